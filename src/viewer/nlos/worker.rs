//! Reconstructions off the UI thread: one named thread per open capture takes the
//! latest request (method and volume), runs [`reconstruct`] on the capture already in
//! memory (no re-rendering), makes the three max-intensity projections and publishes
//! them behind a lock that guards a pointer swap. Requests that arrive while one runs
//! replace each other; only the newest is computed next. The thread ends when the view
//! is dropped (its sender closes); the UI never joins it.

use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tprf_core::nlos::files::LoadedCapture;
use tprf_core::nlos::reconstruct::{Method, Volume, reconstruct};

/// What to reconstruct.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Request {
    pub method: Method,
    pub volume: Volume,
}

/// One max-intensity projection: `width x height` values, row-major.
#[derive(Clone, Debug)]
pub struct Projection {
    pub width: usize,
    pub height: usize,
    pub values: Vec<f32>,
}

/// A finished reconstruction, as the window shows it.
#[derive(Clone, Debug)]
pub struct Finished {
    pub request: Request,
    /// Front (along `n`: `[Y][X]`), top (along `v`: `[Z][X]`), side (along `u`: `[Y][Z]`).
    pub projections: [Projection; 3],
    /// The peak voxel and its centre, world metres.
    pub peak_voxel: [usize; 3],
    pub peak_m: [f32; 3],
    /// Largest value of the volume (the projections' common white).
    pub max: f32,
    pub seconds: f64,
}

/// The worker's state as the window reads it.
#[derive(Clone, Debug, Default)]
pub struct Status {
    /// The request being computed and when it started.
    pub running: Option<(Request, Instant)>,
    /// The last reconstruction that succeeded (kept on screen while a newer one runs or
    /// after one fails).
    pub finished: Option<Arc<Finished>>,
    /// Why the last request failed (and which it was), until one succeeds.
    pub error: Option<(Option<Request>, String)>,
    /// Counts finished results: textures key on it.
    pub generation: u64,
}

/// The reconstruction thread of one capture.
pub struct Reconstructor {
    tx: Sender<Request>,
    status: Arc<Mutex<Status>>,
    /// The last request sent (to send a changed one only).
    sent: Option<Request>,
}

impl Reconstructor {
    /// Start the thread for `capture`; `wake` is called when a result is published.
    pub fn spawn(capture: Arc<LoadedCapture>, wake: impl Fn() + Send + 'static) -> Reconstructor {
        let (tx, rx) = channel::<Request>();
        let status = Arc::new(Mutex::new(Status::default()));
        let shared = status.clone();
        // Cannot fail but for want of a thread; then the status says so.
        let spawned = std::thread::Builder::new()
            .name("tprf-nlos-reconstruct".into())
            .spawn(move || run(&capture, &rx, &shared, &wake));
        if let Err(e) = spawned
            && let Ok(mut s) = status.lock()
        {
            s.error = Some((None, format!("cannot start the reconstruction thread: {e}")));
        }
        Reconstructor {
            tx,
            status,
            sent: None,
        }
    }

    /// Ask for `request` unless it is the one last asked for.
    pub fn request(&mut self, request: Request) {
        if self.sent == Some(request) {
            return;
        }
        self.sent = Some(request);
        // A closed channel means the thread is gone (it panicked): said by `status`.
        let _ = self.tx.send(request);
    }

    /// The last request sent.
    pub fn sent(&self) -> Option<Request> {
        self.sent
    }

    /// The worker's state now (a clone of a few pointers).
    pub fn status(&self) -> Status {
        match self.status.lock() {
            Ok(s) => s.clone(),
            Err(p) => p.into_inner().clone(),
        }
    }
}

/// The thread: the newest request, computed, published; until the sender closes.
fn run(capture: &LoadedCapture, rx: &Receiver<Request>, status: &Mutex<Status>, wake: &dyn Fn()) {
    while let Ok(mut request) = rx.recv() {
        while let Ok(newer) = rx.try_recv() {
            request = newer;
        }
        let started = Instant::now();
        if let Ok(mut s) = status.lock() {
            s.running = Some((request, started));
        }
        wake();
        // A panic in a method is a message, and the thread lives on for the next request.
        let result =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| compute(capture, request)))
                .unwrap_or_else(|_| {
                    Err(format!(
                        "the {} reconstruction failed (a panic)",
                        request.method.name()
                    ))
                })
                .map(Arc::new);
        if let Ok(mut s) = status.lock() {
            s.running = None;
            s.generation += 1;
            match result {
                Ok(f) => {
                    s.finished = Some(f);
                    s.error = None;
                }
                Err(e) => s.error = Some((Some(request), e)),
            }
        }
        wake();
    }
}

/// Reconstruct and project.
fn compute(capture: &LoadedCapture, request: Request) -> Result<Finished, String> {
    let r = reconstruct(capture, request.method, &request.volume, None).map_err(|e| {
        // The core's messages name the command line's flags.
        e.to_string().replace("--volume: ", "volume: ")
    })?;
    let peak_voxel = r.peak();
    let peak_m = r
        .volume
        .voxel_center(peak_voxel[0], peak_voxel[1], peak_voxel[2])
        .to_array();
    let max = r
        .values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0f32, f32::max);
    let [front, top, side] = r.projections().map(|(width, height, values)| Projection {
        width,
        height,
        values,
    });
    Ok(Finished {
        request,
        projections: [front, top, side],
        peak_voxel,
        peak_m,
        max,
        seconds: r.seconds,
    })
}

//! The renderer on a background thread: makes a [`RenderRequest`] ready (loads the
//! scene, builds the BVH, picks the time window), then adds passes until told to stop,
//! publishing a [`FilmSnapshot`] after each. Readers (the viewer) take the latest
//! snapshot and status without ever waiting for a pass: the worker holds its locks only
//! to swap a pointer.

use super::{RenderRequest, RequestError, Session};
use crate::film::{FilmSnapshot, LeftOutCounts, StoreStats, TimeAxis};
use crate::scene::{Camera, Scene};
use crate::transport::Renderer;
use crate::transport::ambient::{AmbientImage, has_ambient, render_ambient_cancellable};
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Where the worker is.
#[derive(Clone, Debug, PartialEq)]
pub enum WorkerState {
    Loading,
    Rendering,
    Paused,
    Done,
    /// The message of the [`RequestError`] that ended it, its causes included.
    Failed(String),
}

/// `error` and its causes, `: `-separated (as `anyhow` prints them with `{:#}`).
fn message_chain(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut cause = error.source();
    while let Some(e) = cause {
        let more = e.to_string();
        // A cause its parent's message already quotes is not repeated.
        if !text.ends_with(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        cause = e.source();
    }
    text
}

/// The worker's progress, copied out for readers.
#[derive(Clone, Debug)]
pub struct WorkerStatus {
    pub state: WorkerState,
    pub spp: u64,
    pub passes: u64,
    /// Wall seconds since rendering began (pauses excluded, snapshot making included),
    /// at the end of the last pass.
    pub elapsed_s: f64,
    /// When the last pass ended (its status written): a reader adds the time since to
    /// `elapsed_s` while rendering, for a clock that runs between passes.
    pub updated_at: Option<Instant>,
    /// Seconds spent loading the scene, building the BVH and choosing the window.
    pub setup_s: f64,
    pub passes_per_s: f64,
    pub rays: u64,
    /// (elapsed seconds, relative error estimate) after each pass with both halves.
    pub error_history: Vec<(f64, f64)>,
    pub axis: Option<TimeAxis>,
    /// When the surfaces' returns arrive in a scene with media ([`Session::surface_returns_s`]):
    /// where a view of it opens.
    pub surface_returns_s: Option<f64>,
    pub triangles: usize,
    pub notes: Vec<String>,
    /// Bins and bytes the film stores, against a dense cube.
    pub store: StoreStats,
    /// Work left out so far: light that could not arrive inside the window.
    pub left_out: LeftOutCounts,
    /// Whether the scene's ambient image is still to come (the scene has ambient
    /// light and [`RenderWorker::ambient`] has none yet).
    pub ambient_pending: bool,
    /// Why the render is paused by itself: its next pass would not fit in memory
    /// ([`super::MemoryStop`], in words). Resuming tries the pass again (memory may
    /// have been freed meanwhile), and pauses again with a new message if it still
    /// does not fit.
    pub memory_stop: Option<String>,
}

struct Shared {
    snapshot: Mutex<Option<Arc<FilmSnapshot>>>,
    ambient: Mutex<Option<Arc<AmbientImage>>>,
    /// The scene prepared and seen from the request's camera, once loaded.
    renderer: Mutex<Option<Arc<Renderer>>>,
    status: Mutex<WorkerStatus>,
    paused: AtomicBool,
    stop: AtomicBool,
}

/// A running render. Dropping it stops the thread (after at most one pass) without
/// waiting for it.
pub struct RenderWorker {
    shared: Arc<Shared>,
    job: Arc<RenderRequest>,
    handle: Option<JoinHandle<()>>,
}

/// Seconds the first passes take, short enough to keep a young image fresh; later
/// passes grow to 4 times that ([`progressive::PACED_GROWTH`]) so that a pass's merge
/// into the film and its snapshot stay a small part of it.
const PASS_TARGET_S: f64 = 0.25;

/// Samples per pixel of the ambient image the worker renders once, after the film's
/// first pass, when the scene has ambient light.
pub const AMBIENT_SPP: u32 = 16;

impl RenderWorker {
    /// Start rendering `job`: its passes paced (`PASS_TARGET_S` at first) unless it
    /// sets `pass_seconds`, and until stopped unless it sets a target (`spp`,
    /// `error_target`; `seconds`); `on_update` is called after each published change
    /// (the viewer passes its repaint request).
    pub fn spawn(job: RenderRequest, on_update: impl Fn() + Send + Sync + 'static) -> RenderWorker {
        RenderWorker::start(job, None, on_update)
    }

    /// [`RenderWorker::spawn`], but on the scene `previous` has loaded and prepared
    /// (its BVH too) where `job` differs from `previous`'s request only in what
    /// [`RenderRequest::same_scene`] allows (a new camera): the scene is not read again.
    /// Otherwise, or while `previous` is still loading, `job` loads its scene as
    /// [`RenderWorker::spawn`] does. The window's camera moves restart this way.
    pub fn spawn_after(
        job: RenderRequest,
        previous: &RenderWorker,
        on_update: impl Fn() + Send + Sync + 'static,
    ) -> RenderWorker {
        let reuse = previous
            .renderer()
            .filter(|_| previous.job().same_scene(&job));
        RenderWorker::start(job, reuse, on_update)
    }

    fn start(
        job: RenderRequest,
        reuse: Option<Arc<Renderer>>,
        on_update: impl Fn() + Send + Sync + 'static,
    ) -> RenderWorker {
        let job = Arc::new(RenderRequest {
            pass_seconds: job.pass_seconds.or(Some(PASS_TARGET_S)),
            until_stopped: true,
            ..job
        });
        let shared = Arc::new(Shared {
            snapshot: Mutex::new(None),
            ambient: Mutex::new(None),
            renderer: Mutex::new(None),
            status: Mutex::new(WorkerStatus {
                state: WorkerState::Loading,
                spp: 0,
                passes: 0,
                elapsed_s: 0.0,
                updated_at: None,
                setup_s: 0.0,
                passes_per_s: 0.0,
                rays: 0,
                error_history: Vec::new(),
                axis: None,
                surface_returns_s: None,
                triangles: 0,
                notes: Vec::new(),
                store: StoreStats::default(),
                left_out: LeftOutCounts::default(),
                ambient_pending: false,
                memory_stop: None,
            }),
            paused: AtomicBool::new(false),
            stop: AtomicBool::new(false),
        });
        let thread_shared = shared.clone();
        let thread_job = job.clone();
        let handle = std::thread::Builder::new()
            .name("tprf-render".into())
            .spawn(move || {
                let result = run(&thread_job, reuse, &thread_shared, &on_update);
                if let Err(e) = result
                    && let Ok(mut s) = thread_shared.status.lock()
                {
                    s.state = WorkerState::Failed(message_chain(&e));
                }
                on_update();
            })
            .ok();
        if handle.is_none()
            && let Ok(mut s) = shared.status.lock()
        {
            s.state = WorkerState::Failed("cannot start the render thread".into());
        }
        RenderWorker {
            shared,
            job,
            handle,
        }
    }

    /// The request rendered (with the worker's pacing: `pass_seconds` set,
    /// `until_stopped`).
    pub fn job(&self) -> &RenderRequest {
        &self.job
    }

    /// The latest published film, if any pass has finished.
    pub fn latest(&self) -> Option<Arc<FilmSnapshot>> {
        self.shared.snapshot.lock().ok().and_then(|s| s.clone())
    }

    /// The scene's ambient image ([`AMBIENT_SPP`] samples per pixel), once rendered;
    /// `None` before, and for a scene without ambient light.
    pub fn ambient(&self) -> Option<Arc<AmbientImage>> {
        self.shared.ambient.lock().ok().and_then(|a| a.clone())
    }

    /// The scene rendered: loaded, with the request's sky and medium applied; its
    /// camera the scene's own (the window's "reset to the scene's camera"), the one
    /// rendered is [`RenderWorker::camera`]. `None` while loading and after a failed
    /// load. The session's own scene, shared.
    pub fn scene(&self) -> Option<Arc<Scene>> {
        self.renderer().map(|r| r.scene_shared().clone())
    }

    /// The camera rendered: the scene's with the request's pose applied (the window's
    /// camera controls start from it; saved in the glTF from the window). `None` while
    /// loading and after a failed load.
    pub fn camera(&self) -> Option<Camera> {
        self.renderer().map(|r| *r.camera())
    }

    /// The scene prepared for transport (BVH, lights), seen from the request's camera,
    /// once loaded: what [`RenderWorker::spawn_after`] reuses.
    pub fn renderer(&self) -> Option<Arc<Renderer>> {
        self.shared.renderer.lock().ok().and_then(|r| r.clone())
    }

    pub fn status(&self) -> Option<WorkerStatus> {
        self.shared.status.lock().ok().map(|s| s.clone())
    }

    pub fn set_paused(&self, paused: bool) {
        self.shared.paused.store(paused, Ordering::Relaxed);
    }

    pub fn is_paused(&self) -> bool {
        self.shared.paused.load(Ordering::Relaxed)
    }

    /// Whether the thread has ended (done, failed or stopped).
    pub fn is_finished(&self) -> bool {
        self.handle.as_ref().is_none_or(|h| h.is_finished())
    }
}

impl Drop for RenderWorker {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        // Not joined: the thread ends after its current pass, and the UI must not wait.
        if let Some(h) = self.handle.take()
            && h.is_finished()
        {
            let _ = h.join();
        }
    }
}

/// Nice value of the render pool's threads: the UI thread (nice 0) needs a few
/// milliseconds a frame and is scheduled before them when both want a core (Linux's
/// fair scheduler weighs nice 10 at a tenth of nice 0), while on an otherwise idle
/// machine the renderer loses nothing. The viewer on 2 cores: a frame that found the
/// core taken by a render thread waited for its time slice.
const RENDER_NICE: i32 = 10;

/// Lower the calling thread's priority to [`RENDER_NICE`] (Linux, where a nice value is
/// per thread; elsewhere the threads keep the process's priority). Raising a priority
/// needs privileges, lowering does not, so this cannot fail in a way that matters.
fn give_way_to_the_caller() {
    #[cfg(target_os = "linux")]
    // SAFETY: setpriority with `who = 0` changes only the calling thread's nice value.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, 0, RENDER_NICE);
    }
}

fn set_status(shared: &Shared, f: impl FnOnce(&mut WorkerStatus)) {
    if let Ok(mut s) = shared.status.lock() {
        f(&mut s);
    }
}

fn run(
    job: &RenderRequest,
    reuse: Option<Arc<Renderer>>,
    shared: &Shared,
    on_update: &(dyn Fn() + Sync),
) -> Result<(), RequestError> {
    let setup_start = Instant::now();
    // One core stays with the caller (the viewer's UI thread) so frames keep their pace.
    let threads = job.threads.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .saturating_sub(1)
            .max(1)
    });
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("tprf-pass-{i}"))
        .start_handler(|_| give_way_to_the_caller())
        .build()
        .map_err(RequestError::Threads)?;
    pool.install(|| render(job, reuse, shared, on_update, setup_start))
}

fn render(
    job: &RenderRequest,
    reuse: Option<Arc<Renderer>>,
    shared: &Shared,
    on_update: &(dyn Fn() + Sync),
    setup_start: Instant,
) -> Result<(), RequestError> {
    let mut session = match reuse {
        Some(previous) => Session::with_renderer(job, &previous)?,
        None => Session::new(job)?,
    };
    if let Ok(mut slot) = shared.renderer.lock() {
        *slot = Some(session.shared_renderer());
    }
    let notes = session.scene().notes.clone();
    let triangles = session.scene().triangles.len();
    let mut ambient_pending = has_ambient(session.renderer());
    let axis = session.axis();
    let surface_returns_s = session.surface_returns_s();
    set_status(shared, |s| {
        s.state = WorkerState::Rendering;
        s.setup_s = setup_start.elapsed().as_secs_f64();
        s.updated_at = Some(Instant::now());
        s.axis = Some(axis);
        s.surface_returns_s = surface_returns_s;
        s.triangles = triangles;
        s.notes = notes;
        s.ambient_pending = ambient_pending;
    });
    on_update();
    let mut retired: Option<Arc<FilmSnapshot>> = None;
    let mut paused_time = Duration::ZERO;
    let mut stopped = shared.stop.load(Ordering::Relaxed);
    if !stopped {
        // The ambient image is rendered from inside the pass callback, which borrows the
        // session's film: it gets its own handle on the renderer.
        let renderer = session.shared_renderer();
        // The snapshot published and the one retired share rows a pass rebuilds.
        session.hold_snapshots(2);
        // Seconds rendered by earlier runs (a run resumed after a memory stop starts
        // its clock again), and by this one at its last pass.
        let (mut carried_s, mut last_s) = (0.0, 0.0);
        loop {
            session.run(|report, film| {
                // Snapshots are made here, on the render pool, not by the reader.
                let snapshot = Arc::new(film.snapshot());
                let error = snapshot.error_estimate;
                // The snapshot replaced now is kept one more pass and freed here, on the
                // render thread: a reader holding it during its frame would otherwise free
                // it there (unmapping a large film takes the UI tens of milliseconds).
                let replaced = shared
                    .snapshot
                    .lock()
                    .ok()
                    .and_then(|mut s| s.replace(snapshot));
                drop(std::mem::replace(&mut retired, replaced));
                let secs = carried_s + (report.wall_s - paused_time.as_secs_f64()).max(0.0);
                last_s = secs;
                set_status(shared, |s| {
                    s.state = WorkerState::Rendering;
                    s.spp = report.spp;
                    s.passes = film.passes();
                    s.elapsed_s = secs;
                    s.updated_at = Some(Instant::now());
                    s.passes_per_s = film.passes() as f64 / secs.max(1e-9);
                    s.rays = report.rays;
                    s.store = film.store_stats();
                    s.left_out = report.left_out;
                    if let Some(e) = error {
                        s.error_history.push((secs, e));
                    }
                });
                on_update();
                // The ambient image, once, after the first pass has been shown (the
                // window has a picture meanwhile; a stop cancels it).
                if ambient_pending {
                    ambient_pending = false;
                    let image = render_ambient_cancellable(
                        &renderer,
                        job.width,
                        job.height,
                        AMBIENT_SPP,
                        &shared.stop,
                    );
                    if let (Some(image), Ok(mut slot)) = (image, shared.ambient.lock()) {
                        *slot = Some(Arc::new(image));
                    }
                    set_status(shared, |s| s.ambient_pending = false);
                    on_update();
                }
                let pause_start = Instant::now();
                let mut was_paused = false;
                while shared.paused.load(Ordering::Relaxed) && !shared.stop.load(Ordering::Relaxed)
                {
                    was_paused = true;
                    set_status(shared, |s| s.state = WorkerState::Paused);
                    std::thread::sleep(Duration::from_millis(30));
                }
                paused_time += pause_start.elapsed();
                if was_paused {
                    // The clock runs on from the end of the pause.
                    set_status(shared, |s| s.updated_at = Some(Instant::now()));
                }
                if shared.stop.load(Ordering::Relaxed) {
                    stopped = true;
                    return ControlFlow::Break(());
                }
                ControlFlow::Continue(())
            });
            // Stopped for memory: paused with the message until resumed (the pass is
            // tried again) or stopped.
            let Some(memory) = session.memory_stop().map(|m| m.to_string()) else {
                break;
            };
            shared.paused.store(true, Ordering::Relaxed);
            set_status(shared, |s| {
                s.state = WorkerState::Paused;
                s.memory_stop = Some(memory);
            });
            on_update();
            while shared.paused.load(Ordering::Relaxed) && !shared.stop.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(30));
            }
            if shared.stop.load(Ordering::Relaxed) {
                stopped = true;
                break;
            }
            set_status(shared, |s| {
                s.state = WorkerState::Rendering;
                s.memory_stop = None;
                s.updated_at = Some(Instant::now());
            });
            (carried_s, paused_time) = (last_s, Duration::ZERO);
        }
    }
    if !stopped {
        set_status(shared, |s| s.state = WorkerState::Done);
        on_update();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::request::apply_camera;
    use std::path::PathBuf;

    /// A small render of `scene` to 1 spp, from `position` looking at the room's
    /// middle where given (else the scene's camera).
    fn small(scene: &str, position: Option<[f64; 3]>) -> RenderRequest {
        RenderRequest {
            width: 12,
            height: 10,
            bins: 24,
            spp: Some(1),
            camera_position_m: position,
            look_at_m: position.map(|_| [0.0, 0.3, 0.0]),
            ..RenderRequest::new(scene)
        }
    }

    /// Every pixel's every bin, and the steady image, as bits.
    fn bits(film: &FilmSnapshot) -> (Vec<u32>, Vec<u32>) {
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        (bits(&film.dense(None)), bits(film.steady()))
    }

    /// A new camera on a prepared scene (`Session::with_renderer`) renders what the
    /// scene loaded again with that camera renders, bit for bit (the same ray offsets,
    /// window and sampling), from the same scene and BVH (shared, not rebuilt), with the
    /// camera the request's pose makes of the scene's own, and another image than the
    /// scene's camera gives. The camera is placed outside the scene's bounds, so the
    /// bounds (and the ray offsets they set) are the new camera's, not the old one's.
    #[test]
    fn a_new_camera_on_a_prepared_scene_renders_what_a_load_renders() {
        let moved = small("builtin:cornell", Some([2.5, 1.6, 3.5]));
        let mut loaded = Session::new(&moved).unwrap();
        loaded.run(|_, _| ControlFlow::Continue(()));
        let mut first = Session::new(&small("builtin:cornell", None)).unwrap();
        first.run(|_, _| ControlFlow::Continue(()));
        let mut kept = Session::with_renderer(&moved, first.renderer()).unwrap();
        kept.run(|_, _| ControlFlow::Continue(()));

        assert!(Arc::ptr_eq(kept.scene(), first.scene()), "the scene copied");
        assert!(
            std::ptr::eq(kept.renderer().accel(), first.renderer().accel()),
            "the BVH built again"
        );
        let want = apply_camera(&moved, &first.scene().camera).unwrap();
        assert_eq!(*kept.camera(), want);
        assert_eq!(*loaded.camera(), want);
        assert_ne!(*first.camera(), want);
        assert_eq!(kept.axis(), loaded.axis());
        let (a, b) = (kept.film().snapshot(), loaded.film().snapshot());
        assert!(bits(&a) == bits(&b), "not the film a load renders");
        assert!(a.steady().iter().any(|&v| v > 0.0), "a black image");
        assert!(
            bits(&a) != bits(&first.film().snapshot()),
            "the old camera's film"
        );
    }

    /// Wait up to 60 s for `w`'s first film; its state when it failed instead.
    fn first_film(w: &RenderWorker) -> Result<Arc<FilmSnapshot>, String> {
        let start = Instant::now();
        loop {
            if let Some(s) = w.latest() {
                return Ok(s);
            }
            if let Some(WorkerState::Failed(e)) = w.status().map(|s| s.state) {
                return Err(e);
            }
            assert!(start.elapsed() < Duration::from_secs(60), "no film in 60 s");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// The window's camera restart (`spawn_after`) does not read the scene again: with
    /// the glTF file deleted after the first render, a new camera still renders the
    /// scene first loaded, from the new pose. A plain spawn, and a restart that changes
    /// the scene's sky, read the file (and so fail here).
    #[test]
    fn a_camera_restart_does_not_read_the_scene_again() {
        let dir: PathBuf =
            std::env::temp_dir().join(format!("tprf-worker-restart-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("cornell.gltf");
        let cornell = crate::scene::load("builtin:cornell").unwrap();
        crate::scene::gltf_save::save_gltf(&cornell, &path).unwrap();
        let file = path.display().to_string();

        let first = RenderWorker::spawn(small(&file, None), || {});
        first_film(&first).unwrap();
        std::fs::remove_file(&path).unwrap();
        let moved = small(&file, Some([0.4, 0.8, 2.2]));
        let second = RenderWorker::spawn_after(moved.clone(), &first, || {});
        let film = first_film(&second).expect("a camera restart reads the file");
        assert!(film.steady().iter().any(|&v| v > 0.0), "a black image");
        let (a, b) = (first.scene().unwrap(), second.scene().unwrap());
        assert!(Arc::ptr_eq(&a, &b), "the scene loaded again");
        assert_eq!(second.status().unwrap().triangles, cornell.triangles.len());
        assert_eq!(
            second.camera().unwrap(),
            apply_camera(&moved, &cornell.camera).unwrap()
        );
        // The scene's own camera stays the file's (the window resets to it).
        assert_eq!(b.camera, cornell.camera);

        let loads = RenderWorker::spawn(moved.clone(), || {});
        assert!(first_film(&loads).is_err(), "a plain spawn read no file");
        let sky = RenderRequest {
            sky_radiance_w_m2_sr: Some(0.5),
            ..moved
        };
        let other = RenderWorker::spawn_after(sky, &second, || {});
        assert!(
            first_film(&other).is_err(),
            "a new sky rendered on the old scene"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}

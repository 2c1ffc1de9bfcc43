//! `tprf.render` and `tprf.Renderer`: a `RenderRequest` rendered from Python.
//!
//! The render runs on a thread of its own (in the request's rayon pool) while the
//! calling thread waits with the GIL released, waking every [`POLL`] to report passes
//! to the progress callback and to check for Ctrl-C: an interrupt raises
//! `KeyboardInterrupt` at once and the render stops at the end of the pass it is in.

use pyo3::exceptions::{PyMemoryError, PyRuntimeError};
use pyo3::prelude::*;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use tprf_core::film::TprfFilm;
use tprf_core::request::{self, Observer, RenderRequest, Session};
use tprf_core::transport::progressive::PassReport;

use crate::cube::Cube;
use crate::errors::IntoPy;

/// `tprf.json`'s `format` of a cube not written to files (`Cube.save` writes its own).
pub(crate) const IN_MEMORY: &str =
    "tprf cube in memory, not saved: Cube.save writes tprf.npy or tprf.zarr";

/// How often the waiting thread wakes to report progress and check for Ctrl-C.
const POLL: Duration = Duration::from_millis(50);

/// A request from its JSON form (the Python layer's dict of `tprf render`'s option
/// names), a Mitsuba scene file's settings in the keys it does not give
/// ([`RenderRequest::with_file_defaults`]), validated; with what came from the file. A
/// field that cannot be read is named (`dt: ...`); a scene file that cannot be read
/// raises its error (`FileNotFoundError` for a missing one).
pub fn request_from_json(json: &str) -> PyResult<(RenderRequest, Vec<String>)> {
    let fields: serde_json::Map<String, serde_json::Value> = serde_json::from_str(json)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("the request: {e}")))?;
    let given = |key: &str| fields.contains_key(key);
    let value = serde_json::Value::Object(fields.clone());
    let mut request: RenderRequest = serde_path_to_error::deserialize(&value).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner().to_string();
        // serde_json ends its messages with a position in the JSON text the user
        // never saw.
        let inner = match inner.rfind(" at line ") {
            Some(i) => inner[..i].to_string(),
            None => inner,
        };
        pyo3::exceptions::PyValueError::new_err(match path.as_str() {
            "." | "" => inner,
            _ => format!("{path}: {inner}"),
        })
    })?;
    let file = tprf_core::scene::file_settings(&request.scene).py_err()?;
    let notes = request.with_file_defaults(&file, given);
    request.validate().py_err()?;
    Ok((request, notes.iter().map(ToString::to_string).collect()))
}

/// resolve_request(request_json) -> (str, list[str])
///
/// The request (JSON with ``tprf render``'s option names) with a Mitsuba scene file's
/// film, sample count and depth in the keys it does not give, validated, as JSON; and
/// what came from the file, one line each.
#[pyfunction]
pub fn resolve_request(request_json: &str) -> PyResult<(String, Vec<String>)> {
    let (request, notes) = request_from_json(request_json)?;
    let text = serde_json::to_string(&request)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
    Ok((text, notes))
}

/// What the render thread tells the waiting one after each pass.
pub(crate) struct Pass {
    pub spp: u64,
    pub passes: u64,
    pub error_estimate: Option<f64>,
    pub wall_s: f64,
}

/// The render thread's observer: passes sent to the waiting thread; the render ends at
/// the next pass once `cancel` is set (an interrupt) or `stop` says so.
pub(crate) struct Reporter<F> {
    pub tx: Sender<Pass>,
    pub cancel: Arc<AtomicBool>,
    pub stop: F,
}

impl<F: FnMut(&PassReport, &TprfFilm) -> bool + Send> Observer for Reporter<F> {
    fn pass(&mut self, report: &PassReport, film: &TprfFilm) -> ControlFlow<()> {
        let _ = self.tx.send(Pass {
            spp: report.spp,
            passes: report.pass + 1,
            error_estimate: film.half_error_estimate(),
            wall_s: report.wall_s,
        });
        if self.cancel.load(Ordering::Relaxed) || (self.stop)(report, film) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    fn writing(&mut self) -> ControlFlow<()> {
        if self.cancel.load(Ordering::Relaxed) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }
}

/// Why [`wait`] returned without the render thread's result.
pub(crate) enum Stopped<T> {
    /// Ctrl-C, another signal's exception, or the progress callback's: the thread runs
    /// on to the end of its pass, and is handed back.
    Interrupted(PyErr, JoinHandle<T>),
    /// The thread panicked.
    Failed(PyErr),
}

pub(crate) fn panicked() -> PyErr {
    PyRuntimeError::new_err("the render thread panicked (a bug in tprf: please report it)")
}

/// Wait for the render thread `handle` with the GIL released, calling `progress(spp,
/// passes, error_estimate, wall_s)` after each pass it reports on `rx`. Ctrl-C (or any
/// pending signal's exception) sets `cancel` and is returned at once.
pub(crate) fn wait<T: Send + 'static>(
    py: Python<'_>,
    handle: JoinHandle<T>,
    rx: Receiver<Pass>,
    cancel: &AtomicBool,
    progress: Option<&Bound<'_, PyAny>>,
) -> Result<T, Stopped<T>> {
    // A receiver is not Sync: the closure that waits (GIL released) borrows it through
    // a lock only this thread takes.
    let rx = Mutex::new(rx);
    loop {
        let next = py.detach(|| match rx.lock() {
            Ok(rx) => rx.recv_timeout(POLL),
            Err(_) => Err(RecvTimeoutError::Disconnected),
        });
        match next {
            Ok(p) => {
                if let Some(cb) = progress
                    && let Err(e) = cb.call1((p.spp, p.passes, p.error_estimate, p.wall_s))
                {
                    cancel.store(true, Ordering::Relaxed);
                    return Err(Stopped::Interrupted(e, handle));
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if let Err(e) = py.check_signals() {
            cancel.store(true, Ordering::Relaxed);
            return Err(Stopped::Interrupted(e, handle));
        }
    }
    py.detach(|| handle.join())
        .map_err(|_| Stopped::Failed(panicked()))
}

/// render(request_json, progress=None) -> Cube
///
/// Render a request (JSON with ``tprf render``'s option names; ``tprf.render`` builds
/// it) in memory: the same passes, film and metadata as ``tprf render`` with the same
/// settings and seed.
#[pyfunction]
#[pyo3(signature = (request_json, progress=None))]
pub fn render(
    py: Python<'_>,
    request_json: &str,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<Cube> {
    let (request, _) = request_from_json(request_json)?;
    let cancel = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let handle = {
        let cancel = cancel.clone();
        std::thread::Builder::new()
            .name("tprf render".into())
            .spawn(move || {
                let mut reporter = Reporter {
                    tx,
                    cancel,
                    stop: |_: &PassReport, _: &TprfFilm| false,
                };
                request::render(&request, &mut reporter)
            })
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start the render thread: {e}")))?
    };
    let rendered = match wait(py, handle, rx, &cancel, progress.as_ref()) {
        Ok(r) => r.py_err()?,
        Err(Stopped::Interrupted(e, _) | Stopped::Failed(e)) => return Err(e),
    };
    let snap = py.detach(|| rendered.film.snapshot());
    drop(rendered.film);
    let mut meta = rendered.meta;
    meta.format = IN_MEMORY.into();
    Cube::from_snapshot(
        py,
        &snap,
        meta,
        rendered.ambient.map(|(image, _)| image.radiance),
    )
}

/// The session of a `Renderer` and what runs it.
struct Inner {
    /// `None` while a run's thread holds it.
    session: Option<Session>,
    /// The thread of a run interrupted by Ctrl-C, which hands the session back at the
    /// end of its pass.
    pending: Option<JoinHandle<(Session, Vec<PassReport>)>>,
    pool: Arc<rayon::ThreadPool>,
    threads: usize,
    /// Each run's pass reports.
    runs: Vec<Vec<PassReport>>,
    /// Wall time spent in passes, seconds.
    wall_s: f64,
}

/// Renderer(request_json)
///
/// A render made progressively: ``run`` adds passes (for some seconds, up to some
/// samples per pixel, or until the request's own target), ``cube`` is the film so far.
/// ``tprf.Renderer`` builds it and iterates over passes.
#[pyclass(module = "tprf._tprf", name = "Renderer")]
pub struct Renderer {
    inner: Mutex<Inner>,
    request: RenderRequest,
}

impl Renderer {
    /// The session back from a run Ctrl-C interrupted (waiting, GIL released, for the
    /// end of its pass).
    fn settle(py: Python<'_>, inner: &mut Inner) -> PyResult<()> {
        if let Some(h) = inner.pending.take() {
            let (session, reports) = py.detach(|| h.join()).map_err(|_| panicked())?;
            inner.wall_s += reports.last().map_or(0.0, |r| r.wall_s);
            inner.runs.push(reports);
            inner.session = Some(session);
        }
        Ok(())
    }

    fn locked(&self) -> PyResult<std::sync::MutexGuard<'_, Inner>> {
        self.inner
            .try_lock()
            .map_err(|_| PyRuntimeError::new_err("this Renderer is in use by another thread"))
    }
}

#[pymethods]
impl Renderer {
    /// Validate the request, load its scene and choose its time window (a pilot render
    /// where the request does not fix it), with the GIL released.
    #[new]
    fn new(py: Python<'_>, request_json: &str) -> PyResult<Renderer> {
        let (request, _) = request_from_json(request_json)?;
        let pool = request.thread_pool().py_err()?;
        let threads = pool.current_num_threads();
        let session = py
            .detach(|| pool.install(|| Session::new(&request)))
            .py_err()?;
        Ok(Renderer {
            inner: Mutex::new(Inner {
                session: Some(session),
                pending: None,
                pool: Arc::new(pool),
                threads,
                runs: Vec::new(),
                wall_s: 0.0,
            }),
            request,
        })
    }

    /// run(seconds=None, spp=None, passes=None, progress=None) -> bool
    ///
    /// Add passes until ``seconds`` of wall time have passed, the film holds ``spp``
    /// samples per pixel, ``passes`` passes were made, or the request's own target
    /// (``spp``, ``seconds``, ``error_target``) is met, whichever comes first; a pass
    /// is never cut. Returns whether the request's target is met (then ``run`` adds
    /// nothing more). ``progress(spp, passes, error_estimate, wall_s)`` is called after
    /// each pass.
    #[pyo3(signature = (seconds=None, spp=None, passes=None, progress=None))]
    fn run(
        &self,
        py: Python<'_>,
        seconds: Option<f64>,
        spp: Option<u64>,
        passes: Option<u64>,
        progress: Option<Bound<'_, PyAny>>,
    ) -> PyResult<bool> {
        if let Some(s) = seconds
            && !(s.is_finite() && s >= 0.0)
        {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "seconds = {s} must be a finite number >= 0"
            )));
        }
        let mut inner = self.locked()?;
        Renderer::settle(py, &mut inner)?;
        let Some(mut session) = inner.session.take() else {
            return Err(PyRuntimeError::new_err("this Renderer lost its film"));
        };
        let cancel = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel();
        let pool = inner.pool.clone();
        let handle = {
            let cancel = cancel.clone();
            std::thread::Builder::new()
                .name("tprf render".into())
                .spawn(move || {
                    let start = Instant::now();
                    let mut made = 0u64;
                    let mut reporter = Reporter {
                        tx,
                        cancel,
                        stop: move |_: &PassReport, film: &TprfFilm| {
                            made += 1;
                            seconds.is_some_and(|s| start.elapsed().as_secs_f64() >= s)
                                || spp.is_some_and(|n| film.spp() >= n)
                                || passes.is_some_and(|n| made >= n)
                        },
                    };
                    // Nothing to do: no pass.
                    let nothing = spp.is_some_and(|n| session.film().spp() >= n)
                        || passes == Some(0)
                        || seconds == Some(0.0);
                    let reports = if nothing {
                        Vec::new()
                    } else {
                        pool.install(|| session.run(|r, film| reporter.pass(r, film)))
                    };
                    (session, reports)
                })
                .map_err(|e| {
                    PyRuntimeError::new_err(format!("cannot start the render thread: {e}"))
                })?
        };
        match wait(py, handle, rx, &cancel, progress.as_ref()) {
            Ok((session, reports)) => {
                inner.wall_s += reports.last().map_or(0.0, |r| r.wall_s);
                inner.runs.push(reports);
                let done = session_done(&self.request, &session);
                let stop = session.memory_stop().map(|m| m.to_string());
                inner.session = Some(session);
                match stop {
                    // The film keeps the passes made; a later run tries the pass again.
                    Some(message) => Err(PyMemoryError::new_err(message)),
                    None => Ok(done),
                }
            }
            Err(Stopped::Interrupted(e, handle)) => {
                inner.pending = Some(handle);
                Err(e)
            }
            Err(Stopped::Failed(e)) => Err(e),
        }
    }

    /// The film so far as a ``Cube`` (its metadata as ``tprf render`` would write it
    /// now; no ambient image).
    fn cube(&self, py: Python<'_>) -> PyResult<Cube> {
        let mut inner = self.locked()?;
        Renderer::settle(py, &mut inner)?;
        let inner = &*inner;
        let Some(session) = &inner.session else {
            return Err(PyRuntimeError::new_err("this Renderer lost its film"));
        };
        let (snap, meta) = py.detach(|| {
            let meta = request::cube_metadata(session, inner.threads, inner.wall_s, &inner.runs);
            (session.film().snapshot(), meta)
        });
        let mut meta = meta.py_err()?;
        meta.format = IN_MEMORY.into();
        Cube::from_snapshot(py, &snap, meta, None)
    }

    /// Samples per pixel in the film.
    #[getter]
    fn spp(&self, py: Python<'_>) -> PyResult<u64> {
        let mut inner = self.locked()?;
        Renderer::settle(py, &mut inner)?;
        Ok(inner.session.as_ref().map_or(0, |s| s.film().spp()))
    }

    /// Passes made.
    #[getter]
    fn passes(&self, py: Python<'_>) -> PyResult<u64> {
        let mut inner = self.locked()?;
        Renderer::settle(py, &mut inner)?;
        Ok(inner.runs.iter().map(|r| r.len() as u64).sum())
    }

    /// The film's relative RMS error estimated from two independent halves of its
    /// samples (None before two passes).
    #[getter]
    fn error_estimate(&self, py: Python<'_>) -> PyResult<Option<f64>> {
        let mut inner = self.locked()?;
        Renderer::settle(py, &mut inner)?;
        Ok(inner
            .session
            .as_ref()
            .and_then(|s| s.film().half_error_estimate()))
    }

    /// Whether the request's own target (``spp``, ``seconds``, ``error_target``) is met.
    #[getter]
    fn done(&self, py: Python<'_>) -> PyResult<bool> {
        let mut inner = self.locked()?;
        Renderer::settle(py, &mut inner)?;
        Ok(inner
            .session
            .as_ref()
            .is_some_and(|s| session_done(&self.request, s)))
    }

    /// The request's settings, as ``tprf render``'s option names (a dict).
    #[getter]
    fn request<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = serde_json::to_string(&self.request)
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    fn __repr__(&self) -> String {
        let r = &self.request;
        format!(
            "<tprf.Renderer {} x {} pixels x {} bins of {}>",
            r.height, r.width, r.bins, r.scene
        )
    }
}

/// Whether `session`'s film met its request's target: the spp target, the time budget
/// (wall time in passes) or the error target.
fn session_done(request: &RenderRequest, session: &Session) -> bool {
    let film = session.film();
    request.spp_target().is_some_and(|n| film.spp() >= n)
        || request
            .error_target
            .zip(film.half_error_estimate())
            .is_some_and(|(t, e)| e <= t)
}

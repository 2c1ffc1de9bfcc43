//! `tprf.Differentiable`: a render request differentiable with respect to named scene
//! parameters (tprf-core's `request::Differentiable`). Forward and backward renders run
//! on a thread of their own while the calling thread waits with the GIL released,
//! reporting progress and raising `KeyboardInterrupt` at Ctrl-C as `tprf.render` does.

use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tprf_core::film::TprfFilm;
use tprf_core::request::{Differentiable as Core, DifferentiableError};
use tprf_core::transport::progressive::PassReport;

use crate::cube::Cube;
use crate::errors::to_py;
use crate::render::{IN_MEMORY, Pass, Reporter, Stopped, panicked, request_from_json, wait};

/// A [`DifferentiableError`] as a Python exception: `RuntimeError` for a backward
/// before any forward, else as the core's other errors (`ValueError` for bad input).
fn py_err(e: DifferentiableError) -> PyErr {
    match e {
        DifferentiableError::NoForward => PyRuntimeError::new_err(e.to_string()),
        e => to_py(&e),
    }
}

/// Differentiable(request_json, wrt)
///
/// The request (JSON with ``tprf render``'s option names; ``tprf.Differentiable`` builds
/// it) differentiable with respect to the parameters named in ``wrt``. Its window is
/// fixed now (a pilot render where ``t0``/``dt`` are not given).
#[pyclass(module = "tprf._tprf", name = "Differentiable")]
pub struct Differentiable {
    inner: Arc<Mutex<Core>>,
}

impl Differentiable {
    fn locked(&self) -> PyResult<std::sync::MutexGuard<'_, Core>> {
        self.inner
            .try_lock()
            .map_err(|_| PyRuntimeError::new_err("this Differentiable is in use by another thread"))
    }
}

#[pymethods]
impl Differentiable {
    #[new]
    fn new(py: Python<'_>, request_json: &str, wrt: Vec<String>) -> PyResult<Differentiable> {
        let (request, _) = request_from_json(request_json)?;
        let core = py.detach(|| Core::new(&request, &wrt)).map_err(py_err)?;
        Ok(Differentiable {
            inner: Arc::new(Mutex::new(core)),
        })
    }

    /// The parameters' names, in ``wrt``'s order.
    #[getter]
    fn names(&self) -> PyResult<Vec<String>> {
        Ok(self.locked()?.names().to_vec())
    }

    /// The values the next forward renders at: the last given, else the scene's own.
    #[getter]
    fn values(&self) -> PyResult<Vec<f64>> {
        Ok(self.locked()?.values().to_vec())
    }

    /// ``(t0_s, dt_s, bins)``: the time axis of every cube.
    #[getter]
    fn axis(&self) -> PyResult<(f64, f64, usize)> {
        let a = self.locked()?.axis();
        Ok((a.t0_s, a.dt_s, a.bins))
    }

    /// ``(height, width, bins)``: the shape of every cube and of the weights.
    #[getter]
    fn shape(&self) -> PyResult<(usize, usize, usize)> {
        let d = self.locked()?;
        let r = d.request();
        Ok((r.height, r.width, d.axis().bins))
    }

    /// forward(values, seed, progress=None) -> Cube
    ///
    /// The cube at ``values`` (``[(name, value)]``; names not given keep their values).
    #[pyo3(signature = (values, seed, progress=None))]
    fn forward(
        &self,
        py: Python<'_>,
        values: Vec<(String, f64)>,
        seed: u64,
        progress: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Cube> {
        drop(self.locked()?);
        let inner = self.inner.clone();
        let cancel = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel();
        let handle = {
            let cancel = cancel.clone();
            std::thread::Builder::new()
                .name("tprf forward".into())
                .spawn(move || {
                    let mut reporter = Reporter {
                        tx,
                        cancel,
                        stop: |_: &PassReport, _: &TprfFilm| false,
                    };
                    let mut d = inner.lock().map_err(|_| DifferentiableError::Interrupted)?;
                    d.forward(&values, seed, &mut reporter)
                })
                .map_err(|e| {
                    PyRuntimeError::new_err(format!("cannot start the render thread: {e}"))
                })?
        };
        let done = match wait(py, handle, rx, &cancel, progress.as_ref()) {
            Ok(r) => r.map_err(py_err)?,
            Err(Stopped::Interrupted(e, _) | Stopped::Failed(e)) => return Err(e),
        };
        let snap = py.detach(|| done.film.snapshot());
        let mut meta = done.meta;
        meta.format = IN_MEMORY.into();
        Cube::from_snapshot(py, &snap, meta, None)
    }

    /// backward(weights, seed, progress=None) -> list[float]
    ///
    /// ``dL/dtheta`` for ``L = sum(weights * cube)`` at the last forward's values, one
    /// per name; ``weights`` float32 ``[H, W, T]`` (C order).
    #[pyo3(signature = (weights, seed, progress=None))]
    fn backward(
        &self,
        py: Python<'_>,
        weights: Bound<'_, PyArrayDyn<f32>>,
        seed: u64,
        progress: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Vec<f64>> {
        let (h, w, t) = self.shape()?;
        let shape = weights.shape().to_vec();
        if shape != [h, w, t] {
            return Err(PyValueError::new_err(format!(
                "weights: shape {shape:?}; the cube is [{h}, {w}, {t}]"
            )));
        }
        let weights = weights.readonly().as_slice()?.to_vec();
        let inner = self.inner.clone();
        let cancel = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel();
        let handle = {
            let cancel = cancel.clone();
            std::thread::Builder::new()
                .name("tprf backward".into())
                .spawn(move || {
                    let start = Instant::now();
                    let d = inner.lock().map_err(|_| DifferentiableError::Interrupted)?;
                    let mut chunks = 0u64;
                    d.backward(&weights, seed, |done, _total| {
                        chunks += 1;
                        let _ = tx.send(Pass {
                            spp: done,
                            passes: chunks,
                            error_estimate: None,
                            wall_s: start.elapsed().as_secs_f64(),
                        });
                        if cancel.load(Ordering::Relaxed) {
                            ControlFlow::Break(())
                        } else {
                            ControlFlow::Continue(())
                        }
                    })
                })
                .map_err(|e| {
                    PyRuntimeError::new_err(format!("cannot start the render thread: {e}"))
                })?
        };
        match wait(py, handle, rx, &cancel, progress.as_ref()) {
            Ok(r) => r.map_err(py_err),
            Err(Stopped::Interrupted(e, _)) => Err(e),
            Err(Stopped::Failed(_)) => Err(panicked()),
        }
    }
}

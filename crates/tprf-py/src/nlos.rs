//! `tprf.nlos.capture` and `tprf.nlos.reconstruct`: a `CaptureRequest` and a
//! `ReconstructRequest` run from Python, their results as numpy arrays.
//!
//! As `tprf.render`: the work runs on a thread of its own (in the request's rayon pool)
//! while the calling thread waits with the GIL released, waking every [`POLL`] to
//! report the sensor points done to the progress callback and to check for Ctrl-C, which
//! raises `KeyboardInterrupt` at once (a capture then stops at the sensor points
//! running; a reconstruction runs on to its end, its result dropped).

use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;
use tprf_core::nlos::Capture;
use tprf_core::nlos::files::{CaptureMetadata, LoadedCapture, VolumeMetadata};
use tprf_core::nlos::reconstruct::Reconstruction;
use tprf_core::request::{CaptureObserver, CaptureRequest, Quiet, ReconstructRequest};

use crate::cube::read_only;
use crate::errors::IntoPy;

/// How often the waiting thread wakes to report progress and check for Ctrl-C.
const POLL: Duration = Duration::from_millis(50);

/// The request's fields from JSON (the Python layer's dict of the command's option
/// names) and the keys given; a field that cannot be read is named.
fn from_json<T: serde::de::DeserializeOwned>(
    json: &str,
) -> PyResult<(T, serde_json::Map<String, serde_json::Value>)> {
    let fields: serde_json::Map<String, serde_json::Value> = serde_json::from_str(json)
        .map_err(|e| PyValueError::new_err(format!("the request: {e}")))?;
    let value = serde_json::Value::Object(fields.clone());
    let request = serde_path_to_error::deserialize(&value).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner().to_string();
        // serde_json ends its messages with a position in the JSON text the user
        // never saw.
        let inner = match inner.rfind(" at line ") {
            Some(i) => inner[..i].to_string(),
            None => inner,
        };
        PyValueError::new_err(match path.as_str() {
            "." | "" => inner,
            _ => format!("{path}: {inner}"),
        })
    })?;
    Ok((request, fields))
}

fn json_of(value: &impl serde::Serialize, py: Python<'_>) -> PyResult<Py<PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

/// The capture thread's observer: the points done sent to the waiting thread; the
/// capture cancelled once `cancel` is set (an interrupt).
struct Reporter {
    tx: Sender<(u64, u64)>,
    cancel: Arc<AtomicBool>,
    /// The count last sent (the capture also asks while points run: sent once).
    sent: Option<u64>,
}

impl CaptureObserver for Reporter {
    fn points(&mut self, done: u64, total: u64) -> ControlFlow<()> {
        if self.sent != Some(done) {
            self.sent = Some(done);
            let _ = self.tx.send((done, total));
        }
        if self.cancel.load(Ordering::Relaxed) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }
}

/// Wait for `handle` with the GIL released, calling `progress(done, total)` for each
/// report on `rx` (none for a reconstruction). Ctrl-C (or any pending signal's
/// exception, or the callback's) sets `cancel` and is raised at once.
fn wait<T: Send + 'static>(
    py: Python<'_>,
    handle: JoinHandle<T>,
    rx: mpsc::Receiver<(u64, u64)>,
    cancel: &AtomicBool,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<T> {
    let rx = Mutex::new(rx);
    loop {
        let next = py.detach(|| match rx.lock() {
            Ok(rx) => rx.recv_timeout(POLL),
            Err(_) => Err(RecvTimeoutError::Disconnected),
        });
        match next {
            Ok((done, total)) => {
                if let Some(cb) = progress
                    && let Err(e) = cb.call1((done, total))
                {
                    cancel.store(true, Ordering::Relaxed);
                    return Err(e);
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if let Err(e) = py.check_signals() {
            cancel.store(true, Ordering::Relaxed);
            return Err(e);
        }
    }
    py.detach(|| handle.join()).map_err(|_| {
        PyRuntimeError::new_err("the NLOS thread panicked (a bug in tprf: please report it)")
    })
}

/// A rendered NLOS capture: the transients a SPAD focused on each sensor point of the
/// relay wall records for a unit-energy laser pulse at each laser point. Bin ``b`` covers
/// ``[t0_s + b dt_s, t0_s + (b + 1) dt_s)`` and holds the integral over the bin of the
/// radiance leaving the sensor point toward the SPAD (W m^-2 sr^-1 s per joule).
#[pyclass(module = "tprf._tprf", name = "NlosCapture", frozen)]
pub struct NlosCapture {
    capture: Capture,
    request: CaptureRequest,
    h: Py<PyAny>,
}

#[pymethods]
impl NlosCapture {
    /// ``H``: float32 ``[T, Sx, Sy]`` (single, confocal) or ``[T, Lx, Ly, Sx, Sy]``
    /// (exhaustive), time first as tal's; read-only, no copy.
    #[getter(H)]
    fn h(&self, py: Python<'_>) -> Py<PyAny> {
        self.h.clone_ref(py)
    }

    /// Sensor points on the wall, float32 ``[Sx, Sy, 3]``, metres.
    #[getter]
    fn sensor_grid<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let g = &self.capture.geometry;
        let v: Vec<f32> = g
            .sensors
            .iter()
            .flat_map(|p| p.position.to_array())
            .collect();
        Ok(read_only(PyArray1::from_vec(py, v).reshape([g.grid[0], g.grid[1], 3])?)?.into_any())
    }

    /// Laser points on the wall, float32 ``[Lx, Ly, 3]`` (``[1, 1, 3]`` single; the
    /// sensor grid's confocal), metres.
    #[getter]
    fn laser_grid<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let g = &self.capture.geometry;
        let v: Vec<f32> = g
            .lasers
            .iter()
            .flat_map(|p| p.position.to_array())
            .collect();
        let [lx, ly] = g.laser_grid;
        Ok(read_only(PyArray1::from_vec(py, v).reshape([lx, ly, 3])?)?.into_any())
    }

    /// The relay wall's normal, toward the hidden scene.
    #[getter]
    fn wall_normal(&self) -> [f32; 3] {
        self.capture.geometry.wall.normal.to_array()
    }

    /// The SPAD's and the laser's device positions, metres.
    #[getter]
    fn sensor_origin(&self) -> [f32; 3] {
        self.capture.geometry.sensor_origin.to_array()
    }

    #[getter]
    fn laser_origin(&self) -> [f32; 3] {
        self.capture.geometry.laser_origin.to_array()
    }

    /// Start of the time axis and bin width, seconds; the number of bins.
    #[getter]
    fn t0_s(&self) -> f64 {
        self.capture.geometry.axis.t0_s
    }

    #[getter]
    fn dt_s(&self) -> f64 {
        self.capture.geometry.axis.dt_s
    }

    #[getter]
    fn bins(&self) -> usize {
        self.capture.geometry.axis.bins
    }

    /// Whether times include the device-to-wall legs (tal's
    /// ``t_accounts_first_and_last_bounces``).
    #[getter]
    fn device_legs(&self) -> bool {
        self.capture.geometry.device_legs
    }

    /// ``single``, ``confocal`` or ``exhaustive``.
    #[getter]
    fn scan(&self) -> &'static str {
        match self.capture.geometry.scan {
            tprf_core::nlos::Scan::Single { .. } => "single",
            tprf_core::nlos::Scan::Confocal => "confocal",
            tprf_core::nlos::Scan::Exhaustive { .. } => "exhaustive",
        }
    }

    /// ``nlos.json`` as a dict: the capture as tprf knows it, its request under
    /// ``request``.
    #[getter]
    fn metadata(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let mut meta = CaptureMetadata::of(&self.capture);
        meta.request = serde_json::to_value(&self.request).ok();
        json_of(&meta, py)
    }

    /// The request's settings, by ``tprf nlos``'s option names (a dict).
    #[getter]
    fn request(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        json_of(&self.request, py)
    }

    /// save(folder)
    ///
    /// Write the folder ``tprf nlos --out`` writes (``nlos.hdf5``, ``H.npy``,
    /// ``nlos.json``): a new or empty folder, or an earlier tprf output (replaced whole).
    fn save(&self, py: Python<'_>, folder: PathBuf) -> PyResult<()> {
        py.detach(|| {
            self.request.write_folder(
                &self.capture,
                &folder,
                &[Path::new(&self.request.scene)],
                &mut Quiet,
            )
        })
        .py_err()?;
        Ok(())
    }

    fn __repr__(&self) -> String {
        format!(
            "<tprf.nlos.Capture {} of {}: H {:?}>",
            self.scan(),
            self.capture.scene_name,
            self.capture.shape()
        )
    }
}

/// capture(request_json, progress=None) -> (NlosCapture, list[str])
///
/// Capture a request (JSON with ``tprf nlos``'s option names; ``tprf.nlos.capture``
/// builds it): a Mitsuba NLOS scene's settings in the keys it does not give, the same
/// transients as ``tprf nlos`` with the same settings and seed; with what came from the
/// scene file. ``progress(done, total)`` is called as sensor points are done.
#[pyfunction]
#[pyo3(signature = (request_json, progress=None))]
pub fn capture(
    py: Python<'_>,
    request_json: &str,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<(NlosCapture, Vec<String>)> {
    let (mut request, given): (CaptureRequest, _) = from_json(request_json)?;
    let (scene, notes) = py
        .detach(|| request.load_scene(|k| given.contains_key(k)))
        .py_err()?;
    let notes: Vec<String> = notes.iter().map(ToString::to_string).collect();
    let cancel = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let handle = {
        let cancel = cancel.clone();
        let request = request.clone();
        std::thread::Builder::new()
            .name("tprf nlos".into())
            .spawn(move || {
                let mut reporter = Reporter {
                    tx,
                    cancel,
                    sent: None,
                };
                request.run(Arc::new(scene), &mut reporter)
            })
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start the capture thread: {e}")))?
    };
    let capture = wait(py, handle, rx, &cancel, progress.as_ref())?.py_err()?;
    let shape = capture.shape();
    let h = read_only(PyArray1::from_vec(py, capture.h.clone()).reshape(shape)?)?
        .into_any()
        .unbind();
    Ok((
        NlosCapture {
            capture,
            request,
            h,
        },
        notes,
    ))
}

/// A reconstruction: values on a voxel volume in the relay wall's frame, ``[Z, Y, X]``
/// float32 with X along the wall's ``u``, Y along ``v`` and Z along its normal ``n``
/// (toward the hidden scene). Values are relative (each method's own scale).
#[pyclass(module = "tprf._tprf", name = "NlosVolume", frozen)]
pub struct NlosVolume {
    r: Reconstruction,
    request: ReconstructRequest,
    capture_name: String,
    values: Py<PyAny>,
}

#[pymethods]
impl NlosVolume {
    /// The values, float32 ``[Z, Y, X]``; read-only, no copy.
    #[getter]
    fn values(&self, py: Python<'_>) -> Py<PyAny> {
        self.values.clone_ref(py)
    }

    /// Centre of the volume (world, metres), its size along u, v, n (metres), its voxels
    /// along them, and the axes u, v, n (unit vectors, world).
    #[getter]
    fn center(&self) -> [f32; 3] {
        self.r.volume.center
    }

    #[getter]
    fn size_m(&self) -> [f32; 3] {
        self.r.volume.size_m
    }

    #[getter]
    fn voxels(&self) -> [usize; 3] {
        self.r.volume.voxels
    }

    #[getter]
    fn u(&self) -> [f32; 3] {
        self.r.volume.u
    }

    #[getter]
    fn v(&self) -> [f32; 3] {
        self.r.volume.v
    }

    #[getter]
    fn n(&self) -> [f32; 3] {
        self.r.volume.n
    }

    /// The voxels' centres along u, v and n, metres from the volume's centre: three
    /// float64 arrays of lengths X, Y and Z (a voxel ``[z, y, x]`` is at ``center + u
    /// axes[0][x] + v axes[1][y] + n axes[2][z]``).
    #[getter]
    fn axes<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let vol = &self.r.volume;
        let axis = |k: usize| {
            let (n, s) = (vol.voxels[k], vol.size_m[k] as f64);
            let v: Vec<f64> = (0..n)
                .map(|i| ((i as f64 + 0.5) / n as f64 - 0.5) * s)
                .collect();
            read_only(PyArray1::from_vec(py, v)).map(Bound::into_any)
        };
        Ok((axis(0)?, axis(1)?, axis(2)?))
    }

    /// The voxel ``(x, y, z)`` of the largest value and its centre (world, metres).
    #[getter]
    fn peak_voxel(&self) -> [usize; 3] {
        self.r.peak()
    }

    #[getter]
    fn peak_m(&self) -> [f32; 3] {
        let [x, y, z] = self.r.peak();
        self.r.volume.voxel_center(x, y, z).to_array()
    }

    /// ``bp``, ``fbp``, ``fk`` or ``pf``.
    #[getter]
    fn method(&self) -> &'static str {
        self.r.method.name()
    }

    /// ``volume.json`` as a dict, its request under ``request``.
    #[getter]
    fn metadata(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let peak = self.r.peak();
        json_of(
            &VolumeMetadata {
                format: "tprf-nlos-volume".into(),
                tprf_version: env!("CARGO_PKG_VERSION").into(),
                capture: self.capture_name.clone(),
                method: self.r.method,
                volume: self.r.volume,
                wave: self.r.wave,
                peak_voxel: peak,
                peak_m: self.peak_m(),
                seconds: self.r.seconds,
                request: serde_json::to_value(&self.request).ok(),
            },
            py,
        )
    }

    /// The request's settings, by ``tprf nlos reconstruct``'s option names (a dict).
    #[getter]
    fn request(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        json_of(&self.request, py)
    }

    /// save(folder)
    ///
    /// Write the folder ``tprf nlos reconstruct --out`` writes (``volume.npy``,
    /// ``volume.json``, ``mip_front.png``, ``mip_top.png``, ``mip_side.png``).
    fn save(&self, py: Python<'_>, folder: PathBuf) -> PyResult<()> {
        py.detach(|| self.request.write_folder(&self.r, &folder))
            .py_err()?;
        Ok(())
    }

    fn __repr__(&self) -> String {
        let [x, y, z] = self.r.volume.voxels;
        format!(
            "<tprf.nlos.Volume {} of {}: {z} x {y} x {x} voxels [Z, Y, X]>",
            self.r.method.name(),
            self.capture_name
        )
    }
}

/// reconstruct(request_json, capture=None) -> NlosVolume
///
/// Reconstruct a request (JSON with ``tprf nlos reconstruct``'s option names;
/// ``tprf.nlos.reconstruct`` builds it): the capture in memory when given, else the
/// folder or HDF5 file its ``capture`` names. The same volume as ``tprf nlos
/// reconstruct`` with the same settings.
#[pyfunction]
#[pyo3(signature = (request_json, capture=None))]
pub fn reconstruct(
    py: Python<'_>,
    request_json: &str,
    capture: Option<Py<NlosCapture>>,
) -> PyResult<NlosVolume> {
    let (mut request, _): (ReconstructRequest, _) = from_json(request_json)?;
    request.validate().py_err()?;
    let loaded = match &capture {
        Some(c) => {
            let c = c.get();
            let name = format!("(in memory: a capture of {})", c.capture.scene_name);
            request.capture = PathBuf::from(&name);
            Some(py.detach(|| LoadedCapture::of(&c.capture, PathBuf::from(name))))
        }
        None => None,
    };
    let capture_name = request.capture.display().to_string();
    let handle = {
        let request = request.clone();
        std::thread::Builder::new()
            .name("tprf nlos reconstruct".into())
            .spawn(move || match &loaded {
                Some(c) => request.run_on(c),
                None => request.run(),
            })
            .map_err(|e| {
                PyRuntimeError::new_err(format!("cannot start the reconstruction thread: {e}"))
            })?
    };
    let r = wait_for(py, handle)?.py_err()?;
    let [nx, ny, nz] = r.volume.voxels;
    let values = read_only(PyArray1::from_vec(py, r.values.clone()).reshape([nz, ny, nx])?)?
        .into_any()
        .unbind();
    Ok(NlosVolume {
        r,
        request,
        capture_name,
        values,
    })
}

/// Wait for a thread that reports nothing, with the GIL released, woken every [`POLL`]
/// to check for Ctrl-C (raised at once; the thread runs on to its end, unseen).
fn wait_for<T: Send + 'static>(py: Python<'_>, handle: JoinHandle<T>) -> PyResult<T> {
    while !handle.is_finished() {
        py.detach(|| std::thread::sleep(POLL));
        py.check_signals()?;
    }
    py.detach(|| handle.join()).map_err(|_| {
        PyRuntimeError::new_err("the NLOS thread panicked (a bug in tprf: please report it)")
    })
}

//! `tprf.Cube`: a transient cube as numpy arrays, and `tprf.load`.

use numpy::{PyArray1, PyArray2, PyArray3, PyArray4, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use tprf_core::export::{self, CubeFormat, CubeMetadata};
use tprf_core::film::{FilmLayout, FilmSnapshot, TimeAxis};
use tprf_core::request;

use crate::errors::IntoPy;

/// A transient cube: per pixel the radiance against arrival time for a unit-energy pulse
/// leaving the light at t = 0. Bin ``b`` covers ``[t0_s + b dt_s, t0_s + (b + 1) dt_s)``
/// and holds the integral over the bin of the pixel's radiance (W m^-2 sr^-1 s per unit
/// pulse energy): summed over bins it is the steady radiance (W m^-2 sr^-1).
#[pyclass(module = "tprf._tprf", name = "Cube", frozen)]
pub struct Cube {
    data: Py<PyArray3<f32>>,
    steady: Py<PyArray2<f32>>,
    bounces: Option<Py<PyArray4<f32>>>,
    ambient: Option<Py<PyArray2<f32>>>,
    /// The phasors `[H, W, F, 2]` at the frequencies of `meta.phasor`, when it has them.
    phasor: Option<Py<PyArray4<f32>>>,
    meta: CubeMetadata,
}

/// `array`, no longer writeable: a cube's arrays are its data and its metadata's, which
/// an edit in place would make lie (`np.array(cube)` is a writeable copy).
pub(crate) fn read_only<'py, A: pyo3::PyTypeInfo>(array: Bound<'py, A>) -> PyResult<Bound<'py, A>> {
    let kwargs = PyDict::new(array.py());
    kwargs.set_item("write", false)?;
    array.as_any().call_method("setflags", (), Some(&kwargs))?;
    Ok(array)
}

impl Cube {
    /// The cube of `snap` with its metadata `meta` and, where the render made one, its
    /// ambient image (`meta.ambient` is dropped without it): the dense arrays built
    /// once, held as read-only numpy arrays that `.data` and the others hand out without
    /// copying. The values are those `tprf render` writes to `tprf.npy` (the same rows,
    /// [`FilmSnapshot::dense`]).
    pub fn from_snapshot(
        py: Python<'_>,
        snap: &FilmSnapshot,
        mut meta: CubeMetadata,
        ambient: Option<Vec<f32>>,
    ) -> PyResult<Cube> {
        let (h, w, t) = (snap.height(), snap.width(), snap.axis().bins);
        let layers = snap.layers();
        let (data, steady, bounces, phasor) = py.detach(|| {
            let data = snap.dense(None);
            let steady = snap.steady().to_vec();
            let bounces: Vec<f32> = (0..layers).flat_map(|l| snap.dense(Some(l))).collect();
            // The phasors from the bins, as `phasor.npy` is written.
            let phasor = meta.phasor.as_ref().map(|p| {
                export::phasor::phasors(snap, &p.frequencies_per_m, p.time_filter)
                    .map(|v| (v, p.frequencies_per_m.len()))
            });
            (data, steady, bounces, phasor)
        });
        let phasor = match phasor.transpose().py_err()? {
            Some((v, nf)) => {
                Some(read_only(PyArray1::from_vec(py, v).reshape([h, w, nf, 2])?)?.unbind())
            }
            None => None,
        };
        let data = read_only(PyArray1::from_vec(py, data).reshape([h, w, t])?)?.unbind();
        let steady = read_only(PyArray1::from_vec(py, steady).reshape([h, w])?)?.unbind();
        let bounces = if layers > 0 {
            Some(read_only(PyArray1::from_vec(py, bounces).reshape([layers, h, w, t])?)?.unbind())
        } else {
            None
        };
        let ambient = match ambient {
            Some(a) if a.len() == h * w => {
                Some(read_only(PyArray1::from_vec(py, a).reshape([h, w])?)?.unbind())
            }
            _ => None,
        };
        if ambient.is_none() {
            meta.ambient = None;
        }
        Ok(Cube {
            data,
            steady,
            bounces,
            ambient,
            phasor,
            meta,
        })
    }

    pub fn meta(&self) -> &CubeMetadata {
        &self.meta
    }

    /// The cube's `[H, W, T]` array.
    pub fn data_array(&self) -> &Py<PyArray3<f32>> {
        &self.data
    }

    /// The bounce layers `[L, H, W, T]`, when rendered.
    pub fn bounces_array(&self) -> Option<&Py<PyArray4<f32>>> {
        self.bounces.as_ref()
    }

    /// The ambient image `[H, W]`, when the scene has one.
    pub fn ambient_array(&self) -> Option<&Py<PyArray2<f32>>> {
        self.ambient.as_ref()
    }
}

#[pymethods]
impl Cube {
    /// The cube, float32 ``[H, W, T]``, row 0 = the top of the image (no copy).
    #[getter]
    fn data<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        self.data.bind(py).clone()
    }

    /// The steady image, float32 ``[H, W]`` (W m^-2 sr^-1): each pixel's sum over time.
    #[getter]
    fn steady<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        self.steady.bind(py).clone()
    }

    /// The per-bounce layers, float32 ``[K + 2, H, W, T]`` (layer 0: light seen directly,
    /// 1..K: that many scattering events, K + 1: more; in a scene with a luminescent
    /// material one more, K + 2, the light it re-emitted, the others holding the rest:
    /// ``metadata["luminescence_layer"]``), or None when not rendered
    /// (``bounces_separate=0``).
    #[getter]
    fn bounces<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray4<f32>>> {
        self.bounces.as_ref().map(|b| b.bind(py).clone())
    }

    /// The ambient image, float32 ``[H, W]`` (W m^-2 sr^-1: the steady radiance of the
    /// scene's unpulsed light, sky and lamps), or None when the scene has none.
    #[getter]
    fn ambient<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f32>>> {
        self.ambient.as_ref().map(|a| a.bind(py).clone())
    }

    /// The phasors, float32 ``[H, W, F, 2]`` (real, imaginary), row 0 = top, at
    /// mitransient's frequencies for the render's ``phasor`` band (``metadata["phasor"]``
    /// lists them in 1/m and Hz), computed from the cube's bins as ``phasor.npy`` is;
    /// None when the render asked for none.
    #[getter]
    fn phasor<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray4<f32>>> {
        self.phasor.as_ref().map(|p| p.bind(py).clone())
    }

    /// save(dir, format="auto", frames=False)
    ///
    /// Write the cube as ``tprf render`` writes its folder (``tprf.npy`` or, for
    /// ``format="zarr"`` or a dense cube over 4 GiB with ``"auto"``, ``tprf.zarr``; with
    /// ``tprf.json``, ``steady.png``, the bounce layers, the ambient image and, with
    /// ``frames=True``, ``frames/``), into a new folder swapped in whole. ``dir`` must
    /// be new, empty or an earlier tprf output (a folder of other files is refused,
    /// never overwritten).
    #[pyo3(signature = (dir, format="auto", frames=false))]
    fn save(&self, py: Python<'_>, dir: PathBuf, format: &str, frames: bool) -> PyResult<()> {
        let format: CubeFormat = format
            .parse()
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("format: {e}")))?;
        let m = &self.meta;
        let (h, w, t) = (m.height, m.width, m.bins);
        let data = self.data.bind(py).readonly();
        let bounces = self.bounces.as_ref().map(|b| b.bind(py).readonly());
        let ambient = self.ambient.as_ref().map(|a| a.bind(py).readonly());
        let data = data.as_slice()?;
        let bounces = match &bounces {
            Some(b) => b.as_slice()?,
            None => &[],
        };
        let ambient = match &ambient {
            Some(a) => Some(a.as_slice()?),
            None => None,
        };
        let format = format.resolve(&[h as u64, w as u64, t as u64]);
        py.detach(|| {
            let layout = FilmLayout {
                width: w,
                height: h,
                axis: TimeAxis::new(m.t0_s, m.dt_s, t)?,
                bounces_separate: m.bounces_separate,
                luminescence: m.luminescence_layer,
            };
            let snap =
                FilmSnapshot::from_dense(layout, m.spp, m.passes, data, bounces, m.error_estimate);
            let steady: Vec<f64> = data
                .chunks_exact(t.max(1))
                .map(|px| px.iter().map(|&v| f64::from(v)).sum())
                .collect();
            struct Quiet;
            impl request::Observer for Quiet {}
            request::write_folder(
                &snap,
                &steady,
                m.clone(),
                ambient,
                format,
                frames,
                &dir,
                &[],
                &mut Quiet,
            )
            .map(|_| ())
            .map_err(|e| Box::new(e) as Box<dyn std::error::Error + Send + Sync>)
        })
        .map_err(|e| crate::errors::to_py(&*e))
    }

    /// Start of the time window, seconds.
    #[getter]
    fn t0_s(&self) -> f64 {
        self.meta.t0_s
    }

    /// Bin width, seconds.
    #[getter]
    fn dt_s(&self) -> f64 {
        self.meta.dt_s
    }

    /// The centre of every bin, seconds, float64 ``[T]``.
    #[getter]
    fn times_s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let m = &self.meta;
        PyArray1::from_vec(
            py,
            (0..m.bins)
                .map(|b| m.t0_s + (b as f64 + 0.5) * m.dt_s)
                .collect(),
        )
    }

    /// The cube's relative RMS error estimated from two independent halves of its
    /// samples, or None.
    #[getter]
    fn error_estimate(&self) -> Option<f64> {
        self.meta.error_estimate
    }

    /// The cube's metadata: the ``tprf.json`` a render writes, as a dict.
    #[getter]
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = serde_json::to_string(&self.meta)
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// ``(H, W, T)``.
    #[getter]
    fn shape(&self) -> (usize, usize, usize) {
        (self.meta.height, self.meta.width, self.meta.bins)
    }

    /// numpy's array protocol: ``np.asarray(cube)`` is ``cube.data`` (no copy, unless a
    /// dtype or ``copy=True`` asks for one).
    #[pyo3(signature = (dtype=None, copy=None))]
    fn __array__<'py>(
        &self,
        py: Python<'py>,
        dtype: Option<Bound<'py, PyAny>>,
        copy: Option<bool>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let data = self.data.bind(py).clone().into_any();
        let kwargs = PyDict::new(py);
        if let Some(d) = dtype {
            kwargs.set_item("dtype", d)?;
        }
        if copy == Some(true) {
            kwargs.set_item("copy", true)?;
        }
        if kwargs.is_empty() {
            return Ok(data);
        }
        py.import("numpy")?
            .getattr("array")?
            .call((data,), Some(&kwargs))
    }

    fn __repr__(&self) -> String {
        let m = &self.meta;
        format!(
            "<tprf.Cube {} x {} pixels x {} bins of {} from {}, {} spp, {}>",
            m.height,
            m.width,
            m.bins,
            tprf_core::units::format_time(m.dt_s),
            tprf_core::units::format_time(m.t0_s),
            m.spp,
            m.scene
        )
    }
}

/// load(dir) -> Cube
///
/// Read a cube folder written by ``tprf render`` (``tprf.npy`` or ``tprf.zarr``, with
/// ``tprf.json`` and, where present, the per-bounce layers), or by ``Cube.save``.
#[pyfunction]
pub fn load(py: Python<'_>, dir: PathBuf) -> PyResult<Cube> {
    let (meta, snap, ambient) = py
        .detach(|| {
            let (meta, snap) = export::load_snapshot(&dir)?;
            let ambient = export::ambient::load_ambient(&dir, &meta)?;
            Ok::<_, export::ExportError>((meta, snap, ambient))
        })
        .py_err()?;
    Cube::from_snapshot(py, &snap, meta, ambient)
}

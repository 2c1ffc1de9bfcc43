//! `tprf.Sensor` and `tprf.Measurement`: `tprf sensor` from Python.
//!
//! A `Sensor` is tprf-core's [`Sensor`] (a preset, a TOML file, or gates and a light
//! given as `kind:key=value,...`); its editable numbers are attributes of its parts
//! (`sensor.light`, `sensor.exposure`, `sensor.noise`, `sensor.spad`) read and written
//! through the parts' own field descriptions ([`tprf_core::sensor::fields`]), so no
//! variant is mirrored here. `Sensor.measure` follows `tprf sensor`'s steps in the
//! core's one order ([`tprf_core::sensor::pipeline`]) with the GIL released, on the
//! cube in memory or on a render folder; `Measurement.save` writes `tprf sensor`'s
//! folder through the core's writers.

use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use numpy::ndarray::{ArrayView, IxDyn};
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods};
use pyo3::exceptions::{PyAttributeError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use tprf_core::export::sensor::{
    DEFAULT_TILE_BYTES, SensorCube, SensorRun, measure_cube, multipath_error, write_sensor_outputs,
    write_spad_image,
};
use tprf_core::export::staging::Staging;
use tprf_core::sensor::spad::Sampler;
use tprf_core::sensor::{
    BUILTIN_PRESETS, Derived, Draws, Exposure, Field, Gates, LightPulse, Measurements, Pipeline,
    Point, Quantity, ReturnImages, Sensor, SensorModel, SpadImage, TimeOrigin,
};
use tprf_core::units::{format_time, parse_time_s};

use crate::cube::{Cube, read_only};
use crate::errors::{IntoPy, to_py};

type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// A part of a sensor whose numbers are fields ([`Field`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Part {
    Light,
    Exposure,
    Noise,
    Spad,
}

impl Part {
    fn name(self) -> &'static str {
        match self {
            Part::Light => "light",
            Part::Exposure => "exposure",
            Part::Noise => "noise",
            Part::Spad => "spad",
        }
    }

    /// The part's fields now; `None` for a SPAD the sensor does not have.
    fn fields(self, s: &Sensor) -> Option<Vec<Field>> {
        match self {
            Part::Light => Some(s.light.fields()),
            Part::Exposure => Some(s.exposure.fields()),
            Part::Noise => Some(s.noise.fields()),
            Part::Spad => s.spad.as_ref().map(|p| p.fields()),
        }
    }

    fn set(self, s: &mut Sensor, key: &str, value: f64) -> bool {
        match self {
            Part::Light => s.light.set_field(key, value),
            Part::Exposure => s.exposure.set_field(key, value),
            Part::Noise => s.noise.set_field(key, value),
            Part::Spad => s.spad.as_mut().is_some_and(|p| p.set_field(key, value)),
        }
    }

    /// The kind of pulse or gates (`gaussian`, `box`), for the parts that have kinds.
    fn kind(self, s: &Sensor) -> Option<&'static str> {
        match self {
            Part::Light => Some(s.light.kind_name()),
            Part::Exposure => Some(s.exposure.kind_name()),
            Part::Noise | Part::Spad => None,
        }
    }

    fn knots(self, s: &Sensor) -> Option<&[Point]> {
        match self {
            Part::Light => s.light.knots(),
            Part::Exposure => s.exposure.knots(),
            Part::Noise | Part::Spad => None,
        }
    }

    fn knots_mut(self, s: &mut Sensor) -> Option<&mut Vec<Point>> {
        match self {
            Part::Light => s.light.knots_mut(),
            Part::Exposure => s.exposure.knots_mut(),
            Part::Noise | Part::Spad => None,
        }
    }
}

/// A field's unit, as its value is given and read from Python.
fn unit(q: Quantity) -> &'static str {
    match q {
        Quantity::Time => "s",
        Quantity::Energy => "J",
        Quantity::Count => "",
        Quantity::Number => "",
        Quantity::Frequency => "Hz",
        Quantity::Rate => "1/s",
        Quantity::Degrees => "deg",
    }
}

/// `v` of quantity `q` to read: a time in its best unit, a count whole.
fn show(q: Quantity, v: f64) -> String {
    match q {
        Quantity::Time => format_time(v),
        Quantity::Count => format!("{v:.0}"),
        Quantity::Frequency if v >= 1e3 => {
            let (f, u) = [(1e9, "GHz"), (1e6, "MHz"), (1e3, "kHz")]
                .into_iter()
                .find(|(f, _)| v >= *f)
                .unwrap_or((1.0, "Hz"));
            format!("{} {u}", v / f)
        }
        _ => match unit(q) {
            "" => format!("{v}"),
            u => format!("{v} {u}"),
        },
    }
}

/// A field's value as Python reads it: an int for a count, else a float (SI units).
fn field_value(py: Python<'_>, f: &Field) -> PyResult<Py<PyAny>> {
    Ok(if f.quantity == Quantity::Count {
        (f.value.round() as u64)
            .into_pyobject(py)?
            .into_any()
            .unbind()
    } else {
        f.value.into_pyobject(py)?.into_any().unbind()
    })
}

/// A time given from Python: seconds (a number) or text with a unit (`"2ns"`, `"30cm"`
/// of optical path).
fn time_arg(what: &str, value: &Bound<'_, PyAny>) -> PyResult<f64> {
    if let Ok(text) = value.extract::<String>() {
        return parse_time_s(&text).map_err(|e| PyValueError::new_err(format!("{what}: {e}")));
    }
    let v: f64 = value.extract().map_err(|_| {
        PyValueError::new_err(format!(
            "{what}: expected seconds (a number) or a time with a unit (\"2ns\")"
        ))
    })?;
    Ok(v)
}

/// The number `value` for field `f` of `part`: a time may be text with a unit; a count
/// must be whole; every value within the field's range.
fn field_arg(part: Part, f: &Field, value: &Bound<'_, PyAny>) -> PyResult<f64> {
    let what = format!("{}.{}", part.name(), f.key);
    let v = if f.quantity == Quantity::Time {
        time_arg(&what, value)?
    } else {
        value.extract::<f64>().map_err(|_| {
            PyValueError::new_err(format!(
                "{what}: expected a number{}",
                match unit(f.quantity) {
                    "" => String::new(),
                    u => format!(" ({u})"),
                }
            ))
        })?
    };
    if !v.is_finite() {
        return Err(PyValueError::new_err(format!(
            "{what} = {v} is not a finite number"
        )));
    }
    if f.quantity == Quantity::Count && v.fract() != 0.0 {
        return Err(PyValueError::new_err(format!(
            "{what} = {v} must be a whole number"
        )));
    }
    if !(f.min..=f.max).contains(&v) {
        return Err(PyValueError::new_err(format!(
            "{what} = {}: it must be within {} .. {}",
            show(f.quantity, v),
            show(f.quantity, f.min),
            show(f.quantity, f.max)
        )));
    }
    Ok(v)
}

/// A time-of-flight sensor: a light pulse, a sequence of exposure gates (or a SPAD's
/// TDC bins), noise and derived outputs, as ``tprf sensor`` takes it (docs/sensor.md).
///
/// ``Sensor.preset("builtin:lidar")``, ``Sensor.from_toml(path)``, or
/// ``Sensor(exposure="box:start=10ns,width=1ns,count=32", light="gaussian:fwhm=2ns")``.
/// Edit its numbers as attributes of its parts (times in seconds or as text with a
/// unit): ``sensor.light.fwhm_s = "1ns"``, ``sensor.exposure.count = 64``,
/// ``sensor.noise.sigma = 0.01``, ``sensor.spad.cycles = 10000``; ``part.fields`` lists
/// them with units and ranges. ``sensor.measure(cube)`` measures a cube.
#[pyclass(module = "tprf._tprf", name = "Sensor", eq)]
#[derive(Clone, PartialEq)]
pub struct PySensor {
    pub sensor: Sensor,
}

impl PySensor {
    /// Apply `edit` to the sensor, keeping it only when the whole sensor is still valid
    /// (else the core's message, naming the field, as ValueError).
    fn edit(&mut self, edit: impl FnOnce(&mut Sensor) -> PyResult<()>) -> PyResult<()> {
        let mut s = self.sensor.clone();
        edit(&mut s)?;
        s.validate().py_err()?;
        self.sensor = s;
        Ok(())
    }
}

/// The text of a part: `kind: key=value, ...`.
fn part_text(part: Part, s: &Sensor) -> String {
    let Some(fields) = part.fields(s) else {
        return "none".into();
    };
    let values: Vec<String> = fields
        .iter()
        .map(|f| format!("{}={}", f.key, show(f.quantity, f.value)))
        .collect();
    let mut text = match part.kind(s) {
        Some(k) => format!("{k}: {}", values.join(", ")),
        None => values.join(", "),
    };
    if let Some(k) = part.knots(s) {
        text.push_str(&format!(", {} knots", k.len()));
    }
    if part == Part::Exposure && s.exposure.kind_name() != "amcw" {
        text.push_str(match s.exposure.origin() {
            TimeOrigin::Pulse => " (times from the pulse's trigger)",
            TimeOrigin::Window => " (times from the window's start)",
        });
    }
    text
}

#[pymethods]
impl PySensor {
    /// Sensor(exposure, light=None)
    ///
    /// A sensor from gates and a light pulse as ``tprf sensor``'s ``--exposure`` and
    /// ``--light`` take them: ``KIND:key=value,...``, e.g.
    /// ``"box:start=10ns,width=1ns,count=32"``, ``"amcw:freq=20MHz,phase_steps=4"``,
    /// ``"gaussian:centre=5ns,fwhm=2ns"`` (default light: a unit delta at t = 0). No
    /// noise, no derived outputs.
    #[new]
    #[pyo3(signature = (exposure, light=None))]
    fn new(exposure: &str, light: Option<&str>) -> PyResult<PySensor> {
        let exposure = Exposure::from_spec(exposure).py_err()?;
        let light = match light {
            Some(spec) => LightPulse::from_spec(spec).py_err()?,
            None => LightPulse::default(),
        };
        let sensor = Sensor::new(light, exposure);
        sensor.validate().py_err()?;
        Ok(PySensor { sensor })
    }

    /// preset(spec) -> Sensor
    ///
    /// A preset as ``tprf sensor --preset`` takes it: ``"builtin:NAME"``
    /// (``Sensor.PRESETS``) or the path of a TOML file.
    #[staticmethod]
    fn preset(spec: PathBuf) -> PyResult<PySensor> {
        let spec = spec.to_string_lossy();
        Ok(PySensor {
            sensor: Sensor::load(&spec).py_err()?,
        })
    }

    /// from_toml(path) -> Sensor
    ///
    /// A sensor file (TOML, docs/sensor.md), as ``tprf sensor --preset FILE`` reads it.
    #[staticmethod]
    fn from_toml(path: PathBuf) -> PyResult<PySensor> {
        Ok(PySensor {
            sensor: Sensor::from_path(&path).py_err()?,
        })
    }

    /// The built-in presets: ``"builtin:gated"``, ``"builtin:lidar"``, ...
    #[classattr]
    #[allow(
        non_snake_case,
        reason = "a Python class constant, named as Python names them"
    )]
    fn PRESETS() -> Vec<String> {
        BUILTIN_PRESETS
            .iter()
            .map(|(n, _)| format!("builtin:{n}"))
            .collect()
    }

    /// The sensor as a TOML file (times in seconds), which ``Sensor.from_toml`` and
    /// ``tprf sensor --preset`` read back.
    fn to_toml(&self) -> PyResult<String> {
        self.sensor.to_toml_string().py_err()
    }

    /// A copy to edit apart.
    fn copy(&self) -> PySensor {
        self.clone()
    }

    fn __copy__(&self) -> PySensor {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> PySensor {
        self.clone()
    }

    #[getter]
    fn name(&self) -> &str {
        &self.sensor.name
    }

    #[setter]
    fn set_name(&mut self, name: String) {
        self.sensor.name = name;
    }

    #[getter]
    fn description(&self) -> &str {
        &self.sensor.description
    }

    #[setter]
    fn set_description(&mut self, text: String) {
        self.sensor.description = text;
    }

    /// The light pulse ``Light(t)`` (a power envelope, its integral ``energy`` J):
    /// its numbers are attributes (``sensor.light.fwhm_s``). Set a new pulse as
    /// ``tprf sensor --light`` takes it: ``sensor.light = "gaussian:centre=5ns,fwhm=2ns"``.
    #[getter]
    fn light(slf: &Bound<'_, Self>) -> SensorPart {
        SensorPart {
            owner: slf.clone().unbind(),
            part: Part::Light,
        }
    }

    #[setter]
    fn set_light(&mut self, spec: &str) -> PyResult<()> {
        let light = LightPulse::from_spec(spec).py_err()?;
        self.edit(|s| {
            s.light = light;
            Ok(())
        })
    }

    /// The gates ``Exposure_i(t)`` (dimensionless sensitivities): their numbers are
    /// attributes (``sensor.exposure.count``). Set new gates as ``tprf sensor
    /// --exposure`` takes them: ``sensor.exposure = "box:start=10ns,width=1ns,count=32"``
    /// (derived outputs that no longer fit them are dropped, with a warning).
    #[getter]
    fn exposure(slf: &Bound<'_, Self>) -> SensorPart {
        SensorPart {
            owner: slf.clone().unbind(),
            part: Part::Exposure,
        }
    }

    #[setter]
    fn set_exposure(&mut self, py: Python<'_>, spec: &str) -> PyResult<()> {
        let exposure = Exposure::from_spec(spec).py_err()?;
        let gates = exposure.gates(0.0).py_err()?;
        let mut dropped = None;
        self.edit(|s| {
            s.exposure = exposure;
            if let Err(e) = s.derived.validate(&s.exposure, &gates) {
                dropped = Some(e.to_string());
                s.derived = Derived::default();
            }
            Ok(())
        })?;
        if let Some(why) = dropped {
            warn(
                py,
                &format!("the sensor's derived outputs are dropped: {why}"),
            )?;
        }
        Ok(())
    }

    /// The noise: ``sigma`` (standard deviation of the additive Gaussian noise, in
    /// measurement units) and ``photons_per_energy`` (photon noise; 0: off). Its seed
    /// is ``sensor.seed``.
    #[getter]
    fn noise(slf: &Bound<'_, Self>) -> SensorPart {
        SensorPart {
            owner: slf.clone().unbind(),
            part: Part::Noise,
        }
    }

    /// The SPAD behind the TDC gates (``builtin:spad``), its numbers attributes
    /// (``sensor.spad.cycles``); None for a sensor without one.
    #[getter]
    fn spad(slf: &Bound<'_, Self>) -> Option<SensorPart> {
        slf.borrow().sensor.spad.as_ref().map(|_| SensorPart {
            owner: slf.clone().unbind(),
            part: Part::Spad,
        })
    }

    /// Seed of the noise and of the SPAD's realisation (``noise.seed`` in a file).
    #[getter]
    fn seed(&self) -> u64 {
        self.sensor.noise.seed
    }

    #[setter]
    fn set_seed(&mut self, seed: u64) {
        self.sensor.noise.seed = seed;
    }

    /// Scale of the cube's ambient image (dimensionless, >= 0): 1 = the scene's
    /// unpulsed light at the power it states, 0 = off.
    #[getter]
    fn ambient_scale(&self) -> f64 {
        self.sensor.ambient_scale
    }

    #[setter]
    fn set_ambient_scale(&mut self, value: f64) -> PyResult<()> {
        self.edit(|s| {
            s.ambient_scale = value;
            Ok(())
        })
    }

    /// AMCW only: seconds of ambient light one measurement collects per unit of
    /// emitted energy (1 / the source's mean power in W), or None (AMCW gates then
    /// leave the ambient image out). Set as seconds or text (``"1ms"``).
    #[getter]
    fn ambient_exposure_s(&self) -> Option<f64> {
        self.sensor.ambient_exposure_s
    }

    #[setter]
    fn set_ambient_exposure_s(&mut self, value: Option<Bound<'_, PyAny>>) -> PyResult<()> {
        let t = match value {
            Some(v) => Some(time_arg("ambient_exposure_s", &v)?),
            None => None,
        };
        self.edit(|s| {
            s.ambient_exposure_s = t;
            Ok(())
        })
    }

    /// measure(cube, *, seed=None, ambient_scale=None, ambient_exposure=None,
    /// cycles=None, noise_sigma=None, photons_per_energy=None, pixels=()) -> Measurement
    ///
    /// Measure ``cube`` (a ``tprf.Cube``, or a render folder read as ``tprf sensor``
    /// reads it, a tile at a time) as ``tprf sensor`` does, the same numbers bit for
    /// bit: clean gates ``sum_b TPRF[b] K_i[b]``, the SPAD's histograms, the cube's
    /// ambient image, noise, derived depths. The keywords override the sensor's
    /// settings for this measurement only, as ``tprf sensor``'s options do: ``seed``
    /// (noise and SPAD realisation), ``ambient_scale``, ``ambient_exposure`` (seconds
    /// or ``"1ms"``), ``cycles`` (SPAD laser cycles), ``noise_sigma``,
    /// ``photons_per_energy``; ``pixels``: (row, column) pairs whose traces
    /// ``Measurement.save`` writes as CSV (``--pixel``). The GIL is released meanwhile.
    /// measure_vjp(cube, weights, fields=[]) -> (dict[str, float], ndarray)
    ///
    /// The gradient of ``L = sum(weights * M)``, ``M`` the clean measurement
    /// ``sum_b TPRF[b] K_i[b]`` ``[N, H, W]`` (before ambient light and noise), with
    /// respect to the sensor's ``fields`` (``"light.centre_s"``, ``"exposure.start_s"``,
    /// ...: central differences of the exact kernels, docs/gradients.md) and to the cube
    /// (``sum_i weights[i] K_i``, float32 ``[H, W, T]``: the weights of a
    /// ``Differentiable.backward`` that fits a scene to a measurement).
    #[pyo3(signature = (cube, weights, fields=Vec::new()))]
    fn measure_vjp(
        &self,
        py: Python<'_>,
        cube: &Bound<'_, Cube>,
        weights: Bound<'_, numpy::PyArrayDyn<f32>>,
        fields: Vec<String>,
    ) -> PyResult<(Py<PyDict>, Py<PyAny>)> {
        let cube = cube.get();
        let meta = cube.meta();
        let axis = tprf_core::film::TimeAxis::new(meta.t0_s, meta.dt_s, meta.bins).py_err()?;
        let data = cube.data_array().bind(py).readonly();
        let data = data.as_slice()?;
        let weights = weights.readonly();
        let w = weights.as_slice()?;
        let (width, height) = (meta.width, meta.height);
        let sensor = &self.sensor;
        let vjp = py
            .detach(|| {
                tprf_core::sensor::gradient::measurement_vjp(
                    sensor, axis, data, width, height, w, &fields,
                )
            })
            .py_err()?;
        let out = PyDict::new(py);
        for (name, g) in fields.iter().zip(&vjp.fields) {
            out.set_item(name, g)?;
        }
        let d_cube = PyArray1::from_vec(py, vjp.cube).reshape([height, width, axis.bins])?;
        Ok((out.unbind(), d_cube.into_any().unbind()))
    }

    #[pyo3(signature = (cube, *, seed=None, ambient_scale=None, ambient_exposure=None,
        cycles=None, noise_sigma=None, photons_per_energy=None, pixels=Vec::new()))]
    #[allow(
        clippy::too_many_arguments,
        reason = "Python keyword arguments, one per `tprf sensor` option"
    )]
    fn measure(
        &self,
        py: Python<'_>,
        cube: &Bound<'_, PyAny>,
        seed: Option<u64>,
        ambient_scale: Option<f64>,
        ambient_exposure: Option<Bound<'_, PyAny>>,
        cycles: Option<u64>,
        noise_sigma: Option<f64>,
        photons_per_energy: Option<f64>,
        pixels: Vec<(usize, usize)>,
    ) -> PyResult<Measurement> {
        let mut sensor = self.sensor.clone();
        if let Some(x) = noise_sigma {
            sensor.noise.sigma = x;
        }
        if let Some(x) = photons_per_energy {
            sensor.noise.photons_per_energy = x;
        }
        if let Some(x) = seed {
            sensor.noise.seed = x;
        }
        if let Some(x) = ambient_scale {
            sensor.ambient_scale = x;
        }
        if let Some(t) = ambient_exposure {
            sensor.ambient_exposure_s = Some(time_arg("ambient_exposure", &t)?);
        }
        if let Some(n) = cycles {
            match &mut sensor.spad {
                Some(spad) => spad.cycles = n,
                None => {
                    return Err(PyValueError::new_err(
                        "cycles needs a sensor with a SPAD (e.g. Sensor.preset(\"builtin:spad\"))",
                    ));
                }
            }
        }
        let started = Instant::now();
        let run = if let Ok(cube) = cube.cast::<Cube>() {
            let cube = cube.get();
            let meta = cube.meta();
            let name = PathBuf::from(format!("<tprf.Cube of {}>", meta.scene));
            let axis = tprf_core::film::TimeAxis::new(meta.t0_s, meta.dt_s, meta.bins).py_err()?;
            let data = cube.data_array().bind(py).readonly();
            let bounces = cube.bounces_array().map(|b| b.bind(py).readonly());
            let ambient = match cube.ambient_array() {
                Some(a) => Some(a.bind(py).readonly().as_slice()?.to_vec()),
                None => None,
            };
            let data = data.as_slice()?;
            let bounces = match &bounces {
                Some(b) => Some(b.as_slice()?),
                None => None,
            };
            py.detach(|| {
                let sc = SensorCube::in_memory(
                    &name,
                    (meta.height, meta.width),
                    axis,
                    data,
                    bounces,
                    ambient,
                )?;
                measure(sensor, &sc, pixels, started, None)
            })
        } else {
            let dir: PathBuf = cube.extract().map_err(|_| {
                pyo3::exceptions::PyTypeError::new_err(
                    "measure takes a tprf.Cube or the path of a render folder",
                )
            })?;
            py.detach(|| {
                let sc = SensorCube::open(&dir)?;
                measure(sensor, &sc, pixels, started, Some(dir.clone()))
            })
        };
        let m = run.map_err(|e| to_py(&*e))?;
        for note in &m.notes {
            warn(py, note)?;
        }
        Ok(m)
    }

    fn __repr__(&self) -> String {
        let s = &self.sensor;
        let mut text = match s.name.as_str() {
            "" => "<tprf.Sensor".to_string(),
            n => format!("<tprf.Sensor {n:?}"),
        };
        for part in [Part::Light, Part::Exposure, Part::Noise, Part::Spad] {
            if part == Part::Spad && s.spad.is_none() {
                continue;
            }
            text.push_str(&format!("\n  {}: {}", part.name(), part_text(part, s)));
        }
        text.push_str(&format!("\n  seed={}", s.noise.seed));
        if s.ambient_scale != 1.0 {
            text.push_str(&format!(", ambient_scale={}", s.ambient_scale));
        }
        if let Some(t) = s.ambient_exposure_s {
            text.push_str(&format!(", ambient_exposure_s={}", format_time(t)));
        }
        let mut derived = Vec::new();
        if s.derived.returns.is_some() {
            derived.push("returns (first, strongest, last, multi-echo depth)");
        }
        if s.derived.amcw_depth {
            derived.push("AMCW depth");
        }
        if s.derived.flim_lifetime {
            derived.push("FLIM lifetime");
        }
        if !derived.is_empty() {
            text.push_str(&format!("\n  derived: {}", derived.join(", ")));
        }
        text.push('>');
        text
    }
}

/// A Python `UserWarning` saying `text`.
fn warn(py: Python<'_>, text: &str) -> PyResult<()> {
    let text = CString::new(text.replace('\0', " ")).unwrap_or_default();
    PyErr::warn(py, &py.get_type::<PyUserWarning>(), &text, 1)
}

/// One part of a sensor (``sensor.light``, ``.exposure``, ``.noise``, ``.spad``): its
/// numbers are attributes, read and set in SI units (a time also as text with a unit,
/// ``"2ns"``); a setting the sensor refuses raises ValueError naming the field and
/// leaves the sensor as it was. ``fields`` lists them.
#[pyclass(module = "tprf._tprf", name = "SensorPart", frozen)]
pub struct SensorPart {
    owner: Py<PySensor>,
    part: Part,
}

impl SensorPart {
    fn fields(&self, py: Python<'_>) -> PyResult<Vec<Field>> {
        self.part
            .fields(&self.owner.borrow(py).sensor)
            .ok_or_else(|| PyAttributeError::new_err("the sensor no longer has a SPAD"))
    }
}

#[pymethods]
impl SensorPart {
    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        let fields = self.fields(py)?;
        match fields.iter().find(|f| f.key == name) {
            Some(f) => field_value(py, f),
            None => Err(PyAttributeError::new_err(format!(
                "{} ({}) has no field '{name}'; it has: {}",
                self.part.name(),
                self.part
                    .kind(&self.owner.borrow(py).sensor)
                    .unwrap_or("its settings"),
                fields.iter().map(|f| f.key).collect::<Vec<_>>().join(", ")
            ))),
        }
    }

    fn __setattr__(&self, py: Python<'_>, name: &str, value: Bound<'_, PyAny>) -> PyResult<()> {
        if name == "knots" {
            return self.set_knots(py, value.extract()?);
        }
        let fields = self.fields(py)?;
        let Some(f) = fields.iter().find(|f| f.key == name) else {
            return Err(PyAttributeError::new_err(format!(
                "{} has no field '{name}'; it has: {}",
                self.part.name(),
                fields.iter().map(|f| f.key).collect::<Vec<_>>().join(", ")
            )));
        };
        let v = field_arg(self.part, f, &value)?;
        let part = self.part;
        self.owner.borrow_mut(py).edit(|s| {
            if part.set(s, name, v) {
                Ok(())
            } else {
                Err(PyAttributeError::new_err(format!(
                    "{}.{name} cannot be set",
                    part.name()
                )))
            }
        })
    }

    fn __dir__(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        let mut names: Vec<String> = self.fields(py)?.iter().map(|f| f.key.to_string()).collect();
        names.extend(["fields", "kind", "knots"].map(String::from));
        Ok(names)
    }

    /// The kind of pulse or gates (``"gaussian"``, ``"box"``, ``"tdc"``, ...); None for
    /// the noise and the SPAD.
    #[getter]
    fn kind(&self, py: Python<'_>) -> Option<&'static str> {
        self.part.kind(&self.owner.borrow(py).sensor)
    }

    /// The part's numbers, in the order a form shows them: a list of dicts with
    /// ``key``, ``label``, ``help``, ``unit`` (SI: ``"s"``, ``"Hz"``, ``"J"``, ``"1/s"``,
    /// ``"deg"``, ``""``), ``value``, ``min``, ``max`` and ``integer``.
    #[getter]
    fn get_fields<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for f in self.fields(py)? {
            let d = PyDict::new(py);
            d.set_item("key", f.key)?;
            d.set_item("label", f.label)?;
            d.set_item("help", f.help)?;
            d.set_item("unit", unit(f.quantity))?;
            d.set_item("value", field_value(py, &f)?)?;
            d.set_item("min", f.min)?;
            d.set_item("max", f.max)?;
            d.set_item("integer", f.quantity == Quantity::Count)?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// A free (piecewise-linear) envelope's knots, ``[(t_s, value), ...]``; None for
    /// the other kinds. Set a new list to change them.
    #[getter]
    fn knots(&self, py: Python<'_>) -> Option<Vec<(f64, f64)>> {
        self.part
            .knots(&self.owner.borrow(py).sensor)
            .map(|k| k.iter().map(|p| (p.0, p.1)).collect())
    }

    #[setter]
    fn set_knots(&self, py: Python<'_>, knots: Vec<(f64, f64)>) -> PyResult<()> {
        let part = self.part;
        self.owner.borrow_mut(py).edit(|s| match part.knots_mut(s) {
            Some(k) => {
                *k = knots.into_iter().map(|(t, v)| Point(t, v)).collect();
                Ok(())
            }
            None => Err(PyAttributeError::new_err(format!(
                "{} has no knots (only piecewise_linear envelopes do)",
                part.name()
            ))),
        })
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "<tprf.Sensor.{} {}>",
            self.part.name(),
            part_text(self.part, &self.owner.borrow(py).sensor)
        )
    }
}

/// The SPAD's arrays and how its realisation was drawn.
struct Spad {
    image: SpadImage,
    sampler: Sampler,
    expected_detections: f64,
}

/// A measurement by a sensor (``Sensor.measure``): the arrays ``tprf sensor`` writes,
/// as read-only numpy arrays (no copies), and ``save`` to write its folder.
#[pyclass(module = "tprf._tprf", name = "Measurement", frozen)]
pub struct Measurement {
    model: SensorModel,
    /// Steps 3 to 5: the measurements, ambient light and noise included, and depths.
    gates: Gates,
    /// Step 1: the clean measurements.
    clean: Measurements,
    true_depth: Option<(Vec<f32>, &'static str)>,
    multipath: Option<Vec<f32>>,
    spad: Option<Spad>,
    pixels: Vec<(usize, usize)>,
    traces: Vec<Vec<f32>>,
    tiles: usize,
    ambient_json: Option<serde_json::Value>,
    /// The cube's folder (refused as the output), or the name of a cube in memory.
    cube_dir: PathBuf,
    from_folder: bool,
    kernels_s: f64,
    measurement_s: f64,
    noise_s: f64,
    total_s: f64,
    notes: Vec<String>,
}

/// `tprf sensor`'s steps (src/cli/sensor.rs) on `cube`, all in memory: the kernels,
/// the clean measurement a tile at a time, the SPAD's whole image (its bands equal
/// the whole bit for bit), then ambient light, noise and derived outputs.
fn measure(
    sensor: Sensor,
    cube: &SensorCube,
    pixels: Vec<(usize, usize)>,
    started: Instant,
    dir: Option<PathBuf>,
) -> Result<Measurement, BoxError> {
    let t_kernels = Instant::now();
    let model = SensorModel::new(sensor, cube.axis)?;
    let kernels_s = t_kernels.elapsed().as_secs_f64();
    let t_measure = Instant::now();
    let measured = measure_cube(cube, &model, &pixels, DEFAULT_TILE_BYTES)?;
    let measurement_s = t_measure.elapsed().as_secs_f64();
    let pipeline = Pipeline {
        model: &model,
        clean: &measured.measurements,
        steady: measured.steady.as_deref().unwrap_or(&[]),
        ambient: cube.ambient.as_deref(),
    };
    let spad = match &measured.steady {
        Some(_) => {
            let (sampler, expected_detections) = pipeline.spad_sampler()?;
            let image = pipeline.spad_rows(sampler, 0, cube.height)?;
            Some(Spad {
                image,
                sampler,
                expected_detections,
            })
        }
        None => None,
    };
    let t_noise = Instant::now();
    let gates = pipeline.gates(Draws::Fresh)?;
    let mut notes = Vec::new();
    let ambient_json = match (&cube.ambient, &gates.ambient) {
        (Some(image), Some(added)) => {
            if let Err(why) = added {
                notes.push(format!("the cube's ambient image is not added: {why}"));
            }
            Some(tprf_core::export::ambient::sensor_json(
                &model,
                image,
                added.clone(),
            ))
        }
        _ => None,
    };
    let noise_s = t_noise.elapsed().as_secs_f64();
    notes.extend(tprf_core::sensor::pipeline::unlit_gates_note(
        &model,
        spad.is_some(),
        &cube.axis,
    ));
    let multipath = match (&gates.amcw, &measured.true_depth) {
        (Some(amcw), Some((reference, _))) => Some(multipath_error(amcw, reference)),
        _ => None,
    };
    Ok(Measurement {
        model,
        gates,
        clean: measured.measurements,
        true_depth: measured.true_depth,
        multipath,
        spad,
        pixels,
        traces: measured.traces,
        tiles: measured.tiles,
        ambient_json,
        from_folder: dir.is_some(),
        cube_dir: dir.unwrap_or_else(|| cube.dir.clone()),
        kernels_s,
        measurement_s,
        noise_s,
        total_s: started.elapsed().as_secs_f64(),
        notes,
    })
}

/// `values` as a read-only numpy array of `shape` that borrows them from `owner` (no
/// copy; `owner` is kept alive by the array).
fn view<'py>(
    owner: &Bound<'py, Measurement>,
    values: &[f32],
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    let array = ArrayView::from_shape(IxDyn(shape), values)
        .map_err(|e| PyValueError::new_err(format!("an array of shape {shape:?}: {e}")))?;
    // SAFETY: `values` lives in the frozen `Measurement` `owner`, which is never
    // changed after it is made, and the array holds a reference to `owner`.
    let array = unsafe { PyArrayDyn::<f32>::borrow_from_array(&array, owner.clone().into_any()) };
    Ok(read_only(array)?.into_any())
}

impl Measurement {
    fn image_shape(&self) -> [usize; 2] {
        [self.clean.height, self.clean.width]
    }

    /// An array of the returns (`[H, W]`, or `[N, H, W]` when `echoes`), or None when
    /// the sensor asks for none.
    fn returns_array<'py>(
        slf: &Bound<'py, Self>,
        of: impl Fn(&ReturnImages) -> &[f32],
        echoes: bool,
    ) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = slf.get();
        let Some(r) = &m.gates.returns else {
            return Ok(None);
        };
        let [h, w] = m.image_shape();
        let shape = if echoes {
            vec![r.max_returns, h, w]
        } else {
            vec![h, w]
        };
        view(slf, of(r), &shape).map(Some)
    }
}

#[pymethods]
impl Measurement {
    /// The measurements ``M_i``, float32 ``[N, H, W]``, row 0 = top (``sensor.npy``):
    /// ambient light and noise included, in the unit of a cube bin (W m^-2 sr^-1 s per
    /// unit pulse energy) times the light's energy.
    #[getter]
    fn images<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let m = slf.get();
        let [h, w] = m.image_shape();
        view(slf, &m.gates.m.values, &[m.gates.m.gates, h, w])
    }

    /// The clean measurements ``sum_b TPRF[b] K_i[b]``, float32 ``[N, H, W]``: before
    /// ambient light, noise and ``max(0, .)``.
    #[getter]
    fn clean<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let m = slf.get();
        let [h, w] = m.image_shape();
        view(slf, &m.clean.values, &[m.clean.gates, h, w])
    }

    /// First-return depth, float32 ``[H, W]``, metres (``c (t_return - light mean
    /// time) / 2``, measured from the light's mean emission time; NaN: no return), when
    /// the sensor asks for returns (``depth.npy``); else None.
    #[getter]
    fn depth<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::returns_array(slf, |r| r.first_m(), false)
    }

    /// The depth of each pixel's strongest return (highest intensity), float32
    /// ``[H, W]``, metres (``depth_strongest.npy``), or None.
    #[getter]
    fn depth_strongest<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::returns_array(slf, |r| &r.strongest_m, false)
    }

    /// The depth of each pixel's last return, float32 ``[H, W]``, metres
    /// (``depth_last.npy``), or None.
    #[getter]
    fn depth_last<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::returns_array(slf, |r| &r.last_m, false)
    }

    /// Multi-echo: up to N returns per pixel, earliest first, float32 ``[N, H, W]``,
    /// metres, NaN past a pixel's last (``depth_returns.npy``; N is the sensor's
    /// ``derived.returns.max_returns``), or None.
    #[getter]
    fn depth_returns<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::returns_array(slf, |r| &r.depth_m, true)
    }

    /// Each return's intensity (the sum of its gate values, measurement units),
    /// float32 ``[N, H, W]``, 0 past a pixel's last (``return_intensity.npy``), or None.
    #[getter]
    fn return_intensity<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::returns_array(slf, |r| &r.intensity, true)
    }

    /// How many returns each pixel has (also past N), uint16 ``[H, W]``
    /// (``return_count.npy``), or None.
    #[getter]
    fn return_count<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = slf.get();
        let Some(r) = &m.gates.returns else {
            return Ok(None);
        };
        let [h, w] = m.image_shape();
        let a = PyArray1::from_slice(slf.py(), &r.count).reshape([h, w])?;
        Ok(Some(a.into_any()))
    }

    /// AMCW phase, float32 ``[H, W]``, radians in ``[0, 2 pi)`` (``amcw_phase.npy``), or
    /// None without AMCW gates.
    #[getter]
    fn amcw_phase<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = slf.get();
        m.gates
            .amcw
            .as_ref()
            .map(|a| view(slf, &a.phase_rad, &m.image_shape()))
            .transpose()
    }

    /// AMCW amplitude, float32 ``[H, W]``, measurement units (``amcw_amplitude.npy``),
    /// or None.
    #[getter]
    fn amcw_amplitude<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = slf.get();
        m.gates
            .amcw
            .as_ref()
            .map(|a| view(slf, &a.amplitude, &m.image_shape()))
            .transpose()
    }

    /// AMCW depth, float32 ``[H, W]``, metres in ``[0, c / 2f)`` (``amcw_depth.npy``),
    /// or None.
    #[getter]
    fn amcw_depth<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = slf.get();
        m.gates
            .amcw
            .as_ref()
            .map(|a| view(slf, &a.depth_m, &m.image_shape()))
            .transpose()
    }

    /// FLIM's two-gate lifetime ``tau = dt / ln(M1 / M2)``, float32 ``[H, W]``, seconds
    /// (``flim_lifetime.npy``; NaN where the first gate is not brighter), or None.
    #[getter]
    fn flim_lifetime<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = slf.get();
        m.gates
            .flim_lifetime_s
            .as_ref()
            .map(|t| view(slf, t, &m.image_shape()))
            .transpose()
    }

    /// The AMCW depth's reference, float32 ``[H, W]``, metres (``true_depth.npy``: the
    /// single-scattering layer's centroid, or the noise-free TPRF's first return
    /// without bounce layers), or None.
    #[getter]
    fn true_depth<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = slf.get();
        m.true_depth
            .as_ref()
            .map(|(d, _)| view(slf, d, &m.image_shape()))
            .transpose()
    }

    /// ``amcw_depth - true_depth`` wrapped into ``[-c/4f, c/4f)``, float32 ``[H, W]``,
    /// metres (``multipath_error.npy``), or None.
    #[getter]
    fn multipath_error<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = slf.get();
        m.multipath
            .as_ref()
            .map(|d| view(slf, d, &m.image_shape()))
            .transpose()
    }

    /// The SPAD's expected counts over all cycles, float32 ``[B, H, W]``
    /// (``spad_histogram.npy``), or None without a SPAD.
    #[getter]
    fn spad_histogram<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::spad_array(slf, |s| &s.histogram, true)
    }

    /// One seeded realisation of the SPAD's counts, float32 ``[B, H, W]``
    /// (``spad_counts.npy``), or None.
    #[getter]
    fn spad_counts<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::spad_array(slf, |s| &s.counts, true)
    }

    /// The Coates estimate of ``spad_counts`` (counts without pile-up; NaN: bin never
    /// armed), float32 ``[B, H, W]`` (``spad_coates.npy``), or None.
    #[getter]
    fn spad_coates<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::spad_array(slf, |s| &s.coates, true)
    }

    /// First-return depth of ``spad_histogram``, float32 ``[H, W]``, metres (NaN: none;
    /// ``spad_depth_histogram.npy``), or None.
    #[getter]
    fn spad_depth_histogram<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::spad_array(slf, |s| &s.depth_histogram_m, false)
    }

    /// First-return depth of ``spad_counts``, float32 ``[H, W]``, metres, or None.
    #[getter]
    fn spad_depth_counts<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::spad_array(slf, |s| &s.depth_counts_m, false)
    }

    /// First-return depth of ``spad_coates``, float32 ``[H, W]``, metres, or None.
    #[getter]
    fn spad_depth_coates<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        Self::spad_array(slf, |s| &s.depth_coates_m, false)
    }

    /// The SPAD's TDC bin centres in the first cycle, seconds, float64 ``[B]``, or None.
    #[getter]
    fn spad_bin_centres_s<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.spad
            .as_ref()
            .map(|s| PyArray1::from_slice(py, &s.image.centres_s))
    }

    /// Gate ``i``'s centre, seconds after the trigger (NaN for a gate without one,
    /// such as an AMCW sinusoid), float64 ``[N]``.
    #[getter]
    fn gate_centres_s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(
            py,
            self.model
                .gates()
                .iter()
                .map(|g| g.centre_s().unwrap_or(f64::NAN))
                .collect(),
        )
    }

    /// The sensor measured with (its settings after ``measure``'s keywords).
    #[getter]
    fn sensor(&self) -> PySensor {
        PySensor {
            sensor: self.model.sensor().clone(),
        }
    }

    /// What ``tprf sensor`` prints as notes (gates that see none of the cube's window,
    /// an ambient image the gates cannot take); each was also a warning.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// ``(N, H, W)``.
    #[getter]
    fn shape(&self) -> (usize, usize, usize) {
        (self.clean.gates, self.clean.height, self.clean.width)
    }

    /// save(dir)
    ///
    /// Write the folder ``tprf sensor --out dir`` writes (``sensor.npy``, the depth
    /// images, the SPAD's arrays, the pixels' CSV files, ``sensor.json``), the same
    /// files, into a new folder swapped in whole. ``dir`` must be new, empty or an
    /// earlier tprf output (a folder of other files is refused, never overwritten), and
    /// not the measured render folder.
    fn save(slf: &Bound<'_, Self>, dir: PathBuf) -> PyResult<()> {
        let m = slf.get();
        slf.py().detach(|| m.write(&dir)).map_err(|e| to_py(&*e))
    }

    fn __repr__(&self) -> String {
        let (n, h, w) = self.shape();
        let mut parts = vec![format!("{n} gates x {h} x {w} pixels")];
        if self.gates.returns.is_some() {
            parts.push("depth".into());
        }
        if self.gates.amcw.is_some() {
            parts.push("AMCW depth".into());
        }
        if let Some(s) = &self.spad {
            parts.push(format!(
                "SPAD {} TDC bins, {:.3e} expected detections",
                s.image.bins, s.expected_detections
            ));
        }
        let name = match self.model.sensor().name.as_str() {
            "" => String::new(),
            n => format!(" {n:?}"),
        };
        format!("<tprf.Measurement{name}: {}>", parts.join(", "))
    }
}

impl Measurement {
    /// A SPAD array (`bins`: `[B, H, W]`, else `[H, W]`), or None without a SPAD.
    fn spad_array<'py>(
        slf: &Bound<'py, Self>,
        pick: impl Fn(&SpadImage) -> &Vec<f32>,
        bins: bool,
    ) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = slf.get();
        let [h, w] = m.image_shape();
        m.spad
            .as_ref()
            .map(|s| {
                let values = pick(&s.image);
                if bins {
                    view(slf, values, &[s.image.bins, h, w])
                } else {
                    view(slf, values, &[h, w])
                }
            })
            .transpose()
    }

    /// `tprf sensor`'s folder at `dir`, staged beside it and swapped in whole.
    fn write(&self, dir: &Path) -> Result<(), BoxError> {
        let inputs: Vec<&Path> = if self.from_folder {
            vec![self.cube_dir.as_path()]
        } else {
            vec![]
        };
        let staging = Staging::new(dir, &inputs)?;
        let spad = match &self.spad {
            Some(s) => Some(write_spad_image(
                staging.path(),
                &s.image,
                s.sampler,
                s.expected_detections,
            )?),
            None => None,
        };
        let started = Instant::now()
            .checked_sub(Duration::from_secs_f64(self.total_s))
            .unwrap_or_else(Instant::now);
        write_sensor_outputs(
            staging.path(),
            &SensorRun {
                model: &self.model,
                gates: &self.gates,
                width: self.clean.width,
                height: self.clean.height,
                cube_dir: &self.cube_dir,
                true_depth: self.true_depth.as_ref(),
                pixels: &self.pixels,
                traces: &self.traces,
                tiles: self.tiles,
                kernels_s: self.kernels_s,
                measurement_s: self.measurement_s,
                noise_s: self.noise_s,
                started,
                spad: spad.as_ref(),
                ambient: self.ambient_json.clone(),
            },
        )?;
        staging.commit()?;
        Ok(())
    }
}

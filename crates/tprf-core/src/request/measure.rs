//! One measurement, described once: [`MeasureRequest`] is what `tprf sensor` does, as
//! data (the cube folder, the sensor preset or gates and the overrides of its parts, the
//! pixels whose traces are written), serialised with `tprf sensor`'s option names, which
//! are also the keys of a batch manifest's sensor jobs. [`MeasureRequest::validate`]
//! checks it naming the field; [`MeasureRequest::sensor`] builds the sensor;
//! [`MeasureRequest::measure_to_folder`] measures the cube in the core's one order
//! ([`crate::sensor::pipeline`]) and writes `tprf sensor`'s folder, staged beside the
//! output and swapped in whole.

use super::Problem;
use crate::export::ExportError;
use crate::export::sensor::{
    DEFAULT_TILE_BYTES, FlimSummary, MultipathError, SensorCube, SensorFilesError, SensorRun,
    SpadFiles, measure_cube, write_sensor_outputs, write_spad_files,
};
use crate::sensor::{
    Derived, Draws, Exposure, LightPulse, Pipeline, Sensor, SensorError, SensorModel,
};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A measurement of a rendered cube by a time-of-flight sensor: `tprf sensor`'s options
/// as data (a field left out takes its default: the preset's value).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MeasureRequest {
    /// The cube: a `tprf render` output folder (`tprf.npy` or `tprf.zarr`, and
    /// `tprf.json`).
    pub dir: PathBuf,
    /// The sensor: a TOML file or `builtin:NAME` (`gated`, `lidar`, `amcw`, `spad`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub preset: Option<String>,
    /// The light pulse, `KIND:key=value,...`, replacing the preset's (default without a
    /// preset: a unit delta at t = 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub light: Option<String>,
    /// The gates, `KIND:key=value,...`, replacing the preset's (the sensor itself without
    /// a preset).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exposure: Option<String>,
    /// Standard deviation of the additive Gaussian noise, measurement units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_sigma: Option<f64>,
    /// Photon noise: photons per unit of measurement (0: off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub photons_per_energy: Option<f64>,
    /// Seed of the noise (and of the SPAD's realisation).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Laser cycles of the SPAD histogram (a sensor with a SPAD only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cycles: Option<u64>,
    /// Scale of the cube's ambient image, dimensionless (1: the scene's power, 0: off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ambient_scale: Option<f64>,
    /// AMCW only: seconds of ambient light per unit of emitted energy (`ambient_exposure`:
    /// a number of seconds, or text with a unit, `"1ms"`).
    #[serde(
        rename = "ambient_exposure",
        deserialize_with = "super::time_s",
        skip_serializing_if = "Option::is_none"
    )]
    pub ambient_exposure_s: Option<f64>,
    /// Pixels `[row, column]` (from the top left, 0-based) whose traces are written as
    /// CSV (`pixel`, as `tprf sensor --pixel Y,X`).
    #[serde(rename = "pixel", skip_serializing_if = "Vec::is_empty")]
    pub pixels: Vec<(usize, usize)>,
}

/// Why a measurement cannot be made or written.
#[derive(Debug, thiserror::Error)]
pub enum MeasureError {
    /// A field's value is not allowed; the message names it.
    #[error("{0}")]
    Invalid(Problem),
    #[error(transparent)]
    Sensor(#[from] SensorError),
    #[error(transparent)]
    Files(#[from] SensorFilesError),
    #[error(transparent)]
    Export(#[from] ExportError),
}

/// A field's problem: `field` and the message after it.
fn invalid(field: &'static str, text: impl Into<String>) -> MeasureError {
    MeasureError::Invalid(Problem::field(field).text(text))
}

/// What [`MeasureRequest::measure_to_folder`] measured and wrote.
#[derive(Debug)]
pub struct Measured {
    /// Things worth saying (`the preset's derived outputs are dropped: ...`), in order.
    pub notes: Vec<String>,
    /// Gates, image height and width.
    pub gates: usize,
    pub height: usize,
    pub width: usize,
    /// Tiles the cube was read in.
    pub tiles: usize,
    /// Seconds compiling the kernels, measuring, adding the noise.
    pub kernels_s: f64,
    pub measurement_s: f64,
    pub noise_s: f64,
    /// The SPAD's files, when the sensor has one.
    pub spad: Option<SpadFiles>,
    /// The AMCW depth's error, when the sensor has AMCW gates.
    pub multipath: Option<MultipathError>,
    /// FLIM's lifetimes in numbers, when the sensor asks for them.
    pub flim: Option<FlimSummary>,
}

impl MeasureRequest {
    /// A request measuring the cube in `dir` with every other field at its default.
    pub fn new(dir: impl Into<PathBuf>) -> MeasureRequest {
        MeasureRequest {
            dir: dir.into(),
            ..MeasureRequest::default()
        }
    }

    /// Check the fields before anything is read: a sensor given (`preset` or
    /// `exposure`), finite numbers; the error names the field.
    pub fn validate(&self) -> Result<(), MeasureError> {
        if self.preset.is_none() && self.exposure.is_none() {
            return Err(MeasureError::Invalid(
                Problem::field("preset")
                    .text(" (a TOML file, or builtin:lidar, builtin:gated, builtin:amcw) or ")
                    .and("exposure")
                    .text(" (KIND:key=value,..., e.g. box:start=10ns,width=1ns,count=32) must be given"),
            ));
        }
        for (field, v) in [
            ("noise_sigma", self.noise_sigma),
            ("photons_per_energy", self.photons_per_energy),
            ("ambient_scale", self.ambient_scale),
            ("ambient_exposure", self.ambient_exposure_s),
        ] {
            if let Some(v) = v
                && !v.is_finite()
            {
                return Err(invalid(field, format!(" = {v} must be a finite number")));
            }
        }
        Ok(())
    }

    /// The sensor: the preset (or a delta light and `exposure`) with the overrides;
    /// with what is worth saying about it (a preset's derived outputs dropped because
    /// they do not fit new gates).
    pub fn sensor(&self) -> Result<(Sensor, Vec<String>), MeasureError> {
        self.validate()?;
        let mut notes = Vec::new();
        let mut sensor = match (&self.preset, &self.exposure) {
            (Some(p), _) => Sensor::load(p).map_err(|e| invalid("preset", format!(" {p}: {e}")))?,
            (None, Some(spec)) => Sensor::new(LightPulse::default(), exposure(spec)?),
            (None, None) => unreachable!("validate refuses a request with no sensor"),
        };
        if let Some(spec) = &self.light {
            sensor.light =
                LightPulse::from_spec(spec).map_err(|e| invalid("light", format!(": {e}")))?;
        }
        if let Some(spec) = &self.exposure {
            sensor.exposure = exposure(spec)?;
            // The preset's derived outputs may not fit the new gates.
            let gates = sensor
                .exposure
                .gates(0.0)
                .map_err(|e| invalid("exposure", format!(": {e}")))?;
            if let Err(e) = sensor.derived.validate(&sensor.exposure, &gates) {
                notes.push(format!("the preset's derived outputs are dropped: {e}"));
                sensor.derived = Derived::default();
            }
        }
        if let Some(x) = self.noise_sigma {
            sensor.noise.sigma = x;
        }
        if let Some(x) = self.photons_per_energy {
            sensor.noise.photons_per_energy = x;
        }
        if let Some(x) = self.seed {
            sensor.noise.seed = x;
        }
        if let Some(x) = self.ambient_scale {
            sensor.ambient_scale = x;
        }
        if let Some(t) = self.ambient_exposure_s {
            sensor.ambient_exposure_s = Some(t);
        }
        if let Some(n) = self.cycles {
            match &mut sensor.spad {
                Some(spad) => spad.cycles = n,
                None => {
                    return Err(invalid(
                        "cycles",
                        " needs a sensor with a [spad] section (e.g. preset builtin:spad)",
                    ));
                }
            }
        }
        Ok((sensor, notes))
    }

    /// Measure the cube and write `tprf sensor`'s folder `out` (staged beside it and
    /// swapped in whole; refused up front when `out` is not a new, empty or earlier tprf
    /// folder): the clean measurement a tile of the cube at a time, then the SPAD (from
    /// the clean measurement, the steady image and the ambient image, a band of rows at
    /// a time), the ambient image's constant rate on the gates
    /// (`M_i += ambient_scale A integral Exposure_i dt`), the noise and the derived
    /// depths: [`crate::sensor::pipeline`]'s order, the window's too.
    pub fn measure_to_folder(&self, out: &Path) -> Result<Measured, MeasureError> {
        let start = Instant::now();
        crate::export::staging::check_target(out, &[&self.dir])?;
        let (sensor, mut notes) = self.sensor()?;
        let cube = SensorCube::open(&self.dir)?;
        let (w, h, axis) = (cube.width, cube.height, cube.axis);
        if let Some(&(y, x)) = self.pixels.iter().find(|&&(y, x)| y >= h || x >= w) {
            return Err(invalid(
                "pixel",
                format!(" {y},{x} is outside the {h} x {w} image (row, column from 0)"),
            ));
        }
        let t_kernels = Instant::now();
        let model = SensorModel::new(sensor, axis)?;
        let kernels_s = t_kernels.elapsed().as_secs_f64();
        let t_measure = Instant::now();
        let measured = measure_cube(&cube, &model, &self.pixels, DEFAULT_TILE_BYTES)?;
        let measurement_s = t_measure.elapsed().as_secs_f64();
        let staging = crate::export::staging::Staging::new(out, &[&self.dir])?;
        let pipeline = Pipeline {
            model: &model,
            clean: &measured.measurements,
            steady: measured.steady.as_deref().unwrap_or(&[]),
            ambient: cube.ambient.as_deref(),
        };
        let spad = match &measured.steady {
            Some(_) => Some(write_spad_files(
                staging.path(),
                &pipeline,
                DEFAULT_TILE_BYTES,
            )?),
            None => None,
        };
        let t_noise = Instant::now();
        let gates = pipeline.gates(Draws::Fresh)?;
        let ambient_json = match (&cube.ambient, &gates.ambient) {
            (Some(image), Some(added)) => {
                if let Err(why) = added {
                    notes.push(format!("the cube's ambient image is not added: {why}"));
                }
                Some(crate::export::ambient::sensor_json(
                    &model,
                    image,
                    added.clone(),
                ))
            }
            _ => None,
        };
        let noise_s = t_noise.elapsed().as_secs_f64();
        if let Some(note) = crate::sensor::pipeline::unlit_gates_note(&model, spad.is_some(), &axis)
        {
            notes.push(note);
        }
        let written = write_sensor_outputs(
            staging.path(),
            &SensorRun {
                model: &model,
                gates: &gates,
                width: w,
                height: h,
                cube_dir: &self.dir,
                true_depth: measured.true_depth.as_ref(),
                pixels: &self.pixels,
                traces: &measured.traces,
                tiles: measured.tiles,
                kernels_s,
                measurement_s,
                noise_s,
                started: start,
                spad: spad.as_ref(),
                ambient: ambient_json,
            },
        )?;
        staging.commit()?;
        Ok(Measured {
            notes,
            gates: model.gate_count(),
            height: h,
            width: w,
            tiles: measured.tiles,
            kernels_s,
            measurement_s,
            noise_s,
            spad,
            multipath: written.multipath,
            flim: written.flim,
        })
    }
}

/// The gates of `exposure`'s text, an error naming the field.
fn exposure(spec: &str) -> Result<Exposure, MeasureError> {
    Exposure::from_spec(spec).map_err(|e| invalid("exposure", format!(": {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A manifest's table: the option names, times with units; unknown keys refused.
    #[test]
    fn measure_requests_read_toml_with_the_option_names() {
        let r: MeasureRequest = toml::from_str(
            "dir = \"out/cornell\"\npreset = \"builtin:amcw\"\nseed = 4\n\
             ambient_exposure = \"1ms\"\npixel = [[3, 4], [0, 1]]\n",
        )
        .unwrap();
        assert_eq!(r.dir, PathBuf::from("out/cornell"));
        assert_eq!(r.ambient_exposure_s, Some(1e-3));
        assert_eq!(r.pixels, [(3, 4), (0, 1)]);
        let back: MeasureRequest = toml::from_str(&toml::to_string(&r).unwrap()).unwrap();
        assert_eq!(back, r);
        let e = toml::from_str::<MeasureRequest>("dir = \"x\"\npixels = []\n").unwrap_err();
        assert!(e.to_string().contains("pixels"), "{e}");
    }

    /// Each refusal names its field.
    #[test]
    fn bad_fields_are_named() {
        let r = MeasureRequest::new("x");
        let said = |r: &MeasureRequest| match r.sensor() {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{r:?} was accepted"),
        };
        assert!(said(&r).starts_with("preset (a TOML file"), "{}", said(&r));
        let cases = [
            (
                MeasureRequest {
                    exposure: Some("box:width=-1ns".into()),
                    ..r.clone()
                },
                "exposure: ",
            ),
            (
                MeasureRequest {
                    preset: Some("builtin:nope".into()),
                    ..r.clone()
                },
                "preset builtin:nope: ",
            ),
            (
                MeasureRequest {
                    preset: Some("builtin:lidar".into()),
                    cycles: Some(3),
                    ..r.clone()
                },
                "cycles needs a sensor with a [spad] section",
            ),
            (
                MeasureRequest {
                    preset: Some("builtin:lidar".into()),
                    noise_sigma: Some(f64::NAN),
                    ..r.clone()
                },
                "noise_sigma = NaN must be a finite number",
            ),
        ];
        for (req, want) in cases {
            let got = said(&req);
            assert!(got.starts_with(want), "{got:?} should start {want:?}");
        }
    }

    /// The overrides reach the preset's parts; new gates the preset's derived outputs
    /// do not fit drop them, saying so.
    #[test]
    fn overrides_replace_the_presets_parts() {
        let (s, notes) = MeasureRequest {
            preset: Some("builtin:spad".into()),
            seed: Some(9),
            cycles: Some(77),
            noise_sigma: Some(0.5),
            ..MeasureRequest::new("x")
        }
        .sensor()
        .unwrap();
        assert_eq!((s.noise.seed, s.noise.sigma), (9, 0.5));
        assert_eq!(s.spad.map(|p| p.cycles), Some(77));
        assert!(notes.is_empty());
        let preset = Sensor::load("builtin:amcw").unwrap();
        let (s, notes) = MeasureRequest {
            preset: Some("builtin:amcw".into()),
            exposure: Some("box:start=1ns,width=1ns,count=3".into()),
            ..MeasureRequest::new("x")
        }
        .sensor()
        .unwrap();
        assert_ne!(preset.derived, Derived::default());
        assert_eq!(s.derived, Derived::default());
        assert!(notes[0].starts_with("the preset's derived outputs are dropped"));
    }
}

//! Sensor descriptions as files (TOML, serde), the built-in presets, and the one-line
//! `kind:key=value,...` form the command line (and a text field) uses.
//!
//! ```toml
//! name = "Full-waveform LiDAR"
//! [light]
//! kind = "gaussian"
//! centre = "5 ns"
//! fwhm = "2 ns"
//! [exposure]
//! kind = "box"
//! origin = "window"
//! width = "1 ns"
//! count = 256
//! [noise]
//! sigma = 0.0
//! [derived]
//! first_return = { threshold = 0.2 }
//! ```
//!
//! Times are seconds, or strings with a unit (`"2 ns"`, or an optical path `"30 cm"`);
//! the format is described in `docs/sensor.md`.

use serde::{Deserialize, Serialize};
use std::path::Path;

use super::SensorError;
use super::derived::Derived;
use super::exposure::Exposure;
use super::light::LightPulse;
use super::noise::Noise;
use super::spad::Spad;

/// The presets shipped in `assets/sensors/`, by name (`builtin:NAME`).
pub const BUILTIN_PRESETS: &[(&str, &str)] = &[
    (
        "gated",
        include_str!("../../../../assets/sensors/gated.toml"),
    ),
    (
        "lidar",
        include_str!("../../../../assets/sensors/lidar.toml"),
    ),
    ("amcw", include_str!("../../../../assets/sensors/amcw.toml")),
    ("spad", include_str!("../../../../assets/sensors/spad.toml")),
    ("flim", include_str!("../../../../assets/sensors/flim.toml")),
];

/// A whole TPRF sensor: light, gates, noise, derived outputs. It is plain data
/// (`Clone + PartialEq`), so a viewer can keep one, edit it and hand it to
/// [`super::SensorModel::update`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sensor {
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub name: String,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// Scale of the cube's ambient image `A` (dimensionless, >= 0; 1 = the ambient
    /// light group at the power the scene states, 0 = off), when the cube has one
    /// (`ambient.npy`): gate `i` measures `ambient_scale A[p] integral Exposure_i dt`
    /// more, and a SPAD counts `ambient_scale photons_per_unit A[p]` more photons per
    /// second (see [`super::ambient`]).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub ambient_scale: f64,
    /// AMCW gates only (they never close): the seconds of ambient light one measurement
    /// collects per unit of emitted energy, i.e. 1 / the source's mean power in W. Gate
    /// `i` then measures `ambient_scale A[p] mean(Exposure_i) ambient_exposure_s` more.
    /// Without it an AMCW sensor leaves the ambient image out (and says so).
    #[serde(
        default,
        alias = "ambient_exposure",
        with = "super::values::option_seconds",
        skip_serializing_if = "Option::is_none"
    )]
    pub ambient_exposure_s: Option<f64>,
    /// `Light(t)`; default a unit delta at `t = 0`.
    #[serde(default)]
    pub light: LightPulse,
    /// `Exposure_i(t)`, `i = 0..N`.
    pub exposure: Exposure,
    #[serde(default)]
    pub noise: Noise,
    #[serde(default)]
    pub derived: Derived,
    /// A SPAD behind the gates (which must then be a `tdc` exposure).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spad: Option<Spad>,
}

fn one() -> f64 {
    1.0
}

fn is_one(x: &f64) -> bool {
    *x == 1.0
}

impl Sensor {
    /// A sensor with `light` and `exposure`, no noise, no derived outputs.
    pub fn new(light: LightPulse, exposure: Exposure) -> Sensor {
        Sensor {
            name: String::new(),
            description: String::new(),
            light,
            exposure,
            noise: Noise::default(),
            derived: Derived::default(),
            spad: None,
            ambient_scale: 1.0,
            ambient_exposure_s: None,
        }
    }

    /// Checks every value for a cube whose window starts at `window_t0_s` (only gates
    /// with `origin = "window"` depend on it).
    pub fn validate_for(&self, window_t0_s: f64) -> Result<(), SensorError> {
        self.light.compile()?;
        let gates = self.exposure.gates(window_t0_s)?;
        self.noise.validate()?;
        self.derived.validate(&self.exposure, &gates)?;
        self.validate_ambient()?;
        match &self.spad {
            Some(spad) => spad.validate(&self.exposure),
            None => Ok(()),
        }
    }

    /// Checks `ambient_scale` (finite, >= 0) and `ambient_exposure_s` (finite, > 0).
    pub fn validate_ambient(&self) -> Result<(), SensorError> {
        super::non_negative("ambient_scale", self.ambient_scale)?;
        if let Some(t) = self.ambient_exposure_s {
            super::positive("ambient_exposure_s", t)?;
        }
        Ok(())
    }

    /// Checks every value ([`Sensor::validate_for`] a window starting at 0).
    pub fn validate(&self) -> Result<(), SensorError> {
        self.validate_for(0.0)
    }

    /// Parses and checks a TOML description.
    pub fn from_toml_str(text: &str) -> Result<Sensor, SensorError> {
        let sensor: Sensor = toml::from_str(text).map_err(|e| SensorError::Parse(e.to_string()))?;
        sensor.validate()?;
        Ok(sensor)
    }

    /// Reads and checks a TOML file.
    pub fn from_path(path: &Path) -> Result<Sensor, SensorError> {
        let text = crate::budget::read_text(path, "the sensor file").map_err(|message| {
            SensorError::Io {
                path: path.to_path_buf(),
                message,
            }
        })?;
        Sensor::from_toml_str(&text).map_err(|e| match e {
            SensorError::Parse(m) => SensorError::Parse(format!("{}: {m}", path.display())),
            other => other,
        })
    }

    /// A built-in preset by name (see [`BUILTIN_PRESETS`]).
    pub fn builtin(name: &str) -> Result<Sensor, SensorError> {
        let text = BUILTIN_PRESETS
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, text)| *text)
            .ok_or_else(|| {
                let names: Vec<&str> = BUILTIN_PRESETS.iter().map(|(n, _)| *n).collect();
                SensorError::Invalid(format!(
                    "no built-in sensor preset '{name}' (there are: {})",
                    names.join(", ")
                ))
            })?;
        Sensor::from_toml_str(text)
    }

    /// `builtin:NAME` or the path of a TOML file. A bare preset name that names no file
    /// (`lidar`) is refused with the spelling that loads the preset.
    pub fn load(spec: &str) -> Result<Sensor, SensorError> {
        match spec.strip_prefix("builtin:") {
            Some(name) => Sensor::builtin(name),
            None if !Path::new(spec).exists()
                && BUILTIN_PRESETS.iter().any(|(n, _)| *n == spec) =>
            {
                Err(SensorError::Invalid(format!(
                    "no sensor file '{spec}': the built-in preset is builtin:{spec}"
                )))
            }
            None => Sensor::from_path(Path::new(spec)),
        }
    }

    /// The description as TOML (times in seconds).
    pub fn to_toml_string(&self) -> Result<String, SensorError> {
        toml::to_string_pretty(self).map_err(|e| SensorError::Parse(e.to_string()))
    }
}

/// Parses `kind:key=value,key=value` into a TOML table with `kind` set. Values are
/// integers, floats, `true`/`false` or strings (`2ns`); `points=T:V;T:V;...` gives a
/// list of `[T, V]` knots.
fn spec_table(spec: &str) -> Result<toml::Table, SensorError> {
    let (kind, rest) = spec.split_once(':').unwrap_or((spec, ""));
    let kind = kind.trim();
    if kind.is_empty() {
        return Err(SensorError::Parse(format!(
            "'{spec}': expected KIND:key=value,... (e.g. gaussian:fwhm=2ns)"
        )));
    }
    let mut table = toml::Table::new();
    table.insert("kind".into(), toml::Value::String(kind.to_string()));
    for item in rest.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (key, value) = item
            .split_once('=')
            .ok_or_else(|| SensorError::Parse(format!("'{item}' in '{spec}' is not key=value")))?;
        let (key, value) = (key.trim(), value.trim());
        let parsed = if key == "points" {
            let mut knots = Vec::new();
            for knot in value.split(';').map(str::trim).filter(|s| !s.is_empty()) {
                let (t, v) = knot.split_once(':').ok_or_else(|| {
                    SensorError::Parse(format!(
                        "knot '{knot}' in '{spec}' is not TIME:VALUE (points=0ns:0;1ns:1)"
                    ))
                })?;
                let v: f64 = v.trim().parse().map_err(|_| {
                    SensorError::Parse(format!("knot '{knot}': '{v}' is not a number"))
                })?;
                knots.push(toml::Value::Array(vec![
                    scalar(t.trim()),
                    toml::Value::Float(v),
                ]));
            }
            toml::Value::Array(knots)
        } else {
            scalar(value)
        };
        if table.insert(key.to_string(), parsed).is_some() {
            return Err(SensorError::Parse(format!(
                "'{key}' is given twice in '{spec}'"
            )));
        }
    }
    Ok(table)
}

fn scalar(text: &str) -> toml::Value {
    if let Ok(i) = text.parse::<i64>() {
        toml::Value::Integer(i)
    } else if let Ok(x) = text.parse::<f64>() {
        toml::Value::Float(x)
    } else if let Ok(b) = text.parse::<bool>() {
        toml::Value::Boolean(b)
    } else {
        toml::Value::String(text.to_string())
    }
}

fn from_spec<T: serde::de::DeserializeOwned>(spec: &str, what: &str) -> Result<T, SensorError> {
    toml::Value::Table(spec_table(spec)?)
        .try_into()
        .map_err(|e: toml::de::Error| {
            SensorError::Parse(format!("{what} '{spec}': {}", e.message()))
        })
}

impl LightPulse {
    /// The pulse from `kind:key=value,...`, e.g. `gaussian:centre=5ns,fwhm=2ns` (not
    /// yet checked: see [`LightPulse::compile`]).
    pub fn from_spec(spec: &str) -> Result<LightPulse, SensorError> {
        from_spec(spec, "light")
    }
}

impl Exposure {
    /// The gates from `kind:key=value,...`, e.g. `box:start=10ns,width=1ns,count=32`
    /// or `amcw:freq=20MHz,phase_steps=4` (not yet checked: see [`Exposure::gates`]).
    pub fn from_spec(spec: &str) -> Result<Exposure, SensorError> {
        from_spec(spec, "exposure")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::values::Point;

    #[test]
    fn builtin_presets_load_and_round_trip() {
        for (name, _) in BUILTIN_PRESETS {
            let s = match Sensor::builtin(name) {
                Ok(s) => s,
                Err(e) => panic!("{name}: {e}"),
            };
            let text = match s.to_toml_string() {
                Ok(t) => t,
                Err(e) => panic!("{name}: {e}"),
            };
            assert_eq!(Sensor::from_toml_str(&text), Ok(s), "{name}:\n{text}");
        }
        assert!(Sensor::builtin("nope").is_err());
        // A bare preset name (no such file here) names the spelling that loads it.
        match Sensor::load("lidar") {
            Err(SensorError::Invalid(m)) => assert!(m.contains("builtin:lidar"), "{m}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn specs_parse_units_and_aliases() {
        let l = LightPulse::from_spec("gaussian:centre=5ns,fwhm=2e-9,energy=2");
        assert_eq!(
            l,
            Ok(LightPulse::Gaussian {
                centre_s: 5e-9,
                fwhm_s: 2e-9,
                energy: 2.0
            })
        );
        let e = Exposure::from_spec("amcw:freq=20MHz,phase_steps=4");
        assert!(matches!(e, Ok(Exposure::Amcw { freq_hz, phase_steps: 4, .. }) if freq_hz == 2e7));
        let e = Exposure::from_spec("box:start=1ns,width=1ns,count=1e9");
        assert!(matches!(
            e,
            Ok(Exposure::Box {
                count: 1_000_000_000,
                ..
            })
        ));
        let p = LightPulse::from_spec("piecewise_linear:points=0ns:0;1ns:1;2ns:0");
        assert_eq!(
            p,
            Ok(LightPulse::PiecewiseLinear {
                points: vec![Point(0.0, 0.0), Point(1e-9, 1.0), Point(2e-9, 0.0)],
                energy: 1.0
            })
        );
        assert!(LightPulse::from_spec("gaussian:fwhm=2ns,fhwm=1ns").is_err());
        assert!(LightPulse::from_spec("laser:fwhm=2ns").is_err());
        assert!(LightPulse::from_spec("gaussian:fwhm=2 furlongs").is_err());
        assert!(Exposure::from_spec("box:width").is_err());
    }

    #[test]
    fn unknown_fields_are_rejected_in_files() {
        let text = "[exposure]\nkind = \"box\"\nwidth = 1e-9\nwdith = 2\n";
        assert!(matches!(
            Sensor::from_toml_str(text),
            Err(SensorError::Parse(_))
        ));
        let text = "[exposure]\nkind = \"box\"\nwidth = \"1 ns\"\ncount = 1000000000\n";
        assert!(matches!(
            Sensor::from_toml_str(text),
            Err(SensorError::TooMany { .. })
        ));
    }
}

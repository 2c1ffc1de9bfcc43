//! The TPRF sensor of the paper's section 6:
//!
//! `M_i = max(0, Noise + integral (TPRF * Light)(t) Exposure_i(t) dt)`,
//!
//! computed from a cached transient cube without re-rendering. It knows nothing of
//! rendering: it reads a cube `&[f32]` in `[H, W, T]` layout on a [`TimeAxis`] and
//! writes measurements `[N, H, W]`.
//!
//! The identity behind it (DESIGN.md): `integral (TPRF * Light)(t) Exposure_i(t) dt =
//! integral TPRF(tau) K_i(tau) dtau` with the correlation kernel
//! `K_i(tau) = integral Light(t - tau) Exposure_i(t) dt`. A cube bin holds the integral
//! of the TPRF over the bin, taken as spread uniformly over it, so the kernel a bin
//! meets is `K_i` averaged over the bin ([`kernel`]); a measurement is then one sparse
//! dot product per pixel and gate ([`measure`]).
//!
//! Units: time in seconds (`_s`), frequency in hertz (`_hz`), lengths in metres (`_m`).
//! `Light(t)` is a power envelope with `integral Light dt = energy` (1 by default: the
//! unit pulse the cube was rendered for); `Exposure_i(t)` is a dimensionless
//! sensitivity (0..1 for the presets); so `K_i` is dimensionless and `M_i` has the
//! unit of a cube bin (radiance x seconds for a unit pulse).
//!
//! Parts, one per file:
//! - [`light`]: `Light(t)` presets ([`LightPulse`]) and their compiled form ([`Light`]);
//! - [`exposure`]: `Exposure_i(t)` gate sequences ([`Exposure`]) and single gates ([`Gate`]);
//! - [`fields`]: the editable numbers of each kind of pulse, gates and SPAD, described
//!   by the types themselves (what a form and an envelope editor need), and new ones
//!   of a kind;
//! - [`kernel`]: the bin-averaged kernels `K_i[b]` ([`SparseKernel`]);
//! - [`measure`]: the `[pixels x T] x [T x N]` product ([`Measurements`]);
//! - [`ambient`]: the cube's ambient image added to every gate as a constant rate;
//! - [`noise`]: Gaussian white noise, optional Poisson photon noise, `max(0, .)`;
//! - [`pipeline`]: the one order of a measurement (clean, SPAD, ambient, noise,
//!   derived) that `tprf sensor` and the window both follow;
//! - [`derived`]: a LiDAR's returns (first, strongest, last, multi-echo), AMCW phase
//!   and depth;
//! - [`spad`]: a SPAD behind a TDC (a `tdc` exposure): pile-up, dead time,
//!   afterpulsing, ambient light and dark counts, the Coates correction;
//! - [`preset`]: sensor files (TOML) and the built-in presets;
//! - [`model`]: [`SensorModel`], a sensor compiled for one time axis, with its kernels
//!   cached: what a viewer keeps and updates as the user edits.

pub mod ambient;
pub mod derived;
pub mod exposure;
pub mod fields;
pub mod gradient;
pub mod kernel;
pub mod light;
pub mod measure;
pub mod model;
pub mod noise;
pub mod pipeline;
pub mod preset;
mod quad;
pub mod spad;
mod values;

pub use derived::{AmcwImage, Derived, Echo, ReturnImages, Returns};
pub use exposure::{Exposure, Gate, MAX_GATES, TimeOrigin};
pub use fields::{EXPOSURE_KINDS, Field, HandleAt, LIGHT_KINDS, Quantity, kind_label};
pub use kernel::{SparseKernel, compute_kernels};
pub use light::{Light, LightPulse};
pub use measure::{Measurements, PackedKernels};
pub use model::{PixelTrace, SensorModel, Update};
pub use noise::{Noise, NoiseField};
pub use pipeline::{Draws, Gates, Pipeline};
pub use preset::{BUILTIN_PRESETS, Sensor};
pub use spad::{Acquisition, Spad, SpadImage, spad_image, spad_image_ambient};
pub use values::Point;

pub use crate::film::TimeAxis;

use std::path::PathBuf;

/// Why a sensor description or a cube cannot be used. Messages name the parameter
/// (`light.fwhm_s`, `exposure.count`) and what is allowed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SensorError {
    #[error("{what} = {value} is not a finite number")]
    NotFinite { what: String, value: f64 },
    #[error("{what} = {value}: it must be {rule}")]
    OutOfRange {
        what: String,
        value: f64,
        rule: &'static str,
    },
    #[error("{what} = {count} is too many (at most {max})")]
    TooMany { what: String, count: u64, max: u64 },
    #[error("{0}")]
    Invalid(String),
    #[error("cannot read sensor file {path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("not a valid sensor description: {0}")]
    Parse(String),
    /// A memory budget's refusal ([`crate::budget::BudgetError`] in words: the size
    /// needed, what for, and what is available).
    #[error("{0}")]
    Budget(String),
    #[error(
        "the cube has {got} values, but height {height} x width {width} x bins {bins} = \
         {expected}"
    )]
    CubeSize {
        got: usize,
        height: usize,
        width: usize,
        bins: usize,
        expected: usize,
    },
}

/// `value` if finite.
pub(crate) fn finite(what: &str, value: f64) -> Result<f64, SensorError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(SensorError::NotFinite {
            what: what.to_string(),
            value,
        })
    }
}

/// `value` if `ok`, else out of range by `rule`.
fn in_range(what: &str, value: f64, ok: bool, rule: &'static str) -> Result<f64, SensorError> {
    if ok {
        Ok(value)
    } else {
        Err(SensorError::OutOfRange {
            what: what.to_string(),
            value,
            rule,
        })
    }
}

/// `value` if finite and `>= 0`.
pub(crate) fn non_negative(what: &str, value: f64) -> Result<f64, SensorError> {
    finite(what, value)?;
    in_range(what, value, value >= 0.0, ">= 0")
}

/// The largest factor a setting may scale a measurement by: measurements are float32
/// (largest 3.4e38), and a cube bin times a kernel times this stays inside it.
pub(crate) const MAX_SCALE: f64 = 1e30;

/// `value` if `>= 0` and at most [`MAX_SCALE`] (a gain, an energy, a noise level).
pub(crate) fn scale(what: &str, value: f64) -> Result<f64, SensorError> {
    non_negative(what, value)?;
    in_range(
        what,
        value,
        value <= MAX_SCALE,
        "<= 1e30 (measurements are float32)",
    )
}

/// The largest time or duration a sensor setting may hold: one second (3e8 m of light
/// path; a laser cycle of 1 Hz). Beyond it, depths and gate positions leave float32.
pub const MAX_TIME_S: f64 = 1.0;

/// A time in seconds: finite and within `+-MAX_TIME_S`.
pub(crate) fn time_s(what: &str, value: f64) -> Result<f64, SensorError> {
    finite(what, value)?;
    in_range(
        what,
        value,
        value.abs() <= MAX_TIME_S,
        "within +-1 s (a time of flight)",
    )
}

/// A duration in seconds: `>= 0` (`> 0` when `strict`) and at most `MAX_TIME_S`.
pub(crate) fn duration_s(what: &str, value: f64, strict: bool) -> Result<f64, SensorError> {
    if strict {
        positive(what, value)?;
    } else {
        non_negative(what, value)?;
    }
    in_range(what, value, value <= MAX_TIME_S, "<= 1 s")
}

/// `value` if finite and `> 0`.
pub(crate) fn positive(what: &str, value: f64) -> Result<f64, SensorError> {
    finite(what, value)?;
    in_range(what, value, value > 0.0, "> 0")
}

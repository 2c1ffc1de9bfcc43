//! One render, described once: [`RenderRequest`] holds everything a render of a scene
//! into a transient cube depends on (the scene and an optional camera pose, the film's
//! size and time window, the sampling, the bounces, when to stop, the seed, the threads,
//! the files), validated once ([`RenderRequest::validate`]) with messages that name the
//! field. Every front end builds one: `tprf render`'s arguments, a `tprf batch`
//! manifest's job (its TOML keys are the request's fields), Python's keyword arguments,
//! the window's settings, `tprf converge` and `tprf stability`; a Mitsuba scene file's
//! settings fill the fields a front end was not given
//! ([`RenderRequest::with_file_defaults`]).
//!
//! What a request becomes:
//! - [`Session`]: the scene loaded (with the request's sky and camera), the renderer, the
//!   time window (a pilot render when it is not given whole) and an empty film, then its
//!   passes ([`Session::run`]: `progressive::render` with the request's schedule, a
//!   callback after each pass);
//! - [`render`]: that render in memory, with its metadata and ambient image (what Python's
//!   `tprf.render` returns);
//! - [`render_to_folder`]: that render and its files (`tprf render`'s folder: the cube,
//!   `tprf.json`, the steady image, the ambient image, frames, a shard's rows), written
//!   by [`write_folder`] beside the folder and swapped in whole;
//! - [`worker::RenderWorker`]: that render on a background thread, for the window.
//!
//! [`MeasureRequest`] does the same for a measurement of a rendered cube by a sensor
//! (`tprf sensor`, a batch manifest's sensor jobs), [`CaptureRequest`] for an NLOS
//! capture (`tprf nlos`) and [`ReconstructRequest`] for the reconstruction of a hidden
//! scene from one (`tprf nlos reconstruct`).
//!
//! Units: times in seconds (read from a number of seconds, or text with a unit:
//! `"3ns"`, `"1.5m"` of optical path), lengths in metres, angles in degrees, radiance in
//! W m^-2 sr^-1.

mod camera;
mod capture;
mod differentiable;
mod file_defaults;
mod folder;
mod keys;
mod measure;
mod memory;
pub mod parameter;
mod reconstruct;
mod session;
mod spectral;
pub mod worker;

pub use camera::apply_camera;
pub use capture::{CaptureError, CaptureObserver, CaptureRequest, Quiet};
pub use differentiable::{Differentiable, DifferentiableError, Forward};
pub use file_defaults::FileNote;
pub use folder::{
    Observer, Rendered, Written, cube_metadata, render, render_to_folder, write_folder,
};
pub use keys::serde_keys;
pub use measure::{MeasureError, MeasureRequest, Measured};
pub use memory::{MemoryLimit, MemoryRefusal, MemoryStop};
pub use reconstruct::{ReconstructError, ReconstructRequest, VolumeSpec, parse_length_m};
pub use session::Session;

use crate::export::phasor::PhasorBand;
use crate::export::shard::{self, ShardError, ShardSpec};
use crate::export::{CubeFormat, ExportError};
use crate::film::{FilmError, MAX_BINS, TimeFilter};
use crate::scene::{Channel, Medium, PulseOrigin, SceneError, TimeOrigin};
use crate::transport::progressive::{PassSize, Schedule};
use crate::transport::{RenderSettings, WindowError, WindowRequest};
use serde::{Deserialize, Deserializer, Serialize};
use std::fmt;

/// Samples per pixel of a render given no other way to stop (no `spp`, `seconds` or
/// `error_target`, and not `until_stopped`).
pub const DEFAULT_SPP: u64 = 64;

/// Largest image side a request accepts, pixels.
pub const MAX_SIDE: usize = 16384;

/// Largest samples per pixel of one doubling pass (more on small films:
/// [`crate::transport::progressive::doubling_cap`]).
pub const PASS_CAP_SPP: u32 = 16;

/// A render: what `tprf render` does, as data. Serialised with the names of
/// `tprf render`'s options (`t0`, `dt`, `max_bounces`, `sky` ...), which are also the keys
/// of a `tprf batch` manifest's jobs; a field left out takes its default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderRequest {
    /// What to render: `builtin:NAME` or a .gltf/.glb path.
    pub scene: String,
    /// Image width, pixels (default 256).
    pub width: usize,
    /// Image height, pixels (default 256).
    pub height: usize,
    /// Time bins (default 256).
    pub bins: usize,
    /// Start of the time window, seconds (`t0`; unset: just before the first arrival a
    /// pilot render sees).
    #[serde(
        rename = "t0",
        deserialize_with = "time_s",
        skip_serializing_if = "Option::is_none"
    )]
    pub t0_s: Option<f64>,
    /// Bin width, seconds (`dt`; unset: the window holding 99.5 % of a pilot render's
    /// energy, and with media of the surfaces' returns, over `bins`: [`crate::transport::auto_window`]).
    #[serde(
        rename = "dt",
        deserialize_with = "time_s",
        skip_serializing_if = "Option::is_none"
    )]
    pub dt_s: Option<f64>,
    /// Stop at exactly this many samples per pixel.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spp: Option<u64>,
    /// Stop at the end of the first pass after this many seconds of wall time.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seconds: Option<f64>,
    /// Stop once the film's relative error estimate (two independent halves) is at or
    /// below this (0.01: 1 %).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_target: Option<f64>,
    /// Render until the caller stops it (the window, a report with its own clock): with
    /// no `spp`, `seconds` or `error_target`, no [`DEFAULT_SPP`].
    pub until_stopped: bool,
    /// Passes of about this many seconds, growing to 4 times that over the first 6 s,
    /// for a live preview (their sizes follow the machine's speed). Unset: doubling
    /// passes (1, 1, 2, 2, 4, ... samples per pixel), the same film on any machine.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pass_seconds: Option<f64>,
    /// Largest number of scattering events on a path (default 1024).
    pub max_bounces: u32,
    /// Fewest scattering events of a recorded path (default 0: every path; 2 leaves out
    /// direct reflection, 3 an NLOS view's light from the wall straight to the wall).
    pub min_bounces: u32,
    /// Per-bounce layers: bounce 0 (emitters seen directly), 1..=K and the rest.
    pub bounces_separate: u32,
    pub seed: u64,
    /// The spectral band the one-channel cube records (red, green, blue, gray, or a
    /// wavelength: `550nm`).
    #[serde(deserialize_with = "from_text")]
    pub channel: Channel,
    /// Several bands in one render (`--wavelengths 450nm,550nm,650nm`, `--spectrum
    /// 400nm:700nm:31`; a list here): `tprf_spectral.npy` `[L, H, W, T]`, band k at the
    /// k-th, and `tprf.npy` their luminance, or the band `channel` names when it is one
    /// of them (docs/dispersion.md). Empty (the default): the one band `channel`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub wavelengths: Vec<crate::scene::spectrum::Wavelength>,
    /// Every pixel draws every pass's samples; off (the default): adaptive sampling.
    pub uniform: bool,
    /// Render polarized (docs/polarization.md): the Stokes cube `tprf_stokes.npy`
    /// `[4, H, W, T]` beside `tprf.npy` (= S0). Scenes with media or luminescent
    /// materials are refused; written as npy only (not Zarr) for now.
    pub polarized: bool,
    /// Next-event estimation (default on).
    pub nee: bool,
    /// Scattering events before Russian roulette starts (default 3).
    pub rr_start: u32,
    /// Smallest survival probability of Russian roulette, in [0, 1] (default 0).
    pub rr_floor: f32,
    /// Branches of each camera sample at its first scattering vertex, 1..=64 (unset:
    /// chosen per render by a pilot).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub splits: Option<u32>,
    /// Eye vertices joined to light vertices (unset: chosen per render by a pilot).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub light_vertex: Option<bool>,
    /// The time filter: `box` (a bin holds what arrived in it) or `tent`.
    #[serde(rename = "filter")]
    pub time_filter: TimeFilter,
    /// A constant sky of this radiance (W m^-2 sr^-1, every band) in the ambient light
    /// group, replacing the scene's own (`sky`). Never pulsed: only the ambient image.
    #[serde(rename = "sky", skip_serializing_if = "Option::is_none")]
    pub sky_radiance_w_m2_sr: Option<f64>,
    /// Samples per pixel of the ambient image (default: `spp`, or 64).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ambient_spp: Option<u32>,
    /// A participating medium filling the scene (the air: fog, haze, water), replacing
    /// the scene's own: `sigma_s=0.05/m,sigma_a=0.001/m,g=0.9,n=1.0`, `visibility=30m`
    /// or `none` (vacuum); [`crate::scene::Medium::parse_spec`] reads it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub medium: Option<String>,
    /// The camera's position, metres (`camera_position`; unset: the scene camera's).
    #[serde(rename = "camera_position", skip_serializing_if = "Option::is_none")]
    pub camera_position_m: Option<[f64; 3]>,
    /// The point the camera looks at, metres (`look_at`; unset: the scene camera's
    /// direction).
    #[serde(rename = "look_at", skip_serializing_if = "Option::is_none")]
    pub look_at_m: Option<[f64; 3]>,
    /// The camera's up direction (with `look_at`; default +Y, or +Z looking along Y).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub up: Option<[f64; 3]>,
    /// Vertical field of view, degrees (`fov`; unset: the scene camera's).
    #[serde(rename = "fov", skip_serializing_if = "Option::is_none")]
    pub fov_deg: Option<f64>,
    /// Where a path's clock starts: `pinhole` (the time a real camera sees; the
    /// default), `near-plane` (from the camera's near clip plane, as mitransient counts)
    /// or `first-hit` (the camera's own leg left out, each pixel's time starting at the
    /// first surface it sees: mitransient's `camera_unwarp`).
    #[serde(deserialize_with = "from_text")]
    pub time_origin: TimeOrigin,
    /// When the pulse starts: `light` (as it leaves the light: the default) or
    /// `first-hit` (at the first surface it lights, the light's leg left out: an NLOS
    /// laser's spot firing at t = 0, mitransient's `account_first_and_last_bounces`
    /// false). Not in scenes with participating media.
    #[serde(deserialize_with = "from_text")]
    pub pulse_origin: PulseOrigin,
    /// Worker threads (unset: one per core). The film does not depend on it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub threads: Option<usize>,
    /// How the cube is written: `npy`, `zarr` or `auto` (npy up to 4 GiB).
    #[serde(deserialize_with = "from_text")]
    pub format: CubeFormat,
    /// Also write `frames/0000.png` ... (one per bin, one exposure).
    pub frames: bool,
    /// Render only shard K of N (`"K/N"`, 0-based): bands of `band_rows` rows, band b
    /// going to shard b mod N.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shard: Option<String>,
    /// Rows per band of `shard` (default 32, the Zarr chunk height).
    pub band_rows: usize,
    /// The most memory the film may take, bytes (`max_memory`: a number of bytes, or
    /// text with a unit, `"2GiB"`): its fixed part, its store of the bins that received
    /// light, and what a pass builds beside them (the scene and the renderer are not
    /// counted). Before a pass that would exceed it, or what the process may still
    /// allocate, the render stops at the last whole pass ([`MemoryStop`]).
    #[serde(
        rename = "max_memory",
        deserialize_with = "bytes",
        skip_serializing_if = "Option::is_none"
    )]
    pub max_memory_bytes: Option<u64>,
    /// Also write the cube's phasors at mitransient's frequencies for this band of
    /// wavelengths (`phasor`: `WL_MEAN:WL_SIGMA`, metres of optical path, as
    /// `phasor_hdr_film`'s `wl_mean` and `wl_sigma`; a Mitsuba file with that film sets
    /// it): `phasor.npy` and `phasor.json`, computed from the film after the render
    /// ([`crate::export::phasor`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub phasor: Option<PhasorBand>,
}

impl Default for RenderRequest {
    fn default() -> Self {
        let settings = RenderSettings::default();
        RenderRequest {
            scene: String::new(),
            width: 256,
            height: 256,
            bins: 256,
            t0_s: None,
            dt_s: None,
            spp: None,
            seconds: None,
            error_target: None,
            until_stopped: false,
            pass_seconds: None,
            max_bounces: settings.max_bounces,
            min_bounces: settings.min_bounces,
            bounces_separate: 0,
            seed: settings.seed,
            channel: settings.channel,
            wavelengths: Vec::new(),
            uniform: !settings.adaptive,
            polarized: false,
            nee: settings.nee,
            rr_start: settings.rr_start,
            rr_floor: settings.rr_min_survival,
            splits: None,
            light_vertex: settings.light_vertex,
            time_filter: TimeFilter::Box,
            sky_radiance_w_m2_sr: None,
            ambient_spp: None,
            medium: None,
            camera_position_m: None,
            look_at_m: None,
            up: None,
            fov_deg: None,
            time_origin: settings.time_origin,
            pulse_origin: settings.pulse_origin,
            threads: None,
            format: CubeFormat::Auto,
            frames: false,
            shard: None,
            band_rows: shard::DEFAULT_BAND_ROWS,
            max_memory_bytes: None,
            phasor: None,
        }
    }
}

/// One piece of a [`Problem`]'s message: text, or a request field's name.
#[derive(Clone, Debug, PartialEq)]
enum Part {
    Text(String),
    Field(&'static str),
}

/// What is wrong with a request: a message naming the fields concerned, written with
/// the request's field names (`dt: bin width -1 ns must be > 0`), or with another
/// front end's names for them ([`Problem::text_with`]: `--dt` on the command line).
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    parts: Vec<Part>,
}

impl Problem {
    pub(super) fn field(name: &'static str) -> Problem {
        Problem {
            parts: vec![Part::Field(name)],
        }
    }

    fn text_only(text: impl Into<String>) -> Problem {
        Problem {
            parts: vec![Part::Text(text.into())],
        }
    }

    fn and(mut self, name: &'static str) -> Problem {
        self.parts.push(Part::Field(name));
        self
    }

    pub(super) fn text(mut self, text: impl Into<String>) -> Problem {
        self.parts.push(Part::Text(text.into()));
        self
    }

    /// The fields the message names, first the one at fault.
    pub fn fields(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.parts.iter().filter_map(|p| match p {
            Part::Field(f) => Some(*f),
            Part::Text(_) => None,
        })
    }

    /// The message with each field named by `name` (the command line's `--band-rows`
    /// for `band_rows`, say).
    pub fn text_with(&self, name: impl Fn(&str) -> String) -> String {
        self.parts
            .iter()
            .map(|p| match p {
                Part::Text(t) => t.clone(),
                Part::Field(f) => name(f),
            })
            .collect()
    }
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text_with(str::to_string))
    }
}

/// Why a request cannot be rendered, or its render not written.
#[derive(Debug, thiserror::Error)]
pub enum RequestError {
    /// A field's value is not allowed; the message names it.
    #[error("{0}")]
    Invalid(Problem),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Window(#[from] WindowError),
    #[error(transparent)]
    Film(#[from] FilmError),
    #[error(transparent)]
    Shard(#[from] ShardError),
    #[error(transparent)]
    Export(#[from] ExportError),
    #[error("cannot start the render threads")]
    Threads(#[source] rayon::ThreadPoolBuildError),
    /// The first pass cannot fit in memory: the film foreseen by a pilot render.
    #[error("{0}")]
    Memory(MemoryRefusal),
    #[error(
        "{non_finite} sample contributions were NaN or infinite (of {paths} paths): an \
         emitter or a light of {scene} overflows, or a material is broken; the cube was not \
         written"
    )]
    NonFinite {
        non_finite: u64,
        paths: u64,
        scene: String,
    },
    #[error(
        "the ambient image had {0} NaN or infinite contributions: a sun, sky or ambient lamp \
         overflows; nothing was written"
    )]
    AmbientNonFinite(u64),
    #[error(
        "the cube files for {width} x {height} pixels x {bins} bins need {need_gib:.1} GiB, \
         and {out} has {free_gib:.1} GiB free; lower the resolution or the bins"
    )]
    DiskFull {
        width: usize,
        height: usize,
        bins: usize,
        need_gib: f64,
        out: String,
        free_gib: f64,
    },
    /// The caller stopped the writing of the output (Ctrl-C): nothing was written.
    #[error("interrupted (Ctrl-C) while writing: nothing was written")]
    Interrupted,
}

impl RequestError {
    fn invalid(problem: Problem) -> RequestError {
        RequestError::Invalid(problem)
    }
}

/// A number for messages: as written up to a million, in exponent form beyond.
fn number_text(v: f64) -> String {
    if v.is_finite() && v.abs() >= 1e6 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A time for messages: `-1 ns`, `0 s`, `2.5 ps` (at most 6 significant digits).
fn time_text(seconds: f64) -> String {
    if !seconds.is_finite() {
        return format!("{seconds} s");
    }
    let (scale, unit) = crate::units::time_unit(seconds);
    let v = seconds * scale;
    let text = format!("{v:.6}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    format!("{text} {unit}")
}

/// Read a time field given as text with a unit (`"3ns"`, `"1.5m"` of optical path:
/// [`crate::units::parse_time_s`]); empty text is unset. The one reading of times
/// with units for requests: the command line's `--t0`/`--dt`, the window's fields and
/// manifests all come through it. Errors name `field`.
pub fn parse_time_field(field: &'static str, text: &str) -> Result<Option<f64>, RequestError> {
    if text.trim().is_empty() {
        return Ok(None);
    }
    crate::units::parse_time_s(text)
        .map(Some)
        .map_err(|why| RequestError::invalid(Problem::field(field).text(format!(": {why}"))))
}

/// The text of a time field that [`parse_time_field`] reads back as exactly `seconds`:
/// metres of optical path (`"1.5m"`, as a scene file gives a window) where that reads
/// back bit for bit, else seconds (`"5.2e-9s"`).
pub fn time_field_text(seconds: f64) -> String {
    let metres = format!("{}m", seconds * crate::units::C_M_PER_S);
    match crate::units::parse_time_s(&metres) {
        Ok(back) if back.to_bits() == seconds.to_bits() => metres,
        _ => format!("{seconds}s"),
    }
}

/// A time field: a number of seconds, or text with a unit.
fn time_s<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Time {
        Seconds(f64),
        Text(String),
    }
    match Option::<Time>::deserialize(d)? {
        None => Ok(None),
        Some(Time::Seconds(s)) => Ok(Some(s)),
        Some(Time::Text(t)) => crate::units::parse_time_s(&t)
            .map(Some)
            .map_err(serde::de::Error::custom),
    }
}

/// A size in bytes: a number, or text with a unit ([`crate::budget::parse_bytes`]).
fn bytes<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u64>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Size {
        Bytes(u64),
        Text(String),
    }
    match Option::<Size>::deserialize(d)? {
        None => Ok(None),
        Some(Size::Bytes(b)) => Ok(Some(b)),
        Some(Size::Text(t)) => crate::budget::parse_bytes(&t)
            .map(Some)
            .map_err(serde::de::Error::custom),
    }
}

/// A field read through its `FromStr` (case and spaces as the command line takes them).
fn from_text<'de, D, T>(d: D) -> Result<T, D::Error>
where
    D: Deserializer<'de>,
    T: std::str::FromStr,
    T::Err: fmt::Display,
{
    let text = String::deserialize(d)?;
    text.parse().map_err(serde::de::Error::custom)
}

impl RenderRequest {
    /// A request for `scene` with every other field at its default.
    pub fn new(scene: impl Into<String>) -> RenderRequest {
        RenderRequest {
            scene: scene.into(),
            ..RenderRequest::default()
        }
    }

    /// The scene-wide medium `medium` puts in place of the scene's: `None` when not
    /// set, `Some(None)` for `none` (vacuum).
    pub fn medium_override(&self) -> Result<Option<Option<Medium>>, RequestError> {
        match self.medium.as_deref().map(str::trim) {
            None => Ok(None),
            Some("none") => Ok(Some(None)),
            Some(spec) => Medium::parse_spec(spec)
                .map(|m| Some(Some(m)))
                .map_err(|e| {
                    RequestError::invalid(Problem::field("medium").text(format!(": {e}")))
                }),
        }
    }

    /// Check every field and the fields together, before anything is loaded or
    /// rendered; the error names the field (`dt: bin width -1 ns must be > 0`).
    pub fn validate(&self) -> Result<(), RequestError> {
        let bad = |field: &'static str, text: String| {
            Err(RequestError::invalid(Problem::field(field).text(text)))
        };
        if self.scene.trim().is_empty() {
            return bad(
                "scene",
                ": no scene given (builtin:NAME or a .gltf/.glb path)".into(),
            );
        }
        for (field, side) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_SIDE).contains(&side) {
                return bad(field, format!(": {side} pixels; must be in 1..={MAX_SIDE}"));
            }
        }
        if !(1..=MAX_BINS).contains(&self.bins) {
            return bad("bins", format!(": {} must be in 1..={MAX_BINS}", self.bins));
        }
        if let Some(t0) = self.t0_s
            && !t0.is_finite()
        {
            return bad(
                "t0",
                format!(": window start {} is not finite", time_text(t0)),
            );
        }
        if let Some(dt) = self.dt_s
            && !(dt.is_finite() && dt > 0.0)
        {
            return bad(
                "dt",
                format!(": bin width {} must be finite and > 0", time_text(dt)),
            );
        }
        if self.spp == Some(0) {
            return bad("spp", " must be at least 1".into());
        }
        if let Some(s) = self.seconds
            && !(s.is_finite() && s > 0.0)
        {
            return bad("seconds", format!(" must be a positive number (got {s})"));
        }
        if let Some(e) = self.error_target
            && !(e.is_finite() && e > 0.0)
        {
            return bad(
                "error_target",
                format!(" must be a positive relative error, 0.01 for 1 % (got {e})"),
            );
        }
        if let Some(s) = self.pass_seconds
            && !(s.is_finite() && s > 0.0)
        {
            return bad(
                "pass_seconds",
                format!(" must be a positive number (got {s})"),
            );
        }
        if self.min_bounces > self.max_bounces {
            return bad(
                "min_bounces",
                format!(
                    ": {} is more than max_bounces {}: no path would be recorded",
                    self.min_bounces, self.max_bounces
                ),
            );
        }
        if !(0.0..=1.0).contains(&self.rr_floor) {
            return bad(
                "rr_floor",
                format!(
                    ": a survival probability must be in [0, 1] (got {})",
                    self.rr_floor
                ),
            );
        }
        if let Some(k) = self.splits
            && !(1..=64).contains(&k)
        {
            return bad("splits", format!(" must be in 1..=64 (got {k})"));
        }
        if let Some(l) = self.sky_radiance_w_m2_sr
            && !(l.is_finite() && l >= 0.0 && l <= f32::MAX as f64)
        {
            return bad(
                "sky",
                format!(
                    ": sky radiance {} W m^-2 sr^-1 must be finite, >= 0 and at most {:e}",
                    number_text(l),
                    f32::MAX
                ),
            );
        }
        if self.ambient_spp == Some(0) {
            return bad("ambient_spp", " must be at least 1".into());
        }
        if self.polarized && self.format == CubeFormat::Zarr {
            return bad(
                "polarized",
                ": the Stokes cube is written as npy only (tprf_stokes.npy); Zarr is not \
                 supported yet (use format npy)"
                    .into(),
            );
        }
        self.medium_override()?;
        if self.threads == Some(0) {
            return bad("threads", " must be at least 1".into());
        }
        if self.max_memory_bytes == Some(0) {
            return bad("max_memory", " must be at least 1 byte".into());
        }
        camera::check(self)?;
        if let Some(band) = self.phasor {
            let dt_opl_m = self.dt_s.map(|dt| dt * crate::units::C_M_PER_S);
            let checked = match dt_opl_m {
                Some(dt) => band.index_range(self.bins, dt).map(|_| ()),
                None => band.check(),
            };
            if let Err(why) = checked {
                return bad("phasor", format!(": {why}"));
            }
            if self.shard.is_some() {
                return Err(RequestError::invalid(
                    Problem::field("phasor")
                        .text(" cannot be written by a ")
                        .and("shard")
                        .text(": it holds some rows only"),
                ));
            }
        }
        if let Some(spec) = self.shard_spec()? {
            if self.seconds.is_some() {
                return Err(RequestError::invalid(
                    Problem::field("shard")
                        .text(" needs a fixed ")
                        .and("spp")
                        .text(": a ")
                        .and("seconds")
                        .text(" budget gives each shard other passes"),
                ));
            }
            if self.pass_seconds.is_some() || self.error_target.is_some() || self.until_stopped {
                return Err(RequestError::invalid(
                    Problem::field("shard")
                        .text(" needs a fixed ")
                        .and("spp")
                        .text(": a shard's passes must be those of the whole render"),
                ));
            }
            if !self.uniform {
                return Err(RequestError::invalid(
                    Problem::field("shard").text(" needs ").and("uniform").text(
                        ": adaptive sampling plans each pixel's samples from the whole \
                             image's noise, which a shard does not see",
                    ),
                ));
            }
            if self.frames {
                return Err(RequestError::invalid(
                    Problem::field("frames")
                        .text(" cannot be written by a ")
                        .and("shard")
                        .text(": it holds some rows only (merge the shards first)"),
                ));
            }
            spec.check(self.height)?;
        }
        self.check_wavelengths()
    }

    /// The shard this request renders (`None`: the whole image); refused when `shard`
    /// is not `K/N` with `0 <= K < N` or `band_rows` is 0.
    pub fn shard_spec(&self) -> Result<Option<ShardSpec>, RequestError> {
        self.shard
            .as_deref()
            .map(|s| ShardSpec::parse(s, self.band_rows))
            .transpose()
            .map_err(RequestError::from)
    }

    /// The path tracer's settings.
    pub fn settings(&self) -> RenderSettings {
        RenderSettings {
            max_bounces: self.max_bounces,
            min_bounces: self.min_bounces,
            seed: self.seed,
            channel: self.channel,
            nee: self.nee,
            rr_start: self.rr_start,
            rr_min_survival: self.rr_floor,
            first_bounce_splits: self.splits.unwrap_or(0),
            light_vertex: self.light_vertex,
            adaptive: !self.uniform,
            time_origin: self.time_origin,
            pulse_origin: self.pulse_origin,
            luminescence_delay: Default::default(),
        }
    }

    /// Whether `other` renders the same prepared scene as this request (the same scene,
    /// sky, medium and estimator settings: [`Session::with_renderer`] may reuse this
    /// request's renderer for it), whatever its camera, film, window, schedule and
    /// files. The scene is named, not read: whether its file changed is not looked at.
    pub fn same_scene(&self, other: &RenderRequest) -> bool {
        self.scene == other.scene
            && self.sky_radiance_w_m2_sr == other.sky_radiance_w_m2_sr
            && self.medium == other.medium
            && self.settings() == other.settings()
    }

    /// These estimator settings (`max_bounces`, `min_bounces`, `seed`, `channel`, `nee`, the roulette,
    /// `splits`, `light_vertex`, `uniform`) taken from `settings`.
    pub fn with_settings(self, settings: RenderSettings) -> RenderRequest {
        RenderRequest {
            max_bounces: settings.max_bounces,
            min_bounces: settings.min_bounces,
            seed: settings.seed,
            channel: settings.channel,
            nee: settings.nee,
            rr_start: settings.rr_start,
            rr_floor: settings.rr_min_survival,
            splits: (settings.first_bounce_splits > 0).then_some(settings.first_bounce_splits),
            light_vertex: settings.light_vertex,
            uniform: !settings.adaptive,
            time_origin: settings.time_origin,
            pulse_origin: settings.pulse_origin,
            ..self
        }
    }

    /// What the time window fixes (the rest a pilot render chooses).
    pub fn window(&self) -> WindowRequest {
        WindowRequest {
            t0_s: self.t0_s,
            dt_s: self.dt_s,
            bins: self.bins,
            aspect: self.width as f64 / self.height.max(1) as f64,
        }
    }

    /// The samples per pixel the render stops at: `spp`, or [`DEFAULT_SPP`] when
    /// nothing else ends it.
    pub fn spp_target(&self) -> Option<u64> {
        self.spp.or_else(|| {
            (self.seconds.is_none() && self.error_target.is_none() && !self.until_stopped)
                .then_some(DEFAULT_SPP)
        })
    }

    /// The passes: doubling ones ([`PASS_CAP_SPP`] per pass at most, more on small
    /// films) or paced ones (`pass_seconds`), until the spp target or the time budget.
    pub fn schedule(&self) -> Schedule {
        Schedule {
            pass_size: match self.pass_seconds {
                Some(seconds) => PassSize::Paced { seconds },
                None => PassSize::Doubling { cap: PASS_CAP_SPP },
            },
            spp_target: self.spp_target(),
            time_budget_s: self.seconds,
        }
    }

    /// Samples per pixel of the ambient image: `ambient_spp`, or `spp`, or 64.
    pub fn ambient_spp(&self) -> u32 {
        self.ambient_spp.unwrap_or_else(|| {
            self.spp
                .map_or(DEFAULT_SPP as u32, |n| n.min(u32::MAX as u64) as u32)
        })
    }

    /// The worker pool the request asks for: `threads` threads, or one per core.
    pub fn thread_pool(&self) -> Result<rayon::ThreadPool, RequestError> {
        let mut pool = rayon::ThreadPoolBuilder::new();
        if let Some(n) = self.threads {
            pool = pool.num_threads(n);
        }
        pool.build().map_err(RequestError::Threads)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problem(r: &RenderRequest) -> String {
        match r.validate() {
            Err(e) => e.to_string(),
            Ok(()) => panic!("{r:?} was accepted"),
        }
    }

    #[test]
    fn the_defaults_are_tprf_renders() {
        let r = RenderRequest::new("builtin:cornell");
        r.validate().unwrap();
        assert_eq!((r.width, r.height, r.bins), (256, 256, 256));
        assert_eq!(r.spp_target(), Some(DEFAULT_SPP));
        assert_eq!(r.settings(), RenderSettings::default());
        assert_eq!(r.schedule(), Schedule::spp(DEFAULT_SPP));
        let timed = RenderRequest {
            seconds: Some(2.0),
            ..r.clone()
        };
        assert_eq!(timed.schedule(), Schedule::seconds(2.0));
        let live = RenderRequest {
            until_stopped: true,
            pass_seconds: Some(0.25),
            ..r
        };
        assert_eq!(live.schedule(), Schedule::paced(0.25, None));
    }

    /// Each refusal names its field, with the value where there is one.
    #[test]
    fn bad_fields_are_named() {
        let r = RenderRequest::new("builtin:cornell");
        let cases: Vec<(RenderRequest, &str)> = vec![
            (RenderRequest::new(" "), "scene: no scene given"),
            (
                RenderRequest {
                    width: 0,
                    ..r.clone()
                },
                "width: 0 pixels",
            ),
            (
                RenderRequest {
                    dt_s: Some(-1e-9),
                    ..r.clone()
                },
                "dt: bin width -1 ns must be finite and > 0",
            ),
            (
                RenderRequest {
                    dt_s: Some(0.0),
                    ..r.clone()
                },
                "bin width 0 s",
            ),
            (
                RenderRequest {
                    t0_s: Some(f64::INFINITY),
                    ..r.clone()
                },
                "t0: window start inf s is not finite",
            ),
            (
                RenderRequest {
                    bins: 0,
                    ..r.clone()
                },
                "bins: 0 must be in 1..=",
            ),
            (
                RenderRequest {
                    spp: Some(0),
                    ..r.clone()
                },
                "spp must be at least 1",
            ),
            (
                RenderRequest {
                    seconds: Some(f64::NAN),
                    ..r.clone()
                },
                "seconds must be a positive number (got NaN)",
            ),
            (
                RenderRequest {
                    sky_radiance_w_m2_sr: Some(f64::MAX),
                    ..r.clone()
                },
                "sky: sky radiance",
            ),
            (
                RenderRequest {
                    sky_radiance_w_m2_sr: Some(-1.0),
                    ..r.clone()
                },
                "sky: sky radiance -1 W m^-2 sr^-1",
            ),
            (
                RenderRequest {
                    shard: Some("0/2".into()),
                    spp: Some(2),
                    ..r.clone()
                },
                "shard needs uniform",
            ),
            (
                RenderRequest {
                    shard: Some("0/2".into()),
                    seconds: Some(1.0),
                    uniform: true,
                    ..r.clone()
                },
                "shard needs a fixed spp: a seconds budget",
            ),
            (
                RenderRequest {
                    shard: Some("2/2".into()),
                    uniform: true,
                    ..r.clone()
                },
                "K/N",
            ),
            (
                RenderRequest {
                    rr_floor: 1.5,
                    ..r.clone()
                },
                "rr_floor",
            ),
            (
                RenderRequest {
                    threads: Some(0),
                    ..r.clone()
                },
                "threads must be at least 1",
            ),
        ];
        for (req, want) in cases {
            let got = problem(&req);
            assert!(got.contains(want), "{got:?} should say {want:?}");
        }
    }

    /// The command line names the same problem by its flags.
    #[test]
    fn a_problem_reads_with_other_names() {
        let r = RenderRequest {
            shard: Some("0/2".into()),
            spp: Some(2),
            ..RenderRequest::new("builtin:cornell")
        };
        let Err(RequestError::Invalid(p)) = r.validate() else {
            panic!("accepted");
        };
        assert_eq!(p.fields().collect::<Vec<_>>(), ["shard", "uniform"]);
        let flags = p.text_with(|f| format!("--{}", f.replace('_', "-")));
        assert!(flags.starts_with("--shard needs --uniform: "), "{flags}");
    }

    /// A manifest's table: times with units or in seconds, the band and format as the
    /// command line writes them, unknown keys refused; written back, it reads the same.
    #[test]
    fn requests_read_and_write_toml() {
        let r: RenderRequest = toml::from_str(
            "scene = \"builtin:cornell\"\nwidth = 32\nt0 = \"1.5m\"\ndt = 2e-11\n\
             channel = \"Red\"\nformat = \"zarr\"\nfov = 30\nlook_at = [0, 1, 0]\n",
        )
        .unwrap();
        assert_eq!(r.width, 32);
        assert_eq!(r.height, 256);
        assert!((r.t0_s.unwrap() - 1.5 / crate::units::C_M_PER_S).abs() < 1e-20);
        assert_eq!(r.dt_s, Some(2e-11));
        assert_eq!(r.channel, Channel::Red);
        assert_eq!(r.format, CubeFormat::Zarr);
        assert_eq!(r.look_at_m, Some([0.0, 1.0, 0.0]));
        let text = toml::to_string(&r).unwrap();
        let back: RenderRequest = toml::from_str(&text).unwrap();
        assert_eq!(back, r);
        let e = toml::from_str::<RenderRequest>("scene = \"x\"\nwidht = 3\n").unwrap_err();
        assert!(e.to_string().contains("widht"), "{e}");
        let e = toml::from_str::<RenderRequest>("dt = \"5 furlongs\"\n").unwrap_err();
        assert!(e.to_string().contains("unknown unit"), "{e}");
        // A band at a wavelength: written as its name, read back; a bad one refused.
        let r: RenderRequest = toml::from_str("channel = \"550nm\"\n").unwrap();
        assert_eq!(r.channel.name(), "550nm");
        assert!(matches!(r.channel, Channel::Wavelength(w) if w.nm() == 550.0));
        let back: RenderRequest = toml::from_str(&toml::to_string(&r).unwrap()).unwrap();
        assert_eq!(back.channel, r.channel);
        let e = toml::from_str::<RenderRequest>("channel = \"1500nm\"\n").unwrap_err();
        assert!(e.to_string().contains("unknown channel '1500nm'"), "{e}");
    }

    /// A time written for a field reads back bit for bit: in metres where they do.
    #[test]
    fn time_field_text_reads_back_exactly() {
        use crate::units::C_M_PER_S;
        assert_eq!(time_field_text(1.5 / C_M_PER_S), "1.5m");
        for s in [
            1.75 / C_M_PER_S,
            0.01 / C_M_PER_S,
            3.3e-9,
            -2e-12,
            0.0,
            1e-30,
        ] {
            let text = time_field_text(s);
            let back = parse_time_field("t0", &text).unwrap().unwrap();
            assert_eq!(back.to_bits(), s.to_bits(), "{s} as {text}");
        }
    }

    #[test]
    fn times_in_messages_are_short() {
        assert_eq!(time_text(-1e-9), "-1 ns");
        assert_eq!(time_text(0.0), "0 s");
        assert_eq!(time_text(2.5e-12), "2.5 ps");
    }
}

//! What the window remembers between runs ([`ViewerSettings`], eframe storage), its
//! sanitizing, and the render job the settings describe.

use super::camera::CameraPose;
use super::colormap::{ColorMap, ExposureMode};
use serde::{Deserialize, Serialize};
use tprf_core::export::phasor::PhasorBand;
use tprf_core::request::{RenderRequest, parse_time_field};
use tprf_core::scene::{Channel, PulseOrigin, TimeOrigin};
use tprf_core::sensor::Sensor;

/// Everything the viewer remembers between runs (eframe storage).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ViewerSettings {
    pub scene: String,
    pub width: usize,
    pub height: usize,
    pub bins: usize,
    /// Window start and bin width with units ("" = automatic).
    pub t0: String,
    pub dt: String,
    /// Where arrival times start (the request's `time_origin`) and when the pulse
    /// starts (its `pulse_origin`).
    pub time_origin: TimeOrigin,
    pub pulse_origin: PulseOrigin,
    /// Samples per pixel to stop at (0 = keep going).
    pub spp_target: u64,
    /// Relative error estimate (%) to stop at (0 = keep going).
    pub error_target_pct: f64,
    pub max_bounces: u32,
    /// Fewest scattering events of a recorded path (the request's `min_bounces`).
    pub min_bounces: u32,
    pub channel: Channel,
    pub seed: u64,
    /// Every pixel draws every pass's samples (the same noise everywhere); off: adaptive
    /// sampling, samples where the noise is (`RenderSettings::adaptive`).
    pub uniform_sampling: bool,
    /// A constant sky (W m^-2 sr^-1) in the scene's ambient light group, replacing the
    /// scene's own; `None`: the scene's (the worker renders its ambient image, which
    /// the sensor tab adds to every gate and the SPAD).
    pub sky_radiance_w_m2_sr: Option<f64>,
    /// Playback speed, bins per second.
    pub play_bins_per_s: f32,
    pub looping: bool,
    pub exposure: ExposureMode,
    /// Exposure offset in stops.
    pub ev: f32,
    pub log_image: bool,
    pub colormap: ColorMap,
    /// Saved images carry a legend: their colour bar with its scale and unit, and a
    /// line saying what they show (a slice's time).
    pub png_legend: bool,
    pub plot_log: bool,
    /// Per-bounce curves shown, by bounce layer (0: the light seen directly, off by
    /// default; the others on); a layer past the end takes its default.
    pub bounces_shown: Vec<bool>,
    /// What the steady block shows: the steady image, or the scene's ambient image
    /// (W m^-2 sr^-1) when it has one, or the samples each pixel drew.
    pub steady_block: SteadyBlock,
    /// What the window shows: light in flight, or the sensor's measurements.
    pub mode: Mode,
    /// The sensor being edited (Light, gates, noise).
    pub sensor: Sensor,
    /// The camera the window moved to (the request's camera override); `None`: the
    /// scene's own camera.
    pub camera: Option<CameraPose>,
    /// The scene-wide medium the window set (the request's `medium` spec: the fog
    /// control's `visibility=...`); `None`: the scene's own.
    pub medium: Option<String>,
    /// The band whose frequencies the phasor tab shows when it computes them from the
    /// film (mitransient's `wl_mean:wl_sigma`; a `phasor_hdr_film` file sets it);
    /// `None`: mitransient's defaults. A view setting: the film does not depend on it.
    pub phasor: Option<PhasorBand>,
    /// The frequency the phasor tab shows, an index into the band's frequencies.
    pub phasor_index: usize,
    /// What the current scene's file set, with the user's own values it replaced
    /// (`None`: the scene's file set nothing): a file's film belongs to its scene.
    pub scene_file: Option<SceneFileFields>,
}

/// The render settings a scene file may set ([`tprf_core::scene::FileSettings`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileFields {
    pub width: usize,
    pub height: usize,
    pub bins: usize,
    pub max_bounces: u32,
    pub min_bounces: u32,
    pub time_origin: TimeOrigin,
    pub pulse_origin: PulseOrigin,
}

/// The fields a scene's file set (`file`) and the user's own values before it (`own`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneFileFields {
    pub own: FileFields,
    pub file: FileFields,
}

impl FileFields {
    pub fn of(s: &ViewerSettings) -> FileFields {
        FileFields {
            width: s.width,
            height: s.height,
            bins: s.bins,
            max_bounces: s.max_bounces,
            min_bounces: s.min_bounces,
            time_origin: s.time_origin,
            pulse_origin: s.pulse_origin,
        }
    }

    pub fn put(self, s: &mut ViewerSettings) {
        s.width = self.width;
        s.height = self.height;
        s.bins = self.bins;
        s.max_bounces = self.max_bounces;
        s.min_bounces = self.min_bounces;
        s.time_origin = self.time_origin;
        s.pulse_origin = self.pulse_origin;
    }

    /// These values with each one a scene's file set, and the user has not changed
    /// since, back to the user's own (`set.own`); the names of those put back.
    pub fn leaving(self, set: &SceneFileFields) -> (FileFields, Vec<&'static str>) {
        let mut out = self;
        let mut back = Vec::new();
        macro_rules! field {
            ($f:ident, $name:literal) => {
                if self.$f == set.file.$f && set.own.$f != set.file.$f {
                    out.$f = set.own.$f;
                    back.push($name);
                }
            };
        }
        field!(width, "width");
        field!(height, "height");
        field!(bins, "bins");
        field!(max_bounces, "max bounces");
        field!(min_bounces, "min bounces");
        field!(time_origin, "time origin");
        field!(pulse_origin, "pulse origin");
        (out, back)
    }
}

/// What the steady block of the transient view shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum SteadyBlock {
    /// The steady image: the sum over time of each pixel's TPRF.
    #[default]
    Steady,
    /// The scene's ambient image (sun, sky, lamps tagged ambient), when it has one.
    Ambient,
    /// The samples each pixel drew, against the image's mean (adaptive sampling).
    Samples,
}

/// The window's two views of the film.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mode {
    /// Time slices, steady and rainbow images, TPRF plots.
    Transient,
    /// Light(t), Exposure_i(t) and the measurements M_i (the paper's section 6).
    Sensor,
    /// A frequency's amplitude and phase images (mitransient's phasor film).
    Phasor,
}

impl Default for ViewerSettings {
    fn default() -> Self {
        ViewerSettings {
            scene: "builtin:cornell".into(),
            width: 128,
            height: 128,
            bins: 256,
            t0: String::new(),
            dt: String::new(),
            time_origin: TimeOrigin::Pinhole,
            pulse_origin: PulseOrigin::Light,
            spp_target: 0,
            error_target_pct: 0.0,
            max_bounces: 1024,
            min_bounces: 0,
            channel: Channel::Gray,
            seed: 0,
            uniform_sampling: false,
            sky_radiance_w_m2_sr: None,
            play_bins_per_s: 30.0,
            looping: true,
            exposure: ExposureMode::PerFrame,
            ev: 0.0,
            log_image: false,
            png_legend: true,
            colormap: ColorMap::Inferno,
            plot_log: false,
            bounces_shown: Vec::new(),
            steady_block: SteadyBlock::Steady,
            mode: Mode::Transient,
            sensor: Sensor::builtin("lidar").expect("the built-in LiDAR preset parses"),
            camera: None,
            medium: None,
            phasor: None,
            phasor_index: 0,
            scene_file: None,
        }
    }
}

/// Largest image side the viewer accepts.
pub(super) const MAX_SIDE: usize = 4096;
/// Largest bin count the viewer accepts.
pub(super) const MAX_BINS: usize = 16384;

impl ViewerSettings {
    /// Clamp values a stored file or a widget could have made absurd.
    pub(super) fn sanitized(mut self) -> Self {
        self.width = self.width.clamp(1, MAX_SIDE);
        self.height = self.height.clamp(1, MAX_SIDE);
        self.bins = self.bins.clamp(1, MAX_BINS);
        self.max_bounces = self.max_bounces.clamp(1, 100_000);
        self.min_bounces = self.min_bounces.min(self.max_bounces);
        if !(self.play_bins_per_s.is_finite() && self.play_bins_per_s > 0.0) {
            self.play_bins_per_s = 30.0;
        }
        // The request's own check of the sky (finite, >= 0, within f32).
        let sky = RenderRequest {
            sky_radiance_w_m2_sr: self.sky_radiance_w_m2_sr,
            ..RenderRequest::new("sky")
        };
        if self.sky_radiance_w_m2_sr.is_some() && sky.validate().is_err() {
            self.sky_radiance_w_m2_sr = None;
        }
        // A stored pose the request would refuse: the scene's camera instead.
        if self.camera.is_some_and(|c| c.problem().is_some()) {
            self.camera = None;
        }
        // A stored medium the request would refuse: the scene's own instead.
        let medium = RenderRequest {
            medium: self.medium.clone(),
            ..RenderRequest::new("medium")
        };
        if medium.medium_override().is_err() {
            self.medium = None;
        }
        if self.phasor.is_some_and(|b| b.check().is_err()) {
            self.phasor = None;
        }
        // No film has more bounce layers than bounces, nor the window more than this.
        self.bounces_shown.truncate(1024);
        if !self.ev.is_finite() {
            self.ev = 0.0;
        }
        if !(self.error_target_pct.is_finite() && self.error_target_pct > 0.0) {
            self.error_target_pct = 0.0;
        }
        self
    }

    /// Whether the curve of bounce layer `l` is shown (see [`Self::bounces_shown`]).
    pub fn bounce_shown(&self, l: usize) -> bool {
        self.bounces_shown.get(l).copied().unwrap_or(l > 0)
    }

    /// Show or hide the curve of bounce layer `l`.
    pub fn set_bounce_shown(&mut self, l: usize, on: bool) {
        while self.bounces_shown.len() <= l {
            let k = self.bounces_shown.len();
            self.bounces_shown.push(k > 0);
        }
        self.bounces_shown[l] = on;
    }

    /// These settings with the render ones (scene, size, window, spp, bounces, band,
    /// seed, sampling, sky, camera, medium) taken from `other`: what "Apply & restart" applies. Display
    /// and sensor settings take effect at once and are not part of it.
    pub(super) fn with_render_of(&self, other: &ViewerSettings) -> ViewerSettings {
        ViewerSettings {
            scene: other.scene.clone(),
            width: other.width,
            height: other.height,
            bins: other.bins,
            t0: other.t0.clone(),
            dt: other.dt.clone(),
            time_origin: other.time_origin,
            pulse_origin: other.pulse_origin,
            spp_target: other.spp_target,
            error_target_pct: other.error_target_pct,
            max_bounces: other.max_bounces,
            min_bounces: other.min_bounces,
            channel: other.channel,
            seed: other.seed,
            uniform_sampling: other.uniform_sampling,
            sky_radiance_w_m2_sr: other.sky_radiance_w_m2_sr,
            camera: other.camera,
            medium: other.medium.clone(),
            scene_file: other.scene_file,
            ..self.clone()
        }
    }

    /// The render these settings describe (checked: [`RenderRequest::validate`]), or
    /// what is wrong with them (the request's message, naming its field by the render
    /// settings' label: `Bin width: bin width -1 ns must be finite and > 0`).
    pub(super) fn job(&self) -> Result<RenderRequest, String> {
        let named = |e: tprf_core::request::RequestError| match e {
            tprf_core::request::RequestError::Invalid(p) => p.text_with(field_label),
            e => e.to_string(),
        };
        let request = RenderRequest {
            scene: self.scene.clone(),
            width: self.width,
            height: self.height,
            bins: self.bins,
            t0_s: parse_time_field("t0", &self.t0).map_err(named)?,
            dt_s: parse_time_field("dt", &self.dt).map_err(named)?,
            time_origin: self.time_origin,
            pulse_origin: self.pulse_origin,
            bounces_separate: 3,
            max_bounces: self.max_bounces,
            min_bounces: self.min_bounces,
            seed: self.seed,
            channel: self.channel,
            uniform: self.uniform_sampling,
            spp: (self.spp_target > 0).then_some(self.spp_target),
            error_target: (self.error_target_pct > 0.0).then(|| self.error_target_pct / 100.0),
            until_stopped: true,
            sky_radiance_w_m2_sr: self.sky_radiance_w_m2_sr,
            medium: self.medium.clone(),
            ..RenderRequest::default()
        };
        let request = match &self.camera {
            Some(pose) => pose.into_request(request),
            None => request,
        };
        request.validate().map_err(named)?;
        Ok(request)
    }
}

/// The render settings' label of a request field (the field's own name where the panel
/// has none).
fn field_label(field: &str) -> String {
    match field {
        "width" => "Width",
        "height" => "Height",
        "bins" => "Bins",
        "t0" => "Window start",
        "dt" => "Bin width",
        "time_origin" => "Time origin",
        "pulse_origin" => "Pulse origin",
        "spp" => "Stop at spp",
        "error_target" => "Stop at error",
        "max_bounces" => "Max bounces",
        "min_bounces" => "Min bounces",
        "seed" => "Seed",
        "sky" => "Sky",
        "medium" => "Fog",
        other => other,
    }
    .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bad value is named by its label in the panel, not the command line's name.
    #[test]
    fn errors_name_the_panels_labels() {
        let s = ViewerSettings {
            dt: "-1 ns".into(),
            ..ViewerSettings::default()
        };
        let e = s.job().unwrap_err();
        assert!(e.starts_with("Bin width"), "{e}");
        let s = ViewerSettings {
            min_bounces: 9,
            max_bounces: 3,
            ..ViewerSettings::default()
        };
        let e = s.job().unwrap_err();
        assert!(
            e.starts_with("Min bounces") && e.contains("max_bounces"),
            "{e}"
        );
    }

    /// The window's sky goes through the request's one check: f64::MAX (beyond f32,
    /// which the renderer holds radiance in) and a negative sky are dropped by the
    /// sanitizing and refused as a job, naming the field; a finite one renders.
    #[test]
    fn the_sky_is_checked_as_the_request_checks_it() {
        for bad in [f64::MAX, -1.0, f64::NAN] {
            let s = ViewerSettings {
                sky_radiance_w_m2_sr: Some(bad),
                ..ViewerSettings::default()
            };
            let e = s.job().expect_err("an impossible sky was accepted");
            assert!(e.starts_with("Sky: sky radiance"), "{e}");
            assert_eq!(s.sanitized().sky_radiance_w_m2_sr, None);
        }
        let s = ViewerSettings {
            sky_radiance_w_m2_sr: Some(2.5),
            ..ViewerSettings::default()
        };
        assert_eq!(s.job().unwrap().sky_radiance_w_m2_sr, Some(2.5));
        assert_eq!(s.sanitized().sky_radiance_w_m2_sr, Some(2.5));
        let e = ViewerSettings {
            dt: "-1ns".into(),
            ..ViewerSettings::default()
        }
        .job()
        .unwrap_err();
        assert_eq!(e, "Bin width: bin width -1 ns must be finite and > 0");
    }
}

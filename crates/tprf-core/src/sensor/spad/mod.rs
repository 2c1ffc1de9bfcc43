//! A single-photon avalanche diode (SPAD) behind a time-to-digital converter (TDC): the
//! direct time-of-flight detector of LiDAR, modelled on the TPRF sensor's measurement.
//!
//! The TDC's bins are an [`Exposure::Tdc`]: `B` bins of width `w` spanning one laser
//! cycle `T = B w`, each seen through the Gaussian timing jitter. Its kernels turn a
//! pixel's TPRF into `S_k`, the pixel's `(TPRF * Light)` in TDC bin `k` after the jitter,
//! folded into the cycle (in the unit of a cube bin). From there, per pixel and cycle,
//! the mean number of *detectable* events in bin `k` is
//!
//! ```text
//! r_k = PDE (photons_per_unit S_k + (ambient_rate_hz + ambient_lamp_hz photons_per_unit
//!       steady + ambient_scale photons_per_unit A) w) + dark_count_rate_hz w
//! ```
//!
//! (`steady` the pixel's steady image, the sum of its TPRF, times the light's energy:
//! see [`Spad`]; `A` the
//! pixel's ambient image, W m^-2 sr^-1, when the cube has one: see
//! [`crate::sensor::ambient`]). Photons in
//! different bins and cycles are independent Poisson counts. The detector
//! ([`detector`]) fires on the first event of a bin while it is armed, is then dead for
//! the rest of that bin and `dead_time_s` more (`d + f` bins: through `d` whole bins
//! and the first fraction `f` of the next, exactly; no rounding), and may afterpulse. Its expected histogram over `N` cycles is computed exactly for this
//! model ([`detector::Detector::expected`]); one seeded realisation is drawn from it
//! ([`sample`]); the Coates estimate undoes the pile-up ([`coates`](fn@coates)); and
//! [`image`] does it for every pixel with first-return depths.
//!
//! Units: rates in hertz (events per second), times in seconds, counts are events
//! over all `N` cycles.

pub mod coates;
pub mod detector;
pub mod image;
pub mod sample;

pub use coates::{coates, return_depth_m};
pub use detector::{Detector, Sampler};
pub use image::{
    SpadImage, SpadPixel, spad_bytes_per_pixel, spad_expected, spad_expected_until, spad_image,
    spad_image_ambient, spad_pixel, spad_pixel_ambient, spad_rows, spad_sample, spad_sampler,
};

use serde::{Deserialize, Serialize};

use super::exposure::Exposure;
use super::values::{count, hertz, seconds};
use super::{SensorError, finite, non_negative};

/// Most laser cycles one histogram may sum (`10^12`, e.g. a 1 MHz laser for 11 days).
pub const MAX_CYCLES: u64 = 1_000_000_000_000;

/// How the SPAD is armed over the laser cycles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Acquisition {
    /// Armed afresh (no trap filled) at the start of every cycle, as a gated SPAD:
    /// cycles are independent. With a dead time of a whole cycle, at most one photon a
    /// cycle is recorded: the classic first-photon (TCSPC) histogram.
    #[default]
    Synchronous,
    /// Never reset: after a detection the SPAD re-arms when its dead time is over,
    /// whichever cycle that falls in, from a cold start (armed) at the first cycle.
    FreeRunning,
}

fn one() -> f64 {
    1.0
}

/// The SPAD and its light budget, as the `[spad]` section of a sensor file. It needs a
/// `tdc` exposure (its histogram bins and jitter).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spad {
    /// Laser cycles summed into the histogram, `N` (1 ..= 10^12).
    #[serde(with = "count")]
    pub cycles: u64,
    /// Photon detection efficiency, 0 ..= 1: the chance that a photon reaching the
    /// pixel makes an avalanche.
    #[serde(default = "one")]
    pub pde: f64,
    /// Photons reaching the pixel per unit of radiance x seconds (W m^-2 sr^-1 s, the
    /// unit of `(TPRF * Light)` for a light of its energy in joules): the pixel's
    /// etendue (aperture area x solid angle, m^2 sr) over the photon energy `h c /
    /// lambda` (J). With the light's energy the pulse's own, the pulse and the scene's
    /// ambient light (`ambient_scale = 1`) are then both at their stated power.
    pub photons_per_unit: f64,
    /// A uniform ambient background, photons per second reaching each pixel (sun on a
    /// grey scene, say).
    #[serde(default, alias = "ambient_rate", with = "hertz")]
    pub ambient_rate_hz: f64,
    /// A steady lamp where the pulsed light is, of power `ambient_lamp_hz` times the
    /// pulse's energy (per second). It lights each pixel as the pulse does, integrated
    /// over time: `ambient_lamp_hz x energy x photons_per_unit x steady` photons per
    /// second, `steady` the pixel's steady image (the sum of its TPRF, per joule).
    #[serde(default, alias = "ambient_lamp", with = "hertz")]
    pub ambient_lamp_hz: f64,
    /// Dark counts per second (thermal avalanches; the PDE does not apply).
    #[serde(default, alias = "dark_count_rate", with = "hertz")]
    pub dark_count_rate_hz: f64,
    /// Dead time after each detection, seconds, at most one laser cycle, counted from
    /// the end of the TDC bin of the detection (a real SPAD counts it from the photon:
    /// how far apart the two are, and when `tau - w / 2` is the better setting, is in
    /// [`detector`]); any fraction of a bin is honoured.
    #[serde(default, alias = "dead_time", with = "seconds")]
    pub dead_time_s: f64,
    #[serde(default)]
    pub mode: Acquisition,
    /// Chance that a detection fills a carrier trap, 0 ..= 1. The trap empties after
    /// an exponential delay of mean `afterpulse_delay_s` counted from the detection:
    /// during the dead time the release is lost, once armed it is a detection (an
    /// afterpulse). 0: no afterpulsing.
    #[serde(default)]
    pub afterpulse_probability: f64,
    /// Mean delay of a trapped carrier's release, seconds (> 0 when afterpulsing).
    #[serde(default, alias = "afterpulse_delay", with = "seconds")]
    pub afterpulse_delay_s: f64,
}

impl Default for Spad {
    fn default() -> Self {
        Spad {
            cycles: 1000,
            pde: 0.3,
            photons_per_unit: 1.0,
            ambient_rate_hz: 0.0,
            ambient_lamp_hz: 0.0,
            dark_count_rate_hz: 0.0,
            dead_time_s: 0.0,
            mode: Acquisition::Synchronous,
            afterpulse_probability: 0.0,
            afterpulse_delay_s: 0.0,
        }
    }
}

/// `value` if finite and in `[0, 1]`.
fn probability(what: &str, value: f64) -> Result<f64, SensorError> {
    non_negative(what, value)?;
    if value <= 1.0 {
        Ok(value)
    } else {
        Err(SensorError::OutOfRange {
            what: what.into(),
            value,
            rule: "in [0, 1] (a probability)",
        })
    }
}

impl Spad {
    /// Checks every value against the sensor's `exposure`, which must be a TDC: the
    /// error names the field (`spad.pde`, `spad.dead_time_s`, ...).
    pub fn validate(&self, exposure: &Exposure) -> Result<(), SensorError> {
        let Some((cycle_s, _)) = exposure.tdc_cycle_s() else {
            return Err(SensorError::Invalid(format!(
                "spad needs [exposure] kind = \"tdc\" (its histogram bins), not \"{}\"",
                exposure.kind_name()
            )));
        };
        if self.cycles == 0 || self.cycles > MAX_CYCLES {
            return Err(SensorError::OutOfRange {
                what: "spad.cycles".into(),
                value: self.cycles as f64,
                rule: "in 1 ..= 1e12",
            });
        }
        probability("spad.pde", self.pde)?;
        non_negative("spad.photons_per_unit", self.photons_per_unit)?;
        non_negative("spad.ambient_rate_hz", self.ambient_rate_hz)?;
        non_negative("spad.ambient_lamp_hz", self.ambient_lamp_hz)?;
        non_negative("spad.dark_count_rate_hz", self.dark_count_rate_hz)?;
        crate::sensor::duration_s("spad.dead_time_s", self.dead_time_s, false)?;
        finite(
            "laser cycle (exposure.bins x exposure.bin_width_s)",
            cycle_s,
        )?;
        if self.dead_time_s > cycle_s * (1.0 + 1e-12) {
            return Err(SensorError::Invalid(format!(
                "spad.dead_time_s = {:e} s is longer than the laser cycle (exposure.bins x \
                 exposure.bin_width_s = {cycle_s:e} s); at most one cycle",
                self.dead_time_s
            )));
        }
        probability("spad.afterpulse_probability", self.afterpulse_probability)?;
        crate::sensor::duration_s("spad.afterpulse_delay_s", self.afterpulse_delay_s, false)?;
        if self.afterpulse_probability > 0.0 && !(self.afterpulse_delay_s > 0.0) {
            return Err(SensorError::OutOfRange {
                what: "spad.afterpulse_delay_s".into(),
                value: self.afterpulse_delay_s,
                rule: "> 0 when spad.afterpulse_probability > 0",
            });
        }
        Ok(())
    }

    /// The mean detectable events per cycle in each TDC bin of width `bin_width_s`
    /// (into `out`) for a pixel whose folded `(TPRF * Light)` per bin is `signal` and
    /// whose steady image times the light's energy is `steady` (both radiance x s),
    /// under an ambient radiance `ambient` (W m^-2 sr^-1: the cube's ambient image
    /// times `ambient_scale`; 0 without one):
    /// `r_k = PDE (photons_per_unit S_k + ambient photons/s x w) + DCR w`, the ambient
    /// photons/s being `ambient_rate_hz + photons_per_unit (ambient_lamp_hz steady +
    /// ambient)`: a radiance times `photons_per_unit` (photons per radiance x second)
    /// is photons per second. Negative or NaN inputs count as 0.
    pub fn rates(
        &self,
        signal: &[f32],
        steady: f64,
        ambient: f64,
        bin_width_s: f64,
        out: &mut Vec<f64>,
    ) {
        let steady = if steady > 0.0 { steady } else { 0.0 };
        let ambient = if ambient > 0.0 { ambient } else { 0.0 };
        let ambient_hz = self.ambient_rate_hz
            + self.photons_per_unit * (self.ambient_lamp_hz * steady + ambient);
        let floor = self.pde * ambient_hz * bin_width_s + self.dark_count_rate_hz * bin_width_s;
        out.clear();
        out.extend(signal.iter().map(|&s| {
            let s = f64::from(s);
            let s = if s > 0.0 { s } else { 0.0 };
            self.pde * self.photons_per_unit * s + floor
        }));
    }
}

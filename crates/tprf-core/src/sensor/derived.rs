//! Outputs derived from the measurements, where a preset asks for them:
//!
//! - **first-return depth** (full-waveform LiDAR): per pixel, the first return of the
//!   gate waveform `M_i` against the gate centres, located by its centroid, minus the
//!   light's mean emission time; depth `c (t - t_light) / 2`;
//! - **AMCW phase and depth**: per pixel, `theta = atan2(sum M_i sin phi_i,
//!   sum M_i cos phi_i) - theta_0` (`theta_0` the phase the sensor reports for a return
//!   at `tau = 0`, so a light's own delay cancels), depth `c theta / (4 pi f)`, unique
//!   up to the ambiguity range `c / (2 f)`.
//!
//! "Depth" is half the optical path of the return, `c tau / 2`: the distance to the
//! surface along the pixel's ray when the light sits beside the camera (LiDAR and ToF
//! cameras), half the light -> surface -> eye path otherwise. `c` is
//! [`crate::units::C_M_PER_S`].

use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

use super::exposure::{Exposure, Gate};
use super::measure::Measurements;
use super::{SensorError, non_negative};
use crate::film::FilmSnapshot;
use crate::film::TimeAxis;
use crate::units::C_M_PER_S;

/// The derived outputs a sensor asks for; none by default.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Derived {
    /// Depth from the first return of each pixel's gate waveform.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub first_return: Option<FirstReturn>,
    /// AMCW phase, amplitude and depth per pixel (needs an `amcw` exposure).
    pub amcw_depth: bool,
}

/// How the first return of a waveform is found.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FirstReturn {
    /// A return starts where the waveform first reaches this fraction of the pixel's
    /// highest sample (0 < threshold <= 1; default 0.2).
    pub threshold: f64,
    /// Pixels whose highest sample is not above this (measurement units) have no
    /// return (default 0).
    pub min_signal: f64,
}

impl Default for FirstReturn {
    fn default() -> Self {
        FirstReturn {
            threshold: 0.2,
            min_signal: 0.0,
        }
    }
}

impl Derived {
    /// Checks the parameters and that the gates allow what is asked: first return
    /// needs at least two gates with increasing centres; AMCW depth an `amcw` exposure
    /// with at least three phase steps.
    pub fn validate(&self, exposure: &Exposure, gates: &[Gate]) -> Result<(), SensorError> {
        if let Some(fr) = &self.first_return {
            non_negative("derived.first_return.threshold", fr.threshold)?;
            if !(fr.threshold > 0.0 && fr.threshold <= 1.0) {
                return Err(SensorError::OutOfRange {
                    what: "derived.first_return.threshold".into(),
                    value: fr.threshold,
                    rule: "in (0, 1]",
                });
            }
            non_negative("derived.first_return.min_signal", fr.min_signal)?;
            let centres: Option<Vec<f64>> = gates.iter().map(Gate::centre_s).collect();
            match centres {
                Some(c) if c.len() >= 2 && c.windows(2).all(|w| w[1] > w[0]) => {}
                _ => {
                    return Err(SensorError::Invalid(
                        "derived.first_return needs at least two gates with increasing \
                         centres (a waveform)"
                            .into(),
                    ));
                }
            }
        }
        if self.amcw_depth {
            match exposure {
                Exposure::Amcw { phase_steps, .. } if *phase_steps >= 3 => {}
                _ => {
                    return Err(SensorError::Invalid(
                        "derived.amcw_depth needs an amcw exposure with at least 3 \
                         phase_steps"
                            .into(),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Depth (m) of a round-trip time (s): `c t / 2`.
pub fn depth_m(round_trip_s: f64) -> f64 {
    0.5 * C_M_PER_S * round_trip_s
}

/// The time of the first return of a waveform `values[i]` sampled at increasing
/// `times_s[i]`: from the first sample at or above `threshold x` the highest one,
/// up over its peak and down while it keeps falling and stays above the threshold;
/// the return's time is the centroid of those samples. `None` when the highest sample
/// is not above `min_signal` (or not positive).
pub fn first_return_time(values: &[f64], times_s: &[f64], p: &FirstReturn) -> Option<f64> {
    let n = values.len().min(times_s.len());
    let values = &values[..n];
    let peak = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !(peak > p.min_signal && peak > 0.0) {
        return None;
    }
    let threshold = p.threshold * peak;
    let start = values.iter().position(|&v| v >= threshold)?;
    let mut end = start;
    while end + 1 < n && values[end + 1] >= values[end] {
        end += 1;
    }
    while end + 1 < n && values[end + 1] <= values[end] && values[end + 1] >= threshold {
        end += 1;
    }
    let (mut sum, mut moment) = (0.0, 0.0);
    for (v, t) in values[start..=end].iter().zip(&times_s[start..=end]) {
        sum += v;
        moment += v * t;
    }
    (sum > 0.0).then(|| moment / sum)
}

/// First-return depth per pixel, `[H, W]` metres (NaN: no return), from gate
/// waveforms: `c (t_return - light_mean_s) / 2` with `t_return` from
/// [`first_return_time`] over the gate centres.
pub fn first_return_depth(
    m: &Measurements,
    gate_centres_s: &[f64],
    light_mean_s: f64,
    p: &FirstReturn,
) -> Vec<f32> {
    let pixels = m.width * m.height;
    let mut waveform = vec![0.0; m.gates];
    (0..pixels)
        .map(|px| {
            for (i, w) in waveform.iter_mut().enumerate() {
                *w = f64::from(m.values[i * pixels + px]);
            }
            first_return_time(&waveform, gate_centres_s, p)
                .map_or(f32::NAN, |t| depth_m(t - light_mean_s) as f32)
        })
        .collect()
}

/// The first return of every pixel's TPRF itself (bins as samples at their centres):
/// depth `[H, W]` metres, NaN for empty pixels. A reference for noise-free depth.
pub fn tprf_first_return_depth(
    cube: &[f32],
    width: usize,
    height: usize,
    axis: &TimeAxis,
    p: &FirstReturn,
) -> Vec<f32> {
    let times: Vec<f64> = (0..axis.bins).map(|b| axis.bin_center_s(b)).collect();
    let mut waveform = vec![0.0; axis.bins];
    cube.chunks_exact(axis.bins)
        .take(width * height)
        .map(|px| {
            for (w, &v) in waveform.iter_mut().zip(px) {
                *w = f64::from(v);
            }
            first_return_time(&waveform, &times, p).map_or(f32::NAN, |t| depth_m(t) as f32)
        })
        .collect()
}

/// [`tprf_first_return_depth`] of a film snapshot, a row at a time.
pub fn tprf_first_return_depth_film(snap: &FilmSnapshot, p: &FirstReturn) -> Vec<f32> {
    let mut row = Vec::new();
    let mut out = Vec::with_capacity(snap.width() * snap.height());
    for y in 0..snap.height() {
        snap.row_dense(y, None, &mut row);
        out.extend(tprf_first_return_depth(
            &row,
            snap.width(),
            1,
            snap.axis(),
            p,
        ));
    }
    out
}

/// Depth of the centroid in time of every pixel's TPRF, `[H, W]` metres (NaN for
/// empty pixels): the exact mean depth of a single-scattering layer.
pub fn tprf_centroid_depth(cube: &[f32], width: usize, height: usize, axis: &TimeAxis) -> Vec<f32> {
    cube.chunks_exact(axis.bins)
        .take(width * height)
        .map(|px| {
            let (mut sum, mut moment) = (0.0, 0.0);
            for (b, &v) in px.iter().enumerate() {
                sum += f64::from(v);
                moment += f64::from(v) * axis.bin_center_s(b);
            }
            if sum > 0.0 {
                depth_m(moment / sum) as f32
            } else {
                f32::NAN
            }
        })
        .collect()
}

/// AMCW images `[H, W]`.
#[derive(Clone, Debug, PartialEq)]
pub struct AmcwImage {
    pub width: usize,
    pub height: usize,
    /// Phase of the return after removing the light's own, radians in `[0, 2 pi)`
    /// (NaN without signal).
    pub phase_rad: Vec<f32>,
    /// Amplitude of the fundamental, `(2/N) |sum M_i exp(i phi_i)|`.
    pub amplitude: Vec<f32>,
    /// Depth `c phase / (4 pi f)`, metres, in `[0, ambiguity_m)`.
    pub depth_m: Vec<f32>,
    /// The unambiguous range `c / (2 f)`, metres.
    pub ambiguity_m: f64,
}

/// AMCW phase, amplitude and depth from measurements of gates with phases
/// `phases_rad` at `freq_hz`; `phase_offset_rad` is the phase the sensor reports for
/// a return at `tau = 0` (see [`super::SensorModel::amcw_phase_offset_rad`]).
pub fn amcw_image(
    m: &Measurements,
    phases_rad: &[f64],
    freq_hz: f64,
    phase_offset_rad: f64,
) -> AmcwImage {
    let pixels = m.width * m.height;
    let n = phases_rad.len().min(m.gates);
    let (mut phase, mut amplitude, mut depth) = (
        Vec::with_capacity(pixels),
        Vec::with_capacity(pixels),
        Vec::with_capacity(pixels),
    );
    for px in 0..pixels {
        let (mut c, mut s) = (0.0, 0.0);
        for (i, phi) in phases_rad.iter().enumerate().take(n) {
            let v = f64::from(m.values[i * pixels + px]);
            c += v * phi.cos();
            s += v * phi.sin();
        }
        let amp = 2.0 / n as f64 * c.hypot(s);
        if amp > 0.0 {
            let theta = (s.atan2(c) - phase_offset_rad).rem_euclid(TAU);
            phase.push(theta as f32);
            depth.push((C_M_PER_S * theta / (4.0 * PI * freq_hz)) as f32);
        } else {
            phase.push(f32::NAN);
            depth.push(f32::NAN);
        }
        amplitude.push(amp as f32);
    }
    AmcwImage {
        width: m.width,
        height: m.height,
        phase_rad: phase,
        amplitude,
        depth_m: depth,
        ambiguity_m: C_M_PER_S / (2.0 * freq_hz),
    }
}

/// `a - b` wrapped into `[-period / 2, period / 2)`: the error of a depth known only
/// modulo `period`.
pub fn wrapped_difference(a: f64, b: f64, period: f64) -> f64 {
    (a - b + 0.5 * period).rem_euclid(period) - 0.5 * period
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_return_finds_the_first_peak() {
        let times: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let mut v = vec![0.0; 20];
        // A symmetric return centred at 5 and a larger one at 12.
        v[4] = 1.0;
        v[5] = 2.0;
        v[6] = 1.0;
        v[11] = 3.0;
        v[12] = 6.0;
        v[13] = 3.0;
        let p = FirstReturn {
            threshold: 0.1,
            min_signal: 0.0,
        };
        assert_eq!(first_return_time(&v, &times, &p), Some(5.0));
        // Above the first peak's height: the second return.
        let p = FirstReturn {
            threshold: 0.4,
            min_signal: 0.0,
        };
        assert_eq!(first_return_time(&v, &times, &p), Some(12.0));
        let p = FirstReturn {
            threshold: 0.1,
            min_signal: 10.0,
        };
        assert_eq!(first_return_time(&v, &times, &p), None);
        assert_eq!(
            first_return_time(&[0.0; 20], &times, &FirstReturn::default()),
            None
        );
    }

    #[test]
    fn wrapping() {
        assert!((wrapped_difference(0.1, 7.4, 7.5) - 0.2).abs() < 1e-12);
        assert!((wrapped_difference(7.4, 0.1, 7.5) + 0.2).abs() < 1e-12);
        assert_eq!(wrapped_difference(2.0, 1.0, 7.5), 1.0);
    }
}

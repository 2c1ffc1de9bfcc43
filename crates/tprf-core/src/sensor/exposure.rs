//! `Exposure_i(t)`, `i = 0..N-1`: the sensitivity of measurement `i` over time
//! (paper, section 6), dimensionless, `t` in seconds.
//!
//! [`Exposure`] describes a whole sequence (box gates, Gaussian gates, a free
//! piecewise-linear gate repeated at a step, AMCW sinusoids, the bins of a
//! time-to-digital converter with timing jitter); [`Exposure::gates`]
//! checks it and resolves it into single [`Gate`]s at absolute times. What the
//! kernels need from a gate is its average over a bin-wide window,
//! [`Gate::bin_average`], in closed form for every kind.

use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, SQRT_2, TAU};
use std::sync::Arc;

/// The lowest AMCW modulation frequency: 1 mHz (an unambiguous range of 1.5e11 m).
pub const MIN_AMCW_FREQ_HZ: f64 = 1e-3;

use super::values::{Point, count, hertz, option_seconds, seconds};
use super::{SensorError, finite, non_negative, positive};

/// Most gates one sensor may have (the measurement holds `N x H x W` floats).
pub const MAX_GATES: u64 = 4096;

/// Most knots of a piecewise-linear gate.
pub const MAX_GATE_POINTS: usize = 10_000;

/// Gaussian gates are cut at this many sigma (sensitivity below 1.3e-14 of the peak).
const GAUSS_CUT: f64 = 8.0;

/// Where the times of a gate sequence are counted from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeOrigin {
    /// The trigger: the instant the TPRF's unit pulse leaves the light (`t = 0`).
    #[default]
    Pulse,
    /// The start `t0` of the cube's time window, so a preset follows any scene.
    Window,
}

fn one() -> f64 {
    1.0
}

fn one_count() -> u64 {
    1
}

fn four() -> u64 {
    4
}

/// A sequence of exposure gates as written in a sensor file (checked by
/// [`Exposure::gates`]). Gate `i` of a stepped sequence is gate 0 shifted by
/// `i * step_s`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Exposure {
    /// Box gates: gate `i` has sensitivity `gain` (default 1) over
    /// `[start_s + i step_s, start_s + i step_s + width_s)`, 0 elsewhere. `step_s`
    /// defaults to `width_s` (gates side by side).
    Box {
        #[serde(default)]
        origin: TimeOrigin,
        #[serde(default, alias = "start", with = "seconds")]
        start_s: f64,
        #[serde(alias = "width", with = "seconds")]
        width_s: f64,
        #[serde(
            default,
            alias = "step",
            with = "option_seconds",
            skip_serializing_if = "Option::is_none"
        )]
        step_s: Option<f64>,
        #[serde(default = "one_count", with = "count")]
        count: u64,
        #[serde(default = "one")]
        gain: f64,
    },
    /// Gaussian gates: gate `i` is `peak * exp(-(t - c_i)^2 / (2 sigma^2))`,
    /// `c_i = centre_s + i step_s`, `sigma = fwhm_s / 2.3548`. `step_s` defaults to
    /// `fwhm_s`.
    Gaussian {
        #[serde(default)]
        origin: TimeOrigin,
        #[serde(default, alias = "centre", alias = "center", with = "seconds")]
        centre_s: f64,
        #[serde(alias = "fwhm", with = "seconds")]
        fwhm_s: f64,
        #[serde(
            default,
            alias = "step",
            with = "option_seconds",
            skip_serializing_if = "Option::is_none"
        )]
        step_s: Option<f64>,
        #[serde(default = "one_count", with = "count")]
        count: u64,
        #[serde(default = "one")]
        peak: f64,
    },
    /// A free gate through `[t_s, value]` knots (values >= 0, times non-decreasing, a
    /// repeated time is a jump), linear in between, 0 outside; gate `i` is it shifted
    /// by `i * step_s` (default 0).
    PiecewiseLinear {
        #[serde(default)]
        origin: TimeOrigin,
        points: Vec<Point>,
        #[serde(default, alias = "step", with = "seconds")]
        step_s: f64,
        #[serde(default = "one_count", with = "count")]
        count: u64,
    },
    /// An amplitude-modulated continuous-wave (AMCW) time-of-flight camera:
    /// `phase_steps` sinusoidal gates `(1 + modulation cos(2 pi freq_hz t - phi_i)) / 2`
    /// with `phi_i = phase0_deg + 360 i / phase_steps` degrees, in absolute time (the
    /// phase is counted from the trigger). With a delta light the correlation
    /// `K_i(tau)` is the same sinusoid in `tau`, as for a sinusoidally modulated source
    /// correlated over many periods.
    Amcw {
        #[serde(alias = "freq", alias = "frequency", with = "hertz")]
        freq_hz: f64,
        #[serde(default = "four", with = "count")]
        phase_steps: u64,
        #[serde(default, alias = "phase0")]
        phase0_deg: f64,
        #[serde(default = "one")]
        modulation: f64,
    },
    /// The histogram bins of a time-to-digital converter (TDC), as a SPAD sensor has
    /// (see [`super::spad`]): bin `k` counts the photons whose time *after the timing
    /// jitter* falls in `[start_s + k w, start_s + (k + 1) w)`, `w = bin_width_s`. The
    /// jitter (the instrument response) is Gaussian with `jitter_fwhm_s` (0: none), so
    /// the gate is the box convolved with it: `Phi((b - t) / sigma) - Phi((a - t) /
    /// sigma)`. The `bins` bins span one laser cycle, `T = bins w`; light arriving
    /// outside `[start_s, start_s + T)` folds into it modulo `T` (it belongs to an
    /// earlier or later pulse of the periodic laser) when the sensor model computes
    /// the kernels.
    Tdc {
        #[serde(default)]
        origin: TimeOrigin,
        #[serde(default, alias = "start", with = "seconds")]
        start_s: f64,
        #[serde(alias = "bin_width", with = "seconds")]
        bin_width_s: f64,
        #[serde(alias = "count", with = "count")]
        bins: u64,
        #[serde(default, alias = "jitter_fwhm", with = "seconds")]
        jitter_fwhm_s: f64,
    },
}

/// One resolved gate `Exposure_i(t)`, times in seconds after the trigger.
#[derive(Clone, Debug, PartialEq)]
pub enum Gate {
    /// `gain` on `[start_s, end_s)`.
    Box { start_s: f64, end_s: f64, gain: f64 },
    /// `peak * exp(-(t - centre_s)^2 / (2 sigma_s^2))`.
    Gaussian {
        centre_s: f64,
        sigma_s: f64,
        peak: f64,
    },
    /// A piecewise-linear shape shifted by `shift_s`.
    PiecewiseLinear { shape: Arc<PwlShape>, shift_s: f64 },
    /// `(1 + modulation cos(2 pi freq_hz t - phase_rad)) / 2`.
    Cosine {
        freq_hz: f64,
        phase_rad: f64,
        modulation: f64,
    },
    /// A box `[start_s, end_s)` of sensitivity 1 convolved with a Gaussian of standard
    /// deviation `sigma_s > 0`: `Phi((end - t) / sigma) - Phi((start - t) / sigma)`, the
    /// probability that a photon arriving at `t` is time-stamped in the box (a TDC bin
    /// seen through timing jitter).
    Jittered {
        start_s: f64,
        end_s: f64,
        sigma_s: f64,
    },
}

/// The knots of a piecewise-linear gate, with its running integral.
#[derive(Clone, Debug, PartialEq)]
pub struct PwlShape {
    t_s: Vec<f64>,
    v: Vec<f64>,
    /// `integral_{t_0}^{t_k} E`, seconds.
    cum: Vec<f64>,
    centroid_s: f64,
}

impl PwlShape {
    fn new(points: &[Point]) -> Result<PwlShape, SensorError> {
        if points.len() > MAX_GATE_POINTS {
            return Err(SensorError::TooMany {
                what: "exposure.points".into(),
                count: points.len() as u64,
                max: MAX_GATE_POINTS as u64,
            });
        }
        if points.len() < 2 {
            return Err(SensorError::Invalid(
                "exposure.points needs at least two [t_s, value] knots".into(),
            ));
        }
        let mut t_s: Vec<f64> = Vec::with_capacity(points.len());
        let mut v = Vec::with_capacity(points.len());
        for (k, p) in points.iter().enumerate() {
            let t = finite(&format!("exposure.points[{k}] time"), p.0)?;
            let value = non_negative(&format!("exposure.points[{k}] value"), p.1)?;
            if let Some(&prev) = t_s.last()
                && t < prev
            {
                return Err(SensorError::Invalid(format!(
                    "exposure.points[{k}]: time {t} s comes before the previous knot's \
                     {prev} s (times must not decrease)"
                )));
            }
            t_s.push(t);
            v.push(value);
        }
        let mut cum = vec![0.0; t_s.len()];
        let mut moment = 0.0;
        for k in 1..t_s.len() {
            let (t0, t1, v0, v1) = (t_s[k - 1], t_s[k], v[k - 1], v[k]);
            cum[k] = cum[k - 1] + 0.5 * (v0 + v1) * (t1 - t0);
            moment += (t1 - t0) * (v0 * (2.0 * t0 + t1) + v1 * (t0 + 2.0 * t1)) / 6.0;
        }
        let area = cum[cum.len() - 1];
        if !(area > 0.0 && area.is_finite()) {
            return Err(SensorError::Invalid(format!(
                "exposure.points encloses area {area}: a gate needs a positive, finite area"
            )));
        }
        Ok(PwlShape {
            centroid_s: moment / area,
            t_s,
            v,
            cum,
        })
    }

    fn value(&self, t: f64) -> f64 {
        let j = self.t_s.partition_point(|&k| k <= t);
        if j == 0 || j == self.t_s.len() {
            return 0.0;
        }
        let (t0, t1, v0, v1) = (self.t_s[j - 1], self.t_s[j], self.v[j - 1], self.v[j]);
        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    }

    /// `integral_{t_0}^{t} E`.
    fn primitive(&self, t: f64) -> f64 {
        let j = self.t_s.partition_point(|&k| k <= t);
        if j == 0 {
            return 0.0;
        }
        if j == self.t_s.len() {
            return self.cum[j - 1];
        }
        let (t0, t1, v0, v1) = (self.t_s[j - 1], self.t_s[j], self.v[j - 1], self.v[j]);
        let d = t - t0;
        self.cum[j - 1] + v0 * d + 0.5 * (v1 - v0) / (t1 - t0) * d * d
    }

    fn span_s(&self) -> (f64, f64) {
        (self.t_s[0], self.t_s[self.t_s.len() - 1])
    }
}

/// `Phi(x2) - Phi(x1)` for the standard normal CDF, `x1 <= x2`, without cancellation
/// in the tails.
fn normal_cdf_diff(x1: f64, x2: f64) -> f64 {
    let q = |x: f64| 0.5 * libm::erfc(x / SQRT_2);
    if x1 >= 0.0 {
        q(x1) - q(x2)
    } else if x2 <= 0.0 {
        q(-x2) - q(-x1)
    } else {
        1.0 - q(x2) - q(-x1)
    }
}

/// `integral_a^{a + w} Phi(x) dx` for `w >= 0`, from the primitive `F(x) = x Phi(x) +
/// phi(x)`; for positive arguments `F(x) = x + F(-x)`, which keeps the difference exact.
/// The width is given, not taken as a difference: far past an edge (`a ~ 1e14` for a
/// box open for a second seen through a femtosecond Gaussian) `(a + w) - a` would have
/// lost the digits of `w`.
fn normal_cdf_integral(a: f64, w: f64) -> f64 {
    let f = |x: f64| x * 0.5 * libm::erfc(-x / SQRT_2) + (-0.5 * x * x).exp() / (2.0 * PI).sqrt();
    let b = a + w;
    if a >= 0.0 {
        w + f(-b) - f(-a)
    } else if b <= 0.0 {
        f(b) - f(a)
    } else {
        b + f(-b) - f(a)
    }
}

/// `sin(x) / x`.
fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-8 { 1.0 } else { x.sin() / x }
}

impl Exposure {
    /// The `kind` name as in a file.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Exposure::Box { .. } => "box",
            Exposure::Gaussian { .. } => "gaussian",
            Exposure::PiecewiseLinear { .. } => "piecewise_linear",
            Exposure::Amcw { .. } => "amcw",
            Exposure::Tdc { .. } => "tdc",
        }
    }

    /// The number of gates `N` (unchecked).
    pub fn count(&self) -> u64 {
        match self {
            Exposure::Box { count, .. }
            | Exposure::Gaussian { count, .. }
            | Exposure::PiecewiseLinear { count, .. } => *count,
            Exposure::Amcw { phase_steps, .. } => *phase_steps,
            Exposure::Tdc { bins, .. } => *bins,
        }
    }

    /// Gates `first .. first + count` of this stepped sequence as a sequence of their
    /// own: the same shape, width and step, its gate 0 this one's gate `first` (the
    /// start, centre or knots moved on by `first` steps). `None` for AMCW phase steps
    /// and TDC bins (whose count sets the modulation's phases and the laser cycle), and
    /// for an empty range or one past the last gate.
    pub fn subsequence(&self, first: u64, count: u64) -> Option<Exposure> {
        if count == 0 || first.checked_add(count)? > self.count() {
            return None;
        }
        let mut e = self.clone();
        match &mut e {
            Exposure::Box {
                start_s,
                width_s,
                step_s,
                count: n,
                ..
            } => {
                *start_s += step_s.unwrap_or(*width_s) * first as f64;
                *n = count;
            }
            Exposure::Gaussian {
                centre_s,
                fwhm_s,
                step_s,
                count: n,
                ..
            } => {
                *centre_s += step_s.unwrap_or(*fwhm_s) * first as f64;
                *n = count;
            }
            Exposure::PiecewiseLinear {
                points,
                step_s,
                count: n,
                ..
            } => {
                let by = *step_s * first as f64;
                for p in points.iter_mut() {
                    p.0 += by;
                }
                *n = count;
            }
            Exposure::Amcw { .. } | Exposure::Tdc { .. } => return None,
        }
        Some(e)
    }

    /// The time origin of the gate times ([`TimeOrigin::Pulse`] for AMCW).
    pub fn origin(&self) -> TimeOrigin {
        match self {
            Exposure::Box { origin, .. }
            | Exposure::Gaussian { origin, .. }
            | Exposure::PiecewiseLinear { origin, .. }
            | Exposure::Tdc { origin, .. } => *origin,
            Exposure::Amcw { .. } => TimeOrigin::Pulse,
        }
    }

    /// For a TDC: the laser cycle `bins x bin_width_s` (s) and the jitter's standard
    /// deviation (s); `None` for other kinds (unchecked: see [`Exposure::gates`]).
    pub fn tdc_cycle_s(&self) -> Option<(f64, f64)> {
        match self {
            Exposure::Tdc {
                bin_width_s,
                bins,
                jitter_fwhm_s,
                ..
            } => Some((
                *bin_width_s * *bins as f64,
                jitter_fwhm_s / super::light::FWHM_PER_SIGMA,
            )),
            _ => None,
        }
    }

    /// Checks every value (finite, widths > 0, `1 <= count <= MAX_GATES`, ...) and
    /// resolves the sequence into gates at absolute times; `window_t0_s` is the cube's
    /// window start, used when the origin is [`TimeOrigin::Window`].
    pub fn gates(&self, window_t0_s: f64) -> Result<Vec<Gate>, SensorError> {
        let n = self.count();
        let what_count = match self {
            Exposure::Amcw { .. } => "exposure.phase_steps",
            Exposure::Tdc { .. } => "exposure.bins",
            _ => "exposure.count",
        };
        if n == 0 {
            return Err(SensorError::OutOfRange {
                what: what_count.into(),
                value: 0.0,
                rule: "at least 1",
            });
        }
        if n > MAX_GATES {
            return Err(SensorError::TooMany {
                what: what_count.into(),
                count: n,
                max: MAX_GATES,
            });
        }
        let offset = match self.origin() {
            TimeOrigin::Pulse => 0.0,
            TimeOrigin::Window => finite("cube t0_s", window_t0_s)?,
        };
        let gates: Vec<Gate> = match self {
            Exposure::Box {
                start_s,
                width_s,
                step_s,
                gain,
                ..
            } => {
                let start = super::time_s("exposure.start_s", *start_s)?;
                // A zero-width gate is allowed: it is open for no time and measures 0.
                let width = super::duration_s("exposure.width_s", *width_s, false)?;
                let step = super::time_s("exposure.step_s", step_s.unwrap_or(width))?;
                let gain = super::scale("exposure.gain", *gain)?;
                (0..n)
                    .map(|i| {
                        let a = offset + start + step * i as f64;
                        Gate::Box {
                            start_s: a,
                            end_s: a + width,
                            gain,
                        }
                    })
                    .collect()
            }
            Exposure::Gaussian {
                centre_s,
                fwhm_s,
                step_s,
                peak,
                ..
            } => {
                let centre = super::time_s("exposure.centre_s", *centre_s)?;
                let fwhm = super::duration_s("exposure.fwhm_s", *fwhm_s, true)?;
                let step = super::time_s("exposure.step_s", step_s.unwrap_or(fwhm))?;
                let peak = non_negative("exposure.peak", *peak)?;
                (0..n)
                    .map(|i| Gate::Gaussian {
                        centre_s: offset + centre + step * i as f64,
                        sigma_s: fwhm / super::light::FWHM_PER_SIGMA,
                        peak,
                    })
                    .collect()
            }
            Exposure::PiecewiseLinear { points, step_s, .. } => {
                let shape = Arc::new(PwlShape::new(points)?);
                let step = super::time_s("exposure.step_s", *step_s)?;
                (0..n)
                    .map(|i| Gate::PiecewiseLinear {
                        shape: shape.clone(),
                        shift_s: offset + step * i as f64,
                    })
                    .collect()
            }
            Exposure::Amcw {
                freq_hz,
                phase0_deg,
                modulation,
                ..
            } => {
                let freq_hz = positive("exposure.freq_hz", *freq_hz)?;
                // The unambiguous range c / (2 f) must be a float32 distance.
                if freq_hz < MIN_AMCW_FREQ_HZ {
                    return Err(SensorError::OutOfRange {
                        what: "exposure.freq_hz".into(),
                        value: freq_hz,
                        rule: ">= 1 mHz (the unambiguous range c / 2f is then 1.5e11 m)",
                    });
                }
                let phase0 = finite("exposure.phase0_deg", *phase0_deg)?.to_radians();
                let modulation = non_negative("exposure.modulation", *modulation)?;
                if modulation > 1.0 {
                    return Err(SensorError::OutOfRange {
                        what: "exposure.modulation".into(),
                        value: modulation,
                        rule: "in [0, 1] (a sensitivity cannot be negative)",
                    });
                }
                (0..n)
                    .map(|i| Gate::Cosine {
                        freq_hz,
                        phase_rad: (phase0 + TAU * i as f64 / n as f64).rem_euclid(TAU),
                        modulation,
                    })
                    .collect()
            }
            Exposure::Tdc {
                start_s,
                bin_width_s,
                jitter_fwhm_s,
                ..
            } => {
                let start = super::time_s("exposure.start_s", *start_s)?;
                let width = super::duration_s("exposure.bin_width_s", *bin_width_s, true)?;
                let sigma = super::duration_s("exposure.jitter_fwhm_s", *jitter_fwhm_s, false)?
                    / super::light::FWHM_PER_SIGMA;
                (0..n)
                    .map(|i| Gate::tdc_bin(offset + start + width * i as f64, width, sigma))
                    .collect()
            }
        };
        for (i, g) in gates.iter().enumerate() {
            let (lo, hi) = g.bin_average_support(0.0);
            if lo.is_nan() || hi.is_nan() || lo == f64::INFINITY || hi == f64::NEG_INFINITY {
                return Err(SensorError::Invalid(format!(
                    "exposure gate {i}: its times [{lo}, {hi}] s are not representable"
                )));
            }
            if let Gate::Box { start_s, end_s, .. } = g
                && !(start_s.is_finite() && end_s.is_finite() && end_s >= start_s)
            {
                return Err(SensorError::Invalid(format!(
                    "exposure gate {i}: [{start_s}, {end_s}) s is not a representable interval"
                )));
            }
        }
        Ok(gates)
    }
}

impl Gate {
    /// `Exposure_i(t_s)`.
    pub fn value(&self, t_s: f64) -> f64 {
        match self {
            Gate::Box {
                start_s,
                end_s,
                gain,
            } => {
                if t_s >= *start_s && t_s < *end_s {
                    *gain
                } else {
                    0.0
                }
            }
            Gate::Gaussian {
                centre_s,
                sigma_s,
                peak,
            } => {
                let x = (t_s - centre_s) / sigma_s;
                peak * (-0.5 * x * x).exp()
            }
            Gate::PiecewiseLinear { shape, shift_s } => shape.value(t_s - shift_s),
            Gate::Cosine {
                freq_hz,
                phase_rad,
                modulation,
            } => 0.5 * (1.0 + modulation * (TAU * freq_hz * t_s - phase_rad).cos()),
            Gate::Jittered {
                start_s,
                end_s,
                sigma_s,
            } => normal_cdf_diff((start_s - t_s) / sigma_s, (end_s - t_s) / sigma_s),
        }
    }

    /// A TDC bin `[start_s, start_s + width_s)` seen through a Gaussian jitter of
    /// standard deviation `sigma_s` (a plain box when it is 0).
    pub fn tdc_bin(start_s: f64, width_s: f64, sigma_s: f64) -> Gate {
        if sigma_s > 0.0 {
            Gate::Jittered {
                start_s,
                end_s: start_s + width_s,
                sigma_s,
            }
        } else {
            Gate::Box {
                start_s,
                end_s: start_s + width_s,
                gain: 1.0,
            }
        }
    }

    /// The gate shifted later by `by_s` seconds (for a TDC's bins in other laser
    /// cycles; AMCW gates are periodic and stay as they are).
    pub fn shifted(&self, by_s: f64) -> Gate {
        let mut g = self.clone();
        match &mut g {
            Gate::Box { start_s, end_s, .. } | Gate::Jittered { start_s, end_s, .. } => {
                *start_s += by_s;
                *end_s += by_s;
            }
            Gate::Gaussian { centre_s, .. } => *centre_s += by_s,
            Gate::PiecewiseLinear { shift_s, .. } => *shift_s += by_s,
            Gate::Cosine { .. } => {}
        }
        g
    }

    /// `Exposure_i(t)` at each time of `t_s` (for plots): 0 outside [`Gate::support_s`]
    /// without evaluating it (a viewer draws 64 TDC bins across a whole cycle every
    /// frame; each jittered bin is open on a few of its points).
    pub fn sample(&self, t_s: &[f64]) -> Vec<f64> {
        let (a, b) = self
            .support_s()
            .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        t_s.iter()
            .map(|&t| if t < a || t > b { 0.0 } else { self.value(t) })
            .collect()
    }

    /// The gate's mean time, weighted by sensitivity, seconds (`None` for AMCW).
    pub fn centre_s(&self) -> Option<f64> {
        match self {
            Gate::Box { start_s, end_s, .. } | Gate::Jittered { start_s, end_s, .. } => {
                Some(0.5 * (start_s + end_s))
            }
            Gate::Gaussian { centre_s, .. } => Some(*centre_s),
            Gate::PiecewiseLinear { shape, shift_s } => Some(shape.centroid_s + shift_s),
            Gate::Cosine { .. } => None,
        }
    }

    /// Where the gate is sensitive, seconds (`None`: everywhere, AMCW). Gaussian
    /// gates are cut at 8 sigma.
    pub fn support_s(&self) -> Option<(f64, f64)> {
        match self {
            Gate::Cosine { .. } => None,
            _ => Some(self.bin_average_support(0.0)),
        }
    }

    /// `(1 / dt) integral_u^{u + dt} Exposure(t) dt`: the gate averaged over a window
    /// of one bin (`dt_s > 0`) starting at `u_s`; `Exposure(u_s)` for `dt_s = 0`.
    pub fn bin_average(&self, u_s: f64, dt_s: f64) -> f64 {
        if dt_s <= 0.0 {
            return self.value(u_s);
        }
        match self {
            Gate::Box {
                start_s,
                end_s,
                gain,
            } => {
                let overlap = (u_s + dt_s).min(*end_s) - u_s.max(*start_s);
                if overlap > 0.0 {
                    gain * overlap / dt_s
                } else {
                    0.0
                }
            }
            Gate::Gaussian {
                centre_s,
                sigma_s,
                peak,
            } => {
                if dt_s < 1e-3 * sigma_s {
                    // Simpson: exact to (dt / sigma)^4 / 2880.
                    (self.value(u_s) + 4.0 * self.value(u_s + 0.5 * dt_s) + self.value(u_s + dt_s))
                        / 6.0
                } else {
                    let x1 = (u_s - centre_s) / sigma_s;
                    let x2 = (u_s + dt_s - centre_s) / sigma_s;
                    peak * sigma_s * (2.0 * PI).sqrt() / dt_s * normal_cdf_diff(x1, x2)
                }
            }
            Gate::PiecewiseLinear { shape, shift_s } => {
                let u = u_s - shift_s;
                (shape.primitive(u + dt_s) - shape.primitive(u)) / dt_s
            }
            Gate::Cosine {
                freq_hz,
                phase_rad,
                modulation,
            } => {
                let w = TAU * freq_hz;
                0.5 * (1.0
                    + modulation
                        * sinc(0.5 * w * dt_s)
                        * (w * (u_s + 0.5 * dt_s) - phase_rad).cos())
            }
            Gate::Jittered {
                start_s,
                end_s,
                sigma_s,
            } => {
                if dt_s < 1e-3 * sigma_s {
                    (self.value(u_s) + 4.0 * self.value(u_s + 0.5 * dt_s) + self.value(u_s + dt_s))
                        / 6.0
                } else {
                    // (1/dt) integral_u^{u+dt} Phi((b - t)/s) - Phi((a - t)/s) dt
                    // = (s/dt) [integral over x of Phi from (b-u-dt)/s to (b-u)/s, minus
                    // the same for a].
                    let s = *sigma_s;
                    let part = |edge: f64| normal_cdf_integral((edge - u_s - dt_s) / s, dt_s / s);
                    (s / dt_s * (part(*end_s) - part(*start_s))).clamp(0.0, 1.0)
                }
            }
        }
    }

    /// This gate seen through a Gaussian of standard deviation `sigma_s > 0`, `integral
    /// N(s; 0, sigma_s) E(t + s) ds`, when that is again a gate of closed form:
    /// `(gate, factor)` with the blurred exposure `factor x gate`. A box or a jittered
    /// box becomes a jittered box (variances add; a box's gain is the factor), a
    /// Gaussian a wider Gaussian of the same area. `None` for other gates.
    pub fn blurred(&self, sigma_s: f64) -> Option<(Gate, f64)> {
        if !(sigma_s > 0.0 && sigma_s.is_finite()) {
            return None;
        }
        match *self {
            Gate::Box {
                start_s,
                end_s,
                gain,
            } => Some((
                Gate::Jittered {
                    start_s,
                    end_s,
                    sigma_s,
                },
                gain,
            )),
            Gate::Jittered {
                start_s,
                end_s,
                sigma_s: s,
            } => Some((
                Gate::Jittered {
                    start_s,
                    end_s,
                    sigma_s: s.hypot(sigma_s),
                },
                1.0,
            )),
            Gate::Gaussian {
                centre_s,
                sigma_s: s,
                peak,
            } => {
                let wide = s.hypot(sigma_s);
                Some((
                    Gate::Gaussian {
                        centre_s,
                        sigma_s: wide,
                        peak: peak * s / wide,
                    },
                    1.0,
                ))
            }
            _ => None,
        }
    }

    /// `integral Exposure(t) dt` over all time, seconds: what a constant signal of 1
    /// (ambient light) contributes to the gate. `gain (end - start)` for a box, `peak
    /// sigma sqrt(2 pi)` for a Gaussian, the area under the knots, `end - start` for a
    /// jittered TDC bin (the jitter moves photons, it does not lose them). `None` for an
    /// AMCW gate, which never closes: its mean over a period is
    /// [`Gate::mean_value`].
    pub fn integral_s(&self) -> Option<f64> {
        match self {
            Gate::Box {
                start_s,
                end_s,
                gain,
            } => Some(gain * (end_s - start_s)),
            Gate::Gaussian { sigma_s, peak, .. } => Some(peak * sigma_s * (2.0 * PI).sqrt()),
            Gate::PiecewiseLinear { shape, .. } => shape.cum.last().copied(),
            Gate::Jittered { start_s, end_s, .. } => Some(end_s - start_s),
            Gate::Cosine { .. } => None,
        }
    }

    /// The gate's mean sensitivity over one period, for a periodic (AMCW) gate: 1/2;
    /// `None` for the others.
    pub fn mean_value(&self) -> Option<f64> {
        match self {
            Gate::Cosine { .. } => Some(0.5),
            _ => None,
        }
    }

    /// The range of `u` where [`Gate::bin_average`]`(u, dt_s)` can be non-zero.
    pub fn bin_average_support(&self, dt_s: f64) -> (f64, f64) {
        match self {
            Gate::Box { start_s, end_s, .. } => (start_s - dt_s, *end_s),
            Gate::Gaussian {
                centre_s, sigma_s, ..
            } => (
                centre_s - GAUSS_CUT * sigma_s - dt_s,
                centre_s + GAUSS_CUT * sigma_s,
            ),
            Gate::PiecewiseLinear { shape, shift_s } => {
                let (a, b) = shape.span_s();
                (a + shift_s - dt_s, b + shift_s)
            }
            Gate::Cosine { .. } => (f64::NEG_INFINITY, f64::INFINITY),
            Gate::Jittered {
                start_s,
                end_s,
                sigma_s,
            } => (
                start_s - GAUSS_CUT * sigma_s - dt_s,
                end_s + GAUSS_CUT * sigma_s,
            ),
        }
    }

    /// The kinks of [`Gate::bin_average`]`(., dt_s)`, sorted, into `out` (cleared).
    pub fn bin_average_breaks(&self, dt_s: f64, out: &mut Vec<f64>) {
        out.clear();
        match self {
            // The jittered box's average is smooth, but varies fastest around these.
            Gate::Box { start_s, end_s, .. } | Gate::Jittered { start_s, end_s, .. } => {
                out.extend([start_s - dt_s, *start_s, end_s - dt_s, *end_s]);
            }
            Gate::PiecewiseLinear { shape, shift_s } => {
                for &t in &shape.t_s {
                    out.push(t + shift_s - dt_s);
                    out.push(t + shift_s);
                }
            }
            Gate::Gaussian { .. } | Gate::Cosine { .. } => {}
        }
        out.sort_unstable_by(f64::total_cmp);
        out.dedup();
    }

    /// The time scale on which [`Gate::bin_average`] is smooth between its kinks,
    /// seconds (infinity: a polynomial of degree <= 2 there).
    pub fn scale_s(&self) -> f64 {
        match self {
            Gate::Box { .. } | Gate::PiecewiseLinear { .. } => f64::INFINITY,
            Gate::Gaussian { sigma_s, .. } | Gate::Jittered { sigma_s, .. } => *sigma_s,
            Gate::Cosine { freq_hz, .. } => 1.0 / (TAU * freq_hz),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gates(e: &Exposure) -> Vec<Gate> {
        match e.gates(0.0) {
            Ok(g) => g,
            Err(err) => panic!("{err}"),
        }
    }

    #[test]
    fn bin_averages_match_quadrature_of_the_gate() {
        let ns = 1e-9;
        let seqs = [
            Exposure::Box {
                origin: TimeOrigin::Pulse,
                start_s: ns,
                width_s: 2.0 * ns,
                step_s: None,
                count: 1,
                gain: 0.5,
            },
            Exposure::Gaussian {
                origin: TimeOrigin::Pulse,
                centre_s: 3.0 * ns,
                fwhm_s: 1.5 * ns,
                step_s: None,
                count: 1,
                peak: 1.0,
            },
            Exposure::PiecewiseLinear {
                origin: TimeOrigin::Pulse,
                points: vec![
                    Point(ns, 0.0),
                    Point(2.0 * ns, 1.0),
                    Point(2.0 * ns, 0.5),
                    Point(4.0 * ns, 0.0),
                ],
                step_s: 0.0,
                count: 1,
            },
            Exposure::Amcw {
                freq_hz: 2e8,
                phase_steps: 4,
                phase0_deg: 30.0,
                modulation: 0.8,
            },
            Exposure::Tdc {
                origin: TimeOrigin::Pulse,
                start_s: ns,
                bin_width_s: 0.5 * ns,
                bins: 4,
                jitter_fwhm_s: 0.3 * ns,
            },
        ];
        for e in &seqs {
            let g = &gates(e)[0];
            for dt in [0.05 * ns, 0.7 * ns, 3.0 * ns] {
                for k in 0..60 {
                    let u = -ns + 0.1 * ns * k as f64;
                    // Fine midpoint rule of the gate itself.
                    let m = 20_000;
                    let want: f64 = (0..m)
                        .map(|j| g.value(u + dt * (j as f64 + 0.5) / m as f64))
                        .sum::<f64>()
                        / m as f64;
                    let got = g.bin_average(u, dt);
                    assert!(
                        (got - want).abs() < 2e-4,
                        "{} u {u} dt {dt}: {got} vs {want}",
                        e.kind_name()
                    );
                }
            }
        }
    }

    #[test]
    fn window_origin_shifts_gates() {
        let e = Exposure::Box {
            origin: TimeOrigin::Window,
            start_s: 1e-9,
            width_s: 1e-9,
            step_s: Some(2e-9),
            count: 3,
            gain: 1.0,
        };
        let Ok(g) = e.gates(10e-9) else {
            panic!("valid");
        };
        let centre = g[2].centre_s().unwrap_or(f64::NAN);
        assert!((centre - 15.5e-9).abs() < 1e-21, "{centre}");
    }

    #[test]
    fn absurd_sequences_are_errors() {
        let boxes = |width_s: f64, count: u64| Exposure::Box {
            origin: TimeOrigin::Pulse,
            start_s: 0.0,
            width_s,
            step_s: None,
            count,
            gain: 1.0,
        };
        assert!(boxes(1.0, 1_000_000_000).gates(0.0).is_err());
        assert!(boxes(1.0, 0).gates(0.0).is_err());
        assert!(boxes(-1.0, 1).gates(0.0).is_err());
        assert!(boxes(f64::NAN, 1).gates(0.0).is_err());
        assert!(boxes(1e308, 4).gates(0.0).is_err());
        let amcw = Exposure::Amcw {
            freq_hz: 0.0,
            phase_steps: 4,
            phase0_deg: 0.0,
            modulation: 1.0,
        };
        assert!(amcw.gates(0.0).is_err());
    }

    /// A subsequence is gates `first ..` of the whole, gate for gate, for every stepped
    /// kind; the others and out-of-range requests have none.
    #[test]
    fn a_subsequence_is_the_same_gates() {
        let stepped = [
            Exposure::Box {
                origin: TimeOrigin::Window,
                start_s: 1e-9,
                width_s: 0.5e-9,
                step_s: Some(0.7e-9),
                count: 10,
                gain: 2.0,
            },
            Exposure::Gaussian {
                origin: TimeOrigin::Pulse,
                centre_s: 3e-9,
                fwhm_s: 1e-9,
                step_s: None,
                count: 6,
                peak: 1.0,
            },
            Exposure::PiecewiseLinear {
                origin: TimeOrigin::Pulse,
                points: vec![Point(0.0, 0.0), Point(1e-9, 1.0), Point(2e-9, 0.0)],
                step_s: 1.5e-9,
                count: 5,
            },
        ];
        for e in &stepped {
            let all = e.gates(4e-9).unwrap();
            let sub = e.subsequence(2, 3).expect("a stepped kind");
            assert_eq!(sub.count(), 3);
            let part = sub.gates(4e-9).unwrap();
            for (i, (a, b)) in all[2..5].iter().zip(&part).enumerate() {
                for t in [3e-9, 4.2e-9, 5.1e-9, 6.5e-9, 8e-9, 11e-9] {
                    assert!(
                        (a.value(t) - b.value(t)).abs() < 1e-9,
                        "{}: gate {i} at {t}",
                        e.kind_name()
                    );
                }
            }
            assert!(e.subsequence(4, e.count()).is_none());
            assert!(e.subsequence(0, 0).is_none());
        }
        let amcw = Exposure::Amcw {
            freq_hz: 20e6,
            phase_steps: 4,
            phase0_deg: 0.0,
            modulation: 1.0,
        };
        assert!(amcw.subsequence(0, 2).is_none());
    }
}

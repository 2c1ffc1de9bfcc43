//! `Light(t)`: the envelope of the light pulse (paper, section 6), in watts per unit
//! pulse energy: `integral Light(t) dt = energy`, 1 by default (the unit pulse the cube
//! was rendered for). `t` is in seconds after the trigger; the TPRF's own pulse is
//! `delta(t)`.
//!
//! [`LightPulse`] is the serde description (presets and free envelopes);
//! [`LightPulse::compile`] checks it and gives a [`Light`], which evaluates the
//! envelope and integrates other functions against it exactly enough that a pulse a
//! thousandth of a bin wide and one a thousand bins wide both keep their energy.

use serde::{Deserialize, Serialize};

use super::quad::{gauss_legendre, subpieces};
use super::values::{Point, seconds};
use super::{SensorError, finite, non_negative};

/// `FWHM = FWHM_PER_SIGMA * sigma` for a Gaussian: `2 sqrt(2 ln 2)`.
pub const FWHM_PER_SIGMA: f64 = 2.354_820_045_030_949_3;

/// Largest number of knots of a piecewise-linear envelope.
pub const MAX_POINTS: usize = 100_000;

/// Largest number of side lobes of a sinc^2 pulse.
pub const MAX_LOBES: u32 = 1000;

/// Gaussians are cut at this many sigma (the mass beyond is 1.2e-15).
const GAUSS_CUT: f64 = 8.0;
/// Exponential tails are cut at this many time constants (the mass beyond is 4e-18).
const EXP_CUT: f64 = 40.0;

fn one() -> f64 {
    1.0
}

fn default_lobes() -> u32 {
    8
}

/// A light pulse envelope as written in a sensor file (checked by [`compile`]).
/// Every shape is scaled so that `integral Light(t) dt = energy` (default 1); a zero
/// width gives a delta at the pulse's time.
///
/// [`compile`]: LightPulse::compile
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightPulse {
    /// `energy * delta(t - t_s)`: the cube's own pulse for `t_s = 0`, energy 1.
    Delta {
        #[serde(default, alias = "t", with = "seconds")]
        t_s: f64,
        #[serde(default = "one")]
        energy: f64,
    },
    /// A Gaussian centred at `centre_s` with full width at half maximum `fwhm_s`.
    Gaussian {
        #[serde(default, alias = "centre", alias = "center", with = "seconds")]
        centre_s: f64,
        #[serde(alias = "fwhm", with = "seconds")]
        fwhm_s: f64,
        #[serde(default = "one")]
        energy: f64,
    },
    /// Constant power over `[start_s, start_s + width_s)`.
    Rect {
        #[serde(default, alias = "start", with = "seconds")]
        start_s: f64,
        #[serde(alias = "width", with = "seconds")]
        width_s: f64,
        #[serde(default = "one")]
        energy: f64,
    },
    /// Instant rise at `onset_s`, exponential decay with time constant `tau_s`:
    /// `exp(-(t - onset_s) / tau_s) / tau_s`.
    Exponential {
        #[serde(default, alias = "onset", with = "seconds")]
        onset_s: f64,
        #[serde(alias = "tau", with = "seconds")]
        tau_s: f64,
        #[serde(default = "one")]
        energy: f64,
    },
    /// A laser-diode-like asymmetric pulse from `onset_s`: a fast rise and a slower
    /// decay, `(exp(-v / fall_s) - exp(-v / rise_s)) / (fall_s - rise_s)` for
    /// `v = t - onset_s >= 0`; `0 <= rise_s < fall_s`. Its mean is
    /// `onset_s + rise_s + fall_s`.
    LaserDiode {
        #[serde(default, alias = "onset", with = "seconds")]
        onset_s: f64,
        #[serde(alias = "rise", with = "seconds")]
        rise_s: f64,
        #[serde(alias = "fall", with = "seconds")]
        fall_s: f64,
        #[serde(default = "one")]
        energy: f64,
    },
    /// `sinc^2((t - centre_s) / width_s)` with `sinc(x) = sin(pi x) / (pi x)`: first
    /// zeros at `centre_s +- width_s`, cut after `lobes` side lobes on each side
    /// (default 8, holding all but 1.2 % of the untruncated energy) and renormalised.
    Sinc2 {
        #[serde(default, alias = "centre", alias = "center", with = "seconds")]
        centre_s: f64,
        #[serde(alias = "width", with = "seconds")]
        width_s: f64,
        #[serde(default = "default_lobes")]
        lobes: u32,
        #[serde(default = "one")]
        energy: f64,
    },
    /// A free envelope through `[t_s, value]` knots: values >= 0, times non-decreasing
    /// (a repeated time is a jump), linear in between, zero outside; scaled to `energy`.
    PiecewiseLinear {
        points: Vec<Point>,
        #[serde(default = "one")]
        energy: f64,
    },
}

impl Default for LightPulse {
    /// The cube's own pulse: a unit delta at `t = 0`.
    fn default() -> Self {
        LightPulse::Delta {
            t_s: 0.0,
            energy: 1.0,
        }
    }
}

/// A checked, normalised envelope: evaluates `Light(t)` and integrates against it.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    shape: Shape,
    energy: f64,
    /// Time ranges (seconds, sorted, adjacent) with the scale on which the envelope
    /// varies smoothly there; empty for a delta.
    regions: Vec<Region>,
    /// Kinks inside the regions (seconds, sorted).
    breaks: Vec<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Region {
    lo: f64,
    hi: f64,
    scale: f64,
}

/// Unit-energy shapes.
#[derive(Clone, Debug, PartialEq)]
enum Shape {
    Delta {
        t_s: f64,
    },
    Gaussian {
        mu_s: f64,
        sigma_s: f64,
    },
    Rect {
        start_s: f64,
        end_s: f64,
    },
    Exponential {
        onset_s: f64,
        tau_s: f64,
    },
    LaserDiode {
        onset_s: f64,
        rise_s: f64,
        fall_s: f64,
    },
    Sinc2 {
        centre_s: f64,
        width_s: f64,
        half_s: f64,
        norm: f64,
    },
    Pwl {
        t_s: Vec<f64>,
        v: Vec<f64>,
        norm: f64,
    },
}

/// `sin(pi x) / (pi x)`.
fn sinc_pi(x: f64) -> f64 {
    let a = std::f64::consts::PI * x;
    if a.abs() < 1e-8 { 1.0 } else { a.sin() / a }
}

impl LightPulse {
    /// The pulse energy (1: the cube's unit pulse).
    pub fn energy(&self) -> f64 {
        match self {
            LightPulse::Delta { energy, .. }
            | LightPulse::Gaussian { energy, .. }
            | LightPulse::Rect { energy, .. }
            | LightPulse::Exponential { energy, .. }
            | LightPulse::LaserDiode { energy, .. }
            | LightPulse::Sinc2 { energy, .. }
            | LightPulse::PiecewiseLinear { energy, .. } => *energy,
        }
    }

    /// The `kind` name as in a file.
    pub fn kind_name(&self) -> &'static str {
        match self {
            LightPulse::Delta { .. } => "delta",
            LightPulse::Gaussian { .. } => "gaussian",
            LightPulse::Rect { .. } => "rect",
            LightPulse::Exponential { .. } => "exponential",
            LightPulse::LaserDiode { .. } => "laser_diode",
            LightPulse::Sinc2 { .. } => "sinc2",
            LightPulse::PiecewiseLinear { .. } => "piecewise_linear",
        }
    }

    /// Checks every value (finite times, widths >= 0, energy >= 0, sorted knots ...)
    /// and builds the normalised envelope.
    pub fn compile(&self) -> Result<Light, SensorError> {
        let energy = super::scale("light.energy", self.energy())?;
        let shape = match self {
            LightPulse::Delta { t_s, .. } => Shape::Delta {
                t_s: super::time_s("light.t_s", *t_s)?,
            },
            LightPulse::Gaussian {
                centre_s, fwhm_s, ..
            } => {
                let mu_s = super::time_s("light.centre_s", *centre_s)?;
                let fwhm = super::duration_s("light.fwhm_s", *fwhm_s, false)?;
                if fwhm == 0.0 {
                    Shape::Delta { t_s: mu_s }
                } else {
                    Shape::Gaussian {
                        mu_s,
                        sigma_s: fwhm / FWHM_PER_SIGMA,
                    }
                }
            }
            LightPulse::Rect {
                start_s, width_s, ..
            } => {
                let start_s = super::time_s("light.start_s", *start_s)?;
                let width = super::duration_s("light.width_s", *width_s, false)?;
                if width == 0.0 {
                    Shape::Delta { t_s: start_s }
                } else {
                    Shape::Rect {
                        start_s,
                        end_s: start_s + width,
                    }
                }
            }
            LightPulse::Exponential { onset_s, tau_s, .. } => {
                let onset_s = super::time_s("light.onset_s", *onset_s)?;
                let tau_s = super::duration_s("light.tau_s", *tau_s, false)?;
                if tau_s == 0.0 {
                    Shape::Delta { t_s: onset_s }
                } else {
                    Shape::Exponential { onset_s, tau_s }
                }
            }
            LightPulse::LaserDiode {
                onset_s,
                rise_s,
                fall_s,
                ..
            } => {
                let onset_s = super::time_s("light.onset_s", *onset_s)?;
                let rise_s = super::duration_s("light.rise_s", *rise_s, false)?;
                let fall_s = super::duration_s("light.fall_s", *fall_s, false)?;
                if fall_s == 0.0 && rise_s == 0.0 {
                    Shape::Delta { t_s: onset_s }
                } else if rise_s >= fall_s {
                    return Err(SensorError::Invalid(format!(
                        "light.rise_s = {rise_s} must be shorter than light.fall_s = {fall_s} \
                         (the pulse rises fast and decays slowly)"
                    )));
                } else if rise_s == 0.0 {
                    Shape::Exponential {
                        onset_s,
                        tau_s: fall_s,
                    }
                } else {
                    Shape::LaserDiode {
                        onset_s,
                        rise_s,
                        fall_s,
                    }
                }
            }
            LightPulse::Sinc2 {
                centre_s,
                width_s,
                lobes,
                ..
            } => {
                let centre_s = super::time_s("light.centre_s", *centre_s)?;
                let width_s = super::duration_s("light.width_s", *width_s, false)?;
                if *lobes > MAX_LOBES {
                    return Err(SensorError::TooMany {
                        what: "light.lobes".into(),
                        count: u64::from(*lobes),
                        max: u64::from(MAX_LOBES),
                    });
                }
                if width_s == 0.0 {
                    Shape::Delta { t_s: centre_s }
                } else {
                    // integral of sinc^2 over |x| <= lobes + 1, half-lobe pieces.
                    let reach = f64::from(*lobes) + 1.0;
                    let area = gauss_legendre(
                        |x| sinc_pi(x).powi(2),
                        -reach,
                        reach,
                        4 * (*lobes as usize + 1),
                    );
                    Shape::Sinc2 {
                        centre_s,
                        width_s,
                        half_s: reach * width_s,
                        norm: 1.0 / (area * width_s),
                    }
                }
            }
            LightPulse::PiecewiseLinear { points, .. } => compile_pwl(points)?,
        };
        let light = Light::from_shape(shape, energy);
        let (lo, hi) = light.support_s();
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(SensorError::Invalid(format!(
                "light ({}): its time span [{lo}, {hi}] s is not representable",
                self.kind_name()
            )));
        }
        Ok(light)
    }
}

fn compile_pwl(points: &[Point]) -> Result<Shape, SensorError> {
    if points.len() > MAX_POINTS {
        return Err(SensorError::TooMany {
            what: "light.points".into(),
            count: points.len() as u64,
            max: MAX_POINTS as u64,
        });
    }
    if points.len() < 2 {
        return Err(SensorError::Invalid(
            "light.points needs at least two [t_s, value] knots".into(),
        ));
    }
    let mut t_s = Vec::with_capacity(points.len());
    let mut v = Vec::with_capacity(points.len());
    for (k, p) in points.iter().enumerate() {
        let t = finite(&format!("light.points[{k}] time"), p.0)?;
        let value = non_negative(&format!("light.points[{k}] value"), p.1)?;
        if let Some(&prev) = t_s.last()
            && t < prev
        {
            return Err(SensorError::Invalid(format!(
                "light.points[{k}]: time {t} s comes before the previous knot's {prev} s \
                 (times must not decrease)"
            )));
        }
        t_s.push(t);
        v.push(value);
    }
    let area: f64 = (1..t_s.len())
        .map(|k| 0.5 * (v[k - 1] + v[k]) * (t_s[k] - t_s[k - 1]))
        .sum();
    if !(area > 0.0 && area.is_finite()) {
        return Err(SensorError::Invalid(format!(
            "light.points encloses area {area}: the envelope needs a positive, finite area"
        )));
    }
    Ok(Shape::Pwl {
        t_s,
        v,
        norm: 1.0 / area,
    })
}

impl Light {
    fn from_shape(shape: Shape, energy: f64) -> Light {
        let (regions, breaks) = match &shape {
            Shape::Delta { .. } => (vec![], vec![]),
            Shape::Gaussian { mu_s, sigma_s } => (
                vec![Region {
                    lo: mu_s - GAUSS_CUT * sigma_s,
                    hi: mu_s + GAUSS_CUT * sigma_s,
                    scale: 2.0 * sigma_s,
                }],
                vec![],
            ),
            Shape::Rect { start_s, end_s } => (
                vec![Region {
                    lo: *start_s,
                    hi: *end_s,
                    scale: f64::INFINITY,
                }],
                vec![],
            ),
            Shape::Exponential { onset_s, tau_s } => (
                vec![Region {
                    lo: *onset_s,
                    hi: onset_s + EXP_CUT * tau_s,
                    scale: 2.0 * tau_s,
                }],
                vec![],
            ),
            Shape::LaserDiode {
                onset_s,
                rise_s,
                fall_s,
            } => {
                // Near the onset the rise sets the scale; past 40 rise times only the
                // decay is left.
                let hi = onset_s + EXP_CUT * fall_s;
                let knee = (onset_s + EXP_CUT * rise_s).min(hi);
                let mut regions = vec![Region {
                    lo: *onset_s,
                    hi: knee,
                    scale: rise_s.min(2.0 * fall_s),
                }];
                if hi > knee {
                    regions.push(Region {
                        lo: knee,
                        hi,
                        scale: 2.0 * fall_s,
                    });
                }
                (regions, vec![])
            }
            Shape::Sinc2 {
                centre_s,
                width_s,
                half_s,
                ..
            } => (
                vec![Region {
                    lo: centre_s - half_s,
                    hi: centre_s + half_s,
                    scale: 0.5 * width_s,
                }],
                vec![],
            ),
            Shape::Pwl { t_s, .. } => {
                let (lo, hi) = (t_s[0], t_s[t_s.len() - 1]);
                let mut breaks: Vec<f64> =
                    t_s.iter().copied().filter(|&t| t > lo && t < hi).collect();
                breaks.dedup();
                (
                    vec![Region {
                        lo,
                        hi,
                        scale: f64::INFINITY,
                    }],
                    breaks,
                )
            }
        };
        let light = Light {
            shape,
            energy,
            regions,
            breaks,
        };
        light.collapse_if_unresolvable()
    }
}

impl Light {
    /// A pulse whose support is too narrow to be resolved in `f64` at its time (fewer
    /// than ~1e9 distinct instants) is a delta at its mean: integrating it on nodes
    /// that round together would lose energy.
    fn collapse_if_unresolvable(self) -> Light {
        let Some((lo, hi)) = self.support_s_opt() else {
            return self;
        };
        let tiny = 1e-9 * lo.abs().max(hi.abs());
        let unrepresentable = !(lo.is_finite() && hi.is_finite());
        if unrepresentable || (hi - lo > tiny && hi - lo > f64::MIN_POSITIVE) {
            return self;
        }
        let t_s = self.mean_s();
        Light {
            shape: Shape::Delta { t_s },
            energy: self.energy,
            regions: vec![],
            breaks: vec![],
        }
    }

    fn support_s_opt(&self) -> Option<(f64, f64)> {
        Some((self.regions.first()?.lo, self.regions.last()?.hi))
    }

    /// The pulse energy: `integral Light(t) dt`.
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// `Some(t_s)` when the pulse is `energy * delta(t - t_s)`.
    pub fn delta_time_s(&self) -> Option<f64> {
        match self.shape {
            Shape::Delta { t_s } => Some(t_s),
            _ => None,
        }
    }

    /// `Some((mu_s, sigma_s))` when the pulse is `energy N(t; mu_s, sigma_s)` (its
    /// tails, cut at 8 sigma, hold 1.2e-15 of the energy).
    pub fn gaussian(&self) -> Option<(f64, f64)> {
        match self.shape {
            Shape::Gaussian { mu_s, sigma_s } => Some((mu_s, sigma_s)),
            _ => None,
        }
    }

    /// The time range holding the pulse, seconds (tails cut where less than 1e-15 of
    /// the energy lies beyond): `(t, t)` for a delta.
    pub fn support_s(&self) -> (f64, f64) {
        match self.shape {
            Shape::Delta { t_s } => (t_s, t_s),
            _ => self.support_s_opt().unwrap_or((0.0, 0.0)),
        }
    }

    /// The mean emission time `integral t Light(t) dt / energy`, seconds.
    pub fn mean_s(&self) -> f64 {
        match &self.shape {
            Shape::Delta { t_s } => *t_s,
            Shape::Gaussian { mu_s, .. } => *mu_s,
            Shape::Rect { start_s, end_s } => 0.5 * (start_s + end_s),
            Shape::Exponential { onset_s, tau_s } => onset_s + tau_s,
            Shape::LaserDiode {
                onset_s,
                rise_s,
                fall_s,
            } => onset_s + rise_s + fall_s,
            Shape::Sinc2 { centre_s, .. } => *centre_s,
            Shape::Pwl { t_s, v, norm } => {
                // integral of t v(t) over a segment: (t1 - t0) (v0 (2 t0 + t1) + v1 (t0 + 2 t1)) / 6
                let moment: f64 = (1..t_s.len())
                    .map(|k| {
                        let (t0, t1, v0, v1) = (t_s[k - 1], t_s[k], v[k - 1], v[k]);
                        (t1 - t0) * (v0 * (2.0 * t0 + t1) + v1 * (t0 + 2.0 * t1)) / 6.0
                    })
                    .sum();
                moment * norm
            }
        }
    }

    /// `Light(t_s)` for unit energy, 1/s (0 everywhere for a delta).
    fn unit_density(&self, t: f64) -> f64 {
        match &self.shape {
            Shape::Delta { .. } => 0.0,
            Shape::Gaussian { mu_s, sigma_s } => {
                let x = (t - mu_s) / sigma_s;
                (-0.5 * x * x).exp() / (sigma_s * (2.0 * std::f64::consts::PI).sqrt())
            }
            Shape::Rect { start_s, end_s } => {
                if t >= *start_s && t < *end_s {
                    1.0 / (end_s - start_s)
                } else {
                    0.0
                }
            }
            Shape::Exponential { onset_s, tau_s } => {
                let v = t - onset_s;
                if v >= 0.0 {
                    (-v / tau_s).exp() / tau_s
                } else {
                    0.0
                }
            }
            Shape::LaserDiode {
                onset_s,
                rise_s,
                fall_s,
            } => {
                let v = t - onset_s;
                if v >= 0.0 {
                    ((-v / fall_s).exp() - (-v / rise_s).exp()) / (fall_s - rise_s)
                } else {
                    0.0
                }
            }
            Shape::Sinc2 {
                centre_s,
                width_s,
                half_s,
                norm,
            } => {
                let d = t - centre_s;
                if d.abs() <= *half_s {
                    norm * sinc_pi(d / width_s).powi(2)
                } else {
                    0.0
                }
            }
            Shape::Pwl { t_s, v, norm } => {
                let j = t_s.partition_point(|&k| k <= t);
                if j == 0 || j == t_s.len() {
                    return 0.0;
                }
                let (t0, t1, v0, v1) = (t_s[j - 1], t_s[j], v[j - 1], v[j]);
                norm * (v0 + (v1 - v0) * (t - t0) / (t1 - t0))
            }
        }
    }

    /// The envelope's variance in time, `integral (t - mean)^2 Light / energy`,
    /// seconds squared (0 for a delta).
    pub fn variance_s2(&self) -> f64 {
        if self.delta_time_s().is_some() || !(self.energy > 0.0) {
            return 0.0;
        }
        let mean = self.mean_s();
        let (lo, hi) = self.support_s();
        let mut scratch = Vec::new();
        let v = self.integrate(
            |t| (t - mean) * (t - mean),
            lo,
            hi,
            &[],
            0.0,
            f64::INFINITY,
            &mut scratch,
        ) / self.energy;
        if v.is_finite() { v.max(0.0) } else { 0.0 }
    }

    /// `Light(t_s)`, watts per unit of the cube's pulse energy (0 for a delta: see
    /// [`Light::delta_time_s`]).
    pub fn density(&self, t_s: f64) -> f64 {
        self.energy * self.unit_density(t_s)
    }

    /// `Light(t)` at each time of `t_s` (for plots).
    pub fn sample(&self, t_s: &[f64]) -> Vec<f64> {
        t_s.iter().map(|&t| self.density(t)).collect()
    }

    /// The energy emitted in `[a_s, b_s)`.
    pub fn energy_between(&self, a_s: f64, b_s: f64) -> f64 {
        if let Shape::Delta { t_s } = self.shape {
            return if t_s >= a_s && t_s < b_s {
                self.energy
            } else {
                0.0
            };
        }
        let mut scratch = Vec::new();
        self.integrate(|_| 1.0, a_s, b_s, &[], 0.0, f64::INFINITY, &mut scratch)
    }

    /// `integral Light(s) f(s) ds` over `[f_lo, f_hi]`, `f` zero outside, for an `f`
    /// smooth between its kinks (at `b - f_breaks_shift_s` for each `b` of the sorted
    /// `f_breaks`) on the time scale `f_scale` (seconds;
    /// infinity when `f` is a low-degree polynomial between kinks). The integral is
    /// split at every kink of `f` and of the envelope, each piece cut into sub-pieces
    /// no wider than the finer of the two scales, each integrated by 8-point
    /// Gauss-Legendre. A delta is evaluated exactly: `energy * f(t)` (for `t` in
    /// `[f_lo, f_hi]`). `scratch` is reused between calls.
    #[allow(
        clippy::too_many_arguments,
        reason = "the quadrature's interval, kernel and scratch, on the kernels' hot path"
    )]
    pub(crate) fn integrate(
        &self,
        f: impl Fn(f64) -> f64,
        f_lo: f64,
        f_hi: f64,
        f_breaks: &[f64],
        f_breaks_shift_s: f64,
        f_scale: f64,
        scratch: &mut Vec<f64>,
    ) -> f64 {
        if let Shape::Delta { t_s } = self.shape {
            return if t_s >= f_lo && t_s <= f_hi {
                self.energy * f(t_s)
            } else {
                0.0
            };
        }
        let mut total = 0.0;
        for region in &self.regions {
            let lo = region.lo.max(f_lo);
            let hi = region.hi.min(f_hi);
            if !(hi > lo) {
                continue;
            }
            scratch.clear();
            scratch.push(lo);
            let first = self.breaks.partition_point(|&b| b <= lo);
            scratch.extend(self.breaks[first..].iter().take_while(|&&b| b < hi));
            let first = f_breaks.partition_point(|&b| b - f_breaks_shift_s <= lo);
            scratch.extend(
                f_breaks[first..]
                    .iter()
                    .map(|&b| b - f_breaks_shift_s)
                    .take_while(|&b| b < hi),
            );
            scratch.push(hi);
            scratch.sort_unstable_by(f64::total_cmp);
            let scale = region.scale.min(f_scale);
            for w in scratch.windows(2) {
                let (a, b) = (w[0], w[1]);
                if b > a {
                    total += gauss_legendre(
                        |t| self.unit_density(t) * f(t),
                        a,
                        b,
                        subpieces(a, b, scale),
                    );
                }
            }
        }
        total * self.energy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn compile(p: LightPulse) -> Light {
        match p.compile() {
            Ok(l) => l,
            Err(e) => panic!("{e}"),
        }
    }

    #[test]
    fn every_shape_has_unit_energy_and_its_mean() {
        let ns = 1e-9;
        let shapes = [
            LightPulse::Gaussian {
                centre_s: 5.0 * ns,
                fwhm_s: 2.0 * ns,
                energy: 1.0,
            },
            LightPulse::Rect {
                start_s: ns,
                width_s: 3.0 * ns,
                energy: 1.0,
            },
            LightPulse::Exponential {
                onset_s: ns,
                tau_s: 0.7 * ns,
                energy: 1.0,
            },
            LightPulse::LaserDiode {
                onset_s: 0.0,
                rise_s: 0.1 * ns,
                fall_s: 1.3 * ns,
                energy: 1.0,
            },
            LightPulse::Sinc2 {
                centre_s: 4.0 * ns,
                width_s: 0.5 * ns,
                lobes: 8,
                energy: 1.0,
            },
            LightPulse::PiecewiseLinear {
                points: vec![
                    Point(0.0, 0.0),
                    Point(ns, 2.0),
                    Point(ns, 1.0),
                    Point(3.0 * ns, 0.0),
                ],
                energy: 1.0,
            },
        ];
        let mut scratch = Vec::new();
        for p in shapes {
            let l = compile(p.clone());
            let (lo, hi) = l.support_s();
            let e = l.integrate(|_| 1.0, lo, hi, &[], 0.0, f64::INFINITY, &mut scratch);
            assert!((e - 1.0).abs() < 1e-11, "{p:?}: energy {e}");
            let m = l.integrate(|t| t, lo, hi, &[], 0.0, f64::INFINITY, &mut scratch);
            assert!(
                (m - l.mean_s()).abs() < 1e-11 * ns,
                "{p:?}: mean {m} vs {}",
                l.mean_s()
            );
        }
    }

    #[test]
    fn zero_widths_are_deltas() {
        for p in [
            LightPulse::Gaussian {
                centre_s: 2e-9,
                fwhm_s: 0.0,
                energy: 3.0,
            },
            LightPulse::Rect {
                start_s: 2e-9,
                width_s: 0.0,
                energy: 3.0,
            },
            // Far too narrow to resolve at its time.
            LightPulse::Gaussian {
                centre_s: 2e-9,
                fwhm_s: 1e-30,
                energy: 3.0,
            },
        ] {
            let l = compile(p);
            assert_eq!(l.delta_time_s(), Some(2e-9));
            assert_eq!(l.energy_between(0.0, 1.0), 3.0);
        }
    }

    #[test]
    fn bad_values_are_errors() {
        let bad = [
            LightPulse::Gaussian {
                centre_s: f64::NAN,
                fwhm_s: 1.0,
                energy: 1.0,
            },
            LightPulse::Gaussian {
                centre_s: 0.0,
                fwhm_s: -1.0,
                energy: 1.0,
            },
            LightPulse::Rect {
                start_s: 0.0,
                width_s: 1.0,
                energy: -2.0,
            },
            LightPulse::LaserDiode {
                onset_s: 0.0,
                rise_s: 2.0,
                fall_s: 1.0,
                energy: 1.0,
            },
            LightPulse::Sinc2 {
                centre_s: 0.0,
                width_s: 1.0,
                lobes: 1_000_000_000,
                energy: 1.0,
            },
            LightPulse::PiecewiseLinear {
                points: vec![Point(1.0, 1.0), Point(0.0, 1.0)],
                energy: 1.0,
            },
            LightPulse::PiecewiseLinear {
                points: vec![Point(0.0, 0.0), Point(1.0, 0.0)],
                energy: 1.0,
            },
            LightPulse::Exponential {
                onset_s: 0.0,
                tau_s: 1e308,
                energy: 1.0,
            },
        ];
        for p in bad {
            assert!(p.compile().is_err(), "{p:?} accepted");
        }
    }
}

//! Luminescent vertices: where a path meets a surface that re-emits part of the light it
//! receives later ([`crate::scene::Luminescence`]), time stops being optical path length
//! over c.
//!
//! Seen from the eye, a luminescent surface scatters by `f = f_base + (Y / pi) h(t)`:
//! its BSDF at once, plus a Lambertian lobe of albedo `Y` (the band's yield) whose light
//! left the surface a delay `t` after it arrived, `t` distributed by the decay `h`
//! (normalised: `sum_k (Y_k / Y) h_k`, `h_k(t) = e^{-t / tau_k} / tau_k`, each convolved
//! with the rise `e^{-t / tau_r} / tau_r` when given). The path tracer picks one of the
//! two per vertex (re-emission with probability `p`, [`BandLuminescence::reemit_p`], the
//! other with `1 - p`, the weight divided by the probability: unbiased), before next-event
//! estimation, joins and BSDF sampling at the vertex, so every strategy there sees the
//! same lobe and the MIS weights between them keep summing to 1. A re-emitting vertex
//! adds its delay to the path's clock: `opl_m += c t`, so everything found after it
//! (its own next-event estimates, joins, emitters hit later, further vertices) arrives
//! `t` later. Light-vertex joins use the light vertex's BSDF only: a light vertex's
//! re-emission is left to the path tracer, whose next-event estimate at a re-emitting
//! vertex then takes MIS weight 1 (no other strategy finds it).
//!
//! The delay is drawn so the window is used ([`Decay::sample_for_window`]): the delays
//! are split into those that can still reach the window (after its start less the time
//! the rest of the path may take) and the earlier ones; each stratum gets its share of the
//! draws from the decay conditioned on it, weight `P_i / pi_i`. Where the decay's own
//! split gives the window at least half, the weight is 1 for every draw (nothing added
//! to the noise, and no delay is ever drawn past the window's end); where the window
//! lies in the decay's tail (a gate 50 ns after the pulse on a 4 ns lifetime) it still
//! gets half the draws, each weighing its tiny `P / 0.5`, not `e^{-12.5}` of them by
//! luck. [`DelaySampling::Splat`] (the default) deposits the decay's exact integral over
//! every later bin for the next-event estimates at the re-emitting vertex instead (zero
//! variance in the delay; `O(bins)` per contribution), and draws the delay only for the
//! path going on; docs/luminescence.md measures the two.

use super::bsdf::{Bsdf, BsdfParams};
use super::lights::Lights;
use super::sampler::Sampler;
use crate::film::TimeAxis;
use crate::scene::{Channel, Luminescence, Material};
use crate::units::C_M_PER_S;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Least share of the delays drawn among those that can reach the window
/// ([`Decay::sample_for_window`]): a gate far in the decay's tail gets half the samples,
/// and the other half (which can reach it only by longer paths) weigh at most 2.
pub const WINDOW_SHARE: f64 = 0.5;

/// Base of the hashed draws of a luminescent vertex (apart from the coverage draws'
/// keys, which stay below 2^48).
const DRAW_KEY: u64 = 1 << 52;
/// Hashed draws per luminescent vertex.
const DRAWS: u64 = 8;

/// How a re-emitting vertex's delay reaches the film.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DelaySampling {
    /// One delay per vertex drawn for the window, added to the path's clock.
    Sampled,
    /// The default: the vertex's next-event estimates deposit the decay's integral over
    /// each later bin of the film (exact in the delay); the path continues with a drawn
    /// delay, and the vertex makes no light-vertex joins. Measured 21x the efficiency of
    /// [`DelaySampling::Sampled`] on the decay alone, 70x on a late gate, 0.7x on a
    /// window dominated by the direct return (docs/luminescence.md).
    #[default]
    Splat,
}

/// One term `c e^{-x / tau}` (or `c (1 + x / tau) e^{-x / tau}`, the rise equal to the
/// lifetime) of a decay's survival function `S(x) = P(delay > x)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Term {
    c: f64,
    tau_s: f64,
    /// `(1 + x / tau) e^{-x / tau}`: a rise time equal to the lifetime (a Gamma(2)).
    gamma2: bool,
}

/// A decay, normalised to a probability density of the delay: components' weights
/// `Y_k / Y`, lifetimes, the rise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decay {
    weights: [f64; 3],
    lifetimes_s: [f64; 3],
    n: usize,
    /// 0: no rise.
    rise_s: f64,
    /// The survival function as at most 6 terms.
    terms: [Term; 6],
    n_terms: usize,
}

impl Decay {
    /// The normalised decay of `l` (components of zero yield dropped; `None` when the
    /// yield is 0).
    pub fn new(l: &Luminescence) -> Option<Decay> {
        let y: f64 = l.components.iter().map(|c| c.yield_ as f64).sum();
        if !(y > 0.0) {
            return None;
        }
        let mut d = Decay {
            weights: [0.0; 3],
            lifetimes_s: [1.0; 3],
            n: 0,
            rise_s: l.rise_s.unwrap_or(0.0),
            terms: [Term::default(); 6],
            n_terms: 0,
        };
        for c in l.components.iter().filter(|c| c.yield_ > 0.0).take(3) {
            d.weights[d.n] = c.yield_ as f64 / y;
            d.lifetimes_s[d.n] = c.lifetime_s;
            d.n += 1;
        }
        for k in 0..d.n {
            let (w, tau) = (d.weights[k], d.lifetimes_s[k]);
            let r = d.rise_s;
            let mut push = |t: Term| {
                d.terms[d.n_terms] = t;
                d.n_terms += 1;
            };
            if r <= 0.0 {
                push(Term {
                    c: w,
                    tau_s: tau,
                    gamma2: false,
                });
            } else if (tau - r).abs() <= 1e-6 * tau {
                push(Term {
                    c: w,
                    tau_s: tau,
                    gamma2: true,
                });
            } else {
                // S_k(x) = (tau e^{-x/tau} - r e^{-x/r}) / (tau - r).
                push(Term {
                    c: w * tau / (tau - r),
                    tau_s: tau,
                    gamma2: false,
                });
                push(Term {
                    c: -w * r / (tau - r),
                    tau_s: r,
                    gamma2: false,
                });
            }
        }
        Some(d)
    }

    /// The survival function `S(x) = integral_x^inf h`, 1 for `x <= 0`.
    pub fn survival(&self, x_s: f64) -> f64 {
        if !(x_s > 0.0) {
            return 1.0;
        }
        self.terms[..self.n_terms]
            .iter()
            .map(|t| {
                let e = (-x_s / t.tau_s).exp();
                if t.gamma2 {
                    t.c * (1.0 + x_s / t.tau_s) * e
                } else {
                    t.c * e
                }
            })
            .sum::<f64>()
            .max(0.0)
    }

    /// The density `h(x)`, per second (0 for `x < 0`): `-dS/dx`.
    pub fn density_per_s(&self, x_s: f64) -> f64 {
        if !(x_s >= 0.0) {
            return 0.0;
        }
        self.terms[..self.n_terms]
            .iter()
            .map(|t| {
                let e = (-x_s / t.tau_s).exp();
                if t.gamma2 {
                    t.c * x_s / (t.tau_s * t.tau_s) * e
                } else {
                    t.c / t.tau_s * e
                }
            })
            .sum::<f64>()
            .max(0.0)
    }

    /// The probability that the delay falls in `[a_s, b_s]`: `S(a) - S(b)`.
    pub fn integral(&self, a_s: f64, b_s: f64) -> f64 {
        (self.survival(a_s) - self.survival(b_s)).max(0.0)
    }

    /// Component `k`'s survival function `S_k(x)` (1 for `x <= 0`): `e^{-x/tau}`, with a
    /// rise `r` `(tau e^{-x/tau} - r e^{-x/r}) / (tau - r)` (`(1 + x/tau) e^{-x/tau}` for
    /// `r = tau`).
    fn component_survival(&self, k: usize, x_s: f64) -> f64 {
        if !(x_s > 0.0) {
            return 1.0;
        }
        let (tau, r) = (self.lifetimes_s[k], self.rise_s);
        let e = (-x_s / tau).exp();
        if r <= 0.0 {
            e
        } else if (tau - r).abs() <= 1e-6 * tau {
            (1.0 + x_s / tau) * e
        } else {
            ((tau * e - r * (-x_s / r).exp()) / (tau - r)).clamp(0.0, 1.0)
        }
    }

    /// A delay from component `k` conditioned on `[a_s, b_s]` (`b_s` may be infinite):
    /// `u` of the way through its probability there. Closed form without a rise
    /// (`a - tau ln(1 - u (1 - e^{-(b - a)/tau}))`), else bisection on `S_k`.
    fn component_in(&self, k: usize, a_s: f64, b_s: f64, u: f64) -> f64 {
        let tau = self.lifetimes_s[k];
        if self.rise_s <= 0.0 {
            let span = -(-(b_s - a_s) / tau).exp_m1(); // 1 for an infinite b
            return a_s - tau * (-u * span).ln_1p();
        }
        let (sa, sb) = (
            self.component_survival(k, a_s),
            if b_s.is_finite() {
                self.component_survival(k, b_s)
            } else {
                0.0
            },
        );
        let target = sa - u * (sa - sb);
        let mut lo = a_s;
        let mut hi = if b_s.is_finite() {
            b_s
        } else {
            a_s.max(0.0) + 60.0 * tau.max(self.rise_s)
        };
        for _ in 0..64 {
            let mid = 0.5 * (lo + hi);
            if self.component_survival(k, mid) > target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// A delay from the decay conditioned on `[a_s, b_s]`, `u` two uniform numbers (the
    /// component by its probability there, then within it), or `None` when the decay
    /// puts nothing there.
    fn sample_in(&self, a_s: f64, b_s: f64, u: [f64; 2]) -> Option<f64> {
        let p = |k: usize| {
            let sb = if b_s.is_finite() {
                self.component_survival(k, b_s)
            } else {
                0.0
            };
            self.weights[k] * (self.component_survival(k, a_s) - sb).max(0.0)
        };
        let total: f64 = (0..self.n).map(p).sum();
        if !(total > 0.0) {
            return None;
        }
        let mut acc = 0.0;
        let mut k = self.n - 1;
        for j in 0..self.n {
            acc += p(j) / total;
            if u[0] < acc {
                k = j;
                break;
            }
        }
        Some(self.component_in(k, a_s, b_s, u[1]).clamp(a_s, b_s))
    }

    /// A delay drawn so the window is used, with its weight `h / q`: the delays split
    /// at `lo` into the ones that can reach the window, `[lo, hi]`, and the earlier
    /// `[0, lo)`; a stratum is drawn with probability `pi_i` and the delay from the decay
    /// conditioned on it, weight `P_i / pi_i` (`P_i` the decay's probability there). `pi`
    /// is the decay's own split (weight 1: no noise added) unless that gives the window
    /// less than [`WINDOW_SHARE`]; delays after `hi` land past the window and are never
    /// drawn. `u`: three uniform numbers. `None` when the decay puts nothing before `hi`.
    pub fn sample_for_window(&self, lo_s: f64, hi_s: f64, u: [f64; 3]) -> Option<(f64, f64)> {
        let lo = lo_s.clamp(0.0, hi_s.max(0.0));
        let s_hi = if hi_s.is_finite() {
            self.survival(hi_s)
        } else {
            0.0
        };
        let p_late = (self.survival(lo) - s_hi).max(0.0);
        let p_early = 1.0 - self.survival(lo);
        let total = p_late + p_early;
        if !(total > 0.0) {
            return None;
        }
        let pi_late = if p_early > 0.0 {
            (p_late / total).max(WINDOW_SHARE)
        } else {
            1.0
        };
        if u[0] < pi_late {
            let t = self.sample_in(lo, hi_s, [u[1], u[2]])?;
            Some((t, p_late / pi_late))
        } else {
            let t = self.sample_in(0.0, lo, [u[1], u[2]])?;
            Some((t, p_early / (1.0 - pi_late)))
        }
    }

    /// Deposit `value` re-emitted at `arrival_s` over the bins of `axis`: `put(t, w)` with
    /// `t` a bin's centre and `w = value x` the probability that the delay lands the light
    /// in that bin (the decay's integral over the bin). Bins are visited from the one
    /// holding `arrival_s` (the first, for an arrival before the window) to the last
    /// or until the decay has underflowed to 0. The exponentials are stepped bin to bin
    /// (`e^{-(x + dt)/tau} = e^{-x/tau} e^{-dt/tau}`), each bin's share as
    /// `e^{-x/tau} (1 - e^{-dt/tau})` (no cancellation for `dt << tau`).
    pub fn splat(
        &self,
        axis: &TimeAxis,
        arrival_s: f64,
        value: f64,
        mut put: impl FnMut(f64, f64),
    ) {
        if !(arrival_s.is_finite() && arrival_s < axis.end_s()) {
            return;
        }
        let first = if arrival_s < axis.t0_s {
            0
        } else {
            match axis.bin_of(arrival_s) {
                Some(b) => b,
                None => return,
            }
        };
        let dt = axis.dt_s;
        // The first bin: from the arrival (or the window's start) to its end.
        let lo0 = axis.t0_s + first as f64 * dt;
        let x_end0 = lo0 + dt - arrival_s;
        let w0 = self.integral(lo0 - arrival_s, x_end0);
        if w0 > 0.0 {
            put(axis.bin_center_s(first), value * w0);
        }
        // The rest: x runs over the bins' starts measured from the arrival.
        let n = self.n_terms;
        let mut e = [0.0f64; 6];
        let mut step = [0.0f64; 6];
        let mut one_minus = [0.0f64; 6];
        for i in 0..n {
            let t = &self.terms[i];
            e[i] = (-x_end0 / t.tau_s).exp();
            step[i] = (-dt / t.tau_s).exp();
            one_minus[i] = -(-dt / t.tau_s).exp_m1();
        }
        let mut x = x_end0;
        for b in first + 1..axis.bins {
            let mut w = 0.0;
            let mut alive = false;
            for i in 0..n {
                let t = &self.terms[i];
                if e[i] > 0.0 {
                    alive = true;
                }
                w += if t.gamma2 {
                    // S(x) - S(x + dt) for (1 + x/tau) e^{-x/tau}.
                    t.c * e[i] * ((1.0 + x / t.tau_s) * one_minus[i] - dt / t.tau_s * step[i])
                } else {
                    t.c * e[i] * one_minus[i]
                };
                e[i] *= step[i];
            }
            if !alive {
                break;
            }
            if w > 0.0 {
                put(axis.bin_center_s(b), value * w);
            }
            x += dt;
        }
    }
}

/// A luminescent material in the rendered band.
#[derive(Clone, Copy, Debug)]
pub struct BandLuminescence {
    pub decay: Decay,
    /// The band's yield: `Y` times the emission colour's share of the band.
    pub yield_band: f32,
    /// Probability of re-emission at a vertex: `Y / (Y + R)`, `R` the band's base colour
    /// (plus 0.04 of a dielectric's specular reflectance), at least 0.05; 1 when the
    /// surface reflects nothing.
    pub reemit_p: f32,
    /// The re-emission lobe: Lambertian of albedo `yield_band`.
    pub bsdf: Bsdf,
}

impl BandLuminescence {
    /// `m`'s luminescence in band `channel` (`None`: none, or none in this band).
    pub fn new(m: &Material, channel: Channel) -> Option<BandLuminescence> {
        let l = m.luminescence.as_ref()?;
        let decay = Decay::new(l)?;
        let yield_band = (l.yield_total() * channel.pick(l.emission_color)).clamp(0.0, 1.0);
        if !(yield_band > 0.0) {
            return None;
        }
        let base = channel
            .pick([m.base_color[0], m.base_color[1], m.base_color[2]])
            .clamp(0.0, 1.0);
        let reflect = base + 0.04 * m.specular_factor.clamp(0.0, 1.0) + m.metallic.clamp(0.0, 1.0);
        let reemit_p = if reflect > 0.0 || m.transmission > 0.0 {
            (yield_band / (yield_band + reflect)).clamp(0.05, 0.95)
        } else {
            1.0
        };
        let params = BsdfParams {
            base: yield_band,
            metallic: 0.0,
            roughness: 1.0,
            specular_factor: 0.0,
            specular_color: 0.0,
            transmission: 0.0,
            ior: 1.5,
        };
        Some(BandLuminescence {
            decay,
            yield_band,
            reemit_p,
            bsdf: Bsdf::new(&params, 1.0),
        })
    }
}

/// What a luminescent vertex does.
#[derive(Clone, Copy, Debug)]
pub(super) enum Choice<'a> {
    /// Reflects by its BSDF; the path's weight is multiplied by `weight` (`1 / (1 - p)`).
    Reflect { weight: f32 },
    /// Re-emits by `bsdf` (Lambertian, albedo the yield), the weight multiplied by
    /// `weight` (`1 / p`) and by the delay's `delay_weight` (`h / q`), arriving
    /// `delay_opl_m / c` later. `decay` for a splat.
    Reemit {
        bsdf: &'a Bsdf,
        weight: f32,
        delay_weight: f64,
        delay_opl_m: f64,
        decay: &'a Decay,
    },
    /// Re-emits, but every delay the mixture could draw here lands after the window:
    /// nothing after this vertex can count. The path ends.
    Late,
}

/// The `j`-th hashed uniform number of the luminescent vertex after `scatterings` events,
/// 48 bits (two 24-bit draws).
fn draw(rng: &Sampler, scatterings: u32, j: u64) -> f64 {
    let key = DRAW_KEY + (scatterings as u64) * DRAWS * 2 + 2 * j;
    let hi = rng.get1_hashed(key) as f64;
    let lo = rng.get1_hashed(key + 1) as f64;
    (hi + lo * (1.0 / 16_777_216.0)).min(1.0 - f64::EPSILON)
}

/// The least time light takes from `p` to the eye side's vertex from any light: the
/// nearest pulsed punctual light's distance over c (every path from `p` to a light is at
/// least that long); 0 with emissive surfaces, which may lie anywhere.
pub(super) fn nearest_light_s(lights: &Lights, p: Vec3) -> f64 {
    if lights.has_emitters() {
        return 0.0;
    }
    let d = lights
        .punctual
        .iter()
        .map(|l| (l.position - p).length())
        .fold(f32::INFINITY, f32::min);
    if d.is_finite() {
        d as f64 / C_M_PER_S
    } else {
        0.0
    }
}

/// Choose reflection or re-emission at a vertex of material `lum` met after
/// `scatterings` events at optical length `opl_m`, the window being
/// `[window_start_s, window_end_s]` (the sink's); a
/// re-emission's delay is drawn by [`Decay::sample_for_window`], the window's reach being
/// the delays that land the light in the window by the shortest way on,
/// `min_rest_s` ([`nearest_light_s`]): none after it can arrive in time, the ones before
/// only by longer paths. Draws hashed numbers keyed by the vertex (none at a vertex that
/// is not luminescent, so other scenes render bit for bit as before).
pub(super) fn choose<'a>(
    lum: &'a BandLuminescence,
    opl_m: f64,
    min_rest_s: f64,
    scatterings: u32,
    rng: &Sampler,
    window_start_s: f64,
    window_end_s: f64,
) -> Choice<'a> {
    let p = lum.reemit_p;
    if p < 1.0 && draw(rng, scatterings, 0) >= p as f64 {
        return Choice::Reflect {
            weight: 1.0 / (1.0 - p),
        };
    }
    let now_s = opl_m / C_M_PER_S + min_rest_s;
    let lo = window_start_s - now_s;
    let hi = window_end_s - now_s;
    if !(hi > 0.0) {
        return Choice::Late;
    }
    let u = [1, 2, 3].map(|j| draw(rng, scatterings, j));
    let Some((delay_s, w)) = lum.decay.sample_for_window(lo, hi, u) else {
        return Choice::Late;
    };
    if delay_s > hi || !(w > 0.0) {
        return Choice::Late;
    }
    Choice::Reemit {
        bsdf: &lum.bsdf,
        weight: 1.0 / p,
        delay_weight: w,
        delay_opl_m: delay_s * C_M_PER_S,
        decay: &lum.decay,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::DecayComponent;

    fn lum(components: &[(f32, f64)], rise_s: Option<f64>) -> Luminescence {
        Luminescence {
            components: components
                .iter()
                .map(|&(yield_, lifetime_s)| DecayComponent { yield_, lifetime_s })
                .collect(),
            rise_s,
            emission_color: [1.0; 3],
        }
    }

    /// Numerical integral of the density by the midpoint rule.
    fn integrate(d: &Decay, a: f64, b: f64, n: usize) -> f64 {
        let h = (b - a) / n as f64;
        (0..n)
            .map(|i| d.density_per_s(a + (i as f64 + 0.5) * h) * h)
            .sum()
    }

    #[test]
    fn survival_is_the_densitys_tail_with_and_without_a_rise() {
        for l in [
            lum(&[(0.4, 4e-9)], None),
            lum(&[(0.1, 1e-9), (0.3, 4e-9)], None),
            lum(&[(0.2, 2e-9)], Some(5e-10)),
            lum(&[(0.2, 2e-9)], Some(2e-9)),
        ] {
            let d = Decay::new(&l).unwrap();
            assert!((d.survival(0.0) - 1.0).abs() < 1e-12);
            for &(a, b) in &[(0.0, 1e-9), (1e-9, 5e-9), (3e-9, 4e-8)] {
                let num = integrate(&d, a, b, 20_000);
                assert!((d.integral(a, b) - num).abs() < 1e-7, "{l:?} [{a}, {b}]");
            }
        }
        // Two lifetimes by hand: S(x) = 0.25 e^{-x/1ns} + 0.75 e^{-x/4ns}.
        let d = Decay::new(&lum(&[(0.1, 1e-9), (0.3, 4e-9)], None)).unwrap();
        let x = 3e-9;
        let want = 0.25 * (-3.0f64).exp() + 0.75 * (-0.75f64).exp();
        // (The yields are f32: 0.1 / 0.4 is 0.25 to 1e-8.)
        assert!((d.survival(x) - want).abs() < 1e-7);
    }

    #[test]
    fn window_draws_are_unbiased_and_fill_a_late_window() {
        // E[w g(t)] = integral g h for g the indicator of a bin, on a 4 ns lifetime and
        // with a rise, the window's reach [40, 60] ns: bins in the window and before it.
        // The draws are a regular grid (deterministic).
        for l in [
            lum(&[(0.4, 4e-9)], None),
            lum(&[(0.1, 1e-9), (0.3, 4e-9)], Some(5e-10)),
        ] {
            let d = Decay::new(&l).unwrap();
            let (lo, hi) = (40e-9, 60e-9);
            let n = 400_000;
            let bins = [(2e-9, 3e-9), (50e-9, 52e-9), (58e-9, 60e-9)];
            let mut sums = [0.0; 3];
            let mut inside = 0usize;
            for i in 0..n {
                let f = (i as f64 + 0.5) / n as f64;
                let u = [
                    (f * 2.0).fract(),
                    (f * 7919.0).fract(),
                    (f * 104_729.0).fract(),
                ];
                let (t, w) = d.sample_for_window(lo, hi, u).unwrap();
                assert!(t >= 0.0 && t <= hi, "{t}");
                inside += usize::from(t >= lo);
                for (s, &(a, b)) in sums.iter_mut().zip(&bins) {
                    if t >= a && t < b {
                        *s += w;
                    }
                }
            }
            for (s, &(a, b)) in sums.iter().zip(&bins) {
                let want = d.integral(a, b);
                let got = s / n as f64;
                assert!(
                    (got / want - 1.0).abs() < 0.01,
                    "{l:?} [{a}, {b}]: {got} vs {want}"
                );
            }
            // Half the draws reach the window, where the decay itself puts e^{-10}.
            assert!(inside as f64 >= 0.49 * n as f64, "{inside}");
        }
        // A window holding the whole decay: every draw weighs the same (no noise added).
        let d = Decay::new(&lum(&[(0.4, 1e-9)], None)).unwrap();
        let w0 = d.sample_for_window(0.0, 200e-9, [0.3, 0.5, 0.7]).unwrap().1;
        for u in [[0.1, 0.2, 0.9], [0.9, 0.99, 0.01]] {
            assert_eq!(d.sample_for_window(0.0, 200e-9, u).unwrap().1, w0);
        }
    }

    #[test]
    fn splat_deposits_each_bins_integral() {
        let d = Decay::new(&lum(&[(0.1, 1e-9), (0.3, 4e-9)], Some(3e-10))).unwrap();
        let axis = TimeAxis::new(1e-9, 1e-10, 300).unwrap();
        for arrival in [0.2e-9, 1.234e-9, 5e-9] {
            let mut got = vec![0.0; 300];
            d.splat(&axis, arrival, 2.0, |t, w| {
                got[axis.bin_of(t).unwrap()] += w;
            });
            for (b, &g) in got.iter().enumerate() {
                let lo = axis.t0_s + b as f64 * axis.dt_s;
                let want = 2.0 * d.integral(lo - arrival, lo + axis.dt_s - arrival);
                assert!(
                    (g - want).abs() < 1e-12,
                    "arrival {arrival} bin {b}: {g} vs {want}"
                );
            }
        }
    }
}

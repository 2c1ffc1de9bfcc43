//! The SPAD's expected histogram, exact for the detector model of [`super`]:
//!
//! - bins `n = 0, 1, ...` run through the cycles (`n mod B` is the TDC bin); the events
//!   of bin `n` are Poisson with mean `r_{n mod B}`, spread uniformly in time over the
//!   bin (the rate is constant within a bin), independent between bins;
//! - an armed SPAD detects in bin `n` when at least one event falls in it:
//!   probability `1 - exp(-r)`, or `1 - exp(-r - mu)` while a trap is filled (its
//!   release is one more event, of rate `mu = w / afterpulse_delay_s` per bin);
//! - a detection is time-stamped by its TDC bin: the dead time `tau` runs from the end
//!   of the bin of the detection (the SPAD is dead for the rest of that bin, as the
//!   TDC takes one stamp a bin). With `tau / w = d + f` (`d` whole bins, `0 <= f < 1`)
//!   it is dead through bin `n + d` and re-arms at the fraction `f` of bin
//!   `n + d + 1`, armed for the last `1 - f` of it: there the chance of an event is
//!   `1 - exp(-(1 - f) r)`. The detection fills the trap with probability `p`, which
//!   survives the dead time with probability `exp(-mu (d + f))`.
//!
//! With `E_n`, `F_n` the probabilities of being armed from the start of bin `n` with the
//! trap empty, filled, and `G_n`, `H_n` of re-arming at the fraction `f` of bin `n` with
//! the trap empty, filled (`a = 1 - f`, `q = p e^-(mu (d + f))`), the detection
//! probability and the next state are
//!
//! ```text
//! D_n     = E_n (1 - e^-r_n) + F_n (1 - e^-(r_n + mu))
//!         + G_n (1 - e^-(a r_n)) + H_n (1 - e^-(a (r_n + mu)))
//! E_{n+1} = E_n e^-r_n + G_n e^-(a r_n)
//! F_{n+1} = F_n e^-(r_n + mu) + H_n e^-(a (r_n + mu))
//! G_{n+1} = D_{n-d} (1 - q),   H_{n+1} = D_{n-d} q
//! ```
//!
//! For a whole number of bins (`f = 0`) the re-armed states are armed from the start,
//! `G, H` fold into `E, F` and this is the recursion of whole bins (bit for bit: no
//! partly armed factors are computed). This treats the fraction exactly, at the cost
//! of the whole-bin recursion (two more products a bin), with no finer grid: the
//! fraction enters only through the partly armed bin.
//!
//! Its one approximation of a real SPAD is where the dead time starts: the avalanche is
//! somewhere in its bin and a real SPAD is dead for `tau` from it, where this model
//! starts `tau` at the bin's end (it is dead 0 to 1 bin longer). Kept on purpose: the
//! exact photon-start model carries the re-arming time within a bin as a continuous
//! variable (the first arrival in a bin of constant rate is a truncated exponential,
//! so the re-arming phase after it is spread over the bin), which needs a sub-bin grid
//! of `S` steps and `S` times this recursion's cost; the window recomputes this
//! recursion after every edit. How far it lands, measured against a photon-start
//! simulation in `crates/tprf-core/tests/integration/spad.rs`
//! (`dead_time_from_the_photon_against_the_model`):
//! the same histogram when the dead time is a whole cycle (first photon only); within
//! the simulation's noise (about 2 % a bin, 0.5 % in total) for weak returns and long
//! dead times (the `builtin:spad` regime); for strong returns (2.5 events a bin) and
//! dead times of 1-2.5 bins, 8-15 % fewer detections in total and up to 15-30 % off in
//! a bin. Always, the model at `tau` counts at most the real SPAD's total and the model
//! at `tau - w` at least; `dead_time_s = tau - w / 2` brings the totals within 3 % in
//! the strong cases (not every bin).
//!
//! Synchronous acquisition starts every cycle from `E_0 = 1` (and drops re-armings past
//! its end): the histogram is `N D_k`. With `d >= B - 1` and no trap it is the
//! first-photon formula `N (1 - e^-r_k) exp(-sum_{j<k} r_j)`. Free-running acquisition
//! carries the state across cycles from a cold start; the histogram is the sum of the
//! `N` cycles' `D`, iterated until a cycle repeats the previous one (to 1e-13), the
//! rest taken as that cycle (see [`Detector::expected`]).

use super::{Acquisition, Spad};
use crate::sensor::SensorError;

/// Events per bin and cycle above which a bin is certain to fire (`e^-1000 = 0` in
/// f64): rates are clamped here so that sums stay finite.
pub const RATE_CAP: f64 = 1000.0;

/// Free-running cycles iterated at most per pixel; a pixel still changing then (a
/// detector locked to a period of several cycles by a saturating background) takes the
/// mean of the last half for the remaining cycles.
pub const MAX_ITERATED_CYCLES: u64 = 256;

/// The SPAD compiled for a TDC of `bins` bins of `bin_width_s`.
#[derive(Clone, Debug, PartialEq)]
pub struct Detector {
    pub bins: usize,
    pub bin_width_s: f64,
    pub cycles: u64,
    pub mode: Acquisition,
    /// Whole bins dead after the bin of a detection, `d = floor(dead_time_s / w)`.
    pub dead_bins: usize,
    /// The fraction of bin `d + 1` after a detection the SPAD is still dead for, `f` in
    /// `[0, 1)`: `dead_time_s / w = d + f` (a ratio within 1e-9 of a whole number is
    /// taken as that number).
    pub dead_fraction: f64,
    /// Trap release events per bin while filled, `mu` (0: no afterpulsing).
    pub trap_rate: f64,
    /// Probability that the trap is filled when the detector re-arms, `p e^-(mu d)`.
    pub trap_at_rearm: f64,
}

/// How a realisation was drawn (recorded with it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampler {
    /// Cycles with a detection drawn as a multinomial: exact when at most one
    /// detection fits in a cycle (synchronous, dead time of a whole cycle).
    Multinomial,
    /// Every detection drawn in turn, cycle by cycle: exact for any setting.
    Events,
    /// Each bin drawn alone from its exact marginal, Binomial(N, D_k): used when the
    /// image would need more than [`super::sample::MAX_EVENTS`] detections; the
    /// correlation between bins of one cycle is lost.
    Marginals,
}

impl Sampler {
    pub fn name(self) -> &'static str {
        match self {
            Sampler::Multinomial => "multinomial (exact)",
            Sampler::Events => "event by event (exact)",
            Sampler::Marginals => {
                "per-bin binomial marginals (exact means and variances, correlations \
                 between bins dropped)"
            }
        }
    }
}

impl Detector {
    /// Checks `spad` against the TDC and compiles it.
    pub fn new(spad: &Spad, bins: usize, bin_width_s: f64) -> Result<Detector, SensorError> {
        if bins == 0 || !(bin_width_s > 0.0 && bin_width_s.is_finite()) {
            return Err(SensorError::Invalid(format!(
                "a SPAD needs TDC bins: {bins} bins of {bin_width_s:e} s"
            )));
        }
        let dead = spad.dead_time_s / bin_width_s;
        if !(dead.is_finite() && dead >= 0.0) || dead.round() > bins as f64 {
            return Err(SensorError::Invalid(format!(
                "spad.dead_time_s = {:e} s is {dead} TDC bins: at most one cycle ({bins} bins)",
                spad.dead_time_s
            )));
        }
        // A ratio within round-off of a whole number of bins is that number (7e-10 s /
        // 1e-10 s is 6.999999999999999).
        let dead = if (dead - dead.round()).abs() <= 1e-9 * dead.max(1.0) {
            dead.round()
        } else {
            dead
        };
        let dead_bins = dead.floor() as usize;
        let dead_fraction = if dead_bins >= bins {
            0.0
        } else {
            dead - dead_bins as f64
        };
        let trap_rate = if spad.afterpulse_probability > 0.0 {
            bin_width_s / spad.afterpulse_delay_s
        } else {
            0.0
        };
        // Filled at the detection, the trap must survive the d + f dead bins (a release
        // while dead is lost).
        let trap_at_rearm =
            spad.afterpulse_probability * (-trap_rate * (dead_bins as f64 + dead_fraction)).exp();
        Ok(Detector {
            bins,
            bin_width_s,
            cycles: spad.cycles,
            mode: spad.mode,
            dead_bins,
            dead_fraction,
            trap_rate,
            trap_at_rearm,
        })
    }

    /// The laser cycle `B w`, seconds.
    pub fn cycle_s(&self) -> f64 {
        self.bins as f64 * self.bin_width_s
    }

    /// The dead time in TDC bins, `d + f`.
    pub fn dead_bins_f64(&self) -> f64 {
        self.dead_bins as f64 + self.dead_fraction
    }

    /// The part of a bin the SPAD is armed for when it re-arms inside it, `1 - f` (1 for
    /// a whole number of dead bins: it re-arms at the bin's start).
    pub fn rearmed_part(&self) -> f64 {
        1.0 - self.dead_fraction
    }

    /// At most one detection fits in a cycle: synchronous with `d >= B - 1` (the
    /// re-arming bin `k + d + 1` is past the cycle's end for every `k`).
    pub fn first_photon_only(&self) -> bool {
        self.mode == Acquisition::Synchronous && self.dead_bins + 1 >= self.bins
    }

    /// The expected counts over all `N` cycles in each TDC bin, for the mean events per
    /// cycle `rates` (`B` values, clamped to [`RATE_CAP`]), into `out` (`B` values).
    pub fn expected(&self, rates: &[f64], out: &mut [f64]) {
        self.expected_with(rates, out, &mut ExpectedScratch::default());
    }

    /// [`Self::expected`] with its working memory in `scratch`, kept between pixels (an
    /// image calls it once a pixel: no allocation after the first).
    pub fn expected_with(&self, rates: &[f64], out: &mut [f64], scratch: &mut ExpectedScratch) {
        let b = self.bins.min(rates.len()).min(out.len());
        let ExpectedScratch {
            state,
            cycle,
            factors,
            partial,
            previous,
            late_sum,
        } = scratch;
        state.init(self.dead_bins);
        cycle.clear();
        cycle.resize(b, 0.0);
        factors.clear();
        partial.clear();
        factors_by_run(&rates[..b], factors, |r| BinFactors::new(r, self.trap_rate));
        // The partly armed bin after a fractional dead time: the same with the means
        // times `1 - f` (none for whole bins).
        if self.dead_fraction > 0.0 {
            let a = self.rearmed_part();
            factors_by_run(&rates[..b], partial, |r| {
                let rc = if r > 0.0 { r.min(RATE_CAP) } else { 0.0 };
                BinFactors::new(a * rc, a * self.trap_rate)
            });
        }
        match self.mode {
            Acquisition::Synchronous => {
                self.run_cycle(factors, partial, state, cycle);
                let n = self.cycles as f64;
                for (o, d) in out.iter_mut().zip(cycle.iter()) {
                    *o = n * d;
                }
            }
            Acquisition::FreeRunning => {
                out[..b].fill(0.0);
                previous.clear();
                previous.resize(b, 0.0);
                late_sum.clear();
                late_sum.resize(b, 0.0);
                let half = MAX_ITERATED_CYCLES / 2;
                let mut done = 0u64;
                while done < self.cycles {
                    self.run_cycle(factors, partial, state, cycle);
                    done += 1;
                    for (o, d) in out.iter_mut().zip(cycle.iter()) {
                        *o += d;
                    }
                    if done > half {
                        for (s, d) in late_sum.iter_mut().zip(cycle.iter()) {
                            *s += d;
                        }
                    }
                    let total: f64 = cycle.iter().sum();
                    let change = cycle
                        .iter()
                        .zip(previous.iter())
                        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                    let rest = (self.cycles - done) as f64;
                    if done > 1 && change <= 1e-13 * total.max(f64::MIN_POSITIVE) {
                        for (o, d) in out.iter_mut().zip(cycle.iter()) {
                            *o += rest * d;
                        }
                        break;
                    }
                    if done == MAX_ITERATED_CYCLES {
                        let k = (done - half) as f64;
                        for (o, s) in out.iter_mut().zip(late_sum.iter()) {
                            *o += rest * s / k;
                        }
                        break;
                    }
                    std::mem::swap(previous, cycle);
                }
            }
        }
    }

    /// The detection probabilities of one cycle (`D_k` into `cycle`), from `state`
    /// (reset first in synchronous mode), leaving the state at the cycle's end.
    /// `bins` holds each bin's factors, computed once per pixel ([`BinFactors`]), and
    /// `partial` those of the partly armed bin after a fractional dead time (empty for
    /// a whole number of bins).
    fn run_cycle(
        &self,
        bins: &[BinFactors],
        partial: &[BinFactors],
        state: &mut State,
        cycle: &mut [f64],
    ) {
        if self.mode == Acquisition::Synchronous {
            state.reset();
        }
        let p = self.trap_at_rearm;
        if !partial.is_empty() {
            for ((d_out, f), g) in cycle.iter_mut().zip(bins).zip(partial) {
                let det = state.armed_empty * f.fire_e
                    + state.armed_trap * f.fire_f
                    + state.rearm_empty * g.fire_e
                    + state.rearm_trap * g.fire_f;
                *d_out = det;
                let rearm = state.push(det);
                state.armed_empty = state.armed_empty * f.keep_e + state.rearm_empty * g.keep_e;
                state.armed_trap = state.armed_trap * f.keep_f + state.rearm_trap * g.keep_f;
                state.rearm_empty = rearm * (1.0 - p);
                state.rearm_trap = rearm * p;
            }
            return;
        }
        for (d_out, f) in cycle.iter_mut().zip(bins) {
            let det = state.armed_empty * f.fire_e + state.armed_trap * f.fire_f;
            *d_out = det;
            let rearm = state.push(det);
            state.armed_empty = state.armed_empty * f.keep_e + rearm * (1.0 - p);
            state.armed_trap = state.armed_trap * f.keep_f + rearm * p;
        }
    }
}

/// One bin's factors in the recursion: the chances that an armed SPAD stays quiet
/// (`e^-r`, `e^-(r + mu)`) or fires (`1 - e^-r`, `1 - e^-(r + mu)`) with the trap
/// empty or filled, the rate clamped to [`RATE_CAP`].
#[derive(Clone, Copy, Debug)]
struct BinFactors {
    keep_e: f64,
    keep_f: f64,
    fire_e: f64,
    fire_f: f64,
}

impl BinFactors {
    fn new(r: f64, mu: f64) -> BinFactors {
        let r = if r > 0.0 { r.min(RATE_CAP) } else { 0.0 };
        let (keep_e, fire_e) = keep_fire(r);
        if mu == 0.0 {
            // No afterpulsing: the filled trap's factors are the empty one's (r + 0 is
            // r).
            return BinFactors {
                keep_e,
                keep_f: keep_e,
                fire_e,
                fire_f: fire_e,
            };
        }
        let (keep_f, fire_f) = keep_fire(r + mu);
        BinFactors {
            keep_e,
            keep_f,
            fire_e,
            fire_f,
        }
    }
}

/// `factor(r)` of each rate into `out`, computed once a run: a run of bins of the same
/// rate (the background between returns, most of a histogram) shares one computation.
fn factors_by_run(rates: &[f64], out: &mut Vec<BinFactors>, factor: impl Fn(f64) -> BinFactors) {
    let mut last: Option<(f64, BinFactors)> = None;
    out.extend(rates.iter().map(|&r| match last {
        Some((lr, f)) if lr.to_bits() == r.to_bits() => f,
        _ => {
            let f = factor(r);
            last = Some((r, f));
            f
        }
    }));
}

/// `(e^-x, 1 - e^-x)` for `x >= 0` with one transcendental call, each to a relative
/// error of a few ulps: the smaller of the two is computed (`-expm1(-x)` below
/// `ln 2`, `exp(-x)` above) and the other is 1 minus it, which is at least 1/2 and so
/// loses nothing to the subtraction.
fn keep_fire(x: f64) -> (f64, f64) {
    if x < std::f64::consts::LN_2 {
        let fire = -(-x).exp_m1();
        (1.0 - fire, fire)
    } else {
        let keep = (-x).exp();
        (keep, 1.0 - keep)
    }
}

/// Working memory of [`Detector::expected_with`], reused from pixel to pixel.
#[derive(Default)]
pub struct ExpectedScratch {
    state: State,
    cycle: Vec<f64>,
    factors: Vec<BinFactors>,
    partial: Vec<BinFactors>,
    previous: Vec<f64>,
    late_sum: Vec<f64>,
}

/// The detector's state between bins: armed from the bin's start with the trap empty or
/// filled (`E`, `F`), re-arming at the fraction `f` of the bin (`G`, `H`; 0 for whole
/// bins), and the detection probabilities of the last `d + 1` bins (each re-arms
/// `d + 1` bins later).
#[derive(Default)]
struct State {
    armed_empty: f64,
    armed_trap: f64,
    rearm_empty: f64,
    rearm_trap: f64,
    ring: Vec<f64>,
    at: usize,
}

impl State {
    /// Armed, trap empty, nothing detected, for `dead_bins` whole dead bins.
    fn init(&mut self, dead_bins: usize) {
        self.ring.clear();
        self.ring.resize(dead_bins + 1, 0.0);
        self.reset();
    }

    fn reset(&mut self) {
        self.armed_empty = 1.0;
        self.armed_trap = 0.0;
        self.rearm_empty = 0.0;
        self.rearm_trap = 0.0;
        self.ring.fill(0.0);
        self.at = 0;
    }

    /// Records this bin's detection probability `D_n` and returns `D_{n-d}`, the
    /// detections that re-arm at bin `n + 1`.
    fn push(&mut self, det: f64) -> f64 {
        self.ring[self.at] = det;
        self.at += 1;
        if self.at == self.ring.len() {
            self.at = 0;
        }
        // The slot after the one written holds D_{n-d} (for d = 0, the one written).
        self.ring[self.at]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn detector(mode: Acquisition, dead_bins: usize, bins: usize) -> Detector {
        Detector {
            bins,
            bin_width_s: 1e-10,
            cycles: 10,
            mode,
            dead_bins,
            dead_fraction: 0.0,
            trap_rate: 0.0,
            trap_at_rearm: 0.0,
        }
    }

    #[test]
    fn first_photon_formula_when_dead_for_the_cycle() {
        let rates: Vec<f64> = (0..16).map(|k| 0.05 * k as f64).collect();
        let d = detector(Acquisition::Synchronous, 15, 16);
        let mut out = vec![0.0; 16];
        d.expected(&rates, &mut out);
        let mut before = 0.0f64;
        for (k, &r) in rates.iter().enumerate() {
            let want = 10.0 * (1.0 - (-r).exp()) * (-before).exp();
            assert!((out[k] - want).abs() < 1e-12, "{k}");
            before += r;
        }
    }

    #[test]
    fn no_dead_time_no_pile_up() {
        // d = 0: each bin fires with 1 - e^-r, whatever happened before.
        let rates = [0.3, 2.0, 0.0, 5.0, 0.1];
        for mode in [Acquisition::Synchronous, Acquisition::FreeRunning] {
            let d = detector(mode, 0, 5);
            let mut out = vec![0.0; 5];
            d.expected(&rates, &mut out);
            for (o, r) in out.iter().zip(rates) {
                assert!((o - 10.0 * (1.0 - (-r).exp())).abs() < 1e-12);
            }
        }
    }
}

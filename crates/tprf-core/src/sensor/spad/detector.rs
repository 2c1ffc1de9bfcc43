//! The SPAD's expected histogram, exact for the detector model of [`super`]:
//!
//! - bins `n = 0, 1, ...` run through the cycles (`n mod B` is the TDC bin); the events
//!   of bin `n` are Poisson with mean `r_{n mod B}`, independent between bins;
//! - an armed SPAD detects in bin `n` when at least one event falls in it:
//!   probability `1 - exp(-r)`, or `1 - exp(-r - mu)` while a trap is filled (its
//!   release is one more event, of rate `mu = w / afterpulse_delay_s` per bin);
//! - after a detection in bin `n` it is dead through bin `n + d` and armed again at
//!   `n + d + 1`; the detection fills the trap with probability `p`, which survives the
//!   `d` dead bins with probability `exp(-mu d)`.
//!
//! With `E_n`, `F_n` the probabilities of being armed at bin `n` with the trap empty,
//! filled, the detection probability and the next state are
//!
//! ```text
//! D_n     = E_n (1 - e^-r_n) + F_n (1 - e^-(r_n + mu))
//! E_{n+1} = E_n e^-r_n        + D_{n-d} (1 - p e^-(mu d))
//! F_{n+1} = F_n e^-(r_n + mu) + D_{n-d} p e^-(mu d)
//! ```
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
    /// Whole bins dead after the bin of a detection, `d`.
    pub dead_bins: usize,
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
        let dead_bins = dead.round() as usize;
        let trap_rate = if spad.afterpulse_probability > 0.0 {
            bin_width_s / spad.afterpulse_delay_s
        } else {
            0.0
        };
        // Filled at the detection, the trap must survive the d dead bins (a release
        // while dead is lost).
        let trap_at_rearm = spad.afterpulse_probability * (-trap_rate * dead_bins as f64).exp();
        Ok(Detector {
            bins,
            bin_width_s,
            cycles: spad.cycles,
            mode: spad.mode,
            dead_bins,
            trap_rate,
            trap_at_rearm,
        })
    }

    /// The laser cycle `B w`, seconds.
    pub fn cycle_s(&self) -> f64 {
        self.bins as f64 * self.bin_width_s
    }

    /// At most one detection fits in a cycle: synchronous with `d >= B - 1`.
    pub fn first_photon_only(&self) -> bool {
        self.mode == Acquisition::Synchronous && self.dead_bins + 1 >= self.bins
    }

    /// The expected counts over all `N` cycles in each TDC bin, for the mean events per
    /// cycle `rates` (`B` values, clamped to [`RATE_CAP`]), into `out` (`B` values).
    pub fn expected(&self, rates: &[f64], out: &mut [f64]) {
        let b = self.bins.min(rates.len()).min(out.len());
        let mut state = State::new(self.dead_bins);
        let mut cycle = vec![0.0; b];
        let factors: Vec<BinFactors> = rates[..b]
            .iter()
            .map(|&r| BinFactors::new(r, self.trap_rate))
            .collect();
        match self.mode {
            Acquisition::Synchronous => {
                self.run_cycle(&factors, &mut state, &mut cycle);
                let n = self.cycles as f64;
                for (o, d) in out.iter_mut().zip(&cycle) {
                    *o = n * d;
                }
            }
            Acquisition::FreeRunning => {
                out[..b].fill(0.0);
                let mut previous = vec![0.0; b];
                let mut late_sum = vec![0.0; b];
                let half = MAX_ITERATED_CYCLES / 2;
                let mut done = 0u64;
                while done < self.cycles {
                    self.run_cycle(&factors, &mut state, &mut cycle);
                    done += 1;
                    for (o, d) in out.iter_mut().zip(&cycle) {
                        *o += d;
                    }
                    if done > half {
                        for (s, d) in late_sum.iter_mut().zip(&cycle) {
                            *s += d;
                        }
                    }
                    let total: f64 = cycle.iter().sum();
                    let change = cycle
                        .iter()
                        .zip(&previous)
                        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                    let rest = (self.cycles - done) as f64;
                    if done > 1 && change <= 1e-13 * total.max(f64::MIN_POSITIVE) {
                        for (o, d) in out.iter_mut().zip(&cycle) {
                            *o += rest * d;
                        }
                        break;
                    }
                    if done == MAX_ITERATED_CYCLES {
                        let k = (done - half) as f64;
                        for (o, s) in out.iter_mut().zip(&late_sum) {
                            *o += rest * s / k;
                        }
                        break;
                    }
                    std::mem::swap(&mut previous, &mut cycle);
                }
            }
        }
    }

    /// The detection probabilities of one cycle (`D_k` into `cycle`), from `state`
    /// (reset first in synchronous mode), leaving the state at the cycle's end.
    /// `bins` holds each bin's factors, computed once per pixel ([`BinFactors`]).
    fn run_cycle(&self, bins: &[BinFactors], state: &mut State, cycle: &mut [f64]) {
        if self.mode == Acquisition::Synchronous {
            state.reset();
        }
        let p = self.trap_at_rearm;
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
        BinFactors {
            keep_e: (-r).exp(),
            keep_f: (-(r + mu)).exp(),
            fire_e: -(-r).exp_m1(),
            fire_f: -(-(r + mu)).exp_m1(),
        }
    }
}

/// The detector's state between bins: armed with the trap empty or filled, and the
/// detection probabilities of the last `d + 1` bins (each re-arms `d + 1` bins later).
struct State {
    armed_empty: f64,
    armed_trap: f64,
    ring: Vec<f64>,
    at: usize,
}

impl State {
    fn new(dead_bins: usize) -> State {
        State {
            armed_empty: 1.0,
            armed_trap: 0.0,
            ring: vec![0.0; dead_bins + 1],
            at: 0,
        }
    }

    fn reset(&mut self) {
        self.armed_empty = 1.0;
        self.armed_trap = 0.0;
        self.ring.fill(0.0);
        self.at = 0;
    }

    /// Records this bin's detection probability `D_n` and returns `D_{n-d}`, the
    /// detections that re-arm at bin `n + 1`.
    fn push(&mut self, det: f64) -> f64 {
        let len = self.ring.len();
        self.ring[self.at] = det;
        self.at = (self.at + 1) % len;
        // The slot after the one written holds D_{n-d} (for d = 0, the one written).
        self.ring[self.at % len]
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

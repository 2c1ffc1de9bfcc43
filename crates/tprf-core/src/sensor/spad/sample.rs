//! One seeded realisation of a pixel's SPAD histogram, drawn from the model of
//! [`super::detector`] (not an approximation of it):
//!
//! - when at most one detection fits in a cycle, the `N` cycles are a multinomial over
//!   the `B` bins and "none", drawn as `B` sequential binomials ([`Sampler::Multinomial`]);
//! - otherwise detection after detection: from an armed bin `s`, the next detection is
//!   the first bin where the cumulative event mean `sum_{j=s}^{k} (r_j + mu [trap])`
//!   passes an Exp(1) draw (the chance of no event in those bins is the exponential of
//!   minus that sum; after a fractional dead time `d + f` bins the first bin `s` counts
//!   for its armed part, `(1 - f) (r_s + mu [trap])`), whole cycles without one skipped
//!   at once
//!   ([`Sampler::Events`]); the work grows with the detections, not the cycles.
//!
//! Beyond [`MAX_EVENTS`] detections for an image, each bin is drawn from its marginal
//! ([`Sampler::Marginals`]). Streams are keyed by (seed, pixel), so a pixel's draw does
//! not depend on the thread count.

use rand::{Rng, SeedableRng};
use rand_distr::{Binomial, Distribution, Exp1};
use rand_pcg::Pcg64Mcg;

use super::Acquisition;
use super::detector::{Detector, RATE_CAP, Sampler};

/// Most detections an image's realisation draws one by one (~ a few seconds).
pub const MAX_EVENTS: f64 = 2e8;

/// The random stream of `pixel` under `seed`.
pub fn pixel_stream(seed: u64, pixel: usize) -> Pcg64Mcg {
    let key = crate::sensor::noise::mix(seed ^ 0x5350_4144_5350_4144).wrapping_add(pixel as u64);
    Pcg64Mcg::seed_from_u64(crate::sensor::noise::mix(key))
}

/// A Binomial(n, p) draw (0 for p <= 0, n for p >= 1).
fn binomial(n: u64, p: f64, rng: &mut Pcg64Mcg) -> u64 {
    if !(p > 0.0) || n == 0 {
        return 0;
    }
    if p >= 1.0 {
        return n;
    }
    Binomial::new(n, p).map_or(0, |b| b.sample(rng))
}

/// The cumulative event mean `C[k] = sum_{j<k} r_j` (rates clamped), `B + 1` values,
/// and a guide to invert it: `guide[j]` is the first `k` with `C[k] >= j C[B] / B`, so
/// that the first `k` with `C[k]` at or past a target is found from the guide's entry
/// below the target by a step or two (a bucket of the guide spans a bin's worth of mean
/// on average) rather than by bisection, whose chain of dependent loads was most of the
/// sampler's time.
struct Hazard {
    c: Vec<f64>,
    guide: Vec<u32>,
    /// Guide buckets per unit of event mean, `B / C[B]` (0 when `C[B] = 0`).
    scale: f64,
}

impl Hazard {
    fn new(rates: &[f64]) -> Hazard {
        let mut c = Vec::with_capacity(rates.len() + 1);
        let mut sum = 0.0;
        c.push(0.0);
        for &r in rates {
            sum += r.clamp(0.0, RATE_CAP);
            c.push(sum);
        }
        let b = rates.len();
        let scale = if sum > 0.0 { b as f64 / sum } else { 0.0 };
        let mut guide = Vec::with_capacity(b);
        let mut k = 0;
        for j in 0..b {
            let v = j as f64 / scale;
            while k < b && c[k] < v {
                k += 1;
            }
            guide.push(k as u32);
        }
        Hazard { c, guide, scale }
    }

    /// The first `i` in `lo..=B` with `!below(i)`, for a `below` true up to some index
    /// and false from there on (false at `B`), whose crossing lies near `C = target`.
    fn first_reaching(&self, lo: usize, target: f64, below: impl Fn(usize) -> bool) -> usize {
        let b = self.c.len() - 1;
        let j = (target * self.scale).max(0.0);
        let guess = if j < self.guide.len() as f64 {
            self.guide[j as usize] as usize
        } else {
            b
        };
        let mut i = guess.clamp(lo, b);
        // The guide only guides: step back while the index before already reaches
        // (the crossing is exact whatever the guess), then forward.
        while i > lo && !below(i - 1) {
            i -= 1;
        }
        while i < b && below(i) {
            i += 1;
        }
        i
    }
}

/// The first bin `k` in `s..B` where the event mean from the fraction `f` of bin `s`
/// through bin `k`, `C[k+1] - C[s] - f (C[s+1] - C[s]) + mu (k + 1 - s - f)`, reaches
/// `e`; or the total over `s..B` when it does not. `f = 0`: from the start of bin `s`.
fn first_event(h: &Hazard, s: usize, f: f64, mu: f64, e: f64) -> Result<usize, f64> {
    let c = &h.c;
    let b = c.len() - 1;
    if s >= b {
        return Err(0.0);
    }
    // The part of bin s already dead (0.0 - exact - for a whole number of dead bins).
    let dead_part = f * (c[s + 1] - c[s]);
    let hazard = |k: usize| c[k + 1] - c[s] - dead_part + mu * ((k + 1 - s) as f64 - f);
    let total = hazard(b - 1);
    if total < e {
        return Err(total);
    }
    if mu == 0.0 {
        // No trap: the hazard is C[k+1] less a constant, the same arithmetic as
        // `hazard(k)` (mu (..) adds an exact 0), found from the guide: the bin
        // bisection finds.
        let c0 = c[s];
        let i = h.first_reaching(s + 1, c0 + dead_part + e, |i| c[i] - c0 - dead_part < e);
        return Ok(i - 1);
    }
    // The hazard is non-decreasing in k: bisect for the first k with hazard(k) >= e.
    let (mut lo, mut hi) = (s, b - 1);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if hazard(mid) < e {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    Ok(lo)
}

/// A pixel's counts over the detector's `N` cycles with `sampler`, from its mean
/// events per cycle `rates` and, for the multinomial and the marginals, its expected
/// counts `expected` (both `B` values); into `out`.
pub fn sample_pixel(
    det: &Detector,
    sampler: Sampler,
    rates: &[f64],
    expected: &[f64],
    rng: &mut Pcg64Mcg,
    out: &mut [f64],
) {
    out.fill(0.0);
    let n = det.cycles;
    match sampler {
        Sampler::Multinomial => {
            // Sequential binomials: bin k takes Binomial(cycles left, D_k / mass left).
            let mut left = n;
            let mut mass = 1.0;
            for (o, &e) in out.iter_mut().zip(expected) {
                let p = e / n as f64;
                if left == 0 {
                    break;
                }
                let x = binomial(left, p / mass, rng);
                *o = x as f64;
                left -= x;
                mass = (mass - p).max(0.0);
            }
        }
        Sampler::Marginals => {
            for (o, &e) in out.iter_mut().zip(expected) {
                *o = binomial(n, e / n as f64, rng) as f64;
            }
        }
        Sampler::Events => events(det, rates, rng, out),
    }
}

/// [`Sampler::Events`]: every detection in turn.
fn events(det: &Detector, rates: &[f64], rng: &mut Pcg64Mcg, out: &mut [f64]) {
    let b = det.bins.min(rates.len()).min(out.len());
    if b == 0 {
        return;
    }
    let c = Hazard::new(&rates[..b]);
    let total = c.c[b];
    let d = det.dead_bins;
    let f = det.dead_fraction;
    let mu = det.trap_rate;
    let exp1 = |rng: &mut Pcg64Mcg| -> f64 { Exp1.sample(rng) };
    match det.mode {
        Acquisition::Synchronous => {
            // Cycles with at least one detection (armed, no trap at the start).
            let p_cycle = -(-total).exp_m1();
            let with = binomial(det.cycles, p_cycle, rng);
            for _ in 0..with {
                // Exp(1) conditioned below `total`.
                let u: f64 = rng.random();
                let e = -(-u * p_cycle).ln_1p();
                let mut k = match first_event(&c, 0, 0.0, 0.0, e.min(total)) {
                    Ok(k) => k,
                    Err(_) => continue,
                };
                loop {
                    out[k] += 1.0;
                    let trap = rng.random::<f64>() < det.trap_at_rearm;
                    let s = k + d + 1;
                    if s >= b {
                        break;
                    }
                    match first_event(&c, s, f, if trap { mu } else { 0.0 }, exp1(rng)) {
                        Ok(next) => k = next,
                        Err(_) => break,
                    }
                }
            }
        }
        Acquisition::FreeRunning => {
            let end = det.cycles.saturating_mul(b as u64);
            let mut g: u64 = 0; // the global bin where the detector is armed
            let mut partly = false; // armed from the fraction f of bin g, not its start
            let mut trap = false;
            while g < end {
                let m = if trap { mu } else { 0.0 };
                let mut e = exp1(rng);
                let mut cycle = g / b as u64;
                let s = (g % b as u64) as usize;
                let k = match first_event(&c, s, if partly { f } else { 0.0 }, m, e) {
                    Ok(k) => k,
                    Err(rest) => {
                        e -= rest;
                        let per_cycle = total + m * b as f64;
                        if !(per_cycle > 0.0) {
                            break;
                        }
                        let skip = (e / per_cycle).floor();
                        e -= skip * per_cycle;
                        cycle = cycle
                            .saturating_add(1)
                            .saturating_add(skip.min(u64::MAX as f64) as u64);
                        match first_event(&c, 0, 0.0, m, e.max(0.0)) {
                            Ok(k) => k,
                            Err(_) => b - 1,
                        }
                    }
                };
                if cycle >= det.cycles {
                    break;
                }
                out[k] += 1.0;
                trap = rng.random::<f64>() < det.trap_at_rearm;
                g = (cycle * b as u64 + k as u64).saturating_add(d as u64 + 1);
                partly = f > 0.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_event_finds_the_crossing() {
        let c = Hazard::new(&[1.0, 0.0, 2.0, 1.0]);
        assert_eq!(first_event(&c, 0, 0.0, 0.0, 0.5), Ok(0));
        assert_eq!(first_event(&c, 0, 0.0, 0.0, 1.5), Ok(2));
        assert_eq!(first_event(&c, 1, 0.0, 0.0, 2.5), Ok(3));
        assert_eq!(first_event(&c, 1, 0.0, 0.0, 3.5), Err(3.0));
        assert_eq!(first_event(&c, 1, 0.0, 1.0, 3.5), Ok(2));
        assert_eq!(first_event(&c, 4, 0.0, 0.0, 0.1), Err(0.0));
        // From 3/4 of bin 2 (mean 2): 0.5 there, then 1 in bin 3.
        assert_eq!(first_event(&c, 2, 0.75, 0.0, 0.4), Ok(2));
        assert_eq!(first_event(&c, 2, 0.75, 0.0, 0.6), Ok(3));
        assert_eq!(first_event(&c, 2, 0.75, 0.0, 2.0), Err(1.5));
        // With a trap of 1 per bin: 0.25 more in bin 2.
        assert_eq!(first_event(&c, 2, 0.75, 1.0, 0.7), Ok(2));
    }

    /// The guided search finds the bin bisection finds, for every start and draw, on
    /// rates with empty bins, a spike and a flat floor.
    #[test]
    fn guided_search_is_bisection() {
        let mut rates = vec![0.0; 40];
        rates[3] = 0.01;
        rates[17] = 7.5;
        for r in rates.iter_mut().skip(25) {
            *r += 0.2;
        }
        let h = Hazard::new(&rates);
        let c = &h.c;
        for s in 0..40 {
            for f in [0.0, 0.3] {
                for i in 0..400 {
                    let e = i as f64 * 0.03;
                    let dead = f * (c[s + 1] - c[s]);
                    let want = {
                        let hz = |k: usize| c[k + 1] - c[s] - dead;
                        if hz(39) < e {
                            Err(hz(39))
                        } else {
                            Ok((s..40).find(|&k| hz(k) >= e).unwrap_or(39))
                        }
                    };
                    assert_eq!(first_event(&h, s, f, 0.0, e), want, "s {s} f {f} e {e}");
                }
            }
        }
    }
}

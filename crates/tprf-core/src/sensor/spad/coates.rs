//! Undoing the pile-up (Coates 1968), and the first-return depth of a histogram.
//!
//! A bin `k` fires in a cycle with probability `1 - exp(-r_k)` when the SPAD is armed
//! there, so with `h_k` detections in `A_k` armed cycles the estimate is
//!
//! ```text
//! r_k = -ln(1 - h_k / A_k),   A_k = N - sum_{j=1}^{d} h_{k-j}
//! ```
//!
//! (the SPAD is dead at bin `k` in a cycle exactly when it fired in one of the `d` bins
//! before; in synchronous mode those lie in the same cycle, free-running they wrap into
//! the previous one). With a dead time of a whole cycle this is Coates' own
//! `A_k = N - sum_{j<k} h_j`. Afterpulses are taken for photons (the estimate is too
//! high after strong returns when afterpulsing is on).
//!
//! After a fractional dead time `d + f` bins, the cycles that fired in bin `k - d - 1`
//! are armed for only the last `1 - f` of bin `k` ([`super::detector`]): with
//! `A_k = N - sum_{j=1}^{d+1} h_{k-j}` cycles armed for the whole bin and
//! `P_k = h_{k-d-1}` for part of it, `r_k` solves
//!
//! ```text
//! h_k = A_k (1 - e^-r_k) + P_k (1 - e^-((1 - f) r_k))
//! ```
//!
//! (increasing and concave in `r_k`: Newton's method from
//! `-ln(1 - h_k / (A_k + P_k))`, below the root, climbs to it monotonically).

use super::Acquisition;
use super::detector::Detector;
use crate::sensor::derived::{Returns, depth_m};

/// The Coates estimate `N r_k` (events over all cycles as if there were no pile-up) of
/// the histogram `counts` (`B` values) into `out`. A bin where every armed cycle fired
/// gets `N ln(2 A_k + 1)` (as if half a cycle had stayed dark); a bin never armed
/// (`A_k <= 0`) is NaN: nothing is known of it.
pub fn coates(det: &Detector, counts: &[f64], out: &mut [f64]) {
    let b = counts.len().min(out.len());
    if det.dead_fraction > 0.0 && det.dead_bins < b {
        return coates_fractional(det, &counts[..b], &mut out[..b]);
    }
    let n = det.cycles as f64;
    let d = det.dead_bins.min(b);
    let prefix = wrapped_prefix(counts, b);
    for k in 0..b {
        let dead = match det.mode {
            Acquisition::FreeRunning => prefix[b + k] - prefix[b + k - d],
            Acquisition::Synchronous => prefix[k] - prefix[k.saturating_sub(d)],
        };
        let armed = n - dead;
        let h = counts[k];
        out[k] = if !(armed > 0.0) {
            f64::NAN
        } else if h >= armed {
            n * (2.0 * armed + 1.0).ln()
        } else {
            -n * (-h / armed).ln_1p()
        };
    }
}

/// Prefix sums over the first `b` counts repeated twice: position `b + k` is bin `k`, and
/// the `d` positions before it are the `d` bins before `k`, wrapping into the previous
/// cycle.
fn wrapped_prefix(counts: &[f64], b: usize) -> Vec<f64> {
    let mut prefix = Vec::with_capacity(2 * b + 1);
    prefix.push(0.0);
    let mut sum = 0.0;
    for i in 0..2 * b {
        sum += counts[i % b];
        prefix.push(sum);
    }
    prefix
}

/// [`coates`] after a fractional dead time (`0 < f < 1`, `d < B`): cycles armed for
/// the whole bin `k` and for its last `1 - f` (those that fired `d + 1` bins before).
fn coates_fractional(det: &Detector, counts: &[f64], out: &mut [f64]) {
    let b = counts.len();
    let n = det.cycles as f64;
    let d = det.dead_bins;
    let a = det.rearmed_part();
    let prefix = wrapped_prefix(counts, b);
    for k in 0..b {
        // Cycles dead at bin k or re-armed inside it: fired in bins k-d-1 ..= k-1.
        let (not_full, part) = match det.mode {
            Acquisition::FreeRunning => (
                prefix[b + k] - prefix[b + k - (d + 1).min(b)],
                prefix[b + k - d] - prefix[b + k - d - 1],
            ),
            Acquisition::Synchronous => (
                prefix[k] - prefix[k.saturating_sub(d + 1)],
                if k > d { counts[k - d - 1] } else { 0.0 },
            ),
        };
        let full = n - not_full;
        let armed = full + part;
        let h = counts[k];
        out[k] = if !(armed > 0.0) || full < -1e-9 * n {
            f64::NAN
        } else if h >= armed {
            n * (2.0 * armed + 1.0).ln()
        } else {
            n * partly_armed_rate(full.max(0.0), part, a, h)
        };
    }
}

/// The `r >= 0` with `full (1 - e^-r) + part (1 - e^-(a r)) = h`, for
/// `0 <= h < full + part`, `0 < a < 1`.
fn partly_armed_rate(full: f64, part: f64, a: f64, h: f64) -> f64 {
    if !(h > 0.0) {
        return 0.0;
    }
    // A lower bound: the left side is at most (full + part)(1 - e^-r).
    let mut r = -(-h / (full + part)).ln_1p();
    for _ in 0..200 {
        let (ea, eb) = ((-r).exp(), (-a * r).exp());
        let g = full * -(-r).exp_m1() + part * -(-a * r).exp_m1() - h;
        let slope = full * ea + part * a * eb;
        if !(slope > 0.0) {
            break;
        }
        let step = -g / slope;
        r += step;
        if !(step.abs() > 1e-15 * r) {
            break;
        }
    }
    r
}

/// The first-return depth (m, NaN: none) of a histogram `values` over TDC bins whose
/// centres are `centres_s`. The median bin is taken as the background and removed;
/// what is left is smoothed by a moving average over `2 half_width + 1` bins (about the
/// return's own width, so that photon noise does not split a return); the return is
/// the first run of bins whose smoothed value reaches `p.threshold` x the smoothed
/// peak (and whose peak is above `p.min_signal`), and its time the centroid of the
/// unsmoothed bins of that run. Depth `c (t - light_mean_s) / 2`.
pub fn return_depth_m(
    values: &[f64],
    centres_s: &[f64],
    light_mean_s: f64,
    p: &Returns,
    half_width: usize,
    scratch: &mut Vec<f64>,
) -> f64 {
    let n = values.len().min(centres_s.len());
    scratch.clear();
    scratch.extend(values[..n].iter().copied().filter(|v| v.is_finite()));
    if scratch.is_empty() {
        return f64::NAN;
    }
    let mid = scratch.len() / 2;
    let (_, median, _) = scratch.select_nth_unstable_by(mid, f64::total_cmp);
    let background = *median;
    let clean = |v: f64| {
        if v.is_finite() {
            (v - background).max(0.0)
        } else {
            0.0
        }
    };
    // Moving average through a running sum (`scratch[..=n]`), each bin's smoothed value
    // computed once into `scratch[n + 1..]`.
    scratch.clear();
    let mut sum = 0.0;
    scratch.push(0.0);
    for &v in &values[..n] {
        sum += clean(v);
        scratch.push(sum);
    }
    for k in 0..n {
        let (lo, hi) = (k.saturating_sub(half_width), (k + half_width + 1).min(n));
        let s = (scratch[hi] - scratch[lo]) / (hi - lo) as f64;
        scratch.push(s);
    }
    let smooth = &scratch[n + 1..];
    let peak = smooth.iter().fold(0.0f64, |m, &s| m.max(s));
    if !(peak > p.min_signal && peak > 0.0) {
        return f64::NAN;
    }
    let threshold = p.threshold * peak;
    let Some(start) = smooth.iter().position(|&s| s >= threshold) else {
        return f64::NAN;
    };
    let end = smooth[start..]
        .iter()
        .position(|&s| s < threshold)
        .map_or(n, |i| start + i);
    let (mut w, mut moment) = (0.0, 0.0);
    for k in start..end {
        let v = clean(values[k]);
        w += v;
        moment += v * centres_s[k];
    }
    if w > 0.0 {
        depth_m(moment / w - light_mean_s)
    } else {
        f64::NAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(mode: Acquisition, dead_bins: usize, bins: usize) -> Detector {
        Detector {
            bins,
            bin_width_s: 1.0,
            cycles: 100,
            mode,
            dead_bins,
            dead_fraction: 0.0,
            trap_rate: 0.0,
            trap_at_rearm: 0.0,
        }
    }

    #[test]
    fn classic_coates_by_hand() {
        let h = [10.0, 30.0, 0.0, 60.0];
        let mut out = [0.0; 4];
        coates(&det(Acquisition::Synchronous, 3, 4), &h, &mut out);
        let want = [
            -100.0 * (1.0f64 - 10.0 / 100.0).ln(),
            -100.0 * (1.0f64 - 30.0 / 90.0).ln(),
            0.0,
            100.0 * (2.0f64 * 60.0 + 1.0).ln(),
        ];
        for (o, w) in out.iter().zip(want) {
            assert!((o - w).abs() < 1e-9, "{o} {w}");
        }
    }

    /// By hand: d = 1, f = 0.5, synchronous. Bin 2 is fully armed in 100 - 10 - 30 =
    /// 60 cycles and half armed in the 10 that fired in bin 0.
    #[test]
    fn fractional_dead_time_by_hand() {
        let mut d = det(Acquisition::Synchronous, 1, 4);
        d.dead_fraction = 0.5;
        let r = 0.7f64;
        let h2 = 60.0 * (1.0 - (-r).exp()) + 10.0 * (1.0 - (-0.5 * r).exp());
        let h = [10.0, 30.0, h2, 5.0];
        let mut out = [0.0; 4];
        coates(&d, &h, &mut out);
        assert!((out[2] - 100.0 * r).abs() < 1e-9, "{}", out[2]);
        // Bin 0: armed in every cycle.
        assert!((out[0] + 100.0 * (1.0f64 - 0.1).ln()).abs() < 1e-9);
    }

    #[test]
    fn free_running_window_wraps() {
        // d = 1: bin 0 is dead after bin 3 of the previous cycle.
        let h = [10.0, 20.0, 5.0, 40.0];
        let mut out = [0.0; 4];
        coates(&det(Acquisition::FreeRunning, 1, 4), &h, &mut out);
        let armed = [60.0, 90.0, 80.0, 95.0];
        for k in 0..4 {
            let want = -100.0 * (1.0 - h[k] / armed[k]).ln();
            assert!((out[k] - want).abs() < 1e-9, "{k}: {} {want}", out[k]);
        }
        // d = B: the whole previous cycle.
        coates(&det(Acquisition::FreeRunning, 4, 4), &h, &mut out);
        let want = -100.0 * (1.0f64 - 10.0 / 25.0).ln();
        assert!((out[0] - want).abs() < 1e-9, "{}", out[0]);
    }
}

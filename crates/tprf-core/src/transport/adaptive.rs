//! Adaptive sampling: how many of a pass's samples each pixel draws, from the noise the
//! film has measured so far ([`RenderSettings::adaptive`](super::RenderSettings)).
//!
//! What is minimised is the cube's error as the film measures it, the sum over pixels
//! and bins of the squared error of the mean. A pixel whose one sample has variance
//! `s_p^2` (summed over its bins) and costs `c_p` rays contributes `s_p^2 / n_p` after
//! `n_p` samples; for a given amount of work `sum n_p c_p` the sum is least at
//! `n_p ∝ s_p / sqrt(c_p)` (a Lagrange multiplier, as in Neyman allocation), and then it
//! is `(mean s sqrt(c))^2` against uniform sampling's `mean s^2 mean c`. On the race's open
//! corner, whose bright spot beside the lamp holds most of the noise, the two differ by
//! about 2.4x at equal samples (measured: the plan of one 256-spp render applied to
//! another's per-pixel errors); in its closed room by 1.3x.
//!
//! `s_p^2` is estimated from the film's two halves: each half's mean of pixel `p` has
//! variance `s_p^2 / d` after `d` samples, so their squared difference `D_p` has mean
//! `s_p^2 (1 / d_a + 1 / d_b)`. `c_p` is the rays per sample of the pixel's last pass.
//! Both are noisy, so a pixel's `s_p^2` is the larger of its own and its 3 x 3
//! neighbourhood's mean, and [`UNIFORM_SHARE`] of the samples is spread evenly: a pixel
//! whose light the first samples missed still gets its share.
//!
//! A plan has a cost the formula leaves out: a pixel's samples are points of one
//! stratified (Sobol) stream, and weighted unequally from pass to pass they lose some of
//! that stratification. Where the predicted gain is small (a lit plane, whose direct
//! light is all its noise: 1.08; the furnace: 1.00) the plan loses more than it wins
//! (measured on the plane: 1.26x the squared error at equal time), so a pass is planned
//! only where the gain is at least [`MIN_GAIN`] (the race's corner: 1.8; its room: 1.3).
//!
//! The plan of a pass depends only on earlier passes, and every pixel draws at least one
//! sample, so the film's means stay unbiased ([`TprfFilm::run_pass_planned`]). It depends
//! on the whole image, so a shard of a render (some rows only) does not plan: each of
//! its pixels draws the pass's samples, as a render with adaptive sampling off does.

use crate::film::TprfFilm;

/// Samples per half a film holds before its noise plans a pass (the first passes are
/// uniform: 1, 1, 2, 2, 4, 4 samples per pixel in doubling passes).
pub const MIN_HALF_SPP: u64 = 4;

/// Share of a pass's samples spread evenly over the pixels.
pub const UNIFORM_SHARE: f64 = 0.1;

/// Most samples a pixel draws in a pass, in multiples of the pass's samples per pixel.
pub const MAX_RATIO: f64 = 32.0;

/// Least predicted gain (work x error of uniform samples over the plan's) for which a
/// pass is planned. Below it the pass is uniform: a plan also costs what it undoes of
/// the stratification of a pixel's samples (their weights differ from pass to pass), so
/// where the noise is spread evenly (a lit plane: 1.08) it loses more than it wins.
pub const MIN_GAIN: f64 = 1.2;

/// Samples per pixel (row-major) for a pass of `pass_spp` samples per pixel on average
/// into `film`: proportional to each pixel's noise over the square root of its cost
/// (see the module doc), at least 1 and at most [`MAX_RATIO`] times `pass_spp`. `None`
/// (every pixel draws `pass_spp`) for a pass of 1 sample, a film with fewer than
/// [`MIN_HALF_SPP`] samples in a half, a shard's film, a film without measured noise, or
/// one whose noise is spread so evenly that the plan's predicted gain is under
/// [`MIN_GAIN`].
pub fn plan(film: &TprfFilm, pass_spp: u32) -> Option<Vec<u32>> {
    let [na, nb] = film.half_spp();
    if pass_spp < 2 || na.min(nb) < MIN_HALF_SPP || !film.renders_all_rows() {
        return None;
    }
    let (w, h) = (film.layout().width, film.layout().height);
    // Per pixel: the variance of one sample, summed over its bins.
    let variance: Vec<f32> = film
        .pixel_samples()
        .map(|s| match s.drawn {
            [da, db] if da > 0 && db > 0 => {
                (s.half_diff2 as f64 / (1.0 / da as f64 + 1.0 / db as f64)) as f32
            }
            _ => 0.0,
        })
        .collect();
    if variance.len() != w * h {
        return None;
    }
    // The larger of it and its 3 x 3 neighbourhood's mean, over the cost, square-rooted;
    // and the sums of the predicted gain.
    let (mut sum_v, mut sum_c, mut sum_t_c) = (0.0f64, 0.0f64, 0.0f64);
    let target: Vec<f32> = film
        .pixel_samples()
        .enumerate()
        .map(|(i, s)| {
            let (x, y) = (i % w, i / w);
            let (mut sum, mut count) = (0.0f64, 0.0f64);
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    sum += variance[ny * w + nx] as f64;
                    count += 1.0;
                }
            }
            let cost = if s.cost.is_finite() && s.cost >= 1.0 {
                s.cost as f64
            } else {
                1.0
            };
            let v = (variance[i] as f64).max(sum / count);
            let t = (v / cost).sqrt() as f32;
            sum_v += v;
            sum_c += cost;
            sum_t_c += t as f64 * cost;
            t
        })
        .collect();
    drop(variance);
    // Work x error of uniform samples over that of the plan: mean(s^2) mean(c) /
    // mean(s sqrt(c))^2.
    let gain = sum_v * sum_c / (sum_t_c * sum_t_c);
    if !(gain >= MIN_GAIN) {
        return None;
    }
    let mean = target.iter().map(|&t| t as f64).sum::<f64>() / target.len() as f64;
    if !(mean > 0.0 && mean.is_finite()) {
        return None;
    }
    // Rounded with the remainder carried along the row-major order, so the pass draws
    // its budget (less what the clamps cut).
    let per_pixel = pass_spp as f64;
    let mut carry = 0.0;
    let plan = target
        .into_iter()
        .map(|t| {
            let share = (1.0 - UNIFORM_SHARE) * t as f64 / mean + UNIFORM_SHARE;
            let want = (per_pixel * share).min(per_pixel * MAX_RATIO) + carry;
            let n = want.round().clamp(1.0, u32::MAX as f64);
            carry = want - n;
            n as u32
        })
        .collect();
    Some(plan)
}

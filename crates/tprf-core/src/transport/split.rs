//! How many branches a camera sample splits into at its first scattering vertex
//! ([`RenderSettings::first_bounce_splits`](super::RenderSettings)), and whether eye
//! vertices are joined to light vertices (`connect`), chosen per render by a
//! small pilot where the settings leave them automatic.
//!
//! A split sample shares its prefix (the camera ray, the first hit and its next-event
//! estimate) between `k` continuations (the bounce and everything after), each
//! carrying `1 / k` of it. Splitting theory (Arvo and Kirk 1990): per bin, the variance
//! of the pixel's mean over `n` samples is `P + B / k` (`P` from the prefix, `B` from
//! one continuation), and a sample costs `c1 + k c2` rays; work times variance is least
//! near `k* = sqrt(c1 B / (c2 P))`. Splitting pays where the cube's noise comes from
//! the bounces and the prefix is much of a sample's cost (an open corner lit by a
//! lamp); it costs where the noise is the prefix's own (sunlight through leaves).
//!
//! The pilot renders a 16 x 16 grid of pixels spread over the film in 4 independent
//! replicas of 8 samples, once unsplit and once split 4 ways, and takes per bin (the
//! film's window in 256 bins) the variance of the replicas' means, summed over bins and
//! pixels, and the rays per sample. The two give `P`, `B`, `c1` and `c2`. One more
//! step: the prefix is stratified over a pixel's samples (its jitter is an
//! Owen-scrambled Sobol dimension), so its variance falls like `n^-3/2` where the
//! continuations' falls like `n^-1`; `P` is scaled to a render of `TARGET_SPP`
//! samples before `k*` is taken (at 8 samples the pilot would undersplit every
//! longer render). Measured at equal error on the race's corner, room and
//! `builtin:cornell`, this rule picks the best or a near-best of 1 ..= 4, and 1 on
//! `builtin:canopy` (docs/benchmarks.md).
//!
//! The pilot's estimates are noisy (on an area-lit scene, where a first-vertex
//! next-event estimate with shadow edges falls more slowly than `n^-3/2`, the model's
//! best `k` hung on the seed: mitransient's staircase took 4, 1, 2, 1, 1, 1, 2 splits
//! for seeds 0-6, a sample costing 1.7x (2 splits) or 2.4x (4) one of 1 split). So a
//! choice other than the cheaper one (1 split; light vertices off) is taken only where
//! its predicted work times variance is lower beyond the pilot's noise: by
//! `CONFIDENCE_Z` (2) standard errors of the log ratio, the jackknife's standard error
//! over `GROUPS` (16) groups of the pilot's pixels or, for a split not clearly ahead by
//! that, the error between rounds of the pilot (other sample streams, the same pixels;
//! up to `MAX_ROUNDS`, 4; see `splits_beyond_noise`).
//!
//! Light vertices: the pilot runs with and without them (each with its own best
//! split, by the rules above) and keeps them on where that lowers the predicted work
//! times variance at `TARGET_SPP` beyond the noise: on where a light lights a wall the eye's paths bounce off (the
//! race's corner and room, `builtin:cornell`), off where they cannot help (a single lit
//! plane, `builtin:canopy`'s foliage seen from the laser's side). The choice depends on the scene, the
//! settings, the seed and the film's size and window, not on the samples asked for,
//! the bin count or the threads: a longer render continues a shorter one, and a film
//! binned finer over the same window traces the same paths.

use super::integrator::{Renderer, Sink};
use super::sampler::Sampler;
use crate::film::TimeAxis;
use rayon::prelude::*;

/// Largest automatic split.
pub const MAX_SPLITS: u32 = 4;

/// Largest automatic split in a scene lit by a projector: its spot is found by the
/// light-vertex joins alone, so the light a continuation brings back is rare and its
/// variance the prefix's many times over (a camera's view of an NLOS scene: on
/// mitransient's `nlos-z-simple.xml` at 1024 spp, splits 4 / 16 / 64 left seed-to-seed
/// differences of 0.49 / 0.25 / 0.12 in 0.37 / 0.92 / 4.1 s). The pilot still measures
/// at 1 and [`MAX_SPLITS`]; only the whole `k` it may choose reaches this far.
pub const PROJECTOR_MAX_SPLITS: u32 = 64;

/// The render length the choice is made for, in samples per pixel (see the module doc).
const TARGET_SPP: f64 = 256.0;

/// Pilot pixels per image side (a grid spread over the film's real aspect).
const PILOT_SIDE: usize = 16;

/// Camera samples per pilot pixel and replica.
const PILOT_SAMPLES: u32 = 8;

/// Independent replicas per pilot pixel (each its own sample stream).
const REPLICAS: usize = 4;

/// Bins of the pilot's own time axis: the film's window cut into this many, whatever
/// the film's bin count, so that a film of 1 bin and one of 100 000 over the same
/// window trace the same paths.
const PILOT_BINS: usize = 256;

/// Sample streams of the pilot's replicas start here (the film's halves use 0 and 1).
const PILOT_STREAM: u64 = 0x5_0117_0000;

/// Sums one pilot pixel's replicas per bin.
struct PilotSink {
    axis: TimeAxis,
    replica: usize,
    /// `[REPLICAS][T]` sums of the contributions.
    bins: Vec<f64>,
    touched: Vec<usize>,
}

impl Sink for PilotSink {
    fn add(&mut self, arrival_s: f64, value: f64, _scatterings: u32) {
        let (Some(b), true) = (self.axis.bin_of(arrival_s), value.is_finite()) else {
            return;
        };
        if let Some(slot) = self.bins.get_mut(self.replica * self.axis.bins + b) {
            *slot += value;
            self.touched.push(b);
        }
    }
    fn window_end_s(&self) -> f64 {
        self.axis.end_s()
    }
    fn window_start_s(&self) -> f64 {
        self.axis.t0_s
    }
}

/// How a render samples its paths: the branches of a camera sample at its first vertex,
/// and whether eye vertices are joined to light vertices (`connect`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strategy {
    pub splits: u32,
    pub light_vertex: bool,
}

impl Strategy {
    /// One path per camera sample, the path tracer alone.
    pub const PLAIN: Strategy = Strategy {
        splits: 1,
        light_vertex: false,
    };
}

/// The strategy for a `width x height` film on `axis` (its window: see [`PILOT_BINS`]):
/// the settings' split and light-vertex choice, and where they are automatic the
/// pilot's, for the least work times variance (see the module doc). With light
/// vertices automatic and a punctual light in the scene, both choices are piloted (each
/// with its best split): the light vertex is kept where it pays for its rays, not on a
/// single lit plane, where no light vertex can reach another point of the plane.
pub(super) fn choose(
    renderer: &Renderer,
    axis: &TimeAxis,
    width: usize,
    height: usize,
) -> Strategy {
    let settings = renderer.settings();
    let span_s = axis.end_s() - axis.t0_s;
    let axis = &TimeAxis::new(axis.t0_s, span_s / PILOT_BINS as f64, PILOT_BINS).unwrap_or(*axis);
    let light_vertex: &[bool] = match settings.light_vertex {
        Some(true) => &[true],
        Some(false) => &[false],
        // A projector lights only its spot, which a path finds by a light vertex alone
        // (a pilot of 8 samples would see too little of the light the spot reflects to
        // weigh the two).
        None if settings.nee && renderer.has_projectors() => &[true],
        None if settings.nee && renderer.has_punctual_lights() => &[true, false],
        None => &[false],
    };
    let k_fixed = settings.first_bounce_splits;
    if k_fixed != 0 && light_vertex.len() == 1 {
        return Strategy {
            splits: k_fixed,
            light_vertex: light_vertex[0],
        };
    }
    // Per light-vertex choice: its split and the predicted work times variance, whole
    // and with each pixel group left out (the jackknife's replicates).
    let candidates: Vec<(Strategy, Estimate)> = light_vertex
        .iter()
        .map(|&light_vertex| {
            let at = |splits, round| {
                let strategy = Strategy {
                    splits,
                    light_vertex,
                };
                pilot(renderer, axis, width, height, strategy, round)
            };
            if k_fixed != 0 {
                let groups = at(k_fixed, 0);
                let strategy = Strategy {
                    splits: k_fixed,
                    light_vertex,
                };
                return (
                    strategy,
                    Estimate::of(&groups, |s| s.variance_per_sample() * s.rays_per_sample()),
                );
            }
            let cap = if renderer.has_projectors() {
                PROJECTOR_MAX_SPLITS
            } else {
                MAX_SPLITS
            };
            let (splits, estimate) = splits_beyond_noise(at, cap);
            let strategy = Strategy {
                splits,
                light_vertex,
            };
            (strategy, estimate)
        })
        .collect();
    // Light vertices off (the cheaper, listed last) unless on is better beyond its
    // noise (both pilots trace the same pixels' sample streams, so the jackknife of
    // their ratio takes what they share out of its noise).
    match candidates.as_slice() {
        [] => Strategy::PLAIN,
        [(only, _)] => *only,
        [(on, est_on), (off, est_off), ..] => {
            if better_beyond_noise(est_off, est_on) {
                *on
            } else {
                *off
            }
        }
    }
}

/// Standard errors a choice must gain by, in log work times variance, before it is
/// taken over the cheaper one: one-sided, about 2 % of pilots of a choice no better than
/// the cheaper one take it.
const CONFIDENCE_Z: f64 = 2.0;

/// Pixel groups of the pilot's grid: the jackknife's replicates (a pixel `(gx, gy)` of
/// the grid is in group `(gx + 3 gy) mod GROUPS`, so each group spans the film).
const GROUPS: usize = 16;

/// One pixel group's pilot sums: the variance of the mean of [`PILOT_SAMPLES`] samples,
/// summed over its pixels' bins, the rays traced and the camera samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct GroupSums {
    variance: f64,
    rays: f64,
    samples: f64,
}

impl GroupSums {
    fn add(self, o: GroupSums) -> GroupSums {
        GroupSums {
            variance: self.variance + o.variance,
            rays: self.rays + o.rays,
            samples: self.samples + o.samples,
        }
    }
    fn scale(self, f: f64) -> GroupSums {
        GroupSums {
            variance: self.variance * f,
            rays: self.rays * f,
            samples: self.samples * f,
        }
    }
    fn sub(self, o: GroupSums) -> GroupSums {
        GroupSums {
            variance: self.variance - o.variance,
            rays: self.rays - o.rays,
            samples: self.samples - o.samples,
        }
    }
    /// The variance of the mean of [`PILOT_SAMPLES`] samples per camera sample traced:
    /// the same for any number of pixels or rounds of the same scene.
    fn variance_per_sample(&self) -> f64 {
        if self.samples > 0.0 {
            self.variance / self.samples
        } else {
            0.0
        }
    }
    fn rays_per_sample(&self) -> f64 {
        if self.samples > 0.0 {
            self.rays / self.samples
        } else {
            0.0
        }
    }
}

/// A predicted work times variance (rays per sample x summed variance of a pixel's
/// mean, arbitrary units): from the whole pilot, and from the pilot with each pixel
/// group left out.
#[derive(Clone, Debug, PartialEq)]
struct Estimate {
    whole: f64,
    left_out: Vec<f64>,
}

impl Estimate {
    /// `f` of the groups' sums, whole and with each group left out.
    fn of(groups: &[GroupSums], f: impl Fn(&GroupSums) -> f64) -> Estimate {
        let total = groups.iter().fold(GroupSums::default(), |a, &g| a.add(g));
        Estimate {
            whole: f(&total),
            left_out: groups.iter().map(|&g| f(&total.sub(g))).collect(),
        }
    }
}

/// Whether `better` has less work times variance than `base` beyond the noise of the
/// pilot: its [`gain_in_standard_errors`] over [`CONFIDENCE_Z`].
fn better_beyond_noise(base: &Estimate, better: &Estimate) -> bool {
    gain_in_standard_errors(base, better) > CONFIDENCE_Z
}

/// `ln(base / better) / se`, the log ratio of two work times variance estimates over its
/// standard error `se`, the delete-one jackknife's (Efron and Stein 1981): `se^2 = (G -
/// 1) / G x sum_i (r_i - mean r)^2` over the `G` left-out replicates `r_i` of the log
/// ratio. 0 with under two groups (a film of one pixel) or an estimate not finite and
/// positive; infinite where every replicate agrees and `base` is the larger.
fn gain_in_standard_errors(base: &Estimate, better: &Estimate) -> f64 {
    let ratio = |b: f64, w: f64| {
        if b > 0.0 && w > 0.0 && b.is_finite() && w.is_finite() {
            Some((b / w).ln())
        } else {
            None
        }
    };
    let Some(whole) = ratio(base.whole, better.whole) else {
        return 0.0;
    };
    let g = base.left_out.len().min(better.left_out.len());
    if g < 2 {
        return 0.0;
    }
    let replicates: Option<Vec<f64>> = (0..g)
        .map(|i| ratio(base.left_out[i], better.left_out[i]))
        .collect();
    let Some(r) = replicates else {
        return 0.0;
    };
    let n = g as f64;
    let mean = r.iter().sum::<f64>() / n;
    let se = ((n - 1.0) / n * r.iter().map(|x| (x - mean).powi(2)).sum::<f64>()).sqrt();
    if se > 0.0 {
        whole / se
    } else if whole > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// Most rounds of the split pilot (each its own sample streams, the same pixels).
const MAX_ROUNDS: u32 = 4;

/// The split by the model of the module doc from the pilots at 1 and [`MAX_SPLITS`]
/// splits (`pilot(splits, round)`: per pixel group, the same pixels' sample streams at
/// both), with its predicted work times variance: the model's best `k` where it beats
/// `k = 1` beyond the pilot's noise, else 1.
///
/// The first round decides where the model picks 1, or where `k` beats 1 by over
/// [`CONFIDENCE_Z`] + 1 standard errors of the jackknife over pixel groups
/// ([`gain_in_standard_errors`]). That error is an overestimate: it counts how the gain
/// varies across the film, which the pilot's fixed grid sees alike on every seed. So
/// the rest take more rounds (up to [`MAX_ROUNDS`]) and are decided by the error of
/// the gain between rounds ([`gain_over_round_noise`]), once it is over or under the
/// threshold by one standard error (or at the last round, by the threshold alone): a
/// scene whose choices are close is then not split by some seeds and not by others.
fn splits_beyond_noise(
    mut pilot: impl FnMut(u32, u32) -> Vec<GroupSums>,
    cap: u32,
) -> (u32, Estimate) {
    // Per round, each group's sums at 1 and at MAX_SPLITS.
    let mut rounds: Vec<Vec<[GroupSums; 2]>> = Vec::new();
    let mut splits = 1;
    for round in 0..MAX_ROUNDS {
        let (at_1, at_k) = (pilot(1, round), pilot(MAX_SPLITS, round));
        let pairs: Vec<[GroupSums; 2]> = at_1.iter().zip(&at_k).map(|(&a, &b)| [a, b]).collect();
        rounds.push(pairs);
        let z = if round == 0 {
            let pairs = &rounds[0];
            let total = |leave: Option<usize>| {
                let mut t = [GroupSums::default(); 2];
                for (i, p) in pairs.iter().enumerate() {
                    if Some(i) != leave {
                        t = [t[0].add(p[0]), t[1].add(p[1])];
                    }
                }
                t
            };
            let whole = Model::from(&total(None));
            splits = whole.best_splits(cap);
            if splits == 1 {
                break;
            }
            let estimate_at = |k: u32| Estimate {
                whole: whole.work_x_variance(k),
                left_out: (0..pairs.len())
                    .map(|i| Model::from(&total(Some(i))).work_x_variance(k))
                    .collect(),
            };
            let z = gain_in_standard_errors(&estimate_at(1), &estimate_at(splits));
            if z > CONFIDENCE_Z + 1.0 {
                break;
            }
            continue;
        } else {
            gain_over_round_noise(&rounds, splits)
        };
        if (z - CONFIDENCE_Z).abs() >= 1.0 || round + 1 == MAX_ROUNDS {
            if z <= CONFIDENCE_Z {
                splits = 1;
            }
            break;
        }
    }
    let total = rounds
        .iter()
        .flatten()
        .fold([GroupSums::default(); 2], |t, p| {
            [t[0].add(p[0]), t[1].add(p[1])]
        });
    let groups = rounds.first().map_or(0, Vec::len);
    let whole = Model::from(&total);
    // The groups left out of every round, for the light-vertex comparison.
    let left_out = (0..groups)
        .map(|i| {
            let mut t = total;
            for r in &rounds {
                t = [t[0].sub(r[i][0]), t[1].sub(r[i][1])];
            }
            Model::from(&t).work_x_variance(splits)
        })
        .collect();
    let estimate = Estimate {
        whole: whole.work_x_variance(splits),
        left_out,
    };
    (splits, estimate)
}

/// `theta / se` for `theta = ln(W(1) / W(k))`, the log gain of `k` splits over 1 by the
/// model of all rounds' sums, and `se` its standard error from the differences between
/// rounds (the same pixels, other sample streams): by the delta method, `se^2 = sum_g
/// R / (R - 1) sum_r (grad theta . (x_gr - mean_r x_gr))^2` over the groups `g` and the
/// `R` rounds `r` of group sums `x_gr`, the gradient's products taken as central
/// differences of `theta`. 0 with under two rounds or a model not finite and positive;
/// infinite where the rounds agree and the gain is positive.
fn gain_over_round_noise(rounds: &[Vec<[GroupSums; 2]>], k: u32) -> f64 {
    let r = rounds.len();
    if r < 2 {
        return 0.0;
    }
    let theta = |t: &[GroupSums; 2]| {
        let m = Model::from(t);
        let (w1, wk) = (m.work_x_variance(1), m.work_x_variance(k));
        if w1 > 0.0 && wk > 0.0 && w1.is_finite() && wk.is_finite() {
            (w1 / wk).ln()
        } else {
            f64::NAN
        }
    };
    let total = rounds
        .iter()
        .flatten()
        .fold([GroupSums::default(); 2], |t, p| {
            [t[0].add(p[0]), t[1].add(p[1])]
        });
    let whole = theta(&total);
    if !whole.is_finite() {
        return 0.0;
    }
    let groups = rounds.iter().map(Vec::len).min().unwrap_or(0);
    let rf = r as f64;
    let mut variance = 0.0;
    for g in 0..groups {
        let sum = rounds.iter().fold([GroupSums::default(); 2], |t, round| {
            [t[0].add(round[g][0]), t[1].add(round[g][1])]
        });
        let mean = [sum[0].scale(1.0 / rf), sum[1].scale(1.0 / rf)];
        for round in rounds {
            let v = [round[g][0].sub(mean[0]), round[g][1].sub(mean[1])];
            let up = theta(&[total[0].add(v[0]), total[1].add(v[1])]);
            let down = theta(&[total[0].sub(v[0]), total[1].sub(v[1])]);
            let d = (up - down) / 2.0;
            variance += rf / (rf - 1.0) * d * d;
        }
    }
    let se = variance.sqrt();
    if !se.is_finite() {
        0.0
    } else if se > 0.0 {
        whole / se
    } else if whole > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// Splitting theory's model (module doc) from pilots at 1 and [`MAX_SPLITS`] splits:
/// `var(k) = P + B / k`, `rays(k) = c1 + k c2`, `P` scaled to [`TARGET_SPP`].
struct Model {
    c1: f64,
    c2: f64,
    prefix_at_target: f64,
    branches: f64,
}

impl Model {
    fn from(sums: &[GroupSums; 2]) -> Model {
        let (var_1, rays_1) = (sums[0].variance_per_sample(), sums[0].rays_per_sample());
        let (var_k, rays_k) = (sums[1].variance_per_sample(), sums[1].rays_per_sample());
        let k = MAX_SPLITS as f64;
        // var(k) = P + B / k and rays(k) = c1 + k c2, from k = 1 and k = MAX_SPLITS.
        let branches = (var_1 - var_k) * k / (k - 1.0);
        let prefix = var_1 - branches;
        let c2 = (rays_k - rays_1) / (k - 1.0);
        let c1 = rays_1 - c2;
        // The prefix's share at TARGET_SPP: its variance falls like n^-3/2 (stratified),
        // the branches' like n^-1.
        let prefix_at_target = prefix * (PILOT_SAMPLES as f64 / TARGET_SPP).sqrt();
        Model {
            c1,
            c2,
            prefix_at_target,
            branches,
        }
    }
    fn best_splits(&self, cap: u32) -> u32 {
        splits_for(self.c1, self.c2, self.prefix_at_target, self.branches, cap)
    }
    /// `(c1 + k c2)(P + B / k)`.
    fn work_x_variance(&self, k: u32) -> f64 {
        let k = k as f64;
        (self.c1 + k * self.c2) * (self.prefix_at_target + self.branches / k)
    }
}

/// The pilot of `strategy`, per pixel group ([`GROUPS`]): the variance of the mean of
/// [`PILOT_SAMPLES`] samples, summed over the bins of the group's pixels, the rays
/// traced and the camera samples. No groups for an empty film or window.
fn pilot(
    renderer: &Renderer,
    axis: &TimeAxis,
    width: usize,
    height: usize,
    strategy: Strategy,
    round: u32,
) -> Vec<GroupSums> {
    let t = axis.bins;
    if t == 0 || width == 0 || height == 0 {
        return Vec::new();
    }
    let (nx, ny) = (width.min(PILOT_SIDE), height.min(PILOT_SIDE));
    let seed = renderer.settings().seed;
    let n = PILOT_SAMPLES as f64;
    let r = REPLICAS as f64;
    let groups = GROUPS.min(nx * ny);
    let stream = PILOT_STREAM + u64::from(round) * REPLICAS as u64;
    // Per grid pixel (in parallel; summed in grid order, so the same on any pool).
    let per_pixel: Vec<(f64, u64)> = (0..nx * ny)
        .into_par_iter()
        .map_init(
            || PilotSink {
                axis: *axis,
                replica: 0,
                bins: vec![0.0; REPLICAS * t],
                touched: Vec::new(),
            },
            |sink, g| {
                let (gx, gy) = (g % nx, g / nx);
                let (x, y) = (
                    (2 * gx + 1) * width / (2 * nx),
                    (2 * gy + 1) * height / (2 * ny),
                );
                let pixel = (y * width + x) as u64;
                let mut rays = 0;
                for replica in 0..REPLICAS {
                    sink.replica = replica;
                    let mut rng = Sampler::new(seed, stream + replica as u64, pixel);
                    for _ in 0..PILOT_SAMPLES {
                        rays += renderer
                            .trace_sample_with(x, y, width, height, strategy, &mut rng, sink);
                    }
                }
                sink.touched.sort_unstable();
                sink.touched.dedup();
                let mut variance = 0.0;
                for &b in &sink.touched {
                    let means = (0..REPLICAS).map(|i| sink.bins[i * t + b] / n);
                    let (sum, sum2) = means.fold((0.0, 0.0), |(s, s2), m| (s + m, s2 + m * m));
                    // Unbiased variance of one replica's mean.
                    variance += (sum2 - sum * sum / r).max(0.0) / (r - 1.0);
                    for i in 0..REPLICAS {
                        sink.bins[i * t + b] = 0.0;
                    }
                }
                sink.touched.clear();
                (variance, rays)
            },
        )
        .collect();
    let mut sums = vec![GroupSums::default(); groups];
    for (g, &(variance, rays)) in per_pixel.iter().enumerate() {
        let (gx, gy) = (g % nx, g / nx);
        let group = &mut sums[(gx + 3 * gy) % groups];
        *group = group.add(GroupSums {
            variance,
            rays: rays as f64,
            samples: REPLICAS as f64 * n,
        });
    }
    sums
}

/// The whole `k` in `1 ..= cap` of least work times variance
/// `(c1 + k c2)(V1 + V2 / k)`: the least `k` with `k (k + 1) >= c1 V2 / (c2 V1)` (going
/// from `k` to `k + 1` changes it by `c2 V1 - c1 V2 / (k (k + 1))`). 1 when the branches
/// add no variance or cost nothing to compare; `cap` when the prefix has none.
fn splits_for(c1: f64, c2: f64, v1: f64, v2: f64, cap: u32) -> u32 {
    if !(v2 > 0.0 && c2 > 0.0 && c1 > 0.0) {
        return 1;
    }
    if !(v1 > 0.0) {
        return cap;
    }
    let k2 = (c1 * v2) / (c2 * v1);
    (1..cap)
        .find(|&k| (k * (k + 1)) as f64 >= k2)
        .unwrap_or(cap)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_optimum_of_work_times_variance() {
        // (c1 + k c2)(V1 + V2 / k) by brute force over k, against the threshold rule.
        for (c1, c2, v1, v2) in [
            (2.0, 1.3, 1.0, 10.0),
            (2.0, 4.4, 1.0, 9.0),
            (2.0, 1.6, 5.0, 0.5),
            (2.0, 1.0, 1.0, 1.0),
            (2.0, 1.0, 1.0, 3.0),
            (2.0, 1.0, 1.0, 3.1),
            (1.0, 1.0, 1.0, 1e6),
        ] {
            let cost = |k: f64| (c1 + k * c2) * (v1 + v2 / k);
            for cap in [MAX_SPLITS, PROJECTOR_MAX_SPLITS] {
                let best = (1..=cap)
                    .min_by(|&a, &b| cost(a as f64).total_cmp(&cost(b as f64)))
                    .unwrap();
                assert_eq!(splits_for(c1, c2, v1, v2, cap), best, "{c1} {c2} {v1} {v2}");
            }
        }
        // By hand: c1 V2 / (c2 V1) = 2 x 10 / 1.3 = 15.4, between 3 x 4 and 4 x 5.
        let s = |c1, c2, v1, v2| splits_for(c1, c2, v1, v2, MAX_SPLITS);
        assert_eq!(s(2.0, 1.3, 1.0, 10.0), 4);
        assert_eq!(s(2.0, 1.0, 1.0, 0.0), 1);
        assert_eq!(s(2.0, 0.0, 1.0, 1.0), 1);
        assert_eq!(s(2.0, 1.0, -1.0, 1.0), MAX_SPLITS);
        assert_eq!(s(2.0, 1.0, f64::NAN, 1.0), MAX_SPLITS);
        // A prefix 1000 times cheaper in variance: k (k + 1) >= 2 x 1000 / 1 at k = 45.
        assert_eq!(splits_for(2.0, 1.0, 1.0, 1000.0, PROJECTOR_MAX_SPLITS), 45);
    }

    /// Pilot sums of `groups` groups drawn from the model `var(k) = P + B / k`, `rays(k) =
    /// c1 + k c2` with `c1 = 2`, `c2 = 1`, `B = 2` and `P` at the pilot's 8 samples such
    /// that it is 1 at [`TARGET_SPP`]: by hand `c1 B / (c2 P) = 4`, so `k = 2` (`1 x 2 <
    /// 4 <= 2 x 3`), `(c1 + 2 c2)(P + B / 2) = 8` against `(c1 + c2)(P + B) = 9` at `k =
    /// 1` and `5 x 5 / 3` at `k = 3`: a gain of 1.125 over one split.
    /// Group `g`'s variance at [`MAX_SPLITS`] is off by a factor `1 + noise` for even
    /// `g`, `1 - noise` for odd `g`, signs flipped in odd rounds (the pilot's noise);
    /// its `B` is `B (1 + spread)` and its `P` is `P (1 - spread)` for `g mod 4 < 2`, the
    /// signs the other way for the others, in every round (how the gain varies across
    /// the film: the same on every seed).
    fn model_groups(
        splits: u32,
        round: u32,
        groups: usize,
        noise: f64,
        spread: f64,
    ) -> Vec<GroupSums> {
        let p = (TARGET_SPP / PILOT_SAMPLES as f64).sqrt();
        let (b, c1, c2) = (2.0, 2.0, 1.0);
        let k = splits as f64;
        let samples = 64.0;
        (0..groups)
            .map(|g| {
                let sign = if (g + round as usize).is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                };
                let off = if splits == 1 { 1.0 } else { 1.0 + sign * noise };
                let side = if g % 4 < 2 { 1.0 } else { -1.0 };
                let (p, b) = (p * (1.0 - side * spread), b * (1.0 + side * spread));
                GroupSums {
                    variance: samples * (p + b / k) * off,
                    rays: samples * (c1 + k * c2),
                    samples,
                }
            })
            .collect()
    }

    #[test]
    fn the_jackknife_standard_error_by_hand() {
        // Replicates of ln(base / better): 0, 0.1, 0.2, 0.1 (mean 0.1); se^2 = 3 / 4 x
        // 0.02 = 0.015; the whole ratio's log is 0.1, so 0.1 / sqrt(0.015) = 0.8165.
        let better = Estimate {
            whole: 1.0,
            left_out: vec![1.0; 4],
        };
        let base = Estimate {
            whole: 0.1f64.exp(),
            left_out: [0.0f64, 0.1, 0.2, 0.1].iter().map(|r| r.exp()).collect(),
        };
        let z = gain_in_standard_errors(&base, &better);
        assert!((z - 0.1 / 0.015f64.sqrt()).abs() < 1e-9, "{z}");
        assert!(!better_beyond_noise(&base, &better));
        // Replicates agreeing: no noise, any gain is beyond it; no gain never is.
        let agreeing = Estimate {
            whole: 1.05,
            left_out: vec![1.05; 4],
        };
        assert!(better_beyond_noise(&agreeing, &better));
        assert!(!better_beyond_noise(&better, &agreeing));
        assert!(!better_beyond_noise(&better, &better));
        // One group (a film of one pixel), a NaN or a negative estimate: never.
        let one = |w: f64| Estimate {
            whole: w,
            left_out: vec![w],
        };
        assert!(!better_beyond_noise(&one(2.0), &one(1.0)));
        let nan = Estimate {
            whole: f64::NAN,
            left_out: vec![f64::NAN; 4],
        };
        assert!(!better_beyond_noise(&nan, &better));
        assert!(!better_beyond_noise(&agreeing, &nan));
        let negative = Estimate {
            whole: -1.0,
            left_out: vec![-1.0; 4],
        };
        assert!(!better_beyond_noise(&agreeing, &negative));
    }

    #[test]
    fn splits_where_they_pay_beyond_the_pilots_noise() {
        let run = |noise: f64| {
            let mut calls = 0;
            let (k, estimate) = splits_beyond_noise(
                |splits, round| {
                    calls += 1;
                    model_groups(splits, round, GROUPS, noise, 0.0)
                },
                MAX_SPLITS,
            );
            (k, estimate.whole, calls)
        };
        // Exact estimates: the model's k = 2 with its (c1 + 2 c2)(P + B / 2) = 8, from
        // one round (two pilots).
        let (k, whole, calls) = run(0.0);
        assert_eq!((k, calls), (2, 2));
        assert!((whole - 8.0).abs() < 1e-9, "{whole}");
        // A little noise: the gain of 1.125 is still far beyond it.
        assert_eq!(run(0.005).0, 2);
        // Noise of 80 % per group at MAX_SPLITS: the predicted gain is within the noise,
        // the cheaper choice stays (9 = (c1 + c2)(P + B)), decided by the second round.
        let (k, whole, calls) = run(0.8);
        assert_eq!((k, calls), (1, 4));
        assert!((whole - 9.0).abs() < 1e-9, "{whole}");
    }

    #[test]
    fn a_gain_varying_across_the_film_is_not_taken_for_noise() {
        // Groups whose B differs by a factor 9 (0.4 and 3.6) and P by a factor 9 the
        // other way, the same in every round:
        // the jackknife over pixel groups puts the gain of k = 2 within its threshold
        // plus one standard error, but the rounds agree, so more rounds decide for k = 2
        // (four pilots: rounds 0 and 1).
        let spread = 0.8;
        let first = |splits| model_groups(splits, 0, GROUPS, 0.0, spread);
        let pairs: Vec<_> = first(1)
            .into_iter()
            .zip(first(MAX_SPLITS))
            .map(|(a, b)| [a, b])
            .collect();
        let sum = |leave: Option<usize>| {
            let mut t = [GroupSums::default(); 2];
            for (i, p) in pairs.iter().enumerate() {
                if Some(i) != leave {
                    t = [t[0].add(p[0]), t[1].add(p[1])];
                }
            }
            Model::from(&t)
        };
        let at = |k| Estimate {
            whole: sum(None).work_x_variance(k),
            left_out: (0..GROUPS)
                .map(|i| sum(Some(i)).work_x_variance(k))
                .collect(),
        };
        let z = gain_in_standard_errors(&at(1), &at(2));
        assert!(
            z < CONFIDENCE_Z + 1.0,
            "the pixel groups' jackknife: {z} standard errors"
        );
        let mut calls = 0;
        let (k, _) = splits_beyond_noise(
            |splits, round| {
                calls += 1;
                model_groups(splits, round, GROUPS, 0.0, spread)
            },
            MAX_SPLITS,
        );
        assert_eq!((k, calls), (2, 4));
        // And the error between rounds by hand: two rounds whose group sums differ only
        // in one group's variance at MAX_SPLITS.
        let ones = model_groups(1, 0, 2, 0.0, 0.0);
        let ks = model_groups(MAX_SPLITS, 0, 2, 0.0, 0.0);
        let round: Vec<[GroupSums; 2]> = ones.iter().zip(&ks).map(|(&a, &b)| [a, b]).collect();
        let mut rounds = vec![round.clone(), round];
        rounds[0][0][1].variance *= 1.1;
        rounds[1][0][1].variance *= 0.9;
        // theta(x) = ln(W(1) / W(2)) of the model of the totals; the round deviations of
        // group 0 are +-d (d = 0.1 x its variance at MAX_SPLITS), so se^2 = 2 x 2 x
        // ((theta(T + d) - theta(T - d)) / 2)^2.
        let total = rounds
            .iter()
            .flatten()
            .fold([GroupSums::default(); 2], |t, p| {
                [t[0].add(p[0]), t[1].add(p[1])]
            });
        let theta = |extra: f64| {
            let mut t = total;
            t[1].variance += extra;
            let m = Model::from(&t);
            (m.work_x_variance(1) / m.work_x_variance(2)).ln()
        };
        let d = 0.1 * ks[0].variance;
        let se = (4.0 * ((theta(d) - theta(-d)) / 2.0).powi(2)).sqrt();
        let z = gain_over_round_noise(&rounds, 2);
        assert!(
            (z - theta(0.0) / se).abs() < 1e-9 * z.abs(),
            "{z} against {}",
            theta(0.0) / se
        );
        assert_eq!(gain_over_round_noise(&rounds[..1], 2), 0.0);
    }
}

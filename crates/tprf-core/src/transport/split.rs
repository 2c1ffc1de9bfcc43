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
//! Light vertices: the pilot runs with and without them (each with its own best
//! split, by the rule above) and keeps the one of least predicted work times variance
//! at `TARGET_SPP`: on where a light lights a wall the eye's paths bounce off (the
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
    // Per light-vertex choice: its split and the predicted work times variance.
    let candidates = light_vertex.iter().map(|&light_vertex| {
        let at = |splits| {
            let strategy = Strategy {
                splits,
                light_vertex,
            };
            pilot(renderer, axis, width, height, strategy)
        };
        if k_fixed != 0 {
            let (var, rays) = at(k_fixed);
            let strategy = Strategy {
                splits: k_fixed,
                light_vertex,
            };
            return (strategy, var * rays);
        }
        let (var_1, rays_1) = at(1);
        let (var_k, rays_k) = at(MAX_SPLITS);
        let k = MAX_SPLITS as f64;
        // var(k) = P + B / k and rays(k) = c1 + k c2, from k = 1 and k = MAX_SPLITS.
        let branches = (var_1 - var_k) * k / (k - 1.0);
        let prefix = var_1 - branches;
        let c2 = (rays_k - rays_1) / (k - 1.0);
        let c1 = rays_1 - c2;
        // The prefix's share at TARGET_SPP: its variance falls like n^-3/2 (stratified),
        // the branches' like n^-1.
        let prefix_at_target = prefix * (PILOT_SAMPLES as f64 / TARGET_SPP).sqrt();
        let cap = if renderer.has_projectors() {
            PROJECTOR_MAX_SPLITS
        } else {
            MAX_SPLITS
        };
        let splits = splits_for(c1, c2, prefix_at_target, branches, cap);
        let s = splits as f64;
        let work_x_variance = (c1 + s * c2) * (prefix_at_target + branches / s);
        let strategy = Strategy {
            splits,
            light_vertex,
        };
        (strategy, work_x_variance)
    });
    // The first of the least (a NaN estimate, from an empty pilot, never wins).
    candidates
        .reduce(|best, c| if c.1 < best.1 { c } else { best })
        .map_or(Strategy::PLAIN, |(s, _)| s)
}

/// The pilot of `strategy`: the variance of the mean of [`PILOT_SAMPLES`] samples,
/// summed over the bins of the grid's pixels, and the rays traced per sample. Both 0
/// for an empty film or window.
fn pilot(
    renderer: &Renderer,
    axis: &TimeAxis,
    width: usize,
    height: usize,
    strategy: Strategy,
) -> (f64, f64) {
    let t = axis.bins;
    if t == 0 || width == 0 || height == 0 {
        return (0.0, 0.0);
    }
    let (nx, ny) = (width.min(PILOT_SIDE), height.min(PILOT_SIDE));
    let seed = renderer.settings().seed;
    let n = PILOT_SAMPLES as f64;
    let r = REPLICAS as f64;
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
                    let mut rng = Sampler::new(seed, PILOT_STREAM + replica as u64, pixel);
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
    let variance = per_pixel.iter().map(|p| p.0).sum();
    let rays = per_pixel.iter().map(|p| p.1).sum::<u64>();
    let samples = (nx * ny * REPLICAS) as f64 * n;
    (variance, rays as f64 / samples)
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
}

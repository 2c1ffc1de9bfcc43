//! The ambient steady image: per pixel the radiance `A[p]` (W m^-2 sr^-1) that the
//! scene's ambient group (sun, sky, lamps tagged ambient: [`crate::scene::AmbientLights`])
//! sends to the camera, with no time. It is the steady-state rendering equation solved by
//! the same path tracer as the TPRF ([`Renderer`]'s BVH, surfaces and BSDFs), through a
//! sink that ignores arrival times (an infinite window) and with the ambient group as
//! the light table ([`Lights::ambient`]): point and spot lights and directional lights by
//! next-event estimation, the sky where a path escapes. Emissive surfaces are pulsed
//! lights and are dark here; the pulsed lights are not in it.
//!
//! The sky is found only where a BSDF-sampled path escapes, with no next-event estimate
//! of its own, and needs none for the surfaces this renderer has: for a constant sky
//! `L` over a Lambertian surface the sky term is `integral (rho / pi) L V(w) cos dw`, and
//! the BSDF's cosine sampling draws `w` with density `cos / pi`, so each escaping sample
//! weighs exactly `rho L` (the variance left is only the visibility `V`'s, which a sky
//! NEE sampling the same cosine lobe would share); a sky NEE with MIS would add a second
//! sample of the same density and nothing else. Where it could matter, a glossy lobe
//! narrower than the sky's visible cap, BSDF sampling is again the better density (a
//! narrow lobe finds the sky with the lobe's own weight). Measured: a plane under a sky
//! gives `rho L` at 16 spp to 1e-5, every path alike (`tests/ambient.rs`).
//!
//! The sensor adds it to every gate as a constant: `M_i += ambient_scale A[p] integral
//! Exposure_i(t) dt` (see `sensor`).
//!
//! Deterministic: sample `i` of pixel `p` is sample `i / 2` of stream `2 + i % 2` of
//! the render's seed (streams 0 and 1 are the film's halves), and each pixel is summed
//! by one task in order, so the image does not depend on the thread count. The two
//! streams are two independent halves, for an error estimate.

use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use super::integrator::{Renderer, Sink};
use super::lights::Lights;
use super::sampler::Sampler;

/// Streams of the ambient image's two halves (the film uses 0 and 1).
const STREAMS: [u64; 2] = [2, 3];

/// The ambient group's steady radiance per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct AmbientImage {
    pub width: usize,
    pub height: usize,
    /// Samples per pixel.
    pub spp: u32,
    /// Radiance per pixel, W m^-2 sr^-1, `[H, W]` row-major, row 0 = top.
    pub radiance: Vec<f32>,
    /// Relative RMS error of the image estimated from its two halves (as the film's
    /// `half_error_estimate`); `None` below 2 spp.
    pub error_estimate: Option<f64>,
    /// Contributions dropped for being NaN or infinite.
    pub non_finite: u64,
}

/// Adds every contribution, whenever it arrives.
#[derive(Default)]
struct SteadySink {
    sum: f64,
    non_finite: u64,
}

impl Sink for SteadySink {
    #[inline]
    fn add(&mut self, _arrival_s: f64, value: f64, _scatterings: u32) {
        if value.is_finite() {
            self.sum += value;
        } else {
            self.non_finite += 1;
        }
    }
    #[inline]
    fn window_end_s(&self) -> f64 {
        f64::INFINITY
    }
}

/// One row's tally: NaN/infinite contributions, and the two-half error terms
/// `sum (a - b)^2` and `sum m^2` over its pixels.
#[derive(Clone, Copy, Default)]
struct RowTally {
    non_finite: u64,
    diff2: f64,
    norm2: f64,
}

/// Whether `renderer`'s scene has anything in its ambient group.
pub fn has_ambient(renderer: &Renderer) -> bool {
    !renderer.scene().ambient.is_empty()
}

/// The ambient image of `renderer`'s scene at `width x height`, `spp` samples per pixel,
/// rows in parallel on the current rayon pool. An empty ambient group gives zeros.
pub fn render_ambient(renderer: &Renderer, width: usize, height: usize, spp: u32) -> AmbientImage {
    render(renderer, width, height, spp, &AtomicBool::new(false))
}

/// [`render_ambient`] that stops (returning `None`) soon after `cancel` is set: it is
/// checked before each row.
pub fn render_ambient_cancellable(
    renderer: &Renderer,
    width: usize,
    height: usize,
    spp: u32,
    cancel: &AtomicBool,
) -> Option<AmbientImage> {
    let image = render(renderer, width, height, spp, cancel);
    (!cancel.load(Ordering::Relaxed)).then_some(image)
}

/// The image; rows not started once `cancel` is set are left black.
fn render(
    renderer: &Renderer,
    width: usize,
    height: usize,
    spp: u32,
    cancel: &AtomicBool,
) -> AmbientImage {
    let settings = renderer.settings();
    let lights = Lights::ambient(renderer.scene(), settings.channel);
    let seed = settings.seed;
    // Per pixel: the two halves' sums, and non-finite contributions.
    // Per pixel the image (4 bytes); per row the non-finite count and the two-half error
    // terms (summed in row order afterwards: the same for any thread count).
    let mut radiance = vec![0.0f32; width * height];
    let mut rows = vec![RowTally::default(); height];
    let counts = [spp.div_ceil(2), spp / 2];
    let (na, nb) = (f64::from(counts[0]), f64::from(counts[1]));
    let n = f64::from(spp.max(1));
    radiance
        .par_chunks_mut(width.max(1))
        .zip(rows.par_iter_mut())
        .enumerate()
        .for_each(|(y, (row, tally))| {
            if cancel.load(Ordering::Relaxed) {
                return;
            }
            for (x, px) in row.iter_mut().enumerate() {
                let pixel = (y * width + x) as u64;
                let mut sums = [0.0f64; 2];
                for (h, sum) in sums.iter_mut().enumerate() {
                    let mut rng = Sampler::new(seed, STREAMS[h], pixel);
                    let mut sink = SteadySink::default();
                    for _ in 0..counts[h] {
                        rng.start_sample();
                        let (jx, jy) = rng.get2(super::sampler::dim::CAMERA);
                        let (o, d) =
                            renderer.camera_ray(x as f32 + jx, y as f32 + jy, width, height);
                        renderer.trace::<true>(&lights, o, d, &mut rng, &mut sink);
                    }
                    *sum = sink.sum;
                    tally.non_finite += sink.non_finite;
                }
                let m = (sums[0] + sums[1]) / n;
                *px = m as f32;
                if counts[1] > 0 {
                    let (a, b) = (sums[0] / na, sums[1] / nb);
                    tally.diff2 += (a - b) * (a - b);
                    tally.norm2 += m * m;
                }
            }
        });
    let (diff2, norm2) = rows
        .iter()
        .fold((0.0, 0.0), |acc, r| (acc.0 + r.diff2, acc.1 + r.norm2));
    // As the film's `half_error_estimate`: relative RMS of the full image.
    let error_estimate = (counts[1] > 0).then(|| {
        if norm2 == 0.0 {
            0.0
        } else {
            diff2.sqrt() * (na * nb).sqrt() / n / norm2.sqrt()
        }
    });
    let non_finite = rows.iter().map(|r| r.non_finite).sum();
    AmbientImage {
        width,
        height,
        spp,
        radiance,
        error_estimate,
        non_finite,
    }
}

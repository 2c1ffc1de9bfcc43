//! The Henyey-Greenstein phase function: scattering `S` at a point of a medium, the
//! volume's counterpart of the BSDF. It takes no time.
//!
//! `p(cos theta) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^(3/2))`, per steradian,
//! with `theta` the angle between the light's direction of travel before and after the
//! event (`cos theta = 1`: straight on); it integrates to 1 over the sphere and its mean
//! cosine is `g`. Sampled exactly (its CDF inverts in closed form), so a sampled
//! direction's weight `p / pdf` is 1.

use crate::transport::bsdf::{Frame, turn_cos_sin};
use glam::Vec3;
use std::f32::consts::PI;

/// Below this `|g|` the phase function is sampled as isotropic (the closed form divides by g).
const ISOTROPIC_G: f32 = 1e-3;

/// `p(cos theta)` for asymmetry `g`, 1/sr.
#[inline]
pub fn hg(cos_theta: f32, g: f32) -> f32 {
    let denom = (1.0 + g * g - 2.0 * g * cos_theta).max(1e-12);
    (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
}

/// A direction of travel after scattering light travelling along unit `dir`, for
/// `(u1, u2)` in [0, 1)^2; its density is [`hg`] of its cosine with `dir`.
#[inline]
pub fn sample_hg(dir: Vec3, g: f32, (u1, u2): (f32, f32)) -> Vec3 {
    let cos_t = if g.abs() < ISOTROPIC_G {
        1.0 - 2.0 * u1
    } else {
        // Inverse CDF: cos = (1 + g^2 - ((1 - g^2) / (1 - g + 2 g u))^2) / (2 g).
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u1);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let (c, s) = turn_cos_sin(u2);
    Frame::new(dir).to_world(Vec3::new(sin_t * c, sin_t * s, cos_t))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The density integrates to 1 and has mean cosine g (midpoint rule in cos theta).
    #[test]
    fn normalised_with_mean_cosine_g() {
        for g in [-0.9f32, -0.3, 0.0, 0.5, 0.9, 0.99] {
            let n = 400_000;
            let (mut total, mut mean) = (0.0f64, 0.0f64);
            for i in 0..n {
                let c = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
                let p = hg(c as f32, g) as f64 * 2.0 * std::f64::consts::PI * 2.0 / n as f64;
                total += p;
                mean += p * c;
            }
            assert!((total - 1.0).abs() < 1e-3, "g {g}: integral {total}");
            assert!((mean - g as f64).abs() < 2e-3, "g {g}: mean cosine {mean}");
        }
        // Isotropic: 1 / (4 pi) everywhere.
        assert!((hg(0.3, 0.0) - 1.0 / (4.0 * PI)).abs() < 1e-7);
    }

    /// Sampled directions are unit, their cosines follow the density (chi-square over
    /// bins of cos theta), their mean cosine is g, and the azimuth is uniform.
    #[test]
    fn sampling_follows_the_density() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let dir = Vec3::new(0.3, -0.5, 0.8).normalize();
        for g in [-0.7f32, 0.0, 0.0005, 0.6, 0.95] {
            let n = 200_000;
            let bins = 40;
            let mut hist = vec![0u32; bins];
            let (mut mean, mut side) = (0.0f64, 0i64);
            let frame = Frame::new(dir);
            for _ in 0..n {
                let w = sample_hg(dir, g, (rng.random(), rng.random()));
                assert!((w.length() - 1.0).abs() < 1e-5);
                let c = w.dot(dir).clamp(-1.0, 1.0);
                mean += c as f64;
                hist[(((c + 1.0) * 0.5 * bins as f32) as usize).min(bins - 1)] += 1;
                side += if frame.to_local(w).x > 0.0 { 1 } else { -1 };
            }
            mean /= n as f64;
            assert!((mean - g as f64).abs() < 0.01, "g {g}: mean cosine {mean}");
            assert!(side.abs() < 2000, "g {g}: azimuth not uniform ({side})");
            // Expected counts by integrating the density over each bin (fine midpoints).
            let mut chi2 = 0.0;
            let mut dof = 0;
            for (b, &count) in hist.iter().enumerate() {
                let (lo, hi) = (
                    -1.0 + 2.0 * b as f64 / bins as f64,
                    -1.0 + 2.0 * (b + 1) as f64 / bins as f64,
                );
                let m = 200;
                let p: f64 = (0..m)
                    .map(|k| {
                        let c = lo + (k as f64 + 0.5) * (hi - lo) / m as f64;
                        hg(c as f32, g) as f64 * 2.0 * std::f64::consts::PI * (hi - lo) / m as f64
                    })
                    .sum();
                let e = p * n as f64;
                if e > 5.0 {
                    chi2 += (count as f64 - e).powi(2) / e;
                    dof += 1;
                }
            }
            // 40 bins: the 99.99th percentile of chi-square is under 90.
            assert!(chi2 < 90.0, "g {g}: chi-square {chi2} over {dof} bins");
        }
    }
}

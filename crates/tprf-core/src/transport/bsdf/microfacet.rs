//! Microfacet normal distributions as Mitsuba 3 defines them
//! (`include/mitsuba/render/microfacet.h`), isotropic: Beckmann and GGX, their Smith
//! masking, and sampling of `D(m) cos(theta_m)`. Directions in the local shading frame
//! (normal = +Z).

use super::turn_cos_sin;
use crate::scene::MicrofacetDistribution;
use glam::Vec3;
use std::f32::consts::PI;

/// The smallest alpha Mitsuba builds a distribution with (`configure()` clamps to it).
pub const MIN_ALPHA: f32 = 1e-4;

/// One isotropic distribution of microfacet normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub kind: MicrofacetDistribution,
    /// Roughness, at least [`MIN_ALPHA`].
    pub alpha: f32,
}

impl Microfacet {
    pub fn new(kind: MicrofacetDistribution, alpha: f32) -> Microfacet {
        Microfacet {
            kind,
            alpha: if alpha.is_finite() {
                alpha.max(MIN_ALPHA)
            } else {
                MIN_ALPHA
            },
        }
    }

    /// The normal distribution `D(m)`, 1/sr over the microfacet normal's solid angle
    /// (projected: `int D(m) cos(theta_m) dm = 1`). Beckmann:
    /// `exp(-tan^2(theta) / alpha^2) / (pi alpha^2 cos^4(theta))`; GGX:
    /// `1 / (pi alpha^2 ((m_x^2 + m_y^2) / alpha^2 + m_z^2)^2)`. 0 below the surface.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        let c2 = m.z * m.z;
        let xy = (m.x * m.x + m.y * m.y) / a2;
        let d = match self.kind {
            MicrofacetDistribution::Beckmann => (-xy / c2).exp() / (PI * a2 * c2 * c2),
            MicrofacetDistribution::Ggx => {
                let t = xy + c2;
                1.0 / (PI * a2 * t * t)
            }
        };
        if d * m.z > 1e-20 { d } else { 0.0 }
    }

    /// Smith's masking `G1(v, m)` of direction `v` for microfacet normal `m`: for GGX
    /// `2 / (1 + sqrt(1 + alpha^2 tan^2(theta_v)))`, for Beckmann Walter et al.'s
    /// rational fit in `a = 1 / (alpha tan(theta_v))` (1 for `a >= 1.6`, else
    /// `(3.535 a + 2.181 a^2) / (1 + 2.276 a + 2.577 a^2)`), as Mitsuba; 0 where `v`
    /// sees the back of `m`.
    #[inline]
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy = self.alpha * self.alpha * (v.x * v.x + v.y * v.y);
        if xy == 0.0 {
            return 1.0;
        }
        let t2 = xy / (v.z * v.z);
        match self.kind {
            MicrofacetDistribution::Beckmann => {
                let a = 1.0 / t2.sqrt();
                if a >= 1.6 {
                    1.0
                } else {
                    let a2 = a * a;
                    (3.535 * a + 2.181 * a2) / (1.0 + 2.276 * a + 2.577 * a2)
                }
            }
            MicrofacetDistribution::Ggx => 2.0 / (1.0 + (1.0 + t2).sqrt()),
        }
    }

    /// A microfacet normal drawn with density `D(m) cos(theta_m)` (1/sr; see
    /// [`Microfacet::pdf`]) from uniform numbers in [0, 1): `tan^2(theta) = -alpha^2
    /// ln(1 - u1)` (Beckmann) or `alpha^2 u1 / (1 - u1)` (GGX), azimuth `2 pi u2`.
    #[inline]
    pub fn sample(&self, u1: f32, u2: f32) -> Vec3 {
        let a2 = self.alpha * self.alpha;
        let tan2 = match self.kind {
            MicrofacetDistribution::Beckmann => -a2 * (1.0 - u1).max(1e-30).ln(),
            MicrofacetDistribution::Ggx => a2 * u1 / (1.0 - u1).max(1e-30),
        };
        let cos = 1.0 / (1.0 + tan2).sqrt();
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let (c, s) = turn_cos_sin(u2);
        Vec3::new(sin * c, sin * s, cos)
    }

    /// The density of [`Microfacet::sample`]: `D(m) cos(theta_m)`, 1/sr.
    #[inline]
    pub fn pdf(&self, m: Vec3) -> f32 {
        self.d(m) * m.z
    }
}

/// The mirror of `wo` about the unit normal `m`.
#[inline]
pub fn reflect(wo: Vec3, m: Vec3) -> Vec3 {
    2.0 * wo.dot(m) * m - wo
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::sampler::Sampler;

    fn uniform_hemisphere(u1: f32, u2: f32) -> Vec3 {
        let r = (1.0 - u1 * u1).max(0.0).sqrt();
        let (c, s) = turn_cos_sin(u2);
        Vec3::new(r * c, r * s, u1)
    }

    /// The projected distribution integrates to 1 (uniform sampling of the hemisphere),
    /// and the sampler's histogram of `cos(theta_m)` follows `D cos`.
    #[test]
    fn distributions_are_normalised_and_sampled_as_stated() {
        for kind in [
            MicrofacetDistribution::Beckmann,
            MicrofacetDistribution::Ggx,
        ] {
            for alpha in [0.1f32, 0.3, 0.8] {
                let mf = Microfacet::new(kind, alpha);
                // Stratified in cos(theta) (the peak is narrow): int D cos dm.
                let (nt, np) = (20_000, 16);
                let mut sum = 0.0f64;
                for i in 0..nt {
                    for j in 0..np {
                        let m = uniform_hemisphere(
                            (i as f32 + 0.5) / nt as f32,
                            (j as f32 + 0.5) / np as f32,
                        );
                        sum += (mf.d(m) * m.z) as f64;
                    }
                }
                let integral = sum * 2.0 * std::f64::consts::PI / (nt * np) as f64;
                assert!(
                    (integral - 1.0).abs() < 2e-3,
                    "{kind:?} {alpha}: {integral}"
                );
                // Fraction of sampled normals with cos < 0.95 against the integral of
                // D cos over that cap's complement.
                let mut rng = Sampler::new(4, 5, 6);
                let n = 100_000;
                let below = (0..n)
                    .filter(|_| {
                        rng.start_sample();
                        let (u1, u2) = rng.get2(0);
                        mf.sample(u1, u2).z < 0.95
                    })
                    .count() as f64
                    / n as f64;
                let mut expect = 0.0f64;
                for i in 0..nt {
                    let c = 0.95 * (i as f64 + 0.5) / nt as f64;
                    let m = Vec3::new((1.0 - c * c).sqrt() as f32, 0.0, c as f32);
                    expect +=
                        (mf.d(m) * m.z) as f64 * 2.0 * std::f64::consts::PI * 0.95 / nt as f64;
                }
                assert!(
                    (below - expect).abs() < 4e-3,
                    "{kind:?} {alpha}: sampled {below}, expected {expect}"
                );
            }
        }
    }

    /// Smith's G1 is the projected-area ratio: `int G1(v, m) max(0, v.m) D(m) dm =
    /// cos(theta_v)` (exact for GGX; within Mitsuba's stated 0.35 % for Beckmann's fit).
    #[test]
    fn masking_conserves_projected_area() {
        for kind in [
            MicrofacetDistribution::Beckmann,
            MicrofacetDistribution::Ggx,
        ] {
            let mf = Microfacet::new(kind, 0.5);
            for cos_v in [0.2f32, 0.6, 0.95] {
                let v = Vec3::new((1.0 - cos_v * cos_v).sqrt(), 0.0, cos_v);
                let (nt, np) = (4000, 256);
                let mut sum = 0.0f64;
                for i in 0..nt {
                    for j in 0..np {
                        let m = uniform_hemisphere(
                            (i as f32 + 0.5) / nt as f32,
                            (j as f32 + 0.5) / np as f32,
                        );
                        sum += (mf.g1(v, m) * v.dot(m).max(0.0) * mf.d(m)) as f64;
                    }
                }
                let projected = sum * 2.0 * std::f64::consts::PI / (nt * np) as f64;
                assert!(
                    (projected - cos_v as f64).abs() < 0.005 * cos_v as f64,
                    "{kind:?} cos {cos_v}: {projected}"
                );
            }
        }
    }
}

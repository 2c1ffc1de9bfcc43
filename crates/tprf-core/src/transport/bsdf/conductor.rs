//! Mitsuba 3's `conductor` and `roughconductor` (`src/bsdfs/conductor.cpp`,
//! `roughconductor.cpp`): the Fresnel reflectance of a conductor of complex index
//! `eta + i k` times `specular_reflectance`, from a mirror (smooth) or from microfacets
//! (`F(wo.h) D(h) G1(wo, h) G1(wi, h) / (4 cos_o cos_i)`, rough).

use super::fresnel::fresnel_conductor;
use super::microfacet::{Microfacet, reflect};
use super::{BsdfSample, LobeKind};
use glam::Vec3;

/// The BSDF of a conductor, one band.
#[derive(Clone, Copy, Debug)]
pub struct Conductor {
    /// Complex relative index `eta + i k` in this band.
    pub(super) eta: f32,
    pub(super) k: f32,
    /// `specular_reflectance`.
    pub(super) specular: f32,
    /// `None`: a smooth conductor.
    pub(super) rough: Option<Microfacet>,
}

impl Conductor {
    pub fn new(eta: f32, k: f32, specular: f32, rough: Option<Microfacet>) -> Conductor {
        Conductor {
            eta,
            k,
            specular: specular.max(0.0),
            rough,
        }
    }

    pub fn has_smooth_lobe(&self) -> bool {
        self.rough.is_some()
    }

    /// `f(wo, wi)` (1/sr) and the pdf of sampling `wi` (1/sr); zero for a mirror and when
    /// either direction is below the surface.
    // Out of line: the metallic-roughness lobes' inlined dispatch stays as small as before.
    #[inline(never)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        let Some(mf) = self.rough else {
            return (0.0, 0.0);
        };
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (0.0, 0.0);
        }
        let h = (wo + wi).normalize();
        let c = wo.dot(h).max(1e-8);
        let d = mf.d(h);
        let g = mf.g1(wo, h) * mf.g1(wi, h);
        let fr = fresnel_conductor(c, self.eta, self.k);
        (
            self.specular * fr * d * g / (4.0 * wo.z * wi.z),
            mf.pdf(h) / (4.0 * c),
        )
    }

    /// Sample an incident direction for outgoing `wo` from `(u1, u2)`.
    #[inline(never)]
    pub fn sample(&self, wo: Vec3, (u1, u2): (f32, f32)) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let Some(mf) = self.rough else {
            return Some(BsdfSample {
                wi: Vec3::new(-wo.x, -wo.y, wo.z),
                weight: self.specular * fresnel_conductor(wo.z, self.eta, self.k),
                pdf: 0.0,
                kind: LobeKind::Mirror,
            });
        };
        let wi = reflect(wo, mf.sample(u1, u2));
        if wi.z <= 0.0 {
            return None;
        }
        let (f, pdf) = self.eval(wo, wi);
        (pdf > 0.0 && f > 0.0).then(|| BsdfSample {
            wi,
            weight: f * wi.z / pdf,
            pdf,
            kind: LobeKind::Glossy,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::MicrofacetDistribution;
    use crate::transport::bsdf::{BandModel, Bsdf, test_support::*};

    fn conductor(eta: f32, k: f32, rough: Option<(MicrofacetDistribution, f32)>) -> Bsdf {
        let c = Conductor::new(eta, k, 1.0, rough.map(|(d, a)| Microfacet::new(d, a)));
        Bsdf::build(&BandModel::Conductor(c), &params_for_tests(), true)
    }

    /// The smooth conductor reflects `F(cos_o)` into the mirror direction, the reflectance
    /// at normal incidence `((n - 1)^2 + k^2) / ((n + 1)^2 + k^2)` (brass of the
    /// staircase, luminance of its RGB eta and k).
    #[test]
    fn smooth_conductor_is_a_fresnel_mirror() {
        let (n, k) = (2.2129f32, 2.2399f32);
        let b = conductor(n, k, None);
        let s = b.sample(Vec3::Z, 0.5, (0.3, 0.3)).expect("a mirror sample");
        let r0 = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!(s.is_delta() && (s.weight - r0).abs() < 1e-6 && s.wi == Vec3::Z);
        assert_eq!(b.eval(Vec3::Z, Vec3::Z), (0.0, 0.0));
        assert!(!b.has_smooth_lobe());
    }

    /// Rough conductors: sampled albedo equals the uniform integral of `f cos`; with
    /// `F = 1` (Mitsuba's default eta 0, k 1) and a small alpha the albedo at normal
    /// incidence is that of the microfacet lobe alone, `int D G1 G1 / (4 cos_o) dm`-ish,
    /// close to 1; and `f` at a chosen pair equals `F D G1 G1 / (4 cos cos)` evaluated by
    /// hand for GGX.
    #[test]
    fn rough_conductor_sampling_agrees_with_eval_and_formula() {
        for kind in [
            MicrofacetDistribution::Beckmann,
            MicrofacetDistribution::Ggx,
        ] {
            for alpha in [0.1f32, 0.5] {
                let b = conductor(0.0, 1.0, Some((kind, alpha)));
                for co in [1.0f32, 0.5] {
                    let wo = Vec3::new((1.0 - co * co).sqrt(), 0.0, co);
                    let (sampled, uniform, pdf_sum) = albedo_both_ways(&b, wo);
                    assert!(
                        (sampled - uniform).abs() < 0.01 * uniform,
                        "{kind:?} {alpha} cos {co}: {sampled} vs {uniform}"
                    );
                    assert!(pdf_sum < 1.005 && sampled < 1.005);
                    if alpha == 0.1 && co == 1.0 {
                        assert!(sampled > 0.985, "white furnace {sampled}");
                    }
                }
            }
        }
        // GGX by hand: wo = wi at 60 degrees on opposite azimuths -> h = +Z.
        let (a, c) = (0.3f64, 0.5f64);
        let s = (1.0 - c * c).sqrt();
        let wo = Vec3::new(s as f32, 0.0, c as f32);
        let wi = Vec3::new(-s as f32, 0.0, c as f32);
        let d = 1.0 / (std::f64::consts::PI * a * a); // D(+Z) = 1 / (pi a^2)
        let tan2 = s * s / (c * c);
        let g1 = 2.0 / (1.0 + (1.0 + a * a * tan2).sqrt());
        let (n, k) = (1.5f32, 3.0f32);
        let fr = super::super::fresnel::fresnel_conductor(c as f32, n, k) as f64;
        let expect = fr * d * g1 * g1 / (4.0 * c * c);
        let (f, _) = conductor(n, k, Some((MicrofacetDistribution::Ggx, a as f32))).eval(wo, wi);
        assert!((f as f64 - expect).abs() < 1e-5 * expect, "{f} vs {expect}");
    }
}

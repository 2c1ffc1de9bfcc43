//! Polarized evaluation of the BSDFs: Mueller matrices in place of the scalar `f`, as
//! Mitsuba 3's polarized variants evaluate its plugins. Conductors (smooth, and rough
//! with the microfacet's Fresnel in its own frame: Mitsuba's `conductor`,
//! `roughconductor`) and the smooth dielectric lobe (glTF transmission, which is what
//! Mitsuba's `dielectric` is read as) are Fresnel Mueller matrices
//! ([`crate::transport::polarization::fresnel`]); every other lobe depolarizes (an
//! ideal depolarizer of the scalar value), as Mitsuba's `diffuse`, `principled`,
//! `plastic`, `roughplastic` and `roughdielectric` do in its polarized variants (glTF's
//! Schlick specular has no complex index to polarize with).
//!
//! Frames: a matrix here takes light arriving along `-wi` in the implicit frame
//! `stokes_basis(-wi)` to light leaving along `wo` in `stokes_basis(wo)`, both in the
//! local shading frame (Mitsuba's BSDF frames, with its `wo_hat = wi`, `wi_hat = wo` of
//! radiance transport); [`to_world_mueller`] re-expresses it between the world's
//! implicit frames (Mitsuba's `SurfaceInteraction::to_world_mueller`).

use super::conductor::Conductor;
use super::{Bsdf, BsdfSample, Frame, LobeKind, Model};
use crate::transport::polarization::Mueller;
use crate::transport::polarization::frames::{rotate_mueller_basis, stokes_basis};
use crate::transport::polarization::fresnel::{specular_reflection, specular_transmission};
use glam::Vec3;

/// Fresnel matrix `m`, whose frames have the s direction `n x dir` as `x` (`n` the
/// normal of the reflecting or refracting plane), re-expressed in the implicit frames of
/// light arriving along `-wi` and leaving along `wo` (Mitsuba's `s_axis_in`,
/// `s_axis_out`; where the light runs along `n` either is `(1, 0, 0)`).
fn in_implicit_frames(m: &Mueller, n: Vec3, wi: Vec3, wo: Vec3) -> Mueller {
    let s_in = n.cross(-wi);
    let (s_in, s_out) = if s_in == Vec3::ZERO {
        (Vec3::X, Vec3::X)
    } else {
        (s_in.normalize(), n.cross(wo).normalize_or(Vec3::X))
    };
    rotate_mueller_basis(m, -wi, s_in, stokes_basis(-wi), wo, s_out, stokes_basis(wo))
}

impl Conductor {
    /// The Mueller `f(wo, wi)` (1/sr) of a rough conductor: `specular F(wi . h) D(h)
    /// G1(wo, h) G1(wi, h) / (4 cos_o cos_i)`, `F` the conductor's reflection matrix about
    /// the half vector `h`; zero for a mirror and below the surface.
    fn eval_mueller(&self, wo: Vec3, wi: Vec3) -> Mueller {
        let Some(mf) = self.rough else {
            return Mueller::ZERO;
        };
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Mueller::ZERO;
        }
        let h = (wo + wi).normalize();
        let c = wi.dot(h).max(1e-8);
        let scale = self.specular * mf.d(h) * mf.g1(wo, h) * mf.g1(wi, h) / (4.0 * wo.z * wi.z);
        in_implicit_frames(&specular_reflection(c, self.eta, self.k), h, wi, wo) * scale
    }
}

impl Bsdf {
    /// The Mueller matrix of `f(wo, wi)` of the non-delta lobes (1/sr), local frames as
    /// the module says; its `M00` is [`Bsdf::eval`]'s `f`.
    pub fn eval_mueller(&self, wo: Vec3, wi: Vec3) -> Mueller {
        match &self.0 {
            Model::Conductor(c) => c.eval_mueller(wo, wi),
            _ => Mueller::depolarizer(self.eval(wo, wi).0),
        }
    }

    /// The Mueller path weight of sample `bs` drawn for `wo`: the chosen lobe's matrix
    /// (for a non-delta sample, [`Bsdf::eval_mueller`]; for a delta lobe its Fresnel
    /// matrix, or a depolarizer) scaled so that its `M00` is `bs.weight`, the scalar
    /// weight `f |cos| / pdf`: the polarized path then takes the same sampling decisions
    /// with the same intensity weights, and only the polarization state differs. Zero
    /// where the lobe's matrix has no `M00`.
    pub fn sample_weight_mueller(&self, wo: Vec3, bs: &BsdfSample) -> Mueller {
        let shape = match (&self.0, bs.kind) {
            (_, LobeKind::Diffuse | LobeKind::Glossy) => self.eval_mueller(wo, bs.wi),
            (Model::Conductor(c), LobeKind::Mirror) => in_implicit_frames(
                &specular_reflection(bs.wi.z, c.eta, c.k),
                Vec3::Z,
                bs.wi,
                wo,
            ),
            // The smooth dielectric lobe: `eta` there is n(wo side) / n(other side), the
            // Fresnel code's the reciprocal (n beyond the interface over n where `wi`
            // points: for a refraction `wi.z < 0` and it takes the reciprocal again).
            (Model::MetallicRoughness(m), LobeKind::Reflect) => in_implicit_frames(
                &specular_reflection(bs.wi.z, 1.0 / m.eta, 0.0),
                Vec3::Z,
                bs.wi,
                wo,
            ),
            (Model::MetallicRoughness(m), LobeKind::Refract) => in_implicit_frames(
                &specular_transmission(bs.wi.z, 1.0 / m.eta),
                Vec3::Z,
                bs.wi,
                wo,
            ),
            _ => Mueller::depolarizer(1.0),
        };
        let m00 = shape.0[0][0];
        if m00 > 0.0 && m00.is_finite() {
            shape * (bs.weight / m00)
        } else {
            Mueller::ZERO
        }
    }
}

/// `m`, a matrix in the local implicit frames of light arriving along local `-wi` and
/// leaving along local `wo`, re-expressed between the world's implicit frames of the
/// same two beams (`stokes_basis` of the world directions): Mitsuba's
/// `to_world_mueller`.
pub fn to_world_mueller(frame: &Frame, m: &Mueller, wi: Vec3, wo: Vec3) -> Mueller {
    let (in_local, out_local) = (-wi, wo);
    let in_world = frame.to_world(in_local).normalize();
    let out_world = frame.to_world(out_local).normalize();
    rotate_mueller_basis(
        m,
        in_world,
        frame.to_world(stokes_basis(in_local)),
        stokes_basis(in_world),
        out_world,
        frame.to_world(stokes_basis(out_local)),
        stokes_basis(out_world),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::MicrofacetDistribution;
    use crate::transport::bsdf::microfacet::{Microfacet, reflect};
    use crate::transport::bsdf::test_support::params_for_tests;
    use crate::transport::bsdf::{BandModel, BsdfParams, turn_cos_sin};
    use crate::transport::polarization::Stokes;
    use crate::transport::sampler::Sampler;

    fn conductor(eta: f32, k: f32, alpha: Option<f32>) -> Bsdf {
        let c = Conductor::new(
            eta,
            k,
            0.9,
            alpha.map(|a| Microfacet::new(MicrofacetDistribution::Ggx, a)),
        );
        Bsdf::build(&BandModel::Conductor(c), &params_for_tests(), true)
    }

    fn glass(front: bool) -> Bsdf {
        let p = BsdfParams {
            base: 1.0,
            roughness: 0.0,
            specular_factor: 1.0,
            transmission: 1.0,
            ior: 1.5,
            ..params_for_tests()
        };
        Bsdf::build(&BandModel::MetallicRoughness, &p, front)
    }

    fn models() -> Vec<Bsdf> {
        vec![
            conductor(0.18, 3.42, None),
            conductor(0.18, 3.42, Some(0.3)),
            conductor(1.2, 7.3, Some(0.05)),
            glass(true),
            glass(false),
            Bsdf::new(&params_for_tests(), 1.0 / 1.5),
            Bsdf::new(
                &BsdfParams {
                    metallic: 0.5,
                    roughness: 0.4,
                    specular_factor: 1.0,
                    ..params_for_tests()
                },
                1.0 / 1.5,
            ),
        ]
    }

    /// Every sample's Mueller weight has the scalar weight as `M00`, and every evaluated
    /// matrix the scalar `f`; each maps physical Stokes vectors (unpolarized, linear at
    /// several angles, circular) to physical ones (`S0 >= |S1..S3|`): a physical Mueller
    /// matrix, over random directions for all the models.
    #[test]
    fn mueller_weights_extend_the_scalar_ones_and_stay_physical() {
        let inputs = [
            Stokes::unpolarized(1.0),
            Stokes::linear(1.0, 0.0),
            Stokes::linear(1.0, 0.7),
            Stokes::linear(1.0, -1.2),
            Stokes([1.0, 0.0, 0.0, 1.0]),
            Stokes([1.0, 0.0, 0.0, -1.0]),
        ];
        let mut rng = Sampler::new(4, 5, 6);
        let mut polarizing = 0;
        for b in models() {
            for _ in 0..2000 {
                rng.start_sample();
                let (u1, u2) = rng.get2(0);
                let z = u1.max(0.02);
                let r = (1.0 - z * z).sqrt();
                let (c, s) = turn_cos_sin(u2);
                let wo = Vec3::new(r * c, r * s, z);
                let Some(bs) = b.sample(wo, rng.get1(1), rng.get2(2)) else {
                    continue;
                };
                let m = b.sample_weight_mueller(wo, &bs);
                assert!(
                    (m.0[0][0] - bs.weight).abs() <= 1e-5 * bs.weight.max(1.0),
                    "{b:?} {bs:?}: {m:?}"
                );
                if !bs.is_delta() {
                    let e = b.eval_mueller(wo, bs.wi);
                    let f = b.eval(wo, bs.wi).0;
                    assert!(
                        (e.0[0][0] - f).abs() <= 1e-5 * f.max(1.0),
                        "{b:?}: {e:?} vs {f}"
                    );
                }
                for s in inputs {
                    let out = m.apply(s);
                    assert!(
                        out.is_physical(1e-4 * out.0[0].max(1.0)),
                        "{b:?} {bs:?}: {s:?} -> {out:?}"
                    );
                }
                if m.apply(Stokes::unpolarized(1.0)).dolp() > 0.01 {
                    polarizing += 1;
                }
            }
        }
        assert!(
            polarizing > 1000,
            "the Fresnel lobes polarize: {polarizing}"
        );
    }

    /// Light reflected by glass at Brewster's angle is fully polarized with its field
    /// perpendicular to the plane of incidence: the field direction read back from the
    /// Stokes vector in the frame of `wo` (`cos psi x + sin psi y`, `y = wo x x`) is
    /// along `n x wo`, found geometrically, for several azimuths. The Lambertian lobe
    /// turns polarized light into unpolarized light.
    #[test]
    fn brewster_reflection_polarizes_across_the_plane_of_incidence() {
        let theta_b = 1.5f32.atan();
        for phi in [0.0f32, 0.8, 2.0, 4.0] {
            let wo = Vec3::new(
                theta_b.sin() * phi.cos(),
                theta_b.sin() * phi.sin(),
                theta_b.cos(),
            );
            let b = glass(true);
            // u1 = 0 picks the reflection of the transmission lobe.
            let bs = b.sample(wo, 0.999, (0.0, 0.5)).expect("a reflection");
            assert_eq!(bs.kind, LobeKind::Reflect);
            assert!((bs.wi - reflect(wo, Vec3::Z)).length() < 1e-6);
            let s = b
                .sample_weight_mueller(wo, &bs)
                .apply(Stokes::unpolarized(1.0));
            assert!((s.dolp() - 1.0).abs() < 1e-3, "{phi}: {s:?}");
            let x = stokes_basis(wo);
            let y = wo.cross(x);
            let psi = s.aolp_rad();
            let field = x * psi.cos() + y * psi.sin();
            let s_dir = Vec3::Z.cross(wo).normalize();
            assert!(
                (field.dot(s_dir).abs() - 1.0).abs() < 1e-4,
                "{phi}: field {field}, s {s_dir}"
            );
        }
        let lambert = Bsdf::new(&params_for_tests(), 1.0 / 1.5);
        let wo = Vec3::new(0.3, 0.2, 0.9).normalize();
        let bs = lambert
            .sample(wo, 0.5, (0.3, 0.6))
            .expect("a diffuse sample");
        let out = lambert
            .sample_weight_mueller(wo, &bs)
            .apply(Stokes::linear(1.0, 0.4));
        assert!(
            out.dolp() == 0.0 && (out.0[0] - bs.weight).abs() < 1e-6,
            "{out:?}"
        );
    }

    /// The world matrix does not depend on the shading frame's tangents: a rough
    /// conductor evaluated for the same world directions in frames turned about the
    /// normal gives the same world Mueller matrix once [`to_world_mueller`] has
    /// re-expressed each.
    #[test]
    fn world_matrix_is_independent_of_the_tangent_frame() {
        let b = conductor(0.18, 3.42, Some(0.4));
        let n = Vec3::new(0.2, -0.5, 0.8).normalize();
        let base = Frame::new(n);
        // About 65 degrees from the normal on either side: the reflection polarizes.
        let wo_w = (0.45 * n + 0.9 * base.t + 0.1 * base.b).normalize();
        let wi_w = (0.45 * n - 0.9 * base.t + 0.2 * base.b).normalize();
        let mut first: Option<Mueller> = None;
        for turn in [0.0f32, 0.6, 2.1, 4.0] {
            let (s, c) = turn.sin_cos();
            let t = base.t * c + base.b * s;
            let frame = Frame {
                t,
                b: n.cross(t),
                n,
            };
            let (wo, wi) = (frame.to_local(wo_w), frame.to_local(wi_w));
            let world = to_world_mueller(&frame, &b.eval_mueller(wo, wi), wi, wo);
            assert!(world.apply(Stokes::unpolarized(1.0)).dolp() > 0.01);
            match first {
                None => first = Some(world),
                Some(f) => {
                    for (a, e) in world.0.iter().flatten().zip(f.0.iter().flatten()) {
                        assert!(
                            (a - e).abs() < 1e-4 * f.0[0][0],
                            "turn {turn}: {world:?} vs {f:?}"
                        );
                    }
                }
            }
        }
    }
}

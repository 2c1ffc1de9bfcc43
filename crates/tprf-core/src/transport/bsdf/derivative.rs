//! Derivatives of the BSDFs with respect to the base colour (the band's diffuse
//! reflectance `rho`), for differentiable rendering ([`crate::transport::derivative`]).
//!
//! Every model whose base colour is defined is affine in it at fixed sampling
//! probabilities: glTF metallic-roughness (`diffuse = (1 - metallic)(1 - transmission)
//! rho (1 - s F0_d)`, `F0 = metallic rho + ...`, the refraction tint `rho`), Mitsuba's
//! linear `plastic` (`rho / (1 - F_dr) / eta^2`); the `nonlinear` plastic has
//! `rho / (1 - rho F_dr) / eta^2`, whose derivative is `1 / (1 - rho F_dr)^2 / eta^2`.
//! A conductor has no base colour. [`Bsdf::d_base`] is the BSDF whose `f` is `df/drho`
//! with the lobe probabilities of the original, so that a sample drawn by the original
//! (sampling detached: its pdf a constant) has weight derivative
//! `df/drho |cos| / pdf` ([`Bsdf::detached_weights`]).

use super::plastic::Plastic;
use super::{BandModel, Bsdf, BsdfParams, BsdfSample, LobeKind, MetallicRoughness, Model, schlick};
use glam::Vec3;

impl Bsdf {
    /// Whether this is the absorbing back of a one-sided material.
    pub fn is_black(&self) -> bool {
        matches!(self.0, Model::Black)
    }

    /// Whether the model has a base colour (a conductor has none).
    pub fn has_base(&self) -> bool {
        !matches!(self.0, Model::Conductor(_))
    }

    /// `df/drho` of the BSDF [`Bsdf::build`] makes of `model` and `p` on side `front`:
    /// a BSDF-like value whose [`DBase::eval`] is the derivative of `f` with respect to
    /// the base colour `rho = p.base` (1/sr), with the original's lobe probabilities.
    /// `None` for a conductor, whose `f` does not depend on a base colour.
    pub fn d_base(model: &BandModel, p: &BsdfParams, front: bool) -> Option<DBase> {
        match model {
            BandModel::MetallicRoughness => {
                let b = MetallicRoughness::new(p, if front { 1.0 / p.ior } else { p.ior });
                let dielectric = 1.0 - p.metallic;
                let f0_dielectric =
                    (((p.ior - 1.0) / (p.ior + 1.0)).powi(2) * p.specular_color).min(1.0);
                Some(DBase(Model::MetallicRoughness(MetallicRoughness {
                    diffuse: dielectric
                        * (1.0 - p.transmission)
                        * (1.0 - p.specular_factor * f0_dielectric),
                    f0: p.metallic,
                    f90: 0.0,
                    tint: 1.0,
                    ..b
                })))
            }
            BandModel::Plastic(coat) => Some(DBase(Model::Plastic(Plastic::d_base(coat, p.base)))),
            BandModel::Conductor(_) => None,
        }
    }

    /// The value of a delta lobe of kind `kind` for outgoing `wo` (what its sample
    /// weight is divided by the lobe's probability from): a mirror's Fresnel
    /// reflectance, a dielectric's `transmission` (reflection) or `transmission x tint`
    /// (refraction), a smooth plastic's `specular x F`. 0 for a smooth lobe.
    fn delta_value(model: &Model, kind: LobeKind, wo: Vec3) -> f32 {
        match (model, kind) {
            (Model::MetallicRoughness(b), LobeKind::Mirror) => schlick(b.f0, b.f90, wo.z),
            (Model::MetallicRoughness(b), LobeKind::Reflect) => b.transmission,
            (Model::MetallicRoughness(b), LobeKind::Refract) => b.transmission * b.tint,
            (Model::Plastic(p), LobeKind::Mirror) => p.mirror_value(wo),
            _ => 0.0,
        }
    }

    /// The sample `s` drawn by `self` (the sampling BSDF) seen as a sample of `target`
    /// with sampling detached: `(weight, d weight / d rho)` for the path, `f |cos| /
    /// pdf` with `f` and `df/drho` the target's (`d`: its [`Bsdf::d_base`]) and `pdf`
    /// the sampler's. For a delta lobe, the sampler's weight times the ratio of the
    /// lobe's values (`delta_value`). `target` and `self` must be the same model
    /// (the sampler differs only in `rho`).
    pub fn detached_weights(
        &self,
        target: &Bsdf,
        d: Option<&DBase>,
        wo: Vec3,
        s: &BsdfSample,
    ) -> (f32, f32) {
        if s.is_delta() {
            let v_s = Bsdf::delta_value(&self.0, s.kind, wo);
            if !(v_s > 0.0) {
                return (0.0, 0.0);
            }
            let scale = s.weight / v_s;
            let v = Bsdf::delta_value(&target.0, s.kind, wo);
            // A dielectric's reflection (`transmission`) does not depend on `rho`.
            let dv = match (d, s.kind) {
                (Some(d), kind) if kind != LobeKind::Reflect => Bsdf::delta_value(&d.0, kind, wo),
                _ => 0.0,
            };
            return (v * scale, dv * scale);
        }
        if !(s.pdf > 0.0) {
            return (0.0, 0.0);
        }
        let cos = s.wi.z.abs();
        let (f, _) = target.eval(wo, s.wi);
        let df = d.map_or(0.0, |d| d.eval(wo, s.wi));
        (f * cos / s.pdf, df * cos / s.pdf)
    }
}

/// `df/drho` of a BSDF ([`Bsdf::d_base`]).
#[derive(Clone, Copy, Debug)]
pub struct DBase(Model);

impl DBase {
    /// `df/drho (wo, wi)` of the smooth lobes, 1/sr.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        Bsdf(self.0).eval(wo, wi).0
    }
}

//! Scattering `S` of the transient rendering equation: the BSDF at a surface point, in one
//! spectral band. Scattering takes no time; only propagation delays.
//!
//! Models (a material's [`crate::scene::SurfaceModel`]):
//! - glTF metallic-roughness: Lambertian diffuse, GGX microfacet specular (a mirror when
//!   the roughness is near 0) with a Schlick Fresnel that reaches 0 for
//!   `specularFactor = 0` on a dielectric (pure Lambertian), and a smooth dielectric
//!   transmission lobe;
//! - Mitsuba's `plastic` / `roughplastic` ([`plastic`]) and `conductor` /
//!   `roughconductor` ([`conductor`]), with Mitsuba's Fresnel terms ([`fresnel`]) and
//!   microfacet distributions ([`microfacet`]).
//!
//! Directions are in the local shading frame (normal = +Z), pointing away from the
//! surface.

pub mod conductor;
pub mod derivative;
pub mod fresnel;
pub mod microfacet;
pub mod plastic;
pub mod polarized;

pub use fresnel::fresnel_dielectric;

use crate::scene::SurfaceModel;
use conductor::Conductor;
use glam::Vec3;
use microfacet::Microfacet;
use plastic::{Plastic, PlasticCoat};
use std::f32::consts::PI;

/// GGX alpha below which the specular lobe is treated as a perfect mirror.
pub const MIRROR_ALPHA: f32 = 1e-3;

/// An orthonormal frame around a unit normal (Duff et al. 2017).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    pub fn new(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Frame {
            t: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            b: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// `(cos 2 pi u, sin 2 pi u)`: the point a fraction `u` of a turn round the unit circle,
/// for the azimuth of sampled directions. The angle is reduced exactly to `x` in
/// [-pi/4, pi/4] plus a whole number of quarter turns, and `sin x`, `cos x` are Cephes'
/// single-precision minimax polynomials; the quadrant's swap and signs are selects, not
/// branches. Within 2.5e-7 of the exact values for any `u` in [-2^20, 2^20] (tested), and
/// several times faster than libm's `sincosf`, which on the race's corner took 6 % of a
/// render.
#[inline]
pub fn turn_cos_sin(u: f32) -> (f32, f32) {
    let quarters = u * 4.0; // exact: a power-of-two scale
    // The nearest whole number (ties to even) for |quarters| <= 2^22: adding 1.5 * 2^23
    // leaves no fraction bits. (`round` is a libm call on baseline x86-64.)
    const ROUNDER: f32 = 12_582_912.0;
    let q = (quarters + ROUNDER) - ROUNDER;
    let x = (quarters - q) * std::f32::consts::FRAC_PI_2; // quarters - q is exact
    let x2 = x * x;
    let s = x + x * x2 * (-1.666_665_5e-1 + x2 * (8.332_161e-3 + x2 * -1.951_529_6e-4));
    let c =
        1.0 - 0.5 * x2 + x2 * x2 * (4.166_664_6e-2 + x2 * (-1.388_731_6e-3 + x2 * 2.443_315_7e-5));
    // cos(q pi/2 + x), sin(q pi/2 + x): odd quadrants swap c and s; cos is negative in
    // quadrants 1 and 2, sin in 2 and 3 (bit 31 is the sign).
    let q = q as i64 as u32;
    let (a, b) = if q & 1 == 1 { (s, c) } else { (c, s) };
    let cos = f32::from_bits(a.to_bits() ^ ((q.wrapping_add(1) & 2) << 30));
    let sin = f32::from_bits(b.to_bits() ^ ((q & 2) << 30));
    (cos, sin)
}

/// Which lobe produced a sampled direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LobeKind {
    Diffuse,
    Glossy,
    Mirror,
    Reflect,
    Refract,
}

/// A sampled direction and its path weight `f |cos| / pdf`.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub weight: f32,
    /// Solid-angle pdf of the whole (one-sample MIS over lobes) BSDF; 0 for delta lobes.
    pub pdf: f32,
    pub kind: LobeKind,
}

impl BsdfSample {
    pub fn is_delta(&self) -> bool {
        matches!(
            self.kind,
            LobeKind::Mirror | LobeKind::Reflect | LobeKind::Refract
        )
    }
}

/// The BSDF at one point, one band.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf(Model);

#[derive(Clone, Copy, Debug)]
enum Model {
    MetallicRoughness(MetallicRoughness),
    Plastic(Plastic),
    Conductor(Conductor),
    /// Absorbs everything: the back of a one-sided material.
    Black,
}

/// A material's model reduced to one band, with what does not vary over the surface
/// computed once (a rough plastic's coat tables).
#[derive(Clone, Copy, Debug)]
pub enum BandModel {
    MetallicRoughness,
    Plastic(PlasticCoat),
    /// Its index and reflectance in the band (they take no texture).
    Conductor(Conductor),
}

impl BandModel {
    /// `model` in the band that `pick` takes of an RGB triple; `base` and `specular`
    /// are the band's untextured base colour and specular colour (a plastic's sampling
    /// weight reads them).
    pub fn new(
        model: &SurfaceModel,
        pick: impl Fn([f32; 3]) -> f32,
        base: f32,
        specular: f32,
    ) -> BandModel {
        let rough = |m: &Option<crate::scene::Microfacet>| {
            m.map(|m| Microfacet::new(m.distribution, m.alpha))
        };
        match model {
            SurfaceModel::MetallicRoughness => BandModel::MetallicRoughness,
            SurfaceModel::Plastic {
                eta,
                microfacet,
                nonlinear,
            } => BandModel::Plastic(PlasticCoat::new(
                *eta,
                rough(microfacet),
                *nonlinear,
                base,
                specular,
            )),
            SurfaceModel::Conductor {
                eta,
                k,
                specular_reflectance,
                microfacet,
            } => BandModel::Conductor(Conductor::new(
                pick(*eta),
                pick(*k),
                pick(*specular_reflectance),
                rough(microfacet),
            )),
        }
    }
}

/// glTF's metallic-roughness BSDF.
#[derive(Clone, Copy, Debug)]
struct MetallicRoughness {
    /// Lambertian albedo (already weighted by metallic, transmission and specular loss).
    diffuse: f32,
    /// Schlick F0 and F90 of the combined metal/dielectric specular layer.
    f0: f32,
    f90: f32,
    /// GGX alpha = roughness^2.
    alpha: f32,
    /// Weight of the smooth dielectric transmission lobe, and its tint.
    transmission: f32,
    tint: f32,
    /// Relative index `n_incident / n_transmitted` seen from the `wo` side.
    eta: f32,
    p_diffuse: f32,
    p_spec: f32,
}

/// Material parameters at a point, one band, all in [0, 1] except `ior`.
#[derive(Clone, Copy, Debug)]
pub struct BsdfParams {
    pub base: f32,
    pub metallic: f32,
    pub roughness: f32,
    pub specular_factor: f32,
    pub specular_color: f32,
    pub transmission: f32,
    pub ior: f32,
}

#[inline]
fn schlick(f0: f32, f90: f32, cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    f0 + (f90 - f0) * m2 * m2 * m
}

/// GGX normal distribution D(h), `cos_h` = h.z.
#[inline]
fn ggx_d(alpha: f32, cos_h: f32) -> f32 {
    let a2 = alpha * alpha;
    let c2 = cos_h * cos_h;
    let den = c2 * (a2 - 1.0) + 1.0;
    a2 / (PI * den * den)
}

/// Smith G1 for GGX.
#[inline]
fn ggx_g1(alpha: f32, cos: f32) -> f32 {
    let a2 = alpha * alpha;
    let c2 = cos * cos;
    2.0 * cos / (cos + (a2 + (1.0 - a2) * c2).sqrt())
}

impl Bsdf {
    /// The glTF metallic-roughness BSDF of material parameters `p`. `eta` is `1 / ior`
    /// when `wo` is on the front (entering) side, `ior` when it is inside the medium.
    #[inline]
    pub fn new(p: &BsdfParams, eta: f32) -> Bsdf {
        Bsdf(Model::MetallicRoughness(MetallicRoughness::new(p, eta)))
    }

    /// A surface that absorbs all light (the back face of a one-sided material, as
    /// Mitsuba's one-sided BSDFs are black from behind): no lobe, nothing sampled.
    pub const BLACK: Bsdf = Bsdf(Model::Black);

    /// The BSDF of `model` with parameters `p` (textures applied), for `wo` on the front
    /// side (`front`) or the back.
    #[inline]
    pub fn build(model: &BandModel, p: &BsdfParams, front: bool) -> Bsdf {
        match model {
            BandModel::MetallicRoughness => Bsdf::new(p, if front { 1.0 / p.ior } else { p.ior }),
            BandModel::Plastic(coat) => {
                Bsdf(Model::Plastic(Plastic::new(coat, p.base, p.specular_color)))
            }
            BandModel::Conductor(c) => Bsdf(Model::Conductor(*c)),
        }
    }

    /// Whether one lobe is always sampled (then [`Bsdf::sample`] ignores `u_lobe`).
    #[inline]
    pub fn single_lobe(&self) -> bool {
        match &self.0 {
            Model::MetallicRoughness(b) => b.single_lobe(),
            Model::Plastic(_) => false,
            Model::Conductor(_) | Model::Black => true,
        }
    }

    /// Whether some lobe can be evaluated for a given direction pair (next-event
    /// estimation is useless otherwise).
    #[inline]
    pub fn has_smooth_lobe(&self) -> bool {
        match &self.0 {
            Model::MetallicRoughness(b) => b.has_smooth_lobe(),
            Model::Plastic(b) => b.has_smooth_lobe(),
            Model::Conductor(b) => b.has_smooth_lobe(),
            Model::Black => false,
        }
    }

    /// `f(wo, wi)` of the non-delta lobes (1/sr) and the one-sample pdf of sampling `wi`
    /// (1/sr). Both zero when either direction is below the surface.
    #[inline(always)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        match &self.0 {
            Model::MetallicRoughness(b) => b.eval(wo, wi),
            Model::Plastic(b) => b.eval(wo, wi),
            Model::Conductor(b) => b.eval(wo, wi),
            Model::Black => (0.0, 0.0),
        }
    }

    /// Sample an incident direction for outgoing `wo` (local frame) from uniform numbers
    /// in [0, 1): `u_lobe` picks the lobe, `(u1, u2)` the direction within it.
    #[inline(always)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: (f32, f32)) -> Option<BsdfSample> {
        match &self.0 {
            Model::MetallicRoughness(b) => b.sample(wo, u_lobe, u),
            Model::Plastic(b) => b.sample(wo, u_lobe, u),
            Model::Conductor(b) => b.sample(wo, u),
            Model::Black => None,
        }
    }
}

impl MetallicRoughness {
    fn new(p: &BsdfParams, eta: f32) -> MetallicRoughness {
        let dielectric = 1.0 - p.metallic;
        let f0_dielectric = (((p.ior - 1.0) / (p.ior + 1.0)).powi(2) * p.specular_color).min(1.0);
        let f0 = p.metallic * p.base + dielectric * p.specular_factor * f0_dielectric;
        let f90 = p.metallic + dielectric * p.specular_factor;
        let transmission = dielectric * p.transmission;
        let diffuse = dielectric
            * (1.0 - p.transmission)
            * p.base
            * (1.0 - p.specular_factor * f0_dielectric);
        let alpha = (p.roughness * p.roughness).max(0.0);
        let w_spec = 0.5 * (f0 + f90) * (1.0 - transmission);
        let total = diffuse + w_spec + transmission;
        let (p_diffuse, p_spec) = if total > 0.0 {
            (diffuse / total, w_spec / total)
        } else {
            (0.0, 0.0)
        };
        MetallicRoughness {
            diffuse,
            f0,
            f90,
            alpha,
            transmission,
            tint: p.base,
            eta,
            p_diffuse,
            p_spec,
        }
    }

    fn p_transmission(&self) -> f32 {
        (1.0 - self.p_diffuse - self.p_spec).max(0.0)
    }

    fn is_mirror(&self) -> bool {
        self.alpha < MIRROR_ALPHA
    }

    #[inline]
    fn single_lobe(&self) -> bool {
        self.p_diffuse >= 1.0 || self.p_spec >= 1.0 || self.p_diffuse + self.p_spec <= 0.0
    }

    fn has_smooth_lobe(&self) -> bool {
        self.p_diffuse > 0.0 || (self.p_spec > 0.0 && !self.is_mirror())
    }

    #[inline(always)]
    fn eval(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (0.0, 0.0);
        }
        let mut f = self.diffuse / PI;
        let mut pdf = self.p_diffuse * wi.z / PI;
        if self.p_spec > 0.0 && !self.is_mirror() {
            let h = (wo + wi).normalize();
            let d = ggx_d(self.alpha, h.z);
            let g = ggx_g1(self.alpha, wo.z) * ggx_g1(self.alpha, wi.z);
            let fr = schlick(self.f0, self.f90, wo.dot(h));
            f += fr * d * g / (4.0 * wo.z * wi.z);
            pdf += self.p_spec * d * h.z / (4.0 * wo.dot(h).max(1e-8));
        }
        (f, pdf)
    }

    #[inline(always)]
    fn sample(&self, wo: Vec3, u_lobe: f32, (u1, u2): (f32, f32)) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let u = u_lobe;
        let smooth_sample = |wi: Vec3, kind: LobeKind| -> Option<BsdfSample> {
            let (f, pdf) = self.eval(wo, wi);
            (pdf > 0.0 && f > 0.0).then(|| BsdfSample {
                wi,
                weight: f * wi.z / pdf,
                pdf,
                kind,
            })
        };
        if u < self.p_diffuse {
            // Cosine-weighted hemisphere.
            let r = u1.sqrt();
            let (cos_phi, sin_phi) = turn_cos_sin(u2);
            let wi = Vec3::new(r * cos_phi, r * sin_phi, (1.0 - u1).max(0.0).sqrt());
            smooth_sample(wi, LobeKind::Diffuse)
        } else if u < self.p_diffuse + self.p_spec {
            if self.is_mirror() {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                let fr = schlick(self.f0, self.f90, wo.z);
                return Some(BsdfSample {
                    wi,
                    weight: fr / self.p_spec,
                    pdf: 0.0,
                    kind: LobeKind::Mirror,
                });
            }
            // GGX: h ~ D(h) cos(theta_h).
            let a2 = self.alpha * self.alpha;
            let cos2 = (1.0 - u1) / (u1 * (a2 - 1.0) + 1.0);
            let cos_h = cos2.clamp(0.0, 1.0).sqrt();
            let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
            let (cos_phi, sin_phi) = turn_cos_sin(u2);
            let h = Vec3::new(sin_h * cos_phi, sin_h * sin_phi, cos_h);
            let wi = 2.0 * wo.dot(h) * h - wo;
            if wi.z <= 0.0 {
                return None;
            }
            smooth_sample(wi, LobeKind::Glossy)
        } else {
            let pt = self.p_transmission();
            if pt <= 0.0 {
                return None;
            }
            let fr = fresnel_dielectric(wo.z, self.eta);
            if u1 < fr {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                Some(BsdfSample {
                    wi,
                    weight: self.transmission / pt,
                    pdf: 0.0,
                    kind: LobeKind::Reflect,
                })
            } else {
                let sin2_t = self.eta * self.eta * (1.0 - wo.z * wo.z);
                let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
                let wi = Vec3::new(-self.eta * wo.x, -self.eta * wo.y, -cos_t).normalize();
                Some(BsdfSample {
                    wi,
                    weight: self.transmission * self.tint / pt,
                    pdf: 0.0,
                    kind: LobeKind::Refract,
                })
            }
        }
    }
}

/// What the lobes' tests share: plain parameters and the albedo of a BSDF found by
/// its own sampling and by uniform sampling of `f cos`.
#[cfg(test)]
pub(crate) mod test_support {
    use super::{Bsdf, BsdfParams};
    use crate::transport::sampler::Sampler;
    use glam::Vec3;

    pub fn params_for_tests() -> BsdfParams {
        BsdfParams {
            base: 0.5,
            metallic: 0.0,
            roughness: 1.0,
            specular_factor: 0.0,
            specular_color: 1.0,
            transmission: 0.0,
            ior: 1.5,
        }
    }

    /// `(E[weight] of Bsdf::sample, int f cos dw by uniform hemisphere sampling, int pdf
    /// dw)`, each from 400 000 samples.
    pub fn albedo_both_ways(b: &Bsdf, wo: Vec3) -> (f64, f64, f64) {
        let n = 400_000;
        let mut rng = Sampler::new(1, 2, 3);
        let mut sampled = 0.0f64;
        for _ in 0..n {
            rng.start_sample();
            if let Some(s) = b.sample(wo, rng.get1(0), rng.get2(1)) {
                sampled += s.weight as f64;
            }
        }
        let mut rng = Sampler::new(9, 9, 9);
        let (mut uniform, mut pdf) = (0.0f64, 0.0f64);
        for _ in 0..n {
            rng.start_sample();
            let (u1, u2) = rng.get2(0);
            let r = (1.0 - u1 * u1).max(0.0).sqrt();
            let (c, s) = super::turn_cos_sin(u2);
            let wi = Vec3::new(r * c, r * s, u1);
            let (f, p) = b.eval(wo, wi);
            uniform += (f * wi.z) as f64;
            pdf += p as f64;
        }
        let two_pi = 2.0 * std::f64::consts::PI;
        (
            sampled / n as f64,
            uniform * two_pi / n as f64,
            pdf * two_pi / n as f64,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::sampler::Sampler;

    /// The fast azimuth against f64 sine and cosine: every 2^-20 of a turn over two
    /// turns each way, and far out where the angle's reduction is tested.
    #[test]
    fn turn_cos_sin_matches_the_exact_circle() {
        let mut worst = 0.0f64;
        let grid = (-(2i32 << 20)..=(2 << 20)).map(|k| k as f32 / (1 << 20) as f32);
        let far = [
            1e5f32,
            -1e5 - 0.3,
            1048575.75,
            -1048576.0,
            0.999_999_94,
            0.5,
            0.25,
        ];
        for u in grid.chain(far) {
            let (c, s) = turn_cos_sin(u);
            let a = std::f64::consts::TAU * u as f64;
            worst = worst
                .max((c as f64 - a.cos()).abs())
                .max((s as f64 - a.sin()).abs());
        }
        assert!(worst < 2.5e-7, "largest error {worst:e}");
        assert_eq!(turn_cos_sin(0.0), (1.0, 0.0));
    }

    fn params(base: f32, metallic: f32, roughness: f32, specular_factor: f32) -> BsdfParams {
        BsdfParams {
            base,
            metallic,
            roughness,
            specular_factor,
            specular_color: 1.0,
            transmission: 0.0,
            ior: 1.5,
        }
    }

    /// Albedo estimate: E[weight] over sampled directions.
    fn albedo(b: &Bsdf, wo: Vec3, n: usize) -> f64 {
        let mut rng = Sampler::new(1, 2, 3);
        (0..n)
            .map(|_| {
                rng.start_sample();
                b.sample(wo, rng.get1(0), rng.get2(1))
                    .map_or(0.0, |s| s.weight as f64)
            })
            .sum::<f64>()
            / n as f64
    }

    #[test]
    fn lambertian_albedo_is_base() {
        let b = Bsdf::new(&params(0.7, 0.0, 1.0, 0.0), 1.0 / 1.5);
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let a = albedo(&b, wo, 200_000);
        assert!(
            (a - 0.7).abs() < 1e-6,
            "pure Lambertian weight is exactly the albedo: {a}"
        );
        let (f, pdf) = b.eval(wo, Vec3::Z);
        assert!((f - 0.7 / PI).abs() < 1e-6 && (pdf - 1.0 / PI).abs() < 1e-6);
    }

    #[test]
    fn sampling_matches_eval_for_glossy() {
        // Monte Carlo integral of f cos over the hemisphere by uniform sampling must match
        // the importance-sampled albedo.
        let b = Bsdf::new(&params(0.5, 0.5, 0.4, 1.0), 1.0 / 1.5);
        let wo = Vec3::new(0.5, 0.0, 0.8).normalize();
        let importance = albedo(&b, wo, 400_000);
        let mut rng = Sampler::new(9, 9, 9);
        let n = 400_000;
        let mut uniform = 0.0f64;
        for _ in 0..n {
            rng.start_sample();
            let (u1, u2) = rng.get2(0);
            let z = u1;
            let r = (1.0 - z * z).sqrt();
            let phi = 2.0 * PI * u2;
            let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            uniform += (b.eval(wo, wi).0 * wi.z) as f64 * 2.0 * PI as f64;
        }
        uniform /= n as f64;
        assert!(
            (importance - uniform).abs() < 0.01 * uniform,
            "{importance} vs {uniform}"
        );
    }

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.4, 0.5).normalize(),
            Vec3::X,
        ] {
            let f = Frame::new(n);
            assert!(
                f.t.dot(f.b).abs() < 1e-6 && f.t.dot(n).abs() < 1e-6 && f.b.dot(n).abs() < 1e-6
            );
            let v = Vec3::new(0.1, 0.7, -0.2);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
        }
    }
}

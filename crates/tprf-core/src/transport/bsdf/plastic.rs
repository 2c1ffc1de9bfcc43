//! Mitsuba 3's `plastic` and `roughplastic` (`src/bsdfs/plastic.cpp`,
//! `roughplastic.cpp`): a dielectric coat of relative index `eta` over a diffuse base.
//!
//! The coat reflects `F` (smooth: Fresnel's mirror; rough: a microfacet lobe
//! `F D G / (4 cos_o cos_i)`), and the base is a Lambertian of reflectance `rho` seen
//! through the coat, the light it reflects back inside the coat summed as a geometric
//! series:
//!
//! `f_diffuse = rho / (1 - rho F_dr) eta^-2 (1 - F(cos_o)) (1 - F(cos_i)) / pi`
//!
//! (`1 - F_dr` without `nonlinear`). Smooth: `F` is the Fresnel reflectance and `F_dr`
//! Mitsuba's fit of the internal diffuse reflectance `F_dr(1 / eta)`; rough: `1 - F` is
//! the rough coat's transmittance `T(cos)` (an integral over the visible microfacets,
//! tabulated at 64 cosines and interpolated linearly, as Mitsuba) and `F_dr` is
//! `2 mean(R_int(mu) mu)` over the same 64 cosines, `R_int` the rough coat's reflectance
//! from inside. Lobes are picked with Mitsuba's `specular_sampling_weight`
//! `s / (rho_mean + s)` times the coat's reflectance and transmittance toward the viewer.

use super::fresnel::{diffuse_fresnel_reflectance, fresnel_dielectric};
use super::microfacet::{Microfacet, reflect};
use super::{BsdfSample, LobeKind, turn_cos_sin};
use crate::scene::MicrofacetDistribution;
use glam::Vec3;
use std::f32::consts::PI;
use std::sync::Mutex;

/// Cosines at which a rough coat's transmittance is tabulated (Mitsuba's
/// `MI_ROUGH_TRANSMITTANCE_RES`).
pub const COAT_TABLE: usize = 64;

/// A rough dielectric coat's transmittance from outside `T(cos)` at the cosines
/// `max(1e-6, i / 63)` and its internal diffuse reflectance `F_dr`, both dimensionless.
#[derive(Debug)]
pub struct RoughCoat {
    pub transmittance: [f32; COAT_TABLE],
    pub internal_reflectance: f32,
}

impl RoughCoat {
    /// `T(cos)` interpolated linearly between the tabulated cosines (Mitsuba's
    /// `lerp_gather`).
    #[inline]
    pub fn t(&self, cos: f32) -> f32 {
        let x = cos * (COAT_TABLE - 1) as f32;
        let i = (x.max(0.0) as usize).min(COAT_TABLE - 2);
        let (a, b) = (self.transmittance[i], self.transmittance[i + 1]);
        a + (b - a) * (x - i as f32)
    }

    /// The coat of distribution `mf` and relative index `eta` (`int_ior / ext_ior`),
    /// computed once per (distribution, alpha, eta) for the process and shared.
    pub fn shared(mf: Microfacet, eta: f32) -> &'static RoughCoat {
        type Key = (MicrofacetDistribution, u32, u32);
        static COATS: Mutex<Vec<(Key, &'static RoughCoat)>> = Mutex::new(Vec::new());
        let key = (mf.kind, mf.alpha.to_bits(), eta.to_bits());
        let mut coats = COATS.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, c)) = coats.iter().find(|(k, _)| *k == key) {
            return c;
        }
        // One per distinct coat for the life of the process (a few hundred bytes each).
        let coat: &'static RoughCoat = Box::leak(Box::new(RoughCoat::compute(mf, eta)));
        coats.push((key, coat));
        coat
    }

    /// The integrals behind Mitsuba's `eval_transmittance` and `eval_reflectance`, each
    /// an expectation over the normals visible from `wi` (density
    /// `G1(wi, m) max(0, wi.m) D(m) / cos_i`): `T(wi) = E[(1 - F(wi.m)) G1(wt, m)]`, `wt`
    /// refracted into the coat, and `R(wi) = E[F(wi.m) G1(wr, m)]`, `wr` reflected.
    /// Computed here by Gauss-Legendre quadrature in the `D cos` sampling's first number
    /// and the midpoint rule in azimuth (Mitsuba uses Gauss-Legendre over its visible-normal
    /// sampler: the same integrals, other nodes).
    fn compute(mf: Microfacet, eta: f32) -> RoughCoat {
        let (nodes, weights) = gauss_legendre_01(96);
        let n_phi = 192;
        let integrate = |wi: Vec3, eta_in: f32, transmit: bool| -> f64 {
            let mut sum = 0.0f64;
            for (&u1, &w1) in nodes.iter().zip(&weights) {
                for j in 0..n_phi {
                    let m = mf.sample(u1 as f32, (j as f32 + 0.5) / n_phi as f32);
                    let c = wi.dot(m);
                    if c <= 0.0 || m.z <= 0.0 {
                        continue;
                    }
                    // Visible-normal density over the sampler's density D(m) m.z.
                    let w = mf.g1(wi, m) * c / (wi.z * m.z);
                    if w <= 0.0 {
                        continue;
                    }
                    let f = fresnel_dielectric(c, 1.0 / eta_in);
                    let g = if transmit {
                        // Refraction through m with relative index eta_in (n_t / n_i).
                        let e = 1.0 / eta_in;
                        let sin2_t = e * e * (1.0 - c * c);
                        if sin2_t >= 1.0 {
                            continue;
                        }
                        let cos_t = (1.0 - sin2_t).sqrt();
                        let wt = m * (c * e - cos_t) - wi * e;
                        if wt.z >= 0.0 {
                            continue;
                        }
                        (1.0 - f) * mf.g1(wt, m)
                    } else {
                        let wr = reflect(wi, m);
                        if wr.z <= 0.0 {
                            continue;
                        }
                        f * mf.g1(wr, m)
                    };
                    sum += w1 * (w * g) as f64;
                }
            }
            sum / n_phi as f64
        };
        let mut transmittance = [0.0f32; COAT_TABLE];
        let mut internal = 0.0f64;
        for (i, t) in transmittance.iter_mut().enumerate() {
            let mu = (i as f32 / (COAT_TABLE - 1) as f32).max(1e-6);
            let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            *t = integrate(wi, eta, true) as f32;
            internal += integrate(wi, 1.0 / eta, false) * mu as f64;
        }
        RoughCoat {
            transmittance,
            internal_reflectance: (2.0 * internal / COAT_TABLE as f64) as f32,
        }
    }
}

/// Gauss-Legendre nodes and weights on [0, 1] (Newton's iteration on P_n).
fn gauss_legendre_01(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut nodes, mut weights) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0f64, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        nodes.push(0.5 * (1.0 - x));
        weights.push(1.0 / ((1.0 - x * x) * dp * dp));
    }
    (nodes, weights)
}

/// A plastic's coat in one band, prepared once per material: what does not depend on
/// the base colour's texture.
#[derive(Clone, Copy, Debug)]
pub struct PlasticCoat {
    /// `1 / eta`: the outside's index over the coat's.
    inv_eta: f32,
    /// The rough coat's distribution and tables; `None`: smooth.
    rough: Option<(Microfacet, &'static RoughCoat)>,
    /// `F_dr`: the coat's reflectance of diffuse light from inside.
    internal_reflectance: f32,
    nonlinear: bool,
    /// Mitsuba's `specular_sampling_weight`, `s_mean / (rho_mean + s_mean)`.
    specular_sampling_weight: f32,
}

impl PlasticCoat {
    /// `eta` = `int_ior / ext_ior`; `rho_mean` and `specular_mean` the diffuse and
    /// specular reflectances' means (they steer sampling only).
    pub fn new(
        eta: f32,
        microfacet: Option<Microfacet>,
        nonlinear: bool,
        rho_mean: f32,
        specular_mean: f32,
    ) -> PlasticCoat {
        let eta = if eta.is_finite() && eta > 0.0 {
            eta
        } else {
            1.49
        };
        let rough = microfacet.map(|mf| (mf, RoughCoat::shared(mf, eta)));
        let internal_reflectance = match rough {
            Some((_, coat)) => coat.internal_reflectance,
            None => diffuse_fresnel_reflectance(1.0 / eta),
        };
        let total = rho_mean + specular_mean;
        PlasticCoat {
            inv_eta: 1.0 / eta,
            rough,
            internal_reflectance,
            nonlinear,
            specular_sampling_weight: if total > 0.0 {
                specular_mean / total
            } else {
                0.5
            },
        }
    }
}

/// The BSDF of a plastic at one point, one band.
#[derive(Clone, Copy, Debug)]
pub struct Plastic {
    coat: PlasticCoat,
    /// `rho / (1 - rho F_dr) / eta^2` (or `1 - F_dr`): the diffuse lobe's albedo through
    /// the coat before its two Fresnel factors.
    diffuse: f32,
    /// `specular_reflectance`.
    specular: f32,
}

impl Plastic {
    pub fn new(coat: &PlasticCoat, rho: f32, specular: f32) -> Plastic {
        let rho = rho.max(0.0);
        let inner = 1.0
            - if coat.nonlinear {
                rho * coat.internal_reflectance
            } else {
                coat.internal_reflectance
            };
        Plastic {
            coat: *coat,
            diffuse: if inner > 0.0 {
                rho / inner * coat.inv_eta * coat.inv_eta
            } else {
                0.0
            },
            specular: specular.max(0.0),
        }
    }

    /// The plastic whose diffuse albedo is the derivative with respect to `rho` of
    /// [`Plastic::new`]'s (`1 / (1 - F_dr) / eta^2`, or `1 / (1 - rho F_dr)^2 / eta^2`
    /// when `nonlinear`) and whose coat reflects nothing (it does not depend on `rho`):
    /// for [`super::derivative`].
    pub(super) fn d_base(coat: &PlasticCoat, rho: f32) -> Plastic {
        let rho = rho.max(0.0);
        let inner = 1.0
            - if coat.nonlinear {
                rho * coat.internal_reflectance
            } else {
                coat.internal_reflectance
            };
        let d = if !(inner > 0.0) {
            0.0
        } else if coat.nonlinear {
            1.0 / (inner * inner)
        } else {
            1.0 / inner
        };
        Plastic {
            coat: *coat,
            diffuse: d * coat.inv_eta * coat.inv_eta,
            specular: 0.0,
        }
    }

    /// A smooth coat's mirror value toward `wo`, `specular x F(cos_o)` (what its
    /// sample weight divides by the coat's probability); 0 for a rough coat.
    pub(super) fn mirror_value(&self, wo: Vec3) -> f32 {
        match self.coat.rough {
            None => self.specular * fresnel_dielectric(wo.z, self.coat.inv_eta),
            Some(_) => 0.0,
        }
    }

    /// Whether a non-delta lobe is present (next-event estimation is useful).
    pub fn has_smooth_lobe(&self) -> bool {
        self.diffuse > 0.0 || self.coat.rough.is_some()
    }

    /// Probability of sampling the coat for a viewer at `cos_o`, given the coat's
    /// reflectance toward it `r` (Mitsuba's `prob_specular`).
    #[inline]
    fn p_coat(&self, r: f32) -> f32 {
        let w = self.coat.specular_sampling_weight;
        let (s, d) = (r * w, (1.0 - r) * (1.0 - w));
        if s + d > 0.0 { s / (s + d) } else { 0.0 }
    }

    /// `f(wo, wi)` of the non-delta lobes (1/sr) and the one-sample pdf of sampling `wi`
    /// (1/sr); zero when either direction is below the surface.
    // Out of line: the metallic-roughness lobes' inlined dispatch stays as small as before.
    #[inline(never)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (0.0, 0.0);
        }
        match self.coat.rough {
            None => {
                let f_o = fresnel_dielectric(wo.z, self.coat.inv_eta);
                let f_i = fresnel_dielectric(wi.z, self.coat.inv_eta);
                let p_diffuse = 1.0 - self.p_coat(f_o);
                (
                    self.diffuse * (1.0 - f_o) * (1.0 - f_i) / PI,
                    p_diffuse * wi.z / PI,
                )
            }
            Some((mf, coat)) => {
                let (t_o, t_i) = (coat.t(wo.z), coat.t(wi.z));
                let p_spec = self.p_coat(1.0 - t_o);
                let h = (wo + wi).normalize();
                let c = wo.dot(h).max(1e-8);
                let d = mf.d(h);
                let fr = fresnel_dielectric(c, self.coat.inv_eta);
                let g = mf.g1(wo, h) * mf.g1(wi, h);
                let f = self.specular * fr * d * g / (4.0 * wo.z * wi.z)
                    + self.diffuse * t_o * t_i / PI;
                let pdf = p_spec * mf.pdf(h) / (4.0 * c) + (1.0 - p_spec) * wi.z / PI;
                (f, pdf)
            }
        }
    }

    /// Sample an incident direction for outgoing `wo`: `u_lobe` picks the coat or the
    /// base, `(u1, u2)` the direction.
    #[inline(never)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, (u1, u2): (f32, f32)) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (p_coat, mirror_fresnel) = match self.coat.rough {
            None => {
                let f_o = fresnel_dielectric(wo.z, self.coat.inv_eta);
                (self.p_coat(f_o), f_o)
            }
            Some((_, coat)) => (self.p_coat(1.0 - coat.t(wo.z)), 0.0),
        };
        let (wi, kind) = if u_lobe < p_coat {
            match self.coat.rough {
                None => {
                    return Some(BsdfSample {
                        wi: Vec3::new(-wo.x, -wo.y, wo.z),
                        weight: self.specular * mirror_fresnel / p_coat,
                        pdf: 0.0,
                        kind: LobeKind::Mirror,
                    });
                }
                Some((mf, _)) => {
                    let wi = reflect(wo, mf.sample(u1, u2));
                    if wi.z <= 0.0 {
                        return None;
                    }
                    (wi, LobeKind::Glossy)
                }
            }
        } else {
            let r = u1.sqrt();
            let (c, s) = turn_cos_sin(u2);
            (
                Vec3::new(r * c, r * s, (1.0 - u1).max(0.0).sqrt()),
                LobeKind::Diffuse,
            )
        };
        let (f, pdf) = self.eval(wo, wi);
        (pdf > 0.0 && f > 0.0).then(|| BsdfSample {
            wi,
            weight: f * wi.z / pdf,
            pdf,
            kind,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::bsdf::{Bsdf, BsdfParams, test_support::*};

    /// Unpolarised Fresnel reflectance of a smooth dielectric in f64, from the Fresnel
    /// equations as textbooks write them (n1 outside, n2 inside), for the hand-evaluated
    /// checks.
    fn fresnel_f64(cos_i: f64, n1: f64, n2: f64) -> f64 {
        let sin_t = n1 / n2 * (1.0 - cos_i * cos_i).sqrt();
        if sin_t >= 1.0 {
            return 1.0;
        }
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
        let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
        0.5 * (rs * rs + rp * rp)
    }

    fn plastic(rho: f32, eta: f32, rough: Option<(MicrofacetDistribution, f32)>, nl: bool) -> Bsdf {
        let coat = PlasticCoat::new(eta, rough.map(|(k, a)| Microfacet::new(k, a)), nl, rho, 1.0);
        Bsdf::build(
            &crate::transport::bsdf::BandModel::Plastic(coat),
            &BsdfParams {
                base: rho,
                specular_color: 1.0,
                ..params_for_tests()
            },
            true,
        )
    }

    /// The smooth plastic's diffuse lobe at chosen angles against Mitsuba's formula
    /// evaluated here by hand: `rho / (1 - rho F_dr) / eta^2 (1 - F_o)(1 - F_i) / pi`,
    /// `F_dr` Egan and Hilgeman's fit at 1 / eta, and without `nonlinear`
    /// `rho / (1 - F_dr)`.
    #[test]
    fn smooth_plastic_matches_mitsubas_formula_by_hand() {
        let (rho, eta) = (0.578f64, 1.5f64);
        let e = 1.0 / eta;
        let f_dr = 0.0636 / e + 0.6681 + 0.7099 * e - 1.4399 * e * e;
        for nonlinear in [true, false] {
            let b = plastic(rho as f32, eta as f32, None, nonlinear);
            for (co, ci) in [(1.0f64, 1.0f64), (0.8, 0.3), (0.2, 0.9), (0.05, 0.5)] {
                let wo = Vec3::new((1.0 - co * co).sqrt() as f32, 0.0, co as f32);
                let wi = Vec3::new(0.0, -(1.0 - ci * ci).sqrt() as f32, ci as f32);
                let scale = if nonlinear {
                    rho / (1.0 - rho * f_dr)
                } else {
                    rho / (1.0 - f_dr)
                };
                let expect = scale / (eta * eta)
                    * (1.0 - fresnel_f64(co, 1.0, eta))
                    * (1.0 - fresnel_f64(ci, 1.0, eta))
                    / std::f64::consts::PI;
                let (f, pdf) = b.eval(wo, wi);
                assert!(
                    (f as f64 - expect).abs() < 2e-6 * expect.max(1e-3),
                    "nonlinear {nonlinear}, cos {co} {ci}: {f} vs {expect}"
                );
                assert!(pdf > 0.0);
            }
        }
        // At normal incidence on both sides, about 0.36 / pi for the staircase's paint.
        let (f, _) = plastic(0.578, 1.5, None, true).eval(Vec3::Z, Vec3::Z);
        assert!(
            (f * std::f32::consts::PI - 0.363).abs() < 0.002,
            "{}",
            f * std::f32::consts::PI
        );
    }

    /// Energy split of the smooth plastic: the mirror carries exactly `F(cos_o)` (times
    /// the specular reflectance), the base `(1 - F_o) rho / (1 - rho F_dr) / eta^2 (1 -
    /// F_dr,ext)`, `F_dr,ext = 2 int F(mu) mu dmu` from outside, integrated here in f64.
    /// With rho = 1 and an exact `F_dr` the two would sum to 1 (`eta^2 (1 - F_dr,int) =
    /// 1 - F_dr,ext`); with Mitsuba's fit they do within 1 %.
    #[test]
    fn smooth_plastic_splits_energy_between_coat_and_base() {
        let eta = 1.5f64;
        let n = 100_000;
        let fdr_ext: f64 = (0..n)
            .map(|i| {
                let mu = (i as f64 + 0.5) / n as f64;
                2.0 * fresnel_f64(mu, 1.0, eta) * mu / n as f64
            })
            .sum();
        let f_dr_int = diffuse_fresnel_reflectance(1.0 / eta as f32) as f64;
        for rho in [0.578f64, 1.0] {
            let b = plastic(rho as f32, eta as f32, None, true);
            for co in [0.95f64, 0.5, 0.15] {
                let wo = Vec3::new((1.0 - co * co).sqrt() as f32, 0.0, co as f32);
                let (mut mirror, mut base) = (0.0f64, 0.0f64);
                let m = 400_000;
                let mut rng = crate::transport::sampler::Sampler::new(3, 1, 4);
                for _ in 0..m {
                    rng.start_sample();
                    if let Some(s) = b.sample(wo, rng.get1(0), rng.get2(1)) {
                        match s.kind {
                            LobeKind::Mirror => mirror += s.weight as f64,
                            _ => base += s.weight as f64,
                        }
                    }
                }
                let (mirror, base) = (mirror / m as f64, base / m as f64);
                let f_o = fresnel_f64(co, 1.0, eta);
                let expect_base =
                    (1.0 - f_o) * rho / (1.0 - rho * f_dr_int) / (eta * eta) * (1.0 - fdr_ext);
                assert!(
                    (mirror - f_o).abs() < 0.01 * f_o + 1e-4,
                    "rho {rho} cos {co}: mirror {mirror} vs {f_o}"
                );
                assert!(
                    (base - expect_base).abs() < 0.01 * expect_base,
                    "rho {rho} cos {co}: base {base} vs {expect_base}"
                );
                if rho == 1.0 {
                    assert!(
                        (mirror + base - 1.0).abs() < 0.015,
                        "white furnace: {}",
                        mirror + base
                    );
                }
            }
        }
    }

    /// The rough coat's tables: `T(cos) <= 1 - (coat's own reflectance)`, near the smooth
    /// Fresnel transmittance for a small alpha, and `F_dr` near the smooth fit.
    #[test]
    fn rough_coat_tends_to_the_smooth_one() {
        let coat = RoughCoat::compute(Microfacet::new(MicrofacetDistribution::Ggx, 0.01), 1.5);
        for cos in [1.0f32, 0.7, 0.4] {
            let smooth = 1.0 - fresnel_dielectric(cos, 1.0 / 1.5);
            assert!(
                (coat.t(cos) - smooth).abs() < 2e-3,
                "cos {cos}: {} vs {smooth}",
                coat.t(cos)
            );
        }
        let fit = diffuse_fresnel_reflectance(1.0 / 1.5);
        assert!(
            (coat.internal_reflectance - fit).abs() < 0.01,
            "{} vs {fit}",
            coat.internal_reflectance
        );
    }

    /// Rough plastics: sampling agrees with eval and pdf (the sampled albedo equals the
    /// uniform-sampling integral of `f cos`), the pdf integrates to at most 1, and `f` is
    /// reciprocal; with rho = 1 the albedo stays <= 1.
    #[test]
    fn rough_plastic_sampling_agrees_with_eval() {
        for kind in [
            MicrofacetDistribution::Beckmann,
            MicrofacetDistribution::Ggx,
        ] {
            for alpha in [0.1f32, 0.4] {
                for rho in [0.578f32, 1.0] {
                    let b = plastic(rho, 1.5, Some((kind, alpha)), true);
                    for co in [0.9f32, 0.4] {
                        let wo = Vec3::new((1.0 - co * co).sqrt(), 0.0, co);
                        let (sampled, uniform, pdf_sum) = albedo_both_ways(&b, wo);
                        assert!(
                            (sampled - uniform).abs() < 0.01 * uniform,
                            "{kind:?} {alpha} rho {rho} cos {co}: {sampled} vs {uniform}"
                        );
                        assert!(pdf_sum < 1.005, "pdf integrates to {pdf_sum}");
                        assert!(sampled < 1.005, "albedo {sampled}");
                        let wi = Vec3::new(-0.3, 0.2, 0.93).normalize();
                        let (a, _) = b.eval(wo, wi);
                        let (r, _) = b.eval(wi, wo);
                        assert!((a - r).abs() < 1e-5 * a, "reciprocity {a} {r}");
                    }
                }
            }
        }
    }
}

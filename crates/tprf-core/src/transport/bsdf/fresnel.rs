//! Fresnel reflectances for unpolarised light, as Mitsuba 3 defines them
//! (`include/mitsuba/render/fresnel.h`).

/// Exact Fresnel reflectance of a smooth dielectric for unpolarised light; `eta` =
/// n_incident / n_transmitted. Returns 1 for total internal reflection. (Mitsuba's
/// `fresnel(cos_theta_i, eta_m)` is this with `eta = 1 / eta_m`, for `cos_theta_i >= 0`.)
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Fresnel reflectance of a conductor of complex relative index `eta + i k` at incidence
/// cosine `cos_i` (Mitsuba's `fresnel_conductor`, after Moeller, "Optics", 1988):
/// `R_s = (a^2 + b^2 + cos^2 - 2 a cos) / (a^2 + b^2 + cos^2 + 2 a cos)` with
/// `a^2 + b^2 = sqrt((eta^2 - k^2 - sin^2)^2 + 4 eta^2 k^2)`, `a = sqrt((a^2 + b^2 +
/// eta^2 - k^2 - sin^2) / 2)`, and `R_p = R_s (|.|^2 cos^2 + sin^4 - 2 a cos sin^2) /
/// (|.|^2 cos^2 + sin^4 + 2 a cos sin^2)`; their mean. Dimensionless.
pub fn fresnel_conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let temp1 = eta * eta - k * k - s2;
    let a2pb2 = (temp1 * temp1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2pb2 + temp1)).max(0.0).sqrt();
    let term1 = a2pb2 + c2;
    let term2 = 2.0 * cos_i * a;
    let rs = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * c2 + s4;
    let term4 = term2 * s2;
    let rp = rs * (term3 - term4) / (term3 + term4);
    0.5 * (rs + rp)
}

/// Mitsuba's `fresnel_diffuse_reflectance(eta)`: the fraction of uniformly diffuse light
/// (radiance constant over the hemisphere) that a smooth interface of relative index
/// `eta` reflects, from fits: Egan and Hilgeman (1973) for `eta < 1`,
/// `0.0636 / eta + 0.6681 + 0.7099 eta - 1.4399 eta^2`, and d'Eon and Irving (2011)
/// otherwise, a quintic in `1 / eta`.
pub fn diffuse_fresnel_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + (eta * (eta * -1.4399 + 0.7099) + 0.6681)
    } else {
        let c = [0.919317f32, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, &ci| acc * inv + ci)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `F_dr` against the hemispherical integral of the exact Fresnel reflectance,
    /// `2 int_0^1 F(mu) mu dmu`, by the midpoint rule: the fits are within 0.6 % of it
    /// (Mitsuba's stated accuracy) for indices between 1/2 and 2.
    #[test]
    fn diffuse_reflectance_is_the_hemispherical_mean_of_fresnel() {
        for eta in [0.5f32, 1.0 / 1.5, 0.8, 1.2, 1.33, 1.5, 2.0] {
            let n = 200_000;
            let integral: f64 = (0..n)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / n as f64;
                    2.0 * fresnel_dielectric(mu as f32, 1.0 / eta) as f64 * mu / n as f64
                })
                .sum();
            let fit = diffuse_fresnel_reflectance(eta) as f64;
            assert!(
                (fit - integral).abs() < 0.006 * integral + 1e-3,
                "eta {eta}: fit {fit}, integral {integral}"
            );
        }
    }

    /// A conductor of k = 0 is a dielectric; at normal incidence the reflectance is
    /// `((n - 1)^2 + k^2) / ((n + 1)^2 + k^2)`; at grazing it is 1.
    #[test]
    fn conductor_limits() {
        for c in [0.1f32, 0.5, 0.9, 1.0] {
            let d = fresnel_dielectric(c, 1.0 / 1.7);
            assert!((fresnel_conductor(c, 1.7, 0.0) - d).abs() < 1e-5, "cos {c}");
        }
        let (n, k) = (0.2f32, 3.9f32);
        let r0 = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!((fresnel_conductor(1.0, n, k) - r0).abs() < 1e-6);
        assert!((fresnel_conductor(0.0, n, k) - 1.0).abs() < 1e-6);
        assert!(
            (fresnel_conductor(0.7, 0.0, 1.0) - 1.0).abs() < 1e-6,
            "Mitsuba's default eta 0, k 1: a perfect mirror"
        );
    }

    #[test]
    fn fresnel_limits() {
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        assert_eq!(
            fresnel_dielectric(0.1, 1.5),
            1.0,
            "total internal reflection"
        );
        assert!((fresnel_dielectric(0.0, 1.0 / 1.5) - 1.0).abs() < 1e-6);
    }
}

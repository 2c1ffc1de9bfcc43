//! Fresnel Mueller matrices of a smooth interface between dielectrics or with a
//! conductor: Mitsuba 3's `fresnel_polarized`, `specular_reflection` and
//! `specular_transmission`. The matrices are in the frame whose `x` is the s direction
//! (perpendicular to the plane of incidence) on both sides.

use super::complex::Complex;
use super::mueller::Mueller;

/// The complex Fresnel amplitudes at a smooth interface of relative index `eta` (`n_t /
/// n_i` for `cos_i >= 0`, light arriving from the side the normal points to; its
/// reciprocal is used for `cos_i < 0`), as Mitsuba's `fresnel_polarized` returns them.
#[derive(Clone, Copy, Debug)]
pub struct FresnelAmplitudes {
    /// Reflected s amplitude `(cos_i - eta cos_t) / (cos_i + eta cos_t)`.
    pub a_s: Complex,
    /// Reflected p amplitude, Verdet's sign: `(eta cos_i - cos_t) / (eta cos_i + cos_t)`.
    pub a_p: Complex,
    /// Cosine of the refracted direction, of the opposite sign to `cos_i` (0 under total
    /// internal reflection or for a conductor's evanescent wave).
    pub cos_t: f32,
    /// `n_t / n_i` and `n_i / n_t` for the side the light comes from (real parts for a
    /// conductor).
    pub eta_it: f32,
    pub eta_ti: f32,
}

/// Mitsuba's `fresnel_polarized(cos_theta_i, eta)` for a complex index `eta = (eta, k)`:
/// Snell's law `cos_t^2 = 1 - (1 - cos_i^2) / eta_it^2` in complex arithmetic, the root
/// of `cos_t` with non-positive imaginary part (Clarke, "Stellar Polarimetry", A.2), and
/// the amplitudes of [`FresnelAmplitudes`]. `k >= 0` is taken as the index `eta - i k`
/// (the sign Mitsuba's polarized Fresnel code uses). Both amplitudes are 0 for an index
/// of 1 (no interface) or 0 (invalid).
pub fn fresnel_polarized(cos_i: f32, eta: f32, k: f32) -> FresnelAmplitudes {
    let eta_c = Complex::new(eta, -k.abs());
    let outside = cos_i >= 0.0;
    let eta_it = if outside {
        eta_c
    } else {
        Complex::real(1.0) / eta_c
    };
    let eta_ti = Complex::real(1.0) / eta_it;
    let sin2_i = 1.0 - cos_i * cos_i;
    let cos2_t = Complex::real(1.0) - eta_ti * eta_ti * sin2_i;
    let ci = cos_i.abs();
    let mut cos_t = cos2_t.sqrt();
    if cos_t.im > 0.0 {
        cos_t = cos_t.conj();
    }
    let ci_c = Complex::real(ci);
    let mut a_s = (ci_c - eta_it * cos_t) / (ci_c + eta_it * cos_t);
    let mut a_p = (eta_it * ci_c - cos_t) / (eta_it * ci_c + cos_t);
    let n2 = eta_c.norm_sqr();
    if (n2 == 1.0 && eta_c.im == 0.0) || n2 == 0.0 {
        a_s = Complex::real(0.0);
        a_p = Complex::real(0.0);
    }
    let cos_t_signed = if cos2_t.re >= 0.0 {
        -cos_t.re.copysign(cos_i)
    } else {
        0.0
    };
    FresnelAmplitudes {
        a_s,
        a_p,
        cos_t: cos_t_signed,
        eta_it: eta_it.re,
        eta_ti: eta_ti.re,
    }
}

/// The Mueller matrix of specular reflection at incidence cosine `cos_i` on an interface
/// of complex index `(eta, k)` (Mitsuba's `specular_reflection`; Collett ch. 8): with
/// `R_s = |a_s|^2`, `R_p = |a_p|^2`, `a_p conj(a_s) = sqrt(R_s R_p) (cos delta + i sin
/// delta)`,
/// `[(R_s+R_p)/2, (R_s-R_p)/2, 0, 0; (R_s-R_p)/2, (R_s+R_p)/2, 0, 0;
///   0, 0, C cos delta, -C sin delta; 0, 0, C sin delta, C cos delta]`, `C = sqrt(R_s R_p)`.
/// Dimensionless; `M00` is the unpolarized reflectance.
pub fn specular_reflection(cos_i: f32, eta: f32, k: f32) -> Mueller {
    let f = fresnel_polarized(cos_i, eta, k);
    let (r_s, r_p) = (f.a_s.norm_sqr(), f.a_p.norm_sqr());
    let (a, b) = (0.5 * (r_s + r_p), 0.5 * (r_s - r_p));
    let z = f.a_p * f.a_s.conj();
    // `z` is `C (cos delta + i sin delta)` already: no normalisation needed.
    let (c_cos, c_sin) = (z.re, z.im);
    Mueller([
        [a, b, 0.0, 0.0],
        [b, a, 0.0, 0.0],
        [0.0, 0.0, c_cos, -c_sin],
        [0.0, 0.0, c_sin, c_cos],
    ])
}

/// The Mueller matrix of specular transmission through a smooth dielectric interface of
/// real relative index `eta` (Mitsuba's `specular_transmission`): transmitted amplitudes
/// `t_s = 1 + a_s`, `t_p = (1 + a_p) / eta_it`, scaled by the ratio of beam
/// cross-sections `eta_it |cos_t| / |cos_i|`, so that `T_s = 1 - R_s`, `T_p = 1 - R_p`
/// (flux, not radiance: the `1 / eta^2` of radiance is the BSDF's, not this matrix's):
/// `[(T_s+T_p)/2, (T_s-T_p)/2, 0, 0; (T_s-T_p)/2, (T_s+T_p)/2, 0, 0; 0, 0, sqrt(T_s
/// T_p), 0; 0, 0, 0, sqrt(T_s T_p)]`. Zero under total internal reflection.
pub fn specular_transmission(cos_i: f32, eta: f32) -> Mueller {
    let f = fresnel_polarized(cos_i, eta, 0.0);
    let factor = if cos_i.abs() > 1e-8 {
        -f.eta_it * f.cos_t / cos_i
    } else {
        0.0
    };
    let a_s_r = 1.0 + f.a_s.re;
    let a_p_r = (1.0 + f.a_p.re) * f.eta_ti;
    let (t_s, t_p) = (a_s_r * a_s_r, a_p_r * a_p_r);
    let (a, b, c) = (
        0.5 * factor * (t_s + t_p),
        0.5 * factor * (t_s - t_p),
        factor * (t_s * t_p).sqrt(),
    );
    Mueller([
        [a, b, 0.0, 0.0],
        [b, a, 0.0, 0.0],
        [0.0, 0.0, c, 0.0],
        [0.0, 0.0, 0.0, c],
    ])
}

#[cfg(test)]
mod tests {
    use super::super::stokes::Stokes;
    use super::*;

    /// At Brewster's angle `atan(n)` the p reflectance vanishes: unpolarized light
    /// reflects fully s-polarized (DoLP 1, along the frame's `x`, the s direction), with
    /// `R_s = sin^2(i - t) / sin^2(i + t)` (Fresnel's sine law); away from it the
    /// reflected light is partly polarized. Glass from air, and from inside (`atan(1/n)`).
    #[test]
    fn brewster_reflection_is_fully_s_polarized() {
        for n in [1.33f32, 1.5, 2.4] {
            for (eta, sign) in [(n, 1.0f32), (n, -1.0)] {
                // From inside (cos_i < 0) the relative index is 1/n.
                let rel = if sign > 0.0 { n } else { 1.0 / n };
                let theta_b = rel.atan();
                let cos_i = sign * theta_b.cos();
                let m = specular_reflection(cos_i, eta, 0.0);
                let s = m.apply(Stokes::unpolarized(1.0));
                assert!((s.dolp() - 1.0).abs() < 1e-4, "n {n}, side {sign}: {s:?}");
                assert!(s.0[1] > 0.0, "s-polarized means along x: {s:?}");
                let theta_t = (theta_b.sin() / rel).asin();
                let r_s = ((theta_b - theta_t).sin() / (theta_b + theta_t).sin()).powi(2);
                assert!(
                    (s.0[0] - 0.5 * r_s).abs() < 1e-5,
                    "{} vs {}",
                    s.0[0],
                    0.5 * r_s
                );
                // Off Brewster's angle, partly polarized.
                let off = specular_reflection(sign * (theta_b + 0.3).cos(), eta, 0.0)
                    .apply(Stokes::unpolarized(1.0));
                assert!(off.dolp() < 0.95, "{off:?}");
            }
        }
    }

    /// `M00` is the unpolarized reflectance of the textbook Fresnel equations, and
    /// reflection plus transmission conserve flux per polarization: `M_R + M_T` has
    /// `M00 = 1` and `M01 = 0` wherever light is transmitted; total internal reflection
    /// reflects everything and transmits nothing.
    #[test]
    fn dielectric_reflection_and_transmission_conserve_flux() {
        for n in [1.2f32, 1.5, 2.0] {
            for k in 0..=20 {
                for sign in [1.0f32, -1.0] {
                    let cos_i = sign * (k as f32 / 20.0).max(1e-3);
                    let r = specular_reflection(cos_i, n, 0.0);
                    let t = specular_transmission(cos_i, n);
                    // The textbook unpolarized reflectance, n1 on the incident side.
                    let (n1, n2) = if sign > 0.0 {
                        (1.0, n as f64)
                    } else {
                        (n as f64, 1.0)
                    };
                    let ci = cos_i.abs() as f64;
                    let st = n1 / n2 * (1.0 - ci * ci).sqrt();
                    let scalar = if st >= 1.0 {
                        1.0
                    } else {
                        let ct = (1.0 - st * st).sqrt();
                        let rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
                        let rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct);
                        (0.5 * (rs * rs + rp * rp)) as f32
                    };
                    assert!(
                        (r.0[0][0] - scalar).abs() < 2e-5,
                        "{n} {cos_i}: {} vs {scalar}",
                        r.0[0][0]
                    );
                    let sum = r + t;
                    assert!((sum.0[0][0] - 1.0).abs() < 1e-4, "{n} {cos_i}: {sum:?}");
                    assert!(sum.0[0][1].abs() < 1e-4, "{n} {cos_i}: {sum:?}");
                    if scalar >= 1.0 {
                        assert_eq!(
                            t.0[0][0], 0.0,
                            "total internal reflection transmits nothing"
                        );
                    }
                }
            }
        }
    }

    /// A conductor against closed forms: `R_s` and `R_p` from Moeller's real-arithmetic
    /// formulas (the ones `fresnel_conductor` averages, here in f64 and apart), and the
    /// ratio `a_p / a_s = -cos(i + t) / cos(i - t)` (Fresnel's tangent and sine laws in the
    /// Verdet sign, `t` complex with `sin t = sin i / N`, `N = eta - i k`) for the
    /// retardance; at several angles for gold-like, aluminium-like and copper-like indices.
    #[test]
    fn conductor_matches_closed_forms() {
        for (eta, k) in [(0.18f64, 3.42f64), (1.2, 7.26), (0.27, 2.78), (1.7, 0.0)] {
            for deg in [0.0f64, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0] {
                let i = deg.to_radians();
                let (ci, si) = (i.cos(), i.sin());
                // Moeller: a^2 + b^2, a; R_s, R_p.
                let (c2, s2) = (ci * ci, si * si);
                let t1 = eta * eta - k * k - s2;
                let a2b2 = (t1 * t1 + 4.0 * eta * eta * k * k).sqrt();
                let a = (0.5 * (a2b2 + t1)).max(0.0).sqrt();
                let rs = (a2b2 + c2 - 2.0 * a * ci) / (a2b2 + c2 + 2.0 * a * ci);
                let rp = rs * (a2b2 * c2 + s2 * s2 - 2.0 * a * ci * s2)
                    / (a2b2 * c2 + s2 * s2 + 2.0 * a * ci * s2);
                // rho = a_p / a_s = -cos(i + t) / cos(i - t), complex t.
                let (nr, ni) = (eta, -k);
                // sin t = si / N.
                let nn = nr * nr + ni * ni;
                let (st_r, st_i) = (si * nr / nn, -si * ni / nn);
                // cos t = sqrt(1 - sin^2 t), the root with non-positive imaginary part.
                let (q_r, q_i) = (1.0 - (st_r * st_r - st_i * st_i), -2.0 * st_r * st_i);
                let m = (q_r * q_r + q_i * q_i).sqrt();
                let mut ct_r = (0.5 * (m + q_r)).sqrt();
                let mut ct_i = if ct_r > 0.0 {
                    0.5 * q_i / ct_r
                } else {
                    (0.5 * (m - q_r)).sqrt()
                };
                if ct_i > 0.0 {
                    ct_i = -ct_i;
                }
                if ct_r < 0.0 {
                    ct_r = -ct_r;
                }
                // cos(i -+ t) = ci cos t +- si sin t.
                let (num_r, num_i) = (ci * ct_r - si * st_r, ci * ct_i - si * st_i);
                let (den_r, den_i) = (ci * ct_r + si * st_r, ci * ct_i + si * st_i);
                let dd = den_r * den_r + den_i * den_i;
                let rho_r = -(num_r * den_r + num_i * den_i) / dd;
                let rho_i = -(num_i * den_r - num_r * den_i) / dd;
                let expected = [
                    [0.5 * (rs + rp), 0.5 * (rs - rp), 0.0, 0.0],
                    [0.5 * (rs - rp), 0.5 * (rs + rp), 0.0, 0.0],
                    [0.0, 0.0, rs * rho_r, -rs * rho_i],
                    [0.0, 0.0, rs * rho_i, rs * rho_r],
                ];
                let got = specular_reflection(ci as f32, eta as f32, k as f32);
                for (r, row) in expected.iter().enumerate() {
                    for (c, want) in row.iter().enumerate() {
                        assert!(
                            (got.0[r][c] as f64 - want).abs() < 2e-5,
                            "eta {eta} k {k} at {deg} deg: [{r}][{c}] {} vs {want}\n{got:?}",
                            got.0[r][c],
                        );
                    }
                }
            }
        }
    }

    /// Mitsuba's own numbers: `mi.mueller.specular_reflection(cos, eta)` printed by
    /// Mitsuba 3.9.1 (`llvm_ad_mono_polarized`; `mi.Complex2f(eta, k)` for conductors),
    /// elements `M00, M01, M22, M23` (the rest follow: `M10 = M01`, `M11 = M00`, `M32 =
    /// -M23`, `M33 = M22`): gold and aluminium-like conductors, glass from outside and
    /// from inside beyond the critical angle (total internal reflection's retardance).
    #[test]
    fn reflection_matches_mitsubas_numbers() {
        let cases: [(f32, f32, f32, [f32; 4]); 5] = [
            (
                0.9,
                0.18,
                3.42,
                [0.944_784_6, 0.005_954_564, -0.937_744_7, -0.114_967_22],
            ),
            (
                0.4,
                0.18,
                3.42,
                [0.938_015_9, 0.040_356_457, -0.450_619_2, -0.821_697_9],
            ),
            (
                0.2,
                1.2,
                7.26,
                [0.857_496_3, 0.125_380_67, -0.351_545_7, -0.772_007_3],
            ),
            (
                0.6,
                1.5,
                0.0,
                [0.064_524_96, 0.063_564_97, -0.011_089_008, 0.0],
            ),
            (-0.6, 1.5, 0.0, [1.0, 0.0, 0.706_666_7, -0.707_546_6]),
        ];
        for (cos, eta, k, [m00, m01, m22, m23]) in cases {
            let m = specular_reflection(cos, eta, k);
            let expected = [
                [m00, m01, 0.0, 0.0],
                [m01, m00, 0.0, 0.0],
                [0.0, 0.0, m22, m23],
                [0.0, 0.0, -m23, m22],
            ];
            for (r, row) in expected.iter().enumerate() {
                for (c, want) in row.iter().enumerate() {
                    assert!(
                        (m.0[r][c] - want).abs() < 2e-6,
                        "cos {cos}, eta {eta}, k {k}: [{r}][{c}] {} vs Mitsuba's {want}",
                        m.0[r][c]
                    );
                }
            }
        }
    }

    /// Mitsuba's `mi.mueller.specular_transmission(cos, eta)` (3.9.1): `M00, M01, M22`
    /// (`M11 = M00`, `M10 = M01`, `M33 = M22`); zero under total internal reflection.
    #[test]
    fn transmission_matches_mitsubas_numbers() {
        let cases: [(f32, f32, [f32; 3]); 3] = [
            (0.6, 1.5, [0.935_474_9, -0.063_564_96, 0.933_312_9]),
            (-0.6, 1.5, [0.0, 0.0, 0.0]),
            (-0.9, 1.5, [0.953_667_4, -0.033_001_72, 0.953_096_2]),
        ];
        for (cos, eta, [m00, m01, m22]) in cases {
            let m = specular_transmission(cos, eta);
            let expected = [
                [m00, m01, 0.0, 0.0],
                [m01, m00, 0.0, 0.0],
                [0.0, 0.0, m22, 0.0],
                [0.0, 0.0, 0.0, m22],
            ];
            for (r, row) in expected.iter().enumerate() {
                for (c, want) in row.iter().enumerate() {
                    assert!(
                        (m.0[r][c] - want).abs() < 2e-6,
                        "cos {cos}, eta {eta}: [{r}][{c}] {} vs Mitsuba's {want}",
                        m.0[r][c]
                    );
                }
            }
        }
    }
}

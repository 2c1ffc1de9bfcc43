//! Composite Gauss-Legendre quadrature: the integrals the sensor cannot do in closed
//! form are split at every kink of the integrand and into pieces no wider than its
//! smoothness scale, where an 8-point rule is exact to rounding for the envelopes used.

/// Nodes (positive half) and weights of the 8-point Gauss-Legendre rule on [-1, 1].
const GL8: [(f64, f64); 4] = [
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
];

/// Most sub-pieces one piece is cut into (bounds the work for absurd scale ratios).
pub const MAX_SUBPIECES: usize = 1024;

/// Number of sub-pieces of width at most `scale` covering `[a, b]` (1 if `scale` is
/// infinite), capped at [`MAX_SUBPIECES`].
pub fn subpieces(a: f64, b: f64, scale: f64) -> usize {
    let n = ((b - a) / scale).ceil();
    if n.is_finite() && n > 1.0 {
        (n as usize).min(MAX_SUBPIECES)
    } else {
        1
    }
}

/// `integral_a^b f(t) dt` with `n` equal sub-pieces, 8-point Gauss-Legendre on each.
pub fn gauss_legendre(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let n = n.max(1);
    let h = (b - a) / n as f64;
    let mut total = 0.0;
    for k in 0..n {
        let lo = a + h * k as f64;
        let mid = lo + 0.5 * h;
        let half = 0.5 * h;
        let mut piece = 0.0;
        for (x, w) in GL8 {
            piece += w * (f(mid - half * x) + f(mid + half * x));
        }
        total += piece * half;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_polynomials_and_gaussians() {
        // Exact for degree <= 15.
        let got = gauss_legendre(|x| x.powi(15) + 3.0 * x.powi(4), 0.0, 2.0, 1);
        let want = 2f64.powi(16) / 16.0 + 3.0 * 2f64.powi(5) / 5.0;
        assert!((got - want).abs() < 1e-10 * want);
        // A Gaussian over +-8 sigma in sigma-wide pieces.
        let got = gauss_legendre(|x| (-0.5 * x * x).exp(), -8.0, 8.0, 16);
        let want = (2.0 * std::f64::consts::PI).sqrt();
        assert!((got - want).abs() < 1e-14 * want, "{got} {want}");
        assert_eq!(subpieces(0.0, 1.0, f64::INFINITY), 1);
        assert_eq!(subpieces(0.0, 1.0, 0.3), 4);
        assert_eq!(subpieces(0.0, 1.0, 1e-300), MAX_SUBPIECES);
    }
}

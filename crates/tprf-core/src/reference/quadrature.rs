//! Numerical pieces of the references: Gauss-Legendre rules, an integral over an
//! interval whose ends may hold square-root singularities, and the spreading of masses
//! into time bins.

use crate::film::TimeAxis;
use std::sync::OnceLock;

/// Nodes and weights of the `n`-point Gauss-Legendre rule on [-1, 1] (Newton iteration
/// on the Legendre polynomial from the Chebyshev guesses).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 0 { 1.0 } else { p1 };
            let pn1 = if n == 0 { 0.0 } else { p0 };
            dp = n as f64 * (x * pn - pn1) / (x * x - 1.0);
            let step = pn / dp;
            x -= step;
            if step.abs() < 1e-15 {
                break;
            }
        }
        nodes[i] = x;
        weights[i] = 2.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

fn rule24() -> &'static (Vec<f64>, Vec<f64>) {
    static RULE: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    RULE.get_or_init(|| gauss_legendre(24))
}

/// `integral_a^b f(x) dx` for `f` smooth inside (a, b) but possibly behaving like
/// `sqrt(x - a)` or `sqrt(b - x)` at the ends: the substitution
/// `x = a + (b - a) (1 - cos(pi u)) / 2` makes such ends smooth, then 24-point
/// Gauss-Legendre in u.
pub fn integrate_ends(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    if !(b > a) {
        return 0.0;
    }
    let (nodes, weights) = rule24();
    let half = 0.5 * (b - a);
    let pi = std::f64::consts::PI;
    nodes
        .iter()
        .zip(weights)
        .map(|(&s, &w)| {
            let u = 0.5 * (s + 1.0);
            let x = a + half * (1.0 - (pi * u).cos());
            let dx_du = half * pi * (pi * u).sin();
            0.5 * w * f(x) * dx_du
        })
        .sum()
}

/// Accumulates masses into the bins of a time axis: point masses into the bin holding
/// them, uniform masses over an interval split in proportion to the overlap.
pub struct BinSpreader<'a> {
    pub axis: &'a TimeAxis,
    pub bins: Vec<f64>,
}

impl<'a> BinSpreader<'a> {
    pub fn new(axis: &'a TimeAxis) -> Self {
        BinSpreader {
            axis,
            bins: vec![0.0; axis.bins],
        }
    }

    /// `mass` at time `t_s` (whole, into one bin; nothing outside the window).
    pub fn point(&mut self, t_s: f64, mass: f64) {
        if let Some(b) = self.axis.bin_of(t_s) {
            self.bins[b] += mass;
        }
    }

    /// `mass` spread uniformly over `[a_s, b_s]` (seconds).
    pub fn uniform(&mut self, a_s: f64, b_s: f64, mass: f64) {
        if !(b_s > a_s) {
            self.point(a_s, mass);
            return;
        }
        let ax = self.axis;
        let x0 = (a_s - ax.t0_s) / ax.dt_s;
        let x1 = (b_s - ax.t0_s) / ax.dt_s;
        let n = ax.bins as f64;
        let (lo, hi) = (x0.max(0.0), x1.min(n));
        if !(hi > lo) {
            return;
        }
        let density = mass / (x1 - x0);
        let mut b = lo.floor() as usize;
        while (b as f64) < hi && b < ax.bins {
            let s = lo.max(b as f64);
            let e = hi.min(b as f64 + 1.0);
            if e > s {
                self.bins[b] += density * (e - s);
            }
            b += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let (x, w) = gauss_legendre(8);
        // Degree 15 is exact for 8 points: integral of x^14 over [-1, 1] = 2/15.
        let s: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(14)).sum();
        assert!((s - 2.0 / 15.0).abs() < 1e-14, "{s}");
        let total: f64 = w.iter().sum();
        assert!((total - 2.0).abs() < 1e-14);
    }

    #[test]
    fn square_root_ends_integrate_accurately() {
        // integral_0^1 sqrt(x (1 - x)) dx = pi / 8.
        let s = integrate_ends(0.0, 1.0, |x| (x * (1.0 - x)).sqrt());
        assert!((s - std::f64::consts::PI / 8.0).abs() < 1e-10, "{s}");
    }

    #[test]
    fn spreading_conserves_mass_inside_the_window() {
        let axis = TimeAxis::new(0.0, 1.0, 4).unwrap();
        let mut s = BinSpreader::new(&axis);
        s.uniform(0.5, 2.5, 2.0);
        s.uniform(3.5, 5.5, 2.0); // a quarter inside
        s.point(1.0, 1.0);
        s.point(9.0, 1.0);
        assert_eq!(s.bins, vec![0.5, 2.0, 0.5, 0.5]);
    }
}

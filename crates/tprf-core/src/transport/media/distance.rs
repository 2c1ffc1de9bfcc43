//! Distances along a ray in a homogeneous medium: where light scattered once toward the
//! eye arrives inside the time window (the gate), and two densities for sampling a
//! point inside it.
//!
//! A point at distance `s` along a ray from `o` (unit direction `d`, optical path `opl`
//! so far, index `n`) lit straight by a punctual light at `L` through the same medium
//! sends its light to the eye at `t(s) = (opl + n (s + |o + s d - L|)) / c`. `t` never
//! decreases along the ray (its derivative is `n (1 + cos) / c >= 0`), so the points
//! whose light arrives inside a window `[t_a, t_b]` are one interval of `s`: the ray
//! between two confocal ellipsoids around `o` and `L` ([`gate`], in closed form). Only
//! there is a point worth a shadow ray: a narrow gate behind 50 m of fog gets every
//! sample inside it, not the few free-flight sampling leaves there.
//!
//! Inside the interval a point is drawn in proportion to the transmittance of both legs
//! (through the path length, [`PathLength`]; `e^(-sigma_t s)` of the ray alone,
//! [`Exponential`], where the gate is not exact) or to the `1 / r^2` of the light
//! (equiangular sampling, Kulla & Fajardo 2012, [`Equiangular`]), or from a mixture.

/// The length `k(s) = s + |w + s d|` light travels from the light (`w = o - L`) to the
/// point at distance `s` along the ray and back to the ray's origin, m.
pub fn path_length(w: [f64; 3], d: [f64; 3], s: f64) -> f64 {
    let p = [w[0] + s * d[0], w[1] + s * d[1], w[2] + s * d[2]];
    s + (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

/// The distance `s >= 0` with `k(s) = k` ([`path_length`]): `s = (k^2 - |w|^2) / (2 (k +
/// w.d))`; 0 for `k <= |w|` (no point of the ray is reached sooner), infinite for an
/// infinite `k` or one the ray never reaches (`k + w.d <= 0`).
pub fn distance_at(w: [f64; 3], d: [f64; 3], k: f64) -> f64 {
    let len = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    let wd = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
    if k <= len {
        return 0.0;
    }
    if k.is_infinite() {
        return f64::INFINITY;
    }
    let den = 2.0 * (k + wd);
    if den > 0.0 {
        ((k - len) * (k + len) / den).max(0.0)
    } else {
        f64::INFINITY
    }
}

/// The interval of distances `s >= 0` along the ray whose single-scattered light arrives
/// inside the window: the `s` with `k(s)` in `[k_a, k_b]` ([`path_length`]), `k = (c t -
/// opl) / n` the window's ends as lengths left to travel. `None` when no point of the
/// ray lies inside (`k_b` shorter than the straight way `|w|`). The upper end is
/// infinite for an infinite `k_b`.
pub fn gate(w: [f64; 3], d: [f64; 3], k_a: f64, k_b: f64) -> Option<(f64, f64)> {
    let len = path_length(w, d, 0.0);
    if !(k_b >= len) || k_b < k_a {
        return None;
    }
    Some((distance_at(w, d, k_a), distance_at(w, d, k_b)))
}

/// Distances on the ray drawn through the path length `k(s)` ([`path_length`]): `k` in
/// proportion to `e^(-sigma_t k)` on `[k(a), k(b)]`, so the point's density is that of
/// the transmittance of both legs, the ray's and the shadow ray's, `e^(-sigma_t (s +
/// r))` (up to the Jacobian `dk/ds = 1 + cos`). For co-located light and eye it is
/// exactly the two-way transmittance `e^(-2 sigma_t s)`. Equivalently: arrival times
/// drawn in proportion to the transmittance of their path.
#[derive(Clone, Copy, Debug)]
pub struct PathLength {
    w: [f64; 3],
    d: [f64; 3],
    k: Exponential,
}

impl PathLength {
    /// `None` for an empty or infinite interval without extinction.
    pub fn new(w: [f64; 3], d: [f64; 3], a: f64, b: f64, sigma_t: f64) -> Option<PathLength> {
        let (ka, kb) = (path_length(w, d, a), path_length(w, d, b));
        if !(kb > ka) || (kb.is_infinite() && !(sigma_t > 0.0)) {
            return None;
        }
        Some(PathLength {
            w,
            d,
            k: Exponential::new(ka, kb, sigma_t),
        })
    }

    /// The distance for `u` in [0, 1).
    pub fn sample(&self, u: f64) -> f64 {
        distance_at(self.w, self.d, self.k.sample(u))
    }

    /// Density at `s`, 1/m: the density of `k(s)` times `dk/ds = 1 + d.(w + s d) / |w + s d|`.
    pub fn pdf(&self, s: f64) -> f64 {
        let (w, d) = (self.w, self.d);
        let p = [w[0] + s * d[0], w[1] + s * d[1], w[2] + s * d[2]];
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        let cos = if r > 0.0 {
            (d[0] * p[0] + d[1] * p[1] + d[2] * p[2]) / r
        } else {
            1.0
        };
        self.k.pdf(path_length(w, d, s)) * (1.0 + cos).max(0.0)
    }
}

/// Distances on `[a, b]` in proportion to `e^(-sigma_t (s - a))` (uniform when the
/// interval is optically thin, `sigma_t (b - a) < 1e-6`). `b` may be infinite when
/// `sigma_t > 0`.
#[derive(Clone, Copy, Debug)]
pub struct Exponential {
    a: f64,
    b: f64,
    sigma_t: f64,
    /// `1 - e^(-sigma_t (b - a))`: the probability of a collision within the interval.
    mass: f64,
}

impl Exponential {
    pub fn new(a: f64, b: f64, sigma_t: f64) -> Exponential {
        let mass = -(-sigma_t * (b - a)).exp_m1();
        Exponential {
            a,
            b,
            sigma_t,
            mass,
        }
    }

    fn thin(&self) -> bool {
        !(self.sigma_t * (self.b - self.a) >= 1e-6)
    }

    /// The distance for `u` in [0, 1).
    pub fn sample(&self, u: f64) -> f64 {
        let s = if self.thin() {
            self.a + u * (self.b - self.a)
        } else {
            self.a - (-u * self.mass).ln_1p() / self.sigma_t
        };
        s.clamp(self.a, self.b)
    }

    /// Density at `s` (inside the interval), 1/m.
    pub fn pdf(&self, s: f64) -> f64 {
        if self.thin() {
            1.0 / (self.b - self.a)
        } else {
            self.sigma_t * (-self.sigma_t * (s - self.a)).exp() / self.mass
        }
    }
}

/// Distances on `[a, b]` (finite) in proportion to `1 / r(s)^2`, `r` the distance to a
/// point at distance `h` from the ray whose foot is at `s = foot` (equiangular: uniform
/// in the angle the point sees the ray under). Written so that `h` may be 0 (the point
/// on the ray's line, outside the interval): then the density is `1 / (s - foot)^2`.
#[derive(Clone, Copy, Debug)]
pub struct Equiangular {
    foot: f64,
    h: f64,
    /// The interval's ends relative to the foot.
    xa: f64,
    xb: f64,
    /// Angle subtended, radians; and its normalisation `integral 1 / r^2 ds`.
    norm: f64,
}

impl Equiangular {
    /// `None` when the interval contains the point itself (`h` 0 and the foot inside),
    /// where no density in proportion to `1 / r^2` exists, or the interval is empty.
    pub fn new(a: f64, b: f64, foot: f64, h: f64) -> Option<Equiangular> {
        let (xa, xb) = (a - foot, b - foot);
        if !(b > a) || !b.is_finite() {
            return None;
        }
        // integral_xa^xb h / (h^2 + x^2) dx / h = (atan(xb/h) - atan(xa/h)) / h,
        // written as atan2(h (xb - xa), h^2 + xa xb) / h to stay exact as h -> 0.
        let norm = if h > 1e-9 * xa.abs().max(xb.abs()) {
            (h * (xb - xa)).atan2(h * h + xa * xb) / h
        } else if xa * xb > 0.0 {
            (xb - xa) / (xa * xb)
        } else {
            return None;
        };
        (norm > 0.0 && norm.is_finite()).then_some(Equiangular {
            foot,
            h,
            xa,
            xb,
            norm,
        })
    }

    /// The distance for `u` in [0, 1).
    pub fn sample(&self, u: f64) -> f64 {
        let (h, xa, xb) = (self.h, self.xa, self.xb);
        // The point at a fraction u of the subtended angle: x = h tan(theta_a + phi),
        // phi = u (theta_b - theta_a), by the tangent addition formula.
        let x = if h > 1e-9 * xa.abs().max(xb.abs()) {
            let t = (u * self.norm * h).tan();
            h * (xa + h * t) / (h - xa * t)
        } else {
            xa * xb / (xb - u * (xb - xa))
        };
        (self.foot + x).clamp(self.foot + xa, self.foot + xb)
    }

    /// Density at `s` (inside the interval), 1/m.
    pub fn pdf(&self, s: f64) -> f64 {
        let x = s - self.foot;
        1.0 / (self.norm * (self.h * self.h + x * x))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gate's ends are where the arrival crosses the window's ends, found by brute
    /// force along the ray.
    #[test]
    fn gate_matches_brute_force() {
        let cases = [
            ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 4.0, 10.0), // co-located
            ([1.0, 0.5, -2.0], [0.6, 0.0, 0.8], 3.0, 7.5),
            ([-3.0, 0.0, 0.0], [1.0, 0.0, 0.0], 3.5, 20.0), // light ahead on the ray
            ([0.2, 0.1, 0.0], [0.0, 0.6, 0.8], 0.0, 0.5),   // window from before |w|
        ];
        for (w, d, ka, kb) in cases {
            let (a, b) = gate(w, d, ka, kb).unwrap();
            let k = |s: f64| {
                let p = [w[0] + s * d[0], w[1] + s * d[1], w[2] + s * d[2]];
                s + (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
            };
            let len = k(0.0);
            if ka > len {
                assert!(
                    (k(a) - ka).abs() < 1e-9 * ka,
                    "{w:?}: k(a) {} vs {ka}",
                    k(a)
                );
            } else {
                assert_eq!(a, 0.0);
            }
            assert!(
                (k(b) - kb).abs() < 1e-9 * kb,
                "{w:?}: k(b) {} vs {kb}",
                k(b)
            );
            // Every point inside arrives inside, every point outside outside.
            for i in 0..1000 {
                let s = i as f64 * 0.02;
                let inside = k(s) >= ka && k(s) <= kb;
                if (s - a).abs() > 1e-9 && (s - b).abs() > 1e-9 {
                    assert_eq!(inside, s > a && s < b, "{w:?} s {s}");
                }
            }
        }
        // A window that closes before the straight way from the light: nothing.
        assert_eq!(gate([3.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.0, 2.9), None);
        assert_eq!(
            gate([0.0; 3], [0.0, 0.0, 1.0], 2.0, f64::INFINITY),
            Some((1.0, f64::INFINITY))
        );
    }

    /// Each sampler's samples follow its density: the mean of `g(s) / pdf(s)` is the
    /// integral of `g` (here a known closed form), and `pdf` integrates to 1.
    fn check(sample: impl Fn(f64) -> f64, pdf: impl Fn(f64) -> f64, a: f64, b: f64) {
        let n = 100_000;
        // Integral of g(s) = s over [a, b].
        let want = 0.5 * (b * b - a * a);
        let mut est = 0.0;
        for i in 0..n {
            let u = (i as f64 + 0.5) / n as f64;
            let s = sample(u);
            assert!(s >= a && s <= b, "{s} outside [{a}, {b}]");
            est += s / pdf(s) / n as f64;
        }
        assert!((est - want).abs() < 1e-3 * want, "estimate {est} vs {want}");
        let m = 200_000;
        let total: f64 = (0..m)
            .map(|i| pdf(a + (i as f64 + 0.5) * (b - a) / m as f64) * (b - a) / m as f64)
            .sum();
        assert!((total - 1.0).abs() < 1e-3, "pdf integrates to {total}");
    }

    #[test]
    fn exponential_follows_its_density() {
        for (a, b, sigma) in [(0.0, 10.0, 0.3), (2.0, 3.0, 5.0), (1.0, 4.0, 1e-9)] {
            let e = Exponential::new(a, b, sigma);
            check(|u| e.sample(u), |s| e.pdf(s), a, b);
        }
    }

    #[test]
    fn path_length_follows_its_density() {
        for (w, d, a, b, sigma) in [
            ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.5, 10.0, 0.3),
            ([1.0, 0.5, -2.0], [0.6, 0.0, 0.8], 0.0, 6.0, 1.0),
            ([0.3, 2.0, 0.0], [1.0, 0.0, 0.0], 1.0, 5.0, 1e-9),
        ] {
            let p = PathLength::new(w, d, a, b, sigma).unwrap();
            check(|u| p.sample(u), |s| p.pdf(s), a, b);
        }
    }

    #[test]
    fn equiangular_follows_its_density() {
        for (a, b, foot, h) in [
            (0.5, 10.0, 0.0, 0.0),   // co-located light and eye
            (1.0, 6.0, 3.0, 0.2),    // the foot inside
            (1.0, 6.0, -2.0, 1e-12), // the light on the line, behind
            (0.0, 4.0, 2.0, 1.5),
        ] {
            let q = Equiangular::new(a, b, foot, h).unwrap();
            check(|u| q.sample(u), |s| q.pdf(s), a, b);
        }
        assert!(Equiangular::new(0.0, 4.0, 2.0, 0.0).is_none());
    }
}

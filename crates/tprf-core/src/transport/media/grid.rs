//! Optical depth along a ray through a density grid, exactly: the integral of the
//! density, and the distance at which it reaches a given value.
//!
//! The grid's density (trilinear between cell centres, clamped at the outermost samples,
//! [`DensityGrid`]) restricted to a line is a polynomial of degree at most 3 in the
//! distance `t` between the points where the line crosses a plane through sample centres
//! (`g_axis(t) = k`, `g` the grid coordinates, `k = 0 .. n - 1`): in each such piece the
//! three interpolation weights are linear in `t`. Simpson's rule is exact for cubics, so
//! the integral over a piece `[t_a, t_b]` is `(t_b - t_a) / 6 (f(t_a) + 4 f(t_m) + f(t_b))`
//! with no error but rounding; a ray crossing `n` cells has at most `3 n + 1` pieces.
//!
//! So the transmittance `e^(-sigma_t integral_0^d density)` is exact (no ratio-tracking
//! noise), and a free-flight distance is drawn by inverting the optical depth (regular
//! tracking: the piece where it is reached, then the cubic's integral solved by Newton's
//! method kept inside the piece by bisection): the homogeneous medium's estimators with
//! its `sigma_t s` replaced by the grid's optical depth, no extra random numbers, every
//! sample's weight as for a homogeneous medium.

use crate::scene::DensityGrid;
use glam::DVec3;

/// A ray in a grid's coordinates: `g(t) = a + b t` (sample `i` of an axis at `g = i`), and
/// the distances `[t_in, t_out]` where it is inside the box.
pub(crate) struct GridLine<'a> {
    grid: &'a DensityGrid,
    a: DVec3,
    b: DVec3,
    t_in: f64,
    t_out: f64,
}

impl<'a> GridLine<'a> {
    /// The ray from `origin` along unit `dir` (metres); `None` when it misses the box
    /// (nothing to integrate) or the grid has no box.
    pub fn new(grid: &'a DensityGrid, origin: DVec3, dir: DVec3) -> Option<GridLine<'a>> {
        let [lo, hi] = grid.bbox_m?;
        let lo = DVec3::from(lo.map(f64::from));
        let hi = DVec3::from(hi.map(f64::from));
        let n = DVec3::from(grid.dims.map(f64::from));
        let scale = n / (hi - lo);
        let a = (origin - lo) * scale - 0.5;
        let b = dir * scale;
        // The box is g in [-1/2, n - 1/2] on every axis.
        let (mut t_in, mut t_out) = (0.0f64, f64::INFINITY);
        for axis in 0..3 {
            let (lo_g, hi_g) = (-0.5, n[axis] - 0.5);
            if b[axis] == 0.0 {
                if !(a[axis] >= lo_g && a[axis] <= hi_g) {
                    return None;
                }
                continue;
            }
            let t0 = (lo_g - a[axis]) / b[axis];
            let t1 = (hi_g - a[axis]) / b[axis];
            t_in = t_in.max(t0.min(t1));
            t_out = t_out.min(t0.max(t1));
        }
        (t_out > t_in).then_some(GridLine {
            grid,
            a,
            b,
            t_in,
            t_out,
        })
    }

    /// Where the ray is inside the box, metres along it.
    pub fn inside(&self) -> (f64, f64) {
        (self.t_in, self.t_out)
    }

    /// The density at distance `t` (inside the box).
    #[inline]
    pub fn density(&self, t: f64) -> f64 {
        self.grid.at_grid(self.a + self.b * t)
    }

    /// Call `piece(t_a, t_b, f(t_a), integral over [t_a, t_b])` for each piece of
    /// `[t0, t1]` inside the box on which the density is one cubic, in order, until it
    /// returns `false`.
    fn pieces(&self, t0: f64, t1: f64, mut piece: impl FnMut(f64, f64, f64, f64) -> bool) {
        let mut t = t0.max(self.t_in);
        let end = t1.min(self.t_out);
        if !(end > t) {
            return;
        }
        // Per axis: the next sample plane crossed (k), and where.
        let mut k = [0i64; 3];
        let mut next = [f64::INFINITY; 3];
        let dims = self.grid.dims.map(|n| n as i64);
        let plane_t = |axis: usize, k: i64| -> f64 {
            if k < 0 || k > dims[axis] - 1 {
                f64::INFINITY
            } else {
                (k as f64 - self.a[axis]) / self.b[axis]
            }
        };
        for axis in 0..3 {
            let (b, g) = (self.b[axis], self.a[axis] + self.b[axis] * t);
            if b > 0.0 {
                k[axis] = (g.floor() as i64 + 1).max(0);
            } else if b < 0.0 {
                k[axis] = (g.ceil() as i64 - 1).min(dims[axis] - 1);
            } else {
                continue;
            }
            next[axis] = plane_t(axis, k[axis]);
        }
        let mut f_a = self.density(t);
        loop {
            let t_next = next[0].min(next[1]).min(next[2]).min(end);
            if t_next > t {
                let f_b = self.density(t_next);
                let f_m = self.density(0.5 * (t + t_next));
                let integral = (t_next - t) / 6.0 * (f_a + 4.0 * f_m + f_b);
                if !piece(t, t_next, f_a, integral) {
                    return;
                }
                f_a = f_b;
                t = t_next;
            }
            if t_next >= end {
                return;
            }
            for axis in 0..3 {
                if next[axis] <= t_next {
                    k[axis] += if self.b[axis] > 0.0 { 1 } else { -1 };
                    next[axis] = plane_t(axis, k[axis]);
                }
            }
        }
    }

    /// `integral_t0^t1 density(t) dt`, metres (times the density's unit).
    pub fn integral(&self, t0: f64, t1: f64) -> f64 {
        let mut sum = 0.0;
        self.pieces(t0, t1, |_, _, _, i| {
            sum += i;
            true
        });
        sum
    }

    /// The distance `t` in `[t0, t1]` where `integral_t0^t density = target` (> 0); `Err`
    /// with the whole integral over `[t0, t1]` when it is less than `target`.
    pub fn invert(&self, t0: f64, t1: f64, target: f64) -> Result<f64, f64> {
        let mut acc = 0.0;
        let mut found = None;
        self.pieces(t0, t1, |ta, tb, fa, i| {
            if acc + i < target {
                acc += i;
                return true;
            }
            found = Some(self.solve_in_piece(ta, tb, fa, i, target - acc));
            false
        });
        found.ok_or(acc)
    }

    /// The `t` in `[ta, tb]` (one piece, whose integral is `total`) where the integral
    /// from `ta` is `r`: Newton's method on the exact Simpson integral, kept inside a
    /// shrinking bracket by bisection.
    fn solve_in_piece(&self, ta: f64, tb: f64, fa: f64, total: f64, r: f64) -> f64 {
        if !(total > 0.0) {
            return tb;
        }
        let r = r.clamp(0.0, total);
        let (mut lo, mut hi) = (ta, tb);
        let mut t = ta + (tb - ta) * (r / total);
        for _ in 0..60 {
            let f_t = self.density(t);
            let f_m = self.density(0.5 * (ta + t));
            let err = (t - ta) / 6.0 * (fa + 4.0 * f_m + f_t) - r;
            if err.abs() <= 1e-12 * total {
                break;
            }
            if err < 0.0 {
                lo = t;
            } else {
                hi = t;
            }
            let newton = t - err / f_t;
            t = if f_t > 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            if hi - lo <= 1e-15 * hi.abs().max(1.0) {
                break;
            }
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of random values over a box, and rays through it in every direction.
    fn grid() -> DensityGrid {
        let dims = [5u32, 3, 4];
        let mut state = 12345u64;
        let values: Vec<f32> = (0..60)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 33) as f32 / (1u64 << 31) as f32) * 3.0
            })
            .collect();
        DensityGrid::new(
            dims,
            values,
            Some([[-1.0, 0.0, 0.5], [1.5, 1.0, 2.5]]),
            None,
            "g",
        )
        .unwrap()
    }

    fn rays() -> Vec<(DVec3, DVec3)> {
        let mut out = Vec::new();
        for (o, d) in [
            ([-2.0, 0.3, 1.0], [1.0, 0.1, 0.2]),
            ([0.2, 0.4, 1.4], [0.3, -0.5, 0.8]),
            ([3.0, 2.0, 3.0], [-1.0, -0.6, -0.7]),
            ([0.0, 0.5, -1.0], [0.0, 0.0, 1.0]), // along an axis
            ([0.25, 0.5, 1.5], [1.0, 0.0, 0.0]),
        ] {
            out.push((DVec3::from(o), DVec3::from(d).normalize()));
        }
        out
    }

    /// The exact piecewise integral agrees with a fine midpoint sum of the lookup (which
    /// knows nothing of pieces), on rays that start outside, inside and along an axis.
    #[test]
    fn integral_matches_brute_force() {
        let g = grid();
        for (o, d) in rays() {
            let line = GridLine::new(&g, o, d).expect("the ray meets the box");
            // Where the ray is inside the box, by a slab test in world coordinates: the
            // density jumps to 0 there, which a midpoint sum across it would smear.
            let [lo, hi] = g.bbox_m.unwrap();
            let (mut enter, mut exit) = (0.0f64, f64::INFINITY);
            for a in 0..3 {
                let (l, h) = ((lo[a] as f64 - o[a]) / d[a], (hi[a] as f64 - o[a]) / d[a]);
                if d[a] != 0.0 {
                    enter = enter.max(l.min(h));
                    exit = exit.min(l.max(h));
                }
            }
            for (t0, t1) in [(0.0, 10.0), (0.3, 1.7), (1.1, 1.2)] {
                let (t0, t1) = (f64::max(t0, enter), f64::min(t1, exit));
                if t1 <= t0 {
                    assert_eq!(line.integral(t0, t1), 0.0);
                    continue;
                }
                let m = 400_000;
                let h = (t1 - t0) / m as f64;
                let brute: f64 = (0..m)
                    .map(|i| g.density_at(o + d * (t0 + (i as f64 + 0.5) * h)) * h)
                    .sum();
                let exact = line.integral(t0, t1);
                assert!(
                    (exact - brute).abs() <= 1e-6 * brute.max(1e-3),
                    "{o} {d} [{t0}, {t1}]: {exact} vs {brute}"
                );
            }
        }
        // A ray that misses the box.
        assert!(GridLine::new(&g, DVec3::new(5.0, 5.0, 5.0), DVec3::X).is_none());
    }

    /// Inverting the integral gives back the distance it was taken to.
    #[test]
    fn invert_is_the_inverse_of_integral() {
        let g = grid();
        for (o, d) in rays() {
            let line = GridLine::new(&g, o, d).unwrap();
            let (t_in, t_out) = line.inside();
            for f in [0.05, 0.37, 0.5, 0.93] {
                let t = t_in + f * (t_out - t_in);
                let target = line.integral(0.0, t);
                if target <= 0.0 {
                    continue;
                }
                let back = line.invert(0.0, 1e3, target).unwrap();
                assert!(
                    (line.integral(0.0, back) - target).abs() <= 1e-9 * target,
                    "{o}: {back} vs {t}"
                );
            }
            let total = line.integral(0.0, 1e3);
            assert_eq!(line.invert(0.0, 1e3, total * 1.01), Err(total));
        }
    }
}

//! A Lambertian plane seen straight down by a pinhole camera at height `h`, lit by a
//! point light on the camera's axis at height `l` (at the camera by default: a LiDAR).
//!
//! Only single scattering exists (a plane cannot light itself). A ground point at
//! distance `q` from the axis's foot has radiance `L(q) = rho I l / (pi (l^2 + q^2)^(3/2))`
//! (`rho / pi` times the irradiance `I cos / r^2`) and its light arrives at
//! `t(q) = (sqrt(l^2 + q^2) + sqrt(h^2 + q^2)) / c`. A pixel is the mean over its
//! footprint, a rectangle on the ground (the image plane is parallel to the ground, so a
//! uniform jitter on the image is uniform on the ground). Since both `L` and `t` depend
//! on `q` only, every integral over the footprint is one-dimensional:
//! `integral_rect g(q) dA = integral g(q) len(q) dq`, with `len(q)` the length of the
//! circle of radius q inside the rectangle. The bin integrals split that integral at
//! the radii where `t(q)` crosses a bin edge; each piece is integrated by Gauss-Legendre
//! after splitting at the kinks of `len(q)` (the radii of the rectangle's sides and
//! corners). Accurate to ~1e-10.
//!
//! Space may be filled with a purely absorbing medium of index `n` (absorption
//! `sigma_a`, no scattering): light then keeps `e^(-sigma_a path)` of itself over its
//! path `path = sqrt(l^2 + q^2) + sqrt(h^2 + q^2)` and arrives at `n path / c`; still
//! one scattering event, still a function of `q` only.

use crate::film::{FilmError, TimeAxis};
use crate::scene::{Camera, Material, PunctualLight, Scene, Triangle, TriangleAttrs};
use crate::units::C_M_PER_S;
use glam::{Affine3A, Vec2, Vec3};

use super::quadrature::integrate_ends;

/// The lit plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub camera_height_m: f64,
    /// Height of the point light on the camera's axis.
    pub light_height_m: f64,
    pub rho: f64,
    pub intensity_w_per_sr: f64,
    /// Half the side of the square plane, m.
    pub half_m: f64,
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    /// Absorption coefficient of the medium filling space, 1/m (0: none).
    pub sigma_a_per_m: f64,
    /// Refractive index of the medium filling space (1: vacuum).
    pub n: f64,
}

impl Default for Plane {
    fn default() -> Self {
        Plane {
            camera_height_m: 2.0,
            light_height_m: 2.0,
            rho: 0.5,
            intensity_w_per_sr: 3.0,
            half_m: 50.0,
            fov_deg: 40.0,
            sigma_a_per_m: 0.0,
            n: 1.0,
        }
    }
}

/// An axis-aligned rectangle on the ground, metres from the axis's foot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub x0: f64,
    pub x1: f64,
    pub y0: f64,
    pub y1: f64,
}

impl Rect {
    pub fn area(&self) -> f64 {
        (self.x1 - self.x0) * (self.y1 - self.y0)
    }

    /// Nearest and farthest distance of the rectangle from the origin.
    pub fn radial_range(&self) -> (f64, f64) {
        let dx = if self.x0 > 0.0 {
            self.x0
        } else if self.x1 < 0.0 {
            -self.x1
        } else {
            0.0
        };
        let dy = if self.y0 > 0.0 {
            self.y0
        } else if self.y1 < 0.0 {
            -self.y1
        } else {
            0.0
        };
        let fx = self.x0.abs().max(self.x1.abs());
        let fy = self.y0.abs().max(self.y1.abs());
        (dx.hypot(dy), fx.hypot(fy))
    }

    /// Radii where the arc length inside the rectangle has a kink: the sides' distances
    /// and the corners' distances.
    fn kinks(&self) -> [f64; 8] {
        [
            self.x0.abs(),
            self.x1.abs(),
            self.y0.abs(),
            self.y1.abs(),
            self.x0.hypot(self.y0),
            self.x0.hypot(self.y1),
            self.x1.hypot(self.y0),
            self.x1.hypot(self.y1),
        ]
    }

    /// Length of the circle of radius `q` about the origin inside the rectangle.
    pub fn arc_length(&self, q: f64) -> f64 {
        if !(q > 0.0) {
            return 0.0;
        }
        let tau = std::f64::consts::TAU;
        let mut cuts = vec![0.0, tau];
        let mut add = |a: f64| cuts.push(a.rem_euclid(tau));
        for x in [self.x0, self.x1] {
            if x.abs() <= q {
                let a = (x / q).acos();
                add(a);
                add(-a);
            }
        }
        for y in [self.y0, self.y1] {
            if y.abs() <= q {
                let a = (y / q).asin();
                add(a);
                add(std::f64::consts::PI - a);
            }
        }
        cuts.sort_by(f64::total_cmp);
        let mut inside = 0.0;
        for w in cuts.windows(2) {
            let mid = 0.5 * (w[0] + w[1]);
            let (x, y) = (q * mid.cos(), q * mid.sin());
            if x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1 {
                inside += w[1] - w[0];
            }
        }
        q * inside
    }

    /// `integral over the rectangle of g(q) dA` for `q` in `[q_lo, q_hi]`.
    pub fn radial_integral(&self, q_lo: f64, q_hi: f64, g: impl Fn(f64) -> f64) -> f64 {
        let (a, b) = self.radial_range();
        let (lo, hi) = (q_lo.max(a), q_hi.min(b));
        if !(hi > lo) {
            return 0.0;
        }
        let mut cuts: Vec<f64> = self
            .kinks()
            .into_iter()
            .filter(|&k| k > lo && k < hi)
            .collect();
        cuts.push(lo);
        cuts.push(hi);
        cuts.sort_by(f64::total_cmp);
        cuts.windows(2)
            .map(|w| integrate_ends(w[0], w[1], |q| g(q) * self.arc_length(q)))
            .sum()
    }
}

/// Integrals of one pixel: mean radiance, energy-weighted mean arrival, and the standard
/// deviations of radiance and arrival over the footprint (what one jittered sample
/// scatters by), plus the mean of the squared radiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelMoments {
    pub mean: f64,
    pub mean_arrival_s: f64,
    pub sd: f64,
    pub sd_arrival_s: f64,
    pub mean_square: f64,
}

impl Plane {
    /// A co-located light (at the camera), the classic LiDAR set-up.
    pub fn colocated(h_m: f64, rho: f64, i_w_per_sr: f64, half_m: f64, fov_deg: f64) -> Plane {
        Plane {
            camera_height_m: h_m,
            light_height_m: h_m,
            rho,
            intensity_w_per_sr: i_w_per_sr,
            half_m,
            fov_deg,
            sigma_a_per_m: 0.0,
            n: 1.0,
        }
    }

    /// The same, in a purely absorbing medium of absorption `sigma_a_per_m` and index `n`.
    pub fn in_medium(self, sigma_a_per_m: f64, n: f64) -> Plane {
        Plane {
            sigma_a_per_m,
            n,
            ..self
        }
    }

    /// Whether the numbers make a valid scene.
    pub fn check(&self) -> Result<(), String> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if !(ok(self.camera_height_m) && ok(self.light_height_m) && ok(self.half_m)) {
            return Err("heights and size must be finite and > 0".into());
        }
        if !(self.fov_deg > 0.0 && self.fov_deg < 170.0) {
            return Err(format!(
                "field of view {} degrees outside (0, 170)",
                self.fov_deg
            ));
        }
        if !(self.rho.is_finite() && (0.0..=1.0).contains(&self.rho)) {
            return Err(format!("albedo {} outside [0, 1]", self.rho));
        }
        if !(self.intensity_w_per_sr.is_finite() && self.intensity_w_per_sr >= 0.0) {
            return Err("intensity must be finite and >= 0".into());
        }
        if !(self.sigma_a_per_m.is_finite() && self.sigma_a_per_m >= 0.0) {
            return Err(format!(
                "absorption {} /m must be finite and >= 0",
                self.sigma_a_per_m
            ));
        }
        if !(self.n.is_finite() && self.n >= 1.0) {
            return Err(format!(
                "refractive index {} must be finite and >= 1",
                self.n
            ));
        }
        Ok(())
    }

    fn tan_half(&self) -> f64 {
        (0.5 * self.fov_deg.to_radians()).tan()
    }

    /// The scene: the square plane z = 0 (albedo rho), the camera at `(0, 0, h)` looking
    /// down -Z (+Y up in the image), the point light at `(0, 0, l)`.
    pub fn scene(&self) -> Scene {
        let h = self.camera_height_m as f32;
        let half = self.half_m as f32;
        let (a, b, c, d) = (
            Vec3::new(-half, -half, 0.0),
            Vec3::new(half, -half, 0.0),
            Vec3::new(half, half, 0.0),
            Vec3::new(-half, half, 0.0),
        );
        let attrs = TriangleAttrs {
            normals: None,
            uv: [Vec2::ZERO; 3],
            material: 0,
        };
        Scene {
            name: "plane".into(),
            triangles: vec![Triangle { p: [a, b, c] }, Triangle { p: [a, c, d] }],
            attrs: vec![attrs; 2],
            materials: vec![Material::lambertian("plane", [self.rho as f32; 3])],
            textures: Vec::new(),
            lights: vec![PunctualLight {
                name: "point".into(),
                position: Vec3::new(0.0, 0.0, self.light_height_m as f32),
                intensity_w_per_sr: [self.intensity_w_per_sr as f32; 3],
                spot: None,
                projector: None,
            }],
            camera: Camera {
                world_from_camera: Affine3A::from_translation(Vec3::new(0.0, 0.0, h)),
                fov_rad: self.fov_deg.to_radians() as f32,
                fov_axis: crate::scene::FovAxis::Y,
                near_m: crate::scene::camera::DEFAULT_NEAR_M,
            },
            ambient: Default::default(),
            objects: Vec::new(),
            medium: (self.sigma_a_per_m > 0.0 || self.n != 1.0).then(|| {
                crate::scene::Medium::grey(0.0, self.sigma_a_per_m as f32, 0.0, self.n as f32)
            }),
            notes: Vec::new(),
        }
    }

    /// Length of the light's path via the ground at distance `q` from the foot, m.
    fn path_m(&self, q: f64) -> f64 {
        let (h, l) = (self.camera_height_m, self.light_height_m);
        (l * l + q * q).sqrt() + (h * h + q * q).sqrt()
    }

    /// Radiance reaching the camera from the ground at distance `q` from the foot,
    /// W / (m^2 sr): `rho I l / (pi (l^2 + q^2)^(3/2)) e^(-sigma_a path)`.
    pub fn radiance(&self, q: f64) -> f64 {
        let l = self.light_height_m;
        let attenuation = if self.sigma_a_per_m > 0.0 {
            (-self.sigma_a_per_m * self.path_m(q)).exp()
        } else {
            1.0
        };
        self.rho * self.intensity_w_per_sr * l / (std::f64::consts::PI * (l * l + q * q).powf(1.5))
            * attenuation
    }

    /// Arrival time of the light from the ground at distance `q`, seconds: `n path / c`.
    pub fn arrival_s(&self, q: f64) -> f64 {
        self.n * self.path_m(q) / C_M_PER_S
    }

    /// The `q` with `arrival_s(q) = t_s` (bisection; `arrival_s` increases with q).
    pub(super) fn q_of_arrival(&self, t_s: f64, q_max: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, q_max);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if self.arrival_s(mid) < t_s {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo <= 1e-15 * hi.max(1e-300) {
                break;
            }
        }
        0.5 * (lo + hi)
    }

    /// The footprint of pixels `[x0, x1) x [y0, y1)` of a `w x h` image on the ground.
    pub fn footprint(&self, x0: f64, x1: f64, y0: f64, y1: f64, w: usize, h: usize) -> Rect {
        let t = self.tan_half();
        let aspect = w as f64 / h.max(1) as f64;
        let hm = self.camera_height_m;
        let sx = |px: f64| (2.0 * px / w as f64 - 1.0) * t * aspect * hm;
        let sy = |py: f64| (1.0 - 2.0 * py / h as f64) * t * hm;
        Rect {
            x0: sx(x0),
            x1: sx(x1),
            y0: sy(y1),
            y1: sy(y0),
        }
    }

    pub(super) fn pixel_rect(&self, x: usize, y: usize, w: usize, h: usize) -> Rect {
        self.footprint(x as f64, x as f64 + 1.0, y as f64, y as f64 + 1.0, w, h)
    }

    /// Expected TPRF of pixel `(x, y)` (row 0 = top) of a `w x h` image on `axis`.
    pub fn pixel_tprf(&self, x: usize, y: usize, w: usize, h: usize, axis: &TimeAxis) -> Vec<f64> {
        let rect = self.pixel_rect(x, y, w, h);
        let mut out = vec![0.0; axis.bins];
        let (q_lo, q_hi) = rect.radial_range();
        let mut cuts = vec![q_lo, q_hi];
        for b in 0..=axis.bins {
            let t = axis.bin_start_s(b);
            if t > self.arrival_s(q_lo) && t < self.arrival_s(q_hi) {
                cuts.push(self.q_of_arrival(t, q_hi));
            }
        }
        cuts.sort_by(f64::total_cmp);
        let area = rect.area();
        for w in cuts.windows(2) {
            let Some(b) = axis.bin_of(self.arrival_s(0.5 * (w[0] + w[1]))) else {
                continue;
            };
            out[b] += rect.radial_integral(w[0], w[1], |q| self.radiance(q)) / area;
        }
        out
    }

    /// Footprint integrals of pixel `(x, y)` of a `w x h` image.
    pub fn pixel_moments(&self, x: usize, y: usize, w: usize, h: usize) -> PixelMoments {
        self.rect_moments(&self.pixel_rect(x, y, w, h))
    }

    /// Footprint integrals over any ground rectangle.
    pub fn rect_moments(&self, rect: &Rect) -> PixelMoments {
        let area = rect.area();
        let int = |g: &dyn Fn(f64) -> f64| rect.radial_integral(0.0, f64::INFINITY, g) / area;
        let mean = int(&|q| self.radiance(q));
        let mean_square = int(&|q| self.radiance(q).powi(2));
        let lt = int(&|q| self.radiance(q) * self.arrival_s(q));
        let t1 = int(&|q| self.arrival_s(q));
        let t2 = int(&|q| self.arrival_s(q).powi(2));
        PixelMoments {
            mean,
            mean_arrival_s: lt / mean,
            sd: (mean_square - mean * mean).max(0.0).sqrt(),
            sd_arrival_s: (t2 - t1 * t1).max(0.0).sqrt(),
            mean_square,
        }
    }

    /// From 2 % before the earliest to 2 % after the latest arrival in a `w x h` image.
    pub fn default_axis(&self, w: usize, h: usize, bins: usize) -> Result<TimeAxis, FilmError> {
        let (q_lo, q_hi) = self
            .footprint(0.0, w as f64, 0.0, h as f64, w, h)
            .radial_range();
        let (t_lo, t_hi) = (self.arrival_s(q_lo), self.arrival_s(q_hi));
        let span = t_hi - t_lo;
        let t0 = t_lo - 0.02 * span;
        TimeAxis::new(t0, 1.04 * span / bins.max(1) as f64, bins)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arc_lengths_integrate_to_the_area() {
        for r in [
            Rect {
                x0: -1.0,
                x1: 2.0,
                y0: -0.5,
                y1: 0.7,
            },
            Rect {
                x0: 0.3,
                x1: 0.4,
                y0: -0.05,
                y1: 0.02,
            },
            Rect {
                x0: 1.0,
                x1: 3.0,
                y0: 2.0,
                y1: 2.5,
            },
        ] {
            let a = r.radial_integral(0.0, f64::INFINITY, |_| 1.0);
            assert!(
                (a - r.area()).abs() < 1e-10 * r.area(),
                "{a} vs {}",
                r.area()
            );
        }
    }

    #[test]
    fn pixel_mean_matches_a_brute_force_footprint_average() {
        let p = Plane::default();
        for (x, y) in [(0, 0), (5, 3), (11, 8), (6, 4)] {
            let m = p.pixel_moments(x, y, 12, 9);
            let rect = p.pixel_rect(x, y, 12, 9);
            let n = 600;
            let mut s = 0.0;
            for i in 0..n {
                for j in 0..n {
                    let gx = rect.x0 + (rect.x1 - rect.x0) * (i as f64 + 0.5) / n as f64;
                    let gy = rect.y0 + (rect.y1 - rect.y0) * (j as f64 + 0.5) / n as f64;
                    s += p.radiance(gx.hypot(gy));
                }
            }
            s /= (n * n) as f64;
            assert!(
                (m.mean - s).abs() < 1e-6 * s,
                "({x},{y}): {} vs {s}",
                m.mean
            );
            let axis = p.default_axis(12, 9, 40).unwrap();
            let binned: f64 = p.pixel_tprf(x, y, 12, 9, &axis).iter().sum();
            assert!(
                (binned - m.mean).abs() < 1e-9 * m.mean,
                "{binned} vs {}",
                m.mean
            );
        }
    }
}

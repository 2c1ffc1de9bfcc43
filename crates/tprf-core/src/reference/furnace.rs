//! The transient furnace: a closed Lambertian sphere of radius R and albedo rho, the
//! camera at the centre, lit by a point light at the centre or by the wall's own
//! emission, pulsed at t = 0.
//!
//! Inside a sphere `cos(theta_x) cos(theta_y) / |x - y|^2 = 1 / (4 R^2)` for any two wall
//! points, so after the first arrival the radiance leaving the wall is uniform, and a
//! light path from one wall point to the next is a chord whose length `d` has density
//! `d / (2 R^2)` on [0, 2R] (cosine-distributed directions), mean `4R/3`. The TPRF of
//! every pixel is therefore
//!
//! `TPRF(x) = w0 [delta(x - x0) + sum_{j >= 1} rho^j f^{*j}(x - x0)]`
//!
//! in optical path length x (time `x / c`), with `f` the chord density, `f^{*j}` its
//! j-fold convolution (the sum of j independent chords), and
//! - point light: first arrival `x0 = 2R` (light -> wall -> eye), `w0 = rho I / (pi R^2)`;
//! - emitting wall (radiance `Le`): `x0 = R` (wall -> eye), `w0 = Le`.
//!
//! Laws: total energy `w0 / (1 - rho)`; mean optical path `x0 + (4R/3) rho / (1 - rho)`.
//! The series is summed by its renewal equation `G = rho f + rho f * G` on a fine grid
//! (each chord rounded to the nearest grid point, so sums of chords stay on the grid and
//! there is no drift with the number of bounces), then spread into time bins.
//!
//! The rendered sphere is an icosphere (level 5, 20 480 facets) with its vertices on
//! the sphere: its facets lie up to 2.4e-4 R inside, a bias of a few 1e-4 on the
//! energy (documented in docs/accuracy.md).

use crate::film::{FilmError, TimeAxis};
use crate::scene::{Camera, Material, PunctualLight, Scene, Triangle, TriangleAttrs};
use crate::units::C_M_PER_S;
use glam::{Vec2, Vec3};

use super::BinSpreader;

/// What lights the furnace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FurnaceLight {
    /// A point light at the centre, W/sr.
    Point { intensity_w_per_sr: f64 },
    /// The wall itself emits this radiance, W / (m^2 sr).
    Area { radiance: f64 },
}

/// A transient furnace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Furnace {
    pub radius_m: f64,
    /// Albedo in [0, 1).
    pub rho: f64,
    pub light: FurnaceLight,
}

impl Default for Furnace {
    fn default() -> Self {
        Furnace {
            radius_m: 1.0,
            rho: 0.9,
            light: FurnaceLight::Point {
                intensity_w_per_sr: 1.0,
            },
        }
    }
}

/// Subdivision level of the rendered icosphere.
pub const ICOSPHERE_LEVEL: u32 = 5;

/// An icosphere of radius `r_m` (the icosahedron subdivided `level` times), vertices on
/// the sphere, faces wound counter-clockwise seen from outside.
pub fn icosphere(r_m: f32, level: u32) -> Vec<[Vec3; 3]> {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let v = [
        Vec3::new(-1.0, t, 0.0),
        Vec3::new(1.0, t, 0.0),
        Vec3::new(-1.0, -t, 0.0),
        Vec3::new(1.0, -t, 0.0),
        Vec3::new(0.0, -1.0, t),
        Vec3::new(0.0, 1.0, t),
        Vec3::new(0.0, -1.0, -t),
        Vec3::new(0.0, 1.0, -t),
        Vec3::new(t, 0.0, -1.0),
        Vec3::new(t, 0.0, 1.0),
        Vec3::new(-t, 0.0, -1.0),
        Vec3::new(-t, 0.0, 1.0),
    ];
    let f = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut tris: Vec<[Vec3; 3]> = f
        .iter()
        .map(|i| {
            [
                v[i[0]].normalize(),
                v[i[1]].normalize(),
                v[i[2]].normalize(),
            ]
        })
        .collect();
    for _ in 0..level {
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let ab = (a + b).normalize();
                let bc = (b + c).normalize();
                let ca = (c + a).normalize();
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    tris.iter().map(|t| t.map(|p| p * r_m)).collect()
}

impl Furnace {
    /// A furnace lit by a point light of `i_w_per_sr` at the centre.
    pub fn point(radius_m: f64, rho: f64, i_w_per_sr: f64) -> Furnace {
        Furnace {
            radius_m,
            rho,
            light: FurnaceLight::Point {
                intensity_w_per_sr: i_w_per_sr,
            },
        }
    }

    /// A furnace whose wall emits radiance `le`.
    pub fn emitting(radius_m: f64, rho: f64, le: f64) -> Furnace {
        Furnace {
            radius_m,
            rho,
            light: FurnaceLight::Area { radiance: le },
        }
    }

    /// First arrival (optical path, m) and its radiance `w0`.
    pub fn first_arrival(&self) -> (f64, f64) {
        let r = self.radius_m;
        match self.light {
            FurnaceLight::Point { intensity_w_per_sr } => (
                2.0 * r,
                self.rho * intensity_w_per_sr / (std::f64::consts::PI * r * r),
            ),
            FurnaceLight::Area { radiance } => (r, radiance),
        }
    }

    /// Steady radiance over all time: `w0 / (1 - rho)`.
    pub fn energy(&self) -> f64 {
        self.first_arrival().1 / (1.0 - self.rho)
    }

    /// Energy-weighted mean arrival over all time, seconds:
    /// `(x0 + (4R/3) rho / (1 - rho)) / c`.
    pub fn mean_arrival_s(&self) -> f64 {
        let (x0, _) = self.first_arrival();
        (x0 + 4.0 * self.radius_m / 3.0 * self.rho / (1.0 - self.rho)) / C_M_PER_S
    }

    /// The scene: the icosphere, Lambertian albedo rho, camera at the centre looking
    /// along -Z with a 60 degree field of view, and the light.
    pub fn scene(&self) -> Scene {
        let r = self.radius_m as f32;
        let rho = self.rho as f32;
        let mut wall = Material::lambertian("wall", [rho; 3]);
        let mut lights = Vec::new();
        match self.light {
            FurnaceLight::Point { intensity_w_per_sr } => lights.push(PunctualLight {
                name: "centre".into(),
                position: Vec3::ZERO,
                intensity_w_per_sr: [intensity_w_per_sr as f32; 3],
                spot: None,
                projector: None,
            }),
            FurnaceLight::Area { radiance } => wall.emissive = [radiance as f32; 3],
        }
        let tris = icosphere(r, ICOSPHERE_LEVEL);
        Scene {
            name: format!("furnace R={} rho={}", self.radius_m, self.rho),
            attrs: vec![
                TriangleAttrs {
                    normals: None,
                    uv: [Vec2::ZERO; 3],
                    material: 0,
                };
                tris.len()
            ],
            triangles: tris.into_iter().map(|p| Triangle { p }).collect(),
            materials: vec![wall],
            textures: Vec::new(),
            lights,
            camera: Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 60f32.to_radians()),
            ambient: Default::default(),
            objects: Vec::new(),
            medium: None,
            notes: Vec::new(),
        }
    }

    /// Number of chords (after the first arrival) that holds 99 % of the energy.
    fn bounces_99(&self) -> f64 {
        if self.rho <= 0.0 {
            0.0
        } else {
            (0.01f64.ln() / self.rho.ln()).max(1.0)
        }
    }

    /// From t = 0 to the first arrival plus the mean length of the chords that hold 99 %
    /// of the energy, in `bins` bins.
    pub fn default_axis(&self, bins: usize) -> Result<TimeAxis, FilmError> {
        let (x0, _) = self.first_arrival();
        let end_m = x0 + (4.0 * self.radius_m / 3.0 * self.bounces_99()).max(4.0 * self.radius_m);
        TimeAxis::new(0.0, end_m / C_M_PER_S / bins.max(1) as f64, bins)
    }

    /// The expected TPRF of every pixel on `axis`: bin integrals of radiance.
    pub fn tprf(&self, axis: &TimeAxis) -> Vec<f64> {
        let r = self.radius_m;
        let rho = self.rho;
        let (x0, w0) = self.first_arrival();
        let mut out = BinSpreader::new(axis);
        out.point(x0 / C_M_PER_S, w0);
        let horizon_m = axis.end_s() * C_M_PER_S - x0;
        if !(horizon_m > 0.0) || rho <= 0.0 {
            return out.bins;
        }
        // Grid step: fine against the radius and the bins, at most ~4e6 grid points and
        // ~2e9 multiply-adds (grid points x kernel points).
        let mut h = (r / 200.0).min(0.5 * axis.dt_s * C_M_PER_S).max(r / 4000.0);
        h = h
            .max(horizon_m / 4e6)
            .max((horizon_m * 2.0 * r / 2e9).sqrt());
        let n = (horizon_m / h).ceil() as usize + 1;
        let m_max = (2.0 * r / h).ceil() as usize + 1;
        // Chord mass rounded to grid point m: CDF (d / 2R)^2 over [(m - 1/2) h, (m + 1/2) h].
        let cdf = |d: f64| (d.clamp(0.0, 2.0 * r) / (2.0 * r)).powi(2);
        let kernel: Vec<f64> = (0..=m_max)
            .map(|m| cdf((m as f64 + 0.5) * h) - cdf((m as f64 - 0.5) * h))
            .collect();
        // Renewal equation G = rho K + rho K * G, solved point by point.
        let mut g = vec![0.0; n];
        let self_term = 1.0 - rho * kernel[0];
        for i in 0..n {
            let mut s = kernel.get(i).copied().unwrap_or(0.0);
            let top = i.min(m_max);
            for (m, k) in kernel.iter().enumerate().take(top + 1).skip(1) {
                s += k * g[i - m];
            }
            g[i] = rho * s / self_term;
        }
        // Each grid mass stands for the chord sums within half a step of its point.
        for (i, &mass) in g.iter().enumerate() {
            if mass == 0.0 {
                continue;
            }
            let a = x0 + (i as f64 - 0.5).max(0.0) * h;
            let b = x0 + (i as f64 + 0.5) * h;
            out.uniform(a / C_M_PER_S, b / C_M_PER_S, w0 * mass);
        }
        out.bins
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mean_opl(tprf: &[f64], axis: &TimeAxis) -> f64 {
        let total: f64 = tprf.iter().sum();
        tprf.iter()
            .enumerate()
            .map(|(b, v)| v * axis.bin_center_s(b) * C_M_PER_S)
            .sum::<f64>()
            / total
    }

    #[test]
    fn long_window_holds_the_closed_form_energy_and_mean() {
        for rho in [0.5, 0.9, 0.99] {
            for f in [
                Furnace::point(1.0, rho, 2.0),
                Furnace::emitting(0.5, rho, 1.0),
            ] {
                // A window 40 times longer than the mean path: the tail is negligible.
                let end_m = 40.0 * f.mean_arrival_s() * C_M_PER_S;
                let axis = TimeAxis::new(0.0, end_m / C_M_PER_S / 2000.0, 2000).unwrap();
                let tprf = f.tprf(&axis);
                let e: f64 = tprf.iter().sum();
                assert!(
                    (e - f.energy()).abs() < 1e-9 * f.energy(),
                    "rho {rho}: {e} vs {}",
                    f.energy()
                );
                let m = mean_opl(&tprf, &axis);
                let want = f.mean_arrival_s() * C_M_PER_S;
                // Bin centres against exact positions: half a bin at most.
                assert!(
                    (m - want).abs() < 1e-4 * want + 0.5 * axis.dt_s * C_M_PER_S,
                    "rho {rho}: mean path {m} vs {want}"
                );
            }
        }
    }

    #[test]
    fn second_arrival_is_the_chord_density() {
        // rho small: the j = 1 term dominates after the delta; its mass in [x0, x0 + d]
        // is rho w0 (d / 2R)^2.
        let f = Furnace::emitting(1.0, 1e-6, 1.0);
        let axis = TimeAxis::new(0.0, 0.1 / C_M_PER_S, 40).unwrap();
        let t = f.tprf(&axis);
        let b0 = axis.bin_of(1.0 / C_M_PER_S).unwrap();
        assert!((t[b0] - 1.0).abs() < 1e-8, "delta at x0 = R: {}", t[b0]);
        for (b, got) in t.iter().enumerate().skip(b0 + 1).take(19) {
            let d = |s: f64| (s * C_M_PER_S - 1.0).clamp(0.0, 2.0);
            let (d1, d2) = (d(axis.bin_start_s(b)), d(axis.bin_start_s(b + 1)));
            let want = 1e-6 * ((d2 / 2.0).powi(2) - (d1 / 2.0).powi(2));
            assert!(
                (got - want).abs() < 1e-3 * want + 1e-18,
                "bin {b}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn icosphere_vertices_lie_on_the_sphere() {
        let tris = icosphere(2.0, 3);
        assert_eq!(tris.len(), 20 * 64);
        assert!(
            tris.iter()
                .flatten()
                .all(|p| (p.length() - 2.0).abs() < 1e-5)
        );
        // Counter-clockwise from outside: the geometric normal points away from the centre.
        assert!(
            tris.iter()
                .all(|[a, b, c]| (*b - *a).cross(*c - *a).dot(*a) > 0.0)
        );
    }
}

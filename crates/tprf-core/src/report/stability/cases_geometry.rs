//! Geometry: a point light 1e-6 m from a wall, grazing light and view, coincident faces
//! and degenerate triangles, each against footprint integrals or a quadrature of the
//! single-bounce formula.

use super::common::{Size, mean, non_finite, render, triangle_attrs};
use super::verdict::{Check, Kind, Row};
use crate::film::TimeAxis;
use crate::reference::gauss_legendre;
use crate::reference::plane::{Plane, Rect};
use crate::scene::{Camera, Scene, Triangle};
use crate::transport::RenderSettings;
use crate::units::C_M_PER_S;
use glam::Vec3;

/// A wall seen straight down from 1 m, a point light 1e-6 m above the centre of the
/// middle pixel. Every pixel's mean radiance has an exact footprint integral. The pixel
/// holding the light's foot is unbiased but its estimator has a relative variance per
/// sample of about `A / (8 pi d^2)` (A the footprint, d the distance): half the light
/// lands within ~d of the foot, which a uniform jitter over the pixel rarely finds. Its
/// error is bounded by Chebyshev: within 10 predicted standard errors with probability
/// 99 %. The other pixels converge normally.
pub fn light_near_wall(size: Size) -> Vec<Row> {
    let mut rows = Vec::new();
    let d = 1e-6;
    let n_px = size.pick(9, 15);
    let spp = size.pick(256, 4096);
    let plane = Plane {
        camera_height_m: 1.0,
        light_height_m: d,
        rho: 0.5,
        intensity_w_per_sr: 1.0,
        half_m: 1.0,
        fov_deg: 2.0,
        ..Plane::default()
    };
    let axis = TimeAxis::new(0.9 / C_M_PER_S, 0.2 / C_M_PER_S, 2).expect("axis");
    let film = render(
        plane.scene(),
        n_px,
        n_px,
        axis,
        spp,
        RenderSettings {
            seed: 3,
            ..RenderSettings::default()
        },
        0,
    );
    let bad = non_finite(&film);
    let steady = film.steady();
    let c = n_px / 2;
    let setting = format!("{n_px}x{n_px} px, {spp} spp, d = 1e-6 m, footprint 1 m away");
    let (mut want, mut var, mut got) = (0.0, 0.0, 0.0);
    for y in 0..n_px {
        for x in 0..n_px {
            if (x, y) == (c, c) {
                continue;
            }
            let m = plane.pixel_moments(x, y, n_px, n_px);
            want += m.mean;
            var += m.sd * m.sd / spp as f64;
            got += steady[y * n_px + x];
        }
    }
    rows.push(Row {
        case: "light 1e-6 m from a wall: all pixels but the foot's".into(),
        setting: setting.clone(),
        kind: Kind::Reference,
        check: Check::Within {
            expected: want,
            tolerance: 5.0 * var.sqrt() + 1e-5 * want,
        },
        got,
        non_finite: bad,
        note: "sum of the exact footprint integrals, 5 standard errors".into(),
    });
    let m = plane.pixel_moments(c, c, n_px, n_px);
    let rect: Rect = plane.footprint(
        c as f64,
        c as f64 + 1.0,
        c as f64,
        c as f64 + 1.0,
        n_px,
        n_px,
    );
    let se = m.sd / (spp as f64).sqrt();
    rows.push(Row {
        case: "light 1e-6 m from a wall: the foot's pixel".into(),
        setting,
        kind: Kind::Reference,
        check: Check::Within {
            expected: m.mean,
            tolerance: 10.0 * se,
        },
        got: steady[c * n_px + c],
        non_finite: bad,
        note: format!(
            "unbiased, finite; relative sd per sample {:.0} (A/(8 pi d^2) = {:.0}, A = {:.2e} \
             m^2): error bounded by 10 predicted standard errors (Chebyshev, 99 %)",
            m.sd / m.mean,
            (rect.area() / (8.0 * std::f64::consts::PI * d * d)).sqrt(),
            rect.area()
        ),
    });
    rows
}

// ---------------------------------------------------------------------------------------
// Grazing angles.

/// Mean over pixel `(x, y)` of `g(direction)` for a pinhole camera: 8 x 8 Gauss-Legendre
/// points over the pixel (a smooth integrand), with the camera's own convention
/// `dir = world_from_camera (sx, sy, -1)`, `sx, sy` linear in the pixel coordinates.
fn pixel_quadrature(
    cam: &Camera,
    x: usize,
    y: usize,
    w: usize,
    h: usize,
    g: &dyn Fn([f64; 3], [f64; 3]) -> f64,
) -> (f64, f64) {
    let (nodes, weights) = gauss_legendre(8);
    let aspect = w as f64 / h as f64;
    let t = cam.tan_half_fov(aspect as f32).1 as f64;
    let m = cam.world_from_camera.matrix3;
    let col = |c: glam::Vec3A| [c.x as f64, c.y as f64, c.z as f64];
    let (cx, cy, cz) = (col(m.x_axis), col(m.y_axis), col(m.z_axis));
    let o = cam.position();
    let origin = [o.x as f64, o.y as f64, o.z as f64];
    let (mut s1, mut s2) = (0.0, 0.0);
    for (&a, &wa) in nodes.iter().zip(&weights) {
        for (&b, &wb) in nodes.iter().zip(&weights) {
            let px = x as f64 + 0.5 * (a + 1.0);
            let py = y as f64 + 0.5 * (b + 1.0);
            let sx = (2.0 * px / w as f64 - 1.0) * t * aspect;
            let sy = (1.0 - 2.0 * py / h as f64) * t;
            let mut d = [0.0; 3];
            for k in 0..3 {
                d[k] = cx[k] * sx + cy[k] * sy - cz[k];
            }
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let d = d.map(|v| v / len);
            let v = g(origin, d);
            let wt = 0.25 * wa * wb;
            s1 += wt * v;
            s2 += wt * v * v;
        }
    }
    (s1, (s2 - s1 * s1).max(0.0))
}

/// A Lambertian plane z = 0 lit by a point light `light` of intensity `i`, seen by
/// `cam`: single scattering only. Returns the rendered and the exact image means and the
/// standard error.
fn plane_case(
    cam: Camera,
    light: [f64; 3],
    i: f64,
    rho: f64,
    n: usize,
    spp: u64,
    extra: impl Fn(&mut Scene),
) -> (f64, f64, f64, u64) {
    let half = 50.0f32;
    let mut scene = Plane {
        camera_height_m: 1.0,
        light_height_m: 1.0,
        rho,
        intensity_w_per_sr: i,
        half_m: half as f64,
        fov_deg: 10.0,
        ..Plane::default()
    }
    .scene();
    scene.camera = cam;
    scene.lights[0].position = Vec3::new(light[0] as f32, light[1] as f32, light[2] as f32);
    extra(&mut scene);
    let axis = TimeAxis::new(0.0, 2000.0 / C_M_PER_S, 1).expect("axis");
    let film = render(
        scene,
        n,
        n,
        axis,
        spp,
        RenderSettings {
            seed: 11,
            ..RenderSettings::default()
        },
        0,
    );
    let radiance = |o: [f64; 3], d: [f64; 3]| -> f64 {
        if !(d[2] < 0.0) {
            return 0.0;
        }
        let t = -o[2] / d[2];
        let p = [o[0] + t * d[0], o[1] + t * d[1], 0.0];
        if p[0].abs() > half as f64 || p[1].abs() > half as f64 {
            return 0.0;
        }
        let v = [light[0] - p[0], light[1] - p[1], light[2]];
        let r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        rho / std::f64::consts::PI * i * (light[2] / r2.sqrt()) / r2
    };
    let (mut want, mut var) = (0.0, 0.0);
    for y in 0..n {
        for x in 0..n {
            let (m, v) = pixel_quadrature(&cam, x, y, n, n, &radiance);
            want += m;
            var += v / spp as f64;
        }
    }
    let k = (n * n) as f64;
    (
        mean(&film.steady()),
        want / k,
        var.sqrt() / k,
        non_finite(&film),
    )
}

/// Light grazing a plane (0.57 degrees above it at the image centre) and a view grazing
/// it (3 to 7 degrees) with the light at the camera.
pub fn grazing(size: Size) -> Vec<Row> {
    let (n, spp) = (size.pick(8, 24), size.pick(32, 128));
    let mut rows = Vec::new();
    let down = Camera::look_at(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO, 10f32.to_radians());
    let (got, want, se, bad) = plane_case(down, [-20.0, 0.0, 0.2], 100.0, 0.5, n, spp, |_| {});
    rows.push(Row {
        case: "grazing light (0.57 deg above the plane)".into(),
        setting: format!("{n}x{n} px, {spp} spp, camera 1 m above, looking down"),
        kind: Kind::Reference,
        check: Check::Within {
            expected: want,
            tolerance: 5.0 * se + 1e-4 * want,
        },
        got,
        non_finite: bad,
        note: "rho I cos / (pi r^2) over each pixel (8x8 Gauss-Legendre); self-shadowing \
               shadow rays would darken it"
            .into(),
    });
    let eye = Vec3::new(0.0, 0.0, 0.1);
    let target = eye + Vec3::new(1.0, 0.0, -(5f32.to_radians().tan()));
    let grazing_cam = Camera::look_at(eye, target, 4f32.to_radians());
    let (got, want, se, bad) = plane_case(grazing_cam, [0.0, 0.0, 0.1], 1.0, 0.5, n, spp, |_| {});
    rows.push(Row {
        case: "grazing view (3 to 7 deg), light at the camera".into(),
        setting: format!("{n}x{n} px, {spp} spp, camera 0.1 m above"),
        kind: Kind::Reference,
        check: Check::Within {
            expected: want,
            tolerance: 5.0 * se + 1e-4 * want,
        },
        got,
        non_finite: bad,
        note: "single-bounce formula over each pixel's rays (8x8 Gauss-Legendre)".into(),
    });
    rows
}

// ---------------------------------------------------------------------------------------
// Coincident faces and degenerate triangles.

/// The lit plane with its faces doubled (same and opposite winding), and with
/// degenerate triangles (repeated vertices, collinear, a cross product that underflows,
/// one at the light) in front of the camera: the exact plane answer in every case.
pub fn bad_faces(size: Size) -> Vec<Row> {
    let (n, spp) = (size.pick(8, 24), size.pick(32, 128));
    let down = Camera::look_at(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, 40f32.to_radians());
    let light = [0.0, 0.0, 2.0];
    let mut rows = Vec::new();
    type Edit = fn(&mut Scene);
    let variants: [(&str, Edit); 3] = [
        ("coincident faces (plane doubled, same winding)", |s| {
            let t = s.triangles.clone();
            for tri in t {
                s.triangles.push(tri);
                s.attrs.push(triangle_attrs(0));
            }
        }),
        ("coincident faces (plane doubled, opposite winding)", |s| {
            let t = s.triangles.clone();
            for tri in t {
                s.triangles.push(Triangle {
                    p: [tri.p[0], tri.p[2], tri.p[1]],
                });
                s.attrs.push(triangle_attrs(0));
            }
        }),
        ("degenerate triangles in view and at the light", |s| {
            let v = Vec3::new;
            let tiny = 1e-25f32;
            let tris = [
                // Repeated vertex.
                [v(-0.3, -0.3, 1.0), v(-0.3, -0.3, 1.0), v(0.3, 0.3, 1.0)],
                // Collinear, across the view.
                [v(-1.0, 0.0, 1.0), v(0.0, 0.0, 1.0), v(1.0, 0.0, 1.0)],
                // A needle of area 1e-25 m^2, and a speck whose cross product underflows.
                [v(0.0, -1.0, 0.5), v(tiny, -1.0, 0.5), v(0.0, 1.0, 0.5)],
                [
                    v(0.1, 0.1, 0.5),
                    v(0.1 + tiny, 0.1, 0.5),
                    v(0.1, 0.1 + tiny, 0.5),
                ],
                // All three at the light.
                [v(0.0, 0.0, 2.0); 3],
                // Collinear on the plane itself.
                [v(-0.5, 0.1, 0.0), v(0.0, 0.1, 0.0), v(0.5, 0.1, 0.0)],
            ];
            for p in tris {
                s.triangles.push(Triangle { p });
                s.attrs.push(triangle_attrs(0));
            }
        }),
    ];
    for (what, edit) in variants {
        let (got, want, se, bad) = plane_case(down, light, 3.0, 0.5, n, spp, edit);
        rows.push(Row {
            case: what.into(),
            setting: format!("{n}x{n} px, {spp} spp, lit plane"),
            kind: Kind::Reference,
            check: Check::Within {
                expected: want,
                tolerance: 5.0 * se + 1e-4 * want,
            },
            got,
            non_finite: bad,
            note: "the single plane's exact answer".into(),
        });
    }
    rows
}

//! Participating media against answers derived by hand (issue 32): single scattering in
//! an infinite medium, the white furnace filled with a scattering medium, the lit plane
//! in an absorbing medium of index n, energy conservation with albedo 1, the late
//! time-resolved reflectance of a semi-infinite medium (diffusion, Patterson 1989), and the
//! extremes (optically very thick, nearly white, millimetre and kilometre fog).

use crate::common;
use common::*;
use glam::Vec3;
use std::f64::consts::PI;
use std::sync::Arc;
use tprf_core::film::TimeAxis;
use tprf_core::reference::furnace::Furnace;
use tprf_core::reference::plane::Plane;
use tprf_core::scene::{Camera, Medium, PunctualLight};
use tprf_core::transport::{RenderSettings, Renderer};

/// Mean over pixels, and the standard error of that mean from the pixels' spread, per
/// bin (every pixel of these scenes has the same expected TPRF).
fn pixel_mean_and_se(film: &tprf_core::film::TprfFilm, w: usize, h: usize) -> (Vec<f64>, Vec<f64>) {
    let n = (w * h) as f64;
    let tprfs: Vec<Vec<f64>> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| film.pixel_tprf(x, y))
        .collect();
    let bins = tprfs[0].len();
    let mean: Vec<f64> = (0..bins)
        .map(|b| tprfs.iter().map(|t| t[b]).sum::<f64>() / n)
        .collect();
    let se = (0..bins)
        .map(|b| {
            let var = tprfs.iter().map(|t| (t[b] - mean[b]).powi(2)).sum::<f64>() / (n - 1.0);
            (var / n).sqrt()
        })
        .collect();
    (mean, se)
}

/// Single scattering in an infinite homogeneous medium with a pulsed point light of
/// intensity I at the eye: light scattered back from distance r arrives at
/// `t = 2 n r / c`, and every pixel's TPRF integrates, over each bin's `r`,
/// `sigma_s p(pi) I e^(-2 sigma_t r) / r^2`. With `--max-bounces 1` the renderer must
/// give exactly this, per bin, within noise.
#[test]
fn single_scattering_in_an_infinite_medium_matches_the_closed_form() {
    for (sigma_s, sigma_a, g, n) in [
        (0.2, 0.05, 0.6, 1.33),
        (0.5, 0.0, 0.0, 1.0),
        (0.1, 0.2, -0.4, 1.0),
    ] {
        let i = 5.0;
        let mut scene = empty_scene(Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 0.8));
        scene.medium = Some(Medium::grey(
            sigma_s as f32,
            sigma_a as f32,
            g as f32,
            n as f32,
        ));
        scene.lights.push(PunctualLight {
            name: "laser".into(),
            position: Vec3::ZERO,
            intensity_w_per_sr: [i as f32; 3],
            spot: None,
            projector: None,
        });
        // Distances 1 m to 9 m, 40 bins.
        let t_of = |r: f64| 2.0 * n * r / C;
        let axis = TimeAxis::new(t_of(1.0), t_of(0.2), 40).unwrap();
        let settings = RenderSettings {
            max_bounces: 1,
            seed: 3,
            ..RenderSettings::default()
        };
        let (w, h) = (8, 8);
        let r = render_with(scene, w, h, axis, 256, settings, 0);
        let (mean, se) = pixel_mean_and_se(&r.film, w, h);
        let sigma_t = sigma_s + sigma_a;
        let p_back = hg(-1.0, g);
        for (b, (got, se)) in mean.iter().zip(&se).enumerate() {
            let (r0, r1) = (
                axis.bin_start_s(b) * C / (2.0 * n),
                axis.bin_start_s(b + 1) * C / (2.0 * n),
            );
            let want = sigma_s
                * p_back
                * i
                * simpson(r0, r1, 200, |r| (-2.0 * sigma_t * r).exp() / (r * r));
            assert!(
                (got - want).abs() < 5.0 * se + 1e-4 * want,
                "sigma_s {sigma_s} g {g} n {n}: bin {b} (r {r0:.2}-{r1:.2} m): {got} vs {want} \
                 (se {se})"
            );
        }
        // The gate puts every sample where it counts: the window's total is known to
        // well under 1 % from 16384 samples.
        let (total, total_se) = mean_and_se(&r.film.steady());
        assert!(
            total_se < 0.005 * total,
            "standard error {total_se} of {total}"
        );
    }
}

/// A closed furnace whose wall emits `Le` and reflects `rho` holds the uniform isotropic
/// field `Le / (1 - rho)`; a non-absorbing medium scatters a uniform isotropic field into
/// itself, so filling the furnace with one changes nothing of the steady radiance,
/// whatever its density and phase function.
#[test]
fn a_white_medium_leaves_the_furnace_radiance_unchanged() {
    let furnace = Furnace::emitting(1.0, 0.5, 1.0);
    let want = furnace.energy();
    assert_eq!(want, 2.0);
    for (sigma_s, g) in [(0.5f32, 0.0f32), (2.0, 0.0), (2.0, 0.8), (1.0, -0.5)] {
        let mut scene = furnace.scene();
        scene.medium = Some(Medium::grey(sigma_s, 0.0, g, 1.0));
        let pixels = steady_pixels(scene, 8, 8, 128, 9);
        let (mean, se) = mean_and_se(&pixels);
        assert!(
            (mean - want).abs() < 4.0 * se + 2e-3 * want,
            "sigma_s {sigma_s} g {g}: {mean} vs {want} (se {se})"
        );
    }
    // The check can fail: an absorbing medium darkens the furnace.
    let mut scene = furnace.scene();
    scene.medium = Some(Medium::grey(1.0, 0.5, 0.0, 1.0));
    let (mean, se) = mean_and_se(&steady_pixels(scene, 8, 8, 64, 9));
    assert!(mean < want - 10.0 * se, "absorbing: {mean}");
}

/// The plane lit by a co-located point light, in a purely absorbing medium of index n:
/// every footprint point's light is attenuated by `e^(-sigma_a path)` and arrives at
/// `n path / c` (tprf_core::reference::plane, `in_medium`): per pixel the steady
/// radiance, the mean arrival and every bin.
#[test]
fn plane_in_an_absorbing_medium_of_index_n() {
    let (h_m, rho, i, fov) = (2.0, 0.5, 3.0, 40.0);
    let plane = Plane::colocated(h_m, rho, i, 50.0, fov).in_medium(0.15, 1.5);
    let (w, hp) = (12, 9);
    let axis = plane.default_axis(w, hp, 60).unwrap();
    let spp = 64;
    let r = render_scene(plane.scene(), w, hp, axis, spp, 7, 0);
    let vacuum = Plane::colocated(h_m, rho, i, 50.0, fov);
    let se = |sd: f64| 4.0 * sd / (spp as f64).sqrt();
    for y in 0..hp {
        for x in 0..w {
            let m = plane.pixel_moments(x, y, w, hp);
            let tprf = r.film.pixel_tprf(x, y);
            let steady: f64 = tprf.iter().sum();
            assert!(
                (steady - m.mean).abs() < se(m.sd) + 1e-4 * m.mean,
                "pixel ({x},{y}): steady {steady} vs {}",
                m.mean
            );
            let t = mean_arrival_s(&tprf, &axis);
            assert!(
                (t - m.mean_arrival_s).abs() < se(m.sd_arrival_s) + 0.5 * axis.dt_s,
                "pixel ({x},{y}): mean arrival {t} vs {}",
                m.mean_arrival_s
            );
            // Every sample lands in one bin: bin b holds about a share e / L of them, so
            // its estimate scatters by about sqrt(e L / spp).
            let want = plane.pixel_tprf(x, y, w, hp, &axis);
            let peak = want.iter().cloned().fold(0.0, f64::max);
            for (b, (g, e)) in tprf.iter().zip(&want).enumerate() {
                let sd = (e * m.mean / spp as f64).sqrt();
                assert!(
                    (g - e).abs() < 5.0 * sd + 0.01 * peak,
                    "pixel ({x},{y}) bin {b}: {g} vs {e}"
                );
            }
            // The reference itself: n times later, and darker, than in vacuum.
            let v = vacuum.pixel_moments(x, y, w, hp);
            assert!(m.mean < v.mean * (-0.15f64 * 2.0 * h_m).exp() * 1.0001);
            assert!((m.mean_arrival_s / v.mean_arrival_s - 1.5).abs() < 0.01);
        }
    }
}

/// Volume of a closed triangle mesh (divergence theorem), m^3.
fn mesh_volume(scene: &tprf_core::scene::Scene) -> f64 {
    scene
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.p.map(|p| p.as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum::<f64>()
        .abs()
}

/// Energy: in a closed furnace with white walls (albedo 1) filled with a white medium
/// (albedo 1), the pulse's energy `4 pi I` stays in the volume V forever and settles
/// into a uniform isotropic field: energy density `u = 4 pi I / V`, radiance
/// `L = u c / (4 pi n) = I c / (n V)` at late times, in any medium of index n (and in
/// vacuum). Nothing is lost but by the window's end.
#[test]
fn white_walls_and_a_white_medium_lose_nothing() {
    let i = 1.0;
    for medium in [
        None,
        Some(Medium::grey(1.0, 0.0, 0.5, 1.2)),
        Some(Medium::grey(3.0, 0.0, -0.3, 1.0)),
    ] {
        let mut scene = Furnace::point(1.0, 1.0, i).scene();
        scene.medium = medium.clone();
        let n = medium.as_ref().map_or(1.0, |m| m.n as f64);
        let volume = mesh_volume(&scene);
        // Optical path 20 m to 36 m: long after the field has settled.
        let axis = TimeAxis::new(20.0 * n / C, 2.0 * n / C, 8).unwrap();
        let (w, h) = (8, 8);
        let r = render_scene(scene, w, h, axis, 64, 5, 0);
        let totals: Vec<f64> = r.film.steady();
        let (got, se) = mean_and_se(&totals);
        let window_s = axis.end_s() - axis.t0_s;
        let want = i * C / (n * volume) * window_s;
        assert!(
            (got - want).abs() < 4.0 * se + 0.01 * want,
            "{medium:?}: {got} vs {want} (se {se})"
        );
    }
    // Walls that also emit a pulse of radiance Le (energy pi Le A into the volume) beside
    // the lamp: L = (4 pi I + pi Le A) c / (4 pi n V). Emitter sampling at the vertices
    // then shares its MIS with the phase function's and the lamp's glow's directions.
    let le = 0.05;
    let mut scene = Furnace::emitting(1.0, 1.0, le).scene();
    scene.lights = Furnace::point(1.0, 1.0, i).scene().lights;
    scene.medium = Some(Medium::grey(1.5, 0.0, 0.8, 1.0));
    let volume = mesh_volume(&scene);
    let area: f64 = scene
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.p.map(|p| p.as_dvec3());
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    let axis = TimeAxis::new(20.0 / C, 2.0 / C, 8).unwrap();
    let r = render_scene(scene, 8, 8, axis, 64, 5, 0);
    let (got, se) = mean_and_se(&r.film.steady());
    let energy = 4.0 * PI * i + PI * le * area;
    let want = energy * C / (4.0 * PI * volume) * (axis.end_s() - axis.t0_s);
    assert!(
        (got - want).abs() < 4.0 * se + 0.01 * want,
        "emitting walls and a lamp: {got} vs {want} (se {se})"
    );
}

/// Extremes stay finite: an optical depth of 1e4 across the scene, an albedo of 0.9999,
/// fog in a millimetre-sized and in a ten-kilometre-sized box (time axes scaled alike).
#[test]
fn extreme_media_stay_finite() {
    let cases = [
        (
            "optical depth 1e4",
            1.0f32,
            Medium::grey(5e3, 0.0, 0.0, 1.0),
        ),
        ("albedo 0.9999", 1.0, Medium::grey(2.0, 2e-4, 0.9, 1.0)),
        (
            "1 mm fog",
            1e-3,
            Medium::grey(2.0, 0.0, 0.9, 1.0).scaled(1e-3),
        ),
        (
            "10 km fog",
            1e4,
            Medium::grey(2.0, 0.01, 0.9, 1.33).scaled(1e4),
        ),
    ];
    for (what, scale, medium) in cases {
        let mut scene = Furnace::point(1.0, 0.8, 1.0).scene().scaled(scale);
        scene.medium = Some(medium.clone());
        // The window: 12.8 m of optical path, or 300 mean free paths in the dense case.
        let sigma_t = medium.sigma_t_per_m()[0] as f64 * scale as f64;
        let span_m = (300.0 / sigma_t).min(12.8);
        let axis = TimeAxis::new(0.0, span_m / 64.0 * scale as f64 / C, 64).unwrap();
        let r = render_scene(scene, 6, 6, axis, 16, 1, 0);
        let cube = r.film.cube_f64();
        assert!(cube.iter().all(|v| v.is_finite() && *v >= 0.0), "{what}");
        assert!(cube.iter().any(|&v| v > 0.0), "{what}: no light at all");
    }
}

/// A clear medium of index 1 (or none) leaves the scene to the surface loop.
#[test]
fn vacuum_is_rendered_by_the_surface_loop() {
    let settings = RenderSettings::default();
    let mut scene = Furnace::point(1.0, 0.5, 1.0).scene();
    assert!(!Renderer::new(Arc::new(scene.clone()), settings).has_media());
    scene.medium = Some(Medium::grey(0.0, 0.0, 0.3, 1.0));
    assert!(!Renderer::new(Arc::new(scene.clone()), settings).has_media());
    scene.medium = Some(Medium::grey(0.0, 0.0, 0.0, 1.33));
    assert!(Renderer::new(Arc::new(scene), settings).has_media());
}

/// The time-resolved diffusion solution for a semi-infinite medium (Patterson, Chance and
/// Wilson, "Time resolved reflectance and transmittance for the noninvasive measurement
/// of tissue optical properties", Applied Optics 28(12):2331-2336, 1989, eq. 9 for the
/// reflectance), with the extrapolated boundary `z_b = 2 D` of an index-matched surface
/// (the image source at `-(z0 + 2 z_b)`, Haskell et al., JOSA A 11(10), 1994): a unit
/// pulse entering at the origin, an isotropic source at depth `z0 = 1 / mu_s'`,
/// `D = 1 / (3 mu_s')` (m), `v = c / n`:
///
/// - fluence rate at depth z, distance rho: `phi = v (4 pi D v t)^(-3/2) e^(-mu_a v t)
///   [e^(-r1^2 / (4 D v t)) - e^(-r2^2 / (4 D v t))]`, `r1^2 = (z - z0)^2 + rho^2`,
///   `r2^2 = (z + z0 + 2 z_b)^2 + rho^2`;
/// - reflectance `R(rho, t) = D d phi / dz` at the surface `= (4 pi D v)^(-3/2)
///   t^(-5/2) e^(-mu_a v t) e^(-rho^2 / (4 D v t)) [z0 e^(-z0^2 / (4 D v t)) + (z0 + 2 z_b)
///   e^(-(z0 + 2 z_b)^2 / (4 D v t))] / 2` (Patterson's eq. 9 when `z_b = 0`).
///
/// Over the surface (`int 2 pi rho d rho` of `e^(-rho^2 / (4 D v t))` is `4 pi D v t`) the
/// totals are `Phi(t) = v (4 pi D v t)^(-1/2) e^(-mu_a v t) [..]` and `R(t) = (4 pi D v)
/// ^(-1/2) t^(-3/2) e^(-mu_a v t) [..] / 2`, per unit of energy, 1/s. Under a uniform
/// irradiance pulse `E` at normal incidence the radiance leaving along the normal is, by
/// reciprocity and translation invariance, `E` times the normal radiance of the pulse's
/// light integrated over the surface; in the diffusion (P1) approximation the radiance is
/// `(phi + 3 J . w) / (4 pi)`, so the pixels see `E (Phi(t) + 3 R(t)) / (4 pi)`.
fn diffusion_normal_radiance_per_irradiance(t_s: f64, mu_s_red: f64, mu_a: f64, n: f64) -> f64 {
    let v = C / n;
    let d = 1.0 / (3.0 * mu_s_red);
    let z0 = 1.0 / mu_s_red;
    let zb = 2.0 * d;
    let s = 4.0 * d * v * t_s;
    let decay = (-mu_a * v * t_s).exp();
    let phi = v
        * (PI * s).powf(-0.5)
        * decay
        * ((-z0 * z0 / s).exp() - (-(z0 + 2.0 * zb).powi(2) / s).exp());
    let r = (4.0 * PI * d * v).powf(-0.5)
        * t_s.powf(-1.5)
        * decay
        * 0.5
        * (z0 * (-z0 * z0 / s).exp() + (z0 + 2.0 * zb) * (-(z0 + 2.0 * zb).powi(2) / s).exp());
    (phi + 3.0 * r) / (4.0 * PI)
}

/// A quad `a b c d` (counter-clockwise seen from outside) as two triangles.
fn push_quad(scene: &mut tprf_core::scene::Scene, q: [Vec3; 4], material: u32) {
    push_tri(scene, [q[0], q[1], q[2]], material);
    push_tri(scene, [q[0], q[2], q[3]], material);
}

/// A semi-infinite scattering medium (a 4 m x 4 m x 2 m index-matched box, 200 to 400
/// mean free paths to its sides and bottom) lit by a point light 20 m above, seen by a
/// narrow co-located camera: at late times (50-150 reduced mean free paths after the
/// light entered) the window's TPRF follows the diffusion solution above (a loose check:
/// the shape bin by bin to 5 % and 5 standard errors, the level to 10 %, which covers the
/// P1 radiance's and the boundary condition's approximation; measured: the level 1.1 %
/// low, every bin within 3.5 %).
#[test]
fn late_reflectance_of_a_semi_infinite_medium_follows_diffusion() {
    let (mu_s, mu_a, n) = (100.0f64, 0.5f64, 1.0f64);
    let (h_m, i) = (20.0f64, 4.0f64);
    let mut scene = empty_scene(Camera::look_at(
        Vec3::new(0.0, 0.0, h_m as f32),
        Vec3::ZERO,
        1f32.to_radians(),
    ));
    let mut slab = tprf_core::scene::Material::lambertian("slab", [0.0; 3]);
    slab.medium = Some(Medium::grey(mu_s as f32, mu_a as f32, 0.0, n as f32));
    scene.materials.push(slab);
    let (l, dz) = (2.0f32, 2.0f32);
    let p = |x: f32, y: f32, z: f32| Vec3::new(x * l, y * l, z * dz);
    for q in [
        [
            p(-1., -1., 0.),
            p(1., -1., 0.),
            p(1., 1., 0.),
            p(-1., 1., 0.),
        ],
        [
            p(-1., -1., -1.),
            p(-1., 1., -1.),
            p(1., 1., -1.),
            p(1., -1., -1.),
        ],
        [
            p(-1., -1., -1.),
            p(1., -1., -1.),
            p(1., -1., 0.),
            p(-1., -1., 0.),
        ],
        [
            p(1., 1., -1.),
            p(-1., 1., -1.),
            p(-1., 1., 0.),
            p(1., 1., 0.),
        ],
        [
            p(1., -1., -1.),
            p(1., 1., -1.),
            p(1., 1., 0.),
            p(1., -1., 0.),
        ],
        [
            p(-1., 1., -1.),
            p(-1., -1., -1.),
            p(-1., -1., 0.),
            p(-1., 1., 0.),
        ],
    ] {
        push_quad(&mut scene, q, 0);
    }
    // Outward faces: the divergence theorem gives the volume with a positive sign.
    let signed: f64 = scene
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.p.map(|p| p.as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    assert!((signed - 32.0).abs() < 1e-9, "box volume {signed}");
    scene.lights.push(PunctualLight {
        name: "laser".into(),
        position: Vec3::new(0.0, 0.0, h_m as f32),
        intensity_w_per_sr: [i as f32; 3],
        spot: None,
        projector: None,
    });
    // Optical path in the medium 0.5 m to 1.5 m (50 to 150 / mu_s'), 8 bins; the light
    // travels 2 h in vacuum first.
    let (x0, x1, bins) = (0.5f64, 1.5f64, 8usize);
    let axis = TimeAxis::new(
        (2.0 * h_m + x0 * n) / C,
        (x1 - x0) * n / C / bins as f64,
        bins,
    )
    .unwrap();
    let irradiance = i / (h_m * h_m);
    let want: Vec<f64> = (0..bins)
        .map(|b| {
            let (t0, t1) = (
                axis.bin_start_s(b) - 2.0 * h_m / C,
                axis.bin_start_s(b + 1) - 2.0 * h_m / C,
            );
            irradiance
                * simpson(t0, t1, 64, |t| {
                    diffusion_normal_radiance_per_irradiance(t, mu_s, mu_a, n)
                })
        })
        .collect();
    let (w, h) = (16, 16);
    let r = render_scene(scene, w, h, axis, 512, 11, 0);
    let (mean, se) = pixel_mean_and_se(&r.film, w, h);
    let (got_total, want_total) = (mean.iter().sum::<f64>(), want.iter().sum::<f64>());
    assert!(
        (got_total / want_total - 1.0).abs() < 0.10,
        "window total {got_total} vs diffusion {want_total}; bins {mean:?} vs {want:?}"
    );
    for b in 0..bins {
        let (g, e) = (mean[b] / got_total, want[b] / want_total);
        assert!(
            (g - e).abs() < 0.05 * e + 5.0 * se[b] / got_total,
            "bin {b}: share {g} vs diffusion {e} (bins {mean:?} vs {want:?})"
        );
    }
    // The check can fail: without absorption the decay would be far slower.
    let flat: Vec<f64> = (0..bins)
        .map(|b| {
            let t = axis.bin_center_s(b) - 2.0 * h_m / C;
            diffusion_normal_radiance_per_irradiance(t, mu_s, 0.0, n)
        })
        .collect();
    assert!(flat[bins - 1] / flat[0] > 1.4 * want[bins - 1] / want[0]);
}

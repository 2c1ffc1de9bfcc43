//! The renderer against answers derived by hand: a plane lit by a co-located point light
//! (single bounce, per pixel time and value) and the transient furnace (a closed diffuse
//! sphere with light and camera at the centre, or the light off the centre).

use crate::common;
use common::*;
use tprf_core::film::TimeAxis;
use tprf_core::reference::furnace::Furnace;
use tprf_core::reference::plane::Plane;
use tprf_core::transport::RenderSettings;

#[test]
fn plane_lit_by_colocated_light_matches_single_bounce_answer() {
    let (h_m, rho, i, fov) = (2.0f32, 0.5f32, 3.0f32, 40.0f32);
    let (w, hp) = (12, 9);
    let t_direct = 2.0 * h_m as f64 / C;
    let axis = TimeAxis::new(0.95 * t_direct, 0.004 * t_direct, 100).unwrap();
    let spp = 64;
    let r = render_scene(lit_plane(h_m, rho, i, 50.0, fov), w, hp, axis, spp, 7, 2);
    let se = |sd: f64| 4.0 * sd / (spp as f64).sqrt();
    let film = &r.film;
    for y in 0..hp {
        for x in 0..w {
            // The single-bounce answer `L = rho I h / (pi r^3)` at `t = 2 r / c`, integrated
            // over the pixel footprint (tprf_core::reference::plane).
            let m = Plane::colocated(h_m as f64, rho as f64, i as f64, 50.0, fov as f64)
                .pixel_moments(x, y, w, hp);
            let (l_ref, t_ref, l_sd, t_sd) = (m.mean, m.mean_arrival_s, m.sd, m.sd_arrival_s);
            let tprf = film.pixel_tprf(x, y);
            let steady: f64 = tprf.iter().sum();
            assert!(
                (steady - l_ref).abs() < se(l_sd) + 1e-4 * l_ref,
                "pixel ({x},{y}): steady {steady} vs analytic {l_ref}"
            );
            let t_mean = mean_arrival_s(&tprf, &axis);
            assert!(
                (t_mean - t_ref).abs() < se(t_sd) + 0.5 * axis.dt_s,
                "pixel ({x},{y}): mean arrival {t_mean} s vs analytic {t_ref} s (dt {})",
                axis.dt_s
            );
            // Nothing arrives before the shortest possible round trip 2h/c.
            let first = tprf.iter().position(|&v| v > 0.0).unwrap();
            assert!(
                axis.bin_start_s(first + 1) > t_direct,
                "light before 2h/c in pixel ({x},{y})"
            );
            // A plane cannot light itself: everything is one scattering event.
            let layers = film.pixel_bounces(x, y);
            assert_eq!(layers.len(), 4);
            let one: f64 = layers[1].iter().sum();
            let others: f64 = layers[0].iter().chain(&layers[2]).chain(&layers[3]).sum();
            assert!((one - steady).abs() < 1e-9 * steady && others == 0.0);
        }
    }
}

/// Semi-analytic transient furnace (tprf_core::reference::furnace): the k-th scattering term
/// has steady radiance `rho^k I / (pi R^2)` and arrives at `(2R + S_{k-1}) / c`, `S_{k-1}`
/// the sum of k-1 independent chords with density `d / (2 R^2)` on [0, 2R].
fn furnace_reference(r_m: f64, rho: f64, i: f64, axis: &TimeAxis) -> Vec<f64> {
    Furnace::point(r_m, rho, i).tprf(axis)
}

/// The furnace (R 1 m, I 2 W/sr) rendered at 8 x 8, 1024 spp with `settings` against
/// its reference: energy in the window, every bin, mean arrival. `what` names the case.
/// Returns the pixels' mean TPRF.
pub(crate) fn check_furnace_with(rho: f32, settings: RenderSettings, what: &str) -> Vec<f64> {
    let (r_m, i) = (1.0f32, 2.0f32);
    let axis = TimeAxis::new(0.25 / C, 0.5 / C, 60).unwrap();
    let rendered = render_with(furnace(r_m, rho, i), 8, 8, axis, 1024, settings, 0);
    let film = &rendered.film;
    let n = 64.0;
    let mut mean = vec![0.0; axis.bins];
    for y in 0..8 {
        for x in 0..8 {
            for (m, v) in mean.iter_mut().zip(film.pixel_tprf(x, y)) {
                *m += v / n;
            }
        }
    }
    let reference = furnace_reference(r_m as f64, rho as f64, i as f64, &axis);
    let total_ref: f64 = reference.iter().sum();
    let total: f64 = mean.iter().sum();
    // Standard error of the mean from the 64 independent pixel totals.
    let totals: Vec<f64> = film.steady();
    let var = totals.iter().map(|t| (t - total).powi(2)).sum::<f64>() / (n - 1.0);
    let se = (var / n).sqrt();
    // The closed form for the infinite sum, to check the reference itself.
    let closed = rho as f64 * i as f64 / (std::f64::consts::PI * (1.0 - rho as f64));
    let tail = closed - total_ref;
    assert!(
        tail >= -1e-9 * closed,
        "reference exceeds the closed form: {total_ref} > {closed}"
    );
    // 4 standard errors plus 0.5 % for the facets (the icosphere lies inside radius R).
    assert!(
        (total - total_ref).abs() < 4.0 * se + 0.005 * total_ref,
        "{what}: energy in window {total} vs {total_ref} (standard error {se})"
    );
    let peak = reference.iter().cloned().fold(0.0, f64::max);
    for (b, (got, want)) in mean.iter().zip(&reference).enumerate() {
        assert!(
            (got - want).abs() < 0.03 * peak + 0.05 * want,
            "{what}: bin {b}: {got} vs {want} (peak {peak})"
        );
    }
    let t_ref = mean_arrival_s(&reference, &axis);
    let t_got = mean_arrival_s(&mean, &axis);
    assert!(
        (t_got - t_ref).abs() < 0.01 * t_ref,
        "{what}: mean arrival {t_got} vs {t_ref}"
    );
    mean
}

fn check_furnace(rho: f32) {
    let settings = RenderSettings {
        seed: 11,
        ..RenderSettings::default()
    };
    check_furnace_with(rho, settings, &format!("rho {rho}"));
}

#[test]
fn furnace_rho_0_5_energy_and_time_profile() {
    check_furnace(0.5);
}

#[test]
fn furnace_rho_0_9_energy_and_time_profile() {
    check_furnace(0.9);
}

#[test]
fn furnace_total_energy_matches_closed_form() {
    // A window long enough to hold all but ~1e-6 of the energy: the steady radiance is
    // rho I / (pi R^2 (1 - rho)).
    let (r_m, rho, i) = (1.0f32, 0.5f32, 1.0f32);
    let axis = TimeAxis::new(0.0, 100.0 / C, 1).unwrap();
    let rendered = render_scene(furnace(r_m, rho, i), 8, 8, axis, 256, 3, 0);
    let steady: f64 = rendered.film.steady().iter().sum::<f64>() / 64.0;
    let closed = rho as f64 * i as f64
        / (std::f64::consts::PI * r_m as f64 * r_m as f64 * (1.0 - rho as f64));
    assert!(
        (steady - closed).abs() < 0.01 * closed,
        "{steady} vs {closed}"
    );
}

/// A camera 1 m above a glass slab (thickness d, ior n, fully transmissive) with an
/// emissive floor under it, looking straight down through a 1 degree field of view. The
/// floor's light reaches the eye as an impulse train: straight through with weight
/// `Le (1 - F)^2`, then after 2k internal reflections with `Le (1 - F)^2 F^(2k)`, where
/// F = ((n - 1) / (n + 1))^2 at normal incidence; the k-th arrives at
/// `(1 m + (2k + 1) n d + gap) / c`: the slab delays by n d / c per crossing.
/// Mean TPRF over all pixels of a film.
fn mean_tprf(film: &tprf_core::film::TprfFilm) -> Vec<f64> {
    let l = film.layout();
    let n = l.pixels() as f64;
    let mut mean = vec![0.0; l.axis.bins];
    for y in 0..l.height {
        for x in 0..l.width {
            for (m, v) in mean.iter_mut().zip(film.pixel_tprf(x, y)) {
                *m += v / n;
            }
        }
    }
    mean
}

/// The furnace lit by its own wall (radiance Le, pulsed at t = 0): `Le` at `R / c`, then
/// `rho^k Le` spread over `(R + S_k) / c`; total `Le / (1 - rho)`. With next-event
/// estimation (emitter sampling + MIS) and without (BSDF sampling only) alike.
#[test]
fn emitting_furnace_matches_the_renewal_reference_with_and_without_nee() {
    let f = Furnace::emitting(1.0, 0.8, 1.5);
    let axis = f.default_axis(60).unwrap();
    let reference = f.tprf(&axis);
    let total_ref: f64 = reference.iter().sum();
    let peak = reference.iter().skip(1).cloned().fold(0.0, f64::max);
    for nee in [true, false] {
        let settings = RenderSettings {
            seed: 21,
            nee,
            ..RenderSettings::default()
        };
        let r = render_with(f.scene(), 8, 8, axis, 256, settings, 0);
        let mean = mean_tprf(&r.film);
        let total: f64 = mean.iter().sum();
        let totals = r.film.steady();
        let var = totals.iter().map(|t| (t - total).powi(2)).sum::<f64>() / 63.0;
        let se = (var / 64.0).sqrt();
        assert!(
            (total - total_ref).abs() < 4.0 * se + 0.005 * total_ref,
            "nee {nee}: energy {total} vs {total_ref} (se {se})"
        );
        for (b, (got, want)) in mean.iter().zip(&reference).enumerate() {
            assert!(
                (got - want).abs() < 0.03 * peak + 0.03 * want,
                "nee {nee}: bin {b}: {got} vs {want} (peak {peak})"
            );
        }
    }
}

/// The paper's Figure 4 world built in 3-D (mirrors with alpha coverage, an emitting
/// plane at L): every bin against the exact impulse train of tprf_core::oned.
#[test]
fn oned_world_in_3d_matches_the_exact_impulse_train() {
    use tprf_core::reference::oned_scene::{OnedScene, figure4_world};
    let o = OnedScene::new(figure4_world()).unwrap();
    let axis = o.default_axis(256).unwrap();
    let reference = o.tprf(&axis);
    let spp = 4096;
    let r = render_scene(o.scene(), 2, 2, axis, spp, 5, 0);
    let mean = mean_tprf(&r.film);
    let n = 4.0 * spp as f64;
    let mut checked = 0;
    for (b, (got, want)) in mean.iter().zip(&reference).enumerate() {
        // Each sample adds at most 1 to a bin: variance <= mean.
        let tol = 5.0 * (want / n).sqrt() + 1e-3 * want + 1e-9;
        assert!((got - want).abs() < tol, "bin {b}: {got} vs {want}");
        checked += usize::from(*want > 1e-3);
    }
    assert!(
        checked >= 4,
        "only {checked} impulses above 1e-3 in the window"
    );
    let (total, want): (f64, f64) = (mean.iter().sum(), reference.iter().sum());
    assert!(
        (total - want).abs() < 5.0 * (want / n).sqrt(),
        "{total} vs {want}"
    );
}

/// Russian roulette with a survival floor, and no roulette at all, stay unbiased: the
/// furnace's energy in a window holding all but 1e-6 of it is `rho I / (pi R^2 (1 - rho))`.
#[test]
fn russian_roulette_floor_and_no_roulette_are_unbiased() {
    let f = Furnace::point(1.0, 0.7, 1.0);
    let axis = TimeAxis::new(0.0, 100.0 / C, 1).unwrap();
    for (rr_start, floor) in [(1, 0.5f32), (0, 0.9), (2, 1.0)] {
        let settings = RenderSettings {
            seed: 77,
            rr_start,
            rr_min_survival: floor,
            ..RenderSettings::default()
        };
        let r = render_with(f.scene(), 8, 8, axis, 128, settings, 0);
        let totals = r.film.steady();
        let mean = totals.iter().sum::<f64>() / 64.0;
        let var = totals.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / 63.0;
        let se = (var / 64.0).sqrt();
        let want = f.energy();
        assert!(
            (mean - want).abs() < 4.0 * se + 0.003 * want,
            "rr_start {rr_start}, floor {floor}: {mean} vs {want} (se {se})"
        );
    }
}

/// The furnace with its light off the centre, near the wall (a point light, or a spot
/// when `spot` holds its inner and outer cone angles): the first bounce is bright next
/// to the light, but the light the wall scatters (all the light's power P, times rho)
/// spreads uniformly over a sphere (`cos cos / d^2 = 1 / (4 R^2)` for any two wall
/// points), so from the second bounce on every pixel sees exactly
/// `rho^j P / (4 pi^2 R^2)` at bounce j, however the light is placed or aimed
/// (`P = 4 pi I` for a point light: `rho^j I / (pi R^2)`). These are the paths
/// that light-vertex connections (MIS against BSDF sampling, with and without the first
/// vertex split) find a second way; their weights vary over the wall here, unlike with
/// the light at the centre. Returns the spread of the pixels' second bounce over its
/// expected value (pure noise, the answer being uniform).
fn check_off_centre_furnace(light_vertex: bool, splits: u32, spot: Option<(f32, f32)>) -> f64 {
    let (r_m, rho, i) = (1.0f32, 0.5f32, 2.0f32);
    let mut scene = furnace(r_m, rho, i);
    scene.lights[0].position = glam::Vec3::new(0.45, 0.3, -0.55);
    // Power: 2 pi I times the integral over cos(theta) of the falloff
    // ((c - cos_outer) / (cos_inner - cos_outer))^2, clamped to [0, 1].
    let power_w = match spot {
        None => 4.0 * std::f64::consts::PI * i as f64,
        Some((inner, outer)) => {
            scene.lights[0].spot = Some(tprf_core::scene::Spot {
                direction: glam::Vec3::new(0.3, -0.8, -0.4).normalize(),
                inner_cone_rad: inner,
                outer_cone_rad: outer,
            });
            let (ci, co) = (inner.cos() as f64, outer.cos() as f64);
            2.0 * std::f64::consts::PI * i as f64 * ((ci - co) / 3.0 + (1.0 - ci))
        }
    };
    // One bin holding everything but rho^100 of the light.
    let axis = TimeAxis::new(0.0, 150.0 * r_m as f64 / C, 1).unwrap();
    let settings = RenderSettings {
        seed: 5,
        light_vertex: Some(light_vertex),
        first_bounce_splits: splits,
        ..RenderSettings::default()
    };
    let film = render_with(scene, 8, 8, axis, 512, settings, 3).film;
    let unit = power_w / (4.0 * std::f64::consts::PI.powi(2) * (r_m * r_m) as f64);
    let rho = rho as f64;
    // Layers: bounce 0, 1, 2, 3, then 4 and more.
    let expected = [
        (2, rho.powi(2)),
        (3, rho.powi(3)),
        (4, rho.powi(4) / (1.0 - rho)),
    ];
    let mut spread_2 = 0.0;
    for (layer, factor) in expected {
        let values: Vec<f64> = (0..64)
            .map(|p| film.pixel_bounces(p % 8, p / 8)[layer][0])
            .collect();
        let mean = values.iter().sum::<f64>() / 64.0;
        let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / 63.0).sqrt();
        let want = factor * unit;
        // 4 standard errors, plus 0.5 % for the facets (the icosphere lies inside R).
        assert!(
            (mean - want).abs() < 4.0 * sd / 8.0 + 0.005 * want,
            "light vertex {light_vertex}, splits {splits}, spot {spot:?}, bounce layer {layer}: \
             {mean} vs {want} (pixel spread {sd})"
        );
        if layer == 2 {
            spread_2 = sd / want;
        }
    }
    spread_2
}

#[test]
fn light_vertex_connections_are_unbiased_and_tame_a_light_near_a_wall() {
    let off = check_off_centre_furnace(false, 1, None);
    let on = check_off_centre_furnace(true, 1, None);
    let on_split = check_off_centre_furnace(true, 4, None);
    let spot = Some((0.35, 0.6));
    let spot_off = check_off_centre_furnace(false, 1, spot);
    let spot_on = check_off_centre_furnace(true, 2, spot);
    // Found from the light, the second bounce no longer carries the light's 1 / r^2.
    assert!(
        on < 0.5 * off,
        "second-bounce noise with light vertices {on}, without {off}"
    );
    assert!(on_split < off, "split: {on_split} vs {off}");
    assert!(spot_on < spot_off, "spot: {spot_on} vs {spot_off}");
}

/// The pilot keeps light vertices where they pay for their rays: in the furnace with
/// its light near the wall (the second bounce's noise falls tenfold, above), not over a
/// single plane lit from the camera, where a light vertex can reach no other point of
/// the plane and only costs a ray.
#[test]
fn the_pilot_keeps_light_vertices_only_where_they_pay() {
    let strategy = |scene, axis: TimeAxis| {
        let renderer = tprf_core::transport::Renderer::new(
            std::sync::Arc::new(scene),
            RenderSettings::default(),
        );
        renderer.strategy_for(&axis, 32, 32)
    };
    let mut furnace = furnace(1.0, 0.5, 2.0);
    furnace.lights[0].position = glam::Vec3::new(0.45, 0.3, -0.55);
    let axis = TimeAxis::new(0.0, 0.1 / C, 128).unwrap();
    assert!(strategy(furnace, axis).light_vertex);
    let h_m = 2.0;
    let axis = TimeAxis::new(0.95 * 2.0 * h_m / C, 0.004 * 2.0 * h_m / C, 100).unwrap();
    let plane = strategy(lit_plane(h_m as f32, 0.5, 3.0, 50.0, 40.0), axis);
    assert!(!plane.light_vertex, "{plane:?}");
}

/// Splitting a sample at its first vertex (each of k branches carrying 1/k) stays
/// unbiased, in energy and in time: the furnace's TPRF against its semi-analytic
/// reference for k = 1 ..= 4, and the pilot's own choice.
#[test]
fn first_bounce_splitting_is_unbiased_in_energy_and_time() {
    for splits in [1, 2, 3, 4, 0] {
        let settings = RenderSettings {
            seed: 11,
            first_bounce_splits: splits,
            ..RenderSettings::default()
        };
        check_furnace_with(0.5, settings, &format!("splits {splits}"));
    }
}

#[test]
fn glass_slab_delays_by_n_d_over_c() {
    use glam::{Affine3A, Vec3};
    use tprf_core::scene::{Camera, Material};
    let (n, d, gap, le) = (1.5f32, 0.3f32, 0.5f32, 2.0f32);
    let cam = Camera {
        world_from_camera: Affine3A::from_translation(Vec3::new(0.0, 0.0, 1.0)),
        fov_rad: 1f32.to_radians(),
        fov_axis: tprf_core::scene::FovAxis::Y,
        near_m: 0.01,
    };
    let mut s = empty_scene(cam);
    s.materials.push(Material {
        transmission: 1.0,
        ior: n,
        roughness: 0.0,
        specular_factor: 1.0,
        base_color: [1.0; 4],
        ..Material::lambertian("glass", [1.0; 3])
    });
    let mut floor = Material::lambertian("floor", [0.0; 3]);
    floor.emissive = [le; 3];
    s.materials.push(floor);
    let quad = |s: &mut tprf_core::scene::Scene, z: f32, up: bool, m: u32| {
        let (a, b, c, dd) = (
            Vec3::new(-5.0, -5.0, z),
            Vec3::new(5.0, -5.0, z),
            Vec3::new(5.0, 5.0, z),
            Vec3::new(-5.0, 5.0, z),
        );
        if up {
            push_tri(s, [a, b, c], m);
            push_tri(s, [a, c, dd], m);
        } else {
            push_tri(s, [a, c, b], m);
            push_tri(s, [a, dd, c], m);
        }
    };
    quad(&mut s, 0.0, true, 0); // slab top, facing the camera
    quad(&mut s, -d, false, 0); // slab bottom, facing down (outward)
    quad(&mut s, -d - gap, true, 1); // emissive floor
    let direct_m = 1.0 + n as f64 * d as f64 + gap as f64;
    let echo_m = 2.0 * n as f64 * d as f64;
    let axis = TimeAxis::new((direct_m - 0.105) / C, 0.01 / C, 200).unwrap();
    let r = render_scene(s, 2, 2, axis, 4096, 1, 0);
    let mut tprf = vec![0.0; axis.bins];
    for y in 0..2 {
        for x in 0..2 {
            for (a, v) in tprf.iter_mut().zip(r.film.pixel_tprf(x, y)) {
                *a += v / 4.0;
            }
        }
    }
    let f = ((n as f64 - 1.0) / (n as f64 + 1.0)).powi(2);
    for k in 0..2 {
        let t = (direct_m + k as f64 * echo_m) / C;
        let b = axis.bin_of(t).unwrap();
        let want = le as f64 * (1.0 - f).powi(2) * f.powi(2 * k);
        let got = tprf[b - 1] + tprf[b] + tprf[b + 1];
        // Each impulse is a Bernoulli fraction of 4 x 4096 paths: tolerance from that count.
        let se = (want * le as f64 / (4.0 * 4096.0)).sqrt();
        assert!(
            (got - want).abs() < 5.0 * se + 1e-3 * want,
            "echo {k}: {got} vs {want} at {t} s (bin {b})"
        );
    }
    // Nothing arrives before the delayed direct path.
    let first = tprf.iter().position(|&v| v > 0.0).unwrap();
    assert!(
        axis.bin_start_s(first + 1) > direct_m / C,
        "first light in bin {first}"
    );
}

/// The paper's virtual interface: a half-covered layer (alpha 0.5, BLEND) at height h1
/// over an opaque floor at 0, camera and light together at height H, looking down. The
/// single-scattering TPRF has exactly two returns: the layer at `2 (H - h1) / c` with
/// `a rho L1`, and the floor at `2 H / c` with `(1 - a)^2 rho L0` (the light passes the
/// layer twice, undelayed), where `L = I / (pi r^2)` for a co-located source.
#[test]
fn partly_covered_layer_passes_light_undelayed() {
    use glam::{Affine3A, Vec3};
    use tprf_core::scene::{AlphaMode, Camera, Material, PunctualLight};
    let (big_h, h1, a, rho, i) = (10.0f32, 4.0f32, 0.5f32, 0.6f32, 100.0f32);
    let cam = Camera {
        world_from_camera: Affine3A::from_translation(Vec3::new(0.0, 0.0, big_h)),
        fov_rad: 1f32.to_radians(),
        fov_axis: tprf_core::scene::FovAxis::Y,
        near_m: 0.01,
    };
    let mut s = empty_scene(cam);
    let mut leaf = Material::lambertian("leaf", [rho; 3]);
    leaf.base_color[3] = a;
    leaf.alpha_mode = AlphaMode::Blend;
    s.materials.push(leaf);
    s.materials.push(Material::lambertian("ground", [rho; 3]));
    for (z, m) in [(h1, 0u32), (0.0, 1u32)] {
        let (p, q, r_, t) = (
            Vec3::new(-50.0, -50.0, z),
            Vec3::new(50.0, -50.0, z),
            Vec3::new(50.0, 50.0, z),
            Vec3::new(-50.0, 50.0, z),
        );
        push_tri(&mut s, [p, q, r_], m);
        push_tri(&mut s, [p, r_, t], m);
    }
    s.lights.push(PunctualLight {
        name: "laser".into(),
        position: Vec3::new(0.0, 0.0, big_h),
        intensity_w_per_sr: [i; 3],
        spot: None,
        projector: None,
    });
    let axis = TimeAxis::new(0.0, 0.1 / C, 300).unwrap();
    let spp = 2048;
    let r = render_scene(s, 2, 2, axis, spp, 4, 1);
    let mut single = vec![0.0; axis.bins];
    for y in 0..2 {
        for x in 0..2 {
            for (s1, v) in single.iter_mut().zip(&r.film.pixel_bounces(x, y)[1]) {
                *s1 += v / 4.0;
            }
        }
    }
    let pi = std::f64::consts::PI;
    let (a, rho, i) = (a as f64, rho as f64, i as f64);
    let d1 = (big_h - h1) as f64;
    let d0 = big_h as f64;
    let returns = [
        (2.0 * d1, a * rho * i / (pi * d1 * d1)),
        (2.0 * d0, (1.0 - a).powi(2) * rho * i / (pi * d0 * d0)),
    ];
    let total: f64 = single.iter().sum();
    let expected_total: f64 = returns.iter().map(|r| r.1).sum();
    for (opl, want) in returns {
        let b = axis.bin_of(opl / C).unwrap();
        let got = single[b.saturating_sub(1)..=b + 1].iter().sum::<f64>();
        // The camera ray passes or stops at the layer at random: a Bernoulli(a) fraction.
        let se = want * ((1.0 - a) / (a * 4.0 * spp as f64)).sqrt();
        assert!(
            (got - want).abs() < 5.0 * se + 1e-3 * want,
            "return at {opl} m: {got} vs {want}"
        );
    }
    assert!(
        (total - expected_total).abs() < 0.05 * expected_total,
        "nothing else is single scattering: {total} vs {expected_total}"
    );
}

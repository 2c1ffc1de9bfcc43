//! Work left out because its light cannot arrive inside the time window: shadow rays
//! not traced and paths ended, counted exactly. Inside a closed sphere with the camera
//! and a point light at the centre and one scattering event allowed, every camera path
//! hits the wall at distance R, makes exactly one shadow ray (to a light that every
//! wall point sees) and one bounce ray (which hits the wall again): so the counts are
//! known by hand.

use crate::common;

use common::*;
use std::ops::ControlFlow;
use std::sync::Arc;
use tprf_core::film::{FilmLayout, LeftOutCounts, TimeAxis, TprfFilm};
use tprf_core::transport::progressive::{Schedule, render};
use tprf_core::transport::{RenderSettings, Renderer};

const R_M: f64 = 1.0;
const W: usize = 6;
const H: usize = 5;
const SPP: u64 = 64;

/// Render the sphere with one scattering event into `axis`; returns the film, the
/// rays traced and the counts.
fn sphere_render(axis: TimeAxis) -> (TprfFilm, u64, LeftOutCounts) {
    let settings = RenderSettings {
        max_bounces: 1,
        seed: 5,
        ..RenderSettings::default()
    };
    let renderer = Renderer::new(Arc::new(furnace(R_M as f32, 0.5, 1.0)), settings);
    let mut film = TprfFilm::new(FilmLayout {
        width: W,
        height: H,
        axis,
        bounces_separate: 0,
        luminescence: false,
    })
    .unwrap();
    let reports = render(&renderer, &mut film, &Schedule::spp(SPP), |_, _| {
        ControlFlow::Continue(())
    });
    let last = reports.last().unwrap();
    (film, renderer.rays_traced(), last.left_out)
}

const PATHS: u64 = (W * H) as u64 * SPP;

#[test]
fn a_window_that_closes_before_the_wall_is_reached_ends_every_path() {
    // The wall is R away: the window ends at R / (2c).
    let axis = TimeAxis::new(0.0, 0.5 * R_M / C / 4.0, 4).unwrap();
    let (film, rays, left_out) = sphere_render(axis);
    assert_eq!(
        left_out,
        LeftOutCounts {
            paths_past_window: PATHS,
            ..LeftOutCounts::default()
        }
    );
    assert_eq!(rays, PATHS, "one camera ray per path, nothing after it");
    assert!(film.steady().iter().all(|v| *v == 0.0));
}

#[test]
fn a_window_that_opens_after_the_light_has_arrived_traces_no_shadow_ray() {
    // Light via one wall point arrives at 2R / c (light -> wall -> eye); the window opens
    // at 10R / c and ends at 14R / c: the bounce ray's second wall hit (at most 3R of
    // path) is still early, so nothing is recorded and no path ends past the window.
    let axis = TimeAxis::new(10.0 * R_M / C, R_M / C, 4).unwrap();
    let (film, rays, left_out) = sphere_render(axis);
    assert_eq!(
        left_out,
        LeftOutCounts {
            shadow_rays_early: PATHS,
            ..LeftOutCounts::default()
        }
    );
    // The camera ray and the bounce ray, and no shadow ray.
    assert_eq!(rays, 2 * PATHS);
    assert!(film.steady().iter().all(|v| *v == 0.0));
}

#[test]
fn a_window_that_ends_between_the_first_hit_and_the_light_skips_the_shadow_rays() {
    // The wall is reached at R / c, its light would arrive at 2R / c: the window
    // [0, 1.5 R / c) holds the hit but not the light.
    let axis = TimeAxis::new(0.0, 1.5 * R_M / C / 8.0, 8).unwrap();
    let (film, rays, left_out) = sphere_render(axis);
    assert_eq!(left_out.shadow_rays_late, PATHS);
    assert_eq!(left_out.shadow_rays_early, 0);
    // A bounce ray ends past the window when its chord is longer than R / 2: the chord
    // from a wall point to a cosine-sampled wall point has density d / (2 R^2) on
    // [0, 2R], so that happens with probability 1 - 1/16 (binomial, within 4 sigma).
    let p = 1.0 - 1.0 / 16.0;
    let (mean, sigma) = (PATHS as f64 * p, (PATHS as f64 * p * (1.0 - p)).sqrt());
    let got = left_out.paths_past_window as f64;
    assert!(
        (got - mean).abs() <= 4.0 * sigma,
        "{got} paths ended, {mean} expected"
    );
    assert_eq!(rays, 2 * PATHS);
    assert!(film.steady().iter().all(|v| *v == 0.0));
}

#[test]
fn a_window_holding_the_light_traces_every_shadow_ray() {
    let axis = TimeAxis::new(0.0, 4.0 * R_M / C / 8.0, 8).unwrap();
    let (film, rays, left_out) = sphere_render(axis);
    assert_eq!(left_out.shadow_rays_late + left_out.shadow_rays_early, 0);
    assert_eq!(rays, 3 * PATHS);
    assert!(film.steady().iter().all(|v| *v > 0.0));
}

#[test]
fn an_overflowing_emitter_is_refused_with_its_material() {
    let mut scene = furnace(R_M as f32, 0.5, 1.0);
    // emissiveFactor x emissive_strength past f32::MAX.
    scene.materials[0].emissive = [1e30f32 * 1e10; 3];
    let err = scene.validate().unwrap_err().to_string();
    assert!(
        err.contains(&scene.materials[0].name) && err.contains("overflows"),
        "{err}"
    );
}

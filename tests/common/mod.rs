//! Scenes built by hand for the analytic tests, and a one-call render.
#![allow(dead_code, reason = "each test binary uses a part of these helpers")]

pub mod cli;
pub mod serialized;

use glam::{Vec2, Vec3};
use std::sync::Arc;
use tprf_core::film::{FilmLayout, TimeAxis, TprfFilm};
use tprf_core::reference::furnace::Furnace;
use tprf_core::reference::plane::Plane;
use tprf_core::scene::{Camera, Material, Scene, SceneObject, Triangle, TriangleAttrs};
use tprf_core::transport::progressive::{Schedule, render};
use tprf_core::transport::sampler::Sampler;
use tprf_core::transport::{RenderSettings, Renderer, Sink};

pub const C: f64 = 299_792_458.0;

/// Henyey-Greenstein phase function, written out again (not the renderer's), 1/sr.
pub fn hg(cos: f64, g: f64) -> f64 {
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * cos).powf(1.5))
}

/// Composite Simpson's rule with `n` (even) intervals.
pub fn simpson(a: f64, b: f64, n: usize, f: impl Fn(f64) -> f64) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

pub fn empty_scene(camera: Camera) -> Scene {
    Scene {
        name: "test".into(),
        triangles: vec![],
        attrs: vec![],
        materials: vec![],
        textures: vec![],
        lights: vec![],
        camera,
        ambient: Default::default(),
        objects: Vec::new(),
        medium: None,
        notes: vec![],
    }
}

pub fn push_tri(scene: &mut Scene, p: [Vec3; 3], material: u32) {
    scene.triangles.push(Triangle { p });
    scene.attrs.push(TriangleAttrs {
        normals: None,
        uv: [Vec2::ZERO; 3],
        material,
    });
}

/// Closed Lambertian sphere of radius `r_m` and albedo `rho`, with a point light of
/// intensity `i_w_per_sr` and the camera both at the centre.
pub fn furnace(r_m: f32, rho: f32, i_w_per_sr: f32) -> Scene {
    Furnace::point(r_m as f64, rho as f64, i_w_per_sr as f64).scene()
}

/// A square Lambertian plane z = 0 of half-size `half_m`, albedo `rho`; camera at height
/// `h_m` looking straight down with vertical fov `fov_deg`; point light of intensity
/// `i_w_per_sr` at the camera.
pub fn lit_plane(h_m: f32, rho: f32, i_w_per_sr: f32, half_m: f32, fov_deg: f32) -> Scene {
    Plane::colocated(
        h_m as f64,
        rho as f64,
        i_w_per_sr as f64,
        half_m as f64,
        fov_deg as f64,
    )
    .scene()
}

pub struct Rendered {
    pub film: TprfFilm,
    pub rays: u64,
}

/// Render `scene` at `w x h` with `spp` samples on the given axis.
pub fn render_scene(
    scene: Scene,
    w: usize,
    h: usize,
    axis: TimeAxis,
    spp: u64,
    seed: u64,
    bounces_separate: u32,
) -> Rendered {
    let settings = RenderSettings {
        seed,
        ..RenderSettings::default()
    };
    render_with(scene, w, h, axis, spp, settings, bounces_separate)
}

/// Render `scene` at `w x h` with `spp` samples on the given axis with `settings`.
pub fn render_with(
    scene: Scene,
    w: usize,
    h: usize,
    axis: TimeAxis,
    spp: u64,
    settings: RenderSettings,
    bounces_separate: u32,
) -> Rendered {
    let renderer = Renderer::new(Arc::new(scene), settings);
    let luminescence = renderer.is_luminescent();
    let mut film = TprfFilm::new(FilmLayout {
        width: w,
        height: h,
        axis,
        bounces_separate,
        luminescence,
    })
    .expect("film");
    render(&renderer, &mut film, &Schedule::spp(spp), |_, _| {
        std::ops::ControlFlow::Continue(())
    });
    Rendered {
        rays: renderer.rays_traced(),
        film,
    }
}

/// Energy-weighted mean of bin centres, seconds.
pub fn mean_arrival_s(tprf: &[f64], axis: &TimeAxis) -> f64 {
    let total: f64 = tprf.iter().sum();
    tprf.iter()
        .enumerate()
        .map(|(b, v)| v * axis.bin_center_s(b))
        .sum::<f64>()
        / total
}

/// An NLOS scene: the 2 m relay wall at z = 0 (object `relay_wall`) and one square patch
/// of side `side` (object `patch`) centred at `c`, parallel to the wall and facing it.
pub fn nlos_patch_scene(c: Vec3, side: f32) -> Scene {
    let mut s = empty_scene(Camera::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.8));
    s.materials = vec![
        Material::lambertian("wall", [0.8; 3]),
        Material::lambertian("patch", [0.8; 3]),
    ];
    let v = Vec3::new;
    push_tri(
        &mut s,
        [v(-1.0, -1.0, 0.0), v(1.0, -1.0, 0.0), v(1.0, 1.0, 0.0)],
        0,
    );
    push_tri(
        &mut s,
        [v(-1.0, -1.0, 0.0), v(1.0, 1.0, 0.0), v(-1.0, 1.0, 0.0)],
        0,
    );
    let h = side / 2.0;
    let q = [
        c + v(-h, -h, 0.0),
        c + v(h, -h, 0.0),
        c + v(h, h, 0.0),
        c + v(-h, h, 0.0),
    ];
    push_tri(&mut s, [q[0], q[2], q[1]], 1);
    push_tri(&mut s, [q[0], q[3], q[2]], 1);
    s.objects = vec![
        SceneObject {
            name: "relay_wall".into(),
            triangles: 0..2,
        },
        SceneObject {
            name: "patch".into(),
            triangles: 2..4,
        },
    ];
    s
}

/// A sink that sums every contribution whenever it arrives: the steady radiance.
pub struct Steady {
    pub sum: f64,
}

impl Sink for Steady {
    fn add(&mut self, arrival_s: f64, value: f64, _scatterings: u32) {
        assert!(value.is_finite() && arrival_s.is_finite());
        self.sum += value;
    }
    fn window_end_s(&self) -> f64 {
        f64::INFINITY
    }
}

/// Per-pixel steady radiance (mean of `spp` samples) of a `w x h` image of `scene`.
pub fn steady_pixels(scene: Scene, w: usize, h: usize, spp: u32, seed: u64) -> Vec<f64> {
    let settings = RenderSettings {
        seed,
        ..RenderSettings::default()
    };
    let renderer = Renderer::new(Arc::new(scene), settings);
    (0..w * h)
        .map(|p| {
            let mut rng = Sampler::new(seed, 0, p as u64);
            let mut sink = Steady { sum: 0.0 };
            for _ in 0..spp {
                renderer.trace_sample(p % w, p / w, w, h, &mut rng, &mut sink);
            }
            sink.sum / spp as f64
        })
        .collect()
}

/// The mean of `v` and its standard error.
pub fn mean_and_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

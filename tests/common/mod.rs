//! Scenes built by hand for the analytic tests, and a one-call render.
#![allow(dead_code)]

use glam::{Affine3A, Vec2, Vec3};
use std::sync::Arc;
use tprf::film::{FilmLayout, TimeAxis, TprfFilm};
use tprf::scene::{Camera, Material, PunctualLight, Scene, Triangle, TriangleAttrs};
use tprf::transport::progressive::{Budget, render};
use tprf::transport::{RenderSettings, Renderer};

pub const C: f64 = 299_792_458.0;

pub fn empty_scene(camera: Camera) -> Scene {
    Scene {
        name: "test".into(),
        triangles: vec![],
        attrs: vec![],
        materials: vec![],
        textures: vec![],
        lights: vec![],
        camera,
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

/// An icosphere of radius `r_m` (subdivided `level` times), vertices on the sphere.
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

/// Closed Lambertian sphere of radius `r_m` and albedo `rho`, with a point light of
/// intensity `i_w_per_sr` and the camera both at the centre.
pub fn furnace(r_m: f32, rho: f32, i_w_per_sr: f32) -> Scene {
    let cam = Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 60f32.to_radians());
    let mut s = empty_scene(cam);
    s.materials.push(Material::lambertian("wall", [rho; 3]));
    for t in icosphere(r_m, 5) {
        push_tri(&mut s, t, 0);
    }
    s.lights.push(PunctualLight {
        name: "centre".into(),
        position: Vec3::ZERO,
        intensity_w_per_sr: [i_w_per_sr; 3],
        spot: None,
    });
    s
}

/// A square Lambertian plane z = 0 of half-size `half_m`, albedo `rho`; camera at height
/// `h_m` looking straight down with vertical fov `fov_deg`; point light of intensity
/// `i_w_per_sr` at the camera.
pub fn lit_plane(h_m: f32, rho: f32, i_w_per_sr: f32, half_m: f32, fov_deg: f32) -> Scene {
    let eye = Vec3::new(0.0, 0.0, h_m);
    let world_from_camera = Affine3A::from_translation(eye);
    let cam = Camera {
        world_from_camera,
        yfov_rad: fov_deg.to_radians(),
    };
    let mut s = empty_scene(cam);
    s.materials.push(Material::lambertian("plane", [rho; 3]));
    let a = Vec3::new(-half_m, -half_m, 0.0);
    let b = Vec3::new(half_m, -half_m, 0.0);
    let c = Vec3::new(half_m, half_m, 0.0);
    let d = Vec3::new(-half_m, half_m, 0.0);
    push_tri(&mut s, [a, b, c], 0);
    push_tri(&mut s, [a, c, d], 0);
    s.lights.push(PunctualLight {
        name: "colocated".into(),
        position: eye,
        intensity_w_per_sr: [i_w_per_sr; 3],
        spot: None,
    });
    s
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
    let renderer = Renderer::new(Arc::new(scene), settings);
    let mut film = TprfFilm::new(FilmLayout {
        width: w,
        height: h,
        axis,
        bounces_separate,
    })
    .expect("film");
    render(&renderer, &mut film, Budget::Spp(spp), |_, _| {
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

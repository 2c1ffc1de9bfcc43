//! The automatic time window's pilot render samples the film's aspect: a wide film whose
//! only light sits at its left and right edges, outside the square field of view, gets
//! a window around that light, derived here by hand from the geometry.

use glam::{Affine3A, Vec2, Vec3};
use std::sync::Arc;
use tprf_core::scene::{Camera, Material, Scene, Triangle, TriangleAttrs};
use tprf_core::transport::{RenderSettings, Renderer, WindowError, WindowRequest, auto_window};
use tprf_core::units::C_M_PER_S;

/// Half the side of each emitting square, metres.
const HALF_M: f32 = 0.1;
/// The squares' centres: `(+-X_M, 0, -1)`, in the plane `z = -1`, facing the camera.
const X_M: f32 = 2.0;
/// Vertical field of view: tan(20 deg) = 0.364, so a square film sees
/// `|x / z| <= 0.364` and a film 8 times as wide sees `|x / z| <= 2.91`.
const YFOV_DEG: f32 = 40.0;
const ASPECT: f64 = 8.0;

/// Two emitting squares, nothing else; the camera at the origin looking along -Z.
fn edge_lights() -> Scene {
    let mut triangles = Vec::new();
    for cx in [-X_M, X_M] {
        let p = |dx: f32, dy: f32| Vec3::new(cx + dx * HALF_M, dy * HALF_M, -1.0);
        triangles.push(Triangle {
            p: [p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0)],
        });
        triangles.push(Triangle {
            p: [p(-1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)],
        });
    }
    let attrs = vec![
        TriangleAttrs {
            normals: None,
            uv: [Vec2::ZERO; 3],
            material: 0,
        };
        triangles.len()
    ];
    let emitter = Material {
        emissive: [1.0; 3],
        ..Material::lambertian("emitter", [0.0; 3])
    };
    Scene {
        name: "edge lights".into(),
        triangles,
        attrs,
        materials: vec![emitter],
        textures: Vec::new(),
        lights: Vec::new(),
        camera: Camera {
            world_from_camera: Affine3A::IDENTITY,
            fov_rad: YFOV_DEG.to_radians(),
            fov_axis: tprf_core::scene::FovAxis::Y,
            near_m: 0.01,
        },
        ambient: Default::default(),
        objects: Vec::new(),
        medium: None,
        notes: Vec::new(),
    }
}

#[test]
fn the_pilot_of_a_wide_film_sees_light_at_its_edges() {
    let renderer = Renderer::new(Arc::new(edge_lights()), RenderSettings::default());
    let req = WindowRequest {
        t0_s: None,
        dt_s: None,
        bins: 64,
        aspect: ASPECT,
    };
    // Both squares lie at |x / z| in [1.9, 2.1]: outside the square field of view
    // (0.364), inside the wide one (2.91). A square pilot sees nothing.
    assert_eq!(
        auto_window(&renderer, WindowRequest { aspect: 1.0, ..req }),
        Err(WindowError::NoLight)
    );
    let axis = auto_window(&renderer, req).expect("the wide pilot sees the squares");
    // The light leaves a square at t = 0 and travels straight to the eye: a point
    // (x, y, -1) of a square is seen at sqrt(x^2 + y^2 + 1) / c. The nearest point is
    // (1.9, 0, -1), the farthest (2.1, 0.1, -1).
    let (x0, x1) = (f64::from(X_M - HALF_M), f64::from(X_M + HALF_M));
    let y1 = f64::from(HALF_M);
    let first_s = (x0 * x0 + 1.0).sqrt() / C_M_PER_S;
    let last_s = (x1 * x1 + y1 * y1 + 1.0).sqrt() / C_M_PER_S;
    // The window opens before the first light, not much before it.
    assert!(axis.t0_s <= first_s, "{axis:?} opens after {first_s}");
    assert!(axis.t0_s >= first_s - 0.05 / C_M_PER_S, "{axis:?}");
    // It holds the light of at least three quarters of each square's area (x <= 2.05:
    // at most sqrt(2.05^2 + 0.1^2 + 1) / c), and ends soon after the last light.
    let x_3q = f64::from(X_M) + 0.5 * f64::from(HALF_M);
    let three_quarters_s = (x_3q * x_3q + y1 * y1 + 1.0).sqrt() / C_M_PER_S;
    assert!(axis.end_s() >= three_quarters_s, "{axis:?}");
    assert!(axis.end_s() <= last_s + 0.1 / C_M_PER_S, "{axis:?}");
}

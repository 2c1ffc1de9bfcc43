//! The automatic time window's pilot render samples the film's aspect: a wide film whose
//! only light sits at its left and right edges, outside the square field of view, gets
//! a window around that light, derived here by hand from the geometry. In fog, the
//! window holds a wall's return behind the backscatter, timed by hand.

use glam::{Affine3A, Vec2, Vec3};
use std::sync::Arc;
use tprf_core::scene::{Camera, Material, Medium, PunctualLight, Scene, Triangle, TriangleAttrs};
use tprf_core::transport::{
    RenderSettings, Renderer, WindowError, WindowRequest, auto_window, choose_window,
};
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

/// Distance from the camera to the wall, metres.
const WALL_M: f32 = 30.0;
/// Half the wall's side, metres: it fills the field of view.
const WALL_HALF_M: f32 = 20.0;

/// A white wall `WALL_M` away across fog of visibility 20 m (extinction 0.196 /m: the
/// wall's round trip keeps e^(-11.7) = 8e-6 of its light), lit by a point light 0.1 m
/// beside the camera; camera at the origin looking along -Z, 10 degrees field of view.
fn wall_in_fog() -> Scene {
    let p = |x: f32, y: f32| Vec3::new(x * WALL_HALF_M, y * WALL_HALF_M, -WALL_M);
    let triangles = vec![
        Triangle {
            p: [p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0)],
        },
        Triangle {
            p: [p(-1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)],
        },
    ];
    let attrs = vec![
        TriangleAttrs {
            normals: None,
            uv: [Vec2::ZERO; 3],
            material: 0,
        };
        2
    ];
    Scene {
        name: "wall in fog".into(),
        triangles,
        attrs,
        materials: vec![Material::lambertian("wall", [0.8; 3])],
        textures: Vec::new(),
        lights: vec![PunctualLight {
            name: "laser".into(),
            position: Vec3::new(0.0, -0.1, 0.0),
            intensity_w_per_sr: [1.0; 3],
            spot: None,
            projector: None,
        }],
        camera: Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 10f32.to_radians()),
        ambient: Default::default(),
        objects: Vec::new(),
        medium: Some(Medium::from_visibility(20.0, 0.9, 0.85, 1.0)),
        notes: Vec::new(),
    }
}

#[test]
fn in_fog_the_window_holds_the_return_behind_the_backscatter() {
    let renderer = Renderer::new(Arc::new(wall_in_fog()), RenderSettings::default());
    let req = WindowRequest {
        t0_s: None,
        dt_s: None,
        bins: 256,
        aspect: 1.0,
    };
    let chosen = choose_window(&renderer, req).expect("light arrives");
    let axis = chosen.axis;
    // The wall's return: out and back 30 m, to 30 / cos(5 deg) at the field's edge (the
    // corners, 30 / cos(7.1 deg)), the light's 0.1 m offset aside: 200.1 ... 201.7 ns.
    let wall_s = 2.0 * f64::from(WALL_M) / C_M_PER_S;
    let corner_s = 2.0 * f64::from(WALL_M) / (7.1f64.to_radians().cos()) / C_M_PER_S;
    // The fog's backscatter starts at once: the window opens at 0.
    assert!(axis.t0_s <= 0.01 * wall_s, "{axis:?}");
    // Nearly all of the fog pilot's light is backscatter from within a few metres (its
    // 99.5 % ends far before the wall); the window still holds the wall's whole return.
    assert!(
        axis.end_s() >= corner_s,
        "{axis:?} ends before the wall's return at {corner_s}"
    );
    assert!(axis.end_s() <= 1.5 * corner_s, "{axis:?}");
    // The slice a view opens on is the wall's return, whose attenuated light all
    // arrives between wall_s and corner_s.
    let returns_s = chosen
        .surface_returns_s
        .expect("a homogeneous scene medium");
    assert!(
        returns_s >= wall_s && returns_s <= corner_s + 1e-12,
        "{returns_s} outside {wall_s} .. {corner_s}"
    );
    // A clear scene has no such time: every pixel's own peak is its surfaces'.
    let mut clear = wall_in_fog();
    clear.medium = None;
    let clear = Renderer::new(Arc::new(clear), RenderSettings::default());
    assert_eq!(choose_window(&clear, req).unwrap().surface_returns_s, None);
}

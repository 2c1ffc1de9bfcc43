//! `builtin:flim`: fluorescence-lifetime imaging of a slide. Two dye spots of the same
//! steady colour, one with a 1 ns lifetime and one with 4 ns, on a dark slide under a
//! pulsed laser beside a microscope-like camera: a steady image cannot tell them apart,
//! the decay after the pulse can (FLIM's two-gate lifetime, `tprf sensor` with the
//! `flim` preset).

use super::{Builder, Camera, Material, PunctualLight, Scene, SceneObject};
use crate::scene::Luminescence;
use glam::Vec3;

/// The two dyes' lifetimes, seconds: the left spot's and the right spot's.
pub const FLIM_LIFETIMES_S: [f64; 2] = [1e-9, 4e-9];
/// The dyes' yield (both).
pub const FLIM_YIELD: f32 = 0.5;
/// Height of the camera and the laser above the slide, metres.
pub const FLIM_HEIGHT_M: f32 = 0.15;

/// The slide (y = 0, 80 x 50 mm, a dark mount of albedo 0.05), the two spots (25 x 25
/// mm, 0.5 mm above it, base colour 0.1 and yield [`FLIM_YIELD`], green emission), the
/// laser (1 W/sr) and the camera looking straight down from [`FLIM_HEIGHT_M`].
pub fn flim() -> Scene {
    const SLIDE: u32 = 0;
    let v = Vec3::new;
    let mut b = Builder::default();
    let (hx, hz) = (0.04, 0.025);
    b.quad(
        [
            v(-hx, 0.0, -hz),
            v(hx, 0.0, -hz),
            v(hx, 0.0, hz),
            v(-hx, 0.0, hz),
        ],
        Vec3::Y,
        SLIDE,
    );
    let mut objects = vec![SceneObject {
        name: "slide".into(),
        triangles: 0..b.triangles.len(),
    }];
    let mut materials = vec![Material::lambertian("slide", [0.05; 3])];
    for (k, (&tau, x0)) in FLIM_LIFETIMES_S
        .iter()
        .zip([-0.0325f32, 0.0075])
        .enumerate()
    {
        let name = format!("dye {} ns", tau * 1e9);
        let start = b.triangles.len();
        let (x1, y, s) = (x0 + 0.025, 0.0005, 0.0125);
        b.quad(
            [v(x0, y, -s), v(x1, y, -s), v(x1, y, s), v(x0, y, s)],
            Vec3::Y,
            k as u32 + 1,
        );
        objects.push(SceneObject {
            name: name.clone(),
            triangles: start..b.triangles.len(),
        });
        let mut dye = Material::lambertian(&name, [0.1; 3]);
        dye.luminescence = Some(Luminescence {
            emission_color: [0.2, 1.0, 0.3],
            ..Luminescence::single(FLIM_YIELD, tau)
        });
        materials.push(dye);
    }
    let eye = v(0.0, FLIM_HEIGHT_M, 0.0);
    Scene {
        name: "builtin:flim".into(),
        triangles: b.triangles,
        attrs: b.attrs,
        materials,
        textures: Vec::new(),
        lights: vec![PunctualLight {
            name: "pulsed laser".into(),
            position: eye,
            intensity_w_per_sr: [1.0; 3],
            spot: None,
            projector: None,
        }],
        camera: Camera::look_at(eye, Vec3::ZERO, 2.0 * (0.05f32 / FLIM_HEIGHT_M).atan()),
        ambient: Default::default(),
        objects,
        medium: None,
        notes: Vec::new(),
    }
}

//! `builtin:fog`: the automotive LiDAR problem. A road seen from a car's sensor through
//! fog: a pedestrian at 22 m on the verge, a car in the next lane at 35 m, a road sign at
//! 60 m, a car ahead in the own lane at 78 m; the sensor's pulsed laser 10 cm under the
//! camera. The fog's backscatter leaves the sensor first, as a wavefront that fades with
//! distance; each target returns its pulse later, dimmed twice by the fog on the way out
//! and back. A LiDAR's SPAD sees the fog's early pile-up steal its detections from the
//! targets.
//!
//! World space: metres, +Y up; the road runs along -Z from the sensor at the origin. The
//! fog is the scene's medium: visibility [`FOG_VISIBILITY_M`] (meteorological optical
//! range; extinction 3.912 / V), all scattering, g 0.9; replace it with `tprf render
//! --medium visibility=30m` (or `none`).

use super::Builder;
use crate::scene::{Camera, Material, Medium, PunctualLight, Scene, Spot};
use glam::Vec3;

/// The fog's visibility (meteorological optical range), metres.
pub const FOG_VISIBILITY_M: f64 = 50.0;

/// Height of the sensor's camera above the road, metres (a roof-edge LiDAR).
pub const FOG_SENSOR_HEIGHT_M: f32 = 1.2;

/// The laser's offset below the camera, metres: a sensor's baseline. (Exactly at the
/// camera, the backscatter of the fog next to the lens would be infinite: `1 / r^2`
/// integrated from 0.)
pub const FOG_LASER_OFFSET_M: f32 = 0.1;

/// Radiant intensity of the laser, W/sr: the pedestrian (albedo 0.3 at 22 m) has a
/// radiance of about 1 W m^-2 sr^-1 in clear air.
pub const FOG_LASER_W_PER_SR: f32 = 5000.0;

pub(super) fn fog() -> Scene {
    const ROAD: u32 = 0;
    const MARKING: u32 = 1;
    const CAR: u32 = 2;
    const PEDESTRIAN: u32 = 3;
    const SIGN: u32 = 4;
    const POST: u32 = 5;
    let v = Vec3::new;
    let mut b = Builder::default();
    // The road and its verges, 30 m wide, from 5 m behind the sensor to 150 m ahead.
    b.quad(
        [
            v(-15.0, 0.0, 5.0),
            v(15.0, 0.0, 5.0),
            v(15.0, 0.0, -150.0),
            v(-15.0, 0.0, -150.0),
        ],
        Vec3::Y,
        ROAD,
    );
    // Lane markings: dashes 3 m long every 9 m on the centre line (x = -1.75), 1 cm
    // above the road so they are seen in front of it.
    let mut marks = Builder::default();
    let mut z = -2.0;
    while z > -150.0 {
        marks.quad(
            [
                v(-1.8, 0.01, z),
                v(-1.7, 0.01, z),
                v(-1.7, 0.01, z - 3.0),
                v(-1.8, 0.01, z - 3.0),
            ],
            Vec3::Y,
            MARKING,
        );
        z -= 9.0;
    }
    b.append(marks);
    // Two cars: boxes 1.8 m wide, 1.5 m high, 4.5 m long.
    let mut cars = Builder::default();
    let car = |b: &mut Builder, x: f32, z_near: f32| {
        b.prism(
            [
                (x - 0.9, z_near),
                (x + 0.9, z_near),
                (x + 0.9, z_near - 4.5),
                (x - 0.9, z_near - 4.5),
            ],
            0.0,
            1.5,
            CAR,
        );
    };
    car(&mut cars, -3.5, -35.0);
    car(&mut cars, 0.0, -78.0);
    b.append(cars);
    // The pedestrian: a cylinder of radius 0.25 m, 1.75 m tall, on the verge at 22 m.
    let mut person = Builder::default();
    let (cx, cz, radius, height) = (2.8f32, -22.0f32, 0.25f32, 1.75f32);
    let segments = 24;
    let at = |k: usize| {
        let a = std::f32::consts::TAU * k as f32 / segments as f32;
        (cx + radius * a.cos(), cz + radius * a.sin())
    };
    for k in 0..segments {
        let ((x0, z0), (x1, z1)) = (at(k), at(k + 1));
        let out = v(0.5 * (x0 + x1) - cx, 0.0, 0.5 * (z0 + z1) - cz);
        person.quad(
            [
                v(x0, 0.0, z0),
                v(x1, 0.0, z1),
                v(x1, height, z1),
                v(x0, height, z0),
            ],
            out,
            PEDESTRIAN,
        );
        person.triangle(
            [v(cx, height, cz), v(x1, height, z1), v(x0, height, z0)],
            None,
            PEDESTRIAN,
        );
    }
    b.append(person);
    // The sign: a 0.9 m white plate facing the road, its centre 2.2 m up, at 60 m.
    let mut sign = Builder::default();
    let (sx, sz) = (5.0f32, -60.0f32);
    sign.quad(
        [
            v(sx - 0.45, 1.75, sz),
            v(sx + 0.45, 1.75, sz),
            v(sx + 0.45, 2.65, sz),
            v(sx - 0.45, 2.65, sz),
        ],
        Vec3::Z,
        SIGN,
    );
    b.append(sign);
    let mut post = Builder::default();
    post.prism(
        [
            (sx - 0.04, sz - 0.02),
            (sx + 0.04, sz - 0.02),
            (sx + 0.04, sz - 0.1),
            (sx - 0.04, sz - 0.1),
        ],
        0.0,
        1.75,
        POST,
    );
    b.append(post);

    let eye = v(0.0, FOG_SENSOR_HEIGHT_M, 0.0);
    let target = v(0.0, 1.0, -60.0);
    let laser = eye - v(0.0, FOG_LASER_OFFSET_M, 0.0);
    Scene {
        name: "builtin:fog".into(),
        triangles: b.triangles,
        attrs: b.attrs,
        materials: vec![
            Material::lambertian("asphalt", [0.1; 3]),
            Material::lambertian("lane marking", [0.7; 3]),
            Material::lambertian("car paint", [0.35, 0.3, 0.3]),
            Material::lambertian("clothes", [0.3, 0.3, 0.35]),
            Material::lambertian("sign", [0.85; 3]),
            Material::lambertian("post", [0.4; 3]),
        ],
        textures: Vec::new(),
        lights: vec![PunctualLight {
            name: "laser".into(),
            position: laser,
            intensity_w_per_sr: [FOG_LASER_W_PER_SR; 3],
            // A cone that holds the camera's view for images up to 2.5:1.
            spot: Some(Spot {
                direction: (target - laser).normalize(),
                inner_cone_rad: 28f32.to_radians(),
                outer_cone_rad: 30f32.to_radians(),
            }),
            projector: None,
        }],
        camera: Camera::look_at(eye, target, 20f32.to_radians()),
        ambient: Default::default(),
        medium: Some(Medium::from_visibility(
            FOG_VISIBILITY_M,
            1.0,
            crate::scene::medium::FOG_G,
            1.0,
        )),
        objects: Vec::new(),
        notes: Vec::new(),
    }
}

//! What the benches share: the 1 M-triangle test scene.

use glam::Vec3;
use tprf_core::scene::{Material, Scene, Triangle, TriangleAttrs};

/// `builtin:cornell` with the two blocks replaced by a displaced sphere: `lat` rings of
/// `lon` segments, `2 lon (lat - 1)` triangles, grey Lambertian (albedo 0.7), radius
/// 0.15 m +- 10 % on the floor's centre line. Flat-shaded (geometric normals).
pub fn cornell_blob(lat: usize, lon: usize) -> Scene {
    use std::f32::consts::{PI, TAU};
    let mut scene = tprf_core::scene::load("builtin:cornell").expect("builtin:cornell");
    // Keep the walls: triangles whose three vertices lie on one face of the box.
    let h = 0.5 * tprf_core::scene::builtin::CORNELL_SIZE_M;
    let planes = [(0, -h), (0, h), (1, 0.0), (1, 2.0 * h), (2, -h)];
    let on_wall = |t: &Triangle| {
        planes
            .iter()
            .any(|&(axis, v)| t.p.iter().all(|p| (p[axis] - v).abs() < 1e-6))
    };
    let (triangles, attrs): (Vec<Triangle>, Vec<TriangleAttrs>) = scene
        .triangles
        .iter()
        .zip(&scene.attrs)
        .filter(|(t, _)| on_wall(t))
        .map(|(t, a)| (*t, *a))
        .unzip();
    assert_eq!(triangles.len(), 10, "the box has 5 walls of 2 triangles");
    scene.triangles = triangles;
    scene.attrs = attrs;

    let material = scene.materials.len() as u32;
    scene
        .materials
        .push(Material::lambertian("blob", [0.7, 0.7, 0.7]));
    let centre = Vec3::new(0.0, 0.2, 0.0);
    let radius = 0.15;
    // Bumps at several scales, a smooth function of the direction (no seam at the poles).
    let point = |i: usize, j: usize| {
        let (theta, phi) = (PI * i as f32 / lat as f32, TAU * j as f32 / lon as f32);
        let d = Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        );
        let bumps =
            0.06 * (6.0 * d.x + 1.3).sin() * (5.0 * d.y + 0.4).sin() * (7.0 * d.z + 2.1).sin()
                + 0.03 * (17.0 * (d.x + d.y) + 0.5).sin() * (19.0 * (d.y - d.z)).sin()
                + 0.012 * (53.0 * d.x + 41.0 * d.z + 0.7).sin() * (47.0 * d.y + 1.1).sin();
        centre + d * radius * (1.0 + bumps)
    };
    let attrs = TriangleAttrs {
        normals: None,
        uv: Default::default(),
        material,
    };
    let mut push = |p: [Vec3; 3]| {
        // Face outwards.
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let out = (p[0] + p[1] + p[2]) / 3.0 - centre;
        let p = if n.dot(out) < 0.0 {
            [p[0], p[2], p[1]]
        } else {
            p
        };
        scene.triangles.push(Triangle { p });
        scene.attrs.push(attrs);
    };
    for i in 0..lat {
        for j in 0..lon {
            let (a, b) = (point(i, j), point(i, (j + 1) % lon));
            let (c, d) = (point(i + 1, j), point(i + 1, (j + 1) % lon));
            if i > 0 {
                push([a, b, d]);
            }
            if i + 1 < lat {
                push([a, d, c]);
            }
        }
    }
    scene.name = format!("cornell + {}-triangle blob", scene.triangles.len() - 10);
    scene.validate().expect("valid scene");
    scene
}

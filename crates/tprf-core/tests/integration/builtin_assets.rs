//! The built-in scenes against hand-derived facts of their physical setup, and their
//! glTF exports in `assets/` (regenerate with
//! `TPRF_WRITE_ASSETS=1 cargo test --release --test integration builtin_assets`).

use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use std::path::PathBuf;
use tprf_core::scene::{Scene, Triangle, builtin, gltf_save};

/// Distance along the ray `o + t d` (t > 1e-9) to the triangle, Moller-Trumbore in f64.
fn hit(o: DVec3, d: DVec3, t: &Triangle) -> Option<f64> {
    let [p0, p1, p2] = t.p.map(|p| p.as_dvec3());
    let (e1, e2) = (p1 - p0, p2 - p0);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-18 {
        return None;
    }
    let s = o - p0;
    let u = s.dot(pv) / det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) / det;
    (t > 1e-9).then_some(t)
}

/// Nearest hit of the ray among `tris`: (distance, triangle index).
fn nearest<'a>(
    o: DVec3,
    d: DVec3,
    tris: impl Iterator<Item = (usize, &'a Triangle)>,
) -> Option<(f64, usize)> {
    tris.filter_map(|(i, t)| hit(o, d, t).map(|h| (h, i)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

fn normal(t: &Triangle) -> DVec3 {
    let [p0, p1, p2] = t.p.map(|p| p.as_dvec3());
    (p1 - p0).cross(p2 - p0).normalize()
}

fn centroid(t: &Triangle) -> DVec3 {
    (t.p[0] + t.p[1] + t.p[2]).as_dvec3() / 3.0
}

/// A world-space ray direction through the image point (sx, sy) in [-1, 1] of a square
/// image (sy = 1 the top edge).
fn camera_ray(s: &Scene, sx: f64, sy: f64) -> DVec3 {
    let k = (0.5 * s.camera.fov_rad as f64).tan();
    let local = Vec3::new((sx * k) as f32, (sy * k) as f32, -1.0);
    s.camera
        .world_from_camera
        .transform_vector3(local)
        .as_dvec3()
        .normalize()
}

fn material_index(s: &Scene, name: &str) -> u32 {
    s.materials.iter().position(|m| m.name == name).unwrap() as u32
}

#[test]
fn cornell_physical_setup() {
    let s = builtin::load("cornell").unwrap();
    let h = 0.2775f64; // half the 0.555 m side
    let b = s.geometry_bounds().unwrap();
    assert!(
        (b.min.as_dvec3() - DVec3::new(-h, 0.0, -h))
            .abs()
            .max_element()
            < 1e-6
    );
    assert!(
        (b.max.as_dvec3() - DVec3::new(h, 2.0 * h, h))
            .abs()
            .max_element()
            < 1e-6
    );
    assert_eq!(s.triangles.len(), 30, "5 walls + 2 blocks of 5 quads");

    // Materials: pure Lambertian, double-sided, no emission; red left, green right.
    for m in &s.materials {
        assert_eq!(
            (m.specular_factor, m.metallic, m.transmission),
            (0.0, 0.0, 0.0)
        );
        assert!(m.double_sided && !m.is_emissive());
    }

    // Closed on 5 sides: two triangles on each of the planes x = +-h, y = 0, y = 2h,
    // z = -h, covering the whole 0.555 m square, facing into the box; none at z = +h.
    let centre = DVec3::new(0.0, h, 0.0);
    let planes: [(usize, f64, &str); 6] = [
        (0, -h, "red"),
        (0, h, "green"),
        (1, 0.0, "white"),
        (1, 2.0 * h, "white"),
        (2, -h, "white"),
        (2, h, "none: open front"),
    ];
    for (axis, value, mat) in planes {
        let on: Vec<usize> = (0..s.triangles.len())
            .filter(|&i| {
                s.triangles[i]
                    .p
                    .iter()
                    .all(|p| (p.as_dvec3()[axis] - value).abs() < 1e-6)
            })
            .collect();
        if value == h && axis == 2 {
            assert!(on.is_empty(), "the front must be open");
            continue;
        }
        assert_eq!(on.len(), 2, "wall {axis}={value}");
        let area: f64 = on.iter().map(|&i| s.triangles[i].area_m2() as f64).sum();
        assert!(
            (area - 4.0 * h * h).abs() < 1e-5,
            "wall {axis}={value}: {area} m^2"
        );
        for &i in &on {
            let t = &s.triangles[i];
            assert!(normal(t).dot(centre - centroid(t)) > 0.0, "wall faces out");
            let m = &s.materials[s.attrs[i].material as usize];
            assert_eq!(m.name, mat);
        }
    }
    let red = &s.materials[material_index(&s, "red") as usize].base_color;
    let green = &s.materials[material_index(&s, "green") as usize].base_color;
    assert!(red[0] > 5.0 * red[1] && green[1] > 2.0 * green[0]);

    // The light: one point light inside the box, above the tall block (0.33 m), under
    // the ceiling.
    assert_eq!(s.lights.len(), 1);
    let l = &s.lights[0];
    let lp = l.position.as_dvec3();
    assert!(l.spot.is_none());
    assert!(lp.x.abs() < h && lp.z.abs() < h && lp.y > 0.33 && lp.y < 2.0 * h);
    // Direct radiance at the centre of the back wall, unshadowed: albedo/pi I cos / r^2.
    let wall = DVec3::new(0.0, h, -h);
    let to_light = lp - wall;
    let r = to_light.length();
    let blocked = nearest(wall, to_light / r, s.triangles.iter().enumerate())
        .is_some_and(|(d, _)| d < r - 1e-6);
    assert!(!blocked);
    let cos = to_light.z / r;
    let radiance = 0.75 / PI * l.intensity_w_per_sr[0] as f64 * cos / (r * r);
    assert!(
        (0.2..=1.0).contains(&radiance),
        "back wall: {radiance} W/(m^2 sr)"
    );

    // The camera: in front of the opening, looking in along -z.
    let eye = s.camera.position().as_dvec3();
    assert!(eye.z > h && eye.x.abs() < h && eye.y > 0.0 && eye.y < 2.0 * h);
    let fwd = camera_ray(&s, 0.0, 0.0);
    assert!(fwd.dot(DVec3::NEG_Z) > 0.999);
    // The forward ray enters through the opening and, among the walls, meets the back
    // wall (the tall block stands in front of it); its first hit is inside the box.
    let walls = |i: &(usize, &Triangle)| s.triangles[i.0].area_m2() > 0.1;
    let (d, i) = nearest(eye, fwd, s.triangles.iter().enumerate().filter(walls)).unwrap();
    assert!((centroid(&s.triangles[i]).z + h).abs() < 1e-6, "back wall");
    assert!((eye + d * fwd).z + h < 1e-6);
    let (d, _) = nearest(eye, fwd, s.triangles.iter().enumerate()).unwrap();
    let p = eye + d * fwd;
    assert!(p.x.abs() <= h && p.z.abs() <= h + 1e-6 && p.y > 0.0 && p.y < 2.0 * h);
    // Framing: rays 95 % of the way to each edge of a square image enter the opening;
    // the opening nearly fills the frame (rays at the edges just miss it).
    for (sx, sy) in [(0.95, 0.0), (-0.95, 0.0), (0.0, 0.95), (0.0, -0.95)] {
        let d = camera_ray(&s, sx, sy);
        let at = eye + d * ((h - eye.z) / d.z);
        assert!(
            at.x.abs() < h && at.y > 0.0 && at.y < 2.0 * h,
            "({sx},{sy})"
        );
    }
    let d = camera_ray(&s, 1.0, 0.0);
    let at = eye + d * ((h - eye.z) / d.z);
    assert!(at.x > h && at.x < 1.1 * h);
}

#[test]
fn canopy_physical_setup() {
    let s = builtin::load("canopy").unwrap();
    assert!(
        s.triangles.len() < 200_000,
        "{} triangles",
        s.triangles.len()
    );
    let (ground, bark, leaf) = (
        material_index(&s, "ground"),
        material_index(&s, "bark"),
        material_index(&s, "leaves"),
    );
    let albedo = |m: u32| s.materials[m as usize].base_color[0] as f64;
    assert!((albedo(ground) - 0.3).abs() < 0.05 && (albedo(leaf) - 0.5).abs() < 0.1);
    for m in &s.materials {
        assert_eq!(
            (m.specular_factor, m.metallic, m.transmission),
            (0.0, 0.0, 0.0)
        );
        assert!(m.double_sided && !m.is_emissive());
    }
    let of = |m: u32| {
        s.triangles
            .iter()
            .zip(&s.attrs)
            .filter(move |(_, a)| a.material == m)
            .map(|(t, _)| t)
    };

    // Ground: the 40 m x 40 m patch, gently undulating, facing up.
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for t in of(ground) {
        for p in t.p {
            lo = lo.min(p.as_dvec3());
            hi = hi.max(p.as_dvec3());
        }
        assert!(normal(t).y > 0.8, "ground slope > 37 deg");
    }
    assert!((lo.x + 20.0).abs() < 1e-4 && (hi.x - 20.0).abs() < 1e-4);
    assert!((lo.z + 20.0).abs() < 1e-4 && (hi.z - 20.0).abs() < 1e-4);
    assert!(lo.y > -1.5 && hi.y < 1.5 && hi.y - lo.y > 0.5, "{lo} {hi}");
    let area: f64 = of(ground).map(|t| t.area_m2() as f64).sum();
    assert!((1600.0..1650.0).contains(&area), "ground area {area} m^2");

    // Leaves: small (quads 0.3-0.6 m: triangles 0.027-0.18 m^2), 12-20 m up, mostly
    // horizontal. Trunks exist.
    let leaves: Vec<&Triangle> = of(leaf).collect();
    assert!(leaves.len() > 5_000);
    let mut up = 0.0;
    for t in &leaves {
        let a = t.area_m2() as f64;
        assert!((0.026..0.181).contains(&a), "leaf triangle of {a} m^2");
        assert!(t.p.iter().all(|p| (10.5..21.5).contains(&p.y)));
        up += normal(t).y.abs();
    }
    assert!(
        up / leaves.len() as f64 > 0.85,
        "leaves are not mostly horizontal"
    );
    assert!(of(bark).count() >= 10 * 5);

    // The sensor: camera above everything looking straight down, the laser co-located.
    let eye = s.camera.position().as_dvec3();
    let top = s.geometry_bounds().unwrap().max.y as f64;
    assert!(eye.y > top + 50.0 && eye.x.abs() < 1.0 && eye.z.abs() < 1.0);
    let down = camera_ray(&s, 0.0, 0.0);
    assert!(down.dot(DVec3::NEG_Y) > 0.9999);
    assert_eq!(s.lights.len(), 1);
    let l = &s.lights[0];
    assert!(l.spot.is_none());
    assert!(
        (l.position.as_dvec3() - eye).length() < 1e-6,
        "laser not co-located"
    );
    // Ground radiance at nadir (single bounce, normal incidence): albedo/pi I / r^2.
    let (r, _) = nearest(eye, DVec3::NEG_Y, of(ground).enumerate()).unwrap();
    let radiance = albedo(ground) / PI * l.intensity_w_per_sr[0] as f64 / (r * r);
    assert!(
        (0.1..=1.0).contains(&radiance),
        "nadir ground {radiance} W/(m^2 sr)"
    );
    // The view covers the patch: the footprint on the ground lies inside it.
    let half_view = r * (0.5 * s.camera.fov_rad as f64).tan();
    assert!((12.0..20.0).contains(&half_view), "half view {half_view} m");

    // Coverage of the foliage layer seen from above: a grid of vertical rays over the
    // view's ground footprint, against the leaf triangles (brute force, with an xz
    // bounding-box reject).
    let boxes: Vec<(f32, f32, f32, f32)> = leaves
        .iter()
        .map(|t| {
            let xs = t.p.map(|p| p.x);
            let zs = t.p.map(|p| p.z);
            (
                xs.iter().copied().fold(f32::INFINITY, f32::min),
                xs.iter().copied().fold(f32::NEG_INFINITY, f32::max),
                zs.iter().copied().fold(f32::INFINITY, f32::min),
                zs.iter().copied().fold(f32::NEG_INFINITY, f32::max),
            )
        })
        .collect();
    let n = 120;
    let mut covered = 0;
    for j in 0..n {
        for i in 0..n {
            let x = -half_view + (i as f64 + 0.5) / n as f64 * 2.0 * half_view;
            let z = -half_view + (j as f64 + 0.5) / n as f64 * 2.0 * half_view;
            let o = DVec3::new(x, 50.0, z);
            let (xf, zf) = (x as f32, z as f32);
            let any = leaves.iter().zip(&boxes).any(|(t, b)| {
                xf >= b.0
                    && xf <= b.1
                    && zf >= b.2
                    && zf <= b.3
                    && hit(o, DVec3::NEG_Y, t).is_some()
            });
            covered += any as usize;
        }
    }
    let coverage = covered as f64 / (n * n) as f64;
    println!("canopy: foliage covers {:.3} of the view", coverage);
    assert!((0.3..=0.8).contains(&coverage), "coverage {coverage}");
}

fn asset_path(name: &str) -> PathBuf {
    PathBuf::from(crate::ROOT)
        .join("assets")
        .join(format!("{name}.gltf"))
}

/// Write (with `TPRF_WRITE_ASSETS=1`) or check `assets/NAME.gltf` against the builtin.
fn asset(name: &str) {
    let s = builtin::load(name).unwrap();
    let path = asset_path(name);
    if std::env::var("TPRF_WRITE_ASSETS").as_deref() == Ok("1") {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        gltf_save::save_gltf(&s, &path).unwrap();
    }
    assert!(
        path.exists(),
        "{} missing: run TPRF_WRITE_ASSETS=1 cargo test --release --test integration builtin_assets",
        path.display()
    );
    let doc = gltf::Gltf::open(&path).unwrap();
    let used: Vec<usize> = (0..s.materials.len() as u32)
        .filter(|m| s.attrs.iter().any(|a| a.material == *m))
        .map(|m| m as usize)
        .collect();
    assert_eq!(doc.meshes().count(), used.len(), "one mesh per material");
    assert_eq!(doc.materials().count(), s.materials.len());
    assert_eq!(
        doc.nodes().count(),
        used.len() + 1 + s.lights.len() + s.ambient.lights.len() + s.ambient.directional.len(),
        "mesh nodes, the camera, the lights (pulsed and ambient)"
    );
    assert!(
        doc.extensions_used().any(|e| e == "KHR_lights_punctual"),
        "KHR_lights_punctual not in extensionsUsed"
    );

    // Camera.
    let cam = doc.nodes().find(|n| n.camera().is_some()).expect("camera");
    let m = glam::Mat4::from_cols_array_2d(&cam.transform().matrix());
    assert!(m.abs_diff_eq(glam::Mat4::from(s.camera.world_from_camera), 1e-6));
    match cam.camera().unwrap().projection() {
        gltf::camera::Projection::Perspective(p) => {
            assert!((p.yfov() - s.camera.fov_rad).abs() < 1e-7)
        }
        _ => panic!("camera is not perspective"),
    }

    // Lights: intensity x color = the radiant intensity, W/sr.
    // The pulsed lights come first, then the ambient group's.
    let lights: Vec<gltf::Node> = doc.nodes().filter(|n| n.light().is_some()).collect();
    assert_eq!(
        lights.len(),
        s.lights.len() + s.ambient.lights.len() + s.ambient.directional.len()
    );
    for (n, l) in lights.iter().zip(&s.lights) {
        let g = n.light().unwrap();
        assert!(matches!(g.kind(), gltf::khr_lights_punctual::Kind::Point));
        let i = g.color().map(|c| c * g.intensity());
        for k in 0..3 {
            let want = l.intensity_w_per_sr[k];
            assert!((i[k] - want).abs() <= 1e-6 * want, "{i:?} vs {want}");
        }
        let (t, _, _) = n.transform().decomposed();
        assert_eq!(Vec3::from(t), l.position);
    }

    // Materials.
    for (g, m) in doc.materials().zip(&s.materials) {
        assert_eq!(g.name(), Some(m.name.as_str()));
        let pbr = g.pbr_metallic_roughness();
        assert_eq!(pbr.base_color_factor(), m.base_color);
        assert_eq!(pbr.metallic_factor(), m.metallic);
        assert_eq!(pbr.roughness_factor(), m.roughness);
        assert_eq!(
            g.specular().map_or(1.0, |x| x.specular_factor()),
            m.specular_factor
        );
        assert_eq!(g.double_sided(), m.double_sided);
        assert_eq!(g.emissive_factor(), m.emissive);
    }

    // Geometry: the same triangles, in order, with the same normals.
    let (doc, buffers, _) = gltf::import(&path).unwrap();
    let mut k = 0;
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let mat = prim.material().index().unwrap() as u32;
            let r = prim.reader(|b| Some(&buffers[b.index()]));
            let p: Vec<Vec3> = r.read_positions().unwrap().map(Vec3::from).collect();
            let nrm: Option<Vec<Vec3>> = r.read_normals().map(|n| n.map(Vec3::from).collect());
            let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
            for tri in idx.chunks(3) {
                let (t, a) = (&s.triangles[k], &s.attrs[k]);
                assert_eq!(a.material, mat, "triangle {k}");
                for c in 0..3 {
                    assert!(p[tri[c] as usize].abs_diff_eq(t.p[c], 1e-5), "triangle {k}");
                    match (&nrm, a.normals) {
                        (Some(n), Some(want)) => {
                            assert!(n[tri[c] as usize].abs_diff_eq(want[c], 1e-5))
                        }
                        (None, None) => {}
                        _ => panic!("triangle {k}: normals present on one side only"),
                    }
                }
                k += 1;
            }
        }
    }
    assert_eq!(k, s.triangles.len());

    let size = std::fs::metadata(&path).unwrap().len();
    println!("{}: {} bytes", path.display(), size);
    assert!(size < 15_000_000, "{name}.gltf is {size} bytes");
}

#[test]
fn cornell_asset() {
    asset("cornell");
}

#[test]
fn canopy_asset() {
    asset("canopy");
}

/// The saved asset, read back by tprf's own glTF loader, is the built-in scene: same
/// triangles (to f32 rounding), materials, light and camera.
fn round_trip(name: &str) {
    let built = builtin::load(name).unwrap();
    let loaded = tprf_core::scene::gltf_load::load_gltf(&asset_path(name)).unwrap();
    assert_eq!(
        loaded.triangles.len(),
        built.triangles.len(),
        "{name}: triangle count"
    );
    let scale = built.bounds().diagonal_m();
    for (a, b) in loaded.triangles.iter().zip(&built.triangles) {
        for (p, q) in a.p.iter().zip(&b.p) {
            assert!(
                (*p - *q).length() <= 1e-6 * scale,
                "{name}: vertex {p} vs {q}"
            );
        }
    }
    for (a, b) in loaded.attrs.iter().zip(&built.attrs) {
        let (ma, mb) = (
            &loaded.materials[a.material as usize],
            &built.materials[b.material as usize],
        );
        assert_eq!(ma.base_color, mb.base_color, "{name}: material {}", mb.name);
        assert_eq!(ma.specular_factor, mb.specular_factor);
        assert_eq!(ma.emissive, mb.emissive);
    }
    assert_eq!(loaded.lights.len(), built.lights.len());
    for (a, b) in loaded.lights.iter().zip(&built.lights) {
        assert!((a.position - b.position).length() <= 1e-6 * scale);
        for (x, y) in a.intensity_w_per_sr.iter().zip(&b.intensity_w_per_sr) {
            assert!((x - y).abs() <= 1e-6 * y.abs().max(1.0));
        }
    }
    assert_eq!(loaded.ambient.lights.len(), built.ambient.lights.len());
    assert_eq!(loaded.ambient.sky_radiance, built.ambient.sky_radiance);
    assert_eq!(
        loaded.ambient.directional.len(),
        built.ambient.directional.len()
    );
    for (a, b) in loaded
        .ambient
        .directional
        .iter()
        .zip(&built.ambient.directional)
    {
        assert_eq!(a.name, b.name);
        assert!(
            (a.direction - b.direction).length() < 1e-6,
            "{name}: sun direction"
        );
        for (x, y) in a.irradiance_w_per_m2.iter().zip(&b.irradiance_w_per_m2) {
            assert!((x - y).abs() <= 1e-6 * y.abs().max(1.0));
        }
    }
    assert!((loaded.camera.position() - built.camera.position()).length() <= 1e-6 * scale);
    assert!((loaded.camera.fov_rad - built.camera.fov_rad).abs() < 1e-6);
    let fwd = |s: &Scene| s.camera.world_from_camera.transform_vector3(Vec3::NEG_Z);
    assert!((fwd(&loaded) - fwd(&built)).length() < 1e-6);
}

#[test]
fn cornell_asset_loads_back_as_the_builtin() {
    round_trip("cornell");
}

#[test]
fn canopy_asset_loads_back_as_the_builtin() {
    round_trip("canopy");
}

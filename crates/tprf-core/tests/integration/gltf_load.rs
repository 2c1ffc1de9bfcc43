//! glTF import: the shared real-world scenes, small hand-written files checked against
//! hand-computed values, and broken files that must give a clear error (never a panic).

use glam::Vec3;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use tprf_core::scene::gltf_load::load_gltf;
use tprf_core::scene::{AlphaMode, Scene, SceneError};

const SCENES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/scenes");

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

fn has_note(scene: &Scene, text: &str) -> bool {
    scene.notes.iter().any(|n| n.contains(text))
}

/// Standard base64 with padding, for `data:` URIs.
fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = |i: usize| u32::from(chunk.get(i).copied().unwrap_or(0));
        let n = (b(0) << 16) | (b(1) << 8) | b(2);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ABC[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[test]
fn base64_matches_known_vectors() {
    assert_eq!(base64(b""), "");
    assert_eq!(base64(b"f"), "Zg==");
    assert_eq!(base64(b"fo"), "Zm8=");
    assert_eq!(base64(b"foo"), "Zm9v");
    assert_eq!(base64(b"foobar"), "Zm9vYmFy");
}

/// One binary buffer with its views and accessors, built up as a test needs them.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, data: &[u8]) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len()}));
        self.bytes.extend_from_slice(data);
        self.views.len() - 1
    }

    fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn vec3(&mut self, v: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let (mut min, mut max) = ([f32::MAX; 3], [f32::MIN; 3]);
        for p in v {
            for k in 0..3 {
                min[k] = min[k].min(p[k]);
                max[k] = max[k].max(p[k]);
            }
        }
        self.accessor(
            json!({"bufferView": view, "componentType": 5126, "count": v.len(),
            "type": "VEC3", "min": min, "max": max}),
        )
    }

    fn indices(&mut self, i: &[u16]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessor(
            json!({"bufferView": view, "componentType": 5123, "count": i.len(), "type": "SCALAR"}),
        )
    }

    /// Put the buffer (as a `data:` URI), views and accessors into `doc`.
    fn into_doc(self, mut doc: Value) -> Value {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64(&self.bytes)
        );
        doc["buffers"] = json!([{"byteLength": self.bytes.len(), "uri": uri}]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        doc
    }
}

/// The unit right triangle in the z = 0 plane, counter-clockwise seen from +Z, normals +Z.
const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// A mesh of one indexed triangle with normals (all `normal`), and `material` if given.
fn triangle_mesh(
    bin: &mut Bin,
    p: [[f32; 3]; 3],
    normal: [f32; 3],
    material: Option<usize>,
) -> Value {
    let pos = bin.vec3(&p);
    let nrm = bin.vec3(&[normal; 3]);
    let idx = bin.indices(&[0, 1, 2]);
    let mut prim = json!({"attributes": {"POSITION": pos, "NORMAL": nrm}, "indices": idx});
    if let Some(m) = material {
        prim["material"] = json!(m);
    }
    json!({"name": "tri", "primitives": [prim]})
}

/// Write `doc` as `NAME.gltf` in a directory of this test binary's own.
fn write_doc(name: &str, doc: &Value) -> PathBuf {
    write_file(
        &format!("{name}.gltf"),
        serde_json::to_string_pretty(doc).unwrap().as_bytes(),
    )
}

fn write_file(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("gltf_load");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// A document with `nodes` (scene 0 = node 0) and one triangle mesh.
fn doc_with_nodes(bin: Bin, meshes: Value, nodes: Value) -> Value {
    bin.into_doc(json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": nodes,
        "meshes": meshes,
    }))
}

fn load_doc(name: &str, doc: &Value) -> Scene {
    let path = write_doc(name, doc);
    load_gltf(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn load_err(name: &str, doc: &Value) -> String {
    let path = write_doc(name, doc);
    match load_gltf(&path) {
        Ok(_) => panic!("{name} loaded, expected an error"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn cornell_box_glb_loads() {
    let scene = load_gltf(Path::new(&format!("{SCENES}/cornell_box.glb"))).unwrap();
    assert!(
        scene.triangles.len() > 10,
        "{} triangles",
        scene.triangles.len()
    );
    assert_eq!(scene.triangles.len(), scene.attrs.len());
    let light = scene
        .materials
        .iter()
        .find(|m| m.is_emissive())
        .expect("an emissive material");
    // emissiveFactor [1, 0.706, 0.235] x KHR_materials_emissive_strength 17.
    assert!(
        (light.emissive[0] - 17.0).abs() < 1e-4,
        "{:?}",
        light.emissive
    );
    assert!(
        scene
            .materials
            .iter()
            .all(|m| m.double_sided && m.roughness == 0.5)
    );
    assert!(has_note(&scene, "no camera in"), "{:?}", scene.notes);
    assert!(scene.lights.is_empty(), "the emissive patch is the light");
    assert!(!has_note(&scene, "no light"));
    let b = scene.geometry_bounds().unwrap();
    assert!(b.min.is_finite() && b.max.is_finite());
    assert!(
        (1.0..10.0).contains(&b.diagonal_m()),
        "diagonal {} m",
        b.diagonal_m()
    );
    // The camera was framed from outside the box, looking at its centre.
    let to_centre = (b.center() - scene.camera.position()).normalize();
    let forward = scene
        .camera
        .world_from_camera
        .transform_vector3(Vec3::NEG_Z);
    assert!(forward.dot(to_centre) > 0.999);
}

#[test]
fn flight_helmet_loads_materials_and_textures() {
    let dir = format!("{SCENES}/FlightHelmet");
    let scene = load_gltf(Path::new(&format!("{dir}/FlightHelmet.gltf"))).unwrap();
    assert!(
        scene.triangles.len() > 10_000,
        "{} triangles",
        scene.triangles.len()
    );
    // Six glTF materials over five texture sets (HoseMat shares RubberWoodMat's textures).
    let mut names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
    names.sort();
    let expected = [
        "GlassPlasticMat",
        "HoseMat",
        "LeatherPartsMat",
        "LensesMat",
        "MetalPartsMat",
        "RubberWoodMat",
    ];
    assert_eq!(names, expected);
    // Base colour and occlusion-roughness-metallic of five sets; normal maps not decoded.
    assert_eq!(scene.textures.len(), 10);
    for m in &scene.materials {
        let set = if m.name == "HoseMat" {
            "RubberWoodMat"
        } else {
            m.name.as_str()
        };
        let pairs = [
            (m.base_color_texture, "BaseColor"),
            (m.metallic_roughness_texture, "OcclusionRoughMetal"),
        ];
        for (tex, kind) in pairs {
            let tex = &scene.textures[tex.expect("textured").texture as usize];
            let png = format!("{dir}/FlightHelmet_Materials_{set}_{kind}.png");
            let reference = image::open(&png).unwrap().to_rgba8();
            assert_eq!((tex.width, tex.height), reference.dimensions(), "{png}");
            assert_eq!(tex.rgba8.len(), (tex.width * tex.height) as usize);
            let texel = 1000 % tex.rgba8.len();
            let (x, y) = (texel as u32 % tex.width, texel as u32 / tex.width);
            assert_eq!(tex.rgba8[texel], reference.get_pixel(x, y).0, "{png}");
        }
    }
    let lenses = scene
        .materials
        .iter()
        .find(|m| m.name == "LensesMat")
        .unwrap();
    assert_eq!(lenses.alpha_mode, AlphaMode::Blend);
    assert!(has_note(&scene, "normal maps ignored"), "{:?}", scene.notes);
    assert!(has_note(&scene, "no camera in"));
    assert!(has_note(&scene, "no light in"));
    assert_eq!(scene.lights.len(), 1);
    assert_eq!(scene.lights[0].position, scene.camera.position());
}

#[test]
fn node_transforms_compose_down_the_hierarchy() {
    let mut bin = Bin::default();
    let n = std::f32::consts::FRAC_1_SQRT_2;
    let mesh = triangle_mesh(&mut bin, TRI, [n, n, 0.0], None);
    let s = std::f32::consts::FRAC_PI_4.sin();
    let nodes = json!([
        // Parent: 90 degrees about +Z, then up by 5.
        {"children": [1], "rotation": [0.0, 0.0, s, s], "translation": [0.0, 0.0, 5.0]},
        // Child: scale x by 2, then move along x by 1.
        {"mesh": 0, "translation": [1.0, 0.0, 0.0], "scale": [2.0, 1.0, 1.0]},
    ]);
    let scene = load_doc("transforms", &doc_with_nodes(bin, json!([mesh]), nodes));
    assert_eq!(scene.triangles.len(), 1);
    // Child: (x, y, z) -> (2x + 1, y, z); parent: (x, y, z) -> (-y, x, z + 5).
    let p = scene.triangles[0].p;
    assert!(close(p[0], Vec3::new(0.0, 1.0, 5.0)), "{p:?}");
    assert!(close(p[1], Vec3::new(0.0, 3.0, 5.0)), "{p:?}");
    assert!(close(p[2], Vec3::new(-1.0, 1.0, 5.0)), "{p:?}");
    // Normal (1, 1, 0): inverse-transpose of the child's scale gives (0.5, 1, 0), the parent
    // rotates it to (-1, 0.5, 0); renormalised.
    let expected = Vec3::new(-1.0, 0.5, 0.0).normalize();
    let normals = scene.attrs[0].normals.expect("normals");
    assert!(normals.iter().all(|&n| close(n, expected)), "{normals:?}");
}

#[test]
fn negative_scale_keeps_the_front_face() {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
    let nodes = json!([{"mesh": 0, "scale": [-1.0, 1.0, 1.0]}]);
    let scene = load_doc("mirror", &doc_with_nodes(bin, json!([mesh]), nodes));
    let [p0, p1, p2] = scene.triangles[0].p;
    // Mirrored vertices (0,0,0), (-1,0,0), (0,1,0): seen from +Z they run clockwise, so the
    // loader reverses them to keep the front face (+Z, like the normals) counter-clockwise.
    let geometric = (p1 - p0).cross(p2 - p0).normalize();
    assert!(close(geometric, Vec3::Z), "{geometric}");
    let normals = scene.attrs[0].normals.unwrap();
    assert!(normals.iter().all(|&n| close(n, Vec3::Z)), "{normals:?}");
    let mut xs: Vec<f32> = [p0, p1, p2].iter().map(|p| p.x).collect();
    xs.sort_by(f32::total_cmp);
    assert_eq!(xs, [-1.0, 0.0, 0.0]);
}

#[test]
fn strips_fans_and_non_indexed_primitives() {
    let mut bin = Bin::default();
    // A unit square as a non-indexed strip and as an indexed fan: two triangles each, all
    // facing +Z (counter-clockwise).
    let quad = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    let strip_pos = bin.vec3(&quad);
    let fan_pos = bin.vec3(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ]);
    let fan_idx = bin.indices(&[0, 1, 2, 3]);
    let points = bin.vec3(&quad);
    let mesh = json!({"primitives": [
        {"attributes": {"POSITION": strip_pos}, "mode": 5},
        {"attributes": {"POSITION": fan_pos}, "indices": fan_idx, "mode": 6},
        {"attributes": {"POSITION": points}, "mode": 0},
    ]});
    let scene = load_doc(
        "strips",
        &doc_with_nodes(bin, json!([mesh]), json!([{"mesh": 0}])),
    );
    assert_eq!(scene.triangles.len(), 4);
    for t in &scene.triangles {
        let n = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
        assert!(close(n, Vec3::Z), "{t:?}");
        assert!(t.area_m2() == 0.5);
    }
    assert!(
        has_note(&scene, "Points primitives skipped"),
        "{:?}",
        scene.notes
    );
    assert!(scene.attrs.iter().all(|a| a.normals.is_none()));
}

#[test]
fn camera_yfov_and_position_from_its_node() {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
    let s = std::f32::consts::FRAC_PI_4.sin();
    let nodes = json!([
        {"children": [1, 2]},
        {"mesh": 0},
        // 90 degrees about +Y: the camera's -Z (forward) turns to -X. Its scale is dropped.
        {"camera": 0, "translation": [4.0, 0.5, 0.0], "rotation": [0.0, s, 0.0, s], "scale": [3.0, 3.0, 3.0]},
    ]);
    let mut doc = doc_with_nodes(bin, json!([mesh]), nodes);
    doc["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01}}]);
    let scene = load_doc("camera", &doc);
    assert_eq!(scene.camera.fov_rad, 0.7);
    assert!(close(scene.camera.position(), Vec3::new(4.0, 0.5, 0.0)));
    let w = scene.camera.world_from_camera;
    assert!(close(w.transform_vector3(Vec3::NEG_Z), Vec3::NEG_X));
    assert!(close(w.transform_vector3(Vec3::Y), Vec3::Y));
    assert!(!has_note(&scene, "no camera"));
}

#[test]
fn orthographic_camera_is_noted_and_replaced() {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
    let nodes = json!([{"children": [1]}, {"camera": 0, "mesh": 0}]);
    let mut doc = doc_with_nodes(bin, json!([mesh]), nodes);
    let ortho = json!({"xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0});
    doc["cameras"] = json!([{"type": "orthographic", "orthographic": ortho}]);
    let scene = load_doc("ortho", &doc);
    assert!(has_note(&scene, "is orthographic"), "{:?}", scene.notes);
    assert_eq!(scene.camera.fov_rad, std::f32::consts::FRAC_PI_4);
}

#[test]
fn point_and_spot_lights_in_w_per_sr() {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
    let s = std::f32::consts::FRAC_PI_4.sin();
    let light = |i: usize| json!({"KHR_lights_punctual": {"light": i}});
    let nodes = json!([
        {"children": [1, 2, 3, 4], "translation": [0.0, 1.0, 0.0]},
        {"mesh": 0},
        {"extensions": light(0), "translation": [1.0, 2.0, 3.0]},
        // -90 degrees about +X: the light's -Z turns to -Y (pointing down).
        {"extensions": light(1), "translation": [0.0, 4.0, 0.0], "rotation": [-s, 0.0, 0.0, s]},
        {"extensions": light(2)},
    ]);
    let mut doc = doc_with_nodes(bin, json!([mesh]), nodes);
    doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"name": "bulb", "type": "point", "color": [1.0, 0.5, 0.25], "intensity": 10.0},
        {"name": "cone", "type": "spot", "intensity": 3.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
        {"name": "sun", "type": "directional", "intensity": 100.0},
    ]}});
    let scene = load_doc("lights", &doc);
    assert_eq!(scene.lights.len(), 2);
    let bulb = &scene.lights[0];
    assert_eq!(bulb.name, "bulb");
    assert!(close(bulb.position, Vec3::new(1.0, 3.0, 3.0)));
    assert_eq!(bulb.intensity_w_per_sr, [10.0, 5.0, 2.5]);
    assert!(bulb.spot.is_none());
    let cone = &scene.lights[1];
    assert!(close(cone.position, Vec3::new(0.0, 5.0, 0.0)));
    assert_eq!(cone.intensity_w_per_sr, [3.0; 3]);
    let spot = cone.spot.unwrap();
    assert!(close(spot.direction, Vec3::NEG_Y), "{}", spot.direction);
    assert_eq!((spot.inner_cone_rad, spot.outer_cone_rad), (0.2, 0.5));
    // The directional light is the ambient group's sun (node 4: no rotation, along -Z).
    assert_eq!(scene.ambient.directional.len(), 1);
    let sun = &scene.ambient.directional[0];
    assert_eq!(sun.name, "sun");
    assert_eq!(sun.irradiance_w_per_m2, [100.0; 3]);
    assert!(close(sun.direction, Vec3::NEG_Z), "{}", sun.direction);
    assert!(!has_note(&scene, "no light"));
}

/// A point light tagged `{"tprf": {"ambient": true}}` and a sun go to the ambient group,
/// the scene's sky is read from its extras, and all of it survives a glTF export.
#[test]
fn ambient_group_from_extras_and_back() {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
    let s = std::f32::consts::FRAC_PI_4.sin();
    let light = |i: usize| json!({"KHR_lights_punctual": {"light": i}});
    let nodes = json!([
        {"children": [1, 2, 3, 4]},
        {"mesh": 0},
        {"extensions": light(0), "translation": [0.0, 0.0, 2.0]},
        {"extensions": light(1), "translation": [1.0, 1.0, 2.0], "extras": {"tprf": {"ambient": true}}},
        // -90 degrees about +X: the sun's -Z turns to -Y (straight down).
        {"extensions": light(2), "rotation": [-s, 0.0, 0.0, s]},
    ]);
    let mut doc = doc_with_nodes(bin, json!([mesh]), nodes);
    doc["scenes"][0]["extras"] = json!({"tprf": {"sky_radiance": [0.5, 0.25, 1.0]}});
    doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"name": "laser", "type": "point", "intensity": 10.0},
        {"name": "lamp", "type": "point", "intensity": 2.0},
        {"name": "sun", "type": "directional", "intensity": 800.0, "color": [1.0, 0.5, 0.5]},
    ]}});
    let scene = load_doc("ambient_group", &doc);
    assert_eq!(scene.lights.len(), 1);
    assert_eq!(scene.lights[0].name, "laser");
    assert_eq!(scene.ambient.lights.len(), 1);
    assert_eq!(scene.ambient.lights[0].name, "lamp");
    assert!(close(
        scene.ambient.lights[0].position,
        Vec3::new(1.0, 1.0, 2.0)
    ));
    let sun = &scene.ambient.directional[0];
    assert_eq!(sun.irradiance_w_per_m2, [800.0, 400.0, 400.0]);
    assert!(close(sun.direction, Vec3::NEG_Y), "{}", sun.direction);
    assert_eq!(scene.ambient.sky_radiance, [0.5, 0.25, 1.0]);

    let path = write_file("ambient_group_saved.gltf", b"");
    tprf_core::scene::gltf_save::save_gltf(&scene, &path).unwrap();
    let back = load_gltf(&path).unwrap();
    assert_eq!(back.lights.len(), 1);
    assert_eq!(back.ambient.lights.len(), 1);
    assert_eq!(back.ambient.lights[0].intensity_w_per_sr, [2.0; 3]);
    assert_eq!(back.ambient.sky_radiance, scene.ambient.sky_radiance);
    let b = &back.ambient.directional[0];
    assert_eq!(b.irradiance_w_per_m2, [800.0, 400.0, 400.0]);
    assert!(close(b.direction, Vec3::NEG_Y), "{}", b.direction);
}

/// Bad ambient input is refused with a message naming the field, never a panic.
#[test]
fn bad_ambient_input_is_refused_by_name() {
    let base = || {
        let mut bin = Bin::default();
        let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
        let nodes = json!([
            {"children": [1, 2]},
            {"mesh": 0},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}},
        ]);
        let mut doc = doc_with_nodes(bin, json!([mesh]), nodes);
        doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
            {"name": "sun", "type": "directional", "intensity": 1.0},
        ]}});
        doc
    };
    let mut doc = base();
    doc["scenes"][0]["extras"] = json!({"tprf": {"sky_radiance": -1.0}});
    let e = load_err("negative_sky", &doc);
    assert!(e.contains("sky_radiance"), "{e}");
    let mut doc = base();
    doc["scenes"][0]["extras"] = json!({"tprf": {"sky_radiance": "bright"}});
    assert!(load_err("string_sky", &doc).contains("sky_radiance"));
    let mut doc = base();
    doc["nodes"][2]["scale"] = json!([0.0, 0.0, 0.0]);
    let e = load_err("zero_direction", &doc);
    assert!(e.contains("directional light 'sun'"), "{e}");
    let mut doc = base();
    doc["nodes"][2]["extras"] = json!({"tprf": {"ambient": "yes"}});
    let e = load_err("ambient_not_bool", &doc);
    assert!(e.contains("tprf.ambient"), "{e}");
    let mut doc = base();
    doc["extensions"]["KHR_lights_punctual"]["lights"][0]["color"] = json!([-1.0, 1.0, 1.0]);
    let e = load_err("negative_sun", &doc);
    assert!(e.contains("irradiance_w_per_m2"), "{e}");
}

#[test]
fn material_factors_and_extensions() {
    let mut bin = Bin::default();
    let pos = bin.vec3(&TRI);
    let idx = bin.indices(&[0, 1, 2]);
    let prim = |m: Option<usize>| match m {
        Some(m) => json!({"attributes": {"POSITION": pos}, "indices": idx, "material": m}),
        None => json!({"attributes": {"POSITION": pos}, "indices": idx}),
    };
    let prims: Vec<Value> = (0..7).map(Some).chain([None, None]).map(prim).collect();
    let materials = json!([
        {"name": "lambert", "extensions": {"KHR_materials_specular": {"specularFactor": 0.0, "specularColorFactor": [0.5, 0.6, 0.7]}}},
        {"name": "glass", "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.9}, "KHR_materials_ior": {"ior": 1.33}}},
        {"name": "cutout", "alphaMode": "MASK", "alphaCutoff": 0.3},
        {"name": "cutout-default", "alphaMode": "MASK"},
        {"name": "blend", "alphaMode": "BLEND"},
        {"name": "lamp", "emissiveFactor": [1.0, 0.5, 0.0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10.0}}},
        {"name": "plain", "pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.2, 0.3, 0.4], "metallicFactor": 0.25, "roughnessFactor": 0.75}, "doubleSided": true},
    ]);
    let mut doc = doc_with_nodes(bin, json!([{"primitives": prims}]), json!([{"mesh": 0}]));
    doc["materials"] = materials;
    let used = [
        "KHR_materials_specular",
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_emissive_strength",
    ];
    doc["extensionsUsed"] = json!(used);
    // Required, and supported by tprf (the gltf crate alone would refuse the specular one).
    doc["extensionsRequired"] = json!(["KHR_materials_specular", "KHR_materials_transmission"]);
    let scene = load_doc("materials", &doc);
    assert_eq!(scene.triangles.len(), 9);
    // Seven file materials and the default one, added once for the two primitives without.
    assert_eq!(scene.materials.len(), 8);
    let m = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap();
    assert_eq!(
        (m("lambert").specular_factor, m("lambert").specular_color),
        (0.0, [0.5, 0.6, 0.7])
    );
    assert_eq!((m("glass").transmission, m("glass").ior), (0.9, 1.33));
    assert_eq!(m("cutout").alpha_mode, AlphaMode::Mask { cutoff: 0.3 });
    assert_eq!(
        m("cutout-default").alpha_mode,
        AlphaMode::Mask { cutoff: 0.5 }
    );
    assert_eq!(m("blend").alpha_mode, AlphaMode::Blend);
    assert_eq!(m("lamp").emissive, [10.0, 5.0, 0.0]);
    let plain = m("plain");
    assert_eq!(plain.base_color, [0.1, 0.2, 0.3, 0.4]);
    assert_eq!((plain.metallic, plain.roughness), (0.25, 0.75));
    // Without the extensions: specular 1 (white), ior 1.5, no transmission, opaque.
    assert_eq!(
        (plain.specular_factor, plain.specular_color),
        (1.0, [1.0; 3])
    );
    assert_eq!((plain.ior, plain.transmission), (1.5, 0.0));
    assert_eq!(plain.alpha_mode, AlphaMode::Opaque);
    assert!(plain.double_sided && !m("lamp").double_sided);
    assert!(plain.base_color_texture.is_none() && !plain.is_emissive());
    assert_eq!(m("default"), &tprf_core::scene::Material::default());
    // The lamp lights the scene: no co-located light added.
    assert!(scene.lights.is_empty() && !has_note(&scene, "no light"));
}

#[test]
fn degenerate_triangles_are_dropped_and_counted() {
    let mut bin = Bin::default();
    let p = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [2.0, 0.0, 0.0],
    ];
    let pos = bin.vec3(&p);
    // A good triangle, one with a repeated vertex, one with collinear vertices.
    let idx = bin.indices(&[0, 1, 2, 0, 1, 1, 0, 1, 3]);
    let mesh = json!({"primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]});
    let scene = load_doc(
        "degenerate",
        &doc_with_nodes(bin, json!([mesh]), json!([{"mesh": 0}])),
    );
    assert_eq!(scene.triangles.len(), 1);
    assert!(
        has_note(&scene, "dropped 2 degenerate triangles"),
        "{:?}",
        scene.notes
    );
}

#[test]
fn zero_normals_fall_back_to_the_geometric_normal() {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 0.0], None);
    let scene = load_doc(
        "zero-normals",
        &doc_with_nodes(bin, json!([mesh]), json!([{"mesh": 0}])),
    );
    assert_eq!(scene.attrs[0].normals, None);
    assert!(
        has_note(&scene, "1 triangles have zero or non-finite vertex normals"),
        "{:?}",
        scene.notes
    );
}

#[test]
fn no_camera_and_no_light_get_a_framed_camera_and_a_colocated_light() {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
    let path = write_doc(
        "bare",
        &doc_with_nodes(bin, json!([mesh]), json!([{"mesh": 0}])),
    );
    let scene = load_gltf(&path).unwrap();
    assert_eq!(scene.name, path.display().to_string());
    let file = path.display();
    assert!(scene.notes.contains(&format!(
        "no camera in {file}: framed one from the scene bounds"
    )));
    assert!(has_note(
        &scene,
        &format!("no light in {file}: added a point light at the camera")
    ));
    assert_eq!(scene.lights.len(), 1);
    let light = &scene.lights[0];
    assert_eq!(light.position, scene.camera.position());
    // I = pi d^2, d the distance from the camera to the bounds' centre (0.5, 0.5, 0).
    let d = light.position.distance(Vec3::new(0.5, 0.5, 0.0));
    let expected = std::f32::consts::PI * d * d;
    assert!((light.intensity_w_per_sr[0] - expected).abs() < 1e-4 * expected);
}

#[test]
fn no_scene_loads_every_root_node() {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
    let nodes = json!([{"mesh": 0, "children": [1]}, {"mesh": 0}, {"mesh": 0}]);
    let doc = bin.into_doc(json!({"asset": {"version": "2.0"}, "nodes": nodes, "meshes": [mesh]}));
    let scene = load_doc("no-scene", &doc);
    assert_eq!(scene.triangles.len(), 3);
    assert!(has_note(&scene, "no scene in"), "{:?}", scene.notes);
}

#[test]
fn sparse_positions() {
    let mut bin = Bin::default();
    let nrm = bin.vec3(&[[0.0, 0.0, 1.0]; 3]);
    // All-zero base positions; the sparse part sets vertices 1 and 2.
    let sparse_idx = bin.view(&[1, 0, 2, 0]);
    let values: Vec<u8> = [1.0f32, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let sparse_val = bin.view(&values);
    let pos = bin.accessor(json!({"componentType": 5126, "count": 3, "type": "VEC3",
        "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0],
        "sparse": {"count": 2, "indices": {"bufferView": sparse_idx, "componentType": 5123},
                   "values": {"bufferView": sparse_val}}}));
    let mesh = json!({"primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm}}]});
    let scene = load_doc(
        "sparse",
        &doc_with_nodes(bin, json!([mesh]), json!([{"mesh": 0}])),
    );
    let expected = TRI.map(Vec3::from);
    assert_eq!(scene.triangles[0].p, expected);
}

/// A 2 x 1 PNG of `image`.
fn png(image: image::DynamicImage) -> Vec<u8> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    image.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
    bytes.into_inner()
}

/// A document whose primitive `i` uses material `i`, textured with image `i`.
fn textured_doc(bin: &mut Bin, images: Value) -> Value {
    let n = images.as_array().unwrap().len();
    let pos = bin.vec3(&TRI);
    let prims: Vec<Value> = (0..n)
        .map(|i| json!({"attributes": {"POSITION": pos}, "material": i}))
        .collect();
    let materials: Vec<Value> = (0..n)
        .map(|i| json!({"name": format!("m{i}"), "pbrMetallicRoughness": {"baseColorTexture": {"index": i}}}))
        .collect();
    let textures: Vec<Value> = (0..n).map(|i| json!({"source": i})).collect();
    json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": prims}],
        "materials": materials, "textures": textures, "images": images,
    })
}

#[test]
fn every_pixel_format_becomes_rgba8() {
    use image::{DynamicImage as D, ImageBuffer as B};
    let images = [
        D::ImageLuma8(B::from_raw(2, 1, vec![0, 200]).unwrap()),
        D::ImageLumaA8(B::from_raw(2, 1, vec![10, 20, 30, 40]).unwrap()),
        D::ImageRgb8(B::from_raw(2, 1, vec![1, 2, 3, 4, 5, 6]).unwrap()),
        D::ImageRgba8(B::from_raw(2, 1, vec![1, 2, 3, 4, 5, 6, 7, 8]).unwrap()),
        D::ImageLuma16(B::from_raw(2, 1, vec![0, 65535]).unwrap()),
        D::ImageRgba16(
            B::from_raw(2, 1, vec![257 * 100, 0, 65535, 65535, 0, 257, 514, 0]).unwrap(),
        ),
    ];
    let expected: [[[u8; 4]; 2]; 6] = [
        [[0, 0, 0, 255], [200, 200, 200, 255]],
        [[10, 10, 10, 20], [30, 30, 30, 40]],
        [[1, 2, 3, 255], [4, 5, 6, 255]],
        [[1, 2, 3, 4], [5, 6, 7, 8]],
        [[0, 0, 0, 255], [255, 255, 255, 255]],
        [[100, 0, 255, 255], [0, 1, 2, 0]],
    ];
    let uris: Vec<Value> = images
        .into_iter()
        .map(|i| json!({"uri": format!("data:image/png;base64,{}", base64(&png(i)))}))
        .collect();
    let mut bin = Bin::default();
    let doc = textured_doc(&mut bin, json!(uris));
    let scene = load_doc("pixel-formats", &bin.into_doc(doc));
    for (i, want) in expected.iter().enumerate() {
        let m = scene
            .materials
            .iter()
            .find(|m| m.name == format!("m{i}"))
            .unwrap();
        let tex = &scene.textures[m.base_color_texture.unwrap().texture as usize];
        assert_eq!((tex.width, tex.height), (2, 1));
        assert_eq!(tex.rgba8, want.to_vec(), "image {i}");
    }
}

/// A .glb of `doc` with `bin` as its BIN chunk.
fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap();
    json.resize(json.len().div_ceil(4) * 4, b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().div_ceil(4) * 4, 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    for word in [0x4654_6C67, 2, total as u32, json.len() as u32, 0x4E4F_534A] {
        out.extend_from_slice(&u32::to_le_bytes(word));
    }
    out.extend_from_slice(&json);
    out.extend_from_slice(&u32::to_le_bytes(bin.len() as u32));
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

#[test]
fn glb_with_an_image_in_a_buffer_view() {
    let mut bin = Bin::default();
    let rgb = image::DynamicImage::ImageRgb8(
        image::ImageBuffer::from_raw(2, 1, vec![9, 8, 7, 6, 5, 4]).unwrap(),
    );
    let view = bin.view(&png(rgb));
    let mut doc = textured_doc(
        &mut bin,
        json!([{"bufferView": view, "mimeType": "image/png"}]),
    );
    doc["buffers"] = json!([{"byteLength": bin.bytes.len()}]);
    doc["bufferViews"] = json!(bin.views);
    doc["accessors"] = json!(bin.accessors);
    let bytes = glb(&doc, &bin.bytes);
    let scene = load_gltf(&write_file("embedded.glb", &bytes)).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert_eq!(
        scene.textures[0].rgba8,
        vec![[9, 8, 7, 255], [6, 5, 4, 255]]
    );
    // The same file cut inside its BIN chunk.
    let path = write_file("embedded-cut.glb", &bytes[..bytes.len() - 8]);
    let err = load_gltf(&path).unwrap_err().to_string();
    assert!(err.contains("truncated .glb"), "{err}");
}

// ---- bad files: an error that names the problem, never a panic ----

/// A valid one-triangle document to break in various ways.
fn good_doc() -> Value {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
    doc_with_nodes(bin, json!([mesh]), json!([{"mesh": 0}]))
}

#[test]
fn missing_file() {
    let err = load_gltf(Path::new("/nonexistent/dir/scene.gltf")).unwrap_err();
    assert!(matches!(err, SceneError::Io { .. }));
    assert!(
        err.to_string().contains("/nonexistent/dir/scene.gltf"),
        "{err}"
    );
}

#[test]
fn missing_bin_names_the_uri() {
    let mut doc = good_doc();
    doc["buffers"][0]["uri"] = json!("missing-buffer.bin");
    let err = load_err("missing-bin", &doc);
    assert!(
        err.contains("missing-buffer.bin") && err.contains("buffer 0"),
        "{err}"
    );
    assert!(err.contains("No such file"), "{err}");
}

#[test]
fn missing_image_names_the_uri() {
    let mut doc = good_doc();
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["images"] = json!([{"uri": "no-such-texture.png"}]);
    let err = load_err("missing-image", &doc);
    assert!(
        err.contains("no-such-texture.png") && err.contains("images[0]"),
        "{err}"
    );
}

#[test]
fn short_buffer_is_refused() {
    let mut doc = good_doc();
    doc["buffers"][0]["byteLength"] = json!(100_000);
    let err = load_err("short-buffer", &doc);
    assert!(err.contains("the file declares 100000"), "{err}");
}

#[test]
fn index_out_of_range() {
    let mut bin = Bin::default();
    let pos = bin.vec3(&TRI);
    let idx = bin.indices(&[0, 1, 7]);
    let mesh =
        json!({"name": "bad", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]});
    let err = load_err(
        "index-range",
        &doc_with_nodes(bin, json!([mesh]), json!([{"mesh": 0}])),
    );
    assert!(err.contains("vertex index 7 is out of range"), "{err}");
    assert!(err.contains("mesh 'bad' (meshes[0]) primitive 0"), "{err}");
}

#[test]
fn nan_position_names_mesh_and_primitive() {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(
        &mut bin,
        [[0.0; 3], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]],
        [0.0, 0.0, 1.0],
        None,
    );
    let err = load_err(
        "nan",
        &doc_with_nodes(bin, json!([mesh]), json!([{"mesh": 0}])),
    );
    assert!(
        err.contains("mesh 'tri' (meshes[0]) primitive 0: POSITION 1 is not finite"),
        "{err}"
    );
}

#[test]
fn unsupported_required_extension() {
    let mut doc = good_doc();
    doc["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    doc["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    let path = write_doc("draco", &doc);
    let err = load_gltf(&path).unwrap_err();
    assert!(
        matches!(&err, SceneError::UnsupportedExtension { extension, .. } if extension == "KHR_draco_mesh_compression")
    );
    assert!(
        err.to_string()
            .contains("requires extension KHR_draco_mesh_compression"),
        "{err}"
    );
}

#[test]
fn used_but_unsupported_extensions_are_noted() {
    let mut doc = good_doc();
    doc["extensionsUsed"] = json!(["KHR_texture_transform", "KHR_materials_clearcoat"]);
    let scene = load_doc("ignored-ext", &doc);
    assert!(
        has_note(
            &scene,
            "uses extensions tprf ignores: KHR_texture_transform, KHR_materials_clearcoat"
        ),
        "{:?}",
        scene.notes
    );
}

#[test]
fn truncated_glb() {
    let bytes = std::fs::read(format!("{SCENES}/cornell_box.glb")).unwrap();
    for len in [bytes.len() / 2, 30, 16, 10] {
        let path = write_file(&format!("truncated-{len}.glb"), &bytes[..len]);
        let err = load_gltf(&path).unwrap_err().to_string();
        assert!(
            err.contains("truncated .glb") || err.contains("corrupt .glb"),
            "{len} bytes: {err}"
        );
    }
    let path = write_file("truncated-half.glb", &bytes[..bytes.len() / 2]);
    let err = load_gltf(&path).unwrap_err().to_string();
    assert!(err.contains("truncated .glb"), "{err}");
}

#[test]
fn garbage_bytes() {
    let bytes: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    let err = load_gltf(&write_file("garbage.gltf", &bytes))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("not a valid glTF 2.0 file: invalid glTF JSON"),
        "{err}"
    );
    let err = load_gltf(&write_file("not-gltf.gltf", b"{\"hello\": 1}"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("it has no asset object"), "{err}");
}

#[test]
fn gltf_1_0_and_garbled_versions_are_refused_by_asset_version() {
    // A glTF 1.0 file as the 1.0 specification writes it: objects are maps by id. Before,
    // it was read as 2.0 and failed later with "no light reaches the camera".
    let gltf_1 = json!({
        "asset": {"version": "1.0"},
        "scene": "defaultScene",
        "scenes": {"defaultScene": {"nodes": ["node_1"]}},
        "nodes": {"node_1": {"meshes": ["mesh_1"]}},
        "meshes": {"mesh_1": {"primitives": [{"attributes": {"POSITION": "acc_0"}}]}},
    });
    let err = load_err("gltf-1.0", &gltf_1);
    assert!(
        err.contains("it is glTF 1.0 (asset.version \"1.0\")") && err.contains("reads glTF 2.0"),
        "{err}"
    );
    // A document that would otherwise load as 2.0 is refused all the same.
    let with_version = |asset: Value| {
        let mut doc = good_doc();
        doc["asset"] = asset;
        doc
    };
    let refused = [
        (json!({"version": "1.0"}), "it is glTF 1.0"),
        (json!({"version": "1.0.1"}), "it is glTF 1.0.1"),
        (
            json!({"version": 2.0}),
            "asset.version is 2.0, not a string",
        ),
        (
            json!({"version": "two"}),
            "asset.version \"two\" is not a glTF version",
        ),
        (
            json!({"version": "2."}),
            "asset.version \"2.\" is not a glTF version",
        ),
        (json!({"generator": "x"}), "asset has no version"),
        (json!("2.0"), "asset is \"2.0\", not an object"),
        (
            json!({"version": "3.0"}),
            "it is glTF 3.0 (asset.version), and states no",
        ),
        (
            json!({"version": "2.1", "minVersion": "2.1"}),
            "it needs a glTF 2.1 reader",
        ),
        (
            json!({"version": "2.0", "minVersion": "2"}),
            "asset.minVersion \"2\" is not a glTF version",
        ),
    ];
    for (i, (asset, expected)) in refused.into_iter().enumerate() {
        let err = load_err(&format!("version-{i}"), &with_version(asset));
        assert!(err.contains(expected), "expected '{expected}': {err}");
    }
    let mut no_asset = good_doc();
    no_asset.as_object_mut().unwrap().remove("asset");
    let err = load_err("version-none", &no_asset);
    assert!(err.contains("it has no asset object"), "{err}");
    // What a 2.0 reader may load: a later minor version, a later major one that allows
    // 2.0 readers by its minVersion.
    for (i, asset) in [
        json!({"version": "2.0", "minVersion": "2.0"}),
        json!({"version": "2.1"}),
        json!({"version": "3.0", "minVersion": "2.0"}),
    ]
    .into_iter()
    .enumerate()
    {
        let scene = load_doc(&format!("version-ok-{i}"), &with_version(asset));
        assert_eq!(scene.triangles.len(), 1);
    }
}

/// The .glb of [`good_doc`]'s triangle (its buffer as the BIN chunk), loadable as it is.
fn good_glb() -> Vec<u8> {
    let mut bin = Bin::default();
    let mesh = triangle_mesh(&mut bin, TRI, [0.0, 0.0, 1.0], None);
    let bytes = bin.bytes.clone();
    let mut doc = doc_with_nodes(bin, json!([mesh]), json!([{"mesh": 0}]));
    doc["buffers"] = json!([{"byteLength": bytes.len()}]);
    glb(&doc, &bytes)
}

#[test]
fn glb_headers_that_contradict_the_file_are_refused() {
    let good = good_glb();
    let scene = load_gltf(&write_file("good.glb", &good)).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    let set_u32 = |bytes: &mut Vec<u8>, at: usize, v: u32| {
        bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
    };
    let n = good.len() as u32;
    let json_len = u32::from_le_bytes(good[12..16].try_into().unwrap());
    let bin_at = 20 + json_len as usize;
    let cases: Vec<(&str, Vec<u8>, String)> = vec![
        (
            // The case: the header says the file is shorter than it is.
            "header-smaller",
            {
                let mut b = good.clone();
                set_u32(&mut b, 8, n - 8);
                b
            },
            format!(
                "corrupt .glb: its header announces {} bytes, but the file has {n}",
                n - 8
            ),
        ),
        (
            "bytes-appended",
            {
                let mut b = good.clone();
                b.extend([0; 16]);
                b
            },
            format!(
                "announces {n} bytes, but the file has {}: 16 bytes after",
                n + 16
            ),
        ),
        (
            "header-larger",
            {
                let mut b = good.clone();
                set_u32(&mut b, 8, n + 4);
                b
            },
            format!(
                "truncated .glb: its header announces {} bytes, the file has {n}",
                n + 4
            ),
        ),
        (
            "json-unaligned",
            {
                // JSON one byte shorter, the chunk one byte longer than the file's bytes
                // would allow: the BIN chunk header then starts off its 4-byte boundary.
                let mut b = good.clone();
                set_u32(&mut b, 12, json_len - 1);
                b.remove(20 + json_len as usize - 1);
                set_u32(&mut b, 8, n - 1);
                b
            },
            format!(
                "its JSON chunk (chunk 0, at byte 12) is {} bytes long, not a multiple of 4",
                json_len - 1
            ),
        ),
        (
            "bin-overruns",
            {
                let mut b = good.clone();
                let bin_len = u32::from_le_bytes(b[bin_at..bin_at + 4].try_into().unwrap());
                set_u32(&mut b, bin_at, bin_len + 4);
                b
            },
            "truncated .glb: its BIN chunk (chunk 1".into(),
        ),
        (
            "bin-first",
            {
                let mut b = good.clone();
                b[16..20].copy_from_slice(b"BIN\0");
                b
            },
            "its first chunk is BIN, not JSON".into(),
        ),
        (
            "glb-version-1",
            {
                let mut b = good.clone();
                set_u32(&mut b, 4, 1);
                b
            },
            "glTF 1.0 binary".into(),
        ),
    ];
    for (name, bytes, expected) in cases {
        let err = load_gltf(&write_file(&format!("{name}.glb"), &bytes))
            .map(|_| "loaded".to_string())
            .unwrap_or_else(|e| e.to_string());
        assert!(
            err.contains(&expected),
            "{name}: expected '{expected}': {err}"
        );
    }
    // A chunk of a type tprf does not know is skipped, as the specification asks, and
    // noted.
    let mut extra = good.clone();
    extra.extend(8u32.to_le_bytes());
    extra.extend(b"XTRA");
    extra.extend([7; 8]);
    let total = extra.len() as u32;
    set_u32(&mut extra, 8, total);
    let scene = load_gltf(&write_file("extra-chunk.glb", &extra)).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert!(
        has_note(
            &scene,
            "skipped .glb chunk 2 of unknown type 0x41525458 (8 bytes)"
        ),
        "{:?}",
        scene.notes
    );
}

/// A name, an edit that breaks a good document, and a piece of the expected message.
type BrokenCase = (&'static str, fn(&mut Value), &'static str);

#[test]
fn malformed_structure_gives_errors_not_panics() {
    let cases: Vec<BrokenCase> = vec![
        // The gltf crate's validation indexes POSITION's accessor unchecked.
        (
            "position-accessor",
            |d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99),
            "attributes.POSITION is accessor 99",
        ),
        (
            "index-accessor",
            |d| d["meshes"][0]["primitives"][0]["indices"] = json!(99),
            "Index out of bounds",
        ),
        (
            "cycle",
            |d| d["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}]),
            "nodes[0] is reached twice",
        ),
        (
            "stride",
            |d| d["bufferViews"][0]["byteStride"] = json!(4),
            "byteStride 4 is less than its 12-byte elements",
        ),
        (
            "overrun",
            |d| d["accessors"][0]["count"] = json!(1000),
            "overrun bufferViews[0]",
        ),
        (
            "huge-count",
            |d| d["accessors"][0]["count"] = json!(u64::MAX / 2),
            "overrun bufferViews[0]",
        ),
        (
            "zero-count",
            |d| d["accessors"][0]["count"] = json!(0),
            "has count 0",
        ),
        (
            "view-past-buffer",
            |d| d["bufferViews"][0]["byteLength"] = json!(1 << 20),
            "overruns buffer 0",
        ),
        (
            "float-indices",
            |d| d["accessors"][2]["componentType"] = json!(5126),
            "expected Scalar of one of [U8, U16, U32]",
        ),
        (
            "vec2-positions",
            |d| d["accessors"][0]["type"] = json!("VEC2"),
            "expected Vec3",
        ),
        (
            "normal-count",
            |d| d["accessors"][1]["count"] = json!(2),
            "NORMAL has 2 elements, POSITION 3",
        ),
        (
            "bad-percent-uri",
            |d| d["buffers"][0]["uri"] = json!("%FF%FE.bin"),
            "do not decode to UTF-8",
        ),
        (
            "image-without-source",
            |d| d["images"] = json!([{"name": "x"}]),
            "images[0] has neither a uri",
        ),
        (
            "camera-type",
            |d| {
                d["cameras"] =
                    json!([{"type": "orthographic", "perspective": {"yfov": 1.0, "znear": 0.1}}]);
            },
            "cameras[0] lacks the projection object",
        ),
        (
            "nan-matrix",
            |d| {
                // f32::MAX is finite, but its square is not: the world transform of a
                // mesh under two such nodes overflows.
                d["nodes"][0]["matrix"] =
                    json!([3e38, 0, 0, 0, 0, 3e38, 0, 0, 0, 0, 3e38, 0, 0, 0, 0, 1]);
                let mesh = d["nodes"][0]["mesh"].take();
                d["nodes"][0].as_object_mut().unwrap().remove("mesh");
                let child = d["nodes"].as_array().unwrap().len();
                d["nodes"][0]["children"] = json!([child]);
                d["nodes"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!({"mesh": mesh, "matrix": [3e38, 0, 0, 0, 0, 3e38, 0, 0, 0, 0, 3e38, 0, 0, 0, 0, 1]}));
            },
            "non-finite world transform",
        ),
        (
            "light-index",
            |d| d["nodes"][0]["extensions"] = json!({"KHR_lights_punctual": {"light": 3}}),
            "Index out of bounds",
        ),
        (
            "material-index",
            |d| d["meshes"][0]["primitives"][0]["material"] = json!(5),
            "Index out of bounds",
        ),
        (
            "scene-index",
            |d| d["scene"] = json!(4),
            "Index out of bounds",
        ),
        (
            "bad-base64",
            |d| d["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@@"),
            "buffer 0 'data: URI'",
        ),
        (
            "bad-yfov",
            |d| {
                d["nodes"][0]["camera"] = json!(0);
                d["cameras"] =
                    json!([{"type": "perspective", "perspective": {"yfov": 4.0, "znear": 0.1}}]);
            },
            "field of view",
        ),
    ];
    for (name, break_it, expected) in cases {
        let mut doc = good_doc();
        break_it(&mut doc);
        let err = load_err(name, &doc);
        assert!(err.contains(expected), "{name}: {err}");
    }
}

// ---- large textures: reduced on load, each texel its block's mean ----

/// CRC-32 (IEEE) of `bytes`, for PNG chunks.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A PNG of `w x h` pixels of `color_type` (0 grey, 4 grey + alpha, 2 RGB, 6 RGBA) and
/// `bits` (8 or 16) holding `pixels` (row-major, 16-bit samples big-endian), Adam7
/// interlaced when `interlaced`; written here from the PNG specification (image data in
/// stored deflate blocks, filter 0), independently of the decoders under test.
fn raw_png(w: u32, h: u32, color_type: u8, bits: u8, interlaced: bool, pixels: &[u8]) -> Vec<u8> {
    let channels = match color_type {
        0 => 1,
        4 => 2,
        2 => 3,
        _ => 4,
    };
    let bpp = channels * usize::from(bits / 8);
    let pixel = |x: u32, y: u32| {
        let at = (y as usize * w as usize + x as usize) * bpp;
        &pixels[at..at + bpp]
    };
    let mut scanlines = Vec::new();
    // (x offset, x step, y offset, y step) of each pass; one pass of all pixels if not
    // interlaced.
    let passes: &[(u32, u32, u32, u32)] = if interlaced {
        &[
            (0, 8, 0, 8),
            (4, 8, 0, 8),
            (0, 4, 4, 8),
            (2, 4, 0, 4),
            (0, 2, 2, 4),
            (1, 2, 0, 2),
            (0, 1, 1, 2),
        ]
    } else {
        &[(0, 1, 0, 1)]
    };
    for &(xo, xs, yo, ys) in passes {
        if xo >= w || yo >= h {
            continue; // an empty pass has no scanlines
        }
        for y in (yo..h).step_by(ys as usize) {
            scanlines.push(0); // filter: none
            for x in (xo..w).step_by(xs as usize) {
                scanlines.extend_from_slice(pixel(x, y));
            }
        }
    }
    // zlib: header, stored blocks of at most 65535 bytes, Adler-32.
    let mut zlib = vec![0x78, 0x01];
    let blocks: Vec<&[u8]> = scanlines.chunks(65535).collect();
    for (i, block) in blocks.iter().enumerate() {
        zlib.push(u8::from(i + 1 == blocks.len()));
        let len = block.len() as u16;
        zlib.extend(len.to_le_bytes());
        zlib.extend((!len).to_le_bytes());
        zlib.extend_from_slice(block);
    }
    let (mut a, mut b) = (1u32, 0u32);
    for &byte in &scanlines {
        a = (a + u32::from(byte)) % 65521;
        b = (b + a) % 65521;
    }
    zlib.extend(((b << 16) | a).to_be_bytes());
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |ty: &[u8], data: &[u8]| {
        png.extend((data.len() as u32).to_be_bytes());
        let mut body = ty.to_vec();
        body.extend_from_slice(data);
        png.extend_from_slice(&body);
        png.extend(crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([bits, color_type, 0, 0, u8::from(interlaced)]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &zlib);
    chunk(b"IEND", &[]);
    png
}

#[test]
fn the_hand_written_png_decodes_as_written() {
    // Checked against the image crate, which decodes it whole, interlaced or not.
    let pixels: Vec<u8> = (0..13 * 7 * 4).map(|i| (i * 37 % 251) as u8).collect();
    for interlaced in [false, true] {
        let png = raw_png(13, 7, 6, 8, interlaced, &pixels);
        let decoded = image::load_from_memory(&png).unwrap().into_rgba8();
        assert_eq!(decoded.into_raw(), pixels, "interlaced {interlaced}");
    }
}

/// A one-triangle document with `materials` (JSON) and one texture per image URI.
fn doc_with_images(materials: Value, images: &[String]) -> Value {
    let mut bin = Bin::default();
    let pos = bin.vec3(&TRI);
    let n = materials.as_array().unwrap().len();
    let prims: Vec<Value> = (0..n)
        .map(|i| json!({"attributes": {"POSITION": pos}, "material": i}))
        .collect();
    let textures: Vec<Value> = (0..images.len()).map(|i| json!({"source": i})).collect();
    let images: Vec<Value> = images.iter().map(|u| json!({"uri": u})).collect();
    bin.into_doc(json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": prims}],
        "materials": materials, "textures": textures, "images": images,
    }))
}

fn png_uri(png: &[u8]) -> String {
    format!("data:image/png;base64,{}", base64(png))
}

/// The texture of material `m`'s base colour (or metallic-roughness when `mr`).
fn texture_of(scene: &Scene, m: usize, mr: bool) -> &tprf_core::scene::Texture {
    let material = &scene.materials[m];
    let r = if mr {
        material.metallic_roughness_texture
    } else {
        material.base_color_texture
    };
    &scene.textures[r.unwrap().texture as usize]
}

/// sRGB code -> linear, IEC 61966-2-1, in f64.
fn srgb_to_linear(code: u8) -> f64 {
    let c = f64::from(code) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn textures_over_8192_pixels_a_side_are_reduced_keeping_each_blocks_mean() {
    // A black and white checkerboard 8194 pixels wide: halved to 4097 x 1. Every 2 x 2
    // block is half black, half white: mean albedo 0.5 in linear light, which is sRGB
    // code 188 (averaging the codes instead would give 128, linear 0.216). As data
    // (metallic-roughness) the mean of the stored values is 127.5, rounded to 128.
    let (w, h) = (8194u32, 2u32);
    let checker: Vec<u8> = (0..h)
        .flat_map(|y| (0..w).map(move |x| if (x + y) % 2 == 0 { 0 } else { 255 }))
        .collect();
    let checker16: Vec<u8> = checker.iter().flat_map(|&v| [v, v]).collect();
    let uris = [
        png_uri(&raw_png(w, h, 0, 8, false, &checker)),
        png_uri(&raw_png(w, h, 0, 16, true, &checker16)),
    ];
    let materials = json!([
        {"name": "colour", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
        {"name": "data", "pbrMetallicRoughness": {"metallicRoughnessTexture": {"index": 0}}},
        {"name": "colour16", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
    ]);
    let scene = load_doc("checker", &doc_with_images(materials, &uris));
    // One image used as colour and as data: two reductions.
    assert_eq!(scene.textures.len(), 3);
    for (m, mr, code) in [(0, false, 188u8), (1, true, 128), (2, false, 188)] {
        let tex = texture_of(&scene, m, mr);
        assert_eq!((tex.width, tex.height), (4097, 1), "material {m}");
        assert!(
            tex.rgba8.iter().all(|&t| t == [code, code, code, 255]),
            "material {m}: {:?}",
            &tex.rgba8[..4]
        );
    }
    assert!((srgb_to_linear(188) - 0.5).abs() < 0.003);
    assert!(
        has_note(
            &scene,
            "images[0] 'data: URI': 8194 x 2 pixels reduced to 4097 x 1 on load (each texel \
             the mean of a 2 x 2 block, colour averaged in linear light"
        ),
        "{:?}",
        scene.notes
    );
    assert!(
        has_note(&scene, "values averaged as stored"),
        "{:?}",
        scene.notes
    );
}

#[test]
fn reduced_blocks_at_the_edges_and_interlaced_images_are_averaged_exactly() {
    // 8195 x 3 RGBA, as data: factor 2, 4098 x 2 texels, the last column and row of
    // blocks one pixel wide or high. Each texel is checked against its block's mean
    // computed here in f64, for the image read row by row (an external file) and the
    // same image Adam7-interlaced (a data: URI), whose passes revisit every block.
    let (w, h) = (8195u32, 3u32);
    let value = |x: u32, y: u32, c: u32| ((x * 7 + y * 131 + c * 61 + x * x % 13) % 256) as u8;
    let pixels: Vec<u8> = (0..h)
        .flat_map(|y| (0..w).flat_map(move |x| (0..4).map(move |c| value(x, y, c))))
        .collect();
    write_file("edges.png", &raw_png(w, h, 6, 8, false, &pixels));
    let uris = [
        "edges.png".to_string(),
        png_uri(&raw_png(w, h, 6, 8, true, &pixels)),
    ];
    let materials = json!([
        {"pbrMetallicRoughness": {"metallicRoughnessTexture": {"index": 0}}},
        {"pbrMetallicRoughness": {"metallicRoughnessTexture": {"index": 1}}},
    ]);
    let scene = load_doc("edges", &doc_with_images(materials, &uris));
    for m in 0..2 {
        let tex = texture_of(&scene, m, true);
        assert_eq!((tex.width, tex.height), (4098, 2));
        for ty in 0..2u32 {
            for tx in 0..4098u32 {
                let xs: Vec<u32> = (2 * tx..(2 * tx + 2).min(w)).collect();
                let ys: Vec<u32> = (2 * ty..(2 * ty + 2).min(h)).collect();
                let n = (xs.len() * ys.len()) as f64;
                for c in 0..4 {
                    let sum: f64 = ys
                        .iter()
                        .flat_map(|&y| xs.iter().map(move |&x| f64::from(value(x, y, c))))
                        .sum();
                    let want = sum / n;
                    let got = f64::from(tex.rgba8[(ty * 4098 + tx) as usize][c as usize]);
                    assert!(
                        (got - want).abs() <= 0.5 + 1e-3,
                        "material {m}, texel ({tx}, {ty}), channel {c}: {got} for a mean of {want}"
                    );
                }
            }
        }
    }
}

#[test]
fn small_interlaced_and_16_bit_pngs_keep_every_pixel() {
    // 13 x 7 RGBA 16-bit, interlaced and not: kept whole, each sample rounded to eight
    // bits as (v + 128) / 257.
    let samples: Vec<u16> = (0..13 * 7 * 4).map(|i| (i * 7919 % 65536) as u16).collect();
    let bytes: Vec<u8> = samples.iter().flat_map(|s| s.to_be_bytes()).collect();
    let uris = [
        png_uri(&raw_png(13, 7, 6, 16, false, &bytes)),
        png_uri(&raw_png(13, 7, 6, 16, true, &bytes)),
    ];
    let materials = json!([
        {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
        {"pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
    ]);
    let scene = load_doc("interlaced16", &doc_with_images(materials, &uris));
    let want: Vec<[u8; 4]> = samples
        .chunks(4)
        .map(|p| std::array::from_fn(|c| ((u32::from(p[c]) + 128) / 257) as u8))
        .collect();
    for m in 0..2 {
        let tex = texture_of(&scene, m, false);
        assert_eq!((tex.width, tex.height), (13, 7));
        assert_eq!(tex.rgba8, want, "material {m}");
    }
    assert!(!has_note(&scene, "reduced"), "{:?}", scene.notes);
}

#[test]
fn large_jpegs_are_reduced_or_refused_by_what_decoding_them_whole_takes() {
    use image::codecs::jpeg::JpegEncoder;
    let jpeg = |w: u32, h: u32, color: image::ExtendedColorType, data: &[u8]| {
        let mut out = Vec::new();
        JpegEncoder::new_with_quality(&mut out, 100)
            .encode(data, w, h, color)
            .unwrap();
        format!("data:image/jpeg;base64,{}", base64(&out))
    };
    // Grey, 8200 x 8 (65.6 kB decoded whole): halved to 4100 x 4 (65.6 kB), within
    // 4 times the texture. A flat grey stays that grey.
    let grey = jpeg(8200, 8, image::ExtendedColorType::L8, &vec![90u8; 8200 * 8]);
    let materials = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    let scene = load_doc("jpeg-grey", &doc_with_images(materials.clone(), &[grey]));
    let tex = texture_of(&scene, 0, false);
    assert_eq!((tex.width, tex.height), (4100, 4));
    assert!(
        tex.rgba8
            .iter()
            .all(|t| t[0].abs_diff(90) <= 1 && t[3] == 255),
        "{:?}",
        &tex.rgba8[..4]
    );
    assert!(
        has_note(&scene, "8200 x 8 pixels reduced to 4100 x 4"),
        "{:?}",
        scene.notes
    );
    // RGB, 16400 x 16 (787 kB decoded whole) for a 5467 x 6 texture (131 kB): refused.
    let rgb = jpeg(
        16_400,
        16,
        image::ExtendedColorType::Rgb8,
        &vec![200u8; 16_400 * 16 * 3],
    );
    let err = load_err("jpeg-rgb", &doc_with_images(materials, &[rgb]));
    assert!(
        err.contains("a JPEG of 16400 x 16 pixels is decoded whole")
            && err.contains("to keep a 5467 x 6 texture")
            && err.contains("save it as PNG"),
        "{err}"
    );
}

//! Mitsuba 3 / mitransient XML scenes, checked without mitransient: a scene written here
//! whose geometry, lights, camera and render settings are worked out by hand from the
//! XML, rendered and compared with the single-bounce answer; the vendored cornell boxes
//! against their own OBJ files; the volumetric box refused by the documented rule; and
//! hostile XML (malformed, a missing mesh, an include cycle, a huge integer, deep
//! nesting...) refused with the file and line, never a panic. The comparison with
//! mitransient itself is in `tests/mitsuba_mitransient.rs`.

mod common;

use glam::Vec3;
use std::path::{Path, PathBuf};
use tprf_core::film::TimeAxis;
use tprf_core::scene::{self, Channel, Scene};
use tprf_core::transport::RenderSettings;

const C: f64 = common::C;

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("mitsuba-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

fn cbox(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets/mitsuba/mitransient/cornell-box")
        .join(name)
        .display()
        .to_string()
}

/// The error of loading `xml` (written as `name` in a fresh folder), as text.
fn refusal(dir: &Path, name: &str, xml: &str) -> String {
    let p = write(dir, name, xml);
    match scene::load(&p) {
        Ok(_) => panic!("{name} loaded; expected a refusal"),
        Err(e) => e.to_string(),
    }
}

/// Bounds of the triangles of the object named `name`.
fn object_bounds(s: &Scene, name: &str) -> (Vec3, Vec3) {
    let o = s
        .objects
        .iter()
        .find(|o| o.name == name)
        .unwrap_or_else(|| panic!("no object {name}"));
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for t in &s.triangles[o.triangles.clone()] {
        for p in t.p {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (lo, hi)
}

fn area(s: &Scene, name: &str) -> f64 {
    let o = s.objects.iter().find(|o| o.name == name).unwrap();
    s.triangles[o.triangles.clone()]
        .iter()
        .map(|t| 0.5 * f64::from((t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length()))
        .sum()
}

const BY_HAND: &str = r#"<?xml version="1.0"?>
<!-- Every number the test checks is worked out from this text. -->
<scene version="3.0.0">
    <default name="w" value="40"/>
    <integrator type="transient_path">
        <integer name="max_depth" value="4"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <float name="near_clip" value="0.5"/>
        <transform name="to_world">
            <lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="16"/>
        </sampler>
        <film type="transient_hdr_film">
            <integer name="width" value="$w"/>
            <integer name="height" value="20"/>
            <integer name="temporal_bins" value="100"/>
            <float name="start_opl" value="9.98"/>
            <float name="bin_width_opl" value="0.05"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <emitter type="point" id="flash">
        <point name="position" x="0" y="0" z="5"/>
        <rgb name="intensity" value="2, 4, 6"/>
    </emitter>
    <shape type="rectangle" id="wall">
        <transform name="to_world">
            <scale x="2" y="3"/>
            <rotate z="1" angle="90"/>
            <translate x="1" z="-1"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.2, 0.4, 0.6"/>
        </bsdf>
    </shape>
    <shape type="cube" id="lamp">
        <transform name="to_world">
            <scale value="0.5"/>
            <translate z="-6"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="3, 2, 1"/>
        </emitter>
    </shape>
</scene>
"#;

/// Rec. 709 luminance: tprf's gray band, and what Mitsuba's mono variants take of an RGB.
fn gray(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

#[test]
fn a_scene_written_by_hand_loads_as_worked_out_and_renders_its_single_bounce() {
    let dir = tmp("by-hand");
    let path = write(&dir, "by_hand.xml", BY_HAND);
    let (s, file) = scene::load_with_settings(&path).unwrap();
    // What the window reads before the scene loads: the same settings.
    assert_eq!(scene::file_settings(&path).unwrap(), file);

    // The rectangle [-1, 1]^2: scaled (2, 3), turned 90 degrees about +Z ((x, y) ->
    // (-y, x)), moved by (1, 0, -1): x in [-2, 4], y in [-2, 2], z = -1; area 6 x 4.
    let (lo, hi) = object_bounds(&s, "wall");
    assert!(lo.abs_diff_eq(Vec3::new(-2.0, -2.0, -1.0), 1e-5), "{lo}");
    assert!(hi.abs_diff_eq(Vec3::new(4.0, 2.0, -1.0), 1e-5), "{hi}");
    assert!((area(&s, "wall") - 24.0).abs() < 1e-4);
    // The cube [-1, 1]^3 halved, at z = -6: 12 triangles, area 6.
    let (lo, hi) = object_bounds(&s, "lamp");
    assert!(lo.abs_diff_eq(Vec3::new(-0.5, -0.5, -6.5), 1e-5), "{lo}");
    assert!(hi.abs_diff_eq(Vec3::new(0.5, 0.5, -5.5), 1e-5), "{hi}");
    assert!((area(&s, "lamp") - 6.0).abs() < 1e-4);
    assert_eq!(s.triangles.len(), 2 + 12);

    // Materials: the wall's reflectance; the lamp's radiance (W m^-2 sr^-1, as Mitsuba's),
    // from its front only, on Mitsuba's default BSDF (diffuse 0.5).
    let wall = &s.materials[s.attrs[0].material as usize];
    assert_eq!(&wall.base_color[..3], &[0.2, 0.4, 0.6]);
    assert_eq!(wall.emissive, [0.0; 3]);
    let lamp = &s.materials[s.attrs[2].material as usize];
    assert_eq!(lamp.emissive, [3.0, 2.0, 1.0]);
    assert!(!lamp.double_sided);
    assert_eq!(&lamp.base_color[..3], &[0.5, 0.5, 0.5]);

    // The point light: W/sr, as Mitsuba's.
    assert_eq!(s.lights.len(), 1);
    assert_eq!(s.lights[0].position, Vec3::new(0.0, 0.0, 5.0));
    assert_eq!(s.lights[0].intensity_w_per_sr, [2.0, 4.0, 6.0]);

    // The camera: at (0, 0, 5) looking down -Z; fov 60 on x (the default axis) of a 2:1
    // film: yfov = 2 atan(tan(30 deg) / 2) = 32.2042 deg.
    assert!(
        s.camera
            .position()
            .abs_diff_eq(Vec3::new(0.0, 0.0, 5.0), 1e-6)
    );
    let forward = s.camera.world_from_camera.transform_vector3(-Vec3::Z);
    assert!(forward.abs_diff_eq(-Vec3::Z, 1e-6), "{forward}");
    let up = s.camera.world_from_camera.transform_vector3(Vec3::Y);
    assert!(up.abs_diff_eq(Vec3::Y, 1e-6), "{up}");
    let yfov_deg = 2.0 * (30f64.to_radians().tan() / 2.0).atan().to_degrees();
    assert!((f64::from(s.camera.yfov_rad(2.0)).to_degrees() - yfov_deg).abs() < 1e-4);

    // Render settings: the film's size and bins; the window from start_opl + near_clip
    // (mitransient counts from the near plane); max_depth 4 = 3 scattering events.
    let v = |o: &Option<scene::FileSetting<u64>>| o.as_ref().map(|s| s.value);
    assert_eq!(v(&file.width), Some(40));
    assert_eq!(v(&file.height), Some(20));
    assert_eq!(v(&file.bins), Some(100));
    assert_eq!(v(&file.spp), Some(16));
    assert_eq!(file.max_bounces.as_ref().map(|s| s.value), Some(3));
    // start_opl as the file gives it; from the pinhole (tprf's default clock) 0.5 m
    // (near_clip) later.
    assert_eq!(file.t0_opl_m.as_ref().unwrap().value, 9.98);
    let t0_opl_m = file.t0_opl_m_for(scene::TimeOrigin::Pinhole).unwrap().value;
    let dt_opl_m = file.dt_opl_m.as_ref().unwrap().value;
    assert!((t0_opl_m - 10.48).abs() < 1e-12, "{t0_opl_m}");
    assert!((dt_opl_m - 0.05).abs() < 1e-12);
    assert!(
        file.width.as_ref().unwrap().from.contains("by_hand.xml:18"),
        "{:?}",
        file.width
    );

    // Rendered: the centre of the image sees the wall 6 m away, lit head-on by the
    // flash at the camera (the lamp hides behind the wall): gray radiance
    // rho I / (pi d^2), arriving after 12 m of optical path: bin (12 - 10.48) / 0.05 =
    // 30.4, so bin 30.
    let (w, h, bins) = (40, 20, 100);
    let axis = TimeAxis::new(t0_opl_m / C, dt_opl_m / C, bins).unwrap();
    let settings = RenderSettings {
        max_bounces: 3,
        channel: Channel::Gray,
        ..RenderSettings::default()
    };
    let r = common::render_with(s, w, h, axis, 16, settings, 0);
    let expected = gray([0.2, 0.4, 0.6]) * gray([2.0, 4.0, 6.0]) / (std::f64::consts::PI * 36.0);
    for (x, y) in [(19, 9), (20, 9), (19, 10), (20, 10)] {
        let tprf = r.film.pixel_tprf(x, y);
        let sum: f64 = tprf.iter().sum();
        assert!(
            (sum / expected - 1.0).abs() < 2e-3,
            "pixel ({x}, {y}): {sum} against {expected}"
        );
        let peak = (0..bins)
            .max_by(|&a, &b| tprf[a].total_cmp(&tprf[b]))
            .unwrap();
        assert_eq!(peak, 30, "pixel ({x}, {y})");
        assert!(tprf[30] / sum > 0.99);
    }
}

#[test]
fn the_vendored_cornell_boxes_load_their_meshes_and_light() {
    // Each file's <default name="res">: 400, 400, 256.
    for (name, res) in [
        ("cbox_diffuse.xml", 400),
        ("cbox_mirror.xml", 400),
        ("cbox_volumetric.xml", 256),
    ] {
        let settings = scene::file_settings(&cbox(name)).unwrap();
        assert_eq!(settings, scene::load_with_settings(&cbox(name)).unwrap().1);
        assert_eq!(settings.width.map(|w| w.value), Some(res), "{name}: $res");
        assert_eq!(settings.bins.map(|b| b.value), Some(400), "{name}");
    }
    // Faces of the OBJ files, counted here (each `f` line a polygon of n vertices is
    // n - 2 triangles).
    let mesh_dir =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/mitsuba/mitransient/cornell-box/meshes");
    let mut triangles = 0;
    for e in std::fs::read_dir(&mesh_dir).unwrap() {
        let text = std::fs::read_to_string(e.unwrap().path()).unwrap();
        triangles += text
            .lines()
            .filter(|l| l.starts_with("f "))
            .map(|l| l.split_whitespace().count() - 3)
            .sum::<usize>();
    }
    // max_depth 8 and 5: 7 and 4 scattering events.
    for (name, bounces) in [("cbox_diffuse.xml", 7), ("cbox_mirror.xml", 4)] {
        let (s, file) = scene::load_with_settings(&cbox(name)).unwrap();
        assert_eq!(s.triangles.len(), triangles, "{name}");
        // The luminaire: its radiance as the file gives it, lowered by 0.5 (its
        // translate) from the OBJ's y = 548.8.
        let (lo, hi) = object_bounds(&s, "light");
        assert!(
            (lo.y - 548.3).abs() < 1e-3 && (hi.y - 548.3).abs() < 1e-3,
            "{lo} {hi}"
        );
        let o = s.objects.iter().find(|o| o.name == "light").unwrap();
        let m = &s.materials[s.attrs[o.triangles.start].material as usize];
        assert_eq!(m.emissive, [18.387, 10.9873, 2.75357]);
        // It faces down, into the box: Mitsuba's area lights emit on their front.
        let t = &s.triangles[o.triangles.start];
        assert!((t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).y < 0.0);
        assert!(s.lights.is_empty(), "{name}: no light added");
        // The film and integrator: 400 x 400 (the $res default), 400 bins of 6.5 from
        // 1000 + near_clip 10.
        assert_eq!(file.width.as_ref().unwrap().value, 400);
        assert_eq!(file.bins.as_ref().unwrap().value, 400);
        assert_eq!(file.t0_opl_m.as_ref().unwrap().value, 1000.0);
        let pinhole = file.t0_opl_m_for(scene::TimeOrigin::Pinhole).unwrap().value;
        assert_eq!(pinhole, 1010.0);
        assert_eq!(file.dt_opl_m.as_ref().unwrap().value, 6.5);
        assert_eq!(file.max_bounces.as_ref().unwrap().value, bounces);
        assert!((s.camera.position() - Vec3::new(278.0, 273.0, -800.0)).length() < 1e-3);
    }
}

/// The medium of the object named `name` (its material's).
fn object_medium(s: &Scene, name: &str) -> Option<scene::Medium> {
    let o = s.objects.iter().find(|o| o.name == name).unwrap();
    s.materials[s.attrs[o.triangles.start].material as usize]
        .medium
        .clone()
}

fn close(a: [f32; 3], b: [f64; 3]) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| (*x as f64 - y).abs() <= 1e-6 * y.abs().max(1.0))
}

/// mitransient's volumetric Cornell box: two boxes behind `null` BSDFs, each filled with
/// a homogeneous medium given as extinction and albedo: tprf's coefficients are
/// sigma_s = albedo sigma_t and sigma_a = (1 - albedo) sigma_t (worked out here from
/// the file's numbers), its Henyey-Greenstein g, index 1 (an index-matched boundary).
#[test]
fn the_volumetric_cornell_box_fills_its_boxes_with_their_media() {
    let s = scene::load(&cbox("cbox_volumetric.xml")).unwrap();
    assert_eq!(s.medium, None, "the air is vacuum");
    for (name, albedo, sigma_t, g) in [
        ("smallbox", [0.99, 0.4, 0.46], 0.05, 0.1),
        ("largebox", [0.44, 0.4, 0.96], 0.02, 0.7),
    ] {
        let m = object_medium(&s, name).unwrap_or_else(|| panic!("{name}: no medium"));
        assert!(
            close(m.sigma_s_per_m, albedo.map(|a| a * sigma_t)),
            "{name}: {m:?}"
        );
        assert!(
            close(m.sigma_a_per_m, albedo.map(|a| (1.0 - a) * sigma_t)),
            "{name}: {m:?}"
        );
        assert_eq!((m.g, m.n), (g, 1.0), "{name}");
    }
    assert_eq!(object_medium(&s, "floor"), None);
}

/// A scene written here: fog around the camera (the sensor's medium: the scene's, with
/// `scale`), a dielectric sphere of index 1.33 (relative to air) filled with isotropic
/// water (n = the boundary's index); a grid volume's missing file and an unknown phase
/// function refused naming the element and line.
#[test]
fn media_written_by_hand_map_onto_tprfs_and_the_unsupported_are_refused() {
    let dir = tmp("media");
    let scene = |medium: &str| {
        format!(
            r#"<scene version="3.0.0">
  <medium type="homogeneous" id="fog">
    <float name="sigma_t" value="0.2"/>
    <float name="albedo" value="0.9"/>
    <float name="scale" value="0.5"/>
    <phase type="hg"><float name="g" value="0.85"/></phase>
  </medium>
  <sensor type="perspective">
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <ref id="fog"/>
  </sensor>
  <emitter type="point"><point name="position" x="0" y="0" z="5"/></emitter>
  <shape type="sphere" id="drop">
    <bsdf type="dielectric"><float name="int_ior" value="1.33"/></bsdf>
{medium}
  </shape>
</scene>
"#
        )
    };
    let water = r#"    <medium type="homogeneous" name="interior">
      <rgb name="sigma_t" value="0.1, 0.2, 0.4"/>
      <float name="albedo" value="0.5"/>
      <phase type="isotropic"/>
    </medium>"#;
    let p = write(&dir, "media.xml", &scene(water));
    let s = scene::load(&p).unwrap();
    let fog = s
        .medium
        .clone()
        .expect("the sensor's medium is the scene's");
    assert!(close(fog.sigma_s_per_m, [0.5 * 0.9 * 0.2; 3]), "{fog:?}");
    assert!(close(fog.sigma_a_per_m, [0.5 * 0.1 * 0.2; 3]), "{fog:?}");
    assert_eq!((fog.g, fog.n), (0.85, 1.0));
    let w = object_medium(&s, "drop").unwrap();
    assert!(close(w.sigma_s_per_m, [0.05, 0.1, 0.2]), "{w:?}");
    assert!(close(w.sigma_a_per_m, [0.05, 0.1, 0.2]), "{w:?}");
    // Mitsuba's index is relative: int_ior over the default ext_ior, air's 1.000277.
    assert_eq!(w.g, 0.0);
    assert!((w.n as f64 - 1.33 / 1.000277).abs() < 1e-6, "{}", w.n);

    let grid = r#"    <medium type="heterogeneous" name="interior">
      <volume type="gridvolume" name="sigma_t"><string name="filename" value="smoke.vol"/></volume>
    </medium>"#;
    // A heterogeneous medium is read (tests/media_grid.rs); its missing file refused.
    let e = refusal(&dir, "grid.xml", &scene(grid));
    assert!(e.contains("grid.xml:16") && e.contains("smoke.vol"), "{e}");
    let rayleigh = r#"    <medium type="homogeneous" name="interior">
      <phase type="rayleigh"/>
    </medium>"#;
    let e = refusal(&dir, "rayleigh.xml", &scene(rayleigh));
    assert!(
        e.contains("rayleigh.xml:16") && e.contains("<phase type=\"rayleigh\">"),
        "{e}"
    );
    let bad = r#"    <medium type="homogeneous" name="interior">
      <float name="albedo" value="1.5"/>
    </medium>"#;
    let e = refusal(&dir, "albedo.xml", &scene(bad));
    assert!(e.contains("albedo") && e.contains("[0, 1]"), "{e}");
}

#[test]
fn hostile_xml_gets_clear_errors() {
    let dir = tmp("hostile");
    // Malformed: roxmltree's error with the file and position.
    let e = refusal(
        &dir,
        "malformed.xml",
        "<scene version=\"3.0.0\">\n<shape type=\"obj\">\n</scene>\n",
    );
    assert!(e.contains("malformed.xml"), "{e}");
    // A missing mesh file: the mesh's path and the shape's line.
    let e = refusal(
        &dir,
        "missing.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"obj\">\n    <string name=\"filename\" value=\"nowhere.obj\"/>\n  </shape>\n</scene>\n",
    );
    assert!(e.contains("nowhere.obj"), "{e}");
    // An include cycle: a includes b includes a.
    write(
        &dir,
        "b.xml",
        "<scene version=\"3.0.0\">\n  <include filename=\"a.xml\"/>\n</scene>\n",
    );
    let e = refusal(
        &dir,
        "a.xml",
        "<scene version=\"3.0.0\">\n  <include filename=\"b.xml\"/>\n</scene>\n",
    );
    assert!(e.contains("cycle") || e.contains("includes itself"), "{e}");
    // A huge integer: named, with its line.
    let e = refusal(
        &dir,
        "huge.xml",
        "<scene version=\"3.0.0\">\n  <sensor type=\"perspective\">\n    <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"99999999999999999999999\"/>\n    </film>\n  </sensor>\n</scene>\n",
    );
    assert!(e.contains("huge.xml:4"), "{e}");
    // Deep nesting: refused before anything recurses that deep.
    let depth = 100_000;
    let deep = format!(
        "<scene version=\"3.0.0\">{}{}</scene>",
        "<shape type=\"rectangle\">".repeat(depth),
        "</shape>".repeat(depth)
    );
    let e = refusal(&dir, "deep.xml", &deep);
    assert!(e.contains("deep.xml"), "{e}");
    // An unsupported plugin: the element, its type, file and line.
    let e = refusal(
        &dir,
        "hair.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"rectangle\">\n    <bsdf type=\"hair\"/>\n  </shape>\n</scene>\n",
    );
    assert!(
        e.contains("hair.xml:3") && e.contains("<bsdf type=\"hair\"> is not supported"),
        "{e}"
    );
    // A reference to nothing, and a $name with no <default>.
    let e = refusal(
        &dir,
        "ref.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"rectangle\">\n    <ref id=\"nope\"/>\n  </shape>\n</scene>\n",
    );
    assert!(e.contains("ref.xml:3") && e.contains("nope"), "{e}");
    let e = refusal(
        &dir,
        "param.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n    <float name=\"radius\" value=\"$r\"/>\n  </shape>\n</scene>\n",
    );
    assert!(e.contains("param.xml:3") && e.contains("$r"), "{e}");
    // A number that is not one, and a negative film size.
    let e = refusal(
        &dir,
        "nan.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n    <float name=\"radius\" value=\"nan\"/>\n  </shape>\n</scene>\n",
    );
    assert!(e.contains("nan.xml:3"), "{e}");
    // Not a Mitsuba scene at all.
    let e = refusal(&dir, "other.xml", "<html><body/></html>\n");
    assert!(e.contains("other.xml") && e.contains("scene"), "{e}");
    // A file that is not there.
    let e = scene::load(&dir.join("absent.xml").display().to_string())
        .unwrap_err()
        .to_string();
    assert!(e.contains("absent.xml"), "{e}");
}

#[test]
fn a_mitsuba_scene_saved_as_gltf_loads_back_the_same() {
    let dir = tmp("save");
    let (s, _) = scene::load_with_settings(&cbox("cbox_diffuse.xml")).unwrap();
    let out = dir.join("cbox.gltf");
    scene::gltf_save::save_gltf(&s, &out).unwrap();
    let back = scene::load(&out.display().to_string()).unwrap();
    assert_eq!(back.triangles.len(), s.triangles.len());
    for (a, b) in s.triangles.iter().zip(&back.triangles) {
        for (p, q) in a.p.iter().zip(&b.p) {
            assert!(p.abs_diff_eq(*q, 1e-3), "{p} {q}");
        }
    }
    let emissive = |s: &Scene| -> Vec<[f32; 3]> {
        s.attrs
            .iter()
            .map(|a| s.materials[a.material as usize].emissive)
            .collect()
    };
    assert_eq!(emissive(&back), emissive(&s));
    assert!((back.camera.position() - s.camera.position()).length() < 1e-3);
    assert!((back.camera.fov_rad - s.camera.fov_rad).abs() < 1e-6);
}

#[test]
fn includes_defaults_and_ply_meshes_ascii_and_binary() {
    let dir = tmp("ply");
    // The unit square in z = 0 as two triangles, ASCII and binary little endian.
    let header = |format: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
             element face 2\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    let corners = [
        [0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let faces = [[0i32, 1, 2], [0, 2, 3]];
    let mut ascii = header("ascii");
    for c in corners {
        ascii += &format!("{} {} {}\n", c[0], c[1], c[2]);
    }
    for f in faces {
        ascii += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    std::fs::write(dir.join("ascii.ply"), ascii).unwrap();
    let mut binary = header("binary_little_endian").into_bytes();
    for c in corners {
        for v in c {
            binary.extend(v.to_le_bytes());
        }
    }
    for f in faces {
        binary.push(3);
        for i in f {
            binary.extend(i.to_le_bytes());
        }
    }
    std::fs::write(dir.join("binary.ply"), binary).unwrap();
    // The shapes come from an included file, their offsets from <default>s of the
    // including one.
    write(
        &dir,
        "shapes.xml",
        r#"<scene version="3.0.0">
    <shape type="ply" id="a"><string name="filename" value="ascii.ply"/>
        <transform name="to_world"><translate x="$dx"/></transform></shape>
    <shape type="ply" id="b"><string name="filename" value="binary.ply"/>
        <transform name="to_world"><scale value="2"/><translate y="$dy"/></transform></shape>
</scene>
"#,
    );
    let main = write(
        &dir,
        "main.xml",
        r#"<scene version="3.0.0">
    <default name="dx" value="5"/>
    <default name="dy" value="-3"/>
    <include filename="shapes.xml"/>
</scene>
"#,
    );
    let s = scene::load(&main).unwrap();
    let (lo, hi) = object_bounds(&s, "a");
    assert!(
        lo.abs_diff_eq(Vec3::new(5.0, 0.0, 0.0), 1e-6)
            && hi.abs_diff_eq(Vec3::new(6.0, 1.0, 0.0), 1e-6),
        "{lo} {hi}"
    );
    assert!((area(&s, "a") - 1.0).abs() < 1e-6);
    let (lo, hi) = object_bounds(&s, "b");
    assert!(
        lo.abs_diff_eq(Vec3::new(0.0, -3.0, 0.0), 1e-6)
            && hi.abs_diff_eq(Vec3::new(2.0, -1.0, 0.0), 1e-6),
        "{lo} {hi}"
    );
    assert!((area(&s, "b") - 4.0).abs() < 1e-5);
    // No sensor and no light: a framed camera and a light at it, both noted.
    assert!(
        s.notes.iter().any(|n| n.contains("no sensor")),
        "{:?}",
        s.notes
    );
    assert_eq!(s.lights.len(), 1);
    // A PLY whose header promises more faces than the file holds is refused by name.
    std::fs::write(
        dir.join("short.ply"),
        header("binary_little_endian").replace("face 2", "face 2000000000"),
    )
    .unwrap();
    let e = refusal(
        &dir,
        "short.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"ply\">\n    <string name=\"filename\" value=\"short.ply\"/>\n  </shape>\n</scene>\n",
    );
    assert!(e.contains("short.ply"), "{e}");
}

/// `serialized` shapes: files written as Mitsuba's documentation describes the format
/// (tests/common/serialized.rs), in versions 4 and 3, each holding a decoy triangle
/// (mesh 0) and a square pyramid (mesh 1) picked by `shape_index`: the pyramid is read,
/// placed by `to_world`, with its area 4 + 4 sqrt(2) scaled; the decoy is not. A wrong
/// index, a file that is not one and a cut stream are refused by name.
#[test]
fn serialized_meshes_are_read_by_their_index_in_both_versions() {
    use common::serialized::{
        DECOY_FACES, DECOY_POSITIONS, SerMesh, decoy_then_pyramid, serialized,
    };
    let dir = tmp("serialized");
    std::fs::write(dir.join("v4.serialized"), decoy_then_pyramid(4)).unwrap();
    std::fs::write(dir.join("v3.serialized"), decoy_then_pyramid(3)).unwrap();
    let xml = write(
        &dir,
        "scene.xml",
        r#"<scene version="3.0.0">
    <shape type="serialized" id="p4">
        <string name="filename" value="v4.serialized"/>
        <integer name="shape_index" value="1"/>
        <transform name="to_world"><scale value="0.5"/><translate x="2" y="1" z="-3"/></transform>
    </shape>
    <shape type="serialized" id="p3">
        <string name="filename" value="v3.serialized"/>
        <integer name="shape_index" value="1"/>
    </shape>
    <shape type="serialized" id="d">
        <string name="filename" value="v4.serialized"/>
    </shape>
</scene>
"#,
    );
    let s = scene::load(&xml).unwrap();
    let pyramid_area = 4.0 + 4.0 * 2f64.sqrt();
    let (lo, hi) = object_bounds(&s, "p4");
    assert!(
        lo.abs_diff_eq(Vec3::new(1.5, 0.5, -3.0), 1e-6)
            && hi.abs_diff_eq(Vec3::new(2.5, 1.5, -2.5), 1e-6),
        "{lo} {hi}"
    );
    assert!((area(&s, "p4") - 0.25 * pyramid_area).abs() < 1e-5);
    let (lo, hi) = object_bounds(&s, "p3");
    assert!(
        lo.abs_diff_eq(Vec3::new(-1.0, -1.0, 0.0), 1e-6)
            && hi.abs_diff_eq(Vec3::new(1.0, 1.0, 1.0), 1e-6),
        "{lo} {hi}"
    );
    assert!((area(&s, "p3") - pyramid_area).abs() < 1e-5);
    // shape_index 0 (the default) is the decoy: one triangle of area 100 x 100 / 2.
    assert!((area(&s, "d") - 5000.0).abs() < 1e-2);

    let shape = |file: &str, index: u32| {
        format!(
            r#"<scene version="3.0.0"><shape type="serialized"><string name="filename" value="{file}"/>
            <integer name="shape_index" value="{index}"/></shape></scene>"#
        )
    };
    let e = refusal(&dir, "index.xml", &shape("v4.serialized", 2));
    assert!(
        e.contains("shape_index 2") && e.contains("holds 2 meshes"),
        "{e}"
    );
    std::fs::write(dir.join("not.serialized"), b"ply\nformat ascii 1.0\n").unwrap();
    let e = refusal(&dir, "not.xml", &shape("not.serialized", 0));
    assert!(e.contains("not a Mitsuba serialized mesh"), "{e}");
    // A stream cut in the middle of its positions (the table at the end kept whole).
    let whole = serialized(
        &[SerMesh {
            name: "decoy",
            positions: &DECOY_POSITIONS,
            normals: None,
            faces: &DECOY_FACES,
        }],
        4,
    );
    let table = 8 + 4;
    let body = &whole[..whole.len() - table];
    let mut cut = body[..body.len() / 2].to_vec();
    cut.extend(0u64.to_le_bytes());
    cut.extend(1u32.to_le_bytes());
    std::fs::write(dir.join("cut.serialized"), cut).unwrap();
    let e = refusal(&dir, "cut.xml", &shape("cut.serialized", 0));
    assert!(e.contains("cut.serialized") && e.contains("mesh 0"), "{e}");
}

/// A mitransient NLOS scene as tal writes one (tal/render/mitsuba3_transient_nlos.py: a
/// relay wall `<shape>` holding an `nlos_capture_meter` with a 1 x 1 film and the
/// confocal grid beside it, `transient_nlos_path` without a capture_type, a `projector`
/// laser): `tprf nlos` takes
/// its capture from the file (the relay wall by its id, the confocal grid of
/// `original_film_width/height`, the film's time axis, the legs left out as
/// `account_first_and_last_bounces` false says, max_depth 4 = one hidden bounce, the
/// devices' positions), and every wall point's first return lies in the bin of its least
/// path to the hidden square worked out here (2 |s - nearest point of the square|, the
/// legs left out). `tprf render` refuses the file, naming `tprf nlos`.
#[test]
fn a_mitransient_nlos_scene_is_captured_by_tprf_nlos_with_its_settings() {
    let dir = tmp("nlos");
    let xml = write(
        &dir,
        "nlos.xml",
        r#"<scene version="3.0.0">
    <integrator type="transient_nlos_path">
        <integer name="block_size" value="1"/>
        <integer name="max_depth" value="4"/>
        <integer name="filter_bounces" value="-1"/>
        <boolean name="nlos_laser_sampling" value="true"/>
        <boolean name="nlos_hidden_geometry_sampling" value="true"/>
        <string name="temporal_filter" value="box"/>
    </integrator>
    <emitter type="projector" id="laser">
        <transform name="to_world"><translate x="-0.5" y="0" z="0.25"/></transform>
        <rgb name="irradiance" value="1, 1, 1"/>
        <float name="fov" value="0.2"/>
    </emitter>
    <shape type="rectangle" id="wall">
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.8, 0.8"/></bsdf>
        <sensor type="nlos_capture_meter">
            <sampler type="independent"><integer name="sample_count" value="4096"/></sampler>
            <integer name="original_film_width" value="8"/>
            <integer name="original_film_height" value="6"/>
            <boolean name="account_first_and_last_bounces" value="false"/>
            <point name="sensor_origin" x="-0.5" y="0" z="0.25"/>
            <film type="transient_hdr_film">
                <integer name="width" value="1"/>
                <integer name="height" value="1"/>
                <integer name="temporal_bins" value="400"/>
                <float name="bin_width_opl" value="0.01"/>
                <float name="start_opl" value="0"/>
                <rfilter type="box"/>
            </film>
        </sensor>
    </shape>
    <shape type="rectangle" id="hidden">
        <transform name="to_world">
            <scale value="0.05"/>
            <rotate y="1" angle="180"/>
            <translate z="1"/>
        </transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>
    </shape>
</scene>
"#,
    );
    let out = dir.join("capture");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(["nlos", &xml, "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    for said in [
        "--grid 8x6",
        "--spp 4096",
        "the scan confocal",
        "--bins 400",
        "--max-bounces 1",
        "--relay-wall wall",
        "device legs left out",
    ] {
        assert!(err.contains(said), "'{said}' not said: {err}");
    }
    let c = tprf_core::nlos::files::read_capture(&out).unwrap();
    assert!(c.is_confocal());
    assert_eq!(c.sensor_shape, [8, 6]);
    assert_eq!(c.bins(), 400);
    assert!((c.delta_t_m - 0.01).abs() < 1e-9 && c.t_start_m.abs() < 1e-9);
    assert!(!c.device_legs);
    let sensor = c.sensor_xyz.expect("the sensor's position");
    assert!(
        (sensor - Vec3::new(-0.5, 0.0, 0.25)).length() < 1e-6,
        "{sensor}"
    );
    // The hidden square: [-0.05, 0.05]^2 at z = 1.
    let n = c.sensor_grid.len();
    assert_eq!(n, 48);
    for (i, s) in c.sensor_grid.iter().enumerate() {
        let near = Vec3::new(s.x.clamp(-0.05, 0.05), s.y.clamp(-0.05, 0.05), 1.0);
        let want = (2.0 * f64::from((*s - near).length()) / 0.01).floor() as usize;
        let first = (0..c.bins())
            .position(|t| c.h[t * n + i] > 0.0)
            .unwrap_or_else(|| panic!("no light at wall point {i} {s}"));
        assert!(
            first.abs_diff(want) <= 1,
            "wall point {i} {s}: first return in bin {first}, the least path in bin {want}"
        );
    }
    // tprf render refuses it, pointing to tprf nlos.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(["render", &xml, "--out", dir.join("r").to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("tprf nlos"), "{err}");
}

/// The camera of `s` as tprf renders it: the unit direction through image point `(px,
/// py)` of a `w x h` film.
fn camera_dir(s: &Scene, px: f64, py: f64, w: usize, h: usize) -> Vec3 {
    let (tx, ty) = s.camera.tan_half_fov(w as f32 / h as f32);
    let sx = (2.0 * px / w as f64 - 1.0) as f32 * tx;
    let sy = (1.0 - 2.0 * py / h as f64) as f32 * ty;
    s.camera
        .world_from_camera
        .transform_vector3(Vec3::new(sx, sy, -1.0))
        .normalize()
}

#[test]
fn a_field_of_view_keeps_its_axis_on_a_film_of_another_size() {
    let dir = tmp("fov");
    let xml = write(
        &dir,
        "fov.xml",
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="35"/>
        <float name="near_clip" value="2"/>
        <film type="transient_hdr_film">
            <integer name="width" value="720"/><integer name="height" value="1280"/>
            <float name="start_opl" value="3"/><float name="bin_width_opl" value="0.1"/>
        </film>
    </sensor>
    <integrator type="transient_path"><boolean name="camera_unwarp" value="true"/></integrator>
    <shape type="rectangle"><transform name="to_world"><translate z="5"/></transform></shape>
</scene>"#,
    );
    let (s, file) = scene::load_with_settings(&xml).unwrap();
    // Mitsuba keeps fov 35 across x for any film: a square one is 35 degrees tall too,
    // the file's own 720 x 1280 is 2 atan(tan(17.5) 1280 / 720) = 58.52 tall.
    let deg = |r: f32| f64::from(r).to_degrees();
    assert!((deg(s.camera.yfov_rad(1.0)) - 35.0).abs() < 1e-4);
    let tall = 2.0
        * (17.5f64.to_radians().tan() * 1280.0 / 720.0)
            .atan()
            .to_degrees();
    assert!((deg(s.camera.yfov_rad(720.0 / 1280.0)) - tall).abs() < 1e-3);
    // camera_unwarp: the first hit's clock; the window counted from the near plane
    // (start_opl), or 2 m later from the pinhole.
    use tprf_core::scene::TimeOrigin;
    assert_eq!(
        file.time_origin.as_ref().map(|o| o.value),
        Some(TimeOrigin::FirstHit)
    );
    let t0 = |o| file.t0_opl_m_for(o).unwrap().value;
    assert_eq!(t0(TimeOrigin::FirstHit), 3.0);
    assert_eq!(t0(TimeOrigin::NearPlane), 3.0);
    assert_eq!(t0(TimeOrigin::Pinhole), 5.0);
    assert_eq!(s.camera.near_m, 2.0);
}

#[test]
fn angular_area_emitters_and_projectors_are_read_as_mitransient_defines_them() {
    let dir = tmp("emitters");
    let xml = write(
        &dir,
        "e.xml",
        r#"<scene version="3.0.0">
    <shape type="rectangle">
        <emitter type="angulararea">
            <rgb name="radiance" value="2, 2, 2"/>
            <float name="cutoff_angle" value="35"/><float name="beam_width" value="20"/>
        </emitter>
    </shape>
    <shape type="rectangle"><transform name="to_world"><translate x="3"/></transform>
        <emitter type="angulararea"><float name="cutoff_angle" value="30"/></emitter>
    </shape>
    <emitter type="projector">
        <rgb name="irradiance" value="100"/><float name="scale" value="2"/>
        <float name="fov" value="0.2"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    </emitter>
</scene>"#,
    );
    let s = scene::load(&xml).unwrap();
    let falloffs: Vec<_> = s
        .materials
        .iter()
        .filter_map(|m| m.emission_falloff)
        .map(|f| (f.beam_width_rad.to_degrees(), f.cutoff_rad.to_degrees()))
        .collect();
    let near = |a: f32, b: f32| (a - b).abs() < 1e-4;
    assert_eq!(falloffs.len(), 2, "{falloffs:?}");
    assert!(near(falloffs[0].0, 20.0) && near(falloffs[0].1, 35.0));
    // beam_width defaults to the cutoff.
    assert!(near(falloffs[1].0, 30.0) && near(falloffs[1].1, 30.0));
    // The projector: pi E scale on its axis (Mitsuba: a white plane 1 m away shows
    // radiance E scale), its frustum 0.2 degrees across, aimed down.
    let p = &s.lights[0];
    let proj = p.projector.clone().expect("a projector");
    assert!((p.intensity_w_per_sr[0] - std::f32::consts::PI * 200.0).abs() < 1e-3);
    assert!((proj.direction - Vec3::NEG_Z).length() < 1e-6);
    assert!((proj.tan_half_x - 0.1f32.to_radians().tan()).abs() < 1e-9);
    assert_eq!(p.position, Vec3::new(0.0, 0.0, 5.0));
    // A beam wider than its cutoff is refused, naming where.
    let e = refusal(
        &dir,
        "wide.xml",
        r#"<scene version="3.0.0"><shape type="rectangle">
        <emitter type="angulararea"><float name="cutoff_angle" value="10"/><float name="beam_width" value="20"/></emitter>
    </shape></scene>"#,
    );
    assert!(
        e.contains("wide.xml:2") && e.contains("wider than the cutoff"),
        "{e}"
    );
}

#[test]
fn older_nlos_files_aim_the_laser_from_the_meter_as_they_mean() {
    // As mitransient's examples/transient-nlos/nlos_Z.xml: the laser's origin, the film
    // pixel it looks at and confocal false on the capture meter; the projector at the
    // origin with no transform.
    let dir = tmp("nlos-z");
    let xml = write(
        &dir,
        "nlos_Z.xml",
        r#"<scene version="3.3.0">
    <integrator type="transient_nlos_path"><integer name="max_depth" value="-1"/></integrator>
    <shape type="rectangle"><transform name="to_world"><scale value="0.1"/><translate z="1"/></transform></shape>
    <emitter type="projector"><rgb name="irradiance" value="1"/><float name="fov" value="0.2"/></emitter>
    <shape type="rectangle" id="relay_wall">
        <sensor type="nlos_capture_meter">
            <sampler type="independent"><integer name="sample_count" value="64"/></sampler>
            <boolean name="confocal" value="false"/>
            <boolean name="account_first_and_last_bounces" value="false"/>
            <point name="sensor_origin" x="-0.5" y="0.0" z="0.25"/>
            <point name="laser_origin" x="-0.5" y="0.0" z="0.25"/>
            <point name="laser_lookat_pixel" x="16" y="24" z="0"/>
            <film type="transient_hdr_film">
                <integer name="width" value="32"/><integer name="height" value="32"/>
                <integer name="temporal_bins" value="300"/>
                <float name="bin_width_opl" value="0.01"/><float name="start_opl" value="0"/>
            </film>
        </sensor>
    </shape>
</scene>"#,
    );
    let (_, file) = scene::load_with_settings(&xml).unwrap();
    let n = file.nlos.expect("an NLOS capture scene");
    assert_eq!(n.laser_origin.unwrap().value, [-0.5, 0.0, 0.25]);
    // Pixel (16, 24) of 32 x 32 on the unit rectangle: (2 16.5 / 32 - 1, 2 24.5 / 32 - 1).
    let p = n.laser_point.unwrap().value;
    assert!((p[0] - 0.03125).abs() < 1e-12 && (p[1] - 0.53125).abs() < 1e-12 && p[2] == 0.0);
    assert_eq!(n.capture_type.unwrap().value, "single");
    // tprf nlos captures it with those, saying so, and no note calls them ignored.
    let out = dir.join("capture");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args([
            "nlos",
            &xml,
            "--out",
            out.to_str().unwrap(),
            "--grid",
            "4x4",
        ])
        .args(["--spp", "16", "--bins", "300"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("--laser-origin [-0.5, 0.0, 0.25]"), "{err}");
    assert!(
        err.contains("--laser-point [0.03125, 0.53125, 0.0]"),
        "{err}"
    );
    assert!(!err.contains("ignored"), "{err}");
}

#[test]
fn a_camera_watching_an_nlos_integrator_renders_with_tprf_render() {
    // As mitransient's examples/transient-nlos/nlos-z-simple.xml: a camera watches the
    // relay wall (z = 0) while a projector beside it lights one spot s; a square patch in
    // front of the wall is the hidden scene; the integrator leaves both devices' legs
    // out. A pixel seeing wall point x sees light that went s -> y -> x for y on the
    // patch (two points of the flat wall do not see each other): its first light at the
    // least |x - y| + |y - s| over the patch and the pixel's footprint, not before.
    let dir = tmp("nlos-camera");
    let xml = write(
        &dir,
        "nlos-camera.xml",
        r#"<scene version="2.1.0">
    <sensor type="perspective">
        <float name="fov" value="40"/><float name="near_clip" value="0.1"/>
        <transform name="to_world"><lookat origin="-1, 0, 1" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="256"/></sampler>
        <film type="transient_hdr_film">
            <integer name="width" value="8"/><integer name="height" value="8"/>
            <integer name="temporal_bins" value="300"/>
            <float name="bin_width_opl" value="0.01"/><float name="start_opl" value="0"/>
        </film>
    </sensor>
    <integrator type="transient_nlos_path">
        <boolean name="account_first_and_last_bounces" value="False"/>
        <integer name="capture_type" value="1"/>
    </integrator>
    <emitter type="projector">
        <rgb name="irradiance" value="100.0"/><float name="fov" value="0.2"/>
        <transform name="to_world"><lookat origin="-1, 0, 1" target="0.2, 0.1, 0" up="0, 1, 0"/></transform>
    </emitter>
    <shape type="rectangle" id="wall"><transform name="to_world"><scale value="2"/></transform></shape>
    <shape type="rectangle" id="hidden">
        <transform name="to_world"><scale value="0.2"/><rotate y="1" angle="180"/><translate x="0.8" z="0.5"/></transform>
    </shape>
</scene>"#,
    );
    let (s, file) = scene::load_with_settings(&xml).unwrap();
    use tprf_core::scene::{PulseOrigin, TimeOrigin};
    assert!(
        file.nlos.is_none(),
        "a camera's view is not a tprf nlos capture"
    );
    assert!(file.nlos_view);
    assert_eq!(
        file.time_origin.map(|o| o.value),
        Some(TimeOrigin::FirstHit)
    );
    assert_eq!(
        file.pulse_origin.map(|o| o.value),
        Some(PulseOrigin::FirstHit)
    );
    assert!(s.lights[0].projector.is_some());
    // The spot: where the projector's axis meets the wall (a spot of 2.5 mm: a point
    // here), and the power the projector puts into it: pi E 4 tan^2(0.1 deg) W.
    let light = &s.lights[0];
    let proj = light.projector.clone().unwrap();
    let (p, d) = (light.position, proj.direction);
    let spot = (p + d * (-p.z / d.z)).as_dvec3();
    let power = f64::from(light.intensity_w_per_sr[0])
        * 4.0
        * f64::from(proj.tan_half_x)
        * f64::from(proj.tan_half_y);
    let (w, h) = (8, 8);
    let axis = TimeAxis::new(0.0, 0.01 / C, 300).unwrap();
    // Three scattering events: the spot, the patch, the wall point the pixel sees.
    let settings = RenderSettings {
        time_origin: TimeOrigin::FirstHit,
        pulse_origin: PulseOrigin::FirstHit,
        adaptive: false,
        max_bounces: 3,
        ..RenderSettings::default()
    };
    let r = common::render_with(s.clone(), w, h, axis, 1024, settings, 0);
    // Worked out here: radiance at wall point x from the spot through the patch (every
    // surface the default diffuse 0.5, the patch [0.6, 1.0] x [-0.2, 0.2] at z = 0.5
    // facing the wall), L(x) = P (rho / pi)^3 sum_y cos_x cos_y cos_y' cos_s / (|x - y|^2
    // |y - s|^2) dA, arriving at |x - y| + |y - s| (both devices' legs left out); each
    // pixel the mean over its footprint (4 x 4 points), the patch in 2 cm cells.
    let rho_pi = 0.5 / std::f64::consts::PI;
    let eye = s.camera.position();
    let cell = 0.02;
    let patch: Vec<glam::DVec3> = (0..20)
        .flat_map(|i| (0..20).map(move |j| (i, j)))
        .map(|(i, j)| {
            glam::DVec3::new(
                0.6 + cell * (i as f64 + 0.5),
                -0.2 + cell * (j as f64 + 0.5),
                0.5,
            )
        })
        .collect();
    let (mut want_total, mut want_time, mut got_total, mut got_time) = (0.0, 0.0, 0.0, 0.0);
    for y in 0..h {
        for x in 0..w {
            for i in 0..4 {
                for j in 0..4 {
                    let (px, py) = (
                        x as f64 + (i as f64 + 0.5) / 4.0,
                        y as f64 + (j as f64 + 0.5) / 4.0,
                    );
                    let d = camera_dir(&s, px, py, w, h).as_dvec3();
                    let xw = eye.as_dvec3() + d * (-f64::from(eye.z) / d.z);
                    for q in &patch {
                        let (a, b) = (*q - xw, spot - *q);
                        let (la, lb) = (a.length(), b.length());
                        // Cosines at the wall (normal +z) and at the patch (normal -z).
                        let g = (a.z / la) * (a.z / la) * (b.z.abs() / lb) * (b.z.abs() / lb)
                            / (la * la * lb * lb);
                        let l = power * rho_pi.powi(3) * g * cell * cell / 16.0;
                        want_total += l;
                        want_time += l * (la + lb);
                    }
                }
            }
            let tprf = r.film.pixel_tprf(x, y);
            for (b, v) in tprf.iter().enumerate().skip(50) {
                got_total += v;
                got_time += v * (b as f64 + 0.5) * 0.01;
            }
            // Nothing between the spot seen directly (t = 0, both legs out) and the
            // patch's light (its least path is over 1.1 m for every pixel).
            assert!(
                tprf.iter().take(50).skip(1).all(|v| *v == 0.0),
                "pixel ({x}, {y}): light between the spot's direct return and the patch's"
            );
        }
    }
    let (want_mean, got_mean) = (want_time / want_total, got_time / got_total);
    eprintln!(
        "camera NLOS: image total {got_total:.4e} vs {want_total:.4e} worked out; mean arrival {got_mean:.4} m vs {want_mean:.4} m"
    );
    assert!(
        (got_total / want_total - 1.0).abs() < 0.06,
        "{got_total} vs {want_total}"
    );
    assert!(
        (got_mean - want_mean).abs() < 0.01,
        "{got_mean} m vs {want_mean} m"
    );
    // tprf render takes the file as it is.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args([
            "render",
            &xml,
            "--out",
            dir.join("r").to_str().unwrap(),
            "--spp",
            "4",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("--time-origin first-hit") && err.contains("--pulse-origin first-hit"),
        "{err}"
    );
    // tprf nlos leads to tprf render, not back to itself.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(["nlos", &xml, "--out", dir.join("n").to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("tprf render"), "{err}");
}

/// The XML of `n` shapes on a grid, each with an id: rectangles (even `i`) and cubes (odd
/// `i`), nine in ten sharing the BSDF `white` by `<ref>`, every tenth with a BSDF of its
/// own of reflectance `0.1 + 0.1 (i mod 7)`. Each shape takes four lines, the first of
/// shape `i` being line `3 + 4 i`.
fn many_shapes_xml(n: usize) -> String {
    let side = (n as f64).sqrt().ceil() as usize;
    let mut s = String::from(
        "<scene version=\"3.0.0\">\n  <bsdf type=\"diffuse\" id=\"white\"><rgb name=\"reflectance\" value=\"0.7\"/></bsdf>\n",
    );
    for i in 0..n {
        let (x, y) = ((i % side) as f64, (i / side) as f64);
        let kind = if i % 2 == 0 { "rectangle" } else { "cube" };
        let bsdf = if i % 10 == 3 {
            format!(
                "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{:.1}\"/></bsdf>",
                0.1 + 0.1 * (i % 7) as f64
            )
        } else {
            "<ref id=\"white\"/>".to_string()
        };
        s += &format!(
            "  <shape type=\"{kind}\" id=\"s{i}\">\n    <transform name=\"to_world\"><scale value=\"0.4\"/><translate x=\"{x}\" y=\"{y}\" z=\"0\"/></transform>\n    {bsdf}\n  </shape>\n"
        );
    }
    s + "</scene>\n"
}

/// 20 000 shapes load (32 s before loading was made linear; the speed is measured by
/// `cargo bench --bench mitsuba_load`, docs/benchmarks.md): every triangle there (2 per
/// rectangle, 12 per cube), every id an object with its own triangles where the grid
/// puts it, each tenth shape's own reflectance, and an error in the last shape named at
/// its line (the line index of a large file, counted here from the generator's layout).
#[test]
fn twenty_thousand_shapes_load_with_every_triangle_and_their_lines() {
    const N: usize = 20_000;
    let dir = tmp("many");
    let xml = many_shapes_xml(N);
    let path = write(&dir, "many.xml", &xml);
    let s = scene::load(&path).unwrap();
    assert_eq!(s.triangles.len(), (N / 2) * 2 + (N / 2) * 12);
    assert_eq!(s.objects.len(), N);
    let side = (N as f64).sqrt().ceil() as usize;
    for i in [0, 1, 3, 9_999, 13, N - 1] {
        let o = &s.objects[i];
        assert_eq!(o.name, format!("s{i}"));
        assert_eq!(o.triangles.len(), if i % 2 == 0 { 2 } else { 12 });
        // A rectangle spans [-1, 1]^2 and a cube [-1, 1]^3 before the 0.4 scale, then
        // the grid's translation.
        let (lo, hi) = object_bounds(&s, &o.name);
        let c = Vec3::new((i % side) as f32, (i / side) as f32, 0.0);
        assert!(
            ((lo + hi) * 0.5 - c).length() < 1e-4 && (hi.x - lo.x - 0.8).abs() < 1e-5,
            "{} at {lo} {hi}, expected around {c}",
            o.name
        );
        let m = &s.materials[s.attrs[o.triangles.start].material as usize];
        let rho = if i % 10 == 3 {
            0.1 + 0.1 * (i % 7) as f32
        } else {
            0.7
        };
        assert!(
            (m.base_color[0] - rho).abs() < 1e-6,
            "{} {:?}",
            o.name,
            m.base_color
        );
    }
    // The last shape made bad: its error names its line, 3 + 4 (N - 1).
    let bad = xml.replace(
        &format!("<shape type=\"cube\" id=\"s{}\">", N - 1),
        &format!("<shape type=\"hair\" id=\"s{}\">", N - 1),
    );
    let e = refusal(&dir, "bad.xml", &bad);
    assert!(e.contains(&format!("bad.xml:{}", 3 + 4 * (N - 1))), "{e}");
}

/// `tprf nlos` on an XML scene without a capture meter or a shape named `relay_wall`
/// speaks of the file's shape ids (not glTF nodes) and says how to choose the wall.
#[test]
fn nlos_on_xml_without_a_wall_names_the_shape_ids() {
    let dir = tmp("nlos-no-wall");
    let run = |xml: &str| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
            .args(["nlos", xml, "--out", dir.join("out").to_str().unwrap()])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let shapes = |ids: bool| {
        let id = |name: &str| {
            if ids {
                format!(" id=\"{name}\"")
            } else {
                String::new()
            }
        };
        format!(
            "<scene version=\"3.0.0\">\n  <shape type=\"rectangle\"{}/>\n  <shape type=\"cube\"{}><transform name=\"to_world\"><translate z=\"2\"/></transform></shape>\n</scene>\n",
            id("wall"),
            id("box")
        )
    };
    let e = run(&write(&dir, "ids.xml", &shapes(true)));
    for said in [
        "ids.xml",
        "<shape> with id=\"relay_wall\"",
        "shape ids: wall, box",
        "--relay-wall ID",
        "nlos_capture_meter",
    ] {
        assert!(e.contains(said), "'{said}' not said: {e}");
    }
    assert!(!e.contains("glTF"), "{e}");
    let e = run(&write(&dir, "no-ids.xml", &shapes(false)));
    assert!(
        e.contains("no-ids.xml") && e.contains("no <shape> in it has an id"),
        "{e}"
    );
    assert!(!e.contains("glTF"), "{e}");
    // With --relay-wall naming a shape id, the same file is captured.
    let xml = write(&dir, "ids2.xml", &shapes(true));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args([
            "nlos",
            &xml,
            "--relay-wall",
            "wall",
            "--grid",
            "2x2",
            "--spp",
            "4",
            "--out",
        ])
        .arg(dir.join("out2"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// mitransient's path filters of `transient_nlos_path` watched by a camera become the
/// render's bounce range, counted as mitransient's depth at its laser-sampled estimate
/// (the wall point, each hidden vertex and the spot): `discard_direct_paths` keeps paths
/// of 3 or more events, `filter_bounces b` exactly b + 1, `filter_depth d` exactly d.
#[test]
fn an_nlos_views_path_filters_become_its_bounce_range() {
    let dir = tmp("nlos-filters");
    let scene = |filters: &str| {
        format!(
            r#"<scene version="2.1.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="-1, 0, 1" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="transient_hdr_film">
            <integer name="width" value="8"/><integer name="height" value="8"/>
            <integer name="temporal_bins" value="30"/><float name="bin_width_opl" value="0.01"/>
        </film>
    </sensor>
    <integrator type="transient_nlos_path">{filters}</integrator>
    <emitter type="projector">
        <rgb name="irradiance" value="100.0"/><float name="fov" value="0.2"/>
        <transform name="to_world"><lookat origin="-1, 0, 1" target="0.2, 0.1, 0" up="0, 1, 0"/></transform>
    </emitter>
    <shape type="rectangle"><transform name="to_world"><scale value="2"/></transform></shape>
</scene>"#
        )
    };
    let range = |name: &str, filters: &str| {
        let xml = write(&dir, name, &scene(filters));
        let file = scene::file_settings(&xml).unwrap();
        (
            file.min_bounces.map(|s| s.value),
            file.max_bounces.map(|s| s.value),
        )
    };
    assert_eq!(range("none.xml", ""), (None, None));
    let off = r#"<boolean name="discard_direct_paths" value="false"/>"#;
    assert_eq!(range("off.xml", off), (None, None));
    let on = r#"<boolean name="discard_direct_paths" value="true"/>"#;
    assert_eq!(range("on.xml", on), (Some(3), None));
    let b = r#"<integer name="filter_bounces" value="2"/>"#;
    assert_eq!(range("b.xml", b), (Some(3), Some(3)));
    let d = r#"<integer name="filter_depth" value="4"/>"#;
    assert_eq!(range("d.xml", d), (Some(4), Some(4)));
    let both = write(&dir, "both.xml", &scene(&format!("{b}{d}")));
    let e = scene::file_settings(&both).unwrap_err().to_string();
    assert!(e.contains("filter_depth and filter_bounces"), "{e}");
    // The CLI applies them and says so; tprf.json records the floor.
    let out = dir.join("out");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(["render", &write(&dir, "on2.xml", &scene(on)), "--spp", "1"])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("--min-bounces 3"), "{err}");
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("tprf.json")).unwrap()).unwrap();
    assert_eq!(meta["min_bounces"], 3);
}

/// A projector's `bitmap` irradiance: the frustum takes the image's aspect (fov along x),
/// the 8-bit texels are decoded from sRGB; a texture other than a bitmap is refused
/// naming it.
#[test]
fn a_projectors_bitmap_sets_its_frustum_and_irradiance() {
    let dir = tmp("projector-bitmap");
    let mut png = image::RgbImage::new(4, 2);
    png.put_pixel(0, 0, image::Rgb([255, 255, 255]));
    png.put_pixel(3, 1, image::Rgb([128, 128, 128]));
    png.save(dir.join("pattern.png")).unwrap();
    let scene = |irradiance: &str| {
        format!(
            r#"<scene version="3.0.0">
    <emitter type="projector">
        {irradiance}
        <float name="fov" value="40"/><float name="scale" value="2"/>
        <transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform>
    </emitter>
    <shape type="rectangle"><transform name="to_world"><translate z="2"/></transform></shape>
</scene>"#
        )
    };
    let bitmap = r#"<texture type="bitmap" name="irradiance"><string name="filename" value="pattern.png"/></texture>"#;
    let s = scene::load(&write(&dir, "bitmap.xml", &scene(bitmap))).unwrap();
    let light = s.lights.iter().find(|l| l.projector.is_some()).unwrap();
    let p = light.projector.clone().unwrap();
    let tx = 20f32.to_radians().tan();
    assert!((p.tan_half_x - tx).abs() < 1e-6, "{}", p.tan_half_x);
    assert!((p.tan_half_y - tx / 2.0).abs() < 1e-6, "{}", p.tan_half_y);
    let im = p.image.expect("the image");
    assert_eq!((im.width, im.height), (4, 2));
    assert_eq!(im.rgb[0], [1.0; 3]);
    // sRGB 128 is linear ((128/255 + 0.055) / 1.055)^2.4 = 0.21586.
    assert!((im.rgb[7][0] - 0.215_861).abs() < 1e-5, "{:?}", im.rgb[7]);
    assert_eq!(im.rgb[1], [0.0; 3]);
    // The scale is the light's: pi scale on the axis per unit of the image.
    assert!((light.intensity_w_per_sr[0] - 2.0 * std::f32::consts::PI).abs() < 1e-5);
    let checker = r#"<texture type="checkerboard" name="irradiance"/>"#;
    let e = scene::load(&write(&dir, "checker.xml", &scene(checker)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("checkerboard") && e.contains("projector"), "{e}");
}

/// Mitsuba's one-sided BSDFs are black from behind: a camera and a point light above a
/// rectangle facing away from them see nothing of a bare `diffuse` (nor `roughplastic`,
/// `conductor`), and of a `twosided` one exactly what the rectangle shows from its
/// front: rho I / (pi h^2) cos^4-weighted, the same on both.
#[test]
fn one_sided_bsdfs_are_black_from_behind() {
    let dir = tmp("one-sided");
    let steady = |name: &str, flip: bool, bsdf: &str| {
        let rotate = if flip {
            r#"<rotate x="1" angle="180"/>"#
        } else {
            ""
        };
        let xml = write(
            &dir,
            name,
            &format!(
                r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 0, 2" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film>
    </sensor>
    <emitter type="point"><point name="position" x="0" y="0" z="2"/><rgb name="intensity" value="1"/></emitter>
    <shape type="rectangle">
        <transform name="to_world">{rotate}<scale value="3"/></transform>
        {bsdf}
    </shape>
</scene>"#
            ),
        );
        let s = scene::load(&xml).unwrap();
        common::steady_pixels(s, 4, 4, 16, 1).iter().sum::<f64>()
    };
    let diffuse = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>"#;
    let two = format!(r#"<bsdf type="twosided">{diffuse}</bsdf>"#);
    let front = steady("front.xml", false, diffuse);
    assert!(front > 0.0);
    assert_eq!(steady("back.xml", true, diffuse), 0.0);
    let two_back = steady("two-back.xml", true, &two);
    assert!(
        (two_back - front).abs() < 1e-3 * front,
        "{two_back} vs {front}"
    );
    for bsdf in [
        r#"<bsdf type="roughplastic"><float name="alpha" value="0.2"/></bsdf>"#,
        r#"<bsdf type="roughconductor"/>"#,
    ] {
        assert_eq!(steady("back-other.xml", true, bsdf), 0.0, "{bsdf}");
        assert!(steady("front-other.xml", false, bsdf) > 0.0, "{bsdf}");
    }
}

/// Mesh files and textures are decoded ahead in parallel batches (64 shapes at a time):
/// 150 OBJ files (three batches), each one triangle at `x = i` with its own texture
/// coordinates, load in file order with every triangle where its file puts it (worked
/// out here from the generator), and `flip_tex_coords` (true for OBJ unless given) as
/// each shape asks; a texture no shape uses is not read for errors (its file is
/// missing); a missing mesh file is reported for the first shape in file order that
/// names one, also when a later shape of the same batch names a missing file too.
#[test]
fn obj_files_decoded_ahead_load_in_file_order_with_the_first_error() {
    const N: usize = 150;
    let dir = tmp("ahead");
    let mut xml = String::from(
        "<scene version=\"3.0.0\">\n  <texture type=\"bitmap\" id=\"unused\"><string name=\"filename\" value=\"missing.png\"/></texture>\n",
    );
    for i in 0..N {
        write(
            &dir,
            &format!("m{i}.obj"),
            &format!(
                "v {i} 0 0\nv {} 0 0\nv {i} 1 0\nvt 0 0.25\nvt 1 0.25\nvt 0 1\nf 1/1 2/2 3/3\n",
                i + 1
            ),
        );
        let flip = if i % 3 == 0 {
            "<boolean name=\"flip_tex_coords\" value=\"false\"/>"
        } else {
            ""
        };
        xml += &format!(
            "  <shape type=\"obj\" id=\"s{i}\"><string name=\"filename\" value=\"m{i}.obj\"/>{flip}</shape>\n"
        );
    }
    xml += "</scene>\n";
    let path = write(&dir, "ahead.xml", &xml);
    let s = scene::load(&path).unwrap();
    assert_eq!(s.triangles.len(), N);
    for i in 0..N {
        let o = &s.objects[i];
        assert_eq!(o.name, format!("s{i}"));
        let t = &s.triangles[o.triangles.start];
        let x = i as f32;
        assert_eq!(
            t.p,
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0)
            ],
            "s{i}"
        );
        let uv = s.attrs[o.triangles.start].uv;
        let v0 = if i % 3 == 0 { 0.25 } else { 0.75 };
        assert!((uv[0].y - v0).abs() < 1e-6, "s{i}: {uv:?}");
    }
    // Shapes 70 and 100 (the second batch) name missing files: the error is 70's.
    let bad = xml
        .replace("\"m70.obj\"", "\"gone70.obj\"")
        .replace("\"m100.obj\"", "\"gone100.obj\"");
    let e = refusal(&dir, "bad.xml", &bad);
    assert!(e.contains("gone70.obj") && !e.contains("gone100"), "{e}");
}

/// Mitsuba's `stokes` integrator around a transient one (mitransient's polarized
/// examples) asks for a polarized render: the file's settings say so, with the wrapped
/// integrator's own (`max_depth`) still read; `tprf render` writes the Stokes cube; a
/// `stokes` with nothing inside is refused at its line.
#[test]
fn a_stokes_integrator_renders_polarized() {
    let dir = tmp("stokes");
    let wrapped = BY_HAND.replace(
        r#"<integrator type="transient_path">
        <integer name="max_depth" value="4"/>
    </integrator>"#,
        r#"<integrator type="stokes">
        <integrator type="transient_path">
            <integer name="max_depth" value="4"/>
        </integrator>
    </integrator>"#,
    );
    assert_ne!(wrapped, BY_HAND, "the integrator was not replaced");
    let path = write(&dir, "stokes.xml", &wrapped);
    let settings = scene::file_settings(&path).unwrap();
    assert_eq!(settings.polarized.map(|s| s.value), Some(true));
    assert_eq!(settings.max_bounces.map(|s| s.value), Some(3));
    let plain = scene::file_settings(&write(&dir, "plain.xml", BY_HAND)).unwrap();
    assert_eq!(plain.polarized, None);
    let out = dir.join("out");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(["render", &path, "--spp", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("--polarized true"), "{stderr}");
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("tprf.json")).unwrap()).unwrap();
    assert_eq!(meta["polarized"], serde_json::json!(true));
    assert!(out.join("tprf_stokes.npy").is_file());
    let empty = wrapped.replace(
        r#"<integrator type="transient_path">
            <integer name="max_depth" value="4"/>
        </integrator>"#,
        "",
    );
    let why = refusal(&dir, "empty.xml", &empty);
    assert!(
        why.contains("stokes") && why.contains("needs the integrator it wraps"),
        "{why}"
    );
}

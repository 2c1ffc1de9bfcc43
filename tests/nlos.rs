//! NLOS captures against answers derived here, independently of the renderer: a small
//! hidden Lambertian patch's first return (time and three-bounce amplitude, by
//! quadrature over the patch), the scan's geometry, the files round trip, and bad inputs
//! refused with messages naming them. `tal_reads_our_capture` reads `nlos.hdf5` with
//! tal itself (pip's `y-tal` and `h5py`, installed into a venv under target/ where pip
//! can; skipped with a note where it cannot).

mod common;

use common::{C, empty_scene, push_tri};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use tprf_core::nlos::capture::{Progress, render_capture};
use tprf_core::nlos::files::{read_capture, write_capture_folder};
use tprf_core::nlos::{CaptureSettings, NlosError, Scan};
use tprf_core::scene::{Camera, Material, Scene, SceneObject};

const RHO_WALL: f32 = 0.9;
const RHO_PATCH: f32 = 0.5;

/// A 2 m x 2 m wall at z = 0 facing +z (object `relay_wall`) and a square patch of side
/// `side_m` centred at `center`, facing the unit normal `normal` (object `patch`).
fn patch_scene(center: Vec3, normal: Vec3, side_m: f32) -> Scene {
    let mut s = empty_scene(Camera::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.8));
    s.materials = vec![
        Material::lambertian("wall", [RHO_WALL; 3]),
        Material::lambertian("patch", [RHO_PATCH; 3]),
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
    let [a, b] = patch_axes(normal);
    let h = 0.5 * side_m;
    let q = [
        center - a * h - b * h,
        center + a * h - b * h,
        center + a * h + b * h,
        center - a * h + b * h,
    ];
    push_tri(&mut s, [q[0], q[1], q[2]], 1);
    push_tri(&mut s, [q[0], q[2], q[3]], 1);
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

fn patch_axes(normal: Vec3) -> [Vec3; 2] {
    let a = normal.cross(Vec3::Y).normalize();
    [a, normal.cross(a).normalize()]
}

/// The three-bounce radiance leaving wall point `s` toward the SPAD, summed over time,
/// for a unit pulse at laser point `l`: the patch's area integral of
/// `(rho_w/pi) cos_s cos_xs / d_s^2 (rho_p/pi) cos_xl (rho_w/pi) cos_l / d_l^2`,
/// by a 200 x 200 midpoint rule; and the mean and least optical path `d_l + d_s`.
fn expected(center: Vec3, normal: Vec3, side_m: f32, l: Vec3, s: Vec3) -> (f64, f64, f64) {
    let [a, b] = patch_axes(normal);
    let n = 200;
    let cell = side_m as f64 / n as f64;
    let (mut sum, mut weighted_path, mut least) = (0.0f64, 0.0f64, f64::INFINITY);
    let pi = std::f64::consts::PI;
    for i in 0..n {
        for j in 0..n {
            let fa = (i as f64 + 0.5) * cell - 0.5 * side_m as f64;
            let fb = (j as f64 + 0.5) * cell - 0.5 * side_m as f64;
            let x = center.as_dvec3() + a.as_dvec3() * fa + b.as_dvec3() * fb;
            let (ds, dl) = (s.as_dvec3() - x, l.as_dvec3() - x);
            let (rs, rl) = (ds.length(), dl.length());
            let cos_s = (-ds.z / rs).max(0.0); // wall normal +z, direction s -> x
            let cos_l = (-dl.z / rl).max(0.0);
            let nx = normal.as_dvec3();
            let cos_xs = (ds.dot(nx) / rs).max(0.0);
            let cos_xl = (dl.dot(nx) / rl).max(0.0);
            let rw = RHO_WALL as f64 / pi;
            let rp = RHO_PATCH as f64 / pi;
            let v = rw * cos_s * cos_xs / (rs * rs) * rp * cos_xl * rw * cos_l / (rl * rl)
                * cell
                * cell;
            sum += v;
            weighted_path += v * (rs + rl);
            least = least.min(rs + rl);
        }
    }
    (sum, weighted_path / sum, least)
}

fn settings(scan: Scan) -> CaptureSettings {
    CaptureSettings {
        grid: [5, 4],
        scan,
        dt_s: 0.004 / C,
        bins: Some(800),
        spp: 4096,
        max_bounces: 1,
        ..CaptureSettings::default()
    }
}

fn capture(scene: Scene, settings: &CaptureSettings) -> tprf_core::nlos::Capture {
    render_capture(Arc::new(scene), settings, &Progress::default()).unwrap()
}

/// Checks a capture of the patch scene against [`expected`]: per (laser, sensor) pair,
/// the transient's sum within 2 % (the area-sampled estimate of a flat patch has little
/// noise), its mean arrival within one bin of the mean path, and its first non-zero bin
/// the one holding the least path.
fn check_patch(c: &tprf_core::nlos::Capture, center: Vec3, normal: Vec3, side: f32) {
    let g = &c.geometry;
    let dt_m = g.axis.dt_s * C;
    let mut checked = 0;
    for (si, s) in g.sensors.iter().enumerate() {
        let lasers = g.lasers_of(si);
        for (li, l) in lasers.iter().enumerate() {
            let k = if g.is_confocal() { 0 } else { li };
            let h = c.transient(k, si);
            let (sum, mean_path, least) = expected(center, normal, side, l.position, s.position);
            let legs = g.legs_m(l.position, s.position);
            let got: f64 = h.iter().map(|&v| v as f64).sum();
            assert!(
                (got - sum).abs() <= 0.02 * sum,
                "sensor {si} laser {li}: sum {got:e}, expected {sum:e}"
            );
            let mean_bin: f64 = h
                .iter()
                .enumerate()
                .map(|(b, &v)| (b as f64 + 0.5) * v as f64)
                .sum::<f64>()
                / got;
            let mean_m = g.axis.t0_s * C + mean_bin * dt_m;
            assert!(
                (mean_m - (mean_path + legs)).abs() <= dt_m,
                "sensor {si} laser {li}: mean arrival {mean_m} m, expected {} m",
                mean_path + legs
            );
            let first = h.iter().position(|&v| v > 0.0).unwrap();
            let want = ((least + legs - g.axis.t0_s * C) / dt_m).floor() as usize;
            assert!(
                first.abs_diff(want) <= 1,
                "sensor {si} laser {li}: first return in bin {first}, the least path {} m is in bin {want}",
                least + legs
            );
            checked += 1;
        }
    }
    assert!(checked >= 20);
}

#[test]
fn confocal_patch_returns_at_the_analytic_time_with_the_three_bounce_amplitude() {
    let (center, normal, side) = (
        Vec3::new(0.15, -0.1, 0.7),
        Vec3::new(-0.2, 0.1, -1.0).normalize(),
        0.02,
    );
    let set = CaptureSettings {
        device_legs: false,
        ..settings(Scan::Confocal)
    };
    let c = capture(patch_scene(center, normal, side), &set);
    assert!(c.geometry.is_confocal());
    check_patch(&c, center, normal, side);
}

#[test]
fn exhaustive_patch_with_device_legs_returns_at_the_analytic_time() {
    let (center, normal, side) = (
        Vec3::new(-0.2, 0.2, 0.9),
        Vec3::new(0.1, -0.1, -1.0).normalize(),
        0.02,
    );
    let set = CaptureSettings {
        device_legs: true,
        laser_origin: Some([0.4, 0.1, 0.6]),
        sensor_origin: Some([-0.6, 0.0, 0.3]),
        spp: 2048,
        // The legs add up to 2 m: a 6 m axis.
        bins: Some(1500),
        ..settings(Scan::Exhaustive { lx: 2, ly: 3 })
    };
    let c = capture(patch_scene(center, normal, side), &set);
    assert_eq!(c.shape(), vec![1500, 2, 3, 5, 4]);
    check_patch(&c, center, normal, side);
}

#[test]
fn a_capture_is_the_same_for_any_thread_count() {
    let scene = tprf_core::scene::load("builtin:nlos-z").unwrap();
    let set = CaptureSettings {
        grid: [4, 4],
        spp: 64,
        scan: Scan::Confocal,
        ..CaptureSettings::default()
    };
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| capture(scene.clone(), &set)).h
    };
    let one = run(1);
    assert_eq!(one, run(3));
    assert!(one.iter().any(|&v| v > 0.0));
}

#[test]
fn the_scan_follows_tal_conventions() {
    let scene = tprf_core::scene::load("builtin:nlos-z").unwrap();
    let set = CaptureSettings {
        grid: [4, 2],
        spp: 1,
        scan: Scan::Single { laser_point: None },
        ..CaptureSettings::default()
    };
    let g = tprf_core::nlos::setup::resolve(&scene, &set).unwrap();
    // tal's wall: z = 0, normal +z, u = +x, v = +y; cell centres, x-major.
    assert!((g.wall.normal - Vec3::Z).length() < 1e-6);
    assert!((g.wall.u_axis - Vec3::X).length() < 1e-6);
    let p = |k: usize| g.sensors[k].position;
    assert!((p(0) - Vec3::new(-0.75, -0.5, 0.0)).length() < 1e-6);
    assert!((p(1) - Vec3::new(-0.75, 0.5, 0.0)).length() < 1e-6);
    assert!((p(2) - Vec3::new(-0.25, -0.5, 0.0)).length() < 1e-6);
    assert!((g.lasers[0].position - Vec3::ZERO).length() < 1e-6);
    assert!((g.laser_origin - Vec3::new(-0.5, 0.0, 0.25)).length() < 1e-6);
    // The default axis reaches the longest three-bounce path (brute force over every
    // sensor point and hidden vertex; the code takes the grid's corners).
    let confocal = tprf_core::nlos::setup::resolve(
        &scene,
        &CaptureSettings {
            scan: Scan::Confocal,
            ..set.clone()
        },
    )
    .unwrap();
    let mut longest = 0.0f64;
    for t in &scene.triangles[2..] {
        for x in t.p {
            for s in &confocal.sensors {
                longest = longest.max(2.0 * (s.position - x).length() as f64);
            }
        }
    }
    let end_m = confocal.axis.end_s() * C;
    assert!(
        end_m >= longest - 1e-5 && end_m < longest + 0.0031,
        "{end_m} vs {longest}"
    );
}

fn message(r: Result<impl std::fmt::Debug, NlosError>) -> String {
    r.expect_err("expected a refusal").to_string()
}

#[test]
fn bad_inputs_are_refused_naming_them() {
    let scene = patch_scene(Vec3::new(0.0, 0.0, 0.5), Vec3::NEG_Z, 0.1);
    let resolve = |s: &Scene, set: &CaptureSettings| tprf_core::nlos::setup::resolve(s, set);
    // No relay wall.
    let m = message(resolve(
        &scene,
        &CaptureSettings {
            relay_wall: "wall".into(),
            ..settings(Scan::Confocal)
        },
    ));
    assert!(
        m.contains("no relay wall") && m.contains("'wall'") && m.contains("--relay-wall"),
        "{m}"
    );
    assert!(m.contains("relay_wall, patch"), "{m}");
    // A wall that is not planar.
    let mut bent = scene.clone();
    bent.triangles[1].p[2].z = 0.05;
    let m = message(resolve(&bent, &settings(Scan::Confocal)));
    assert!(m.contains("'relay_wall' is not planar"), "{m}");
    // A grid of 0.
    let m = message(resolve(
        &scene,
        &CaptureSettings {
            grid: [0, 8],
            ..settings(Scan::Confocal)
        },
    ));
    assert!(m.contains("--grid 0x8"), "{m}");
    let m = message(resolve(
        &scene,
        &settings(Scan::Exhaustive { lx: 3, ly: 0 }),
    ));
    assert!(m.contains("--laser-grid 3x0"), "{m}");
    // Devices behind the wall, a laser point off it, nothing hidden.
    let m = message(resolve(
        &scene,
        &CaptureSettings {
            sensor_origin: Some([0.0, 0.0, -1.0]),
            ..settings(Scan::Confocal)
        },
    ));
    assert!(
        m.contains("--sensor-origin") && m.contains("behind the relay wall"),
        "{m}"
    );
    let m = message(resolve(
        &scene,
        &settings(Scan::Single {
            laser_point: Some([3.0, 0.0, 0.0]),
        }),
    ));
    assert!(
        m.contains("--laser-point") && m.contains("not on the relay wall"),
        "{m}"
    );
    let mut bare = scene.clone();
    bare.triangles.truncate(2);
    bare.attrs.truncate(2);
    bare.objects.truncate(1);
    let m = message(resolve(&bare, &settings(Scan::Confocal)));
    assert!(m.contains("no hidden geometry"), "{m}");
    let m = message(resolve(
        &scene,
        &CaptureSettings {
            spp: 0,
            ..settings(Scan::Confocal)
        },
    ));
    assert!(m.contains("--spp 0"), "{m}");
}

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tprf-nlos-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn the_files_round_trip() {
    let scene = tprf_core::scene::load("builtin:nlos-z").unwrap();
    for scan in [
        Scan::Confocal,
        Scan::Exhaustive { lx: 2, ly: 2 },
        Scan::Single { laser_point: None },
    ] {
        let set = CaptureSettings {
            grid: [6, 4],
            spp: 8,
            scan,
            device_legs: matches!(scan, Scan::Confocal),
            ..CaptureSettings::default()
        };
        let c = capture(scene.clone(), &set);
        let dir = out_dir("roundtrip");
        write_capture_folder(&c, &dir, &[]).unwrap();
        let r = read_capture(&dir).unwrap();
        assert_eq!(r.h, c.h);
        assert_eq!(r.h_shape, c.shape());
        assert_eq!(r.exhaustive, matches!(scan, Scan::Exhaustive { .. }));
        assert_eq!(r.is_confocal(), matches!(scan, Scan::Confocal));
        assert_eq!(r.device_legs, set.device_legs);
        assert!((r.delta_t_m - 0.003).abs() < 1e-12);
        assert_eq!(r.sensor_shape, [6, 4]);
        let positions: Vec<Vec3> = c.geometry.sensors.iter().map(|p| p.position).collect();
        assert_eq!(r.sensor_grid, positions);
        let (shape, npy) = tprf_core::export::read_npy_f32(&dir.join("H.npy")).unwrap();
        assert_eq!(npy, c.h);
        assert_eq!(
            shape.iter().map(|&d| d as usize).collect::<Vec<_>>(),
            c.shape()
        );
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("nlos.json")).unwrap()).unwrap();
        assert_eq!(json["delta_t_m"].as_f64().unwrap(), r.delta_t_m);
        // The capture in memory reads as its folder does (what Python reconstructs).
        let m = tprf_core::nlos::files::LoadedCapture::of(&c, dir.clone());
        assert_eq!(
            (
                &m.h,
                &m.h_shape,
                m.exhaustive,
                m.sensor_shape,
                m.laser_shape
            ),
            (
                &r.h,
                &r.h_shape,
                r.exhaustive,
                r.sensor_shape,
                r.laser_shape
            )
        );
        assert_eq!(
            (&m.sensor_grid, &m.laser_grid),
            (&r.sensor_grid, &r.laser_grid)
        );
        assert_eq!(
            (m.sensor_normal, m.sensor_xyz, m.laser_xyz),
            (r.sensor_normal, r.sensor_xyz, r.laser_xyz)
        );
        assert_eq!(
            (m.delta_t_m.to_bits(), m.t_start_m.to_bits(), m.device_legs),
            (r.delta_t_m.to_bits(), r.t_start_m.to_bits(), r.device_legs)
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn the_builtin_wall_survives_a_gltf_round_trip() {
    let scene = tprf_core::scene::load("builtin:nlos-shapes").unwrap();
    let dir = out_dir("gltf");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("shapes.gltf");
    tprf_core::scene::gltf_save::save_gltf(&scene, &path).unwrap();
    let back = tprf_core::scene::load(path.to_str().unwrap()).unwrap();
    let a = tprf_core::nlos::RelayWall::find(&scene, "relay_wall").unwrap();
    let b = tprf_core::nlos::RelayWall::find(&back, "relay_wall").unwrap();
    assert_eq!(a.triangles.len(), b.triangles.len());
    assert!((a.normal - b.normal).length() < 1e-6 && (a.corner - b.corner).length() < 1e-6);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A Python with h5py and tal (pip's y-tal): the venv under target/ tests share, made
/// and filled on first use; `None`, with a note, where that cannot be done.
fn tal_python() -> Option<PathBuf> {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target"));
    let venv = target.join("nlos-venv");
    let python = venv.join("bin/python");
    let ok = |p: &Path| {
        Command::new(p)
            .args(["-c", "import h5py, tal"])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if ok(&python) {
        return Some(python);
    }
    if !python.exists() {
        let made = Command::new("python3")
            .arg("-m")
            .arg("venv")
            .arg(&venv)
            .status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("note: skipped reading nlos.hdf5 with tal: python3 -m venv failed");
            return None;
        }
    }
    let pip = Command::new(&python)
        .args([
            "-m",
            "pip",
            "install",
            "-q",
            "--disable-pip-version-check",
            "y-tal",
            "h5py",
        ])
        .status();
    if !pip.is_ok_and(|s| s.success()) || !ok(&python) {
        eprintln!("note: skipped reading nlos.hdf5 with tal: pip could not install y-tal and h5py");
        return None;
    }
    Some(python)
}

#[test]
fn tal_reads_our_capture() {
    let Some(python) = tal_python() else {
        return;
    };
    let scene = tprf_core::scene::load("builtin:nlos-z").unwrap();
    for (scan, legs) in [
        (Scan::Confocal, false),
        (Scan::Exhaustive { lx: 2, ly: 3 }, true),
        (Scan::Single { laser_point: None }, false),
    ] {
        let set = CaptureSettings {
            grid: [6, 4],
            spp: 8,
            scan,
            device_legs: legs,
            ..CaptureSettings::default()
        };
        let c = capture(scene.clone(), &set);
        let dir = out_dir("tal");
        write_capture_folder(&c, &dir, &[]).unwrap();
        let script = r#"
import sys, numpy as np, h5py, tal
d = sys.argv[1]
c = tal.io.read_capture(d + '/nlos.hdf5')
H = np.load(d + '/H.npy')
assert c.H.dtype == np.float32 and c.H.shape == H.shape and np.array_equal(c.H, H), (c.H.shape, H.shape)
want = sys.argv[2]
assert c.H_format.name == want, c.H_format
assert c.sensor_grid_format.name == 'X_Y_3' and c.laser_grid_format.name == 'X_Y_3'
assert c.sensor_grid_xyz.shape == (6, 4, 3), c.sensor_grid_xyz.shape
assert np.allclose(c.sensor_grid_normals[..., 2], 1.0)
assert abs(float(c.delta_t) - 0.003) < 1e-9 and float(c.t_start) == 0.0
assert bool(c.t_accounts_first_and_last_bounces) == (sys.argv[3] == 'True')
assert c.is_confocal() == (sys.argv[4] == 'confocal'), c.is_confocal()
assert np.allclose(c.sensor_xyz, [-0.5, 0, 0.25]) and np.allclose(c.laser_xyz, [-0.5, 0, 0.25])
assert c.scene_info['original_format'] == 'tprf' and c.scene_info['tprf']['scene'] == 'builtin:nlos-z', c.scene_info
print('ok')
"#;
        let kind = match scan {
            Scan::Confocal => "confocal",
            Scan::Exhaustive { .. } => "exhaustive",
            Scan::Single { .. } => "single",
        };
        let want = if kind == "exhaustive" {
            "T_Lx_Ly_Sx_Sy"
        } else {
            "T_Sx_Sy"
        };
        let out = Command::new(&python)
            .args([
                "-c",
                script,
                dir.to_str().unwrap(),
                want,
                if legs { "True" } else { "False" },
                kind,
            ])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{kind}: tal could not read the capture:\n{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn a_spad_measures_a_capture_as_its_expected_photon_counts() {
    let scene = tprf_core::scene::load("builtin:nlos-z").unwrap();
    let bins = 1400;
    let set = CaptureSettings {
        grid: [4, 3],
        spp: 64,
        scan: Scan::Confocal,
        bins: Some(bins),
        ..CaptureSettings::default()
    };
    let c = capture(scene, &set);
    let dir = out_dir("spad-in");
    write_capture_folder(&c, &dir, &[]).unwrap();
    // A delta pulse and TDC bins equal to the capture's: the SPAD's rate in bin k is
    // pde photons_per_unit H_k, kept below 0.01 per cycle so that N (1 - e^-r) = N r
    // within 0.5 % (no dead time: no pile-up).
    let (pde, cycles) = (0.5, 1000.0);
    let max_h = c.h.iter().copied().fold(0.0f32, f32::max) as f64;
    let ppu = 0.01 / (pde * max_h);
    let preset = dir.with_extension("toml");
    std::fs::write(
        &preset,
        format!(
            "name = \"test\"\n[light]\nkind = \"delta\"\n[exposure]\nkind = \"tdc\"\nstart = \"0 s\"\n\
             bin_width = \"{:e} s\"\nbins = {bins}\n[noise]\nseed = 3\n[spad]\ncycles = {cycles}\n\
             pde = {pde}\nphotons_per_unit = {ppu:e}\n",
            0.003 / C
        ),
    )
    .unwrap();
    let out = out_dir("spad-out");
    let run = Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args([
            "nlos",
            "spad",
            dir.to_str().unwrap(),
            "--preset",
            preset.to_str().unwrap(),
        ])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let counts = read_capture(&out).unwrap();
    assert_eq!(counts.h_shape, c.shape());
    assert!((counts.delta_t_m - 0.003).abs() < 1e-9 && counts.t_start_m.abs() < 1e-9);
    let (_, expected) = tprf_core::export::read_npy_f32(&out.join("spad_histogram.npy")).unwrap();
    let k = 12;
    for s in 0..k {
        let h: Vec<f64> = (0..bins).map(|t| c.h[t * k + s] as f64).collect();
        let e: Vec<f64> = (0..bins).map(|t| expected[t * k + s] as f64).collect();
        let n: Vec<f64> = (0..bins).map(|t| counts.h[t * k + s] as f64).collect();
        let want = cycles * pde * ppu * h.iter().sum::<f64>();
        let got = e.iter().sum::<f64>();
        assert!(
            (got - want).abs() <= 0.006 * want,
            "sensor {s}: expected counts {got}, {want} from H"
        );
        let argmax = |v: &[f64]| (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap();
        assert_eq!(
            argmax(&e),
            argmax(&h),
            "sensor {s}: the histogram's peak bin"
        );
        let drawn = n.iter().sum::<f64>();
        assert!(
            (drawn - got).abs() <= 5.0 * got.sqrt() + 1.0,
            "sensor {s}: {drawn} counts drawn, {got} expected"
        );
        assert!(n.iter().all(|&x| x >= 0.0 && x.fract() == 0.0));
    }
    for d in [&dir, &out] {
        std::fs::remove_dir_all(d).unwrap();
    }
    std::fs::remove_file(preset).unwrap();
}

/// A capture with a NaN (and an infinity after it) in `H` is refused where it is read,
/// naming the dataset and the first bad value's index, worked out here from the shape
/// `[T, Sx, Sy]`; `tprf nlos reconstruct` on it exits with that error instead of a volume
/// of NaN. The same capture without them reads.
#[test]
fn a_non_finite_capture_is_refused_naming_the_dataset_and_index() {
    let scene = tprf_core::scene::load("builtin:nlos-z").unwrap();
    let set = CaptureSettings {
        grid: [6, 4],
        spp: 2,
        ..CaptureSettings::default()
    };
    let mut c = capture(scene, &set);
    let shape = c.shape();
    assert_eq!(&shape[1..], &[6, 4]);
    let (t, i, j) = (5, 2, 3);
    c.h[(t * 6 + i) * 4 + j] = f32::NAN;
    c.h[(t * 6 + i) * 4 + j + 7] = f32::INFINITY;
    let dir = out_dir("nan");
    write_capture_folder(&c, &dir, &[]).unwrap();
    let m = message(read_capture(&dir));
    assert!(
        m.contains("nlos.hdf5") && m.contains("H[5, 2, 3] is NaN") && m.contains("2 of its"),
        "{m}"
    );
    let out = dir.with_extension("volume");
    let o = Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(["nlos", "reconstruct", dir.to_str().unwrap(), "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("H[5, 2, 3] is NaN"), "{err}");
    assert!(!out.exists());
    c.h.iter_mut().for_each(|v| {
        if !v.is_finite() {
            *v = 0.0;
        }
    });
    write_capture_folder(&c, &dir, &[]).unwrap();
    assert!(read_capture(&dir).is_ok());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Scans too large to hold are refused before any wall point is made, naming the flags
/// and the size foreseen: over [`tprf_core::nlos::setup::MAX_TRANSIENTS`] (the issue's
/// `--grid 100000x100000`, which aborted allocating 120 GB, and an exhaustive
/// `--laser-grid 100000x100000`). (Under it but larger than memory: tests/hostile.rs,
/// under `ulimit -v`.)
#[test]
fn absurd_grids_are_refused_with_their_size() {
    let scene = patch_scene(Vec3::new(0.0, 0.0, 0.5), Vec3::NEG_Z, 0.1);
    let resolve = |set: &CaptureSettings| tprf_core::nlos::setup::resolve(&scene, set);
    let m = message(resolve(&CaptureSettings {
        grid: [100_000, 100_000],
        ..settings(Scan::Confocal)
    }));
    // 1e10 sensor points, as many laser points (confocal), 36 B each: 670.6 GiB; the
    // transients 8 B a bin: 74.5 GiB per bin.
    assert!(
        m.contains("--grid 100000x100000")
            && m.contains("10.0 G transients")
            && m.contains("670.6 GiB")
            && m.contains("74.5 GiB for each time bin"),
        "{m}"
    );
    let m = message(resolve(&settings(Scan::Exhaustive {
        lx: 100_000,
        ly: 100_000,
    })));
    // 5 x 4 sensor points x 1e10 laser points.
    assert!(
        m.contains("--grid 5x4 --laser-grid 100000x100000") && m.contains("200.0 G transients"),
        "{m}"
    );
}

//! The ambient steady image against independent answers: a plane under a sun (rho E cos /
//! pi), a plane under a constant sky (rho L), a lamp tagged ambient against the pulsed
//! render's steady image of the same lamp; the TPRF does not see the ambient group; the
//! image does not depend on the thread count.

mod common;

use common::{empty_scene, push_tri, render_scene};
use glam::Vec3;
use std::sync::Arc;
use tprf_core::film::TimeAxis;
use tprf_core::scene::{self, Camera, DirectionalLight, Material, PunctualLight, Scene};
use tprf_core::transport::ambient::render_ambient;
use tprf_core::transport::{RenderSettings, Renderer};

/// A Lambertian square `z = 0` of half-size 10 m, albedo `rho`, seen from 1 m above
/// through a 30 degree field of view (every pixel sees it).
fn plane(rho: f32) -> Scene {
    let cam = Camera::look_at(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO, 30f32.to_radians());
    let mut s = empty_scene(cam);
    s.materials.push(Material::lambertian("plane", [rho; 3]));
    let h = 10.0;
    let q = [
        Vec3::new(-h, -h, 0.0),
        Vec3::new(h, -h, 0.0),
        Vec3::new(h, h, 0.0),
        Vec3::new(-h, h, 0.0),
    ];
    push_tri(&mut s, [q[0], q[1], q[2]], 0);
    push_tri(&mut s, [q[0], q[2], q[3]], 0);
    s
}

fn sun(direction: Vec3, e_w_per_m2: f32) -> DirectionalLight {
    DirectionalLight {
        name: "sun".into(),
        direction: direction.normalize(),
        irradiance_w_per_m2: [e_w_per_m2; 3],
    }
}

fn ambient_image(scene: Scene, w: usize, h: usize, spp: u32, seed: u64) -> Vec<f32> {
    scene.validate().unwrap();
    let settings = RenderSettings {
        seed,
        ..Default::default()
    };
    let r = Renderer::new(Arc::new(scene), settings);
    let img = render_ambient(&r, w, h, spp);
    assert_eq!(img.radiance.len(), w * h);
    assert_eq!(img.non_finite, 0);
    img.radiance
}

#[test]
fn plane_under_a_sun_has_radiance_rho_e_cos_over_pi() {
    let (rho, e) = (0.6f32, 2.5f32);
    for (dir, cos) in [
        (Vec3::NEG_Z, 1.0f32),
        (Vec3::new(0.75f32.sqrt(), 0.0, -0.5), 0.5),
    ] {
        let mut s = plane(rho);
        s.ambient.directional.push(sun(dir, e));
        let img = ambient_image(s, 8, 8, 4, 1);
        let want = rho * e * cos / std::f32::consts::PI;
        for v in img {
            assert!((v - want).abs() <= 1e-5 * want, "{v} vs {want}");
        }
    }
}

#[test]
fn plane_under_a_constant_sky_has_radiance_rho_l() {
    let (rho, l) = (0.5f32, 3.0f32);
    let mut s = plane(rho);
    s.ambient.sky_radiance = [l; 3];
    let img = ambient_image(s, 8, 8, 16, 2);
    for v in img {
        // One bounce, cosine-sampled: every path carries exactly rho L.
        assert!((v - rho * l).abs() <= 1e-5 * rho * l, "{v} vs {}", rho * l);
    }
}

#[test]
fn the_sky_seen_directly_is_its_radiance() {
    // No geometry in view: the camera looks away from the plane.
    let mut s = plane(0.5);
    s.camera = Camera::look_at(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, 2.0), 0.5);
    s.ambient.sky_radiance = [0.25; 3];
    for v in ambient_image(s, 4, 4, 2, 0) {
        assert_eq!(v, 0.25);
    }
}

/// The Cornell box with its lamp in the ambient group: the ambient image is the pulsed
/// render's steady image (the sum over bins of the TPRF, on a window that holds all
/// light) of the same lamp, within noise.
#[test]
fn a_lamp_tagged_ambient_gives_the_pulsed_steady_image() {
    let pulsed = scene::load("builtin:cornell").unwrap();
    let mut ambient = pulsed.clone();
    ambient.ambient.lights = std::mem::take(&mut ambient.lights);
    let (w, h, spp) = (12, 12, 256);
    let r = Renderer::new(
        Arc::new(ambient),
        RenderSettings {
            seed: 5,
            ..Default::default()
        },
    );
    let img = render_ambient(&r, w, h, spp);
    let a = img.radiance;
    // 1 us (300 m of optical path, ~500 box crossings) holds all light.
    let axis = TimeAxis::new(0.0, 1e-6 / 64.0, 64).unwrap();
    let film = render_scene(pulsed, w, h, axis, spp as u64, 9, 0).film;
    let steady = film.steady();
    let (sa, sp): (f64, f64) = (a.iter().map(|&v| v as f64).sum(), steady.iter().sum());
    let rel = (sa - sp).abs() / sp;
    println!("image sums: ambient {sa:.5}, pulsed steady {sp:.5}, relative difference {rel:.4}");
    assert!(sp > 0.0 && rel < 0.02, "ambient {sa} vs pulsed {sp}");
    // Per pixel: relative RMS difference at the level of two independent 256 spp
    // estimates of the box (a few per cent), not a systematic gap.
    let (mut d2, mut n2) = (0.0, 0.0);
    for (x, y) in a.iter().zip(&steady) {
        d2 += (*x as f64 - y).powi(2);
        n2 += y * y;
    }
    let rms = (d2 / n2).sqrt();
    let (ea, ep) = (
        img.error_estimate.unwrap(),
        film.half_error_estimate().unwrap(),
    );
    let expected = (ea * ea + ep * ep).sqrt();
    println!(
        "per-pixel relative RMS difference {rms:.4}; error estimates: ambient {ea:.4}, \
         pulsed {ep:.4}, combined {expected:.4}"
    );
    assert!(rms < 1.5 * expected, "{rms} vs {expected}");
}

/// The TPRF of a scene with and without a sun (and a sky, and an ambient lamp) is
/// bit-identical: the transient render never sees the ambient group.
#[test]
fn the_tprf_does_not_see_the_ambient_group() {
    let plain = scene::load("builtin:cornell").unwrap();
    let mut lit = plain.clone();
    lit.ambient
        .directional
        .push(sun(Vec3::new(0.2, -1.0, -0.3), 1000.0));
    lit.ambient.sky_radiance = [5.0; 3];
    lit.ambient.lights.push(PunctualLight {
        name: "lamp".into(),
        position: Vec3::new(0.2, 0.3, 0.2),
        intensity_w_per_sr: [50.0; 3],
        spot: None,
        projector: None,
    });
    let axis = TimeAxis::new(0.0, 2e-11, 256).unwrap();
    let a = render_scene(plain, 10, 10, axis, 8, 3, 0).film.snapshot();
    let b = render_scene(lit, 10, 10, axis, 8, 3, 0).film.snapshot();
    let (da, db) = (a.dense(None), b.dense(None));
    assert!(da.iter().any(|&v| v > 0.0));
    assert!(
        da.iter().zip(&db).all(|(x, y)| x.to_bits() == y.to_bits()),
        "the TPRF changed with an ambient group"
    );
}

#[test]
fn the_ambient_image_does_not_depend_on_the_thread_count() {
    let s = scene::load("builtin:canopy").unwrap();
    assert!(!s.ambient.is_empty(), "builtin:canopy has a sun");
    let r = Renderer::new(Arc::new(s), RenderSettings::default());
    let image = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render_ambient(&r, 16, 12, 4))
    };
    let (a, b) = (image(1), image(3));
    assert_eq!(a, b);
    assert!(a.radiance.iter().any(|&v| v > 0.0));
    // Canopy under a 1000 W/m^2 sun at 60 degrees: grey ground (0.3) and leaves (0.5),
    // partly shaded: well below the unshaded leaf's 0.5 x 1000 x 0.866 / pi = 138.
    let mean = a.radiance.iter().sum::<f32>() / a.radiance.len() as f32;
    println!(
        "canopy ambient: mean {mean:.2} W m^-2 sr^-1, error estimate {:?}",
        a.error_estimate
    );
    assert!(mean > 10.0 && mean < 140.0, "{mean}");
}

fn tprf(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(args)
        .output()
        .unwrap()
}

fn out_dir(name: &str) -> std::path::PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("ambient")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// `tprf render` writes `ambient.npy` (or `tprf.zarr/ambient`) and records it in
/// `tprf.json`; the readers find it; a folder without it (an old one) still loads; and
/// `tprf sensor` adds it: a box-gated sensor's measurement grows by `A x width` per
/// gate, and by nothing with `--ambient-scale 0`.
#[test]
fn render_writes_it_readers_read_it_the_sensor_adds_it() {
    use tprf_core::export::{self, ambient::load_ambient, sensor::SensorCube};
    for format in ["npy", "zarr"] {
        let dir = out_dir(&format!("canopy_{format}"));
        let d = dir.to_str().unwrap();
        let o = tprf(&[
            "render",
            "builtin:canopy",
            "--out",
            d,
            "--width",
            "12",
            "--height",
            "10",
            "--spp",
            "2",
            "--bins",
            "64",
            "--format",
            format,
            "--ambient-spp",
            "4",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (meta, _snap) = export::load_snapshot(&dir).unwrap();
        let am = meta
            .ambient
            .clone()
            .expect("tprf.json records the ambient image");
        assert_eq!(am.spp, 4);
        assert!(am.lights.iter().any(|l| l.contains("sun")));
        let img = load_ambient(&dir, &meta).unwrap().expect("ambient image");
        assert_eq!(img.len(), 12 * 10);
        assert!(img.iter().all(|v| v.is_finite() && *v >= 0.0));
        assert!(img.iter().any(|&v| v > 1.0));
        let cube = SensorCube::open(&dir).unwrap();
        assert_eq!(cube.ambient.as_deref(), Some(&img[..]));
        if format == "npy" {
            assert!(dir.join("ambient.npy").exists() && dir.join("ambient.png").exists());
            // Box gates of 2 ns: with and without the ambient image.
            let sensor = |scale: &str, out: &str| {
                let out = out_dir(out);
                let o = tprf(&[
                    "sensor",
                    d,
                    "--exposure",
                    "box:origin=window,start=0ns,width=2ns,count=4",
                    "--ambient-scale",
                    scale,
                    "--out",
                    out.to_str().unwrap(),
                ]);
                assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
                let (shape, m) = export::read_npy_f32(&out.join("sensor.npy")).unwrap();
                assert_eq!(shape, vec![4, 10, 12]);
                m
            };
            let (with, without) = (sensor("1", "lit"), sensor("0", "dark"));
            for (i, (a, b)) in with.iter().zip(&without).enumerate() {
                let want = f64::from(*b) + f64::from(img[i % 120]) * 2e-9;
                assert!(
                    (f64::from(*a) - want).abs() <= 1e-5 * want,
                    "{i}: {a} vs {want}"
                );
            }
            // An old folder: no "ambient" in tprf.json, no ambient.npy.
            let json = dir.join("tprf.json");
            let mut j: serde_json::Value =
                serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
            j.as_object_mut().unwrap().remove("ambient");
            std::fs::write(&json, serde_json::to_vec(&j).unwrap()).unwrap();
            std::fs::remove_file(dir.join("ambient.npy")).unwrap();
            let (meta, _) = export::load_snapshot(&dir).unwrap();
            assert!(load_ambient(&dir, &meta).unwrap().is_none());
            assert!(SensorCube::open(&dir).unwrap().ambient.is_none());
        } else {
            assert!(dir.join("tprf.zarr").join("ambient").is_dir());
        }
    }
    // A scene without ambient light writes none; --sky adds one; a bad sky is refused.
    let dir = out_dir("cornell");
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        dir.to_str().unwrap(),
        "--width",
        "4",
        "--height",
        "4",
        "--spp",
        "1",
        "--bins",
        "16",
    ]);
    assert!(o.status.success());
    assert!(!dir.join("ambient.npy").exists());
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        dir.to_str().unwrap(),
        "--width",
        "4",
        "--height",
        "4",
        "--spp",
        "1",
        "--bins",
        "16",
        "--sky",
        "0.5",
    ]);
    assert!(o.status.success());
    assert!(dir.join("ambient.npy").exists());
    for bad in ["-1", "NaN", "inf"] {
        let sky = format!("--sky={bad}");
        let o = tprf(&[
            "render",
            "builtin:cornell",
            "--out",
            dir.to_str().unwrap(),
            &sky,
        ]);
        assert!(!o.status.success());
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains("--sky"), "{e}");
    }
}

/// The viewer's worker renders the ambient image once, after the first pass, at
/// `AMBIENT_SPP`: the same image `render_ambient` gives (deterministic), and no image
/// for a scene without ambient light.
#[test]
fn the_worker_renders_the_ambient_image_once() {
    use std::time::{Duration, Instant};
    use tprf_core::request::RenderRequest;
    use tprf_core::request::worker::{AMBIENT_SPP, RenderWorker, WorkerState};
    let job = |scene: &str| RenderRequest {
        width: 16,
        height: 12,
        bins: 32,
        spp: Some(2),
        ..RenderRequest::new(scene)
    };
    let wait = |w: &RenderWorker| {
        let start = Instant::now();
        while !w.is_finished() && start.elapsed() < Duration::from_secs(120) {
            std::thread::sleep(Duration::from_millis(20));
        }
        assert_eq!(w.status().unwrap().state, WorkerState::Done);
    };
    let w = RenderWorker::spawn(job("builtin:canopy"), || {});
    wait(&w);
    let got = w
        .ambient()
        .expect("the canopy's sun gives an ambient image");
    assert!(!w.status().unwrap().ambient_pending);
    let r = Renderer::new(
        Arc::new(scene::load("builtin:canopy").unwrap()),
        RenderSettings::default(),
    );
    assert_eq!(*got, render_ambient(&r, 16, 12, AMBIENT_SPP));
    let w = RenderWorker::spawn(job("builtin:cornell"), || {});
    wait(&w);
    assert!(w.ambient().is_none());
    // The window's sky setting: the same scene under a sky of 2 W m^-2 sr^-1 gives the
    // ambient image of the scene with that sky (as `tprf render --sky 2` does), and a
    // negative one fails the job, naming the sky.
    let w = RenderWorker::spawn(
        RenderRequest {
            sky_radiance_w_m2_sr: Some(2.0),
            ..job("builtin:cornell")
        },
        || {},
    );
    wait(&w);
    let got = w.ambient().expect("a sky gives an ambient image");
    let mut sky_scene = scene::load("builtin:cornell").unwrap();
    sky_scene.ambient.sky_radiance = [2.0; 3];
    let r = Renderer::new(Arc::new(sky_scene), RenderSettings::default());
    let want = render_ambient(&r, 16, 12, AMBIENT_SPP);
    assert_eq!(*got, want);
    assert!(want.radiance.iter().any(|&v| v > 0.0), "the sky is seen");
    let w = RenderWorker::spawn(
        RenderRequest {
            sky_radiance_w_m2_sr: Some(-1.0),
            ..job("builtin:cornell")
        },
        || {},
    );
    let start = Instant::now();
    while !w.is_finished() && start.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
    match w.status().unwrap().state {
        WorkerState::Failed(e) => assert!(e.contains("sky radiance"), "{e}"),
        s => panic!("a negative sky rendered: {s:?}"),
    }
}

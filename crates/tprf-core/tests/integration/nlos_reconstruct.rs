//! Reconstructions of NLOS captures: every method peaks at the hidden object's position
//! (within two voxels), a volume behind the wall is refused naming it, and, where tal is
//! installed (see tests/nlos.rs), our back-projection and filtered back-projection agree
//! with tal's own reconstruction of our `nlos.hdf5`.

use crate::common;

use common::C;
use glam::Vec3;
use std::path::PathBuf;
use std::process::Command;
use std::sync::Arc;
use tprf_core::nlos::capture::{Progress, render_capture};
use tprf_core::nlos::files::{LoadedCapture, read_capture, write_capture_folder};
use tprf_core::nlos::reconstruct::{GridFrame, Method, Volume, reconstruct};
use tprf_core::nlos::{CaptureSettings, Scan};

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tprf-nlosrec-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// A capture of the patch at `c`, written and read back as a reconstruction reads it.
fn captured(c: Vec3, scan: Scan, legs: bool, name: &str) -> (LoadedCapture, PathBuf) {
    let set = CaptureSettings {
        grid: [24, 24],
        scan,
        spp: 64,
        dt_s: 0.01 / C,
        device_legs: legs,
        max_bounces: 1,
        ..CaptureSettings::default()
    };
    let cap = render_capture(
        Arc::new(common::nlos_patch_scene(c, 0.12)),
        &set,
        &Progress::default(),
    )
    .unwrap();
    let dir = out_dir(name);
    write_capture_folder(&cap, &dir, &[]).unwrap();
    (read_capture(&dir).unwrap(), dir)
}

/// The voxel holding `p`.
fn voxel_of(v: &Volume, p: Vec3) -> [i64; 3] {
    let rel = p - Vec3::from(v.center);
    let f = |axis: [f32; 3], k: usize| {
        let x = rel.dot(Vec3::from(axis)) / v.size_m[k] + 0.5;
        (x * v.voxels[k] as f32).floor() as i64
    };
    [f(v.u, 0), f(v.v, 1), f(v.n, 2)]
}

fn check_peak(c: &LoadedCapture, method: Method, volume: &Volume, at: Vec3) {
    let r = reconstruct(c, method, volume, None).unwrap();
    assert!(r.values.iter().all(|v| v.is_finite()));
    let peak = r.peak();
    let want = voxel_of(volume, at);
    let off: Vec<i64> = (0..3).map(|k| (peak[k] as i64 - want[k]).abs()).collect();
    assert!(
        off.iter().all(|&d| d <= 2),
        "{}: peak at voxel {peak:?}, the patch is in voxel {want:?}",
        method.name()
    );
}

#[test]
fn every_method_peaks_at_the_patch() {
    let at = Vec3::new(0.25, -0.3, 0.7);
    let (c, dir) = captured(at, Scan::Confocal, false, "confocal");
    let frame = GridFrame::of(&c).unwrap();
    let volume = Volume::new(
        &frame,
        Vec3::new(0.0, 0.0, 0.75),
        [2.0, 2.0, 1.0],
        [24, 24, 20],
    )
    .unwrap();
    for method in [Method::Bp, Method::Fbp, Method::Pf, Method::Fk] {
        check_peak(&c, method, &volume, at);
    }
    // The default volume too.
    let default = Volume::default_for(&c, &frame).unwrap();
    assert_eq!(default.voxels[..2], [24, 24]);
    for method in [Method::Bp, Method::Pf] {
        check_peak(&c, method, &default, at);
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn non_confocal_captures_peak_at_the_patch_and_fk_refuses_them() {
    let at = Vec3::new(-0.3, 0.2, 0.8);
    for (scan, legs) in [
        (Scan::Single { laser_point: None }, true),
        (Scan::Exhaustive { lx: 3, ly: 3 }, false),
    ] {
        let (c, dir) = captured(at, scan, legs, "single");
        let frame = GridFrame::of(&c).unwrap();
        let volume = Volume::new(
            &frame,
            Vec3::new(0.0, 0.0, 0.75),
            [2.0, 2.0, 1.0],
            [24, 24, 20],
        )
        .unwrap();
        for method in [Method::Bp, Method::Fbp, Method::Pf] {
            check_peak(&c, method, &volume, at);
        }
        let e = reconstruct(&c, Method::Fk, &volume, None)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--method fk") && e.contains("not a confocal capture"),
            "{e}"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }
}

#[test]
fn a_volume_behind_the_wall_is_refused() {
    let (c, dir) = captured(Vec3::new(0.0, 0.0, 0.5), Scan::Confocal, false, "behind");
    let frame = GridFrame::of(&c).unwrap();
    let e = Volume::new(
        &frame,
        Vec3::new(0.0, 0.0, -0.5),
        [1.0, 1.0, 0.5],
        [8, 8, 8],
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("--volume") && e.contains("behind the relay wall"),
        "{e}"
    );
    let e = Volume::new(&frame, Vec3::new(0.0, 0.0, 0.2), [1.0, 1.0, 0.5], [8, 8, 8])
        .unwrap_err()
        .to_string();
    assert!(e.contains("behind the relay wall"), "{e}");
    let e = Volume::new(&frame, Vec3::new(0.0, 0.0, 1.0), [1.0, 1.0, 0.5], [8, 0, 8])
        .unwrap_err()
        .to_string();
    assert!(e.contains("--volume") && e.contains("voxels"), "{e}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// tal's Python, as tests/nlos.rs makes it (`None` where it is not there: the test that
/// installs it is tests/nlos.rs's).
fn tal_python() -> Option<PathBuf> {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(crate::ROOT).join("target"));
    let python = target.join("nlos-venv/bin/python");
    let ok = Command::new(&python)
        .args(["-c", "import h5py, tal"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!(
            "note: skipped comparing with tal: no venv with tal at {}",
            python.display()
        );
    }
    ok.then_some(python)
}

#[test]
fn bp_and_fbp_match_tals_reconstruction() {
    let Some(python) = tal_python() else {
        return;
    };
    let at = Vec3::new(0.2, 0.1, 0.6);
    let (c, dir) = captured(at, Scan::Confocal, true, "tal");
    let frame = GridFrame::of(&c).unwrap();
    let volume = Volume::new(
        &frame,
        Vec3::new(0.0, 0.0, 0.6),
        [1.6, 1.6, 0.8],
        [16, 16, 16],
    )
    .unwrap();
    let wave = tprf_core::nlos::reconstruct::Wave::default_for(&c, &frame);
    for method in [Method::Bp, Method::Fbp] {
        let r = reconstruct(&c, method, &volume, Some(wave)).unwrap();
        let ours = dir.join(format!("{}.npy", method.name()));
        let [nx, ny, nz] = volume.voxels;
        tprf_core::export::write_npy_f32(&ours, &[nz as u64, ny as u64, nx as u64], &r.values)
            .unwrap();
        let script = r#"
import sys, json, numpy as np, tal
from tal.enums import CameraSystem
d, method, ours = sys.argv[1], sys.argv[2], sys.argv[3]
vol = json.loads(sys.argv[4]); wl = float(sys.argv[5])
data = tal.io.read_capture(d + '/nlos.hdf5')
c, s, n = np.array(vol['center']), vol['size_m'], vol['voxels']
u, v, w = np.array(vol['u']), np.array(vol['v']), np.array(vol['n'])
f = lambda i, k: ((np.arange(n[k]) + 0.5) / n[k] - 0.5) * s[k]
X, Y, Z = np.meshgrid(f(0, 0), f(0, 1), f(0, 2), indexing='ij')
xyz = (c + X[..., None] * u + Y[..., None] * v + Z[..., None] * w).astype(np.float32)
tal.set_resources(cpu_processes=1) if hasattr(tal, 'set_resources') else None
if method == 'bp':
    R = tal.reconstruct.bp.solve(data, volume_xyz=xyz, camera_system=CameraSystem.DIRECT_LIGHT, progress=False)
else:
    R = tal.reconstruct.fbp.solve(data, wl_mean=wl, wl_sigma=wl / np.sqrt(2), volume_xyz=xyz, camera_system=CameraSystem.DIRECT_LIGHT, progress=False)
R = np.abs(R)                              # [X, Y, Z]
O = np.load(ours).transpose(2, 1, 0)       # ours [Z, Y, X] -> [X, Y, Z]
a, b = R.ravel() / R.max(), O.ravel() / O.max()
corr = np.dot(a - a.mean(), b - b.mean()) / np.linalg.norm(a - a.mean()) / np.linalg.norm(b - b.mean())
pr, po = np.unravel_index(R.argmax(), R.shape), np.unravel_index(O.argmax(), O.shape)
print(method, 'correlation', corr, 'peaks', pr, po)
assert corr > 0.98, corr
assert max(abs(int(x) - int(y)) for x, y in zip(pr, po)) <= 1, (pr, po)
"#;
        let vol_json = serde_json::to_string(&volume).unwrap();
        let out = Command::new(&python)
            .args([
                "-c",
                script,
                dir.to_str().unwrap(),
                method.name(),
                ours.to_str().unwrap(),
                &vol_json,
                &wave.wavelength_m.to_string(),
            ])
            .output()
            .unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            out.status.success(),
            "{}: tal's reconstruction differs from ours:\n{text}",
            method.name()
        );
        eprintln!(
            "{}",
            text.lines()
                .filter(|l| l.contains("correlation"))
                .collect::<Vec<_>>()
                .join("\n")
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

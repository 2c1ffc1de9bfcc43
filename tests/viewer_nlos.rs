//! The window's NLOS view driven as a user would, with egui_kittest, on a capture of a
//! small hidden patch written by `tprf nlos`'s writer: opening the folder shows the
//! capture's time slices on the wall grid; a click on a wall point plots its transient,
//! whose first return is at the analytic time (2 |wall point - patch| / c, plus the
//! device legs when the capture's times include them) within a bin; the projections'
//! peak is at the patch within two voxels for the methods chosen in the window and for
//! a volume typed there; a bad volume is a message, not a panic.
//!
//! With `TPRF_SCREENSHOTS=1` the ignored test `screenshot` writes `screenshots/nlos.png`.

mod common;

use common::C;
use eframe::egui::{Event, Modifiers, PointerButton, Pos2, Vec2};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tprf::viewer::{Start, TprfApp, ViewerSettings};
use tprf_core::nlos::capture::{Progress, render_capture};
use tprf_core::nlos::files::write_capture_folder;
use tprf_core::nlos::reconstruct::{Method, Volume};
use tprf_core::nlos::{CaptureSettings, Scan};

/// Side of the hidden patch, metres.
const SIDE_M: f32 = 0.12;
/// Bin width as optical path, metres.
const DT_M: f64 = 0.01;

/// A confocal capture of the patch at `c` written to a fresh folder.
fn capture_folder(c: Vec3, device_legs: bool, name: &str) -> PathBuf {
    let set = CaptureSettings {
        grid: [16, 16],
        scan: Scan::Confocal,
        spp: 256,
        dt_s: DT_M / C,
        device_legs,
        max_bounces: 1,
        ..CaptureSettings::default()
    };
    let cap = render_capture(
        Arc::new(common::nlos_patch_scene(c, SIDE_M)),
        &set,
        &Progress::default(),
    )
    .unwrap();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("viewer-nlos-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    write_capture_folder(&cap, &dir, &[]).unwrap();
    dir
}

fn harness(dir: &Path) -> Harness<'static, TprfApp> {
    let dir = dir.to_path_buf();
    Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(cc, ViewerSettings::default(), Start::Cube(dir))
        })
}

/// A mouse click (press and release, no movement) at `pos`.
fn click_at(h: &mut Harness<'static, TprfApp>, pos: Pos2) {
    h.hover_at(pos);
    h.step();
    for pressed in [true, false] {
        h.event(Event::PointerButton {
            pos,
            button: PointerButton::Primary,
            pressed,
            modifiers: Modifiers::NONE,
        });
        h.step();
    }
    h.step();
}

/// Step until the reconstruction of the method and volume last asked for is on screen.
fn wait_reconstruction(h: &mut Harness<'static, TprfApp>) {
    let start = Instant::now();
    loop {
        h.step();
        let v = h.state().nlos().expect("the NLOS view");
        let st = v.reconstruction();
        let want = (v.method, v.volume);
        if st.running.is_none()
            && let Some(f) = &st.finished
            && (f.request.method, f.request.volume) == want
        {
            break;
        }
        if let Some((_, e)) = &st.error {
            panic!("reconstruction failed: {e}");
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no reconstruction in 120 s"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    h.run_steps(2);
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

/// The patch's point nearest `s`: `s`'s x and y clamped to the square, at its depth.
fn nearest_on_patch(c: Vec3, s: Vec3) -> Vec3 {
    let h = SIDE_M / 2.0;
    Vec3::new(
        s.x.clamp(c.x - h, c.x + h),
        s.y.clamp(c.y - h, c.y + h),
        c.z,
    )
}

/// Open the capture, check the wall shows light, click wall point `(ix, iy)` and check
/// its plotted transient's first return against the analytic time.
fn click_and_check_first_return(dir: &Path, patch: Vec3, legs: bool, points: &[(usize, usize)]) {
    let mut h = harness(dir);
    h.run_steps(3);
    let v = h.state().nlos().expect("the folder opens in the NLOS view");
    assert_eq!(v.grid(), [16, 16]);
    assert_eq!(v.capture.device_legs, legs);
    // The slice on screen is where the light is: some wall points are lit.
    let bin = h.state().bin;
    let slice = v.slice_image(bin);
    assert!(
        slice.iter().any(|&x| x > 0.0),
        "the wall slice at bin {bin} is dark"
    );
    h.get_by_label("wall slice");
    h.get_by_label("transient plot");
    // The panel and the plot say the capture's time convention.
    let said = if legs {
        "t_accounts_first_and_last_bounces = true"
    } else {
        "t_accounts_first_and_last_bounces = false"
    };
    assert!(
        h.query_all_by_label_contains(said).count() >= 1,
        "the window does not say '{said}'"
    );
    for &(ix, iy) in points {
        let (col, row) = h.state().nlos().unwrap().pixel_of_grid(ix, iy);
        let rect = h.get_by_label("wall slice").rect();
        let pos = Pos2::new(
            rect.min.x + (col as f32 + 0.5) * rect.width() / 16.0,
            rect.min.y + (row as f32 + 0.5) * rect.height() / 16.0,
        );
        click_at(&mut h, pos);
        let v = h.state().nlos().unwrap();
        assert_eq!(v.wall_point, (ix, iy), "the click chose the wall point");
        let s = v.capture.sensor_grid[ix * 16 + iy];
        // The plotted transient is this point's: the label under the heading says so.
        h.get_by_label_contains(&format!("grid point ({ix}, {iy})"));
        let tr = v.transient(ix, iy);
        let first = tr.iter().position(|&x| x > 0.0).expect("a return");
        let mut path_m = 2.0 * (s - nearest_on_patch(patch, s)).length() as f64;
        if legs {
            let (l, o) = (v.capture.laser_xyz.unwrap(), v.capture.sensor_xyz.unwrap());
            path_m += ((s - l).length() + (s - o).length()) as f64;
        }
        let want = ((path_m - v.capture.t_start_m) / v.capture.delta_t_m).floor() as i64;
        assert!(
            (first as i64 - want).abs() <= 1,
            "wall point ({ix}, {iy}): first return in bin {first}, the analytic time \
             {:.4} ns is bin {want}",
            path_m / C * 1e9
        );
    }
}

#[test]
fn wall_slices_and_a_clicked_points_transient() {
    // In front of grid point (9, 6); the points clicked see the patch's nearest point
    // in its middle or on an edge (a corner's first bin holds too little of the patch
    // for 256 samples to find it surely).
    let patch = Vec3::new(0.1875, -0.1875, 0.6);
    let dir = capture_folder(patch, false, "unwarped");
    click_and_check_first_return(&dir, patch, false, &[(9, 6), (9, 13), (2, 6)]);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn warped_times_include_the_device_legs() {
    // In front of grid point (7, 10).
    let patch = Vec3::new(-0.0625, 0.3125, 0.5);
    let dir = capture_folder(patch, true, "warped");
    click_and_check_first_return(&dir, patch, true, &[(7, 10), (7, 2), (14, 10)]);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn projections_peak_at_the_patch_and_a_bad_volume_is_a_message() {
    let patch = Vec3::new(0.25, -0.3, 0.7);
    let dir = capture_folder(patch, false, "projections");
    let mut h = harness(&dir);
    // The first reconstruction (bp on the default volume) starts by itself.
    wait_reconstruction(&mut h);
    let check = |h: &Harness<'static, TprfApp>| {
        let v = h.state().nlos().unwrap();
        let st = v.reconstruction();
        let f = st.finished.as_ref().unwrap();
        let want = voxel_of(&f.request.volume, patch);
        let off: Vec<i64> = (0..3)
            .map(|k| (f.peak_voxel[k] as i64 - want[k]).abs())
            .collect();
        assert!(
            off.iter().all(|&d| d <= 2),
            "{}: peak at voxel {:?}, the patch is in voxel {want:?}",
            f.request.method.name(),
            f.peak_voxel
        );
        // The front projection's brightest cell is the peak's column.
        let p = &f.projections[0];
        let k = p
            .values
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap()
            .0;
        assert_eq!(
            [k % p.width, k / p.width],
            [f.peak_voxel[0], f.peak_voxel[1]]
        );
        for label in ["front projection", "top projection", "side projection"] {
            h.get_by_label(label);
        }
    };
    check(&h);
    assert_eq!(h.state().nlos().unwrap().method, Method::Bp);
    // Methods chosen with their buttons: the projections follow, nothing re-renders.
    for name in ["fbp", "pf", "fk"] {
        h.get_by_label(name).click();
        h.run_steps(2);
        assert_eq!(h.state().nlos().unwrap().method.name(), name);
        wait_reconstruction(&mut h);
        check(&h);
    }
    // A volume typed in the window.
    {
        let v = h.state_mut().nlos_mut().unwrap();
        v.volume_text.center = "0, 0, 0.75".into();
        v.volume_text.size = "2, 2, 1".into();
        v.volume_text.voxels = "20, 20, 20".into();
    }
    h.get_by_label("Apply").click();
    h.run_steps(2);
    assert_eq!(h.state().nlos().unwrap().volume.voxels, [20, 20, 20]);
    wait_reconstruction(&mut h);
    check(&h);
    // A volume behind the wall, and one of no voxels: messages, the last volume kept.
    for (center, voxels, says) in [
        ("0, 0, 0.2", "20, 20, 20", "behind the relay wall"),
        ("0, 0, 0.75", "20, 0, 20", "give 1 to"),
        ("0, 0", "20, 20, 20", "volume centre '0, 0'"),
    ] {
        {
            let v = h.state_mut().nlos_mut().unwrap();
            v.volume_text.center = center.into();
            v.volume_text.voxels = voxels.into();
        }
        h.get_by_label("Apply").click();
        h.run_steps(2);
        let v = h.state().nlos().unwrap();
        let e = v.volume_error.clone().expect("a message");
        assert!(e.contains(says), "{e}");
        assert_eq!(v.volume.voxels, [20, 20, 20], "the last good volume stays");
        assert!(
            h.query_all_by_label_contains(says).count() >= 1,
            "the window shows {says}"
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// `TPRF_SCREENSHOTS=1 cargo test --release --test viewer_nlos -- --ignored screenshot`
/// writes `screenshots/nlos.png`: the Z scene's capture (tal's quickstart), a wall
/// point's transient and the f-k reconstruction's projections.
#[test]
#[ignore = "writes screenshots/; run by hand"]
fn screenshot() {
    if std::env::var_os("TPRF_SCREENSHOTS").is_none() {
        eprintln!("set TPRF_SCREENSHOTS=1 to write screenshots/");
        return;
    }
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let scene = tprf_core::scene::builtin::load("nlos-z").unwrap();
    let set = CaptureSettings {
        grid: [48, 48],
        spp: 64,
        dt_s: 0.01 / C,
        ..CaptureSettings::default()
    };
    let cap = render_capture(Arc::new(scene), &set, &Progress::default()).unwrap();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("viewer-nlos-screenshot");
    let _ = std::fs::remove_dir_all(&dir);
    write_capture_folder(&cap, &dir, &[]).unwrap();
    let mut h = harness(&dir);
    h.run_steps(2);
    {
        let app = h.state_mut();
        app.playing = false;
        let v = app.nlos_mut().unwrap();
        v.wall_point = (30, 30);
        v.set_method(Method::Fk).unwrap();
    }
    wait_reconstruction(&mut h);
    h.remove_cursor();
    h.run_steps(3);
    let mut img = h.render().expect("a wgpu adapter for screenshots");
    tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
    img.save(shots.join("nlos.png")).unwrap();
    std::fs::remove_dir_all(dir).unwrap();
}

/// Over an NLOS capture the film's tabs are greyed out: clicking one changes nothing.
#[test]
fn the_films_tabs_are_greyed_out_over_a_capture() {
    let dir = capture_folder(Vec3::new(0.0, 0.0, 0.6), false, "tabs");
    let mut h = harness(&dir);
    h.run_steps(2);
    assert!(h.state().nlos().is_some());
    let before = h.state().settings.mode;
    // A pointer's click, as a user's (an accessibility action reaches a disabled
    // widget too).
    let tab = h.get_by_label("Sensor").rect().center();
    click_at(&mut h, tab);
    h.run_steps(2);
    assert_eq!(h.state().settings.mode, before);
    std::fs::remove_dir_all(dir).unwrap();
}

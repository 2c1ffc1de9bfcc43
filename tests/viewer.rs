//! The viewer driven as a user would, with egui_kittest: open it on a built-in scene,
//! wait for the renderer, pause playback, step the scrubber with the keyboard, click a
//! pixel of the time slice and check the plot shows that pixel's TPRF.
//!
//! Where a wgpu adapter exists (CI installs Mesa's software Vulkan), the window is also
//! rendered to an image and checked for the things a person would see. With
//! `TPRF_SCREENSHOTS=1` the ignored test `screenshots` writes the README's pictures to
//! `screenshots/`.

use eframe::egui::{Event, Key, Modifiers, PointerButton, Pos2, Vec2};
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tprf::viewer::sensor::SensorState;
use tprf::viewer::{Mode, Selection, Start, SteadyBlock, TprfApp, ViewerSettings};
use tprf_core::film::{FilmLayout, FilmSnapshot, TimeAxis};
use tprf_core::request::worker::WorkerState;
use tprf_core::sensor::{Exposure, LightPulse, Sensor, TimeOrigin};

fn small_settings(scene: &str, side: usize, bins: usize, spp: u64) -> ViewerSettings {
    ViewerSettings {
        scene: scene.into(),
        width: side,
        height: side,
        bins,
        spp_target: spp,
        ..ViewerSettings::default()
    }
}

fn harness(settings: ViewerSettings) -> Harness<'static, TprfApp> {
    Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default))
}

/// Step the UI until the render worker has finished (its spp target reached).
fn wait_done(h: &mut Harness<'static, TprfApp>, limit: Duration) {
    let start = Instant::now();
    loop {
        h.step();
        match h.state().status().map(|s| s.state) {
            Some(WorkerState::Done) if h.state().snapshot().is_some() => break,
            Some(WorkerState::Failed(e)) => panic!("render failed: {e}"),
            _ => {}
        }
        assert!(
            start.elapsed() < limit,
            "render did not finish in {limit:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // Let the last snapshot reach the textures.
    h.run_steps(2);
}

/// Screen position of the centre of pixel (x, y) of the image widget labelled `label`.
fn pixel_pos(
    h: &Harness<'static, TprfApp>,
    label: &str,
    x: usize,
    y: usize,
    w: usize,
    hgt: usize,
) -> Pos2 {
    let rect = h.get_by_label(label).rect();
    Pos2::new(
        rect.min.x + (x as f32 + 0.5) * rect.width() / w as f32,
        rect.min.y + (y as f32 + 0.5) * rect.height() / hgt as f32,
    )
}

/// Opens `builtin:NAME` from the top bar's menu of built-in scenes.
fn open_builtin(h: &mut Harness<'static, TprfApp>, name: &str) {
    h.get_by_label("Built-in scene ⏷").click();
    h.run_steps(2);
    h.get_by_label(&format!("builtin:{name}")).click();
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

#[test]
fn scrub_click_and_plot_a_pixel() {
    let (side, bins) = (24, 48);
    let mut h = harness(small_settings("builtin:cornell", side, bins, 8));
    wait_done(&mut h, Duration::from_secs(120));
    let snap = h.state().snapshot().expect("a film");
    assert_eq!(
        (snap.width(), snap.height(), snap.axis().bins),
        (side, side, bins)
    );
    assert_eq!(snap.spp, 8);

    // Light moves at once; space pauses it.
    assert!(h.state().playing, "playback starts on opening");
    h.key_press(Key::Space);
    h.step();
    assert!(!h.state().playing, "space pauses");

    // Arrow keys step one bin; the start button goes to bin 0.
    h.get_by_label("⏮").click();
    h.step();
    assert_eq!(h.state().bin, 0);
    for _ in 0..3 {
        h.key_press(Key::ArrowRight);
        h.step();
    }
    assert_eq!(h.state().bin, 3);
    h.key_press(Key::ArrowLeft);
    h.step();
    assert_eq!(h.state().bin, 2);
    // Stepping back from bin 0 stays at 0 when not looping... or wraps when looping;
    // either way it stays inside the window.
    for _ in 0..5 {
        h.key_press(Key::ArrowLeft);
        h.step();
    }
    assert!(h.state().bin < bins);

    // Click pixel (17, 6) of the time slice (the back wall's upper right).
    let (px, py) = (17, 6);
    let pos = pixel_pos(&h, "time slice", px, py, side, side);
    click_at(&mut h, pos);
    assert_eq!(
        h.state().selection,
        Some(Selection::pixel(px, py)),
        "the click at {pos:?} selects the pixel under it"
    );

    // The plot's first curve is that pixel's TPRF, bin by bin.
    let curves = h.state().plotted_curves(&snap);
    let (name, values) = (&curves[0].name, &curves[0].values);
    assert_eq!(name, &format!("pixel (row {py}, column {px})"));
    let expected: Vec<f64> = snap.pixel(px, py).iter().map(|&v| v as f64).collect();
    assert_eq!(values.len(), bins);
    for (b, (got, want)) in values.iter().zip(&expected).enumerate() {
        assert!(
            (got - want).abs() <= 1e-6 * want.abs().max(1e-12),
            "bin {b}: plotted {got}, pixel has {want}"
        );
    }
    assert!(
        expected.iter().sum::<f64>() > 0.0,
        "a lit wall pixel receives light"
    );
    // Per-bounce curves add up to the total (layers partition the paths).
    let bounce_sum: Vec<f64> = (0..bins)
        .map(|b| {
            (0..snap.layers())
                .map(|l| snap.pixel_layer(l, px, py)[b] as f64)
                .sum()
        })
        .collect();
    for (b, (s, t)) in bounce_sum.iter().zip(&expected).enumerate() {
        assert!(
            (s - t).abs() <= 1e-4 * t.abs().max(1e-9),
            "bin {b}: layers sum {s}, total {t}"
        );
    }

    // Pin it, pick another pixel: both are plotted.
    h.get_by_label("📌 Pin").click();
    h.step();
    let pos2 = pixel_pos(&h, "steady image", 5, 20, side, side);
    click_at(&mut h, pos2);
    assert_eq!(h.state().selection, Some(Selection::pixel(5, 20)));
    let names: Vec<String> = h
        .state()
        .plotted_curves(&snap)
        .into_iter()
        .map(|c| c.name)
        .collect();
    assert!(
        names.contains(&format!("pin: pixel (row {py}, column {px})")),
        "pinned curve kept: {names:?}"
    );
}

/// The number after `key` in `text` (up to the next space): `3.2e-4` in "… = 3.2e-4 W".
fn number_after(text: &str, key: &str) -> f64 {
    let rest = &text[text
        .find(key)
        .unwrap_or_else(|| panic!("{key:?} not in {text:?}"))
        + key.len()..];
    let word = rest.trim_start().split(' ').next().unwrap();
    word.parse()
        .unwrap_or_else(|e| panic!("{word:?} in {text:?}: {e}"))
}

/// The label of the node whose label contains `part`.
fn label_with(h: &Harness<'static, TprfApp>, part: &str) -> String {
    let node = h.get_by_label_contains(part).accesskit_node();
    // A text label carries its text as its value.
    node.label()
        .filter(|l| l.contains(part))
        .or_else(|| node.value())
        .unwrap_or_default()
}

/// Every image has a colour bar with its unit; the readout under the cursor gives the
/// hovered pixel's value in the scrubber's bin (checked against the film) and when its
/// light peaks; an EV step changes the bar.
#[test]
fn images_have_colour_bars_and_a_readout_under_the_cursor() {
    let (side, bins) = (24, 48);
    let mut h = harness(small_settings("builtin:cornell", side, bins, 8));
    wait_done(&mut h, Duration::from_secs(120));
    let snap = h.state().snapshot().unwrap();
    let (px, py) = (17, 6);
    let tprf = snap.pixel(px, py);
    let peak = (0..bins)
        .max_by(|&a, &b| tprf[a].total_cmp(&tprf[b]))
        .unwrap();
    {
        let app = h.state_mut();
        app.playing = false;
        app.bin = peak;
    }
    h.run_steps(2);
    for (of, unit) in [
        ("colour bar: time slice", "W m⁻² sr⁻¹ s"),
        ("colour bar: steady image", "W m⁻² sr⁻¹"),
        ("colour bar: rainbow image", "ns"),
    ] {
        let l = label_with(&h, of);
        assert!(l.ends_with(&format!("{unit}, linear")), "{l}");
    }
    // Hover the pixel: the readout names it, with its value in this bin and unit.
    let pos = pixel_pos(&h, "time slice", px, py, side, side);
    h.hover_at(pos);
    h.run_steps(2);
    let readout = label_with(&h, &format!("row {py}, column {px} · bin {peak}:"));
    let shown = number_after(&readout, &format!("bin {peak}:"));
    let want = f64::from(tprf[peak]);
    assert!(want > 0.0);
    assert!(
        (shown - want).abs() <= 1e-3 * want,
        "{readout}: film has {want}"
    );
    assert!(readout.contains("W m⁻² sr⁻¹ s"), "{readout}");
    let steady: f64 = tprf.iter().map(|&v| f64::from(v)).sum();
    let shown = number_after(&readout, "steady");
    assert!((shown - steady).abs() <= 1e-3 * steady, "{readout}");
    let t_peak_ns = snap.axis().bin_center_s(peak) * 1e9;
    let shown = number_after(&readout, "peak at");
    assert!(
        (shown - t_peak_ns).abs() < 1e-3,
        "{readout}: peak at {t_peak_ns} ns"
    );
    // One stop more exposure halves the value shown white, and the bar says so.
    let top = |h: &Harness<'static, TprfApp>| {
        let l = label_with(h, "colour bar: time slice");
        number_after(&l, "…")
    };
    let before = top(&h);
    h.state_mut().settings.ev = 1.0;
    h.run_steps(2);
    let after = top(&h);
    assert!((after / before - 0.5).abs() < 1e-3, "{before} -> {after}");
}

/// At every window size from 1024 x 700 up, everything is on screen: the time ruler
/// ends left of the right panel (its last bin reachable by a click at its visible
/// end), the playback speed field is visible, the images stay clear of the right panel
/// and the window's bottom, and in sensor mode the measurement and the envelope editor
/// too. (At 1280 x 800 the ruler ran on under the right panel: its visible end was bin
/// 223 of 256, and the speed field was hidden.)
#[test]
fn the_layout_fits_at_every_window_size() {
    let bins = 256;
    for (w, hgt) in [
        (1024.0, 700.0),
        (1280.0, 800.0),
        (1600.0, 900.0),
        (1920.0, 1080.0),
    ] {
        let settings = small_settings("builtin:cornell", 24, bins, 2);
        let mut h = Harness::builder()
            .with_size(Vec2::new(w, hgt))
            .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default));
        wait_done(&mut h, Duration::from_secs(60));
        h.state_mut().playing = false;
        h.run_steps(2);
        let size = format!("{w} x {hgt}");
        let inside = |r: eframe::egui::Rect, right: f32, what: &str| {
            assert!(
                r.left() >= 0.0 && r.top() >= 0.0 && r.right() <= right && r.bottom() <= hgt,
                "{size}: {what} at {r:?} leaves the visible area (right edge {right})"
            );
        };
        let plot = h.get_by_label("tprf plot").rect();
        let ruler = h.get_by_label("time scrubber").rect();
        inside(ruler, plot.left(), "the time ruler");
        inside(
            h.get_by_label("speed").rect(),
            plot.left(),
            "the speed field",
        );
        inside(
            h.get_by_label("time slice").rect(),
            plot.left(),
            "the time slice",
        );
        inside(
            h.get_by_label("rainbow image").rect(),
            plot.left(),
            "the rainbow image",
        );
        inside(plot, w, "the TPRF plot");
        for (x, want) in [(ruler.right() - 1.0, bins - 1), (ruler.left() + 1.0, 0)] {
            click_at(&mut h, Pos2::new(x, ruler.center().y));
            assert_eq!(
                h.state().bin,
                want,
                "{size}: a click at x = {x} of {ruler:?}"
            );
        }
        h.state_mut().settings.mode = Mode::Sensor;
        h.run_steps(3);
        wait_sensor(&mut h);
        h.run_steps(2);
        let editor = h.get_by_label("envelope editor").rect();
        inside(editor, w, "the envelope editor");
        inside(
            h.get_by_label("measurement image").rect(),
            editor.left(),
            "the measurement image",
        );
        inside(
            h.get_by_label("depth image").rect(),
            editor.left(),
            "the depth image",
        );
        // The top bar is one row: Pause beside the tabs, the built-in scenes a menu.
        let tab = h.get_by_label("Transient").rect();
        let pause = h.get_by_label("⏸ Pause").rect();
        assert!(
            (pause.center().y - tab.center().y).abs() < 2.0 && pause.right() <= w,
            "{size}: Pause at {pause:?}, the tabs at {tab:?}"
        );
        // The SPAD: its views, its depth image and its histogram reachable.
        h.state_mut().settings.sensor = Sensor::builtin("spad").unwrap();
        h.run_steps(2);
        let snap = h.state().snapshot().unwrap();
        let start = Instant::now();
        while !h.state().sensor.is_current(&snap) && start.elapsed() < Duration::from_secs(60) {
            h.step();
            std::thread::sleep(Duration::from_millis(10));
        }
        h.run_steps(3);
        let editor = h.get_by_label("envelope editor").rect();
        for what in ["expected", "one realisation", "Coates", "SPAD depth image"] {
            inside(h.get_by_label(what).rect(), editor.left(), what);
        }
        let title = h.get_by_label_contains("SPAD histogram of pixel").rect();
        inside(title, w, "the SPAD histogram's title");
    }
}

/// Typing into a field and pressing Tab within one frame (a slow frame: 4 a second
/// under software rendering): what was typed lands in that field, and the next field
/// keeps its value. (egui moved the focus first, and "Height 256", Tab, made "Height
/// 25" and "Bins 2566".) The window's input hook is called as eframe calls it.
#[test]
fn typing_then_tab_in_one_frame_stays_in_its_field() {
    use eframe::App;
    use eframe::egui::Modifiers;
    let mut h = harness(small_settings("builtin:cornell", 8, 16, 1));
    h.run_steps(2);
    let key = |key: Key, modifiers: Modifiers| Event::Key {
        key,
        physical_key: None,
        pressed: true,
        repeat: false,
        modifiers,
    };
    // One frame's input, through the hook.
    let frame = |h: &mut Harness<'static, TprfApp>, events: Vec<Event>| {
        for e in events {
            h.event(e);
        }
        let ctx = h.ctx.clone();
        let mut input = std::mem::take(h.input_mut());
        h.state_mut().raw_input_hook(&ctx, &mut input);
        *h.input_mut() = input;
        h.step();
    };
    h.get_by_label("Height").click();
    frame(&mut h, vec![]);
    frame(&mut h, vec![key(Key::A, Modifiers::COMMAND)]);
    frame(
        &mut h,
        vec![
            Event::Text("3".into()),
            Event::Text("2".into()),
            key(Key::Tab, Modifiers::NONE),
        ],
    );
    for _ in 0..3 {
        frame(&mut h, vec![]);
    }
    let p = &h.state().pending;
    assert_eq!((p.height, p.bins), (32, 16), "Height then Bins");
}

/// After a resolution change the selected pixel and the pins point at the same scene
/// point of the new film, and the window says so.
#[test]
fn the_selection_follows_a_resolution_change() {
    let mut h = harness(small_settings("builtin:cornell", 24, 32, 2));
    wait_done(&mut h, Duration::from_secs(60));
    h.state_mut().playing = false;
    let pos = pixel_pos(&h, "time slice", 17, 6, 24, 24);
    click_at(&mut h, pos);
    assert_eq!(h.state().selection, Some(Selection::pixel(17, 6)));
    h.get_by_label("📌 Pin").click();
    h.step();
    let pos = pixel_pos(&h, "time slice", 3, 20, 24, 24);
    click_at(&mut h, pos);
    h.state_mut().pending.width = 48;
    h.state_mut().pending.height = 48;
    h.step();
    h.get_by_label("Apply & restart").click();
    // Every frame until the new film is done: no note that an image was shrunk to the
    // GPU's texture limit (the steady and rainbow images keep the old film's picture for
    // a frame or two, which once read as a texture too small for the new film).
    let start = Instant::now();
    while h.state().status().map(|s| s.state) != Some(WorkerState::Done)
        || h.state().snapshot().is_none_or(|s| s.width() != 48)
    {
        h.step();
        assert!(
            h.query_by_label_contains("shown as").is_none(),
            "a texture-limit note on a film within the limit"
        );
        assert!(start.elapsed() < Duration::from_secs(60), "no new film");
        std::thread::sleep(Duration::from_millis(5));
    }
    h.run_steps(2);
    let snap = h.state().snapshot().unwrap();
    assert_eq!((snap.width(), snap.height()), (48, 48));
    // Pixel (x, y) of 24 holds [x/24, (x+1)/24): its centre is in pixel 2x + 1 of 48.
    assert_eq!(h.state().selection, Some(Selection::pixel(7, 41)));
    assert_eq!(h.state().pins, vec![Selection::pixel(35, 13)]);
    assert!(
        h.state()
            .messages()
            .iter()
            .any(|m| m.contains("same scene point")),
        "{:?}",
        h.state().messages()
    );
}

/// The sensor tab opens on the film's window and the pulse (not on all 256 LiDAR
/// gates), with the preset fitted to the window (said so, with a way back); gates
/// outside the window are said so, and fitting them clears it.
#[test]
fn the_sensor_tab_opens_on_the_window_and_flags_gates_outside_it() {
    let mut h = harness(ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:cornell", 16, 64, 4)
    });
    wait_done(&mut h, Duration::from_secs(120));
    h.run_steps(3);
    let axis = *h.state().snapshot().unwrap().axis();
    let (lo, hi) = h
        .state()
        .sensor
        .editor_view_s()
        .expect("the editor was drawn");
    assert!(
        lo <= axis.t0_s && hi >= axis.end_s(),
        "{lo}..{hi} vs the window"
    );
    // The LiDAR pulse, 2 ns FWHM at 5 ns, is in view; the 256 ns of gates are not.
    assert!(lo <= 4e-9 && hi >= 6e-9, "{lo}..{hi}");
    assert!(
        hi - lo < 1.5 * (axis.end_s() - lo.min(axis.t0_s)) + 4e-9,
        "{lo}..{hi}"
    );
    // It opens on a gate that sees light: the LiDAR's gate 0 closes before its pulse
    // (centred 5 ns after the trigger) has lit anything, and shows black.
    let snap = h.state().snapshot().unwrap();
    let gate = h.state().sensor.gate;
    assert!(gate > 0, "opened on gate 0");
    let plane = h
        .state()
        .sensor
        .shown_plane(&snap)
        .expect("the shown gate is measured");
    assert!(plane.iter().any(|&v| v > 0.0), "gate {gate} is black");
    // The LiDAR's 256 gates of 1 ns run far past this window: the tab opened on the
    // ones that see it, and says so; the preset's own gates are one click away, and
    // then flagged.
    let note = label_with(&h, "Fitted the Full-waveform LiDAR preset");
    assert!(note.contains("of 256"), "{note}");
    let kept = h.state().settings.sensor.exposure.count();
    assert!((10..=30).contains(&kept), "{kept} gates kept: {note}");
    assert!(
        h.query_by_label_contains("outside the rendered window")
            .is_none()
    );
    // A fitted preset has no warnings: no gate it kept misses part of its light.
    assert!(h.query_by_label_contains("partly outside").is_none());
    h.get_by_label("Keep all 256 gates").click();
    h.run_steps(2);
    assert_eq!(h.state().settings.sensor.exposure.count(), 256);
    assert!(h.query_by_label_contains("Fitted the").is_none());
    let warning = label_with(&h, "lie outside the rendered window");
    assert!(warning.contains("of 256"), "{warning}");
    // Gated camera: 8 gates of 3 ns from the window's start, past its end. Picked,
    // it is fitted too; its own gates, flagged, can instead tile the window.
    h.get_by_label("gated").click();
    h.run_steps(2);
    assert!(h.state().settings.sensor.exposure.count() < 8);
    h.get_by_label("Keep all 8 gates").click();
    h.run_steps(2);
    let warning = label_with(&h, "lie outside the rendered window");
    assert!(warning.contains("of 8"), "{warning}");
    h.get_by_label("Fit the gates to the window").click();
    h.run_steps(2);
    assert!(
        h.query_by_label_contains("outside the rendered window")
            .is_none()
    );
    let Exposure::Box { width_s, count, .. } = h.state().settings.sensor.exposure else {
        panic!("box gates expected");
    };
    assert_eq!(count, 8);
    assert!((width_s * 8.0 - (axis.end_s() - axis.t0_s)).abs() < 1e-15);
}

/// Switching presets never shows one preset's image with another's exposure: the
/// white point taken at once is the one all gates' measurement gives later.
#[test]
fn switching_presets_keeps_the_exposure_steady() {
    let mut h = harness(ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:cornell", 16, 64, 4)
    });
    wait_done(&mut h, Duration::from_secs(120));
    wait_sensor(&mut h);
    let lidar = h.state().sensor.shared_white().unwrap();
    h.get_by_label("gated").click();
    h.run_steps(2);
    let at_once = h
        .state()
        .sensor
        .shared_white()
        .expect("an exposure at once");
    assert_ne!(
        at_once, lidar,
        "the gated camera's own exposure, not the LiDAR's"
    );
    wait_sensor(&mut h);
    let later = h.state().sensor.shared_white().unwrap();
    assert_eq!(at_once, later);
}

/// The status line counts wall time, and a render with a target shows a progress bar
/// with the time left; an error target stops the render once the film's own error
/// estimate is at or under it.
#[test]
fn progress_is_shown_in_wall_time_toward_the_target() {
    // A target far away: still rendering while we look.
    let mut h = harness(small_settings("builtin:cornell", 8, 16, 10_000_000));
    let start = Instant::now();
    loop {
        h.step();
        let s = h.state().status().unwrap();
        if s.state == WorkerState::Rendering && s.spp > 0 {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(60), "no pass");
        std::thread::sleep(Duration::from_millis(20));
    }
    // Let the wall clock run past the last pass.
    std::thread::sleep(Duration::from_millis(300));
    h.run_steps(2);
    let bar = label_with(&h, "% · ~");
    assert!(bar.ends_with(" left"), "{bar}");
    // The status line's parts are labels of their own (the bar wraps between them).
    let wall = label_with(&h, "s wall");
    let shown = number_after(&format!(" {wall}"), "");
    let s = h.state().status().unwrap();
    // Wall time: at least the status's time at the last pass, and it keeps running.
    assert!(shown >= s.elapsed_s - 0.05, "{wall} vs {}", s.elapsed_s);
    // The frame time: "UI x ms/frame", or with eframe's CPU figure "frame x ms CPU ...".
    assert!(
        h.query_by_label_contains("ms/frame").is_some()
            || h.query_by_label_contains("ms CPU").is_some(),
        "no frame time in the status line"
    );

    // An error target of 20 %: done once the estimate is under it.
    let mut h = harness(ViewerSettings {
        error_target_pct: 20.0,
        ..small_settings("builtin:cornell", 8, 16, 0)
    });
    wait_done(&mut h, Duration::from_secs(120));
    let e = h.state().snapshot().unwrap().error_estimate.unwrap();
    assert!(e <= 0.2, "stopped at {e}");
    let bar = label_with(&h, "target reached");
    assert!(!bar.is_empty());
}

/// With no system file dialog, "Open cube…" offers a path field; the cube opens and
/// the panel shows its own facts.
#[test]
fn without_a_file_dialog_a_path_field_opens_a_cube() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("viewer-path-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(["render", "builtin:canopy", "--width", "10", "--height", "8"])
        .args(["--spp", "2", "--bins", "30", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut h = harness(small_settings("builtin:cornell", 12, 16, 1));
    h.state_mut().file_dialogs = false;
    h.get_by_label("Open cube…").click();
    h.run_steps(2);
    let field = h.get_by_label("path");
    field.focus();
    h.step();
    h.get_by_label("path").type_text(&dir.display().to_string());
    h.step();
    h.get_by_label("OK").click();
    h.run_steps(3);
    let snap = h.state().snapshot().expect("the cube is shown");
    assert_eq!((snap.width(), snap.height(), snap.axis().bins), (10, 8, 30));
    h.get_by_label("10 × 8 px × 30 bins");
    // A cube without bounce layers shows no bounce toggles.
    assert!(h.query_by_label_contains("no bounce layers").is_some());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bad_scene_is_reported_in_the_window() {
    let mut h = harness(small_settings("/no/such/scene.gltf", 16, 16, 1));
    let start = Instant::now();
    loop {
        h.step();
        if matches!(
            h.state().status().map(|s| s.state),
            Some(WorkerState::Failed(_))
        ) {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no failure reported"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    h.run_steps(2);
    assert!(
        h.state()
            .messages()
            .iter()
            .any(|m| m.contains("scene.gltf")),
        "messages: {:?}",
        h.state().messages()
    );
    // The window keeps running and a built-in can be opened from it.
    open_builtin(&mut h, "cornell");
    h.step();
    assert_eq!(h.state().settings.scene, "builtin:cornell");
}

/// Renders the window where a wgpu adapter exists; skips (with a note) where none does.
fn render(h: &mut Harness<'static, TprfApp>) -> Option<image::RgbaImage> {
    match h.render() {
        Ok(mut img) => {
            tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
            Some(img)
        }
        Err(e) => {
            eprintln!("no wgpu adapter, window image not checked: {e}");
            None
        }
    }
}

#[test]
fn the_window_image_shows_the_scene() {
    let side = 48;
    let mut h = harness(small_settings("builtin:cornell", side, 64, 16));
    wait_done(&mut h, Duration::from_secs(120));
    h.state_mut().playing = false;
    let Some(img) = render(&mut h) else { return };
    assert_eq!((img.width(), img.height()), (1280, 800));
    // The steady image: a lit box, so its area has both bright and dark pixels, and
    // the lamp region near its top is brighter than the floor shadow region.
    let rect = h.get_by_label("steady image").rect();
    let lum = |x: f32, y: f32| {
        let p = img.get_pixel(
            (rect.min.x + x * rect.width()) as u32,
            (rect.min.y + y * rect.height()) as u32,
        );
        0.2126 * p[0] as f32 + 0.7152 * p[1] as f32 + 0.0722 * p[2] as f32
    };
    let samples: Vec<f32> = (1..10)
        .flat_map(|i| (1..10).map(move |j| (i as f32 / 10.0, j as f32 / 10.0)))
        .map(|(x, y)| lum(x, y))
        .collect();
    let (lo, hi) = samples
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(hi - lo > 60.0, "steady image is flat: luminance {lo}..{hi}");
    assert!(hi > 120.0, "steady image is dark: max luminance {hi}");
}

/// `TPRF_SCREENSHOTS=1 cargo test --release --test viewer -- --ignored screenshots`
/// writes the README's screenshots.
#[test]
#[ignore = "writes screenshots/; run by hand"]
fn screenshots() {
    if std::env::var_os("TPRF_SCREENSHOTS").is_none() {
        eprintln!("set TPRF_SCREENSHOTS=1 to write screenshots/");
        return;
    }
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("screenshots");
    std::fs::create_dir_all(&dir).unwrap();

    // Cornell box mid-propagation, a back-wall pixel plotted.
    let side = 160;
    let mut h = harness(small_settings("builtin:cornell", side, 256, 512));
    wait_done(&mut h, Duration::from_secs(600));
    {
        let app = h.state_mut();
        app.playing = false;
        app.selection = Some(Selection::pixel(60, 50));
        let snap = app.snapshot().unwrap();
        // The bin where the first wave has swept the back wall: the selected pixel's
        // peak plus a little.
        let px = snap.pixel(60, 50);
        let peak = px
            .iter()
            .enumerate()
            .fold((0, 0.0f32), |a, (i, &v)| if v > a.1 { (i, v) } else { a })
            .0;
        app.bin = (peak + 6).min(snap.axis().bins - 1);
    }
    h.remove_cursor();
    h.run_steps(3);
    let mut img = h.render().expect("a wgpu adapter for screenshots");
    tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
    img.save(dir.join("cornell.png")).unwrap();

    // Canopy: airborne LiDAR over a partly covered foliage layer.
    let mut h = harness(ViewerSettings {
        plot_log: true,
        ..small_settings("builtin:canopy", 160, 256, 256)
    });
    wait_done(&mut h, Duration::from_secs(600));
    {
        let app = h.state_mut();
        app.playing = false;
        app.selection = Some(Selection::pixel(80, 80));
        let snap = app.snapshot().unwrap();
        let px = snap.pixel(80, 80);
        let peak = px
            .iter()
            .enumerate()
            .fold((0, 0.0f32), |a, (i, &v)| if v > a.1 { (i, v) } else { a })
            .0;
        app.bin = peak.min(snap.axis().bins - 1);
    }
    h.remove_cursor();
    h.run_steps(3);
    let mut img = h.render().expect("a wgpu adapter for screenshots");
    tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
    img.save(dir.join("canopy.png")).unwrap();

    // The sensor over the Cornell box: the full-waveform LiDAR preset with a pulse
    // and box gates; the envelope editor over a back-wall pixel.
    let mut h = harness(ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:cornell", 160, 256, 256)
    });
    wait_done(&mut h, Duration::from_secs(600));
    {
        let app = h.state_mut();
        app.playing = false;
        app.selection = Some(Selection::pixel(60, 50));
        app.settings.sensor = Sensor::builtin("lidar").unwrap();
        app.settings.sensor.exposure = Exposure::Box {
            origin: TimeOrigin::Window,
            start_s: 0.0,
            width_s: 0.4e-9,
            step_s: None,
            count: 32,
            gain: 1.0,
        };
        app.settings.sensor.light = LightPulse::Gaussian {
            centre_s: 0.5e-9,
            fwhm_s: 0.3e-9,
            energy: 1.0,
        };
        app.sensor.gate = 5;
    }
    h.remove_cursor();
    h.run_steps(2);
    // All gates measured: the strip of gate images under the measurement shows.
    let snap = h.state().snapshot().unwrap();
    let start = std::time::Instant::now();
    while !h.state().sensor.is_current(&snap) && start.elapsed() < Duration::from_secs(120) {
        h.step();
        std::thread::sleep(Duration::from_millis(20));
    }
    h.run_steps(4);
    let mut img = h.render().expect("a wgpu adapter for screenshots");
    tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
    img.save(dir.join("sensor.png")).unwrap();

    // The SPAD preset on the same film: a bin of the histogram, its depth, and the
    // pixel's histogram with pile-up and the Coates estimate.
    {
        let app = h.state_mut();
        app.settings.sensor = Sensor::builtin("spad").unwrap();
        app.sensor.gate = 0;
    }
    h.run_steps(2);
    let snap = h.state().snapshot().unwrap();
    let start = std::time::Instant::now();
    // The expected histogram, then the realisation.
    while (!h.state().sensor.is_current(&snap) || h.state().sensor.spad_sampling())
        && start.elapsed() < Duration::from_secs(120)
    {
        h.step();
        std::thread::sleep(Duration::from_millis(20));
    }
    h.run_steps(4);
    let mut img = h.render().expect("a wgpu adapter for screenshots");
    tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
    img.save(dir.join("spad.png")).unwrap();
}

#[test]
fn opens_a_saved_cube_without_rendering() {
    let dir = tprf_render(
        "cube",
        &[
            "builtin:cornell",
            "--width",
            "20",
            "--height",
            "12",
            "--spp",
            "4",
            "--bins",
            "40",
        ],
    );
    let cube_dir = dir.clone();
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(cc, ViewerSettings::default(), Start::Cube(cube_dir))
        });
    h.run_steps(3);
    assert!(h.state().status().is_none(), "no renderer runs for a cube");
    let snap = h.state().snapshot().expect("the cube is shown");
    assert_eq!(
        (snap.width(), snap.height(), snap.axis().bins),
        (20, 12, 40)
    );
    // The viewer shows the file's numbers: compare with tprf.npy read independently.
    let bytes = std::fs::read(dir.join("tprf.npy")).unwrap();
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let data: Vec<f32> = bytes[10 + header_len..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    assert_eq!(data.len(), 20 * 12 * 40);
    assert_eq!(
        snap.pixel(7, 5),
        &data[(5 * 20 + 7) * 40..(5 * 20 + 8) * 40]
    );
    assert!(
        h.state()
            .status_line(Some(&snap))
            .contains("builtin:cornell")
    );

    // A directory that is not a cube: an error in the window, not a panic.
    let bad = dir.join("not-a-cube");
    std::fs::create_dir_all(&bad).unwrap();
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(cc, ViewerSettings::default(), Start::Cube(bad))
        });
    h.run_steps(2);
    assert!(
        h.state().messages().iter().any(|m| m.contains("tprf.json")),
        "{:?}",
        h.state().messages()
    );
}

#[test]
fn changing_the_resolution_restarts_the_render() {
    let mut h = harness(small_settings("builtin:cornell", 16, 32, 0));
    let start = Instant::now();
    while h.state().snapshot().is_none() {
        h.step();
        assert!(start.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(10));
    }
    h.state_mut().pending.width = 24;
    h.state_mut().pending.spp_target = 2;
    h.step();
    h.get_by_label("Apply & restart").click();
    h.step();
    assert_eq!(h.state().settings.width, 24);
    wait_done(&mut h, Duration::from_secs(60));
    let snap = h.state().snapshot().unwrap();
    assert_eq!((snap.width(), snap.height(), snap.spp), (24, 16, 2));
}

#[test]
fn absurd_settings_are_clamped_or_refused() {
    let settings = ViewerSettings {
        width: 0,
        height: 1_000_000,
        bins: usize::MAX,
        play_bins_per_s: f32::NAN,
        ev: f32::INFINITY,
        dt: "-5 ns".into(),
        ..small_settings("builtin:cornell", 8, 8, 1)
    };
    let mut h = harness(settings);
    h.run_steps(3);
    let s = &h.state().settings;
    assert!(s.width >= 1 && s.height <= 4096 && s.bins <= 16384);
    assert!(s.play_bins_per_s.is_finite() && s.ev.is_finite());
    // A negative bin width cannot start a render: said in the window.
    assert!(
        h.state().messages().iter().any(|m| m.contains("bin width")),
        "{:?}",
        h.state().messages()
    );
    // An unparsable one neither.
    h.state_mut().pending.dt = "fast".into();
    h.state_mut().pending.t0 = String::new();
    h.step();
    h.get_by_label("Apply & restart").click();
    h.step();
    assert!(
        h.state().messages().iter().any(|m| m.contains("fast")),
        "{:?}",
        h.state().messages()
    );
}

/// Step until the sensor has measured every gate of the current film.
fn wait_sensor(h: &mut Harness<'static, TprfApp>) {
    let start = Instant::now();
    loop {
        h.step();
        let snap = h.state().snapshot().unwrap();
        if h.state().sensor.is_current(&snap) {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "sensor never caught up"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn sensor_mode_measures_the_cached_film_within_a_frame() {
    let (side, bins) = (16, 40);
    let mut h = harness(ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:cornell", side, bins, 8)
    });
    wait_done(&mut h, Duration::from_secs(120));
    let snap = h.state().snapshot().unwrap();
    let axis = *snap.axis();
    let window_s = axis.dt_s * bins as f64;
    let steady: Vec<f64> = (0..side * side)
        .map(|p| {
            snap.pixel(p % side, p / side)
                .iter()
                .map(|&v| v as f64)
                .sum()
        })
        .collect();
    let close = |got: f64, want: f64, what: &str| {
        assert!(
            (got - want).abs() <= 1e-5 * want.max(1e-12),
            "{what}: {got} vs steady {want}"
        );
    };
    // A delta pulse at t = 0 and one gate over the whole window: the gate sees every
    // bin once, so M_0 = the steady value. The image on screen has it within the frame.
    h.state_mut().settings.sensor = Sensor::new(
        LightPulse::Delta {
            t_s: 0.0,
            energy: 1.0,
        },
        Exposure::Box {
            origin: TimeOrigin::Window,
            start_s: 0.0,
            width_s: window_s,
            step_s: None,
            count: 1,
            gain: 1.0,
        },
    );
    h.step();
    let plane = h
        .state()
        .sensor
        .shown_plane(&snap)
        .expect("the gate on screen is measured in the same frame")
        .to_vec();
    for (p, want) in steady.iter().enumerate() {
        close(plane[p] as f64, *want, &format!("pixel {p}, shown gate"));
    }
    // Eight gates side by side: together they still see every bin once.
    if let Exposure::Box { width_s, count, .. } = &mut h.state_mut().settings.sensor.exposure {
        *width_s = window_s / 8.0;
        *count = 8;
    }
    h.step();
    assert!(h.state().sensor.shown_plane(&snap).is_some());
    wait_sensor(&mut h);
    let m = h.state().sensor.measurements().unwrap();
    assert_eq!((m.gates, m.height, m.width), (8, side, side));
    for (p, want) in steady.iter().enumerate() {
        close(
            (0..8).map(|i| m.plane(i)[p] as f64).sum(),
            *want,
            &format!("pixel {p}, sum over gates"),
        );
    }
    // Under the images, the strip of gate images: a click on one shows that gate.
    h.run_steps(2);
    h.get_by_label("gate 3 thumbnail").click();
    h.run_steps(2);
    assert_eq!(h.state().sensor.gate, 3);
    // A gate entirely before the window measures exactly zero.
    h.state_mut().settings.sensor.exposure = Exposure::Box {
        origin: TimeOrigin::Pulse,
        start_s: 0.0,
        width_s: axis.t0_s * 0.5,
        step_s: None,
        count: 1,
        gain: 1.0,
    };
    h.step();
    assert!(
        h.state()
            .sensor
            .shown_plane(&snap)
            .unwrap()
            .iter()
            .all(|&v| v == 0.0)
    );
    wait_sensor(&mut h);
    assert!(
        h.state()
            .sensor
            .measurements()
            .unwrap()
            .values
            .iter()
            .all(|&v| v == 0.0)
    );
    // An invalid edit (negative width) is reported and the last good measurement kept.
    if let Exposure::Box { width_s, .. } = &mut h.state_mut().settings.sensor.exposure {
        *width_s = -1.0;
    }
    h.step();
    assert!(
        h.state()
            .sensor
            .error
            .as_deref()
            .is_some_and(|e| e.contains("width")),
        "{:?}",
        h.state().sensor.error
    );
    assert_eq!(h.state().sensor.measurements().unwrap().gates, 1);
    // The window still draws the sensor's widgets.
    h.step();
    h.get_by_label("envelope editor");
    h.get_by_label("measurement image");
}

/// A `side x side` film of `bins` bins where pixel `p`, bin `b` holds `scale * (p + b + 1)`.
fn ramp_snapshot(side: usize, bins: usize, scale: f32) -> FilmSnapshot {
    let layout = FilmLayout {
        width: side,
        height: side,
        axis: TimeAxis::new(1e-9, 1e-10, bins).unwrap(),
        bounces_separate: 0,
        luminescence: false,
    };
    let cube: Vec<f32> = (0..side * side * bins)
        .map(|i| scale * ((i / bins) + (i % bins) + 1) as f32)
        .collect();
    FilmSnapshot::from_dense(layout, 1, 1, &cube, &[], None)
}

/// The viewer keys what it caches on the snapshot's generation, not its address: a
/// snapshot freed and a new one made at the same address (as the render worker does
/// every pass) shows the new one's values, not the cached ones.
#[test]
fn a_new_snapshot_at_a_freed_ones_address_is_not_taken_for_it() {
    let (side, bins) = (6, 10);
    let window_s = 1e-10 * bins as f64;
    // One gate over the whole window: the gate's image is the steady image.
    let sensor = Sensor::new(
        LightPulse::Delta {
            t_s: 0.0,
            energy: 1.0,
        },
        Exposure::Box {
            origin: TimeOrigin::Window,
            start_s: 0.0,
            width_s: window_s,
            step_s: None,
            count: 1,
            gain: 1.0,
        },
    );
    let steady = |snap: &FilmSnapshot| -> Vec<f64> {
        (0..side * side)
            .map(|p| {
                snap.pixel(p % side, p / side)
                    .iter()
                    .map(|&v| v as f64)
                    .sum()
            })
            .collect()
    };
    let assert_shows = |state: &SensorState, snap: &FilmSnapshot, what: &str| {
        let plane = state
            .shown_plane(snap)
            .expect("the gate on screen is measured");
        for (p, (got, want)) in plane.iter().zip(steady(snap)).enumerate() {
            assert!(
                (*got as f64 - want).abs() <= 1e-5 * want,
                "{what}, pixel {p}: shows {got}, the film has {want}"
            );
        }
    };

    let mut state = SensorState::default();
    let a = Arc::new(ramp_snapshot(side, bins, 1.0));
    // Another snapshot's data, made before `a` is freed so its own buffers do not take
    // `a`'s place.
    let b_data = ramp_snapshot(side, bins, 3.0);
    state.update(&sensor, &a);
    assert_shows(&state, &a, "first snapshot");
    // All gates measured in the background; then the measuring thread lets go of `a`.
    let start = Instant::now();
    while !state.is_current(&a) || Arc::strong_count(&a) > 1 {
        assert!(start.elapsed() < Duration::from_secs(30), "no measurement");
        std::thread::sleep(Duration::from_millis(2));
        state.update(&sensor, &a);
    }
    assert_shows(&state, &a, "first snapshot, all gates");
    let (addr, generation) = (Arc::as_ptr(&a), a.generation());
    drop(a);

    // New snapshots until one lands where `a` was (kept alive meanwhile, so the
    // allocator moves on); clones share their generation.
    let mut tries = Vec::new();
    let b = loop {
        let b = Arc::new(b_data.clone());
        if Arc::as_ptr(&b) == addr || tries.len() >= 100_000 {
            break b;
        }
        tries.push(b);
    };
    if Arc::as_ptr(&b) == addr {
        eprintln!("address reused after {} tries", tries.len());
    } else {
        eprintln!("the allocator never reused the address: generations compared only");
    }
    drop(tries);
    assert_ne!(b.generation(), generation);
    assert!(!state.is_current(&b), "measurements of a freed snapshot");
    state.update(&sensor, &b);
    assert_shows(&state, &b, "second snapshot at the first one's address");
}

/// After an edit, the SPAD's preview (a coarse grid of pixels, measured beside the full
/// image) comes for the edited sensor, and each of its pixels is the full image's at
/// that pixel, as tprf_core's one-shot image computes it from the whole film.
#[test]
fn spad_preview_follows_an_edit_and_matches_the_full_image_at_its_pixels() {
    let (side, bins) = (64, 32);
    let mut h = harness(ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:cornell", side, bins, 4)
    });
    wait_done(&mut h, Duration::from_secs(120));
    let snap = h.state().snapshot().unwrap();
    h.state_mut().settings.sensor = Sensor::builtin("spad").unwrap();
    h.step();
    wait_sensor(&mut h);
    // A SPAD-only edit (the clean measurement is reused by the full job) and then a
    // light edit (measured again, on the grid too).
    for edit in 0..2 {
        let sensor = &mut h.state_mut().settings.sensor;
        if edit == 0 {
            sensor.spad.as_mut().expect("a SPAD").pde = 0.45;
        } else if let LightPulse::Gaussian { centre_s, .. } = &mut sensor.light {
            *centre_s += 50e-12;
        }
        // The frame of the edit keeps the SPAD's images (the last ones, marked as
        // updating) rather than falling back to the bin's plain measurement.
        h.step();
        assert!(
            h.query_all_by_label_contains("TDC bin k").next().is_some(),
            "edit {edit}: the SPAD view left the screen"
        );
        assert!(
            h.state().sensor.spad_previewing(&snap)
                || h.query_by_label_contains("Updating after the edit")
                    .is_some(),
            "edit {edit}: stale histograms shown unmarked"
        );
        let start = Instant::now();
        loop {
            h.step();
            if h.state().sensor.spad_preview(&snap).is_some() {
                break;
            }
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "no preview after edit {edit}"
            );
            std::thread::sleep(Duration::from_millis(2));
        }
        // TPRF_SPAD_PREVIEW_SHOT=FILE: a picture of the tab showing the preview, to look
        // at (when the full image has not come yet).
        if let Some(path) = std::env::var_os("TPRF_SPAD_PREVIEW_SHOT")
            && edit == 0
            && h.state().sensor.spad_previewing(&snap)
            && let Some(shot) = render(&mut h)
        {
            shot.save(path).unwrap();
        }
        let (preview, step) = {
            let (p, s) = h.state().sensor.spad_preview(&snap).expect("preview");
            (p.clone(), s)
        };
        assert!(
            step >= 2,
            "a 64 x 64 x 512 film is previewed on a grid: step {step}"
        );
        assert_eq!(
            (preview.width, preview.height),
            (side.div_ceil(step), side.div_ceil(step))
        );
        let model = h.state().sensor.model().expect("a model").clone();
        assert_eq!(Some(model.sensor()), Some(&h.state().settings.sensor));
        let clean = model.measure_clean_film(&snap);
        let whole = tprf_core::sensor::spad::spad_expected(&model, &clean, snap.steady(), None)
            .expect("spad");
        let mut lit = 0;
        for j in 0..preview.height {
            for i in 0..preview.width {
                let (x, y) = (
                    (i * step + step / 2).min(side - 1),
                    (j * step + step / 2).min(side - 1),
                );
                let got = preview.pixel(&preview.histogram, j, i);
                let want = whole.pixel(&whole.histogram, y, x);
                for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                    assert!(
                        (g - w).abs() <= 1e-5 * w.abs().max(1e-3),
                        "edit {edit}, pixel ({y}, {x}), bin {k}: preview {g} vs full {w}"
                    );
                }
                let (dg, dw) = (
                    preview.depth_histogram_m[j * preview.width + i],
                    whole.depth_histogram_m[y * side + x],
                );
                assert!(
                    (dg.is_nan() && dw.is_nan()) || (dg - dw).abs() <= 1e-4,
                    "edit {edit}, pixel ({y}, {x}): depth {dg} vs {dw}"
                );
                lit += usize::from(dw.is_finite());
            }
        }
        assert!(
            lit > preview.width * preview.height / 2,
            "few returns: {lit}"
        );
        wait_sensor(&mut h);
    }
}

/// While the renderer runs, the SPAD's full image (every pixel, realisation drawn: not
/// the preview) comes and then follows the film: newer passes are measured in their
/// turn, the full image stays on screen meanwhile (never the preview again), and the
/// render goes on. (It used to stay on the preview for as long as the render ran: each
/// new snapshot restarted the full measurement, and cancelled its realisation.)
#[test]
fn spad_full_image_follows_a_running_render() {
    let side = 64;
    let mut h = harness(ViewerSettings {
        mode: Mode::Sensor,
        sensor: Sensor::builtin("spad").unwrap(),
        ..small_settings("builtin:cornell", side, 64, 0)
    });
    let start = Instant::now();
    // (film generation, spp) of each full image seen, in order.
    let mut seen: Vec<(u64, u64)> = Vec::new();
    while seen.len() < 3 {
        assert!(
            start.elapsed() < Duration::from_secs(150),
            "full SPAD images of {} passes in 150 s: {seen:?}",
            seen.len()
        );
        h.step();
        std::thread::sleep(Duration::from_millis(10));
        let Some(snap) = h.state().snapshot() else {
            continue;
        };
        let sensor = &h.state().sensor;
        match sensor.spad_image(&snap) {
            Some(img) if img.is_sampled() => {
                assert_eq!((img.width, img.height), (side, side));
                let (g, spp) = sensor.shown_film(&snap).expect("the film it is of");
                assert!(g <= snap.generation());
                if seen.last().map(|s| s.0) != Some(g) {
                    assert!(seen.last().is_none_or(|s| s.0 < g), "{seen:?} then {g}");
                    seen.push((g, spp));
                }
            }
            _ => assert!(
                seen.is_empty(),
                "after full images of {seen:?}, the window went back to the preview or to \
                 the expected histogram alone"
            ),
        }
    }
    let status = h.state().status().expect("a render");
    assert_eq!(status.state, WorkerState::Rendering);
    let snap = h.state().snapshot().unwrap();
    assert!(
        snap.spp > seen[0].1,
        "the render stalled: {} spp, {seen:?}",
        snap.spp
    );
}

/// A new resolution in SPAD mode: the histograms of the old film (another size) are
/// never drawn over the new one; every frame until the new film's are measured shows
/// histograms of the new film's size or none, and they come.
#[test]
fn a_new_resolution_in_spad_mode_never_shows_the_old_films_histograms() {
    // Tall enough that the SPAD's controls leave "Apply & restart" on screen.
    let settings = ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:cornell", 16, 32, 2)
    };
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 1800.0))
        .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default));
    wait_done(&mut h, Duration::from_secs(120));
    h.state_mut().settings.sensor = Sensor::builtin("spad").unwrap();
    h.step();
    wait_sensor(&mut h);
    let old = h.state().snapshot().unwrap();
    assert!(h.state().sensor.spad_image(&old).is_some());
    h.state_mut().pending.width = 24;
    h.step();
    h.get_by_label("Apply & restart").click();
    let start = Instant::now();
    loop {
        h.step();
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no SPAD histograms of the new film"
        );
        // The restarted render has no film for its first moments.
        let Some(snap) = h.state().snapshot() else {
            std::thread::sleep(Duration::from_millis(5));
            continue;
        };
        if let Some(img) = h.state().sensor.spad_image(&snap) {
            assert_eq!((img.width, img.height), (snap.width(), snap.height()));
            if snap.width() == 24 {
                break;
            }
        }
        if let Some((img, step)) = h.state().sensor.spad_preview(&snap) {
            assert_eq!(
                (img.width, img.height),
                (snap.width().div_ceil(step), snap.height().div_ceil(step))
            );
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn spad_preset_shows_the_first_photon_histogram_of_the_cached_film() {
    use tprf_core::sensor::Spad;
    let (side, bins) = (12, 48);
    let mut h = harness(ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:cornell", side, bins, 16)
    });
    wait_done(&mut h, Duration::from_secs(120));
    let snap = h.state().snapshot().unwrap();
    let axis = *snap.axis();
    // The built-in preset loads and measures.
    h.state_mut().settings.sensor = Sensor::builtin("spad").unwrap();
    h.step();
    wait_sensor(&mut h);
    assert!(h.state().sensor.spad_image(&snap).is_some());
    // A delta pulse at t = 0 and TDC bins that are the film's own bins, no jitter, a
    // dead time of the whole cycle, every photon detected, no background: the
    // expected histogram is the first-photon formula on the pixel's TPRF itself,
    // N (1 - e^-s_k) exp(-sum_{j<k} s_j), s_k = photons x TPRF[k].
    let (cycles, photons) = (5000u64, 1.0);
    let mut sensor = Sensor::new(
        LightPulse::Delta {
            t_s: 0.0,
            energy: 1.0,
        },
        Exposure::Tdc {
            origin: TimeOrigin::Window,
            start_s: 0.0,
            bin_width_s: axis.dt_s,
            bins: bins as u64,
            jitter_fwhm_s: 0.0,
        },
    );
    sensor.spad = Some(Spad {
        cycles,
        pde: 1.0,
        photons_per_unit: photons,
        dead_time_s: axis.dt_s * bins as f64,
        ..Spad::default()
    });
    h.state_mut().settings.sensor = sensor;
    h.state_mut().selection = Some(Selection::pixel(side / 2, side / 2));
    h.step();
    wait_sensor(&mut h);
    let img = h
        .state()
        .sensor
        .spad_image(&snap)
        .expect("SPAD histograms of the current film")
        .clone();
    assert_eq!((img.bins, img.height, img.width), (bins, side, side));
    let mut checked = 0;
    for (y, x) in [(side / 2, side / 2), (1, 1), (side - 2, 3)] {
        let tprf = snap.pixel(x, y);
        let got = img.pixel(&img.histogram, y, x);
        let mut before = 0.0f64;
        for k in 0..bins {
            let s = photons * f64::from(tprf[k]).max(0.0);
            let want = cycles as f64 * (1.0 - (-s).exp()) * (-before).exp();
            assert!(
                (f64::from(got[k]) - want).abs() <= 1e-3 * want.max(1.0),
                "pixel ({y}, {x}), bin {k}: {} vs first-photon {want}",
                got[k]
            );
            before += s;
            checked += usize::from(want > 1.0);
        }
    }
    assert!(checked > 10, "too little light to check: {checked} bins");
    // The realisation follows the expected histogram from the same job, drawn as
    // tprf_core's one-shot image draws it (same seed, same film and sensor).
    let start = Instant::now();
    while h.state().sensor.spad_sampling() {
        h.step();
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the realisation never came"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let sampled = h.state().sensor.spad_image(&snap).expect("current").clone();
    assert!(sampled.is_sampled() && sampled.histogram == img.histogram);
    let model = h.state().sensor.model().expect("a model").clone();
    let clean = model.measure_clean_film(&snap);
    let whole = tprf_core::sensor::spad_image(&model, &clean, snap.steady()).expect("spad");
    assert_eq!(sampled.counts, whole.counts);
    assert!(sampled.counts.iter().sum::<f32>() > 0.0);
    // An edit while a realisation is drawn cancels it; the next one is of the edit.
    for cycles in [7000, 9000] {
        if let Some(s) = h.state_mut().settings.sensor.spad.as_mut() {
            s.cycles = cycles;
        }
        h.step();
    }
    wait_sensor(&mut h);
    let start = Instant::now();
    while h.state().sensor.spad_sampling() {
        h.step();
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the realisation never came"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let last = h.state().sensor.spad_image(&snap).expect("current").clone();
    assert!(last.is_sampled());
    let n: f32 = last.counts.iter().sum();
    let e: f32 = last.histogram.iter().sum();
    assert!(
        (n - e).abs() < 0.05 * e,
        "realisation {n} vs expected {e} over 9000 cycles"
    );
    // The tab draws the SPAD's images and the pixel's histogram.
    h.step();
    h.get_by_label("SPAD bin image");
    h.get_by_label("SPAD depth image");
    // TPRF_SPAD_SHOT=FILE: a picture of the tab with the built-in preset, to look at.
    if let Some(path) = std::env::var_os("TPRF_SPAD_SHOT") {
        h.state_mut().settings.sensor = Sensor::builtin("spad").unwrap();
        h.state_mut().sensor.gate = 40;
        h.step();
        wait_sensor(&mut h);
        h.run_steps(3);
        if let Some(shot) = render(&mut h) {
            shot.save(path).unwrap();
        }
    }
}

/// A cube folder rendered by `tprf render` at `w x h` pixels (4 bins, 2 spp).
fn rendered_cube(name: &str, w: usize, h: usize) -> std::path::PathBuf {
    rendered_cube_with(name, w, h, &["--bins", "4"])
}

/// A cube folder rendered by `tprf render builtin:cornell --spp 2` at `w x h` pixels
/// with the further arguments `more`.
fn rendered_cube_with(name: &str, w: usize, h: usize, more: &[&str]) -> std::path::PathBuf {
    let (w, h) = (w.to_string(), h.to_string());
    let mut args = vec!["builtin:cornell", "--spp", "2"];
    args.extend_from_slice(more);
    args.extend(["--width", &w, "--height", &h]);
    tprf_render(name, &args)
}

/// A cube folder (named after `name`) made by `tprf render ARGS --out FOLDER`.
fn tprf_render(name: &str, args: &[&str]) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("viewer-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
        .arg("render")
        .args(args)
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    dir
}

/// A cube rendered with `--bounces-separate K` keeps `K + 2` bounce layers (the light
/// seen directly, 1 ... K scattering events, more than K): the window plots a curve for
/// each (a checkbox each, the direct one off at first), named by what it holds, and
/// together they are the pixel's TPRF. (Only a film with exactly the window's own 3
/// used to get curves; `--bounces-separate 2` read "no bounce layers in this film".)
#[test]
fn bounce_curves_follow_the_films_layers() {
    for k in [1usize, 2, 3, 5] {
        let dir = rendered_cube_with(
            &format!("bounces-{k}"),
            12,
            12,
            &["--bins", "48", "--bounces-separate", &k.to_string()],
        );
        let mut h = Harness::builder()
            .with_size(Vec2::new(1280.0, 800.0))
            .build_eframe(move |cc| {
                TprfApp::with_settings(cc, ViewerSettings::default(), Start::Cube(dir))
            });
        h.run_steps(3);
        let snap = h.state().snapshot().expect("the cube is shown");
        assert_eq!(snap.layers(), k + 2);
        h.state_mut().selection = Some(Selection::pixel(6, 4));
        h.step();
        // A checkbox per layer, the last "more than K".
        for name in ["direct", "1", &format!(">{k}")] {
            assert!(
                h.query_all_by_label(name).next().is_some(),
                "K = {k}: no checkbox {name}"
            );
        }
        // Direct is off at first: K + 1 dashed curves; with it on, K + 2.
        let dashed = |h: &Harness<'static, TprfApp>| -> Vec<String> {
            h.state()
                .plotted_curves(&snap)
                .into_iter()
                .filter(|c| c.dashed)
                .map(|c| c.name)
                .collect()
        };
        let names = dashed(&h);
        assert_eq!(names.len(), k + 1, "K = {k}: {names:?}");
        assert_eq!(names.first().map(String::as_str), Some("1 bounce"));
        assert_eq!(names.last(), Some(&format!(">{k} bounces")));
        h.get_by_label("direct").click();
        h.step();
        let curves = h.state().plotted_curves(&snap);
        let names = dashed(&h);
        assert_eq!(names.len(), k + 2, "K = {k}: {names:?}");
        // The layers partition the paths: their curves sum to the pixel's TPRF.
        let total = &curves[0].values;
        for (b, t) in total.iter().enumerate() {
            let sum: f64 = curves
                .iter()
                .filter(|c| c.dashed)
                .map(|c| c.values[b])
                .sum();
            assert!(
                (sum - t).abs() <= 1e-4 * t.abs().max(1e-9),
                "K = {k}, bin {b}: layers {sum}, total {t}"
            );
        }
        assert!(total.iter().sum::<f64>() > 0.0, "K = {k}: a dark pixel");
    }
}

/// A luminescent scene's cube keeps the re-emitted light in a layer of its own (issue
/// 47): `builtin:flim` rendered with `--bounces-separate 1` has the direct, 1 and >1
/// layers and then "re-emitted"; the window names and colours it, the four add up to
/// the pixel's TPRF, and once the excitation's last reflection has passed (the slide is
/// 0.15 m away: every path that was not re-emitted has arrived within a few hundred
/// ps) the whole TPRF is the re-emitted light's.
#[test]
fn a_luminescent_cube_keeps_its_re_emitted_light_apart() {
    let dir = tprf_render(
        "flim-layers",
        &[
            "builtin:flim",
            "--spp",
            "16",
            "--width",
            "16",
            "--height",
            "16",
            "--bins",
            "96",
            "--bounces-separate",
            "1",
        ],
    );
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("tprf.json")).unwrap()).unwrap();
    assert_eq!(meta["luminescence_layer"], serde_json::json!(true));
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(cc, ViewerSettings::default(), Start::Cube(dir))
        });
    h.run_steps(3);
    let snap = h.state().snapshot().expect("the cube is shown");
    assert_eq!((snap.layers(), snap.luminescence_layer()), (4, Some(3)));
    // A pixel on a dye (the spots' centres lie at 0.3 and 0.7 of the width).
    h.state_mut().selection = Some(Selection::pixel(5, 8));
    h.step();
    h.get_by_label("re-emitted");
    h.get_by_label("direct").click();
    h.step();
    let curves = h.state().plotted_curves(&snap);
    let names: Vec<&str> = curves
        .iter()
        .filter(|c| c.dashed)
        .map(|c| c.name.as_str())
        .collect();
    assert_eq!(
        names,
        [
            "direct (0 bounces)",
            "1 bounce",
            ">1 bounces",
            "re-emitted (luminescence)"
        ]
    );
    let total = &curves[0].values;
    let re_emitted = &curves[4].values;
    let axis = snap.axis();
    // The excitation's direct return: the first lit bin of the 1-bounce layer.
    let first = curves[2]
        .values
        .iter()
        .position(|&v| v > 0.0)
        .expect("a reflection");
    let late = first + (1.0e-9 / axis.dt_s).ceil() as usize;
    let mut late_light = 0.0;
    for (b, t) in total.iter().enumerate() {
        let sum: f64 = curves
            .iter()
            .filter(|c| c.dashed)
            .map(|c| c.values[b])
            .sum();
        assert!(
            (sum - t).abs() <= 1e-4 * t.abs().max(1e-9),
            "bin {b}: layers {sum}, total {t}"
        );
        if b >= late {
            assert!(
                (re_emitted[b] - t).abs() <= 1e-4 * t.abs().max(1e-9),
                "bin {b}, {:.2} ns: re-emitted {}, total {t}",
                axis.bin_center_s(b) * 1e9,
                re_emitted[b]
            );
            late_light += t;
        }
    }
    assert!(late_light > 0.0, "no light after the excitation");
    // TPRF_FLIM_SHOT=FILE: a picture of the window with the curves, to look at.
    if let Some(path) = std::env::var_os("TPRF_FLIM_SHOT")
        && let Some(shot) = render(&mut h)
    {
        shot.save(path).unwrap();
    }
}

/// A new scene opens where its light is (the scrubber was left on a late bin, after
/// the light had passed: a black image); a restart of the same scene keeps the bin.
#[test]
fn a_new_scene_opens_where_its_light_is() {
    let bins = 64;
    let mut h = harness(small_settings("builtin:cornell", 24, bins, 2));
    wait_done(&mut h, Duration::from_secs(60));
    h.state_mut().playing = false;
    h.state_mut().bin = 40;
    h.get_by_label("⟲ Restart").click();
    wait_done(&mut h, Duration::from_secs(60));
    assert_eq!(
        h.state().bin,
        40,
        "a restart of the same scene keeps its bin"
    );
    h.state_mut().bin = bins - 1;
    open_builtin(&mut h, "canopy");
    let start = Instant::now();
    while h.state().status().map(|s| s.state) != Some(WorkerState::Done)
        || h.state().settings.scene != "builtin:canopy"
    {
        h.step();
        assert!(start.elapsed() < Duration::from_secs(120), "no canopy");
        std::thread::sleep(Duration::from_millis(10));
    }
    h.run_steps(2);
    let snap = h.state().snapshot().unwrap();
    let energy = |b: usize| snap.slice(b).iter().map(|&v| f64::from(v)).sum::<f64>();
    let brightest = (0..snap.axis().bins).map(energy).fold(0.0, f64::max);
    let bin = h.state().bin;
    assert!(
        energy(bin) >= 0.1 * brightest && brightest > 0.0,
        "the new scene opens on bin {bin}: {} of the brightest slice's {brightest}",
        energy(bin)
    );
}

/// A cube wider than the GPU's largest texture (`tprf render --width 9000 --height 2`,
/// then `tprf view`, panicked in wgpu): every texture the window makes fits the limit,
/// the images are shown shrunk with a note, and picking still reaches every film pixel.
/// The limit is set small here (1024 texels, where eframe puts the device's
/// `max_texture_dimension_2d`; egui's font atlas needs that much), so the cube need not
/// be 9000 pixels wide.
#[test]
fn a_cube_wider_than_the_texture_limit_is_shown_shrunk() {
    let (w, hgt) = (2400, 2);
    let dir = rendered_cube("wide", w, hgt);
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(cc, ViewerSettings::default(), Start::Cube(dir))
        });
    h.input_mut().max_texture_side = Some(1024);
    h.run_steps(3);
    let snap = h.state().snapshot().expect("the cube is shown");
    assert_eq!((snap.width(), snap.height()), (w, hgt));
    let sizes: Vec<(String, [usize; 2])> = h
        .ctx
        .tex_manager()
        .read()
        .allocated()
        .map(|(_, m)| (m.name.clone(), m.size))
        .filter(|(name, _)| ["Slice", "Steady", "Rainbow"].contains(&name.as_str()))
        .collect();
    assert_eq!(sizes.len(), 3, "{sizes:?}");
    for (name, [tw, th]) in &sizes {
        // 2400 wide shrinks by 3: 800 x 1 texels, each the mean of a 3 x 3 block.
        assert_eq!((*tw, *th), (800, 1), "{name}");
    }
    assert_eq!(
        h.query_all_by_label_contains("2400 x 2 pixels shown as 800 x 1")
            .count(),
        3,
        "a note under each shrunk image"
    );
    // Clicking near the right edge of the slice picks a pixel of the film, not of the
    // texture.
    let pos = pixel_pos(&h, "time slice", w - 2, 1, w, hgt);
    click_at(&mut h, pos);
    assert_eq!(h.state().selection, Some(Selection::pixel(w - 2, 1)));
    render(&mut h);
}

/// A cube with no pixels is an error in the window, not a panic.
#[test]
fn a_cube_without_pixels_is_an_error_in_the_window() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("viewer-empty-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // A real cube's metadata with its width set to 0, and an array of that shape.
    let src = rendered_cube("empty-src", 3, 2);
    let mut meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(src.join("tprf.json")).unwrap()).unwrap();
    meta["width"] = serde_json::json!(0);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("tprf.json"), meta.to_string()).unwrap();
    tprf_core::export::write_npy_f32(&dir.join("tprf.npy"), &[2, 0, 4], &[]).unwrap();
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(cc, ViewerSettings::default(), Start::Cube(dir))
        });
    h.run_steps(3);
    assert!(h.state().snapshot().is_none());
    assert!(
        h.state()
            .messages()
            .iter()
            .any(|m| m.contains("0 x 2 pixels x 4 bins: there is nothing in it")),
        "{:?}",
        h.state().messages()
    );
    // In the messages and in place of the images (no spinner: nothing is coming).
    assert!(
        h.query_all_by_label_contains("there is nothing in it")
            .count()
            >= 2
    );
    render(&mut h);
}

/// JSON pointers of the numeric leaves of `v` (every slider and number field of the
/// settings, the sensor's included).
fn numeric_leaves(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Number(_) => out.push(at),
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                numeric_leaves(x, format!("{at}/{i}"), out);
            }
        }
        serde_json::Value::Object(o) => {
            for (k, x) in o {
                numeric_leaves(x, format!("{at}/{k}"), out);
            }
        }
        _ => {}
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(12),
        failure_persistence: None,
        ..proptest::prelude::ProptestConfig::default()
    })]

    /// Any values in any of the window's settings (display, playback, sensor; the
    /// render's size kept small here, its clamping is `absurd_settings_are_clamped_or_refused`),
    /// in either tab: a few frames run without a panic, and what the window keeps is
    /// finite and in range.
    #[test]
    fn any_settings_run_without_a_panic_or_a_nan(
        edits in proptest::collection::vec((proptest::prelude::any::<proptest::sample::Index>(), proptest::prop_oneof![
            proptest::strategy::Just(-1.0), proptest::strategy::Just(0.0), proptest::strategy::Just(1e-300),
            proptest::strategy::Just(0.5), proptest::strategy::Just(3.0), proptest::strategy::Just(1e9),
            proptest::strategy::Just(1e300), proptest::strategy::Just(-1e300), (-1e4f64..1e4),
        ]), 1..5),
        sensor_tab in proptest::prelude::any::<bool>(),
        preset in 0usize..tprf_core::sensor::BUILTIN_PRESETS.len(),
    ) {
        let mut settings = small_settings("builtin:cornell", 12, 48, 2);
        settings.sensor = Sensor::from_toml_str(tprf_core::sensor::BUILTIN_PRESETS[preset].1).unwrap();
        settings.mode = if sensor_tab { Mode::Sensor } else { Mode::Transient };
        let mut doc = serde_json::to_value(&settings).unwrap();
        let mut leaves = Vec::new();
        numeric_leaves(&doc, String::new(), &mut leaves);
        for (at, value) in &edits {
            let p = at.get(&leaves).clone();
            *doc.pointer_mut(&p).unwrap() = if value.fract() == 0.0 && value.abs() < 1e18 {
                serde_json::json!(*value as i64)
            } else {
                serde_json::json!(value)
            };
        }
        let Ok(mut settings) = serde_json::from_value::<ViewerSettings>(doc.clone()) else {
            return Ok(()); // not a settings value at all (a negative count, say)
        };
        // The render stays small: a big one would only take longer.
        settings.width = settings.width.clamp(1, 24);
        settings.height = settings.height.clamp(1, 24);
        settings.bins = settings.bins.clamp(1, 256);
        settings.spp_target = settings.spp_target.clamp(1, 4);
        let mut h = harness(settings);
        h.run_steps(4);
        std::thread::sleep(Duration::from_millis(100));
        h.run_steps(4);
        let s = &h.state().settings;
        proptest::prop_assert!(s.ev.is_finite() && s.play_bins_per_s.is_finite(), "{doc}");
        proptest::prop_assert!(s.width >= 1 && s.height >= 1 && s.bins >= 1, "{doc}");
    }
}

/// A scene with a sun: the worker's ambient image reaches the sensor tab, whose
/// measurements are the film's plus `ambient_scale A integral Exposure_i dt` per gate
/// (and the film's alone at scale 0).
#[test]
fn the_sensor_tab_adds_the_scenes_ambient_image() {
    use tprf_core::sensor::SensorModel;
    let (side, bins) = (10, 32);
    let mut h = harness(ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:canopy", side, bins, 2)
    });
    wait_done(&mut h, Duration::from_secs(120));
    let snap = h.state().snapshot().unwrap();
    let ambient = h
        .state()
        .ambient()
        .expect("the canopy's sun: an ambient image");
    assert_eq!((ambient.width, ambient.height), (side, side));
    for scale in [1.0, 0.0] {
        let mut sensor = Sensor::new(
            LightPulse::default(),
            Exposure::from_spec("box:origin=window,start=0ns,width=3ns,count=4").unwrap(),
        );
        sensor.ambient_scale = scale;
        h.state_mut().settings.sensor = sensor.clone();
        h.step();
        wait_sensor(&mut h);
        let got = h.state().sensor.measurements().unwrap().clone();
        let model = SensorModel::new(sensor, *snap.axis()).unwrap();
        let mut want = model.measure_clean_film(&snap);
        model.add_ambient(&mut want, &ambient.radiance).unwrap();
        for (g, w) in got.values.iter().zip(&want.values) {
            assert!((g - w).abs() <= 1e-6 * w.abs().max(1e-12), "{g} vs {w}");
        }
        let clean = model.measure_clean_film(&snap);
        let lit = got.values.iter().zip(&clean.values).any(|(g, c)| g > c);
        assert_eq!(lit, scale > 0.0, "scale {scale}");
    }
}

/// The samples each pixel drew: under adaptive sampling the steady block can show them
/// against the image's mean, and the readout gives a pixel's own count; with uniform
/// samples every pixel drew the film's spp. (1024 spp: on so small a film the worker's
/// paced passes are 1, 256, 256, ... samples, and a pass is planned once both halves of
/// the film hold a few.)
#[test]
fn the_steady_block_shows_the_samples_each_pixel_drew() {
    let mut h = harness(small_settings("builtin:cornell", 24, 32, 1024));
    wait_done(&mut h, Duration::from_secs(120));
    h.run_steps(2);
    h.get_by_label("steady image");
    h.state_mut().settings.steady_block = SteadyBlock::Samples;
    h.run_steps(2);
    h.get_by_label("samples image");
    assert!(h.query_by_label("steady image").is_none());
    let bar = label_with(&h, "colour bar: samples image");
    assert!(bar.ends_with("× the mean, log"), "{bar}");
    // The worker's film: its pixels drew unequal samples averaging the film's spp.
    let snap = h.state().snapshot().expect("a snapshot");
    let drawn: Vec<u64> = (0..24 * 24)
        .map(|i| snap.pixel_samples_drawn(i % 24, i / 24).unwrap())
        .collect();
    assert!(drawn.iter().any(|&d| d != drawn[0]), "{drawn:?}");
    let mean = drawn.iter().sum::<u64>() as f64 / drawn.len() as f64;
    assert!(
        (mean / snap.spp as f64 - 1.0).abs() < 0.05,
        "{mean} vs {}",
        snap.spp
    );
    let readout = h.state().pixel_readout(&snap, 3, 5);
    let own = drawn[5 * 24 + 3];
    assert!(readout.contains(&format!(" · {own} spp (")), "{readout}");
    // Uniform samples: every pixel drew the film's spp.
    let mut h = harness(ViewerSettings {
        uniform_sampling: true,
        ..small_settings("builtin:cornell", 24, 32, 1024)
    });
    wait_done(&mut h, Duration::from_secs(120));
    let snap = h.state().snapshot().expect("a snapshot");
    for i in 0..24 * 24 {
        assert_eq!(snap.pixel_samples_drawn(i % 24, i / 24), Some(1024));
    }
}

/// The window's sky: a scene with none rendered under a sky from the render settings
/// has an ambient image, and the steady block shows it (its own image, colour bar in
/// W m^-2 sr^-1) when chosen, the steady image otherwise.
#[test]
fn the_steady_block_shows_the_ambient_image_of_the_sky_set_in_the_window() {
    let mut h = harness(ViewerSettings {
        sky_radiance_w_m2_sr: Some(3.0),
        ..small_settings("builtin:cornell", 16, 32, 4)
    });
    wait_done(&mut h, Duration::from_secs(120));
    let start = Instant::now();
    while h.state().ambient().is_none() {
        h.step();
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no ambient image"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let a = h.state().ambient().expect("ambient");
    assert!(
        a.radiance.iter().any(|&v| v > 0.0),
        "the sky lights the box"
    );
    h.run_steps(2);
    h.get_by_label("steady image");
    assert!(h.query_by_label("ambient image").is_none());
    h.state_mut().settings.steady_block = SteadyBlock::Ambient;
    h.run_steps(2);
    h.get_by_label("ambient image");
    assert!(h.query_by_label("steady image").is_none());
    let bar = label_with(&h, "colour bar: ambient image");
    assert!(bar.ends_with("W m⁻² sr⁻¹, linear"), "{bar}");
    // Without a sky (the scene's own: none) there is no choice to make.
    let mut h = harness(small_settings("builtin:cornell", 16, 32, 4));
    wait_done(&mut h, Duration::from_secs(120));
    h.state_mut().settings.steady_block = SteadyBlock::Ambient;
    h.run_steps(2);
    assert!(h.state().ambient().is_none());
    h.get_by_label("steady image");
}

/// A right-drag on the window from `from` to `to`, as a mouse makes it: press, moves of
/// at most 10 points a frame, release.
fn right_drag(h: &mut Harness<'static, TprfApp>, from: Pos2, to: Pos2) {
    drag_with(h, PointerButton::Secondary, from, to);
}

/// [`right_drag`] with any button.
fn drag_with(h: &mut Harness<'static, TprfApp>, which: PointerButton, from: Pos2, to: Pos2) {
    h.hover_at(from);
    h.step();
    let button = |pos, pressed| Event::PointerButton {
        pos,
        button: which,
        pressed,
        modifiers: Modifiers::NONE,
    };
    h.event(button(from, true));
    h.step();
    let steps = ((to - from).length() / 10.0).ceil().max(1.0) as usize;
    for i in 1..=steps {
        h.event(Event::PointerMoved(
            from + (to - from) * (i as f32 / steps as f32),
        ));
        h.step();
    }
    h.event(button(to, false));
    h.step();
}

/// Per pixel, the sum over bins (the steady image).
fn steady_of(snap: &FilmSnapshot) -> Vec<f64> {
    (0..snap.height())
        .flat_map(|y| (0..snap.width()).map(move |x| (x, y)))
        .map(|(x, y)| snap.pixel(x, y).iter().map(|&v| f64::from(v)).sum())
        .collect()
}

/// Step until the render is done, asserting every frame that a film is on screen (the
/// old camera's until the new one has light).
fn wait_done_never_blank(h: &mut Harness<'static, TprfApp>, old: &Arc<FilmSnapshot>) {
    let start = Instant::now();
    loop {
        h.step();
        let snap = h
            .state()
            .snapshot()
            .expect("a film on screen after a camera move");
        if h.state().showing_previous_camera() {
            assert!(Arc::ptr_eq(&snap, old), "the film kept is not the old one");
        }
        match h.state().status().map(|s| s.state) {
            Some(WorkerState::Done) if !h.state().showing_previous_camera() => break,
            Some(WorkerState::Failed(e)) => panic!("render failed: {e}"),
            _ => {}
        }
        assert!(start.elapsed() < Duration::from_secs(120), "no new film");
        std::thread::sleep(Duration::from_millis(10));
    }
    h.run_steps(2);
}

/// Issue 34, item 1: a right-drag on the time slice orbits the camera about its look-at
/// point, half a turn per image height (checked against the pose before the drag: the
/// same look-at point and distance, turned about +Y by -pi dx / h, the camera going to
/// its left), the render restarts with that pose as the request's camera override, the
/// old film stays on screen until the new one has light, and the new image is another
/// view. A click still selects a pixel and moves no camera.
#[test]
fn orbiting_on_the_image_moves_the_camera_and_renders_again() {
    use glam::DVec3;
    use tprf::viewer::CameraPose;
    let side = 24;
    let mut h = harness(small_settings("builtin:cornell", side, 48, 4));
    wait_done(&mut h, Duration::from_secs(120));
    h.state_mut().playing = false;
    assert_eq!(h.state().request().unwrap().camera_position_m, None);
    let before = h
        .state_mut()
        .camera_pose()
        .expect("the scene's camera as a pose");
    let old = h.state().snapshot().unwrap();
    let rect = h.get_by_label("time slice").rect();
    let dx = rect.height() / 4.0;
    right_drag(&mut h, rect.center(), rect.center() + Vec2::new(dx, 0.0));
    let pose = h.state().settings.camera.expect("a pose after the drag");
    let request = h.state().request().unwrap();
    assert_eq!(CameraPose::of_request(&request), Some(pose));
    assert_eq!(
        (pose.look_at_m, pose.up, pose.fov_deg),
        (before.look_at_m, before.up, before.fov_deg)
    );
    let offset = |p: &CameraPose| DVec3::from(p.position_m) - DVec3::from(p.look_at_m);
    let (a, b) = (offset(&before), offset(&pose));
    assert!(
        (a.length() - b.length()).abs() < 1e-9 * a.length(),
        "{a} {b}"
    );
    assert!(
        (a.y - b.y).abs() < 1e-9,
        "an orbit about +Y keeps the height: {a} {b}"
    );
    let turn = (a.z * b.x - a.x * b.z).atan2(a.x * b.x + a.z * b.z);
    let expected = -std::f64::consts::PI * f64::from(dx / rect.height());
    // Within one frame's move (egui starts a drag after a few points).
    let frame = std::f64::consts::PI * 10.0 / f64::from(rect.height());
    assert!(
        (turn - expected).abs() <= frame,
        "turned {turn} rad, expected {expected}"
    );
    wait_done_never_blank(&mut h, &old);
    let new = h.state().snapshot().unwrap();
    let (s0, s1) = (steady_of(&old), steady_of(&new));
    let diff: f64 = s0.iter().zip(&s1).map(|(a, b)| (a - b).abs()).sum();
    let total: f64 = s0.iter().sum();
    assert!(
        diff > 0.2 * total,
        "the image hardly changed: {diff} of {total}"
    );
    let pos = pixel_pos(&h, "time slice", 5, 7, side, side);
    click_at(&mut h, pos);
    assert_eq!(h.state().selection, Some(Selection::pixel(5, 7)));
    assert_eq!(h.state().settings.camera, Some(pose));
}

/// Focus the field labelled `label` and replace its text with `text`.
fn retype(h: &mut Harness<'static, TprfApp>, label: &str, text: &str) {
    h.get_by_label(label).focus();
    h.step();
    h.event(Event::Key {
        key: Key::A,
        physical_key: None,
        pressed: true,
        repeat: false,
        modifiers: Modifiers::COMMAND,
    });
    h.step();
    h.get_by_label(label).type_text(text);
    h.step();
}

/// The pose typed in the Camera section is the request's camera exactly (the fields not
/// edited keep their exact values), `tprf render` of that request records it in
/// tprf.json (position, field of view, the view along look-at - position), bad input is
/// a message naming the field (no camera change), "save the scene with this camera"
/// writes a glTF whose camera is the one rendered, and "reset" renders the scene's own
/// camera again.
#[test]
fn a_typed_pose_round_trips_is_recorded_saved_and_reset() {
    use glam::DVec3;
    use tprf::viewer::CameraPose;
    let mut h = harness(small_settings("builtin:cornell", 16, 32, 2));
    h.state_mut().file_dialogs = false;
    wait_done(&mut h, Duration::from_secs(120));
    let scene_pose = h.state_mut().camera_pose().unwrap();
    let old = h.state().snapshot().unwrap();

    retype(&mut h, "Position (m)", "1, 2");
    h.get_by_label("Set camera").click();
    h.run_steps(2);
    assert!(
        h.query_by_label_contains("position: \"1, 2\" is not three numbers")
            .is_some(),
        "no message for a bad position"
    );
    assert_eq!(h.state().settings.camera, None);

    retype(&mut h, "Position (m)", "0.1, 0.35, 1.2");
    retype(&mut h, "Field of view (°)", "50");
    h.get_by_label("Set camera").click();
    h.run_steps(2);
    let typed = CameraPose {
        position_m: [0.1, 0.35, 1.2],
        fov_deg: 50.0,
        ..scene_pose
    };
    assert_eq!(h.state().settings.camera, Some(typed));
    let request = h.state().request().unwrap();
    assert_eq!(CameraPose::of_request(&request), Some(typed));
    wait_done_never_blank(&mut h, &old);
    let flags = h.state_mut().camera_pose().unwrap().flags();
    assert!(
        flags.starts_with("--camera-position 0.1,0.35,1.2 --look-at "),
        "{flags}"
    );

    // The request renders to a folder whose tprf.json records the pose.
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("viewer-camera-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let small = tprf_core::request::RenderRequest {
        width: 8,
        height: 8,
        bins: 16,
        spp: Some(1),
        until_stopped: false,
        pass_seconds: None,
        ..request.clone()
    };
    struct Quiet;
    impl tprf_core::request::Observer for Quiet {}
    tprf_core::request::render_to_folder(&small, &dir.join("cube"), &mut Quiet).unwrap();
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("cube/tprf.json")).unwrap())
            .unwrap();
    let cam = &meta["camera"];
    let num = |v: &serde_json::Value| v.as_f64().unwrap();
    let position: Vec<f64> = cam["position_m"]
        .as_array()
        .unwrap()
        .iter()
        .map(num)
        .collect();
    assert!(
        (DVec3::from_slice(&position) - DVec3::from(typed.position_m)).length() < 1e-6,
        "{position:?}"
    );
    assert!((num(&cam["yfov_deg"]) - 50.0).abs() < 1e-4);
    let m: Vec<f64> = cam["world_from_camera"]
        .as_array()
        .unwrap()
        .iter()
        .map(num)
        .collect();
    let view = -DVec3::new(m[8], m[9], m[10]);
    let want = (DVec3::from(typed.look_at_m) - DVec3::from(typed.position_m)).normalize();
    assert!((view - want).length() < 1e-6, "{view} vs {want}");

    // Saved as glTF: the camera read back is the one rendered.
    h.get_by_label("Save scene with this camera…").click();
    h.run_steps(2);
    let path = dir.join("scene.gltf");
    // The field starts with the suggested name: select it all, type over it.
    assert_eq!(
        h.state()
            .suggested_name(tprf::viewer::FileAction::SaveSceneGltf)
            .as_deref(),
        Some("cornell_camera.gltf")
    );
    type_path_and_ok(&mut h, &path);
    let start = Instant::now();
    while !h.state().messages().iter().any(|m| m.starts_with("saved ")) {
        h.step();
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "{:?}",
            h.state().messages()
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let saved = tprf_core::scene::load(&path.display().to_string()).unwrap();
    let rendered = tprf_core::request::apply_camera(&request, &saved.camera).unwrap();
    assert!(
        glam::Mat4::from(saved.camera.world_from_camera)
            .abs_diff_eq(glam::Mat4::from(rendered.world_from_camera), 1e-6)
    );
    assert!((saved.camera.fov_rad - 50f32.to_radians()).abs() < 1e-6);

    // Reset: the scene's camera again, as before any move.
    let old = h.state().snapshot().unwrap();
    h.get_by_label("Reset to the scene's camera").click();
    h.step();
    assert_eq!(h.state().settings.camera, None);
    assert_eq!(h.state().request().unwrap().camera_position_m, None);
    wait_done_never_blank(&mut h, &old);
    assert_eq!(h.state_mut().camera_pose(), Some(scene_pose));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A camera move renders the scene the window has loaded, not the file again: with the
/// glTF file deleted after the first render, a typed pose still renders (the scene's
/// triangles, the camera the request's pose makes of the file's camera, another image),
/// while "⟲ Restart" reads the file again (and so fails here).
#[test]
fn a_camera_move_renders_the_loaded_scene_without_reading_it_again() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("viewer-keep-scene-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cornell.gltf");
    let cornell = tprf_core::scene::load("builtin:cornell").unwrap();
    tprf_core::scene::gltf_save::save_gltf(&cornell, &path).unwrap();
    let mut h = harness(small_settings(&path.display().to_string(), 16, 32, 2));
    wait_done(&mut h, Duration::from_secs(120));
    h.state_mut().playing = false;
    let old = h.state().snapshot().unwrap();
    std::fs::remove_file(&path).unwrap();

    retype(&mut h, "Position (m)", "0.1, 0.35, 1.2");
    h.get_by_label("Set camera").click();
    h.run_steps(2);
    wait_done_never_blank(&mut h, &old);
    let request = h.state().request().unwrap();
    assert_eq!(request.camera_position_m, Some([0.1, 0.35, 1.2]));
    assert_eq!(
        h.state().rendered_camera(),
        Some(tprf_core::request::apply_camera(&request, &cornell.camera).unwrap())
    );
    assert_eq!(
        h.state().status().unwrap().triangles,
        cornell.triangles.len()
    );
    let (s0, s1) = (steady_of(&old), steady_of(&h.state().snapshot().unwrap()));
    let diff: f64 = s0.iter().zip(&s1).map(|(a, b)| (a - b).abs()).sum();
    assert!(
        diff > 0.1 * s0.iter().sum::<f64>(),
        "the image hardly changed"
    );

    h.get_by_label("⟲ Restart").click();
    let start = Instant::now();
    loop {
        h.step();
        if let Some(WorkerState::Failed(e)) = h.state().status().map(|s| s.state) {
            assert!(e.contains("cornell.gltf"), "{e}");
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "a restart rendered a deleted file"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Mitsuba XML scene opened in the window renders with its file's film (size, time
/// window: start_opl + near_clip, bin_width_opl) and its integrator's depth (max_depth
/// counts the camera segment: one less scattering event), says so, and does not take
/// its sample count; a time window set for another scene is not carried over.
#[test]
fn a_mitsuba_scene_opens_with_its_files_film_settings() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("viewer-xml");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let xml = dir.join("small.xml");
    std::fs::write(
        &xml,
        r#"<scene version="3.0.0">
    <integrator type="transient_path"><integer name="max_depth" value="4"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <float name="near_clip" value="0.1"/>
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
        <film type="transient_hdr_film">
            <integer name="width" value="24"/>
            <integer name="height" value="16"/>
            <integer name="temporal_bins" value="50"/>
            <float name="start_opl" value="5.5"/>
            <float name="bin_width_opl" value="0.02"/>
        </film>
    </sensor>
    <shape type="rectangle">
        <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
    </shape>
</scene>
"#,
    )
    .unwrap();
    let settings = ViewerSettings {
        t0: "5ns".into(),
        dt: "10ps".into(),
        ..small_settings("builtin:cornell", 8, 8, 0)
    };
    let path = xml.display().to_string();
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Scene(path)));
    h.run_steps(2);
    let r = h.state().request().expect("a render of the file");
    let c = 299_792_458.0;
    assert_eq!((r.width, r.height, r.bins), (24, 16, 50));
    assert!((r.t0_s.unwrap() - 5.6 / c).abs() < 1e-18, "{:?}", r.t0_s);
    assert!((r.dt_s.unwrap() - 0.02 / c).abs() < 1e-20, "{:?}", r.dt_s);
    assert_eq!(r.max_bounces, 3);
    let m = h.state().messages().join("\n");
    assert!(
        m.contains("from the scene file: width 24") && m.contains("8 spp not taken"),
        "{m}"
    );

    // A built-in scene opened with a window set: it starts automatic (None), the size kept.
    let settings = ViewerSettings {
        t0: "5ns".into(),
        dt: "10ps".into(),
        ..small_settings("builtin:cornell", 8, 8, 0)
    };
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(cc, settings, Start::Scene("builtin:cornell".into()))
        });
    h.run_steps(2);
    let r = h.state().request().expect("a render");
    assert_eq!((r.width, r.t0_s, r.dt_s), (8, None, None));
    assert!(
        h.state().messages().is_empty(),
        "{:?}",
        h.state().messages()
    );
}

/// Issue 34, item 1: the other camera gestures on the time slice, each against the pose
/// before it. The wheel dollies: the same look-at point and direction, nearer (wheel
/// forward), the field of view kept; ctrl + wheel changes only the field of view; a
/// middle-drag pans: position and look-at move by the same vector, across the view
/// (perpendicular to it), the field of view kept. Each renders once the gesture rests.
#[test]
fn wheel_ctrl_wheel_and_middle_drag_dolly_zoom_and_pan() {
    use glam::DVec3;
    use tprf::viewer::CameraPose;
    let mut h = harness(small_settings("builtin:cornell", 16, 32, 2));
    wait_done(&mut h, Duration::from_secs(120));
    h.state_mut().playing = false;
    let rect = h.get_by_label("time slice").rect();
    let offset = |p: &CameraPose| DVec3::from(p.position_m) - DVec3::from(p.look_at_m);
    // Step until the gesture has rested and the request carries the new pose.
    let settle = |h: &mut Harness<'static, TprfApp>, before: &CameraPose| -> CameraPose {
        let start = Instant::now();
        loop {
            h.step();
            let req = h.state().request().unwrap();
            if let Some(p) = CameraPose::of_request(&req)
                && p != *before
                && h.state().settings.camera == Some(p)
            {
                return p;
            }
            assert!(start.elapsed() < Duration::from_secs(10), "no camera move");
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    let wheel = |h: &mut Harness<'static, TprfApp>, modifiers: Modifiers| {
        h.hover_at(rect.center());
        h.step();
        h.event(Event::MouseWheel {
            unit: eframe::egui::MouseWheelUnit::Point,
            delta: Vec2::new(0.0, 120.0),
            phase: eframe::egui::TouchPhase::Move,
            source: eframe::egui::MouseWheelSource::Unknown,
            modifiers,
        });
    };

    let p0 = h.state_mut().camera_pose().unwrap();
    // The scrubber on the light's last third: after the dolly it shows the same time,
    // though the new camera's automatic window starts elsewhere.
    let old = h.state().snapshot().unwrap();
    let side = old.width();
    let light_bins: Vec<usize> = (0..old.axis().bins)
        .filter(|&b| (0..side * side).any(|i| old.pixel(i % side, i / side)[b] > 0.0))
        .collect();
    h.state_mut().bin = light_bins[2 * light_bins.len() / 3];
    let t_before = old.axis().bin_center_s(h.state().bin);
    wheel(&mut h, Modifiers::NONE);
    let p1 = settle(&mut h, &p0);
    wait_done_never_blank(&mut h, &old);
    let new = h.state().snapshot().unwrap();
    assert!(
        new.axis().t0_s != old.axis().t0_s,
        "the same window: {:?}",
        new.axis()
    );
    match new.axis().bin_of(t_before) {
        Some(b) => assert_eq!(h.state().bin, b, "the scrubber keeps its time"),
        None => panic!("the new window lost the time {t_before} s"),
    }
    let (a, b) = (offset(&p0), offset(&p1));
    assert_eq!((p1.look_at_m, p1.fov_deg), (p0.look_at_m, p0.fov_deg));
    assert!(
        b.length() < a.length(),
        "nearer: {} -> {}",
        a.length(),
        b.length()
    );
    assert!(
        (a.normalize() - b.normalize()).length() < 1e-9,
        "same direction: {a} {b}"
    );

    wheel(&mut h, Modifiers::CTRL);
    let p2 = settle(&mut h, &p1);
    assert_eq!(
        (p2.position_m, p2.look_at_m, p2.up),
        (p1.position_m, p1.look_at_m, p1.up)
    );
    assert!(p2.fov_deg != p1.fov_deg, "{} -> {}", p1.fov_deg, p2.fov_deg);

    let c = rect.center();
    drag_with(&mut h, PointerButton::Middle, c, c + Vec2::new(30.0, 20.0));
    let p3 = settle(&mut h, &p2);
    let moved = DVec3::from(p3.look_at_m) - DVec3::from(p2.look_at_m);
    let (o2, o3) = (offset(&p2), offset(&p3));
    assert!(
        (o2 - o3).length() < 1e-9 * o2.length(),
        "the same offset: {o2} {o3}"
    );
    assert!(moved.length() > 1e-6, "the pan moved nothing");
    assert!(
        moved.normalize().dot(o2.normalize()).abs() < 1e-9,
        "across the view: {moved} vs {o2}"
    );
    assert_eq!(p3.fov_deg, p2.fov_deg);
}

/// A clock's origins belong to the scene that set them: an XML file's `camera_unwarp`
/// opens with the first-hit time origin (said), and a scene opened after it (settings
/// kept from an NLOS camera view: both first hits) starts from the pinhole and the light.
#[test]
fn time_and_pulse_origins_do_not_outlive_their_scene() {
    use tprf_core::scene::{PulseOrigin, TimeOrigin as ClockOrigin};
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("viewer-origins");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let xml = dir.join("unwarp.xml");
    std::fs::write(
        &xml,
        r#"<scene version="3.0.0">
    <integrator type="transient_path"><boolean name="camera_unwarp" value="true"/></integrator>
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="transient_hdr_film"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="rectangle"><emitter type="area"/></shape>
</scene>
"#,
    )
    .unwrap();
    let path = xml.display().to_string();
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(
                cc,
                small_settings("builtin:cornell", 16, 8, 0),
                Start::Scene(path),
            )
        });
    h.run_steps(2);
    let r = h.state().request().expect("a render of the file");
    assert_eq!(
        (r.time_origin, r.pulse_origin),
        (ClockOrigin::FirstHit, PulseOrigin::Light)
    );
    let m = h.state().messages().join("\n");
    assert!(m.contains("time origin first-hit"), "{m}");

    // Another scene starts from the user's own settings, not the file's (the film, the
    // clock), and says so; the file's messages go with it.
    open_builtin(&mut h, "cornell");
    h.run_steps(2);
    let r = h.state().request().expect("a render of the built-in scene");
    assert_eq!(
        (r.time_origin, r.pulse_origin),
        (ClockOrigin::Pinhole, PulseOrigin::Light)
    );
    assert_eq!((r.width, r.height), (16, 16), "the user's own film");
    let m = h.state().messages().join("\n");
    assert!(!m.contains("from the scene file"), "{m}");
    assert!(
        m.contains("your own width, height") && m.contains("time origin again"),
        "{m}"
    );
    // A value the user changed while on the file's scene stays theirs.
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(
                cc,
                small_settings("builtin:cornell", 16, 8, 0),
                Start::Scene(xml.display().to_string()),
            )
        });
    h.run_steps(2);
    h.state_mut().pending.width = 24;
    open_builtin(&mut h, "cornell");
    h.run_steps(2);
    let r = h.state().request().expect("a render");
    assert_eq!((r.width, r.height), (24, 16));
}

/// A failed scene's message does not outlive it: the next scene opens without it.
#[test]
fn a_failed_scenes_message_goes_with_it() {
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| {
            TprfApp::with_settings(
                cc,
                small_settings("builtin:cornell", 8, 8, 0),
                Start::Scene("/nonexistent/missing.glb".into()),
            )
        });
    for _ in 0..50 {
        h.run_steps(2);
        if h.state()
            .messages()
            .iter()
            .any(|m| m.contains("missing.glb"))
        {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let m = h.state().messages().join("\n");
    assert!(m.contains("missing.glb"), "the failure is said: {m}");
    open_builtin(&mut h, "cornell");
    h.run_steps(4);
    let m = h.state().messages().join("\n");
    assert!(!m.contains("missing.glb"), "{m}");
}

/// In the open path window: select the field's text (the suggested name), type `path`
/// over it and press OK.
fn type_path_and_ok(h: &mut Harness<'static, TprfApp>, path: &std::path::Path) {
    h.get_by_label("path").focus();
    h.step();
    h.event(Event::Key {
        key: Key::A,
        physical_key: None,
        pressed: true,
        repeat: false,
        modifiers: Modifiers::COMMAND,
    });
    h.step();
    h.get_by_label("path")
        .type_text(&path.display().to_string());
    h.step();
    h.get_by_label("OK").click();
}

/// Saves start from a name made of the scene and what is saved, not an empty field.
#[test]
fn saves_suggest_the_scenes_name() {
    use tprf::viewer::FileAction;
    let h = harness(small_settings("builtin:cornell", 8, 16, 1));
    let bin = h.state().bin;
    assert_eq!(
        h.state().suggested_name(FileAction::SaveSlicePng),
        Some(format!("cornell_bin{bin:04}.png"))
    );
    assert_eq!(
        h.state()
            .suggested_name(FileAction::SaveSteadyPng)
            .as_deref(),
        Some("cornell_steady.png")
    );
    assert_eq!(h.state().suggested_name(FileAction::OpenScene), None);
}

/// Ten presses of → within one frame step ten bins (they used to step once a frame).
#[test]
fn quick_arrow_presses_each_step_a_bin() {
    let mut h = harness(small_settings("builtin:cornell", 8, 64, 1));
    let start = Instant::now();
    while h.state().snapshot().is_none() {
        h.step();
        assert!(start.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(10));
    }
    h.state_mut().playing = false;
    h.run_steps(2);
    h.state_mut().bin = 3;
    h.step();
    let from = h.state().bin;
    assert!(from + 10 < 64);
    for _ in 0..10 {
        h.event(Event::Key {
            key: Key::ArrowRight,
            physical_key: None,
            pressed: true,
            repeat: false,
            modifiers: Modifiers::NONE,
        });
    }
    h.step();
    assert_eq!(h.state().bin, from + 10);
}

/// The LiDAR's returns in the window: the depth image offers the first, strongest and
/// last return and each echo of multi-echo; the readout under the cursor lists the
/// pixel's returns, each at the depth the core's detector finds in the same gates.
#[test]
fn the_lidar_depth_image_offers_every_return() {
    let side = 16;
    let mut h = harness(ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:cornell", side, 64, 16)
    });
    wait_done(&mut h, Duration::from_secs(120));
    wait_sensor(&mut h);
    h.run_steps(2);
    let snap = h.state().snapshot().unwrap();
    let sensor = h.state().settings.sensor.clone();
    let model = tprf_core::sensor::SensorModel::new(sensor, *snap.axis()).unwrap();
    let returns = model
        .returns(&model.measure_clean_film(&snap))
        .expect("the LiDAR preset asks for returns");
    assert_eq!(returns.max_returns, 3);
    for choice in ["first", "strongest", "last", "2nd", "3rd"] {
        h.get_by_label(choice);
    }
    // A pixel with a return: the readout gives its depth to the millimetre.
    let (px, py) = (side / 2, side / 2);
    let i = py * side + px;
    let first = returns.first_m()[i];
    assert!(first.is_finite(), "no return at the centre");
    h.hover_at(pixel_pos(&h, "depth image", px, py, side, side));
    h.run_steps(2);
    let readout = label_with(&h, &format!("row {py}, column {px} · M_"));
    assert!(
        readout.contains(&format!("return {first:.3} m"))
            || readout.contains(&format!("returns {first:.3} m")),
        "{readout}: first return {first}"
    );
    // Choosing the last return keeps the colour bar's range (one range for all).
    let bar = label_with(&h, "colour bar: depth");
    h.get_by_label("last").click();
    h.run_steps(2);
    assert_eq!(h.state().sensor.echo, tprf_core::sensor::Echo::Last);
    assert_eq!(label_with(&h, "colour bar: depth"), bar);
}

/// `TPRF_SCREENSHOTS=1 cargo test --release --test viewer -- --ignored layout_shots`
/// renders the window at 1024 x 700, 1280 x 800 and 1920 x 1080 in each mode (the
/// transient view, the LiDAR, the SPAD) into `target/tmp/layout/`, to look at.
#[test]
#[ignore = "writes target/tmp/layout/; run by hand"]
fn layout_shots() {
    if std::env::var_os("TPRF_SCREENSHOTS").is_none() {
        eprintln!("set TPRF_SCREENSHOTS=1 to write target/tmp/layout/");
        return;
    }
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("layout");
    std::fs::create_dir_all(&dir).unwrap();
    for (w, hgt) in [(1024.0, 700.0), (1280.0, 800.0), (1920.0, 1080.0)] {
        let settings = small_settings("builtin:cornell", 64, 128, 64);
        let mut h = Harness::builder()
            .with_size(Vec2::new(w, hgt))
            .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default));
        wait_done(&mut h, Duration::from_secs(120));
        h.state_mut().playing = false;
        h.state_mut().selection = Some(Selection::pixel(32, 20));
        h.state_mut().bin = 40;
        let shot = |h: &mut Harness<'static, TprfApp>, name: &str| {
            h.run_steps(3);
            let mut img = h.render().expect("a wgpu adapter for screenshots");
            tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
            img.save(dir.join(format!("{name}_{w}x{hgt}.png"))).unwrap();
        };
        shot(&mut h, "transient");
        h.state_mut().settings.mode = Mode::Sensor;
        h.run_steps(3);
        wait_sensor(&mut h);
        shot(&mut h, "lidar");
        h.state_mut().settings.sensor = Sensor::builtin("spad").unwrap();
        h.run_steps(2);
        let snap = h.state().snapshot().unwrap();
        let start = Instant::now();
        while (!h.state().sensor.is_current(&snap) || h.state().sensor.spad_sampling())
            && start.elapsed() < Duration::from_secs(120)
        {
            h.step();
            std::thread::sleep(Duration::from_millis(20));
        }
        shot(&mut h, "spad");
    }
}

/// A saved time slice carries its legend (issue 44: exported PNGs had no colour bar or
/// time): the film's pixels enlarged by a whole factor to 360 px wide, each the colour
/// the plain PNG (legend off) has for it, over a strip whose bar runs from inferno's 0
/// to its 1 (colorous, the ramp the window shows) with its labels and the slice's time
/// written in dark pixels.
#[test]
fn a_saved_slice_carries_its_legend() {
    let dir = std::env::temp_dir().join(format!("tprf-legend-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut h = harness(small_settings("builtin:cornell", 12, 16, 1));
    h.state_mut().file_dialogs = false;
    wait_done(&mut h, Duration::from_secs(60));
    h.state_mut().playing = false;
    h.run_steps(2);
    let save = |h: &mut Harness<'static, TprfApp>, path: &std::path::Path| {
        // (The Save section is below the fold of the left panel at 1280 x 800.)
        h.state_mut()
            .choose_file(tprf::viewer::FileAction::SaveSlicePng);
        h.run_steps(2);
        type_path_and_ok(h, path);
        let start = Instant::now();
        loop {
            h.step();
            if let Ok(img) = image::open(path) {
                break img.to_rgb8();
            }
            assert!(start.elapsed() < Duration::from_secs(30), "no {path:?}");
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    let with = save(&mut h, &dir.join("with.png"));
    h.state_mut().settings.png_legend = false;
    h.run_steps(2);
    let plain = save(&mut h, &dir.join("plain.png"));
    assert_eq!(plain.dimensions(), (12, 12));
    let k = 360 / 12;
    let strip = tprf_core::export::legend::LEGEND_H as u32;
    assert_eq!(with.dimensions(), (360, 12 * k + strip));
    for y in 0..12 {
        for x in 0..12 {
            assert_eq!(
                with.get_pixel(x * k + k / 2, y * k + k / 2),
                plain.get_pixel(x, y),
                "pixel ({x}, {y})"
            );
        }
    }
    let inferno = |t: f64| {
        let c = colorous::INFERNO.eval_continuous(t);
        [c.r, c.g, c.b]
    };
    let bar_y = 12 * k + 12;
    assert_eq!(with.get_pixel(12, bar_y).0, inferno(0.0));
    assert_eq!(with.get_pixel(347, bar_y).0, inferno(1.0));
    let text = (12 * k + 22..12 * k + strip)
        .flat_map(|y| (0..360).map(move |x| (x, y)))
        .filter(|&(x, y)| with.get_pixel(x, y).0.iter().all(|&c| c < 128))
        .count();
    assert!(text > 200, "labels and the time: {text} dark pixels");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The FLIM preset's lifetime image sits beside the measurement on `builtin:flim`, and
/// the readout over each dye gives that dye's lifetime (1 ns and 4 ns, the scene's own
/// decays: rapid lifetime determination is exact for one exponential).
#[test]
fn the_flim_preset_shows_each_dyes_lifetime() {
    let side = 24;
    let mut settings = ViewerSettings {
        mode: Mode::Sensor,
        ..small_settings("builtin:flim", side, 128, 64)
    };
    settings.sensor = Sensor::builtin("flim").unwrap();
    let mut h = harness(settings);
    wait_done(&mut h, Duration::from_secs(180));
    wait_sensor(&mut h);
    h.run_steps(2);
    h.get_by_label("FLIM lifetime");
    let mut found = Vec::new();
    // The spots' centres lie at 0.3 and 0.7 of the image's width, on its middle row
    // (builtin:flim: 25 mm squares, centres 20 mm either side of the slide's middle).
    for fx in [0.3, 0.7] {
        let (px, py) = ((fx * side as f64) as usize, side / 2);
        h.hover_at(pixel_pos(&h, "lifetime image", px, py, side, side));
        h.run_steps(2);
        let readout = label_with(&h, &format!("row {py}, column {px} · M_"));
        found.push(number_after(&readout, "lifetime "));
    }
    // TPRF_FLIM_SHOT=FILE: a picture of the tab, to look at.
    if let Some(path) = std::env::var_os("TPRF_FLIM_SHOT")
        && let Some(shot) = render(&mut h)
    {
        shot.save(path).unwrap();
    }
    found.sort_by(f64::total_cmp);
    let expected = tprf_core::scene::builtin::flim::FLIM_LIFETIMES_S.map(|t| t * 1e9);
    for (got, want) in found.iter().zip(expected) {
        assert!(
            (got - want).abs() < 0.05 * want,
            "lifetimes {found:?} ns, the dyes' {expected:?} ns"
        );
    }
}

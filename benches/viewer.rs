//! UI frame time while the renderer runs: `cargo bench --bench viewer`.
//!
//! Drives the real app (egui_kittest, no window) at a 60 Hz pace while the background
//! worker renders, with playback on (a new time slice is coloured every frame) and the
//! pointer over the image (hover readout). A frame's time is what the UI thread spends:
//! our `ui()` (reading the latest snapshot, colouring, plots) plus egui's layout and
//! tessellation. The GPU paint is not included (it runs on the GPU, or on Mesa's
//! software rasteriser where none exists, which measures the rasteriser, not tprf).

use eframe::egui::{self, Pos2, Vec2};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use std::time::{Duration, Instant};
use tprf::viewer::{Mode, Start, TprfApp, ViewerSettings};
use tprf_core::sensor::{LightPulse, Sensor};

/// CPU time the calling thread has used, ms (Linux; elsewhere `None`): what a frame
/// cost the UI thread itself, apart from the time it waited for a core.
fn thread_cpu_ms() -> Option<f64> {
    #[cfg(target_os = "linux")]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: clock_gettime writes one timespec.
        if unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0 {
            return Some(ts.tv_sec as f64 * 1e3 + ts.tv_nsec as f64 * 1e-6);
        }
    }
    None
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn run(label: &str, settings: ViewerSettings, frames: usize) {
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default));
    // Wait for the first pass, then hover the middle of the time slice.
    let start = Instant::now();
    while h.query_by_label("time slice").is_none() {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no image after 120 s"
        );
        h.step();
        std::thread::sleep(Duration::from_millis(5));
    }
    let rect = h.get_by_label("time slice").rect();
    h.hover_at(Pos2::new(rect.center().x, rect.center().y));
    let mut times_ms = Vec::with_capacity(frames);
    let mut cpu_ms = Vec::with_capacity(frames);
    let mut snapshots = 0;
    let mut last = None;
    for _ in 0..frames {
        let t = Instant::now();
        let cpu = thread_cpu_ms();
        h.step();
        let shapes = h.output().shapes.clone();
        let _ = h.ctx.tessellate(shapes, 1.0);
        let spent = t.elapsed();
        times_ms.push(spent.as_secs_f64() * 1e3);
        if let (Some(a), Some(b)) = (cpu, thread_cpu_ms()) {
            cpu_ms.push(b - a);
        }
        let snap = h.state().snapshot().map(|s| s.generation());
        if snap != last {
            snapshots += 1;
            last = snap;
        }
        std::thread::sleep(Duration::from_micros(16_667).saturating_sub(spent));
    }
    let status = h.state().status().unwrap();
    times_ms.sort_by(f64::total_cmp);
    cpu_ms.sort_by(f64::total_cmp);
    let cpu = |q| {
        if cpu_ms.is_empty() {
            "-".to_string()
        } else {
            format!("{:.2}", quantile(&cpu_ms, q))
        }
    };
    println!(
        "| {label} | {frames} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {} | {snapshots} | {} |",
        quantile(&times_ms, 0.5),
        quantile(&times_ms, 0.95),
        quantile(&times_ms, 0.99),
        times_ms.last().unwrap(),
        cpu(0.5),
        cpu(0.99),
        status.spp
    );
}

/// The window in sensor mode with built-in `preset`, rendering a `side^2 x bins` film
/// to 1 spp.
fn sensor_window(preset: &str, side: usize, bins: usize) -> Harness<'static, TprfApp> {
    let settings = ViewerSettings {
        width: side,
        height: side,
        bins,
        spp_target: 1,
        mode: Mode::Sensor,
        sensor: Sensor::builtin(preset).unwrap(),
        ..ViewerSettings::default()
    };
    Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default))
}

/// Sensor mode: the time of the frame that follows an edit of the light pulse (new
/// kernels, new measurements of the whole film, noise, derived depth, new textures).
fn sensor_edits(label: &str, preset: &str, side: usize, bins: usize, edits: usize) {
    let mut h = sensor_window(preset, side, bins);
    let start = Instant::now();
    while h.state().sensor.measurements().is_none() || h.state().status().map(|s| s.spp) != Some(1)
    {
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "no film after 300 s"
        );
        h.step();
        std::thread::sleep(Duration::from_millis(20));
    }
    h.run_steps(3);
    let gates = h.state().sensor.measurements().unwrap().gates;
    let mut times_ms = Vec::with_capacity(edits);
    let mut all_ms = Vec::with_capacity(edits);
    for k in 0..edits {
        // Move the pulse by a fraction of a bin: a kernel edit.
        let shift = 1e-12 * (1 + k % 7) as f64;
        match &mut h.state_mut().settings.sensor.light {
            LightPulse::Gaussian { centre_s, .. } => *centre_s += shift,
            LightPulse::Delta { t_s, .. } => *t_s += shift,
            LightPulse::Rect { start_s, .. } => *start_s += shift,
            other => panic!("bench preset with a {other:?} light"),
        }
        let t = Instant::now();
        h.step();
        let shapes = h.output().shapes.clone();
        let _ = h.ctx.tessellate(shapes, 1.0);
        times_ms.push(t.elapsed().as_secs_f64() * 1e3);
        // Then every gate, noise and depth, measured in the background.
        let snap = h.state().snapshot().unwrap();
        while !h.state().sensor.is_current(&snap) {
            std::thread::sleep(Duration::from_millis(1));
            h.step();
        }
        all_ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times_ms.sort_by(f64::total_cmp);
    all_ms.sort_by(f64::total_cmp);
    println!(
        "| {label} | {gates} | {edits} | {:.1} | {:.1} | {:.1} | {:.0} |",
        quantile(&times_ms, 0.5),
        quantile(&times_ms, 0.95),
        times_ms.last().unwrap(),
        quantile(&all_ms, 0.5),
    );
}

fn main() {
    // `cargo bench --bench viewer -- sensor` (or `-- frames`) runs one part; a number
    // (`-- frames 512`) keeps only the films of that side.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let sides: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    let only: Vec<&String> = args
        .iter()
        .filter(|a| a.parse::<usize>().is_err())
        .collect();
    let part = |name: &str| {
        only.iter()
            .all(|a| ["gated", "lidar", "amcw"].contains(&a.as_str()))
            || only.iter().any(|a| *a == name)
    };
    // `-- spad`: the SPAD preset's preview and first stage after an edit.
    if part("frames") {
        frames(&sides);
    }
    if part("sensor") {
        // `-- sensor lidar` keeps only that preset's rows.
        let presets: Vec<&str> = ["gated", "lidar", "amcw"]
            .into_iter()
            .filter(|p| only.iter().any(|a| a == p))
            .collect();
        sensor(&presets);
    }
    if part("spad") {
        spad();
    }
    if part("throughput") {
        throughput();
    }
    if part("paint") {
        paint();
    }
}

/// Area of triangle `t` inside `clip` (Sutherland-Hodgman against the rectangle's four
/// sides, then the shoelace formula), square pixels.
fn clipped_area(t: [Pos2; 3], clip: egui::Rect) -> f64 {
    let mut poly: Vec<Pos2> = t.to_vec();
    // (along y, the side's coordinate, inside above it).
    let sides = [
        (false, clip.min.x, true),
        (false, clip.max.x, false),
        (true, clip.min.y, true),
        (true, clip.max.y, false),
    ];
    for (along_y, edge, keep_above) in sides {
        let coord = |p: Pos2| if along_y { p.y } else { p.x };
        let inside = |p: Pos2| (coord(p) >= edge) == keep_above || coord(p) == edge;
        let mut out = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            if inside(a) {
                out.push(a);
            }
            if inside(a) != inside(b) {
                let f = (edge - coord(a)) / (coord(b) - coord(a));
                out.push(a + (b - a) * f);
            }
        }
        poly = out;
        if poly.len() < 3 {
            return 0.0;
        }
    }
    let twice: f64 = (0..poly.len())
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            f64::from(a.x) * f64::from(b.y) - f64::from(b.x) * f64::from(a.y)
        })
        .sum();
    0.5 * twice.abs()
}

/// Pixels the rasteriser shades for a frame's meshes, as a multiple of the window's
/// pixels (1 = every pixel once): the area of every triangle inside its clip rectangle.
/// What a software rasteriser's time follows; egui has no depth test, so every layer
/// of a pixel is shaded and blended.
fn overdraw(prims: &[egui::ClippedPrimitive], window: Vec2) -> f64 {
    let mut area = 0.0;
    for p in prims {
        if let egui::epaint::Primitive::Mesh(m) = &p.primitive {
            let clip = p
                .clip_rect
                .intersect(egui::Rect::from_min_size(Pos2::ZERO, window));
            for t in m.indices.chunks_exact(3) {
                let v = |i: u32| m.vertices[i as usize].pos;
                area += clipped_area([v(t[0]), v(t[1]), v(t[2])], clip);
            }
        }
    }
    area / f64::from(window.x * window.y)
}

/// The whole frame: our `ui()` with egui's layout and tessellation, then the paint of
/// the 1280 x 800 window by wgpu on whatever adapter there is (Mesa's lavapipe, on the
/// CPU, where there is no GPU) with egui-wgpu's default options (eframe's), read back (kittest reads
/// the image; 4 MB), while the renderer runs, playback on, the pointer on the slice.
/// `cargo bench --bench viewer -- paint`.
fn paint() {
    println!(
        "\nWhole frame (UI + layout + tessellation, then wgpu paint and read-back of 1280 x 800), \
         128 x 128 x 256 cornell while rendering\n"
    );
    println!(
        "| tab | frames | UI p50 ms | paint p50 ms | paint p95 ms | whole p50 ms | whole p95 ms | pixels shaded / window | adapter |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for mode in [Mode::Transient, Mode::Sensor] {
        let settings = ViewerSettings {
            mode,
            ..ViewerSettings::default()
        };
        let mut h = Harness::builder()
            .with_size(Vec2::new(1280.0, 800.0))
            .with_render_options(eframe::egui_wgpu::RendererOptions::default())
            .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default));
        let start = Instant::now();
        while h.state().snapshot().is_none() {
            assert!(start.elapsed() < Duration::from_secs(120), "no film");
            h.step();
            std::thread::sleep(Duration::from_millis(5));
        }
        h.run_steps(3);
        if let Some(n) = h.query_by_label("time slice") {
            let c = n.rect().center();
            h.hover_at(Pos2::new(c.x, c.y));
        }
        if let Err(e) = h.render() {
            println!("| {mode:?} | - | - | - | - | - | - | - | none: {e} |");
            continue;
        }
        let frames = 60;
        let (mut ui_ms, mut paint_ms, mut whole_ms) = (vec![], vec![], vec![]);
        let mut shaded = vec![];
        for _ in 0..frames {
            let t = Instant::now();
            h.step();
            let ui = t.elapsed();
            let _ = h.render();
            let whole = t.elapsed();
            let prims = h.ctx.tessellate(h.output().shapes.clone(), 1.0);
            shaded.push(overdraw(&prims, Vec2::new(1280.0, 800.0)));
            ui_ms.push(ui.as_secs_f64() * 1e3);
            paint_ms.push((whole - ui).as_secs_f64() * 1e3);
            whole_ms.push(whole.as_secs_f64() * 1e3);
        }
        for v in [&mut ui_ms, &mut paint_ms, &mut whole_ms, &mut shaded] {
            v.sort_by(f64::total_cmp);
        }
        println!(
            "| {mode:?} | {frames} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} | wgpu (kittest) |",
            quantile(&ui_ms, 0.5),
            quantile(&paint_ms, 0.5),
            quantile(&paint_ms, 0.95),
            quantile(&whole_ms, 0.5),
            quantile(&whole_ms, 0.95),
            quantile(&shaded, 0.5),
        );
        if std::env::var_os("TPRF_BENCH_LAYERS").is_some() {
            layers(&h.ctx, h.output().shapes.clone());
        }
    }
}

/// The largest meshes of a frame (`TPRF_BENCH_LAYERS=1`): area as a share of the window,
/// clip rectangle, first vertex colour and texture, to see which layers a pixel has.
fn layers(ctx: &egui::Context, shapes: Vec<egui::epaint::ClippedShape>) {
    let window = Vec2::new(1280.0, 800.0);
    let mut big: Vec<(f64, String)> = ctx
        .tessellate(shapes, 1.0)
        .iter()
        .filter_map(|p| match &p.primitive {
            egui::epaint::Primitive::Mesh(m) => {
                let a = overdraw(std::slice::from_ref(p), window);
                let c = m.vertices.first().map(|v| v.color);
                Some((
                    a,
                    format!(
                        "clip {:?} colour {c:?} texture {:?} triangles {}",
                        p.clip_rect,
                        m.texture_id,
                        m.indices.len() / 3
                    ),
                ))
            }
            _ => None,
        })
        .collect();
    big.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (a, what) in big.iter().take(20) {
        println!("    {a:.3} {what}");
    }
}

/// The SPAD preset after an edit: the UI thread's frame, then the wall time until the
/// preview of the expected histogram and depth (a coarse grid) is on screen, and until
/// the full expected histogram is. Edits follow each other as a drag would, without
/// waiting for the realisation (the next edit cancels it).
fn spad() {
    println!(
        "\nSPAD preset (builtin:spad, 512 TDC bins): the frame after an edit, then the wall \
         time until the preview and the full expected histogram are shown\n"
    );
    println!(
        "| film (cornell) | edit | edits | frame p50 ms | frame p95 ms | preview p50 ms | \
         preview max ms | preview made in, p50 ms | full expected p50 ms |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for light in [false, true] {
        spad_edits(160, 512, 12, light);
    }
}

fn spad_edits(side: usize, bins: usize, edits: usize, light: bool) {
    let mut h = sensor_window("spad", side, bins);
    let start = Instant::now();
    loop {
        h.step();
        let ready = h.state().status().map(|s| s.spp) == Some(1)
            && h.state()
                .snapshot()
                .is_some_and(|s| h.state().sensor.is_current(&s));
        if ready && !h.state().sensor.spad_sampling() {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "no SPAD after 300 s"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let (mut frame_ms, mut preview_ms, mut full_ms) = (vec![], vec![], vec![]);
    let mut made_ms = vec![];
    for k in 0..edits {
        let sensor = &mut h.state_mut().settings.sensor;
        if light {
            if let LightPulse::Gaussian { centre_s, .. } = &mut sensor.light {
                *centre_s += 1e-12 * (1 + k % 7) as f64;
            }
        } else if let Some(s) = sensor.spad.as_mut() {
            s.pde = if k % 2 == 0 { 0.35 } else { 0.3 };
        }
        let t = Instant::now();
        h.step();
        let shapes = h.output().shapes.clone();
        let _ = h.ctx.tessellate(shapes, 1.0);
        frame_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let snap = h.state().snapshot().unwrap();
        let mut previewed = false;
        while !h.state().sensor.is_current(&snap) {
            std::thread::sleep(Duration::from_millis(1));
            h.step();
            if !previewed && h.state().sensor.spad_previewing(&snap) {
                previewed = true;
                preview_ms.push(t.elapsed().as_secs_f64() * 1e3);
                made_ms.extend(h.state().sensor.preview_millis(&snap));
            }
        }
        full_ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    for v in [&mut frame_ms, &mut preview_ms, &mut full_ms, &mut made_ms] {
        v.sort_by(f64::total_cmp);
    }
    let q = |v: &[f64], p: f64| {
        if v.is_empty() {
            f64::NAN
        } else {
            quantile(v, p)
        }
    };
    println!(
        "| {side} x {side} x {bins} | {} | {edits} ({} previewed) | {:.1} | {:.1} | {:.0} | \
         {:.0} | {:.0} | {:.0} |",
        if light {
            "light pulse (clean measured again)"
        } else {
            "PDE (SPAD only)"
        },
        preview_ms.len(),
        q(&frame_ms, 0.5),
        q(&frame_ms, 0.95),
        q(&preview_ms, 0.5),
        preview_ms.last().copied().unwrap_or(f64::NAN),
        q(&made_ms, 0.5),
        q(&full_ms, 0.5),
    );
}

/// Samples per pixel per wall second, window against `tprf render`: the real app
/// (egui_kittest, UI frames at a 60 Hz pace, playback on, the pointer over the image)
/// renders to `spp` from the moment it opens; then the CLI renders the same film to the
/// same spp with the worker's thread count and the same bounce layers (3), timed from
/// process start to exit (writing `tprf.npy` included), with the render time it reports.
/// Seconds the window takes from opening to `spp` samples on a `side`^2 x `bins` film
/// of builtin:cornell, stepped at up to 60 frames a second with the pointer over the
/// image; `playing`: playback on (a new slice every frame) or paused. Each frame is
/// also drawn through wgpu where an adapter exists (software Vulkan here: the cost a
/// machine without a GPU pays), so the UI's share of the cores shows.
fn window_seconds(side: usize, bins: usize, spp: u64, playing: bool) -> f64 {
    let settings = ViewerSettings {
        width: side,
        height: side,
        bins,
        spp_target: spp,
        ..ViewerSettings::default()
    };
    let opened = Instant::now();
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default));
    let mut hovering = false;
    let mut draw = true;
    loop {
        let t = Instant::now();
        h.state_mut().playing = playing;
        h.step();
        if draw {
            // No adapter: the tessellation alone, as before.
            draw = h.render().is_ok();
        }
        if !draw {
            let shapes = h.output().shapes.clone();
            let _ = h.ctx.tessellate(shapes, 1.0);
        }
        if !hovering && let Some(n) = h.query_by_label("time slice") {
            let c = n.rect().center();
            h.hover_at(Pos2::new(c.x, c.y));
            hovering = true;
        }
        let status = h.state().status();
        if let Some(s) = &status
            && let tprf_core::request::worker::WorkerState::Failed(e) = &s.state
        {
            panic!("render failed: {e}");
        }
        if status.is_some_and(|s| s.spp >= spp) {
            return opened.elapsed().as_secs_f64();
        }
        assert!(
            opened.elapsed() < Duration::from_secs(600),
            "window too slow"
        );
        std::thread::sleep(Duration::from_micros(16_667).saturating_sub(t.elapsed()));
    }
}

fn throughput() {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .saturating_sub(1)
        .max(1);
    println!(
        "\nWindow against CLI, builtin:cornell, {threads} render thread(s), same spp, one run\n"
    );
    println!(
        "| film | spp | window wall s, playing | paused | playing / paused rate | CLI wall s | CLI render s | window (playing) / CLI rate | CLI wall / render |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (side, bins, spp) in [(256usize, 512usize, 32u64), (512, 1024, 8)] {
        let window_s = window_seconds(side, bins, spp, true);
        let paused_s = window_seconds(side, bins, spp, false);
        let out = std::env::temp_dir().join(format!("tprf-bench-throughput-{side}"));
        let started = Instant::now();
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
            .args(["render", "builtin:cornell", "--bounces-separate", "3"])
            .args(["--width", &side.to_string(), "--height", &side.to_string()])
            .args(["--bins", &bins.to_string(), "--spp", &spp.to_string()])
            .args(["--threads", &threads.to_string(), "--out"])
            .arg(&out)
            .output()
            .expect("tprf render runs");
        let cli_s = started.elapsed().as_secs_f64();
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let meta: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("tprf.json")).unwrap()).unwrap();
        let render_s = meta["render_seconds"].as_f64().unwrap();
        let _ = std::fs::remove_dir_all(&out);
        let (w_rate, c_rate) = (spp as f64 / window_s, spp as f64 / cli_s);
        println!(
            "| {side} x {side} x {bins} | {spp} | {window_s:.1} | {paused_s:.1} | {:.2} | {cli_s:.1} | {render_s:.1} | {:.2} | {:.2} |",
            paused_s / window_s,
            w_rate / c_rate,
            cli_s / render_s
        );
    }
}

fn frames(sides: &[usize]) {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "UI thread time per frame while rendering ({threads} hardware threads; the renderer uses {})\n",
        threads.saturating_sub(1).max(1)
    );
    println!(
        "| film (cornell) | frames | p50 ms | p95 ms | p99 ms | max ms | UI CPU p50 ms | UI CPU p99 ms | new snapshots seen | spp at end |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let base = ViewerSettings::default();
    for (side, bins, frames) in [(128, 256, 600), (256, 512, 600), (512, 1024, 300)] {
        if !sides.is_empty() && !sides.contains(&side) {
            continue;
        }
        let settings = ViewerSettings {
            width: side,
            height: side,
            bins,
            ..base.clone()
        };
        let default = if settings == base { " (default)" } else { "" };
        run(
            &format!("{side} x {side} x {bins}{default}"),
            settings,
            frames,
        );
    }
}

fn sensor(presets: &[&str]) {
    println!(
        "\nSensor mode: UI thread time of the frame after an edit of Light(t) (the gate on screen measured in it), and the time until all gates are\n"
    );
    println!(
        "| film (cornell) | gates | edits | frame p50 ms | frame p95 ms | frame max ms | all gates + depth, p50 ms |"
    );
    println!("|---|---|---|---|---|---|---|");
    let rows = [
        ("128 x 128 x 256, gated camera", "gated", 128, 256, 60),
        ("256 x 256 x 1024, gated camera", "gated", 256, 1024, 40),
        (
            "256 x 256 x 1024, full-waveform LiDAR",
            "lidar",
            256,
            1024,
            20,
        ),
        ("256 x 256 x 1024, AMCW", "amcw", 256, 1024, 20),
        (
            "256 x 256 x 1024, SPAD (512 TDC bins)",
            "spad",
            256,
            1024,
            12,
        ),
    ];
    for (label, preset, side, bins, edits) in rows {
        if presets.is_empty() || presets.contains(&preset) {
            sensor_edits(label, preset, side, bins, edits);
        }
    }
}

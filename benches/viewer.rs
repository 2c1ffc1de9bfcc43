//! UI frame time while the renderer runs: `cargo bench --bench viewer`.
//!
//! Drives the real app (egui_kittest, no window) at a 60 Hz pace while the background
//! worker renders, with playback on (a new time slice is coloured every frame) and the
//! pointer over the image (hover readout). A frame's time is what the UI thread spends:
//! our `ui()` (reading the latest snapshot, colouring, plots) plus egui's layout and
//! tessellation. The GPU paint is not included (it runs on the GPU, or on Mesa's
//! software rasteriser where none exists, which measures the rasteriser, not tprf).

use eframe::egui::{Pos2, Vec2};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use std::time::{Duration, Instant};
use tprf::viewer::{Start, TprfApp, ViewerSettings};

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
    let mut snapshots = 0;
    let mut last = None;
    for _ in 0..frames {
        let t = Instant::now();
        h.step();
        let shapes = h.output().shapes.clone();
        let _ = h.ctx.tessellate(shapes, 1.0);
        let spent = t.elapsed();
        times_ms.push(spent.as_secs_f64() * 1e3);
        let snap = h
            .state()
            .snapshot()
            .map(|s| std::sync::Arc::as_ptr(&s) as usize);
        if snap != last {
            snapshots += 1;
            last = snap;
        }
        std::thread::sleep(Duration::from_micros(16_667).saturating_sub(spent));
    }
    let status = h.state().status().unwrap();
    times_ms.sort_by(f64::total_cmp);
    println!(
        "| {label} | {frames} | {:.2} | {:.2} | {:.2} | {:.2} | {snapshots} | {} |",
        quantile(&times_ms, 0.5),
        quantile(&times_ms, 0.95),
        quantile(&times_ms, 0.99),
        times_ms.last().unwrap(),
        status.spp
    );
}

fn main() {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "UI thread time per frame while rendering ({threads} hardware threads; the renderer uses {})\n",
        threads.saturating_sub(1).max(1)
    );
    println!(
        "| film (cornell) | frames | p50 ms | p95 ms | p99 ms | max ms | new snapshots seen | spp at end |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let base = ViewerSettings::default();
    run("128 x 128 x 256 (default)", base.clone(), 600);
    run(
        "256 x 256 x 512",
        ViewerSettings {
            width: 256,
            height: 256,
            bins: 512,
            ..base.clone()
        },
        600,
    );
    run(
        "512 x 512 x 1024",
        ViewerSettings {
            width: 512,
            height: 512,
            bins: 1024,
            ..base
        },
        300,
    );
}

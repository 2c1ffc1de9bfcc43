//! The central panel in sensor mode: the measurement M_i of the gate shown (one
//! exposure over all gates), the depth image and, for AMCW, the multipath error; click a
//! pixel to select it.

use super::gate_time_label;
use super::measure::SpadView;
use super::state::SensorState;
use crate::viewer::colormap::{self, ColorMap, Tone};
use crate::viewer::textures::TextureCache;
use eframe::egui::{self, RichText, Sense, TextureHandle, Vec2};
use tprf_core::film::FilmSnapshot;

/// The measurement image of the gate shown and the derived images. Returns a clicked
/// pixel.
pub(crate) fn images_ui(
    ui: &mut egui::Ui,
    state: &mut SensorState,
    snap: &FilmSnapshot,
) -> Option<(usize, usize)> {
    let (w, h) = (snap.width(), snap.height());
    // The textures are taken out for the frame so the measurements can be borrowed.
    let mut textures = std::mem::take(&mut state.textures);
    let mut gate_sel = state.gate;
    let mut view = state.spad_view;
    let clicked = if state.spad(snap).is_some() {
        spad_images(ui, state, snap, &mut textures, &mut gate_sel, &mut view)
    } else {
        measurement_images(ui, state, snap, &mut textures, &mut gate_sel, w, h)
    };
    state.textures = textures;
    state.gate = gate_sel;
    state.spad_view = view;
    clicked
}

/// The SPAD's images: TDC bin `k` of the histogram chosen (expected, one realisation,
/// Coates), one exposure over all bins, and that histogram's first-return depth.
fn spad_images(
    ui: &mut egui::Ui,
    state: &SensorState,
    snap: &FilmSnapshot,
    textures: &mut TextureCache<u64>,
    gate_sel: &mut usize,
    view: &mut SpadView,
) -> Option<(usize, usize)> {
    let (Some(model), Some(sp)) = (state.model.as_ref(), state.spad(snap)) else {
        return None;
    };
    let (w, h) = (snap.width(), snap.height());
    let img = &sp.image;
    let bins = img.bins;
    let bin = (*gate_sel).min(bins.saturating_sub(1));
    let ctx = ui.ctx().clone();
    let mut clicked = None;
    ui.horizontal(|ui| {
        let l = ui.label(format!("TDC bin k (of {bins})"));
        ui.add(egui::Slider::new(gate_sel, 0..=bins.saturating_sub(1)))
            .labelled_by(l.id);
        ui.label(gate_time_label(model, bin));
        for v in SpadView::ALL {
            ui.selectable_value(view, v, v.label());
        }
    });
    ui.label(
        RichText::new(format!(
            "{:.3e} detections expected; realisation: {}; measured in {:.0} ms",
            img.expected_detections,
            img.sampler.name(),
            state.measured.as_ref().map_or(0.0, |m| m.millis)
        ))
        .weak()
        .small(),
    );
    let hash = |x: &dyn std::fmt::Debug| {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        format!("{x:?}").hash(&mut hasher);
        hasher.finish()
    };
    let key = hash(&(snap.generation(), model.sensor(), *view));
    let avail = ui.available_size();
    let side = (avail.x - 16.0) / 2.0;
    let max = Vec2::new(side, avail.y - 40.0);
    ui.horizontal_top(|ui| {
        ui.vertical(|ui| {
            ui.label(
                RichText::new(format!(
                    "{} counts in bin {bin} (one exposure over all bins)",
                    view.label()
                ))
                .strong(),
            );
            let tone = Tone {
                scale: sp.robust_max(*view).map_or(1.0, |m| 1.0 / m),
                log: false,
                decades: 3.0,
            };
            let plane = img.plane(sp.values(*view), bin);
            let tex = textures.get(&ctx, "spad-bin", hash(&(key, bin)), || {
                egui::ColorImage::from_rgba_unmultiplied(
                    [w, h],
                    &colormap::colorize(plane, &tone, ColorMap::Inferno),
                )
            });
            if let Some(p) = pick(ui, &tex, w, h, max, "SPAD bin image") {
                clicked = Some(p);
            }
        });
        ui.vertical(|ui| {
            let (lo, hi) = sp.depth_range(*view);
            ui.label(
                RichText::new(format!(
                    "first-return depth of the {} histogram (m): {lo:.3} … {hi:.3}",
                    view.label()
                ))
                .strong(),
            );
            let depth = sp.depth(*view);
            let tex = textures.get(&ctx, "spad-depth", key, || depth_image(depth, w, h, lo, hi));
            if let Some(p) = pick(ui, &tex, w, h, max, "SPAD depth image") {
                clicked = Some(p);
            }
        });
    });
    clicked
}

/// The images of [`images_ui`], drawn with `state` borrowed and its `textures` and gate
/// selection taken out of it.
#[allow(clippy::too_many_arguments)]
fn measurement_images(
    ui: &mut egui::Ui,
    state: &SensorState,
    snap: &FilmSnapshot,
    textures: &mut TextureCache<u64>,
    gate_sel: &mut usize,
    w: usize,
    h: usize,
) -> Option<(usize, usize)> {
    let (Some(model), Some(plane)) = (state.model.as_ref(), state.shown_plane(snap)) else {
        ui.label(state.error.clone().unwrap_or_else(|| "Measuring…".into()));
        return None;
    };
    let current = state.is_current(snap);
    let gates = model.gate_count();
    let gate = state.gate.min(gates.saturating_sub(1));
    // Keys on the snapshot's generation (never its address) and the sensor.
    let hash = |x: &dyn std::fmt::Debug| {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        format!("{x:?}").hash(&mut hasher);
        hasher.finish()
    };
    let plane_key = hash(&(snap.generation(), model.sensor(), gate, current));
    let measured = state.measured.as_ref();
    // One exposure over all gates (from the full measurement, even a stale one).
    let all_max = measured
        .and_then(|m| m.robust_max)
        .or_else(|| colormap::quantile_positive(plane.iter().copied(), 0.999));
    let status = match measured {
        Some(m) if current => format!("all {gates} gates measured in {:.0} ms", m.millis),
        _ => {
            let plane_ms = state.plane.as_ref().map_or(0.0, |p| p.millis);
            format!("gate {gate} measured in {plane_ms:.1} ms; all gates updating…")
        }
    };
    let ctx = ui.ctx().clone();
    let mut clicked = None;
    ui.horizontal(|ui| {
        let l = ui.label(format!("gate i (of {gates})"));
        ui.add(egui::Slider::new(gate_sel, 0..=gates.saturating_sub(1)))
            .labelled_by(l.id);
        ui.label(gate_time_label(model, gate));
        ui.label(RichText::new(&status).weak().small());
    });
    let avail = ui.available_size();
    let side = (avail.x - 16.0) / 2.0;
    let max = Vec2::new(side, avail.y - 40.0);
    ui.horizontal_top(|ui| {
        ui.vertical(|ui| {
            ui.label(RichText::new(format!("M_{gate} (one exposure over all gates)")).strong());
            let tone = Tone {
                scale: all_max.map_or(1.0, |m| 1.0 / m),
                log: false,
                decades: 3.0,
            };
            let tex = textures.get(&ctx, "measurement", plane_key, || {
                egui::ColorImage::from_rgba_unmultiplied(
                    [w, h],
                    &colormap::colorize(plane, &tone, ColorMap::Inferno),
                )
            });
            if let Some(p) = pick(ui, &tex, w, h, max, "measurement image") {
                clicked = Some(p);
            }
        });
        let Some(m) = measured else {
            return;
        };
        let Some(depth) = m.depth() else {
            return;
        };
        let key = hash(&(m.snapshot, &m.sensor));
        ui.vertical(|ui| {
            let (lo, hi) = m.depth_range;
            let title = if m.amcw_error_m.is_some() {
                "AMCW depth (m)"
            } else {
                "first-return depth (m)"
            };
            ui.label(RichText::new(format!("{title}: {lo:.3} … {hi:.3}")).strong());
            let small = Vec2::new(
                max.x,
                if m.amcw_error_m.is_some() {
                    max.y / 2.0 - 20.0
                } else {
                    max.y
                },
            );
            let tex = textures.get(&ctx, "depth", key, || depth_image(depth, w, h, lo, hi));
            if let Some(p) = pick(ui, &tex, w, h, small, "depth image") {
                clicked = Some(p);
            }
            if let Some(err) = &m.amcw_error_m {
                let a = m.error_abs_max;
                ui.label(
                    RichText::new(format!(
                        "multipath error: AMCW − true first return, ±{a:.3} m"
                    ))
                    .strong(),
                );
                let tex = textures.get(&ctx, "amcw-error", key, || error_image(err, w, h, a));
                if let Some(p) = pick(ui, &tex, w, h, small, "multipath error image") {
                    clicked = Some(p);
                }
            }
        });
    });
    clicked
}

/// Depth in turbo between `lo` and `hi`; no return is black.
fn depth_image(depth: &[f32], w: usize, h: usize, lo: f32, hi: f32) -> egui::ColorImage {
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    let px: Vec<u8> = depth
        .iter()
        .flat_map(|&d| {
            if d.is_finite() {
                let c = colorous::TURBO.eval_continuous(((d - lo) / span).clamp(0.0, 1.0) as f64);
                [c.r, c.g, c.b, 255]
            } else {
                [0, 0, 0, 255]
            }
        })
        .collect();
    egui::ColorImage::from_rgba_unmultiplied([w, h], &px)
}

/// Signed error, blue (too near) – white – red (too far), saturating at `a`.
fn error_image(err: &[f32], w: usize, h: usize, a: f32) -> egui::ColorImage {
    let a = a.max(f32::MIN_POSITIVE);
    let px: Vec<u8> = err
        .iter()
        .flat_map(|&e| {
            if e.is_finite() {
                let c = colorous::RED_BLUE
                    .eval_continuous((0.5 - 0.5 * (e / a).clamp(-1.0, 1.0)) as f64);
                [c.r, c.g, c.b, 255]
            } else {
                [0, 0, 0, 255]
            }
        })
        .collect();
    egui::ColorImage::from_rgba_unmultiplied([w, h], &px)
}

/// An image that reports the pixel clicked.
fn pick(
    ui: &mut egui::Ui,
    tex: &TextureHandle,
    w: usize,
    h: usize,
    max: Vec2,
    label: &str,
) -> Option<(usize, usize)> {
    let scale = (max.x / w as f32).min(max.y / h as f32).max(0.01);
    let r = ui.add(
        egui::Image::new((tex.id(), Vec2::new(w as f32, h as f32) * scale)).sense(Sense::click()),
    );
    r.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, label));
    crate::viewer::textures::shrunk_note_ui(ui, tex, w, h);
    let pos = r.interact_pointer_pos().filter(|_| r.clicked())?;
    let p = (pos - r.rect.min) / scale;
    Some((
        (p.x.max(0.0) as usize).min(w.saturating_sub(1)),
        (p.y.max(0.0) as usize).min(h.saturating_sub(1)),
    ))
}

//! The central panel in sensor mode: the measurement M_i of the gate shown (one
//! exposure over all gates), the depth image and, for AMCW, the multipath error, each
//! with its colour bar and unit; a readout of the pixel under the pointer; and, when
//! gates need light the film does not hold, which ones, with the two ways out.

use super::gate_time_label;
use super::measure::{Measured, SpadView};
use super::state::SensorState;
use super::view::{Coverage, coverage, gates_fitted, main_span, window_covering};
use crate::viewer::axes::{self, BIN_UNIT, BarScale};
use crate::viewer::colorbar::ColorBar;
use crate::viewer::colormap::{self, ColorMap, Tone};
use crate::viewer::layout::image_layout;
use crate::viewer::textures::TextureCache;
use eframe::egui::{self, RichText, Sense, TextureHandle, Vec2};
use tprf_core::film::{FilmSnapshot, MAX_BINS};
use tprf_core::sensor::{Echo, Exposure, ReturnImages};
use tprf_core::units::format_time;

/// What the user asked for about gates outside the film's window.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum CoverageAction {
    /// Render again over this window: start (s), bin width (s), bins.
    ExtendWindow { t0_s: f64, dt_s: f64, bins: usize },
    /// Replace the gates with these, fitted to the window.
    FitGates(Exposure),
    /// Put this sensor back (the preset as it was before the tab fitted it).
    Restore(Box<tprf_core::sensor::Sensor>),
}

/// What the sensor images report back: a clicked pixel, an action.
#[derive(Default)]
pub(crate) struct ImagesOutcome {
    pub(crate) clicked: Option<(usize, usize)>,
    pub(crate) action: Option<CoverageAction>,
}

/// Height of a colour bar with its labels, points.
const BAR_H: f32 = 30.0;

/// The measurement image of the gate shown and the derived images.
pub(crate) fn images_ui(
    ui: &mut egui::Ui,
    state: &mut SensorState,
    snap: &FilmSnapshot,
) -> ImagesOutcome {
    let (w, h) = (snap.width(), snap.height());
    // The textures are taken out for the frame so the measurements can be borrowed.
    let mut textures = std::mem::take(&mut state.textures);
    let mut gate_sel = state.gate;
    let mut view = state.spad_view;
    let mut echo = state.echo;
    let restore = fit_note_ui(ui, state);
    let mut out = if state.spad_shown(snap).is_some() {
        ImagesOutcome {
            clicked: spad_images(ui, state, snap, &mut textures, &mut gate_sel, &mut view),
            action: None,
        }
    } else {
        measurement_images(
            ui,
            state,
            snap,
            &mut textures,
            (&mut gate_sel, &mut echo),
            (w, h),
        )
    };
    state.echo = echo;
    state.textures = textures;
    state.gate = gate_sel;
    state.spad_view = view;
    if let Some(s) = restore {
        state.fit_note = None;
        out.action = Some(CoverageAction::Restore(Box::new(s)));
    }
    out
}

/// The note that the tab fitted the preset to the film's window, while its gates are
/// the fitted ones, with a button to put the preset's own back; the sensor to put back
/// when it was clicked.
fn fit_note_ui(ui: &mut egui::Ui, state: &SensorState) -> Option<tprf_core::sensor::Sensor> {
    let note = state.fit_note.as_ref()?;
    let model = state.model.as_ref()?;
    if model.sensor().exposure != note.fitted {
        return None;
    }
    let mut restore = None;
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new(format!("ℹ {}", note.text)).color(ui.visuals().strong_text_color()));
        if note.original.exposure != note.fitted
            && ui
                .button(format!("Keep all {} gates", note.original.exposure.count()))
                .on_hover_text("the preset's own gates, most of which see nothing of this film")
                .clicked()
        {
            restore = Some(note.original.clone());
        }
    });
    restore
}

/// The SPAD's images: TDC bin `k` of the histogram chosen (expected, one realisation,
/// Coates), one exposure over all bins, and that histogram's first-return depth; or,
/// while they are measured after an edit, the preview of the expected histogram and
/// its depth on a coarse grid (each grid pixel drawn over its block), marked as one.
fn spad_images(
    ui: &mut egui::Ui,
    state: &SensorState,
    snap: &FilmSnapshot,
    textures: &mut TextureCache<u64>,
    gate_sel: &mut usize,
    view: &mut SpadView,
) -> Option<(usize, usize)> {
    let (Some(model), Some(shown)) = (state.model.as_ref(), state.spad_shown(snap)) else {
        return None;
    };
    let sp = shown.sp;
    let (w, h) = (snap.width(), snap.height());
    let preview = sp.is_preview().then_some(sp.step);
    let img = &sp.image;
    let bins = img.bins;
    let bin = (*gate_sel).min(bins.saturating_sub(1));
    let ctx = ui.ctx().clone();
    let mut clicked = None;
    ui.horizontal(|ui| {
        let l = ui.label(format!("TDC bin k (of {bins})"));
        ui.add(egui::Slider::new(gate_sel, 0..=bins.saturating_sub(1)))
            .labelled_by(l.id);
        ui.add(egui::Label::new(gate_time_label(model, bin)).truncate());
    });
    // The histogram's views on a row of their own: beside the slider they ran past the
    // panel at 1024 px and widened it under the right panel.
    ui.horizontal(|ui| {
        ui.label("histogram:");
        for v in SpadView::ALL {
            ui.selectable_value(view, v, v.label());
        }
    });
    let sampled = match state.measured.as_ref().and_then(|m| m.sample_millis) {
        Some(ms) if sp.is_sampled() => format!("drawn in {ms:.0} ms"),
        _ => "sampling…".to_string(),
    };
    match preview {
        _ if !shown.current => ui.label(
            RichText::new(
                "Updating after the edit… (these histograms are of the sensor or film before \
                 it)",
            )
            .color(ui.visuals().warn_fg_color),
        ),
        Some(step) => ui.label(
            RichText::new(format!(
                "PREVIEW from one pixel per {step} x {step} block ({} x {}, made in {:.0} \
                 ms); the full image is being measured…",
                img.width,
                img.height,
                state.preview_millis(snap).unwrap_or(0.0)
            ))
            .color(ui.visuals().warn_fg_color),
        ),
        None => ui.label(
            RichText::new(format!(
                "{:.3e} detections expected; realisation: {} ({sampled}); expected histogram \
                 and depth measured in {:.0} ms{}",
                img.expected_detections,
                img.sampler.name(),
                state.measured.as_ref().map_or(0.0, |m| m.millis),
                match state.shown_film(snap) {
                    Some((g, spp)) if g != snap.generation() => format!(
                        ", of the film at {spp} spp (it is at {} now: the next measurement \
                         follows)",
                        snap.spp
                    ),
                    _ => String::new(),
                }
            ))
            .weak(),
        ),
    };
    // The realisation's views show the expected histogram until it is drawn.
    let waiting = sp.shown(*view) != *view;
    let hash = |x: &dyn std::fmt::Debug| {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        format!("{x:?}").hash(&mut hasher);
        hasher.finish()
    };
    // Keyed on what the histograms are of (a stale image keeps its textures).
    let key = hash(&(shown.snapshot, shown.sensor, sp.shown(*view), sp.step));
    let avail = ui.available_size();
    let avail = Vec2::new(avail.x, avail.y - strip_height(avail.y, bins));
    let title_h = 22.0;
    let readout_h = 26.0;
    let side = (avail.x - 16.0) / 2.0;
    let max = Vec2::new(side, avail.y - title_h - BAR_H - readout_h - 12.0);
    // The largest image of the film's aspect inside `max`.
    let size = {
        let scale = (max.x / w.max(1) as f32)
            .min(max.y / h.max(1) as f32)
            .max(0.01);
        Vec2::new(w as f32, h as f32) * scale
    };
    let white = sp.robust_max(*view);
    let plane = sp.film_plane(sp.values(*view), bin, (w, h));
    let depth = sp.at_film(sp.depth(*view), (w, h));
    let mut hovered = None;
    ui.horizontal_top(|ui| {
        ui.vertical(|ui| {
            ui.set_width(size.x);
            ui.add(
                egui::Label::new(
                    RichText::new(if let Some(step) = preview {
                        format!(
                            "expected counts in bin {bin} (preview, 1 pixel per {step} x {step})"
                        )
                    } else if waiting {
                        format!(
                            "sampling {}… expected counts in bin {bin} meanwhile",
                            view.label()
                        )
                    } else {
                        format!(
                            "{} counts in bin {bin} (one exposure over all bins)",
                            view.label()
                        )
                    })
                    .strong(),
                )
                .truncate(),
            );
            let tone = Tone {
                scale: white.map_or(1.0, |m| 1.0 / m),
                log: false,
                decades: 3.0,
            };
            let tex = textures.get(&ctx, "spad-bin", hash(&(key, bin)), || {
                egui::ColorImage::from_rgba_unmultiplied(
                    [w, h],
                    &colormap::colorize(&plane, &tone, ColorMap::Inferno),
                )
            });
            let p = pick(ui, &tex, w, h, size, "SPAD bin image");
            clicked = clicked.or(p.clicked);
            hovered = hovered.or(p.hover);
            let ramp = |t: f64| colormap::color_of(ColorMap::Inferno, t);
            ColorBar {
                of: "SPAD counts",
                ramp: &ramp,
                scale: BarScale::Linear {
                    lo: 0.0,
                    hi: white.unwrap_or(1.0),
                },
                unit: "counts",
                second: None,
                note: "counts per TDC bin over all cycles; white = the 99.9th percentile of \
                       this histogram's bins over all pixels",
            }
            .ui(ui, size.x);
        });
        ui.vertical(|ui| {
            ui.set_width(size.x);
            let (lo, hi) = sp.depth_range();
            ui.add(
                egui::Label::new(
                    RichText::new(match preview {
                        Some(_) => {
                            "first-return depth of the expected histogram (preview)".to_string()
                        }
                        None => format!(
                            "first-return depth of the {} histogram",
                            sp.shown(*view).label()
                        ),
                    })
                    .strong(),
                )
                .truncate(),
            );
            let tex = textures.get(&ctx, "spad-depth", key, || {
                depth_image(&depth, w, h, lo, hi)
            });
            let p = pick(ui, &tex, w, h, size, "SPAD depth image");
            clicked = clicked.or(p.clicked);
            hovered = hovered.or(p.hover);
            ColorBar {
                of: "depth",
                ramp: &colormap::turbo,
                scale: BarScale::Linear {
                    lo: f64::from(lo),
                    hi: f64::from(hi).max(f64::from(lo) + 1e-6),
                },
                unit: "m",
                second: None,
                note: "depth = c × round-trip time / 2 of the histogram's first peak; \
                       black: no return",
            }
            .ui(ui, size.x);
        });
    });
    let text = match hovered {
        Some((x, y)) => {
            let i = y * w + x;
            let mut s = format!(
                "row {y}, column {x} · bin {bin}: {} counts",
                axes::format_value(f64::from(plane.get(i).copied().unwrap_or(0.0)), "")
            );
            match depth.get(i) {
                Some(d) if d.is_finite() => s += &format!(" · depth {d:.3} m"),
                _ => s += " · no return",
            }
            s
        }
        None => "Hover a pixel to read its counts and depth".to_string(),
    };
    ui.add(egui::Label::new(RichText::new(text).monospace()).truncate());
    let values = sp.values(*view);
    let tone = white.map_or(1.0, |m| 1.0 / m);
    let planes = |k: usize| img.plane(values, k);
    let thumb_key = |k: usize| hash(&(key, k, "strip"));
    // A preview's thumbnails at its own grid (the film's aspect, near enough).
    if let Some(k) = gate_strip(
        ui,
        textures,
        (img.width, img.height),
        bins,
        bin,
        "TDC bin",
        tone,
        &planes,
        &thumb_key,
    ) {
        *gate_sel = k;
    }
    clicked
}

/// `[1, 2, 3, 5]` as "1–3, 5".
pub(crate) fn index_ranges(v: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let mut j = i;
        while j + 1 < v.len() && v[j + 1] == v[j] + 1 {
            j += 1;
        }
        parts.push(if j > i {
            format!("{}–{}", v[i], v[j])
        } else {
            v[i].to_string()
        });
        i = j + 1;
    }
    parts.join(", ")
}

/// The warning about gates that need light outside the window, with its two buttons.
fn coverage_ui(
    ui: &mut egui::Ui,
    state: &SensorState,
    snap: &FilmSnapshot,
) -> Option<CoverageAction> {
    let model = state.model.as_ref()?;
    let axis = snap.axis();
    let pulse = main_span(model.light());
    let cov: Vec<Coverage> = model
        .gates()
        .iter()
        .map(|g| coverage(g, pulse, axis, state.auto_start))
        .collect();
    let of = |c: Coverage| -> Vec<usize> {
        cov.iter()
            .enumerate()
            .filter(|(_, x)| **x == c)
            .map(|(i, _)| i)
            .collect()
    };
    let (outside, partial) = (of(Coverage::Outside), of(Coverage::Partial));
    if outside.is_empty() && partial.is_empty() {
        return None;
    }
    let window = format!("{} … {}", format_time(axis.t0_s), format_time(axis.end_s()));
    let mut text = String::from("⚠ ");
    if !outside.is_empty() {
        text += &format!(
            "gate{} {} of {} lie outside the rendered window {window}: no data, black",
            if outside.len() > 1 { "s" } else { "" },
            index_ranges(&outside),
            cov.len()
        );
    }
    if !partial.is_empty() {
        if !outside.is_empty() {
            text += "; ";
        }
        text += &format!(
            "gate{} {} partly outside it: light missing",
            if partial.len() > 1 { "s" } else { "" },
            index_ranges(&partial)
        );
    }
    let mut action = None;
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new(text).color(ui.visuals().warn_fg_color));
        let (t0, dt, bins) = window_covering(model.gates(), pulse, axis, MAX_BINS);
        if ui
            .button("Extend the window to cover the gates")
            .on_hover_text(format!(
                "render again over {} … {} ({bins} bins of {})",
                format_time(t0),
                format_time(t0 + dt * bins as f64),
                format_time(dt)
            ))
            .clicked()
        {
            action = Some(CoverageAction::ExtendWindow {
                t0_s: t0,
                dt_s: dt,
                bins,
            });
        }
        if let Some(fitted) = gates_fitted(&model.sensor().exposure, axis, pulse, state.auto_start)
            && ui
                .button("Fit the gates to the window")
                .on_hover_text("the same number of gates, tiling the rendered window")
                .clicked()
        {
            action = Some(CoverageAction::FitGates(fitted));
        }
    });
    action
}

/// The images of [`images_ui`], drawn with `state` borrowed and its `textures`, gate
/// and return selections taken out of it.
fn measurement_images(
    ui: &mut egui::Ui,
    state: &SensorState,
    snap: &FilmSnapshot,
    textures: &mut TextureCache<u64>,
    (gate_sel, echo): (&mut usize, &mut Echo),
    (w, h): (usize, usize),
) -> ImagesOutcome {
    let mut out = ImagesOutcome::default();
    let (Some(model), Some(plane)) = (state.model.as_ref(), state.shown_plane(snap)) else {
        ui.label(state.error.clone().unwrap_or_else(|| "Measuring…".into()));
        return out;
    };
    let current = state.shows_full(snap);
    let gates = model.gate_count();
    let gate = state.gate.min(gates.saturating_sub(1));
    // Keys on the snapshot's generation (never its address) and the sensor.
    let hash = |x: &dyn std::fmt::Debug| {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        format!("{x:?}").hash(&mut hasher);
        hasher.finish()
    };
    let measured = measured_of_film(state, snap);
    // One exposure over all gates, the same before and after all gates are measured.
    let white = state
        .shared_white()
        .or_else(|| colormap::quantile_positive(plane.iter().copied(), 0.999));
    let plane_key = hash(&(snap.generation(), model.sensor(), gate, current, white));
    let status = match measured {
        Some(m) if current && m.snapshot == snap.generation() => {
            format!("all {gates} gates measured in {:.0} ms", m.millis)
        }
        Some(m) if current => format!(
            "all {gates} gates measured in {:.0} ms, of the film at {} spp (it is at {} now: \
             the next measurement follows)",
            m.millis, m.spp, snap.spp
        ),
        _ => {
            let plane_ms = state.plane.as_ref().map_or(0.0, |p| p.millis);
            format!("gate {gate} measured in {plane_ms:.1} ms; all gates updating…")
        }
    };
    let ctx = ui.ctx().clone();
    ui.horizontal(|ui| {
        let l = ui.label(format!("gate i (of {gates})"));
        ui.add(egui::Slider::new(gate_sel, 0..=gates.saturating_sub(1)))
            .labelled_by(l.id);
        ui.add(egui::Label::new(gate_time_label(model, gate)).truncate());
    });
    // On its own line: wrapped beside the slider it was drawn over the row.
    ui.add(egui::Label::new(RichText::new(&status).weak()).truncate());
    out.action = coverage_ui(ui, state, snap);
    let pulse = main_span(model.light());
    let shown_cov = model.gates().get(gate).map_or(Coverage::Inside, |g| {
        coverage(g, pulse, snap.axis(), state.auto_start)
    });
    let derived = measured.filter(|m| m.smalls() > 0);
    let avail = ui.available_size();
    let avail = Vec2::new(avail.x, avail.y - strip_height(avail.y, gates));
    let readout_h = 26.0;
    let title_h = 22.0;
    let extra = title_h + BAR_H + 8.0;
    let aspect = w.max(1) as f32 / h.max(1) as f32;
    // Two derived images (AMCW depth and its multipath error): the measurement large,
    // those two beside or under it, as the main tab lays out its images. One (a
    // return's depth, or FLIM's lifetime): two equal columns. None: the measurement
    // alone.
    let two = derived.is_some_and(|m| m.smalls() >= 2);
    let (big, small, below) = if two {
        let l = image_layout((avail.x, avail.y - readout_h), aspect, extra, 12.0);
        (
            Vec2::new(l.big.0, l.big.1),
            Vec2::new(l.small.0, l.small.1),
            l.below,
        )
    } else {
        let cols = if derived.is_some() { 2.0 } else { 1.0 };
        let col_w = (avail.x - 12.0 * (cols - 1.0)) / cols;
        let img_h = (avail.y - readout_h - extra).max(16.0);
        let side = col_w.min(img_h * aspect).max(16.0);
        let size = Vec2::new(side, side / aspect);
        (size, size, false)
    };
    let mut hovered: Option<(usize, usize)> = None;
    let mut measurement = |ui: &mut egui::Ui, out: &mut ImagesOutcome| {
        ui.vertical(|ui| {
            ui.set_width(big.x);
            ui.add(
                egui::Label::new(
                    RichText::new(format!("M_{gate}, the measurement of gate {gate}")).strong(),
                )
                .truncate(),
            )
            .on_hover_text("one exposure for all gates: see the colour bar");
            let tone = Tone {
                scale: white.map_or(1.0, |m| 1.0 / m),
                log: false,
                decades: 3.0,
            };
            let tex = textures.get(&ctx, "measurement", plane_key, || {
                egui::ColorImage::from_rgba_unmultiplied(
                    [w, h],
                    &colormap::colorize(plane, &tone, ColorMap::Inferno),
                )
            });
            let Picked {
                clicked,
                hover,
                rect,
            } = pick(ui, &tex, w, h, big, "measurement image");
            out.clicked = out.clicked.or(clicked);
            hovered = hovered.or(hover);
            if shown_cov != Coverage::Inside {
                let text = if shown_cov == Coverage::Outside {
                    format!("gate {gate} lies outside the rendered window: no data")
                } else {
                    format!("gate {gate} is partly outside the rendered window")
                };
                let painter = ui.painter_at(rect);
                let galley = painter.layout(
                    text,
                    egui::FontId::proportional(15.0),
                    egui::Color32::WHITE,
                    rect.width() - 16.0,
                );
                let at = rect.center() - galley.size() / 2.0;
                painter.rect_filled(
                    egui::Rect::from_min_size(at, galley.size()).expand(6.0),
                    4.0,
                    egui::Color32::from_black_alpha(200),
                );
                painter.galley(at, galley, egui::Color32::WHITE);
            }
            let ramp = |t: f64| colormap::color_of(ColorMap::Inferno, t);
            ColorBar {
                of: "measurement",
                ramp: &ramp,
                scale: BarScale::Linear {
                    lo: 0.0,
                    hi: white.unwrap_or(1.0),
                },
                unit: BIN_UNIT,
                second: None,
                note: "M_i: a bin's unit times the light's energy; white = the 99.9th \
                       percentile of all gates' clean measurements on a grid of pixels",
            }
            .ui(ui, big.x);
        });
        let Some(m) = derived else {
            return;
        };
        let key = hash(&(m.snapshot, &m.sensor, *echo));
        let (lo, hi) = m.depth_range;
        let mut depth_block = |ui: &mut egui::Ui,
                               textures: &mut TextureCache<u64>,
                               out: &mut ImagesOutcome|
         -> Option<(usize, usize)> {
            let depth = m.depth(*echo)?;
            ui.vertical(|ui| {
                ui.set_width(small.x);
                match &m.returns {
                    Some(r) => echo_choice(ui, echo, r),
                    None => {
                        ui.add(egui::Label::new(RichText::new("AMCW depth").strong()).truncate());
                    }
                }
                let tex = textures.get(&ctx, "depth", key, || depth_image(depth, w, h, lo, hi));
                let Picked { clicked, hover, .. } = pick(ui, &tex, w, h, small, "depth image");
                out.clicked = out.clicked.or(clicked);
                ColorBar {
                    of: "depth",
                    ramp: &colormap::turbo,
                    scale: BarScale::Linear {
                        lo: f64::from(lo),
                        hi: f64::from(hi).max(f64::from(lo) + 1e-6),
                    },
                    unit: "m",
                    second: None,
                    note: "depth = c × (return time − the light's mean emission time) / 2: \
                           the distance along the pixel's ray when the light is beside \
                           the camera, half the light → surface → eye path otherwise; \
                           black: no return",
                }
                .ui(ui, small.x);
                hover
            })
            .inner
        };
        let error_block = |ui: &mut egui::Ui,
                           textures: &mut TextureCache<u64>,
                           out: &mut ImagesOutcome|
         -> Option<(usize, usize)> {
            let err = m.amcw_error_m.as_ref()?;
            ui.vertical(|ui| {
                ui.set_width(small.x);
                let a = m.error_abs_max;
                ui.add(egui::Label::new(RichText::new("multipath error").strong()).truncate())
                    .on_hover_text(
                        "AMCW depth − the depth of the TPRF's own first return (the \
                         single-scattering layer's, when the render kept bounce layers)",
                    );
                let tex = textures.get(&ctx, "amcw-error", key, || error_image(err, w, h, a));
                let Picked { clicked, hover, .. } =
                    pick(ui, &tex, w, h, small, "multipath error image");
                out.clicked = out.clicked.or(clicked);
                let a = f64::from(a).max(1e-9);
                ColorBar {
                    of: "multipath error",
                    ramp: &colormap::diverging,
                    scale: BarScale::Linear { lo: -a, hi: a },
                    unit: "m",
                    second: None,
                    note: "red: AMCW reads too far; blue: too near",
                }
                .ui(ui, small.x);
                hover
            })
            .inner
        };
        let lifetime_block = |ui: &mut egui::Ui,
                              textures: &mut TextureCache<u64>,
                              out: &mut ImagesOutcome|
         -> Option<(usize, usize)> {
            let tau = m.flim_lifetime_s.as_ref()?;
            ui.vertical(|ui| {
                ui.set_width(small.x);
                ui.add(egui::Label::new(RichText::new("FLIM lifetime").strong()).truncate())
                    .on_hover_text(
                        "each pixel's fluorescence lifetime from gates 0 and 1 (rapid \
                         lifetime determination): tau = dt / ln(M_0 / M_1), dt the gates' \
                         spacing; exact for one exponential decay",
                    );
                let top_ns = f64::from(m.lifetime_top_s) * 1e9;
                let tex = textures.get(&ctx, "flim-lifetime", key, || {
                    lifetime_image(tau, w, h, m.lifetime_top_s)
                });
                let Picked { clicked, hover, .. } = pick(ui, &tex, w, h, small, "lifetime image");
                out.clicked = out.clicked.or(clicked);
                ColorBar {
                    of: "lifetime",
                    ramp: &colormap::turbo,
                    scale: BarScale::Linear {
                        lo: 0.0,
                        hi: top_ns.max(1e-6),
                    },
                    unit: "ns",
                    second: None,
                    note: "lifetime tau, 0 to the 99th percentile of the image's; black: \
                           no decay between the gates (M_0 <= M_1, or no light)",
                }
                .ui(ui, small.x);
                hover
            })
            .inner
        };
        let mut smalls = |ui: &mut egui::Ui| {
            let a = depth_block(ui, textures, out);
            let b = error_block(ui, textures, out);
            let c = lifetime_block(ui, textures, out);
            hovered = hovered.or(a).or(b).or(c);
        };
        if below {
            ui.horizontal_top(|ui| smalls(ui));
        } else {
            ui.vertical(|ui| smalls(ui));
        }
    };
    if below {
        ui.vertical(|ui| measurement(ui, &mut out));
    } else {
        ui.horizontal_top(|ui| measurement(ui, &mut out));
    }
    let text = match hovered {
        Some((x, y)) => readout(state, snap, plane, gate, x, y),
        None => "Hover a pixel to read its measurement".to_string(),
    };
    ui.add(egui::Label::new(RichText::new(text).monospace()).truncate());
    if let Some(m) = measured.filter(|_| current) {
        let tone = white.map_or(1.0, |v| 1.0 / v);
        let planes = |i: usize| m.m.plane(i);
        // The sensor is formatted once a frame, not once a thumbnail.
        let base = hash(&(snap.generation(), model.sensor(), white));
        let key = |i: usize| hash(&(base, i));
        if let Some(i) = gate_strip(
            ui,
            textures,
            (w, h),
            gates,
            gate,
            "gate",
            tone,
            &planes,
            &key,
        ) {
            *gate_sel = i;
        }
    }
    out
}

/// The height kept under the images for the strip of gate images ([`gate_strip`]) in a
/// panel `avail_h` points tall: a fifth of it, 90 to 160 points, when there are several
/// gates and the images keep at least 320 points.
fn strip_height(avail_h: f32, gates: usize) -> f32 {
    let strip = (0.2 * avail_h).clamp(90.0, 160.0);
    if gates >= 2 && avail_h - strip >= 320.0 {
        strip
    } else {
        0.0
    }
}

/// Texture names of the strip's thumbnails (one per slot).
const STRIP_NAMES: [&str; 16] = [
    "strip-0", "strip-1", "strip-2", "strip-3", "strip-4", "strip-5", "strip-6", "strip-7",
    "strip-8", "strip-9", "strip-10", "strip-11", "strip-12", "strip-13", "strip-14", "strip-15",
];

/// A row of small images of the gates (or TDC bins) around the one shown, in the space
/// left under the images, on one exposure (`tone`: 1 / white): the whole sequence read
/// at a glance, the shown one outlined; a click shows that one. The gate clicked.
#[allow(
    clippy::too_many_arguments,
    reason = "the sensor tab's state, one argument each; not yet a narrow context struct"
)]
fn gate_strip<'a>(
    ui: &mut egui::Ui,
    textures: &mut TextureCache<u64>,
    (w, h): (usize, usize),
    count: usize,
    shown: usize,
    what: &str,
    tone: f64,
    plane: &dyn Fn(usize) -> &'a [f32],
    key: &dyn Fn(usize) -> u64,
) -> Option<usize> {
    const MIN_THUMB: f32 = 40.0;
    const GAP: f32 = 6.0;
    let label_h = 20.0;
    let avail = ui.available_size();
    let aspect = w.max(1) as f32 / h.max(1) as f32;
    let thumb_h = (avail.y - label_h - 16.0).min(140.0);
    if count < 2 || thumb_h < MIN_THUMB {
        return None;
    }
    let thumb = Vec2::new(thumb_h * aspect, thumb_h);
    let fit = (((avail.x + GAP) / (thumb.x + GAP)) as usize).clamp(1, STRIP_NAMES.len());
    let n = fit.min(count);
    let first = shown.saturating_sub(n / 2).min(count - n);
    ui.add_space(8.0);
    ui.label(
        RichText::new(format!(
            "{what}s {first}..{} of {count}, one exposure; click one to show it",
            first + n - 1
        ))
        .weak(),
    );
    let ctx = ui.ctx().clone();
    let tone = Tone {
        scale: tone,
        log: false,
        decades: 3.0,
    };
    let mut clicked = None;
    ui.horizontal(|ui| {
        ui.spacing_mut().item_spacing.x = GAP;
        for (slot, i) in (first..first + n).enumerate() {
            let tex = textures.get(&ctx, STRIP_NAMES[slot], key(i), || {
                egui::ColorImage::from_rgba_unmultiplied(
                    [w, h],
                    &colormap::colorize(plane(i), &tone, ColorMap::Inferno),
                )
            });
            let r = ui
                .add(egui::Image::new((tex.id(), thumb)).sense(Sense::click()))
                .on_hover_text(format!("{what} {i}"));
            r.widget_info(|| {
                egui::WidgetInfo::labeled(egui::Role::Image, true, format!("{what} {i} thumbnail"))
            });
            if i == shown {
                ui.painter().rect_stroke(
                    r.rect.expand(2.0),
                    2.0,
                    egui::Stroke::new(2.0, ui.visuals().selection.bg_fill),
                    egui::StrokeKind::Outside,
                );
            }
            if r.clicked() {
                clicked = Some(i);
            }
        }
    });
    clicked
}

/// What the window says of pixel `(x, y)` in sensor mode: M_i with its unit, the depth,
/// multipath error and lifetime where shown.
fn readout(
    state: &SensorState,
    snap: &FilmSnapshot,
    plane: &[f32],
    gate: usize,
    x: usize,
    y: usize,
) -> String {
    let i = y * snap.width() + x;
    let mut s = format!(
        "row {y}, column {x} · M_{gate} = {}",
        axes::format_value(f64::from(plane.get(i).copied().unwrap_or(0.0)), BIN_UNIT)
    );
    // The depth images on screen are the latest full measurement's (a pass behind
    // while the renderer runs): read out what is shown.
    if let Some(m) = measured_of_film(state, snap) {
        if let Some(r) = &m.returns {
            s += &returns_readout(r, i);
        } else if let Some(d) = m.depth(Echo::First).and_then(|d| d.get(i)) {
            if d.is_finite() {
                s += &format!(" · depth {d:.3} m");
            } else {
                s += " · depth: no return";
            }
        }
        if let Some(e) = m.amcw_error_m.as_ref().and_then(|e| e.get(i))
            && e.is_finite()
        {
            s += &format!(" · multipath error {e:+.3} m");
        }
        if let Some(&tau) = m.flim_lifetime_s.as_ref().and_then(|t| t.get(i)) {
            if tau.is_finite() {
                s += &format!(" · lifetime {:.3} ns", f64::from(tau) * 1e9);
            } else {
                s += " · lifetime: no decay";
            }
        }
    }
    s
}

/// Pixel `i`'s returns in words: " · no return", " · return 3.120 m", or " · returns
/// 3.120 m (0.81), 5.600 m (0.19)" with each return's share of the pixel's kept
/// intensity, and how many more there are past the kept ones.
fn returns_readout(r: &ReturnImages, i: usize) -> String {
    let px = r.width * r.height;
    let Some(&count) = r.count.get(i) else {
        return String::new();
    };
    if count == 0 {
        return " · no return".into();
    }
    let kept: Vec<(f32, f32)> = (0..r.max_returns)
        .map(|k| (r.depth_m[k * px + i], r.intensity[k * px + i]))
        .filter(|(d, _)| d.is_finite())
        .collect();
    let total: f32 = kept.iter().map(|(_, e)| e).sum();
    let list: Vec<String> = kept
        .iter()
        .map(|(d, e)| match kept.len() {
            1 => format!("{d:.3} m"),
            _ => format!("{d:.3} m ({:.2})", e / total.max(f32::MIN_POSITIVE)),
        })
        .collect();
    let more = usize::from(count).saturating_sub(kept.len());
    let mut s = format!(
        " · {} {}",
        if count == 1 { "return" } else { "returns" },
        list.join(", ")
    );
    if more > 0 {
        s += &format!(" and {more} more");
    }
    s
}

/// The title of the LiDAR depth image: which return it shows, a choice of the first,
/// strongest and last, and the k-th of multi-echo.
fn echo_choice(ui: &mut egui::Ui, echo: &mut Echo, r: &ReturnImages) {
    let several = r.count.iter().filter(|&&c| c > 1).count();
    let mut choices = vec![Echo::First, Echo::Strongest, Echo::Last];
    choices.extend((1..r.max_returns).map(Echo::Nth));
    ui.horizontal_wrapped(|ui| {
        ui.spacing_mut().item_spacing.x = 4.0;
        ui.add(egui::Label::new(RichText::new("depth:").strong()))
            .on_hover_text(format!(
                "the depth of which of each pixel's returns the image shows; {several} \
                 pixels have more than one (multi-echo keeps up to {} each, earliest \
                 first)",
                r.max_returns
            ));
        for c in choices {
            ui.selectable_value(echo, c, c.label());
        }
    });
}

/// The latest measurement of all gates when it has the film's size: a pass behind
/// while the renderer runs, it is drawn until the next one comes; one of a film of
/// another resolution (a restart) is not (its images would not fit the film's).
fn measured_of_film<'a>(state: &'a SensorState, snap: &FilmSnapshot) -> Option<&'a Measured> {
    state
        .measured
        .as_ref()
        .filter(|m| (m.m.width, m.m.height) == (snap.width(), snap.height()))
}

/// Depth in turbo between `lo` and `hi`; no return is black.
fn depth_image(depth: &[f32], w: usize, h: usize, lo: f32, hi: f32) -> egui::ColorImage {
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    let px: Vec<u8> = depth
        .iter()
        .flat_map(|&d| {
            if d.is_finite() {
                let [r, g, b] = colormap::turbo(f64::from((d - lo) / span));
                [r, g, b, 255]
            } else {
                [0, 0, 0, 255]
            }
        })
        .collect();
    egui::ColorImage::from_rgba_unmultiplied([w, h], &px)
}

/// Lifetime (s) in turbo from 0 to `top_s`, saturating; no decay is black.
fn lifetime_image(tau_s: &[f32], w: usize, h: usize, top_s: f32) -> egui::ColorImage {
    depth_image(tau_s, w, h, 0.0, top_s)
}

/// Signed error, blue (too near) – white – red (too far), saturating at `a`.
fn error_image(err: &[f32], w: usize, h: usize, a: f32) -> egui::ColorImage {
    let a = a.max(f32::MIN_POSITIVE);
    let px: Vec<u8> = err
        .iter()
        .flat_map(|&e| {
            if e.is_finite() {
                let [r, g, b] =
                    colormap::diverging(f64::from(0.5 + 0.5 * (e / a).clamp(-1.0, 1.0)));
                [r, g, b, 255]
            } else {
                [0, 0, 0, 255]
            }
        })
        .collect();
    egui::ColorImage::from_rgba_unmultiplied([w, h], &px)
}

/// What [`pick`] saw: the pixel clicked, the one under the pointer, the image's
/// rectangle.
struct Picked {
    clicked: Option<(usize, usize)>,
    hover: Option<(usize, usize)>,
    rect: egui::Rect,
}

/// An image at `size` that reports the pixel clicked and the one under the pointer,
/// and its rectangle.
fn pick(
    ui: &mut egui::Ui,
    tex: &TextureHandle,
    w: usize,
    h: usize,
    size: Vec2,
    label: &str,
) -> Picked {
    let scale = size.x / w.max(1) as f32;
    let r = ui.add(egui::Image::new((tex.id(), size)).sense(Sense::click()));
    r.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, label));
    let to_pixel = |pos: egui::Pos2| {
        let p = (pos - r.rect.min) / scale;
        (
            (p.x.max(0.0) as usize).min(w.saturating_sub(1)),
            (p.y.max(0.0) as usize).min(h.saturating_sub(1)),
        )
    };
    crate::viewer::textures::shrunk_note_ui(ui, w, h);
    let clicked = r
        .interact_pointer_pos()
        .filter(|_| r.clicked())
        .map(to_pixel);
    Picked {
        clicked,
        hover: r.hover_pos().map(to_pixel),
        rect: r.rect,
    }
}

#[cfg(test)]
mod tests {
    use super::index_ranges;

    #[test]
    fn indices_read_as_ranges() {
        assert_eq!(index_ranges(&[4, 5, 6, 7]), "4–7");
        assert_eq!(index_ranges(&[0, 4, 5, 7]), "0, 4–5, 7");
        assert_eq!(index_ranges(&[]), "");
    }
}

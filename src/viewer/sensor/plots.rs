//! One pixel through the sensor (the paper's Figures 6 and 7): TPRF * Light over every
//! bin it reaches (past the window's ends too, where the pulse carries it), and M_i
//! against the gate i (click a point to show that gate; gates outside the window red).

use super::state::SensorState;
use super::view::{Coverage, coverage, main_span};
use super::{GATE_COLOR, LIGHT_COLOR, OUTSIDE_COLOR};
use crate::viewer::axes::BIN_UNIT;
use crate::viewer::plotting;
use eframe::egui::{self, Color32, RichText};
use egui_plot::{Line, Plot, PlotPoints, Points, Span, VLine};
use tprf_core::film::FilmSnapshot;
use tprf_core::sensor::spad::spad_pixel_ambient;

const COATES_COLOR: Color32 = Color32::from_rgb(0x7d, 0xe0, 0x7d);
const TRUTH_COLOR: Color32 = Color32::from_rgb(0xff, 0x6b, 0x9a);

/// Height of the last plot of the panel: down to `bottom` (the panel's lower edge, so
/// its axis label is not cut off), at least `min` points.
fn to_bottom(ui: &egui::Ui, bottom: f32, min: f32) -> f32 {
    (bottom - ui.cursor().top() - 8.0).max(min)
}

/// Figures 6 and 7 of the paper for one pixel: TPRF * Light on the bins (`height`
/// points tall), and M_i against i (click a point to show that gate) or a SPAD's
/// histograms, down to `bottom`.
#[allow(
    clippy::too_many_arguments,
    reason = "the sensor tab's state, one argument each; not yet a narrow context struct"
)]
pub(crate) fn pixel_plots_ui(
    ui: &mut egui::Ui,
    state: &mut SensorState,
    tprf: &[f32],
    m_pixel: &[f32],
    height: f32,
    bottom: f32,
    snap: &FilmSnapshot,
    pixel: (usize, usize),
) {
    let axis = snap.axis();
    let Some(model) = state.model() else {
        return;
    };
    let Some(trace) = state.pixel_trace(tprf) else {
        return;
    };
    let (k0, full) = model.tprf_light_full(tprf);
    ui.label(RichText::new(
        "(TPRF * Light)(t) of the pixel: what reaches the sensor, pulse included",
    ));
    let dt_ns = axis.dt_s * 1e9;
    let per_px = (full.len() as f64 / f64::from(ui.available_width().max(1.0))) as usize;
    let steps = plotting::steps(axis.t0_s * 1e9 + k0 as f64 * dt_ns, dt_ns, &full, per_px);
    let plot = Plot::new("sensor-tprf-light")
        .height(height)
        .allow_drag(false)
        .include_y(0.0);
    plotting::time_plot(plot, &format!("per bin ({BIN_UNIT})"), false).show(ui, |p| {
        p.span(
            Span::new("rendered window", axis.t0_s * 1e9..=axis.end_s() * 1e9)
                .fill(Color32::from_white_alpha(10)),
        );
        p.line(
            Line::new("TPRF * Light", PlotPoints::from(steps))
                .color(LIGHT_COLOR)
                .allow_band(false),
        )
    });
    if spad_plot_ui(
        ui,
        state,
        &trace.m_clean,
        tprf,
        (height, bottom),
        snap,
        pixel,
    ) {
        return;
    }
    let Some(model) = state.model() else {
        return;
    };
    ui.label(RichText::new(
        "M_i of the pixel (with noise once all gates are measured); click a gate",
    ));
    let m_clean: Vec<f32> = trace.m_clean.iter().map(|&v| v as f32).collect();
    let m_pixel = if m_pixel.is_empty() {
        &m_clean[..]
    } else {
        m_pixel
    };
    let pulse = main_span(model.light());
    let outside: Vec<bool> = model
        .gates()
        .iter()
        .map(|g| coverage(g, pulse, axis, state.auto_start) != Coverage::Inside)
        .collect();
    let pts: Vec<[f64; 2]> = m_pixel
        .iter()
        .enumerate()
        .map(|(i, &v)| [i as f64, v as f64])
        .collect();
    let (inside_pts, outside_pts): (Vec<[f64; 2]>, Vec<[f64; 2]>) = pts
        .iter()
        .partition(|p| !outside.get(p[0] as usize).copied().unwrap_or(false));
    let gate = state.gate;
    let plot = Plot::new("sensor-m")
        .height(to_bottom(ui, bottom, height))
        .allow_drag(false)
        .include_y(0.0);
    let r = plotting::value_plot(plot, "gate i", &format!("M_i ({BIN_UNIT})")).show(ui, |p| {
        p.line(Line::new("M_i", PlotPoints::from(pts.clone())).color(GATE_COLOR));
        p.points(
            Points::new("M_i", PlotPoints::from(inside_pts))
                .radius(2.5)
                .color(GATE_COLOR),
        );
        if !outside_pts.is_empty() {
            p.points(
                Points::new("outside the rendered window", PlotPoints::from(outside_pts))
                    .radius(3.5)
                    .shape(egui_plot::MarkerShape::Cross)
                    .color(OUTSIDE_COLOR),
            );
        }
        p.vline(VLine::new("gate shown", gate as f64).color(Color32::WHITE));
        p.pointer_coordinate()
    });
    if r.response.clicked()
        && let Some(p) = r.inner
        && p.x.is_finite()
    {
        state.gate = (p.x.round().max(0.0) as usize).min(m_pixel.len().saturating_sub(1));
    }
}

/// A curve over TDC bins as steps, time in ns.
fn bin_steps(centres_s: &[f64], width_s: f64, values: impl Iterator<Item = f64>) -> Vec<[f64; 2]> {
    centres_s
        .iter()
        .zip(values)
        .flat_map(|(&c, v)| {
            let v = if v.is_finite() { v } else { 0.0 };
            [
                [(c - 0.5 * width_s) * 1e9, v],
                [(c + 0.5 * width_s) * 1e9, v],
            ]
        })
        .collect()
}

/// The SPAD's histograms of the pixel (expected, Coates estimate of the realisation,
/// and the counts without pile-up `N r_k` and of the signal alone) over the TDC bins.
/// Returns whether it drew (the sensor has a SPAD and its histograms are current).
fn spad_plot_ui(
    ui: &mut egui::Ui,
    state: &mut SensorState,
    signal: &[f64],
    tprf: &[f32],
    (height, bottom): (f32, f32),
    snap: &FilmSnapshot,
    (y, x): (usize, usize),
) -> bool {
    let (Some(model), Some(shown)) = (state.model(), state.spad_shown(snap)) else {
        return false;
    };
    let (sp, img) = (shown.sp, &shown.sp.image);
    let signal: Vec<f32> = signal.iter().map(|&v| v as f32).collect();
    let steady: f64 = tprf.iter().map(|&v| f64::from(v)).sum();
    let ambient = state.ambient_at(y, x);
    let Ok(px) = spad_pixel_ambient(model, &signal, steady, ambient) else {
        return false;
    };
    // The current sensor's bins (a stale image may have others).
    let centres = &model.gate_centres_s().unwrap_or_default();
    let width_s = match centres[..] {
        [a, b, ..] => b - a,
        _ => 0.0,
    };
    // A preview holds a coarse grid, and stale histograms another sensor's: the pixel's
    // expected histogram is the one computed here for it, and its realisation is not
    // drawn yet.
    let (expected, coates, counts) = if sp.is_preview() || !shown.current {
        let e: Vec<f32> = px.expected.iter().map(|&v| v as f32).collect();
        (e, Vec::new(), Vec::new())
    } else {
        (
            img.pixel(&img.histogram, y, x),
            img.pixel(&img.coates, y, x),
            img.pixel(&img.counts, y, x),
        )
    };
    let curve = |v: &[f32]| bin_steps(centres, width_s, v.iter().map(|&v| f64::from(v)));
    let shown = centres.get(state.gate).copied();
    let spad = model.sensor().spad.as_ref();
    let cycle_s = width_s * centres.len() as f64;
    // Early light (a fog's backscatter) takes the detections of later light (the target
    // behind it) only within a dead time of each detection: say so when it is short.
    let dead = spad
        .filter(|s| s.dead_time_s < 0.5 * cycle_s)
        .map_or(String::new(), |s| {
            format!(
                ". Each detection blinds the pixel for its dead time ({}): early light \
                 (fog) steals only the detections within it; a dead time of one cycle \
                 (first photon) lets it steal the target's",
                tprf_core::units::format_time(s.dead_time_s)
            )
        });
    // The title on one line; what the curves are, in its tooltip (four lines of text
    // left the histogram below the fold at 1024 x 700).
    let cycles = spad.map_or(0, |s| s.cycles);
    ui.add(
        egui::Label::new(format!(
            "SPAD histogram of pixel (row {y}, column {x}), {cycles} cycles"
        ))
        .truncate(),
    )
    .on_hover_text(format!(
        "Over {cycles} cycles: expected (piled up), one realisation, its Coates estimate, and \
         N r_k without pile-up{dead}"
    ));
    // Head room above the highest curve for the legend, which would hide the peak.
    let top = [&counts[..], &expected[..], &coates[..]]
        .into_iter()
        .flatten()
        .map(|&v| f64::from(v))
        .chain(px.unpiled.iter().chain(&px.signal).copied())
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    // At least 220 points (the panel scrolls): its legend of six curves covers ~110.
    let plot = Plot::new("sensor-spad")
        .height(to_bottom(ui, bottom, height.max(220.0)))
        .allow_drag(false)
        .include_y(0.0)
        .include_y(1.7 * top)
        .legend(
            egui_plot::Legend::default()
                .position(egui_plot::Corner::RightTop)
                .background_alpha(0.6),
        );
    let r = plotting::value_plot(plot, "TDC time (ns)", "counts per bin").show(ui, |p| {
        let realisation = if sp.is_sampled() {
            "realisation"
        } else {
            "realisation (sampling…)"
        };
        p.line(
            Line::new(realisation, PlotPoints::from(curve(&counts)))
                .color(Color32::from_gray(0x80)),
        );
        p.line(
            Line::new("expected histogram", PlotPoints::from(curve(&expected))).color(GATE_COLOR),
        );
        p.line(Line::new("Coates estimate", PlotPoints::from(curve(&coates))).color(COATES_COLOR));
        p.line(
            Line::new(
                "N r_k (no pile-up)",
                PlotPoints::from(bin_steps(centres, width_s, px.unpiled.iter().copied())),
            )
            .color(TRUTH_COLOR),
        );
        p.line(
            Line::new(
                "TPRF * Light detected",
                PlotPoints::from(bin_steps(centres, width_s, px.signal.iter().copied())),
            )
            .color(LIGHT_COLOR),
        );
        if let Some(c) = shown {
            p.vline(VLine::new("bin shown", c * 1e9).color(Color32::from_rgb(0xff, 0x9f, 0x43)));
        }
        p.pointer_coordinate()
    });
    if r.response.clicked()
        && let Some(p) = r.inner
        && p.x.is_finite()
        && width_s > 0.0
        && let Some(&c0) = centres.first()
    {
        let k = ((p.x * 1e-9 - c0) / width_s).round().max(0.0) as usize;
        state.gate = k.min(centres.len().saturating_sub(1));
    }
    true
}

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
use tprf_core::film::TimeAxis;

/// Figures 6 and 7 of the paper for one pixel: TPRF * Light on the bins, and M_i
/// against i (click a point to show that gate).
pub(crate) fn pixel_plots_ui(
    ui: &mut egui::Ui,
    state: &mut SensorState,
    tprf: &[f32],
    m_pixel: &[f32],
    axis: &TimeAxis,
    height: f32,
) {
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
    let steps: Vec<[f64; 2]> = full
        .iter()
        .enumerate()
        .flat_map(|(j, &v)| {
            let t = axis.t0_s * 1e9 + (k0 + j as i64) as f64 * dt_ns;
            [[t, v], [t + dt_ns, v]]
        })
        .collect();
    let plot = Plot::new("sensor-tprf-light")
        .height(height)
        .allow_drag(false)
        .include_y(0.0);
    plotting::time_plot(plot, &format!("per bin ({BIN_UNIT})"), false).show(ui, |p| {
        p.span(
            Span::new("rendered window", axis.t0_s * 1e9..=axis.end_s() * 1e9)
                .fill(Color32::from_white_alpha(10)),
        );
        p.line(Line::new("TPRF * Light", PlotPoints::from(steps)).color(LIGHT_COLOR))
    });
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
        .height(height)
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

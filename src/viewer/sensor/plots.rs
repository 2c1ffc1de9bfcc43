//! One pixel through the sensor (the paper's Figures 6 and 7): TPRF * Light on the
//! bins, and M_i against the gate i (click a point to show that gate).

use super::state::SensorState;
use super::{GATE_COLOR, LIGHT_COLOR};
use eframe::egui::{self, Color32, RichText};
use egui_plot::{Line, Plot, PlotPoints, Points, VLine};
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
    let Some(trace) = state.pixel_trace(tprf) else {
        return;
    };
    ui.label(RichText::new("(TPRF * Light)(t) of the pixel").small());
    let steps: Vec<[f64; 2]> = trace
        .tprf_light
        .iter()
        .enumerate()
        .flat_map(|(b, &v)| {
            [
                [axis.bin_start_s(b) * 1e9, v],
                [(axis.bin_start_s(b) + axis.dt_s) * 1e9, v],
            ]
        })
        .collect();
    Plot::new("sensor-tprf-light")
        .height(height)
        .allow_drag(false)
        .x_axis_label("arrival time (ns)")
        .show(ui, |p| {
            p.line(Line::new("TPRF * Light", PlotPoints::from(steps)).color(LIGHT_COLOR))
        });
    ui.label(
        RichText::new("M_i of the pixel (with noise once all gates are measured); click a gate")
            .small(),
    );
    let m_clean: Vec<f32> = trace.m_clean.iter().map(|&v| v as f32).collect();
    let m_pixel = if m_pixel.is_empty() {
        &m_clean[..]
    } else {
        m_pixel
    };
    let pts: Vec<[f64; 2]> = m_pixel
        .iter()
        .enumerate()
        .map(|(i, &v)| [i as f64, v as f64])
        .collect();
    let gate = state.gate;
    let r = Plot::new("sensor-m")
        .height(height)
        .allow_drag(false)
        .x_axis_label("gate i")
        .show(ui, |p| {
            p.line(Line::new("M_i", PlotPoints::from(pts.clone())).color(GATE_COLOR));
            p.points(
                Points::new("", PlotPoints::from(pts))
                    .radius(2.0)
                    .color(GATE_COLOR),
            );
            p.vline(
                VLine::new("gate shown", gate as f64).color(Color32::from_rgb(0xff, 0x9f, 0x43)),
            );
            p.pointer_coordinate()
        });
    if r.response.clicked()
        && let Some(p) = r.inner
        && p.x.is_finite()
    {
        state.gate = (p.x.round().max(0.0) as usize).min(m_pixel.len().saturating_sub(1));
    }
}

//! The envelope editor: Light(t) and every Exposure_i(t) on one time axis over the
//! selected pixel's TPRF, with handles to drag (their maths in `handles`).

use super::handles::{Handle, drag_handle, handles};
use super::state::SensorState;
use super::{GATE_COLOR, LIGHT_COLOR, TPRF_COLOR, gate_time_label};
use eframe::egui::{self, Color32, RichText};
use egui_plot::{Line, Plot, PlotPoint, PlotPoints, Points, VLine};
use tprf_core::film::TimeAxis;
use tprf_core::sensor::Sensor;

/// The envelope editor: Light(t) and every Exposure_i(t) on one time axis with the
/// pixel's TPRF behind them, each scaled to its own peak; drag the handles.
pub(crate) fn editor_ui(
    ui: &mut egui::Ui,
    state: &mut SensorState,
    sensor: &mut Sensor,
    tprf: &[f32],
    axis: &TimeAxis,
    height: f32,
) {
    let Some(model) = state.model() else {
        return;
    };
    let (lo, hi) = model.time_span_s();
    let n = 600;
    let ts: Vec<f64> = (0..=n)
        .map(|k| lo + (hi - lo) * k as f64 / n as f64)
        .collect();
    let norm = |v: Vec<f64>| -> Vec<f64> {
        let m = v.iter().fold(0.0f64, |m, &x| m.max(x));
        if m > 0.0 {
            v.into_iter().map(|x| x / m).collect()
        } else {
            v
        }
    };
    let light = norm(model.light_curve(&ts));
    let delta = model.light().delta_time_s();
    let gates = model.gate_count();
    // Every gate, faint, when there are not too many; the selected one bright.
    let shown: Vec<usize> = if gates <= 64 {
        (0..gates).collect()
    } else {
        vec![]
    };
    let gate_curves: Vec<(usize, Vec<f64>)> = shown
        .iter()
        .map(|&i| (i, model.exposure_curve(i, &ts)))
        .collect();
    let sel = model.exposure_curve(state.gate, &ts);
    let gate_peak = gate_curves
        .iter()
        .flat_map(|c| c.1.iter())
        .chain(&sel)
        .fold(0.0f64, |m, &x| m.max(x))
        .max(1e-300);
    let tprf_max = tprf
        .iter()
        .fold(0.0f32, |m, &x| m.max(x))
        .max(f32::MIN_POSITIVE) as f64;
    let tprf_steps: Vec<[f64; 2]> = tprf
        .iter()
        .enumerate()
        .flat_map(|(b, &v)| {
            let y = v as f64 / tprf_max;
            [
                [axis.bin_start_s(b) * 1e9, y],
                [(axis.bin_start_s(b) + axis.dt_s) * 1e9, y],
            ]
        })
        .collect();
    let hs = handles(sensor, axis);
    let gate_label = gate_time_label(model, state.gate);
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new("— Light").color(LIGHT_COLOR).small());
        ui.label(
            RichText::new(format!("— Exposure_{} {gate_label}", state.gate))
                .color(GATE_COLOR)
                .small(),
        );
        ui.label(RichText::new("■ TPRF").color(TPRF_COLOR).small());
        ui.label(RichText::new("white dots: drag").small());
    });
    let response = Plot::new("sensor-editor")
        .height(height)
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .include_y(0.0)
        .include_y(1.05)
        .x_axis_label("time after the trigger (ns)")
        .y_axis_label("each scaled to its peak")
        .show(ui, |p| {
            p.line(
                Line::new("TPRF (pixel)", PlotPoints::from(tprf_steps))
                    .color(TPRF_COLOR)
                    .fill(0.0)
                    .fill_alpha(0.35),
            );
            for (i, c) in &gate_curves {
                if *i != state.gate {
                    let pts: Vec<[f64; 2]> = ts
                        .iter()
                        .zip(c)
                        .map(|(t, v)| [t * 1e9, v / gate_peak])
                        .collect();
                    p.line(
                        Line::new("Exposure_i", PlotPoints::from(pts))
                            .color(GATE_COLOR.gamma_multiply(0.25)),
                    );
                }
            }
            let pts: Vec<[f64; 2]> = ts
                .iter()
                .zip(&sel)
                .map(|(t, v)| [t * 1e9, v / gate_peak])
                .collect();
            p.line(
                Line::new(
                    format!("Exposure_{} {gate_label}", state.gate),
                    PlotPoints::from(pts),
                )
                .color(GATE_COLOR)
                .width(2.0),
            );
            match delta {
                Some(t) => p.vline(
                    VLine::new("Light (delta)", t * 1e9)
                        .color(LIGHT_COLOR)
                        .width(2.0),
                ),
                None => {
                    let pts: Vec<[f64; 2]> =
                        ts.iter().zip(&light).map(|(t, v)| [t * 1e9, *v]).collect();
                    p.line(
                        Line::new("Light", PlotPoints::from(pts))
                            .color(LIGHT_COLOR)
                            .width(2.0),
                    );
                }
            }
            let pts: Vec<[f64; 2]> = hs.iter().map(|h| [h.t_s * 1e9, h.y]).collect();
            p.points(
                Points::new("handles", PlotPoints::from(pts))
                    .radius(5.0)
                    .color(Color32::WHITE),
            );
            let screen: Vec<(Handle, egui::Pos2)> = hs
                .iter()
                .map(|h| {
                    (
                        h.handle,
                        p.screen_from_plot(PlotPoint::new(h.t_s * 1e9, h.y)),
                    )
                })
                .collect();
            (screen, p.pointer_coordinate())
        });
    let (screen, pointer) = response.inner;
    let r = &response.response;
    if r.drag_started()
        && let Some(pos) = r.interact_pointer_pos()
    {
        state.drag = screen
            .iter()
            .map(|(h, p)| (*h, p.distance(pos)))
            .filter(|(_, d)| *d < 12.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(h, _)| h);
    }
    if r.dragged()
        && let (Some(h), Some(p)) = (state.drag, pointer)
    {
        drag_handle(sensor, h, p.x * 1e-9, p.y, axis);
    }
    if r.drag_stopped() {
        state.drag = None;
    }
    if let Some(pos) = r.hover_pos()
        && screen.iter().any(|(_, p)| p.distance(pos) < 12.0)
    {
        ui.ctx().set_cursor_icon(egui::CursorIcon::Grab);
    }
    r.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Figure, true, "envelope editor"));
}

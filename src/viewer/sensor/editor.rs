//! The envelope editor: Light(t) and every Exposure_i(t) on one time axis over the
//! selected pixel's TPRF, with handles to drag (their maths in `handles`). It opens on
//! the film's window and the pulse ([`TimeView::fit`]); the scroll wheel zooms about
//! the pointer, dragging empty space pans, a double click fits again. Shift while
//! dragging a handle moves it a tenth as far. Time the film does not cover is shaded
//! and gates that need it are drawn red.

use super::handles::{Handle, drag_handle, handles};
use super::state::SensorState;
use super::view::{Coverage, TimeView, coverage, declutter, main_span};
use super::{GATE_COLOR, LIGHT_COLOR, OUTSIDE_COLOR, TPRF_COLOR, gate_time_label};
use crate::viewer::plotting;
use eframe::egui::{self, Color32, RichText};
use egui_plot::{Line, Plot, PlotPoint, PlotPoints, Points, Span, VLine};
use tprf_core::film::TimeAxis;
use tprf_core::sensor::Sensor;

/// Handles closer than this on screen are moved apart, points.
const HANDLE_GAP_PX: f32 = 13.0;
/// A press this near a handle grabs it, points.
const GRAB_PX: f32 = 10.0;
/// Shift-drag moves a handle this share of the pointer's movement.
const FINE: f64 = 0.1;

/// Most gates drawn one by one in the editor; more are drawn as one band.
const MAX_GATES_DRAWN: usize = 8;

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
    let pulse = main_span(model.light());
    let view = state.view.unwrap_or_else(|| TimeView::fit(axis, pulse));
    let (lo, hi) = (view.lo_s, view.hi_s);
    let n = 800;
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
    // The gates in view, faint (at most 64); the selected one bright. Red where the
    // film lacks light they need.
    let in_view: Vec<usize> = model
        .gates()
        .iter()
        .enumerate()
        .filter(|(_, g)| g.support_s().is_none_or(|(a, b)| b >= lo && a <= hi))
        .map(|(i, _)| i)
        .take(64)
        .collect();
    let gate_curves: Vec<(usize, Vec<f64>, Coverage)> = in_view
        .iter()
        .map(|&i| {
            let cov = model.gates().get(i).map_or(Coverage::Inside, |g| {
                coverage(g, pulse, axis, state.auto_start)
            });
            (i, model.exposure_curve(i, &ts), cov)
        })
        .collect();
    let sel = model.exposure_curve(state.gate, &ts);
    let sel_cov = model.gates().get(state.gate).map_or(Coverage::Inside, |g| {
        coverage(g, pulse, axis, state.auto_start)
    });
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
    // Bins of the view sharing a screen column: the TPRF drawn with only what shows.
    let per_px = ((hi - lo) / axis.dt_s / f64::from(ui.available_width().max(1.0))) as usize;
    let ys: Vec<f64> = tprf.iter().map(|&v| v as f64 / tprf_max).collect();
    let tprf_steps = plotting::steps(axis.t0_s * 1e9, axis.dt_s * 1e9, &ys, per_px);
    let hs = handles(sensor, axis);
    let gate_label = gate_time_label(model, state.gate);
    let sel_color = if sel_cov == Coverage::Inside {
        GATE_COLOR
    } else {
        OUTSIDE_COLOR
    };
    // Each entry whole: one that does not fit goes to the next line.
    ui.horizontal_wrapped(|ui| {
        for (text, color) in [
            ("— Light".to_string(), LIGHT_COLOR),
            (format!("— Exposure_{} {gate_label}", state.gate), sel_color),
            ("■ TPRF".to_string(), TPRF_COLOR),
            ("▨ not rendered".to_string(), OUTSIDE_COLOR),
        ] {
            ui.add(
                egui::Label::new(RichText::new(text).color(color))
                    .wrap_mode(egui::TextWrapMode::Extend),
            );
        }
    });
    ui.label(
        RichText::new("Drag the dots (Shift: fine) · scroll: zoom · drag: pan · double-click: fit")
            .weak(),
    );
    let plot = Plot::new("sensor-editor")
        .height(height)
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .allow_double_click_reset(false)
        .allow_boxed_zoom(false)
        .show_x(false)
        .show_y(false);
    let plot = plotting::time_plot(plot, "each scaled to its peak", false);
    let response = plot.show(ui, |p| {
        p.set_plot_bounds_x(lo * 1e9..=hi * 1e9);
        p.set_plot_bounds_y(-0.06..=1.12);
        let (w0, w1) = (axis.t0_s * 1e9, axis.end_s() * 1e9);
        // Unnamed: the legend above names them (a name inside a narrow span was cut
        // to "not r…").
        let shade = OUTSIDE_COLOR.gamma_multiply(0.18);
        if lo * 1e9 < w0 {
            p.span(Span::new("", (lo * 1e9).min(w0)..=w0).fill(shade));
        }
        if hi * 1e9 > w1 {
            p.span(Span::new("", w1..=(hi * 1e9).max(w1)).fill(shade));
        }
        p.line(
            Line::new("TPRF (pixel)", PlotPoints::from(tprf_steps))
                .color(TPRF_COLOR)
                .allow_band(false)
                .fill(0.0)
                .fill_alpha(0.35),
        );
        // Many gates (a digitiser's boxes, a TDC's bins) as one band: where any other
        // gate is open, its height the largest of them; a few (AMCW phases) one by one.
        if gate_curves.len() > MAX_GATES_DRAWN {
            let mut env = vec![0.0f64; ts.len()];
            for (i, c, _) in &gate_curves {
                if *i != state.gate {
                    for (e, v) in env.iter_mut().zip(c) {
                        *e = e.max(*v / gate_peak);
                    }
                }
            }
            let pts: Vec<[f64; 2]> = ts.iter().zip(&env).map(|(t, v)| [t * 1e9, *v]).collect();
            p.line(
                Line::new(
                    format!("the other {} gates", gate_curves.len() - 1),
                    PlotPoints::from(pts),
                )
                .color(GATE_COLOR.gamma_multiply(0.45))
                .fill(0.0)
                .fill_alpha(0.12),
            );
        }
        for (i, c, cov) in gate_curves
            .iter()
            .filter(|_| gate_curves.len() <= MAX_GATES_DRAWN)
        {
            if *i != state.gate {
                let pts: Vec<[f64; 2]> = ts
                    .iter()
                    .zip(c)
                    .map(|(t, v)| [t * 1e9, v / gate_peak])
                    .collect();
                let color = if *cov == Coverage::Inside {
                    GATE_COLOR
                } else {
                    OUTSIDE_COLOR
                };
                p.line(
                    Line::new("Exposure_i", PlotPoints::from(pts)).color(color.gamma_multiply(0.3)),
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
            .color(sel_color)
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
        // Handles where they are, then moved apart on screen so none hides another.
        let mut screen: Vec<(f32, f32)> = hs
            .iter()
            .map(|h| {
                let s = p.screen_from_plot(PlotPoint::new(h.t_s * 1e9, h.y));
                (s.x, s.y)
            })
            .collect();
        declutter(&mut screen, HANDLE_GAP_PX);
        let drawn: Vec<(Handle, egui::Pos2)> = hs
            .iter()
            .zip(&screen)
            .map(|(h, s)| (h.handle, egui::pos2(s.0, s.1)))
            .collect();
        let pts: Vec<[f64; 2]> = drawn
            .iter()
            .map(|(_, s)| {
                let v = p.plot_from_screen(*s);
                [v.x, v.y]
            })
            .collect();
        p.points(
            Points::new("handles", PlotPoints::from(pts))
                .radius(5.0)
                .color(Color32::WHITE),
        );
        drawn
    });
    let drawn = response.inner;
    state.view.get_or_insert(view);
    let r = &response.response;
    // Seconds per screen point along x.
    let s_per_px = response.transform.dvalue_dpos()[0] * 1e-9;
    let y_per_px = response.transform.dvalue_dpos()[1];
    let near = |pos: egui::Pos2| {
        drawn
            .iter()
            .map(|(h, p)| (*h, p.distance(pos)))
            .filter(|(_, d)| *d < GRAB_PX)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(h, _)| h)
    };
    if r.drag_started() {
        state.drag = r.interact_pointer_pos().and_then(near);
    }
    let fine = ui.input(|i| i.modifiers.shift);
    if r.dragged() {
        let d = r.drag_delta();
        let k = if fine { FINE } else { 1.0 };
        match state.drag {
            // The handle moves by the pointer's movement (a tenth with Shift).
            Some(h) => {
                if let Some(now) = handles(sensor, axis).into_iter().find(|p| p.handle == h) {
                    let t = now.t_s + f64::from(d.x) * s_per_px * k;
                    let y = now.y + f64::from(d.y) * y_per_px * k;
                    drag_handle(sensor, h, t, y, axis);
                }
            }
            // Empty space: pan.
            None => state.view = Some(view.panned(-f64::from(d.x) * s_per_px)),
        }
    }
    if r.drag_stopped() {
        state.drag = None;
    }
    if r.double_clicked() {
        state.view = Some(TimeView::fit(axis, pulse));
    }
    let hover = r.hover_pos();
    if r.hovered() {
        let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta, i.zoom_delta()));
        let about_s = hover.map_or(0.5 * (lo + hi), |p| {
            response.transform.value_from_position(p).x * 1e-9
        });
        let mut v = state.view.unwrap_or(view);
        if scroll.y != 0.0 {
            v = v.zoomed(about_s, (-f64::from(scroll.y) * 0.003).exp());
        }
        if zoom != 1.0 {
            v = v.zoomed(about_s, 1.0 / f64::from(zoom));
        }
        if scroll.x != 0.0 {
            v = v.panned(-f64::from(scroll.x) * s_per_px);
        }
        if scroll != egui::Vec2::ZERO {
            // Taken here: the panel's scroll area does not scroll as well.
            ui.input_mut(|i| i.smooth_scroll_delta = egui::Vec2::ZERO);
        }
        state.view = Some(v);
    }
    if let Some(h) = hover.and_then(near).or(state.drag) {
        ui.ctx().set_cursor_icon(if state.drag.is_some() {
            egui::CursorIcon::Grabbing
        } else {
            egui::CursorIcon::Grab
        });
        let text = format!(
            "{} — drag; hold Shift for fine steps",
            h.describe(sensor, axis)
        );
        r.clone().on_hover_text_at_pointer(text);
    }
    r.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Figure, true, "envelope editor"));
}

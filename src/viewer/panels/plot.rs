//! The right panel: in transient mode the TPRF plot of the selection, its per-bounce
//! curves and the pins (drag on it to scrub); in sensor mode the envelope editor and the
//! selected pixel's TPRF * Light and M_i.

use super::{BOUNCE_COLORS, PIN_COLORS, SCRUBBER_COLOR};
use crate::viewer::app::TprfApp;
use crate::viewer::axes::{self, BIN_UNIT};
use crate::viewer::files::FileAction;
use crate::viewer::plotting;
use crate::viewer::selection::Selection;
use crate::viewer::sensor;
use eframe::egui::{self, Color32, RichText};
use egui_plot::{Legend, Line, Plot, PlotPoints, VLine};
use tprf_core::film::{FilmSnapshot, TimeAxis};
use tprf_core::units::C_M_PER_S;

/// Layers a film needs for the per-bounce curves: direct, 1, 2, 3, more than 3.
const BOUNCE_LAYERS: usize = 5;

impl TprfApp {
    /// The curves the TPRF plot shows: (name, colour, values per bin).
    pub fn plotted_curves(&self, snap: &FilmSnapshot) -> Vec<(String, Color32, Vec<f64>)> {
        let mut curves = Vec::new();
        if let Some(sel) = &self.selection {
            curves.push((sel.label(), PIN_COLORS[0], sel.tprf(snap, None)));
            if snap.layers() >= BOUNCE_LAYERS {
                // Layers: 0 direct, 1, 2, 3, 4 = more than 3.
                for (k, show) in self.settings.show_bounces.iter().enumerate() {
                    if *show {
                        let name = if k == 3 {
                            ">3 bounces".to_string()
                        } else {
                            format!("{} bounce{}", k + 1, if k == 0 { "" } else { "s" })
                        };
                        curves.push((name, BOUNCE_COLORS[k], sel.tprf(snap, Some(k + 1))));
                    }
                }
            }
        }
        for (i, p) in self.pins.iter().enumerate() {
            curves.push((
                format!("pin: {}", p.label()),
                PIN_COLORS[(i + 1) % PIN_COLORS.len()],
                p.tprf(snap, None),
            ));
        }
        curves
    }

    /// The TPRF plot with its options, pin and CSV buttons, then the error plot.
    pub(crate) fn plot_ui(&mut self, ui: &mut egui::Ui, snap: &FilmSnapshot) {
        ui.heading("TPRF");
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut self.settings.plot_log, "log");
            // Bounce curves only where the film has the layers.
            if snap.layers() >= BOUNCE_LAYERS {
                ui.label("bounces:");
                for (k, name) in ["1", "2", "3", ">3"].iter().enumerate() {
                    ui.checkbox(
                        &mut self.settings.show_bounces[k],
                        RichText::new(*name).color(BOUNCE_COLORS[k]),
                    );
                }
            } else {
                ui.label(RichText::new("no bounce layers in this film").weak());
            }
        });
        ui.horizontal(|ui| {
            if ui
                .add_enabled(self.selection.is_some(), egui::Button::new("📌 Pin"))
                .clicked()
                && let Some(s) = self.selection
                && !self.pins.contains(&s)
            {
                self.pins.push(s);
            }
            if ui
                .add_enabled(!self.pins.is_empty(), egui::Button::new("Clear pins"))
                .clicked()
            {
                self.pins.clear();
            }
            if ui
                .add_enabled(
                    self.selection.is_some() || !self.pins.is_empty(),
                    egui::Button::new("Export CSV…"),
                )
                .clicked()
            {
                self.choose_file(FileAction::SaveCsv);
            }
        });
        if self.selection.is_none() && self.pins.is_empty() {
            ui.label(
                RichText::new("Click a pixel (or drag a box) on an image to plot its TPRF.").weak(),
            );
        }
        let axis = *snap.axis();
        let log = self.settings.plot_log;
        let curves = self.plotted_curves(snap);
        let bin_now = self.bin;
        // On the log scale an empty bin is drawn at 1e-6 of the largest value.
        let log_floor = log.then(|| {
            let max = curves
                .iter()
                .flat_map(|c| c.2.iter())
                .fold(0.0f64, |m, &v| m.max(v));
            if max > 0.0 { max * 1e-6 } else { 1e-30 }
        });
        let plot_h = (ui.available_height() - 150.0).max(160.0);
        let y_label = if log {
            format!("radiance per bin, log ({BIN_UNIT})")
        } else {
            format!("radiance per bin ({BIN_UNIT})")
        };
        let plot = Plot::new("tprf-plot")
            .height(plot_h)
            .legend(Legend::default())
            .allow_drag(false)
            .label_formatter(move |hover| {
                let (name, pos) = match hover {
                    egui_plot::HoverPosition::NearDataPoint {
                        plot_name,
                        position,
                        ..
                    } => (*plot_name, *position),
                    egui_plot::HoverPosition::Elsewhere { position } => ("", *position),
                };
                let t_ns = pos.x;
                let v = if log { 10f64.powf(pos.y) } else { pos.y };
                Some(format!(
                    "{name}\n{t_ns:.3} ns · {:.3} m\n{}",
                    t_ns * 1e-9 * C_M_PER_S,
                    axes::format_value(v, BIN_UNIT)
                ))
            })
            .include_x(axis.t0_s * 1e9)
            .include_x(axis.end_s() * 1e9);
        let width_px = ui.available_width();
        let response = plotting::time_plot(plot, &y_label, log).show(ui, |plot_ui| {
            for (name, color, values) in &curves {
                let bounce = BOUNCE_COLORS.contains(color);
                let pts = step_points(&axis, values, log_floor, width_px);
                let line = Line::new(name.clone(), pts).color(*color).allow_band(false);
                plot_ui.line(if bounce {
                    line.style(egui_plot::LineStyle::dashed_dense()).width(1.2)
                } else {
                    line.width(1.8)
                });
            }
            plot_ui.vline(
                VLine::new("scrubber", axis.bin_center_s(bin_now) * 1e9)
                    .color(SCRUBBER_COLOR)
                    .style(egui_plot::LineStyle::dotted_loose()),
            );
            plot_ui.pointer_coordinate()
        });
        // Drag on the plot moves the scrubber.
        if (response.response.dragged() || response.response.clicked())
            && let Some(p) = response.inner
        {
            let b = ((p.x * 1e-9 - axis.t0_s) / axis.dt_s).floor();
            if b.is_finite() {
                self.bin = (b.max(0.0) as usize).min(axis.bins.saturating_sub(1));
                self.playing = false;
            }
        }
        response
            .response
            .widget_info(|| egui::WidgetInfo::labeled(egui::Role::Figure, true, "tprf plot"));
        self.error_plot_ui(ui);
    }

    /// Sensor mode's right panel: the envelope editor over the selected pixel's TPRF,
    /// then that pixel's TPRF * Light and M_i (the paper's Figures 5-7).
    pub(crate) fn sensor_plots_ui(&mut self, ui: &mut egui::Ui, snap: &FilmSnapshot) {
        let sel = self.selection.unwrap_or(Selection::pixel(0, 0));
        ui.heading(format!("Sensor · {}", sel.label()));
        let tprf: Vec<f32> = sel.tprf(snap, None).into_iter().map(|v| v as f32).collect();
        // With noise once all gates are measured; until then the clean values.
        let m_pixel = match self.sensor.measurements() {
            Some(m) if self.sensor.is_current(snap) => m.pixel(sel.y0, sel.x0),
            _ => Vec::new(),
        };
        let h = ui.available_height();
        let axis = *snap.axis();
        // Scrolls when the window is too short for the three plots.
        egui::ScrollArea::vertical().show(ui, |ui| {
            sensor::editor_ui(
                ui,
                &mut self.sensor,
                &mut self.settings.sensor,
                &tprf,
                &axis,
                (h * 0.36).max(170.0),
            );
            sensor::pixel_plots_ui(
                ui,
                &mut self.sensor,
                &tprf,
                &m_pixel,
                (h * 0.19).max(110.0),
                snap,
                (sel.y0, sel.x0),
            );
        });
    }
}

/// A binned curve as steps: each bin a flat segment over its time span (ns), because a
/// bin holds the integral over its interval, not a point sample. With `log_floor`, the
/// values are log10 and empty bins sit at the floor. Drawn with only the points that
/// show ([`plotting::steps`]) on a plot `width_px` points wide.
fn step_points(
    axis: &TimeAxis,
    values: &[f64],
    log_floor: Option<f64>,
    width_px: f32,
) -> PlotPoints<'static> {
    let ys: Vec<f64> = values
        .iter()
        .map(|&v| match log_floor {
            Some(floor) => v.max(floor).log10(),
            None => v,
        })
        .collect();
    let per_px = (values.len() as f64 / f64::from(width_px.max(1.0))).floor() as usize;
    let pts = plotting::steps(axis.t0_s * 1e9, axis.dt_s * 1e9, &ys, per_px);
    PlotPoints::from(pts)
}

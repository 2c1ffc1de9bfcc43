//! The right panel: in transient mode the TPRF plot of the selection, its per-bounce
//! curves and the pins (drag on it to scrub); in sensor mode the envelope editor and the
//! selected pixel's TPRF * Light and M_i.

use super::{PIN_COLORS, SCRUBBER_COLOR, bounce_color};
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

/// One curve of the TPRF plot: its legend name, colour, value per bin, and whether it
/// is a bounce layer's (drawn dashed, thinner).
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    pub name: String,
    pub color: Color32,
    pub values: Vec<f64>,
    pub dashed: bool,
}

/// The name of layer `l` of a film with `layers` of them and its luminescence layer at
/// `luminescence` ([`FilmLayout`]: layer 0 the emitter seen directly, `1..=K` that many
/// scattering events, `K + 1` more than `K`, then the light re-emitted by luminescent
/// surfaces when the film keeps it apart), long (a legend's) or short (a checkbox's).
///
/// [`FilmLayout`]: tprf_core::film::FilmLayout
pub fn bounce_layer_name(
    l: usize,
    layers: usize,
    luminescence: Option<usize>,
    long: bool,
) -> String {
    if Some(l) == luminescence {
        return if long {
            "re-emitted (luminescence)"
        } else {
            "re-emitted"
        }
        .into();
    }
    let k = (layers - usize::from(luminescence.is_some())).saturating_sub(2);
    match (l, long) {
        (0, true) => "direct (0 bounces)".into(),
        (0, false) => "direct".into(),
        (l, true) if l > k => format!(">{k} bounces"),
        (l, false) if l > k => format!(">{k}"),
        (1, true) => "1 bounce".into(),
        (l, true) => format!("{l} bounces"),
        (l, false) => l.to_string(),
    }
}

impl TprfApp {
    /// The curves the TPRF plot shows: the selection's, its bounce layers' (those the
    /// film has and the plot shows), the pins'.
    pub fn plotted_curves(&self, snap: &FilmSnapshot) -> Vec<Curve> {
        let mut curves = Vec::new();
        if let Some(sel) = &self.selection {
            curves.push(Curve {
                name: sel.label(),
                color: PIN_COLORS[0],
                values: sel.tprf(snap, None),
                dashed: false,
            });
            let (layers, lum) = (snap.layers(), snap.luminescence_layer());
            for l in (0..layers).filter(|&l| self.settings.bounce_shown(l)) {
                curves.push(Curve {
                    name: bounce_layer_name(l, layers, lum, true),
                    color: bounce_color(l, layers, lum),
                    values: sel.tprf(snap, Some(l)),
                    dashed: true,
                });
            }
        }
        for (i, p) in self.pins.iter().enumerate() {
            curves.push(Curve {
                name: format!("pin: {}", p.label()),
                color: PIN_COLORS[(i + 1) % PIN_COLORS.len()],
                values: p.tprf(snap, None),
                dashed: false,
            });
        }
        curves
    }

    /// The TPRF plot with its options, pin and CSV buttons, then the error plot.
    pub(crate) fn plot_ui(&mut self, ui: &mut egui::Ui, snap: &FilmSnapshot) {
        ui.heading("TPRF");
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut self.settings.plot_log, "log");
            // A curve per bounce layer the film has (none without layers).
            let (layers, lum) = (snap.layers(), snap.luminescence_layer());
            if layers > 0 {
                ui.label("bounces:").on_hover_text(
                    "the selection's TPRF split by scattering events (the film's bounce \
                     layers): direct is the light seen straight from an emitter; \
                     re-emitted, where the scene has luminescent surfaces, is the light \
                     they re-emitted later (the bounce layers then hold the rest)",
                );
                for l in 0..layers {
                    let mut on = self.settings.bounce_shown(l);
                    let name = bounce_layer_name(l, layers, lum, false);
                    let colour = bounce_color(l, layers, lum);
                    if ui
                        .checkbox(&mut on, RichText::new(name).color(colour))
                        .changed()
                    {
                        self.settings.set_bounce_shown(l, on);
                        self.pending.bounces_shown = self.settings.bounces_shown.clone();
                    }
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
                .flat_map(|c| c.values.iter())
                .fold(0.0f64, |m, &v| m.max(v));
            if max > 0.0 { max * 1e-6 } else { 1e-30 }
        });
        // Room under the plot for the error plot: its title row, the plot, the spacing
        // between them (150 once clipped the error plot's axis label at every size).
        let error_block = super::error_plot::ERROR_PLOT_H
            + ui.text_style_height(&egui::TextStyle::Body)
            + 3.0 * ui.spacing().item_spacing.y
            + 4.0;
        let plot_h = (ui.available_height() - error_block).max(160.0);
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
            for c in &curves {
                let pts = step_points(&axis, &c.values, log_floor, width_px);
                let line = Line::new(c.name.clone(), pts)
                    .color(c.color)
                    .allow_band(false);
                plot_ui.line(if c.dashed {
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
        self.scrub_from_plot(&response.response, response.inner, &axis);
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
            Some(m) if self.sensor.shows_full(snap) => m.pixel(sel.y0, sel.x0),
            _ => Vec::new(),
        };
        let h = ui.available_height();
        let bottom = ui.max_rect().bottom();
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
                bottom,
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

//! The error estimate (two half buffers) against render time, log-log, under the TPRF
//! plot while a render runs.

use crate::viewer::app::TprfApp;
use crate::viewer::plotting;
use eframe::egui::{self, RichText};
use egui_plot::{AxisHints, Line, Plot, PlotPoints};

/// The error plot's height, points (its axes included).
pub(crate) const ERROR_PLOT_H: f32 = 130.0;

impl TprfApp {
    /// Nothing for a loaded cube or before the first estimate.
    pub(crate) fn error_plot_ui(&mut self, ui: &mut egui::Ui) {
        let Some(status) = self.status() else {
            return;
        };
        if status.error_history.is_empty() {
            return;
        }
        ui.label(RichText::new(
            "Error estimate (two half buffers) against wall time, log-log",
        ));
        let pts: PlotPoints = status
            .error_history
            .iter()
            .filter(|(t, e)| *t > 0.0 && *e > 0.0)
            .map(|(t, e)| [t.log10(), e.log10()])
            .collect();
        Plot::new("error-plot")
            .height(ERROR_PLOT_H)
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .x_grid_spacer(plotting::spacer(60.0))
            .y_grid_spacer(plotting::spacer(24.0))
            .custom_x_axes(vec![
                AxisHints::new_x()
                    .label("wall time (s)")
                    .formatter(plotting::log_tick),
            ])
            .custom_y_axes(vec![
                AxisHints::new_y()
                    .label("rel. error")
                    .formatter(plotting::log_tick),
            ])
            .show(ui, |plot_ui| plot_ui.line(Line::new("error", pts)));
    }
}

//! The time scrubber under the images: first/step/play buttons, loop and speed, the bin
//! and its time, and a ruler to click or drag with round tick times.

use super::SCRUBBER_COLOR;
use crate::viewer::app::TprfApp;
use crate::viewer::timeline::{TimeRuler, bin_label, nice_ticks_s};
use eframe::egui::{self, RichText, Sense, Vec2};
use tprf_core::film::TimeAxis;

impl TprfApp {
    /// The playback buttons over the ruler of `axis`.
    pub(crate) fn scrubber_ui(&mut self, ui: &mut egui::Ui, axis: &TimeAxis) {
        let bins = axis.bins;
        // The panel's width, taken before anything is laid out: a row wider than the
        // panel widens the ui, and a ruler as wide as that ran on under the right panel
        // (the last eighth of the bins out of reach at 1280 x 800).
        let width = ui.available_width();
        // Every item is whole and wraps to a new row where the panel is narrow: the
        // time first, then the buttons, loop and speed.
        ui.horizontal_wrapped(|ui| {
            ui.add(
                egui::Label::new(
                    // Padded to the widest it gets on this axis (monospace): the buttons
                    // after it keep their place while the bin changes.
                    RichText::new(format!(
                        "bin {:>digits$} / {} · t = {:<label$}",
                        self.bin,
                        bins,
                        bin_label(axis, self.bin),
                        digits = bins.to_string().len(),
                        label = widest_label(axis),
                    ))
                    .monospace()
                    .strong(),
                )
                .wrap_mode(egui::TextWrapMode::Truncate),
            );
            ui.separator();
            if ui.button("⏮").on_hover_text("First bin").clicked() {
                self.bin = 0;
            }
            if ui.button("◀").on_hover_text("Step back (←)").clicked() {
                self.playing = false;
                self.step(-1, bins);
            }
            if ui
                .button(if self.playing { "⏸" } else { "▶" })
                .on_hover_text("Play / pause (space)")
                .clicked()
            {
                self.playing = !self.playing;
            }
            if ui.button("▶|").on_hover_text("Step forward (→)").clicked() {
                self.playing = false;
                self.step(1, bins);
            }
            ui.checkbox(&mut self.settings.looping, "loop");
            let l = ui.label("speed");
            ui.add(
                egui::DragValue::new(&mut self.settings.play_bins_per_s)
                    .range(1.0..=240.0)
                    .speed(0.5)
                    .max_decimals(1)
                    .suffix(" bins/s"),
            )
            .labelled_by(l.id)
            .on_hover_text("playback speed, bins per second (1 to 240)");
        });
        // The scrub bar: drag or click anywhere on it.
        let (rect, response) =
            ui.allocate_exact_size(Vec2::new(width, 32.0), Sense::click_and_drag());
        let ruler = TimeRuler {
            axis: *axis,
            left: rect.left() + 4.0,
            right: rect.right() - 4.0,
        };
        if let Some(pos) = response.interact_pointer_pos()
            && (response.dragged() || response.clicked())
        {
            self.bin = ruler.bin_at_x(pos.x);
            self.playing = false;
        }
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 4.0, ui.visuals().extreme_bg_color);
        let (ticks, decimals) = nice_ticks_s(
            axis.t0_s,
            axis.end_s(),
            ((rect.width() / 90.0) as usize).max(2),
        );
        let font = egui::FontId::proportional(12.0);
        for t in ticks {
            let x = ruler.x_of_time(t);
            painter.line_segment(
                [
                    egui::pos2(x, rect.bottom() - 8.0),
                    egui::pos2(x, rect.bottom()),
                ],
                (1.0, ui.visuals().weak_text_color()),
            );
            let galley = painter.layout_no_wrap(
                format!("{:.*} ns", decimals, t * 1e9),
                font.clone(),
                ui.visuals().weak_text_color(),
            );
            // Centred on its tick, kept inside the bar.
            let left = (x - galley.size().x / 2.0)
                .clamp(rect.left() + 2.0, rect.right() - 2.0 - galley.size().x);
            painter.galley(
                egui::pos2(left, rect.top() + 2.0),
                galley,
                ui.visuals().weak_text_color(),
            );
        }
        let x = ruler.x_of_bin(self.bin);
        painter.line_segment(
            [egui::pos2(x, rect.top()), egui::pos2(x, rect.bottom())],
            (2.0, SCRUBBER_COLOR),
        );
        response
            .widget_info(|| egui::WidgetInfo::labeled(egui::Role::Slider, true, "time scrubber"));
    }
}

/// The most characters [`bin_label`] takes on `axis` (its first, middle and last bins:
/// the longest numbers and unit prefixes are at the ends).
fn widest_label(axis: &TimeAxis) -> usize {
    let last = axis.bins.saturating_sub(1);
    [0, last / 2, last]
        .iter()
        .map(|&b| bin_label(axis, b).chars().count())
        .max()
        .unwrap_or(0)
}

//! The left panel: the scene, the render settings (applied with "Apply & restart"), the
//! display settings (at once), saving images and video, and the messages. In sensor
//! mode the sensor's controls come first.

use crate::viewer::app::TprfApp;
use crate::viewer::colormap::{ColorMap, ExposureMode};
use crate::viewer::sensor;
use crate::viewer::settings::{MAX_BINS, MAX_SIDE};
use crate::viewer::tone::View;
use eframe::egui::{self, RichText};
use std::sync::Arc;
use tprf_core::film::FilmSnapshot;
use tprf_core::scene::Channel;
use tprf_core::units::format_time;

impl TprfApp {
    /// The sensor's presets, light, gates and noise, and what is wrong with them.
    pub(crate) fn sensor_controls_ui(
        &mut self,
        ui: &mut egui::Ui,
        snap: Option<&Arc<FilmSnapshot>>,
    ) {
        let axis = snap.map(|s| *s.axis());
        if let Some(m) = sensor::controls_ui(ui, &mut self.settings.sensor, axis.as_ref()) {
            self.messages.push(m);
        }
        if let Some(e) = &self.sensor.error {
            ui.label(RichText::new(e).color(ui.visuals().error_fg_color));
        }
    }

    /// Scene, Render, Display, Save and Messages.
    pub(crate) fn controls_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Scene");
        ui.label(RichText::new(&self.settings.scene).monospace());
        if let Some(s) = self.status() {
            ui.label(format!("{} triangles", s.triangles));
            for n in &s.notes {
                ui.label(RichText::new(format!("note: {n}")).small().weak());
            }
        }
        ui.separator();
        self.render_settings_ui(ui);
        ui.separator();
        self.display_settings_ui(ui);
        ui.separator();
        self.save_ui(ui);
        if !self.messages.is_empty() {
            ui.separator();
            ui.heading("Messages");
            for m in &self.messages {
                ui.label(RichText::new(m).color(ui.visuals().warn_fg_color));
            }
            if ui.button("Clear").clicked() {
                self.messages.clear();
            }
        }
    }

    /// The render settings being edited, "Apply & restart", "Revert", and the window
    /// the render uses.
    fn render_settings_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Render");
        let p = &mut self.pending;
        egui::Grid::new("render-grid")
            .num_columns(2)
            .show(ui, |ui| {
                let l = ui.label("Width");
                ui.add(egui::DragValue::new(&mut p.width).range(1..=MAX_SIDE))
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Height");
                ui.add(egui::DragValue::new(&mut p.height).range(1..=MAX_SIDE))
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Bins");
                ui.add(egui::DragValue::new(&mut p.bins).range(1..=MAX_BINS))
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui
                    .label("Window start")
                    .on_hover_text("with a unit: ns, ps, m, cm… (empty: automatic)");
                ui.add(
                    egui::TextEdit::singleline(&mut p.t0)
                        .hint_text("auto")
                        .desired_width(80.0),
                )
                .labelled_by(l.id);
                ui.end_row();
                let l = ui
                    .label("Bin width")
                    .on_hover_text("with a unit: ns, ps, m, cm… (empty: automatic)");
                ui.add(
                    egui::TextEdit::singleline(&mut p.dt)
                        .hint_text("auto")
                        .desired_width(80.0),
                )
                .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Stop at spp").on_hover_text("0: keep refining");
                ui.add(egui::DragValue::new(&mut p.spp_target).range(0..=1_000_000))
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Max bounces");
                ui.add(egui::DragValue::new(&mut p.max_bounces).range(1..=100_000))
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Band");
                egui::ComboBox::from_id_salt("band")
                    .selected_text(format!("{:?}", p.channel))
                    .show_ui(ui, |ui| {
                        for c in [Channel::Gray, Channel::Red, Channel::Green, Channel::Blue] {
                            ui.selectable_value(&mut p.channel, c, format!("{c:?}"));
                        }
                    })
                    .response
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Seed");
                ui.add(egui::DragValue::new(&mut p.seed)).labelled_by(l.id);
                ui.end_row();
            });
        let changed = self.settings.with_render_of(&self.pending) != self.settings;
        ui.horizontal(|ui| {
            if ui
                .add_enabled(changed, egui::Button::new("Apply & restart"))
                .clicked()
            {
                self.apply_pending();
            }
            if ui
                .add_enabled(changed, egui::Button::new("Revert"))
                .clicked()
            {
                self.pending = self.settings.clone();
            }
        });
        if let Some(s) = self.status()
            && let Some(axis) = s.axis
        {
            ui.label(
                RichText::new(format!(
                    "window {} … {} ({} bins of {})",
                    format_time(axis.t0_s),
                    format_time(axis.end_s()),
                    axis.bins,
                    format_time(axis.dt_s)
                ))
                .small(),
            );
        }
    }

    /// Exposure, EV, log scale and colour map: in effect at once (and kept in the
    /// pending settings, so "Apply" does not undo them).
    fn display_settings_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Display");
        let s = &mut self.settings;
        ui.horizontal(|ui| {
            ui.label("Exposure");
            ui.selectable_value(&mut s.exposure, ExposureMode::PerFrame, "per frame");
            ui.selectable_value(&mut s.exposure, ExposureMode::Global, "global");
        });
        ui.add(egui::Slider::new(&mut s.ev, -10.0..=10.0).text("EV"));
        ui.checkbox(&mut s.log_image, "Log scale (3 decades)");
        ui.horizontal(|ui| {
            ui.label("Colours");
            ui.selectable_value(&mut s.colormap, ColorMap::Inferno, "inferno");
            ui.selectable_value(&mut s.colormap, ColorMap::Gray, "grey");
        });
        self.pending.ev = self.settings.ev;
        self.pending.log_image = self.settings.log_image;
        self.pending.exposure = self.settings.exposure;
        self.pending.colormap = self.settings.colormap;
    }

    /// The save buttons (disabled until there is a film), and a note while a file is
    /// being written.
    fn save_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Save");
        let snap = self.snapshot();
        ui.add_enabled_ui(snap.is_some(), |ui| {
            if ui.button("Time slice as PNG…").clicked()
                && let Some(snap) = &snap
            {
                self.save_view_png(View::Slice, snap);
            }
            if ui.button("Steady image as PNG…").clicked()
                && let Some(snap) = &snap
            {
                self.save_view_png(View::Steady, snap);
            }
            if ui.button("Video as frames + GIF…").clicked()
                && let Some(snap) = &snap
            {
                self.save_video(snap);
            }
        });
        if self.exports.busy() {
            ui.horizontal(|ui| {
                ui.spinner();
                ui.label(RichText::new("saving…").small());
            });
        }
    }
}

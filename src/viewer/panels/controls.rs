//! The left panel: the scene, its camera and fog, the render settings (applied with "Apply & restart"), the
//! display settings (at once), saving images and video, and the messages. In sensor
//! mode the sensor's controls come first.

use crate::viewer::app::TprfApp;
use crate::viewer::colormap::{ColorMap, ExposureMode};
use crate::viewer::files::FileAction;
use crate::viewer::sensor;
use crate::viewer::settings::{MAX_BINS, MAX_SIDE};
use crate::viewer::source::Source;
use crate::viewer::tone::{SLICE_FLOOR, SLICE_PERCENTILE};
use eframe::egui::{self, RichText};
use std::sync::Arc;
use tprf_core::film::FilmSnapshot;
use tprf_core::scene::{Channel, PulseOrigin, TimeOrigin};
use tprf_core::units::format_time;

impl TprfApp {
    /// The sensor's presets, light, gates and noise, and what is wrong with them.
    pub(crate) fn sensor_controls_ui(
        &mut self,
        ui: &mut egui::Ui,
        snap: Option<&Arc<FilmSnapshot>>,
    ) {
        let axis = snap.map(|s| *s.axis());
        let out = sensor::controls_ui(ui, &mut self.settings.sensor, axis.as_ref());
        if let Some(m) = out.message {
            self.messages.push(m);
        }
        if let Some(a) = out.file {
            self.choose_file(a);
        }
        if out.preset_picked {
            self.sensor.preset_picked();
        }
        if let Some(e) = &self.sensor.error {
            ui.label(RichText::new(e).color(ui.visuals().error_fg_color));
        }
    }

    /// Scene (or the cube's own facts), Render, Display, Save and Messages.
    pub(crate) fn controls_ui(&mut self, ui: &mut egui::Ui) {
        if let Source::Cube {
            dir,
            meta,
            snapshot,
            ..
        } = &self.source
        {
            ui.heading("Cube");
            ui.label(RichText::new(dir.display().to_string()).monospace());
            let axis = snapshot.axis();
            egui::Grid::new("cube-grid").num_columns(2).show(ui, |ui| {
                let mut row = |k: &str, v: String| {
                    ui.label(k);
                    ui.label(v);
                    ui.end_row();
                };
                row("scene", meta.scene.clone());
                row(
                    "film",
                    format!("{} × {} px × {} bins", meta.width, meta.height, meta.bins),
                );
                row("spp", meta.spp.to_string());
                row(
                    "window",
                    format!(
                        "{} … {} (bins of {})",
                        format_time(axis.t0_s),
                        format_time(axis.end_s()),
                        format_time(axis.dt_s)
                    ),
                );
                row("band", meta.channel.clone());
                row(
                    "bounce layers",
                    if snapshot.layers() > 1 {
                        match snapshot.luminescence_layer() {
                            Some(_) => {
                                format!("{} (the last: re-emitted light)", snapshot.layers())
                            }
                            None => format!("{}", snapshot.layers()),
                        }
                    } else {
                        "none".into()
                    },
                );
                row(
                    "rendered",
                    format!("in {:.1} s, {} passes", meta.wall_seconds, meta.passes),
                );
                if let Some(e) = meta.error_estimate {
                    row("error estimate", format!("{:.2} %", 100.0 * e));
                }
            });
            for n in &meta.notes {
                ui.label(RichText::new(format!("note: {n}")).weak());
            }
            ui.label(
                RichText::new("The render settings below start a new render of a scene.").weak(),
            );
        } else {
            ui.heading("Scene");
            ui.label(RichText::new(&self.settings.scene).monospace());
            if let Some(s) = self.status() {
                ui.label(format!(
                    "{} triangles · set up in {:.1} s",
                    s.triangles, s.setup_s
                ));
                for n in &s.notes {
                    ui.label(RichText::new(format!("note: {n}")).weak());
                }
            }
            ui.separator();
            self.camera_ui(ui);
            self.fog_ui(ui);
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
                ui.label(RichText::new(m).color(super::message_color(ui, m)));
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
                let l = ui.label("Time origin").on_hover_text(
                    "where arrival times start: the pinhole (what a real camera sees), the \
                     near clip plane (mitransient's count), or each pixel's first surface \
                     (the camera's leg left out: mitransient's camera_unwarp)",
                );
                egui::ComboBox::from_id_salt("time_origin")
                    .selected_text(p.time_origin.name())
                    .show_ui(ui, |ui| {
                        for o in TimeOrigin::ALL {
                            ui.selectable_value(&mut p.time_origin, o, o.name());
                        }
                    })
                    .response
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Pulse origin").on_hover_text(
                    "when the pulse starts: as it leaves the light, or at the first surface \
                     it lights (the light's leg left out, as an NLOS laser's spot firing at \
                     t = 0)",
                );
                egui::ComboBox::from_id_salt("pulse_origin")
                    .selected_text(p.pulse_origin.name())
                    .show_ui(ui, |ui| {
                        for o in PulseOrigin::ALL {
                            ui.selectable_value(&mut p.pulse_origin, o, o.name());
                        }
                    })
                    .response
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Stop at spp").on_hover_text("0: keep refining");
                ui.add(egui::DragValue::new(&mut p.spp_target).range(0..=1_000_000))
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui
                    .label("Stop at error")
                    .on_hover_text("relative error estimate of the cube; 0: keep refining");
                ui.add(
                    egui::DragValue::new(&mut p.error_target_pct)
                        .range(0.0..=100.0)
                        .speed(0.05)
                        .max_decimals(2)
                        .suffix(" %"),
                )
                .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Max bounces");
                ui.add(egui::DragValue::new(&mut p.max_bounces).range(1..=100_000))
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Min bounces").on_hover_text(
                    "fewest scattering events of a recorded path: 2 leaves out direct reflection, 3 an NLOS view's wall-to-wall light",
                );
                let most = p.max_bounces;
                ui.add(egui::DragValue::new(&mut p.min_bounces).range(0..=most))
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Band");
                egui::ComboBox::from_id_salt("band")
                    .selected_text(p.channel.name())
                    .show_ui(ui, |ui| {
                        // The colour bands, then wavelengths every 50 nm (docs/dispersion.md).
                        let bands = [Channel::Gray, Channel::Red, Channel::Green, Channel::Blue]
                            .into_iter()
                            .chain((0..7).filter_map(|k| {
                                let nm = 400.0 + 50.0 * k as f64;
                                tprf_core::scene::spectrum::Wavelength::from_nm(nm)
                                    .ok()
                                    .map(Channel::Wavelength)
                            }));
                        for c in bands {
                            ui.selectable_value(&mut p.channel, c, c.name());
                        }
                    })
                    .response
                    .labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Seed");
                ui.add(egui::DragValue::new(&mut p.seed)).labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Uniform samples").on_hover_text(
                    "every pixel draws every pass's samples: the same noise across the \
                     image; off: samples go where the noise is, for the least cube error \
                     per second (unbiased either way)",
                );
                ui.checkbox(&mut p.uniform_sampling, "").labelled_by(l.id);
                ui.end_row();
                let l = ui.label("Sky").on_hover_text(
                    "a constant sky in the ambient light group (steady light: the sensor adds \
                     its ambient image to every gate and the SPAD); off: the scene's own",
                );
                ui.horizontal(|ui| {
                    let mut on = p.sky_radiance_w_m2_sr.is_some();
                    if ui.checkbox(&mut on, "").labelled_by(l.id).changed() {
                        p.sky_radiance_w_m2_sr =
                            on.then_some(p.sky_radiance_w_m2_sr.unwrap_or(1.0));
                    }
                    if let Some(sky) = p.sky_radiance_w_m2_sr.as_mut() {
                        ui.add(
                            egui::DragValue::new(sky)
                                .range(0.0..=f64::MAX)
                                .speed(0.1)
                                .suffix(" W m⁻² sr⁻¹"),
                        )
                        .labelled_by(l.id);
                    }
                });
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
            ui.label(format!(
                "window {} … {} ({} bins of {})",
                format_time(axis.t0_s),
                format_time(axis.end_s()),
                axis.bins,
                format_time(axis.dt_s)
            ));
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
        ui.label(
            RichText::new(match s.exposure {
                ExposureMode::PerFrame => format!(
                    "per frame: white = the {:.1}th percentile of the slice's pixels (at \
                     least {:.0} % of the cube's white)",
                    SLICE_PERCENTILE * 100.0,
                    SLICE_FLOOR * 100.0
                ),
                ExposureMode::Global => {
                    "global: white = the 99.9th percentile of the cube's lit bins".into()
                }
            })
            .weak(),
        );
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
            if ui.button("Time slice as PNG…").clicked() {
                self.choose_file(FileAction::SaveSlicePng);
            }
            if ui.button("Steady image as PNG…").clicked() {
                self.choose_file(FileAction::SaveSteadyPng);
            }
            if ui.button("Video as frames + GIF…").clicked() {
                self.choose_file(FileAction::SaveVideo);
            }
        });
        ui.checkbox(&mut self.settings.png_legend, "PNG with legend")
            .on_hover_text(
                "the slice and steady PNGs carry their colour bar (scale and unit) and a \
                 line saying what they show (the slice's time), so the file reads on its \
                 own; off: the film's pixels only, one PNG pixel per film pixel",
            );
        if self.exports.busy() {
            ui.horizontal(|ui| {
                ui.spinner();
                ui.label("saving…");
            });
        }
    }
}

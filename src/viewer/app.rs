//! The application: [`TprfApp`], what it keeps between frames, and the order in which a
//! frame reads the film and draws the panels. The panels, the playback clock, the
//! sources of film and the file exports extend it from their own files.

use super::Start;
use super::exports::Exports;
use super::selection::Selection;
use super::sensor::{self, SensorState};
use super::settings::{Mode, ViewerSettings};
use super::source::Source;
use super::textures::{ImageKey, TextureCache};
use eframe::egui::{self, RichText};
use std::time::Instant;
use tprf_core::transport::worker::WorkerState;

/// The tprf window.
pub struct TprfApp {
    /// Settings in effect (persisted).
    pub settings: ViewerSettings,
    /// Settings being edited in the render panel; applied with "Apply".
    pub pending: ViewerSettings,
    pub(super) source: Source,
    /// The scrubber's bin.
    pub bin: usize,
    pub playing: bool,
    /// Bins of playback not yet stepped (a fraction of one).
    pub(super) play_accum: f32,
    /// The selected pixel or box, and pinned ones.
    pub selection: Option<Selection>,
    pub pins: Vec<Selection>,
    /// The pixel where a box drag on an image started.
    pub(super) drag_start: Option<(usize, usize)>,
    /// The slice, steady and rainbow images.
    pub(super) textures: TextureCache<ImageKey>,
    pub(super) messages: Vec<String>,
    /// Files being written in the background.
    pub(super) exports: Exports,
    /// Smoothed time our `ui()` takes, ms.
    pub(super) frame_ms: f32,
    /// The sensor's model, measurements and textures.
    pub sensor: SensorState,
    pub(super) ctx: egui::Context,
}

impl TprfApp {
    /// The window with the settings saved by the last run (defaults on the first).
    pub fn new(cc: &eframe::CreationContext<'_>, start: Start) -> TprfApp {
        let settings: ViewerSettings = cc
            .storage
            .and_then(|s| eframe::get_value(s, eframe::APP_KEY))
            .unwrap_or_default();
        TprfApp::with_settings(cc, settings, start)
    }

    /// The window with the given settings (tests, screenshots).
    pub fn with_settings(
        cc: &eframe::CreationContext<'_>,
        settings: ViewerSettings,
        start: Start,
    ) -> TprfApp {
        let settings = settings.sanitized();
        let mut app = TprfApp {
            pending: settings.clone(),
            settings,
            source: Source::None,
            bin: 0,
            // Light starts to move at once.
            playing: true,
            play_accum: 0.0,
            selection: None,
            pins: Vec::new(),
            drag_start: None,
            textures: TextureCache::default(),
            messages: Vec::new(),
            exports: Exports::default(),
            frame_ms: 0.0,
            sensor: SensorState::default(),
            ctx: cc.egui_ctx.clone(),
        };
        match start {
            Start::Default => app.restart(),
            Start::Scene(s) => {
                app.pending.scene = s;
                app.apply_pending();
            }
            Start::Cube(dir) => app.open_cube(&dir),
        }
        app
    }

    /// Errors and notes shown in the window.
    pub fn messages(&self) -> &[String] {
        &self.messages
    }
}

impl eframe::App for TprfApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let started = Instant::now();
        let ctx = ui.ctx().clone();
        self.messages.extend(self.exports.finished());
        self.handle_dropped_files(&ctx);
        let snap = self.snapshot();
        // A film without pixels or bins has nothing to draw (and no texture can be made
        // of it): said in the window instead.
        let empty = snap
            .as_ref()
            .filter(|s| s.width() == 0 || s.height() == 0 || s.axis().bins == 0)
            .map(|s| {
                format!(
                    "the film is {} x {} pixels x {} bins: there is nothing to show",
                    s.width(),
                    s.height(),
                    s.axis().bins
                )
            });
        if let Some(m) = &empty
            && !self.messages.contains(m)
        {
            self.messages.push(m.clone());
        }
        let snap = snap.filter(|_| empty.is_none());
        let bins = snap.as_ref().map_or(0, |s| s.axis().bins);
        if bins > 0 {
            self.bin = self.bin.min(bins - 1);
        }
        if let Some(s) = &snap {
            // Something to plot from the first frame: the pixel at the image centre. A
            // selection from another resolution is clamped onto this one.
            let (w, h) = (s.width(), s.height());
            let sel = self.selection.get_or_insert(Selection::pixel(w / 2, h / 2));
            *sel = sel.clamped(w, h);
            for p in &mut self.pins {
                *p = p.clamped(w, h);
            }
        }
        self.handle_keys(&ctx, bins);
        self.advance_playback(&ctx, bins);

        let sensor_mode = self.settings.mode == Mode::Sensor;
        if sensor_mode && let Some(s) = &snap {
            self.sensor.update(&self.settings.sensor, s);
        }
        let window_w = ui.available_width();
        egui::Panel::top("top").show(ui, |ui| self.top_bar_ui(ui));
        egui::Panel::bottom("status").show(ui, |ui| self.status_bar_ui(ui, snap.as_ref()));
        egui::Panel::left("controls")
            .resizable(true)
            .default_size(250.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    if sensor_mode {
                        self.sensor_controls_ui(ui, snap.as_ref());
                        ui.separator();
                    }
                    self.controls_ui(ui)
                });
            });
        egui::Panel::right("plot")
            .resizable(true)
            .default_size((window_w * 0.3).clamp(320.0, 720.0))
            .show(ui, |ui| {
                // Keep the panel's width while its content is narrow (the first frames).
                ui.set_min_width(ui.available_width());
                match &snap {
                    Some(s) if sensor_mode => self.sensor_plots_ui(ui, s),
                    Some(s) => self.plot_ui(ui, s),
                    None => {
                        ui.heading("TPRF");
                        ui.label("Waiting for the first pass…");
                    }
                }
            });
        if let Some(s) = &snap
            && !sensor_mode
        {
            let axis = *s.axis();
            egui::Panel::bottom("timeline").show(ui, |ui| self.scrubber_ui(ui, &axis));
        }
        egui::CentralPanel::default().show(ui, |ui| match &snap {
            Some(s) if sensor_mode => {
                if let Some((x, y)) = sensor::images_ui(ui, &mut self.sensor, s) {
                    self.selection = Some(Selection::pixel(x, y));
                }
            }
            Some(s) => self.images_ui(ui, s),
            None => {
                ui.centered_and_justified(|ui| match (self.status().map(|s| s.state), &empty) {
                    (Some(WorkerState::Failed(e)), _) => ui.label(
                        RichText::new(format!("Render failed: {e}"))
                            .color(ui.visuals().error_fg_color),
                    ),
                    (_, Some(m)) => ui.label(RichText::new(m).color(ui.visuals().error_fg_color)),
                    // No render runs and no cube is open (it could not be read): nothing
                    // is coming, so no spinner.
                    _ if matches!(self.source, Source::None) => ui.label(
                        RichText::new(self.messages.last().map_or(
                            "Nothing to show: open a glTF scene or a cube.",
                            String::as_str,
                        ))
                        .color(ui.visuals().error_fg_color),
                    ),
                    _ => ui.spinner(),
                });
            }
        });
        if let Some(WorkerState::Failed(e)) = self.status().map(|s| s.state) {
            let m = format!("render failed: {e}");
            if !self.messages.contains(&m) {
                self.messages.push(m);
            }
        }
        self.frame_ms = 0.9 * self.frame_ms + 0.1 * started.elapsed().as_secs_f32() * 1e3;
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, eframe::APP_KEY, &self.settings);
    }
}

//! The application: [`TprfApp`], what it keeps between frames, and the order in which a
//! frame reads the film and draws the panels. The panels, the playback clock, the
//! sources of film and the file exports extend it from their own files.

use super::Start;
use super::exports::Exports;
use super::files::PathPrompt;
use super::selection::Selection;
use super::sensor::{self, SensorState};
use super::settings::{Mode, ViewerSettings};
use super::source::Source;
use super::textures::{ImageKey, TextureCache};
use super::tone::{Exposure, Scratch, View};
use eframe::egui::{self, RichText};
use std::time::Instant;
use tprf_core::film::FilmSnapshot;
use tprf_core::request::worker::WorkerState;

/// The tprf window.
pub struct TprfApp {
    /// Settings in effect (persisted).
    pub settings: ViewerSettings,
    /// Settings being edited in the render panel; applied with "Apply".
    pub pending: ViewerSettings,
    pub(super) source: Source,
    /// The scrubber's bin.
    pub bin: usize,
    /// Whether the scrubber goes to where the light is ([`super::timeline::light_bin`])
    /// on the next film: a new scene, window or cube, not a restart of the same one.
    pub(super) seek_light: bool,
    /// The scene and window the scrubber's bin was chosen for.
    pub(super) light_key: Option<String>,
    /// The scrubber's time (s) when the camera moved: the new film's automatic window
    /// may start elsewhere, so its first film puts the scrubber at the bin of this time
    /// (or where the light is, when the window no longer holds it).
    pub(super) keep_time_s: Option<f64>,
    pub playing: bool,
    /// Bins of playback not yet stepped (a fraction of one).
    pub(super) play_accum: f32,
    /// egui's time (s) of the last frame that played; `None` while not playing.
    pub(super) play_time_s: Option<f64>,
    /// The selected pixel or box, and pinned ones.
    pub selection: Option<Selection>,
    pub pins: Vec<Selection>,
    /// Width and height of the film the selection and pins were made on: on a film of
    /// another size they are moved onto the same scene point.
    pub(super) selection_film: Option<(usize, usize)>,
    /// The pixel where a box drag on an image started.
    pub(super) drag_start: Option<(usize, usize)>,
    /// The slice, steady and rainbow images.
    pub(super) textures: TextureCache<ImageKey>,
    /// The ambient image's texture (steady block, [`ViewerSettings::steady_block`]),
    /// keyed by the image's address and the colour settings, with its white point.
    pub(super) ambient_texture: TextureCache<(usize, bool)>,
    /// The samples image's texture (steady block), keyed by the snapshot's generation.
    pub(super) samples_texture: TextureCache<u64>,
    pub(super) ambient_white: Option<f64>,
    /// How each image's texture was exposed (for its colour bar).
    pub(super) exposures: Vec<(View, Exposure)>,
    /// Buffers the images are made in, kept between frames.
    pub(super) scratch: Scratch,
    /// Whether this frame already remade an image of the whole film (see
    /// `TprfApp::texture`).
    pub(super) remade_this_frame: bool,
    pub(super) messages: Vec<String>,
    /// Files being written in the background.
    pub(super) exports: Exports,
    /// Frame times (smoothed), ms.
    pub(super) timing: FrameTiming,
    /// The sensor's model, measurements and textures.
    pub sensor: SensorState,
    /// Whether "Open…" and "Save…" use the system file dialog (else a path field).
    pub file_dialogs: bool,
    /// The path window, while open.
    pub(super) path_prompt: Option<PathPrompt>,
    /// Input events held back for the next frame ([`super::input::split_at_tab`]).
    pub(super) deferred_input: Vec<egui::Event>,
    /// The film of the camera before the last camera move, on screen until the new
    /// render's first pass.
    pub(super) held: Option<std::sync::Arc<FilmSnapshot>>,
    /// A camera gesture on the images not yet rendered.
    pub(super) camera_gesture: Option<super::panels::CameraGesture>,
    /// The rendered scene's camera and bounds, found once per scene.
    pub(super) scene_view: super::panels::SceneView,
    /// The camera's pose as typed, and what is wrong with it.
    pub(super) pose_text: super::camera::PoseText,
    pub(super) pose_error: Option<String>,
    /// The fog's fields as typed (the Fog section).
    pub(super) fog_text: super::fog::FogText,
    /// The phasor tab's textures, planes and band as typed.
    pub(super) phasor: super::phasor::PhasorState,
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
        // Units are written with superscripts (W m⁻² sr⁻¹): the monospace font has the
        // ones the proportional font lacks.
        let mut fonts = egui::FontDefinitions::default();
        if let Some(family) = fonts.families.get_mut(&egui::FontFamily::Proportional) {
            family.push("Hack".to_owned());
        }
        cc.egui_ctx.set_fonts(fonts);
        let mut app = TprfApp {
            pending: settings.clone(),
            settings,
            source: Source::None,
            bin: 0,
            seek_light: true,
            light_key: None,
            keep_time_s: None,
            // Light starts to move at once.
            playing: true,
            play_accum: 0.0,
            play_time_s: None,
            selection: None,
            pins: Vec::new(),
            selection_film: None,
            drag_start: None,
            textures: TextureCache::default(),
            ambient_texture: TextureCache::default(),
            samples_texture: TextureCache::default(),
            ambient_white: None,
            exposures: Vec::new(),
            scratch: Scratch::default(),
            remade_this_frame: false,
            messages: Vec::new(),
            exports: Exports::default(),
            timing: FrameTiming::default(),
            sensor: SensorState::default(),
            file_dialogs: super::files::dialogs_enabled(),
            path_prompt: None,
            deferred_input: Vec::new(),
            held: None,
            camera_gesture: None,
            scene_view: Default::default(),
            pose_text: Default::default(),
            pose_error: None,
            fog_text: Default::default(),
            phasor: Default::default(),
            ctx: cc.egui_ctx.clone(),
        };
        app.sensor.set_waker(cc.egui_ctx.clone());
        match start {
            Start::Default => app.restart(),
            Start::Scene(s) => app.open_scene(s),
            Start::Cube(dir) => app.open_cube(&dir),
        }
        app
    }

    /// Errors and notes shown in the window.
    pub fn messages(&self) -> &[String] {
        &self.messages
    }

    /// Select `sel` on `snap` (the film it was picked on).
    pub(super) fn select(&mut self, sel: Selection, snap: &FilmSnapshot) {
        self.selection = Some(sel);
        self.selection_film = Some((snap.width(), snap.height()));
    }

    /// Keep the selection and pins on the film `(w, h)`: made on a film of another size
    /// (a resolution change), they move to the same scene point, and the window says so.
    fn follow_film_size(&mut self, w: usize, h: usize) {
        match self.selection_film {
            Some(from) if from != (w, h) => {
                if let Some(s) = &mut self.selection {
                    *s = s.rescaled(from, (w, h));
                }
                for p in &mut self.pins {
                    *p = p.rescaled(from, (w, h));
                }
                if self.selection.is_some() || !self.pins.is_empty() {
                    self.messages.push(format!(
                        "selection and pins moved from the {}×{} film to the same scene points \
                         of the {w}×{h} film",
                        from.0, from.1
                    ));
                }
            }
            _ => {}
        }
        self.selection_film = Some((w, h));
        // Something to plot from the first frame: the pixel at the image centre.
        let sel = self.selection.get_or_insert(Selection::pixel(w / 2, h / 2));
        *sel = sel.clamped(w, h);
        for p in &mut self.pins {
            *p = p.clamped(w, h);
        }
    }
}

/// The UI thread's time per frame, smoothed: our drawing, the whole frame's CPU time
/// (egui layout, tessellation and painting, as eframe reports it) and the time between
/// frames.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameTiming {
    /// Our `ui()`, ms.
    pub ui_ms: f32,
    /// The previous frame's CPU time including painting (eframe), ms.
    pub cpu_ms: Option<f32>,
    /// From one frame's start to the next, ms (includes waiting for input or vsync).
    pub interval_ms: f32,
    pub(super) last_start: Option<Instant>,
}

impl FrameTiming {
    /// Exponential smoothing: the new value weighs 1/10.
    fn smooth(old: f32, new: f32) -> f32 {
        if old == 0.0 {
            new
        } else {
            0.9 * old + 0.1 * new
        }
    }
}

impl eframe::App for TprfApp {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let started = Instant::now();
        if let Some(last) = self.timing.last_start {
            let gap = started.duration_since(last).as_secs_f32() * 1e3;
            self.timing.interval_ms = FrameTiming::smooth(self.timing.interval_ms, gap);
        }
        self.timing.last_start = Some(started);
        self.remade_this_frame = false;
        if let Some(cpu) = frame.info().cpu_usage {
            let old = self.timing.cpu_ms.unwrap_or(0.0);
            self.timing.cpu_ms = Some(FrameTiming::smooth(old, cpu * 1e3));
        }
        let ctx = ui.ctx().clone();
        self.messages.extend(self.exports.finished());
        self.handle_dropped_files(&ctx);
        self.release_held_film();
        self.settle_camera_gesture(&ctx);
        // An NLOS capture has a view of its own (taken out of the source for the frame,
        // put back unless the frame opened something else).
        if matches!(self.source, Source::Nlos(_))
            && let Source::Nlos(mut view) = std::mem::replace(&mut self.source, Source::None)
        {
            self.nlos_ui(ui, &mut view);
            if matches!(self.source, Source::None) {
                self.source = Source::Nlos(view);
            }
            self.path_prompt_ui(&ctx);
            let ui_ms = started.elapsed().as_secs_f32() * 1e3;
            self.timing.ui_ms = FrameTiming::smooth(self.timing.ui_ms, ui_ms);
            return;
        }
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
            self.follow_film_size(s.width(), s.height());
            if let Some(t) = self.keep_time_s
                && !self.showing_previous_camera()
            {
                match s.axis().bin_of(t) {
                    Some(b) => self.bin = b,
                    None => self.seek_light = true,
                }
                self.keep_time_s = None;
            }
            // In fog every pixel peaks with the backscatter at the start: a scene with
            // media opens where its surfaces' returns arrive (the window's pilot).
            let opening = || {
                self.status()
                    .and_then(|st| st.surface_returns_s)
                    .and_then(|t| s.axis().bin_of(t))
                    .or_else(|| super::timeline::light_bin(s.peak_bins()))
            };
            if self.seek_light
                && let Some(b) = opening()
            {
                self.bin = b.min(bins.saturating_sub(1));
                self.seek_light = false;
            }
        }
        self.handle_keys(&ctx, bins);
        self.advance_playback(&ctx, bins);

        let sensor_mode = self.settings.mode == Mode::Sensor;
        if sensor_mode && let Some(s) = &snap {
            self.sensor.auto_start = matches!(self.source, super::source::Source::Live(_))
                && self.settings.t0.trim().is_empty();
            self.sensor.set_ambient(self.ambient());
            self.sensor.fit_on_open(&mut self.settings.sensor, s.axis());
            self.sensor.update(&self.settings.sensor, s);
        }
        let window_w = ui.available_width();
        egui::Panel::top("top")
            .frame(super::panel_frame(ui))
            .show(ui, |ui| self.top_bar_ui(ui));
        egui::Panel::bottom("status")
            .frame(super::panel_frame(ui))
            .show(ui, |ui| self.status_bar_ui(ui, snap.as_ref()));
        egui::Panel::left("controls")
            .frame(super::panel_frame(ui))
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
            .frame(super::panel_frame(ui))
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
        let phasor_mode = self.settings.mode == Mode::Phasor;
        if let Some(s) = &snap
            && !sensor_mode
            && !phasor_mode
        {
            let axis = *s.axis();
            egui::Panel::bottom("timeline")
                .frame(super::panel_frame(ui))
                .show(ui, |ui| self.scrubber_ui(ui, &axis));
        }
        egui::CentralPanel::default()
            .frame(super::central_frame(ui))
            .show(ui, |ui| match &snap {
                Some(s) if sensor_mode => {
                    let out = sensor::images_ui(ui, &mut self.sensor, s);
                    if let Some((x, y)) = out.clicked {
                        self.select(Selection::pixel(x, y), s);
                    }
                    match out.action {
                        Some(sensor::CoverageAction::ExtendWindow { t0_s, dt_s, bins }) => {
                            self.pending.t0 = format!("{:.6} ns", t0_s * 1e9);
                            self.pending.dt = format!("{:.6} ps", dt_s * 1e12);
                            self.pending.bins = bins;
                            self.messages.push(format!(
                                "rendering again over {:.3} … {:.3} ns to cover the gates",
                                t0_s * 1e9,
                                (t0_s + dt_s * bins as f64) * 1e9
                            ));
                            self.apply_pending();
                        }
                        Some(sensor::CoverageAction::FitGates(e)) => {
                            self.settings.sensor.exposure = e
                        }
                        Some(sensor::CoverageAction::Restore(s)) => self.settings.sensor = *s,
                        None => {}
                    }
                }
                Some(s) if phasor_mode => {
                    use super::phasor::{PhasorInput, phasor_ui};
                    let input = match &self.source {
                        Source::Cube {
                            phasors: Some(p), ..
                        } => PhasorInput::Files {
                            meta: &p.0,
                            data: &p.1,
                            width: s.width(),
                            height: s.height(),
                        },
                        // A window's film and a cube's means are box-binned.
                        _ => PhasorInput::Film {
                            snap: s,
                            filter: tprf_core::film::TimeFilter::Box,
                        },
                    };
                    let clicked = phasor_ui(
                        ui,
                        &mut self.phasor,
                        input,
                        &mut self.settings.phasor,
                        &mut self.settings.phasor_index,
                    );
                    if let Some((x, y)) = clicked {
                        self.select(Selection::pixel(x, y), s);
                    }
                }
                Some(s) => self.images_ui(ui, s),
                None => {
                    ui.centered_and_justified(|ui| {
                        match (self.status().map(|s| s.state), &empty) {
                            (Some(WorkerState::Failed(e)), _) => ui.label(
                                RichText::new(format!("Render failed: {e}"))
                                    .color(ui.visuals().error_fg_color),
                            ),
                            (_, Some(m)) => {
                                ui.label(RichText::new(m).color(ui.visuals().error_fg_color))
                            }
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
                        }
                    });
                }
            });
        self.path_prompt_ui(&ctx);
        if let Some(WorkerState::Failed(e)) = self.status().map(|s| s.state) {
            let m = format!("render failed: {e}");
            if !self.messages.contains(&m) {
                self.messages.push(m);
            }
        }
        let ui_ms = started.elapsed().as_secs_f32() * 1e3;
        self.timing.ui_ms = FrameTiming::smooth(self.timing.ui_ms, ui_ms);
    }

    /// A frame's input cut at a Tab (see `viewer::input`): the events held back last
    /// frame come first, and what this one holds back waits for the next, which is
    /// asked for at once.
    fn raw_input_hook(&mut self, ctx: &egui::Context, raw_input: &mut egui::RawInput) {
        if !self.deferred_input.is_empty() {
            let mut events = std::mem::take(&mut self.deferred_input);
            events.append(&mut raw_input.events);
            raw_input.events = events;
        }
        self.deferred_input = super::input::split_at_tab(&mut raw_input.events);
        if !self.deferred_input.is_empty() {
            ctx.request_repaint();
        }
    }

    /// The panels' colour, which they leave to the clear ([`super::background`]).
    fn clear_color(&self, visuals: &egui::Visuals) -> [f32; 4] {
        super::background(visuals).to_normalized_gamma_f32()
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, eframe::APP_KEY, &self.settings);
    }
}

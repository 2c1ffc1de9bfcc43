//! The application: layout, widgets, and the glue between the worker and the screen.

use super::Start;
use super::colormap::{self, ColorMap, ExposureMode, Tone};
use super::sensor_ui::{self, SensorState};
use super::timeline::{TimeRuler, bin_label, nice_ticks_s};
use eframe::egui::{self, Color32, RichText, Sense, TextureHandle, TextureOptions, Vec2};
use egui_plot::{Legend, Line, Plot, PlotPoints, VLine};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;
use tprf_core::export::{self, CubeMetadata};
use tprf_core::film::{FilmSnapshot, TimeAxis};
use tprf_core::scene::Channel;
use tprf_core::sensor::Sensor;
use tprf_core::transport::worker::{RenderJob, RenderWorker, WorkerState, WorkerStatus};
use tprf_core::transport::{RenderSettings, WindowRequest};
use tprf_core::units::{C_M_PER_S, format_time, parse_time_s};

/// Everything the viewer remembers between runs (eframe storage).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ViewerSettings {
    pub scene: String,
    pub width: usize,
    pub height: usize,
    pub bins: usize,
    /// Window start and bin width with units ("" = automatic).
    pub t0: String,
    pub dt: String,
    /// Samples per pixel to stop at (0 = keep going).
    pub spp_target: u64,
    pub max_bounces: u32,
    pub channel: Channel,
    pub seed: u64,
    /// Playback speed, bins per second.
    pub play_bins_per_s: f32,
    pub looping: bool,
    pub exposure: ExposureMode,
    /// Exposure offset in stops.
    pub ev: f32,
    pub log_image: bool,
    pub colormap: ColorMap,
    pub plot_log: bool,
    /// Per-bounce curves shown: 1, 2, 3, >3 scattering events.
    pub show_bounces: [bool; 4],
    /// What the window shows: light in flight, or the sensor's measurements.
    pub mode: Mode,
    /// The sensor being edited (Light, gates, noise).
    pub sensor: Sensor,
}

/// The window's two views of the film.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mode {
    /// Time slices, steady and rainbow images, TPRF plots.
    Transient,
    /// Light(t), Exposure_i(t) and the measurements M_i (the paper's section 6).
    Sensor,
}

impl Default for ViewerSettings {
    fn default() -> Self {
        ViewerSettings {
            scene: "builtin:cornell".into(),
            width: 128,
            height: 128,
            bins: 256,
            t0: String::new(),
            dt: String::new(),
            spp_target: 0,
            max_bounces: 1024,
            channel: Channel::Gray,
            seed: 0,
            play_bins_per_s: 30.0,
            looping: true,
            exposure: ExposureMode::PerFrame,
            ev: 0.0,
            log_image: false,
            colormap: ColorMap::Inferno,
            plot_log: false,
            show_bounces: [true, true, true, true],
            mode: Mode::Transient,
            sensor: Sensor::builtin("lidar").expect("the built-in LiDAR preset parses"),
        }
    }
}

/// Largest image side and bin count the viewer accepts.
const MAX_SIDE: usize = 4096;
const MAX_BINS: usize = 16384;

impl ViewerSettings {
    /// Clamp values a stored file or a widget could have made absurd.
    fn sanitized(mut self) -> Self {
        self.width = self.width.clamp(1, MAX_SIDE);
        self.height = self.height.clamp(1, MAX_SIDE);
        self.bins = self.bins.clamp(1, MAX_BINS);
        self.max_bounces = self.max_bounces.clamp(1, 100_000);
        if !(self.play_bins_per_s.is_finite() && self.play_bins_per_s > 0.0) {
            self.play_bins_per_s = 30.0;
        }
        if !self.ev.is_finite() {
            self.ev = 0.0;
        }
        self
    }

    /// These settings with the render ones (scene, size, window, spp, bounces, band,
    /// seed) taken from `other`: what "Apply & restart" applies. Display and sensor
    /// settings take effect at once and are not part of it.
    fn with_render_of(&self, other: &ViewerSettings) -> ViewerSettings {
        ViewerSettings {
            scene: other.scene.clone(),
            width: other.width,
            height: other.height,
            bins: other.bins,
            t0: other.t0.clone(),
            dt: other.dt.clone(),
            spp_target: other.spp_target,
            max_bounces: other.max_bounces,
            channel: other.channel,
            seed: other.seed,
            ..self.clone()
        }
    }

    /// The render job these settings describe, or what is wrong with them.
    fn job(&self) -> Result<RenderJob, String> {
        let parse = |s: &str, what: &str| -> Result<Option<f64>, String> {
            if s.trim().is_empty() {
                Ok(None)
            } else {
                parse_time_s(s)
                    .map(Some)
                    .map_err(|e| format!("{what}: {e}"))
            }
        };
        let t0_s = parse(&self.t0, "window start")?;
        let dt_s = parse(&self.dt, "bin width")?;
        if let Some(dt) = dt_s
            && dt <= 0.0
        {
            return Err("bin width must be > 0".into());
        }
        Ok(RenderJob {
            scene: self.scene.clone(),
            width: self.width,
            height: self.height,
            window: WindowRequest {
                t0_s,
                dt_s,
                bins: self.bins,
            },
            bounces_separate: 3,
            settings: RenderSettings {
                max_bounces: self.max_bounces,
                seed: self.seed,
                channel: self.channel,
                ..Default::default()
            },
            spp_target: (self.spp_target > 0).then_some(self.spp_target),
        })
    }
}

/// A pixel box on the image (inclusive); one pixel when both corners agree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Selection {
    pub x0: usize,
    pub y0: usize,
    pub x1: usize,
    pub y1: usize,
}

impl Selection {
    pub fn pixel(x: usize, y: usize) -> Selection {
        Selection {
            x0: x,
            y0: y,
            x1: x,
            y1: y,
        }
    }
    fn normalized(self) -> Selection {
        Selection {
            x0: self.x0.min(self.x1),
            y0: self.y0.min(self.y1),
            x1: self.x0.max(self.x1),
            y1: self.y0.max(self.y1),
        }
    }
    /// The box moved inside a `w x h` image.
    fn clamped(self, w: usize, h: usize) -> Selection {
        let (mx, my) = (w.saturating_sub(1), h.saturating_sub(1));
        Selection {
            x0: self.x0.min(mx),
            y0: self.y0.min(my),
            x1: self.x1.min(mx),
            y1: self.y1.min(my),
        }
    }
    fn label(&self) -> String {
        let s = self.normalized();
        if s.x0 == s.x1 && s.y0 == s.y1 {
            format!("pixel ({}, {})", s.x0, s.y0)
        } else {
            format!("box ({}, {})–({}, {})", s.x0, s.y0, s.x1, s.y1)
        }
    }
    /// Mean TPRF over the box (`layer` None = total).
    pub fn tprf(&self, snap: &FilmSnapshot, layer: Option<usize>) -> Vec<f64> {
        let s = self.normalized();
        snap.box_mean(s.x0, s.y0, s.x1, s.y1, layer)
    }
}

/// Where the film comes from.
enum Source {
    Live(RenderWorker),
    Cube {
        dir: PathBuf,
        snapshot: Arc<FilmSnapshot>,
        meta: Box<CubeMetadata>,
    },
    None,
}

/// Which image a texture shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum View {
    Slice,
    Steady,
    Rainbow,
}

/// A texture and what it was made from, so it is rebuilt only when that changes.
struct CachedTexture {
    key: (usize, usize, u64),
    handle: TextureHandle,
}

const PIN_COLORS: [Color32; 6] = [
    Color32::from_rgb(0x4e, 0xc9, 0xff),
    Color32::from_rgb(0xff, 0x9f, 0x43),
    Color32::from_rgb(0x7b, 0xe0, 0x7b),
    Color32::from_rgb(0xff, 0x6b, 0xd6),
    Color32::from_rgb(0xff, 0xe0, 0x66),
    Color32::from_rgb(0xb0, 0x9c, 0xff),
];
const BOUNCE_COLORS: [Color32; 4] = [
    Color32::from_rgb(0xff, 0x55, 0x55),
    Color32::from_rgb(0x55, 0xdd, 0x55),
    Color32::from_rgb(0x66, 0x99, 0xff),
    Color32::from_rgb(0xcc, 0xcc, 0xcc),
];

/// The tprf window.
pub struct TprfApp {
    /// Settings in effect (persisted).
    pub settings: ViewerSettings,
    /// Settings being edited in the render panel; applied with "Apply".
    pub pending: ViewerSettings,
    source: Source,
    /// The scrubber's bin.
    pub bin: usize,
    pub playing: bool,
    play_accum: f32,
    /// The selected pixel or box, and pinned ones.
    pub selection: Option<Selection>,
    pub pins: Vec<Selection>,
    drag_start: Option<(usize, usize)>,
    textures: Vec<(View, CachedTexture)>,
    global_scale: Option<(usize, f64)>,
    messages: Vec<String>,
    frame_ms: f32,
    /// The sensor's model, measurements and textures.
    pub sensor: SensorState,
    ctx: egui::Context,
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
            textures: Vec::new(),
            global_scale: None,
            messages: Vec::new(),
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

    /// The film on screen now.
    pub fn snapshot(&self) -> Option<Arc<FilmSnapshot>> {
        match &self.source {
            Source::Live(w) => w.latest(),
            Source::Cube { snapshot, .. } => Some(snapshot.clone()),
            Source::None => None,
        }
    }

    /// The render worker's progress (None for a loaded cube).
    pub fn status(&self) -> Option<WorkerStatus> {
        match &self.source {
            Source::Live(w) => w.status(),
            _ => None,
        }
    }

    /// Errors and notes shown in the window.
    pub fn messages(&self) -> &[String] {
        &self.messages
    }

    fn apply_pending(&mut self) {
        let pending = self.settings.with_render_of(&self.pending).sanitized();
        match pending.job() {
            Ok(_) => {
                self.settings = pending.clone();
                self.pending = pending;
                self.restart();
            }
            Err(e) => self.messages.push(e),
        }
    }

    /// (Re)start the render of the current settings; the old worker is dropped (it ends
    /// by itself after its pass) and the window goes on drawing.
    fn restart(&mut self) {
        match self.settings.job() {
            Ok(job) => {
                let ctx = self.ctx.clone();
                self.source = Source::Live(RenderWorker::spawn(job, move || ctx.request_repaint()));
                self.textures.clear();
                self.global_scale = None;
            }
            Err(e) => self.messages.push(e),
        }
    }

    fn open_cube(&mut self, dir: &Path) {
        match export::load_snapshot(dir) {
            Ok((meta, snapshot)) => {
                self.bin = self.bin.min(snapshot.axis().bins.saturating_sub(1));
                self.source = Source::Cube {
                    dir: dir.to_path_buf(),
                    snapshot: Arc::new(snapshot),
                    meta: Box::new(meta),
                };
                self.textures.clear();
                self.global_scale = None;
                self.selection = None;
                self.pins.clear();
            }
            Err(e) => self.messages.push(format!(
                "cannot open cube {}: {:#}",
                dir.display(),
                anyhow::Error::from(e)
            )),
        }
    }

    fn open_scene(&mut self, scene: String) {
        self.pending.scene = scene;
        self.selection = None;
        self.pins.clear();
        self.apply_pending();
    }

    /// Tone for the current view settings.
    fn tone(&mut self, snap: &Arc<FilmSnapshot>, frame_values: Option<&[f32]>) -> Tone {
        let base = match (self.settings.exposure, frame_values) {
            (ExposureMode::PerFrame, Some(v)) => {
                colormap::quantile_positive(v.iter().copied(), 0.995)
            }
            _ => {
                let key = Arc::as_ptr(snap) as usize;
                match self.global_scale {
                    Some((k, s)) if k == key => Some(s),
                    _ => {
                        let s = snap.robust_max();
                        if let Some(s) = s {
                            self.global_scale = Some((key, s));
                        }
                        s
                    }
                }
            }
        };
        let scale = base.map_or(1.0, |b| 1.0 / b) * 2f64.powf(self.settings.ev as f64);
        Tone {
            scale,
            log: self.settings.log_image,
            decades: 3.0,
        }
    }

    fn tone_key(&self) -> u64 {
        let s = &self.settings;
        (s.ev.to_bits() as u64)
            ^ ((s.log_image as u64) << 40)
            ^ ((s.exposure as u64) << 41)
            ^ ((s.colormap as u64) << 42)
    }

    /// The texture of `view`, rebuilt when the snapshot, bin or tone changed.
    fn texture(&mut self, view: View, snap: &Arc<FilmSnapshot>) -> TextureHandle {
        let bin = if view == View::Slice {
            self.bin
        } else {
            usize::MAX
        };
        let key = (Arc::as_ptr(snap) as usize, bin, self.tone_key());
        if let Some((_, t)) = self
            .textures
            .iter()
            .find(|(v, t)| *v == view && t.key == key)
        {
            return t.handle.clone();
        }
        let rgba = self.view_pixels(view, snap);
        let image = egui::ColorImage::from_rgba_unmultiplied([snap.width(), snap.height()], &rgba);
        let options = TextureOptions::NEAREST;
        if let Some((_, t)) = self.textures.iter_mut().find(|(v, _)| *v == view) {
            t.handle.set(image, options);
            t.key = key;
            return t.handle.clone();
        }
        let handle = self.ctx.load_texture(format!("{view:?}"), image, options);
        self.textures.push((
            view,
            CachedTexture {
                key,
                handle: handle.clone(),
            },
        ));
        handle
    }

    fn view_pixels(&mut self, view: View, snap: &Arc<FilmSnapshot>) -> Vec<u8> {
        match view {
            View::Slice => {
                let values = snap.slice(self.bin);
                let tone = self.tone(snap, Some(&values));
                colormap::colorize(&values, &tone, self.settings.colormap)
            }
            View::Steady => {
                let values = snap.steady();
                let base = colormap::quantile_positive(values.iter().copied(), 0.99)
                    .map_or(1.0, |b| 0.8 / b);
                let tone = Tone {
                    scale: base * 2f64.powf(self.settings.ev as f64),
                    log: self.settings.log_image,
                    decades: 3.0,
                };
                colormap::colorize(values, &tone, ColorMap::Gray)
            }
            View::Rainbow => {
                let base = colormap::quantile_positive(snap.steady().iter().copied(), 0.99)
                    .map_or(1.0, |b| 1.0 / b);
                let tone = Tone {
                    scale: base * 2f64.powf(self.settings.ev as f64),
                    log: false,
                    decades: 3.0,
                };
                colormap::rainbow(snap.peak_bins(), snap.steady(), snap.axis().bins, &tone)
            }
        }
    }

    fn step(&mut self, delta: i64, bins: usize) {
        if bins == 0 {
            return;
        }
        let b = self.bin as i64 + delta;
        self.bin = if self.settings.looping {
            b.rem_euclid(bins as i64) as usize
        } else {
            b.clamp(0, bins as i64 - 1) as usize
        };
    }

    fn handle_keys(&mut self, ctx: &egui::Context, bins: usize) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        let (left, right, space) = ctx.input(|i| {
            (
                i.key_pressed(egui::Key::ArrowLeft),
                i.key_pressed(egui::Key::ArrowRight),
                i.key_pressed(egui::Key::Space),
            )
        });
        if self.settings.mode == Mode::Sensor {
            // In sensor mode the arrows step the gate shown.
            let gates = self.sensor.model().map_or(1, |m| m.gate_count());
            if left {
                self.sensor.gate = self.sensor.gate.saturating_sub(1);
            }
            if right {
                self.sensor.gate = (self.sensor.gate + 1).min(gates.saturating_sub(1));
            }
            return;
        }
        if left {
            self.playing = false;
            self.step(-1, bins);
        }
        if right {
            self.playing = false;
            self.step(1, bins);
        }
        if space {
            self.playing = !self.playing;
        }
    }

    fn advance_playback(&mut self, ctx: &egui::Context, bins: usize) {
        if !self.playing || bins == 0 {
            return;
        }
        let dt = ctx.input(|i| i.stable_dt).min(0.1);
        self.play_accum += dt * self.settings.play_bins_per_s;
        let steps = self.play_accum.floor();
        if steps >= 1.0 {
            self.play_accum -= steps;
            let before = self.bin;
            self.step(steps as i64, bins);
            if !self.settings.looping && self.bin == before {
                self.playing = false;
            }
        }
        ctx.request_repaint();
    }

    fn handle_dropped_files(&mut self, ctx: &egui::Context) {
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .filter(|p| !p.as_os_str().is_empty())
                .collect()
        });
        for path in dropped {
            if path.is_dir() {
                self.open_cube(&path);
            } else if matches!(
                path.extension()
                    .and_then(|e| e.to_str())
                    .map(|e| e.to_ascii_lowercase())
                    .as_deref(),
                Some("gltf" | "glb")
            ) {
                self.open_scene(path.display().to_string());
            } else {
                self.messages.push(format!(
                    "{}: drop a .gltf/.glb file or a cube folder",
                    path.display()
                ));
            }
        }
    }

    // ---- panels -------------------------------------------------------------------

    fn top_bar_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            ui.strong("tprf");
            ui.separator();
            ui.selectable_value(&mut self.settings.mode, Mode::Transient, "Transient")
                .on_hover_text("Light in flight: time slices and TPRF plots");
            ui.selectable_value(&mut self.settings.mode, Mode::Sensor, "Sensor")
                .on_hover_text(
                    "Light(t), Exposure_i(t) and the measurements M_i, from the cached TPRFs",
                );
            ui.separator();
            if ui
                .button("Open glTF…")
                .on_hover_text("Render a .gltf/.glb scene (or drop one on the window)")
                .clicked()
                && let Some(p) = rfd::FileDialog::new()
                    .add_filter("glTF", &["gltf", "glb"])
                    .pick_file()
            {
                self.open_scene(p.display().to_string());
            }
            if ui
                .button("Open cube…")
                .on_hover_text("Show a folder written by `tprf render`")
                .clicked()
                && let Some(p) = rfd::FileDialog::new().pick_folder()
            {
                self.open_cube(&p);
            }
            for name in tprf_core::scene::builtin::NAMES {
                if ui.button(format!("builtin:{name}")).clicked() {
                    self.open_scene(format!("builtin:{name}"));
                }
            }
            ui.separator();
            match &self.source {
                Source::Live(w) => {
                    let paused = w.is_paused();
                    if ui
                        .button(if paused { "▶ Resume" } else { "⏸ Pause" })
                        .clicked()
                    {
                        w.set_paused(!paused);
                    }
                    if ui.button("⟲ Restart").clicked() {
                        self.restart();
                    }
                }
                Source::Cube { dir, .. } => {
                    ui.label(format!("cube: {}", dir.display()));
                }
                Source::None => {}
            }
        });
    }

    /// spp, passes/s, elapsed time, error estimate and frame time.
    pub fn status_line(&self, snap: Option<&Arc<FilmSnapshot>>) -> String {
        let mut parts = Vec::new();
        if let Some(s) = self.status() {
            let state = match &s.state {
                WorkerState::Loading => "loading".to_string(),
                WorkerState::Rendering => "rendering".to_string(),
                WorkerState::Paused => "paused".to_string(),
                WorkerState::Done => "done".to_string(),
                WorkerState::Failed(e) => format!("failed: {e}"),
            };
            parts.push(state);
            parts.push(format!("{} spp", s.spp));
            parts.push(format!("{:.1} passes/s", s.passes_per_s));
            parts.push(format!("{:.1} s", s.elapsed_s));
            parts.push(format!(
                "{:.1} Mrays/s",
                s.rays as f64 / s.elapsed_s.max(1e-9) / 1e6
            ));
        } else if let Source::Cube { dir, meta, .. } = &self.source {
            parts.push(format!(
                "cube {} · {} · {} spp · rendered in {:.1} s",
                dir.display(),
                meta.scene,
                meta.spp,
                meta.wall_seconds
            ));
        }
        if let Some(e) = snap.and_then(|s| s.error_estimate) {
            parts.push(format!("error ≈ {:.2} %", 100.0 * e));
        }
        parts.push(format!("frame {:.1} ms", self.frame_ms));
        parts.join("  ·  ")
    }

    fn controls_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Scene");
        ui.label(RichText::new(&self.settings.scene).monospace());
        if let Some(s) = self.status() {
            ui.label(format!("{} triangles", s.triangles));
            for n in &s.notes {
                ui.label(RichText::new(format!("note: {n}")).small().weak());
            }
        }
        ui.separator();
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
        ui.separator();
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
        ui.separator();
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
        if !self.messages.is_empty() {
            ui.separator();
            ui.heading("Messages");
            let mut clear = false;
            for m in &self.messages {
                ui.label(RichText::new(m).color(ui.visuals().warn_fg_color));
            }
            if ui.button("Clear").clicked() {
                clear = true;
            }
            if clear {
                self.messages.clear();
            }
        }
    }

    fn save_view_png(&mut self, view: View, snap: &Arc<FilmSnapshot>) {
        let Some(path) = rfd::FileDialog::new()
            .add_filter("PNG", &["png"])
            .set_file_name("tprf.png")
            .save_file()
        else {
            return;
        };
        let rgba = self.view_pixels(view, snap);
        let result = image::RgbaImage::from_raw(snap.width() as u32, snap.height() as u32, rgba)
            .ok_or_else(|| anyhow::anyhow!("image size mismatch"))
            .and_then(|img| {
                export::write_atomic(&path, |w| {
                    img.write_to(w, image::ImageFormat::Png)?;
                    Ok(())
                })
                .map_err(anyhow::Error::from)
            });
        if let Err(e) = result {
            self.messages.push(format!("{e:#}"));
        }
    }

    /// Every bin as a PNG in a folder plus an animated GIF, with one global exposure.
    fn save_video(&mut self, snap: &Arc<FilmSnapshot>) {
        let Some(dir) = rfd::FileDialog::new().pick_folder() else {
            return;
        };
        let result = (|| -> anyhow::Result<()> {
            let scale = snap.robust_max().map_or(1.0, |b| 1.0 / b);
            let tone = Tone {
                scale: scale * 2f64.powf(self.settings.ev as f64),
                log: self.settings.log_image,
                decades: 3.0,
            };
            let (w, h) = (snap.width() as u32, snap.height() as u32);
            let gif_path = dir.join("tprf.gif");
            let mut frames = Vec::new();
            for b in 0..snap.axis().bins {
                let rgba = colormap::colorize(&snap.slice(b), &tone, self.settings.colormap);
                let img = image::RgbaImage::from_raw(w, h, rgba)
                    .ok_or_else(|| anyhow::anyhow!("image size mismatch"))?;
                export::write_atomic(&dir.join(format!("{b:04}.png")), |out| {
                    img.write_to(out, image::ImageFormat::Png)?;
                    Ok(())
                })?;
                frames.push(image::Frame::from_parts(
                    img,
                    0,
                    0,
                    image::Delay::from_numer_denom_ms(1000, 30),
                ));
            }
            export::write_atomic(&gif_path, |out| {
                let mut enc = image::codecs::gif::GifEncoder::new(out);
                enc.set_repeat(image::codecs::gif::Repeat::Infinite)?;
                enc.encode_frames(frames)?;
                Ok(())
            })?;
            Ok(())
        })();
        if let Err(e) = result {
            self.messages.push(format!("{e:#}"));
        }
    }

    fn timeline_ui(&mut self, ui: &mut egui::Ui, axis: &TimeAxis) {
        let bins = axis.bins;
        ui.horizontal(|ui| {
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
            ui.add(
                egui::Slider::new(&mut self.settings.play_bins_per_s, 1.0..=240.0)
                    .logarithmic(true)
                    .text("bins/s"),
            );
            ui.separator();
            ui.label(
                RichText::new(format!(
                    "bin {} / {}   t = {}",
                    self.bin,
                    bins,
                    bin_label(axis, self.bin)
                ))
                .monospace(),
            );
        });
        // The scrub bar: drag or click anywhere on it.
        let (rect, response) = ui.allocate_exact_size(
            Vec2::new(ui.available_width(), 28.0),
            Sense::click_and_drag(),
        );
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
        let font = egui::FontId::proportional(10.0);
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
            (2.0, Color32::from_rgb(0xff, 0x9f, 0x43)),
        );
        response
            .widget_info(|| egui::WidgetInfo::labeled(egui::Role::Slider, true, "time scrubber"));
    }

    /// One image with pixel picking; returns nothing, updates the selection.
    fn image_ui(
        &mut self,
        ui: &mut egui::Ui,
        view: View,
        snap: &Arc<FilmSnapshot>,
        max: Vec2,
        label: &str,
    ) {
        let tex = self.texture(view, snap);
        let (w, h) = (snap.width() as f32, snap.height() as f32);
        let scale = (max.x / w).min(max.y / h).max(0.01);
        let size = Vec2::new(w * scale, h * scale);
        let response = ui.add(egui::Image::new((tex.id(), size)).sense(Sense::click_and_drag()));
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, label));
        let to_pixel = |pos: egui::Pos2| -> (usize, usize) {
            let p = (pos - response.rect.min) / scale;
            (
                (p.x.max(0.0) as usize).min(snap.width() - 1),
                (p.y.max(0.0) as usize).min(snap.height() - 1),
            )
        };
        if response.drag_started()
            && let Some(pos) = response.interact_pointer_pos()
        {
            self.drag_start = Some(to_pixel(pos));
        }
        if let (Some(start), Some(pos)) = (self.drag_start, response.interact_pointer_pos())
            && response.dragged()
        {
            let end = to_pixel(pos);
            self.selection = Some(
                Selection {
                    x0: start.0,
                    y0: start.1,
                    x1: end.0,
                    y1: end.1,
                }
                .normalized(),
            );
        }
        if response.drag_stopped() {
            self.drag_start = None;
        }
        if response.clicked()
            && let Some(pos) = response.interact_pointer_pos()
        {
            let (x, y) = to_pixel(pos);
            self.selection = Some(Selection::pixel(x, y));
        }
        // Outline the selection and pins.
        let painter = ui.painter_at(response.rect);
        let outline = |s: &Selection, color: Color32| {
            let s = s.normalized();
            let min = response.rect.min + Vec2::new(s.x0 as f32, s.y0 as f32) * scale;
            let max = response.rect.min + Vec2::new((s.x1 + 1) as f32, (s.y1 + 1) as f32) * scale;
            painter.rect_stroke(
                egui::Rect::from_min_max(min, max).expand(1.0),
                0.0,
                (1.5, color),
                egui::StrokeKind::Outside,
            );
        };
        for (i, p) in self.pins.iter().enumerate() {
            outline(p, PIN_COLORS[(i + 1) % PIN_COLORS.len()]);
        }
        if let Some(s) = &self.selection {
            outline(s, PIN_COLORS[0]);
        }
        if let Some(pos) = response.hover_pos() {
            let (x, y) = to_pixel(pos);
            let v = snap.pixel(x, y).get(self.bin).copied().unwrap_or(0.0);
            response.on_hover_text(format!(
                "({x}, {y})  slice {v:.4e}  steady {:.4e}",
                snap.pixel(x, y).iter().map(|&v| v as f64).sum::<f64>()
            ));
        }
    }

    fn images_ui(&mut self, ui: &mut egui::Ui, snap: &Arc<FilmSnapshot>) {
        let avail = ui.available_size();
        let side_w = (avail.x * 0.3).max(120.0);
        ui.horizontal_top(|ui| {
            ui.vertical(|ui| {
                ui.label(
                    RichText::new(format!("Time slice · {}", bin_label(snap.axis(), self.bin)))
                        .strong(),
                );
                let max = Vec2::new(avail.x - side_w - 16.0, avail.y - 24.0);
                self.image_ui(ui, View::Slice, snap, max, "time slice");
            });
            ui.vertical(|ui| {
                let max = Vec2::new(side_w, (avail.y - 60.0) / 2.0);
                ui.label(RichText::new("Steady state (sum over time)").strong());
                self.image_ui(ui, View::Steady, snap, max, "steady image");
                ui.label(RichText::new("Rainbow (hue = peak arrival)").strong());
                self.image_ui(ui, View::Rainbow, snap, max, "rainbow image");
            });
        });
    }

    /// The curves the TPRF plot shows: (name, colour, values per bin).
    pub fn plotted_curves(&self, snap: &FilmSnapshot) -> Vec<(String, Color32, Vec<f64>)> {
        let mut curves = Vec::new();
        if let Some(sel) = &self.selection {
            curves.push((sel.label(), PIN_COLORS[0], sel.tprf(snap, None)));
            if snap.layers() >= 5 {
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

    fn plot_ui(&mut self, ui: &mut egui::Ui, snap: &Arc<FilmSnapshot>) {
        ui.heading("TPRF");
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut self.settings.plot_log, "log");
            for (k, name) in ["1", "2", "3", ">3"].iter().enumerate() {
                ui.checkbox(
                    &mut self.settings.show_bounces[k],
                    RichText::new(*name).color(BOUNCE_COLORS[k]),
                );
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
                self.export_csv(snap);
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
        let response = Plot::new("tprf-plot")
            .height(plot_h)
            .legend(Legend::default())
            .allow_drag(false)
            .x_axis_label("arrival time (ns)")
            .y_axis_label(if log {
                "log10 radiance per bin"
            } else {
                "radiance per bin"
            })
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
                    "{name}\n{t_ns:.3} ns · {:.3} m\n{v:.4e}",
                    t_ns * 1e-9 * C_M_PER_S
                ))
            })
            .include_x(axis.t0_s * 1e9)
            .include_x(axis.end_s() * 1e9)
            .show(ui, |plot_ui| {
                for (name, color, values) in &curves {
                    plot_ui.line(
                        Line::new(name.clone(), step_points(&axis, values, log_floor))
                            .color(*color),
                    );
                }
                plot_ui.vline(
                    VLine::new("scrubber", axis.bin_center_s(bin_now) * 1e9)
                        .color(Color32::from_rgb(0xff, 0x9f, 0x43)),
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
    fn sensor_plots_ui(&mut self, ui: &mut egui::Ui, snap: &Arc<FilmSnapshot>) {
        let sel = self.selection.unwrap_or(Selection::pixel(0, 0));
        ui.heading(format!("Sensor · {}", sel.label()));
        let tprf: Vec<f32> = sel.tprf(snap, None).into_iter().map(|v| v as f32).collect();
        // With noise once all gates are measured; until then the clean values.
        let m_pixel = match self.sensor.measurements() {
            Some(m) if self.sensor.is_current(snap) => m.pixel(sel.y0, sel.x0),
            _ => Vec::new(),
        };
        let h = ui.available_height();
        ui.label(
            RichText::new("Drag the handles: Light(t) and the gates over the pixel's TPRF").small(),
        );
        sensor_ui::editor_ui(
            ui,
            &mut self.sensor,
            &mut self.settings.sensor,
            &tprf,
            snap.axis(),
            (h * 0.42).max(160.0),
        );
        sensor_ui::pixel_plots_ui(
            ui,
            &mut self.sensor,
            &tprf,
            &m_pixel,
            snap.axis(),
            (h * 0.2).max(90.0),
        );
    }

    fn error_plot_ui(&mut self, ui: &mut egui::Ui) {
        let Some(status) = self.status() else {
            return;
        };
        if status.error_history.is_empty() {
            return;
        }
        ui.label(RichText::new("Error estimate (two half buffers) against time").small());
        let pts: PlotPoints = status
            .error_history
            .iter()
            .filter(|(t, e)| *t > 0.0 && *e > 0.0)
            .map(|(t, e)| [t.log10(), e.log10()])
            .collect();
        Plot::new("error-plot")
            .height(110.0)
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .x_axis_label("log10 s")
            .y_axis_label("log10 rel. error")
            .show(ui, |plot_ui| plot_ui.line(Line::new("error", pts)));
    }

    fn export_csv(&mut self, snap: &Arc<FilmSnapshot>) {
        let Some(path) = rfd::FileDialog::new()
            .add_filter("CSV", &["csv"])
            .set_file_name("tprf.csv")
            .save_file()
        else {
            return;
        };
        let curves = self.plotted_curves(snap);
        let axis = *snap.axis();
        let result = export::write_atomic(&path, |w| {
            use std::io::Write;
            write!(w, "bin,t_start_s,t_center_ns,opl_m")?;
            for (name, _, _) in &curves {
                write!(w, ",\"{}\"", name.replace('"', "'"))?;
            }
            writeln!(w)?;
            for b in 0..axis.bins {
                let t = axis.bin_center_s(b);
                write!(
                    w,
                    "{b},{:e},{:.6},{:.6}",
                    axis.bin_start_s(b),
                    t * 1e9,
                    t * C_M_PER_S
                )?;
                for (_, _, v) in &curves {
                    write!(w, ",{:e}", v.get(b).copied().unwrap_or(0.0))?;
                }
                writeln!(w)?;
            }
            Ok(())
        });
        if let Err(e) = result {
            self.messages.push(format!("{:#}", anyhow::Error::from(e)));
        }
    }
}

impl eframe::App for TprfApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let started = Instant::now();
        let ctx = ui.ctx().clone();
        self.handle_dropped_files(&ctx);
        let snap = self.snapshot();
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
        egui::Panel::bottom("status").show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.label(RichText::new(self.status_line(snap.as_ref())).small());
                // The latest error stays in sight (all of them: the left panel).
                if let Some(m) = self.messages.last() {
                    ui.separator();
                    ui.label(RichText::new(m).small().color(ui.visuals().error_fg_color));
                }
            });
        });
        egui::Panel::left("controls")
            .resizable(true)
            .default_size(250.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    if sensor_mode {
                        let axis = snap.as_ref().map(|s| *s.axis());
                        if let Some(m) =
                            sensor_ui::controls_ui(ui, &mut self.settings.sensor, axis.as_ref())
                        {
                            self.messages.push(m);
                        }
                        if let Some(e) = &self.sensor.error {
                            ui.label(RichText::new(e).color(ui.visuals().error_fg_color));
                        }
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
            egui::Panel::bottom("timeline").show(ui, |ui| self.timeline_ui(ui, &axis));
        }
        egui::CentralPanel::default().show(ui, |ui| match &snap {
            Some(s) if sensor_mode => {
                if let Some((x, y)) = sensor_ui::images_ui(ui, &mut self.sensor, s) {
                    self.selection = Some(Selection::pixel(x, y));
                }
            }
            Some(s) => self.images_ui(ui, s),
            None => {
                ui.centered_and_justified(|ui| match self.status().map(|s| s.state) {
                    Some(WorkerState::Failed(e)) => ui.label(
                        RichText::new(format!("Render failed: {e}"))
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

/// A binned curve as steps: each bin a flat segment over its time span (ns), because a
/// bin holds the integral over its interval, not a point sample. With `log_floor`, the
/// values are log10 and empty bins sit at the floor.
fn step_points(axis: &TimeAxis, values: &[f64], log_floor: Option<f64>) -> PlotPoints<'static> {
    let mut pts = Vec::with_capacity(2 * values.len());
    for (b, &v) in values.iter().enumerate() {
        let y = match log_floor {
            Some(floor) => v.max(floor).log10(),
            None => v,
        };
        let t0_ns = axis.bin_start_s(b) * 1e9;
        pts.push([t0_ns, y]);
        pts.push([t0_ns + axis.dt_s * 1e9, y]);
    }
    PlotPoints::from(pts)
}

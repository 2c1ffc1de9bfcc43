//! Where the film comes from: a render worker started from the settings, or a cube
//! written by `tprf render` and loaded from disk; opening scenes, cubes and dropped files.

use super::app::TprfApp;
use eframe::egui;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tprf_core::export::phasor::PhasorMetadata;
use tprf_core::export::{self, CubeMetadata};
use tprf_core::film::FilmSnapshot;
use tprf_core::request::worker::{RenderWorker, WorkerState, WorkerStatus};
use tprf_core::request::{RenderRequest, time_field_text};
use tprf_core::transport::ambient::AmbientImage;

/// Where the film comes from.
pub(super) enum Source {
    /// A render in progress (or done) on a background thread.
    Live(RenderWorker),
    /// A cube loaded from `dir`: no renderer runs.
    Cube {
        dir: PathBuf,
        snapshot: Arc<FilmSnapshot>,
        meta: Box<CubeMetadata>,
        /// `ambient.npy` (or `tprf.zarr/ambient`) when the folder has one.
        ambient: Option<Arc<AmbientImage>>,
        /// `phasor.json` and `phasor.npy` (or `tprf.zarr/phasor`), `[H, W, F, 2]`, when
        /// the folder has them.
        phasors: Option<Arc<(PhasorMetadata, Vec<f32>)>>,
    },
    /// An NLOS capture (`nlos.hdf5`) and its reconstruction thread: no renderer runs.
    Nlos(Box<super::nlos::NlosView>),
    /// Nothing yet (the settings could not start a render).
    None,
}

impl TprfApp {
    /// The film on screen now.
    pub fn snapshot(&self) -> Option<Arc<FilmSnapshot>> {
        match &self.source {
            Source::Live(w) => w.latest().or_else(|| self.held.clone()),
            Source::Cube { snapshot, .. } => Some(snapshot.clone()),
            Source::Nlos(_) | Source::None => None,
        }
    }

    /// The scene's ambient image: the worker's once rendered, or the cube's.
    pub fn ambient(&self) -> Option<Arc<AmbientImage>> {
        match &self.source {
            Source::Live(w) => w.ambient(),
            Source::Cube { ambient, .. } => ambient.clone(),
            Source::Nlos(_) | Source::None => None,
        }
    }

    /// The NLOS capture on screen, if one is open.
    pub fn nlos(&self) -> Option<&super::nlos::NlosView> {
        match &self.source {
            Source::Nlos(v) => Some(v),
            _ => None,
        }
    }

    /// The NLOS capture on screen, to change what it shows (tests, screenshots).
    pub fn nlos_mut(&mut self) -> Option<&mut super::nlos::NlosView> {
        match &mut self.source {
            Source::Nlos(v) => Some(v),
            _ => None,
        }
    }

    /// The request being rendered (None for a loaded cube).
    pub fn request(&self) -> Option<tprf_core::request::RenderRequest> {
        match &self.source {
            Source::Live(w) => Some(w.job().clone()),
            _ => None,
        }
    }

    /// Whether the film on screen is the one before a camera move (the new render has
    /// no pass yet).
    pub fn showing_previous_camera(&self) -> bool {
        matches!(&self.source, Source::Live(w) if w.latest().is_none()) && self.held.is_some()
    }

    /// Let go of the film kept over a camera move once the new render has one (or
    /// failed).
    pub(super) fn release_held_film(&mut self) {
        if let Source::Live(w) = &self.source
            && self.held.is_some()
            && (w.latest().is_some()
                || matches!(w.status().map(|s| s.state), Some(WorkerState::Failed(_))))
        {
            self.held = None;
        }
    }

    /// Restart with the current settings, the film on screen kept there until the new
    /// render's first pass (a camera move: the same scene, size and window). The scene
    /// the old render loaded and prepared is rendered again from the new camera, not
    /// read again ([`RenderWorker::spawn_after`]; a new fog or sky loads it).
    pub(super) fn restart_keeping_film(&mut self) {
        let film = self.snapshot();
        self.start_render(true);
        if matches!(self.source, Source::Live(_)) {
            // The scrubber keeps its time, not its bin number (a new camera's automatic
            // window starts where its light does).
            self.keep_time_s = film.as_ref().map(|f| f.axis().bin_center_s(self.bin));
            self.held = film;
        }
    }

    /// The camera the render worker renders: the scene's own with the window's pose
    /// applied (`None` while the scene loads, and for a cube).
    pub fn rendered_camera(&self) -> Option<tprf_core::scene::Camera> {
        match &self.source {
            Source::Live(w) => w.camera(),
            _ => None,
        }
    }

    /// The render worker's progress (None for a loaded cube).
    pub fn status(&self) -> Option<WorkerStatus> {
        match &self.source {
            Source::Live(w) => w.status(),
            _ => None,
        }
    }

    /// Take the render settings being edited into effect and restart, or say why not.
    pub(super) fn apply_pending(&mut self) {
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

    /// (Re)start the render of the current settings, the scene read again; the old
    /// worker is dropped (it ends by itself after its pass) and the window goes on
    /// drawing.
    pub(super) fn restart(&mut self) {
        self.start_render(false);
    }

    /// [`TprfApp::restart`]; with `keep_scene`, on the old render's scene where it
    /// is the same (see [`TprfApp::restart_keeping_film`]).
    fn start_render(&mut self, keep_scene: bool) {
        self.held = None;
        self.keep_time_s = None;
        self.camera_gesture = None;
        match self.settings.job() {
            Ok(job) => {
                // A new scene or window opens where its light is; a restart of the same
                // keeps the scrubber's bin.
                let s = &self.settings;
                let key = format!("{}|{}|{}|{}", s.scene, s.t0, s.dt, s.bins);
                if self.light_key.as_ref() != Some(&key) {
                    self.seek_light = true;
                    self.light_key = Some(key);
                }
                let ctx = self.ctx.clone();
                let wake = move || ctx.request_repaint();
                self.source = Source::Live(match &self.source {
                    Source::Live(old) if keep_scene => RenderWorker::spawn_after(job, old, wake),
                    _ => RenderWorker::spawn(job, wake),
                });
            }
            Err(e) => self.messages.push(e),
        }
    }

    /// Show the cube in `dir` (or the NLOS capture there) instead of rendering; an
    /// unreadable one is a message.
    pub(super) fn open_cube(&mut self, dir: &Path) {
        self.messages.clear();
        if super::nlos::is_capture(dir) {
            return self.open_nlos(dir);
        }
        let loaded = export::load_snapshot(dir).and_then(|(meta, snapshot)| {
            let ambient = export::ambient::load_ambient(dir, &meta)?.map(|radiance| {
                Arc::new(AmbientImage {
                    width: meta.width,
                    height: meta.height,
                    spp: meta.ambient.as_ref().map_or(0, |a| a.spp),
                    radiance,
                    error_estimate: meta.ambient.as_ref().and_then(|a| a.error_estimate),
                    non_finite: 0,
                })
            });
            let phasors = export::phasor::load_phasors(dir, meta.width, meta.height)?.map(Arc::new);
            Ok((meta, snapshot, ambient, phasors))
        });
        match loaded {
            Ok((meta, snapshot, ambient, phasors)) => {
                self.bin = self.bin.min(snapshot.axis().bins.saturating_sub(1));
                self.seek_light = true;
                self.light_key = None;
                self.held = None;
                self.camera_gesture = None;
                self.source = Source::Cube {
                    dir: dir.to_path_buf(),
                    snapshot: Arc::new(snapshot),
                    meta: Box::new(meta),
                    ambient,
                    phasors,
                };
                self.selection = None;
                self.selection_film = None;
                self.pins.clear();
            }
            Err(e) => self.messages.push(format!(
                "cannot open cube {}: {:#}",
                dir.display(),
                anyhow::Error::from(e)
            )),
        }
    }

    /// Show the NLOS capture at `path` (a folder of `tprf nlos`, or a tal HDF5 file); an
    /// unreadable one is a message.
    pub(super) fn open_nlos(&mut self, path: &Path) {
        self.messages.clear();
        let ctx = self.ctx.clone();
        match super::nlos::NlosView::open(path, move || ctx.request_repaint()) {
            Ok(view) => {
                self.held = None;
                self.camera_gesture = None;
                self.seek_light = true;
                self.light_key = None;
                self.source = Source::Nlos(Box::new(view));
            }
            Err(e) => self
                .messages
                .push(format!("cannot open NLOS capture {}: {e}", path.display())),
        }
    }

    /// Render `scene` (`builtin:NAME`, a glTF or a Mitsuba XML path) with the other
    /// settings kept, but the time window (automatic) and those a scene file carries (a Mitsuba film's size and time
    /// window, its integrator's depth: [`tprf_core::scene::file_settings`]), which it
    /// takes and says so. Its sample count is not taken: the window keeps rendering
    /// until the spp target set here.
    pub(super) fn open_scene(&mut self, scene: String) {
        // Messages belong to the scene and action that made them.
        self.messages.clear();
        // A time window belongs to the scene it was set for (as a camera pose does):
        // a new scene starts automatic, or with its file's.
        self.pending.t0.clear();
        self.pending.dt.clear();
        // So does what the last scene's file set: the user's own values come back
        // where the user left the file's.
        let mut back = Vec::new();
        if let Some(set) = self.pending.scene_file.take() {
            let (own, names) = super::settings::FileFields::of(&self.pending).leaving(&set);
            own.put(&mut self.pending);
            back = names;
        }
        let own = super::settings::FileFields::of(&self.pending);
        let mut set_again: Vec<String> = Vec::new();
        // Errors in the file are the render's to report (the worker loads it).
        if let Ok(file) = tprf_core::scene::file_settings(&scene) {
            let p = &mut self.pending;
            // The file's settings replace the user's own (which came back above); the
            // window renders on, so no sample count is taken.
            let mut r = RenderRequest {
                width: p.width,
                height: p.height,
                bins: p.bins,
                max_bounces: p.max_bounces,
                min_bounces: p.min_bounces,
                time_origin: p.time_origin,
                pulse_origin: p.pulse_origin,
                until_stopped: true,
                ..RenderRequest::new(scene.clone())
            };
            let notes = r.with_file_defaults(&file, |_| false);
            p.width = r.width;
            p.height = r.height;
            p.bins = r.bins;
            p.max_bounces = r.max_bounces;
            p.min_bounces = r.min_bounces;
            p.time_origin = r.time_origin;
            p.pulse_origin = r.pulse_origin;
            p.t0 = r.t0_s.map_or_else(String::new, time_field_text);
            p.dt = r.dt_s.map_or_else(String::new, time_field_text);
            if let Some(band) = r.phasor {
                // A view setting: the phasor tab's band, at once.
                p.phasor = Some(band);
                self.settings.phasor = Some(band);
                self.phasor = Default::default();
            }
            let file_fields = super::settings::FileFields::of(&self.pending);
            if file_fields != own {
                self.pending.scene_file = Some(super::settings::SceneFileFields {
                    own,
                    file: file_fields,
                });
            }
            set_again = notes.iter().map(|n| n.field.replace('_', " ")).collect();
            if !notes.is_empty() {
                let spp = file
                    .spp
                    .as_ref()
                    .map(|s| format!(" (its {} spp not taken: the window renders on)", s.value))
                    .unwrap_or_default();
                // Fields named as the window's labels: `time origin`, `max bounces`.
                let taken: Vec<String> = notes
                    .iter()
                    .map(|n| match (n.field, r.phasor) {
                        ("phasor", Some(b)) => format!(
                            "phasor band {}:{} m (the Phasor tab)",
                            b.wl_mean_m, b.wl_sigma_m
                        ),
                        _ => n.text_with(|f| f.replace('_', " ")),
                    })
                    .collect();
                self.messages
                    .push(format!("from the scene file: {}{spp}", taken.join(", ")));
            }
        }
        // Said only where this scene's file did not set it again.
        let back: Vec<_> = back
            .into_iter()
            .filter(|name| !set_again.iter().any(|f| f == name))
            .collect();
        if !back.is_empty() {
            self.messages.push(format!(
                "your own {} again (the last scene's file had set them)",
                back.join(", ")
            ));
        }
        self.pending.scene = scene;
        // A pose and a fog belong to the scene they were made in.
        self.pending.camera = None;
        self.pending.medium = None;
        self.selection = None;
        self.selection_film = None;
        self.pins.clear();
        self.apply_pending();
    }

    /// Files dropped on the window: a folder opens as a cube (or an NLOS capture), an
    /// HDF5 file as an NLOS capture, a .gltf/.glb or Mitsuba .xml scene renders.
    pub(super) fn handle_dropped_files(&mut self, ctx: &egui::Context) {
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
            } else if super::nlos::is_capture(&path) {
                self.open_nlos(&path);
            } else if matches!(
                path.extension()
                    .and_then(|e| e.to_str())
                    .map(|e| e.to_ascii_lowercase())
                    .as_deref(),
                Some("gltf" | "glb" | "xml")
            ) {
                self.open_scene(path.display().to_string());
            } else {
                self.messages.push(format!(
                    "{}: drop a .gltf/.glb or Mitsuba .xml file, a cube or NLOS capture folder or a \
                     tal .hdf5 capture",
                    path.display()
                ));
            }
        }
    }
}

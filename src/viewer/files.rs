//! Choosing a file or folder: the system dialog (rfd), or a path typed into a small
//! window where the dialog cannot open (no xdg-desktop-portal and no zenity: rfd then
//! returns at once, as if cancelled) or is turned off (`TPRF_NO_FILE_DIALOG=1`). Either
//! way the window says what happened; nothing fails silently.

use super::app::TprfApp;
use super::tone::View;
use eframe::egui::{self, RichText};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tprf_core::sensor::Sensor;

/// What a chosen path is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileAction {
    OpenScene,
    OpenCube,
    SaveSlicePng,
    SaveSteadyPng,
    SaveVideo,
    SaveCsv,
    LoadSensor,
    SaveSensor,
    SaveSceneGltf,
}

impl FileAction {
    /// The window's title.
    fn title(self) -> &'static str {
        match self {
            FileAction::OpenScene => "Open a scene (.gltf, .glb, or Mitsuba .xml)",
            FileAction::OpenCube => {
                "Open a cube folder (tprf render) or an NLOS capture folder (tprf nlos)"
            }
            FileAction::SaveSlicePng => "Save the time slice as PNG",
            FileAction::SaveSteadyPng => "Save the steady image as PNG",
            FileAction::SaveVideo => {
                "Save every bin as PNG frames + GIF into a new or empty folder"
            }
            FileAction::SaveCsv => "Save the plotted curves as CSV",
            FileAction::LoadSensor => "Load a sensor file (TOML)",
            FileAction::SaveSensor => "Save the sensor as TOML",
            FileAction::SaveSceneGltf => "Save the scene with this camera as glTF (.gltf)",
        }
    }

    /// The system dialog for this action, a save dialog starting at `name`; `None` when
    /// cancelled or when it could not open.
    fn dialog(self, name: Option<String>) -> Option<PathBuf> {
        let d = rfd::FileDialog::new();
        let d = match name {
            Some(n) => d.set_file_name(n),
            None => d,
        };
        match self {
            FileAction::OpenScene => d.add_filter("scene", &["gltf", "glb", "xml"]).pick_file(),
            FileAction::OpenCube | FileAction::SaveVideo => d.pick_folder(),
            FileAction::SaveSlicePng | FileAction::SaveSteadyPng => {
                d.add_filter("PNG", &["png"]).save_file()
            }
            FileAction::SaveCsv => d.add_filter("CSV", &["csv"]).save_file(),
            FileAction::LoadSensor => d.add_filter("sensor", &["toml"]).pick_file(),
            FileAction::SaveSensor => d.add_filter("sensor", &["toml"]).save_file(),
            FileAction::SaveSceneGltf => d.add_filter("glTF", &["gltf"]).save_file(),
        }
    }
}

/// The path window: what it is for, the path typed so far, and why it is open.
pub(super) struct PathPrompt {
    pub(super) action: FileAction,
    pub(super) text: String,
    pub(super) note: Option<String>,
}

/// A dialog that returns sooner than this did not open: nobody cancels that fast.
const NO_DIALOG: Duration = Duration::from_millis(250);

/// Whether the system file dialog is used: not with `TPRF_NO_FILE_DIALOG` set.
pub(super) fn dialogs_enabled() -> bool {
    std::env::var_os("TPRF_NO_FILE_DIALOG").is_none_or(|v| v.is_empty() || v == "0")
}

impl TprfApp {
    /// Ask for a path for `action` and carry it out: the system dialog, or the path
    /// window when dialogs are off or the dialog could not open.
    pub fn choose_file(&mut self, action: FileAction) {
        if !self.file_dialogs {
            self.open_path_prompt(action, None);
            return;
        }
        let started = Instant::now();
        match action.dialog(self.suggested_name(action)) {
            Some(p) => self.file_chosen(action, &p),
            None if started.elapsed() < NO_DIALOG => {
                let note = "The system file dialog did not open (no xdg-desktop-portal or \
                            zenity?): type the path here."
                    .to_string();
                self.messages.push(note.clone());
                self.open_path_prompt(action, Some(note));
            }
            // Cancelled.
            None => {}
        }
    }

    /// The name a save starts from: the scene's name and what is saved
    /// (`cornell_bin0042.png`, `staircase_steady.png`, `cornell_frames`); `None` when
    /// opening.
    pub fn suggested_name(&self, action: FileAction) -> Option<String> {
        let scene = &self.settings.scene;
        let stem = scene
            .strip_prefix("builtin:")
            .map(str::to_string)
            .or_else(|| {
                std::path::Path::new(scene)
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
            })
            .filter(|s| !s.is_empty())
            .unwrap_or_else(|| "tprf".into());
        match action {
            FileAction::OpenScene | FileAction::OpenCube | FileAction::LoadSensor => None,
            FileAction::SaveSlicePng => Some(format!("{stem}_bin{:04}.png", self.bin)),
            FileAction::SaveSteadyPng => Some(format!("{stem}_steady.png")),
            FileAction::SaveVideo => Some(format!("{stem}_frames")),
            FileAction::SaveCsv => Some(format!("{stem}_tprf.csv")),
            FileAction::SaveSensor => Some(format!("{stem}_sensor.toml")),
            FileAction::SaveSceneGltf => Some(format!("{stem}_camera.gltf")),
        }
    }

    /// Open the path window for `action`, keeping a path typed before (or starting
    /// from the suggested name of a save).
    fn open_path_prompt(&mut self, action: FileAction, note: Option<String>) {
        let text = self
            .path_prompt
            .take()
            .map(|p| p.text)
            .filter(|t| !t.is_empty())
            .or_else(|| self.suggested_name(action))
            .unwrap_or_default();
        self.path_prompt = Some(PathPrompt { action, text, note });
    }

    /// Carry out `action` on `path`.
    pub(super) fn file_chosen(&mut self, action: FileAction, path: &Path) {
        let snap = self.snapshot();
        let need_film = |app: &mut TprfApp| {
            app.messages
                .push("nothing to save yet: the first pass has not finished".into());
        };
        match action {
            FileAction::OpenScene => self.open_scene(path.display().to_string()),
            FileAction::OpenCube => self.open_cube(path),
            FileAction::SaveSlicePng | FileAction::SaveSteadyPng => match &snap {
                Some(s) => {
                    let view = if action == FileAction::SaveSlicePng {
                        View::Slice
                    } else {
                        View::Steady
                    };
                    self.save_view_png(view, s, path.to_path_buf());
                }
                None => need_film(self),
            },
            FileAction::SaveVideo => match &snap {
                Some(s) => self.save_video(s, path.to_path_buf()),
                None => need_film(self),
            },
            FileAction::SaveCsv => match &snap {
                Some(s) => self.export_csv(s, path),
                None => need_film(self),
            },
            FileAction::SaveSceneGltf => self.save_scene_gltf(path),
            FileAction::LoadSensor => match Sensor::from_path(path) {
                Ok(s) => self.settings.sensor = s,
                Err(e) => self
                    .messages
                    .push(format!("cannot load {}: {e}", path.display())),
            },
            FileAction::SaveSensor => {
                let r = self
                    .settings
                    .sensor
                    .to_toml_string()
                    .map_err(|e| e.to_string())
                    .and_then(|t| {
                        use std::io::Write;
                        tprf_core::export::write_atomic(path, |f| Ok(f.write_all(t.as_bytes())?))
                            .map_err(|e| format!("{e:#}"))
                    });
                match r {
                    Ok(()) => self.messages.push(format!("saved {}", path.display())),
                    Err(e) => self
                        .messages
                        .push(format!("cannot save {}: {e}", path.display())),
                }
            }
        }
    }

    /// The path window, while one is open: a path field (Enter or OK carries the action
    /// out, Cancel closes it).
    pub(super) fn path_prompt_ui(&mut self, ctx: &egui::Context) {
        let Some(prompt) = &mut self.path_prompt else {
            return;
        };
        let mut done: Option<bool> = None;
        egui::Window::new(prompt.action.title())
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, egui::Vec2::ZERO)
            .show(ctx, |ui| {
                if let Some(note) = &prompt.note {
                    ui.label(RichText::new(note).color(ui.visuals().warn_fg_color));
                }
                let l = ui.label("path");
                let r = ui.add(
                    egui::TextEdit::singleline(&mut prompt.text)
                        .desired_width(420.0)
                        .hint_text("/path/to/file"),
                );
                let r = r.labelled_by(l.id);
                if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                    done = Some(true);
                }
                ui.horizontal(|ui| {
                    if ui.button("OK").clicked() {
                        done = Some(true);
                    }
                    if ui.button("Cancel").clicked() {
                        done = Some(false);
                    }
                });
            });
        match done {
            Some(true) => {
                let text = prompt.text.trim().to_string();
                let action = prompt.action;
                if text.is_empty() {
                    prompt.note = Some("type a path first".into());
                    return;
                }
                self.path_prompt = None;
                self.file_chosen(action, Path::new(&text));
            }
            Some(false) => self.path_prompt = None,
            None => {}
        }
    }
}

//! The camera: its pose as numbers that can be typed (the left panel's Camera section),
//! the mouse on the images (right-drag orbits, shift + right-drag or middle-drag pans,
//! the wheel dollies, ctrl + wheel changes the field of view; a click still selects a
//! pixel and a left-drag a box), "reset to the scene's camera" and "save the scene with
//! this camera" as glTF. A gesture moves a pose the images outline (the scene's bounds
//! drawn from it) and restarts the render with it when the button is let go (the wheel:
//! when it rests); the old film stays on screen until the new one has light.

use crate::viewer::app::TprfApp;
use crate::viewer::camera::CameraPose;
use crate::viewer::files::FileAction;
use crate::viewer::source::Source;
use eframe::egui::{self, Color32, PointerButton, Rect, RichText};
use glam::DVec3;
use std::sync::{Arc, Weak};
use std::time::{Duration, Instant};
use tprf_core::scene::{Bounds, Camera, Scene};

/// What the images say of the mouse (in the readout line when no pixel is hovered, and
/// in the Camera section).
pub(crate) const GESTURES_HINT: &str = "click: select a pixel · drag: select a box · \
     right-drag: orbit · shift + right-drag or middle-drag: pan · wheel: dolly · \
     ctrl + wheel: field of view";

/// How long the wheel rests before its pose is rendered.
const WHEEL_REST: Duration = Duration::from_millis(300);
/// Dolly per point of wheel: a notch (about 50 points) moves 10 % closer.
const DOLLY_PER_POINT: f64 = 0.002;

/// A gesture in progress: the pose it has reached, and (for the wheel) when it is
/// rendered unless the wheel turns again; `None` while a button is held.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CameraGesture {
    pub(crate) pose: CameraPose,
    pub(crate) render_at: Option<Instant>,
}

/// The scene rendered, held weakly (its address cannot be reused while held), with
/// the bounds of its geometry (the orbit's pivot, the outline drawn during a gesture),
/// found once per scene (a camera move renders the same scene).
#[derive(Debug, Default)]
pub(crate) struct SceneView {
    scene: Weak<Scene>,
    bounds: Option<Bounds>,
}

impl TprfApp {
    /// The camera rendered and the scene's geometry bounds (`None` while it loads, and
    /// for a cube).
    fn scene_view(&mut self) -> Option<(Camera, Option<Bounds>)> {
        let Source::Live(w) = &self.source else {
            return None;
        };
        let scene = w.scene()?;
        if !Weak::ptr_eq(&self.scene_view.scene, &Arc::downgrade(&scene)) {
            self.scene_view = SceneView {
                scene: Arc::downgrade(&scene),
                bounds: scene.geometry_bounds(),
            };
        }
        Some((w.camera()?, self.scene_view.bounds))
    }

    /// The pose shown: a gesture's, else the window's camera, else the scene's own
    /// (`None` while the scene loads, and for a cube).
    pub fn camera_pose(&mut self) -> Option<CameraPose> {
        if let Some(g) = &self.camera_gesture {
            return Some(g.pose);
        }
        if matches!(self.source, Source::Cube { .. }) {
            return None;
        }
        if let Some(p) = self.settings.camera {
            return Some(p);
        }
        let aspect = self.settings.width as f32 / self.settings.height.max(1) as f32;
        self.scene_view()
            .map(|(camera, bounds)| CameraPose::of_camera(&camera, aspect, bounds))
    }

    /// Render from `pose` (`None`: the scene's camera), the film on screen kept until
    /// the new one has light.
    pub(crate) fn move_camera(&mut self, pose: Option<CameraPose>) {
        self.camera_gesture = None;
        if let Some(p) = pose.and_then(|p| p.problem()) {
            self.messages.push(format!("camera: {p}"));
            return;
        }
        self.settings.camera = pose;
        self.pending.camera = pose;
        self.restart_keeping_film();
    }

    /// A wheel gesture that has rested is rendered (called each frame).
    pub(crate) fn settle_camera_gesture(&mut self, ctx: &egui::Context) {
        if let Some(CameraGesture {
            pose,
            render_at: Some(at),
        }) = self.camera_gesture
        {
            let now = Instant::now();
            if now >= at {
                self.move_camera(Some(pose));
            } else {
                ctx.request_repaint_after(at - now);
            }
        }
    }

    /// The mouse on an image (`response`): orbit, pan, dolly, field of view; and the
    /// scene's bounds outlined from the pose during a gesture.
    pub(crate) fn camera_gestures(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        aspect: f64,
    ) {
        if matches!(self.source, Source::Cube { .. }) {
            return;
        }
        let height = f64::from(response.rect.height().max(1.0));
        let shift = ui.input(|i| i.modifiers.shift);
        let orbit = response.dragged_by(PointerButton::Secondary) && !shift;
        let pan = response.dragged_by(PointerButton::Middle)
            || (response.dragged_by(PointerButton::Secondary) && shift);
        if orbit || pan {
            let d = response.drag_delta();
            let (dx, dy) = (f64::from(d.x) / height, f64::from(d.y) / height);
            if let Some(pose) = self.camera_pose() {
                let moved = if orbit {
                    pose.orbit(
                        dx * crate::viewer::camera::ORBIT_RAD_PER_HEIGHT,
                        dy * crate::viewer::camera::ORBIT_RAD_PER_HEIGHT,
                    )
                } else {
                    pose.pan(dx, dy)
                };
                self.camera_gesture = Some(CameraGesture {
                    pose: moved,
                    render_at: None,
                });
            }
        }
        if (response.drag_stopped_by(PointerButton::Secondary)
            || response.drag_stopped_by(PointerButton::Middle))
            && let Some(g) = self.camera_gesture
        {
            self.move_camera(Some(g.pose));
        }
        if response.hovered() {
            let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta.y, i.zoom_delta()));
            if (scroll != 0.0 || zoom != 1.0)
                && let Some(pose) = self.camera_pose()
            {
                let pose = pose
                    .dolly((-f64::from(scroll) * DOLLY_PER_POINT).exp())
                    .zoom_fov(1.0 / f64::from(zoom));
                self.camera_gesture = Some(CameraGesture {
                    pose,
                    render_at: Some(Instant::now() + WHEEL_REST),
                });
                self.ctx.request_repaint_after(WHEEL_REST);
            }
        }
        if let Some(g) = self.camera_gesture {
            self.outline_bounds(ui, response.rect, &g.pose, aspect);
        }
    }

    /// The scene's bounding box as seen from `pose`, over the image in `rect`, and what
    /// happens when the gesture ends.
    fn outline_bounds(&mut self, ui: &egui::Ui, rect: Rect, pose: &CameraPose, aspect: f64) {
        let painter = ui.painter_at(rect);
        let color = Color32::from_rgb(0x4e, 0xc9, 0xff);
        if let Some((_, Some(b))) = self.scene_view() {
            let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
            let corner = |i: usize| {
                DVec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                )
            };
            let to_screen = |p: DVec3| {
                pose.project(p, aspect).map(|(u, v)| {
                    egui::pos2(
                        rect.min.x + u as f32 * rect.width(),
                        rect.min.y + v as f32 * rect.height(),
                    )
                })
            };
            for a in 0..8 {
                for bit in [1, 2, 4] {
                    let b = a | bit;
                    if b != a
                        && let (Some(p), Some(q)) = (to_screen(corner(a)), to_screen(corner(b)))
                    {
                        painter.line_segment([p, q], (1.5, color));
                    }
                }
            }
        }
        let text = if self.camera_gesture.is_some_and(|g| g.render_at.is_some()) {
            "renders from here when the wheel rests"
        } else {
            "let go to render from here"
        };
        painter.text(
            rect.left_top() + egui::vec2(6.0, 6.0),
            egui::Align2::LEFT_TOP,
            text,
            egui::FontId::proportional(13.0),
            color,
        );
    }

    /// The Camera section: the pose as numbers (Enter or "Set camera" renders it), the
    /// options that give `tprf render` the same view (copied), "Reset to the scene's camera" and
    /// "Save scene with this camera…".
    pub(crate) fn camera_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Camera");
        let Some(pose) = self.camera_pose() else {
            ui.label(RichText::new("the scene is loading…").weak());
            return;
        };
        self.pose_text.follow(&pose);
        let mut submit = false;
        let t = &mut self.pose_text;
        egui::Grid::new("camera-grid")
            .num_columns(2)
            .show(ui, |ui| {
                for (name, hover, text) in [
                    (
                        "Position (m)",
                        "where the camera stands: x, y, z in metres",
                        &mut t.position,
                    ),
                    (
                        "Look at (m)",
                        "the point at the image's centre (orbits turn about it): x, y, z in \
                     metres",
                        &mut t.look_at,
                    ),
                    (
                        "Up",
                        "the direction shown upward (any length, across the view)",
                        &mut t.up,
                    ),
                    (
                        "Field of view (°)",
                        "vertical, in degrees (0 to 180, not included)",
                        &mut t.fov,
                    ),
                ] {
                    let l = ui.label(name).on_hover_text(hover);
                    let r = ui
                        .add(egui::TextEdit::singleline(text).desired_width(130.0))
                        .labelled_by(l.id);
                    if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                        submit = true;
                    }
                    ui.end_row();
                }
            });
        let edited = self.pose_text.edited();
        ui.horizontal_wrapped(|ui| {
            if ui
                .add_enabled(edited, egui::Button::new("Set camera"))
                .clicked()
            {
                submit = true;
            }
            if ui
                .add_enabled(edited, egui::Button::new("Revert"))
                .clicked()
            {
                self.pose_text = Default::default();
                self.pose_text.follow(&pose);
            }
            if ui
                .add_enabled(
                    self.settings.camera.is_some() || self.camera_gesture.is_some(),
                    egui::Button::new("Reset to the scene's camera"),
                )
                .clicked()
            {
                self.pose_text = Default::default();
                self.move_camera(None);
            }
        });
        if submit && edited {
            match self.pose_text.parse() {
                Ok(p) => {
                    self.pose_error = None;
                    self.move_camera(Some(p));
                }
                Err(e) => self.pose_error = Some(e),
            }
        }
        if let Some(e) = &self.pose_error {
            ui.label(RichText::new(e).color(ui.visuals().error_fg_color));
        }
        if ui
            .button("Save scene with this camera…")
            .on_hover_text("the scene as rendered, with this camera, as one .gltf file")
            .clicked()
        {
            self.choose_file(FileAction::SaveSceneGltf);
        }
        let flags = pose.flags();
        if ui
            .button("Copy as tprf render options")
            .on_hover_text(format!("the same view from the command line: {flags}"))
            .clicked()
        {
            ui.ctx().copy_text(flags);
        }
        ui.label(RichText::new(GESTURES_HINT).weak().small());
    }

    /// Write the scene as rendered (the window's camera in it) to `path` as glTF, in the
    /// background.
    pub(crate) fn save_scene_gltf(&mut self, path: &std::path::Path) {
        let scene = match &self.source {
            Source::Live(w) => w.scene().zip(w.camera()),
            _ => None,
        };
        let Some((scene, camera)) = scene else {
            self.messages.push(
                "no scene to save: a cube holds no scene, or the scene is still loading".into(),
            );
            return;
        };
        if !path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("gltf"))
        {
            self.messages.push(format!(
                "{}: the scene is saved as a .gltf file (JSON, buffers embedded): give a \
                 name ending in .gltf",
                path.display()
            ));
            return;
        }
        let path = path.to_path_buf();
        let what = path.display().to_string();
        let named = what.clone();
        let write = move || {
            // The scene keeps its own camera (the renderer has the one rendered): a
            // copy with the camera rendered is written.
            let scene = tprf_core::scene::Scene {
                camera,
                ..(*scene).clone()
            };
            tprf_core::scene::gltf_save::save_gltf(&scene, &path)
                .map_err(|e| anyhow::Error::from(e).context(format!("cannot save {named}")))
        };
        if let Err(e) = self.exports.spawn(&self.ctx, what, write) {
            self.messages.push(e);
        }
    }
}

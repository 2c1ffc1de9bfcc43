//! The top bar: the mode, opening a scene or a cube, and the render's pause and restart.

use crate::viewer::app::TprfApp;
use crate::viewer::files::FileAction;
use crate::viewer::settings::Mode;
use crate::viewer::source::Source;
use eframe::egui;

/// Why the film's tabs are greyed out over an NLOS capture.
const NLOS_TABS: &str = "an NLOS capture shows its own view (measurements, reconstruction): \
open a scene or a cube for the film's tabs";

impl TprfApp {
    /// Mode tabs, "Open scene (glTF, XML)…", "Open cube…", the built-in scenes, pause/restart.
    pub(crate) fn top_bar_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            ui.strong("tprf");
            ui.separator();
            // An NLOS capture has a view of its own: the tabs of a film do nothing there,
            // so they are greyed out, saying why (the capture's view is taken out of
            // `source` while it draws, which then reads `None`).
            let film = !matches!(self.source, Source::Nlos(_) | Source::None);
            ui.add_enabled_ui(film, |ui| {
                ui.selectable_value(&mut self.settings.mode, Mode::Transient, "Transient")
                    .on_hover_text("Light in flight: time slices and TPRF plots")
                    .on_disabled_hover_text(NLOS_TABS);
                ui.selectable_value(&mut self.settings.mode, Mode::Sensor, "Sensor")
                    .on_hover_text(
                        "Light(t), Exposure_i(t) and the measurements M_i, from the cached TPRFs",
                    )
                    .on_disabled_hover_text(NLOS_TABS);
                ui.selectable_value(&mut self.settings.mode, Mode::Phasor, "Phasor")
                    .on_hover_text(
                        "A frequency's amplitude and phase images: the cube's phasor.npy, or computed from the film at mitransient's phasor_hdr_film frequencies",
                    )
                    .on_disabled_hover_text(NLOS_TABS);
            });
            ui.separator();
            if ui
                .button("Open scene (glTF, XML)…")
                .on_hover_text(
                    "Render a .gltf/.glb or Mitsuba .xml scene (or drop one on the window)",
                )
                .clicked()
            {
                self.choose_file(FileAction::OpenScene);
            }
            if ui
                .button("Open cube…")
                .on_hover_text("Show a folder written by `tprf render` or `tprf nlos`")
                .clicked()
            {
                self.choose_file(FileAction::OpenCube);
            }
            // The built-in scenes in a menu: five buttons made the bar wrap at 1024 px
            // and moved Pause and Restart to a second row.
            ui.menu_button("Built-in scene ⏷", |ui| {
                for (name, what) in BUILTINS {
                    if ui
                        .button(format!("builtin:{name}"))
                        .on_hover_text(what)
                        .clicked()
                    {
                        self.open_scene(format!("builtin:{name}"));
                        ui.close();
                    }
                }
            })
            .response
            .on_hover_text("Open a scene built into tprf (no file needed)");
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
                Source::Nlos(v) => {
                    ui.label(format!("NLOS capture: {}", v.path.display()));
                }
                Source::None => {}
            }
        });
    }
}

/// The built-in scenes the menu offers, each with what it shows.
const BUILTINS: [(&str, &str); 6] = [
    (
        "cornell",
        "the Cornell box, lit by a point light under its ceiling: light in flight, \
         multipath between the walls",
    ),
    (
        "canopy",
        "airborne LiDAR over a partly covered foliage layer, 100 m up, under the sun: \
         two returns per pixel",
    ),
    (
        "nlos-z",
        "tal's NLOS quickstart: a Z hidden behind a relay wall (a capture, then a \
         reconstruction)",
    ),
    (
        "nlos-shapes",
        "NLOS: three shapes at different depths behind a relay wall",
    ),
    (
        "fog",
        "a road in 50 m fog: a pedestrian, two cars and a sign at 22-78 m",
    ),
    (
        "flim",
        "fluorescence lifetimes: two dye spots of one colour, 1 ns and 4 ns, told apart \
         only by their decay after the laser pulse",
    ),
];

#[cfg(test)]
mod tests {
    /// The menu offers every built-in scene the core knows, in its order.
    #[test]
    fn the_menu_offers_every_builtin() {
        let names: Vec<&str> = super::BUILTINS.iter().map(|(n, _)| *n).collect();
        assert_eq!(names, tprf_core::scene::builtin::NAMES);
    }
}

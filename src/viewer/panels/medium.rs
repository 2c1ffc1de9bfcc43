//! The Fog section of the left panel: for a scene with a scene-wide medium (`builtin:fog`,
//! a glTF scene's extras, `--medium`): its visibility (the meteorological optical range
//! `V`: extinction `3.912 / V` per metre) as a number and a slider, its albedo and
//! Henyey-Greenstein `g`. A new fog restarts the render with it as the request's
//! `medium` (the old film stays on screen until the new one has light); a bad value is
//! a message and renders nothing. "Window out to 2 V" renders the time axis out to the
//! range the fog lets a return come back from (the automatic one is the scene's surfaces'
//! and the fog's light).
//! A scene in clear air is offered a fog to add (its visibility ten times the scene's
//! size), as `tprf render --medium` would render it.

use crate::viewer::app::TprfApp;
use crate::viewer::camera::number_text;
use crate::viewer::fog::{Fog, parse_visibility_m};
use crate::viewer::source::Source;
use eframe::egui::{self, RichText};
use tprf_core::scene::medium::MOR_EXTINCTION;
use tprf_core::units::C_M_PER_S;

/// The slider's range of visibility, metres (the fields take any visibility > 0).
const SLIDER_VISIBILITY_M: std::ops::RangeInclusive<f64> = 5.0..=2000.0;

impl TprfApp {
    /// The scene-wide fog of the scene as rendered (the window's own when it set one);
    /// `None` while the scene loads, for a cube, and for a scene in clear air.
    fn scene_fog(&self) -> Option<Fog> {
        let Source::Live(w) = &self.source else {
            return None;
        };
        w.scene()?.medium.as_ref().and_then(Fog::of_medium)
    }

    /// Render with `fog` as the scene-wide medium (`None`: the scene's own), keeping the
    /// film on screen until the new one has light; a fog the request refuses is a
    /// message.
    pub(crate) fn set_fog(&mut self, fog: Option<Fog>) {
        let medium = fog.map(|f| f.spec());
        let trial = crate::viewer::ViewerSettings {
            medium: medium.clone(),
            ..self.settings.clone()
        };
        if let Err(e) = trial.job() {
            self.messages.push(e);
            return;
        }
        self.settings.medium = medium.clone();
        self.pending.medium = medium;
        self.restart_keeping_film();
    }

    /// A fog to offer a scene in clear air: visibility ten times the scene's bounding
    /// diagonal (two significant digits), so a return across the scene keeps most of
    /// its light and the backscatter shows; albedo 0.9, `g` 0.85 (fog), the scene's `n`
    /// (1). `None` while the scene loads, for a cube, and for a scene with a medium.
    fn clear_air_fog(&self) -> Option<Fog> {
        let Source::Live(w) = &self.source else {
            return None;
        };
        let scene = w.scene()?;
        if scene.medium.is_some() {
            return None;
        }
        let d = f64::from(scene.bounds().diagonal_m());
        let v = if d.is_finite() && d > 0.0 {
            let raw = 10.0 * d;
            let p = 10f64.powf(raw.log10().floor() - 1.0);
            (raw / p).round() * p
        } else {
            50.0
        };
        Some(Fog {
            visibility_m: v,
            albedo: 0.9,
            g: 0.85,
            n: 1.0,
        })
    }

    /// The Fog section of a scene in clear air: a fog's fields, filled with `suggested`,
    /// and "Add fog", which renders the scene in it (the request's `medium`).
    /// Folded by default: one line in the panel for scenes that want no fog.
    fn add_fog_ui(&mut self, ui: &mut egui::Ui, suggested: Fog) {
        ui.separator();
        let mut add = None;
        egui::CollapsingHeader::new("Fog: clear air")
            .id_salt("add-fog")
            .default_open(false)
            .show(ui, |ui| {
                self.fog_text.follow(&suggested);
                let submit = fog_fields(ui, &mut self.fog_text);
                if ui
                    .button("Add fog")
                    .on_hover_text("render this scene in the fog above (as tprf render --medium)")
                    .clicked()
                    || submit
                {
                    add = Some(self.fog_text.parse());
                }
            });
        match add {
            Some(Ok(f)) => self.set_fog(Some(f)),
            Some(Err(e)) => self.messages.push(e),
            None => {}
        }
    }

    /// The Fog section: the scene's fog to edit, or for a scene in clear air a fog to
    /// add.
    pub(crate) fn fog_ui(&mut self, ui: &mut egui::Ui) {
        let Some(fog) = self.scene_fog() else {
            if self.settings.medium.is_some() && matches!(self.source, Source::Live(_)) {
                ui.separator();
                ui.heading("Fog");
                ui.label(RichText::new("the scene is loading…").weak());
            } else if let Some(suggested) = self.clear_air_fog() {
                self.add_fog_ui(ui, suggested);
            }
            return;
        };
        ui.separator();
        ui.heading("Fog");
        self.fog_text.follow(&fog);
        let mut submit = fog_fields(ui, &mut self.fog_text);
        // The slider moves the visibility field and renders when let go.
        let mut v = parse_visibility_m(&self.fog_text.visibility).unwrap_or(fog.visibility_m);
        let r = ui.add(
            egui::Slider::new(&mut v, SLIDER_VISIBILITY_M)
                .logarithmic(true)
                .show_value(false)
                .text("visibility"),
        );
        if r.changed() {
            self.fog_text.visibility = number_text(v);
        }
        if r.drag_stopped() || (r.changed() && !r.dragged()) {
            submit = true;
        }
        let edited = self.fog_text.edited();
        ui.horizontal_wrapped(|ui| {
            if ui
                .add_enabled(edited, egui::Button::new("Set fog"))
                .clicked()
            {
                submit = true;
            }
            if ui
                .add_enabled(edited, egui::Button::new("Revert fog"))
                .clicked()
            {
                self.fog_text = Default::default();
                self.fog_text.follow(&fog);
            }
            if ui
                .add_enabled(
                    self.settings.medium.is_some(),
                    egui::Button::new("The scene's fog"),
                )
                .clicked()
            {
                self.fog_text = Default::default();
                self.set_fog(None);
            }
        });
        // The automatic window holds 99.5 % of the light and of the surfaces' returns
        // timed without the fog; this button sets the range by the fog. Out to 2 V a return keeps
        // e^(-4 x 3.912) = 2e-7 of its light; farther is lost in the fog.
        // (The range as the button writes it: the scene's f32 extinction makes 50 m fog
        // 50.0000002 m.)
        let range_m = number_text(2.0 * fog.visibility_m)
            .parse::<f64>()
            .unwrap_or(2.0 * fog.visibility_m);
        if ui
            .button(format!("Window out to {} m (2 V)", number_text(range_m)))
            .on_hover_text(
                "render the time axis 0 … 4 V / c: the targets' returns through the fog \
                 out to where they keep e^(-4 × 3.912) = 2e-7 of their light",
            )
            .clicked()
        {
            let bins = self.settings.bins.max(1) as f64;
            let dt_ps = 2.0 * range_m * fog.n / C_M_PER_S / bins * 1e12;
            self.pending.t0 = "0 ns".into();
            self.pending.dt = format!("{dt_ps} ps");
            self.apply_pending();
        }
        if submit && self.fog_text.edited() {
            match self.fog_text.parse() {
                Ok(f) => self.set_fog(Some(f)),
                Err(e) => self.messages.push(e),
            }
        }
        ui.label(
            RichText::new(format!(
                "extinction 3.912 / V = {} /m: a return from V away keeps e^(-2 × 3.912) = \
                 0.04 % of its light",
                number_text(MOR_EXTINCTION / fog.visibility_m)
            ))
            .weak()
            .small(),
        );
    }
}

/// The fog's three fields (visibility, albedo, g); whether Enter was pressed in one.
fn fog_fields(ui: &mut egui::Ui, t: &mut crate::viewer::fog::FogText) -> bool {
    let mut submit = false;
    egui::Grid::new("fog-grid").num_columns(2).show(ui, |ui| {
        for (name, hover, text) in [
            (
                "Visibility (m)",
                "the meteorological optical range V: where a black target keeps 2 % \
                     contrast; extinction 3.912 / V per metre",
                &mut t.visibility,
            ),
            (
                "Albedo",
                "the share of the extinction that scatters (1: no absorption), in [0, 1]",
                &mut t.albedo,
            ),
            (
                "g",
                "Henyey-Greenstein asymmetry, in (-1, 1): 0 isotropic, fog about 0.85-0.9 \
                     (forward)",
                &mut t.g,
            ),
        ] {
            let l = ui.label(name).on_hover_text(hover);
            let r = ui
                .add(egui::TextEdit::singleline(text).desired_width(90.0))
                .labelled_by(l.id);
            if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                submit = true;
            }
            ui.end_row();
        }
    });
    submit
}

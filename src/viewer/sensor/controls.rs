//! The sensor's controls in the left panel: presets, loading and saving a sensor file,
//! the light pulse, the gate sequence, the SPAD, the ambient light and the noise. The
//! pulse's, gates' and SPAD's numbers are the ones their types list
//! ([`tprf_core::sensor::Field`]): each drawn by its unit, none mirrored here. Every
//! time is shown after the trigger (the pulse), as the editor's axis and its handles
//! show it: a gate time stored from the window's start is shown with the start added,
//! and the gates' origin is named beside them.

use super::{GATE_COLOR, LIGHT_COLOR};
use crate::viewer::files::FileAction;
use eframe::egui::{self, RichText};
use tprf_core::film::TimeAxis;
use tprf_core::sensor::{
    Acquisition, EXPOSURE_KINDS, Exposure, Field, LIGHT_KINDS, LightPulse, Quantity, Sensor, Spad,
    TimeOrigin, kind_label,
};
use tprf_core::units::format_time;

/// `field` as a row of a two-column grid: its label and a number widget in its unit
/// (times in ns, `offset_s` added to a time counted from the gates' origin; energy with
/// an SI prefix; frequencies in MHz), its help on hover. The new value (in the field's
/// own terms) when it was changed.
fn field_ui(ui: &mut egui::Ui, f: &Field, offset_s: f64, dt_s: f64) -> Option<f64> {
    let l = ui.label(f.label);
    let offset = if f.from_origin { offset_s } else { 0.0 };
    let mut v = f.value;
    let r = match f.quantity {
        Quantity::Time => {
            let mut ns = (f.value + offset) * 1e9;
            let r = ui.add(
                egui::DragValue::new(&mut ns)
                    .range((f.min + offset) * 1e9..=(f.max + offset) * 1e9)
                    .speed(dt_s * 1e9 / 4.0)
                    .suffix(" ns")
                    .max_decimals(4),
            );
            v = ns * 1e-9 - offset;
            r
        }
        Quantity::Energy => {
            let speed = (v.abs() * 0.01).max(1e-18);
            ui.add(
                egui::DragValue::new(&mut v)
                    .range(f.min..=f.max)
                    .speed(speed)
                    .custom_formatter(|x, _| si_joules(x))
                    .custom_parser(parse_joules),
            )
        }
        Quantity::Count => {
            let mut n = f.value.round().max(0.0) as u64;
            let r = ui.add(egui::DragValue::new(&mut n).range(f.min as u64..=f.max as u64));
            v = n as f64;
            r
        }
        Quantity::Number => {
            let speed = (v.abs() * 0.01).max((f.max - f.min).min(1.0) * 1e-3);
            ui.add(
                egui::DragValue::new(&mut v)
                    .range(f.min..=f.max)
                    .speed(speed)
                    .max_decimals(6),
            )
        }
        Quantity::Frequency => {
            let mut mhz = f.value * 1e-6;
            let r = ui.add(
                egui::DragValue::new(&mut mhz)
                    .range(f.min * 1e-6..=f.max * 1e-6)
                    .speed(0.1)
                    .suffix(" MHz"),
            );
            v = mhz * 1e6;
            r
        }
        Quantity::Rate => {
            let speed = (v * 0.01).max(1.0);
            ui.add(
                egui::DragValue::new(&mut v)
                    .range(f.min..=f.max)
                    .speed(speed)
                    .suffix(" /s"),
            )
        }
        Quantity::Degrees => ui.add(
            egui::DragValue::new(&mut v)
                .range(f.min..=f.max)
                .speed(1.0)
                .suffix("°"),
        ),
    };
    let r = r.labelled_by(l.id);
    let r = if f.help.is_empty() {
        r
    } else {
        r.on_hover_text(f.help)
    };
    ui.end_row();
    (r.changed() && v.is_finite()).then_some(v)
}

/// The fields of one sensor part as a grid; the first changed, as (key, new value).
fn fields_ui(
    ui: &mut egui::Ui,
    id: &str,
    fields: &[Field],
    offset_s: f64,
    dt_s: f64,
    knots: Option<usize>,
) -> Option<(&'static str, f64)> {
    let mut changed = None;
    egui::Grid::new(id).num_columns(2).show(ui, |ui| {
        if let Some(n) = knots {
            ui.label(format!("{n} knots: drag them on the plot"));
            ui.end_row();
        }
        for f in fields {
            if let Some(v) = field_ui(ui, f, offset_s, dt_s) {
                changed = Some((f.key, v));
            }
        }
    });
    changed
}

/// `x` joules with the SI prefix that puts it in 1 ..= 999, four significant digits.
fn si_joules(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x} J");
    }
    const PREFIXES: [(f64, &str); 7] = [
        (1e3, "kJ"),
        (1.0, "J"),
        (1e-3, "mJ"),
        (1e-6, "µJ"),
        (1e-9, "nJ"),
        (1e-12, "pJ"),
        (1e-15, "fJ"),
    ];
    let (scale, unit) = PREFIXES
        .iter()
        .copied()
        .find(|(s, _)| x.abs() >= *s * 0.9995)
        .unwrap_or((1e-15, "fJ"));
    let v = x / scale;
    let decimals = 3usize.saturating_sub(v.abs().log10().floor().max(0.0) as usize);
    let text = format!("{v:.decimals$}");
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.')
    } else {
        &text
    };
    format!("{text} {unit}")
}

/// Joules typed as a number or a number and a unit (fJ .. kJ, `u` for µ).
fn parse_joules(s: &str) -> Option<f64> {
    let s = s.trim();
    for (suffix, scale) in [
        ("fJ", 1e-15),
        ("pJ", 1e-12),
        ("nJ", 1e-9),
        ("µJ", 1e-6),
        ("uJ", 1e-6),
        ("mJ", 1e-3),
        ("kJ", 1e3),
        ("J", 1.0),
    ] {
        if let Some(num) = s.strip_suffix(suffix) {
            return num.trim().parse::<f64>().ok().map(|v| v * scale);
        }
    }
    s.parse().ok()
}

/// The SPAD's parameters (the TDC bins and jitter are the exposure's).
fn spad_ui(ui: &mut egui::Ui, spad: &mut Spad, dt_s: f64) {
    ui.label(RichText::new("SPAD").strong());
    if let Some((key, v)) = fields_ui(ui, "spad-grid", &spad.fields(), 0.0, dt_s, None) {
        spad.set_field(key, v);
    }
    ui.horizontal(|ui| {
        let l = ui.label("acquisition");
        egui::ComboBox::from_id_salt("spad-mode")
            .selected_text(match spad.mode {
                Acquisition::Synchronous => "synchronous",
                Acquisition::FreeRunning => "free-running",
            })
            .show_ui(ui, |ui| {
                ui.selectable_value(&mut spad.mode, Acquisition::Synchronous, "synchronous");
                ui.selectable_value(&mut spad.mode, Acquisition::FreeRunning, "free-running");
            })
            .response
            .labelled_by(l.id)
            .on_hover_text("synchronous: armed afresh each laser cycle; free-running: never reset");
    });
}

/// What the sensor's controls ask of the window.
#[derive(Default)]
pub(crate) struct ControlsOutcome {
    /// A message to show (a preset that did not parse).
    pub(crate) message: Option<String>,
    /// A sensor file to load or save (the window asks for its path).
    pub(crate) file: Option<FileAction>,
    /// A built-in preset was picked.
    pub(crate) preset_picked: bool,
}

/// The gates' origin: where their times count from (the window's start or the
/// trigger), shown with what that is in time after the trigger, and switchable
/// (the gates stay where they are).
fn origin_ui(ui: &mut egui::Ui, exposure: &mut Exposure, axis: Option<&TimeAxis>) {
    if matches!(exposure, Exposure::Amcw { .. }) {
        ui.label(RichText::new("phases count from the trigger").weak());
        return;
    }
    let t0 = axis.map(|a| a.t0_s);
    let window = match t0 {
        Some(t0) => format!("the window start ({})", format_time(t0)),
        None => "the window start".to_string(),
    };
    let name = |o: TimeOrigin| match o {
        TimeOrigin::Window => window.clone(),
        TimeOrigin::Pulse => "the pulse (0 ns)".to_string(),
    };
    let now = exposure.origin();
    let mut origin = now;
    ui.horizontal_wrapped(|ui| {
        let l = ui.label("gates move with");
        egui::ComboBox::from_id_salt("exposure-origin")
            .selected_text(name(now))
            .show_ui(ui, |ui| {
                for o in [TimeOrigin::Window, TimeOrigin::Pulse] {
                    ui.selectable_value(&mut origin, o, name(o));
                }
            })
            .response
            .labelled_by(l.id)
            .on_hover_text(
                "what the gates are tied to when the film's window changes; their times \
                 below are after the pulse either way",
            );
    });
    if origin != now
        && let Some(t0) = t0
    {
        *exposure = exposure.with_origin(origin, t0);
    }
    ui.label(
        RichText::new(match (now, t0) {
            (TimeOrigin::Window, None) => {
                "times counted from the window start (no film yet)".to_string()
            }
            _ => "times after the pulse, as on the plot".to_string(),
        })
        .weak(),
    );
}

/// The sensor's controls (left panel): presets, light, gates, noise.
pub(crate) fn controls_ui(
    ui: &mut egui::Ui,
    sensor: &mut Sensor,
    axis: Option<&TimeAxis>,
) -> ControlsOutcome {
    let mut out = ControlsOutcome::default();
    ui.heading("Sensor");
    if !sensor.name.is_empty() {
        ui.label(RichText::new(&sensor.name).strong());
    }
    ui.horizontal_wrapped(|ui| {
        for (name, _) in tprf_core::sensor::BUILTIN_PRESETS {
            if ui
                .button(*name)
                .on_hover_text(format!("builtin:{name}"))
                .clicked()
            {
                match Sensor::builtin(name) {
                    Ok(s) => {
                        *sensor = s;
                        out.preset_picked = true;
                    }
                    Err(e) => out.message = Some(e.to_string()),
                }
            }
        }
        if ui
            .button("Load…")
            .on_hover_text("A sensor file (TOML)")
            .clicked()
        {
            out.file = Some(FileAction::LoadSensor);
        }
        if ui.button("Save…").clicked() {
            out.file = Some(FileAction::SaveSensor);
        }
    });
    let dt_s = axis.map_or(1e-10, |a| a.dt_s);

    let heading = ui.label(RichText::new("Light(t)").color(LIGHT_COLOR).strong());
    let kind = sensor.light.kind_name();
    let mut new_kind = kind;
    egui::ComboBox::from_id_salt("light-kind")
        .selected_text(kind_label(LIGHT_KINDS, kind))
        .show_ui(ui, |ui| {
            for (k, l) in LIGHT_KINDS {
                ui.selectable_value(&mut new_kind, k, *l);
            }
        })
        .response
        .labelled_by(heading.id);
    if new_kind != kind {
        // A new pulse leaves at the trigger, t = 0, like the rendered one.
        sensor.light = LightPulse::of_kind(new_kind, 0.0, 4.0 * dt_s);
    }
    let knots = sensor.light.knots().map(<[_]>::len);
    if let Some((key, v)) = fields_ui(ui, "light-grid", &sensor.light.fields(), 0.0, dt_s, knots) {
        sensor.light.set_field(key, v);
    }

    let heading = ui.label(RichText::new("Exposure_i(t)").color(GATE_COLOR).strong());
    let kind = sensor.exposure.kind_name();
    let mut new_kind = kind;
    egui::ComboBox::from_id_salt("exposure-kind")
        .selected_text(kind_label(EXPOSURE_KINDS, kind))
        .show_ui(ui, |ui| {
            for (k, l) in EXPOSURE_KINDS {
                ui.selectable_value(&mut new_kind, k, *l);
            }
        })
        .response
        .labelled_by(heading.id);
    if new_kind != kind
        && let Some(axis) = axis
    {
        sensor.exposure = Exposure::of_kind(new_kind, axis.end_s() - axis.t0_s);
        sensor.derived = Default::default();
        sensor.derived.amcw_depth = new_kind == "amcw";
        // A SPAD needs TDC bins; TDC bins get a SPAD.
        sensor.spad = (new_kind == "tdc").then(Spad::default);
    }
    origin_ui(ui, &mut sensor.exposure, axis);
    let offset = match (sensor.exposure.origin(), axis) {
        (TimeOrigin::Window, Some(a)) => a.t0_s,
        _ => 0.0,
    };
    let knots = sensor.exposure.knots().map(<[_]>::len);
    let fields = sensor.exposure.fields();
    if let Some((key, v)) = fields_ui(ui, "exposure-grid", &fields, offset, dt_s, knots) {
        sensor.exposure.set_field(key, v);
    }
    if let Some(spad) = &mut sensor.spad {
        spad_ui(ui, spad, dt_s);
    }
    if let Some(returns) = &mut sensor.derived.returns {
        // A SPAD's depth is its histogram's first return: multi-echo is the gates'.
        let spad = sensor.spad.is_some();
        ui.label(RichText::new("Returns").strong())
            .on_hover_text(if spad {
                "how the first return of each pixel's histogram is found"
            } else {
                "the LiDAR's returns of each pixel's gate waveform: first, strongest, last \
             and multi-echo depth"
            });
        let fields: Vec<_> = returns
            .fields()
            .into_iter()
            .filter(|f| !(spad && f.key == "max_returns"))
            .collect();
        if let Some((key, v)) = fields_ui(ui, "returns-grid", &fields, 0.0, dt_s, None) {
            returns.set_field(key, v);
        }
    }

    ui.label(RichText::new("Ambient").strong());
    egui::Grid::new("ambient-grid")
        .num_columns(2)
        .show(ui, |ui| {
            let l = ui.label("ambient scale");
            let speed = (sensor.ambient_scale * 0.01).max(1e-3);
            ui.add(
                egui::DragValue::new(&mut sensor.ambient_scale)
                    .range(0.0..=1e15)
                    .speed(speed),
            )
            .labelled_by(l.id)
            .on_hover_text(
                "scale of the scene's ambient image A (sun, sky, lamps tagged ambient; \
             dimensionless, 1 = the scene's power, 0 = off): gate i measures \
             scale x A x integral Exposure_i dt more; a SPAD counts scale x photons/unit \
             x A photons/s more",
            );
            ui.end_row();
            if matches!(sensor.exposure, Exposure::Amcw { .. }) {
                let l = ui.label("ambient exposure");
                let mut on = sensor.ambient_exposure_s.is_some();
                ui.checkbox(&mut on, "").labelled_by(l.id).on_hover_text(
                    "AMCW gates never close: seconds of ambient light per unit of emitted \
                     energy (1 / the source's mean power in W); off: no ambient",
                );
                if on != sensor.ambient_exposure_s.is_some() {
                    sensor.ambient_exposure_s = on.then_some(1.0);
                }
                ui.end_row();
                if let Some(t) = &mut sensor.ambient_exposure_s {
                    let l = ui.label("  seconds / J");
                    let speed = (*t * 0.01).max(1e-12);
                    ui.add(egui::DragValue::new(t).range(1e-15..=1e15).speed(speed))
                        .labelled_by(l.id);
                    ui.end_row();
                }
            }
        });

    ui.label(RichText::new("Noise").strong());
    egui::Grid::new("noise-grid").num_columns(2).show(ui, |ui| {
        let l = ui.label("σ (additive)");
        ui.add(
            egui::DragValue::new(&mut sensor.noise.sigma)
                .range(0.0..=1e12)
                .speed(1e-4)
                .max_decimals(6),
        )
        .labelled_by(l.id);
        ui.end_row();
        let l = ui.label("photons / energy");
        ui.add(
            egui::DragValue::new(&mut sensor.noise.photons_per_energy)
                .range(0.0..=1e15)
                .speed(1.0),
        )
        .labelled_by(l.id)
        .on_hover_text("Poisson photon noise; 0 = off");
        ui.end_row();
        let l = ui.label("seed");
        ui.add(egui::DragValue::new(&mut sensor.noise.seed))
            .labelled_by(l.id);
        ui.end_row();
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand-written cases: the prefix that puts the value in 1 ..= 999, and the typed
    /// forms read back.
    #[test]
    fn joules_are_shown_with_a_prefix_and_read_back() {
        for (x, shown) in [
            (1e-6, "1 µJ"),
            (2.5e-3, "2.5 mJ"),
            (1.0, "1 J"),
            (0.0, "0 J"),
            (123.456e-9, "123.5 nJ"),
            (4e3, "4 kJ"),
        ] {
            assert_eq!(si_joules(x), shown, "{x}");
            let back = parse_joules(shown).unwrap();
            assert!((back - x).abs() <= 1e-3 * x.abs(), "{shown}: {back}");
        }
        assert_eq!(parse_joules("1e-6"), Some(1e-6));
        assert_eq!(parse_joules(" 3 uJ "), Some(3e-6));
        assert_eq!(parse_joules("lots"), None);
    }
}

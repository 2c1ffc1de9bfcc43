//! The sensor's controls in the left panel: presets, loading and saving a sensor file,
//! the light pulse, the gate sequence and the noise, each kind with its own fields.

use super::kinds::{EXPOSURE_KINDS, LIGHT_KINDS, exposure_of_kind, label_of, light_of_kind};
use super::{GATE_COLOR, LIGHT_COLOR};
use crate::viewer::files::FileAction;
use eframe::egui::{self, RichText};
use tprf_core::film::TimeAxis;
use tprf_core::sensor::{Acquisition, Exposure, LightPulse, Sensor, Spad};

/// A time in ns, stored in seconds, within the sensor's +-1 s
/// ([`tprf_core::sensor::MAX_TIME_S`]).
fn time_ns(ui: &mut egui::Ui, label: &str, t_s: &mut f64, speed_ns: f64) {
    let l = ui.label(label);
    let mut ns = *t_s * 1e9;
    let max_ns = tprf_core::sensor::MAX_TIME_S * 1e9;
    if ui
        .add(
            egui::DragValue::new(&mut ns)
                .range(-max_ns..=max_ns)
                .speed(speed_ns)
                .suffix(" ns")
                .max_decimals(4),
        )
        .labelled_by(l.id)
        .changed()
        && ns.is_finite()
    {
        *t_s = ns * 1e-9;
    }
    ui.end_row();
}

/// A number in `range`, dragged at `speed` per pixel.
fn number(
    ui: &mut egui::Ui,
    label: &str,
    v: &mut f64,
    range: std::ops::RangeInclusive<f64>,
    speed: f64,
) {
    let l = ui.label(label);
    ui.add(egui::DragValue::new(v).range(range).speed(speed))
        .labelled_by(l.id);
    ui.end_row();
}

/// The light's energy in joules, shown with an SI prefix ("1 µJ", "2.5 mJ") and typed
/// as joules or with a unit ("1e-6", "1 uJ"): a real pulse's microjoules would read
/// 0.00 with two decimals.
fn energy_j(ui: &mut egui::Ui, v: &mut f64) {
    let l = ui.label("energy");
    let speed = (v.abs() * 0.01).max(1e-18);
    ui.add(
        egui::DragValue::new(v)
            .range(0.0..=1e12)
            .speed(speed)
            .custom_formatter(|x, _| si_joules(x))
            .custom_parser(parse_joules),
    )
    .on_hover_text("pulse energy, J (type e.g. 1e-6 or 1 uJ)")
    .labelled_by(l.id);
    ui.end_row();
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

/// A count from 1 to `max`.
fn count(ui: &mut egui::Ui, label: &str, v: &mut u64, max: u64) {
    let l = ui.label(label);
    ui.add(egui::DragValue::new(v).range(1..=max))
        .labelled_by(l.id);
    ui.end_row();
}

/// A rate in hertz, typed as a count per second.
fn rate(ui: &mut egui::Ui, label: &str, v: &mut f64, hover: &str) {
    let l = ui.label(label);
    let speed = (*v * 0.01).max(1.0);
    ui.add(
        egui::DragValue::new(v)
            .range(0.0..=1e15)
            .speed(speed)
            .suffix(" /s"),
    )
    .labelled_by(l.id)
    .on_hover_text(hover);
    ui.end_row();
}

/// The SPAD's parameters (the TDC bins and jitter are the exposure's).
fn spad_ui(ui: &mut egui::Ui, spad: &mut Spad) {
    ui.label(RichText::new("SPAD").strong());
    egui::Grid::new("spad-grid").num_columns(2).show(ui, |ui| {
        count(
            ui,
            "cycles",
            &mut spad.cycles,
            tprf_core::sensor::spad::MAX_CYCLES,
        );
        number(ui, "PDE", &mut spad.pde, 0.0..=1.0, 0.005);
        let l = ui.label("photons / unit");
        let speed = (spad.photons_per_unit * 0.01).max(1e-6);
        ui.add(
            egui::DragValue::new(&mut spad.photons_per_unit)
                .range(0.0..=1e30)
                .speed(speed),
        )
        .labelled_by(l.id)
        .on_hover_text("photons reaching the pixel per unit of (TPRF * Light), per pulse");
        ui.end_row();
        rate(
            ui,
            "ambient",
            &mut spad.ambient_rate_hz,
            "uniform ambient photons per second at each pixel",
        );
        let l = ui.label("ambient lamp");
        let speed = (spad.ambient_lamp_hz * 0.01).max(1.0);
        ui.add(
            egui::DragValue::new(&mut spad.ambient_lamp_hz)
                .range(0.0..=1e15)
                .speed(speed)
                .suffix(" /s"),
        )
        .labelled_by(l.id)
        .on_hover_text(
            "a steady lamp where the light is, of this many pulse energies per second: \
             each pixel gets it times its steady image",
        );
        ui.end_row();
        rate(
            ui,
            "dark counts",
            &mut spad.dark_count_rate_hz,
            "dark count rate",
        );
        let speed = (spad.dead_time_s * 1e9 * 0.01).max(0.01);
        time_ns(ui, "dead time", &mut spad.dead_time_s, speed);
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
            .labelled_by(l.id);
        ui.end_row();
        number(
            ui,
            "afterpulsing",
            &mut spad.afterpulse_probability,
            0.0..=1.0,
            0.001,
        );
        if spad.afterpulse_probability > 0.0 {
            if !(spad.afterpulse_delay_s > 0.0) {
                spad.afterpulse_delay_s = (spad.dead_time_s * 2.0).max(1e-9);
            }
            let speed = (spad.afterpulse_delay_s * 1e9 * 0.01).max(0.01);
            time_ns(ui, "afterpulse delay", &mut spad.afterpulse_delay_s, speed);
        }
    });
}

/// What the sensor's controls ask of the window.
#[derive(Default)]
pub(crate) struct ControlsOutcome {
    /// A message to show (a preset that did not parse).
    pub(crate) message: Option<String>,
    /// A sensor file to load or save (the window asks for its path).
    pub(crate) file: Option<FileAction>,
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
                    Ok(s) => *sensor = s,
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
    let speed = dt_s * 1e9 / 4.0;

    ui.label(RichText::new("Light(t)").color(LIGHT_COLOR).strong());
    let kind = sensor.light.kind_name();
    let mut new_kind = kind;
    egui::ComboBox::from_id_salt("light-kind")
        .selected_text(label_of(LIGHT_KINDS, kind))
        .show_ui(ui, |ui| {
            for (k, l) in LIGHT_KINDS {
                ui.selectable_value(&mut new_kind, k, *l);
            }
        });
    if new_kind != kind {
        // A new pulse leaves at the trigger, t = 0, like the rendered one.
        sensor.light = light_of_kind(new_kind, 0.0, dt_s);
    }
    egui::Grid::new("light-grid")
        .num_columns(2)
        .show(ui, |ui| match &mut sensor.light {
            LightPulse::Delta { t_s, energy } => {
                time_ns(ui, "time", t_s, speed);
                energy_j(ui, energy);
            }
            LightPulse::Gaussian {
                centre_s,
                fwhm_s,
                energy,
            } => {
                time_ns(ui, "centre", centre_s, speed);
                time_ns(ui, "FWHM", fwhm_s, speed);
                energy_j(ui, energy);
            }
            LightPulse::Rect {
                start_s,
                width_s,
                energy,
            } => {
                time_ns(ui, "start", start_s, speed);
                time_ns(ui, "width", width_s, speed);
                energy_j(ui, energy);
            }
            LightPulse::Exponential {
                onset_s,
                tau_s,
                energy,
            } => {
                time_ns(ui, "onset", onset_s, speed);
                time_ns(ui, "decay τ", tau_s, speed);
                energy_j(ui, energy);
            }
            LightPulse::LaserDiode {
                onset_s,
                rise_s,
                fall_s,
                energy,
            } => {
                time_ns(ui, "onset", onset_s, speed);
                time_ns(ui, "rise", rise_s, speed);
                time_ns(ui, "fall", fall_s, speed);
                energy_j(ui, energy);
            }
            LightPulse::Sinc2 {
                centre_s,
                width_s,
                lobes,
                energy,
            } => {
                time_ns(ui, "centre", centre_s, speed);
                time_ns(ui, "first zero", width_s, speed);
                let l = ui.label("side lobes");
                ui.add(egui::DragValue::new(lobes).range(0..=64))
                    .labelled_by(l.id);
                ui.end_row();
                energy_j(ui, energy);
            }
            LightPulse::PiecewiseLinear { points, energy } => {
                ui.label(format!("{} knots: drag them on the plot", points.len()));
                ui.end_row();
                energy_j(ui, energy);
            }
        });

    ui.label(RichText::new("Exposure_i(t)").color(GATE_COLOR).strong());
    let kind = sensor.exposure.kind_name();
    let mut new_kind = kind;
    egui::ComboBox::from_id_salt("exposure-kind")
        .selected_text(label_of(EXPOSURE_KINDS, kind))
        .show_ui(ui, |ui| {
            for (k, l) in EXPOSURE_KINDS {
                ui.selectable_value(&mut new_kind, k, *l);
            }
        });
    if new_kind != kind
        && let Some(axis) = axis
    {
        sensor.exposure = exposure_of_kind(new_kind, axis);
        sensor.derived = Default::default();
        sensor.derived.amcw_depth = new_kind == "amcw";
        // A SPAD needs TDC bins; TDC bins get a SPAD.
        sensor.spad = (new_kind == "tdc").then(Spad::default);
    }
    let max_gates = tprf_core::sensor::MAX_GATES;
    egui::Grid::new("exposure-grid")
        .num_columns(2)
        .show(ui, |ui| match &mut sensor.exposure {
            Exposure::Box {
                start_s,
                width_s,
                step_s,
                count: n,
                gain,
                ..
            } => {
                time_ns(ui, "start", start_s, speed);
                time_ns(ui, "width", width_s, speed);
                let mut step = step_s.unwrap_or(*width_s);
                time_ns(ui, "step", &mut step, speed);
                if step_s.is_some() || step != *width_s {
                    *step_s = Some(step);
                }
                count(ui, "gates", n, max_gates);
                number(ui, "gain", gain, 0.0..=1e12, 0.01);
            }
            Exposure::Gaussian {
                centre_s,
                fwhm_s,
                step_s,
                count: n,
                peak,
                ..
            } => {
                time_ns(ui, "centre", centre_s, speed);
                time_ns(ui, "FWHM", fwhm_s, speed);
                let mut step = step_s.unwrap_or(*fwhm_s);
                time_ns(ui, "step", &mut step, speed);
                if step_s.is_some() || step != *fwhm_s {
                    *step_s = Some(step);
                }
                count(ui, "gates", n, max_gates);
                number(ui, "peak", peak, 0.0..=1e12, 0.01);
            }
            Exposure::PiecewiseLinear {
                points,
                step_s,
                count: n,
                ..
            } => {
                ui.label(format!("{} knots: drag them on the plot", points.len()));
                ui.end_row();
                time_ns(ui, "step", step_s, speed);
                count(ui, "gates", n, max_gates);
            }
            Exposure::Amcw {
                freq_hz,
                phase_steps,
                phase0_deg,
                modulation,
            } => {
                let mut mhz = *freq_hz * 1e-6;
                let l = ui.label("frequency");
                if ui
                    .add(
                        egui::DragValue::new(&mut mhz)
                            .range(1e-3..=1e5)
                            .speed(0.1)
                            .suffix(" MHz"),
                    )
                    .labelled_by(l.id)
                    .changed()
                {
                    *freq_hz = mhz * 1e6;
                }
                ui.end_row();
                count(ui, "phase steps", phase_steps, 64);
                number(ui, "phase 0 (deg)", phase0_deg, -360.0..=360.0, 1.0);
                number(ui, "modulation", modulation, 0.0..=1.0, 0.01);
            }
            Exposure::Tdc {
                start_s,
                bin_width_s,
                bins,
                jitter_fwhm_s,
                ..
            } => {
                time_ns(ui, "start", start_s, speed);
                time_ns(ui, "bin width", bin_width_s, speed);
                count(ui, "bins", bins, max_gates);
                time_ns(ui, "jitter FWHM", jitter_fwhm_s, speed);
            }
        });
    if let Some(spad) = &mut sensor.spad {
        spad_ui(ui, spad);
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
            if matches!(sensor.exposure, tprf_core::sensor::Exposure::Amcw { .. }) {
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
                    number(ui, "  seconds / J", t, 1e-15..=1e15, (*t * 0.01).max(1e-12));
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

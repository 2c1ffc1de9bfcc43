//! A new light pulse or gate sequence of a kind picked in the controls, sized for the
//! film's window, and the kinds' names in the menus. Pure functions.

use tprf_core::film::TimeAxis;
use tprf_core::sensor::{Exposure, LightPulse, Point, TimeOrigin};

/// A new light of `kind` with sizes fit for a window of bin width `dt_s`.
pub(super) fn light_of_kind(kind: &str, at_s: f64, dt_s: f64) -> LightPulse {
    let w = 4.0 * dt_s;
    match kind {
        "gaussian" => LightPulse::Gaussian {
            centre_s: at_s,
            fwhm_s: w,
            energy: 1.0,
        },
        "rect" => LightPulse::Rect {
            start_s: at_s,
            width_s: w,
            energy: 1.0,
        },
        "exponential" => LightPulse::Exponential {
            onset_s: at_s,
            tau_s: w,
            energy: 1.0,
        },
        "laser_diode" => LightPulse::LaserDiode {
            onset_s: at_s,
            rise_s: w / 4.0,
            fall_s: w,
            energy: 1.0,
        },
        "sinc2" => LightPulse::Sinc2 {
            centre_s: at_s,
            width_s: w,
            lobes: 8,
            energy: 1.0,
        },
        "piecewise_linear" => LightPulse::PiecewiseLinear {
            points: vec![
                Point(at_s, 0.0),
                Point(at_s + w / 2.0, 1.0),
                Point(at_s + 2.0 * w, 0.3),
                Point(at_s + 4.0 * w, 0.0),
            ],
            energy: 1.0,
        },
        _ => LightPulse::Delta {
            t_s: at_s,
            energy: 1.0,
        },
    }
}

/// A new gate sequence of `kind` covering the window `axis`.
pub(super) fn exposure_of_kind(kind: &str, axis: &TimeAxis) -> Exposure {
    let span = axis.end_s() - axis.t0_s;
    let n = 32u64;
    let w = span / n as f64;
    match kind {
        "gaussian" => Exposure::Gaussian {
            origin: TimeOrigin::Window,
            centre_s: w / 2.0,
            fwhm_s: w,
            step_s: None,
            count: n,
            peak: 1.0,
        },
        "piecewise_linear" => Exposure::PiecewiseLinear {
            origin: TimeOrigin::Window,
            points: vec![
                Point(0.0, 0.0),
                Point(w, 1.0),
                Point(2.0 * w, 1.0),
                Point(3.0 * w, 0.0),
            ],
            step_s: w,
            count: n,
        },
        "tdc" => Exposure::Tdc {
            origin: TimeOrigin::Window,
            start_s: 0.0,
            bin_width_s: span / 256.0,
            bins: 256,
            jitter_fwhm_s: span / 256.0,
        },
        "amcw" => Exposure::Amcw {
            freq_hz: 20e6,
            phase_steps: 4,
            phase0_deg: 0.0,
            modulation: 1.0,
        },
        _ => Exposure::Box {
            origin: TimeOrigin::Window,
            start_s: 0.0,
            width_s: w,
            step_s: None,
            count: n,
            gain: 1.0,
        },
    }
}

/// Light kinds: (name in sensor files, label in the menu).
pub(super) const LIGHT_KINDS: &[(&str, &str)] = &[
    ("delta", "delta"),
    ("gaussian", "Gaussian"),
    ("rect", "rectangular"),
    ("exponential", "exponential decay"),
    ("laser_diode", "laser diode"),
    ("sinc2", "sinc²"),
    ("piecewise_linear", "free (piecewise linear)"),
];

/// Gate kinds: (name in sensor files, label in the menu).
pub(super) const EXPOSURE_KINDS: &[(&str, &str)] = &[
    ("box", "box gates"),
    ("gaussian", "Gaussian gates"),
    ("piecewise_linear", "free gates (piecewise linear)"),
    ("amcw", "AMCW sinusoids"),
    ("tdc", "TDC bins (SPAD)"),
];

/// The menu label of `key` in `table` ("?" for an unknown kind).
pub(super) fn label_of(table: &[(&str, &'static str)], key: &str) -> &'static str {
    table
        .iter()
        .find(|(k, _)| *k == key)
        .map_or("?", |(_, l)| l)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tprf_core::sensor::{Sensor, SensorModel};

    fn axis() -> TimeAxis {
        TimeAxis::new(2e-9, 50e-12, 200).unwrap()
    }

    #[test]
    fn every_kind_makes_a_valid_sensor() {
        let axis = axis();
        for (lk, _) in LIGHT_KINDS {
            for (ek, _) in EXPOSURE_KINDS {
                let s = Sensor::new(
                    light_of_kind(lk, 0.0, axis.dt_s),
                    exposure_of_kind(ek, &axis),
                );
                SensorModel::new(s, axis).unwrap_or_else(|e| panic!("{lk} x {ek}: {e}"));
            }
        }
    }
}

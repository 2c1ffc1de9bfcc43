//! egui_plot set up to be read: grid marks from [`axes::axis_marks`] (several labelled
//! ticks on every axis, whatever its span), tick labels from [`axes::format_tick`]
//! (scientific notation where needed), and time plots with arrival time in ns under the
//! plot and optical path length in m over it.

use super::axes;
use egui_plot::{AxisHints, GridInput, GridMark, Plot, VPlacement};
use std::ops::RangeInclusive;
use tprf_core::units::C_M_PER_S;

/// Labelled x ticks at least this far apart, points.
const X_LABEL_PX: f64 = 72.0;
/// Labelled y ticks at least this far apart, points.
const Y_LABEL_PX: f64 = 30.0;
/// egui_plot's `grid_spacing` minimum (its default), from which `GridInput` is scaled.
const GRID_MIN_PX: f64 = 8.0;

/// A grid spacer for egui_plot: labelled 1-2-5 marks `label_px` apart, finer marks
/// between.
pub(crate) fn spacer(label_px: f64) -> impl Fn(GridInput) -> Vec<GridMark> {
    move |input: GridInput| {
        let (lo, hi) = input.bounds;
        if !(input.base_step_size > 0.0) {
            return Vec::new();
        }
        let length_px = (hi - lo) / input.base_step_size * GRID_MIN_PX;
        axes::axis_marks(lo, hi, length_px, label_px)
            .into_iter()
            .map(|m| GridMark {
                value: m.value,
                step_size: m.step,
            })
            .collect()
    }
}

/// A tick label: the value with the decimals its step needs, or scientific notation.
pub(crate) fn tick(mark: GridMark, _range: &RangeInclusive<f64>) -> String {
    axes::format_tick(mark.value, mark.step_size)
}

/// A tick label on a log10 axis: `10^value`, plainly from 1e-3 to 1e4 (`0.01`, `3.2`,
/// `100`), else in scientific notation (`1e-6`, `3.2e-7` between decades).
pub(crate) fn log_tick(mark: GridMark, _range: &RangeInclusive<f64>) -> String {
    let v = 10f64.powf(mark.value);
    let decade = (mark.value - mark.value.round()).abs() < 1e-9;
    let plain = (-3.0..5.0).contains(&mark.value.floor());
    match (decade, plain) {
        (true, true) => format!("{v:.*}", (-mark.value.round()).max(0.0) as usize),
        (true, false) => format!("1e{}", mark.value.round() as i64),
        (false, _) => axes::format_sig(v, 2),
    }
}

/// `plot` with the time axis in ns under it and the optical path in m over it, and a y
/// axis labelled `y_label` (values, or log10 values when `y_log`).
pub(crate) fn time_plot<'a>(plot: Plot<'a>, y_label: &str, y_log: bool) -> Plot<'a> {
    let y_axis = AxisHints::new_y().label(y_label.to_owned());
    let y_axis = if y_log {
        y_axis.formatter(log_tick)
    } else {
        y_axis.formatter(tick)
    };
    plot.x_grid_spacer(spacer(X_LABEL_PX))
        .y_grid_spacer(spacer(Y_LABEL_PX))
        .custom_x_axes(vec![
            AxisHints::new_x()
                .label("arrival time after the pulse (ns)")
                .formatter(tick),
            AxisHints::new_x()
                .label("optical path (m)")
                .formatter(|m: GridMark, _: &RangeInclusive<f64>| {
                    axes::format_sig(m.value * 1e-9 * C_M_PER_S, 3)
                })
                .placement(VPlacement::Top),
        ])
        .custom_y_axes(vec![y_axis])
}

/// `plot` with readable ticks on both axes (no time axes), the axes labelled.
pub(crate) fn value_plot<'a>(plot: Plot<'a>, x_label: &str, y_label: &str) -> Plot<'a> {
    plot.x_grid_spacer(spacer(X_LABEL_PX))
        .y_grid_spacer(spacer(Y_LABEL_PX))
        .custom_x_axes(vec![
            AxisHints::new_x().label(x_label.to_owned()).formatter(tick),
        ])
        .custom_y_axes(vec![
            AxisHints::new_y().label(y_label.to_owned()).formatter(tick),
        ])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The TPRF plot: 3.5-16 ns on a plot 300 points wide. egui_plot labels the
    /// marks whose step spans more than its 60-point minimum: several of them.
    #[test]
    fn the_spacer_gives_egui_plot_several_labelled_ticks() {
        let px = 300.0;
        let (lo, hi) = (3.5, 16.0);
        let base = (hi - lo) / px * GRID_MIN_PX;
        let marks = spacer(X_LABEL_PX)(GridInput {
            bounds: (lo, hi),
            base_step_size: base,
        });
        let labelled: Vec<f64> = marks
            .iter()
            .filter(|m| m.step_size * px / (hi - lo) > 60.0)
            .map(|m| m.value)
            .collect();
        assert!(labelled.len() >= 3, "{labelled:?}");
        let labels: Vec<String> = marks
            .iter()
            .filter(|m| labelled.contains(&m.value))
            .map(|m| tick(*m, &(lo..=hi)))
            .collect();
        assert_eq!(labels, vec!["5", "10", "15"]);
        assert_eq!(
            log_tick(
                GridMark {
                    value: -3.0,
                    step_size: 1.0
                },
                &(0.0..=1.0)
            ),
            "0.001"
        );
        let at = |value: f64| {
            log_tick(
                GridMark {
                    value,
                    step_size: 0.5,
                },
                &(0.0..=1.0),
            )
        };
        assert_eq!(at(0.0), "1");
        assert_eq!(at(1.0), "10");
        assert_eq!(at(0.5), "3.2");
        assert_eq!(at(-0.5), "0.32");
        assert_eq!(at(-6.0), "1e-6");
        assert_eq!(at(-6.5), "3.2e-7");
        assert_eq!(
            log_tick(
                GridMark {
                    value: -3.5,
                    step_size: 0.5
                },
                &(0.0..=1.0)
            ),
            "3.2e-4"
        );
    }
}

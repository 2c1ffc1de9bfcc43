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

/// A binned curve as steps, `[time ns, value]`: bin `b` flat from `t0_ns + b dt_ns` to
/// the next edge, with only the vertices that show when `per_px` bins share a screen
/// column ([`step_vertices`]). Non-finite values are drawn at 0.
pub(crate) fn steps(t0_ns: f64, dt_ns: f64, ys: &[f64], per_px: usize) -> Vec<[f64; 2]> {
    let finite: Vec<f64> = ys
        .iter()
        .map(|&y| if y.is_finite() { y } else { 0.0 })
        .collect();
    step_vertices(&finite, per_px.max(1))
        .into_iter()
        .map(|(edge, y)| [t0_ns + edge * dt_ns, y])
        .collect()
}

/// The vertices of the step curve of `ys` (bin `b` flat over bin edges `b .. b + 1`), as
/// (bin edge, value), with nothing a viewer could see left out: a run of equal values is
/// one segment (empty bins are most of a TPRF), and where `per_px` >= 3 bins share a
/// screen column each group of `per_px` bins is drawn as its first value, its largest,
/// its smallest and its last (the column a step curve fills there). Tessellating 2
/// vertices a bin of several 1024-bin curves was a tenth of the UI thread at 512^2.
///
/// Draw them with `Line::allow_band(false)`: egui_plot otherwise turns a line whose
/// points share pixel columns into a filled band interpolated between columns, which
/// across a long flat segment is a filled wedge (seen in a screenshot).
fn step_vertices(ys: &[f64], per_px: usize) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut push = |edge: f64, y: f64| {
        // A vertex on the line through the previous two at the same height is dropped.
        if let [.., (_, y0), (_, y1)] = out[..]
            && y0 == y
            && y1 == y
        {
            if let Some(last) = out.last_mut() {
                last.0 = edge;
            }
        } else if out.last() != Some(&(edge, y)) {
            out.push((edge, y));
        }
    };
    if per_px >= 3 {
        for (g, group) in ys.chunks(per_px).enumerate() {
            let start = (g * per_px) as f64;
            let (lo, hi) = group
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &y| {
                    (lo.min(y), hi.max(y))
                });
            let first = group[0];
            let last = group[group.len() - 1];
            let end = start + group.len() as f64;
            let mid = start + 0.5 * group.len() as f64;
            push(start, first);
            if lo != hi {
                push(mid, hi);
                push(mid, lo);
            }
            push(end, last);
        }
    } else {
        for (b, &y) in ys.iter().enumerate() {
            push(b as f64, y);
            push((b + 1) as f64, y);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The curve's height at `x` (a bin edge or inside a bin) along the vertices: the
    /// value of the segment there (on a vertical edge, any value along it).
    fn heights_at(v: &[(f64, f64)], x: f64) -> Vec<f64> {
        v.windows(2)
            .filter(|w| w[0].0 <= x && x <= w[1].0)
            .flat_map(|w| [w[0].1, w[1].1])
            .collect()
    }

    /// Runs of equal values become one segment; every bin's value is still drawn over
    /// its whole span.
    #[test]
    fn steps_keep_every_bin() {
        let ys = [0.0, 0.0, 0.0, 2.0, 3.0, 3.0, 0.0, 0.0];
        let v = step_vertices(&ys, 1);
        assert_eq!(
            v,
            vec![
                (0.0, 0.0),
                (3.0, 0.0),
                (3.0, 2.0),
                (4.0, 2.0),
                (4.0, 3.0),
                (6.0, 3.0),
                (6.0, 0.0),
                (8.0, 0.0)
            ]
        );
        for (b, y) in ys.iter().enumerate() {
            assert_eq!(heights_at(&v, b as f64 + 0.5), vec![*y, *y], "bin {b}");
        }
    }

    /// Several bins a column: each group reaches its largest and smallest value, starts
    /// at its first and ends at its last; flat groups stay one segment.
    #[test]
    fn columns_keep_their_extremes() {
        let ys: Vec<f64> = (0..40)
            .map(|b| {
                if (10..17).contains(&b) {
                    (b * 7 % 5) as f64
                } else {
                    0.0
                }
            })
            .collect();
        let v = step_vertices(&ys, 4);
        assert!(v.len() < 2 * ys.len() / 2, "{} vertices", v.len());
        for (g, group) in ys.chunks(4).enumerate() {
            let (x0, x1) = ((4 * g) as f64, (4 * g + 4) as f64);
            // What the curve reaches over the group: its vertices there, and its height
            // along a flat segment that crosses the whole group.
            let inside: Vec<f64> = v
                .iter()
                .filter(|(x, _)| *x >= x0 && *x <= x1)
                .map(|p| p.1)
                .chain(heights_at(&v, 0.5 * (x0 + x1)))
                .collect();
            let max = group.iter().cloned().fold(f64::MIN, f64::max);
            let min = group.iter().cloned().fold(f64::MAX, f64::min);
            assert!(inside.contains(&max) && inside.contains(&min), "group {g}");
            assert!(heights_at(&v, x0).contains(&group[0]), "group {g} start");
            assert!(heights_at(&v, x1).contains(&group[3]), "group {g} end");
        }
        assert_eq!(v.first(), Some(&(0.0, 0.0)));
        assert_eq!(v.last(), Some(&(40.0, 0.0)));
    }

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

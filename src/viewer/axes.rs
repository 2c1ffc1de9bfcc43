//! Numbers on screen, without egui: round 1-2-5 steps, the marks of a plot axis (so that
//! every axis carries several labelled ticks whatever its span), colour-bar ticks on a
//! linear or log scale, and values written with their unit in scientific notation where
//! plain decimals would hide them.

/// Unit of a bin of the cube: the integral over the bin of the radiance, for a pulse of
/// unit energy.
pub const BIN_UNIT: &str = "W m⁻² sr⁻¹ s";
/// [`BIN_UNIT`] in ASCII, for file headers.
pub const BIN_UNIT_ASCII: &str = "W m^-2 sr^-1 s";
/// Unit of the steady image (the sum over bins).
pub const STEADY_UNIT: &str = "W m⁻² sr⁻¹";

/// The smallest round step (`{1, 2, 2.5, 5} x 10^k`) that is at least `raw` (`raw >
/// 0`); `None` for a non-positive or non-finite `raw`.
pub fn nice_step(raw: f64) -> Option<f64> {
    if !(raw.is_finite() && raw > 0.0) {
        return None;
    }
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        // 1e-9 of slack: 0.3 / 0.1 is 2.9999999999999996.
        .find(|&s| s >= raw * (1.0 - 1e-9))
        .or(Some(10.0 * mag))
}

/// The grid step under a round step: 5 -> 1, 2.5 -> 0.5, 2 -> 0.5, 1 -> 0.2 (times its
/// power of ten).
fn finer_step(step: f64) -> f64 {
    let mag = 10f64.powf(step.log10().floor());
    let m = step / mag;
    if m >= 4.9 {
        mag
    } else if m >= 1.9 {
        0.5 * mag
    } else {
        0.2 * mag
    }
}

/// The multiples of `step` inside `[lo, hi]` (at most 10 000 of them).
fn multiples(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    if !(step > 0.0 && lo.is_finite() && hi.is_finite() && hi >= lo) {
        return Vec::new();
    }
    let first = (lo / step - 1e-9).ceil();
    let last = (hi / step + 1e-9).floor();
    if !(last - first < 10_000.0) {
        return Vec::new();
    }
    (first as i64..=last as i64)
        .map(|i| i as f64 * step)
        // -0 reads as "-0".
        .map(|v| if v == 0.0 { 0.0 } else { v })
        .collect()
}

/// One mark of an axis: its value and the step of its series (the labelled marks have
/// the largest step).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mark {
    pub value: f64,
    pub step: f64,
}

/// The marks of a plot axis showing `[lo, hi]` over `length_px` screen points: labelled
/// marks on a round 1-2-5 step at least `label_px` apart, and finer unlabelled ones
/// between them (a grid). Whatever the span (a 12 ns window, 1e-12 radiance), this
/// gives `length_px / label_px` labelled marks or a few fewer, never one or none while
/// the axis is longer than `2.5 label_px`.
pub fn axis_marks(lo: f64, hi: f64, length_px: f64, label_px: f64) -> Vec<Mark> {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0 && length_px > 0.0 && label_px > 0.0) {
        return Vec::new();
    }
    let Some(major) = nice_step(span * label_px / length_px) else {
        return Vec::new();
    };
    let minor = finer_step(major);
    let mut marks: Vec<Mark> = multiples(lo, hi, minor)
        .into_iter()
        .map(|value| Mark { value, step: minor })
        .collect();
    for v in multiples(lo, hi, major) {
        match marks
            .iter_mut()
            .find(|m| (m.value - v).abs() < 1e-6 * minor)
        {
            Some(m) => m.step = major,
            None => marks.push(Mark {
                value: v,
                step: major,
            }),
        }
    }
    marks.sort_by(|a, b| a.value.total_cmp(&b.value));
    marks
}

/// A tick label for `value` on an axis of marks `step` apart: plain decimals (as many
/// as the step needs) for steps from 1e-3 to 1e5, else scientific notation with the
/// digits the step needs (`2.5e-12`). Zero is `0`.
pub fn format_tick(value: f64, step: f64) -> String {
    if !value.is_finite() {
        return format!("{value}");
    }
    if value.abs() < 1e-9 * step.abs() {
        return "0".into();
    }
    let step = step.abs();
    if (1e-3..1e5).contains(&step) && value.abs() < 1e6 {
        return format!("{value:.*}", decimals_of(step));
    }
    let exp_v = value.abs().log10().floor();
    let exp_s = if step > 0.0 {
        step.log10().floor()
    } else {
        exp_v
    };
    // The digits the step needs below the value's leading one (2.5e-13: one).
    let step_digits = decimals_of(step / 10f64.powf(exp_s)) as f64;
    let digits = (exp_v - exp_s + step_digits).clamp(0.0, 6.0) as usize;
    trim_exp(format!("{value:.digits$e}"))
}

/// A value for a readout: 4 significant digits, in scientific notation below 1e-3 or
/// from 1e5 (`3.214e-3`), then ` unit` when `unit` is not empty.
pub fn format_value(v: f64, unit: &str) -> String {
    let number = if !v.is_finite() {
        format!("{v}")
    } else if v == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&v.abs()) {
        let decimals = (3.0 - v.abs().log10().floor()).max(0.0) as usize;
        format!("{v:.decimals$}")
    } else {
        trim_exp(format!("{v:.3e}"))
    };
    if unit.is_empty() {
        number
    } else {
        format!("{number} {unit}")
    }
}

/// `v` to `digits` significant digits in plain decimals (`1.499` -> `1.50` at 3), for a
/// second axis whose marks follow the first one's (optical path under round ns).
pub fn format_sig(v: f64, digits: u32) -> String {
    if !v.is_finite() || v == 0.0 {
        return format_value(v, "");
    }
    let mag = v.abs().log10().floor();
    if !(-3.0..6.0).contains(&mag) {
        return trim_exp(format!("{v:.*e}", digits.saturating_sub(1) as usize));
    }
    let decimals = (f64::from(digits) - 1.0 - mag).max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// The decimals that write `step` exactly (a 2.5 step needs one), at most 12.
fn decimals_of(step: f64) -> usize {
    (0..12)
        .find(|&d| {
            let x = step * 10f64.powi(d as i32);
            (x - x.round()).abs() < 1e-6 * x.abs().max(1.0)
        })
        .unwrap_or(12)
}

/// `1.500e-3` -> `1.5e-3`: trailing zeros of the mantissa dropped.
fn trim_exp(s: String) -> String {
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => {
            let m = m.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{e}")
        }
        _ => s,
    }
}

/// How a colour bar maps values to `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BarScale {
    /// `(v - lo) / (hi - lo)`.
    Linear { lo: f64, hi: f64 },
    /// `log(v / lo) / log(hi / lo)` (`0 < lo < hi`).
    Log { lo: f64, hi: f64 },
}

impl BarScale {
    /// Where `v` sits along the bar, `[0, 1]` inside it (not clamped).
    pub fn fraction(&self, v: f64) -> f64 {
        match *self {
            BarScale::Linear { lo, hi } => (v - lo) / (hi - lo),
            BarScale::Log { lo, hi } => (v / lo).ln() / (hi / lo).ln(),
        }
    }

    /// The value at `f` along the bar.
    pub fn value(&self, f: f64) -> f64 {
        match *self {
            BarScale::Linear { lo, hi } => lo + f * (hi - lo),
            BarScale::Log { lo, hi } => lo * (hi / lo).powf(f),
        }
    }

    /// Whether the bar has a span to draw (finite, `lo < hi`, `lo > 0` on a log scale).
    pub fn is_valid(&self) -> bool {
        match *self {
            BarScale::Linear { lo, hi } => lo.is_finite() && hi.is_finite() && lo < hi,
            BarScale::Log { lo, hi } => lo.is_finite() && hi.is_finite() && 0.0 < lo && lo < hi,
        }
    }
}

/// Ticks of a colour bar `length_px` long: `(fraction along the bar, label)`, at least
/// `label_px` apart. Linear: round 1-2-5 values; log: the decades (with 2 and 5 between
/// them when fewer than three decades are inside), labelled in scientific notation.
pub fn bar_ticks(scale: BarScale, length_px: f64, label_px: f64) -> Vec<(f64, String)> {
    if !scale.is_valid() {
        return Vec::new();
    }
    match scale {
        BarScale::Linear { lo, hi } => {
            // The round step for labels `label_px` apart; where that leaves fewer than
            // two ticks inside (0.6-1.4 m on a short bar: only "1"), the next finer
            // round steps, so a value can always be read off the bar.
            let major = axis_marks_major(lo, hi, length_px, label_px);
            let steps = [
                major,
                nice_step(0.4 * major).unwrap_or(major),
                finer_step(major),
            ];
            let ticks = |step: f64| multiples(lo, hi, step);
            let step = steps
                .into_iter()
                .find(|&s| ticks(s).len() >= 2)
                .unwrap_or(major);
            ticks(step)
                .into_iter()
                .map(|v| (scale.fraction(v), format_tick(v, step)))
                .collect()
        }
        BarScale::Log { lo, hi } => {
            let (e_lo, e_hi) = (lo.log10().ceil() as i32, hi.log10().floor() as i32);
            let decades = (hi / lo).log10();
            let per_decade = length_px / decades.max(1e-9);
            let mults: &[f64] = if per_decade > 3.0 * label_px {
                &[1.0, 2.0, 5.0]
            } else {
                &[1.0]
            };
            let mut ticks = Vec::new();
            for e in (e_lo - 1)..=e_hi {
                for &m in mults {
                    let v = m * 10f64.powi(e);
                    let f = scale.fraction(v);
                    if (-1e-9..=1.0 + 1e-9).contains(&f) {
                        ticks.push((f, v, e));
                    }
                }
            }
            // One notation for the whole bar: plain when every tick reads plainly.
            let plain = ticks.iter().all(|t| (-3..5).contains(&t.2));
            let out: Vec<(f64, String)> = ticks
                .into_iter()
                .map(|(f, v, e)| {
                    let label = if plain {
                        format!("{v:.*}", (-e).max(0) as usize)
                    } else {
                        trim_exp(format!("{v:.0e}"))
                    };
                    (f, label)
                })
                .collect();
            // Too many decades for the bar: keep every k-th.
            let keep = ((out.len() as f64 * label_px / length_px).ceil() as usize).max(1);
            out.into_iter().step_by(keep).collect()
        }
    }
}

/// The labelled step of [`axis_marks`].
fn axis_marks_major(lo: f64, hi: f64, length_px: f64, label_px: f64) -> f64 {
    nice_step((hi - lo) * label_px / length_px).unwrap_or(f64::INFINITY)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_follow_one_two_five() {
        assert_eq!(nice_step(0.3), Some(0.5));
        assert_eq!(nice_step(1.0), Some(1.0));
        assert_eq!(nice_step(1.01), Some(2.0));
        assert_eq!(nice_step(3.0e-12), Some(5.0e-12));
        assert_eq!(nice_step(7.0), Some(10.0));
        assert_eq!(nice_step(0.0), None);
        assert_eq!(nice_step(f64::NAN), None);
    }

    /// Labelled marks of an axis, as egui_plot shows them (the largest step).
    fn labelled(lo: f64, hi: f64, px: f64, label_px: f64) -> Vec<f64> {
        let marks = axis_marks(lo, hi, px, label_px);
        let top = marks.iter().fold(0.0f64, |a, m| a.max(m.step));
        marks
            .iter()
            .filter(|m| m.step == top)
            .map(|m| m.value)
            .collect()
    }

    /// The two windows on a 300 px plot: several labelled ns ticks, not one.
    #[test]
    fn a_time_axis_has_several_labelled_ticks() {
        let v = labelled(3.5, 16.3, 300.0, 70.0);
        assert_eq!(v, vec![5.0, 10.0, 15.0]);
        let v = labelled(14.0, 65.0, 300.0, 70.0);
        assert_eq!(v, vec![20.0, 40.0, 60.0]);
        // A wide plot gets more.
        assert!(labelled(3.5, 16.3, 700.0, 70.0).len() >= 6);
        // Every labelled mark is also on the minor grid's series.
        for m in axis_marks(3.5, 16.3, 300.0, 70.0) {
            assert!((3.5..=16.3).contains(&m.value));
        }
    }

    /// Radiance of 1e-12 on a 150 px y axis: labelled ticks at 2.5e-13 steps, written
    /// in scientific notation, not a single "0".
    #[test]
    fn a_tiny_value_axis_reads_in_scientific_notation() {
        let v = labelled(0.0, 1.1e-12, 150.0, 28.0);
        assert!(v.len() >= 4, "{v:?}");
        let labels: Vec<String> = v.iter().map(|&x| format_tick(x, 2.5e-13)).collect();
        assert_eq!(labels[0], "0");
        assert_eq!(labels[1], "2.5e-13");
        assert_eq!(labels[2], "5e-13");
        // Distinct labels: no two ticks read the same.
        let mut d = labels.clone();
        d.dedup();
        assert_eq!(d.len(), labels.len());
    }

    #[test]
    fn tick_labels_have_the_decimals_their_step_needs() {
        assert_eq!(format_tick(10.0, 5.0), "10");
        assert_eq!(format_tick(12.5, 2.5), "12.5");
        assert_eq!(format_tick(0.2, 0.1), "0.2");
        assert_eq!(format_tick(0.25, 0.05), "0.25");
        assert_eq!(format_tick(3.0e-6, 1e-6), "3e-6");
        assert_eq!(format_tick(2.5e-12, 5e-13), "2.5e-12");
        assert_eq!(format_tick(2e6, 1e6), "2e6");
        assert_eq!(format_tick(-0.0, 1.0), "0");
    }

    #[test]
    fn values_carry_four_digits_and_their_unit() {
        assert_eq!(format_value(3.21456e-3, "m"), "0.003215 m");
        assert_eq!(format_value(3.21456, "m"), "3.215 m");
        assert_eq!(format_value(3.21456e-4, "W"), "3.215e-4 W");
        assert_eq!(format_value(1.5e-12, ""), "1.5e-12");
        assert_eq!(format_value(12.0, "ns"), "12.00 ns");
        assert_eq!(format_value(0.0, "m"), "0 m");
        assert_eq!(format_value(2.0e7, ""), "2e7");
    }

    #[test]
    fn second_axis_labels_keep_three_digits() {
        // 5 ns of light travel is 1.49896229 m.
        assert_eq!(format_sig(1.49896229, 3), "1.50");
        assert_eq!(format_sig(14.9896229, 3), "15.0");
        assert_eq!(format_sig(149.896229, 3), "150");
        assert_eq!(format_sig(0.0149896, 3), "0.0150");
        assert_eq!(format_sig(0.0, 3), "0");
        assert_eq!(format_sig(1.5e-5, 3), "1.5e-5");
    }

    #[test]
    fn colour_bar_ticks_sit_where_their_values_are() {
        let lin = BarScale::Linear { lo: 0.0, hi: 4e-3 };
        let t = bar_ticks(lin, 200.0, 50.0);
        assert_eq!(
            t.iter().map(|x| x.1.as_str()).collect::<Vec<_>>(),
            vec!["0", "0.001", "0.002", "0.003", "0.004"]
        );
        assert!((t[2].0 - 0.5).abs() < 1e-12);
        // Three decades: a tick per decade, each at its place on the log bar.
        let log = BarScale::Log { lo: 1e-6, hi: 1e-3 };
        let t = bar_ticks(log, 200.0, 40.0);
        assert_eq!(
            t.iter().map(|x| x.1.as_str()).collect::<Vec<_>>(),
            vec!["1e-6", "1e-5", "1e-4", "1e-3"],
            "scientific throughout when one tick needs it"
        );
        assert!((t[1].0 - 1.0 / 3.0).abs() < 1e-9);
        // Less than a decade on a long bar: 2 and 5 between.
        let t = bar_ticks(BarScale::Log { lo: 1.5, hi: 60.0 }, 300.0, 40.0);
        let labels: Vec<&str> = t.iter().map(|x| x.1.as_str()).collect();
        assert_eq!(labels, vec!["2", "5", "10", "20", "50"]);
        // A short bar over 0.6-1.4 m: at 64 px a label, the 0.5 step leaves only "1";
        // a finer round step gives several.
        let t = bar_ticks(BarScale::Linear { lo: 0.6, hi: 1.4 }, 125.0, 64.0);
        let labels: Vec<&str> = t.iter().map(|x| x.1.as_str()).collect();
        assert_eq!(labels, vec!["0.6", "0.8", "1.0", "1.2", "1.4"]);
        // A signed range keeps its zero in the middle.
        let t = bar_ticks(
            BarScale::Linear {
                lo: -0.03,
                hi: 0.03,
            },
            125.0,
            64.0,
        );
        assert!(t.len() >= 2 && t.iter().any(|x| x.1 == "0" && (x.0 - 0.5).abs() < 1e-9));
        // Nothing to draw: no ticks, no panic.
        assert!(bar_ticks(BarScale::Log { lo: 0.0, hi: 1.0 }, 100.0, 40.0).is_empty());
        assert!(bar_ticks(BarScale::Linear { lo: 1.0, hi: 1.0 }, 100.0, 40.0).is_empty());
    }
}

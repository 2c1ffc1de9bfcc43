//! The time axis on screen: a pure mapping between bins, seconds and screen x, rebuilt
//! each frame (testable without egui), round tick times and bin labels. The widget that
//! draws it is the scrubber (`panels/scrubber.rs`).

use tprf_core::film::TimeAxis;
use tprf_core::units::C_M_PER_S;

/// Maps bins to screen x in `[left, right]` (bin centres spread over the width).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeRuler {
    pub axis: TimeAxis,
    pub left: f32,
    pub right: f32,
}

impl TimeRuler {
    /// Screen x of bin `b`'s centre.
    pub fn x_of_bin(&self, b: usize) -> f32 {
        let f = (b as f32 + 0.5) / self.axis.bins.max(1) as f32;
        self.left + f * (self.right - self.left)
    }

    /// Screen x of time `t_s` (bin centres at their `x_of_bin`).
    pub fn x_of_time(&self, t_s: f64) -> f32 {
        let f = ((t_s - self.axis.t0_s) / (self.axis.dt_s * self.axis.bins.max(1) as f64)) as f32;
        self.left + f * (self.right - self.left)
    }

    /// The bin under screen x (clamped to the axis).
    pub fn bin_at_x(&self, x: f32) -> usize {
        let w = (self.right - self.left).max(1e-6);
        let f = ((x - self.left) / w).clamp(0.0, 1.0);
        ((f * self.axis.bins as f32) as usize).min(self.axis.bins.saturating_sub(1))
    }
}

/// Round tick times (seconds) inside `[t0_s, t1_s]`: steps of 1, 2 or 5 x 10^k with at
/// most `max_ticks` ticks; also returns the number of decimals that show the step in ns.
pub fn nice_ticks_s(t0_s: f64, t1_s: f64, max_ticks: usize) -> (Vec<f64>, usize) {
    let span = t1_s - t0_s;
    if !(span.is_finite() && span > 0.0) || max_ticks == 0 {
        return (Vec::new(), 0);
    }
    let raw = span / max_ticks as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (t0_s / step).ceil() as i64;
    let last = (t1_s / step).floor() as i64;
    let ticks = (first..=last).map(|i| i as f64 * step).collect();
    let decimals = (-(step * 1e9).log10().floor()).max(0.0) as usize;
    (ticks, decimals)
}

/// The bin a new film opens on, "where its light is": the median of the lit pixels'
/// peak bins (`peaks`, per pixel, `None` for a dark pixel). Half the image has had its
/// brightest moment by then, so the slice shows the scene lit, neither before the light
/// has come nor after it has passed. `None` when no pixel is lit.
pub fn light_bin(peaks: &[Option<u32>]) -> Option<usize> {
    let mut lit: Vec<u32> = peaks.iter().flatten().copied().collect();
    if lit.is_empty() {
        return None;
    }
    let mid = lit.len() / 2;
    let (_, median, _) = lit.select_nth_unstable(mid);
    Some(*median as usize)
}

/// Bin centre time in ns and optical path length in m, for labels.
pub fn bin_label(axis: &TimeAxis, b: usize) -> String {
    let t = axis.bin_center_s(b);
    format!("{:.3} ns  ·  {:.3} m", t * 1e9, t * C_M_PER_S)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_inside() {
        // Cornell-like window 3.55 ns .. 16.35 ns: steps of 2 ns.
        let (t, d) = nice_ticks_s(3.55e-9, 16.35e-9, 8);
        let ns: Vec<f64> = t.iter().map(|x| (x * 1e9 * 1e6).round() / 1e6).collect();
        assert_eq!(ns, vec![4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0]);
        assert_eq!(d, 0);
        // Picoseconds: 0 .. 3.3 ps in 0.5 ps steps, three decimals in ns... four.
        let (t, d) = nice_ticks_s(0.0, 3.3e-12, 8);
        assert_eq!(t.len(), 7);
        assert!((t[1] - 0.5e-12).abs() < 1e-24);
        assert_eq!(d, 4);
        assert!(nice_ticks_s(1.0, 1.0, 5).0.is_empty());
        assert!(nice_ticks_s(0.0, f64::NAN, 5).0.is_empty());
    }

    #[test]
    fn a_new_film_opens_where_most_pixels_have_peaked() {
        // Peaks at 3, 5, 9, 40 and two dark pixels: the median of the lit is 9.
        let peaks = [Some(40), None, Some(3), Some(9), None, Some(5)];
        assert_eq!(light_bin(&peaks), Some(9));
        assert_eq!(light_bin(&[Some(7)]), Some(7));
        assert_eq!(light_bin(&[None, None]), None);
        assert_eq!(light_bin(&[]), None);
    }

    #[test]
    fn ruler_round_trips_bins() {
        let axis = TimeAxis::new(1e-9, 1e-11, 100).unwrap();
        let r = TimeRuler {
            axis,
            left: 10.0,
            right: 510.0,
        };
        for b in [0, 1, 50, 99] {
            assert_eq!(r.bin_at_x(r.x_of_bin(b)), b);
        }
        assert_eq!(r.bin_at_x(-100.0), 0);
        assert_eq!(r.bin_at_x(1e6), 99);
    }
}

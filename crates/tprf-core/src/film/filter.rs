//! The time filter: how one contribution at arrival time t is shared among bins.

use super::TimeAxis;
use serde::{Deserialize, Serialize};

/// How a contribution is binned. Both conserve energy: what arrives inside the window
/// is shared among bins with weights summing to 1, so the sum over bins (the steady
/// image) does not depend on the filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TimeFilter {
    /// The whole contribution lands in the bin holding t: a bin's expected value is the
    /// integral of the radiance over the bin (DESIGN.md).
    #[default]
    Box,
    /// Linear weights between the two nearest bin centres: less noise, but a bin's
    /// expected value is the integral smoothed by a one-bin tent (a bias of order
    /// `dt^2` times the curvature of the TPRF). Within half a bin of the window's ends
    /// everything goes to the end bin.
    Tent,
}

impl TimeFilter {
    pub fn name(self) -> &'static str {
        match self {
            TimeFilter::Box => "box",
            TimeFilter::Tent => "tent",
        }
    }
}

/// Bin-centre offsets closer than this (in bins) count as on the centre.
const SNAP_BINS: f64 = 1e-9;

impl TimeAxis {
    /// The tent filter's share of a contribution at `t_s`: `[(bin, weight); 2]` with
    /// weights summing to 1 (the second weight may be 0), or `None` outside the window.
    #[inline]
    pub fn tent_split(&self, t_s: f64) -> Option<[(usize, f64); 2]> {
        self.bin_of(t_s)?;
        let x = (t_s - self.t0_s) / self.dt_s - 0.5;
        let last = self.bins - 1;
        if x <= 0.0 {
            return Some([(0, 1.0), (0, 0.0)]);
        }
        if x >= last as f64 {
            return Some([(last, 1.0), (last, 0.0)]);
        }
        let b = x.floor();
        let f = x - b;
        let b = b as usize;
        Some(if f < SNAP_BINS {
            [(b, 1.0), (b, 0.0)]
        } else if f > 1.0 - SNAP_BINS {
            [((b + 1).min(last), 1.0), (b, 0.0)]
        } else {
            [(b, 1.0 - f), ((b + 1).min(last), f)]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tent_weights_sum_to_one_and_centres_land_in_one_bin() {
        let a = TimeAxis::new(1e-9, 1e-10, 10).unwrap();
        for b in 0..10 {
            let s = a.tent_split(a.bin_center_s(b)).unwrap();
            assert_eq!(s[0], (b, 1.0));
            assert_eq!(s[1].1, 0.0);
        }
        let s = a.tent_split(1e-9 + 2.75e-10).unwrap();
        assert_eq!((s[0].0, s[1].0), (2, 3));
        assert!((s[0].1 - 0.75).abs() < 1e-9 && (s[1].1 - 0.25).abs() < 1e-9);
        assert_eq!(a.tent_split(1e-9 + 1e-12).unwrap()[0], (0, 1.0));
        assert_eq!(a.tent_split(2e-9 - 1e-12).unwrap()[0], (9, 1.0));
        assert!(a.tent_split(0.5e-9).is_none() && a.tent_split(f64::NAN).is_none());
        for k in 0..1000 {
            let t = 1e-9 + 1e-9 * k as f64 / 1000.0;
            let s = a.tent_split(t).unwrap();
            assert!((s[0].1 + s[1].1 - 1.0).abs() < 1e-15);
        }
    }
}

//! The time axis of a transient cube: `t0` and bin width `dt`; bin `b` covers
//! `[t0 + b dt, t0 + (b + 1) dt)` (DESIGN.md conventions).

use super::FilmError;
use crate::units::C_M_PER_S;
use serde::{Deserialize, Serialize};

/// Largest number of bins tprf accepts on one axis.
pub const MAX_BINS: usize = 1 << 22;

/// Start, bin width and bin count of the arrival-time axis, seconds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeAxis {
    pub t0_s: f64,
    pub dt_s: f64,
    pub bins: usize,
}

impl TimeAxis {
    /// A checked axis: finite `t0_s`, finite `dt_s > 0`, `1 <= bins <= MAX_BINS`.
    pub fn new(t0_s: f64, dt_s: f64, bins: usize) -> Result<TimeAxis, FilmError> {
        if !t0_s.is_finite() {
            return Err(FilmError::StartNotFinite { t0_s });
        }
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(FilmError::BinWidth { dt_s });
        }
        if bins == 0 || bins > MAX_BINS {
            return Err(FilmError::BinCount { bins });
        }
        let end = t0_s + dt_s * bins as f64;
        if !end.is_finite() || end <= t0_s {
            return Err(FilmError::NotRepresentable { t0_s, dt_s, bins });
        }
        Ok(TimeAxis { t0_s, dt_s, bins })
    }

    /// End of the last bin, seconds.
    pub fn end_s(&self) -> f64 {
        self.t0_s + self.dt_s * self.bins as f64
    }

    /// The bin holding arrival time `t_s`, or `None` outside the window.
    #[inline]
    pub fn bin_of(&self, t_s: f64) -> Option<usize> {
        let x = (t_s - self.t0_s) / self.dt_s;
        // `x >= 0.0` is false for NaN too.
        if x >= 0.0 && x < self.bins as f64 {
            Some((x as usize).min(self.bins - 1))
        } else {
            None
        }
    }

    /// Start of bin `b`, seconds.
    pub fn bin_start_s(&self, b: usize) -> f64 {
        self.t0_s + self.dt_s * b as f64
    }

    /// Centre of bin `b`, seconds.
    pub fn bin_center_s(&self, b: usize) -> f64 {
        self.t0_s + self.dt_s * (b as f64 + 0.5)
    }

    /// Optical path length at time `t_s` in vacuum, metres (`opl = c t`).
    pub fn opl_m(t_s: f64) -> f64 {
        t_s * C_M_PER_S
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_cover_half_open_intervals() {
        let a = TimeAxis::new(1e-9, 1e-10, 10).unwrap();
        assert_eq!(a.bin_of(1e-9), Some(0));
        assert_eq!(a.bin_of(1e-9 - 1e-15), None);
        assert_eq!(a.bin_of(1.05e-9), Some(0));
        assert_eq!(a.bin_of(1.95e-9), Some(9));
        assert_eq!(a.bin_of(2e-9 + 1e-15), None);
        assert_eq!(a.bin_of(f64::NAN), None);
        assert!((a.end_s() - 2e-9).abs() < 1e-24);
    }

    #[test]
    fn rejects_bad_axes() {
        assert!(TimeAxis::new(0.0, 0.0, 4).is_err());
        assert!(TimeAxis::new(0.0, -1.0, 4).is_err());
        assert!(TimeAxis::new(f64::NAN, 1.0, 4).is_err());
        assert!(TimeAxis::new(0.0, 1.0, 0).is_err());
        assert!(TimeAxis::new(0.0, f64::INFINITY, 4).is_err());
        assert!(TimeAxis::new(0.0, 1.0, MAX_BINS + 1).is_err());
    }
}

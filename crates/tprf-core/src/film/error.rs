//! Why a time axis or a film cannot be made.

use super::MAX_BINS;
use crate::budget::{Limit, format_bytes};

/// Why a [`super::TimeAxis`] or a [`super::TprfFilm`] cannot be made. Messages name the
/// value and what is allowed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FilmError {
    #[error("time axis start {t0_s} s is not finite")]
    StartNotFinite { t0_s: f64 },
    #[error("bin width {dt_s} s must be finite and > 0")]
    BinWidth { dt_s: f64 },
    #[error("bin count {bins} must be in 1..={MAX_BINS}")]
    BinCount { bins: usize },
    #[error("time axis t0 {t0_s} s + {bins} bins of {dt_s} s is not representable")]
    NotRepresentable { t0_s: f64, dt_s: f64, bins: usize },
    #[error(
        "a film of {width} x {height} pixels x {bins} bins has more cells than memory can index"
    )]
    SizeOverflow {
        width: usize,
        height: usize,
        bins: usize,
    },
    #[error(
        "a film of {width} x {height} pixels x {bins} bins needs {} before any light is \
         stored (its pixel directory, a snapshot's images, the exported steady image); {} \
         available ({limited_by}); lower the resolution",
        format_bytes(*need_bytes),
        format_bytes(*available_bytes)
    )]
    NotEnoughMemory {
        width: usize,
        height: usize,
        bins: usize,
        need_bytes: u64,
        available_bytes: u64,
        limited_by: Limit,
    },
}

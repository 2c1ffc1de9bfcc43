//! Why a time axis or a film cannot be made.

use super::MAX_BINS;

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
        "a film of {width} x {height} pixels x {bins} bins needs at least {:.1} GiB before \
         any light is stored, and {:.1} GiB is free; lower the resolution",
        gib(*need_bytes),
        gib(*free_bytes)
    )]
    NotEnoughMemory {
        width: usize,
        height: usize,
        bins: usize,
        need_bytes: u64,
        free_bytes: u64,
    },
}

/// Bytes in GiB (2^30 bytes).
fn gib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 30) as f64
}

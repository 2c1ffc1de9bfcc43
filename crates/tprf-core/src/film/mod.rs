//! Film: the TPRF store. Time-binned accumulators per pixel (pbrt's "film": how samples
//! accumulate), kept apart from the sensor (what is measured from them). Memory follows
//! the bins that received light: each pixel keeps runs of non-zero bins.

mod error;
mod filter;
mod layout;
mod row;
mod sink;
mod snapshot;
pub mod sparse;
mod stokes;
mod store;
mod time_axis;

pub use error::FilmError;
pub use filter::TimeFilter;
pub use layout::{FilmLayout, RE_EMITTED, scattering_count};
pub use row::{PixelPass, PixelSamples};
pub use sink::{LeftOut, LeftOutCounts, PixelSink};
pub use snapshot::{
    DENSE_BAND_VALUES, FilmSnapshot, SliceCursor, SnapshotBuilder, quantile, quantile_f32,
    quantile_positive, robust_max,
};
pub use stokes::{StokesFilms, StokesPixelSink};
pub use store::{BYTES_PER_PIXEL, PassTally, StoreStats, TprfFilm, half_error_from_terms};
pub use time_axis::{MAX_BINS, TimeAxis};

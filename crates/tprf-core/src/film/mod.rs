//! Film: the TPRF store. Time-binned accumulators per pixel (pbrt's "film": how samples
//! accumulate), kept apart from the sensor (what is measured from them).

mod error;
mod filter;
mod snapshot;
mod store;
mod time_axis;

pub use error::FilmError;
pub use filter::TimeFilter;
pub use snapshot::{FilmSnapshot, quantile_positive, robust_max};
pub use store::{FilmLayout, PixelSink, TprfFilm, available_memory_bytes};
pub use time_axis::{MAX_BINS, TimeAxis};

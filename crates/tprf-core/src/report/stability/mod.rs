//! Stiff and extreme cases as a verdict table: albedo 0.99 and 0.999 furnaces (energy,
//! mean arrival, the order law, Russian roulette's variance), the same scenes at 1 mm,
//! 1 m and 10 km, 1 and 100 000 time bins, 10^8 samples in one bin, a point light 1e-6 m
//! from a wall, grazing light and view, coincident faces and degenerate triangles, and
//! the sensor on hand-made TPRFs (pulses, gates, noise, huge values, a SPAD at 10^9
//! cycles with saturating returns and ambient), and extreme participating media (an
//! optical depth of 1e4, an albedo of 0.9999, fog at 1 mm and at 10 km), and a
//! luminescent surface of lifetime 1 ms on 10 ps bins.
//!
//! Most rows compare with an answer derived independently of the renderer (a closed
//! form, a quadrature, the renewal equation, an exact sum): [`Kind::Reference`]. The
//! scale rows (1 mm and 10 km against 1 m) and the 100 000-bin sum (against one bin)
//! compare the renderer with itself on an equivalent input: [`Kind::Invariance`], a
//! check that nothing changes, not a measure of accuracy. The table says which.
//!
//! [`Size::Test`] runs in the test suite (seconds); [`Size::Full`] is `tprf stability`
//! (larger films, more samples). Every row says what was expected, what came out, how
//! far apart they may be and why, how many values were NaN or infinite, and a verdict.
//!
//! Files: `verdict` (rows, checks, the table), `common` (the size, rendering, pixel
//! statistics), and one `cases_*` file per family of cases.

mod cases_bins;
mod cases_furnace;
mod cases_geometry;
mod cases_luminescence;
mod cases_media;
mod cases_scales;
mod cases_sensor;
mod common;
mod verdict;

pub use cases_bins::bins;
pub use cases_furnace::stiff_furnace;
pub use cases_geometry::{bad_faces, grazing, light_near_wall};
pub use cases_luminescence::stiff_luminescence;
pub use cases_media::extreme_media;
pub use cases_scales::scales;
pub use cases_sensor::{pulses_and_gates, sensor_extremes, spad_extremes};
pub use common::Size;
pub use verdict::{Check, Kind, Row, markdown};

/// A case: its rows at a size.
pub type Case = fn(Size) -> Vec<Row>;

/// The cases by name, each runnable alone.
pub fn cases() -> Vec<(&'static str, Case)> {
    vec![
        ("stiff furnace", stiff_furnace),
        ("scales", scales),
        ("bins", bins),
        ("point light near a wall", light_near_wall),
        ("grazing angles", grazing),
        ("coincident and degenerate faces", bad_faces),
        ("pulses and gates", pulses_and_gates),
        ("sensor extremes", sensor_extremes),
        ("SPAD extremes", spad_extremes),
        ("extreme media", extreme_media),
        ("stiff luminescence", stiff_luminescence),
    ]
}

/// Every case.
pub fn run_all(size: Size) -> Vec<Row> {
    cases().into_iter().flat_map(|(_, f)| f(size)).collect()
}

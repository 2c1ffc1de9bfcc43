//! tprf: the desktop studio and command line over [`tprf_core`].
//!
//! The renderer, film, sensor and files live in `tprf-core` (no window, no argument
//! parser); this crate adds the egui/eframe viewer and the `tprf` command.

pub mod cli;
pub mod viewer;

//! tprf: the desktop studio and command line over [`tprf_core`].
//!
//! The renderer, film, sensor and files live in `tprf-core` (no window, no argument
//! parser); this crate adds the egui/eframe viewer and the `tprf` command.

// `!(x > 0.0)` is how this crate rejects NaN along with the non-positive values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod cli;
pub mod viewer;

//! tprf: transient rendering (Smith, Skorupski & Davis 2008).
//!
//! Data flow, each arrow one-way (see ARCHITECTURE.md):
//! `scene -> accel -> transport -> film -> (sensor, viewer, export)`.

// `!(x > 0.0)` is how this crate rejects NaN along with the non-positive values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod cli;
pub mod export;
pub mod film;
pub mod oned;
pub mod reference;
pub mod report;
pub mod scene;
pub mod sensor;
pub mod transport;
pub mod units;
pub mod viewer;

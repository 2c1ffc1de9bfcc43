//! tprf: transient rendering (Smith, Skorupski & Davis 2008).
//!
//! Data flow, each arrow one-way (see ARCHITECTURE.md):
//! `scene -> accel -> transport -> film -> (sensor, viewer, export)`.

pub mod accel;
pub mod film;
pub mod scene;
pub mod transport;
pub mod units;
pub mod cli;
pub mod export;

//! tprf: transient rendering (Smith, Skorupski & Davis 2008).
//!
//! Data flow, each arrow one-way (see ARCHITECTURE.md):
//! `scene -> accel -> transport -> film -> (sensor, viewer, export)`.

pub mod accel;
pub mod cli;
pub mod export;
pub mod film;
pub mod oned;
pub mod scene;
pub mod sensor;
pub mod transport;
pub mod units;

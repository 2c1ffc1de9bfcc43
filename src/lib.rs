//! tprf: transient rendering (Smith, Skorupski & Davis 2008).
//!
//! Data flow, each arrow one-way (see ARCHITECTURE.md):
//! `scene -> accel -> transport -> film -> (sensor, viewer, export)`.

pub mod oned;
pub mod scene;
pub mod units;

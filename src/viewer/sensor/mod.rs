//! The sensor in the window (the paper's section 6): edit Light(t) and the gates
//! Exposure_i(t) over a rendered film and see the measurements M_i at once. Nothing is
//! re-rendered: each frame the edited [`Sensor`](tprf_core::sensor::Sensor) goes to
//! [`SensorModel::update`](tprf_core::sensor::SensorModel::update) (kernels recomputed
//! only when the light or the gates changed) and the measurement is redone only when
//! the sensor or the film snapshot changed.
//!
//! - `state`: [`SensorState`], the model, the gate on screen measured in the frame, and
//!   the latest measurement of all gates;
//! - `measure`: all gates, noise and derived depth, on a background pool;
//! - `handles`: where the editor's handles are and what dragging one changes (pure);
//! - `view`: the editor's time range, gates outside the film's window and the ways out,
//!   handles kept apart (pure);
//! - `controls`, `editor`, `plots`, `images`: the widgets.

mod controls;
mod editor;
mod handles;
mod images;
mod measure;
mod plots;
mod state;
mod view;

pub(crate) use controls::controls_ui;
pub(crate) use editor::editor_ui;
pub(crate) use images::{CoverageAction, images_ui};
pub(crate) use plots::pixel_plots_ui;
pub use state::SensorState;

use eframe::egui::Color32;
use tprf_core::sensor::SensorModel;

const LIGHT_COLOR: Color32 = Color32::from_rgb(0xff, 0xc8, 0x3d);
const GATE_COLOR: Color32 = Color32::from_rgb(0x4d, 0xc3, 0xff);
const TPRF_COLOR: Color32 = Color32::from_gray(0x90);
/// Gates and times outside the film's window.
const OUTSIDE_COLOR: Color32 = Color32::from_rgb(0xff, 0x5a, 0x5a);

/// "(centre X ns)" of gate `i`, or nothing when the gate has no centre.
fn gate_time_label(model: &SensorModel, i: usize) -> String {
    model
        .gates()
        .get(i)
        .and_then(|g| g.centre_s())
        .map_or(String::new(), |c| format!("(centre {:.3} ns)", c * 1e9))
}

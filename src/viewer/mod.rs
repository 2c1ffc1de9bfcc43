//! The viewer: an egui/eframe window over a TPRF film. Immediate mode: each frame it
//! reads the latest snapshot and status from the render worker (or a cube loaded from
//! disk) and draws; it mirrors no film data. It talks to the renderer only by starting,
//! pausing and dropping a [`RenderWorker`](tprf_core::request::worker::RenderWorker),
//! and never waits for it.
//!
//! - `app`: [`TprfApp`] and the order in which a frame draws its panels;
//! - `settings`: [`ViewerSettings`] (persisted), [`Mode`], the render job they describe;
//! - `source`: where the film comes from (a render worker or a cube on disk);
//! - `selection`: the pixel or box plotted ([`Selection`]);
//! - `playback`: the scrubber's bin over time, keys and the playback clock;
//! - `tone`, `textures`: film values to pixels, and textures keyed on what they show;
//! - `panels`: one file per panel (top bar, controls, scrubber, images, plots, status);
//! - `exports`: PNG, video and CSV files saved from the window, images encoded in the
//!   background;
//! - [`colormap`], [`timeline`], [`axes`], [`layout`]: pure colour, time-axis, tick and
//!   number, and image-layout mappings (tested without a window);
//! - [`camera`]: the camera pose as numbers and what the mouse does to it (orbit, pan,
//!   dolly, field of view; tested without a window), the request's camera override;
//! - [`fog`]: the scene-wide fog as the window edits it (visibility, albedo, g) and the
//!   request's `medium` spec it becomes (tested without a window);
//! - `colorbar`, `plotting`: the colour bar under every image, and egui_plot set up
//!   with readable ticks and units;
//! - `input`: a frame's keyboard input cut at a Tab, so typing never lands in the next
//!   field;
//! - `files`: choosing a file: the system dialog, or a path typed in the window when
//!   the dialog cannot open;
//! - [`sensor`]: the sensor tab (model, background measurement, envelope editor);
//! - [`nlos`]: the view of an NLOS capture folder (time slices on the wall grid, a wall
//!   point's transient, the reconstruction's projections from a thread of its own).

mod app;
pub mod axes;
pub mod camera;
mod colorbar;
pub mod colormap;
mod exports;
mod files;
pub mod fog;
mod input;
pub mod layout;
pub mod nlos;
mod panels;
mod playback;
mod plotting;
mod selection;
pub mod sensor;
mod settings;
mod source;
mod textures;
pub mod timeline;
mod tone;

pub use app::{FrameTiming, TprfApp};
pub use camera::CameraPose;
pub use files::FileAction;
pub use fog::Fog;
pub use selection::Selection;
pub use settings::{Mode, SteadyBlock, ViewerSettings};

use eframe::egui;
use std::path::PathBuf;

/// What the window opens on.
#[derive(Clone, Debug)]
pub enum Start {
    /// Render the scene of the saved settings (first run: `builtin:cornell`).
    Default,
    /// Render this scene (`builtin:NAME` or a glTF path).
    Scene(String),
    /// Show a cube written by `tprf render`, or an NLOS capture written by `tprf nlos`
    /// (no rendering).
    Cube(PathBuf),
}

/// Open the window and run until it is closed.
pub fn run(start: Start) -> eframe::Result {
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_inner_size([1280.0, 800.0])
            .with_min_inner_size([800.0, 500.0])
            .with_title("tprf — transient rendering")
            .with_drag_and_drop(true),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    eframe::run_native(
        "tprf",
        options,
        Box::new(move |cc| Ok(Box::new(TprfApp::new(cc, start)))),
    )
}

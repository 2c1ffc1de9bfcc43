//! The viewer: an egui/eframe window over a TPRF film. Immediate mode: each frame it
//! reads the latest snapshot and status from the render worker (or a cube loaded from
//! disk) and draws; it mirrors no film data. It talks to the renderer only by starting,
//! pausing and dropping a [`RenderWorker`], and never waits for it.

mod app;
pub mod colormap;
pub mod sensor_ui;
pub mod timeline;

pub use app::{Mode, Selection, TprfApp, ViewerSettings};

use eframe::egui;
use std::path::PathBuf;

/// What the window opens on.
#[derive(Clone, Debug)]
pub enum Start {
    /// Render the scene of the saved settings (first run: `builtin:cornell`).
    Default,
    /// Render this scene (`builtin:NAME` or a glTF path).
    Scene(String),
    /// Show a cube written by `tprf render` (no rendering).
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

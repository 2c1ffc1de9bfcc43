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
//! - [`phasor`]: the phasor tab (a frequency's amplitude and phase images, from the
//!   cube's `phasor.npy` or computed from the film; its maths tested without a window);
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
pub mod phasor;
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

/// What the window is cleared to before each frame is painted: the panels' colour.
/// The panels are drawn without a fill of their own (`panel_frame`): the clear is
/// free, where their fills were a layer over every pixel of the window that a software
/// rasteriser (Mesa's llvmpipe, without a GPU) shaded and blended, a million fragments
/// a frame at 1280 x 800 (`cargo bench --bench viewer -- paint` counts them).
pub fn background(visuals: &egui::Visuals) -> egui::Color32 {
    visuals.panel_fill
}

/// A side, top or bottom panel's frame: egui's, without its fill ([`background`]).
pub(crate) fn panel_frame(ui: &egui::Ui) -> egui::Frame {
    egui::Frame::side_top_panel(ui.style()).fill(egui::Color32::TRANSPARENT)
}

/// The central panel's frame: egui's, without its fill ([`background`]).
pub(crate) fn central_frame(ui: &egui::Ui) -> egui::Frame {
    egui::Frame::central_panel(ui.style()).fill(egui::Color32::TRANSPARENT)
}

/// A frame painted over transparency (as egui_kittest renders one: premultiplied
/// colours, as blended) put over the window's [`background`]: the image the window
/// shows, `c + (1 - a) background` per channel.
pub fn over_background(image: &mut image::RgbaImage, visuals: &egui::Visuals) {
    let bg = background(visuals).to_array();
    for p in image.pixels_mut() {
        let a = u32::from(p[3]);
        for (c, b) in p.0.iter_mut().zip(bg) {
            let v = u32::from(*c) + (u32::from(b) * (255 - a) + 127) / 255;
            *c = v.min(255) as u8;
        }
    }
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

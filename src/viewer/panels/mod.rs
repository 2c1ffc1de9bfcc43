//! The window's panels, one file each: the top bar, the status line, the controls on
//! the left, the time scrubber, the images in the centre, the TPRF and error plots on
//! the right. Each extends [`TprfApp`](super::app::TprfApp) with its `*_ui` method.

mod controls;
mod error_plot;
mod images;
mod plot;
mod scrubber;
mod status_line;
mod top_bar;

use eframe::egui::Color32;

/// The selection's colour (index 0), then the pins'.
const PIN_COLORS: [Color32; 6] = [
    Color32::from_rgb(0x4e, 0xc9, 0xff),
    Color32::from_rgb(0xff, 0x9f, 0x43),
    Color32::from_rgb(0x7b, 0xe0, 0x7b),
    Color32::from_rgb(0xff, 0x6b, 0xd6),
    Color32::from_rgb(0xff, 0xe0, 0x66),
    Color32::from_rgb(0xb0, 0x9c, 0xff),
];

/// The per-bounce curves: 1, 2, 3, more than 3 scattering events.
const BOUNCE_COLORS: [Color32; 4] = [
    Color32::from_rgb(0xff, 0x55, 0x55),
    Color32::from_rgb(0x55, 0xdd, 0x55),
    Color32::from_rgb(0x66, 0x99, 0xff),
    Color32::from_rgb(0xcc, 0xcc, 0xcc),
];

/// The scrubber's bin, on the ruler and on the plot.
const SCRUBBER_COLOR: Color32 = Color32::from_rgb(0xff, 0x9f, 0x43);

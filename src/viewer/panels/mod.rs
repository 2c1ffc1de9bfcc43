//! The window's panels, one file each: the top bar, the status line, the controls on
//! the left, the time scrubber, the images in the centre, the TPRF and error plots on
//! the right, the camera (its pose typed, and the mouse on the images), the scene's fog. Each extends [`TprfApp`](super::app::TprfApp) with its `*_ui` method.

mod camera;
mod controls;
mod error_plot;
mod images;
mod medium;
mod plot;
mod scrubber;
mod status_line;
mod top_bar;

pub(crate) use camera::{CameraGesture, GESTURES_HINT, SceneView};

use eframe::egui::{self, Color32};

/// A message's colour: a file written is news, anything else a warning.
fn message_color(ui: &egui::Ui, m: &str) -> Color32 {
    if m.starts_with("saved ") || m.starts_with("from the scene file") {
        ui.visuals().strong_text_color()
    } else {
        ui.visuals().warn_fg_color
    }
}

/// The selection's colour (index 0), then the pins'. None is the scrubber's or a
/// bounce curve's (see the test).
const PIN_COLORS: [Color32; 6] = [
    Color32::from_rgb(0x4e, 0xc9, 0xff),
    Color32::from_rgb(0xff, 0x9f, 0x43),
    Color32::from_rgb(0xff, 0x6b, 0xd6),
    Color32::from_rgb(0xf0, 0xf0, 0x50),
    Color32::from_rgb(0x2e, 0xd8, 0xa8),
    Color32::from_rgb(0x30, 0x50, 0xff),
];

/// The per-bounce curves (drawn dashed): the light seen directly, ...
const DIRECT_COLOR: Color32 = Color32::from_rgb(0xa0, 0xf8, 0xf8);
/// ... 1, 2, 3 ... scattering events (round again past the sixth) ...
const BOUNCE_COLORS: [Color32; 6] = [
    Color32::from_rgb(0xff, 0x50, 0x50),
    Color32::from_rgb(0x6c, 0xe0, 0x4c),
    Color32::from_rgb(0xa8, 0x78, 0xff),
    Color32::from_rgb(0xb8, 0x00, 0xc8),
    Color32::from_rgb(0xb8, 0xc8, 0x00),
    Color32::from_rgb(0x00, 0xa0, 0xe0),
];
/// ... and more than the film keeps apart (its last bounce layer) ...
const REST_COLOR: Color32 = Color32::from_rgb(0xb4, 0xb4, 0xb4);
/// ... and the light a luminescent surface re-emitted (its luminescence layer).
const LUMINESCENCE_COLOR: Color32 = Color32::from_rgb(0x00, 0xff, 0x40);

/// The colour of layer `l` of a film with `layers` of them and its luminescence layer
/// at `luminescence` (layer 0 direct, the last bounce layer "more than K"; see
/// [`plot::bounce_layer_name`]).
fn bounce_color(l: usize, layers: usize, luminescence: Option<usize>) -> Color32 {
    let bounce_layers = layers - usize::from(luminescence.is_some());
    match l {
        l if Some(l) == luminescence => LUMINESCENCE_COLOR,
        0 => DIRECT_COLOR,
        l if l + 1 == bounce_layers => REST_COLOR,
        l => BOUNCE_COLORS[(l - 1) % BOUNCE_COLORS.len()],
    }
}

/// The scrubber's bin, on the ruler and on the plot: white, like no curve.
const SCRUBBER_COLOR: Color32 = Color32::from_rgb(0xff, 0xff, 0xff);

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pair of curve colours on the TPRF plot (selection, pins, bounces, scrubber)
    /// differs by at least 80 in RGB distance, so no two read as the same curve.
    #[test]
    fn plot_colours_do_not_collide() {
        let all: Vec<Color32> = PIN_COLORS
            .iter()
            .chain(&BOUNCE_COLORS)
            .chain([&DIRECT_COLOR, &REST_COLOR, &LUMINESCENCE_COLOR])
            .chain(std::iter::once(&SCRUBBER_COLOR))
            .copied()
            .collect();
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                let d = [a.r(), a.g(), a.b()]
                    .iter()
                    .zip([b.r(), b.g(), b.b()])
                    .map(|(x, y)| (f32::from(*x) - f32::from(y)).powi(2))
                    .sum::<f32>()
                    .sqrt();
                assert!(d >= 80.0, "{a:?} and {b:?} are {d:.0} apart");
            }
        }
    }
}

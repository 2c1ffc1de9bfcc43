//! Film values to pixels as the window shows them: the exposure of each view (per frame
//! or global, EV offset, log scale) and the RGBA8 pixels of the time slice, the steady
//! image and the rainbow image. Pure functions of a snapshot and the settings.

use super::colormap::{self, ColorMap, ExposureMode, Tone};
use super::settings::ViewerSettings;
use tprf_core::film::FilmSnapshot;

/// Which image of the film a texture shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum View {
    /// The time slice of the scrubber's bin.
    Slice,
    /// The sum over time.
    Steady,
    /// Hue = arrival time of each pixel's peak.
    Rainbow,
}

impl View {
    /// The texture's name.
    pub(super) fn name(self) -> &'static str {
        match self {
            View::Slice => "Slice",
            View::Steady => "Steady",
            View::Rainbow => "Rainbow",
        }
    }
}

/// The EV offset as a factor, `2^ev`.
fn ev_gain(settings: &ViewerSettings) -> f64 {
    2f64.powf(settings.ev as f64)
}

/// One exposure for the whole film: `scale = 2^ev / robust_max` (the 99.9 % quantile of
/// the cube), so brightness compares across time. The video's exposure.
pub(super) fn global_tone(settings: &ViewerSettings, snap: &FilmSnapshot) -> Tone {
    Tone {
        scale: snap.robust_max().map_or(1.0, |b| 1.0 / b) * ev_gain(settings),
        log: settings.log_image,
        decades: 3.0,
    }
}

/// The exposure of a time slice with values `values`: per frame, `scale = 2^ev / q`
/// with `q` the slice's 99.5 % quantile; global, [`global_tone`].
pub(super) fn slice_tone(settings: &ViewerSettings, snap: &FilmSnapshot, values: &[f32]) -> Tone {
    match settings.exposure {
        ExposureMode::PerFrame => Tone {
            scale: colormap::quantile_positive(values.iter().copied(), 0.995)
                .map_or(1.0, |b| 1.0 / b)
                * ev_gain(settings),
            log: settings.log_image,
            decades: 3.0,
        },
        ExposureMode::Global => global_tone(settings, snap),
    }
}

/// RGBA8 pixels (`[H, W]`, row 0 = top) of `view` of `snap`; `bin` is the time slice's.
pub(super) fn view_pixels(
    view: View,
    snap: &FilmSnapshot,
    bin: usize,
    settings: &ViewerSettings,
) -> Vec<u8> {
    match view {
        View::Slice => {
            let values = snap.slice(bin);
            let tone = slice_tone(settings, snap, &values);
            colormap::colorize(&values, &tone, settings.colormap)
        }
        View::Steady => {
            // The 99 % quantile at 80 % grey, so the lamp and the lit walls both read.
            let values = snap.steady();
            let base =
                colormap::quantile_positive(values.iter().copied(), 0.99).map_or(1.0, |b| 0.8 / b);
            let tone = Tone {
                scale: base * ev_gain(settings),
                log: settings.log_image,
                decades: 3.0,
            };
            colormap::colorize(values, &tone, ColorMap::Gray)
        }
        View::Rainbow => {
            let base = colormap::quantile_positive(snap.steady().iter().copied(), 0.99)
                .map_or(1.0, |b| 1.0 / b);
            let tone = Tone {
                scale: base * ev_gain(settings),
                log: false,
                decades: 3.0,
            };
            colormap::rainbow(snap.peak_bins(), snap.steady(), snap.axis().bins, &tone)
        }
    }
}

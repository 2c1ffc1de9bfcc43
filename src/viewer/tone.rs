//! Film values to pixels as the window shows them: the exposure of each view (per frame
//! or global, EV offset, log scale) and the RGBA8 pixels of the time slice, the steady
//! image and the rainbow image. Pure functions of a snapshot and the settings.

use super::axes::BarScale;
use super::colormap::{self, ColorMap, ExposureMode, Tone};
use super::settings::ViewerSettings;
use tprf_core::film::{FilmSnapshot, SliceCursor, quantile_f32};

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

/// Per-frame exposure: the percentile of a slice's pixels (dark ones counted) taken as
/// white.
pub(super) const SLICE_PERCENTILE: f64 = 0.995;
/// Per-frame exposure never makes white darker than this share of the cube's white: a
/// slice with a few noisy pixels is not stretched until they glare.
pub(super) const SLICE_FLOOR: f64 = 0.01;

/// An image's tone and, in words, how its white point was chosen (shown on screen).
pub(super) struct Exposure {
    pub(super) tone: Tone,
    pub(super) note: String,
}

impl Exposure {
    /// The values the colour bar spans: `[0, white]`, or the `decades` below white on
    /// a log scale.
    pub(super) fn bar_scale(&self) -> BarScale {
        let white = 1.0 / self.tone.scale;
        if self.tone.log {
            BarScale::Log {
                lo: white * 10f64.powf(-self.tone.decades),
                hi: white,
            }
        } else {
            BarScale::Linear { lo: 0.0, hi: white }
        }
    }
}

/// " (EV +1.0)" when the EV offset is not zero.
fn ev_note(settings: &ViewerSettings) -> String {
    if settings.ev == 0.0 {
        String::new()
    } else {
        format!(", then EV {:+.1}", settings.ev)
    }
}

/// One exposure for the whole film: `scale = 2^ev / robust_max` (the 99.9 % quantile of
/// the cube's lit bins), so brightness compares across time. The video's exposure.
pub(super) fn global_tone(settings: &ViewerSettings, snap: &FilmSnapshot) -> Tone {
    Tone {
        scale: snap.robust_max().map_or(1.0, |b| 1.0 / b) * ev_gain(settings),
        log: settings.log_image,
        decades: 3.0,
    }
}

/// The exposure of a time slice with values `values`. Per frame: white is the slice's
/// [`SLICE_PERCENTILE`] percentile over all its pixels, dark ones counted (a robust
/// white: the brightest 0.5 % of pixels, noise included, saturate), but at least
/// [`SLICE_FLOOR`] of the cube's white. Global: [`global_tone`].
pub(super) fn slice_exposure(
    settings: &ViewerSettings,
    snap: &FilmSnapshot,
    values: &[f32],
    keys: &mut Vec<u32>,
) -> Exposure {
    let cube_white = snap.robust_max();
    match settings.exposure {
        ExposureMode::PerFrame => {
            let pct = quantile_f32(values, SLICE_PERCENTILE, keys).unwrap_or(0.0);
            let floor = cube_white.map_or(0.0, |w| w * SLICE_FLOOR);
            let (white, note) = if pct > 0.0 && pct >= floor {
                (
                    pct,
                    format!(
                        "per frame: white = {:.1}th percentile of this slice's pixels",
                        SLICE_PERCENTILE * 100.0
                    ),
                )
            } else if floor > 0.0 {
                (
                    floor,
                    format!(
                        "per frame: slice nearly dark, white = {:.0} % of the cube's",
                        SLICE_FLOOR * 100.0
                    ),
                )
            } else {
                (1.0, "per frame: empty slice".to_string())
            };
            Exposure {
                tone: Tone {
                    scale: ev_gain(settings) / white,
                    log: settings.log_image,
                    decades: 3.0,
                },
                note: note + &ev_note(settings),
            }
        }
        ExposureMode::Global => Exposure {
            tone: global_tone(settings, snap),
            note: "global: white = 99.9th percentile of the cube's lit bins".to_string()
                + &ev_note(settings),
        },
    }
}

/// The steady image's exposure: its 99th percentile of lit pixels at 80 % grey, so the
/// lamp and the lit walls both read.
pub(super) fn steady_exposure(settings: &ViewerSettings, snap: &FilmSnapshot) -> Exposure {
    let base =
        colormap::quantile_positive(snap.steady().iter().copied(), 0.99).map_or(1.0, |b| 0.8 / b);
    Exposure {
        tone: Tone {
            scale: base * ev_gain(settings),
            log: settings.log_image,
            decades: 3.0,
        },
        note: "white = 99th percentile of lit pixels / 0.8".to_string() + &ev_note(settings),
    }
}

/// Buffers a frame's image is made in, kept between frames: playback makes a new time
/// slice every frame, and fresh megabytes a frame cost page faults.
#[derive(Default)]
pub(super) struct Scratch {
    values: Vec<f32>,
    keys: Vec<u32>,
    /// Where playback left each pixel's runs (a slice a frame walks only the runs it
    /// passes).
    cursor: SliceCursor,
}

/// RGBA8 pixels (`[H, W]`, row 0 = top) of `view` of `snap`, and the exposure they were
/// made with; `bin` is the time slice's.
pub(super) fn view_pixels(
    view: View,
    snap: &FilmSnapshot,
    bin: usize,
    settings: &ViewerSettings,
    scratch: &mut Scratch,
) -> (Vec<u8>, Exposure) {
    match view {
        View::Slice => {
            snap.slice_forward(bin, &mut scratch.cursor, &mut scratch.values);
            let e = slice_exposure(settings, snap, &scratch.values, &mut scratch.keys);
            (
                colormap::colorize(&scratch.values, &e.tone, settings.colormap),
                e,
            )
        }
        View::Steady => {
            let e = steady_exposure(settings, snap);
            (
                colormap::colorize(snap.steady(), &e.tone, ColorMap::Gray),
                e,
            )
        }
        View::Rainbow => {
            let base = colormap::quantile_positive(snap.steady().iter().copied(), 0.99)
                .map_or(1.0, |b| 1.0 / b);
            let e = Exposure {
                tone: Tone {
                    scale: base * ev_gain(settings),
                    log: false,
                    decades: 3.0,
                },
                note: "brightness: the pixel's energy, full at the 99th percentile of the \
                       steady image"
                    .to_string()
                    + &ev_note(settings),
            };
            let px = colormap::rainbow(snap.peak_bins(), snap.steady(), snap.axis().bins, &e.tone);
            (px, e)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tprf_core::film::{FilmLayout, TimeAxis};

    /// 400 pixels, 2 bins: bin 0 lit evenly (1.0 everywhere but one 50.0 pixel), bin 1
    /// dark but for one noisy pixel of 0.2.
    fn film() -> FilmSnapshot {
        let layout = FilmLayout {
            width: 20,
            height: 20,
            axis: TimeAxis::new(0.0, 1e-9, 2).unwrap(),
            bounces_separate: 0,
            luminescence: false,
        };
        let mut cube = vec![0.0f32; 800];
        for p in 0..400 {
            cube[2 * p] = 1.0;
        }
        cube[2 * 7] = 50.0;
        cube[2 * 42 + 1] = 0.2;
        FilmSnapshot::from_dense(layout, 1, 1, &cube, &[], None)
    }

    #[test]
    fn per_frame_white_is_a_robust_percentile() {
        let snap = film();
        let settings = ViewerSettings::default();
        // Bin 0: the one 50.0 pixel is above the 99.5th percentile; white = 1.0.
        let e = slice_exposure(&settings, &snap, &snap.slice(0), &mut Vec::new());
        assert!(
            (1.0 / e.tone.scale - 1.0).abs() < 1e-12,
            "{}",
            1.0 / e.tone.scale
        );
        assert!(e.note.contains("99.5th percentile"), "{}", e.note);
        assert_eq!(e.bar_scale(), BarScale::Linear { lo: 0.0, hi: 1.0 });
        // Bin 1: one lit pixel in 400 is below the percentile; white falls back to 1 %
        // of the cube's white (its 99.9th percentile of lit bins: the top one of 401,
        // 50.0), so the lone noisy pixel is not made white.
        let e = slice_exposure(&settings, &snap, &snap.slice(1), &mut Vec::new());
        assert_eq!(snap.robust_max(), Some(50.0));
        assert!((1.0 / e.tone.scale - 0.5).abs() < 1e-12);
        assert!((e.tone.map(0.2) - 0.4).abs() < 1e-9);
        assert!(e.note.contains("nearly dark"), "{}", e.note);
        // EV +1 halves white and says so; log spans three decades under it.
        let settings = ViewerSettings {
            ev: 1.0,
            log_image: true,
            ..ViewerSettings::default()
        };
        let e = slice_exposure(&settings, &snap, &snap.slice(0), &mut Vec::new());
        assert_eq!(
            e.bar_scale(),
            BarScale::Log {
                lo: 0.5e-3,
                hi: 0.5
            }
        );
        assert!(e.note.contains("EV +1.0"), "{}", e.note);
    }
}

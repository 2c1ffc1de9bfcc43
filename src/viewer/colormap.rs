//! Turning film values into pixels: exposure, log scale, colour maps. Pure functions,
//! tested without a window.

use serde::{Deserialize, Serialize};

/// How a time slice is exposed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ExposureMode {
    /// Each frame scaled by its own 99.5 % quantile: every instant readable.
    PerFrame,
    /// One scale for the whole cube (its 99.9 % quantile): brightness compares across time.
    Global,
}

/// Colour map of a scalar image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ColorMap {
    Inferno,
    Gray,
}

/// Display mapping of values to [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tone {
    /// Multiplies values before mapping (from the exposure mode and EV offset).
    pub scale: f64,
    /// Log mapping over `decades` decades below 1 instead of linear.
    pub log: bool,
    pub decades: f64,
}

impl Tone {
    /// Map a value to [0, 1].
    pub fn map(&self, v: f64) -> f64 {
        let x = v * self.scale;
        if x.is_nan() || x <= 0.0 || !x.is_finite() {
            return if x == f64::INFINITY { 1.0 } else { 0.0 };
        }
        if self.log {
            (1.0 + x.log10() / self.decades.max(0.1)).clamp(0.0, 1.0)
        } else {
            x.clamp(0.0, 1.0)
        }
    }
}

pub use tprf_core::film::quantile_positive;

/// sRGB-encode a linear value in [0, 1].
fn srgb(x: f64) -> u8 {
    tprf_core::export::srgb8(x)
}

/// The colour of `t` in `[0, 1]` under `map` (what a pixel of tone `t` and its place on
/// the colour bar show).
pub fn color_of(map: ColorMap, t: f64) -> [u8; 3] {
    match map {
        ColorMap::Gray => {
            let g = srgb(t);
            [g, g, g]
        }
        ColorMap::Inferno => {
            let c = colorous::INFERNO.eval_continuous(t.clamp(0.0, 1.0));
            [c.r, c.g, c.b]
        }
    }
}

/// The rainbow view's hue of `t` in `[0, 1]` (turbo), also used for depth images.
pub fn turbo(t: f64) -> [u8; 3] {
    let c = colorous::TURBO.eval_continuous(t.clamp(0.0, 1.0));
    [c.r, c.g, c.b]
}

/// The signed-error colour of `t` in `[0, 1]`: blue (0) - white (0.5) - red (1).
pub fn diverging(t: f64) -> [u8; 3] {
    let c = colorous::RED_BLUE.eval_continuous((1.0 - t).clamp(0.0, 1.0));
    [c.r, c.g, c.b]
}

/// RGBA8 pixels of a scalar image.
pub fn colorize(values: &[f32], tone: &Tone, map: ColorMap) -> Vec<u8> {
    let lut = lut(map);
    let last = (LUT_SIZE - 1) as f64;
    let mut out = vec![255u8; values.len() * 4];
    // The table's entry of tone `t` is `round(t last)`; NaN, zero and negatives are 0,
    // as `color_of` clamps them. The linear case, what playback shows every frame, is
    // one multiply and a compare a pixel.
    for (px, &v) in out.chunks_exact_mut(4).zip(values) {
        let t = if tone.log {
            tone.map(v as f64)
        } else {
            v as f64 * tone.scale
        };
        let i = if t > 0.0 {
            (t.min(1.0) * last + 0.5) as usize
        } else {
            0
        };
        px[..3].copy_from_slice(&lut[i]);
    }
    out
}

/// Entries of a colour map's table: adjacent entries differ by less than one 8-bit
/// level, so a looked-up colour is within one level of [`color_of`].
const LUT_SIZE: usize = 4096;

/// [`color_of`] of `map` at `i / (LUT_SIZE - 1)`, made once: `colorize` runs per pixel
/// per frame, and the gradient's spline (or the sRGB curve) per pixel was a tenth of the
/// UI thread's time at 512 x 512.
fn lut(map: ColorMap) -> &'static [[u8; 3]] {
    use std::sync::OnceLock;
    static GRAY: OnceLock<Vec<[u8; 3]>> = OnceLock::new();
    static INFERNO: OnceLock<Vec<[u8; 3]>> = OnceLock::new();
    let cell = match map {
        ColorMap::Gray => &GRAY,
        ColorMap::Inferno => &INFERNO,
    };
    cell.get_or_init(|| {
        (0..LUT_SIZE)
            .map(|i| color_of(map, i as f64 / (LUT_SIZE - 1) as f64))
            .collect()
    })
}

/// The "rainbow" view: hue = arrival time of the TPRF's peak (bin / bins, turbo colour
/// map), brightness = the pixel's energy through `tone`.
pub fn rainbow(peak_bins: &[Option<u32>], energy: &[f32], bins: usize, tone: &Tone) -> Vec<u8> {
    static TURBO: std::sync::OnceLock<Vec<[u8; 3]>> = std::sync::OnceLock::new();
    let table = TURBO.get_or_init(|| {
        (0..LUT_SIZE)
            .map(|i| turbo(i as f64 / (LUT_SIZE - 1) as f64))
            .collect()
    });
    let last = (LUT_SIZE - 1) as f64;
    let span = bins.saturating_sub(1).max(1) as f64;
    let mut out = vec![255u8; peak_bins.len() * 4];
    for ((px, &bin), &energy) in out.chunks_exact_mut(4).zip(peak_bins).zip(energy) {
        match bin {
            Some(b) => {
                let hue = (b as f64 / span).min(1.0);
                let rgb = table[(hue * last + 0.5) as usize];
                let k = tone.map(energy as f64).sqrt();
                for (o, c) in px.iter_mut().zip(rgb) {
                    *o = (c as f64 * k + 0.5).min(255.0) as u8;
                }
            }
            None => px[..3].fill(0),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colorize_is_within_one_level_of_the_exact_colour() {
        let tone = Tone {
            scale: 1.0,
            log: false,
            decades: 3.0,
        };
        let values: Vec<f32> = (0..=20_000)
            .map(|i| i as f32 / 20_000.0)
            .chain([f32::NAN, -1.0, 7.0])
            .collect();
        for map in [ColorMap::Gray, ColorMap::Inferno] {
            let got = colorize(&values, &tone, map);
            for (v, px) in values.iter().zip(got.chunks_exact(4)) {
                let want = color_of(map, tone.map(*v as f64));
                for c in 0..3 {
                    assert!(
                        (px[c] as i32 - want[c] as i32).abs() <= 1,
                        "{map:?} at {v}: {px:?} vs {want:?}"
                    );
                }
                assert_eq!(px[3], 255);
            }
        }
    }

    #[test]
    fn tone_maps_linear_and_log() {
        let lin = Tone {
            scale: 2.0,
            log: false,
            decades: 3.0,
        };
        assert_eq!(lin.map(0.25), 0.5);
        assert_eq!(lin.map(1.0), 1.0);
        assert_eq!(lin.map(-1.0), 0.0);
        assert_eq!(lin.map(f64::NAN), 0.0);
        let log = Tone {
            scale: 1.0,
            log: true,
            decades: 3.0,
        };
        assert!((log.map(1.0) - 1.0).abs() < 1e-12);
        assert!((log.map(1e-3) - 0.0).abs() < 1e-12);
        assert!((log.map(1e-1) - 2.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn rainbow_is_black_where_dark_and_hue_follows_time() {
        let tone = Tone {
            scale: 1.0,
            log: false,
            decades: 3.0,
        };
        let px = rainbow(&[None, Some(0), Some(9)], &[0.0, 1.0, 1.0], 10, &tone);
        assert_eq!(&px[0..4], &[0, 0, 0, 255]);
        assert_ne!(&px[4..8], &px[8..12]);
    }
}

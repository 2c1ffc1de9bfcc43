//! The shape of a film: pixels, time axis, per-bounce layers.

use super::TimeAxis;

/// The shape of a film.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmLayout {
    pub width: usize,
    pub height: usize,
    pub axis: TimeAxis,
    /// `0`: no per-bounce layers. `K > 0`: layers for 0 (emitter seen directly),
    /// 1, ..., K scattering events and one for "more than K" (`K + 2` layers in all).
    pub bounces_separate: u32,
}

impl FilmLayout {
    pub fn pixels(&self) -> usize {
        self.width * self.height
    }

    /// Number of per-bounce layers (0 when not asked for).
    pub fn bounce_layers(&self) -> usize {
        if self.bounces_separate == 0 {
            0
        } else {
            self.bounces_separate as usize + 2
        }
    }

    /// The layer a contribution with `scatterings` events lands in.
    #[inline]
    pub fn layer_of(&self, scatterings: u32) -> usize {
        scatterings.min(self.bounces_separate + 1) as usize
    }

    /// Bins of the whole cube, `H x W x T` (saturating).
    pub fn cells(&self) -> u64 {
        (self.pixels() as u64).saturating_mul(self.axis.bins as u64)
    }

    /// Bytes a dense store of this shape would need: every bin of every pixel in two
    /// f64 halves, plus one f64 per bounce layer. What the sparse film is measured
    /// against.
    pub fn dense_bytes(&self) -> u64 {
        self.cells()
            .saturating_mul(8 * (2 + self.bounce_layers() as u64))
    }
}

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
    /// With bounce layers, one more after them: the light re-emitted by a luminescent
    /// surface on its way (contributions marked [`RE_EMITTED`]); the bounce layers then
    /// hold the rest, so the layers still add up to the total. Ignored without bounce
    /// layers.
    pub luminescence: bool,
}

/// A flag on a contribution's count of scattering events (the `scatterings` of
/// [`super::PixelSink::add`]): the path was re-emitted by a luminescent surface, so its
/// light lands in the film's luminescence layer ([`FilmLayout::luminescence`]). The
/// count itself is `scatterings & !RE_EMITTED` ([`scattering_count`]).
pub const RE_EMITTED: u32 = 1 << 31;

/// The number of scattering events of a contribution marked with [`RE_EMITTED`] or not.
#[inline(always)]
pub const fn scattering_count(scatterings: u32) -> u32 {
    scatterings & !RE_EMITTED
}

impl FilmLayout {
    pub fn pixels(&self) -> usize {
        self.width * self.height
    }

    /// Number of per-bounce layers (0 when not asked for), the luminescence layer
    /// included.
    pub fn bounce_layers(&self) -> usize {
        if self.bounces_separate == 0 {
            0
        } else {
            self.bounces_separate as usize + 2 + usize::from(self.luminescence)
        }
    }

    /// The luminescence layer's index, when the film has one.
    pub fn luminescence_layer(&self) -> Option<usize> {
        (self.bounces_separate > 0 && self.luminescence)
            .then_some(self.bounces_separate as usize + 2)
    }

    /// The layer a contribution after `scatterings` events lands in (with
    /// [`RE_EMITTED`] set: the luminescence layer, when the film has one).
    #[inline]
    pub fn layer_of(&self, scatterings: u32) -> usize {
        if self.luminescence && scatterings & RE_EMITTED != 0 {
            return self.bounces_separate as usize + 2;
        }
        scattering_count(scatterings).min(self.bounces_separate + 1) as usize
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

    /// Bytes a film of this shape and its readers hold whatever light it stores: per
    /// pixel the run directory, steady sum, peak bin and sampling record
    /// ([`super::BYTES_PER_PIXEL`]) and 16 B per bounce layer; an adaptive pass's plan
    /// while it is made (8 B); a snapshot's steady image and peak bins (f32 and
    /// `Option<u32>`: 12 B); the exported steady image (f64 and 8-bit: 9 B); one dense
    /// f32 row (`W x T x 4` B) of a cube file being written. `None` on overflow.
    pub fn fixed_bytes(&self) -> Option<u64> {
        let per_pixel = super::BYTES_PER_PIXEL + 16 * self.bounce_layers() as u64 + 8 + 12 + 9;
        let row = (self.width as u64)
            .checked_mul(self.axis.bins as u64)?
            .checked_mul(4)?;
        (self.width as u64)
            .checked_mul(self.height as u64)?
            .checked_mul(per_pixel)?
            .checked_add(row)
    }
}

//! Where one pixel's samples of one pass go: a dense scratch of the pixel's bins (one
//! per bounce layer too), and the bins touched, merged into the sparse film after the
//! pixel's samples (see `row.rs`). Adding a contribution costs what a dense film costs.

use super::{FilmLayout, TimeAxis, TimeFilter};

/// Work the integrator leaves out, and why: none of it could change the film.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LeftOut {
    /// A shadow ray whose contribution would arrive after the window: not traced.
    ShadowRayLate,
    /// A shadow ray whose contribution would arrive before the window: not traced.
    ShadowRayEarly,
    /// A path whose optical length already reaches past the window: ended.
    PathPastWindow,
}

/// Work left out because its light could not arrive inside the window, counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct LeftOutCounts {
    /// Shadow rays not traced: their light would arrive after the window.
    pub shadow_rays_late: u64,
    /// Shadow rays not traced: their light would arrive before the window.
    pub shadow_rays_early: u64,
    /// Paths ended because their optical length already reached past the window.
    pub paths_past_window: u64,
    /// Contributions that were NaN or infinite, left out of the film: a render with any
    /// is an error (an emitter or a light overflows, or a material is broken).
    #[serde(default)]
    pub non_finite: u64,
}

impl std::ops::AddAssign for LeftOutCounts {
    fn add_assign(&mut self, o: LeftOutCounts) {
        self.shadow_rays_late += o.shadow_rays_late;
        self.shadow_rays_early += o.shadow_rays_early;
        self.paths_past_window += o.paths_past_window;
        self.non_finite += o.non_finite;
    }
}

/// The bins of a scratch array that received something: a bit per bin, and the words
/// of bits that have one set, in the order first set. Draining sorts only those words
/// (a few for a short axis, where sorting the bins cost 1 % of a render; on a long,
/// sparse axis about one word per bin, no more than sorting the bins).
#[derive(Clone, Debug, Default)]
pub(super) struct Touched {
    bits: Vec<u64>,
    words: Vec<u32>,
}

impl Touched {
    fn new(bins: usize) -> Touched {
        Touched {
            bits: vec![0; bins.div_ceil(64)],
            words: Vec::new(),
        }
    }

    /// Note that bin `b` received something.
    #[inline(always)]
    fn mark(&mut self, b: usize) {
        if let Some(word) = self.bits.get_mut(b / 64) {
            if *word == 0 {
                self.words.push((b / 64) as u32);
            }
            *word |= 1 << (b % 64);
        }
    }

    /// Take the bins `bins` accumulated: `(bin, sum)` in increasing bin order appended
    /// to `out`, leaving `bins` zeroed and nothing marked. Bins whose sum is 0 are left
    /// out.
    pub(super) fn drain(&mut self, bins: &mut [f64], out: &mut Vec<(u32, f64)>) {
        self.words.sort_unstable();
        for &w in &self.words {
            let Some(word) = self.bits.get_mut(w as usize) else {
                continue;
            };
            let mut set = std::mem::take(word);
            while set != 0 {
                let b = w * 64 + set.trailing_zeros();
                set &= set - 1;
                if let Some(slot) = bins.get_mut(b as usize) {
                    if *slot != 0.0 {
                        out.push((b, *slot));
                    }
                    *slot = 0.0;
                }
            }
        }
        self.words.clear();
    }
}

/// A pixel's bins during one pass: dense, reused from pixel to pixel.
pub(super) struct Scratch {
    /// `[T]` sums of this pass.
    pub bins: Vec<f64>,
    /// The bins received.
    pub touched: Touched,
    /// `[L][T]` per-bounce sums, empty without layers.
    pub layers: Vec<f64>,
    /// Per layer, the bins received.
    pub layer_touched: Vec<Touched>,
}

impl Scratch {
    pub fn new(layout: &FilmLayout) -> Scratch {
        let (t, l) = (layout.axis.bins, layout.bounce_layers());
        Scratch {
            bins: vec![0.0; t],
            touched: Touched::new(t),
            layers: vec![0.0; t * l],
            layer_touched: vec![Touched::new(t); l],
        }
    }
}

/// Where one pixel's samples of one pass go.
pub struct PixelSink<'a> {
    axis: TimeAxis,
    layout: FilmLayout,
    filter: TimeFilter,
    /// What each contribution is multiplied by: the pass's samples per pixel over the
    /// pixel's (1 in a uniform pass).
    weight: f64,
    scratch: &'a mut Scratch,
    /// Sum of contributions that arrived before or after the window (for diagnostics).
    pub outside: f64,
    /// Work the integrator left out.
    pub(super) left_out: LeftOutCounts,
}

impl<'a> PixelSink<'a> {
    pub(super) fn new(
        layout: FilmLayout,
        filter: TimeFilter,
        weight: f64,
        scratch: &'a mut Scratch,
    ) -> PixelSink<'a> {
        PixelSink {
            axis: layout.axis,
            layout,
            filter,
            weight,
            scratch,
            outside: 0.0,
            left_out: LeftOutCounts::default(),
        }
    }

    /// Add one contribution `value` (radiance of one sample, W / (m^2 sr) per unit pulse
    /// energy) arriving at `arrival_s` after `scatterings` scattering events, binned by
    /// the film's [`TimeFilter`] (box: the whole value in the bin holding `arrival_s`),
    /// times the pixel's weight in this pass.
    ///
    /// Inlined into the integrator; the tent filter's split is out of line.
    #[inline]
    pub fn add(&mut self, arrival_s: f64, value: f64, scatterings: u32) {
        if !(value.is_finite() && arrival_s.is_finite()) {
            self.left_out.non_finite += 1;
            return;
        }
        let value = value * self.weight;
        if self.filter == TimeFilter::Tent {
            self.add_tent(arrival_s, value, scatterings);
            return;
        }
        match self.axis.bin_of(arrival_s) {
            Some(b) => self.put(b, value, scatterings),
            None => self.outside += value,
        }
    }

    /// [`Self::add`]'s weighted `value` shared between the two bins nearest `arrival_s`
    /// (the tent filter).
    #[inline(never)]
    fn add_tent(&mut self, arrival_s: f64, value: f64, scatterings: u32) {
        match self.axis.tent_split(arrival_s) {
            Some(split) => {
                for (b, w) in split {
                    if w > 0.0 {
                        self.put(b, w * value, scatterings);
                    }
                }
            }
            None => self.outside += value,
        }
    }

    #[inline]
    fn put(&mut self, b: usize, value: f64, scatterings: u32) {
        let s = &mut *self.scratch;
        if let Some(slot) = s.bins.get_mut(b) {
            s.touched.mark(b);
            *slot += value;
        }
        if !s.layers.is_empty() {
            let l = self.layout.layer_of(scatterings);
            if let (Some(slot), Some(touched)) = (
                s.layers.get_mut(l * self.axis.bins + b),
                s.layer_touched.get_mut(l),
            ) {
                touched.mark(b);
                *slot += value;
            }
        }
    }

    /// The time axis contributions are binned on.
    #[inline]
    pub fn axis(&self) -> TimeAxis {
        self.axis
    }

    /// End of the time window, seconds: a path already later than this cannot contribute.
    #[inline]
    pub fn window_end_s(&self) -> f64 {
        self.axis.end_s()
    }

    /// Start of the time window, seconds.
    #[inline]
    pub fn window_start_s(&self) -> f64 {
        self.axis.t0_s
    }

    /// Count work the integrator left out.
    #[inline]
    pub fn left_out(&mut self, why: LeftOut) {
        let c = &mut self.left_out;
        match why {
            LeftOut::ShadowRayLate => c.shadow_rays_late += 1,
            LeftOut::ShadowRayEarly => c.shadow_rays_early += 1,
            LeftOut::PathPastWindow => c.paths_past_window += 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn touched_bins_drain_in_order_once_each() {
        // Bins across word boundaries, in no order, some more than once, one summing to
        // zero; checked against a map summed independently.
        let bins = 300;
        let adds: [(usize, f64); 10] = [
            (299, 1.0),
            (64, 2.0),
            (0, 0.5),
            (63, 4.0),
            (64, 3.0),
            (130, 1.5),
            (130, -1.5),
            (1, 0.25),
            (299, 1.0),
            (200, 8.0),
        ];
        let mut scratch = vec![0.0; bins];
        let mut touched = Touched::new(bins);
        let mut expect = BTreeMap::new();
        for round in 0..2 {
            for &(b, v) in &adds {
                touched.mark(b);
                scratch[b] += v;
                *expect.entry(b as u32).or_insert(0.0) += v;
            }
            let mut out = vec![(7, 7.0)];
            touched.drain(&mut scratch, &mut out);
            let want: Vec<(u32, f64)> = std::iter::once((7, 7.0))
                .chain(expect.iter().map(|(&b, &v)| (b, v)).filter(|e| e.1 != 0.0))
                .collect();
            assert_eq!(out, want, "round {round}");
            assert!(scratch.iter().all(|&v| v == 0.0));
            expect.clear();
        }
    }
}

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

/// A pixel's bins during one pass: dense, reused from pixel to pixel.
pub(super) struct Scratch {
    /// `[T]` sums of this pass.
    pub bins: Vec<f64>,
    /// Bins made non-zero, in the order first touched.
    pub touched: Vec<u32>,
    /// `[L][T]` per-bounce sums, empty without layers.
    pub layers: Vec<f64>,
    /// Per layer, the bins touched.
    pub layer_touched: Vec<Vec<u32>>,
}

impl Scratch {
    pub fn new(layout: &FilmLayout) -> Scratch {
        let (t, l) = (layout.axis.bins, layout.bounce_layers());
        Scratch {
            bins: vec![0.0; t],
            touched: Vec::new(),
            layers: vec![0.0; t * l],
            layer_touched: vec![Vec::new(); l],
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
            if *slot == 0.0 {
                s.touched.push(b as u32);
            }
            *slot += value;
        }
        if !s.layers.is_empty() {
            let l = self.layout.layer_of(scatterings);
            if let (Some(slot), Some(touched)) = (
                s.layers.get_mut(l * self.axis.bins + b),
                s.layer_touched.get_mut(l),
            ) {
                if *slot == 0.0 {
                    touched.push(b as u32);
                }
                *slot += value;
            }
        }
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

/// Take the bins a scratch array accumulated: `(bin, sum)` in increasing bin order,
/// leaving the array zeroed and the touched list empty. Bins whose sum is 0 are left out.
pub(super) fn drain_touched(bins: &mut [f64], touched: &mut Vec<u32>, out: &mut Vec<(u32, f64)>) {
    out.clear();
    touched.sort_unstable();
    touched.dedup();
    for &b in touched.iter() {
        if let Some(slot) = bins.get_mut(b as usize) {
            if *slot != 0.0 {
                out.push((b, *slot));
            }
            *slot = 0.0;
        }
    }
    touched.clear();
}

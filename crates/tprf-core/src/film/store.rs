//! The TPRF store: per pixel, per time bin, the sum of sample contributions, in f64.
//!
//! Samples of even passes and of odd passes go to two independent halves, so the error
//! of the mean can be estimated without a reference (their difference). The cube a user
//! sees is `(half0 + half1) / samples`: a bin then holds the integral over the bin of the
//! pixel's radiance (W / (m^2 sr) times seconds per unit pulse energy... i.e. summed over
//! bins it is the steady-state radiance for a unit pulse; DESIGN.md).

use super::{FilmError, FilmSnapshot, TimeAxis, TimeFilter};
use rayon::prelude::*;

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
    /// `width x height` (saturating at `usize::MAX`, which no allocation can meet).
    pub fn pixels(&self) -> usize {
        self.width.saturating_mul(self.height)
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

    /// Bytes the store needs (two f64 halves plus the bounce layers); saturates at
    /// `usize::MAX` rather than overflowing.
    pub fn bytes(&self) -> usize {
        let t = self.axis.bins;
        self.pixels()
            .saturating_mul(t)
            .saturating_mul(8 * (2 + self.bounce_layers()))
    }
}

/// Where one pixel's samples of one pass go: its bins in one half, and its bounce layers.
pub struct PixelSink<'a> {
    axis: TimeAxis,
    layout: FilmLayout,
    bins: &'a mut [f64],
    bounce_bins: &'a mut [f64],
    filter: TimeFilter,
    /// Sum of contributions that arrived before or after the window (for diagnostics).
    pub outside: f64,
}

impl PixelSink<'_> {
    /// Add one contribution `value` (radiance of one sample, W / (m^2 sr) per unit pulse
    /// energy) arriving at `arrival_s` after `scatterings` scattering events, binned by
    /// the film's [`TimeFilter`] (box: the whole value in the bin holding `arrival_s`).
    #[inline]
    pub fn add(&mut self, arrival_s: f64, value: f64, scatterings: u32) {
        if self.filter == TimeFilter::Tent {
            match self.axis.tent_split(arrival_s) {
                Some(split) => {
                    let l = self.layout.layer_of(scatterings) * self.axis.bins;
                    for (b, w) in split {
                        if w > 0.0 {
                            self.bins[b] += w * value;
                            if !self.bounce_bins.is_empty() {
                                self.bounce_bins[l + b] += w * value;
                            }
                        }
                    }
                }
                None => self.outside += value,
            }
            return;
        }
        match self.axis.bin_of(arrival_s) {
            Some(b) => {
                self.bins[b] += value;
                if !self.bounce_bins.is_empty() {
                    let l = self.layout.layer_of(scatterings);
                    self.bounce_bins[l * self.axis.bins + b] += value;
                }
            }
            None => self.outside += value,
        }
    }

    /// End of the time window, seconds: a path already later than this cannot contribute.
    #[inline]
    pub fn window_end_s(&self) -> f64 {
        self.axis.end_s()
    }
}

/// The TPRF cache: accumulated sample sums and counts.
#[derive(Clone, Debug)]
pub struct TprfFilm {
    layout: FilmLayout,
    /// `[half][row][col][bin]`.
    halves: [Vec<f64>; 2],
    /// `[row][col][layer][bin]`, empty without per-bounce layers.
    bounces: Vec<f64>,
    /// Samples per pixel in each half.
    spp: [u64; 2],
    passes: u64,
    filter: TimeFilter,
}

impl TprfFilm {
    /// A zeroed film. Fails (rather than aborting) when the allocation is impossible.
    pub fn new(layout: FilmLayout) -> Result<TprfFilm, FilmError> {
        let (width, height, bins) = (layout.width, layout.height, layout.axis.bins);
        let n = layout
            .pixels()
            .checked_mul(bins)
            .ok_or(FilmError::SizeOverflow {
                width,
                height,
                bins,
            })?;
        let need_bytes = layout.bytes() as u64;
        // Refuse what would only fit by swapping (or be killed): an allocation larger than
        // the free memory succeeds on Linux and fails page by page later.
        if let Some(free_bytes) = available_memory_bytes()
            && need_bytes > free_bytes / 10 * 9
        {
            return Err(FilmError::NotEnoughMemory {
                width,
                height,
                bins,
                need_bytes,
                free_bytes,
            });
        }
        let alloc = |len: usize| -> Result<Vec<f64>, FilmError> {
            let mut v = Vec::new();
            v.try_reserve_exact(len)
                .map_err(|_| FilmError::Allocation {
                    width,
                    height,
                    bins,
                    need_bytes,
                })?;
            v.resize(len, 0.0);
            Ok(v)
        };
        Ok(TprfFilm {
            layout,
            halves: [alloc(n)?, alloc(n)?],
            bounces: alloc(n * layout.bounce_layers())?,
            spp: [0, 0],
            passes: 0,
            filter: TimeFilter::Box,
        })
    }

    /// The film with time filter `filter` (default [`TimeFilter::Box`]); set it before
    /// the first pass.
    pub fn with_time_filter(mut self, filter: TimeFilter) -> TprfFilm {
        self.filter = filter;
        self
    }

    pub fn time_filter(&self) -> TimeFilter {
        self.filter
    }

    pub fn layout(&self) -> &FilmLayout {
        &self.layout
    }

    pub fn axis(&self) -> &TimeAxis {
        &self.layout.axis
    }

    /// Samples per pixel so far.
    pub fn spp(&self) -> u64 {
        self.spp[0] + self.spp[1]
    }

    /// Samples per pixel in each half.
    pub fn half_spp(&self) -> [u64; 2] {
        self.spp
    }

    pub fn passes(&self) -> u64 {
        self.passes
    }

    /// Run one pass: `render_row(y, sinks)` gets one sink per pixel of row `y`. Rows run in
    /// parallel on the current rayon pool; each pixel is written by one task in a fixed
    /// order, so the result does not depend on the thread count. `spp_in_pass` is how
    /// many samples each pixel received. Returns the sum of what arrived outside the window.
    pub fn run_pass<F>(&mut self, spp_in_pass: u64, render_row: F) -> f64
    where
        F: Fn(usize, &mut [PixelSink<'_>]) + Sync,
    {
        let layout = self.layout;
        let t = layout.axis.bins;
        let w = layout.width;
        let layers = layout.bounce_layers();
        let half = (self.passes % 2) as usize;
        let filter = self.filter;
        let rows = self.halves[half].par_chunks_mut(w * t);
        let outside: f64 = if layers == 0 {
            rows.enumerate()
                .map(|(y, row)| {
                    let mut sinks: Vec<PixelSink<'_>> = row
                        .chunks_mut(t)
                        .map(|bins| PixelSink {
                            axis: layout.axis,
                            layout,
                            bins,
                            bounce_bins: &mut [],
                            filter,
                            outside: 0.0,
                        })
                        .collect();
                    render_row(y, &mut sinks);
                    sinks.iter().map(|s| s.outside).sum::<f64>()
                })
                .collect::<Vec<f64>>()
                .iter()
                .sum()
        } else {
            rows.zip(self.bounces.par_chunks_mut(w * layers * t))
                .enumerate()
                .map(|(y, (row, brow))| {
                    let mut sinks: Vec<PixelSink<'_>> = row
                        .chunks_mut(t)
                        .zip(brow.chunks_mut(layers * t))
                        .map(|(bins, bounce_bins)| PixelSink {
                            axis: layout.axis,
                            layout,
                            bins,
                            bounce_bins,
                            filter,
                            outside: 0.0,
                        })
                        .collect();
                    render_row(y, &mut sinks);
                    sinks.iter().map(|s| s.outside).sum::<f64>()
                })
                .collect::<Vec<f64>>()
                .iter()
                .sum()
        };
        self.spp[half] += spp_in_pass;
        self.passes += 1;
        outside / (layout.pixels() as f64).max(1.0)
    }

    fn index(&self, x: usize, y: usize) -> usize {
        (y * self.layout.width + x) * self.layout.axis.bins
    }

    /// The TPRF of pixel `(x, y)` (row 0 = top): bin integrals of radiance, mean over samples.
    pub fn pixel_tprf(&self, x: usize, y: usize) -> Vec<f64> {
        let n = self.spp().max(1) as f64;
        let i = self.index(x, y);
        let t = self.layout.axis.bins;
        (0..t)
            .map(|b| (self.halves[0][i + b] + self.halves[1][i + b]) / n)
            .collect()
    }

    /// The per-bounce TPRFs of pixel `(x, y)`: `layers x bins`, empty without layers.
    pub fn pixel_bounces(&self, x: usize, y: usize) -> Vec<Vec<f64>> {
        let layers = self.layout.bounce_layers();
        let t = self.layout.axis.bins;
        let n = self.spp().max(1) as f64;
        let base = (y * self.layout.width + x) * layers * t;
        (0..layers)
            .map(|l| (0..t).map(|b| self.bounces[base + l * t + b] / n).collect())
            .collect()
    }

    /// The whole cube `[H, W, T]` in f64 (row 0 = top): means over all samples.
    pub fn cube_f64(&self) -> Vec<f64> {
        let n = self.spp().max(1) as f64;
        self.halves[0]
            .par_iter()
            .zip(self.halves[1].par_iter())
            .map(|(a, b)| (a + b) / n)
            .collect()
    }

    /// The whole cube `[H, W, T]` as f32 (row 0 = top).
    pub fn cube_f32(&self) -> Vec<f32> {
        let n = self.spp().max(1) as f64;
        self.halves[0]
            .par_iter()
            .zip(self.halves[1].par_iter())
            .map(|(a, b)| ((a + b) / n) as f32)
            .collect()
    }

    /// The per-bounce cube `[L, H, W, T]` as f32, empty without layers.
    pub fn bounce_cube_f32(&self) -> Vec<f32> {
        let layers = self.layout.bounce_layers();
        let t = self.layout.axis.bins;
        let pixels = self.layout.pixels();
        let n = self.spp().max(1) as f64;
        let mut out = Vec::with_capacity(self.bounces.len());
        for l in 0..layers {
            for p in 0..pixels {
                let base = (p * layers + l) * t;
                out.extend(self.bounces[base..base + t].iter().map(|v| (v / n) as f32));
            }
        }
        out
    }

    /// A copy of the current means for readers on other threads.
    pub fn snapshot(&self) -> FilmSnapshot {
        FilmSnapshot::new(
            self.layout,
            self.spp(),
            self.passes,
            self.cube_f32(),
            self.bounce_cube_f32(),
            self.half_error_estimate(),
        )
    }

    /// Steady-state image `[H, W]`: per pixel the sum over bins (in f64).
    pub fn steady(&self) -> Vec<f64> {
        let n = self.spp().max(1) as f64;
        let t = self.layout.axis.bins;
        self.halves[0]
            .par_chunks(t)
            .zip(self.halves[1].par_chunks(t))
            .map(|(a, b)| (a.iter().sum::<f64>() + b.iter().sum::<f64>()) / n)
            .collect()
    }

    /// Time slice `[H, W]` for bin `b`.
    pub fn slice(&self, b: usize) -> Vec<f64> {
        let n = self.spp().max(1) as f64;
        let t = self.layout.axis.bins;
        (0..self.layout.pixels())
            .map(|p| (self.halves[0][p * t + b] + self.halves[1][p * t + b]) / n)
            .collect()
    }

    /// Relative RMS error of the cube estimated from the two independent halves, no
    /// reference needed: with means `a`, `b` of `n_a`, `n_b` samples, the error of the
    /// combined mean is estimated by `|a - b| * sqrt(n_a n_b) / (n_a + n_b)` per bin,
    /// relative to the L2 norm of the combined mean. `None` until both halves have samples.
    pub fn half_error_estimate(&self) -> Option<f64> {
        let [na, nb] = self.spp;
        if na == 0 || nb == 0 {
            return None;
        }
        let (na, nb) = (na as f64, nb as f64);
        let n = na + nb;
        let (diff2, norm2) = self.halves[0]
            .par_iter()
            .zip(self.halves[1].par_iter())
            .map(|(a, b)| {
                let d = a / na - b / nb;
                let m = (a + b) / n;
                (d * d, m * m)
            })
            .reduce(|| (0.0, 0.0), |x, y| (x.0 + y.0, x.1 + y.1));
        if norm2 == 0.0 {
            return Some(0.0);
        }
        Some((diff2.sqrt() * (na * nb).sqrt() / n) / norm2.sqrt())
    }
}

/// Memory the system can give without swapping (`MemAvailable`), where it says (Linux).
pub fn available_memory_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

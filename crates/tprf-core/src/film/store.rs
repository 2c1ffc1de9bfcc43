//! The TPRF store: per pixel, per time bin, the sum of sample contributions, in f64,
//! kept only for the bins that received light (sparse runs per pixel, `sparse.rs`).
//!
//! Samples of even passes and of odd passes go to two independent halves, so the error
//! of the mean can be estimated without a reference (their difference). The cube a user
//! sees is `(half0 + half1) / samples`: a bin then holds the integral over the bin of the
//! pixel's radiance (W m^-2 sr^-1 s per unit pulse energy): summed over bins it is the
//! steady-state radiance for a unit pulse (DESIGN.md).
//!
//! The film is a list of rows (`row.rs`) behind `Arc`s; a pass builds new rows, or adds
//! to a row in place where the film holds its only reference, and a [`FilmSnapshot`]
//! shares them (a shared row is never changed), so publishing a snapshot copies nothing.

use super::row::{FilmRow, PixelPass, PixelSamples, RowWork, render_row};
use super::{FilmError, FilmLayout, FilmSnapshot, LeftOutCounts, PixelSink, TimeAxis, TimeFilter};
use rayon::prelude::*;
use std::sync::Arc;

/// What one pass delivered outside the film, summed over its pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassTally {
    /// Mean per pixel of the contributions that arrived outside the window.
    pub outside_per_pixel: f64,
    pub left_out: LeftOutCounts,
    /// The work the pixels reported, summed (rays, for the renderer).
    pub work: u64,
}

impl PassTally {
    /// The pass's tally from its rows' (in row order: the same totals for any thread
    /// count) over the `pixels` it rendered.
    pub(super) fn of_rows(rows: Vec<super::row::RowTally>, pixels: usize) -> PassTally {
        let mut tally = PassTally::default();
        for t in rows {
            tally.outside_per_pixel += t.outside;
            tally.left_out += t.left_out;
            tally.work += t.work;
        }
        tally.outside_per_pixel /= (pixels as f64).max(1.0);
        tally
    }
}

/// How much of the dense cube the film stores.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StoreStats {
    /// Bins stored (non-zero bins of the halves).
    pub stored_bins: u64,
    /// Bins of the dense cube, `H x W x T`.
    pub dense_bins: u64,
    /// Runs of consecutive stored bins.
    pub runs: u64,
    /// Heap bytes the store holds.
    pub bytes: u64,
    /// Bytes a dense store of the same shape would hold.
    pub dense_bytes: u64,
}

/// Bytes per pixel the film holds whatever it stores: the run directory, steady sum,
/// peak bin and sampling record (see `FilmRow`).
pub const BYTES_PER_PIXEL: u64 = 16 + 8 + 4 + std::mem::size_of::<PixelSamples>() as u64;

/// The TPRF cache: accumulated sample sums and counts.
#[derive(Clone, Debug)]
pub struct TprfFilm {
    layout: FilmLayout,
    pub(super) rows: Vec<Arc<FilmRow>>,
    /// Samples per pixel in each half.
    pub(super) spp: [u64; 2],
    pub(super) passes: u64,
    filter: TimeFilter,
    /// The rows a pass renders (`None`: all). A shard of a render renders its bands of
    /// rows only; the others stay empty.
    pub(super) rows_rendered: Option<Arc<[bool]>>,
    /// See [`FilmSnapshot::film`].
    id: u64,
}

impl TprfFilm {
    /// An empty film. Fails (rather than aborting) when what it holds whatever light it
    /// stores ([`FilmLayout::fixed_bytes`]) does not fit in the memory left
    /// ([`crate::budget`]).
    pub fn new(layout: FilmLayout) -> Result<TprfFilm, FilmError> {
        let (width, height, bins) = (layout.width, layout.height, layout.axis.bins);
        let need_bytes = layout.fixed_bytes().ok_or(FilmError::SizeOverflow {
            width,
            height,
            bins,
        })?;
        if let Some(a) = crate::budget::available()
            && need_bytes > a.bytes
        {
            return Err(FilmError::NotEnoughMemory {
                width,
                height,
                bins,
                need_bytes,
                available_bytes: a.bytes,
                limited_by: a.limited_by,
            });
        }
        let empty = Arc::new(FilmRow::empty(layout.width, layout.bounce_layers()));
        Ok(TprfFilm {
            layout,
            rows: vec![empty; layout.height],
            spp: [0, 0],
            passes: 0,
            filter: TimeFilter::Box,
            rows_rendered: None,
            id: super::snapshot::next_id(),
        })
    }

    /// The film with time filter `filter` (default [`TimeFilter::Box`]); set it before
    /// the first pass.
    pub fn with_time_filter(mut self, filter: TimeFilter) -> TprfFilm {
        self.filter = filter;
        self
    }

    /// The film rendering only the rows `y` with `rows[y]` true (one flag per row; a
    /// missing flag is false); set it before the first pass. Every other row stays
    /// empty and costs nothing. A rendered row holds exactly what it holds in a film
    /// that renders every row: a pixel's samples depend only on the seed, the half, the
    /// pixel and the sample index, and each row is built from its own old row alone.
    pub fn with_rows(mut self, rows: &[bool]) -> TprfFilm {
        let h = self.layout.height;
        self.rows_rendered = Some(
            (0..h)
                .map(|y| rows.get(y).copied().unwrap_or(false))
                .collect(),
        );
        self
    }

    /// Whether a pass renders row `y`.
    pub fn renders_row(&self, y: usize) -> bool {
        self.rows_rendered
            .as_ref()
            .is_none_or(|r| r.get(y).copied().unwrap_or(false))
    }

    /// Rows a pass renders.
    pub fn rows_rendered(&self) -> usize {
        (0..self.layout.height)
            .filter(|&y| self.renders_row(y))
            .count()
    }

    /// Per row, the two sums of the two-half error estimate as the row was last built:
    /// `(sum (a / n_a - b / n_b)^2, sum ((a + b) / n)^2)` over its bins (see
    /// [`TprfFilm::half_error_estimate`] and [`half_error_from_terms`]).
    pub fn row_error_terms(&self) -> Vec<(f64, f64)> {
        self.rows.iter().map(|r| r.err_terms).collect()
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

    /// Samples per pixel so far: the sum of the passes' sizes (each pixel's mean is of
    /// this many, a pixel's own count may differ under an adaptive plan: see
    /// [`TprfFilm::run_pass_planned`]).
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

    /// Run one pass: `render_pixel(x, y, sink)` for every pixel, each pixel's samples
    /// into its sink. Rows run in parallel on the current rayon pool, the pixels of a
    /// row in order, so the result does not depend on the thread count. `spp_in_pass`
    /// is how many samples each pixel received. Returns what arrived outside the window
    /// and the work left out.
    pub fn run_pass<F>(&mut self, spp_in_pass: u64, render_pixel: F) -> PassTally
    where
        F: Fn(usize, usize, &mut PixelSink<'_>) + Sync,
    {
        let spp = spp_in_pass.min(u32::MAX as u64) as u32;
        self.run_pass_planned(spp, None, |x, y, _, sink| {
            render_pixel(x, y, sink);
            0
        })
    }

    /// Run one pass of `spp_in_pass` samples per pixel on average, pixel `i` (row-major)
    /// drawing `plan[i]` of them (at least 1; `None`, or a plan whose length is not the
    /// film's pixel count: `spp_in_pass` each):
    /// `render_pixel(x, y, pass, sink)` draws `pass.samples` samples from index
    /// `pass.first` of the pixel's stream of this pass's half into `sink`, and returns
    /// their work (rays), which the film keeps per sample ([`PixelSamples::cost`]).
    ///
    /// Each contribution of the pass is weighted `spp_in_pass / samples`, so the pass
    /// adds to every pixel `spp_in_pass` times the mean of its samples: the film's
    /// means stay `sum / spp` and every pass's term is unbiased whatever `plan` was,
    /// provided the plan is fixed before the pass's samples are drawn (it may follow
    /// earlier passes, as an adaptive plan does: their noise decides how many samples
    /// a pixel draws, never how its samples are weighted within the pass's sum).
    pub fn run_pass_planned<F>(
        &mut self,
        spp_in_pass: u32,
        plan: Option<&[u32]>,
        render_pixel: F,
    ) -> PassTally
    where
        F: Fn(usize, usize, PixelPass, &mut PixelSink<'_>) -> u64 + Sync,
    {
        let layout = self.layout;
        let half = (self.passes % 2) as usize;
        let filter = self.filter;
        let mut spp_after = self.spp;
        spp_after[half] += spp_in_pass as u64;
        let w = layout.width;
        let plan = plan.filter(|p| p.len() == layout.pixels());
        let rows_rendered = self.rows_rendered.clone();
        // Rows in leaves of at most a 64th of a thread's share. A pass ends when its last
        // leaf does, the other threads waiting about half a leaf: 1.5 % of the engine
        // bench's render at a 16th of a share (8 rows), 0.4 % at a 64th (2 rows). Small
        // leaves also keep a pass whose plan piles samples into a few rows from leaving
        // threads idle while one finishes a long stretch of them. But each leaf zeroes a
        // scratch of the axis's length (32 MB at 4 M bins): on a long axis, leaves of
        // at least one scratch bin per 64 pixels, up to a 16th of a share.
        let leaf_rows = leaf_rows(&layout);
        let tallies: Vec<super::row::RowTally> = self
            .rows
            .par_iter_mut()
            .with_max_len(leaf_rows)
            .enumerate()
            .map_init(
                || RowWork::new(&layout),
                |work, (y, row)| {
                    if rows_rendered
                        .as_ref()
                        .is_some_and(|r| !r.get(y).copied().unwrap_or(false))
                    {
                        return super::row::RowTally::default();
                    }
                    render_row(
                        row,
                        y,
                        &layout,
                        filter,
                        half,
                        spp_in_pass,
                        plan.and_then(|p| p.get(y * w..(y + 1) * w)),
                        spp_after,
                        work,
                        &render_pixel,
                    )
                },
            )
            .collect();
        let tally = PassTally::of_rows(tallies, layout.width * self.rows_rendered());
        self.spp = spp_after;
        self.passes += 1;
        tally
    }

    /// A row of the film (`None` past its height).
    fn row(&self, y: usize) -> Option<&FilmRow> {
        self.rows.get(y).map(|r| &**r)
    }

    /// Every pixel's sampling so far, row-major (what an adaptive plan reads).
    pub fn pixel_samples(&self) -> impl Iterator<Item = PixelSamples> + '_ {
        let w = self.layout.width;
        self.rows
            .iter()
            .flat_map(move |r| (0..w).map(move |x| r.pixel_samples(x)))
    }

    /// Whether a pass renders every row (not a shard's bands).
    pub fn renders_all_rows(&self) -> bool {
        self.rows_rendered.is_none()
    }

    /// What a sum is divided by to give a mean.
    fn norm(&self) -> f64 {
        self.spp().max(1) as f64
    }

    /// The TPRF of pixel `(x, y)` (row 0 = top): bin integrals of radiance, mean over
    /// samples, all `T` bins (zeros where nothing arrived); empty outside the image.
    pub fn pixel_tprf(&self, x: usize, y: usize) -> Vec<f64> {
        let Some(row) = self.row(y).filter(|_| x < self.layout.width) else {
            return Vec::new();
        };
        let n = self.norm();
        let mut out = vec![0.0; self.layout.axis.bins];
        for (start, values) in row.halves.pixel_runs(x) {
            for (o, [a, b]) in out.iter_mut().skip(start).zip(values) {
                *o = (a + b) / n;
            }
        }
        out
    }

    /// The per-bounce TPRFs of pixel `(x, y)`: `layers x bins`, empty without layers.
    pub fn pixel_bounces(&self, x: usize, y: usize) -> Vec<Vec<f64>> {
        let Some(row) = self.row(y).filter(|_| x < self.layout.width) else {
            return Vec::new();
        };
        let n = self.norm();
        row.layers
            .iter()
            .map(|layer| {
                let mut out = vec![0.0; self.layout.axis.bins];
                for (start, values) in layer.pixel_runs(x) {
                    for (o, v) in out.iter_mut().skip(start).zip(values) {
                        *o = v / n;
                    }
                }
                out
            })
            .collect()
    }

    /// The whole cube `[H, W, T]` in f64 (row 0 = top): means over all samples. Dense:
    /// for small films (tests, reports); readers of large films go through
    /// [`TprfFilm::snapshot`].
    pub fn cube_f64(&self) -> Vec<f64> {
        let (w, h) = (self.layout.width, self.layout.height);
        let mut out = Vec::with_capacity(self.layout.cells() as usize);
        for y in 0..h {
            for x in 0..w {
                out.extend(self.pixel_tprf(x, y));
            }
        }
        out
    }

    /// A reader's view of the current means, for other threads: it shares the film's
    /// rows (nothing is copied) and keeps them while the film moves on.
    pub fn snapshot(&self) -> FilmSnapshot {
        FilmSnapshot::from_rows(
            self.layout,
            self.spp(),
            self.passes,
            self.rows.clone(),
            self.half_error_estimate(),
            self.id,
        )
    }

    /// Steady-state image `[H, W]`: per pixel the sum over bins (in f64).
    pub fn steady(&self) -> Vec<f64> {
        let n = self.norm();
        self.rows
            .iter()
            .flat_map(|r| r.steady_sum.iter().map(move |s| s / n))
            .collect()
    }

    /// Time slice `[H, W]` for bin `b`.
    pub fn slice(&self, b: usize) -> Vec<f64> {
        let n = self.norm();
        let w = self.layout.width;
        self.rows
            .iter()
            .flat_map(|r| (0..w).map(move |x| r.halves.get(x, b).map_or(0.0, |[a, c]| (a + c) / n)))
            .collect()
    }

    /// How much the store holds against a dense cube (of the rows it renders: a shard's
    /// rows' stores add up to the whole film's, but for the list of rows itself, counted
    /// once per shard).
    pub fn store_stats(&self) -> StoreStats {
        let mut s = StoreStats {
            dense_bins: self.layout.cells(),
            dense_bytes: self.layout.dense_bytes(),
            ..StoreStats::default()
        };
        for (y, r) in self.rows.iter().enumerate() {
            if !self.renders_row(y) {
                continue;
            }
            s.stored_bins += r.stored_bins() as u64;
            s.runs += r.runs() as u64;
            s.bytes += r.heap_bytes() as u64;
        }
        s.bytes += self.row_list_bytes();
        s
    }

    /// Heap bytes the film's rows hold in memory now: a row shared by several places
    /// (a new film's rows are one empty row; a snapshot's rows are the film's until a
    /// pass rebuilds them) counted once, the list of rows included. [`TprfFilm::store_stats`]
    /// counts every row as its own (what the rows will hold once a pass has rebuilt
    /// each); this is what the process has allocated for them.
    pub fn held_bytes(&self) -> u64 {
        let mut seen = std::collections::HashSet::with_capacity(self.rows.len());
        self.row_list_bytes()
            + self
                .rows
                .iter()
                .filter(|r| seen.insert(Arc::as_ptr(r)))
                .map(|r| r.heap_bytes() as u64)
                .sum::<u64>()
    }

    /// Heap bytes of the film's list of rows (in [`TprfFilm::store_stats`]'s `bytes`).
    pub fn row_list_bytes(&self) -> u64 {
        (self.rows.capacity() * std::mem::size_of::<Arc<FilmRow>>()) as u64
    }

    /// Relative RMS error of the cube estimated from the two independent halves, no
    /// reference needed: with means `a`, `b` of `n_a`, `n_b` samples, the error of the
    /// combined mean is estimated by `|a - b| * sqrt(n_a n_b) / (n_a + n_b)` per bin,
    /// relative to the L2 norm of the combined mean. `None` until both halves have samples.
    pub fn half_error_estimate(&self) -> Option<f64> {
        half_error_from_terms(self.spp, self.rows.iter().map(|r| r.err_terms))
    }
}

/// Rows per leaf of a pass's parallel loop over rows (see [`TprfFilm::run_pass_planned`]).
pub(super) fn leaf_rows(layout: &FilmLayout) -> usize {
    let share = layout.height / rayon::current_num_threads();
    (share / 64)
        .max(layout.axis.bins / (64 * layout.width.max(1)))
        .min(share / 16)
        .max(1)
}

/// The two-half error estimate ([`TprfFilm::half_error_estimate`]) from the samples per
/// half and the rows' error terms ([`TprfFilm::row_error_terms`]) in row order: the one
/// formula, so a cube merged from shards' rows gets the estimate bit for bit.
pub fn half_error_from_terms(
    half_spp: [u64; 2],
    row_terms: impl IntoIterator<Item = (f64, f64)>,
) -> Option<f64> {
    let [na, nb] = half_spp;
    if na == 0 || nb == 0 {
        return None;
    }
    let (na, nb) = (na as f64, nb as f64);
    let n = na + nb;
    let (diff2, norm2) = row_terms
        .into_iter()
        .fold((0.0, 0.0), |acc, t| (acc.0 + t.0, acc.1 + t.1));
    if norm2 == 0.0 {
        return Some(0.0);
    }
    Some((diff2.sqrt() * (na * nb).sqrt() / n) / norm2.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::TimeAxis;

    fn layout(width: usize, height: usize) -> FilmLayout {
        FilmLayout {
            width,
            height,
            axis: TimeAxis {
                t0_s: 0.0,
                dt_s: 1e-12,
                bins: 64,
            },
            bounces_separate: 0,
            luminescence: false,
        }
    }

    /// A new film's rows are one shared empty row: held once, while the store's
    /// statistics count it per row (what the rows hold once each is rebuilt).
    #[test]
    fn a_shared_row_is_held_once() {
        let film = TprfFilm::new(layout(100, 300)).unwrap();
        let one_row = film.rows[0].heap_bytes() as u64;
        assert!(one_row >= 100 * 8, "a row holds at least its steady sums");
        let list = film.row_list_bytes();
        assert_eq!(film.held_bytes(), one_row + list);
        assert_eq!(film.store_stats().bytes, 300 * one_row + list);
    }
}

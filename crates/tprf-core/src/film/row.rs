//! One image row of the film: the two halves' sums and the bounce layers as sparse runs
//! (`sparse.rs`), with per-pixel summaries remade after every pass. A pass renders the
//! row's pixels into a dense scratch, one pixel at a time, then adds what it found to the
//! row in place where the film holds the row's only reference and every new bin is
//! stored, else merges the old row with it into a new row. Readers (snapshots) share
//! rows by `Arc` while the film moves on; a row they share is never changed.

use super::sink::{PixelSink, Scratch};
use super::sparse::{RowBuilder, SparseRow, merge_pixel};
use super::{FilmLayout, LeftOutCounts, TimeFilter};
use std::sync::Arc;

/// [`FilmRow::peak_bin`] of a pixel that received no light.
pub const NO_PEAK: u32 = u32::MAX;

/// One image row of sums.
#[derive(Clone, Debug, Default)]
pub struct FilmRow {
    /// Per pixel, per stored bin: the sums of the even passes and of the odd passes.
    pub(super) halves: SparseRow<[f64; 2]>,
    /// Per layer (empty without per-bounce layers): sums over all passes.
    pub(super) layers: Vec<SparseRow<f64>>,
    /// Per pixel: the sum over bins of both halves (not divided by the samples).
    pub(super) steady_sum: Vec<f64>,
    /// Per pixel: the bin of the largest sum (the first of equals), [`NO_PEAK`] if dark.
    pub(super) peak_bin: Vec<u32>,
    /// Over the row's bins: the sums of `(a / n_a - b / n_b)^2` and `((a + b) / n)^2`
    /// for the sample counts the row was built with (the two-half error estimate).
    pub(super) err_terms: (f64, f64),
    /// Per pixel: the samples it drew and what they cost (empty in a row read from a
    /// file, which draws none).
    pub(super) samples: Vec<PixelSamples>,
}

/// One pixel's sampling so far: what an adaptive pass plan reads (see
/// [`TprfFilm::run_pass_planned`](super::TprfFilm::run_pass_planned)).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSamples {
    /// Samples drawn into each half: the index of the next one in the pixel's stream of
    /// that half.
    pub drawn: [u32; 2],
    /// Work per sample of the pixel's last pass, in whatever unit the renderer reports
    /// (rays); 0 before its first pass.
    pub cost: f32,
    /// Sum over the pixel's bins of `(a / n_a - b / n_b)^2`: the squared difference of
    /// the two halves' means (the film's `n_a`, `n_b`), the pixel's term of the two-half
    /// error estimate.
    pub half_diff2: f32,
}

impl FilmRow {
    /// A row of `width` pixels with nothing stored.
    pub fn empty(width: usize, layers: usize) -> FilmRow {
        FilmRow {
            halves: SparseRow::empty(width),
            layers: (0..layers).map(|_| SparseRow::empty(width)).collect(),
            steady_sum: vec![0.0; width],
            peak_bin: vec![NO_PEAK; width],
            err_terms: (0.0, 0.0),
            samples: vec![PixelSamples::default(); width],
        }
    }

    /// A row of means `[W, T]` (zero = not stored), as read from a file: stored as the
    /// first half with one sample.
    pub fn from_dense(pixels: &[f32], width: usize, bins: usize) -> FilmRow {
        FilmRow::from_builder(dense_to_builder(pixels, width, bins, |v| [v, 0.0]), width)
    }

    /// A row of means built pixel by pixel (first half, one sample), see
    /// `SnapshotBuilder`.
    pub(super) fn from_builder(mut b: RowBuilder<[f64; 2]>, width: usize) -> FilmRow {
        let mut row = FilmRow {
            halves: b.take_exact(width),
            layers: Vec::new(),
            steady_sum: Vec::new(),
            peak_bin: Vec::new(),
            err_terms: (0.0, 0.0),
            samples: Vec::new(),
        };
        // One sample in the first half, none in the second: no error terms.
        row.summarise([1, 0]);
        row
    }

    /// A layer row of means `[W, T]` added to a row made by [`FilmRow::from_dense`].
    pub fn push_dense_layer(&mut self, pixels: &[f32], width: usize, bins: usize) {
        let mut b = dense_to_builder(pixels, width, bins, |v| v);
        self.layers.push(b.take_exact(width));
    }

    /// Bins stored (of the halves; the layers store at most as many each).
    pub fn stored_bins(&self) -> usize {
        self.halves.stored_bins()
    }

    /// Runs stored (of the halves).
    pub fn runs(&self) -> usize {
        self.halves.runs()
    }

    /// Heap bytes the row holds.
    pub fn heap_bytes(&self) -> usize {
        self.halves.heap_bytes()
            + self.layers.iter().map(SparseRow::heap_bytes).sum::<usize>()
            + self.layers.capacity() * std::mem::size_of::<SparseRow<f64>>()
            + self.steady_sum.capacity() * 8
            + self.peak_bin.capacity() * 4
            + self.samples.capacity() * std::mem::size_of::<PixelSamples>()
    }

    /// Pixel `x`'s sampling so far (none drawn in a row read from a file).
    pub fn pixel_samples(&self, x: usize) -> PixelSamples {
        self.samples.get(x).copied().unwrap_or_default()
    }
}

/// The non-zero bins of dense rows `[W, T]` of means, as values `value(mean)`.
fn dense_to_builder<V: Copy>(
    pixels: &[f32],
    width: usize,
    bins: usize,
    value: impl Fn(f64) -> V,
) -> RowBuilder<V> {
    let mut b = RowBuilder::default();
    for x in 0..width {
        let p = pixels.get(x * bins..(x + 1) * bins).unwrap_or(&[]);
        for (bin, v) in p.iter().enumerate() {
            if *v != 0.0 {
                b.push(bin, value(*v as f64));
            }
        }
        b.end_pixel();
    }
    b
}

/// What a task keeps from row to row during a pass: the pixel scratch and the buffers
/// of the new bins and the builders.
pub(super) struct RowWork {
    scratch: Scratch,
    /// New bins of the halves: all pixels of the row, and where each pixel's end.
    new: Vec<(u32, f64)>,
    new_end: Vec<usize>,
    layer_new: Vec<Vec<(u32, f64)>>,
    layer_new_end: Vec<Vec<usize>>,
    /// Where the new bins sit in a row's values (see [`SparseRow::add_in_place`]).
    pos: Vec<u32>,
}

impl RowWork {
    pub fn new(layout: &FilmLayout) -> RowWork {
        let l = layout.bounce_layers();
        RowWork {
            scratch: Scratch::new(layout),
            // Room for 32 new bins a pixel (what a 9-spp pass adds on the Cornell box),
            // so a leaf's first rows do not grow it by copying: with leaves of two
            // rows, that growth was 0.4 % of a render's instructions.
            new: Vec::with_capacity(layout.width * 32),
            new_end: Vec::new(),
            layer_new: vec![Vec::new(); l],
            layer_new_end: vec![Vec::new(); l],
            pos: Vec::new(),
        }
    }
}

/// What rendering one row returned besides the row.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct RowTally {
    pub outside: f64,
    pub left_out: LeftOutCounts,
    pub work: u64,
}

/// Samples one pass draws for one pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelPass {
    /// Index of the first one in the pixel's sample stream of the pass's half: the
    /// samples the pixel drew into that half before.
    pub first: u32,
    /// How many (at least 1).
    pub samples: u32,
}

/// Render row `y` of a pass of `pass_spp` samples per pixel (nominal) into half `half`:
/// every pixel through `render_pixel`, in order, then the new bins added to the row: in
/// place where the film holds the row's only reference and every new bin is stored
/// already, else merged with the old row into a new one. `plan` is the row's samples per
/// pixel (`None`: `pass_spp` each); a pixel's contributions are weighted `pass_spp /
/// samples` (see `TprfFilm::run_pass_planned`). `spp_after` is the film's samples per
/// half once the pass is counted. The tally's `work` is the sum of what `render_pixel`
/// returned.
#[allow(
    clippy::too_many_arguments,
    reason = "a row's pass: its rows, plan, axis and callbacks, on the hot path"
)]
pub(super) fn render_row<F>(
    row: &mut Arc<FilmRow>,
    y: usize,
    layout: &FilmLayout,
    filter: TimeFilter,
    half: usize,
    pass_spp: u32,
    plan: Option<&[u32]>,
    spp_after: [u64; 2],
    work: &mut RowWork,
    render_pixel: &F,
) -> RowTally
where
    F: Fn(usize, usize, PixelPass, &mut PixelSink<'_>) -> u64 + Sync,
{
    let w = layout.width;
    let mut tally = RowTally::default();
    work.begin_row(layout);
    let mut samples = Vec::with_capacity(w);
    for x in 0..w {
        let (pass, weight) = pixel_pass(row, x, half, pass_spp, plan);
        let mut sink = PixelSink::new(*layout, filter, weight, &mut work.scratch);
        let cost = render_pixel(x, y, pass, &mut sink);
        tally.work += cost;
        tally.outside += sink.outside;
        tally.left_out += sink.left_out;
        samples.push(drawn_after(row, x, half, pass, cost));
        work.end_pixel(layout);
    }
    commit_row(row, layout, half, spp_after, work, samples);
    tally
}

/// Pixel `x`'s samples in a pass of `pass_spp` per pixel into half `half` (`plan`: the
/// row's samples per pixel, `None`: `pass_spp` each), and the weight of its
/// contributions, `pass_spp / samples`.
#[inline]
pub(super) fn pixel_pass(
    row: &FilmRow,
    x: usize,
    half: usize,
    pass_spp: u32,
    plan: Option<&[u32]>,
) -> (PixelPass, f64) {
    let drawn = row.pixel_samples(x);
    let n = plan
        .and_then(|p| p.get(x).copied())
        .unwrap_or(pass_spp)
        .max(1);
    let pass = PixelPass {
        first: drawn.drawn[half],
        samples: n,
    };
    // Exactly 1 when the pixel draws the pass's samples (x / x = 1 in IEEE).
    (pass, pass_spp as f64 / n as f64)
}

/// Pixel `x`'s sampling record once `pass` drew its samples at a work of `cost`.
#[inline]
pub(super) fn drawn_after(
    row: &FilmRow,
    x: usize,
    half: usize,
    pass: PixelPass,
    cost: u64,
) -> PixelSamples {
    let mut drawn = row.pixel_samples(x);
    drawn.drawn[half] = drawn.drawn[half].wrapping_add(pass.samples);
    drawn.cost = (cost as f64 / pass.samples as f64) as f32;
    drawn
}

impl RowWork {
    /// Start a row: no new bins yet.
    #[inline]
    pub(super) fn begin_row(&mut self, layout: &FilmLayout) {
        self.new.clear();
        self.new_end.clear();
        for l in 0..layout.bounce_layers() {
            self.layer_new[l].clear();
            self.layer_new_end[l].clear();
        }
    }

    /// After a pixel's samples: its scratch's bins taken into the row's new bins.
    #[inline]
    pub(super) fn end_pixel(&mut self, layout: &FilmLayout) {
        let t = layout.axis.bins;
        let s = &mut self.scratch;
        s.touched.drain(&mut s.bins, &mut self.new);
        self.new_end.push(self.new.len());
        for l in 0..layout.bounce_layers() {
            let bins = s.layers.get_mut(l * t..(l + 1) * t).unwrap_or(&mut []);
            s.layer_touched[l].drain(bins, &mut self.layer_new[l]);
            self.layer_new_end[l].push(self.layer_new[l].len());
        }
    }

    /// The scratch a pixel's sink adds to.
    pub(super) fn scratch(&mut self) -> &mut Scratch {
        &mut self.scratch
    }
}

/// The row's new bins (`work`, one pass into half `half`) added to `row`: in place where
/// the film holds the row's only reference and every new bin is stored already, else
/// merged with the old row into a new one; `samples` the pixels' sampling records after
/// the pass, `spp_after` the film's samples per half once the pass is counted.
pub(super) fn commit_row(
    row: &mut Arc<FilmRow>,
    layout: &FilmLayout,
    half: usize,
    spp_after: [u64; 2],
    work: &mut RowWork,
    samples: Vec<PixelSamples>,
) {
    let w = layout.width;
    let layers = layout.bounce_layers();
    // Branches, not `o[half]`: an array indexed by a variable lives on the stack.
    let add_half = |[a, b]: [f64; 2], n: f64| if half == 0 { [a + n, b] } else { [a, b + n] };
    let fresh_half = |n: f64| if half == 0 { [n, 0.0] } else { [0.0, n] };
    let add = |o: f64, n: f64| o + n;
    let fresh = |n: f64| n;
    let Some(r) = Arc::get_mut(row) else {
        // Shared with a reader: the next row is new, the old one stays as it is.
        let old = &**row;
        let empty = SparseRow::empty(w);
        let (new, new_end) = (&work.new, &work.new_end);
        let mut next = FilmRow {
            halves: merge_row(&old.halves, w, new, new_end, add_half, fresh_half),
            layers: (0..layers)
                .map(|l| {
                    let old_layer = old.layers.get(l).unwrap_or(&empty);
                    let (new, new_end) = (&work.layer_new[l], &work.layer_new_end[l]);
                    merge_row(old_layer, w, new, new_end, add, fresh)
                })
                .collect(),
            steady_sum: Vec::new(),
            peak_bin: Vec::new(),
            err_terms: (0.0, 0.0),
            samples,
        };
        next.summarise(spp_after);
        *row = Arc::new(next);
        return;
    };
    // The film's only copy: the pass's bins are added where they are stored, and the row
    // is rebuilt only where one is new.
    let (new, new_end) = (&work.new, &work.new_end);
    if !r.halves.add_in_place(new, new_end, &mut work.pos, add_half) {
        r.halves = merge_row(&r.halves, w, new, new_end, add_half, fresh_half);
    }
    r.layers
        .resize_with(layers.max(r.layers.len()), || SparseRow::empty(w));
    for (l, layer) in r.layers.iter_mut().enumerate().take(layers) {
        let (new, new_end) = (&work.layer_new[l], &work.layer_new_end[l]);
        if !layer.add_in_place(new, new_end, &mut work.pos, add) {
            *layer = merge_row(layer, w, new, new_end, add, fresh);
        }
    }
    r.samples = samples;
    r.summarise(spp_after);
}

/// Every pixel of `old` merged with the pass's new bins (`new`, pixel `x`'s ending at
/// `new_end[x]`) into a new row of `width` pixels (see [`merge_pixel`]), its values
/// allocated once.
fn merge_row<V: Copy>(
    old: &SparseRow<V>,
    width: usize,
    new: &[(u32, f64)],
    new_end: &[usize],
    mut combine: impl FnMut(V, f64) -> V,
    mut fresh: impl FnMut(f64) -> V,
) -> SparseRow<V> {
    // At most every new bin is new to the row: room for that, and `finish` gives back
    // what is left over (a shrink in place, not a copy; counting the new bins first
    // cost a third walk of the row's runs).
    let at_most = new.len();
    let mut out =
        RowBuilder::with_capacity(width, old.runs() + at_most, old.stored_bins() + at_most);
    let mut start = 0;
    for (x, &end) in new_end.iter().enumerate() {
        merge_pixel(
            old,
            x,
            new.get(start..end).unwrap_or(&[]),
            &mut out,
            &mut combine,
            &mut fresh,
        );
        start = end;
    }
    out.finish(width)
}

impl FilmRow {
    /// Remake the per-pixel summaries from the halves in one sweep: steady sums, peak
    /// bins, and the two-half error terms for `spp_after` samples per half, with each
    /// pixel's share in its `samples`.
    ///
    /// The error terms are the row's sums of `(a / n_a - b / n_b)^2` and `((a + b) /
    /// n)^2` over its bins (see `TprfFilm::half_error_estimate`), 0 while a half has no
    /// samples; each pixel's first sum goes into its `samples` (where it has them).
    fn summarise(&mut self, [na, nb]: [u64; 2]) {
        let w = self.halves.width();
        let halves_drawn = na > 0 && nb > 0;
        let (na, nb) = (na as f64, nb as f64);
        // Reciprocals: three multiplications per bin where three divisions were.
        let (inv_na, inv_nb, inv_n) = (1.0 / na, 1.0 / nb, 1.0 / (na + nb));
        let (mut diff2, mut norm2) = (0.0, 0.0);
        // Exactly `w` each, whichever way the row was made (the store's byte count must
        // not depend on it: the last row still sharing a film's first, empty row finds
        // it unique and keeps its vectors).
        self.steady_sum.clear();
        self.steady_sum.reserve_exact(w);
        self.peak_bin.clear();
        self.peak_bin.reserve_exact(w);
        for x in 0..w {
            // The pixel's values are contiguous: one pass over them, then the peak's
            // value index turned into its bin.
            let values = self.halves.pixel_values(x);
            let mut sum = 0.0;
            let mut best: Option<(usize, f64)> = None;
            let mut pixel_diff2 = 0.0;
            for (i, &[a, b]) in values.iter().enumerate() {
                let s = a + b;
                sum += s;
                if s > 0.0 && best.is_none_or(|(_, m)| s > m) {
                    best = Some((i, s));
                }
                if halves_drawn {
                    let d = a * inv_na - b * inv_nb;
                    let m = s * inv_n;
                    diff2 += d * d;
                    pixel_diff2 += d * d;
                    norm2 += m * m;
                }
            }
            self.steady_sum.push(sum);
            let peak = best.and_then(|(i, _)| self.halves.bin_of_value(x, i));
            self.peak_bin.push(peak.map_or(NO_PEAK, |b| b as u32));
            if let Some(s) = self.samples.get_mut(x) {
                s.half_diff2 = pixel_diff2 as f32;
            }
        }
        self.err_terms = (diff2, norm2);
    }
}

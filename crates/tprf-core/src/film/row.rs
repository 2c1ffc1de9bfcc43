//! One image row of the film: the two halves' sums and the bounce layers as sparse runs
//! (`sparse.rs`), with per-pixel summaries made when the row is built. A row is never
//! changed: a pass renders the row's pixels into a dense scratch, one pixel at a time,
//! and merges the old row with what the pass added into a new row. Readers (snapshots)
//! share rows by `Arc` while the film moves on.

use super::sink::{PixelSink, Scratch, drain_touched};
use super::sparse::{RowBuilder, SparseRow, merge_pixel};
use super::{FilmLayout, LeftOutCounts, TimeFilter};

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
        let halves = b.take_exact(width);
        let (steady_sum, peak_bin) = summaries(&halves);
        FilmRow {
            halves,
            layers: Vec::new(),
            steady_sum,
            peak_bin,
            err_terms: (0.0, 0.0),
            samples: Vec::new(),
        }
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

/// Per-pixel steady sums and peak bins of `halves`.
fn summaries(halves: &SparseRow<[f64; 2]>) -> (Vec<f64>, Vec<u32>) {
    let w = halves.width();
    let mut steady = Vec::with_capacity(w);
    let mut peak = Vec::with_capacity(w);
    for x in 0..w {
        let mut sum = 0.0;
        let mut best: Option<(u32, f64)> = None;
        for (start, values) in halves.pixel_runs(x) {
            for (i, v) in values.iter().enumerate() {
                let s = v[0] + v[1];
                sum += s;
                if s > 0.0 && best.is_none_or(|(_, m)| s > m) {
                    best = Some(((start + i) as u32, s));
                }
            }
        }
        steady.push(sum);
        peak.push(best.map_or(NO_PEAK, |(b, _)| b));
    }
    (steady, peak)
}

/// What a task keeps from row to row during a pass: the pixel scratch and the buffers
/// of the new bins and the builders.
pub(super) struct RowWork {
    scratch: Scratch,
    drained: Vec<(u32, f64)>,
    /// New bins of the halves: all pixels of the row, and where each pixel's end.
    new: Vec<(u32, f64)>,
    new_end: Vec<usize>,
    layer_new: Vec<Vec<(u32, f64)>>,
    layer_new_end: Vec<Vec<usize>>,
    halves: RowBuilder<[f64; 2]>,
    layer: RowBuilder<f64>,
}

impl RowWork {
    pub fn new(layout: &FilmLayout) -> RowWork {
        let l = layout.bounce_layers();
        RowWork {
            scratch: Scratch::new(layout),
            drained: Vec::new(),
            new: Vec::new(),
            new_end: Vec::new(),
            layer_new: vec![Vec::new(); l],
            layer_new_end: vec![Vec::new(); l],
            halves: RowBuilder::default(),
            layer: RowBuilder::default(),
        }
    }
}

/// What rendering one row returned besides the row.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct RowTally {
    pub outside: f64,
    pub left_out: LeftOutCounts,
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
/// every pixel through `render_pixel`, in order, then the old row merged with the new
/// bins. `plan` is the row's samples per pixel (`None`: `pass_spp` each); a pixel's
/// contributions are weighted `pass_spp / samples` (see `TprfFilm::run_pass_planned`).
/// `spp_after` is the film's samples per half once the pass is counted.
#[allow(clippy::too_many_arguments)]
pub(super) fn render_row<F>(
    old: &FilmRow,
    y: usize,
    layout: &FilmLayout,
    filter: TimeFilter,
    half: usize,
    pass_spp: u32,
    plan: Option<&[u32]>,
    spp_after: [u64; 2],
    work: &mut RowWork,
    render_pixel: &F,
) -> (FilmRow, RowTally)
where
    F: Fn(usize, usize, PixelPass, &mut PixelSink<'_>) -> u64 + Sync,
{
    let w = layout.width;
    let t = layout.axis.bins;
    let layers = layout.bounce_layers();
    let mut tally = RowTally::default();
    work.new.clear();
    work.new_end.clear();
    for l in 0..layers {
        work.layer_new[l].clear();
        work.layer_new_end[l].clear();
    }
    let mut samples = Vec::with_capacity(w);
    for x in 0..w {
        let mut drawn = old.pixel_samples(x);
        let n = plan
            .and_then(|p| p.get(x).copied())
            .unwrap_or(pass_spp)
            .max(1);
        let pass = PixelPass {
            first: drawn.drawn[half],
            samples: n,
        };
        // Exactly 1 when the pixel draws the pass's samples (x / x = 1 in IEEE).
        let weight = pass_spp as f64 / n as f64;
        let mut sink = PixelSink::new(*layout, filter, weight, &mut work.scratch);
        let cost = render_pixel(x, y, pass, &mut sink);
        drawn.drawn[half] = drawn.drawn[half].wrapping_add(n);
        drawn.cost = (cost as f64 / n as f64) as f32;
        samples.push(drawn);
        tally.outside += sink.outside;
        tally.left_out += sink.left_out;
        let s = &mut work.scratch;
        drain_touched(&mut s.bins, &mut s.touched, &mut work.drained);
        work.new.extend_from_slice(&work.drained);
        work.new_end.push(work.new.len());
        for l in 0..layers {
            let bins = s.layers.get_mut(l * t..(l + 1) * t).unwrap_or(&mut []);
            drain_touched(bins, &mut s.layer_touched[l], &mut work.drained);
            work.layer_new[l].extend_from_slice(&work.drained);
            work.layer_new_end[l].push(work.layer_new[l].len());
        }
    }
    // Merge: the old sums plus this pass's, pixel by pixel.
    let mut start = 0;
    for x in 0..w {
        let end = work.new_end[x];
        merge_pixel(
            &old.halves,
            x,
            &work.new[start..end],
            &mut work.halves,
            |mut o, n| {
                o[half] += n;
                o
            },
            |n| {
                let mut v = [0.0; 2];
                v[half] = n;
                v
            },
        );
        start = end;
    }
    let halves = work.halves.take_exact(w);
    let mut layer_rows = Vec::with_capacity(layers);
    for l in 0..layers {
        let mut start = 0;
        let old_layer = old.layers.get(l);
        let empty = SparseRow::empty(w);
        let old_layer = old_layer.unwrap_or(&empty);
        for x in 0..w {
            let end = work.layer_new_end[l][x];
            merge_pixel(
                old_layer,
                x,
                &work.layer_new[l][start..end],
                &mut work.layer,
                |o, n| o + n,
                |n| n,
            );
            start = end;
        }
        layer_rows.push(work.layer.take_exact(w));
    }
    let (steady_sum, peak_bin) = summaries(&halves);
    let err_terms = error_terms(&halves, spp_after, &mut samples);
    (
        FilmRow {
            halves,
            layers: layer_rows,
            steady_sum,
            peak_bin,
            err_terms,
            samples,
        },
        tally,
    )
}

/// The row's sums of `(a / n_a - b / n_b)^2` and `((a + b) / n)^2` (see
/// `TprfFilm::half_error_estimate`), and each pixel's first sum into its `samples`.
fn error_terms(
    halves: &SparseRow<[f64; 2]>,
    [na, nb]: [u64; 2],
    samples: &mut [PixelSamples],
) -> (f64, f64) {
    if na == 0 || nb == 0 {
        return (0.0, 0.0);
    }
    let (na, nb) = (na as f64, nb as f64);
    let n = na + nb;
    let mut diff2 = 0.0;
    let mut norm2 = 0.0;
    for (x, s) in samples.iter_mut().enumerate().take(halves.width()) {
        let mut pixel_diff2 = 0.0;
        for (_, values) in halves.pixel_runs(x) {
            for [a, b] in values {
                let d = a / na - b / nb;
                let m = (a + b) / n;
                diff2 += d * d;
                pixel_diff2 += d * d;
                norm2 += m * m;
            }
        }
        s.half_diff2 = pixel_diff2 as f32;
    }
    (diff2, norm2)
}

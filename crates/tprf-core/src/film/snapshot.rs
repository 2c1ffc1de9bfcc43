//! A reader's view of the film's current estimate, handed to other threads (the viewer,
//! the sensor, exports) while the renderer keeps adding samples. It shares the film's
//! immutable rows, so making one copies nothing; means are formed as they are read.
//!
//! This is the one read interface of the film: a pixel's TPRF and its span, its runs of
//! stored bins, a time slice, the steady image, per-bounce curves, rows as dense arrays
//! for files. Nothing outside the film knows how bins are stored.

use super::row::{FilmRow, NO_PEAK};
use super::sparse::{RowBuilder, RunCursor};
use super::{FilmLayout, TimeAxis};
use std::sync::Arc;

/// The film's mean values at one moment.
#[derive(Clone, Debug)]
pub struct FilmSnapshot {
    pub layout: FilmLayout,
    pub spp: u64,
    pub passes: u64,
    /// Relative RMS error estimated from the two half-sample buffers.
    pub error_estimate: Option<f64>,
    rows: Vec<Arc<FilmRow>>,
    /// What a stored sum is divided by to give a mean: `spp` for a live film, 1 for a
    /// cube read from a file (which stores means).
    norm: f64,
    /// Summaries made once, when the snapshot is made, so readers drawing every frame
    /// never scan the cube.
    steady: Vec<f32>,
    peak_bin: Vec<Option<u32>>,
    robust_max: Option<f64>,
    /// See [`FilmSnapshot::generation`].
    generation: u64,
    /// See [`FilmSnapshot::film`].
    film: u64,
}

/// The next [`FilmSnapshot::generation`] or film identity (one sequence for both); 0 is
/// never handed out.
static NEXT_GENERATION: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

/// A number no snapshot or film of this process has had.
pub(super) fn next_id() -> u64 {
    NEXT_GENERATION.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// At most this many values are looked at for [`FilmSnapshot::robust_max`].
const ROBUST_MAX_SAMPLES: usize = 1 << 20;

/// Values of a band of rows made dense at a time by [`FilmSnapshot::from_dense_rows`]
/// (64 MiB of f32; at least one row).
pub const DENSE_BAND_VALUES: usize = 1 << 24;

impl FilmSnapshot {
    /// A snapshot sharing a film's rows (sums of `spp` samples per pixel).
    pub(super) fn from_rows(
        layout: FilmLayout,
        spp: u64,
        passes: u64,
        rows: Vec<Arc<FilmRow>>,
        error_estimate: Option<f64>,
        film: u64,
    ) -> FilmSnapshot {
        let mut snap =
            FilmSnapshot::summarised(layout, spp, passes, rows, spp.max(1) as f64, error_estimate);
        snap.film = film;
        snap
    }

    /// A snapshot of means read from a file: `cube` `[H, W, T]` and `bounces`
    /// `[L, H, W, T]` or empty (zeros are not stored).
    pub fn from_dense(
        layout: FilmLayout,
        spp: u64,
        passes: u64,
        cube: &[f32],
        bounces: &[f32],
        error_estimate: Option<f64>,
    ) -> FilmSnapshot {
        let (w, h, t) = (layout.width, layout.height, layout.axis.bins);
        let plane = w * h * t;
        let layers = bounces.len().checked_div(plane).unwrap_or(0);
        let read = |y0: usize, layer: Option<usize>, out: &mut [f32]| {
            let src = match layer {
                None => cube,
                Some(l) => bounces.get(l * plane..).unwrap_or(&[]),
            };
            let src = src.get(y0 * w * t..).unwrap_or(&[]);
            let n = out.len().min(src.len());
            out[..n].copy_from_slice(&src[..n]);
            out[n..].fill(0.0);
            Ok::<(), std::convert::Infallible>(())
        };
        match FilmSnapshot::from_dense_rows(
            layout,
            spp,
            passes,
            layers,
            error_estimate,
            read,
            |_, _| Ok(()),
        ) {
            Ok(s) => s,
            Err(never) => match never {},
        }
    }

    /// A snapshot of means read a band of rows at a time, so that only one band is
    /// dense in memory: `read(y0, layer, out)` fills `out` (`[rows, W, T]` from row `y0`)
    /// with the total (`layer` `None`) or bounce layer `l` of `layers`; zeros are not
    /// stored. After each band, `after_band(rows_done, heap_bytes)` may stop the read
    /// (a memory budget).
    pub fn from_dense_rows<E>(
        layout: FilmLayout,
        spp: u64,
        passes: u64,
        layers: usize,
        error_estimate: Option<f64>,
        mut read: impl FnMut(usize, Option<usize>, &mut [f32]) -> Result<(), E>,
        mut after_band: impl FnMut(usize, usize) -> Result<(), E>,
    ) -> Result<FilmSnapshot, E> {
        use rayon::prelude::*;
        let (w, h, t) = (layout.width, layout.height, layout.axis.bins);
        let row_len = (w * t).max(1);
        let band = (DENSE_BAND_VALUES / row_len).clamp(1, h.max(1));
        let mut rows: Vec<FilmRow> = Vec::with_capacity(h);
        let mut buf = Vec::new();
        let mut heap_bytes = 0;
        for y0 in (0..h).step_by(band) {
            let n = band.min(h - y0);
            buf.resize(n * w * t, 0.0);
            read(y0, None, &mut buf)?;
            let mut built: Vec<FilmRow> = buf
                .par_chunks(row_len)
                .map(|px| FilmRow::from_dense(px, w, t))
                .collect();
            for l in 0..layers {
                read(y0, Some(l), &mut buf)?;
                built
                    .par_iter_mut()
                    .zip(buf.par_chunks(row_len))
                    .for_each(|(row, px)| row.push_dense_layer(px, w, t));
            }
            heap_bytes += built.iter().map(FilmRow::heap_bytes).sum::<usize>();
            rows.extend(built);
            after_band(y0 + n, heap_bytes)?;
        }
        // The luminescence layer, when the caller's layout says the file has one, is
        // the last.
        let lum = layout.luminescence && layers >= 4;
        let layout = FilmLayout {
            bounces_separate: match layers - usize::from(lum) {
                l if l >= 2 => (l - 2) as u32,
                _ => 0,
            },
            luminescence: lum,
            ..layout
        };
        let rows = rows.into_iter().map(Arc::new).collect();
        Ok(FilmSnapshot::summarised(
            layout,
            spp,
            passes,
            rows,
            1.0,
            error_estimate,
        ))
    }

    fn summarised(
        layout: FilmLayout,
        spp: u64,
        passes: u64,
        rows: Vec<Arc<FilmRow>>,
        norm: f64,
        error_estimate: Option<f64>,
    ) -> FilmSnapshot {
        let steady = rows
            .iter()
            .flat_map(|r| r.steady_sum.iter().map(|s| (s / norm) as f32))
            .collect();
        let peak_bin = rows
            .iter()
            .flat_map(|r| r.peak_bin.iter().map(|&b| (b != NO_PEAK).then_some(b)))
            .collect();
        let stored: usize = rows.iter().map(|r| r.stored_bins()).sum();
        let stride = stored.div_ceil(ROBUST_MAX_SAMPLES).max(1);
        let sample = rows.iter().flat_map(|r| {
            r.halves
                .values()
                .iter()
                .step_by(stride)
                .map(|[a, b]| ((a + b) / norm) as f32)
        });
        let robust_max = quantile_positive(sample, 0.999);
        let generation = next_id();
        FilmSnapshot {
            layout,
            spp,
            passes,
            error_estimate,
            rows,
            norm,
            steady,
            peak_bin,
            robust_max,
            generation,
            film: generation,
        }
    }

    /// A number no other snapshot made by this process has (clones share it): what
    /// readers key caches on. An address (`Arc::as_ptr`) is not an identity: once a
    /// snapshot is freed the allocator may hand the same address to the next one.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The film this is a snapshot of: the passes of one render share it, any other
    /// snapshot (a cube read from a file, another render) has its own. What tells a
    /// reader that an earlier snapshot is an earlier pass of the same film.
    pub fn film(&self) -> u64 {
        self.film
    }

    pub fn axis(&self) -> &TimeAxis {
        &self.layout.axis
    }

    pub fn width(&self) -> usize {
        self.layout.width
    }

    pub fn height(&self) -> usize {
        self.layout.height
    }

    /// Number of per-bounce layers (0 when not recorded), the luminescence layer
    /// included.
    pub fn layers(&self) -> usize {
        self.rows.first().map_or(0, |r| r.layers.len())
    }

    /// The index of the luminescence layer (the light re-emitted by a luminescent
    /// surface, [`FilmLayout::luminescence`]), when the film has one: the last.
    pub fn luminescence_layer(&self) -> Option<usize> {
        self.layout
            .luminescence_layer()
            .filter(|&l| l < self.layers())
    }

    fn row(&self, x: usize, y: usize) -> Option<&FilmRow> {
        self.rows
            .get(y)
            .map(|r| &**r)
            .filter(|_| x < self.layout.width)
    }

    /// The samples pixel `(x, y)` drew, both halves together (under adaptive sampling a
    /// pixel's own count, against the film's mean `spp`); `None` outside
    /// the image and for a cube read from a file, which records none.
    pub fn pixel_samples_drawn(&self, x: usize, y: usize) -> Option<u64> {
        let row = self.row(x, y)?;
        let drawn = row.samples.get(x)?.drawn;
        Some(drawn[0] as u64 + drawn[1] as u64)
    }

    /// Pixel `(x, y)`'s runs of stored bins in increasing order: `f(first bin, means)`.
    /// Bins not visited hold 0. This is how a reader touches only the light (the
    /// sensor's measurement, a sparse export).
    pub fn for_each_run(&self, x: usize, y: usize, mut f: impl FnMut(usize, &[f32])) {
        let Some(row) = self.row(x, y) else { return };
        let mut buf = Vec::new();
        for (start, values) in row.halves.pixel_runs(x) {
            buf.clear();
            buf.extend(values.iter().map(|[a, b]| ((a + b) / self.norm) as f32));
            f(start, &buf);
        }
    }

    /// Pixel `(x, y)`'s runs of stored bins in bounce layer `l`, as
    /// [`FilmSnapshot::for_each_run`] gives the total's. Nothing outside the layers.
    pub fn for_each_layer_run(
        &self,
        l: usize,
        x: usize,
        y: usize,
        mut f: impl FnMut(usize, &[f32]),
    ) {
        let Some(layer) = self.row(x, y).and_then(|r| r.layers.get(l)) else {
            return;
        };
        let mut buf = Vec::new();
        for (start, values) in layer.pixel_runs(x) {
            buf.clear();
            buf.extend(values.iter().map(|v| (v / self.norm) as f32));
            f(start, &buf);
        }
    }

    /// Pixel `(x, y)`'s first and last stored bins; `None` when dark or outside.
    pub fn pixel_span(&self, x: usize, y: usize) -> Option<(usize, usize)> {
        self.row(x, y)?.halves.pixel_span(x)
    }

    /// Bins stored for pixel `(x, y)`.
    pub fn pixel_stored_bins(&self, x: usize, y: usize) -> usize {
        self.row(x, y).map_or(0, |r| r.halves.pixel_stored_bins(x))
    }

    /// The TPRF of pixel `(x, y)`, all `T` bins; empty outside the image.
    pub fn pixel(&self, x: usize, y: usize) -> Vec<f32> {
        let Some(row) = self.row(x, y) else {
            return Vec::new();
        };
        let mut out = vec![0.0; self.layout.axis.bins];
        for (start, values) in row.halves.pixel_runs(x) {
            for (o, [a, b]) in out.iter_mut().skip(start).zip(values) {
                *o = ((a + b) / self.norm) as f32;
            }
        }
        out
    }

    /// Layer `l` of pixel `(x, y)`'s per-bounce TPRFs, all `T` bins; empty outside the
    /// image or the layers.
    pub fn pixel_layer(&self, l: usize, x: usize, y: usize) -> Vec<f32> {
        let Some(layer) = self.row(x, y).and_then(|r| r.layers.get(l)) else {
            return Vec::new();
        };
        let mut out = vec![0.0; self.layout.axis.bins];
        for (start, values) in layer.pixel_runs(x) {
            for (o, v) in out.iter_mut().skip(start).zip(values) {
                *o = (v / self.norm) as f32;
            }
        }
        out
    }

    /// Row `y` as a dense `[W, T]` array of means into `out` (layer `None` for the
    /// total): how files and dense readers take the cube a row at a time.
    pub fn row_dense(&self, y: usize, layer: Option<usize>, out: &mut Vec<f32>) {
        let (w, t) = (self.layout.width, self.layout.axis.bins);
        out.clear();
        out.resize(w * t, 0.0);
        let Some(row) = self.rows.get(y) else { return };
        for (x, dst) in out.chunks_exact_mut(t.max(1)).enumerate() {
            match layer {
                None => {
                    for (start, values) in row.halves.pixel_runs(x) {
                        for (o, [a, b]) in dst.iter_mut().skip(start).zip(values) {
                            *o = ((a + b) / self.norm) as f32;
                        }
                    }
                }
                Some(l) => {
                    let Some(layer) = row.layers.get(l) else {
                        return;
                    };
                    for (start, values) in layer.pixel_runs(x) {
                        for (o, v) in dst.iter_mut().skip(start).zip(values) {
                            *o = (v / self.norm) as f32;
                        }
                    }
                }
            }
        }
    }

    /// The whole cube `[H, W, T]` as one dense array (layer `None` for the total). For
    /// cubes that fit; files are written a row at a time with [`FilmSnapshot::row_dense`].
    pub fn dense(&self, layer: Option<usize>) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.layout.cells() as usize);
        let mut row = Vec::new();
        for y in 0..self.layout.height {
            self.row_dense(y, layer, &mut row);
            out.extend_from_slice(&row);
        }
        out
    }

    /// Mean TPRF over the pixels of the box `[x0, x1] x [y0, y1]` (clamped to the image);
    /// `layer` `None` for the total.
    pub fn box_mean(
        &self,
        x0: usize,
        y0: usize,
        x1: usize,
        y1: usize,
        layer: Option<usize>,
    ) -> Vec<f64> {
        let t = self.layout.axis.bins;
        let mut out = vec![0.0f64; t];
        let (x1, y1) = (
            x1.min(self.layout.width.saturating_sub(1)),
            y1.min(self.layout.height.saturating_sub(1)),
        );
        let mut n = 0usize;
        for y in y0.min(y1)..=y1 {
            for x in x0.min(x1)..=x1 {
                let p = match layer {
                    None => self.pixel(x, y),
                    Some(l) => self.pixel_layer(l, x, y),
                };
                if p.len() == t {
                    n += 1;
                    for (o, v) in out.iter_mut().zip(&p) {
                        *o += *v as f64;
                    }
                }
            }
        }
        if n > 0 {
            out.iter_mut().for_each(|v| *v /= n as f64);
        }
        out
    }

    /// Time slice of bin `b`: `[H * W]`. Each pixel's runs are walked up to `b`: the
    /// work follows the stored runs, not the cube.
    pub fn slice(&self, b: usize) -> Vec<f32> {
        let mut out = Vec::new();
        self.slice_forward(b, &mut SliceCursor::default(), &mut out);
        out
    }

    /// [`Self::slice`] into `out`, for a reader that plays the bins forward: `cursor` keeps
    /// where each pixel's runs were left at the previous bin, so the next bin of the
    /// same snapshot starts from there (a slice costs the pixels plus the runs passed,
    /// not every run before `b`). A cursor of another snapshot, or a bin before the
    /// last, starts again from bin 0.
    pub fn slice_forward(&self, b: usize, cursor: &mut SliceCursor, out: &mut Vec<f32>) {
        use rayon::prelude::*;
        let w = self.layout.width;
        let pixels = self.layout.pixels();
        if cursor.generation != Some(self.generation)
            || b < cursor.bin
            || cursor.pixels.len() != pixels
        {
            cursor.generation = Some(self.generation);
            cursor.pixels.clear();
            cursor.pixels.resize(pixels, RunCursor::default());
        }
        cursor.bin = b;
        out.clear();
        out.resize(pixels, 0.0);
        if b >= self.layout.axis.bins || w == 0 {
            return;
        }
        let norm = self.norm;
        out.par_chunks_mut(w)
            .zip(cursor.pixels.par_chunks_mut(w))
            .zip(self.rows.par_iter())
            .for_each(|((line, cursors), row)| {
                for (x, (v, c)) in line.iter_mut().zip(cursors).enumerate() {
                    if let Some([a, h]) = row.halves.get_from(x, b, c) {
                        *v = ((a + h) / norm) as f32;
                    }
                }
            });
    }

    /// Steady-state image (sum over bins): `[H * W]`.
    pub fn steady(&self) -> &[f32] {
        &self.steady
    }

    /// Per pixel the bin of the TPRF's peak (`None` for a dark pixel): the "rainbow"
    /// view's colour, arrival time of the peak.
    pub fn peak_bins(&self) -> &[Option<u32>] {
        &self.peak_bin
    }

    /// The 99.9 % quantile of the positive bin values (from at most 2^20 of them): a
    /// maximum that one firefly cannot set, for a global exposure.
    pub fn robust_max(&self) -> Option<f64> {
        self.robust_max
    }

    /// Bins stored, against the dense cube's `H x W x T`.
    pub fn stored_bins(&self) -> u64 {
        self.rows.iter().map(|r| r.stored_bins() as u64).sum()
    }
}

/// Where [`FilmSnapshot::slice_forward`] left each pixel's runs, for one snapshot.
#[derive(Clone, Debug, Default)]
pub struct SliceCursor {
    generation: Option<u64>,
    bin: usize,
    pixels: Vec<RunCursor>,
}

/// Builds a snapshot of means pixel by pixel, in any order of rows but in increasing
/// `x` within a row (a tiled file is read tile by tile): only the non-zero bins are
/// kept, so a cube larger than memory as a dense array can be loaded when its light is
/// not. With `layout.bounces_separate > 0` each pixel brings its bounce layers too.
pub struct SnapshotBuilder {
    layout: FilmLayout,
    rows: Vec<RowBuilder<[f64; 2]>>,
    /// Per row, per layer.
    layers: Vec<Vec<RowBuilder<f64>>>,
    next_x: Vec<usize>,
}

impl SnapshotBuilder {
    pub fn new(layout: FilmLayout) -> SnapshotBuilder {
        let l = layout.bounce_layers();
        SnapshotBuilder {
            layout,
            rows: (0..layout.height).map(|_| RowBuilder::default()).collect(),
            layers: (0..layout.height)
                .map(|_| (0..l).map(|_| RowBuilder::default()).collect())
                .collect(),
            next_x: vec![0; layout.height],
        }
    }

    /// Pixel `(x, y)`'s TPRF (`T` means) and, when the layout has bounce layers, each
    /// layer's (`layers[l]`, `T` means; missing layers stay dark). A pixel before the
    /// row's last one, or outside the image, is ignored; pixels skipped stay dark.
    pub fn push_pixel(&mut self, x: usize, y: usize, tprf: &[f32], layers: &[&[f32]]) {
        let (Some(row), Some(layer_rows), Some(next)) = (
            self.rows.get_mut(y),
            self.layers.get_mut(y),
            self.next_x.get_mut(y),
        ) else {
            return;
        };
        if x < *next || x >= self.layout.width {
            return;
        }
        while *next < x {
            row.end_pixel();
            layer_rows.iter_mut().for_each(RowBuilder::end_pixel);
            *next += 1;
        }
        let t = self.layout.axis.bins;
        for (b, v) in tprf.iter().enumerate().take(t) {
            if *v != 0.0 {
                row.push(b, [*v as f64, 0.0]);
            }
        }
        row.end_pixel();
        for (l, builder) in layer_rows.iter_mut().enumerate() {
            for (b, v) in layers
                .get(l)
                .map_or(&[][..], |p| p)
                .iter()
                .enumerate()
                .take(t)
            {
                if *v != 0.0 {
                    builder.push(b, *v as f64);
                }
            }
            builder.end_pixel();
        }
        *next += 1;
    }

    /// The snapshot (recording `spp` and `passes` of the render it came from).
    pub fn finish(self, spp: u64, passes: u64, error_estimate: Option<f64>) -> FilmSnapshot {
        let w = self.layout.width;
        let rows = self
            .rows
            .into_iter()
            .zip(self.layers)
            .map(|(b, layers)| {
                let mut row = FilmRow::from_builder(b, w);
                for mut l in layers {
                    row.layers.push(l.take_exact(w));
                }
                Arc::new(row)
            })
            .collect();
        FilmSnapshot::summarised(self.layout, spp, passes, rows, 1.0, error_estimate)
    }
}

/// The 99.9 % quantile of the positive values, from at most 2^20 of them evenly spaced:
/// a maximum that one outlier cannot set, for an exposure.
pub fn robust_max(values: &[f32]) -> Option<f64> {
    let stride = values.len().div_ceil(ROBUST_MAX_SAMPLES).max(1);
    quantile_positive(values.iter().step_by(stride).copied(), 0.999)
}

/// The `q` quantile of the finite values (NaN and infinities are left out), by nearest
/// rank: with the `n` finite values sorted, `v[k]` for `k = round((n - 1) q)`, `q`
/// clamped to `[0, 1]`. So `q = 0` gives the smallest, `q = 1` the largest, `q = 0.5`
/// the median (the upper middle value when `n` is even). `None` when there is no finite
/// value. The one quantile of tprf: exposures, robust maxima and depth-image ranges all
/// use it.
pub fn quantile(values: impl Iterator<Item = f64>, q: f64) -> Option<f64> {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    let last = v.len().checked_sub(1)?;
    let k = (last as f64 * q.clamp(0.0, 1.0)).round() as usize;
    let (_, x, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    Some(*x)
}

/// [`quantile`] of the positive finite values (zeros and negatives left out), `None`
/// when there are none.
pub fn quantile_positive(values: impl Iterator<Item = f32>, q: f64) -> Option<f64> {
    let mut keys: Vec<u32> = values
        .filter(|x| *x > 0.0 && x.is_finite())
        .map(order_key)
        .collect();
    select_key(&mut keys, q)
}

/// [`quantile`] of `f32` values, the same value for the same input, without a copy in
/// `f64`: the values are selected as 32-bit keys in the order of [`f32::total_cmp`]
/// (`order_key`), which costs a third of the `f64` selection on an image (a time
/// slice's white point, every frame of playback). `keys` is scratch space, kept by the
/// caller so that a frame allocates nothing.
pub fn quantile_f32(values: &[f32], q: f64, keys: &mut Vec<u32>) -> Option<f64> {
    keys.clear();
    keys.extend(
        values
            .iter()
            .filter(|x| x.is_finite())
            .map(|&x| order_key(x)),
    );
    select_key(keys, q)
}

/// A key whose unsigned order is [`f32::total_cmp`]'s order of `x`: negative values
/// have all bits flipped, the others only the sign bit.
fn order_key(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 == 1 { !b } else { b | 1 << 31 }
}

/// The nearest-rank `q` quantile of the values whose [`order_key`]s are `keys`
/// (reordered).
fn select_key(keys: &mut [u32], q: f64) -> Option<f64> {
    let last = keys.len().checked_sub(1)?;
    let k = (last as f64 * q.clamp(0.0, 1.0)).round() as usize;
    let (_, key, _) = keys.select_nth_unstable(k);
    let b = if *key >> 31 == 1 {
        *key & !(1 << 31)
    } else {
        !*key
    };
    Some(f64::from(f32::from_bits(b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Snapshots of one film's passes share [`FilmSnapshot::film`] and differ in
    /// generation; another film, or a cube read from a file, is another film.
    #[test]
    fn passes_of_one_film_share_its_identity() {
        let layout = FilmLayout {
            width: 2,
            height: 1,
            axis: TimeAxis::new(0.0, 1e-9, 3).unwrap(),
            bounces_separate: 0,
            luminescence: false,
        };
        let film = crate::film::TprfFilm::new(layout).unwrap();
        let (a, b) = (film.snapshot(), film.snapshot());
        assert_eq!(a.film(), b.film());
        assert_ne!(a.generation(), b.generation());
        let other = crate::film::TprfFilm::new(layout).unwrap().snapshot();
        assert_ne!(other.film(), a.film());
        let dense = FilmSnapshot::from_dense(layout, 1, 1, &[0.0; 6], &[], None);
        assert_ne!(dense.film(), a.film());
        assert_ne!(dense.film(), other.film());
    }

    #[test]
    fn summaries_by_hand() {
        let axis = TimeAxis::new(0.0, 1e-9, 3).unwrap();
        let layout = FilmLayout {
            width: 2,
            height: 1,
            axis,
            bounces_separate: 0,
            luminescence: false,
        };
        // Pixel 0: 1, 3, 2 (peak bin 1, sum 6); pixel 1 dark.
        let snap =
            FilmSnapshot::from_dense(layout, 4, 1, &[1.0, 3.0, 2.0, 0.0, 0.0, 0.0], &[], None);
        assert_eq!(snap.steady(), &[6.0, 0.0]);
        assert_eq!(snap.peak_bins(), &[Some(1), None]);
        assert_eq!(snap.robust_max(), Some(3.0));
        assert_eq!(snap.slice(2), vec![2.0, 0.0]);
        assert_eq!(snap.slice(7), vec![0.0, 0.0]);
        assert_eq!(snap.layers(), 0);
        assert_eq!(snap.box_mean(0, 0, 1, 0, None), vec![0.5, 1.5, 1.0]);
        assert_eq!(snap.pixel(0, 0), vec![1.0, 3.0, 2.0]);
        assert_eq!(snap.pixel(1, 0), vec![0.0; 3]);
        assert!(snap.pixel(2, 0).is_empty());
        assert_eq!(snap.pixel_span(0, 0), Some((0, 2)));
        assert_eq!(snap.pixel_span(1, 0), None);
        assert_eq!(snap.stored_bins(), 3);
        assert_eq!(snap.dense(None), vec![1.0, 3.0, 2.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn quantiles() {
        let v = [0.0f32, 1.0, 2.0, 3.0, 4.0, f32::NAN];
        assert_eq!(quantile_positive(v.into_iter(), 1.0), Some(4.0));
        assert_eq!(quantile_positive(v.into_iter(), 0.0), Some(1.0));
        assert_eq!(quantile_positive([0.0f32; 3].into_iter(), 0.5), None);
        let w = [f64::NAN, -2.0, 0.0, 5.0, 1.0, f64::INFINITY];
        assert_eq!(quantile(w.into_iter(), 0.0), Some(-2.0));
        assert_eq!(quantile(w.into_iter(), 0.5), Some(1.0));
        assert_eq!(quantile(w.into_iter(), 1.0), Some(5.0));
        assert_eq!(quantile(w.into_iter(), 7.0), Some(5.0));
        assert_eq!(quantile([f64::NAN].into_iter(), 0.5), None);
    }

    /// Slices played forward, backward, repeated and past the end, and on a new
    /// snapshot with the same cursor, are the slices read from the dense cube.
    #[test]
    fn slices_played_forward_are_the_dense_slices() {
        let (w, h, t) = (5, 3, 40);
        let layout = FilmLayout {
            width: w,
            height: h,
            axis: TimeAxis::new(0.0, 1e-9, t).unwrap(),
            bounces_separate: 0,
            luminescence: false,
        };
        let cube = |seed: usize| -> Vec<f32> {
            (0..w * h * t)
                .map(|i| {
                    let k = (i * 7919 + seed * 104_729) % 97;
                    if k < 60 { 0.0 } else { k as f32 * 0.25 }
                })
                .collect()
        };
        let mut cursor = SliceCursor::default();
        let mut out = Vec::new();
        for seed in 0..3 {
            let dense = cube(seed);
            let snap = FilmSnapshot::from_dense(layout, 1, 1, &dense, &[], None);
            for b in [0, 1, 2, 2, 9, 10, 39, 5, 6, 30, 40, 41, 3, 0] {
                snap.slice_forward(b, &mut cursor, &mut out);
                let want: Vec<f32> = (0..w * h)
                    .map(|p| if b < t { dense[p * t + b] } else { 0.0 })
                    .collect();
                assert_eq!(out, want, "seed {seed}, bin {b}");
            }
        }
    }

    /// The key selection gives what the `f64` selection gives (and a full sort, read
    /// at the nearest rank) on values with NaNs, infinities, both zeros and negatives.
    #[test]
    fn f32_quantile_is_the_f64_quantile() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut keys = Vec::new();
        for n in [0usize, 1, 2, 3, 10, 1000] {
            let values: Vec<f32> = (0..n)
                .map(|_| match next() % 10 {
                    0 => f32::NAN,
                    1 => f32::INFINITY,
                    2 => -0.0,
                    3 => 0.0,
                    4 => -((next() % 1000) as f32) * 0.37,
                    _ => (next() % 100_000) as f32 * 1e-3,
                })
                .collect();
            let mut sorted: Vec<f64> = values
                .iter()
                .filter(|v| v.is_finite())
                .map(|&v| f64::from(v))
                .collect();
            sorted.sort_by(f64::total_cmp);
            for q in [0.0, 0.1, 0.5, 0.995, 1.0, -3.0, 9.0] {
                let want = quantile(values.iter().map(|&v| f64::from(v)), q);
                let by_sort = sorted
                    .len()
                    .checked_sub(1)
                    .map(|last| sorted[(last as f64 * q.clamp(0.0, 1.0)).round() as usize]);
                let got = quantile_f32(&values, q, &mut keys);
                assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "n {n} q {q}");
                assert_eq!(
                    got.map(f64::to_bits),
                    by_sort.map(f64::to_bits),
                    "n {n} q {q}"
                );
                let positive: Vec<f64> = sorted.iter().copied().filter(|v| *v > 0.0).collect();
                let want = positive
                    .len()
                    .checked_sub(1)
                    .map(|last| positive[(last as f64 * q.clamp(0.0, 1.0)).round() as usize]);
                assert_eq!(
                    quantile_positive(values.iter().copied(), q),
                    want,
                    "n {n} q {q}"
                );
            }
        }
    }
}

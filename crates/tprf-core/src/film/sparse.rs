//! Sparse time bins: a row of pixels whose memory follows the bins that received light.
//!
//! A pixel keeps only its non-zero bins, as runs of consecutive bins: each run is a
//! 4-byte header (`gap` empty bins since the end of the previous run, then `len` stored
//! bins) followed, in the row's value array, by one value per stored bin. A lone bin
//! costs its value plus 4 bytes; a run of `L` bins costs `L` values plus 4 bytes. A pass
//! builds the next row by merging the old one with what the pass added ([`merge_pixel`],
//! [`RowBuilder`]), so readers can hold a row (an `Arc`) while the next is made; where
//! no reader holds it and every new bin is stored, the pass adds in place
//! ([`SparseRow::add_in_place`]).

/// A run of stored bins: `gap` bins not stored since the end of the previous run (or
/// since bin 0), then `len` stored bins. Gaps longer than `u16::MAX` are written as runs
/// of length 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Run {
    gap: u16,
    len: u16,
}

/// Where one pixel's runs and values sit in its row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct PixelEntry {
    run_start: u32,
    run_count: u32,
    value_start: u32,
    value_count: u32,
}

/// One image row of sparse TPRFs with values of type `V` (`[f64; 2]` for the two halves
/// of the film, `f64` for a bounce layer, `f32` for a reader's copy).
#[derive(Clone, Debug, Default)]
pub struct SparseRow<V> {
    pixels: Vec<PixelEntry>,
    runs: Vec<Run>,
    values: Vec<V>,
}

/// Bytes one stored bin costs beyond its value at most (its share of a run header).
pub const RUN_HEADER_BYTES: usize = std::mem::size_of::<u32>();

impl<V: Copy> SparseRow<V> {
    /// A row of `width` pixels with nothing stored.
    pub fn empty(width: usize) -> SparseRow<V> {
        SparseRow {
            pixels: vec![PixelEntry::default(); width],
            runs: Vec::new(),
            values: Vec::new(),
        }
    }

    pub fn width(&self) -> usize {
        self.pixels.len()
    }

    /// Bins stored in the whole row.
    pub fn stored_bins(&self) -> usize {
        self.values.len()
    }

    /// Runs in the whole row.
    pub fn runs(&self) -> usize {
        self.runs.len()
    }

    /// Heap bytes the row holds (capacity, not length: what the allocator gave).
    pub fn heap_bytes(&self) -> usize {
        self.pixels.capacity() * std::mem::size_of::<PixelEntry>()
            + self.runs.capacity() * std::mem::size_of::<Run>()
            + self.values.capacity() * std::mem::size_of::<V>()
    }

    /// Every stored value of the row, pixel after pixel.
    pub fn values(&self) -> &[V] {
        &self.values
    }

    /// Bins stored for pixel `x` (0 outside the row).
    pub fn pixel_stored_bins(&self, x: usize) -> usize {
        self.pixels.get(x).map_or(0, |p| p.value_count as usize)
    }

    /// Pixel `x`'s runs in increasing bin order: `(first bin, values)`. Nothing outside
    /// the row.
    pub fn pixel_runs(&self, x: usize) -> PixelRuns<'_, V> {
        let (runs, values) = match self.pixels.get(x) {
            Some(p) => {
                let r = p.run_start as usize..(p.run_start + p.run_count) as usize;
                let v = p.value_start as usize..(p.value_start + p.value_count) as usize;
                (
                    self.runs.get(r).unwrap_or(&[]),
                    self.values.get(v).unwrap_or(&[]),
                )
            }
            None => (&[][..], &[][..]),
        };
        PixelRuns {
            runs,
            values,
            next_bin: 0,
        }
    }

    /// Pixel `x`'s stored values in increasing bin order (empty outside the row).
    pub fn pixel_values(&self, x: usize) -> &[V] {
        self.pixel_parts(x).1
    }

    /// The bin of pixel `x`'s `i`-th stored value (`None` past its last).
    pub fn bin_of_value(&self, x: usize, i: usize) -> Option<usize> {
        let mut before = 0;
        for (start, values) in self.pixel_runs(x) {
            if i < before + values.len() {
                return Some(start + i - before);
            }
            before += values.len();
        }
        None
    }

    /// Pixel `x`'s value in bin `b`, `None` when not stored.
    pub fn get(&self, x: usize, b: usize) -> Option<V> {
        self.get_from(x, b, &mut RunCursor::default())
    }

    /// [`Self::get`] resumed from `cursor`, which it moves past the runs that end at or
    /// before `b`: asking for increasing bins (a time slice played forward) walks each
    /// run once in all, not once a bin. `b` must not be less than a bin asked before
    /// with this cursor (start again from `RunCursor::default()`).
    pub fn get_from(&self, x: usize, b: usize, cursor: &mut RunCursor) -> Option<V> {
        let p = self.pixels.get(x)?;
        let runs = self
            .runs
            .get(p.run_start as usize..(p.run_start + p.run_count) as usize)?;
        let values = self
            .values
            .get(p.value_start as usize..(p.value_start + p.value_count) as usize)?;
        while let Some(run) = runs.get(cursor.run as usize) {
            let start = cursor.end_bin as usize + run.gap as usize;
            if b < start {
                return None;
            }
            let len = run.len as usize;
            if b < start + len {
                return values.get(cursor.value as usize + b - start).copied();
            }
            cursor.run += 1;
            cursor.end_bin = (start + len) as u32;
            cursor.value += len as u32;
        }
        None
    }

    /// Pixel `x`'s first and last stored bins, `None` when nothing is stored.
    pub fn pixel_span(&self, x: usize) -> Option<(usize, usize)> {
        let mut span: Option<(usize, usize)> = None;
        for (start, values) in self.pixel_runs(x) {
            if values.is_empty() {
                continue;
            }
            let end = start + values.len() - 1;
            span = Some(span.map_or((start, end), |(s, _)| (s, end)));
        }
        span
    }
}

impl<V: Copy> SparseRow<V> {
    /// Pixel `x`'s runs and values (empty outside the row).
    fn pixel_parts(&self, x: usize) -> (&[Run], &[V], usize) {
        let Some(p) = self.pixels.get(x) else {
            return (&[], &[], 0);
        };
        let r = p.run_start as usize..(p.run_start + p.run_count) as usize;
        let v = p.value_start as usize..(p.value_start + p.value_count) as usize;
        (
            self.runs.get(r).unwrap_or(&[]),
            self.values.get(v).unwrap_or(&[]),
            p.value_start as usize,
        )
    }

    /// Add a pass's new bins in place where every one of them is stored already: `new`
    /// holds each pixel's bins in increasing order, pixel `x`'s ending at `new_end[x]`;
    /// a stored value `v` becomes `combine(v, n)`. Returns `false`, changing nothing,
    /// where a new bin is not stored (the row must then be rebuilt, see
    /// [`merge_pixel`]). `pos` is scratch.
    pub fn add_in_place<N: Copy>(
        &mut self,
        new: &[(u32, N)],
        new_end: &[usize],
        pos: &mut Vec<u32>,
        mut combine: impl FnMut(V, N) -> V,
    ) -> bool {
        pos.clear();
        if new_end.last().copied().unwrap_or(0) != new.len() || new_end.len() > self.width() {
            return false;
        }
        let mut start = 0;
        for (x, &end) in new_end.iter().enumerate() {
            let Some(bins) = new.get(start..end) else {
                return false;
            };
            start = end;
            let (runs, _, first) = self.pixel_parts(x);
            let mut stored = true;
            locate(runs, bins, |i, _| match i {
                Some(i) => pos.push((first + i) as u32),
                None => stored = false,
            });
            if !stored {
                return false;
            }
        }
        for (&p, &(_, n)) in pos.iter().zip(new) {
            if let Some(v) = self.values.get_mut(p as usize) {
                *v = combine(*v, n);
            }
        }
        true
    }
}

/// Walk one pixel's `runs` with the bins of `new` in increasing order: `at(Some(i), n)`
/// for a bin stored as the pixel's `i`-th value, `at(None, n)` for a bin not stored.
#[inline]
fn locate<N: Copy>(runs: &[Run], new: &[(u32, N)], mut at: impl FnMut(Option<usize>, N)) {
    let mut runs = runs.iter();
    // The run at hand: bins [run_start, run_end), the first one's value index (both
    // ends past every bin once the runs are used up).
    let (mut run_start, mut run_end, mut value) = (0, 0, 0);
    for &(b, n) in new {
        let b = b as usize;
        while b >= run_end {
            value += run_end - run_start;
            (run_start, run_end) = match runs.next() {
                Some(r) => {
                    let start = run_end + r.gap as usize;
                    (start, start + r.len as usize)
                }
                None => (usize::MAX, usize::MAX),
            };
        }
        at((b >= run_start).then(|| value + b - run_start), n);
    }
}

/// Where [`SparseRow::get_from`] got to in one pixel's runs: the runs passed, the bin
/// after the last of them, and the values they hold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunCursor {
    run: u32,
    end_bin: u32,
    value: u32,
}

/// Runs of one pixel, see [`SparseRow::pixel_runs`].
pub struct PixelRuns<'a, V> {
    runs: &'a [Run],
    values: &'a [V],
    next_bin: usize,
}

impl<'a, V> Iterator for PixelRuns<'a, V> {
    type Item = (usize, &'a [V]);

    fn next(&mut self) -> Option<(usize, &'a [V])> {
        loop {
            let (run, rest) = self.runs.split_first()?;
            self.runs = rest;
            let start = self.next_bin + run.gap as usize;
            let len = run.len as usize;
            self.next_bin = start + len;
            if len == 0 {
                continue; // a long gap's filler
            }
            let (values, rest) = self.values.split_at_checked(len)?;
            self.values = rest;
            return Some((start, values));
        }
    }
}

/// Builds the next version of a row pixel by pixel, in order: for each pixel call
/// [`RowBuilder::push`] with increasing bins, then [`RowBuilder::end_pixel`].
pub struct RowBuilder<V> {
    row: SparseRow<V>,
    pixel: PixelEntry,
    /// End (one past the last bin) of the current pixel's last run.
    end_bin: usize,
    x: usize,
}

impl<V: Copy> Default for RowBuilder<V> {
    fn default() -> Self {
        RowBuilder::with_capacity(0, 0, 0)
    }
}

impl<V: Copy> RowBuilder<V> {
    /// The row built so far as a new row with no spare capacity; the builder is emptied
    /// and keeps its buffers for the next row (a pass reuses one builder per task).
    pub fn take_exact(&mut self, width: usize) -> SparseRow<V> {
        while self.row.pixels.len() < width {
            self.end_pixel();
        }
        let row = SparseRow {
            pixels: self.row.pixels[..width].to_vec(),
            runs: self.row.runs.to_vec(),
            values: self.row.values.to_vec(),
        };
        self.row.pixels.clear();
        self.row.runs.clear();
        self.row.values.clear();
        self.pixel = PixelEntry::default();
        self.end_bin = 0;
        self.x = 0;
        row
    }

    /// A builder for a row of `width` pixels expecting about `runs` runs and `values`
    /// values (the old row's counts plus the pass's new bins: the vectors are then
    /// allocated once, with no spare capacity).
    pub fn with_capacity(width: usize, runs: usize, values: usize) -> RowBuilder<V> {
        RowBuilder {
            row: SparseRow {
                pixels: Vec::with_capacity(width),
                runs: Vec::with_capacity(runs),
                values: Vec::with_capacity(values),
            },
            pixel: PixelEntry::default(),
            end_bin: 0,
            x: 0,
        }
    }

    /// Store `value` in bin `b` of the current pixel; bins must increase within a pixel.
    #[inline]
    pub fn push(&mut self, b: usize, value: V) {
        debug_assert!(b >= self.end_bin || self.pixel.value_count == 0);
        let extend = self.pixel.run_count > 0
            && b == self.end_bin
            && self.row.runs.last().is_some_and(|r| r.len < u16::MAX);
        if extend {
            if let Some(r) = self.row.runs.last_mut() {
                r.len += 1;
            }
        } else {
            self.open_run(b, 1);
        }
        self.row.values.push(value);
        self.pixel.value_count += 1;
        self.end_bin = b + 1;
    }

    /// Append the stored run `values` from bin `start` (after every bin pushed so far
    /// in this pixel) to the current pixel, joined to its last run where it follows on;
    /// returns the index of the run's first value in the row's values.
    fn push_run(&mut self, start: usize, values: &[V]) -> usize {
        let v0 = self.row.values.len();
        let n = values.len();
        if n == 0 {
            return v0;
        }
        debug_assert!(start >= self.end_bin || self.pixel.value_count == 0);
        let extend = self.pixel.run_count > 0
            && start == self.end_bin
            && self
                .row
                .runs
                .last()
                .is_some_and(|r| r.len as usize + n <= u16::MAX as usize);
        if extend {
            if let Some(r) = self.row.runs.last_mut() {
                r.len += n as u16;
            }
        } else {
            // A stored run is at most u16::MAX long. (`push` is not written as a run of
            // one: that measured 3 % slower on the engine bench's render.)
            self.open_run(start, n.min(u16::MAX as usize) as u16);
        }
        self.row.values.extend_from_slice(values);
        self.pixel.value_count += n as u32;
        self.end_bin = start + n;
        v0
    }

    /// Start a run of `len` bins at bin `start` of the current pixel (after every bin
    /// pushed so far): its gap from the pixel's last stored bin, gaps longer than
    /// `u16::MAX` written as runs of length 0 first.
    #[inline(always)]
    fn open_run(&mut self, start: usize, len: u16) {
        let mut gap = start.saturating_sub(self.end_bin);
        while gap > u16::MAX as usize {
            self.row.runs.push(Run {
                gap: u16::MAX,
                len: 0,
            });
            self.pixel.run_count += 1;
            gap -= u16::MAX as usize;
        }
        self.row.runs.push(Run {
            gap: gap as u16,
            len,
        });
        self.pixel.run_count += 1;
    }

    /// Close the current pixel and start the next.
    pub fn end_pixel(&mut self) {
        self.row.pixels.push(self.pixel);
        self.x += 1;
        self.pixel = PixelEntry {
            run_start: self.row.runs.len() as u32,
            run_count: 0,
            value_start: self.row.values.len() as u32,
            value_count: 0,
        };
        self.end_bin = 0;
    }

    /// The finished row (pixels not ended are left empty). Capacity asked for beyond
    /// an eighth of what was used is given back.
    pub fn finish(mut self, width: usize) -> SparseRow<V> {
        while self.row.pixels.len() < width {
            self.end_pixel();
        }
        self.row.pixels.truncate(width);
        if self.row.runs.capacity() > self.row.runs.len() + self.row.runs.len() / 8 {
            self.row.runs.shrink_to_fit();
        }
        if self.row.values.capacity() > self.row.values.len() + self.row.values.len() / 8 {
            self.row.values.shrink_to_fit();
        }
        self.row
    }
}

/// Merge pixel `x` of `old` with `new` (bins in increasing order, each once) into `out`:
/// a bin in both gets `combine(old, new)`, a bin only in `new` gets `fresh(new)`. Each
/// stored run is copied whole, then the new bins inside it are combined in place.
pub fn merge_pixel<V: Copy, N: Copy>(
    old: &SparseRow<V>,
    x: usize,
    new: &[(u32, N)],
    out: &mut RowBuilder<V>,
    mut combine: impl FnMut(V, N) -> V,
    mut fresh: impl FnMut(N) -> V,
) {
    let mut new = new.iter().peekable();
    for (start, values) in old.pixel_runs(x) {
        while let Some(&&(nb, nv)) = new.peek() {
            if nb as usize >= start {
                break;
            }
            out.push(nb as usize, fresh(nv));
            new.next();
        }
        let end = start + values.len();
        let v0 = out.push_run(start, values);
        while let Some(&&(nb, nv)) = new.peek() {
            let nb = nb as usize;
            if nb >= end {
                break;
            }
            if let Some(v) = out.row.values.get_mut(v0 + nb - start) {
                *v = combine(*v, nv);
            }
            new.next();
        }
    }
    for &(nb, nv) in new {
        out.push(nb as usize, fresh(nv));
    }
    out.end_pixel();
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Build a row from dense pixels (zero = not stored).
    fn from_dense(pixels: &[Vec<f64>]) -> SparseRow<f64> {
        let mut b = RowBuilder::with_capacity(pixels.len(), 0, 0);
        for p in pixels {
            for (bin, v) in p.iter().enumerate() {
                if *v != 0.0 {
                    b.push(bin, *v);
                }
            }
            b.end_pixel();
        }
        b.finish(pixels.len())
    }

    fn to_dense(row: &SparseRow<f64>, x: usize, bins: usize) -> Vec<f64> {
        let mut out = vec![0.0; bins];
        for (start, values) in row.pixel_runs(x) {
            out[start..start + values.len()].copy_from_slice(values);
        }
        out
    }

    #[test]
    fn runs_by_hand() {
        let row = from_dense(&[
            vec![0.0, 1.0, 2.0, 0.0, 0.0, 3.0],
            vec![0.0; 6],
            vec![4.0, 0.0, 0.0, 0.0, 0.0, 5.0],
        ]);
        // Pixel 0: runs (gap 1, len 2) and (gap 2, len 1); pixel 2: (0, 1), (4, 1).
        assert_eq!(row.runs(), 4);
        assert_eq!(row.stored_bins(), 5);
        let runs: Vec<(usize, Vec<f64>)> =
            row.pixel_runs(0).map(|(s, v)| (s, v.to_vec())).collect();
        assert_eq!(runs, vec![(1, vec![1.0, 2.0]), (5, vec![3.0])]);
        assert_eq!(row.pixel_runs(1).count(), 0);
        assert_eq!(row.pixel_span(0), Some((1, 5)));
        assert_eq!(row.pixel_span(1), None);
        assert_eq!(row.pixel_span(2), Some((0, 5)));
        assert_eq!(row.get(0, 2), Some(2.0));
        assert_eq!(row.get(0, 3), None);
        assert_eq!(row.get(2, 5), Some(5.0));
        assert_eq!(row.get(9, 0), None);
        assert_eq!(row.pixel_runs(7).count(), 0);
    }

    #[test]
    fn gaps_longer_than_a_header_holds() {
        let bins = 200_000;
        let mut p = vec![0.0; bins];
        p[3] = 1.0;
        p[150_000] = 2.0;
        p[bins - 1] = 3.0;
        let row = from_dense(std::slice::from_ref(&p));
        assert_eq!(to_dense(&row, 0, bins), p);
        assert_eq!(row.pixel_span(0), Some((3, bins - 1)));
    }

    /// Adding in place gives what the dense addition gives where every new bin is
    /// stored, and refuses, changing nothing, where one is not.
    #[test]
    fn adding_in_place_equals_dense_addition() {
        let (width, bins) = (4, 300);
        let mut dense = vec![vec![0.0f64; bins]; width];
        // Pixel x stores bins x, x + 7, x + 14, ... (runs of one, gaps of six).
        for (x, d) in dense.iter_mut().enumerate() {
            for b in (x..bins).step_by(7) {
                d[b] = (b + 1) as f64;
            }
        }
        let mut row = from_dense(&dense);
        let runs = row.runs();
        let mut pos = Vec::new();
        // New bins in stored places (pixel 1 gets none): added in place.
        let new: Vec<(u32, f64)> = vec![(0, 0.5), (70, 1.5), (2, 2.5), (9, 3.5), (297, 4.5)];
        let new_end = [2, 2, 4, 5];
        assert!(row.add_in_place(&new, &new_end, &mut pos, |o, n| o + n));
        for (x, b, v) in [
            (0, 0, 0.5),
            (0, 70, 1.5),
            (2, 2, 2.5),
            (2, 9, 3.5),
            (3, 297, 4.5),
        ] {
            dense[x][b] += v;
        }
        for (x, d) in dense.iter().enumerate() {
            assert_eq!(&to_dense(&row, x, bins), d);
        }
        assert_eq!(row.runs(), runs);
        // One bin not stored (pixel 2's bin 3, between its runs): refused, unchanged.
        let before = row.clone();
        let new = vec![(7, 1.0), (2, 1.0), (3, 1.0)];
        assert!(!row.add_in_place(&new, &[1, 1, 3, 3], &mut pos, |o, n| o + n));
        // Past the last run, and before the first.
        assert!(!row.add_in_place(&[(299, 1.0)], &[0, 0, 0, 1], &mut pos, |o, n| o + n));
        assert!(!row.add_in_place(&[(0, 1.0)], &[0, 0, 0, 1], &mut pos, |o, n| o + n));
        // Ends that do not match the bins.
        assert!(!row.add_in_place(&[(7, 1.0)], &[0, 0, 0, 0], &mut pos, |o, n| o + n));
        for x in 0..width {
            assert_eq!(to_dense(&row, x, bins), to_dense(&before, x, bins));
        }
    }

    #[test]
    fn merging_equals_dense_addition() {
        // A small deterministic generator: no dependence on the code under test.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let (width, bins) = (5, 300);
        let mut dense = vec![vec![0.0f64; bins]; width];
        let mut row = SparseRow::<f64>::empty(width);
        for _pass in 0..20 {
            let news: Vec<Vec<(u32, f64)>> = (0..width)
                .map(|_| {
                    let mut new: Vec<(u32, f64)> = (0..(next() % 40))
                        .map(|_| ((next() % bins as u64) as u32, (next() % 1000) as f64 + 1.0))
                        .collect();
                    new.sort_by_key(|e| e.0);
                    new.dedup_by_key(|e| e.0);
                    new
                })
                .collect();
            let added: usize = news.iter().map(Vec::len).sum();
            // The bins merging adds: those not yet non-zero in the dense copy.
            let unstored = news
                .iter()
                .zip(&dense)
                .map(|(new, d)| new.iter().filter(|e| d[e.0 as usize] == 0.0).count())
                .sum::<usize>();
            let stored_before = row.stored_bins();
            let mut b =
                RowBuilder::with_capacity(width, row.runs() + added, row.stored_bins() + added);
            for (x, (d, new)) in dense.iter_mut().zip(&news).enumerate() {
                for &(nb, nv) in new {
                    d[nb as usize] += nv;
                }
                merge_pixel(&row, x, new, &mut b, |o, n| o + n, |n| n);
            }
            row = b.finish(width);
            assert_eq!(row.stored_bins(), stored_before + unstored);
            for (x, d) in dense.iter().enumerate() {
                assert_eq!(&to_dense(&row, x, bins), d);
                assert_eq!(
                    row.pixel_stored_bins(x),
                    d.iter().filter(|v| **v != 0.0).count()
                );
            }
        }
        // Memory: each stored bin costs its value plus at most one 4-byte header.
        let stored = row.stored_bins();
        assert!(row.runs() <= stored);
        assert!(
            row.heap_bytes()
                <= (stored * (8 + RUN_HEADER_BYTES)) * 9 / 8
                    + width * std::mem::size_of::<PixelEntry>()
        );
    }
}

//! A read-only copy of the film's current estimate (f32 means), handed to readers on
//! other threads (the viewer, the sensor) while the renderer keeps adding samples.

use super::{FilmLayout, TimeAxis};

/// The film's mean values at one moment.
#[derive(Clone, Debug)]
pub struct FilmSnapshot {
    pub layout: FilmLayout,
    pub spp: u64,
    pub passes: u64,
    /// `[H, W, T]`, row 0 = top: bin integrals of radiance (DESIGN.md).
    pub cube: Vec<f32>,
    /// `[L, H, W, T]` per-bounce layers (empty when not recorded).
    pub bounces: Vec<f32>,
    /// Relative RMS error estimated from the two half-sample buffers.
    pub error_estimate: Option<f64>,
    /// Per-snapshot summaries, computed once by whoever makes the snapshot (the render
    /// thread) so readers drawing every frame never scan the cube.
    steady: Vec<f32>,
    peak_bin: Vec<Option<u32>>,
    robust_max: Option<f64>,
    /// See [`FilmSnapshot::generation`].
    generation: u64,
}

/// The next [`FilmSnapshot::generation`]; 0 is never handed out.
static NEXT_GENERATION: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

/// At most this many values are looked at for [`FilmSnapshot::robust_max`].
const ROBUST_MAX_SAMPLES: usize = 1 << 20;

impl FilmSnapshot {
    /// A snapshot of `cube` (`[H, W, T]`) and `bounces` (`[L, H, W, T]` or empty); computes
    /// the steady image, the peak bins and the robust maximum in parallel.
    pub fn new(
        layout: FilmLayout,
        spp: u64,
        passes: u64,
        cube: Vec<f32>,
        bounces: Vec<f32>,
        error_estimate: Option<f64>,
    ) -> FilmSnapshot {
        use rayon::prelude::*;
        let t = layout.axis.bins.max(1);
        let (steady, peak_bin): (Vec<f32>, Vec<Option<u32>>) = cube
            .par_chunks(t)
            .map(|p| {
                let mut best: Option<(u32, f32)> = None;
                let mut sum = 0.0f64;
                for (b, &v) in p.iter().enumerate() {
                    sum += v as f64;
                    if v > 0.0 && best.is_none_or(|(_, m)| v > m) {
                        best = Some((b as u32, v));
                    }
                }
                (sum as f32, best.map(|(b, _)| b))
            })
            .unzip();
        let robust_max = robust_max(&cube);
        FilmSnapshot {
            layout,
            spp,
            passes,
            cube,
            bounces,
            error_estimate,
            steady,
            peak_bin,
            robust_max,
            generation: NEXT_GENERATION.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        }
    }

    /// A number no other snapshot made by this process has (clones share it): what
    /// readers key caches on. An address (`Arc::as_ptr`) is not an identity: once a
    /// snapshot is freed the allocator may hand the same address to the next one.
    pub fn generation(&self) -> u64 {
        self.generation
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

    /// Number of per-bounce layers (0 when not recorded).
    pub fn layers(&self) -> usize {
        let per = self.cube.len();
        self.bounces.len().checked_div(per).unwrap_or(0)
    }

    /// The TPRF of pixel `(x, y)`, or an empty slice outside the image.
    pub fn pixel(&self, x: usize, y: usize) -> &[f32] {
        let (w, h, t) = (self.layout.width, self.layout.height, self.layout.axis.bins);
        if x >= w || y >= h {
            return &[];
        }
        let i = (y * w + x) * t;
        self.cube.get(i..i + t).unwrap_or(&[])
    }

    /// Layer `l` of pixel `(x, y)`'s per-bounce TPRFs, or an empty slice.
    pub fn pixel_layer(&self, l: usize, x: usize, y: usize) -> &[f32] {
        let (w, h, t) = (self.layout.width, self.layout.height, self.layout.axis.bins);
        if x >= w || y >= h || l >= self.layers() {
            return &[];
        }
        let i = ((l * h + y) * w + x) * t;
        self.bounces.get(i..i + t).unwrap_or(&[])
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
                    for (o, v) in out.iter_mut().zip(p) {
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

    /// Time slice of bin `b`: `[H * W]`.
    pub fn slice(&self, b: usize) -> Vec<f32> {
        let t = self.layout.axis.bins;
        if b >= t {
            return vec![0.0; self.layout.pixels()];
        }
        // A strided gather, one cache line per pixel: spread over the threads.
        use rayon::prelude::*;
        self.cube
            .par_chunks_exact(t)
            .with_min_len(4096)
            .map(|p| p[b])
            .collect()
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
    quantile(values.filter(|x| *x > 0.0).map(f64::from), q)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summaries_by_hand() {
        let axis = TimeAxis::new(0.0, 1e-9, 3).unwrap();
        let layout = FilmLayout {
            width: 2,
            height: 1,
            axis,
            bounces_separate: 0,
        };
        // Pixel 0: 1, 3, 2 (peak bin 1, sum 6); pixel 1 dark.
        let snap = FilmSnapshot::new(
            layout,
            4,
            1,
            vec![1.0, 3.0, 2.0, 0.0, 0.0, 0.0],
            Vec::new(),
            None,
        );
        assert_eq!(snap.steady(), &[6.0, 0.0]);
        assert_eq!(snap.peak_bins(), &[Some(1), None]);
        assert_eq!(snap.robust_max(), Some(3.0));
        assert_eq!(snap.slice(2), vec![2.0, 0.0]);
        assert_eq!(snap.slice(7), vec![0.0, 0.0]);
        assert_eq!(snap.layers(), 0);
        assert_eq!(snap.box_mean(0, 0, 1, 0, None), vec![0.5, 1.5, 1.0]);
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
}

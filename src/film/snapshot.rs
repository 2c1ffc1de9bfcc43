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
}

impl FilmSnapshot {
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
        self.cube.chunks_exact(t).map(|p| p[b]).collect()
    }

    /// Steady-state image (sum over bins): `[H * W]`.
    pub fn steady(&self) -> Vec<f32> {
        let t = self.layout.axis.bins;
        self.cube
            .chunks_exact(t)
            .map(|p| p.iter().map(|&v| v as f64).sum::<f64>() as f32)
            .collect()
    }

    /// Per pixel the bin of the TPRF's peak and the pixel's total energy (the "rainbow"
    /// view: colour = arrival time of the peak, brightness = energy). Bin is `None` for a
    /// dark pixel.
    pub fn peaks(&self) -> Vec<(Option<usize>, f32)> {
        let t = self.layout.axis.bins;
        self.cube
            .chunks_exact(t)
            .map(|p| {
                let mut best: Option<(usize, f32)> = None;
                let mut sum = 0.0f64;
                for (b, &v) in p.iter().enumerate() {
                    sum += v as f64;
                    if v > 0.0 && best.is_none_or(|(_, m)| v > m) {
                        best = Some((b, v));
                    }
                }
                (best.map(|(b, _)| b), sum as f32)
            })
            .collect()
    }
}

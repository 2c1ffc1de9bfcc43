//! `M_i = sum_b TPRF[b] K_i[b]` for every pixel: a `[pixels x T] x [T x N]` product
//! that reads only the bins where each kernel is non-zero, in parallel over image rows.
//! The cube is a plain `&[f32]` in `[H, W, T]` layout (a `tprf.npy` or a viewer's live
//! film snapshot); the result is `[N, H, W]`.

use rayon::prelude::*;

use super::SensorError;
use super::kernel::SparseKernel;

/// The kernels in one f32 buffer, with each one's span of bins.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PackedKernels {
    bins: usize,
    spans: Vec<Span>,
    weights: Vec<f32>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Span {
    first: usize,
    len: usize,
    offset: usize,
}

impl PackedKernels {
    /// Packs `kernels` for a cube of `bins` bins (bins past the end are dropped). Each
    /// span is padded with zero weights to a multiple of the dot product's lane count
    /// (within the cube), so that no scalar tail is left.
    pub fn new(kernels: &[SparseKernel], bins: usize) -> PackedKernels {
        let mut spans = Vec::with_capacity(kernels.len());
        let mut weights = Vec::new();
        for k in kernels {
            let first = k.first_bin.min(bins);
            let len = k.weights.len().min(bins - first);
            if len == 0 {
                spans.push(Span {
                    first: 0,
                    len: 0,
                    offset: weights.len(),
                });
                continue;
            }
            let padded = len.div_ceil(LANES).saturating_mul(LANES).min(bins);
            let start = first.min(bins - padded);
            let offset = weights.len();
            weights.resize(offset + padded, 0.0);
            for (slot, &w) in weights[offset + first - start..]
                .iter_mut()
                .zip(&k.weights[..len])
            {
                *slot = w as f32;
            }
            spans.push(Span {
                first: start,
                len: padded,
                offset,
            });
        }
        PackedKernels {
            bins,
            spans,
            weights,
        }
    }

    /// The number of gates `N`.
    pub fn gates(&self) -> usize {
        self.spans.len()
    }

    /// The number of bins `T` of the cubes they apply to.
    pub fn bins(&self) -> usize {
        self.bins
    }

    /// Bins read per pixel, summed over the gates (the work per pixel; spans padded to
    /// whole lanes).
    pub fn reads_per_pixel(&self) -> usize {
        self.spans.iter().map(|s| s.len).sum()
    }
}

/// Measurements `[N, H, W]`, row 0 = top, in the unit of a cube bin.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Measurements {
    pub gates: usize,
    pub height: usize,
    pub width: usize,
    pub values: Vec<f32>,
}

impl Measurements {
    /// The image of gate `i`, `[H, W]` (empty if there is no gate `i`).
    pub fn plane(&self, i: usize) -> &[f32] {
        let n = self.height * self.width;
        self.values.get(i * n..(i + 1) * n).unwrap_or(&[])
    }

    /// `M_i` for `i = 0..N` at pixel `(y, x)` (empty outside the image).
    pub fn pixel(&self, y: usize, x: usize) -> Vec<f32> {
        if y >= self.height || x >= self.width {
            return vec![];
        }
        let n = self.height * self.width;
        (0..self.gates)
            .map(|i| self.values[i * n + y * self.width + x])
            .collect()
    }
}

/// Independent accumulators of [`dot`].
const LANES: usize = 16;

/// `sum_k a[k] b[k]` in 16 independent f32 lanes (vectorised; relative error ~1e-7 for
/// the kernel lengths used).
#[inline]
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0f32; LANES];
    let (ca, cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f32 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for ((s, x), y) in acc.iter_mut().zip(x).zip(y) {
            *s += x * y;
        }
    }
    acc.iter().sum::<f32>() + tail
}

/// `M_i = sum_b cube[y, x, b] K_i[b]` for every pixel and gate: the integral term of
/// the sensor model, before noise and `max(0, .)`. `cube` is `[height, width, T]`.
pub fn measure_clean(
    kernels: &PackedKernels,
    cube: &[f32],
    width: usize,
    height: usize,
) -> Result<Measurements, SensorError> {
    let bins = kernels.bins;
    let expected = height
        .checked_mul(width)
        .and_then(|p| p.checked_mul(bins))
        .unwrap_or(usize::MAX);
    if cube.len() != expected {
        return Err(SensorError::CubeSize {
            got: cube.len(),
            height,
            width,
            bins,
            expected,
        });
    }
    let gates = kernels.gates();
    let pixels = width * height;
    let mut values = vec![0f32; gates * pixels];
    if pixels == 0 || gates == 0 || bins == 0 {
        return Ok(Measurements {
            gates,
            height,
            width,
            values,
        });
    }
    // Row y of every gate's plane, so that one task writes one image row of all gates.
    let mut rows: Vec<Vec<&mut [f32]>> = (0..height).map(|_| Vec::with_capacity(gates)).collect();
    for plane in values.chunks_mut(pixels) {
        for (out, row) in rows.iter_mut().zip(plane.chunks_mut(width)) {
            out.push(row);
        }
    }
    rows.into_par_iter()
        .zip(cube.par_chunks(width * bins))
        .for_each(|(mut out, cube_row)| {
            for (x, tprf) in cube_row.chunks_exact(bins).enumerate() {
                for (row, s) in out.iter_mut().zip(&kernels.spans) {
                    let w = &kernels.weights[s.offset..s.offset + s.len];
                    row[x] = dot(&tprf[s.first..s.first + s.len], w);
                }
            }
        });
    Ok(Measurements {
        gates,
        height,
        width,
        values,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dot_matches_f64() {
        let a: Vec<f32> = (0..1000).map(|k| (k as f32 * 0.37).sin().abs()).collect();
        let b: Vec<f32> = (0..1000).map(|k| (k as f32 * 0.11).cos().abs()).collect();
        for len in [0, 1, 15, 16, 17, 999, 1000] {
            let want: f64 = a[..len]
                .iter()
                .zip(&b[..len])
                .map(|(&x, &y)| f64::from(x) * f64::from(y))
                .sum();
            let got = f64::from(dot(&a[..len], &b[..len]));
            assert!((got - want).abs() <= 1e-5 * want.max(1e-30), "{len}");
        }
    }

    #[test]
    fn wrong_cube_size_is_an_error() {
        let k = PackedKernels::new(&[SparseKernel::default()], 8);
        assert!(measure_clean(&k, &[0.0; 10], 2, 2).is_err());
        let Ok(m) = measure_clean(&k, &[1.0; 32], 2, 2) else {
            panic!("valid size");
        };
        assert_eq!(m.values, vec![0.0; 4]);
    }
}

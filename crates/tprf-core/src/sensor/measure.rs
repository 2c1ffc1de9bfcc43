//! `M_i = sum_b TPRF[b] K_i[b]` for every pixel: a `[pixels x T] x [T x N]` product
//! that reads only the bins where each kernel is non-zero, in parallel over image rows.
//! The cube is a plain `&[f32]` in `[H, W, T]` layout (a `tprf.npy` or a viewer's live
//! film snapshot); the result is `[N, H, W]`.

use rayon::prelude::*;

use super::SensorError;
use super::kernel::SparseKernel;
use crate::film::FilmSnapshot;

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
/// the kernel lengths used): lane `l` sums the products `k = l (mod 16)` of the whole
/// chunks in order, then the lanes are added in order, then the tail.
#[inline(always)]
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let (ca, ta) = a.as_chunks::<LANES>();
    let (cb, tb) = b.as_chunks::<LANES>();
    let mut acc = [0f32; LANES];
    for (x, y) in ca.iter().zip(cb) {
        for l in 0..LANES {
            acc[l] += x[l] * y[l];
        }
    }
    finish(&acc, ta, tb)
}

/// The lanes added in order, then the tail products.
#[inline(always)]
fn finish(acc: &[f32; LANES], ta: &[f32], tb: &[f32]) -> f32 {
    acc.iter().sum::<f32>() + ta.iter().zip(tb).map(|(x, y)| x * y).sum::<f32>()
}

/// Pixels measured together: the kernel weights are loaded once for all of them.
const BLOCK: usize = 4;

/// [`dot`] of four rows with the same weights, each with exactly [`dot`]'s arithmetic
/// (so a pixel's result does not depend on its neighbours).
#[inline(always)]
fn dot_block(rows: [&[f32]; BLOCK], w: &[f32]) -> [f32; BLOCK] {
    let (cw, tw) = w.as_chunks::<LANES>();
    let [(c0, t0), (c1, t1), (c2, t2), (c3, t3)] = rows.map(|r| r.as_chunks::<LANES>());
    let mut acc = [[0f32; LANES]; BLOCK];
    for (((y, x0), x1), (x2, x3)) in cw.iter().zip(c0).zip(c1).zip(c2.iter().zip(c3)) {
        for l in 0..LANES {
            acc[0][l] += x0[l] * y[l];
            acc[1][l] += x1[l] * y[l];
            acc[2][l] += x2[l] * y[l];
            acc[3][l] += x3[l] * y[l];
        }
    }
    [
        finish(&acc[0], t0, tw),
        finish(&acc[1], t1, tw),
        finish(&acc[2], t2, tw),
        finish(&acc[3], t3, tw),
    ]
}

/// One image row: `out[i][x] = dot(cube_row[x], K_i)`, `BLOCK` pixels at a time.
#[inline(always)]
fn measure_row(kernels: &PackedKernels, cube_row: &[f32], out: &mut [&mut [f32]]) {
    let bins = kernels.bins;
    let blocks = cube_row.chunks_exact(bins * BLOCK);
    let rest = blocks.remainder();
    for (bx, block) in blocks.enumerate() {
        let x0 = bx * BLOCK;
        // Gates that read nothing keep their zeros.
        for (row, s) in out
            .iter_mut()
            .zip(&kernels.spans)
            .filter(|(_, s)| s.len > 0)
        {
            let w = &kernels.weights[s.offset..s.offset + s.len];
            let px: [&[f32]; BLOCK] = std::array::from_fn(|p| {
                let start = p * bins + s.first;
                &block[start..start + s.len]
            });
            row[x0..x0 + BLOCK].copy_from_slice(&dot_block(px, w));
        }
    }
    let x0 = (cube_row.len() - rest.len()) / bins;
    for (x, tprf) in rest.chunks_exact(bins).enumerate() {
        for (row, s) in out
            .iter_mut()
            .zip(&kernels.spans)
            .filter(|(_, s)| s.len > 0)
        {
            let w = &kernels.weights[s.offset..s.offset + s.len];
            row[x0 + x] = dot(&tprf[s.first..s.first + s.len], w);
        }
    }
}

/// [`measure_row`] compiled for AVX: the same operations in the same order (no fused
/// multiply-add), so the result is bit-identical, on 8-wide registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn measure_row_avx(kernels: &PackedKernels, cube_row: &[f32], out: &mut [&mut [f32]]) {
    measure_row(kernels, cube_row, out);
}

fn avx_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
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
    let avx = avx_available();
    rows.into_par_iter()
        .zip(cube.par_chunks(width * bins))
        .for_each(|(mut out, cube_row)| {
            if avx {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: the CPU supports AVX (`avx_available`).
                unsafe {
                    measure_row_avx(kernels, cube_row, &mut out)
                };
            } else {
                measure_row(kernels, cube_row, &mut out);
            }
        });
    Ok(Measurements {
        gates,
        height,
        width,
        values,
    })
}

/// [`measure_clean`] of a film snapshot, reading only its stored runs of bins: for each
/// pixel, each run, each gate whose kernel overlaps the run, the dot product over the
/// overlap. The cost follows the bins that received light, not the cube.
pub fn measure_clean_film(kernels: &PackedKernels, snap: &FilmSnapshot) -> Measurements {
    let (width, height) = (snap.width(), snap.height());
    let gates = kernels.gates();
    let pixels = width * height;
    let mut values = vec![0f32; gates * pixels];
    if pixels == 0 || gates == 0 || kernels.bins == 0 || snap.axis().bins != kernels.bins {
        return Measurements {
            gates,
            height,
            width,
            values,
        };
    }
    let mut rows: Vec<Vec<&mut [f32]>> = (0..height).map(|_| Vec::with_capacity(gates)).collect();
    for plane in values.chunks_mut(pixels) {
        for (out, row) in rows.iter_mut().zip(plane.chunks_mut(width)) {
            out.push(row);
        }
    }
    let live: Vec<(usize, &Span)> = kernels
        .spans
        .iter()
        .enumerate()
        .filter(|(_, s)| s.len > 0)
        .collect();
    rows.into_par_iter().enumerate().for_each(|(y, mut out)| {
        for x in 0..width {
            snap.for_each_run(x, y, |start, run| {
                let end = start + run.len();
                for &(i, s) in &live {
                    let lo = start.max(s.first);
                    let hi = end.min(s.first + s.len);
                    if lo >= hi {
                        continue;
                    }
                    let w = &kernels.weights[s.offset + lo - s.first..s.offset + hi - s.first];
                    if let Some(o) = out.get_mut(i).and_then(|r| r.get_mut(x)) {
                        *o += dot(&run[lo - start..hi - start], w);
                    }
                }
            });
        }
    });
    Measurements {
        gates,
        height,
        width,
        values,
    }
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
    fn blocked_pixels_match_single_dots_exactly() {
        let bins = 100;
        let kernels = [
            SparseKernel {
                first_bin: 3,
                weights: (0..37).map(|k| 0.1 + k as f64 * 0.01).collect(),
            },
            SparseKernel {
                first_bin: 90,
                weights: vec![0.5; 10],
            },
            SparseKernel::default(),
        ];
        let packed = PackedKernels::new(&kernels, bins);
        let (w, h) = (7, 2);
        let cube: Vec<f32> = (0..w * h * bins)
            .map(|k| ((k * 7919) % 1000) as f32 * 1e-3)
            .collect();
        let Ok(m) = measure_clean(&packed, &cube, w, h) else {
            panic!("valid size");
        };
        for (i, s) in packed.spans.iter().enumerate() {
            let wts = &packed.weights[s.offset..s.offset + s.len];
            for px in 0..w * h {
                let tprf = &cube[px * bins..(px + 1) * bins];
                let want = dot(&tprf[s.first..s.first + s.len], wts);
                assert_eq!(m.values[i * w * h + px], want, "gate {i}, pixel {px}");
            }
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

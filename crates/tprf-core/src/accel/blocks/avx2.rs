//! The blocks' two tests in AVX2 and FMA intrinsics: the same IEEE operations as the
//! portable [`intersect_block`](super::intersect_block) and
//! [`enter_blocks`](super::enter_blocks), fused multiply-adds included, in the same order
//! in every lane (so the same hits, bit for bit), with each test's lane mask taken by one
//! `vmovmskps` where the compiler made it from bytes.

use super::{Block, BlockBounds, BlockHits, LANES};
use glam::Vec3A;
use std::arch::x86_64::*;

/// A ray's origin, direction and `1 / direction` in every lane.
#[derive(Clone, Copy)]
pub(super) struct Ray8 {
    o: [__m256; 3],
    d: [__m256; 3],
    inv_d: [__m256; 3],
}

#[inline]
#[target_feature(enable = "avx2,fma")]
fn load(a: &[f32; LANES]) -> __m256 {
    // SAFETY: `a` is eight readable f32s; `loadu` has no alignment requirement.
    unsafe { _mm256_loadu_ps(a.as_ptr()) }
}

/// `a . b` as the portable test sums it: `fma(a2, b2, fma(a1, b1, a0 b0))`.
#[inline]
#[target_feature(enable = "avx2,fma")]
fn dot(a: [__m256; 3], b: [__m256; 3]) -> __m256 {
    _mm256_fmadd_ps(
        a[2],
        b[2],
        _mm256_fmadd_ps(a[1], b[1], _mm256_mul_ps(a[0], b[0])),
    )
}

impl Ray8 {
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn new(o: Vec3A, d: Vec3A) -> Ray8 {
        let inv = Vec3A::ONE / d;
        let splat = |v: Vec3A| [v.x, v.y, v.z].map(|c| _mm256_set1_ps(c));
        Ray8 {
            o: splat(o),
            d: splat(d),
            inv_d: splat(inv),
        }
    }
}

/// [`enter_blocks`](super::enter_blocks): the mask of the blocks the segment (0, `tmax`)
/// meets, and where it enters each.
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(super) fn enter_blocks(b: &BlockBounds, r: &Ray8, tmax: f32) -> (u32, [f32; LANES]) {
    // `_mm256_min_ps(a, b)` is `if a < b { a } else { b }` and `_mm256_max_ps(a, b)` is
    // `if a > b { a } else { b }`, NaN included: the portable test's `min` and `max`.
    let (mut near, mut far) = (_mm256_setzero_ps(), _mm256_set1_ps(tmax));
    for c in 0..3 {
        let t0 = _mm256_mul_ps(_mm256_sub_ps(load(&b.lo[c]), r.o[c]), r.inv_d[c]);
        let t1 = _mm256_mul_ps(_mm256_sub_ps(load(&b.hi[c]), r.o[c]), r.inv_d[c]);
        near = _mm256_max_ps(near, _mm256_min_ps(t0, t1));
        far = _mm256_min_ps(far, _mm256_max_ps(t0, t1));
    }
    let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(near, far);
    (_mm256_movemask_ps(hit) as u32, lanes(near))
}

/// [`intersect_block`](super::intersect_block): Cramer's rule against `|det|`.
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(super) fn intersect_block(b: &Block, r: &Ray8, tmax: f32) -> BlockHits {
    let d = r.d;
    let w = [0, 1, 2].map(|c| _mm256_sub_ps(load(&b.v0[c]), r.o[c]));
    // `fma(a, b, -(c e))`, as the portable test: one rounding of `c e`, then one.
    let rx = _mm256_fmsub_ps(d[1], w[2], _mm256_mul_ps(d[2], w[1]));
    let ry = _mm256_fmsub_ps(d[2], w[0], _mm256_mul_ps(d[0], w[2]));
    let rz = _mm256_fmsub_ps(d[0], w[1], _mm256_mul_ps(d[1], w[0]));
    let n = [0, 1, 2].map(|c| load(&b.n[c]));
    let e2 = [0, 1, 2].map(|c| load(&b.e2[c]));
    let ne1 = [0, 1, 2].map(|c| load(&b.ne1[c]));
    let det = dot(d, n);
    let sign_bit = _mm256_set1_ps(-0.0);
    let sign = _mm256_and_ps(det, sign_bit);
    let t = _mm256_xor_ps(dot(w, n), sign);
    let u = _mm256_xor_ps(dot([rx, ry, rz], e2), sign);
    let v = _mm256_xor_ps(dot([rx, ry, rz], ne1), sign);
    let abs_det = _mm256_andnot_ps(sign_bit, det);
    let zero = _mm256_setzero_ps();
    let all = [
        _mm256_cmp_ps::<_CMP_GT_OQ>(abs_det, zero),
        _mm256_cmp_ps::<_CMP_LT_OQ>(abs_det, _mm256_set1_ps(f32::INFINITY)),
        _mm256_cmp_ps::<_CMP_GE_OQ>(u, zero),
        _mm256_cmp_ps::<_CMP_GE_OQ>(v, zero),
        _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_fmadd_ps(v, load(&b.tri), u), abs_det),
        _mm256_cmp_ps::<_CMP_LE_OQ>(v, abs_det),
        _mm256_cmp_ps::<_CMP_GT_OQ>(t, zero),
        _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_mul_ps(_mm256_set1_ps(tmax), abs_det)),
    ];
    let hit = all
        .into_iter()
        .reduce(|a, b| _mm256_and_ps(a, b))
        .unwrap_or(zero);
    BlockHits {
        mask: _mm256_movemask_ps(hit) as u32,
        t: lanes(t),
        u: lanes(u),
        v: lanes(v),
        det: lanes(abs_det),
    }
}

/// The eight lanes of `v`.
#[inline]
#[target_feature(enable = "avx2,fma")]
fn lanes(v: __m256) -> [f32; LANES] {
    // SAFETY: `__m256` is eight f32s, every bit pattern a valid f32.
    unsafe { std::mem::transmute::<__m256, [f32; LANES]>(v) }
}

//! Acceleration: an obvhs compressed-wide BVH (CWBVH) over the scene's triangles, or, for
//! scenes of at most [`SMALL_SCENE_TRIANGLES`] triangles, every triangle tested on every
//! ray, eight at a time (a BVH's node tests cost more than they save there).
//!
//! The BVH knows nothing of materials: closest-hit returns the triangle and its
//! barycentrics; the any-hit query hands every hit to a closure that decides whether it
//! blocks (used by shadow rays through partly covered surfaces).

use crate::scene::Scene;
use glam::{Vec3, Vec3A};
use obvhs::{BvhBuildParams, cwbvh::CwBvh, cwbvh::builder::build_cwbvh_from_tris, ray::Ray};
use std::time::Duration;

/// A triangle prepared for intersection: one vertex and two edges.
#[derive(Clone, Copy, Debug)]
struct PreparedTri {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
}

/// Scenes with at most this many (non-degenerate) triangles skip the BVH. Measured (1
/// thread): testing every triangle, four at a time with SSE, rendered the race's
/// 12-triangle room 12 % faster and its 6-triangle corner 17 % faster than the CWBVH
/// (64 x 48, 512 spp), and the 30-triangle Cornell box equally fast. Eight at a time with
/// AVX2 renders the Cornell box (128 x 128, 64 spp) 11 % faster than the CWBVH; without
/// AVX2 (two SSE or NEON halves) 5 % slower. The limit is the same on every CPU, so a
/// scene traces the same way on every machine (shards of one render may run on several).
pub const SMALL_SCENE_TRIANGLES: usize = 32;

/// Triangles per block of the small-scene path: one AVX register per coordinate where
/// the CPU has AVX2 (detected at run time), two SSE or NEON registers elsewhere.
const LANES: usize = 8;

/// Eight prepared triangles, one coordinate per array (lanes past the scene's triangles
/// are zero: a zero determinant, never hit): a vertex `v0`, the edge `e2 = v2 - v0`, the
/// reversed edge `ne1 = v0 - v1`, and the normal `n = e2 x e1` (not normalised).
#[derive(Clone, Copy, Debug, Default)]
struct TriBlock {
    v0: [[f32; LANES]; 3],
    e2: [[f32; LANES]; 3],
    ne1: [[f32; LANES]; 3],
    n: [[f32; LANES]; 3],
}

/// What a ray meets in one block: a bit mask of the lanes hit within (0, tmax), and per
/// lane the distance and barycentrics times the determinant's magnitude `det` (divided
/// only for the lanes hit: see [`BlockHits::lane`]).
struct BlockHits {
    mask: u32,
    t: [f32; LANES],
    u: [f32; LANES],
    v: [f32; LANES],
    det: [f32; LANES],
}

impl BlockHits {
    /// Lane `l`'s distance and barycentrics `(t, u, v)`.
    #[inline(always)]
    fn lane(&self, l: usize) -> (f32, f32, f32) {
        let inv = 1.0 / self.det[l];
        (self.t[l] * inv, self.u[l] * inv, self.v[l] * inv)
    }
}

/// The eight triangles of a block against one ray, lane by lane without branches,
/// written for the compiler to vectorise (the same IEEE operations on every instruction
/// set, so the same hits). Cramer's rule on `o + t d = v0 + u e1 + v e2`, with `w = v0 -
/// o` and `r = d x w`: `det = d . n`, `t det = w . n`, `u det = r . e2`, `v det = r .
/// ne1` (Moller-Trumbore's terms, with the normal made once per triangle and no
/// division: the tests compare against `|det|`, the signs taken from `det`).
#[inline(always)]
// One lane index reads twelve arrays; the comparisons are joined with `&`, not ranges'
// short-circuiting `contains`, so every lane computes all of them (no branches).
#[allow(clippy::needless_range_loop, clippy::manual_range_contains)]
fn intersect_block(b: &TriBlock, o: Vec3A, d: Vec3A, tmax: f32) -> BlockHits {
    let mut out = BlockHits {
        mask: 0,
        t: [0.0; LANES],
        u: [0.0; LANES],
        v: [0.0; LANES],
        det: [0.0; LANES],
    };
    let mut hit = [false; LANES];
    for l in 0..LANES {
        let wx = b.v0[0][l] - o.x;
        let wy = b.v0[1][l] - o.y;
        let wz = b.v0[2][l] - o.z;
        let rx = d.y * wz - d.z * wy;
        let ry = d.z * wx - d.x * wz;
        let rz = d.x * wy - d.y * wx;
        let (nx, ny, nz) = (b.n[0][l], b.n[1][l], b.n[2][l]);
        let det = d.x * nx + d.y * ny + d.z * nz;
        let sign = det.to_bits() & 0x8000_0000;
        let flip = |x: f32| f32::from_bits(x.to_bits() ^ sign);
        let t = flip(wx * nx + wy * ny + wz * nz);
        let u = flip(rx * b.e2[0][l] + ry * b.e2[1][l] + rz * b.e2[2][l]);
        let v = flip(rx * b.ne1[0][l] + ry * b.ne1[1][l] + rz * b.ne1[2][l]);
        let abs_det = det.abs();
        // A finite, non-zero determinant (NaN fails every comparison).
        hit[l] = (abs_det > 0.0)
            & (abs_det < f32::INFINITY)
            & (u >= 0.0)
            & (v >= 0.0)
            & (u + v <= abs_det)
            & (t > 0.0)
            & (t < tmax * abs_det);
        (out.t[l], out.u[l], out.v[l], out.det[l]) = (t, u, v, abs_det);
    }
    // Eight flags, one per byte, to eight bits: the multiply gathers byte j's low bit
    // into bit 56 + j (no carries: each partial product lands on its own bit).
    let bytes = u64::from_le_bytes(hit.map(u8::from));
    out.mask = ((bytes.wrapping_mul(0x0102_0408_1020_4080)) >> 56) as u32;
    out
}

/// The bounds of a small scene's blocks, one lane per block (at most [`LANES`] blocks),
/// in BVH space, each padded by [`BLOCK_PAD`] so rounding in the slab test never loses
/// a hit the block's triangle test would find.
#[derive(Clone, Copy, Debug, Default)]
struct BlockBounds {
    lo: [[f32; LANES]; 3],
    hi: [[f32; LANES]; 3],
}

/// Padding of a block's bounds, BVH-space units (the scene's diagonal is about 2^14
/// units, its coordinates' rounding at most 2^-10): 64 times the rounding of a
/// coordinate, far below a ray's offset from the surface it leaves.
const BLOCK_PAD: f32 = 1.0 / 16.0;

/// The slab test of a ray against every block's bounds: a mask of the blocks the segment
/// (0, `tmax`) meets, and where it enters each (0 where it starts inside). `inv_d` is
/// `1 / d` per axis (infinite for a zero component; the one NaN, a ray in a padded face's
/// plane, cannot enter the unpadded block, so either answer is right).
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn enter_blocks(b: &BlockBounds, o: Vec3A, inv_d: Vec3A, tmax: f32) -> (u32, [f32; LANES]) {
    let mut near_out = [0.0; LANES];
    let mut hit = [false; LANES];
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let max = |a: f32, b: f32| if a > b { a } else { b };
    for l in 0..LANES {
        let (mut near, mut far) = (0.0f32, tmax);
        for c in 0..3 {
            let t0 = (b.lo[c][l] - o[c]) * inv_d[c];
            let t1 = (b.hi[c][l] - o[c]) * inv_d[c];
            near = max(near, min(t0, t1));
            far = min(far, max(t0, t1));
        }
        hit[l] = near <= far;
        near_out[l] = near;
    }
    let bytes = u64::from_le_bytes(hit.map(u8::from));
    (
        ((bytes.wrapping_mul(0x0102_0408_1020_4080)) >> 56) as u32,
        near_out,
    )
}

/// A ray-triangle intersection. `u`, `v` are the barycentric weights of vertices 1 and 2
/// (the hit is `p0 (1 - u - v) + p1 u + p2 v`); `t_m` is the distance along the unit
/// direction, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t_m: f32,
    /// Index into `Scene::triangles`.
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
}

impl PreparedTri {
    /// Moller-Trumbore: distance along `dir` and barycentrics, if hit within (tmin, tmax).
    #[inline(always)]
    fn intersect(
        &self,
        origin: Vec3A,
        dir: Vec3A,
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, f32, f32)> {
        let pvec = dir.cross(self.e2);
        let det = self.e1.dot(pvec);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv_det = 1.0 / det;
        let tvec = origin - self.v0;
        let u = tvec.dot(pvec) * inv_det;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let qvec = tvec.cross(self.e1);
        let v = dir.dot(qvec) * inv_det;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = self.e2.dot(qvec) * inv_det;
        (t > tmin && t < tmax).then_some((t, u, v))
    }
}

/// The BVH and the triangles in BVH order, in *BVH space*: world space shifted to the
/// scene's centre and scaled by a power of two so the scene's diagonal is about 2^14
/// units. obvhs culls BVH nodes closer than an absolute 1e-4 units to the ray origin;
/// in BVH space that is below 1e-8 of the scene at any scale, so a 1 mm scene and a
/// 10 km scene trace the same way (and the power-of-two scale is exact in floating point).
pub struct Accel {
    /// BVH space = (world - origin) * scale.
    origin: Vec3A,
    scale: f32,
    bvh: Option<CwBvh>,
    /// Triangles in BVH primitive order.
    tris: Vec<PreparedTri>,
    /// Small scenes: the triangles in blocks of eight (then `bvh` is `None`).
    blocks: Vec<TriBlock>,
    /// Small scenes: the blocks' bounds.
    bounds: BlockBounds,
    /// BVH primitive order (block lane order for small scenes) -> scene triangle index.
    scene_index: Vec<u32>,
    /// Whether the blocks are tested with AVX2 (the CPU has it; never elsewhere).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    wide: bool,
}

/// Whether this CPU has AVX2, for the small-scene path's eight-lane blocks.
fn cpu_has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

impl Accel {
    /// Build the CWBVH (obvhs `medium_build`: no spatial splits, so every triangle sits in
    /// exactly one leaf and any-hit visits it at most once).
    pub fn build(scene: &Scene) -> Accel {
        Accel::build_with(scene, SMALL_SCENE_TRIANGLES)
    }

    /// The CWBVH whatever the scene's size (the engine benchmark's raw obvhs baseline).
    pub fn build_bvh(scene: &Scene) -> Accel {
        Accel::build_with(scene, 0)
    }

    /// Build blocks for at most `small_max` triangles, else the CWBVH.
    fn build_with(scene: &Scene, small_max: usize) -> Accel {
        let Some(bounds) = scene.geometry_bounds() else {
            return Accel {
                origin: Vec3A::ZERO,
                scale: 1.0,
                bvh: None,
                tris: Vec::new(),
                blocks: Vec::new(),
                bounds: BlockBounds::default(),
                scene_index: Vec::new(),
                wide: false,
            };
        };
        let origin: Vec3A = bounds.center().into();
        let diag = bounds.diagonal_m().max(f32::MIN_POSITIVE);
        let scale = (16384.0 / diag).log2().round().clamp(-120.0, 120.0).exp2();
        let to_bvh = |p: Vec3| (Vec3A::from(p) - origin) * scale;
        // Degenerate triangles (no normal: collinear or repeated vertices, or a cross
        // product that underflows) are left out: they have no side to shade or offset
        // from, and a zero-area surface must not stop light.
        let kept: Vec<u32> = (0..scene.triangles.len() as u32)
            .filter(|&i| {
                let t = &scene.triangles[i as usize];
                (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).normalize_or_zero() != Vec3::ZERO
            })
            .collect();
        if kept.is_empty() {
            return Accel {
                origin,
                scale,
                bvh: None,
                tris: Vec::new(),
                blocks: Vec::new(),
                bounds: BlockBounds::default(),
                scene_index: Vec::new(),
                wide: false,
            };
        }
        if kept.len() <= small_max {
            let mut blocks = vec![TriBlock::default(); kept.len().div_ceil(LANES)];
            let mut bounds = BlockBounds::default();
            for k in 0..blocks.len() {
                for c in 0..3 {
                    bounds.lo[c][k] = f32::INFINITY;
                    bounds.hi[c][k] = f32::NEG_INFINITY;
                }
            }
            for (k, &i) in kept.iter().enumerate() {
                let t = &scene.triangles[i as usize];
                let (v0, v1, v2) = (to_bvh(t.p[0]), to_bvh(t.p[1]), to_bvh(t.p[2]));
                let (e1, e2) = (v1 - v0, v2 - v0);
                for c in 0..3 {
                    let (lo, hi) = (&mut bounds.lo[c][k / LANES], &mut bounds.hi[c][k / LANES]);
                    *lo = lo.min(v0[c].min(v1[c]).min(v2[c]) - BLOCK_PAD);
                    *hi = hi.max(v0[c].max(v1[c]).max(v2[c]) + BLOCK_PAD);
                }
                let (b, lane) = (&mut blocks[k / LANES], k % LANES);
                let n = e2.cross(e1);
                for c in 0..3 {
                    b.v0[c][lane] = v0[c];
                    b.e2[c][lane] = e2[c];
                    b.ne1[c][lane] = -e1[c];
                    b.n[c][lane] = n[c];
                }
            }
            return Accel {
                origin,
                scale,
                bvh: None,
                tris: Vec::new(),
                blocks,
                bounds,
                scene_index: kept,
                wide: cpu_has_avx2(),
            };
        }
        let obvhs_tris: Vec<obvhs::triangle::Triangle> = kept
            .iter()
            .map(|&i| &scene.triangles[i as usize])
            .map(|t| obvhs::triangle::Triangle {
                v0: to_bvh(t.p[0]),
                v1: to_bvh(t.p[1]),
                v2: to_bvh(t.p[2]),
            })
            .collect();
        let mut bvh = build_cwbvh_from_tris(
            &obvhs_tris,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        // obvhs reserves one node per triangle and keeps the spare capacity.
        bvh.nodes.shrink_to_fit();
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let t = &obvhs_tris[i as usize];
                PreparedTri {
                    v0: t.v0,
                    e1: t.v1 - t.v0,
                    e2: t.v2 - t.v0,
                }
            })
            .collect();
        let scene_index = bvh
            .primitive_indices
            .iter()
            .map(|&i| kept[i as usize])
            .collect();
        Accel {
            origin,
            scale,
            bvh: Some(bvh),
            tris,
            blocks: Vec::new(),
            bounds: BlockBounds::default(),
            scene_index,
            wide: false,
        }
    }

    /// Number of triangles in the BVH (the scene's, less the degenerate ones).
    pub fn triangle_count(&self) -> usize {
        self.scene_index.len()
    }

    /// Whether the scene is small enough to skip the BVH (see [`SMALL_SCENE_TRIANGLES`]).
    pub fn is_small_scene(&self) -> bool {
        !self.blocks.is_empty()
    }

    /// Every hit of the ray among a small scene's blocks within (0, `t_max`), in block
    /// and lane order, with AVX2 where the CPU has it: `visit(lane, t, u, v, t_max)`
    /// gets the triangle's index in block-lane order, may lower `t_max` for the hits
    /// still to come, and returns whether to stop. Returns whether it stopped.
    fn small_hits(
        &self,
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        visit: impl FnMut(usize, f32, f32, f32, &mut f32) -> bool,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.wide {
            // SAFETY: `wide` is set only where the CPU was found to have AVX2.
            return unsafe { self.small_hits_avx2(o, d, t_max, visit) };
        }
        self.small_hits_any(o, d, t_max, visit)
    }

    /// [`Accel::small_hits`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn small_hits_avx2(
        &self,
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        visit: impl FnMut(usize, f32, f32, f32, &mut f32) -> bool,
    ) -> bool {
        self.small_hits_any(o, d, t_max, visit)
    }

    /// [`Accel::small_hits`] for the instruction set it is compiled for.
    #[inline(always)]
    fn small_hits_any(
        &self,
        o: Vec3A,
        d: Vec3A,
        mut t_max: f32,
        mut visit: impl FnMut(usize, f32, f32, f32, &mut f32) -> bool,
    ) -> bool {
        let (mut blocks, near) = enter_blocks(&self.bounds, o, Vec3A::ONE / d, t_max);
        blocks &= (1u32 << self.blocks.len()) - 1;
        while blocks != 0 {
            let k = blocks.trailing_zeros() as usize;
            blocks &= blocks - 1;
            let Some(b) = self.blocks.get(k) else { break };
            if near[k] > t_max {
                continue;
            }
            let h = intersect_block(b, o, d, t_max);
            let mut mask = h.mask;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let (t, u, v) = h.lane(lane);
                if visit(k * LANES + lane, t, u, v, &mut t_max) {
                    return true;
                }
            }
        }
        false
    }

    /// Closest hit among the blocks of a small scene.
    fn closest_hit_small(&self, o: Vec3A, d: Vec3A, t_max: f32) -> Option<Hit> {
        let mut best: Option<(f32, usize, f32, f32)> = None;
        self.small_hits(o, d, t_max, |id, t, u, v, t_best| {
            if t < *t_best {
                *t_best = t;
                best = Some((t, id, u, v));
            }
            false
        });
        let (t, id, u, v) = best?;
        Some(Hit {
            t_m: t / self.scale,
            triangle: *self.scene_index.get(id)?,
            u,
            v,
        })
    }

    /// Closest hit along `origin + t dir` for `t` in (0, t_max_m). `dir` must be unit length.
    #[inline]
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_max_m: f32) -> Option<Hit> {
        let o = (Vec3A::from(origin) - self.origin) * self.scale;
        let d: Vec3A = dir.into();
        if !self.blocks.is_empty() {
            return self.closest_hit_small(o, d, t_max_m * self.scale);
        }
        self.closest_hit_bvh(o, d, t_max_m * self.scale)
    }

    /// [`Accel::closest_hit`] through the CWBVH, in BVH space. Not inlined: a small
    /// scene's rays go straight to its blocks, without this path's stack frame (3.5 %
    /// of a one-thread `builtin:cornell` render; the same split of `any_hit` measured
    /// 3-4 % slower, so it stays whole).
    #[inline(never)]
    fn closest_hit_bvh(&self, o: Vec3A, d: Vec3A, t_max: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let ray = Ray::new(o, d, 0.0, t_max);
        let mut best: Option<(f32, usize, f32, f32)> = None;
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(ray, &mut hit, |r, id| {
            match self.tris[id].intersect(o, d, 0.0, r.tmax) {
                Some((t, u, v)) => {
                    best = Some((t, id, u, v));
                    t
                }
                None => f32::INFINITY,
            }
        });
        best.map(|(t, id, u, v)| Hit {
            t_m: t / self.scale,
            triangle: self.scene_index[id],
            u,
            v,
        })
    }

    /// Visit every hit along the segment (0, t_max_m), in no particular order, until
    /// `visit` returns `true` (the ray is blocked). Returns whether it was blocked.
    pub fn any_hit(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max_m: f32,
        mut visit: impl FnMut(Hit) -> bool,
    ) -> bool {
        let o = (Vec3A::from(origin) - self.origin) * self.scale;
        let d: Vec3A = dir.into();
        let t_max = t_max_m * self.scale;
        if !self.blocks.is_empty() {
            return self.small_hits(o, d, t_max, |id, t, u, v, _| {
                self.scene_index.get(id).is_some_and(|&triangle| {
                    visit(Hit {
                        t_m: t / self.scale,
                        triangle,
                        u,
                        v,
                    })
                })
            });
        }
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let ray = Ray::new(o, d, 0.0, t_max);
        !bvh.ray_traverse_miss(ray, |_, id| {
            match self.tris[id].intersect(o, d, 0.0, t_max) {
                Some((t, u, v))
                    if visit(Hit {
                        t_m: t / self.scale,
                        triangle: self.scene_index[id],
                        u,
                        v,
                    }) =>
                {
                    t
                }
                _ => f32::INFINITY,
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rays from points inside the Cornell box in scattered directions.
    fn rays(n: usize) -> Vec<(Vec3, Vec3)> {
        let mut state = 0x1234_5678_9abc_def0u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let o = Vec3::new(next() - 0.5, next(), next() - 0.5) * 0.5;
                let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or(Vec3::X);
                (o, d)
            })
            .collect()
    }

    #[test]
    fn small_scene_blocks_agree_with_the_bvh() {
        let scene = crate::scene::load("builtin:cornell").unwrap();
        let (bvh, blocks) = (
            Accel::build_with(&scene, 0),
            Accel::build_with(&scene, usize::MAX),
        );
        assert!(!bvh.is_small_scene() && blocks.is_small_scene());
        assert_eq!(bvh.triangle_count(), blocks.triangle_count());
        let mut hits = 0;
        for (o, d) in rays(20_000) {
            let (a, b) = (
                bvh.closest_hit(o, d, f32::INFINITY),
                blocks.closest_hit(o, d, f32::INFINITY),
            );
            match (a, b) {
                (Some(a), Some(b)) => {
                    hits += 1;
                    // Relative to the distance, or to 1 cm on this 1 m box: a ray from
                    // nearly on a surface finds it with a rounding error of the scene's
                    // size in both tests (they round differently).
                    let tol = a.t_m.max(0.01);
                    assert!((a.t_m - b.t_m).abs() <= 1e-5 * tol, "{a:?} {b:?}");
                    if a.triangle != b.triangle {
                        // Only through a shared edge, at the same distance.
                        assert!((a.t_m - b.t_m).abs() <= 1e-6 * tol, "{a:?} {b:?}");
                    }
                }
                (None, None) => {}
                _ => panic!("{o} {d}: {a:?} vs {b:?}"),
            }
            // Any-hit over a segment: the same set of triangles crossed.
            let count = |acc: &Accel| {
                let mut seen = Vec::new();
                acc.any_hit(o, d, 0.4, |h| {
                    seen.push(h.triangle);
                    false
                });
                seen.sort_unstable();
                seen
            };
            assert_eq!(count(&bvh), count(&blocks));
        }
        assert!(hits > 15_000, "{hits}");
    }

    /// The blocks tested with AVX2 (where this CPU has it) and without give the same
    /// hits, bit for bit: the same IEEE operations in every lane.
    #[test]
    fn small_scene_blocks_trace_alike_with_and_without_avx2() {
        let scene = crate::scene::load("builtin:cornell").unwrap();
        let (wide, mut narrow) = (
            Accel::build_with(&scene, usize::MAX),
            Accel::build_with(&scene, usize::MAX),
        );
        narrow.wide = false;
        assert_eq!(wide.wide, cpu_has_avx2());
        for (o, d) in rays(20_000) {
            assert_eq!(
                wide.closest_hit(o, d, f32::INFINITY),
                narrow.closest_hit(o, d, f32::INFINITY)
            );
            let seen = |acc: &Accel| {
                let mut seen = Vec::new();
                acc.any_hit(o, d, 0.4, |h| {
                    seen.push(h);
                    false
                });
                seen
            };
            assert_eq!(seen(&wide), seen(&narrow));
        }
    }
}

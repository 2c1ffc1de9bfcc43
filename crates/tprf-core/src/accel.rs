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
/// are zero: a zero determinant, never hit).
#[derive(Clone, Copy, Debug, Default)]
struct TriBlock {
    v0: [[f32; LANES]; 3],
    e1: [[f32; LANES]; 3],
    e2: [[f32; LANES]; 3],
}

/// What a ray meets in one block: a bit mask of the lanes hit within (0, tmax), and per
/// lane the distance and barycentrics.
struct BlockHits {
    mask: u32,
    t: [f32; LANES],
    u: [f32; LANES],
    v: [f32; LANES],
}

/// Möller-Trumbore on the eight triangles of a block: the arithmetic of
/// [`PreparedTri::intersect`], lane by lane without branches, written for the compiler to
/// vectorise (the same IEEE operations on every instruction set, so the same hits).
#[inline(always)]
// One lane index reads nine arrays; the comparisons are joined with `&`, not ranges'
// short-circuiting `contains`, so every lane computes all of them (no branches).
#[allow(clippy::needless_range_loop, clippy::manual_range_contains)]
fn intersect_block(b: &TriBlock, o: Vec3A, d: Vec3A, tmax: f32) -> BlockHits {
    let mut out = BlockHits {
        mask: 0,
        t: [0.0; LANES],
        u: [0.0; LANES],
        v: [0.0; LANES],
    };
    let mut hit = [false; LANES];
    for l in 0..LANES {
        let (e1x, e1y, e1z) = (b.e1[0][l], b.e1[1][l], b.e1[2][l]);
        let (e2x, e2y, e2z) = (b.e2[0][l], b.e2[1][l], b.e2[2][l]);
        let px = d.y * e2z - d.z * e2y;
        let py = d.z * e2x - d.x * e2z;
        let pz = d.x * e2y - d.y * e2x;
        let det = e1x * px + e1y * py + e1z * pz;
        let inv_det = 1.0 / det;
        let tx = o.x - b.v0[0][l];
        let ty = o.y - b.v0[1][l];
        let tz = o.z - b.v0[2][l];
        let u = (tx * px + ty * py + tz * pz) * inv_det;
        let qx = ty * e1z - tz * e1y;
        let qy = tz * e1x - tx * e1z;
        let qz = tx * e1y - ty * e1x;
        let v = (d.x * qx + d.y * qy + d.z * qz) * inv_det;
        let t = (e2x * qx + e2y * qy + e2z * qz) * inv_det;
        // A finite, non-zero determinant (NaN fails every comparison).
        hit[l] = (det != 0.0)
            & (det.abs() < f32::INFINITY)
            & (u >= 0.0)
            & (u <= 1.0)
            & (v >= 0.0)
            & (u + v <= 1.0)
            & (t > 0.0)
            & (t < tmax);
        (out.t[l], out.u[l], out.v[l]) = (t, u, v);
    }
    // Eight flags, one per byte, to eight bits: the multiply gathers byte j's low bit
    // into bit 56 + j (no carries: each partial product lands on its own bit).
    let bytes = u64::from_le_bytes(hit.map(u8::from));
    out.mask = ((bytes.wrapping_mul(0x0102_0408_1020_4080)) >> 56) as u32;
    out
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
                scene_index: Vec::new(),
                wide: false,
            };
        }
        if kept.len() <= small_max {
            let mut blocks = vec![TriBlock::default(); kept.len().div_ceil(LANES)];
            for (k, &i) in kept.iter().enumerate() {
                let t = &scene.triangles[i as usize];
                let (v0, v1, v2) = (to_bvh(t.p[0]), to_bvh(t.p[1]), to_bvh(t.p[2]));
                let (e1, e2) = (v1 - v0, v2 - v0);
                let (b, lane) = (&mut blocks[k / LANES], k % LANES);
                for c in 0..3 {
                    b.v0[c][lane] = v0[c];
                    b.e1[c][lane] = e1[c];
                    b.e2[c][lane] = e2[c];
                }
            }
            return Accel {
                origin,
                scale,
                bvh: None,
                tris: Vec::new(),
                blocks,
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
        for (k, b) in self.blocks.iter().enumerate() {
            let h = intersect_block(b, o, d, t_max);
            let mut mask = h.mask;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if visit(
                    k * LANES + lane,
                    h.t[lane],
                    h.u[lane],
                    h.v[lane],
                    &mut t_max,
                ) {
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
                    assert!((a.t_m - b.t_m).abs() <= 1e-5 * a.t_m, "{a:?} {b:?}");
                    if a.triangle != b.triangle {
                        // Only through a shared edge, at the same distance.
                        assert!((a.t_m - b.t_m).abs() <= 1e-6 * a.t_m, "{a:?} {b:?}");
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

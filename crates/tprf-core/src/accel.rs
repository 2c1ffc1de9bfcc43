//! Acceleration: an obvhs compressed-wide BVH (CWBVH) over the scene's triangles, or, for
//! scenes of at most [`SMALL_SCENE_TRIANGLES`] triangles, every triangle tested on every
//! ray, eight at a time, in blocks culled by their bounds (`blocks.rs`: a BVH's node
//! tests cost more than they save there).
//!
//! The BVH knows nothing of materials: closest-hit returns the triangle and its
//! barycentrics; the any-hit query hands every hit to a closure that decides whether it
//! blocks (used by shadow rays through partly covered surfaces).

mod blocks;

use crate::scene::Scene;
use blocks::{Blocks, SmallTri};
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
/// AVX2 (two SSE or NEON halves) 5 % slower. (Since then the blocks are culled by their
/// bounds and pair parallelograms into one lane; 32 triangles always fit the eight
/// blocks of eight lanes.) The limit is the same on every CPU, so a
/// scene traces the same way on every machine (shards of one render may run on several).
pub const SMALL_SCENE_TRIANGLES: usize = 32;

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
    /// Small scenes: the triangles in blocks (then `bvh` is `None`).
    small: Option<Blocks>,
    /// BVH primitive order -> scene triangle index.
    scene_index: Vec<u32>,
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
                small: None,
                scene_index: Vec::new(),
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
                small: None,
                scene_index: Vec::new(),
            };
        }
        if kept.len() <= small_max {
            let tris: Vec<SmallTri> = kept
                .iter()
                .map(|&i| {
                    let p = scene.triangles[i as usize].p;
                    SmallTri {
                        index: i,
                        world: p,
                        bvh: p.map(to_bvh),
                    }
                })
                .collect();
            if let Some(small) = Blocks::build(&tris) {
                return Accel {
                    origin,
                    scale,
                    bvh: None,
                    tris: Vec::new(),
                    small: Some(small),
                    scene_index: Vec::new(),
                };
            }
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
            small: None,
            scene_index,
        }
    }

    /// Number of triangles traced (the scene's, less the degenerate ones).
    pub fn triangle_count(&self) -> usize {
        self.small
            .as_ref()
            .map_or(self.scene_index.len(), Blocks::triangles)
    }

    /// Whether the scene is small enough to skip the BVH (see [`SMALL_SCENE_TRIANGLES`]).
    pub fn is_small_scene(&self) -> bool {
        self.small.is_some()
    }

    /// Closest hit among the blocks of a small scene. Inlined into the caller, which then
    /// makes one call on a ray (into the blocks' test).
    #[inline(always)]
    fn closest_hit_small(&self, small: &Blocks, o: Vec3A, d: Vec3A, t_max: f32) -> Option<Hit> {
        let mut best: Option<(f32, usize, f32, f32)> = None;
        small.hits(o, d, t_max, |id, t, u, v, t_best| {
            if t < *t_best {
                *t_best = t;
                best = Some((t, id, u, v));
            }
            false
        });
        let (t, id, u, v) = best?;
        let (triangle, u, v) = small.resolve(id, u, v)?;
        Some(Hit {
            t_m: t / self.scale,
            triangle,
            u,
            v,
        })
    }

    /// Closest hit along `origin + t dir` for `t` in (0, t_max_m). `dir` must be unit length.
    /// Always inlined: a small scene's ray is then one call from the caller.
    #[inline(always)]
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_max_m: f32) -> Option<Hit> {
        let o = (Vec3A::from(origin) - self.origin) * self.scale;
        let d: Vec3A = dir.into();
        if let Some(small) = &self.small {
            return self.closest_hit_small(small, o, d, t_max_m * self.scale);
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
        if let Some(small) = &self.small {
            return small.hits(o, d, t_max, |id, t, u, v, _| {
                small.resolve(id, u, v).is_some_and(|(triangle, u, v)| {
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
        // The Cornell box: its walls and the blocks' sides are parallelograms (one lane
        // each), the blocks' tops are not.
        let scene = crate::scene::load("builtin:cornell").unwrap();
        assert!(agree(&scene) > 15_000);
        // 32 triangles strewn through the box, none sharing an edge: 32 lanes, grouped
        // into at most eight blocks.
        let mut soup = scene.clone();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        soup.triangles = (0..SMALL_SCENE_TRIANGLES)
            .map(|_| {
                let c = Vec3::new(next(), next() + 0.5, next()) * 0.5;
                let mut corner = || c + Vec3::new(next(), next(), next()) * 0.3;
                crate::scene::Triangle {
                    p: [corner(), corner(), corner()],
                }
            })
            .collect();
        assert!(agree(&soup) > 2_000);
    }

    /// Closest hits (distance, triangle, barycentrics) and any-hit sets of the blocks
    /// against the BVH for 20 000 rays; returns the number of closest hits.
    fn agree(scene: &Scene) -> usize {
        let (bvh, blocks) = (
            Accel::build_with(scene, 0),
            Accel::build_with(scene, SMALL_SCENE_TRIANGLES),
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
                    // Relative to the distance, or to 10 cm on this 0.56 m box: a ray
                    // from nearly on a surface finds it with a rounding error of the
                    // scene's size in both tests (they round differently); and over the
                    // cosine of the ray with the triangle (a grazing ray's distance is
                    // that much less certain).
                    let p = scene.triangles[a.triangle as usize].p;
                    let cos = (p[1] - p[0]).cross(p[2] - p[0]).normalize().dot(d).abs();
                    let tol = a.t_m.max(0.1) / cos.max(1e-3);
                    assert!((a.t_m - b.t_m).abs() <= 1e-5 * tol, "{a:?} {b:?}");
                    if a.triangle != b.triangle {
                        // Only through a shared edge, at the same distance.
                        assert!((a.t_m - b.t_m).abs() <= 1e-6 * tol, "{a:?} {b:?}");
                    } else {
                        // The same point of the triangle (a parallelogram's lane gives
                        // each of its triangles' own barycentrics).
                        assert!((a.u - b.u).abs() <= 1e-4, "{a:?} {b:?}");
                        assert!((a.v - b.v).abs() <= 1e-4, "{a:?} {b:?}");
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
        hits
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
        narrow.small.as_mut().unwrap().wide = false;
        assert_eq!(
            wide.small.as_ref().unwrap().wide,
            blocks::cpu_has_avx2_fma()
        );
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

//! Acceleration: an obvhs compressed-wide BVH (CWBVH) over the scene's triangles.
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
    /// BVH primitive order -> scene triangle index.
    scene_index: Vec<u32>,
}

impl Accel {
    /// Build the CWBVH (obvhs `medium_build`: no spatial splits, so every triangle sits in
    /// exactly one leaf and any-hit visits it at most once).
    pub fn build(scene: &Scene) -> Accel {
        let Some(bounds) = scene.geometry_bounds() else {
            return Accel {
                origin: Vec3A::ZERO,
                scale: 1.0,
                bvh: None,
                tris: Vec::new(),
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
                scene_index: Vec::new(),
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
            scene_index,
        }
    }

    /// Number of triangles in the BVH (the scene's, less the degenerate ones).
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Closest hit along `origin + t dir` for `t` in (0, t_max_m). `dir` must be unit length.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_max_m: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let o = (Vec3A::from(origin) - self.origin) * self.scale;
        let d: Vec3A = dir.into();
        let ray = Ray::new(o, d, 0.0, t_max_m * self.scale);
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
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let o = (Vec3A::from(origin) - self.origin) * self.scale;
        let d: Vec3A = dir.into();
        let t_max = t_max_m * self.scale;
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

//! The relay wall: a planar surface of the scene, found by its object's name, with a
//! frame `(u, v, n)` on it and grids of points over its bounding rectangle.
//!
//! The frame follows tal's convention for its default wall (the plane `z = 0`, the hidden
//! scene at `z > 0`): `n` is the wall's normal on the side of the hidden scene, `v` the
//! world's +Y projected onto the wall (its +Z where the wall is horizontal), `u = v x n`.
//! A grid of `nx x ny` points holds cell centres: point `(i, j)` is at
//! `corner + (i + 1/2) w/nx u + (j + 1/2) h/ny v` (tal's `get_grid_xyz`), index
//! `i ny + j` (x-major, as tal's `[X, Y, 3]` grids).

use super::NlosError;
use crate::scene::Scene;
use glam::{DVec3, Vec3};

/// Largest distance of a wall vertex from the wall's plane, as a fraction of the wall's
/// bounding diagonal, for the wall to count as planar.
pub const PLANAR_TOLERANCE: f64 = 1e-4;

/// A point on the relay wall: where it is and which wall triangle holds it (with its
/// barycentrics), so the wall's material can be evaluated there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallPoint {
    pub position: Vec3,
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
}

/// The relay wall of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct RelayWall {
    /// The object's name.
    pub name: String,
    /// Its triangles (indices into `Scene::triangles`), non-degenerate ones only.
    pub triangles: Vec<usize>,
    /// Corner of its bounding rectangle at the least `u` and `v`, metres.
    pub corner: Vec3,
    /// Unit axes on the wall, and its unit normal toward the hidden scene.
    pub u_axis: Vec3,
    pub v_axis: Vec3,
    pub normal: Vec3,
    /// Extent of the bounding rectangle along `u` and `v`, metres.
    pub width_m: f32,
    pub height_m: f32,
}

impl RelayWall {
    /// The wall named `name` in `scene`: its triangles must lie in one plane (within
    /// [`PLANAR_TOLERANCE`] of its diagonal), and the scene must hold other triangles (the
    /// hidden geometry), whose side of the plane (by area) gives the normal's direction.
    pub fn find(scene: &Scene, name: &str) -> Result<RelayWall, NlosError> {
        let all = scene.object_triangles(name);
        if all.is_empty() {
            let xml = std::path::Path::new(&scene.name)
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("xml"));
            let mut known: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
            known.dedup();
            let listed = known.len().min(super::KNOWN_LISTED);
            let mut list = known[..listed].join(", ");
            if known.len() > listed {
                list += &format!(" and {} more", known.len() - listed);
            }
            let known = match (known.is_empty(), xml) {
                (false, _) => list,
                (true, true) => "none: no <shape> in it has an id".to_string(),
                (true, false) => "none: its glTF nodes have no names".to_string(),
            };
            return Err(NlosError::NoRelayWall {
                scene: scene.name.clone(),
                name: name.to_string(),
                known,
                xml,
            });
        }
        let tri = |i: usize| scene.triangles[i].p.map(|p| p.as_dvec3());
        // Area-weighted normal, each triangle's sign aligned with the largest one's.
        let cross = |i: usize| {
            let [a, b, c] = tri(i);
            (b - a).cross(c - a)
        };
        let triangles: Vec<usize> = all
            .into_iter()
            .filter(|&i| cross(i).length() > 0.0)
            .collect();
        let Some(&largest) = triangles
            .iter()
            .max_by(|&&a, &&b| cross(a).length().total_cmp(&cross(b).length()))
        else {
            return Err(NlosError::WallEmpty {
                name: name.to_string(),
            });
        };
        let reference = cross(largest);
        let mut normal = DVec3::ZERO;
        for &i in &triangles {
            let c = cross(i);
            normal += if c.dot(reference) < 0.0 { -c } else { c };
        }
        let mut normal = normal.normalize();
        let points: Vec<DVec3> = triangles.iter().flat_map(|&i| tri(i)).collect();
        let centroid = points.iter().sum::<DVec3>() / points.len() as f64;
        let (lo, hi) = points.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let tolerance_m = PLANAR_TOLERANCE * (hi - lo).length();
        let deviation_m = points
            .iter()
            .map(|p| (p - centroid).dot(normal).abs())
            .fold(0.0, f64::max);
        if deviation_m > tolerance_m {
            return Err(NlosError::WallNotPlanar {
                name: name.to_string(),
                deviation_m,
                tolerance_m,
            });
        }
        // The hidden scene's side: the area-weighted side of every other triangle.
        let is_wall = {
            let mut v = vec![false; scene.triangles.len()];
            for &i in &triangles {
                v[i] = true;
            }
            for o in scene.objects.iter().filter(|o| o.name == name) {
                for i in o.triangles.clone() {
                    if let Some(x) = v.get_mut(i) {
                        *x = true;
                    }
                }
            }
            v
        };
        let mut side = 0.0;
        let mut hidden_area = 0.0;
        for (i, _) in scene
            .triangles
            .iter()
            .enumerate()
            .filter(|(i, _)| !is_wall[*i])
        {
            let [a, b, c] = tri(i);
            let area = 0.5 * (b - a).cross(c - a).length();
            hidden_area += area;
            side += area * ((a + b + c) / 3.0 - centroid).dot(normal);
        }
        if !(hidden_area > 0.0) {
            return Err(NlosError::NoHiddenGeometry {
                name: name.to_string(),
            });
        }
        if side < 0.0 {
            normal = -normal;
        }
        let up = if normal.cross(DVec3::Y).length() > 1e-3 {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let v_axis = (up - normal * up.dot(normal)).normalize();
        let u_axis = v_axis.cross(normal);
        let (mut u0, mut u1, mut v0, mut v1) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for p in &points {
            let d = p - centroid;
            u0 = u0.min(d.dot(u_axis));
            u1 = u1.max(d.dot(u_axis));
            v0 = v0.min(d.dot(v_axis));
            v1 = v1.max(d.dot(v_axis));
        }
        let corner = centroid + u_axis * u0 + v_axis * v0;
        Ok(RelayWall {
            name: name.to_string(),
            triangles,
            corner: corner.as_vec3(),
            u_axis: u_axis.as_vec3(),
            v_axis: v_axis.as_vec3(),
            normal: normal.as_vec3(),
            width_m: (u1 - u0) as f32,
            height_m: (v1 - v0) as f32,
        })
    }

    /// The point at fractions `(fu, fv)` of the bounding rectangle (0: its least corner).
    pub fn point(&self, fu: f32, fv: f32) -> Vec3 {
        self.corner + self.u_axis * (fu * self.width_m) + self.v_axis * (fv * self.height_m)
    }

    /// Centre of the bounding rectangle.
    pub fn center(&self) -> Vec3 {
        self.point(0.5, 0.5)
    }

    /// Cell centres of an `nx x ny` grid over the bounding rectangle, index `i ny + j`.
    pub fn grid(&self, nx: usize, ny: usize) -> Vec<Vec3> {
        let mut out = Vec::with_capacity(nx.saturating_mul(ny));
        for i in 0..nx {
            for j in 0..ny {
                let fu = (i as f32 + 0.5) / nx as f32;
                let fv = (j as f32 + 0.5) / ny as f32;
                out.push(self.point(fu, fv));
            }
        }
        out
    }

    /// The wall triangle holding `p` (a point on the wall's plane) and its barycentrics;
    /// `None` where `p` is on none (a hole, or outside a wall that is not a rectangle).
    pub fn locate(&self, scene: &Scene, p: Vec3) -> Option<WallPoint> {
        let n = self.normal.as_dvec3();
        let q = p.as_dvec3();
        for &i in &self.triangles {
            let [a, b, c] = scene.triangles.get(i)?.p.map(|x| x.as_dvec3());
            let (e1, e2) = (b - a, c - a);
            let area2 = e1.cross(e2).dot(n);
            if area2 == 0.0 {
                continue;
            }
            let d = q - a;
            let u = d.cross(e2).dot(n) / area2;
            let v = e1.cross(d).dot(n) / area2;
            const SLACK: f64 = 1e-6;
            if u >= -SLACK && v >= -SLACK && u + v <= 1.0 + SLACK {
                return Some(WallPoint {
                    position: p,
                    triangle: i as u32,
                    u: u.clamp(0.0, 1.0) as f32,
                    v: v.clamp(0.0, 1.0) as f32,
                });
            }
        }
        None
    }

    /// Whether `p` is on the hidden scene's side of the wall's plane (strictly in front).
    pub fn in_front(&self, p: Vec3) -> bool {
        (p - self.corner).dot(self.normal) > 0.0
    }

    /// Signed distance of `p` from the wall's plane along its normal, metres.
    pub fn height_above_m(&self, p: Vec3) -> f32 {
        (p - self.corner).dot(self.normal)
    }
}

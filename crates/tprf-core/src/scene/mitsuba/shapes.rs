//! Shapes as triangles in world space: mesh files (`obj`, `ply`, `serialized`, read by
//! [`super::meshes`]) and Mitsuba's analytic shapes, `rectangle` and `cube` exactly (they
//! are meshes in Mitsuba too), `sphere`, `disk` and `cylinder` tessellated, with their
//! vertices pushed out so that the tessellation has the shape's area (what an area
//! light's power depends on) and vertex normals of the true surface.
//!
//! As Mitsuba: positions map through `to_world`, normals through its inverse transpose;
//! a mirroring `to_world` and `flip_normals` each reverse the winding (so the geometric
//! normal, the side an area light emits from, stays on the side of the shading normal);
//! a mesh without normals gets angle-weighted vertex normals (Mitsuba's
//! `compute_normals`) unless `face_normals` is set.

use super::meshes::{self, Mesh};
use super::prefetch::Job;
use super::transform::is_affine;
use super::xml::{self, err};
use super::{Builder, MaterialSlot};
use crate::budget::{self, format_count};
use crate::scene::{BYTES_PER_TRIANGLE, SceneError, SceneObject, Triangle, TriangleAttrs};
use glam::{DAffine2, DMat3, DMat4, DVec2, DVec3, Vec2, Vec3};
use std::f64::consts::{PI, TAU};

/// Segments round a tessellated circle (sphere, disk, cylinder).
const SEGMENTS: u32 = 128;
/// Rings from pole to pole of a tessellated sphere.
const RINGS: u32 = 64;

/// Zero area up to f32 rounding (the glTF loader's rule).
fn is_degenerate(t: &Triangle) -> bool {
    let [p0, p1, p2] = t.p;
    let longest_sq = (p1 - p0)
        .length_squared()
        .max((p2 - p0).length_squared())
        .max((p2 - p1).length_squared());
    let twice_area = (p1 - p0).cross(p2 - p0).length();
    twice_area.is_nan() || twice_area <= 1e-7 * longest_sq
}

/// Area of a mesh's triangles (object space).
fn mesh_area(m: &Mesh) -> f64 {
    m.faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| m.positions[i as usize].as_dvec3());
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// Mitsuba's `rectangle`: [-1, 1]^2 in z = 0, normal +Z, uv (x + 1, y + 1) / 2.
fn rectangle() -> Mesh {
    let p = [[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0], [1.0, 1.0]];
    Mesh {
        positions: p.iter().map(|&[x, y]| Vec3::new(x, y, 0.0)).collect(),
        normals: Some(vec![Vec3::Z; 4]),
        uvs: Some(
            p.iter()
                .map(|&[x, y]| Vec2::new((x + 1.0) / 2.0, (y + 1.0) / 2.0))
                .collect(),
        ),
        faces: vec![[1, 2, 0], [1, 3, 2]],
    }
}

/// Mitsuba's `cube`: [-1, 1]^3, four vertices a face with the face's normal.
fn cube() -> Mesh {
    let normals = [
        Vec3::NEG_Y,
        Vec3::Y,
        Vec3::X,
        Vec3::Z,
        Vec3::NEG_X,
        Vec3::NEG_Z,
    ];
    let uv = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let corner = |c: u32| {
        Vec3::new(
            if c & 1 != 0 { 1.0 } else { -1.0 },
            if c & 2 != 0 { 1.0 } else { -1.0 },
            if c & 4 != 0 { 1.0 } else { -1.0 },
        )
    };
    let index = [
        1, 5, 4, 0, 3, 2, 6, 7, 1, 3, 7, 5, 5, 7, 6, 4, 4, 6, 2, 0, 3, 1, 0, 2,
    ];
    let mut m = Mesh {
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        ..Mesh::default()
    };
    for (s, n) in normals.iter().enumerate() {
        let v = 4 * s as u32;
        for k in 0..4 {
            m.positions.push(corner(index[4 * s + k]));
            if let Some(ns) = m.normals.as_mut() {
                ns.push(*n)
            }
            if let Some(us) = m.uvs.as_mut() {
                us.push(Vec2::from_array(uv[k]))
            }
        }
        m.faces.push([v, v + 1, v + 2]);
        m.faces.push([v + 3, v, v + 2]);
    }
    m
}

/// The unit sphere: RINGS x SEGMENTS, uv = (phi / 2 pi, theta / pi) as Mitsuba's, radial
/// normals, radius grown so the tessellation has the sphere's area 4 pi.
fn sphere() -> Mesh {
    let mut m = Mesh {
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        ..Mesh::default()
    };
    let cols = SEGMENTS + 1;
    for r in 0..=RINGS {
        let theta = PI * f64::from(r) / f64::from(RINGS);
        for s in 0..=SEGMENTS {
            let phi = TAU * f64::from(s) / f64::from(SEGMENTS);
            let n = DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            m.positions.push(n.as_vec3());
            if let Some(ns) = m.normals.as_mut() {
                ns.push(n.as_vec3())
            }
            if let Some(us) = m.uvs.as_mut() {
                us.push(Vec2::new(
                    (f64::from(s) / f64::from(SEGMENTS)) as f32,
                    (f64::from(r) / f64::from(RINGS)) as f32,
                ))
            }
        }
    }
    for r in 0..RINGS {
        for s in 0..SEGMENTS {
            let (a, b) = (r * cols + s, r * cols + s + 1);
            let (c, d) = (a + cols, b + cols);
            // Outward: theta grows toward -Z, phi counter-clockwise about +Z.
            if r > 0 {
                m.faces.push([a, c, b]);
            }
            if r + 1 < RINGS {
                m.faces.push([b, c, d]);
            }
        }
    }
    let grow = (4.0 * PI / mesh_area(&m)).sqrt() as f32;
    for p in &mut m.positions {
        *p *= grow;
    }
    m
}

/// The unit disk in z = 0, normal +Z, a fan of SEGMENTS triangles, uv = (r, phi / 2 pi)
/// as Mitsuba's, its rim grown so the fan has area pi.
fn disk() -> Mesh {
    let n = f64::from(SEGMENTS);
    let grow = (PI / (0.5 * n * (TAU / n).sin())).sqrt();
    let mut m = Mesh {
        positions: vec![Vec3::ZERO],
        normals: Some(vec![Vec3::Z]),
        uvs: Some(vec![Vec2::ZERO]),
        faces: Vec::new(),
    };
    for s in 0..=SEGMENTS {
        let phi = TAU * f64::from(s) / n;
        m.positions
            .push((DVec3::new(phi.cos(), phi.sin(), 0.0) * grow).as_vec3());
        if let Some(ns) = m.normals.as_mut() {
            ns.push(Vec3::Z)
        }
        if let Some(us) = m.uvs.as_mut() {
            us.push(Vec2::new(1.0, (f64::from(s) / n) as f32))
        }
    }
    for s in 0..SEGMENTS {
        m.faces.push([0, s + 1, s + 2]);
    }
    m
}

/// The unit cylinder about +Z from z = 0 to 1 (open ends), outward normals, uv =
/// (phi / 2 pi, z), its radius grown so the side has area 2 pi.
fn cylinder() -> Mesh {
    let n = f64::from(SEGMENTS);
    let grow = TAU / (n * 2.0 * (PI / n).sin());
    let mut m = Mesh {
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        ..Mesh::default()
    };
    for s in 0..=SEGMENTS {
        let phi = TAU * f64::from(s) / n;
        let radial = DVec3::new(phi.cos(), phi.sin(), 0.0);
        for z in [0.0, 1.0] {
            m.positions
                .push((radial * grow + DVec3::new(0.0, 0.0, z)).as_vec3());
            if let Some(ns) = m.normals.as_mut() {
                ns.push(radial.as_vec3())
            }
            if let Some(us) = m.uvs.as_mut() {
                us.push(Vec2::new((f64::from(s) / n) as f32, z as f32))
            }
        }
    }
    for s in 0..SEGMENTS {
        let (a, b, c, d) = (2 * s, 2 * s + 1, 2 * s + 2, 2 * s + 3);
        m.faces.push([a, c, b]);
        m.faces.push([b, c, d]);
    }
    m
}

/// Angle-weighted vertex normals of `faces` over `positions` (Thürmer and Wüthrich 1998,
/// Mitsuba's `compute_normals`); a vertex no face contributes to gets `None`.
fn vertex_normals(positions: &[Vec3], faces: &[[u32; 3]]) -> Vec<Option<Vec3>> {
    let mut acc = vec![DVec3::ZERO; positions.len()];
    for f in faces {
        let p = f.map(|i| positions[i as usize].as_dvec3());
        let Some(n) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
            continue;
        };
        for k in 0..3 {
            let (e1, e2) = (
                (p[(k + 1) % 3] - p[k]).normalize_or_zero(),
                (p[(k + 2) % 3] - p[k]).normalize_or_zero(),
            );
            let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
            acc[f[k] as usize] += n * angle;
        }
    }
    acc.into_iter()
        .map(|n| n.try_normalize().map(|n| n.as_vec3()))
        .collect()
}

impl Builder<'_> {
    /// A `<shape>` at the top level (or in a shape group): its triangles in world
    /// space with its material.
    pub(super) fn add_shape(&mut self, k: usize) -> Result<(), SceneError> {
        let o = self.object(k);
        let what = format!("{} at {}", o.describe(), o.loc);
        let file_of = |b: &Self| -> Result<std::path::PathBuf, SceneError> {
            let p = o.prop("filename").ok_or_else(|| {
                err(
                    &o.loc,
                    format!("{} needs <string name=\"filename\">", o.describe()),
                )
            })?;
            let name = o.string("filename")?.unwrap_or_default();
            let dir = Path::new(&*p.loc.file).parent().unwrap_or(Path::new(""));
            let main = Path::new(&b.file).parent().unwrap_or(Path::new(""));
            Ok(xml::resolve_in(dir, &[main.to_path_buf()], name))
        };
        use std::path::Path;
        let (mesh, file_mesh, analytic_to_local) = match o.plugin.as_str() {
            "obj" => {
                let (path, flip) = (file_of(self)?, o.boolean("flip_tex_coords", true)?);
                let job = Job::Obj(path, flip);
                let mesh = match self.prefetched.take_mesh(k, &job) {
                    Some(mesh) => mesh?,
                    None => meshes::read_obj(job.path(), &what, flip)?,
                };
                (mesh, true, DMat4::IDENTITY)
            }
            "ply" => {
                let (path, flip) = (file_of(self)?, o.boolean("flip_tex_coords", false)?);
                let job = Job::Ply(path, flip);
                let mesh = match self.prefetched.take_mesh(k, &job) {
                    Some(mesh) => mesh?,
                    None => meshes::read_ply(job.path(), &what, flip)?,
                };
                (mesh, true, DMat4::IDENTITY)
            }
            "serialized" => {
                let (index, at) = o.integer("shape_index", 0)?;
                let index = u64::try_from(index).map_err(|_| {
                    err(
                        &at.map_or(o.loc.clone(), |p| p.loc.clone()),
                        format!("shape_index {index} must be >= 0"),
                    )
                })?;
                let mesh = meshes::read_serialized(
                    &file_of(self)?,
                    &what,
                    index,
                    o.boolean("flip_tex_coords", false)?,
                )?;
                (mesh, true, DMat4::IDENTITY)
            }
            "rectangle" => (rectangle(), false, DMat4::IDENTITY),
            "cube" => (cube(), false, DMat4::IDENTITY),
            "sphere" => {
                let c = o.vector("center")?.map_or(DVec3::ZERO, DVec3::from);
                let r = o.float("radius", 1.0)?;
                if r <= 0.0 {
                    return Err(err(
                        &o.loc,
                        format!("{}: radius {r} must be > 0", o.describe()),
                    ));
                }
                self.note_at(
                    &o.loc,
                    format!(
                        "<shape type=\"sphere\"> tessellated into {} triangles (its area kept)",
                        sphere().faces.len()
                    ),
                );
                (
                    sphere(),
                    false,
                    DMat4::from_translation(c) * DMat4::from_scale(DVec3::splat(r)),
                )
            }
            "disk" => {
                self.note_at(&o.loc, format!("<shape type=\"disk\"> tessellated into {SEGMENTS} triangles (its area kept)"));
                (disk(), false, DMat4::IDENTITY)
            }
            "cylinder" => {
                let p0 = o.vector("p0")?.map_or(DVec3::ZERO, DVec3::from);
                let p1 = o.vector("p1")?.map_or(DVec3::Z, DVec3::from);
                let r = o.float("radius", 1.0)?;
                let axis = p1 - p0;
                let len = axis.length();
                let Some(dir) = axis.try_normalize().filter(|_| r > 0.0) else {
                    return Err(err(
                        &o.loc,
                        format!("{}: p0 = p1 or radius {r} <= 0", o.describe()),
                    ));
                };
                let (t, b) = dir.any_orthonormal_pair();
                let frame = DMat4::from_cols(
                    t.extend(0.0),
                    b.extend(0.0),
                    dir.extend(0.0),
                    p0.extend(1.0),
                );
                self.note_at(&o.loc, format!("<shape type=\"cylinder\"> tessellated into {} triangles (its area kept; open ends, as Mitsuba's)", 2 * SEGMENTS));
                (
                    cylinder(),
                    false,
                    frame * DMat4::from_scale(DVec3::new(r, r, len)),
                )
            }
            "shapegroup" | "instance" => {
                return Err(Builder::unsupported(
                    o,
                    "shape groups and instances are not read: export the shapes themselves",
                ));
            }
            _ => return Err(Builder::unsupported(o, "")),
        };
        let to_world = o.transform("to_world")? * analytic_to_local;
        if !(to_world.is_finite() && is_affine(&to_world))
            || DMat3::from_mat4(to_world).determinant() == 0.0
        {
            return Err(err(
                &o.loc,
                format!(
                    "{}: to_world is not an invertible affine transform",
                    o.describe()
                ),
            ));
        }
        let flip_normals = o.boolean("flip_normals", false)?;
        let face_normals = o.boolean("face_normals", false)?;
        // Sub-objects: the BSDF, an area emitter; anything else refuses the shape.
        let mut bsdf = None;
        let mut emitter = None;
        let mut interior = None;
        let mut capture_meter = None;
        for (p, c) in o.children() {
            p.used.set(true);
            let child = self.object(c);
            match child.tag {
                "sensor" if child.plugin == "nlos_capture_meter" => capture_meter = Some(c),
                "bsdf" | "texture" if child.tag == "bsdf" => {
                    if bsdf.is_some() {
                        self.note_at(&child.loc, "a second <bsdf> of a shape ignored".into());
                    } else {
                        bsdf = Some(c);
                    }
                }
                "emitter" if child.plugin == "area" || child.plugin == "angulararea" => {
                    emitter = Some(self.area_emitter(c)?);
                }
                "emitter" => {
                    return Err(err(
                        &child.loc,
                        format!(
                            "{} inside a shape: only an area emitter can be",
                            child.describe()
                        ),
                    ));
                }
                "medium" if p.name == "interior" => interior = Some(c),
                "medium" => {
                    let what = format!(
                        "{} named \"{}\" of a shape taken to be the scene's medium (the sensor's): tprf's media are a shape's interior and the scene's",
                        child.describe(),
                        p.name
                    );
                    self.note_at(&child.loc, what);
                }
                _ => {
                    return Err(err(
                        &child.loc,
                        format!(
                            "{} inside {} is not supported",
                            child.describe(),
                            o.describe()
                        ),
                    ));
                }
            }
        }
        let slot = self.material(bsdf, emitter, interior)?;
        let _ = file_mesh;
        let first = self.triangles.len();
        self.place(mesh, &to_world, flip_normals, face_normals, slot, &what)?;
        // The relay wall of an NLOS capture: named by its id, else `relay_wall`.
        if let Some(meter) = capture_meter {
            let (name, from) = match &o.id {
                Some(id) => (id.clone(), format!("{} {} id", o.loc, o.describe())),
                None => (
                    "relay_wall".to_string(),
                    format!("{} {} (no id)", o.loc, o.describe()),
                ),
            };
            // Mitsuba parameterises a rectangle's [-1, 1]^2 by its film's pixels.
            let rectangle = (o.plugin == "rectangle").then_some(to_world);
            self.read_capture_meter(meter, &name, from, rectangle)?;
            if o.id.is_none() {
                self.objects.push(SceneObject {
                    name,
                    triangles: first..self.triangles.len(),
                });
            }
        }
        // A shape's id names it, as a glTF node's name does (what NLOS captures find a
        // relay wall by).
        if let Some(id) = &o.id {
            self.objects.push(SceneObject {
                name: id.clone(),
                triangles: first..self.triangles.len(),
            });
        }
        Ok(())
    }

    /// Add `mesh` (object space) through `to_world` with material `slot`.
    fn place(
        &mut self,
        mesh: Mesh,
        to_world: &DMat4,
        flip_normals: bool,
        face_normals: bool,
        slot: MaterialSlot,
        what: &str,
    ) -> Result<(), SceneError> {
        let count = mesh.faces.len();
        let total = (self.triangles.len() + count) as u64;
        // The scene's triangles so far against the budget, asked again only when they
        // grow by an eighth (at least 1 MiB) past the last answer: reading the limits
        // for each of 100 000 shapes took longer than placing them.
        let need_bytes = total.saturating_mul(BYTES_PER_TRIANGLE);
        if need_bytes > self.budget_unchecked_to {
            budget::check(
                need_bytes,
                &format!("scene {}", self.file),
                format_args!("{} triangles", format_count(total)),
            )?;
            self.budget_unchecked_to = need_bytes.saturating_add((need_bytes / 8).max(1 << 20));
        }
        if self.triangles.try_reserve(count).is_err() || self.attrs.try_reserve(count).is_err() {
            return Err(SceneError::Invalid(format!(
                "{what}: cannot allocate {count} triangles"
            )));
        }
        let positions: Vec<Vec3> = mesh
            .positions
            .iter()
            .map(|p| to_world.transform_point3(p.as_dvec3()).as_vec3())
            .collect();
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(SceneError::Invalid(format!(
                "{what}: vertex {i} is not finite in world space"
            )));
        }
        let normal_matrix = DMat3::from_mat4(*to_world).inverse().transpose();
        let sign = if flip_normals { -1.0 } else { 1.0 };
        let normals: Option<Vec<Option<Vec3>>> = if face_normals {
            None
        } else {
            Some(match &mesh.normals {
                Some(ns) => ns
                    .iter()
                    .map(|n| {
                        (normal_matrix * n.as_dvec3() * sign)
                            .try_normalize()
                            .map(|n| n.as_vec3())
                    })
                    .collect(),
                None => vertex_normals(&positions, &mesh.faces)
                    .into_iter()
                    .map(|n| n.map(|n| n * sign as f32))
                    .collect(),
            })
        };
        let reverse = (DMat3::from_mat4(*to_world).determinant() < 0.0) != flip_normals;
        let uv_of = |uv: Vec2| -> Vec2 {
            match slot.to_uv {
                Some(t) => t.transform_point2(uv.as_dvec2()).as_vec2(),
                None => uv,
            }
        };
        let mut bad_normals = 0usize;
        for f in &mesh.faces {
            let f = if reverse { [f[0], f[2], f[1]] } else { *f };
            let [a, b, c] = f.map(|i| i as usize);
            if a.max(b).max(c) >= positions.len() {
                return Err(SceneError::Invalid(format!(
                    "{what}: a face indexes past its {} vertices",
                    positions.len()
                )));
            }
            let triangle = Triangle {
                p: [positions[a], positions[b], positions[c]],
            };
            if is_degenerate(&triangle) {
                self.degenerate += 1;
                continue;
            }
            let n = normals
                .as_ref()
                .and_then(|ns| Some([ns[a]?, ns[b]?, ns[c]?]));
            bad_normals += usize::from(normals.is_some() && n.is_none());
            let uv = mesh
                .uvs
                .as_ref()
                .map_or([Vec2::ZERO; 3], |us| [us[a], us[b], us[c]].map(uv_of));
            self.triangles.push(triangle);
            self.attrs.push(TriangleAttrs {
                normals: n,
                uv,
                material: slot.index,
            });
        }
        if bad_normals > 0 {
            self.notes.push(format!(
                "{what}: {bad_normals} triangles have zero vertex normals: shaded with their geometric normal"
            ));
        }
        Ok(())
    }
}

/// A `to_uv` transform (4 x 4 in the file) as the 2-D affine map Mitsuba takes from it.
pub(super) fn uv_transform(m: &DMat4) -> DAffine2 {
    DAffine2::from_cols(
        DVec2::new(m.x_axis.x, m.x_axis.y),
        DVec2::new(m.y_axis.x, m.y_axis.y),
        DVec2::new(m.w_axis.x, m.w_axis.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tessellations_keep_the_area_and_face_out() {
        let s = sphere();
        // Positions are f32: the area is kept to their precision.
        assert!((mesh_area(&s) / (4.0 * PI) - 1.0).abs() < 1e-6);
        let d = disk();
        assert!((mesh_area(&d) / PI - 1.0).abs() < 1e-6);
        let c = cylinder();
        assert!((mesh_area(&c) / TAU - 1.0).abs() < 1e-6);
        for m in [s, d, c, cube(), rectangle()] {
            // Every face's winding agrees with its vertex normals.
            for f in &m.faces {
                let [a, b, cc] = f.map(|i| m.positions[i as usize]);
                let n = (b - a).cross(cc - a);
                let vn = m.normals.as_ref().unwrap()[f[0] as usize];
                assert!(n.dot(vn) > 0.0, "face {f:?}");
            }
        }
        assert!((mesh_area(&cube()) - 24.0).abs() < 1e-9);
        assert!((mesh_area(&rectangle()) - 4.0).abs() < 1e-9);
    }

    #[test]
    fn vertex_normals_of_a_flat_quad_are_its_normal() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let n = vertex_normals(&p, &[[0, 1, 2], [0, 2, 3]]);
        assert!(
            n.iter()
                .all(|n| n.is_some_and(|n| n.abs_diff_eq(Vec3::Z, 1e-6)))
        );
    }
}

//! The [`Scene`] from a checked document: node trees walked depth first with their
//! transforms, triangle primitives (lists, strips, fans) in world space, punctual lights,
//! the first perspective camera, and what the file lacks (a camera, a light) added with a
//! note.

use super::decode::Encoding;
use super::validate::{SUPPORTED_EXTENSIONS, check_accessor, check_count, invalid, read_all};
use crate::budget::{self, format_count};
use crate::scene::{
    AmbientLights, BYTES_PER_TRIANGLE, Camera, DirectionalLight, Material, Medium, PunctualLight,
    Scene, SceneError, SceneObject, Spot, Texture, Triangle, TriangleAttrs,
};
use glam::{Affine3A, Mat3, Mat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::khr_lights_punctual::Kind;
use gltf::mesh::Mode;
use gltf::{Document, buffer};
use std::collections::HashMap;
use std::path::Path;

/// Vertical field of view of a camera framed from the scene bounds.
const FRAMED_YFOV_RAD: f32 = std::f32::consts::FRAC_PI_4;

/// An object's name, or `kind[index]` when it has none.
pub(super) fn name_or_index(name: Option<&str>, kind: &str, index: usize) -> String {
    name.map_or_else(|| format!("{kind}[{index}]"), String::from)
}

/// A primitive's vertices in world space (metres), before assembly into triangles.
struct Vertices {
    positions: Vec<Vec3>,
    /// Unit world-space normals; `None` where the file's normal is zero or not finite.
    normals: Option<Vec<Option<Vec3>>>,
    uvs: Option<Vec<Vec2>>,
}

/// The three entries of `values` at `corners`, or `None` if a corner is out of range.
fn gather<T: Copy>(values: &[T], corners: [u32; 3]) -> Option<[T; 3]> {
    let [a, b, c] = corners.map(|i| values.get(i as usize).copied());
    Some([a?, b?, c?])
}

/// Vertex-index triples of a primitive's triangles, in glTF's winding (counter-clockwise
/// front face), following the spec's rules for strips and fans.
fn triangle_corners(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::TriangleStrip => indices
            .windows(3)
            .enumerate()
            .map(|(i, w)| match i % 2 {
                0 => [w[0], w[1], w[2]],
                _ => [w[0], w[2], w[1]],
            })
            .collect(),
        Mode::TriangleFan => match indices.split_first() {
            Some((&first, rest)) => rest.windows(2).map(|w| [w[0], w[1], first]).collect(),
            None => Vec::new(),
        },
        _ => indices.as_chunks::<3>().0.to_vec(),
    }
}

/// The size of a triangle primitive from its accessors' counts, before anything is read.
struct PrimitiveSize {
    vertices: u64,
    indices: u64,
    triangles: u64,
}

impl PrimitiveSize {
    /// Bytes held while the primitive is read: per vertex its position, normal and UV as
    /// read and in world space (12 + 12 + 12 + 16 + 8 + 8), per index 4, per triangle its
    /// corners (12).
    fn read_bytes(&self) -> u64 {
        self.vertices
            .saturating_mul(68)
            .saturating_add(self.indices.saturating_mul(4))
            .saturating_add(self.triangles.saturating_mul(12))
    }
}

/// A triangle primitive's size (`None` for points and lines, or without POSITION).
fn primitive_size(prim: &gltf::Primitive) -> Option<PrimitiveSize> {
    let vertices = prim.get(&gltf::Semantic::Positions)?.count() as u64;
    let indices = prim.indices().map_or(vertices, |a| a.count() as u64);
    let triangles = match prim.mode() {
        Mode::Triangles => indices / 3,
        Mode::TriangleStrip | Mode::TriangleFan => indices.saturating_sub(2),
        _ => return None,
    };
    Some(PrimitiveSize {
        vertices,
        indices,
        triangles,
    })
}

/// The POSITION and index accessors of a triangle primitive: types and spans, as
/// [`Builder::read_vertices`] and [`Builder::read_indices`] check them before reading.
fn check_primitive_accessors(prim: &gltf::Primitive) -> Result<(), String> {
    if let Some(acc) = prim.get(&gltf::Semantic::Positions) {
        check_accessor(&acc, &[DataType::F32], Dimensions::Vec3)?;
    }
    if let Some(acc) = prim.indices() {
        let types = [DataType::U8, DataType::U16, DataType::U32];
        check_accessor(&acc, &types, Dimensions::Scalar)?;
    }
    Ok(())
}

/// Zero area up to f32 rounding: the height over the longest edge is below 1e-7 of that
/// edge's length (or the area overflows to NaN).
fn is_degenerate(t: &Triangle) -> bool {
    let [p0, p1, p2] = t.p;
    let longest_sq = (p1 - p0)
        .length_squared()
        .max((p2 - p0).length_squared())
        .max((p2 - p1).length_squared());
    let twice_area = (p1 - p0).cross(p2 - p0).length();
    twice_area.is_nan() || twice_area <= 1e-7 * longest_sq
}

/// The camera of a camera node with world transform `world`; an orthographic one gives the
/// note to print instead.
fn file_camera(camera: &gltf::Camera, world: &Mat4, file: &str) -> Result<Camera, String> {
    match camera.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let (_scale, rotation, translation) = world.to_scale_rotation_translation();
            Ok(Camera {
                world_from_camera: Affine3A::from_rotation_translation(rotation, translation),
                fov_rad: p.yfov(),
                fov_axis: crate::scene::FovAxis::Y,
                near_m: p.znear(),
            })
        }
        gltf::camera::Projection::Orthographic(_) => Err(format!(
            "camera '{}' in {file} is orthographic, which tprf does not render: framed a perspective one from the scene bounds",
            name_or_index(camera.name(), "cameras", camera.index())
        )),
    }
}

/// The roots to load: the default scene's, else scene 0's, else every node without a parent
/// (`None`).
fn scene_roots<'a>(doc: &'a Document) -> Option<Vec<gltf::Node<'a>>> {
    let scene = doc.default_scene().or_else(|| doc.scenes().next())?;
    Some(scene.nodes().collect())
}

/// The `"tprf"` object of an element's glTF extras, if any (`None` without extras or
/// without the key); extras that are not JSON objects are ignored, a `"tprf"` that is not
/// an object is refused, naming `what`.
pub(super) fn tprf_extras(
    extras: &gltf::json::Extras,
    file: &str,
    what: &str,
) -> Result<Option<serde_json::Map<String, serde_json::Value>>, SceneError> {
    let Some(raw) = extras.as_ref() else {
        return Ok(None);
    };
    let Ok(serde_json::Value::Object(mut map)) = serde_json::from_str(raw.get()) else {
        return Ok(None);
    };
    match map.remove("tprf") {
        None => Ok(None),
        Some(serde_json::Value::Object(t)) => Ok(Some(t)),
        Some(v) => Err(invalid(
            file,
            format!("{what} extras \"tprf\" = {v}: expected an object"),
        )),
    }
}

/// Every node that is no other node's child.
fn parentless_nodes(doc: &Document) -> Vec<gltf::Node<'_>> {
    let mut is_child = vec![false; doc.nodes().len()];
    for child in doc.nodes().flat_map(|n| n.children()) {
        if let Some(flag) = is_child.get_mut(child.index()) {
            *flag = true;
        }
    }
    doc.nodes()
        .filter(|n| !is_child.get(n.index()).copied().unwrap_or(true))
        .collect()
}

/// Accumulates the scene while the node tree is walked.
pub(super) struct Builder<'a> {
    pub(super) file: &'a str,
    pub(super) doc: &'a Document,
    pub(super) buffers: &'a [buffer::Data],
    pub(super) base: &'a Path,
    pub(super) triangles: Vec<Triangle>,
    pub(super) attrs: Vec<TriangleAttrs>,
    pub(super) materials: Vec<Material>,
    /// Scene material of each glTF material used so far (`None` key: the default material).
    pub(super) material_of: HashMap<Option<usize>, u32>,
    pub(super) textures: Vec<Texture>,
    /// Scene texture of each glTF image decoded so far: key `(image, None)` for an image
    /// kept whole (the same texels whatever it encodes), `(image, Some(encoding))` for a
    /// reduced one (its block means depend on whether it is sRGB colour).
    pub(super) texture_of_image: HashMap<(usize, Option<Encoding>), u32>,
    pub(super) lights: Vec<PunctualLight>,
    /// Directional lights, point/spot lights tagged ambient, the sky.
    pub(super) ambient: AmbientLights,
    /// The scene-wide medium of the scene's extras.
    pub(super) medium: Option<Medium>,
    /// The first camera node met, with its world transform.
    pub(super) camera: Option<(gltf::Camera<'a>, Mat4)>,
    pub(super) notes: Vec<String>,
    pub(super) degenerate: usize,
    pub(super) bad_normals: usize,
    /// Named nodes with meshes and their triangles.
    pub(super) objects: Vec<SceneObject>,
}

impl<'a> Builder<'a> {
    pub(super) fn new(
        file: &'a str,
        doc: &'a Document,
        buffers: &'a [buffer::Data],
        base: &'a Path,
    ) -> Self {
        Builder {
            file,
            doc,
            buffers,
            base,
            triangles: Vec::new(),
            attrs: Vec::new(),
            materials: Vec::new(),
            material_of: HashMap::new(),
            textures: Vec::new(),
            texture_of_image: HashMap::new(),
            lights: Vec::new(),
            ambient: AmbientLights::default(),
            medium: None,
            camera: None,
            notes: Vec::new(),
            degenerate: 0,
            bad_normals: 0,
            objects: Vec::new(),
        }
    }

    pub(super) fn note_once(&mut self, note: String) {
        if !self.notes.contains(&note) {
            self.notes.push(note);
        }
    }

    /// Name the extensions the file uses (without requiring them) that tprf ignores.
    pub(super) fn note_ignored_extensions(&mut self) {
        let ignored: Vec<&str> = self
            .doc
            .extensions_used()
            .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
            .collect();
        if !ignored.is_empty() {
            let note = format!(
                "{} uses extensions tprf ignores: {}",
                self.file,
                ignored.join(", ")
            );
            self.notes.push(note);
        }
    }

    /// Walk the scene's node trees depth first, composing transforms from the roots down:
    /// first to count the triangles after instancing against the memory budget, then to
    /// add them.
    pub(super) fn add_scene(&mut self) -> Result<(), SceneError> {
        let instances = self.instances()?;
        let triangles = self.check_triangle_budget(&instances)?;
        let reserve = self
            .triangles
            .try_reserve_exact(triangles)
            .and_then(|()| self.attrs.try_reserve_exact(triangles));
        if reserve.is_err() {
            let m = format!("cannot allocate {triangles} triangles");
            return Err(invalid(self.file, m));
        }
        for (node, world) in &instances {
            self.add_node(node, world)?;
        }
        Ok(())
    }

    /// Every node of the scene with its world transform, depth first (the order triangles
    /// are added in).
    fn instances(&mut self) -> Result<Vec<(gltf::Node<'a>, Mat4)>, SceneError> {
        let roots = match scene_roots(self.doc) {
            Some(roots) => roots,
            None => {
                self.notes
                    .push(format!("no scene in {}: loaded every root node", self.file));
                parentless_nodes(self.doc)
            }
        };
        let mut visited = vec![false; self.doc.nodes().len()];
        let mut stack: Vec<(gltf::Node, Mat4)> = roots
            .into_iter()
            .rev()
            .map(|n| (n, Mat4::IDENTITY))
            .collect();
        let mut out = Vec::new();
        while let Some((node, parent)) = stack.pop() {
            match visited.get_mut(node.index()) {
                Some(seen) if !*seen => *seen = true,
                _ => {
                    return Err(invalid(
                        self.file,
                        format!(
                            "nodes[{}] is reached twice: glTF nodes must form trees (a cycle, or a child with two parents)",
                            node.index()
                        ),
                    ));
                }
            }
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            if !world.is_finite() {
                let msg = format!("nodes[{}] has a non-finite world transform", node.index());
                return Err(invalid(self.file, msg));
            }
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
            out.push((node, world));
        }
        Ok(out)
    }

    /// Count the triangles of `instances` (every mesh instance's primitives, from their
    /// accessors' counts, before any is read) and refuse them when what they need does
    /// not fit in memory: [`BYTES_PER_TRIANGLE`] each to load and render, plus the largest
    /// primitive's vertices and indices while it is read. The number of triangles.
    fn check_triangle_budget(&self, instances: &[(gltf::Node, Mat4)]) -> Result<usize, SceneError> {
        let (mut triangles, mut transient, mut placed) = (0u64, 0u64, 0u64);
        for (node, _) in instances {
            let Some(mesh) = node.mesh() else { continue };
            placed += 1;
            for prim in mesh.primitives() {
                let Some(size) = primitive_size(&prim) else {
                    continue;
                };
                // Counts that overrun their buffer views are refused as such, not budgeted.
                check_primitive_accessors(&prim).map_err(|m| {
                    let what = format!("meshes[{}] primitive {}", mesh.index(), prim.index());
                    invalid(self.file, format!("{what}: {m}"))
                })?;
                triangles = triangles.saturating_add(size.triangles);
                transient = transient.max(size.read_bytes());
            }
        }
        let purpose = format!(
            "{} triangles after instancing ({placed} mesh instance{})",
            format_count(triangles),
            if placed == 1 { "" } else { "s" }
        );
        if triangles > u64::from(u32::MAX) {
            let m = format!("{purpose}: more than the {} a scene may hold", u32::MAX);
            return Err(invalid(self.file, m));
        }
        let need = triangles
            .saturating_mul(BYTES_PER_TRIANGLE)
            .saturating_add(transient);
        budget::check(need, &format!("scene {}", self.file), purpose)?;
        Ok(triangles as usize)
    }

    fn add_node(&mut self, node: &gltf::Node<'a>, world: &Mat4) -> Result<(), SceneError> {
        if node.skin().is_some() {
            self.note_once(
                "skins ignored: skinned meshes are placed by their node transform".into(),
            );
        }
        if let Some(mesh) = node.mesh() {
            let first = self.triangles.len();
            for prim in mesh.primitives() {
                self.add_primitive(&mesh, &prim, world)?;
            }
            // The node's name, else its mesh's: what NLOS captures find a relay wall by.
            if let Some(name) = node.name().or(mesh.name()) {
                self.objects.push(SceneObject {
                    name: name.to_string(),
                    triangles: first..self.triangles.len(),
                });
            }
        }
        if let Some(camera) = node.camera() {
            self.camera.get_or_insert((camera, *world));
        }
        if let Some(light) = node.light() {
            let ambient = tprf_extras(
                node.extras(),
                self.file,
                &format!("nodes[{}]", node.index()),
            )?
            .and_then(|t| t.get("ambient").cloned());
            let ambient = match ambient {
                None => false,
                Some(serde_json::Value::Bool(b)) => b,
                Some(v) => {
                    let m = format!(
                        "nodes[{}] extras tprf.ambient = {v}: expected true or false",
                        node.index()
                    );
                    return Err(invalid(self.file, m));
                }
            };
            self.add_light(&light, world, ambient)?;
        }
        Ok(())
    }

    /// Add a primitive's triangles in world space; `world` is its node's world transform.
    fn add_primitive(
        &mut self,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        world: &Mat4,
    ) -> Result<(), SceneError> {
        let what = match mesh.name() {
            Some(name) => format!("mesh '{name}' (meshes[{}])", mesh.index()),
            None => format!("meshes[{}]", mesh.index()),
        };
        let what = format!("{what} primitive {}", prim.index());
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.note_once(format!(
                "{mode:?} primitives skipped: tprf renders triangles only"
            ));
            return Ok(());
        }
        if prim.morph_targets().next().is_some() {
            self.note_once("morph targets ignored: meshes keep their base shape".into());
        }
        let file = self.file;
        let err = |m: String| invalid(file, format!("{what}: {m}"));
        let vertices = self.read_vertices(prim, world).map_err(err)?;
        let indices = self
            .read_indices(prim, vertices.positions.len())
            .map_err(err)?;
        let material = self.material_index(&prim.material())?;
        let flip = Mat3::from_mat4(*world).determinant() < 0.0;
        for corners in triangle_corners(mode, &indices) {
            self.add_triangle(&vertices, corners, flip, material)
                .map_err(err)?;
        }
        Ok(())
    }

    /// POSITION (required, finite), NORMAL and TEXCOORD_0, transformed to world space.
    fn read_vertices(&self, prim: &gltf::Primitive, world: &Mat4) -> Result<Vertices, String> {
        let reader = prim.reader(|b| self.buffers.get(b.index()).map(|d| &d.0[..]));
        let pos_acc = prim.get(&gltf::Semantic::Positions).ok_or("no POSITION")?;
        check_accessor(&pos_acc, &[DataType::F32], Dimensions::Vec3)?;
        let positions = read_all(reader.read_positions(), &pos_acc)?;
        if let Some((i, p)) = positions
            .iter()
            .enumerate()
            .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
        {
            return Err(format!("POSITION {i} is not finite ({p:?})"));
        }
        let count = positions.len();
        let normals = prim.get(&gltf::Semantic::Normals).map(|acc| {
            check_accessor(&acc, &[DataType::F32], Dimensions::Vec3)?;
            check_count(&acc, "NORMAL", count)?;
            read_all(reader.read_normals(), &acc)
        });
        let uvs = prim.get(&gltf::Semantic::TexCoords(0)).map(|acc| {
            let types = [DataType::F32, DataType::U8, DataType::U16];
            check_accessor(&acc, &types, Dimensions::Vec2)?;
            check_count(&acc, "TEXCOORD_0", count)?;
            read_all(reader.read_tex_coords(0).map(|t| t.into_f32()), &acc)
        });
        let (normals, uvs) = (normals.transpose()?, uvs.transpose()?);
        let normal_matrix = Mat3::from_mat4(*world).inverse().transpose();
        Ok(Vertices {
            positions: positions
                .into_iter()
                .map(|p| world.transform_point3(p.into()))
                .collect(),
            normals: normals.map(|ns| {
                ns.into_iter()
                    .map(|n| (normal_matrix * Vec3::from(n)).try_normalize())
                    .collect()
            }),
            uvs: uvs.map(|uvs| uvs.into_iter().map(Vec2::from).collect()),
        })
    }

    /// The primitive's index list, or `0..vertex_count` for a non-indexed primitive.
    fn read_indices(
        &self,
        prim: &gltf::Primitive,
        vertex_count: usize,
    ) -> Result<Vec<u32>, String> {
        let Some(acc) = prim.indices() else {
            let n = u32::try_from(vertex_count)
                .map_err(|_| format!("{vertex_count} vertices: more than u32 indices reach"))?;
            return Ok((0..n).collect());
        };
        let types = [DataType::U8, DataType::U16, DataType::U32];
        check_accessor(&acc, &types, Dimensions::Scalar)?;
        let reader = prim.reader(|b| self.buffers.get(b.index()).map(|d| &d.0[..]));
        read_all(reader.read_indices().map(|i| i.into_u32()), &acc)
    }

    /// Add one triangle (vertex indices `corners`), dropping it if degenerate; `flip` reverses
    /// the winding (a mirroring transform) so the front face stays counter-clockwise.
    fn add_triangle(
        &mut self,
        v: &Vertices,
        corners: [u32; 3],
        flip: bool,
        material: u32,
    ) -> Result<(), String> {
        let [a, b, c] = corners;
        let corners = if flip { [a, c, b] } else { corners };
        let Some(p) = gather(&v.positions, corners) else {
            let bad = corners
                .into_iter()
                .find(|&i| i as usize >= v.positions.len());
            return Err(format!(
                "vertex index {} is out of range: the primitive has {} vertices",
                bad.unwrap_or_default(),
                v.positions.len()
            ));
        };
        let triangle = Triangle { p };
        if is_degenerate(&triangle) {
            self.degenerate += 1;
            return Ok(());
        }
        let normals = v.normals.as_ref().and_then(|ns| {
            let [x, y, z] = gather(ns, corners)?;
            Some([x?, y?, z?])
        });
        self.bad_normals += usize::from(v.normals.is_some() && normals.is_none());
        let uv = v.uvs.as_ref().and_then(|uvs| gather(uvs, corners));
        self.triangles.push(triangle);
        self.attrs.push(TriangleAttrs {
            normals,
            uv: uv.unwrap_or([Vec2::ZERO; 3]),
            material,
        });
        Ok(())
    }

    /// Add a KHR_lights_punctual light at its node (world transform `world`); intensity in
    /// W/sr is `color x intensity` (no 683 lm/W factor, DESIGN.md). A directional light
    /// (irradiance `color x intensity` W/m^2 along the node's -Z) and a point or spot
    /// light whose node is tagged `ambient` go to the ambient group.
    fn add_light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        world: &Mat4,
        ambient: bool,
    ) -> Result<(), SceneError> {
        let name = name_or_index(light.name(), "lights", light.index());
        let spot = match light.kind() {
            Kind::Directional => {
                let direction = world.transform_vector3(Vec3::NEG_Z).try_normalize();
                let direction = direction.ok_or_else(|| {
                    invalid(
                        self.file,
                        format!(
                            "directional light '{name}': its node's transform has no -Z direction (zero scale?)"
                        ),
                    )
                })?;
                let intensity = light.intensity();
                self.ambient.directional.push(DirectionalLight {
                    name,
                    direction,
                    irradiance_w_per_m2: light.color().map(|c| c * intensity),
                });
                return Ok(());
            }
            Kind::Point => None,
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let direction = world.transform_vector3(Vec3::NEG_Z).try_normalize();
                let direction = direction.ok_or_else(|| {
                    invalid(
                        self.file,
                        format!("spot light '{name}': its node's transform has no -Z direction"),
                    )
                })?;
                Some(Spot {
                    direction,
                    inner_cone_rad: inner_cone_angle,
                    outer_cone_rad: outer_cone_angle,
                })
            }
        };
        let intensity = light.intensity();
        let light = PunctualLight {
            name,
            position: world.transform_point3(Vec3::ZERO),
            intensity_w_per_sr: light.color().map(|c| c * intensity),
            spot,
            projector: None,
        };
        if ambient {
            self.ambient.lights.push(light);
        } else {
            self.lights.push(light);
        }
        Ok(())
    }

    /// The sky radiance of the scene's extras `{"tprf": {"sky_radiance": L}}` (a number
    /// or `[r, g, b]`, W m^-2 sr^-1) and the scene-wide medium `{"tprf": {"medium":
    /// {...}}}` ([`Medium::from_json`]), when given.
    pub(super) fn read_scene_extras(&mut self) -> Result<(), SceneError> {
        let Some(scene) = self
            .doc
            .default_scene()
            .or_else(|| self.doc.scenes().next())
        else {
            return Ok(());
        };
        let what = format!("scenes[{}]", scene.index());
        let Some(tprf) = tprf_extras(scene.extras(), self.file, &what)? else {
            return Ok(());
        };
        if let Some(v) = tprf.get("sky_radiance") {
            let rgb = match v {
                serde_json::Value::Number(n) => n.as_f64().map(|x| [x; 3]),
                serde_json::Value::Array(a) if a.len() == 3 => {
                    let c: Option<Vec<f64>> = a.iter().map(|x| x.as_f64()).collect();
                    c.map(|c| [c[0], c[1], c[2]])
                }
                _ => None,
            };
            let rgb = rgb.filter(|c| c.iter().all(|x| x.is_finite() && *x >= 0.0));
            let rgb = rgb.ok_or_else(|| {
                let m = format!(
                    "{what} extras tprf.sky_radiance = {v}: expected a number or [r, g, b], \
                     finite and >= 0 (W m^-2 sr^-1)"
                );
                invalid(self.file, m)
            })?;
            self.ambient.sky_radiance = rgb.map(|x| x as f32);
        }
        if let Some(v) = tprf.get("medium") {
            let what = format!("{what} extras tprf.medium");
            let medium = Medium::from_json(v, [0.0; 3], Some(self.base), &what)
                .map_err(|m| invalid(self.file, m))?;
            self.medium = Some(medium);
        }
        Ok(())
    }

    /// The scene, with a camera and a light added where the file has none, and the counts
    /// of what was dropped noted.
    pub(super) fn finish(self) -> Result<Scene, SceneError> {
        let file = self.file;
        let found_camera = self.camera.map(|(c, world)| file_camera(&c, &world, file));
        let mut scene = Scene {
            name: file.to_string(),
            triangles: self.triangles,
            attrs: self.attrs,
            materials: self.materials,
            textures: self.textures,
            lights: self.lights,
            camera: Camera::look_at(Vec3::Z, Vec3::ZERO, FRAMED_YFOV_RAD),
            ambient: self.ambient,
            objects: self.objects,
            medium: self.medium,
            notes: self.notes,
        };
        if scene.triangles.is_empty() {
            scene.notes.push(format!("no triangles in {file}"));
        }
        scene.fit_density_boxes();
        match found_camera {
            Some(Ok(camera)) => scene.camera = camera,
            Some(Err(note)) => {
                scene.notes.push(note);
                scene.camera = scene.framed_camera(FRAMED_YFOV_RAD);
            }
            None => {
                scene.notes.push(format!(
                    "no camera in {file}: framed one from the scene bounds"
                ));
                scene.camera = scene.framed_camera(FRAMED_YFOV_RAD);
            }
        }
        let emits = scene.attrs.iter().any(|a| {
            scene
                .materials
                .get(a.material as usize)
                .is_some_and(Material::is_emissive)
        });
        if scene.lights.is_empty() && !emits {
            let light = scene.colocated_light();
            scene.notes.push(format!(
                "no light in {file}: added a point light at the camera ({:.3} W/sr: a white Lambertian at the scene centre has radiance ~1)",
                light.intensity_w_per_sr[0]
            ));
            scene.lights.push(light);
        }
        if self.degenerate > 0 {
            scene.notes.push(format!(
                "dropped {} degenerate triangles (zero area)",
                self.degenerate
            ));
        }
        if self.bad_normals > 0 {
            scene.notes.push(format!(
                "{} triangles have zero or non-finite vertex normals: shaded with their geometric normal",
                self.bad_normals
            ));
        }
        scene.validate().map_err(|e| match e {
            SceneError::Invalid(m) => SceneError::Invalid(format!("{file}: {m}")),
            e => e,
        })?;
        Ok(scene)
    }
}

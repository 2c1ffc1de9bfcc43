//! glTF 2.0 import: `.gltf` (external or `data:` buffers and images) and `.glb`.
//!
//! Loads the default scene (else scene 0, else every root node) into a [`Scene`] in world
//! space: metres, point and spot lights in W/sr, emission in W/(m^2 sr) (DESIGN.md's
//! conventions). The `gltf` crate parses, validates and decodes; this module adds the checks
//! that keep a malformed file from panicking inside that crate, and turns every problem into
//! a [`SceneError`] that names it.
//!
//! Read: triangle primitives (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN; indexed or not, sparse
//! accessors too) with POSITION, NORMAL and TEXCOORD_0; node transforms down the hierarchy;
//! metallic-roughness materials with base colour, metallic-roughness and emissive textures,
//! alpha modes and KHR_materials_{specular, transmission, ior, emissive_strength} factors;
//! the first perspective camera; KHR_lights_punctual point and spot lights.
//!
//! Not read (each noted in [`Scene::notes`] when a file has it, except samplers and
//! occlusion): points and lines, directional lights, orthographic cameras, normal maps,
//! the specular and transmission extensions' textures, TEXCOORD sets other than 0, skins and
//! morph targets, samplers (wrap and filter modes), occlusion textures (a path tracer
//! computes occlusion itself).

use super::{
    AlphaMode, Camera, Material, PunctualLight, Scene, SceneError, Spot, Texture, TextureRef,
    Triangle, TriangleAttrs,
};
use glam::{Affine3A, Mat3, Mat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::json::validation::Checked;
use gltf::khr_lights_punctual::Kind;
use gltf::mesh::Mode;
use gltf::{Accessor, Document, buffer, json};
use std::collections::HashMap;
use std::path::Path;

/// Extensions tprf honours; a file that *requires* any other one is refused.
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
];

/// Vertical field of view of a camera framed from the scene bounds.
const FRAMED_YFOV_RAD: f32 = std::f32::consts::FRAC_PI_4;

/// Load a `.gltf` or `.glb` file into a [`Scene`] (metres, W/sr, W/(m^2 sr)).
///
/// What the loader decides on its own (a framed camera, a co-located light, dropped
/// degenerate triangles, ignored features) is listed in [`Scene::notes`].
pub fn load_gltf(path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: file.clone(),
        source,
    })?;
    let (doc, blob) = parse(&file, &bytes)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(&file, &doc, base, blob)?;
    check_views(&file, &doc, &buffers)?;
    let mut builder = Builder::new(&file, &doc, &buffers, base);
    builder.note_ignored_extensions();
    builder.add_scene()?;
    builder.finish()
}

/// A [`SceneError::Gltf`] for `file`.
fn invalid(file: &str, message: impl Into<String>) -> SceneError {
    SceneError::Gltf {
        path: file.to_string(),
        message: message.into(),
    }
}

/// Parse the JSON (and the .glb container), refuse unsupported required extensions, then let
/// the gltf crate validate the document.
fn parse(file: &str, bytes: &[u8]) -> Result<(Document, Option<Vec<u8>>), SceneError> {
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| invalid(file, describe_parse_error(e)))?;
    let mut root = document.into_json();
    check_required_extensions(file, &root)?;
    // All of them are supported (just checked). The crate's own validation would refuse
    // some it parses but does not list as enabled (KHR_materials_specular), so drop them.
    root.extensions_required.clear();
    check_crate_preconditions(&root).map_err(|m| invalid(file, m))?;
    let document = Document::from_json(root).map_err(|e| invalid(file, e.to_string()))?;
    Ok((document, blob))
}

/// A parse error in words: truncated .glb files and bad JSON say so.
fn describe_parse_error(e: gltf::Error) -> String {
    use gltf::binary::Error as Glb;
    match e {
        gltf::Error::Binary(Glb::Length {
            length,
            length_read,
        }) => format!(
            "truncated .glb: its header announces {length} bytes of chunks, the file has {length_read}"
        ),
        gltf::Error::Binary(Glb::ChunkLength {
            ty,
            length,
            length_read,
        }) => format!(
            "truncated .glb: its {ty:?} chunk announces {length} bytes, {length_read} remain"
        ),
        gltf::Error::Binary(Glb::Io(e)) => format!("truncated .glb: {e}"),
        gltf::Error::Binary(e) => format!("corrupt .glb: {e}"),
        gltf::Error::Deserialize(e) => format!("invalid glTF JSON: {e}"),
        e => e.to_string(),
    }
}

/// Refuse a file whose `extensionsRequired` names something tprf cannot honour.
fn check_required_extensions(file: &str, root: &json::Root) -> Result<(), SceneError> {
    let unsupported: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
        .collect();
    if unsupported.is_empty() {
        return Ok(());
    }
    Err(SceneError::UnsupportedExtension {
        path: file.to_string(),
        extension: unsupported.join(", "),
    })
}

/// What the gltf crate (1.4) indexes or unwraps unchecked, in its own validation (POSITION's
/// accessor) or after it passed (images' sources, cameras' projections): check these first,
/// so that such a file gives an error instead of a panic.
fn check_crate_preconditions(root: &json::Root) -> Result<(), String> {
    let accessors = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &prim.attributes {
                if index.value() >= accessors {
                    let name = match semantic {
                        Checked::Valid(s) => s.to_string(),
                        Checked::Invalid => "?".into(),
                    };
                    return Err(format!(
                        "meshes[{m}].primitives[{p}].attributes.{name} is accessor {}, but the file has {accessors} accessors",
                        index.value()
                    ));
                }
            }
        }
    }
    for (i, image) in root.images.iter().enumerate() {
        if image.uri.is_none() && (image.buffer_view.is_none() || image.mime_type.is_none()) {
            return Err(format!(
                "images[{i}] has neither a uri nor a bufferView with a mimeType"
            ));
        }
    }
    for (i, camera) in root.cameras.iter().enumerate() {
        use json::camera::Type;
        let complete = match camera.type_ {
            Checked::Valid(Type::Perspective) => camera.perspective.is_some(),
            Checked::Valid(Type::Orthographic) => camera.orthographic.is_some(),
            Checked::Invalid => true, // the crate's validation reports it
        };
        if !complete {
            return Err(format!(
                "cameras[{i}] lacks the projection object its type names"
            ));
        }
    }
    Ok(())
}

/// An object's name, or `kind[index]` when it has none.
fn name_or_index(name: Option<&str>, kind: &str, index: usize) -> String {
    name.map_or_else(|| format!("{kind}[{index}]"), String::from)
}

/// A short label for a URI in messages (`data:` URIs can be megabytes long).
fn uri_label(uri: &str) -> &str {
    if uri.starts_with("data:") {
        "data: URI"
    } else {
        uri
    }
}

/// The gltf crate unwraps the percent-decoding of a relative URI: refuse one that does not
/// decode to UTF-8 before handing it over.
fn check_uri(uri: &str) -> Result<(), String> {
    if uri.contains(':') || urlencoding::decode(uri).is_ok() {
        Ok(())
    } else {
        Err("its %-escapes do not decode to UTF-8".into())
    }
}

/// An error reading an external buffer or image (`what`, at `uri`): a missing file is a
/// [`SceneError::Io`] naming the path looked for.
fn resource_error(
    file: &str,
    base: &Path,
    what: &str,
    uri: Option<&str>,
    e: gltf::Error,
) -> SceneError {
    match (e, uri) {
        (gltf::Error::Io(source), Some(uri)) => SceneError::Io {
            path: format!("{} ({what} of {file})", base.join(uri).display()),
            source,
        },
        (e, _) => invalid(file, format!("{what}: {e}")),
    }
}

/// Read every buffer (external file, `data:` URI or the .glb BIN chunk).
fn load_buffers(
    file: &str,
    doc: &Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<buffer::Data>, SceneError> {
    doc.buffers()
        .map(|b| load_buffer(file, &b, base, &mut blob))
        .collect()
}

/// Read one buffer, naming it (index and URI) if that fails or it is shorter than declared.
fn load_buffer(
    file: &str,
    buffer: &gltf::Buffer,
    base: &Path,
    blob: &mut Option<Vec<u8>>,
) -> Result<buffer::Data, SceneError> {
    let source = buffer.source();
    let uri = match source {
        buffer::Source::Uri(uri) => Some(uri),
        buffer::Source::Bin => None,
    };
    let what = match uri {
        Some(uri) => format!("buffer {} '{}'", buffer.index(), uri_label(uri)),
        None => format!("buffer {} (the .glb BIN chunk)", buffer.index()),
    };
    if let Some(uri) = uri {
        check_uri(uri).map_err(|m| invalid(file, format!("{what}: {m}")))?;
    }
    let data = buffer::Data::from_source_and_blob(source, Some(base), blob)
        .map_err(|e| resource_error(file, base, &what, uri, e))?;
    if data.len() < buffer.length() {
        return Err(invalid(
            file,
            format!(
                "{what} holds {} bytes, the file declares {}",
                data.len(),
                buffer.length()
            ),
        ));
    }
    Ok(data)
}

/// Every buffer view must lie inside its buffer (the gltf crate slices image views unchecked).
fn check_views(file: &str, doc: &Document, buffers: &[buffer::Data]) -> Result<(), SceneError> {
    for view in doc.views() {
        let have = buffers.get(view.buffer().index()).map_or(0, |d| d.len());
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > have) {
            return Err(invalid(
                file,
                format!(
                    "bufferViews[{}] (bytes {} + {}) overruns buffer {} ({have} bytes)",
                    view.index(),
                    view.offset(),
                    view.length(),
                    view.buffer().index()
                ),
            ));
        }
    }
    Ok(())
}

/// Check that `accessor` holds elements of `dims` with a component type in `types`, and that
/// every byte the gltf crate's reader will touch lies inside its buffer views (the reader
/// panics on a stride below the element size and underflows on a zero count).
fn check_accessor(acc: &Accessor, types: &[DataType], dims: Dimensions) -> Result<(), String> {
    let name = format!("accessors[{}]", acc.index());
    if !types.contains(&acc.data_type()) || acc.dimensions() != dims {
        return Err(format!(
            "{name} holds {:?} of {:?}, expected {dims:?} of one of {types:?}",
            acc.dimensions(),
            acc.data_type()
        ));
    }
    if let Some(view) = acc.view() {
        check_span(&name, &view, acc.offset(), acc.count(), acc.size())?;
    }
    if let Some(sparse) = acc.sparse() {
        let (indices, values) = (sparse.indices(), sparse.values());
        let index_size = indices.index_type().size();
        check_span(
            &format!("{name} (sparse indices)"),
            &indices.view(),
            indices.offset(),
            sparse.count(),
            index_size,
        )?;
        check_span(
            &format!("{name} (sparse values)"),
            &values.view(),
            values.offset(),
            sparse.count(),
            acc.size(),
        )?;
    }
    Ok(())
}

/// `count` (>= 1) elements of `elem` bytes, from byte `offset` of `view` and a stride apart,
/// must fit inside the view.
fn check_span(
    name: &str,
    view: &buffer::View,
    offset: usize,
    count: usize,
    elem: usize,
) -> Result<(), String> {
    let stride = view.stride().unwrap_or(elem);
    if count == 0 {
        return Err(format!("{name} has count 0"));
    }
    if stride < elem {
        return Err(format!(
            "{name}: byteStride {stride} is less than its {elem}-byte elements"
        ));
    }
    let end = (count - 1)
        .checked_mul(stride)
        .and_then(|s| s.checked_add(offset))
        .and_then(|s| s.checked_add(elem));
    match end {
        Some(end) if end <= view.length() => Ok(()),
        _ => Err(format!(
            "{name}: {count} elements from byte {offset} overrun bufferViews[{}] ({} bytes)",
            view.index(),
            view.length()
        )),
    }
}

/// A vertex attribute must have one element per vertex (`count`, POSITION's).
fn check_count(acc: &Accessor, name: &str, count: usize) -> Result<(), String> {
    if acc.count() == count {
        Ok(())
    } else {
        Err(format!(
            "{name} has {} elements, POSITION {count}",
            acc.count()
        ))
    }
}

/// Collect a reader's iterator, checking that it yielded all `acc.count()` elements.
fn read_all<T>(iter: Option<impl Iterator<Item = T>>, acc: &Accessor) -> Result<Vec<T>, String> {
    let values: Vec<T> = iter
        .ok_or_else(|| format!("accessors[{}] cannot be read", acc.index()))?
        .collect();
    if values.len() != acc.count() {
        return Err(format!(
            "accessors[{}] yields {} of its {} elements",
            acc.index(),
            values.len(),
            acc.count()
        ));
    }
    Ok(values)
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

/// Decoded image bytes (any format the gltf crate produces) as an RGBA8 [`Texture`], values
/// as stored (sRGB decoding happens at lookup). `None` if the bytes do not match the size.
fn to_texture(data: gltf::image::Data) -> Option<Texture> {
    use gltf::image::Format as F;
    use image::{DynamicImage as D, ImageBuffer as B};
    let (w, h, px) = (data.width, data.height, data.pixels);
    let u16s = |px: &[u8]| -> Vec<u16> {
        px.as_chunks::<2>()
            .0
            .iter()
            .map(|&b| u16::from_ne_bytes(b))
            .collect()
    };
    let f32s = |px: &[u8]| -> Vec<f32> {
        px.as_chunks::<4>()
            .0
            .iter()
            .map(|&b| f32::from_ne_bytes(b))
            .collect()
    };
    let image = match data.format {
        F::R8 => D::ImageLuma8(B::from_raw(w, h, px)?),
        F::R8G8 => D::ImageLumaA8(B::from_raw(w, h, px)?),
        F::R8G8B8 => D::ImageRgb8(B::from_raw(w, h, px)?),
        F::R8G8B8A8 => D::ImageRgba8(B::from_raw(w, h, px)?),
        F::R16 => D::ImageLuma16(B::from_raw(w, h, u16s(&px))?),
        F::R16G16 => D::ImageLumaA16(B::from_raw(w, h, u16s(&px))?),
        F::R16G16B16 => D::ImageRgb16(B::from_raw(w, h, u16s(&px))?),
        F::R16G16B16A16 => D::ImageRgba16(B::from_raw(w, h, u16s(&px))?),
        F::R32G32B32FLOAT => D::ImageRgb32F(B::from_raw(w, h, f32s(&px))?),
        F::R32G32B32A32FLOAT => D::ImageRgba32F(B::from_raw(w, h, f32s(&px))?),
    };
    let rgba = image.into_rgba8();
    Some(Texture {
        width: w,
        height: h,
        rgba8: rgba.pixels().map(|p| p.0).collect(),
    })
}

/// The camera of a camera node with world transform `world`; an orthographic one gives the
/// note to print instead.
fn file_camera(camera: &gltf::Camera, world: &Mat4, file: &str) -> Result<Camera, String> {
    match camera.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let (_scale, rotation, translation) = world.to_scale_rotation_translation();
            Ok(Camera {
                world_from_camera: Affine3A::from_rotation_translation(rotation, translation),
                yfov_rad: p.yfov(),
            })
        }
        gltf::camera::Projection::Orthographic(_) => Err(format!(
            "camera '{}' in {file} is orthographic, which tprf does not render: framed a perspective one from the scene bounds",
            name_or_index(camera.name(), "cameras", camera.index())
        )),
    }
}

/// A point light at the camera (a LiDAR-style co-located source), bright enough that a white
/// Lambertian facing it at the geometry's centre has radiance ~1 W/(m^2 sr):
/// `I = pi d^2` W/sr, since `L = (1/pi) I / d^2`.
fn colocated_light(scene: &Scene) -> PunctualLight {
    let eye = scene.camera.position();
    let d = scene.geometry_bounds().map_or(1.0, |b| {
        let d = eye.distance(b.center());
        if d > 0.0 { d } else { 0.5 * b.diagonal_m() }
    });
    let d = if d > 0.0 && d.is_finite() { d } else { 1.0 };
    PunctualLight {
        name: "co-located".into(),
        position: eye,
        intensity_w_per_sr: [std::f32::consts::PI * d * d; 3],
        spot: None,
    }
}

/// The roots to load: the default scene's, else scene 0's, else every node without a parent
/// (`None`).
fn scene_roots<'a>(doc: &'a Document) -> Option<Vec<gltf::Node<'a>>> {
    let scene = doc.default_scene().or_else(|| doc.scenes().next())?;
    Some(scene.nodes().collect())
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
struct Builder<'a> {
    file: &'a str,
    doc: &'a Document,
    buffers: &'a [buffer::Data],
    base: &'a Path,
    triangles: Vec<Triangle>,
    attrs: Vec<TriangleAttrs>,
    materials: Vec<Material>,
    /// Scene material of each glTF material used so far (`None` key: the default material).
    material_of: HashMap<Option<usize>, u32>,
    textures: Vec<Texture>,
    /// Scene texture of each glTF image decoded so far.
    texture_of_image: HashMap<usize, u32>,
    lights: Vec<PunctualLight>,
    /// The first camera node met, with its world transform.
    camera: Option<(gltf::Camera<'a>, Mat4)>,
    notes: Vec<String>,
    degenerate: usize,
    bad_normals: usize,
}

impl<'a> Builder<'a> {
    fn new(file: &'a str, doc: &'a Document, buffers: &'a [buffer::Data], base: &'a Path) -> Self {
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
            camera: None,
            notes: Vec::new(),
            degenerate: 0,
            bad_normals: 0,
        }
    }

    fn note_once(&mut self, note: String) {
        if !self.notes.contains(&note) {
            self.notes.push(note);
        }
    }

    /// Name the extensions the file uses (without requiring them) that tprf ignores.
    fn note_ignored_extensions(&mut self) {
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

    /// Walk the scene's node trees depth first, composing transforms from the roots down.
    fn add_scene(&mut self) -> Result<(), SceneError> {
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
            self.add_node(&node, &world)?;
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
        }
        Ok(())
    }

    fn add_node(&mut self, node: &gltf::Node<'a>, world: &Mat4) -> Result<(), SceneError> {
        if node.skin().is_some() {
            self.note_once(
                "skins ignored: skinned meshes are placed by their node transform".into(),
            );
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                self.add_primitive(&mesh, &prim, world)?;
            }
        }
        if let Some(camera) = node.camera() {
            self.camera.get_or_insert((camera, *world));
        }
        if let Some(light) = node.light() {
            self.add_light(&light, world)?;
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
            return Ok((0..vertex_count as u32).collect());
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

    /// The scene material for a glTF material (converted on first use); the glTF default
    /// material (`index() == None`) becomes [`Material::default`].
    fn material_index(&mut self, m: &gltf::Material) -> Result<u32, SceneError> {
        if let Some(&k) = self.material_of.get(&m.index()) {
            return Ok(k);
        }
        let material = match m.index() {
            Some(_) => self.convert_material(m)?,
            None => Material::default(),
        };
        let k = self.materials.len() as u32;
        self.materials.push(material);
        self.material_of.insert(m.index(), k);
        Ok(k)
    }

    /// A glTF material with its textures; factors are linear, emission in W/(m^2 sr).
    fn convert_material(&mut self, m: &gltf::Material) -> Result<Material, SceneError> {
        let pbr = m.pbr_metallic_roughness();
        let specular = m.specular();
        let transmission = m.transmission();
        if m.normal_texture().is_some() {
            self.note_once("normal maps ignored: shading uses the mesh normals".into());
        }
        let ext_textures = specular.as_ref().is_some_and(|s| {
            s.specular_texture().is_some() || s.specular_color_texture().is_some()
        }) || transmission
            .as_ref()
            .is_some_and(|t| t.transmission_texture().is_some());
        if ext_textures {
            self.note_once(
                "specular and transmission textures ignored: their factors are used".into(),
            );
        }
        let strength = m.emissive_strength().unwrap_or(1.0);
        Ok(Material {
            name: name_or_index(m.name(), "materials", m.index().unwrap_or_default()),
            base_color: pbr.base_color_factor(),
            base_color_texture: self.texture(pbr.base_color_texture())?,
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            metallic_roughness_texture: self.texture(pbr.metallic_roughness_texture())?,
            specular_factor: specular.as_ref().map_or(1.0, |s| s.specular_factor()),
            specular_color: specular
                .as_ref()
                .map_or([1.0; 3], |s| s.specular_color_factor()),
            transmission: transmission.map_or(0.0, |t| t.transmission_factor()),
            ior: m.ior().unwrap_or(1.5),
            alpha_mode: match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask {
                    cutoff: m.alpha_cutoff().unwrap_or(0.5),
                },
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            },
            emissive: m.emissive_factor().map(|e| e * strength),
            emissive_texture: self.texture(m.emissive_texture())?,
            double_sided: m.double_sided(),
        })
    }

    /// The scene texture of a texture reference, decoding its image on first use.
    fn texture(
        &mut self,
        info: Option<gltf::texture::Info>,
    ) -> Result<Option<TextureRef>, SceneError> {
        let Some(info) = info else {
            return Ok(None);
        };
        if info.tex_coord() != 0 {
            self.note_once(format!(
                "textures on TEXCOORD_{} read with TEXCOORD_0: only set 0 is loaded",
                info.tex_coord()
            ));
        }
        let image = info.texture().source();
        if let Some(&k) = self.texture_of_image.get(&image.index()) {
            return Ok(Some(TextureRef { texture: k }));
        }
        let texture = self.decode_image(&image)?;
        let k = self.textures.len() as u32;
        self.textures.push(texture);
        self.texture_of_image.insert(image.index(), k);
        Ok(Some(TextureRef { texture: k }))
    }

    /// Decode an image (external file, `data:` URI or buffer view) to RGBA8.
    fn decode_image(&self, image: &gltf::Image) -> Result<Texture, SceneError> {
        let source = image.source();
        let uri = match source {
            gltf::image::Source::Uri { uri, .. } => Some(uri),
            gltf::image::Source::View { .. } => None,
        };
        let what = match uri {
            Some(uri) => format!("images[{}] '{}'", image.index(), uri_label(uri)),
            None => format!("images[{}] (in a buffer view)", image.index()),
        };
        if let Some(uri) = uri {
            check_uri(uri).map_err(|m| invalid(self.file, format!("{what}: {m}")))?;
        }
        let data = gltf::image::Data::from_source(source, Some(self.base), self.buffers)
            .map_err(|e| resource_error(self.file, self.base, &what, uri, e))?;
        to_texture(data).ok_or_else(|| {
            invalid(
                self.file,
                format!("{what}: pixel data does not match its size"),
            )
        })
    }

    /// Add a KHR_lights_punctual light at its node (world transform `world`); intensity in
    /// W/sr is `color x intensity` (no 683 lm/W factor, DESIGN.md).
    fn add_light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        world: &Mat4,
    ) -> Result<(), SceneError> {
        let name = name_or_index(light.name(), "lights", light.index());
        let spot = match light.kind() {
            Kind::Directional => {
                self.notes.push(format!(
                    "directional light '{name}' skipped: a pulsed directional light has no position for the pulse to leave at t = 0"
                ));
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
        self.lights.push(PunctualLight {
            name,
            position: world.transform_point3(Vec3::ZERO),
            intensity_w_per_sr: light.color().map(|c| c * intensity),
            spot,
        });
        Ok(())
    }

    /// The scene, with a camera and a light added where the file has none, and the counts
    /// of what was dropped noted.
    fn finish(self) -> Result<Scene, SceneError> {
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
            notes: self.notes,
        };
        if scene.triangles.is_empty() {
            scene.notes.push(format!("no triangles in {file}"));
        }
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
            let light = colocated_light(&scene);
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

//! What is checked before the gltf crate sees a file or touches its data: the .glb
//! container and the JSON, required extensions, what the crate indexes or unwraps
//! unchecked, URIs, buffer sizes, buffer views and accessor spans. Each problem becomes a
//! [`SceneError`] naming the object (`meshes[0].primitives[1]`, `buffer 0 'a.bin'`).

use crate::scene::SceneError;
use gltf::accessor::{DataType, Dimensions};
use gltf::json::validation::Checked;
use gltf::{Accessor, Document, buffer, json};
use std::path::Path;

/// Extensions tprf honours; a file that *requires* any other one is refused.
pub(super) const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
];

/// A [`SceneError::Gltf`] for `file`.
pub(super) fn invalid(file: &str, message: impl Into<String>) -> SceneError {
    SceneError::Gltf {
        path: file.to_string(),
        message: message.into(),
    }
}

/// Parse the JSON (and the .glb container), refuse unsupported required extensions, then let
/// the gltf crate validate the document.
pub(super) fn parse(file: &str, bytes: &[u8]) -> Result<(Document, Option<Vec<u8>>), SceneError> {
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

/// A short label for a URI in messages (`data:` URIs can be megabytes long).
pub(super) fn uri_label(uri: &str) -> &str {
    if uri.starts_with("data:") {
        "data: URI"
    } else {
        uri
    }
}

/// The gltf crate unwraps the percent-decoding of a relative URI: refuse one that does not
/// decode to UTF-8 before handing it over.
pub(super) fn check_uri(uri: &str) -> Result<(), String> {
    if uri.contains(':') || urlencoding::decode(uri).is_ok() {
        Ok(())
    } else {
        Err("its %-escapes do not decode to UTF-8".into())
    }
}

/// An error reading an external buffer or image (`what`, at `uri`): a missing file is a
/// [`SceneError::Io`] naming the path looked for.
pub(super) fn resource_error(
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
pub(super) fn load_buffers(
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
pub(super) fn check_views(
    file: &str,
    doc: &Document,
    buffers: &[buffer::Data],
) -> Result<(), SceneError> {
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
pub(super) fn check_accessor(
    acc: &Accessor,
    types: &[DataType],
    dims: Dimensions,
) -> Result<(), String> {
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
pub(super) fn check_count(acc: &Accessor, name: &str, count: usize) -> Result<(), String> {
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
pub(super) fn read_all<T>(
    iter: Option<impl Iterator<Item = T>>,
    acc: &Accessor,
) -> Result<Vec<T>, String> {
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

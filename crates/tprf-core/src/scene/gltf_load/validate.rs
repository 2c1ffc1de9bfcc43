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
    "KHR_materials_volume",
];

/// A [`SceneError::Gltf`] for `file`.
pub(super) fn invalid(file: &str, message: impl Into<String>) -> SceneError {
    SceneError::Gltf {
        path: file.to_string(),
        message: message.into(),
    }
}

/// What [`parse`] gives: the document, the .glb BIN chunk, and notes on what was skipped.
pub(super) struct Parsed {
    pub document: Document,
    pub blob: Option<Vec<u8>>,
    pub notes: Vec<String>,
}

/// Parse the JSON (and the .glb container, checked by [`super::glb::split`]), refuse a
/// file that is not glTF 2.0 by its `asset.version` and unsupported required extensions,
/// then let the gltf crate validate the document.
pub(super) fn parse(file: &str, bytes: &[u8]) -> Result<Parsed, SceneError> {
    let (json, bin, notes) = if super::glb::is_glb(bytes) {
        let glb = super::glb::split(bytes).map_err(|m| invalid(file, m))?;
        (glb.json, glb.bin, glb.notes)
    } else {
        (bytes, None, Vec::new())
    };
    check_asset_version(json).map_err(|m| invalid(file, m))?;
    let gltf::Gltf { document, .. } = gltf::Gltf::from_slice_without_validation(json)
        .map_err(|e| invalid(file, describe_parse_error(e)))?;
    let mut root = document.into_json();
    check_required_extensions(file, &root)?;
    // All of them are supported (just checked). The crate's own validation would refuse
    // some it parses but does not list as enabled (KHR_materials_specular), so drop them.
    root.extensions_required.clear();
    check_crate_preconditions(&root).map_err(|m| invalid(file, m))?;
    let document = Document::from_json(root).map_err(|e| invalid(file, e.to_string()))?;
    Ok(Parsed {
        document,
        blob: bin.map(<[u8]>::to_vec),
        notes,
    })
}

/// The glTF version `asset.version` (or `asset.minVersion`) states: `MAJOR.MINOR`, both
/// decimal integers (the schema's pattern `^[0-9]+\.[0-9]+$`).
fn parse_version(text: &str) -> Option<(u64, u64)> {
    let (major, minor) = text.split_once('.')?;
    let number = |s: &str| {
        (!s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
            .then(|| s.parse().ok())
            .flatten()
    };
    Some((number(major)?, number(minor)?))
}

/// Refuse JSON that does not declare glTF 2.0: a missing or garbled `asset.version`,
/// glTF 1.0 (whose objects are maps, which the 2.0 reader would misread or half-read),
/// or a later major version that does not allow 2.0 readers by `asset.minVersion` (glTF
/// 2.0 section 3.2: a reader loads a file when `minVersion`, or without it the major
/// version, is one it supports). JSON that does not parse is left to the gltf crate,
/// whose message says where.
fn check_asset_version(json: &[u8]) -> Result<(), String> {
    #[derive(serde::Deserialize)]
    struct Head {
        asset: Option<serde_json::Value>,
    }
    let Ok(head) = serde_json::from_slice::<Head>(json) else {
        return Ok(());
    };
    const HINT: &str = "a glTF 2.0 file has \"asset\": {\"version\": \"2.0\"}";
    let Some(asset) = head.asset else {
        return Err(format!("it has no asset object ({HINT})"));
    };
    let version = match asset.get("version") {
        Some(serde_json::Value::String(v)) => v.as_str(),
        Some(other) => return Err(format!("asset.version is {other}, not a string ({HINT})")),
        None if asset.is_object() => return Err(format!("asset has no version ({HINT})")),
        None => return Err(format!("asset is {asset}, not an object ({HINT})")),
    };
    let gltf_1_refusal = |v: &str| {
        format!(
            "it is glTF {v} (asset.version \"{v}\"), which tprf does not read: tprf reads \
             glTF 2.0; convert the file to glTF 2.0 first (for example with gltf-pipeline)"
        )
    };
    let Some((major, _)) = parse_version(version) else {
        if version.starts_with("1.") || version.starts_with("0.") {
            return Err(gltf_1_refusal(version));
        }
        return Err(format!(
            "asset.version \"{version}\" is not a glTF version (MAJOR.MINOR; {HINT})"
        ));
    };
    let min_version = match asset.get("minVersion") {
        None => None,
        Some(serde_json::Value::String(v)) => match parse_version(v) {
            Some(min) => Some((v.as_str(), min)),
            None => {
                return Err(format!(
                    "asset.minVersion \"{v}\" is not a glTF version (MAJOR.MINOR)"
                ));
            }
        },
        Some(other) => return Err(format!("asset.minVersion is {other}, not a string")),
    };
    match (major, min_version) {
        (0 | 1, _) => Err(gltf_1_refusal(version)),
        (_, Some((text, min))) if min > (2, 0) => Err(format!(
            "it needs a glTF {text} reader (asset.minVersion \"{text}\"); tprf reads glTF 2.0"
        )),
        (_, Some(_)) => Ok(()),
        (2, None) => Ok(()),
        (_, None) => Err(format!(
            "it is glTF {version} (asset.version), and states no asset.minVersion that a \
             glTF 2.0 reader may load it with; tprf reads glTF 2.0"
        )),
    }
}

/// A parse error in words: bad JSON says so. (The .glb container was split and checked
/// before: the crate sees JSON only.)
fn describe_parse_error(e: gltf::Error) -> String {
    match e {
        gltf::Error::Deserialize(e) => format!("invalid glTF JSON: {e}"),
        gltf::Error::Binary(e) => format!("corrupt .glb: {e}"),
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

/// Read one buffer (at most its declared length of an external file), naming it (index
/// and URI) if that fails or it is shorter than declared. Its length was budgeted with
/// the others' by [`check_buffer_budget`].
fn load_buffer(
    file: &str,
    buffer: &gltf::Buffer,
    base: &Path,
    blob: &mut Option<Vec<u8>>,
) -> Result<buffer::Data, SceneError> {
    let declared = buffer.length();
    let (what, mut data) = match buffer.source() {
        buffer::Source::Uri(uri) => {
            let what = format!("buffer {} '{}'", buffer.index(), uri_label(uri));
            let data = super::resource::read_uri(file, base, &what, uri, declared as u64)?;
            (what, data)
        }
        buffer::Source::Bin => {
            let what = format!("buffer {} (the .glb BIN chunk)", buffer.index());
            if buffer.index() != 0 {
                // glTF 2.0 section 4.4.3.3: the BIN chunk is buffer 0's.
                return Err(invalid(
                    file,
                    format!("{what}: it has no uri, and only buffer 0 may be the BIN chunk"),
                ));
            }
            let data = blob
                .take()
                .ok_or_else(|| invalid(file, format!("{what}: the file has no BIN chunk")))?;
            (what, data)
        }
    };
    if data.len() < declared {
        return Err(invalid(
            file,
            format!(
                "{what} holds {} bytes, the file declares {declared}",
                data.len(),
            ),
        ));
    }
    // The gltf crate's readers expect whole 4-byte words.
    data.resize(data.len().next_multiple_of(4), 0);
    Ok(buffer::Data(data))
}

/// Refuse buffers whose declared lengths add up to more memory than is left, before any
/// is read.
pub(super) fn check_buffer_budget(file: &str, doc: &Document) -> Result<(), SceneError> {
    // The BIN chunk is in memory already (read with the file).
    let external = doc
        .buffers()
        .filter(|b| matches!(b.source(), buffer::Source::Uri(_)));
    let (count, total) = external.fold((0, 0u64), |(n, sum), b| {
        (n + 1, sum.saturating_add(b.length() as u64))
    });
    crate::budget::check(
        total,
        &format!("scene {file}"),
        format_args!("its {count} buffer(s)"),
    )?;
    Ok(())
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

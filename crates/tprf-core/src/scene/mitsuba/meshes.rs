//! Mesh files of the `obj`, `ply` and `serialized` shapes, read as Mitsuba reads them into
//! one indexed triangle mesh in the object's own space.
//!
//! - **OBJ** through `tobj`: every object and group of the file in one mesh, polygons
//!   triangulated, vertices shared where position, texture and normal indices agree;
//!   `.mtl` materials are not read (Mitsuba does not either).
//! - **PLY** (ASCII, binary little and big endian) read here: the `vertex` element's
//!   `x y z`, `nx ny nz`, and `u v` (or `s t`, `texture_u texture_v`), the `face`
//!   element's `vertex_indices` (or `vertex_index`) lists, polygons as fans; other
//!   elements and properties skipped. Hand-written rather than through a PLY crate so
//!   that the counts in the header are budgeted (and checked against the file's size)
//!   before anything is allocated, and a mesh costs 32 bytes a vertex, not a map per
//!   vertex.
//! - **serialized** (Mitsuba's own zlib-compressed format, versions 3 and 4): positions,
//!   normals, texture coordinates (vertex colours skipped), one mesh of the file chosen
//!   by `shape_index` through the file's table of offsets.
//!
//! Every count is checked against the memory budget before its buffers are made, and
//! every index against the vertex count.

use crate::budget::{self, format_count};
use crate::scene::{BYTES_PER_TRIANGLE, SceneError};
use glam::{Vec2, Vec3};
use std::io::Read;
use std::path::Path;

/// A triangle mesh in object space.
#[derive(Debug, Default)]
pub(super) struct Mesh {
    pub positions: Vec<Vec3>,
    /// Per vertex, as the file gives them (not normalised).
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub faces: Vec<[u32; 3]>,
}

/// Bytes a vertex holds while a mesh is read and placed: position, normal and UV, in
/// object space and in world space.
const BYTES_PER_VERTEX: u64 = 2 * (12 + 12 + 8);

/// Refuse a mesh of `vertices` and `triangles` that does not fit in memory (its
/// triangles as the renderer holds them, and its vertices while they are read).
pub(super) fn check_budget(what: &str, vertices: u64, triangles: u64) -> Result<(), SceneError> {
    if triangles > u64::from(u32::MAX) || vertices > u64::from(u32::MAX) {
        return Err(SceneError::Invalid(format!(
            "{what}: {} vertices and {} triangles: more than a mesh may hold (2^32)",
            format_count(vertices),
            format_count(triangles)
        )));
    }
    let need = triangles
        .saturating_mul(BYTES_PER_TRIANGLE)
        .saturating_add(vertices.saturating_mul(BYTES_PER_VERTEX));
    budget::check(
        need,
        what,
        format_args!(
            "{} vertices and {} triangles",
            format_count(vertices),
            format_count(triangles)
        ),
    )?;
    Ok(())
}

/// The file's bytes (a regular file that fits in memory); `what` names the shape for
/// a missing file.
fn read(path: &Path, what: &str) -> Result<Vec<u8>, SceneError> {
    budget::read_file(path, what).map_err(|e| match e {
        budget::BudgetError::Io { path, source } => SceneError::Io {
            path: format!("{} ({what})", path.display()),
            source,
        },
        e => SceneError::Budget(e),
    })
}

/// A Wavefront OBJ file; `flip_v`: texture v as `1 - v` (Mitsuba's `flip_tex_coords`,
/// true by default for OBJ). Errors are the message for the shape's line.
pub(super) fn read_obj(path: &Path, what: &str, flip_v: bool) -> Result<Mesh, SceneError> {
    let bytes = read(path, what)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = std::io::BufReader::new(bytes.as_slice());
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| {
        SceneError::Invalid(format!("{}: not a readable OBJ file: {e}", path.display()))
    })?;
    drop(bytes);
    let vertices: u64 = models
        .iter()
        .map(|m| m.mesh.positions.len() as u64 / 3)
        .sum();
    let triangles: u64 = models.iter().map(|m| m.mesh.indices.len() as u64 / 3).sum();
    check_budget(what, vertices, triangles)?;
    let mut mesh = Mesh::default();
    let all_normals = models
        .iter()
        .all(|m| !m.mesh.normals.is_empty() && m.mesh.normals.len() == m.mesh.positions.len());
    let all_uvs = models.iter().all(|m| {
        !m.mesh.texcoords.is_empty() && m.mesh.texcoords.len() / 2 == m.mesh.positions.len() / 3
    });
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for m in &models {
        let base = mesh.positions.len() as u32;
        let count = m.mesh.positions.len() / 3;
        mesh.positions.extend(
            m.mesh
                .positions
                .as_chunks::<3>()
                .0
                .iter()
                .map(|p| Vec3::from_array(*p)),
        );
        if all_normals {
            normals.extend(
                m.mesh
                    .normals
                    .as_chunks::<3>()
                    .0
                    .iter()
                    .map(|n| Vec3::from_array(*n)),
            );
        }
        if all_uvs {
            uvs.extend(
                m.mesh
                    .texcoords
                    .as_chunks::<2>()
                    .0
                    .iter()
                    .map(|&[u, v]| Vec2::new(u, if flip_v { 1.0 - v } else { v })),
            );
        }
        for f in m.mesh.indices.as_chunks::<3>().0 {
            if f.iter().any(|&i| i as usize >= count) {
                return Err(SceneError::Invalid(format!(
                    "{}: a face of object '{}' indexes past its {count} vertices",
                    path.display(),
                    m.name
                )));
            }
            mesh.faces.push(f.map(|i| i + base));
        }
    }
    mesh.normals = all_normals.then_some(normals);
    mesh.uvs = all_uvs.then_some(uvs);
    Ok(mesh)
}

/// A PLY scalar type.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug)]
struct Property {
    name: String,
    /// `Some(count type)` for a list.
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Values of a PLY body, in order: ASCII tokens or binary numbers.
struct Body<'a> {
    bytes: &'a [u8],
    pos: usize,
    format: Format,
}

impl Body<'_> {
    fn value(&mut self, ty: Scalar) -> Result<f64, String> {
        if self.format == Format::Ascii {
            let rest = self.bytes.get(self.pos..).unwrap_or_default();
            let start = rest
                .iter()
                .position(|b| !b.is_ascii_whitespace())
                .ok_or("the file ends early")?;
            let len = rest[start..]
                .iter()
                .position(|b| b.is_ascii_whitespace())
                .unwrap_or(rest.len() - start);
            let token = std::str::from_utf8(&rest[start..start + len])
                .map_err(|_| "a value is not text")?;
            self.pos += start + len;
            return token
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("\"{token}\" is not a finite number"));
        }
        let n = ty.size();
        let b = self
            .bytes
            .get(self.pos..self.pos + n)
            .ok_or("the file ends early")?;
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.format == Format::Big {
            a[..n].reverse();
        }
        let v = match ty {
            Scalar::I8 => f64::from(a[0] as i8),
            Scalar::U8 => f64::from(a[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes([a[0], a[1]])),
            Scalar::U16 => f64::from(u16::from_le_bytes([a[0], a[1]])),
            Scalar::I32 => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::U32 => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::F32 => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::F64 => f64::from_le_bytes(a),
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err("a value is not finite".into())
        }
    }
}

/// The header: format, elements, and where the body starts.
fn ply_header(bytes: &[u8]) -> Result<(Format, Vec<Element>, usize), String> {
    let end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or("no end_header line: not a PLY file")?;
    let body_start = bytes[end..]
        .iter()
        .position(|&b| b == b'\n')
        .map(|k| end + k + 1)
        .ok_or("the file ends after end_header")?;
    let text = std::str::from_utf8(&bytes[..end]).map_err(|_| "the header is not text")?;
    let mut lines = text.lines().map(str::trim);
    if lines.next() != Some("ply") {
        return Err("it does not start with \"ply\"".into());
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for line in lines {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    other => return Err(format!("format {other} is not a PLY format")),
                })
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| format!("element {name}: count \"{count}\" is not a count"))?,
                props: Vec::new(),
            }),
            ["property", "list", c, t, name] => {
                let e = elements.last_mut().ok_or("a property before any element")?;
                e.props.push(Property {
                    name: name.to_string(),
                    list: Some(Scalar::parse(c).ok_or_else(|| format!("unknown type {c}"))?),
                    ty: Scalar::parse(t).ok_or_else(|| format!("unknown type {t}"))?,
                });
            }
            ["property", t, name] => {
                let e = elements.last_mut().ok_or("a property before any element")?;
                e.props.push(Property {
                    name: name.to_string(),
                    list: None,
                    ty: Scalar::parse(t).ok_or_else(|| format!("unknown type {t}"))?,
                });
            }
            _ => return Err(format!("header line \"{line}\" is not PLY")),
        }
    }
    Ok((format.ok_or("no format line")?, elements, body_start))
}

/// A PLY file; `flip_v` as [`read_obj`] (false by default for PLY in Mitsuba).
pub(super) fn read_ply(path: &Path, what: &str, flip_v: bool) -> Result<Mesh, SceneError> {
    let bytes = read(path, what)?;
    let bad = |m: String| SceneError::Invalid(format!("{}: {m}", path.display()));
    let (format, elements, body_start) =
        ply_header(&bytes).map_err(|m| bad(format!("not a readable PLY file: {m}")))?;
    let vertex = elements.iter().find(|e| e.name == "vertex");
    let face = elements.iter().find(|e| e.name == "face");
    let (Some(vertex), Some(face)) = (vertex, face) else {
        return Err(bad("no vertex or no face element".into()));
    };
    let has = |n: &str| vertex.props.iter().any(|p| p.name == n && p.list.is_none());
    if !(has("x") && has("y") && has("z")) {
        return Err(bad("the vertex element has no x, y, z".into()));
    }
    let index_prop = face
        .props
        .iter()
        .find(|p| p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index"))
        .ok_or_else(|| bad("the face element has no vertex_indices list".into()))?
        .name
        .clone();
    // At least a byte a value (a binary file's stride, an ASCII file's digit): counts the
    // file cannot hold are refused before any allocation.
    let body = bytes.len().saturating_sub(body_start) as u64;
    let min_bytes: u64 = elements
        .iter()
        .map(|e| e.count.saturating_mul(e.props.len() as u64))
        .fold(0u64, u64::saturating_add);
    if min_bytes > body {
        return Err(bad(format!(
            "the header announces {} vertices and {} faces, more than its {} bytes hold",
            format_count(vertex.count),
            format_count(face.count),
            format_count(body)
        )));
    }
    check_budget(what, vertex.count, face.count)?;
    let (uname, vname) = if has("u") && has("v") {
        ("u", "v")
    } else if has("s") && has("t") {
        ("s", "t")
    } else {
        ("texture_u", "texture_v")
    };
    let normals = has("nx") && has("ny") && has("nz");
    let uvs = has(uname) && has(vname);
    let mut mesh = Mesh {
        positions: Vec::with_capacity(vertex.count as usize),
        normals: normals.then(|| Vec::with_capacity(vertex.count as usize)),
        uvs: uvs.then(|| Vec::with_capacity(vertex.count as usize)),
        faces: Vec::with_capacity(face.count as usize),
    };
    let mut b = Body {
        bytes: &bytes,
        pos: body_start,
        format,
    };
    let nv = vertex.count;
    for e in &elements {
        for i in 0..e.count {
            let mut p = [0.0f64; 3];
            let mut n = [0.0f64; 3];
            let mut uv = [0.0f64; 2];
            for prop in &e.props {
                let at = |m: String| bad(format!("{} {i}, {}: {m}", e.name, prop.name));
                if let Some(count_ty) = prop.list {
                    let count = b.value(count_ty).map_err(at)?;
                    if !(0.0..=1e6).contains(&count) || count.fract() != 0.0 {
                        return Err(at(format!("a list of {count} values")));
                    }
                    let count = count as usize;
                    if e.name == "face" && prop.name == index_prop {
                        let mut idx = Vec::with_capacity(count);
                        for _ in 0..count {
                            let v = b.value(prop.ty).map_err(at)?;
                            if !(v >= 0.0 && v < nv as f64 && v.fract() == 0.0) {
                                return Err(at(format!(
                                    "vertex index {v} is not one of the {nv} vertices"
                                )));
                            }
                            idx.push(v as u32);
                        }
                        // Polygons as fans, as Mitsuba triangulates them.
                        for k in 1..count.saturating_sub(1) {
                            mesh.faces.push([idx[0], idx[k], idx[k + 1]]);
                        }
                    } else {
                        for _ in 0..count {
                            b.value(prop.ty).map_err(at)?;
                        }
                    }
                    continue;
                }
                let v = b.value(prop.ty).map_err(at)?;
                if e.name == "vertex" {
                    match prop.name.as_str() {
                        "x" => p[0] = v,
                        "y" => p[1] = v,
                        "z" => p[2] = v,
                        "nx" => n[0] = v,
                        "ny" => n[1] = v,
                        "nz" => n[2] = v,
                        s if s == uname => uv[0] = v,
                        s if s == vname => uv[1] = v,
                        _ => {}
                    }
                }
            }
            if e.name == "vertex" {
                mesh.positions
                    .push(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32));
                if let Some(ns) = &mut mesh.normals {
                    ns.push(Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32));
                }
                if let Some(us) = &mut mesh.uvs {
                    let v = if flip_v { 1.0 - uv[1] } else { uv[1] };
                    us.push(Vec2::new(uv[0] as f32, v as f32));
                }
            }
        }
    }
    Ok(mesh)
}

/// Flags of a serialized mesh.
const SER_NORMALS: u32 = 0x0001;
const SER_TEXCOORDS: u32 = 0x0002;
const SER_COLORS: u32 = 0x0008;
const SER_DOUBLE: u32 = 0x2000;

/// Mesh `shape_index` of a Mitsuba `.serialized` file; `flip_v` as [`read_obj`].
pub(super) fn read_serialized(
    path: &Path,
    what: &str,
    shape_index: u64,
    flip_v: bool,
) -> Result<Mesh, SceneError> {
    let bytes = read(path, what)?;
    let bad = |m: String| SceneError::Invalid(format!("{}: {m}", path.display()));
    let u16_at = |k: usize| {
        bytes
            .get(k..k + 2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
    };
    if u16_at(0) != Some(0x041C) {
        return Err(bad(
            "not a Mitsuba serialized mesh (no 0x041C header)".into()
        ));
    }
    let version = u16_at(2).unwrap_or(0);
    if !(3..=4).contains(&version) {
        return Err(bad(format!(
            "serialized format version {version}: tprf reads 3 and 4"
        )));
    }
    // The table at the end: an offset per mesh (u64 in version 4, u32 in 3), then the
    // number of meshes (u32).
    let len = bytes.len();
    let count = bytes
        .get(len.saturating_sub(4)..)
        .filter(|b| b.len() == 4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64)
        .ok_or_else(|| bad("the file is too short".into()))?;
    if shape_index >= count {
        return Err(bad(format!(
            "shape_index {shape_index}: the file holds {count} meshes"
        )));
    }
    let width = if version == 4 { 8 } else { 4 };
    let table = (len as u64)
        .checked_sub(4 + count.saturating_mul(width))
        .ok_or_else(|| {
            bad(format!(
                "its table of {count} meshes is longer than the file"
            ))
        })?;
    let entry = (table + shape_index * width) as usize;
    let offset = match version {
        4 => bytes
            .get(entry..entry + 8)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8]))),
        _ => bytes
            .get(entry..entry + 4)
            .map(|b| u64::from(u32::from_le_bytes(b.try_into().unwrap_or([0; 4])))),
    }
    .ok_or_else(|| bad("its table of meshes is cut".into()))?;
    let start = usize::try_from(offset)
        .ok()
        .and_then(|o| o.checked_add(4))
        .filter(|&o| o <= table as usize)
        .ok_or_else(|| {
            bad(format!(
                "mesh {shape_index} starts at {offset}, past its data"
            ))
        })?;
    let mut z = flate2::read::ZlibDecoder::new(&bytes[start..table as usize]);
    let take =
        |n: usize, z: &mut flate2::read::ZlibDecoder<&[u8]>| -> Result<Vec<u8>, SceneError> {
            let mut buf = Vec::new();
            buf.try_reserve_exact(n)
                .map_err(|_| bad(format!("cannot allocate {n} bytes")))?;
            z.by_ref()
                .take(n as u64)
                .read_to_end(&mut buf)
                .map_err(|e| {
                    bad(format!(
                        "mesh {shape_index}: its compressed data do not inflate: {e}"
                    ))
                })?;
            if buf.len() < n {
                return Err(bad(format!("mesh {shape_index}: its data end early")));
            }
            Ok(buf)
        };
    let u32_of = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    let u64_of = |b: &[u8]| u64::from_le_bytes(b.try_into().unwrap_or([0; 8]));
    let flags = u32_of(&take(4, &mut z)?);
    if version == 4 {
        // The mesh's name, NUL-terminated (at most 64 KiB).
        let mut name_len = 0;
        loop {
            let b = take(1, &mut z)?;
            if b[0] == 0 {
                break;
            }
            name_len += 1;
            if name_len > 65536 {
                return Err(bad("a mesh name longer than 64 KiB".into()));
            }
        }
    }
    let vertices = u64_of(&take(8, &mut z)?);
    let triangles = u64_of(&take(8, &mut z)?);
    check_budget(what, vertices, triangles)?;
    let fsize = if flags & SER_DOUBLE != 0 { 8 } else { 4 };
    let (nv, nt) = (vertices as usize, triangles as usize);
    let floats =
        |k: usize, z: &mut flate2::read::ZlibDecoder<&[u8]>| -> Result<Vec<f32>, SceneError> {
            let raw = take(nv * k * fsize, z)?;
            let out: Vec<f32> = if fsize == 8 {
                raw.as_chunks::<8>()
                    .0
                    .iter()
                    .map(|b| f64::from_le_bytes(*b) as f32)
                    .collect()
            } else {
                raw.as_chunks::<4>()
                    .0
                    .iter()
                    .map(|b| f32::from_le_bytes(*b))
                    .collect()
            };
            if out.iter().all(|v| v.is_finite()) {
                Ok(out)
            } else {
                Err(bad(format!(
                    "mesh {shape_index}: a vertex attribute is not finite"
                )))
            }
        };
    let positions: Vec<Vec3> = floats(3, &mut z)?
        .as_chunks::<3>()
        .0
        .iter()
        .map(|p| Vec3::from_array(*p))
        .collect();
    let normals = if flags & SER_NORMALS != 0 {
        Some(
            floats(3, &mut z)?
                .as_chunks::<3>()
                .0
                .iter()
                .map(|n| Vec3::from_array(*n))
                .collect(),
        )
    } else {
        None
    };
    let uvs = if flags & SER_TEXCOORDS != 0 {
        Some(
            floats(2, &mut z)?
                .as_chunks::<2>()
                .0
                .iter()
                .map(|&[u, v]| Vec2::new(u, if flip_v { 1.0 - v } else { v }))
                .collect(),
        )
    } else {
        None
    };
    if flags & SER_COLORS != 0 {
        floats(3, &mut z)?;
    }
    let wide = vertices > u64::from(u32::MAX);
    let raw = take(nt * 3 * if wide { 8 } else { 4 }, &mut z)?;
    let index: Vec<u64> = if wide {
        raw.as_chunks::<8>()
            .0
            .iter()
            .map(|b| u64::from_le_bytes(*b))
            .collect()
    } else {
        raw.as_chunks::<4>()
            .0
            .iter()
            .map(|b| u64::from(u32::from_le_bytes(*b)))
            .collect()
    };
    if let Some(i) = index.iter().find(|&&i| i >= vertices) {
        return Err(bad(format!(
            "mesh {shape_index}: vertex index {i} of {vertices} vertices"
        )));
    }
    let faces = index
        .as_chunks::<3>()
        .0
        .iter()
        .map(|f| f.map(|i| i as u32))
        .collect();
    Ok(Mesh {
        positions,
        normals,
        uvs,
        faces,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ply_header_reads_formats_and_lists() {
        let h = b"ply\nformat binary_little_endian 1.0\ncomment x\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let (f, e, start) = ply_header(h).unwrap();
        assert!(f == Format::Little);
        assert_eq!(e.len(), 2);
        assert_eq!(e[1].props[0].list, Some(Scalar::U8));
        assert_eq!(start, h.len());
        assert!(ply_header(b"ply\nformat ascii 1.0\nelement vertex many\nend_header\n").is_err());
        assert!(ply_header(b"PLY? no").is_err());
    }
}

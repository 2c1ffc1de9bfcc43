//! Mitsuba `.serialized` mesh files written as Mitsuba's documentation of the format
//! describes them (Mitsuba 0.6 manual, "Serialized mesh loader"), independently of
//! tprf's reader:
//!
//! - per mesh: `u16 0x041C`, `u16` version, then a zlib stream of `u32` flags, (version
//!   4) the mesh's name NUL-terminated, `u64` vertex count, `u64` triangle count, the
//!   positions (`f32` with flag 0x1000, `f64` with 0x2000), the normals (flag 0x0001),
//!   the texture coordinates (0x0002), the vertex colours (0x0008), then `u32` indices
//!   (three a triangle);
//! - at the end, each mesh's offset from the file's start (`u64` in version 4, `u32` in
//!   version 3) and the number of meshes (`u32`).

use std::io::Write;

/// A mesh to write: positions, optional normals, triangles.
pub struct SerMesh<'a> {
    pub name: &'a str,
    pub positions: &'a [[f32; 3]],
    pub normals: Option<&'a [[f32; 3]]>,
    pub faces: &'a [[u32; 3]],
}

/// A `.serialized` file of `meshes` in format `version` (3 or 4), single precision.
pub fn serialized(meshes: &[SerMesh], version: u16) -> Vec<u8> {
    let mut file = Vec::new();
    let mut offsets = Vec::new();
    for m in meshes {
        offsets.push(file.len() as u64);
        file.extend(0x041Cu16.to_le_bytes());
        file.extend(version.to_le_bytes());
        let mut raw = Vec::new();
        let flags: u32 = 0x1000 | if m.normals.is_some() { 0x0001 } else { 0 };
        raw.extend(flags.to_le_bytes());
        if version == 4 {
            raw.extend(m.name.as_bytes());
            raw.push(0);
        }
        raw.extend((m.positions.len() as u64).to_le_bytes());
        raw.extend((m.faces.len() as u64).to_le_bytes());
        for v in m.positions.iter().chain(m.normals.unwrap_or(&[])).flatten() {
            raw.extend(v.to_le_bytes());
        }
        for i in m.faces.iter().flatten() {
            raw.extend(i.to_le_bytes());
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).unwrap();
        file.extend(z.finish().unwrap());
    }
    for o in &offsets {
        if version == 4 {
            file.extend(o.to_le_bytes());
        } else {
            file.extend((*o as u32).to_le_bytes());
        }
    }
    file.extend((meshes.len() as u32).to_le_bytes());
    file
}

/// A square pyramid: base `[-1, 1]^2` at z = 0, apex at (0, 0, 1); outward faces
/// (counter-clockwise seen from outside). Its area: base 4 plus four triangles of base
/// 2 and slant height sqrt(2): 4 + 4 sqrt(2).
pub const PYRAMID_POSITIONS: [[f32; 3]; 5] = [
    [-1.0, -1.0, 0.0],
    [1.0, -1.0, 0.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];
pub const PYRAMID_FACES: [[u32; 3]; 6] = [
    [0, 2, 1],
    [0, 3, 2],
    [0, 1, 4],
    [1, 2, 4],
    [2, 3, 4],
    [3, 0, 4],
];

/// One large triangle, put first in a file so that a reader taking the wrong mesh
/// shows it.
pub const DECOY_POSITIONS: [[f32; 3]; 3] =
    [[-50.0, -50.0, 0.0], [50.0, -50.0, 0.0], [0.0, 50.0, 0.0]];
pub const DECOY_FACES: [[u32; 3]; 1] = [[0, 1, 2]];

/// A file of the decoy (mesh 0) and the pyramid (mesh 1).
pub fn decoy_then_pyramid(version: u16) -> Vec<u8> {
    serialized(
        &[
            SerMesh {
                name: "decoy",
                positions: &DECOY_POSITIONS,
                normals: None,
                faces: &DECOY_FACES,
            },
            SerMesh {
                name: "pyramid",
                positions: &PYRAMID_POSITIONS,
                normals: None,
                faces: &PYRAMID_FACES,
            },
        ],
        version,
    )
}

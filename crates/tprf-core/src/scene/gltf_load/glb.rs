//! The .glb container (glTF 2.0 section 4.4, "Binary glTF Layout"), checked as the
//! Khronos glTF-Validator checks it before the gltf crate sees the JSON: the 12-byte
//! header (magic `glTF`, version 2, the total length equal to the file's), then chunks of
//! an 8-byte header (length, type) and data; every chunk's length a multiple of 4 and
//! inside the file; the first chunk JSON and not empty; at most one JSON and one BIN
//! chunk, the BIN chunk second. Chunks of other types are skipped (the specification
//! says loaders ignore them) and noted.
//!
//! The gltf crate (1.4) reads only the chunks it needs and checks neither the header's
//! length against the file nor the alignment: a file whose header is smaller than the
//! file (bytes appended, or a cut-and-paste of two files) was read as if whole.

/// Magic of a .glb file: `glTF` as a little-endian u32.
const MAGIC: &[u8; 4] = b"glTF";
/// The GLB header: magic, version, total length (u32 each).
const HEADER_BYTES: usize = 12;
/// A chunk's header: data length, type (u32 each).
const CHUNK_HEADER_BYTES: usize = 8;
/// Chunk type of the JSON chunk (`JSON`).
const CHUNK_JSON: u32 = 0x4E4F_534A;
/// Chunk type of the binary buffer (`BIN\0`).
const CHUNK_BIN: u32 = 0x004E_4942;

/// The parts of a .glb file.
pub(super) struct Glb<'a> {
    /// The JSON chunk's bytes (trailing padding included: spaces, which JSON ignores).
    pub json: &'a [u8],
    /// The BIN chunk's bytes, if the file has one.
    pub bin: Option<&'a [u8]>,
    /// What was skipped (chunks of unknown types), for [`crate::scene::Scene::notes`].
    pub notes: Vec<String>,
}

/// Whether `bytes` claim to be a .glb (they start with its magic).
pub(super) fn is_glb(bytes: &[u8]) -> bool {
    bytes.starts_with(MAGIC)
}

/// A chunk type in words: `JSON`, `BIN` or its hex value, as glTF-Validator writes it.
fn chunk_name(ty: u32) -> String {
    match ty {
        CHUNK_JSON => "JSON".into(),
        CHUNK_BIN => "BIN".into(),
        other => format!("0x{other:08x}"),
    }
}

/// The little-endian u32 at `offset` of `bytes`, if all four bytes are there.
fn u32_at(bytes: &[u8], offset: usize) -> Option<u32> {
    let word = bytes.get(offset..offset.checked_add(4)?)?;
    Some(u32::from_le_bytes(word.try_into().ok()?))
}

/// Split a .glb file into its JSON and BIN chunks, or say what is wrong with it:
/// "truncated .glb: ..." when the file ends before what its headers announce, "corrupt
/// .glb: ..." when they contradict the file or the layout's rules, and a glTF 1.0 binary
/// (version 1, the KHR_binary_glTF extension) by its name.
pub(super) fn split(bytes: &[u8]) -> Result<Glb<'_>, String> {
    let file_len = bytes.len();
    let (Some(version), Some(length)) = (u32_at(bytes, 4), u32_at(bytes, 8)) else {
        return Err(format!(
            "truncated .glb: {file_len} bytes, less than its {HEADER_BYTES}-byte header"
        ));
    };
    match version {
        2 => {}
        1 => {
            return Err(
                "it is a glTF 1.0 binary (.glb version 1, KHR_binary_glTF): tprf reads \
                 glTF 2.0 only; convert it to glTF 2.0 first (for example with gltf-pipeline)"
                    .into(),
            );
        }
        v => {
            return Err(format!(
                "corrupt .glb: its header says version {v}, expected 2"
            ));
        }
    }
    let length = length as usize;
    if length > file_len {
        return Err(format!(
            "truncated .glb: its header announces {length} bytes, the file has {file_len}"
        ));
    }
    if length < file_len {
        return Err(format!(
            "corrupt .glb: its header announces {length} bytes, but the file has {file_len}: \
             {} bytes after the end it declares",
            file_len - length
        ));
    }
    let mut glb = Glb {
        json: &[],
        bin: None,
        notes: Vec::new(),
    };
    let (mut seen_json, mut seen_bin) = (false, false);
    let mut offset = HEADER_BYTES;
    let mut index = 0usize;
    while offset < file_len {
        let (Some(chunk_len), Some(ty)) = (u32_at(bytes, offset), u32_at(bytes, offset + 4)) else {
            return Err(format!(
                "truncated .glb: {} bytes at byte {offset}, where chunk {index}'s \
                 {CHUNK_HEADER_BYTES}-byte header should be",
                file_len - offset
            ));
        };
        let name = chunk_name(ty);
        let data_start = offset + CHUNK_HEADER_BYTES;
        let remaining = file_len - data_start;
        let chunk_len = chunk_len as usize;
        if chunk_len > remaining {
            return Err(format!(
                "truncated .glb: its {name} chunk (chunk {index}, at byte {offset}) announces \
                 {chunk_len} bytes, {remaining} remain"
            ));
        }
        if !chunk_len.is_multiple_of(4) {
            return Err(format!(
                "corrupt .glb: its {name} chunk (chunk {index}, at byte {offset}) is \
                 {chunk_len} bytes long, not a multiple of 4 (chunks are padded to 4 bytes)"
            ));
        }
        if index == 0 && ty != CHUNK_JSON {
            return Err(format!("corrupt .glb: its first chunk is {name}, not JSON"));
        }
        let data = bytes.get(data_start..data_start + chunk_len).unwrap_or(&[]);
        match ty {
            CHUNK_JSON if seen_json => {
                return Err(format!(
                    "corrupt .glb: a second JSON chunk (chunk {index}, at byte {offset})"
                ));
            }
            CHUNK_JSON if chunk_len == 0 => {
                return Err("corrupt .glb: its JSON chunk is empty".into());
            }
            CHUNK_JSON => {
                seen_json = true;
                glb.json = data;
            }
            CHUNK_BIN if seen_bin => {
                return Err(format!(
                    "corrupt .glb: a second BIN chunk (chunk {index}, at byte {offset})"
                ));
            }
            CHUNK_BIN if index != 1 => {
                return Err(format!(
                    "corrupt .glb: its BIN chunk is chunk {index} (at byte {offset}); it must \
                     come right after the JSON chunk"
                ));
            }
            CHUNK_BIN => {
                seen_bin = true;
                glb.bin = Some(data);
            }
            _ => glb.notes.push(format!(
                "skipped .glb chunk {index} of unknown type {name} ({chunk_len} bytes)"
            )),
        }
        offset = data_start + chunk_len;
        index += 1;
    }
    if !seen_json {
        return Err("corrupt .glb: it has no JSON chunk".into());
    }
    Ok(glb)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A .glb of `chunks` (type, data), with `length` in its header (None: the real one).
    fn glb(chunks: &[(u32, &[u8])], length: Option<u32>) -> Vec<u8> {
        let mut body = Vec::new();
        for (ty, data) in chunks {
            body.extend((data.len() as u32).to_le_bytes());
            body.extend(ty.to_le_bytes());
            body.extend(*data);
        }
        let total = (HEADER_BYTES + body.len()) as u32;
        let mut out = MAGIC.to_vec();
        out.extend(2u32.to_le_bytes());
        out.extend(length.unwrap_or(total).to_le_bytes());
        out.extend(body);
        out
    }

    fn err(bytes: &[u8]) -> String {
        match split(bytes) {
            Ok(_) => "accepted".into(),
            Err(e) => e,
        }
    }

    #[test]
    fn a_well_formed_file_splits_into_its_chunks() {
        let json = b"{}  ";
        let bin = [1u8, 2, 3, 4];
        let bytes = glb(&[(CHUNK_JSON, json), (CHUNK_BIN, &bin)], None);
        let Ok(parts) = split(&bytes) else {
            panic!("{}", err(&bytes));
        };
        assert_eq!(parts.json, json);
        assert_eq!(parts.bin, Some(&bin[..]));
        assert!(parts.notes.is_empty());
        // An unknown chunk after them is skipped and noted.
        let bytes = glb(
            &[
                (CHUNK_JSON, json),
                (CHUNK_BIN, &bin),
                (0x1234_5678, &[0; 8]),
            ],
            None,
        );
        let Ok(parts) = split(&bytes) else {
            panic!("{}", err(&bytes));
        };
        assert_eq!(parts.bin, Some(&bin[..]));
        assert_eq!(
            parts.notes,
            ["skipped .glb chunk 2 of unknown type 0x12345678 (8 bytes)"]
        );
    }

    #[test]
    fn what_the_validator_refuses_is_refused() {
        let json: &[u8] = b"{}  ";
        let good = glb(&[(CHUNK_JSON, json)], None);
        assert!(split(&good).is_ok());
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (good[..10].to_vec(), "less than its 12-byte header"),
            (
                glb(&[(CHUNK_JSON, json)], Some(16)),
                "announces 16 bytes, but the file has 24: 8 bytes after",
            ),
            (
                glb(&[(CHUNK_JSON, json)], Some(40)),
                "truncated .glb: its header announces 40 bytes, the file has 24",
            ),
            (
                glb(&[(CHUNK_JSON, b"{} ")], None),
                "JSON chunk (chunk 0, at byte 12) is 3 bytes long, not a multiple of 4",
            ),
            (
                glb(&[(CHUNK_BIN, &[0; 4]), (CHUNK_JSON, json)], None),
                "its first chunk is BIN, not JSON",
            ),
            (glb(&[(CHUNK_JSON, b"")], None), "JSON chunk is empty"),
            (
                glb(&[(CHUNK_JSON, json), (CHUNK_JSON, json)], None),
                "a second JSON chunk (chunk 1, at byte 24)",
            ),
            (
                glb(
                    &[
                        (CHUNK_JSON, json),
                        (CHUNK_BIN, &[0; 4]),
                        (CHUNK_BIN, &[0; 4]),
                    ],
                    None,
                ),
                "a second BIN chunk (chunk 2",
            ),
            (
                glb(
                    &[(CHUNK_JSON, json), (7, &[0; 4]), (CHUNK_BIN, &[0; 4])],
                    None,
                ),
                "its BIN chunk is chunk 2",
            ),
        ];
        for (bytes, expected) in cases {
            let e = err(&bytes);
            assert!(e.contains(expected), "expected '{expected}': {e}");
        }
        // A chunk that runs past the end, and a chunk header cut short (the header's
        // length made to match the cut file).
        let mut long = glb(&[(CHUNK_JSON, json)], None);
        long[12..16].copy_from_slice(&8u32.to_le_bytes());
        let e = err(&long);
        assert!(
            e.contains("JSON chunk (chunk 0, at byte 12) announces 8 bytes, 4 remain"),
            "{e}"
        );
        let mut cut = glb(&[(CHUNK_JSON, json)], None);
        cut.extend([0, 0, 0, 0]);
        cut[8..12].copy_from_slice(&28u32.to_le_bytes());
        let e = err(&cut);
        assert!(
            e.contains("4 bytes at byte 24, where chunk 1's 8-byte header"),
            "{e}"
        );
        // Version 1 is glTF 1.0's binary; other versions are corrupt.
        let mut v1 = good.clone();
        v1[4..8].copy_from_slice(&1u32.to_le_bytes());
        assert!(err(&v1).contains("glTF 1.0 binary"), "{}", err(&v1));
        let mut v3 = good;
        v3[4..8].copy_from_slice(&3u32.to_le_bytes());
        assert!(err(&v3).contains("version 3, expected 2"), "{}", err(&v3));
    }
}

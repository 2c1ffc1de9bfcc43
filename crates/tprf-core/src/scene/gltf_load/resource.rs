//! External data of a glTF file, read under a memory budget: buffers and images named by
//! URI (`data:` base64, `file:` absolute paths, or paths relative to the glTF file) or
//! held in the .glb BIN chunk and buffer views.
//!
//! The gltf crate would read a URI's file to its end (`file:///dev/zero` never ends, a
//! FIFO blocks) and decode any image whole; here a file is read only if it is a regular
//! file, at most the buffer's declared length, and an image file is opened (a regular
//! file only) for `decode` to read as it decodes.

use super::decode::Encoded;
use super::validate::invalid;
use crate::budget::{self, BudgetError};
use crate::scene::SceneError;
use base64::Engine as _;
use std::path::{Path, PathBuf};

/// Where a URI's bytes are.
pub(super) enum Location<'a> {
    /// A `data:` URI: its media type (if any) and base64 payload.
    Data {
        mime: Option<&'a str>,
        base64: &'a str,
    },
    /// A file: `file:` URIs name the path as written, other URIs are percent-decoded
    /// and joined to the glTF file's folder.
    File(PathBuf),
}

/// Where `uri` points, for a glTF file in folder `base` (the glTF 2.0 rules the gltf
/// crate applies too); a scheme other than `data:` and `file:` is refused.
pub(super) fn locate<'a>(base: &Path, uri: &'a str) -> Result<Location<'a>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (mime, base64) = match rest.split_once(";base64,") {
            Some((mime, data)) => (Some(mime).filter(|m| !m.is_empty()), data),
            None => return Err("a data: URI must be base64 (';base64,')".into()),
        };
        return Ok(Location::Data { mime, base64 });
    }
    if let Some(path) = uri
        .strip_prefix("file://")
        .or_else(|| uri.strip_prefix("file:"))
    {
        return Ok(Location::File(PathBuf::from(path)));
    }
    if uri.contains(':') {
        let scheme = uri.split(':').next().unwrap_or_default();
        return Err(format!(
            "the URI scheme '{scheme}:' is not read (only data: and files)"
        ));
    }
    let decoded = urlencoding::decode(uri).map_err(|_| "its %-escapes do not decode to UTF-8")?;
    Ok(Location::File(base.join(&*decoded)))
}

/// The bytes at `uri` (at most `max_bytes` of a file), for `what` ("buffer 0 'a.bin'").
/// A file must be a regular file and its size fit in memory; a missing one is a
/// [`SceneError::Io`] naming the path looked for.
pub(super) fn read_uri(
    file: &str,
    base: &Path,
    what: &str,
    uri: &str,
    max_bytes: u64,
) -> Result<Vec<u8>, SceneError> {
    match locate(base, uri).map_err(|m| invalid(file, format!("{what}: {m}")))? {
        Location::Data { base64, .. } => base64::engine::general_purpose::STANDARD
            .decode(base64)
            .map_err(|e| invalid(file, format!("{what}: its data: URI is not base64: {e}"))),
        Location::File(path) => {
            let subject = format!("{what} of {file}");
            budget::read_file_prefix(&path, &subject, max_bytes).map_err(|e| match e {
                BudgetError::Io { path, source } => SceneError::Io {
                    path: format!("{} ({what} of {file})", path.display()),
                    source,
                },
                // The device or FIFO is named by its path; which buffer or image of which
                // file asked for it is said before.
                e @ BudgetError::NotAFile { .. } => invalid(file, format!("{what}: {e}")),
                e => SceneError::Budget(e),
            })
        }
    }
}

/// The encoded image at `uri`: a `data:` URI's bytes, or its file opened (a regular file
/// only), to be read as it is decoded.
pub(super) fn open_image(
    file: &str,
    base: &Path,
    what: &str,
    uri: &str,
) -> Result<Encoded<'static>, SceneError> {
    match locate(base, uri).map_err(|m| invalid(file, format!("{what}: {m}")))? {
        Location::Data { .. } => {
            let bytes = read_uri(file, base, what, uri, u64::MAX)?;
            Ok(Encoded::Bytes(bytes.into()))
        }
        Location::File(path) => match budget::open_regular(&path) {
            Ok((f, len)) => Ok(Encoded::File { file: f, len }),
            Err(BudgetError::Io { path, source }) => Err(SceneError::Io {
                path: format!("{} ({what} of {file})", path.display()),
                source,
            }),
            Err(e @ BudgetError::NotAFile { .. }) => Err(invalid(file, format!("{what}: {e}"))),
            Err(e) => Err(SceneError::Budget(e)),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris_point_where_gltf_says() {
        let base = Path::new("/scenes");
        let path = |uri| match locate(base, uri) {
            Ok(Location::File(p)) => p,
            _ => PathBuf::from("?"),
        };
        assert_eq!(path("file:///dev/zero"), PathBuf::from("/dev/zero"));
        assert_eq!(path("file:/tmp/a.bin"), PathBuf::from("/tmp/a.bin"));
        assert_eq!(path("a%20b.bin"), PathBuf::from("/scenes/a b.bin"));
        assert!(matches!(
            locate(base, "data:application/octet-stream;base64,AAAA"),
            Ok(Location::Data {
                mime: Some("application/octet-stream"),
                base64: "AAAA"
            })
        ));
        assert!(locate(base, "https://example.com/a.bin").is_err());
    }
}

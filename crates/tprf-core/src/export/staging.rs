//! Whole-folder output, and what tprf may replace.
//!
//! A command's files are written into a fresh folder beside the target and swapped in at
//! the end, so a reader never sees a new cube beside old metadata, stale frames or bounce
//! layers of an earlier render survive nowhere, and a failed, interrupted or killed write
//! leaves the previous folder as it was.
//!
//! **Never destroy what tprf did not write.** The target is replaced only when it is
//! missing, an empty folder, or a folder tprf recognises as its own output and holding
//! nothing else: each output folder carries a manifest ([`MANIFEST`]) naming the entries
//! tprf put there; folders written before the manifest are recognised by their metadata
//! (`tprf.json` of a cube, `sensor.json` of a sensor run, `converge.csv` of a convergence
//! run). Anything else is refused, naming what is there: a folder with files tprf did not
//! write (files a user added to an earlier output folder included: the run is refused, not
//! carried over; tprf does not guess whether they still belong beside a new render), a
//! regular file, a device, a FIFO, a socket, a symbolic link (never followed: what it
//! points to is not tprf's to replace), a mount point, and the current folder or one above
//! it. When the old folder is swapped out, only the entries tprf recognised are removed,
//! one by one, and the folder itself last with `rmdir`: a file that appeared in it while
//! the command ran is never deleted.

use super::ExportError;
use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// The manifest every output folder carries: JSON naming the folder's entries tprf wrote.
pub const MANIFEST: &str = ".tprf-output.json";

/// Entries a cube folder written before [`MANIFEST`] existed may hold.
const LEGACY_CUBE_ENTRIES: &[&str] = &[
    "tprf.json",
    "tprf.npy",
    "tprf_bounces.npy",
    "tprf.zarr",
    "steady.png",
    "frames",
    "ambient.npy",
    "ambient.png",
    "shard_steady.npy",
];

/// Entries of a convergence folder written before [`MANIFEST`] existed.
const LEGACY_CONVERGE_ENTRIES: &[&str] = &["converge.csv", "converge.png", "summary.md"];

/// Entries listed in a folder's manifest, at most this many (a manifest is small; a
/// larger one is not tprf's).
const MAX_MANIFEST_BYTES: u64 = 1 << 20;

/// A folder being written, to become `target` on [`Staging::commit`]; dropped without
/// committing, it is removed.
pub struct Staging {
    target: PathBuf,
    tmp: PathBuf,
    inputs: Vec<PathBuf>,
    committed: bool,
}

/// A name no other process or call uses: the process id, the time in nanoseconds and a
/// counter.
fn unique_suffix() -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    format!(
        "{}-{nanos:x}-{}",
        std::process::id(),
        COUNT.fetch_add(1, Ordering::Relaxed)
    )
}

fn refuse(target: &Path, why: impl Into<String>) -> ExportError {
    ExportError::OutRefused {
        path: target.to_path_buf(),
        why: why.into(),
    }
}

/// `names` as a short list for a message: the first five, then how many more.
fn name_list(names: &[String]) -> String {
    const SHOWN: usize = 5;
    let mut s = names
        .iter()
        .take(SHOWN)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > SHOWN {
        s.push_str(&format!(", and {} more", names.len() - SHOWN));
    }
    s
}

/// The folder `path` is in (`.` for a bare name).
fn parent_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// What kind of file system object `t` is, in words, for one that is neither a folder
/// nor a regular file nor a link.
#[cfg(unix)]
fn special_kind(t: std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_fifo() {
        "a named pipe (FIFO)"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else {
        "not a folder"
    }
}

#[cfg(not(unix))]
fn special_kind(_: std::fs::FileType) -> &'static str {
    "not a folder"
}

/// Whether folder `dir` is a mount point: on another device than its parent, or the root.
#[cfg(unix)]
fn is_mount_point(dir: &Path, meta: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    let Ok(canonical) = dir.canonicalize() else {
        return false;
    };
    match canonical.parent() {
        None => true,
        Some(parent) => std::fs::metadata(parent).is_ok_and(|p| p.dev() != meta.dev()),
    }
}

#[cfg(not(unix))]
fn is_mount_point(dir: &Path, _: &std::fs::Metadata) -> bool {
    dir.canonicalize().is_ok_and(|c| c.parent().is_none())
}

/// The names of the entries in folder `dir`.
fn entries(dir: &Path) -> Result<Vec<OsString>, ExportError> {
    let read = |source| ExportError::Read {
        path: dir.to_path_buf(),
        source,
    };
    let mut names = Vec::new();
    for e in std::fs::read_dir(dir).map_err(read)? {
        names.push(e.map_err(read)?.file_name());
    }
    names.sort();
    Ok(names)
}

/// A small JSON file at `path`, if it is a regular file that parses.
fn read_small_json(path: &Path) -> Option<serde_json::Value> {
    let meta = std::fs::symlink_metadata(path).ok()?;
    if !meta.is_file() || meta.len() > MAX_MANIFEST_BYTES {
        return None;
    }
    serde_json::from_slice(&std::fs::read(path).ok()?).ok()
}

/// The string entries of JSON array `v`.
fn string_list(v: Option<&serde_json::Value>) -> Option<Vec<String>> {
    Some(
        v?.as_array()?
            .iter()
            .filter_map(|s| s.as_str().map(String::from))
            .collect(),
    )
}

/// The entries of folder `dir` that tprf wrote, when `dir` is a tprf output folder (by
/// its manifest, or, written before manifests, by its metadata); `None` when it is not.
fn tprf_entries(dir: &Path) -> Option<BTreeSet<OsString>> {
    let listed: Vec<String> = if let Some(m) = read_small_json(&dir.join(MANIFEST)) {
        let mut l = string_list(m.get("entries"))?;
        l.push(MANIFEST.into());
        l
    } else if let Some(meta) = read_small_json(&dir.join("tprf.json")) {
        meta.get("format")?
            .as_str()?
            .starts_with("tprf cube")
            .then_some(())?;
        LEGACY_CUBE_ENTRIES.iter().map(|s| s.to_string()).collect()
    } else if let Some(meta) = read_small_json(&dir.join("sensor.json")) {
        meta.get("sensor")?;
        let mut l = string_list(meta.get("files"))?;
        l.push("sensor.json".into());
        l
    } else {
        let csv = std::fs::read(dir.join("converge.csv")).ok()?;
        csv.starts_with(b"setting,").then_some(())?;
        LEGACY_CONVERGE_ENTRIES
            .iter()
            .map(|s| s.to_string())
            .collect()
    };
    // A listed name is one entry of this folder, never a path out of it.
    let own: BTreeSet<OsString> = listed
        .into_iter()
        .filter(|n| {
            let p = Path::new(n);
            p.components().count() == 1
                && matches!(p.components().next(), Some(std::path::Component::Normal(_)))
        })
        .map(OsString::from)
        .collect();
    Some(own)
}

/// Whether entry `name` of a tprf output folder whose own entries are `own` is a
/// leftover of a write tprf did not finish: a file's temporary copy (`NAME.tmp` beside
/// its own `NAME`) or a staging folder (`.NAME.tmp-PID-TIME-N`, of a command killed while
/// it wrote an output folder inside this one).
fn is_leftover(name: &OsString, own: &BTreeSet<OsString>) -> bool {
    let Some(n) = name.to_str() else {
        return false;
    };
    if n.strip_suffix(".tmp")
        .is_some_and(|n| own.contains(&OsString::from(n)))
    {
        return true;
    }
    let Some((_, suffix)) = n.strip_prefix('.').and_then(|n| n.rsplit_once(".tmp-")) else {
        return false;
    };
    let parts: Vec<&str> = suffix.split('-').collect();
    parts.len() == 3
        && parts[0].bytes().all(|b| b.is_ascii_digit())
        && parts[1].bytes().all(|b| b.is_ascii_hexdigit())
        && parts[2].bytes().all(|b| b.is_ascii_digit())
        && parts.iter().all(|p| !p.is_empty())
}

/// What in folder `dir` tprf did not write: entries that are neither tprf's own nor a
/// leftover of an unfinished write ([`is_leftover`]) nor a tprf output folder
/// themselves (a batch puts its sensor runs inside the cube's folder), holding only
/// what tprf wrote. `None` when `dir` is not a tprf output folder at all.
fn foreign_entries(dir: &Path, depth: usize) -> Result<Option<Vec<String>>, ExportError> {
    let Some(own) = tprf_entries(dir) else {
        return Ok(None);
    };
    let mut foreign = Vec::new();
    for name in entries(dir)? {
        if own.contains(&name) || is_leftover(&name, &own) {
            continue;
        }
        let path = dir.join(&name);
        let is_dir = std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir());
        if is_dir && depth < 4 && foreign_entries(&path, depth + 1)?.is_some_and(|f| f.is_empty()) {
            continue;
        }
        foreign.push(name.to_string_lossy().into_owned());
    }
    Ok(Some(foreign))
}

/// Whether `a` is `b` or a folder above it (both made absolute, `.` and `..` resolved;
/// a path that cannot be resolved compares by its absolute spelling).
fn contains(a: &Path, b: &Path) -> bool {
    let resolve = |p: &Path| {
        p.canonicalize()
            .or_else(|_| std::path::absolute(p))
            .unwrap_or_else(|_| p.to_path_buf())
    };
    resolve(b).starts_with(resolve(a))
}

/// Check that tprf may put an output folder at `target`, before any work is done: it is
/// missing, an empty folder, or a tprf output folder holding only what tprf wrote, and it
/// is not one of `inputs` (the folders the command reads) nor a folder above one.
/// The refusal names what is there and how to proceed.
pub fn check_target(target: &Path, inputs: &[&Path]) -> Result<(), ExportError> {
    if target.as_os_str().is_empty() {
        return Err(refuse(target, "is empty: name the folder to write"));
    }
    let last = target.components().next_back();
    let is_here = matches!(
        last,
        Some(std::path::Component::CurDir | std::path::Component::ParentDir)
    ) || std::env::current_dir().is_ok_and(|cwd| contains(target, &cwd));
    if is_here {
        return Err(refuse(
            target,
            "is the current folder or one above it: tprf replaces an output folder whole; \
             name a new folder, e.g. --out ./render",
        ));
    }
    for input in inputs {
        if contains(target, input) {
            return Err(refuse(
                target,
                format!(
                    "holds {}, which this command reads: choose another output folder",
                    input.display()
                ),
            ));
        }
    }
    let meta = match std::fs::symlink_metadata(target) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(source) => {
            return Err(ExportError::Read {
                path: target.to_path_buf(),
                source,
            });
        }
    };
    let t = meta.file_type();
    if t.is_symlink() {
        let to =
            std::fs::read_link(target).map_or_else(|_| "?".into(), |p| p.display().to_string());
        return Err(refuse(
            target,
            format!(
                "is a symbolic link (to {to}): tprf never replaces what a link points to; give \
                 the folder's own path, or a new one"
            ),
        ));
    }
    if t.is_file() {
        return Err(refuse(
            target,
            "is a file, not a folder: tprf writes a folder of files; choose a new or empty folder",
        ));
    }
    if !t.is_dir() {
        return Err(refuse(
            target,
            format!(
                "is {}, not a folder: choose a new or empty folder",
                special_kind(t)
            ),
        ));
    }
    if is_mount_point(target, &meta) {
        return Err(refuse(
            target,
            "is a mount point: tprf replaces an output folder whole; name a new folder inside it",
        ));
    }
    if entries(target)?.is_empty() {
        return Ok(());
    }
    match foreign_entries(target, 0)? {
        Some(f) if f.is_empty() => Ok(()),
        Some(f) => Err(refuse(
            target,
            format!(
                "is an earlier tprf output holding files tprf did not write ({}): tprf replaces \
                 its output folder whole, so move them out first, or choose a new or empty folder",
                name_list(&f)
            ),
        )),
        None => {
            let names: Vec<String> = entries(target)?
                .iter()
                .map(|n| n.to_string_lossy().into_owned())
                .collect();
            Err(refuse(
                target,
                format!(
                    "holds files tprf did not write ({}): choose a new or empty folder",
                    name_list(&names)
                ),
            ))
        }
    }
}

impl Staging {
    /// Start writing what will become `target`: checks that `target` may be replaced
    /// ([`check_target`]; `inputs` are the folders the command reads), then makes a new,
    /// empty folder beside it. Creating it fails if the name exists, so nothing planted
    /// there is written through.
    pub fn new(target: &Path, inputs: &[&Path]) -> Result<Staging, ExportError> {
        check_target(target, inputs)?;
        let parent = parent_of(target);
        std::fs::create_dir_all(&parent).map_err(|source| ExportError::Create {
            path: parent.clone(),
            source,
        })?;
        let name = target
            .file_name()
            .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
        let tmp = parent.join(format!(".{name}.tmp-{}", unique_suffix()));
        std::fs::create_dir(&tmp).map_err(|source| ExportError::Create {
            path: tmp.clone(),
            source,
        })?;
        Ok(Staging {
            target: target.to_path_buf(),
            tmp,
            inputs: inputs.iter().map(|p| p.to_path_buf()).collect(),
            committed: false,
        })
    }

    /// Where to write the files.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// Put the written folder in place of `target`: its manifest written, `target`
    /// checked again (it may have changed while the command ran), the old folder (if any)
    /// moved aside, the new one renamed to `target`, then the old one's tprf entries
    /// removed and the folder itself with `rmdir` (what appeared in it meanwhile is left,
    /// in `TARGET.old-…`). A reader sees the old folder, then (for the moment between two
    /// renames) none, then the new one. When `target` may no longer be replaced, the new
    /// folder is kept as `TARGET.new-…` and the error names it.
    pub fn commit(mut self) -> Result<(), ExportError> {
        self.write_manifest()?;
        let inputs: Vec<&Path> = self.inputs.iter().map(PathBuf::as_path).collect();
        if let Err(e) = check_target(&self.target, &inputs) {
            let kept = self.beside("new");
            if std::fs::rename(&self.tmp, &kept).is_ok() {
                self.committed = true;
                return Err(ExportError::OutChanged {
                    path: self.target.clone(),
                    kept,
                    source: Box::new(e),
                });
            }
            return Err(e);
        }
        let old = std::fs::symlink_metadata(&self.target)
            .is_ok()
            .then(|| self.beside("old"));
        if let Some(old) = &old {
            std::fs::rename(&self.target, old).map_err(|source| ExportError::Rename {
                from: self.target.clone(),
                to: old.clone(),
                source,
            })?;
        }
        if let Err(source) = std::fs::rename(&self.tmp, &self.target) {
            // Put the old folder back.
            if let Some(old) = &old {
                let _ = std::fs::rename(old, &self.target);
            }
            return Err(ExportError::Rename {
                from: self.tmp.clone(),
                to: self.target.clone(),
                source,
            });
        }
        self.committed = true;
        if let Some(old) = old {
            remove_tprf_output(&old);
        }
        Ok(())
    }

    /// `TARGET.WHAT-SUFFIX`, beside the target.
    fn beside(&self, what: &str) -> PathBuf {
        let mut o = self.target.clone().into_os_string();
        o.push(format!(".{what}-{}", unique_suffix()));
        PathBuf::from(o)
    }

    /// The manifest: the staging folder's entries, which are all tprf's.
    fn write_manifest(&self) -> Result<(), ExportError> {
        let names: Vec<String> = entries(&self.tmp)?
            .iter()
            .map(|n| n.to_string_lossy().into_owned())
            .filter(|n| n != MANIFEST)
            .collect();
        let json = serde_json::json!({
            "written_by": format!("tprf {}", env!("CARGO_PKG_VERSION")),
            "about": "the entries of this folder that tprf wrote; tprf replaces this folder \
                      whole on a new run into it, and refuses to when it holds anything else",
            "entries": names,
        });
        super::write_json(&self.tmp.join(MANIFEST), &json)
    }
}

/// Remove the tprf output folder `dir` that was swapped out: its tprf entries (and tprf
/// output folders inside it) one by one, then the folder itself, which fails, leaving
/// it, when anything else is in it.
fn remove_tprf_output(dir: &Path) {
    let Some(own) = tprf_entries(dir) else {
        return;
    };
    let Ok(names) = entries(dir) else {
        return;
    };
    for name in names {
        let path = dir.join(&name);
        let Ok(meta) = std::fs::symlink_metadata(&path) else {
            continue;
        };
        if own.contains(&name) || is_leftover(&name, &own) {
            if meta.is_dir() {
                let _ = std::fs::remove_dir_all(&path);
            } else {
                let _ = std::fs::remove_file(&path);
            }
        } else if meta.is_dir() && matches!(foreign_entries(&path, 1), Ok(Some(f)) if f.is_empty())
        {
            remove_tprf_output(&path);
        }
    }
    let _ = std::fs::remove_dir(dir);
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tempdir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("tprf-staging-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A committed folder with one file of tprf's.
    fn output(target: &Path, content: &[u8]) {
        let s = Staging::new(target, &[]).unwrap();
        std::fs::write(s.path().join("a.npy"), content).unwrap();
        s.commit().unwrap();
    }

    #[test]
    fn a_folder_that_gains_a_user_file_during_the_run_is_kept_and_the_new_output_set_beside() {
        let dir = tempdir("changed");
        let target = dir.join("out");
        output(&target, b"old");
        let s = Staging::new(&target, &[]).unwrap();
        std::fs::write(s.path().join("a.npy"), b"new").unwrap();
        std::fs::write(target.join("notes.txt"), b"mine").unwrap();
        let Err(ExportError::OutChanged { kept, .. }) = s.commit() else {
            panic!("the commit should have been refused");
        };
        assert_eq!(std::fs::read(target.join("notes.txt")).unwrap(), b"mine");
        assert_eq!(std::fs::read(target.join("a.npy")).unwrap(), b"old");
        assert_eq!(std::fs::read(kept.join("a.npy")).unwrap(), b"new");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn removing_an_old_output_removes_only_what_tprf_wrote() {
        let dir = tempdir("remove");
        let target = dir.join("out");
        output(&target, b"old");
        // A file that appeared after the last check: the folder is left with it alone.
        std::fs::write(target.join("late.txt"), b"mine").unwrap();
        std::fs::write(target.join("a.npy.tmp"), b"half").unwrap();
        remove_tprf_output(&target);
        let left: Vec<_> = entries(&target).unwrap();
        assert_eq!(left, vec![OsString::from("late.txt")]);
        // Without it, the folder goes too.
        std::fs::remove_file(target.join("late.txt")).unwrap();
        std::fs::write(target.join(MANIFEST), br#"{"entries": ["a.npy"]}"#).unwrap();
        remove_tprf_output(&target);
        assert!(!target.exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_manifest_cannot_name_entries_outside_its_folder() {
        let dir = tempdir("escape");
        let target = dir.join("out");
        std::fs::create_dir(&target).unwrap();
        std::fs::write(dir.join("precious"), b"x").unwrap();
        std::fs::write(
            target.join(MANIFEST),
            br#"{"entries": ["../precious", "/etc/passwd", ".", "..", "sub/x"]}"#,
        )
        .unwrap();
        let own = tprf_entries(&target).unwrap();
        assert_eq!(own, BTreeSet::from([OsString::from(MANIFEST)]));
        remove_tprf_output(&target);
        assert!(dir.join("precious").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn leftovers_of_unfinished_writes_are_recognised_by_their_exact_shape() {
        let own = BTreeSet::from([OsString::from("tprf.npy")]);
        for (name, is) in [
            ("tprf.npy.tmp", true),
            ("mine.tmp", false),
            (".sensor-lidar.tmp-1234-18f3a-0", true),
            (".sensor-lidar.tmp-12x4-18f3a-0", false),
            (".notes.tmp-1", false),
            ("notes.tmp-1-a-2", false),
        ] {
            assert_eq!(is_leftover(&OsString::from(name), &own), is, "{name}");
        }
    }
}

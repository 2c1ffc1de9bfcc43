//! Whole-folder output: a render's files are written into a fresh folder beside the
//! target and swapped in at the end, so a reader never sees a new cube beside old
//! metadata, stale frames or bounce layers of an earlier render survive nowhere, and a
//! failed or killed write leaves the previous folder as it was.

use super::ExportError;
use std::path::{Path, PathBuf};

/// A folder being written, to become `target` on [`Staging::commit`]; dropped without
/// committing, it is removed.
pub struct Staging {
    target: PathBuf,
    tmp: PathBuf,
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

impl Staging {
    /// Start writing what will become `target`: a new, empty folder beside it. Creating
    /// it fails if the name exists, so nothing planted there is written through.
    pub fn new(target: &Path) -> Result<Staging, ExportError> {
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
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
            committed: false,
        })
    }

    /// Where to write the files.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// Put the written folder in place of `target`: the old folder (if any) is moved
    /// aside, the new one renamed to `target`, then the old one removed. A reader sees
    /// the old folder, then (for the moment between two renames) none, then the new one.
    pub fn commit(mut self) -> Result<(), ExportError> {
        let old = self.target.exists().then(|| {
            let mut o = self.target.clone().into_os_string();
            o.push(format!(".old-{}", unique_suffix()));
            PathBuf::from(o)
        });
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
            let _ = std::fs::remove_dir_all(old);
        }
        Ok(())
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.tmp);
        }
    }
}

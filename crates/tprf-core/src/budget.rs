//! Memory budgets: how much more memory the process may use, and a refusal that names
//! the size and what it is for, made *before* an allocation whose size an input
//! controls (a glTF's triangles after instancing, a texture's decoded pixels, a film, a
//! 1-D world's live packets). Also files read whole into memory: only a regular file
//! (a device such as `/dev/zero` never ends, a FIFO blocks until a writer comes), its
//! size budgeted first and the read bounded by that size.
//!
//! What the process may still use is the least of (Linux; where none can be read,
//! nothing is refused):
//! - `MemAvailable` (/proc/meminfo): what the system can give without swapping;
//! - for its cgroup v2 and each parent: `memory.max - memory.current`;
//! - cgroup v1: `memory.limit_in_bytes - memory.usage_in_bytes`;
//! - `RLIMIT_AS` (`ulimit -v`) less the address space mapped now (`VmSize`), and
//!   `RLIMIT_DATA` (`ulimit -d`) less the data mapped now (`VmData`).
//!
//! A check compares one stage's whole need (every buffer it will hold at once) with
//! that figure, so a refusal comes before the first byte of it is allocated.

use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};

/// What limits the memory available.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Limit {
    /// The system's `MemAvailable`.
    System,
    /// A cgroup v2 `memory.max`.
    CgroupV2,
    /// A cgroup v1 `memory.limit_in_bytes`.
    CgroupV1,
    /// `RLIMIT_AS`.
    AddressSpace,
    /// `RLIMIT_DATA`.
    DataSegment,
}

impl fmt::Display for Limit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Limit::System => "free system memory",
            Limit::CgroupV2 => "the cgroup's memory.max",
            Limit::CgroupV1 => "the cgroup's memory.limit_in_bytes",
            Limit::AddressSpace => "the address-space limit, ulimit -v",
            Limit::DataSegment => "the data limit, ulimit -d",
        })
    }
}

/// Bytes the process may still allocate, and what sets that figure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Available {
    pub bytes: u64,
    pub limited_by: Limit,
}

/// Why a budget check or a whole-file read refused.
#[derive(Debug, thiserror::Error)]
pub enum BudgetError {
    #[error(
        "{subject} needs {} for {purpose}; {} available ({limited_by})",
        format_bytes(*need_bytes),
        format_bytes(*available_bytes)
    )]
    Memory {
        /// What needs it: "this scene", "the film".
        subject: String,
        /// What for: "98.0 M triangles after instancing".
        purpose: String,
        need_bytes: u64,
        available_bytes: u64,
        limited_by: Limit,
    },
    #[error("{path} is {kind}, not a regular file: not read (it may never end, or block)")]
    NotAFile { path: PathBuf, kind: &'static str },
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Bytes for a person: `512 B`, `3.2 KiB`, `37.0 GiB` (powers of 1024).
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = UNITS[0];
    for next in &UNITS[1..] {
        if value < 1024.0 {
            break;
        }
        value /= 1024.0;
        unit = next;
    }
    format!("{value:.1} {unit}")
}

/// A size in bytes as a person writes it: `2GiB`, `512 MiB`, `1.5G`, `300MB`, `4096`
/// (bytes). `KiB MiB GiB TiB` and `K M G T` are powers of 1024, `kB MB GB TB` powers of
/// 1000, `B` (or no unit) bytes.
pub fn parse_bytes(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let value: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("'{text}': '{}' is not a number", num.trim()))?;
    let scale: f64 = match unit.trim() {
        "" | "B" => 1.0,
        "K" | "KiB" | "k" => 1024.0,
        "M" | "MiB" => 1024.0 * 1024.0,
        "G" | "GiB" => 1024.0 * 1024.0 * 1024.0,
        "T" | "TiB" => 1024f64.powi(4),
        "kB" | "KB" => 1e3,
        "MB" => 1e6,
        "GB" => 1e9,
        "TB" => 1e12,
        other => {
            return Err(format!(
                "'{text}': unknown unit '{other}' (B, KiB MiB GiB TiB or K M G T, kB MB GB TB)"
            ));
        }
    };
    let bytes = value * scale;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("'{text}' is not a size of at least 1 byte"));
    }
    Ok(bytes.round() as u64)
}

/// A count for a person: `5000`, `98.0 M`, `3.0 G`.
pub fn format_count(n: u64) -> String {
    match n {
        0..100_000 => n.to_string(),
        100_000..1_000_000_000 => format!("{:.1} M", n as f64 / 1e6),
        _ => format!("{:.1} G", n as f64 / 1e9),
    }
}

/// The memory the process may still use now; `None` where nothing can be read.
pub fn available() -> Option<Available> {
    let candidates = [
        mem_available().map(|b| (b, Limit::System)),
        cgroup_v2_room().map(|b| (b, Limit::CgroupV2)),
        cgroup_v1_room().map(|b| (b, Limit::CgroupV1)),
        rlimit_room(Rlimit::AddressSpace).map(|b| (b, Limit::AddressSpace)),
        rlimit_room(Rlimit::Data).map(|b| (b, Limit::DataSegment)),
    ];
    candidates
        .into_iter()
        .flatten()
        .min_by_key(|&(b, _)| b)
        .map(|(bytes, limited_by)| Available { bytes, limited_by })
}

/// Refuse `need_bytes` for `subject` (what needs it) and `purpose` (what for) when more
/// than [`available`] now.
pub fn check(
    need_bytes: u64,
    subject: &str,
    purpose: impl fmt::Display,
) -> Result<(), BudgetError> {
    check_against(need_bytes, available(), subject, purpose)
}

/// [`check`] against a given availability (`None`: unknown, nothing refused).
pub fn check_against(
    need_bytes: u64,
    available: Option<Available>,
    subject: &str,
    purpose: impl fmt::Display,
) -> Result<(), BudgetError> {
    match available {
        Some(a) if need_bytes > a.bytes => Err(BudgetError::Memory {
            subject: subject.to_string(),
            purpose: purpose.to_string(),
            need_bytes,
            available_bytes: a.bytes,
            limited_by: a.limited_by,
        }),
        _ => Ok(()),
    }
}

/// What a non-regular file is, in words.
fn file_kind(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a folder"
    } else {
        "not a regular file"
    }
}

/// Open `path` for reading if it is a regular file (symbolic links followed), without
/// blocking on a FIFO; the file and its length in bytes.
pub fn open_regular(path: &Path) -> Result<(std::fs::File, u64), BudgetError> {
    let io = |source| BudgetError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        // Opening a FIFO for reading blocks until a writer opens it; O_NONBLOCK returns at
        // once, and the type is then checked on the open file (no race with a rename).
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    if !meta.is_file() {
        return Err(BudgetError::NotAFile {
            path: path.to_path_buf(),
            kind: file_kind(meta.file_type()),
        });
    }
    Ok((file, meta.len()))
}

/// Read the regular file `path` whole, after checking that its size fits in memory
/// (`subject` names what it is in a refusal: "the scene file"). At most the size the
/// file had when opened is read.
pub fn read_file(path: &Path, subject: &str) -> Result<Vec<u8>, BudgetError> {
    read_file_prefix(path, subject, u64::MAX)
}

/// [`read_file`] as UTF-8 text; the error in words, the path first where it is not
/// already in it: what a file's reader puts after "cannot read FILE: ".
pub fn read_text(path: &Path, subject: &str) -> Result<String, String> {
    let bytes = read_file(path, subject).map_err(|e| match e {
        BudgetError::Io { source, .. } => source.to_string(),
        e => e.to_string(),
    })?;
    String::from_utf8(bytes).map_err(|e| format!("not UTF-8 text ({e})"))
}

/// [`read_file`], reading at most `max_bytes` (a glTF buffer of a declared length).
pub fn read_file_prefix(
    path: &Path,
    subject: &str,
    max_bytes: u64,
) -> Result<Vec<u8>, BudgetError> {
    let (file, len) = open_regular(path)?;
    let len = len.min(max_bytes);
    check(len, subject, format_args!("reading {}", path.display()))?;
    let mut data = Vec::new();
    data.try_reserve_exact(len as usize)
        .map_err(|_| BudgetError::Io {
            path: path.to_path_buf(),
            source: std::io::ErrorKind::OutOfMemory.into(),
        })?;
    file.take(len)
        .read_to_end(&mut data)
        .map_err(|source| BudgetError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(data)
}

/// `MemAvailable` from /proc/meminfo, bytes.
fn mem_available() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    kib_field(&info, "MemAvailable:")
}

/// The value of a `Name:  123 kB` line, in bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// A number of bytes in a cgroup file; `None` for `max` (no limit) or anything else.
fn read_bytes(path: &Path) -> Option<u64> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

/// The least `memory.max - memory.current` of the process's cgroup v2 and its parents.
fn cgroup_v2_room() -> Option<u64> {
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let rel = cgroups.lines().find_map(|l| l.strip_prefix("0::"))?;
    let root = Path::new("/sys/fs/cgroup");
    let mut dir = root.join(rel.trim_start_matches('/'));
    let mut room: Option<u64> = None;
    loop {
        if let (Some(max), Some(current)) = (
            read_bytes(&dir.join("memory.max")),
            read_bytes(&dir.join("memory.current")),
        ) {
            let r = max.saturating_sub(current);
            room = Some(room.map_or(r, |m| m.min(r)));
        }
        if dir == root || !dir.pop() || !dir.starts_with(root) {
            break;
        }
    }
    room
}

/// `memory.limit_in_bytes - memory.usage_in_bytes` of a cgroup v1 memory controller
/// (the process's own group, else the mount's root as a container sees it). Limits of
/// 2^62 and above mean none.
fn cgroup_v1_room() -> Option<u64> {
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let rel = cgroups.lines().find_map(|l| {
        let mut parts = l.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        controllers
            .split(',')
            .any(|c| c == "memory")
            .then_some(path)
    })?;
    let mount = Path::new("/sys/fs/cgroup/memory");
    [mount.join(rel.trim_start_matches('/')), mount.to_path_buf()]
        .iter()
        .find_map(|dir| {
            let limit = read_bytes(&dir.join("memory.limit_in_bytes"))?;
            let usage = read_bytes(&dir.join("memory.usage_in_bytes"))?;
            (limit < 1 << 62).then(|| limit.saturating_sub(usage))
        })
}

#[derive(Clone, Copy)]
enum Rlimit {
    AddressSpace,
    Data,
}

/// Room left under a resource limit: the soft limit less what is mapped now.
fn rlimit_room(which: Rlimit) -> Option<u64> {
    #[cfg(target_os = "linux")]
    {
        let (resource, field) = match which {
            Rlimit::AddressSpace => (libc::RLIMIT_AS, "VmSize:"),
            Rlimit::Data => (libc::RLIMIT_DATA, "VmData:"),
        };
        let mut lim = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit writes one rlimit through a valid pointer.
        if unsafe { libc::getrlimit(resource, &mut lim) } != 0
            || lim.rlim_cur == libc::RLIM_INFINITY
        {
            return None;
        }
        let status = std::fs::read_to_string("/proc/self/status").ok()?;
        let used = kib_field(&status, field)?;
        #[allow(clippy::unnecessary_cast, reason = "u64 on Linux, but not everywhere")]
        Some((lim.rlim_cur as u64).saturating_sub(used))
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = which;
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_as_written() {
        assert_eq!(parse_bytes("2GiB").unwrap(), 2 << 30);
        assert_eq!(parse_bytes(" 1.5 G").unwrap(), 3 << 29);
        assert_eq!(parse_bytes("300MB").unwrap(), 300_000_000);
        assert_eq!(parse_bytes("4096").unwrap(), 4096);
        assert_eq!(parse_bytes("64 KiB").unwrap(), 65536);
        for bad in ["", "GiB", "2 furlongs", "-1G", "0", "inf", "1e30 TiB"] {
            assert!(parse_bytes(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn bytes_and_counts_read_as_a_person_writes_them() {
        assert_eq!(format_bytes(512), "512 B");
        assert_eq!(format_bytes(3 * 1024 + 205), "3.2 KiB");
        assert_eq!(format_bytes(37 << 30), "37.0 GiB");
        assert_eq!(format_count(5000), "5000");
        assert_eq!(format_count(98_000_000), "98.0 M");
    }

    #[test]
    fn a_refusal_names_the_size_the_purpose_and_the_limit() {
        let a = Available {
            bytes: 20 << 30,
            limited_by: Limit::CgroupV2,
        };
        let e = check_against(
            37 << 30,
            Some(a),
            "this scene",
            "98.0 M triangles after instancing",
        );
        let m = e.map_err(|e| e.to_string()).err().unwrap_or_default();
        assert_eq!(
            m,
            "this scene needs 37.0 GiB for 98.0 M triangles after instancing; 20.0 GiB \
             available (the cgroup's memory.max)"
        );
        assert!(check_against(20 << 30, Some(a), "x", "y").is_ok());
        assert!(check_against(u64::MAX, None, "x", "y").is_ok());
    }

    #[test]
    fn this_process_has_some_memory() {
        // On Linux MemAvailable is always there; the figure is below the machine's RAM.
        if cfg!(target_os = "linux") {
            let a = available().expect("MemAvailable");
            assert!(a.bytes > 0);
        }
    }

    #[cfg(unix)]
    #[test]
    fn devices_and_folders_are_not_read() {
        match read_file(Path::new("/dev/zero"), "x") {
            Err(BudgetError::NotAFile { kind, .. }) => assert_eq!(kind, "a character device"),
            other => panic!("{other:?}"),
        }
        match read_file(Path::new("/"), "x") {
            Err(BudgetError::NotAFile { kind, .. }) => assert_eq!(kind, "a folder"),
            other => panic!("{other:?}"),
        }
    }
}

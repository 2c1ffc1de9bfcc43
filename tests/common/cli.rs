//! Running the `tprf` binary from a test and reading what it writes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// `tprf ARGS...`, its output captured.
pub fn tprf(args: &[&str]) -> Output {
    // Built for the root package's tests only: tprf-core's tests share this folder.
    let Some(bin) = option_env!("CARGO_BIN_EXE_tprf") else {
        panic!("the tprf binary is built for the root package's tests only");
    };
    Command::new(bin).args(args).output().expect("run tprf")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh folder `TESTFILE-NAME-PID` under the target's temporary folder (`TESTFILE` the
/// test crate's name).
pub fn tempdir(name: &str) -> PathBuf {
    let test = module_path!().split("::").next().unwrap_or("test");
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("{test}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

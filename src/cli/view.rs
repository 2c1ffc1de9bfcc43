//! `tprf view` (and `tprf` alone): the window on a cube folder or a scene.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::Args;

use crate::viewer::Start;

#[derive(Args, Debug)]
pub struct ViewArgs {
    /// A cube folder, a glTF or Mitsuba XML file, or builtin:NAME.
    pub what: Option<String>,
}

/// `tprf view` (and `tprf` alone): the window.
pub fn run(a: &ViewArgs) -> Result<()> {
    let start = match &a.what {
        None => Start::Default,
        Some(w) if Path::new(w).is_dir() => Start::Cube(PathBuf::from(w)),
        Some(w) => Start::Scene(w.clone()),
    };
    // rayon's global pool (the UI's time slices and gate images, the automatic window's
    // pilot) named as such: unnamed, its threads took the name of whichever thread made
    // them first (the render thread's), which made profiles of the window misleading.
    // Already built (it cannot be here) is not an error worth stopping for.
    let _ = rayon::ThreadPoolBuilder::new()
        .thread_name(|i| format!("tprf-global-{i}"))
        .build_global();
    crate::viewer::run(start).map_err(|e| anyhow::anyhow!("cannot open the window: {e}"))
}

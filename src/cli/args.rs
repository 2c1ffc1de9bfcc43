//! Helpers the commands share: time options with units, the worker pool.

use anyhow::{Context, Result};
use tprf_core::units::parse_time_s;

/// The value of a time option such as `--t0 3ns` or `--dt 1cm` (a unit of time, or of
/// optical path length divided by c), in seconds; an error names the `option`.
pub(super) fn time_s(text: &str, option: &str) -> Result<f64> {
    parse_time_s(text)
        .map_err(anyhow::Error::msg)
        .with_context(|| option.to_string())
}

/// The worker pool: `threads` threads, or one per core when `None`.
pub(super) fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        pool = pool.num_threads(n);
    }
    pool.build().context("cannot start the worker threads")
}

/// Refuse, before any work, an output folder tprf may not replace
/// (`tprf_core::export::staging::check_target`): "--out PATH: what is there: what to do".
/// `inputs` are the folders and files the command reads.
pub fn check_out(flag: &str, out: &std::path::Path, inputs: &[&std::path::Path]) -> Result<()> {
    use tprf_core::export::{ExportError, staging::check_target};
    check_target(out, inputs).map_err(|e| match e {
        ExportError::OutRefused { path, why } => {
            anyhow::anyhow!("{flag} {}: {why}", path.display())
        }
        e => anyhow::Error::from(e).context(flag.to_string()),
    })
}

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

//! `tprf merge OUT SHARD_DIR...`: the folders of `tprf render --shard K/N` into the one
//! cube folder a single process writes (bit for bit; `tprf_core::export::shard`).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use clap::Args;
use tprf_core::export::shard;

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The merged cube folder: new, empty, or an earlier tprf output, which is replaced
    /// whole (written beside it and swapped in); anything else is refused.
    pub out: PathBuf,
    /// The shard folders: every K of 0..N exactly once, in any order.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
}

/// `tprf merge`.
pub fn run(a: &MergeArgs) -> Result<()> {
    let start = Instant::now();
    let inputs: Vec<&std::path::Path> = a.shards.iter().map(PathBuf::as_path).collect();
    super::args::check_out("OUT", &a.out, &inputs)?;
    let report = shard::merge(&a.shards, &a.out)?;
    let chunks = report.chunks_linked + report.chunks_copied + report.chunks_combined;
    let linked = if chunks > 0 {
        format!(
            ", {} chunk files linked, {} copied, {} put together from several shards",
            report.chunks_linked, report.chunks_copied, report.chunks_combined
        )
    } else {
        String::new()
    };
    eprintln!(
        "merged {} shards into {} ({:.1} MiB of cube read{linked}, {:.2} s)",
        report.shards,
        a.out.display(),
        report.bytes_read as f64 / (1u64 << 20) as f64,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

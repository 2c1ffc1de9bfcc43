//! `tprf stability`: stiff and extreme cases as a verdict table.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Result, bail};
use clap::Args;
use tprf_core::export;
use tprf_core::report::stability::{Size, cases, markdown};

use super::args::thread_pool;

#[derive(Args, Debug)]
pub struct StabilityArgs {
    /// Output folder for stability.md: a new or empty one, or an earlier tprf output
    /// (replaced whole); anything else is refused up front.
    #[arg(long)]
    pub out: PathBuf,
    /// Case sizes: full (larger films, more samples) or test (what the tests run).
    #[arg(long, value_enum, default_value_t = StabilitySize::Full)]
    pub size: StabilitySize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum StabilitySize {
    Test,
    Full,
}

/// `tprf stability`.
pub fn run(a: &StabilityArgs) -> Result<()> {
    if a.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let size = match a.size {
        StabilitySize::Test => Size::Test,
        StabilitySize::Full => Size::Full,
    };
    super::args::check_out("--out", &a.out, &[])?;
    let pool = thread_pool(a.threads)?;
    let start = Instant::now();
    let mut rows = Vec::new();
    for (name, case) in cases() {
        let t = Instant::now();
        let r = pool.install(|| case(size));
        let failed = r.iter().filter(|r| !r.passed()).count();
        eprintln!(
            "{name}: {} rows, {failed} failed, {:.1} s",
            r.len(),
            t.elapsed().as_secs_f64()
        );
        rows.extend(r);
    }
    let table = markdown(&rows);
    let text = format!(
        "# tprf stability ({:?} size, {:.0} s on {} threads)\n\n{table}",
        size,
        start.elapsed().as_secs_f64(),
        pool.current_num_threads()
    );
    let staging = export::staging::Staging::new(&a.out, &[])?;
    export::write_atomic(&staging.path().join("stability.md"), |w| {
        use std::io::Write;
        w.write_all(text.as_bytes())?;
        Ok(())
    })?;
    staging.commit()?;
    let path = a.out.join("stability.md");
    print!("{table}");
    let failed = rows.iter().filter(|r| !r.passed()).count();
    eprintln!("wrote {}", path.display());
    if failed > 0 {
        bail!("{failed} of {} stability checks failed", rows.len());
    }
    Ok(())
}

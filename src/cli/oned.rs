//! `tprf oned`: the exact impulse train of a 1-D world file, and its binned TPRF.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::Args;
use tprf_core::budget;
use tprf_core::oned::{ImpulseOptions, InterfaceKind, World, WorldError, binned};

use super::args::time_s;

#[derive(Args, Debug)]
pub struct OnedArgs {
    /// The world description (JSON; see docs/oned.md).
    pub world: PathBuf,
    /// Bin the train: start of the window (with a unit, as for render --t0).
    #[arg(long, requires_all = ["dt", "bins"])]
    pub t0: Option<String>,
    /// Bin width (with a unit).
    #[arg(long, requires_all = ["t0", "bins"])]
    pub dt: Option<String>,
    /// Number of bins.
    #[arg(long, requires_all = ["t0", "dt"])]
    pub bins: Option<usize>,
}

/// `tprf oned`.
pub fn run(a: &OnedArgs) -> Result<()> {
    let bins = match (&a.t0, &a.dt, a.bins) {
        (Some(t0), Some(dt), Some(n)) => Some((time_s(t0, "--t0")?, time_s(dt, "--dt")?, n)),
        _ => None,
    };
    print_oned(&a.world, bins, &mut std::io::stdout().lock())
}

/// Nanoseconds per second: `tprf oned` prints times in ns.
const NS_PER_S: f64 = 1e9;

/// Refuse a binning window (`--t0`, `--dt`, `--bins`; seconds) whose times overflow or
/// collapse: every bin edge `t0 + b dt` must be finite also in the nanoseconds printed,
/// and neighbouring edges must differ in double precision (`dt` at least 4 units in the
/// last place of the largest edge: each edge is rounded twice, by less than 1.5 units,
/// so computed edges then still increase).
fn check_window(t0_s: f64, dt_s: f64, count: usize) -> Result<()> {
    anyhow::ensure!(
        (1..=tprf_core::film::MAX_BINS).contains(&count),
        "--bins {count} must be in 1..={}",
        tprf_core::film::MAX_BINS
    );
    anyhow::ensure!(
        (t0_s * NS_PER_S).is_finite(),
        "--t0 {t0_s:e} s: times overflow (the window must start and end within {:e} s of 0, \
         finite in the nanoseconds printed)",
        f64::MAX / NS_PER_S
    );
    anyhow::ensure!(
        dt_s > 0.0 && dt_s.is_finite(),
        "--dt {dt_s:e} s must be a positive finite bin width"
    );
    let end_s = t0_s + dt_s * count as f64;
    anyhow::ensure!(
        (end_s * NS_PER_S).is_finite(),
        "--dt {dt_s:e} s x --bins {count} from --t0 {t0_s:e} s ends the window at {end_s:e} s: \
         times overflow (the window must end within {:e} s of 0, finite in the nanoseconds \
         printed); use fewer or narrower bins",
        f64::MAX / NS_PER_S
    );
    let largest_s = t0_s.abs().max(end_s.abs());
    anyhow::ensure!(
        dt_s >= 4.0 * f64::EPSILON * largest_s,
        "--dt {dt_s:e} s is below double precision's resolution at {largest_s:e} s (the \
         window --t0 {t0_s:e} s + --bins {count} bins): neighbouring bin edges would be \
         equal; use a wider --dt or a --t0 nearer 0"
    );
    Ok(())
}

/// `tprf oned`'s output: reads the world file at `path`, prints its impulse train (time in
/// ns, optical path length in m, weight, order) and, with `bins = Some((t0_s, dt_s,
/// count))`, the binned TPRF (bin index, bin start in ns, integrated weight). Lines
/// starting with `#` are comments; the rest are whitespace-separated columns.
pub fn print_oned(
    path: &Path,
    bins: Option<(f64, f64, usize)>,
    out: &mut impl Write,
) -> Result<()> {
    if let Some((t0_s, dt_s, count)) = bins {
        check_window(t0_s, dt_s, count)?;
    }
    let world = World::from_path(path).map_err(|e| match e {
        WorldError::Io { .. } => anyhow::Error::new(e),
        other => anyhow::anyhow!("{}: {other}", path.display()),
    })?;
    let opts = ImpulseOptions::default();
    let interfaces = world.interfaces().len();
    // The enumeration holds at most `max_bytes`: refuse now what memory cannot give.
    budget::check(
        opts.max_bytes,
        &format!("the 1-D world {}", path.display()),
        format_args!(
            "its live packets and impulses (up to {} packets of {} for {interfaces} interfaces)",
            budget::format_count(opts.max_packets(interfaces)),
            budget::format_bytes(ImpulseOptions::packet_bytes(interfaces))
        ),
    )?;
    let train = world.impulse_train(&opts);

    writeln!(out, "# tprf 1-D world: {}", path.display())?;
    writeln!(
        out,
        "# eye at {} m looking {}; light at {} m",
        world.eye_m(),
        world.look(),
        world.light_m()
    )?;
    for (i, interface) in world.interfaces().iter().enumerate() {
        let ior_right = world.segment_ior().get(i + 1).copied().unwrap_or(1.0);
        match interface.kind {
            InterfaceKind::Real => writeln!(
                out,
                "# interface {} at {} m: left r {} t {}, right r {} t {}; ior right of it {}",
                interface.name,
                interface.x_m,
                interface.left.reflectance,
                interface.left.transmittance,
                interface.right.reflectance,
                interface.right.transmittance,
                ior_right
            )?,
            kind => writeln!(
                out,
                "# interface {} at {} m: {kind}; ior right of it {}",
                interface.name, interface.x_m, ior_right
            )?,
        }
    }
    let e = &train.energy;
    writeln!(
        out,
        "# energy ({} emitted, 1 each way): escaped {:.6e}, absorbed {:.6e}, cut {:.3e} \
         (weight {:.3e}, time {:.3e}, order {:.3e}, packets {:.3e})",
        e.emitted,
        e.escaped,
        e.absorbed,
        e.cut_total(),
        e.cut_weight,
        e.cut_time,
        e.cut_order,
        e.cut_packets
    )?;
    if train.truncated {
        writeln!(
            out,
            "# WARNING: the enumeration reached its memory limit of {} ({} live packets of {} \
             for {interfaces} interfaces, with the impulses): the train is incomplete",
            budget::format_bytes(opts.max_bytes),
            budget::format_count(opts.max_packets(interfaces)),
            budget::format_bytes(ImpulseOptions::packet_bytes(interfaces))
        )?;
    }
    let seen: f64 = train.impulses.iter().map(|i| i.weight).sum();
    writeln!(
        out,
        "# impulses: {} (total weight {:.12e}; cut-offs: weight < {:e}, order > {})",
        train.impulses.len(),
        seen,
        opts.min_weight,
        opts.max_order
    )?;
    writeln!(
        out,
        "# {:>20} {:>20} {:>20} {:>6}",
        "time_ns", "opl_m", "weight", "order"
    )?;
    for impulse in &train.impulses {
        writeln!(
            out,
            "  {:>20.9} {:>20.9} {:>20.12e} {:>6}",
            impulse.time_s * 1e9,
            impulse.opl_m(),
            impulse.weight,
            impulse.order
        )?;
    }

    if let Some((t0_s, dt_s, count)) = bins {
        let values = binned(&train.impulses, t0_s, dt_s, count);
        let inside: f64 = values.iter().sum();
        writeln!(
            out,
            "# binned TPRF: t0 {:.9} ns, dt {:.9} ns, {} bins (weight in the window {:.12e})",
            t0_s * 1e9,
            dt_s * 1e9,
            count,
            inside
        )?;
        writeln!(out, "# {:>8} {:>20} {:>20}", "bin", "start_ns", "value")?;
        for (b, value) in values.iter().enumerate() {
            writeln!(
                out,
                "  {:>8} {:>20.9} {:>20.12e}",
                b,
                (t0_s + b as f64 * dt_s) * 1e9,
                value
            )?;
        }
    }
    Ok(())
}

//! `tprf converge`: error against run time for estimator settings against a reference.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Result, bail};
use clap::Args;
use tprf_core::report::converge::{
    EstimatorSetting, FilmRequest, RunConfig, resolve_target, run_setting, summarise, summary_text,
    write_outputs,
};
use tprf_core::request::RenderRequest;
use tprf_core::units::format_time;

use super::args::{thread_pool, time_s};

#[derive(Args, Debug)]
pub struct ConvergeArgs {
    /// What to render: with an analytic reference leave it out (the reference builds its
    /// scene); with a .npy reference, the scene it was rendered from (a glTF path or
    /// builtin:NAME). An analytic:... spec here is its own reference.
    pub scene: Option<String>,
    /// analytic:furnace?rho=0.9 (also r, i, light=area, le), analytic:plane (h, rho, i,
    /// fov, light_h), analytic:oned (world=PATH; default the paper's Figure 4 world), or
    /// a tprf.npy written by `tprf render` (its tprf.json beside it).
    #[arg(long)]
    pub reference: Option<String>,
    /// Seconds of rendering per estimator setting (a setting's own seconds=S wins).
    #[arg(long, default_value_t = 10.0)]
    pub seconds: f64,
    /// Output folder: a new or empty one, or an earlier tprf output (replaced whole);
    /// anything else is refused up front.
    #[arg(long)]
    pub out: PathBuf,
    /// An estimator setting to compare (repeat for several on one plot): `default`, or
    /// comma-separated nee=on|off, filter=box|tent, rr_start=N, rr_floor=P,
    /// max_bounces=N, splits=N|auto, light_vertex=on|off, adaptive=on|off, seconds=S.
    /// Default: just `default`.
    #[arg(long = "setting")]
    pub settings: Vec<String>,
    /// Film width (default: the reference's).
    #[arg(long)]
    pub width: Option<usize>,
    #[arg(long)]
    pub height: Option<usize>,
    #[arg(long)]
    pub bins: Option<usize>,
    /// Start of the time window, with a unit (default: the reference's).
    #[arg(long)]
    pub t0: Option<String>,
    /// Bin width, with a unit (default: the reference's).
    #[arg(long)]
    pub dt: Option<String>,
    /// Checkpoints per decade of time.
    #[arg(long, default_value_t = 8)]
    pub per_decade: u32,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Memory the film may take, with a unit (`4GiB`, `500MB`); a setting whose next
    /// pass would not fit ends there, its checkpoints kept, and `tprf` exits with status
    /// 3 after writing the outputs. Default: what the system can give.
    #[arg(long, value_name = "SIZE", value_parser = super::args::bytes_value)]
    pub max_memory: Option<u64>,
}

/// `tprf converge`.
pub fn run(a: &ConvergeArgs) -> Result<()> {
    if !(a.seconds.is_finite() && a.seconds > 0.0) {
        bail!("--seconds must be a positive number (got {})", a.seconds);
    }
    // What the run reads (a reference cube, a scene file) is never replaced by its output.
    let inputs: Vec<&std::path::Path> = [a.scene.as_deref(), a.reference.as_deref()]
        .into_iter()
        .flatten()
        .map(std::path::Path::new)
        .collect();
    super::args::check_out("--out", &a.out, &inputs)?;
    if a.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    if a.per_decade == 0 || a.per_decade > 100 {
        bail!("--per-decade must be in 1..=100");
    }
    let parse = |s: &Option<String>, what: &str| s.as_deref().map(|t| time_s(t, what)).transpose();
    let film = FilmRequest {
        width: a.width,
        height: a.height,
        bins: a.bins,
        t0_s: parse(&a.t0, "--t0")?,
        dt_s: parse(&a.dt, "--dt")?,
    };
    let settings: Vec<EstimatorSetting> = if a.settings.is_empty() {
        vec![EstimatorSetting::default_setting()]
    } else {
        a.settings
            .iter()
            .map(|s| EstimatorSetting::parse(s).map_err(anyhow::Error::msg))
            .collect::<Result<_>>()?
    };
    let target = resolve_target(a.scene.as_deref(), a.reference.as_deref(), &film)
        .map_err(converge_flags)?;
    let pool = thread_pool(a.threads)?;
    let config = RunConfig {
        seconds: a.seconds,
        per_decade: a.per_decade,
        base: RenderRequest {
            seed: a.seed,
            channel: target.channel,
            max_memory_bytes: a.max_memory,
            ..RenderRequest::default()
        },
    };
    let r = &target.reference;
    eprintln!(
        "{}: {} x {} pixels, {} bins of {} from {}; {} setting(s), {} s each",
        target.label,
        r.width,
        r.height,
        r.axis.bins,
        format_time(r.axis.dt_s),
        format_time(r.axis.t0_s),
        settings.len(),
        a.seconds
    );
    let scene = Arc::new(target.scene);
    let mut all = Vec::new();
    let mut summaries = Vec::new();
    // Settings that ended before their budget, their next pass not fitting in memory.
    let mut stopped = Vec::new();
    for s in &settings {
        let run = pool
            .install(|| {
                run_setting(&scene, s, &config, r, |c| {
                    eprintln!(
                        "  {:<24} {:>8.2} s {:>8} spp  error {:.3e}  estimate {}",
                        c.setting,
                        c.seconds,
                        c.spp,
                        c.rel_l2_cube,
                        c.half_estimate
                            .map_or("-".to_string(), |e| format!("{e:.3e}"))
                    )
                })
            })
            .map_err(super::args::request_error)?;
        if let Some(stop) = &run.memory_stop {
            let text = stop.text_with(super::args::flag);
            eprintln!("  {}: stopped: {text}", s.label);
            stopped.push(format!("{}: {text}", s.label));
        }
        summaries.extend(summarise(&run.checkpoints));
        all.extend(run.checkpoints);
    }
    let title = format!(
        "{}: {} x {} x {} bins",
        target.label, r.width, r.height, r.axis.bins
    );
    write_outputs(&a.out, &inputs, &title, &all, &summaries)?;
    eprint!("{}", summary_text(&summaries));
    eprintln!("wrote {}", a.out.display());
    if stopped.is_empty() {
        Ok(())
    } else {
        Err(super::render::StoppedForMemory(stopped.join("; ")).into())
    }
}

/// `e` with the `tprf converge` arguments it concerns in front.
fn converge_flags(e: tprf_core::report::ReportError) -> anyhow::Error {
    use tprf_core::report::ReportError as E;
    let flags = match &e {
        E::NoReference => "--reference",
        E::SceneWithAnalytic { .. } => "SCENE",
        E::NoScene => {
            return anyhow::anyhow!("a .npy reference needs the SCENE it was rendered from");
        }
        E::FilmSide { .. } => "--width and --height",
        E::FilmFromCube => "--width, --height, --bins, --t0, --dt",
        _ => return e.into(),
    };
    anyhow::Error::from(e).context(flags)
}

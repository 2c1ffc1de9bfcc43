//! The command line: `tprf render`, `tprf oned`. Errors end here, printed once.

use crate::export::{self, BIN_VALUE, CameraMetadata, CubeMetadata};
use crate::film::{FilmLayout, TprfFilm};
use crate::scene::{self, Channel};
use crate::transport::progressive::{self, Budget};
use crate::transport::{RenderSettings, Renderer, WindowRequest, auto_window};
use crate::units::{C_M_PER_S, format_time, parse_time_s};
use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(
    name = "tprf",
    version,
    about = "Transient rendering: light in flight, TPRF cubes and time-of-flight sensors"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a transient cube (TPRF per pixel) of a scene.
    Render(RenderArgs),
    /// The paper's 1-D world: print the exact impulse train (and the binned TPRF).
    Oned(OnedArgs),
    /// Error against run time: render progressively and compare with a reference at
    /// checkpoints evenly spaced in log time; writes converge.csv, converge.png and
    /// summary.md.
    Converge(ConvergeArgs),
    /// Stiff and extreme cases against independently derived answers; writes
    /// stability.md (case, setting, expected, got, relative error, NaN/Inf, verdict).
    Stability(StabilityArgs),
    /// Open the viewer on a cube folder written by `tprf render` (no rendering), or on a
    /// scene to render (a .gltf/.glb path or builtin:NAME). No argument: the last scene.
    View(ViewArgs),
}

#[derive(Args, Debug)]
pub struct ViewArgs {
    /// A cube folder, a glTF file or builtin:NAME.
    pub what: Option<String>,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// A .gltf/.glb path or builtin:NAME (builtin:cornell, builtin:canopy).
    pub scene: String,
    /// Output folder (created if missing; files in it are replaced).
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long, default_value_t = 256)]
    pub width: usize,
    #[arg(long, default_value_t = 256)]
    pub height: usize,
    /// Samples per pixel (default 64 unless --seconds is given).
    #[arg(long, conflicts_with = "seconds")]
    pub spp: Option<u64>,
    /// Render for this many seconds of wall time instead of a fixed spp.
    #[arg(long)]
    pub seconds: Option<f64>,
    /// Number of time bins.
    #[arg(long, default_value_t = 256)]
    pub bins: usize,
    /// Start of the time window, with a unit: s ms us ns ps fs, or m cm mm km of optical
    /// path (default: just before the first arrival).
    #[arg(long)]
    pub t0: Option<String>,
    /// Bin width, with a unit as for --t0 (default: the window that holds 99.5 % of a pilot
    /// render's energy, divided into --bins).
    #[arg(long)]
    pub dt: Option<String>,
    /// Largest number of scattering events on a path (Russian roulette ends most earlier).
    #[arg(long, default_value_t = 1024)]
    pub max_bounces: u32,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores). The output does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also write frames/0000.png ... (one per bin, shared exposure).
    #[arg(long)]
    pub frames: bool,
    /// Per-bounce layers: bounce 0 (emitters seen directly), 1..K and the rest, in
    /// tprf_bounces.npy [K+2, H, W, T].
    #[arg(long, default_value_t = 0)]
    pub bounces_separate: u32,
    /// The spectral band the one-channel cube records.
    #[arg(long, value_enum, default_value_t = Channel::Gray)]
    pub channel: Channel,
}

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
    /// Output folder (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// An estimator setting to compare (repeat for several on one plot): `default`, or
    /// comma-separated nee=on|off, filter=box|tent, rr_start=N, rr_floor=P,
    /// max_bounces=N, seconds=S. Default: just `default`.
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
}

#[derive(Args, Debug)]
pub struct StabilityArgs {
    /// Output folder (created if missing).
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

/// Largest image side accepted.
const MAX_SIDE: usize = 16384;

fn check_render_args(a: &RenderArgs) -> Result<()> {
    if a.width == 0 || a.height == 0 || a.width > MAX_SIDE || a.height > MAX_SIDE {
        bail!(
            "--width and --height must be in 1..={MAX_SIDE} (got {} x {})",
            a.width,
            a.height
        );
    }
    if let Some(s) = a.seconds
        && !(s.is_finite() && s > 0.0)
    {
        bail!("--seconds must be a positive number (got {s})");
    }
    if a.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    if a.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    Ok(())
}

/// `tprf render`.
pub fn render(a: &RenderArgs) -> Result<()> {
    check_render_args(a)?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = a.threads {
        pool = pool.num_threads(n);
    }
    let pool = pool.build().context("cannot start the worker threads")?;
    pool.install(|| render_in_pool(a, pool.current_num_threads()))
}

fn render_in_pool(a: &RenderArgs, threads: usize) -> Result<()> {
    let start = Instant::now();
    let t0_s =
        a.t0.as_deref()
            .map(parse_time_s)
            .transpose()
            .map_err(anyhow::Error::msg)
            .context("--t0")?;
    let dt_s =
        a.dt.as_deref()
            .map(parse_time_s)
            .transpose()
            .map_err(anyhow::Error::msg)
            .context("--dt")?;
    let scene = scene::load(&a.scene)?;
    for note in &scene.notes {
        eprintln!("note: {note}");
    }
    let settings = RenderSettings {
        max_bounces: a.max_bounces,
        seed: a.seed,
        channel: a.channel,
        ..Default::default()
    };
    let scene = Arc::new(scene);
    let renderer = Renderer::new(scene.clone(), settings);
    let axis = auto_window(
        &renderer,
        WindowRequest {
            t0_s,
            dt_s,
            bins: a.bins,
        },
    )
    .map_err(anyhow::Error::msg)?;
    eprintln!(
        "time axis: {} bins of {} from {} ({:.4} m to {:.4} m of optical path)",
        axis.bins,
        format_time(axis.dt_s),
        format_time(axis.t0_s),
        axis.t0_s * C_M_PER_S,
        axis.end_s() * C_M_PER_S
    );
    let layout = FilmLayout {
        width: a.width,
        height: a.height,
        axis,
        bounces_separate: a.bounces_separate,
    };
    let mut film = TprfFilm::new(layout).map_err(anyhow::Error::msg)?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;

    let budget = match (a.spp, a.seconds) {
        (_, Some(s)) => Budget::Seconds(s),
        (Some(n), None) => Budget::Spp(n),
        (None, None) => Budget::Spp(64),
    };
    let bar = match budget {
        Budget::Spp(n) => ProgressBar::new(n),
        Budget::Seconds(s) => ProgressBar::new((s * 10.0).ceil() as u64),
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let reports = progressive::render(&renderer, &mut film, budget, |r, _| {
        bar.set_position(match budget {
            Budget::Spp(_) => r.spp,
            Budget::Seconds(_) => (r.seconds * 10.0) as u64,
        });
        bar.set_message(format!(
            "{} spp, {:.1} Mrays/s",
            r.spp,
            r.rays as f64 / r.seconds.max(1e-9) / 1e6
        ));
        ControlFlow::Continue(())
    });
    bar.finish_and_clear();
    let last = reports.last().copied();

    let (w, h, t) = (a.width as u64, a.height as u64, axis.bins as u64);
    export::write_npy_f32(&a.out.join("tprf.npy"), &[h, w, t], &film.cube_f32())?;
    if layout.bounce_layers() > 0 {
        let l = layout.bounce_layers() as u64;
        export::write_npy_f32(
            &a.out.join("tprf_bounces.npy"),
            &[l, h, w, t],
            &film.bounce_cube_f32(),
        )?;
    }
    let steady = film.steady();
    let exposure = 0.8 * export::exposure_for(steady.iter().copied(), 0.99);
    export::write_png_gray(
        &a.out.join("steady.png"),
        a.width,
        a.height,
        &steady,
        exposure,
    )?;
    if a.frames {
        export::write_frames(&a.out, &film)?;
    }
    let cam = &scene.camera;
    let meta = CubeMetadata {
        format: "tprf cube v1: tprf.npy float32 [H, W, T], row 0 = top".into(),
        t0_s: axis.t0_s,
        dt_s: axis.dt_s,
        bins: axis.bins,
        width: a.width,
        height: a.height,
        spp: film.spp(),
        seed: a.seed,
        c_m_per_s: C_M_PER_S,
        channel: format!("{:?}", a.channel).to_lowercase(),
        value: BIN_VALUE.into(),
        scene: a.scene.clone(),
        camera: CameraMetadata {
            position_m: cam.position().to_array(),
            world_from_camera: glam::Mat4::from(cam.world_from_camera).to_cols_array(),
            yfov_deg: cam.yfov_rad.to_degrees(),
        },
        max_bounces: a.max_bounces,
        bounces_separate: a.bounces_separate,
        threads,
        wall_seconds: start.elapsed().as_secs_f64(),
        rays_traced: renderer.rays_traced(),
        paths_traced: last.map_or(0, |r| r.paths),
        error_estimate: film.half_error_estimate(),
        passes: reports,
        notes: scene.notes.clone(),
    };
    export::write_json(&a.out.join("tprf.json"), &meta)?;
    eprintln!(
        "wrote {} ({} spp, {:.1} s, {:.2} Mrays/s{})",
        a.out.display(),
        film.spp(),
        meta.wall_seconds,
        meta.rays_traced as f64 / meta.wall_seconds.max(1e-9) / 1e6,
        meta.error_estimate.map_or(String::new(), |e| format!(
            ", error estimate {:.2} %",
            100.0 * e
        ))
    );
    Ok(())
}

/// `tprf converge`.
pub fn converge(a: &ConvergeArgs) -> Result<()> {
    use crate::report::converge::{
        EstimatorSetting, FilmRequest, RunConfig, resolve_target, run_setting, summarise,
        summary_text, write_outputs,
    };
    if !(a.seconds.is_finite() && a.seconds > 0.0) {
        bail!("--seconds must be a positive number (got {})", a.seconds);
    }
    if a.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    if a.per_decade == 0 || a.per_decade > 100 {
        bail!("--per-decade must be in 1..=100");
    }
    let parse = |s: &Option<String>, what: &str| -> Result<Option<f64>> {
        s.as_deref()
            .map(parse_time_s)
            .transpose()
            .map_err(anyhow::Error::msg)
            .with_context(|| what.to_string())
    };
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
    let target = resolve_target(a.scene.as_deref(), a.reference.as_deref(), &film)?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = a.threads {
        pool = pool.num_threads(n);
    }
    let pool = pool.build().context("cannot start the worker threads")?;
    let config = RunConfig {
        seconds: a.seconds,
        per_decade: a.per_decade,
        base: RenderSettings {
            seed: a.seed,
            channel: target.channel,
            ..RenderSettings::default()
        },
        ..RunConfig::default()
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
    for s in &settings {
        let checkpoints = pool
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
            .map_err(anyhow::Error::msg)?;
        summaries.extend(summarise(&checkpoints));
        all.extend(checkpoints);
    }
    let title = format!(
        "{}: {} x {} x {} bins",
        target.label, r.width, r.height, r.axis.bins
    );
    write_outputs(&a.out, &title, &all, &summaries)?;
    eprint!("{}", summary_text(&summaries));
    eprintln!("wrote {}", a.out.display());
    Ok(())
}

/// `tprf stability`.
pub fn stability(a: &StabilityArgs) -> Result<()> {
    use crate::report::stability::{Size, cases, markdown};
    if a.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let size = match a.size {
        StabilitySize::Test => Size::Test,
        StabilitySize::Full => Size::Full,
    };
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = a.threads {
        pool = pool.num_threads(n);
    }
    let pool = pool.build().context("cannot start the worker threads")?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
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
    let path = a.out.join("stability.md");
    export::write_atomic(&path, |w| {
        use std::io::Write;
        w.write_all(text.as_bytes())?;
        Ok(())
    })?;
    print!("{table}");
    let failed = rows.iter().filter(|r| !r.passed()).count();
    eprintln!("wrote {}", path.display());
    if failed > 0 {
        bail!("{failed} of {} stability checks failed", rows.len());
    }
    Ok(())
}

/// `tprf oned`.
pub fn oned(a: &OnedArgs) -> Result<()> {
    let bins = match (&a.t0, &a.dt, a.bins) {
        (Some(t0), Some(dt), Some(n)) => Some((
            parse_time_s(t0)
                .map_err(anyhow::Error::msg)
                .context("--t0")?,
            parse_time_s(dt)
                .map_err(anyhow::Error::msg)
                .context("--dt")?,
            n,
        )),
        _ => None,
    };
    crate::oned::run_cli(&a.world, bins, &mut std::io::stdout().lock())
}

/// `tprf view` (and `tprf` alone): the window.
pub fn view(a: &ViewArgs) -> Result<()> {
    use crate::viewer::Start;
    let start = match &a.what {
        None => Start::Default,
        Some(w) if std::path::Path::new(w).is_dir() => Start::Cube(PathBuf::from(w)),
        Some(w) => Start::Scene(w.clone()),
    };
    crate::viewer::run(start).map_err(|e| anyhow::anyhow!("cannot open the window: {e}"))
}

/// Entry point of the `tprf` binary.
pub fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Some(Command::Render(a)) => render(a),
        Some(Command::Oned(a)) => oned(a),
        Some(Command::Converge(a)) => converge(a),
        Some(Command::Stability(a)) => stability(a),
        Some(Command::View(a)) => view(a),
        None => view(&ViewArgs { what: None }),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

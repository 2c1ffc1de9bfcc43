//! The command line: `tprf render`, `tprf oned`, `tprf sensor`. Errors end here, printed
//! once.

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;
use tprf_core::export::{self, BIN_VALUE, CameraMetadata, CubeMetadata};
use tprf_core::film::TimeAxis;
use tprf_core::film::{FilmLayout, TprfFilm};
use tprf_core::oned::{ImpulseOptions, InterfaceKind, World, WorldError, binned};
use tprf_core::scene::{self, Channel};
use tprf_core::sensor::{
    self, Derived, Exposure, FirstReturn, LightPulse, Sensor, SensorModel, derived,
};
use tprf_core::transport::progressive::{self, Schedule};
use tprf_core::transport::{RenderSettings, Renderer, WindowError, WindowRequest, auto_window};
use tprf_core::units::{C_M_PER_S, format_time, parse_time_s};

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
    /// Measure a rendered cube with a time-of-flight sensor (light pulse, exposure
    /// gates, noise): the paper's TPRF sensor, without re-rendering.
    Sensor(SensorArgs),
    /// Error against run time: render progressively and compare with a reference at
    /// checkpoints evenly spaced in log time; writes converge.csv, converge.png and
    /// summary.md.
    Converge(ConvergeArgs),
    /// Stiff and extreme cases against independently derived answers or invariances;
    /// writes stability.md (case, setting, expected, got, relative error, NaN/Inf,
    /// verdict, kind).
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
    /// The spectral band the one-channel cube records: red, green, blue or gray.
    #[arg(long, default_value_t = Channel::Gray, value_parser = parse_channel)]
    pub channel: Channel,
}

fn parse_channel(s: &str) -> Result<Channel, String> {
    s.parse()
        .map_err(|e: tprf_core::scene::UnknownChannel| e.to_string())
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

#[derive(Args, Debug)]
pub struct SensorArgs {
    /// A `tprf render` output folder: tprf.npy float32 [H, W, T] and tprf.json (t0_s,
    /// dt_s, bins); tprf_bounces.npy, when present, gives the AMCW reference depth.
    pub dir: PathBuf,
    /// The sensor: a TOML file (see docs/sensor.md) or builtin:gated, builtin:lidar,
    /// builtin:amcw. The options below override its parts.
    #[arg(long)]
    pub preset: Option<String>,
    /// The light pulse as KIND:key=value,... e.g. gaussian:centre=5ns,fwhm=2ns (kinds:
    /// delta gaussian rect exponential laser_diode sinc2 piecewise_linear). Default: a
    /// unit delta at t = 0.
    #[arg(long)]
    pub light: Option<String>,
    /// The gates as KIND:key=value,... e.g. box:start=10ns,width=1ns,count=32 or
    /// amcw:freq=20MHz,phase_steps=4 (kinds: box gaussian piecewise_linear amcw).
    #[arg(long)]
    pub exposure: Option<String>,
    /// Standard deviation of the additive Gaussian noise, in measurement units.
    #[arg(long)]
    pub noise_sigma: Option<f64>,
    /// Photon noise: photons per unit of measurement (0: off).
    #[arg(long)]
    pub photons_per_energy: Option<f64>,
    /// Seed of the noise.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Also write pixel_Y_X.csv and pixel_Y_X_gates.csv for pixel Y,X (row from the
    /// top, column from the left). Repeatable.
    #[arg(long = "pixel", value_name = "Y,X", value_parser = parse_pixel)]
    pub pixels: Vec<(usize, usize)>,
    /// Output folder (created if missing; files in it are replaced).
    #[arg(long)]
    pub out: PathBuf,
}

fn parse_pixel(text: &str) -> Result<(usize, usize), String> {
    let (y, x) = text
        .split_once(',')
        .ok_or_else(|| format!("'{text}' is not Y,X"))?;
    let y = y
        .trim()
        .parse()
        .map_err(|_| format!("'{y}' is not a row index"))?;
    let x = x
        .trim()
        .parse()
        .map_err(|_| format!("'{x}' is not a column index"))?;
    Ok((y, x))
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
    .map_err(|e| match e {
        WindowError::NoLight => anyhow::Error::from(e).context("--t0 and --dt"),
        e => e.into(),
    })?;
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

    let schedule = match (a.spp, a.seconds) {
        (_, Some(s)) => Schedule::seconds(s),
        (Some(n), None) => Schedule::spp(n),
        (None, None) => Schedule::spp(64),
    };
    let bar = match (schedule.spp_target, schedule.time_budget_s) {
        (Some(n), _) => ProgressBar::new(n),
        (None, s) => ProgressBar::new((s.unwrap_or(0.0) * 10.0).ceil() as u64),
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let reports = progressive::render(&renderer, &mut film, &schedule, |r, _| {
        bar.set_position(match schedule.spp_target {
            Some(_) => r.spp,
            None => (r.wall_s * 10.0) as u64,
        });
        bar.set_message(format!(
            "{} spp, {:.1} Mrays/s",
            r.spp,
            r.rays as f64 / r.render_s.max(1e-9) / 1e6
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
        channel: a.channel.name().into(),
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
        passes: reports.len() as u64,
        render_seconds: last.map_or(0.0, |r| r.render_s),
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
    use tprf_core::report::converge::{
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
    let target = resolve_target(a.scene.as_deref(), a.reference.as_deref(), &film)
        .map_err(converge_flags)?;
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

/// `tprf stability`.
pub fn stability(a: &StabilityArgs) -> Result<()> {
    use tprf_core::report::stability::{Size, cases, markdown};
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
    print_oned(&a.world, bins, &mut std::io::stdout().lock())
}

/// `tprf oned`'s output: reads the world file at `path`, prints its impulse train (time in
/// ns, optical path length in m, weight, order) and, with `bins = Some((t0_s, dt_s,
/// count))`, the binned TPRF (bin index, bin start in ns, integrated weight). Lines
/// starting with `#` are comments; the rest are whitespace-separated columns.
pub fn print_oned(
    path: &Path,
    bins: Option<(f64, f64, usize)>,
    out: &mut impl Write,
) -> anyhow::Result<()> {
    if let Some((t0_s, dt_s, _)) = bins {
        anyhow::ensure!(t0_s.is_finite(), "bin start t0 = {t0_s} s is not finite");
        anyhow::ensure!(
            dt_s > 0.0 && dt_s.is_finite(),
            "bin width dt = {dt_s} s must be a positive finite number"
        );
    }
    let world = World::from_path(path).map_err(|e| match e {
        WorldError::Io { .. } => anyhow::Error::new(e),
        other => anyhow::anyhow!("{}: {other}", path.display()),
    })?;
    let opts = ImpulseOptions::default();
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
            "# WARNING: more than {} live packets in one order: the train is incomplete",
            opts.max_packets
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

/// The time window of a cube as `tprf.json` records it; other keys are ignored, so a
/// cube written by another tool needs only these.
#[derive(serde::Deserialize)]
struct CubeWindow {
    t0_s: f64,
    dt_s: f64,
    bins: usize,
    #[serde(default)]
    width: Option<usize>,
    #[serde(default)]
    height: Option<usize>,
}

/// The sensor of `tprf sensor`: the preset (or a delta light and `--exposure`), with
/// the options' overrides.
fn sensor_from_args(a: &SensorArgs) -> Result<Sensor> {
    let mut sensor = match (&a.preset, &a.exposure) {
        (Some(p), _) => Sensor::load(p).with_context(|| format!("--preset {p}"))?,
        (None, Some(spec)) => Sensor::new(
            LightPulse::default(),
            Exposure::from_spec(spec).context("--exposure")?,
        ),
        (None, None) => bail!(
            "give --preset (a TOML file, or builtin:lidar, builtin:gated, builtin:amcw) or \
             --exposure KIND:key=value,... (e.g. box:start=10ns,width=1ns,count=32)"
        ),
    };
    if let Some(spec) = &a.light {
        sensor.light = LightPulse::from_spec(spec).context("--light")?;
    }
    if let Some(spec) = &a.exposure {
        sensor.exposure = Exposure::from_spec(spec).context("--exposure")?;
        // The preset's derived outputs may not fit the new gates.
        let gates = sensor.exposure.gates(0.0).context("--exposure")?;
        if let Err(e) = sensor.derived.validate(&sensor.exposure, &gates) {
            eprintln!("note: the preset's derived outputs are dropped: {e}");
            sensor.derived = Derived::default();
        }
    }
    if let Some(x) = a.noise_sigma {
        sensor.noise.sigma = x;
    }
    if let Some(x) = a.photons_per_energy {
        sensor.noise.photons_per_energy = x;
    }
    if let Some(x) = a.seed {
        sensor.noise.seed = x;
    }
    Ok(sensor)
}

/// Reads `tprf.npy` and `tprf.json` of a render folder: the cube, width, height, axis.
/// Unlike [`export::read_cube`] it needs only the time window in the JSON, so cubes
/// written by other tools can be measured too.
fn read_any_cube(dir: &std::path::Path) -> Result<(Vec<f32>, usize, usize, TimeAxis)> {
    let json_path = dir.join("tprf.json");
    let text = std::fs::read(&json_path)
        .with_context(|| format!("cannot read {}", json_path.display()))?;
    let meta: CubeWindow = serde_json::from_slice(&text)
        .with_context(|| format!("{}: expected t0_s, dt_s and bins", json_path.display()))?;
    let axis = TimeAxis::new(meta.t0_s, meta.dt_s, meta.bins)
        .map_err(anyhow::Error::msg)
        .with_context(|| json_path.display().to_string())?;
    let npy_path = dir.join("tprf.npy");
    let (shape, cube) = export::read_npy_f32(&npy_path)?;
    let (h, w, t) = match shape[..] {
        [h, w, t] => (h as usize, w as usize, t as usize),
        _ => bail!(
            "{} has shape {shape:?}; expected [H, W, T]",
            npy_path.display()
        ),
    };
    if t != axis.bins
        || meta.width.is_some_and(|mw| mw != w)
        || meta.height.is_some_and(|mh| mh != h)
    {
        bail!(
            "{} is [{h}, {w}, {t}] but {} says {} x {} pixels, {} bins",
            npy_path.display(),
            json_path.display(),
            meta.height.map_or("?".into(), |v| v.to_string()),
            meta.width.map_or("?".into(), |v| v.to_string()),
            axis.bins
        );
    }
    Ok((cube, w, h, axis))
}

/// A depth image as grey PNG, linear in depth from the 1 % to the 99 % quantile:
/// nearest white, farthest dark grey, no depth black.
fn write_depth_png(path: &std::path::Path, w: usize, h: usize, depth: &[f32]) -> Result<()> {
    let values = || depth.iter().map(|&d| f64::from(d));
    let (lo, hi) = (quantile(values(), 0.01), quantile(values(), 0.99));
    let span = (hi - lo).max(1e-12);
    let mut rgb = Vec::with_capacity(3 * depth.len());
    for &d in depth {
        let g = if d.is_finite() {
            let t = ((hi - f64::from(d)) / span).clamp(0.0, 1.0);
            (255.0 * (0.15 + 0.85 * t)).round() as u8
        } else {
            0
        };
        rgb.extend([g, g, g]);
    }
    Ok(export::write_png_rgb(path, w, h, rgb)?)
}

/// A signed image as PNG: blue below 0, white at 0, red above, saturating at
/// `+- scale`; NaN black.
fn write_signed_png(
    path: &std::path::Path,
    w: usize,
    h: usize,
    values: &[f32],
    scale: f64,
) -> Result<()> {
    let mut rgb = Vec::with_capacity(3 * values.len());
    for &v in values {
        let px = if v.is_finite() {
            let t = (f64::from(v) / scale.max(1e-300)).clamp(-1.0, 1.0);
            let fade = (255.0 * (1.0 - t.abs())).round() as u8;
            if t < 0.0 {
                [fade, fade, 255]
            } else {
                [255, fade, fade]
            }
        } else {
            [0, 0, 0]
        };
        rgb.extend(px);
    }
    Ok(export::write_png_rgb(path, w, h, rgb)?)
}

/// The `q` quantile of the finite values (0 if none).
fn quantile(values: impl Iterator<Item = f64>, q: f64) -> f64 {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    let k = ((v.len() - 1) as f64 * q).round() as usize;
    *v.select_nth_unstable_by(k, f64::total_cmp).1
}

/// The AMCW depth reference: the single-scattering layer's centroid when the render
/// kept per-bounce layers, else the first return of the noise-free TPRF.
fn reference_depth(
    dir: &std::path::Path,
    cube: &[f32],
    w: usize,
    h: usize,
    axis: &TimeAxis,
) -> Result<(Vec<f32>, &'static str)> {
    let path = dir.join("tprf_bounces.npy");
    if path.exists() {
        let (shape, layers) = export::read_npy_f32(&path)?;
        let n = w * h * axis.bins;
        if shape.len() == 4
            && shape[0] >= 3
            && shape[1..] == [h as u64, w as u64, axis.bins as u64]
            && let Some(single) = layers.get(n..2 * n)
        {
            return Ok((
                derived::tprf_centroid_depth(single, w, h, axis),
                "centroid of the single-scattering layer (layer 1 of tprf_bounces.npy)",
            ));
        }
    }
    Ok((
        derived::tprf_first_return_depth(cube, w, h, axis, &FirstReturn::default()),
        "first return of the noise-free TPRF (render with --bounces-separate 1 for the \
         exact single-scattering depth)",
    ))
}

/// `tprf sensor`.
pub fn sensor(a: &SensorArgs) -> Result<()> {
    let start = Instant::now();
    let sensor = sensor_from_args(a)?;
    let (cube, w, h, axis) = read_any_cube(&a.dir)?;
    for &(y, x) in &a.pixels {
        if y >= h || x >= w {
            bail!("--pixel {y},{x} is outside the {h} x {w} image (row, column from 0)");
        }
    }
    let t_kernels = Instant::now();
    let model = SensorModel::new(sensor, axis)?;
    let kernels_s = t_kernels.elapsed().as_secs_f64();
    let t_measure = Instant::now();
    let mut m = model.measure_clean(&cube, w, h)?;
    let measure_s = t_measure.elapsed().as_secs_f64();
    let t_noise = Instant::now();
    model.apply_noise(&mut m);
    let noise_s = t_noise.elapsed().as_secs_f64();
    let n = model.gate_count();

    let unread: Vec<usize> = (0..n)
        .filter(|&i| model.kernels()[i].weights.is_empty())
        .collect();
    if !unread.is_empty() {
        eprintln!(
            "note: {} of {n} gates see no light from the cube's window ({} .. {}); their \
             measurements are noise only",
            unread.len(),
            format_time(axis.t0_s),
            format_time(axis.end_s())
        );
    }

    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let mut files = vec!["sensor.npy".to_string(), "sensor.json".to_string()];
    export::write_npy_f32(
        &a.out.join("sensor.npy"),
        &[n as u64, h as u64, w as u64],
        &m.values,
    )?;

    let mut derived_json = serde_json::Map::new();
    if let Some(depth) = model.first_return_depth(&m) {
        export::write_npy_f32(&a.out.join("depth.npy"), &[h as u64, w as u64], &depth)?;
        write_depth_png(&a.out.join("depth.png"), w, h, &depth)?;
        files.extend(["depth.npy".into(), "depth.png".into()]);
        let found = depth.iter().filter(|d| d.is_finite()).count();
        derived_json.insert(
            "first_return".into(),
            serde_json::json!({
                "depth": "c (t_return - light mean time) / 2, metres; NaN: no return",
                "pixels_with_return": found,
                "light_mean_s": model.light().mean_s(),
            }),
        );
    }
    if let Some(amcw) = model.amcw(&m) {
        let (reference, how) = reference_depth(&a.dir, &cube, w, h, &axis)?;
        let error: Vec<f32> = amcw
            .depth_m
            .iter()
            .zip(&reference)
            .map(|(&d, &r)| {
                derived::wrapped_difference(f64::from(d), f64::from(r), amcw.ambiguity_m) as f32
            })
            .collect();
        let shape = [h as u64, w as u64];
        export::write_npy_f32(&a.out.join("amcw_phase.npy"), &shape, &amcw.phase_rad)?;
        export::write_npy_f32(&a.out.join("amcw_amplitude.npy"), &shape, &amcw.amplitude)?;
        export::write_npy_f32(&a.out.join("amcw_depth.npy"), &shape, &amcw.depth_m)?;
        export::write_npy_f32(&a.out.join("true_depth.npy"), &shape, &reference)?;
        export::write_npy_f32(&a.out.join("multipath_error.npy"), &shape, &error)?;
        write_depth_png(&a.out.join("amcw_depth.png"), w, h, &amcw.depth_m)?;
        let abs = || error.iter().map(|e| f64::from(e.abs()));
        let (median, p95) = (quantile(abs(), 0.5), quantile(abs(), 0.95));
        write_signed_png(
            &a.out.join("multipath_error.png"),
            w,
            h,
            &error,
            quantile(abs(), 0.99),
        )?;
        files.extend(
            [
                "amcw_phase.npy",
                "amcw_amplitude.npy",
                "amcw_depth.npy",
                "true_depth.npy",
                "multipath_error.npy",
                "amcw_depth.png",
                "multipath_error.png",
            ]
            .map(String::from),
        );
        eprintln!(
            "AMCW: multipath error |amcw_depth - true_depth| median {:.4} m, 95 % {:.4} m \
             (ambiguity range {:.3} m)",
            median, p95, amcw.ambiguity_m
        );
        derived_json.insert(
            "amcw".into(),
            serde_json::json!({
                "phase": "radians in [0, 2 pi), the light's own phase removed",
                "depth": "c phase / (4 pi f), metres, in [0, ambiguity_m)",
                "ambiguity_m": amcw.ambiguity_m,
                "phase_offset_rad": model.amcw_phase_offset_rad(),
                "true_depth": how,
                "multipath_error": "amcw_depth - true_depth wrapped into [-ambiguity/2, ambiguity/2), metres",
                "multipath_error_median_abs_m": median,
                "multipath_error_p95_abs_m": p95,
            }),
        );
    }

    for &(y, x) in &a.pixels {
        let written = write_pixel_csv(&a.out, &model, &m, &cube, w, y, x)?;
        files.extend(written);
    }

    let gates: Vec<serde_json::Value> = model
        .gates()
        .iter()
        .zip(model.kernels())
        .enumerate()
        .map(|(i, (g, k))| {
            serde_json::json!({
                "index": i,
                "centre_s": g.centre_s(),
                "support_s": g.support_s().map(|(lo, hi)| [lo, hi]),
                "kernel_first_bin": k.first_bin,
                "kernel_bins": k.weights.len(),
                "kernel_sum": k.weights.iter().sum::<f64>(),
            })
        })
        .collect();
    let light = model.light();
    let (lo, hi) = light.support_s();
    let json = serde_json::json!({
        "format": "tprf sensor v1: sensor.npy float32 [N, H, W], row 0 = top",
        "model": "M_i = max(0, Noise + sum_b TPRF[b] K_i[b]), K_i[b] the mean over bin b of \
                  K_i(tau) = integral Light(t - tau) Exposure_i(t) dt",
        "value": "measurement in the unit of a cube bin (radiance x seconds per unit pulse \
                  energy) times the light's energy",
        "sensor": model.sensor(),
        "cube": {
            "dir": a.dir.display().to_string(),
            "t0_s": axis.t0_s,
            "dt_s": axis.dt_s,
            "bins": axis.bins,
            "width": w,
            "height": h,
        },
        "light": {
            "energy": light.energy(),
            "mean_s": light.mean_s(),
            "support_s": [lo, hi],
            "delta_at_s": light.delta_time_s(),
        },
        "gates": gates,
        "bins_read_per_pixel": model.packed().reads_per_pixel(),
        "derived": derived_json,
        "files": files,
        "seconds": {
            "kernels": kernels_s,
            "measurement": measure_s,
            "noise": noise_s,
            "total": start.elapsed().as_secs_f64(),
        },
    });
    export::write_json(&a.out.join("sensor.json"), &json)?;
    eprintln!(
        "wrote {} ({n} gates x {h} x {w}; kernels {:.1} ms, measurement {:.1} ms, noise \
         {:.1} ms)",
        a.out.display(),
        kernels_s * 1e3,
        measure_s * 1e3,
        noise_s * 1e3
    );
    Ok(())
}

/// `pixel_Y_X.csv` (per bin: time, TPRF, TPRF * Light, each gate's share of M_i) and
/// `pixel_Y_X_gates.csv` (per gate: centre, M_i before and after noise).
fn write_pixel_csv(
    out: &std::path::Path,
    model: &SensorModel,
    m: &sensor::Measurements,
    cube: &[f32],
    w: usize,
    y: usize,
    x: usize,
) -> Result<Vec<String>> {
    let axis = *model.axis();
    let start = (y * w + x) * axis.bins;
    let tprf = cube
        .get(start..start + axis.bins)
        .context("pixel outside the cube")?;
    let trace = model.pixel_trace(tprf)?;
    let kernels = model.kernels();
    let mut header: Vec<String> = ["bin", "t_start_s", "t_centre_s", "tprf", "tprf_light"]
        .map(String::from)
        .to_vec();
    header.extend((0..kernels.len()).map(|i| format!("gate_{i}")));
    let rows = (0..axis.bins).map(|b| {
        let mut row = vec![
            b as f64,
            axis.bin_start_s(b),
            axis.bin_center_s(b),
            trace.tprf[b],
            trace.tprf_light[b],
        ];
        row.extend(kernels.iter().map(|k| trace.tprf[b] * k.get(b)));
        row
    });
    let name = format!("pixel_{y}_{x}.csv");
    export::write_csv(&out.join(&name), &header, rows)?;

    let noisy = m.pixel(y, x);
    let header = ["gate", "centre_s", "m_clean", "m"].map(String::from);
    let rows = model.gates().iter().enumerate().map(|(i, g)| {
        vec![
            i as f64,
            g.centre_s().unwrap_or(f64::NAN),
            trace.m_clean[i],
            noisy.get(i).map_or(f64::NAN, |&v| f64::from(v)),
        ]
    });
    let gates_name = format!("pixel_{y}_{x}_gates.csv");
    export::write_csv(&out.join(&gates_name), &header, rows)?;
    Ok(vec![name, gates_name])
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
        Some(Command::Sensor(a)) => sensor(a),
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

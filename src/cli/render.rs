//! `tprf render`: a scene into a transient cube folder (`tprf.npy`, `tprf.json`,
//! `steady.png`, optional per-bounce layers and frames), with a progress bar.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use tprf_core::export::shard::{self, ShardInfo, ShardSpec};
use tprf_core::export::{self, BIN_VALUE, CameraMetadata, CubeFormat, CubeMetadata};
use tprf_core::film::{FilmLayout, TprfFilm};
use tprf_core::scene::{self, Channel};
use tprf_core::transport::progressive::{self, PassReport, Schedule};
use tprf_core::transport::{RenderSettings, Renderer, WindowError, WindowRequest, auto_window};
use tprf_core::units::{C_M_PER_S, format_time};

use super::args::{thread_pool, time_s};

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// A .gltf/.glb path or builtin:NAME (builtin:cornell, builtin:canopy).
    pub scene: String,
    /// Output folder: a new or empty one, or an earlier tprf output (replaced whole when
    /// the render is written: the files go into a new folder beside it and are swapped
    /// in, so a reader never sees half of a render). A folder holding anything tprf did
    /// not write, a file, a link, a device or the current folder is refused up front.
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
    /// tprf_bounces.npy [K+2, H, W, T] (or the array "bounces" of tprf.zarr).
    #[arg(long, default_value_t = 0)]
    pub bounces_separate: u32,
    /// How the cube is written: `npy` (tprf.npy, one dense float32 array), `zarr`
    /// (tprf.zarr, chunked and compressed, only where light arrived), or `auto`: npy
    /// up to 4 GiB, zarr above.
    #[arg(long, default_value = "auto", value_parser = parse_format)]
    pub format: CubeFormat,
    /// The spectral band the one-channel cube records: red, green, blue or gray.
    #[arg(long, default_value_t = Channel::Gray, value_parser = parse_channel)]
    pub channel: Channel,
    /// Every pixel draws every pass's samples, for the same noise across the image.
    /// Default: from the fourth sample per pixel on, where the noise is uneven enough for
    /// it to pay, pixels draw samples in proportion to their measured noise over the
    /// square root of their cost, for the least cube error per second (unbiased either
    /// way).
    #[arg(long)]
    pub uniform: bool,
    /// Render only shard K of N (0-based, "K/N"): the image's bands of --band-rows rows,
    /// band b going to shard b mod N, with the same passes and window as the whole
    /// render. `tprf merge` puts the N shard folders together into the cube one
    /// process writes, bit for bit. Needs --spp (a time budget is not reproducible) and
    /// --uniform (a shard cannot see the other shards' noise to plan its samples).
    #[arg(long, conflicts_with_all = ["seconds", "frames"])]
    pub shard: Option<String>,
    /// Rows per band of --shard. Bands of whole Zarr chunks (32 rows, the default) let
    /// `tprf merge` link every chunk file; thinner bands share chunks, which the merge
    /// decodes and encodes again.
    #[arg(long, default_value_t = shard::DEFAULT_BAND_ROWS, requires = "shard")]
    pub band_rows: usize,
    /// A constant sky of this radiance (W m^-2 sr^-1) in the ambient light group: not
    /// pulsed, rendered once into ambient.npy beside the cube.
    #[arg(long)]
    pub sky: Option<f64>,
    /// Samples per pixel of the ambient image, when the scene has ambient light (a sun,
    /// a sky, lamps tagged ambient). Default: --spp, or 64.
    #[arg(long)]
    pub ambient_spp: Option<u32>,
}

fn parse_channel(s: &str) -> Result<Channel, String> {
    s.parse()
        .map_err(|e: tprf_core::scene::UnknownChannel| e.to_string())
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
    if a.shard.is_some() && a.seconds.is_some() {
        bail!("--shard needs a fixed --spp: a --seconds budget gives each shard other passes");
    }
    if a.shard.is_some() && !a.uniform {
        bail!(
            "--shard needs --uniform: adaptive sampling plans each pixel's samples from the \
             whole image's noise, which a shard does not see"
        );
    }
    if a.ambient_spp == Some(0) {
        bail!("--ambient-spp must be at least 1");
    }
    Ok(())
}

/// `tprf render`.
pub fn run(a: &RenderArgs) -> Result<()> {
    check_render_args(a)?;
    let scene_path = std::path::Path::new(&a.scene);
    super::args::check_out("--out", &a.out, &[scene_path])?;
    let pool = thread_pool(a.threads)?;
    pool.install(|| render_in_pool(a, pool.current_num_threads()))
}

fn render_in_pool(a: &RenderArgs, threads: usize) -> Result<()> {
    let start = Instant::now();
    let spec = a
        .shard
        .as_deref()
        .map(|s| ShardSpec::parse(s, a.band_rows))
        .transpose()?;
    // Before the scene and the pilot: a split that cannot be made is refused at once.
    if let Some(spec) = &spec {
        spec.check(a.height)?;
    }
    let t0_s = a.t0.as_deref().map(|t| time_s(t, "--t0")).transpose()?;
    let dt_s = a.dt.as_deref().map(|t| time_s(t, "--dt")).transpose()?;
    let mut scene = scene::load(&a.scene)?;
    super::ambient::apply_sky(&mut scene, a.sky)?;
    for note in &scene.notes {
        eprintln!("note: {note}");
    }
    let settings = RenderSettings {
        max_bounces: a.max_bounces,
        seed: a.seed,
        channel: a.channel,
        adaptive: !a.uniform,
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
            aspect: a.width as f64 / a.height.max(1) as f64,
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
    // The folder is written beside its place and swapped in at the end (export::staging),
    // which creates the folders above it then: nothing is made on disk before the render
    // is done. Its free space is that of the nearest folder above it that exists.
    let parent = existing_ancestor(&a.out);
    let (w, h, t) = (a.width as u64, a.height as u64, axis.bins as u64);
    let format = a.format.resolve(&[h, w, t]);
    let fingerprint = match &spec {
        Some(spec) => {
            film = film.with_rows(&spec.rows(a.height));
            Some(shard::scene_fingerprint(&a.scene)?)
        }
        None => None,
    };
    // A dense cube: refuse now, not after the render, what cannot be written.
    let file_bytes = export::npy_f32_bytes(&[h, w, t]).saturating_add(export::npy_f32_bytes(&[
        layout.bounce_layers() as u64,
        h,
        w,
        t,
    ]));
    if format == CubeFormat::Npy
        && let Some(free) = export::disk_free_bytes(&parent)
        && file_bytes > free
    {
        bail!(
            "the cube files for {} x {} pixels x {} bins need {:.1} GiB, and {} has {:.1} GiB free; lower the resolution or the bins",
            a.width,
            a.height,
            axis.bins,
            file_bytes as f64 / (1u64 << 30) as f64,
            a.out.display(),
            free as f64 / (1u64 << 30) as f64
        );
    }

    let schedule = match (a.spp, a.seconds) {
        (_, Some(s)) => Schedule::seconds(s),
        (Some(n), None) => Schedule::spp(n),
        (None, None) => Schedule::spp(64),
    };
    let reports = render_with_progress(&renderer, &mut film, &schedule);
    let last = reports.last().copied();
    if let Some(r) = last
        && r.left_out.non_finite > 0
    {
        bail!(
            "{} sample contributions were NaN or infinite (of {} paths): an emitter or a light \
             of {} overflows, or a material is broken; the cube was not written",
            r.left_out.non_finite,
            r.paths,
            a.scene
        );
    }

    let ambient_spp = a
        .ambient_spp
        .unwrap_or_else(|| a.spp.map_or(64, |n| n.min(u32::MAX as u64) as u32));
    let ambient = super::ambient::render(&renderer, a.width, a.height, ambient_spp)?;

    // Ctrl-C from here on drops what was written (the staging folder) and leaves the
    // old output as it was; checked between files.
    super::interrupt::catch();
    super::interrupt::check()?;
    let staging = export::staging::Staging::new(&a.out, &[std::path::Path::new(&a.scene)])?;
    let dir = staging.path();
    let snap = film.snapshot();
    let steady = film.steady();
    let exposure = 0.8 * export::exposure_for(steady.iter().copied(), 0.99);
    export::write_png_gray(
        &dir.join("steady.png"),
        a.width,
        a.height,
        &steady,
        exposure,
    )?;
    if a.frames {
        export::write_frames(dir, &snap)?;
    }
    let cam = &scene.camera;
    let meta = CubeMetadata {
        format: match format {
            CubeFormat::Zarr => {
                "tprf cube v2: tprf.zarr (Zarr v3 group): cube float32 [H, W, T] and, with \
                 bounces_separate > 0, bounces float32 [layers, H, W, T]; row 0 = top"
            }
            _ => "tprf cube v1: tprf.npy float32 [H, W, T], row 0 = top",
        }
        .into(),
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
        first_bounce_splits: renderer.strategy().splits,
        light_vertex: renderer.strategy().light_vertex,
        adaptive: !a.uniform,
        error_estimate: film.half_error_estimate(),
        passes: reports.len() as u64,
        left_out: last.map_or_else(Default::default, |r| r.left_out),
        store: film.store_stats(),
        render_seconds: last.map_or(0.0, |r| r.render_s),
        notes: scene.notes.clone(),
        shard: match (&spec, fingerprint) {
            (Some(spec), Some(scene_fingerprint)) => {
                let terms = film.row_error_terms();
                Some(ShardInfo {
                    k: spec.k,
                    n: spec.n,
                    band_rows: spec.band_rows,
                    rows: ShardInfo::row_ranges(spec, a.height),
                    half_spp: film.half_spp(),
                    scene_fingerprint,
                    filter: film.time_filter(),
                    format: match format {
                        CubeFormat::Zarr => "zarr",
                        _ => "npy",
                    }
                    .into(),
                    row_error_terms: (0..a.height)
                        .filter(|&y| film.renders_row(y))
                        .map(|y| [terms[y].0, terms[y].1])
                        .collect(),
                    store_list_bytes: film.row_list_bytes(),
                })
            }
            _ => None,
        },
        ambient: ambient
            .as_ref()
            .map(|(_, m)| export::ambient::AmbientMetadata {
                file: super::ambient::file_name(format),
                ..m.clone()
            }),
    };
    if spec.is_some() {
        shard::write_steady(dir, a.width, a.height, &steady)?;
    }
    if format == CubeFormat::Zarr {
        export::zarr::write_snapshot_zarr(&dir.join(export::zarr::ZARR_NAME), &snap, &meta)?;
    } else {
        export::write_snapshot_npy(&dir.join("tprf.npy"), &snap, false)?;
        if layout.bounce_layers() > 0 {
            export::write_snapshot_npy(&dir.join("tprf_bounces.npy"), &snap, true)?;
        }
    }
    if let Some((image, _)) = &ambient {
        super::ambient::write(dir, format, image)?;
    }
    super::interrupt::check()?;
    export::write_json(&dir.join("tprf.json"), &meta)?;
    super::interrupt::check()?;
    staging.commit()?;
    eprintln!(
        "wrote {}{} ({} spp, {:.1} s, {:.2} Mrays/s{})",
        a.out.display(),
        spec.map_or(String::new(), |s| format!(
            " (shard {}/{}: {} of {} rows)",
            s.k,
            s.n,
            film.rows_rendered(),
            a.height
        )),
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

/// The nearest of `path`'s parent folders that exists (`.` for a relative path whose
/// first folder is new).
fn existing_ancestor(path: &std::path::Path) -> PathBuf {
    path.ancestors()
        .skip(1)
        .find(|p| !p.as_os_str().is_empty() && p.is_dir())
        .map_or_else(|| PathBuf::from("."), PathBuf::from)
}

fn parse_format(s: &str) -> Result<CubeFormat, String> {
    s.parse()
}

/// The progressive passes of `schedule` into `film`, with a progress bar on stderr (in
/// spp, or in tenths of a second for a time budget); the passes' reports.
fn render_with_progress(
    renderer: &Renderer,
    film: &mut TprfFilm,
    schedule: &Schedule,
) -> Vec<PassReport> {
    let bar = match (schedule.spp_target, schedule.time_budget_s) {
        (Some(n), _) => ProgressBar::new(n),
        (None, s) => ProgressBar::new((s.unwrap_or(0.0) * 10.0).ceil() as u64),
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let reports = progressive::render(renderer, film, schedule, |r, _| {
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
    reports
}

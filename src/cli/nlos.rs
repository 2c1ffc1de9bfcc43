//! `tprf nlos SCENE --out DIR`: a non-line-of-sight capture (the transients a SPAD
//! focused on a grid of relay-wall points records), written as tal's `nlos.hdf5`,
//! `H.npy` and `nlos.json`.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use tprf_core::nlos::capture::{Progress, render_capture};
use tprf_core::nlos::files::write_capture_folder;
use tprf_core::nlos::{CaptureSettings, Scan};
use tprf_core::scene::{self, Channel, FileSetting, NlosFileSettings};
use tprf_core::units::{C_M_PER_S, format_time};

use super::args::{thread_pool, time_s};

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct NlosArgs {
    #[command(subcommand)]
    pub command: Option<NlosCommand>,
    #[command(flatten)]
    pub capture: CaptureArgs,
}

#[derive(Subcommand, Debug)]
pub enum NlosCommand {
    /// Reconstruct the hidden scene of a capture (a folder of `tprf nlos`, or any tal
    /// HDF5 capture file) onto a voxel volume: volume.npy [Z, Y, X] f32, volume.json and
    /// max-intensity projections (mip_front.png, mip_top.png, mip_side.png).
    Reconstruct(ReconstructArgs),
    /// Measure a capture with the SPAD of a `tprf sensor` preset (light pulse, TDC
    /// jitter, pile-up, dead time, ambient and dark counts), without rendering again:
    /// a capture of photon counts on the TDC's bins (nlos.hdf5, H.npy) and spad.json.
    Spad(SpadArgs),
}

#[derive(Args, Debug)]
pub struct SpadArgs {
    /// The capture: a `tprf nlos` output folder, or an HDF5 file in tal's format.
    pub capture: PathBuf,
    /// A sensor TOML with a [spad] section and a tdc exposure, or builtin:spad.
    #[allow(
        rustdoc::broken_intra_doc_links,
        rustdoc::private_intra_doc_links,
        reason = "clap's help text: the brackets are TOML, not links"
    )]
    #[arg(long)]
    pub preset: String,
    /// Laser cycles summed into the histogram (overrides the preset's).
    #[arg(long)]
    pub cycles: Option<u64>,
    /// Seed of the realisation (overrides the preset's noise.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Output folder (a new or empty one, or an earlier tprf output).
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args, Debug)]
pub struct ReconstructArgs {
    /// The capture: a `tprf nlos` output folder, or an HDF5 file in tal's format.
    pub capture: PathBuf,
    /// bp (back-projection), fbp (filtered back-projection), fk (f-k migration,
    /// confocal captures) or pf (phasor fields).
    #[arg(long, default_value = "fbp")]
    pub method: String,
    /// Output folder (a new or empty one, or an earlier tprf output).
    #[arg(long)]
    pub out: PathBuf,
    /// The voxel volume, CX,CY,CZ:SX,SY,SZ:NX,NY,NZ: centre (world, metres), size along
    /// the wall's u, v and normal (metres), voxels along them. Default: the sensor
    /// grid's extent and lattice, from the wall to the farthest depth the time axis
    /// reaches.
    #[arg(long)]
    pub volume: Option<String>,
    /// Central wavelength of the phasor-field kernel (fbp, pf), with a length unit
    /// (m cm mm); default four grid spacings. Its Gaussian's sigma is it over sqrt(2).
    #[arg(long)]
    pub wavelength: Option<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

#[derive(Args, Debug)]
pub struct CaptureArgs {
    /// A .gltf/.glb/.xml (Mitsuba) path or builtin:NAME (builtin:nlos-z, builtin:nlos-shapes) holding a
    /// planar relay wall and the hidden geometry.
    pub scene: Option<String>,
    /// Output folder (nlos.hdf5, H.npy, nlos.json): a new or empty one, or an earlier
    /// tprf output (replaced whole); anything else is refused up front.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Name of the relay wall's object (its glTF node, else its mesh; a Mitsuba scene's
    /// shape id, else the shape holding the nlos_capture_meter). Default relay_wall.
    #[arg(long)]
    pub relay_wall: Option<String>,
    /// Sensor points on the wall, along its u and v axes: NXxNY. Default 64x64 (a
    /// Mitsuba NLOS scene: its capture meter's).
    #[arg(long)]
    pub grid: Option<String>,
    /// The laser at each sensor point in turn (the default is one fixed laser point).
    #[arg(long, conflicts_with_all = ["exhaustive", "laser_point"])]
    pub confocal: bool,
    /// Every point of --laser-grid with every sensor point.
    #[arg(long, conflicts_with = "laser_point")]
    pub exhaustive: bool,
    /// Laser points of an exhaustive scan: NXxNY.
    #[arg(long, default_value = "8x8", requires = "exhaustive")]
    pub laser_grid: String,
    /// The one laser point, X,Y,Z metres (projected onto the wall); default the wall's centre.
    #[arg(long)]
    pub laser_point: Option<String>,
    /// Laser device position X,Y,Z metres (default: tal's, 0.5 m left of the wall's
    /// centre and 0.25 m in front).
    #[arg(long)]
    pub laser_origin: Option<String>,
    /// SPAD device position X,Y,Z metres (default as --laser-origin).
    #[arg(long)]
    pub sensor_origin: Option<String>,
    /// Number of time bins (default: up to the longest three-bounce path).
    #[arg(long)]
    pub bins: Option<usize>,
    /// Bin width, with a unit: s ms us ns ps fs, or m cm mm km of optical path. Default
    /// 3mm (a Mitsuba NLOS scene: its film's bin_width_opl).
    #[arg(long)]
    pub dt: Option<String>,
    /// Start of the time axis, with a unit as --dt. Default 0m (a Mitsuba NLOS scene: its
    /// film's start_opl).
    #[arg(long)]
    pub t0: Option<String>,
    /// Times start when the pulse hits the wall and end when light returns to it (tal's
    /// default): the device-to-wall legs are left out. Without it they count (a Mitsuba
    /// NLOS scene: as its account_first_and_last_bounces says).
    #[arg(long)]
    pub unwarped: bool,
    /// Samples per sensor point (an exhaustive scan's samples serve every laser point).
    /// Default 256 (a Mitsuba NLOS scene: its capture meter's sample_count).
    #[arg(long)]
    pub spp: Option<u32>,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Largest number of scattering events in the hidden scene (the two on the wall not
    /// counted). Default 1024 (a Mitsuba NLOS scene: its max_depth - 3).
    #[arg(long)]
    pub max_bounces: Option<u32>,
    /// The spectral band: red, green, blue or gray.
    #[arg(long, default_value_t = Channel::Gray, value_parser = parse_channel)]
    pub channel: Channel,
    /// Worker threads (default: all cores). The output does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
}

fn parse_channel(s: &str) -> Result<Channel, String> {
    s.parse()
        .map_err(|e: tprf_core::scene::UnknownChannel| e.to_string())
}

/// `NXxNY` as two counts; the error names `flag`.
fn parse_grid(text: &str, flag: &str) -> Result<[usize; 2]> {
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    let [a, b] = parts.as_slice() else {
        bail!("{flag} {text}: expected NXxNY, e.g. 64x64");
    };
    let n = |s: &str| {
        s.trim()
            .parse::<usize>()
            .with_context(|| format!("{flag} {text}: '{s}' is not a whole number"))
    };
    Ok([n(a)?, n(b)?])
}

/// `X,Y,Z` metres; the error names `flag`.
fn parse_point(text: &str, flag: &str) -> Result<[f32; 3]> {
    let v: Vec<f32> = text
        .split(',')
        .map(|s| s.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{flag} {text}: expected X,Y,Z in metres"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => bail!("{flag} {text}: expected three finite numbers X,Y,Z in metres"),
    }
}

pub fn run(a: &NlosArgs) -> Result<()> {
    match &a.command {
        Some(NlosCommand::Reconstruct(r)) => reconstruct(r),
        Some(NlosCommand::Spad(r)) => spad(r),
        None => capture(&a.capture),
    }
}

/// The capture the flags ask for, each flag not given taken from `file` (a Mitsuba NLOS
/// scene's settings), else its default; with what came from the file, in words.
fn settings_of(a: &CaptureArgs, file: &NlosFileSettings) -> Result<(CaptureSettings, Vec<String>)> {
    let mut used = Vec::new();
    let mut from_file = |flag: &str, value: String, at: &str| {
        used.push(format!("{flag} {value} ({at})"));
    };
    let grid = match (&a.grid, &file.grid) {
        (Some(g), _) => parse_grid(g, "--grid")?,
        (None, Some(g)) => {
            from_file("--grid", format!("{}x{}", g.value[0], g.value[1]), &g.from);
            g.value.map(|n| usize::try_from(n).unwrap_or(usize::MAX))
        }
        (None, None) => [64, 64],
    };
    let flagged_scan = a.confocal || a.exhaustive || a.laser_point.is_some();
    let kind = match (&file.capture_type, flagged_scan) {
        (Some(k), false) => {
            from_file("the scan", k.value.clone(), &k.from);
            k.value.as_str()
        }
        _ if a.confocal => "confocal",
        _ if a.exhaustive => "exhaustive",
        _ => "single",
    };
    let scan = match kind {
        "confocal" => Scan::Confocal,
        "exhaustive" if a.exhaustive => {
            let [lx, ly] = parse_grid(&a.laser_grid, "--laser-grid")?;
            Scan::Exhaustive { lx, ly }
        }
        // mitransient's exhaustive scan lights the sensor grid's points.
        "exhaustive" => Scan::Exhaustive {
            lx: grid[0],
            ly: grid[1],
        },
        _ => Scan::Single {
            laser_point: match (&a.laser_point, &file.laser_point) {
                (Some(p), _) => Some(parse_point(p, "--laser-point")?),
                (None, Some(f)) => {
                    from_file("--laser-point", format!("{:?}", f.value), &f.from);
                    Some(f.value.map(|c| c as f32))
                }
                (None, None) => None,
            },
        },
    };
    let point = |p: &Option<String>, flag| p.as_deref().map(|p| parse_point(p, flag)).transpose();
    let mut origin = |given: Option<[f32; 3]>, f: &Option<FileSetting<[f64; 3]>>, flag: &str| {
        given.or_else(|| {
            f.as_ref().map(|f| {
                from_file(flag, format!("{:?}", f.value), &f.from);
                f.value.map(|c| c as f32)
            })
        })
    };
    let laser_origin = origin(
        point(&a.laser_origin, "--laser-origin")?,
        &file.laser_origin,
        "--laser-origin",
    );
    let sensor_origin = origin(
        point(&a.sensor_origin, "--sensor-origin")?,
        &file.sensor_origin,
        "--sensor-origin",
    );
    if a.bins == Some(0) {
        bail!("--bins 0: a capture needs at least one time bin");
    }
    let mut opl = |given: &Option<String>,
                   f: &Option<FileSetting<f64>>,
                   flag: &str,
                   default: &str|
     -> Result<f64> {
        match (given, f) {
            (Some(t), _) => time_s(t, flag),
            (None, Some(f)) => {
                from_file(flag, format!("{}m of optical path", f.value), &f.from);
                Ok(f.value / C_M_PER_S)
            }
            (None, None) => time_s(default, flag),
        }
    };
    let dt_s = opl(&a.dt, &file.dt_opl_m, "--dt", "3mm")?;
    let t0_s = opl(&a.t0, &file.t0_opl_m, "--t0", "0m")?;
    let bins = a.bins.or_else(|| {
        file.bins.as_ref().map(|b| {
            from_file("--bins", b.value.to_string(), &b.from);
            usize::try_from(b.value).unwrap_or(usize::MAX)
        })
    });
    let device_legs = if a.unwarped {
        false
    } else if let Some(l) = &file.device_legs {
        from_file(
            "device legs",
            if l.value { "included" } else { "left out" }.into(),
            &l.from,
        );
        l.value
    } else {
        true
    };
    let spp = match (a.spp, &file.spp) {
        (Some(s), _) => s,
        (None, Some(f)) => {
            from_file("--spp", f.value.to_string(), &f.from);
            u32::try_from(f.value).unwrap_or(u32::MAX)
        }
        (None, None) => 256,
    };
    let max_bounces = match (a.max_bounces, &file.hidden_bounces) {
        (Some(m), _) => m,
        (None, Some(f)) => {
            from_file("--max-bounces", f.value.to_string(), &f.from);
            f.value
        }
        (None, None) => 1024,
    };
    let relay_wall = match (&a.relay_wall, &file.relay_wall) {
        (Some(r), _) => r.clone(),
        (None, Some(f)) => {
            from_file("--relay-wall", f.value.clone(), &f.from);
            f.value.clone()
        }
        (None, None) => "relay_wall".into(),
    };
    Ok((
        CaptureSettings {
            relay_wall,
            grid,
            scan,
            laser_origin,
            sensor_origin,
            bins,
            dt_s,
            t0_s,
            device_legs,
            spp,
            seed: a.seed,
            max_bounces,
            channel: a.channel,
        },
        used,
    ))
}

fn capture(a: &CaptureArgs) -> Result<()> {
    let Some(scene_name) = a.scene.as_deref() else {
        bail!("tprf nlos: give a SCENE to capture, e.g. tprf nlos builtin:nlos-z --out capture");
    };
    let Some(out) = a.out.as_deref() else {
        bail!("tprf nlos {scene_name}: give the output folder with --out DIR");
    };
    // The flags first, so a bad one is refused before the scene loads.
    settings_of(a, &NlosFileSettings::default())?;
    let scene_path = std::path::Path::new(scene_name);
    super::args::check_out("--out", out, &[scene_path])?;
    let (scene, file) = scene::load_with_settings(scene_name)?;
    // mitransient's NLOS integrator watched by a camera (no capture meter): the file is
    // a camera's view, which tprf render renders; tprf nlos needs a wall to capture.
    if file.nlos_view && a.relay_wall.is_none() {
        bail!(
            "{scene_name} is mitransient's NLOS integrator watched by a camera (no nlos_capture_meter on a relay wall): render its view with tprf render {scene_name} --out {}, or capture a wall with tprf nlos {scene_name} --relay-wall ID (its shapes' ids)",
            out.display()
        );
    }
    let (settings, used) = settings_of(a, &file.nlos.unwrap_or_default())?;
    for u in used {
        eprintln!("from the scene file: {u}");
    }
    for note in &scene.notes {
        eprintln!("note: {note}");
    }
    let scene = Arc::new(scene);
    // The geometry first, so a bad wall or grid is refused before any work.
    let geometry = tprf_core::nlos::setup::resolve(&scene, &settings)?;
    eprintln!(
        "relay wall '{}': {:.3} m x {:.3} m; {} sensor points, {} laser point{}; {} bins of {} ({:.4} m) from {}{}",
        geometry.wall.name,
        geometry.wall.width_m,
        geometry.wall.height_m,
        geometry.sensors.len(),
        geometry.lasers.len(),
        if geometry.lasers.len() == 1 { "" } else { "s" },
        geometry.axis.bins,
        format_time(geometry.axis.dt_s),
        geometry.axis.dt_s * C_M_PER_S,
        format_time(geometry.axis.t0_s),
        if geometry.device_legs {
            ", device legs included"
        } else {
            ", unwarped"
        },
    );
    let pool = thread_pool(a.threads)?;
    let progress = Progress::default();
    let bar = ProgressBar::new(geometry.sensors.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} sensor points, {elapsed} ({eta} left)")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let capture = std::thread::scope(|s| {
        let worker =
            s.spawn(|| pool.install(|| render_capture(scene.clone(), &settings, &progress)));
        while !worker.is_finished() {
            bar.set_position(progress.points_done.load(Ordering::Relaxed));
            std::thread::sleep(Duration::from_millis(100));
        }
        worker.join()
    })
    .map_err(|_| anyhow::anyhow!("the capture's worker thread panicked"))??;
    bar.finish_and_clear();
    eprintln!(
        "rendered in {:.2} s ({:.1} M rays)",
        capture.render_s,
        capture.rays as f64 / 1e6
    );
    super::interrupt::catch();
    super::interrupt::check()?;
    write_capture_folder(&capture, out, &[scene_path])
        .with_context(|| format!("writing {}", out.display()))?;
    super::interrupt::check()?;
    println!("{}", out.display());
    Ok(())
}

/// Three comma-separated values of `T`; the error names the part of --volume.
fn triple<T: std::str::FromStr>(text: &str, what: &str) -> Result<[T; 3]> {
    let v: Vec<T> = text
        .split(',')
        .map(|s| s.trim().parse::<T>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("--volume: {what} '{text}' is not three numbers X,Y,Z"))?;
    v.try_into()
        .map_err(|_| anyhow::anyhow!("--volume: {what} '{text}' is not three numbers X,Y,Z"))
}

fn reconstruct(a: &ReconstructArgs) -> Result<()> {
    use tprf_core::nlos::files::{read_capture, write_reconstruction_folder};
    use tprf_core::nlos::reconstruct::{self as rec, GridFrame, Method, Volume, Wave};
    let method: Method = a
        .method
        .parse()
        .map_err(|e: String| anyhow::anyhow!("--method: {e}"))?;
    super::args::check_out("--out", &a.out, &[&a.capture])?;
    let capture = read_capture(&a.capture)?;
    let frame = GridFrame::of(&capture)?;
    let volume = match &a.volume {
        None => Volume::default_for(&capture, &frame)?,
        Some(text) => {
            let parts: Vec<&str> = text.split(':').collect();
            let [c, s, n] = parts.as_slice() else {
                bail!(
                    "--volume {text}: expected CX,CY,CZ:SX,SY,SZ:NX,NY,NZ (centre, size, voxels)"
                );
            };
            let center: [f32; 3] = triple(c, "centre")?;
            Volume::new(
                &frame,
                glam::Vec3::from(center),
                triple(s, "size")?,
                triple(n, "voxels")?,
            )?
        }
    };
    let wave = a
        .wavelength
        .as_deref()
        .map(|w| -> Result<Wave> {
            let m = time_s(w, "--wavelength")? * C_M_PER_S;
            Ok(Wave {
                wavelength_m: m,
                sigma_m: m / std::f64::consts::SQRT_2,
            })
        })
        .transpose()?;
    let pool = thread_pool(a.threads)?;
    let r = pool.install(|| rec::reconstruct(&capture, method, &volume, wave))?;
    let peak = r.peak();
    let p = r.volume.voxel_center(peak[0], peak[1], peak[2]);
    eprintln!(
        "{}: {} x {} x {} voxels in {:.3} s; peak at voxel {:?}, ({:.3}, {:.3}, {:.3}) m",
        method.name(),
        r.volume.voxels[0],
        r.volume.voxels[1],
        r.volume.voxels[2],
        r.seconds,
        peak,
        p.x,
        p.y,
        p.z
    );
    super::interrupt::catch();
    write_reconstruction_folder(&r, &a.capture, &a.out)
        .with_context(|| format!("writing {}", a.out.display()))?;
    super::interrupt::check()?;
    println!("{}", a.out.display());
    Ok(())
}

fn spad(a: &SpadArgs) -> Result<()> {
    use tprf_core::export::staging::Staging;
    use tprf_core::nlos::files::{TalView, read_capture, write_tal_hdf5};
    use tprf_core::sensor::Sensor;
    super::args::check_out("--out", &a.out, &[&a.capture])?;
    let mut sensor = Sensor::load(&a.preset).with_context(|| format!("--preset {}", a.preset))?;
    if let Some(n) = a.cycles {
        match &mut sensor.spad {
            Some(spad) => spad.cycles = n,
            None => {
                bail!("--cycles needs a sensor with a [spad] section (e.g. --preset builtin:spad)")
            }
        }
    }
    if let Some(seed) = a.seed {
        sensor.noise.seed = seed;
    }
    let capture = read_capture(&a.capture)?;
    let measured = tprf_core::nlos::spad::spad_capture(&capture, sensor.clone())?;
    let c = &measured.capture;
    eprintln!(
        "{} TDC bins of {:.4} m from {:.4} m; {:.3e} expected detections over {} transients",
        c.bins(),
        c.delta_t_m,
        c.t_start_m,
        measured.image.expected_detections,
        c.h.len() / c.bins().max(1)
    );
    super::interrupt::catch();
    let staging = Staging::new(&a.out, &[&a.capture])?;
    let dir = staging.path();
    let info = format!(
        "original_format: tprf\ntprf:\n  spad_of: {}\n  preset: {}\n",
        serde_json::to_string(&a.capture.display().to_string())?,
        serde_json::to_string(&a.preset)?
    );
    write_tal_hdf5(
        &TalView::of_loaded(c, info)?,
        &dir.join(tprf_core::nlos::files::HDF5_NAME),
    )?;
    let shape: Vec<u64> = c.h_shape.iter().map(|&d| d as u64).collect();
    tprf_core::export::write_npy_f32(&dir.join(tprf_core::nlos::files::NPY_NAME), &shape, &c.h)?;
    tprf_core::export::write_npy_f32(
        &dir.join("spad_histogram.npy"),
        &shape,
        &measured.image.histogram,
    )?;
    tprf_core::export::write_json(
        &dir.join("spad.json"),
        &serde_json::json!({
            "format": "tprf-nlos-spad",
            "capture": a.capture.display().to_string(),
            "sensor": sensor,
            "bins": c.bins(),
            "delta_t_m": c.delta_t_m,
            "t_start_m": c.t_start_m,
            "expected_detections": measured.image.expected_detections,
            "h": "photon counts of one seeded realisation (H.npy, nlos.hdf5); spad_histogram.npy: their expectation",
        }),
    )?;
    super::interrupt::check()?;
    staging.commit()?;
    println!("{}", a.out.display());
    Ok(())
}

//! `tprf sensor`: measure a rendered cube with a time-of-flight sensor; the files are
//! written by [`tprf_core::export::sensor`].

use std::path::PathBuf;
use std::time::Instant;

use super::args::time_s;
use anyhow::{Context, Result, bail};
use clap::Args;
use tprf_core::export::sensor::{
    DEFAULT_TILE_BYTES, SensorCube, SensorRun, measure_cube, write_sensor_outputs, write_spad_files,
};
use tprf_core::sensor::{Derived, Draws, Exposure, LightPulse, Pipeline, Sensor, SensorModel};

#[derive(Args, Debug)]
pub struct SensorArgs {
    /// A `tprf render` output folder: tprf.npy float32 [H, W, T] (read whole) or
    /// tprf.zarr (read a tile of pixels at a time: a cube larger than memory is
    /// measured), and tprf.json (t0_s, dt_s, bins); bounce layers, when present, give
    /// the AMCW reference depth.
    pub dir: PathBuf,
    /// The sensor: a TOML file (see docs/sensor.md) or builtin:gated, builtin:lidar,
    /// builtin:amcw, builtin:spad. The options below override its parts.
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
    /// Seed of the noise (and of the SPAD's realisation).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Laser cycles of the SPAD histogram (sensors with a [spad] section).
    #[allow(
        rustdoc::broken_intra_doc_links,
        reason = "clap's help text: the brackets are TOML, not links"
    )]
    #[arg(long)]
    pub cycles: Option<u64>,
    /// Scale of the cube's ambient image (ambient.npy), dimensionless: 1 = the ambient
    /// light group at the scene's power, 0 = off (the sensor's ambient_scale).
    #[arg(long)]
    pub ambient_scale: Option<f64>,
    /// AMCW only: seconds of ambient light per unit of emitted energy (1 / the source's
    /// mean power in W), with a unit, e.g. 1ms (the sensor's ambient_exposure_s).
    #[arg(long)]
    pub ambient_exposure: Option<String>,
    /// Also write pixel_Y_X.csv and pixel_Y_X_gates.csv for pixel Y,X (row from the
    /// top, column from the left). Repeatable.
    #[arg(long = "pixel", value_name = "Y,X", value_parser = parse_pixel)]
    pub pixels: Vec<(usize, usize)>,
    /// Output folder: a new or empty one, or an earlier tprf output (replaced whole: the
    /// files are written beside it and swapped in); anything else is refused up front.
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
    if let Some(x) = a.ambient_scale {
        sensor.ambient_scale = x;
    }
    if let Some(t) = &a.ambient_exposure {
        sensor.ambient_exposure_s = Some(time_s(t, "--ambient-exposure")?);
    }
    if let Some(n) = a.cycles {
        match &mut sensor.spad {
            Some(spad) => spad.cycles = n,
            None => {
                bail!("--cycles needs a sensor with a [spad] section (e.g. --preset builtin:spad)")
            }
        }
    }
    Ok(sensor)
}

/// `tprf sensor`.
pub fn run(a: &SensorArgs) -> Result<()> {
    let start = Instant::now();
    super::args::check_out("--out", &a.out, &[&a.dir])?;
    let sensor = sensor_from_args(a)?;
    let cube = SensorCube::open(&a.dir)?;
    let (w, h, axis) = (cube.width, cube.height, cube.axis);
    for &(y, x) in &a.pixels {
        if y >= h || x >= w {
            bail!("--pixel {y},{x} is outside the {h} x {w} image (row, column from 0)");
        }
    }
    let t_kernels = Instant::now();
    let model = SensorModel::new(sensor, axis)?;
    let kernels_s = t_kernels.elapsed().as_secs_f64();
    let t_measure = Instant::now();
    let measured = measure_cube(&cube, &model, &a.pixels, DEFAULT_TILE_BYTES)?;
    let measure_s = t_measure.elapsed().as_secs_f64();
    // The sensor's steps after the clean one, in the one order of
    // tprf_core::sensor::pipeline (the window takes the same): the SPAD reads the clean
    // measurement, the steady image and the cube's ambient image (measure_cube gathered
    // the first two tile by tile; never the cube itself), its [B, H, W] arrays computed
    // and written a band of rows at a time; then the gates get the ambient image as a
    // constant rate (M_i += ambient_scale A integral Exposure_i dt), before the noise,
    // which photon noise grows with; then the noise and the derived depths.
    // Everything is written into a folder beside --out and swapped in at the end.
    let staging = tprf_core::export::staging::Staging::new(&a.out, &[&a.dir])?;
    let pipeline = Pipeline {
        model: &model,
        clean: &measured.measurements,
        steady: measured.steady.as_deref().unwrap_or(&[]),
        ambient: cube.ambient.as_deref(),
    };
    let spad = match &measured.steady {
        Some(_) => Some(write_spad_files(
            staging.path(),
            &pipeline,
            DEFAULT_TILE_BYTES,
        )?),
        None => None,
    };
    let t_noise = Instant::now();
    let gates = pipeline.gates(Draws::Fresh)?;
    let ambient_json = match (&cube.ambient, &gates.ambient) {
        (Some(image), Some(added)) => {
            if let Err(why) = added {
                eprintln!("note: the cube's ambient image is not added: {why}");
            }
            Some(tprf_core::export::ambient::sensor_json(
                &model,
                image,
                added.clone(),
            ))
        }
        _ => None,
    };
    let noise_s = t_noise.elapsed().as_secs_f64();
    let n = model.gate_count();

    if let Some(note) = tprf_core::sensor::pipeline::unlit_gates_note(&model, spad.is_some(), &axis)
    {
        eprintln!("note: {note}");
    }

    let written = write_sensor_outputs(
        staging.path(),
        &SensorRun {
            model: &model,
            gates: &gates,
            width: w,
            height: h,
            cube_dir: &a.dir,
            true_depth: measured.true_depth.as_ref(),
            pixels: &a.pixels,
            traces: &measured.traces,
            tiles: measured.tiles,
            kernels_s,
            measurement_s: measure_s,
            noise_s,
            started: start,
            spad: spad.as_ref(),
            ambient: ambient_json,
        },
    )?;
    staging.commit()?;
    if let Some(s) = &spad {
        eprintln!(
            "SPAD: {} TDC bins, {:.3e} expected detections; realisation {}; {:.1} ms{}",
            s.bins,
            s.expected_detections,
            s.sampler.name(),
            s.seconds * 1e3,
            if s.bands > 1 {
                format!(" in {} bands of rows", s.bands)
            } else {
                String::new()
            }
        );
    }
    if let Some(e) = written.multipath {
        eprintln!(
            "AMCW: multipath error |amcw_depth - true_depth| median {:.4} m, 95 % {:.4} m \
             (ambiguity range {:.3} m)",
            e.median_abs_m, e.p95_abs_m, e.ambiguity_m
        );
    }
    eprintln!(
        "wrote {} ({n} gates x {h} x {w}; kernels {:.1} ms, measurement {:.1} ms{}, noise \
         {:.1} ms)",
        a.out.display(),
        kernels_s * 1e3,
        measure_s * 1e3,
        if measured.tiles > 1 {
            format!(" in {} tiles", measured.tiles)
        } else {
            String::new()
        },
        noise_s * 1e3
    );
    Ok(())
}

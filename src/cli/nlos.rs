//! `tprf nlos SCENE --out DIR`: a non-line-of-sight capture (the transients a SPAD
//! focused on a grid of relay-wall points records), written as tal's `nlos.hdf5`,
//! `H.npy` and `nlos.json`; `tprf nlos reconstruct` and `tprf nlos spad` on a capture.
//! The capture and the reconstruction are `tprf_core::request`'s `CaptureRequest` and
//! `ReconstructRequest`: the options make one, and this command reports progress.

use std::ops::ControlFlow;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use tprf_core::nlos::reconstruct::Method;
use tprf_core::request::{
    CaptureError, CaptureObserver, CaptureRequest, ReconstructError, ReconstructRequest,
    VolumeSpec, parse_length_m,
};
use tprf_core::scene::Channel;

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

/// `tprf nlos reconstruct`'s options: one per [`ReconstructRequest`] field, named as it
/// is serialised (an option not given is left out), and the output folder.
#[derive(Args, Debug, Serialize)]
pub struct ReconstructArgs {
    /// The capture: a `tprf nlos` output folder, or an HDF5 file in tal's format.
    pub capture: PathBuf,
    /// bp (back-projection), fbp (filtered back-projection), fk (f-k migration,
    /// confocal captures) or pf (phasor fields). Default fbp.
    #[arg(long, value_parser = parse_method)]
    pub method: Option<Method>,
    /// Output folder (a new or empty one, or an earlier tprf output).
    #[arg(long)]
    #[serde(skip)]
    pub out: PathBuf,
    /// The voxel volume, CX,CY,CZ:SX,SY,SZ:NX,NY,NZ: centre (world, metres), size along
    /// the wall's u, v and normal (metres), voxels along them. Default: the sensor
    /// grid's extent and lattice, from the wall to the farthest depth the time axis
    /// reaches.
    #[arg(long, value_parser = parse_volume, allow_hyphen_values = true)]
    pub volume: Option<VolumeSpec>,
    /// Central wavelength of the phasor-field kernel (fbp, pf), with a length unit
    /// (m cm mm); default four grid spacings. Its Gaussian's sigma is it over sqrt(2).
    #[arg(long, value_parser = parse_length_m)]
    pub wavelength: Option<f64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// `tprf nlos`'s options: one per [`CaptureRequest`] field, named as it is serialised
/// (an option not given is left out, and takes a Mitsuba NLOS scene's setting or the
/// request's default), and the output folder.
#[derive(Args, Debug, Serialize)]
pub struct CaptureArgs {
    /// A .gltf/.glb/.xml (Mitsuba) path or builtin:NAME (builtin:nlos-z, builtin:nlos-shapes) holding a
    /// planar relay wall and the hidden geometry.
    pub scene: Option<String>,
    /// Output folder (nlos.hdf5, H.npy, nlos.json): a new or empty one, or an earlier
    /// tprf output (replaced whole); anything else is refused up front.
    #[arg(long)]
    #[serde(skip)]
    pub out: Option<PathBuf>,
    /// Name of the relay wall's object (its glTF node, else its mesh; a Mitsuba scene's
    /// shape id, else the shape holding the nlos_capture_meter). Default relay_wall.
    #[arg(long)]
    pub relay_wall: Option<String>,
    /// Sensor points on the wall, along its u and v axes: NXxNY. Default 64x64 (a
    /// Mitsuba NLOS scene: its capture meter's).
    #[arg(long, value_parser = parse_grid)]
    pub grid: Option<[usize; 2]>,
    /// The laser at each sensor point in turn (the default is one fixed laser point).
    #[arg(long, conflicts_with_all = ["exhaustive", "laser_point"])]
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub confocal: bool,
    /// Every point of --laser-grid with every sensor point.
    #[arg(long, conflicts_with = "laser_point")]
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub exhaustive: bool,
    /// Laser points of an exhaustive scan: NXxNY. Default 8x8.
    #[arg(long, value_parser = parse_grid, requires = "exhaustive")]
    pub laser_grid: Option<[usize; 2]>,
    /// The one laser point, X,Y,Z metres (projected onto the wall); default the wall's centre.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    pub laser_point: Option<[f32; 3]>,
    /// Laser device position X,Y,Z metres (default: tal's, 0.5 m left of the wall's
    /// centre and 0.25 m in front).
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    pub laser_origin: Option<[f32; 3]>,
    /// SPAD device position X,Y,Z metres (default as --laser-origin).
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    pub sensor_origin: Option<[f32; 3]>,
    /// Number of time bins (default: up to the longest three-bounce path).
    #[arg(long)]
    pub bins: Option<usize>,
    /// Bin width, with a unit: s ms us ns ps fs, or m cm mm km of optical path. Default
    /// 3mm (a Mitsuba NLOS scene: its film's bin_width_opl).
    #[arg(long, value_parser = time_value)]
    pub dt: Option<f64>,
    /// Start of the time axis, with a unit as --dt. Default 0m (a Mitsuba NLOS scene: its
    /// film's start_opl).
    #[arg(long, value_parser = time_value, allow_hyphen_values = true)]
    pub t0: Option<f64>,
    /// Times start when the pulse hits the wall and end when light returns to it (tal's
    /// default): the device-to-wall legs are left out. Without it they count (a Mitsuba
    /// NLOS scene: as its account_first_and_last_bounces says).
    #[arg(long)]
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub unwarped: bool,
    /// Samples per sensor point (an exhaustive scan's samples serve every laser point).
    /// Default 256 (a Mitsuba NLOS scene: its capture meter's sample_count).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Seed of the samples (default 0): the capture is a function of the request.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Largest number of scattering events in the hidden scene (the two on the wall not
    /// counted). Default 1024 (a Mitsuba NLOS scene: its max_depth - 3).
    #[arg(long)]
    pub max_bounces: Option<u32>,
    /// The spectral band: red, green, blue or gray (default gray).
    #[arg(long, value_parser = parse_channel)]
    pub channel: Option<Channel>,
    /// Worker threads (default: all cores). The output does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
}

fn parse_channel(s: &str) -> Result<Channel, String> {
    s.parse()
        .map_err(|e: tprf_core::scene::UnknownChannel| e.to_string())
}

fn parse_method(s: &str) -> Result<Method, String> {
    s.parse()
}

fn parse_volume(s: &str) -> Result<VolumeSpec, String> {
    s.parse()
}

/// `--dt`/`--t0`: a time with a unit, in seconds.
fn time_value(text: &str) -> Result<f64, String> {
    tprf_core::units::parse_time_s(text)
}

/// `NXxNY` as two counts.
fn parse_grid(text: &str) -> Result<[usize; 2], String> {
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    let [a, b] = parts.as_slice() else {
        return Err(format!("{text}: expected NXxNY, e.g. 64x64"));
    };
    let n = |s: &str| {
        s.trim()
            .parse::<usize>()
            .map_err(|_| format!("{text}: '{s}' is not a whole number"))
    };
    Ok([n(a)?, n(b)?])
}

/// `X,Y,Z` metres.
fn parse_point(text: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = text
        .split(',')
        .map(|s| s.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{text}: expected X,Y,Z in metres"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!(
            "{text}: expected three finite numbers X,Y,Z in metres"
        )),
    }
}

pub fn run(a: &NlosArgs) -> Result<()> {
    match &a.command {
        Some(NlosCommand::Reconstruct(r)) => reconstruct(r),
        Some(NlosCommand::Spad(r)) => spad(r),
        None => capture(&a.capture),
    }
}

/// A capture request's field as `tprf nlos` names it: `--laser-grid` for `laser_grid`,
/// and in the notes of what a scene file set, `the scan` and `device legs`.
pub fn capture_flag(field: &str) -> String {
    match field {
        "scan" => "the scan".into(),
        "unwarped" => "device legs".into(),
        f => super::args::flag(f),
    }
}

/// The options given, keyed as the request's fields (an option not given is left out).
fn given_of(args: &impl Serialize) -> Result<serde_json::Map<String, serde_json::Value>> {
    match serde_json::to_value(args).context("the options as a request")? {
        serde_json::Value::Object(mut map) => {
            map.retain(|_, v| !v.is_null());
            Ok(map)
        }
        v => bail!("the options read as {v}, not as a request"),
    }
}

impl CaptureArgs {
    /// The capture these options describe (not yet validated, no scene file read), and
    /// the keys given.
    pub fn request(&self) -> Result<(CaptureRequest, serde_json::Map<String, serde_json::Value>)> {
        let given = given_of(self)?;
        let request = serde_json::from_value(given.clone().into())
            .context("the options as a capture request")?;
        Ok((request, given))
    }
}

impl ReconstructArgs {
    /// The reconstruction these options describe (not yet validated).
    pub fn request(&self) -> Result<ReconstructRequest> {
        serde_json::from_value(given_of(self)?.into())
            .context("the options as a reconstruction request")
    }
}

/// A capture's error as the command line (`flag`) or a manifest names its fields.
pub fn capture_error(e: CaptureError, flag: impl Fn(&str) -> String) -> anyhow::Error {
    match e {
        CaptureError::Invalid(p) => anyhow::anyhow!(p.text_with(flag)),
        e => e.into(),
    }
}

/// A reconstruction's error as the command line (`flag`) or a manifest names its fields.
pub fn reconstruct_error(e: ReconstructError, flag: impl Fn(&str) -> String) -> anyhow::Error {
    match e {
        ReconstructError::Invalid(p) => anyhow::anyhow!(p.text_with(flag)),
        e => e.into(),
    }
}

/// `tprf nlos SCENE --out DIR`.
fn capture(a: &CaptureArgs) -> Result<()> {
    let Some(scene_name) = a.scene.as_deref() else {
        bail!("tprf nlos: give a SCENE to capture, e.g. tprf nlos builtin:nlos-z --out capture");
    };
    let Some(out) = a.out.as_deref() else {
        bail!("tprf nlos {scene_name}: give the output folder with --out DIR");
    };
    let (request, given) = a.request()?;
    // The options first, so a bad one is refused before the scene loads.
    request
        .validate()
        .map_err(|e| capture_error(e, capture_flag))?;
    super::args::check_out("--out", out, &[std::path::Path::new(scene_name)])?;
    capture_request(request, |k| given.contains_key(k), out, capture_flag)?;
    println!("{}", out.display());
    Ok(())
}

/// Capture `request` into the folder `out` with a progress bar over the sensor points
/// and the capture's lines on stderr (what came from a scene file among them, fields
/// named by `flag`); `given(key)`: whether the caller gave the field (a scene file's
/// setting does not replace it). Ctrl-C while writing drops what was written.
pub fn capture_request(
    mut request: CaptureRequest,
    given: impl Fn(&str) -> bool,
    out: &std::path::Path,
    flag: impl Fn(&str) -> String + Copy,
) -> Result<()> {
    let mut bar = PointsBar::default();
    request
        .capture_to_folder(out, given, flag, &mut bar)
        .map_err(|e| capture_error(e, flag))?;
    Ok(())
}

/// The capture's lines on stderr and a progress bar over its sensor points, shown from
/// the first point until the capture says something else; Ctrl-C caught once the files
/// are being written.
#[derive(Default)]
struct PointsBar {
    bar: Option<ProgressBar>,
}

impl PointsBar {
    fn done(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

impl CaptureObserver for PointsBar {
    fn message(&mut self, line: &str) {
        self.done();
        eprintln!("{line}");
    }

    fn points(&mut self, done: u64, total: u64) -> ControlFlow<()> {
        let bar = self.bar.get_or_insert_with(|| {
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} sensor points, {elapsed} ({eta} left)",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar
        });
        bar.set_position(done);
        ControlFlow::Continue(())
    }

    fn writing(&mut self) -> ControlFlow<()> {
        self.done();
        // Ctrl-C from here on drops what was written (the staging folder) and leaves the
        // old output as it was; checked between files.
        super::interrupt::catch();
        match super::interrupt::check() {
            Ok(()) => ControlFlow::Continue(()),
            Err(_) => ControlFlow::Break(()),
        }
    }
}

impl Drop for PointsBar {
    fn drop(&mut self) {
        self.done();
    }
}

/// `tprf nlos reconstruct CAPTURE --out DIR`.
fn reconstruct(a: &ReconstructArgs) -> Result<()> {
    let request = a.request()?;
    request
        .validate()
        .map_err(|e| reconstruct_error(e, super::args::flag))?;
    super::args::check_out("--out", &a.out, &[&a.capture])?;
    reconstruct_request(&request, &a.out, super::args::flag)?;
    println!("{}", a.out.display());
    Ok(())
}

/// Reconstruct as `tprf nlos reconstruct` does, into the folder `out`, saying the peak
/// on stderr; errors name fields by `flag`.
pub fn reconstruct_request(
    request: &ReconstructRequest,
    out: &std::path::Path,
    flag: impl Fn(&str) -> String + Copy,
) -> Result<()> {
    let r = request.run().map_err(|e| reconstruct_error(e, flag))?;
    let peak = r.peak();
    let p = r.volume.voxel_center(peak[0], peak[1], peak[2]);
    eprintln!(
        "{}: {} x {} x {} voxels in {:.3} s; peak at voxel {:?}, ({:.3}, {:.3}, {:.3}) m",
        r.method.name(),
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
    request
        .write_folder(&r, out)
        .map_err(|e| reconstruct_error(e, flag))
        .with_context(|| format!("writing {}", out.display()))?;
    super::interrupt::check()?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::FromArgMatches;
    use std::collections::BTreeSet;
    use tprf_core::request::serde_keys;

    /// A command's options as request keys (`--laser-grid` as `laser_grid`), `--out`
    /// aside: the folder is where a request is written, not part of it.
    fn flags<A: Args>(name: &'static str) -> BTreeSet<String> {
        A::augment_args(clap::Command::new(name))
            .get_arguments()
            .map(|a| match a.get_long() {
                Some(long) => long.replace('-', "_"),
                None => a.get_id().to_string(),
            })
            .filter(|f| f != "out")
            .collect()
    }

    fn keys<'de, T: serde::Deserialize<'de>>() -> BTreeSet<String> {
        serde_keys::<T>().iter().map(|k| k.to_string()).collect()
    }

    /// Every key a `CaptureRequest` reads is a `tprf nlos` option, and every option a
    /// key; so for a `ReconstructRequest` and `tprf nlos reconstruct`.
    #[test]
    fn every_capture_and_reconstruct_key_is_a_flag() {
        assert_eq!(keys::<CaptureRequest>(), flags::<CaptureArgs>("nlos"));
        assert_eq!(
            keys::<ReconstructRequest>(),
            flags::<ReconstructArgs>("reconstruct")
        );
    }

    fn capture_args(args: &[&str]) -> CaptureArgs {
        let m = CaptureArgs::augment_args(clap::Command::new("nlos"))
            .try_get_matches_from(std::iter::once("nlos").chain(args.iter().copied()))
            .unwrap_or_else(|e| panic!("{args:?}: {e}"));
        CaptureArgs::from_arg_matches(&m).unwrap()
    }

    /// The options reach the request's fields, values as the command line reads them
    /// (grids, points, times with units); nothing given is the default request, and
    /// only what was given counts as given.
    #[test]
    fn options_make_the_request() {
        let (r, given) = capture_args(&["builtin:nlos-z"]).request().unwrap();
        assert_eq!(r, CaptureRequest::new("builtin:nlos-z"));
        assert_eq!(given.keys().collect::<Vec<_>>(), ["scene"]);
        let (r, given) = capture_args(&[
            "builtin:nlos-z",
            "--grid",
            "16x8",
            "--exhaustive",
            "--laser-grid",
            "3x2",
            "--laser-origin",
            "-0.5,0,0.25",
            "--dt",
            "5mm",
            "--t0",
            "1ns",
            "--unwarped",
            "--seed",
            "3",
            "--channel",
            "red",
            "--out",
            "o",
        ])
        .request()
        .unwrap();
        assert_eq!(
            r,
            CaptureRequest {
                grid: [16, 8],
                exhaustive: true,
                laser_grid: Some([3, 2]),
                laser_origin: Some([-0.5, 0.0, 0.25]),
                dt_s: tprf_core::units::parse_time_s("5mm").unwrap(),
                t0_s: 1e-9,
                unwarped: true,
                seed: 3,
                channel: Channel::Red,
                ..CaptureRequest::new("builtin:nlos-z")
            }
        );
        assert!(given.contains_key("laser_grid") && !given.contains_key("spp"));
        let m = ReconstructArgs::augment_args(clap::Command::new("reconstruct"))
            .try_get_matches_from([
                "reconstruct",
                "cap",
                "--method",
                "pf",
                "--volume",
                "0,0,1:1.5,1.5,1:12,12,10",
                "--wavelength",
                "5cm",
                "--out",
                "o",
            ])
            .unwrap();
        let r = ReconstructArgs::from_arg_matches(&m)
            .unwrap()
            .request()
            .unwrap();
        assert_eq!(
            r,
            ReconstructRequest {
                method: Method::Pf,
                volume: Some("0,0,1:1.5,1.5,1:12,12,10".parse().unwrap()),
                wavelength_m: Some(parse_length_m("5cm").unwrap()),
                ..ReconstructRequest::new("cap")
            }
        );
    }
}

//! Helpers the commands share: time options with units, the worker pool, the
//! arguments of a render request and its errors named by option.

use anyhow::{Context, Result};
use tprf_core::request::{RenderRequest, RequestError};
use tprf_core::units::parse_time_s;

/// The value of a time option such as `--t0 3ns` or `--dt 1cm` (a unit of time, or of
/// optical path length divided by c), in seconds; an error names the `option`.
pub(super) fn time_s(text: &str, option: &str) -> Result<f64> {
    parse_time_s(text)
        .map_err(anyhow::Error::msg)
        .with_context(|| option.to_string())
}

/// The worker pool: `threads` threads, or one per core when `None`.
pub(super) fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        pool = pool.num_threads(n);
    }
    pool.build().context("cannot start the worker threads")
}

/// Refuse, before any work, an output folder tprf may not replace
/// (`tprf_core::export::staging::check_target`): "--out PATH: what is there: what to do".
/// `inputs` are the folders and files the command reads.
pub fn check_out(flag: &str, out: &std::path::Path, inputs: &[&std::path::Path]) -> Result<()> {
    use tprf_core::export::{ExportError, staging::check_target};
    check_target(out, inputs).map_err(|e| match e {
        ExportError::OutRefused { path, why } => {
            anyhow::anyhow!("{flag} {}: {why}", path.display())
        }
        e => anyhow::Error::from(e).context(flag.to_string()),
    })
}

/// The arguments every command that renders a scene shares (`tprf render`, and its
/// shards): one [`RenderRequest`] field each, flattened into the command's own
/// arguments (`#[command(flatten)]`), with the request's defaults.
#[derive(clap::Args, Debug, Clone)]
pub struct RequestArgs {
    /// A .gltf/.glb path, a Mitsuba 3 / mitransient .xml scene, or builtin:NAME
    /// (builtin:cornell, builtin:canopy). An XML scene's film (size, temporal_bins,
    /// start_opl, bin_width_opl), sample_count and max_depth stand in for the options
    /// below that are not given.
    pub scene: String,
    /// Image width in pixels (default 256).
    #[arg(long)]
    pub width: Option<usize>,
    /// Image height in pixels (default 256).
    #[arg(long)]
    pub height: Option<usize>,
    /// Samples per pixel (default 64 unless --seconds is given).
    #[arg(long, conflicts_with = "seconds")]
    pub spp: Option<u64>,
    /// Render for this many seconds of wall time instead of a fixed spp.
    #[arg(long)]
    pub seconds: Option<f64>,
    /// Number of time bins (default 256).
    #[arg(long)]
    pub bins: Option<usize>,
    /// Start of the time window, with a unit: s ms us ns ps fs, or m cm mm km of optical
    /// path (default: just before the first arrival).
    #[arg(long, value_parser = time_value)]
    pub t0: Option<f64>,
    /// Bin width, with a unit as for --t0 (default: the window that holds 99.5 % of a pilot
    /// render's energy, divided into --bins).
    #[arg(long, value_parser = time_value)]
    pub dt: Option<f64>,
    /// Largest number of scattering events on a path (Russian roulette ends most earlier;
    /// default 1024).
    #[arg(long)]
    pub max_bounces: Option<u32>,
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
    pub format: tprf_core::export::CubeFormat,
    /// The spectral band the one-channel cube records: red, green, blue or gray.
    #[arg(long, default_value_t = tprf_core::scene::Channel::Gray, value_parser = parse_channel)]
    pub channel: tprf_core::scene::Channel,
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
    #[arg(long, default_value_t = tprf_core::export::shard::DEFAULT_BAND_ROWS, requires = "shard")]
    pub band_rows: usize,
    /// A constant sky of this radiance (W m^-2 sr^-1) in the ambient light group: not
    /// pulsed, rendered once into ambient.npy beside the cube.
    #[arg(long)]
    pub sky: Option<f64>,
    /// Samples per pixel of the ambient image, when the scene has ambient light (a sun,
    /// a sky, lamps tagged ambient). Default: --spp, or 64.
    #[arg(long)]
    pub ambient_spp: Option<u32>,
    /// A participating medium filling the scene (the air: fog, haze, water), replacing
    /// the scene's own: `sigma_s=0.05/m,sigma_a=0.001/m,g=0.9,n=1.0` (coefficients per
    /// metre, Henyey-Greenstein g, refractive index n), or `visibility=30m` (fog of that
    /// meteorological optical range: extinction 3.912 / V, g 0.9; `albedo=` and `g=`
    /// may follow), or `none` to render the scene in vacuum.
    #[arg(long, value_name = "SPEC")]
    pub medium: Option<String>,
    /// Put the camera at X,Y,Z (metres); alone, it keeps the scene camera's direction.
    #[arg(long, value_name = "X,Y,Z", value_parser = vec3_value, allow_hyphen_values = true)]
    pub camera_position: Option<[f64; 3]>,
    /// Turn the camera toward the point X,Y,Z (metres).
    #[arg(long, value_name = "X,Y,Z", value_parser = vec3_value, allow_hyphen_values = true)]
    pub look_at: Option<[f64; 3]>,
    /// The camera's up direction with --look-at (default +Y, or +Z when looking along Y).
    #[arg(long, value_name = "X,Y,Z", value_parser = vec3_value, allow_hyphen_values = true)]
    pub up: Option<[f64; 3]>,
    /// The camera's vertical field of view, degrees (default: the scene camera's).
    #[arg(long, value_name = "DEG")]
    pub fov: Option<f64>,
    /// Where arrival times start: `pinhole` (the time a real camera sees; the default),
    /// `near-plane` (from the camera's near clip plane, as mitransient counts: its cube
    /// bin for bin) or `first-hit` (the camera's leg left out, each pixel's clock
    /// starting at the first surface it sees: mitransient's camera_unwarp). An XML
    /// scene's camera_unwarp stands in when it is not given.
    #[arg(long, value_name = "ORIGIN", value_parser = parse_time_origin)]
    pub time_origin: Option<tprf_core::scene::TimeOrigin>,
    /// When the pulse starts: `light` (as it leaves the light; the default) or
    /// `first-hit` (at the first surface it lights: the light's leg left out, as an NLOS
    /// laser's spot firing at t = 0; mitransient's account_first_and_last_bounces
    /// false). An XML scene's NLOS integrator stands in when it is not given.
    #[arg(long, value_name = "ORIGIN", value_parser = parse_pulse_origin)]
    pub pulse_origin: Option<tprf_core::scene::PulseOrigin>,
    /// The most memory the film may take, with a unit (`2GiB`, `512MiB`, `300MB`; no
    /// unit: bytes). A render whose first pass would not fit is refused with the size
    /// foreseen; before a pass that would take the film over this, or over what the
    /// system, the cgroup or `ulimit -v` leaves, the render stops at the last whole
    /// pass, writes the passes made and exits with status 3.
    #[arg(long, value_name = "SIZE", value_parser = bytes_value)]
    pub max_memory: Option<u64>,
    /// Also write the cube's phasors, computed from the film after the render:
    /// phasor.npy (float32 [H, W, F, 2], real and imaginary; tprf.zarr/phasor for a Zarr
    /// cube) and phasor.json, at mitransient's phasor_hdr_film frequencies for this band
    /// of wavelengths in metres of optical path (its wl_mean and wl_sigma, e.g.
    /// `100:100`). A Mitsuba file with a phasor_hdr_film sets it.
    #[arg(long, value_name = "WL_MEAN:WL_SIGMA")]
    pub phasor: Option<tprf_core::export::phasor::PhasorBand>,
}

impl RequestArgs {
    /// The request these arguments describe (not yet validated).
    pub fn request(&self) -> RenderRequest {
        self.request_with(&tprf_core::scene::FileSettings::default())
            .0
    }

    /// The request, each option not given taken from `file` (a scene file's settings:
    /// see `tprf_core::scene::load_with_settings`) where it has it
    /// ([`RenderRequest::with_file_defaults`]), else the request's default; with what
    /// came from the file, in words, options named as flags.
    pub fn request_with(
        &self,
        file: &tprf_core::scene::FileSettings,
    ) -> (RenderRequest, Vec<String>) {
        let default = RenderRequest::default();
        let mut request = RenderRequest {
            scene: self.scene.clone(),
            width: self.width.unwrap_or(default.width),
            height: self.height.unwrap_or(default.height),
            bins: self.bins.unwrap_or(default.bins),
            t0_s: self.t0,
            dt_s: self.dt,
            spp: self.spp,
            seconds: self.seconds,
            max_bounces: self.max_bounces.unwrap_or(default.max_bounces),
            bounces_separate: self.bounces_separate,
            seed: self.seed,
            channel: self.channel,
            uniform: self.uniform,
            sky_radiance_w_m2_sr: self.sky,
            ambient_spp: self.ambient_spp,
            medium: self.medium.clone(),
            camera_position_m: self.camera_position,
            look_at_m: self.look_at,
            up: self.up,
            fov_deg: self.fov,
            time_origin: self.time_origin.unwrap_or(default.time_origin),
            pulse_origin: self.pulse_origin.unwrap_or(default.pulse_origin),
            threads: self.threads,
            format: self.format,
            frames: self.frames,
            shard: self.shard.clone(),
            band_rows: self.band_rows,
            max_memory_bytes: self.max_memory,
            phasor: self.phasor,
            ..default
        };
        let given = |key: &str| match key {
            "width" => self.width.is_some(),
            "height" => self.height.is_some(),
            "bins" => self.bins.is_some(),
            "t0" => self.t0.is_some(),
            "dt" => self.dt.is_some(),
            "spp" => self.spp.is_some(),
            "max_bounces" => self.max_bounces.is_some(),
            "time_origin" => self.time_origin.is_some(),
            "pulse_origin" => self.pulse_origin.is_some(),
            "phasor" => self.phasor.is_some(),
            _ => true,
        };
        let notes = request.with_file_defaults(file, given);
        (request, notes.iter().map(|n| n.text_with(flag)).collect())
    }
}

/// A request field's option on the command line: `--band-rows` for `band_rows`, `SCENE`
/// for the scene.
pub fn flag(field: &str) -> String {
    match field {
        "scene" => "SCENE".into(),
        f => format!("--{}", f.replace('_', "-")),
    }
}

/// A request's error as the command line says it: fields named by their options, and
/// no light in the pilot pointing at the window options.
pub fn request_error(e: RequestError) -> anyhow::Error {
    use tprf_core::transport::WindowError;
    match e {
        RequestError::Invalid(p) => anyhow::anyhow!(p.text_with(flag)),
        RequestError::Memory(m) => anyhow::anyhow!(m.text_with(flag)),
        RequestError::Window(WindowError::NoLight) => {
            anyhow::Error::from(e).context("--t0 and --dt")
        }
        e => e.into(),
    }
}

/// `--t0`/`--dt`: a time with a unit, in seconds.
fn time_value(text: &str) -> Result<f64, String> {
    parse_time_s(text)
}

/// `--max-memory`: a size with a unit, in bytes.
pub fn bytes_value(text: &str) -> Result<u64, String> {
    tprf_core::budget::parse_bytes(text)
}

/// `X,Y,Z`: three finite numbers.
fn vec3_value(text: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let numbers: Vec<f64> = parts
        .iter()
        .filter_map(|p| p.parse::<f64>().ok())
        .filter(|v| v.is_finite())
        .collect();
    match numbers[..] {
        [x, y, z] if parts.len() == 3 => Ok([x, y, z]),
        _ => Err(format!(
            "'{text}' is not X,Y,Z: three finite numbers separated by commas"
        )),
    }
}

fn parse_format(s: &str) -> Result<tprf_core::export::CubeFormat, String> {
    s.parse()
}

fn parse_time_origin(s: &str) -> Result<tprf_core::scene::TimeOrigin, String> {
    s.parse()
        .map_err(|e: tprf_core::scene::UnknownOrigin| e.to_string())
}

fn parse_pulse_origin(s: &str) -> Result<tprf_core::scene::PulseOrigin, String> {
    s.parse()
        .map_err(|e: tprf_core::scene::UnknownOrigin| e.to_string())
}

fn parse_channel(s: &str) -> Result<tprf_core::scene::Channel, String> {
    s.parse()
        .map_err(|e: tprf_core::scene::UnknownChannel| e.to_string())
}

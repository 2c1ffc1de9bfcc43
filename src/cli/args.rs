//! Helpers the commands share: time options with units, the worker pool, the
//! arguments of a render request and its errors named by option.

use anyhow::{Context, Result};
use serde::Serialize;
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

/// The options of a render (`tprf render`, and its shards): one per [`RenderRequest`]
/// field, each named as the field is serialised (the test `every_request_key_is_a_flag`
/// holds the two lists equal). An option not given is left out of the request
/// (`RequestArgs::given`) and takes the scene file's setting or the request's default,
/// which `--help` shows from [`RenderRequest::default`] ([`with_request_defaults`]).
#[derive(clap::Args, Debug, Clone, Serialize)]
pub struct RequestArgs {
    /// A .gltf/.glb path, a Mitsuba 3 / mitransient .xml scene, or builtin:NAME
    /// (builtin:cornell, builtin:canopy). An XML scene's film (size, temporal_bins,
    /// start_opl, bin_width_opl), sample_count and max_depth stand in for the options
    /// below that are not given.
    pub scene: String,
    /// Image width in pixels.
    #[arg(long)]
    pub width: Option<usize>,
    /// Image height in pixels.
    #[arg(long)]
    pub height: Option<usize>,
    /// Samples per pixel (64 unless --seconds, --error-target or --until-stopped ends
    /// the render).
    #[arg(long, conflicts_with = "seconds")]
    pub spp: Option<u64>,
    /// Render for this many seconds of wall time instead of a fixed spp.
    #[arg(long, value_parser = finite)]
    pub seconds: Option<f64>,
    /// Stop once the film's relative error estimate (from two independent halves) is at
    /// or below this: 0.01 for 1 %.
    #[arg(long, value_name = "FRACTION", value_parser = finite)]
    pub error_target: Option<f64>,
    /// Render until Ctrl-C (without --spp, --seconds or --error-target, no 64 spp
    /// target): the first Ctrl-C ends the render at the end of its pass and writes it.
    #[arg(long)]
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub until_stopped: bool,
    /// Passes of about this many seconds (growing to 4 times that over the first 6 s),
    /// their sizes following the machine's speed; unset: doubling passes (1, 1, 2, 2,
    /// 4, ... samples per pixel), the same cube on any machine.
    #[arg(long, value_name = "SECONDS", value_parser = finite)]
    pub pass_seconds: Option<f64>,
    /// Number of time bins.
    #[arg(long)]
    pub bins: Option<usize>,
    /// Start of the time window, with a unit: s ms us ns ps fs, or m cm mm km of optical
    /// path (default: just before the first arrival).
    #[arg(long, value_parser = time_value)]
    pub t0: Option<f64>,
    /// Bin width, with a unit as for --t0 (default: the window that holds 99.5 % of a pilot
    /// render's energy, divided into --bins; in a scene with media also 99.5 % of the
    /// surfaces' returns, from a pilot with the media emptied: targets behind fog).
    #[arg(long, value_parser = time_value)]
    pub dt: Option<f64>,
    /// Largest number of scattering events on a path (Russian roulette ends most earlier).
    #[arg(long)]
    pub max_bounces: Option<u32>,
    /// Fewest scattering events of a recorded path (2 leaves out direct reflection, 3 an
    /// NLOS view's wall-to-wall light). Paths are traced as before; only what reaches
    /// the cube changes.
    #[arg(long)]
    pub min_bounces: Option<u32>,
    /// Seed of the samples: the cube is a function of the request, seed included.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Next-event estimation, true or false: each scattering vertex joined to a light.
    #[arg(long, value_name = "BOOL")]
    pub nee: Option<bool>,
    /// Scattering events before Russian roulette starts.
    #[arg(long, value_name = "N")]
    pub rr_start: Option<u32>,
    /// Smallest survival probability of Russian roulette, in [0, 1].
    #[arg(long, value_name = "P", value_parser = finite_f32)]
    pub rr_floor: Option<f32>,
    /// Branches of each camera sample at its first scattering vertex, 1..=64 (default:
    /// chosen per render by a pilot).
    #[arg(long, value_name = "N")]
    pub splits: Option<u32>,
    /// Join eye vertices to light vertices, true or false (default: chosen per render by
    /// a pilot).
    #[arg(long, value_name = "BOOL")]
    pub light_vertex: Option<bool>,
    /// The time filter: `box` (a bin holds what arrived in it) or `tent` (an arrival
    /// shared between the two nearest bin centres).
    #[arg(long, value_parser = text_value::<tprf_core::film::TimeFilter>)]
    pub filter: Option<tprf_core::film::TimeFilter>,
    /// Worker threads (default: all cores). The output does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also write frames/0000.png ... (one per bin, shared exposure).
    #[arg(long)]
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub frames: bool,
    /// Per-bounce layers: bounce 0 (emitters seen directly), 1..K and the rest, in
    /// tprf_bounces.npy [K+2, H, W, T] (or the array "bounces" of tprf.zarr).
    #[arg(long)]
    pub bounces_separate: Option<u32>,
    /// How the cube is written: `npy` (tprf.npy, one dense float32 array), `zarr`
    /// (tprf.zarr, chunked and compressed, only where light arrived), or `auto`: npy
    /// up to 4 GiB, zarr above.
    #[arg(long, value_parser = parse_format)]
    pub format: Option<tprf_core::export::CubeFormat>,
    /// The spectral band the one-channel cube records: red, green, blue or gray, or a
    /// wavelength in [360, 830] nm (`550nm`): colours upsampled to smooth spectra,
    /// dispersive indices read there (docs/dispersion.md).
    #[arg(long, value_parser = parse_channel)]
    pub channel: Option<tprf_core::scene::Channel>,
    /// Several bands in one render, in this order: `450nm,550nm,650nm`. Writes
    /// tprf_spectral.npy float32 [L, H, W, T] (band k the k-th wavelength) and, as
    /// tprf.npy, the bands' CIE 1931 luminance, or the band --channel names when it is
    /// one of them (docs/dispersion.md).
    #[arg(long, value_parser = parse_wavelengths, conflicts_with = "spectrum")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wavelengths: Option<Wavelengths>,
    /// Several bands evenly spaced, FIRST:LAST:COUNT, both ends included
    /// (`400nm:700nm:31`): the same as listing them with --wavelengths.
    #[arg(long, value_parser = parse_spectrum)]
    #[serde(rename = "wavelengths", skip_serializing_if = "Option::is_none")]
    pub spectrum: Option<Wavelengths>,
    /// Every pixel draws every pass's samples, for the same noise across the image.
    /// Default: from the fourth sample per pixel on, where the noise is uneven enough for
    /// it to pay, pixels draw samples in proportion to their measured noise over the
    /// square root of their cost, for the least cube error per second (unbiased either
    /// way).
    #[arg(long)]
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub uniform: bool,
    /// Render polarized: also write `tprf_stokes.npy`, float32 [4, H, W, T] (S0 S1 S2
    /// S3 in the camera's frame, S1 > 0 along the image's x axis; `tprf.npy` is S0).
    /// Refused for scenes with media or luminescent materials, and with --format zarr
    /// (docs/polarization.md).
    #[arg(long)]
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub polarized: bool,
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
    #[arg(long, requires = "shard")]
    pub band_rows: Option<usize>,
    /// A constant sky of this radiance (W m^-2 sr^-1) in the ambient light group: not
    /// pulsed, rendered once into ambient.npy beside the cube.
    #[arg(long, value_parser = finite)]
    pub sky: Option<f64>,
    /// Samples per pixel of the ambient image, when the scene has ambient light (a sun,
    /// a sky, lamps tagged ambient). Default: --spp, or 64.
    #[arg(long)]
    pub ambient_spp: Option<u32>,
    /// A participating medium filling the scene (the air: fog, haze, water), replacing
    /// the scene's own: `sigma_s=0.05/m,sigma_a=0.001/m,g=0.9,n=1.0` (coefficients per
    /// metre, Henyey-Greenstein g, refractive index n, or a dispersive one: `n=bk7`,
    /// `n=fused_silica`, `n=water`, `n=cauchy:A:B`, `n=sellmeier:B1:B2:B3:C1:C2:C3` with
    /// B, C in um^2), or `visibility=30m` (fog of that
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
    #[arg(long, value_name = "DEG", value_parser = finite)]
    pub fov: Option<f64>,
    /// Where arrival times start: `pinhole` (the time a real camera sees), `near-plane`
    /// (from the camera's near clip plane, as mitransient counts: its cube bin for bin)
    /// or `first-hit` (the camera's leg left out, each pixel's clock starting at the
    /// first surface it sees: mitransient's camera_unwarp). An XML scene's
    /// camera_unwarp stands in when it is not given.
    #[arg(long, value_name = "ORIGIN", value_parser = parse_time_origin)]
    pub time_origin: Option<tprf_core::scene::TimeOrigin>,
    /// When the pulse starts: `light` (as it leaves the light) or `first-hit` (at the
    /// first surface it lights: the light's leg left out, as an NLOS laser's spot firing
    /// at t = 0; mitransient's account_first_and_last_bounces false). An XML scene's
    /// NLOS integrator stands in when it is not given.
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
    /// The options given, keyed as the request's fields (an option not given is left
    /// out).
    fn given(&self) -> Result<serde_json::Map<String, serde_json::Value>> {
        match serde_json::to_value(self).context("the options as a render request")? {
            serde_json::Value::Object(mut map) => {
                map.retain(|_, v| !v.is_null());
                Ok(map)
            }
            v => anyhow::bail!("the options read as {v}, not as a render request"),
        }
    }

    /// The request these arguments describe (not yet validated): each option given, the
    /// request's default for the others.
    pub fn request(&self) -> Result<RenderRequest> {
        self.request_with(&tprf_core::scene::FileSettings::default())
            .map(|(r, _)| r)
    }

    /// The request, each option not given taken from `file` (a scene file's settings:
    /// see `tprf_core::scene::load_with_settings`) where it has it
    /// ([`RenderRequest::with_file_defaults`]), else the request's default; with what
    /// came from the file, in words, options named as flags.
    pub fn request_with(
        &self,
        file: &tprf_core::scene::FileSettings,
    ) -> Result<(RenderRequest, Vec<String>)> {
        let given = self.given()?;
        let mut request: RenderRequest = serde_json::from_value(given.clone().into())
            .context("the options as a render request")?;
        let notes = request.with_file_defaults(file, |key| given.contains_key(key));
        Ok((request, notes.iter().map(|n| n.text_with(flag)).collect()))
    }
}

/// `command` (the `tprf` command) with `tprf render`'s options showing their defaults
/// as [`RenderRequest::default`] serialises them (`[default: 256]`), so that no option
/// restates one.
pub fn with_request_defaults(command: clap::Command) -> clap::Command {
    let defaults = match serde_json::to_value(RenderRequest::default()) {
        Ok(serde_json::Value::Object(map)) => map,
        _ => return command,
    };
    command.mut_subcommand("render", |render| {
        let ids: Vec<String> = render
            .get_arguments()
            .map(|a| a.get_id().to_string())
            .collect();
        ids.into_iter().fold(render, |render, id| {
            let shown = match defaults.get(&id) {
                Some(serde_json::Value::String(s)) if id != "scene" => s.clone(),
                Some(v @ (serde_json::Value::Number(_) | serde_json::Value::Bool(_))) => {
                    v.to_string()
                }
                _ => return render,
            };
            render.mut_arg(id, |arg| {
                let help = arg.get_help().map(ToString::to_string).unwrap_or_default();
                let long = arg.get_long_help().map(ToString::to_string);
                let arg = arg.help(format!("{help} [default: {shown}]"));
                match long {
                    Some(long) => arg.long_help(format!("{long}\n\n[default: {shown}]")),
                    None => arg,
                }
            })
        })
    })
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

/// A finite number: a request travels as JSON, which has no NaN or infinity (the
/// request's own check then says what range the option takes).
pub(super) fn finite(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(format!("{v} is not a finite number")),
        Err(e) => Err(e.to_string()),
    }
}

fn finite_f32(text: &str) -> Result<f32, String> {
    match text.trim().parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(format!("{v} is not a finite number")),
        Err(e) => Err(e.to_string()),
    }
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

/// A value given as the text its type is serialised as (`box`, `tent`).
fn text_value<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, String> {
    T::deserialize(serde::de::value::StrDeserializer::<serde::de::value::Error>::new(text.trim()))
        .map_err(|e| e.to_string())
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

/// `--wavelengths` and `--spectrum`'s value: the request's `wavelengths`.
#[derive(Clone, Debug, Serialize)]
#[serde(transparent)]
pub struct Wavelengths(Vec<tprf_core::scene::spectrum::Wavelength>);

fn parse_wavelengths(s: &str) -> Result<Wavelengths, String> {
    tprf_core::scene::wavelengths::parse_list(s).map(Wavelengths)
}

fn parse_spectrum(s: &str) -> Result<Wavelengths, String> {
    tprf_core::scene::wavelengths::parse_range(s).map(Wavelengths)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{Args, CommandFactory, FromArgMatches};
    use std::collections::BTreeSet;
    use tprf_core::request::serde_keys;

    /// `tprf render`'s options as request keys: `--band-rows` as `band_rows`, the
    /// positional scene as `scene`.
    fn flags() -> BTreeSet<String> {
        RequestArgs::augment_args(clap::Command::new("render"))
            .get_arguments()
            .map(|a| match a.get_long() {
                Some(long) => long.replace('-', "_"),
                None => a.get_id().to_string(),
            })
            .collect()
    }

    /// The two lists are one: every key a `RenderRequest` reads (from its own
    /// `Deserialize`) is a `tprf render` option, and every option a key.
    #[test]
    fn every_request_key_is_a_flag() {
        let keys: BTreeSet<String> = serde_keys::<RenderRequest>()
            .iter()
            .map(|k| k.to_string())
            .collect();
        // `--spectrum` is `wavelengths` given as a range.
        let flags: BTreeSet<String> = flags().into_iter().filter(|f| f != "spectrum").collect();
        assert_eq!(
            keys.difference(&flags).collect::<Vec<_>>(),
            Vec::<&String>::new(),
            "request keys with no tprf render option"
        );
        assert_eq!(
            flags.difference(&keys).collect::<Vec<_>>(),
            Vec::<&String>::new(),
            "tprf render options that are no request key"
        );
    }

    fn parse(args: &[&str]) -> RequestArgs {
        let command = RequestArgs::augment_args(clap::Command::new("render"));
        let matches = command
            .try_get_matches_from(std::iter::once("render").chain(args.iter().copied()))
            .unwrap_or_else(|e| panic!("{args:?}: {e}"));
        RequestArgs::from_arg_matches(&matches).unwrap()
    }

    /// Each option given reaches its field: an option with a value unlike the default
    /// changes the request in that key alone (compared as the request serialises),
    /// and nothing given is the default request.
    #[test]
    fn each_option_sets_its_own_field() {
        let value = |key: &str| -> &[&str] {
            match key {
                "width" | "height" | "bins" | "band_rows" | "threads" | "ambient_spp" => &["7"],
                "spp" | "seed" | "max_bounces" | "min_bounces" | "bounces_separate"
                | "rr_start" => &["5"],
                "splits" => &["3"],
                "seconds" | "error_target" | "pass_seconds" | "rr_floor" | "sky" => &["0.5"],
                "fov" => &["33"],
                "t0" => &["1ns"],
                "dt" => &["7ps"],
                "nee" => &["false"],
                "light_vertex" => &["true"],
                "filter" => &["tent"],
                "format" => &["zarr"],
                "channel" => &["red"],
                "wavelengths" => &["450nm,550nm"],
                "spectrum" => &["450nm:550nm:3"],
                "time_origin" => &["near-plane"],
                "pulse_origin" => &["first-hit"],
                "medium" => &["visibility=30m"],
                "camera_position" | "look_at" | "up" => &["1,-2,3"],
                "max_memory" => &["2GiB"],
                "phasor" => &["100:50"],
                "shard" => &["1/2"],
                "until_stopped" | "frames" | "uniform" | "polarized" => &[],
                other => panic!("no test value for --{other}: add one"),
            }
        };
        let plain = serde_json::to_value(parse(&["builtin:x"]).request().unwrap()).unwrap();
        assert_eq!(
            parse(&["builtin:x"]).request().unwrap(),
            RenderRequest::new("builtin:x")
        );
        for key in flags().into_iter().filter(|k| k != "scene") {
            let flag = format!("--{}", key.replace('_', "-"));
            let mut args = vec!["builtin:x", flag.as_str()];
            args.extend_from_slice(value(&key));
            if key == "band_rows" {
                args.extend_from_slice(&["--shard", "0/2"]);
            }
            let request = serde_json::to_value(parse(&args).request().unwrap()).unwrap();
            // A value the option takes always reaches the request (JSON drops NaN).
            let mut odd = vec!["builtin:x", flag.as_str(), "NaN"];
            if key == "band_rows" {
                odd.extend_from_slice(&["--shard", "0/2"]);
            }
            if !value(&key).is_empty()
                && let Ok(m) = RequestArgs::augment_args(clap::Command::new("render"))
                    .try_get_matches_from(std::iter::once("render").chain(odd.iter().copied()))
            {
                let given = RequestArgs::from_arg_matches(&m).unwrap().given().unwrap();
                assert!(given.contains_key(&key), "{odd:?} is lost on the way");
            }
            let changed: Vec<&String> = request
                .as_object()
                .unwrap()
                .iter()
                .filter(|(k, v)| plain.get(k.as_str()) != Some(*v))
                .map(|(k, _)| k)
                .filter(|k| !(key == "band_rows" && *k == "shard"))
                .collect();
            let key = if key == "spectrum" {
                "wavelengths".to_string()
            } else {
                key
            };
            assert_eq!(changed, [&key], "{args:?}");
        }
    }

    /// `--wavelengths` and `--spectrum` fill the same list; bad values are refused
    /// naming the flag, and the two together are refused.
    #[test]
    fn wavelengths_and_spectrum_are_one_list() {
        let list = |args: &[&str]| parse(args).request().unwrap().wavelengths;
        let names = |l: Vec<tprf_core::scene::spectrum::Wavelength>| {
            l.iter().map(|w| w.name()).collect::<Vec<_>>()
        };
        assert_eq!(
            names(list(&["builtin:x", "--wavelengths", "650nm,450nm"])),
            ["650nm", "450nm"]
        );
        assert_eq!(
            names(list(&["builtin:x", "--spectrum", "400nm:700nm:4"])),
            ["400nm", "500nm", "600nm", "700nm"]
        );
        let refused = |args: &[&str]| {
            RequestArgs::augment_args(clap::Command::new("render"))
                .try_get_matches_from(std::iter::once("render").chain(args.iter().copied()))
                .unwrap_err()
                .to_string()
        };
        for (flag, bad) in [
            ("--wavelengths", "450nm,900nm"),
            ("--wavelengths", "450nm,450nm"),
            ("--wavelengths", "blue"),
            ("--spectrum", "700nm:400nm:3"),
            ("--spectrum", "400nm:700nm"),
        ] {
            let e = refused(&["builtin:x", flag, bad]);
            assert!(e.contains(flag), "{flag} {bad}: {e}");
        }
        let both = refused(&[
            "builtin:x",
            "--wavelengths",
            "450nm",
            "--spectrum",
            "400nm:700nm:3",
        ]);
        assert!(
            both.contains("--wavelengths") && both.contains("--spectrum"),
            "{both}"
        );
    }

    /// `--help` shows the request's own defaults.
    #[test]
    fn help_shows_the_requests_defaults() {
        let mut command = with_request_defaults(crate::cli::Cli::command());
        let render = command.find_subcommand_mut("render").unwrap();
        let help = render.render_help().to_string();
        let d = RenderRequest::default();
        for (flag, shown) in [
            ("--width", d.width.to_string()),
            ("--rr-start", d.rr_start.to_string()),
            ("--nee", d.nee.to_string()),
            ("--band-rows", d.band_rows.to_string()),
        ] {
            // The option's line and the lines of its text that follow it.
            let mut lines = help
                .lines()
                .skip_while(|l| !l.trim_start().starts_with(flag));
            let first = lines.next().unwrap_or_default().to_string();
            let line = first
                + &lines
                    .take_while(|l| !l.trim_start().starts_with('-') && !l.trim().is_empty())
                    .collect::<String>();
            assert!(
                line.contains(&format!("[default: {shown}]")),
                "{flag}: {line}"
            );
        }
    }
}

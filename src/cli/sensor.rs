//! `tprf sensor`: measure a rendered cube with a time-of-flight sensor. The options make
//! a [`MeasureRequest`], which measures and writes the folder
//! ([`MeasureRequest::measure_to_folder`]); this command prints what was made.

use std::path::{Path, PathBuf};

use super::args::finite;
use anyhow::{Context, Result};
use clap::Args;
use serde::Serialize;
use tprf_core::request::{MeasureError, MeasureRequest};

/// `tprf sensor`'s options: one per [`MeasureRequest`] field, named as it is serialised
/// (an option not given is left out), and the output folder.
#[derive(Args, Debug, Serialize)]
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
    #[arg(long, value_parser = finite)]
    pub noise_sigma: Option<f64>,
    /// Photon noise: photons per unit of measurement (0: off).
    #[arg(long, value_parser = finite)]
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
    #[arg(long, value_parser = finite)]
    pub ambient_scale: Option<f64>,
    /// AMCW only: seconds of ambient light per unit of emitted energy (1 / the source's
    /// mean power in W), with a unit, e.g. 1ms (the sensor's ambient_exposure_s).
    #[arg(long, value_parser = time_text)]
    pub ambient_exposure: Option<String>,
    /// Also write pixel_Y_X.csv and pixel_Y_X_gates.csv for pixel Y,X (row from the
    /// top, column from the left). Repeatable.
    #[arg(long = "pixel", value_name = "Y,X", value_parser = parse_pixel)]
    #[serde(rename = "pixel")]
    pub pixels: Vec<(usize, usize)>,
    /// Output folder: a new or empty one, or an earlier tprf output (replaced whole: the
    /// files are written beside it and swapped in); anything else is refused up front.
    #[arg(long)]
    #[serde(skip)]
    pub out: PathBuf,
}

/// A time with a unit, kept as text (the request reads it).
fn time_text(text: &str) -> Result<String, String> {
    tprf_core::units::parse_time_s(text).map(|_| text.to_string())
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

impl SensorArgs {
    /// The measurement these options describe: each option given, keyed as the
    /// request's field (the test `every_measure_key_is_a_flag` holds the two lists
    /// equal).
    pub fn request(&self) -> Result<MeasureRequest> {
        serde_json::from_value(serde_json::to_value(self)?)
            .context("the options as a measurement request")
    }
}

/// `tprf sensor`.
pub fn run(a: &SensorArgs) -> Result<()> {
    super::args::check_out("--out", &a.out, &[&a.dir])?;
    measure(&a.request()?, &a.out, |e| match e {
        MeasureError::Invalid(p) => anyhow::anyhow!(p.text_with(super::args::flag)),
        e => e.into(),
    })
}

/// Measure as `tprf sensor` does, into the folder `out`, saying what was made on stderr;
/// `error` words the request's errors for the caller (options, or a manifest's keys).
pub fn measure(
    request: &MeasureRequest,
    out: &Path,
    error: impl Fn(MeasureError) -> anyhow::Error,
) -> Result<()> {
    let m = request.measure_to_folder(out).map_err(error)?;
    for note in &m.notes {
        eprintln!("note: {note}");
    }
    if let Some(s) = &m.spad {
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
    if let Some(e) = m.multipath {
        eprintln!(
            "AMCW: multipath error |amcw_depth - true_depth| median {:.4} m, 95 % {:.4} m \
             (ambiguity range {:.3} m)",
            e.median_abs_m, e.p95_abs_m, e.ambiguity_m
        );
    }
    if let Some(f) = m.flim {
        eprintln!(
            "FLIM: lifetime median {:.3} ns (5-95 %: {:.3} to {:.3} ns) in {} of {} pixels \
             (gates {:.3} ns apart)",
            f.median_s * 1e9,
            f.p05_s * 1e9,
            f.p95_s * 1e9,
            f.pixels_with_lifetime,
            f.pixels,
            f.gate_spacing_s * 1e9
        );
    }
    eprintln!(
        "wrote {} ({} gates x {} x {}; kernels {:.1} ms, measurement {:.1} ms{}, noise \
         {:.1} ms)",
        out.display(),
        m.gates,
        m.height,
        m.width,
        m.kernels_s * 1e3,
        m.measurement_s * 1e3,
        if m.tiles > 1 {
            format!(" in {} tiles", m.tiles)
        } else {
            String::new()
        },
        m.noise_s * 1e3
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Args;
    use std::collections::BTreeSet;
    use tprf_core::request::serde_keys;

    /// Every key a `MeasureRequest` reads is a `tprf sensor` option (`--out` aside: the
    /// folder is where a request is written, not part of it), and every option a key.
    #[test]
    fn every_measure_key_is_a_flag() {
        let keys: BTreeSet<String> = serde_keys::<MeasureRequest>()
            .iter()
            .map(|k| k.to_string())
            .collect();
        let flags: BTreeSet<String> = SensorArgs::augment_args(clap::Command::new("sensor"))
            .get_arguments()
            .map(|a| match a.get_long() {
                Some(long) => long.replace('-', "_"),
                None => a.get_id().to_string(),
            })
            .filter(|f| f != "out")
            .collect();
        assert_eq!(keys, flags);
    }

    /// The options reach the request's fields: a time with its unit, the pixels.
    #[test]
    fn options_make_the_request() {
        use clap::FromArgMatches;
        let m = SensorArgs::augment_args(clap::Command::new("sensor"))
            .try_get_matches_from([
                "sensor",
                "cube",
                "--preset",
                "builtin:amcw",
                "--ambient-exposure",
                "2ms",
                "--pixel",
                "1,2",
                "--pixel",
                "3,4",
                "--seed",
                "5",
                "--out",
                "o",
            ])
            .unwrap();
        let r = SensorArgs::from_arg_matches(&m).unwrap().request().unwrap();
        assert_eq!(
            r,
            MeasureRequest {
                preset: Some("builtin:amcw".into()),
                ambient_exposure_s: Some(2e-3),
                pixels: vec![(1, 2), (3, 4)],
                seed: Some(5),
                ..MeasureRequest::new("cube")
            }
        );
    }
}

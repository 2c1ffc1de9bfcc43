//! Phasors of a cube: what mitransient's `phasor_hdr_film` records, computed from the
//! film (the time-binned TPRF store) after the render, never by a second render.
//!
//! **The frequencies** are mitransient's (`films/phasor_hdr_film.py`): with `nt` bins of
//! `bw` metres of optical path, `mean_idx = nt bw / wl_mean`, `sigma_idx = nt bw /
//! (6 wl_sigma)`, the indices `floor(mean_idx - 3 sigma_idx) ..= ceil(mean_idx + 3
//! sigma_idx)` clamped to `[0, nt / 2]` of numpy's `fftfreq(nt, d = bw)`: `k / (nt bw)`
//! cycles per metre of optical path ([`fftfreq`]; an even `nt`'s index `nt / 2` is
//! numpy's negative Nyquist frequency, kept as numpy gives it). mitransient stores them
//! as float32 (a relative rounding below 6e-8, a phase error below 2e-5 rad at the
//! example's 3000 m paths); here they are f64.
//!
//! **The definition**: pixel `p`, frequency `f` (per metre of optical path):
//! `P(p, f) = sum over samples of (value / spp) e^(-2 pi i f (opl - opl0))`, `opl0` the
//! window's start (mitransient's `start_opl`: tprf's window starts at `start_opl +
//! near_clip`, where mitransient's path lengths start): the sign and scale of
//! mitransient's (`render/phasor_image_block.py`: `phase = -2 pi f opl`, real part
//! `spec cos(phase)`, imaginary `spec sin(phase)`, `spec` already divided by spp). Its
//! `P(p, 0)` is the pixel's steady radiance in the window.
//!
//! **From bins**: a bin holds the integral of the pixel's radiance over the bin
//! (DESIGN.md). Taking the light as uniform inside each bin, the exact integral of
//! `e^(-2 pi i f x)` over bin `k` (width `dt`, centre `x_k`) over `dt` is
//! `e^(-2 pi i f x_k) sinc(f dt)` (`sinc(u) = sin(pi u) / (pi u)`), so
//! `P(p, f) = sinc(f dt) sum_k b_k e^(-2 pi i f x_k)` ([`bin_factor`]). That is the
//! expected phasor of a return whose place inside its bin is unknown, and exact for
//! light uniform within bins; it never amplifies (`|sinc| <= 1`). The bin centre alone
//! (factor 1) is the other choice: the two differ by `1 - sinc(f dt) ~ (pi f dt)^2 / 6`,
//! 3.7e-4 at the highest frequency of mitransient's example (`f dt` = 0.015), far below
//! its noise. For light smooth across many bins the centre sum is `sinc(f dt)` times the
//! true coefficient (Poisson summation), so there the bin-uniform estimate is low by
//! `1 - sinc^2(f dt) ~ (pi f dt)^2 / 3` (7.4e-4 in the example): keep `f dt` small (bins
//! much narrower than the wavelengths) where that matters. A `tent` film has already
//! spread each sample's phase linearly between two bin centres (on average the same
//! `sinc^2` as a box bin with this factor), so its factor is 1.
//!
//! Light outside the window is not in the film: mitransient's phasor film has no window
//! and keeps every arrival. Choose a window holding the light (mitransient's example:
//! 4000 m of optical path) when comparing.
//!
//! **Files**: `phasor.npy` float32 `[H, W, F, 2]` (real, imaginary; row 0 = top), or the
//! array `phasor` of `tprf.zarr` (dimensions `y`, `x`, `f`, `part`) when the cube is
//! Zarr; `phasor.json` ([`PhasorMetadata`], also under `"phasor"` in `tprf.json`) lists
//! the frequencies per metre and in Hz (`f c`) and the wavelengths in metres.

use std::fmt;
use std::path::Path;
use std::str::FromStr;
use std::sync::Arc;

use rayon::prelude::*;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use zarrs::array::{Array, ArrayBuilder, ArraySubset};
use zarrs::filesystem::FilesystemStore;

use super::{ExportError, read_npy_f32, write_json, write_npy_f32, zarr};
use crate::film::{FilmSnapshot, TimeFilter};
use crate::units::C_M_PER_S;

/// The file beside `tprf.npy`.
pub const PHASOR_NPY: &str = "phasor.npy";
/// The frequencies and the definition, beside it.
pub const PHASOR_JSON: &str = "phasor.json";
/// The array's path in `tprf.zarr`.
const ZARR_ARRAY: &str = "/phasor";
/// Pixels per side of a Zarr chunk (every frequency in one chunk).
const ZARR_TILE: u64 = 64;

/// mitransient's defaults of `phasor_hdr_film`, metres of optical path.
pub const WL_MEAN_DEFAULT_M: f64 = 100.0;
pub const WL_SIGMA_DEFAULT_M: f64 = 1000.0;

/// What the phasor's definition is, in words (`phasor.json`'s `definition`).
pub const DEFINITION: &str = "P[y, x, j] = sum over samples of (value / spp) exp(-2 pi i f_j \
(opl - opl0)), f_j in cycles per metre of optical path, opl0 the window's start (mitransient's \
start_opl): mitransient's phasor_hdr_film sign and scale; [..., 0] real, [..., 1] imaginary; \
P at f = 0 is the steady radiance in the window (W m^-2 sr^-1)";

/// How a bin becomes a phasor, in words (`phasor.json`'s `from_bins`).
pub const FROM_BINS: &str = "computed from the time-binned film: sum over bins k of b_k \
exp(-2 pi i f (x_k - opl0)) g(f), x_k the bin's centre; box filter: g = sinc(f dt) = \
sin(pi f dt) / (pi f dt), the exact integral over the bin for light uniform within it; tent \
filter: g = 1";

/// mitransient's band of wavelengths (`wl_mean`, `wl_sigma`: the Morlet filter of
/// phasor-field NLOS imaging), metres of optical path. Text form `MEAN:SIGMA`, each a
/// number of metres with or without the unit `m` (`100:100`, `100m:1000m`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhasorBand {
    pub wl_mean_m: f64,
    pub wl_sigma_m: f64,
}

impl Default for PhasorBand {
    fn default() -> Self {
        PhasorBand {
            wl_mean_m: WL_MEAN_DEFAULT_M,
            wl_sigma_m: WL_SIGMA_DEFAULT_M,
        }
    }
}

/// `numpy.fft.fftfreq(n, d)[k]`: `k / (n d)` for `k < ceil(n / 2)`, `(k - n) / (n d)`
/// after (the negative half), cycles per unit of `d`.
pub fn fftfreq(n: usize, d: f64, k: usize) -> f64 {
    let positive = n.div_ceil(2);
    let signed = if k < positive {
        k as f64
    } else {
        k as f64 - n as f64
    };
    signed / (n as f64 * d)
}

/// `sin(pi u) / (pi u)`, 1 at 0.
pub fn sinc(u: f64) -> f64 {
    let x = std::f64::consts::PI * u;
    if x.abs() < 1e-8 { 1.0 } else { x.sin() / x }
}

/// The factor a bin's centre phasor takes at frequency `f_per_m` (bins `dt_opl_m`
/// metres of optical path wide): `sinc(f dt)` for a box film (the exact integral over
/// the bin of light uniform within it), 1 for a tent film (see the module doc).
pub fn bin_factor(filter: TimeFilter, f_per_m: f64, dt_opl_m: f64) -> f64 {
    match filter {
        TimeFilter::Box => sinc(f_per_m * dt_opl_m),
        TimeFilter::Tent => 1.0,
    }
}

/// A length in metres: a number, or a number followed by `m`.
fn parse_metres(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let number = t.strip_suffix('m').unwrap_or(t).trim();
    number
        .parse::<f64>()
        .map_err(|_| format!("'{t}' is not a length in metres (100 or 100m)"))
}

impl PhasorBand {
    /// Both wavelengths finite and > 0.
    pub fn check(&self) -> Result<(), String> {
        for (name, v) in [("wl_mean", self.wl_mean_m), ("wl_sigma", self.wl_sigma_m)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!(
                    "{name} {v} m must be a finite wavelength > 0 (metres of optical path)"
                ));
            }
        }
        Ok(())
    }

    /// The first and last index of `fftfreq(bins, dt_opl_m)` mitransient keeps; an
    /// error when none is left (`wl_mean` shorter than about two bins).
    pub fn index_range(&self, bins: usize, dt_opl_m: f64) -> Result<(usize, usize), String> {
        self.check()?;
        if bins == 0 || !(dt_opl_m.is_finite() && dt_opl_m > 0.0) {
            return Err(format!("no time axis ({bins} bins of {dt_opl_m} m)"));
        }
        let span_m = bins as f64 * dt_opl_m;
        let mean_idx = span_m / self.wl_mean_m;
        let sigma_idx = span_m / (6.0 * self.wl_sigma_m);
        let lo = (mean_idx - 3.0 * sigma_idx).floor().max(0.0);
        let hi = (mean_idx + 3.0 * sigma_idx).ceil().min((bins / 2) as f64);
        if !(lo <= hi) {
            return Err(format!(
                "no frequency: wl_mean {} m is shorter than two bins of {dt_opl_m} m (the \
                 shortest wavelength the {bins} bins hold is {} m)",
                self.wl_mean_m,
                2.0 * dt_opl_m
            ));
        }
        Ok((lo as usize, hi as usize))
    }

    /// mitransient's frequencies for `bins` bins of `dt_opl_m`, cycles per metre of
    /// optical path, in increasing index order.
    pub fn frequencies_per_m(&self, bins: usize, dt_opl_m: f64) -> Result<Vec<f64>, String> {
        let (lo, hi) = self.index_range(bins, dt_opl_m)?;
        Ok((lo..=hi).map(|k| fftfreq(bins, dt_opl_m, k)).collect())
    }
}

impl FromStr for PhasorBand {
    type Err = String;
    fn from_str(s: &str) -> Result<PhasorBand, String> {
        let (mean, sigma) = s.split_once(':').ok_or_else(|| {
            format!("'{s}' is not WL_MEAN:WL_SIGMA (metres of optical path, e.g. 100:100)")
        })?;
        let band = PhasorBand {
            wl_mean_m: parse_metres(mean)?,
            wl_sigma_m: parse_metres(sigma)?,
        };
        band.check()?;
        Ok(band)
    }
}

impl fmt::Display for PhasorBand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}m:{}m", self.wl_mean_m, self.wl_sigma_m)
    }
}

impl Serialize for PhasorBand {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_string())
    }
}

impl<'de> Deserialize<'de> for PhasorBand {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<PhasorBand, D::Error> {
        String::deserialize(d)?
            .parse()
            .map_err(serde::de::Error::custom)
    }
}

/// Pixel `(x, y)`'s phasors at `freqs_per_m`, `[re, im]` each, added into `out`:
/// `g(f) sum_k b_k e^(-2 pi i f (k + 1/2) dt)` over its stored runs (the module doc),
/// the phase advanced bin to bin by one complex rotation (f64: after 10^6 bins the
/// drift is below 1e-9 rad).
fn pixel_phasors(
    snap: &FilmSnapshot,
    x: usize,
    y: usize,
    freqs_per_m: &[f64],
    factors: &[f64],
    out: &mut [[f64; 2]],
) {
    let dt_opl_m = snap.axis().dt_s * C_M_PER_S;
    snap.for_each_run(x, y, |start, values| {
        for ((&f, &g), acc) in freqs_per_m.iter().zip(factors).zip(out.iter_mut()) {
            // Turns at the run's first centre, reduced before the sine for precision.
            let turns = (f * dt_opl_m * (start as f64 + 0.5)).fract();
            let (mut s, mut c) = (-std::f64::consts::TAU * turns).sin_cos();
            let (rs, rc) = (-std::f64::consts::TAU * f * dt_opl_m).sin_cos();
            let (mut re, mut im) = (0.0, 0.0);
            for &v in values {
                let v = f64::from(v);
                re += v * c;
                im += v * s;
                (c, s) = (c * rc - s * rs, c * rs + s * rc);
            }
            acc[0] += g * re;
            acc[1] += g * im;
        }
    });
}

/// The phasors of every pixel of `snap` at `freqs_per_m` (cycles per metre of optical
/// path), float32 `[H, W, F, 2]`, the film's time filter being `filter` (see the module
/// doc for the definition and the bin factor). Refused when the array does not fit in
/// the memory the process may still use.
pub fn phasors(
    snap: &FilmSnapshot,
    freqs_per_m: &[f64],
    filter: TimeFilter,
) -> Result<Vec<f32>, ExportError> {
    let (w, h, nf) = (snap.width(), snap.height(), freqs_per_m.len());
    let len = w * h * nf * 2;
    crate::budget::check(
        (len as u64).saturating_mul(4),
        "the phasor image",
        format_args!("{w} x {h} pixels x {nf} frequencies x 2 float32"),
    )?;
    let dt_opl_m = snap.axis().dt_s * C_M_PER_S;
    let factors: Vec<f64> = freqs_per_m
        .iter()
        .map(|&f| bin_factor(filter, f, dt_opl_m))
        .collect();
    let mut out = vec![0.0f32; len];
    out.par_chunks_mut((w * nf * 2).max(1))
        .enumerate()
        .for_each(|(y, row)| {
            let mut acc = vec![[0.0f64; 2]; nf];
            for (x, px) in row.chunks_mut((nf * 2).max(1)).enumerate() {
                acc.fill([0.0; 2]);
                pixel_phasors(snap, x, y, freqs_per_m, &factors, &mut acc);
                for (o, a) in px.chunks_mut(2).zip(&acc) {
                    o[0] = a[0] as f32;
                    o[1] = a[1] as f32;
                }
            }
        });
    Ok(out)
}

/// One frequency's phasor image, `[H * W]` of `[re, im]` (f64), for a viewer.
pub fn phasor_image(snap: &FilmSnapshot, f_per_m: f64, filter: TimeFilter) -> Vec<[f64; 2]> {
    let (w, h) = (snap.width(), snap.height());
    let factor = [bin_factor(filter, f_per_m, snap.axis().dt_s * C_M_PER_S)];
    let mut out = vec![[0.0f64; 2]; w * h];
    out.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, px) in row.iter_mut().enumerate() {
                pixel_phasors(snap, x, y, &[f_per_m], &factor, std::slice::from_mut(px));
            }
        });
    out
}

/// What `phasor.json` (and `tprf.json`'s `"phasor"`) records.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhasorMetadata {
    /// `phasor.npy`, or `tprf.zarr/phasor`.
    pub file: String,
    /// `float32 [H, W, F, 2] (real, imaginary), row 0 = top`.
    pub layout: String,
    pub definition: String,
    pub from_bins: String,
    /// The film's time filter (`box` or `tent`): which bin factor.
    pub time_filter: TimeFilter,
    /// mitransient's `wl_mean` and `wl_sigma`, metres of optical path.
    pub wl_mean_m: f64,
    pub wl_sigma_m: f64,
    /// The window the frequencies were chosen from: its bins, their width and its
    /// start (the phase origin), metres of optical path.
    pub bins: usize,
    pub bin_width_opl_m: f64,
    pub start_opl_m: f64,
    /// Indices of numpy's `fftfreq(bins, bin_width_opl_m)` kept, first and last.
    pub fft_index_first: usize,
    pub fft_index_last: usize,
    /// The frequencies, cycles per metre of optical path.
    pub frequencies_per_m: Vec<f64>,
    /// The same in Hz (`f c`).
    pub frequencies_hz: Vec<f64>,
    /// Wavelengths `1 / |f|`, metres of optical path; `null` for the DC term.
    pub wavelengths_m: Vec<Option<f64>>,
}

impl PhasorMetadata {
    /// The frequencies `band` picks for a window of `bins` bins of `dt_s` seconds from
    /// `t0_s`, for a film binned with `filter`; the file named for an npy cube
    /// ([`write_phasors`] renames it for Zarr).
    pub fn new(
        band: PhasorBand,
        t0_s: f64,
        dt_s: f64,
        bins: usize,
        filter: TimeFilter,
    ) -> Result<PhasorMetadata, String> {
        let dt_opl_m = dt_s * C_M_PER_S;
        let (lo, hi) = band.index_range(bins, dt_opl_m)?;
        let freqs = band.frequencies_per_m(bins, dt_opl_m)?;
        Ok(PhasorMetadata {
            file: PHASOR_NPY.into(),
            layout: "float32 [H, W, F, 2] (real, imaginary), row 0 = top".into(),
            definition: DEFINITION.into(),
            from_bins: FROM_BINS.into(),
            time_filter: filter,
            wl_mean_m: band.wl_mean_m,
            wl_sigma_m: band.wl_sigma_m,
            bins,
            bin_width_opl_m: dt_opl_m,
            start_opl_m: t0_s * C_M_PER_S,
            fft_index_first: lo,
            fft_index_last: hi,
            frequencies_hz: freqs.iter().map(|f| f * C_M_PER_S).collect(),
            wavelengths_m: freqs
                .iter()
                .map(|f| (*f != 0.0).then(|| 1.0 / f.abs()))
                .collect(),
            frequencies_per_m: freqs,
        })
    }
}

fn zarr_err(path: &Path, e: &dyn fmt::Display) -> ExportError {
    ExportError::Zarr {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Compute `snap`'s phasors at `meta`'s frequencies and write them into render folder
/// `dir`: into its `tprf.zarr` (which must exist) as the array `phasor` when `zarr`,
/// else as `phasor.npy`; then `phasor.json`. Returns the metadata written (its `file`
/// set).
pub fn write_phasors(
    dir: &Path,
    zarr: bool,
    snap: &FilmSnapshot,
    mut meta: PhasorMetadata,
) -> Result<PhasorMetadata, ExportError> {
    let data = phasors(snap, &meta.frequencies_per_m, meta.time_filter)?;
    let shape = [
        snap.height() as u64,
        snap.width() as u64,
        meta.frequencies_per_m.len() as u64,
        2,
    ];
    if zarr {
        let path = dir.join(zarr::ZARR_NAME);
        let err = |e: &dyn fmt::Display| zarr_err(&path, e);
        let store = Arc::new(FilesystemStore::new(&path).map_err(|e| err(&e))?);
        let chunk = vec![ZARR_TILE, ZARR_TILE, shape[2].max(1), 2];
        let mut builder = ArrayBuilder::new(
            shape.to_vec(),
            chunk,
            zarrs::array::data_type::float32(),
            0.0f32,
        );
        builder
            .array_to_bytes_codec(Arc::new(zarrs::array::codec::BytesCodec::little()))
            .bytes_to_bytes_codecs(vec![Arc::new(zarrs::array::codec::ZstdCodec::new(
                zarr::ZSTD_LEVEL,
                false,
            ))])
            .dimension_names(Some(["y", "x", "f", "part"].map(String::from)));
        let array = builder.build(store, ZARR_ARRAY).map_err(|e| err(&e))?;
        array.store_metadata().map_err(|e| err(&e))?;
        let all = ArraySubset::new_with_ranges(&shape.map(|n| 0..n));
        array
            .store_array_subset(&all, data.as_slice())
            .map_err(|e| err(&e))?;
        meta.file = format!("{}/phasor", zarr::ZARR_NAME);
    } else {
        write_npy_f32(&dir.join(PHASOR_NPY), &shape, &data)?;
        meta.file = PHASOR_NPY.into();
    }
    write_json(&dir.join(PHASOR_JSON), &meta)?;
    Ok(meta)
}

/// The phasors of render folder `dir` (`phasor.json` read, then `phasor.npy` or
/// `tprf.zarr`'s array `phasor`), checked to be `[height, width, F, 2]`; `None` when the
/// folder has no `phasor.json`.
pub fn load_phasors(
    dir: &Path,
    width: usize,
    height: usize,
) -> Result<Option<(PhasorMetadata, Vec<f32>)>, ExportError> {
    let json = dir.join(PHASOR_JSON);
    if !json.is_file() {
        return Ok(None);
    }
    let bytes = crate::budget::read_file(&json, "phasor.json").map_err(|e| match e {
        crate::budget::BudgetError::Io { source, .. } => ExportError::Read {
            path: json.clone(),
            source,
        },
        e => e.into(),
    })?;
    let meta: PhasorMetadata =
        serde_json::from_slice(&bytes).map_err(|source| ExportError::PhasorMetadata {
            path: json.clone(),
            source,
        })?;
    let expected = vec![
        height as u64,
        width as u64,
        meta.frequencies_per_m.len() as u64,
        2,
    ];
    let npy = dir.join(PHASOR_NPY);
    let zarr_path = dir.join(zarr::ZARR_NAME);
    let (shape, data, path) = if !npy.exists() && zarr_path.is_dir() {
        let err = |e: &dyn fmt::Display| zarr_err(&zarr_path, e);
        let store = Arc::new(FilesystemStore::new(&zarr_path).map_err(|e| err(&e))?);
        let array = Array::open(store, ZARR_ARRAY)
            .map_err(|e| err(&format!("phasor.json records phasors: {e}")))?;
        if *array.data_type() != zarrs::array::data_type::float32() {
            return Err(err(&"array phasor is not float32"));
        }
        let shape = array.shape().to_vec();
        if shape != expected {
            return Err(ExportError::Shape {
                path: zarr_path.join("phasor"),
                shape,
                layout: "[H, W, F, 2]",
                expected,
            });
        }
        let all = ArraySubset::new_with_ranges(&expected.iter().map(|&n| 0..n).collect::<Vec<_>>());
        let data = array
            .retrieve_array_subset::<Vec<f32>>(&all)
            .map_err(|e| err(&e))?;
        (shape, data, zarr_path.join("phasor"))
    } else {
        let (shape, data) = read_npy_f32(&npy)?;
        (shape, data, npy)
    };
    if shape != expected {
        return Err(ExportError::Shape {
            path,
            shape,
            layout: "[H, W, F, 2]",
            expected,
        });
    }
    Ok(Some((meta, data)))
}

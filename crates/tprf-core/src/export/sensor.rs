//! The files of `tprf sensor`: the cube it reads ([`SensorCube`], measured a tile at a
//! time by [`measure_cube`]) and what it writes ([`write_sensor_outputs`]): the measurement `sensor.npy` `[N, H, W]`, the derived
//! depth images (`depth.*`, `amcw_*`, `true_depth.npy`, `multipath_error.*`), the
//! traces of chosen pixels (`pixel_Y_X.csv`, `pixel_Y_X_gates.csv`) and `sensor.json`,
//! which describes them all.

use std::path::Path;
use std::time::Instant;

use super::ExportError;
use crate::film::FilmError;
use crate::sensor::SensorError;

/// Why `tprf sensor`'s cube could not be read or its files written.
#[derive(Debug, thiserror::Error)]
pub enum SensorFilesError {
    #[error(transparent)]
    Export(#[from] ExportError),
    #[error(transparent)]
    Sensor(#[from] SensorError),
    #[error("cannot read {path}")]
    Read {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: expected t0_s, dt_s and bins")]
    Window {
        path: std::path::PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("{path}")]
    Axis {
        path: std::path::PathBuf,
        #[source]
        source: FilmError,
    },
    /// A cube or a request that does not fit: the message says how.
    #[error("{0}")]
    Invalid(String),
}

type Result<T> = std::result::Result<T, SensorFilesError>;

macro_rules! bail {
    ($($arg:tt)*) => {
        return Err(SensorFilesError::Invalid(format!($($arg)*)))
    };
}

use super::legend::{Legend, LegendError, with_legend};
use super::{NpyBands, NpyF32, write_csv, write_json, write_npy_f32, write_png_rgb};
use crate::film::{TimeAxis, quantile};
use crate::sensor::spad::{Sampler, spad_bytes_per_pixel};
use crate::sensor::{
    AmcwImage, Gates, Measurements, Pipeline, Returns, SensorModel, SpadImage, derived,
};

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
    /// Whether the folder holds an ambient image (its metadata).
    #[serde(default)]
    ambient: Option<super::ambient::AmbientMetadata>,
}

/// A cube `tprf sensor` measures: `tprf.npy` (numpy's form) read a band of rows at a
/// time, or `tprf.zarr` read a tile of pixels at a time, so that a cube larger than
/// memory is measured in memory that follows one tile; or a cube already in memory
/// ([`SensorCube::in_memory`], borrowed for `'a`: Python's `tprf.Cube`).
pub struct SensorCube<'a> {
    /// The render folder (for a cube in memory, the name it is given in messages and
    /// in `sensor.json`).
    pub dir: std::path::PathBuf,
    pub width: usize,
    pub height: usize,
    pub axis: TimeAxis,
    /// The ambient image `[H, W]` (W m^-2 sr^-1) beside the cube, when `tprf.json`
    /// records one ([`super::ambient`]).
    pub ambient: Option<Vec<f32>>,
    form: CubeForm<'a>,
}

enum CubeForm<'a> {
    /// `tprf.npy` `[H, W, T]`, and `tprf_bounces.npy` `[L, H, W, T]` when it is there
    /// with a single-scattering layer (`L >= 3`) and the cube's shape.
    Npy {
        cube: NpyF32,
        bounces: Option<NpyF32>,
    },
    Zarr(Box<super::zarr::ZarrCube>),
    /// `[H, W, T]` in memory, and the bounce layers `[L, H, W, T]` when there are
    /// `L >= 3` of them (with a single-scattering layer).
    Memory {
        cube: &'a [f32],
        bounces: Option<&'a [f32]>,
    },
}

/// The most bytes of cube a tile read from the cube holds by default: 256 MiB (or a
/// quarter of the memory free, if less). One tile is in memory at a time.
pub const DEFAULT_TILE_BYTES: u64 = 256 << 20;

impl<'a> SensorCube<'a> {
    /// A cube in memory, float32 `[H, W, T]` row-major (`height` x `width` pixels on
    /// `axis`), named `name` in messages; `bounces` its per-bounce layers `[L, H, W, T]`
    /// (used, as a folder's `tprf_bounces.npy`, when `L >= 3`: layer 1 is single
    /// scattering, the AMCW reference depth), `ambient` its ambient image `[H, W]`
    /// (W m^-2 sr^-1). Measured by [`measure_cube`] as a folder holding the same
    /// arrays is, bit for bit.
    pub fn in_memory(
        name: &Path,
        (height, width): (usize, usize),
        axis: TimeAxis,
        cube: &'a [f32],
        bounces: Option<&'a [f32]>,
        ambient: Option<Vec<f32>>,
    ) -> Result<SensorCube<'a>> {
        let t = axis.bins;
        super::check_not_empty(name, width, height, t)?;
        let plane = height.saturating_mul(width).saturating_mul(t);
        if cube.len() != plane {
            bail!(
                "{}: {} values, but {height} x {width} pixels x {t} bins = {plane}",
                name.display(),
                cube.len()
            );
        }
        let bounces = bounces.filter(|b| b.len() % plane == 0 && b.len() / plane >= 3);
        if let Some(a) = &ambient
            && a.len() != width * height
        {
            bail!(
                "{}: the ambient image has {} values, not {height} x {width}",
                name.display(),
                a.len()
            );
        }
        Ok(SensorCube {
            dir: name.to_path_buf(),
            width,
            height,
            axis,
            ambient,
            form: CubeForm::Memory { cube, bounces },
        })
    }

    /// Opens the cube of render folder `dir`: `tprf.npy` or, without one, `tprf.zarr`;
    /// either is read tile by tile as it is measured. `tprf.json` needs only the time
    /// window (`t0_s`, `dt_s`, `bins`; `width` and `height` are checked when present), so
    /// `.npy` cubes written by other tools can be measured too.
    pub fn open(dir: &Path) -> Result<SensorCube<'static>> {
        let json_path = dir.join("tprf.json");
        let text = crate::budget::read_file(&json_path, "tprf.json").map_err(|e| match e {
            crate::budget::BudgetError::Io { path, source } => {
                SensorFilesError::Read { path, source }
            }
            e => SensorFilesError::Export(e.into()),
        })?;
        let meta: CubeWindow =
            serde_json::from_slice(&text).map_err(|source| SensorFilesError::Window {
                path: json_path.clone(),
                source,
            })?;
        let axis = TimeAxis::new(meta.t0_s, meta.dt_s, meta.bins).map_err(|source| {
            SensorFilesError::Axis {
                path: json_path.clone(),
                source,
            }
        })?;
        let npy_path = dir.join("tprf.npy");
        let zarr_path = dir.join(super::zarr::ZARR_NAME);
        if !npy_path.exists() && zarr_path.is_dir() {
            let z = super::zarr::ZarrCube::open(&zarr_path)?;
            if z.bins != axis.bins {
                bail!(
                    "{} has {} bins but {} says {}",
                    zarr_path.display(),
                    z.bins,
                    json_path.display(),
                    axis.bins
                );
            }
            let ambient = match meta.ambient {
                Some(_) => super::ambient::load_ambient_image(dir, z.width, z.height)?,
                None => None,
            };
            return Ok(SensorCube {
                dir: dir.to_path_buf(),
                width: z.width,
                height: z.height,
                axis,
                ambient,
                form: CubeForm::Zarr(Box::new(z)),
            });
        }
        let cube = NpyF32::open(&npy_path)?;
        let (h, w, t) = match cube.shape()[..] {
            [h, w, t] => (h as usize, w as usize, t as usize),
            _ => bail!(
                "{} has shape {:?}; expected [H, W, T]",
                npy_path.display(),
                cube.shape()
            ),
        };
        super::check_not_empty(&npy_path, w, h, t)?;
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
        let bounces_path = dir.join("tprf_bounces.npy");
        let bounces = if bounces_path.exists() {
            let b = NpyF32::open(&bounces_path)?;
            let s = b.shape();
            (s.len() == 4 && s[0] >= 3 && s[1..] == [h as u64, w as u64, t as u64]).then_some(b)
        } else {
            None
        };
        let ambient = match meta.ambient {
            Some(_) => super::ambient::load_ambient_image(dir, w, h)?,
            None => None,
        };
        Ok(SensorCube {
            dir: dir.to_path_buf(),
            width: w,
            height: h,
            axis,
            ambient,
            form: CubeForm::Npy { cube, bounces },
        })
    }

    /// Where the cube is read from.
    fn path(&self) -> &Path {
        match &self.form {
            CubeForm::Npy { cube, .. } => cube.path(),
            CubeForm::Zarr(z) => &z.path,
            CubeForm::Memory { .. } => &self.dir,
        }
    }

    /// The tile `(first row, first column, rows, columns)` of the cube (`layer` `None`)
    /// or of bounce layer `l`, `[rows, columns, T]`.
    fn read_tile(
        &self,
        (y0, x0, rows, cols): (usize, usize, usize, usize),
        layer: Option<usize>,
    ) -> Result<Vec<f32>> {
        let t = self.axis.bins;
        match &self.form {
            CubeForm::Zarr(z) => Ok(z.read_tile(y0, x0, rows, cols, layer)?),
            CubeForm::Memory { cube, bounces } => {
                let values = match layer {
                    None => *cube,
                    Some(_) => match bounces {
                        Some(b) => *b,
                        None => bail!("the cube has no single-scattering layer"),
                    },
                };
                let plane = self.width * self.height * t;
                let base = layer.map_or(0, |l| l * plane);
                let mut out = Vec::with_capacity(rows * cols * t);
                for y in y0..y0 + rows {
                    let first = base + (y * self.width + x0) * t;
                    match values.get(first..first + cols * t) {
                        Some(row) => out.extend_from_slice(row),
                        None => bail!("rows {y0}..{} are outside the cube", y0 + rows),
                    }
                }
                Ok(out)
            }
            CubeForm::Npy { cube, bounces } => {
                let npy = match layer {
                    None => cube,
                    Some(_) => match bounces {
                        Some(b) => b,
                        None => bail!("the cube has no single-scattering layer"),
                    },
                };
                let plane = (self.width * self.height * t) as u64;
                let base = layer.map_or(0, |l| l as u64 * plane);
                let mut out = vec![0.0f32; rows * cols * t];
                for (dy, dst) in out.chunks_exact_mut((cols * t).max(1)).enumerate() {
                    let first = base + (((y0 + dy) * self.width + x0) * t) as u64;
                    npy.read(first, dst)?;
                }
                Ok(out)
            }
        }
    }

    /// Whether the cube has a single-scattering layer (layer 1 of the bounce layers).
    fn has_single_layer(&self) -> bool {
        match &self.form {
            CubeForm::Npy { bounces, .. } => bounces.is_some(),
            CubeForm::Zarr(z) => z.layers() >= 3,
            CubeForm::Memory { bounces, .. } => bounces.is_some(),
        }
    }

    /// The tiles the cube is read in, `(first row, first column, rows, columns)`, for
    /// tiles of at most `tile_bytes` (at least one Zarr chunk's pixels, all bins):
    /// whole bands of chunk rows when a band fits, else pieces of one chunk row (for
    /// `tprf.npy`, a chunk is one pixel).
    pub fn tiles(&self, tile_bytes: u64) -> Vec<(usize, usize, usize, usize)> {
        let (w, h) = (self.width, self.height);
        if w == 0 || h == 0 {
            return vec![(0, 0, h, w)];
        }
        let [cy, cx, _] = match self.form {
            CubeForm::Npy { .. } | CubeForm::Memory { .. } => [1, 1, 0],
            CubeForm::Zarr(_) => super::zarr::CHUNK.map(|c| c as usize),
        };
        let pixel_bytes = (self.axis.bins as u64).saturating_mul(4).max(1);
        let fit = usize::try_from(tile_bytes / pixel_bytes).unwrap_or(usize::MAX);
        let (rows, cols) = if fit >= w.saturating_mul(cy) {
            (cy * (fit / (w * cy)), w)
        } else {
            (cy, (cx * (fit / (cy * cx))).max(cx))
        };
        (0..h.div_ceil(rows))
            .flat_map(|ty| {
                (0..w.div_ceil(cols)).map(move |tx| {
                    let (y0, x0) = (ty * rows, tx * cols);
                    (y0, x0, rows.min(h - y0), cols.min(w - x0))
                })
            })
            .collect()
    }
}

/// What measuring a cube yields besides the files' settings: the clean measurements
/// and what the derived files and pixel traces need of the cube, gathered in the same
/// pass over it.
pub struct CubeMeasurement {
    /// `sum_b TPRF[b] K_i[b]`, `[N, H, W]`: no noise, no `max(0, .)`.
    pub measurements: Measurements,
    /// The AMCW depth reference `[H, W]` (metres, NaN: none) and how it was made, when
    /// the sensor asks for AMCW depth.
    pub true_depth: Option<(Vec<f32>, &'static str)>,
    /// The TPRF (`T` bins) of each pixel asked for, in the order asked.
    pub traces: Vec<Vec<f32>>,
    /// The steady image `[H, W]`, `sum_t TPRF[t]` per pixel (summed in f64), when the
    /// sensor has a SPAD (its ambient lamp reads it: [`crate::sensor::spad_image`]).
    pub steady: Option<Vec<f32>>,
    /// Tiles the cube was read in.
    pub tiles: usize,
}

/// Measures `cube` with `model` a tile at a time ([`SensorCube::tiles`] of at most
/// `tile_bytes`, a quarter of the memory free at most): each tile is checked for
/// NaN/infinite bins, measured ([`SensorModel::measure_clean`], so each pixel's result
/// is the one the whole cube gives), and gives its part of the AMCW depth reference and
/// of the traces of `pixels` (row, column; each inside the image), and of the steady
/// image when the sensor has a SPAD. Only one tile of the
/// cube (and of the single-scattering layer, for the AMCW reference of a render with
/// bounce layers) is in memory at a time.
pub fn measure_cube(
    cube: &SensorCube,
    model: &SensorModel,
    pixels: &[(usize, usize)],
    tile_bytes: u64,
) -> Result<CubeMeasurement> {
    let (w, h, axis) = (cube.width, cube.height, cube.axis);
    if model.axis().bins != axis.bins {
        bail!(
            "the sensor was compiled for {} bins; the cube has {}",
            model.axis().bins,
            axis.bins
        );
    }
    for &(y, x) in pixels {
        if y >= h || x >= w {
            bail!("pixel {y},{x} is outside the {h} x {w} image (row, column from 0)");
        }
    }
    let n = model.gate_count();
    let t = axis.bins;
    let amcw = model.wants_amcw();
    let spad = model.sensor().spad.is_some();
    // The whole-image arrays: the measurements, the AMCW reference, the steady image.
    let image_values = (n + usize::from(amcw) + usize::from(spad)) as u64 * (w * h) as u64;
    crate::budget::check(
        image_values.saturating_mul(4),
        "the measurement",
        format_args!("{n} gates of {w} x {h} pixels"),
    )
    .map_err(|e| SensorFilesError::Export(e.into()))?;
    let mut m = Measurements {
        gates: n,
        height: h,
        width: w,
        values: vec![0.0; n * w * h],
    };
    // Layer 1 (single scattering) of the bounce layers, for the AMCW reference.
    let single = amcw && cube.has_single_layer();
    let mut depth = if amcw {
        vec![f32::NAN; w * h]
    } else {
        Vec::new()
    };
    let mut traces = vec![Vec::new(); pixels.len()];
    let mut steady = spad.then(|| vec![0.0f32; w * h]);
    let budget = crate::budget::available()
        .map_or(tile_bytes, |free| tile_bytes.min(free.bytes / 4))
        / if single { 2 } else { 1 };
    let tiles = cube.tiles(budget);
    let first_return = Returns::default();
    for &(y0, x0, rows, cols) in &tiles {
        let tile = cube.read_tile((y0, x0, rows, cols), None)?;
        let tile = &tile[..];
        check_finite(tile, (y0, x0), cols, t, cube.path())?;
        let part = model.measure_clean(tile, cols, rows)?;
        for i in 0..n {
            for (dy, src) in part.plane(i).chunks_exact(cols).enumerate() {
                let at = i * w * h + (y0 + dy) * w + x0;
                m.values[at..at + cols].copy_from_slice(src);
            }
        }
        if amcw {
            let part = if single {
                let layer = cube.read_tile((y0, x0, rows, cols), Some(1))?;
                derived::tprf_centroid_depth(&layer, cols, rows, &axis)
            } else {
                derived::tprf_first_return_depth(tile, cols, rows, &axis, &first_return)
            };
            for (dy, src) in part.chunks_exact(cols).enumerate() {
                let at = (y0 + dy) * w + x0;
                depth[at..at + cols].copy_from_slice(src);
            }
        }
        if let Some(steady) = steady.as_mut() {
            for (dy, row) in tile.chunks_exact(cols * t.max(1)).enumerate() {
                let at = (y0 + dy) * w + x0;
                for (s, px) in steady[at..at + cols]
                    .iter_mut()
                    .zip(row.chunks_exact(t.max(1)))
                {
                    *s = px.iter().map(|&v| f64::from(v)).sum::<f64>() as f32;
                }
            }
        }
        for (trace, &(y, x)) in traces.iter_mut().zip(pixels) {
            if (y0..y0 + rows).contains(&y) && (x0..x0 + cols).contains(&x) {
                let p = ((y - y0) * cols + x - x0) * t;
                trace.extend_from_slice(&tile[p..p + t]);
            }
        }
    }
    let true_depth = amcw.then(|| {
        let how = if single {
            "centroid of the single-scattering layer (layer 1 of the bounce layers)"
        } else {
            "first return of the noise-free TPRF (render with --bounces-separate 1 for the \
             exact single-scattering depth)"
        };
        (depth, how)
    });
    Ok(CubeMeasurement {
        measurements: m,
        true_depth,
        traces,
        steady,
        tiles: tiles.len(),
    })
}

/// Refuse a tile (`cols` pixels wide, its first pixel at `origin` = (row, column) of
/// the image) with a NaN or infinite bin, naming the first: the measurement would carry
/// it into every gate that reads the bin (and `max(0, NaN)` hides it).
fn check_finite(
    tile: &[f32],
    origin: (usize, usize),
    cols: usize,
    bins: usize,
    path: &Path,
) -> Result<()> {
    if let Some(i) = tile.iter().position(|v| !v.is_finite()) {
        let bad = tile.iter().filter(|v| !v.is_finite()).count();
        let (p, b) = (i / bins.max(1), i % bins.max(1));
        let rows = tile.len() / (cols * bins).max(1);
        let (y0, x0) = origin;
        bail!(
            "{}: {bad} bins of rows {y0}..{}, columns {x0}..{} are NaN or infinite, the \
             first at pixel (row {}, column {}), bin {b} ({}); measure a cube without them",
            path.display(),
            y0 + rows,
            x0 + cols,
            y0 + p / cols.max(1),
            x0 + p % cols.max(1),
            tile[i]
        );
    }
    Ok(())
}

/// A measurement made by `tprf sensor`, with what it was made from: everything
/// [`write_sensor_outputs`] writes.
pub struct SensorRun<'a> {
    /// The sensor compiled for the cube's time axis.
    pub model: &'a SensorModel,
    /// The measurements `M_i` (noise included) and what is derived from them: steps 3
    /// to 5 of the sensor's [`crate::sensor::pipeline`].
    pub gates: &'a Gates,
    pub width: usize,
    pub height: usize,
    /// The render folder the cube came from: recorded in `sensor.json`.
    pub cube_dir: &'a Path,
    /// The AMCW depth reference `[H, W]` and how it was made ([`measure_cube`]); needed
    /// when the sensor asks for AMCW depth.
    pub true_depth: Option<&'a (Vec<f32>, &'static str)>,
    /// Pixels (row from the top, column from the left) whose traces are written as CSV,
    /// each with its noise-free TPRF (`T` bins).
    pub pixels: &'a [(usize, usize)],
    pub traces: &'a [Vec<f32>],
    /// Tiles the cube was read in (recorded in `sensor.json`).
    pub tiles: usize,
    /// Seconds spent compiling the kernels, measuring and adding noise.
    pub kernels_s: f64,
    pub measurement_s: f64,
    pub noise_s: f64,
    /// When the run started: `sensor.json`'s total time runs from here to its writing.
    pub started: Instant,
    /// The SPAD's files, when the sensor has a `[spad]` section ([`write_spad_files`],
    /// into the same folder).
    pub spad: Option<&'a SpadFiles>,
    /// The `ambient` entry of `sensor.json` when the cube has an ambient image
    /// ([`super::ambient::sensor_json`]).
    pub ambient: Option<serde_json::Value>,
}

/// The AMCW multipath error `|amcw_depth - true_depth|`, metres (wrapped into half the
/// ambiguity range), over the pixels.
#[derive(Clone, Copy, Debug)]
pub struct MultipathError {
    pub median_abs_m: f64,
    pub p95_abs_m: f64,
    /// The unambiguous range `c / (2 f)`, metres.
    pub ambiguity_m: f64,
}

/// The AMCW multipath error image `[H, W]`: `amcw_depth - true_depth` wrapped into
/// `[-ambiguity/2, ambiguity/2)`, metres, per pixel ([`derived::wrapped_difference`];
/// `multipath_error.npy`).
pub fn multipath_error(amcw: &AmcwImage, true_depth_m: &[f32]) -> Vec<f32> {
    amcw.depth_m
        .iter()
        .zip(true_depth_m)
        .map(|(&d, &r)| {
            derived::wrapped_difference(f64::from(d), f64::from(r), amcw.ambiguity_m) as f32
        })
        .collect()
}

/// What [`write_sensor_outputs`] wrote.
#[derive(Clone, Debug)]
pub struct SensorOutputs {
    /// The names of the files written into the output folder, `sensor.json` included.
    pub files: Vec<String>,
    /// The AMCW depth's error, when the sensor has AMCW gates.
    pub multipath: Option<MultipathError>,
    /// FLIM's lifetime image in numbers, when the sensor asks for it.
    pub flim: Option<FlimSummary>,
}

/// FLIM's lifetime image in numbers: how many pixels measured a decay and the spread of
/// their lifetimes, seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlimSummary {
    pub pixels_with_lifetime: usize,
    pub pixels: usize,
    pub median_s: f64,
    pub p05_s: f64,
    pub p95_s: f64,
    /// The two gates' spacing `dt`, seconds.
    pub gate_spacing_s: f64,
}

/// Writes the files of a `tprf sensor` run into `out` (created if missing; files in it
/// are replaced):
/// - `sensor.npy`: float32 `[N, H, W]`, row 0 = top, the measurements;
/// - with a returns output: `depth.npy` (the first return, `c (t_return - light mean
///   time) / 2`, metres, NaN where no return) and `depth.png`, `depth_strongest.npy`,
///   `depth_last.npy` (`[H, W]`), multi-echo `depth_returns.npy` and
///   `return_intensity.npy` (`[N, H, W]`), `return_count.npy` (uint16 `[H, W]`);
/// - with AMCW gates: `amcw_phase.npy`, `amcw_amplitude.npy`, `amcw_depth.npy`,
///   `true_depth.npy`, `multipath_error.npy` (`[H, W]` each), `amcw_depth.png` and
///   `multipath_error.png`;
/// - with a FLIM lifetime output: `flim_lifetime.npy` (`[H, W]`, seconds, NaN where
///   the first gate is not brighter than the second);
/// - per requested pixel `Y,X`: `pixel_Y_X.csv` and `pixel_Y_X_gates.csv`;
/// - `sensor.json`: the model, the cube's window, the gates and their kernels, the
///   derived outputs, the file list and the timings.
pub fn write_sensor_outputs(out: &Path, run: &SensorRun) -> Result<SensorOutputs> {
    let SensorRun {
        model,
        gates,
        width: w,
        height: h,
        cube_dir,
        true_depth,
        pixels,
        traces,
        ..
    } = *run;
    let m = &gates.m;
    let axis = *model.axis();
    let n = model.gate_count();
    super::create_dir(out)?;
    let mut files = vec!["sensor.npy".to_string(), "sensor.json".to_string()];
    write_npy_f32(
        &out.join("sensor.npy"),
        &[n as u64, h as u64, w as u64],
        &m.values,
    )?;

    let mut derived_json = serde_json::Map::new();
    if let Some(r) = &gates.returns {
        let image = [h as u64, w as u64];
        let echoes = [r.max_returns as u64, h as u64, w as u64];
        let depth = r.first_m();
        write_npy_f32(&out.join("depth.npy"), &image, depth)?;
        write_depth_png(&out.join("depth.png"), w, h, depth)?;
        write_npy_f32(&out.join("depth_strongest.npy"), &image, &r.strongest_m)?;
        write_npy_f32(&out.join("depth_last.npy"), &image, &r.last_m)?;
        write_npy_f32(&out.join("depth_returns.npy"), &echoes, &r.depth_m)?;
        write_npy_f32(&out.join("return_intensity.npy"), &echoes, &r.intensity)?;
        super::write_npy(&out.join("return_count.npy"), &image, &r.count)?;
        files.extend(
            [
                "depth.npy",
                "depth.png",
                "depth_strongest.npy",
                "depth_last.npy",
                "depth_returns.npy",
                "return_intensity.npy",
                "return_count.npy",
            ]
            .map(String::from),
        );
        let found = depth.iter().filter(|d| d.is_finite()).count();
        let several = r.count.iter().filter(|&&c| c > 1).count();
        derived_json.insert(
            "returns".into(),
            serde_json::json!({
                "depth": "first return: c (t_return - light mean time) / 2, metres, \
                          measured from the light's mean emission time; NaN: no return",
                "depth_strongest": "the return of highest intensity, metres",
                "depth_last": "the latest return, metres",
                "depth_returns": "[N, H, W]: up to N returns per pixel, earliest first, \
                                  metres; NaN past a pixel's last",
                "return_intensity": "[N, H, W]: each return's sum of gate values \
                                     (measurement units); 0 past a pixel's last",
                "return_count": "uint16 [H, W]: how many returns each pixel has (also past N)",
                "max_returns": r.max_returns,
                "pixels_with_return": found,
                "pixels_with_several_returns": several,
                "light_mean_s": model.light().mean_s(),
            }),
        );
    }
    let mut multipath = None;
    if let Some(amcw) = &gates.amcw {
        let Some((reference, how)) = true_depth else {
            bail!("the AMCW depth needs its reference depth (measure_cube gives it)");
        };
        let error = multipath_error(amcw, reference);
        let shape = [h as u64, w as u64];
        write_npy_f32(&out.join("amcw_phase.npy"), &shape, &amcw.phase_rad)?;
        write_npy_f32(&out.join("amcw_amplitude.npy"), &shape, &amcw.amplitude)?;
        write_npy_f32(&out.join("amcw_depth.npy"), &shape, &amcw.depth_m)?;
        write_npy_f32(&out.join("true_depth.npy"), &shape, reference)?;
        write_npy_f32(&out.join("multipath_error.npy"), &shape, &error)?;
        write_depth_png(&out.join("amcw_depth.png"), w, h, &amcw.depth_m)?;
        let abs_quantile = |q| quantile(error.iter().map(|e| f64::from(e.abs())), q).unwrap_or(0.0);
        let (median, p95) = (abs_quantile(0.5), abs_quantile(0.95));
        write_signed_png(
            &out.join("multipath_error.png"),
            w,
            h,
            &error,
            abs_quantile(0.99),
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
        multipath = Some(MultipathError {
            median_abs_m: median,
            p95_abs_m: p95,
            ambiguity_m: amcw.ambiguity_m,
        });
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

    let mut flim = None;
    if let Some(tau) = &gates.flim_lifetime_s {
        write_npy_f32(&out.join("flim_lifetime.npy"), &[h as u64, w as u64], tau)?;
        write_lifetime_png(&out.join("flim_lifetime.png"), w, h, tau)?;
        files.extend(["flim_lifetime.npy", "flim_lifetime.png"].map(String::from));
        let finite: Vec<f64> = tau
            .iter()
            .filter(|t| t.is_finite())
            .map(|&t| f64::from(t))
            .collect();
        let q = |q| quantile(finite.iter().copied(), q).unwrap_or(f64::NAN);
        let gate_spacing_s =
            crate::sensor::derived::flim_gate_spacing_s(model.gates()).unwrap_or(f64::NAN);
        let summary = FlimSummary {
            pixels_with_lifetime: finite.len(),
            pixels: tau.len(),
            median_s: q(0.5),
            p05_s: q(0.05),
            p95_s: q(0.95),
            gate_spacing_s,
        };
        derived_json.insert(
            "flim".into(),
            serde_json::json!({
                "lifetime": "tau = dt / ln(M_1 / M_2) from gates 0 and 1 (box gates of \
                             equal width, starts dt apart), seconds; NaN where M_1 <= M_2",
                "gate_spacing_s": gate_spacing_s,
                "pixels_with_lifetime": finite.len(),
                "median_s": quantile(finite.iter().copied(), 0.5),
                "p05_s": quantile(finite.iter().copied(), 0.05),
                "p95_s": quantile(finite.iter().copied(), 0.95),
            }),
        );
        flim = Some(summary);
    }

    if let Some(spad) = run.spad {
        files.extend(spad.files.iter().cloned());
        derived_json.insert("spad".into(), spad_json(model, spad));
    }

    if traces.len() != pixels.len() {
        bail!("{} pixel traces for {} pixels", traces.len(), pixels.len());
    }
    for (&(y, x), tprf) in pixels.iter().zip(traces) {
        if y >= h || x >= w {
            bail!("pixel {y},{x} is outside the {h} x {w} image (row, column from 0)");
        }
        let written = write_pixel_csv(out, model, m, tprf, y, x)?;
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
            "dir": cube_dir.display().to_string(),
            "t0_s": axis.t0_s,
            "dt_s": axis.dt_s,
            "bins": axis.bins,
            "width": w,
            "height": h,
            "tiles_read": run.tiles,
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
        "ambient": run.ambient,
        "files": files,
        "seconds": {
            "kernels": run.kernels_s,
            "measurement": run.measurement_s,
            "noise": run.noise_s,
            "total": run.started.elapsed().as_secs_f64(),
        },
    });
    write_json(&out.join("sensor.json"), &json)?;
    Ok(SensorOutputs {
        files,
        multipath,
        flim,
    })
}

/// What [`write_spad_files`] wrote and found.
#[derive(Clone, Debug)]
pub struct SpadFiles {
    pub bins: usize,
    pub width: usize,
    pub height: usize,
    /// How the realisation was drawn.
    pub sampler: Sampler,
    /// Expected detections summed over the image.
    pub expected_detections: f64,
    /// TDC bin centres in the first cycle, s.
    pub centres_s: Vec<f64>,
    /// Values of `spad_coates.npy` that are NaN (bin never armed).
    pub never_armed: usize,
    /// Pixels with a first return in the expected histogram, the realisation and the
    /// Coates estimate.
    pub pixels_with_return: [usize; 3],
    /// Bands of rows the image was computed and written in.
    pub bands: usize,
    /// The files written.
    pub files: Vec<String>,
    /// Seconds it took.
    pub seconds: f64,
}

/// Step 2 of the sensor's [`crate::sensor::pipeline`] into files: the SPAD of
/// `pipeline` (its clean measurement `[B, H, W]`, before ambient and noise, the steady
/// image and the cube's ambient image; as [`crate::sensor::spad_image_ambient`]):
/// `spad_histogram.npy`, `spad_counts.npy`, `spad_coates.npy` (`[B, H, W]`) and
/// `spad_depth_{histogram,counts,coates}.{npy,png}` (`[H, W]`) into `out`. The image is
/// computed and written a band of rows at a time ([`Pipeline::spad_rows`]), each band's
/// arrays at most `tile_bytes` (and a quarter of the memory free; one row at least): a
/// histogram larger than memory is measured, and the files are byte for byte the same
/// for any band size.
pub fn write_spad_files(out: &Path, pipeline: &Pipeline, tile_bytes: u64) -> Result<SpadFiles> {
    let started = Instant::now();
    let signal = pipeline.clean;
    let (w, h) = (signal.width, signal.height);
    let (sampler, expected_detections) = pipeline.spad_sampler()?;
    let bins = signal.gates;
    let budget =
        crate::budget::available().map_or(tile_bytes, |free| tile_bytes.min(free.bytes / 4));
    let row_bytes = spad_bytes_per_pixel(bins).saturating_mul(w.max(1) as u64);
    let rows = usize::try_from(budget / row_bytes.max(1))
        .unwrap_or(usize::MAX)
        .clamp(1, h.max(1));
    let shape = SpadShape {
        bins,
        width: w,
        height: h,
        sampler,
        expected_detections,
    };
    write_spad_bands(out, &shape, rows, started, |y0, n| {
        Ok(std::borrow::Cow::Owned(pipeline.spad_rows(sampler, y0, n)?))
    })
}

/// [`write_spad_files`]'s files from a SPAD image already computed whole
/// ([`Pipeline::spad_rows`] over every row, which the bands of `write_spad_files` equal
/// bit for bit), drawn by `sampler` with `expected_detections` over the image
/// ([`Pipeline::spad_sampler`]): the same files, byte for byte, written in one band.
pub fn write_spad_image(
    out: &Path,
    image: &SpadImage,
    sampler: Sampler,
    expected_detections: f64,
) -> Result<SpadFiles> {
    let shape = SpadShape {
        bins: image.bins,
        width: image.width,
        height: image.height,
        sampler,
        expected_detections,
    };
    let n = image.width * image.height;
    if image.histogram.len() != image.bins * n
        || image.counts.len() != image.bins * n
        || image.coates.len() != image.bins * n
        || [
            &image.depth_histogram_m,
            &image.depth_counts_m,
            &image.depth_coates_m,
        ]
        .iter()
        .any(|d| d.len() != n)
    {
        bail!(
            "the SPAD image's arrays do not hold {} bins of {} x {} pixels",
            image.bins,
            image.height,
            image.width
        );
    }
    write_spad_bands(out, &shape, image.height.max(1), Instant::now(), |_, _| {
        Ok(std::borrow::Cow::Borrowed(image))
    })
}

/// What the SPAD's files describe besides the arrays.
struct SpadShape {
    bins: usize,
    width: usize,
    height: usize,
    sampler: Sampler,
    expected_detections: f64,
}

/// The SPAD's files, `band(y0, n)` giving rows `y0 .. y0 + n` of the image, taken
/// `rows` at a time.
fn write_spad_bands<'b>(
    out: &Path,
    shape: &SpadShape,
    rows: usize,
    started: Instant,
    mut band_of: impl FnMut(usize, usize) -> Result<std::borrow::Cow<'b, SpadImage>>,
) -> Result<SpadFiles> {
    let SpadShape {
        bins,
        width: w,
        height: h,
        sampler,
        expected_detections,
    } = *shape;
    super::create_dir(out)?;
    let npy_shape = [bins as u64, h as u64, w as u64];
    let names = ["spad_histogram.npy", "spad_counts.npy", "spad_coates.npy"];
    let mut arrays = [
        NpyBands::create(&out.join(names[0]), npy_shape)?,
        NpyBands::create(&out.join(names[1]), npy_shape)?,
        NpyBands::create(&out.join(names[2]), npy_shape)?,
    ];
    let mut depths = [
        vec![f32::NAN; w * h],
        vec![f32::NAN; w * h],
        vec![f32::NAN; w * h],
    ];
    let (mut never_armed, mut bands, mut centres_s) = (0, 0, Vec::new());
    for y0 in (0..h).step_by(rows.max(1)) {
        let n = rows.min(h - y0);
        let band = band_of(y0, n)?;
        for (file, values) in arrays
            .iter_mut()
            .zip([&band.histogram, &band.counts, &band.coates])
        {
            file.write_rows(y0, n, values)?;
        }
        for (all, part) in depths.iter_mut().zip([
            &band.depth_histogram_m,
            &band.depth_counts_m,
            &band.depth_coates_m,
        ]) {
            all[y0 * w..(y0 + n) * w].copy_from_slice(part);
        }
        never_armed += band.coates.iter().filter(|v| v.is_nan()).count();
        bands += 1;
        centres_s.clone_from(&band.centres_s);
    }
    for file in arrays {
        file.finish()?;
    }
    let mut files: Vec<String> = names.map(String::from).to_vec();
    let mut pixels_with_return = [0; 3];
    for ((name, depth), found) in ["histogram", "counts", "coates"]
        .iter()
        .zip(&depths)
        .zip(&mut pixels_with_return)
    {
        let npy = format!("spad_depth_{name}.npy");
        let png = format!("spad_depth_{name}.png");
        write_npy_f32(&out.join(&npy), &[h as u64, w as u64], depth)?;
        write_depth_png(&out.join(&png), w, h, depth)?;
        *found = depth.iter().filter(|d| d.is_finite()).count();
        files.extend([npy, png]);
    }
    Ok(SpadFiles {
        bins,
        width: w,
        height: h,
        sampler,
        expected_detections,
        centres_s,
        never_armed,
        pixels_with_return,
        bands,
        files,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The SPAD's entry in `sensor.json`: every parameter with its unit, what the files
/// hold, how the realisation was drawn.
fn spad_json(model: &SensorModel, spad: &SpadFiles) -> serde_json::Value {
    let sensor = model.sensor();
    let p = sensor.spad.clone().unwrap_or_default();
    let (cycle_s, sigma_s) = sensor.exposure.tdc_cycle_s().unwrap_or((0.0, 0.0));
    let bin_width_s = cycle_s / spad.bins.max(1) as f64;
    let never_armed = spad.never_armed;
    let dead = crate::sensor::spad::Detector::new(&p, spad.bins, bin_width_s).ok();
    serde_json::json!({
        "model": "per cycle, events in TDC bin k ~ Poisson(r_k), r_k = pde (photons_per_unit \
                  S_k + ambient photons/s x bin width) + dark_count_rate x bin width, S_k the \
                  pixel's (TPRF * Light) in bin k after the jitter, folded into the cycle; \
                  the SPAD fires on the first event of a bin while armed, is then dead \
                  for the rest of that bin and dead_time_s more (dead_bins whole bins and \
                  the first dead_fraction of the next), and may afterpulse (docs/sensor.md)",
        "parameters": {
            "cycles": {"value": p.cycles, "unit": "laser cycles"},
            "pde": {"value": p.pde, "unit": "probability"},
            "photons_per_unit": {"value": p.photons_per_unit, "unit": "photons per W m^-2 sr^-1 s at the pixel (radiance x seconds: the unit of (TPRF * Light) for a light of its energy in J)"},
            "ambient_rate_hz": {"value": p.ambient_rate_hz, "unit": "photons/s per pixel (before the PDE)"},
            "ambient_lamp_hz": {"value": p.ambient_lamp_hz, "unit": "1/s: a steady lamp where the light is, in pulse energies per second"},
            "dark_count_rate_hz": {"value": p.dark_count_rate_hz, "unit": "counts/s"},
            "dead_time_s": {"value": p.dead_time_s, "unit": "s"},
            "dead_bins": {"value": dead.as_ref().map_or(0, |d| d.dead_bins), "unit": "whole TDC bins dead after the bin of a detection"},
            "dead_fraction": {"value": dead.as_ref().map_or(0.0, |d| d.dead_fraction), "unit": "fraction of the next bin still dead (dead_time_s / bin width = dead_bins + dead_fraction)"},
            "mode": {"value": p.mode, "unit": "synchronous: armed afresh each cycle; free_running: never reset"},
            "afterpulse_probability": {"value": p.afterpulse_probability, "unit": "probability per detection"},
            "afterpulse_delay_s": {"value": p.afterpulse_delay_s, "unit": "s (mean of an exponential)"},
            "tdc_bins": {"value": spad.bins, "unit": "bins"},
            "tdc_bin_width_s": {"value": bin_width_s, "unit": "s"},
            "cycle_s": {"value": cycle_s, "unit": "s (bins x bin width; the laser period)"},
            "jitter_sigma_s": {"value": sigma_s, "unit": "s (Gaussian standard deviation)"},
            "seed": {"value": sensor.noise.seed, "unit": "seed of the realisation (noise.seed)"},
        },
        "tdc_bin_centres_s": [spad.centres_s.first(), spad.centres_s.last()],
        "spad_histogram": "expected counts over all cycles, float32 [B, H, W]",
        "spad_counts": "one seeded realisation, float32 [B, H, W]",
        "spad_coates": "Coates estimate N r_k of spad_counts (counts without pile-up); NaN: bin never armed",
        "sampler": spad.sampler.name(),
        "expected_detections": spad.expected_detections,
        "coates_bins_never_armed": never_armed,
        "depth": "first return after removing the median bin (the background), c (t - light mean time) / 2, metres; NaN: none",
        "pixels_with_return": {
            "histogram": spad.pixels_with_return[0],
            "counts": spad.pixels_with_return[1],
            "coates": spad.pixels_with_return[2],
        },
        "bands": {"value": spad.bands, "unit": "bands of rows computed and written one at a time"},
        "seconds": spad.seconds,
    })
}

/// A depth image as grey PNG, linear in depth from the 1 % to the 99 % quantile:
/// nearest white, farthest dark grey, no depth black; with its scale under it
/// ([`with_legend`]).
fn write_depth_png(path: &Path, w: usize, h: usize, depth: &[f32]) -> Result<()> {
    let values = || depth.iter().map(|&d| f64::from(d));
    let (lo, hi) = (
        quantile(values(), 0.01).unwrap_or(0.0),
        quantile(values(), 0.99).unwrap_or(0.0),
    );
    let span = (hi - lo).max(1e-12);
    // t = 0 nearest (white), 1 farthest (dark grey).
    let grey = |t: f64| {
        let g = (255.0 * (0.15 + 0.85 * (1.0 - t.clamp(0.0, 1.0)))).round() as u8;
        [g, g, g]
    };
    let mut rgb = Vec::with_capacity(3 * depth.len());
    for &d in depth {
        rgb.extend(if d.is_finite() {
            grey((f64::from(d) - lo) / span)
        } else {
            [0, 0, 0]
        });
    }
    let scale = Legend {
        ramp: &grey,
        lo,
        hi: lo + span,
        log: false,
        unit: "m",
        note: "depth; black: no return",
    };
    let (rgb, cw, ch) = with_legend(rgb, w, h, &scale).map_err(legend_error)?;
    Ok(write_png_rgb(path, cw, ch, rgb)?)
}

/// A lifetime image (seconds) as grey PNG, linear from 0 (dark grey) to the 99 %
/// quantile (white), saturating; no decay black; its scale in ns under it
/// ([`with_legend`]).
fn write_lifetime_png(path: &Path, w: usize, h: usize, tau_s: &[f32]) -> Result<()> {
    let top_ns = 1e9 * quantile(tau_s.iter().map(|&t| f64::from(t)), 0.99).unwrap_or(0.0);
    let top_ns = top_ns.max(1e-9);
    let grey = |t: f64| {
        let g = (255.0 * (0.15 + 0.85 * t.clamp(0.0, 1.0))).round() as u8;
        [g, g, g]
    };
    let mut rgb = Vec::with_capacity(3 * tau_s.len());
    for &t in tau_s {
        rgb.extend(if t.is_finite() {
            grey(1e9 * f64::from(t) / top_ns)
        } else {
            [0, 0, 0]
        });
    }
    let scale = Legend {
        ramp: &grey,
        lo: 0.0,
        hi: top_ns,
        log: false,
        unit: "ns",
        note: "FLIM lifetime; black: no decay",
    };
    let (rgb, cw, ch) = with_legend(rgb, w, h, &scale).map_err(legend_error)?;
    Ok(write_png_rgb(path, cw, ch, rgb)?)
}

/// A signed image as PNG: blue below 0, white at 0, red above, saturating at
/// `+- scale`; NaN black; with its scale under it ([`with_legend`]).
fn write_signed_png(path: &Path, w: usize, h: usize, values: &[f32], scale: f64) -> Result<()> {
    let scale = scale.max(1e-300);
    // t = 0 at -scale, 1/2 at 0, 1 at +scale.
    let colour = |t: f64| {
        let t = (2.0 * t - 1.0).clamp(-1.0, 1.0);
        let fade = (255.0 * (1.0 - t.abs())).round() as u8;
        if t < 0.0 {
            [fade, fade, 255]
        } else {
            [255, fade, fade]
        }
    };
    let mut rgb = Vec::with_capacity(3 * values.len());
    for &v in values {
        rgb.extend(if v.is_finite() {
            colour(0.5 + 0.5 * f64::from(v) / scale)
        } else {
            [0, 0, 0]
        });
    }
    let bar = Legend {
        ramp: &colour,
        lo: -scale,
        hi: scale,
        log: false,
        unit: "m",
        note: "AMCW depth - true depth; black: none",
    };
    let (rgb, cw, ch) = with_legend(rgb, w, h, &bar).map_err(legend_error)?;
    Ok(write_png_rgb(path, cw, ch, rgb)?)
}

/// A legend that could not be drawn, as the sensor files' error.
fn legend_error(e: LegendError) -> SensorFilesError {
    match e {
        LegendError::Budget(b) => SensorFilesError::Export(ExportError::from(b)),
        LegendError::Draw(why) => SensorFilesError::Invalid(why),
    }
}

/// `pixel_Y_X.csv` (per bin: time, TPRF, TPRF * Light, each gate's share of M_i) and
/// `pixel_Y_X_gates.csv` (per gate: centre, M_i before and after noise); returns the
/// two file names.
fn write_pixel_csv(
    out: &Path,
    model: &SensorModel,
    m: &Measurements,
    tprf: &[f32],
    y: usize,
    x: usize,
) -> Result<Vec<String>> {
    let axis = *model.axis();
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
    write_csv(&out.join(&name), &header, rows)?;

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
    write_csv(&out.join(&gates_name), &header, rows)?;
    Ok(vec![name, gates_name])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2 x 1 depth image (1 m, 3 m): enlarged by 180 to 360 pixels wide, nearest
    /// white and farthest dark grey (0.15 x 255), over a strip whose bar runs from the
    /// same white to the same grey, with its labels written in dark pixels.
    #[test]
    fn a_depth_png_carries_its_scale() {
        let dir = std::env::temp_dir().join(format!("tprf-depth-png-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("depth.png");
        write_depth_png(&path, 2, 1, &[1.0, 3.0]).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(
            img.dimensions(),
            (360, 180 + super::super::legend::LEGEND_H as u32)
        );
        let far = (255.0f64 * 0.15).round() as u8;
        assert_eq!(img.get_pixel(0, 0).0, [255; 3]);
        assert_eq!(img.get_pixel(179, 179).0, [255; 3]);
        assert_eq!(img.get_pixel(180, 0).0, [far; 3]);
        assert_eq!(img.get_pixel(12, 190).0, [255; 3]);
        assert_eq!(img.get_pixel(347, 190).0, [far; 3]);
        let text = (203..236)
            .flat_map(|y| (0..360).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y).0[0] < 128)
            .count();
        assert!(text > 100, "labels: {text} dark pixels");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

//! Exports: the cube as `.npy` with JSON metadata, tone-mapped PNGs (steady image and
//! time-slice frames). Every file is written to a temporary name and renamed, so an
//! existing file is replaced atomically and a failed write loses nothing.

use crate::film::{
    DENSE_BAND_VALUES, FilmError, FilmLayout, FilmSnapshot, LeftOutCounts, StoreStats, TimeAxis,
};
use bulk_file::BulkFile;
pub use npy_read::NpyF32;
use npyz::WriterBuilder;
use serde::{Deserialize, Serialize};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

pub mod ambient;
pub mod bulk_file;
pub mod legend;
mod npy_read;
pub mod phasor;
pub mod sensor;
pub mod shard;
pub mod staging;
pub mod zarr;

/// Why a file could not be written or read. Messages name the file; the cause (an I/O,
/// JSON or image error) is the [`std::error::Error::source`].
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("cannot create {path}")]
    Create {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("writing {path}")]
    Write {
        path: PathBuf,
        #[source]
        source: WriteError,
    },
    #[error("cannot rename {from} to {to}")]
    Rename {
        from: PathBuf,
        to: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// An output folder tprf may not replace ([`staging::check_target`]): `why` says
    /// what is there and how to proceed.
    #[error("{path}: {why}")]
    OutRefused { path: PathBuf, why: String },
    /// The output folder changed while the command ran so that it may no longer be
    /// replaced; the new output was kept beside it, at `kept`.
    #[error("the new output is kept in {kept} instead of {path}")]
    OutChanged {
        path: PathBuf,
        kept: PathBuf,
        #[source]
        source: Box<ExportError>,
    },
    #[error("cannot read {path}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("the cube needs its metadata {path}")]
    NoMetadata {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path} is not tprf.json metadata")]
    Metadata {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("{path} is not phasor.json metadata")]
    PhasorMetadata {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("{path}: its time axis is invalid")]
    Axis {
        path: PathBuf,
        #[source]
        source: FilmError,
    },
    #[error("{path} is not a .npy file")]
    NotNpy {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: Fortran-order arrays are not supported")]
    FortranOrder { path: PathBuf },
    #[error("{path}: expected float32 data")]
    NotF32 {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: shape {shape:?} does not match its metadata {layout} = {expected:?}")]
    Shape {
        path: PathBuf,
        shape: Vec<u64>,
        /// The axes' names: `[H, W, T]`, `[layers, H, W, T]`.
        layout: &'static str,
        expected: Vec<u64>,
    },
    #[error("{path}: {message}")]
    Zarr { path: PathBuf, message: String },
    #[error("{path}: the cube is {width} x {height} pixels x {bins} bins: there is nothing in it")]
    Empty {
        path: PathBuf,
        width: usize,
        height: usize,
        bins: usize,
    },
    #[error(
        "{path}: its header's shape {shape:?} needs {need_bytes} bytes of data, the file has {have_bytes}"
    )]
    Truncated {
        path: PathBuf,
        shape: Vec<u64>,
        need_bytes: u64,
        have_bytes: u64,
    },
    /// Too large for the memory left, or not a regular file.
    #[error(transparent)]
    Budget(#[from] crate::budget::BudgetError),
    #[error("{bytes} bytes do not make a {width} x {height} image of {channels} channel(s)")]
    ImageSize {
        width: usize,
        height: usize,
        channels: usize,
        bytes: usize,
    },
}

/// What the writer given to [`write_atomic`] may fail with: any error (`?` converts).
pub type WriteError = Box<dyn std::error::Error + Send + Sync>;

/// Everything `tprf.json` records about a cube.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CubeMetadata {
    pub format: String,
    pub t0_s: f64,
    pub dt_s: f64,
    pub bins: usize,
    pub width: usize,
    pub height: usize,
    pub spp: u64,
    pub seed: u64,
    pub c_m_per_s: f64,
    /// The band the one-channel cube records.
    pub channel: String,
    /// What a bin holds.
    pub value: String,
    pub scene: String,
    pub camera: CameraMetadata,
    /// When the pulse starts: `light` (it leaves the light at t = 0) or `first-hit`
    /// (it is at the first surface it lights at t = 0: the light's leg left out). Older
    /// files, which hold none: `light`.
    #[serde(default = "light")]
    pub pulse_origin: String,
    pub max_bounces: u32,
    /// Fewest scattering events of a recorded path (0: every path). Older files: 0.
    #[serde(default)]
    pub min_bounces: u32,
    /// Per-bounce layers in `tprf_bounces.npy` (0 = none): layer 0 = light seen directly,
    /// 1..=K = that many scattering events, K+1 = more.
    pub bounces_separate: u32,
    /// Whether `tprf_bounces.npy` has one more layer after those, K+2: the light
    /// re-emitted by a luminescent surface (the others then hold the rest). Older
    /// files: false.
    #[serde(default)]
    pub luminescence_layer: bool,
    pub threads: usize,
    /// Wall time of the render, seconds (scene loading and writing included).
    pub wall_seconds: f64,
    /// Time inside render passes, seconds.
    #[serde(default)]
    pub render_seconds: f64,
    pub rays_traced: u64,
    /// Camera samples traced.
    pub paths_traced: u64,
    /// Branches of each camera sample at its first scattering vertex
    /// (`RenderSettings::first_bounce_splits`, as the pilot chose it); 0 in files
    /// written before it was recorded.
    #[serde(default)]
    pub first_bounce_splits: u32,
    /// Whether eye vertices were joined to light vertices found from the punctual
    /// lights (`RenderSettings::light_vertex`, as the pilot chose it); false in files
    /// written before it was recorded.
    #[serde(default)]
    pub light_vertex: bool,
    /// Whether pixels drew samples in proportion to their noise
    /// (`RenderSettings::adaptive`); false in files written before it was recorded.
    #[serde(default)]
    pub adaptive: bool,
    /// Error of the cube estimated from two independent halves of the samples (relative
    /// RMS), when both halves have samples.
    pub error_estimate: Option<f64>,
    /// Work left out because its light could not arrive inside the window.
    #[serde(default)]
    pub left_out: LeftOutCounts,
    /// Bins and bytes the film stored, against a dense cube.
    #[serde(default)]
    pub store: StoreStats,
    /// Render passes made.
    #[serde(default, deserialize_with = "pass_count")]
    pub passes: u64,
    /// The ambient image beside the cube (`ambient.npy` or `tprf.zarr/ambient`), when the
    /// scene has an ambient light group.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ambient: Option<ambient::AmbientMetadata>,
    /// The participating media the light crossed: the scene-wide medium (`region`
    /// "scene") and those filling closed meshes (`region` "material 'NAME'"); empty
    /// (and not written) for a scene in vacuum.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub media: Vec<MediumMetadata>,
    pub notes: Vec<String>,
    /// Only in a shard's folder (`tprf render --shard K/N`): which part of the render it
    /// holds, and what `tprf merge` needs to check and merge it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<shard::ShardInfo>,
    /// Only when the render stopped before its target: why (its next pass would not
    /// have fitted in memory); the cube holds the passes made, whole.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped: Option<RenderStopped>,
    /// Only when phasors were asked for (`phasor`, or a Mitsuba `phasor_hdr_film`):
    /// `phasor.npy` or `tprf.zarr/phasor` and its frequencies ([`phasor`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phasor: Option<phasor::PhasorMetadata>,
    /// Whether the render was polarized (the request's `polarized`): `tprf.npy` is then
    /// S0 and `stokes` names the Stokes cube. Older files: false.
    #[serde(default)]
    pub polarized: bool,
    /// A polarized render's Stokes cube ([`StokesMetadata`]); `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stokes: Option<StokesMetadata>,
    /// Only in a render of several bands (`wavelengths`): `tprf_spectral.npy`, its
    /// wavelengths and what `tprf.npy` holds ([`SpectralMetadata`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spectral: Option<SpectralMetadata>,
    /// The request that made the render (`tprf render`'s options, as a batch manifest's
    /// `[[job]]` keys: [`crate::request::RenderRequest`], every field written, its
    /// defaults included), when one did: enough to render the cube again. Older files
    /// hold none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub request: Option<serde_json::Value>,
}

/// A render of several bands, as `tprf.json` records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpectralMetadata {
    /// `tprf_spectral.npy`: float32 `[L, H, W, T]`, band k at `wavelengths_nm[k]`.
    pub file: String,
    /// The bands' wavelengths, nm, in the order asked (the file's first axis).
    pub wavelengths_nm: Vec<f64>,
    /// What `tprf.npy` holds: `luminance`, or the band's name (`550nm`) when the
    /// request's channel is one of the wavelengths.
    pub tprf_npy: String,
    /// Each band's weight in the luminance (in the order of `wavelengths_nm`), and the
    /// rule that made them.
    pub luminance_weights: Vec<f64>,
    pub luminance: String,
    /// Samples per pixel each band reached.
    pub spp: Vec<u64>,
}

/// Write snapshots of one shape as one float32 C-order `.npy` `[L, H, W, T]`, plane k
/// the total of `snaps[k]`, a row at a time as [`write_snapshot_npy`] (holes where no
/// light arrived).
pub fn write_snapshots_npy(path: &Path, snaps: &[&FilmSnapshot]) -> Result<(), ExportError> {
    let Some(first) = snaps.first() else {
        return write_npy_f32(path, &[0, 0, 0, 0], &[]);
    };
    let (w, h, t) = (first.width(), first.height(), first.axis().bins);
    let shape = [snaps.len() as u64, h as u64, w as u64, t as u64];
    write_atomic_bulk(path, |out| {
        let sparse = npyz::WriteOptions::<f32>::new()
            .default_dtype()
            .shape(&shape)
            .writer(&mut *out)
            .write_header_only()?;
        let (mut row, mut bytes) = (Vec::new(), Vec::new());
        for snap in snaps {
            for y in 0..h {
                snap.row_dense(y, None, &mut row);
                row.resize(w * t, 0.0);
                bytes.clear();
                bytes.extend(row.iter().flat_map(|v| v.to_le_bytes()));
                sparse.write_all(&bytes)?;
            }
        }
        Ok(())
    })
}

/// Why a render stopped before its target, as `tprf.json` records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderStopped {
    /// `memory`: the next pass would have taken the film over its memory budget.
    pub reason: String,
    /// What happened, in words: the spp reached, the memory foreseen, the limit.
    pub message: String,
    /// The samples per pixel asked for, when the request set a target.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spp_target: Option<u64>,
    /// The limit, bytes, and what set it (`max_memory`, `system`, `cgroup`,
    /// `address_space`, `data_segment`).
    pub limit_bytes: u64,
    pub limited_by: String,
}

/// `passes` as a count; cubes written before it was summarised list one record per pass.
fn pass_count<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<u64, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Passes {
        Count(u64),
        List(Vec<serde::de::IgnoredAny>),
    }
    Ok(match Passes::deserialize(d)? {
        Passes::Count(n) => n,
        Passes::List(l) => l.len() as u64,
    })
}

/// A participating medium as written to metadata (scene::Medium's fields).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MediumMetadata {
    /// Where it is: `scene` (around everything) or `material 'NAME'` (inside the meshes
    /// of that material).
    pub region: String,
    /// Scattering coefficient per channel (linear RGB), 1/m.
    pub sigma_s_per_m: [f32; 3],
    /// Absorption coefficient per channel, 1/m.
    pub sigma_a_per_m: [f32; 3],
    /// Henyey-Greenstein asymmetry.
    pub g: f32,
    /// Refractive index: light travels at c / n in it.
    pub n: f32,
    /// A heterogeneous medium's density grid (the coefficients above are at density 1):
    /// its file and size, not its values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density: Option<DensityMetadata>,
}

/// A density grid as written to metadata.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DensityMetadata {
    /// The `.vol` file it was read from; absent for a grid given inline.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Samples along x, y, z.
    pub dims: [u32; 3],
    /// The box, world metres.
    pub bbox_min_m: [f32; 3],
    pub bbox_max_m: [f32; 3],
    /// The largest density.
    pub max: f32,
}

/// The camera as written to metadata.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CameraMetadata {
    pub position_m: [f32; 3],
    /// Column-major 4x4 `world_from_camera` (camera looks along its -Z, +Y up).
    pub world_from_camera: [f32; 16],
    /// Vertical field of view of this cube's image, degrees.
    pub yfov_deg: f32,
    /// Where each pixel's arrival times start: `pinhole`, `near-plane` (from the near
    /// clip plane `near_m` in front of the pinhole, along each ray) or `first-hit` (the
    /// camera's leg left out). Older files, which hold none: `pinhole`.
    #[serde(default = "pinhole")]
    pub time_origin: String,
    /// The near clip plane's distance, metres (with `near-plane`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub near_m: Option<f32>,
}

fn light() -> String {
    "light".into()
}

fn pinhole() -> String {
    "pinhole".into()
}

/// Where a polarized render's Stokes cube is and how to read it (docs/polarization.md).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StokesMetadata {
    /// The file: `tprf_stokes.npy`, float32 `[4, H, W, T]`, S0 S1 S2 S3 (S0 = `tprf.npy`).
    pub file: String,
    /// The frame the Stokes vectors are in.
    pub frame: String,
}

impl StokesMetadata {
    /// The Stokes cube of `tprf render --polarized`.
    pub fn npy() -> StokesMetadata {
        StokesMetadata {
            file: STOKES_NPY.into(),
            frame: "camera: x = ray x camera up (the image's x axis at the centre), y = \
                    forward x x; S1 > 0 polarized along the image's x axis, S3 > 0 right \
                    circular (Mitsuba 3's conventions, as mitransient's stokes integrator)"
                .into(),
        }
    }
}

/// A polarized render's Stokes cube, float32 `[4, H, W, T]`.
pub const STOKES_NPY: &str = "tprf_stokes.npy";

impl CubeMetadata {
    /// The cube's time axis, checked ([`TimeAxis::new`]).
    pub fn axis(&self) -> Result<TimeAxis, FilmError> {
        TimeAxis::new(self.t0_s, self.dt_s, self.bins)
    }

    /// Refuse a cube without pixels or bins (read from `path`): every reader divides by
    /// its sides or walks it in rows.
    pub fn check_not_empty(&self, path: &Path) -> Result<(), ExportError> {
        check_not_empty(path, self.width, self.height, self.bins)
    }
}

/// Refuse a cube of `width x height` pixels x `bins` bins (read from `path`) with nothing
/// in it.
pub fn check_not_empty(
    path: &Path,
    width: usize,
    height: usize,
    bins: usize,
) -> Result<(), ExportError> {
    if width == 0 || height == 0 || bins == 0 {
        return Err(ExportError::Empty {
            path: path.to_path_buf(),
            width,
            height,
            bins,
        });
    }
    Ok(())
}

/// What a bin holds, in words (DESIGN.md conventions).
pub const BIN_VALUE: &str = "integral over the bin of the pixel's radiance (W m^-2 sr^-1 s) for a \
unit-energy pulse emitted at t = 0; the sum over bins is the steady-state radiance (W m^-2 sr^-1) \
for unit emitted power";

fn temp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Write `path` through `write` into a temporary file (`NAME.tmp` beside it), then rename
/// over `path`; on failure the temporary file is removed and `path` is untouched.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), WriteError>,
) -> Result<(), ExportError> {
    through_temp(
        path,
        |p| File::create(p),
        |file| {
            let mut w = BufWriter::new(file);
            write(&mut w)?;
            w.flush()?;
            w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
            Ok(())
        },
    )
}

/// [`write_atomic`] for a large file written front to back through a [`BulkFile`]
/// (`O_DIRECT` where allowed, all-zero chunks left as holes).
pub fn write_atomic_bulk(
    path: &Path,
    write: impl FnOnce(&mut BulkFile) -> Result<(), WriteError>,
) -> Result<(), ExportError> {
    through_temp(path, BulkFile::create, |mut file| {
        write(&mut file)?;
        file.finish()?;
        Ok(())
    })
}

/// The temporary file beside `path` made by `create`, filled (and synced) by `fill`,
/// renamed over `path`; removed on any failure, `path` untouched.
fn through_temp<F>(
    path: &Path,
    create: impl FnOnce(&Path) -> std::io::Result<F>,
    fill: impl FnOnce(F) -> Result<(), WriteError>,
) -> Result<(), ExportError> {
    // A file is replaced only by a file: never a folder, a device, a FIFO, a socket, nor
    // a symbolic link (the rename would replace the link, not what it points to).
    if let Ok(meta) = std::fs::symlink_metadata(path)
        && !meta.is_file()
    {
        let what = if meta.is_dir() {
            "a folder"
        } else if meta.file_type().is_symlink() {
            "a symbolic link"
        } else {
            "not a regular file (a device, FIFO or socket)"
        };
        return Err(ExportError::OutRefused {
            path: path.to_path_buf(),
            why: format!("is {what}: tprf replaces only a regular file here; choose another name"),
        });
    }
    let tmp = temp_path(path);
    let result = (|| {
        let file = create(&tmp).map_err(|source| ExportError::Create {
            // The file asked for, not the temporary name a user never chose (a missing
            // folder reads "cannot create out/x.png: No such file or directory").
            path: path.to_path_buf(),
            source,
        })?;
        fill(file).map_err(|source| ExportError::Write {
            path: path.to_path_buf(),
            source,
        })?;
        std::fs::rename(&tmp, path).map_err(|source| ExportError::Rename {
            from: tmp.clone(),
            to: path.to_path_buf(),
            source,
        })
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Create folder `dir` and its parents (nothing if it exists).
pub fn create_dir(dir: &Path) -> Result<(), ExportError> {
    std::fs::create_dir_all(dir).map_err(|source| ExportError::Create {
        path: dir.to_path_buf(),
        source,
    })
}

/// Bytes of a float32 `.npy` file of `shape` (its data; the header adds under 1 KiB).
pub fn npy_f32_bytes(shape: &[u64]) -> u64 {
    shape.iter().fold(4u64, |acc, &d| acc.saturating_mul(d))
}

/// Space free for an unprivileged writer on the file system holding `dir`, bytes;
/// `None` where it cannot be told.
pub fn disk_free_bytes(dir: &Path) -> Option<u64> {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let c = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
        let mut st = std::mem::MaybeUninit::<libc::statvfs>::uninit();
        // SAFETY: `c` is a valid NUL-terminated path and `st` a buffer statvfs fills.
        let rc = unsafe { libc::statvfs(c.as_ptr(), st.as_mut_ptr()) };
        if rc != 0 {
            return None;
        }
        // SAFETY: statvfs returned 0, so it filled `st`.
        let st = unsafe { st.assume_init() };
        #[allow(clippy::unnecessary_cast, reason = "u32 on some platforms")]
        Some((st.f_bavail as u64).saturating_mul(st.f_frsize as u64))
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        None
    }
}

/// How a render's cube is written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CubeFormat {
    /// `tprf.npy` when the dense array is at most [`NPY_MAX_BYTES`], else `tprf.zarr`.
    #[default]
    Auto,
    /// `tprf.npy`: one dense float32 array, what numpy users load in one line.
    Npy,
    /// `tprf.zarr`: chunked and compressed, only where light arrived.
    Zarr,
}

/// The largest cube [`CubeFormat::Auto`] writes as one dense `tprf.npy`: 4 GiB.
pub const NPY_MAX_BYTES: u64 = 4 << 30;

impl CubeFormat {
    /// The concrete format for a cube of `[H, W, T]` float32.
    pub fn resolve(self, shape: &[u64]) -> CubeFormat {
        match self {
            CubeFormat::Auto if npy_f32_bytes(shape) > NPY_MAX_BYTES => CubeFormat::Zarr,
            CubeFormat::Auto => CubeFormat::Npy,
            f => f,
        }
    }
}

/// Written as the command line takes it: `auto`, `npy`, `zarr`.
impl serde::Serialize for CubeFormat {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(match self {
            CubeFormat::Auto => "auto",
            CubeFormat::Npy => "npy",
            CubeFormat::Zarr => "zarr",
        })
    }
}

impl std::str::FromStr for CubeFormat {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<CubeFormat, String> {
        match s.trim() {
            "auto" => Ok(CubeFormat::Auto),
            "npy" => Ok(CubeFormat::Npy),
            "zarr" => Ok(CubeFormat::Zarr),
            other => Err(format!("unknown cube format '{other}' (auto, npy or zarr)")),
        }
    }
}

/// Write a float32 C-order array.
pub fn write_npy_f32(path: &Path, shape: &[u64], data: &[f32]) -> Result<(), ExportError> {
    write_npy(path, shape, data)
}

/// Write a C-order array of `T`'s default dtype (`f32`: `<f4`, `u16`: `<u2`).
pub fn write_npy<T: npyz::AutoSerialize + Copy>(
    path: &Path,
    shape: &[u64],
    data: &[T],
) -> Result<(), ExportError> {
    write_atomic(path, |w| {
        let mut npy = npyz::WriteOptions::<T>::new()
            .default_dtype()
            .shape(shape)
            .writer(w)
            .begin_nd()?;
        npy.extend(data.iter().copied())?;
        npy.finish()?;
        Ok(())
    })
}

/// A float32 C-order `.npy` of shape `[P, H, W]` written a band of rows at a time (all
/// `P` planes of rows `y0 .. y0 + rows` per call, in any order), into `NAME.tmp` beside
/// it and renamed over it by [`NpyBands::finish`] (dropped unfinished, the temporary
/// file is removed). The file is byte for byte what [`write_npy_f32`] writes of the
/// whole array.
pub struct NpyBands {
    path: PathBuf,
    tmp: PathBuf,
    file: Option<File>,
    data_at: u64,
    shape: [u64; 3],
    bytes: Vec<u8>,
}

impl NpyBands {
    /// Creates the temporary file with its header and room for the data.
    pub fn create(path: &Path, shape: [u64; 3]) -> Result<NpyBands, ExportError> {
        let tmp = temp_path(path);
        let mut header = Vec::new();
        let write_err = |source: std::io::Error| ExportError::Write {
            path: path.to_path_buf(),
            source: source.into(),
        };
        npyz::WriteOptions::<f32>::new()
            .default_dtype()
            .shape(&shape)
            .writer(&mut header)
            .write_header_only()
            .map_err(write_err)?;
        let file = File::create(&tmp).map_err(|source| ExportError::Create {
            path: tmp.clone(),
            source,
        })?;
        let bands = NpyBands {
            path: path.to_path_buf(),
            tmp,
            file: Some(file),
            data_at: header.len() as u64,
            shape,
            bytes: Vec::new(),
        };
        let file = bands.file.as_ref().expect("just opened");
        std::os::unix::fs::FileExt::write_all_at(file, &header, 0).map_err(write_err)?;
        file.set_len(header.len() as u64 + npy_f32_bytes(&shape))
            .map_err(write_err)?;
        Ok(bands)
    }

    /// Writes rows `y0 .. y0 + rows` of every plane: `values` is `[P, rows, W]`.
    pub fn write_rows(
        &mut self,
        y0: usize,
        rows: usize,
        values: &[f32],
    ) -> Result<(), ExportError> {
        let [p, h, w] = self.shape.map(|v| v as usize);
        if y0 + rows > h || values.len() != p * rows * w {
            return Err(ExportError::Write {
                path: self.path.clone(),
                source: format!(
                    "rows {y0} .. {} of {h} with {} values for {p} planes of {w} columns",
                    y0 + rows,
                    values.len()
                )
                .into(),
            });
        }
        let file = self.file.as_ref().expect("open until finished");
        for (k, plane) in values.chunks_exact((rows * w).max(1)).enumerate() {
            self.bytes.clear();
            self.bytes
                .extend(plane.iter().flat_map(|v| v.to_le_bytes()));
            let at = self.data_at + 4 * ((k * h + y0) * w) as u64;
            std::os::unix::fs::FileExt::write_all_at(file, &self.bytes, at).map_err(|source| {
                ExportError::Write {
                    path: self.path.clone(),
                    source: source.into(),
                }
            })?;
        }
        Ok(())
    }

    /// Flushes the file to disk and renames it over its path.
    pub fn finish(mut self) -> Result<(), ExportError> {
        let file = self.file.take().expect("open until finished");
        file.sync_all().map_err(|source| ExportError::Write {
            path: self.path.clone(),
            source: source.into(),
        })?;
        drop(file);
        std::fs::rename(&self.tmp, &self.path).map_err(|source| ExportError::Rename {
            from: self.tmp.clone(),
            to: self.path.clone(),
            source,
        })
    }
}

impl Drop for NpyBands {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Write a snapshot's cube as a float32 C-order `.npy`: `[H, W, T]` for the total
/// (`layer` `None`) or `[L, H, W, T]` for all per-bounce layers (`layer` `Some(_)` is
/// ignored beyond choosing that form). Rows are made dense one at a time, so the only
/// cube-sized memory is the file, written straight to the disk with chunks of zeros
/// left as holes ([`bulk_file`]).
pub fn write_snapshot_npy(
    path: &Path,
    snap: &FilmSnapshot,
    layers: bool,
) -> Result<(), ExportError> {
    let (w, h, t) = (
        snap.width() as u64,
        snap.height() as u64,
        snap.axis().bins as u64,
    );
    if layers {
        let l = snap.layers();
        write_planes_npy(path, &[l as u64, h, w, t], (0..l).map(|p| (snap, Some(p))))
    } else {
        write_planes_npy(path, &[h, w, t], [(snap, None)])
    }
}

/// Write the Stokes cube `[4, H, W, T]` of the snapshots of S0..S3 (one layout) to
/// `path` ([`STOKES_NPY`]), atomically.
pub fn write_stokes_npy(path: &Path, stokes: [&FilmSnapshot; 4]) -> Result<(), ExportError> {
    let s0 = stokes[0];
    let shape = [
        4,
        s0.height() as u64,
        s0.width() as u64,
        s0.axis().bins as u64,
    ];
    write_planes_npy(path, &shape, stokes.map(|s| (s, None)))
}

/// Write `planes` (each a snapshot's cube, or one of its layers) one after the other as
/// an npy array of `shape`, atomically; chunks no light reached are holes in the file.
fn write_planes_npy<'a>(
    path: &Path,
    shape: &[u64],
    planes: impl IntoIterator<Item = (&'a FilmSnapshot, Option<usize>)>,
) -> Result<(), ExportError> {
    write_atomic_bulk(path, |out| {
        // Chunks no light reached are holes in the file, not written zeros.
        let sparse = npyz::WriteOptions::<f32>::new()
            .default_dtype()
            .shape(shape)
            .writer(&mut *out)
            .write_header_only()?;
        // The data: little-endian float32 (the header's `<f4`), a row at a time.
        let (mut row, mut bytes) = (Vec::new(), Vec::new());
        for (snap, plane) in planes {
            for y in 0..snap.height() {
                snap.row_dense(y, plane, &mut row);
                bytes.clear();
                bytes.extend(row.iter().flat_map(|v| v.to_le_bytes()));
                sparse.write_all(&bytes)?;
            }
        }
        Ok(())
    })
}

/// Read a cube `tprf.npy` written by `tprf render` with the `tprf.json` beside it,
/// checking that the array's shape is the metadata's `[H, W, T]`.
pub fn read_cube(npy: &Path) -> Result<(CubeMetadata, Vec<f32>), ExportError> {
    let (meta, cube) = open_cube(npy)?;
    Ok((meta, cube.read_all()?))
}

/// A cube's `tprf.json` at `path` (a regular file, read under the memory budget).
pub fn read_metadata(path: &Path) -> Result<CubeMetadata, ExportError> {
    let bytes = crate::budget::read_file(path, "tprf.json").map_err(|e| match e {
        crate::budget::BudgetError::Io { source, .. } => ExportError::NoMetadata {
            path: path.to_path_buf(),
            source,
        },
        e => e.into(),
    })?;
    serde_json::from_slice(&bytes).map_err(|source| ExportError::Metadata {
        path: path.to_path_buf(),
        source,
    })
}

/// [`read_cube`] without reading the values: the metadata and the open array, its
/// shape checked.
pub fn open_cube(npy: &Path) -> Result<(CubeMetadata, NpyF32), ExportError> {
    let meta_path = npy.with_file_name("tprf.json");
    let meta = read_metadata(&meta_path)?;
    meta.check_not_empty(&meta_path)?;
    let cube = NpyF32::open(npy)?;
    let expected = vec![meta.height as u64, meta.width as u64, meta.bins as u64];
    if cube.shape() != expected {
        return Err(ExportError::Shape {
            path: npy.to_path_buf(),
            shape: cube.shape().to_vec(),
            layout: "[H, W, T]",
            expected,
        });
    }
    Ok((meta, cube))
}

/// A folder written by `tprf render` as a film snapshot: the cube, and its per-bounce
/// layers when `tprf_bounces.npy` is there.
pub fn load_snapshot(dir: &Path) -> Result<(CubeMetadata, FilmSnapshot), ExportError> {
    let zarr_path = dir.join(zarr::ZARR_NAME);
    if !dir.join("tprf.npy").exists() && zarr_path.is_dir() {
        let cube = zarr::ZarrCube::open(&zarr_path)?;
        let snap = cube.snapshot()?;
        return Ok((cube.meta, snap));
    }
    let (meta, cube) = open_cube(&dir.join("tprf.npy"))?;
    let axis = meta.axis().map_err(|source| ExportError::Axis {
        path: dir.join("tprf.json"),
        source,
    })?;
    let bounces_path = dir.join("tprf_bounces.npy");
    let bounces = if meta.bounces_separate > 0 && bounces_path.exists() {
        let b = NpyF32::open(&bounces_path)?;
        let expected = vec![
            meta.bounces_separate as u64 + 2 + u64::from(meta.luminescence_layer),
            meta.height as u64,
            meta.width as u64,
            meta.bins as u64,
        ];
        if b.shape() != expected {
            return Err(ExportError::Shape {
                path: bounces_path,
                shape: b.shape().to_vec(),
                layout: "[layers, H, W, T]",
                expected,
            });
        }
        Some(b)
    } else {
        None
    };
    let layout = FilmLayout {
        width: meta.width,
        height: meta.height,
        axis,
        bounces_separate: if bounces.is_some() {
            meta.bounces_separate
        } else {
            0
        },
        luminescence: meta.luminescence_layer,
    };
    let (w, h, t) = (meta.width as u64, meta.height as u64, meta.bins as u64);
    let layers = bounces.as_ref().map_or(0, |b| b.shape()[0] as usize);
    // One dense band of rows at a time; the light read so far is what stays.
    let band_bytes = 4 * (DENSE_BAND_VALUES as u64).max(w * t);
    let read = |y0: usize, layer: Option<usize>, out: &mut [f32]| match (layer, &bounces) {
        (None, _) => cube.read(y0 as u64 * w * t, out),
        (Some(l), Some(b)) => b.read((l as u64 * h + y0 as u64) * w * t, out),
        (Some(_), None) => Ok(()),
    };
    let after_band = |rows_done: usize, heap_bytes: usize| {
        if rows_done < meta.height {
            crate::budget::check(
                band_bytes,
                "the cube",
                format_args!(
                    "reading rows {rows_done}.. of {} (the light of the rows before holds {})",
                    cube.path().display(),
                    crate::budget::format_bytes(heap_bytes as u64)
                ),
            )?;
        }
        Ok(())
    };
    crate::budget::check(
        band_bytes + 28 * w * h,
        "the cube",
        format_args!("reading {}", cube.path().display()),
    )?;
    let snapshot = FilmSnapshot::from_dense_rows(
        layout,
        meta.spp,
        meta.passes,
        layers,
        meta.error_estimate,
        read,
        after_band,
    )?;
    Ok((meta, snapshot))
}

/// Read a float32 array written by [`write_npy_f32`] (or numpy), with its shape: the
/// header checked against the file's length, then the values, budgeted, in one copy.
pub fn read_npy_f32(path: &Path) -> Result<(Vec<u64>, Vec<f32>), ExportError> {
    let npy = NpyF32::open(path)?;
    let data = npy.read_all()?;
    Ok((npy.shape().to_vec(), data))
}

/// Write pretty JSON.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), ExportError> {
    write_atomic(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value)?;
        writeln!(w)?;
        Ok(())
    })
}

/// The exposure that maps the `q` quantile of the positive values to 1 (1 if none).
pub fn exposure_for(values: impl Iterator<Item = f64>, q: f64) -> f64 {
    crate::film::quantile(values.filter(|x| *x > 0.0), q).map_or(1.0, |x| 1.0 / x)
}

/// Linear value -> sRGB-encoded 8-bit (clamped to [0, 1] first).
pub fn srgb8(x: f64) -> u8 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Write a grey PNG of `values` (row-major `w x h`) times `exposure`, sRGB-encoded.
pub fn write_png_gray(
    path: &Path,
    w: usize,
    h: usize,
    values: &[f64],
    exposure: f64,
) -> Result<(), ExportError> {
    let bytes: Vec<u8> = values.iter().map(|v| srgb8(v * exposure)).collect();
    let size_error = ExportError::ImageSize {
        width: w,
        height: h,
        channels: 1,
        bytes: bytes.len(),
    };
    let img = image_of::<image::Luma<u8>>(w, h, bytes, size_error)?;
    write_atomic(path, |out| {
        img.write_to(out, image::ImageFormat::Png)?;
        Ok(())
    })
}

/// Write `frames/0000.png ...`: one PNG per time bin, one shared exposure (the 99.9 %
/// quantile of the cube's positive bins maps to white) so brightness compares across
/// frames.
pub fn write_frames(dir: &Path, snap: &FilmSnapshot) -> Result<(), ExportError> {
    let frames = dir.join("frames");
    create_dir(&frames)?;
    let exposure = snap.robust_max().map_or(1.0, |m| 1.0 / m);
    let l = &snap.layout;
    for b in 0..l.axis.bins {
        let slice: Vec<f64> = snap.slice(b).into_iter().map(f64::from).collect();
        write_png_gray(
            &frames.join(format!("{b:04}.png")),
            l.width,
            l.height,
            &slice,
            exposure,
        )?;
    }
    Ok(())
}

/// Write an 8-bit RGB PNG (`rgb` row-major, 3 bytes per pixel, `w x h`).
pub fn write_png_rgb(path: &Path, w: usize, h: usize, rgb: Vec<u8>) -> Result<(), ExportError> {
    let size_error = ExportError::ImageSize {
        width: w,
        height: h,
        channels: 3,
        bytes: rgb.len(),
    };
    let img = image_of::<image::Rgb<u8>>(w, h, rgb, size_error)?;
    write_atomic(path, |out| {
        img.write_to(out, image::ImageFormat::Png)?;
        Ok(())
    })
}

/// An image of `w x h` pixels of `bytes` (row-major), or `size_error` when they do not
/// match (or a side does not fit in `u32`).
fn image_of<P: image::Pixel<Subpixel = u8>>(
    w: usize,
    h: usize,
    bytes: Vec<u8>,
    size_error: ExportError,
) -> Result<image::ImageBuffer<P, Vec<u8>>, ExportError> {
    let (Ok(w), Ok(h)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(size_error);
    };
    image::ImageBuffer::from_raw(w, h, bytes).ok_or(size_error)
}

/// Write a CSV file: a header line, then one line per row (NaN written as an empty
/// field, other numbers by [`csv_number`]).
pub fn write_csv(
    path: &Path,
    header: &[String],
    rows: impl Iterator<Item = Vec<f64>>,
) -> Result<(), ExportError> {
    write_atomic(path, |w| {
        writeln!(w, "{}", header.join(","))?;
        for row in rows {
            let mut first = true;
            for v in row {
                if !first {
                    write!(w, ",")?;
                }
                first = false;
                if !v.is_nan() {
                    write!(w, "{}", csv_number(v))?;
                }
            }
            writeln!(w)?;
        }
        Ok(())
    })
}

/// A number as a CSV file holds it: a whole number under 10^15 as an integer, anything
/// else in scientific notation to 12 significant digits with the trailing zeros
/// dropped (`3.575e-9`, not the `3.5749999999999993e-9` that `t0 + (b + 1/2) dt` gives
/// in full): more than an f32 cube's 7 digits, without the last bits' arithmetic noise.
pub fn csv_number(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        return format!("{v}");
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    let full = format!("{v:.11e}");
    match full.split_once('e') {
        Some((mantissa, exp)) if mantissa.contains('.') => {
            let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{mantissa}e{exp}")
        }
        _ => full,
    }
}

#[cfg(test)]
mod csv_tests {
    use super::csv_number;

    /// Hand-written cases: integers stay integers, a bin centre computed in f64 reads
    /// as the decimal it stands for, and 12 digits survive.
    #[test]
    fn csv_numbers_are_short_and_exact_enough() {
        assert_eq!(csv_number(42.0), "42");
        assert_eq!(csv_number(-3.0), "-3");
        assert_eq!(csv_number(3.55e-9 + 0.5 * 50e-12), "3.575e-9");
        assert_eq!(csv_number(3.5749999999999993), "3.575e0");
        assert_eq!(csv_number(0.1), "1e-1");
        assert_eq!(csv_number(1.23456789012345e-7), "1.23456789012e-7");
        assert_eq!(csv_number(1e20), "1e20");
        assert_eq!(csv_number(f64::INFINITY), "inf");
        for v in [0.1f32, 3.3e-9, 7.77e12, -1.5e-30] {
            let back: f64 = csv_number(f64::from(v)).parse().unwrap();
            assert_eq!(back as f32, v, "an f32 survives");
        }
    }
}

#[cfg(test)]
mod write_tests {
    use super::write_atomic;

    /// Writing into a folder that does not exist names the file asked for, not the
    /// temporary file beside it.
    #[test]
    fn a_missing_folder_names_the_file_asked_for() {
        let dir = std::env::temp_dir().join(format!("tprf-missing-{}", std::process::id()));
        let path = dir.join("nowhere").join("slice.png");
        let e = write_atomic(&path, |_| Ok(())).unwrap_err();
        let text = format!("{e}");
        assert!(
            text.contains("slice.png") && !text.contains(".tmp"),
            "{text}"
        );
        assert!(!path.exists());
    }
}

//! A capture's files, in one output folder: `nlos.hdf5` in tal's capture format (the
//! keys of `NLOSCaptureData` in diegoroyo/tal's `tal/io/capture_data.py`), `H.npy` (the
//! same array) and `nlos.json` (what tprf knows of the capture, in seconds and metres).
//!
//! tal's format, as tprf writes it:
//!
//! | key | shape, type | what |
//! | --- | --- | --- |
//! | `H` | `[T, Sx, Sy]` or `[T, Lx, Ly, Sx, Sy]` f32 | the transients (a bin: the integral over the bin of the radiance leaving the sensor point toward the SPAD, W m^-2 sr^-1 s per joule of laser pulse) |
//! | `H_format` | enum (i32) `(1,)` | `T_Sx_Sy` = 1 (single, confocal), `T_Lx_Ly_Sx_Sy` = 2 (exhaustive) |
//! | `sensor_xyz`, `laser_xyz` | `(3,)` f32 | the SPAD's and the laser's device positions, m |
//! | `sensor_grid_xyz`, `sensor_grid_normals` | `(Sx, Sy, 3)` f32 | sensor points on the wall, and the wall's normal |
//! | `laser_grid_xyz`, `laser_grid_normals` | `(Lx, Ly, 3)` f32 | laser points (`(1, 1, 3)` single; the sensor grid confocal) |
//! | `sensor_grid_format`, `laser_grid_format` | enum (i32) `(1,)` | `X_Y_3` = 2 |
//! | `volume_format` | enum (i32) `(1,)` | `X_Y_Z_3` = 2 |
//! | `delta_t`, `t_start` | scalar f64 | bin width and start, **metres** of optical path |
//! | `t_accounts_first_and_last_bounces` | scalar bool (h5py's enum of i8) | whether times include the device-to-wall legs |
//! | `scene_info` | scalar string, YAML | `original_format: tprf` and the capture's settings |
//!
//! The HDF5 file is written by `hdf5-pure` (no C library); tests read it back with h5py
//! and tal's own reader.

use super::NlosError;
use super::capture::Capture;
use super::setup::Scan;
use crate::export::staging::Staging;
use crate::export::{write_json, write_npy_f32};
use crate::units::C_M_PER_S;
use glam::Vec3;
use hdf5_pure::{EnumTypeBuilder, FileBuilder, make_i8_type};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The capture's HDF5 file in an output folder.
pub const HDF5_NAME: &str = "nlos.hdf5";
/// The capture's metadata in an output folder.
pub const JSON_NAME: &str = "nlos.json";
/// `H` as a numpy array in an output folder.
pub const NPY_NAME: &str = "H.npy";

/// tal's `HFormat` members (`tal/enums.py`).
const H_FORMATS: &[(&str, i32)] = &[
    ("UNKNOWN", 0),
    ("T_Sx_Sy", 1),
    ("T_Lx_Ly_Sx_Sy", 2),
    ("T_Si", 3),
    ("T_Li_Si", 4),
    ("F_Sx_Sy", 10),
    ("F_Lx_Ly_Sx_Sy", 11),
    ("F_Si", 12),
    ("F_Li_Si", 13),
];
/// tal's `GridFormat` members.
const GRID_FORMATS: &[(&str, i32)] = &[("UNKNOWN", 0), ("N_3", 1), ("X_Y_3", 2)];
/// tal's `VolumeFormat` members.
const VOLUME_FORMATS: &[(&str, i32)] = &[("UNKNOWN", 0), ("N_3", 1), ("X_Y_Z_3", 2), ("X_Y_3", 3)];

/// `H_format` values tprf writes and reads.
pub const H_T_SX_SY: i32 = 1;
pub const H_T_LX_LY_SX_SY: i32 = 2;
/// `X_Y_3`, the grid format tprf writes and reads.
pub const GRID_X_Y_3: i32 = 2;

/// The relay wall's frame, as `nlos.json` records it (metres).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WallMetadata {
    pub name: String,
    pub corner: [f32; 3],
    pub u_axis: [f32; 3],
    pub v_axis: [f32; 3],
    pub normal: [f32; 3],
    pub width_m: f32,
    pub height_m: f32,
}

/// `nlos.json`: the capture as tprf knows it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaptureMetadata {
    pub format: String,
    pub tprf_version: String,
    pub scene: String,
    pub wall: WallMetadata,
    pub scan: Scan,
    /// Sensor points along the wall's u and v axes.
    pub grid: [usize; 2],
    pub laser_grid: [usize; 2],
    /// Shape of `H` (time first, as tal's).
    pub h_shape: Vec<usize>,
    /// tal's `H_format` name.
    pub h_format: String,
    pub t0_s: f64,
    pub dt_s: f64,
    pub bins: usize,
    /// The same axis in metres of optical path (tal's `t_start`, `delta_t`).
    pub t_start_m: f64,
    pub delta_t_m: f64,
    pub t_accounts_first_and_last_bounces: bool,
    pub laser_origin: [f32; 3],
    pub sensor_origin: [f32; 3],
    pub spp: u32,
    pub seed: u64,
    pub max_bounces: u32,
    pub channel: crate::scene::Channel,
    /// What a value of `H` is.
    pub h_units: String,
    pub render_s: f64,
    pub rays: u64,
    /// The request that made the capture (`tprf nlos`'s options, as a batch manifest's
    /// `[[capture]]` keys: [`crate::request::CaptureRequest`]), when one did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub request: Option<serde_json::Value>,
}

impl CaptureMetadata {
    pub fn of(c: &Capture) -> CaptureMetadata {
        let g = &c.geometry;
        CaptureMetadata {
            format: "tprf-nlos-capture".into(),
            tprf_version: env!("CARGO_PKG_VERSION").into(),
            scene: c.scene_name.clone(),
            wall: WallMetadata {
                name: g.wall.name.clone(),
                corner: g.wall.corner.to_array(),
                u_axis: g.wall.u_axis.to_array(),
                v_axis: g.wall.v_axis.to_array(),
                normal: g.wall.normal.to_array(),
                width_m: g.wall.width_m,
                height_m: g.wall.height_m,
            },
            scan: g.scan,
            grid: g.grid,
            laser_grid: g.laser_grid,
            h_shape: c.shape(),
            h_format: match g.scan {
                Scan::Exhaustive { .. } => "T_Lx_Ly_Sx_Sy",
                _ => "T_Sx_Sy",
            }
            .into(),
            t0_s: g.axis.t0_s,
            dt_s: g.axis.dt_s,
            bins: g.axis.bins,
            t_start_m: g.axis.t0_s * C_M_PER_S,
            delta_t_m: g.axis.dt_s * C_M_PER_S,
            t_accounts_first_and_last_bounces: g.device_legs,
            laser_origin: g.laser_origin.to_array(),
            sensor_origin: g.sensor_origin.to_array(),
            spp: c.spp,
            seed: c.seed,
            max_bounces: c.max_bounces,
            channel: c.channel,
            h_units: "per bin: the integral over the bin of the radiance leaving the sensor point \
                      toward the SPAD, W m^-2 sr^-1 s, per joule of laser pulse"
                .into(),
            render_s: c.render_s,
            rays: c.rays,
            request: None,
        }
    }
}

fn h5_err(path: &Path, e: impl std::fmt::Display) -> NlosError {
    NlosError::File {
        path: path.display().to_string(),
        message: format!("HDF5: {e}"),
    }
}

fn flat(points: impl Iterator<Item = Vec3>) -> Vec<f32> {
    points.flat_map(|p| p.to_array()).collect()
}

/// An enum dataset of one value, shape `(1,)`, as tal writes its enums.
fn enum_dataset(
    fb: &mut FileBuilder,
    name: &str,
    members: &[(&str, i32)],
    value: i32,
) -> Result<(), hdf5_pure::FormatError> {
    let dt = members
        .iter()
        .fold(EnumTypeBuilder::i32_based(), |b, (n, v)| b.value(n, *v))
        .build()?;
    fb.create_dataset(name)
        .with_enum_i32_data(dt, &[value])
        .with_shape(&[1]);
    Ok(())
}

/// The YAML of `scene_info`.
fn scene_info_yaml(m: &CaptureMetadata) -> String {
    let scan = match m.scan {
        Scan::Single { .. } => "single",
        Scan::Confocal => "confocal",
        Scan::Exhaustive { .. } => "exhaustive",
    };
    // JSON strings are YAML flow scalars.
    let q = |s: &str| serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into());
    format!(
        "original_format: tprf\ntprf:\n  version: {}\n  scene: {}\n  relay_wall: {}\n  scan: {scan}\n  \
         spp: {}\n  seed: {}\n  max_bounces: {}\n  channel: {}\n  t0_s: {:e}\n  dt_s: {:e}\n",
        q(&m.tprf_version),
        q(&m.scene),
        q(&m.wall.name),
        m.spp,
        m.seed,
        m.max_bounces,
        m.channel.name(),
        m.t0_s,
        m.dt_s,
    )
}

/// What tal's HDF5 file holds, borrowed: from a rendered [`Capture`] or a
/// [`LoadedCapture`] (a SPAD's counts, say). Grids are x-major point lists.
pub struct TalView<'a> {
    pub h: &'a [f32],
    pub h_shape: Vec<usize>,
    pub exhaustive: bool,
    pub sensor_grid: &'a [Vec3],
    pub sensor_shape: [usize; 2],
    pub laser_grid: &'a [Vec3],
    pub laser_shape: [usize; 2],
    /// The wall's normal (every grid point's).
    pub normal: Vec3,
    pub sensor_xyz: Vec3,
    pub laser_xyz: Vec3,
    pub delta_t_m: f64,
    pub t_start_m: f64,
    pub device_legs: bool,
    /// `scene_info`'s YAML.
    pub scene_info: String,
}

impl<'a> TalView<'a> {
    /// The view of a loaded capture, with `scene_info` (grid normals from the file, else
    /// the grid's own; device positions from the file, else the grid's centre).
    pub fn of_loaded(c: &'a LoadedCapture, scene_info: String) -> Result<TalView<'a>, NlosError> {
        let frame = super::reconstruct::GridFrame::of(c)?;
        Ok(TalView {
            h: &c.h,
            h_shape: c.h_shape.clone(),
            exhaustive: c.exhaustive,
            sensor_grid: &c.sensor_grid,
            sensor_shape: c.sensor_shape,
            laser_grid: &c.laser_grid,
            laser_shape: c.laser_shape,
            normal: c.sensor_normal.unwrap_or(frame.n),
            sensor_xyz: c.sensor_xyz.unwrap_or(frame.center),
            laser_xyz: c.laser_xyz.unwrap_or(frame.center),
            delta_t_m: c.delta_t_m,
            t_start_m: c.t_start_m,
            device_legs: c.device_legs,
            scene_info,
        })
    }
}

/// Write `c` as tal's HDF5 capture file at `path`.
pub fn write_hdf5(c: &Capture, path: &Path) -> Result<(), NlosError> {
    let g = &c.geometry;
    let m = CaptureMetadata::of(c);
    let sensors: Vec<Vec3> = g.sensors.iter().map(|p| p.position).collect();
    let lasers: Vec<Vec3> = g.lasers.iter().map(|p| p.position).collect();
    write_tal_hdf5(
        &TalView {
            h: &c.h,
            h_shape: c.shape(),
            exhaustive: matches!(g.scan, Scan::Exhaustive { .. }),
            sensor_grid: &sensors,
            sensor_shape: g.grid,
            laser_grid: &lasers,
            laser_shape: g.laser_grid,
            normal: g.wall.normal,
            sensor_xyz: g.sensor_origin,
            laser_xyz: g.laser_origin,
            delta_t_m: m.delta_t_m,
            t_start_m: m.t_start_m,
            device_legs: g.device_legs,
            scene_info: scene_info_yaml(&m),
        },
        path,
    )
}

/// Write `v` as tal's HDF5 capture file at `path` (into `path.tmp`, renamed over it).
pub fn write_tal_hdf5(v: &TalView, path: &Path) -> Result<(), NlosError> {
    let err = |e: hdf5_pure::FormatError| h5_err(path, e);
    crate::budget::check(
        (v.h.len() as u64).saturating_mul(4),
        "nlos.hdf5",
        "a copy of H while the file is assembled",
    )?;
    let mut fb = FileBuilder::new();
    let shape: Vec<u64> = v.h_shape.iter().map(|&d| d as u64).collect();
    fb.create_dataset("H").with_f32_data(v.h).with_shape(&shape);
    let h_format = if v.exhaustive {
        H_T_LX_LY_SX_SY
    } else {
        H_T_SX_SY
    };
    enum_dataset(&mut fb, "H_format", H_FORMATS, h_format).map_err(err)?;
    let [sx, sy] = v.sensor_shape;
    let [lx, ly] = v.laser_shape;
    let n = v.normal;
    fb.create_dataset("sensor_xyz")
        .with_f32_data(&v.sensor_xyz.to_array())
        .with_shape(&[3]);
    fb.create_dataset("sensor_grid_xyz")
        .with_f32_data(&flat(v.sensor_grid.iter().copied()))
        .with_shape(&[sx as u64, sy as u64, 3]);
    fb.create_dataset("sensor_grid_normals")
        .with_f32_data(&flat(v.sensor_grid.iter().map(|_| n)))
        .with_shape(&[sx as u64, sy as u64, 3]);
    enum_dataset(&mut fb, "sensor_grid_format", GRID_FORMATS, GRID_X_Y_3).map_err(err)?;
    fb.create_dataset("laser_xyz")
        .with_f32_data(&v.laser_xyz.to_array())
        .with_shape(&[3]);
    fb.create_dataset("laser_grid_xyz")
        .with_f32_data(&flat(v.laser_grid.iter().copied()))
        .with_shape(&[lx as u64, ly as u64, 3]);
    fb.create_dataset("laser_grid_normals")
        .with_f32_data(&flat(v.laser_grid.iter().map(|_| n)))
        .with_shape(&[lx as u64, ly as u64, 3]);
    enum_dataset(&mut fb, "laser_grid_format", GRID_FORMATS, GRID_X_Y_3).map_err(err)?;
    enum_dataset(&mut fb, "volume_format", VOLUME_FORMATS, 2).map_err(err)?;
    fb.create_dataset("delta_t")
        .with_f64_data(&[v.delta_t_m])
        .with_shape(&[]);
    fb.create_dataset("t_start")
        .with_f64_data(&[v.t_start_m])
        .with_shape(&[]);
    // h5py's bool: an enum of i8 with FALSE = 0, TRUE = 1.
    let bool_type = EnumTypeBuilder::with_base(make_i8_type())
        .value("FALSE", 0)
        .value("TRUE", 1)
        .build()
        .map_err(err)?;
    fb.create_dataset("t_accounts_first_and_last_bounces")
        .with_enum_u8_data(bool_type, &[u8::from(v.device_legs)])
        .with_shape(&[]);
    // A variable-length UTF-8 string, as h5py writes a Python str (tal's YAML parser
    // takes the bytes h5py reads back; a fixed-length string reads as numpy.bytes_).
    fb.create_dataset("scene_info")
        .with_vlen_strings(&[&v.scene_info])
        .with_shape(&[]);
    let tmp = path.with_extension("hdf5.tmp");
    fb.write(&tmp).map_err(|e| h5_err(path, e))?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        h5_err(path, e)
    })
}

/// Write the capture folder `out` (`nlos.hdf5`, `H.npy`, `nlos.json`), replacing only
/// what tprf may replace ([`Staging`]); `inputs` are the paths the command read.
pub fn write_capture_folder(c: &Capture, out: &Path, inputs: &[&Path]) -> Result<(), NlosError> {
    let staging = Staging::new(out, inputs)?;
    let dir = staging.path();
    let shape: Vec<u64> = c.shape().iter().map(|&d| d as u64).collect();
    write_npy_f32(&dir.join(NPY_NAME), &shape, &c.h)?;
    write_json(&dir.join(JSON_NAME), &CaptureMetadata::of(c))?;
    write_hdf5(c, &dir.join(HDF5_NAME))?;
    staging.commit()?;
    Ok(())
}

/// A capture read from a tal HDF5 file (tprf's or tal's own): what reconstruction needs.
/// Grids are x-major point lists.
#[derive(Clone, Debug)]
pub struct LoadedCapture {
    pub path: PathBuf,
    /// `[T, (Lx, Ly,) Sx, Sy]`, time-major.
    pub h: Vec<f32>,
    pub h_shape: Vec<usize>,
    pub exhaustive: bool,
    pub sensor_grid: Vec<Vec3>,
    pub sensor_shape: [usize; 2],
    pub laser_grid: Vec<Vec3>,
    pub laser_shape: [usize; 2],
    pub sensor_normal: Option<Vec3>,
    pub sensor_xyz: Option<Vec3>,
    pub laser_xyz: Option<Vec3>,
    pub delta_t_m: f64,
    pub t_start_m: f64,
    pub device_legs: bool,
}

impl LoadedCapture {
    /// A rendered capture as [`read_capture`] reads its folder back (the same grids,
    /// normals, device positions and axis in metres), without the files: what a
    /// reconstruction of a capture in memory reads. `path` names it in messages.
    pub fn of(c: &Capture, path: PathBuf) -> LoadedCapture {
        let g = &c.geometry;
        let m = CaptureMetadata::of(c);
        LoadedCapture {
            path,
            h: c.h.clone(),
            h_shape: c.shape(),
            exhaustive: matches!(g.scan, Scan::Exhaustive { .. }),
            sensor_grid: g.sensors.iter().map(|p| p.position).collect(),
            sensor_shape: g.grid,
            laser_grid: g.lasers.iter().map(|p| p.position).collect(),
            laser_shape: g.laser_grid,
            sensor_normal: Some(g.wall.normal).filter(|n| n.length() > 0.5),
            sensor_xyz: Some(g.sensor_origin),
            laser_xyz: Some(g.laser_origin),
            delta_t_m: m.delta_t_m,
            t_start_m: m.t_start_m,
            device_legs: g.device_legs,
        }
    }

    pub fn bins(&self) -> usize {
        self.h_shape.first().copied().unwrap_or(0)
    }

    /// Whether each sensor point has its own laser point at the same place (confocal).
    pub fn is_confocal(&self) -> bool {
        !self.exhaustive
            && self.sensor_grid.len() == self.laser_grid.len()
            && self
                .sensor_grid
                .iter()
                .zip(&self.laser_grid)
                .all(|(s, l)| (*s - *l).length() <= 1e-5 * (1.0 + s.length()))
    }
}

/// The capture at `path`: a capture folder (its `nlos.hdf5`) or an HDF5 file.
pub fn read_capture(path: &Path) -> Result<LoadedCapture, NlosError> {
    let file = if path.is_dir() {
        path.join(HDF5_NAME)
    } else {
        path.to_path_buf()
    };
    let (f, len) = crate::budget::open_regular(&file)?;
    drop(f);
    crate::budget::check(
        len.saturating_mul(2),
        &file.display().to_string(),
        "reading the capture",
    )?;
    let h5 = hdf5_pure::File::open(&file).map_err(|e| h5_err(&file, e))?;
    let bad = |m: String| NlosError::File {
        path: file.display().to_string(),
        message: m,
    };
    let ds = |name: &str| {
        h5.dataset(name)
            .map_err(|e| bad(format!("no dataset '{name}' ({e}): not a tal capture file")))
    };
    // A dataset of floats: its declared size budgeted before it is read (a header may
    // declare any shape), and every value finite (a NaN in H would reconstruct to a
    // volume of NaN without a word).
    let floats = |name: &str| -> Result<(Vec<u64>, Vec<f32>), NlosError> {
        let d = ds(name)?;
        let shape = d.shape().map_err(|e| bad(format!("{name}: {e}")))?;
        let count = shape
            .iter()
            .try_fold(1u64, |a, &b| a.checked_mul(b))
            .unwrap_or(u64::MAX);
        crate::budget::check(
            count.saturating_mul(4),
            &file.display().to_string(),
            format!(
                "its dataset {name} of shape {shape:?} ({} f32 values)",
                crate::budget::format_count(count)
            ),
        )?;
        let v = d.read_f32().map_err(|e| bad(format!("{name}: {e}")))?;
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            let n_bad = v.iter().filter(|x| !x.is_finite()).count();
            return Err(bad(format!(
                "{name}{:?} is {}: a capture's values must be finite ({n_bad} of its {} values \
                 are not); the capture is not read",
                unravel(i as u64, &shape),
                v[i],
                v.len()
            )));
        }
        Ok((shape, v))
    };
    let scalar = |name: &str| -> Result<f64, NlosError> {
        let d = ds(name)?;
        let v = d.read_f64().map_err(|e| bad(format!("{name}: {e}")))?;
        match v.as_slice() {
            [x] if x.is_finite() => Ok(*x),
            _ => Err(bad(format!(
                "{name} holds {} values; expected one finite number",
                v.len()
            ))),
        }
    };
    let integer = |name: &str| -> Result<i64, NlosError> {
        let d = ds(name)?;
        let v = d
            .read_i64()
            .or_else(|_| d.read_i32().map(|v| v.into_iter().map(i64::from).collect()))
            .or_else(|_| d.read_i8().map(|v| v.into_iter().map(i64::from).collect()))
            .or_else(|_| d.read_u8().map(|v| v.into_iter().map(i64::from).collect()))
            .map_err(|e| bad(format!("{name}: {e}")))?;
        v.first()
            .copied()
            .ok_or_else(|| bad(format!("{name} is empty")))
    };
    let h_format = integer("H_format")?;
    let exhaustive = match h_format as i32 {
        H_T_SX_SY => false,
        H_T_LX_LY_SX_SY => true,
        other => {
            return Err(bad(format!(
                "H_format {other}: tprf reads T_Sx_Sy (1) and T_Lx_Ly_Sx_Sy (2) captures"
            )));
        }
    };
    for key in ["sensor_grid_format", "laser_grid_format"] {
        if integer(key)? as i32 != GRID_X_Y_3 {
            return Err(bad(format!("{key}: tprf reads X_Y_3 grids (2) only")));
        }
    }
    let grid = |name: &str| -> Result<(Vec<Vec3>, [usize; 2]), NlosError> {
        let (shape, v) = floats(name)?;
        match shape.as_slice() {
            [x, y, 3] if v.len() as u64 == x * y * 3 => Ok((
                v.chunks_exact(3)
                    .map(|c| Vec3::new(c[0], c[1], c[2]))
                    .collect(),
                [*x as usize, *y as usize],
            )),
            _ => Err(bad(format!(
                "{name} has shape {shape:?}; expected (X, Y, 3)"
            ))),
        }
    };
    let (sensor_grid, sensor_shape) = grid("sensor_grid_xyz")?;
    let (laser_grid, laser_shape) = grid("laser_grid_xyz")?;
    let point = |name: &str| -> Option<Vec3> {
        let (_, v) = floats(name).ok()?;
        (v.len() == 3).then(|| Vec3::new(v[0], v[1], v[2]))
    };
    let sensor_normal = grid("sensor_grid_normals")
        .ok()
        .and_then(|(n, _)| n.first().copied())
        .filter(|n| n.length() > 0.5);
    let (h_shape, h) = floats("H")?;
    let h_shape: Vec<usize> = h_shape.iter().map(|&d| d as usize).collect();
    let want: Vec<usize> = if exhaustive {
        vec![
            laser_shape[0],
            laser_shape[1],
            sensor_shape[0],
            sensor_shape[1],
        ]
    } else {
        vec![sensor_shape[0], sensor_shape[1]]
    };
    if h_shape.len() != want.len() + 1 || h_shape[1..] != want[..] || h_shape[0] == 0 {
        return Err(bad(format!(
            "H has shape {h_shape:?}; its grids say (T, {})",
            want.iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let delta_t_m = scalar("delta_t")?;
    if !(delta_t_m > 0.0) {
        return Err(bad(format!("delta_t = {delta_t_m} m: must be > 0")));
    }
    let t_start_m = scalar("t_start").unwrap_or(0.0);
    let device_legs = integer("t_accounts_first_and_last_bounces")? != 0;
    let sensor_xyz = point("sensor_xyz");
    let laser_xyz = point("laser_xyz");
    if device_legs && (sensor_xyz.is_none() || laser_xyz.is_none()) {
        return Err(bad(
            "t_accounts_first_and_last_bounces is set but sensor_xyz or laser_xyz is missing"
                .into(),
        ));
    }
    Ok(LoadedCapture {
        path: file.clone(),
        h,
        h_shape,
        exhaustive,
        sensor_grid,
        sensor_shape,
        laser_grid,
        laser_shape,
        sensor_normal,
        sensor_xyz,
        laser_xyz,
        delta_t_m,
        t_start_m,
        device_legs,
    })
}

/// The index of flat (row-major, C order) offset `flat` in an array of `shape`: what
/// `numpy.unravel_index` gives.
fn unravel(mut flat: u64, shape: &[u64]) -> Vec<u64> {
    let mut index = vec![0; shape.len()];
    for (slot, &dim) in index.iter_mut().zip(shape).rev() {
        if dim > 0 {
            *slot = flat % dim;
            flat /= dim;
        }
    }
    index
}

/// `volume.json`: what a reconstruction folder holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct VolumeMetadata {
    pub format: String,
    pub tprf_version: String,
    /// The capture reconstructed.
    pub capture: String,
    pub method: super::reconstruct::Method,
    /// Centre (world, metres), size along u, v, n (metres), voxels along them; the
    /// axes. `volume.npy` is `[Z, Y, X]`: Z along n, Y along v, X along u.
    pub volume: super::reconstruct::Volume,
    pub wave: Option<super::reconstruct::Wave>,
    /// The voxel `[x, y, z]` of the largest value and its centre, metres.
    pub peak_voxel: [usize; 3],
    pub peak_m: [f32; 3],
    pub seconds: f64,
    /// The request that made the reconstruction (`tprf nlos reconstruct`'s options:
    /// [`crate::request::ReconstructRequest`]), when one did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub request: Option<serde_json::Value>,
}

/// Write a reconstruction folder: `volume.npy` (`[Z, Y, X]` f32), `volume.json`, and the
/// max-intensity projections `mip_front.png` (along n), `mip_top.png` (along v, rows
/// = depth) and `mip_side.png` (along u, columns = depth), each scaled to its maximum.
pub fn write_reconstruction_folder(
    r: &super::reconstruct::Reconstruction,
    capture: &Path,
    out: &Path,
) -> Result<(), NlosError> {
    write_reconstruction_folder_with(r, capture, out, None)
}

/// [`write_reconstruction_folder`], `volume.json` holding `request` (the request that
/// made the reconstruction) when given.
pub fn write_reconstruction_folder_with(
    r: &super::reconstruct::Reconstruction,
    capture: &Path,
    out: &Path,
    request: Option<serde_json::Value>,
) -> Result<(), NlosError> {
    let staging = Staging::new(out, &[capture])?;
    let dir = staging.path();
    let [nx, ny, nz] = r.volume.voxels;
    write_npy_f32(
        &dir.join("volume.npy"),
        &[nz as u64, ny as u64, nx as u64],
        &r.values,
    )?;
    let peak = r.peak();
    let meta = VolumeMetadata {
        format: "tprf-nlos-volume".into(),
        tprf_version: env!("CARGO_PKG_VERSION").into(),
        capture: capture.display().to_string(),
        method: r.method,
        volume: r.volume,
        wave: r.wave,
        peak_voxel: peak,
        peak_m: r.volume.voxel_center(peak[0], peak[1], peak[2]).to_array(),
        seconds: r.seconds,
        request,
    };
    write_json(&dir.join("volume.json"), &meta)?;
    for ((w, h, values), name) in
        r.projections()
            .into_iter()
            .zip(["mip_front.png", "mip_top.png", "mip_side.png"])
    {
        // Image row 0 = top: flip the row axis (+v up, or the far depth at the top).
        let mut flipped = Vec::with_capacity(values.len());
        for row in (0..h).rev() {
            flipped.extend(values[row * w..(row + 1) * w].iter().map(|&v| v as f64));
        }
        let max = flipped.iter().copied().fold(0.0f64, f64::max);
        let exposure = if max > 0.0 { 1.0 / max } else { 1.0 };
        crate::export::write_png_gray(&dir.join(name), w, h, &flipped, exposure)?;
    }
    staging.commit()?;
    Ok(())
}

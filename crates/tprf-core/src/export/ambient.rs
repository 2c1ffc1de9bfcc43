//! The ambient image beside a cube: `ambient.npy` (float32 `[H, W]`, row 0 = top,
//! W m^-2 sr^-1: the steady radiance the scene's ambient group sends to each pixel, at
//! the group's stated power), or the array `ambient` of `tprf.zarr` (same shape,
//! dimensions `y`, `x`) when the cube is Zarr. `tprf.json` describes it under
//! `"ambient"` ([`AmbientMetadata`]); a folder without that entry has no ambient image
//! (every folder written before it existed), and loads as before.

use std::path::Path;
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use zarrs::array::{Array, ArrayBuilder, ArraySubset};
use zarrs::filesystem::FilesystemStore;

use super::{CubeMetadata, ExportError, read_npy_f32, write_npy_f32, zarr};
use crate::sensor::SensorModel;

/// The file name beside `tprf.npy`.
pub const AMBIENT_NPY: &str = "ambient.npy";

/// The array's path in `tprf.zarr`.
const ZARR_ARRAY: &str = "/ambient";

/// Chunk of the Zarr array, `[rows, columns]`.
const ZARR_CHUNK: [u64; 2] = [256, 256];

/// Units of the ambient image.
pub const AMBIENT_UNITS: &str = "W m^-2 sr^-1 (steady radiance of the ambient light group at \
its stated power, arriving at every time; the sensor adds ambient_scale x it x integral of \
Exposure_i dt to gate i)";

/// What `tprf.json` records of the ambient image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AmbientMetadata {
    /// `ambient.npy`, or `tprf.zarr/ambient`.
    pub file: String,
    pub units: String,
    /// The ambient group's members, in words.
    pub lights: Vec<String>,
    /// Samples per pixel of the ambient image.
    pub spp: u32,
    /// Relative RMS error from two independent halves (`None` below 2 spp).
    #[serde(default)]
    pub error_estimate: Option<f64>,
}

/// Refuse an image that is not `width x height`.
fn check_len(path: &Path, width: usize, height: usize, len: usize) -> Result<(), ExportError> {
    if len != width * height {
        return Err(ExportError::Shape {
            path: path.to_path_buf(),
            shape: vec![len as u64],
            layout: "[H, W]",
            expected: vec![height as u64, width as u64],
        });
    }
    Ok(())
}

/// Write `radiance` (`[height, width]`) as `dir/ambient.npy`.
pub fn write_ambient_npy(
    dir: &Path,
    width: usize,
    height: usize,
    radiance: &[f32],
) -> Result<(), ExportError> {
    let path = dir.join(AMBIENT_NPY);
    check_len(&path, width, height, radiance.len())?;
    write_npy_f32(&path, &[height as u64, width as u64], radiance)
}

fn zarr_err(path: &Path, e: &dyn std::fmt::Display) -> ExportError {
    ExportError::Zarr {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Add `radiance` (`[height, width]`) to the Zarr group at `zarr_path` (written by
/// [`zarr::write_snapshot_zarr`]) as its array `ambient` (float32, zstd, chunks of
/// 256 x 256 pixels).
pub fn write_ambient_zarr(
    zarr_path: &Path,
    width: usize,
    height: usize,
    radiance: &[f32],
) -> Result<(), ExportError> {
    check_len(zarr_path, width, height, radiance.len())?;
    let err = |e: &dyn std::fmt::Display| zarr_err(zarr_path, e);
    let store = Arc::new(FilesystemStore::new(zarr_path).map_err(|e| err(&e))?);
    let shape = vec![height as u64, width as u64];
    let mut builder = ArrayBuilder::new(
        shape.clone(),
        ZARR_CHUNK.to_vec(),
        zarrs::array::data_type::float32(),
        0.0f32,
    );
    builder
        .array_to_bytes_codec(Arc::new(zarrs::array::codec::BytesCodec::little()))
        .bytes_to_bytes_codecs(vec![Arc::new(zarrs::array::codec::ZstdCodec::new(
            1, false,
        ))])
        .dimension_names(Some(["y", "x"].map(String::from)));
    let array = builder.build(store, ZARR_ARRAY).map_err(|e| err(&e))?;
    array.store_metadata().map_err(|e| err(&e))?;
    let all = ArraySubset::new_with_ranges(&[0..shape[0], 0..shape[1]]);
    array
        .store_array_subset(&all, radiance)
        .map_err(|e| err(&e))
}

/// Write `radiance` (`[height, width]`) into render folder `dir`: into its `tprf.zarr`
/// (which must exist) when `zarr`, else as `ambient.npy`; and `ambient.png` beside it.
pub fn write_ambient(
    dir: &Path,
    zarr: bool,
    width: usize,
    height: usize,
    radiance: &[f32],
) -> Result<(), ExportError> {
    if zarr {
        write_ambient_zarr(&dir.join(zarr::ZARR_NAME), width, height, radiance)?;
    } else {
        write_ambient_npy(dir, width, height, radiance)?;
    }
    let values: Vec<f64> = radiance.iter().map(|&v| f64::from(v)).collect();
    let exposure = 0.8 * super::exposure_for(values.iter().copied(), 0.99);
    super::write_png_gray(&dir.join("ambient.png"), width, height, &values, exposure)
}

/// The ambient image of the render folder `dir` whose metadata is `meta`: `None` when
/// the metadata records none (an older folder, or a scene without ambient light);
/// otherwise `ambient.npy`, or the array `ambient` of `tprf.zarr`, checked to be
/// `[H, W]`. A recorded image whose file is missing is an error naming it.
pub fn load_ambient(dir: &Path, meta: &CubeMetadata) -> Result<Option<Vec<f32>>, ExportError> {
    if meta.ambient.is_none() {
        return Ok(None);
    }
    load_ambient_image(dir, meta.width, meta.height)
}

/// The ambient image of render folder `dir`, `[height, width]`: `ambient.npy`, else
/// the array `ambient` of `tprf.zarr`; an error naming the file when neither is there
/// or the shape is wrong. (Call it when `tprf.json` records an ambient image.)
pub fn load_ambient_image(dir: &Path, w: usize, h: usize) -> Result<Option<Vec<f32>>, ExportError> {
    let npy = dir.join(AMBIENT_NPY);
    let zarr_path = dir.join(zarr::ZARR_NAME);
    let data = if !npy.exists() && zarr_path.is_dir() {
        let err = |e: &dyn std::fmt::Display| zarr_err(&zarr_path, e);
        let store = Arc::new(FilesystemStore::new(&zarr_path).map_err(|e| err(&e))?);
        let array = Array::open(store, ZARR_ARRAY)
            .map_err(|e| err(&format!("tprf.json records an ambient image: {e}")))?;
        let expected = vec![h as u64, w as u64];
        if array.shape() != expected.as_slice() {
            return Err(ExportError::Shape {
                path: zarr_path.join("ambient"),
                shape: array.shape().to_vec(),
                layout: "[H, W]",
                expected,
            });
        }
        if *array.data_type() != zarrs::array::data_type::float32() {
            return Err(err(&"array ambient is not float32"));
        }
        let all = ArraySubset::new_with_ranges(&[0..h as u64, 0..w as u64]);
        array
            .retrieve_array_subset::<Vec<f32>>(&all)
            .map_err(|e| err(&e))?
    } else {
        let (shape, data) = read_npy_f32(&npy)?;
        let expected = vec![h as u64, w as u64];
        if shape != expected {
            return Err(ExportError::Shape {
                path: npy,
                shape,
                layout: "[H, W]",
                expected,
            });
        }
        data
    };
    Ok(Some(data))
}

/// The `ambient` entry of `sensor.json`: the image, its mean, `ambient_scale` with its
/// unit, what each gate adds per unit of radiance, and whether it was added (an AMCW
/// sensor without `ambient_exposure_s` cannot take it: the reason).
pub fn sensor_json(
    model: &SensorModel,
    image: &[f32],
    added: Result<(), String>,
) -> serde_json::Value {
    let mean =
        image.iter().map(|&v| f64::from(v.max(0.0))).sum::<f64>() / image.len().max(1) as f64;
    let s = model.sensor();
    let weights = model.ambient_weights_s().ok();
    serde_json::json!({
        "image": "the cube's ambient image A (ambient.npy or tprf.zarr/ambient), W m^-2 sr^-1",
        "mean_radiance": mean,
        "ambient_scale": {"value": s.ambient_scale, "unit": "dimensionless (1: the ambient light group at the power the scene states)"},
        "ambient_exposure_s": {"value": s.ambient_exposure_s, "unit": "s per unit of emitted energy (AMCW gates only)"},
        "model": "M_i[p] += ambient_scale A[p] integral Exposure_i(t) dt (radiance x s, the unit of a measurement), before the noise; a SPAD counts ambient_scale photons_per_unit A[p] photons/s more in every TDC bin",
        "gate_weights_s": weights,
        "added": added.is_ok(),
        "not_added_because": added.err(),
    })
}

//! Cubes too large for one dense array: `tprf.zarr`, a Zarr v3 array `[H, W, T]` of
//! float32 (fill value 0, chunks of [`CHUNK`] = 32 x 32 pixels x 256 bins, zstd), which
//! zarr-python, xarray and dask open directly. A pixel tile or a time range reads alone;
//! chunks where no light arrived are not written at all. The cube's metadata is in the
//! array's attributes under `"tprf"`, and in `tprf.json` beside it as for `tprf.npy`.

use super::CubeMetadata;
use super::ExportError;
use crate::film::{FilmLayout, FilmSnapshot, SnapshotBuilder};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use zarrs::array::{Array, ArrayBuilder};
use zarrs::filesystem::FilesystemStore;

/// Chunk shape `[rows, columns, bins]`.
pub const CHUNK: [u64; 3] = [32, 32, 256];

/// The folder name of the array inside a render folder.
pub const ZARR_NAME: &str = "tprf.zarr";

type Result<T> = std::result::Result<T, ExportError>;

/// A Zarr library error, with the array it concerns.
fn zarr_err(path: &Path) -> impl Fn(&dyn std::fmt::Display) -> ExportError + '_ {
    move |e| ExportError::Zarr {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Write `snap`'s cube (the total, not the bounce layers) as a Zarr v3 array at `path`
/// (a folder, replaced), with `meta` in its attributes. Tiles of 32 x 32 pixels are made
/// dense one at a time from the stored runs, on the rayon pool.
pub fn write_snapshot_zarr(path: &Path, snap: &FilmSnapshot, meta: &CubeMetadata) -> Result<()> {
    let (w, h, t) = (snap.width(), snap.height(), snap.axis().bins);
    if path.exists() {
        std::fs::remove_dir_all(path).map_err(|source| ExportError::Create {
            path: path.to_path_buf(),
            source,
        })?;
    }
    let store = Arc::new(FilesystemStore::new(path).map_err(|e| zarr_err(path)(&e))?);
    let mut attributes = serde_json::Map::new();
    attributes.insert(
        "tprf".into(),
        serde_json::to_value(meta).map_err(|e| zarr_err(path)(&e))?,
    );
    let mut builder = ArrayBuilder::new(
        vec![h as u64, w as u64, t as u64],
        CHUNK.to_vec(),
        zarrs::array::data_type::float32(),
        0.0f32,
    );
    builder
        .bytes_to_bytes_codecs(vec![Arc::new(zarrs::array::codec::ZstdCodec::new(
            3, false,
        ))])
        .dimension_names(Some(["y", "x", "t"]))
        .attributes(attributes);
    let array = builder.build(store, "/").map_err(|e| zarr_err(path)(&e))?;
    array.store_metadata().map_err(|e| zarr_err(path)(&e))?;
    let [cy, cx, ct] = CHUNK.map(|c| c as usize);
    let tiles: Vec<(usize, usize)> = (0..h.div_ceil(cy))
        .flat_map(|ty| (0..w.div_ceil(cx)).map(move |tx| (ty, tx)))
        .collect();
    tiles
        .into_par_iter()
        .try_for_each(|(ty, tx)| -> Result<()> {
            // The tile, all bins: [cy, cx, T].
            let mut tile = vec![0f32; cy * cx * t];
            let mut lit = false;
            for dy in 0..cy {
                for dx in 0..cx {
                    let (x, y) = (tx * cx + dx, ty * cy + dy);
                    let base = (dy * cx + dx) * t;
                    snap.for_each_run(x, y, |start, run| {
                        lit = true;
                        if let Some(dst) = tile.get_mut(base + start..base + start + run.len()) {
                            dst.copy_from_slice(run);
                        }
                    });
                }
            }
            if !lit {
                return Ok(());
            }
            let mut chunk = vec![0f32; cy * cx * ct];
            for tc in 0..t.div_ceil(ct) {
                chunk.fill(0.0);
                let mut any = false;
                for p in 0..cy * cx {
                    let from = p * t + tc * ct;
                    let n = ct.min(t - tc * ct);
                    let src = &tile[from..from + n];
                    if src.iter().any(|v| *v != 0.0) {
                        any = true;
                        chunk[p * ct..p * ct + n].copy_from_slice(src);
                    }
                }
                if any {
                    array
                        .store_chunk(&[ty as u64, tx as u64, tc as u64], &chunk[..])
                        .map_err(|e| zarr_err(path)(&e))?;
                }
            }
            Ok(())
        })
}

/// An opened `tprf.zarr`: its shape and metadata, read tile by tile.
pub struct ZarrCube {
    array: Array<FilesystemStore>,
    pub meta: CubeMetadata,
    pub width: usize,
    pub height: usize,
    pub bins: usize,
}

impl ZarrCube {
    /// Open the array at `path` and check it against the metadata in its attributes.
    pub fn open(path: &Path) -> Result<ZarrCube> {
        let store = Arc::new(FilesystemStore::new(path).map_err(|e| zarr_err(path)(&e))?);
        let array = Array::open(store, "/").map_err(|e| zarr_err(path)(&e))?;
        let err = zarr_err(path);
        let attrs = array
            .attributes()
            .get("tprf")
            .cloned()
            .ok_or_else(|| err(&"no \"tprf\" attributes (not written by tprf)"))?;
        let meta: CubeMetadata = serde_json::from_value(attrs)
            .map_err(|e| err(&format!("the \"tprf\" attributes are not tprf.json: {e}")))?;
        meta.check_not_empty(path)?;
        let shape = array.shape().to_vec();
        let want = [meta.height as u64, meta.width as u64, meta.bins as u64];
        if shape != want {
            return Err(ExportError::Shape {
                path: path.to_path_buf(),
                shape,
                layout: "[H, W, T]",
                expected: want.to_vec(),
            });
        }
        Ok(ZarrCube {
            width: meta.width,
            height: meta.height,
            bins: meta.bins,
            meta,
            array,
        })
    }

    /// The tiles of the cube: `(first row, first column, rows, columns)`.
    pub fn tiles(&self) -> Vec<(usize, usize, usize, usize)> {
        let [cy, cx, _] = CHUNK.map(|c| c as usize);
        (0..self.height.div_ceil(cy))
            .flat_map(|ty| {
                (0..self.width.div_ceil(cx)).map(move |tx| {
                    let (y0, x0) = (ty * cy, tx * cx);
                    (y0, x0, cy.min(self.height - y0), cx.min(self.width - x0))
                })
            })
            .collect()
    }

    /// The pixels `[y0, y0 + rows) x [x0, x0 + cols)`, all bins: dense `[rows, cols, T]`.
    pub fn read_tile(&self, y0: usize, x0: usize, rows: usize, cols: usize) -> Result<Vec<f32>> {
        let subset = zarrs::array::ArraySubset::new_with_ranges(&[
            y0 as u64..(y0 + rows) as u64,
            x0 as u64..(x0 + cols) as u64,
            0..self.bins as u64,
        ]);
        self.array
            .retrieve_array_subset::<Vec<f32>>(&subset)
            .map_err(|e| ExportError::Zarr {
                path: PathBuf::from(ZARR_NAME),
                message: e.to_string(),
            })
    }

    /// The whole cube as a snapshot that keeps only the bins that received light.
    pub fn snapshot(&self) -> Result<FilmSnapshot> {
        let axis = self.meta.axis().map_err(|source| ExportError::Axis {
            path: PathBuf::from(ZARR_NAME),
            source,
        })?;
        let layout = FilmLayout {
            width: self.width,
            height: self.height,
            axis,
            bounces_separate: 0,
        };
        let mut builder = SnapshotBuilder::new(layout);
        let t = self.bins;
        for (y0, x0, rows, cols) in self.tiles() {
            let tile = self.read_tile(y0, x0, rows, cols)?;
            for dy in 0..rows {
                for dx in 0..cols {
                    let p = (dy * cols + dx) * t;
                    builder.push_pixel(x0 + dx, y0 + dy, tile.get(p..p + t).unwrap_or(&[]));
                }
            }
        }
        Ok(builder.finish(self.meta.spp, self.meta.passes, self.meta.error_estimate))
    }
}

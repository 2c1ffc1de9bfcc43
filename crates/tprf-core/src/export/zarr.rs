//! Cubes too large for one dense array: `tprf.zarr`, a Zarr v3 group that zarr-python,
//! xarray (`xr.open_zarr`) and dask open directly. It holds
//!
//! - `cube`: float32 `[H, W, T]` (dimensions `y`, `x`, `t`), chunks of [`CHUNK`] =
//!   32 x 32 pixels x 256 bins;
//! - `bounces`, when the render kept per-bounce layers: float32 `[L, H, W, T]`
//!   (dimensions `layer`, `y`, `x`, `t`; layer 0 = light seen directly, 1..=K = that
//!   many scattering events, K+1 = more, as `tprf_bounces.npy`), chunks of one layer and
//!   the same pixel tile and bins;
//!
//! both with fill value 0 and zstd. A pixel tile or a time range reads alone, and chunks
//! where no light arrived are not written at all. The cube's metadata is in the group's
//! attributes under `"tprf"`, and in `tprf.json` beside it as for `tprf.npy`.

use super::CubeMetadata;
use super::ExportError;
use crate::film::{FilmLayout, FilmSnapshot, SnapshotBuilder};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use zarrs::array::{Array, ArrayBuilder, ArraySubset};
use zarrs::filesystem::FilesystemStore;
use zarrs::group::{Group, GroupBuilder};

/// Chunk shape `[rows, columns, bins]` (of each layer, for `bounces`).
pub const CHUNK: [u64; 3] = [32, 32, 256];

/// The folder name of the group inside a render folder.
pub const ZARR_NAME: &str = "tprf.zarr";

/// The arrays' paths in the group.
const CUBE: &str = "/cube";
const BOUNCES: &str = "/bounces";

type Result<T> = std::result::Result<T, ExportError>;

/// A Zarr library error, with the array it concerns.
fn zarr_err(path: &Path) -> impl Fn(&dyn std::fmt::Display) -> ExportError + '_ {
    move |e| ExportError::Zarr {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Write `snap` as a Zarr v3 group at `path` (a folder, replaced): the cube, and its
/// bounce layers when the snapshot has them, with `meta` in the group's attributes.
/// Each pixel tile's stored runs are cut at the chunks' time boundaries, and only the
/// chunks that received a run are made dense, compressed and written; tiles are
/// encoded in parallel on the rayon pool.
pub fn write_snapshot_zarr(path: &Path, snap: &FilmSnapshot, meta: &CubeMetadata) -> Result<()> {
    let err = zarr_err(path);
    let (w, h, t) = (
        snap.width() as u64,
        snap.height() as u64,
        snap.axis().bins as u64,
    );
    if path.exists() {
        std::fs::remove_dir_all(path).map_err(|source| ExportError::Create {
            path: path.to_path_buf(),
            source,
        })?;
    }
    let store = Arc::new(FilesystemStore::new(path).map_err(|e| err(&e))?);
    let mut attributes = serde_json::Map::new();
    attributes.insert(
        "tprf".into(),
        serde_json::to_value(meta).map_err(|e| err(&e))?,
    );
    let group = GroupBuilder::new()
        .attributes(attributes)
        .build(store.clone(), "/")
        .map_err(|e| err(&e))?;
    group.store_metadata().map_err(|e| err(&e))?;
    let array = |shape: Vec<u64>, chunk: Vec<u64>, dims: &[&str], at: &str| {
        let mut builder =
            ArrayBuilder::new(shape, chunk, zarrs::array::data_type::float32(), 0.0f32);
        builder
            .bytes_to_bytes_codecs(vec![Arc::new(zarrs::array::codec::ZstdCodec::new(
                3, false,
            ))])
            .dimension_names(Some(dims.iter().map(|d| d.to_string())));
        let array = builder.build(store.clone(), at).map_err(|e| err(&e))?;
        array.store_metadata().map_err(|e| err(&e))?;
        Ok::<_, ExportError>(array)
    };
    let cube = array(vec![h, w, t], CHUNK.to_vec(), &["y", "x", "t"], CUBE)?;
    write_runs(path, &cube, snap, None)?;
    let layers = snap.layers();
    if layers > 0 {
        let mut chunk = vec![1];
        chunk.extend(CHUNK);
        let bounces = array(
            vec![layers as u64, h, w, t],
            chunk,
            &["layer", "y", "x", "t"],
            BOUNCES,
        )?;
        for l in 0..layers {
            write_runs(path, &bounces, snap, Some(l))?;
        }
    }
    Ok(())
}

/// One piece of a stored run inside one time chunk: the pixel in its tile, the first
/// bin in the chunk, and the values' range in the tile's value buffer.
#[derive(Clone, Copy)]
struct Piece {
    pixel: u32,
    bin: u32,
    values: (u32, u32),
}

/// The chunks of `array` holding the total (`layer` `None`) or bounce layer `l` of
/// `snap`: per 32 x 32 tile (in parallel), its pixels' runs cut into the time chunks
/// they touch; each touched chunk is zero-filled, given its pieces, and stored.
fn write_runs(
    path: &Path,
    array: &Array<FilesystemStore>,
    snap: &FilmSnapshot,
    layer: Option<usize>,
) -> Result<()> {
    let (w, h, t) = (snap.width(), snap.height(), snap.axis().bins);
    let [cy, cx, ct] = CHUNK.map(|c| c as usize);
    let time_chunks = t.div_ceil(ct);
    let tiles: Vec<(usize, usize)> = (0..h.div_ceil(cy))
        .flat_map(|ty| (0..w.div_ceil(cx)).map(move |tx| (ty, tx)))
        .collect();
    tiles.into_par_iter().try_for_each_init(
        || (Vec::new(), vec![Vec::new(); time_chunks], Vec::new()),
        |(values, buckets, chunk): &mut (Vec<f32>, Vec<Vec<Piece>>, Vec<f32>),
         (ty, tx)|
         -> Result<()> {
            values.clear();
            buckets.iter_mut().for_each(Vec::clear);
            for dy in 0..cy {
                for dx in 0..cx {
                    let (x, y) = (tx * cx + dx, ty * cy + dy);
                    let pixel = (dy * cx + dx) as u32;
                    let mut take = |start: usize, run: &[f32]| {
                        let base = values.len();
                        values.extend_from_slice(run);
                        // Cut the run at the chunks' time boundaries.
                        let mut b = start;
                        let end = start + run.len();
                        while b < end {
                            let tc = b / ct;
                            let stop = end.min((tc + 1) * ct);
                            if let Some(bucket) = buckets.get_mut(tc) {
                                bucket.push(Piece {
                                    pixel,
                                    bin: (b - tc * ct) as u32,
                                    values: (
                                        (base + b - start) as u32,
                                        (base + stop - start) as u32,
                                    ),
                                });
                            }
                            b = stop;
                        }
                    };
                    match layer {
                        None => snap.for_each_run(x, y, &mut take),
                        Some(l) => snap.for_each_layer_run(l, x, y, &mut take),
                    }
                }
            }
            for (tc, pieces) in buckets.iter().enumerate() {
                if pieces.is_empty() {
                    continue;
                }
                chunk.clear();
                chunk.resize(cy * cx * ct, 0.0);
                for p in pieces {
                    let at = p.pixel as usize * ct + p.bin as usize;
                    let src = &values[p.values.0 as usize..p.values.1 as usize];
                    if let Some(dst) = chunk.get_mut(at..at + src.len()) {
                        dst.copy_from_slice(src);
                    }
                }
                let mut index = Vec::with_capacity(4);
                index.extend(layer.map(|l| l as u64));
                index.extend([ty as u64, tx as u64, tc as u64]);
                array
                    .store_chunk(&index, &chunk[..])
                    .map_err(|e| zarr_err(path)(&e))?;
            }
            Ok(())
        },
    )
}

/// An opened `tprf.zarr`: its shape and metadata, read tile by tile.
pub struct ZarrCube {
    cube: Array<FilesystemStore>,
    bounces: Option<Array<FilesystemStore>>,
    /// The group's folder.
    pub path: PathBuf,
    pub meta: CubeMetadata,
    pub width: usize,
    pub height: usize,
    pub bins: usize,
}

impl ZarrCube {
    /// Open the group at `path` and check its arrays against the metadata in its
    /// attributes.
    pub fn open(path: &Path) -> Result<ZarrCube> {
        let err = zarr_err(path);
        let store = Arc::new(FilesystemStore::new(path).map_err(|e| err(&e))?);
        let group = Group::open(store.clone(), "/").map_err(|e| {
            err(&format!(
                "not a Zarr v3 group written by tprf (a group holding \"cube\"): {e}"
            ))
        })?;
        let attrs = group
            .attributes()
            .get("tprf")
            .cloned()
            .ok_or_else(|| err(&"no \"tprf\" attributes (not written by tprf)"))?;
        let meta: CubeMetadata = serde_json::from_value(attrs)
            .map_err(|e| err(&format!("the \"tprf\" attributes are not tprf.json: {e}")))?;
        meta.check_not_empty(path)?;
        let cube = Array::open(store.clone(), CUBE)
            .map_err(|e| err(&format!("its array \"cube\": {e}")))?;
        let (h, w, t) = (meta.height as u64, meta.width as u64, meta.bins as u64);
        check_shape(path, &cube, "[H, W, T]", vec![h, w, t])?;
        check_f32(path, &cube)?;
        let bounces = if meta.bounces_separate > 0 {
            let b = Array::open(store, BOUNCES).map_err(|e| {
                err(&format!(
                    "bounces_separate is {} but its array \"bounces\" cannot be opened: {e}",
                    meta.bounces_separate
                ))
            })?;
            let l = meta.bounces_separate as u64 + 2;
            check_shape(path, &b, "[layers, H, W, T]", vec![l, h, w, t])?;
            check_f32(path, &b)?;
            Some(b)
        } else {
            None
        };
        Ok(ZarrCube {
            width: meta.width,
            height: meta.height,
            bins: meta.bins,
            path: path.to_path_buf(),
            meta,
            cube,
            bounces,
        })
    }

    /// Per-bounce layers held (0 when the render kept none).
    pub fn layers(&self) -> usize {
        self.bounces
            .as_ref()
            .and_then(|b| b.shape().first())
            .map_or(0, |&l| l as usize)
    }

    /// The tiles of the cube, one per chunk's pixels: `(first row, first column, rows,
    /// columns)`.
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

    /// The pixels `[y0, y0 + rows) x [x0, x0 + cols)`, all bins, of the total (`layer`
    /// `None`) or of bounce layer `l`: dense `[rows, cols, T]`.
    pub fn read_tile(
        &self,
        y0: usize,
        x0: usize,
        rows: usize,
        cols: usize,
        layer: Option<usize>,
    ) -> Result<Vec<f32>> {
        let mut ranges = Vec::with_capacity(4);
        let array = match layer {
            None => &self.cube,
            Some(l) => {
                let Some(b) = self.bounces.as_ref().filter(|_| l < self.layers()) else {
                    return Err(zarr_err(&self.path)(&format!(
                        "no bounce layer {l} (it holds {})",
                        self.layers()
                    )));
                };
                ranges.push(l as u64..l as u64 + 1);
                b
            }
        };
        ranges.extend([
            y0 as u64..(y0 + rows) as u64,
            x0 as u64..(x0 + cols) as u64,
            0..self.bins as u64,
        ]);
        array
            .retrieve_array_subset::<Vec<f32>>(&ArraySubset::new_with_ranges(&ranges))
            .map_err(|e| zarr_err(&self.path)(&e))
    }

    /// The whole cube, and its bounce layers, as a snapshot that keeps only the bins
    /// that received light; read a chunk's pixels at a time.
    pub fn snapshot(&self) -> Result<FilmSnapshot> {
        let axis = self.meta.axis().map_err(|source| ExportError::Axis {
            path: self.path.clone(),
            source,
        })?;
        let layers = self.layers();
        let layout = FilmLayout {
            width: self.width,
            height: self.height,
            axis,
            bounces_separate: if layers >= 3 { (layers - 2) as u32 } else { 0 },
        };
        let mut builder = SnapshotBuilder::new(layout);
        let t = self.bins;
        for (y0, x0, rows, cols) in self.tiles() {
            let tile = self.read_tile(y0, x0, rows, cols, None)?;
            let layer_tiles = (0..layers)
                .map(|l| self.read_tile(y0, x0, rows, cols, Some(l)))
                .collect::<Result<Vec<_>>>()?;
            for dy in 0..rows {
                for dx in 0..cols {
                    let p = (dy * cols + dx) * t;
                    let pixel_layers: Vec<&[f32]> = layer_tiles
                        .iter()
                        .map(|l| l.get(p..p + t).unwrap_or(&[]))
                        .collect();
                    builder.push_pixel(
                        x0 + dx,
                        y0 + dy,
                        tile.get(p..p + t).unwrap_or(&[]),
                        &pixel_layers,
                    );
                }
            }
        }
        Ok(builder.finish(self.meta.spp, self.meta.passes, self.meta.error_estimate))
    }
}

/// Refuse an array whose shape is not `expected`.
fn check_shape(
    path: &Path,
    array: &Array<FilesystemStore>,
    layout: &'static str,
    expected: Vec<u64>,
) -> Result<()> {
    let shape = array.shape().to_vec();
    if shape != expected {
        return Err(ExportError::Shape {
            path: path.join(array.path().as_str().trim_start_matches('/')),
            shape,
            layout,
            expected,
        });
    }
    Ok(())
}

/// Refuse an array that is not float32.
fn check_f32(path: &Path, array: &Array<FilesystemStore>) -> Result<()> {
    let dt = array.data_type();
    if *dt != zarrs::array::data_type::float32() {
        return Err(zarr_err(path)(&format!(
            "array {} holds {dt:?}; expected float32",
            array.path()
        )));
    }
    Ok(())
}

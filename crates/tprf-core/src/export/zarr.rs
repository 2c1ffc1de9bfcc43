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

/// zstd level of the chunks (the arrays' `zstd` codec, without checksum).
pub(crate) const ZSTD_LEVEL: i32 = 1;

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
    let shape = [
        snap.height() as u64,
        snap.width() as u64,
        snap.axis().bins as u64,
    ];
    let (store, cube, bounces) = create_group(path, meta, shape, snap.layers())?;
    write_runs(path, &store, &cube, snap, None)?;
    if let Some(bounces) = &bounces {
        for l in 0..snap.layers() {
            write_runs(path, &store, bounces, snap, Some(l))?;
        }
    }
    sync_dir(path)
}

/// A group's store, its array `cube`, and `bounces` when it has one.
pub type NewGroup = (
    Arc<FilesystemStore>,
    Array<FilesystemStore>,
    Option<Array<FilesystemStore>>,
);

/// A new, empty `tprf.zarr` group at `path` (a folder, replaced) for a cube of `[H, W,
/// T]` `shape`: the group's metadata with `meta` in its attributes, the array `cube`, and
/// `bounces` when `layers > 0`; no chunks. Its store and arrays, to write chunks into.
pub fn create_group(
    path: &Path,
    meta: &CubeMetadata,
    [h, w, t]: [u64; 3],
    layers: usize,
) -> Result<NewGroup> {
    let err = zarr_err(path);
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
            .array_to_bytes_codec(Arc::new(zarrs::array::codec::BytesCodec::little()))
            .bytes_to_bytes_codecs(vec![Arc::new(zarrs::array::codec::ZstdCodec::new(
                ZSTD_LEVEL, false,
            ))])
            .dimension_names(Some(dims.iter().map(|d| d.to_string())));
        let array = builder.build(store.clone(), at).map_err(|e| err(&e))?;
        array.store_metadata().map_err(|e| err(&e))?;
        Ok::<_, ExportError>(array)
    };
    let cube = array(vec![h, w, t], CHUNK.to_vec(), &["y", "x", "t"], CUBE)?;
    let bounces = if layers > 0 {
        let mut chunk = vec![1];
        chunk.extend(CHUNK);
        Some(array(
            vec![layers as u64, h, w, t],
            chunk,
            &["layer", "y", "x", "t"],
            BOUNCES,
        )?)
    } else {
        None
    };
    Ok((store, cube, bounces))
}

/// Make everything written under the group folder `path` durable
/// (`sync_filesystem`).
pub fn sync_dir(path: &Path) -> Result<()> {
    sync_filesystem(path).map_err(|source| ExportError::Create {
        path: path.to_path_buf(),
        source,
    })
}

/// The folders of the arrays' chunks inside a group: `cube/c` (chunk files
/// `cube/c/Y/X/T`) and `bounces/c` (`bounces/c/L/Y/X/T`), with the position of the
/// row-tile index `Y` in a chunk's index.
pub const CHUNK_DIRS: [(&str, usize); 2] = [("cube/c", 0), ("bounces/c", 1)];

/// Bytes of one decoded chunk (float32, [`CHUNK`]; edge chunks are stored whole).
pub const CHUNK_BYTES: usize = (CHUNK[0] * CHUNK[1] * CHUNK[2] * 4) as usize;

/// Flush what was written under `dir` to disk, in one call for all its files:
/// `syncfs` on Linux, `sync` on other Unixes; nothing elsewhere.
fn sync_filesystem(dir: &Path) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        let folder = std::fs::File::open(dir)?;
        // SAFETY: `folder` is an open file descriptor for the duration of the call.
        if unsafe { libc::syncfs(folder.as_raw_fd()) } != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    #[cfg(all(unix, not(target_os = "linux")))]
    {
        let _ = dir;
        // SAFETY: `sync` takes no arguments and cannot fail.
        unsafe { libc::sync() };
    }
    #[cfg(not(unix))]
    let _ = dir;
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

/// A worker's scratch in [`write_runs`]: the tile's run values, its pieces per time
/// chunk, one chunk's bytes (kept zeroed), and its zstd context.
type TileScratch = (
    Vec<f32>,
    Vec<Vec<Piece>>,
    Vec<u8>,
    std::io::Result<zstd::bulk::Compressor<'static>>,
);

/// The chunks of `array` holding the total (`layer` `None`) or bounce layer `l` of
/// `snap`: per 32 x 32 tile (in parallel), its pixels' runs cut into the time chunks
/// they touch; each touched chunk is zero-filled, given its pieces, and stored.
///
/// The chunks are encoded here, as the arrays' codecs say (float32 little-endian
/// bytes, then zstd at [`ZSTD_LEVEL`]), with one zstd context per worker, and written
/// as plain files at the array's chunk keys; [`sync_filesystem`] makes them durable
/// once at the end. Through zarrs' store each chunk made a new zstd context and was
/// `fsync`ed on its own, which took 3.5 min for the 115 k chunks of a 15 s render
/// (`builtin:canopy` at 2048 x 2048 x 16384, 1 spp).
fn write_runs(
    path: &Path,
    store: &FilesystemStore,
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
    let zstd_err = |e: &std::io::Error| zarr_err(path)(&format!("zstd: {e}"));
    tiles.into_par_iter().try_for_each_init(
        || {
            (
                Vec::new(),
                vec![Vec::new(); time_chunks],
                Vec::new(),
                zstd::bulk::Compressor::new(ZSTD_LEVEL),
            )
        },
        |(values, buckets, chunk, compressor): &mut TileScratch, (ty, tx)| -> Result<()> {
            let compressor = compressor.as_mut().map_err(|e| zstd_err(e))?;
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
                // All zeros here (zeroed once, and put back after each use below).
                chunk.resize(cy * cx * ct * 4, 0);
                for p in pieces {
                    let at = (p.pixel as usize * ct + p.bin as usize) * 4;
                    let src = &values[p.values.0 as usize..p.values.1 as usize];
                    if let Some(dst) = chunk.get_mut(at..at + 4 * src.len()) {
                        for (d, v) in dst.chunks_exact_mut(4).zip(src) {
                            d.copy_from_slice(&v.to_le_bytes());
                        }
                    }
                }
                let encoded = compressor.compress(chunk).map_err(|e| zstd_err(&e))?;
                for p in pieces {
                    let at = (p.pixel as usize * ct + p.bin as usize) * 4;
                    let len = 4 * (p.values.1 - p.values.0) as usize;
                    if let Some(dst) = chunk.get_mut(at..at + len) {
                        dst.fill(0);
                    }
                }
                let mut index = Vec::with_capacity(4);
                index.extend(layer.map(|l| l as u64));
                index.extend([ty as u64, tx as u64, tc as u64]);
                let file = store.key_to_fspath(&array.chunk_key(&index));
                if let Some(dir) = file.parent() {
                    std::fs::create_dir_all(dir).map_err(|source| ExportError::Create {
                        path: dir.to_path_buf(),
                        source,
                    })?;
                }
                std::fs::write(&file, &encoded).map_err(|source| ExportError::Create {
                    path: file.clone(),
                    source,
                })?;
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
        let lum = self.meta.luminescence_layer && layers >= 4;
        let layout = FilmLayout {
            width: self.width,
            height: self.height,
            axis,
            bounces_separate: match layers - usize::from(lum) {
                l if l >= 3 => (l - 2) as u32,
                _ => 0,
            },
            luminescence: lum,
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

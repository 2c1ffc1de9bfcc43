//! Shards of one render and their merge: `tprf render --shard K/N` renders a
//! deterministic, disjoint part of the image, and [`merge`] puts the N parts together
//! into the cube one machine would have written, bit for bit.
//!
//! **The split is by rows, not by samples.** The film's f64 bin sums grow pass by pass
//! (`new = old + pass`); float addition is not associative, so N shards each holding
//! some passes could not be summed back into one machine's bits. A pixel's sums, though,
//! depend only on the seed, the pass schedule and the pixel (its samples are a
//! scrambled Sobol stream keyed by seed, half, pixel and sample index, and a row is
//! built from its own old row alone): a shard that renders some rows with the same
//! schedule holds exactly those rows of the whole render. The image is cut into bands
//! of [`ShardSpec::band_rows`] rows (a multiple of the Zarr chunk height for a Zarr
//! cube, so each chunk has one owner), dealt round-robin (band `b` to shard `b mod N`)
//! so every shard gets rows from the whole image (light is rarely even over it).
//!
//! A shard folder is a normal cube folder (its other rows are zero: holes in `tprf.npy`,
//! absent chunks in `tprf.zarr`) whose `tprf.json` has a [`ShardInfo`] section: what the
//! merge checks the shards against each other with, its rows' two-half error terms
//! (the merged error estimate is the whole render's, bit for bit), and `shard_steady.npy`
//! beside it (float64 `[H, W]`, the steady image's sums, for the merged `steady.png`).

use super::{CubeMetadata, ExportError};
use crate::film::{StoreStats, TimeFilter, half_error_from_terms};
use npyz::WriterBuilder;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// The steady image's f64 values of a shard (`[H, W]`, zeros outside its rows).
pub const STEADY_NAME: &str = "shard_steady.npy";

/// Why shards cannot be made or merged. Each message names the shard (its index and
/// folder) and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    #[error(transparent)]
    Export(#[from] ExportError),
    #[error(transparent)]
    Budget(#[from] crate::budget::BudgetError),
    #[error("--shard must be K/N with 0 <= K < N (got '{given}')")]
    Spec { given: String },
    #[error(
        "{height} rows in bands of {band_rows} make {bands} band(s), fewer than the {n} shards: \
         use fewer shards or smaller bands (--band-rows)"
    )]
    FewBands {
        height: usize,
        band_rows: usize,
        bands: usize,
        n: usize,
    },
    #[error("--band-rows must be at least 1")]
    NoBandRows,
    #[error("no shard folders given")]
    NoShards,
    #[error(
        "{dir} is not a shard: its tprf.json has no \"shard\" section (render it with --shard K/N)"
    )]
    NotAShard { dir: PathBuf },
    #[error("shard {k} is given twice: {first} and {second}")]
    Duplicate {
        k: usize,
        first: PathBuf,
        second: PathBuf,
    },
    #[error("shard {k} of {n} is missing (given: {given})")]
    Missing { k: usize, n: usize, given: String },
    #[error("{0}")]
    Mismatch(Box<FieldMismatch>),
    #[error("shard {k} ({dir}): {message}")]
    Broken {
        k: usize,
        dir: PathBuf,
        message: String,
    },
    #[error("cannot read the scene file {path} for its fingerprint")]
    SceneFile {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

type Result<T> = std::result::Result<T, ShardError>;

/// Two shards that differ in a field every shard of one render shares.
#[derive(Debug, thiserror::Error)]
#[error("shard {k} ({dir}) has {field} {value}, shard {k0} ({dir0}) has {field} {value0}")]
pub struct FieldMismatch {
    pub field: &'static str,
    pub k: usize,
    pub dir: PathBuf,
    pub value: String,
    pub k0: usize,
    pub dir0: PathBuf,
    pub value0: String,
}

/// Which part of the image a shard renders: bands of `band_rows` rows, band `b` going to
/// shard `b mod n`; this is shard `k`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShardSpec {
    pub k: usize,
    pub n: usize,
    pub band_rows: usize,
}

/// Rows per band by default: the Zarr chunk height.
pub const DEFAULT_BAND_ROWS: usize = super::zarr::CHUNK[0] as usize;

impl ShardSpec {
    /// `"K/N"` (0 <= K < N) with bands of `band_rows` rows.
    pub fn parse(text: &str, band_rows: usize) -> Result<ShardSpec> {
        let spec_err = || ShardError::Spec {
            given: text.to_string(),
        };
        let (k, n) = text.trim().split_once('/').ok_or_else(spec_err)?;
        let k: usize = k.trim().parse().map_err(|_| spec_err())?;
        let n: usize = n.trim().parse().map_err(|_| spec_err())?;
        if n == 0 || k >= n {
            return Err(spec_err());
        }
        if band_rows == 0 {
            return Err(ShardError::NoBandRows);
        }
        Ok(ShardSpec { k, n, band_rows })
    }

    /// Bands of an image `height` rows high.
    pub fn bands(&self, height: usize) -> usize {
        height.div_ceil(self.band_rows.max(1))
    }

    /// The shard that renders row `y`.
    pub fn owner(&self, y: usize) -> usize {
        (y / self.band_rows.max(1)) % self.n.max(1)
    }

    /// Per row of an image `height` rows high, whether this shard renders it.
    pub fn rows(&self, height: usize) -> Vec<bool> {
        (0..height).map(|y| self.owner(y) == self.k).collect()
    }

    /// Refuse a split that leaves a shard without rows.
    pub fn check(&self, height: usize) -> Result<()> {
        let bands = self.bands(height);
        if bands < self.n {
            return Err(ShardError::FewBands {
                height,
                band_rows: self.band_rows,
                bands,
                n: self.n,
            });
        }
        Ok(())
    }
}

/// The `shard` section of a shard's `tprf.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardInfo {
    /// This shard's index, 0-based.
    pub k: usize,
    /// Number of shards.
    pub n: usize,
    /// Rows per band (band `b` is rendered by shard `b mod n`).
    pub band_rows: usize,
    /// The rows rendered, as ranges `[first, end)`.
    pub rows: Vec<[usize; 2]>,
    /// Samples per pixel in each half of the film (even and odd passes).
    pub half_spp: [u64; 2],
    /// The scene: `builtin:NAME`, or a hash of the scene file's bytes.
    pub scene_fingerprint: String,
    /// The film's time filter.
    pub filter: TimeFilter,
    /// How the cube is written: `npy` or `zarr`.
    pub format: String,
    /// Per rendered row, in row order: the two sums of the two-half error estimate
    /// (`sum (a/n_a - b/n_b)^2`, `sum ((a+b)/n)^2`), printed so they read back exactly.
    pub row_error_terms: Vec<[f64; 2]>,
    /// Bytes of the film's list of rows, counted in this shard's `store.bytes` (and once
    /// in a merged cube's).
    pub store_list_bytes: u64,
}

impl ShardInfo {
    /// The ranges `[first, end)` of the rows `spec` gives an image `height` rows high.
    pub fn row_ranges(spec: &ShardSpec, height: usize) -> Vec<[usize; 2]> {
        (0..spec.bands(height))
            .filter(|b| b % spec.n == spec.k)
            .map(|b| [b * spec.band_rows, ((b + 1) * spec.band_rows).min(height)])
            .collect()
    }
}

/// What identifies scene `spec` (a `.gltf`/`.glb` path or `builtin:NAME`) across
/// machines: `builtin:NAME` as given, or `fnv1a64:HASH:BYTES` of the file's bytes (a
/// path may differ between nodes; the bytes may not). Buffers and textures a `.gltf`
/// names in other files are not in the hash.
pub fn scene_fingerprint(spec: &str) -> Result<String> {
    if spec.starts_with("builtin:") {
        return Ok(spec.to_string());
    }
    let path = Path::new(spec);
    let err = |source| ShardError::SceneFile {
        path: path.to_path_buf(),
        source,
    };
    let mut file = File::open(path).map_err(err)?;
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut len = 0u64;
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let got = file.read(&mut buf).map_err(err)?;
        if got == 0 {
            break;
        }
        len += got as u64;
        for &b in &buf[..got] {
            hash = (hash ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    Ok(format!("fnv1a64:{hash:016x}:{len}"))
}

/// Write a shard's steady sums: float64 `[H, W]` (`steady`, row-major).
pub fn write_steady(
    dir: &Path,
    width: usize,
    height: usize,
    steady: &[f64],
) -> std::result::Result<(), ExportError> {
    super::write_atomic(&dir.join(STEADY_NAME), |w| {
        let mut npy = npyz::WriteOptions::<f64>::new()
            .default_dtype()
            .shape(&[height as u64, width as u64])
            .writer(w)
            .begin_nd()?;
        npy.extend(steady.iter().copied())?;
        npy.finish()?;
        Ok(())
    })
}

/// A shard folder read for merging.
#[derive(Clone, Debug)]
pub struct Shard {
    pub dir: PathBuf,
    pub meta: CubeMetadata,
    pub info: ShardInfo,
}

/// Read a shard folder's `tprf.json`; refuse one without a shard section.
pub fn read_shard(dir: &Path) -> Result<Shard> {
    let meta = super::read_metadata(&dir.join("tprf.json"))?;
    let info = meta.shard.clone().ok_or_else(|| ShardError::NotAShard {
        dir: dir.to_path_buf(),
    })?;
    Ok(Shard {
        dir: dir.to_path_buf(),
        meta,
        info,
    })
}

/// An f64 in its shortest exact form: two values print alike only when they are equal
/// (`-0.0` and `0.0` told apart).
fn exact(x: f64) -> String {
    format!("{x:e}")
}

/// The fields every shard of one render has equal: `(name, value)`.
fn fingerprint(s: &Shard) -> Vec<(&'static str, String)> {
    let (m, i) = (&s.meta, &s.info);
    vec![
        ("shard count n", i.n.to_string()),
        ("scene", i.scene_fingerprint.clone()),
        ("seed", m.seed.to_string()),
        ("width", m.width.to_string()),
        ("height", m.height.to_string()),
        ("bins", m.bins.to_string()),
        ("t0_s", exact(m.t0_s)),
        ("dt_s", exact(m.dt_s)),
        ("spp", m.spp.to_string()),
        ("half_spp", format!("{:?}", i.half_spp)),
        ("passes", m.passes.to_string()),
        ("filter", i.filter.name().to_string()),
        ("bounces_separate", m.bounces_separate.to_string()),
        ("channel", m.channel.clone()),
        ("max_bounces", m.max_bounces.to_string()),
        ("band_rows", i.band_rows.to_string()),
        ("format", i.format.clone()),
    ]
}

/// Check a set of shards: the same render (every field of `fingerprint` equal), each
/// of `0..n` exactly once, each holding the rows its index gives. Returns them ordered
/// by index.
pub fn check_set(mut shards: Vec<Shard>) -> Result<Vec<Shard>> {
    let Some(first) = shards.first() else {
        return Err(ShardError::NoShards);
    };
    let reference = fingerprint(first);
    for s in &shards[1..] {
        for ((field, v0), (_, v)) in reference.iter().zip(fingerprint(s)) {
            if *v0 != v {
                return Err(ShardError::Mismatch(Box::new(FieldMismatch {
                    field,
                    k: s.info.k,
                    dir: s.dir.clone(),
                    value: v,
                    k0: first.info.k,
                    dir0: first.dir.clone(),
                    value0: v0.clone(),
                })));
            }
        }
    }
    let n = first.info.n;
    let mut by_k: BTreeMap<usize, &Shard> = BTreeMap::new();
    for s in &shards {
        if s.info.k >= n {
            return Err(ShardError::Broken {
                k: s.info.k,
                dir: s.dir.clone(),
                message: format!("its index is not below the shard count {n}"),
            });
        }
        if let Some(other) = by_k.insert(s.info.k, s) {
            return Err(ShardError::Duplicate {
                k: s.info.k,
                first: other.dir.clone(),
                second: s.dir.clone(),
            });
        }
    }
    let given = by_k.keys().map(|k| k.to_string()).collect::<Vec<_>>();
    if let Some(k) = (0..n).find(|k| !by_k.contains_key(k)) {
        return Err(ShardError::Missing {
            k,
            n,
            given: given.join(", "),
        });
    }
    for s in &shards {
        let spec = ShardSpec {
            k: s.info.k,
            n,
            band_rows: s.info.band_rows,
        };
        let broken = |message: String| ShardError::Broken {
            k: s.info.k,
            dir: s.dir.clone(),
            message,
        };
        // Counted before any list of that length is made: a tprf.json can claim any size.
        let bands = spec.bands(s.meta.height);
        let own_bands = bands.saturating_sub(spec.k).div_ceil(n);
        if spec.band_rows == 0 || s.info.rows.len() != own_bands {
            return Err(broken(format!(
                "it lists {} bands of rows; shard {} of {n} of an image {} rows high in bands of {} has {own_bands}",
                s.info.rows.len(),
                s.info.k,
                s.meta.height,
                s.info.band_rows
            )));
        }
        let expected = ShardInfo::row_ranges(&spec, s.meta.height);
        if s.info.rows != expected {
            return Err(broken(format!(
                "its rows {:?} are not shard {} of {n}'s bands of {} rows ({expected:?})",
                s.info.rows, s.info.k, s.info.band_rows
            )));
        }
        let rows: usize = expected.iter().map(|r| r[1] - r[0]).sum();
        if s.info.row_error_terms.len() != rows {
            return Err(broken(format!(
                "it records error terms for {} rows, it rendered {rows}",
                s.info.row_error_terms.len()
            )));
        }
    }
    // Every row's bytes and the cube's planes, before a merge allocates them.
    let m = &first.meta;
    let row_bytes = (m.width as u64)
        .checked_mul(m.bins as u64)
        .and_then(|v| v.checked_mul(8));
    let pixels = (m.width as u64).checked_mul(m.height as u64);
    let need = row_bytes.zip(pixels.and_then(|p| p.checked_mul(16)));
    let Some((row_bytes, steady_bytes)) = need else {
        return Err(ShardError::Broken {
            k: first.info.k,
            dir: first.dir.clone(),
            message: format!("its size {} x {} x {} overflows", m.width, m.height, m.bins),
        });
    };
    crate::budget::check(
        row_bytes.saturating_add(steady_bytes),
        "the merge",
        format_args!(
            "rows of {} x {} pixels x {} bins",
            m.width, m.height, m.bins
        ),
    )?;
    shards.sort_by_key(|s| s.info.k);
    Ok(shards)
}

/// The merged cube's `tprf.json`: what one machine would have written (timings apart:
/// `wall_seconds` and `render_seconds` are the shards' sums, `threads` shard 0's),
/// without a shard section. `shards` are checked and ordered ([`check_set`]).
pub fn merged_metadata(shards: &[Shard]) -> Result<CubeMetadata> {
    let first = shards.first().ok_or(ShardError::NoShards)?;
    let spec = ShardSpec {
        k: 0,
        n: first.info.n,
        band_rows: first.info.band_rows,
    };
    let height = first.meta.height;
    // Row y's terms are the next of its owner's list (rows in order).
    let mut next = vec![0usize; shards.len()];
    let mut terms = Vec::with_capacity(height);
    for y in 0..height {
        let o = spec.owner(y);
        let t = shards[o].info.row_error_terms[next[o]];
        next[o] += 1;
        terms.push((t[0], t[1]));
    }
    let mut meta = first.meta.clone();
    meta.shard = None;
    // The merged cube is the request's without its shard: what renders it in one
    // process.
    if let Some(serde_json::Value::Object(request)) = &mut meta.request {
        request.remove("shard");
    }
    meta.error_estimate = half_error_from_terms(first.info.half_spp, terms);
    meta.wall_seconds = shards.iter().map(|s| s.meta.wall_seconds).sum();
    meta.render_seconds = shards.iter().map(|s| s.meta.render_seconds).sum();
    meta.rays_traced = shards.iter().map(|s| s.meta.rays_traced).sum();
    meta.paths_traced = shards.iter().map(|s| s.meta.paths_traced).sum();
    let mut left_out = crate::film::LeftOutCounts::default();
    for s in shards {
        left_out += s.meta.left_out;
    }
    meta.left_out = left_out;
    let list = first.info.store_list_bytes;
    meta.store = StoreStats {
        stored_bins: shards.iter().map(|s| s.meta.store.stored_bins).sum(),
        runs: shards.iter().map(|s| s.meta.store.runs).sum(),
        bytes: list
            + shards
                .iter()
                .map(|s| s.meta.store.bytes.saturating_sub(s.info.store_list_bytes))
                .sum::<u64>(),
        dense_bins: first.meta.store.dense_bins,
        dense_bytes: first.meta.store.dense_bytes,
    };
    Ok(meta)
}

/// What [`merge`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MergeReport {
    pub shards: usize,
    /// Bytes of cube data read from the shards (npy rows, or chunk files linked or
    /// copied).
    pub bytes_read: u64,
    /// Chunk files hard-linked rather than copied (Zarr on one file system).
    pub chunks_linked: u64,
    /// Chunk files copied (the shards on another file system).
    pub chunks_copied: u64,
    /// Chunks several shards wrote parts of, put together and encoded again.
    pub chunks_combined: u64,
}

/// Merge shard folders `dirs` into the cube folder `out` (written beside it and swapped
/// in whole, as `tprf render` does): `tprf.npy` (and `tprf_bounces.npy`) row by row from
/// each row's shard, or `tprf.zarr` with every shard's chunk files linked (or copied)
/// in without decoding; `steady.png` and `tprf.json` as one machine writes them.
/// Refused: shards of different renders (naming the field), a missing or repeated
/// shard, a truncated or unreadable file.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<MergeReport> {
    let shards = dirs
        .iter()
        .map(|d| read_shard(d))
        .collect::<Result<Vec<_>>>()?;
    let shards = check_set(shards)?;
    let meta = merged_metadata(&shards)?;
    let first = &shards[0];
    let spec = ShardSpec {
        k: 0,
        n: first.info.n,
        band_rows: first.info.band_rows,
    };
    let (w, h) = (meta.width, meta.height);
    // Everything is checked before anything is written.
    let steady = read_steady(&shards, &spec, w, h)?;
    let staging =
        super::staging::Staging::new(out, &dirs.iter().map(PathBuf::as_path).collect::<Vec<_>>())?;
    let dir = staging.path();
    let mut report = MergeReport {
        shards: shards.len(),
        ..MergeReport::default()
    };
    if first.info.format == "zarr" {
        merge_zarr(&shards, &spec, &meta, dir, &mut report)?;
    } else {
        report.bytes_read += merge_npy(&shards, &spec, "tprf.npy", dir, None)?;
        if meta.bounces_separate > 0 {
            let layers = meta.bounces_separate as u64 + 2;
            report.bytes_read += merge_npy(&shards, &spec, "tprf_bounces.npy", dir, Some(layers))?;
        }
    }
    // The ambient image: every shard renders the whole of it (it is cheap and needs no
    // rows of the film), the same for the same seed; the shards' copies must agree.
    if meta.ambient.is_some() {
        let mut image: Option<Vec<f32>> = None;
        for s in &shards {
            let Some(this) = super::ambient::load_ambient(&s.dir, &s.meta)? else {
                return Err(broken(
                    s,
                    "it has no ambient image; its tprf.json says the render has one",
                ));
            };
            match &image {
                None => image = Some(this),
                Some(first)
                    if first
                        .iter()
                        .map(|v| v.to_bits())
                        .eq(this.iter().map(|v| v.to_bits())) => {}
                Some(_) => {
                    return Err(broken(
                        s,
                        "its ambient image differs from the first shard's",
                    ));
                }
            }
        }
        if let Some(image) = image {
            super::ambient::write_ambient(dir, first.info.format == "zarr", w, h, &image)?;
        }
    }
    let exposure = 0.8 * super::exposure_for(steady.iter().copied(), 0.99);
    super::write_png_gray(&dir.join("steady.png"), w, h, &steady, exposure)?;
    super::write_json(&dir.join("tprf.json"), &meta)?;
    staging.commit()?;
    Ok(report)
}

fn broken(s: &Shard, message: impl Into<String>) -> ShardError {
    ShardError::Broken {
        k: s.info.k,
        dir: s.dir.clone(),
        message: message.into(),
    }
}

/// The merged steady sums `[H, W]`, each row from its shard's `shard_steady.npy`.
fn read_steady(shards: &[Shard], spec: &ShardSpec, w: usize, h: usize) -> Result<Vec<f64>> {
    let planes = shards
        .iter()
        .map(|s| {
            let path = s.dir.join(STEADY_NAME);
            let bytes = crate::budget::read_file(&path, STEADY_NAME)
                .map_err(|e| broken(s, format!("cannot read {STEADY_NAME}: {e}")))?;
            let npy = npyz::NpyFile::new(&bytes[..])
                .map_err(|e| broken(s, format!("{STEADY_NAME} is not a .npy file: {e}")))?;
            if npy.shape() != [h as u64, w as u64] {
                return Err(broken(
                    s,
                    format!("{STEADY_NAME} has shape {:?}, not [{h}, {w}]", npy.shape()),
                ));
            }
            let data_bytes = (w * h * 8) as u64;
            let have = npy.into_inner().len() as u64;
            if have != data_bytes {
                return Err(broken(
                    s,
                    format!(
                        "{STEADY_NAME} holds {have} bytes of data, its shape needs {data_bytes}"
                    ),
                ));
            }
            let npy = npyz::NpyFile::new(&bytes[..])
                .map_err(|e| broken(s, format!("{STEADY_NAME}: {e}")))?;
            npy.into_vec::<f64>()
                .map_err(|e| broken(s, format!("{STEADY_NAME} is not float64: {e}")))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut steady = Vec::with_capacity(w * h);
    for y in 0..h {
        steady.extend_from_slice(&planes[spec.owner(y)][y * w..(y + 1) * w]);
    }
    Ok(steady)
}

/// A shard's `.npy` cube opened for reading rows: the file, where its data starts.
fn open_npy(s: &Shard, name: &str, shape: &[u64]) -> Result<(File, u64)> {
    let path = s.dir.join(name);
    let mut file = File::open(&path).map_err(|e| broken(s, format!("cannot open {name}: {e}")))?;
    let mut head = Vec::new();
    (&mut file)
        .take(1 << 16)
        .read_to_end(&mut head)
        .map_err(|e| broken(s, format!("cannot read {name}: {e}")))?;
    let npy = npyz::NpyFile::new(&head[..])
        .map_err(|e| broken(s, format!("{name} is not a .npy file: {e}")))?;
    let float32 = matches!(npy.dtype(), npyz::DType::Plain(t) if t.to_string() == "<f4");
    if !float32 || npy.order() != npyz::Order::C {
        return Err(broken(s, format!("{name} is not a C-order float32 array")));
    }
    if npy.shape() != shape {
        return Err(broken(
            s,
            format!(
                "{name} has shape {:?}, its tprf.json says {shape:?}",
                npy.shape()
            ),
        ));
    }
    let data_at = (head.len() - npy.into_inner().len()) as u64;
    let need = data_at + super::npy_f32_bytes(shape);
    let have = file
        .metadata()
        .map_err(|e| broken(s, format!("{name}: {e}")))?
        .len();
    if have != need {
        return Err(broken(
            s,
            format!(
                "{name} is {have} bytes, its header's shape {shape:?} makes {need}: {}",
                if have < need {
                    "truncated"
                } else {
                    "longer than its array"
                }
            ),
        ));
    }
    Ok((file, data_at))
}

/// Write `dir/name` (float32 `[layers?, H, W, T]`) from the shards' files of that name,
/// each row from its shard; zero blocks stay holes. Returns the bytes read.
fn merge_npy(
    shards: &[Shard],
    spec: &ShardSpec,
    name: &str,
    dir: &Path,
    layers: Option<u64>,
) -> Result<u64> {
    use std::os::unix::fs::FileExt;
    let m = &shards[0].meta;
    let (w, h, t) = (m.width as u64, m.height as u64, m.bins as u64);
    let mut shape: Vec<u64> = layers.into_iter().collect();
    shape.extend([h, w, t]);
    let files = shards
        .iter()
        .map(|s| open_npy(s, name, &shape))
        .collect::<Result<Vec<_>>>()?;
    let row_bytes = (w * t * 4) as usize;
    let planes = layers.unwrap_or(1);
    let mut read = 0u64;
    let mut failure: Option<ShardError> = None;
    super::write_atomic_bulk(&dir.join(name), |out| {
        let sparse = npyz::WriteOptions::<f32>::new()
            .default_dtype()
            .shape(&shape)
            .writer(&mut *out)
            .write_header_only()?;
        let mut row = vec![0u8; row_bytes];
        for plane in 0..planes {
            for y in 0..h {
                let o = spec.owner(y as usize);
                let (file, data_at) = &files[o];
                let at = data_at + (plane * h + y) * row_bytes as u64;
                if let Err(e) = file.read_exact_at(&mut row, at) {
                    failure = Some(broken(&shards[o], format!("reading {name} row {y}: {e}")));
                    return Err(e.into());
                }
                read += row_bytes as u64;
                sparse.write_all(&row)?;
            }
        }
        Ok(())
    })
    .map_err(|e| failure.take().unwrap_or(ShardError::Export(e)))?;
    Ok(read)
}

/// The chunk files of a shard's group: `(path, index)` per file of each array.
fn chunk_files(s: &Shard, group: &Path) -> Result<Vec<(PathBuf, String, Vec<u64>)>> {
    let mut out = Vec::new();
    for (array_dir, _) in super::zarr::CHUNK_DIRS {
        let root = group.join(array_dir);
        if !root.exists() {
            continue;
        }
        let mut stack = vec![(root.clone(), Vec::new())];
        while let Some((dir, index)) = stack.pop() {
            let entries = std::fs::read_dir(&dir)
                .map_err(|e| broken(s, format!("cannot list {}: {e}", dir.display())))?;
            for entry in entries {
                let entry = entry.map_err(|e| broken(s, format!("{}: {e}", dir.display())))?;
                let name = entry.file_name().to_string_lossy().into_owned();
                let i: u64 = name.parse().map_err(|_| {
                    broken(
                        s,
                        format!("{} is not a chunk of the cube", entry.path().display()),
                    )
                })?;
                let mut index = index.clone();
                index.push(i);
                let kind = entry
                    .file_type()
                    .map_err(|e| broken(s, format!("{}: {e}", entry.path().display())))?;
                if kind.is_dir() {
                    stack.push((entry.path(), index));
                } else if kind.is_file() {
                    out.push((entry.path(), array_dir.to_string(), index));
                } else {
                    return Err(broken(
                        s,
                        format!("{} is not a regular file", entry.path().display()),
                    ));
                }
            }
        }
    }
    out.sort();
    Ok(out)
}

/// `tprf.zarr` from the shards' groups: the group and arrays made anew with the merged
/// metadata, then each chunk file checked (decoded: a whole chunk, zero in the rows
/// that are not its shard's) and put in place. A chunk that one shard wrote (always,
/// with bands of whole chunks) is hard-linked in (copied across file systems): never
/// re-encoded, the very bytes one machine writes. A chunk whose rows several shards
/// share (bands thinner than a chunk) is made from each row's shard's rows and encoded
/// as the render encodes it (the same bytes, since the same data goes into the same
/// encoder).
fn merge_zarr(
    shards: &[Shard],
    spec: &ShardSpec,
    meta: &CubeMetadata,
    dir: &Path,
    report: &mut MergeReport,
) -> Result<()> {
    use rayon::prelude::*;
    let name = super::zarr::ZARR_NAME;
    let layers = if meta.bounces_separate > 0 {
        meta.bounces_separate as usize + 2
    } else {
        0
    };
    let height = meta.height;
    let cy = super::zarr::CHUNK[0] as usize;
    // Chunk files by their place in the store: (shard, file, first row of the tile).
    let mut plan: BTreeMap<PathBuf, Vec<(&Shard, PathBuf, usize)>> = BTreeMap::new();
    for s in shards {
        let group = s.dir.join(name);
        super::zarr::ZarrCube::open(&group)?;
        for (path, array_dir, index) in chunk_files(s, &group)? {
            let dims = if array_dir.starts_with("cube") { 3 } else { 4 };
            let row_at = super::zarr::CHUNK_DIRS
                .iter()
                .find(|(d, _)| *d == array_dir)
                .map_or(0, |d| d.1);
            let y0 = (index.get(row_at).copied().unwrap_or(0) as usize).saturating_mul(cy);
            if index.len() != dims || y0 >= height {
                return Err(broken(
                    s,
                    format!("{} is not a chunk of the cube", path.display()),
                ));
            }
            let y1 = (y0 + cy).min(height);
            if !(y0..y1).any(|y| spec.owner(y) == s.info.k) {
                return Err(broken(
                    s,
                    format!(
                        "{} holds rows {y0}..{y1}, none of them its own",
                        path.display()
                    ),
                ));
            }
            let rel = path.strip_prefix(&group).unwrap_or(&path).to_path_buf();
            plan.entry(rel).or_default().push((s, path, y0));
        }
    }
    let target = dir.join(name);
    let shape = [meta.height as u64, meta.width as u64, meta.bins as u64];
    super::zarr::create_group(&target, meta, shape, layers)?;
    let row_bytes = (super::zarr::CHUNK[1] * super::zarr::CHUNK[2] * 4) as usize;
    let linked = std::sync::atomic::AtomicU64::new(0);
    let copied = std::sync::atomic::AtomicU64::new(0);
    let combined = std::sync::atomic::AtomicU64::new(0);
    let read = std::sync::atomic::AtomicU64::new(0);
    let plan: Vec<_> = plan.into_iter().collect();
    plan.par_iter().try_for_each(|(rel, files)| -> Result<()> {
        let to = target.join(rel);
        if let Some(parent) = to.parent() {
            super::create_dir(parent)?;
        }
        let mut decoded = Vec::with_capacity(files.len());
        for (s, path, y0) in files {
            let bytes =
                std::fs::read(path).map_err(|e| broken(s, format!("{}: {e}", path.display())))?;
            read.fetch_add(bytes.len() as u64, std::sync::atomic::Ordering::Relaxed);
            let chunk = zstd::bulk::decompress(&bytes, super::zarr::CHUNK_BYTES)
                .map_err(|e| broken(s, format!("{} does not decode: {e}", path.display())))?;
            if chunk.len() != super::zarr::CHUNK_BYTES {
                return Err(broken(
                    s,
                    format!(
                        "{} decodes to {} bytes, not a chunk's {}",
                        path.display(),
                        chunk.len(),
                        super::zarr::CHUNK_BYTES
                    ),
                ));
            }
            // Rows of the tile that are not this shard's (or below the image) are zero.
            for (r, row) in chunk.chunks_exact(row_bytes).enumerate() {
                let y = y0 + r;
                let own = y < height && spec.owner(y) == s.info.k;
                if !own && row.iter().any(|&b| b != 0) {
                    return Err(broken(
                        s,
                        format!("{} has light in row {y}, not its own", path.display()),
                    ));
                }
            }
            decoded.push((s, path, *y0, chunk));
        }
        if let [(s, path, _, _)] = &decoded[..] {
            if std::fs::hard_link(path, &to).is_ok() {
                linked.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            } else {
                std::fs::copy(path, &to).map_err(|e| {
                    broken(
                        s,
                        format!("cannot copy {} to {}: {e}", path.display(), to.display()),
                    )
                })?;
                copied.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
            return Ok(());
        }
        // Several shards' rows in one chunk: each row from its shard.
        let mut chunk = vec![0u8; super::zarr::CHUNK_BYTES];
        for (s, _, y0, part) in &decoded {
            for (r, (dst, src)) in chunk
                .chunks_exact_mut(row_bytes)
                .zip(part.chunks_exact(row_bytes))
                .enumerate()
            {
                if y0 + r < height && spec.owner(y0 + r) == s.info.k {
                    dst.copy_from_slice(src);
                }
            }
        }
        let encoded = zstd::bulk::compress(&chunk, super::zarr::ZSTD_LEVEL).map_err(|e| {
            ExportError::Zarr {
                path: to.clone(),
                message: format!("zstd: {e}"),
            }
        })?;
        std::fs::write(&to, encoded).map_err(|source| ExportError::Create {
            path: to.clone(),
            source,
        })?;
        combined.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Ok(())
    })?;
    report.chunks_linked += linked.into_inner();
    report.chunks_copied += copied.into_inner();
    report.chunks_combined += combined.into_inner();
    report.bytes_read += read.into_inner();
    super::zarr::sync_dir(&target)?;
    Ok(())
}

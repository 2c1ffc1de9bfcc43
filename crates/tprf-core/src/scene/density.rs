//! Heterogeneous media: a density grid that scales a medium's coefficients point by point.
//!
//! A grid is `nx x ny x nz` non-negative numbers over an axis-aligned box in world metres
//! (x fastest, then y, then z: Mitsuba's `.vol` order). At a point `p` the medium's
//! coefficients are `sigma_s(p) = density(p) sigma_s`, `sigma_a(p) = density(p) sigma_a`,
//! so the albedo is the medium's everywhere. `density(p)` is the trilinear interpolation
//! of the samples, each at the centre of its cell (sample `i` of `n` at `(i + 1/2) / n`
//! of the box's width), clamped to the outermost samples inside the box and 0 outside
//! it: Mitsuba 3's `gridvolume` (`filter_type` trilinear, `wrap_mode` clamp, its medium
//! bounded by the volume's box) and pbrt-v4's `SampledGrid`.
//!
//! Where grids come from: the medium's glTF extras `"density": {"file": "smoke.vol"}` (a
//! Mitsuba `.vol` file, [`DensityGrid::read_vol`]) or `{"dims": [nx, ny, nz], "values":
//! [...]}`, with the box `"bbox_min_m"` / `"bbox_max_m"` (a mesh medium's default: the
//! mesh's bounds; a scene-wide medium's: the `.vol` file's box); Mitsuba's `<medium
//! type="heterogeneous">` with a `gridvolume` for `sigma_t` (`scene::mitsuba::media`).
//! A grid's size is budgeted before its values are allocated ([`crate::budget`]).

use crate::budget;
use glam::DVec3;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Bytes of a `.vol` file's header: `VOL`, version, encoding, three sizes, channels, box.
pub const VOL_HEADER_BYTES: usize = 48;

/// A density grid over an axis-aligned box.
#[derive(Clone, Debug, PartialEq)]
pub struct DensityGrid {
    /// Samples along x, y and z (each at least 1).
    pub dims: [u32; 3],
    /// `dims[0] dims[1] dims[2]` densities, x fastest; finite and >= 0.
    pub values: Arc<[f32]>,
    /// The box `[min, max]`, world metres; `None` until the loader gives it the bounds
    /// of the mesh the medium fills.
    pub bbox_m: Option<[[f32; 3]; 2]>,
    /// The `.vol` file it was read from, when it was (recorded in `tprf.json` and written
    /// back by glTF save in place of the values).
    pub file: Option<PathBuf>,
    /// The largest value.
    max: f32,
}

impl DensityGrid {
    /// A grid of `values` (x fastest) over `bbox_m`, checked: every size at least 1, as
    /// many values as cells, each finite and >= 0. The message names `what`.
    pub fn new(
        dims: [u32; 3],
        values: Vec<f32>,
        bbox_m: Option<[[f32; 3]; 2]>,
        file: Option<PathBuf>,
        what: &str,
    ) -> Result<DensityGrid, String> {
        let cells = cell_count(dims).ok_or_else(|| {
            format!("{what}: dims {dims:?} must each be at least 1, their product below 2^64")
        })?;
        if values.len() as u64 != cells {
            return Err(format!(
                "{what}: {} values for dims {dims:?}, which need {cells} (nx ny nz, x fastest)",
                values.len()
            ));
        }
        if let Some(i) = values.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            let nx = dims[0] as usize;
            let ny = dims[1] as usize;
            return Err(format!(
                "{what}: value {} at (x {}, y {}, z {}) must be finite and >= 0 (a density)",
                values[i],
                i % nx,
                (i / nx) % ny,
                i / (nx * ny)
            ));
        }
        if let Some(b) = bbox_m {
            check_bbox(b, what)?;
        }
        let max = values.iter().copied().fold(0.0f32, f32::max);
        Ok(DensityGrid {
            dims,
            values: values.into(),
            bbox_m,
            file,
            max,
        })
    }

    /// The largest density.
    pub fn max(&self) -> f32 {
        self.max
    }

    /// The same grid over the box scaled by `s` about the origin.
    pub fn scaled(&self, s: f32) -> DensityGrid {
        DensityGrid {
            bbox_m: self.bbox_m.map(|b| b.map(|p| p.map(|x| x * s))),
            ..self.clone()
        }
    }

    /// The value of cell `(x, y, z)` (indices clamped to the grid).
    #[inline]
    fn at(&self, x: usize, y: usize, z: usize) -> f64 {
        let [nx, ny, _] = self.dims.map(|n| n as usize);
        self.values
            .get((z * ny + y) * nx + x)
            .map_or(0.0, |&v| v as f64)
    }

    /// The density at world point `p`: trilinear between cell centres, clamped to the
    /// outermost samples inside the box, 0 outside it (and 0 without a box).
    pub fn density_at(&self, p: DVec3) -> f64 {
        let Some([lo, hi]) = self.bbox_m else {
            return 0.0;
        };
        let (lo, hi) = (
            DVec3::from(lo.map(f64::from)),
            DVec3::from(hi.map(f64::from)),
        );
        if !(p.cmpge(lo).all() && p.cmple(hi).all()) {
            return 0.0;
        }
        let n = DVec3::from(self.dims.map(f64::from));
        let g = (p - lo) / (hi - lo) * n - 0.5;
        self.at_grid(g)
    }

    /// The interpolated density at grid coordinates `g` (sample `i` at `g = i`), clamped.
    #[inline]
    pub(crate) fn at_grid(&self, g: DVec3) -> f64 {
        let mut i0 = [0usize; 3];
        let mut i1 = [0usize; 3];
        let mut f = [0.0f64; 3];
        for a in 0..3 {
            let n = self.dims[a] as usize;
            let x = g[a].clamp(0.0, (n - 1) as f64);
            let lo = (x.floor() as usize).min(n.saturating_sub(2));
            i0[a] = lo;
            i1[a] = (lo + 1).min(n - 1);
            f[a] = if n > 1 { x - lo as f64 } else { 0.0 };
        }
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let c00 = lerp(
            self.at(i0[0], i0[1], i0[2]),
            self.at(i1[0], i0[1], i0[2]),
            f[0],
        );
        let c10 = lerp(
            self.at(i0[0], i1[1], i0[2]),
            self.at(i1[0], i1[1], i0[2]),
            f[0],
        );
        let c01 = lerp(
            self.at(i0[0], i0[1], i1[2]),
            self.at(i1[0], i0[1], i1[2]),
            f[0],
        );
        let c11 = lerp(
            self.at(i0[0], i1[1], i1[2]),
            self.at(i1[0], i1[1], i1[2]),
            f[0],
        );
        lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2])
    }

    /// Read a Mitsuba `.vol` file (Mitsuba 3's `gridvolume` format): `VOL`, version 3,
    /// encoding 1 (float32), x, y and z sizes and the channel count (int32), the box
    /// (6 float32: xmin ymin zmin xmax ymax zmax), then the values x fastest, all little
    /// endian. One channel only. The file's size is budgeted before it is read and must
    /// be exactly the header's; the grid's box is the file's. Errors name the file.
    pub fn read_vol(path: &Path) -> Result<DensityGrid, String> {
        let name = path.display();
        let bytes = budget::read_file(path, "the density grid").map_err(|e| e.to_string())?;
        let (dims, channels, bbox) = vol_header(&bytes).map_err(|m| format!("{name}: {m}"))?;
        if channels != 1 {
            return Err(format!(
                "{name}: {channels} channels: tprf's density grids have one (a density; the \
                 medium's coefficients give the colour)"
            ));
        }
        // In u128: three sizes of up to 2^31 each and 4 bytes a value cannot overflow it.
        let want = dims.iter().map(|&n| n as u128).product::<u128>() * 4 + VOL_HEADER_BYTES as u128;
        if want != bytes.len() as u128 {
            return Err(format!(
                "{name}: {} bytes, but its header's sizes {dims:?} x 1 channel need {want} (48 \
                 + 4 per value): the file is cut short, too long, or not this grid",
                bytes.len(),
            ));
        }
        let value_bytes = (want - VOL_HEADER_BYTES as u128) as u64;
        budget::check(value_bytes, "the density grid", format_args!("{name}"))
            .map_err(|e| e.to_string())?;
        let values: Vec<f32> = bytes[VOL_HEADER_BYTES..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let file = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        DensityGrid::new(dims, values, Some(bbox), Some(file), &name.to_string())
    }

    /// A grid of the glTF extras object `{"file": "smoke.vol"}` (relative to `base`) or
    /// `{"dims": [nx, ny, nz], "values": [...]}`, with an optional box `"bbox_min_m"`,
    /// `"bbox_max_m"` (both or neither; a file's own box when left out). `what` names the
    /// object in messages.
    pub fn from_json(
        value: &serde_json::Value,
        base: Option<&Path>,
        what: &str,
    ) -> Result<DensityGrid, String> {
        let serde_json::Value::Object(map) = value else {
            return Err(format!(
                "{what} = {value}: expected an object {{\"file\"}} or {{\"dims\", \"values\"}}, \
                 with \"bbox_min_m\" and \"bbox_max_m\""
            ));
        };
        for key in map.keys() {
            if !["file", "dims", "values", "bbox_min_m", "bbox_max_m"].contains(&key.as_str()) {
                return Err(format!(
                    "{what}: unknown key '{key}' (known: file, dims, values, bbox_min_m, \
                     bbox_max_m)"
                ));
            }
        }
        let point = |key: &str| -> Result<Option<[f32; 3]>, String> {
            let Some(v) = map.get(key) else {
                return Ok(None);
            };
            let p = v.as_array().filter(|a| a.len() == 3).and_then(|a| {
                let c: Option<Vec<f64>> = a.iter().map(|x| x.as_f64()).collect();
                c.map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
            });
            p.map(Some)
                .ok_or_else(|| format!("{what}.{key} = {v}: expected [x, y, z] (metres)"))
        };
        let bbox = match (point("bbox_min_m")?, point("bbox_max_m")?) {
            (Some(lo), Some(hi)) => Some([lo, hi]),
            (None, None) => None,
            _ => {
                return Err(format!(
                    "{what}: give both bbox_min_m and bbox_max_m, or neither"
                ));
            }
        };
        let mut grid = match (map.get("file"), map.get("dims"), map.get("values")) {
            (Some(f), None, None) => {
                let Some(f) = f.as_str() else {
                    return Err(format!("{what}.file = {f}: expected a path (a string)"));
                };
                let path = base.map_or_else(|| PathBuf::from(f), |b| b.join(f));
                DensityGrid::read_vol(&path).map_err(|e| format!("{what}.file: {e}"))?
            }
            (None, Some(d), Some(v)) => {
                let dims = d
                    .as_array()
                    .filter(|a| a.len() == 3)
                    .and_then(|a| {
                        let n: Option<Vec<u32>> = a
                            .iter()
                            .map(|x| x.as_u64().and_then(|x| u32::try_from(x).ok()))
                            .collect();
                        n.map(|n| [n[0], n[1], n[2]])
                    })
                    .ok_or_else(|| {
                        format!("{what}.dims = {d}: expected [nx, ny, nz], whole numbers >= 1")
                    })?;
                let Some(values) = v.as_array() else {
                    return Err(format!("{what}.values: expected an array of numbers"));
                };
                let cells = cell_count(dims).ok_or_else(|| {
                    format!(
                        "{what}.dims {dims:?} must each be at least 1, their product below 2^64"
                    )
                })?;
                if values.len() as u64 != cells {
                    return Err(format!(
                        "{what}.values: {} values for dims {dims:?}, which need {cells} (x \
                         fastest)",
                        values.len()
                    ));
                }
                let values: Vec<f32> = values
                    .iter()
                    .enumerate()
                    .map(|(i, x)| {
                        x.as_f64()
                            .map(|x| x as f32)
                            .ok_or_else(|| format!("{what}.values[{i}] = {x}: expected a number"))
                    })
                    .collect::<Result<_, _>>()?;
                DensityGrid::new(dims, values, None, None, &format!("{what}.values"))?
            }
            _ => {
                return Err(format!(
                    "{what}: give either \"file\" (a .vol) or both \"dims\" and \"values\""
                ));
            }
        };
        if let Some(b) = bbox {
            check_bbox(b, what)?;
            grid.bbox_m = Some(b);
        }
        Ok(grid)
    }

    /// The extras object [`DensityGrid::from_json`] reads: the file where the grid came
    /// from one (its absolute path), else the dims and values; the box.
    pub fn to_json(&self) -> serde_json::Value {
        let mut o = match &self.file {
            Some(f) => serde_json::json!({"file": f.display().to_string()}),
            None => serde_json::json!({"dims": self.dims, "values": &*self.values}),
        };
        if let (Some([lo, hi]), Some(map)) = (self.bbox_m, o.as_object_mut()) {
            map.insert("bbox_min_m".into(), serde_json::json!(lo));
            map.insert("bbox_max_m".into(), serde_json::json!(hi));
        }
        o
    }

    /// The grid in words: `density grid 32x32x16 from smoke.vol (max 3.2) over [..]`.
    pub fn describe(&self) -> String {
        let [x, y, z] = self.dims;
        let from = self
            .file
            .as_ref()
            .map_or(String::new(), |f| format!(" from {}", f.display()));
        let over = self
            .bbox_m
            .map_or(String::new(), |[lo, hi]| format!(" over {lo:?}-{hi:?} m"));
        format!("density grid {x}x{y}x{z}{from} (max {}){over}", self.max)
    }

    /// Check the grid as a scene holds it: a box given, valid. `what` names its medium.
    pub fn validate(&self, what: &str) -> Result<(), String> {
        match self.bbox_m {
            None => Err(format!(
                "{what}: its density grid has no box: give \"bbox_min_m\" and \"bbox_max_m\" \
                 (metres)"
            )),
            Some(b) => check_bbox(b, what),
        }
    }
}

/// `nx ny nz`, or `None` when a size is 0 or the product overflows.
fn cell_count(dims: [u32; 3]) -> Option<u64> {
    if dims.contains(&0) {
        return None;
    }
    (dims[0] as u64)
        .checked_mul(dims[1] as u64)?
        .checked_mul(dims[2] as u64)
}

/// A box: finite corners, `min < max` on every axis.
fn check_bbox([lo, hi]: [[f32; 3]; 2], what: &str) -> Result<(), String> {
    let ok = (0..3).all(|a| lo[a].is_finite() && hi[a].is_finite() && lo[a] < hi[a]);
    if ok {
        Ok(())
    } else {
        Err(format!(
            "{what}: bbox_min_m {lo:?} and bbox_max_m {hi:?} must be finite, min < max on \
             every axis (metres)"
        ))
    }
}

/// A `.vol` header: the x, y, z sizes, the channel count and the box.
type VolHeader = ([u32; 3], u32, [[f32; 3]; 2]);

/// The sizes, channel count and box of a `.vol` header.
fn vol_header(b: &[u8]) -> Result<VolHeader, String> {
    if b.len() < VOL_HEADER_BYTES {
        return Err(format!(
            "{} bytes: shorter than a .vol header (48 bytes)",
            b.len()
        ));
    }
    if &b[0..3] != b"VOL" {
        return Err("not a Mitsuba .vol file (it does not start with 'VOL')".into());
    }
    if b[3] != 3 {
        return Err(format!("version {}: only version 3 is read", b[3]));
    }
    let int = |i: usize| i32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    let float = |i: usize| f32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    let encoding = int(4);
    if encoding != 1 {
        return Err(format!(
            "encoding {encoding}: only encoding 1 (float32) is read"
        ));
    }
    let sizes = [int(8), int(12), int(16)];
    if sizes.iter().any(|&s| s < 1) {
        return Err(format!("sizes {sizes:?}: each must be at least 1"));
    }
    let channels = int(20);
    if channels < 1 {
        return Err(format!("{channels} channels: must be at least 1"));
    }
    let lo = [float(24), float(28), float(32)];
    let hi = [float(36), float(40), float(44)];
    check_bbox([lo, hi], "its box")?;
    Ok((sizes.map(|s| s as u32), channels as u32, [lo, hi]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(dims: [u32; 3], values: Vec<f32>) -> DensityGrid {
        DensityGrid::new(dims, values, Some([[0.0; 3], [1.0; 3]]), None, "g").unwrap()
    }

    /// Sample centres hold the samples; between them the lookup is linear; outside the
    /// centres it is clamped; outside the box 0.
    #[test]
    fn trilinear_between_cell_centres() {
        let g = grid([2, 1, 1], vec![1.0, 3.0]);
        let at = |x: f64| g.density_at(DVec3::new(x, 0.5, 0.5));
        assert_eq!(at(0.25), 1.0);
        assert_eq!(at(0.75), 3.0);
        assert_eq!(at(0.5), 2.0);
        assert_eq!(at(0.1), 1.0);
        assert_eq!(at(0.9), 3.0);
        assert_eq!(at(1.1), 0.0);
        assert_eq!(g.density_at(DVec3::new(0.5, -0.01, 0.5)), 0.0);
        // A product of linear ramps is reproduced exactly by trilinear interpolation.
        let f = |x: f64, y: f64, z: f64| (1.0 + x) * (2.0 + y) * (0.5 + z);
        let mut v = Vec::new();
        for z in 0..3 {
            for y in 0..4 {
                for x in 0..5 {
                    v.push(f(x as f64, y as f64, z as f64) as f32);
                }
            }
        }
        let g = grid([5, 4, 3], v);
        for (gx, gy, gz) in [(0.3, 1.7, 0.2), (3.9, 2.5, 1.99), (2.0, 0.0, 1.0)] {
            let p = DVec3::new((gx + 0.5) / 5.0, (gy + 0.5) / 4.0, (gz + 0.5) / 3.0);
            let want = f(gx, gy, gz);
            assert!((g.density_at(p) - want).abs() < 1e-5 * want, "{p}");
        }
    }

    #[test]
    fn bad_grids_are_refused_by_name() {
        let e = DensityGrid::new([2, 2, 2], vec![1.0; 7], None, None, "m").unwrap_err();
        assert!(e.contains("7 values") && e.contains("need 8"), "{e}");
        let mut v = vec![1.0; 8];
        v[5] = f32::NAN;
        let e = DensityGrid::new([2, 2, 2], v, None, None, "m").unwrap_err();
        assert!(e.contains("(x 1, y 0, z 1)"), "{e}");
        let e = DensityGrid::new([2, 1, 1], vec![1.0, -1.0], None, None, "m").unwrap_err();
        assert!(e.contains("finite and >= 0"), "{e}");
        let e = DensityGrid::new([0, 1, 1], vec![], None, None, "m").unwrap_err();
        assert!(e.contains("at least 1"), "{e}");
        let bad_box = Some([[0.0; 3], [1.0, 0.0, 1.0]]);
        let e = DensityGrid::new([1, 1, 1], vec![1.0], bad_box, None, "m").unwrap_err();
        assert!(e.contains("min < max"), "{e}");
        // Sizes far beyond memory are refused against the values given, before any
        // allocation of their size.
        let j = serde_json::json!({"dims": [65536, 65536, 65536], "values": [1]});
        let e = DensityGrid::from_json(&j, None, "mat.density").unwrap_err();
        assert!(e.contains("mat.density.values: 1 values"), "{e}");
        let j = serde_json::json!({"dims": [4294967295u64, 4294967295u64, 4294967295u64], "values": [1]});
        let e = DensityGrid::from_json(&j, None, "mat.density").unwrap_err();
        assert!(e.contains("below 2^64"), "{e}");
        let j = serde_json::json!({"file": "x.vol", "dims": [1, 1, 1]});
        let e = DensityGrid::from_json(&j, None, "d").unwrap_err();
        assert!(e.contains("either"), "{e}");
        let j = serde_json::json!({"dims": [1, 1, 1], "values": [1], "bbox_min_m": [0, 0, 0]});
        let e = DensityGrid::from_json(&j, None, "d").unwrap_err();
        assert!(e.contains("both"), "{e}");
        let j = serde_json::json!({"dims": [1, 1, 1], "values": [1], "size": 2});
        let e = DensityGrid::from_json(&j, None, "d").unwrap_err();
        assert!(e.contains("unknown key 'size'"), "{e}");
    }

    #[test]
    fn json_round_trips_inline_grids() {
        let j = serde_json::json!({"dims": [2, 1, 1], "values": [0.5, 2.0],
            "bbox_min_m": [0, 0, 0], "bbox_max_m": [1, 2, 3]});
        let g = DensityGrid::from_json(&j, None, "d").unwrap();
        assert_eq!(g.max(), 2.0);
        assert_eq!(g.bbox_m, Some([[0.0; 3], [1.0, 2.0, 3.0]]));
        assert_eq!(DensityGrid::from_json(&g.to_json(), None, "d").unwrap(), g);
    }
}

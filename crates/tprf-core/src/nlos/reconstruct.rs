//! Reconstruction of the hidden scene from a capture, onto a voxel volume in the wall's
//! frame (`u`, `v` along the sensor grid's x and y, `n` toward the hidden scene).
//!
//! - `bp`, back-projection (Velten et al. 2012; tal's `reconstruct.bp` with its
//!   `DIRECT_LIGHT` camera): voxel `x` gets `sum_{l,s} H[bin(d_1 + |l - x| + |x - s| + d_4), l, s]`,
//!   `d_1`, `d_4` the device legs when the capture's times include them; bins by
//!   `floor((path - t_start) / delta_t)`.
//! - `fbp`, filtered back-projection (tal's `reconstruct.fbp`): `H` convolved along
//!   time with the phasor-field kernel `K(t) = g(t) exp(2 pi i t / lambda)` (`g` a
//!   Gaussian of standard deviation `sigma`, summing to 1), back-projected, magnitude.
//! - `pf`, phasor fields (Liu et al. 2019; tal's `reconstruct.pf` at `t = 0`): per
//!   frequency `f` of the same Gaussian band, the wall's phasor field
//!   `P_f(l, s) = sum_t H e^{-2 pi i f t}` (times less the device legs) is propagated to
//!   each depth plane by the Rayleigh-Sommerfeld kernel `e^{2 pi i f d} / d` from every
//!   sensor point and from the laser points (confocal: one kernel of twice the distance,
//!   `e^{2 pi i f 2d} / d^2`), as 2-D convolutions by FFT on the sensor grid's lattice;
//!   the image is `|sum_f w_f I_f|`.
//! - `fk`, f-k migration (Lindell et al. 2019; tal's `reconstruct.fk`), confocal
//!   captures only: the transients scaled by `t`, a 3-D FFT, Stolt's change of variables
//!   `k_z' = sqrt((k_x^2 + k_y^2) (extent scale)^2 + k_z^2)`, an inverse FFT, `|.|^2`, on
//!   the grid's lattice and depth `c t / 2`, then sampled at the voxels.
//!
//! Values are relative (each method's own scale); `volume.npy` holds them as `[Z, Y, X]`
//! float32, Z along `n`.

use super::NlosError;
use super::files::LoadedCapture;
use crate::transport::bsdf::turn_cos_sin;
use glam::Vec3;
use rayon::prelude::*;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex32;
use serde::{Deserialize, Serialize};

/// A reconstruction method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    Bp,
    Fbp,
    Fk,
    Pf,
}

impl std::str::FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Method, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "bp" => Ok(Method::Bp),
            "fbp" => Ok(Method::Fbp),
            "fk" => Ok(Method::Fk),
            "pf" => Ok(Method::Pf),
            other => Err(format!("unknown method '{other}' (bp, fbp, fk or pf)")),
        }
    }
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Bp => "bp",
            Method::Fbp => "fbp",
            Method::Fk => "fk",
            Method::Pf => "pf",
        }
    }

    /// What a voxel's value is, in words and units (the capture's `H` is per bin: W
    /// m^-2 sr^-1 s per joule of laser pulse). Values compare within one volume; across
    /// methods only their shapes do.
    pub fn value_meaning(self) -> &'static str {
        match self {
            Method::Bp => {
                "the sum over the capture's transients of H at the voxel's path length \
                 (H's unit, W m⁻² sr⁻¹ s per J, summed over the wall)"
            }
            Method::Fbp => {
                "the magnitude of the sum over the transients of H filtered by the phasor \
                 kernel (a Gaussian of sum 1 times a carrier) at the voxel's path length \
                 (H's unit summed over the wall)"
            }
            Method::Pf => {
                "the magnitude of the wall's phasor field propagated to the voxel \
                 (H's unit summed over the wall, each point weighted by 1/d, confocal 1/d², d in m)"
            }
            Method::Fk => {
                "|ψ|² after Stolt's migration of the transients scaled by t: H's unit \
                 squared on the method's own scale"
            }
        }
    }
}

/// The wall's frame as the capture's sensor grid gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridFrame {
    /// Centre of the sensor grid, metres.
    pub center: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub n: Vec3,
    /// Spacing of the sensor grid along u and v, metres (0 along an axis of one point).
    pub spacing_m: [f32; 2],
}

impl GridFrame {
    /// The frame of `c`'s sensor grid: `u`, `v` along its x and y indices, `n` = `u x v`
    /// turned to the grid's normals where the file has them.
    pub fn of(c: &LoadedCapture) -> Result<GridFrame, NlosError> {
        let [sx, sy] = c.sensor_shape;
        let g = &c.sensor_grid;
        let at = |i: usize, j: usize| g.get(i * sy + j).copied().unwrap_or(Vec3::ZERO);
        let center = g.iter().copied().sum::<Vec3>() / g.len().max(1) as f32;
        let du = if sx > 1 {
            at(sx - 1, 0) - at(0, 0)
        } else {
            Vec3::ZERO
        };
        let dv = if sy > 1 {
            at(0, sy - 1) - at(0, 0)
        } else {
            Vec3::ZERO
        };
        let normal = c.sensor_normal.map(|n| n.normalize());
        let (u, v, n) = match (du.length() > 0.0, dv.length() > 0.0) {
            (true, true) => {
                let (u, v) = (du.normalize(), dv.normalize());
                let mut n = u.cross(v).normalize();
                if normal.is_some_and(|m| m.dot(n) < 0.0) {
                    n = -n;
                }
                (u, v, n)
            }
            (true, false) | (false, true) => {
                let Some(n) = normal else {
                    return Err(NlosError::Setup(format!(
                        "{}: a sensor grid of one row needs sensor_grid_normals",
                        c.path.display()
                    )));
                };
                if du.length() > 0.0 {
                    let u = du.normalize();
                    (u, n.cross(u).normalize(), n)
                } else {
                    let v = dv.normalize();
                    (v.cross(n).normalize(), v, n)
                }
            }
            (false, false) => {
                let Some(n) = normal else {
                    return Err(NlosError::Setup(format!(
                        "{}: a sensor grid of one point needs sensor_grid_normals",
                        c.path.display()
                    )));
                };
                let u = n.any_orthonormal_vector();
                (u, n.cross(u), n)
            }
        };
        Ok(GridFrame {
            center,
            u,
            v,
            n,
            spacing_m: [
                if sx > 1 {
                    du.length() / (sx - 1) as f32
                } else {
                    0.0
                },
                if sy > 1 {
                    dv.length() / (sy - 1) as f32
                } else {
                    0.0
                },
            ],
        })
    }
}

/// A box of voxels in the wall's frame: centre (world, metres), size along `u`, `v`, `n`
/// (metres) and voxel counts along them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Volume {
    pub center: [f32; 3],
    pub size_m: [f32; 3],
    pub voxels: [usize; 3],
    pub u: [f32; 3],
    pub v: [f32; 3],
    pub n: [f32; 3],
}

/// Most voxels a volume may have.
pub const MAX_VOXELS: usize = 1 << 27;

impl Volume {
    /// Centre of voxel `(ix, iy, iz)`.
    pub fn voxel_center(&self, ix: usize, iy: usize, iz: usize) -> Vec3 {
        let f = |i: usize, n: usize, s: f32| ((i as f32 + 0.5) / n as f32 - 0.5) * s;
        Vec3::from(self.center)
            + Vec3::from(self.u) * f(ix, self.voxels[0], self.size_m[0])
            + Vec3::from(self.v) * f(iy, self.voxels[1], self.size_m[1])
            + Vec3::from(self.n) * f(iz, self.voxels[2], self.size_m[2])
    }

    pub fn len(&self) -> usize {
        self.voxels.iter().product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index into `[Z, Y, X]` values.
    pub fn index(&self, ix: usize, iy: usize, iz: usize) -> usize {
        (iz * self.voxels[1] + iy) * self.voxels[0] + ix
    }

    /// The default volume of a capture: the sensor grid's extent and lattice across,
    /// from the wall to the farthest depth its time axis reaches (half the longest path,
    /// less the device legs), voxels about as deep as the grid's spacing.
    pub fn default_for(c: &LoadedCapture, frame: &GridFrame) -> Result<Volume, NlosError> {
        let [sx, sy] = c.sensor_shape;
        let end_m = c.t_start_m + c.delta_t_m * c.bins() as f64;
        let legs = if c.device_legs {
            let sensor = c.sensor_xyz.unwrap_or(frame.center);
            let laser = c.laser_xyz.unwrap_or(frame.center);
            (sensor - frame.center).length() as f64 + (laser - frame.center).length() as f64
        } else {
            0.0
        };
        let depth_m = ((end_m - legs) / 2.0) as f32;
        if !(depth_m > 0.0) {
            return Err(NlosError::Setup(format!(
                "{}: the time axis ends ({end_m:.3} m) before light could return from in front of the wall",
                c.path.display()
            )));
        }
        let w = frame.spacing_m[0] * sx as f32;
        let h = frame.spacing_m[1] * sy as f32;
        let w = if w > 0.0 { w } else { h.max(depth_m) };
        let h = if h > 0.0 { h } else { w };
        let step = frame.spacing_m[0]
            .max(frame.spacing_m[1])
            .max(depth_m / 256.0);
        let nz = ((depth_m / step).round() as usize).clamp(1, 256);
        let voxels = (sx as u64)
            .saturating_mul(sy as u64)
            .saturating_mul(nz as u64);
        if voxels > MAX_VOXELS as u64 {
            return Err(NlosError::Setup(format!(
                "{}: the default volume, its {sx} x {sy} sensor grid by {nz} depths, is {} voxels \
                 ({} of f32), more than the {MAX_VOXELS} a volume may have: choose a smaller one \
                 with --volume CX,CY,CZ:SX,SY,SZ:NX,NY,NZ",
                c.path.display(),
                crate::budget::format_count(voxels),
                crate::budget::format_bytes(voxels.saturating_mul(4)),
            )));
        }
        Ok(Volume {
            center: (frame.center + frame.n * (0.5 * depth_m)).to_array(),
            size_m: [w, h, depth_m],
            voxels: [sx, sy, nz],
            u: frame.u.to_array(),
            v: frame.v.to_array(),
            n: frame.n.to_array(),
        })
    }

    /// A volume of the given centre, size (along u, v, n) and voxels, in `frame`;
    /// refused when empty, too large, or reaching the wall's plane or behind it.
    pub fn new(
        frame: &GridFrame,
        center: Vec3,
        size_m: [f32; 3],
        voxels: [usize; 3],
    ) -> Result<Volume, NlosError> {
        if voxels.contains(&0)
            || voxels
                .iter()
                .try_fold(1usize, |a, &b| a.checked_mul(b))
                .is_none_or(|n| n > MAX_VOXELS)
        {
            return Err(NlosError::Setup(format!(
                "--volume: {voxels:?} voxels; give 1 to {MAX_VOXELS} voxels in all, at least 1 along each axis"
            )));
        }
        if !(center.is_finite() && size_m.iter().all(|s| s.is_finite() && *s > 0.0)) {
            return Err(NlosError::Setup(format!(
                "--volume: centre {:?} and size {size_m:?} must be finite, the size > 0",
                center.to_array()
            )));
        }
        let near = (center - frame.center).dot(frame.n) - 0.5 * size_m[2];
        if !(near > 0.0) {
            return Err(NlosError::Setup(format!(
                "--volume: the volume reaches behind the relay wall (its near face is {:.3} m \
                 {} the wall's plane): the hidden scene is in front of the wall; move its \
                 centre out along the wall's normal {:?} or make it shallower",
                near.abs(),
                if near < 0.0 { "behind" } else { "on" },
                frame.n.to_array()
            )));
        }
        Ok(Volume {
            center: center.to_array(),
            size_m,
            voxels,
            u: frame.u.to_array(),
            v: frame.v.to_array(),
            n: frame.n.to_array(),
        })
    }
}

/// Parameters of the phasor-field kernel (fbp, pf): central wavelength and the
/// Gaussian's standard deviation, metres.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Wave {
    pub wavelength_m: f64,
    pub sigma_m: f64,
}

impl Wave {
    /// tal's choice of sigma (`wl_mean / sqrt(2)`) for a wavelength of four grid spacings
    /// (or four bins, if coarser).
    pub fn default_for(c: &LoadedCapture, frame: &GridFrame) -> Wave {
        let spacing = frame.spacing_m[0].max(frame.spacing_m[1]) as f64;
        let wavelength_m = (4.0 * spacing).max(4.0 * c.delta_t_m);
        Wave {
            wavelength_m,
            sigma_m: wavelength_m / std::f64::consts::SQRT_2,
        }
    }
}

/// A reconstruction: values `[Z, Y, X]` on `volume`.
#[derive(Clone, Debug)]
pub struct Reconstruction {
    pub method: Method,
    pub volume: Volume,
    pub values: Vec<f32>,
    pub wave: Option<Wave>,
    pub seconds: f64,
}

impl Reconstruction {
    /// The voxel `(ix, iy, iz)` of the largest value.
    pub fn peak(&self) -> [usize; 3] {
        let k = self
            .values
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |(k, _)| k);
        let [nx, ny, _] = self.volume.voxels;
        [k % nx, (k / nx) % ny, k / (nx * ny)]
    }

    /// Max-intensity projections: along n (front, `[Y][X]`), along v (top, `[Z][X]`)
    /// and along u (side, `[Y][Z]`), each with its width and height.
    pub fn projections(&self) -> [(usize, usize, Vec<f32>); 3] {
        let [nx, ny, nz] = self.volume.voxels;
        let mut front = vec![0.0f32; nx * ny];
        let mut top = vec![0.0f32; nx * nz];
        let mut side = vec![0.0f32; nz * ny];
        for iz in 0..nz {
            for iy in 0..ny {
                for ix in 0..nx {
                    let v = self.values[self.volume.index(ix, iy, iz)];
                    let f = &mut front[iy * nx + ix];
                    *f = f.max(v);
                    let t = &mut top[iz * nx + ix];
                    *t = t.max(v);
                    let s = &mut side[iy * nz + iz];
                    *s = s.max(v);
                }
            }
        }
        [(nx, ny, front), (nx, nz, top), (nz, ny, side)]
    }
}

/// The pairs a capture holds: for each transient (time-major index `k` of `H`'s
/// non-time axes), its laser and sensor point.
struct Pairs {
    lasers: Vec<Vec3>,
    sensors: Vec<Vec3>,
    /// Per transient: its laser index, sensor index.
    of: Vec<(u32, u32)>,
    /// Per transient: the device legs, metres.
    legs_m: Vec<f32>,
}

fn pairs(c: &LoadedCapture) -> Pairs {
    let ns = c.sensor_grid.len();
    let confocal = c.is_confocal() || (!c.exhaustive && c.laser_grid.len() == ns);
    let of: Vec<(u32, u32)> = if c.exhaustive {
        (0..c.laser_grid.len())
            .flat_map(|l| (0..ns).map(move |s| (l as u32, s as u32)))
            .collect()
    } else if confocal {
        (0..ns).map(|s| (s as u32, s as u32)).collect()
    } else {
        (0..ns).map(|s| (0, s as u32)).collect()
    };
    let legs_m = of
        .iter()
        .map(|&(l, s)| {
            if c.device_legs {
                let (lo, so) = (
                    c.laser_xyz.unwrap_or(Vec3::ZERO),
                    c.sensor_xyz.unwrap_or(Vec3::ZERO),
                );
                (c.laser_grid[l as usize] - lo).length() + (c.sensor_grid[s as usize] - so).length()
            } else {
                0.0
            }
        })
        .collect();
    Pairs {
        lasers: c.laser_grid.clone(),
        sensors: c.sensor_grid.clone(),
        of,
        legs_m,
    }
}

/// Transient-major copy of `H` (`[k][t]`), real or complex.
fn transients(c: &LoadedCapture) -> (usize, Vec<f32>) {
    let t = c.bins();
    let k = c.h.len() / t.max(1);
    let mut out = vec![0.0f32; c.h.len()];
    for ti in 0..t {
        for ki in 0..k {
            out[ki * t + ti] = c.h[ti * k + ki];
        }
    }
    (k, out)
}

/// Reconstruct `c` on `volume` with `method` (`wave` for fbp and pf; `None`: the default).
pub fn reconstruct(
    c: &LoadedCapture,
    method: Method,
    volume: &Volume,
    wave: Option<Wave>,
) -> Result<Reconstruction, NlosError> {
    let start = std::time::Instant::now();
    let frame = GridFrame::of(c)?;
    let wave = wave.unwrap_or_else(|| Wave::default_for(c, &frame));
    if !(wave.wavelength_m > 0.0
        && wave.sigma_m > 0.0
        && wave.wavelength_m.is_finite()
        && wave.sigma_m.is_finite())
    {
        return Err(NlosError::Setup(format!(
            "--wavelength {} m, sigma {} m: both must be finite and > 0",
            wave.wavelength_m, wave.sigma_m
        )));
    }
    crate::budget::check(
        (c.h.len() as u64)
            .saturating_mul(16)
            .saturating_add(volume.len() as u64 * 8),
        "this reconstruction",
        format!("{} on {} voxels", method.name(), volume.len()),
    )?;
    let values = match method {
        Method::Bp => {
            let (k, tr) = transients(c);
            backproject::<1>(c, volume, &pairs(c), k, &tr)
                .into_iter()
                .map(|[v]| v)
                .collect()
        }
        Method::Fbp => {
            let (k, tr) = transients(c);
            let filtered = phasor_filter(&tr, k, c.bins(), c.delta_t_m, wave);
            drop(tr);
            // Real and imaginary parts back-projected together: one path length per
            // voxel and transient for both.
            let parts: Vec<f32> = filtered.iter().flat_map(|z| [z.re, z.im]).collect();
            drop(filtered);
            backproject::<2>(c, volume, &pairs(c), k, &parts)
                .into_iter()
                .map(|[a, b]| a.hypot(b))
                .collect()
        }
        Method::Pf => phasor_fields(c, &frame, volume, wave)?,
        Method::Fk => fk_migration(c, &frame, volume)?,
    };
    Ok(Reconstruction {
        method,
        volume: *volume,
        values,
        wave: matches!(method, Method::Fbp | Method::Pf).then_some(wave),
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Back-projection of the transients `tr` (`[k][t][C]`: `C` values per bin back-projected
/// together, one path length for all) onto `volume` (see the module doc).
/// Blocks of voxels are the parallel work; within one, each transient is read once and
/// added to every voxel of the block, so the transient and the block's sums stay in
/// the cache.
fn backproject<const C: usize>(
    c: &LoadedCapture,
    volume: &Volume,
    p: &Pairs,
    k: usize,
    tr: &[f32],
) -> Vec<[f32; C]> {
    let t = c.bins();
    let [nx, _, _] = volume.voxels;
    let inv_dt = (1.0 / c.delta_t_m) as f32;
    let t0 = c.t_start_m as f32;
    let confocal =
        !c.exhaustive && p.of.iter().all(|&(l, s)| l == s) && p.lasers.len() == p.sensors.len();
    let rows_per_block = (4096 / nx.max(1)).max(1);
    let mut out = vec![[0.0f32; C]; volume.len()];
    out.par_chunks_mut(nx * rows_per_block)
        .enumerate()
        .for_each(|(block, sums)| {
            let first = block * rows_per_block * nx;
            let pos: Vec<Vec3> = (0..sums.len())
                .map(|i| {
                    let v = first + i;
                    let [vx, vy, _] = volume.voxels;
                    volume.voxel_center(v % vx, (v / vx) % vy, v / (vx * vy))
                })
                .collect();
            // Laser distances per voxel, unless each sensor point is its own laser point.
            let d_l: Vec<Vec<f32>> = if confocal {
                Vec::new()
            } else {
                p.lasers
                    .iter()
                    .map(|l| pos.iter().map(|x| (*x - *l).length()).collect())
                    .collect()
            };
            let xs: Vec<f32> = pos.iter().map(|p| p.x).collect();
            let ys: Vec<f32> = pos.iter().map(|p| p.y).collect();
            let zs: Vec<f32> = pos.iter().map(|p| p.z).collect();
            // Each transient padded with a zero at index `t`: a path outside the time
            // axis reads it, so the inner loops have no branch and vectorise.
            let mut padded = vec![[0.0f32; C]; t + 1];
            let mut bins = vec![0u32; sums.len()];
            let last = t as f32;
            for (ki, &(li, si)) in p.of.iter().enumerate().take(k) {
                let Some(h) = tr.get(ki * t * C..(ki + 1) * t * C) else {
                    continue;
                };
                for (p, v) in padded.iter_mut().zip(h.chunks_exact(C)) {
                    p.copy_from_slice(v);
                }
                let s = p.sensors[si as usize];
                // Bin of a path: (path - t0) / dt, the legs folded into the offset.
                let offset = (p.legs_m[ki] - t0) * inv_dt;
                // floor((path - t0) / dt) for a path inside the axis: truncation, as the
                // bin is >= 0 there (no floor call: it would not vectorise).
                let bin = |b: f32| {
                    if b >= 0.0 && b < last {
                        b as u32
                    } else {
                        t as u32
                    }
                };
                // Distances from the voxels' coordinates as three arrays (vectorised).
                let dist = |i: usize| {
                    let (dx, dy, dz) = (xs[i] - s.x, ys[i] - s.y, zs[i] - s.z);
                    (dx * dx + dy * dy + dz * dz).sqrt()
                };
                if confocal {
                    let two = 2.0 * inv_dt;
                    for (i, b) in bins.iter_mut().enumerate() {
                        *b = bin(dist(i) * two + offset);
                    }
                } else {
                    let dl = &d_l[li as usize];
                    for ((i, b), l) in bins.iter_mut().enumerate().zip(dl) {
                        *b = bin((dist(i) + l) * inv_dt + offset);
                    }
                }
                for (o, &b) in sums.iter_mut().zip(&bins) {
                    let v = padded[(b as usize).min(t)];
                    for j in 0..C {
                        o[j] += v[j];
                    }
                }
            }
        });
    out
}

/// The phasor-field kernel's taps, `g(t) e^{2 pi i t / lambda}` for `t` = -r..=r bins.
fn kernel(delta_t_m: f64, wave: Wave) -> Vec<Complex32> {
    let r = ((3.0 * wave.sigma_m / delta_t_m).ceil() as usize).max(1);
    let g: Vec<f64> = (0..=2 * r)
        .map(|i| {
            let t = (i as f64 - r as f64) * delta_t_m;
            (-0.5 * (t / wave.sigma_m).powi(2)).exp()
        })
        .collect();
    let total: f64 = g.iter().sum();
    g.iter()
        .enumerate()
        .map(|(i, w)| {
            let t = (i as f64 - r as f64) * delta_t_m;
            let ph = std::f64::consts::TAU * t / wave.wavelength_m;
            Complex32::new((w / total * ph.cos()) as f32, (w / total * ph.sin()) as f32)
        })
        .collect()
}

/// Each of `k` transients of `t` bins convolved with the phasor-field kernel (zero
/// outside the axis), by FFT.
fn phasor_filter(tr: &[f32], k: usize, t: usize, delta_t_m: f64, wave: Wave) -> Vec<Complex32> {
    let taps = kernel(delta_t_m, wave);
    let r = taps.len() / 2;
    let n = (t + taps.len()).next_power_of_two();
    let mut planner = FftPlanner::<f32>::new();
    let fwd = planner.plan_fft_forward(n);
    let inv = planner.plan_fft_inverse(n);
    let mut kf = vec![Complex32::new(0.0, 0.0); n];
    kf[..taps.len()].copy_from_slice(&taps);
    fwd.process(&mut kf);
    let scale = 1.0 / n as f32;
    let mut out = vec![Complex32::new(0.0, 0.0); k * t];
    out.par_chunks_mut(t).enumerate().for_each(|(ki, o)| {
        let mut buf = vec![Complex32::new(0.0, 0.0); n];
        for (b, x) in buf.iter_mut().zip(&tr[ki * t..(ki + 1) * t]) {
            *b = Complex32::new(*x, 0.0);
        }
        fwd.process(&mut buf);
        for (b, kk) in buf.iter_mut().zip(&kf) {
            *b *= kk * scale;
        }
        inv.process(&mut buf);
        o.copy_from_slice(&buf[r..r + t]);
    });
    out
}

/// The band of frequencies (cycles per metre) and weights of the phasor-field kernel:
/// a Gaussian around `1 / lambda` of standard deviation `1 / (2 pi sigma)`, within 3 of them.
fn band(wave: Wave, delta_t_m: f64, n: usize) -> Vec<(usize, f64, f32)> {
    let df = 1.0 / (n as f64 * delta_t_m);
    let fc = 1.0 / wave.wavelength_m;
    let sf = 1.0 / (std::f64::consts::TAU * wave.sigma_m);
    let nyquist = 0.5 / delta_t_m;
    let lo = ((fc - 3.0 * sf) / df).ceil().max(1.0) as usize;
    let hi = (((fc + 3.0 * sf).min(nyquist)) / df).floor() as usize;
    (lo..=hi.max(lo).min(n / 2))
        .map(|i| {
            let f = i as f64 * df;
            (i, f, (-0.5 * ((f - fc) / sf).powi(2)).exp() as f32)
        })
        .collect()
}

/// Phasor fields at `t = 0` (see the module doc).
fn phasor_fields(
    c: &LoadedCapture,
    frame: &GridFrame,
    volume: &Volume,
    wave: Wave,
) -> Result<Vec<f32>, NlosError> {
    let [sx, sy] = c.sensor_shape;
    let t = c.bins();
    let p = pairs(c);
    let (k, tr) = transients(c);
    let n_t = (2 * t).next_power_of_two();
    let freqs = band(wave, c.delta_t_m, n_t);
    let confocal = c.is_confocal();
    let nf = freqs.len();
    let [nx, ny, nz] = volume.voxels;
    let (px, py) = ((2 * sx).next_power_of_two(), (2 * sy).next_power_of_two());
    let lasers_k = if c.exhaustive { c.laser_grid.len() } else { 1 };
    // What the fields hold beyond `reconstruct`'s budget: P_f, a padded lattice per
    // frequency and laser point, and per thread a kernel, a product and the image.
    let lattice = (px as u64).saturating_mul(py as u64);
    let cplx = std::mem::size_of::<Complex32>() as u64;
    crate::budget::check(
        [
            (k as u64).saturating_mul(nf as u64),
            (nf as u64)
                .saturating_mul(lasers_k as u64)
                .saturating_mul(lattice),
            (rayon::current_num_threads() as u64)
                .saturating_mul(lattice.saturating_mul(3).saturating_add((sx * sy) as u64)),
        ]
        .iter()
        .fold(0u64, |a, &n| a.saturating_add(n.saturating_mul(cplx))),
        "the phasor-field reconstruction",
        format!(
            "{nf} frequencies x {lasers_k} laser point(s) of {px} x {py} padded sensor lattices"
        ),
    )?;
    // P_f per transient: sum_b H_b e^{-2 pi i f (t_b - legs)}, t_b the bin's centre: the
    // band's bins of the transient's FFT (zero-padded to n_t), the phase of the start.
    let mut pf = vec![Complex32::new(0.0, 0.0); k * nf];
    let fwd_t = FftPlanner::<f32>::new().plan_fft_forward(n_t);
    pf.par_chunks_mut(nf).enumerate().for_each(|(ki, o)| {
        let mut buf = vec![Complex32::new(0.0, 0.0); n_t];
        for (b, x) in buf.iter_mut().zip(&tr[ki * t..(ki + 1) * t]) {
            *b = Complex32::new(*x, 0.0);
        }
        fwd_t.process(&mut buf);
        let start_m = c.t_start_m + 0.5 * c.delta_t_m - p.legs_m[ki] as f64;
        for (o, &(bin, f, w)) in o.iter_mut().zip(&freqs) {
            let phase = -std::f64::consts::TAU * f * start_m;
            *o = buf[bin] * Complex32::from_polar(w, phase as f32);
        }
    });
    // Each depth plane on the sensor lattice (2-D convolution by FFT), then the voxels.
    let mut planner = FftPlanner::<f32>::new();
    let fx = planner.plan_fft_forward(px);
    let fy = planner.plan_fft_forward(py);
    let ix_ = planner.plan_fft_inverse(px);
    let iy_ = planner.plan_fft_inverse(py);
    let fft2 = |a: &mut [Complex32], inverse: bool| {
        let (rx, ry) = if inverse { (&ix_, &iy_) } else { (&fx, &fy) };
        for row in a.chunks_mut(py) {
            ry.process(row);
        }
        let mut col = vec![Complex32::new(0.0, 0.0); px];
        for j in 0..py {
            for i in 0..px {
                col[i] = a[i * py + j];
            }
            rx.process(&mut col);
            for i in 0..px {
                a[i * py + j] = col[i];
            }
        }
    };
    // The sensor-side fields per frequency (and laser, exhaustive), FFT'd once.
    let mut fields: Vec<Vec<Complex32>> = Vec::with_capacity(nf * lasers_k);
    for fi in 0..nf {
        for l in 0..lasers_k {
            let mut a = vec![Complex32::new(0.0, 0.0); px * py];
            for i in 0..sx {
                for j in 0..sy {
                    let ki = l * sx * sy + i * sy + j;
                    if let Some(v) = pf.get(ki * nf + fi) {
                        a[i * py + j] = *v;
                    }
                }
            }
            fft2(&mut a, false);
            fields.push(a);
        }
    }
    let [du, dv] = [frame.spacing_m[0].max(1e-9), frame.spacing_m[1].max(1e-9)];
    let grid0 = c.sensor_grid.first().copied().unwrap_or(frame.center);
    let planes: Vec<Vec<f32>> = (0..nz)
        .into_par_iter()
        .map(|iz| {
            let depth = (volume.voxel_center(0, 0, iz) - frame.center).dot(frame.n);
            let mut image = vec![Complex32::new(0.0, 0.0); sx * sy];
            let mut kern = vec![Complex32::new(0.0, 0.0); px * py];
            let mut quarter = vec![Complex32::new(0.0, 0.0); (px / 2 + 1) * (py / 2 + 1)];
            for (fi, &(_, f, _)) in freqs.iter().enumerate() {
                let k2 = std::f32::consts::TAU * f as f32;
                // Kernel over offsets (circular indices), e^{i k m d} / d^m: a quadrant
                // of |offsets|, mirrored.
                let (hx, hy) = (px / 2, py / 2);
                for a in 0..=hx {
                    for b in 0..=hy {
                        let d = ((a as f32 * du).powi(2) + (b as f32 * dv).powi(2) + depth * depth)
                            .sqrt()
                            .max(1e-9);
                        let (m, amp) = if confocal {
                            (2.0, 1.0 / (d * d))
                        } else {
                            (1.0, 1.0 / d)
                        };
                        let (cos, sin) = turn_cos_sin(f as f32 * m * d);
                        quarter[a * (hy + 1) + b] = Complex32::new(amp * cos, amp * sin);
                    }
                }
                for i in 0..px {
                    let a = if i <= hx { i } else { px - i };
                    for j in 0..py {
                        let b = if j <= hy { j } else { py - j };
                        kern[i * py + j] = quarter[a * (hy + 1) + b];
                    }
                }
                fft2(&mut kern, false);
                for l in 0..lasers_k {
                    let field = &fields[fi * lasers_k + l];
                    let mut prod: Vec<Complex32> =
                        field.iter().zip(&kern).map(|(a, b)| a * b).collect();
                    fft2(&mut prod, true);
                    let norm = 1.0 / (px * py) as f32;
                    for i in 0..sx {
                        for j in 0..sy {
                            let mut v = prod[i * py + j] * norm;
                            if !confocal {
                                // The laser side: e^{i k d_l} / d_l to the lattice point.
                                let x = grid0
                                    + frame.u * (i as f32 * du)
                                    + frame.v * (j as f32 * dv)
                                    + frame.n * depth;
                                let lp = c.laser_grid.get(l).copied().unwrap_or(Vec3::ZERO);
                                let dl = (x - lp).length().max(1e-6);
                                v *= Complex32::from_polar(1.0 / dl, k2 * dl);
                            }
                            image[i * sy + j] += v;
                        }
                    }
                }
            }
            // The voxels of this depth: bilinear on the lattice.
            let mut plane = vec![0.0f32; nx * ny];
            for iy in 0..ny {
                for ix in 0..nx {
                    let x = volume.voxel_center(ix, iy, iz);
                    let rel = x - grid0;
                    let fu = if sx > 1 { rel.dot(frame.u) / du } else { 0.0 };
                    let fv = if sy > 1 { rel.dot(frame.v) / dv } else { 0.0 };
                    plane[iy * nx + ix] = bilinear(&image, sx, sy, fu, fv);
                }
            }
            plane
        })
        .collect();
    Ok(planes.concat())
}

/// `|image|` at fractional lattice point `(fu, fv)` (clamped to the lattice), bilinear.
fn bilinear(image: &[Complex32], sx: usize, sy: usize, fu: f32, fv: f32) -> f32 {
    let fu = fu.clamp(0.0, (sx - 1) as f32);
    let fv = fv.clamp(0.0, (sy - 1) as f32);
    let (i0, j0) = (fu.floor() as usize, fv.floor() as usize);
    let (i1, j1) = ((i0 + 1).min(sx - 1), (j0 + 1).min(sy - 1));
    let (a, b) = (fu - i0 as f32, fv - j0 as f32);
    let m = |i: usize, j: usize| image[i * sy + j].norm();
    (1.0 - a) * ((1.0 - b) * m(i0, j0) + b * m(i0, j1))
        + a * ((1.0 - b) * m(i1, j0) + b * m(i1, j1))
}

/// f-k migration (see the module doc); confocal captures only.
fn fk_migration(
    c: &LoadedCapture,
    frame: &GridFrame,
    volume: &Volume,
) -> Result<Vec<f32>, NlosError> {
    if !c.is_confocal() {
        return Err(NlosError::Setup(format!(
            "--method fk: {} is not a confocal capture (f-k migration needs the laser at each sensor point); use bp, fbp or pf",
            c.path.display()
        )));
    }
    let [sx, sy] = c.sensor_shape;
    let p = pairs(c);
    let (k, tr) = transients(c);
    let t = c.bins();
    // Depth bins from the wall (t = 0, legs removed): as far as the volume reaches.
    let far = (0..8)
        .map(|q| {
            let corner = volume.voxel_center(
                if q & 1 == 0 { 0 } else { volume.voxels[0] - 1 },
                if q & 2 == 0 { 0 } else { volume.voxels[1] - 1 },
                if q & 4 == 0 { 0 } else { volume.voxels[2] - 1 },
            );
            (corner - frame.center).dot(frame.n)
        })
        .fold(0.0f32, f32::max) as f64;
    let dz = 0.5 * c.delta_t_m;
    let m = (((far / dz).ceil() as usize) + 2).clamp(2, 4 * t + 2);
    crate::budget::check(
        [
            8 * m as u64,
            4,
            sx.next_power_of_two() as u64,
            sy.next_power_of_two() as u64,
            8,
        ]
        .iter()
        .fold(1u64, |a, &n| a.saturating_mul(n)),
        "f-k migration",
        format!("a 3-D FFT of {} x {} x {}", 2 * m, 2 * sx, 2 * sy),
    )?;
    // tau[z][x][y]: bin z of depth z dz, i.e. path 2 z dz (unwarped), scaled by z / m.
    let (nm, nx2, ny2) = (
        (2 * m).next_power_of_two(),
        (2 * sx).next_power_of_two(),
        (2 * sy).next_power_of_two(),
    );
    let mut data = vec![Complex32::new(0.0, 0.0); nm * nx2 * ny2];
    for ki in 0..k.min(sx * sy) {
        let (i, j) = (ki / sy, ki % sy);
        let shift_m = c.t_start_m - p.legs_m[ki] as f64;
        for zi in 0..m {
            let path = 2.0 * zi as f64 * dz;
            let b = ((path - shift_m) / c.delta_t_m).floor();
            if b >= 0.0 && (b as usize) < t {
                let v = tr[ki * t + b as usize] * (zi as f32 / m as f32);
                data[(zi * nx2 + i) * ny2 + j] = Complex32::new(v.abs(), 0.0);
            }
        }
    }
    let mut planner = FftPlanner::<f32>::new();
    fft3(&mut planner, &mut data, [nm, nx2, ny2], false);
    // Stolt: output (kz, kx, ky) from input at kz' = sqrt(scale^2 (kx^2 + ky^2) + kz^2),
    // frequencies in cycles per sample; kz per depth sample dz, kx per grid spacing.
    let (du, dv) = (
        frame.spacing_m[0].max(1e-9) as f64,
        frame.spacing_m[1].max(1e-9) as f64,
    );
    let freq = |i: usize, n: usize| -> f64 {
        if i < n / 2 {
            i as f64 / n as f64
        } else {
            i as f64 / n as f64 - 1.0
        }
    };
    let mut out = vec![Complex32::new(0.0, 0.0); data.len()];
    out.par_chunks_mut(nx2 * ny2)
        .enumerate()
        .for_each(|(zi, plane)| {
            let kz = freq(zi, nm) / dz; // cycles per metre of depth
            if kz <= 0.0 {
                return;
            }
            for i in 0..nx2 {
                let kx = freq(i, nx2) / du;
                for j in 0..ny2 {
                    let ky = freq(j, ny2) / dv;
                    // Depth frequency kz' of the data that maps to kz: kz'^2 = kz^2 + kx^2 + ky^2
                    // (the round trip halves the wave speed: time frequency in depth units).
                    let kzp = (kz * kz + kx * kx + ky * ky).sqrt();
                    let pos = kzp * dz * nm as f64; // fractional index
                    let i0 = pos.floor() as usize;
                    if i0 + 1 >= nm / 2 {
                        continue;
                    }
                    let a = (pos - i0 as f64) as f32;
                    let at = |z: usize| data[(z * nx2 + i) * ny2 + j];
                    let v = at(i0) * (1.0 - a) + at(i0 + 1) * a;
                    plane[i * ny2 + j] = v * (kz / kzp.max(1e-12)) as f32;
                }
            }
        });
    fft3(&mut planner, &mut out, [nm, nx2, ny2], true);
    // Sample the volume: trilinear in (depth bin, i, j) of |.|^2.
    let [nx, ny, nz] = volume.voxels;
    let grid0 = c.sensor_grid.first().copied().unwrap_or(frame.center);
    let val = |z: usize, i: usize, j: usize| out[(z * nx2 + i) * ny2 + j].norm_sqr();
    let mut values = vec![0.0f32; volume.len()];
    values
        .par_chunks_mut(nx)
        .enumerate()
        .for_each(|(row, chunk)| {
            let (iy, iz) = (row % ny, row / ny);
            if iz >= nz {
                return;
            }
            for (ix, o) in chunk.iter_mut().enumerate() {
                let x = volume.voxel_center(ix, iy, iz);
                let rel = x - grid0;
                let fz =
                    ((x - frame.center).dot(frame.n) as f64 / dz).clamp(0.0, (m - 1) as f64) as f32;
                let fu = if sx > 1 {
                    (rel.dot(frame.u) / du as f32).clamp(0.0, (sx - 1) as f32)
                } else {
                    0.0
                };
                let fv = if sy > 1 {
                    (rel.dot(frame.v) / dv as f32).clamp(0.0, (sy - 1) as f32)
                } else {
                    0.0
                };
                let (z0, i0, j0) = (
                    fz.floor() as usize,
                    fu.floor() as usize,
                    fv.floor() as usize,
                );
                let (z1, i1, j1) = (
                    (z0 + 1).min(m - 1),
                    (i0 + 1).min(sx - 1),
                    (j0 + 1).min(sy - 1),
                );
                let (a, b, g) = (fz - z0 as f32, fu - i0 as f32, fv - j0 as f32);
                let lerp2 = |z: usize| {
                    (1.0 - b) * ((1.0 - g) * val(z, i0, j0) + g * val(z, i0, j1))
                        + b * ((1.0 - g) * val(z, i1, j0) + g * val(z, i1, j1))
                };
                *o = (1.0 - a) * lerp2(z0) + a * lerp2(z1);
            }
        });
    Ok(values)
}

/// In-place 3-D FFT of `a` (`[n0][n1][n2]`, row-major), forward or inverse (scaled by
/// `1 / N`).
fn fft3(
    planner: &mut FftPlanner<f32>,
    a: &mut [Complex32],
    [n0, n1, n2]: [usize; 3],
    inverse: bool,
) {
    let plan = |p: &mut FftPlanner<f32>, n| {
        if inverse {
            p.plan_fft_inverse(n)
        } else {
            p.plan_fft_forward(n)
        }
    };
    let (f0, f1, f2) = (plan(planner, n0), plan(planner, n1), plan(planner, n2));
    a.par_chunks_mut(n2).for_each(|row| f2.process(row));
    a.par_chunks_mut(n1 * n2).for_each(|plane| {
        let mut col = vec![Complex32::new(0.0, 0.0); n1];
        for j in 0..n2 {
            for i in 0..n1 {
                col[i] = plane[i * n2 + j];
            }
            f1.process(&mut col);
            for i in 0..n1 {
                plane[i * n2 + j] = col[i];
            }
        }
    });
    // Along axis 0: gather columns in blocks of the last axis.
    let stride = n1 * n2;
    let cols: Vec<Vec<Complex32>> = (0..stride)
        .into_par_iter()
        .map(|c| {
            let mut col: Vec<Complex32> = (0..n0).map(|z| a[z * stride + c]).collect();
            f0.process(&mut col);
            col
        })
        .collect();
    for (c, col) in cols.iter().enumerate() {
        for (z, v) in col.iter().enumerate() {
            a[z * stride + c] = *v;
        }
    }
    if inverse {
        let s = 1.0 / (n0 * n1 * n2) as f32;
        a.par_iter_mut().for_each(|v| *v *= s);
    }
}

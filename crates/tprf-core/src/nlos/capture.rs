//! The wall-point integrator: the transients a SPAD focused on each sensor point records
//! for a unit-energy laser pulse at each laser point.
//!
//! A path runs from the sensor point `s` into the hidden scene and ends at the laser
//! spot `l`, both on the relay wall. Its first hidden vertex `x1` is sampled by area on
//! the hidden geometry (every triangle but the wall's; mitransient's "hidden geometry
//! sampling"), so no sample is spent on directions that find nothing; further vertices
//! follow BSDF samples, and every vertex is joined to `l` (a point: next-event
//! estimation). The lit spot is a point source of radiant intensity
//! `I(w) = Phi f_w(w_laser, w) cos theta_w` (W/sr for a pulse of `Phi` = 1 J), and the SPAD
//! records the radiance leaving `s` toward its device,
//!
//! `L_s = f_w(w_spad, w_x1) cos theta_s G(x1, s) L(x1 -> s)`, `G = cos theta_x1 / |x1 - s|^2`,
//!
//! so the three-bounce term (one hidden vertex) of a sample is
//! `f_w(s) cos_s cos_x1 / d_s^2 / p_A(x1) * f(x1) cos_x1' I_l(x1) / d_l^2`, arriving after
//! the optical path `d_l + d_s` (plus the device legs when they count). A bin holds the
//! integral of `L_s` over the bin (W m^-2 sr^-1 s per joule: DESIGN.md's convention).
//!
//! The triangle and the point in it come from one 2-D Sobol point (`Hidden::sample_point`:
//! stratified over the whole hidden area), and in a confocal scan the first vertex's
//! shadow segment to the laser spot, the sensor point itself, is traced once.
//!
//! Work is split by sensor point (one task each, its sample stream keyed by (seed,
//! point)), so a capture is identical for any thread count. Each task accumulates its
//! transients in f64 and stores them as f32.

use super::NlosError;
use super::setup::{CaptureGeometry, CaptureSettings, resolve};
use super::wall::WallPoint;
use crate::accel::{Accel, Hit};
use crate::film::TimeAxis;
use crate::scene::Scene;
use crate::transport::bsdf::{Frame, LobeKind};
use crate::transport::sampler::{Sampler, dim};
use crate::transport::surface::Surfaces;
use crate::units::C_M_PER_S;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Scattering events before Russian roulette starts (as the camera integrator's default).
const RR_START: u32 = 3;

/// A rendered capture: the geometry and the transients.
#[derive(Clone, Debug)]
pub struct Capture {
    pub geometry: CaptureGeometry,
    /// Time-major, as tal's `H`: `[T, Sx, Sy]` (single, confocal) or
    /// `[T, Lx, Ly, Sx, Sy]` (exhaustive), f32.
    pub h: Vec<f32>,
    pub spp: u32,
    pub seed: u64,
    pub max_bounces: u32,
    pub scene_name: String,
    pub channel: crate::scene::Channel,
    /// Wall-clock seconds the render took, and the rays it traced.
    pub render_s: f64,
    pub rays: u64,
}

impl Capture {
    /// Shape of `h`.
    pub fn shape(&self) -> Vec<usize> {
        let g = &self.geometry;
        let mut s = vec![g.axis.bins];
        if let super::Scan::Exhaustive { lx, ly } = g.scan {
            s.extend([lx, ly]);
        }
        s.extend(g.grid);
        s
    }

    /// The transient of sensor point `s` with laser `l` (0 unless exhaustive), one value
    /// per bin.
    pub fn transient(&self, l: usize, s: usize) -> Vec<f32> {
        let g = &self.geometry;
        let per_t = g.sensors.len() * g.lasers_per_sensor();
        let k = l * g.sensors.len() + s;
        (0..g.axis.bins)
            .map(|t| self.h.get(t * per_t + k).copied().unwrap_or(0.0))
            .collect()
    }
}

/// The scene prepared for captures: its BVH, surfaces, and the hidden triangles' area
/// table for sampling first vertices.
struct Hidden {
    accel: Accel,
    surfaces: Surfaces,
    /// Hidden triangles and the cumulative distribution of their areas.
    triangles: Vec<u32>,
    cdf: Vec<f64>,
    total_area_m2: f64,
    eps_m: f32,
}

impl Hidden {
    fn new(
        scene: Arc<Scene>,
        geometry: &CaptureGeometry,
        channel: crate::scene::Channel,
    ) -> Hidden {
        let mut is_wall = vec![false; scene.triangles.len()];
        for &i in &geometry.wall.triangles {
            is_wall[i] = true;
        }
        for o in scene
            .objects
            .iter()
            .filter(|o| o.name == geometry.wall.name)
        {
            for i in o.triangles.clone() {
                if let Some(w) = is_wall.get_mut(i) {
                    *w = true;
                }
            }
        }
        let mut triangles = Vec::new();
        let mut cdf = Vec::new();
        let mut total = 0.0f64;
        for (i, t) in scene.triangles.iter().enumerate() {
            let area = t.area_m2() as f64;
            if is_wall[i] || !(area > 0.0) {
                continue;
            }
            total += area;
            triangles.push(i as u32);
            cdf.push(total);
        }
        let diag = scene.bounds().diagonal_m();
        let eps_m = if diag.is_finite() && diag > 0.0 {
            diag * 1e-6
        } else {
            1e-6
        };
        Hidden {
            accel: Accel::build(&scene),
            surfaces: Surfaces::new(scene, channel),
            triangles,
            cdf,
            total_area_m2: total,
            eps_m,
        }
    }

    fn offset_m(&self, p: Vec3) -> f32 {
        self.eps_m + p.abs().max_element() * 4.0 * f32::EPSILON
    }

    /// A point uniformly distributed by area on the hidden geometry, from one point of
    /// the unit square: triangle, barycentrics. `u_a` chooses the triangle by its share
    /// of the area and, rescaled to that share, is also the point's first coordinate in
    /// it (`sqrt(u) (1 - v), sqrt(u) v`): the map from the square to the hidden surface
    /// is continuous within each triangle, so stratified (Sobol) points of the square
    /// stay stratified over the whole hidden area, which one coordinate for the choice
    /// and two others for the point did not.
    fn sample_point(&self, (u_a, u_b): (f32, f32)) -> Option<(u32, f32, f32)> {
        let target = u_a as f64 * self.total_area_m2;
        let k = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len().checked_sub(1)?);
        let tri = *self.triangles.get(k)?;
        let lo = if k == 0 { 0.0 } else { self.cdf[k - 1] };
        let hi = self.cdf[k];
        let u1 = (((target - lo) / (hi - lo)) as f32).clamp(0.0, 1.0);
        let r = u1.sqrt();
        Some((tri, r * (1.0 - u_b), r * u_b))
    }

    fn position(&self, tri: u32, u: f32, v: f32) -> Vec3 {
        let t = &self.surfaces.scene().triangles[tri as usize];
        t.p[0] * (1.0 - u - v) + t.p[1] * u + t.p[2] * v
    }

    /// Fraction of light passing from `a` to `b` (both surface points, with their
    /// outward offsets applied by the caller): 0 when an opaque surface is between.
    fn transmittance(&self, from: Vec3, to: Vec3) -> f32 {
        let d = to - from;
        let len = d.length();
        let t_max = len - self.offset_m(to);
        if !(t_max > 0.0) {
            return 1.0;
        }
        let dir = d / len;
        let mut tr = 1.0f32;
        let blocked = self.accel.any_hit(from, dir, t_max, |hit| {
            tr *= self
                .surfaces
                .shadow_transmission(hit.triangle, hit.u, hit.v);
            tr <= 0.0
        });
        if blocked { 0.0 } else { tr }
    }

    /// The wall's surface at `p` seen from the side `normal` faces (the hidden
    /// scene's): made once per wall point, used for every sample's [`WallSpot::f`].
    fn wall_spot(&self, p: &WallPoint, normal: Vec3) -> WallSpot {
        let hit = Hit {
            t_m: 0.0,
            triangle: p.triangle,
            u: p.u,
            v: p.v,
        };
        // A ray arriving along -normal sees the side `normal` faces.
        let sp = self.surfaces.at(&hit, p.position + normal, -normal);
        WallSpot {
            normal,
            frame: Frame::new(sp.n_shading),
            bsdf: sp.bsdf,
        }
    }
}

/// A wall point's shading frame and BSDF, on the hidden scene's side.
struct WallSpot {
    normal: Vec3,
    frame: Frame,
    bsdf: crate::transport::bsdf::Bsdf,
}

impl WallSpot {
    /// The wall's BSDF value for light from direction `wi` leaving along `wo` (both
    /// unit, away from the wall), 0 when either is behind it.
    fn f(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.dot(self.normal) <= 0.0 || wo.dot(self.normal) <= 0.0 {
            return 0.0;
        }
        self.bsdf
            .eval(self.frame.to_local(wo), self.frame.to_local(wi))
            .0
    }
}

/// Counts shared by the tasks: rays traced, and whether to stop.
pub struct Progress {
    pub points_done: AtomicU64,
    pub rays: AtomicU64,
    pub cancel: AtomicBool,
}

impl Default for Progress {
    fn default() -> Self {
        Progress {
            points_done: AtomicU64::new(0),
            rays: AtomicU64::new(0),
            cancel: AtomicBool::new(false),
        }
    }
}

/// Render the capture `settings` asks of `scene` (see the module doc). `progress` counts
/// the sensor points done; setting its `cancel` stops the render early (the result then
/// holds zeros where points were not rendered, and the error says so).
pub fn render_capture(
    scene: Arc<Scene>,
    settings: &CaptureSettings,
    progress: &Progress,
) -> Result<Capture, NlosError> {
    render_capture_with(scene, settings, progress, &|| {})
}

/// [`render_capture`], calling `poll` (from the worker threads) after each sensor point
/// is counted in `progress.points_done`, and every [`POLL_SAMPLES`] samples while a point
/// runs: what a caller's progress report and cancel hang on
/// ([`crate::request::CaptureRequest::run`]). Once `progress.cancel` is set, the points
/// running stop within [`POLL_SAMPLES`] samples and the others are skipped.
pub fn render_capture_with(
    scene: Arc<Scene>,
    settings: &CaptureSettings,
    progress: &Progress,
    poll: &(dyn Fn() + Sync),
) -> Result<Capture, NlosError> {
    let start = std::time::Instant::now();
    let geometry = resolve(&scene, settings)?;
    let per_sensor = geometry.lasers_per_sensor();
    let bins = geometry.axis.bins;
    let values = (geometry.sensors.len() as u64)
        .saturating_mul(per_sensor as u64)
        .saturating_mul(bins as u64);
    // The per-point transients, then the time-major copy.
    crate::budget::check(
        values.saturating_mul(8),
        "this capture",
        format!(
            "{} transients of {bins} bins (two f32 copies)",
            geometry.sensors.len() * per_sensor
        ),
    )?;
    let hidden = Hidden::new(scene.clone(), &geometry, settings.channel);
    let per_point: Vec<Vec<f32>> = (0..geometry.sensors.len())
        .into_par_iter()
        .map(|s| {
            if progress.cancel.load(Ordering::Relaxed) {
                return vec![0.0; per_sensor * bins];
            }
            let mut acc = vec![0.0f64; per_sensor * bins];
            let stop = || {
                poll();
                progress.cancel.load(Ordering::Relaxed)
            };
            let rays = trace_point(&hidden, &geometry, settings, s, &mut acc, &stop);
            progress.rays.fetch_add(rays, Ordering::Relaxed);
            if progress.cancel.load(Ordering::Relaxed) {
                // Stopped part way (or after): not a point done.
                return Vec::new();
            }
            progress.points_done.fetch_add(1, Ordering::Relaxed);
            poll();
            let inv = 1.0 / settings.spp as f64;
            acc.iter().map(|v| (v * inv) as f32).collect()
        })
        .collect();
    if progress.cancel.load(Ordering::Relaxed) {
        return Err(NlosError::Setup("capture cancelled".into()));
    }
    // Time-major: h[t][l][s].
    let n_s = geometry.sensors.len();
    let per_t = n_s * per_sensor;
    let mut h = vec![0.0f32; per_t * bins];
    for (s, point) in per_point.iter().enumerate() {
        for l in 0..per_sensor {
            for (t, &v) in point[l * bins..(l + 1) * bins].iter().enumerate() {
                h[t * per_t + l * n_s + s] = v;
            }
        }
    }
    drop(per_point);
    Ok(Capture {
        geometry,
        h,
        spp: settings.spp,
        seed: settings.seed,
        max_bounces: settings.max_bounces,
        scene_name: scene.name.clone(),
        channel: settings.channel,
        render_s: start.elapsed().as_secs_f64(),
        rays: progress.rays.load(Ordering::Relaxed),
    })
}

/// Slots of a capture sample: the hidden point (one 2-D point: the triangle and the point
/// in it), then per hidden vertex `k` (0: the first) the camera integrator's per-vertex
/// slots (from `dim::vertex(2, _)`, after these).
const SLOT_POINT: u32 = 1;

/// Samples of a sensor point between two looks at whether the capture is cancelled.
pub const POLL_SAMPLES: u32 = 256;

/// All samples of sensor point `s`: adds `spp` times the transients' mean into `acc`
/// (`[laser][bin]`), unless `stop` (asked every [`POLL_SAMPLES`] samples) says the
/// capture is cancelled; returns the rays traced.
fn trace_point(
    hidden: &Hidden,
    g: &CaptureGeometry,
    settings: &CaptureSettings,
    s: usize,
    acc: &mut [f64],
    stop: &dyn Fn() -> bool,
) -> u64 {
    let Some(sensor) = g.sensors.get(s) else {
        return 0;
    };
    let lasers = g.lasers_of(s);
    let axis: &TimeAxis = &g.axis;
    let bins = axis.bins;
    let n = g.wall.normal;
    let sp_pos = sensor.position;
    let s_out = sp_pos + n * hidden.offset_m(sp_pos);
    let to_spad = (g.sensor_origin - sp_pos).normalize_or_zero();
    let sensor_leg_m = if g.device_legs {
        (g.sensor_origin - sp_pos).length() as f64
    } else {
        0.0
    };
    // Per laser point: its leg, and where shadow rays to it end.
    let laser_legs: Vec<f64> = lasers
        .iter()
        .map(|l| {
            if g.device_legs {
                (g.laser_origin - l.position).length() as f64
            } else {
                0.0
            }
        })
        .collect();
    let laser_outs: Vec<Vec3> = lasers
        .iter()
        .map(|l| l.position + n * hidden.offset_m(l.position))
        .collect();
    let to_laser_dev: Vec<Vec3> = lasers
        .iter()
        .map(|l| (g.laser_origin - l.position).normalize_or_zero())
        .collect();
    let sensor_spot = hidden.wall_spot(sensor, n);
    let laser_spots: Vec<WallSpot> = lasers.iter().map(|l| hidden.wall_spot(l, n)).collect();
    // The laser spot at the sensor point itself (a confocal scan): the first hidden
    // vertex's shadow segment to it is the one to the sensor point, traced once.
    let colocated = lasers.iter().position(|l| l.position == sp_pos);
    let end_opl_m = axis.end_s() * C_M_PER_S;
    let start_opl_m = axis.t0_s * C_M_PER_S;
    let min_leg = laser_legs.iter().copied().fold(f64::INFINITY, f64::min);
    let mut rng = Sampler::new(settings.seed, 0, s as u64);
    let mut rays = 0u64;
    for i in 0..settings.spp {
        if i > 0 && i % POLL_SAMPLES == 0 && stop() {
            break;
        }
        rng.start_sample();
        let Some((tri, u, v)) = hidden.sample_point(rng.get2(SLOT_POINT)) else {
            break;
        };
        let x = hidden.position(tri, u, v);
        let to_x = x - sp_pos;
        let d2 = to_x.length_squared();
        if !(d2 > 0.0) {
            continue;
        }
        let d = d2.sqrt();
        let dir = to_x / d;
        let cos_s = dir.dot(n);
        if cos_s <= 0.0 {
            continue;
        }
        let f_s = sensor_spot.f(dir, to_spad);
        if f_s <= 0.0 {
            continue;
        }
        let sp = hidden.surfaces.at(
            &Hit {
                t_m: d,
                triangle: tri,
                u,
                v,
            },
            sp_pos,
            dir,
        );
        let cos_x = sp.n_face.dot(-dir);
        if cos_x <= 0.0 {
            continue;
        }
        let mut opl_m = d as f64 + sensor_leg_m;
        if opl_m + min_leg > end_opl_m {
            continue;
        }
        let x_out = x + sp.n_face * hidden.offset_m(x);
        rays += 1;
        let vis = hidden.transmittance(s_out, x_out);
        if vis <= 0.0 {
            continue;
        }
        let mut throughput =
            f_s * cos_s * cos_x / d2 * hidden.total_area_m2 as f32 * vis * sp.coverage;
        let mut sp = sp;
        let mut wo_world = -dir;
        let mut k = 0u32;
        // Refractive index where the path is (light in glass travels at c / n).
        let mut ior_here = 1.0f32;
        loop {
            let frame = Frame::new(sp.n_shading);
            let wo = frame.to_local(wo_world);
            let x = sp.position;
            let x_out = x + sp.n_face * hidden.offset_m(x);
            // Join the laser spots (next-event estimation to points).
            if sp.bsdf.has_smooth_lobe() && ior_here == 1.0 {
                for (li, l) in lasers.iter().enumerate() {
                    let to_l = l.position - x;
                    let dl2 = to_l.length_squared();
                    if !(dl2 > 0.0) {
                        continue;
                    }
                    let dl = dl2.sqrt();
                    let wi = to_l / dl;
                    if wi.dot(sp.n_face) <= 0.0 {
                        continue;
                    }
                    let arrival_m = opl_m + dl as f64 + laser_legs[li];
                    if arrival_m < start_opl_m || arrival_m >= end_opl_m {
                        continue;
                    }
                    let Some(bin) = axis.bin_of(arrival_m / C_M_PER_S) else {
                        continue;
                    };
                    let wi_local = frame.to_local(wi);
                    let (f, _) = sp.bsdf.eval(wo, wi_local);
                    if f <= 0.0 {
                        continue;
                    }
                    // The spot's intensity toward x: Phi f_w(laser, -wi) cos theta.
                    let cos_l = (-wi).dot(n);
                    let f_l = laser_spots[li].f(to_laser_dev[li], -wi);
                    let intensity = f_l * cos_l;
                    if intensity <= 0.0 {
                        continue;
                    }
                    let tr = if k == 0 && colocated == Some(li) {
                        // The segment x1 - s, already traced (`vis`): the same ray's
                        // answer.
                        vis
                    } else {
                        rays += 1;
                        hidden.transmittance(x_out, laser_outs[li])
                    };
                    if tr <= 0.0 {
                        continue;
                    }
                    let value = throughput * f * wi_local.z * intensity / dl2 * tr;
                    if let Some(a) = acc.get_mut(li * bins + bin) {
                        *a += value as f64;
                    }
                }
            }
            // The next hidden vertex.
            if k + 1 >= settings.max_bounces {
                break;
            }
            let (s_lobe, s_dir, s_rr) = (
                dim::vertex(k + 2, dim::LOBE),
                dim::vertex(k + 2, dim::BSDF_DIRECTION),
                dim::vertex(k + 2, dim::ROULETTE),
            );
            let u_lobe = if sp.bsdf.single_lobe() {
                0.0
            } else {
                rng.get1(s_lobe)
            };
            let Some(bs) = sp.bsdf.sample(wo, u_lobe, rng.get2(s_dir)) else {
                break;
            };
            let wi_world = frame.to_world(bs.wi).normalize();
            let refracted = bs.kind == LobeKind::Refract;
            let geo = wi_world.dot(sp.n_face);
            if (refracted && geo >= 0.0) || (!refracted && geo <= 0.0) {
                break;
            }
            throughput *= bs.weight;
            if refracted {
                ior_here = if sp.front { sp.ior } else { 1.0 };
            }
            k += 1;
            if k >= RR_START {
                let q = throughput.min(1.0);
                if !(q > 0.0) || rng.get1(s_rr) >= q {
                    break;
                }
                throughput /= q;
            }
            if !(throughput.is_finite() && throughput > 0.0) {
                break;
            }
            let origin = x + sp.n_face * hidden.offset_m(x) * geo.signum();
            rays += 1;
            let Some(hit) = hidden.accel.closest_hit(origin, wi_world, f32::INFINITY) else {
                break;
            };
            opl_m += hit.t_m as f64 * ior_here as f64;
            if opl_m + min_leg > end_opl_m {
                break;
            }
            let next = hidden.surfaces.at(&hit, origin, wi_world);
            // A partly covered surface: the uncovered fraction is not followed (its light
            // is left out); the covered fraction scatters.
            throughput *= next.coverage;
            wo_world = -wi_world;
            sp = next;
        }
    }
    rays
}

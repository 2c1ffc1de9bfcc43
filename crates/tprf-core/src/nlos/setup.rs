//! The scan of an NLOS capture: where the SPAD looks (a grid of sensor points on the
//! relay wall), where the laser points (one fixed point, every sensor point in turn:
//! *confocal*, or a grid of its own: *exhaustive*), where the devices stand, and the
//! time axis, with or without the device-to-wall legs (tal's
//! `t_accounts_first_and_last_bounces`).

use super::NlosError;
use super::wall::{RelayWall, WallPoint};
use crate::budget::{format_bytes, format_count};
use crate::film::TimeAxis;
use crate::scene::{Channel, Scene};
use crate::units::C_M_PER_S;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Where the laser points.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scan {
    /// One fixed laser point: the given one (projected onto the wall), else the wall's
    /// centre. tal's `single`.
    Single { laser_point: Option<[f32; 3]> },
    /// The laser at each sensor point in turn.
    Confocal,
    /// Every laser point of an `lx x ly` grid with every sensor point.
    Exhaustive { lx: usize, ly: usize },
}

/// Largest number of sensor points times laser points of one capture (a sanity bound:
/// 256 x 256 sensor points, each with 64 x 64 laser points, is 2^28).
pub const MAX_TRANSIENTS: usize = 1 << 28;

/// What the user asks of a capture. Lengths in metres, times in seconds.
#[derive(Clone, Debug, PartialEq)]
pub struct CaptureSettings {
    /// Name of the relay wall's object (a glTF node).
    pub relay_wall: String,
    /// Sensor points along the wall's `u` and `v` axes.
    pub grid: [usize; 2],
    pub scan: Scan,
    /// Laser and SPAD device positions; `None`: tal's default, 0.5 m along `-u` from the
    /// wall's centre and 0.25 m in front (`(-0.5, 0, 0.25)` for tal's wall).
    pub laser_origin: Option<[f32; 3]>,
    pub sensor_origin: Option<[f32; 3]>,
    /// Bin count; `None`: up to the longest three-bounce path through the hidden
    /// geometry's vertices.
    pub bins: Option<usize>,
    pub dt_s: f64,
    pub t0_s: f64,
    /// Times include the laser-to-wall and wall-to-SPAD legs (tal's
    /// `t_accounts_first_and_last_bounces`); false: they start when the pulse hits the
    /// wall and end when the light returns to it ("unwarped").
    pub device_legs: bool,
    /// Samples per sensor point (each also serves every laser point of an exhaustive scan).
    pub spp: u32,
    pub seed: u64,
    /// Largest number of scattering events in the hidden scene (the two on the wall not
    /// counted).
    pub max_bounces: u32,
    pub channel: Channel,
}

impl Default for CaptureSettings {
    fn default() -> Self {
        CaptureSettings {
            relay_wall: "relay_wall".into(),
            grid: [64, 64],
            scan: Scan::Confocal,
            laser_origin: None,
            sensor_origin: None,
            bins: None,
            dt_s: 0.003 / C_M_PER_S,
            t0_s: 0.0,
            device_legs: false,
            spp: 256,
            seed: 0,
            max_bounces: 1024,
            channel: Channel::Gray,
        }
    }
}

/// A capture's geometry, resolved against the scene and checked.
#[derive(Clone, Debug, PartialEq)]
pub struct CaptureGeometry {
    pub wall: RelayWall,
    pub grid: [usize; 2],
    /// Sensor points, index `i ny + j`.
    pub sensors: Vec<WallPoint>,
    /// Laser points: one (single), the sensor points (confocal) or the laser grid
    /// (exhaustive, index `i ly + j`).
    pub lasers: Vec<WallPoint>,
    /// Laser grid shape: `[1, 1]` for one point, the sensor grid's for confocal.
    pub laser_grid: [usize; 2],
    pub scan: Scan,
    pub laser_origin: Vec3,
    pub sensor_origin: Vec3,
    pub axis: TimeAxis,
    pub device_legs: bool,
}

impl CaptureGeometry {
    /// Whether laser point `k` goes with sensor point `k` only (confocal).
    pub fn is_confocal(&self) -> bool {
        matches!(self.scan, Scan::Confocal)
    }

    /// Transients recorded per sensor point: 1, or the laser grid's points (exhaustive).
    pub fn lasers_per_sensor(&self) -> usize {
        match self.scan {
            Scan::Exhaustive { .. } => self.lasers.len(),
            _ => 1,
        }
    }

    /// The laser points sensor point `s` is recorded with.
    pub fn lasers_of(&self, s: usize) -> &[WallPoint] {
        match self.scan {
            Scan::Confocal => self.lasers.get(s..s + 1).unwrap_or(&[]),
            _ => &self.lasers,
        }
    }

    /// Optical path of the device legs of laser point `l` and sensor point `s`, metres
    /// (0 without [`CaptureSettings::device_legs`]).
    pub fn legs_m(&self, l: Vec3, s: Vec3) -> f64 {
        if self.device_legs {
            (self.laser_origin - l).length() as f64 + (s - self.sensor_origin).length() as f64
        } else {
            0.0
        }
    }
}

fn point_of(v: [f32; 3]) -> Vec3 {
    Vec3::from_array(v)
}

/// Bytes a wall point of a scan holds while it is resolved: its position on the grid
/// (`Vec3`), then its [`WallPoint`] (a confocal scan's laser points a copy of the
/// sensor points).
const BYTES_PER_WALL_POINT: u64 =
    (std::mem::size_of::<Vec3>() + std::mem::size_of::<WallPoint>()) as u64;

/// Bytes a capture holds per transient and time bin: the per-point transients and their
/// time-major copy, f32 each (as `capture::render_capture` budgets them).
pub const BYTES_PER_TRANSIENT_BIN: u64 = 8;

/// Refuse a scan whose sizes cannot be held, before any point of it is made: more than
/// [`MAX_TRANSIENTS`] transients, or wall points that do not fit in memory. The message
/// names the flags and the size foreseen.
fn check_size(settings: &CaptureSettings) -> Result<(), NlosError> {
    let [nx, ny] = settings.grid;
    let sensors = (nx as u64).saturating_mul(ny as u64);
    let (lasers, laser_flag) = match settings.scan {
        Scan::Single { .. } => (1, String::new()),
        Scan::Confocal => (sensors, String::new()),
        Scan::Exhaustive { lx, ly } => (
            (lx as u64).saturating_mul(ly as u64),
            format!(" --laser-grid {lx}x{ly}"),
        ),
    };
    let transients = match settings.scan {
        Scan::Exhaustive { .. } => sensors.saturating_mul(lasers),
        _ => sensors,
    };
    let points = sensors.saturating_add(lasers);
    let points_bytes = points.saturating_mul(BYTES_PER_WALL_POINT);
    let flags = format!("--grid {nx}x{ny}{laser_flag}");
    if transients > MAX_TRANSIENTS as u64 {
        return Err(NlosError::Setup(format!(
            "{flags} is {} transients ({} sensor points x {} laser point{}), more than the \
             {MAX_TRANSIENTS} one capture may hold: its wall points alone would need {}, and \
             its transients {} for each time bin; use a coarser --grid or --laser-grid",
            format_count(transients),
            format_count(sensors),
            format_count(lasers),
            if lasers == 1 { "" } else { "s" },
            format_bytes(points_bytes),
            format_bytes(transients.saturating_mul(BYTES_PER_TRANSIENT_BIN)),
        )));
    }
    crate::budget::check(
        points_bytes,
        "this capture",
        format!(
            "the wall points of {flags} ({} sensor and {} laser point{})",
            format_count(sensors),
            format_count(lasers),
            if lasers == 1 { "" } else { "s" },
        ),
    )?;
    Ok(())
}

/// Resolve `settings` against `scene`: the wall, its grids, the devices, the time axis.
/// Every refusal names the flag concerned.
pub fn resolve(scene: &Scene, settings: &CaptureSettings) -> Result<CaptureGeometry, NlosError> {
    let [nx, ny] = settings.grid;
    if nx == 0 || ny == 0 {
        return Err(NlosError::Setup(format!(
            "--grid {nx}x{ny}: a grid needs at least one sensor point along each axis (e.g. --grid 64x64)"
        )));
    }
    if settings.spp == 0 {
        return Err(NlosError::Setup(
            "--spp 0: a capture needs at least one sample per sensor point".into(),
        ));
    }
    check_size(settings)?;
    let wall = RelayWall::find(scene, &settings.relay_wall)?;
    let locate = |p: Vec3, what: &str| {
        wall.locate(scene, p).ok_or_else(|| {
            NlosError::Setup(format!(
                "{what} at {:?} is not on the relay wall '{}' (a hole, or a wall that is not \
                 a rectangle: the grid spans the wall's bounding rectangle)",
                p.to_array(),
                wall.name
            ))
        })
    };
    let sensors = wall
        .grid(nx, ny)
        .into_iter()
        .enumerate()
        .map(|(k, p)| locate(p, &format!("sensor point ({}, {})", k / ny, k % ny)))
        .collect::<Result<Vec<_>, _>>()?;
    let (lasers, laser_grid) = match settings.scan {
        Scan::Confocal => (sensors.clone(), [nx, ny]),
        Scan::Single { laser_point } => {
            let p = match laser_point {
                Some(p) => {
                    let p = point_of(p);
                    if !p.is_finite() {
                        return Err(NlosError::Setup(format!(
                            "--laser-point {:?} is not finite",
                            p.to_array()
                        )));
                    }
                    p - wall.normal * wall.height_above_m(p)
                }
                None => wall.center(),
            };
            (vec![locate(p, "--laser-point")?], [1, 1])
        }
        Scan::Exhaustive { lx, ly } => {
            if lx == 0 || ly == 0 {
                return Err(NlosError::Setup(format!(
                    "--laser-grid {lx}x{ly}: an exhaustive scan needs at least one laser point \
                     along each axis (e.g. --laser-grid 8x8)"
                )));
            }
            let points = wall
                .grid(lx, ly)
                .into_iter()
                .enumerate()
                .map(|(k, p)| locate(p, &format!("laser point ({}, {})", k / ly, k % ly)))
                .collect::<Result<Vec<_>, _>>()?;
            (points, [lx, ly])
        }
    };
    let default_device = wall.center() - wall.u_axis * 0.5 + wall.normal * 0.25;
    let device = |given: Option<[f32; 3]>, flag: &str| -> Result<Vec3, NlosError> {
        let p = given.map_or(default_device, point_of);
        if !p.is_finite() {
            return Err(NlosError::Setup(format!(
                "{flag} {:?} is not finite",
                p.to_array()
            )));
        }
        if !wall.in_front(p) {
            return Err(NlosError::Setup(format!(
                "{flag} {:?} is behind the relay wall '{}' (or on it): the devices look at the \
                 wall from the side of the hidden scene",
                p.to_array(),
                wall.name
            )));
        }
        Ok(p)
    };
    let laser_origin = device(settings.laser_origin, "--laser-origin")?;
    let sensor_origin = device(settings.sensor_origin, "--sensor-origin")?;
    if !(settings.dt_s.is_finite() && settings.dt_s > 0.0) {
        return Err(NlosError::Setup(format!(
            "--dt {} s: the bin width must be a positive time or length (e.g. 3mm, 10ps)",
            settings.dt_s
        )));
    }
    let bins = match settings.bins {
        Some(b) => b,
        None => {
            let longest_m = longest_three_bounce_m(
                scene,
                &wall,
                &sensors,
                &lasers,
                settings,
                laser_origin,
                sensor_origin,
            );
            let end_m = longest_m - settings.t0_s * C_M_PER_S;
            let bins = (end_m / (settings.dt_s * C_M_PER_S)).ceil();
            if !(bins >= 1.0) {
                return Err(NlosError::Setup(format!(
                    "--t0 {} s starts after the longest three-bounce path ({longest_m:.3} m): \
                     nothing would arrive; give a smaller --t0 or --bins",
                    settings.t0_s
                )));
            }
            (bins as usize).min(crate::film::MAX_BINS)
        }
    };
    let axis = TimeAxis::new(settings.t0_s, settings.dt_s, bins).map_err(|e| {
        NlosError::Setup(format!(
            "time axis (--t0 {} s, --dt {} s, --bins {bins}): {e}",
            settings.t0_s, settings.dt_s
        ))
    })?;
    Ok(CaptureGeometry {
        wall,
        grid: settings.grid,
        sensors,
        lasers,
        laser_grid,
        scan: settings.scan,
        laser_origin,
        sensor_origin,
        axis,
        device_legs: settings.device_legs,
    })
}

/// The longest optical path laser point -> hidden vertex -> sensor point over the hidden
/// geometry's vertices and the scan's points (device legs included when asked), metres.
fn longest_three_bounce_m(
    scene: &Scene,
    wall: &RelayWall,
    sensors: &[WallPoint],
    lasers: &[WallPoint],
    settings: &CaptureSettings,
    laser_origin: Vec3,
    sensor_origin: Vec3,
) -> f64 {
    let mut is_wall = vec![false; scene.triangles.len()];
    for &i in &wall.triangles {
        is_wall[i] = true;
    }
    // The farthest of a point set from x is at one of its bounding rectangle's corners
    // (distance is convex): the grids' corners suffice.
    let corners = |pts: &[WallPoint]| -> Vec<Vec3> {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in pts {
            lo = lo.min(p.position);
            hi = hi.max(p.position);
        }
        (0..8)
            .map(|k| {
                Vec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                )
            })
            .collect()
    };
    let (sc, lc) = (corners(sensors), corners(lasers));
    let legs = if settings.device_legs {
        let far = |o: Vec3, c: &[Vec3]| c.iter().map(|p| (*p - o).length()).fold(0.0f32, f32::max);
        (far(laser_origin, &lc) + far(sensor_origin, &sc)) as f64
    } else {
        0.0
    };
    let mut longest = 0.0f64;
    for (i, t) in scene.triangles.iter().enumerate() {
        if is_wall[i] {
            continue;
        }
        for x in t.p {
            let far = |c: &[Vec3]| c.iter().map(|p| (*p - x).length()).fold(0.0f32, f32::max);
            longest = longest.max((far(&sc) + far(&lc)) as f64);
        }
    }
    longest + legs
}

//! A SPAD on a capture: the model of `tprf sensor` (its light pulse, a TDC with jitter,
//! pile-up and dead time, afterpulsing, ambient and dark counts, a seeded realisation)
//! applied to every transient of a capture, without rendering again. The result is a
//! capture of photon counts on the TDC's bins, in the same format, which the
//! reconstructions read like any other.
//!
//! Each transient is one pixel of a cube `[Sx, Sy, T]` (`[Lx Ly Sx, Sy, T]` for an
//! exhaustive scan), so the SPAD's `[B, H, W]` arrays are tal's `H` `[B, Sx, Sy]`
//! (`[B, Lx, Ly, Sx, Sy]`) as they are. The capture's `H` is radiance x s per joule, the
//! unit of `(TPRF * Light)` the sensor's `photons_per_unit` converts (a preset's pulse
//! energy scales it).

use super::NlosError;
use super::files::LoadedCapture;
use crate::film::TimeAxis;
use crate::sensor::{Sensor, SensorModel, SpadImage, spad_image_ambient};
use crate::units::C_M_PER_S;

/// A capture measured by a SPAD: the counts as a capture (on the TDC's bins), and the
/// SPAD's image (expected histogram, counts, Coates estimate, depths).
pub struct SpadCapture {
    pub capture: LoadedCapture,
    pub image: SpadImage,
}

/// The SPAD of `sensor` (it needs a `[spad]` section and a `tdc` exposure) on capture `c`.
pub fn spad_capture(c: &LoadedCapture, sensor: Sensor) -> Result<SpadCapture, NlosError> {
    if sensor.spad.is_none() {
        return Err(NlosError::Setup(
            "--preset: the sensor has no [spad] section (e.g. --preset builtin:spad)".into(),
        ));
    }
    let t = c.bins();
    let axis = TimeAxis::new(c.t_start_m / C_M_PER_S, c.delta_t_m / C_M_PER_S, t)?;
    let model = SensorModel::new(sensor, axis)?;
    let k = c.h.len() / t.max(1);
    let width = c.sensor_shape[1].max(1);
    let height = k / width;
    // [H, W, T] = the transients, transient-major.
    let mut cube = vec![0.0f32; c.h.len()];
    for ti in 0..t {
        for ki in 0..k {
            cube[ki * t + ti] = c.h[ti * k + ki];
        }
    }
    let steady: Vec<f32> = cube
        .chunks(t.max(1))
        .map(|p| p.iter().map(|&v| v as f64).sum::<f64>() as f32)
        .collect();
    let signal = model.measure_clean(&cube, width, height)?;
    drop(cube);
    let image = spad_image_ambient(&model, &signal, &steady, None)?;
    let centres = model.gate_centres_s().unwrap_or_default();
    let bin_s = match (centres.first(), centres.get(1)) {
        (Some(a), Some(b)) => b - a,
        _ => c.delta_t_m / C_M_PER_S,
    };
    let start_s = centres.first().map_or(0.0, |a| a - 0.5 * bin_s);
    let mut h_shape = c.h_shape.clone();
    if let Some(first) = h_shape.first_mut() {
        *first = image.bins;
    }
    let capture = LoadedCapture {
        path: c.path.clone(),
        h: image.counts.clone(),
        h_shape,
        exhaustive: c.exhaustive,
        sensor_grid: c.sensor_grid.clone(),
        sensor_shape: c.sensor_shape,
        laser_grid: c.laser_grid.clone(),
        laser_shape: c.laser_shape,
        sensor_normal: c.sensor_normal,
        sensor_xyz: c.sensor_xyz,
        laser_xyz: c.laser_xyz,
        delta_t_m: bin_s * C_M_PER_S,
        t_start_m: start_s * C_M_PER_S,
        device_legs: c.device_legs,
    };
    Ok(SpadCapture { capture, image })
}

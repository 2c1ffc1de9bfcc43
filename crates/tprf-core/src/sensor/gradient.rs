//! The sensor's vector-Jacobian product: for `L = sum_{i, p} w[i, p] M_i[p]` with the
//! clean measurement `M_i[p] = sum_b TPRF[p, b] K_i[b]` (DESIGN.md: before ambient light
//! and noise), the gradient of `L`
//!
//! - with respect to the cube: `dL/dTPRF[p, b] = sum_i w[i, p] K_i[b]` (exact: `M` is
//!   linear in the cube), to chain into a differentiable render's backward;
//! - with respect to a numeric field of the light pulse or the gates (`light.centre_s`,
//!   `light.fwhm_s`, `light.energy`, `exposure.start_s`, `exposure.width_s`,
//!   `exposure.step_s`, ...): `dL/dtheta = sum_i sum_b a_i[b] dK_i[b]/dtheta` with
//!   `a_i[b] = sum_p w[i, p] TPRF[p, b]` reduced once over the pixels.
//!
//! `dK_i[b]/dtheta` is the central difference `(K(theta + h) - K(theta - h)) / 2h` of the
//! kernels, which are deterministic functions of the fields (closed forms for a Gaussian
//! light through a box, Gaussian or jittered gate; Gauss-Legendre between the kinks
//! otherwise): no Monte Carlo noise. The step is `h = 1e-4` of the field's natural
//! scale (the bin width for times, the value for an energy), so the truncation error is
//! `h^2 K''' / 6`, about 1e-8 of the derivative for kernels smooth on the scale of a bin,
//! and the rounding error `eps K / h`, about 1e-11 of it; a kernel linear in the field
//! (`energy`) has none. Where a kernel has a kink at `theta` (a box light's edge meeting
//! a box gate's edge exactly) the difference is the mean of the two one-sided
//! derivatives. Counts (`count`, `lobes`) are not differentiable and are refused, as are
//! the noise and SPAD fields: the expected value of `max(0, M + noise)` and of a SPAD's
//! counts is not the clean measurement, whose derivative this is.

use super::fields::{Field, Quantity};
use super::{Sensor, SensorError, SensorModel};
use crate::film::TimeAxis;

/// The gradients of `L = sum(w x clean measurement)`.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasurementVjp {
    /// `dL/dtheta` per field asked for, in their order.
    pub fields: Vec<f64>,
    /// `dL/dTPRF`, `[height, width, T]`.
    pub cube: Vec<f32>,
}

/// Relative step of the central differences of the kernels.
const STEP: f64 = 1e-4;

/// The field `name` (`light.KEY` or `exposure.KEY`) of `sensor`: its description.
fn field_of(sensor: &Sensor, name: &str) -> Result<Field, SensorError> {
    let bad = |why: String| SensorError::Invalid(format!("{name}: {why}"));
    let (part, key) = name
        .split_once('.')
        .ok_or_else(|| bad("a field is light.KEY or exposure.KEY".into()))?;
    let fields = match part {
        "light" => sensor.light.fields(),
        "exposure" => sensor.exposure.fields(),
        "noise" | "spad" => {
            return Err(bad(format!(
                "the {part}'s fields are not differentiable here: the expected {} is not \
                 the clean measurement whose derivative this is",
                if part == "noise" {
                    "value of max(0, M + noise)"
                } else {
                    "count of a SPAD"
                }
            )));
        }
        _ => return Err(bad("a field is light.KEY or exposure.KEY".into())),
    };
    let known = || {
        fields
            .iter()
            .map(|f| format!("{part}.{}", f.key))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let f = fields
        .iter()
        .find(|f| f.key == key)
        .cloned()
        .ok_or_else(|| bad(format!("no such field; this sensor's: {}", known())))?;
    if f.quantity == Quantity::Count {
        return Err(bad("a count is not differentiable".into()));
    }
    Ok(f)
}

/// `sensor` with field `name` set to `value`.
fn with_field(sensor: &Sensor, name: &str, value: f64) -> Result<Sensor, SensorError> {
    let mut s = sensor.clone();
    let ok = match name.split_once('.') {
        Some(("light", key)) => s.light.set_field(key, value),
        Some(("exposure", key)) => s.exposure.set_field(key, value),
        _ => false,
    };
    if !ok {
        return Err(SensorError::Invalid(format!(
            "{name}: cannot be set to {value} (differentiated at the edge of its range?)"
        )));
    }
    Ok(s)
}

/// The gradients of `L = sum_{i, p} weights[i, p] M_i[p]` (module doc) for the cube
/// `[height, width, T]` on `axis` and weights `[N, height, width]` (N gates), with
/// respect to the cube and to each of `fields`.
pub fn measurement_vjp(
    sensor: &Sensor,
    axis: TimeAxis,
    cube: &[f32],
    width: usize,
    height: usize,
    weights: &[f32],
    fields: &[String],
) -> Result<MeasurementVjp, SensorError> {
    let model = SensorModel::new(sensor.clone(), axis)?;
    let (n, t, plane) = (model.gate_count(), axis.bins, width * height);
    if cube.len() != plane * t {
        return Err(SensorError::Invalid(format!(
            "the cube holds {} values; {height} x {width} x {t} expected",
            cube.len()
        )));
    }
    if weights.len() != n * plane {
        return Err(SensorError::Invalid(format!(
            "the weights hold {} values; the measurement is {n} x {height} x {width}",
            weights.len()
        )));
    }
    let descriptions = fields
        .iter()
        .map(|f| field_of(sensor, f))
        .collect::<Result<Vec<_>, _>>()?;
    // dL/dTPRF[p, b] = sum_i w[i, p] K_i[b].
    let mut d_cube = vec![0f32; plane * t];
    for (i, k) in model.kernels().iter().enumerate() {
        for p in 0..plane {
            let w = weights[i * plane + p];
            if w == 0.0 {
                continue;
            }
            let row = &mut d_cube[p * t..(p + 1) * t];
            for b in k.bins() {
                row[b] += (w as f64 * k.get(b)) as f32;
            }
        }
    }
    // a_i[b] = sum_p w[i, p] TPRF[p, b].
    let mut adjoint = vec![0f64; n * t];
    for i in 0..n {
        let a = &mut adjoint[i * t..(i + 1) * t];
        for p in 0..plane {
            let w = weights[i * plane + p] as f64;
            if w == 0.0 {
                continue;
            }
            for (ab, &v) in a.iter_mut().zip(&cube[p * t..(p + 1) * t]) {
                *ab += w * v as f64;
            }
        }
    }
    let l_of = |s: &Sensor| -> Result<f64, SensorError> {
        let m = SensorModel::new(s.clone(), axis)?;
        let mut l = 0.0;
        for (i, k) in m.kernels().iter().enumerate() {
            let a = &adjoint[i * t..(i + 1) * t];
            l += k.bins().map(|b| a[b] * k.get(b)).sum::<f64>();
        }
        Ok(l)
    };
    let mut d_fields = Vec::with_capacity(fields.len());
    for (name, f) in fields.iter().zip(&descriptions) {
        let scale = match f.quantity {
            Quantity::Time => axis.dt_s,
            _ => f.value.abs().max(f64::MIN_POSITIVE),
        };
        let h = STEP * scale;
        let plus = l_of(&with_field(sensor, name, f.value + h)?)?;
        let minus = l_of(&with_field(sensor, name, f.value - h)?)?;
        d_fields.push((plus - minus) / (2.0 * h));
    }
    Ok(MeasurementVjp {
        fields: d_fields,
        cube: d_cube,
    })
}

//! The sensor's vector-Jacobian product (`sensor::gradient`) against what follows from
//! the measurement alone: `M` is linear in the cube (Euler: `sum dL/dTPRF x TPRF = L`)
//! and in the light's energy; shifting the light by `d` is shifting the gates by `-d`
//! (so `dL/dcentre = -dL/dstart`); and Richardson-extrapolated central differences of
//! the clean measurement itself with steps a hundred times larger.

use tprf_core::film::TimeAxis;
use tprf_core::sensor::gradient::measurement_vjp;
use tprf_core::sensor::{Exposure, LightPulse, Sensor, SensorModel};

/// Deterministic numbers in (0.1, 1.1).
fn numbers(n: usize, seed: u64) -> Vec<f32> {
    let mut x = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (0..n)
        .map(|_| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            0.1 + (x >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect()
}

fn setup() -> (Sensor, TimeAxis, Vec<f32>, Vec<f32>, usize, usize) {
    let axis = TimeAxis::new(0.0, 1e-10, 60).unwrap();
    let mut exposure = Exposure::of_kind("box", 6e-9);
    assert!(exposure.set_field("step_s", 0.21e-9) && exposure.set_field("width_s", 0.23e-9));
    let sensor = Sensor::new(LightPulse::of_kind("gaussian", 1.03e-9, 0.31e-9), exposure);
    let (w, h) = (4, 3);
    let n = SensorModel::new(sensor.clone(), axis).unwrap().gate_count();
    let cube = numbers(w * h * axis.bins, 1);
    let weights = numbers(n * w * h, 2);
    (sensor, axis, cube, weights, w, h)
}

/// `L = sum(weights x clean measurement)` of `sensor`, in f64 from its kernels
/// (`M_i[p] = sum_b TPRF[p, b] K_i[b]`; the measurement's own values are float32, too
/// coarse for differences); checked against the float32 measurement.
fn loss(sensor: &Sensor, axis: TimeAxis, cube: &[f32], weights: &[f32], w: usize, h: usize) -> f64 {
    let model = SensorModel::new(sensor.clone(), axis).unwrap();
    let (t, plane) = (axis.bins, w * h);
    let mut l = 0.0;
    for (i, k) in model.kernels().iter().enumerate() {
        for p in 0..plane {
            let m: f64 = k.bins().map(|b| cube[p * t + b] as f64 * k.get(b)).sum();
            l += weights[i * plane + p] as f64 * m;
        }
    }
    let m32 = model.measure_clean(cube, w, h).unwrap();
    let l32: f64 = m32
        .values
        .iter()
        .zip(weights)
        .map(|(&a, &b)| a as f64 * b as f64)
        .sum();
    assert!((l32 - l).abs() < 1e-5 * l, "{l32} vs {l}");
    l
}

fn set(sensor: &Sensor, name: &str, value: f64) -> Sensor {
    let mut s = sensor.clone();
    let ok = match name.split_once('.').unwrap() {
        ("light", k) => s.light.set_field(k, value),
        (_, k) => s.exposure.set_field(k, value),
    };
    assert!(ok, "{name} = {value}");
    s
}

#[test]
fn sensor_gradients_match_linearity_shifts_and_differences() {
    let (sensor, axis, cube, weights, w, h) = setup();
    let fields: Vec<String> = [
        "light.energy",
        "light.centre_s",
        "light.fwhm_s",
        "exposure.start_s",
        "exposure.width_s",
        "exposure.step_s",
    ]
    .map(String::from)
    .to_vec();
    let g = measurement_vjp(&sensor, axis, &cube, w, h, &weights, &fields).unwrap();
    let l = loss(&sensor, axis, &cube, &weights, w, h);
    assert!(l > 0.0);
    // Euler: M is linear in the cube.
    let euler: f64 = g
        .cube
        .iter()
        .zip(&cube)
        .map(|(&a, &b)| a as f64 * b as f64)
        .sum();
    assert!((euler - l).abs() < 1e-5 * l, "{euler} vs {l}");
    // Linear in the energy (1 J here).
    assert!(
        (g.fields[0] - l).abs() < 1e-6 * l,
        "dL/dE {} vs {l}",
        g.fields[0]
    );
    // A light later by d is the gates earlier by d.
    let (centre, start) = (g.fields[1], g.fields[3]);
    assert!(
        centre.abs() > 0.0 && (centre + start).abs() < 1e-5 * centre.abs(),
        "{centre} {start}"
    );
    // Central differences of the measurement with h = dt / 100 and dt / 200,
    // Richardson-extrapolated (error O(h^4)).
    let values = [1.0, 1.03e-9, 0.31e-9, 0.0, 0.23e-9, 0.21e-9];
    for (k, name) in fields.iter().enumerate().skip(1) {
        let d = |step: f64| {
            let p = loss(
                &set(&sensor, name, values[k] + step),
                axis,
                &cube,
                &weights,
                w,
                h,
            );
            let m = loss(
                &set(&sensor, name, values[k] - step),
                axis,
                &cube,
                &weights,
                w,
                h,
            );
            (p - m) / (2.0 * step)
        };
        let step = axis.dt_s / 100.0;
        let want = (4.0 * d(step / 2.0) - d(step)) / 3.0;
        assert!(
            (g.fields[k] - want).abs() < 1e-4 * want.abs().max(1e-3 * l / axis.dt_s),
            "{name}: {} vs differences {want}",
            g.fields[k]
        );
    }
}

#[test]
fn sensor_fields_that_are_not_smooth_are_refused() {
    let (sensor, axis, cube, weights, w, h) = setup();
    for (name, says) in [
        ("noise.sigma", "not differentiable"),
        ("exposure.count", "count is not differentiable"),
        ("light.bogus", "light.centre_s"),
        ("camera.fov", "light.KEY or exposure.KEY"),
    ] {
        let e = measurement_vjp(&sensor, axis, &cube, w, h, &weights, &[name.to_string()])
            .unwrap_err()
            .to_string();
        assert!(e.contains(name) && e.contains(says), "{name}: {e}");
    }
    let e = measurement_vjp(&sensor, axis, &cube, w, h, &weights[1..], &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("weights"), "{e}");
}

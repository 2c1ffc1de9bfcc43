//! The TPRF sensor (paper, section 6) against cases derived by hand.
//!
//! Notation: a cube bin `b` covers `[tau_b, tau_b + dt)` and its value `w` is taken as
//! spread uniformly over the bin, so a measurement is `w` times the kernel averaged over
//! the bin, `(1/dt) integral_{tau_b}^{tau_b + dt} K(tau) dtau`, with
//! `K(tau) = integral Light(t - tau) Exposure(t) dt = P(tau + s in gate)` for a
//! unit-energy light whose emission time `s` has density `Light`.
//!
//! `Phi` is the standard normal CDF and `I(x) = x Phi(x) + phi(x)` its primitive.

use std::f64::consts::{PI, SQRT_2, TAU};

use tprf_core::film::TimeAxis;
use tprf_core::oned::{ImpulseOptions, World, binned};
use tprf_core::sensor::light::FWHM_PER_SIGMA;
use tprf_core::sensor::noise::standard_normal;
use tprf_core::sensor::{
    Exposure, LightPulse, Noise, Point, Sensor, SensorError, SensorModel, TimeOrigin, Update,
};
use tprf_core::units::C_M_PER_S;

const NS: f64 = 1e-9;

fn phi_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / SQRT_2)
}

fn phi_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * PI).sqrt()
}

/// `integral Phi`.
fn phi_int(x: f64) -> f64 {
    x * phi_cdf(x) + phi_pdf(x)
}

fn axis(t0_s: f64, dt_s: f64, bins: usize) -> TimeAxis {
    match TimeAxis::new(t0_s, dt_s, bins) {
        Ok(a) => a,
        Err(e) => panic!("{e}"),
    }
}

fn model(light: LightPulse, exposure: Exposure, axis: TimeAxis) -> SensorModel {
    match SensorModel::new(Sensor::new(light, exposure), axis) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    }
}

fn gaussian(centre_s: f64, sigma_s: f64) -> LightPulse {
    LightPulse::Gaussian {
        centre_s,
        fwhm_s: sigma_s * FWHM_PER_SIGMA,
        energy: 1.0,
    }
}

fn boxes(start_s: f64, width_s: f64, count: u64) -> Exposure {
    Exposure::Box {
        origin: TimeOrigin::Pulse,
        start_s,
        width_s,
        step_s: None,
        count,
        gain: 1.0,
    }
}

/// A pseudo-random cube (fixed LCG), values in [0, 1).
fn random_cube(len: usize, seed: u64) -> Vec<f32> {
    let mut s = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    (0..len)
        .map(|_| {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect()
}

/// One impulse of weight `w` in bin `b` of a 1 x 1 cube.
fn impulse_cube(bins: usize, b: usize, w: f32) -> Vec<f32> {
    let mut c = vec![0.0; bins];
    c[b] = w;
    c
}

#[test]
fn delta_tprf_gaussian_light_box_gate_is_the_erf_formula() {
    // K_bin = (sigma/dt) { [I(x1a) - I(x1b)] - [I(x0a) - I(x0b)] },
    // x_ga = (g - tau_b - mu) / sigma, x_gb = x_ga - dt / sigma.
    let a = axis(20.0 * NS, 0.1 * NS, 400);
    let (g0, g1, mu) = (30.37 * NS, 34.81 * NS, 2.0 * NS);
    for sigma_bins in [1e-3, 0.1, 1.0, 3.0, 30.0] {
        let sigma = sigma_bins * a.dt_s;
        let m = model(gaussian(mu, sigma), boxes(g0, g1 - g0, 1), a);
        let k = &m.kernels()[0];
        let mut worst: f64 = 0.0;
        for b in 0..a.bins {
            let tau = a.bin_start_s(b);
            let term = |g: f64| {
                let xa = (g - tau - mu) / sigma;
                let xb = (g - tau - a.dt_s - mu) / sigma;
                sigma / a.dt_s * (phi_int(xa) - phi_int(xb))
            };
            let want = term(g1) - term(g0);
            worst = worst.max((k.get(b) - want).abs());
            if b % 7 == 0 {
                // Through the f32 measurement of a delta TPRF of weight 0.37.
                let cube = impulse_cube(a.bins, b, 0.37);
                let Ok(meas) = m.measure(&cube, 1, 1) else {
                    panic!("measure");
                };
                let got = f64::from(meas.values[0]);
                assert!(
                    (got - 0.37 * want).abs() <= 1e-6 * 0.37 * want.max(1e-3),
                    "sigma {sigma_bins} bins, bin {b}: M {got}, want {}",
                    0.37 * want
                );
            }
        }
        assert!(worst < 1e-9, "sigma {sigma_bins} bins: worst error {worst}");
    }
    // Bins much narrower than the pulse: the point formula
    // M = w [Phi((g1 - t - mu)/sigma) - Phi((g0 - t - mu)/sigma)] at the bin centre t.
    let a = axis(20.0 * NS, 1e-3 * NS, 20_000);
    let sigma = 1.0 * NS;
    let m = model(gaussian(mu, sigma), boxes(g0, g1 - g0, 1), a);
    for b in (0..a.bins).step_by(997) {
        let t = a.bin_center_s(b);
        let want = phi_cdf((g1 - t - mu) / sigma) - phi_cdf((g0 - t - mu) / sigma);
        assert!((m.kernels()[0].get(b) - want).abs() < 1e-7, "bin {b}");
    }
}

#[test]
fn other_closed_forms() {
    let a = axis(10.0 * NS, 0.25 * NS, 160);
    let dt = a.dt_s;
    // Exponential light (onset o, time constant te) and a box gate:
    // F(v) = 1 - exp(-v/te), J(v) = integral F = v - te (1 - exp(-v/te)) for v >= 0;
    // K_bin = (1/dt) sum_g +-[J(g - tau_b - o) - J(g - tau_b - dt - o)].
    let (o, te, g0, g1) = (0.5 * NS, 1.7 * NS, 17.1 * NS, 23.9 * NS);
    let j = |v: f64| {
        if v > 0.0 {
            v - te * (1.0 - (-v / te).exp())
        } else {
            0.0
        }
    };
    let m = model(
        LightPulse::Exponential {
            onset_s: o,
            tau_s: te,
            energy: 1.0,
        },
        boxes(g0, g1 - g0, 1),
        a,
    );
    for b in 0..a.bins {
        let tau = a.bin_start_s(b);
        let term = |g: f64| (j(g - tau - o) - j(g - tau - dt - o)) / dt;
        let want = term(g1) - term(g0);
        assert!(
            (m.kernels()[0].get(b) - want).abs() < 1e-9,
            "exponential, bin {b}"
        );
    }
    // Gaussian light (mu, s) and a Gaussian gate (c, sg, peak p):
    // K(tau) = p sg sqrt(2 pi) N(c - tau - mu; S), S^2 = s^2 + sg^2, so
    // K_bin = p sg sqrt(2 pi) / dt [Phi((c - tau_b - mu)/S) - Phi((c - tau_b - dt - mu)/S)].
    let (mu, s, c, sg, p) = (1.0 * NS, 0.4 * NS, 25.0 * NS, 1.1 * NS, 0.8);
    let m = model(
        gaussian(mu, s),
        Exposure::Gaussian {
            origin: TimeOrigin::Pulse,
            centre_s: c,
            fwhm_s: sg * FWHM_PER_SIGMA,
            step_s: None,
            count: 1,
            peak: p,
        },
        a,
    );
    let big_s = (s * s + sg * sg).sqrt();
    for b in 0..a.bins {
        let tau = a.bin_start_s(b);
        let want = p * sg * (2.0 * PI).sqrt() / dt
            * (phi_cdf((c - tau - mu) / big_s) - phi_cdf((c - tau - dt - mu) / big_s));
        assert!(
            (m.kernels()[0].get(b) - want).abs() < 1e-9,
            "gaussian gate, bin {b}"
        );
    }
    // Gaussian light and AMCW gates (1 + m cos(w t - phi)) / 2:
    // K(tau) = (1 + m exp(-w^2 s^2 / 2) cos(w (tau + mu) - phi)) / 2, and over a bin
    // the cosine is multiplied by sinc(w dt / 2) and taken at the bin centre.
    let f = 60e6;
    let w = TAU * f;
    let m = model(
        gaussian(mu, s),
        Exposure::Amcw {
            freq_hz: f,
            phase_steps: 4,
            phase0_deg: 10.0,
            modulation: 0.9,
        },
        a,
    );
    let sinc = (0.5 * w * dt).sin() / (0.5 * w * dt);
    for (i, k) in m.kernels().iter().enumerate() {
        let phase = (10.0 + 90.0 * i as f64).to_radians();
        for b in 0..a.bins {
            let tc = a.bin_center_s(b);
            let want = 0.5
                * (1.0 + 0.9 * (-0.5 * w * w * s * s).exp() * sinc * (w * (tc + mu) - phase).cos());
            assert!((k.get(b) - want).abs() < 1e-9, "amcw gate {i}, bin {b}");
        }
    }
}

/// Pulses of every shape, `width` seconds wide, unit energy.
fn shapes(centre_s: f64, width: f64) -> Vec<LightPulse> {
    vec![
        LightPulse::Gaussian {
            centre_s,
            fwhm_s: width,
            energy: 1.0,
        },
        LightPulse::Rect {
            start_s: centre_s,
            width_s: width,
            energy: 1.0,
        },
        LightPulse::Exponential {
            onset_s: centre_s,
            tau_s: width,
            energy: 1.0,
        },
        LightPulse::LaserDiode {
            onset_s: centre_s,
            rise_s: 0.2 * width,
            fall_s: width,
            energy: 1.0,
        },
        LightPulse::Sinc2 {
            centre_s,
            width_s: width,
            lobes: 8,
            energy: 1.0,
        },
        LightPulse::PiecewiseLinear {
            points: vec![
                Point(centre_s, 0.0),
                Point(centre_s + 0.2 * width, 1.0),
                Point(centre_s + width, 0.0),
            ],
            energy: 1.0,
        },
    ]
}

#[test]
fn energy_is_conserved_for_pulses_from_a_thousandth_to_a_thousand_bins() {
    let a = axis(0.0, 10e-12, 200);
    let cube = random_cube(2 * 3 * a.bins, 11);
    let total: Vec<f64> = cube
        .chunks(a.bins)
        .map(|px| px.iter().map(|&v| f64::from(v)).sum())
        .collect();
    for k in -3..=3 {
        let width = a.dt_s * 10f64.powi(k);
        for light in shapes(0.3 * NS + 0.37 * a.dt_s, width) {
            let what = format!("{} {} bins wide", light.kind_name(), 10f64.powi(k));
            // One gate open for all time: every bin meets K = 1.
            let all = model(light.clone(), boxes(-0.5, 1.0, 1), a);
            let k0 = &all.kernels()[0];
            for b in 0..a.bins {
                assert!(
                    (k0.get(b) - 1.0).abs() < 1e-9,
                    "{what}: K[{b}] = {}",
                    k0.get(b)
                );
            }
            let Ok(m) = all.measure(&cube, 3, 2) else {
                panic!("measure");
            };
            for (got, want) in m.values.iter().zip(&total) {
                assert!((f64::from(*got) / want - 1.0).abs() < 1e-6, "{what}");
            }
            // Sixteen gates side by side over the light's whole reach: their kernels
            // add up to 1 in every bin.
            let tiles = model(light.clone(), boxes(-0.5e-6, 1e-6 / 16.0, 16), a);
            for b in 0..a.bins {
                let sum: f64 = tiles.kernels().iter().map(|k| k.get(b)).sum();
                assert!(
                    (sum - 1.0).abs() < 1e-9,
                    "{what}: sum of tiles {sum} in bin {b}"
                );
            }
            // (TPRF * Light) on the bins keeps the energy of an impulse mid-window when
            // the pulse fits in the window.
            if k <= 0 {
                let Ok(trace) = all.pixel_trace(&impulse_cube(a.bins, 20, 1.0)) else {
                    panic!("trace");
                };
                let e: f64 = trace.tprf_light.iter().sum();
                assert!((e - 1.0).abs() < 1e-9, "{what}: TPRF*Light sums to {e}");
            }
        }
    }
    // The energy parameter scales everything.
    let light = LightPulse::Gaussian {
        centre_s: NS,
        fwhm_s: 0.05 * NS,
        energy: 2.5,
    };
    let m = model(light, boxes(-0.5, 1.0, 1), a);
    assert!((m.kernels()[0].get(3) - 2.5).abs() < 1e-9);
}

#[test]
fn measurement_is_linear_in_the_tprf() {
    let a = axis(5.0 * NS, 0.05 * NS, 128);
    let (w, h) = (4, 3);
    let x = random_cube(w * h * a.bins, 1);
    let y = random_cube(w * h * a.bins, 2);
    let (ca, cb) = (0.7f32, -1.3f32);
    let mix: Vec<f32> = x.iter().zip(&y).map(|(p, q)| ca * p + cb * q).collect();
    for exposure in [
        boxes(6.0 * NS, 0.4 * NS, 12),
        Exposure::Amcw {
            freq_hz: 20e6,
            phase_steps: 4,
            phase0_deg: 0.0,
            modulation: 1.0,
        },
    ] {
        let m = model(gaussian(NS, 0.2 * NS), exposure, a);
        let (Ok(mx), Ok(my), Ok(mm)) = (
            m.measure_clean(&x, w, h),
            m.measure_clean(&y, w, h),
            m.measure_clean(&mix, w, h),
        ) else {
            panic!("measure");
        };
        for j in 0..mm.values.len() {
            let want =
                f64::from(ca) * f64::from(mx.values[j]) + f64::from(cb) * f64::from(my.values[j]);
            let scale = f64::from(ca.abs() * mx.values[j].abs() + cb.abs() * my.values[j].abs());
            assert!(
                (f64::from(mm.values[j]) - want).abs() <= 1e-5 * scale + 1e-7,
                "value {j}"
            );
        }
    }
}

#[test]
fn measurements_are_never_negative() {
    let a = axis(0.0, 0.1 * NS, 64);
    let mut cube = random_cube(5 * 5 * a.bins, 3);
    // A user's cube may hold negative values.
    for (j, v) in cube.iter_mut().enumerate() {
        if j % 5 == 0 {
            *v = -*v;
        }
    }
    for (sigma, photons) in [(0.0, 0.0), (0.3, 0.0), (5.0, 0.0), (0.3, 50.0), (0.0, 1e3)] {
        let mut sensor = Sensor::new(gaussian(NS, 0.3 * NS), boxes(0.0, 0.5 * NS, 16));
        sensor.noise = Noise {
            sigma,
            seed: 9,
            photons_per_energy: photons,
        };
        let Ok(m) = SensorModel::new(sensor, a) else {
            panic!("model");
        };
        let Ok(meas) = m.measure(&cube, 5, 5) else {
            panic!("measure");
        };
        assert!(
            meas.values.iter().all(|v| *v >= 0.0 && v.is_finite()),
            "sigma {sigma}, photons {photons}"
        );
        // A NaN or an infinity in the cube is refused, naming where it reaches a gate,
        // instead of becoming a 0 (max(0, NaN)) in some gates.
        for bad in [f32::NAN, f32::INFINITY] {
            let mut broken = cube.clone();
            broken[5 * a.bins + 7] = bad;
            let err = m.measure(&broken, 5, 5).err().map(|e| e.to_string());
            assert!(
                err.as_deref().is_some_and(
                    |e| e.contains("pixel (row 0, column 5)") || e.contains("row 1, column 0")
                ),
                "{err:?}"
            );
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_noise() {
    let a = axis(0.0, 0.1 * NS, 64);
    // A bright cube, so that max(0, .) never clips.
    let cube: Vec<f32> = random_cube(6 * 4 * a.bins, 4)
        .iter()
        .map(|v| 100.0 + v)
        .collect();
    let run = |light: LightPulse, sigma: f64, seed: u64| {
        let mut s = Sensor::new(light, boxes(0.5 * NS, 2.0 * NS, 3));
        s.noise = Noise {
            sigma,
            seed,
            photons_per_energy: 0.0,
        };
        let Ok(m) = SensorModel::new(s, a) else {
            panic!("model");
        };
        let (Ok(clean), Ok(noisy)) = (m.measure_clean(&cube, 6, 4), m.measure(&cube, 6, 4)) else {
            panic!("measure");
        };
        (clean.values, noisy.values)
    };
    let light = gaussian(NS, 0.2 * NS);
    let (clean, a1) = run(light.clone(), 0.5, 42);
    let (_, a2) = run(light.clone(), 0.5, 42);
    assert_eq!(a1, a2);
    let (_, b) = run(light.clone(), 0.5, 43);
    assert_ne!(a1, b);
    // The noise is sigma times one fixed field z_j: a slider change rescales it, and a
    // light edit keeps it.
    for (j, (&m, &c)) in a1.iter().zip(&clean).enumerate() {
        assert_eq!(m, c + 0.5f32 * standard_normal(42, j as u64));
    }
    let other_light = LightPulse::Rect {
        start_s: 0.0,
        width_s: 0.7 * NS,
        energy: 1.0,
    };
    let (clean2, c2) = run(other_light, 0.25, 42);
    for j in 0..c2.len() {
        assert_eq!(c2[j], clean2[j] + 0.25f32 * standard_normal(42, j as u64));
    }
}

/// The paper's 1-D world (its Figure 4, `assets/oned/figure4.json`) through the
/// full-waveform LiDAR preset: Figure 5 (the impulse train), Figure 6 (convolved with
/// the Gaussian pulse) and Figure 7 (box-gated measurements). Each impulse becomes one
/// pulse of the waveform, with the impulse's weight as area, at the impulse's time
/// plus the pulse's delay; consecutive pulses from B are 2 d(A, B) / c apart.
#[test]
fn the_one_d_world_through_the_lidar_preset_gives_figure_7() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/oned/figure4.json");
    let world = match World::from_path(&path) {
        Ok(w) => w,
        Err(e) => panic!("{e}"),
    };
    let impulses = world.impulses(&ImpulseOptions::default());
    let a = axis(50.0 * NS, 0.1 * NS, 2560);
    let cube: Vec<f32> = binned(&impulses, a.t0_s, a.dt_s, a.bins)
        .iter()
        .map(|&v| v as f32)
        .collect();
    let sensor = match Sensor::builtin("lidar") {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    };
    let Ok(m) = SensorModel::new(sensor, a) else {
        panic!("model");
    };
    let delay = m.light().mean_s();
    assert_eq!(delay, 5.0 * NS);
    let Ok(meas) = m.measure(&cube, 1, 1) else {
        panic!("measure");
    };
    let Some(centres) = m.gate_centres_s() else {
        panic!("box gates have centres");
    };
    // Hand-derived from the file: A reflects rA = 0.3; through A and back off B:
    // tA tA' rB = 0.6 * 0.6 * 0.8 = 0.288; once more between B and A: x rA' rB = 0.24.
    // The eye at 0 and the light at -0.5 (L -> A -> E is 20.5 m); A at 10, B at 25.
    let want_times = [20.5 / C_M_PER_S, 50.5 / C_M_PER_S, 80.5 / C_M_PER_S];
    let want_weights = [0.3, 0.288, 0.288 * 0.24];
    let waveform: Vec<f64> = meas.values.iter().map(|&v| f64::from(v)).collect();
    let trace = match m.pixel_trace(&cube) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    let bin_times: Vec<f64> = (0..a.bins).map(|b| a.bin_center_s(b)).collect();
    for (what, values, times) in [
        ("Figure 7 (gates)", &waveform, &centres),
        ("Figure 6 (TPRF * Light)", &trace.tprf_light, &bin_times),
    ] {
        // The pulses are separated by runs of exact zeros (tails cut at 8 sigma).
        let mut returns = Vec::new();
        let mut i = 0;
        while i < values.len() {
            if values[i] > 0.0 {
                let start = i;
                while i < values.len() && values[i] > 0.0 {
                    i += 1;
                }
                let area: f64 = values[start..i].iter().sum();
                let moment: f64 = (start..i).map(|k| values[k] * times[k]).sum();
                returns.push((moment / area, area));
            }
            i += 1;
        }
        assert_eq!(returns.len(), 3, "{what}: {returns:?}");
        for (k, (t, area)) in returns.iter().enumerate() {
            assert!(
                (area / want_weights[k] - 1.0).abs() < 1e-5,
                "{what}, return {k}: area {area}, want {}",
                want_weights[k]
            );
            // Within the bin holding the impulse (the cube's resolution).
            assert!(
                (t - delay - want_times[k]).abs() <= 0.5 * a.dt_s + 1e-13,
                "{what}, return {k}: at {t}, want {}",
                want_times[k] + delay
            );
        }
        let separation = 2.0 * 15.0 / C_M_PER_S;
        for w in returns.windows(2) {
            assert!(
                (w[1].0 - w[0].0 - separation).abs() <= a.dt_s,
                "{what}: pulses {} s apart, want 2 d(A,B) / c = {separation} s",
                w[1].0 - w[0].0
            );
        }
    }
    // The preset's derived output: depth of the first return, c t / 2 = 10.25 m.
    let Some(returns) = m.returns(&meas) else {
        panic!("the LiDAR preset has returns");
    };
    let depth = returns.first_m();
    assert!(
        (f64::from(depth[0]) - 10.25).abs() < 0.5 * C_M_PER_S * a.dt_s,
        "{}",
        depth[0]
    );
    // Multi-echo: the three returns (the third, 0.069, is above the preset's level of
    // 0.2 x the highest gate), each at half its path: 10.25, 25.25 and 40.25 m; the
    // strongest is A's (0.3 against 0.288), the last the second pass's.
    assert_eq!(returns.count, vec![3], "{returns:?}");
    for (k, want) in [10.25, 25.25, 40.25].into_iter().enumerate() {
        let got = f64::from(returns.depth_m[k]);
        assert!(
            (got - want).abs() < 0.5 * C_M_PER_S * a.dt_s,
            "return {k} at {got} m, want {want}"
        );
    }
    assert_eq!(returns.strongest_m[0], returns.depth_m[0]);
    assert_eq!(returns.last_m[0], returns.depth_m[2]);
    let e = &returns.intensity;
    assert!(e[0] > e[1] && e[1] > e[2] && e[2] > 0.0, "{e:?}");
}

#[test]
fn amcw_depth_of_one_and_two_returns() {
    let a = axis(0.0, 0.05 * NS, 1024);
    let f = 20e6;
    let mut sensor = match Sensor::builtin("amcw") {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    };
    // A delayed, widened pulse: its own phase is calibrated out.
    sensor.light = LightPulse::Gaussian {
        centre_s: 3.0 * NS,
        fwhm_s: NS,
        energy: 1.0,
    };
    let Ok(m) = SensorModel::new(sensor, a) else {
        panic!("model");
    };
    let (b1, b2) = (300, 520);
    let (t1, t2) = (a.bin_center_s(b1), a.bin_center_s(b2));
    let mut cube = impulse_cube(a.bins, b1, 1.0);
    let Ok(one) = m.measure(&cube, 1, 1) else {
        panic!("measure");
    };
    let Some(img) = m.amcw(&one) else {
        panic!("the AMCW preset has a depth");
    };
    assert!((img.ambiguity_m - C_M_PER_S / (2.0 * f)).abs() < 1e-9);
    let d1 = 0.5 * C_M_PER_S * t1;
    assert!(
        (f64::from(img.depth_m[0]) - d1).abs() < 2e-5,
        "{} vs {d1}",
        img.depth_m[0]
    );
    // Multipath: a second, later return pulls the depth towards it; the phase is that
    // of the phasor sum w1 exp(i w t1) + w2 exp(i w t2).
    cube[b2] = 0.5;
    let Ok(two) = m.measure(&cube, 1, 1) else {
        panic!("measure");
    };
    let Some(img) = m.amcw(&two) else {
        panic!("amcw");
    };
    let w = TAU * f;
    let (c, s) = (
        (w * t1).cos() + 0.5 * (w * t2).cos(),
        (w * t1).sin() + 0.5 * (w * t2).sin(),
    );
    let want = C_M_PER_S * s.atan2(c).rem_euclid(TAU) / (4.0 * PI * f);
    assert!((f64::from(img.depth_m[0]) - want).abs() < 2e-5);
    assert!(want > d1 + 0.1 && want < 0.5 * C_M_PER_S * t2);
}

#[test]
fn bad_values_are_clear_errors_not_panics() {
    let bad_files = [
        ("[exposure]\nkind = \"box\"\nwidth = nan\n", "width_s"),
        ("[exposure]\nkind = \"box\"\nwidth = -1e-9\n", "width_s"),
        (
            "[exposure]\nkind = \"box\"\nwidth = 1e-9\ncount = 1000000000\n",
            "count",
        ),
        (
            "[exposure]\nkind = \"box\"\nwidth = 1e-9\ncount = 1e9\n",
            "count",
        ),
        (
            "[exposure]\nkind = \"amcw\"\nfreq = \"20 MHz\"\nphase_steps = 0\n",
            "phase_steps",
        ),
        (
            "[exposure]\nkind = \"amcw\"\nfreq = \"20 MHz\"\nmodulation = 2\n",
            "modulation",
        ),
        ("[exposure]\nkind = \"amcw\"\nfreq = -5\n", "freq_hz"),
        ("[exposure]\nkind = \"boxcar\"\nwidth = 1e-9\n", "boxcar"),
        ("[exposure]\nkind = \"box\"\nwidht = 1e-9\n", "widht"),
        (
            "[light]\nkind = \"gaussian\"\nfwhm = \"-2 ns\"\n[exposure]\nkind = \"box\"\nwidth = 1e-9\n",
            "fwhm_s",
        ),
        (
            "[light]\nkind = \"gaussian\"\nfwhm = \"2 parsecs\"\n[exposure]\nkind = \"box\"\nwidth = 1e-9\n",
            "parsecs",
        ),
        (
            "[light]\nkind = \"rect\"\nwidth = 1e-9\nenergy = inf\n[exposure]\nkind = \"box\"\nwidth = 1e-9\n",
            "energy",
        ),
        (
            "[exposure]\nkind = \"box\"\nwidth = 1e-9\n[noise]\nsigma = -1\n",
            "sigma",
        ),
        (
            "[exposure]\nkind = \"box\"\nwidth = 1e-9\ncount = 4\n[derived]\nfirst_return = { threshold = 0 }\n",
            "threshold",
        ),
        (
            "[exposure]\nkind = \"amcw\"\nfreq = 2e7\n[derived]\nfirst_return = {}\n",
            "derived.returns",
        ),
        (
            "[exposure]\nkind = \"box\"\nwidth = 1e-9\ncount = 4\n[derived]\nreturns = { max_returns = 0 }\n",
            "max_returns",
        ),
        (
            "[exposure]\nkind = \"box\"\nwidth = 1e-9\n[derived]\namcw_depth = true\n",
            "amcw",
        ),
        (
            "[light]\nkind = \"piecewise_linear\"\npoints = [[1e-9, 1], [0, 1]]\n[exposure]\nkind = \"box\"\nwidth = 1e-9\n",
            "points",
        ),
        ("exposure = 3\n", "exposure"),
    ];
    for (text, mention) in bad_files {
        match Sensor::from_toml_str(text) {
            Ok(s) => panic!("accepted {s:?} from\n{text}"),
            Err(e) => assert!(
                e.to_string().contains(mention),
                "error for\n{text}\ndoes not mention '{mention}': {e}"
            ),
        }
    }
    // A wrong cube size is an error too.
    let m = model(
        LightPulse::default(),
        boxes(0.0, NS, 2),
        axis(0.0, 0.1 * NS, 32),
    );
    assert!(matches!(
        m.measure(&[0.0; 31], 1, 1),
        Err(SensorError::CubeSize { .. })
    ));
    assert!(m.pixel_trace(&[0.0; 3]).is_err());
    // 4096 AMCW gates over 2^20 bins would hold 2^32 kernel weights.
    let huge = SensorModel::new(
        Sensor::new(
            LightPulse::default(),
            Exposure::Amcw {
                freq_hz: 20e6,
                phase_steps: 4096,
                phase0_deg: 0.0,
                modulation: 1.0,
            },
        ),
        axis(0.0, 1e-12, 1 << 20),
    );
    assert!(matches!(huge, Err(SensorError::TooMany { .. })), "{huge:?}");
}

#[test]
fn kernels_are_recomputed_only_when_light_or_gates_change() {
    let a = axis(0.0, 0.1 * NS, 64);
    let mut sensor = Sensor::new(gaussian(NS, 0.3 * NS), boxes(0.0, NS, 4));
    let Ok(mut m) = SensorModel::new(sensor.clone(), a) else {
        panic!("model");
    };
    assert_eq!(m.update(&sensor), Ok(Update::Unchanged));
    sensor.noise.sigma = 0.1;
    assert_eq!(m.update(&sensor), Ok(Update::Settings));
    assert_eq!(m.sensor().noise.sigma, 0.1);
    let before = m.kernels().to_vec();
    sensor.light = gaussian(NS, 0.5 * NS);
    assert_eq!(m.update(&sensor), Ok(Update::Kernels));
    assert_ne!(m.kernels(), &before[..]);
    // A bad edit leaves the model as it was.
    let mut bad = sensor.clone();
    bad.noise.sigma = f64::NAN;
    assert!(m.update(&bad).is_err());
    assert_eq!(m.sensor(), &sensor);
    assert_eq!(
        m.set_axis(axis(1.0 * NS, 0.1 * NS, 64)),
        Ok(Update::Kernels)
    );
}

#[test]
fn only_bins_where_the_kernel_is_nonzero_are_read() {
    let a = axis(0.0, 0.1 * NS, 1024);
    // A 1 ns gate and a 0.2 ns FWHM pulse (sigma 0.085 ns, cut at 8 sigma).
    let m = model(gaussian(0.0, 0.085 * NS), boxes(40.0 * NS, NS, 1), a);
    let k = &m.kernels()[0];
    assert!(
        k.weights.len() <= 10 + 2 * 7 + 2,
        "{} bins",
        k.weights.len()
    );
    // Read in whole 16-lane chunks.
    assert!(m.packed().reads_per_pixel() < k.weights.len() + 16);
    // A delta light: exactly the gate's bins.
    let m = model(LightPulse::default(), boxes(40.0 * NS, NS, 1), a);
    assert_eq!(m.kernels()[0].bins(), 400..410);
    // AMCW gates are sensitive at all times: every bin.
    let m = model(
        LightPulse::default(),
        Exposure::Amcw {
            freq_hz: 20e6,
            phase_steps: 4,
            phase0_deg: 0.0,
            modulation: 1.0,
        },
        a,
    );
    assert_eq!(m.packed().reads_per_pixel(), 4 * 1024);
}

#[test]
fn envelopes_sample_for_plots() {
    let a = axis(0.0, 0.1 * NS, 64);
    let m = model(gaussian(2.0 * NS, 0.5 * NS), boxes(NS, 2.0 * NS, 3), a);
    let (lo, hi) = m.time_span_s();
    assert!(lo <= -1.99 * NS && hi >= 6.99 * NS, "{lo} {hi}");
    let n = 20_000;
    let t: Vec<f64> = (0..n)
        .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
        .collect();
    let light = m.light_curve(&t);
    let energy: f64 = light.iter().sum::<f64>() * (hi - lo) / (n - 1) as f64;
    assert!((energy - 1.0).abs() < 1e-6, "{energy}");
    let gate = m.exposure_curve(1, &[2.9 * NS, 3.1 * NS, 4.9 * NS, 5.1 * NS]);
    assert_eq!(gate, vec![0.0, 1.0, 1.0, 0.0]);
    assert!(m.exposure_curve(3, &t).is_empty());
    assert_eq!(m.light().delta_time_s(), None);
}

mod cli {
    use std::path::{Path, PathBuf};
    use std::process::{Command, Output};

    fn tprf(args: &[&str]) -> Output {
        match Command::new(env!("CARGO_BIN_EXE_tprf")).args(args).output() {
            Ok(o) => o,
            Err(e) => panic!("cannot run tprf: {e}"),
        }
    }

    fn stderr(o: &Output) -> String {
        String::from_utf8_lossy(&o.stderr).into_owned()
    }

    fn tempdir(name: &str) -> PathBuf {
        let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join(format!("sensor-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("create temp dir");
        d
    }

    /// A cube folder as `tprf render` writes it: one impulse per pixel at a bin that
    /// grows with the column.
    fn synthetic_cube(dir: &Path, w: usize, h: usize, bins: usize) {
        let mut cube = vec![0f32; w * h * bins];
        for y in 0..h {
            for x in 0..w {
                cube[(y * w + x) * bins + 40 + 10 * x] = 1.0 + y as f32;
            }
        }
        tprf_core::export::write_npy_f32(
            &dir.join("tprf.npy"),
            &[h as u64, w as u64, bins as u64],
            &cube,
        )
        .expect("write cube");
        let meta = serde_json::json!({
            "t0_s": 10e-9, "dt_s": 0.1e-9, "bins": bins, "width": w, "height": h,
        });
        tprf_core::export::write_json(&dir.join("tprf.json"), &meta).expect("write json");
    }

    fn json(path: &Path) -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(path).expect("read json")).expect("parse json")
    }

    #[test]
    fn lidar_preset_writes_measurements_depth_and_pixel_csv() {
        let dir = tempdir("lidar");
        let cube = dir.join("cube");
        std::fs::create_dir_all(&cube).expect("mkdir");
        synthetic_cube(&cube, 5, 3, 256);
        let out = dir.join("out");
        let o = tprf(&[
            "sensor",
            cube.to_str().expect("utf-8"),
            "--preset",
            "builtin:lidar",
            "--noise-sigma",
            "0",
            "--pixel",
            "2,4",
            "--pixel",
            "0,0",
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let (shape, values) =
            tprf_core::export::read_npy_f32(&out.join("sensor.npy")).expect("npy");
        assert_eq!(shape, vec![256, 3, 5]);
        assert!(values.iter().all(|v| *v >= 0.0));
        // Each pixel's impulse of weight 1 + y: the gates sum to it.
        for px in 0..15 {
            let sum: f32 = (0..256).map(|i| values[i * 15 + px]).sum();
            assert!(
                (sum - (1 + px / 5) as f32).abs() < 1e-4,
                "pixel {px}: {sum}"
            );
        }
        let (dshape, depth) = tprf_core::export::read_npy_f32(&out.join("depth.npy")).expect("npy");
        assert_eq!(dshape, vec![3, 5]);
        // The impulse of column x is at bin 40 + 10 x: 14.05 ns + x ns.
        for (px, d) in depth.iter().enumerate() {
            let t = 14.05e-9 + (px % 5) as f64 * 1e-9;
            assert!(
                (f64::from(*d) - 0.5 * 299_792_458.0 * t).abs() < 0.01,
                "pixel {px}: {d}"
            );
        }
        assert!(out.join("depth.png").exists());
        let meta = json(&out.join("sensor.json"));
        assert_eq!(meta["sensor"]["exposure"]["kind"], "box");
        assert_eq!(meta["sensor"]["exposure"]["count"], 256);
        assert_eq!(meta["gates"].as_array().map(Vec::len), Some(256));
        assert_eq!(meta["cube"]["bins"], 256);
        let csv = std::fs::read_to_string(out.join("pixel_2_4.csv")).expect("csv");
        let mut lines = csv.lines();
        let header = lines.next().expect("header");
        assert!(header.starts_with("bin,t_start_s,t_centre_s,tprf,tprf_light,gate_0,"));
        assert_eq!(header.split(',').count(), 5 + 256);
        assert_eq!(lines.count(), 256);
        let gates = std::fs::read_to_string(out.join("pixel_2_4_gates.csv")).expect("csv");
        assert_eq!(gates.lines().next(), Some("gate,centre_s,m_clean,m"));
        assert!(out.join("pixel_0_0.csv").exists());
    }

    #[test]
    fn options_without_a_preset_and_clear_errors() {
        let dir = tempdir("errors");
        let cube = dir.join("cube");
        std::fs::create_dir_all(&cube).expect("mkdir");
        synthetic_cube(&cube, 4, 2, 128);
        let c = cube.to_str().expect("utf-8");
        let out = dir.join("out");
        let o_str = out.to_str().expect("utf-8");
        let o = tprf(&[
            "sensor",
            c,
            "--light",
            "gaussian:centre=1ns,fwhm=0.5ns",
            "--exposure",
            "box:start=12ns,width=0.5ns,count=8",
            "--noise-sigma",
            "0.01",
            "--seed",
            "3",
            "--out",
            o_str,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let (shape, _) = tprf_core::export::read_npy_f32(&out.join("sensor.npy")).expect("npy");
        assert_eq!(shape, vec![8, 2, 4]);
        assert_eq!(json(&out.join("sensor.json"))["sensor"]["noise"]["seed"], 3);
        for (args, mention) in [
            (vec!["sensor", c, "--out", o_str], "--preset"),
            (
                vec![
                    "sensor",
                    c,
                    "--exposure",
                    "box:width=1ns,count=1000000000",
                    "--out",
                    o_str,
                ],
                "count",
            ),
            (
                vec!["sensor", c, "--exposure", "box:width=-1ns", "--out", o_str],
                "width_s",
            ),
            (
                vec![
                    "sensor",
                    c,
                    "--exposure",
                    "box:width=1ns",
                    "--light",
                    "gaussian:fwhm=nan",
                    "--out",
                    o_str,
                ],
                "fwhm_s",
            ),
            (
                vec!["sensor", c, "--preset", "builtin:nope", "--out", o_str],
                "nope",
            ),
            (
                vec![
                    "sensor",
                    c,
                    "--preset",
                    "builtin:lidar",
                    "--pixel",
                    "2,0",
                    "--out",
                    o_str,
                ],
                "outside",
            ),
            (
                vec![
                    "sensor",
                    "/nonexistent/cube",
                    "--preset",
                    "builtin:lidar",
                    "--out",
                    o_str,
                ],
                "tprf.json",
            ),
        ] {
            let o = tprf(&args);
            assert!(!o.status.success(), "{args:?} succeeded");
            let err = stderr(&o);
            assert!(err.contains(mention), "{args:?}: '{err}' lacks '{mention}'");
            assert!(!err.contains("panicked"), "{args:?}: {err}");
        }
    }

    #[test]
    fn amcw_preset_on_a_render_shows_multipath() {
        let dir = tempdir("amcw");
        let cube = dir.join("cornell");
        let o = tprf(&[
            "render",
            "builtin:cornell",
            "--out",
            cube.to_str().expect("utf-8"),
            "--width",
            "16",
            "--height",
            "12",
            "--spp",
            "16",
            "--bins",
            "128",
            "--bounces-separate",
            "1",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = dir.join("out");
        let o = tprf(&[
            "sensor",
            cube.to_str().expect("utf-8"),
            "--preset",
            "builtin:amcw",
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        for f in [
            "amcw_phase.npy",
            "amcw_amplitude.npy",
            "amcw_depth.npy",
            "true_depth.npy",
            "multipath_error.npy",
            "amcw_depth.png",
            "multipath_error.png",
        ] {
            assert!(out.join(f).exists(), "{f} missing");
        }
        let meta = json(&out.join("sensor.json"));
        let how = meta["derived"]["amcw"]["true_depth"].as_str().unwrap_or("");
        assert!(how.contains("single-scattering"), "{how}");
        // Interreflections arrive later than the direct return: the AMCW depth is
        // mostly too far.
        let (_, err) =
            tprf_core::export::read_npy_f32(&out.join("multipath_error.npy")).expect("npy");
        let finite: Vec<f32> = err.into_iter().filter(|e| e.is_finite()).collect();
        assert!(!finite.is_empty());
        let positive = finite.iter().filter(|e| **e > 0.0).count();
        assert!(
            positive * 2 > finite.len(),
            "{positive} of {}",
            finite.len()
        );
    }
}

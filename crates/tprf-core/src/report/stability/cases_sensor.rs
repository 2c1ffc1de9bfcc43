//! The sensor's rows of the stability suite: pulses and gates at extreme widths, and
//! noise and values at extreme sizes. The TPRF cubes here are made by hand (impulses
//! of known weight in known bins), so every expected value is exact or a closed form.

use super::common::Size;
use super::verdict::{Check, Kind, Row};
use crate::film::TimeAxis;
use crate::sensor::{
    Acquisition, Exposure, LightPulse, Noise, Sensor, SensorError, SensorModel, Spad, SpadImage,
    TimeOrigin, spad_image,
};

/// A cube `[h, w, T]` where pixel `p` holds weight `(p + 1)` split over three bins
/// (0.5, 0.3, 0.2 of it) near the middle of the window; returns it with its per-pixel
/// energies.
fn impulse_cube(w: usize, h: usize, bins: usize) -> (Vec<f32>, Vec<f64>) {
    let mut cube = vec![0.0f32; w * h * bins];
    let mut energy = Vec::with_capacity(w * h);
    for p in 0..w * h {
        let e = (p + 1) as f64;
        let b0 = bins / 3 + p % (bins / 3);
        for (k, f) in [0.5, 0.3, 0.2].into_iter().enumerate() {
            cube[p * bins + b0 + 7 * k] = (e * f) as f32;
        }
        energy.push(
            cube[p * bins..(p + 1) * bins]
                .iter()
                .map(|&v| v as f64)
                .sum(),
        );
    }
    (cube, energy)
}

fn box_gate(origin: TimeOrigin, start_s: f64, width_s: f64) -> Exposure {
    Exposure::Box {
        origin,
        start_s,
        width_s,
        step_s: None,
        count: 1,
        gain: 1.0,
    }
}

/// Measure `cube` with `sensor`: (measurements, count of NaN/Inf), or why not.
fn measure(
    sensor: Sensor,
    axis: TimeAxis,
    cube: &[f32],
    w: usize,
    h: usize,
) -> Result<(Vec<f32>, u64), SensorError> {
    let model = SensorModel::new(sensor, axis)?;
    let m = model.measure(cube, w, h)?;
    let bad = m.values.iter().filter(|v| !v.is_finite()).count() as u64;
    Ok((m.values, bad))
}

/// A row from a measurement that may have failed (a failure is a FAIL row saying why).
fn row(
    case: &str,
    setting: String,
    check: Check,
    got: Result<(f64, u64), SensorError>,
    note: &str,
) -> Row {
    match got {
        Ok((got, non_finite)) => Row {
            case: case.into(),
            setting,
            kind: Kind::Reference,
            check,
            got,
            non_finite,
            note: note.into(),
        },
        Err(e) => Row {
            case: case.into(),
            setting,
            kind: Kind::Reference,
            check,
            got: f64::NAN,
            non_finite: 0,
            note: format!("error: {e}"),
        },
    }
}

/// Largest relative deviation of `m` from `expected` (per pixel).
fn max_rel(m: &[f32], expected: &[f64]) -> f64 {
    m.iter()
        .zip(expected)
        .map(|(&g, &e)| (g as f64 - e).abs() / e.abs().max(1e-300))
        .fold(0.0, f64::max)
}

/// Pulses and gates: energy conserved through a gate that holds all the light, for a
/// delta and for Gaussians from 1e-3 to 1e3 bins wide; exactly zero through a gate of
/// zero width and through gates before or after all the light.
pub fn pulses_and_gates(size: Size) -> Vec<Row> {
    let (w, h, bins) = match size {
        Size::Test => (4, 4, 64),
        Size::Full => (64, 64, 1024),
    };
    let dt = 1e-9;
    let axis = TimeAxis::new(0.0, dt, bins).expect("a valid axis");
    let (cube, energy) = impulse_cube(w, h, bins);
    let window = bins as f64 * dt;
    let case = "pulses and gates";
    let mut rows = Vec::new();

    // Delta light, one gate over the window: M = the pixel's energy.
    let s = Sensor::new(
        LightPulse::default(),
        box_gate(TimeOrigin::Window, 0.0, window),
    );
    rows.push(row(
        case,
        "delta light, whole-window gate: max relative error of M over pixels".into(),
        Check::AtMost { bound: 1e-6 },
        measure(s, axis, &cube, w, h).map(|(m, bad)| (max_rel(&m, &energy), bad)),
        "M = sum of the TPRF (f32 sums)",
    ));

    // Gaussian pulses centred at the trigger, a gate holding +-12 FWHM around the window.
    for bins_wide in [1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0, 1e3] {
        let fwhm = bins_wide * dt;
        let margin = 12.0 * fwhm;
        let s = Sensor::new(
            LightPulse::Gaussian {
                centre_s: 0.0,
                fwhm_s: fwhm,
                energy: 1.0,
            },
            box_gate(TimeOrigin::Pulse, -margin, window + 2.0 * margin),
        );
        rows.push(row(
            case,
            format!(
                "Gaussian FWHM {bins_wide:e} bins, gate over all light: max relative error of M"
            ),
            Check::AtMost { bound: 1e-6 },
            measure(s, axis, &cube, w, h).map(|(m, bad)| (max_rel(&m, &energy), bad)),
            "energy conserved; Gaussian tails beyond 12 FWHM are < 1e-100",
        ));
    }

    // Zero-width gate: open for no time.
    let s = Sensor::new(
        LightPulse::default(),
        box_gate(TimeOrigin::Window, window / 2.0, 0.0),
    );
    rows.push(row(
        case,
        "zero-width gate in the middle of the returns: max |M|".into(),
        Check::Within {
            expected: 0.0,
            tolerance: 0.0,
        },
        measure(s, axis, &cube, w, h)
            .map(|(m, bad)| (m.iter().fold(0.0f64, |a, &v| a.max(v.abs() as f64)), bad)),
        "exactly zero",
    ));

    // Gates entirely before and after the light's arrival (a 2-bin rectangular pulse).
    let first = bins / 3;
    let last = first + bins / 3 + 14;
    let pulse = LightPulse::Rect {
        start_s: 0.0,
        width_s: 2.0 * dt,
        energy: 1.0,
    };
    for (what, start, width) in [
        (
            "gate closing before the first arrival",
            0.0,
            first as f64 * dt,
        ),
        (
            "gate opening after the last light",
            (last + 3) as f64 * dt,
            5.0 * dt,
        ),
    ] {
        let s = Sensor::new(pulse.clone(), box_gate(TimeOrigin::Pulse, start, width));
        rows.push(row(
            case,
            format!("{what}: max |M|"),
            Check::Within {
                expected: 0.0,
                tolerance: 0.0,
            },
            measure(s, axis, &cube, w, h)
                .map(|(m, bad)| (m.iter().fold(0.0f64, |a, &v| a.max(v.abs() as f64)), bad)),
            "exactly zero: only bins where K_i is non-zero are read",
        ));
    }
    rows
}

/// Noise and values at extreme sizes: sigma 0 and 1e6, an all-zero TPRF, huge values.
pub fn sensor_extremes(size: Size) -> Vec<Row> {
    let (w, h, bins) = match size {
        Size::Test => (32, 32, 64),
        Size::Full => (256, 256, 256),
    };
    let dt = 1e-9;
    let axis = TimeAxis::new(0.0, dt, bins).expect("a valid axis");
    let window = bins as f64 * dt;
    let n = (w * h) as f64;
    let case = "sensor extremes";
    let whole = |noise: Noise| {
        let mut s = Sensor::new(
            LightPulse::default(),
            box_gate(TimeOrigin::Window, 0.0, window),
        );
        s.noise = noise;
        s
    };
    let mut rows = Vec::new();

    // sigma = 0: M is the clean measurement, bit for bit.
    let (cube, energy) = impulse_cube(w, h, bins);
    rows.push(row(
        case,
        "sigma 0: max relative error of M".into(),
        Check::AtMost { bound: 1e-6 },
        measure(
            whole(Noise {
                sigma: 0.0,
                seed: 1,
                photons_per_energy: 0.0,
            }),
            axis,
            &cube,
            w,
            h,
        )
        .map(|(m, bad)| (max_rel(&m, &energy), bad)),
        "no noise added",
    ));

    // sigma = 1e6 over small signals: M = max(0, N(mu, sigma)) with mu << sigma, whose
    // mean is sigma / sqrt(2 pi); M >= 0 everywhere.
    let sigma = 1e6;
    let expected = sigma / (2.0 * std::f64::consts::PI).sqrt();
    let sd = sigma * (0.5 - 1.0 / (2.0 * std::f64::consts::PI)).sqrt();
    let got = measure(
        whole(Noise {
            sigma,
            seed: 7,
            photons_per_energy: 0.0,
        }),
        axis,
        &cube,
        w,
        h,
    )
    .map(|(m, bad)| {
        let negative = m.iter().filter(|&&v| v < 0.0).count() as u64;
        (m.iter().map(|&v| v as f64).sum::<f64>() / n, bad + negative)
    });
    rows.push(row(
        case,
        "sigma 1e6: mean of M (negative values counted as bad)".into(),
        Check::Within {
            expected,
            tolerance: 5.0 * sd / n.sqrt() + energy.iter().sum::<f64>() / n,
        },
        got,
        "E[max(0, N(0, s))] = s / sqrt(2 pi); 5 standard errors, plus the signal",
    ));

    // All-zero TPRF: exactly 0 without noise; with sigma 1, half the pixels clip to 0.
    let zeros = vec![0.0f32; w * h * bins];
    rows.push(row(
        case,
        "all-zero TPRF, sigma 0: max |M|".into(),
        Check::Within {
            expected: 0.0,
            tolerance: 0.0,
        },
        measure(whole(Noise::default()), axis, &zeros, w, h)
            .map(|(m, bad)| (m.iter().fold(0.0f64, |a, &v| a.max(v.abs() as f64)), bad)),
        "exactly zero",
    ));
    let got = measure(
        whole(Noise {
            sigma: 1.0,
            seed: 3,
            photons_per_energy: 0.0,
        }),
        axis,
        &zeros,
        w,
        h,
    )
    .map(|(m, bad)| {
        (
            m.iter().filter(|&&v| v == 0.0).count() as f64 / n,
            bad + m.iter().filter(|&&v| v < 0.0).count() as u64,
        )
    });
    rows.push(row(
        case,
        "all-zero TPRF, sigma 1: fraction of M clipped to 0".into(),
        Check::Within {
            expected: 0.5,
            tolerance: 5.0 * 0.5 / n.sqrt(),
        },
        got,
        "max(0, N(0, 1)) is 0 with probability 1/2; 5 binomial standard errors",
    ));

    // Huge values: 1e30 in every bin (f32 holds up to 3.4e38).
    let huge = vec![1e30f32; w * h * bins];
    let expected = 1e30 * bins as f64;
    let got = measure(whole(Noise::default()), axis, &huge, w, h).map(|(m, bad)| {
        (
            m.iter()
                .map(|&v| (v as f64 - expected).abs() / expected)
                .fold(0.0, f64::max),
            bad,
        )
    });
    rows.push(row(
        case,
        format!("1e30 in every bin ({bins} bins): max relative error of M"),
        Check::AtMost { bound: 1e-5 },
        got,
        "finite, no overflow",
    ));
    // Photon noise on huge values: finite and non-negative.
    let got = measure(
        whole(Noise {
            sigma: 0.0,
            seed: 5,
            photons_per_energy: 1.0,
        }),
        axis,
        &huge,
        w,
        h,
    )
    .map(|(m, bad)| {
        (
            m.iter()
                .map(|&v| (v as f64 - expected).abs() / expected)
                .fold(0.0, f64::max),
            bad + m.iter().filter(|&&v| v < 0.0).count() as u64,
        )
    });
    rows.push(row(
        case,
        "1e30 in every bin, Poisson photon noise: max relative deviation of M".into(),
        Check::AtMost { bound: 1e-5 },
        got,
        "relative photon noise 1/sqrt(N) is ~1e-16 here",
    ));
    rows
}

/// The SPAD at extreme settings: 10^9 cycles, a saturating return, no ambient, a
/// saturating ambient, free-running with a dead time that divides the cycle. Every
/// expected count is a closed form of the detector model.
pub fn spad_extremes(size: Size) -> Vec<Row> {
    let (w, h) = match size {
        Size::Test => (4, 4),
        Size::Full => (64, 64),
    };
    let bins = 64usize;
    let dt = 1e-10;
    let axis = TimeAxis::new(0.0, dt, bins).expect("a valid axis");
    let case = "SPAD extremes";
    let n = 1e9;
    // Pixel p: a return of (p + 1) 1e3 photons per cycle in bin 20: saturating.
    let mut cube = vec![0.0f32; w * h * bins];
    for p in 0..w * h {
        cube[p * bins + 20] = 1e3 * (p + 1) as f32;
    }
    let steady: Vec<f32> = (0..w * h).map(|p| 1e3 * (p + 1) as f32).collect();
    let run = |spad: Spad| -> Result<SpadImage, SensorError> {
        let mut sensor = Sensor::new(
            LightPulse::default(),
            Exposure::Tdc {
                origin: TimeOrigin::Pulse,
                start_s: 0.0,
                bin_width_s: dt,
                bins: bins as u64,
                jitter_fwhm_s: 0.0,
            },
        );
        sensor.spad = Some(spad);
        let model = SensorModel::new(sensor, axis)?;
        let m = model.measure_clean(&cube, w, h)?;
        spad_image(&model, &m, &steady)
    };
    let non_finite = |img: &SpadImage| {
        (img.histogram.iter().chain(&img.counts))
            .filter(|v| !v.is_finite() || **v < 0.0)
            .count() as u64
            + img.coates.iter().filter(|v| v.is_infinite()).count() as u64
    };
    let base = Spad {
        cycles: n as u64,
        pde: 1.0,
        photons_per_unit: 1.0,
        dead_time_s: bins as f64 * dt,
        ..Spad::default()
    };
    let mut rows = Vec::new();

    // First photon, 1e9 cycles, saturating return, no ambient: every cycle fires in
    // bin 20 (e^-1000 = 0): the histogram holds N there and 0 elsewhere.
    rows.push(row(
        case,
        "1e9 cycles, saturating return, zero ambient: max |histogram - N [bin 20]| / N".into(),
        Check::AtMost { bound: 1e-6 },
        run(base.clone()).map(|img| {
            let err = img
                .histogram
                .chunks(w * h)
                .enumerate()
                .flat_map(|(k, plane)| {
                    let want = if k == 20 { n } else { 0.0 };
                    plane.iter().map(move |&v| (f64::from(v) - want).abs() / n)
                })
                .fold(0.0, f64::max);
            (err, non_finite(&img))
        }),
        "P(first detection in bin k) = (1 - e^-r_k) e^-sum_{j<k} r_j; f32 output",
    ));
    // The realisation of the same: exactly N in bin 20.
    rows.push(row(
        case,
        "1e9 cycles, saturating return: realisation's count in bin 20 / N".into(),
        Check::Within {
            expected: 1.0,
            tolerance: 1e-6,
        },
        run(base.clone()).map(|img| {
            let got = img
                .plane(&img.counts, 20)
                .iter()
                .map(|&v| f64::from(v))
                .sum::<f64>()
                / (n * (w * h) as f64);
            (got, non_finite(&img))
        }),
        "multinomial with p = 1: every cycle",
    ));
    // A saturating ambient (1e15 photons/s: 1e5 per bin), free-running, dead time 7
    // bins: the detector fires every 8 bins, 64 / 8 = 8 detections per cycle.
    rows.push(row(
        case,
        "free-running, saturating ambient, dead time 7 bins: detections per cycle per pixel".into(),
        Check::Within {
            expected: 8.0,
            tolerance: 1e-6,
        },
        run(Spad {
            ambient_rate_hz: 1e15,
            dead_time_s: 7.0 * dt,
            mode: Acquisition::FreeRunning,
            ..base.clone()
        })
        .map(|img| {
            let total: f64 = img.histogram.iter().map(|&v| f64::from(v)).sum();
            (total / (n * (w * h) as f64), non_finite(&img))
        }),
        "every bin fires when armed: one detection per d + 1 bins",
    ));
    // No light at all: exactly zero everywhere.
    let dark = vec![0.0f32; w * h * bins];
    let zero_steady = vec![0.0f32; w * h];
    let got = (|| -> Result<(f64, u64), SensorError> {
        let mut sensor = Sensor::new(
            LightPulse::default(),
            Exposure::Tdc {
                origin: TimeOrigin::Pulse,
                start_s: 0.0,
                bin_width_s: dt,
                bins: bins as u64,
                jitter_fwhm_s: 2.0 * dt,
            },
        );
        sensor.spad = Some(Spad {
            mode: Acquisition::FreeRunning,
            dead_time_s: 3.0 * dt,
            ..base.clone()
        });
        let model = SensorModel::new(sensor, axis)?;
        let m = model.measure_clean(&dark, w, h)?;
        let img = spad_image(&model, &m, &zero_steady)?;
        let max = img
            .histogram
            .iter()
            .chain(&img.counts)
            .chain(&img.coates)
            .fold(0.0f64, |a, &v| a.max(f64::from(v).abs()));
        Ok((max, non_finite(&img)))
    })();
    rows.push(row(
        case,
        "no signal, no ambient, no dark counts, 1e9 cycles: max |histogram, counts, Coates|".into(),
        Check::Within {
            expected: 0.0,
            tolerance: 0.0,
        },
        got,
        "exactly zero",
    ));
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn impulse_cube_energies() {
        let (cube, e) = impulse_cube(2, 1, 30);
        assert_eq!(cube.len(), 60);
        assert!((e[0] - 1.0).abs() < 1e-6 && (e[1] - 2.0).abs() < 1e-6);
    }
}

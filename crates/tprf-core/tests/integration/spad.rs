//! The SPAD model against an independent photon-level Monte Carlo written here: cycle
//! by cycle, bin by bin, Poisson photon counts, a dead-time clock, a carrier trap that
//! releases bin by bin, and the detections counted. Tolerances come from the Monte
//! Carlo's own spread: `R` independent runs give a mean and a standard error per bin,
//! and the closed form must lie within 5 standard errors (plus rounding).
//!
//! Then: the Coates estimate recovers `N r_k`; the timing jitter conserves energy and
//! has the shape of `Phi` differences; dark counts are flat; pile-up pulls strong
//! returns early by what the first-photon density says and leaves weak ones; bad input
//! is refused with the field's name; extreme values stay finite.

use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Poisson};
use rand_pcg::Pcg64Mcg;
use std::f64::consts::{PI, SQRT_2};

use tprf_core::film::TimeAxis;
use tprf_core::sensor::Returns;
use tprf_core::sensor::light::FWHM_PER_SIGMA;
use tprf_core::sensor::spad::sample::{pixel_stream, sample_pixel};
use tprf_core::sensor::spad::{
    Detector, Sampler, coates, return_depth_m, spad_expected, spad_expected_until, spad_pixel,
    spad_pixel_ambient,
};
use tprf_core::sensor::{
    Acquisition, Exposure, LightPulse, Sensor, SensorError, SensorModel, Spad, TimeOrigin,
    spad_image, spad_image_ambient,
};
use tprf_core::units::C_M_PER_S;

const NS: f64 = 1e-9;

fn spad(cycles: u64) -> Spad {
    Spad {
        cycles,
        pde: 1.0,
        photons_per_unit: 1.0,
        ..Spad::default()
    }
}

fn detector(s: &Spad, bins: usize, width_s: f64) -> Detector {
    match Detector::new(s, bins, width_s) {
        Ok(d) => d,
        Err(e) => panic!("{e}"),
    }
}

/// Rates with a background and a return of `peak` events per cycle in a few bins.
fn rates(bins: usize, background: f64, peak: f64, at: usize) -> Vec<f64> {
    (0..bins)
        .map(|k| {
            let x = k as f64 - at as f64;
            background + peak * (-0.5 * x * x / 2.0).exp()
        })
        .collect()
}

/// The independent simulation: one run of `cycles` cycles of the SPAD, photon by
/// photon. `dead_bins` after the bin of a detection; trap filled with `p_trap` at each
/// detection, released in a bin with probability `1 - exp(-mu)` (lost while dead).
#[allow(
    clippy::too_many_arguments,
    reason = "the SPAD model's parameters, one argument each, as the test states them"
)]
fn monte_carlo(
    rates: &[f64],
    cycles: u64,
    dead_bins: usize,
    free_running: bool,
    p_trap: f64,
    mu: f64,
    rng: &mut Pcg64Mcg,
) -> Vec<f64> {
    let b = rates.len();
    let poisson: Vec<Option<Poisson<f64>>> = rates.iter().map(|&r| Poisson::new(r).ok()).collect();
    let release = 1.0 - (-mu).exp();
    let mut counts = vec![0.0; b];
    let mut armed_at: u64 = 0;
    let mut trap = false;
    for c in 0..cycles {
        if !free_running {
            armed_at = c * b as u64;
            trap = false;
        }
        for k in 0..b {
            let g = c * b as u64 + k as u64;
            let photons = poisson[k].as_ref().map_or(0.0, |p| p.sample(rng));
            let released = trap && rng.random::<f64>() < release;
            if g < armed_at {
                if released {
                    trap = false;
                }
                continue;
            }
            if photons > 0.0 || released {
                counts[k] += 1.0;
                trap = rng.random::<f64>() < p_trap;
                armed_at = g + dead_bins as u64 + 1;
            }
        }
    }
    counts
}

/// Mean and standard error per bin over `runs` independent runs of `f`.
fn mean_and_error(runs: usize, mut f: impl FnMut(u64) -> Vec<f64>) -> (Vec<f64>, Vec<f64>) {
    let all: Vec<Vec<f64>> = (0..runs as u64).map(&mut f).collect();
    let b = all[0].len();
    let n = runs as f64;
    let mean: Vec<f64> = (0..b)
        .map(|k| all.iter().map(|r| r[k]).sum::<f64>() / n)
        .collect();
    let error = (0..b)
        .map(|k| {
            let var = all.iter().map(|r| (r[k] - mean[k]).powi(2)).sum::<f64>() / (n - 1.0);
            (var / n).sqrt()
        })
        .collect();
    (mean, error)
}

fn assert_within_noise(what: &str, got: &[f64], mean: &[f64], error: &[f64]) {
    for k in 0..got.len() {
        let tol = 5.0 * error[k] + 1e-9 * mean[k].abs() + 1e-12;
        assert!(
            (got[k] - mean[k]).abs() <= tol,
            "{what}, bin {k}: closed form {} vs Monte Carlo {} +- {}",
            got[k],
            mean[k],
            error[k]
        );
    }
}

/// Where the simulated SPAD's dead time starts.
#[derive(Clone, Copy)]
enum DeadFrom {
    /// The end of the detection's TDC bin (the model's meaning).
    BinEnd,
    /// The detected photon's own arrival (a real SPAD: dead `1 - u` bins shorter than
    /// the model after a photon at the fraction `u` of its bin).
    Photon,
}

/// The independent simulation in continuous time, for a dead time of any length: one
/// run of `cycles` cycles, time in units of a bin. Bin `k` of each cycle receives a
/// Poisson(`r_k`) number of photons at uniform times within it (the rate is constant
/// in a bin); the SPAD, armed, detects the first photon at or after the time it
/// re-armed; the detection is stamped with its bin, and the SPAD is dead for exactly
/// `dead_bins` (a real number) from `from`. No afterpulsing.
fn monte_carlo_continuous(
    rates: &[f64],
    cycles: u64,
    dead_bins: f64,
    from: DeadFrom,
    free_running: bool,
    rng: &mut Pcg64Mcg,
) -> Vec<f64> {
    let b = rates.len();
    let poisson: Vec<Option<Poisson<f64>>> = rates.iter().map(|&r| Poisson::new(r).ok()).collect();
    let mut counts = vec![0.0; b];
    let mut armed_at = 0.0f64;
    let mut times = Vec::new();
    for c in 0..cycles {
        let cycle_start = (c * b as u64) as f64;
        if !free_running {
            armed_at = cycle_start;
        }
        for k in 0..b {
            let start = cycle_start + k as f64;
            let photons = poisson[k].as_ref().map_or(0.0, |p| p.sample(rng)) as usize;
            times.clear();
            times.extend((0..photons).map(|_| start + rng.random::<f64>()));
            times.sort_by(f64::total_cmp);
            if let Some(&t) = times.iter().find(|&&t| t >= armed_at) {
                counts[k] += 1.0;
                armed_at = dead_bins
                    + match from {
                        DeadFrom::BinEnd => start + 1.0,
                        DeadFrom::Photon => t,
                    };
            }
        }
    }
    counts
}

/// Closed form against the Monte Carlo for one detector setting.
fn check_against_mc(what: &str, s: &Spad, bins: usize, rates: &[f64]) {
    let width_s = 1e-10;
    let det = detector(s, bins, width_s);
    let mu = if s.afterpulse_probability > 0.0 {
        width_s / s.afterpulse_delay_s
    } else {
        0.0
    };
    check_against(what, &det, rates, |run| {
        let mut rng = Pcg64Mcg::seed_from_u64(0xC0FFEE + run);
        monte_carlo(
            rates,
            s.cycles,
            det.dead_bins,
            s.mode == Acquisition::FreeRunning,
            s.afterpulse_probability,
            mu,
            &mut rng,
        )
    });
}

/// Closed form against the continuous-time Monte Carlo (no afterpulsing); returns the
/// closed form.
fn check_against_continuous_mc(what: &str, s: &Spad, bins: usize, rates: &[f64]) -> Vec<f64> {
    let width_s = 1e-10;
    let det = detector(s, bins, width_s);
    let tau_bins = s.dead_time_s / width_s;
    check_against(what, &det, rates, |run| {
        let mut rng = Pcg64Mcg::seed_from_u64(0xBEEF + run);
        monte_carlo_continuous(
            rates,
            s.cycles,
            tau_bins,
            DeadFrom::BinEnd,
            s.mode == Acquisition::FreeRunning,
            &mut rng,
        )
    })
}

/// The closed form of `det` and its sampler against a Monte Carlo `mc` (one run per
/// seed); returns the closed form.
fn check_against(
    what: &str,
    det: &Detector,
    rates: &[f64],
    mc: impl FnMut(u64) -> Vec<f64>,
) -> Vec<f64> {
    let bins = det.bins;
    let mut expected = vec![0.0; bins];
    det.expected(rates, &mut expected);
    let (mean, error) = mean_and_error(48, mc);
    assert_within_noise(what, &expected, &mean, &error);
    // The sampler draws the same distribution.
    let sampler = if det.first_photon_only() {
        Sampler::Multinomial
    } else {
        Sampler::Events
    };
    let (smean, serror) = mean_and_error(48, |run| {
        let mut out = vec![0.0; bins];
        sample_pixel(
            det,
            sampler,
            rates,
            &expected,
            &mut pixel_stream(run, 3),
            &mut out,
        );
        out
    });
    let joint: Vec<f64> = serror
        .iter()
        .zip(&error)
        .map(|(a, b)| a.hypot(*b))
        .collect();
    assert_within_noise(&format!("{what} (sampler)"), &smean, &mean, &joint);
    // And its spread is the Monte Carlo's (variance ratio within a loose band).
    let (vs, vm): (f64, f64) = (
        serror.iter().map(|e| e * e).sum(),
        error.iter().map(|e| e * e).sum(),
    );
    assert!(
        vs > 0.6 * vm && vs < 1.6 * vm,
        "{what}: sampler variance {vs} vs Monte Carlo {vm}"
    );
    expected
}

/// A dead time of a fraction of a bin more than a whole number: the closed form and
/// the sampler against the continuous-time simulation, synchronous and free-running,
/// at 2.5 and 0.3 bins; and the fraction matters (the histogram lies between those of
/// the whole numbers around it, apart from both by more than the noise).
#[test]
fn fractional_dead_time_matches_continuous_monte_carlo() {
    let bins = 24;
    for mode in [Acquisition::Synchronous, Acquisition::FreeRunning] {
        for tau in [2.5, 0.3] {
            let s = Spad {
                dead_time_s: tau * 1e-10,
                mode,
                ..spad(1500)
            };
            let r = rates(bins, 0.15, 2.5, 9);
            let got =
                check_against_continuous_mc(&format!("{mode:?}, tau = {tau} bins"), &s, bins, &r);
            // Detections over the cycle: fewer than with the whole bin below, more than
            // with the one above (a longer dead time loses more).
            let total = |dead: f64| {
                let s = Spad {
                    dead_time_s: dead * 1e-10,
                    ..s.clone()
                };
                let mut e = vec![0.0; bins];
                detector(&s, bins, 1e-10).expected(&r, &mut e);
                e.iter().sum::<f64>()
            };
            let (lo, mid, hi) = (
                total(tau.ceil()),
                got.iter().sum::<f64>(),
                total(tau.floor()),
            );
            assert!(
                lo + 50.0 < mid && mid + 50.0 < hi,
                "{mode:?}, tau = {tau}: {lo} < {mid} < {hi}"
            );
            // The continuous simulation at the whole numbers gives the whole-bin model
            // (the bin-by-bin simulation's).
            let s_whole = Spad {
                dead_time_s: tau.floor() * 1e-10,
                ..s.clone()
            };
            check_against_continuous_mc(
                &format!("{mode:?}, tau = {}", tau.floor()),
                &s_whole,
                bins,
                &r,
            );
        }
    }
}

/// A ratio a hair from a whole number is that number (the whole-bin recursion, bit for
/// bit), and the fraction is kept otherwise.
#[test]
fn dead_time_resolution() {
    for (dead_s, d, f) in [
        (7e-10, 7, 0.0),
        (3e-10, 3, 0.0),
        (2.5e-10, 2, 0.5),
        (0.3e-10, 0, 0.3),
        (32e-10, 32, 0.0),
    ] {
        let det = detector(
            &Spad {
                dead_time_s: dead_s,
                ..spad(10)
            },
            32,
            1e-10,
        );
        assert_eq!(det.dead_bins, d, "{dead_s}");
        assert!(
            (det.dead_fraction - f).abs() < 1e-9,
            "{dead_s}: {}",
            det.dead_fraction
        );
    }
}

/// Coates of the expected histogram after a fractional dead time gives `N r_k` back
/// (synchronous: exact; the estimate's model is the closed form's).
#[test]
fn coates_undoes_a_fractional_dead_time() {
    let bins = 40;
    let r = rates(bins, 0.03, 2.0, 15);
    let n = 5000.0;
    for dead in [0.3, 2.5, 7.75] {
        let s = Spad {
            dead_time_s: dead * 1e-10,
            ..spad(n as u64)
        };
        let det = detector(&s, bins, 1e-10);
        let mut e = vec![0.0; bins];
        det.expected(&r, &mut e);
        let mut est = vec![0.0; bins];
        coates(&det, &e, &mut est);
        for k in 0..bins {
            let want = n * r[k];
            assert!(
                (est[k] - want).abs() <= 1e-8 * want,
                "dead {dead}: bin {k}: {} vs {want}",
                est[k]
            );
        }
    }
}

#[test]
fn synchronous_first_photon_matches_monte_carlo() {
    // Dead for the whole cycle: the classic first-photon histogram, a strong return
    // over a background.
    let bins = 32;
    let s = Spad {
        dead_time_s: bins as f64 * 1e-10,
        ..spad(2000)
    };
    check_against_mc("first photon", &s, bins, &rates(bins, 0.01, 1.5, 12));
    // And the formula itself, by hand.
    let r = rates(bins, 0.02, 0.8, 20);
    let det = detector(&s, bins, 1e-10);
    let mut e = vec![0.0; bins];
    det.expected(&r, &mut e);
    let mut before = 0.0f64;
    for k in 0..bins {
        let want = 2000.0 * (1.0 - (-r[k]).exp()) * (-before).exp();
        assert!((e[k] - want).abs() < 1e-9 * want.max(1.0), "bin {k}");
        before += r[k];
    }
}

#[test]
fn synchronous_with_short_dead_time_matches_monte_carlo() {
    let bins = 32;
    let s = Spad {
        dead_time_s: 3e-10,
        ..spad(1500)
    };
    check_against_mc("synchronous, d = 3", &s, bins, &rates(bins, 0.05, 2.0, 10));
}

#[test]
fn free_running_matches_monte_carlo() {
    let bins = 24;
    let s = Spad {
        dead_time_s: 7e-10,
        mode: Acquisition::FreeRunning,
        ..spad(1500)
    };
    check_against_mc("free-running, d = 7", &s, bins, &rates(bins, 0.08, 3.0, 5));
    // A dead time of the whole cycle.
    let s = Spad {
        dead_time_s: bins as f64 * 1e-10,
        ..s
    };
    check_against_mc("free-running, d = B", &s, bins, &rates(bins, 0.03, 1.0, 18));
}

#[test]
fn afterpulsing_matches_monte_carlo() {
    let bins = 32;
    for mode in [Acquisition::Synchronous, Acquisition::FreeRunning] {
        let s = Spad {
            dead_time_s: 2e-10,
            mode,
            afterpulse_probability: 0.4,
            afterpulse_delay_s: 5e-10,
            ..spad(1500)
        };
        check_against_mc(
            &format!("afterpulsing, {mode:?}"),
            &s,
            bins,
            &rates(bins, 0.01, 2.5, 8),
        );
    }
}

#[test]
fn coates_recovers_the_unpiled_histogram() {
    let bins = 40;
    let r = rates(bins, 0.03, 2.0, 15);
    let n = 5000.0;
    for (mode, dead_s, tol) in [
        (Acquisition::Synchronous, 40e-10, 1e-9),
        (Acquisition::Synchronous, 5e-10, 1e-9),
        // Free-running, the cold first cycle is armed where later ones may not be:
        // O(1/N).
        (Acquisition::FreeRunning, 5e-10, 3.0 / n),
    ] {
        let s = Spad {
            dead_time_s: dead_s,
            mode,
            ..spad(n as u64)
        };
        let det = detector(&s, bins, 1e-10);
        let mut e = vec![0.0; bins];
        det.expected(&r, &mut e);
        let mut est = vec![0.0; bins];
        coates(&det, &e, &mut est);
        for k in 0..bins {
            let want = n * r[k];
            assert!(
                (est[k] - want).abs() <= tol * want,
                "{mode:?} d {dead_s}: bin {k}: {} vs {want}",
                est[k]
            );
        }
        // From Monte Carlo counts: N r_k within the noise of the estimate (a weaker
        // return, so that every bin stays armed in hundreds of cycles).
        let r = rates(bins, 0.01, 0.6, 15);
        let (mean, error) = mean_and_error(32, |run| {
            let mut rng = Pcg64Mcg::seed_from_u64(77 + run);
            let counts = monte_carlo(
                &r,
                n as u64,
                det.dead_bins,
                mode == Acquisition::FreeRunning,
                0.0,
                0.0,
                &mut rng,
            );
            let mut est = vec![0.0; bins];
            coates(&det, &counts, &mut est);
            est
        });
        let want: Vec<f64> = r.iter().map(|x| n * x).collect();
        // Coates is biased at O(1/armed cycles); the noise dominates here.
        assert_within_noise(&format!("Coates of counts, {mode:?}"), &want, &mean, &error);
    }
}

fn phi(x: f64) -> f64 {
    0.5 * libm::erfc(-x / SQRT_2)
}

fn axis(t0: f64, dt: f64, bins: usize) -> TimeAxis {
    match TimeAxis::new(t0, dt, bins) {
        Ok(a) => a,
        Err(e) => panic!("{e}"),
    }
}

fn tdc(start_s: f64, bin_width_s: f64, bins: u64, jitter_fwhm_s: f64) -> Exposure {
    Exposure::Tdc {
        origin: TimeOrigin::Pulse,
        start_s,
        bin_width_s,
        bins,
        jitter_fwhm_s,
    }
}

fn model(sensor: Sensor, axis: TimeAxis) -> SensorModel {
    match SensorModel::new(sensor, axis) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn jitter_conserves_energy_and_has_the_phi_shape() {
    // A film of 64 bins of 50 ps from 2 ns; one impulse of weight 3 in bin 20; a TDC
    // of 40 bins of 80 ps from 1 ns (a 3.2 ns cycle), jitter from 1e-3 to 100 TDC bins.
    let ax = axis(2.0 * NS, 0.05 * NS, 64);
    let mut tprf = vec![0.0f32; 64];
    tprf[20] = 3.0;
    for fwhm_bins in [1e-3, 0.1, 1.0, 4.0, 100.0] {
        let fwhm = fwhm_bins * 0.08 * NS;
        let m = model(
            Sensor::new(LightPulse::default(), tdc(NS, 0.08 * NS, 40, fwhm)),
            ax,
        );
        let Ok(meas) = m.measure_clean(&tprf, 1, 1) else {
            panic!("measure");
        };
        let total: f64 = meas.values.iter().map(|&v| f64::from(v)).sum();
        assert!(
            (total - 3.0).abs() < 1e-5,
            "FWHM {fwhm_bins} bins: sum {total}"
        );
        // Shape: the impulse spread over [tau, tau + dt), folded with period T.
        let sigma = fwhm / FWHM_PER_SIGMA;
        let (tau, dt, t) = (ax.bin_start_s(20), ax.dt_s, 40.0 * 0.08 * NS);
        for k in 0..40 {
            let (a, b) = (NS + k as f64 * 0.08 * NS, NS + (k + 1) as f64 * 0.08 * NS);
            let steps = 2000;
            let mut want = 0.0;
            for j in 0..steps {
                let u = tau + dt * (j as f64 + 0.5) / steps as f64;
                for n in -3..=3 {
                    let (a, b) = (a + n as f64 * t, b + n as f64 * t);
                    want += phi((b - u) / sigma) - phi((a - u) / sigma);
                }
            }
            want *= 3.0 / steps as f64;
            let got = f64::from(meas.values[k]);
            assert!(
                (got - want).abs() < 2e-4 * 3.0,
                "FWHM {fwhm_bins} bins, TDC bin {k}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn arrivals_fold_into_the_cycle() {
    // An impulse at 2.5 cycles lands half-way through the cycle.
    let ax = axis(0.0, 0.1 * NS, 100);
    let mut tprf = vec![0.0f32; 100];
    tprf[62] = 1.0; // [6.2, 6.3) ns; cycle 2.4 ns: phase [1.4, 1.5) ns = TDC bin 14
    let m = model(
        Sensor::new(LightPulse::default(), tdc(0.0, 0.1 * NS, 24, 0.0)),
        ax,
    );
    let Ok(meas) = m.measure_clean(&tprf, 1, 1) else {
        panic!("measure");
    };
    for (k, &v) in meas.values.iter().enumerate() {
        let want = if k == 14 { 1.0 } else { 0.0 };
        assert!((f64::from(v) - want).abs() < 1e-6, "bin {k}: {v}");
    }
}

/// A whole SPAD sensor over a cube of `w` pixels with one impulse each.
fn spad_sensor(s: Spad, bins: u64, width_s: f64, light: LightPulse) -> Sensor {
    let mut sensor = Sensor::new(light, tdc(0.0, width_s, bins, 0.0));
    sensor.spad = Some(s);
    sensor.noise.seed = 11;
    sensor
}

#[test]
fn dark_counts_are_uniform() {
    let ax = axis(0.0, 0.1 * NS, 64);
    let (w, h) = (8, 4);
    let cube = vec![0.0f32; w * h * 64];
    let steady = vec![0.0f32; w * h];
    let dcr = 2e8; // 0.02 per 100 ps bin
    for (dead_s, free) in [(0.0, false), (6.4 * NS, false), (1.0 * NS, true)] {
        let s = Spad {
            dark_count_rate_hz: dcr,
            dead_time_s: dead_s,
            mode: if free {
                Acquisition::FreeRunning
            } else {
                Acquisition::Synchronous
            },
            ..spad(4000)
        };
        let m = model(spad_sensor(s, 64, 0.1 * NS, LightPulse::default()), ax);
        let Ok(meas) = m.measure_clean(&cube, w, h) else {
            panic!("measure");
        };
        let img = match spad_image(&m, &meas, &steady) {
            Ok(i) => i,
            Err(e) => panic!("{e}"),
        };
        let r = dcr * 0.1 * NS;
        // Coates of the expected histogram: flat at N r (free-running to O(1/N)).
        for &v in &img.histogram {
            assert!(v.is_finite() && v > 0.0);
        }
        let det = detector(
            m.sensor().spad.as_ref().unwrap_or(&Spad::default()),
            64,
            0.1 * NS,
        );
        let px: Vec<f64> = img
            .pixel(&img.histogram, 1, 2)
            .iter()
            .map(|&v| f64::from(v))
            .collect();
        let mut est = vec![0.0; 64];
        coates(&det, &px, &mut est);
        for (k, e) in est.iter().enumerate() {
            assert!(
                (e - 4000.0 * r).abs() < 1e-3 * 4000.0 * r,
                "dead {dead_s}: bin {k}: {e}"
            );
        }
        if dead_s == 0.0 {
            // No dead time: the histogram itself is flat, and each realisation's bins
            // are Binomial(N, 1 - e^-r): chi-square over all pixels and bins.
            let p = 1.0 - (-r).exp();
            let mean = 4000.0 * p;
            for &v in &img.histogram {
                assert!((f64::from(v) - mean).abs() < 1e-6 * mean);
            }
            let var = 4000.0 * p * (1.0 - p);
            let chi2: f64 = img
                .counts
                .iter()
                .map(|&c| (f64::from(c) - mean).powi(2) / var)
                .sum();
            let dof = img.counts.len() as f64;
            assert!(
                (chi2 - dof).abs() < 5.0 * (2.0 * dof).sqrt(),
                "chi2 {chi2} for {dof} bins"
            );
        }
    }
}

/// The cube's ambient image as a SPAD sees it: a pixel with only ambient radiance `A`
/// (no signal) counts `ambient_scale photons_per_unit A` photons per second in every
/// TDC bin, exactly as a uniform `ambient_rate_hz` of that value: same expected
/// histogram, same realisation (same seed), and the closed form of a flat rate
/// without dead time, `N (1 - exp(-PDE rate w))`.
#[test]
fn ambient_image_is_the_uniform_rate_closed_form() {
    let ax = axis(0.0, 0.1 * NS, 64);
    let (w, h) = (3, 2);
    let cube = vec![0.0f32; w * h * 64];
    let steady = vec![0.0f32; w * h];
    let (ppu, scale) = (2.0, 3.0);
    let a_radiance = [0.0f32, 1e7, 2e7, 5e7, 1e8, 4e8]; // W m^-2 sr^-1
    let base = Spad {
        photons_per_unit: ppu,
        pde: 0.5,
        ..spad(3000)
    };
    let mut sensor = spad_sensor(base.clone(), 64, 0.1 * NS, LightPulse::default());
    sensor.ambient_scale = scale;
    let m = model(sensor, ax);
    let Ok(meas) = m.measure_clean(&cube, w, h) else {
        panic!("measure");
    };
    let img = match spad_image_ambient(&m, &meas, &steady, Some(&a_radiance)) {
        Ok(i) => i,
        Err(e) => panic!("{e}"),
    };
    for (p, &a) in a_radiance.iter().enumerate() {
        let rate_hz = scale * ppu * f64::from(a);
        // The same pixel as a uniform ambient rate.
        let uniform = Spad {
            ambient_rate_hz: rate_hz,
            ..base.clone()
        };
        let mu = model(
            spad_sensor(uniform, 64, 0.1 * NS, LightPulse::default()),
            ax,
        );
        let one = vec![0.0f32; 64];
        let Ok(px) = spad_pixel(&mu, &one, 0.0) else {
            panic!("pixel");
        };
        let (y, x) = (p / w, p % w);
        let got = img.pixel(&img.histogram, y, x);
        let r = 0.5 * rate_hz * 0.1 * NS;
        let closed = 3000.0 * (1.0 - (-r).exp());
        for (k, (g, e)) in got.iter().zip(&px.expected).enumerate() {
            let g = f64::from(*g);
            assert!(
                (g - e).abs() <= 1e-5 * e.max(1e-9),
                "pixel {p} bin {k}: {g} vs {e}"
            );
            assert!(
                (g - closed).abs() <= 1e-5 * closed.max(1e-9),
                "pixel {p} bin {k}: {g} vs {closed}"
            );
        }
        let Ok(pa) = spad_pixel_ambient(&m, &one, 0.0, f64::from(a)) else {
            panic!("pixel");
        };
        assert_eq!(pa.expected, px.expected, "pixel {p}");
    }
}

/// Units of the light budget: the pulse's energy `E` (J) and `photons_per_unit`
/// (photons per radiance x second) enter the signal only as their product, and a steady
/// lamp of `ambient_lamp_hz` pulse energies per second counts `ambient_lamp_hz E
/// photons_per_unit steady` photons per second (hand-computed here as a uniform rate).
/// So a 1 uJ pulse with its real photon factor gives what the unit pulse with that
/// factor folded in gives, and the ambient image at `ambient_scale = 1` is physical.
#[test]
fn pulse_energy_and_photon_factor_enter_as_a_product() {
    let bins = 64;
    let ax = axis(0.0, 0.1 * NS, bins);
    let (w, h) = (2, 1);
    // [H, W, T]: a return at bin 10 in pixel 0, at bin 20 in pixel 1 (radiance x s per J).
    let mut cube = vec![0.0f32; w * h * bins];
    cube[10] = 3e-3;
    cube[bins + 20] = 1e-3;
    let steady: Vec<f32> = cube.chunks(bins).map(|px| px.iter().sum()).collect();
    let lamp_hz = 5e6;
    let histogram = |energy: f64, ppu: f64, lamp_hz: f64, ambient_hz: f64| {
        let light = LightPulse::Delta { t_s: 0.0, energy };
        let s = Spad {
            photons_per_unit: ppu,
            pde: 0.5,
            ambient_lamp_hz: lamp_hz,
            ambient_rate_hz: ambient_hz,
            ..spad(1000)
        };
        let m = model(spad_sensor(s, bins as u64, 0.1 * NS, light), ax);
        let Ok(meas) = m.measure_clean(&cube, w, h) else {
            panic!("measure");
        };
        match spad_image(&m, &meas, &steady) {
            Ok(i) => i,
            Err(e) => panic!("{e}"),
        }
    };
    let unit = histogram(1.0, 4e3, lamp_hz, 0.0);
    let micro = histogram(1e-6, 4e9, lamp_hz, 0.0);
    for (k, (a, b)) in unit.histogram.iter().zip(&micro.histogram).enumerate() {
        assert!(
            (a - b).abs() <= 1e-5 * a.abs().max(1e-9),
            "value {k}: {a} vs {b}"
        );
    }
    // The lamp of pixel p is a uniform rate of lamp_hz x E x ppu x steady[p].
    for (p, &st) in steady.iter().enumerate() {
        let rate_hz = lamp_hz * 1e-6 * 4e9 * f64::from(st);
        let flat = histogram(1e-6, 4e9, 0.0, rate_hz);
        let (y, x) = (p / w, p % w);
        let (a, b) = (
            micro.pixel(&micro.histogram, y, x),
            flat.pixel(&flat.histogram, y, x),
        );
        for (k, (a, b)) in a.iter().zip(&b).enumerate() {
            assert!(
                (a - b).abs() <= 1e-5 * a.abs().max(1e-9),
                "pixel {p} bin {k}: {a} vs {b}"
            );
        }
    }
}

/// The cancellable expected histogram: with its flag left clear it is the plain one,
/// value for value; with the flag set before it starts it gives up (`None`) rather than
/// an image.
#[test]
fn the_expected_histogram_gives_up_when_cancelled() {
    use std::sync::atomic::AtomicBool;
    let bins = 64;
    let ax = axis(0.0, 0.1 * NS, bins);
    let (w, h) = (9, 8);
    let cube: Vec<f32> = (0..w * h * bins)
        .map(|i| {
            if i % bins == 10 + (i / bins) % 7 {
                2e-3
            } else {
                0.0
            }
        })
        .collect();
    let steady: Vec<f32> = cube.chunks(bins).map(|px| px.iter().sum()).collect();
    let s = Spad {
        photons_per_unit: 1e3,
        ..spad(500)
    };
    let m = model(
        spad_sensor(s, bins as u64, 0.1 * NS, LightPulse::default()),
        ax,
    );
    let Ok(meas) = m.measure_clean(&cube, w, h) else {
        panic!("measure");
    };
    let plain = match spad_expected(&m, &meas, &steady, None) {
        Ok(i) => i,
        Err(e) => panic!("{e}"),
    };
    let clear = AtomicBool::new(false);
    let Ok(Some(until)) = spad_expected_until(&m, &meas, &steady, None, &clear) else {
        panic!("not cancelled, yet no image");
    };
    assert_eq!(until.histogram, plain.histogram);
    assert_eq!(
        until
            .depth_histogram_m
            .iter()
            .map(|d| d.to_bits())
            .collect::<Vec<_>>(),
        plain
            .depth_histogram_m
            .iter()
            .map(|d| d.to_bits())
            .collect::<Vec<_>>()
    );
    assert!(plain.histogram.iter().any(|&v| v > 0.0));
    let set = AtomicBool::new(true);
    assert!(matches!(
        spad_expected_until(&m, &meas, &steady, None, &set),
        Ok(None)
    ));
}

/// Mean of the first-photon time for a Gaussian return of `total` photons centred at
/// `mu` with `sigma`, by quadrature of `s(t) exp(-integral s) / (1 - e^-total)`.
fn first_photon_mean(total: f64, mu: f64, sigma: f64) -> f64 {
    let n = 200_000;
    let (lo, hi) = (mu - 10.0 * sigma, mu + 10.0 * sigma);
    let h = (hi - lo) / n as f64;
    let (mut num, mut den) = (0.0, 0.0);
    for j in 0..n {
        let t = lo + (j as f64 + 0.5) * h;
        let s = total * (-0.5 * ((t - mu) / sigma).powi(2)).exp() / (sigma * (2.0 * PI).sqrt());
        let cum = total * phi((t - mu) / sigma);
        let p = s * (-cum).exp() * h;
        num += p * t;
        den += p;
    }
    num / den
}

#[test]
fn pile_up_pulls_strong_returns_early() {
    // One impulse at [10.0, 10.01) ns in a 10 ps film; a Gaussian pulse of sigma 0.3 ns
    // centred at 2 ns; a first-photon TDC of 25 ps bins; no background.
    let ax = axis(0.0, 0.01 * NS, 2000);
    let mut tprf = vec![0.0f32; 2000];
    tprf[1000] = 1.0;
    let sigma = 0.3 * NS;
    let light = LightPulse::Gaussian {
        centre_s: 2.0 * NS,
        fwhm_s: sigma * FWHM_PER_SIGMA,
        energy: 1.0,
    };
    let bins = 1024u64; // 25.6 ns cycle
    let true_t = 10.005 * NS + 2.0 * NS;
    let mut bias_s = Vec::new();
    let mut depth_bias_m = Vec::new();
    let bin_m = 0.5 * C_M_PER_S * 0.025 * NS;
    for photons in [0.01, 1.0, 5.0, 30.0] {
        let s = Spad {
            photons_per_unit: photons,
            dead_time_s: bins as f64 * 0.025 * NS,
            ..spad(1_000_000)
        };
        let m = model(spad_sensor(s, bins, 0.025 * NS, light.clone()), ax);
        let Ok(meas) = m.measure_clean(&tprf, 1, 1) else {
            panic!("measure");
        };
        let img = match spad_image(&m, &meas, &[1.0]) {
            Ok(i) => i,
            Err(e) => panic!("{e}"),
        };
        // Histogram centroid against the first-photon density's mean.
        let (mut num, mut den) = (0.0, 0.0);
        for (k, &v) in img.histogram.iter().enumerate() {
            num += f64::from(v) * img.centres_s[k];
            den += f64::from(v);
        }
        let centroid = num / den;
        let theory = first_photon_mean(photons, true_t, sigma);
        assert!(
            (centroid - theory).abs() < 0.5 * 0.025 * NS,
            "{photons} photons: centroid {centroid} vs first-photon mean {theory}"
        );
        bias_s.push(theory - true_t);
        // The depths: pile-up pulls the histogram's early; Coates undoes it (exactly on
        // the expected histogram; on the realisation while the tail of the return still
        // has armed cycles to be measured in).
        let depth_true = 0.5 * C_M_PER_S * 10.005 * NS;
        let d_hist = f64::from(img.depth_histogram_m[0]);
        let det = detector(
            m.sensor().spad.as_ref().unwrap_or(&Spad::default()),
            bins as usize,
            0.025 * NS,
        );
        // In f64 (the f32 file loses the few cycles still armed after a saturating
        // return).
        let e = match spad_pixel(&m, &meas.values, 1.0) {
            Ok(p) => p.expected,
            Err(e) => panic!("{e}"),
        };
        let mut est = vec![0.0; e.len()];
        coates(&det, &e, &mut est);
        let d_expected_coates = return_depth_m(
            &est,
            &img.centres_s,
            2.0 * NS,
            &Returns {
                threshold: 0.2,
                ..Returns::default()
            },
            0,
            &mut Vec::new(),
        );
        assert!(
            (d_expected_coates - depth_true).abs() < bin_m,
            "{photons}: Coates of the expected histogram {d_expected_coates} vs {depth_true}"
        );
        depth_bias_m.push(d_hist - depth_true);
        if photons <= 5.0 {
            let d_coates = f64::from(img.depth_coates_m[0]);
            assert!(
                (d_coates - depth_true).abs() < 2.0 * bin_m,
                "{photons}: Coates {d_coates}"
            );
        }
    }
    // Weak: no bias to speak of; strong: early by a good part of sigma, more with more
    // photons.
    assert!(bias_s[0].abs() < 0.01 * sigma, "{bias_s:?}");
    // The histogram's depth follows: none when weak, early and more so with more light.
    let b = &depth_bias_m;
    assert!(b[0].abs() < bin_m, "{b:?}");
    assert!(b[1] < -0.5 * bin_m && b[2] < b[1] && b[3] < b[2], "{b:?}");
    assert!(bias_s[3] < bias_s[2] && bias_s[2] < bias_s[1] && bias_s[3] < -sigma);
}

fn tdc_sensor_with(f: impl FnOnce(&mut Spad)) -> Result<SensorModel, SensorError> {
    let mut s = spad(100);
    f(&mut s);
    let sensor = spad_sensor(s, 64, 0.1 * NS, LightPulse::default());
    SensorModel::new(sensor, axis(0.0, 0.1 * NS, 64))
}

#[test]
fn bad_input_is_refused_with_the_field() {
    type Edit = Box<dyn Fn(&mut Spad)>;
    let cases: [(&str, Edit); 10] = [
        ("spad.pde", Box::new(|s| s.pde = 1.5)),
        ("spad.pde", Box::new(|s| s.pde = f64::NAN)),
        (
            "spad.dark_count_rate_hz",
            Box::new(|s| s.dark_count_rate_hz = -1.0),
        ),
        (
            "spad.ambient_rate_hz",
            Box::new(|s| s.ambient_rate_hz = f64::INFINITY),
        ),
        ("spad.dead_time_s", Box::new(|s| s.dead_time_s = 7.0 * NS)),
        ("spad.cycles", Box::new(|s| s.cycles = 0)),
        ("spad.cycles", Box::new(|s| s.cycles = 10_000_000_000_000)),
        (
            "spad.photons_per_unit",
            Box::new(|s| s.photons_per_unit = -2.0),
        ),
        (
            "spad.afterpulse_probability",
            Box::new(|s| s.afterpulse_probability = 2.0),
        ),
        (
            "spad.afterpulse_delay_s",
            Box::new(|s| s.afterpulse_probability = 0.1),
        ),
    ];
    for (field, f) in cases {
        match tdc_sensor_with(|s| f(s)) {
            Ok(_) => panic!("{field}: accepted"),
            Err(e) => assert!(e.to_string().contains(field), "{field}: {e}"),
        }
    }
    // A SPAD needs TDC bins.
    let mut sensor = Sensor::new(
        LightPulse::default(),
        Exposure::Box {
            origin: TimeOrigin::Pulse,
            start_s: 0.0,
            width_s: NS,
            step_s: None,
            count: 4,
            gain: 1.0,
        },
    );
    sensor.spad = Some(spad(10));
    let e = SensorModel::new(sensor, axis(0.0, 0.1 * NS, 64));
    assert!(
        matches!(e, Err(ref e) if e.to_string().contains("tdc")),
        "{e:?}"
    );
    // In a file, with a unit.
    let text = "[exposure]\nkind = \"tdc\"\nbin_width = \"100 ps\"\nbins = 64\n\
                [spad]\ncycles = 10\nphotons_per_unit = 1\npde = 1.2\n";
    match Sensor::from_toml_str(text) {
        Ok(_) => panic!("pde 1.2 accepted"),
        Err(e) => assert!(e.to_string().contains("spad.pde"), "{e}"),
    }
    let text = "[exposure]\nkind = \"tdc\"\nbin_width = \"100 ps\"\nbins = 64\n\
                [spad]\ncycles = 10\nphotons_per_unit = 1\ndead_tme = \"1 ns\"\n";
    assert!(Sensor::from_toml_str(text).is_err());
    // The built-in preset loads.
    assert!(Sensor::builtin("spad").is_ok());
}

#[test]
fn extreme_values_stay_finite() {
    let ax = axis(0.0, 0.1 * NS, 64);
    let (w, h) = (4, 2);
    let mut cube = vec![0.0f32; w * h * 64];
    for p in 0..w * h {
        cube[p * 64 + 20] = 1e6 * (p as f32 + 1.0); // saturating returns
    }
    let steady: Vec<f32> = (0..w * h).map(|p| 1e6 * (p as f32 + 1.0)).collect();
    for mode in [Acquisition::Synchronous, Acquisition::FreeRunning] {
        for (dead_s, ambient) in [(6.4 * NS, 0.0), (1.0 * NS, 1e12), (0.0, 0.0)] {
            let s = Spad {
                cycles: 1_000_000_000,
                photons_per_unit: 1e3,
                ambient_rate_hz: ambient,
                dead_time_s: dead_s,
                mode,
                ..spad(1)
            };
            let m = model(spad_sensor(s, 64, 0.1 * NS, LightPulse::default()), ax);
            let Ok(meas) = m.measure_clean(&cube, w, h) else {
                panic!("measure");
            };
            let img = match spad_image(&m, &meas, &steady) {
                Ok(i) => i,
                Err(e) => panic!("{e}"),
            };
            let what = format!("{mode:?}, dead {dead_s}, ambient {ambient}");
            assert!(
                img.histogram.iter().all(|v| v.is_finite() && *v >= 0.0),
                "{what}"
            );
            assert!(
                img.counts.iter().all(|v| v.is_finite() && *v >= 0.0),
                "{what}"
            );
            assert!(
                img.coates.iter().all(|v| v.is_nan() || v.is_finite()),
                "{what}"
            );
            // At most 1e9 detections per bin, and per cycle at most one per d + 1 bins.
            let per_px: f64 = img
                .pixel(&img.histogram, 0, 0)
                .iter()
                .map(|&v| f64::from(v))
                .sum();
            let d = (dead_s / (0.1 * NS)).round();
            assert!(
                per_px <= 1e9 * (64.0 / (d + 1.0)).ceil() * (1.0 + 1e-9),
                "{what}: {per_px}"
            );
        }
    }
}

/// A fresh folder under the test target's temporary folder.
fn tempdir(name: &str) -> std::path::PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("spad-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    if let Err(e) = std::fs::create_dir_all(&d) {
        panic!("{}: {e}", d.display());
    }
    d
}

/// The SPAD's files written a row at a time (a budget of 1 byte a band) are byte for
/// byte those written in one band, which hold the arrays `spad_image_ambient` gives in
/// memory; and the two-stage form (expected first, realisation later) gives them too.
#[test]
fn spad_files_in_bands_are_the_whole_image() {
    let bins = 48;
    let ax = axis(0.0, 0.1 * NS, bins);
    let (w, h) = (7, 5);
    // A return per pixel at a bin that moves with the pixel, over a background.
    let mut cube = vec![0.0f32; w * h * bins];
    for p in 0..w * h {
        cube[p * bins + 5 + (p * 7) % 30] = 0.5 + 0.1 * (p % 4) as f32;
    }
    let steady: Vec<f32> = (0..w * h).map(|p| 0.5 + 0.1 * (p % 4) as f32).collect();
    let ambient: Vec<f32> = (0..w * h).map(|p| 1e6 * (p % 3) as f32).collect();
    for (dead_s, mode) in [
        (0.25 * NS, Acquisition::FreeRunning),
        (bins as f64 * 0.1 * NS, Acquisition::Synchronous),
    ] {
        let s = Spad {
            dead_time_s: dead_s,
            mode,
            ambient_rate_hz: 1e8,
            ..spad(700)
        };
        let light = LightPulse::Gaussian {
            centre_s: 0.5 * NS,
            fwhm_s: 0.3 * NS,
            energy: 1.0,
        };
        let mut sensor = spad_sensor(s, bins as u64, 0.1 * NS, light);
        sensor.ambient_scale = 1.0;
        let m = model(sensor, ax);
        let Ok(meas) = m.measure_clean(&cube, w, h) else {
            panic!("measure");
        };
        let whole = tempdir(&format!("whole-{mode:?}"));
        let rows = tempdir(&format!("rows-{mode:?}"));
        let write = |dir: &std::path::Path, tile_bytes: u64| {
            let pipeline = tprf_core::sensor::pipeline::Pipeline {
                model: &m,
                clean: &meas,
                steady: &steady,
                ambient: Some(&ambient),
            };
            match tprf_core::export::sensor::write_spad_files(dir, &pipeline, tile_bytes) {
                Ok(f) => f,
                Err(e) => panic!("{e}"),
            }
        };
        let a = write(&whole, u64::MAX);
        let b = write(&rows, 1);
        assert_eq!((a.bands, b.bands), (1, h), "{mode:?}");
        let img = match spad_image_ambient(&m, &meas, &steady, Some(&ambient)) {
            Ok(i) => i,
            Err(e) => panic!("{e}"),
        };
        for (name, values) in [
            ("spad_histogram.npy", &img.histogram),
            ("spad_counts.npy", &img.counts),
            ("spad_coates.npy", &img.coates),
            ("spad_depth_histogram.npy", &img.depth_histogram_m),
            ("spad_depth_counts.npy", &img.depth_counts_m),
            ("spad_depth_coates.npy", &img.depth_coates_m),
        ] {
            let (x, y) = (
                std::fs::read(whole.join(name)).unwrap_or_default(),
                std::fs::read(rows.join(name)).unwrap_or_default(),
            );
            assert!(!x.is_empty() && x == y, "{mode:?}: {name} differs");
            let (_, read) = match tprf_core::export::read_npy_f32(&whole.join(name)) {
                Ok(r) => r,
                Err(e) => panic!("{e}"),
            };
            let same = read
                .iter()
                .zip(values.iter())
                .all(|(p, q)| p.to_bits() == q.to_bits());
            assert!(
                same && read.len() == values.len(),
                "{mode:?}: {name} vs in memory"
            );
        }
        assert!(img.counts.iter().any(|&c| c > 0.0));
        // Expected first, then the realisation: the same image.
        let mut staged =
            match tprf_core::sensor::spad::spad_expected(&m, &meas, &steady, Some(&ambient)) {
                Ok(i) => i,
                Err(e) => panic!("{e}"),
            };
        assert!(!staged.is_sampled() && staged.histogram == img.histogram);
        assert_eq!(staged.depth_histogram_m.len(), img.depth_histogram_m.len());
        if let Err(e) =
            tprf_core::sensor::spad::spad_sample(&m, &meas, &steady, Some(&ambient), &mut staged)
        {
            panic!("{e}");
        }
        assert!(staged.is_sampled());
        assert_eq!(staged.counts, img.counts);
        assert_eq!(staged.sampler, img.sampler);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&staged.coates), bits(&img.coates));
        assert_eq!(bits(&staged.depth_counts_m), bits(&img.depth_counts_m));
        let _ = std::fs::remove_dir_all(&whole);
        let _ = std::fs::remove_dir_all(&rows);
    }
}

/// How far the model (dead time from the end of the detection's TDC bin) lands from a
/// real SPAD (dead time from the photon), measured against the photon-start simulation
/// above (48 runs of 1500-2000 cycles; the figures are this test's, printed with
/// `--nocapture`):
///
/// - a dead time of a whole cycle or more (first photon only): the same histogram;
/// - always: the model is dead 0 to 1 bin longer, so its total detections lie between
///   the real SPAD's at `tau` and at `tau + w` (model at `tau` <= real <= model at
///   `tau - w`);
/// - weak returns and a long dead time (the preset's regime: 100 of 256 bins, at most
///   0.3 events a bin): every bin within the simulation's noise (5 standard errors +
///   2 %), the totals within 0.5 %;
/// - strong returns (2.5 events a bin) and a short dead time (1-2.5 bins): the model
///   loses 8-15 % of the detections and its worst bin is 15-30 % off. Setting
///   `dead_time_s` to `tau - w / 2` brings the totals within 3 % there, not every bin.
#[test]
fn dead_time_from_the_photon_against_the_model() {
    let w = 1e-10;
    let mc = |r: &[f64], s: &Spad, tau: f64| {
        mean_and_error(48, |run| {
            let mut rng = Pcg64Mcg::seed_from_u64(0xD00D + run);
            monte_carlo_continuous(
                r,
                s.cycles,
                tau,
                DeadFrom::Photon,
                s.mode == Acquisition::FreeRunning,
                &mut rng,
            )
        })
    };
    let model = |r: &[f64], s: &Spad, tau: f64| {
        let s = Spad {
            dead_time_s: tau * w,
            ..s.clone()
        };
        let mut e = vec![0.0; r.len()];
        detector(&s, r.len(), w).expected(r, &mut e);
        e
    };
    // First photon only: the dead time never ends within the cycle either way.
    {
        let bins = 24;
        let r = rates(bins, 0.15, 2.5, 9);
        let s = spad(1500);
        let (mean, error) = mc(&r, &s, bins as f64);
        let got = model(&r, &s, bins as f64);
        // A bin too dark for any run to see gets the Poisson error of its mean.
        let error: Vec<f64> = error
            .iter()
            .zip(&got)
            .map(|(e, g)| e.max((g / 48.0).sqrt()))
            .collect();
        assert_within_noise("first photon", &got, &mean, &error);
    }
    // (bins, tau in bins, background, peak, mode, strong return).
    let cases = [
        (24, 2.5, 0.15, 2.5, Acquisition::Synchronous, true),
        (24, 2.5, 0.15, 2.5, Acquisition::FreeRunning, true),
        (24, 1.0, 0.3, 1.0, Acquisition::FreeRunning, true),
        (256, 100.0, 0.004, 0.3, Acquisition::Synchronous, false),
        (256, 100.0, 0.004, 0.3, Acquisition::FreeRunning, false),
    ];
    for (bins, tau, background, peak, mode, strong) in cases {
        let what = format!("{mode:?}, {bins} bins, tau = {tau} bins");
        let r = rates(bins, background, peak, bins / 3);
        let s = Spad { mode, ..spad(2000) };
        let (mean, error) = mc(&r, &s, tau);
        let at_tau = model(&r, &s, tau);
        let shorter = model(&r, &s, (tau - 1.0).max(0.0));
        let half = model(&r, &s, tau - 0.5);
        let total = |v: &[f64]| v.iter().sum::<f64>();
        let (real, total_error) = (
            total(&mean),
            error.iter().map(|e| e * e).sum::<f64>().sqrt(),
        );
        assert!(
            total(&at_tau) <= real + 5.0 * total_error
                && real <= total(&shorter) + 5.0 * total_error,
            "{what}: model at tau {} <= real {real} <= model at tau - w {}",
            total(&at_tau),
            total(&shorter)
        );
        let worst = |v: &[f64]| {
            (0..bins)
                .filter(|&k| mean[k] > 20.0)
                .map(|k| (v[k] / mean[k] - 1.0).abs())
                .fold(0.0f64, f64::max)
        };
        let (worst_tau, worst_half) = (worst(&at_tau), worst(&half));
        eprintln!(
            "{what}: worst bin off by {:.1} % at tau, {:.1} % at tau - w/2; totals {:.1} at \
             tau, {:.1} at tau - w/2, real {real:.1} +- {total_error:.1}",
            100.0 * worst_tau,
            100.0 * worst_half,
            total(&at_tau),
            total(&half),
        );
        if strong {
            let lost = 1.0 - total(&at_tau) / real;
            assert!(
                (0.05..=0.2).contains(&lost) && (0.15..=0.35).contains(&worst_tau),
                "{what}: the model loses {lost} of the detections, worst bin {worst_tau}"
            );
            assert!(
                (total(&half) / real - 1.0).abs() <= 0.03,
                "{what}: model at tau - w/2 {} vs real {real}",
                total(&half)
            );
        } else {
            for k in 0..bins {
                let tol = 5.0 * error[k] + 0.02 * mean[k];
                assert!(
                    (at_tau[k] - mean[k]).abs() <= tol,
                    "{what}, bin {k}: model {} vs real {} +- {}",
                    at_tau[k],
                    mean[k],
                    error[k]
                );
            }
            assert!(
                (total(&at_tau) / real - 1.0).abs() <= 0.005,
                "{what}: model {} vs real {real}",
                total(&at_tau)
            );
        }
    }
}

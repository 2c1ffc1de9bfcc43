//! Recompute time of the sensor (paper, section 6) on cubes of 64^2, 256^2 and 512^2
//! pixels x 1024 bins: the kernels `K_i` after a light or gate edit, the measurement
//! `[pixels x T] x [T x N]`, and the noise after a `sigma` edit. Prints a markdown
//! table (docs/sensor.md). Run: `cargo bench --bench sensor`.
//!
//! The target: every edit updates the measurement image within one frame (16 ms) at
//! 256 x 256 x 1024.
//!
//! With `TPRF_BENCH_SPAD_CUBE=DIR` (a `tprf render` folder with `tprf.npy`), only the
//! SPAD's stages on that cube with `builtin:spad`: the clean measurement, the expected
//! histogram with its depth (what the window shows first after an edit), the
//! realisation with Coates and depths, and all of it at once, on one thread (the
//! viewer's background pool on a 2-core machine) and on all. `TPRF_BENCH_SPAD_QUICK=1`
//! times the first stage only (for a profiler: the realisation dwarfs it).

use std::time::Instant;

use tprf_core::film::TimeAxis;
use tprf_core::sensor::light::FWHM_PER_SIGMA;
use tprf_core::sensor::{Exposure, LightPulse, NoiseField, Sensor, SensorModel, TimeOrigin};

const BINS: usize = 1024;
const DT_S: f64 = 10e-12;

/// Best wall time of `runs` calls of `f`, milliseconds (after one warm-up call): the
/// least disturbed by other work on a shared machine.
fn best_ms(runs: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[0]
}

fn boxes(start_bins: f64, width_bins: f64, count: u64) -> Exposure {
    Exposure::Box {
        origin: TimeOrigin::Window,
        start_s: start_bins * DT_S,
        width_s: width_bins * DT_S,
        step_s: None,
        count,
        gain: 1.0,
    }
}

/// The SPAD's stages on the cube of `dir` (see the module's doc).
fn spad_stages(dir: &std::path::Path) {
    use tprf_core::sensor::spad::{spad_expected, spad_image_ambient, spad_sample};
    let (meta, cube) = match tprf_core::export::read_cube(&dir.join("tprf.npy")) {
        Ok(c) => c,
        Err(e) => panic!("{}: {e}", dir.display()),
    };
    let axis = match meta.axis() {
        Ok(a) => a,
        Err(e) => panic!("{e}"),
    };
    let (w, h) = (meta.width, meta.height);
    let sensor = match Sensor::builtin("spad") {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    };
    let mut model = None;
    // The kernels (TDC bins folded over the cycle, through the jitter and the pulse):
    // what a light or gate edit recomputes before anything is measured.
    let kernels_ms = best_ms(3, || model = SensorModel::new(sensor.clone(), axis).ok());
    let Some(model) = model else {
        panic!("builtin:spad rejected");
    };
    println!(
        "kernels of the {} TDC bins: {kernels_ms:.1} ms\n",
        model.gate_count()
    );
    let steady: Vec<f32> = cube
        .chunks_exact(axis.bins)
        .map(|p| p.iter().map(|&v| f64::from(v)).sum::<f64>() as f32)
        .collect();
    println!(
        "SPAD stages, builtin:spad on {} ({w} x {h} x {} bins), best of 3, ms\n",
        dir.display(),
        axis.bins
    );
    println!(
        "| threads | clean measurement | expected + depth | realisation + Coates + depths | \
         all at once (spad_image_ambient) |"
    );
    println!("| ---: | ---: | ---: | ---: | ---: |");
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build();
    let all = rayon::ThreadPoolBuilder::new().build();
    for pool in [one, all].into_iter().flatten() {
        pool.install(|| {
            let mut clean = None;
            let clean_ms = best_ms(3, || clean = model.measure_clean(&cube, w, h).ok());
            let Some(clean) = clean else {
                panic!("measurement failed");
            };
            let mut first = None;
            let expected_ms = best_ms(3, || {
                first = spad_expected(&model, &clean, &steady, None).ok();
            });
            let Some(first) = first else {
                panic!("spad_expected failed");
            };
            if std::env::var_os("TPRF_BENCH_SPAD_QUICK").is_some() {
                let again_ms = best_ms(10, || {
                    std::hint::black_box(spad_expected(&model, &clean, &steady, None).ok());
                });
                println!(
                    "| {} | {clean_ms:.0} | {:.0} | - | - |",
                    rayon::current_num_threads(),
                    expected_ms.min(again_ms)
                );
                return;
            }
            let sample_ms = best_ms(3, || {
                let mut img = first.clone();
                if let Err(e) = spad_sample(&model, &clean, &steady, None, &mut img) {
                    panic!("{e}");
                }
            });
            let all_ms = best_ms(3, || {
                std::hint::black_box(spad_image_ambient(&model, &clean, &steady, None).ok());
            });
            println!(
                "| {} | {clean_ms:.0} | {expected_ms:.0} | {sample_ms:.0} | {all_ms:.0} |",
                rayon::current_num_threads()
            );
        });
    }
}

fn main() {
    if let Some(dir) = std::env::var_os("TPRF_BENCH_SPAD_CUBE") {
        spad_stages(std::path::Path::new(&dir));
        return;
    }
    let axis = match TimeAxis::new(0.0, DT_S, BINS) {
        Ok(a) => a,
        Err(e) => panic!("{e}"),
    };
    // A Gaussian pulse 2 bins wide (FWHM), centred 4 bins after the trigger.
    let light = LightPulse::Gaussian {
        centre_s: 4.0 * DT_S,
        fwhm_s: 2.0 * DT_S,
        energy: 1.0,
    };
    let sensors = [
        ("1 box gate, 64 bins", boxes(300.0, 64.0, 1)),
        ("1 box gate, whole window", boxes(-16.0, 1056.0, 1)),
        ("32 box gates tiling the window", boxes(0.0, 32.0, 32)),
        (
            "4 AMCW gates (20 MHz)",
            Exposure::Amcw {
                freq_hz: 20e6,
                phase_steps: 4,
                phase0_deg: 0.0,
                modulation: 1.0,
            },
        ),
    ];
    println!(
        "rayon threads: {}; light: Gaussian, FWHM {} bins; bins of {} ps\n",
        rayon::current_num_threads(),
        2.0,
        DT_S * 1e12
    );
    let _ = FWHM_PER_SIGMA;
    println!(
        "| pixels | sensor | bins read / pixel | kernels (ms) | measurement (ms) | \
         cube read (GB/s) | noise, sigma edit (ms) | noise, new seed (ms) |"
    );
    println!("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    for side in [64usize, 256, 512] {
        let n = side * side * BINS;
        // Deterministic, non-trivial content (the cost does not depend on it).
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let cube: Vec<f32> = (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
            })
            .collect();
        let runs = if side >= 512 { 3 } else { 7 };
        // For scale: one plain pass over the cube.
        let sum_ms = best_ms(runs, || {
            use rayon::prelude::*;
            // Bitwise OR vectorises (a float sum would not): a pure read of the cube.
            let s: u32 = cube
                .par_chunks(1 << 16)
                .map(|c| c.iter().fold(0u32, |a, x| a | x.to_bits()))
                .reduce(|| 0, |a, b| a | b);
            std::hint::black_box(s);
        });
        println!(
            "| {side}^2 | (reference: one pass over the cube, bitwise OR) | {BINS} | | \
             {sum_ms:.2} | {:.1} | | |",
            (n * 4) as f64 / (sum_ms * 1e-3) / 1e9
        );
        for (name, exposure) in &sensors {
            let mut sensor = Sensor::new(light.clone(), exposure.clone());
            sensor.noise.sigma = 0.01;
            let mut model = None;
            let kernels_ms = best_ms(runs, || {
                model = SensorModel::new(sensor.clone(), axis).ok();
            });
            let Some(model) = model else {
                panic!("sensor rejected");
            };
            let mut m = None;
            let measure_ms = best_ms(runs, || {
                m = model.measure_clean(&cube, side, side).ok();
            });
            let Some(clean) = m else {
                panic!("measurement failed");
            };
            let reads = model.packed().reads_per_pixel();
            let bytes = (side * side) as f64 * reads.min(BINS) as f64 * 4.0;
            // Noise on a copy of the clean measurement (a viewer keeps the clean one).
            let mut field = NoiseField::default();
            let mut noisy = clean.clone();
            model.apply_noise_cached(&mut noisy, &mut field);
            let sigma_ms = best_ms(runs, || {
                noisy.values.copy_from_slice(&clean.values);
                model.apply_noise_cached(&mut noisy, &mut field);
            });
            let seed_ms = best_ms(runs, || {
                noisy.values.copy_from_slice(&clean.values);
                model.apply_noise_cached(&mut noisy, &mut NoiseField::default());
            });
            println!(
                "| {side}^2 | {name} | {reads} | {kernels_ms:.2} | {measure_ms:.2} | {:.1} | \
                 {sigma_ms:.2} | {seed_ms:.2} |",
                bytes / (measure_ms * 1e-3) / 1e9
            );
        }
    }
}

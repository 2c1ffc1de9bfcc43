//! Laws the renderer must obey whatever the scene: determinism across thread counts,
//! conservation of energy by the time binning, time-scale invariance, and lossless
//! accumulation.

use crate::common;
use common::*;
use tprf_core::film::{FilmLayout, TimeAxis, TimeFilter, TprfFilm};
use tprf_core::transport::RenderSettings;
use tprf_core::transport::progressive::Schedule;

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn same_output_for_one_and_two_threads() {
    let axis = TimeAxis::new(0.0, 0.5 / C, 40).unwrap();
    let one = in_pool(1, || {
        render_scene(furnace(1.0, 0.7, 1.0), 10, 7, axis, 6, 42, 3)
    });
    let two = in_pool(2, || {
        render_scene(furnace(1.0, 0.7, 1.0), 10, 7, axis, 6, 42, 3)
    });
    let (a, b) = (
        one.film.snapshot().dense(None),
        two.film.snapshot().dense(None),
    );
    assert!(a.iter().any(|&v| v > 0.0));
    assert!(
        a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
        "cubes differ"
    );
    let dense_layers = |f: &TprfFilm| {
        let s = f.snapshot();
        (0..s.layers())
            .flat_map(|l| s.dense(Some(l)))
            .collect::<Vec<f32>>()
    };
    let (a, b) = (dense_layers(&one.film), dense_layers(&two.film));
    assert!(a.iter().any(|&v| v > 0.0));
    assert!(
        a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
        "bounce layers differ"
    );
    assert_eq!(one.rays, two.rays);
}

#[test]
fn an_adaptive_render_is_the_same_for_one_and_two_threads() {
    // builtin:cornell's noise sits in a few pixels, so its passes are planned: each plan
    // is made from the film alone, whatever the pool that rendered it.
    let render = || {
        let scene = tprf_core::scene::load("builtin:cornell").unwrap();
        let axis = TimeAxis::new(3.5e-9, 5e-11, 64).unwrap();
        render_scene(scene, 24, 24, axis, 96, 3, 0)
    };
    let (one, two) = (in_pool(1, render), in_pool(2, render));
    let (a, b) = (one.film.cube_f64(), two.film.cube_f64());
    assert!(a.iter().any(|&v| v > 0.0));
    assert!(
        a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
        "cubes differ"
    );
    assert_eq!(one.rays, two.rays);
    // Planned: the pixels drew unequal samples.
    let drawn: Vec<[u32; 2]> = one.film.pixel_samples().map(|s| s.drawn).collect();
    assert!(drawn.iter().any(|d| d != &drawn[0]), "no pass was planned");
    assert_eq!(
        drawn,
        two.film
            .pixel_samples()
            .map(|s| s.drawn)
            .collect::<Vec<_>>()
    );
}

#[test]
fn sum_over_time_equals_steady_state_render() {
    // Same seed, same paths: a one-bin render covering all times (a steady-state render)
    // must equal the sum over 200 bins of a window that holds every arrival. Uniform
    // samples: an adaptive plan follows the noise of each bin, which differs between the
    // two axes, so the two would draw other samples.
    let scene = || furnace(1.0, 0.5, 1.0);
    let fine = TimeAxis::new(0.0, 0.25 / C, 200).unwrap();
    let steady_axis = TimeAxis::new(0.0, 50.0 / C, 1).unwrap();
    let uniform = RenderSettings {
        seed: 5,
        adaptive: false,
        ..RenderSettings::default()
    };
    let binned = render_with(scene(), 6, 6, fine, 64, uniform, 0);
    let steady = render_with(scene(), 6, 6, steady_axis, 64, uniform, 0);
    for (a, b) in binned.film.steady().iter().zip(steady.film.steady()) {
        assert!((a - b).abs() <= 1e-12 * b, "{a} vs {b}");
    }
    // Adaptive (the default): the same within the noise.
    let adaptive = render_scene(scene(), 6, 6, fine, 64, 5, 0);
    let mean = |v: Vec<f64>| v.iter().sum::<f64>() / v.len() as f64;
    let (a, b) = (mean(adaptive.film.steady()), mean(steady.film.steady()));
    assert!((a - b).abs() < 0.03 * b, "{a} vs {b}");
    // Independent seeds: equal within the noise (about 1 % for the mean of 6 x 6 x 64 samples).
    let other = render_scene(scene(), 6, 6, steady_axis, 64, 6, 0);
    let (a, b) = (mean(binned.film.steady()), mean(other.film.steady()));
    assert!((a - b).abs() < 0.03 * b, "{a} vs {b}");
}

/// Scale the furnace by `s` (and the intensity by s^2 so radiance is unchanged): the TPRF
/// is the same on a time axis stretched by s.
fn scaled_matches(s: f32) {
    let base_axis = TimeAxis::new(0.25 / C, 0.5 / C, 30).unwrap();
    let axis = TimeAxis::new(base_axis.t0_s * s as f64, base_axis.dt_s * s as f64, 30).unwrap();
    let base = render_scene(furnace(1.0, 0.6, 1.0), 8, 8, base_axis, 16, 9, 0);
    let scaled = render_scene(
        furnace(1.0, 0.6, 1.0).scaled(s).with_intensity_scale(s * s),
        8,
        8,
        axis,
        16,
        9,
        0,
    );
    let sum_bins = |film: &TprfFilm| -> Vec<f64> {
        let mut out = vec![0.0; 30];
        for y in 0..8 {
            for x in 0..8 {
                for (o, v) in out.iter_mut().zip(film.pixel_tprf(x, y)) {
                    *o += v;
                }
            }
        }
        out
    };
    let (a, b) = (sum_bins(&base.film), sum_bins(&scaled.film));
    let peak = a.iter().cloned().fold(0.0, f64::max);
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        assert!(
            (x - y).abs() < 2e-3 * peak,
            "scale {s}: bin {i}: {x} vs {y}"
        );
    }
}

#[test]
fn time_scale_invariance_1mm() {
    scaled_matches(1e-3);
}

#[test]
fn time_scale_invariance_10km() {
    scaled_matches(1e4);
}

#[test]
fn bins_accumulate_1e8_samples_without_loss() {
    let axis = TimeAxis::new(0.0, 1.0, 2).unwrap();
    let mut film = TprfFilm::new(FilmLayout {
        width: 1,
        height: 1,
        axis,
        bounces_separate: 0,
        luminescence: false,
    })
    .unwrap();
    let n: u64 = 100_000_000;
    film.run_pass(1, |_, _, sink| {
        for i in 0..n {
            // Values that an f32 accumulator would lose entirely once the sum is large.
            sink.add(0.5, 1.0 + (i % 7) as f64 * 1e-3, 1);
        }
    });
    let expected: f64 = (0..7u64)
        .map(|k| (n / 7 + u64::from(k < n % 7)) as f64 * (1.0 + k as f64 * 1e-3))
        .sum();
    let got = film.pixel_tprf(0, 0)[0];
    assert!(
        (got - expected).abs() < 1e-9 * expected,
        "{got} vs {expected}"
    );
}

#[test]
fn tent_filter_conserves_energy_and_keeps_centred_deltas_in_one_bin() {
    // Same seed, same paths (uniform samples: an adaptive plan follows each film's own
    // noise): the tent film's sum over bins equals the box film's.
    let axis = TimeAxis::new(0.0, 0.5 / C, 40).unwrap();
    let settings = RenderSettings {
        seed: 8,
        adaptive: false,
        ..Default::default()
    };
    let renderer =
        tprf_core::transport::Renderer::new(std::sync::Arc::new(furnace(1.0, 0.7, 1.0)), settings);
    let layout = FilmLayout {
        width: 6,
        height: 5,
        axis,
        bounces_separate: 2,
        luminescence: false,
    };
    let mut films = [TimeFilter::Box, TimeFilter::Tent]
        .map(|f| TprfFilm::new(layout).unwrap().with_time_filter(f));
    for film in &mut films {
        tprf_core::transport::progressive::render(&renderer, film, &Schedule::spp(12), |_, _| {
            std::ops::ControlFlow::Continue(())
        });
    }
    let [boxed, tent] = &films;
    for (a, b) in boxed.steady().iter().zip(tent.steady()) {
        assert!((a - b).abs() <= 1e-12 * a.abs(), "{a} vs {b}");
    }
    // The per-bounce layers are filtered the same way.
    let (bl, tl) = (boxed.pixel_bounces(2, 2), tent.pixel_bounces(2, 2));
    for (a, b) in bl.iter().zip(&tl) {
        let (sa, sb): (f64, f64) = (a.iter().sum(), b.iter().sum());
        assert!((sa - sb).abs() <= 1e-12 * sa.abs());
    }
    // The tent smooths: its TPRF differs from the box's, but not its total.
    assert_ne!(boxed.pixel_tprf(2, 2), tent.pixel_tprf(2, 2));

    // A delta at a bin centre lands in that bin alone; one between two centres splits
    // linearly.
    let axis = TimeAxis::new(1e-9, 1e-10, 8).unwrap();
    let mut film = TprfFilm::new(FilmLayout {
        width: 1,
        height: 1,
        axis,
        bounces_separate: 0,
        luminescence: false,
    })
    .unwrap()
    .with_time_filter(TimeFilter::Tent);
    film.run_pass(1, |_, _, sink| {
        sink.add(axis.bin_center_s(3), 2.0, 1);
        sink.add(axis.bin_center_s(5) + 0.25 * axis.dt_s, 1.0, 1);
    });
    let t = film.pixel_tprf(0, 0);
    assert_eq!(t[3], 2.0);
    assert!((t[5] - 0.75).abs() < 1e-12 && (t[6] - 0.25).abs() < 1e-12);
    assert_eq!(t[2] + t[4] + t[7], 0.0);
}

//! Adaptive sampling against answers known here: a planned pass weights each pixel to
//! the pass's size (hand-computed means), and over many pixels of known mean and
//! variance the plan puts the samples where the noise is while the means stay unbiased
//! (their average within a few standard errors of the truth, which is tight over
//! thousands of pixels).

use tprf_core::film::{FilmLayout, PixelPass, TimeAxis, TprfFilm};
use tprf_core::transport::adaptive;
use tprf_core::transport::progressive::doubling_spp;

/// A uniform number in [0, 1) from a key, by the SplitMix64 finaliser: owes nothing to
/// the code under test.
fn uniform(key: u64) -> f64 {
    let mut z = key.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

fn film(width: usize, height: usize, bins: usize) -> (TprfFilm, TimeAxis) {
    let axis = TimeAxis::new(0.0, 1e-9, bins).unwrap();
    let layout = FilmLayout {
        width,
        height,
        axis,
        bounces_separate: 0,
        luminescence: false,
    };
    (TprfFilm::new(layout).unwrap(), axis)
}

#[test]
fn a_planned_pass_weights_each_pixel_to_the_pass_size() {
    let (mut film, axis) = film(3, 2, 4);
    // Pixel i's samples each bring i + 1 into bin 1: whatever a pixel draws, its mean
    // is i + 1.
    let plan = [1, 2, 3, 5, 8, 13];
    film.run_pass_planned(4, Some(&plan), |x, y, pass, sink| {
        let i = y * 3 + x;
        assert_eq!(pass.first, 0);
        assert_eq!(pass.samples, plan[i]);
        for _ in 0..pass.samples {
            sink.add(axis.bin_center_s(1), (i + 1) as f64, 1);
        }
        7 * pass.samples as u64
    });
    // A uniform pass into the other half, then a planned one into the first half again:
    // it continues each pixel's stream where its last pass in that half stopped.
    film.run_pass(4, |x, y, sink| {
        for _ in 0..4 {
            sink.add(axis.bin_center_s(1), (y * 3 + x + 1) as f64, 1);
        }
    });
    let seen = std::sync::Mutex::new(Vec::new());
    film.run_pass_planned(2, Some(&[2, 2, 1, 1, 0, 9]), |x, y, pass, sink| {
        seen.lock().unwrap().push((y * 3 + x, pass));
        for _ in 0..pass.samples {
            sink.add(axis.bin_center_s(1), (y * 3 + x + 1) as f64, 1);
        }
        0
    });
    let mut seen = seen.into_inner().unwrap();
    seen.sort_by_key(|s| s.0);
    let want = [
        (0, 1, 2),
        (1, 2, 2),
        (2, 3, 1),
        (3, 5, 1),
        (4, 8, 1),
        (5, 13, 9),
    ];
    for ((i, pass), (j, first, samples)) in seen.iter().zip(want) {
        assert_eq!(*i, j);
        // A plan's 0 is drawn as 1: every pixel draws in every pass.
        assert_eq!(*pass, PixelPass { first, samples }, "pixel {i}");
    }
    assert_eq!(film.spp(), 10);
    for y in 0..2 {
        for x in 0..3 {
            let tprf = film.pixel_tprf(x, y);
            let want = (y * 3 + x + 1) as f64;
            assert!((tprf[1] - want).abs() < 1e-12 * want, "{x} {y}: {tprf:?}");
            assert_eq!(tprf[0] + tprf[2] + tprf[3], 0.0);
        }
    }
    let drawn: Vec<[u32; 2]> = film.pixel_samples().map(|s| s.drawn).collect();
    assert_eq!(drawn[0], [3, 4]);
    assert_eq!(drawn[5], [22, 4]);
}

/// Pixel `p` of the test below: noisy (its light comes rarely and strong) in the left
/// half of the image, steady in the right; the mean is 1 everywhere.
fn is_noisy(p: usize, width: usize) -> bool {
    p % width < width / 2
}

/// Chance of a noisy pixel's sample bringing light (and then 1 / P).
const P: f64 = 0.05;

#[test]
fn the_plan_follows_the_noise_and_the_means_stay_unbiased() {
    let (w, h, bins) = (64, 32, 8);
    let (mut film, axis) = film(w, h, bins);
    let mut pass = 0u64;
    while film.spp() < 512 {
        let spp = doubling_spp(pass, 64);
        let plan = adaptive::plan(&film, spp);
        let half = pass % 2;
        film.run_pass_planned(spp, plan.as_deref(), |x, y, px, sink| {
            let p = y * w + x;
            for i in px.first..px.first + px.samples {
                let key = ((p as u64) << 34) ^ (half << 33) ^ i as u64;
                let u = uniform(key);
                if !is_noisy(p, w) {
                    sink.add(axis.bin_center_s(2), 1.0, 1);
                } else if u < P {
                    // The bin is random too: the noise is in the cube's bins, not
                    // only in the pixel's sum.
                    let b = 2 + (uniform(!key) * 4.0) as usize;
                    sink.add(axis.bin_center_s(b), 1.0 / P, 1);
                }
            }
            // A noisy pixel's sample costs 4 rays, a steady one's 1.
            let rays = if is_noisy(p, w) { 4 } else { 1 };
            rays * px.samples as u64
        });
        pass += 1;
    }
    let steady = film.steady();
    let drawn: Vec<u64> = film
        .pixel_samples()
        .map(|s| s.drawn.iter().map(|&d| d as u64).sum())
        .collect();
    // Unbiased: the average of the noisy pixels' means is within 4 standard errors of
    // 1. Each mean's variance is (1 / P - 1) / n for n samples (n counted per pixel: the
    // weights of its passes are nearly equal).
    let noisy: Vec<usize> = (0..w * h).filter(|&p| is_noisy(p, w)).collect();
    let mean = noisy.iter().map(|&p| steady[p]).sum::<f64>() / noisy.len() as f64;
    let var: f64 = noisy
        .iter()
        .map(|&p| (1.0 / P - 1.0) / drawn[p] as f64)
        .sum::<f64>()
        / (noisy.len() as f64).powi(2);
    assert!(
        (mean - 1.0).abs() < 4.0 * var.sqrt(),
        "mean {mean}, standard error {}",
        var.sqrt()
    );
    // The steady pixels are exact whatever they drew.
    for p in (0..w * h).filter(|&p| !is_noisy(p, w)) {
        assert!((steady[p] - 1.0).abs() < 1e-12, "pixel {p}: {}", steady[p]);
    }
    // The samples went to the noise: a steady pixel has no variance, so away from the
    // noisy half (beyond the 3 x 3 neighbourhood) it draws only the uniform share.
    let total: u64 = drawn.iter().sum();
    let noisy_share = noisy.iter().map(|&p| drawn[p]).sum::<u64>() as f64 / total as f64;
    assert!(
        noisy_share > 0.8,
        "noisy pixels drew {noisy_share} of the samples"
    );
    let far_steady = (0..w * h).filter(|&p| p % w >= w / 2 + 2);
    let uniform_spp = film.spp() as f64;
    for p in far_steady {
        let ratio = drawn[p] as f64 / uniform_spp;
        assert!(ratio < 0.2, "steady pixel {p} drew {ratio} of uniform");
    }
}

/// A film of `w x h` pixels after 4 uniform passes of 8 samples whose two halves differ
/// by exactly `2 a(p)` in pixel `p`'s one bin (half 0 holds `1 + a`, half 1 `1 - a`), one
/// ray per sample: the noise the plan estimates is known by hand.
fn film_with_half_differences(w: usize, h: usize, a: impl Fn(usize) -> f64 + Sync) -> TprfFilm {
    let (mut film, axis) = film(w, h, 4);
    for pass in 0..4 {
        let sign = if pass % 2 == 0 { 1.0 } else { -1.0 };
        film.run_pass_planned(8, None, |x, y, px, sink| {
            for _ in 0..px.samples {
                sink.add(axis.bin_center_s(1), 1.0 + sign * a(y * w + x), 1);
            }
            px.samples as u64
        });
    }
    film
}

#[test]
fn a_plan_is_made_only_where_it_pays_and_in_proportion_to_the_noise() {
    let (w, h) = (16, 8);
    // The same noise everywhere: the predicted gain is exactly 1, no plan.
    let even = film_with_half_differences(w, h, |_| 0.1);
    assert_eq!(adaptive::plan(&even, 16), None);
    // Noise 4x larger (variance 16x) in the left half, columns 0-7. A pixel's variance
    // is the larger of its own and its 3 x 3 neighbourhood's mean, which changes only
    // column 8: (3 x 16 + 6 x 1) / 9 = 6 (in units of the right half's). So s is 4 in
    // columns 0-7, sqrt(6) = 2.449 in column 8 and 1 in 9-15; mean(s) = (8 x 4 + 2.449 +
    // 7) / 16 = 2.5906, mean(s^2) = (8 x 16 + 6 + 7) / 16 = 8.8125, and the predicted
    // gain 8.8125 / 2.5906^2 = 1.31, over the 1.2 a plan needs. A pixel's share of the
    // pass is 0.9 s / mean(s) + 0.1: 1.4897 (23.8 of 16 samples) on the left, 0.9509
    // (15.2) in column 8, 0.4474 (7.2) on the right, rounded with the remainder carried.
    let uneven = film_with_half_differences(w, h, |p| if p % w < w / 2 { 0.4 } else { 0.1 });
    let plan = adaptive::plan(&uneven, 16).expect("a plan");
    for (p, &n) in plan.iter().enumerate() {
        let want = match p % w {
            0..=7 => 23..=24,
            8 => 15..=16,
            _ => 7..=8,
        };
        assert!(want.contains(&n), "pixel {p}: {n}, want {want:?}");
    }
    // The shares add up to the pass: 16 per pixel.
    let total: u32 = plan.iter().sum();
    assert!(total.abs_diff(16 * (w * h) as u32) <= 1, "{total}");
}

//! The sparse TPRF store against a dense accumulation written here, independently: the
//! same contributions (a fixed pseudo-random list per pass and pixel) summed into plain
//! `[half][pixel][bin]` and `[layer][pixel][bin]` arrays. Each pass's contributions are
//! summed first and then added to the running sums, in the film's order, so the
//! comparison is exact.

use tprf_core::film::{FilmLayout, TimeAxis, TimeFilter, TprfFilm};

const W: usize = 7;
const H: usize = 5;
const T: usize = 64;
const K: u32 = 2; // per-bounce layers 0, 1, 2, >2

/// xorshift64*: a generator that owes nothing to the code under test.
fn rng(seed: u64) -> impl FnMut() -> u64 {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    move || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        s.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
}

/// The contributions of pixel `(x, y)` in pass `pass`: (arrival bin, value, scatterings).
/// A dark pixel now and then, runs of bins and lone bins, some in the same bin twice.
fn contributions(pass: u64, x: usize, y: usize) -> Vec<(usize, f64, u32)> {
    let mut r = rng(pass * 1000 + (y * W + x) as u64 + 1);
    if (x + y).is_multiple_of(5) {
        return Vec::new();
    }
    let n = (r() % 12) as usize;
    (0..n)
        .map(|_| {
            let b = if r().is_multiple_of(3) {
                (r() % T as u64) as usize
            } else {
                10 + (x + pass as usize) % 7 + (r() % 4) as usize
            };
            let v = (r() % 1000) as f64 / 7.0 + 0.5;
            (b, v, (r() % 5) as u32)
        })
        .collect()
}

#[test]
fn the_sparse_store_equals_a_dense_accumulation() {
    let axis = TimeAxis::new(2e-9, 1e-10, T).unwrap();
    let layout = FilmLayout {
        width: W,
        height: H,
        axis,
        bounces_separate: K,
        luminescence: false,
    };
    let layers = layout.bounce_layers();
    let mut film = TprfFilm::new(layout).unwrap();
    let mut halves = vec![vec![0.0f64; W * H * T]; 2];
    let mut bounce = vec![0.0f64; layers * W * H * T];
    let mut spp = [0u64; 2];
    for pass in 0..9u64 {
        let spp_in_pass = 1 + pass % 3;
        film.run_pass(spp_in_pass, |x, y, sink| {
            for (b, v, s) in contributions(pass, x, y) {
                sink.add(axis.bin_center_s(b), v, s);
            }
        });
        let half = (pass % 2) as usize;
        spp[half] += spp_in_pass;
        for y in 0..H {
            for x in 0..W {
                let p = y * W + x;
                let mut sum = vec![0.0f64; T];
                let mut lsum = vec![0.0f64; layers * T];
                for (b, v, s) in contributions(pass, x, y) {
                    sum[b] += v;
                    lsum[(s.min(K + 1) as usize) * T + b] += v;
                }
                for b in 0..T {
                    halves[half][p * T + b] += sum[b];
                    for l in 0..layers {
                        bounce[(l * W * H + p) * T + b] += lsum[l * T + b];
                    }
                }
            }
        }
    }
    let n = (spp[0] + spp[1]) as f64;
    assert_eq!(film.spp(), spp[0] + spp[1]);
    let snap = film.snapshot();
    let mut nonzero = 0u64;
    let mut diff2 = 0.0;
    let mut norm2 = 0.0;
    let (na, nb) = (spp[0] as f64, spp[1] as f64);
    for y in 0..H {
        for x in 0..W {
            let p = y * W + x;
            let want: Vec<f64> = (0..T)
                .map(|b| (halves[0][p * T + b] + halves[1][p * T + b]) / n)
                .collect();
            assert_eq!(film.pixel_tprf(x, y), want, "pixel ({x}, {y})");
            let want32: Vec<f32> = want.iter().map(|v| *v as f32).collect();
            assert_eq!(snap.pixel(x, y), want32);
            let lit: Vec<usize> = (0..T).filter(|&b| want[b] != 0.0).collect();
            nonzero += lit.len() as u64;
            assert_eq!(snap.pixel_stored_bins(x, y), lit.len());
            assert_eq!(
                snap.pixel_span(x, y),
                lit.first().map(|&f| (f, *lit.last().unwrap()))
            );
            // The runs cover exactly the lit bins.
            let mut seen = Vec::new();
            snap.for_each_run(x, y, |start, run| {
                for (i, v) in run.iter().enumerate() {
                    assert_eq!(*v, want32[start + i]);
                    seen.push(start + i);
                }
            });
            assert_eq!(seen, lit);
            let steady: f64 = want.iter().sum();
            assert!((film.steady()[p] - steady).abs() <= 1e-12 * steady.abs());
            for l in 0..layers {
                let want_l: Vec<f64> = (0..T)
                    .map(|b| bounce[(l * W * H + p) * T + b] / n)
                    .collect();
                assert_eq!(film.pixel_bounces(x, y)[l], want_l, "layer {l} ({x}, {y})");
            }
            for b in 0..T {
                let (a, c) = (halves[0][p * T + b], halves[1][p * T + b]);
                diff2 += (a / na - c / nb).powi(2);
                norm2 += ((a + c) / n).powi(2);
            }
        }
    }
    // Time slices.
    for b in [0, 11, 13, T - 1] {
        let want: Vec<f32> = (0..W * H)
            .map(|p| ((halves[0][p * T + b] + halves[1][p * T + b]) / n) as f32)
            .collect();
        assert_eq!(snap.slice(b), want);
    }
    // The two-half error estimate, as its formula says.
    let want_err = diff2.sqrt() * (na * nb).sqrt() / n / norm2.sqrt();
    let got_err = film.half_error_estimate().unwrap();
    assert!(
        (got_err - want_err).abs() <= 1e-9 * want_err,
        "{got_err} vs {want_err}"
    );
    // Memory follows the lit bins: at most a value (two f64) and a 4-byte run header per
    // stored bin, plus per-pixel bookkeeping (the layers' directories included).
    let stats = film.store_stats();
    assert_eq!(stats.stored_bins, nonzero);
    assert_eq!(stats.dense_bins, (W * H * T) as u64);
    let per_bin = 16 + 4 + layers as u64 * (8 + 4);
    assert!(
        stats.bytes <= nonzero * per_bin + (W * H) as u64 * (28 + 16 * layers as u64) + 1024,
        "{} bytes for {nonzero} bins",
        stats.bytes
    );
}

#[test]
fn the_tent_filter_splits_between_bin_centres_in_the_sparse_store() {
    let axis = TimeAxis::new(0.0, 1.0, 8).unwrap();
    let layout = FilmLayout {
        width: 1,
        height: 1,
        axis,
        bounces_separate: 0,
        luminescence: false,
    };
    let mut film = TprfFilm::new(layout)
        .unwrap()
        .with_time_filter(TimeFilter::Tent);
    film.run_pass(1, |_, _, sink| {
        sink.add(2.5, 1.0, 1); // centre of bin 2
        sink.add(4.75, 2.0, 1); // 1/4 of the way from centre 4 to centre 5
    });
    let t = film.pixel_tprf(0, 0);
    assert_eq!(t, vec![0.0, 0.0, 1.0, 0.0, 1.5, 0.5, 0.0, 0.0]);
    assert_eq!(film.store_stats().stored_bins, 3);
}

#[test]
fn a_pass_after_a_snapshot_leaves_the_snapshot_as_it_was() {
    let axis = TimeAxis::new(0.0, 1.0, 4).unwrap();
    let layout = FilmLayout {
        width: 2,
        height: 2,
        axis,
        bounces_separate: 0,
        luminescence: false,
    };
    let mut film = TprfFilm::new(layout).unwrap();
    film.run_pass(1, |x, _, sink| sink.add(0.5 + x as f64, 1.0, 1));
    let before = film.snapshot();
    film.run_pass(1, |_, _, sink| sink.add(3.5, 4.0, 1));
    assert_eq!(before.pixel(1, 0), vec![0.0, 1.0, 0.0, 0.0]);
    assert_eq!(film.snapshot().pixel(1, 0), vec![0.0, 0.5, 0.0, 2.0]);
    assert_ne!(before.generation(), film.snapshot().generation());
}

/// With and without bounce layers: non-finite values and arrival times are counted,
/// never stored; a finite arrival outside the window is light outside, not an error.
#[test]
fn non_finite_contributions_are_counted_and_kept_out() {
    for bounces_separate in [0, 1] {
        let axis = TimeAxis::new(0.0, 1.0, 4).unwrap();
        let layout = FilmLayout {
            width: 2,
            height: 1,
            axis,
            bounces_separate,
            luminescence: false,
        };
        let mut film = TprfFilm::new(layout).unwrap();
        let tally = film.run_pass(1, |x, _, sink| {
            sink.add(0.5, 1.0, 0);
            if x == 1 {
                sink.add(1.5, f64::INFINITY, 1);
                sink.add(2.5, f64::NAN, 1);
                sink.add(f64::NAN, 1.0, 1);
                sink.add(f64::INFINITY, 1.0, 1);
                sink.add(7.5, 2.0, 1);
            }
        });
        assert_eq!(tally.left_out.non_finite, 4, "{bounces_separate} layers");
        // Pixel 1's 2.0 after the window, over the image's 2 pixels.
        assert_eq!(tally.outside_per_pixel, 1.0, "{bounces_separate} layers");
        assert_eq!(film.pixel_tprf(1, 0), vec![1.0, 0.0, 0.0, 0.0]);
        assert!(film.half_error_estimate().is_none());
        assert!(film.steady().iter().all(|v| v.is_finite()));
    }
}

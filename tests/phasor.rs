//! Phasors (mitransient's `phasor_hdr_film`) computed from the film, against answers
//! worked out here without the code under test:
//!
//! - a return spread evenly over a known span, and a return at one known time: their
//!   Fourier coefficients in closed form (`w e^(-2 pi i f (centre - opl0)) sinc(f span)`
//!   and `w e^(-2 pi i f (x - opl0))`);
//! - every pixel of the lit plane (one scattering event): its coefficient integrated over
//!   the pixel's footprint on the ground, against the phasors of the reference's exact
//!   bins;
//! - a render's `phasor.npy` against a direct DFT of its own `tprf.npy`, summed here bin
//!   by bin (`sum_b cube[b] e^(-2 pi i k b / T)`), times the documented bin factor
//!   `e^(-i pi k / T) sinc(k / T)`; and its `phasor.json` against mitransient's formula;
//! - mitransient's example file (`cbox_diffuse_freq.xml`): the band and bins it sets and
//!   the 41 frequencies worked out by hand (wl_mean 100, wl_sigma 100, 4000 bins of 1 m:
//!   indices 20 ..= 60 of fftfreq(4000, 1)).

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::Command;
use tprf_core::export::phasor::{self, PhasorBand, PhasorMetadata, phasors};
use tprf_core::export::read_npy_f32;
use tprf_core::film::{FilmLayout, FilmSnapshot, TimeAxis, TimeFilter};
use tprf_core::reference::plane::Plane;
use tprf_core::units::C_M_PER_S;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn tempdir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("phasor-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn snapshot(w: usize, h: usize, axis: TimeAxis, cube: &[f32]) -> FilmSnapshot {
    let layout = FilmLayout {
        width: w,
        height: h,
        axis,
        bounces_separate: 0,
        luminescence: false,
    };
    FilmSnapshot::from_dense(layout, 1, 1, cube, &[], None)
}

/// `e^(-2 pi i turns)` as `[re, im]`.
fn cis(turns: f64) -> [f64; 2] {
    let a = -2.0 * PI * turns;
    [a.cos(), a.sin()]
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn sinc(u: f64) -> f64 {
    if u == 0.0 {
        1.0
    } else {
        (PI * u).sin() / (PI * u)
    }
}

/// A return of weight w spread evenly over one whole bin has the coefficient
/// `(w / dt) integral over the bin of e^(-2 pi i f (x - opl0)) dx`, which is
/// `w e^(-2 pi i f (c - opl0)) sinc(f dt)` (c the bin's centre): the film's phasor
/// equals it. A return at one time x inside the bin is `w e^(-2 pi i f (x - opl0))`:
/// the film's phasor is within `w max |sinc(f dt) - e^(-2 pi i f u)|` (|u| <= dt / 2)
/// of it, about `pi f dt w`.
#[test]
fn a_single_return_is_its_fourier_coefficient() {
    // 200 bins of 0.5 m from 3 m of optical path.
    let (t0_m, dt_m, bins) = (3.0, 0.5, 200);
    let axis = TimeAxis::new(t0_m / C_M_PER_S, dt_m / C_M_PER_S, bins).unwrap();
    let (k, w) = (37usize, 2.5f64);
    let mut cube = vec![0.0f32; bins];
    cube[k] = w as f32;
    let snap = snapshot(1, 1, axis, &cube);
    // 100 bins of 0.5 m hold wavelengths of 1 m .. 100 m: a band around 10 m.
    let band = PhasorBand {
        wl_mean_m: 10.0,
        wl_sigma_m: 2.0,
    };
    let meta = PhasorMetadata::new(band, axis.t0_s, axis.dt_s, bins, TimeFilter::Box).unwrap();
    let freqs = &meta.frequencies_per_m;
    assert!(freqs.len() > 5);
    let p = phasors(&snap, freqs, TimeFilter::Box).unwrap();
    let centre_m = (k as f64 + 0.5) * dt_m; // from the window's start
    let mut worst_delta = 0.0f64;
    for (j, &f) in freqs.iter().enumerate() {
        let got = [f64::from(p[2 * j]), f64::from(p[2 * j + 1])];
        let spread = cis(f * centre_m).map(|c| w * c * sinc(f * dt_m));
        assert!(
            dist(got, spread) <= 1e-6 * w,
            "f {f}: {got:?} against {spread:?}"
        );
        // At a known time inside the bin, a quarter bin past its centre.
        let x = centre_m + 0.25 * dt_m;
        let exact = cis(f * x).map(|c| w * c);
        let bound = (0..=100)
            .map(|i| {
                let u = (i as f64 / 100.0 - 0.5) * dt_m;
                dist([sinc(f * dt_m), 0.0], cis(f * u))
            })
            .fold(0.0, f64::max)
            * w;
        let d = dist(got, exact);
        assert!(d <= bound * (1.0 + 1e-9), "f {f}: {d} > {bound}");
        worst_delta = worst_delta.max(d / w);
    }
    eprintln!(
        "a return a quarter bin off the centre: phasor off by at most {worst_delta:.3e} of its weight \
         (f dt up to {:.3})",
        freqs.last().unwrap() * dt_m
    );
}

/// The lit plane (one scattering event per path): each pixel's light arrives over its
/// footprint on the ground, at `t(q)` with radiance `L(q)` (DESIGN.md, `reference::plane`).
/// Its Fourier coefficient `(1 / A) integral over the footprint of L(q) e^(-2 pi i f (c
/// t(q) - opl0)) dA` is integrated here (in rings, as the reference integrates its bins);
/// the phasors of the reference's exact bins equal it within the bin bound, and within
/// `(pi f dt)^2 / 3` of the pixel's light where its return spans several bins.
#[test]
fn the_lit_planes_phasors_are_its_fourier_coefficients() {
    let plane = Plane::default();
    let (w, h, bins) = (6, 6, 48);
    let axis = plane.default_axis(w, h, bins).unwrap();
    let dt_m = axis.dt_s * C_M_PER_S;
    let opl0 = axis.t0_s * C_M_PER_S;
    let mut cube = Vec::with_capacity(w * h * bins);
    for y in 0..h {
        for x in 0..w {
            cube.extend(
                plane
                    .pixel_tprf(x, y, w, h, &axis)
                    .into_iter()
                    .map(|v| v as f32),
            );
        }
    }
    let snap = snapshot(w, h, axis, &cube);
    // Wavelengths of about 8 bins: f dt up to ~0.2.
    let band = PhasorBand {
        wl_mean_m: 8.0 * dt_m,
        wl_sigma_m: 8.0 * dt_m,
    };
    let meta = PhasorMetadata::new(band, axis.t0_s, axis.dt_s, bins, TimeFilter::Box).unwrap();
    let freqs = &meta.frequencies_per_m;
    let nf = freqs.len();
    let p = phasors(&snap, freqs, TimeFilter::Box).unwrap();
    let mut worst_rel = 0.0f64;
    for y in 0..h {
        for x in 0..w {
            let rect = plane.footprint(x as f64, x as f64 + 1.0, y as f64, y as f64 + 1.0, w, h);
            let (q_lo, q_hi) = rect.radial_range();
            let px = &cube[(y * w + x) * bins..(y * w + x + 1) * bins];
            let light: f64 = px.iter().map(|&v| f64::from(v)).sum();
            let spanned = px.iter().filter(|&&v| f64::from(v) > 1e-3 * light).count();
            for (j, &f) in freqs.iter().enumerate() {
                // The coefficient over the footprint, in 64 rings.
                let part = |re: bool| {
                    (0..64)
                        .map(|i| {
                            let a = q_lo + (q_hi - q_lo) * i as f64 / 64.0;
                            let b = q_lo + (q_hi - q_lo) * (i + 1) as f64 / 64.0;
                            rect.radial_integral(a, b, |q| {
                                let [c, s] = cis(f * (plane.arrival_s(q) * C_M_PER_S - opl0));
                                plane.radiance(q) * if re { c } else { s }
                            })
                        })
                        .sum::<f64>()
                        / rect.area()
                };
                let exact = [part(true), part(false)];
                let i = ((y * w + x) * nf + j) * 2;
                let got = [f64::from(p[i]), f64::from(p[i + 1])];
                let bound = (PI * f * dt_m) * light;
                let d = dist(got, exact);
                assert!(
                    d <= bound + 1e-6 * light,
                    "pixel ({x}, {y}), f {f}: off by {d}, bound {bound}"
                );
                if spanned >= 4 {
                    let tight = (PI * f * dt_m).powi(2) / 3.0;
                    assert!(
                        d <= tight * light + 1e-6 * light,
                        "pixel ({x}, {y}) over {spanned} bins, f dt {}: off by {:.3e} of its light, \
                         more than (pi f dt)^2 / 3 = {tight:.3e}",
                        f * dt_m,
                        d / light
                    );
                }
                worst_rel = worst_rel.max(d / light);
            }
        }
    }
    eprintln!(
        "lit plane: phasors from the exact bins off the footprint integral by at most {worst_rel:.3e} \
         of the pixel's light (f dt up to {:.3})",
        freqs.last().unwrap() * dt_m
    );
}

fn tprf(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(args)
        .output()
        .expect("run tprf")
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// A render's phasor.npy is a direct DFT of its own tprf.npy at mitransient's indices:
/// `P[k] = e^(-i pi k / T) sinc(k / T) sum_b cube[b] e^(-2 pi i k b / T)` (the phase at
/// bin b's centre, (b + 1/2) dt, is 2 pi k (b + 1/2) / T; sinc the box bin's factor; k
/// signed as numpy's fftfreq gives it);
/// phasor.json lists `k / (T dt)` per metre, times c in Hz, and their wavelengths.
#[test]
fn a_renders_phasors_are_the_dft_of_its_cube() {
    let dir = tempdir("dft");
    let out = dir.join("out");
    let (w, h, bins) = (6usize, 5usize, 64usize);
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        out.to_str().unwrap(),
        "--width",
        &w.to_string(),
        "--height",
        &h.to_string(),
        "--bins",
        &bins.to_string(),
        "--spp",
        "4",
        "--phasor",
        "1.5m:0.2",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, cube) = read_npy_f32(&out.join("tprf.npy")).unwrap();
    let (shape, p) = read_npy_f32(&out.join("phasor.npy")).unwrap();
    let pj = json(&out.join("phasor.json"));
    let tj = json(&out.join("tprf.json"));
    assert_eq!(tj["phasor"], pj, "tprf.json's phasor entry is phasor.json");
    let dt_m = tj["dt_s"].as_f64().unwrap() * C_M_PER_S;
    // mitransient's indices by its formula, written out here.
    let span = bins as f64 * dt_m;
    let (mean_idx, sigma_idx) = (span / 1.5, span / (6.0 * 0.2));
    let lo = ((mean_idx - 3.0 * sigma_idx).floor().max(0.0)) as usize;
    let hi = ((mean_idx + 3.0 * sigma_idx).ceil() as usize).min(bins / 2);
    let ks: Vec<usize> = (lo..=hi).collect();
    assert_eq!(shape, vec![h as u64, w as u64, ks.len() as u64, 2]);
    assert_eq!(pj["fft_index_first"], lo);
    assert_eq!(pj["fft_index_last"], hi);
    let freq = |key: &str| -> Vec<f64> {
        pj[key]
            .as_array()
            .unwrap()
            .iter()
            // The DC term's wavelength is null.
            .map(|v| v.as_f64().unwrap_or(f64::INFINITY))
            .collect()
    };
    let (per_m, hz, wl) = (
        freq("frequencies_per_m"),
        freq("frequencies_hz"),
        freq("wavelengths_m"),
    );
    // numpy's fftfreq: index k is k / (T dt) below ceil(T / 2), (k - T) / (T dt) from
    // there (an even T's index T / 2 is the negative Nyquist frequency).
    let signed = |k: usize| -> f64 {
        if k < bins.div_ceil(2) {
            k as f64
        } else {
            k as f64 - bins as f64
        }
    };
    for (j, &k) in ks.iter().enumerate() {
        let f = signed(k) / (bins as f64 * dt_m);
        assert!((per_m[j] - f).abs() <= 1e-12 * f.abs().max(1e-12));
        assert!((hz[j] - f * C_M_PER_S).abs() <= 1e-9 * hz[j].abs());
        if f != 0.0 {
            assert!((wl[j] - 1.0 / f.abs()).abs() <= 1e-9 * wl[j]);
        }
    }
    let mut largest = 0.0f64;
    for px in 0..w * h {
        let tprf_px = &cube[px * bins..(px + 1) * bins];
        let light: f64 = tprf_px.iter().map(|&v| f64::from(v)).sum();
        largest = largest.max(light);
        for (j, &k) in ks.iter().enumerate() {
            let (mut re, mut im) = (0.0, 0.0);
            for (b, &v) in tprf_px.iter().enumerate() {
                let a = 2.0 * PI * (k * b) as f64 / bins as f64;
                re += f64::from(v) * a.cos();
                im -= f64::from(v) * a.sin();
            }
            // The half-bin phase and the bin factor of the signed index.
            let [c, s] = cis(signed(k) / (2.0 * bins as f64));
            let g = sinc(signed(k) / bins as f64);
            let want = [g * (re * c - im * s), g * (re * s + im * c)];
            let i = (px * ks.len() + j) * 2;
            let got = [f64::from(p[i]), f64::from(p[i + 1])];
            assert!(
                dist(got, want) <= 1e-5 * light.max(1e-30),
                "pixel {px}, k {k}: {got:?} against the DFT's {want:?}"
            );
        }
    }
    assert!(largest > 0.0, "the render holds light");
}

/// mitransient's example file: its film's band and bins, and the frequencies by hand;
/// rendered small, it writes phasor.npy with those 41 frequencies and says where the
/// band came from.
#[test]
fn the_example_files_band_and_frequencies() {
    let xml = repo().join("assets/mitsuba/mitransient/cornell-box/cbox_diffuse_freq.xml");
    let s = tprf_core::scene::file_settings(xml.to_str().unwrap()).unwrap();
    assert_eq!(s.phasor_wl_mean_m.as_ref().map(|v| v.value), Some(100.0));
    assert_eq!(s.phasor_wl_sigma_m.as_ref().map(|v| v.value), Some(100.0));
    assert_eq!(s.bins.as_ref().map(|v| v.value), Some(4000));
    assert_eq!(s.dt_opl_m.as_ref().map(|v| v.value), Some(1.0));
    // mean_idx = 4000 * 1 / 100 = 40, sigma_idx = 4000 / 600: floor(20) ..= ceil(60).
    let dir = tempdir("example");
    let out = dir.join("out");
    let o = tprf(&[
        "render",
        xml.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--width",
        "4",
        "--height",
        "4",
        "--spp",
        "2",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("from the scene file: --phasor 100:100"),
        "says where the band came from: {err}"
    );
    let pj = json(&out.join("phasor.json"));
    assert_eq!(
        (
            pj["fft_index_first"].as_u64(),
            pj["fft_index_last"].as_u64()
        ),
        (Some(20), Some(60))
    );
    let f = pj["frequencies_per_m"].as_array().unwrap();
    assert_eq!(f.len(), 41);
    for (j, v) in f.iter().enumerate() {
        assert!((v.as_f64().unwrap() - (20 + j) as f64 / 4000.0).abs() < 1e-15);
    }
    assert_eq!(pj["wavelengths_m"][20].as_f64(), Some(100.0));
    let (shape, _) = read_npy_f32(&out.join("phasor.npy")).unwrap();
    assert_eq!(shape, vec![4, 4, 41, 2]);
}

/// A band with no frequency on the window, and a malformed one, are refused naming the
/// option.
#[test]
fn bad_bands_are_refused_by_name() {
    let dir = tempdir("bad");
    let out = dir.join("out");
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        out.to_str().unwrap(),
        "--bins",
        "16",
        "--dt",
        "1m",
        "--phasor",
        "0.5:100",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--phasor") && err.contains("wl_mean 0.5 m"),
        "{err}"
    );
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        out.to_str().unwrap(),
        "--phasor",
        "100",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("WL_MEAN:WL_SIGMA"), "{err}");
    assert!(!out.exists(), "nothing written");
}

/// numpy's fftfreq for n = 8 and 7, d = 0.5 (from numpy's documentation's rule).
#[test]
fn fftfreq_is_numpys() {
    let even: Vec<f64> = (0..8).map(|k| phasor::fftfreq(8, 0.5, k)).collect();
    assert_eq!(even, [0.0, 0.25, 0.5, 0.75, -1.0, -0.75, -0.5, -0.25]);
    let odd: Vec<f64> = (0..7).map(|k| phasor::fftfreq(7, 0.5, k)).collect();
    let want = [0.0, 1.0, 2.0, 3.0, -3.0, -2.0, -1.0].map(|v| v / 3.5);
    assert_eq!(odd, want);
}

/// mitransient's example (`cbox_diffuse_freq.xml`: wl_mean 100, wl_sigma 100, 4000
/// bins of 1 m) by hand: mean_idx = 4000 / 100 = 40, sigma_idx = 4000 / 600 =
/// 6.667, indices floor(40 - 20) = 20 ..= ceil(60) = 60: 41 frequencies k / 4000 per
/// metre, 0.005 to 0.015 (wavelengths 200 m to 66.7 m).
#[test]
fn the_examples_frequencies_by_hand() {
    let band = PhasorBand {
        wl_mean_m: 100.0,
        wl_sigma_m: 100.0,
    };
    assert_eq!(band.index_range(4000, 1.0), Ok((20, 60)));
    let f = band.frequencies_per_m(4000, 1.0).unwrap();
    assert_eq!(f.len(), 41);
    assert_eq!(f[0], 0.005);
    assert_eq!(f[40], 0.015);
    assert_eq!(f[20], 0.01);
    // The defaults (wl_sigma 1000) on 4096 bins of 3 mm: mean_idx 0.12288,
    // sigma_idx 0.0020480: floor(0.11674) = 0 ..= ceil(0.12902) = 1.
    let d = PhasorBand::default();
    assert_eq!(d.index_range(4096, 0.003), Ok((0, 1)));
    // Clamped at nt / 2: wl_mean of 2 bins, wide band.
    let nyquist = PhasorBand {
        wl_mean_m: 2.0,
        wl_sigma_m: 0.5,
    };
    assert_eq!(nyquist.index_range(10, 1.0), Ok((0, 5)));
    assert_eq!(phasor::fftfreq(10, 1.0, 5), -0.5);
    let too_short = PhasorBand {
        wl_mean_m: 0.1,
        wl_sigma_m: 1000.0,
    };
    let e = too_short.index_range(100, 1.0).unwrap_err();
    assert!(e.contains("wl_mean 0.1 m"), "{e}");
}

#[test]
fn bands_read_and_print() {
    let b: PhasorBand = "100:100".parse().unwrap();
    assert_eq!((b.wl_mean_m, b.wl_sigma_m), (100.0, 100.0));
    let b: PhasorBand = " 2.5m : 1e3 m".parse().unwrap();
    assert_eq!((b.wl_mean_m, b.wl_sigma_m), (2.5, 1000.0));
    assert_eq!(b.to_string().parse::<PhasorBand>(), Ok(b));
    assert!(
        "100"
            .parse::<PhasorBand>()
            .unwrap_err()
            .contains("WL_MEAN:WL_SIGMA")
    );
    assert!(
        "-1:3"
            .parse::<PhasorBand>()
            .unwrap_err()
            .contains("wl_mean -1")
    );
    assert!("1:x".parse::<PhasorBand>().unwrap_err().contains("'x'"));
}

#[test]
fn the_modules_sinc_is_sin_pi_u_over_pi_u() {
    assert_eq!(phasor::sinc(0.0), 1.0);
    assert!(phasor::sinc(1.0).abs() < 1e-15);
    assert!((phasor::sinc(0.5) - 2.0 / std::f64::consts::PI).abs() < 1e-15);
    // (pi f dt)^2 / 6 at the example's highest frequency.
    assert!(((1.0 - phasor::sinc(0.015)) - 3.7e-4).abs() < 0.1e-4);
}

/// A Zarr cube holds its phasors as the array `phasor` of `tprf.zarr`: the same values
/// as the npy render's `phasor.npy` (same seed), read back by `load_phasors`.
#[test]
fn a_zarr_cubes_phasors_equal_the_npy_cubes() {
    let dir = tempdir("zarr");
    let mut read = Vec::new();
    for format in ["npy", "zarr"] {
        let out = dir.join(format);
        let o = tprf(&[
            "render",
            "builtin:cornell",
            "--out",
            out.to_str().unwrap(),
            "--width",
            "8",
            "--height",
            "6",
            "--bins",
            "32",
            "--spp",
            "2",
            "--format",
            format,
            "--phasor",
            "1:0.2",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (meta, data) = phasor::load_phasors(&out, 8, 6).unwrap().expect("phasors");
        read.push((meta, data));
    }
    assert_eq!(read[1].0.file, "tprf.zarr/phasor");
    assert_eq!(read[0].0.frequencies_per_m, read[1].0.frequencies_per_m);
    assert_eq!(read[0].1, read[1].1);
    assert!(read[0].1.iter().any(|&v| v != 0.0));
    assert!(!dir.join("zarr").join("phasor.npy").exists());
}

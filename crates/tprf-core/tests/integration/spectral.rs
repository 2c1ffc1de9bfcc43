//! Several bands in one render (issue 47 part 2, step 3): `tprf_spectral.npy`'s band k
//! is the single-band render at the k-th wavelength with the same seed and window, bit
//! for bit; a BK7 slab's bands arrive at their group delays (N-BK7's Sellmeier formula
//! written out in `dispersion`) in one file; `tprf.npy` is the bands' luminance by the
//! trapezoid weights computed here from CIE `ybar`, a grey scene's equal to each band;
//! bad requests refused naming the field.

use super::dispersion::{bk7_glass, bk7_ng, emitter_below, quad};
use crate::common::*;
use std::path::{Path, PathBuf};
use tprf_core::export::{CubeMetadata, read_metadata, read_npy_f32};
use tprf_core::request::{Observer, RenderRequest, render, render_to_folder};
use tprf_core::scene::spectrum::Wavelength;
use tprf_core::scene::{Channel, Scene};

struct Quiet;
impl Observer for Quiet {}

/// A folder's metadata, `tprf.npy` and, for several bands, `tprf_spectral.npy`'s shape
/// and values.
type Folder = (CubeMetadata, Vec<f32>, Option<(Vec<u64>, Vec<f32>)>);

fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tprf-spectral-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn wl(nm: f64) -> Wavelength {
    Wavelength::from_nm(nm).unwrap()
}

/// Render `request` into `dir/name`: its metadata, `tprf.npy` and, for several bands,
/// `tprf_spectral.npy` (shape and values).
fn run(request: &RenderRequest, dir: &Path, name: &str) -> Folder {
    let out = dir.join(name);
    render_to_folder(request, &out, &mut Quiet).unwrap();
    let meta = read_metadata(&out.join("tprf.json")).unwrap();
    let (_, cube) = read_npy_f32(&out.join("tprf.npy")).unwrap();
    let spectral = out
        .join("tprf_spectral.npy")
        .exists()
        .then(|| read_npy_f32(&out.join("tprf_spectral.npy")).unwrap());
    (meta, cube, spectral)
}

/// The trapezoid weights of 450, 550, 650 nm by hand: intervals 50, 100, 50 nm.
fn weights_450_550_650() -> [f64; 3] {
    let raw = [
        wl(450.0).ybar() * 50.0,
        wl(550.0).ybar() * 100.0,
        wl(650.0).ybar() * 50.0,
    ];
    let sum: f64 = raw.iter().sum();
    raw.map(|v| v / sum)
}

fn save(scene: &Scene, dir: &Path) -> String {
    let path = dir.join("scene.gltf");
    tprf_core::scene::gltf_save::save_gltf(scene, &path).unwrap();
    path.display().to_string()
}

/// The Cornell box (red and green walls: bands differ) at 450, 550, 650 nm with an
/// automatic window: band k of `tprf_spectral.npy` is, bit for bit, the single-band
/// render at that wavelength with the same seed on the window `tprf.json` reports;
/// `tprf.npy` is `sum_k w_k band_k` with the trapezoid weights; with `channel 550nm` it
/// is that band, bit for bit.
#[test]
fn spectral_bands_are_the_single_band_renders() {
    let dir = tempdir("bands");
    let request = RenderRequest {
        width: 16,
        height: 16,
        bins: 48,
        spp: Some(4),
        seed: 3,
        wavelengths: vec![wl(450.0), wl(550.0), wl(650.0)],
        ..RenderRequest::new("builtin:cornell")
    };
    let (meta, lum, spectral) = run(&request, &dir, "all");
    let (shape, cube) = spectral.expect("tprf_spectral.npy");
    assert_eq!(shape, [3, 16, 16, 48]);
    let s = meta.spectral.as_ref().unwrap();
    assert_eq!(s.wavelengths_nm, [450.0, 550.0, 650.0]);
    assert_eq!(
        (meta.channel.as_str(), s.tprf_npy.as_str()),
        ("luminance", "luminance")
    );
    let plane = 16 * 16 * 48;
    for (k, nm) in [450.0, 550.0, 650.0].into_iter().enumerate() {
        let one = RenderRequest {
            channel: Channel::Wavelength(wl(nm)),
            wavelengths: Vec::new(),
            t0_s: Some(meta.t0_s),
            dt_s: Some(meta.dt_s),
            ..request.clone()
        };
        let (m, single, none) = run(&one, &dir, &format!("{nm}"));
        assert!(none.is_none() && m.spectral.is_none());
        let band = &cube[k * plane..(k + 1) * plane];
        assert!(band.iter().sum::<f32>() > 0.0, "{nm} nm: no light");
        assert!(
            band.iter()
                .zip(&single)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "band {k} ({nm} nm) differs from its single-band render"
        );
    }
    // The bands differ (the walls are coloured), so the weights are seen.
    assert_ne!(cube[..plane], cube[plane..2 * plane]);
    let w = weights_450_550_650();
    for (a, b) in s.luminance_weights.iter().zip(w) {
        assert!(
            (a - b).abs() < 1e-12,
            "{:?} against {w:?}",
            s.luminance_weights
        );
    }
    for (i, &v) in lum.iter().enumerate() {
        let want: f64 = (0..3).map(|k| w[k] * cube[k * plane + i] as f64).sum();
        assert!(
            (v as f64 - want).abs() <= 1e-6 * want.abs() + 1e-30,
            "voxel {i}: {v} against {want}"
        );
    }
    // tprf.npy as the band `channel` names.
    let green = RenderRequest {
        channel: Channel::Wavelength(wl(550.0)),
        ..request.clone()
    };
    let (m, band, _) = run(&green, &dir, "green");
    assert_eq!(m.spectral.unwrap().tprf_npy, "550nm");
    assert!(
        band.iter()
            .zip(&cube[plane..2 * plane])
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A 1 m slab of N-BK7 between the camera (z = 3) and an emitting floor, one pixel,
/// 400, 550 and 700 nm in one render on 1 ps bins: each band of the one file peaks at
/// `(2 + n_g(lambda)) 1 m / c` within 0.6 ps. Rendered again with the window chosen
/// automatically, the window holds all three arrivals.
#[test]
fn bk7_slab_bands_arrive_at_their_group_delays_in_one_file() {
    let dir = tempdir("slab");
    let mut s = emitter_below(3.0);
    s.materials.push(bk7_glass());
    quad(&mut s, 2.0, 2.0, true, 1);
    quad(&mut s, 1.0, 2.0, false, 1);
    let scene = save(&s, &dir);
    let nms = [400.0, 550.0, 700.0];
    let bins = 400;
    let request = RenderRequest {
        width: 1,
        height: 1,
        bins,
        t0_s: Some(3.5 / C),
        dt_s: Some(1e-12),
        spp: Some(16),
        seed: 5,
        wavelengths: nms.map(wl).to_vec(),
        ..RenderRequest::new(scene.clone())
    };
    let (meta, _, spectral) = run(&request, &dir, "fixed");
    let (_, cube) = spectral.unwrap();
    let centre = |b: usize| meta.t0_s + (b as f64 + 0.5) * meta.dt_s;
    for (k, nm) in nms.into_iter().enumerate() {
        let tprf = &cube[k * bins..(k + 1) * bins];
        let peak = (0..bins)
            .max_by(|&a, &b| tprf[a].total_cmp(&tprf[b]))
            .unwrap();
        let (lo, hi) = (peak.saturating_sub(2), (peak + 3).min(bins));
        let (mut w, mut m) = (0.0, 0.0);
        for (b, &v) in tprf.iter().enumerate().take(hi).skip(lo) {
            w += v as f64;
            m += v as f64 * centre(b);
        }
        let (t, want) = (m / w, (2.0 + bk7_ng(nm * 1e-3)) / C);
        assert!(
            (t - want).abs() < 0.6e-12,
            "{nm} nm: arrived at {t:e} s, group delay {want:e} s"
        );
    }
    let auto = RenderRequest {
        t0_s: None,
        dt_s: None,
        bins: 256,
        ..request
    };
    let (meta, _, _) = run(&auto, &dir, "auto");
    let end = meta.t0_s + meta.bins as f64 * meta.dt_s;
    for nm in nms {
        let t = (2.0 + bk7_ng(nm * 1e-3)) / C;
        assert!(
            meta.t0_s < t && t < end,
            "{nm} nm at {t:e} s outside [{:e}, {end:e}]",
            meta.t0_s
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A grey plane under a white point light (a grey is the flat spectrum): every band is
/// the same, and `tprf.npy`, the luminance, is each band (the weights sum to 1), over a
/// 31-band spectrum.
#[test]
fn a_grey_scene_luminance_is_each_band() {
    let dir = tempdir("grey");
    let scene = save(&lit_plane(1.0, 0.5, 1.0, 2.0, 40.0), &dir);
    let request = RenderRequest {
        width: 8,
        height: 8,
        bins: 32,
        spp: Some(2),
        wavelengths: tprf_core::scene::wavelengths::parse_range("400nm:700nm:31").unwrap(),
        ..RenderRequest::new(scene)
    };
    let (meta, lum, spectral) = run(&request, &dir, "grey");
    let (shape, cube) = spectral.unwrap();
    assert_eq!(shape, [31, 8, 8, 32]);
    let sum: f64 = meta.spectral.unwrap().luminance_weights.iter().sum();
    assert!((sum - 1.0).abs() < 1e-12, "weights sum to {sum}");
    let plane = lum.len();
    assert!(lum.iter().sum::<f32>() > 0.0);
    for k in 0..31 {
        let band = &cube[k * plane..(k + 1) * plane];
        assert_eq!(band, &cube[..plane], "band {k}");
        for (a, b) in lum.iter().zip(band) {
            assert!(
                (a - b).abs() <= 1e-6 * b.abs(),
                "band {k}: luminance {a}, band {b}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Requests a render of several bands cannot honour are refused naming the field.
#[test]
fn bad_spectral_requests_are_refused_naming_the_field() {
    let base = RenderRequest {
        wavelengths: vec![wl(450.0), wl(550.0)],
        ..RenderRequest::new("builtin:cornell")
    };
    let refused = |r: RenderRequest, fields: &[&str]| {
        let e = r.validate().unwrap_err().to_string();
        for f in fields {
            assert!(e.contains(f), "{f} not named in: {e}");
        }
    };
    refused(
        RenderRequest {
            wavelengths: vec![wl(450.0), wl(450.0)],
            ..base.clone()
        },
        &["wavelengths", "twice"],
    );
    refused(
        RenderRequest {
            channel: Channel::Red,
            ..base.clone()
        },
        &["channel", "wavelengths"],
    );
    refused(
        RenderRequest {
            channel: Channel::Wavelength(wl(600.0)),
            ..base.clone()
        },
        &["channel", "600nm"],
    );
    refused(
        RenderRequest {
            format: tprf_core::export::CubeFormat::Zarr,
            ..base.clone()
        },
        &["format", "wavelengths"],
    );
    refused(
        RenderRequest {
            shard: Some("0/2".into()),
            spp: Some(4),
            uniform: true,
            ..base.clone()
        },
        &["shard", "wavelengths"],
    );
    refused(
        RenderRequest {
            bounces_separate: 2,
            ..base.clone()
        },
        &["bounces_separate"],
    );
    let e = toml::from_str::<RenderRequest>("wavelengths = [\"450nm\", \"2000nm\"]\n").unwrap_err();
    assert!(e.to_string().contains("2000"), "{e}");
    let r: RenderRequest = toml::from_str("wavelengths = [\"450nm\", 550]\n").unwrap();
    assert_eq!(r.wavelengths, [wl(450.0), wl(550.0)]);
    let e = render(&base, &mut Quiet).err().unwrap().to_string();
    assert!(e.contains("wavelengths"), "{e}");
}

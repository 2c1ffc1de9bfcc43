//! tprf against mitransient on the same Mitsuba XML files: the vendored cornell boxes
//! (diffuse, mirror, volumetric: two boxes of homogeneous media), mitransient's angular
//! area light example (`angular_1light.xml`, with `--time-origin near-plane`: its cube
//! bin for bin) and its NLOS scene watched by a camera (`nlos-z-simple.xml`: a projector,
//! both devices' legs left out; mitransient's cube is per unit area of the laser's spot,
//! tprf's is scaled by that area's inverse, worked out from the file), and a scene written
//! here (a point light in W/sr, a mirror box, a two-sided wall, a tessellated sphere, a
//! mesh from a `.serialized` file). Each renderer renders each file twice (two
//! seeds); the cubes are compared against the two renderers' own noise:
//!
//! - chi = |A - B|^2 / ((|A1 - A2|^2 + |B1 - B2|^2) / 4), A and B the two-seed means of
//!   tprf's and mitransient's cubes: about 1 when they differ by noise only, above it by
//!   a bias (a 2 % scale of one cube gives about 2 at these sample counts); on the cube,
//!   on the cube in bins of 10 (less noise: a bias stands out) and on the steady image
//!   (the cube summed over its window);
//! - the image's total in the window, within 1 %;
//! - each lit pixel's peak arrival: in bins of 4, apart by no more than each renderer's
//!   peaks are apart between its two seeds; in single bins, a median difference of 0.
//!
//! mitransient is run by `tests/mitsuba_mitransient.py` in the Python that
//! `$TPRF_MITRANSIENT_PYTHON` names, else `target/race-venv/bin/python` (installed as
//! benches/race/README.md says). Where it is missing the test prints `skipped: ...`
//! and passes: CI does not install it.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use tprf_core::export::read_npy_f32;

const SIZE: usize = 32;
/// Samples per pixel: tprf's cube is about 7 times less noisy than mitransient's at
/// equal spp on the cornell box, so mitransient gets more.
const TPRF_SPP: u64 = 1024;
const MT_SPP: u64 = 4096;
const SEEDS: [u64; 2] = [1, 2];

/// Largest chi (see the module doc) taken for noise.
const CHI_MAX: f64 = 2.0;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The Python that has mitransient, or why there is none.
fn mitransient_python() -> Result<PathBuf, String> {
    let python = std::env::var_os("TPRF_MITRANSIENT_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("target/race-venv/bin/python"));
    if !python.exists() {
        return Err(format!(
            "no {} (set TPRF_MITRANSIENT_PYTHON)",
            python.display()
        ));
    }
    let out = Command::new(&python)
        .arg(repo().join("tests/mitsuba_mitransient.py"))
        .arg("check")
        .output()
        .map_err(|e| format!("{}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(format!(
            "{} cannot load mitransient: {}",
            python.display(),
            String::from_utf8_lossy(&out.stdout).trim()
        ));
    }
    Ok(python)
}

fn npy(path: &Path) -> Vec<f64> {
    let (_, data) = read_npy_f32(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    data.into_iter().map(f64::from).collect()
}

/// tprf's cube of `xml` for each seed (through the CLI: the file's settings, the size
/// and spp given), and mitransient's.
fn render_both(
    python: &Path,
    xml: &Path,
    dir: &Path,
    extra: &[&str],
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let mut tprf = Vec::new();
    for seed in SEEDS {
        let out = dir.join(format!("tprf_{seed}"));
        let status = Command::new(env!("CARGO_BIN_EXE_tprf"))
            .arg("render")
            .arg(xml)
            .args(["--width", &SIZE.to_string(), "--height", &SIZE.to_string()])
            .args(["--spp", &TPRF_SPP.to_string(), "--seed", &seed.to_string()])
            .args(extra)
            .arg("--out")
            .arg(&out)
            .status()
            .unwrap();
        assert!(status.success(), "tprf render {}", xml.display());
        tprf.push(npy(&out.join("tprf.npy")));
    }
    let status = Command::new(python)
        .arg(repo().join("tests/mitsuba_mitransient.py"))
        .arg("render")
        .arg(xml)
        .arg(dir)
        .args([SIZE.to_string(), SIZE.to_string(), MT_SPP.to_string()])
        .args(SEEDS.map(|s| s.to_string()))
        .status()
        .unwrap();
    assert!(status.success(), "mitransient {}", xml.display());
    let mt = SEEDS
        .iter()
        .map(|s| npy(&dir.join(format!("mt_{s}_cube.npy"))))
        .collect();
    (tprf, mt)
}

/// `cube` [pixels, bins] summed over groups of `k` bins.
fn rebin(cube: &[f64], bins: usize, k: usize) -> Vec<f64> {
    cube.chunks(bins)
        .flat_map(|px| px.chunks(k).map(|c| c.iter().sum::<f64>()))
        .collect()
}

fn mean2(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| 0.5 * (x + y)).collect()
}

fn dist2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// chi: the squared distance of the two means over its expectation from the two
/// renderers' seed-to-seed noise.
fn chi(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    let noise2 = (dist2(&a[0], &a[1]) + dist2(&b[0], &b[1])) / 4.0;
    dist2(&mean2(&a[0], &a[1]), &mean2(&b[0], &b[1])) / noise2
}

fn peak(px: &[f64]) -> usize {
    (0..px.len())
        .max_by(|&i, &j| px[i].total_cmp(&px[j]))
        .unwrap_or(0)
}

/// `lit_share`: the least share of pixels the scene lights (every lit pixel's peak is
/// compared).
fn compare(name: &str, bins: usize, tprf: &[Vec<f64>], mt: &[Vec<f64>], lit_share: f64) {
    let pixels = SIZE * SIZE;
    for c in tprf.iter().chain(mt) {
        assert_eq!(c.len(), pixels * bins, "{name}: cube size");
    }
    let chi_cube = chi(tprf, mt);
    let coarse = |v: &[Vec<f64>], k| v.iter().map(|c| rebin(c, bins, k)).collect::<Vec<_>>();
    let chi_10 = chi(&coarse(tprf, 10), &coarse(mt, 10));
    let steady = |v: &[Vec<f64>]| coarse(v, bins);
    let (st, sm) = (steady(tprf), steady(mt));
    let chi_steady = chi(&st, &sm);
    let total = |v: &[Vec<f64>]| v.iter().map(|c| c.iter().sum::<f64>()).sum::<f64>();
    let ratio = total(tprf) / total(mt);

    // Peak arrival per lit pixel (steady above a fifth of the median). A pixel whose
    // histogram has a plateau peaks anywhere on it by noise, so the renderers' peaks are
    // held to their own seed-to-seed spread: in bins of 4, the mean |difference| of the
    // two renderers' peaks at most the sum of each one's between its seeds (the share
    // within a bin is printed); in single bins, a median difference of 0 (a shift of the
    // time axis by a bin moves it).
    let s = mean2(&sm[0], &sm[1]);
    let mut sorted = s.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let lit: Vec<usize> = (0..pixels).filter(|&p| s[p] > 0.2 * median).collect();
    let peaks = |c: &[f64], k: usize| -> Vec<i64> {
        let t = bins.div_ceil(k);
        let c = rebin(c, bins, k);
        lit.iter()
            .map(|&p| peak(&c[p * t..(p + 1) * t]) as i64)
            .collect()
    };
    let mean_abs = |a: &[i64], b: &[i64]| {
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<i64>() as f64 / a.len() as f64
    };
    let (a, b) = (mean2(&tprf[0], &tprf[1]), mean2(&mt[0], &mt[1]));
    let (pa, pb) = (peaks(&a, 4), peaks(&b, 4));
    let between = mean_abs(&pa, &pb);
    let tprf_seeds = mean_abs(&peaks(&tprf[0], 4), &peaks(&tprf[1], 4));
    let mt_seeds = mean_abs(&peaks(&mt[0], 4), &peaks(&mt[1], 4));
    let near = pa
        .iter()
        .zip(&pb)
        .filter(|(x, y)| (*x - *y).abs() <= 1)
        .count() as f64
        / lit.len() as f64;
    let mut fine: Vec<i64> = peaks(&a, 1)
        .iter()
        .zip(peaks(&b, 1))
        .map(|(x, y)| x - y)
        .collect();
    fine.sort_unstable();
    let median_shift = fine.get(fine.len() / 2).copied().unwrap_or(i64::MAX);

    eprintln!(
        "{name}: chi cube {chi_cube:.3}, in bins of 10 {chi_10:.3}, steady {chi_steady:.3}; \
         total tprf / mitransient {ratio:.4}; peaks of {} lit pixels (bins of 4): mean |tprf - mitransient| \
         {between:.3} (between seeds: tprf {tprf_seeds:.3}, mitransient {mt_seeds:.3}), within a bin {:.1} %; \
         median shift {median_shift} bins",
        lit.len(),
        100.0 * near
    );
    assert!(chi_cube < CHI_MAX, "{name}: cube chi {chi_cube}");
    assert!(chi_10 < CHI_MAX, "{name}: chi in bins of 10 {chi_10}");
    assert!(chi_steady < CHI_MAX, "{name}: steady chi {chi_steady}");
    assert!((ratio - 1.0).abs() < 0.01, "{name}: total ratio {ratio}");
    assert!(
        lit.len() as f64 > lit_share * pixels as f64,
        "{name}: {} lit pixels",
        lit.len()
    );
    assert!(
        between <= tprf_seeds + mt_seeds,
        "{name}: peaks differ by {between}"
    );
    assert_eq!(median_shift, 0, "{name}: peaks shifted");
}

/// A scene of the kinds the cornell boxes do not have: a point light (W/sr), a mirror
/// box, a two-sided wall, a tessellated sphere, fov on the y axis; bins of 5 cm, fine
/// enough that the default near_clip (1 cm) would move an off-axis pixel's arrivals by a
/// visible share of a bin (chi 2.3 on the cube with it).
const WRITTEN: &str = r#"<scene version="3.0.0">
    <default name="res" value="64"/>
    <default name="spp" value="64"/>
    <integrator type="transient_path">
        <integer name="max_depth" value="-1"/>
    </integrator>
    <sensor type="perspective">
        <string name="fov_axis" value="y"/>
        <float name="fov" value="50"/>
        <!-- Off the image's axis mitransient's arrivals are early by
             near_clip (1 / cos - 1): 0.1 mm keeps that far below a bin. -->
        <float name="near_clip" value="0.0001"/>
        <transform name="to_world">
            <lookat origin="0, 1, 4" target="0, 0.5, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="transient_hdr_film">
            <integer name="width" value="$res"/>
            <integer name="height" value="$res"/>
            <integer name="temporal_bins" value="200"/>
            <float name="start_opl" value="4"/>
            <float name="bin_width_opl" value="0.05"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <emitter type="point">
        <point name="position" x="1" y="2.5" z="2"/>
        <rgb name="intensity" value="30, 20, 10"/>
    </emitter>
    <bsdf type="diffuse" id="floor_bsdf">
        <rgb name="reflectance" value="0.6, 0.5, 0.4"/>
    </bsdf>
    <shape type="rectangle" id="floor">
        <transform name="to_world">
            <rotate x="1" angle="-90"/>
            <scale value="3"/>
        </transform>
        <ref id="floor_bsdf"/>
    </shape>
    <shape type="rectangle" id="back">
        <transform name="to_world">
            <scale value="3"/>
            <translate y="1.5" z="-2"/>
        </transform>
        <bsdf type="twosided">
            <bsdf type="diffuse">
                <rgb name="reflectance" value="0.3, 0.7, 0.5"/>
            </bsdf>
        </bsdf>
    </shape>
    <shape type="cube" id="mirror_box">
        <transform name="to_world">
            <scale x="0.4" y="0.6" z="0.4"/>
            <rotate y="1" angle="30"/>
            <translate x="-0.6" y="0.6" z="-0.3"/>
        </transform>
        <bsdf type="conductor"/>
    </shape>
    <!-- A square pyramid from a .serialized file the test writes (mesh 1 of 2: both
         readers must pick it by shape_index), standing on the floor. -->
    <shape type="serialized" id="pyramid">
        <string name="filename" value="pyramid.serialized"/>
        <integer name="shape_index" value="1"/>
        <transform name="to_world">
            <rotate x="1" angle="-90"/>
            <scale value="0.35"/>
            <translate x="0.1" z="1.3"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.7, 0.6, 0.5"/>
        </bsdf>
    </shape>
    <shape type="sphere" id="ball">
        <point name="center" x="0.7" y="0.4" z="0.3"/>
        <float name="radius" value="0.4"/>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.8, 0.8, 0.8"/>
        </bsdf>
    </shape>
</scene>
"#;

#[test]
fn tprf_matches_mitransient_on_the_same_xml_files() {
    let python = match mitransient_python() {
        Ok(p) => p,
        Err(why) => {
            eprintln!(
                "skipped: mitransient is not available ({why}); install it as benches/race/README.md says"
            );
            return;
        }
    };
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mitsuba-mitransient");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let written = dir.join("written.xml");
    std::fs::write(&written, WRITTEN).unwrap();
    std::fs::write(
        dir.join("pyramid.serialized"),
        common::serialized::decoy_then_pyramid(4),
    )
    .unwrap();
    let examples = repo().join("assets/mitsuba/mitransient");
    let cbox = examples.join("cornell-box");
    // mitransient's clock: from the near plane (its bins of 0.5 m against near_clip 10
    // at the angular scene's corners: 2.4 bins apart from the pinhole's).
    let near: &[&str] = &["--time-origin", "near-plane"];
    // mitransient's transient_nlos_path joins paths to the laser's spot as to a point
    // of unit area: its cube is tprf's over the spot's area (the projector's frustum,
    // 4 tan^2(0.1 deg) D^2 across its axis at distance D, over the cosine of incidence
    // on the wall z = 0), worked out here from the file's projector.
    let nlos_xml = examples.join("transient-nlos/nlos-z-simple.xml");
    let spot_m2 = {
        let s = tprf_core::scene::load(nlos_xml.to_str().unwrap()).unwrap();
        let l = &s.lights[0];
        let p = l.projector.clone().expect("the projector");
        let (o, d) = (l.position.as_dvec3(), p.direction.as_dvec3());
        let dist = -o.z / d.z;
        4.0 * f64::from(p.tan_half_x) * f64::from(p.tan_half_y) * dist * dist / d.z.abs()
    };
    for (name, xml, bins, extra, tprf_scale, lit) in [
        (
            "cbox_diffuse",
            cbox.join("cbox_diffuse.xml"),
            400,
            &[][..],
            1.0,
            0.5,
        ),
        (
            "cbox_mirror",
            cbox.join("cbox_mirror.xml"),
            400,
            &[],
            1.0,
            0.5,
        ),
        // Two boxes of homogeneous media (transient_prbvolpath in mitransient).
        (
            "cbox_volumetric",
            cbox.join("cbox_volumetric.xml"),
            400,
            &[],
            1.0,
            0.5,
        ),
        ("written", written, 200, &[], 1.0, 0.5),
        // An angular area light (mitransient's angulararea, its next-event weight
        // mended: tests/mitsuba_mitransient.py) lighting a fifth of the floor seen.
        (
            "angular_1light",
            examples.join("angulararea-emitter/angular_1light.xml"),
            200,
            near,
            1.0,
            0.15,
        ),
        // The same scene with a plain area light.
        (
            "area_1light",
            examples.join("angulararea-emitter/area_1light.xml"),
            200,
            near,
            1.0,
            0.15,
        ),
        // An NLOS scene watched by a camera (transient_nlos_path, a projector, both
        // devices' legs left out).
        ("nlos-z-simple", nlos_xml, 300, &[], 1.0 / spot_m2, 0.5),
    ] {
        let d = dir.join(name);
        std::fs::create_dir_all(&d).unwrap();
        let (mut tprf, mt) = render_both(&python, &xml, &d, extra);
        for c in &mut tprf {
            c.iter_mut().for_each(|v| *v *= tprf_scale);
        }
        compare(name, bins, &tprf, &mt, lit);
    }
}

/// mitransient's phasor film example (`cbox_diffuse_freq.xml`: 41 frequencies, 0.005 to
/// 0.015 per metre) rendered by both at 32 x 32: tprf's phasor.npy (from its film) against
/// mitransient's phasor_hdr_film, by the same chi on the real and imaginary parts. The
/// copy rendered sets `discard_direct_light` false (mitransient then drops every emitter
/// hit, at any depth, keeping the light it samples at emitters with its MIS weight: a
/// biased image that tprf does not make, noting the property as not applied) and
/// `near_clip` 1 mm (the file's 10 m would shift mitransient's off-axis phases by
/// `2 pi f near_clip (1 / cos a - 1)`, 0.06 rad at the corners at 0.015 per metre).
#[test]
fn tprf_phasors_match_mitransients_phasor_film() {
    let python = match mitransient_python() {
        Ok(p) => p,
        Err(why) => {
            eprintln!(
                "skipped: mitransient is not available ({why}); install it as benches/race/README.md says"
            );
            return;
        }
    };
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mitsuba-mitransient-phasor");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let cbox = repo().join("assets/mitsuba/mitransient/cornell-box");
    let text = std::fs::read_to_string(cbox.join("cbox_diffuse_freq.xml")).unwrap();
    let meshes = format!("\"{}/meshes/", cbox.display());
    let copy = text
        .replace(
            "name=\"discard_direct_light\" value=\"true\"",
            "name=\"discard_direct_light\" value=\"false\"",
        )
        .replace(
            "name=\"near_clip\" value=\"10\"",
            "name=\"near_clip\" value=\"0.001\"",
        )
        .replace("\"meshes/", &meshes);
    assert!(copy.contains("discard_direct_light\" value=\"false") && copy.contains("0.001"));
    let xml = dir.join("cbox_diffuse_freq.xml");
    std::fs::write(&xml, copy).unwrap();
    let mut tprf = Vec::new();
    for seed in SEEDS {
        let out = dir.join(format!("tprf_{seed}"));
        let status = Command::new(env!("CARGO_BIN_EXE_tprf"))
            .arg("render")
            .arg(&xml)
            .args(["--width", &SIZE.to_string(), "--height", &SIZE.to_string()])
            .args(["--spp", &TPRF_SPP.to_string(), "--seed", &seed.to_string()])
            .arg("--out")
            .arg(&out)
            .status()
            .unwrap();
        assert!(status.success(), "tprf render {}", xml.display());
        tprf.push(npy(&out.join("phasor.npy")));
    }
    let status = Command::new(&python)
        .arg(repo().join("tests/mitsuba_mitransient.py"))
        .arg("phasor")
        .arg(&xml)
        .arg(&dir)
        .args([SIZE.to_string(), SIZE.to_string(), MT_SPP.to_string()])
        .args(SEEDS.map(|s| s.to_string()))
        .status()
        .unwrap();
    assert!(status.success(), "mitransient {}", xml.display());
    let mt: Vec<Vec<f64>> = SEEDS
        .iter()
        .map(|s| npy(&dir.join(format!("mt_{s}_phasor.npy"))))
        .collect();
    let nf = 41;
    for c in tprf.iter().chain(&mt) {
        assert_eq!(c.len(), SIZE * SIZE * nf * 2, "phasor size");
    }
    let chi_all = chi(&tprf, &mt);
    // Per frequency, over the pixels; and the image's sum per frequency (|sum P|).
    let pick = |v: &[Vec<f64>], j: usize| -> Vec<Vec<f64>> {
        v.iter()
            .map(|c| {
                c.chunks(2 * nf)
                    .flat_map(|px| [px[2 * j], px[2 * j + 1]])
                    .collect()
            })
            .collect()
    };
    let mut worst = (0.0f64, 0);
    for j in 0..nf {
        let c = chi(&pick(&tprf, j), &pick(&mt, j));
        if c > worst.0 {
            worst = (c, j);
        }
    }
    let image_sum = |v: &[Vec<f64>], j: usize| -> (f64, f64) {
        let p = pick(v, j);
        let n = p.len() as f64;
        p.iter().fold((0.0, 0.0), |(re, im), c| {
            let s = c
                .chunks(2)
                .fold((0.0, 0.0), |a, z| (a.0 + z[0], a.1 + z[1]));
            (re + s.0 / n, im + s.1 / n)
        })
    };
    let ratios: Vec<f64> = (0..nf)
        .map(|j| {
            let (a, b) = (image_sum(&tprf, j), image_sum(&mt, j));
            a.0.hypot(a.1) / b.0.hypot(b.1)
        })
        .collect();
    let (rmin, rmax) = ratios
        .iter()
        .fold((f64::MAX, f64::MIN), |(lo, hi), &r| (lo.min(r), hi.max(r)));
    // The image's mean phasor per frequency (less noise: a bias stands out), its chi.
    let sums = |v: &[Vec<f64>]| -> Vec<Vec<f64>> {
        v.iter()
            .map(|c| {
                let mut s = vec![0.0; 2 * nf];
                for px in c.chunks(2 * nf) {
                    for (a, b) in s.iter_mut().zip(px) {
                        *a += b / (SIZE * SIZE) as f64;
                    }
                }
                s
            })
            .collect()
    };
    let chi_sum = chi(&sums(&tprf), &sums(&mt));
    eprintln!(
        "cbox_diffuse_freq phasors: chi {chi_all:.3} over all 41 frequencies; largest chi of one \
         frequency {:.3} (index {}); chi of the image's mean phasors {chi_sum:.3}; |image mean| \
         tprf / mitransient from {rmin:.4} to {rmax:.4}",
        worst.0, worst.1
    );
    assert!(chi_all < CHI_MAX, "phasor chi {chi_all}");
    assert!(
        worst.0 < CHI_MAX,
        "phasor chi at frequency {}: {}",
        worst.1,
        worst.0
    );
    assert!(
        chi_sum < CHI_MAX,
        "chi of the image's mean phasors {chi_sum}"
    );
}

//! tprf's Mitsuba BSDFs against Mitsuba 3 itself: `plastic`, `roughplastic` (Beckmann
//! and GGX, `nonlinear` or not) and `roughconductor` evaluated at chosen direction pairs
//! (a specular peak, off-peak, grazing), and the named conductors' eta and k against
//! Mitsuba's own.
//!
//! Mitsuba is run by `crates/tprf-core/tests/mitsuba_bsdf.py` in the Python that `$TPRF_MITRANSIENT_PYTHON`
//! names, else `target/race-venv/bin/python` (installed as benches/race/README.md says).
//! Where it is missing the test prints `skipped: ...` and passes: CI does not install it.

use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::Command;
use tprf_core::scene::{Channel, Microfacet, MicrofacetDistribution, SurfaceModel};
use tprf_core::transport::bsdf::{BandModel, Bsdf, BsdfParams};

/// The workspace root (this file is tprf-core's: it needs no more than the library).
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn mitsuba_python() -> Result<PathBuf, String> {
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
        .arg(repo().join("crates/tprf-core/tests/mitsuba_bsdf.py"))
        .arg("check")
        .output()
        .map_err(|e| format!("{}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(format!(
            "{} cannot load mitsuba: {}",
            python.display(),
            String::from_utf8_lossy(&out.stdout).trim()
        ));
    }
    Ok(python)
}

/// Run the script on `cases` (one JSON object a line); its output lines.
fn mitsuba(python: &Path, cases: &[String]) -> Vec<String> {
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("tprf-mitsuba-bsdf-{}-{call}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("cases.jsonl");
    std::fs::write(&file, cases.join("\n") + "\n").unwrap();
    let out = Command::new(python)
        .arg(repo().join("crates/tprf-core/tests/mitsuba_bsdf.py"))
        .arg("eval")
        .arg(&file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "mitsuba_bsdf.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z).normalize()
}

fn json_vec(a: Vec3) -> String {
    format!("[{}, {}, {}]", a.x, a.y, a.z)
}

fn mf_json(m: &Option<Microfacet>) -> String {
    match m {
        Some(m) => format!(
            r#", "distribution": "{}", "alpha": {}"#,
            match m.distribution {
                MicrofacetDistribution::Beckmann => "beckmann",
                MicrofacetDistribution::Ggx => "ggx",
            },
            m.alpha
        ),
        None => String::new(),
    }
}

#[test]
fn plastics_and_conductors_evaluate_as_mitsuba() {
    let python = match mitsuba_python() {
        Ok(p) => p,
        Err(why) => {
            println!("skipped: Mitsuba is not available ({why})");
            return;
        }
    };
    let rough = |d, alpha| {
        Some(Microfacet {
            distribution: d,
            alpha,
        })
    };
    use MicrofacetDistribution::{Beckmann, Ggx};
    // (model, diffuse reflectance, Mitsuba's dict)
    let mut models: Vec<(SurfaceModel, f32, String)> = Vec::new();
    for (microfacet, nonlinear, rho) in [
        (None, true, 0.578f32),
        (None, false, 0.3),
        (rough(Ggx, 0.1), true, 0.578),
        (rough(Ggx, 0.2), true, 0.9),
        (rough(Beckmann, 0.3), false, 0.5),
        (rough(Beckmann, 0.05), true, 0.578),
    ] {
        let plugin = if microfacet.is_some() {
            "roughplastic"
        } else {
            "plastic"
        };
        models.push((
            SurfaceModel::Plastic {
                eta: 1.5,
                microfacet,
                nonlinear,
            },
            rho,
            format!(
                r#"{{"type": "{plugin}", "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": {nonlinear}, "diffuse_reflectance": {rho}{}}}"#,
                mf_json(&microfacet)
            ),
        ));
    }
    for (microfacet, eta, k) in [
        (rough(Ggx, 0.1), 2.2129f32, 2.2399f32),
        (rough(Beckmann, 0.25), 0.2, 3.9),
        (rough(Ggx, 0.5), 1.6, 6.7),
    ] {
        models.push((
            SurfaceModel::Conductor {
                eta: [eta; 3],
                k: [k; 3],
                specular_reflectance: [0.8; 3],
                microfacet,
            },
            0.5,
            format!(
                r#"{{"type": "roughconductor", "eta": {eta}, "k": {k}, "specular_reflectance": 0.8{}}}"#,
                mf_json(&microfacet)
            ),
        ));
    }
    let pairs = [
        (v(0.6, 0.0, 0.8), v(-0.6, 0.0, 0.8)), // the specular peak (h = +Z)
        (v(0.6, 0.0, 0.8), v(-0.5, 0.1, 0.8)), // near it
        (v(0.3, 0.2, 0.9), v(0.0, -0.7, 0.7)), // off it
        (v(0.99, 0.0, 0.1), v(-0.97, 0.0, 0.2)), // grazing
        (Vec3::Z, v(0.9, 0.3, 0.3)),
    ];
    let mut cases = Vec::new();
    let mut ours = Vec::new();
    for (model, rho, dict) in &models {
        let band = BandModel::new(model, |c| Channel::Gray.pick(c), *rho, 1.0);
        let params = BsdfParams {
            base: *rho,
            metallic: 0.0,
            roughness: 1.0,
            specular_factor: 1.0,
            specular_color: 1.0,
            transmission: 0.0,
            ior: 1.5,
        };
        let bsdf = Bsdf::build(&band, &params, true);
        for (wo, wi) in pairs {
            cases.push(format!(
                r#"{{"bsdf": {dict}, "wo": {}, "wi": {}}}"#,
                json_vec(wo),
                json_vec(wi)
            ));
            ours.push((dict.clone(), wo, wi, bsdf.eval(wo, wi).0 * wi.z));
        }
    }
    let theirs = mitsuba(&python, &cases);
    assert_eq!(theirs.len(), ours.len());
    let mut worst = 0.0f64;
    for ((dict, wo, wi, a), b) in ours.iter().zip(&theirs) {
        let b: f64 = b.trim().parse().unwrap();
        let a = *a as f64;
        // Smooth lobes are formulas: f32 rounding. Rough plastics interpolate tables of
        // integrals that tprf and Mitsuba compute by different quadratures.
        let rel = (a - b).abs() / b.abs().max(1e-3);
        worst = worst.max(rel);
        assert!(
            rel < 5e-3,
            "{dict}\n  wo {wo} wi {wi}: tprf {a}, Mitsuba {b} ({:.3} %)",
            100.0 * rel
        );
    }
    println!("largest relative difference {:.4} %", 100.0 * worst);
}

/// The named conductors tprf knows carry Mitsuba's own eta and k (its RGB variants'
/// reduction of the spectra).
#[test]
fn named_conductors_are_mitsubas() {
    let python = match mitsuba_python() {
        Ok(p) => p,
        Err(why) => {
            println!("skipped: Mitsuba is not available ({why})");
            return;
        }
    };
    let names = ["Ag", "Al", "Au", "Cr", "Cu", "Ni_palik", "VN"];
    let mut cases = Vec::new();
    for n in names {
        for key in ["eta", "k"] {
            cases.push(format!(
                r#"{{"bsdf": {{"type": "conductor", "material": "{n}"}}, "param": "{key}.value"}}"#
            ));
        }
    }
    let theirs = mitsuba(&python, &cases);
    for (i, n) in names.iter().enumerate() {
        let xml = format!(
            r#"<scene version="3.0.0"><shape type="rectangle"><bsdf type="conductor"><string name="material" value="{n}"/></bsdf></shape></scene>"#
        );
        let dir = std::env::temp_dir().join(format!("tprf-named-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("s.xml");
        std::fs::write(&file, xml).unwrap();
        let scene = tprf_core::scene::load(file.to_str().unwrap()).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let Some(SurfaceModel::Conductor { eta, k, .. }) =
            scene.materials.iter().map(|m| m.model).next()
        else {
            panic!("{n}: not a conductor");
        };
        for (j, ours) in [eta, k].iter().enumerate() {
            let t: Vec<f64> = theirs[2 * i + j]
                .split_whitespace()
                .map(|s| s.parse().unwrap())
                .collect();
            for c in 0..3 {
                assert!(
                    (ours[c] as f64 - t[c]).abs() < 1e-4 * t[c].abs().max(1.0),
                    "{n} {}: {ours:?} vs {t:?}",
                    ["eta", "k"][j]
                );
            }
        }
    }
}

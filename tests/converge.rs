//! Error against samples: the renderer against the exact references converges at least
//! like `spp^-1/2` (fitted on spp, never on time: no timed assertions), the film's two-half
//! estimate tracks the true error, and `tprf converge` writes its files and refuses
//! bad input with a clear error.

use std::ops::ControlFlow;
use std::path::Path;
use std::process::Command;
use std::sync::Arc;
use tprf_core::film::{FilmLayout, TimeAxis, TimeFilter, TprfFilm};
use tprf_core::reference::Analytic;
use tprf_core::report::converge::{
    Checkpoint, EstimatorSetting, FilmRequest, RunConfig, fit_loglog, measure, resolve_target,
    run_setting,
};
use tprf_core::transport::progressive::{Schedule, render};
use tprf_core::transport::{RenderSettings, Renderer};

/// Render `spec`'s scene on a small film, measuring after 4, 8, ..., 4^k spp.
fn errors_by_spp(spec: &str, w: usize, h: usize, bins: usize, max_spp: u64) -> Vec<Checkpoint> {
    let a = Analytic::parse(spec).unwrap();
    let axis = a.default_axis(w, h, bins).unwrap();
    let reference = a.cube(w, h, &axis);
    let settings = RenderSettings {
        seed: 3,
        ..RenderSettings::default()
    };
    let renderer = Renderer::new(Arc::new(a.scene()), settings);
    let mut film = TprfFilm::new(FilmLayout {
        width: w,
        height: h,
        axis,
        bounces_separate: 0,
        luminescence: false,
    })
    .unwrap();
    let mut out = Vec::new();
    let mut target = 4;
    while target <= max_spp {
        render(&renderer, &mut film, &Schedule::spp(target), |_, _| {
            ControlFlow::Continue(())
        });
        out.push(measure(spec, 0.0, &film, &reference));
        target *= 4;
    }
    out
}

/// `band`: how far (a factor) the two-half estimate may be from the true error.
fn check_rate(spec: &str, w: usize, h: usize, bins: usize, max_spp: u64, band: f64) {
    let c = errors_by_spp(spec, w, h, bins, max_spp);
    assert!(c.iter().all(|c| c.non_finite == 0));
    let fit = fit_loglog(c.iter().map(|c| (c.spp as f64, c.rel_l2_cube))).unwrap();
    // At least spp^-1/2: an unbiased estimator of finite variance falls like spp^-1/2,
    // and faster where the stratified samples help (the plane's footprint jitter falls
    // like spp^-3/4); a bias would flatten the slope.
    assert!(
        fit.slope < -0.42 && fit.slope > -1.0,
        "{spec}: slope {} on spp ({:?})",
        fit.slope,
        c.iter().map(|c| (c.spp, c.rel_l2_cube)).collect::<Vec<_>>()
    );
    let (first, last) = (&c[0], &c[c.len() - 1]);
    assert!(
        last.rel_l2_cube < 0.2 * first.rel_l2_cube,
        "{spec}: error did not fall"
    );
    assert!(last.rel_l1_cube < first.rel_l1_cube && last.rel_l2_steady < first.rel_l2_steady);
    // The estimate without a reference is within a factor `band` of the true error
    // (geometric mean over the checkpoints: the square root of a sum over few lit bins
    // scatters, and is low on average, by Jensen's inequality).
    let ratios: Vec<f64> = c
        .iter()
        .map(|c| c.half_estimate.unwrap() / c.rel_l2_cube)
        .collect();
    let mean_ratio = (ratios.iter().map(|r| r.ln()).sum::<f64>() / ratios.len() as f64).exp();
    assert!(
        mean_ratio < band && mean_ratio > 1.0 / band,
        "{spec}: two-half estimate / error {mean_ratio} (per checkpoint {ratios:?})"
    );
}

#[test]
fn furnace_error_falls_as_spp_to_the_minus_half() {
    check_rate("analytic:furnace?rho=0.5", 8, 8, 32, 1024, 1.5);
}

#[test]
fn emitting_furnace_error_falls_as_spp_to_the_minus_half() {
    check_rate(
        "analytic:furnace?rho=0.8&light=area&r=2",
        6,
        6,
        32,
        1024,
        1.5,
    );
}

#[test]
fn plane_error_falls_as_spp_to_the_minus_half() {
    check_rate("analytic:plane", 8, 6, 24, 1024, 1.5);
}

#[test]
fn oned_error_falls_as_spp_to_the_minus_half() {
    // 4 pixels of a few impulses each: the error is a sum over few bins, and so is its
    // estimate, so they agree only within a factor 2.
    check_rate("analytic:oned", 2, 2, 128, 16384, 2.0);
}

#[test]
fn a_time_budget_run_makes_ordered_checkpoints() {
    let target = resolve_target(
        None,
        Some("analytic:furnace?rho=0.5"),
        &FilmRequest {
            width: Some(6),
            height: Some(4),
            bins: Some(16),
            ..FilmRequest::default()
        },
    )
    .unwrap();
    let scene = Arc::new(target.scene);
    let config = RunConfig {
        seconds: 0.3,
        ..RunConfig::default()
    };
    for spec in ["default", "filter=tent,rr_floor=0.5,seconds=0.2"] {
        let setting = EstimatorSetting::parse(spec).unwrap();
        let mut seen = 0;
        let run = run_setting(&scene, &setting, &config, &target.reference, |_| seen += 1).unwrap();
        assert_eq!(run.memory_stop, None, "{spec}");
        let c = run.checkpoints;
        assert_eq!(seen, c.len());
        // At least one checkpoint; how many fit the budget depends on the machine's load
        // (a loaded 2-core machine fits one pass of the first), so only their order is
        // checked.
        assert!(!c.is_empty(), "{spec}: no checkpoint");
        assert!(
            c.windows(2)
                .all(|w| w[1].seconds > w[0].seconds && w[1].spp > w[0].spp)
        );
        assert!(c.last().unwrap().seconds >= setting.seconds.unwrap_or(config.seconds));
        assert!(c.iter().all(|c| c.setting == spec && c.non_finite == 0));
    }
}

#[test]
fn the_tent_filter_has_a_bias_floor_against_box_bins() {
    // The furnace's first arrival is a delta: the tent moves part of it into the next
    // bin, so against box-bin references the tent keeps an error however many samples.
    let a = Analytic::parse("analytic:furnace?rho=0.5").unwrap();
    let axis = a.default_axis(4, 4, 32).unwrap();
    let reference = a.cube(4, 4, &axis);
    let renderer = Renderer::new(Arc::new(a.scene()), RenderSettings::default());
    let layout = FilmLayout {
        width: 4,
        height: 4,
        axis,
        bounces_separate: 0,
        luminescence: false,
    };
    let mut film = TprfFilm::new(layout)
        .unwrap()
        .with_time_filter(TimeFilter::Tent);
    render(&renderer, &mut film, &Schedule::spp(512), |_, _| {
        ControlFlow::Continue(())
    });
    let c = measure("tent", 0.0, &film, &reference);
    // Where 2R/c falls in its bin sets the share the tent moves: at least the part of
    // the delta's weight that leaves its bin.
    let x = (2.0 / tprf_core::units::C_M_PER_S - axis.t0_s) / axis.dt_s;
    let moved = (x.fract() - 0.5).abs();
    assert!(moved > 0.05, "the test needs the delta off a bin centre");
    assert!(c.rel_l2_cube > 0.5 * moved, "{} vs {moved}", c.rel_l2_cube);
    // The steady image is unaffected.
    assert!(c.rel_l2_steady < 0.05, "{}", c.rel_l2_steady);
}

fn tprf_bin(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(args)
        .output()
        .expect("run tprf")
}

fn tempdir(name: &str) -> std::path::PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("converge-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn cli_writes_csv_plot_and_summary_against_analytic_and_npy_references() {
    let dir = tempdir("cli");
    let out = dir.join("furnace");
    let o = tprf_bin(&[
        "converge",
        "--reference",
        "analytic:furnace?rho=0.5",
        "--seconds",
        "0.3",
        "--width",
        "8",
        "--height",
        "8",
        "--bins",
        "16",
        "--setting",
        "default",
        "--setting",
        "rr_start=1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("converge.csv")).unwrap();
    assert!(csv.starts_with("setting,seconds,spp"));
    assert!(csv.lines().any(|l| l.starts_with("\"rr_start=1\"")));
    let png = image::open(out.join("converge.png")).unwrap();
    assert!(png.width() > 100 && png.height() > 100);
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("| default |") && md.contains("| rr_start=1 |"));

    // A long(er) render as the reference.
    let cube = dir.join("cube");
    let o = tprf_bin(&[
        "render",
        "builtin:cornell",
        "--out",
        cube.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "64",
        "--bins",
        "16",
    ]);
    assert!(o.status.success());
    let npy = cube.join("tprf.npy");
    let out2 = dir.join("cornell");
    let o = tprf_bin(&[
        "converge",
        "builtin:cornell",
        "--reference",
        npy.to_str().unwrap(),
        "--seconds",
        "0.2",
        "--out",
        out2.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out2.join("converge.png").exists());

    // Bad input: clear errors, never a panic.
    let bad_shape = dir.join("bad");
    std::fs::create_dir_all(&bad_shape).unwrap();
    std::fs::copy(cube.join("tprf.json"), bad_shape.join("tprf.json")).unwrap();
    tprf_core::export::write_npy_f32(&bad_shape.join("tprf.npy"), &[8, 4, 16], &[0.0; 512])
        .unwrap();
    let o2 = out2.to_str().unwrap();
    let bad_npy = bad_shape.join("tprf.npy");
    let no_meta = dir.join("lonely.npy");
    tprf_core::export::write_npy_f32(&no_meta, &[1, 1, 1], &[0.0]).unwrap();
    for (args, want) in [
        (
            vec!["converge", "--reference", "analytic:teapot", "--out", o2],
            "unknown reference",
        ),
        (
            vec![
                "converge",
                "--reference",
                "analytic:furnace?rho=NaN",
                "--out",
                o2,
            ],
            "not a finite number",
        ),
        (
            vec![
                "converge",
                "--reference",
                "analytic:furnace?rho=1.5",
                "--out",
                o2,
            ],
            "[0, 1)",
        ),
        (
            vec![
                "converge",
                "builtin:cornell",
                "--reference",
                bad_npy.to_str().unwrap(),
                "--out",
                o2,
            ],
            "does not match its metadata",
        ),
        (
            vec![
                "converge",
                "builtin:cornell",
                "--reference",
                no_meta.to_str().unwrap(),
                "--out",
                o2,
            ],
            "metadata",
        ),
        (
            vec![
                "converge",
                "--reference",
                npy.to_str().unwrap(),
                "--out",
                o2,
            ],
            "needs the SCENE",
        ),
        (
            vec![
                "converge",
                "builtin:cornell",
                "--reference",
                "analytic:plane",
                "--out",
                o2,
            ],
            "builds its own scene",
        ),
        (
            vec!["converge", "builtin:cornell", "--out", o2],
            "give a reference",
        ),
        (
            vec![
                "converge",
                "--reference",
                "analytic:plane",
                "--setting",
                "nee=maybe",
                "--out",
                o2,
            ],
            "expected on or off",
        ),
        (
            vec![
                "converge",
                "--reference",
                "analytic:plane",
                "--seconds",
                "0",
                "--out",
                o2,
            ],
            "--seconds",
        ),
        (
            vec![
                "converge",
                "--reference",
                "notes.txt",
                "builtin:cornell",
                "--out",
                o2,
            ],
            "unknown reference",
        ),
        (
            vec![
                "converge",
                "--reference",
                "analytic:plane",
                "--width",
                "4096",
                "--height",
                "4096",
                "--bins",
                "4000000",
                "--out",
                o2,
            ],
            "too large",
        ),
        (
            vec![
                "converge",
                "--reference",
                "analytic:plane",
                "--bins",
                "0",
                "--out",
                o2,
            ],
            "bin count",
        ),
    ] {
        let o = tprf_bin(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn reference_axis_overrides_apply() {
    let t = resolve_target(
        Some("analytic:plane"),
        None,
        &FilmRequest {
            width: Some(4),
            height: Some(3),
            bins: Some(10),
            t0_s: Some(1e-9),
            dt_s: Some(2e-11),
        },
    )
    .unwrap();
    assert_eq!(t.reference.axis, TimeAxis::new(1e-9, 2e-11, 10).unwrap());
    assert_eq!(t.reference.values.len(), 4 * 3 * 10);
}

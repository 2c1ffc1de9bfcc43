//! The `tprf` binary as a user runs it: files written, metadata, and clear errors.

use std::path::Path;
use std::process::Command;

fn tprf(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(args)
        .output()
        .expect("run tprf")
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn render_writes_cube_metadata_and_pngs() {
    let dir = tempdir("render");
    let out = dir.to_str().unwrap();
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        out,
        "--width",
        "24",
        "--height",
        "16",
        "--spp",
        "4",
        "--bins",
        "32",
        "--frames",
        "--bounces-separate",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (shape, data) = tprf_core::export::read_npy_f32(&dir.join("tprf.npy")).unwrap();
    assert_eq!(shape, vec![16, 24, 32]);
    assert!(data.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert!(data.iter().any(|&v| v > 0.0));
    let (bshape, bdata) = tprf_core::export::read_npy_f32(&dir.join("tprf_bounces.npy")).unwrap();
    assert_eq!(bshape, vec![4, 16, 24, 32]);
    // The per-bounce layers add up to the cube.
    let n = data.len();
    for i in 0..n {
        let sum: f32 = (0..4).map(|l| bdata[l * n + i]).sum();
        assert!((sum - data[i]).abs() <= 1e-5 * data[i].max(1e-3));
    }
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("tprf.json")).unwrap()).unwrap();
    for key in [
        "t0_s",
        "dt_s",
        "bins",
        "width",
        "height",
        "spp",
        "seed",
        "c_m_per_s",
        "channel",
        "scene",
        "camera",
        "threads",
        "wall_seconds",
        "rays_traced",
        "passes",
    ] {
        assert!(meta.get(key).is_some(), "tprf.json lacks {key}");
    }
    assert_eq!(meta["spp"], 4);
    assert_eq!(meta["bins"], 32);
    // `passes` counts the render passes (it was once a list of per-pass records).
    assert!(
        meta["passes"]
            .as_u64()
            .is_some_and(|n| (1..=4).contains(&n))
    );
    let png = image::open(dir.join("steady.png")).unwrap();
    assert_eq!((png.width(), png.height()), (24, 16));
    assert!(dir.join("frames/0000.png").exists() && dir.join("frames/0031.png").exists());
    // No temporary files are left behind.
    assert!(
        std::fs::read_dir(&dir).unwrap().all(|e| !e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with(".tmp"))
    );
}

#[test]
fn explicit_window_in_path_length_units() {
    let dir = tempdir("window");
    let out = dir.to_str().unwrap();
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        out,
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
        "--bins",
        "10",
        "--t0",
        "1m",
        "--dt",
        "10cm",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("tprf.json")).unwrap()).unwrap();
    let c = 299_792_458.0;
    assert!((meta["t0_s"].as_f64().unwrap() - 1.0 / c).abs() < 1e-20);
    assert!((meta["dt_s"].as_f64().unwrap() - 0.1 / c).abs() < 1e-20);
}

#[test]
fn bad_input_gives_clear_errors() {
    let dir = tempdir("bad");
    let out = dir.to_str().unwrap();
    let cases: &[(&[&str], &str)] = &[
        (
            &["render", "builtin:nope", "--out", out],
            "unknown built-in scene",
        ),
        (
            &["render", "/no/such/file.glb", "--out", out],
            "/no/such/file.glb",
        ),
        (
            &["render", "builtin:cornell", "--out", out, "--width", "0"],
            "--width",
        ),
        (
            // 1 TiB of film: refused up front with its size, not killed by the kernel.
            &[
                "render",
                "builtin:cornell",
                "--out",
                out,
                "--width",
                "2048",
                "--height",
                "2048",
                "--bins",
                "16384",
                "--spp",
                "1",
            ],
            "GiB",
        ),
        (
            &[
                "render",
                "builtin:cornell",
                "--out",
                out,
                "--dt",
                "5 furlongs",
            ],
            "unknown unit",
        ),
        (
            &[
                "render",
                "builtin:cornell",
                "--out",
                out,
                "--dt=-1ns",
                "--t0",
                "0ns",
            ],
            "bin width",
        ),
        (
            &[
                "render",
                "builtin:cornell",
                "--out",
                out,
                "--seconds",
                "NaN",
            ],
            "--seconds",
        ),
        (
            &["render", "builtin:cornell", "--out", out, "--bins", "0"],
            "bins",
        ),
        (&["oned", "/no/such/world.json"], "world.json"),
    ];
    for (args, needle) in cases {
        let o = tprf(args);
        let e = stderr(&o);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(
            e.contains(needle),
            "{args:?}: error '{e}' should mention '{needle}'"
        );
        assert!(!e.contains("panicked"), "{args:?} panicked: {e}");
    }
}

#[test]
fn oned_prints_the_train() {
    let world = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/oned/figure4.json");
    let o = tprf(&["oned", world, "--t0", "0ns", "--dt", "1ns", "--bins", "400"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("time_ns") && text.contains("bin"));
}

fn tempdir(name: &str) -> std::path::PathBuf {
    let d =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

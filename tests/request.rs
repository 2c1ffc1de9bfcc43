//! One render request behind every front end: `tprf render`'s options and a batch
//! manifest's keys make the same request (the same files, bit for bit), the camera
//! override is applied and recorded, and a bad field is named where it was given.

mod common;

use common::cli::{json, stderr, tempdir, tprf};

fn vec3(v: &serde_json::Value) -> [f64; 3] {
    let a: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    [a[0], a[1], a[2]]
}

const SMALL: [&str; 8] = [
    "--width", "12", "--height", "10", "--bins", "16", "--spp", "2",
];

/// The pose given on the command line is the one rendered and recorded: position as
/// given, the camera's -Z column along (look-at - position) / |.|, its +Y column in the
/// plane of that direction and +Y, the field of view as given. Worked by hand: from
/// (0.5, 0.3, 2.0) toward (0, 0.3, 0) the direction is (-0.5, 0, -2) / sqrt(4.25).
#[test]
fn the_camera_override_is_rendered_and_recorded() {
    let dir = tempdir("camera");
    let out = dir.join("cam");
    let mut args = vec![
        "render",
        "builtin:cornell",
        "--out",
        out.to_str().unwrap(),
        "--camera-position",
        "0.5,0.3,2",
        "--look-at",
        "0,0.3,0",
        "--fov",
        "30",
    ];
    args.extend(SMALL);
    let o = tprf(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let cam = &json(&out.join("tprf.json"))["camera"];
    assert_eq!(vec3(&cam["position_m"]), [0.5, 0.3, 2.0]);
    assert!((cam["yfov_deg"].as_f64().unwrap() - 30.0).abs() < 1e-4);
    let m: Vec<f64> = cam["world_from_camera"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    // Column-major: column 2 (m[8..11]) is the camera's +Z, looking along its -Z.
    let n = 4.25f64.sqrt();
    let want_forward = [-0.5 / n, 0.0, -2.0 / n];
    for (i, w) in want_forward.iter().enumerate() {
        assert!((-m[8 + i] - w).abs() < 1e-6, "forward {:?}", &m[8..11]);
    }
    // Up: +Y is already across the view direction, so the camera's up is +Y itself.
    for (i, w) in [0.0, 1.0, 0.0].iter().enumerate() {
        assert!((m[4 + i] - w).abs() < 1e-6, "up {:?}", &m[4..7]);
    }
    // The scene's own camera looks into the box through its open front; turned to look
    // out of it, it sees nothing, and the pilot render says so.
    let away = dir.join("away");
    let mut args = vec![
        "render",
        "builtin:cornell",
        "--out",
        away.to_str().unwrap(),
        "--look-at",
        "0,0.2775,10",
    ];
    args.extend(SMALL);
    let o = tprf(&args);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("no light reaches the camera"),
        "{}",
        stderr(&o)
    );
}

/// A sweep over views in a manifest renders, per settings entry, the cube `tprf render`
/// renders with the same options: the keys are the options, the request the same.
#[test]
fn a_manifest_job_is_the_render_its_options_make() {
    let dir = tempdir("batch");
    let manifest = dir.join("views.toml");
    std::fs::write(
        &manifest,
        r#"
[defaults]
width = 12
height = 10
bins = 16
spp = 3
dt = "50ps"

[[sweep]]
scenes = ["builtin:cornell"]
out = "out/{settings}"
settings = [
  { name = "side", camera_position = [0.2, 0.3, 1.5], look_at = [0, 0.25, 0], fov = 45, uniform = true },
  { name = "plain", seed = 4, t0 = "0.9m" },
]
"#,
    )
    .unwrap();
    let o = tprf(&["batch", manifest.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cli = |name: &str, extra: &[&str]| {
        let out = dir.join(format!("cli-{name}"));
        let mut args = vec![
            "render",
            "builtin:cornell",
            "--out",
            out.to_str().unwrap(),
            "--width",
            "12",
            "--height",
            "10",
            "--bins",
            "16",
            "--spp",
            "3",
            "--dt",
            "50ps",
        ];
        args.extend_from_slice(extra);
        let o = tprf(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        out
    };
    let side = cli(
        "side",
        &[
            "--camera-position",
            "0.2,0.3,1.5",
            "--look-at",
            "0,0.25,0",
            "--fov",
            "45",
            "--uniform",
        ],
    );
    let plain = cli("plain", &["--seed", "4", "--t0", "0.9m"]);
    for (job, by_hand) in [("side", side), ("plain", plain)] {
        let from_batch = dir.join("out").join(job);
        assert_eq!(
            std::fs::read(from_batch.join("tprf.npy")).unwrap(),
            std::fs::read(by_hand.join("tprf.npy")).unwrap(),
            "{job}: the batch's cube is not tprf render's"
        );
        let (a, b) = (
            json(&from_batch.join("tprf.json")),
            json(&by_hand.join("tprf.json")),
        );
        for key in ["camera", "t0_s", "dt_s", "seed", "adaptive", "spp"] {
            assert_eq!(a[key], b[key], "{job}: {key}");
        }
    }
    assert_eq!(
        vec3(&json(&dir.join("out/side/tprf.json"))["camera"]["position_m"]),
        [0.2, 0.3, 1.5]
    );
}

/// A bad value in a manifest stops the batch before anything renders, naming the job
/// and the key; on the command line the same problem names the option.
#[test]
fn a_bad_field_is_named_where_it_was_given() {
    let dir = tempdir("bad");
    let manifest = dir.join("bad.toml");
    std::fs::write(
        &manifest,
        "[[job]]\nname = \"fine\"\nscene = \"builtin:cornell\"\nout = \"fine\"\nwidth = 8\n\
         height = 8\nbins = 8\nspp = 1\n\n[[job]]\nname = \"wide\"\nscene = \"builtin:cornell\"\n\
         out = \"wide\"\nwidth = 0\n",
    )
    .unwrap();
    let o = tprf(&["batch", manifest.to_str().unwrap()]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("job 'wide'") && e.contains("width: 0 pixels"),
        "{e}"
    );
    assert!(
        !dir.join("fine").exists(),
        "a job rendered before the refusal"
    );
    std::fs::write(
        &manifest,
        "[[job]]\nscene = \"builtin:cornell\"\nout = \"x\"\nfov = 200\n",
    )
    .unwrap();
    let e = stderr(&tprf(&["batch", manifest.to_str().unwrap()]));
    assert!(e.contains("fov = 200 degrees"), "{e}");
    let out = dir.join("cli");
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        out.to_str().unwrap(),
        "--fov",
        "200",
    ]);
    assert!(stderr(&o).contains("--fov = 200 degrees"), "{}", stderr(&o));
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        out.to_str().unwrap(),
        "--camera-position",
        "1,2,3",
        "--look-at",
        "1,2,3",
    ]);
    assert!(
        stderr(&o).contains("--look-at = 1,2,3 is the --camera-position"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

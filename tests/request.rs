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

/// A small Mitsuba scene whose film, sampler and integrator say every setting a file
/// can: 6 x 4 pixels, 20 bins from 9 m of optical path counted from a near plane 0.5 m
/// in front of the pinhole, bins of 0.1 m, 2 samples, depth 3 (2 scattering events).
const FILM_XML: &str = r#"<scene version="3.0.0">
    <integrator type="transient_path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <float name="near_clip" value="0.5"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="2"/></sampler>
        <film type="transient_hdr_film">
            <integer name="width" value="6"/>
            <integer name="height" value="4"/>
            <integer name="temporal_bins" value="20"/>
            <float name="start_opl" value="9"/>
            <float name="bin_width_opl" value="0.1"/>
        </film>
    </sensor>
    <emitter type="point"><point name="position" x="0" y="0" z="5"/><rgb name="intensity" value="1"/></emitter>
    <shape type="rectangle"><bsdf type="diffuse"/></shape>
</scene>
"#;

/// An XML scene's film reaches the request through `tprf render` and through a batch
/// job alike: each setting the file has fills the option or key not given (the window
/// from start_opl + near_clip, times as optical path over c, max_depth less the camera
/// segment), one given wins, and the batch's cube is `tprf render`'s with the same
/// options, bit for bit.
#[test]
fn an_xml_scenes_film_reaches_the_request_from_each_front_end() {
    let dir = tempdir("xml-film");
    let xml = dir.join("film.xml");
    std::fs::write(&xml, FILM_XML).unwrap();
    let c = 299_792_458.0;
    let check = |out: &std::path::Path, width: u64| {
        let m = json(&out.join("tprf.json"));
        assert_eq!(m["width"], width);
        assert_eq!(
            (m["height"].as_u64(), m["bins"].as_u64()),
            (Some(4), Some(20))
        );
        assert_eq!(
            (m["spp"].as_u64(), m["max_bounces"].as_u64()),
            (Some(2), Some(2))
        );
        assert_eq!(m["t0_s"].as_f64(), Some((9.0 + 0.5) / c));
        assert_eq!(m["dt_s"].as_f64(), Some(0.1 / c));
    };
    let cli = dir.join("cli");
    let o = tprf(&[
        "render",
        xml.to_str().unwrap(),
        "--out",
        cli.to_str().unwrap(),
        "--width",
        "5",
    ]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("from the scene file: --height 4 ("), "{e}");
    assert!(!e.contains("--width 6"), "{e}");
    check(&cli, 5);
    let manifest = dir.join("jobs.toml");
    std::fs::write(
        &manifest,
        "[[job]]\nscene = \"film.xml\"\nout = \"batch\"\nwidth = 5\n",
    )
    .unwrap();
    let o = tprf(&["batch", manifest.to_str().unwrap()]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("from the scene file: bins 20 ("), "{e}");
    check(&dir.join("batch"), 5);
    assert_eq!(
        std::fs::read(dir.join("batch/tprf.npy")).unwrap(),
        std::fs::read(cli.join("tprf.npy")).unwrap(),
        "the batch's cube is not tprf render's"
    );
    // The job is complete as the file made it: a second run skips it.
    let o = tprf(&["batch", manifest.to_str().unwrap()]);
    assert!(stderr(&o).contains("complete, skipped"), "{}", stderr(&o));
}

/// A manifest's `[[measure]]` job is the measurement `tprf sensor` makes with the same
/// options (its keys are the options' names): the same `sensor.npy`, bit for bit, made
/// after the render it reads; complete, it is skipped; a bad key is named.
#[test]
fn a_measure_job_is_the_measurement_its_options_make() {
    let dir = tempdir("measure-job");
    let manifest = dir.join("m.toml");
    std::fs::write(
        &manifest,
        "[[measure]]\nname = \"gated\"\ndir = \"cube\"\nout = \"gated\"\npreset = \"builtin:gated\"\n\
         seed = 7\nnoise_sigma = 0.01\npixel = [[1, 2]]\n\n\
         [[job]]\nscene = \"builtin:cornell\"\nout = \"cube\"\nwidth = 8\nheight = 6\nbins = 16\nspp = 2\n",
    )
    .unwrap();
    let o = tprf(&["batch", manifest.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let by_hand = dir.join("by-hand");
    let o = tprf(&[
        "sensor",
        dir.join("cube").to_str().unwrap(),
        "--preset",
        "builtin:gated",
        "--seed",
        "7",
        "--noise-sigma",
        "0.01",
        "--pixel",
        "1,2",
        "--out",
        by_hand.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for file in ["sensor.npy", "pixel_1_2.csv"] {
        assert_eq!(
            std::fs::read(dir.join("gated").join(file)).unwrap(),
            std::fs::read(by_hand.join(file)).unwrap(),
            "{file}: the batch's is not tprf sensor's"
        );
    }
    let o = tprf(&["batch", manifest.to_str().unwrap(), "--list"]);
    let listed = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(listed.contains("gated\tcomplete"), "{listed}");
    std::fs::write(
        &manifest,
        "[[measure]]\ndir = \"cube\"\nout = \"x\"\npreset = \"builtin:gated\"\nsed = 7\n",
    )
    .unwrap();
    let e = stderr(&tprf(&["batch", manifest.to_str().unwrap()]));
    assert!(e.contains("measure 1") && e.contains("sed"), "{e}");
}

/// A manifest's `[[capture]]` and `[[reconstruct]]` jobs are the capture and the
/// reconstruction `tprf nlos` and `tprf nlos reconstruct` make with the same options
/// (their keys are the options' names): the same `H.npy`, `nlos.hdf5` and `volume.npy`,
/// bit for bit, the reconstruction made after the capture it reads; `nlos.json` holds
/// the request; complete, they are skipped; a bad key is named.
#[test]
fn capture_and_reconstruct_jobs_are_what_their_options_make() {
    let dir = tempdir("nlos-jobs");
    let manifest = dir.join("n.toml");
    std::fs::write(
        &manifest,
        "[[reconstruct]]\ncapture = \"cap\"\nout = \"rec\"\nmethod = \"bp\"\n\
         volume = { center = [0, 0, 1], size = [1.5, 1.5, 1], voxels = [8, 8, 6] }\n\n\
         [[capture]]\nscene = \"builtin:nlos-z\"\nout = \"cap\"\ngrid = [6, 5]\nconfocal = true\n\
         spp = 8\ndt = \"1cm\"\n",
    )
    .unwrap();
    let o = tprf(&["batch", manifest.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cap = dir.join("by-hand-cap");
    let o = tprf(&[
        "nlos",
        "builtin:nlos-z",
        "--grid",
        "6x5",
        "--confocal",
        "--spp",
        "8",
        "--dt",
        "1cm",
        "--out",
        cap.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for file in ["H.npy", "nlos.hdf5"] {
        assert_eq!(
            std::fs::read(dir.join("cap").join(file)).unwrap(),
            std::fs::read(cap.join(file)).unwrap(),
            "{file}: the batch's is not tprf nlos's"
        );
    }
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("cap/nlos.json")).unwrap()).unwrap();
    assert_eq!(meta["request"]["grid"], serde_json::json!([6, 5]));
    assert_eq!(meta["request"]["confocal"], serde_json::json!(true));
    assert_eq!(meta["h_shape"], serde_json::json!([meta["bins"], 6, 5]));
    let rec = dir.join("by-hand-rec");
    let o = tprf(&[
        "nlos",
        "reconstruct",
        cap.to_str().unwrap(),
        "--method",
        "bp",
        "--volume",
        "0,0,1:1.5,1.5,1:8,8,6",
        "--out",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(dir.join("rec/volume.npy")).unwrap(),
        std::fs::read(rec.join("volume.npy")).unwrap(),
        "volume.npy: the batch's is not tprf nlos reconstruct's"
    );
    let o = tprf(&["batch", manifest.to_str().unwrap(), "--list"]);
    let listed = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        listed.contains("cap\tcomplete") && listed.contains("rec\tcomplete"),
        "{listed}"
    );
    std::fs::write(
        &manifest,
        "[[capture]]\nscene = \"builtin:nlos-z\"\nout = \"x\"\ngrid = [0, 4]\n",
    )
    .unwrap();
    let e = stderr(&tprf(&["batch", manifest.to_str().unwrap()]));
    assert!(e.contains("grid 0x4: a grid needs"), "{e}");
    std::fs::write(
        &manifest,
        "[[reconstruct]]\ncapture = \"cap\"\nout = \"y\"\nmethd = \"bp\"\n",
    )
    .unwrap();
    let e = stderr(&tprf(&["batch", manifest.to_str().unwrap()]));
    assert!(e.contains("reconstruct 1") && e.contains("methd"), "{e}");
}

/// `tprf.json` holds the request that made the cube (issue 43): read back, it is a
/// `RenderRequest` with the options given on the command line, and rendering it again
/// makes the same cube, bit for bit.
#[test]
fn a_cubes_json_holds_the_request_that_renders_it_again() {
    let dir = tempdir("request-echo");
    let first = dir.join("first");
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        first.to_str().unwrap(),
        "--width",
        "10",
        "--height",
        "8",
        "--bins",
        "24",
        "--spp",
        "4",
        "--seed",
        "7",
        "--t0",
        "0.5m",
        "--dt",
        "40ps",
        "--bounces-separate",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let meta = json(&first.join("tprf.json"));
    let request: tprf_core::request::RenderRequest =
        serde_json::from_value(meta["request"].clone()).expect("a render request");
    assert_eq!(
        (
            request.width,
            request.height,
            request.seed,
            request.bounces_separate
        ),
        (10, 8, 7, 2)
    );
    assert_eq!(request.scene, "builtin:cornell");
    let again = dir.join("again");
    struct Quiet;
    impl tprf_core::request::Observer for Quiet {}
    tprf_core::request::render_to_folder(&request, &again, &mut Quiet).expect("renders");
    for file in ["tprf.npy", "tprf_bounces.npy"] {
        assert!(
            std::fs::read(first.join(file)).unwrap() == std::fs::read(again.join(file)).unwrap(),
            "{file} differs when rendered again from tprf.json's request"
        );
    }
    assert_eq!(json(&again.join("tprf.json"))["request"], meta["request"]);
}

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
    // Doubling passes cut to keep the two halves equal: 1, 1, then 1, 1 (not 2, 2).
    assert_eq!(meta["passes"], 4);
    assert!(meta["render_seconds"].as_f64().unwrap() > 0.0);
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
            // A 256 GiB dense cube file asked for: refused up front with its size, not
            // after the render when the disk fills.
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
                "--format",
                "npy",
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
        (
            &["render", "builtin:cornell", "--out", out, "--t0", "100ns"],
            "no light arrives after the window start",
        ),
        (
            &["render", "builtin:cornell", "--out", out, "--dt", "0ns"],
            "bin width 0 s",
        ),
        (
            &[
                "oned",
                "assets/oned/figure4.json",
                "--t0",
                "0ns",
                "--dt",
                "1ns",
                "--bins",
                "0",
            ],
            "--bins 0",
        ),
        (
            &[
                "oned",
                "assets/oned/figure4.json",
                "--t0",
                "0ns",
                "--dt",
                "1ns",
                "--bins",
                "100000000000",
            ],
            "--bins 100000000000",
        ),
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

#[test]
fn a_zarr_cube_holds_what_the_npy_cube_holds_and_reads_back() {
    let dir = tempdir("zarr");
    let (zdir, ndir) = (dir.join("z"), dir.join("n"));
    // 40 x 36 pixels and 300 bins: edge tiles and an edge time chunk (chunks 32x32x256);
    // 2 bounces kept apart: 4 layers.
    for (out, format) in [(&zdir, "zarr"), (&ndir, "npy")] {
        let o = tprf(&[
            "render",
            "builtin:cornell",
            "--out",
            out.to_str().unwrap(),
            "--width",
            "40",
            "--height",
            "36",
            "--bins",
            "300",
            "--spp",
            "4",
            "--bounces-separate",
            "2",
            "--format",
            format,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert!(zdir.join("tprf.zarr/zarr.json").exists() && !zdir.join("tprf.npy").exists());
    assert!(!zdir.join("tprf_bounces.npy").exists());
    let (_, dense) = tprf_core::export::read_cube(&ndir.join("tprf.npy")).unwrap();
    let (bshape, bounces) =
        tprf_core::export::read_npy_f32(&ndir.join("tprf_bounces.npy")).unwrap();
    assert_eq!(bshape, vec![4, 36, 40, 300]);
    let plane = dense.len();
    // Read through the Zarr reader, tile by tile, and as a snapshot.
    let z = tprf_core::export::zarr::ZarrCube::open(&zdir.join("tprf.zarr")).unwrap();
    assert_eq!((z.width, z.height, z.bins, z.layers()), (40, 36, 300, 4));
    let t = 300;
    for (y0, x0, rows, cols) in z.tiles() {
        for layer in [None, Some(0), Some(1), Some(2), Some(3)] {
            let want = match layer {
                None => &dense[..],
                Some(l) => &bounces[l * plane..(l + 1) * plane],
            };
            let tile = z.read_tile(y0, x0, rows, cols, layer).unwrap();
            for dy in 0..rows {
                for dx in 0..cols {
                    let p = ((y0 + dy) * 40 + x0 + dx) * t;
                    let q = (dy * cols + dx) * t;
                    assert_eq!(&tile[q..q + t], &want[p..p + t], "layer {layer:?}");
                }
            }
        }
    }
    assert!(z.read_tile(0, 0, 1, 1, Some(4)).is_err());
    let (meta, snap) = tprf_core::export::load_snapshot(&zdir).unwrap();
    assert_eq!(meta.spp, 4);
    assert_eq!(snap.dense(None), dense);
    assert_eq!(snap.layers(), 4);
    for l in 0..4 {
        assert_eq!(snap.dense(Some(l)), &bounces[l * plane..(l + 1) * plane]);
    }
    // Only lit bins are kept.
    assert_eq!(
        snap.stored_bins(),
        dense.iter().filter(|v| **v != 0.0).count() as u64
    );
    // `tprf sensor` measures the Zarr cube as it measures the npy one; AMCW takes its
    // reference depth from the single-scattering layer of either; the SPAD's histograms,
    // realisation and depths are the same from either.
    for preset in ["lidar", "amcw", "spad"] {
        for d in [&zdir, &ndir] {
            let o = tprf(&[
                "sensor",
                d.to_str().unwrap(),
                "--preset",
                &format!("builtin:{preset}"),
                "--pixel",
                "33,39",
                "--out",
                d.join(preset).to_str().unwrap(),
            ]);
            assert!(o.status.success(), "{}", stderr(&o));
        }
        let files = match preset {
            "amcw" => &["sensor.npy", "true_depth.npy", "pixel_33_39.csv"][..],
            "spad" => &[
                "sensor.npy",
                "pixel_33_39.csv",
                "spad_histogram.npy",
                "spad_counts.npy",
                "spad_coates.npy",
                "spad_depth_histogram.npy",
                "spad_depth_counts.npy",
                "spad_depth_coates.npy",
            ][..],
            _ => &["sensor.npy", "pixel_33_39.csv"][..],
        };
        for f in files {
            assert_eq!(
                std::fs::read(zdir.join(preset).join(f)).unwrap(),
                std::fs::read(ndir.join(preset).join(f)).unwrap(),
                "{preset}: {f}"
            );
        }
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(ndir.join("amcw/sensor.json")).unwrap()).unwrap();
    assert!(
        json["derived"]["amcw"]["true_depth"]
            .as_str()
            .unwrap()
            .contains("single-scattering layer"),
        "{json}"
    );
    // Measured a tile at a time (a memory budget below one chunk's pixels: 2 x 2 tiles,
    // or one band of 32 rows: 2 tiles), the Zarr cube gives what the whole npy cube
    // measured at once gives.
    use tprf_core::export::sensor::{SensorCube, measure_cube};
    use tprf_core::sensor::{Sensor, SensorModel, derived};
    let cube = SensorCube::open(&zdir).unwrap();
    let axis = cube.axis;
    let single = &bounces[plane..2 * plane];
    for (preset, budget, tiles) in [
        ("builtin:lidar", 1, 4),
        ("builtin:amcw", 1, 4),
        ("builtin:lidar", 40 * 32 * 300 * 4, 2),
    ] {
        let model = SensorModel::new(Sensor::load(preset).unwrap(), axis).unwrap();
        let pixels = [(33, 39), (0, 0), (31, 32)];
        let tiled = measure_cube(&cube, &model, &pixels, budget).unwrap();
        assert_eq!(tiled.tiles, tiles, "{preset}");
        assert_eq!(
            tiled.measurements,
            model.measure_clean(&dense, 40, 36).unwrap(),
            "{preset}"
        );
        for ((y, x), trace) in pixels.iter().zip(&tiled.traces) {
            let p = (y * 40 + x) * t;
            assert_eq!(trace, &dense[p..p + t]);
        }
        match tiled.true_depth {
            Some((depth, _)) => {
                let want = derived::tprf_centroid_depth(single, 40, 36, &axis);
                let bits = |v: &[f32]| v.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&depth), bits(&want));
                assert!(want.iter().any(|d| d.is_finite()));
            }
            None => assert_eq!(preset, "builtin:lidar"),
        }
    }
    // The SPAD from a Zarr cube measured in 4 tiles is the SPAD of the whole npy cube:
    // the steady image gathered tile by tile is each pixel's sum of its TPRF, and the
    // histograms, realisation, Coates estimate and depths follow.
    use tprf_core::sensor::spad_image;
    let model = SensorModel::new(Sensor::load("builtin:spad").unwrap(), axis).unwrap();
    let tiled = measure_cube(&cube, &model, &[], 1).unwrap();
    assert_eq!(tiled.tiles, 4);
    let steady: Vec<f32> = dense
        .chunks_exact(t)
        .map(|px| px.iter().map(|&v| f64::from(v)).sum::<f64>() as f32)
        .collect();
    assert_eq!(tiled.steady.as_deref(), Some(&steady[..]));
    let from_tiles = spad_image(&model, &tiled.measurements, &steady).unwrap();
    let whole = spad_image(
        &model,
        &model.measure_clean(&dense, 40, 36).unwrap(),
        &steady,
    )
    .unwrap();
    let bits = |v: &[f32]| v.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&from_tiles.histogram), bits(&whole.histogram));
    assert_eq!(bits(&from_tiles.counts), bits(&whole.counts));
    assert_eq!(bits(&from_tiles.coates), bits(&whole.coates));
    for (a, b) in [
        (&from_tiles.depth_histogram_m, &whole.depth_histogram_m),
        (&from_tiles.depth_counts_m, &whole.depth_counts_m),
        (&from_tiles.depth_coates_m, &whole.depth_coates_m),
    ] {
        assert_eq!(bits(a), bits(b));
    }
    assert_eq!(from_tiles.sampler, whole.sampler);
    assert!(whole.expected_detections > 0.0);
    assert!(whole.counts.iter().any(|&c| c > 0.0));
    assert!(whole.depth_histogram_m.iter().any(|d| d.is_finite()));
    // Rendering the npy form over it removes the stale Zarr array.
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        zdir.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
        "--format",
        "npy",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!zdir.join("tprf.zarr").exists() && zdir.join("tprf.npy").exists());
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        zdir.to_str().unwrap(),
        "--format",
        "hdf5",
    ]);
    assert!(!o.status.success() && stderr(&o).contains("auto, npy or zarr"));
}

#[test]
fn a_cube_with_a_nan_bin_is_refused_by_the_sensor_naming_the_bin() {
    let dir = tempdir("nan");
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        dir.to_str().unwrap(),
        "--width",
        "6",
        "--height",
        "4",
        "--bins",
        "16",
        "--spp",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let npy = dir.join("tprf.npy");
    let (_, mut cube) = tprf_core::export::read_cube(&npy).unwrap();
    // Row 2, column 3, bin 5.
    cube[(2 * 6 + 3) * 16 + 5] = f32::NAN;
    tprf_core::export::write_npy_f32(&npy, &[4, 6, 16], &cube).unwrap();
    let out = dir.join("s");
    let o = tprf(&[
        "sensor",
        dir.to_str().unwrap(),
        "--preset",
        "builtin:lidar",
        "--out",
        out.to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert!(!o.status.success(), "a NaN cube was measured");
    assert!(e.contains("row 2, column 3") && e.contains("bin 5"), "{e}");
    assert!(!out.join("sensor.npy").exists());
}

#[test]
fn a_render_replaces_the_whole_folder_and_leaves_nothing_beside_it() {
    let dir = tempdir("swap");
    let out = dir.join("cube");
    let o_str = out.to_str().unwrap();
    let small = ["--width", "6", "--height", "4", "--bins", "8", "--spp", "1"];
    let run = |extra: &[&str]| {
        let mut args = vec!["render", "builtin:cornell", "--out", o_str];
        args.extend_from_slice(&small);
        args.extend_from_slice(extra);
        tprf(&args)
    };
    let o = run(&["--frames", "--bounces-separate", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("frames/0000.png").exists() && out.join("tprf_bounces.npy").exists());
    std::fs::write(out.join("mine.txt"), "a file of the user's").unwrap();
    // A render that fails leaves the folder as it was.
    // (The window starts long after the Cornell box's light has died out.)
    let o = run(&["--t0", "1s"]);
    assert!(!o.status.success(), "{}", stderr(&o));
    assert!(out.join("tprf_bounces.npy").exists() && out.join("mine.txt").exists());
    // The user's file is never deleted: the render is refused, naming it, until it is
    // moved out (tests/never_destroy.rs has the other cases).
    let o = run(&[]);
    assert!(!o.status.success() && stderr(&o).contains("mine.txt"));
    assert!(out.join("mine.txt").exists() && out.join("tprf_bounces.npy").exists());
    std::fs::remove_file(out.join("mine.txt")).unwrap();
    // A new render replaces the folder: nothing of the earlier render is left to be read.
    let o = run(&[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("tprf.npy").exists() && out.join("tprf.json").exists());
    assert!(!out.join("frames").exists() && !out.join("tprf_bounces.npy").exists());
    let beside: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        beside,
        vec!["cube".to_string()],
        "left beside the folder: {beside:?}"
    );
}

#[test]
fn sensor_with_a_spad_writes_histograms_that_follow_the_first_photon_law() {
    let dir = tempdir("spad");
    let (w, h, bins) = (8usize, 6usize, 32usize);
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        dir.to_str().unwrap(),
        "--width",
        &w.to_string(),
        "--height",
        &h.to_string(),
        "--bins",
        &bins.to_string(),
        "--spp",
        "4",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (meta, cube) = tprf_core::export::read_cube(&dir.join("tprf.npy")).unwrap();
    // A delta pulse at t = 0, TDC bins that are the film's bins, a dead time of the
    // whole cycle: per pixel the SPAD fires at most once a cycle, in a fraction
    // 1 - exp(-R) of them, R = PDE (ppu steady + ambient T) + DCR T, T = the cycle.
    let (n, pde, ppu, ambient_hz, dcr_hz) = (1000.0, 0.5, 2.0, 3e7, 2e6);
    let cycle_s = meta.dt_s * bins as f64;
    let toml = format!(
        "[light]\nkind = \"delta\"\n\
         [exposure]\nkind = \"tdc\"\norigin = \"window\"\nstart = 0\nbin_width = {dt:e}\nbins = {bins}\n\
         [spad]\ncycles = {n}\npde = {pde}\nphotons_per_unit = {ppu}\nambient_rate = {ambient_hz:e}\n\
         dark_count_rate = {dcr_hz:e}\ndead_time = {cycle_s:e}\n",
        dt = meta.dt_s,
        n = n as u64,
    );
    let preset = dir.join("spad.toml");
    std::fs::write(&preset, toml).unwrap();
    let out = dir.join("s");
    let o = tprf(&[
        "sensor",
        dir.to_str().unwrap(),
        "--preset",
        preset.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (shape, hist) = tprf_core::export::read_npy_f32(&out.join("spad_histogram.npy")).unwrap();
    assert_eq!(shape, vec![bins as u64, h as u64, w as u64]);
    let (_, counts) = tprf_core::export::read_npy_f32(&out.join("spad_counts.npy")).unwrap();
    let (_, coates) = tprf_core::export::read_npy_f32(&out.join("spad_coates.npy")).unwrap();
    for p in 0..w * h {
        let steady: f64 = cube[p * bins..(p + 1) * bins]
            .iter()
            .map(|&v| f64::from(v))
            .sum();
        let r = pde * (ppu * steady + ambient_hz * cycle_s) + dcr_hz * cycle_s;
        let want = n * (1.0 - (-r).exp());
        let got: f64 = (0..bins).map(|k| f64::from(hist[k * w * h + p])).sum();
        assert!(
            (got - want).abs() <= 1e-4 * want,
            "pixel {p}: {got} vs {want}"
        );
        let drawn: Vec<f64> = (0..bins)
            .map(|k| f64::from(counts[k * w * h + p]))
            .collect();
        assert!(drawn.iter().all(|c| c.fract() == 0.0 && *c >= 0.0));
        assert!(drawn.iter().sum::<f64>() <= n);
        // The Coates estimate of bin 0 is -N ln(1 - h_0 / N): nothing before it.
        let h0 = drawn[0];
        if h0 < n {
            let c0 = f64::from(coates[p]);
            let want = -n * (1.0 - h0 / n).ln();
            assert!(
                (c0 - want).abs() <= 1e-4 * want.max(1.0),
                "pixel {p}: {c0} vs {want}"
            );
        }
    }
    for name in ["histogram", "counts", "coates"] {
        let (shape, _) =
            tprf_core::export::read_npy_f32(&out.join(format!("spad_depth_{name}.npy"))).unwrap();
        assert_eq!(shape, vec![h as u64, w as u64]);
        assert!(out.join(format!("spad_depth_{name}.png")).exists());
    }
    // sensor.json records every parameter with its unit.
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("sensor.json")).unwrap()).unwrap();
    let params = &json["derived"]["spad"]["parameters"];
    for (key, value) in [
        ("cycles", n),
        ("pde", pde),
        ("ambient_rate_hz", ambient_hz),
        ("dark_count_rate_hz", dcr_hz),
        ("dead_bins", bins as f64),
    ] {
        assert_eq!(params[key]["value"].as_f64(), Some(value), "{key}");
        assert!(params[key]["unit"].is_string(), "{key}");
    }
    // The built-in preset runs; a bad override is refused, naming the field.
    let o = tprf(&[
        "sensor",
        dir.to_str().unwrap(),
        "--preset",
        "builtin:spad",
        "--cycles",
        "0",
        "--out",
        dir.join("bad").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("spad.cycles"), "{}", stderr(&o));
    let o = tprf(&[
        "sensor",
        dir.to_str().unwrap(),
        "--preset",
        "builtin:spad",
        "--out",
        dir.join("builtin").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("builtin/spad_depth_coates.png").exists());
}

/// `--until-stopped` renders until Ctrl-C (it has no other end), then ends the pass
/// running and writes the passes made, with exit status 0.
#[cfg(unix)]
#[test]
fn until_stopped_renders_until_ctrl_c_and_writes_what_it_made() {
    use std::io::{BufRead, BufReader};
    let dir = tempdir("until-stopped");
    let out = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args([
            "render",
            "builtin:cornell",
            "--width",
            "8",
            "--height",
            "8",
            "--bins",
            "8",
            "--threads",
            "1",
            "--until-stopped",
            "--out",
        ])
        .arg(&out)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut said = String::new();
    while !said.contains("rendering until Ctrl-C") {
        let mut line = String::new();
        assert!(err.read_line(&mut line).unwrap() > 0, "ended early: {said}");
        said += &line;
    }
    std::thread::sleep(std::time::Duration::from_millis(300));
    // SAFETY: a signal to the child this test started.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    let status = child.wait().unwrap();
    assert!(status.success(), "{status}: {said}{rest}");
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("tprf.json")).unwrap()).unwrap();
    let (spp, passes) = (
        meta["spp"].as_u64().unwrap(),
        meta["passes"].as_u64().unwrap(),
    );
    assert!(passes >= 1 && spp >= passes, "{spp} spp in {passes} passes");
    assert!(
        out.join("tprf.npy").is_file() && rest.contains("wrote"),
        "{rest}"
    );
}

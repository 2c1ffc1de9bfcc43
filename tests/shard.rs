//! Sharded renders through the `tprf` binary: `tprf render --shard K/N` then
//! `tprf merge` give what one `tprf render` of the whole image gives, bit for bit (the
//! cube files, the steady image, `tprf.json` apart from timings, the error estimate);
//! shards of another render, missing, repeated or truncated shards are refused.

use std::path::{Path, PathBuf};
mod common;

use common::cli::{json, stderr, tempdir, tprf};
use std::process::Output;

/// `tprf render SCENE --out OUT ARGS...`, which must succeed.
fn render(scene: &str, out: &Path, args: &[&str]) {
    let mut all = vec!["render", scene, "--out", out.to_str().unwrap()];
    all.extend_from_slice(args);
    let o = tprf(&all);
    assert!(o.status.success(), "tprf {all:?}: {}", stderr(&o));
}

/// `tprf merge OUT SHARDS...`.
fn merge(out: &Path, shards: &[PathBuf]) -> Output {
    let mut all = vec!["merge".to_string(), out.to_str().unwrap().to_string()];
    all.extend(shards.iter().map(|s| s.to_str().unwrap().to_string()));
    let refs: Vec<&str> = all.iter().map(String::as_str).collect();
    tprf(&refs)
}

/// Render the N shards of a render into `dir/sK` (shard args `args` plus `--shard`).
fn shards(dir: &Path, scene: &str, args: &[&str], n: usize) -> Vec<PathBuf> {
    (0..n)
        .map(|k| {
            let out = dir.join(format!("s{k}-of-{n}"));
            let spec = format!("{k}/{n}");
            let mut a = args.to_vec();
            a.extend(["--shard", &spec]);
            render(scene, &out, &a);
            out
        })
        .collect()
}

/// `tprf.json` without what depends on the machine's speed and cores.
fn json_without_timings(path: &Path) -> serde_json::Value {
    let mut v = json(path);
    let m = v.as_object_mut().unwrap();
    for k in ["wall_seconds", "render_seconds", "threads"] {
        assert!(m.remove(k).is_some(), "{k} missing from {}", path.display());
    }
    // How many rows a shard writes at a time is how its files were written, not what
    // they hold.
    if let Some(r) = m.get_mut("request").and_then(|r| r.as_object_mut()) {
        r.remove("band_rows");
    }
    v
}

fn bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Every file under `dir`, relative path -> bytes.
fn tree(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    let mut out = std::collections::BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.strip_prefix(dir).unwrap().to_path_buf(), bytes(&p));
            }
        }
    }
    out
}

/// A small render with light in most rows, per-bounce layers and an uneven last band.
const NPY: &[&str] = &[
    "--uniform",
    "--width",
    "20",
    "--height",
    "14",
    "--spp",
    "6",
    "--bins",
    "40",
    "--bounces-separate",
    "1",
    "--seed",
    "3",
    "--band-rows",
    "3",
    "--format",
    "npy",
];

/// `args` without `--band-rows R` (a one-process render takes no bands).
fn unsharded<'a>(args: &[&'a str]) -> Vec<&'a str> {
    let mut out = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if *a == "--band-rows" {
            it.next();
        } else {
            out.push(*a);
        }
    }
    out
}

#[test]
fn merged_npy_shards_are_the_one_process_render_bit_for_bit() {
    let dir = tempdir("npy");
    let one = dir.join("one");
    render("builtin:cornell", &one, &unsharded(NPY));
    let one_meta = json(&one.join("tprf.json"));
    assert!(one_meta.get("shard").is_none());
    for n in [1, 2, 3] {
        let parts = shards(&dir, "builtin:cornell", NPY, n);
        // A shard renders its rows only: the others are zero.
        if n == 3 {
            let (_, data) = tprf_core::export::read_npy_f32(&parts[1].join("tprf.npy")).unwrap();
            let row = 20 * 40;
            for y in 0..14 {
                let lit = data[y * row..(y + 1) * row].iter().any(|&v| v != 0.0);
                if (y / 3) % 3 != 1 {
                    assert!(!lit, "shard 1 of 3 wrote row {y}");
                }
            }
            let meta = json(&parts[1].join("tprf.json"));
            assert_eq!(meta["shard"]["rows"], serde_json::json!([[3, 6], [12, 14]]));
        }
        // In any order.
        let mut given = parts.clone();
        given.reverse();
        let merged = dir.join(format!("merged-{n}"));
        let o = merge(&merged, &given);
        assert!(o.status.success(), "{}", stderr(&o));
        for f in ["tprf.npy", "tprf_bounces.npy", "steady.png"] {
            assert!(
                bytes(&one.join(f)) == bytes(&merged.join(f)),
                "{f} of {n} merged shards differs from the one-process render"
            );
        }
        assert_eq!(
            json_without_timings(&one.join("tprf.json")),
            json_without_timings(&merged.join("tprf.json")),
            "tprf.json of {n} merged shards"
        );
        let m = json(&merged.join("tprf.json"));
        assert!(one_meta["error_estimate"].as_f64().unwrap() > 0.0);
        assert_eq!(
            one_meta["error_estimate"].as_f64().unwrap().to_bits(),
            m["error_estimate"].as_f64().unwrap().to_bits()
        );
        assert!(!merged.join(tprf_core::export::shard::STEADY_NAME).exists());
    }
}

#[test]
fn merged_shards_of_a_scene_with_a_sun_carry_its_ambient_image() {
    // builtin:canopy has a sun: every shard renders the whole ambient image (the same
    // for the same seed) and the merge keeps one copy, as one process writes it.
    let dir = tempdir("ambient");
    let args = [
        "--uniform",
        "--width",
        "24",
        "--height",
        "20",
        "--bins",
        "32",
        "--spp",
        "2",
        "--band-rows",
        "4",
    ];
    let one = dir.join("one");
    render("builtin:canopy", &one, &unsharded(&args));
    for format in ["npy", "zarr"] {
        let mut a = args.to_vec();
        a.extend(["--format", format]);
        let parts = shards(&dir.join(format), "builtin:canopy", &a, 2);
        let merged = dir.join(format!("merged-{format}"));
        let o = merge(&merged, &parts);
        assert!(o.status.success(), "{}", stderr(&o));
        let meta = tprf_core::export::load_snapshot(&merged).unwrap().0;
        let got = tprf_core::export::ambient::load_ambient(&merged, &meta).unwrap();
        let want = tprf_core::export::ambient::load_ambient(
            &one,
            &tprf_core::export::load_snapshot(&one).unwrap().0,
        )
        .unwrap();
        assert!(want.is_some(), "the canopy has a sun");
        assert_eq!(got, want, "{format}: the merged ambient image");
        assert!(merged.join("ambient.png").is_file());
    }
}

#[test]
fn merged_zarr_shards_are_the_one_process_store_chunk_for_chunk() {
    let dir = tempdir("zarr");
    // 3 bands of 32 rows (the chunk height), an edge tile in x, two time chunks.
    let args = [
        "--uniform",
        "--width",
        "40",
        "--height",
        "96",
        "--spp",
        "4",
        "--bins",
        "300",
        "--bounces-separate",
        "1",
        "--format",
        "zarr",
    ];
    let one = dir.join("one");
    render("builtin:cornell", &one, &args);
    // Bands of whole chunks (the default: every chunk file linked), and thinner bands
    // whose chunks the merge puts together from several shards.
    for (n, band_rows) in [(1, "32"), (2, "32"), (3, "32"), (3, "8"), (2, "12")] {
        let sharded = [&args[..], &["--band-rows", band_rows]].concat();
        let parts: Vec<PathBuf> = shards(&dir, "builtin:cornell", &sharded, n)
            .into_iter()
            .enumerate()
            .map(|(k, p)| {
                let to = dir.join(format!("b{band_rows}-s{k}-of-{n}"));
                std::fs::rename(&p, &to).unwrap();
                to
            })
            .collect();
        let merged = dir.join(format!("merged-{n}-{band_rows}"));
        let o = merge(&merged, &parts);
        assert!(o.status.success(), "{}", stderr(&o));
        let linked_all = stderr(&o).contains(" 0 put together");
        assert_eq!(linked_all, band_rows == "32", "{}", stderr(&o));
        let (a, b) = (
            tree(&one.join("tprf.zarr")),
            tree(&merged.join("tprf.zarr")),
        );
        assert_eq!(
            a.keys().collect::<Vec<_>>(),
            b.keys().collect::<Vec<_>>(),
            "the chunk files of {n} merged shards"
        );
        let mut chunks = 0;
        for (path, one_bytes) in &a {
            // The group's zarr.json holds tprf.json, timings included.
            if path.as_os_str() == "zarr.json" {
                continue;
            }
            assert!(
                *one_bytes == b[path],
                "{} differs ({n} shards of {band_rows} rows)",
                path.display()
            );
            chunks += path.starts_with("cube/c") as usize;
        }
        assert!(chunks > 4, "only {chunks} chunks");
        assert_eq!(
            json_without_timings(&one.join("tprf.json")),
            json_without_timings(&merged.join("tprf.json"))
        );
        // The merged store reads back as the cube.
        let cube = tprf_core::export::zarr::ZarrCube::open(&merged.join("tprf.zarr")).unwrap();
        assert!(cube.meta.shard.is_none());
        assert_eq!(
            bytes(&one.join("steady.png")),
            bytes(&merged.join("steady.png"))
        );
    }
}

/// A fixed window, so two renders of other settings still agree on it.
const SMALL: &[&str] = &[
    "--uniform",
    "--width",
    "16",
    "--height",
    "8",
    "--spp",
    "2",
    "--bins",
    "16",
    "--band-rows",
    "4",
    "--t0",
    "3m",
    "--dt",
    "0.5m",
];

fn shard_with(dir: &Path, name: &str, k: usize, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let spec = format!("{k}/2");
    // SMALL with the flags of `extra` given other values.
    let mut a = SMALL.to_vec();
    for pair in extra.chunks(2) {
        match a.iter().position(|x| *x == pair[0]) {
            Some(i) => a[i + 1] = pair[1],
            None => a.extend_from_slice(pair),
        }
    }
    a.extend(["--shard", &spec]);
    render("builtin:cornell", &out, &a);
    out
}

/// The merge fails, naming what `wanted` says, and writes nothing.
fn refused(dir: &Path, parts: &[PathBuf], wanted: &[&str]) {
    let out = dir.join("merged");
    let o = merge(&out, parts);
    let e = stderr(&o);
    assert!(!o.status.success(), "merged anyway");
    for w in wanted {
        assert!(e.contains(w), "the message lacks '{w}': {e}");
    }
    assert!(!e.contains("panicked"), "{e}");
    assert!(!out.exists(), "a refused merge wrote {}", out.display());
}

#[test]
fn shards_of_another_render_are_refused_naming_the_difference() {
    let dir = tempdir("mismatch");
    let s0 = shard_with(&dir, "s0", 0, &[]);
    let s1 = shard_with(&dir, "s1", 1, &[]);
    // The good pair merges.
    let ok = merge(&dir.join("ok"), &[s0.clone(), s1.clone()]);
    assert!(ok.status.success(), "{}", stderr(&ok));

    let seed = shard_with(&dir, "seed", 1, &["--seed", "7"]);
    refused(
        &dir,
        &[s0.clone(), seed],
        &["shard 1", "seed 7", "shard 0", "seed 0"],
    );

    let scene_dir = dir.join("scene");
    let o = tprf(&[
        "render",
        &format!("{}/assets/cornell.gltf", env!("CARGO_MANIFEST_DIR")),
        "--out",
        scene_dir.to_str().unwrap(),
        "--uniform",
        "--width",
        "16",
        "--height",
        "8",
        "--spp",
        "2",
        "--bins",
        "16",
        "--band-rows",
        "4",
        "--t0",
        "3m",
        "--dt",
        "0.5m",
        "--shard",
        "1/2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    refused(
        &dir,
        &[s0.clone(), scene_dir],
        &["scene", "fnv1a64:", "builtin:cornell"],
    );

    let window = shard_with(&dir, "window", 1, &["--t0", "4m"]);
    refused(&dir, &[s0.clone(), window], &["t0_s"]);
    let width = shard_with(&dir, "width", 1, &["--width", "18"]);
    refused(&dir, &[s0.clone(), width], &["width 18", "width 16"]);
    let spp = shard_with(&dir, "spp", 1, &["--spp", "3"]);
    refused(&dir, &[s0.clone(), spp], &["spp 3", "spp 2"]);

    // One of three shards is not a shard of two.
    let out = dir.join("third");
    let mut third = SMALL.to_vec();
    let at = third.iter().position(|a| *a == "--band-rows").unwrap();
    third[at + 1] = "2";
    third.extend(["--shard", "2/3"]);
    render("builtin:cornell", &out, &third);
    refused(
        &dir,
        &[s0.clone(), s1.clone(), out],
        &["shard count n 3", "shard count n 2"],
    );
}

#[test]
fn a_missing_repeated_or_truncated_shard_is_refused() {
    let dir = tempdir("broken");
    let s0 = shard_with(&dir, "s0", 0, &[]);
    let s1 = shard_with(&dir, "s1", 1, &[]);
    refused(
        &dir,
        std::slice::from_ref(&s0),
        &["shard 1 of 2 is missing", "given: 0"],
    );
    let again = dir.join("s0-again");
    std::fs::create_dir_all(&again).unwrap();
    for e in std::fs::read_dir(&s0).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, again.join(p.file_name().unwrap())).unwrap();
    }
    refused(
        &dir,
        &[s0.clone(), again, s1.clone()],
        &["shard 0 is given twice"],
    );

    // Truncated: the cube file cut short by a byte.
    let cut = dir.join("cut");
    std::fs::create_dir_all(&cut).unwrap();
    for e in std::fs::read_dir(&s1).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, cut.join(p.file_name().unwrap())).unwrap();
    }
    let npy = cut.join("tprf.npy");
    let len = std::fs::metadata(&npy).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&npy)
        .unwrap()
        .set_len(len - 1)
        .unwrap();
    refused(
        &dir,
        &[s0.clone(), cut.clone()],
        &["shard 1", "tprf.npy", "truncated"],
    );
    std::fs::remove_file(&npy).unwrap();
    refused(
        &dir,
        &[s0.clone(), cut],
        &["shard 1", "cannot open tprf.npy"],
    );

    // Metadata that claims an enormous image: refused, nothing allocated for it.
    for (field, value, wanted) in [
        ("height", 1u64 << 40, "bands of rows"),
        ("width", 1u64 << 40, "memory"),
        ("width", 1u64 << 62, "overflows"),
    ] {
        let huge: Vec<PathBuf> = [&s0, &s1]
            .iter()
            .enumerate()
            .map(|(k, from)| {
                let to = dir.join(format!("huge-{field}-{value}-{k}"));
                let _ = std::fs::remove_dir_all(&to);
                std::fs::create_dir_all(&to).unwrap();
                for e in std::fs::read_dir(from).unwrap() {
                    let p = e.unwrap().path();
                    std::fs::copy(&p, to.join(p.file_name().unwrap())).unwrap();
                }
                let mut meta = json(&to.join("tprf.json"));
                meta[field] = serde_json::json!(value);
                std::fs::write(to.join("tprf.json"), meta.to_string()).unwrap();
                to
            })
            .collect();
        refused(&dir, &huge, &[wanted]);
    }

    // A whole render is not a shard.
    let whole = dir.join("whole");
    render("builtin:cornell", &whole, &unsharded(SMALL));
    refused(&dir, &[s0, whole], &["not a shard"]);
}

#[test]
fn shard_settings_that_cannot_be_split_are_refused() {
    let dir = tempdir("settings");
    let out = dir.join("x");
    let run = |extra: &[&str]| {
        let mut a = vec![
            "render",
            "builtin:cornell",
            "--out",
            out.to_str().unwrap(),
            "--width",
            "8",
            "--height",
            "8",
            "--bins",
            "8",
        ];
        a.extend_from_slice(extra);
        let o = tprf(&a);
        assert!(!o.status.success(), "{extra:?} rendered");
        assert!(!out.exists());
        stderr(&o)
    };
    let e = run(&[
        "--uniform",
        "--spp",
        "2",
        "--shard",
        "0/3",
        "--band-rows",
        "4",
    ]);
    assert!(e.contains("2 band(s), fewer than the 3 shards"), "{e}");
    let e = run(&["--uniform", "--seconds", "1", "--shard", "0/2"]);
    assert!(e.contains("--seconds") && e.contains("--shard"), "{e}");
    let e = run(&["--uniform", "--spp", "2", "--shard", "2/2"]);
    assert!(e.contains("K/N"), "{e}");
    let e = run(&[
        "--uniform",
        "--spp",
        "2",
        "--shard",
        "0/2",
        "--band-rows",
        "0",
    ]);
    assert!(e.contains("--band-rows must be at least 1"), "{e}");
    // A shard cannot plan adaptive samples: it sees only its rows' noise.
    let e = run(&["--spp", "2", "--shard", "0/2"]);
    assert!(e.contains("--shard needs --uniform"), "{e}");
}

/// `tprf batch MANIFEST ARGS...`.
fn batch(manifest: &Path, args: &[&str]) -> Output {
    let mut all = vec!["batch", manifest.to_str().unwrap()];
    all.extend_from_slice(args);
    tprf(&all)
}

/// When `tprf.json` of a job's output was last written.
fn written_at(out: &Path) -> std::time::SystemTime {
    std::fs::metadata(out.join("tprf.json"))
        .unwrap()
        .modified()
        .unwrap()
}

#[test]
fn a_batch_resumes_rendering_only_what_is_missing() {
    let dir = tempdir("batch");
    let manifest = dir.join("batch.toml");
    std::fs::write(
        &manifest,
        r#"
[defaults]
width = 12
height = 10
spp = 3
bins = 16

[[job]]
name = "lidar"
scene = "builtin:cornell"
out = "out/lidar"
sensors = ["builtin:lidar"]

[[sweep]]
scenes = ["builtin:cornell"]
out = "out/{scene}-{settings}"
settings = [{ name = "a", seed = 1 }, { name = "b", seed = 2, spp = 5, uniform = true }]
"#,
    )
    .unwrap();
    let o = batch(&manifest, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("3 rendered, 0 skipped"),
        "{}",
        stderr(&o)
    );
    let out = dir.join("out");
    assert!(out.join("lidar/sensor-lidar/sensor.json").is_file());
    // The sweep's job is the render its settings give.
    let one = dir.join("one-b");
    render(
        "builtin:cornell",
        &one,
        &[
            "--width",
            "12",
            "--height",
            "10",
            "--spp",
            "5",
            "--bins",
            "16",
            "--seed",
            "2",
            "--uniform",
        ],
    );
    assert!(bytes(&one.join("tprf.npy")) == bytes(&out.join("cornell-b/tprf.npy")));
    assert_eq!(json(&out.join("cornell-b/tprf.json"))["adaptive"], false);
    assert_eq!(json(&out.join("cornell-a/tprf.json"))["adaptive"], true);

    let before: Vec<_> = ["lidar", "cornell-a", "cornell-b"]
        .iter()
        .map(|j| written_at(&out.join(j)))
        .collect();
    let o = batch(&manifest, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("0 rendered, 3 skipped"),
        "{}",
        stderr(&o)
    );

    // One output deleted: only it is rendered again.
    std::fs::remove_dir_all(out.join("cornell-a")).unwrap();
    let o = batch(&manifest, &[]);
    assert!(
        stderr(&o).contains("1 rendered, 2 skipped"),
        "{}",
        stderr(&o)
    );
    assert!(out.join("cornell-a/tprf.npy").is_file());
    assert_eq!(written_at(&out.join("lidar")), before[0]);
    assert_eq!(written_at(&out.join("cornell-b")), before[2]);
    // A sensor's outputs deleted: the sensor runs again, the cube is kept.
    std::fs::remove_dir_all(out.join("lidar/sensor-lidar")).unwrap();
    let o = batch(&manifest, &["--only", "lidar"]);
    assert!(
        stderr(&o).contains("1 rendered, 0 skipped"),
        "{}",
        stderr(&o)
    );
    assert!(out.join("lidar/sensor-lidar/sensor.json").is_file());
    assert_eq!(written_at(&out.join("lidar")), before[0]);

    // The list says what is complete.
    let o = batch(&manifest, &["--list"]);
    let list = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(list.lines().count(), 3, "{list}");
    assert!(list.lines().all(|l| l.contains("\tcomplete\t")), "{list}");

    // A job asking for uniform samples is not complete with an adaptive cube.
    let text = std::fs::read_to_string(&manifest).unwrap();
    let uniform_a = text.replace(
        r#"name = "a", seed = 1"#,
        r#"name = "a", seed = 1, uniform = true"#,
    );
    std::fs::write(&manifest, uniform_a).unwrap();
    let o = batch(&manifest, &["--list"]);
    let list = String::from_utf8_lossy(&o.stdout).into_owned();
    let a = list.lines().find(|l| l.contains("cornell-a")).unwrap();
    assert!(a.contains("\tto do\t"), "{list}");
    let complete = list.lines().filter(|l| l.contains("\tcomplete\t")).count();
    assert_eq!(complete, 2, "{list}");
}

#[test]
fn a_failed_batch_job_is_reported_and_the_others_go_on() {
    let dir = tempdir("batch-fail");
    let manifest = dir.join("batch.toml");
    std::fs::write(
        &manifest,
        r#"
[[job]]
scene = "builtin:nosuchscene"
out = "broken"
width = 8
height = 8
spp = 1
bins = 8

[[job]]
scene = "builtin:cornell"
out = "fine"
width = 8
height = 8
spp = 1
bins = 8
"#,
    )
    .unwrap();
    let o = batch(&manifest, &[]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("job broken failed") && e.contains("nosuchscene"),
        "{e}"
    );
    assert!(e.contains("1 of 2 jobs failed: broken"), "{e}");
    assert!(dir.join("fine/tprf.npy").is_file());
    let o = batch(&manifest, &["--only", "nope"]);
    assert!(
        stderr(&o).contains("no job of that name (it has broken, fine)"),
        "{}",
        stderr(&o)
    );
    // Bad manifests.
    std::fs::write(
        &manifest,
        "[[job]]\nscene = \"builtin:cornell\"\nout = \"x\"\nspp = \"many\"\n",
    )
    .unwrap();
    let o = batch(&manifest, &[]);
    assert!(
        !o.status.success() && stderr(&o).contains("not a batch manifest"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_truncated_zarr_chunk_is_refused() {
    let dir = tempdir("zarr-cut");
    let args = [
        "--uniform",
        "--width",
        "16",
        "--height",
        "64",
        "--spp",
        "2",
        "--bins",
        "16",
        "--format",
        "zarr",
        "--t0",
        "3m",
        "--dt",
        "0.5m",
    ];
    let parts = shards(&dir, "builtin:cornell", &args, 2);
    let chunk = tree(&parts[1].join("tprf.zarr"))
        .into_keys()
        .find(|p| p.starts_with("cube/c"))
        .expect("shard 1 wrote no chunk");
    let file = parts[1].join("tprf.zarr").join(&chunk);
    let len = std::fs::metadata(&file).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&file)
        .unwrap()
        .set_len(len / 2)
        .unwrap();
    refused(&dir, &parts, &["shard 1", "does not decode"]);
}

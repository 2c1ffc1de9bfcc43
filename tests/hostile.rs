//! Hostile input, as a user (or an attacker) hands it to the `tprf` binary and the
//! library: small files that ask for huge memory, special files, empty cubes, Ctrl-C.
//! Each test builds its hostile file here and expects a clean refusal that names the
//! size or the file, never an abort, an OOM kill or a hang.
//!
//! The memory cases run the binary under `ulimit -v` (RLIMIT_AS): an allocation of
//! the size asked for would then fail and abort the process, so a clean refusal shows
//! both that nothing was allocated and that the budget reads the limit.

use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Address-space limit the memory cases run under, KiB (2 GiB).
const ULIMIT_V_KIB: u64 = 2 << 20;

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("hostile-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Run `tprf ARGS` under `ulimit -v limit_kib` (none: `None`), with a time limit after
/// which it is killed and the test fails (a hang).
fn tprf_limited(args: &[&str], limit_kib: Option<u64>) -> Output {
    let bin = env!("CARGO_BIN_EXE_tprf");
    let mut cmd = match limit_kib {
        Some(kib) => {
            let mut c = Command::new("sh");
            c.arg("-c")
                .arg(format!("ulimit -v {kib} && exec \"$0\" \"$@\""))
                .arg(bin);
            c
        }
        None => Command::new(bin),
    };
    let mut child = cmd
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run tprf");
    let start = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("tprf {args:?} hung (killed after 120 s)");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("output")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The run failed with tprf's own error (exit 1), not a signal (abort, OOM kill).
fn assert_refused(o: &Output, needles: &[&str]) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "expected a clean refusal: {err}");
    for n in needles {
        assert!(err.contains(n), "'{n}' not in: {err}");
    }
    err
}

/// A glTF document (`scene.gltf` in `dir`) with one external buffer `scene.bin`.
fn write_gltf(dir: &Path, mut doc: Value, bin: &[u8]) -> PathBuf {
    std::fs::write(dir.join("scene.bin"), bin).unwrap();
    doc["asset"] = json!({"version": "2.0"});
    doc["buffers"] = json!([{"uri": "scene.bin", "byteLength": bin.len()}]);
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// A grid of `nx x ny` quads (2 triangles each) in z = 0: positions then u16 indices.
fn grid(nx: usize, ny: usize) -> (Vec<u8>, usize, usize) {
    let mut bin = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            for c in [i as f32 / nx as f32, j as f32 / ny as f32, 0.0] {
                bin.extend(c.to_le_bytes());
            }
        }
    }
    let vertices = (nx + 1) * (ny + 1);
    let mut indices = 0;
    for j in 0..ny {
        for i in 0..nx {
            let v = |di: usize, dj: usize| ((j + dj) * (nx + 1) + i + di) as u16;
            for k in [v(0, 0), v(1, 0), v(1, 1), v(0, 0), v(1, 1), v(0, 1)] {
                bin.extend(k.to_le_bytes());
                indices += 1;
            }
        }
    }
    (bin, vertices, indices)
}

#[test]
fn one_mesh_instanced_5000_times_is_refused_before_it_is_built() {
    // 70 x 140 quads = 19 600 triangles, placed by 5000 nodes: 98 M triangles.
    let dir = tmp("instances");
    let (bin, vertices, indices) = grid(70, 140);
    let pos_bytes = vertices * 12;
    let nodes: Vec<Value> = (0..5000)
        .map(|k| json!({"mesh": 0, "translation": [0.0, 0.0, k as f32 * 0.01]}))
        .collect();
    let doc = json!({
        "scene": 0,
        "scenes": [{"nodes": (0..5000).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pos_bytes},
            {"buffer": 0, "byteOffset": pos_bytes, "byteLength": indices * 2},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": vertices, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5123, "count": indices, "type": "SCALAR"},
        ],
    });
    let path = write_gltf(&dir, doc, &bin);
    let out = dir.join("out");
    let o = tprf_limited(
        &[
            "render",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        Some(ULIMIT_V_KIB),
    );
    let err = assert_refused(
        &o,
        &[
            "needs",
            "GiB for 98.0 M triangles after instancing (5000 mesh instances)",
            "ulimit -v",
        ],
    );
    // 98 M triangles at the budgeted bytes each.
    let need_gib = 98e6 * tprf_core::scene::BYTES_PER_TRIANGLE as f64 / f64::from(1 << 30);
    assert!(err.contains(&format!("{need_gib:.1} GiB")), "{err}");
    assert!(!out.exists());
}

#[test]
fn a_sparse_accessor_of_3e8_elements_without_a_buffer_view_is_refused() {
    // 1 KB of glTF: POSITION is 3e8 zero vectors with one sparse substitution.
    let dir = tmp("sparse");
    let mut bin = Vec::new();
    bin.extend(0u32.to_le_bytes());
    for c in [1.0f32, 2.0, 3.0] {
        bin.extend(c.to_le_bytes());
    }
    let doc = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 4},
            {"buffer": 0, "byteOffset": 4, "byteLength": 12},
        ],
        "accessors": [{
            "componentType": 5126, "count": 300_000_000u64, "type": "VEC3",
            "min": [0.0, 0.0, 0.0], "max": [1.0, 2.0, 3.0],
            "sparse": {"count": 1,
                "indices": {"bufferView": 0, "componentType": 5125},
                "values": {"bufferView": 1}},
        }],
    });
    let path = write_gltf(&dir, doc, &bin);
    assert!(std::fs::metadata(&path).unwrap().len() < 1024);
    let o = tprf_limited(
        &[
            "render",
            path.to_str().unwrap(),
            "--out",
            dir.join("out").to_str().unwrap(),
        ],
        Some(ULIMIT_V_KIB),
    );
    assert_refused(
        &o,
        &["needs", "100.0 M triangles after instancing", "available"],
    );
}

/// CRC-32 (IEEE) of `bytes`, for PNG chunks.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A PNG whose header says `w x h` RGBA 16-bit, with an empty image stream after it.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |ty: &[u8], data: &[u8]| {
        png.extend((data.len() as u32).to_be_bytes());
        let mut body = ty.to_vec();
        body.extend(data);
        png.extend(&body);
        png.extend(crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([16, 6, 0, 0, 0]); // 16-bit RGBA, deflate, no filter, no interlace
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    chunk(b"IEND", &[]);
    png
}

#[test]
fn crc32_matches_a_known_value() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(crc32(b"IEND"), 0xAE42_6082);
}

/// A one-triangle document whose base colour texture is `image`.
fn textured_triangle(dir: &Path, image: Value) -> PathBuf {
    let mut bin = Vec::new();
    for c in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bin.extend(c.to_le_bytes());
    }
    let doc = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}],
        "images": [image],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
            "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]}],
    });
    write_gltf(dir, doc, &bin)
}

#[test]
fn a_png_claiming_more_pixels_than_it_holds_is_refused() {
    // A 20000 x 20000 header with no image data: reduced on load to 6667 x 6667 (178 MB,
    // within the 2 GiB limit), then refused where its data ends, not after 6 GB of
    // buffers (20000^2 x 16-bit RGBA, converted and copied, as before).
    let dir = tmp("png");
    std::fs::write(dir.join("huge.png"), png_header_only(20_000, 20_000)).unwrap();
    let path = textured_triangle(&dir, json!({"uri": "huge.png"}));
    let out = dir.join("out");
    let args = [
        "render",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let o = tprf_limited(&args, Some(ULIMIT_V_KIB));
    assert_refused(&o, &["images[0] 'huge.png'", "cannot decode"]);
    // A million pixels a side would need a reduction by 123: refused from the header.
    std::fs::write(dir.join("huge.png"), png_header_only(1_000_000, 1_000_000)).unwrap();
    let o = tprf_limited(&args, Some(ULIMIT_V_KIB));
    assert_refused(
        &o,
        &[
            "images[0] 'huge.png'",
            "the image is 1000000 x 1000000 pixels: textures are kept at most 8192 pixels a \
             side, and reduced on load from at most 524288",
        ],
    );
}

/// Run `tprf ARGS` under `ulimit -v limit_kib` to its end: its exit status, its stderr
/// and its peak resident memory (`ru_maxrss` from wait4, bytes).
#[cfg(target_os = "linux")]
#[allow(
    clippy::zombie_processes,
    reason = "the child is reaped by wait4 (which also gives its rusage), not by Child::wait"
)]
fn tprf_peak_rss(args: &[&str], limit_kib: u64) -> (Option<i32>, String, u64) {
    use std::io::Read;
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {limit_kib} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_tprf"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run tprf");
    let mut pipe = child.stderr.take().expect("stderr");
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        let _ = pipe.read_to_string(&mut text);
        text
    });
    let mut status = 0;
    // SAFETY: an all-zero rusage is a valid value; wait4 fills it for our own child.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = child.id() as libc::pid_t;
    // SAFETY: `status` and `usage` are valid for writes; `pid` is our child, not yet
    // reaped (`child` is never waited on).
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(waited, pid, "wait4");
    let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
    let stderr = reader.join().expect("stderr reader");
    (code, stderr, (usage.ru_maxrss as u64) << 10)
}

#[cfg(target_os = "linux")]
#[test]
fn a_20000_x_20000_png_loads_within_a_fixed_multiple_of_its_texture() {
    // A valid 20000 x 20000 grey PNG (400 M pixels) took 3.1 GB of resident memory: the
    // image crate's 400 MB decode, a 1.6 GB RGBA8 conversion and a 1.6 GB copy. Now it is
    // read row by row into a 6667 x 6667 texture (178 MB). Under a 2 GiB address-space
    // limit the render runs, and the process peaks below the texture plus 64 MiB for the
    // program and its small render (decoding may hold up to 4 times the texture; a PNG
    // read row by row holds one row of sums).
    let dir = tmp("png-20k");
    let (w, h) = (20_000u32, 20_000u32);
    let file = std::fs::File::create(dir.join("grey.png")).unwrap();
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Fastest);
    let mut writer = encoder.write_header().unwrap();
    let mut stream = writer.stream_writer().unwrap();
    let mut row = vec![0u8; w as usize];
    for y in 0..h {
        for (x, v) in row.iter_mut().enumerate() {
            *v = ((x as u32 * 7 + y * 3) % 256) as u8;
        }
        std::io::Write::write_all(&mut stream, &row).unwrap();
    }
    stream.finish().unwrap();
    // The IEND chunk and the buffered bytes reach the file when the writer goes.
    drop(writer);
    let path = textured_triangle(&dir, json!({"uri": "grey.png"}));
    let out = dir.join("out");
    let (code, err, peak) = tprf_peak_rss(
        &[
            "render",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "1",
        ],
        ULIMIT_V_KIB,
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("images[0] 'grey.png': 20000 x 20000 pixels reduced to 6667 x 6667 on load"),
        "{err}"
    );
    let texture = 6667u64 * 6667 * 4;
    assert!(
        peak < texture + (64 << 20),
        "peak resident memory {peak} B for a {texture} B texture"
    );
}

#[test]
fn a_huge_film_is_refused_before_it_is_allocated() {
    let dir = tmp("film");
    let o = tprf_limited(
        &[
            "render",
            "builtin:cornell",
            "--out",
            dir.join("out").to_str().unwrap(),
            "--width",
            "16384",
            "--height",
            "16384",
            "--bins",
            "16",
        ],
        Some(ULIMIT_V_KIB),
    );
    assert_refused(
        &o,
        &[
            "a film of 16384 x 16384 pixels x 16 bins needs",
            "ulimit -v",
        ],
    );
}

/// NLOS scans larger than memory are refused before any point is made, naming the flags
/// and the size (they aborted allocating 120 GB): the two grids, over the
/// transients one capture may hold, and a grid under that bound whose wall points
/// (16000 x 16000 sensor points and the one laser point of builtin:nlos-z's single scan,
/// 36 B each: 8.6 GiB) do not fit under `ulimit -v`.
#[test]
fn nlos_grids_larger_than_memory_are_refused_with_their_size() {
    let dir = tmp("nlos-grid");
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    let o = tprf_limited(
        &[
            "nlos",
            "builtin:nlos-z",
            "--grid",
            "100000x100000",
            "--out",
            out,
        ],
        Some(ULIMIT_V_KIB),
    );
    assert_refused(
        &o,
        &["--grid 100000x100000", "10.0 G transients", "335.3 GiB"],
    );
    let o = tprf_limited(
        &[
            "nlos",
            "builtin:nlos-z",
            "--exhaustive",
            "--laser-grid",
            "100000x100000",
            "--out",
            out,
        ],
        Some(ULIMIT_V_KIB),
    );
    assert_refused(&o, &["--laser-grid 100000x100000", "transients", "GiB"]);
    let o = tprf_limited(
        &[
            "nlos",
            "builtin:nlos-z",
            "--grid",
            "16000x16000",
            "--out",
            out,
        ],
        Some(ULIMIT_V_KIB),
    );
    assert_refused(
        &o,
        &[
            "needs 8.6 GiB for the wall points of --grid 16000x16000",
            "ulimit -v",
        ],
    );
    assert!(!Path::new(out).exists());
}

#[cfg(unix)]
#[test]
fn dev_zero_as_a_buffer_uri_is_named_and_not_read() {
    let dir = tmp("devzero-buffer");
    let (bin, vertices, _) = grid(1, 1);
    let doc = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": vertices * 12}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
            "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]}],
    });
    let path = write_gltf(&dir, doc.clone(), &bin);
    // The buffer's URI replaced by the endless device.
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    doc["buffers"][0]["uri"] = json!("file:///dev/zero");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let err = tprf_core::scene::load(path.to_str().unwrap())
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        err.contains("/dev/zero is a character device, not a regular file"),
        "{err}"
    );
    // Which buffer of which file, and the path as the URI names it, not joined to the
    // glTF file's folder (`.../hostile-devzero-buffer/file:///dev/zero` before).
    assert!(err.contains("buffer 0 'file:///dev/zero'"), "{err}");
    assert!(err.contains(path.to_str().unwrap()), "{err}");
    assert!(!err.contains(&format!("{}/file:", dir.display())), "{err}");
    // The same as an image.
    let path = textured_triangle(&dir, json!({"uri": "file:///dev/zero"}));
    let err = tprf_core::scene::load(path.to_str().unwrap())
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(err.contains("images[0] 'file:///dev/zero'"), "{err}");
    assert!(err.contains("/dev/zero is a character device"), "{err}");
}

#[cfg(unix)]
#[test]
fn dev_zero_and_a_fifo_as_the_scene_are_refused_at_once() {
    let dir = tmp("special-scene");
    let out = dir.join("out");
    let o = tprf_limited(
        &["render", "/dev/zero", "--out", out.to_str().unwrap()],
        None,
    );
    assert_refused(&o, &["/dev/zero is a character device, not a regular file"]);
    let fifo = dir.join("scene.gltf");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    // Nothing writes to the FIFO: reading it would block for ever.
    let o = tprf_limited(
        &[
            "render",
            fifo.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert_refused(&o, &["scene.gltf is a FIFO, not a regular file"]);
    // The 1-D world and the sensor file too.
    let o = tprf_limited(&["oned", fifo.to_str().unwrap()], None);
    assert_refused(&o, &["is a FIFO"]);
}

/// A 1-D world of `n` interfaces that each reflect and pass half the light.
fn many_interfaces(n: usize) -> Value {
    let side = json!({"reflectance": 0.5, "transmittance": 0.5});
    let interfaces: Vec<Value> = (0..n)
        .map(|i| json!({"x_m": 1.0 + i as f64 * 0.01, "left": side, "right": side}))
        .collect();
    json!({"interfaces": interfaces, "eye_m": 0.0, "light_m": 0.0, "look": "right"})
}

/// The peak resident memory of process `pid` (`VmHWM`), bytes.
fn peak_rss_bytes(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let kib: u64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    Some(kib << 10)
}

#[cfg(target_os = "linux")]
#[test]
fn oned_on_a_1000_interface_world_stays_inside_its_byte_limit() {
    // Before, 500 000 packets of 4 kB keys each (one crossing count per segment) grew
    // past 2.9 GB in seconds. The enumeration is exponential here and may run for
    // minutes; what it holds must stay at its 256 MiB limit (plus the program) all along,
    // under a 2 GiB address-space limit that would abort a larger allocation.
    let dir = tmp("oned");
    let world = dir.join("world.json");
    std::fs::write(&world, serde_json::to_vec(&many_interfaces(1000)).unwrap()).unwrap();
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {ULIMIT_V_KIB} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_tprf"))
        .args(["oned", world.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let mut peak = 0;
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        peak = peak_rss_bytes(child.id()).unwrap_or(0).max(peak);
        if start.elapsed() > Duration::from_secs(15) {
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let _ = child.kill();
    let output = child.wait_with_output().unwrap();
    if let Some(status) = status {
        assert!(status.success(), "{}", stderr(&output));
    }
    assert!(peak > 0, "the peak memory was read");
    assert!(peak < 400 << 20, "peak resident memory {peak} B");
}
/// A cube folder of `w x h` pixels and `bins` bins, all zeros.
fn write_cube(dir: &Path, w: usize, h: usize, bins: usize) {
    std::fs::create_dir_all(dir).unwrap();
    let meta = json!({
        "format": "tprf cube v1", "t0_s": 0.0, "dt_s": 1e-10, "bins": bins,
        "width": w, "height": h, "spp": 1, "seed": 0, "c_m_per_s": 299792458.0,
        "channel": "gray", "value": "", "scene": "builtin:cornell",
        "camera": {"position_m": [0.0, 0.0, 0.0], "world_from_camera": [1.0, 0.0, 0.0, 0.0,
            0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0], "yfov_deg": 45.0},
        "max_bounces": 8, "bounces_separate": 0, "threads": 1, "wall_seconds": 0.0,
        "rays_traced": 0, "paths_traced": 0, "error_estimate": null, "notes": [],
    });
    std::fs::write(dir.join("tprf.json"), serde_json::to_vec(&meta).unwrap()).unwrap();
    let data = vec![0f32; w * h * bins];
    tprf_core::export::write_npy_f32(
        &dir.join("tprf.npy"),
        &[h as u64, w as u64, bins as u64],
        &data,
    )
    .unwrap();
}

#[test]
fn an_empty_reference_cube_is_refused_wherever_it_enters() {
    let dir = tmp("empty-cube");
    let cube = dir.join("cube");
    write_cube(&cube, 0, 0, 4);
    let npy = cube.join("tprf.npy");
    // converge panicked here: `chunk_size must not be zero`.
    let o = tprf_limited(
        &[
            "converge",
            "builtin:cornell",
            "--reference",
            npy.to_str().unwrap(),
            "--seconds",
            "0.1",
            "--out",
            dir.join("conv").to_str().unwrap(),
        ],
        None,
    );
    assert_refused(&o, &["0 x 0 pixels x 4 bins: there is nothing in it"]);
    let o = tprf_limited(
        &[
            "sensor",
            cube.to_str().unwrap(),
            "--preset",
            "builtin:lidar",
            "--out",
            dir.join("sensor").to_str().unwrap(),
        ],
        None,
    );
    assert_refused(&o, &["0 x 0 pixels x 4 bins: there is nothing in it"]);
    // What `tprf view` opens.
    let err = tprf_core::export::load_snapshot(&cube)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(err.contains("there is nothing in it"), "{err}");
    // One side zero is as empty.
    write_cube(&cube, 0, 3, 4);
    let err = tprf_core::export::load_snapshot(&cube)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(err.contains("0 x 3 pixels"), "{err}");
}

#[test]
fn an_npy_header_claiming_more_than_its_bytes_is_refused() {
    let dir = tmp("npy-header");
    let cube = dir.join("cube");
    write_cube(&cube, 2, 2, 4);
    // Rewrite the header's shape to claim 10^12 values over the same 64 bytes of data
    // (the header keeps its length: the new shape takes the place of padding).
    let npy = cube.join("tprf.npy");
    let bytes = std::fs::read(&npy).unwrap();
    let header_len = usize::from(u16::from_le_bytes([bytes[8], bytes[9]]));
    let (head, data) = bytes.split_at(10 + header_len);
    assert_eq!(data.len(), 2 * 2 * 4 * 4);
    let header = String::from_utf8(head[10..].to_vec()).unwrap();
    let dict = header.trim_end();
    let forged = dict.replacen("(2, 2, 4, )", "(1000000, 1000000, 1, )", 1);
    assert_ne!(dict, forged);
    let forged = format!("{forged:<width$}\n", width = header_len - 1);
    assert_eq!(forged.len(), header_len);
    let mut bytes = head[..10].to_vec();
    bytes.extend(forged.as_bytes());
    bytes.extend(data);
    std::fs::write(&npy, &bytes).unwrap();
    let err = tprf_core::export::read_npy_f32(&npy)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(err.contains("needs 4000000000000 bytes of data"), "{err}");
}

#[cfg(unix)]
#[test]
fn ctrl_c_during_a_render_to_a_new_folder_leaves_nothing() {
    let dir = tmp("sigint");
    let out = dir.join("new").join("sub").join("cube");
    let mut child = ctrl_c_as_a_terminal_sends_it(&mut Command::new(env!("CARGO_BIN_EXE_tprf")))
        .args([
            "render",
            "builtin:cornell",
            "--out",
            out.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "64",
            "--spp",
            "100000000",
        ])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    assert!(!status.success());
    assert!(
        !dir.join("new").exists(),
        "Ctrl-C left {}",
        dir.join("new").display()
    );
}

/// `cmd` with SIGINT at its default action in the child, as a shell in a terminal
/// starts a command. A test run from a background job (`cmd &` in a script, `nohup`)
/// inherits SIGINT ignored, and the child would then never see the Ctrl-C these tests
/// send it (a render of 10^8 spp ran on for minutes).
#[cfg(unix)]
fn ctrl_c_as_a_terminal_sends_it(cmd: &mut Command) -> &mut Command {
    use std::os::unix::process::CommandExt;
    // SAFETY: between fork and exec only `signal`, which is async-signal-safe.
    unsafe {
        cmd.pre_exec(|| {
            libc::signal(libc::SIGINT, libc::SIG_DFL);
            Ok(())
        })
    }
}

/// The staging folders (`.NAME.tmp-*`) beside `target`.
fn staging_folders(target: &Path) -> Vec<PathBuf> {
    let name = target.file_name().unwrap().to_string_lossy().into_owned();
    let prefix = format!(".{name}.tmp-");
    std::fs::read_dir(target.parent().unwrap())
        .map(|d| {
            d.flatten()
                .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
                .map(|e| e.path())
                .collect()
        })
        .unwrap_or_default()
}

#[cfg(unix)]
#[test]
fn ctrl_c_while_the_output_is_written_keeps_the_old_folder_whole() {
    let dir = tmp("sigint-write");
    let out = dir.join("cube");
    let out_s = out.to_str().unwrap().to_string();
    let render = |bins: &'static str, frames: bool| -> Vec<String> {
        let mut args: Vec<&str> = vec![
            "render",
            "builtin:cornell",
            "--out",
            &out_s,
            "--width",
            "96",
            "--height",
            "96",
            "--spp",
            "1",
            "--bins",
            bins,
        ];
        if frames {
            args.push("--frames");
        }
        args.into_iter().map(String::from).collect()
    };
    // The old output: a small render, its files remembered byte for byte.
    let old_args = render("8", false);
    let o = tprf_limited(
        &old_args.iter().map(|s| s.as_str()).collect::<Vec<_>>(),
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let old: Vec<(PathBuf, Vec<u8>)> = ["tprf.json", "tprf.npy", "steady.png"]
        .iter()
        .map(|f| (out.join(f), std::fs::read(out.join(f)).unwrap()))
        .collect();
    // The new render writes 4096 frames: Ctrl-C lands while its folder is being written.
    let mut child = ctrl_c_as_a_terminal_sends_it(&mut Command::new(env!("CARGO_BIN_EXE_tprf")))
        .args(render("4096", true))
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let mut seen_writing = false;
    while start.elapsed() < Duration::from_secs(120) {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if let Some(staging) = staging_folders(&out).first()
            && staging.join("frames").is_dir()
        {
            seen_writing = true;
            let killed = Command::new("kill")
                .args(["-INT", &child.id().to_string()])
                .status()
                .unwrap();
            assert!(killed.success());
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let o = child.wait_with_output().unwrap();
    assert!(seen_writing, "the write ended before it was seen");
    assert!(!o.status.success(), "an interrupted write must not exit 0");
    assert!(
        stderr(&o).contains("interrupted"),
        "the message says so: {}",
        stderr(&o)
    );
    for (path, bytes) in &old {
        assert_eq!(
            &std::fs::read(path).unwrap(),
            bytes,
            "{} changed",
            path.display()
        );
    }
    assert!(
        !out.join("frames").exists(),
        "new frames beside the old cube"
    );
    assert_eq!(staging_folders(&out), Vec::<PathBuf>::new());
}

#[test]
fn a_convergence_run_larger_than_memory_is_refused() {
    // 4096 x 4096 x 8 = 2^27 pixel-bins (the run's fixed cap) at 32 B each: 4 GiB.
    let dir = tmp("converge-big");
    let o = tprf_limited(
        &[
            "converge",
            "analytic:plane",
            "--width",
            "4096",
            "--height",
            "4096",
            "--bins",
            "8",
            "--seconds",
            "0.1",
            "--out",
            dir.join("conv").to_str().unwrap(),
        ],
        Some(ULIMIT_V_KIB),
    );
    assert_refused(
        &o,
        &[
            "the convergence run needs 4.0 GiB for a 4096 x 4096 x 8 film",
            "ulimit -v",
        ],
    );
}

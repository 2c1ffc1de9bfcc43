//! Property tests over what reads user input: the time/unit parser, the glTF loader
//! (a valid document with one field replaced by a hostile value, and raw bytes), the
//! .npy reader, the 1-D world JSON and the sensor TOML. Each input must give a value or
//! a clean error, never a panic; a loaded scene must pass its own validation, and a
//! parsed time is finite.
//!
//! Kept to a few seconds in `cargo test --release` (`PROPTEST_CASES` runs more: see
//! docs/hostile.md for a long run). The process runs under an address-space limit
//! (RLIMIT_AS, 4 GiB above what it maps at start), so an input that asks for more is
//! refused by the memory budget instead of taking the machine.

use proptest::prelude::*;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::sync::Once;

/// Lower this process's soft address-space limit once (see the file's doc).
fn limit_memory() {
    static ONCE: Once = Once::new();
    #[cfg(target_os = "linux")]
    ONCE.call_once(|| {
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        let vm_kib: u64 = status
            .lines()
            .find_map(|l| l.strip_prefix("VmSize:"))
            .and_then(|v| v.split_whitespace().next()?.parse().ok())
            .unwrap_or(0);
        let limit = (vm_kib << 10) + (4 << 30);
        let mut lim = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit/setrlimit read and write one rlimit through valid pointers.
        unsafe {
            if libc::getrlimit(libc::RLIMIT_AS, &mut lim) == 0 && lim.rlim_cur > limit {
                lim.rlim_cur = limit;
                libc::setrlimit(libc::RLIMIT_AS, &lim);
            }
        }
    });
    #[cfg(not(target_os = "linux"))]
    ONCE.call_once(|| {});
}

fn dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A file name no other case running at the same time uses.
fn unique(ext: &str) -> PathBuf {
    use std::sync::atomic::{AtomicU64, Ordering};
    static N: AtomicU64 = AtomicU64::new(0);
    dir().join(format!("case-{}.{ext}", N.fetch_add(1, Ordering::Relaxed)))
}

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(128)
}

// ---- time and units ----

const UNITS: [(&str, f64); 10] = [
    ("s", 1.0),
    ("ms", 1e-3),
    ("us", 1e-6),
    ("ns", 1e-9),
    ("ps", 1e-12),
    ("fs", 1e-15),
    ("m", 1.0 / 299_792_458.0),
    ("cm", 1e-2 / 299_792_458.0),
    ("mm", 1e-3 / 299_792_458.0),
    ("km", 1e3 / 299_792_458.0),
];

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

    /// Any text: a finite time or an error.
    #[test]
    fn any_text_is_a_finite_time_or_an_error(text in "\\PC{0,24}") {
        if let Ok(t) = tprf_core::units::parse_time_s(&text) {
            prop_assert!(t.is_finite(), "{text:?} -> {t}");
        }
    }

    /// Number-like text with units and exponents: the same rule.
    #[test]
    fn numbers_with_units_are_finite_or_refused(
        mantissa in "[-+]?[0-9]{0,4}(\\.[0-9]{0,3})?",
        exponent in "([eE][-+]?[0-9]{1,3})?",
        space in " {0,2}",
        unit in "(s|ms|us|µs|ns|ps|fs|m|cm|mm|km|x|)",
    ) {
        let text = format!("{mantissa}{exponent}{space}{unit}");
        if let Ok(t) = tprf_core::units::parse_time_s(&text) {
            prop_assert!(t.is_finite(), "{text:?} -> {t}");
        }
    }

    /// A number written in any unit reads back as that many of the unit's seconds.
    #[test]
    fn a_number_in_a_unit_reads_back(v in -1e30f64..1e30, u in 0usize..UNITS.len()) {
        let (unit, scale) = UNITS[u];
        let t = tprf_core::units::parse_time_s(&format!("{v:e} {unit}"));
        prop_assert!(t.is_ok(), "{v:e} {unit}: {t:?}");
        let t = t.unwrap_or_default();
        let want = v * scale;
        prop_assert!((t - want).abs() <= 1e-12 * want.abs(), "{v:e} {unit}: {t} vs {want}");
    }
}

// ---- glTF ----

/// A valid document using most of what the loader reads: an indexed triangle with
/// normals and UVs, a sparse accessor, a textured material, a camera, a spot light, a
/// node hierarchy. Its buffer is external (`buf`), its image a `data:` PNG.
fn seed_doc(buf: &str) -> (Value, Vec<u8>) {
    let mut bin = Vec::new();
    let floats = |bin: &mut Vec<u8>, v: &[f32]| {
        for x in v {
            bin.extend(x.to_le_bytes());
        }
    };
    floats(&mut bin, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]); // 0..36 positions
    floats(&mut bin, &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]); // 36..72 normals
    floats(&mut bin, &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]); // 72..96 uvs
    for i in [0u16, 1, 2, 0] {
        bin.extend(i.to_le_bytes()); // 96..104 indices (and padding)
    }
    bin.extend(1u32.to_le_bytes()); // 104..108 sparse index
    floats(&mut bin, &[2.0, 0.0, 0.0]); // 108..120 sparse value
    // A 1 x 1 PNG (RGB 8-bit, one red pixel).
    let png = [
        0x89, 0x50, 0x4E, 0x47, 0x0D, 0x0A, 0x1A, 0x0A, 0x00, 0x00, 0x00, 0x0D, 0x49, 0x48, 0x44,
        0x52, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00, 0x00, 0x90,
        0x77, 0x53, 0xDE, 0x00, 0x00, 0x00, 0x0C, 0x49, 0x44, 0x41, 0x54, 0x08, 0xD7, 0x63, 0xF8,
        0xCF, 0xC0, 0x00, 0x00, 0x03, 0x01, 0x01, 0x00, 0x18, 0xDD, 0x8D, 0xB0, 0x00, 0x00, 0x00,
        0x00, 0x49, 0x45, 0x4E, 0x44, 0xAE, 0x42, 0x60, 0x82,
    ];
    let png_uri = format!("data:image/png;base64,{}", base64_encode(&png));
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 3]}],
        "nodes": [
            {"children": [1, 2], "translation": [0.0, 0.0, -1.0]},
            {"mesh": 0, "scale": [1.0, 1.0, 1.0]},
            {"mesh": 1, "rotation": [0.0, 0.0, 0.0, 1.0]},
            {"camera": 0, "translation": [0.0, 0.0, 3.0],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "spot", "intensity": 10.0, "color": [1.0, 1.0, 1.0],
             "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}]}},
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                             "indices": 3, "material": 0, "mode": 4}]},
            {"primitives": [{"attributes": {"POSITION": 4}, "mode": 5}]},
        ],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0]}, "emissiveFactor": [0.0, 0.0, 0.0]}],
        "textures": [{"source": 0}],
        "images": [{"uri": png_uri}],
        "buffers": [{"uri": buf, "byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 36},
            {"buffer": 0, "byteOffset": 72, "byteLength": 24},
            {"buffer": 0, "byteOffset": 96, "byteLength": 6},
            {"buffer": 0, "byteOffset": 104, "byteLength": 4},
            {"buffer": 0, "byteOffset": 108, "byteLength": 12},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"},
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [2.0, 1.0, 0.0],
             "sparse": {"count": 1, "indices": {"bufferView": 4, "componentType": 5125},
                        "values": {"bufferView": 5}}},
        ],
    });
    (doc, bin)
}

/// Standard base64 with padding.
fn base64_encode(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = |i: usize| u32::from(chunk.get(i).copied().unwrap_or(0));
        let n = (b(0) << 16) | (b(1) << 8) | b(2);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ABC[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Every JSON pointer to a value inside `v` (objects' keys and arrays' elements).
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                let p = format!("{at}/{}", k.replace('~', "~0").replace('/', "~1"));
                out.push(p.clone());
                pointers(x, p, out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                let p = format!("{at}/{i}");
                out.push(p.clone());
                pointers(x, p, out);
            }
        }
        _ => {}
    }
}

/// Values a hostile file puts in a field: out-of-range indices and counts, huge and
/// negative numbers, wrong types, special files.
fn hostile_value() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(json!(null)),
        Just(json!(-1)),
        Just(json!(0)),
        Just(json!(1)),
        Just(json!(2)),
        Just(json!(7)),
        Just(json!(255)),
        Just(json!(65_536)),
        Just(json!(4_294_967_295u64)),
        Just(json!(4_294_967_296u64)),
        Just(json!(300_000_000u64)),
        Just(json!(9_007_199_254_740_993u64)),
        Just(json!(1e308)),
        Just(json!(-1e308)),
        Just(json!(0.5)),
        Just(json!("")),
        Just(json!("file:///dev/zero")),
        Just(json!("/dev/zero")),
        Just(json!("../../../../etc/passwd")),
        Just(json!("%FF%FE.bin")),
        Just(json!("data:application/octet-stream;base64,AAAA")),
        Just(json!("data:image/png;base64,iVBORw0KGgo=")),
        Just(json!([])),
        Just(json!([0, 0, 0])),
        Just(json!({})),
        Just(json!(true)),
        any::<i32>().prop_map(|i| json!(i)),
        any::<f32>()
            .prop_filter("JSON numbers are finite", |f| f.is_finite())
            .prop_map(|f| json!(f)),
    ]
}

/// Load `doc` (with its buffer `bin`) through the library: a scene that validates, or an
/// error, never a panic.
fn load_checks(doc: &Value, bin: &[u8], buf: &Path) -> Result<(), TestCaseError> {
    std::fs::write(buf, bin).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let path = buf.with_extension("gltf");
    std::fs::write(&path, serde_json::to_vec(doc).unwrap_or_default())
        .map_err(|e| TestCaseError::fail(e.to_string()))?;
    let loaded = std::panic::catch_unwind(|| tprf_core::scene::load(path.to_str().unwrap_or("")));
    let _ = std::fs::remove_file(&path);
    let _ = std::fs::remove_file(buf);
    match loaded {
        Err(_) => Err(TestCaseError::fail(format!("the loader panicked on {doc}"))),
        Ok(Ok(scene)) => {
            prop_assert!(scene.validate().is_ok(), "loaded but invalid: {doc}");
            Ok(())
        }
        Ok(Err(_)) => Ok(()),
    }
}

#[test]
fn the_seed_document_loads() {
    let buf = unique("bin");
    let (doc, bin) = seed_doc(buf.file_name().unwrap().to_str().unwrap());
    std::fs::write(&buf, &bin).unwrap();
    let path = buf.with_extension("gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let scene = tprf_core::scene::load(path.to_str().unwrap()).expect("seed loads");
    // 1 triangle, and the strip's 1 (its sparse accessor moved vertex 1 to x = 2).
    assert_eq!(scene.triangles.len(), 2);
    assert!(
        scene
            .triangles
            .iter()
            .any(|t| t.p.iter().any(|p| p.x == 2.0))
    );
    assert_eq!(scene.textures.len(), 1);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

    /// The seed document with one to three fields replaced by hostile values.
    #[test]
    fn gltf_with_hostile_fields_loads_or_is_refused(
        edits in prop::collection::vec((any::<prop::sample::Index>(), hostile_value()), 1..4)
    ) {
        limit_memory();
        let buf = unique("bin");
        let (mut doc, bin) = seed_doc(buf.file_name().and_then(|n| n.to_str()).unwrap_or(""));
        for (at, value) in edits {
            let mut all = Vec::new();
            pointers(&doc, String::new(), &mut all);
            if all.is_empty() {
                break;
            }
            let p = at.get(&all).clone();
            if let Some(slot) = doc.pointer_mut(&p) {
                *slot = value;
            }
        }
        load_checks(&doc, &bin, &buf)?;
    }

    /// The seed document's buffer cut or with bytes changed.
    #[test]
    fn gltf_with_a_damaged_buffer_loads_or_is_refused(
        cut in 0usize..130,
        flips in prop::collection::vec((0usize..130, any::<u8>()), 0..6),
    ) {
        limit_memory();
        let buf = unique("bin");
        let (doc, mut bin) = seed_doc(buf.file_name().and_then(|n| n.to_str()).unwrap_or(""));
        for (i, b) in flips {
            if let Some(x) = bin.get_mut(i) {
                *x = b;
            }
        }
        bin.truncate(cut);
        load_checks(&doc, &bin, &buf)?;
    }

    /// Arbitrary bytes as a .glb or .gltf file.
    #[test]
    fn arbitrary_bytes_as_a_scene_are_refused(
        bytes in prop::collection::vec(any::<u8>(), 0..256),
        glb_header in any::<bool>(),
    ) {
        limit_memory();
        let mut data = Vec::new();
        if glb_header {
            data.extend(b"glTF");
            data.extend(2u32.to_le_bytes());
            data.extend(((bytes.len() + 12) as u32).to_le_bytes());
        }
        data.extend(bytes);
        let path = unique(if glb_header { "glb" } else { "gltf" });
        std::fs::write(&path, &data).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let loaded = std::panic::catch_unwind(|| tprf_core::scene::load(path.to_str().unwrap_or("")));
        let _ = std::fs::remove_file(&path);
        prop_assert!(loaded.is_ok(), "panicked on {data:?}");
    }

    /// Arbitrary bytes after a .npy magic, and damaged headers: an array or an error.
    #[test]
    fn npy_bytes_are_read_or_refused(
        shape in prop::collection::vec(0u64..100_000_000_000, 0..4),
        descr in "(<f4|<f8|>f4|<i4|\\|u1|<f2|O)",
        fortran in any::<bool>(),
        data in prop::collection::vec(any::<u8>(), 0..128),
    ) {
        limit_memory();
        let shape_text: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
        let header = format!(
            "{{'descr': '{descr}', 'fortran_order': {}, 'shape': ({}{}), }}",
            if fortran { "True" } else { "False" },
            shape_text.join(", "),
            if shape.len() == 1 { "," } else { "" }
        );
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        let pad = (64 - (10 + header.len() + 1) % 64) % 64;
        let len = header.len() + pad + 1;
        bytes.extend((len as u16).to_le_bytes());
        bytes.extend(header.as_bytes());
        bytes.extend(std::iter::repeat_n(b' ', pad));
        bytes.push(b'\n');
        bytes.extend(&data);
        let path = unique("npy");
        std::fs::write(&path, &bytes).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let read = std::panic::catch_unwind(|| tprf_core::export::read_npy_f32(&path));
        let _ = std::fs::remove_file(&path);
        match read {
            Err(_) => return Err(TestCaseError::fail(format!("panicked on {header}"))),
            Ok(Ok((s, values))) => {
                let n: u64 = s.iter().product();
                prop_assert_eq!(values.len() as u64, n);
            }
            Ok(Err(_)) => {}
        }
    }

    /// A 1-D world with hostile numbers: a train or an error.
    #[test]
    fn oned_worlds_with_hostile_numbers_are_read_or_refused(
        xs in prop::collection::vec(prop_oneof![Just(1e308), Just(-1e308), Just(0.0), -10.0f64..10.0], 0..6),
        rs in prop::collection::vec(prop_oneof![Just(-1.0), Just(2.0), 0.0f64..1.0], 0..6),
        eye in -10.0f64..10.0,
    ) {
        limit_memory();
        let interfaces: Vec<Value> = xs
            .iter()
            .zip(rs.iter().chain(std::iter::repeat(&0.5)))
            .map(|(x, r)| json!({"x_m": x, "left": {"reflectance": r, "transmittance": 0.1},
                                 "right": {"reflectance": r}}))
            .collect();
        let text = json!({"interfaces": interfaces, "eye_m": eye, "light_m": eye, "look": "right"})
            .to_string();
        let run = std::panic::catch_unwind(|| {
            tprf_core::oned::World::from_json_str(&text)
                .map(|w| w.impulse_train(&tprf_core::oned::ImpulseOptions::default()))
        });
        prop_assert!(run.is_ok(), "panicked on {text}");
        if let Ok(Ok(train)) = run {
            prop_assert!(train.impulses.iter().all(|i| i.time_s.is_finite() && i.weight.is_finite()));
        }
    }

    /// The built-in sensor presets with one to three values replaced by hostile ones.
    #[test]
    fn sensor_toml_with_hostile_values_is_read_or_refused(
        preset in 0usize..tprf_core::sensor::BUILTIN_PRESETS.len(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), prop_oneof![
            Just("-1"), Just("0"), Just("1e308"), Just("-1e308"), Just("nan"), Just("inf"),
            Just("4294967296"), Just("18446744073709551615"), Just("\"-1 ns\""),
            Just("\"0 s\""), Just("\"1e300 km\""), Just("\"x\""), Just("[]"), Just("{}"),
            Just("true"), Just("1e-320"), Just("100000000"),
        ]), 1..4),
    ) {
        let (_, text) = tprf_core::sensor::BUILTIN_PRESETS[preset];
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        for (at, value) in edits {
            // A `key = value` line's value.
            let assignments: Vec<usize> = (0..lines.len())
                .filter(|&i| lines[i].contains(" = ") && !lines[i].trim_start().starts_with('#'))
                .collect();
            if assignments.is_empty() {
                break;
            }
            let i = *at.get(&assignments);
            if let Some((key, _)) = lines[i].split_once(" = ") {
                lines[i] = format!("{key} = {value}");
            }
        }
        let text = lines.join("\n");
        let run = std::panic::catch_unwind(|| tprf_core::sensor::Sensor::from_toml_str(&text));
        prop_assert!(run.is_ok(), "panicked on {text}");
    }
}

// ---- the sensor's settings, as the viewer's sliders and fields set them ----

/// JSON pointers of the numeric leaves of `v`, and of strings that start with a number
/// (times and rates with a unit: "5 ns", "1 MHz").
fn numeric_leaves(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Number(_) => out.push(at),
        Value::String(s)
            if s.trim_start()
                .starts_with(|c: char| c.is_ascii_digit() || c == '-') =>
        {
            out.push(at)
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                numeric_leaves(x, format!("{at}/{i}"), out);
            }
        }
        Value::Object(o) => {
            for (k, x) in o {
                numeric_leaves(
                    x,
                    format!("{at}/{}", k.replace('~', "~0").replace('/', "~1")),
                    out,
                );
            }
        }
        _ => {}
    }
}

/// A small cube `[3, 4, 256]` over 0..25.6 ns: a return per pixel at its own time and
/// a weak tail, so every gate and derived output has something to read.
fn small_cube() -> (tprf_core::sensor::TimeAxis, Vec<f32>) {
    let axis = tprf_core::sensor::TimeAxis::new(0.0, 0.1e-9, 256).unwrap();
    let mut cube = vec![0.0f32; 3 * 4 * 256];
    for (p, px) in cube.chunks_exact_mut(256).enumerate() {
        px[20 + 17 * p] = 1.0 + p as f32;
        for (b, v) in px.iter_mut().enumerate().skip(21 + 17 * p) {
            *v = 1e-3 / (1 + b) as f32;
        }
    }
    (axis, cube)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    /// Any values in any of a built-in sensor's fields (as the sensor tab's sliders and
    /// text fields can set them, and beyond): refused with a message, or a model whose
    /// measurements are finite and non-negative, whose depths are finite or NaN (no
    /// return), and whose SPAD histograms are finite. Never a panic.
    #[test]
    fn sensor_settings_measure_finite_or_are_refused(
        preset in 0usize..tprf_core::sensor::BUILTIN_PRESETS.len(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), prop_oneof![
            Just(-1.0), Just(0.0), Just(1e-300), Just(1e-12), Just(0.5), Just(1.0), Just(3.0),
            Just(64.0), Just(1e6), Just(1e9), Just(1e15), Just(1e300), Just(f64::MAX),
            Just(-1e300), Just(4294967296.0), (-1e3f64..1e3),
        ]), 1..4),
        unit in prop::sample::select(vec!["", " ns", " ps", " s", " m", " MHz", " Hz"]),
    ) {
        limit_memory();
        let (_, text) = tprf_core::sensor::BUILTIN_PRESETS[preset];
        let sensor = tprf_core::sensor::Sensor::from_toml_str(text).unwrap();
        let mut doc = serde_json::to_value(&sensor).unwrap();
        let mut leaves = Vec::new();
        numeric_leaves(&doc, String::new(), &mut leaves);
        for (at, value) in &edits {
            if leaves.is_empty() {
                break;
            }
            let p = at.get(&leaves).clone();
            let slot = doc.pointer_mut(&p).unwrap();
            *slot = match slot {
                Value::String(_) => Value::String(format!("{value}{unit}")),
                _ if value.fract() == 0.0 && value.abs() < 1e18 => json!(*value as i64),
                _ => json!(value),
            };
        }
        let run = std::panic::catch_unwind(|| -> Result<(), String> {
            let Ok(sensor) = serde_json::from_value::<tprf_core::sensor::Sensor>(doc.clone()) else {
                return Ok(()); // refused as it is read
            };
            let (axis, cube) = small_cube();
            let Ok(model) = tprf_core::sensor::SensorModel::new(sensor, axis) else {
                return Ok(()); // refused as it is compiled
            };
            let clean = model.measure_clean(&cube, 4, 3).map_err(|e| e.to_string())?;
            let mut m = clean.clone();
            model.apply_noise(&mut m);
            if let Some(v) = m.values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
                return Err(format!("measurement {v}"));
            }
            let no_inf = |what: &str, d: &[f32]| match d.iter().find(|v| v.is_infinite()) {
                Some(v) => Err(format!("{what} {v}")),
                None => Ok(()),
            };
            if let Some(r) = model.returns(&m) {
                no_inf("return depths", &r.depth_m)?;
                no_inf("return intensities", &r.intensity)?;
                no_inf("strongest return", &r.strongest_m)?;
                no_inf("last return", &r.last_m)?;
            }
            if let Some(a) = model.amcw(&m) {
                no_inf("AMCW depth", &a.depth_m)?;
                no_inf("AMCW amplitude", &a.amplitude)?;
            }
            if model.sensor().spad.is_some() {
                let steady: Vec<f32> = cube.chunks_exact(256).map(|p| p.iter().sum()).collect();
                if let Ok(s) = tprf_core::sensor::spad_image(&model, &clean, &steady) {
                    if let Some(v) = s.histogram.iter().chain(&s.counts).find(|v| !v.is_finite()) {
                        return Err(format!("SPAD count {v}"));
                    }
                    no_inf("SPAD depth", &s.depth_coates_m)?;
                }
            }
            Ok(())
        });
        match run {
            Err(_) => prop_assert!(false, "panicked on {doc}"),
            Ok(Err(e)) => prop_assert!(false, "{e} from {doc}"),
            Ok(Ok(())) => {}
        }
    }
}

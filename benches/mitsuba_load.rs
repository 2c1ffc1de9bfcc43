//! Mitsuba XML loading at scale: `cargo bench --bench mitsuba_load` (a plain program, not
//! a timed test). `cargo bench --bench mitsuba_load -- 1000 10000` picks the sizes.
//!
//! For N = 1 000, 10 000 and 100 000 simple shapes (half `rectangle`, half `cube`, laid
//! on a grid; nine in ten share one diffuse BSDF by `<ref>`, every tenth has a BSDF of
//! its own, every shape an id), written here to one XML file: the time to load it
//! (`load_mitsuba`: parse, shapes, materials, notes), best of two, and the time to write
//! the loaded scene as glTF (`save_gltf`, what `tprf render --save-gltf` does), once.
//! Printed: seconds, microseconds per shape, and the triangles (checked against the
//! count the shapes must give: 2 per rectangle, 12 per cube). Loading is linear when the
//! microseconds per shape stay flat as N grows by ten.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tprf_core::scene::gltf_save::save_gltf;
use tprf_core::scene::mitsuba::load_mitsuba;

/// The XML of `n` shapes (see the module doc).
fn scene_xml(n: usize) -> String {
    let side = (n as f64).sqrt().ceil() as usize;
    let mut s = String::with_capacity(n * 200 + 1024);
    s.push_str("<scene version=\"3.0.0\">\n");
    s.push_str(
        "  <bsdf type=\"diffuse\" id=\"white\"><rgb name=\"reflectance\" value=\"0.7\"/></bsdf>\n",
    );
    s.push_str("  <emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"40\"/><rgb name=\"intensity\" value=\"100\"/></emitter>\n");
    for i in 0..n {
        let (x, y) = ((i % side) as f64, (i / side) as f64);
        let kind = if i % 2 == 0 { "rectangle" } else { "cube" };
        let bsdf = if i % 10 == 3 {
            format!(
                "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{:.3}\"/></bsdf>",
                0.1 + 0.1 * (i % 7) as f64
            )
        } else {
            "<ref id=\"white\"/>".to_string()
        };
        let _ = writeln!(
            s,
            "  <shape type=\"{kind}\" id=\"s{i}\">\n    <transform name=\"to_world\"><scale value=\"0.4\"/><translate x=\"{x}\" y=\"{y}\" z=\"0\"/></transform>\n    {bsdf}\n  </shape>"
        );
    }
    s.push_str("</scene>\n");
    s
}

fn triangles_of(n: usize) -> usize {
    (n / 2 + n % 2) * 2 + (n / 2) * 12
}

fn main() {
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if sizes.is_empty() {
        vec![1_000, 10_000, 100_000]
    } else {
        sizes
    };
    let dir: PathBuf =
        std::env::temp_dir().join(format!("tprf-bench-mitsuba-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    println!(
        "| shapes | XML | load (s) | us per shape | triangles | save glTF (s) | us per shape |"
    );
    println!("| ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
    for &n in &sizes {
        let xml = dir.join(format!("shapes{n}.xml"));
        std::fs::write(&xml, scene_xml(n)).expect("write the XML");
        let bytes = std::fs::metadata(&xml).map(|m| m.len()).unwrap_or(0);
        let (mut best, mut scene) = (f64::INFINITY, None);
        for _ in 0..2 {
            let t = Instant::now();
            let (s, _) = load_mitsuba(&xml).expect("load");
            best = best.min(t.elapsed().as_secs_f64());
            scene = Some(s);
        }
        let scene = scene.expect("loaded");
        assert_eq!(
            scene.triangles.len(),
            triangles_of(n),
            "triangles of {n} shapes"
        );
        let gltf: &Path = &dir.join(format!("shapes{n}.gltf"));
        let t = Instant::now();
        save_gltf(&scene, gltf).expect("save");
        let save_s = t.elapsed().as_secs_f64();
        println!(
            "| {n} | {:.1} MB | {best:.3} | {:.1} | {} | {save_s:.3} | {:.1} |",
            bytes as f64 / 1e6,
            best * 1e6 / n as f64,
            scene.triangles.len(),
            save_s * 1e6 / n as f64,
        );
        let _ = std::fs::remove_file(&xml);
        let _ = std::fs::remove_file(gltf);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

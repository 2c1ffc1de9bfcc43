//! Heterogeneous media (issue 32: a density grid scaling a medium's coefficients) against
//! answers derived by hand: a constant grid is the homogeneous medium of its density
//! (single scattering's closed form), an absorbing grid attenuates the lit plane by
//! `e^(-sigma_a integral density)` worked out for its slabs, a white grid leaves the
//! furnace's radiance unchanged; a Mitsuba `.vol` written here from the documented
//! format read back through glTF and Mitsuba XML; bad grids refused by field and file;
//! `tprf.json` records the grid.

mod common;
use common::cli::{json, stderr, tempdir, tprf};
use common::*;
use glam::Vec3;
use std::path::Path;
use tprf_core::film::TimeAxis;
use tprf_core::reference::furnace::Furnace;
use tprf_core::reference::plane::Plane;
use tprf_core::scene::{self, Camera, DensityGrid, Medium, PunctualLight, Scene};
use tprf_core::transport::RenderSettings;

/// A `.vol` file's bytes as Mitsuba 3's `gridvolume` documents them: `VOL`, version 3,
/// encoding 1 (float32), x, y, z sizes, channels (int32), the box (6 float32: xmin ymin
/// zmin xmax ymax zmax), the values x fastest; little endian.
fn vol_bytes(dims: [i32; 3], channels: i32, bbox: [f32; 6], values: &[f32]) -> Vec<u8> {
    let mut b = b"VOL".to_vec();
    b.push(3);
    b.extend(1i32.to_le_bytes());
    for d in dims {
        b.extend(d.to_le_bytes());
    }
    b.extend(channels.to_le_bytes());
    for x in bbox {
        b.extend(x.to_le_bytes());
    }
    for v in values {
        b.extend(v.to_le_bytes());
    }
    b
}

fn grid(dims: [u32; 3], values: Vec<f32>, lo: [f32; 3], hi: [f32; 3]) -> DensityGrid {
    DensityGrid::new(dims, values, Some([lo, hi]), None, "test grid").unwrap()
}

/// A constant grid of density `k` over a box holding every point that can be seen is the
/// homogeneous medium of coefficients `k sigma`: single scattering of a co-located pulsed
/// point light (every bin against `k sigma_s p(pi) I e^(-2 k sigma_t r) / r^2` integrated
/// over the bin's `r = c t / (2 n)`), `--max-bounces 1`. The grid's box ends at 10 m, past
/// the window's 9 m, so the clip to the box is exercised where it changes nothing.
#[test]
fn a_constant_grid_is_the_homogeneous_medium_of_its_density() {
    for (sigma_s, sigma_a, g, n, k) in [(0.1, 0.025, 0.6, 1.33, 2.0), (0.25, 0.1, -0.4, 1.0, 0.5)] {
        let i = 5.0;
        let mut scene = empty_scene(Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 0.8));
        let density = grid([3, 2, 2], vec![k as f32; 12], [-10.0; 3], [10.0; 3]);
        scene.medium = Some(Medium {
            density: Some(density),
            ..Medium::grey(sigma_s as f32, sigma_a as f32, g as f32, n as f32)
        });
        scene.lights.push(PunctualLight {
            name: "laser".into(),
            position: Vec3::ZERO,
            intensity_w_per_sr: [i as f32; 3],
            spot: None,
            projector: None,
        });
        let t_of = |r: f64| 2.0 * n * r / C;
        let axis = TimeAxis::new(t_of(1.0), t_of(0.2), 40).unwrap();
        let settings = RenderSettings {
            max_bounces: 1,
            seed: 5,
            ..RenderSettings::default()
        };
        let (w, h) = (8, 8);
        let r = render_with(scene, w, h, axis, 256, settings, 0);
        let tprfs: Vec<Vec<f64>> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| r.film.pixel_tprf(x, y))
            .collect();
        let npx = tprfs.len() as f64;
        let (ks, kt) = (k * sigma_s, k * (sigma_s + sigma_a));
        for b in 0..axis.bins {
            let mean = tprfs.iter().map(|t| t[b]).sum::<f64>() / npx;
            let var = tprfs.iter().map(|t| (t[b] - mean).powi(2)).sum::<f64>() / (npx - 1.0);
            let se = (var / npx).sqrt();
            let (r0, r1) = (
                axis.bin_start_s(b) * C / (2.0 * n),
                axis.bin_start_s(b + 1) * C / (2.0 * n),
            );
            let want =
                ks * hg(-1.0, g) * i * simpson(r0, r1, 200, |r| (-2.0 * kt * r).exp() / (r * r));
            assert!(
                (mean - want).abs() < 5.0 * se + 1e-4 * want,
                "k {k}: bin {b} (r {r0:.2}-{r1:.2} m): {mean} vs {want} (se {se})"
            );
        }
    }
}

/// The lit plane (z = 0, camera and light at height h) under an absorbing grid of two
/// samples along z over the box from the plane to the camera's height: trilinear
/// interpolation between the cell centres (h/4 and 3h/4) gives `d1` below h/4, a ramp,
/// `d2` above 3h/4, so `integral_0^h density dz = (d1 + d2) h / 2`, and every path from
/// the light down to the plane and back up crosses the whole height at the slant of its
/// own straight line: the attenuation is `e^(-sigma_a (d1 + d2) / 2 x path)`, that of the
/// homogeneous medium `sigma_a (d1 + d2) / 2` (tprf_core::reference::plane, `in_medium`).
/// A box from the plane to h/2 only holds half that integral. Per pixel, the steady
/// radiance and the mean arrival; in index 1.5, times scaled by n.
#[test]
fn an_absorbing_grid_attenuates_by_its_integral() {
    let (h_m, rho, i, fov) = (2.0f64, 0.5, 3.0, 40.0);
    let (d1, d2, sigma_a, n) = (0.25f32, 1.75f32, 0.15f64, 1.5f64);
    for (top_m, sigma_eq) in [(h_m, sigma_a), (h_m / 2.0, sigma_a / 2.0)] {
        let plane = Plane::colocated(h_m, rho, i, 50.0, fov).in_medium(sigma_eq, n);
        let mut scene = plane.scene();
        let slabs = grid(
            [1, 1, 2],
            vec![d1, d2],
            [-60.0, -60.0, 0.0],
            [60.0, 60.0, top_m as f32],
        );
        scene.medium = Some(Medium {
            density: Some(slabs),
            ..Medium::grey(0.0, sigma_a as f32, 0.0, n as f32)
        });
        let (w, hp) = (12, 9);
        let axis = plane.default_axis(w, hp, 60).unwrap();
        let spp = 64;
        let r = render_scene(scene, w, hp, axis, spp, 7, 0);
        let se = |sd: f64| 4.0 * sd / (spp as f64).sqrt();
        let vacuum = Plane::colocated(h_m, rho, i, 50.0, fov);
        for y in 0..hp {
            for x in 0..w {
                let m = plane.pixel_moments(x, y, w, hp);
                let tprf = r.film.pixel_tprf(x, y);
                let steady: f64 = tprf.iter().sum();
                assert!(
                    (steady - m.mean).abs() < se(m.sd) + 1e-4 * m.mean,
                    "box top {top_m} m, pixel ({x},{y}): steady {steady} vs {}",
                    m.mean
                );
                let t = mean_arrival_s(&tprf, &axis);
                assert!(
                    (t - m.mean_arrival_s).abs() < se(m.sd_arrival_s) + 0.5 * axis.dt_s,
                    "pixel ({x},{y}): mean arrival {t} vs {}",
                    m.mean_arrival_s
                );
                // The check can fail: the grid darkens the plane by far more than the noise.
                let v = vacuum.pixel_moments(x, y, w, hp);
                assert!(steady < v.mean * (-sigma_eq * 2.0 * h_m).exp() * 1.001);
            }
        }
    }
}

/// All orders of scattering: a closed furnace lit by a pulsed point light at its centre,
/// filled with a constant grid of density `k` times coefficients `sigma / k`, renders the
/// cube of the homogeneous medium `sigma` (every bin of the mean over pixels within the
/// two renders' noise): free-flight distances drawn by inverting the grid's optical
/// depth follow the homogeneous medium's law. A grid of another density does not (the
/// check can fail).
#[test]
fn all_orders_in_a_constant_grid_match_the_homogeneous_cube() {
    let furnace = Furnace::point(1.0, 0.6, 1.0);
    let axis = TimeAxis::new(0.0, 0.4 / C, 40).unwrap();
    let (w, h, spp) = (16, 16, 256);
    let per_bin = |medium: Medium, seed: u64| -> (Vec<f64>, Vec<f64>) {
        let mut scene = furnace.scene();
        scene.medium = Some(medium);
        let r = render_scene(scene, w, h, axis, spp, seed, 0);
        let tprfs: Vec<Vec<f64>> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| r.film.pixel_tprf(x, y))
            .collect();
        let n = tprfs.len() as f64;
        (0..axis.bins)
            .map(|b| {
                let m = tprfs.iter().map(|t| t[b]).sum::<f64>() / n;
                let v = tprfs.iter().map(|t| (t[b] - m).powi(2)).sum::<f64>() / (n - 1.0);
                (m, (v / n).sqrt())
            })
            .unzip()
    };
    let homogeneous = Medium::grey(1.5, 0.3, 0.5, 1.0);
    let with_k = |k: f32, scale: f32| Medium {
        density: Some(grid([2, 2, 3], vec![k; 12], [-1.5; 3], [1.5; 3])),
        ..Medium::grey(1.5 * scale / k, 0.3 * scale / k, 0.5, 1.0)
    };
    let (want, want_se) = per_bin(homogeneous, 1);
    let (got, got_se) = per_bin(with_k(2.5, 1.0), 2);
    let mut chi2 = 0.0;
    for b in 0..axis.bins {
        let se = (want_se[b].powi(2) + got_se[b].powi(2)).sqrt();
        assert!(
            (got[b] - want[b]).abs() < 5.0 * se + 1e-9,
            "bin {b}: {} vs {} (se {se})",
            got[b],
            want[b]
        );
        if se > 0.0 {
            chi2 += ((got[b] - want[b]) / se).powi(2);
        }
    }
    assert!(
        chi2 < 2.5 * axis.bins as f64,
        "chi2 {chi2} over {} bins",
        axis.bins
    );
    // Twice the extinction is told apart.
    let (other, other_se) = per_bin(with_k(2.5, 2.0), 2);
    let mut chi2 = 0.0;
    for b in 0..axis.bins {
        let se = (want_se[b].powi(2) + other_se[b].powi(2)).sqrt();
        if se > 0.0 {
            chi2 += ((other[b] - want[b]) / se).powi(2);
        }
    }
    assert!(
        chi2 > 4.0 * axis.bins as f64,
        "chi2 {chi2}: denser not told apart"
    );
}

/// Mean steady radiance over an 8 x 8 image's pixels and its standard error.
fn steady_mean(scene: Scene, spp: u32, seed: u64) -> (f64, f64) {
    mean_and_se(&steady_pixels(scene, 8, 8, spp, seed))
}

/// A blob: density `peak e^(-|p - c|^2 / (2 s^2))` sampled on an `n^3` grid over the
/// cube `[-1, 1]^3`, nearly empty at its corners, with a dense core off-centre.
fn blob(n: u32, peak: f32) -> DensityGrid {
    let c = Vec3::new(0.2, -0.1, 0.15);
    let mut v = Vec::new();
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let p = (Vec3::new(x as f32, y as f32, z as f32) + 0.5) / n as f32 * 2.0 - 1.0;
                v.push(peak * (-(p - c).length_squared() / (2.0 * 0.3 * 0.3)).exp());
            }
        }
    }
    grid([n, n, n], v, [-1.0; 3], [1.0; 3])
}

/// A closed furnace whose wall emits `Le` and reflects `rho` holds the uniform isotropic
/// field `Le / (1 - rho)`; a non-absorbing medium scatters a uniform isotropic field into
/// itself, so a white heterogeneous medium (any density, any phase function) leaves the
/// steady radiance as it was. An absorbing blob darkens it (the check can fail).
#[test]
fn a_white_grid_leaves_the_furnace_radiance_unchanged() {
    let furnace = Furnace::emitting(1.0, 0.5, 1.0);
    let want = furnace.energy();
    for (sigma_s, g) in [(2.0f32, 0.0f32), (4.0, 0.7)] {
        let mut scene = furnace.scene();
        scene.medium = Some(Medium {
            density: Some(blob(12, 3.0)),
            ..Medium::grey(sigma_s, 0.0, g, 1.0)
        });
        let (mean, se) = steady_mean(scene, 128, 9);
        assert!(
            (mean - want).abs() < 4.0 * se + 2e-3 * want,
            "sigma_s {sigma_s} g {g}: {mean} vs {want} (se {se})"
        );
    }
    let mut scene = furnace.scene();
    scene.medium = Some(Medium {
        density: Some(blob(12, 3.0)),
        ..Medium::grey(2.0, 1.0, 0.0, 1.0)
    });
    let (mean, se) = steady_mean(scene, 64, 9);
    assert!(mean < want - 10.0 * se, "absorbing: {mean}");
}

/// A glTF holding a unit cube (material 0, whose extras give `medium`) in front of a
/// camera, with a point light; written to `dir/scene.gltf`.
fn write_gltf(dir: &Path, medium: serde_json::Value) -> std::path::PathBuf {
    let mut s = empty_scene(Camera::look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 0.8));
    let c = [
        [-0.5, -0.5, -0.5],
        [0.5, -0.5, -0.5],
        [0.5, 0.5, -0.5],
        [-0.5, 0.5, -0.5],
        [-0.5, -0.5, 0.5],
        [0.5, -0.5, 0.5],
        [0.5, 0.5, 0.5],
        [-0.5, 0.5, 0.5],
    ]
    .map(Vec3::from);
    s.materials
        .push(scene::Material::lambertian("smoke box", [0.5; 3]));
    // Outward-facing quads of the cube.
    for q in [
        [0, 3, 2, 1],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [3, 7, 6, 2],
        [0, 4, 7, 3],
        [1, 2, 6, 5],
    ] {
        push_tri(&mut s, [c[q[0]], c[q[1]], c[q[2]]], 0);
        push_tri(&mut s, [c[q[0]], c[q[2]], c[q[3]]], 0);
    }
    s.lights.push(PunctualLight {
        name: "lamp".into(),
        position: Vec3::new(0.0, 0.0, 4.0),
        intensity_w_per_sr: [10.0; 3],
        spot: None,
        projector: None,
    });
    let path = dir.join("scene.gltf");
    scene::gltf_save::save_gltf(&s, &path).unwrap();
    let mut v = json(&path);
    v["materials"][0]["extras"] = serde_json::json!({"tprf": {"medium": medium}});
    std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
    path
}

/// A `.vol` file written here from the documented format, named in a glTF material's
/// extras relative to the glTF: its values where the samples sit, its box replaced by
/// the mesh's bounds (a mesh medium's default) or by the extras' box; the same file read
/// by a Mitsuba scene through `<volume type="gridvolume">`, its box the volume's
/// `to_world` applied to the unit cube; tprf.json records the grid's file and size.
#[test]
fn a_vol_file_is_read_back_through_gltf_and_mitsuba() {
    let dir = tempdir("vol");
    let values: Vec<f32> = (0..24).map(|i| i as f32 * 0.25).collect();
    let bytes = vol_bytes([4, 3, 2], 1, [0.0, 0.0, 0.0, 4.0, 3.0, 2.0], &values);
    std::fs::create_dir_all(dir.join("grids")).unwrap();
    std::fs::write(dir.join("grids/smoke.vol"), &bytes).unwrap();
    let medium = serde_json::json!({"sigma_s_per_m": 2.0, "sigma_a_per_m": 0.5, "g": 0.3,
        "density": {"file": "grids/smoke.vol"}});
    let path = write_gltf(&dir, medium);
    let s = scene::load(path.to_str().unwrap()).unwrap();
    let m = s.materials[0].medium.clone().unwrap();
    let d = m.density.clone().unwrap();
    assert_eq!(d.dims, [4, 3, 2]);
    assert_eq!(d.max(), 23.0 * 0.25);
    assert_eq!(d.bbox_m, Some([[-0.5; 3], [0.5; 3]]), "the cube's bounds");
    // Sample (x, y, z) sits at the centre of its cell of the box: value (z 3 + y) 4 + x.
    for (x, y, z) in [(0usize, 0usize, 0usize), (3, 2, 1), (1, 2, 0), (2, 0, 1)] {
        let p = Vec3::new(
            (x as f32 + 0.5) / 4.0 - 0.5,
            (y as f32 + 0.5) / 3.0 - 0.5,
            (z as f32 + 0.5) / 2.0 - 0.5,
        );
        let want = values[(z * 3 + y) * 4 + x] as f64;
        assert!(
            (d.density_at(p.as_dvec3()) - want).abs() < 1e-5,
            "({x},{y},{z})"
        );
    }
    // The extras' box wins.
    let medium = serde_json::json!({"sigma_s_per_m": 2.0, "density": {"file": "grids/smoke.vol",
        "bbox_min_m": [-2, -1, 0], "bbox_max_m": [2, 1, 1]}});
    let path = write_gltf(&dir, medium);
    let s = scene::load(path.to_str().unwrap()).unwrap();
    let d = s.materials[0].medium.clone().unwrap().density.unwrap();
    assert_eq!(d.bbox_m, Some([[-2.0, -1.0, 0.0], [2.0, 1.0, 1.0]]));

    // tprf.json: the grid by its file and size.
    let out = dir.join("out");
    let o = tprf(&[
        "render",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "2",
        "--bins",
        "16",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let meta = json(&out.join("tprf.json"));
    let media = meta["media"].as_array().expect("media recorded");
    let g = &media[0]["density"];
    assert_eq!(g["dims"], serde_json::json!([4, 3, 2]), "{meta}");
    assert!(
        g["file"].as_str().unwrap().ends_with("grids/smoke.vol"),
        "{g}"
    );
    assert_eq!(g["bbox_max_m"], serde_json::json!([2.0, 1.0, 1.0]));
    assert!(g.get("values").is_none());

    // Mitsuba: sigma_t a gridvolume scaled and moved by to_world, albedo and scale.
    let xml = r#"<scene version="3.0.0">
  <sensor type="perspective">
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
  </sensor>
  <emitter type="point"><point name="position" x="0" y="0" z="5"/></emitter>
  <shape type="cube">
    <bsdf type="null"/>
    <medium type="heterogeneous" name="interior">
      <volume type="gridvolume" name="sigma_t">
        <string name="filename" value="grids/smoke.vol"/>
        <transform name="to_world"><scale x="2" y="4" z="1"/><translate x="-1" y="-2" z="-0.5"/></transform>
      </volume>
      <float name="albedo" value="0.8"/>
      <float name="scale" value="3"/>
      <phase type="hg"><float name="g" value="0.5"/></phase>
    </medium>
  </shape>
</scene>
"#
    .to_string();
    std::fs::write(dir.join("grid.xml"), &xml).unwrap();
    let s = scene::load(dir.join("grid.xml").to_str().unwrap()).unwrap();
    let m = s
        .materials
        .iter()
        .find_map(|m| m.medium.clone())
        .expect("the cube's medium");
    let close = |a: [f32; 3], b: f32| a.iter().all(|x| (x - b).abs() < 1e-6);
    assert!(close(m.sigma_s_per_m, 3.0 * 0.8), "{m:?}");
    assert!(close(m.sigma_a_per_m, 3.0 * 0.2), "{m:?}");
    assert_eq!(m.g, 0.5);
    let d = m.density.unwrap();
    assert_eq!(d.dims, [4, 3, 2]);
    assert_eq!(d.bbox_m, Some([[-1.0, -2.0, -0.5], [1.0, 2.0, 0.5]]));
    // A rotated volume cannot be an axis-aligned box: refused naming to_world.
    let rotated = xml.replace(
        "<scale x=\"2\" y=\"4\" z=\"1\"/>",
        "<rotate y=\"1\" angle=\"30\"/>",
    );
    std::fs::write(dir.join("rotated.xml"), &rotated).unwrap();
    let e = scene::load(dir.join("rotated.xml").to_str().unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("to_world") && e.contains("rotated.xml:9"), "{e}");
    // A grid of albedos is not a density: refused.
    let albedo = xml
        .replace("name=\"sigma_t\"", "name=\"albedo\"")
        .replace("<float name=\"albedo\" value=\"0.8\"/>", "");
    std::fs::write(dir.join("albedo.xml"), &albedo).unwrap();
    let e = scene::load(dir.join("albedo.xml").to_str().unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("albedo is constant"), "{e}");
}

/// Bad grids are refused naming the field or the file and what is wrong, never a panic:
/// a missing file, a cut-short file, a header claiming sizes far beyond memory, NaN and
/// negative values, three channels, a wrong version, encoding or magic, inline values
/// that do not match their dims, and a scene-wide grid without a box.
#[test]
fn bad_grids_are_refused_by_field_and_file() {
    let dir = tempdir("bad");
    let ok_box = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    let eight = [1.0f32; 8];
    let mut nan = eight;
    nan[6] = f32::NAN;
    let mut negative = eight;
    negative[1] = -0.5;
    let mut version = vol_bytes([2, 2, 2], 1, ok_box, &eight);
    version[3] = 2;
    let mut encoding = vol_bytes([2, 2, 2], 1, ok_box, &eight);
    encoding[4] = 2;
    let files: Vec<(&str, Option<Vec<u8>>, &str)> = vec![
        ("missing.vol", None, "No such file"),
        (
            "short.vol",
            Some(vol_bytes([2, 2, 2], 1, ok_box, &eight[..7])),
            "76 bytes, but its header's sizes [2, 2, 2] x 1 channel need 80",
        ),
        (
            "huge.vol",
            Some(vol_bytes([1 << 30, 1 << 30, 1 << 30], 1, ok_box, &eight)),
            "sizes [1073741824, 1073741824, 1073741824] x 1 channel need 4951760157141521099596496944",
        ),
        (
            "nan.vol",
            Some(vol_bytes([2, 2, 2], 1, ok_box, &nan)),
            "value NaN at (x 0, y 1, z 1)",
        ),
        (
            "negative.vol",
            Some(vol_bytes([2, 2, 2], 1, ok_box, &negative)),
            "value -0.5 at (x 1, y 0, z 0)",
        ),
        (
            "rgb.vol",
            Some(vol_bytes([2, 2, 2], 3, ok_box, &[1.0; 24])),
            "3 channels",
        ),
        ("version.vol", Some(version), "version 2"),
        ("encoding.vol", Some(encoding), "encoding 2"),
        (
            "magic.vol",
            Some(b"VOX".repeat(30)),
            "does not start with 'VOL'",
        ),
        (
            "box.vol",
            Some(vol_bytes(
                [2, 2, 2],
                1,
                [0.0, 0.0, 0.0, 1.0, -1.0, 1.0],
                &eight,
            )),
            "min < max",
        ),
    ];
    for (name, bytes, needle) in files {
        if let Some(b) = bytes {
            std::fs::write(dir.join(name), b).unwrap();
        }
        let path = write_gltf(
            &dir,
            serde_json::json!({"sigma_s_per_m": 1.0, "density": {"file": name}}),
        );
        let e = scene::load(path.to_str().unwrap()).unwrap_err().to_string();
        assert!(
            e.contains("materials[0] extras tprf.medium.density.file") && e.contains(name),
            "{name}: {e}"
        );
        assert!(e.contains(needle), "{name}: {e}");
    }
    for (medium, needle) in [
        (
            serde_json::json!({"density": {"dims": [2, 2, 2], "values": [1, 2, 3]}}),
            "tprf.medium.density.values: 3 values for dims [2, 2, 2], which need 8",
        ),
        (
            serde_json::json!({"density": {"dims": [100000, 100000, 100000], "values": [1]}}),
            "1 values for dims [100000, 100000, 100000], which need 1000000000000000",
        ),
        (
            serde_json::json!({"density": {"dims": [1, 1, 2], "values": [1, -2]}}),
            "value -2 at (x 0, y 0, z 1)",
        ),
        (
            serde_json::json!({"density": {"dims": [1, 1], "values": [1]}}),
            "tprf.medium.density.dims = [1,1]",
        ),
        (
            serde_json::json!({"density": {"dims": [1, 1, 1], "values": ["a"]}}),
            "tprf.medium.density.values[0]",
        ),
        (
            serde_json::json!({"density": {"dims": [1, 1, 1], "values": [1],
                "bbox_min_m": [0, 0, 0], "bbox_max_m": [0, 1, 1]}}),
            "min < max",
        ),
        (
            serde_json::json!({"density": 3}),
            "tprf.medium.density = 3: expected an object",
        ),
    ] {
        let path = write_gltf(&dir, medium);
        let e = scene::load(path.to_str().unwrap()).unwrap_err().to_string();
        assert!(e.contains(needle), "{e}");
    }
    // A scene-wide grid has no mesh to take a box from.
    let mut s = empty_scene(Camera::look_at(Vec3::Z, Vec3::ZERO, 0.8));
    s.medium = Some(Medium {
        density: Some(DensityGrid::new([1, 1, 1], vec![1.0], None, None, "g").unwrap()),
        ..Medium::grey(1.0, 0.0, 0.0, 1.0)
    });
    let e = s.validate().unwrap_err().to_string();
    assert!(
        e.contains("scene medium") && e.contains("bbox_min_m"),
        "{e}"
    );
}

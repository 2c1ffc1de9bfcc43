//! Luminescent surfaces (issue 47): the lit plane made luminescent against its closed
//! form per bin (one and two lifetimes), energy against steady renders of the same
//! scene with the yield as albedo, the delay sampled into a late window, and the
//! refusals of bad input in glTF, Mitsuba XML and the scene.

use crate::common::*;
use std::path::{Path, PathBuf};
use tprf_core::film::TimeAxis;
use tprf_core::reference::luminescent_plane::LuminescentPlane;
use tprf_core::reference::plane::Plane;
use tprf_core::scene::{self, Channel, Luminescence, Scene};
use tprf_core::transport::{DelaySampling, RenderSettings};

const LIFETIME_S: f64 = 4e-9;

fn lplane(rho: f64, components: &[(f64, f64)]) -> LuminescentPlane {
    LuminescentPlane {
        plane: Plane::colocated(2.0, rho, 3.0, 50.0, 40.0),
        components: components.to_vec(),
    }
}

/// Render `lp` at 6 x 4 on `axis` with `spp` and `delay`, and compare every bin from
/// `first_bin` on with the closed form: the mean over the pixels of `rendered - exact`
/// within 4.5 of its standard errors (estimated from the 24 pixels' residuals, which
/// are independent) plus 1e-4 of the peak bin. Returns the worst relative error of the
/// bins holding at least 1 % of the peak bin.
fn check_plane(
    lp: &LuminescentPlane,
    axis: TimeAxis,
    spp: u64,
    delay: DelaySampling,
    first_bin: usize,
) -> f64 {
    let (w, h) = (6, 4);
    let settings = RenderSettings {
        seed: 3,
        luminescence_delay: delay,
        ..RenderSettings::default()
    };
    let r = render_with(lp.scene(), w, h, axis, spp, settings, 0);
    let mut residuals = vec![Vec::new(); axis.bins];
    let mut want = vec![0.0; axis.bins];
    for y in 0..h {
        for x in 0..w {
            let g = r.film.pixel_tprf(x, y);
            let e = lp.pixel_tprf(x, y, w, h, &axis);
            for b in 0..axis.bins {
                residuals[b].push(g[b] - e[b]);
                want[b] += e[b] / (w * h) as f64;
            }
        }
    }
    let peak = want.iter().cloned().fold(0.0, f64::max);
    let mut worst = 0.0f64;
    for b in first_bin..axis.bins {
        let (mean, se) = mean_and_se(&residuals[b]);
        if want[b] == 0.0 {
            // Before the first return: nothing at all.
            assert!(residuals[b].iter().all(|&r| r == 0.0), "{delay:?} bin {b}");
            continue;
        }
        assert!(
            mean.abs() < 4.5 * se + 1e-4 * peak,
            "{delay:?} bin {b} ({:.2} ns): rendered - exact = {mean} (standard error {se}, \
             exact {})",
            axis.bin_center_s(b) * 1e9,
            want[b]
        );
        if want[b] >= 0.01 * peak {
            worst = worst.max(mean.abs() / want[b]);
        }
    }
    eprintln!(
        "{delay:?} at {spp} spp: worst bin off by {:.2} %",
        100.0 * worst
    );
    worst
}

#[test]
fn a_luminescent_plane_decays_as_its_closed_form_per_bin() {
    let t_direct = 4.0 / C;
    let axis = TimeAxis::new(0.95 * t_direct, 0.5e-9, 90).unwrap();
    let lp = lplane(0.3, &[(0.4, LIFETIME_S)]);
    // The expected cube holds the decay: its tail is e^{-(t - t0)/tau} (checked on the
    // reference itself, so a wrong reference cannot pass).
    let e = lp.pixel_tprf(3, 2, 6, 4, &axis);
    let (b1, b2) = (60, 68);
    let ratio = e[b2] / e[b1];
    let want = (-((b2 - b1) as f64) * 0.5e-9 / LIFETIME_S).exp();
    assert!((ratio / want - 1.0).abs() < 1e-3, "{ratio} vs {want}");
    // Sampled delays: about spp x 24 x P(bin) draws land in a bin; the splat's bins
    // see the decay exactly. Both must also be close, not only within their noise.
    assert!(check_plane(&lp, axis, 4096, DelaySampling::Sampled, 0) < 0.3);
    assert!(check_plane(&lp, axis, 256, DelaySampling::Splat, 0) < 0.2);
}

/// With bounce layers, the film's luminescence layer holds the re-emitted light and the
/// bounce layers the rest: on the lit plane the layer is the closed form's decay alone
/// and the single-bounce layer the plain plane's direct return (both per bin within
/// noise), the direct and ">1" layers are empty, and the layers add up to the total.
#[test]
fn the_luminescence_layer_holds_the_decay_and_the_bounce_layers_the_rest() {
    let t_direct = 4.0 / C;
    let axis = TimeAxis::new(0.95 * t_direct, 0.5e-9, 60).unwrap();
    let lp = lplane(0.3, &[(0.4, LIFETIME_S)]);
    let (w, h) = (6, 4);
    let settings = RenderSettings {
        seed: 5,
        luminescence_delay: DelaySampling::Splat,
        ..RenderSettings::default()
    };
    let r = render_with(lp.scene(), w, h, axis, 256, settings, 1);
    let layout = *r.film.layout();
    assert_eq!(layout.bounce_layers(), 4);
    assert_eq!(layout.luminescence_layer(), Some(3));
    // Expected per layer: [direct, 1 bounce, >1, luminescence].
    let mut residuals = vec![vec![Vec::new(); axis.bins]; 4];
    let mut want = vec![vec![0.0; axis.bins]; 4];
    for y in 0..h {
        for x in 0..w {
            let total = r.film.pixel_tprf(x, y);
            let layers = r.film.pixel_bounces(x, y);
            let reflected = lp.plane.pixel_tprf(x, y, w, h, &axis);
            let all = lp.pixel_tprf(x, y, w, h, &axis);
            for b in 0..axis.bins {
                let sum: f64 = layers.iter().map(|l| l[b]).sum();
                assert!(
                    (sum - total[b]).abs() <= 1e-9 * total[b].abs().max(1e-30),
                    "pixel {x},{y} bin {b}: layers add to {sum}, the total is {}",
                    total[b]
                );
                let expected = [0.0, reflected[b], 0.0, all[b] - reflected[b]];
                for l in 0..4 {
                    residuals[l][b].push(layers[l][b] - expected[l]);
                    want[l][b] += expected[l] / (w * h) as f64;
                }
            }
        }
    }
    let peak = want.iter().flatten().cloned().fold(0.0, f64::max);
    for (l, name) in ["direct", "1 bounce", ">1", "luminescence"]
        .iter()
        .enumerate()
    {
        let mut lit = 0;
        for b in 0..axis.bins {
            let (mean, se) = mean_and_se(&residuals[l][b]);
            if want[l][b] == 0.0 {
                assert!(
                    residuals[l][b].iter().all(|&r| r == 0.0),
                    "{name} layer, bin {b}: light where none belongs"
                );
                continue;
            }
            lit += 1;
            assert!(
                mean.abs() < 4.5 * se + 1e-4 * peak,
                "{name} layer, bin {b}: rendered - exact = {mean} (standard error {se}, \
                 exact {})",
                want[l][b]
            );
        }
        // The reflection fills a few bins, the decay most of the window.
        match l {
            1 => assert!((1..10).contains(&lit), "{name}: {lit} lit bins"),
            3 => assert!(lit > 40, "{name}: {lit} lit bins"),
            _ => {}
        }
    }
}

#[test]
fn two_lifetimes_add_their_decays() {
    let t_direct = 4.0 / C;
    let axis = TimeAxis::new(0.95 * t_direct, 0.25e-9, 120).unwrap();
    let lp = lplane(0.2, &[(0.3, 1e-9), (0.2, 5e-9)]);
    assert!(check_plane(&lp, axis, 4096, DelaySampling::Sampled, 0) < 0.3);
    assert!(check_plane(&lp, axis, 256, DelaySampling::Splat, 0) < 0.2);
}

#[test]
fn a_late_window_gets_the_decays_light_not_by_luck() {
    // 50 ns after a 13 ns return on a 4 ns lifetime: e^{-9} of the decay, in a window
    // that holds no direct light. Drawn from the decay, 1024 samples a pixel would put
    // about 2 delays in the window in all; drawn for the window, half of the re-emitted
    // ones land there and every bin is within noise (and within 35 %: some 60 draws in the last bin).
    let axis = TimeAxis::new(50e-9, 0.5e-9, 20).unwrap();
    let lp = lplane(0.3, &[(0.4, LIFETIME_S)]);
    assert!(check_plane(&lp, axis, 1024, DelaySampling::Sampled, 0) < 0.35);
    // Splatted, every bin gets every re-emission's share: 64 samples do better.
    assert!(check_plane(&lp, axis, 64, DelaySampling::Splat, 0) < 0.1);
}

#[test]
fn a_black_plane_with_yield_y_is_y_times_the_white_planes_steady_image() {
    let (w, h) = (6, 4);
    let y = 0.45;
    let lp = lplane(0.0, &[(y, 1e-9)]);
    // A window holding the whole decay (200 lifetimes).
    let axis = TimeAxis::new(0.0, 1e-9, 200).unwrap();
    let r = render_scene(lp.scene(), w, h, axis, 128, 9, 0);
    let white = Plane::colocated(2.0, 1.0, 3.0, 50.0, 40.0);
    for py in 0..h {
        for px in 0..w {
            let got: f64 = r.film.pixel_tprf(px, py).iter().sum();
            let want = y * white.pixel_moments(px, py, w, h).mean;
            assert!(
                (got / want - 1.0).abs() < 0.02,
                "({px}, {py}): {got} vs {want}"
            );
        }
    }
}

/// The Cornell box with every surface's band albedo moved into a yield (base colour 0),
/// against the box as it is: the same steady image (re-emission is Lambertian with
/// albedo Y; only its time differs), interreflections included.
#[test]
fn a_box_of_yield_only_walls_has_the_steady_image_of_the_same_albedos() {
    let plain = scene::builtin::load("cornell").unwrap();
    let mut glowing = plain.clone();
    for m in &mut glowing.materials {
        let red = m.base_color[0];
        if m.model == tprf_core::scene::SurfaceModel::MetallicRoughness
            && m.metallic == 0.0
            && red > 0.0
        {
            m.base_color = [0.0, 0.0, 0.0, 1.0];
            m.specular_factor = 0.0;
            m.luminescence = Some(Luminescence::single(red, 2e-10));
        }
    }
    glowing.validate().unwrap();
    let (w, h, spp) = (8, 8, 256);
    let axis = TimeAxis::new(0.0, 1e-9, 100).unwrap();
    let settings = RenderSettings {
        seed: 2,
        channel: Channel::Red,
        ..RenderSettings::default()
    };
    let a = render_with(plain, w, h, axis, spp, settings, 0);
    let b = render_with(glowing, w, h, axis, spp, settings, 0);
    let diffs: Vec<f64> = a
        .film
        .steady()
        .iter()
        .zip(b.film.steady())
        .map(|(x, y)| x - y)
        .collect();
    let total: f64 = a.film.steady().iter().sum::<f64>() / (w * h) as f64;
    let (mean, se) = mean_and_se(&diffs);
    assert!(
        mean.abs() < 4.0 * se + 0.002 * total,
        "steady differs by {mean} (standard error {se}, mean {total})"
    );
    // And in time it differs: the re-emission arrives later on average.
    let mean_t = |f: &tprf_core::film::TprfFilm| {
        let mut sum = vec![0.0; axis.bins];
        for y in 0..h {
            for x in 0..w {
                for (s, v) in sum.iter_mut().zip(f.pixel_tprf(x, y)) {
                    *s += v;
                }
            }
        }
        mean_arrival_s(&sum, &axis)
    };
    assert!(mean_t(&b.film) > mean_t(&a.film) + 1e-10);
}

#[test]
fn renders_do_not_depend_on_the_thread_count() {
    let lp = lplane(0.3, &[(0.4, LIFETIME_S)]);
    let axis = TimeAxis::new(12e-9, 0.5e-9, 60).unwrap();
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render_scene(lp.scene(), 5, 3, axis, 16, 1, 0))
    };
    let (one, two) = (run(1), run(2));
    for y in 0..3 {
        for x in 0..5 {
            assert_eq!(one.film.pixel_tprf(x, y), two.film.pixel_tprf(x, y));
        }
    }
}

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("luminescence-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn load(path: &Path) -> Result<Scene, String> {
    scene::load(&path.display().to_string()).map_err(|e| e.to_string())
}

#[test]
fn gltf_extras_round_trip_and_bad_values_are_refused_by_name() {
    let dir = tmp("gltf");
    let mut s = lplane(0.3, &[(0.1, 1e-9), (0.2, 4e-9)]).scene();
    s.materials[0].name = "phosphor".into();
    if let Some(l) = s.materials[0].luminescence.as_mut() {
        l.rise_s = Some(2e-10);
        l.emission_color = [0.2, 1.0, 0.4];
    }
    let path = dir.join("lum.gltf");
    scene::gltf_save::save_gltf(&s, &path).unwrap();
    let back = load(&path).unwrap();
    assert_eq!(back.materials[0].luminescence, s.materials[0].luminescence);
    // The single form of the issue, and refusals naming the material and field.
    let text = std::fs::read_to_string(&path).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let set = |doc: &mut serde_json::Value, v: serde_json::Value| {
        doc["materials"][0]["extras"]["tprf"]["luminescence"] = v;
    };
    let with = |doc: &serde_json::Value, name: &str| {
        let p = dir.join(name);
        std::fs::write(&p, serde_json::to_string(doc).unwrap()).unwrap();
        load(&p)
    };
    set(
        &mut doc,
        serde_json::json!({"yield": 0.4, "lifetime_s": 4e-9}),
    );
    let one = with(&doc, "one.gltf").unwrap();
    assert_eq!(
        one.materials[0].luminescence,
        Some(Luminescence::single(0.4, 4e-9))
    );
    for (v, needle) in [
        (
            serde_json::json!({"yield": 0.4, "lifetime_s": 0.0}),
            "lifetime_s 0",
        ),
        (
            serde_json::json!({"yield": 0.4, "lifetime_s": -1e-9}),
            "lifetime_s -0.000000001",
        ),
        (serde_json::json!({"yield": 0.4}), "lifetime_s"),
        (
            serde_json::json!({"yield": 0.9, "lifetime_s": 1e-9}),
            "plus yield 0.9",
        ),
        (
            serde_json::json!({"components": [[0.1, 1e-9], [0.2]]}),
            "components[1]",
        ),
    ] {
        set(&mut doc, v.clone());
        let e = with(&doc, "bad.gltf").unwrap_err();
        assert!(e.contains(needle), "{v}: {e}");
        assert!(
            e.contains("phosphor") || e.contains("materials[0]"),
            "{v}: {e}"
        );
    }
}

const XML: &str = r#"<?xml version="1.0"?>
<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 2" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <emitter type="point"><point name="position" x="0" y="0" z="2"/><rgb name="intensity" value="3, 3, 3"/></emitter>
    <shape type="rectangle" id="slide">
        <transform name="to_world"><scale value="5"/></transform>
        <bsdf type="tprf_luminescent" id="dye">
            BODY
            <bsdf type="diffuse"><rgb name="reflectance" value="0.3, 0.3, 0.3"/></bsdf>
        </bsdf>
    </shape>
</scene>
"#;

#[test]
fn the_mitsuba_wrapper_reads_one_or_more_lifetimes_and_refuses_bad_ones() {
    let dir = tmp("xml");
    let load_body = |name: &str, body: &str| {
        let p = dir.join(name);
        std::fs::write(&p, XML.replace("BODY", body)).unwrap();
        load(&p)
    };
    let s = load_body(
        "one.xml",
        r#"<float name="yield" value="0.4"/><float name="lifetime" value="4e-9"/>"#,
    )
    .unwrap();
    let m = &s.materials[s.attrs[0].material as usize];
    assert_eq!(m.luminescence, Some(Luminescence::single(0.4, 4e-9)));
    assert_eq!(&m.base_color[..3], &[0.3, 0.3, 0.3]);
    let s = load_body(
        "two.xml",
        r#"<float name="yield_1" value="0.1"/><float name="lifetime_1" value="1e-9"/>
           <float name="yield_2" value="0.3"/><float name="lifetime_2" value="4e-9"/>
           <float name="rise_time" value="1e-10"/><rgb name="emission_color" value="0, 1, 0"/>"#,
    )
    .unwrap();
    let l = s.materials[s.attrs[0].material as usize]
        .luminescence
        .clone()
        .unwrap();
    assert_eq!(l.components.len(), 2);
    assert_eq!((l.rise_s, l.emission_color), (Some(1e-10), [0.0, 1.0, 0.0]));
    for (body, needle) in [
        (r#"<float name="yield" value="0.4"/>"#, "lifetime"),
        (
            r#"<float name="yield" value="0.4"/><float name="lifetime" value="0"/>"#,
            "lifetime 0",
        ),
        (
            r#"<float name="yield" value="0.8"/><float name="lifetime" value="1e-9"/>"#,
            "plus yield 0.8",
        ),
        ("", "needs"),
    ] {
        let e = load_body("bad.xml", body).unwrap_err();
        assert!(e.contains(needle), "{body}: {e}");
    }
}

/// builtin:flim rendered, then measured with the `flim` preset's two gates: the
/// lifetime image recovers each dye's own lifetime (1 ns and 4 ns, the materials'),
/// while the steady image cannot tell the spots apart.
#[test]
fn flim_tells_the_two_dyes_apart_by_their_lifetimes() {
    use tprf_core::scene::builtin::flim::{FLIM_LIFETIMES_S, flim};
    use tprf_core::sensor::{Sensor, SensorModel};
    use tprf_core::transport::Renderer;
    let (w, h) = (32, 20);
    // 0-60 ns: the whole of both decays (e^-15 of the 4 ns dye's is left out).
    let axis = TimeAxis::new(0.0, 0.05e-9, 1200).unwrap();
    let r = render_scene(flim(), w, h, axis, 64, 4, 0);
    let cube: Vec<f32> = r.film.cube_f64().iter().map(|&v| v as f32).collect();
    let model = SensorModel::new(Sensor::builtin("flim").unwrap(), axis).unwrap();
    let m = model.measure(&cube, w, h).unwrap();
    let tau = model
        .flim_lifetime(&m)
        .expect("the preset asks for the lifetime");
    // Which spot each pixel centre sees (2 mm inside its edges), by the camera's ray.
    let renderer = Renderer::new(std::sync::Arc::new(flim()), RenderSettings::default());
    let steady = r.film.steady();
    let mut found = [Vec::new(), Vec::new()];
    let mut bright = [Vec::new(), Vec::new()];
    for y in 0..h {
        for x in 0..w {
            let (o, d) = renderer.camera_ray(x as f32 + 0.5, y as f32 + 0.5, w, h);
            let p = o + d * ((0.0005 - o.y) / d.y);
            for (k, x0) in [-0.0325f32, 0.0075].into_iter().enumerate() {
                if p.x > x0 + 0.002 && p.x < x0 + 0.023 && p.z.abs() < 0.0105 {
                    found[k].push(f64::from(tau[y * w + x]));
                    bright[k].push(steady[y * w + x]);
                }
            }
        }
    }
    for k in 0..2 {
        assert!(found[k].len() >= 6, "spot {k}: {} pixels", found[k].len());
        let (mean, se) = mean_and_se(&found[k]);
        let want = FLIM_LIFETIMES_S[k];
        eprintln!(
            "dye {k}: {} pixels, lifetime {mean:.4e} s (se {se:.1e}) vs {want:e} s",
            found[k].len()
        );
        assert!(
            (mean / want - 1.0).abs() < 0.01 + 4.0 * se / want,
            "dye {k}: lifetime {mean} s (standard error {se}) vs {want} s"
        );
    }
    // The same steady brightness: one steady colour, only time tells them apart.
    let (a, sa) = mean_and_se(&bright[0]);
    let (b, sb) = mean_and_se(&bright[1]);
    assert!(
        (a - b).abs() < 4.0 * sa.hypot(sb) + 0.01 * a,
        "steady {a} vs {b}"
    );
}

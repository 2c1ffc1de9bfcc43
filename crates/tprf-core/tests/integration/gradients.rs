//! Gradients of cubes (`tprf_core::transport::derivative`, `request::Differentiable`)
//! against derivatives found without them: the lit plane's single-bounce answer (linear
//! in albedo and intensity), the transient furnace's closed form differentiated in rho
//! (central differences of the exact reference) and in the wall's emission, and central
//! differences of forward renders with common random numbers on a glossy, textured
//! Cornell box. Noise bounds follow from the sample count: the plane's per-pixel
//! standard deviation is known in closed form; elsewhere it is measured over
//! independent estimates (pixels of the furnace, seeds of the box).

use std::ops::ControlFlow;
use std::sync::Arc;
use tprf_core::film::TimeAxis;
use tprf_core::reference::furnace::Furnace;
use tprf_core::reference::plane::Plane;
use tprf_core::request::{Differentiable, DifferentiableError, Observer, RenderRequest};
use tprf_core::scene::{self, Scene, Texture, TextureRef};
use tprf_core::transport::derivative::{VjpTarget, Wrt};
use tprf_core::transport::{RenderSettings, Renderer};

const C: f64 = tprf_core::units::C_M_PER_S;

/// Reports nothing.
struct Silent;
impl Observer for Silent {}

fn request(w: usize, h: usize, axis: TimeAxis, spp: u64) -> RenderRequest {
    RenderRequest {
        width: w,
        height: h,
        bins: axis.bins,
        t0_s: Some(axis.t0_s),
        dt_s: Some(axis.dt_s),
        spp: Some(spp),
        threads: Some(2),
        ..RenderRequest::new("")
    }
}

fn names(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

fn go(_: u64, _: u64) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

/// Mean and standard error of the mean.
fn mean_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// The lit plane (camera and point light together 2 m above it) is one bounce: its cube
/// is `rho I` times a function of geometry, so `dL/drho = L(rho = 1)` and `dL/dI =
/// L(I = 1)` at every rho and I, zero included for rho. `L`'s expectation per pixel is
/// the reference's footprint integral (`pixel_moments`), and the noise of a jittered
/// sample its footprint standard deviation: the bound is 4 standard errors.
#[test]
fn lit_plane_gradients_are_the_single_bounce_answer_per_unit() {
    let (h_m, i, fov) = (2.0, 3.0, 40.0);
    let (w, hp) = (12, 9);
    let t_direct = 2.0 * h_m / C;
    let axis = TimeAxis::new(0.95 * t_direct, 0.004 * t_direct, 100).unwrap();
    let spp = 32u64;
    // Weights per pixel, the same in every bin of the window.
    let w_px = |x: usize, y: usize| 1.0 + ((x + 2 * y) % 3) as f64;
    let mut weights = vec![0f32; w * hp * axis.bins];
    for y in 0..hp {
        for x in 0..w {
            let px = y * w + x;
            weights[px * axis.bins..(px + 1) * axis.bins].fill(w_px(x, y) as f32);
        }
    }
    // Expected dL/drho and dL/dI with their standard errors, from the unit plane.
    let unit = Plane::colocated(h_m, 1.0, 1.0, 50.0, fov);
    let (mut expect, mut var) = (0.0, 0.0);
    for y in 0..hp {
        for x in 0..w {
            let m = unit.pixel_moments(x, y, w, hp);
            expect += w_px(x, y) * m.mean;
            var += (w_px(x, y) * m.sd).powi(2) / spp as f64;
        }
    }
    for rho in [0.5, 0.0] {
        let scene = Plane::colocated(h_m, rho, i, 50.0, fov).scene();
        let mut d = Differentiable::with_scene(
            &request(w, hp, axis, spp),
            Arc::new(scene),
            &names(&["material:plane.albedo", "light:point.intensity"]),
        )
        .unwrap();
        d.forward(&[], 1, &mut Silent).unwrap();
        let g = d.backward(&weights, 2, go).unwrap();
        // dL/drho = I x (the unit plane's L); dL/dI = rho x it.
        let (want_rho, se_rho) = (i * expect, i * var.sqrt());
        assert!(
            (g[0] - want_rho).abs() < 4.0 * se_rho + 1e-4 * want_rho,
            "rho {rho}: dL/drho {} vs {want_rho} (se {se_rho})",
            g[0]
        );
        let (want_i, se_i) = (rho * expect, rho * var.sqrt());
        assert!(
            (g[1] - want_i).abs() <= 4.0 * se_i + 1e-4 * want_i,
            "rho {rho}: dL/dI {} vs {want_i} (se {se_i})",
            g[1]
        );
    }
}

/// Weights that pick bins (the first half of the window) weigh only those bins'
/// contributions: on the plane, `dL/drho = L(first half) / rho`, with `L` summed from the
/// reference cube (its bins integrated exactly).
#[test]
fn lit_plane_gradient_follows_the_time_bins() {
    let (h_m, rho, i, fov) = (2.0, 0.5, 3.0, 40.0);
    let (w, hp) = (8, 6);
    let t_direct = 2.0 * h_m / C;
    let axis = TimeAxis::new(0.95 * t_direct, 0.004 * t_direct, 60).unwrap();
    let spp = 64u64;
    let plane = Plane::colocated(h_m, rho, i, 50.0, fov);
    let reference = tprf_core::reference::Analytic::Plane(plane).cube(w, hp, &axis);
    let split = 20;
    let mut weights = vec![0f32; w * hp * axis.bins];
    let mut expect = 0.0;
    for (k, (wt, v)) in weights.iter_mut().zip(&reference.values).enumerate() {
        if k % axis.bins < split {
            *wt = 1.0;
            expect += v / rho;
        }
    }
    assert!(expect > 0.0, "the first bins hold light");
    let mut d = Differentiable::with_scene(
        &request(w, hp, axis, spp),
        Arc::new(plane.scene()),
        &names(&["material:plane.albedo"]),
    )
    .unwrap();
    d.forward(&[], 1, &mut Silent).unwrap();
    let seeds: Vec<f64> = (10..16)
        .map(|s| d.backward(&weights, s, go).unwrap()[0])
        .collect();
    let (g, se) = mean_se(&seeds);
    assert!(
        (g - expect).abs() < 4.0 * se + 2e-3 * expect,
        "dL/drho over the first {split} bins: {g} (se {se}) vs {expect}"
    );
    // And not the whole window's: the later bins hold light too.
    let all: f64 = reference.values.iter().sum::<f64>() / rho;
    assert!(all > 1.2 * expect, "{all} vs {expect}");
}

/// Per pixel estimates of the furnace's `sum_b w_b d TPRF_b / d theta` (every pixel of
/// the furnace sees the same TPRF): their mean and standard error.
fn furnace_grads(
    f: &Furnace,
    wrt: &[Wrt],
    w_bin: &[f32],
    axis: TimeAxis,
    spp: u32,
) -> Vec<(f64, f64)> {
    let scene = Arc::new(f.scene());
    let settings = RenderSettings {
        first_bounce_splits: 1,
        light_vertex: Some(false),
        ..RenderSettings::default()
    };
    let renderer = Renderer::new(scene, settings);
    let (w, h) = (6, 6);
    let mut per_pixel = vec![Vec::new(); wrt.len()];
    for px in 0..w * h {
        let mut weights = vec![0f32; w * h * axis.bins];
        weights[px * axis.bins..(px + 1) * axis.bins].copy_from_slice(w_bin);
        let target = VjpTarget {
            weights: &weights,
            width: w,
            height: h,
            axis,
            filter: Default::default(),
        };
        let g = renderer.vjp(wrt, &target, 5, 0, spp).unwrap();
        for (k, v) in g.into_iter().enumerate() {
            per_pixel[k].push(v / spp as f64);
        }
    }
    per_pixel.iter().map(|v| mean_se(v)).collect()
}

/// The point-lit furnace: `d/drho` of its exact TPRF (`w0 = rho I / (pi R^2)` times a
/// series in rho) by central differences of the reference (smooth in rho: its grid does
/// not depend on rho), and `d/dI = TPRF / I`. Weights: all bins (the energy, whose
/// derivative is `I / (pi R^2) / (1 - rho)^2`) and a ramp in time.
#[test]
fn furnace_gradients_match_the_closed_form() {
    let (r, rho, i) = (1.0, 0.6, 2.0);
    let f = Furnace::point(r, rho, i);
    let axis = f.default_axis(48).unwrap();
    let ramp: Vec<f32> = (0..axis.bins)
        .map(|b| b as f32 / axis.bins as f32)
        .collect();
    let ones = vec![1f32; axis.bins];
    let h = 1e-4;
    let ref_grad = |wb: &[f32]| {
        let l = |rho| -> f64 {
            let t = Furnace::point(r, rho, i).tprf(&axis);
            t.iter().zip(wb).map(|(v, &w)| v * w as f64).sum()
        };
        ((l(rho + h) - l(rho - h)) / (2.0 * h), l(rho) / i)
    };
    let wrt = [
        Wrt::Albedo { material: 0 },
        Wrt::Intensity {
            light: 0,
            value: i as f32,
        },
    ];
    for (label, wb) in [("all bins", &ones), ("ramp", &ramp)] {
        let (want_rho, want_i) = ref_grad(wb);
        let g = furnace_grads(&f, &wrt, wb, axis, 64);
        let ((g_rho, se_rho), (g_i, se_i)) = (g[0], g[1]);
        assert!(
            (g_rho - want_rho).abs() < 4.0 * se_rho + 2e-3 * want_rho,
            "{label}: dL/drho {g_rho} (se {se_rho}) vs {want_rho}"
        );
        assert!(
            (g_i - want_i).abs() < 4.0 * se_i + 2e-3 * want_i,
            "{label}: dL/dI {g_i} (se {se_i}) vs {want_i}"
        );
    }
    // The whole window's energy derivative against its closed form, as a check of the
    // reference's differences (most of the energy is inside the window).
    let (want, _) = ref_grad(&ones);
    let closed = i / (std::f64::consts::PI * r * r) / (1.0 - rho).powi(2);
    assert!(
        want > 0.9 * closed && want < closed * 1.001,
        "{want} vs {closed}"
    );
}

/// The emitting furnace (MIS between emitter sampling and emission found by BSDF
/// sampling): `d/dLe = TPRF / Le`, `d/drho` by differences of the reference; and at
/// zero albedo, only the first bounce has a derivative.
#[test]
fn emitting_furnace_gradients_match_the_closed_form() {
    let (r, le) = (1.0, 1.5);
    for rho in [0.5, 0.0] {
        let f = Furnace::emitting(r, rho, le);
        // 37 bins: the first arrival (R / c) falls inside a bin, not on an edge that the
        // icosphere's facets (inside the sphere) would put it before.
        let axis = f.default_axis(37).unwrap();
        let ramp: Vec<f32> = (0..axis.bins).map(|b| 1.0 + b as f32 / 10.0).collect();
        let l = |rho: f64| -> f64 {
            let t = Furnace::emitting(r, rho, le).tprf(&axis);
            t.iter().zip(&ramp).map(|(v, &w)| v * w as f64).sum()
        };
        let h = 1e-4;
        let want_rho = if rho > 0.0 {
            (l(rho + h) - l(rho - h)) / (2.0 * h)
        } else {
            (l(h) - l(0.0)) / h
        };
        let want_le = l(rho) / le;
        let wrt = [
            Wrt::Albedo { material: 0 },
            Wrt::Emission {
                material: 0,
                value: le as f32,
            },
        ];
        let g = furnace_grads(&f, &wrt, &ramp, axis, 64);
        let ((g_rho, se_rho), (g_le, se_le)) = (g[0], g[1]);
        assert!(
            (g_rho - want_rho).abs() < 4.0 * se_rho + 3e-3 * want_rho.abs(),
            "rho {rho}: dL/drho {g_rho} (se {se_rho}) vs {want_rho}"
        );
        assert!(
            (g_le - want_le).abs() < 4.0 * se_le + 2e-3 * want_le,
            "rho {rho}: dL/dLe {g_le} (se {se_le}) vs {want_le}"
        );
    }
}

/// The Cornell box with a glossy metallic-roughness white (specular, a little metal:
/// `F0` depends on the base colour) and a red wall under a checker texture.
fn glossy_textured_cornell() -> Scene {
    let mut s = scene::load("builtin:cornell").unwrap();
    let white = &mut s.materials[0];
    white.specular_factor = 1.0;
    white.metallic = 0.3;
    white.roughness = 0.5;
    let checker: Vec<[u8; 4]> = (0..64)
        .map(|k| {
            let v = if (k % 8 + k / 8) % 2 == 0 { 255 } else { 90 };
            [v, v, v, 255]
        })
        .collect();
    s.textures.push(Texture {
        width: 8,
        height: 8,
        rgba8: checker,
    });
    let tex = (s.textures.len() - 1) as u32;
    s.materials[1].base_color_texture = Some(TextureRef { texture: tex });
    for (t, a) in s.triangles.iter().zip(s.attrs.iter_mut()) {
        if a.material == 1 {
            for (uv, p) in a.uv.iter_mut().zip(t.p) {
                *uv = glam::Vec2::new(p.z * 3.0, p.y * 3.0);
            }
        }
    }
    s
}

/// Central differences of forward renders with common random numbers (the same seed at
/// `theta +- h`) against backward renders of other seeds, on the glossy, textured box:
/// the albedos of the white and the red walls and the light's intensity. Both are
/// measured over 4 seeds; they agree within 4 standard errors of their difference.
#[test]
fn cornell_gradients_match_finite_differences_of_forward_renders() {
    let s = glossy_textured_cornell();
    let (w, h, bins) = (12, 12, 24);
    let wrt = names(&[
        "material:white.albedo",
        "material:red.albedo",
        "light:ceiling point light.intensity",
    ]);
    let lights: Vec<&str> = s.lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(lights, ["ceiling point light"]);
    let mut req = request(w, h, TimeAxis::new(0.0, 1.0, bins).unwrap(), 32);
    req.t0_s = None;
    req.dt_s = None;
    let mut d = Differentiable::with_scene(&req, Arc::new(s), &wrt).unwrap();
    let axis = d.axis();
    let weights: Vec<f32> = (0..w * h * axis.bins)
        .map(|k| {
            let (px, b) = (k / axis.bins, k % axis.bins);
            (1 + (px * 7 + b * 3) % 5) as f32
        })
        .collect();
    let loss = |film: &tprf_core::film::TprfFilm| -> f64 {
        let mut l = 0.0;
        for y in 0..h {
            for x in 0..w {
                let t = film.pixel_tprf(x, y);
                let px = y * w + x;
                for (b, v) in t.iter().enumerate() {
                    l += v * weights[px * axis.bins + b] as f64;
                }
            }
        }
        l
    };
    let at = [0.6, 0.5, 0.5];
    let step = [0.05, 0.05, 0.05];
    let mut fd = vec![Vec::new(); 3];
    let mut bw = vec![Vec::new(); 3];
    for seed in 1..=4u64 {
        for k in 0..3 {
            let mut value = |v: f64| {
                let mut vals: Vec<(String, f64)> =
                    wrt.iter().cloned().zip(at.iter().copied()).collect();
                vals[k].1 = v;
                loss(&d.forward(&vals, seed, &mut Silent).unwrap().film)
            };
            let (lp, lm) = (value(at[k] + step[k]), value(at[k] - step[k]));
            fd[k].push((lp - lm) / (2.0 * step[k]));
        }
        let vals: Vec<(String, f64)> = wrt.iter().cloned().zip(at.iter().copied()).collect();
        d.forward(&vals, seed, &mut Silent).unwrap();
        let g = d.backward(&weights, 100 + seed, go).unwrap();
        for k in 0..3 {
            bw[k].push(g[k]);
        }
    }
    for k in 0..3 {
        let ((f, sf), (b, sb)) = (mean_se(&fd[k]), mean_se(&bw[k]));
        let se = (sf * sf + sb * sb).sqrt();
        assert!(
            (f - b).abs() < 4.0 * se + 0.01 * f.abs(),
            "{}: finite differences {f} (se {sf}) vs backward {b} (se {sb})",
            wrt[k]
        );
        assert!(b > 0.0, "{}: more light, more L", wrt[k]);
    }
}

/// Unknown names are refused listing the known ones; geometry and the camera by name with
/// the reason; values out of range, names not differentiated, and a backward before any
/// forward, each with its own message.
#[test]
fn bad_parameters_are_refused_by_name() {
    let plane = Plane::colocated(2.0, 0.5, 3.0, 50.0, 40.0);
    let axis = TimeAxis::new(1e-8, 1e-10, 20).unwrap();
    let req = request(4, 4, axis, 4);
    let make = |wrt: &[&str]| {
        Differentiable::with_scene(&req, Arc::new(plane.scene()), &names(wrt)).map(|_| ())
    };
    let text = |r: Result<(), DifferentiableError>| r.unwrap_err().to_string();
    let e = text(make(&["material:wall.albedo"]));
    assert!(
        e.contains("no material named \"wall\"")
            && e.contains("material:plane.albedo")
            && e.contains("light:point.intensity"),
        "{e}"
    );
    for geometry in [
        "camera.position",
        "node:plane.translation",
        "object:plane.scale",
    ] {
        let e = text(make(&[geometry]));
        assert!(
            e.contains("not differentiable") && e.contains("edge sampling"),
            "{geometry}: {e}"
        );
    }
    let e = text(make(&["material:plane.roughness"]));
    assert!(
        e.contains("not differentiable") && e.contains("albedo"),
        "{e}"
    );
    let e = text(make(&["light:point.wattage"]));
    assert!(e.contains("no field \"wattage\""), "{e}");
    let mut d = Differentiable::with_scene(
        &req,
        Arc::new(plane.scene()),
        &names(&["material:plane.albedo"]),
    )
    .unwrap();
    let e = d
        .backward(&vec![1.0; 4 * 4 * 20], 1, go)
        .unwrap_err()
        .to_string();
    assert!(e.contains("forward"), "{e}");
    let e = d
        .forward(&[("material:plane.albedo".into(), 1.5)], 1, &mut Silent)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("[0, 1]"), "{e}");
    let e = d
        .forward(&[("light:point.intensity".into(), 1.0)], 1, &mut Silent)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("not among"), "{e}");
    d.forward(&[], 1, &mut Silent).unwrap();
    let e = d.backward(&[1.0; 7], 1, go).unwrap_err().to_string();
    assert!(e.contains("7 values") && e.contains("4 x 4 x 20"), "{e}");
    // A luminescent scene is refused up front: the derivative walk has no re-emission.
    let mut s = plane.scene();
    s.materials[0].luminescence = Some(tprf_core::scene::Luminescence::single(0.3, 4e-9));
    let e = text(
        Differentiable::with_scene(&req, Arc::new(s), &names(&["material:plane.albedo"]))
            .map(|_| ()),
    );
    assert!(e.contains("luminescent") && e.contains("plane"), "{e}");
    // Names may hold dots: the field is after the last one.
    let mut s = plane.scene();
    s.materials[0].name = "lambert_0.5".into();
    let d = Differentiable::with_scene(&req, Arc::new(s), &names(&["material:lambert_0.5.albedo"]));
    assert!(d.is_ok(), "{:?}", d.err().map(|e| e.to_string()));
}

/// `L = sum(cube)` of `d` rendered at albedo `a` with `seed`.
fn total_at(d: &mut Differentiable, name: &str, a: f64, seed: u64) -> f64 {
    let f = d
        .forward(&[(name.to_string(), a)], seed, &mut Silent)
        .unwrap();
    let (w, h) = (d.request().width, d.request().height);
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| f.film.pixel_tprf(x, y).iter().sum::<f64>())
        .sum()
}

/// Mitsuba's smooth plastic, linear and `nonlinear` (whose diffuse albedo `rho / (1 - rho
/// F_dr)` is not linear in rho), on the lit plane: one bounce, lit through the diffuse
/// lobe alone (the coat's mirror cannot reach a point light), so forward renders with one
/// seed differ only by `g(rho)` and their central difference is the derivative up to
/// `O(h^2)`; the backward render (another seed) agrees within its jitter noise (the
/// plane's is 4e-4 of L at this size). At rho = 0 (the one-sided difference `L(h) / h`),
/// the directions come from the plastic rebuilt at albedo 1.
#[test]
fn plastic_albedo_gradients_match_differences_of_forward_renders() {
    let name = "material:plane.albedo";
    let (w, hp) = (12, 9);
    let t_direct = 4.0 / C;
    let axis = TimeAxis::new(0.95 * t_direct, 0.004 * t_direct, 100).unwrap();
    for nonlinear in [false, true] {
        let mut s = Plane::colocated(2.0, 0.5, 3.0, 50.0, 40.0).scene();
        s.materials[0].model = scene::SurfaceModel::Plastic {
            eta: 1.5,
            microfacet: None,
            nonlinear,
        };
        let mut d =
            Differentiable::with_scene(&request(w, hp, axis, 64), Arc::new(s), &names(&[name]))
                .unwrap();
        let ones = vec![1f32; w * hp * axis.bins];
        for rho in [0.6, 0.0] {
            let h = 1e-3;
            let fd = if rho > 0.0 {
                (total_at(&mut d, name, rho + h, 1) - total_at(&mut d, name, rho - h, 1))
                    / (2.0 * h)
            } else {
                total_at(&mut d, name, h, 1) / h
            };
            d.forward(&[(name.to_string(), rho)], 1, &mut Silent)
                .unwrap();
            let g = d.backward(&ones, 7, go).unwrap()[0];
            assert!(
                fd > 0.0 && (g - fd).abs() < 5e-3 * fd,
                "nonlinear {nonlinear}, rho {rho}: backward {g} vs differences {fd}"
            );
        }
    }
}

//! mitransient's conventions and emitters against answers worked out here: the time
//! origins (near plane, first hit) and the pulse origin, an angular area light over a
//! plane and a projector's spot, each pixel's expected value integrated over its
//! footprint by the test itself.

mod common;

use common::{C, empty_scene, lit_plane, mean_arrival_s, push_tri, render_with};
use glam::Vec3;
use tprf_core::film::TimeAxis;
use tprf_core::scene::{
    AngularFalloff, Camera, ImageWrap, IrradianceImage, Material, Projector, PulseOrigin,
    PunctualLight, Scene, TimeOrigin,
};
use tprf_core::transport::RenderSettings;

const W: usize = 8;
const H: usize = 8;

fn settings(time_origin: TimeOrigin, pulse_origin: PulseOrigin) -> RenderSettings {
    RenderSettings {
        seed: 3,
        adaptive: false,
        time_origin,
        pulse_origin,
        ..RenderSettings::default()
    }
}

/// Unit direction through image point `(px, py)` of a camera at `eye` looking down -Z
/// (+X right, +Y up on the image) with vertical field of view `fov_deg`, square image.
fn down_ray(px: f64, py: f64, w: usize, h: usize, fov_deg: f64) -> glam::DVec3 {
    let t = (0.5 * fov_deg).to_radians().tan();
    let sx = (2.0 * px / w as f64 - 1.0) * t * (w as f64 / h as f64);
    let sy = (1.0 - 2.0 * py / h as f64) * t;
    glam::DVec3::new(sx, sy, -1.0).normalize()
}

/// The lit plane (camera and point light together at height 2 m above a Lambertian
/// plane) with the camera's near plane `near_m` in front of it: every arrival is the
/// single bounce `2 h / cos a` (a the ray's angle to the axis).
fn plane_scene(near_m: f32) -> Scene {
    let mut s = lit_plane(2.0, 0.5, 1.0, 20.0, 60.0);
    s.camera.near_m = near_m;
    s
}

fn mean_arrivals(scene: Scene, settings: RenderSettings, axis: TimeAxis) -> Vec<f64> {
    let r = render_with(scene, W, H, axis, 16, settings, 0);
    (0..W * H)
        .map(|p| mean_arrival_s(&r.film.pixel_tprf(p % W, p / W), &axis))
        .collect()
}

#[test]
fn the_near_plane_origin_starts_each_ray_near_over_cos_a_sooner() {
    let near = 0.5;
    // Bins of 1 mm of optical path from -1 m: every arrival inside.
    let axis = TimeAxis::new(-1.0 / C, 0.001 / C, 7000).unwrap();
    let pin = mean_arrivals(
        plane_scene(near),
        settings(TimeOrigin::Pinhole, PulseOrigin::Light),
        axis,
    );
    let np = mean_arrivals(
        plane_scene(near),
        settings(TimeOrigin::NearPlane, PulseOrigin::Light),
        axis,
    );
    for p in 0..W * H {
        let (x, y) = ((p % W) as f64, (p / W) as f64);
        // The same samples in both renders: each arrives near / cos a sooner, a over the
        // pixel's footprint, so the shift lies between its least and largest value.
        let cos = |px, py| down_ray(px, py, W, H, 60.0).z.abs();
        let corners = [(x, y), (x + 1.0, y), (x, y + 1.0), (x + 1.0, y + 1.0)];
        let shifts: Vec<f64> = corners
            .iter()
            .map(|&(a, b)| near as f64 / cos(a, b))
            .collect();
        let (lo, hi) = shifts
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), s| (l.min(*s), h.max(*s)));
        // Within a bin of the footprint's range (the binned mean moves by under one).
        let shift_m = (pin[p] - np[p]) * C;
        assert!(
            shift_m > lo - 0.001 && shift_m < hi + 0.001,
            "pixel {p}: shifted {shift_m} m, the footprint's near / cos a is {lo}..{hi} m"
        );
    }
    // Off the axis the shift exceeds near: the corner pixel's least is 0.5 / cos 36 deg.
    assert!((pin[0] - np[0]) * C > 0.55);
}

#[test]
fn the_first_hit_origin_leaves_the_camera_leg_out_and_the_pulse_origin_the_lights() {
    let axis = TimeAxis::new(-0.5 / C, 0.001 / C, 6000).unwrap();
    let run = |t, p| mean_arrivals(plane_scene(0.01), settings(t, p), axis);
    let pin = run(TimeOrigin::Pinhole, PulseOrigin::Light);
    let first = run(TimeOrigin::FirstHit, PulseOrigin::Light);
    let pulse = run(TimeOrigin::Pinhole, PulseOrigin::FirstHit);
    let both = run(TimeOrigin::FirstHit, PulseOrigin::FirstHit);
    let dt_s = axis.dt_s;
    for p in 0..W * H {
        // Camera and light at the same point: each leg is half the path, h / cos a.
        assert!(
            (first[p] - 0.5 * pin[p]).abs() < dt_s,
            "pixel {p}: first-hit {} vs half of {}",
            first[p],
            pin[p]
        );
        assert!(
            (pulse[p] - first[p]).abs() < dt_s,
            "pixel {p}: pulse {}",
            pulse[p]
        );
        // Both legs out: a single bounce arrives at 0.
        assert!(both[p].abs() < dt_s, "pixel {p}: both {}", both[p]);
    }
}

/// A ground plane z = 0 of albedo `rho` (half-size 50 m) seen from `eye` looking down.
fn ground(eye: Vec3, fov_deg: f32, rho: f32) -> Scene {
    let mut s = empty_scene(Camera::look_at(eye, eye - Vec3::Z, fov_deg.to_radians()));
    s.materials.push(Material::lambertian("ground", [rho; 3]));
    let g = 50.0;
    let (a, b, c, d) = (
        Vec3::new(-g, -g, 0.0),
        Vec3::new(g, -g, 0.0),
        Vec3::new(g, g, 0.0),
        Vec3::new(-g, g, 0.0),
    );
    push_tri(&mut s, [a, b, c], 0);
    push_tri(&mut s, [a, c, d], 0);
    s
}

/// The mean over pixel `(x, y)`'s footprint on the ground of `value(ground point)`, by
/// an n x n grid of the pixel (the camera at `eye`, looking down).
fn footprint_mean(
    x: usize,
    y: usize,
    eye: glam::DVec3,
    fov_deg: f64,
    value: impl Fn(glam::DVec3) -> f64,
) -> f64 {
    let n = 24;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let px = x as f64 + (i as f64 + 0.5) / n as f64;
            let py = y as f64 + (j as f64 + 0.5) / n as f64;
            let d = down_ray(px, py, W, H, fov_deg);
            let p = eye + d * (eye.z / -d.z);
            sum += value(p);
        }
    }
    sum / (n * n) as f64
}

#[test]
fn an_angular_area_light_falls_linearly_in_angle_between_beam_and_cutoff() {
    // A 2 cm square emitter 1 m above the plane, facing down: radiance 1000, full to 20
    // degrees, none past 35. The plane's radiance at angle theta from below it is
    // rho / pi * Le f(theta) A cos^4(theta) / h^2 (the emitter small against h).
    let (h, side, le, rho) = (1.0f32, 0.02f32, 1000.0f32, 0.5f32);
    let eye = Vec3::new(0.0, 0.0, 0.999);
    let mut s = ground(eye, 90.0, rho);
    let mut m = Material::lambertian("lamp", [0.0; 3]);
    m.emissive = [le; 3];
    m.double_sided = false;
    let falloff = AngularFalloff {
        beam_width_rad: 20f32.to_radians(),
        cutoff_rad: 35f32.to_radians(),
    };
    m.emission_falloff = Some(falloff);
    s.materials.push(m);
    let e = 0.5 * side;
    // Counter-clockwise seen from below: the front face looks down (-Z).
    let (a, b, c, d) = (
        Vec3::new(-e, -e, h),
        Vec3::new(-e, e, h),
        Vec3::new(e, e, h),
        Vec3::new(e, -e, h),
    );
    push_tri(&mut s, [a, b, c], 1);
    push_tri(&mut s, [a, c, d], 1);
    let axis = TimeAxis::new(0.0, 0.05 / C, 100).unwrap();
    let r = render_with(
        s,
        W,
        H,
        axis,
        64,
        settings(TimeOrigin::Pinhole, PulseOrigin::Light),
        0,
    );
    // The profile written out: 1 to 20 degrees, linear in the angle to 0 at 35.
    let profile = |theta: f64| {
        let (b, c) = (20f64.to_radians(), 35f64.to_radians());
        if theta <= b {
            1.0
        } else if theta < c {
            (c - theta) / (c - b)
        } else {
            0.0
        }
    };
    let area = (side * side) as f64;
    let (h, le, rho) = (h as f64, le as f64, rho as f64);
    let mut lit_some = 0;
    let mut dark_some = 0;
    for y in 0..H {
        for x in 0..W {
            let want = footprint_mean(x, y, eye.as_dvec3(), 90.0, |p| {
                let r = p.truncate().length();
                let cos = h / (h * h + r * r).sqrt();
                rho / std::f64::consts::PI * le * profile(cos.acos()) * area * cos.powi(4) / (h * h)
            });
            let got: f64 = r.film.pixel_tprf(x, y).iter().sum();
            if want > 0.0 {
                lit_some += 1;
            } else {
                dark_some += 1;
            }
            assert!(
                (got - want).abs() <= 0.03 * want + 1e-4,
                "pixel ({x}, {y}): {got} vs {want}"
            );
        }
    }
    // The image holds the beam, the fall and the dark beyond the cutoff.
    assert!(
        lit_some > 10 && dark_some > 10,
        "{lit_some} lit, {dark_some} dark"
    );
}

#[test]
fn a_projector_lights_its_frustum_with_mitsubas_uniform_irradiance() {
    // Mitsuba's projector of irradiance E lights a plane across its axis at distance h
    // with pi E / h^2 everywhere in its frustum: intensity pi E / cos^3 theta. Seen on a
    // Lambertian plane: radiance rho E / h^2 inside, 0 outside.
    let (h, e, rho) = (2.0f32, 3.0f32, 0.5f32);
    let eye = Vec3::new(0.0, 0.0, 1.999);
    let mut s = ground(eye, 60.0, rho);
    let (tx, ty) = (10f32.to_radians().tan(), 15f32.to_radians().tan());
    s.lights.push(PunctualLight {
        name: "projector".into(),
        position: Vec3::new(0.0, 0.0, h),
        intensity_w_per_sr: [std::f32::consts::PI * e; 3],
        spot: None,
        projector: Some(Projector {
            direction: -Vec3::Z,
            up: Vec3::Y,
            tan_half_x: tx,
            tan_half_y: ty,
            image: None,
        }),
    });
    let axis = TimeAxis::new(0.0, 0.05 / C, 200).unwrap();
    let r = render_with(
        s,
        W,
        H,
        axis,
        256,
        settings(TimeOrigin::Pinhole, PulseOrigin::Light),
        0,
    );
    let (h, e, rho) = (h as f64, e as f64, rho as f64);
    // The projector's image +X is the world's -X (up +Y, axis -Z): the frustum is
    // symmetric, so |x| and |y| are what count.
    let inside =
        |p: glam::DVec3| (p.x.abs() <= h * tx as f64 && p.y.abs() <= h * ty as f64) as u8 as f64;
    let mut full = 0;
    for y in 0..H {
        for x in 0..W {
            let want = rho * e / (h * h) * footprint_mean(x, y, eye.as_dvec3(), 60.0, inside);
            let got: f64 = r.film.pixel_tprf(x, y).iter().sum();
            if want > 0.99 * rho * e / (h * h) {
                full += 1;
            }
            // Inside: the uniform irradiance to 1 %; outside: nothing at all; across
            // the frustum's edge, the share of the pixel's samples inside it (a
            // stratified estimate of its covered fraction).
            let full_l = rho * e / (h * h);
            let tolerance = if want == 0.0 {
                0.0
            } else if want > 0.999 * full_l {
                0.01 * full_l
            } else {
                0.06 * full_l
            };
            assert!(
                (got - want).abs() <= tolerance,
                "pixel ({x}, {y}): {got} vs {want}"
            );
        }
    }
    assert!(full >= 4, "{full} pixels wholly inside the frustum");
}

#[test]
fn a_projectors_image_lands_upright_with_its_bilinear_irradiance() {
    // A 6 x 3 image, dark but for its top-left texel (1) and its bottom-right one (0.5),
    // clamped at its edges, projected straight down from height h (up +Y): seen from
    // behind the projector the image's left is the world's -X, its top +Y. A ground point
    // p lies at image point u = 1/2 + p.x / (2 h tan_x), v = 1/2 - p.y / (2 h tan_y), and
    // shows radiance rho e E(u, v) / h^2, E the image's bilinear value there (texel
    // centres at (i + 1/2) / width), worked out here.
    let (h, e, rho) = (2.0f32, 3.0f32, 0.5f32);
    let eye = Vec3::new(0.0, 0.0, 1.999);
    let mut s = ground(eye, 60.0, rho);
    let (tx, ty) = (18f32.to_radians().tan(), 9f32.to_radians().tan());
    let (iw, ih) = (6usize, 3usize);
    let mut texels = vec![0.0f32; iw * ih];
    texels[0] = 1.0;
    texels[iw * ih - 1] = 0.5;
    s.lights.push(PunctualLight {
        name: "projector".into(),
        position: Vec3::new(0.0, 0.0, h),
        intensity_w_per_sr: [std::f32::consts::PI * e; 3],
        spot: None,
        projector: Some(Projector {
            direction: -Vec3::Z,
            up: Vec3::Y,
            tan_half_x: tx,
            tan_half_y: ty,
            image: Some(std::sync::Arc::new(IrradianceImage {
                width: iw as u32,
                height: ih as u32,
                rgb: texels.iter().map(|&v| [v; 3]).collect(),
                wrap: ImageWrap::Clamp,
            })),
        }),
    });
    let axis = TimeAxis::new(0.0, 0.05 / C, 200).unwrap();
    let r = render_with(
        s,
        W,
        H,
        axis,
        512,
        settings(TimeOrigin::Pinhole, PulseOrigin::Light),
        0,
    );
    let (h, e, rho) = (h as f64, e as f64, rho as f64);
    let texel = |i: i64, j: i64| {
        let (i, j) = (i.clamp(0, iw as i64 - 1), j.clamp(0, ih as i64 - 1));
        texels[j as usize * iw + i as usize] as f64
    };
    let image = |p: glam::DVec3| {
        let u = 0.5 + p.x / (2.0 * h * tx as f64);
        let v = 0.5 - p.y / (2.0 * h * ty as f64);
        if !(0.0..=1.0).contains(&u) || !(0.0..=1.0).contains(&v) {
            return 0.0;
        }
        let (x, y) = (u * iw as f64 - 0.5, v * ih as f64 - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i, j) = (x0 as i64, y0 as i64);
        let top = texel(i, j) * (1.0 - fx) + texel(i + 1, j) * fx;
        let bottom = texel(i, j + 1) * (1.0 - fx) + texel(i + 1, j + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    };
    let full_l = rho * e / (h * h);
    let (mut lit_left_top, mut lit_right_bottom) = (0.0, 0.0);
    for y in 0..H {
        for x in 0..W {
            let want = full_l * footprint_mean(x, y, eye.as_dvec3(), 60.0, image);
            let got: f64 = r.film.pixel_tprf(x, y).iter().sum();
            assert!(
                (got - want).abs() <= 0.03 * full_l,
                "pixel ({x}, {y}): {got} vs {want} (full {full_l})"
            );
            // The camera's image: x right is world +X, y down is world -Y.
            if x < W / 2 && y < H / 2 {
                lit_left_top += got;
            } else if x >= W / 2 && y >= H / 2 {
                lit_right_bottom += got;
            }
        }
    }
    assert!(
        lit_left_top > 1.2 * lit_right_bottom && lit_right_bottom > 0.0,
        "the image's brighter corner is its top left: {lit_left_top} vs {lit_right_bottom}"
    );
}

/// Bad origins are refused naming the option: an unknown name, and the pulse's first hit
/// in a scene with participating media (its light's leg is not separated there).
#[test]
fn bad_origins_are_refused_naming_the_option() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("conventions-bad");
    let _ = std::fs::remove_dir_all(&dir);
    let run = |args: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_tprf"))
            .args(["render", "--out", dir.to_str().unwrap(), "--spp", "1"])
            .args(["--width", "8", "--height", "8"])
            .args(args)
            .output()
            .unwrap();
        assert!(!o.status.success());
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let e = run(&["builtin:cornell", "--time-origin", "sideways"]);
    assert!(
        e.contains("--time-origin") && e.contains("pinhole, near-plane or first-hit"),
        "{e}"
    );
    let e = run(&["builtin:fog", "--pulse-origin", "first-hit"]);
    assert!(
        e.contains("--pulse-origin first-hit") && e.contains("participating media"),
        "{e}"
    );
    assert!(!dir.exists(), "nothing written");
}

/// `min_bounces` leaves out of the film exactly the light of fewer scattering events:
/// with the same samples (no adaptive plan, the strategy fixed), the Cornell box's cube
/// with `min_bounces` 2 is its full cube less the light seen directly and after one
/// bounce, the film's own bounce layers 0 and 1 (the layers partition every
/// contribution by its scattering count).
#[test]
fn min_bounces_leaves_out_the_bounce_layers_below_it() {
    let axis = TimeAxis::new(0.0, 0.05 / C, 120).unwrap();
    let run = |min_bounces| {
        let settings = RenderSettings {
            seed: 5,
            adaptive: false,
            first_bounce_splits: 2,
            light_vertex: Some(true),
            min_bounces,
            ..RenderSettings::default()
        };
        let scene = tprf_core::scene::builtin::load("cornell").unwrap();
        render_with(scene, W, H, axis, 16, settings, 2).film
    };
    let all = run(0);
    let from2 = run(2);
    let (mut total, mut low, mut worst) = (0.0, 0.0, 0.0f64);
    for p in 0..W * H {
        let (x, y) = (p % W, p / W);
        let full = all.pixel_tprf(x, y);
        let layers = all.pixel_bounces(x, y);
        let got = from2.pixel_tprf(x, y);
        for b in 0..axis.bins {
            let want = full[b] - layers[0][b] - layers[1][b];
            worst = worst.max((got[b] - want).abs());
            total += full[b];
            low += layers[0][b] + layers[1][b];
        }
    }
    assert!(
        low > 0.1 * total,
        "direct light is a good share: {low} of {total}"
    );
    assert!(
        worst <= 1e-5 * total / (W * H) as f64,
        "min_bounces 2 = all - layers 0, 1: worst bin off by {worst} (total {total})"
    );
    // Nothing of fewer bounces reached the second film's own layers either.
    for p in 0..W * H {
        let layers = from2.pixel_bounces(p % W, p / W);
        assert!(layers[..2].iter().flatten().all(|&v| v == 0.0));
    }
}

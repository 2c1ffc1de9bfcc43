//! Wavelengths and dispersion (issue 47, part 2): a pulse through a slab of BK7, and
//! through a scene filled with BK7, arrives at the group delay `L n_g(lambda) / c` per
//! band, and the spread of a 400-700 nm pulse is the group-delay difference; a prism
//! deviates each wavelength by Snell's law at its phase index; a white furnace is the
//! same in every band. The indices are computed here from N-BK7's Sellmeier
//! coefficients, and the group index by a difference quotient, apart from the
//! renderer's closed forms.

use crate::common::*;
use glam::{Affine3A, Vec2, Vec3};
use std::sync::Arc;
use tprf_core::accel::Hit;
use tprf_core::film::TimeAxis;
use tprf_core::scene::dispersion::Dispersion;
use tprf_core::scene::spectrum::Wavelength;
use tprf_core::scene::{Camera, Channel, Material, Medium, Scene, Triangle, TriangleAttrs};
use tprf_core::transport::RenderSettings;
use tprf_core::transport::bsdf::Frame;
use tprf_core::transport::surface::Surfaces;

/// N-BK7's phase index at `l_um` micrometres: SCHOTT's Sellmeier formula, written out.
fn bk7_n(l_um: f64) -> f64 {
    let b = [1.039_612_12, 0.231_792_344, 1.010_469_45];
    let c = [0.006_000_698_67, 0.020_017_914_4, 103.560_653];
    let l2 = l_um * l_um;
    (1.0 + (0..3).map(|i| b[i] * l2 / (l2 - c[i])).sum::<f64>()).sqrt()
}

/// Its group index `n - lambda dn/dlambda`, `dn/dlambda` by a central difference.
pub(super) fn bk7_ng(l_um: f64) -> f64 {
    let h = 1e-5;
    bk7_n(l_um) - l_um * (bk7_n(l_um + h) - bk7_n(l_um - h)) / (2.0 * h)
}

fn band(nm: f64) -> Channel {
    Channel::Wavelength(Wavelength::from_nm(nm).unwrap())
}

/// An axis-aligned square at height `z`, half-size `half`, its front face looking up
/// (`up`) or down.
pub(super) fn quad(scene: &mut Scene, z: f32, half: f32, up: bool, material: u32) {
    let (a, b, c, d) = (
        Vec3::new(-half, -half, z),
        Vec3::new(half, -half, z),
        Vec3::new(half, half, z),
        Vec3::new(-half, half, z),
    );
    if up {
        push_tri(scene, [a, b, c], material);
        push_tri(scene, [a, c, d], material);
    } else {
        push_tri(scene, [a, c, b], material);
        push_tri(scene, [a, d, c], material);
    }
}

/// A camera at `(0, 0, h)` looking down -Z with a 0.2 degree field of view.
fn camera_above(h: f32) -> Camera {
    Camera {
        world_from_camera: Affine3A::from_translation(Vec3::new(0.0, 0.0, h)),
        fov_rad: 0.2f32.to_radians(),
        fov_axis: tprf_core::scene::FovAxis::Y,
        near_m: tprf_core::scene::camera::DEFAULT_NEAR_M,
    }
}

/// A camera at `(0, 0, h)` looking down with a 0.2 degree field of view (its rays within
/// 0.1 degree of the vertical: their paths longer by a relative 2e-6, 0.02 ps here), over
/// an emitting plane z = 0 (black, radiance 1, pulsed at t = 0).
pub(super) fn emitter_below(h: f32) -> Scene {
    let mut s = empty_scene(camera_above(h));
    s.materials.push(Material {
        emissive: [1.0; 3],
        ..Material::lambertian("emitter", [0.0; 3])
    });
    quad(&mut s, 0.0, 2.0, true, 0);
    s
}

/// The smooth N-BK7 dielectric (glTF transmission 1, roughness 0, its index the
/// Sellmeier dispersion).
pub(super) fn bk7_glass() -> Material {
    let d = Dispersion::named("bk7").unwrap();
    Material {
        transmission: 1.0,
        roughness: 0.0,
        specular_factor: 1.0,
        ior: d.n(0.58756) as f32,
        dispersion: Some(d),
        ..Material::lambertian("bk7", [1.0; 3])
    }
}

/// The energy-weighted mean bin centre of a one-pixel render of `scene` in band
/// `channel`, over the 5 bins round its peak (the direct arrival; the slab's internal
/// echoes come nanoseconds later), with 1 ps bins from `t0_s`.
fn arrival_s(scene: Scene, channel: Channel, t0_s: f64, bins: usize) -> f64 {
    let axis = TimeAxis::new(t0_s, 1e-12, bins).unwrap();
    let settings = RenderSettings {
        channel,
        seed: 5,
        ..RenderSettings::default()
    };
    let r = render_with(scene, 1, 1, axis, 16, settings, 0);
    let tprf = r.film.pixel_tprf(0, 0);
    let peak = (0..bins)
        .max_by(|&a, &b| tprf[a].total_cmp(&tprf[b]))
        .unwrap();
    let (lo, hi) = (peak.saturating_sub(2), (peak + 3).min(bins));
    let (mut w, mut m) = (0.0, 0.0);
    for (b, v) in tprf.iter().enumerate().take(hi).skip(lo) {
        w += v;
        m += v * axis.bin_center_s(b);
    }
    assert!(w > 0.0, "no light in {channel}");
    m / w
}

/// A 1 m slab of N-BK7 (faces z = 1 and z = 2) between the camera at z = 3 and the
/// emitter: the light crosses 2 m of air and 1 m of glass, arriving at
/// `(2 + n_g(lambda)) / c`, to within the 1 ps bins; the 400-700 nm spread is
/// `(n_g(400) - n_g(700)) 1 m / c`, about 175 ps. (Timed by the phase index instead, each
/// would arrive 80-110 ps early.)
#[test]
fn pulse_through_a_bk7_slab_arrives_at_the_group_delay() {
    let scene = || {
        let mut s = emitter_below(3.0);
        s.materials.push(bk7_glass());
        quad(&mut s, 2.0, 2.0, true, 1); // entering face, outward normal up
        quad(&mut s, 1.0, 2.0, false, 1); // leaving face, outward normal down
        s
    };
    let t0_s = 3.5 / C;
    let mut got = Vec::new();
    for nm in [400.0, 450.0, 550.0, 650.0, 700.0] {
        let want = (2.0 + bk7_ng(nm * 1e-3)) / C;
        let t = arrival_s(scene(), band(nm), t0_s, 400);
        eprintln!(
            "{nm} nm: arrival {:.2} ps, group delay {:.2} ps (phase {:.2} ps)",
            t * 1e12,
            want * 1e12,
            (2.0 + bk7_n(nm * 1e-3)) / C * 1e12
        );
        assert!(
            (t - want).abs() < 0.6e-12,
            "{nm} nm: arrived at {t:e} s, the group delay is {want:e} s"
        );
        got.push(t);
    }
    let spread = got[0] - got[4];
    let want = (bk7_ng(0.4) - bk7_ng(0.7)) / C;
    assert!(
        (spread - want).abs() < 1.2e-12,
        "400-700 nm spread {spread:e} s, group-delay difference {want:e} s"
    );
}

/// The camera 1 m above the emitter in a scene filled with BK7 (`--medium n=bk7`): the
/// light arrives at `n_g(lambda) 1 m / c`.
#[test]
fn pulse_through_a_bk7_medium_arrives_at_the_group_delay() {
    let scene = || {
        let mut s = emitter_below(1.0);
        s.medium = Some(Medium::parse_spec("n=bk7").unwrap());
        s
    };
    for nm in [400.0, 550.0, 700.0] {
        let want = bk7_ng(nm * 1e-3) / C;
        let t = arrival_s(scene(), band(nm), 1.5 / C, 400);
        assert!(
            (t - want).abs() < 0.6e-12,
            "{nm} nm: arrived at {t:e} s, the group delay is {want:e} s"
        );
    }
}

/// A 60 degree prism of N-BK7, its two faces crossing along the y axis: a ray in the
/// x-z plane meeting the first face at 50 degrees, refracted there and at the second
/// face by the BSDF of each band's surface point, leaves deviated by
/// `delta = theta_1 + asin(n sin(A - asin(sin theta_1 / n))) - A`, Snell's law at
/// `n = n(lambda)`: 39.89 degrees at 400 nm, 38.33 at 700.
#[test]
fn prism_deviates_each_wavelength_by_snells_law() {
    let apex = 60f64.to_radians();
    // Face 1 has outward normal n1 at -apex/2 from +x toward... in the x-z plane: the
    // prism's apex points up (+z), face 1 on the left (normal up-left), face 2 on the right.
    let n1 = Vec3::new(-(apex / 2.0).cos() as f32, 0.0, (apex / 2.0).sin() as f32);
    let n2 = Vec3::new((apex / 2.0).cos() as f32, 0.0, (apex / 2.0).sin() as f32);
    let face = |n: Vec3| {
        // A large triangle through the origin in the plane with normal n, wound so its
        // front face looks along n.
        let t = Vec3::Y * 10.0;
        let s = n.cross(Vec3::Y).normalize() * 10.0;
        let (a, b, c) = (-s - t, s - t, t);
        if (b - a).cross(c - a).dot(n) > 0.0 {
            Triangle { p: [a, b, c] }
        } else {
            Triangle { p: [a, c, b] }
        }
    };
    let mut scene = empty_scene(camera_above(5.0));
    scene.materials.push(bk7_glass());
    for n in [n1, n2] {
        scene.triangles.push(face(n));
        scene.attrs.push(TriangleAttrs {
            normals: None,
            uv: [Vec2::ZERO; 3],
            material: 0,
        });
    }
    let scene = Arc::new(scene);
    let theta1 = 50f64.to_radians();
    // The incident ray makes theta1 with -n1 (it travels into face 1).
    let rot = |v: Vec3, a: f64| {
        // Rotate v about +y by angle a.
        let (s, c) = (a.sin() as f32, a.cos() as f32);
        Vec3::new(c * v.x + s * v.z, v.y, -s * v.x + c * v.z)
    };
    let d0 = rot(-n1, -theta1).normalize();
    let refract = |surfaces: &Surfaces, tri: u32, dir: Vec3| -> Vec3 {
        let hit = Hit {
            t_m: 1.0,
            triangle: tri,
            u: 0.3,
            v: 0.3,
        };
        let sp = surfaces.at(&hit, Vec3::ZERO, dir);
        let frame = Frame::new(sp.n_shading);
        let s = sp
            .bsdf
            .sample(frame.to_local(-dir), 0.999_9, (0.999_9, 0.5))
            .expect("a refraction");
        assert_eq!(s.kind, tprf_core::transport::bsdf::LobeKind::Refract);
        frame.to_world(s.wi).normalize()
    };
    let mut deviations = Vec::new();
    for nm in [400.0, 550.0, 700.0] {
        let surfaces = Surfaces::new(scene.clone(), band(nm));
        let d1 = refract(&surfaces, 0, d0);
        let d2 = refract(&surfaces, 1, d1);
        let got = (d0.dot(d2) as f64).clamp(-1.0, 1.0).acos();
        let n = bk7_n(nm * 1e-3);
        let t1p = (theta1.sin() / n).asin();
        let want = theta1 + (n * (apex - t1p).sin()).asin() - apex;
        eprintln!(
            "{nm} nm: deviation {:.4} deg, Snell {:.4} deg",
            got.to_degrees(),
            want.to_degrees()
        );
        assert!(
            (got - want).abs() < 2e-5,
            "{nm} nm: deviated {} deg, Snell's law at n = {n} gives {} deg",
            got.to_degrees(),
            want.to_degrees()
        );
        deviations.push(got);
    }
    assert!(deviations[0] > deviations[1] && deviations[1] > deviations[2]);
}

/// The white furnace (albedo 0.8) rendered at 450 and 650 nm: each matches the
/// furnace's semi-analytic answer, and the two cubes are the same bit for bit (a grey is
/// the flat spectrum: every band sees the same albedo).
#[test]
fn white_furnace_stays_white_across_bands() {
    let mut films = Vec::new();
    for nm in [450.0, 650.0] {
        let settings = RenderSettings {
            seed: 11,
            channel: band(nm),
            ..RenderSettings::default()
        };
        films.push(super::analytic::check_furnace_with(
            0.8,
            settings,
            &format!("{nm} nm"),
        ));
    }
    assert_eq!(films[0], films[1]);
}

/// A dispersive glass written to glTF comes back with its index (extras `{"tprf": {"n":
/// ...}}`), as a name or a Cauchy pair; `"n": {"cauchy": [A, B_um2]}` written by hand is
/// read, its `ior` the d line's; a bad one is refused naming the material.
#[test]
fn gltf_extras_carry_the_dispersion() {
    let dir = std::env::temp_dir().join(format!("tprf-dispersion-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("slab.gltf");
    let mut s = emitter_below(3.0);
    s.materials.push(bk7_glass());
    let cauchy = Dispersion::parse("cauchy:1.5046:0.0042").unwrap();
    s.materials.push(Material {
        name: "cauchy".into(),
        dispersion: Some(cauchy.clone()),
        ior: cauchy.n(0.58756) as f32,
        ..bk7_glass()
    });
    quad(&mut s, 2.0, 2.0, true, 1);
    quad(&mut s, 1.0, 2.0, false, 2);
    tprf_core::scene::gltf_save::save_gltf(&s, &path).unwrap();
    let back = tprf_core::scene::gltf_load::load_gltf(&path).unwrap();
    let by_name = |n: &str| back.materials.iter().find(|m| m.name == n).unwrap().clone();
    assert_eq!(by_name("bk7").dispersion, Dispersion::named("bk7"));
    assert_eq!(by_name("cauchy").dispersion, Some(cauchy.clone()));
    assert!((by_name("cauchy").ior as f64 - (1.5046 + 0.0042 / (0.58756 * 0.58756))).abs() < 1e-6);
    // A bad dispersion in the file: refused, naming the material.
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("\"cauchy\""), "{text}");
    std::fs::write(&path, text.replace("[1.5046,0.0042]", "[1.5046]")).unwrap();
    let e = tprf_core::scene::gltf_load::load_gltf(&path)
        .unwrap_err()
        .to_string();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(e.contains("'cauchy'") && e.contains("tprf.n"), "{e}");
}

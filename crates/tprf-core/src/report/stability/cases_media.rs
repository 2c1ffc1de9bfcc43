//! Extreme participating media (issue 32): an optical depth of 1e4, an albedo of 0.9999,
//! and fog in a 1 mm and in a 10 km furnace, each against an answer written here.
//!
//! - Optical depth 1e4 (extinction 1e4 / m in a 1 m furnace), `--max-bounces 1`: the
//!   co-located point light and camera see single scattering,
//!   `sigma_s p(pi) I e^(-2 sigma_t r) / r^2` integrated over each bin's `r = c t / (2 n)`
//!   (Simpson); rendered with every order, its single-scattering layer is the same.
//! - Albedo 0.9999, 1 mm and 10 km fog: a closed furnace with white walls that emit a
//!   pulse of radiance `Le` at t = 0 keeps its energy `pi Le A` (wall area `A`) but for
//!   what the medium absorbs, and light that has gone an optical path `x` has met
//!   absorption along all of it whatever its route: the energy left is
//!   `pi Le A e^(-sigma_a x)`. Long after the pulse it is a uniform isotropic field in the
//!   volume `V`, radiance `L = u (c/n) / (4 pi) = Le A (c/n) e^(-sigma_a x) / (4 V)`, so a
//!   window of optical paths `[x0, x1]` (times `n/c`) holds
//!   `Le A (e^(-sigma_a x0) - e^(-sigma_a x1)) / (4 V sigma_a)` (radiance times seconds),
//!   whatever the scale (coefficients over the scale) and the index.

use super::common::{Size, mean, non_finite, pixels, render, std_error};
use super::verdict::{Check, Kind, Row, num};
use crate::film::TimeAxis;
use crate::reference::furnace::Furnace;
use crate::scene::{Medium, Scene};
use crate::transport::RenderSettings;
use crate::units::C_M_PER_S;

/// Henyey-Greenstein phase function of `g` at `cos`, 1/sr (written out for the reference,
/// not the renderer's).
fn hg(cos: f64, g: f64) -> f64 {
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * cos).powf(1.5))
}

/// Composite Simpson's rule with `n` (even) intervals.
fn simpson(a: f64, b: f64, n: usize, f: impl Fn(f64) -> f64) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// Volume enclosed by a closed triangle mesh (divergence theorem), m^3.
fn mesh_volume_m3(scene: &Scene) -> f64 {
    scene
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.p.map(|p| p.as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum::<f64>()
        .abs()
}

/// Optical depth 1e4: the single-scattering closed form per bin and for the window, and
/// every order at least as bright.
fn optical_depth_1e4(size: Size) -> Vec<Row> {
    let (sigma_s, sigma_a, g, n, i) = (9e3f64, 1e3f64, 0.6f64, 1.33f64, 2.0f64);
    let sigma_t = sigma_s + sigma_a;
    let mut scene = Furnace::point(1.0, 0.8, i).scene();
    scene.medium = Some(Medium::grey(
        sigma_s as f32,
        sigma_a as f32,
        g as f32,
        n as f32,
    ));
    // Scattering at 0.1 to 3.1 mean free paths from the eye, 30 bins.
    let bins = 30;
    let t_of = |r: f64| 2.0 * n * r / C_M_PER_S;
    let axis = TimeAxis::new(t_of(0.1 / sigma_t), t_of(0.1 / sigma_t), bins).expect("axis");
    let want: Vec<f64> = (0..bins)
        .map(|b| {
            let r0 = axis.bin_start_s(b) * C_M_PER_S / (2.0 * n);
            let r1 = axis.bin_start_s(b + 1) * C_M_PER_S / (2.0 * n);
            sigma_s
                * hg(-1.0, g)
                * i
                * simpson(r0, r1, 200, |r| (-2.0 * sigma_t * r).exp() / (r * r))
        })
        .collect();
    let want_total: f64 = want.iter().sum();
    let (side, spp) = (size.pick(6, 16), size.pick(64, 256));
    let setting = format!(
        "{side}x{side} px, {spp} spp, extinction {} /m in a 1 m furnace, albedo 0.9, g {g}, n {n}",
        num(sigma_t)
    );
    let single = RenderSettings {
        seed: 41,
        max_bounces: 1,
        ..RenderSettings::default()
    };
    let film = render(scene.clone(), side, side, axis, spp, single, 0);
    let bad = non_finite(&film);
    let px = pixels(&film);
    let totals: Vec<f64> = px.iter().map(|p| p.iter().sum()).collect();
    // The worst bin, in standard errors of the pixel mean.
    let worst = (0..bins)
        .map(|b| {
            let v: Vec<f64> = px.iter().map(|p| p[b]).collect();
            (mean(&v) - want[b]).abs() / (std_error(&v) + 1e-4 * want[b])
        })
        .fold(0.0, f64::max);
    let mut rows = vec![
        Row {
            case: "optical depth 1e4, single scattering: window total".into(),
            setting: setting.clone(),
            kind: Kind::Reference,
            check: Check::Within {
                expected: want_total,
                tolerance: 5.0 * std_error(&totals) + 1e-4 * want_total,
            },
            got: mean(&totals),
            non_finite: bad,
            note: "sigma_s p(pi) I e^(-2 sigma_t r) / r^2 over r = c t / (2n), Simpson; \
                   --max-bounces 1; 5 standard errors"
                .into(),
        },
        Row {
            case: "optical depth 1e4, single scattering: worst of 30 bins (standard errors)".into(),
            setting: setting.clone(),
            kind: Kind::Reference,
            check: Check::AtMost { bound: 5.0 },
            got: worst,
            non_finite: bad,
            note: "|pixel mean - closed form| / its standard error, per bin".into(),
        },
    ];
    let all = RenderSettings {
        seed: 43,
        max_bounces: 100_000,
        ..RenderSettings::default()
    };
    let film = render(scene, side, side, axis, spp, all, 1);
    let l = film.layout();
    let layer1: Vec<f64> = (0..l.height)
        .flat_map(|y| (0..l.width).map(move |x| (x, y)))
        .map(|(x, y)| film.pixel_bounces(x, y)[1].iter().sum::<f64>())
        .collect();
    rows.push(Row {
        case: "optical depth 1e4, every order: its single-scattering layer's window total".into(),
        setting,
        kind: Kind::Reference,
        check: Check::Within {
            expected: want_total,
            tolerance: 5.0 * std_error(&layer1) + 1e-4 * want_total,
        },
        got: mean(&layer1),
        non_finite: non_finite(&film),
        note: "the closed form again, from the render with every order (max-bounces \
               100000, --bounces-separate 1: layer 1); 5 standard errors"
            .into(),
    });
    rows
}

/// Area of a triangle mesh, m^2.
fn mesh_area_m2(scene: &Scene) -> f64 {
    scene
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.p.map(|p| p.as_dvec3());
            (b - a).cross(c - a).length() / 2.0
        })
        .sum()
}

/// A white-walled furnace of radius `s` whose wall emits a pulse of radiance 1 (W/(m^2
/// sr) times seconds) at t = 0, filled with `medium` (given at 1 m, scaled by `s`): the
/// window of optical paths `x0_m` to `x0_m + 64` (times `s`) against
/// `Le A (e^(-sigma_a x0) - e^(-sigma_a x1)) / (4 V sigma_a)`.
fn white_furnace_row(size: Size, what: &str, s: f64, medium: Medium, x0_m: f64) -> Row {
    let le = 1.0;
    let mut scene = Furnace::emitting(1.0, 1.0, le).scene().scaled(s as f32);
    scene.medium = Some(medium.clone().scaled(s as f32));
    let (area, volume) = (mesh_area_m2(&scene), mesh_volume_m3(&scene));
    let n = medium.n as f64;
    let sigma_a = medium.sigma_a_per_m[0] as f64 / s;
    let (x0, x1) = (x0_m * s, (x0_m + 64.0) * s);
    let bins = 8;
    let axis = TimeAxis::new(
        x0 * n / C_M_PER_S,
        (x1 - x0) / bins as f64 * n / C_M_PER_S,
        bins,
    )
    .expect("axis");
    let want =
        le * area * ((-sigma_a * x0).exp() - (-sigma_a * x1).exp()) / (4.0 * volume * sigma_a);
    let (side, spp) = (size.pick(6, 12), size.pick(64, 128));
    let settings = RenderSettings {
        seed: 47,
        max_bounces: 100_000,
        ..RenderSettings::default()
    };
    let film = render(scene, side, side, axis, spp, settings, 0);
    let totals: Vec<f64> = pixels(&film).iter().map(|p| p.iter().sum()).collect();
    Row {
        case: format!("{what}: late radiance in a white furnace"),
        setting: format!(
            "{side}x{side} px, {spp} spp, R {} m, sigma_s {} /m, sigma_a {} /m, g {}, n {n}, \
             optical path {}-{} m",
            num(s),
            num(medium.sigma_s_per_m[0] as f64 / s),
            num(sigma_a),
            medium.g,
            num(x0),
            num(x1)
        ),
        kind: Kind::Reference,
        check: Check::Within {
            expected: want,
            tolerance: 5.0 * std_error(&totals) + 0.01 * want,
        },
        got: mean(&totals),
        non_finite: non_finite(&film),
        note: format!(
            "Le A (e^(-sigma_a x0) - e^(-sigma_a x1)) / (4 V sigma_a): the wall's pulse \
             pi Le A kept by white walls but for e^(-sigma_a x) (no absorption would give {}); \
             5 standard errors + 1 % for the field's residual non-uniformity",
            num(le * area * (x1 - x0) / (4.0 * volume))
        ),
    }
}

/// The extreme media: optical depth 1e4, albedo 0.9999, 1 mm and 10 km fog.
pub fn extreme_media(size: Size) -> Vec<Row> {
    let mut rows = optical_depth_1e4(size);
    rows.push(white_furnace_row(
        size,
        "albedo 0.9999",
        1.0,
        Medium::grey(2.0, 2e-4, 0.9, 1.0),
        500.0,
    ));
    rows.push(white_furnace_row(
        size,
        "1 mm fog",
        1e-3,
        Medium::grey(2.0, 0.01, 0.9, 1.0),
        100.0,
    ));
    rows.push(white_furnace_row(
        size,
        "10 km fog",
        1e4,
        Medium::grey(2.0, 0.01, 0.9, 1.33),
        100.0,
    ));
    rows
}

//! Scales: the Cornell box at 1 mm and 10 km against itself at 1 m (invariance), and
//! the lit plane at 1 mm, 1 m and 10 km against its exact answer.

use super::common::{Size, mean, mean_arrival_s, non_finite, pixels, render};
use super::verdict::{Check, Kind, Row, num};
use crate::film::TimeAxis;
use crate::reference::plane::Plane;
use crate::transport::RenderSettings;
use crate::units::C_M_PER_S;

/// The image mean of `plane` rendered at `w x h`, `spp` samples, against its exact
/// footprint integrals, within 5 standard errors from the footprint spread.
fn plane_rows(plane: &Plane, w: usize, h: usize, spp: u64, what: &str, setting: &str) -> Row {
    let axis = {
        let a = plane.default_axis(w, h, 8).expect("axis");
        // A wide window: every arrival is in it.
        TimeAxis::new(0.0, a.end_s() * 1.5 / 8.0, 8).expect("axis")
    };
    let film = render(
        plane.scene(),
        w,
        h,
        axis,
        spp,
        RenderSettings {
            seed: 5,
            ..RenderSettings::default()
        },
        0,
    );
    let steady = film.steady();
    let mut want = 0.0;
    let mut var = 0.0;
    for y in 0..h {
        for x in 0..w {
            let m = plane.pixel_moments(x, y, w, h);
            want += m.mean;
            var += m.sd * m.sd / spp as f64;
        }
    }
    let n = (w * h) as f64;
    Row {
        case: what.into(),
        setting: setting.into(),
        kind: Kind::Reference,
        check: Check::Within {
            expected: want / n,
            tolerance: 5.0 * var.sqrt() / n + 1e-5 * want / n,
        },
        got: mean(&steady),
        non_finite: non_finite(&film),
        note: "image mean of the exact footprint integrals; 5 standard errors from the \
               footprint spread (acne would darken pixels)"
            .into(),
    }
}

/// The Cornell box and the lit plane at 1 mm, 1 m and 10 km (light intensities times
/// s^2, so radiance is unchanged; time axes times s).
pub fn scales(size: Size) -> Vec<Row> {
    let mut rows = Vec::new();
    let (side, spp) = (size.pick(16, 48), size.pick(16, 64));
    let cornell = |s: f32| {
        crate::scene::load("builtin:cornell")
            .expect("built-in")
            .scaled(s)
            .with_intensity_scale(s * s)
    };
    let bins = 64;
    let axis_for = |s: f64| TimeAxis::new(0.0, 0.05 * s / C_M_PER_S, bins).expect("axis");
    let settings = RenderSettings {
        seed: 17,
        ..RenderSettings::default()
    };
    let base = render(cornell(1.0), side, side, axis_for(1.0), spp, settings, 0);
    let base_px = pixels(&base);
    let base_steady = mean(&base.steady());
    let base_curve: Vec<f64> = (0..bins)
        .map(|b| base_px.iter().map(|p| p[b]).sum::<f64>())
        .collect();
    let base_t = mean_arrival_s(&base_curve, &axis_for(1.0));
    for s in [1e-3f64, 1e4] {
        let film = render(cornell(s as f32), side, side, axis_for(s), spp, settings, 0);
        let bad = non_finite(&film);
        let px = pixels(&film);
        let curve: Vec<f64> = (0..bins)
            .map(|b| px.iter().map(|p| p[b]).sum::<f64>())
            .collect();
        let label = if s < 1.0 { "1 mm" } else { "10 km" };
        let setting = format!("{side}x{side} px, {spp} spp, same seed as 1 m");
        rows.push(Row {
            case: format!("Cornell box at {label}: steady image mean"),
            setting: setting.clone(),
            kind: Kind::Invariance,
            check: Check::Within {
                expected: base_steady,
                tolerance: 2e-3 * base_steady,
            },
            got: mean(&film.steady()),
            non_finite: bad,
            note: "the 0.555 m box's value; same random streams, so only rounding differs".into(),
        });
        rows.push(Row {
            case: format!("Cornell box at {label}: mean arrival / scale (ns)"),
            setting: setting.clone(),
            kind: Kind::Invariance,
            check: Check::Within {
                expected: base_t * 1e9,
                tolerance: 2e-3 * base_t * 1e9,
            },
            got: mean_arrival_s(&curve, &axis_for(s)) / s * 1e9,
            non_finite: bad,
            note: format!(
                "time axis {} s bins: the TPRF stretches by the scale",
                num(axis_for(s).dt_s)
            ),
        });
        let diff = base_curve
            .iter()
            .zip(&curve)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt()
            / base_curve.iter().map(|a| a * a).sum::<f64>().sqrt();
        rows.push(Row {
            case: format!("Cornell box at {label}: TPRF vs 1 m, relative L2"),
            setting,
            kind: Kind::Invariance,
            check: Check::AtMost { bound: 5e-3 },
            got: diff,
            non_finite: bad,
            note: "sum over pixels, bin by bin".into(),
        });
    }
    let (pw, pspp) = (size.pick(12, 32), size.pick(16, 64));
    for (s, label) in [(1e-3, "1 mm"), (1.0, "1 m"), (1e4, "10 km")] {
        let p = Plane::colocated(2.0 * s, 0.5, 3.0 * s * s, 50.0 * s, 40.0);
        rows.push(plane_rows(
            &p,
            pw,
            pw,
            pspp,
            &format!("lit plane at {label}: no acne"),
            &format!("{pw}x{pw} px, {pspp} spp, camera {}", num(2.0 * s)),
        ));
    }
    rows
}

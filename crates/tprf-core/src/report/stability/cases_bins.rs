//! Bins: one bin and 100 000 bins over the same window with the same paths, and 10^8
//! samples into one bin.

use super::common::{Size, mean, mean_arrival_s, non_finite, pixels, render, std_error};
use super::verdict::{Check, Kind, Row, num};
use crate::film::{FilmLayout, TimeAxis, TprfFilm};
use crate::reference::furnace::Furnace;
use crate::transport::RenderSettings;
use crate::units::C_M_PER_S;

/// One bin and 100 000 bins over the same window with the same paths; 10^8 samples into
/// one bin.
pub fn bins(size: Size) -> Vec<Row> {
    let mut rows = Vec::new();
    let f = Furnace::point(1.0, 0.5, 1.0);
    let (side, spp) = (size.pick(4, 8), size.pick(64, 256));
    let end_s = 30.0 / C_M_PER_S;
    // Uniform samples: an adaptive plan follows each bin's noise, which differs between
    // the two axes, and the two renders would not trace the same paths.
    let settings = RenderSettings {
        seed: 31,
        adaptive: false,
        ..RenderSettings::default()
    };
    let one_axis = TimeAxis::new(0.0, end_s, 1).expect("axis");
    let many = 100_000;
    let many_axis = TimeAxis::new(0.0, end_s / many as f64, many).expect("axis");
    let one = render(f.scene(), side, side, one_axis, spp, settings, 0);
    let fine = render(f.scene(), side, side, many_axis, spp, settings, 0);
    let e_ref: f64 = f.tprf(&one_axis).iter().sum();
    let totals = one.steady();
    let setting = format!("{side}x{side} px, {spp} spp, furnace rho=0.5, window 30 R");
    rows.push(Row {
        case: "T = 1: energy".into(),
        setting: setting.clone(),
        kind: Kind::Reference,
        check: Check::Within {
            expected: e_ref,
            tolerance: 5.0 * std_error(&totals) + 3e-3 * e_ref,
        },
        got: mean(&totals),
        non_finite: non_finite(&one),
        note: "renewal reference in the window (1 - 2^-20 of rho I/(pi R^2 (1-rho)))".into(),
    });
    let fine_totals = fine.steady();
    let fine_bad = non_finite(&fine);
    rows.push(Row {
        case: "T = 100 000: sum over bins vs T = 1".into(),
        setting: setting.clone(),
        kind: Kind::Invariance,
        check: Check::Within {
            expected: mean(&totals),
            tolerance: 1e-12 * mean(&totals),
        },
        got: mean(&fine_totals),
        non_finite: fine_bad,
        note: "same paths: binning conserves energy to rounding".into(),
    });
    let px = pixels(&fine);
    let mut curve = vec![0.0; many];
    for p in &px {
        for (c, v) in curve.iter_mut().zip(p) {
            *c += v / px.len() as f64;
        }
    }
    let reference = f.tprf(&many_axis);
    let t_ref = mean_arrival_s(&reference, &many_axis);
    let t_px: Vec<f64> = px.iter().map(|p| mean_arrival_s(p, &many_axis)).collect();
    rows.push(Row {
        case: "T = 100 000: mean arrival (ns)".into(),
        setting: setting.clone(),
        kind: Kind::Reference,
        check: Check::Within {
            expected: t_ref * 1e9,
            tolerance: (5.0 * std_error(&t_px) + 3e-3 * t_ref) * 1e9,
        },
        got: mean_arrival_s(&curve, &many_axis) * 1e9,
        non_finite: fine_bad,
        note: format!(
            "bins of {} fs; renewal reference on the same bins",
            num(many_axis.dt_s * 1e15)
        ),
    });
    // 10^8 samples into one bin: values 1 + k/1024 sum exactly in f64 (37 bits).
    let n: u64 = 100_000_000;
    let mut film = TprfFilm::new(FilmLayout {
        width: 1,
        height: 1,
        axis: TimeAxis::new(0.0, 1.0, 2).expect("axis"),
        bounces_separate: 0,
        luminescence: false,
    })
    .expect("tiny film");
    film.run_pass(1, |_, _, sink| {
        for i in 0..n {
            sink.add(0.5, 1.0 + (i % 7) as f64 / 1024.0, 1);
        }
    });
    let exact_1024: u64 = (0..7u64)
        .map(|k| (n / 7 + u64::from(k < n % 7)) * (1024 + k))
        .sum();
    let exact = exact_1024 as f64 / 1024.0;
    rows.push(Row {
        case: "10^8 samples into one bin".into(),
        setting: "values 1 + k/1024, k = i mod 7".into(),
        kind: Kind::Reference,
        check: Check::Within {
            expected: exact,
            tolerance: 0.0,
        },
        got: film.pixel_tprf(0, 0)[0],
        non_finite: non_finite(&film),
        note: "exact integer sum; an f32 accumulator would stop growing at 2^24".into(),
    });
    rows
}

//! A stiff luminescence: a phosphor of lifetime 1 ms seen on 10 ps bins (eight orders
//! of magnitude between the decay and the bin), on the luminescent lit plane whose cube
//! is known in closed form ([`LuminescentPlane`]).

use super::common::{Size, mean, non_finite, pixels, render, std_error};
use super::verdict::{Check, Kind, Row, num};
use crate::film::TimeAxis;
use crate::reference::luminescent_plane::LuminescentPlane;
use crate::reference::plane::Plane;
use crate::transport::RenderSettings;

/// The phosphor's lifetime, seconds, and its yield.
const LIFETIME_S: f64 = 1e-3;
const YIELD: f64 = 0.4;

/// Per pixel, the sum over `bins` of the film and of the reference.
fn sums(
    lp: &LuminescentPlane,
    film: &crate::film::TprfFilm,
    side: usize,
    axis: &TimeAxis,
    bins: std::ops::Range<usize>,
) -> (Vec<f64>, f64) {
    let got: Vec<f64> = pixels(film)
        .iter()
        .map(|p| p[bins.clone()].iter().sum())
        .collect();
    let mut want = 0.0;
    for y in 0..side {
        for x in 0..side {
            want += lp.pixel_tprf(x, y, side, side, axis)[bins.clone()]
                .iter()
                .sum::<f64>();
        }
    }
    (got, want / (side * side) as f64)
}

/// The 1 ms phosphor: its decay's light in 10 ps bins just after the return, in a 10 ps
/// gate 1 ms after the pulse, and its whole energy on a 20 ms window.
pub fn stiff_luminescence(size: Size) -> Vec<Row> {
    let mut rows = Vec::new();
    let lp = LuminescentPlane {
        plane: Plane::colocated(2.0, 0.3, 3.0, 50.0, 40.0),
        components: vec![(YIELD, LIFETIME_S)],
    };
    let (side, spp) = (size.pick(4, 8), size.pick(64, 1024));
    let settings = RenderSettings {
        seed: 41,
        ..RenderSettings::default()
    };
    let setting =
        format!("{side}x{side} px, {spp} spp, plane rho 0.3 + yield {YIELD}, lifetime 1 ms");
    let cases: [(&str, TimeAxis, &str); 3] = [
        (
            "1 ms phosphor: 10 ps bins after the return",
            TimeAxis::new(12.5e-9, 10e-12, 2000).expect("axis"),
            "the decay's light in the 1650 bins after every pixel's return (16-32.5 ns)",
        ),
        (
            "1 ms phosphor: a 10 ps gate 1 ms later",
            TimeAxis::new(1e-3, 10e-12, 1).expect("axis"),
            "one bin 1 ms after the pulse: e^-1 of the decay's density, 1e-8 of its light",
        ),
        (
            "1 ms phosphor: whole decay, 20 ms window",
            TimeAxis::new(0.0, 20e-6, 1000).expect("axis"),
            "direct return + (1 - e^-20) of the re-emission",
        ),
    ];
    for (case, axis, note) in cases {
        let film = render(lp.scene(), side, side, axis, spp, settings, 0);
        // After the return only (the first row): the bins from 16 ns on, past every
        // pixel's direct light (the corners' returns end at 15 ns).
        let first = if axis.bins > 1000 { 350 } else { 0 };
        let (got, want) = sums(&lp, &film, side, &axis, first..axis.bins);
        rows.push(Row {
            case: case.into(),
            setting: format!("{setting}, bins of {} s", num(axis.dt_s)),
            kind: Kind::Reference,
            check: Check::Within {
                expected: want,
                tolerance: 5.0 * std_error(&got) + 1e-3 * want,
            },
            got: mean(&got),
            non_finite: non_finite(&film),
            note: note.into(),
        });
    }
    rows
}

//! Stiff furnaces: albedo 0.99 and 0.999 against the renewal reference and the albedo
//! laws.

use super::common::{Size, mean, mean_arrival_s, non_finite, pixels, render, std_error};
use super::verdict::{Check, Kind, Row, num};
use crate::film::TimeAxis;
use crate::reference::furnace::Furnace;
use crate::transport::RenderSettings;
use crate::units::C_M_PER_S;

/// Albedo 0.99 and 0.999: energy and mean arrival in the window against the renewal
/// reference (the `rho / (1 - rho)` laws restricted to the window), the energy of paths
/// with more than 200 scattering events against `w0 rho^200 / (1 - rho)` (less what
/// lies past the window, all of which has more than 200 events), and the spread of one
/// sample against the analog walk's that Russian roulette makes of it.
pub fn stiff_furnace(size: Size) -> Vec<Row> {
    let mut rows = Vec::new();
    for (rho, held, side, spp) in [
        (0.99f64, 1e-4f64, size.pick(16, 32), size.pick(16, 64)),
        (0.999, 1e-2, size.pick(16, 32), size.pick(4, 16)),
    ] {
        let f = Furnace::point(1.0, rho, 1.0);
        let (x0, w0) = f.first_arrival();
        let chords = held.ln() / rho.ln();
        let end_m = x0 + 4.0 / 3.0 * chords;
        let bins = 64;
        let axis = TimeAxis::new(0.0, end_m / C_M_PER_S / bins as f64, bins).expect("axis");
        let reference = f.tprf(&axis);
        let e_ref: f64 = reference.iter().sum();
        let t_ref = mean_arrival_s(&reference, &axis);
        const K: u32 = 200;
        let settings = RenderSettings {
            seed: 99,
            max_bounces: 100_000,
            ..RenderSettings::default()
        };
        let film = render(f.scene(), side, side, axis, spp, settings, K);
        let bad = non_finite(&film);
        let px = pixels(&film);
        let totals: Vec<f64> = px.iter().map(|p| p.iter().sum()).collect();
        let e = mean(&totals);
        let se = std_error(&totals);
        let setting = format!("{side}x{side} px, {spp} spp, rr_start 3, {bins} bins");
        let case = format!("furnace rho={rho}");
        rows.push(Row {
            case: format!("{case}: energy in window"),
            setting: setting.clone(),
            kind: Kind::Reference,
            check: Check::Within {
                expected: e_ref,
                tolerance: 5.0 * se + 3e-3 * e_ref,
            },
            got: e,
            non_finite: bad,
            note: format!(
                "renewal sum; law rho I/(pi R^2 (1-rho)) = {} over all time, the window \
                 (to {:.0} R) holds {:.4} of it; 5 standard errors + 0.3 % for the facets",
                num(f.energy()),
                end_m,
                e_ref / f.energy()
            ),
        });
        let mut cube_mean = vec![0.0; bins];
        for p in &px {
            for (m, v) in cube_mean.iter_mut().zip(p) {
                *m += v / px.len() as f64;
            }
        }
        let t_got = mean_arrival_s(&cube_mean, &axis);
        let t_px: Vec<f64> = px.iter().map(|p| mean_arrival_s(p, &axis)).collect();
        rows.push(Row {
            case: format!("{case}: mean arrival in window (ns)"),
            setting: setting.clone(),
            kind: Kind::Reference,
            check: Check::Within {
                expected: t_ref * 1e9,
                tolerance: (5.0 * std_error(&t_px) + 3e-3 * t_ref) * 1e9,
            },
            got: t_got * 1e9,
            non_finite: bad,
            note: format!(
                "bin centres of the renewal sum; law (2R + 4R/3 rho/(1-rho))/c = {} ns over \
                 all time",
                num(f.mean_arrival_s() * 1e9)
            ),
        });
        // Orders above K: all that lies past the window has more than K events (K chords
        // are at most 2RK long).
        let beyond_px: Vec<f64> = {
            let l = film.layout();
            let last = l.bounce_layers() - 1;
            (0..l.height)
                .flat_map(|y| (0..l.width).map(move |x| (x, y)))
                .map(|(x, y)| film.pixel_bounces(x, y)[last].iter().sum::<f64>())
                .collect()
        };
        let beyond = mean(&beyond_px);
        let want = w0 * rho.powi(K as i32) / (1.0 - rho) - (f.energy() - e_ref);
        rows.push(Row {
            case: format!("{case}: energy after more than {K} scattering events"),
            setting: setting.clone(),
            kind: Kind::Reference,
            check: Check::Within {
                expected: want,
                tolerance: 5.0 * std_error(&beyond_px) + 3e-3 * want,
            },
            got: beyond,
            non_finite: bad,
            note: format!(
                "order law w0 rho^{K}/(1-rho) less the energy past the window; paths of \
                 hundreds to thousands of bounces (max_bounces 100000)"
            ),
        });
        // One sample's relative spread. Roulette with survival = throughput turns the
        // walk into the analog one: weights 1, rho, rho^2, then 1 per surviving bounce
        // (probability rho each, after surviving rho^3 once): relative sd
        // sqrt(rho^3 (1 + rho) - rho^6) over all time, less in a window.
        let rel_sd = std_error(&totals) * (totals.len() as f64).sqrt() * (spp as f64).sqrt() / e;
        let analog = (rho.powi(3) * (1.0 + rho) - rho.powi(6)).sqrt();
        rows.push(Row {
            case: format!("{case}: relative sd of one sample"),
            setting,
            kind: Kind::Reference,
            check: Check::AtMost {
                bound: 1.25 * analog,
            },
            got: rel_sd,
            non_finite: bad,
            note: format!(
                "no variance explosion: the analog walk's {:.4} (+25 % for the estimate \
                 from {} pixels)",
                analog,
                totals.len()
            ),
        });
    }
    rows
}

//! Stiff and extreme cases, each against an answer derived independently of the
//! renderer: albedo 0.99 and 0.999 furnaces (energy, mean arrival, the order law,
//! Russian roulette's variance), the same scenes at 1 mm, 1 m and 10 km, 1 and 100 000
//! time bins, 10^8 samples in one bin, a point light 1e-6 m from a wall, grazing light
//! and view, coincident faces and degenerate triangles.
//!
//! [`Size::Test`] runs in the test suite (seconds); [`Size::Full`] is `tprf stability`
//! (larger films, more samples). Every row says what was expected, what came out, how
//! far apart they may be and why, how many values were NaN or infinite, and a verdict.

use crate::film::{FilmLayout, TimeAxis, TprfFilm};
use crate::reference::furnace::Furnace;
use crate::reference::gauss_legendre;
use crate::reference::plane::{Plane, Rect};
use crate::scene::{Camera, Scene, Triangle, TriangleAttrs};
use crate::transport::progressive::{self, Schedule};
use crate::transport::{RenderSettings, Renderer};
use crate::units::C_M_PER_S;
use glam::{Vec2, Vec3};
use std::fmt::Write as _;
use std::sync::Arc;

/// How big the cases are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Size {
    /// Small films, few samples: seconds, for the tests.
    Test,
    /// Larger films and more samples: `tprf stability`.
    Full,
}

impl Size {
    fn pick<T>(self, test: T, full: T) -> T {
        match self {
            Size::Test => test,
            Size::Full => full,
        }
    }
}

/// What a row checks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Check {
    /// `|got - expected| <= tolerance`.
    Within { expected: f64, tolerance: f64 },
    /// `got <= bound`.
    AtMost { bound: f64 },
    /// `got > bound`.
    Above { bound: f64 },
}

/// One line of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub case: String,
    pub setting: String,
    pub check: Check,
    pub got: f64,
    /// NaN or infinite values in what was rendered.
    pub non_finite: u64,
    /// Where the expected value and the tolerance come from; a documented bias.
    pub note: String,
}

impl Row {
    pub fn passed(&self) -> bool {
        self.non_finite == 0
            && self.got.is_finite()
            && match self.check {
                Check::Within {
                    expected,
                    tolerance,
                } => (self.got - expected).abs() <= tolerance,
                Check::AtMost { bound } => self.got <= bound,
                Check::Above { bound } => self.got > bound,
            }
    }

    /// `|got - expected| / |expected|` where there is an expected value.
    pub fn relative_error(&self) -> Option<f64> {
        match self.check {
            Check::Within { expected, .. } if expected != 0.0 => {
                Some((self.got - expected).abs() / expected.abs())
            }
            _ => None,
        }
    }

    fn expected_text(&self) -> String {
        match self.check {
            Check::Within {
                expected,
                tolerance,
            } => format!("{} ± {}", num(expected), num(tolerance)),
            Check::AtMost { bound } => format!("≤ {}", num(bound)),
            Check::Above { bound } => format!("> {}", num(bound)),
        }
    }
}

fn num(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&x.abs()) {
        format!("{x:.6}")
    } else {
        format!("{x:.6e}")
    }
}

/// The markdown table of `rows`.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from(
        "| case | setting | expected | got | relative error | NaN/Inf | verdict | notes |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            r.case,
            r.setting,
            r.expected_text(),
            num(r.got),
            r.relative_error()
                .map_or("-".into(), |e| format!("{:.2e}", e)),
            r.non_finite,
            if r.passed() { "pass" } else { "FAIL" },
            r.note
        );
    }
    s
}

/// A case: its rows at a size.
pub type Case = fn(Size) -> Vec<Row>;

/// The cases by name, each runnable alone.
pub fn cases() -> Vec<(&'static str, Case)> {
    vec![
        ("stiff furnace", stiff_furnace),
        ("scales", scales),
        ("bins", bins),
        ("point light near a wall", light_near_wall),
        ("grazing angles", grazing),
        ("coincident and degenerate faces", bad_faces),
        ("pulses and gates", super::sensor_cases::pulses_and_gates),
        ("sensor extremes", super::sensor_cases::sensor_extremes),
    ]
}

/// Every case.
pub fn run_all(size: Size) -> Vec<Row> {
    cases().into_iter().flat_map(|(_, f)| f(size)).collect()
}

// ---------------------------------------------------------------------------------------
// Helpers.

/// Render `scene` at `w x h`, `spp` samples in the progressive passes of `tprf render`.
fn render(
    scene: Scene,
    w: usize,
    h: usize,
    axis: TimeAxis,
    spp: u64,
    settings: RenderSettings,
    bounces_separate: u32,
) -> TprfFilm {
    let renderer = Renderer::new(Arc::new(scene), settings);
    let mut film = TprfFilm::new(FilmLayout {
        width: w,
        height: h,
        axis,
        bounces_separate,
    })
    .expect("stability films are small");
    progressive::render(&renderer, &mut film, &Schedule::spp(spp), |_, _| {
        std::ops::ControlFlow::Continue(())
    });
    film
}

fn non_finite(film: &TprfFilm) -> u64 {
    film.cube_f64().iter().filter(|v| !v.is_finite()).count() as u64
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Standard error of the mean of `v` (independent values).
fn std_error(v: &[f64]) -> f64 {
    let m = mean(v);
    let n = v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0) / n).sqrt()
}

/// Energy-weighted mean of bin centres, seconds.
fn mean_arrival_s(tprf: &[f64], axis: &TimeAxis) -> f64 {
    let total: f64 = tprf.iter().sum();
    tprf.iter()
        .enumerate()
        .map(|(b, v)| v * axis.bin_center_s(b))
        .sum::<f64>()
        / total
}

/// Per-pixel TPRFs of a film.
fn pixels(film: &TprfFilm) -> Vec<Vec<f64>> {
    let l = film.layout();
    (0..l.height)
        .flat_map(|y| (0..l.width).map(move |x| (x, y)))
        .map(|(x, y)| film.pixel_tprf(x, y))
        .collect()
}

fn triangle_attrs(material: u32) -> TriangleAttrs {
    TriangleAttrs {
        normals: None,
        uv: [Vec2::ZERO; 3],
        material,
    }
}

// ---------------------------------------------------------------------------------------
// Stiff furnaces.

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

// ---------------------------------------------------------------------------------------
// Scales.

/// Relative standard error of an image mean from per-pixel footprint spreads.
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

// ---------------------------------------------------------------------------------------
// Bins.

/// One bin and 100 000 bins over the same window with the same paths; 10^8 samples into
/// one bin.
pub fn bins(size: Size) -> Vec<Row> {
    let mut rows = Vec::new();
    let f = Furnace::point(1.0, 0.5, 1.0);
    let (side, spp) = (size.pick(4, 8), size.pick(64, 256));
    let end_s = 30.0 / C_M_PER_S;
    let settings = RenderSettings {
        seed: 31,
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
        check: Check::Within {
            expected: e_ref,
            tolerance: 5.0 * std_error(&totals) + 3e-3 * e_ref,
        },
        got: mean(&totals),
        non_finite: non_finite(&one),
        note: "renewal reference in the window (1 - 2^-20 of rho I/(pi R^2 (1-rho)))".into(),
    });
    let fine_totals = fine.steady();
    rows.push(Row {
        case: "T = 100 000: sum over bins vs T = 1".into(),
        setting: setting.clone(),
        check: Check::Within {
            expected: mean(&totals),
            tolerance: 1e-12 * mean(&totals),
        },
        got: mean(&fine_totals),
        non_finite: non_finite(&fine),
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
        check: Check::Within {
            expected: t_ref * 1e9,
            tolerance: (5.0 * std_error(&t_px) + 3e-3 * t_ref) * 1e9,
        },
        got: mean_arrival_s(&curve, &many_axis) * 1e9,
        non_finite: 0,
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

// ---------------------------------------------------------------------------------------
// A point light 1e-6 m from a wall.

/// A wall seen straight down from 1 m, a point light 1e-6 m above the centre of the
/// middle pixel. Every pixel's mean radiance has an exact footprint integral. The pixel
/// holding the light's foot is unbiased but its estimator has a relative variance per
/// sample of about `A / (8 pi d^2)` (A the footprint, d the distance): half the light
/// lands within ~d of the foot, which a uniform jitter over the pixel rarely finds. Its
/// error is bounded by Chebyshev: within 10 predicted standard errors with probability
/// 99 %. The other pixels converge normally.
pub fn light_near_wall(size: Size) -> Vec<Row> {
    let mut rows = Vec::new();
    let d = 1e-6;
    let n_px = size.pick(9, 15);
    let spp = size.pick(256, 4096);
    let plane = Plane {
        camera_height_m: 1.0,
        light_height_m: d,
        rho: 0.5,
        intensity_w_per_sr: 1.0,
        half_m: 1.0,
        fov_deg: 2.0,
    };
    let axis = TimeAxis::new(0.9 / C_M_PER_S, 0.2 / C_M_PER_S, 2).expect("axis");
    let film = render(
        plane.scene(),
        n_px,
        n_px,
        axis,
        spp,
        RenderSettings {
            seed: 3,
            ..RenderSettings::default()
        },
        0,
    );
    let bad = non_finite(&film);
    let steady = film.steady();
    let c = n_px / 2;
    let setting = format!("{n_px}x{n_px} px, {spp} spp, d = 1e-6 m, footprint 1 m away");
    let (mut want, mut var, mut got) = (0.0, 0.0, 0.0);
    for y in 0..n_px {
        for x in 0..n_px {
            if (x, y) == (c, c) {
                continue;
            }
            let m = plane.pixel_moments(x, y, n_px, n_px);
            want += m.mean;
            var += m.sd * m.sd / spp as f64;
            got += steady[y * n_px + x];
        }
    }
    rows.push(Row {
        case: "light 1e-6 m from a wall: all pixels but the foot's".into(),
        setting: setting.clone(),
        check: Check::Within {
            expected: want,
            tolerance: 5.0 * var.sqrt() + 1e-5 * want,
        },
        got,
        non_finite: bad,
        note: "sum of the exact footprint integrals, 5 standard errors".into(),
    });
    let m = plane.pixel_moments(c, c, n_px, n_px);
    let rect: Rect = plane.footprint(
        c as f64,
        c as f64 + 1.0,
        c as f64,
        c as f64 + 1.0,
        n_px,
        n_px,
    );
    let se = m.sd / (spp as f64).sqrt();
    rows.push(Row {
        case: "light 1e-6 m from a wall: the foot's pixel".into(),
        setting,
        check: Check::Within {
            expected: m.mean,
            tolerance: 10.0 * se,
        },
        got: steady[c * n_px + c],
        non_finite: bad,
        note: format!(
            "unbiased, finite; relative sd per sample {:.0} (A/(8 pi d^2) = {:.0}, A = {:.2e} \
             m^2): error bounded by 10 predicted standard errors (Chebyshev, 99 %)",
            m.sd / m.mean,
            (rect.area() / (8.0 * std::f64::consts::PI * d * d)).sqrt(),
            rect.area()
        ),
    });
    rows
}

// ---------------------------------------------------------------------------------------
// Grazing angles.

/// Mean over pixel `(x, y)` of `g(direction)` for a pinhole camera: 8 x 8 Gauss-Legendre
/// points over the pixel (a smooth integrand), with the camera's own convention
/// `dir = world_from_camera (sx, sy, -1)`, `sx, sy` linear in the pixel coordinates.
fn pixel_quadrature(
    cam: &Camera,
    x: usize,
    y: usize,
    w: usize,
    h: usize,
    g: &dyn Fn([f64; 3], [f64; 3]) -> f64,
) -> (f64, f64) {
    let (nodes, weights) = gauss_legendre(8);
    let t = (0.5 * cam.yfov_rad as f64).tan();
    let aspect = w as f64 / h as f64;
    let m = cam.world_from_camera.matrix3;
    let col = |c: glam::Vec3A| [c.x as f64, c.y as f64, c.z as f64];
    let (cx, cy, cz) = (col(m.x_axis), col(m.y_axis), col(m.z_axis));
    let o = cam.position();
    let origin = [o.x as f64, o.y as f64, o.z as f64];
    let (mut s1, mut s2) = (0.0, 0.0);
    for (&a, &wa) in nodes.iter().zip(&weights) {
        for (&b, &wb) in nodes.iter().zip(&weights) {
            let px = x as f64 + 0.5 * (a + 1.0);
            let py = y as f64 + 0.5 * (b + 1.0);
            let sx = (2.0 * px / w as f64 - 1.0) * t * aspect;
            let sy = (1.0 - 2.0 * py / h as f64) * t;
            let mut d = [0.0; 3];
            for k in 0..3 {
                d[k] = cx[k] * sx + cy[k] * sy - cz[k];
            }
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let d = d.map(|v| v / len);
            let v = g(origin, d);
            let wt = 0.25 * wa * wb;
            s1 += wt * v;
            s2 += wt * v * v;
        }
    }
    (s1, (s2 - s1 * s1).max(0.0))
}

/// A Lambertian plane z = 0 lit by a point light `light` of intensity `i`, seen by
/// `cam`: single scattering only. Returns the rendered and the exact image means and the
/// standard error.
fn plane_case(
    cam: Camera,
    light: [f64; 3],
    i: f64,
    rho: f64,
    n: usize,
    spp: u64,
    extra: impl Fn(&mut Scene),
) -> (f64, f64, f64, u64) {
    let half = 50.0f32;
    let mut scene = Plane {
        camera_height_m: 1.0,
        light_height_m: 1.0,
        rho,
        intensity_w_per_sr: i,
        half_m: half as f64,
        fov_deg: 10.0,
    }
    .scene();
    scene.camera = cam;
    scene.lights[0].position = Vec3::new(light[0] as f32, light[1] as f32, light[2] as f32);
    extra(&mut scene);
    let axis = TimeAxis::new(0.0, 2000.0 / C_M_PER_S, 1).expect("axis");
    let film = render(
        scene,
        n,
        n,
        axis,
        spp,
        RenderSettings {
            seed: 11,
            ..RenderSettings::default()
        },
        0,
    );
    let radiance = |o: [f64; 3], d: [f64; 3]| -> f64 {
        if !(d[2] < 0.0) {
            return 0.0;
        }
        let t = -o[2] / d[2];
        let p = [o[0] + t * d[0], o[1] + t * d[1], 0.0];
        if p[0].abs() > half as f64 || p[1].abs() > half as f64 {
            return 0.0;
        }
        let v = [light[0] - p[0], light[1] - p[1], light[2]];
        let r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        rho / std::f64::consts::PI * i * (light[2] / r2.sqrt()) / r2
    };
    let (mut want, mut var) = (0.0, 0.0);
    for y in 0..n {
        for x in 0..n {
            let (m, v) = pixel_quadrature(&cam, x, y, n, n, &radiance);
            want += m;
            var += v / spp as f64;
        }
    }
    let k = (n * n) as f64;
    (
        mean(&film.steady()),
        want / k,
        var.sqrt() / k,
        non_finite(&film),
    )
}

/// Light grazing a plane (0.57 degrees above it at the image centre) and a view grazing
/// it (3 to 7 degrees) with the light at the camera.
pub fn grazing(size: Size) -> Vec<Row> {
    let (n, spp) = (size.pick(8, 24), size.pick(32, 128));
    let mut rows = Vec::new();
    let down = Camera::look_at(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO, 10f32.to_radians());
    let (got, want, se, bad) = plane_case(down, [-20.0, 0.0, 0.2], 100.0, 0.5, n, spp, |_| {});
    rows.push(Row {
        case: "grazing light (0.57 deg above the plane)".into(),
        setting: format!("{n}x{n} px, {spp} spp, camera 1 m above, looking down"),
        check: Check::Within {
            expected: want,
            tolerance: 5.0 * se + 1e-4 * want,
        },
        got,
        non_finite: bad,
        note: "rho I cos / (pi r^2) over each pixel (8x8 Gauss-Legendre); self-shadowing \
               shadow rays would darken it"
            .into(),
    });
    let eye = Vec3::new(0.0, 0.0, 0.1);
    let target = eye + Vec3::new(1.0, 0.0, -(5f32.to_radians().tan()));
    let grazing_cam = Camera::look_at(eye, target, 4f32.to_radians());
    let (got, want, se, bad) = plane_case(grazing_cam, [0.0, 0.0, 0.1], 1.0, 0.5, n, spp, |_| {});
    rows.push(Row {
        case: "grazing view (3 to 7 deg), light at the camera".into(),
        setting: format!("{n}x{n} px, {spp} spp, camera 0.1 m above"),
        check: Check::Within {
            expected: want,
            tolerance: 5.0 * se + 1e-4 * want,
        },
        got,
        non_finite: bad,
        note: "single-bounce formula over each pixel's rays (8x8 Gauss-Legendre)".into(),
    });
    rows
}

// ---------------------------------------------------------------------------------------
// Coincident faces and degenerate triangles.

/// The lit plane with its faces doubled (same and opposite winding), and with
/// degenerate triangles (repeated vertices, collinear, a cross product that underflows,
/// one at the light) in front of the camera: the exact plane answer in every case.
pub fn bad_faces(size: Size) -> Vec<Row> {
    let (n, spp) = (size.pick(8, 24), size.pick(32, 128));
    let down = Camera::look_at(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, 40f32.to_radians());
    let light = [0.0, 0.0, 2.0];
    let mut rows = Vec::new();
    type Edit = fn(&mut Scene);
    let variants: [(&str, Edit); 3] = [
        ("coincident faces (plane doubled, same winding)", |s| {
            let t = s.triangles.clone();
            for tri in t {
                s.triangles.push(tri);
                s.attrs.push(triangle_attrs(0));
            }
        }),
        ("coincident faces (plane doubled, opposite winding)", |s| {
            let t = s.triangles.clone();
            for tri in t {
                s.triangles.push(Triangle {
                    p: [tri.p[0], tri.p[2], tri.p[1]],
                });
                s.attrs.push(triangle_attrs(0));
            }
        }),
        ("degenerate triangles in view and at the light", |s| {
            let v = Vec3::new;
            let tiny = 1e-25f32;
            let tris = [
                // Repeated vertex.
                [v(-0.3, -0.3, 1.0), v(-0.3, -0.3, 1.0), v(0.3, 0.3, 1.0)],
                // Collinear, across the view.
                [v(-1.0, 0.0, 1.0), v(0.0, 0.0, 1.0), v(1.0, 0.0, 1.0)],
                // A needle of area 1e-25 m^2, and a speck whose cross product underflows.
                [v(0.0, -1.0, 0.5), v(tiny, -1.0, 0.5), v(0.0, 1.0, 0.5)],
                [
                    v(0.1, 0.1, 0.5),
                    v(0.1 + tiny, 0.1, 0.5),
                    v(0.1, 0.1 + tiny, 0.5),
                ],
                // All three at the light.
                [v(0.0, 0.0, 2.0); 3],
                // Collinear on the plane itself.
                [v(-0.5, 0.1, 0.0), v(0.0, 0.1, 0.0), v(0.5, 0.1, 0.0)],
            ];
            for p in tris {
                s.triangles.push(Triangle { p });
                s.attrs.push(triangle_attrs(0));
            }
        }),
    ];
    for (what, edit) in variants {
        let (got, want, se, bad) = plane_case(down, light, 3.0, 0.5, n, spp, edit);
        rows.push(Row {
            case: what.into(),
            setting: format!("{n}x{n} px, {spp} spp, lit plane"),
            check: Check::Within {
                expected: want,
                tolerance: 5.0 * se + 1e-4 * want,
            },
            got,
            non_finite: bad,
            note: "the single plane's exact answer".into(),
        });
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_judge_and_print() {
        let r = Row {
            case: "c".into(),
            setting: "s".into(),
            check: Check::Within {
                expected: 2.0,
                tolerance: 0.1,
            },
            got: 2.05,
            non_finite: 0,
            note: String::new(),
        };
        assert!(r.passed());
        assert!((r.relative_error().unwrap() - 0.025).abs() < 1e-12);
        let nan = Row {
            got: f64::NAN,
            ..r.clone()
        };
        assert!(!nan.passed());
        let inf = Row {
            non_finite: 1,
            ..r.clone()
        };
        assert!(!inf.passed());
        let t = markdown(&[r, nan]);
        assert!(t.contains("| pass |") && t.contains("| FAIL |"));
    }
}

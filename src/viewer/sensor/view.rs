//! The envelope editor's geometry as pure maths: the time range it shows (opened on the
//! film's window and the light pulse, zoomed and panned), where a gate needs light the
//! film does not have, the two ways out (a window covering the gates, gates fitted to
//! the window), and handles kept apart on screen.

use tprf_core::film::TimeAxis;
use tprf_core::sensor::{Exposure, Gate, Light, Point, Sensor, TimeOrigin};
use tprf_core::units::format_time;

/// The editor's time range, seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeView {
    pub lo_s: f64,
    pub hi_s: f64,
}

/// Narrowest and widest range the editor zooms to, seconds.
const MIN_SPAN_S: f64 = 1e-15;
const MAX_SPAN_S: f64 = 1.0;

impl TimeView {
    /// The range showing `[a, b]` with 4 % margins each side.
    pub fn around(a: f64, b: f64) -> TimeView {
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        let span = (b - a).max(MIN_SPAN_S * 10.0);
        let m = 0.04 * span;
        TimeView {
            lo_s: a - m,
            hi_s: a + span + m,
        }
    }

    /// What the editor opens on: the film's window and the main part of the light
    /// pulse (`pulse`, from [`main_span`]), not every gate.
    pub fn fit(axis: &TimeAxis, pulse: (f64, f64)) -> TimeView {
        TimeView::around(axis.t0_s.min(pulse.0), axis.end_s().max(pulse.1))
    }

    pub fn span_s(&self) -> f64 {
        self.hi_s - self.lo_s
    }

    /// Zoomed by `factor` (< 1: closer) about the time `about_s`, which stays where it
    /// is on screen.
    pub fn zoomed(self, about_s: f64, factor: f64) -> TimeView {
        if !(factor.is_finite() && factor > 0.0 && about_s.is_finite()) {
            return self;
        }
        let span = (self.span_s() * factor).clamp(MIN_SPAN_S, MAX_SPAN_S);
        let f = self.span_s() / span;
        let lo = about_s - (about_s - self.lo_s) / f;
        TimeView {
            lo_s: lo,
            hi_s: lo + span,
        }
    }

    /// Moved `by_s` later.
    pub fn panned(self, by_s: f64) -> TimeView {
        if !by_s.is_finite() {
            return self;
        }
        TimeView {
            lo_s: self.lo_s + by_s,
            hi_s: self.hi_s + by_s,
        }
    }
}

/// Where the pulse `light` holds its power: from the first to the last time its density
/// is at least 1e-3 of its peak (sampled over its support), `(t, t)` for a delta.
pub fn main_span(light: &Light) -> (f64, f64) {
    if let Some(t) = light.delta_time_s() {
        return (t, t);
    }
    let (lo, hi) = light.support_s();
    if !(hi > lo) {
        return (lo, hi);
    }
    let n = 2000;
    let ts: Vec<f64> = (0..=n)
        .map(|k| lo + (hi - lo) * k as f64 / n as f64)
        .collect();
    let d = light.sample(&ts);
    let peak = d.iter().fold(0.0f64, |m, &v| m.max(v));
    if !(peak > 0.0) {
        return (lo, hi);
    }
    let on = |v: &f64| *v >= 1e-3 * peak;
    let first = d.iter().position(on).unwrap_or(0);
    let last = d.iter().rposition(on).unwrap_or(n);
    let step = (hi - lo) / n as f64;
    (ts[first] - step, ts.get(last).copied().unwrap_or(hi) + step)
}

/// How much of the light a gate measures the film holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coverage {
    /// Every arrival time the gate can see through the pulse is inside the window.
    Inside,
    /// Some are outside: the gate's value misses that light.
    Partial,
    /// None are inside: the gate measures nothing of the film.
    Outside,
}

/// The arrival times (s) gate `g` sees through a pulse emitting over `pulse`:
/// `[gate start - pulse end, gate end - pulse start]`. `None` for a gate open at all
/// times (AMCW).
pub fn needed_arrivals(g: &Gate, pulse: (f64, f64)) -> Option<(f64, f64)> {
    let (a, b) = g.support_s()?;
    Some((a - pulse.1, b - pulse.0))
}

/// Whether the window `axis` holds the arrivals gate `g` needs through `pulse`. With
/// `starts_at_first_light` (an automatic window, which starts just before the first
/// arrival) nothing is missing before the window's start.
pub fn coverage(
    g: &Gate,
    pulse: (f64, f64),
    axis: &TimeAxis,
    starts_at_first_light: bool,
) -> Coverage {
    let Some((lo, hi)) = needed_arrivals(g, pulse) else {
        return Coverage::Inside;
    };
    // Light arrives at t >= 0: what a gate needs before that, no film lacks.
    let lo = if starts_at_first_light {
        lo.max(axis.t0_s)
    } else {
        lo.max(0.0)
    };
    let (t0, t1) = (axis.t0_s, axis.end_s());
    if hi <= lo {
        // Nothing after t = 0 to see.
        return Coverage::Inside;
    }
    if hi <= t0 || lo >= t1 {
        Coverage::Outside
    } else if lo >= t0 && hi <= t1 {
        Coverage::Inside
    } else {
        Coverage::Partial
    }
}

/// A window of bins `dt_s` wide that holds `axis` and the arrivals every gate needs
/// through `pulse` (from t = 0 on): `(t0_s, dt_s, bins)`, the bin width grown when more
/// than `max_bins` bins would be needed.
pub fn window_covering(
    gates: &[Gate],
    pulse: (f64, f64),
    axis: &TimeAxis,
    max_bins: usize,
) -> (f64, f64, usize) {
    let (mut lo, mut hi) = (axis.t0_s, axis.end_s());
    for (a, b) in gates.iter().filter_map(|g| needed_arrivals(g, pulse)) {
        if b > a.max(0.0) {
            lo = lo.min(a.max(0.0));
            hi = hi.max(b);
        }
    }
    let mut dt = axis.dt_s;
    let mut bins = ((hi - lo) / dt).ceil().max(1.0);
    if bins > max_bins as f64 {
        dt = (hi - lo) / max_bins as f64;
        bins = max_bins as f64;
    }
    (lo, dt, bins as usize)
}

/// The gate sequence `exposure` stretched or squeezed so its `count` gates tile the
/// part of the window `axis` whose light they see in full through a pulse emitting over
/// `pulse` (s): gates over `[t0 + pulse end, t1 + pulse start]`, each then needing only
/// arrivals inside the window ([`coverage`] `Inside`); from `t0 + pulse start` when the
/// window starts at the first light (nothing arrives before it). Where the pulse is as long as
/// the window, they tile the window. The kind, count and gains are kept; `None` for
/// AMCW gates, which have no extent.
pub fn gates_fitted(
    exposure: &Exposure,
    axis: &TimeAxis,
    pulse: (f64, f64),
    starts_at_first_light: bool,
) -> Option<Exposure> {
    // Offsets from the window's start: a gate over [a, b] sees arrivals [a - pulse end,
    // b - pulse start]; with the window at the first light nothing arrives before t0,
    // so a gate may open as soon as the pulse's start could bring light.
    let lead_s = if starts_at_first_light {
        pulse.0
    } else {
        pulse.1
    };
    let (from_s, to_s) = (lead_s, axis.end_s() - axis.t0_s + pulse.0);
    let (offset_s, span) = if to_s > from_s {
        (from_s, to_s - from_s)
    } else {
        (0.0, axis.end_s() - axis.t0_s)
    };
    let mut e = exposure.clone();
    match &mut e {
        Exposure::Box {
            origin,
            start_s,
            width_s,
            step_s,
            count,
            ..
        } => {
            let w = span / (*count).max(1) as f64;
            *origin = TimeOrigin::Window;
            *start_s = offset_s;
            *width_s = w;
            *step_s = None;
        }
        Exposure::Gaussian {
            origin,
            centre_s,
            fwhm_s,
            step_s,
            count,
            ..
        } => {
            let w = span / (*count).max(1) as f64;
            *origin = TimeOrigin::Window;
            *centre_s = offset_s + w / 2.0;
            *fwhm_s = w;
            *step_s = None;
        }
        Exposure::PiecewiseLinear {
            origin,
            points,
            step_s,
            count,
        } => {
            let w = span / (*count).max(1) as f64;
            let (a, b) = points
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                    (a.min(p.0), b.max(p.0))
                });
            let k = if b > a { w / (b - a) } else { 1.0 };
            *points = points
                .iter()
                .map(|p| Point(offset_s + (p.0 - a) * k, p.1))
                .collect();
            *origin = TimeOrigin::Window;
            *step_s = w;
        }
        Exposure::Tdc {
            origin,
            start_s,
            bin_width_s,
            bins,
            ..
        } => {
            // The TDC's bins tile what they see in full: its cycle is the window.
            *origin = TimeOrigin::Window;
            *start_s = offset_s;
            *bin_width_s = span / (*bins).max(1) as f64;
        }
        Exposure::Amcw { .. } => return None,
    }
    Some(e)
}

/// What the sensor tab does to a preset it opens on a film whose window its gates do
/// not fit: `sensor` with only the gates that see all their light in the window `axis`
/// (through its pulse; [`Coverage::Inside`]), or, when none does, its gates tiling what
/// the window lets them see ([`gates_fitted`]); and a sentence saying so. A fitted
/// sensor has no gate partly or wholly outside the window. `None` when every gate
/// already sees all its light in the window, or the sensor does not compile.
pub fn fitted_on_open(
    sensor: &Sensor,
    axis: &TimeAxis,
    starts_at_first_light: bool,
) -> Option<(Sensor, String)> {
    let light = sensor.light.compile().ok()?;
    let pulse = main_span(&light);
    let gates = sensor.exposure.gates(axis.t0_s).ok()?;
    let cover: Vec<Coverage> = gates
        .iter()
        .map(|g| coverage(g, pulse, axis, starts_at_first_light))
        .collect();
    let inside = |c: &Coverage| *c == Coverage::Inside;
    let n = cover.len();
    let window = format!("{} … {}", format_time(axis.t0_s), format_time(axis.end_s()));
    let name = if sensor.name.is_empty() {
        "the sensor".to_string()
    } else {
        format!("the {} preset", sensor.name)
    };
    let range = |a: usize, b: usize| {
        if a == b {
            a.to_string()
        } else {
            format!("{a}–{b}")
        }
    };
    let mut fitted = sensor.clone();
    let note = match (
        cover.iter().position(inside),
        cover.iter().rposition(inside),
    ) {
        (Some(0), Some(last)) if last + 1 == n => {
            // A TDC whose whole cycle sees only the window's first half: the light after
            // it (the targets behind fog) would never be histogrammed.
            let seen_to_s = gates
                .iter()
                .filter_map(|g| needed_arrivals(g, pulse))
                .fold(f64::NEG_INFINITY, |a, (_, b)| a.max(b));
            let half_s = axis.t0_s + 0.5 * (axis.end_s() - axis.t0_s);
            if !matches!(sensor.exposure, Exposure::Tdc { .. }) || seen_to_s >= half_s {
                return None;
            }
            fitted.exposure = gates_fitted(&sensor.exposure, axis, pulse, starts_at_first_light)?;
            format!(
                "Fitted {name} to the rendered window {window}: its {n} TDC bins saw only \
                 its light up to {}, so they now tile it (bins of {}).",
                format_time(seen_to_s),
                format_time(
                    fitted
                        .exposure
                        .gates(axis.t0_s)
                        .ok()?
                        .first()?
                        .support_s()
                        .map_or(0.0, |(a, b)| b - a)
                )
            )
        }
        (Some(first), Some(last)) => {
            fitted.exposure = sensor
                .exposure
                .subsequence(first as u64, (last - first + 1) as u64)?;
            let partial: Vec<usize> = (0..n).filter(|&k| cover[k] == Coverage::Partial).collect();
            let partly = match (partial.first(), partial.last()) {
                (Some(&a), Some(&b)) => format!(
                    "; gates {} would see only part of their light (a longer window would hold it)",
                    range(a, b)
                ),
                _ => String::new(),
            };
            format!(
                "Fitted {name} to the rendered window {window}: its gates {} of {n} see all \
                 their light in it, and are kept as gates 0–{}{partly}.",
                range(first, last),
                last - first
            )
        }
        _ => {
            fitted.exposure = gates_fitted(&sensor.exposure, axis, pulse, starts_at_first_light)?;
            format!(
                "Fitted {name} to the rendered window {window}: none of its {n} gates saw \
                 all their light in it, so they now tile what it holds."
            )
        }
    };
    // Derived outputs the new gates cannot give (AMCW depth needs its phases) go.
    if let Ok(g) = fitted.exposure.gates(axis.t0_s)
        && fitted.derived.validate(&fitted.exposure, &g).is_err()
    {
        fitted.derived = Default::default();
    }
    Some((fitted, note))
}

/// The gates of `sensor` that see nothing of the window `axis` (through its pulse), as
/// a sentence for a sensor the user edited and the window then changed; `None` when
/// every gate sees some of it.
pub fn gates_outside(
    sensor: &Sensor,
    axis: &TimeAxis,
    starts_at_first_light: bool,
) -> Option<String> {
    let pulse = main_span(&sensor.light.compile().ok()?);
    let gates = sensor.exposure.gates(axis.t0_s).ok()?;
    let out: Vec<usize> = gates
        .iter()
        .enumerate()
        .filter(|(_, g)| coverage(g, pulse, axis, starts_at_first_light) == Coverage::Outside)
        .map(|(k, _)| k)
        .collect();
    let (first, last) = (out.first()?, out.last()?);
    Some(format!(
        "The rendered window is now {} … {}: your gates are kept, and {} of {} ({}) see nothing of it.",
        format_time(axis.t0_s),
        format_time(axis.end_s()),
        out.len(),
        gates.len(),
        if first == last {
            format!("gate {first}")
        } else {
            format!("gates {first}–{last}")
        }
    ))
}

/// Screen positions moved apart so no two are closer than `min_px`: each one too near
/// an earlier one steps down by `min_px` until it is clear.
pub fn declutter(points: &mut [(f32, f32)], min_px: f32) {
    for i in 1..points.len() {
        for _ in 0..points.len() {
            let clash = points[..i].iter().any(|p| {
                let (dx, dy) = (p.0 - points[i].0, p.1 - points[i].1);
                (dx * dx + dy * dy).sqrt() < min_px
            });
            if !clash {
                break;
            }
            points[i].1 += min_px;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tprf_core::sensor::{LightPulse, Sensor, SensorModel};

    /// The Cornell box's window.
    fn axis() -> TimeAxis {
        TimeAxis::new(3.5e-9, 50e-12, 256).unwrap()
    }

    /// The LiDAR preset's pulse (FWHM 2 ns at 5 ns) and 256 gates over 256 ns: the
    /// editor opens on the window and the pulse, not on 0-260 ns.
    #[test]
    fn the_editor_opens_on_the_window_and_the_pulse() {
        let axis = axis();
        let lidar = Sensor::builtin("lidar").unwrap();
        let model = SensorModel::new(lidar, axis).unwrap();
        let pulse = main_span(model.light());
        // A Gaussian above 1e-3 of its peak: +- sqrt(2 ln 1000) = 3.717 sigma, with
        // sigma = FWHM / 2.3548.
        let half = (2.0 * 1000f64.ln()).sqrt() * 2e-9 / 2.3548;
        assert!((pulse.0 - (5e-9 - half)).abs() < 0.02e-9, "{pulse:?}");
        assert!((pulse.1 - (5e-9 + half)).abs() < 0.02e-9, "{pulse:?}");
        let v = TimeView::fit(&axis, pulse);
        assert!(v.lo_s <= pulse.0 && v.lo_s <= axis.t0_s);
        assert!(v.hi_s >= axis.end_s() && v.hi_s < 20e-9, "{v:?}");
        // Zoom keeps the time under the pointer in place; pan moves everything.
        let z = v.zoomed(10e-9, 0.5);
        assert!((z.span_s() - 0.5 * v.span_s()).abs() < 1e-18);
        let frac = |v: &TimeView| (10e-9 - v.lo_s) / v.span_s();
        assert!((frac(&z) - frac(&v)).abs() < 1e-9);
        let p = z.panned(1e-9);
        assert!((p.lo_s - z.lo_s - 1e-9).abs() < 1e-18 && (p.span_s() - z.span_s()).abs() < 1e-18);
        assert_eq!(z.zoomed(1.0, f64::NAN), z);
        assert!(v.zoomed(0.0, 1e-30).span_s() >= MIN_SPAN_S);
    }

    /// The gated preset on the Cornell box window: 8 gates of 3 ns from the window
    /// start and a 1 ns pulse. Gate k needs arrivals in [t0 + 3k - 1, t0 + 3k + 3] ns;
    /// the window is 12.8 ns long.
    #[test]
    fn gates_past_the_window_are_found_and_fixed() {
        let axis = axis();
        let gated = Sensor::builtin("gated").unwrap();
        let model = SensorModel::new(gated.clone(), axis).unwrap();
        let pulse = main_span(model.light());
        let cov: Vec<Coverage> = model
            .gates()
            .iter()
            .map(|g| coverage(g, pulse, &axis, false))
            .collect();
        use Coverage::*;
        // Gate 0 needs [t0 - 1, t0 + 3] ns: its first ns is before the window.
        assert_eq!(
            cov,
            vec![
                Partial, Inside, Inside, Inside, Partial, Outside, Outside, Outside
            ]
        );
        // Unless the window starts where light starts.
        assert_eq!(coverage(&model.gates()[0], pulse, &axis, true), Inside);
        // A window covering them: from t0 - 1 ns to t0 + 24 ns, same bins.
        let (t0, dt, bins) = window_covering(model.gates(), pulse, &axis, 16384);
        assert!((t0 - 2.5e-9).abs() < 0.01e-9, "{t0}");
        assert_eq!(dt, axis.dt_s);
        let covering = TimeAxis::new(t0, dt, bins).unwrap();
        assert!(
            model
                .gates()
                .iter()
                .all(|g| coverage(g, pulse, &covering, false) == Inside)
        );
        // Too many bins: wider bins instead.
        let (_, dt2, bins2) = window_covering(model.gates(), pulse, &axis, 100);
        assert_eq!(bins2, 100);
        assert!(dt2 > axis.dt_s);
        // Gates fitted to the window: 8 gates tiling what the window lets them see in
        // full through the pulse, [t0 + pulse end, t1 + pulse start]: every one inside.
        let fitted = gates_fitted(&gated.exposure, &axis, pulse, false).unwrap();
        let mut s = gated.clone();
        s.exposure = fitted;
        let m = SensorModel::new(s, axis).unwrap();
        let cov: Vec<Coverage> = m
            .gates()
            .iter()
            .map(|g| coverage(g, pulse, &axis, false))
            .collect();
        assert!(cov.iter().all(|c| *c == Inside), "{cov:?}");
        let (first, last) = (
            m.gates()[0].support_s().unwrap(),
            m.gates()[7].support_s().unwrap(),
        );
        assert!((first.0 - (axis.t0_s + pulse.1)).abs() < 1e-15, "{first:?}");
        assert!(
            (last.1 - (axis.end_s() + pulse.0)).abs() < 1e-15,
            "{last:?}"
        );
        // AMCW gates have no extent: always covered, nothing to fit.
        let amcw = Sensor::builtin("amcw").unwrap();
        assert!(gates_fitted(&amcw.exposure, &axis, pulse, false).is_none());
        let m = SensorModel::new(amcw, axis).unwrap();
        assert_eq!(coverage(&m.gates()[0], (0.0, 0.0), &axis, false), Inside);
        // A delta pulse is a point.
        let d = LightPulse::Delta {
            t_s: 1e-9,
            energy: 1.0,
        }
        .compile()
        .unwrap();
        assert_eq!(main_span(&d), (1e-9, 1e-9));
    }

    /// The LiDAR preset (1 ns box gates from the window start, a 2 ns FWHM pulse at
    /// 5 ns) on the Cornell box's 12.8 ns window: gate k sees arrivals from
    /// `t0 + k - 8.157` to `t0 + k + 1 - 1.843` ns (the pulse above 1e-3 of its peak
    /// spans 5 +- 3.157 ns), all of them inside the window for k = 9..=13: those are
    /// kept, and gates 1-20 (partly inside) said. A window starting at the first light
    /// has nothing before t0: gates 0-13 see all their light. The gated preset's 8
    /// gates, all seeing a 40 ns window, are left alone; every fitted sensor's gates
    /// see all their light in the window.
    #[test]
    fn a_preset_opens_fitted_to_the_window() {
        let axis = axis();
        let lidar = Sensor::builtin("lidar").unwrap();
        let inside_all = |s: &Sensor, first_light: bool| {
            let m = SensorModel::new(s.clone(), axis).unwrap();
            let pulse = main_span(m.light());
            m.gates()
                .iter()
                .all(|g| coverage(g, pulse, &axis, first_light) == Coverage::Inside)
        };
        let (fitted, note) = fitted_on_open(&lidar, &axis, false).expect("fitted");
        let Exposure::Box { start_s, count, .. } = fitted.exposure else {
            panic!("{:?}", fitted.exposure)
        };
        assert_eq!(count, 5);
        assert!((start_s - 9e-9).abs() < 1e-18, "{start_s}");
        assert!(note.contains("gates 9–13 of 256"), "{note}");
        assert!(note.contains("gates 1–20 would see only part"), "{note}");
        assert!(inside_all(&fitted, false));
        let (fitted, _) = fitted_on_open(&lidar, &axis, true).expect("fitted");
        assert_eq!(fitted.exposure.count(), 14);
        assert_eq!(
            fitted.exposure.subsequence(0, 1),
            lidar.exposure.subsequence(0, 1)
        );
        assert!(inside_all(&fitted, true));
        let wide = TimeAxis::new(0.0, 0.5e-9, 80).unwrap();
        assert!(fitted_on_open(&Sensor::builtin("gated").unwrap(), &wide, false).is_none());
        // Gates that all miss the window tile what it holds instead.
        let mut late = Sensor::builtin("gated").unwrap();
        late.exposure = late.exposure.subsequence(0, 8).unwrap();
        if let Exposure::Box { start_s, .. } = &mut late.exposure {
            *start_s = 500e-9;
        }
        let (fitted, note) = fitted_on_open(&late, &axis, false).expect("fitted");
        let pulse = main_span(&late.light.compile().unwrap());
        assert_eq!(
            Some(fitted.exposure.clone()),
            gates_fitted(&late.exposure, &axis, pulse, false)
        );
        assert!(note.contains("none of its 8 gates"), "{note}");
        assert!(inside_all(&fitted, false));
    }

    /// The SPAD preset's TDC (512 bins of 100 ps from the window's start - 2 ns: a
    /// 51.2 ns cycle) on `builtin:fog`'s window out to 96 m (640 ns): every bin sees the
    /// window, but only its first 49 ns, so the bins are stretched to tile it (1.25 ns
    /// each). On an 80 ns window the cycle sees more than its first half: left alone.
    #[test]
    fn a_tdc_cycle_short_of_the_window_is_stretched_over_it() {
        let spad = Sensor::builtin("spad").unwrap();
        let fog = TimeAxis::new(0.0, 2.5e-9, 256).unwrap();
        let (fitted, note) = fitted_on_open(&spad, &fog, true).expect("fitted");
        let Exposure::Tdc {
            bin_width_s, bins, ..
        } = fitted.exposure
        else {
            panic!("{:?}", fitted.exposure)
        };
        assert_eq!(bins, 512);
        assert!((bin_width_s - 1.25e-9).abs() < 1e-21, "{bin_width_s}");
        assert!(note.contains("512 TDC bins saw only"), "{note}");
        let short = TimeAxis::new(0.0, 0.5e-9, 160).unwrap();
        assert!(fitted_on_open(&spad, &short, true).is_none());
    }

    #[test]
    fn handles_on_one_spot_are_spread_apart() {
        let mut p = vec![(100.0, 50.0), (100.0, 50.0), (104.0, 52.0), (300.0, 50.0)];
        declutter(&mut p, 12.0);
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                let d = ((p[i].0 - p[j].0).powi(2) + (p[i].1 - p[j].1).powi(2)).sqrt();
                assert!(d >= 12.0, "{i} and {j}: {p:?}");
            }
        }
        // One far away is left where it is.
        assert_eq!(p[3], (300.0, 50.0));
        assert_eq!(p[0], (100.0, 50.0));
    }
}

//! The envelope editor's handles as pure maths: where each handle of a sensor sits on
//! the editor (time in s, height on its 0..1 scale) and what dragging one to a point
//! changes. No drawing here; the editor turns these into dots and drags.

use tprf_core::film::TimeAxis;
use tprf_core::sensor::{Exposure, LightPulse, Point, Sensor, TimeOrigin};

/// A point of an envelope the user can drag on the editor plot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Handle {
    /// The pulse's time (delta time, centre, onset or start).
    LightTime,
    /// The pulse's width (FWHM, width, decay or fall time).
    LightWidth,
    /// Knot `k` of a piecewise-linear pulse.
    LightKnot(usize),
    /// Gate 0's time (start or centre).
    GateTime,
    /// Gate 0's width.
    GateWidth,
    /// Gate 1's time: the step between gates.
    GateStep,
    /// Knot `k` of a piecewise-linear gate.
    GateKnot(usize),
}

impl Handle {
    /// What the handle is and where it stands now: "Light centre: 5.000 ns".
    pub(super) fn describe(self, sensor: &Sensor, axis: &TimeAxis) -> String {
        let name = match self {
            Handle::LightTime => "Light time (centre, onset or start)".to_string(),
            Handle::LightWidth => "Light width".to_string(),
            Handle::LightKnot(k) => format!("Light knot {k}"),
            Handle::GateTime => "gate 0's time (start or centre)".to_string(),
            Handle::GateWidth => "gate width".to_string(),
            Handle::GateStep => "gate 1: the step between gates".to_string(),
            Handle::GateKnot(k) => format!("gate knot {k}"),
        };
        match handles(sensor, axis).into_iter().find(|h| h.handle == self) {
            Some(h) => format!("{name}: at {:.4} ns", h.t_s * 1e9),
            None => name,
        }
    }
}

/// A handle where it is drawn: time (s) and height on the editor's 0..1 scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct HandlePos {
    pub(super) handle: Handle,
    pub(super) t_s: f64,
    pub(super) y: f64,
}

/// Absolute time of a gate-sequence time `t` (gates may count from the window start).
fn gate_abs_s(origin: TimeOrigin, t_s: f64, axis: &TimeAxis) -> f64 {
    match origin {
        TimeOrigin::Pulse => t_s,
        TimeOrigin::Window => t_s + axis.t0_s,
    }
}

/// The largest knot value (1 when none is positive): knots are drawn over it.
fn knot_scale(points: &[Point]) -> f64 {
    let m = points.iter().fold(0.0f64, |m, p| m.max(p.1));
    if m > 0.0 { m } else { 1.0 }
}

/// The handles of `sensor` on the editor (gate handles on gate 0 and gate 1).
pub(super) fn handles(sensor: &Sensor, axis: &TimeAxis) -> Vec<HandlePos> {
    let mut out = Vec::new();
    let mut push = |handle, t_s: f64, y: f64| out.push(HandlePos { handle, t_s, y });
    match &sensor.light {
        LightPulse::Delta { t_s, .. } => push(Handle::LightTime, *t_s, 1.0),
        LightPulse::Gaussian {
            centre_s, fwhm_s, ..
        } => {
            push(Handle::LightTime, *centre_s, 1.0);
            push(Handle::LightWidth, centre_s + fwhm_s / 2.0, 0.5);
        }
        LightPulse::Rect {
            start_s, width_s, ..
        } => {
            push(Handle::LightTime, *start_s, 1.0);
            push(Handle::LightWidth, start_s + width_s, 1.0);
        }
        LightPulse::Exponential { onset_s, tau_s, .. } => {
            push(Handle::LightTime, *onset_s, 1.0);
            push(Handle::LightWidth, onset_s + tau_s, (-1.0f64).exp());
        }
        LightPulse::LaserDiode {
            onset_s, fall_s, ..
        } => {
            push(Handle::LightTime, *onset_s, 0.0);
            push(Handle::LightWidth, onset_s + fall_s, 0.5);
        }
        LightPulse::Sinc2 {
            centre_s, width_s, ..
        } => {
            push(Handle::LightTime, *centre_s, 1.0);
            push(Handle::LightWidth, centre_s + width_s, 0.0);
        }
        LightPulse::PiecewiseLinear { points, .. } => {
            let s = knot_scale(points);
            for (k, p) in points.iter().enumerate() {
                push(Handle::LightKnot(k), p.0, p.1 / s);
            }
        }
    }
    match &sensor.exposure {
        Exposure::Box {
            origin,
            start_s,
            width_s,
            step_s,
            count,
            ..
        } => {
            let t0 = gate_abs_s(*origin, *start_s, axis);
            push(Handle::GateTime, t0, 0.9);
            push(Handle::GateWidth, t0 + width_s, 0.9);
            if *count > 1 {
                push(Handle::GateStep, t0 + step_s.unwrap_or(*width_s), 0.8);
            }
        }
        Exposure::Gaussian {
            origin,
            centre_s,
            fwhm_s,
            step_s,
            count,
            ..
        } => {
            let c = gate_abs_s(*origin, *centre_s, axis);
            push(Handle::GateTime, c, 0.9);
            push(Handle::GateWidth, c + fwhm_s / 2.0, 0.45);
            if *count > 1 {
                push(Handle::GateStep, c + step_s.unwrap_or(*fwhm_s), 0.8);
            }
        }
        Exposure::PiecewiseLinear { origin, points, .. } => {
            let s = knot_scale(points);
            for (k, p) in points.iter().enumerate() {
                push(
                    Handle::GateKnot(k),
                    gate_abs_s(*origin, p.0, axis),
                    0.9 * p.1 / s,
                );
            }
        }
        Exposure::Tdc {
            origin,
            start_s,
            bin_width_s,
            ..
        } => {
            let t0 = gate_abs_s(*origin, *start_s, axis);
            push(Handle::GateTime, t0, 0.9);
            push(Handle::GateWidth, t0 + bin_width_s, 0.9);
        }
        Exposure::Amcw { .. } => {}
    }
    out
}

/// Move `handle` to time `t_s` (and height `y` on the 0..1 scale, for knots). Widths
/// stay positive; knots keep their time order.
pub(super) fn drag_handle(sensor: &mut Sensor, handle: Handle, t_s: f64, y: f64, axis: &TimeAxis) {
    if !(t_s.is_finite() && y.is_finite()) {
        return;
    }
    let min_w = axis.dt_s * 1e-3;
    let y = y.clamp(0.0, 1.0);
    match (&mut sensor.light, handle) {
        (LightPulse::Delta { t_s: t, .. }, Handle::LightTime) => *t = t_s,
        (LightPulse::Gaussian { centre_s, .. }, Handle::LightTime) => *centre_s = t_s,
        (
            LightPulse::Gaussian {
                centre_s, fwhm_s, ..
            },
            Handle::LightWidth,
        ) => *fwhm_s = (2.0 * (t_s - *centre_s)).max(min_w),
        (LightPulse::Rect { start_s, .. }, Handle::LightTime) => *start_s = t_s,
        (
            LightPulse::Rect {
                start_s, width_s, ..
            },
            Handle::LightWidth,
        ) => *width_s = (t_s - *start_s).max(min_w),
        (LightPulse::Exponential { onset_s, .. }, Handle::LightTime) => *onset_s = t_s,
        (LightPulse::Exponential { onset_s, tau_s, .. }, Handle::LightWidth) => {
            *tau_s = (t_s - *onset_s).max(min_w)
        }
        (LightPulse::LaserDiode { onset_s, .. }, Handle::LightTime) => *onset_s = t_s,
        (
            LightPulse::LaserDiode {
                onset_s,
                rise_s,
                fall_s,
                ..
            },
            Handle::LightWidth,
        ) => *fall_s = (t_s - *onset_s).max(*rise_s + min_w),
        (LightPulse::Sinc2 { centre_s, .. }, Handle::LightTime) => *centre_s = t_s,
        (
            LightPulse::Sinc2 {
                centre_s, width_s, ..
            },
            Handle::LightWidth,
        ) => *width_s = (t_s - *centre_s).max(min_w),
        (LightPulse::PiecewiseLinear { points, .. }, Handle::LightKnot(k)) => {
            move_knot(points, k, t_s, y)
        }
        _ => {}
    }
    match (&mut sensor.exposure, handle) {
        (
            Exposure::Box {
                origin, start_s, ..
            },
            Handle::GateTime,
        ) => *start_s = t_s - gate_abs_s(*origin, 0.0, axis),
        (
            Exposure::Box {
                origin,
                start_s,
                width_s,
                ..
            },
            Handle::GateWidth,
        ) => *width_s = (t_s - gate_abs_s(*origin, *start_s, axis)).max(min_w),
        (
            Exposure::Box {
                origin,
                start_s,
                step_s,
                ..
            },
            Handle::GateStep,
        ) => *step_s = Some((t_s - gate_abs_s(*origin, *start_s, axis)).max(min_w)),
        (
            Exposure::Gaussian {
                origin, centre_s, ..
            },
            Handle::GateTime,
        ) => *centre_s = t_s - gate_abs_s(*origin, 0.0, axis),
        (
            Exposure::Gaussian {
                origin,
                centre_s,
                fwhm_s,
                ..
            },
            Handle::GateWidth,
        ) => *fwhm_s = (2.0 * (t_s - gate_abs_s(*origin, *centre_s, axis))).max(min_w),
        (
            Exposure::Gaussian {
                origin,
                centre_s,
                step_s,
                ..
            },
            Handle::GateStep,
        ) => *step_s = Some((t_s - gate_abs_s(*origin, *centre_s, axis)).max(min_w)),
        (
            Exposure::Tdc {
                origin, start_s, ..
            },
            Handle::GateTime,
        ) => *start_s = t_s - gate_abs_s(*origin, 0.0, axis),
        (
            Exposure::Tdc {
                origin,
                start_s,
                bin_width_s,
                ..
            },
            Handle::GateWidth,
        ) => *bin_width_s = (t_s - gate_abs_s(*origin, *start_s, axis)).max(min_w),
        (Exposure::PiecewiseLinear { origin, points, .. }, Handle::GateKnot(k)) => {
            let t = t_s - gate_abs_s(*origin, 0.0, axis);
            move_knot(points, k, t, y / 0.9)
        }
        _ => {}
    }
}

/// Knot `k` to `(t_s, y * scale)`, between its neighbours in time.
fn move_knot(points: &mut [Point], k: usize, t_s: f64, y: f64) {
    let scale = knot_scale(points);
    let lo = if k > 0 {
        points.get(k - 1).map_or(f64::NEG_INFINITY, |p| p.0)
    } else {
        f64::NEG_INFINITY
    };
    let hi = points.get(k + 1).map_or(f64::INFINITY, |p| p.0);
    if let Some(p) = points.get_mut(k) {
        p.0 = t_s.clamp(lo, hi);
        p.1 = (y.clamp(0.0, 1.0) * scale).max(0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::super::kinds::{exposure_of_kind, light_of_kind};
    use super::*;
    use tprf_core::sensor::SensorModel;

    fn axis() -> TimeAxis {
        TimeAxis::new(2e-9, 50e-12, 200).unwrap()
    }

    #[test]
    fn handles_move_what_they_show() {
        let axis = axis();
        let mut s = Sensor::new(
            LightPulse::Gaussian {
                centre_s: 1e-9,
                fwhm_s: 0.4e-9,
                energy: 1.0,
            },
            Exposure::Box {
                origin: TimeOrigin::Window,
                start_s: 1e-9,
                width_s: 0.5e-9,
                step_s: None,
                count: 4,
                gain: 1.0,
            },
        );
        let hs = handles(&s, &axis);
        let find = |h| hs.iter().find(|p| p.handle == h).unwrap().t_s;
        assert!((find(Handle::LightTime) - 1e-9).abs() < 1e-21);
        assert!((find(Handle::LightWidth) - 1.2e-9).abs() < 1e-21);
        // Window-relative gates are drawn at absolute times.
        assert!((find(Handle::GateTime) - 3e-9).abs() < 1e-21);
        assert!((find(Handle::GateWidth) - 3.5e-9).abs() < 1e-21);
        assert!((find(Handle::GateStep) - 3.5e-9).abs() < 1e-21);

        // Dragging a handle to a time puts the handle there.
        for (h, t) in [
            (Handle::LightTime, 0.5e-9),
            (Handle::LightWidth, 1.0e-9),
            (Handle::GateTime, 4e-9),
            (Handle::GateWidth, 4.3e-9),
            (Handle::GateStep, 4.6e-9),
        ] {
            drag_handle(&mut s, h, t, 0.5, &axis);
            let now = handles(&s, &axis)
                .into_iter()
                .find(|p| p.handle == h)
                .unwrap()
                .t_s;
            assert!((now - t).abs() < 1e-18, "{h:?}: {now} vs {t}");
        }
        // A width dragged past its start stays positive; NaN is ignored.
        drag_handle(&mut s, Handle::GateWidth, 0.0, 0.5, &axis);
        let Exposure::Box { width_s, .. } = s.exposure else {
            unreachable!()
        };
        assert!(width_s > 0.0);
        let before = s.clone();
        drag_handle(&mut s, Handle::LightTime, f64::NAN, 0.5, &axis);
        assert_eq!(s, before);
        // Every edit leaves a sensor the model accepts.
        SensorModel::new(s, axis).unwrap();
    }

    #[test]
    fn knots_keep_their_order() {
        let axis = axis();
        let mut s = Sensor::new(
            light_of_kind("piecewise_linear", 0.0, axis.dt_s),
            exposure_of_kind("box", &axis),
        );
        drag_handle(&mut s, Handle::LightKnot(1), 1.0, 0.7, &axis);
        let LightPulse::PiecewiseLinear { points, .. } = &s.light else {
            unreachable!()
        };
        assert!(points.windows(2).all(|w| w[0].0 <= w[1].0));
        SensorModel::new(s, axis).unwrap();
    }
}

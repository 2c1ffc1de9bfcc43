//! The envelope editor's handles as pure maths: where each handle of a sensor sits on
//! the editor (time in s, height on its 0..1 scale) and what dragging one to a point
//! changes. Which numbers have handles, and where, the sensor's own types say
//! ([`tprf_core::sensor::Field::handle`]); the knots of a free envelope are handles
//! too. No drawing here; the editor turns these into dots and drags.

use tprf_core::film::TimeAxis;
use tprf_core::sensor::{Field, HandleAt, Point, Sensor, TimeOrigin};

/// A point of an envelope the user can drag on the editor plot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Handle {
    /// The light's field of this key (its time, or its width).
    Light(&'static str),
    /// The gates' field of this key (gate 0's time or width, or gate 1's time: the
    /// step).
    Gate(&'static str),
    /// Knot `k` of a piecewise-linear pulse.
    LightKnot(usize),
    /// Knot `k` of a piecewise-linear gate.
    GateKnot(usize),
}

impl Handle {
    /// What the handle is and where it stands now, in seconds after the trigger (as
    /// the editor's axis and the form's fields show it): "Light centre: at 5.0000 ns".
    pub(super) fn describe(self, sensor: &Sensor, axis: &TimeAxis) -> String {
        let label = |fields: Vec<Field>, key: &str| {
            fields
                .into_iter()
                .find(|f| f.key == key)
                .map_or(key.to_string(), |f| f.label.to_string())
        };
        let name = match self {
            Handle::Light(key) => format!("Light {}", label(sensor.light.fields(), key)),
            Handle::Gate("step_s") => "gate 1: the step between gates".to_string(),
            Handle::Gate(key) => format!("gate 0's {}", label(sensor.exposure.fields(), key)),
            Handle::LightKnot(k) => format!("Light knot {k}"),
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

/// Where the gate sequence's times count from, in seconds after the trigger.
pub(super) fn origin_offset_s(sensor: &Sensor, axis: &TimeAxis) -> f64 {
    match sensor.exposure.origin() {
        TimeOrigin::Pulse => 0.0,
        TimeOrigin::Window => axis.t0_s,
    }
}

/// The largest knot value (1 when none is positive): knots are drawn over it.
fn knot_scale(points: &[Point]) -> f64 {
    let m = points.iter().fold(0.0f64, |m, p| m.max(p.1));
    if m > 0.0 { m } else { 1.0 }
}

/// Where the handles of `fields` stand: `offset_s` added to a time that counts from
/// the gates' origin (and to an extent's anchor, which does).
fn field_handles(
    fields: &[Field],
    offset_s: f64,
    handle: impl Fn(&'static str) -> Handle,
    out: &mut Vec<HandlePos>,
) {
    let at = |f: &Field| f.value + if f.from_origin { offset_s } else { 0.0 };
    for f in fields {
        let (t_s, y) = match f.handle {
            Some(HandleAt::Time { y }) => (at(f), y),
            Some(HandleAt::Extent { anchor, factor, y }) => {
                let Some(a) = fields.iter().find(|g| g.key == anchor) else {
                    continue;
                };
                (at(a) + factor * f.value, y)
            }
            None => continue,
        };
        out.push(HandlePos {
            handle: handle(f.key),
            t_s,
            y,
        });
    }
}

/// The handles of `sensor` on the editor (gate handles on gate 0 and gate 1).
pub(super) fn handles(sensor: &Sensor, axis: &TimeAxis) -> Vec<HandlePos> {
    let mut out = Vec::new();
    field_handles(&sensor.light.fields(), 0.0, Handle::Light, &mut out);
    if let Some(points) = sensor.light.knots() {
        let s = knot_scale(points);
        for (k, p) in points.iter().enumerate() {
            out.push(HandlePos {
                handle: Handle::LightKnot(k),
                t_s: p.0,
                y: p.1 / s,
            });
        }
    }
    let offset = origin_offset_s(sensor, axis);
    field_handles(&sensor.exposure.fields(), offset, Handle::Gate, &mut out);
    if let Some(points) = sensor.exposure.knots() {
        let s = knot_scale(points);
        for (k, p) in points.iter().enumerate() {
            out.push(HandlePos {
                handle: Handle::GateKnot(k),
                t_s: offset + p.0,
                y: 0.9 * p.1 / s,
            });
        }
    }
    out
}

/// The value field `f` of `fields` takes when its handle is dragged to `t_s`: the time
/// itself, or the extent from its anchor, at least `min_w` (and the field's minimum).
fn dragged_value(fields: &[Field], f: &Field, t_s: f64, offset_s: f64, min_w: f64) -> Option<f64> {
    let origin = |g: &Field| if g.from_origin { offset_s } else { 0.0 };
    match f.handle? {
        HandleAt::Time { .. } => Some(t_s - origin(f)),
        HandleAt::Extent { anchor, factor, .. } => {
            let a = fields.iter().find(|g| g.key == anchor)?;
            let w = (t_s - (a.value + origin(a))) / factor;
            Some(w.max(min_w).max(f.min))
        }
    }
}

/// Move `handle` to time `t_s` (and height `y` on the 0..1 scale, for knots). Widths
/// stay positive; knots keep their time order.
pub(super) fn drag_handle(sensor: &mut Sensor, handle: Handle, t_s: f64, y: f64, axis: &TimeAxis) {
    if !(t_s.is_finite() && y.is_finite()) {
        return;
    }
    let min_w = axis.dt_s * 1e-3;
    let y = y.clamp(0.0, 1.0);
    match handle {
        Handle::Light(key) => {
            let fields = sensor.light.fields();
            if let Some(f) = fields.iter().find(|f| f.key == key)
                && let Some(v) = dragged_value(&fields, f, t_s, 0.0, min_w)
            {
                sensor.light.set_field(key, v);
            }
        }
        Handle::Gate(key) => {
            let offset = origin_offset_s(sensor, axis);
            let fields = sensor.exposure.fields();
            if let Some(f) = fields.iter().find(|f| f.key == key)
                && let Some(v) = dragged_value(&fields, f, t_s, offset, min_w)
            {
                sensor.exposure.set_field(key, v);
            }
        }
        Handle::LightKnot(k) => {
            if let Some(points) = sensor.light.knots_mut() {
                move_knot(points, k, t_s, y);
            }
        }
        Handle::GateKnot(k) => {
            let offset = origin_offset_s(sensor, axis);
            if let Some(points) = sensor.exposure.knots_mut() {
                move_knot(points, k, t_s - offset, y / 0.9);
            }
        }
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
    use super::*;
    use tprf_core::sensor::{Exposure, LightPulse, SensorModel};

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
        assert!((find(Handle::Light("centre_s")) - 1e-9).abs() < 1e-21);
        // The FWHM's handle at the half maximum: centre + FWHM / 2.
        assert!((find(Handle::Light("fwhm_s")) - 1.2e-9).abs() < 1e-21);
        // Window-relative gates are drawn at absolute times.
        assert!((find(Handle::Gate("start_s")) - 3e-9).abs() < 1e-21);
        assert!((find(Handle::Gate("width_s")) - 3.5e-9).abs() < 1e-21);
        assert!((find(Handle::Gate("step_s")) - 3.5e-9).abs() < 1e-21);
        assert_eq!(hs.len(), 5);

        // Dragging a handle to a time puts the handle there.
        for (h, t) in [
            (Handle::Light("centre_s"), 0.5e-9),
            (Handle::Light("fwhm_s"), 1.0e-9),
            (Handle::Gate("start_s"), 4e-9),
            (Handle::Gate("width_s"), 4.3e-9),
            (Handle::Gate("step_s"), 4.6e-9),
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
        // Dragged to 4.6 ns, gate 1 starts there: a step of 0.6 ns from gate 0's 4 ns,
        // counted from the window start (2 ns) in the file.
        let Exposure::Box {
            start_s, step_s, ..
        } = s.exposure
        else {
            unreachable!()
        };
        assert!((start_s - 2e-9).abs() < 1e-18 && (step_s.unwrap() - 0.6e-9).abs() < 1e-18);
        drag_handle(&mut s, Handle::Gate("width_s"), 0.0, 0.5, &axis);
        let Exposure::Box { width_s, .. } = s.exposure else {
            unreachable!()
        };
        assert!(width_s > 0.0);
        let before = s.clone();
        drag_handle(&mut s, Handle::Light("centre_s"), f64::NAN, 0.5, &axis);
        assert_eq!(s, before);
        // Every edit leaves a sensor the model accepts.
        SensorModel::new(s, axis).unwrap();
    }

    #[test]
    fn knots_keep_their_order() {
        let axis = axis();
        let mut s = Sensor::new(
            LightPulse::of_kind("piecewise_linear", 0.0, 4.0 * axis.dt_s),
            Exposure::of_kind("box", axis.end_s() - axis.t0_s),
        );
        drag_handle(&mut s, Handle::LightKnot(1), 1.0, 0.7, &axis);
        let LightPulse::PiecewiseLinear { points, .. } = &s.light else {
            unreachable!()
        };
        assert!(points.windows(2).all(|w| w[0].0 <= w[1].0));
        SensorModel::new(s, axis).unwrap();
    }
}

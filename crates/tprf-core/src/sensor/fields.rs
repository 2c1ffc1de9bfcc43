//! The editable numbers of a sensor, described by its own types. For each parameter of
//! a light pulse ([`LightPulse::fields`]), a gate sequence ([`Exposure::fields`]), the
//! noise ([`Noise::fields`]) and a
//! SPAD ([`Spad::fields`]): its key in a sensor file, a short name, its unit and range,
//! whether a gate time counts from the sequence's origin, and where an envelope editor
//! draws a handle for it (and so what dragging the handle changes). A user interface
//! lists the fields and writes back through `set_field`: it mirrors no variant. Here
//! too: the kinds and their names ([`LIGHT_KINDS`], [`EXPOSURE_KINDS`]), a new pulse or
//! gate sequence of a kind sized for a time window, and the knots of the free
//! (piecewise-linear) envelopes.

use super::derived::{MAX_RETURNS, Returns};
use super::exposure::{Exposure, MAX_GATES, TimeOrigin};
use super::light::{LightPulse, MAX_LOBES};
use super::noise::Noise;
use super::spad::{MAX_CYCLES, Spad};
use super::values::Point;

/// What a number is, for showing and typing it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// A time or a duration, seconds.
    Time,
    /// An energy, joules.
    Energy,
    /// A whole number (gates, bins, side lobes, cycles).
    Count,
    /// A dimensionless number (gain, peak, modulation, a probability).
    Number,
    /// A frequency, hertz.
    Frequency,
    /// A rate, events per second.
    Rate,
    /// An angle, degrees.
    Degrees,
}

/// Where an envelope editor draws a field's handle (times in seconds after the trigger
/// once a gate field's origin is added; heights on the envelope's 0..1 scale).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HandleAt {
    /// At the field's own time (a pulse's centre, gate 0's start), at height `y`:
    /// dragging it sets the field to the time it is dragged to.
    Time { y: f64 },
    /// At `anchor + factor x value`: an extent from the time field `anchor` (a width
    /// at `factor` 1, a FWHM at 1/2, where the envelope is at half its peak), at height
    /// `y`: dragging it to `t` sets the field to `(t - anchor) / factor`.
    Extent {
        anchor: &'static str,
        factor: f64,
        y: f64,
    },
}

/// One editable number of a sensor part.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    /// Its key in a sensor file (`centre_s`, `count`).
    pub key: &'static str,
    /// Its name on screen (`centre`, `gates`).
    pub label: &'static str,
    /// What it means, in a sentence (empty when the label says it all).
    pub help: &'static str,
    pub quantity: Quantity,
    /// Its value now (a count as a whole number).
    pub value: f64,
    /// The range a user may set it in (the sensor's own checks may refuse more, with a
    /// message naming the field).
    pub min: f64,
    pub max: f64,
    /// A gate time counted from the sequence's origin ([`Exposure::origin`]: the
    /// window's start for [`TimeOrigin::Window`]), not from the trigger.
    pub from_origin: bool,
    /// Where an envelope editor draws its handle, if it has one.
    pub handle: Option<HandleAt>,
}

/// The largest time or duration a sensor holds, seconds ([`super::MAX_TIME_S`]).
const T: f64 = super::MAX_TIME_S;

impl Field {
    fn new(key: &'static str, label: &'static str, quantity: Quantity, value: f64) -> Field {
        let (min, max) = match quantity {
            Quantity::Time => (-T, T),
            Quantity::Energy => (0.0, 1e12),
            Quantity::Count => (1.0, MAX_GATES as f64),
            Quantity::Number => (0.0, 1e12),
            Quantity::Frequency => (1e-3, 1e12),
            Quantity::Rate => (0.0, 1e15),
            Quantity::Degrees => (-360.0, 360.0),
        };
        Field {
            key,
            label,
            help: "",
            quantity,
            value,
            min,
            max,
            from_origin: false,
            handle: None,
        }
    }

    /// A duration: a time from 0 up.
    fn duration(key: &'static str, label: &'static str, value: f64) -> Field {
        Field::new(key, label, Quantity::Time, value).range(0.0, T)
    }

    fn range(mut self, min: f64, max: f64) -> Field {
        self.min = min;
        self.max = max;
        self
    }

    fn help(mut self, help: &'static str) -> Field {
        self.help = help;
        self
    }

    fn at(mut self, y: f64) -> Field {
        self.handle = Some(HandleAt::Time { y });
        self
    }

    fn extent(mut self, anchor: &'static str, factor: f64, y: f64) -> Field {
        self.handle = Some(HandleAt::Extent { anchor, factor, y });
        self
    }

    fn timed_from_origin(mut self) -> Field {
        self.from_origin = true;
        self
    }
}

/// A count from a field's value: rounded, at least `min`.
fn whole(v: f64, min: u64) -> u64 {
    if v.is_finite() {
        (v.round().max(min as f64).min(u64::MAX as f64)) as u64
    } else {
        min
    }
}

fn energy(value: f64) -> Field {
    Field::new("energy", "energy", Quantity::Energy, value)
        .help("the pulse's energy, J (1 = the unit pulse the film was rendered for)")
}

/// Light kinds: (name in sensor files, label in a menu).
pub const LIGHT_KINDS: &[(&str, &str)] = &[
    ("delta", "delta"),
    ("gaussian", "Gaussian"),
    ("rect", "rectangular"),
    ("exponential", "exponential decay"),
    ("laser_diode", "laser diode"),
    ("sinc2", "sinc²"),
    ("piecewise_linear", "free (piecewise linear)"),
];

/// Gate kinds: (name in sensor files, label in a menu).
pub const EXPOSURE_KINDS: &[(&str, &str)] = &[
    ("box", "box gates"),
    ("gaussian", "Gaussian gates"),
    ("piecewise_linear", "free gates (piecewise linear)"),
    ("amcw", "AMCW sinusoids"),
    ("tdc", "TDC bins (SPAD)"),
];

/// The menu label of kind `key` in `table` (`LIGHT_KINDS`, `EXPOSURE_KINDS`); "?" for
/// an unknown kind.
pub fn kind_label(table: &[(&str, &'static str)], key: &str) -> &'static str {
    table
        .iter()
        .find(|(k, _)| *k == key)
        .map_or("?", |(_, l)| l)
}

impl LightPulse {
    /// A new pulse of `kind` (a name of [`LIGHT_KINDS`]; anything else a delta) leaving
    /// at `at_s`, its width `width_s` (FWHM, duration, decay time, first zero), energy 1.
    pub fn of_kind(kind: &str, at_s: f64, width_s: f64) -> LightPulse {
        let w = width_s;
        match kind {
            "gaussian" => LightPulse::Gaussian {
                centre_s: at_s,
                fwhm_s: w,
                energy: 1.0,
            },
            "rect" => LightPulse::Rect {
                start_s: at_s,
                width_s: w,
                energy: 1.0,
            },
            "exponential" => LightPulse::Exponential {
                onset_s: at_s,
                tau_s: w,
                energy: 1.0,
            },
            "laser_diode" => LightPulse::LaserDiode {
                onset_s: at_s,
                rise_s: w / 4.0,
                fall_s: w,
                energy: 1.0,
            },
            "sinc2" => LightPulse::Sinc2 {
                centre_s: at_s,
                width_s: w,
                lobes: 8,
                energy: 1.0,
            },
            "piecewise_linear" => LightPulse::PiecewiseLinear {
                points: vec![
                    Point(at_s, 0.0),
                    Point(at_s + w / 2.0, 1.0),
                    Point(at_s + 2.0 * w, 0.3),
                    Point(at_s + 4.0 * w, 0.0),
                ],
                energy: 1.0,
            },
            _ => LightPulse::Delta {
                t_s: at_s,
                energy: 1.0,
            },
        }
    }

    /// The pulse's editable numbers, in the order a form shows them.
    pub fn fields(&self) -> Vec<Field> {
        use Quantity::Time;
        match self {
            LightPulse::Delta { t_s, energy: e } => {
                vec![Field::new("t_s", "time", Time, *t_s).at(1.0), energy(*e)]
            }
            LightPulse::Gaussian {
                centre_s,
                fwhm_s,
                energy: e,
            } => vec![
                Field::new("centre_s", "centre", Time, *centre_s).at(1.0),
                Field::duration("fwhm_s", "FWHM", *fwhm_s)
                    .help("full width at half maximum")
                    .extent("centre_s", 0.5, 0.5),
                energy(*e),
            ],
            LightPulse::Rect {
                start_s,
                width_s,
                energy: e,
            } => vec![
                Field::new("start_s", "start", Time, *start_s).at(1.0),
                Field::duration("width_s", "width", *width_s).extent("start_s", 1.0, 1.0),
                energy(*e),
            ],
            LightPulse::Exponential {
                onset_s,
                tau_s,
                energy: e,
            } => vec![
                Field::new("onset_s", "onset", Time, *onset_s).at(1.0),
                Field::duration("tau_s", "decay τ", *tau_s)
                    .help("time constant of the decay: the power falls to 1/e after it")
                    .extent("onset_s", 1.0, (-1.0f64).exp()),
                energy(*e),
            ],
            LightPulse::LaserDiode {
                onset_s,
                rise_s,
                fall_s,
                energy: e,
            } => vec![
                Field::new("onset_s", "onset", Time, *onset_s).at(0.0),
                Field::duration("rise_s", "rise", *rise_s)
                    .help("time constant of the rise (less than the fall's)"),
                Field::duration("fall_s", "fall", *fall_s)
                    .range(*rise_s, T)
                    .help("time constant of the decay (more than the rise's)")
                    .extent("onset_s", 1.0, 0.5),
                energy(*e),
            ],
            LightPulse::Sinc2 {
                centre_s,
                width_s,
                lobes,
                energy: e,
            } => vec![
                Field::new("centre_s", "centre", Time, *centre_s).at(1.0),
                Field::duration("width_s", "first zero", *width_s)
                    .help("time from the centre to the first zero")
                    .extent("centre_s", 1.0, 0.0),
                Field::new("lobes", "side lobes", Quantity::Count, f64::from(*lobes))
                    .range(0.0, f64::from(MAX_LOBES))
                    .help("side lobes kept on each side"),
                energy(*e),
            ],
            LightPulse::PiecewiseLinear { energy: e, .. } => vec![energy(*e)],
        }
    }

    /// Set the field `key` (as [`Self::fields`] names it) to `value`; false when this
    /// kind has no such field.
    pub fn set_field(&mut self, key: &str, value: f64) -> bool {
        let slot: &mut f64 = match (self, key) {
            (LightPulse::Sinc2 { lobes, .. }, "lobes") => {
                *lobes = whole(value, 0).min(u64::from(MAX_LOBES)) as u32;
                return true;
            }
            (
                LightPulse::Delta { energy, .. }
                | LightPulse::Gaussian { energy, .. }
                | LightPulse::Rect { energy, .. }
                | LightPulse::Exponential { energy, .. }
                | LightPulse::LaserDiode { energy, .. }
                | LightPulse::Sinc2 { energy, .. }
                | LightPulse::PiecewiseLinear { energy, .. },
                "energy",
            ) => energy,
            (LightPulse::Delta { t_s, .. }, "t_s") => t_s,
            (LightPulse::Gaussian { centre_s, .. }, "centre_s")
            | (LightPulse::Sinc2 { centre_s, .. }, "centre_s") => centre_s,
            (LightPulse::Gaussian { fwhm_s, .. }, "fwhm_s") => fwhm_s,
            (LightPulse::Rect { start_s, .. }, "start_s") => start_s,
            (LightPulse::Rect { width_s, .. }, "width_s")
            | (LightPulse::Sinc2 { width_s, .. }, "width_s") => width_s,
            (LightPulse::Exponential { onset_s, .. }, "onset_s")
            | (LightPulse::LaserDiode { onset_s, .. }, "onset_s") => onset_s,
            (LightPulse::Exponential { tau_s, .. }, "tau_s") => tau_s,
            (LightPulse::LaserDiode { rise_s, .. }, "rise_s") => rise_s,
            (LightPulse::LaserDiode { fall_s, .. }, "fall_s") => fall_s,
            _ => return false,
        };
        *slot = value;
        true
    }

    /// The knots of a free (piecewise-linear) pulse, `None` for the other kinds.
    pub fn knots_mut(&mut self) -> Option<&mut Vec<Point>> {
        match self {
            LightPulse::PiecewiseLinear { points, .. } => Some(points),
            _ => None,
        }
    }

    /// The knots of a free pulse (see [`Self::knots_mut`]).
    pub fn knots(&self) -> Option<&[Point]> {
        match self {
            LightPulse::PiecewiseLinear { points, .. } => Some(points),
            _ => None,
        }
    }
}

impl Exposure {
    /// A new gate sequence of `kind` (a name of [`EXPOSURE_KINDS`]; anything else box
    /// gates) covering a window `span_s` long from its start: 32 gates side by side,
    /// 256 TDC bins, or 4 AMCW phases at 20 MHz.
    pub fn of_kind(kind: &str, span_s: f64) -> Exposure {
        let n = 32u64;
        let w = span_s / n as f64;
        match kind {
            "gaussian" => Exposure::Gaussian {
                origin: TimeOrigin::Window,
                centre_s: w / 2.0,
                fwhm_s: w,
                step_s: None,
                count: n,
                peak: 1.0,
            },
            "piecewise_linear" => Exposure::PiecewiseLinear {
                origin: TimeOrigin::Window,
                points: vec![
                    Point(0.0, 0.0),
                    Point(w, 1.0),
                    Point(2.0 * w, 1.0),
                    Point(3.0 * w, 0.0),
                ],
                step_s: w,
                count: n,
            },
            "tdc" => Exposure::Tdc {
                origin: TimeOrigin::Window,
                start_s: 0.0,
                bin_width_s: span_s / 256.0,
                bins: 256,
                jitter_fwhm_s: span_s / 256.0,
            },
            "amcw" => Exposure::Amcw {
                freq_hz: 20e6,
                phase_steps: 4,
                phase0_deg: 0.0,
                modulation: 1.0,
            },
            _ => Exposure::Box {
                origin: TimeOrigin::Window,
                start_s: 0.0,
                width_s: w,
                step_s: None,
                count: n,
                gain: 1.0,
            },
        }
    }

    /// The sequence's editable numbers, in the order a form shows them. Handles are on
    /// gate 0 (its time and width) and on gate 1 (its time: the step), the latter
    /// only when there are several gates.
    pub fn fields(&self) -> Vec<Field> {
        use Quantity::{Count, Number, Time};
        let gates = |n: u64| {
            Field::new("count", "gates", Count, n as f64).help("number of gates in the sequence")
        };
        let several = self.count() > 1;
        let step = |anchor: &'static str, value: f64| {
            let f = Field::new("step_s", "step", Time, value)
                .help("from one gate to the next (drag gate 1 to set it)");
            if several {
                f.extent(anchor, 1.0, 0.8)
            } else {
                f
            }
        };
        match self {
            Exposure::Box {
                start_s,
                width_s,
                step_s,
                count,
                gain,
                ..
            } => vec![
                Field::new("start_s", "start", Time, *start_s)
                    .help("gate 0 opens")
                    .timed_from_origin()
                    .at(0.9),
                Field::duration("width_s", "width", *width_s)
                    .help("each gate is open this long")
                    .extent("start_s", 1.0, 0.9),
                step("start_s", step_s.unwrap_or(*width_s)),
                gates(*count),
                Field::new("gain", "gain", Number, *gain).help("sensitivity while open"),
            ],
            Exposure::Gaussian {
                centre_s,
                fwhm_s,
                step_s,
                count,
                peak,
                ..
            } => vec![
                Field::new("centre_s", "centre", Time, *centre_s)
                    .help("gate 0's centre")
                    .timed_from_origin()
                    .at(0.9),
                Field::duration("fwhm_s", "FWHM", *fwhm_s)
                    .help("full width at half maximum")
                    .extent("centre_s", 0.5, 0.45),
                step("centre_s", step_s.unwrap_or(*fwhm_s)),
                gates(*count),
                Field::new("peak", "peak", Number, *peak).help("sensitivity at the centre"),
            ],
            Exposure::PiecewiseLinear { step_s, count, .. } => {
                vec![
                    Field::new("step_s", "step", Time, *step_s).help("from one gate to the next"),
                    gates(*count),
                ]
            }
            Exposure::Amcw {
                freq_hz,
                phase_steps,
                phase0_deg,
                modulation,
            } => vec![
                Field::new("freq_hz", "frequency", Quantity::Frequency, *freq_hz)
                    .help("modulation frequency: the depth wraps every c / 2f"),
                Field::new("phase_steps", "phase steps", Count, *phase_steps as f64)
                    .range(1.0, 64.0)
                    .help("gates, one per phase, evenly spread over a period"),
                Field::new("phase0_deg", "phase 0", Quantity::Degrees, *phase0_deg)
                    .help("gate 0's phase"),
                Field::new("modulation", "modulation", Number, *modulation)
                    .range(0.0, 1.0)
                    .help("depth of the modulation, 0 to 1"),
            ],
            Exposure::Tdc {
                start_s,
                bin_width_s,
                bins,
                jitter_fwhm_s,
                ..
            } => vec![
                Field::new("start_s", "start", Time, *start_s)
                    .help("bin 0 opens")
                    .timed_from_origin()
                    .at(0.9),
                Field::duration("bin_width_s", "bin width", *bin_width_s)
                    .extent("start_s", 1.0, 0.9),
                Field::new("bins", "bins", Count, *bins as f64)
                    .help("TDC bins: bins x bin width is the laser cycle"),
                Field::duration("jitter_fwhm_s", "jitter FWHM", *jitter_fwhm_s)
                    .help("timing jitter of the detector and TDC (Gaussian)"),
            ],
        }
    }

    /// Set the field `key` (as [`Self::fields`] names it) to `value`; false when this
    /// kind has no such field. A count is rounded (at least 1); setting a step that
    /// defaults to the width makes it explicit.
    pub fn set_field(&mut self, key: &str, value: f64) -> bool {
        let slot: &mut f64 = match (self, key) {
            (
                Exposure::Box { count, .. }
                | Exposure::Gaussian { count, .. }
                | Exposure::PiecewiseLinear { count, .. },
                "count",
            )
            | (
                Exposure::Amcw {
                    phase_steps: count, ..
                },
                "phase_steps",
            )
            | (Exposure::Tdc { bins: count, .. }, "bins") => {
                *count = whole(value, 1);
                return true;
            }
            (Exposure::Box { step_s, .. } | Exposure::Gaussian { step_s, .. }, "step_s") => {
                *step_s = Some(value);
                return true;
            }
            (Exposure::Box { start_s, .. } | Exposure::Tdc { start_s, .. }, "start_s") => start_s,
            (Exposure::Box { width_s, .. }, "width_s") => width_s,
            (Exposure::Box { gain, .. }, "gain") => gain,
            (Exposure::Gaussian { centre_s, .. }, "centre_s") => centre_s,
            (Exposure::Gaussian { fwhm_s, .. }, "fwhm_s") => fwhm_s,
            (Exposure::Gaussian { peak, .. }, "peak") => peak,
            (Exposure::PiecewiseLinear { step_s, .. }, "step_s") => step_s,
            (Exposure::Amcw { freq_hz, .. }, "freq_hz") => freq_hz,
            (Exposure::Amcw { phase0_deg, .. }, "phase0_deg") => phase0_deg,
            (Exposure::Amcw { modulation, .. }, "modulation") => modulation,
            (Exposure::Tdc { bin_width_s, .. }, "bin_width_s") => bin_width_s,
            (Exposure::Tdc { jitter_fwhm_s, .. }, "jitter_fwhm_s") => jitter_fwhm_s,
            _ => return false,
        };
        *slot = value;
        true
    }

    /// The same gates counted from `origin` instead: every time that counts from the
    /// origin moved by the difference (`window_t0_s` the window's start), so each gate
    /// stays where it is. AMCW phases count from the trigger always: unchanged.
    pub fn with_origin(&self, origin: TimeOrigin, window_t0_s: f64) -> Exposure {
        let offset = |o: TimeOrigin| match o {
            TimeOrigin::Pulse => 0.0,
            TimeOrigin::Window => window_t0_s,
        };
        let by = offset(self.origin()) - offset(origin);
        let mut e = self.clone();
        match &mut e {
            Exposure::Box {
                origin: o, start_s, ..
            }
            | Exposure::Tdc {
                origin: o, start_s, ..
            } => {
                *start_s += by;
                *o = origin;
            }
            Exposure::Gaussian {
                origin: o,
                centre_s,
                ..
            } => {
                *centre_s += by;
                *o = origin;
            }
            Exposure::PiecewiseLinear {
                origin: o, points, ..
            } => {
                for p in points.iter_mut() {
                    p.0 += by;
                }
                *o = origin;
            }
            Exposure::Amcw { .. } => {}
        }
        e
    }

    /// The knots of a free (piecewise-linear) gate, `None` for the other kinds.
    pub fn knots_mut(&mut self) -> Option<&mut Vec<Point>> {
        match self {
            Exposure::PiecewiseLinear { points, .. } => Some(points),
            _ => None,
        }
    }

    /// The knots of a free gate (see [`Self::knots_mut`]).
    pub fn knots(&self) -> Option<&[Point]> {
        match self {
            Exposure::PiecewiseLinear { points, .. } => Some(points),
            _ => None,
        }
    }
}

impl Noise {
    /// The noise's editable numbers (its seed aside: a whole number beyond a float's
    /// 53 bits), in the order a form shows them.
    pub fn fields(&self) -> Vec<Field> {
        use Quantity::Number;
        vec![
            Field::new("sigma", "noise σ", Number, self.sigma)
                .range(0.0, super::MAX_SCALE)
                .help("standard deviation of the additive Gaussian noise, in measurement units"),
            Field::new(
                "photons_per_energy",
                "photons / unit",
                Number,
                self.photons_per_energy,
            )
            .range(0.0, super::MAX_SCALE)
            .help("photon (Poisson) noise: photons per unit of measurement; 0: none"),
        ]
    }

    /// Set the field `key` (as [`Self::fields`] names it) to `value`; false when there
    /// is no such field.
    pub fn set_field(&mut self, key: &str, value: f64) -> bool {
        let slot = match key {
            "sigma" => &mut self.sigma,
            "photons_per_energy" => &mut self.photons_per_energy,
            _ => return false,
        };
        *slot = value;
        true
    }
}

impl Returns {
    /// The return detector's editable numbers, in the order a form shows them.
    pub fn fields(&self) -> Vec<Field> {
        use Quantity::{Count, Number};
        vec![
            Field::new("threshold", "threshold", Number, self.threshold)
                .range(1e-6, 1.0)
                .help(
                    "detection level as a fraction of each pixel's highest gate value: a \
                     return is a run of gates at or above it; a valley parts two returns \
                     where both sides rise above it by the level. Lower it for weak \
                     echoes behind strong ones (a target behind fog)",
                ),
            Field::new("min_signal", "min signal", Number, self.min_signal)
                .range(0.0, super::MAX_SCALE)
                .help("pixels whose highest gate value is not above this have no return"),
            Field::new(
                "max_returns",
                "returns kept",
                Count,
                self.max_returns as f64,
            )
            .range(1.0, MAX_RETURNS as f64)
            .help("multi-echo: returns kept per pixel, earliest first"),
            Field::new("cfar_factor", "CFAR factor", Number, self.cfar_factor)
                .range(0.0, 1e6)
                .help(
                    "0: off. Else a gate counts only at this many times its local \
                     background (the greater of the means of the gates before and after \
                     it): a fog's falling backscatter is not a return, a target out of it \
                     is. With it, lower the threshold (0.005) for targets behind fog",
                ),
            Field::new("cfar_guard", "CFAR guard", Count, self.cfar_guard as f64)
                .range(1.0, 64.0)
                .help("gates each side left out of the background: about a return's half width"),
            Field::new("cfar_train", "CFAR train", Count, self.cfar_train as f64)
                .range(1.0, 256.0)
                .help("gates each side averaged into the background"),
        ]
    }

    /// Set the field `key` (as [`Self::fields`] names it) to `value`; false when there
    /// is no such field.
    pub fn set_field(&mut self, key: &str, value: f64) -> bool {
        match key {
            "threshold" => self.threshold = value,
            "min_signal" => self.min_signal = value,
            "max_returns" => {
                self.max_returns = value.round().clamp(1.0, MAX_RETURNS as f64) as usize
            }
            "cfar_factor" => self.cfar_factor = value,
            "cfar_guard" => self.cfar_guard = value.round().clamp(1.0, 64.0) as usize,
            "cfar_train" => self.cfar_train = value.round().clamp(1.0, 256.0) as usize,
            _ => return false,
        }
        true
    }
}

impl Spad {
    /// The SPAD's editable numbers (its acquisition mode aside), in the order a form
    /// shows them; the afterpulse delay only with afterpulsing on.
    pub fn fields(&self) -> Vec<Field> {
        use Quantity::{Count, Number, Rate};
        let mut f = vec![
            Field::new("cycles", "cycles", Count, self.cycles as f64)
                .range(1.0, MAX_CYCLES as f64)
                .help("laser cycles summed into the histogram"),
            Field::new("pde", "PDE", Number, self.pde)
                .range(0.0, 1.0)
                .help("photon detection efficiency: the chance a photon makes an avalanche"),
            Field::new(
                "photons_per_unit",
                "photons / unit",
                Number,
                self.photons_per_unit,
            )
            .range(0.0, 1e30)
            .help("photons reaching the pixel per unit of (TPRF * Light), per pulse"),
            Field::new("ambient_rate_hz", "ambient", Rate, self.ambient_rate_hz)
                .help("uniform ambient photons per second at each pixel"),
            Field::new(
                "ambient_lamp_hz",
                "ambient lamp",
                Rate,
                self.ambient_lamp_hz,
            )
            .help(
                "a steady lamp where the light is, of this many pulse energies per second: \
                 each pixel gets it times its steady image",
            ),
            Field::new(
                "dark_count_rate_hz",
                "dark counts",
                Rate,
                self.dark_count_rate_hz,
            )
            .help("dark count rate"),
            Field::duration("dead_time_s", "dead time", self.dead_time_s)
                .help("dead after each detection, from the end of its TDC bin"),
            Field::new(
                "afterpulse_probability",
                "afterpulsing",
                Number,
                self.afterpulse_probability,
            )
            .range(0.0, 1.0)
            .help("chance a detection is followed by an afterpulse"),
        ];
        if self.afterpulse_probability > 0.0 {
            f.push(
                Field::duration(
                    "afterpulse_delay_s",
                    "afterpulse delay",
                    self.afterpulse_delay_s,
                )
                .help("mean delay of an afterpulse"),
            );
        }
        f
    }

    /// Set the field `key` (as [`Self::fields`] names it) to `value`; false when there
    /// is no such field. Afterpulsing switched on with no delay gets one (twice the
    /// dead time, at least 1 ns).
    pub fn set_field(&mut self, key: &str, value: f64) -> bool {
        let slot = match key {
            "cycles" => {
                self.cycles = whole(value, 1).min(MAX_CYCLES);
                return true;
            }
            "pde" => &mut self.pde,
            "photons_per_unit" => &mut self.photons_per_unit,
            "ambient_rate_hz" => &mut self.ambient_rate_hz,
            "ambient_lamp_hz" => &mut self.ambient_lamp_hz,
            "dark_count_rate_hz" => &mut self.dark_count_rate_hz,
            "dead_time_s" => &mut self.dead_time_s,
            "afterpulse_probability" => &mut self.afterpulse_probability,
            "afterpulse_delay_s" => &mut self.afterpulse_delay_s,
            _ => return false,
        };
        *slot = value;
        if self.afterpulse_probability > 0.0 && !(self.afterpulse_delay_s > 0.0) {
            self.afterpulse_delay_s = (2.0 * self.dead_time_s).max(1e-9);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::{Sensor, SensorModel, TimeAxis};

    fn axis() -> TimeAxis {
        TimeAxis::new(2e-9, 50e-12, 200).unwrap()
    }

    /// Every kind of pulse and gates makes a sensor the model accepts.
    #[test]
    fn every_kind_makes_a_valid_sensor() {
        let axis = axis();
        for (lk, _) in LIGHT_KINDS {
            for (ek, _) in EXPOSURE_KINDS {
                let s = Sensor::new(
                    LightPulse::of_kind(lk, 0.0, 4.0 * axis.dt_s),
                    Exposure::of_kind(ek, axis.end_s() - axis.t0_s),
                );
                assert_eq!(s.light.kind_name(), *lk);
                assert_eq!(s.exposure.kind_name(), *ek);
                SensorModel::new(s, axis).unwrap_or_else(|e| panic!("{lk} x {ek}: {e}"));
            }
        }
        assert_eq!(kind_label(LIGHT_KINDS, "sinc2"), "sinc²");
        assert_eq!(kind_label(EXPOSURE_KINDS, "nope"), "?");
    }

    /// Each field is the variant's own number: set to a new value, read back the same,
    /// and the number the sensor file holds (its key) is that value. Anchors name a
    /// time field of the same part.
    #[test]
    fn every_field_reads_and_writes_its_own_number() {
        let axis = axis();
        for (lk, _) in LIGHT_KINDS {
            let mut l = LightPulse::of_kind(lk, 1e-9, 0.3e-9);
            for f in l.fields() {
                let v = f.value * 1.5
                    + if f.quantity == Quantity::Count {
                        1.0
                    } else {
                        1e-10
                    };
                let v = if f.quantity == Quantity::Count {
                    v.round()
                } else {
                    v
                };
                assert!(l.set_field(f.key, v), "{lk}.{}", f.key);
                let back = l.fields().into_iter().find(|g| g.key == f.key).unwrap();
                assert_eq!(back.value, v, "{lk}.{}", f.key);
                let file = toml::Value::try_from(&l).unwrap();
                let stored = file
                    .get(f.key)
                    .and_then(|x| x.as_float().or(x.as_integer().map(|i| i as f64)));
                assert_eq!(stored, Some(v), "{lk}.{} in the file", f.key);
                if let Some(HandleAt::Extent { anchor, .. }) = f.handle {
                    assert!(l.fields().iter().any(|g| g.key == anchor), "{lk}: {anchor}");
                }
            }
            assert!(!l.set_field("no_such_field", 1.0));
        }
        for (ek, _) in EXPOSURE_KINDS {
            let mut e = Exposure::of_kind(ek, axis.end_s() - axis.t0_s);
            for f in e.fields() {
                let v = if f.quantity == Quantity::Count {
                    (f.value + 3.0).min(f.max)
                } else {
                    f.value * 1.5 + 1e-10
                };
                assert!(e.set_field(f.key, v), "{ek}.{}", f.key);
                let back = e.fields().into_iter().find(|g| g.key == f.key).unwrap();
                assert_eq!(back.value, v, "{ek}.{}", f.key);
                let file = toml::Value::try_from(&e).unwrap();
                let stored = file
                    .get(f.key)
                    .and_then(|x| x.as_float().or(x.as_integer().map(|i| i as f64)));
                assert_eq!(stored, Some(v), "{ek}.{} in the file", f.key);
            }
        }
        let mut spad = Spad::default();
        for f in spad.fields() {
            let v = if f.quantity == Quantity::Count {
                f.value + 7.0
            } else {
                (f.value * 0.5 + 0.25).min(f.max)
            };
            assert!(spad.set_field(f.key, v), "spad.{}", f.key);
            assert_eq!(
                spad.fields()
                    .into_iter()
                    .find(|g| g.key == f.key)
                    .unwrap()
                    .value,
                v
            );
        }
        let mut noise = Noise::default();
        for f in noise.fields() {
            assert!(noise.set_field(f.key, 0.5), "noise.{}", f.key);
            let file = toml::Value::try_from(noise).unwrap();
            assert_eq!(file.get(f.key).and_then(|x| x.as_float()), Some(0.5));
        }
        assert!(!noise.set_field("seed", 1.0));
        // The return detector: each field is its key in the file, as numbers go there.
        let mut returns = Returns::default();
        for (f, v) in returns.fields().into_iter().zip([0.05, 2.5, 5.0]) {
            assert!(returns.set_field(f.key, v), "returns.{}", f.key);
            let file = toml::Value::try_from(returns).unwrap();
            let got = file
                .get(f.key)
                .and_then(|x| x.as_float().or(x.as_integer().map(|i| i as f64)));
            assert_eq!(got, Some(v), "returns.{}", f.key);
        }
        assert!(!returns.set_field("sigma", 1.0));
        // Afterpulsing on: its delay appears, and is set.
        assert!(spad.fields().iter().any(|f| f.key == "afterpulse_delay_s"));
        assert!(spad.afterpulse_delay_s > 0.0);
    }

    /// A sequence moved to the other origin keeps every gate where it was.
    #[test]
    fn a_new_origin_keeps_the_gates_in_place() {
        let t0 = 3.5e-9;
        for (ek, _) in EXPOSURE_KINDS {
            let e = Exposure::of_kind(ek, 12e-9);
            let moved = e.with_origin(TimeOrigin::Pulse, t0);
            if !matches!(e, Exposure::Amcw { .. }) {
                assert_eq!(moved.origin(), TimeOrigin::Pulse, "{ek}");
            }
            let (a, b) = (e.gates(t0).unwrap(), moved.gates(t0).unwrap());
            for (ga, gb) in a.iter().zip(&b) {
                for t in [3e-9, 4e-9, 5.5e-9, 9e-9, 14e-9] {
                    assert!((ga.value(t) - gb.value(t)).abs() < 1e-9, "{ek} at {t}");
                }
            }
        }
    }
}

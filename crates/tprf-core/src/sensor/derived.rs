//! Outputs derived from the measurements, where a preset asks for them:
//!
//! - **returns** (full-waveform LiDAR): per pixel, the returns (echoes) of the gate
//!   waveform `M_i` against the gate centres, each located by its centroid, minus the
//!   light's mean emission time; depth `c (t - t_light) / 2`. A LiDAR reports the
//!   first, the strongest and the last return, and multi-echo: up to N returns per
//!   pixel with their intensities ([`find_returns`], [`ReturnImages`]);
//! - **AMCW phase and depth**: per pixel, `theta = atan2(sum M_i sin phi_i,
//!   sum M_i cos phi_i) - theta_0` (`theta_0` the phase the sensor reports for a return
//!   at `tau = 0`, so a light's own delay cancels), depth `c theta / (4 pi f)`, unique
//!   up to the ambiguity range `c / (2 f)`.
//!
//! - **FLIM lifetime** (fluorescence-lifetime imaging's rapid lifetime determination):
//!   per pixel, from two box gates of equal width whose starts are `dt` apart, the
//!   lifetime of a single-exponential decay `tau = dt / ln(M_1 / M_2)`
//!   ([`flim_lifetime_s`]). Exact for a decay `e^{-t/tau}` that starts before both gates
//!   (each gate then holds `tau e^{-t_i/tau} (1 - e^{-w/tau})`); a mixture of lifetimes
//!   gives an average between them.
//!
//! "Depth" is half the optical path of the return, `c tau / 2`, measured from the
//! light's mean emission time: the distance to the surface along the pixel's ray when
//! the light sits beside the camera (LiDAR and ToF cameras), half the light -> surface
//! -> eye path otherwise. `c` is [`crate::units::C_M_PER_S`].

use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

use super::exposure::{Exposure, Gate};
use super::measure::Measurements;
use super::{SensorError, non_negative};
use crate::film::FilmSnapshot;
use crate::film::TimeAxis;
use crate::units::C_M_PER_S;

/// The derived outputs a sensor asks for; none by default.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Derived {
    /// The returns of each pixel's gate waveform (first, strongest, last, multi-echo).
    /// Files before 2026-11-29 call it `first_return`.
    #[serde(skip_serializing_if = "Option::is_none", alias = "first_return")]
    pub returns: Option<Returns>,
    /// AMCW phase, amplitude and depth per pixel (needs an `amcw` exposure).
    pub amcw_depth: bool,
    /// FLIM's two-gate lifetime per pixel, `tau = dt / ln(M_1 / M_2)` from the first two
    /// gates (box gates of equal width, the second starting `dt` after the first).
    pub flim_lifetime: bool,
}

/// How the returns of a waveform are found ([`find_returns`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Returns {
    /// The detection level as a fraction of the pixel's highest sample (0 < threshold
    /// <= 1; default 0.2): a return is a run of samples at or above it, and a valley
    /// inside a run parts two returns where both sides rise above it by the level.
    pub threshold: f64,
    /// Pixels whose highest sample is not above this (measurement units) have no
    /// return (default 0).
    pub min_signal: f64,
    /// How many returns per pixel multi-echo keeps, earliest first (1 to 16;
    /// default 3). The strongest and the last return are chosen among all.
    pub max_returns: usize,
    /// A constant-false-alarm-rate detector on top of the level (0: off, default): a
    /// sample counts only where it is at least this many times its local background,
    /// the greater of the means of `cfar_train` samples before it and after it, each
    /// beyond `cfar_guard` samples (greatest-of CA-CFAR). In fog, the backscatter's
    /// falling tail stays under its own earlier samples and is not a return, while a
    /// target standing out of it is; with a low `threshold` (0.005) the car 22 m into
    /// builtin:fog's 50 m visibility is found (1.5 % of the pixel's peak).
    pub cfar_factor: f64,
    /// Samples each side of the sample under test left out of its background (1 to 64;
    /// default 2): about the return's half width.
    pub cfar_guard: usize,
    /// Samples each side averaged into the background (1 to 256; default 8).
    pub cfar_train: usize,
}

/// The most returns multi-echo keeps per pixel.
pub const MAX_RETURNS: usize = 16;

impl Default for Returns {
    fn default() -> Self {
        Returns {
            threshold: 0.2,
            min_signal: 0.0,
            max_returns: 3,
            cfar_factor: 0.0,
            cfar_guard: 2,
            cfar_train: 8,
        }
    }
}

impl Derived {
    /// Checks the parameters and that the gates allow what is asked: first return
    /// needs at least two gates with increasing centres; AMCW depth an `amcw` exposure
    /// with at least three phase steps.
    pub fn validate(&self, exposure: &Exposure, gates: &[Gate]) -> Result<(), SensorError> {
        if let Some(fr) = &self.returns {
            non_negative("derived.returns.threshold", fr.threshold)?;
            if !(fr.threshold > 0.0 && fr.threshold <= 1.0) {
                return Err(SensorError::OutOfRange {
                    what: "derived.returns.threshold".into(),
                    value: fr.threshold,
                    rule: "in (0, 1]",
                });
            }
            non_negative("derived.returns.min_signal", fr.min_signal)?;
            non_negative("derived.returns.cfar_factor", fr.cfar_factor)?;
            for (what, v, max) in [
                ("derived.returns.cfar_guard", fr.cfar_guard, 64),
                ("derived.returns.cfar_train", fr.cfar_train, 256),
            ] {
                if !(1..=max).contains(&v) {
                    return Err(SensorError::OutOfRange {
                        what: what.into(),
                        value: v as f64,
                        rule: if max == 64 {
                            "from 1 to 64"
                        } else {
                            "from 1 to 256"
                        },
                    });
                }
            }
            if !(1..=MAX_RETURNS).contains(&fr.max_returns) {
                return Err(SensorError::OutOfRange {
                    what: "derived.returns.max_returns".into(),
                    value: fr.max_returns as f64,
                    rule: "from 1 to 16",
                });
            }
            let centres: Option<Vec<f64>> = gates.iter().map(Gate::centre_s).collect();
            match centres {
                Some(c) if c.len() >= 2 && c.windows(2).all(|w| w[1] > w[0]) => {}
                _ => {
                    return Err(SensorError::Invalid(
                        "derived.returns needs at least two gates with increasing \
                         centres (a waveform)"
                            .into(),
                    ));
                }
            }
        }
        if self.flim_lifetime && flim_gate_spacing_s(gates).is_none() {
            return Err(SensorError::Invalid(
                "derived.flim_lifetime needs its first two gates to be box gates of equal \
                 width, the second starting after the first"
                    .into(),
            ));
        }
        if self.amcw_depth {
            match exposure {
                Exposure::Amcw { phase_steps, .. } if *phase_steps >= 3 => {}
                _ => {
                    return Err(SensorError::Invalid(
                        "derived.amcw_depth needs an amcw exposure with at least 3 \
                         phase_steps"
                            .into(),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// The spacing `dt` (seconds) of the two gates FLIM's lifetime is taken from: the
/// starts of gates 0 and 1 when both are box gates of equal width (to 1e-9 of it) and
/// the second starts later; else `None`.
pub fn flim_gate_spacing_s(gates: &[Gate]) -> Option<f64> {
    let (
        Some(Gate::Box {
            start_s: a0,
            end_s: a1,
            ..
        }),
        Some(Gate::Box {
            start_s: b0,
            end_s: b1,
            ..
        }),
    ) = (gates.first(), gates.get(1))
    else {
        return None;
    };
    let (wa, wb) = (a1 - a0, b1 - b0);
    let same = (wa - wb).abs() <= 1e-9 * wa.abs().max(wb.abs());
    (same && wa > 0.0 && b0 > a0).then_some(b0 - a0)
}

/// FLIM's rapid lifetime determination per pixel: `tau = dt / ln(M_1 / M_2)`, seconds,
/// from gates 0 and 1 of `m` (`dt` their spacing, [`flim_gate_spacing_s`]); NaN where
/// `M_1 <= M_2` or `M_2 <= 0` (no decay to measure). `[H, W]`.
pub fn flim_lifetime_s(m: &Measurements, dt_s: f64) -> Vec<f32> {
    let pixels = m.width * m.height;
    (0..pixels)
        .map(|px| {
            let m1 = m.values.get(px).map_or(0.0, |&v| f64::from(v));
            let m2 = m.values.get(pixels + px).map_or(0.0, |&v| f64::from(v));
            if m2 > 0.0 && m1 > m2 {
                (dt_s / (m1 / m2).ln()) as f32
            } else {
                f32::NAN
            }
        })
        .collect()
}

/// Depth (m) of a round-trip time (s): `c t / 2`.
pub fn depth_m(round_trip_s: f64) -> f64 {
    0.5 * C_M_PER_S * round_trip_s
}

/// One return (echo) of a waveform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Return {
    /// The centroid of the return's samples, `sum v_i t_i / sum v_i`, seconds.
    pub time_s: f64,
    /// The sum of the return's samples (measurement units): with gates that tile
    /// time, proportional to the energy the return brought.
    pub intensity: f64,
}

/// The returns of a waveform `values[i]` sampled at increasing `times_s[i]`, earliest
/// first, into `out`. Detection: with `level = threshold x` the highest sample, a return
/// is a run of samples at or above `level`; inside a run a valley parts two returns
/// where the samples before it rose above it by at least `level` and the samples after
/// it rise by as much (a hysteresis peak detector: noise wiggles smaller than the level
/// do not split a return; the valley's sample goes to the earlier return). Extent: each
/// return then takes in its flanks below the level, down to the local minimum (or zero)
/// on each side, so its intensity is the whole echo's and not only its top. Each
/// return's time is the centroid of its samples. None when the highest sample is not
/// above `min_signal` (or not positive). With [`Returns::cfar_factor`] a sample must
/// also reach that many times its local background (`cfar_background`) to be in a
/// run.
pub fn find_returns(values: &[f64], times_s: &[f64], p: &Returns, out: &mut Vec<Return>) {
    out.clear();
    let n = values.len().min(times_s.len());
    let values = &values[..n];
    let peak = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !(peak > p.min_signal && peak > 0.0) {
        return;
    }
    let floor_level = p.threshold * peak;
    let level = |i: usize| match p.cfar_factor > 0.0 {
        true => floor_level.max(p.cfar_factor * cfar_background(values, i, p)),
        false => floor_level,
    };
    // Each detected span (inclusive) is measured once the next is known: its flank runs
    // short of the next return. `floor`: the first sample after the previous return.
    let mut pending: Option<(usize, usize)> = None;
    let mut floor = 0;
    let mut detected = |span: (usize, usize), out: &mut Vec<Return>| {
        if let Some(done) = pending.replace(span) {
            floor = measure_return(values, times_s, done, (floor, span.0 - 1), out) + 1;
        }
    };
    let mut i = 0;
    while i < n {
        if !(values[i] >= level(i)) {
            i += 1;
            continue;
        }
        // A run from `start`; `hi` its highest sample since the return began, `lo` the
        // lowest since `hi` (at `lo_at`).
        let mut start = i;
        let (mut hi, mut lo, mut lo_at) = (values[i], values[i], i);
        while i + 1 < n && values[i + 1] >= level(i + 1) {
            i += 1;
            let v = values[i];
            let rise = floor_level;
            if v > hi && hi - lo < rise {
                (hi, lo, lo_at) = (v, v, i);
            } else if v < lo {
                (lo, lo_at) = (v, i);
            } else if hi - lo >= rise && v - lo >= rise {
                detected((start, lo_at), out);
                start = lo_at + 1;
                let top = values[start..=i].iter().copied().fold(lo, f64::max);
                (hi, lo, lo_at) = (top, v, i);
            }
        }
        detected((start, i), out);
        i += 1;
    }
    if let Some(last) = pending {
        measure_return(values, times_s, last, (floor, n - 1), out);
    }
}

/// The local background of sample `i` for [`Returns::cfar_factor`]: the greater of the
/// means of the `cfar_train` samples before and after it beyond `cfar_guard` (a side
/// cut short by the waveform's end averages what it has; none: 0).
fn cfar_background(values: &[f64], i: usize, p: &Returns) -> f64 {
    let mean = |w: &[f64]| match w.len() {
        0 => 0.0,
        n => w.iter().sum::<f64>() / n as f64,
    };
    let before = i.saturating_sub(p.cfar_guard);
    let lead = &values[before.saturating_sub(p.cfar_train)..before];
    let after = (i + p.cfar_guard + 1).min(values.len());
    let lag = &values[after..(after + p.cfar_train).min(values.len())];
    mean(lead).max(mean(lag))
}

/// The return detected over `(from, to)`: its flanks added, down from each end while
/// the samples keep falling and stay positive, within `(floor, ceil)`; its centroid
/// and sum pushed onto `out` (when positive). Gives the return's last sample.
fn measure_return(
    values: &[f64],
    times_s: &[f64],
    (mut from, mut to): (usize, usize),
    (floor, ceil): (usize, usize),
    out: &mut Vec<Return>,
) -> usize {
    while from > floor && values[from - 1] > 0.0 && values[from - 1] <= values[from] {
        from -= 1;
    }
    while to < ceil && values[to + 1] > 0.0 && values[to + 1] <= values[to] {
        to += 1;
    }
    let (mut sum, mut moment) = (0.0, 0.0);
    for (v, t) in values[from..=to].iter().zip(&times_s[from..=to]) {
        sum += v;
        moment += v * t;
    }
    if sum > 0.0 {
        out.push(Return {
            time_s: moment / sum,
            intensity: sum,
        });
    }
    to
}

/// A LiDAR's returns over the image: multi-echo `[N, H, W]` and the first, strongest
/// and last return's depth `[H, W]` (metres, `c (t_return - light mean time) / 2`;
/// NaN: no such return).
#[derive(Clone, Debug, PartialEq)]
pub struct ReturnImages {
    pub width: usize,
    pub height: usize,
    /// N, the returns kept per pixel ([`Returns::max_returns`]).
    pub max_returns: usize,
    /// `[N, H, W]`: the k-th return's depth, earliest first, NaN past a pixel's last.
    pub depth_m: Vec<f32>,
    /// `[N, H, W]`: the k-th return's intensity ([`Return::intensity`]), 0 past a
    /// pixel's last.
    pub intensity: Vec<f32>,
    /// `[H, W]`: how many returns each pixel has (all of them, also past N).
    pub count: Vec<u16>,
    /// `[H, W]`: the depth of the return of highest intensity.
    pub strongest_m: Vec<f32>,
    /// `[H, W]`: the depth of the latest return.
    pub last_m: Vec<f32>,
}

/// Which of a pixel's returns a depth image shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Echo {
    #[default]
    First,
    Strongest,
    Last,
    /// The k-th return, earliest first, from 0 (`Nth(0)` is `First`).
    Nth(usize),
}

impl Echo {
    /// Its name on screen: "first", "strongest", "last", "2nd", "3rd", "11th".
    pub fn label(self) -> String {
        match self {
            Echo::First => "first".into(),
            Echo::Strongest => "strongest".into(),
            Echo::Last => "last".into(),
            Echo::Nth(k) => {
                let n = k + 1;
                let suffix = match (n % 10, n % 100) {
                    (_, 11..=13) => "th",
                    (1, _) => "st",
                    (2, _) => "nd",
                    (3, _) => "rd",
                    _ => "th",
                };
                format!("{n}{suffix}")
            }
        }
    }
}

impl ReturnImages {
    /// The depth image `[H, W]` of `echo` (metres, NaN: none); an `Nth` past N gives
    /// the last kept.
    pub fn depth(&self, echo: Echo) -> &[f32] {
        let px = self.width * self.height;
        match echo {
            Echo::First => &self.depth_m[..px],
            Echo::Strongest => &self.strongest_m,
            Echo::Last => &self.last_m,
            Echo::Nth(k) => {
                let k = k.min(self.max_returns - 1);
                &self.depth_m[k * px..(k + 1) * px]
            }
        }
    }

    /// The first return's depth `[H, W]`.
    pub fn first_m(&self) -> &[f32] {
        self.depth(Echo::First)
    }
}

/// The returns of every pixel, from gate waveforms: depth `c (t_return -
/// light_mean_s) / 2` with the returns from [`find_returns`] over the gate centres.
pub fn return_images(
    m: &Measurements,
    gate_centres_s: &[f64],
    light_mean_s: f64,
    p: &Returns,
) -> ReturnImages {
    let pixels = m.width * m.height;
    let n = p.max_returns.clamp(1, MAX_RETURNS);
    let mut out = ReturnImages {
        width: m.width,
        height: m.height,
        max_returns: n,
        depth_m: vec![f32::NAN; n * pixels],
        intensity: vec![0.0; n * pixels],
        count: vec![0; pixels],
        strongest_m: vec![f32::NAN; pixels],
        last_m: vec![f32::NAN; pixels],
    };
    let mut waveform = vec![0.0; m.gates];
    let mut found = Vec::new();
    let depth = |r: &Return| depth_m(r.time_s - light_mean_s) as f32;
    for px in 0..pixels {
        for (i, w) in waveform.iter_mut().enumerate() {
            *w = f64::from(m.values[i * pixels + px]);
        }
        find_returns(&waveform, gate_centres_s, p, &mut found);
        out.count[px] = found.len().min(usize::from(u16::MAX)) as u16;
        for (k, r) in found.iter().take(n).enumerate() {
            out.depth_m[k * pixels + px] = depth(r);
            out.intensity[k * pixels + px] = r.intensity as f32;
        }
        if let Some(last) = found.last() {
            out.last_m[px] = depth(last);
        }
        if let Some(strong) = found
            .iter()
            .reduce(|a, b| if b.intensity > a.intensity { b } else { a })
        {
            out.strongest_m[px] = depth(strong);
        }
    }
    out
}

/// The first return of every pixel's TPRF itself (bins as samples at their centres):
/// depth `[H, W]` metres, NaN for empty pixels. A reference for noise-free depth.
pub fn tprf_first_return_depth(
    cube: &[f32],
    width: usize,
    height: usize,
    axis: &TimeAxis,
    p: &Returns,
) -> Vec<f32> {
    let times: Vec<f64> = (0..axis.bins).map(|b| axis.bin_center_s(b)).collect();
    let mut waveform = vec![0.0; axis.bins];
    let mut found = Vec::new();
    cube.chunks_exact(axis.bins)
        .take(width * height)
        .map(|px| {
            for (w, &v) in waveform.iter_mut().zip(px) {
                *w = f64::from(v);
            }
            find_returns(&waveform, &times, p, &mut found);
            found.first().map_or(f32::NAN, |r| depth_m(r.time_s) as f32)
        })
        .collect()
}

/// [`tprf_first_return_depth`] of a film snapshot, a row at a time.
pub fn tprf_first_return_depth_film(snap: &FilmSnapshot, p: &Returns) -> Vec<f32> {
    let mut row = Vec::new();
    let mut out = Vec::with_capacity(snap.width() * snap.height());
    for y in 0..snap.height() {
        snap.row_dense(y, None, &mut row);
        out.extend(tprf_first_return_depth(
            &row,
            snap.width(),
            1,
            snap.axis(),
            p,
        ));
    }
    out
}

/// Depth of the centroid in time of every pixel's TPRF, `[H, W]` metres (NaN for
/// empty pixels): the exact mean depth of a single-scattering layer.
pub fn tprf_centroid_depth(cube: &[f32], width: usize, height: usize, axis: &TimeAxis) -> Vec<f32> {
    cube.chunks_exact(axis.bins)
        .take(width * height)
        .map(|px| {
            let (mut sum, mut moment) = (0.0, 0.0);
            for (b, &v) in px.iter().enumerate() {
                sum += f64::from(v);
                moment += f64::from(v) * axis.bin_center_s(b);
            }
            if sum > 0.0 {
                depth_m(moment / sum) as f32
            } else {
                f32::NAN
            }
        })
        .collect()
}

/// AMCW images `[H, W]`.
#[derive(Clone, Debug, PartialEq)]
pub struct AmcwImage {
    pub width: usize,
    pub height: usize,
    /// Phase of the return after removing the light's own, radians in `[0, 2 pi)`
    /// (NaN without signal).
    pub phase_rad: Vec<f32>,
    /// Amplitude of the fundamental, `(2/N) |sum M_i exp(i phi_i)|`.
    pub amplitude: Vec<f32>,
    /// Depth `c phase / (4 pi f)`, metres, in `[0, ambiguity_m)`.
    pub depth_m: Vec<f32>,
    /// The unambiguous range `c / (2 f)`, metres.
    pub ambiguity_m: f64,
}

/// AMCW phase, amplitude and depth from measurements of gates with phases
/// `phases_rad` at `freq_hz`; `phase_offset_rad` is the phase the sensor reports for
/// a return at `tau = 0` (see [`super::SensorModel::amcw_phase_offset_rad`]).
pub fn amcw_image(
    m: &Measurements,
    phases_rad: &[f64],
    freq_hz: f64,
    phase_offset_rad: f64,
) -> AmcwImage {
    let pixels = m.width * m.height;
    let n = phases_rad.len().min(m.gates);
    let (mut phase, mut amplitude, mut depth) = (
        Vec::with_capacity(pixels),
        Vec::with_capacity(pixels),
        Vec::with_capacity(pixels),
    );
    for px in 0..pixels {
        let (mut c, mut s) = (0.0, 0.0);
        for (i, phi) in phases_rad.iter().enumerate().take(n) {
            let v = f64::from(m.values[i * pixels + px]);
            c += v * phi.cos();
            s += v * phi.sin();
        }
        let amp = 2.0 / n as f64 * c.hypot(s);
        if amp > 0.0 {
            let theta = (s.atan2(c) - phase_offset_rad).rem_euclid(TAU);
            phase.push(theta as f32);
            depth.push((C_M_PER_S * theta / (4.0 * PI * freq_hz)) as f32);
        } else {
            phase.push(f32::NAN);
            depth.push(f32::NAN);
        }
        amplitude.push(amp as f32);
    }
    AmcwImage {
        width: m.width,
        height: m.height,
        phase_rad: phase,
        amplitude,
        depth_m: depth,
        ambiguity_m: C_M_PER_S / (2.0 * freq_hz),
    }
}

/// `a - b` wrapped into `[-period / 2, period / 2)`: the error of a depth known only
/// modulo `period`.
pub fn wrapped_difference(a: f64, b: f64, period: f64) -> f64 {
    (a - b + 0.5 * period).rem_euclid(period) - 0.5 * period
}

#[cfg(test)]
mod tests {

    #[test]
    fn flim_lifetime_is_rapid_lifetime_determination() {
        // Gates [2, 4) and [4, 6) ns on e^{-t/tau}: M_i = tau e^{-t_i/tau} (1 - e^{-2/tau})
        // by hand, for tau 1 ns and 4 ns; a pixel whose second gate is not darker has none.
        let gate = |a: f64| Gate::Box {
            start_s: a * 1e-9,
            end_s: (a + 2.0) * 1e-9,
            gain: 1.0,
        };
        let gates = [gate(2.0), gate(4.0)];
        assert_eq!(flim_gate_spacing_s(&gates), Some(2e-9));
        let m_of = |tau: f64, t: f64| (tau * (-t / tau).exp() * (1.0 - (-2.0 / tau).exp())) as f32;
        let m = Measurements {
            gates: 2,
            height: 1,
            width: 3,
            values: vec![
                m_of(1.0, 2.0),
                m_of(4.0, 2.0),
                1.0,
                m_of(1.0, 4.0),
                m_of(4.0, 4.0),
                1.0,
            ],
        };
        let tau = flim_lifetime_s(&m, 2e-9);
        assert!((f64::from(tau[0]) / 1e-9 - 1.0).abs() < 1e-5, "{}", tau[0]);
        assert!((f64::from(tau[1]) / 4e-9 - 1.0).abs() < 1e-5, "{}", tau[1]);
        assert!(tau[2].is_nan());
        // Unequal widths, other kinds or a second gate not after the first: refused.
        let wide = Gate::Box {
            start_s: 4e-9,
            end_s: 7e-9,
            gain: 1.0,
        };
        assert_eq!(flim_gate_spacing_s(&[gate(2.0), wide]), None);
        assert_eq!(flim_gate_spacing_s(&[gate(4.0), gate(2.0)]), None);
        assert_eq!(flim_gate_spacing_s(&[gate(2.0)]), None);
    }
    use super::*;

    /// The time of the first return of a waveform, seconds.
    fn first_return_time(values: &[f64], times_s: &[f64], p: &Returns) -> Option<f64> {
        let mut out = Vec::new();
        find_returns(values, times_s, p, &mut out);
        out.first().map(|r| r.time_s)
    }

    #[test]
    fn first_return_finds_the_first_peak() {
        let times: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let mut v = vec![0.0; 20];
        // A symmetric return centred at 5 and a larger one at 12.
        v[4] = 1.0;
        v[5] = 2.0;
        v[6] = 1.0;
        v[11] = 3.0;
        v[12] = 6.0;
        v[13] = 3.0;
        let p = Returns {
            threshold: 0.1,
            ..Returns::default()
        };
        assert_eq!(first_return_time(&v, &times, &p), Some(5.0));
        // Above the first peak's height: the second return.
        let p = Returns {
            threshold: 0.4,
            ..Returns::default()
        };
        assert_eq!(first_return_time(&v, &times, &p), Some(12.0));
        let p = Returns {
            threshold: 0.1,
            min_signal: 10.0,
            ..Returns::default()
        };
        assert_eq!(first_return_time(&v, &times, &p), None);
        assert_eq!(
            first_return_time(&[0.0; 20], &times, &Returns::default()),
            None
        );
    }

    /// A LiDAR in fog, by hand on 1 s samples: the backscatter `100 e^(-i/6)` from the
    /// start, a clutter floor of 1 with wiggles of +-0.3 (alternating: symmetric about
    /// every sample), and a target of height 6 over the floor at 120 (`6 e^(-k^2/8)`).
    /// At a level of 0.005 x the peak (0.5) the floor is one long run whose 0.6 wiggles
    /// part it into many returns; the greatest-of CFAR at 3 x the background (about 1
    /// on the floor, so a level of about 3) keeps only the target, whose centroid is 120
    /// by symmetry: the backscatter's first sample (101) is under 3 x the mean of the
    /// 8 after its guard (`100 e^(-i/6)` for i = 3..10: 36.6, so 110).
    #[test]
    fn cfar_finds_the_target_in_fog_and_not_the_clutter() {
        let times: Vec<f64> = (0..240).map(|i| i as f64).collect();
        let v: Vec<f64> = (0..240)
            .map(|i| {
                let k = i as f64 - 120.0;
                let wiggle = if i % 2 == 0 { 0.3 } else { -0.3 };
                100.0 * (-(i as f64) / 6.0).exp() + 1.0 + wiggle + 6.0 * (-k * k / 8.0).exp()
            })
            .collect();
        let mut out = Vec::new();
        let plain = Returns {
            threshold: 0.005,
            max_returns: 16,
            ..Returns::default()
        };
        find_returns(&v, &times, &plain, &mut out);
        assert!(
            out.len() > 10,
            "the clutter's wiggles: {} returns",
            out.len()
        );
        let cfar = Returns {
            cfar_factor: 3.0,
            ..plain
        };
        find_returns(&v, &times, &cfar, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!((out[0].time_s - 120.0).abs() < 1e-6, "{out:?}");
        // Off by default; out-of-range windows refused by name.
        assert_eq!(Returns::default().cfar_factor, 0.0);
        let exposure = Exposure::Box {
            origin: Default::default(),
            start_s: 0.0,
            width_s: 1.0,
            step_s: None,
            count: 4,
            gain: 1.0,
        };
        let gates: Vec<Gate> = (0..4)
            .map(|i| Gate::Box {
                start_s: i as f64,
                end_s: i as f64 + 1.0,
                gain: 1.0,
            })
            .collect();
        let bad = Derived {
            returns: Some(Returns {
                cfar_guard: 0,
                ..cfar
            }),
            ..Derived::default()
        };
        assert!(
            Derived {
                returns: Some(cfar),
                ..Derived::default()
            }
            .validate(&exposure, &gates)
            .is_ok()
        );
        let e = bad.validate(&exposure, &gates).unwrap_err();
        assert!(e.to_string().contains("cfar_guard"), "{e}");
    }

    /// Hand-made waveforms on 1 s samples: each return's centroid and sum worked out
    /// by hand.
    #[test]
    fn returns_are_runs_above_the_level_parted_at_deep_valleys() {
        let times: Vec<f64> = (0..30).map(|i| i as f64).collect();
        let p = Returns {
            threshold: 0.1,
            max_returns: 4,
            ..Returns::default()
        };
        let mut out = Vec::new();
        // Two separate returns: (1, 2, 1) centred at 5, sum 4; (3, 6, 3) at 12, sum 12.
        let mut v = vec![0.0; 30];
        v[4..7].copy_from_slice(&[1.0, 2.0, 1.0]);
        v[11..14].copy_from_slice(&[3.0, 6.0, 3.0]);
        find_returns(&v, &times, &p, &mut out);
        assert_eq!(
            out,
            vec![
                Return {
                    time_s: 5.0,
                    intensity: 4.0
                },
                Return {
                    time_s: 12.0,
                    intensity: 12.0
                }
            ]
        );
        // A decaying backscatter (10, 8, 6, 4, 3) and a target (5, 3) on its tail, no
        // gap: level 0.1 x 10 = 1; the valley (3) is 7 below the peak and the target
        // rises 2 above it, so two returns: [10, 8, 6, 4, 3] then [5, 3].
        let mut v = vec![0.0; 30];
        v[0..7].copy_from_slice(&[10.0, 8.0, 6.0, 4.0, 3.0, 5.0, 3.0]);
        find_returns(&v, &times, &p, &mut out);
        assert_eq!(out.len(), 2, "{out:?}");
        let t0 = (8.0 + 12.0 + 12.0 + 12.0) / 31.0;
        assert!((out[0].time_s - t0).abs() < 1e-12 && out[0].intensity == 31.0);
        assert!((out[1].time_s - (25.0 + 18.0) / 8.0).abs() < 1e-12);
        assert_eq!(out[1].intensity, 8.0);
        // A weak echo's flanks below the level (1.0) are its own: (0.5, 2, 0.4) has
        // intensity 2.9 and centroid (5 + 22 + 4.8) / 2.9.
        let mut v = vec![0.0; 30];
        v[2..4].copy_from_slice(&[10.0, 6.0]);
        v[10..13].copy_from_slice(&[0.5, 2.0, 0.4]);
        find_returns(&v, &times, &p, &mut out);
        assert_eq!(out.len(), 2, "{out:?}");
        assert!((out[1].intensity - 2.9).abs() < 1e-12, "{out:?}");
        assert!((out[1].time_s - 31.8 / 2.9).abs() < 1e-12, "{out:?}");
        // An uptick of 0.5 on the tail (level 1) does not part it: one return.
        let mut v = vec![0.0; 30];
        v[0..6].copy_from_slice(&[10.0, 8.0, 6.0, 4.0, 4.5, 3.0]);
        find_returns(&v, &times, &p, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(out[0].intensity, 35.5);
        // A wiggle smaller than the level does not part a return: (2, 6, 5.5, 6, 2),
        // level 0.2 x 6 = 1.2 > 0.5; centroid 258 / 21.5 = 12.
        let mut v = vec![0.0; 30];
        v[10..15].copy_from_slice(&[2.0, 6.0, 5.5, 6.0, 2.0]);
        let p2 = Returns {
            threshold: 0.2,
            ..p
        };
        find_returns(&v, &times, &p2, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!((out[0].time_s - 12.0).abs() < 1e-12);
        // Three returns; max_returns 2 keeps the first two, the strongest and last are
        // chosen among all three. Two pixels: the second is dark.
        let mut v = vec![0.0; 30];
        v[2] = 1.0;
        v[10] = 5.0;
        v[20] = 2.0;
        let m = Measurements {
            width: 2,
            height: 1,
            gates: 30,
            values: v.iter().flat_map(|&x| [x as f32, 0.0]).collect(),
        };
        let p3 = Returns {
            threshold: 0.1,
            max_returns: 2,
            ..Returns::default()
        };
        let img = return_images(&m, &times, 0.0, &p3);
        let d = |t: f64| depth_m(t) as f32;
        assert_eq!(img.count, vec![3, 0]);
        assert_eq!(img.depth(Echo::First)[0], d(2.0));
        assert!(img.depth_m[1].is_nan() && img.depth_m[3].is_nan());
        assert_eq!(img.depth_m[2], d(10.0));
        assert_eq!(img.intensity, vec![1.0, 0.0, 5.0, 0.0]);
        assert_eq!(img.strongest_m[0], d(10.0));
        assert_eq!(img.last_m[0], d(20.0));
        assert!(img.strongest_m[1].is_nan() && img.last_m[1].is_nan());
        assert_eq!(img.depth(Echo::Nth(1))[0], d(10.0));
        let labels: Vec<String> = [0, 1, 2, 3, 10, 11, 12, 20, 21]
            .map(|k| Echo::Nth(k).label())
            .into();
        assert_eq!(
            labels,
            [
                "1st", "2nd", "3rd", "4th", "11th", "12th", "13th", "21st", "22nd"
            ]
        );
    }

    #[test]
    fn wrapping() {
        assert!((wrapped_difference(0.1, 7.4, 7.5) - 0.2).abs() < 1e-12);
        assert!((wrapped_difference(7.4, 0.1, 7.5) + 0.2).abs() < 1e-12);
        assert_eq!(wrapped_difference(2.0, 1.0, 7.5), 1.0);
    }
}

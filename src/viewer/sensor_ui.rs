//! The sensor in the window (the paper's section 6): edit Light(t) and the gates
//! Exposure_i(t) over a rendered film and see the measurements M_i at once. Nothing is
//! re-rendered: each frame the edited [`Sensor`] goes to [`SensorModel::update`]
//! (kernels recomputed only when the light or the gates changed) and the measurement is
//! redone only when the sensor or the film snapshot changed.

use super::colormap::{self, ColorMap, Tone};
use eframe::egui::{self, Color32, RichText, Sense, TextureHandle, TextureOptions, Vec2};
use egui_plot::{Line, Plot, PlotPoint, PlotPoints, Points, VLine};
use std::sync::Arc;
use std::time::Instant;
use tprf_core::film::{FilmSnapshot, TimeAxis};
use tprf_core::sensor::{
    AmcwImage, Exposure, LightPulse, Measurements, NoiseField, PixelTrace, Point, Sensor,
    SensorModel, TimeOrigin, derived,
};

const LIGHT_COLOR: Color32 = Color32::from_rgb(0xff, 0xc8, 0x3d);
const GATE_COLOR: Color32 = Color32::from_rgb(0x4d, 0xc3, 0xff);
const TPRF_COLOR: Color32 = Color32::from_gray(0x90);

/// A point of an envelope the user can drag on the editor plot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Handle {
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

/// A handle where it is drawn: time (s) and height on the editor's 0..1 scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HandlePos {
    pub handle: Handle,
    pub t_s: f64,
    pub y: f64,
}

/// The measurements of one (snapshot, sensor) pair and what is derived from them.
struct Measured {
    snapshot: usize,
    sensor: Sensor,
    m: Measurements,
    depth_m: Option<Vec<f32>>,
    amcw: Option<AmcwImage>,
    /// AMCW depth minus the depth of the TPRF's own first return (multipath error), m.
    amcw_error_m: Option<Vec<f32>>,
    millis: f64,
    /// 99.9 % quantile of the positive measurements: one exposure for all gates.
    robust_max: Option<f64>,
    /// Finite range of the depth image (m), and the largest |multipath error| (m).
    depth_range: (f32, f32),
    error_abs_max: f32,
    noise_field: NoiseField,
}

/// The shown gate's image, measured on the UI thread right after an edit.
struct Plane {
    snapshot: usize,
    sensor: Sensor,
    gate: usize,
    values: Vec<f32>,
    millis: f64,
}

/// What the sensor tab keeps between frames: the model with its kernels, the latest
/// measurements and their textures. The sensor being edited lives in the settings.
///
/// An edit is shown within the frame: the image of the gate on screen is measured at
/// once (one kernel over the film). All N gates, the noise and the derived depth are
/// measured on a background thread and replace it when done; the UI never waits.
#[derive(Default)]
pub struct SensorState {
    model: Option<SensorModel>,
    measured: Option<Measured>,
    plane: Option<Plane>,
    job: Option<std::sync::mpsc::Receiver<Measured>>,
    noise_field: Option<NoiseField>,
    pub error: Option<String>,
    /// The gate shown, `i`.
    pub gate: usize,
    drag: Option<Handle>,
    textures: Vec<(&'static str, u64, TextureHandle)>,
}

/// Threads for the background measurements: half the cores.
fn background_pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: std::sync::OnceLock<Option<rayon::ThreadPool>> = std::sync::OnceLock::new();
    POOL.get_or_init(|| {
        let n = std::thread::available_parallelism().map_or(1, |n| n.get());
        rayon::ThreadPoolBuilder::new()
            .num_threads((n / 2).max(1))
            .thread_name(|i| format!("tprf-sensor-{i}"))
            .build()
            .ok()
    })
    .as_ref()
}

/// All gates of `snap` through `model`, with noise and derived outputs.
fn measure_all(
    model: &SensorModel,
    snap: &FilmSnapshot,
    mut noise_field: NoiseField,
) -> Result<Measured, String> {
    let started = Instant::now();
    let mut m = model
        .measure_clean(&snap.cube, snap.width(), snap.height())
        .map_err(|e| e.to_string())?;
    model.apply_noise_cached(&mut m, &mut noise_field);
    let robust_max = tprf_core::film::robust_max(&m.values);
    let depth_m = model.first_return_depth(&m);
    let amcw = model.amcw(&m);
    let amcw_error_m = amcw.as_ref().map(|a| {
        let truth = derived::tprf_first_return_depth(
            &snap.cube,
            snap.width(),
            snap.height(),
            snap.axis(),
            &Default::default(),
        );
        a.depth_m.iter().zip(&truth).map(|(d, t)| d - t).collect()
    });
    let depth = depth_m
        .as_deref()
        .or(amcw.as_ref().map(|a| a.depth_m.as_slice()));
    let depth_range = depth.map_or((0.0, 0.0), finite_range);
    let error_abs_max = amcw_error_m.as_ref().map_or(0.0, |e: &Vec<f32>| {
        e.iter()
            .filter(|x| x.is_finite())
            .fold(0.0f32, |a, x| a.max(x.abs()))
    });
    Ok(Measured {
        snapshot: 0,
        sensor: model.sensor().clone(),
        m,
        depth_m,
        amcw,
        amcw_error_m,
        millis: started.elapsed().as_secs_f64() * 1e3,
        robust_max,
        depth_range,
        error_abs_max,
        noise_field,
    })
}

impl SensorState {
    /// Bring the model and the measurements up to date with `sensor` and `snap`; an
    /// invalid sensor leaves the last good ones and says why. Never waits.
    pub fn update(&mut self, sensor: &Sensor, snap: &Arc<FilmSnapshot>) {
        let axis = *snap.axis();
        let model = match self.model.take() {
            Some(mut m) => {
                let r = m.set_axis(axis).and_then(|_| m.update(sensor));
                self.error = r.err().map(|e| e.to_string());
                m
            }
            None => match SensorModel::new(sensor.clone(), axis) {
                Ok(m) => {
                    self.error = None;
                    m
                }
                Err(e) => {
                    self.error = Some(e.to_string());
                    return;
                }
            },
        };
        self.gate = self.gate.min(model.gate_count().saturating_sub(1));
        let key = Arc::as_ptr(snap) as usize;
        // A finished background measurement.
        if let Some(rx) = &self.job {
            match rx.try_recv() {
                Ok(mut done) => {
                    self.noise_field = Some(std::mem::take(&mut done.noise_field));
                    self.measured = Some(done);
                    self.job = None;
                }
                Err(std::sync::mpsc::TryRecvError::Disconnected) => self.job = None,
                Err(std::sync::mpsc::TryRecvError::Empty) => {}
            }
        }
        if !self.is_current_for(key, model.sensor()) {
            if self.job.is_none() {
                let (tx, rx) = std::sync::mpsc::channel();
                let (job_model, job_snap) = (model.clone(), snap.clone());
                let field = self.noise_field.take().unwrap_or_default();
                let spawned = std::thread::Builder::new()
                    .name("tprf-sensor".into())
                    .spawn(move || {
                        // On its own threads, so the gate measured for the frame does
                        // not queue behind it on the global pool.
                        let result = match background_pool() {
                            Some(pool) => {
                                pool.install(|| measure_all(&job_model, &job_snap, field))
                            }
                            None => measure_all(&job_model, &job_snap, field),
                        };
                        if let Ok(mut m) = result {
                            m.snapshot = Arc::as_ptr(&job_snap) as usize;
                            let _ = tx.send(m);
                        }
                    });
                match spawned {
                    Ok(_) => self.job = Some(rx),
                    Err(e) => {
                        self.error = Some(format!("cannot start the measurement thread: {e}"))
                    }
                }
            }
            // The gate on screen, now.
            let gate = self.gate;
            let stale = self
                .plane
                .as_ref()
                .is_none_or(|p| p.snapshot != key || p.gate != gate || p.sensor != *model.sensor());
            if stale && let Some(k) = model.kernels().get(gate) {
                let started = Instant::now();
                let packed =
                    tprf_core::sensor::PackedKernels::new(std::slice::from_ref(k), axis.bins);
                if let Ok(m) = tprf_core::sensor::measure::measure_clean(
                    &packed,
                    &snap.cube,
                    snap.width(),
                    snap.height(),
                ) {
                    self.plane = Some(Plane {
                        snapshot: key,
                        sensor: model.sensor().clone(),
                        gate,
                        values: m.values,
                        millis: started.elapsed().as_secs_f64() * 1e3,
                    });
                }
            }
        }
        self.model = Some(model);
    }

    fn is_current_for(&self, snapshot: usize, sensor: &Sensor) -> bool {
        self.measured
            .as_ref()
            .is_some_and(|m| m.snapshot == snapshot && m.sensor == *sensor)
    }

    /// Whether the measurements of all gates are those of the current sensor and film.
    pub fn is_current(&self, snap: &Arc<FilmSnapshot>) -> bool {
        self.model
            .as_ref()
            .is_some_and(|m| self.is_current_for(Arc::as_ptr(snap) as usize, m.sensor()))
    }

    /// The image of the gate on screen, `[H, W]`, as the window shows it now: from the
    /// full measurement when it is current, else measured for this frame (no noise).
    pub fn shown_plane(&self, snap: &Arc<FilmSnapshot>) -> Option<&[f32]> {
        if self.is_current(snap) {
            return self.measured.as_ref().map(|m| m.m.plane(self.gate));
        }
        let key = Arc::as_ptr(snap) as usize;
        let model = self.model.as_ref()?;
        self.plane
            .as_ref()
            .filter(|p| p.snapshot == key && p.gate == self.gate && p.sensor == *model.sensor())
            .map(|p| p.values.as_slice())
    }

    pub fn model(&self) -> Option<&SensorModel> {
        self.model.as_ref()
    }

    /// The latest measurements `[N, H, W]`.
    pub fn measurements(&self) -> Option<&Measurements> {
        self.measured.as_ref().map(|m| &m.m)
    }

    /// Milliseconds the last measurement took (kernels excluded).
    pub fn last_measure_ms(&self) -> Option<f64> {
        self.measured.as_ref().map(|m| m.millis)
    }

    /// One pixel's trace through the sensor: TPRF, TPRF * Light, M_i before noise.
    pub fn pixel_trace(&self, tprf: &[f32]) -> Option<PixelTrace> {
        self.model.as_ref()?.pixel_trace(tprf).ok()
    }
}

/// The texture `name`, rebuilt with `make` when its key changed.
fn texture(
    textures: &mut Vec<(&'static str, u64, TextureHandle)>,
    ctx: &egui::Context,
    name: &'static str,
    key: u64,
    make: impl FnOnce() -> egui::ColorImage,
) -> TextureHandle {
    if let Some((_, k, t)) = textures.iter().find(|(n, _, _)| *n == name)
        && *k == key
    {
        return t.clone();
    }
    let image = make();
    if let Some((_, k, t)) = textures.iter_mut().find(|(n, _, _)| *n == name) {
        t.set(image, TextureOptions::NEAREST);
        *k = key;
        return t.clone();
    }
    let t = ctx.load_texture(name, image, TextureOptions::NEAREST);
    textures.push((name, key, t.clone()));
    t
}

// ---------------------------------------------------------------------------------
// Handles: where they are and what dragging them changes.

/// Absolute time of a gate-sequence time `t` (gates may count from the window start).
fn gate_abs_s(origin: TimeOrigin, t_s: f64, axis: &TimeAxis) -> f64 {
    match origin {
        TimeOrigin::Pulse => t_s,
        TimeOrigin::Window => t_s + axis.t0_s,
    }
}

fn knot_scale(points: &[Point]) -> f64 {
    let m = points.iter().fold(0.0f64, |m, p| m.max(p.1));
    if m > 0.0 { m } else { 1.0 }
}

/// The handles of `sensor` on the editor (gate handles on gate 0 and gate 1).
pub fn handles(sensor: &Sensor, axis: &TimeAxis) -> Vec<HandlePos> {
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
        Exposure::Amcw { .. } => {}
    }
    out
}

/// Move `handle` to time `t_s` (and height `y` on the 0..1 scale, for knots). Widths
/// stay positive; knots keep their time order.
pub fn drag_handle(sensor: &mut Sensor, handle: Handle, t_s: f64, y: f64, axis: &TimeAxis) {
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

// ---------------------------------------------------------------------------------
// Widgets.

/// A time in ns, stored in seconds.
fn time_ns(ui: &mut egui::Ui, label: &str, t_s: &mut f64, speed_ns: f64) {
    let l = ui.label(label);
    let mut ns = *t_s * 1e9;
    if ui
        .add(
            egui::DragValue::new(&mut ns)
                .speed(speed_ns)
                .suffix(" ns")
                .max_decimals(4),
        )
        .labelled_by(l.id)
        .changed()
        && ns.is_finite()
    {
        *t_s = ns * 1e-9;
    }
    ui.end_row();
}

fn number(
    ui: &mut egui::Ui,
    label: &str,
    v: &mut f64,
    range: std::ops::RangeInclusive<f64>,
    speed: f64,
) {
    let l = ui.label(label);
    ui.add(egui::DragValue::new(v).range(range).speed(speed))
        .labelled_by(l.id);
    ui.end_row();
}

fn count(ui: &mut egui::Ui, label: &str, v: &mut u64, max: u64) {
    let l = ui.label(label);
    ui.add(egui::DragValue::new(v).range(1..=max))
        .labelled_by(l.id);
    ui.end_row();
}

/// A new light of `kind` with sizes fit for a window of bin width `dt_s`.
fn light_of_kind(kind: &str, at_s: f64, dt_s: f64) -> LightPulse {
    let w = 4.0 * dt_s;
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

/// A new gate sequence of `kind` covering the window `axis`.
fn exposure_of_kind(kind: &str, axis: &TimeAxis) -> Exposure {
    let span = axis.end_s() - axis.t0_s;
    let n = 32u64;
    let w = span / n as f64;
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

const LIGHT_KINDS: &[(&str, &str)] = &[
    ("delta", "delta"),
    ("gaussian", "Gaussian"),
    ("rect", "rectangular"),
    ("exponential", "exponential decay"),
    ("laser_diode", "laser diode"),
    ("sinc2", "sinc²"),
    ("piecewise_linear", "free (piecewise linear)"),
];

const EXPOSURE_KINDS: &[(&str, &str)] = &[
    ("box", "box gates"),
    ("gaussian", "Gaussian gates"),
    ("piecewise_linear", "free gates (piecewise linear)"),
    ("amcw", "AMCW sinusoids"),
];

fn label_of(table: &[(&str, &'static str)], key: &str) -> &'static str {
    table
        .iter()
        .find(|(k, _)| *k == key)
        .map_or("?", |(_, l)| l)
}

/// The sensor's controls (left panel): presets, light, gates, noise. Returns a message
/// to show when a preset file could not be read or written.
pub fn controls_ui(
    ui: &mut egui::Ui,
    sensor: &mut Sensor,
    axis: Option<&TimeAxis>,
) -> Option<String> {
    let mut message = None;
    ui.heading("Sensor");
    if !sensor.name.is_empty() {
        ui.label(RichText::new(&sensor.name).strong());
    }
    ui.horizontal_wrapped(|ui| {
        for (name, _) in tprf_core::sensor::BUILTIN_PRESETS {
            if ui
                .button(*name)
                .on_hover_text(format!("builtin:{name}"))
                .clicked()
            {
                match Sensor::builtin(name) {
                    Ok(s) => *sensor = s,
                    Err(e) => message = Some(e.to_string()),
                }
            }
        }
        if ui
            .button("Load…")
            .on_hover_text("A sensor file (TOML)")
            .clicked()
            && let Some(p) = rfd::FileDialog::new()
                .add_filter("sensor", &["toml"])
                .pick_file()
        {
            match Sensor::from_path(&p) {
                Ok(s) => *sensor = s,
                Err(e) => message = Some(e.to_string()),
            }
        }
        if ui.button("Save…").clicked()
            && let Some(p) = rfd::FileDialog::new()
                .add_filter("sensor", &["toml"])
                .set_file_name("sensor.toml")
                .save_file()
        {
            let r = sensor
                .to_toml_string()
                .map_err(|e| e.to_string())
                .and_then(|t| {
                    use std::io::Write;
                    tprf_core::export::write_atomic(&p, |f| Ok(f.write_all(t.as_bytes())?))
                        .map_err(|e| format!("{:#}", anyhow::Error::from(e)))
                });
            if let Err(e) = r {
                message = Some(format!("cannot save {}: {e}", p.display()));
            }
        }
    });
    let dt_s = axis.map_or(1e-10, |a| a.dt_s);
    let speed = dt_s * 1e9 / 4.0;

    ui.label(RichText::new("Light(t)").color(LIGHT_COLOR).strong());
    let kind = sensor.light.kind_name();
    let mut new_kind = kind;
    egui::ComboBox::from_id_salt("light-kind")
        .selected_text(label_of(LIGHT_KINDS, kind))
        .show_ui(ui, |ui| {
            for (k, l) in LIGHT_KINDS {
                ui.selectable_value(&mut new_kind, k, *l);
            }
        });
    if new_kind != kind {
        // A new pulse leaves at the trigger, t = 0, like the rendered one.
        sensor.light = light_of_kind(new_kind, 0.0, dt_s);
    }
    egui::Grid::new("light-grid")
        .num_columns(2)
        .show(ui, |ui| match &mut sensor.light {
            LightPulse::Delta { t_s, energy } => {
                time_ns(ui, "time", t_s, speed);
                number(ui, "energy", energy, 0.0..=1e12, 0.01);
            }
            LightPulse::Gaussian {
                centre_s,
                fwhm_s,
                energy,
            } => {
                time_ns(ui, "centre", centre_s, speed);
                time_ns(ui, "FWHM", fwhm_s, speed);
                number(ui, "energy", energy, 0.0..=1e12, 0.01);
            }
            LightPulse::Rect {
                start_s,
                width_s,
                energy,
            } => {
                time_ns(ui, "start", start_s, speed);
                time_ns(ui, "width", width_s, speed);
                number(ui, "energy", energy, 0.0..=1e12, 0.01);
            }
            LightPulse::Exponential {
                onset_s,
                tau_s,
                energy,
            } => {
                time_ns(ui, "onset", onset_s, speed);
                time_ns(ui, "decay τ", tau_s, speed);
                number(ui, "energy", energy, 0.0..=1e12, 0.01);
            }
            LightPulse::LaserDiode {
                onset_s,
                rise_s,
                fall_s,
                energy,
            } => {
                time_ns(ui, "onset", onset_s, speed);
                time_ns(ui, "rise", rise_s, speed);
                time_ns(ui, "fall", fall_s, speed);
                number(ui, "energy", energy, 0.0..=1e12, 0.01);
            }
            LightPulse::Sinc2 {
                centre_s,
                width_s,
                lobes,
                energy,
            } => {
                time_ns(ui, "centre", centre_s, speed);
                time_ns(ui, "first zero", width_s, speed);
                let l = ui.label("side lobes");
                ui.add(egui::DragValue::new(lobes).range(0..=64))
                    .labelled_by(l.id);
                ui.end_row();
                number(ui, "energy", energy, 0.0..=1e12, 0.01);
            }
            LightPulse::PiecewiseLinear { points, energy } => {
                ui.label(format!("{} knots: drag them on the plot", points.len()));
                ui.end_row();
                number(ui, "energy", energy, 0.0..=1e12, 0.01);
            }
        });

    ui.label(RichText::new("Exposure_i(t)").color(GATE_COLOR).strong());
    let kind = sensor.exposure.kind_name();
    let mut new_kind = kind;
    egui::ComboBox::from_id_salt("exposure-kind")
        .selected_text(label_of(EXPOSURE_KINDS, kind))
        .show_ui(ui, |ui| {
            for (k, l) in EXPOSURE_KINDS {
                ui.selectable_value(&mut new_kind, k, *l);
            }
        });
    if new_kind != kind
        && let Some(axis) = axis
    {
        sensor.exposure = exposure_of_kind(new_kind, axis);
        sensor.derived = Default::default();
        sensor.derived.amcw_depth = new_kind == "amcw";
    }
    let max_gates = tprf_core::sensor::MAX_GATES;
    egui::Grid::new("exposure-grid")
        .num_columns(2)
        .show(ui, |ui| match &mut sensor.exposure {
            Exposure::Box {
                start_s,
                width_s,
                step_s,
                count: n,
                gain,
                ..
            } => {
                time_ns(ui, "start", start_s, speed);
                time_ns(ui, "width", width_s, speed);
                let mut step = step_s.unwrap_or(*width_s);
                time_ns(ui, "step", &mut step, speed);
                if step_s.is_some() || step != *width_s {
                    *step_s = Some(step);
                }
                count(ui, "gates", n, max_gates);
                number(ui, "gain", gain, 0.0..=1e12, 0.01);
            }
            Exposure::Gaussian {
                centre_s,
                fwhm_s,
                step_s,
                count: n,
                peak,
                ..
            } => {
                time_ns(ui, "centre", centre_s, speed);
                time_ns(ui, "FWHM", fwhm_s, speed);
                let mut step = step_s.unwrap_or(*fwhm_s);
                time_ns(ui, "step", &mut step, speed);
                if step_s.is_some() || step != *fwhm_s {
                    *step_s = Some(step);
                }
                count(ui, "gates", n, max_gates);
                number(ui, "peak", peak, 0.0..=1e12, 0.01);
            }
            Exposure::PiecewiseLinear {
                points,
                step_s,
                count: n,
                ..
            } => {
                ui.label(format!("{} knots: drag them on the plot", points.len()));
                ui.end_row();
                time_ns(ui, "step", step_s, speed);
                count(ui, "gates", n, max_gates);
            }
            Exposure::Amcw {
                freq_hz,
                phase_steps,
                phase0_deg,
                modulation,
            } => {
                let mut mhz = *freq_hz * 1e-6;
                let l = ui.label("frequency");
                if ui
                    .add(
                        egui::DragValue::new(&mut mhz)
                            .range(1e-3..=1e5)
                            .speed(0.1)
                            .suffix(" MHz"),
                    )
                    .labelled_by(l.id)
                    .changed()
                {
                    *freq_hz = mhz * 1e6;
                }
                ui.end_row();
                count(ui, "phase steps", phase_steps, 64);
                number(ui, "phase 0 (deg)", phase0_deg, -360.0..=360.0, 1.0);
                number(ui, "modulation", modulation, 0.0..=1.0, 0.01);
            }
        });

    ui.label(RichText::new("Noise").strong());
    egui::Grid::new("noise-grid").num_columns(2).show(ui, |ui| {
        let l = ui.label("σ (additive)");
        ui.add(
            egui::DragValue::new(&mut sensor.noise.sigma)
                .range(0.0..=1e12)
                .speed(1e-4)
                .max_decimals(6),
        )
        .labelled_by(l.id);
        ui.end_row();
        let l = ui.label("photons / energy");
        ui.add(
            egui::DragValue::new(&mut sensor.noise.photons_per_energy)
                .range(0.0..=1e15)
                .speed(1.0),
        )
        .labelled_by(l.id)
        .on_hover_text("Poisson photon noise; 0 = off");
        ui.end_row();
        let l = ui.label("seed");
        ui.add(egui::DragValue::new(&mut sensor.noise.seed))
            .labelled_by(l.id);
        ui.end_row();
    });
    message
}

/// The envelope editor: Light(t) and every Exposure_i(t) on one time axis with the
/// pixel's TPRF behind them, each scaled to its own peak; drag the handles.
pub fn editor_ui(
    ui: &mut egui::Ui,
    state: &mut SensorState,
    sensor: &mut Sensor,
    tprf: &[f32],
    axis: &TimeAxis,
    height: f32,
) {
    let Some(model) = state.model() else {
        return;
    };
    let (lo, hi) = model.time_span_s();
    let n = 600;
    let ts: Vec<f64> = (0..=n)
        .map(|k| lo + (hi - lo) * k as f64 / n as f64)
        .collect();
    let norm = |v: Vec<f64>| -> Vec<f64> {
        let m = v.iter().fold(0.0f64, |m, &x| m.max(x));
        if m > 0.0 {
            v.into_iter().map(|x| x / m).collect()
        } else {
            v
        }
    };
    let light = norm(model.light_curve(&ts));
    let delta = model.light().delta_time_s();
    let gates = model.gate_count();
    // Every gate, faint, when there are not too many; the selected one bright.
    let shown: Vec<usize> = if gates <= 64 {
        (0..gates).collect()
    } else {
        vec![]
    };
    let gate_curves: Vec<(usize, Vec<f64>)> = shown
        .iter()
        .map(|&i| (i, model.exposure_curve(i, &ts)))
        .collect();
    let sel = model.exposure_curve(state.gate, &ts);
    let gate_peak = gate_curves
        .iter()
        .flat_map(|c| c.1.iter())
        .chain(&sel)
        .fold(0.0f64, |m, &x| m.max(x))
        .max(1e-300);
    let tprf_max = tprf
        .iter()
        .fold(0.0f32, |m, &x| m.max(x))
        .max(f32::MIN_POSITIVE) as f64;
    let tprf_steps: Vec<[f64; 2]> = tprf
        .iter()
        .enumerate()
        .flat_map(|(b, &v)| {
            let y = v as f64 / tprf_max;
            [
                [axis.bin_start_s(b) * 1e9, y],
                [(axis.bin_start_s(b) + axis.dt_s) * 1e9, y],
            ]
        })
        .collect();
    let hs = handles(sensor, axis);
    let gate_label = gate_time_label(model, state.gate);
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new("— Light").color(LIGHT_COLOR).small());
        ui.label(
            RichText::new(format!("— Exposure_{} {gate_label}", state.gate))
                .color(GATE_COLOR)
                .small(),
        );
        ui.label(RichText::new("■ TPRF").color(TPRF_COLOR).small());
        ui.label(RichText::new("white dots: drag").small());
    });
    let response = Plot::new("sensor-editor")
        .height(height)
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .include_y(0.0)
        .include_y(1.05)
        .x_axis_label("time after the trigger (ns)")
        .y_axis_label("each scaled to its peak")
        .show(ui, |p| {
            p.line(
                Line::new("TPRF (pixel)", PlotPoints::from(tprf_steps))
                    .color(TPRF_COLOR)
                    .fill(0.0)
                    .fill_alpha(0.35),
            );
            for (i, c) in &gate_curves {
                if *i != state.gate {
                    let pts: Vec<[f64; 2]> = ts
                        .iter()
                        .zip(c)
                        .map(|(t, v)| [t * 1e9, v / gate_peak])
                        .collect();
                    p.line(
                        Line::new("Exposure_i", PlotPoints::from(pts))
                            .color(GATE_COLOR.gamma_multiply(0.25)),
                    );
                }
            }
            let pts: Vec<[f64; 2]> = ts
                .iter()
                .zip(&sel)
                .map(|(t, v)| [t * 1e9, v / gate_peak])
                .collect();
            p.line(
                Line::new(
                    format!("Exposure_{} {gate_label}", state.gate),
                    PlotPoints::from(pts),
                )
                .color(GATE_COLOR)
                .width(2.0),
            );
            match delta {
                Some(t) => p.vline(
                    VLine::new("Light (delta)", t * 1e9)
                        .color(LIGHT_COLOR)
                        .width(2.0),
                ),
                None => {
                    let pts: Vec<[f64; 2]> =
                        ts.iter().zip(&light).map(|(t, v)| [t * 1e9, *v]).collect();
                    p.line(
                        Line::new("Light", PlotPoints::from(pts))
                            .color(LIGHT_COLOR)
                            .width(2.0),
                    );
                }
            }
            let pts: Vec<[f64; 2]> = hs.iter().map(|h| [h.t_s * 1e9, h.y]).collect();
            p.points(
                Points::new("handles", PlotPoints::from(pts))
                    .radius(5.0)
                    .color(Color32::WHITE),
            );
            let screen: Vec<(Handle, egui::Pos2)> = hs
                .iter()
                .map(|h| {
                    (
                        h.handle,
                        p.screen_from_plot(PlotPoint::new(h.t_s * 1e9, h.y)),
                    )
                })
                .collect();
            (screen, p.pointer_coordinate())
        });
    let (screen, pointer) = response.inner;
    let r = &response.response;
    if r.drag_started()
        && let Some(pos) = r.interact_pointer_pos()
    {
        state.drag = screen
            .iter()
            .map(|(h, p)| (*h, p.distance(pos)))
            .filter(|(_, d)| *d < 12.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(h, _)| h);
    }
    if r.dragged()
        && let (Some(h), Some(p)) = (state.drag, pointer)
    {
        drag_handle(sensor, h, p.x * 1e-9, p.y, axis);
    }
    if r.drag_stopped() {
        state.drag = None;
    }
    if let Some(pos) = r.hover_pos()
        && screen.iter().any(|(_, p)| p.distance(pos) < 12.0)
    {
        ui.ctx().set_cursor_icon(egui::CursorIcon::Grab);
    }
    r.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Figure, true, "envelope editor"));
}

fn gate_time_label(model: &SensorModel, i: usize) -> String {
    model
        .gates()
        .get(i)
        .and_then(|g| g.centre_s())
        .map_or(String::new(), |c| format!("(centre {:.3} ns)", c * 1e9))
}

/// Figures 6 and 7 of the paper for one pixel: TPRF * Light on the bins, and M_i
/// against i (click a point to show that gate).
pub fn pixel_plots_ui(
    ui: &mut egui::Ui,
    state: &mut SensorState,
    tprf: &[f32],
    m_pixel: &[f32],
    axis: &TimeAxis,
    height: f32,
) {
    let Some(trace) = state.pixel_trace(tprf) else {
        return;
    };
    ui.label(RichText::new("(TPRF * Light)(t) of the pixel").small());
    let steps: Vec<[f64; 2]> = trace
        .tprf_light
        .iter()
        .enumerate()
        .flat_map(|(b, &v)| {
            [
                [axis.bin_start_s(b) * 1e9, v],
                [(axis.bin_start_s(b) + axis.dt_s) * 1e9, v],
            ]
        })
        .collect();
    Plot::new("sensor-tprf-light")
        .height(height)
        .allow_drag(false)
        .x_axis_label("arrival time (ns)")
        .show(ui, |p| {
            p.line(Line::new("TPRF * Light", PlotPoints::from(steps)).color(LIGHT_COLOR))
        });
    ui.label(
        RichText::new("M_i of the pixel (with noise once all gates are measured); click a gate")
            .small(),
    );
    let m_clean: Vec<f32> = trace.m_clean.iter().map(|&v| v as f32).collect();
    let m_pixel = if m_pixel.is_empty() {
        &m_clean[..]
    } else {
        m_pixel
    };
    let pts: Vec<[f64; 2]> = m_pixel
        .iter()
        .enumerate()
        .map(|(i, &v)| [i as f64, v as f64])
        .collect();
    let gate = state.gate;
    let r = Plot::new("sensor-m")
        .height(height)
        .allow_drag(false)
        .x_axis_label("gate i")
        .show(ui, |p| {
            p.line(Line::new("M_i", PlotPoints::from(pts.clone())).color(GATE_COLOR));
            p.points(
                Points::new("", PlotPoints::from(pts))
                    .radius(2.0)
                    .color(GATE_COLOR),
            );
            p.vline(
                VLine::new("gate shown", gate as f64).color(Color32::from_rgb(0xff, 0x9f, 0x43)),
            );
            p.pointer_coordinate()
        });
    if r.response.clicked()
        && let Some(p) = r.inner
        && p.x.is_finite()
    {
        state.gate = (p.x.round().max(0.0) as usize).min(m_pixel.len().saturating_sub(1));
    }
}

/// The measurement image of the gate shown and the derived images. Returns a clicked
/// pixel.
pub fn images_ui(
    ui: &mut egui::Ui,
    state: &mut SensorState,
    snap: &Arc<FilmSnapshot>,
) -> Option<(usize, usize)> {
    let (w, h) = (snap.width(), snap.height());
    // The textures are taken out for the frame so the measurements can be borrowed.
    let mut textures = std::mem::take(&mut state.textures);
    let mut gate_sel = state.gate;
    let clicked = measurement_images(ui, state, snap, &mut textures, &mut gate_sel, w, h);
    state.textures = textures;
    state.gate = gate_sel;
    clicked
}

#[allow(clippy::too_many_arguments)]
fn measurement_images(
    ui: &mut egui::Ui,
    state: &SensorState,
    snap: &Arc<FilmSnapshot>,
    textures: &mut Vec<(&'static str, u64, TextureHandle)>,
    gate_sel: &mut usize,
    w: usize,
    h: usize,
) -> Option<(usize, usize)> {
    let (Some(model), Some(plane)) = (state.model.as_ref(), state.shown_plane(snap)) else {
        ui.label(state.error.clone().unwrap_or_else(|| "Measuring…".into()));
        return None;
    };
    let current = state.is_current(snap);
    let gates = model.gate_count();
    let gate = state.gate.min(gates.saturating_sub(1));
    let hash = |x: &dyn std::fmt::Debug| {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        format!("{x:?}").hash(&mut hasher);
        hasher.finish()
    };
    let plane_key = hash(&(Arc::as_ptr(snap) as usize, model.sensor(), gate, current));
    let measured = state.measured.as_ref();
    // One exposure over all gates (from the full measurement, even a stale one).
    let all_max = measured
        .and_then(|m| m.robust_max)
        .or_else(|| colormap::quantile_positive(plane.iter().copied(), 0.999));
    let status = match measured {
        Some(m) if current => format!("all {gates} gates measured in {:.0} ms", m.millis),
        _ => {
            let plane_ms = state.plane.as_ref().map_or(0.0, |p| p.millis);
            format!("gate {gate} measured in {plane_ms:.1} ms; all gates updating…")
        }
    };
    let ctx = ui.ctx().clone();
    let mut clicked = None;
    ui.horizontal(|ui| {
        let l = ui.label(format!("gate i (of {gates})"));
        ui.add(egui::Slider::new(gate_sel, 0..=gates.saturating_sub(1)))
            .labelled_by(l.id);
        ui.label(gate_time_label(model, gate));
        ui.label(RichText::new(&status).weak().small());
    });
    let avail = ui.available_size();
    let side = (avail.x - 16.0) / 2.0;
    let max = Vec2::new(side, avail.y - 40.0);
    ui.horizontal_top(|ui| {
        ui.vertical(|ui| {
            ui.label(RichText::new(format!("M_{gate} (one exposure over all gates)")).strong());
            let tone = Tone {
                scale: all_max.map_or(1.0, |m| 1.0 / m),
                log: false,
                decades: 3.0,
            };
            let tex = texture(textures, &ctx, "measurement", plane_key, || {
                egui::ColorImage::from_rgba_unmultiplied(
                    [w, h],
                    &colormap::colorize(plane, &tone, ColorMap::Inferno),
                )
            });
            if let Some(p) = pick(ui, &tex, w, h, max, "measurement image") {
                clicked = Some(p);
            }
        });
        let Some(m) = measured else {
            return;
        };
        let Some(depth) = m
            .depth_m
            .as_deref()
            .or(m.amcw.as_ref().map(|a| a.depth_m.as_slice()))
        else {
            return;
        };
        let key = hash(&(m.snapshot, &m.sensor));
        ui.vertical(|ui| {
            let (lo, hi) = m.depth_range;
            let title = if m.amcw_error_m.is_some() {
                "AMCW depth (m)"
            } else {
                "first-return depth (m)"
            };
            ui.label(RichText::new(format!("{title}: {lo:.3} … {hi:.3}")).strong());
            let small = Vec2::new(
                max.x,
                if m.amcw_error_m.is_some() {
                    max.y / 2.0 - 20.0
                } else {
                    max.y
                },
            );
            let tex = texture(textures, &ctx, "depth", key, || {
                depth_image(depth, w, h, lo, hi)
            });
            if let Some(p) = pick(ui, &tex, w, h, small, "depth image") {
                clicked = Some(p);
            }
            if let Some(err) = &m.amcw_error_m {
                let a = m.error_abs_max;
                ui.label(
                    RichText::new(format!(
                        "multipath error: AMCW − true first return, ±{a:.3} m"
                    ))
                    .strong(),
                );
                let tex = texture(textures, &ctx, "amcw-error", key, || {
                    error_image(err, w, h, a)
                });
                if let Some(p) = pick(ui, &tex, w, h, small, "multipath error image") {
                    clicked = Some(p);
                }
            }
        });
    });
    clicked
}

fn finite_range(v: &[f32]) -> (f32, f32) {
    let (lo, hi) = v
        .iter()
        .filter(|x| x.is_finite())
        .fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    if lo <= hi { (lo, hi) } else { (0.0, 0.0) }
}

/// Depth in turbo between `lo` and `hi`; no return is black.
fn depth_image(depth: &[f32], w: usize, h: usize, lo: f32, hi: f32) -> egui::ColorImage {
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    let px: Vec<u8> = depth
        .iter()
        .flat_map(|&d| {
            if d.is_finite() {
                let c = colorous::TURBO.eval_continuous(((d - lo) / span).clamp(0.0, 1.0) as f64);
                [c.r, c.g, c.b, 255]
            } else {
                [0, 0, 0, 255]
            }
        })
        .collect();
    egui::ColorImage::from_rgba_unmultiplied([w, h], &px)
}

/// Signed error, blue (too near) – white – red (too far), saturating at `a`.
fn error_image(err: &[f32], w: usize, h: usize, a: f32) -> egui::ColorImage {
    let a = a.max(f32::MIN_POSITIVE);
    let px: Vec<u8> = err
        .iter()
        .flat_map(|&e| {
            if e.is_finite() {
                let c = colorous::RED_BLUE
                    .eval_continuous((0.5 - 0.5 * (e / a).clamp(-1.0, 1.0)) as f64);
                [c.r, c.g, c.b, 255]
            } else {
                [0, 0, 0, 255]
            }
        })
        .collect();
    egui::ColorImage::from_rgba_unmultiplied([w, h], &px)
}

/// An image that reports the pixel clicked.
fn pick(
    ui: &mut egui::Ui,
    tex: &TextureHandle,
    w: usize,
    h: usize,
    max: Vec2,
    label: &str,
) -> Option<(usize, usize)> {
    let scale = (max.x / w as f32).min(max.y / h as f32).max(0.01);
    let r = ui.add(
        egui::Image::new((tex.id(), Vec2::new(w as f32, h as f32) * scale)).sense(Sense::click()),
    );
    r.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, label));
    let pos = r.interact_pointer_pos().filter(|_| r.clicked())?;
    let p = (pos - r.rect.min) / scale;
    Some((
        (p.x.max(0.0) as usize).min(w - 1),
        (p.y.max(0.0) as usize).min(h - 1),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn every_kind_makes_a_valid_sensor() {
        let axis = axis();
        for (lk, _) in LIGHT_KINDS {
            for (ek, _) in EXPOSURE_KINDS {
                let s = Sensor::new(
                    light_of_kind(lk, 0.0, axis.dt_s),
                    exposure_of_kind(ek, &axis),
                );
                SensorModel::new(s, axis).unwrap_or_else(|e| panic!("{lk} x {ek}: {e}"));
            }
        }
    }
}

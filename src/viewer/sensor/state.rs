//! What the sensor tab keeps between frames: the model with its kernels, the image of
//! the gate on screen, and the latest measurement of all gates, each keyed on the film
//! snapshot's [`FilmSnapshot::generation`] (an address would be reused by the next one).

use super::handles::Handle;
use super::measure::{
    Measured, SpadMeasured, SpadPreview, SpadView, Stage, background_pool, brightest_gate,
    follow_pool, measure_all, preview_pool, preview_spad, sample_spad, shared_white,
};
use super::view::TimeView;
use crate::viewer::textures::TextureCache;
use eframe::egui;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError, channel};
use std::time::{Duration, Instant};
use tprf_core::film::FilmSnapshot;
use tprf_core::sensor::{Echo, Measurements, NoiseField, PixelTrace, Sensor, SensorModel};
use tprf_core::transport::ambient::AmbientImage;

/// SPAD histograms on screen ([`SensorState::spad_shown`]) and what they are of.
#[derive(Clone, Copy)]
pub(super) struct SpadShown<'a> {
    pub(super) sp: &'a SpadMeasured,
    /// The film generation and sensor they were measured for.
    pub(super) snapshot: u64,
    pub(super) sensor: &'a Sensor,
    /// Whether they are of the current sensor and film (else an edit's are coming).
    pub(super) current: bool,
}

/// The shown gate's image, measured on the UI thread right after an edit.
pub(super) struct Plane {
    /// The film's [`FilmSnapshot::generation`].
    snapshot: u64,
    sensor: Sensor,
    gate: usize,
    values: Vec<f32>,
    pub(super) millis: f64,
}

/// A measurement of all gates running on a background thread: what it sends back, how
/// to cancel it, the sensor it measures and when it started.
struct Job {
    rx: Receiver<Stage>,
    cancel: Arc<AtomicBool>,
    sensor: Sensor,
    started: Instant,
    /// Whether it measures a newer pass of the film for the sensor already shown: then
    /// its first stage waits for its realisation ([`SensorState::pending`]), so the
    /// shown image never falls back from a realisation to the expected histogram.
    follow: bool,
}

/// What the sensor tab keeps between frames: the model with its kernels, the latest
/// measurements and their textures. The sensor being edited lives in the settings.
///
/// An edit is shown within the frame: the image of the gate on screen is measured at
/// once (one kernel over the film). All N gates, the noise and the derived depth are
/// measured on a background thread and replace it when done; the UI never waits. A
/// SPAD's expected histogram and depth come with them; its realisation and Coates
/// estimate follow from the same thread (the views that show them say "sampling"
/// meanwhile), and the next edit cancels a realisation being drawn. An edit of the
/// SPAD's own settings (or the noise) reuses the clean measurement of the last job.
/// Until the SPAD's histograms are those of the current sensor, a preview of them on
/// a coarse grid of pixels (`preview_spad`, on a thread of its own) is shown, marked
/// as one: it follows an edit within a frame or two.
///
/// While the renderer adds passes, the measurement of the current sensor stays on
/// screen (said to be of an earlier pass) and follows the film: a new snapshot never
/// cancels a measurement or a realisation under way; once both are done, and after a
/// pause as long as they took (so the sensor takes at most half of a core from the
/// renderer), the newest snapshot is measured, on threads below the renderer's
/// priority (`follow_pool`).
#[derive(Default)]
pub struct SensorState {
    pub(super) model: Option<SensorModel>,
    pub(super) measured: Option<Measured>,
    pub(super) plane: Option<Plane>,
    job: Option<Job>,
    /// The job drawing the SPAD's realisation after its first stage came back.
    sampling: Option<Job>,
    /// The first stage of a follow-up job, kept until its realisation is drawn.
    pending: Option<Box<Measured>>,
    /// When the last measurement of all gates (a SPAD's realisation included) ended,
    /// and how long it took: the next one for a newer film waits as long again.
    last_full: Option<(Instant, Duration)>,
    /// The latest SPAD preview, and the job making the next.
    preview: Option<SpadPreview>,
    preview_job: Option<Receiver<Result<SpadPreview, String>>>,
    /// The film generation and sensor of the preview job running or last started, and
    /// whether it failed (then it is not started again for them: its error is shown).
    preview_for: Option<(u64, Sensor)>,
    preview_failed: bool,
    noise_field: Option<NoiseField>,
    pub error: Option<String>,
    /// The gate shown, `i` (the TDC bin, for a SPAD).
    pub gate: usize,
    /// Which SPAD histogram the images show.
    pub(super) spad_view: SpadView,
    /// Which return the LiDAR depth image shows.
    pub echo: Echo,
    /// The editor's handle being dragged.
    pub(super) drag: Option<Handle>,
    /// The editor's time range (`None`: fit to the window and pulse when next drawn).
    pub(super) view: Option<TimeView>,
    /// The exposure shared by all gates' images and the sensor layout it was taken for
    /// (see [`layout_key`]).
    pub(super) white: Option<(String, Option<f64>)>,
    /// The layout the editor's view was fitted for.
    view_key: Option<String>,
    /// Whether the film's window starts at its first light (an automatic window):
    /// then no gate misses light before the window's start.
    pub auto_start: bool,
    pub(super) textures: TextureCache<u64>,
    /// The scene's ambient image (from the render worker, or `ambient.npy` beside a
    /// cube), added to every gate; set by [`SensorState::set_ambient`].
    pub(super) ambient: Option<Arc<AmbientImage>>,
    /// Wakes the window when a background result is ready or a follow-up is due.
    waker: Option<egui::Context>,
    /// Whether the sensor was checked against the film's window since the tab opened
    /// or a preset was picked ([`SensorState::fit_on_open`]).
    opened: bool,
    /// What that check changed, while the gates are still the ones it made.
    pub(super) fit_note: Option<FitNote>,
    /// The window of that check and the sensor as it left it: a new window refits a
    /// sensor still as left, and keeps an edited one.
    checked: Option<(tprf_core::film::TimeAxis, Sensor)>,
}

/// A preset fitted to the film's window when the tab opened on it: the note shown, the
/// gates it made, and the sensor as it was (to undo it).
pub(super) struct FitNote {
    pub(super) text: String,
    pub(super) fitted: tprf_core::sensor::Exposure,
    pub(super) original: Sensor,
}

impl SensorState {
    /// The ambient image the measurements use (`None`: the scene has none, or it is not
    /// rendered yet). A new one is measured with on the next update.
    pub fn set_ambient(&mut self, ambient: Option<Arc<AmbientImage>>) {
        if !same_ambient(&self.ambient, &ambient) {
            self.ambient = ambient;
        }
    }

    /// The context to wake when a background measurement is back or a follow-up of the
    /// film is due (without one the window sees them at its next frame).
    pub fn set_waker(&mut self, ctx: egui::Context) {
        self.waker = Some(ctx);
    }

    /// The first time the tab measures a film after it opened or a preset was picked,
    /// and whenever the film's window changes after: a preset none of whose gates see
    /// all their light in the window is fitted to it (`view::fitted_on_open`), and the
    /// tab says so (with a way back). A sensor the user edited since is kept on a new
    /// window, the tab saying which gates now see nothing.
    pub fn fit_on_open(&mut self, sensor: &mut Sensor, axis: &tprf_core::film::TimeAxis) {
        let same_window = self.checked.as_ref().is_some_and(|(a, _)| a == axis);
        if self.opened && same_window {
            return;
        }
        let refit = self.opened;
        if refit && let Some((_, left)) = self.checked.take() {
            if *sensor != left {
                self.checked = Some((*axis, sensor.clone()));
                self.fit_note =
                    super::view::gates_outside(sensor, axis, self.auto_start).map(|text| FitNote {
                        text,
                        fitted: sensor.exposure.clone(),
                        original: sensor.clone(),
                    });
                return;
            }
            // As the last check left it: fitted again from the preset as picked.
            if let Some(n) = self.fit_note.take()
                && n.original.exposure != n.fitted
            {
                *sensor = n.original;
            }
        }
        self.opened = true;
        if let Some((fitted, text)) = super::view::fitted_on_open(sensor, axis, self.auto_start) {
            let text = if refit {
                format!("The window changed. {text}")
            } else {
                text
            };
            self.fit_note = Some(FitNote {
                text,
                fitted: fitted.exposure.clone(),
                original: sensor.clone(),
            });
            *sensor = fitted;
        }
        self.checked = Some((*axis, sensor.clone()));
    }

    /// A preset was picked: it is checked against the film's window on the next frame.
    pub fn preset_picked(&mut self) {
        self.opened = false;
        self.fit_note = None;
        self.checked = None;
    }

    /// The ambient radiance of pixel `(y, x)`, W m^-2 sr^-1 (0 without an image).
    pub(super) fn ambient_at(&self, y: usize, x: usize) -> f64 {
        self.ambient
            .as_ref()
            .filter(|a| y < a.height && x < a.width)
            .map_or(0.0, |a| f64::from(a.radiance[y * a.width + x]))
    }

    /// Take in what the background jobs sent since the last frame.
    fn receive(&mut self) {
        if let Some(job) = &self.job {
            match job.rx.try_recv() {
                Ok(Stage::Measured(mut done)) => {
                    self.noise_field = Some(std::mem::take(&mut done.noise_field));
                    let sampling = done.spad.as_ref().is_some_and(|s| !s.is_sampled());
                    let job = self.job.take();
                    if sampling && job.as_ref().is_some_and(|j| j.follow) {
                        self.pending = Some(done);
                    } else {
                        self.replace_measured(*done);
                    }
                    if sampling {
                        self.sampling = job;
                    } else if let Some(j) = job {
                        self.last_full = Some((Instant::now(), j.started.elapsed()));
                    }
                }
                Ok(Stage::Sampled(_)) | Err(TryRecvError::Disconnected) => self.job = None,
                Err(TryRecvError::Empty) => {}
            }
        }
        if let Some(job) = &self.sampling {
            match job.rx.try_recv() {
                Ok(Stage::Sampled(s)) => {
                    self.last_full = Some((Instant::now(), job.started.elapsed()));
                    self.sampling = None;
                    if let Some(p) = self.pending.take() {
                        self.replace_measured(*p);
                    }
                    if let Some(m) = self.measured.as_mut() {
                        m.take_sampled(*s);
                    }
                }
                Ok(Stage::Measured(_)) | Err(TryRecvError::Disconnected) => {
                    self.sampling = None;
                    self.pending = None;
                }
                Err(TryRecvError::Empty) => {}
            }
        }
        if let Some(rx) = &self.preview_job {
            match rx.try_recv() {
                Ok(Ok(p)) => {
                    self.preview = Some(p);
                    self.preview_job = None;
                }
                Ok(Err(e)) => {
                    self.error = Some(e);
                    self.preview_job = None;
                    self.preview_failed = true;
                }
                Err(TryRecvError::Disconnected) => self.preview_job = None,
                Err(TryRecvError::Empty) => {}
            }
        }
    }

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
        // A new preset, kind, gate count or film window: the editor opens anew on the
        // window and the pulse, and on the gate that sees the most light.
        let layout = layout_key(model.sensor(), &axis);
        if self.view_key.as_ref() != Some(&layout) {
            self.view = None;
            self.view_key = Some(layout.clone());
            if let Some(g) = brightest_gate(&model, snap) {
                self.gate = g;
            }
        }
        let key = snap.generation();
        self.receive();
        let full = self
            .full_for(model.sensor(), snap)
            .map(|m| (m.snapshot, m.robust_max));
        // The shared exposure: from the full measurement once there is one of this
        // sensor; measured now on a small grid of pixels when the layout changed (a
        // preset picked), so the images never show another sensor's exposure.
        match full {
            Some((_, white)) => self.white = Some((layout.clone(), white)),
            None if self.white.as_ref().is_none_or(|w| w.0 != layout) => {
                self.white = Some((layout.clone(), shared_white(&model, snap)));
            }
            None => {}
        }
        match full {
            // The film moved on: its newest snapshot is measured once the last
            // measurement (and realisation) is done and as long again has passed.
            Some((measured_for, _)) if measured_for != key => {
                if self.job.is_none() && self.sampling.is_none() {
                    match self.follow_wait() {
                        None => self.spawn_measurement(&model, snap, true),
                        Some(wait) => {
                            if let Some(ctx) = &self.waker {
                                ctx.request_repaint_after(wait);
                            }
                        }
                    }
                }
            }
            Some(_) => {}
            // An edit (or a new film size, or ambient image): shown at once, measured
            // in full at the editing priority.
            None => self.after_edit(&model, snap),
        }
        self.model = Some(model);
    }

    /// Show `done` in place of the measurement shown. The one replaced (all gates of
    /// every pixel: 64 MiB for 256 gates at 256^2) is freed off the UI thread:
    /// unmapping it took a frame milliseconds.
    fn replace_measured(&mut self, done: Measured) {
        if let Some(old) = self.measured.replace(done) {
            free_elsewhere(old);
        }
    }

    /// How long the next measurement of a newer film must still wait: until the last
    /// one ended as long ago as it took. `None`: it may start now.
    fn follow_wait(&self) -> Option<Duration> {
        let (ended, took) = self.last_full?;
        took.checked_sub(ended.elapsed()).filter(|w| !w.is_zero())
    }

    /// After an edit: the gate on screen measured now, a SPAD's preview, and all gates
    /// in the background (a job or realisation of an earlier sensor given up).
    fn after_edit(&mut self, model: &SensorModel, snap: &Arc<FilmSnapshot>) {
        let key = snap.generation();
        let axis = *snap.axis();
        // The gate on screen, now; then all gates in the background (started after
        // it, so the frame's gate has the cores to itself: the LiDAR's frame after an
        // edit waited for it behind the background job).
        let gate = self.gate;
        let stale = self
            .plane
            .as_ref()
            .is_none_or(|p| p.snapshot != key || p.gate != gate || p.sensor != *model.sensor());
        // A SPAD shows its histograms, or the last ones until an edit's preview: the
        // bin's plain image is measured only before there are any.
        let spad_shown = self.spad_shown_for(model.sensor(), snap).is_some();
        if stale
            && !spad_shown
            && let Some(k) = model.kernels().get(gate)
        {
            let started = Instant::now();
            let packed = tprf_core::sensor::PackedKernels::new(std::slice::from_ref(k), axis.bins);
            let mut m = tprf_core::sensor::measure::measure_clean_film(&packed, snap);
            // The ambient light in this gate too (as the full measurement adds it).
            if let Some(a) = &self.ambient {
                tprf_core::sensor::pipeline::add_ambient_to_gate(
                    model,
                    gate,
                    &mut m.values,
                    &a.radiance,
                );
            }
            self.plane = Some(Plane {
                snapshot: key,
                sensor: model.sensor().clone(),
                gate,
                values: m.values,
                millis: started.elapsed().as_secs_f64() * 1e3,
            });
        }
        // A SPAD's preview, one at a time (each takes a frame or two; the one after an
        // edit made during it starts when it is back).
        if model.sensor().spad.is_some()
            && self.preview_job.is_none()
            && !self.preview_is_current_for(snap, model.sensor())
            && !(self.preview_failed
                && self
                    .preview_for
                    .as_ref()
                    .is_some_and(|(g, s)| *g == key && s == model.sensor()))
        {
            self.preview_for = Some((key, model.sensor().clone()));
            self.preview_failed = false;
            self.spawn_preview(model, snap);
        }
        // A SPAD's first stage for a sensor edited since is given up (the preview
        // stands in meanwhile), so that the current sensor's starts at once rather than
        // after it. (Other sensors' jobs are short: they finish, then the edit's runs.)
        if model.sensor().spad.is_some()
            && let Some(job) = &self.job
            && job.sensor != *model.sensor()
        {
            job.cancel.store(true, Ordering::Relaxed);
        }
        // A realisation being drawn for an earlier sensor.
        if let Some(s) = &self.sampling
            && s.sensor != *model.sensor()
        {
            s.cancel.store(true, Ordering::Relaxed);
            self.sampling = None;
            self.pending = None;
        }
        if self.job.is_none() && self.sampling.is_none() {
            self.spawn_measurement(model, snap, false);
        }
    }

    /// Make the SPAD preview of `snap` through `model` on [`preview_pool`]; it comes back
    /// through `preview_job`.
    fn spawn_preview(&mut self, model: &SensorModel, snap: &Arc<FilmSnapshot>) {
        let (tx, rx) = channel();
        let (job_model, job_snap) = (model.clone(), snap.clone());
        let job_ambient = self.ambient.clone();
        let waker = self.waker.clone();
        let spawned = spawn_on("tprf-spad-preview", preview_pool, move || {
            let done = preview_spad(&job_model, &job_snap, job_ambient);
            // The window may have gone on (or closed) meanwhile.
            let _ = tx.send(done);
            if let Some(ctx) = waker {
                ctx.request_repaint();
            }
        });
        match spawned {
            Ok(_) => self.preview_job = Some(rx),
            Err(e) => self.error = Some(format!("cannot start the SPAD preview thread: {e}")),
        }
    }

    /// Whether the SPAD preview is that of `sensor`, the ambient image and a film of
    /// `snap`'s size (a pass behind is fine: it stands in until the full image).
    fn preview_is_current_for(&self, snap: &FilmSnapshot, sensor: &Sensor) -> bool {
        self.preview.as_ref().is_some_and(|p| {
            p.sensor == *sensor
                && p.film_size == (snap.width(), snap.height())
                && same_ambient(&p.ambient, &self.ambient)
        })
    }

    /// Measure all gates of `snap` through `model` on a thread named `tprf-sensor`
    /// (the work itself on [`follow_pool`] when it `follow`s the film with the sensor
    /// shown, else on [`background_pool`]); the result comes back through `job`.
    fn spawn_measurement(&mut self, model: &SensorModel, snap: &Arc<FilmSnapshot>, follow: bool) {
        let pool = if follow { follow_pool } else { background_pool };
        let (tx, rx) = channel();
        let (job_model, job_snap) = (model.clone(), snap.clone());
        let job_ambient = self.ambient.clone();
        let field = self.noise_field.take().unwrap_or_default();
        let clean = self.measured.as_ref().map(|m| m.clean.clone());
        let cancel = Arc::new(AtomicBool::new(false));
        let job_cancel = cancel.clone();
        let waker = self.waker.clone();
        let wake = move || {
            if let Some(ctx) = &waker {
                ctx.request_repaint();
            }
        };
        // On pool threads of its own, so the gate measured for the frame does not queue
        // behind it on the global pool.
        let spawned = spawn_on("tprf-sensor", pool, move || {
            let run = || {
                let measured = measure_all(
                    &job_model,
                    &job_snap,
                    job_ambient,
                    field,
                    clean,
                    &job_cancel,
                )
                .ok()?;
                let sample = measured.spad.as_ref().is_some_and(|s| !s.is_sampled());
                // The realisation is drawn from a copy's inputs once the first stage
                // is on its way.
                let (m_model, m_clean) = (job_model.clone(), measured.clean.clone());
                let m_ambient = measured.ambient.clone();
                let (snapshot, sensor) = (measured.snapshot, measured.sensor.clone());
                let first = measured.spad.as_ref().map(|s| s.image.clone());
                tx.send(Stage::Measured(Box::new(measured))).ok()?;
                wake();
                if sample {
                    let stub = super::measure::SampleInput {
                        snapshot,
                        sensor,
                        clean: m_clean,
                        ambient: m_ambient,
                        image: first?,
                    };
                    let s = sample_spad(&m_model, &job_snap, &stub, &job_cancel)?;
                    tx.send(Stage::Sampled(Box::new(s))).ok()?;
                    wake();
                }
                Some(())
            };
            run();
        });
        match spawned {
            Ok(_) => {
                self.job = Some(Job {
                    rx,
                    cancel,
                    sensor: model.sensor().clone(),
                    started: Instant::now(),
                    follow,
                });
            }
            Err(e) => self.error = Some(format!("cannot start the measurement thread: {e}")),
        }
    }

    /// The latest measurement of all gates when it is of `sensor` (and the ambient
    /// image) on `snap`'s film: while the renderer runs it may be of an
    /// earlier pass ([`Measured::snapshot`]); it stays on screen until the next one.
    fn full_for(&self, sensor: &Sensor, snap: &FilmSnapshot) -> Option<&Measured> {
        self.measured.as_ref().filter(|m| {
            m.sensor == *sensor
                && m.film == snap.film()
                && (m.m.width, m.m.height) == (snap.width(), snap.height())
                && same_ambient(&m.ambient, &self.ambient)
        })
    }

    /// The measurement of all gates shown with the current sensor (see
    /// [`Self::full_for`]): of this film or an earlier pass of it.
    pub(super) fn full(&self, snap: &FilmSnapshot) -> Option<&Measured> {
        self.full_for(self.model.as_ref()?.sensor(), snap)
    }

    /// Whether the measurement of all gates is that of film `generation` and `sensor`.
    fn is_current_for(&self, generation: u64, sensor: &Sensor) -> bool {
        self.measured.as_ref().is_some_and(|m| {
            m.snapshot == generation
                && m.sensor == *sensor
                && same_ambient(&m.ambient, &self.ambient)
        })
    }

    /// Whether the measurements of all gates are those of the current sensor and of
    /// this very snapshot.
    pub fn is_current(&self, snap: &FilmSnapshot) -> bool {
        self.model
            .as_ref()
            .is_some_and(|m| self.is_current_for(snap.generation(), m.sensor()))
    }

    /// Whether the window shows a measurement of all gates through the current sensor
    /// (of this snapshot or, while the renderer runs, an earlier one of the same film).
    pub fn shows_full(&self, snap: &FilmSnapshot) -> bool {
        self.full(snap).is_some()
    }

    /// The film generation and samples per pixel of the measurement shown, when it is
    /// of the current sensor.
    pub fn shown_film(&self, snap: &FilmSnapshot) -> Option<(u64, u64)> {
        self.full(snap).map(|m| (m.snapshot, m.spp))
    }

    /// The image of the gate on screen, `[H, W]`, as the window shows it now: from the
    /// full measurement when there is one of the current sensor, else measured for this
    /// frame (no noise).
    pub fn shown_plane(&self, snap: &FilmSnapshot) -> Option<&[f32]> {
        if let Some(m) = self.full(snap) {
            return Some(m.m.plane(self.gate));
        }
        let model = self.model.as_ref()?;
        self.plane
            .as_ref()
            .filter(|p| {
                p.snapshot == snap.generation()
                    && p.gate == self.gate
                    && p.sensor == *model.sensor()
            })
            .map(|p| p.values.as_slice())
    }

    /// The white point all gates' images share (measurement units).
    pub fn shared_white(&self) -> Option<f64> {
        self.white.as_ref().and_then(|w| w.1)
    }

    /// The editor's time range in seconds, once it has been drawn.
    pub fn editor_view_s(&self) -> Option<(f64, f64)> {
        self.view.map(|v| (v.lo_s, v.hi_s))
    }

    /// The sensor model of the last valid sensor, with its kernels.
    pub fn model(&self) -> Option<&SensorModel> {
        self.model.as_ref()
    }

    /// The SPAD's latest full histograms, when they are those of the current sensor
    /// (of this film or an earlier pass of it).
    pub(super) fn spad(&self, snap: &FilmSnapshot) -> Option<&SpadMeasured> {
        self.full(snap)?.spad.as_ref()
    }

    /// The SPAD's histograms to show: the latest full ones when of the current sensor,
    /// else the preview when it is that of the current sensor (see
    /// [`SpadMeasured::step`]), else, in the frames between an edit and its preview,
    /// the latest preview or histograms of an earlier sensor or film, marked stale
    /// ([`SpadShown::current`]): the view keeps its images and layout while a drag goes
    /// on rather than falling back to the bin's plain measurement for a frame or two.
    pub(super) fn spad_shown(&self, snap: &FilmSnapshot) -> Option<SpadShown<'_>> {
        self.spad_shown_for(self.model.as_ref()?.sensor(), snap)
    }

    /// [`Self::spad_shown`] with `sensor` the current one.
    fn spad_shown_for(&self, sensor: &Sensor, snap: &FilmSnapshot) -> Option<SpadShown<'_>> {
        sensor.spad.as_ref()?;
        if let Some(m) = self.full_for(sensor, snap)
            && let Some(sp) = &m.spad
        {
            return Some(SpadShown {
                sp,
                snapshot: m.snapshot,
                sensor: &m.sensor,
                current: true,
            });
        }
        let full = self.measured.as_ref().and_then(|m| {
            m.spad.as_ref().map(|sp| SpadShown {
                sp,
                snapshot: m.snapshot,
                sensor: &m.sensor,
                current: false,
            })
        });
        let preview = self.preview.as_ref().map(|p| SpadShown {
            sp: &p.spad,
            snapshot: p.snapshot,
            sensor: &p.sensor,
            current: false,
        });
        if self.preview_is_current_for(snap, sensor) {
            return preview.map(|p| SpadShown { current: true, ..p });
        }
        // The newer of the two: a preview is started after every edit, so it is of a
        // later sensor than the full histograms unless those have caught up with it.
        // Only histograms of the film's size (a new resolution starts afresh).
        let fits = |s: &SpadShown| {
            let step = s.sp.step.max(1);
            (s.sp.image.width, s.sp.image.height)
                == (snap.width().div_ceil(step), snap.height().div_ceil(step))
        };
        let (preview, full) = (preview.filter(fits), full.filter(fits));
        match (preview, full) {
            (Some(p), Some(f)) if f.sensor == p.sensor && f.snapshot >= p.snapshot => Some(f),
            (p, f) => p.or(f),
        }
    }

    /// Milliseconds the shown SPAD preview took, when one is shown.
    pub fn preview_millis(&self, snap: &FilmSnapshot) -> Option<f64> {
        let model = self.model.as_ref()?;
        (self.spad(snap).is_none() && self.preview_is_current_for(snap, model.sensor()))
            .then(|| self.preview.as_ref().map(|p| p.millis))
            .flatten()
    }

    /// The latest SPAD preview when it is that of the current sensor on a film of this
    /// size (shown until the full histograms are), with its grid step: its pixel
    /// `(i, j)` is the film's `(i s + s / 2, j s + s / 2)`, clamped to the film.
    pub fn spad_preview(
        &self,
        snap: &FilmSnapshot,
    ) -> Option<(&tprf_core::sensor::SpadImage, usize)> {
        let model = self.model.as_ref()?;
        if !self.preview_is_current_for(snap, model.sensor()) {
            return None;
        }
        self.preview.as_ref().map(|p| (&p.spad.image, p.spad.step))
    }

    /// Whether the window shows the SPAD's preview (the full histograms are being
    /// measured).
    pub fn spad_previewing(&self, snap: &FilmSnapshot) -> bool {
        self.spad_shown(snap)
            .is_some_and(|s| s.current && s.sp.is_preview())
    }

    /// The SPAD's latest full histograms and depths (sensors with a `[spad]` section),
    /// when they are those of the current sensor (of this film or an earlier pass).
    pub fn spad_image(&self, snap: &FilmSnapshot) -> Option<&tprf_core::sensor::SpadImage> {
        self.spad(snap).map(|s| &s.image)
    }

    /// Whether a SPAD's realisation is being drawn (its expected histogram is shown).
    pub fn spad_sampling(&self) -> bool {
        self.sampling.is_some()
    }

    /// The latest measurements `[N, H, W]`.
    pub fn measurements(&self) -> Option<&Measurements> {
        self.measured.as_ref().map(|m| &m.m)
    }

    /// One pixel's trace through the sensor: TPRF, TPRF * Light, M_i before noise.
    pub fn pixel_trace(&self, tprf: &[f32]) -> Option<PixelTrace> {
        self.model.as_ref()?.pixel_trace(tprf).ok()
    }
}

/// What fixes the layout of a sensor over a film: its name, light and gate kinds, gate
/// count and the film's window. A new one refits the editor and retakes the exposure.
fn layout_key(sensor: &Sensor, axis: &tprf_core::film::TimeAxis) -> String {
    format!(
        "{}|{}|{}|{}|{}|{}|{}",
        sensor.name,
        sensor.light.kind_name(),
        sensor.exposure.kind_name(),
        sensor.exposure.count(),
        axis.t0_s,
        axis.dt_s,
        axis.bins
    )
}

/// Whether two ambient images are the same one (by identity), or both absent.
fn same_ambient(a: &Option<Arc<AmbientImage>>, b: &Option<Arc<AmbientImage>>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => Arc::ptr_eq(a, b),
        (None, None) => true,
        _ => false,
    }
}

/// Drop `value` on the background pool (or a thread of its own), not on the caller's.
fn free_elsewhere<T: Send + 'static>(value: T) {
    match background_pool() {
        Some(pool) => pool.spawn(move || drop(value)),
        None => {
            if let Err(e) = std::thread::Builder::new().spawn(move || drop(value)) {
                // The thread was not made: the closure (and the value) dropped here.
                eprintln!("tprf: freeing a measurement on the UI thread: {e}");
            }
        }
    }
}

/// Run `job` on a new thread named `name`, inside `pool()` when it has one (else on the
/// global pool), so its parallel work stays on that pool's threads.
fn spawn_on(
    name: &str,
    pool: fn() -> Option<&'static rayon::ThreadPool>,
    job: impl FnOnce() + Send + 'static,
) -> std::io::Result<()> {
    std::thread::Builder::new()
        .name(name.into())
        .spawn(move || match pool() {
            Some(p) => p.install(job),
            None => job(),
        })
        .map(drop)
}

#[cfg(test)]
mod tests {
    use super::super::view::{Coverage, coverage, main_span};
    use super::*;
    use tprf_core::film::TimeAxis;
    use tprf_core::sensor::SensorModel;

    /// Whether every gate of `sensor` sees all its light in `axis` (not at first light).
    fn fits(sensor: &Sensor, axis: TimeAxis) -> bool {
        let m = SensorModel::new(sensor.clone(), axis).unwrap();
        let pulse = main_span(m.light());
        m.gates()
            .iter()
            .all(|g| coverage(g, pulse, &axis, false) == Coverage::Inside)
    }

    /// A preset the user has not edited is fitted again when the window moves (an XML
    /// scene's window 3.4 us away: the 1 ns gates at 0-256 ns would see nothing), and
    /// says so; an edited one is kept, the tab saying which gates see nothing.
    #[test]
    fn a_new_window_refits_an_unedited_preset_and_keeps_an_edited_one() {
        let mut state = SensorState::default();
        let mut sensor = Sensor::builtin("lidar").unwrap();
        let near = TimeAxis::new(3.5e-9, 50e-12, 256).unwrap();
        state.fit_on_open(&mut sensor, &near);
        assert!(fits(&sensor, near));
        let fitted_near = sensor.clone();
        // The same window again: nothing changes.
        state.fit_on_open(&mut sensor, &near);
        assert_eq!(sensor, fitted_near);
        let far = TimeAxis::new(3369e-9, 20e-9, 400).unwrap();
        state.fit_on_open(&mut sensor, &far);
        assert!(fits(&sensor, far), "refitted to the far window");
        let note = state.fit_note.as_ref().expect("a note").text.clone();
        assert!(note.starts_with("The window changed."), "{note}");
        // Back on the near window: fitted from the preset, as the first time.
        state.fit_on_open(&mut sensor, &near);
        assert_eq!(sensor, fitted_near);
        // Edited: kept on a new window, and the gates that see nothing named.
        if let tprf_core::sensor::Exposure::Box { start_s, .. } = &mut sensor.exposure {
            *start_s = 20e-6;
        }
        let edited = sensor.clone();
        state.fit_on_open(&mut sensor, &far);
        assert_eq!(sensor, edited);
        let note = state.fit_note.as_ref().expect("a note").text.clone();
        assert!(
            note.contains("your gates are kept") && note.contains("see nothing"),
            "{note}"
        );
    }
}

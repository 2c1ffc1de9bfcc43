//! All gates of a film through the sensor, with noise and the derived depth images, on
//! a pool of half the cores so the gate measured for the frame does not queue behind.
//! A SPAD's realisation and Coates estimate come in a second stage ([`sample_spad`]),
//! after its expected histogram and depth have been handed to the window, in bands of
//! rows so that an edit cancels it between two bands. Before either, a SPAD's preview
//! ([`preview_spad`]): the expected histogram and depth on a coarse grid of pixels,
//! measured on a thread of its own within a frame or two of an edit.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;
use tprf_core::film::FilmSnapshot;
use tprf_core::sensor::{
    AmcwImage, Draws, Echo, Gates, Measurements, NoiseField, Pipeline, ReturnImages, Sensor,
    SensorModel, SpadImage, derived,
};
use tprf_core::transport::ambient::AmbientImage;

/// Which of the SPAD's histograms the images show.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SpadView {
    /// The expected histogram over all cycles.
    #[default]
    Expected,
    /// One seeded realisation.
    Counts,
    /// The Coates estimate of the realisation (pile-up undone).
    Coates,
}

impl SpadView {
    pub(super) const ALL: [SpadView; 3] = [SpadView::Expected, SpadView::Counts, SpadView::Coates];

    pub(super) fn label(self) -> &'static str {
        match self {
            SpadView::Expected => "expected",
            SpadView::Counts => "one realisation",
            SpadView::Coates => "Coates",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// A SPAD image with its exposures and depth ranges per view.
pub(super) struct SpadMeasured {
    pub(super) image: SpadImage,
    /// 1: the image holds every pixel of the film. `s > 1`: a preview, whose pixel
    /// `(i, j)` is the film's `(i s + s / 2, j s + s / 2)` (clamped to the film) and
    /// stands for the `s x s` block from `(i s, j s)` ([`preview_spad`]).
    pub(super) step: usize,
    robust_max: [Option<f64>; 3],
    /// The expected histogram's depth range: one colour range for every view, so the
    /// realisation's and Coates's depths compare with it (outliers saturate).
    depth_range: (f32, f32),
}

impl SpadMeasured {
    /// Whether the realisation and its Coates estimate are drawn (until then the views
    /// that show them show the expected histogram, with a note).
    pub(super) fn is_sampled(&self) -> bool {
        self.image.is_sampled()
    }

    /// The view shown for `view`: the expected histogram while the realisation is drawn.
    pub(super) fn shown(&self, view: SpadView) -> SpadView {
        if self.is_sampled() {
            view
        } else {
            SpadView::Expected
        }
    }

    fn new(image: SpadImage) -> SpadMeasured {
        let views = SpadView::ALL;
        let robust_max = views.map(|v| tprf_core::film::robust_max(spad_values(&image, v)));
        let depth_range = finite_range(spad_depth(&image, SpadView::Expected));
        SpadMeasured {
            image,
            step: 1,
            robust_max,
            depth_range,
        }
    }

    /// Whether this is a preview on a coarse grid (see [`Self::step`]).
    pub(super) fn is_preview(&self) -> bool {
        self.step > 1
    }

    /// Bin `k` of `values` (a `[B, h, w]` array of this image) at the film's `w x h`:
    /// a preview's pixels repeated over their blocks.
    pub(super) fn film_plane<'a>(
        &self,
        values: &'a [f32],
        k: usize,
        (w, h): (usize, usize),
    ) -> std::borrow::Cow<'a, [f32]> {
        let plane = self.image.plane(values, k);
        self.at_film(plane, (w, h))
    }

    /// An `[h, w]` array of this image at the film's `w x h` (see [`Self::film_plane`]).
    pub(super) fn at_film<'a>(
        &self,
        plane: &'a [f32],
        (w, h): (usize, usize),
    ) -> std::borrow::Cow<'a, [f32]> {
        if self.step <= 1 {
            return std::borrow::Cow::Borrowed(plane);
        }
        let (gw, s) = (self.image.width, self.step);
        if plane.len() != gw * self.image.height {
            return std::borrow::Cow::Owned(Vec::new());
        }
        let mut out = Vec::with_capacity(w * h);
        for y in 0..h {
            let row = &plane[(y / s) * gw..(y / s + 1) * gw];
            out.extend((0..w).map(|x| row[(x / s).min(gw - 1)]));
        }
        std::borrow::Cow::Owned(out)
    }

    /// The `[B, H, W]` array of `view` ([`Self::shown`]).
    pub(super) fn values(&self, view: SpadView) -> &[f32] {
        spad_values(&self.image, self.shown(view))
    }

    pub(super) fn depth(&self, view: SpadView) -> &[f32] {
        spad_depth(&self.image, self.shown(view))
    }

    pub(super) fn robust_max(&self, view: SpadView) -> Option<f64> {
        self.robust_max[self.shown(view).index()]
    }

    pub(super) fn depth_range(&self) -> (f32, f32) {
        self.depth_range
    }
}

fn spad_values(image: &SpadImage, view: SpadView) -> &[f32] {
    match view {
        SpadView::Expected => &image.histogram,
        SpadView::Counts => &image.counts,
        SpadView::Coates => &image.coates,
    }
}

fn spad_depth(image: &SpadImage, view: SpadView) -> &[f32] {
    match view {
        SpadView::Expected => &image.depth_histogram_m,
        SpadView::Counts => &image.depth_counts_m,
        SpadView::Coates => &image.depth_coates_m,
    }
}

/// The measurements of one (snapshot, sensor) pair and what is derived from them.
pub(super) struct Measured {
    /// The film's [`FilmSnapshot::generation`], its [`FilmSnapshot::film`] and its
    /// samples per pixel.
    pub(super) snapshot: u64,
    pub(super) film: u64,
    pub(super) spp: u64,
    pub(super) sensor: Sensor,
    /// The ambient image it was measured with (compared by identity).
    pub(super) ambient: Option<Arc<AmbientImage>>,
    pub(super) m: Measurements,
    pub(super) returns: Option<ReturnImages>,
    pub(super) amcw: Option<AmcwImage>,
    /// The SPAD's histograms and depths, when the sensor has one.
    pub(super) spad: Option<SpadMeasured>,
    /// AMCW depth minus the depth of the TPRF's own first return (multipath error), m.
    pub(super) amcw_error_m: Option<Vec<f32>>,
    /// FLIM's two-gate lifetime `[H, W]`, seconds, when the sensor asks for it
    /// ([`tprf_core::sensor::derived::flim_lifetime_s`]).
    pub(super) flim_lifetime_s: Option<Vec<f32>>,
    pub(super) millis: f64,
    /// Milliseconds the SPAD's realisation took, once drawn.
    pub(super) sample_millis: Option<f64>,
    /// The clean measurement (no ambient, no noise) of the film and the sensor's light
    /// and gates, shared with the next measurement when only the rest of the sensor
    /// changes (a SPAD's own settings, the noise).
    pub(super) clean: Arc<CleanKey>,
    /// One exposure for all gates: [`shared_white`] of the film and sensor.
    pub(super) robust_max: Option<f64>,
    /// Finite range of the depth image (m), and the largest |multipath error| (m).
    pub(super) depth_range: (f32, f32),
    pub(super) error_abs_max: f32,
    /// The lifetime image's colour range, seconds: 0 to the 99th percentile of its
    /// finite values (a few spot-edge pixels with little light read far longer).
    pub(super) lifetime_top_s: f32,
    /// The noise draws, handed back to be reused by the next measurement.
    pub(super) noise_field: NoiseField,
}

impl Measured {
    /// How many derived images are shown beside the measurement: depth, multipath
    /// error, lifetime.
    pub(super) fn smalls(&self) -> usize {
        usize::from(self.depth(Echo::First).is_some())
            + usize::from(self.amcw_error_m.is_some())
            + usize::from(self.flim_lifetime_s.is_some())
    }

    /// The depth image shown: the return `echo`'s depth, else AMCW depth.
    pub(super) fn depth(&self, echo: Echo) -> Option<&[f32]> {
        match &self.returns {
            Some(r) => Some(r.depth(echo)),
            None => self.amcw.as_ref().map(|a| a.depth_m.as_slice()),
        }
    }
}

/// A clean measurement `sum_b TPRF[b] K_i[b]` and what it depends on.
pub(super) struct CleanKey {
    pub(super) snapshot: u64,
    pub(super) light: tprf_core::sensor::LightPulse,
    pub(super) exposure: tprf_core::sensor::Exposure,
    pub(super) m: Measurements,
}

impl CleanKey {
    /// Whether this is the clean measurement of film `generation` through `sensor`.
    pub(super) fn is_for(&self, generation: u64, sensor: &Sensor) -> bool {
        self.snapshot == generation
            && self.light == sensor.light
            && self.exposure == sensor.exposure
    }
}

/// Pixel-bins a SPAD preview computes at most (the grid's pixels times the TDC bins):
/// its grid step is the smallest that stays under it, 6 at 160 x 160 x 512. The
/// preview's cost is about this many steps of the recursion, whatever the film's size.
pub(super) const PREVIEW_PIXEL_BINS: usize = 1 << 19;

/// The step of the preview grid for a film of `w x h` pixels and a TDC of `bins`:
/// `ceil(sqrt(w h B / PREVIEW_PIXEL_BINS))`, 1 when the whole image fits.
pub(super) fn preview_step(w: usize, h: usize, bins: usize) -> usize {
    let work = (w as f64) * (h as f64) * (bins.max(1) as f64);
    (work / PREVIEW_PIXEL_BINS as f64).sqrt().ceil().max(1.0) as usize
}

/// A SPAD's preview for (snapshot, sensor, ambient): [`preview_spad`].
pub(super) struct SpadPreview {
    pub(super) snapshot: u64,
    /// The film's width and height.
    pub(super) film_size: (usize, usize),
    pub(super) sensor: Sensor,
    pub(super) ambient: Option<Arc<AmbientImage>>,
    pub(super) spad: SpadMeasured,
    pub(super) millis: f64,
}

/// The SPAD's expected histogram and depth of `snap` through `model` on every
/// [`preview_step`]-th pixel in each direction (the pixel at the middle of each block):
/// those pixels' TPRFs, clean measurement, steady and ambient values gathered into a
/// small film and put through [`Pipeline::spad_expected`] as the full image is. Each preview
/// pixel's values are exactly the full image's at that pixel; only the pixels between
/// are missing (shown as their block's).
pub(super) fn preview_spad(
    model: &SensorModel,
    snap: &FilmSnapshot,
    ambient_image: Option<Arc<AmbientImage>>,
) -> Result<SpadPreview, String> {
    let started = Instant::now();
    let (w, h, t) = (snap.width(), snap.height(), snap.axis().bins);
    let s = preview_step(w, h, model.gate_count());
    let (gw, gh) = (w.div_ceil(s), h.div_ceil(s));
    let at = |i: usize, n: usize| (i * s + s / 2).min(n.saturating_sub(1));
    let ambient = ambient_image
        .as_deref()
        .filter(|a| a.width == w && a.height == h)
        .map(|a| a.radiance.as_slice());
    let mut cube = Vec::with_capacity(gw * gh * t);
    let mut steady = Vec::with_capacity(gw * gh);
    let mut amb = ambient.map(|_| Vec::with_capacity(gw * gh));
    for j in 0..gh {
        for i in 0..gw {
            let (x, y) = (at(i, w), at(j, h));
            let mut tprf = snap.pixel(x, y);
            tprf.resize(t, 0.0);
            cube.extend_from_slice(&tprf);
            steady.push(snap.steady().get(y * w + x).copied().unwrap_or(0.0));
            if let (Some(a), Some(out)) = (ambient, amb.as_mut()) {
                out.push(a[y * w + x]);
            }
        }
    }
    let clean = model
        .measure_clean(&cube, gw, gh)
        .map_err(|e| e.to_string())?;
    let image = Pipeline {
        model,
        clean: &clean,
        steady: &steady,
        ambient: amb.as_deref(),
    }
    .spad_expected(&AtomicBool::new(false))
    .map_err(|e| e.to_string())?
    .ok_or("the sensor has no SPAD")?;
    let mut spad = SpadMeasured::new(image);
    spad.step = s;
    Ok(SpadPreview {
        snapshot: snap.generation(),
        film_size: (w, h),
        sensor: model.sensor().clone(),
        ambient: ambient_image,
        spad,
        millis: started.elapsed().as_secs_f64() * 1e3,
    })
}

/// One thread for SPAD previews, beside [`background_pool`]: a preview never queues
/// behind the measurement of all gates.
pub(super) fn preview_pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: std::sync::OnceLock<Option<rayon::ThreadPool>> = std::sync::OnceLock::new();
    POOL.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .thread_name(|_| "tprf-spad-preview".into())
            .build()
            .ok()
    })
    .as_ref()
}

/// What a measurement job sends back: all gates with the SPAD's expected histogram
/// first, then (SPAD only) the realisation.
pub(super) enum Stage {
    Measured(Box<Measured>),
    Sampled(Box<Sampled>),
}

/// A SPAD's realisation, Coates estimate and their depths for (snapshot, sensor).
pub(super) struct Sampled {
    pub(super) snapshot: u64,
    pub(super) sensor: Sensor,
    pub(super) image: SpadImage,
    pub(super) millis: f64,
}

/// Pixels the shared exposure reads: a grid of about [`WHITE_PIXELS`] pixels.
const WHITE_PIXELS: usize = 256;

/// The pixels of the grid [`shared_white`] reads.
fn white_sample(w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    let step = ((w * h) as f64 / WHITE_PIXELS as f64)
        .sqrt()
        .ceil()
        .max(1.0) as usize;
    let (ox, oy) = (step / 2, step / 2);
    (0..h.div_ceil(step)).flat_map(move |j| {
        (0..w.div_ceil(step)).filter_map(move |i| {
            let (x, y) = (ox + i * step, oy + j * step);
            (x < w && y < h).then_some((x, y))
        })
    })
}

/// The white point shared by every gate's image: the 99.9 % quantile of the positive
/// clean measurements of all gates on a fixed grid of about [`WHITE_PIXELS`] pixels.
/// Cheap enough to compute in the frame right after a preset is picked, and the same
/// number the background measurement reports for that film and sensor, so the images
/// do not change brightness when all gates arrive.
pub(super) fn shared_white(model: &SensorModel, snap: &FilmSnapshot) -> Option<f64> {
    let mut values = Vec::new();
    for (x, y) in white_sample(snap.width(), snap.height()) {
        let tprf = snap.pixel(x, y);
        values.extend(model.kernels().iter().map(|k| k.dot(&tprf) as f32));
    }
    tprf_core::film::quantile_positive(values.into_iter(), 0.999)
}

/// The gate that measures the most light over the grid of [`shared_white`]: the one the
/// tab opens on (a LiDAR's first gates see nothing before its pulse has fired). `None`
/// when no gate sees any light.
pub(super) fn brightest_gate(model: &SensorModel, snap: &FilmSnapshot) -> Option<usize> {
    let mut sums = vec![0.0f64; model.kernels().len()];
    for (x, y) in white_sample(snap.width(), snap.height()) {
        let tprf = snap.pixel(x, y);
        for (s, k) in sums.iter_mut().zip(model.kernels()) {
            *s += k.dot(&tprf);
        }
    }
    sums.iter()
        .enumerate()
        .filter(|(_, s)| s.is_finite() && **s > 0.0)
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(i, _)| i)
}

/// Nice value of [`background_pool`]'s threads: the UI thread and the SPAD preview
/// (nice 0) are scheduled before them when both want a core (Linux's fair scheduler
/// weighs nice 5 at a third of nice 0), the renderer's threads (nice 10) after them:
/// what an edit asks for comes first.
const BACKGROUND_NICE: i32 = 5;

/// Nice value of [`follow_pool`]'s threads: below the renderer's (nice 10, which
/// Linux weighs at three times nice 15), so measuring each new pass of the film does
/// not slow the render that makes it.
const FOLLOW_NICE: i32 = 15;

/// Lower the calling thread's priority to `nice` (Linux, where a nice value is per
/// thread; elsewhere nothing). Lowering needs no privilege; raising it back would.
fn lower_priority(nice: i32) {
    #[cfg(target_os = "linux")]
    // SAFETY: setpriority with `who = 0` changes only the calling thread's nice value.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, 0, nice);
    }
    #[cfg(not(target_os = "linux"))]
    let _ = nice;
}

/// Threads for the measurements after an edit: half the cores, at [`BACKGROUND_NICE`].
pub(super) fn background_pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: std::sync::OnceLock<Option<rayon::ThreadPool>> = std::sync::OnceLock::new();
    POOL.get_or_init(|| {
        let n = std::thread::available_parallelism().map_or(1, |n| n.get());
        rayon::ThreadPoolBuilder::new()
            .num_threads((n / 2).max(1))
            .thread_name(|i| format!("tprf-sensor-{i}"))
            .start_handler(|_| lower_priority(BACKGROUND_NICE))
            .build()
            .ok()
    })
    .as_ref()
}

/// Threads for measuring a newer pass of the film with an unchanged sensor: half the
/// cores, at [`FOLLOW_NICE`].
pub(super) fn follow_pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: std::sync::OnceLock<Option<rayon::ThreadPool>> = std::sync::OnceLock::new();
    POOL.get_or_init(|| {
        let n = std::thread::available_parallelism().map_or(1, |n| n.get());
        rayon::ThreadPoolBuilder::new()
            .num_threads((n / 2).max(1))
            .thread_name(|i| format!("tprf-follow-{i}"))
            .start_handler(|_| lower_priority(FOLLOW_NICE))
            .build()
            .ok()
    })
    .as_ref()
}

/// All gates of `snap` through `model`, with noise (drawn into `noise_field`, reused)
/// and derived outputs; a SPAD's expected histogram and its depth, not yet its
/// realisation ([`sample_spad`]). `clean` is the clean measurement of a previous job,
/// reused when it is that of this film, light and gates.
pub(super) fn measure_all(
    model: &SensorModel,
    snap: &FilmSnapshot,
    ambient_image: Option<Arc<AmbientImage>>,
    mut noise_field: NoiseField,
    clean: Option<Arc<CleanKey>>,
    cancel: &AtomicBool,
) -> Result<Measured, String> {
    let started = Instant::now();
    let sensor = model.sensor();
    let clean = match clean.filter(|c| c.is_for(snap.generation(), sensor)) {
        Some(c) => c,
        None => Arc::new(CleanKey {
            snapshot: snap.generation(),
            light: sensor.light.clone(),
            exposure: sensor.exposure.clone(),
            m: model.measure_clean_film(snap),
        }),
    };
    // The scene's ambient image, when it has one of the film's size.
    let ambient = ambient_image
        .as_deref()
        .filter(|a| a.width == snap.width() && a.height == snap.height())
        .map(|a| a.radiance.as_slice());
    // The sensor's steps after the clean one, in the order tprf sensor takes them.
    let pipeline = Pipeline {
        model,
        clean: &clean.m,
        steady: snap.steady(),
        ambient,
    };
    let spad = match model.sensor().spad {
        Some(_) => Some(SpadMeasured::new(
            pipeline
                .spad_expected(cancel)
                .map_err(|e| e.to_string())?
                .ok_or("cancelled by an edit")?,
        )),
        None => None,
    };
    let Gates {
        m,
        returns,
        amcw,
        flim_lifetime_s,
        ..
    } = pipeline
        .gates(Draws::Kept(&mut noise_field))
        .map_err(|e| e.to_string())?;
    let robust_max = shared_white(model, snap);
    let amcw_error_m = amcw.as_ref().map(|a| {
        let truth = derived::tprf_first_return_depth_film(snap, &Default::default());
        a.depth_m.iter().zip(&truth).map(|(d, t)| d - t).collect()
    });
    let error_abs_max = amcw_error_m.as_ref().map_or(0.0, |e: &Vec<f32>| {
        e.iter()
            .filter(|x| x.is_finite())
            .fold(0.0f32, |a, x| a.max(x.abs()))
    });
    let lifetime_top_s = flim_lifetime_s.as_deref().map_or(0.0, |t| {
        tprf_core::film::quantile(t.iter().map(|&x| f64::from(x)), 0.99).unwrap_or(0.0) as f32
    });
    let mut measured = Measured {
        snapshot: snap.generation(),
        film: snap.film(),
        spp: snap.spp,
        sensor: model.sensor().clone(),
        ambient: ambient_image.clone(),
        m,
        returns,
        amcw,
        spad,
        amcw_error_m,
        flim_lifetime_s,
        millis: started.elapsed().as_secs_f64() * 1e3,
        sample_millis: None,
        clean,
        robust_max,
        depth_range: (0.0, 0.0),
        error_abs_max,
        lifetime_top_s,
        noise_field,
    };
    // One range for every return's image, so that switching between them compares.
    measured.depth_range = match &measured.returns {
        Some(r) => finite_range(
            r.depth_m
                .iter()
                .chain(&r.strongest_m)
                .chain(&r.last_m)
                .copied()
                .collect::<Vec<_>>()
                .as_slice(),
        ),
        None => measured.depth(Echo::First).map_or((0.0, 0.0), finite_range),
    };
    Ok(measured)
}

/// What [`sample_spad`] draws from: the first stage's SPAD image and its inputs.
pub(super) struct SampleInput {
    pub(super) snapshot: u64,
    pub(super) sensor: Sensor,
    pub(super) clean: Arc<CleanKey>,
    pub(super) ambient: Option<Arc<AmbientImage>>,
    pub(super) image: SpadImage,
}

/// Rows a band of [`sample_spad`] holds: about 16 bands an image, at least 4 rows.
fn sample_band_rows(height: usize) -> usize {
    height.div_ceil(16).max(4)
}

/// The realisation of `measured`'s SPAD image (drawn with its sampler, from the clean
/// measurement it was made from), its Coates estimate and their depths, a band of rows
/// at a time; `None` when `cancel` is set between two bands (an edit made it stale) or
/// there is nothing to draw.
pub(super) fn sample_spad(
    model: &SensorModel,
    snap: &FilmSnapshot,
    measured: &SampleInput,
    cancel: &AtomicBool,
) -> Option<Sampled> {
    let started = Instant::now();
    let clean = &measured.clean.m;
    let ambient = measured
        .ambient
        .as_deref()
        .filter(|a| a.width == snap.width() && a.height == snap.height())
        .map(|a| a.radiance.as_slice());
    let (w, h, b) = (clean.width, clean.height, clean.gates);
    let pipeline = Pipeline {
        model,
        clean,
        steady: snap.steady(),
        ambient,
    };
    let mut image = SpadImage {
        counts: vec![0.0; b * w * h],
        coates: vec![0.0; b * w * h],
        depth_counts_m: vec![f32::NAN; w * h],
        depth_coates_m: vec![f32::NAN; w * h],
        ..measured.image.clone()
    };
    let rows = sample_band_rows(h);
    for y0 in (0..h).step_by(rows) {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        let n = rows.min(h - y0);
        let band = pipeline.spad_rows(image.sampler, y0, n).ok()?;
        for k in 0..b {
            let (from, to) = (k * n * w..(k + 1) * n * w, k * h * w + y0 * w);
            image.counts[to..to + n * w].copy_from_slice(&band.counts[from.clone()]);
            image.coates[to..to + n * w].copy_from_slice(&band.coates[from]);
        }
        image.depth_counts_m[y0 * w..(y0 + n) * w].copy_from_slice(&band.depth_counts_m);
        image.depth_coates_m[y0 * w..(y0 + n) * w].copy_from_slice(&band.depth_coates_m);
    }
    Some(Sampled {
        snapshot: measured.snapshot,
        sensor: measured.sensor.clone(),
        image,
        millis: started.elapsed().as_secs_f64() * 1e3,
    })
}

impl Measured {
    /// Takes in the realisation `s` when it is that of this measurement.
    pub(super) fn take_sampled(&mut self, s: Sampled) {
        if s.snapshot != self.snapshot || s.sensor != self.sensor {
            return;
        }
        if let Some(sp) = self.spad.as_mut() {
            *sp = SpadMeasured::new(s.image);
            self.sample_millis = Some(s.millis);
        }
    }
}

/// The smallest and largest finite values, `(0, 0)` when there are none.
fn finite_range(v: &[f32]) -> (f32, f32) {
    let (lo, hi) = v
        .iter()
        .filter(|x| x.is_finite())
        .fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    if lo <= hi { (lo, hi) } else { (0.0, 0.0) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tprf_core::film::{FilmLayout, TimeAxis};
    use tprf_core::sensor::{Exposure, LightPulse, TimeOrigin};

    /// One box gate over the whole window and a delta pulse at 0: each pixel measures
    /// its steady value, so the shared white is the top of the sampled steady values
    /// (pixel p of the ramp film sums to 10 (p + 1) + 45 over 10 bins).
    #[test]
    fn the_shared_white_is_a_quantile_of_the_sampled_measurements() {
        let (side, bins) = (40, 10);
        let layout = FilmLayout {
            width: side,
            height: side,
            axis: TimeAxis::new(1e-9, 1e-10, bins).unwrap(),
            bounces_separate: 0,
            luminescence: false,
        };
        let cube: Vec<f32> = (0..side * side * bins)
            .map(|i| ((i / bins) + (i % bins) + 1) as f32)
            .collect();
        let snap = FilmSnapshot::from_dense(layout, 1, 1, &cube, &[], None);
        let sensor = Sensor::new(
            LightPulse::Delta {
                t_s: 0.0,
                energy: 1.0,
            },
            Exposure::Box {
                origin: TimeOrigin::Window,
                start_s: 0.0,
                width_s: 1e-9,
                step_s: None,
                count: 1,
                gain: 1.0,
            },
        );
        let model = SensorModel::new(sensor, layout.axis).unwrap();
        let white = shared_white(&model, &snap).expect("a white point");
        // The grid: every 3rd pixel from (1, 1) (40 x 40 / 256 -> step 3); the
        // largest sampled pixel is (37, 37), p = 37 * 40 + 37.
        let p = 37.0 * 40.0 + 37.0;
        let top = 10.0 * (p + 1.0) + 45.0;
        assert!(
            white <= top * (1.0 + 1e-6) && white > 0.9 * top,
            "{white} vs {top}"
        );
    }

    /// Every pixel returns light at 10 ns; the gated preset's 1 ns pulse from the
    /// trigger puts it at 10-11.1 ns, inside gate 3 of its 3 ns gates from 0 ns.
    #[test]
    fn the_tab_opens_on_the_gate_that_sees_the_light() {
        let (side, bins) = (8, 240);
        let layout = FilmLayout {
            width: side,
            height: side,
            axis: TimeAxis::new(0.0, 1e-10, bins).unwrap(),
            bounces_separate: 0,
            luminescence: false,
        };
        let mut cube = vec![0.0f32; side * side * bins];
        for p in 0..side * side {
            cube[p * bins + 100] = 1.0;
        }
        let snap = FilmSnapshot::from_dense(layout, 1, 1, &cube, &[], None);
        let model = SensorModel::new(Sensor::builtin("gated").unwrap(), layout.axis).unwrap();
        assert_eq!(brightest_gate(&model, &snap), Some(3));
        // A dark film: no gate to prefer.
        let dark =
            FilmSnapshot::from_dense(layout, 1, 1, &vec![0.0; side * side * bins], &[], None);
        assert_eq!(brightest_gate(&model, &dark), None);
    }
}

//! All gates of a film through the sensor, with noise and the derived depth images, on
//! a pool of half the cores so the gate measured for the frame does not queue behind.

use std::time::Instant;
use tprf_core::film::FilmSnapshot;
use tprf_core::sensor::{
    AmcwImage, Measurements, NoiseField, Sensor, SensorModel, SpadImage, derived, spad_image,
};

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
    robust_max: [Option<f64>; 3],
    depth_range: [(f32, f32); 3],
}

impl SpadMeasured {
    fn new(image: SpadImage) -> SpadMeasured {
        let views = SpadView::ALL;
        let robust_max = views.map(|v| tprf_core::film::robust_max(spad_values(&image, v)));
        let depth_range = views.map(|v| finite_range(spad_depth(&image, v)));
        SpadMeasured {
            image,
            robust_max,
            depth_range,
        }
    }

    /// The `[B, H, W]` array of `view`.
    pub(super) fn values(&self, view: SpadView) -> &[f32] {
        spad_values(&self.image, view)
    }

    pub(super) fn depth(&self, view: SpadView) -> &[f32] {
        spad_depth(&self.image, view)
    }

    pub(super) fn robust_max(&self, view: SpadView) -> Option<f64> {
        self.robust_max[view.index()]
    }

    pub(super) fn depth_range(&self, view: SpadView) -> (f32, f32) {
        self.depth_range[view.index()]
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
    /// The film's [`FilmSnapshot::generation`].
    pub(super) snapshot: u64,
    pub(super) sensor: Sensor,
    pub(super) m: Measurements,
    pub(super) depth_m: Option<Vec<f32>>,
    pub(super) amcw: Option<AmcwImage>,
    /// The SPAD's histograms and depths, when the sensor has one.
    pub(super) spad: Option<SpadMeasured>,
    /// AMCW depth minus the depth of the TPRF's own first return (multipath error), m.
    pub(super) amcw_error_m: Option<Vec<f32>>,
    pub(super) millis: f64,
    /// 99.9 % quantile of the positive measurements: one exposure for all gates.
    pub(super) robust_max: Option<f64>,
    /// Finite range of the depth image (m), and the largest |multipath error| (m).
    pub(super) depth_range: (f32, f32),
    pub(super) error_abs_max: f32,
    /// The noise draws, handed back to be reused by the next measurement.
    pub(super) noise_field: NoiseField,
}

impl Measured {
    /// The depth image shown: first-return depth, else AMCW depth.
    pub(super) fn depth(&self) -> Option<&[f32]> {
        self.depth_m
            .as_deref()
            .or(self.amcw.as_ref().map(|a| a.depth_m.as_slice()))
    }
}

/// Threads for the background measurements: half the cores.
pub(super) fn background_pool() -> Option<&'static rayon::ThreadPool> {
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

/// All gates of `snap` through `model`, with noise (drawn into `noise_field`, reused)
/// and derived outputs.
pub(super) fn measure_all(
    model: &SensorModel,
    snap: &FilmSnapshot,
    mut noise_field: NoiseField,
) -> Result<Measured, String> {
    let started = Instant::now();
    let mut m = model.measure_clean_film(snap);
    // The SPAD counts photons of the clean (TPRF * Light); the additive noise is the
    // gates' own.
    let spad = match model.sensor().spad {
        Some(_) => Some(SpadMeasured::new(
            spad_image(model, &m, snap.steady()).map_err(|e| e.to_string())?,
        )),
        None => None,
    };
    model.apply_noise_cached(&mut m, &mut noise_field);
    let robust_max = tprf_core::film::robust_max(&m.values);
    let depth_m = model.first_return_depth(&m);
    let amcw = model.amcw(&m);
    let amcw_error_m = amcw.as_ref().map(|a| {
        let truth = derived::tprf_first_return_depth_film(snap, &Default::default());
        a.depth_m.iter().zip(&truth).map(|(d, t)| d - t).collect()
    });
    let error_abs_max = amcw_error_m.as_ref().map_or(0.0, |e: &Vec<f32>| {
        e.iter()
            .filter(|x| x.is_finite())
            .fold(0.0f32, |a, x| a.max(x.abs()))
    });
    let mut measured = Measured {
        snapshot: snap.generation(),
        sensor: model.sensor().clone(),
        m,
        depth_m,
        amcw,
        spad,
        amcw_error_m,
        millis: started.elapsed().as_secs_f64() * 1e3,
        robust_max,
        depth_range: (0.0, 0.0),
        error_abs_max,
        noise_field,
    };
    measured.depth_range = measured.depth().map_or((0.0, 0.0), finite_range);
    Ok(measured)
}

/// The smallest and largest finite values, `(0, 0)` when there are none.
fn finite_range(v: &[f32]) -> (f32, f32) {
    let (lo, hi) = v
        .iter()
        .filter(|x| x.is_finite())
        .fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    if lo <= hi { (lo, hi) } else { (0.0, 0.0) }
}

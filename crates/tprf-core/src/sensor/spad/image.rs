//! The SPAD over a whole image: from the sensor's folded `(TPRF * Light)` per TDC bin
//! (`M_k`, [`crate::sensor::SensorModel::measure_clean`] of a `tdc` exposure) and the
//! steady image, per pixel the event rates, the expected histogram, one seeded
//! realisation, its Coates estimate, and the first-return depth of each. Pixels are
//! independent and done in parallel; every array is `[B, H, W]` (row 0 = top) or
//! `[H, W]`.
//!
//! Three ways to it, with the same numbers: [`spad_image_ambient`] (all at once);
//! [`spad_expected`] then [`spad_sample`] (the expected histogram and its depth first, the
//! realisation later: a viewer shows the first while the second is drawn); and
//! [`spad_sampler`] then [`spad_rows`] for bands of rows (a histogram larger than memory,
//! written a band at a time). A pixel's realisation is drawn from its own stream (seed,
//! pixel index in the image), so it does not depend on the way taken.

use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

use super::Spad;
use super::coates::{coates, return_depth_m};
use super::detector::{Detector, ExpectedScratch, Sampler};
use super::sample::{MAX_EVENTS, pixel_stream, sample_pixel};
use crate::sensor::measure::Measurements;
use crate::sensor::{Returns, SensorError, SensorModel};

/// A SPAD's histograms and depths over an image.
#[derive(Clone, Debug, PartialEq)]
pub struct SpadImage {
    pub bins: usize,
    pub width: usize,
    pub height: usize,
    /// Expected counts over all `N` cycles, `[B, H, W]`.
    pub histogram: Vec<f32>,
    /// One seeded realisation, `[B, H, W]`.
    pub counts: Vec<f32>,
    /// The Coates estimate of `counts`, `N r_k` (NaN: bin never armed), `[B, H, W]`.
    pub coates: Vec<f32>,
    /// First-return depth of `histogram`, `counts`, `coates` (m, NaN: none), `[H, W]`.
    pub depth_histogram_m: Vec<f32>,
    pub depth_counts_m: Vec<f32>,
    pub depth_coates_m: Vec<f32>,
    /// How `counts` was drawn (or will be, before [`spad_sample`]).
    pub sampler: Sampler,
    /// Expected detections summed over the image.
    pub expected_detections: f64,
    /// TDC bin centres in the first cycle, s.
    pub centres_s: Vec<f64>,
}

impl SpadImage {
    /// Whether the realisation and its Coates estimate are drawn ([`spad_expected`]
    /// leaves `counts`, `coates` and their depths empty until [`spad_sample`]).
    pub fn is_sampled(&self) -> bool {
        !self.counts.is_empty() || self.histogram.is_empty()
    }

    /// Bin `k` of a `[B, H, W]` array of this image (empty if there is none).
    pub fn plane<'a>(&self, values: &'a [f32], k: usize) -> &'a [f32] {
        let n = self.width * self.height;
        values.get(k * n..(k + 1) * n).unwrap_or(&[])
    }

    /// Pixel `(y, x)` of a `[B, H, W]` array (empty outside the image).
    pub fn pixel(&self, values: &[f32], y: usize, x: usize) -> Vec<f32> {
        if y >= self.height || x >= self.width {
            return vec![];
        }
        let n = self.width * self.height;
        (0..self.bins)
            .filter_map(|k| values.get(k * n + y * self.width + x).copied())
            .collect()
    }
}

/// One pixel's curves, over all `N` cycles, per TDC bin.
#[derive(Clone, Debug, PartialEq)]
pub struct SpadPixel {
    /// `N r_k`: the events the SPAD would count without pile-up (signal, ambient, dark).
    pub unpiled: Vec<f64>,
    /// `N PDE photons_per_unit S_k`: the detected `(TPRF * Light)` alone.
    pub signal: Vec<f64>,
    /// The expected histogram.
    pub expected: Vec<f64>,
}

/// The SPAD of `model`'s sensor, with its TDC.
fn detector(model: &SensorModel) -> Result<(&Spad, Detector, f64), SensorError> {
    let sensor = model.sensor();
    let spad = sensor
        .spad
        .as_ref()
        .ok_or_else(|| SensorError::Invalid("the sensor has no [spad] section".into()))?;
    spad.validate(&sensor.exposure)?;
    let (cycle_s, _) = sensor
        .exposure
        .tdc_cycle_s()
        .ok_or_else(|| SensorError::Invalid("a SPAD needs a tdc exposure".into()))?;
    let bins = model.gate_count();
    let width_s = cycle_s / bins.max(1) as f64;
    Ok((spad, Detector::new(spad, bins, width_s)?, width_s))
}

/// The curves of one pixel whose folded `(TPRF * Light)` per TDC bin is `signal` (`B`
/// values, the unit of a cube bin) and whose steady image is `steady`, without ambient
/// image.
pub fn spad_pixel(
    model: &SensorModel,
    signal: &[f32],
    steady: f64,
) -> Result<SpadPixel, SensorError> {
    spad_pixel_ambient(model, signal, steady, 0.0)
}

/// [`spad_pixel`] of a pixel whose ambient image is `ambient` (W m^-2 sr^-1, before
/// the sensor's `ambient_scale`).
pub fn spad_pixel_ambient(
    model: &SensorModel,
    signal: &[f32],
    steady: f64,
    ambient: f64,
) -> Result<SpadPixel, SensorError> {
    let (spad, det, width_s) = detector(model)?;
    let mut rates = Vec::new();
    let scale = model.sensor().ambient_scale;
    let lamp = steady * model.sensor().light.energy();
    spad.rates(signal, lamp, scale * ambient, width_s, &mut rates);
    let mut expected = vec![0.0; rates.len()];
    det.expected(&rates, &mut expected);
    let n = det.cycles as f64;
    let scale = n * spad.pde * spad.photons_per_unit;
    Ok(SpadPixel {
        unpiled: rates.iter().map(|r| n * r).collect(),
        signal: signal
            .iter()
            .map(|&s| scale * f64::from(s).max(0.0))
            .collect(),
        expected,
    })
}

/// Half-width (bins) of the smoothing before a histogram's first return is looked for:
/// half the return's standard deviation, `sqrt(var(Light) + sigma_jitter^2)`, at
/// most 64 bins.
pub fn smoothing_bins(model: &SensorModel, bin_width_s: f64) -> usize {
    let sigma_jitter = model.sensor().exposure.tdc_cycle_s().map_or(0.0, |c| c.1);
    let sigma = (model.light().variance_s2() + sigma_jitter * sigma_jitter).sqrt();
    let bins = (0.5 * sigma / bin_width_s).round();
    if bins.is_finite() && bins > 0.0 {
        (bins as usize).min(64)
    } else {
        0
    }
}

/// The SPAD over an image: `signal` the sensor's clean measurement `[B, H, W]` of
/// `model` (a `tdc` exposure), `steady` the steady image `[H, W]` (the sum of each
/// pixel's TPRF). The realisation's seed is the sensor's `noise.seed`. No ambient
/// image: see [`spad_image_ambient`].
pub fn spad_image(
    model: &SensorModel,
    signal: &Measurements,
    steady: &[f32],
) -> Result<SpadImage, SensorError> {
    spad_image_ambient(model, signal, steady, None)
}

/// [`spad_image`] under the cube's ambient image `ambient` (`[H, W]`, W m^-2 sr^-1,
/// before the sensor's `ambient_scale`), when it has one: each pixel's ambient photon
/// rate grows by `ambient_scale photons_per_unit A[p]`, in every TDC bin alike.
pub fn spad_image_ambient(
    model: &SensorModel,
    signal: &Measurements,
    steady: &[f32],
    ambient: Option<&[f32]>,
) -> Result<SpadImage, SensorError> {
    let plan = Plan::new(model, signal, steady, ambient)?;
    plan.check_budget(plan.pixels(), true)?;
    let band = plan.band(0..plan.pixels(), None);
    let sampler = plan.sampler(band.totals.iter().sum());
    let band = plan.band(0..plan.pixels(), Some((sampler, band)));
    Ok(plan.image(band, signal.height))
}

/// The expected histogram and its first-return depth over the image (as
/// [`spad_image_ambient`]), with `counts`, `coates` and their depths left empty: the
/// cheap part (no realisation), for a viewer to show first. [`spad_sample`] fills them.
pub fn spad_expected(
    model: &SensorModel,
    signal: &Measurements,
    steady: &[f32],
    ambient: Option<&[f32]>,
) -> Result<SpadImage, SensorError> {
    let plan = Plan::new(model, signal, steady, ambient)?;
    plan.check_budget(plan.pixels(), false)?;
    Ok(plan.expected_image())
}

/// [`spad_expected`], given up (`Ok(None)`) when `cancel` is set meanwhile (checked
/// every few hundred pixels): for a viewer whose next edit makes this one stale.
pub fn spad_expected_until(
    model: &SensorModel,
    signal: &Measurements,
    steady: &[f32],
    ambient: Option<&[f32]>,
    cancel: &AtomicBool,
) -> Result<Option<SpadImage>, SensorError> {
    let mut plan = Plan::new(model, signal, steady, ambient)?;
    plan.check_budget(plan.pixels(), false)?;
    plan.cancel = Some(cancel);
    let image = plan.expected_image();
    Ok((!cancel.load(Ordering::Relaxed)).then_some(image))
}

/// Draws the realisation of `image` (made by [`spad_expected`] from the same inputs),
/// its Coates estimate and their depths: `image` becomes what [`spad_image_ambient`]
/// gives. The expected histograms are computed again per pixel (in f64, as the first
/// time), not read back from the f32 array.
pub fn spad_sample(
    model: &SensorModel,
    signal: &Measurements,
    steady: &[f32],
    ambient: Option<&[f32]>,
    image: &mut SpadImage,
) -> Result<(), SensorError> {
    let plan = Plan::new(model, signal, steady, ambient)?;
    if image.bins != plan.det.bins || image.width != signal.width || image.height != signal.height {
        return Err(SensorError::Invalid(format!(
            "SPAD image of {} bins x {} x {} for a measurement of {} x {} x {}",
            image.bins, image.height, image.width, plan.det.bins, signal.height, signal.width
        )));
    }
    plan.check_budget(plan.pixels(), true)?;
    let band = plan.band(0..plan.pixels(), Some((image.sampler, Band::default())));
    let full = plan.image(band, signal.height);
    image.counts = full.counts;
    image.coates = full.coates;
    image.depth_counts_m = full.depth_counts_m;
    image.depth_coates_m = full.depth_coates_m;
    Ok(())
}

/// The sampler [`spad_image_ambient`] would use for this image, and the expected
/// detections over it: one pass of the expected histograms, none kept (memory of a few
/// values per pixel). For [`spad_rows`].
pub fn spad_sampler(
    model: &SensorModel,
    signal: &Measurements,
    steady: &[f32],
    ambient: Option<&[f32]>,
) -> Result<(Sampler, f64), SensorError> {
    let plan = Plan::new(model, signal, steady, ambient)?;
    let b = plan.det.bins.max(1);
    let mut totals = vec![0.0f64; plan.pixels()];
    totals.par_chunks_mut(BLOCK).enumerate().for_each_init(
        || {
            (
                Vec::new(),
                Vec::new(),
                Vec::new(),
                ExpectedScratch::default(),
            )
        },
        |(sig, rates, out, ex), (j, totals)| {
            let p0 = j * BLOCK;
            plan.gather_block(p0, totals.len(), sig);
            out.resize(b, 0.0);
            for (i, total) in totals.iter_mut().enumerate() {
                plan.rates_of(p0 + i, &sig[i * b..(i + 1) * b], rates);
                plan.det.expected_with(rates, out, ex);
                *total = out.iter().sum::<f64>();
            }
        },
    );
    let total: f64 = totals.iter().sum();
    Ok((plan.sampler(total), total))
}

/// Rows `y0 .. y0 + rows` of [`spad_image_ambient`]'s image, drawn with `sampler`
/// (from [`spad_sampler`] over the whole image): a [`SpadImage`] of `rows` rows whose
/// values are those rows of the whole image's, bit for bit. Its `expected_detections`
/// is the band's.
pub fn spad_rows(
    model: &SensorModel,
    signal: &Measurements,
    steady: &[f32],
    ambient: Option<&[f32]>,
    sampler: Sampler,
    y0: usize,
    rows: usize,
) -> Result<SpadImage, SensorError> {
    let plan = Plan::new(model, signal, steady, ambient)?;
    let w = signal.width;
    if y0.checked_add(rows).is_none_or(|end| end > signal.height) {
        return Err(SensorError::Invalid(format!(
            "SPAD rows {y0} .. {} of an image of {} rows",
            y0.saturating_add(rows),
            signal.height
        )));
    }
    plan.check_budget(rows * w, true)?;
    let band = plan.band(y0 * w..(y0 + rows) * w, Some((sampler, Band::default())));
    let mut image = plan.image(band, rows);
    image.sampler = sampler;
    Ok(image)
}

/// Bytes [`spad_rows`] holds per pixel of a band for `bins` TDC bins: the expected
/// histogram, the realisation and its Coates estimate in f64 and in f32, and the depths.
pub fn spad_bytes_per_pixel(bins: usize) -> u64 {
    (bins as u64).saturating_mul(3 * 8 + 3 * 4) + 4 * 8
}

/// Pixels whose signals are gathered together ([`Plan::gather_block`]).
const BLOCK: usize = 64;

/// What every pixel's computation shares: the checked inputs and the detector.
struct Plan<'a> {
    spad: &'a Spad,
    det: Detector,
    width_s: f64,
    ambient_scale: f64,
    /// The light's energy, J: the steady lamp's power is `ambient_lamp_hz` of them a
    /// second.
    energy_j: f64,
    seed: u64,
    centres_s: Vec<f64>,
    light_mean_s: f64,
    returns: Returns,
    half_width: usize,
    signal: &'a Measurements,
    steady: &'a [f32],
    ambient: Option<&'a [f32]>,
    /// Set from elsewhere: the expected histograms stop early ([`spad_expected_until`]).
    cancel: Option<&'a AtomicBool>,
}

/// A range of pixels' results, pixel-major (`B` values a pixel).
#[derive(Default)]
struct Band {
    expected: Vec<f64>,
    /// Each pixel's expected detections.
    totals: Vec<f64>,
    depth_expected: Vec<f32>,
    counts: Vec<f64>,
    coates: Vec<f64>,
    depth_counts: Vec<f32>,
    depth_coates: Vec<f32>,
    expected_detections: f64,
}

impl<'a> Plan<'a> {
    fn new(
        model: &'a SensorModel,
        signal: &'a Measurements,
        steady: &'a [f32],
        ambient: Option<&'a [f32]>,
    ) -> Result<Plan<'a>, SensorError> {
        let (spad, det, width_s) = detector(model)?;
        let (w, h, b) = (signal.width, signal.height, signal.gates);
        let pixels = w * h;
        if b != det.bins
            || signal.values.len() != b * pixels
            || steady.len() != pixels
            || ambient.is_some_and(|a| a.len() != pixels)
        {
            return Err(SensorError::Invalid(format!(
                "SPAD input: {} values for {b} bins x {h} x {w}, steady image of {} and \
                 ambient image of {} for {} pixels",
                signal.values.len(),
                steady.len(),
                ambient.map_or(pixels, <[f32]>::len),
                pixels
            )));
        }
        Ok(Plan {
            spad,
            det,
            width_s,
            ambient_scale: model.sensor().ambient_scale,
            energy_j: model.sensor().light.energy(),
            seed: model.sensor().noise.seed,
            centres_s: model.gate_centres_s().unwrap_or_default(),
            light_mean_s: model.light().mean_s(),
            returns: model.sensor().derived.returns.unwrap_or_default(),
            half_width: smoothing_bins(model, width_s),
            signal,
            steady,
            ambient,
            cancel: None,
        })
    }

    fn pixels(&self) -> usize {
        self.signal.width * self.signal.height
    }

    /// Refuses `pixels` pixels' arrays when they do not fit (`sampled`: with the
    /// realisation and its Coates estimate).
    fn check_budget(&self, pixels: usize, sampled: bool) -> Result<(), SensorError> {
        let b = self.det.bins as u64;
        let per_pixel = if sampled {
            spad_bytes_per_pixel(self.det.bins)
        } else {
            b * (8 + 4) + 3 * 8
        };
        let (w, h) = (self.signal.width, self.signal.height);
        crate::budget::check(
            (pixels as u64).saturating_mul(per_pixel),
            &format!(
                "the SPAD over {} of {h} x {w} pixels x {b} TDC bins",
                pixels
            ),
            if sampled {
                "its histograms, realisation, Coates estimate and depths"
            } else {
                "its expected histograms and depths"
            },
        )
        .map_err(|e| SensorError::Budget(e.to_string()))
    }

    /// Pixel `p`'s event rates per TDC bin into `rates` (`sig` scratch).
    fn rates(&self, p: usize, sig: &mut Vec<f32>, rates: &mut Vec<f64>) {
        let (b, pixels) = (self.det.bins, self.pixels());
        sig.clear();
        sig.extend((0..b).map(|k| self.signal.values[k * pixels + p]));
        self.rates_of(p, sig, rates);
    }

    /// Pixel `p`'s event rates from its signal `sig` (`B` values).
    fn rates_of(&self, p: usize, sig: &[f32], rates: &mut Vec<f64>) {
        let ambient = self
            .ambient
            .map_or(0.0, |a| self.ambient_scale * f64::from(a[p]));
        let lamp = f64::from(self.steady[p]) * self.energy_j;
        self.spad.rates(sig, lamp, ambient, self.width_s, rates);
    }

    /// The signals of pixels `p0 .. p0 + n` into `out`, pixel-major (`[n, B]`): per TDC
    /// bin one contiguous run of the `[B, H, W]` measurement, where a pixel at a time
    /// would load one value every `H W` (a cache miss a bin).
    fn gather_block(&self, p0: usize, n: usize, out: &mut Vec<f32>) {
        let (b, pixels) = (self.det.bins, self.pixels());
        out.clear();
        out.resize(n * b, 0.0);
        for k in 0..b {
            let run = &self.signal.values[k * pixels + p0..k * pixels + p0 + n];
            for (i, &v) in run.iter().enumerate() {
                out[i * b + k] = v;
            }
        }
    }

    /// The expected histograms and depths of every pixel, with the sampler of their
    /// total; `counts`, `coates` and their depths left empty.
    fn expected_image(&self) -> SpadImage {
        let band = self.band(0..self.pixels(), None);
        let total = band.totals.iter().sum();
        let mut image = self.image(band, self.signal.height);
        image.sampler = self.sampler(total);
        image
    }

    fn sampler(&self, expected_detections: f64) -> Sampler {
        if self.det.first_photon_only() {
            Sampler::Multinomial
        } else if expected_detections <= MAX_EVENTS {
            Sampler::Events
        } else {
            Sampler::Marginals
        }
    }

    fn depth(&self, v: &[f64], scratch: &mut Vec<f64>) -> f32 {
        return_depth_m(
            v,
            &self.centres_s,
            self.light_mean_s,
            &self.returns,
            self.half_width,
            scratch,
        ) as f32
    }

    /// Pixels `range`: without `sample`, the expected histograms, their totals and
    /// depths; with `(sampler, band)`, also the realisation, its Coates estimate and
    /// their depths, reusing `band`'s expected histograms when it holds this range's
    /// (else computing them).
    fn band(&self, range: std::ops::Range<usize>, sample: Option<(Sampler, Band)>) -> Band {
        let b = self.det.bins.max(1);
        let n = range.len();
        let (sampler, mut band) = match sample {
            Some((s, band)) => (Some(s), band),
            None => (None, Band::default()),
        };
        if band.expected.len() != n * b {
            band.expected = vec![0.0f64; n * b];
            band.totals = vec![0.0; n];
            band.depth_expected = vec![f32::NAN; n];
            band.expected
                .par_chunks_mut(b * BLOCK)
                .zip(band.totals.par_chunks_mut(BLOCK))
                .zip(band.depth_expected.par_chunks_mut(BLOCK))
                .enumerate()
                .for_each_init(
                    || {
                        (
                            Vec::new(),
                            Vec::new(),
                            Vec::new(),
                            ExpectedScratch::default(),
                        )
                    },
                    |(sig, rates, scratch, ex), (j, ((outs, totals), depths))| {
                        if self.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                            return;
                        }
                        let p0 = range.start + j * BLOCK;
                        self.gather_block(p0, totals.len(), sig);
                        for (i, ((out, total), depth)) in outs
                            .chunks_exact_mut(b)
                            .zip(totals.iter_mut())
                            .zip(depths.iter_mut())
                            .enumerate()
                        {
                            self.rates_of(p0 + i, &sig[i * b..(i + 1) * b], rates);
                            self.det.expected_with(rates, out, ex);
                            *total = out.iter().sum();
                            *depth = self.depth(out, scratch);
                        }
                    },
                );
            band.expected_detections = band.totals.iter().sum();
        }
        let Some(sampler) = sampler else {
            return band;
        };
        band.counts = vec![0.0f64; n * b];
        band.coates = vec![0.0f64; n * b];
        let depths: Vec<[f32; 2]> = band
            .counts
            .par_chunks_mut(b)
            .zip(band.coates.par_chunks_mut(b))
            .zip(band.expected.par_chunks(b))
            .enumerate()
            .map_init(
                || (Vec::new(), Vec::new(), Vec::new()),
                |(sig, rates, scratch), (i, ((cnt, est), exp))| {
                    let p = range.start + i;
                    self.rates(p, sig, rates);
                    let mut rng = pixel_stream(self.seed, p);
                    sample_pixel(&self.det, sampler, rates, exp, &mut rng, cnt);
                    coates(&self.det, cnt, est);
                    [self.depth(cnt, scratch), self.depth(est, scratch)]
                },
            )
            .collect();
        band.depth_counts = depths.iter().map(|d| d[0]).collect();
        band.depth_coates = depths.iter().map(|d| d[1]).collect();
        band
    }

    /// The band as an image of `rows` rows, `[B, rows, W]` arrays.
    fn image(&self, band: Band, rows: usize) -> SpadImage {
        let b = self.det.bins;
        let plane = rows * self.signal.width;
        // Pixel-major f64 to plane-major f32 in tiles of TILE planes x PIXELS pixels:
        // each tile reads PIXELS runs of TILE adjacent values and writes TILE runs of
        // PIXELS (a cache line each), where a plane at a time read one value every `B`
        // and missed the cache on each (a quarter of the expected histogram's time at
        // 160 x 160 x 512).
        const TILE: usize = 64;
        const PIXELS: usize = 16;
        let transpose = |pm: &[f64]| -> Vec<f32> {
            if pm.is_empty() || plane == 0 {
                return Vec::new();
            }
            let mut out = vec![0.0f32; pm.len()];
            out.par_chunks_mut(plane * TILE)
                .enumerate()
                .for_each(|(g, o)| {
                    let k0 = g * TILE;
                    let planes = o.len() / plane;
                    for p0 in (0..plane).step_by(PIXELS) {
                        let p1 = (p0 + PIXELS).min(plane);
                        for t in 0..planes {
                            let row = &mut o[t * plane + p0..t * plane + p1];
                            for (i, v) in row.iter_mut().enumerate() {
                                *v = pm[(p0 + i) * b + k0 + t] as f32;
                            }
                        }
                    }
                });
            out
        };
        SpadImage {
            bins: b,
            width: self.signal.width,
            height: rows,
            histogram: transpose(&band.expected),
            counts: transpose(&band.counts),
            coates: transpose(&band.coates),
            depth_histogram_m: band.depth_expected,
            depth_counts_m: band.depth_counts,
            depth_coates_m: band.depth_coates,
            sampler: self.sampler(band.expected_detections),
            expected_detections: band.expected_detections,
            centres_s: self.centres_s.clone(),
        }
    }
}

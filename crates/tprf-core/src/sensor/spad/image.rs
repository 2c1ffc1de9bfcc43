//! The SPAD over a whole image: from the sensor's folded `(TPRF * Light)` per TDC bin
//! (`M_k`, [`crate::sensor::SensorModel::measure_clean`] of a `tdc` exposure) and the
//! steady image, per pixel the event rates, the expected histogram, one seeded
//! realisation, its Coates estimate, and the first-return depth of each. Pixels are
//! independent and done in parallel; every array is `[B, H, W]` (row 0 = top) or
//! `[H, W]`.

use rayon::prelude::*;

use super::Spad;
use super::coates::{coates, return_depth_m};
use super::detector::{Detector, Sampler};
use super::sample::{MAX_EVENTS, pixel_stream, sample_pixel};
use crate::sensor::measure::Measurements;
use crate::sensor::{SensorError, SensorModel};

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
    /// How `counts` was drawn.
    pub sampler: Sampler,
    /// Expected detections summed over the image.
    pub expected_detections: f64,
    /// TDC bin centres in the first cycle, s.
    pub centres_s: Vec<f64>,
}

impl SpadImage {
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
    spad.rates(signal, steady, scale * ambient, width_s, &mut rates);
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
    let (spad, det, width_s) = detector(model)?;
    let (w, h, b) = (signal.width, signal.height, signal.gates);
    let pixels = w * h;
    if b != det.bins
        || signal.values.len() != b * pixels
        || steady.len() != pixels
        || ambient.is_some_and(|a| a.len() != pixels)
    {
        return Err(SensorError::Invalid(format!(
            "SPAD input: {} values for {b} bins x {h} x {w}, steady image of {} and ambient \
             image of {} for {} pixels",
            signal.values.len(),
            steady.len(),
            ambient.map_or(pixels, <[f32]>::len),
            pixels
        )));
    }
    let scale = model.sensor().ambient_scale;
    let ambient_at = |p: usize| ambient.map_or(0.0, |a| scale * f64::from(a[p]));
    // Held at once: the expected histogram, the realisation and its Coates estimate in
    // f64 pixel-major, the three f32 [B, H, W] copies of them, and the depths.
    let need_bytes = (pixels as u64)
        .saturating_mul(b as u64)
        .saturating_mul(3 * 8 + 3 * 4)
        .saturating_add((pixels as u64).saturating_mul(2 * 3 * 4));
    crate::budget::check(
        need_bytes,
        &format!("the SPAD over {h} x {w} pixels x {b} TDC bins"),
        "its histograms, realisation, Coates estimate and depths",
    )
    .map_err(|e| SensorError::Budget(e.to_string()))?;
    let seed = model.sensor().noise.seed;
    let centres_s = model.gate_centres_s().unwrap_or_default();
    let light_mean_s = model.light().mean_s();
    let first_return = model.sensor().derived.first_return.unwrap_or_default();
    let half_width = smoothing_bins(model, width_s);
    let gather = |p: usize, out: &mut Vec<f32>| {
        out.clear();
        out.extend((0..b).map(|k| signal.values[k * pixels + p]));
    };

    // Pass 1: rates and expected histogram, pixel-major.
    let mut expected = vec![0.0f64; pixels * b];
    expected.par_chunks_mut(b.max(1)).enumerate().for_each_init(
        || (Vec::new(), Vec::new()),
        |(sig, rates), (p, out)| {
            gather(p, sig);
            spad.rates(sig, f64::from(steady[p]), ambient_at(p), width_s, rates);
            det.expected(rates, out);
        },
    );
    let expected_detections: f64 = expected.par_iter().sum();
    let sampler = if det.first_photon_only() {
        Sampler::Multinomial
    } else if expected_detections <= MAX_EVENTS {
        Sampler::Events
    } else {
        Sampler::Marginals
    };

    // Pass 2: realisation, Coates, depths.
    let mut counts = vec![0.0f64; pixels * b];
    let mut estimate = vec![0.0f64; pixels * b];
    let depths: Vec<[f32; 3]> = counts
        .par_chunks_mut(b.max(1))
        .zip(estimate.par_chunks_mut(b.max(1)))
        .zip(expected.par_chunks(b.max(1)))
        .enumerate()
        .map_init(
            || (Vec::new(), Vec::new(), Vec::new()),
            |(sig, rates, scratch), (p, ((cnt, est), exp))| {
                gather(p, sig);
                spad.rates(sig, f64::from(steady[p]), ambient_at(p), width_s, rates);
                let mut rng = pixel_stream(seed, p);
                sample_pixel(&det, sampler, rates, exp, &mut rng, cnt);
                coates(&det, cnt, est);
                let depth = |v: &[f64], s: &mut Vec<f64>| {
                    return_depth_m(v, &centres_s, light_mean_s, &first_return, half_width, s) as f32
                };
                [
                    depth(exp, scratch),
                    depth(cnt, scratch),
                    depth(est, scratch),
                ]
            },
        )
        .collect();

    let transpose = |pm: &[f64]| -> Vec<f32> {
        let mut out = vec![0.0f32; pm.len()];
        out.par_chunks_mut(pixels.max(1))
            .enumerate()
            .for_each(|(k, plane)| {
                for (p, o) in plane.iter_mut().enumerate() {
                    *o = pm[p * b + k] as f32;
                }
            });
        out
    };
    Ok(SpadImage {
        bins: b,
        width: w,
        height: h,
        histogram: transpose(&expected),
        counts: transpose(&counts),
        coates: transpose(&estimate),
        depth_histogram_m: depths.iter().map(|d| d[0]).collect(),
        depth_counts_m: depths.iter().map(|d| d[1]).collect(),
        depth_coates_m: depths.iter().map(|d| d[2]).collect(),
        sampler,
        expected_detections,
        centres_s,
    })
}

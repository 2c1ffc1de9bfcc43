//! The one order a sensor measurement is made in, for `tprf sensor` and the window
//! alike:
//!
//! 1. **clean**: `sum_b TPRF[b] K_i[b]` per pixel and gate (the paper's section 6, no
//!    noise), from a film snapshot or from a cube read a tile at a time
//!    ([`SensorModel::measure_clean`]); its result is what [`Pipeline`] starts from;
//! 2. **SPAD**, for a sensor with a `[spad]` section: photon counts from the clean
//!    measurement, the steady image and the scene's ambient image, never from gates
//!    that already hold ambient light or noise ([`Pipeline::spad_expected`], then the
//!    realisation a band of rows at a time, [`Pipeline::spad_rows`]);
//! 3. **ambient**: the ambient image as a constant rate in every gate, before the
//!    noise, since photon noise grows with it ([`SensorModel::add_ambient`]);
//! 4. **noise**: additive Gaussian and photon noise, then `max(0, .)`;
//! 5. **derived**: first-return depth and AMCW phase and depth, from the noisy gates.
//!
//! Steps 3 to 5 are [`Pipeline::gates`]; [`add_ambient_to_gate`] is step 3 for the
//! image of one gate alone (what a viewer measures within a frame after an edit).

use std::sync::atomic::AtomicBool;

use super::spad::{Sampler, spad_expected_until, spad_rows, spad_sampler};
use super::{
    AmcwImage, Measurements, NoiseField, ReturnImages, SensorError, SensorModel, SpadImage,
};

/// The inputs every step after the clean one reads.
#[derive(Clone, Copy)]
pub struct Pipeline<'a> {
    pub model: &'a SensorModel,
    /// Step 1's result, `[N, H, W]`: no ambient light, no noise.
    pub clean: &'a Measurements,
    /// The steady image `[H, W]`, the sum of each pixel's TPRF (a SPAD's ambient lamp
    /// lights each pixel by it); may be empty for a sensor without a SPAD.
    pub steady: &'a [f32],
    /// The scene's ambient image `[H, W]`, W m^-2 sr^-1 (before the sensor's
    /// `ambient_scale`), when it has one of this size.
    pub ambient: Option<&'a [f32]>,
}

/// Where step 4's normal draws come from.
pub enum Draws<'a> {
    /// Drawn afresh from the sensor's seed.
    Fresh,
    /// Kept in a field between calls (the same seed's draws are reused: after the
    /// first measurement, an edit of `sigma` costs one multiply-add per value).
    Kept(&'a mut NoiseField),
}

/// What steps 3 to 5 give: the measurements `M_i` and what is derived from them.
pub struct Gates {
    /// `[N, H, W]`, ambient light and noise included.
    pub m: Measurements,
    /// Whether the ambient image went into the gates: `None` without one; `Err` (why,
    /// in words) when the gates cannot take it (AMCW gates without
    /// `ambient_exposure_s`), and nothing was added.
    pub ambient: Option<Result<(), String>>,
    /// The returns' depths and intensities (first, strongest, last, multi-echo), when
    /// the sensor asks for them.
    pub returns: Option<ReturnImages>,
    /// AMCW phase, amplitude and depth, when the sensor has AMCW gates.
    pub amcw: Option<AmcwImage>,
    /// FLIM's two-gate lifetime `[H, W]`, seconds, when the sensor asks for it.
    pub flim_lifetime_s: Option<Vec<f32>>,
}

impl Pipeline<'_> {
    /// Step 2, the cheap part: the SPAD's expected histogram and its depth over the
    /// image (no realisation yet); `Ok(None)` when `cancel` was set meanwhile, and for
    /// a sensor without a SPAD.
    pub fn spad_expected(&self, cancel: &AtomicBool) -> Result<Option<SpadImage>, SensorError> {
        if self.model.sensor().spad.is_none() {
            return Ok(None);
        }
        spad_expected_until(self.model, self.clean, self.steady, self.ambient, cancel)
    }

    /// Step 2's realisation: the sampler the whole image is drawn with, and the
    /// expected detections over it ([`spad_sampler`]).
    pub fn spad_sampler(&self) -> Result<(Sampler, f64), SensorError> {
        spad_sampler(self.model, self.clean, self.steady, self.ambient)
    }

    /// Step 2 for rows `y0 .. y0 + rows` with `sampler`: expected histogram,
    /// realisation, Coates estimate and depths, bit for bit those rows of the whole
    /// image's ([`spad_rows`]).
    pub fn spad_rows(
        &self,
        sampler: Sampler,
        y0: usize,
        rows: usize,
    ) -> Result<SpadImage, SensorError> {
        spad_rows(
            self.model,
            self.clean,
            self.steady,
            self.ambient,
            sampler,
            y0,
            rows,
        )
    }

    /// Steps 3 to 5 on a copy of the clean measurement.
    pub fn gates(&self, draws: Draws) -> Result<Gates, SensorError> {
        let model = self.model;
        let mut m = self.clean.clone();
        let ambient = match self.ambient {
            None => None,
            Some(a) => Some(match model.ambient_weights_s() {
                Ok(_) => {
                    model.add_ambient(&mut m, a)?;
                    Ok(())
                }
                Err(why) => Err(why),
            }),
        };
        match draws {
            Draws::Fresh => model.apply_noise(&mut m),
            Draws::Kept(field) => model.apply_noise_cached(&mut m, field),
        }
        let returns = model.returns(&m);
        let amcw = model.amcw(&m);
        let flim_lifetime_s = model.flim_lifetime(&m);
        Ok(Gates {
            m,
            ambient,
            returns,
            amcw,
            flim_lifetime_s,
        })
    }
}

/// Step 3 for gate `gate`'s image alone, `values` `[H, W]` of its clean measurement:
/// the ambient image `ambient` (`[H, W]`) at the weight [`Pipeline::gates`] gives that
/// gate. Nothing when the gates cannot take ambient light or the sizes differ.
pub fn add_ambient_to_gate(model: &SensorModel, gate: usize, values: &mut [f32], ambient: &[f32]) {
    if let Ok(w) = model.ambient_weights_s()
        && let Some(&w) = w.get(gate)
        && values.len() == ambient.len()
    {
        super::ambient::add_to_plane(values, w, ambient);
    }
}

/// What to say when some of `model`'s gates (TDC bins, for a SPAD: `spad`) see no
/// light from the cube's window `axis`: their measurements are noise (or ambient, dark
/// and afterpulse counts) only. `None` when every gate sees some.
pub fn unlit_gates_note(
    model: &SensorModel,
    spad: bool,
    axis: &crate::film::TimeAxis,
) -> Option<String> {
    let unlit = model
        .kernels()
        .iter()
        .filter(|k| k.weights.is_empty())
        .count();
    (unlit > 0).then(|| {
        let (what, rest) = if spad {
            (
                "TDC bins",
                "they count ambient light, dark counts and afterpulses only",
            )
        } else {
            ("gates", "their measurements are noise only")
        };
        format!(
            "{unlit} of {} {what} see no light from the cube's window ({} .. {}); {rest}",
            model.gate_count(),
            crate::units::format_time(axis.t0_s),
            crate::units::format_time(axis.end_s())
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::{Exposure, LightPulse, Sensor, TimeAxis, TimeOrigin};

    /// Two pixels, 10 bins of 1 ns from 0; pixel 0 holds 2.0 in bin 3, pixel 1 is dark.
    /// A delta light at 0 and one box gate over [3, 5) ns of gain 0.5: the clean
    /// measurement is 0.5 x 2 = 1 for pixel 0 and 0 for pixel 1; an ambient image
    /// (4, 8) W m^-2 sr^-1 adds gain x width x A = 0.5 x 2 ns x A in every gate, before
    /// the noise (none here); the gate on screen alone gets the same.
    #[test]
    fn the_steps_add_ambient_light_to_the_clean_gates() {
        let axis = TimeAxis::new(0.0, 1e-9, 10).unwrap();
        let mut cube = vec![0.0f32; 20];
        cube[3] = 2.0;
        let sensor = Sensor::new(
            LightPulse::default(),
            Exposure::Box {
                origin: TimeOrigin::Pulse,
                start_s: 3e-9,
                width_s: 2e-9,
                step_s: None,
                count: 1,
                gain: 0.5,
            },
        );
        let model = SensorModel::new(sensor, axis).unwrap();
        let clean = model.measure_clean(&cube, 2, 1).unwrap();
        assert_eq!(clean.values, vec![1.0, 0.0]);
        let ambient = [4.0f32, 8.0];
        let p = Pipeline {
            model: &model,
            clean: &clean,
            steady: &[],
            ambient: Some(&ambient),
        };
        let g = p.gates(Draws::Fresh).unwrap();
        let want = [1.0 + 0.5 * 2e-9 * 4.0, 0.5 * 2e-9 * 8.0];
        for (got, want) in g.m.values.iter().zip(want) {
            assert!(
                (f64::from(*got) - want).abs() <= 1e-7 * want,
                "{got} vs {want}"
            );
        }
        assert_eq!(g.ambient, Some(Ok(())));
        assert!(g.returns.is_none() && g.amcw.is_none());
        let mut one = clean.values.clone();
        add_ambient_to_gate(&model, 0, &mut one, &ambient);
        assert_eq!(one, g.m.values);
        // No SPAD: no step 2.
        let cancel = AtomicBool::new(false);
        assert!(p.spad_expected(&cancel).unwrap().is_none());
        // AMCW gates never close: without ambient_exposure_s nothing is added, and
        // the reason is given.
        let mut amcw = Sensor::builtin("amcw").unwrap();
        amcw.ambient_exposure_s = None;
        let model = SensorModel::new(amcw, axis).unwrap();
        let clean = model.measure_clean(&cube, 2, 1).unwrap();
        let g = Pipeline {
            model: &model,
            clean: &clean,
            steady: &[],
            ambient: Some(&ambient),
        }
        .gates(Draws::Fresh)
        .unwrap();
        assert!(matches!(g.ambient, Some(Err(_))), "{:?}", g.ambient);
        assert_eq!(g.m.values, clean.values);
        assert!(g.amcw.is_some());
    }
}

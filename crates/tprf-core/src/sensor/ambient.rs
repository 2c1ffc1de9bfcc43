//! Ambient light in the sensor: the cube's ambient image `A[p]` (W m^-2 sr^-1, the
//! steady radiance of the scene's ambient light group: sun, sky, lamps; `ambient.npy`)
//! added as a constant rate to every gate.
//!
//! Units. A cube bin holds radiance x seconds for a unit-energy pulse (W m^-2 sr^-1 s
//! per J), so `(TPRF * Light)(t)` is a radiance for a light of `integral Light dt` joules
//! and a measurement `M_i = integral (TPRF * Light)(t) Exposure_i(t) dt` is radiance x
//! seconds (the unit of a cube bin for the unit pulse). The ambient radiance arrives at
//! every time, independent of the pulse's energy, so it adds
//!
//! ```text
//! M_i[p] += ambient_scale A[p] integral Exposure_i(t) dt        (radiance x s)
//! ```
//!
//! the same unit. `integral Exposure_i dt` is [`Gate::integral_s`]: `gain x width` for a
//! box gate, `peak sigma sqrt(2 pi)` for a Gaussian one, the area under a
//! piecewise-linear one, the bin width for a TDC bin. AMCW gates never close: they take
//! `mean(Exposure_i) x ambient_exposure_s`, the seconds of ambient light collected per
//! unit of emitted energy (1 / the source's mean power), and are left without ambient
//! when the sensor does not give it. This is added before the noise, so photon (shot)
//! noise grows with it.
//!
//! A SPAD counts it as photons instead, in every TDC bin alike:
//! `ambient_scale photons_per_unit A[p]` photons per second (see
//! [`super::spad::Spad::rates`]), on top of `ambient_rate_hz` and the lamp term.

use super::measure::Measurements;
use super::model::SensorModel;
use super::{Gate, SensorError};

/// Per gate, the seconds of ambient light it integrates, `integral Exposure_i dt` (or
/// `mean(Exposure_i) ambient_exposure_s` for AMCW gates), times nothing else.
/// `Err` (the reason, in words) when a gate has no finite integral and the sensor gives
/// no `ambient_exposure_s`.
pub fn gate_ambient_s(gates: &[Gate], ambient_exposure_s: Option<f64>) -> Result<Vec<f64>, String> {
    gates
        .iter()
        .enumerate()
        .map(
            |(i, g)| match (g.integral_s(), g.mean_value(), ambient_exposure_s) {
                (Some(s), _, _) => Ok(s),
                (None, Some(mean), Some(t)) => Ok(mean * t),
                _ => Err(format!(
                    "gate {i} never closes (AMCW): its ambient light needs ambient_exposure_s, \
                 the seconds of ambient light collected per unit of emitted energy \
                 (1 / the source's mean power in W)"
                )),
            },
        )
        .collect()
}

impl SensorModel {
    /// What gate `i` adds per unit of ambient radiance, `ambient_scale integral
    /// Exposure_i dt` (seconds), for every gate: see [`gate_ambient_s`].
    pub fn ambient_weights_s(&self) -> Result<Vec<f64>, String> {
        let s = self.sensor();
        let w = gate_ambient_s(self.gates(), s.ambient_exposure_s)?;
        Ok(w.into_iter().map(|x| x * s.ambient_scale).collect())
    }

    /// `M_i[p] += ambient_scale A[p] integral Exposure_i dt` for every gate and pixel of
    /// clean measurements `m` (`[N, H, W]`), `ambient` the image `A` (`[H, W]`,
    /// W m^-2 sr^-1; negative or NaN values count as 0). `Ok(false)` when the gates
    /// cannot take ambient light (AMCW without `ambient_exposure_s`: nothing added).
    pub fn add_ambient(&self, m: &mut Measurements, ambient: &[f32]) -> Result<bool, SensorError> {
        let pixels = m.width * m.height;
        if ambient.len() != pixels {
            return Err(SensorError::Invalid(format!(
                "ambient image of {} values for {} x {} pixels",
                ambient.len(),
                m.height,
                m.width
            )));
        }
        let Ok(weights) = self.ambient_weights_s() else {
            return Ok(false);
        };
        for (i, w) in weights.iter().enumerate() {
            if *w == 0.0 {
                continue;
            }
            let Some(plane) = m.values.get_mut(i * pixels..(i + 1) * pixels) else {
                break;
            };
            add_to_plane(plane, *w, ambient);
        }
        Ok(true)
    }
}

/// `plane[p] += w A[p]` (in f64), `A` the ambient image, its negative or NaN values
/// counted as 0: one gate's share of [`SensorModel::add_ambient`].
pub(crate) fn add_to_plane(plane: &mut [f32], w: f64, ambient: &[f32]) {
    if w == 0.0 {
        return;
    }
    for (v, &a) in plane.iter_mut().zip(ambient) {
        let a = if a > 0.0 { f64::from(a) } else { 0.0 };
        *v = (f64::from(*v) + w * a) as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::{Exposure, LightPulse, Sensor, TimeAxis, TimeOrigin};

    /// One pixel, one box gate of known width and gain, a known ambient radiance: the
    /// hand-computed sum.
    #[test]
    fn box_gate_adds_ambient_times_gain_times_width() {
        let exposure = Exposure::Box {
            origin: TimeOrigin::Pulse,
            start_s: 10e-9,
            width_s: 4e-9,
            step_s: None,
            count: 2,
            gain: 0.5,
        };
        let mut sensor = Sensor::new(LightPulse::default(), exposure);
        sensor.ambient_scale = 2.0;
        let model = SensorModel::new(sensor, TimeAxis::new(0.0, 1e-9, 64).unwrap()).unwrap();
        let mut m = Measurements {
            gates: 2,
            height: 1,
            width: 1,
            values: vec![1.0, 3.0],
        };
        let a = 7.0f32; // W m^-2 sr^-1
        assert!(model.add_ambient(&mut m, &[a]).unwrap());
        // 2 x 7 W m^-2 sr^-1 x 0.5 x 4 ns = 2.8e-8 W m^-2 sr^-1 s.
        let add = 2.0 * 7.0 * 0.5 * 4e-9;
        assert!((f64::from(m.values[0]) - (1.0 + add)).abs() < 1e-7);
        assert!((f64::from(m.values[1]) - (3.0 + add)).abs() < 1e-7);
        // Scale 0: off.
        let mut off = model.sensor().clone();
        off.ambient_scale = 0.0;
        let model = SensorModel::new(off, *model.axis()).unwrap();
        let mut m2 = Measurements {
            gates: 2,
            height: 1,
            width: 1,
            values: vec![1.0, 3.0],
        };
        model.add_ambient(&mut m2, &[a]).unwrap();
        assert_eq!(m2.values, vec![1.0, 3.0]);
    }

    #[test]
    fn gate_integrals() {
        let g = Gate::Gaussian {
            centre_s: 1.0,
            sigma_s: 2.0,
            peak: 3.0,
        };
        let want = 3.0 * 2.0 * (2.0 * std::f64::consts::PI).sqrt();
        assert!((g.integral_s().unwrap() - want).abs() < 1e-12);
        let j = Gate::Jittered {
            start_s: 1e-9,
            end_s: 1.1e-9,
            sigma_s: 3e-11,
        };
        assert!((j.integral_s().unwrap() - 1e-10).abs() < 1e-22);
        let c = Gate::Cosine {
            freq_hz: 2e7,
            phase_rad: 0.0,
            modulation: 1.0,
        };
        assert!(c.integral_s().is_none());
        assert!(gate_ambient_s(std::slice::from_ref(&c), None).is_err());
        assert_eq!(gate_ambient_s(&[c], Some(1e-3)).unwrap(), vec![0.5e-3]);
    }

    #[test]
    fn bad_scale_is_refused_by_name() {
        let mut s = Sensor::builtin("lidar").unwrap();
        s.ambient_scale = -1.0;
        assert!(
            s.validate()
                .unwrap_err()
                .to_string()
                .contains("ambient_scale")
        );
        s.ambient_scale = f64::NAN;
        assert!(
            s.validate()
                .unwrap_err()
                .to_string()
                .contains("ambient_scale")
        );
        s.ambient_scale = 1.0;
        s.ambient_exposure_s = Some(0.0);
        assert!(
            s.validate()
                .unwrap_err()
                .to_string()
                .contains("ambient_exposure_s")
        );
    }

    #[test]
    fn ambient_fields_round_trip_through_toml() {
        let mut s = Sensor::builtin("amcw").unwrap();
        assert_eq!(s.ambient_scale, 1.0);
        s.ambient_scale = 1e6;
        s.ambient_exposure_s = Some(2e-3);
        let text = s.to_toml_string().unwrap();
        let back = Sensor::from_toml_str(&text).unwrap();
        assert_eq!(back, s);
        let t = "ambient_scale = 0.5\nambient_exposure = \"1 ms\"\n[exposure]\nkind = \"amcw\"\nfreq = \"20 MHz\"\n";
        let parsed = Sensor::from_toml_str(t).unwrap();
        assert_eq!(parsed.ambient_scale, 0.5);
        assert!((parsed.ambient_exposure_s.unwrap() - 1e-3).abs() < 1e-15);
    }
}

//! [`SensorModel`]: a [`Sensor`] compiled for one time axis, its kernels cached.
//!
//! What a viewer keeps: each frame it hands the (possibly edited) sensor to
//! [`SensorModel::update`], which recomputes the kernels only when the light or the
//! gates changed, and calls [`SensorModel::measure`] on its film snapshot when anything
//! changed. Noise and derived-output edits never recompute kernels.

use super::derived::{self, AmcwImage, ReturnImages};
use super::exposure::{Exposure, Gate};
use super::kernel::{BinTransfer, SparseKernel, compute_kernels, folded_kernels, kernel_bins};
use super::light::Light;
use super::measure::{Measurements, PackedKernels, measure_clean, measure_clean_film};
use super::noise::NoiseField;
use super::preset::Sensor;
use super::{SensorError, TimeAxis};
use crate::film::FilmSnapshot;

/// Most kernel weights (gates x bins each reads) a model may hold: 2^26, 0.5 GiB in
/// f64 (e.g. 64 dense gates over 2^20 bins).
pub const MAX_KERNEL_WEIGHTS: u64 = 1 << 26;

/// Refuses more than [`MAX_KERNEL_WEIGHTS`] kernel weights.
fn check_weights(weights: u64, gates: usize, axis: &TimeAxis) -> Result<(), SensorError> {
    if weights > MAX_KERNEL_WEIGHTS {
        return Err(SensorError::TooMany {
            what: format!("kernel weights ({gates} gates over {} bins)", axis.bins),
            count: weights,
            max: MAX_KERNEL_WEIGHTS,
        });
    }
    Ok(())
}

/// A sensor ready to measure cubes on one time axis.
#[derive(Clone, Debug)]
pub struct SensorModel {
    sensor: Sensor,
    axis: TimeAxis,
    light: Light,
    gates: Vec<Gate>,
    kernels: Vec<SparseKernel>,
    packed: PackedKernels,
    transfer: BinTransfer,
}

/// What [`SensorModel::update`] had to redo.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Update {
    /// Nothing changed.
    Unchanged,
    /// Only noise or derived outputs changed: the kernels were kept.
    Settings,
    /// The light or the gates changed: the kernels were recomputed.
    Kernels,
}

/// One pixel through the sensor, on the cube's bins (for a pixel plot or CSV).
#[derive(Clone, Debug, PartialEq)]
pub struct PixelTrace {
    /// `TPRF[b]`: the cube's bins (integral over the bin).
    pub tprf: Vec<f64>,
    /// `(TPRF * Light)` integrated over each bin (light falling past the window's end
    /// is not shown).
    pub tprf_light: Vec<f64>,
    /// `sum_b TPRF[b] K_i[b]` per gate: the measurements before noise and `max(0, .)`.
    pub m_clean: Vec<f64>,
}

impl SensorModel {
    /// Checks `sensor` and computes its kernels on `axis`.
    pub fn new(sensor: Sensor, axis: TimeAxis) -> Result<SensorModel, SensorError> {
        let light = sensor.light.compile()?;
        let gates = sensor.exposure.gates(axis.t0_s)?;
        sensor.noise.validate()?;
        sensor.validate_ambient()?;
        sensor.derived.validate(&sensor.exposure, &gates)?;
        if let Some(spad) = &sensor.spad {
            spad.validate(&sensor.exposure)?;
        }
        let kernels = match sensor.exposure.tdc_cycle_s() {
            Some((cycle_s, _)) => folded_kernels(&light, &gates, cycle_s, &axis)?,
            None => {
                let weights: u64 = gates
                    .iter()
                    .filter_map(|g| kernel_bins(&light, g, &axis))
                    .map(|(lo, hi)| (hi - lo + 1) as u64)
                    .sum();
                check_weights(weights, gates.len(), &axis)?;
                compute_kernels(&light, &gates, &axis)
            }
        };
        let weights: u64 = kernels.iter().map(|k| k.weights.len() as u64).sum();
        check_weights(weights, gates.len(), &axis)?;
        for (i, k) in kernels.iter().enumerate() {
            let total: f64 = k.weights.iter().map(|w| w.abs()).sum();
            if !(total <= super::MAX_SCALE) {
                return Err(SensorError::Invalid(format!(
                    "gate {i}'s kernel sums to {total:.3e} (light energy x exposure gain): \
                     above 1e30 its measurements would overflow float32; lower \
                     light.energy or exposure.gain"
                )));
            }
        }
        let packed = PackedKernels::new(&kernels, axis.bins);
        let transfer = BinTransfer::new(&light, axis.dt_s, axis.bins.saturating_sub(1));
        Ok(SensorModel {
            sensor,
            axis,
            light,
            gates,
            kernels,
            packed,
            transfer,
        })
    }

    /// Takes an edited sensor. Kernels are recomputed only when the light or the
    /// exposure changed. On error the model is left as it was.
    pub fn update(&mut self, sensor: &Sensor) -> Result<Update, SensorError> {
        if *sensor == self.sensor {
            return Ok(Update::Unchanged);
        }
        if sensor.light == self.sensor.light && sensor.exposure == self.sensor.exposure {
            sensor.noise.validate()?;
            sensor.derived.validate(&sensor.exposure, &self.gates)?;
            sensor.validate_ambient()?;
            if let Some(spad) = &sensor.spad {
                spad.validate(&sensor.exposure)?;
            }
            self.sensor = sensor.clone();
            return Ok(Update::Settings);
        }
        *self = SensorModel::new(sensor.clone(), self.axis)?;
        Ok(Update::Kernels)
    }

    /// Moves the model to another time axis (a new render window).
    pub fn set_axis(&mut self, axis: TimeAxis) -> Result<Update, SensorError> {
        if axis == self.axis {
            return Ok(Update::Unchanged);
        }
        *self = SensorModel::new(self.sensor.clone(), axis)?;
        Ok(Update::Kernels)
    }

    pub fn sensor(&self) -> &Sensor {
        &self.sensor
    }

    pub fn axis(&self) -> &TimeAxis {
        &self.axis
    }

    /// The compiled light envelope.
    pub fn light(&self) -> &Light {
        &self.light
    }

    /// The gates at absolute times.
    pub fn gates(&self) -> &[Gate] {
        &self.gates
    }

    /// The number of measurements per pixel, `N`.
    pub fn gate_count(&self) -> usize {
        self.gates.len()
    }

    /// `K_i[b]` for every gate.
    pub fn kernels(&self) -> &[SparseKernel] {
        &self.kernels
    }

    /// The kernels as the measurement reads them.
    pub fn packed(&self) -> &PackedKernels {
        &self.packed
    }

    /// The integral term `sum_b TPRF[b] K_i[b]` for a cube `[height, width, T]`: no
    /// noise, no `max(0, .)`.
    pub fn measure_clean(
        &self,
        cube: &[f32],
        width: usize,
        height: usize,
    ) -> Result<Measurements, SensorError> {
        let m = measure_clean(&self.packed, cube, width, height)?;
        let plane = (width * height).max(1);
        if let Some(j) = m.values.iter().position(|v| !v.is_finite()) {
            let (gate, p) = (j / plane, j % plane);
            return Err(SensorError::Invalid(format!(
                "gate {gate} at pixel (row {}, column {}) measures {}: the cube times the \
                 gate's kernel is outside float32 (or the cube holds NaN or infinite bins)",
                p / width.max(1),
                p % width.max(1),
                m.values[j]
            )));
        }
        Ok(m)
    }

    /// [`SensorModel::measure_clean`] of a film snapshot, reading only its stored bins.
    pub fn measure_clean_film(&self, snap: &FilmSnapshot) -> Measurements {
        measure_clean_film(&self.packed, snap)
    }

    /// The sensor model `M_i = max(0, Noise + sum_b TPRF[b] K_i[b])` for a cube
    /// `[height, width, T]`: measurements `[N, height, width]`.
    pub fn measure(
        &self,
        cube: &[f32],
        width: usize,
        height: usize,
    ) -> Result<Measurements, SensorError> {
        let mut m = self.measure_clean(cube, width, height)?;
        self.apply_noise(&mut m);
        Ok(m)
    }

    /// Noise and `max(0, .)` on clean measurements (to reuse a clean result when only
    /// the noise changed).
    pub fn apply_noise(&self, m: &mut Measurements) {
        self.sensor.noise.apply(&mut m.values);
    }

    /// [`SensorModel::apply_noise`] keeping the normal draws in `field`: after the
    /// first call with a seed, a `sigma` edit costs one multiply-add per measurement.
    pub fn apply_noise_cached(&self, m: &mut Measurements, field: &mut NoiseField) {
        self.sensor.noise.apply_cached(&mut m.values, field);
    }

    /// One pixel's TPRF (`T` bins of the cube) through the sensor.
    pub fn pixel_trace(&self, tprf: &[f32]) -> Result<PixelTrace, SensorError> {
        if tprf.len() != self.axis.bins {
            return Err(SensorError::CubeSize {
                got: tprf.len(),
                height: 1,
                width: 1,
                bins: self.axis.bins,
                expected: self.axis.bins,
            });
        }
        Ok(PixelTrace {
            tprf: tprf.iter().map(|&v| f64::from(v)).collect(),
            tprf_light: self.transfer.apply(tprf),
            m_clean: self.kernels.iter().map(|k| k.dot(tprf)).collect(),
        })
    }

    /// `(TPRF * Light)` of one pixel over every bin it reaches, past the window's ends
    /// included: `(k0, v)`, `v[j]` the integral over bin `k0 + j` of the axis extended
    /// both ways (see [`BinTransfer::apply_full`]).
    pub fn tprf_light_full(&self, tprf: &[f32]) -> (i64, Vec<f64>) {
        self.transfer.apply_full(tprf)
    }

    /// `Light(t)` at each of `t_s` (W per unit of the cube's pulse energy); a delta
    /// light is 0 here: see [`Light::delta_time_s`].
    pub fn light_curve(&self, t_s: &[f64]) -> Vec<f64> {
        self.light.sample(t_s)
    }

    /// `Exposure_i(t)` at each of `t_s` (empty if there is no gate `i`).
    pub fn exposure_curve(&self, i: usize, t_s: &[f64]) -> Vec<f64> {
        self.gates.get(i).map_or_else(Vec::new, |g| g.sample(t_s))
    }

    /// A time range (s) holding the cube's window, the light pulse and every gate with
    /// a finite support: a default range for plotting them together.
    pub fn time_span_s(&self) -> (f64, f64) {
        let (l_lo, l_hi) = self.light.support_s();
        let mut lo = self.axis.t0_s.min(l_lo);
        let mut hi = self.axis.end_s().max(l_hi);
        for (a, b) in self.gates.iter().filter_map(Gate::support_s) {
            lo = lo.min(a);
            hi = hi.max(b);
        }
        (lo, hi)
    }

    /// Gate centres (s), when every gate has one.
    pub fn gate_centres_s(&self) -> Option<Vec<f64>> {
        self.gates.iter().map(Gate::centre_s).collect()
    }

    /// The returns' depths and intensities (first, strongest, last, multi-echo) when
    /// the sensor asks for them.
    pub fn returns(&self, m: &Measurements) -> Option<ReturnImages> {
        let p = self.sensor.derived.returns.as_ref()?;
        let centres = self.gate_centres_s()?;
        Some(derived::return_images(m, &centres, self.light.mean_s(), p))
    }

    /// For AMCW gates: the phase (rad) the sensor reports for a single return at
    /// `tau = 0`, `atan2(sum K_i(0) sin phi_i, sum K_i(0) cos phi_i)`, with the
    /// unbinned `K_i(0) = integral Light(s) Exposure_i(s) ds`. Subtracting it removes
    /// the light's own delay and shape from the phase.
    pub fn amcw_phase_offset_rad(&self) -> Option<f64> {
        let phases = self.amcw_phases_rad()?;
        let mut scratch = Vec::new();
        let (mut c, mut s) = (0.0, 0.0);
        for (g, phi) in self.gates.iter().zip(&phases) {
            let k0 = self.light.integrate(
                |t| g.value(t),
                f64::NEG_INFINITY,
                f64::INFINITY,
                &[],
                0.0,
                g.scale_s(),
                &mut scratch,
            );
            c += k0 * phi.cos();
            s += k0 * phi.sin();
        }
        Some(s.atan2(c))
    }

    /// The AMCW gates' frequency (Hz) and phases (rad).
    fn amcw_phases_rad(&self) -> Option<Vec<f64>> {
        self.gates
            .iter()
            .map(|g| match g {
                Gate::Cosine { phase_rad, .. } => Some(*phase_rad),
                _ => None,
            })
            .collect()
    }

    /// Whether the sensor asks for AMCW depth (and has AMCW gates):
    /// [`SensorModel::amcw`] gives it.
    pub fn wants_amcw(&self) -> bool {
        self.sensor.derived.amcw_depth && matches!(self.sensor.exposure, Exposure::Amcw { .. })
    }

    /// FLIM's two-gate lifetime image `[H, W]` (seconds, [`derived::flim_lifetime_s`])
    /// when the sensor asks for it and its first two gates allow it.
    pub fn flim_lifetime(&self, m: &Measurements) -> Option<Vec<f32>> {
        if !self.sensor.derived.flim_lifetime {
            return None;
        }
        let dt_s = derived::flim_gate_spacing_s(&self.gates)?;
        Some(derived::flim_lifetime_s(m, dt_s))
    }

    /// AMCW phase, amplitude and depth when the sensor asks for them.
    pub fn amcw(&self, m: &Measurements) -> Option<AmcwImage> {
        if !self.wants_amcw() {
            return None;
        }
        let Exposure::Amcw { freq_hz, .. } = self.sensor.exposure else {
            return None;
        };
        let phases = self.amcw_phases_rad()?;
        let offset = self.amcw_phase_offset_rad()?;
        Some(derived::amcw_image(m, &phases, freq_hz, offset))
    }
}

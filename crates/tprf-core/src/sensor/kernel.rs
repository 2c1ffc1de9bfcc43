//! The correlation kernels `K_i` of DESIGN.md, integrated over the cube's bins.
//!
//! `integral (TPRF * Light)(t) Exposure_i(t) dt = integral TPRF(tau) K_i(tau) dtau`,
//! `K_i(tau) = integral Light(t - tau) Exposure_i(t) dt = integral Light(s)
//! Exposure_i(s + tau) ds` (dimensionless for a unit-energy light and a 0..1 gate).
//!
//! Bin `b` of a cube holds `integral_{bin b} TPRF`, and tprf takes the TPRF as spread
//! uniformly over the bin, so the bin meets the kernel averaged over it:
//!
//! `K_i[b] = (1/dt) integral_{tau_b}^{tau_b + dt} K_i(tau) dtau
//!         = integral Light(s) h_i(s + tau_b) ds`,
//!
//! `tau_b = t0 + b dt`, `h_i(u) = (1/dt) integral_u^{u + dt} Exposure_i` the gate
//! averaged over one bin ([`Gate::bin_average`], closed form). `h_i` is continuous with
//! known kinks, so the integral against the light is done piecewise
//! (`Light::integrate`): a delta light is one evaluation, a pulse a thousandth of a
//! bin wide keeps all its energy, and `M_i = sum_b TPRF[b] K_i[b]`.

use rayon::prelude::*;
use std::ops::Range;

use super::exposure::Gate;
use super::light::Light;
use crate::film::TimeAxis;

/// Kernel weights below this fraction of the kernel's largest are trimmed from its
/// ends (at least; see [`trim_fraction`]).
const TRIM_REL: f64 = 1e-12;

/// `K_i[b]` (dimensionless) for `b` in `first_bin..first_bin + weights.len()`, zero
/// elsewhere: only those bins of a pixel are read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseKernel {
    pub first_bin: usize,
    pub weights: Vec<f64>,
}

impl SparseKernel {
    /// The bins where the kernel may be non-zero.
    pub fn bins(&self) -> Range<usize> {
        self.first_bin..self.first_bin + self.weights.len()
    }

    /// `K_i[b]`.
    pub fn get(&self, b: usize) -> f64 {
        b.checked_sub(self.first_bin)
            .and_then(|k| self.weights.get(k))
            .copied()
            .unwrap_or(0.0)
    }

    /// All `bins` weights, zeros included.
    pub fn to_dense(&self, bins: usize) -> Vec<f64> {
        (0..bins).map(|b| self.get(b)).collect()
    }

    /// `sum_b tprf[b] K_i[b]` in f64 (one pixel; the cube goes through
    /// [`super::measure`]).
    pub fn dot(&self, tprf: &[f32]) -> f64 {
        tprf.get(self.bins())
            .unwrap_or(&[])
            .iter()
            .zip(&self.weights)
            .map(|(&v, &w)| f64::from(v) * w)
            .sum()
    }
}

/// The bins (inclusive range) where `K_i[b]` of `gate` can be non-zero: those whose
/// start `tau_b` lets the light's support reach the gate,
/// `tau_b` in `[g_lo - s_hi, g_hi - s_lo]`. `None` when no bin can.
pub fn kernel_bins(light: &Light, gate: &Gate, axis: &TimeAxis) -> Option<(usize, usize)> {
    let dt = axis.dt_s;
    let (s_lo, s_hi) = light.support_s();
    let (g_lo, g_hi) = gate.bin_average_support(dt);
    let b_lo = ((g_lo - s_hi - axis.t0_s) / dt).floor().max(0.0);
    let b_hi = ((g_hi - s_lo - axis.t0_s) / dt)
        .ceil()
        .min(axis.bins as f64 - 1.0);
    (b_hi >= b_lo).then_some((b_lo as usize, b_hi as usize))
}

/// `K_i[b]` of one gate over `axis`.
pub fn kernel(light: &Light, gate: &Gate, axis: &TimeAxis) -> SparseKernel {
    let Some((b_lo, b_hi)) = kernel_bins(light, gate, axis) else {
        return SparseKernel::default();
    };
    let dt = axis.dt_s;
    // A Gaussian light through a box, jittered or Gaussian gate: the gate blurred by the
    // light (variances add), each weight in closed form, `K[b] = energy factor
    // blurred.bin_average(tau_b + mu, dt)`, with no quadrature (a light edit recomputes
    // every kernel on the viewer's frame).
    if let Some((mu_s, sigma_s)) = light.gaussian()
        && let Some((blurred, factor)) = gate.blurred(sigma_s)
    {
        let scale = light.energy() * factor;
        let weights: Vec<f64> = (b_lo..=b_hi)
            .map(|b| scale * blurred.bin_average(axis.bin_start_s(b) + mu_s, dt))
            .collect();
        return trimmed(b_lo, weights, trim_fraction(axis));
    }
    by_quadrature(light, gate, axis, b_lo..=b_hi)
}

/// [`kernel`] over bins `bins` by quadrature of `Light(s) gate.bin_average(s + tau_b)`
/// (8-point Gauss-Legendre between the kinks of both): any light, any gate.
fn by_quadrature(
    light: &Light,
    gate: &Gate,
    axis: &TimeAxis,
    bins: std::ops::RangeInclusive<usize>,
) -> SparseKernel {
    let (b_lo, dt) = (*bins.start(), axis.dt_s);
    let (g_lo, g_hi) = gate.bin_average_support(dt);
    let mut breaks = Vec::new();
    gate.bin_average_breaks(dt, &mut breaks);
    let scale = gate.scale_s();
    let mut scratch = Vec::new();
    let weights: Vec<f64> = bins
        .map(|b| {
            let tau = axis.bin_start_s(b);
            light.integrate(
                |s| gate.bin_average(s + tau, dt),
                g_lo - tau,
                g_hi - tau,
                &breaks,
                tau,
                scale,
                &mut scratch,
            )
        })
        .collect();
    trimmed(b_lo, weights, trim_fraction(axis))
}

/// The fraction of a kernel's largest weight below which its end weights are dropped:
/// [`TRIM_REL`], or the rounding of times on `axis` (a few ulps of the latest time, in
/// bins), whichever is larger, so that a gate edge on a bin edge does not leave a
/// rounding-sized weight in the next bin.
fn trim_fraction(axis: &TimeAxis) -> f64 {
    let t_max = axis.t0_s.abs().max(axis.end_s().abs());
    TRIM_REL.max(8.0 * f64::EPSILON * t_max / axis.dt_s)
}

/// Drops the negligible ends of a kernel.
fn trimmed(first_bin: usize, mut weights: Vec<f64>, fraction: f64) -> SparseKernel {
    let max = weights.iter().fold(0.0f64, |m, w| m.max(w.abs()));
    if !(max > 0.0) {
        return SparseKernel::default();
    }
    let keep = |w: &f64| w.abs() > fraction * max;
    let start = weights.iter().position(keep).unwrap_or(0);
    let end = weights.iter().rposition(keep).map_or(0, |e| e + 1);
    weights.truncate(end);
    weights.drain(..start);
    SparseKernel {
        first_bin: first_bin + start,
        weights,
    }
}

/// `K_i[b]` for every gate, in parallel over the gates.
pub fn compute_kernels(light: &Light, gates: &[Gate], axis: &TimeAxis) -> Vec<SparseKernel> {
    gates.par_iter().map(|g| kernel(light, g, axis)).collect()
}

/// Most shifted copies of a TDC's bins [`folded_kernels`] may evaluate (bins x laser
/// cycles the arrivals span).
pub const MAX_TDC_COPIES: u64 = 1 << 18;

/// The kernels of a TDC's `gates` (its bins in the first laser cycle) with the
/// arrivals folded into the cycle: `K_k[b] = sum_n K[gate k shifted by n cycle_s][b]`
/// over every cycle `n` in which light from the cube's window can reach the bin. So a
/// photon arriving a cycle late (or early) counts in the same bin as it would in its
/// own cycle: the rate a periodic laser gives. Errors when the window spans so many
/// cycles that more than [`MAX_TDC_COPIES`] shifted bins would be needed.
pub fn folded_kernels(
    light: &Light,
    gates: &[Gate],
    cycle_s: f64,
    axis: &TimeAxis,
) -> Result<Vec<SparseKernel>, super::SensorError> {
    let (s_lo, s_hi) = light.support_s();
    let dt = axis.dt_s;
    let mut copies: Vec<(usize, Gate)> = Vec::new();
    for (k, g) in gates.iter().enumerate() {
        let (g_lo, g_hi) = g.bin_average_support(dt);
        let n_lo = ((axis.t0_s - g_hi + s_lo) / cycle_s).floor();
        let n_hi = ((axis.end_s() - g_lo + s_hi) / cycle_s).ceil();
        let n = n_hi - n_lo + 1.0;
        if !(n.is_finite() && (copies.len() as f64 + n.max(0.0)) <= MAX_TDC_COPIES as f64) {
            return Err(super::SensorError::TooMany {
                what: format!(
                    "TDC bins over the laser cycles the window spans (cycle {cycle_s:e} s, \
                     window {:e} .. {:e} s)",
                    axis.t0_s,
                    axis.end_s()
                ),
                count: (gates.len() as f64 * n.max(0.0)).min(u64::MAX as f64) as u64,
                max: MAX_TDC_COPIES,
            });
        }
        // Cycle numbers beyond 2^52 are not distinct doubles: shifts by them would repeat.
        if n_lo.abs().max(n_hi.abs()) > (1u64 << 52) as f64 {
            return Err(super::SensorError::Invalid(format!(
                "the cube's window ({:e} .. {:e} s) lies {:e} laser cycles of {cycle_s:e} s \
                 from the trigger: too many to tell apart",
                axis.t0_s,
                axis.end_s(),
                n_lo.abs().max(n_hi.abs())
            )));
        }
        // Counted in integers: `i += 1.0` stops moving at large `i`.
        for j in 0..n.max(0.0) as u64 {
            copies.push((k, g.shifted((n_lo + j as f64) * cycle_s)));
        }
    }
    let pieces = shifted_kernels(light, &copies, axis);
    let mut folded: Vec<SparseKernel> = vec![SparseKernel::default(); gates.len()];
    for (k, piece) in pieces {
        if piece.weights.is_empty() {
            continue;
        }
        let Some(f) = folded.get_mut(k) else {
            continue;
        };
        if f.weights.is_empty() {
            *f = piece;
            continue;
        }
        let lo = f.first_bin.min(piece.first_bin);
        let hi = (f.first_bin + f.weights.len()).max(piece.first_bin + piece.weights.len());
        let mut w = vec![0.0; hi - lo];
        for (src, at) in [(&f.weights, f.first_bin), (&piece.weights, piece.first_bin)] {
            for (slot, v) in w[at - lo..].iter_mut().zip(src) {
                *slot += v;
            }
        }
        *f = SparseKernel {
            first_bin: lo,
            weights: w,
        };
    }
    Ok(folded)
}

/// Where a box or jittered gate lies on `axis`'s bin grid: `(m, key)` with its start at
/// `t0 + (m + phase) dt`, and `key` its shape and phase (to 1e-9 of a bin). Gates of one
/// key have the same kernel shifted by their difference in `m`: a kernel weight
/// depends on a bin's time only through its offset from the gate. Other gates: `None`.
fn grid_key(g: &Gate, axis: &TimeAxis) -> Option<(i64, [i64; 4])> {
    let (start_s, end_s, kind, shape) = match *g {
        Gate::Jittered {
            start_s,
            end_s,
            sigma_s,
        } => (start_s, end_s, 1, sigma_s / axis.dt_s),
        Gate::Box {
            start_s,
            end_s,
            gain,
        } => (start_s, end_s, 2, gain),
        _ => return None,
    };
    let at = (start_s - axis.t0_s) / axis.dt_s;
    let m = at.floor();
    let q = |x: f64| (x * 1e9).round();
    let key = [q(at - m), q((end_s - start_s) / axis.dt_s), q(shape)];
    if !(m.abs() < 1e15 && key.iter().all(|k| k.abs() < 9e18)) {
        return None;
    }
    Some((
        m as i64,
        [kind, key[0] as i64, key[1] as i64, key[2] as i64],
    ))
}

/// [`kernel`] of every `(k, gate)` of `copies`. Shifted copies of one gate shape (a
/// TDC's bins, each shifted by whole cycles: [`grid_key`]) share one evaluation: the
/// first copy of a key whose kernel lies wholly inside the axis is computed, the others
/// are it shifted by whole bins, cut to the axis and trimmed as [`kernel`] trims. At
/// 512 TDC bins of 5 cube bins each, 5 kernels are integrated instead of every bin's
/// (the weights agree to rounding: a bin's time is `t0 + b dt` either way).
fn shifted_kernels(
    light: &Light,
    copies: &[(usize, Gate)],
    axis: &TimeAxis,
) -> Vec<(usize, SparseKernel)> {
    use std::collections::HashMap;
    let bins = axis.bins as i64;
    let inside = |g: &Gate| {
        let (s_lo, s_hi) = light.support_s();
        let (g_lo, g_hi) = g.bin_average_support(axis.dt_s);
        let lo = ((g_lo - s_hi - axis.t0_s) / axis.dt_s).floor();
        let hi = ((g_hi - s_lo - axis.t0_s) / axis.dt_s).ceil();
        lo >= 0.0 && hi <= (bins - 1) as f64
    };
    let keys: Vec<Option<(i64, [i64; 4])>> =
        copies.iter().map(|(_, g)| grid_key(g, axis)).collect();
    // One template a key: the first copy lying inside the axis.
    let mut templates: HashMap<[i64; 4], (i64, usize)> = HashMap::new();
    for (i, ((_, g), key)) in copies.iter().zip(&keys).enumerate() {
        if let Some((m, key)) = *key
            && !templates.contains_key(&key)
            && inside(g)
        {
            templates.insert(key, (m, i));
        }
    }
    let computed: HashMap<[i64; 4], (i64, SparseKernel)> = templates
        .into_par_iter()
        .map(|(key, (m, i))| (key, (m, kernel(light, &copies[i].1, axis))))
        .collect();
    let fraction = trim_fraction(axis);
    copies
        .par_iter()
        .zip(&keys)
        .map(|((k, g), key)| {
            let shared = key.and_then(|(m, key)| computed.get(&key).map(|c| (m, c)));
            let Some((m, (m0, t))) = shared else {
                return (*k, kernel(light, g, axis));
            };
            if t.weights.is_empty() {
                return (*k, SparseKernel::default());
            }
            // The template's bins moved by m - m0, cut to the axis.
            let first = t.first_bin as i64 + (m - m0);
            let last = first + t.weights.len() as i64;
            let (lo, hi) = (first.max(0), last.min(bins));
            if lo >= hi {
                return (*k, SparseKernel::default());
            }
            let w = t.weights[(lo - first) as usize..(hi - first) as usize].to_vec();
            (*k, trimmed(lo as usize, w, fraction))
        })
        .collect()
}

/// The light's transfer between bins: entry `d - first_offset` is
/// `P[d] = (1/dt) integral_{tau in bin b} integral_{t in bin b + d} Light(t - tau) dt dtau
/// = integral Light(s) tri(s - d dt) ds` (`tri` the unit-height triangle of half-width
/// `dt`), for offsets `|d| <= max_offset`. `sum_b TPRF[b] P[k - b]` is
/// `(TPRF * Light)` integrated over bin `k`; `sum_d P[d]` is the light's energy.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BinTransfer {
    pub first_offset: i64,
    pub weights: Vec<f64>,
}

impl BinTransfer {
    /// The transfer of `light` on bins of width `dt_s`, offsets within `max_offset`.
    pub fn new(light: &Light, dt_s: f64, max_offset: usize) -> BinTransfer {
        let (s_lo, s_hi) = light.support_s();
        let limit = max_offset as f64;
        let d_lo = ((s_lo / dt_s).floor() - 1.0).max(-limit);
        let d_hi = ((s_hi / dt_s).ceil() + 1.0).min(limit);
        if !(d_hi >= d_lo) {
            return BinTransfer::default();
        }
        let (d_lo, d_hi) = (d_lo as i64, d_hi as i64);
        let mut scratch = Vec::new();
        let weights = (d_lo..=d_hi)
            .map(|d| {
                let c = d as f64 * dt_s;
                light.integrate(
                    |s| (1.0 - (s - c).abs() / dt_s).max(0.0),
                    c - dt_s,
                    c + dt_s,
                    &[c],
                    0.0,
                    f64::INFINITY,
                    &mut scratch,
                )
            })
            .collect();
        BinTransfer {
            first_offset: d_lo,
            weights,
        }
    }

    /// `(TPRF * Light)` integrated over every bin it reaches, those outside the TPRF's
    /// axis included: `(k0, v)` with `v[j]` the integral over bin `k0 + j` of the axis
    /// extended both ways (`k0` may be negative). Nothing is cut: `sum v` is the TPRF's
    /// sum times the light's energy (as far as `max_offset` allowed the transfer).
    pub fn apply_full(&self, tprf: &[f32]) -> (i64, Vec<f64>) {
        if self.weights.is_empty() || tprf.is_empty() {
            return (0, vec![0.0; tprf.len()]);
        }
        let mut out = vec![0.0; tprf.len() + self.weights.len() - 1];
        for (b, &v) in tprf.iter().enumerate() {
            if v == 0.0 {
                continue;
            }
            for (j, &w) in self.weights.iter().enumerate() {
                out[b + j] += f64::from(v) * w;
            }
        }
        (self.first_offset, out)
    }

    /// `(TPRF * Light)` integrated over each bin of the TPRF's axis (what falls past
    /// the last bin is not shown).
    pub fn apply(&self, tprf: &[f32]) -> Vec<f64> {
        let n = tprf.len() as i64;
        let mut out = vec![0.0; tprf.len()];
        for (b, &v) in tprf.iter().enumerate() {
            if v == 0.0 {
                continue;
            }
            for (j, &w) in self.weights.iter().enumerate() {
                let k = b as i64 + self.first_offset + j as i64;
                if (0..n).contains(&k) {
                    out[k as usize] += f64::from(v) * w;
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Shifted copies sharing one integration ([`shifted_kernels`]) against each copy
    /// integrated on its own ([`kernel`]): a TDC of 64 bins of 5 cube bins (and of 3.7,
    /// off the grid) through jitter and a Gaussian pulse, over a window that cuts the
    /// cycle's kernels at both ends and spans two cycles.
    #[test]
    fn shared_shifted_kernels_are_each_kernel_integrated() {
        use crate::sensor::{Exposure, LightPulse, TimeOrigin};
        let dt = 20e-12;
        let axis = TimeAxis::new(1e-9, dt, 300).unwrap();
        let light = LightPulse::Gaussian {
            centre_s: 0.4e-9,
            fwhm_s: 0.3e-9,
            energy: 1.0,
        }
        .compile()
        .unwrap();
        for (width_bins, jitter_s) in [(5.0, 50e-12), (3.7, 50e-12), (5.0, 0.0)] {
            let exposure = Exposure::Tdc {
                origin: TimeOrigin::Window,
                start_s: -0.5e-9,
                bin_width_s: width_bins * dt,
                bins: 64,
                jitter_fwhm_s: jitter_s,
            };
            let gates = exposure.gates(axis.t0_s).unwrap();
            let (cycle_s, _) = exposure.tdc_cycle_s().unwrap();
            let copies: Vec<(usize, Gate)> = gates
                .iter()
                .enumerate()
                .flat_map(|(k, g)| (-1..=2).map(move |n| (k, g.shifted(n as f64 * cycle_s))))
                .collect();
            let shared = shifted_kernels(&light, &copies, &axis);
            let direct: Vec<SparseKernel> = copies
                .iter()
                .map(|(_, g)| kernel(&light, g, &axis))
                .collect();
            // The scale: a whole kernel's peak (a copy cut by the window keeps tails the
            // shared one trimmed below 1e-12 of it).
            let peak = direct
                .iter()
                .flat_map(|k| k.weights.iter())
                .fold(0.0f64, |m, w| m.max(w.abs()));
            let mut lit = 0;
            for (((k, _), (k2, got)), want) in copies.iter().zip(&shared).zip(&direct) {
                assert_eq!(k, k2);
                lit += usize::from(!want.weights.is_empty());
                for b in 0..axis.bins {
                    assert!(
                        (got.get(b) - want.get(b)).abs() <= 1e-10 * peak,
                        "width {width_bins} bins, jitter {jitter_s}: gate {k} bin {b}: {} vs {}",
                        got.get(b),
                        want.get(b)
                    );
                }
            }
            assert!(lit > 20, "too few kernels inside the window: {lit}");
        }
    }

    /// The closed form of a Gaussian light through a box, a jittered box and a Gaussian
    /// gate (the gate blurred by the light) against the quadrature any light and gate
    /// take: every bin within 1e-9 of the peak, on bins finer and coarser than the
    /// pulse.
    #[test]
    fn gaussian_light_closed_form_is_the_quadrature() {
        let light = crate::sensor::LightPulse::Gaussian {
            centre_s: 0.4e-9,
            fwhm_s: 0.3e-9,
            energy: 2.5,
        }
        .compile()
        .unwrap();
        assert!(light.gaussian().is_some());
        let gates = [
            Gate::Box {
                start_s: 2.0e-9,
                end_s: 2.7e-9,
                gain: 1.5,
            },
            Gate::Jittered {
                start_s: 2.0e-9,
                end_s: 2.1e-9,
                sigma_s: 40e-12,
            },
            Gate::Gaussian {
                centre_s: 2.5e-9,
                sigma_s: 0.2e-9,
                peak: 3.0,
            },
        ];
        for dt in [7e-12, 20e-12, 0.45e-9] {
            let axis = TimeAxis::new(-1e-9, dt, (7e-9 / dt) as usize).unwrap();
            for g in &gates {
                let closed = kernel(&light, g, &axis);
                let (lo, hi) = kernel_bins(&light, g, &axis).unwrap();
                let quad = by_quadrature(&light, g, &axis, lo..=hi);
                let peak = quad.weights.iter().fold(0.0f64, |m, w| m.max(w.abs()));
                assert!(peak > 0.0);
                for b in 0..axis.bins {
                    assert!(
                        (closed.get(b) - quad.get(b)).abs() <= 1e-9 * peak,
                        "{g:?} dt {dt}: bin {b}: {} vs {}",
                        closed.get(b),
                        quad.get(b)
                    );
                }
                // Energy: the weights sum to energy x factor x integral of the gate / dt.
                let sum: f64 = closed.weights.iter().sum();
                let want = 2.5 * g.integral_s().unwrap() / dt;
                assert!(
                    (sum - want).abs() <= 1e-9 * want,
                    "{g:?} dt {dt}: {sum} vs {want}"
                );
            }
        }
    }

    /// A delta 3 bins after the trigger moves the TPRF 3 bins later, times its energy;
    /// the full result keeps what the clipped one drops past the end.
    #[test]
    fn the_full_convolution_keeps_what_falls_outside() {
        let dt = 1e-9;
        let light = crate::sensor::LightPulse::Delta {
            t_s: 3.0 * dt,
            energy: 2.0,
        }
        .compile()
        .unwrap();
        let t = BinTransfer::new(&light, dt, 10);
        let tprf = [1.0f32, 0.0, 0.5, 0.25];
        let (k0, full) = t.apply_full(&tprf);
        let clipped = t.apply(&tprf);
        let at = |k: i64| {
            usize::try_from(k - k0)
                .ok()
                .and_then(|j| full.get(j))
                .copied()
                .unwrap_or(0.0)
        };
        // Bins 3, 5 and 6 of the extended axis.
        assert!((at(3) - 2.0).abs() < 1e-9);
        assert!((at(5) - 1.0).abs() < 1e-9);
        assert!((at(6) - 0.5).abs() < 1e-9);
        assert!((full.iter().sum::<f64>() - 3.5).abs() < 1e-9);
        // The axis' own bins agree with the clipped result, which loses bins 5 and 6.
        for (k, c) in clipped.iter().enumerate() {
            assert!((at(k as i64) - c).abs() < 1e-12);
        }
        assert!((clipped.iter().sum::<f64>() - 2.0).abs() < 1e-9);
    }
}

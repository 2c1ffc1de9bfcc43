//! The noise of the sensor model: `M_i = max(0, Noise + signal)`.
//!
//! The paper's term is additive Gaussian white noise of standard deviation `sigma` (in
//! the unit of a measurement). Beyond the paper, optional photon (shot) noise: with
//! `photons_per_energy = k > 0` the signal `m` becomes `Poisson(k m) / k`.
//!
//! Every measurement (index `j` of the `[N, H, W]` array) draws from its own random
//! stream keyed by `(seed, j)`, so the same seed gives the same noise whatever the
//! thread count, and moving the `sigma` slider scales one fixed noise pattern instead
//! of drawing a new one.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{SensorError, non_negative};

/// Photon counts above this are drawn from the normal approximation (relative error
/// of the count's distribution below 1e-6).
const POISSON_NORMAL_ABOVE: f64 = 1e12;

/// Noise settings; all off by default.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Noise {
    /// Standard deviation of the additive Gaussian white noise, in the unit of a
    /// measurement. 0: none.
    pub sigma: f64,
    /// Seed of the noise streams.
    pub seed: u64,
    /// Photons per unit of measurement (energy); 0: no photon noise.
    pub photons_per_energy: f64,
}

/// A SplitMix64 counter stream (Steele, Lea & Flood 2014): cheap to key per
/// measurement, and statistically sound for noise.
struct Stream(u64);

fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Stream {
    fn new(seed: u64, index: u64, purpose: u64) -> Stream {
        Stream(mix(mix(seed ^ 0x6A09_E667_F3BC_C909)
            ^ index.rotate_left(17)
            ^ purpose))
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        mix(self.0)
    }

    /// Uniform in (0, 1).
    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
    }

    /// Two independent standard normals (Box-Muller, both outputs).
    fn normal_pair(&mut self) -> (f64, f64) {
        let (u1, u2) = (self.uniform(), self.uniform());
        let r = (-2.0 * u1.ln()).sqrt();
        let (sin, cos) = (std::f64::consts::TAU * u2).sin_cos();
        (r * cos, r * sin)
    }

    /// One standard normal.
    fn normal(&mut self) -> f64 {
        self.normal_pair().0
    }

    /// Poisson with mean `lambda >= 0`: inversion below 12, Hormann's transformed
    /// rejection (PTRS, 1993) above.
    fn poisson(&mut self, lambda: f64) -> f64 {
        if !(lambda > 0.0) {
            return 0.0;
        }
        if lambda > POISSON_NORMAL_ABOVE {
            return (lambda + lambda.sqrt() * self.normal()).round().max(0.0);
        }
        if lambda < 12.0 {
            let mut p = (-lambda).exp();
            let mut cdf = p;
            let u = self.uniform();
            let mut k = 0.0;
            while u > cdf && k < 1000.0 {
                k += 1.0;
                p *= lambda / k;
                cdf += p;
            }
            return k;
        }
        let slam = lambda.sqrt();
        let loglam = lambda.ln();
        let b = 0.931 + 2.53 * slam;
        let a = -0.059 + 0.02483 * b;
        let inv_alpha = 1.1239 + 1.1328 / (b - 3.4);
        let vr = 0.9277 - 3.6224 / (b - 2.0);
        loop {
            let u = self.uniform() - 0.5;
            let v = self.uniform();
            let us = 0.5 - u.abs();
            let k = ((2.0 * a / us + b) * u + lambda + 0.43).floor();
            if us >= 0.07 && v <= vr {
                return k;
            }
            if k < 0.0 || (us < 0.013 && v > us) {
                continue;
            }
            let lhs = v.ln() + inv_alpha.ln() - (a / (us * us) + b).ln();
            let rhs = -lambda + k * loglam - libm::lgamma(k + 1.0);
            if lhs <= rhs {
                return k;
            }
        }
    }
}

/// The standard normal `z_j` of measurement `index` under `seed` (the pattern that
/// `sigma` scales), rounded to f32 as it is applied. Measurements `2p` and `2p + 1`
/// share one Box-Muller draw.
pub fn standard_normal(seed: u64, index: u64) -> f32 {
    let (a, b) = Stream::new(seed, index >> 1, 0).normal_pair();
    (if index & 1 == 0 { a } else { b }) as f32
}

/// The standard normals `z_j` of one seed for `len` measurements, kept between calls:
/// with it, a `sigma` change costs one multiply-add per measurement
/// ([`Noise::apply_cached`]).
#[derive(Clone, Debug, Default)]
pub struct NoiseField {
    seed: u64,
    z: Vec<f32>,
}

impl NoiseField {
    /// `z_j` for `j < len` under `seed`, drawn again only when either changed.
    pub fn normals(&mut self, seed: u64, len: usize) -> &[f32] {
        if self.seed != seed || self.z.len() != len {
            const CHUNK: usize = 4096;
            self.seed = seed;
            self.z.resize(len, 0.0);
            self.z
                .par_chunks_mut(CHUNK)
                .enumerate()
                .for_each(|(c, chunk)| {
                    for (p, pair) in chunk.chunks_mut(2).enumerate() {
                        let index = ((c * CHUNK) / 2 + p) as u64;
                        let (a, b) = Stream::new(seed, index, 0).normal_pair();
                        pair[0] = a as f32;
                        if let Some(second) = pair.get_mut(1) {
                            *second = b as f32;
                        }
                    }
                });
        }
        &self.z
    }
}

impl Noise {
    /// Checks `sigma >= 0` and `photons_per_energy >= 0`, both finite.
    pub fn validate(&self) -> Result<(), SensorError> {
        non_negative("noise.sigma", self.sigma)?;
        non_negative("noise.photons_per_energy", self.photons_per_energy)?;
        Ok(())
    }

    /// `m -> max(0, sigma z + shot(m))` for every value (index `j` of the `[N, H, W]`
    /// array): `z_j` from [`standard_normal`], `shot(m) = Poisson(k m) / k` drawn from
    /// the value's own stream with photon noise on, `m` otherwise. With all noise off
    /// this is just `max(0, m)` (NaN becomes 0).
    pub fn apply(&self, values: &mut [f32]) {
        self.apply_cached(values, &mut NoiseField::default());
    }

    /// [`Noise::apply`] with the normals kept in `field` for the next call.
    pub fn apply_cached(&self, values: &mut [f32], field: &mut NoiseField) {
        const CHUNK: usize = 4096;
        let Noise {
            sigma,
            seed,
            photons_per_energy: k,
        } = *self;
        if k > 0.0 {
            values
                .par_chunks_mut(CHUNK)
                .enumerate()
                .for_each(|(c, chunk)| {
                    for (j, m) in chunk.iter_mut().enumerate() {
                        let mut s = Stream::new(seed, (c * CHUNK + j) as u64, 1);
                        *m = (s.poisson(k * f64::from(*m).max(0.0)) / k) as f32;
                    }
                });
        }
        if sigma > 0.0 {
            let sigma = sigma as f32;
            let z = field.normals(seed, values.len());
            values
                .par_chunks_mut(CHUNK)
                .zip(z.par_chunks(CHUNK))
                .for_each(|(m, z)| {
                    for (m, z) in m.iter_mut().zip(z) {
                        *m = (*m + sigma * z).max(0.0);
                    }
                });
        } else {
            values.par_chunks_mut(CHUNK).for_each(|m| {
                for m in m {
                    *m = m.max(0.0);
                }
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_and_poisson_moments() {
        let n = 200_000u64;
        let z: Vec<f64> = (0..n).map(|i| f64::from(standard_normal(7, i))).collect();
        let mean = z.iter().sum::<f64>() / n as f64;
        let var = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.01 && (var - 1.0).abs() < 0.01,
            "{mean} {var}"
        );
        for lambda in [0.3, 5.0, 40.0, 1e4] {
            let mut total = 0.0;
            let mut sq = 0.0;
            for i in 0..n {
                let k = Stream::new(3, i, 1).poisson(lambda);
                assert!(k >= 0.0 && k.fract() == 0.0);
                total += k;
                sq += k * k;
            }
            let mean = total / n as f64;
            let var = sq / n as f64 - mean * mean;
            assert!(
                (mean - lambda).abs() < 5.0 * (lambda / n as f64).sqrt(),
                "{lambda}: {mean}"
            );
            assert!((var / lambda - 1.0).abs() < 0.03, "{lambda}: var {var}");
        }
    }

    #[test]
    fn noise_is_seeded_and_never_negative() {
        let clean = vec![0.5f32; 10_000];
        let noise = Noise {
            sigma: 2.0,
            seed: 1,
            photons_per_energy: 10.0,
        };
        let (mut a, mut b) = (clean.clone(), clean.clone());
        noise.apply(&mut a);
        noise.apply(&mut b);
        assert_eq!(a, b);
        assert!(a.iter().all(|&v| v >= 0.0));
        let mut c = clean.clone();
        Noise { seed: 2, ..noise }.apply(&mut c);
        assert_ne!(a, c);
        // The cached normals give the same result, and are the documented ones.
        let mut d = clean.clone();
        let mut field = NoiseField::default();
        noise.apply_cached(&mut d, &mut field);
        assert_eq!(a, d);
        let only_gauss = Noise {
            photons_per_energy: 0.0,
            ..noise
        };
        let mut e = vec![100.0f32; 5];
        only_gauss.apply_cached(&mut e, &mut field);
        for (j, v) in e.iter().enumerate() {
            assert_eq!(*v, 100.0 + 2.0 * standard_normal(1, j as u64));
        }
    }
}

//! The noise of the sensor model: `M_i = max(0, Noise + signal)`.
//!
//! The paper's term is additive Gaussian white noise of standard deviation `sigma` (in
//! the unit of a measurement). Beyond the paper, optional photon (shot) noise: with
//! `photons_per_energy = k > 0` the signal `m` becomes `Poisson(k m) / k`.
//!
//! The measurements (index `j` of the `[N, H, W]` array) draw from random streams
//! keyed by `seed` and `j / 4096`, so the same seed gives the same noise whatever the
//! thread count, and moving the `sigma` slider scales one fixed noise pattern `z_j`
//! instead of drawing a new one (a light or gate edit keeps it too).

use rand::SeedableRng;
use rand_distr::{Distribution, Poisson, StandardNormal};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::SensorError;

/// Measurements per random stream: stream `c` serves the indices `c CHUNK ..
/// (c + 1) CHUNK` in order, whatever the thread that runs it.
const CHUNK: usize = 4096;

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

/// SplitMix64 finaliser (a bijection), to decorrelate seeds.
pub(crate) fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The stream of chunk `chunk` under `seed`: `purpose` 0 for the Gaussian draws, 1 for
/// the photon counts.
fn stream(seed: u64, chunk: usize, purpose: u64) -> Pcg64Mcg {
    let key = mix(seed ^ 0x6A09_E667_F3BC_C909).wrapping_add(2 * chunk as u64 + purpose);
    Pcg64Mcg::seed_from_u64(mix(key))
}

/// A photon count with mean `lambda >= 0` (rand_distr's Poisson; the normal
/// approximation beyond 1e12).
fn photons(lambda: f64, rng: &mut Pcg64Mcg) -> f64 {
    if !(lambda > 0.0) {
        return 0.0;
    }
    if lambda > POISSON_NORMAL_ABOVE {
        let z: f64 = StandardNormal.sample(rng);
        return (lambda + lambda.sqrt() * z).round().max(0.0);
    }
    match Poisson::new(lambda) {
        Ok(p) => p.sample(rng),
        Err(_) => lambda,
    }
}

/// The standard normal `z_j` of measurement `index` under `seed` (the pattern that
/// `sigma` scales), rounded to f32 as it is applied. (Draws its chunk's stream up to
/// `index`: for checks; [`NoiseField`] draws them all.)
pub fn standard_normal(seed: u64, index: u64) -> f32 {
    let chunk = (index / CHUNK as u64) as usize;
    let mut rng = stream(seed, chunk, 0);
    let mut z = 0.0f64;
    for _ in 0..=index % CHUNK as u64 {
        z = StandardNormal.sample(&mut rng);
    }
    z as f32
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
    /// `z_j` for `j < len` under `seed` (ziggurat normals from one PCG stream per
    /// chunk), drawn again only when either changed.
    pub fn normals(&mut self, seed: u64, len: usize) -> &[f32] {
        if self.seed != seed || self.z.len() != len {
            self.seed = seed;
            self.z.resize(len, 0.0);
            self.z
                .par_chunks_mut(CHUNK)
                .enumerate()
                .for_each(|(c, chunk)| {
                    let mut rng = stream(seed, c, 0);
                    for z in chunk {
                        *z = StandardNormal.sample(&mut rng);
                    }
                });
        }
        &self.z
    }
}

impl Noise {
    /// Checks `sigma` and `photons_per_energy` in `0..=1e30` (measurements are float32).
    pub fn validate(&self) -> Result<(), SensorError> {
        super::scale("noise.sigma", self.sigma)?;
        super::scale("noise.photons_per_energy", self.photons_per_energy)?;
        Ok(())
    }

    /// `m -> max(0, sigma z_j + shot(m))` for every value (index `j` of the `[N, H, W]`
    /// array): `z_j` from [`standard_normal`]; `shot(m) = Poisson(k m) / k` with photon
    /// noise on (drawn from the stream of the value's chunk, in order), `m` otherwise.
    /// With all noise off this is just `max(0, m)` (NaN becomes 0).
    pub fn apply(&self, values: &mut [f32]) {
        self.apply_cached(values, &mut NoiseField::default());
    }

    /// [`Noise::apply`] with the normals kept in `field` for the next call.
    pub fn apply_cached(&self, values: &mut [f32], field: &mut NoiseField) {
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
                    let mut rng = stream(seed, c, 1);
                    for m in chunk {
                        *m = (photons(k * f64::from(*m).max(0.0), &mut rng) / k) as f32;
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
        let n = 200_000;
        let mut field = NoiseField::default();
        let z: Vec<f64> = field.normals(7, n).iter().map(|&v| f64::from(v)).collect();
        let mean = z.iter().sum::<f64>() / n as f64;
        let var = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.01 && (var - 1.0).abs() < 0.01,
            "{mean} {var}"
        );
        for j in [0u64, 1, 4095, 4096, 123_456] {
            assert_eq!(standard_normal(7, j), field.normals(7, n)[j as usize]);
        }
        for lambda in [0.3f32, 5.0, 40.0, 1e4] {
            let mut counts = vec![lambda; n];
            Noise {
                sigma: 0.0,
                seed: 3,
                photons_per_energy: 1.0,
            }
            .apply(&mut counts);
            let (mut total, mut sq) = (0.0, 0.0);
            for &k in &counts {
                let k = f64::from(k);
                assert!(k >= 0.0 && k.fract() == 0.0);
                total += k;
                sq += k * k;
            }
            let lambda = f64::from(lambda);
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

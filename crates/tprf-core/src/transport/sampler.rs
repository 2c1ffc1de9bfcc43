//! Random streams: one per (seed, pass, pixel), so a render is reproducible whatever the
//! thread count, and a bad sample can be replayed from its pixel and pass alone.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// The random stream of one pixel in one pass.
pub struct Sampler(Pcg64Mcg);

/// SplitMix64 finaliser, used only to decorrelate the seed words.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Sampler {
    /// The stream for `pixel` (row-major index) in `pass` of a render seeded with `seed`.
    pub fn new(seed: u64, pass: u64, pixel: u64) -> Sampler {
        let s = mix(mix(mix(seed) ^ pass) ^ pixel.rotate_left(32));
        Sampler(Pcg64Mcg::seed_from_u64(s))
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        self.0.random::<f32>()
    }

    /// Two uniforms in [0, 1).
    #[inline]
    pub fn next2(&mut self) -> (f32, f32) {
        (self.uniform(), self.uniform())
    }
}

//! Sample streams: low-discrepancy samples keyed by (seed, stream, pixel, sample index),
//! so a render is reproducible whatever the thread count and however its samples are
//! split into passes, and a bad sample can be replayed from its pixel and index alone.
//!
//! Each sample is a point in many dimensions, asked for by *slot* ([`dim`]): the
//! camera's jitter, and per scattering vertex the coverage test, the light choice, the
//! point on the light, the lobe choice, the BSDF direction and the roulette. The first
//! slots are Owen-scrambled Sobol points, padded (Burley 2020, *Practical Hash-based Owen
//! Scrambling*, JCGT 9(4)): slot `s` of sample `i` is the 2-D Sobol point (dimensions 0
//! and 1, a (0, 2)-sequence) of index `shuffle_s(i)`, each coordinate scrambled; the
//! shuffle and the scrambles are nested-uniform (Owen) scrambles approximated by a hash
//! (Vegdahl's Laine-Karras permutation, as in pbrt-v4), seeded by (seed, stream, pixel,
//! slot). So the first `2^k` samples of a pixel are stratified in each slot's square
//! (one point in each of `2^k` elementary intervals of any shape), the slots are
//! decorrelated, and every point is uniformly distributed: the estimator stays unbiased,
//! and independent streams (the film's two halves) give independent estimates. Slots
//! past [`SOBOL_SLOTS`] (deep vertices, where stratification buys little) are hashed
//! uniform numbers, also keyed by (seed, stream, pixel, index, slot).
//!
//! Where it pays: the pixel jitter decides in which bin a footprint's direct light lands,
//! and stratified, that noise falls like spp^-3/4 instead of spp^-1/2. Light arriving
//! after more bounces spreads over many bins, each reached by few samples, and gains
//! little (pairing the jitter with the first bounce direction in a 4-D Sobol point
//! measured no better than independent pairs).

/// Slots of a sample. Slot numbers are fixed per use, so a draw that one sample skips
/// (no emitter, an opaque surface) never shifts the others.
pub mod dim {
    /// The pixel jitter (2-D).
    pub const CAMERA: u32 = 0;
    /// Coverage test of the first surface met at a vertex (1-D).
    pub const COVERAGE: u32 = 0;
    /// Which emitter next-event estimation samples (1-D).
    pub const EMITTER_SELECT: u32 = 1;
    /// The point on that emitter (2-D).
    pub const EMITTER_POINT: u32 = 2;
    /// Which BSDF lobe is sampled (1-D).
    pub const LOBE: u32 = 3;
    /// The direction within the lobe (2-D).
    pub const BSDF_DIRECTION: u32 = 4;
    /// Russian roulette after the vertex (1-D).
    pub const ROULETTE: u32 = 5;
    /// Which punctual light a light vertex starts from (1-D; drawn at the vertex that
    /// first connects to it, usually the first).
    pub const LIGHT_SELECT: u32 = 6;
    /// The direction of the light vertex's ray from that light (2-D).
    pub const LIGHT_DIRECTION: u32 = 7;
    /// Slots per vertex.
    pub const PER_VERTEX: u32 = 8;

    /// Slot of `use_` at vertex `k` (0: the first surface the camera ray meets).
    #[inline]
    pub fn vertex(k: u32, use_: u32) -> u32 {
        1u32.saturating_add(k.saturating_mul(PER_VERTEX))
            .saturating_add(use_)
    }
}

/// Slots drawn from scrambled Sobol points: the camera and the first 2 vertices. Deeper
/// slots are hashed uniform numbers (measured on the race's scenes: Sobol points at the
/// first vertex cut the cube's variance by 12 %, at the next ones by nothing visible).
pub const SOBOL_SLOTS: u32 = 1 + 2 * dim::PER_VERTEX;

/// The sample stream of one pixel.
#[derive(Clone, Debug)]
pub struct Sampler {
    /// Hash of (seed, stream, pixel).
    key: u64,
    /// Index of the sample being drawn (`u32::MAX` before the first).
    index: u32,
    /// `index` with its bits reversed.
    index_reversed: u32,
    /// Hash of (key, index), for hashed slots.
    sample_key: u64,
    /// Per Sobol slot, the seeds of its index shuffle and of its two coordinates'
    /// scrambles (functions of the key and the slot: computed once per stream).
    seeds: [[u32; 3]; SOBOL_SLOTS as usize],
}

/// SplitMix64 finaliser: a 64-bit mix.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Laine-Karras-style permutation with Vegdahl's constants: bit `j` of the result is bit
/// `j` of `x` xor a function of the lower bits, so on bit-reversed values it is a
/// nested-uniform scramble.
#[inline]
fn lk_permute(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Direction vectors of Sobol dimension 1 (primitive polynomial x + 1: Pascal's triangle
/// mod 2), bit-reversed: entry `j` is the contribution of index bit `j` to the reversed
/// 32-bit coordinate.
const fn sobol1_reversed_directions() -> [u32; 32] {
    let mut v = [0u32; 32];
    let mut d = 1u32 << 31;
    let mut j = 0;
    while j < 32 {
        v[j] = d.reverse_bits();
        d ^= d >> 1;
        j += 1;
    }
    v
}

/// `SOBOL1_BYTES[b][x]`: the xor of the reversed direction vectors of the set bits of
/// byte `x` placed at byte `b` of the index.
const SOBOL1_BYTES: [[u32; 256]; 4] = {
    let dirs = sobol1_reversed_directions();
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut x = 0;
        while x < 256 {
            let mut acc = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if x & (1 << bit) != 0 {
                    acc ^= dirs[b * 8 + bit];
                }
                bit += 1;
            }
            t[b][x] = acc;
            x += 1;
        }
        b += 1;
    }
    t
};

/// Sobol dimension 1 of index `i`, bit-reversed.
#[inline]
fn sobol1_reversed(i: u32) -> u32 {
    SOBOL1_BYTES[0][(i & 0xff) as usize]
        ^ SOBOL1_BYTES[1][((i >> 8) & 0xff) as usize]
        ^ SOBOL1_BYTES[2][((i >> 16) & 0xff) as usize]
        ^ SOBOL1_BYTES[3][(i >> 24) as usize]
}

/// A 32-bit fraction to a float in [0, 1) (24 bits kept).
#[inline]
fn unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

impl Sampler {
    /// The stream of `pixel` (row-major index) in `stream` of a render seeded with
    /// `seed`, positioned before its sample 0.
    pub fn new(seed: u64, stream: u64, pixel: u64) -> Sampler {
        let key = mix(mix(mix(seed) ^ stream) ^ pixel.rotate_left(32));
        let mut seeds = [[0u32; 3]; SOBOL_SLOTS as usize];
        for (slot, s) in seeds.iter_mut().enumerate() {
            let h = mix(key ^ (slot as u64 + 1).wrapping_mul(0xA076_1D64_78BD_642F));
            let h2 = mix(h);
            *s = [h as u32, (h >> 32) as u32, h2 as u32];
        }
        Sampler {
            key,
            index: u32::MAX,
            index_reversed: 0,
            sample_key: 0,
            seeds,
        }
    }

    /// The same stream, positioned before sample `first` (the next
    /// [`start_sample`](Self::start_sample) begins sample `first`). Indices wrap at 2^32.
    pub fn starting_at(mut self, first: u64) -> Sampler {
        self.index = (first as u32).wrapping_sub(1);
        self
    }

    /// Begin the next sample of the stream.
    #[inline]
    pub fn start_sample(&mut self) {
        self.index = self.index.wrapping_add(1);
        self.draw_from(self.index);
    }

    /// Draw from index `i` of the stream from now on (its Sobol points and hashes).
    #[inline]
    fn draw_from(&mut self, i: u32) {
        self.index_reversed = i.reverse_bits();
        self.sample_key = mix(self.key ^ (i as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93));
    }

    /// Begin branch `j` of `k` of the current sample: the draws from here on (the first
    /// vertex's lobe, direction and roulette, and every deeper slot) come from index
    /// `k i + j` of the stream instead of `i`, so over the samples `i < n` the `k n`
    /// branches of a slot are one stratified set of `k n` points, and the branches of
    /// one sample are as independent as any two samples. `start_branch(0, 1)` changes
    /// nothing. (Indices wrap at 2^32: past 2^32 / k samples a pixel's branches repeat
    /// earlier ones.)
    #[inline]
    pub fn start_branch(&mut self, j: u32, k: u32) {
        self.draw_from(self.index.wrapping_mul(k).wrapping_add(j));
    }

    /// Hash of the sample and `slot`: 64 uniform bits.
    #[inline]
    fn hashed(&self, slot: u64) -> u64 {
        mix(self.sample_key ^ slot.wrapping_mul(0x9E37_79B9_7F4A_7C15))
    }

    /// The shuffled index of a Sobol slot: a nested-uniform scramble of the sample index
    /// (the first `2^k` samples map onto one aligned block of `2^k` Sobol points).
    #[inline]
    fn shuffled(&self, seed: u32) -> u32 {
        lk_permute(self.index_reversed, seed).reverse_bits()
    }

    /// One uniform number in [0, 1) of `slot` of the current sample.
    #[inline]
    pub fn get1(&self, slot: u32) -> f32 {
        let Some(&[s_index, s_x, _]) = self.seeds.get(slot as usize) else {
            return unit(self.hashed(slot as u64) as u32);
        };
        let i = self.shuffled(s_index);
        // Sobol dimension 0 is the bit-reversed index: scrambled in the reversed domain.
        unit(lk_permute(i, s_x).reverse_bits())
    }

    /// Two uniform numbers in [0, 1) of `slot` of the current sample, stratified
    /// together over the samples of the stream.
    #[inline]
    pub fn get2(&self, slot: u32) -> (f32, f32) {
        let Some(&[s_index, s_x, s_y]) = self.seeds.get(slot as usize) else {
            let h = self.hashed(slot as u64);
            return (unit(h as u32), unit((h >> 32) as u32));
        };
        let i = self.shuffled(s_index);
        let x = lk_permute(i, s_x).reverse_bits();
        let y = lk_permute(sobol1_reversed(i), s_y).reverse_bits();
        (unit(x), unit(y))
    }

    /// A hashed uniform number in [0, 1) for draws with no fixed slot (a coverage test
    /// after the first at one vertex): `extra` distinguishes them.
    #[inline]
    pub fn get1_hashed(&self, extra: u64) -> f32 {
        unit(self.hashed(extra.wrapping_add(1 << 40)) as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sobol dimension 1 by its definition, not reversed.
    fn sobol1(i: u32) -> u32 {
        let mut d = 1u32 << 31;
        let mut x = 0;
        for j in 0..32 {
            if i & (1 << j) != 0 {
                x ^= d;
            }
            d ^= d >> 1;
        }
        x
    }

    /// The branches of `n` samples split `k` ways are `k n` stratified points of a
    /// slot (one in each interval of width `1 / (k n)`), and branch 0 of 1 is the
    /// sample itself.
    #[test]
    fn branches_are_one_stratified_set_and_one_branch_is_the_sample() {
        let slot = dim::vertex(0, dim::BSDF_DIRECTION);
        for (n, k) in [(8u32, 4u32), (16, 2), (4, 8)] {
            let mut s = Sampler::new(3, 0, 77);
            let mut seen = vec![0u32; (n * k) as usize];
            for _ in 0..n {
                s.start_sample();
                for j in 0..k {
                    s.start_branch(j, k);
                    let (x, y) = s.get2(slot);
                    seen[(x * (n * k) as f32) as usize] += 1;
                    assert!((0.0..1.0).contains(&y));
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "n {n} k {k}: {seen:?}");
        }
        let (mut a, mut b) = (Sampler::new(9, 1, 5), Sampler::new(9, 1, 5));
        for _ in 0..10 {
            a.start_sample();
            b.start_sample();
            b.start_branch(0, 1);
            for slot in [0, 4, 5, 6, 30] {
                assert_eq!(a.get2(slot), b.get2(slot));
            }
            assert_eq!(a.get1_hashed(12), b.get1_hashed(12));
        }
    }

    #[test]
    fn sobol_dimension_one_matches_its_definition() {
        for i in [0u32, 1, 2, 3, 7, 255, 256, 12345, u32::MAX] {
            assert_eq!(sobol1_reversed(i), sobol1(i).reverse_bits(), "{i}");
        }
        // The first points: 0, 1/2, 3/4, 1/4.
        assert_eq!(
            [sobol1(0), sobol1(1), sobol1(2), sobol1(3)],
            [0, 1 << 31, 3 << 30, 1 << 30]
        );
    }

    /// Every power-of-two prefix of a slot is a (0, k, 2)-net: one point in each of the
    /// `2^k` elementary intervals `2^-a x 2^-(k-a)`.
    #[test]
    fn prefixes_are_stratified_in_every_slot() {
        for (pixel, slot) in [
            (0u64, 0u32),
            (7, 3),
            (1000, dim::vertex(1, dim::BSDF_DIRECTION)),
        ] {
            let mut s = Sampler::new(42, 1, pixel);
            let points: Vec<(f32, f32)> = (0..256)
                .map(|_| {
                    s.start_sample();
                    s.get2(slot)
                })
                .collect();
            for k in 0..=8u32 {
                let n = 1usize << k;
                for a in 0..=k {
                    let (nx, ny) = (1usize << a, 1usize << (k - a));
                    let mut seen = vec![false; n];
                    for &(x, y) in &points[..n] {
                        let cell = (x * nx as f32) as usize * ny + (y * ny as f32) as usize;
                        assert!(
                            !seen[cell],
                            "pixel {pixel} slot {slot}: 2^{k} points, 2^{a} x 2^{}",
                            k - a
                        );
                        seen[cell] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn streams_differ_and_repeat() {
        let draw = |seed, stream, pixel, first| {
            let mut s = Sampler::new(seed, stream, pixel).starting_at(first);
            s.start_sample();
            (s.get2(0), s.get1(5), s.get2(SOBOL_SLOTS + 3))
        };
        assert_eq!(draw(1, 0, 5, 9), draw(1, 0, 5, 9));
        assert_ne!(draw(1, 0, 5, 9), draw(1, 1, 5, 9));
        assert_ne!(draw(1, 0, 5, 9), draw(1, 0, 6, 9));
        assert_ne!(draw(1, 0, 5, 9), draw(2, 0, 5, 9));
        // Positioned at 9, or started at 0 and advanced: the same sample.
        let mut s = Sampler::new(1, 0, 5);
        for _ in 0..10 {
            s.start_sample();
        }
        assert_eq!(
            (s.get2(0), s.get1(5), s.get2(SOBOL_SLOTS + 3)),
            draw(1, 0, 5, 9)
        );
    }

    #[test]
    fn every_slot_is_uniform() {
        // Mean and variance of many pixels' first 64 samples, per slot: 1/2 and 1/12.
        for slot in [0, 1, 5, SOBOL_SLOTS - 1, SOBOL_SLOTS, SOBOL_SLOTS + 40] {
            let (mut sum, mut sum2, mut n) = (0.0f64, 0.0f64, 0.0f64);
            for pixel in 0..500 {
                let mut s = Sampler::new(3, 0, pixel);
                for _ in 0..64 {
                    s.start_sample();
                    let (x, y) = s.get2(slot);
                    let z = s.get1(slot);
                    for v in [x, y, z] {
                        assert!((0.0..1.0).contains(&v));
                        sum += v as f64;
                        sum2 += (v as f64) * (v as f64);
                        n += 1.0;
                    }
                }
            }
            let mean = sum / n;
            let var = sum2 / n - mean * mean;
            assert!((mean - 0.5).abs() < 0.005, "slot {slot}: mean {mean}");
            assert!(
                (var - 1.0 / 12.0).abs() < 0.003,
                "slot {slot}: variance {var}"
            );
        }
    }
}

//! Progressive stratified sampling for the path sampler: Owen-scrambled Sobol' (0,2)-sequences with
//! hash-based nested uniform scrambling and index shuffling (Burley 2020, "Practical Hash-based
//! Owen Scrambling", JCGT 9(4)), one independent sequence per (seed, pixel, stream, dimension pair).
//! `shaders/sobol.wgsl` mirrors it bit for bit (integer operations only; the float is the top 24
//! bits, exactly representable).
//!
//! **Why this replaces the thesis's 4×4 random-permutation pairing** (Sec. 5.8: lens, light and
//! hemisphere samples each from a 4×4 stratification, "matched with random permutations"):
//! - *Progressive.* The first two Sobol' dimensions form a (0,2)-sequence in base 2: every aligned
//!   block of `2^m` consecutive points has one point in each elementary interval of area `2^-m`.
//!   Owen scrambling keeps that, and Burley's index shuffle is itself a nested scramble of the
//!   index, which maps the prefix `[0, 4^k)` onto one aligned block. So the first 4 samples are 2×2
//!   stratified, the first 16 are 4×4 stratified (the thesis's first pass), and the second pass's
//!   samples continue the same sequence (indices 16, 17, …): the first 64 are 8×8 stratified, and so
//!   on for every power-of-4 prefix. A 4×4 grid with a permutation stratifies exactly 16 samples and
//!   cannot be continued by a second pass with an arbitrary per-pixel count.
//! - *Decorrelated pairs.* Each dimension pair (pixel jitter, lens, light, hemisphere, …) hashes its
//!   own scramble seeds *and* its own index shuffle, so sample `i`'s lens point and light point are
//!   paired as by an independent random permutation of the strata — the thesis's pairing — without
//!   storing a permutation, for any count.
//! - *Deterministic, stateless.* A pure function of (seed, pixel, stream, pair, index), the same
//!   on both backends and for any thread count or chunking of the sample loop.
//!
//! Streams and pairs are combined by hashing ([`sequence_key`]), never by arithmetic packing, so no
//! two (stream, pair) choices collide by construction.

use crate::rng::{hash4, pcg_hash, to_unit};

/// Dimension pairs the path sampler draws (one 2-D sequence each).
pub mod pair {
    /// Sub-pixel position of the primary ray (image plane jitter).
    pub const PIXEL: u32 = 0;
    /// Lens position (thin lens).
    pub const LENS: u32 = 1;
    /// Point on the area light for the shadow ray at the primary hit.
    pub const LIGHT: u32 = 2;
    /// Cosine-weighted hemisphere direction of the diffuse indirect sample.
    pub const HEMISPHERE_DIFFUSE: u32 = 3;
    /// Glossy-lobe direction of the glossy indirect sample.
    pub const HEMISPHERE_GLOSSY: u32 = 4;
    /// Independent numbers for everything beyond the first bounce (next-event and continuation at
    /// the indirect path's vertices) — keyed like `rng::PixelRng`, with this as its stream salt.
    pub const PATH: u32 = 5;
    /// Shutter time of the path (its first coordinate; thesis App. B: time as a sample dimension).
    pub const TIME: u32 = 6;
    /// The environment table: the first coordinate of sample 0 is the pixel's table shift
    /// (`kernels::environment::stratified_entry`); under independent sampling sample `q` picks look-up `q`.
    pub const ENVIRONMENT: u32 = 7;
    /// The glossy-lobe direction that each environment look-up at a glossy receiver pairs with under
    /// multiple importance sampling (`kernels::environment::GlossySampling::Mis`).
    pub const ENVIRONMENT_LOBE: u32 = 8;
    /// How many pairs there are.
    pub const COUNT: usize = 9;
}

/// Point `index` of Sobol' dimension 0 or 1 as a 32-bit fraction.
///
/// Dimension 1's generator matrix is Pascal's triangle mod 2 (`SOBOL1[k]` has bit `31 − i` set iff
/// `C(k, i)` is odd), and by Lucas's theorem `C(k, i)` is odd iff the bits of `i` are a subset of
/// those of `k`. So bit `31 − i` of the point is the XOR of the index bits `k ⊇ i`: a superset
/// transform over the 5-bit bit positions, five shift-and-mask steps instead of a data-dependent loop
/// over the index's 32 bits (the loop, kept in the tests as the reference, was most of a draw's time).
#[inline]
pub fn sobol(index: u32, dimension: u32) -> u32 {
    if dimension == 0 {
        return index.reverse_bits();
    }
    let mut z = index;
    z ^= (z >> 1) & 0x5555_5555;
    z ^= (z >> 2) & 0x3333_3333;
    z ^= (z >> 4) & 0x0f0f_0f0f;
    z ^= (z >> 8) & 0x00ff_00ff;
    z ^= z >> 16;
    z.reverse_bits()
}

/// Laine–Karras-style hash permutation (Burley 2020, Listing 2, his improved constants): each
/// output bit depends only on the same and lower input bits.
#[inline]
pub fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Nested uniform (Owen) scramble in base 2 of a 32-bit fraction: each bit is flipped by a hash of
/// the bits above it (Burley 2020, Listing 3).
#[inline]
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The key of one pixel's sequence for one (stream, pair): a hash of all four, so sub-streams
/// never collide by arithmetic.
#[inline]
pub fn sequence_key(seed: u32, pixel: u32, stream: u32, pair: u32) -> u32 {
    hash4(seed, pixel, stream, pcg_hash(pair ^ 0x5bd1_e995))
}

/// A sub-stream of `stream` for independent numbers (`rng::PixelRng`), by hashing with `salt`.
#[inline]
pub fn substream(stream: u32, salt: u32) -> u32 {
    hash4(stream, pcg_hash(salt ^ 0x27d4_eb2f), pair::PATH, 0x1656_67b1)
}

/// One 2-D sequence `key` with what its draws share hashed once: the two dimensions' scramble
/// seeds and the first hash of the independent numbers. A pixel's pass draws many indices of the
/// same few sequences, so the key's hashes are paid per (pixel, pair), not per draw; the numbers are
/// those of [`sobol2`] and [`independent2`] bit for bit (they are defined through it).
#[derive(Clone, Copy, Debug, Default)]
pub struct Sequence {
    key: u32,
    sx: u32,
    sy: u32,
    /// `pcg_hash(key)`: the first step of `hash4(key, …)`.
    hashed: u32,
}

impl Sequence {
    #[inline]
    pub fn new(key: u32) -> Sequence {
        Sequence { key, sx: pcg_hash(key ^ 0x68bc_21eb), sy: pcg_hash(key ^ 0x02e5_be93), hashed: pcg_hash(key) }
    }

    /// Sample `index` of the shuffled, Owen-scrambled 2-D Sobol' sequence (Burley 2020, Listing 4
    /// for two dimensions), in [0,1)².
    #[inline]
    pub fn point(&self, index: u32) -> [f32; 2] {
        let shuffled = nested_uniform_scramble(index, self.key);
        [
            to_unit(nested_uniform_scramble(sobol(shuffled, 0), self.sx)),
            to_unit(nested_uniform_scramble(sobol(shuffled, 1), self.sy)),
        ]
    }

    /// Independent uniform numbers for `index`: `hash4(key, index, d, 0x85eb_ca6b)` for d = 0, 1.
    #[inline]
    pub fn independent(&self, index: u32) -> [f32; 2] {
        let h = pcg_hash(self.hashed ^ index);
        let dim = |d: u32| to_unit(pcg_hash(pcg_hash(h ^ d) ^ 0x85eb_ca6b));
        [dim(0), dim(1)]
    }
}

/// Sample `index` of the shuffled, Owen-scrambled 2-D Sobol' sequence `key` (Burley 2020,
/// Listing 4 for two dimensions), in [0,1)².
#[inline]
pub fn sobol2(key: u32, index: u32) -> [f32; 2] {
    Sequence::new(key).point(index)
}

/// Independent uniform numbers for the same (key, index): the Monte Carlo baseline that samples the
/// same dimensions without stratification (`sampling: "independent"`).
#[inline]
pub fn independent2(key: u32, index: u32) -> [f32; 2] {
    Sequence::new(key).independent(index)
}

/// Sample `index` of pair `pair` of pixel `pixel`'s sequence in `stream`.
#[inline]
pub fn sample2(seed: u32, pixel: u32, stream: u32, pair: u32, index: u32) -> [f32; 2] {
    sobol2(sequence_key(seed, pixel, stream, pair), index)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether points `first..first + n` of `key` put one point in each cell of a √n×√n grid.
    fn stratified(key: u32, first: u32, n: u32) -> bool {
        let k = (n as f64).sqrt() as u32;
        let mut cells = vec![0u32; n as usize];
        for i in first..first + n {
            let [x, y] = sobol2(key, i);
            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
            cells[(x * k as f32) as usize + k as usize * (y * k as f32) as usize] += 1;
        }
        cells.iter().all(|&c| c == 1)
    }

    /// Sobol' direction-number generator matrix of dimension 1 (dimension 0 is bit reversal):
    /// primitive polynomial x + 1, all m_i = 1, i.e. v_k = v_{k-1} ^ (v_{k-1} >> 1) from v_0 = 2^31.
    const SOBOL1: [u32; 32] = {
        let mut v = [0u32; 32];
        let mut k = 0;
        let mut d = 1u32 << 31;
        while k < 32 {
            v[k] = d;
            d ^= d >> 1;
            k += 1;
        }
        v
    };

    /// The definitions before [`Sequence`] and the branch-free dimension 1: the generator-matrix loop,
    /// every hash per draw.
    fn sobol_loop(index: u32) -> u32 {
        let (mut x, mut i, mut k) = (0u32, index, 0);
        while i != 0 {
            if i & 1 != 0 {
                x ^= SOBOL1[k];
            }
            i >>= 1;
            k += 1;
        }
        x
    }

    fn sobol2_reference(key: u32, index: u32) -> [f32; 2] {
        let shuffled = nested_uniform_scramble(index, key);
        let sx = pcg_hash(key ^ 0x68bc_21eb);
        let sy = pcg_hash(key ^ 0x02e5_be93);
        [
            to_unit(nested_uniform_scramble(shuffled.reverse_bits(), sx)),
            to_unit(nested_uniform_scramble(sobol_loop(shuffled), sy)),
        ]
    }

    #[test]
    fn hoisted_draws_are_bit_identical_to_the_reference() {
        // Every single-bit index (dimension 1 is linear over GF(2), so these pin it down) and a
        // hashed spread of indices, small and large, over many keys.
        for b in 0..32 {
            assert_eq!(sobol(1 << b, 1), sobol_loop(1 << b), "bit {b}");
        }
        for k in 0..2000u32 {
            let key = pcg_hash(k.wrapping_mul(0x9e37_79b9));
            let seq = Sequence::new(key);
            for i in (0..64).chain((0..64).map(|j| pcg_hash(j ^ key))) {
                assert_eq!(sobol(i, 1), sobol_loop(i), "index {i:#x}");
                assert_eq!(seq.point(i).map(f32::to_bits), sobol2_reference(key, i).map(f32::to_bits), "{key} {i}");
                let independent = [0, 1].map(|d| to_unit(hash4(key, i, d, 0x85eb_ca6b)).to_bits());
                assert_eq!(seq.independent(i).map(f32::to_bits), independent, "{key} {i}");
            }
        }
    }

    #[test]
    fn sobol_dimension_one_matches_known_points() {
        // Unscrambled Sobol' dimension 1 in index (not Gray-code) order.
        let expect = [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875];
        for (i, e) in expect.iter().enumerate() {
            assert_eq!(sobol(i as u32, 1) as f64 / 4294967296.0, *e, "index {i}");
        }
        assert_eq!(sobol(3, 0), 0xc000_0000);
    }

    #[test]
    fn every_power_of_four_prefix_is_stratified() {
        for p in 0..500u32 {
            for pair in [pair::PIXEL, pair::LENS, pair::LIGHT, pair::HEMISPHERE_DIFFUSE] {
                let key = sequence_key(7, p, 3, pair);
                assert!(stratified(key, 0, 4), "first 4: pixel {p} pair {pair}");
                assert!(stratified(key, 0, 16), "first 16: pixel {p} pair {pair}");
                assert!(stratified(key, 0, 64), "first 64: pixel {p} pair {pair}");
                assert!(stratified(key, 16, 16), "second pass's first 16 continue stratified: pixel {p}");
                assert!(stratified(key, 0, 256), "first 256: pixel {p} pair {pair}");
            }
        }
    }

    /// Pearson's chi-square with `bins` cells; returns the statistic.
    fn chi_square(counts: &[u32], expected: f64) -> f64 {
        counts.iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum()
    }

    #[test]
    fn marginals_are_uniform_across_pixels() {
        // One sample (index 5: not at a stratum corner) from each of 40,000 pixels: the scrambles are
        // independent across pixels, so these are i.i.d. uniform. 1-D: 20 bins, 19 dof (99.9% point
        // 43.8); 2-D: 10×10 bins, 99 dof (99.9% point 148.2).
        let n = 40_000u32;
        let (mut bx, mut by, mut b2) = (vec![0u32; 20], vec![0u32; 20], vec![0u32; 100]);
        for p in 0..n {
            let [x, y] = sample2(11, p, 0, pair::LENS, 5);
            bx[(x * 20.0) as usize] += 1;
            by[(y * 20.0) as usize] += 1;
            b2[(x * 10.0) as usize + 10 * (y * 10.0) as usize] += 1;
        }
        let (cx, cy, c2) =
            (chi_square(&bx, n as f64 / 20.0), chi_square(&by, n as f64 / 20.0), chi_square(&b2, n as f64 / 100.0));
        println!("chi-square 1-D x {cx:.1}, y {cy:.1} (19 dof); 2-D {c2:.1} (99 dof)");
        assert!(cx < 43.8 && cy < 43.8 && c2 < 148.2, "{cx} {cy} {c2}");
        // Within one pixel, 4096 samples: stratified, so far more uniform than chance.
        let mut b = vec![0u32; 64];
        for i in 0..4096 {
            let [x, y] = sample2(11, 17, 0, pair::LIGHT, i);
            b[(x * 8.0) as usize + 8 * (y * 8.0) as usize] += 1;
        }
        assert!(b.iter().all(|&c| c == 64), "{b:?}");
    }

    #[test]
    fn pixels_and_pairs_are_decorrelated() {
        // Correlation of sample 0..16 between neighbouring pixels and between the lens and light
        // pairs of one pixel, over many pixels: near zero (|ρ| < 0.02 at 64k pairs of values).
        let corr = |a: &[f64], b: &[f64]| {
            let n = a.len() as f64;
            let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
            let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum::<f64>() / n;
            let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum::<f64>() / n;
            let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum::<f64>() / n;
            cov / (va * vb).sqrt()
        };
        let (mut here, mut next, mut light) = (Vec::new(), Vec::new(), Vec::new());
        for p in 0..4000u32 {
            for i in 0..16 {
                here.push(sample2(3, p, 1, pair::LENS, i)[0] as f64);
                next.push(sample2(3, p + 1, 1, pair::LENS, i)[0] as f64);
                light.push(sample2(3, p, 1, pair::LIGHT, i)[0] as f64);
            }
        }
        let (a, b) = (corr(&here, &next), corr(&here, &light));
        println!("correlation: neighbouring pixels {a:.4}, lens vs light {b:.4}");
        assert!(a.abs() < 0.02 && b.abs() < 0.02, "{a} {b}");
        // Different streams give different sequences.
        assert_ne!(sample2(3, 0, 1, pair::LENS, 0), sample2(3, 0, 2, pair::LENS, 0));
    }
}

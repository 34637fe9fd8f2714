//! Counter-based randomness: every random number is a pure function of (seed, pixel, sample index,
//! dimension), built from 32-bit integer hashing only, so the WGSL mirror (`shaders/rng.wgsl`)
//! reproduces it bit for bit and no RNG state exists anywhere.
//!
//! Stratification uses Kensler's correlated multi-jittered sampling (Pixar TM 13-01, 2013): a pure
//! function of (sample index, count, pattern) that stratifies any count `n` in 2-D and in each 1-D
//! projection — which is what adaptive per-pixel counts need (a 3×3 grid for the first pass is the
//! `n = 9` case).

/// PCG-style 32-bit hash (Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 2020).
#[inline]
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28).wrapping_add(4))) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

/// Hash of four words, chained so that each word changes every bit of the result.
#[inline]
pub fn hash4(a: u32, b: u32, c: u32, d: u32) -> u32 {
    let mut h = pcg_hash(a);
    h = pcg_hash(h ^ b);
    h = pcg_hash(h ^ c);
    pcg_hash(h ^ d)
}

/// The sub-stream `index` (a light, a component) of a pass's `stream`: a hash of both words, so
/// sub-streams of different passes never meet the way packed integers did (`stream * 64 + light`
/// gave pass 1's light 0 the numbers of pass 0's light 64). The pass's stream is assigned by the
/// graph (`wedge_graph::stream_id` of the pass's name); use as `PixelRng::new(seed, pixel,
/// substream(stream, l))`. Mirrored by `rng_substream` in `shaders/rng.wgsl`.
#[inline]
pub fn substream(stream: u32, index: u32) -> u32 {
    hash4(stream, index, 0x27d4_eb2f, 0x1656_67b1)
}

/// Uniform float in [0, 1) from the top 24 bits (exactly representable, identical in WGSL).
#[inline]
pub fn to_unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Named sampling dimensions, so different estimators never reuse a dimension by accident.
/// A stream (per pass, see [`substream`]) separates passes that sample the same dimension.
pub mod dim {
    pub const PIXEL: u32 = 0;
    pub const LENS: u32 = 2;
    pub const TIME: u32 = 4;
    /// The environment table look-up of next-event estimation at a path vertex (one number).
    pub const ENVIRONMENT: u32 = 6;
    pub const LIGHT: u32 = 8;
    pub const LIGHT_SELECT: u32 = 10;
    pub const BSDF: u32 = 12;
    /// Each further bounce shifts by this much.
    pub const BOUNCE_STRIDE: u32 = 16;
}

/// Identifies one pixel's random sequence in one stream (pass) of one render.
#[derive(Clone, Copy, Debug)]
pub struct PixelRng {
    /// `pcg_hash(key)` of the sequence's key `hash4(seed, pixel, stream, 0x9e37_79b9)`: the first
    /// step of every `hash4(key, …)` below, hashed once per pixel, not per number (the same numbers
    /// bit for bit).
    hashed: u32,
}

impl PixelRng {
    pub fn new(seed: u32, pixel: u32, stream: u32) -> Self {
        PixelRng { hashed: pcg_hash(hash4(seed, pixel, stream, 0x9e37_79b9)) }
    }
    /// `hash4(key, a, b, c)` from the stored first step.
    #[inline]
    fn hash3(&self, a: u32, b: u32, c: u32) -> u32 {
        pcg_hash(pcg_hash(pcg_hash(self.hashed ^ a) ^ b) ^ c)
    }
    /// Independent uniform number for (sample, dimension).
    #[inline]
    pub fn uniform(&self, sample: u32, dimension: u32) -> f32 {
        to_unit(self.hash3(sample, dimension, 0x85eb_ca6b))
    }
    /// `[uniform(sample, dimension), uniform(sample, dimension + 1)]`, hashing `sample` once.
    #[inline]
    pub fn uniform2(&self, sample: u32, dimension: u32) -> [f32; 2] {
        let h = pcg_hash(self.hashed ^ sample);
        let dim = |d: u32| to_unit(pcg_hash(pcg_hash(h ^ d) ^ 0x85eb_ca6b));
        [dim(dimension), dim(dimension + 1)]
    }
    /// Sample `s` of a stratified 2-D pattern of `n` samples for `dimension` (CMJ).
    #[inline]
    pub fn stratified2(&self, s: u32, n: u32, dimension: u32) -> [f32; 2] {
        cmj(s, n, self.hash3(dimension, 0x68bc_21eb, 0x02e5_be93))
    }
}

/// Kensler's `permute`: a bijection on [0, l) chosen by `p`, by cycle walking over the next power of two.
#[inline]
pub fn permute(mut i: u32, l: u32, p: u32) -> u32 {
    let mut w = l.wrapping_sub(1);
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= p;
        i = i.wrapping_mul(0xe170_893d);
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | (p >> 27));
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < l {
            break;
        }
    }
    (i.wrapping_add(p)) % l
}

/// Kensler's `randfloat`: a hashed float in [0, 1) for index `i` under pattern `p`.
#[inline]
fn randfloat(mut i: u32, p: u32) -> f32 {
    i ^= p;
    i ^= i >> 17;
    i ^= i >> 10;
    i = i.wrapping_mul(0xb365_34e5);
    i ^= i >> 12;
    i ^= i >> 21;
    i = i.wrapping_mul(0x93fc_4795);
    i ^= 0xdf6e_307f;
    i ^= i >> 17;
    i = i.wrapping_mul(1 | (p >> 18));
    to_unit(i)
}

/// Correlated multi-jittered sample `s` of `n` (Kensler 2013, Listing 6 with aspect 1): stratified
/// on an m×k grid (m = ceil(sqrt n), k = ceil(n/m)) and in both 1-D projections.
#[inline]
pub fn cmj(s: u32, n: u32, p: u32) -> [f32; 2] {
    let n = n.max(1);
    let m = (n as f32).sqrt().ceil() as u32;
    let m = if (m - 1) * (m - 1) >= n { m - 1 } else { m }; // guard sqrt rounding
    let k = n.div_ceil(m);
    let s = permute(s, n, p.wrapping_mul(0x5163_3e2d));
    let sx = permute(s % m, m, p.wrapping_mul(0x68bc_21eb));
    let sy = permute(s / m, k, p.wrapping_mul(0x02e5_be93));
    let jx = randfloat(s, p.wrapping_mul(0x967a_889b));
    let jy = randfloat(s, p.wrapping_mul(0x368c_c8b7));
    let mut x = ((s % m) as f32 + (sy as f32 + jx) / k as f32) / m as f32;
    let mut y = ((s / m) as f32 + (sx as f32 + jy) / m as f32) / k as f32;
    if m * k != n {
        // With n < m·k cells the last row is only partly filled, so the pattern's density is not
        // uniform and an estimate from it would be biased. A random toroidal shift per pattern
        // (Cranley–Patterson rotation) makes every sample uniform again and keeps the strata.
        x = wrap_unit(x + randfloat(0x5bd1_e995, p.wrapping_mul(0x1b87_3593)));
        y = wrap_unit(y + randfloat(0x27d4_eb2f, p.wrapping_mul(0x85eb_ca6b)));
    }
    // f32 rounding may land exactly on 1.0; keep the half-open interval.
    [x.min(ONE_MINUS_EPS), y.min(ONE_MINUS_EPS)]
}

/// `v mod 1` for `v` in [0, 2).
#[inline]
fn wrap_unit(v: f32) -> f32 {
    if v >= 1.0 {
        v - 1.0
    } else {
        v
    }
}

const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permute_is_a_bijection() {
        for l in [1u32, 2, 3, 9, 10, 31, 64, 100] {
            let mut seen = vec![false; l as usize];
            for i in 0..l {
                let j = permute(i, l, 0x1234_5678);
                assert!(j < l);
                assert!(!seen[j as usize]);
                seen[j as usize] = true;
            }
        }
    }

    #[test]
    fn cmj_nine_is_a_three_by_three_stratification() {
        let mut cells = [0u32; 9];
        let mut rows = [0u32; 9];
        for s in 0..9 {
            let [x, y] = cmj(s, 9, 77);
            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
            cells[(x * 3.0) as usize + 3 * (y * 3.0) as usize] += 1;
            rows[(x * 9.0) as usize] += 1;
        }
        assert_eq!(cells, [1; 9]);
        assert_eq!(rows, [1; 9], "1-D projection stratified into n strata");
    }

    #[test]
    fn cmj_is_uniform_for_counts_that_do_not_fill_the_grid() {
        // n = 10 uses a 4×3 grid (12 cells). Over many patterns every sample must still be uniform:
        // count y in 6 bins and check each bin's share (unrotated, the top third would get 2/10 of
        // the samples instead of 1/3).
        let n = 10u32;
        let patterns = 40_000u32;
        let mut bins = [0u32; 6];
        for p in 0..patterns {
            for s in 0..n {
                let [_, y] = cmj(s, n, pcg_hash(p));
                bins[(y * 6.0) as usize] += 1;
            }
        }
        let total = (n * patterns) as f64;
        for (i, b) in bins.iter().enumerate() {
            let share = *b as f64 / total;
            assert!((share - 1.0 / 6.0).abs() < 0.003, "bin {i}: {share}");
        }
    }

    #[test]
    fn sub_streams_of_many_lights_and_passes_are_distinct() {
        // The streams of SoftShadows' two passes (as the graph hashes them) over 4096 lights, and
        // Indirect's two components: every key distinct, where `stream * 64 + l` collided at l = 64.
        let fnv = |s: &str| s.bytes().fold(0x811c_9dc5u32, |h, b| (h ^ u32::from(b)).wrapping_mul(0x0100_0193));
        let streams = [
            fnv("shadows.sample_initial"),
            fnv("shadows.sample_adaptive"),
            fnv("indirect.sample_initial"),
            fnv("indirect.sample_adaptive"),
        ];
        let mut keys: Vec<u32> = Vec::new();
        for s in streams {
            for l in 0..4096 {
                keys.push(substream(s, l));
            }
        }
        let n = keys.len();
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), n, "sub-stream keys collide");
        // And the per-pixel keys built on them stay distinct across pixels for one light (`hashed` is a
        // bijection of the key: `pcg_hash` is one).
        let mut px: Vec<u32> = (0..65_536).map(|p| PixelRng::new(1, p, substream(streams[0], 64)).hashed).collect();
        px.sort_unstable();
        px.dedup();
        assert!(px.len() > 65_536 - 4, "{} distinct of 65536", px.len());
    }

    #[test]
    fn hoisted_hashes_give_the_same_numbers() {
        // The numbers as defined before the first hash was stored: `hash4(key, …)` per number.
        for p in 0..3000u32 {
            let r = PixelRng::new(7, p, pcg_hash(p / 100));
            let key = hash4(7, p, pcg_hash(p / 100), 0x9e37_79b9);
            for (s, d) in [(0u32, 0u32), (1, 2), (p, 14), (u32::MAX, p % 40), (pcg_hash(p), 8)] {
                let old = |d: u32| to_unit(hash4(key, s, d, 0x85eb_ca6b)).to_bits();
                assert_eq!(r.uniform(s, d).to_bits(), old(d));
                assert_eq!(r.uniform2(s, d).map(f32::to_bits), [old(d), old(d + 1)]);
                let n = 1 + s % 20;
                let old_cmj = cmj(s % n, n, hash4(key, d, 0x68bc_21eb, 0x02e5_be93)).map(f32::to_bits);
                assert_eq!(r.stratified2(s % n, n, d).map(f32::to_bits), old_cmj);
            }
        }
    }

    #[test]
    fn uniform_is_uniform() {
        let r = PixelRng::new(1, 2, 3);
        let n = 100_000;
        let mean: f64 = (0..n).map(|i| r.uniform(i, 0) as f64).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
    }
}

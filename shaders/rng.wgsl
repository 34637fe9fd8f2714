// rng.wgsl — bit-for-bit mirror of backends/src/rng.rs (counter-based hashing + Kensler's CMJ).
// Integer arithmetic wraps in WGSL exactly as Rust's wrapping_* does; to_unit is exact.
// The float steps of cmj (two divisions) are the only places an implementation could round
// differently; tests/parity.rs checks hash4/uniform/cmj outputs against Rust bit for bit.

const DIM_PIXEL: u32 = 0u;
const DIM_LENS: u32 = 2u;
const DIM_TIME: u32 = 4u;
const DIM_ENVIRONMENT: u32 = 6u;
const DIM_LIGHT: u32 = 8u;
const DIM_LIGHT_SELECT: u32 = 10u;
const DIM_BSDF: u32 = 12u;
const DIM_BOUNCE_STRIDE: u32 = 16u;

fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn hash4(a: u32, b: u32, c: u32, d: u32) -> u32 {
    var h = pcg_hash(a);
    h = pcg_hash(h ^ b);
    h = pcg_hash(h ^ c);
    return pcg_hash(h ^ d);
}

fn to_unit(h: u32) -> f32 {
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

// rng::substream(stream, index): sub-stream of a pass's stream per light / component (hashed, never packed).
fn rng_substream(stream: u32, index: u32) -> u32 {
    return hash4(stream, index, 0x27d4eb2fu, 0x165667b1u);
}

// PixelRng::new(seed, pixel, stream).key
fn rng_key(seed: u32, pixel: u32, stream: u32) -> u32 {
    return hash4(seed, pixel, stream, 0x9e3779b9u);
}

fn rng_uniform(key: u32, sample: u32, dimension: u32) -> f32 {
    return to_unit(hash4(key, sample, dimension, 0x85ebca6bu));
}

fn rng_uniform2(key: u32, sample: u32, dimension: u32) -> vec2<f32> {
    return vec2<f32>(rng_uniform(key, sample, dimension), rng_uniform(key, sample, dimension + 1u));
}

fn rng_stratified2(key: u32, s: u32, n: u32, dimension: u32) -> vec2<f32> {
    return cmj(s, n, hash4(key, dimension, 0x68bc21ebu, 0x02e5be93u));
}

fn permute(i_in: u32, l: u32, p: u32) -> u32 {
    var i = i_in;
    var w = l - 1u;
    w |= w >> 1u;
    w |= w >> 2u;
    w |= w >> 4u;
    w |= w >> 8u;
    w |= w >> 16u;
    loop {
        i ^= p;
        i *= 0xe170893du;
        i ^= p >> 16u;
        i ^= (i & w) >> 4u;
        i ^= p >> 8u;
        i *= 0x0929eb3fu;
        i ^= p >> 23u;
        i ^= (i & w) >> 1u;
        i *= 1u | (p >> 27u);
        i *= 0x6935fa69u;
        i ^= (i & w) >> 11u;
        i *= 0x74dcb303u;
        i ^= (i & w) >> 2u;
        i *= 0x9e501cc3u;
        i ^= (i & w) >> 2u;
        i *= 0xc860a3dfu;
        i &= w;
        i ^= i >> 5u;
        if (i < l) {
            break;
        }
    }
    return (i + p) % l;
}

fn randfloat(i_in: u32, p: u32) -> f32 {
    var i = i_in;
    i ^= p;
    i ^= i >> 17u;
    i ^= i >> 10u;
    i *= 0xb36534e5u;
    i ^= i >> 12u;
    i ^= i >> 21u;
    i *= 0x93fc4795u;
    i ^= 0xdf6e307fu;
    i ^= i >> 17u;
    i *= 1u | (p >> 18u);
    return to_unit(i);
}

// Whether this implementation's fma() is fused (one rounding). Mesa's lavapipe, for one, lowers
// it to a multiply and an add. Probed at run time on values from the uniform, so no compiler folds it.
fn fma_is_fused() -> bool {
    let x = bitcast<f32>(frame.fma_probe_x);
    let y = bitcast<f32>(frame.fma_probe_y);
    return fma(x, x, -y) != 0.0;
}

// Dekker's split: hi + lo == v exactly, each with at most 12 significant bits.
fn split_hi(v: f32) -> f32 {
    let c = 4097.0 * v;
    return c - (c - v);
}

// a - q·b, exact for a quotient q of a/b (q·b ≈ a): through a fused fma where there is one,
// else Dekker's two-product (exact with correctly rounded + − ×, which Vulkan guarantees).
fn div_residual(a: f32, q: f32, b: f32) -> f32 {
    if (fma_is_fused()) {
        return fma(-q, b, a);
    }
    let p = q * b;
    let qh = split_hi(q);
    let ql = q - qh;
    let bh = split_hi(b);
    let bl = b - bh;
    let err = ((qh * bh - p) + qh * bl + ql * bh) + ql * bl;
    return (a - p) - err;
}

// a / b rounded to nearest, as Rust's `/` is, whatever the implementation's division precision
// (Vulkan allows 2.5 ulp): the hardware quotient plus one correction by the exact residual.
fn div_rn(a: f32, b: f32) -> f32 {
    let q = a / b;
    return q + div_residual(a, q, b) / b;
}

fn cmj(s_in: u32, n_in: u32, p: u32) -> vec2<f32> {
    let n = max(n_in, 1u);
    var m = u32(ceil(sqrt(f32(n))));
    if ((m - 1u) * (m - 1u) >= n) {
        m = m - 1u;
    }
    let k = (n + m - 1u) / m;
    let s = permute(s_in, n, p * 0x51633e2du);
    let sx = permute(s % m, m, p * 0x68bc21ebu);
    let sy = permute(s / m, k, p * 0x02e5be93u);
    let jx = randfloat(s, p * 0x967a889bu);
    let jy = randfloat(s, p * 0x368cc8b7u);
    var x = div_rn(f32(s % m) + div_rn(f32(sy) + jx, f32(k)), f32(m));
    var y = div_rn(f32(s / m) + div_rn(f32(sx) + jy, f32(m)), f32(k));
    if (m * k != n) {
        // Cranley–Patterson rotation for a partly filled last row (see backends/src/rng.rs).
        x = wrap_unit(x + randfloat(0x5bd1e995u, p * 0x1b873593u));
        y = wrap_unit(y + randfloat(0x27d4eb2fu, p * 0x85ebca6bu));
    }
    let one_minus_eps = bitcast<f32>(0x3f7fffffu);
    return vec2<f32>(min(x, one_minus_eps), min(y, one_minus_eps));
}

// `v mod 1` for `v` in [0, 2).
fn wrap_unit(v: f32) -> f32 {
    if (v >= 1.0) {
        return v - 1.0;
    }
    return v;
}

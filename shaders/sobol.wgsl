// sobol.wgsl — shuffled, Owen-scrambled Sobol' (0,2)-sequences (Burley 2020); mirrors
// backends/src/sobol.rs bit for bit (see its module doc for why the path sampler uses them).
#include "rng.wgsl"

const PAIR_PIXEL: u32 = 0u;
const PAIR_LENS: u32 = 1u;
const PAIR_LIGHT: u32 = 2u;
const PAIR_HEMISPHERE_DIFFUSE: u32 = 3u;
const PAIR_HEMISPHERE_GLOSSY: u32 = 4u;
const PAIR_PATH: u32 = 5u;
const PAIR_TIME: u32 = 6u;
const PAIR_ENVIRONMENT: u32 = 7u;
const PAIR_ENVIRONMENT_LOBE: u32 = 8u;

fn sobol_point(index: u32, dimension: u32) -> u32 {
    if (dimension == 0u) {
        return reverseBits(index);
    }
    var x = 0u;
    var i = index;
    var v = 0x80000000u;
    // v_k = v_{k-1} ^ (v_{k-1} >> 1): Sobol' dimension 1's direction numbers. At most 32 iterations.
    while (i != 0u) {
        if ((i & 1u) != 0u) {
            x = x ^ v;
        }
        i = i >> 1u;
        v = v ^ (v >> 1u);
    }
    return x;
}

fn laine_karras(x_in: u32, seed: u32) -> u32 {
    var x = x_in + seed;
    x = x ^ (x * 0x6c50b47cu);
    x = x ^ (x * 0xb82f1e52u);
    x = x ^ (x * 0xc7afe638u);
    x = x ^ (x * 0x8d22f6e6u);
    return x;
}

fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras(reverseBits(x), seed));
}

fn sequence_key(seed: u32, pixel: u32, stream: u32, pair: u32) -> u32 {
    return hash4(seed, pixel, stream, pcg_hash(pair ^ 0x5bd1e995u));
}

fn substream(stream: u32, salt: u32) -> u32 {
    return hash4(stream, pcg_hash(salt ^ 0x27d4eb2fu), PAIR_PATH, 0x165667b1u);
}

fn sobol2(key: u32, index: u32) -> vec2<f32> {
    let shuffled = nested_uniform_scramble(index, key);
    let sx = pcg_hash(key ^ 0x68bc21ebu);
    let sy = pcg_hash(key ^ 0x02e5be93u);
    return vec2<f32>(
        to_unit(nested_uniform_scramble(sobol_point(shuffled, 0u), sx)),
        to_unit(nested_uniform_scramble(sobol_point(shuffled, 1u), sy)),
    );
}

fn independent2(key: u32, index: u32) -> vec2<f32> {
    return vec2<f32>(to_unit(hash4(key, index, 0u, 0x85ebca6bu)), to_unit(hash4(key, index, 1u, 0x85ebca6bu)));
}

fn sample2(seed: u32, pixel: u32, stream: u32, pair: u32, index: u32) -> vec2<f32> {
    return sobol2(sequence_key(seed, pixel, stream, pair), index);
}

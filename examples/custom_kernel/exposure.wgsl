// example.exposure — out = value · 2^stops. The scale is computed on the CPU (`f32::powf`) and
// handed over in the uniform block, so both backends multiply by the same float: bit-identical.
#include "common.wgsl"

struct Params {
    scale: f32,
    _p0: u32,
    _p1: u32,
    _p2: u32,
}
@group(0) @binding(1) var<uniform> params: Params;

@group(1) @binding(0) var<storage, read> value: array<f32>; // vec3, packed
@group(1) @binding(1) var<storage, read_write> out: array<f32>; // vec3, packed

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    for (var c = 0u; c < 3u; c = c + 1u) {
        out[3u * i + c] = value[3u * i + c] * params.scale;
    }
}

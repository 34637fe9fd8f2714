// compose.modulate — out = value.rgb · albedo + emission (albedo/emission optional);
// mirrors backends/src/kernels/compose.rs. vec3 buffers are packed f32 arrays.
#include "common.wgsl"

struct Params {
    _unused: u32,
}
@group(0) @binding(1) var<uniform> params: Params;

@group(1) @binding(0) var<storage, read> value: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> albedo: array<f32>;
@group(1) @binding(2) var<storage, read> emission: array<f32>;
@group(1) @binding(3) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    var a = vec3<f32>(1.0);
    if (is_bound(1u)) {
        a = vec3<f32>(albedo[3u * i], albedo[3u * i + 1u], albedo[3u * i + 2u]);
    }
    var e = vec3<f32>(0.0);
    if (is_bound(2u)) {
        e = vec3<f32>(emission[3u * i], emission[3u * i + 1u], emission[3u * i + 2u]);
    }
    let o = value[i].xyz * a + e;
    out[3u * i] = o.x;
    out[3u * i + 1u] = o.y;
    out[3u * i + 2u] = o.z;
}

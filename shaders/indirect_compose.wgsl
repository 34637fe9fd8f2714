// indirect.compose — out = diffuse·k_d + glossy·k_s + direct·k_d + emission (every input but
// `diffuse` optional: k_d white, k_s zero when absent); mirrors backends/src/kernels/indirect.rs.
// vec3 buffers are packed f32 arrays.
#include "common.wgsl"

struct Params {
    _unused: u32,
}
@group(0) @binding(1) var<uniform> params: Params;

@group(1) @binding(0) var<storage, read> diffuse: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> glossy: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> direct: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read> albedo: array<f32>;
@group(1) @binding(4) var<storage, read> specular: array<vec4<f32>>;
@group(1) @binding(5) var<storage, read> emission: array<f32>;
@group(1) @binding(6) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    var kd = vec3<f32>(1.0);
    if (is_bound(3u)) {
        kd = vec3<f32>(albedo[3u * i], albedo[3u * i + 1u], albedo[3u * i + 2u]);
    }
    var ks = vec3<f32>(0.0);
    if (is_bound(4u)) {
        ks = specular[i].xyz;
    }
    var v = diffuse[i].xyz * kd;
    if (is_bound(1u)) {
        v = v + glossy[i].xyz * ks;
    }
    if (is_bound(2u)) {
        v = v + direct[i].xyz * kd;
    }
    if (is_bound(5u)) {
        v = v + vec3<f32>(emission[3u * i], emission[3u * i + 1u], emission[3u * i + 2u]);
    }
    out[3u * i] = v.x;
    out[3u * i + 1u] = v.y;
    out[3u * i + 2u] = v.z;
}

// compose.add — out = a + b per pixel and channel; mirrors effects/src/add.rs.
// vec3 buffers are packed f32 arrays (3 floats per pixel).
#include "common.wgsl"

struct Params {
    _unused: u32,
}
@group(0) @binding(1) var<uniform> params: Params;

@group(1) @binding(0) var<storage, read> a: array<f32>;
@group(1) @binding(1) var<storage, read> b: array<f32>;
@group(1) @binding(2) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let k = 3u * pixel_index(gid);
    out[k] = a[k] + b[k];
    out[k + 1u] = a[k + 1u] + b[k + 1u];
    out[k + 2u] = a[k + 2u] + b[k + 2u];
}

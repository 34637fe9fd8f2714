// defocus.layers — a blurred near layer composited over the rest (docs/DESIGN-NOTES.md "The near layer");
// mirrors effects/src/defocus/kernels/layers.rs (near_width, LayerInputs::near_tap, layered_pixel) term by
// term and in the same order; the CPU finds each weight once per distance (filter_window.rs
// CentreWeights, the same bits), the shader once per tap.
#include "common.wgsl"
#include "filter_window.wgsl"

const OMEGA_U_MAX: f32 = 1.0;
const FULL: f32 = 0.9999;
const LAYER_SEPARATION: f32 = 4.0;

// The near layer's width Ω = μ Ω_u / r_near (layers.rs near_width).
fn near_width(mu: f32, r_near: f32) -> f32 {
    return mu * OMEGA_U_MAX / r_near;
}

// (F, α) of pixel j, or (I, 1) where all its paths are near (layers.rs LayerInputs::near_tap).
fn near_of(j: u32) -> vec4<f32> {
    let n = near_at(j);
    if (n.w >= FULL) {
        return vec4<f32>(composed_at(j), 1.0);
    }
    return n;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let xy = vec2<i32>(pixel_xy(gid));
    let own = near_at(i);
    let r = near_coc_at(i).x;
    if (!(own.w > 0.0 && own.w < FULL && r > LAYER_SEPARATION * lens_at(i).x)) {
        out_put(i, filtered_at(i));
        return;
    }
    let omega = near_width(params.mu, r);
    let radius = window_radius(omega, params.max_radius);
    var f = vec3<f32>(0.0);
    var alpha = 0.0;
    var wsum = 0.0;
    for (var dy = -radius; dy <= radius; dy = dy + 1) {
        for (var dx = -radius; dx <= radius; dx = dx + 1) {
            let p = xy + vec2<i32>(dx, dy);
            if (!in_frame(p)) {
                continue;
            }
            let j = index_at(p.x, p.y);
            let rj = near_coc_at(j).x;
            var gj = 0.0;
            if (near_at(j).w > 0.0 && rj > 0.0) {
                gj = near_width(params.mu, rj);
            }
            let w = pair_weight(f32(dx * dx + dy * dy), omega * omega, gj * gj);
            if (w <= 0.0) {
                continue;
            }
            let n = near_of(j);
            f = f + w * n.xyz;
            alpha = alpha + w * n.w;
            wsum = wsum + w;
        }
    }
    f = vec3<f32>(f.x / wsum, f.y / wsum, f.z / wsum);
    alpha = alpha / wsum;
    let cover = 1.0 - own.w;
    let c = composed_at(i);
    let far = vec3<f32>((c.x - own.x) / cover, (c.y - own.y) / cover, (c.z - own.z) / cover);
    out_put(i, f + (1.0 - alpha) * far);
}

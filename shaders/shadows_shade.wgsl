// shadows.shade — r(x)·V: the closed-form unoccluded irradiance of the light (over π) times the
// filtered visibility ΣE/ΣU; mirrors effects/src/shadows/kernels.rs `Shade` and, term by term,
// scene/src/light.rs `AreaLight::irradiance_unoccluded` (Lambert's polygon formula, clipped to the
// tangent plane). The light's corners, radiance and (unnormalised) normal come as uniforms.
#include "common.wgsl"

fn light_corner(k: u32) -> vec3<f32> {
    switch (k) {
        case 0u: { return params.v0.xyz; }
        case 1u: { return params.v1.xyz; }
        case 2u: { return params.v2.xyz; }
        default: { return params.v3.xyz; }
    }
}

// scene/src/light.rs `angle`: atan2(y, x) for y ≥ 0 from + − × ÷ (a GPU's atan2 may be 4096 ulp off).
fn angle(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    var num = ax;
    var den = ay;
    if (ay <= ax) {
        num = ay;
        den = ax;
    }
    if (den == 0.0) {
        return 0.0;
    }
    var t = num / den;
    var base = 0.0;
    if (t > 0.2679492) {
        t = (t - 0.57735026) / (1.0 + t * 0.57735026);
        base = 0.5235988; // π/6
    }
    let t2 = t * t;
    let series = t * (1.0 + t2 * (-1.0 / 3.0 + t2 * (1.0 / 5.0 + t2 * (-1.0 / 7.0 + t2 * (1.0 / 9.0 + t2 * (-1.0 / 11.0 + t2 * (1.0 / 13.0)))))));
    var a = base + series;
    if (ay > ax) {
        a = 1.5707964 - a; // π/2
    }
    if (x < 0.0) {
        a = 3.1415927 - a;
    }
    return a;
}

fn polygon_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let count = params.count;
    let side = dot3(p - params.v0.xyz, params.cross.xyz);
    if (side == 0.0 || (side < 0.0 && params.two_sided == 0u)) {
        return vec3<f32>(0.0);
    }
    var poly: array<vec3<f32>, 5>;
    var m = 0u;
    for (var i = 0u; i < count; i = i + 1u) {
        let a = light_corner(i) - p;
        let b = light_corner((i + 1u) % count) - p;
        let da = dot3(n, a);
        let db = dot3(n, b);
        if (da >= 0.0) {
            poly[m] = a;
            m = m + 1u;
        }
        if ((da >= 0.0) != (db >= 0.0)) {
            poly[m] = a + (b - a) * (da / (da - db));
            m = m + 1u;
        }
    }
    var sum = 0.0;
    for (var i = 0u; i < m; i = i + 1u) {
        let a = poly[i];
        let b = poly[(i + 1u) % m];
        let c = cross3(a, b);
        let cl = length3(c);
        if (cl == 0.0) {
            continue;
        }
        let theta = angle(cl, dot3(a, b));
        sum = sum + theta * (dot3(n, c) / cl);
    }
    var oriented = sum;
    if (side > 0.0) {
        oriented = -sum;
    }
    return params.radiance.xyz * (0.5 * rmax(oriented, 0.0));
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let direct = direct_at(i);
    let position = position_at(i);
    if (position.w == 0.0) {
        out_put(i, direct);
        return;
    }
    let vis = visibility_at(i);
    var v = 1.0;
    if (vis.y > 0.0) {
        v = vis.x / vis.y;
    }
    let e = polygon_irradiance(position.xyz, normal_at(i).xyz) / 3.14159265358979323846 * v;
    out_put(i, vec4<f32>(e, direct.w));
}

// environment.wgsl — the environment map (wedge_scene::EnvironmentMap) as uploaded by
// backends/src/gpu/scene.rs into the one scene buffer; included by scene.wgsl.
//
// Conventions (scene/src/environment.rs): lat-long, row 0 the zenith (+Y), the column at u = 0.5
// facing −Z and u = 0.75 facing +X, `rotation_deg` about +Y by the right-hand rule (already folded
// into the uploaded column boundaries and table), radiance already multiplied by `scale`.
//
// The texel of a direction is found exactly as EnvironmentMap::texel_of does it — binary searches
// comparing f32 products of the direction's components with boundary tables computed on the CPU, in
// the same operation order; no atan2/acos (whose rounding differs between Rust and WGSL
// implementations). Radiance is piecewise constant per texel (no filtering), so it matches the
// sampling pdf, which is constant per texel too (stored with the texel).
//
// Sampling on the GPU is through the 4096-entry table (thesis Sec. 6.5.2): pick `env_table(i)` with
// i = floor(u · ENV_TABLE_SIZE) for a uniform u; `radiance · f · cos / pdf` then estimates the table's
// quadrature of the lighting integral.

const ENV_TABLE_SIZE: u32 = 4096u;

// One table entry: a unit world direction, the radiance from it (scaled), its pdf per solid angle, and
// its texel (row · width + column).
struct EnvSample {
    dir: vec3<f32>,
    radiance: vec3<f32>,
    pdf: f32,
    texel: u32,
}

// Whether the scene has an environment map (without one every env_* function returns zeros).
fn env_present() -> bool {
    return scene_layout.env_width > 0u;
}

// cot²θ_k of row boundary k (1 ≤ k < height), four per element.
fn env_row_t(k: u32) -> f32 {
    return bitcast<f32>(scene_data[scene_layout.env_rows + k / 4u][k % 4u]);
}

// Sorted column boundary m: (quadrant, fraction bits), two per element.
fn env_column_bound(m: u32) -> vec2<u32> {
    let e = scene_data[scene_layout.env_columns + m / 2u];
    return select(e.zw, e.xy, m % 2u == 0u);
}

// Row of `d`: the number of row boundaries k with θ ≥ θ_k (EnvironmentMap's `row_of`).
fn env_row_of(d: vec3<f32>) -> u32 {
    let h = scene_layout.env_height;
    let h2 = d.x * d.x + d.z * d.z;
    let yy = d.y * d.y;
    var lo = 1u;
    var hi = h;
    loop {
        if (lo >= hi) {
            break;
        }
        let mid = (lo + hi) / 2u;
        let t = env_row_t(mid) * h2;
        var below: bool;
        if (2u * mid <= h) {
            below = d.y <= 0.0 || yy <= t;
        } else {
            below = d.y < 0.0 && yy >= t;
        }
        if (below) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo - 1u;
}

// Map column of `d` (EnvironmentMap's `column_of`): the quadrant of ψ = atan2(−x, z) and the
// components turned back into quadrant 0, then the count of sorted boundaries at or before it.
fn env_column_of(d: vec3<f32>) -> u32 {
    let a0 = -d.x;
    let b0 = d.z;
    var q = 0u;
    var a = 0.0;
    var b = 1.0;
    if (b0 > 0.0 && a0 >= 0.0) {
        q = 0u;
        a = a0;
        b = b0;
    } else if (a0 > 0.0 && b0 <= 0.0) {
        q = 1u;
        a = -b0;
        b = a0;
    } else if (b0 < 0.0 && a0 <= 0.0) {
        q = 2u;
        a = -a0;
        b = -b0;
    } else if (a0 < 0.0 && b0 >= 0.0) {
        q = 3u;
        a = b0;
        b = -a0;
    }
    let den = a + b;
    let w = scene_layout.env_width;
    var lo = 0u;
    var hi = w;
    loop {
        if (lo >= hi) {
            break;
        }
        let mid = (lo + hi) / 2u;
        let c = env_column_bound(mid);
        let at_or_after = q > c.x || (q == c.x && a >= bitcast<f32>(c.y) * den);
        if (at_or_after) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return (scene_layout.env_first + lo + w - 1u) % w;
}

// EnvironmentMap::texel_of as one index (row · width + column); only with env_present().
fn env_texel(d: vec3<f32>) -> u32 {
    return env_row_of(d) * scene_layout.env_width + env_column_of(d);
}

// Texel i: radiance × scale (xyz) and its pdf per solid angle (w).
fn env_texel_value(i: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(scene_data[scene_layout.env_texels + i]);
}

// EnvironmentMap::radiance: radiance arriving from direction `d` (any non-zero length).
fn env_radiance(d: vec3<f32>) -> vec3<f32> {
    if (!env_present()) {
        return vec3<f32>(0.0);
    }
    return env_texel_value(env_texel(d)).xyz;
}

// EnvironmentMap::pdf: the pdf per solid angle of sampling direction `d` from the map.
fn env_pdf(d: vec3<f32>) -> f32 {
    if (!env_present()) {
        return 0.0;
    }
    return env_texel_value(env_texel(d)).w;
}

// EnvironmentMap::table: entry i (mod ENV_TABLE_SIZE) of the precomputed sample table.
fn env_table(i: u32) -> EnvSample {
    let b = scene_layout.env_table + 2u * (i % ENV_TABLE_SIZE);
    let e0 = bitcast<vec4<f32>>(scene_data[b]);
    let e1 = scene_data[b + 1u];
    return EnvSample(e0.xyz, bitcast<vec3<f32>>(e1.xyz), e0.w, e1.w);
}

// Scene::background: what a ray leaving the scene in direction `d` sees (black without a map).
fn scene_background(d: vec3<f32>) -> vec3<f32> {
    return env_radiance(d);
}

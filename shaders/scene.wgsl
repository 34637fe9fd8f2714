// scene.wgsl — the scene as uploaded by backends/src/gpu/scene.rs (group 2), and surface
// interpolation / albedo / emission mirroring wedge_scene::Scene::{surface, albedo, emission}.
// BvhNode and Triangle are the Rust `repr(C)` structs byte for byte (32 and 48 bytes).

struct BvhNode {
    min: vec3<f32>,
    index: u32,
    max: vec3<f32>,
    count: u32,
}

struct Triangle {
    v0: vec3<f32>,
    material: u32,
    e1: vec3<f32>,
    light: u32,
    e2: vec3<f32>,
    source: u32,
}

// TriangleShading, repacked (80 bytes): vertex normals, uvs, material, object.
struct Shading {
    n0: vec3<f32>,
    material: u32,
    n1: vec3<f32>,
    object: u32,
    n2: vec3<f32>,
    _pad: u32,
    uv0: vec2<f32>,
    uv1: vec2<f32>,
    uv2: vec2<f32>,
    _pad2: vec2<f32>,
}

const NO_TEXTURE: u32 = 0xffffffffu;

struct Material {
    base_color: vec3<f32>,
    texture: u32,
    emission: vec3<f32>,
    _pad: u32,
    specular: vec3<f32>,   // k_s
    phong_exponent: f32,   // m (0 = no glossy lobe)
}

struct TextureInfo {
    offset: u32, // first texel in `texels` (in texels, 3 floats each)
    width: u32,
    height: u32,
    _pad: u32,
}

const LIGHT_RECT: u32 = 0u;
const LIGHT_TRIANGLE: u32 = 1u;

// AreaLight with the derived quantities precomputed on the CPU (same Rust code the CPU uses):
// rect: p0 = corner, p1 = edge_u, p2 = edge_v; triangle: p0..p2 = v0..v2.
struct Light {
    p0: vec4<f32>,
    p1: vec4<f32>,
    p2: vec4<f32>,
    radiance: vec4<f32>,
    normal_area: vec4<f32>,  // xyz = normal(), w = area()
    centre_sigma: vec4<f32>, // xyz = centre(), w = sigma()
    kind: u32,
    two_sided: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(2) @binding(0) var<storage, read> bvh_nodes: array<BvhNode>;
@group(2) @binding(1) var<storage, read> triangles: array<Triangle>;
@group(2) @binding(2) var<storage, read> shading: array<Shading>;
@group(2) @binding(3) var<storage, read> materials: array<Material>;
@group(2) @binding(4) var<storage, read> tex_info: array<TextureInfo>;
@group(2) @binding(5) var<storage, read> texels: array<f32>;
@group(2) @binding(6) var<storage, read> lights: array<Light>;

struct SurfacePoint {
    position: vec3<f32>,
    geometric_normal: vec3<f32>,
    shading_normal: vec3<f32>,
    uv: vec2<f32>,
    material: u32,
    object: u32,
}

// Scene::surface
fn surface(tri_index: u32, hb1: f32, hb2: f32, dir: vec3<f32>) -> SurfacePoint {
    let tri = triangles[tri_index];
    let sh = shading[tri_index];
    let b0 = 1.0 - hb1 - hb2;
    let b1 = hb1;
    let b2 = hb2;
    let e1 = tri.e1;
    let e2 = tri.e2;
    let position = tri.v0 + b1 * e1 + b2 * e2;
    var ng = normalize_or_zero3(cross3(e1, e2));
    if (is_zero3(ng)) {
        ng = -normalize_or_zero3(dir);
    }
    if (dot3(ng, dir) > 0.0) {
        ng = -ng;
    }
    var ns = normalize_or_zero3(b0 * sh.n0 + b1 * sh.n1 + b2 * sh.n2);
    if (is_zero3(ns) || !is_finite3(ns)) {
        ns = ng;
    }
    if (dot3(ns, ng) < 0.0) {
        ns = -ns;
    }
    var sp: SurfacePoint;
    sp.position = position;
    sp.geometric_normal = ng;
    sp.shading_normal = ns;
    sp.uv = b0 * sh.uv0 + b1 * sh.uv1 + b2 * sh.uv2;
    sp.material = sh.material;
    sp.object = sh.object;
    return sp;
}

// f32::rem_euclid(x, 1.0)
fn rem1(x: f32) -> f32 {
    let r = x - trunc(x);
    return select(r, r + 1.0, r < 0.0);
}

fn texel_at(t: TextureInfo, x: i32, y: i32) -> vec3<f32> {
    let w = i32(t.width);
    let h = i32(t.height);
    let xi = ((x % w) + w) % w;
    let yi = ((y % h) + h) % h;
    let k = (t.offset + u32(yi * w + xi)) * 3u;
    return vec3<f32>(texels[k], texels[k + 1u], texels[k + 2u]);
}

fn lerp3(a: vec3<f32>, b: vec3<f32>, s: f32) -> vec3<f32> {
    return a * (1.0 - s) + b * s;
}

// Texture::sample: bilinear, repeat.
fn texture_sample(index: u32, uv_in: vec2<f32>) -> vec3<f32> {
    let t = tex_info[index];
    if (t.width == 0u || t.height == 0u) {
        return vec3<f32>(1.0);
    }
    var uv = uv_in;
    if (!(is_finite(uv.x) && is_finite(uv.y))) {
        uv = vec2<f32>(0.5) / vec2<f32>(f32(t.width), f32(t.height));
    }
    let x = rem1(uv.x) * f32(t.width) - 0.5;
    let y = rem1(uv.y) * f32(t.height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let xi = i32(x0);
    let yi = i32(y0);
    let top = lerp3(texel_at(t, xi, yi), texel_at(t, xi + 1, yi), fx);
    let bottom = lerp3(texel_at(t, xi, yi + 1), texel_at(t, xi + 1, yi + 1), fx);
    return lerp3(top, bottom, fy);
}

// Scene::albedo
fn albedo(sp: SurfacePoint) -> vec3<f32> {
    let m = materials[sp.material];
    if (m.texture != NO_TEXTURE) {
        return m.base_color * texture_sample(m.texture, sp.uv);
    }
    return m.base_color;
}

// Scene::emission
fn emission(sp: SurfacePoint) -> vec3<f32> {
    return materials[sp.material].emission;
}

// scene.wgsl — the scene as uploaded by backends/src/gpu/scene.rs (group 2), and surface
// interpolation / albedo / emission mirroring wedge_scene::Scene::{surface, albedo, emission}.
// WideNode, TrianglePack and Triangle are the Rust `repr(C)` structs byte for byte (256, 160 and
// 48 bytes).
//
// All arrays live in ONE storage buffer of 16-byte elements (`scene_data`), one after another;
// `scene_layout` says at which element each starts. So the scene costs one storage binding
// (WebGPU's default allows 8 per stage). Read them only through the accessors below
// (`wide_node_base(i)` with bvh.wgsl's `node_slab`/`node_child`, `triangle_pack_row(i, v, a)`, `triangle(i)`, `shading_of(i)`, `material(i)`, `texture_info(i)`, `texel(i)`,
// `area_light(i)`, `scene_instance(i)`, `object_instance(i)`): each rebuilds the struct from its
// 16-byte elements with bitcasts (bit-exact).
//
// Motion (wedge_scene::SceneAt): objects that move over the shutter are instances (motion.wgsl), each
// with its own tree after the static one (bvh.wgsl traverses both). `scene_time` is the time the
// scene is seen at — `scene_intersect`, `scene_occluded`, `surface`, `scene_light_at` and
// `object_velocity` read it; it is 0 (the shutter's centre, what `Scene::intersect` etc. mean on the
// CPU) unless a kernel sets it. `area_light(i)` is the light as stored (rest pose, `Scene::lights`);
// `scene_light_at(i)` is where it is at `scene_time` (`SceneAt::light`).
//
// Environment (wedge_scene::EnvironmentMap, environment.wgsl): `env_present()`, `env_radiance(dir)`,
// `env_pdf(dir)`, `env_table(i)` and `scene_background(dir)`, reading the four env_* arrays.
//
// Real layer (wedge_scene::RealLayer, real_layer.wgsl; mixed reality): `real_present()`,
// `real_camera(x, y)`, `real_position(x, y)`, `real_normal(x, y)`, `real_albedo(x, y)`.
#include "motion.wgsl"
#include "environment.wgsl"
#include "real_layer.wgsl"

// The time of the shutter (t ∈ [−1, 1]) the scene is traced at; see above.
var<private> scene_time: f32 = 0.0;

// wedge_scene::bvh::WideNode (8 · BVH_GROUPS elements of `scene_data`, read in place by bvh.wgsl's
// `node_slab` / `node_child`): BVH_WIDTH child boxes as six rows (row 2·axis the minima, 2·axis + 1
// the maxima, one lane per child), each row BVH_GROUPS elements (element row · BVH_GROUPS + g holds
// children 4g .. 4g + 3), then the child references (BVH_GROUPS elements); the Rust node's pad (its
// last BVH_GROUPS elements) is not read.
// wedge_scene::bvh::WIDTH children per node, in BVH_GROUPS groups of four lanes.
const BVH_WIDTH: u32 = 8u;
const BVH_GROUPS: u32 = 2u;
const BVH_NODE_ELEMENTS: u32 = 16u;

// wedge_scene::bvh::TrianglePack (10 elements): four triangles' v0, v1, v2 as x/y/z rows (elements
// 0–2, 3–5, 6–8; lane = triangle), then their indices (element 9). Read row by row
// (`triangle_pack_row`, `triangle_pack_index`): the watertight test picks rows by the ray's axes.

struct Triangle {
    v0: vec3<f32>,
    material: u32,
    v1: vec3<f32>,
    light: u32,
    v2: vec3<f32>,
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
    offset: u32, // first texel (see `texel`)
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
    instance: u32, // the instance it moves with (Scene::light_object's), or NO_INSTANCE
    _pad1: u32,
}

// First element of each array in `scene_data` (backends/src/gpu/scene.rs `pack`).
struct SceneLayout {
    bvh_nodes: u32,
    triangle_packs: u32,
    triangles: u32,
    shading: u32,
    materials: u32,
    tex_info: u32,
    texels: u32,
    lights: u32,
    instances: u32,
    object_instances: u32,
    env_texels: u32,
    env_rows: u32,
    env_columns: u32,
    env_table: u32,
    real_maps: u32,
    instance_count: u32,
    instance_root: u32, // the top-level tree over the instances (Scene::instance_root)
    env_width: u32,   // 0: no environment map
    env_height: u32,
    env_first: u32,   // the map column the first sorted column boundary starts
    real_width: u32,  // 0: no real layer (real_layer.wgsl)
    real_height: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(2) @binding(0) var<storage, read> scene_data: array<vec4<u32>>;
@group(2) @binding(1) var<uniform> scene_layout: SceneLayout;

fn scene_xyz(v: vec4<u32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(v.xyz);
}

// The first element of node `i` in `scene_data`.
fn wide_node_base(i: u32) -> u32 {
    return scene_layout.bvh_nodes + BVH_NODE_ELEMENTS * i;
}

// Axis `axis` of vertex `vertex` of the four triangles of pack `i`.
fn triangle_pack_row(i: u32, vertex: u32, axis: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(scene_data[scene_layout.triangle_packs + 10u * i + 3u * vertex + axis]);
}

fn triangle_pack_index(i: u32) -> vec4<u32> {
    return scene_data[scene_layout.triangle_packs + 10u * i + 9u];
}

fn triangle(i: u32) -> Triangle {
    let b = scene_layout.triangles + 3u * i;
    let a = scene_data[b];
    let c = scene_data[b + 1u];
    let d = scene_data[b + 2u];
    return Triangle(scene_xyz(a), a.w, scene_xyz(c), c.w, scene_xyz(d), d.w);
}

fn shading_of(i: u32) -> Shading {
    let b = scene_layout.shading + 5u * i;
    let a = scene_data[b];
    let c = scene_data[b + 1u];
    let d = scene_data[b + 2u];
    let uv01 = bitcast<vec4<f32>>(scene_data[b + 3u]);
    let uv2 = bitcast<vec4<f32>>(scene_data[b + 4u]);
    return Shading(scene_xyz(a), a.w, scene_xyz(c), c.w, scene_xyz(d), d.w, uv01.xy, uv01.zw, uv2.xy, uv2.zw);
}

fn material(i: u32) -> Material {
    let b = scene_layout.materials + 3u * i;
    let a = scene_data[b];
    let c = scene_data[b + 1u];
    let d = scene_data[b + 2u];
    return Material(scene_xyz(a), a.w, scene_xyz(c), c.w, scene_xyz(d), bitcast<f32>(d.w));
}

fn texture_info(i: u32) -> TextureInfo {
    let a = scene_data[scene_layout.tex_info + i];
    return TextureInfo(a.x, a.y, a.z, a.w);
}

// Texel `i` of all textures (one 16-byte element each: rgb, 0).
fn texel(i: u32) -> vec3<f32> {
    return scene_xyz(scene_data[scene_layout.texels + i]);
}

fn area_light(i: u32) -> Light {
    let b = scene_layout.lights + 7u * i;
    let f = bitcast<vec4<f32>>(scene_data[b]);
    let g = bitcast<vec4<f32>>(scene_data[b + 1u]);
    let h = bitcast<vec4<f32>>(scene_data[b + 2u]);
    let r = bitcast<vec4<f32>>(scene_data[b + 3u]);
    let na = bitcast<vec4<f32>>(scene_data[b + 4u]);
    let cs = bitcast<vec4<f32>>(scene_data[b + 5u]);
    let k = scene_data[b + 6u];
    return Light(f, g, h, r, na, cs, k.x, k.y, k.z, k.w);
}

// Instance `i` (wedge_scene::Scene::instances[i] with its PreparedMotion; 8 elements).
fn scene_instance(i: u32) -> Instance {
    let b = scene_layout.instances + 8u * i;
    let a = scene_data[b];
    let c = scene_data[b + 1u];
    let p = bitcast<vec4<f32>>(scene_data[b + 2u]);
    let t0 = bitcast<vec4<f32>>(scene_data[b + 3u]);
    let t1 = bitcast<vec4<f32>>(scene_data[b + 4u]);
    let q0 = bitcast<vec4<f32>>(scene_data[b + 5u]);
    let q1 = bitcast<vec4<f32>>(scene_data[b + 6u]);
    let w = bitcast<vec4<f32>>(scene_data[b + 7u]);
    return Instance(scene_xyz(a), a.w, scene_xyz(c), p.xyz, p.w, t0.xyz, t0.w, t1.xyz, q0, q1, w.xyz);
}

// The instance moving object `object` (Scene::objects[object].instance), or NO_INSTANCE.
fn object_instance(object: u32) -> u32 {
    return scene_data[scene_layout.object_instances + object / 4u][object % 4u];
}

// SceneAt::velocity: the world velocity per unit t (per half shutter) of the point `x` (at
// `scene_time`) of object `object`; zero at rest.
fn object_velocity(object: u32, x: vec3<f32>) -> vec3<f32> {
    if (scene_layout.instance_count == 0u) {
        return vec3<f32>(0.0);
    }
    let k = object_instance(object);
    if (k == NO_INSTANCE) {
        return vec3<f32>(0.0);
    }
    return instance_velocity(scene_instance(k), scene_time, x);
}

// SceneAt::light: light `i` where it is at `scene_time` (its shape moved with its object; normal,
// area and centre recomputed as AreaLight's methods do; σ kept: a rigid motion does not change it).
fn scene_light_at(i: u32) -> Light {
    var l = area_light(i);
    if (l.instance == NO_INSTANCE) {
        return l;
    }
    let xf = instance_transform(scene_instance(l.instance), scene_time);
    var c: vec3<f32>;
    var area: f32;
    var centre: vec3<f32>;
    if (l.kind == LIGHT_RECT) {
        let corner = xf_point(xf, l.p0.xyz);
        let eu = xf_vector(xf, l.p1.xyz);
        let ev = xf_vector(xf, l.p2.xyz);
        l.p0 = vec4<f32>(corner, 0.0);
        l.p1 = vec4<f32>(eu, 0.0);
        l.p2 = vec4<f32>(ev, 0.0);
        c = cross3(eu, ev);
        area = length3(c);
        centre = corner + 0.5 * (eu + ev);
    } else {
        let v0 = xf_point(xf, l.p0.xyz);
        let v1 = xf_point(xf, l.p1.xyz);
        let v2 = xf_point(xf, l.p2.xyz);
        l.p0 = vec4<f32>(v0, 0.0);
        l.p1 = vec4<f32>(v1, 0.0);
        l.p2 = vec4<f32>(v2, 0.0);
        c = cross3(v1 - v0, v2 - v0);
        area = 0.5 * length3(c);
        centre = (v0 + v1 + v2) / 3.0;
    }
    l.normal_area = vec4<f32>(normalize_or_zero3(c), area);
    l.centre_sigma = vec4<f32>(centre, l.centre_sigma.w);
    return l;
}

struct SurfacePoint {
    position: vec3<f32>,
    geometric_normal: vec3<f32>,
    shading_normal: vec3<f32>,
    uv: vec2<f32>,
    material: u32,
    object: u32,
}

// SceneAt::surface at `scene_time`: a moving triangle's point and normals as stored (with `dir` moved
// into its rest pose), then moved by its instance's transform (normals rotated).
// (One call of `surface_stored`, so it is inlined once.)
fn surface(tri_index: u32, hb1: f32, hb2: f32, dir: vec3<f32>) -> SurfacePoint {
    var k = NO_INSTANCE;
    if (scene_layout.instance_count > 0u) {
        k = object_instance(shading_of(tri_index).object);
    }
    var xf: RigidTransform;
    var d = dir;
    if (k != NO_INSTANCE) {
        xf = instance_transform(scene_instance(k), scene_time);
        d = xf_inverse_vector(xf, dir);
    }
    var sp = surface_stored(tri_index, hb1, hb2, d);
    if (k != NO_INSTANCE) {
        sp.position = xf_point(xf, sp.position);
        sp.geometric_normal = xf_vector(xf, sp.geometric_normal);
        sp.shading_normal = xf_vector(xf, sp.shading_normal);
    }
    return sp;
}

// Scene::surface_stored: a triangle as stored, `dir` in the same space.
fn surface_stored(tri_index: u32, hb1: f32, hb2: f32, dir: vec3<f32>) -> SurfacePoint {
    let tri = triangle(tri_index);
    let sh = shading_of(tri_index);
    let b0 = 1.0 - hb1 - hb2;
    let b1 = hb1;
    let b2 = hb2;
    let e1 = tri.v1 - tri.v0;
    let e2 = tri.v2 - tri.v0;
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
    return texel(t.offset + u32(yi * w + xi));
}

fn lerp3(a: vec3<f32>, b: vec3<f32>, s: f32) -> vec3<f32> {
    return a * (1.0 - s) + b * s;
}

// Texture::sample: bilinear, repeat.
fn texture_sample(index: u32, uv_in: vec2<f32>) -> vec3<f32> {
    let t = texture_info(index);
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
    let m = material(sp.material);
    if (m.texture != NO_TEXTURE) {
        return m.base_color * texture_sample(m.texture, sp.uv);
    }
    return m.base_color;
}

// Scene::emission
fn emission(sp: SurfacePoint) -> vec3<f32> {
    return material(sp.material).emission;
}

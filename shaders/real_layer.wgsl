// real_layer.wgsl — the mixed-reality real layer (wedge_scene::RealLayer) as uploaded by
// backends/src/gpu/scene.rs into the one scene buffer; included by scene.wgsl.
//
// Per pixel of the camera image (row-major, row 0 at the top; pixel (x, y) is the camera ray through
// its centre) four consecutive 16-byte elements starting at `scene_layout.real_maps`:
//   0: camera rgb (L_cam, linear) + coverage (1: a real surface covers the pixel centre, 0: none)
//   1: world position xyz + coverage (xyz 0 where not covered)
//   2: unit world normal xyz, 0 (0 where not covered)
//   3: diffuse albedo rgb, 0 (0 where not covered)
// The values are the CPU's bit for bit (RealLayer::camera_map, position_map, normal_map, albedo_map).
// After the last pixel's elements, in the same array: the depth pyramid of the layer seen by the
// scene's camera (backends/src/kernels/screen_trace.rs DepthPyramid::gpu_elements, bit for bit) —
// REAL_PYRAMID_HEADER elements, element l = level l's first value, width, height, the level count
// (u32), then the values (lower bounds of the real surface's depth; NO_SURFACE where none), four per
// element.
// Coordinates outside the image (a screen-space march leaving the screen) read zeros — not covered —
// exactly as RealLayer::index_of returns None there; without a layer every pixel is outside.

// Whether the scene has a real layer.
fn real_present() -> bool {
    return scene_layout.real_width > 0u;
}

// First element of pixel (x, y), or -1 outside the layer.
fn real_element(x: i32, y: i32) -> i32 {
    let w = i32(scene_layout.real_width);
    let h = i32(scene_layout.real_height);
    if (x < 0 || y < 0 || x >= w || y >= h) {
        return -1;
    }
    return 4 * (y * w + x);
}

fn real_load(x: i32, y: i32, k: u32) -> vec4<f32> {
    let e = real_element(x, y);
    if (e < 0) {
        return vec4<f32>(0.0);
    }
    return bitcast<vec4<f32>>(scene_data[scene_layout.real_maps + u32(e) + k]);
}

// L_cam at pixel (x, y), linear RGB.
fn real_camera(x: i32, y: i32) -> vec3<f32> {
    return real_load(x, y, 0u).xyz;
}

// World position xyz and coverage w (1 covered, 0 not, and 0 outside the image).
fn real_position(x: i32, y: i32) -> vec4<f32> {
    return real_load(x, y, 1u);
}

// Unit world normal (0 where not covered).
fn real_normal(x: i32, y: i32) -> vec3<f32> {
    return real_load(x, y, 2u).xyz;
}

// Diffuse albedo k_d, linear RGB in [0, 1] (0 where not covered).
fn real_albedo(x: i32, y: i32) -> vec3<f32> {
    return real_load(x, y, 3u).xyz;
}

// Elements before the pyramid's values (screen_trace.rs PYRAMID_HEADER).
const REAL_PYRAMID_HEADER: u32 = 16u;

fn real_pyramid_start() -> u32 {
    return scene_layout.real_maps + 4u * scene_layout.real_width * scene_layout.real_height;
}

// Level l of the depth pyramid: first value, width, height, level count.
fn real_pyramid_level(l: u32) -> vec4<u32> {
    return scene_data[real_pyramid_start() + l];
}

// The bound of cell (x, y) of a level (`level` its real_pyramid_level); NO_SURFACE (f32::MAX)
// outside the level, as DepthPyramid::get.
fn real_pyramid_get(level: vec4<u32>, x: i32, y: i32) -> f32 {
    if (x < 0 || y < 0 || x >= i32(level.y) || y >= i32(level.z)) {
        return bitcast<f32>(0x7f7fffffu);
    }
    let i = level.x + u32(y) * level.y + u32(x);
    let e = bitcast<vec4<f32>>(scene_data[real_pyramid_start() + REAL_PYRAMID_HEADER + i / 4u]);
    return e[i % 4u];
}

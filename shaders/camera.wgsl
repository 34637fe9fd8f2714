// camera.wgsl — the thin-lens camera; mirrors scene/src/camera.rs (Camera::ray, Camera::coc_pixels,
// LensShape::weight) with the same operation order, so both backends trace the same primary rays.
// Kernels fill a `CameraModel` from their params (kernels::paths::camera_uniforms writes the fields).
#include "common.wgsl"
#include "sampling.wgsl"

struct CameraModel {
    position: vec3<f32>,
    right: vec3<f32>,
    up: vec3<f32>,
    forward: vec3<f32>,
    tan_half: f32,
    aperture: f32,        // aperture radius (world units); <= 0 is a pinhole
    focus_distance: f32,  // effective focus distance along the view direction
    gaussian: u32,        // LensShape: 0 disk, 1 gaussian
}

struct LensRay {
    origin: vec3<f32>,
    dir: vec3<f32>,
    weight: f32,
    lens: vec2<f32>,
}

fn lens_weight(c: CameraModel, u: vec2<f32>) -> f32 {
    if (c.gaussian != 0u) {
        return exp(-0.5 * (u.x * u.x + u.y * u.y));
    }
    return 1.0;
}

// Camera::ray: image point `pixel` (pixels, (0,0) top-left, y down), lens sample in [0,1)².
fn camera_ray(c: CameraModel, pixel: vec2<f32>, lens_sample: vec2<f32>) -> LensRay {
    let w = f32(max(frame.full_width, 1u));
    let h = f32(max(frame.full_height, 1u));
    let sx = (2.0 * pixel.x / w - 1.0) * c.tan_half * (w / h);
    let sy = (1.0 - 2.0 * pixel.y / h) * c.tan_half;
    let dir = normalize3(c.forward + sx * c.right + sy * c.up);
    if (c.aperture <= 0.0) {
        return LensRay(c.position, dir, 1.0, vec2<f32>(0.0));
    }
    let focus = c.position + dir * (c.focus_distance / dot3(dir, c.forward));
    let u = concentric_disk(lens_sample);
    let d = u * c.aperture;
    let origin = c.position + d.x * c.right + d.y * c.up;
    return LensRay(origin, normalize3(focus - origin), lens_weight(c, u), u);
}

// Camera::coc_pixels: signed circle of confusion (pixels) at `depth` along the optical axis (eq. 5.2).
fn coc_pixels(c: CameraModel, depth: f32) -> f32 {
    if (c.aperture <= 0.0) {
        return 0.0;
    }
    let scale = c.aperture * f32(max(frame.full_height, 1u)) / (2.0 * c.focus_distance * c.tan_half);
    return scale * (c.focus_distance / depth - 1.0);
}

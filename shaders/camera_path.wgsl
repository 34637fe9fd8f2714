// camera_path.wgsl — the camera of the kernels that trace their own camera paths and the camera ray
// of path `j` through a pixel (effects/src/camera_paths.rs `CameraDraws`, `camera_uniforms`: the
// including kernel's Params carry `cam_*`, `cam_shutter`, `jitter` and `strata`): jittered over the
// pixel (`params.jitter`, else through its centre), through the lens where the camera has an
// aperture, at the path's own time (`scene_time`) where `params.cam_shutter` is set; each its own
// dimension, independent or (`params.strata` > 0) stratified. Shared by pixel_filter.sample,
// pixel_filter.range, radiance_filter.sample and light_field.sample.
#include "rng.wgsl"
#include "scene.wgsl"
#include "camera.wgsl"

fn path_camera() -> CameraModel {
    return CameraModel(params.cam_position, params.cam_right, params.cam_up, params.cam_forward, params.cam_tan_half,
        params.cam_aperture, params.cam_focus_distance, params.cam_gaussian);
}

// Path j's numbers for `dimension`: independent, or sample j of `params.strata` stratified ones.
fn path_camera_draw(key: u32, j: u32, dimension: u32) -> vec2<f32> {
    if (params.strata != 0u) {
        return rng_stratified2(key, j, params.strata, dimension);
    }
    return rng_uniform2(key, j, dimension);
}

fn path_camera_ray(c: CameraModel, key: u32, j: u32, xy: vec2<u32>) -> LensRay {
    let jit = select(vec2<f32>(0.5), path_camera_draw(key, j, DIM_PIXEL), params.jitter != 0u);
    let lens = select(vec2<f32>(0.5), path_camera_draw(key, j, DIM_LENS), c.aperture > 0.0);
    scene_time = select(0.0, 2.0 * path_camera_draw(key, j, DIM_TIME).x - 1.0, params.cam_shutter != 0u);
    return camera_ray(c, vec2<f32>(f32(xy.x) + jit.x, f32(xy.y) + jit.y), lens);
}

//! The Ch. 6 filter (`filter.environment`, eqs. 6.21–6.23; `filter.environment_history` and the
//! temporal y pass, eqs. 6.24–6.26 as read in `effects/src/environment/kernels/filter.rs`): weights against a
//! direct evaluation, the temporal join on a still camera, reprojection under camera motion, and
//! parity of both kernels with the wgpu backend.

mod common;

use std::collections::BTreeMap;
use std::sync::Arc;

use common::gpu_or_skip;
use wedge::backends::gpu::GpuBackend;
use wedge::backends::lone::LonePass;
use wedge::backends::parity::{compare, Tolerance};
use wedge::backends::{BufferData, Kernel, KernelClass, Texel};
use wedge::effects::environment::kernels::filter::{EnvironmentFilter, EnvironmentHistory};
use wedge::graph::ParamValue;
use wedge::scene::{Camera, Scene, SceneSource};

const W: u32 = 40;
const H: u32 = 30;

/// A plane z = 0 seen head on from z = 3, so pixel (x, y)'s position is where its centre ray meets it.
fn plane_scene() -> (Scene, Camera) {
    let mut scene = wedge::scene::load(&SceneSource::Builtin("grids".into())).expect("scene");
    let cam =
        Camera { position: glam::Vec3::new(0.0, 0.0, 3.0), look_at: glam::Vec3::ZERO, vfov_deg: 40.0, ..scene.camera };
    scene.camera = cam;
    (scene, cam)
}

/// G-buffer of the plane as `cam` sees it (object id 1 everywhere, normal +z, w = footprint).
fn gbuffer(cam: &Camera) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let mut position = Vec::new();
    let mut normal = Vec::new();
    for y in 0..H {
        for x in 0..W {
            let (o, d) = cam.generate_ray(x as f32 + 0.5, y as f32 + 0.5, W, H, glam::Vec2::splat(0.5));
            let t = -o.z / d.z;
            let p = o + d * t;
            position.push([p.x, p.y, p.z, 1.0]);
            normal.push([0.0, 0.0, 1.0, 0.01]);
        }
    }
    (position, normal)
}

/// Irradiance with structure: a ramp in x and stripes in y.
fn value() -> Vec<[f32; 3]> {
    (0..W * H).map(|i| [(i % W) as f32 / W as f32, ((i / W) % 3) as f32, 1.0]).collect()
}

fn run(
    kernel: Arc<dyn Kernel>,
    scene: &Scene,
    params: &[(&str, ParamValue)],
    inputs: &BTreeMap<&str, BufferData>,
    gpu: Option<&mut GpuBackend>,
) -> BufferData {
    let params = params.iter().map(|(k, v)| (k.to_string(), v.clone())).collect();
    let lone = LonePass::new(kernel, params, inputs).expect("inputs match the kernel's bindings");
    let out = match gpu {
        Some(g) => lone.run_gpu(g, scene, W, H, 1).expect("gpu pass").0,
        None => lone.run_cpu(scene, W, H, 1).expect("cpu pass").0,
    };
    out["out"].clone()
}

fn axis_params(axis: i64) -> Vec<(&'static str, ParamValue)> {
    vec![
        ("axis", ParamValue::Int(axis)),
        ("max_radius", ParamValue::Int(15)),
        ("normal_cos", ParamValue::Float(10f64.to_radians().cos())),
    ]
}

#[test]
fn the_x_pass_is_the_averaged_bandwidth_gaussian() {
    let (scene, cam) = plane_scene();
    let (position, normal) = gbuffer(&cam);
    // Bandwidth varying along x, so B̄² matters.
    let bandwidth: Vec<[f32; 2]> = (0..W * H).map(|i| [20.0 + (i % W) as f32, 30.0]).collect();
    let v = value();
    let inputs: BTreeMap<&str, BufferData> = [
        ("value", BufferData::Vec3(v.clone())),
        ("position", BufferData::Vec4(position.clone())),
        ("normal", BufferData::Vec4(normal)),
        ("bandwidth", BufferData::Vec2(bandwidth.clone())),
    ]
    .into_iter()
    .collect();
    let out = run(Arc::new(EnvironmentFilter), &scene, &axis_params(0), &inputs, None);
    let out = <[f32; 3] as Texel>::slice(&out).unwrap();
    let (x, y) = (20i32, 10i32);
    let i = (y * W as i32 + x) as usize;
    let (mut s, mut ws) = (0.0f64, 0.0f64);
    for k in -15..=15 {
        let j = (y * W as i32 + x + k) as usize;
        let b2 = 0.5 * (bandwidth[i][0].powi(2) + bandwidth[j][0].powi(2)) as f64;
        let d = (0..3).map(|c| (position[j][c] - position[i][c]) as f64).map(|e| e * e).sum::<f64>();
        let w = (-2.0 * b2 * d).exp();
        s += w * v[j][0] as f64;
        ws += w;
    }
    assert!((out[i][0] as f64 - s / ws).abs() < 1e-5, "{} vs {}", out[i][0], s / ws);
    // The y stripes are untouched by the x pass.
    assert_eq!(out[i][1], v[i][1]);
}

#[test]
fn a_still_camera_reprojects_onto_itself_and_joins_the_y_pass() {
    // Previous frame = this frame (same camera, same buffers): the history pass gives the x filter of
    // the same values around the same pixel, valid everywhere; the y pass then weighs both equally, so
    // its output equals the y pass without history.
    let (mut scene, cam) = plane_scene();
    scene.previous_camera = Some(cam);
    let (position, normal) = gbuffer(&cam);
    let bandwidth = vec![[25.0f32, 25.0]; (W * H) as usize];
    let v = value();
    let base: BTreeMap<&str, BufferData> = [
        ("value", BufferData::Vec3(v.clone())),
        ("position", BufferData::Vec4(position.clone())),
        ("normal", BufferData::Vec4(normal.clone())),
        ("bandwidth", BufferData::Vec2(bandwidth.clone())),
    ]
    .into_iter()
    .collect();
    let x = run(Arc::new(EnvironmentFilter), &scene, &axis_params(0), &base, None);
    let mut hist_in: BTreeMap<&str, BufferData> = base.clone();
    hist_in.remove("value");
    hist_in.insert("previous_value", BufferData::Vec3(v.clone()));
    hist_in.insert("previous_position", BufferData::Vec4(position.clone()));
    hist_in.insert("previous_normal", BufferData::Vec4(normal.clone()));
    hist_in.insert("previous_bandwidth", BufferData::Vec2(bandwidth.clone()));
    let hp: Vec<(&str, ParamValue)> = vec![
        ("axis", ParamValue::Int(0)),
        ("max_radius", ParamValue::Int(15)),
        ("normal_cos", ParamValue::Float(0.98)),
        ("max_motion", ParamValue::Int(32)),
    ];
    let hist = run(Arc::new(EnvironmentHistory), &scene, &hp, &hist_in, None);
    let (xs, hs) = (<[f32; 3] as Texel>::slice(&x).unwrap(), <[f32; 4] as Texel>::slice(&hist).unwrap());
    for i in 0..(W * H) as usize {
        assert_eq!(hs[i][3], 1.0, "pixel {i} found itself in the previous frame");
        for c in 0..3 {
            assert!((hs[i][c] - xs[i][c]).abs() < 1e-5, "pixel {i}: {:?} vs {:?}", hs[i], xs[i]);
        }
    }
    let mut y_in = base.clone();
    y_in.insert("value", x.clone());
    let y_plain = run(Arc::new(EnvironmentFilter), &scene, &axis_params(1), &y_in, None);
    y_in.insert("previous", hist.clone());
    let y_temporal = run(Arc::new(EnvironmentFilter), &scene, &axis_params(1), &y_in, None);
    let (a, b) = (<[f32; 3] as Texel>::slice(&y_plain).unwrap(), <[f32; 3] as Texel>::slice(&y_temporal).unwrap());
    for i in 0..a.len() {
        for c in 0..3 {
            assert!((a[i][c] - b[i][c]).abs() < 1e-5);
        }
    }
    // No previous camera (a first frame): nothing valid.
    scene.previous_camera = None;
    let none = run(Arc::new(EnvironmentHistory), &scene, &hp, &hist_in, None);
    assert!(<[f32; 4] as Texel>::slice(&none).unwrap().iter().all(|p| p[3] == 0.0));
}

#[test]
fn a_moving_camera_reprojects_to_the_same_world_points() {
    // The previous camera sat 0.3 m to the left: the previous frame's pixel for a current position is
    // shifted; with a previous value that is a function of world x only, the history pass must return
    // that function at the current position (no ghost of the old image grid).
    let (mut scene, cam) = plane_scene();
    let prev = Camera {
        position: cam.position - glam::Vec3::new(0.3, 0.0, 0.0),
        look_at: cam.look_at - glam::Vec3::new(0.3, 0.0, 0.0),
        ..cam
    };
    scene.previous_camera = Some(prev);
    let (position, normal) = gbuffer(&cam);
    let (prev_position, prev_normal) = gbuffer(&prev);
    let f = |x: f32| 0.5 + 0.25 * x;
    let prev_value: Vec<[f32; 3]> = prev_position.iter().map(|p| [f(p[0]); 3]).collect();
    let bandwidth = vec![[40.0f32, 40.0]; (W * H) as usize];
    let inputs: BTreeMap<&str, BufferData> = [
        ("position", BufferData::Vec4(position.clone())),
        ("normal", BufferData::Vec4(normal)),
        ("bandwidth", BufferData::Vec2(bandwidth.clone())),
        ("previous_value", BufferData::Vec3(prev_value)),
        ("previous_position", BufferData::Vec4(prev_position)),
        ("previous_normal", BufferData::Vec4(prev_normal)),
        ("previous_bandwidth", BufferData::Vec2(bandwidth)),
    ]
    .into_iter()
    .collect();
    let hp: Vec<(&str, ParamValue)> = vec![
        ("axis", ParamValue::Int(0)),
        ("max_radius", ParamValue::Int(15)),
        ("normal_cos", ParamValue::Float(0.98)),
        ("max_motion", ParamValue::Int(32)),
    ];
    let hist = run(Arc::new(EnvironmentHistory), &scene, &hp, &inputs, None);
    let hs = <[f32; 4] as Texel>::slice(&hist).unwrap();
    let mut valid = 0;
    for (i, h) in hs.iter().enumerate() {
        if h[3] > 0.0 {
            valid += 1;
            // A linear function is kept by a symmetric filter; near the previous frame's edge the
            // window is one-sided, so allow a pixel's worth there.
            assert!((h[0] - f(position[i][0])).abs() < 0.02, "pixel {i}: {} vs {}", h[0], f(position[i][0]));
        }
    }
    // The strip the previous frame did not see (on the right) has no history.
    assert!(valid > (W * H) as usize * 3 / 4 && valid < (W * H) as usize, "{valid}");
    // The points moved 0.3 m × 30 px / (2 · 3 m · tan 20°) ≈ 4.1 px: under `max_motion` 3 no pixel
    // keeps its history, under 5 the same pixels as under 32.
    let count_valid = |max_motion: i64| {
        let mut hp = hp.clone();
        hp.retain(|(k, _)| *k != "max_motion");
        hp.push(("max_motion", ParamValue::Int(max_motion)));
        let h = run(Arc::new(EnvironmentHistory), &scene, &hp, &inputs, None);
        <[f32; 4] as Texel>::slice(&h).unwrap().iter().filter(|h| h[3] > 0.0).count()
    };
    assert_eq!(count_valid(3), 0);
    assert_eq!(count_valid(5), valid);
}

#[test]
fn both_kernels_agree_with_the_gpu() {
    let Some(mut gpu) = gpu_or_skip("both_kernels_agree_with_the_gpu") else { return };
    let (mut scene, cam) = plane_scene();
    // The previous camera 0.1 m right and 0.05 m up (about 1.4 px and 0.7 px at the plane).
    let shift = glam::Vec3::new(0.1, 0.05, 0.0);
    let prev = Camera { position: cam.position + shift, look_at: cam.look_at + shift, ..cam };
    scene.previous_camera = Some(prev);
    let (position, normal) = gbuffer(&cam);
    let (prev_position, prev_normal) = gbuffer(&prev);
    let bandwidth: Vec<[f32; 2]> = (0..W * H).map(|i| [15.0 + (i % 7) as f32, 20.0 + (i % 5) as f32]).collect();
    let v = value();
    let inputs: BTreeMap<&str, BufferData> = [
        ("value", BufferData::Vec3(v.clone())),
        ("position", BufferData::Vec4(position)),
        ("normal", BufferData::Vec4(normal)),
        ("bandwidth", BufferData::Vec2(bandwidth.clone())),
        ("previous_value", BufferData::Vec3(v)),
        ("previous_position", BufferData::Vec4(prev_position)),
        ("previous_normal", BufferData::Vec4(prev_normal)),
        ("previous_bandwidth", BufferData::Vec2(bandwidth)),
    ]
    .into_iter()
    .collect();
    let tol = Tolerance::for_class(KernelClass::Filter);
    let hp: Vec<(&str, ParamValue)> = vec![
        ("axis", ParamValue::Int(0)),
        ("max_radius", ParamValue::Int(15)),
        ("normal_cos", ParamValue::Float(0.98)),
        ("max_motion", ParamValue::Int(32)),
    ];
    let only = |names: &[&str]| -> BTreeMap<&str, BufferData> {
        inputs.iter().filter(|(k, _)| names.contains(k)).map(|(k, v)| (*k, v.clone())).collect()
    };
    let hist_in = only(&[
        "position",
        "normal",
        "bandwidth",
        "previous_value",
        "previous_position",
        "previous_normal",
        "previous_bandwidth",
    ]);
    let (hc, hg) = (
        run(Arc::new(EnvironmentHistory), &scene, &hp, &hist_in, None),
        run(Arc::new(EnvironmentHistory), &scene, &hp, &hist_in, Some(&mut gpu)),
    );
    assert_eq!(compare(&hc, &hg, tol).2, 0, "history pass");
    // Every point moved one pixel to the left (1.4 px from the pixel centre): a motion bound of 0 px
    // cuts all history, on both backends.
    let mut hp1 = hp.clone();
    hp1.retain(|(k, _)| *k != "max_motion");
    hp1.push(("max_motion", ParamValue::Int(0)));
    let (c1, g1) = (
        run(Arc::new(EnvironmentHistory), &scene, &hp1, &hist_in, None),
        run(Arc::new(EnvironmentHistory), &scene, &hp1, &hist_in, Some(&mut gpu)),
    );
    assert_eq!(compare(&c1, &g1, tol).2, 0, "history pass, max_motion 0");
    let valid = |b: &BufferData| <[f32; 4] as Texel>::slice(b).unwrap().iter().filter(|h| h[3] > 0.0).count();
    println!("history pixels: {} under max_motion 32, {} on the GPU under 0", valid(&hc), valid(&g1));
    assert!(valid(&hc) > 0 && valid(&g1) == 0, "{} vs {}", valid(&hc), valid(&g1));
    for axis in [0, 1] {
        let mut f_in = only(&["value", "position", "normal", "bandwidth"]);
        if axis == 1 {
            f_in.insert("previous", hc.clone());
        }
        let (c, g) = (
            run(Arc::new(EnvironmentFilter), &scene, &axis_params(axis), &f_in, None),
            run(Arc::new(EnvironmentFilter), &scene, &axis_params(axis), &f_in, Some(&mut gpu)),
        );
        assert_eq!(compare(&c, &g, tol).2, 0, "axis {axis}");
    }
}

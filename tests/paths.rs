//! The path sampler (issue 11 §1–2): thin-lens camera and Owen-scrambled Sobol' sequences identical
//! on both backends, and `paths.trace` (CPU-vs-GPU parity, pinhole equivalence with
//! `primary.gbuffer`, agreement with `direct.light`, progressive continuation, ray counters).

mod common;
use common::gpu_or_skip;
use std::collections::BTreeMap;
use std::sync::Arc;

use glam::Vec2;
use wedge::backends::gpu::GpuBackend;
use wedge::backends::{sobol, BackendError, Binding, BufferData, Kernel, KernelClass, KernelCtx, Uniforms, WgslSource};
use wedge::graph::Format;
use wedge::scene::{Camera, LensShape, Scene};

fn builtin(name: &str) -> Scene {
    wedge::scene::load(&wedge::scene::SceneSource::Builtin(name.into())).unwrap()
}

/// Writes Sobol' samples of several (stream, pair, index) per pixel on both backends.
struct SobolProbe;

const SOBOL_PROBE_WGSL: &str = r#"
#include "common.wgsl"
#include "sobol.wgsl"
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let p = pixel_id(gid);
    a_put(i, sample2(frame.seed, p, p % 7u, PAIR_LENS, p % 300u));
    b_put(i, sample2(frame.seed, p / 3u, 1u, p % 6u, p * 2654435761u));
    key_put(i, sequence_key(frame.seed, p, 5u, PAIR_LIGHT));
}
"#;

impl Kernel for SobolProbe {
    fn name(&self) -> &'static str {
        "test.sobol_probe"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![Binding::write("a", Format::Vec2), Binding::write("b", Format::Vec2), Binding::write("key", Format::U32)]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (seed, n) = (ctx.seed, ctx.pixels() as u32);
        ctx.put("a", (0..n).map(|p| sobol::sample2(seed, p, p % 7, sobol::pair::LENS, p % 300)).collect::<Vec<_>>())?;
        ctx.put(
            "b",
            (0..n).map(|p| sobol::sample2(seed, p / 3, 1, p % 6, p.wrapping_mul(2654435761))).collect::<Vec<_>>(),
        )?;
        ctx.put("key", (0..n).map(|p| sobol::sequence_key(seed, p, 5, sobol::pair::LIGHT)).collect::<Vec<_>>())
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(SOBOL_PROBE_WGSL, |_| Ok(Uniforms::new())))
    }
}

#[test]
fn sobol_wgsl_is_bit_exact() {
    let Some(mut gpu) = gpu_or_skip("sobol_wgsl_is_bit_exact") else { return };
    let scene = builtin("grids");
    let (w, h, seed) = (128u32, 96u32, 4242u32);
    let gpu_out = gpu.run_kernel(Arc::new(SobolProbe), &scene, w, h, seed, BTreeMap::new(), &BTreeMap::new()).unwrap();
    let (BufferData::Vec2(a), BufferData::Vec2(b), BufferData::U32(k)) =
        (&gpu_out["a"], &gpu_out["b"], &gpu_out["key"])
    else {
        panic!("formats")
    };
    let mut bad = 0;
    for p in 0..w * h {
        let i = p as usize;
        let ea = sobol::sample2(seed, p, p % 7, sobol::pair::LENS, p % 300);
        let eb = sobol::sample2(seed, p / 3, 1, p % 6, p.wrapping_mul(2654435761));
        bad += (a[i][0].to_bits() != ea[0].to_bits() || a[i][1].to_bits() != ea[1].to_bits()) as usize;
        bad += (b[i][0].to_bits() != eb[0].to_bits() || b[i][1].to_bits() != eb[1].to_bits()) as usize;
        bad += (k[i] != sobol::sequence_key(seed, p, 5, sobol::pair::LIGHT)) as usize;
    }
    println!("sobol mismatches: {bad} of {}", 3 * w * h);
    assert_eq!(bad, 0);
}

/// Camera rays for a grid of image and lens samples on both backends.
struct CameraProbe;

const CAMERA_PROBE_WGSL: &str = r#"
#include "common.wgsl"
#include "camera.wgsl"
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let xy = pixel_xy(gid);
    let c = CameraModel(params.position, params.right, params.up, params.forward, params.tan_half, params.aperture,
        params.focus_distance, params.gaussian);
    let lens = (vec2<f32>(f32(xy.x % 8u), f32(xy.y % 8u)) + 0.5) / 8.0;
    let r = camera_ray(c, vec2<f32>(f32(xy.x) + 0.25, f32(xy.y) + 0.75), lens);
    origin_put(i, r.origin);
    dir_put(i, r.dir);
    weight_put(i, vec2<f32>(r.weight, coc_pixels(c, 0.5 + f32(xy.x))));
}
"#;

fn camera_uniforms(cam: &Camera, shape: LensShape) -> Uniforms {
    let (right, up, forward) = cam.basis();
    Uniforms::new()
        .vec3("position", cam.position.to_array())
        .vec3("right", right.to_array())
        .vec3("up", up.to_array())
        .vec3("forward", forward.to_array())
        .f32("tan_half", (cam.vfov_deg.to_radians() * 0.5).tan())
        .f32("aperture", cam.aperture_radius)
        .f32("focus_distance", cam.effective_focus_distance())
        .u32("gaussian", (shape == LensShape::Gaussian) as u32)
}

impl Kernel for CameraProbe {
    fn name(&self) -> &'static str {
        "test.camera_probe"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::write("origin", Format::Vec3),
            Binding::write("dir", Format::Vec3),
            Binding::write("weight", Format::Vec2),
        ]
    }
    fn run_cpu(&self, _ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        unreachable!("the test compares against Camera::ray directly")
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(CAMERA_PROBE_WGSL, |ctx| {
            let shape = LensShape::parse(ctx.str_param("lens")?).unwrap();
            Ok(camera_uniforms(&ctx.scene.camera, shape))
        }))
    }
}

#[test]
fn thin_lens_rays_agree_on_both_backends() {
    let Some(mut gpu) = gpu_or_skip("thin_lens_rays_agree_on_both_backends") else { return };
    let (w, h) = (48u32, 40u32);
    for (aperture, shape) in [(0.0, LensShape::Disk), (0.2, LensShape::Disk), (0.35, LensShape::Gaussian)] {
        let mut scene = builtin("grids");
        scene.camera.aperture_radius = aperture;
        scene.camera.focus_distance = 3.5;
        let name = if shape == LensShape::Gaussian { "gaussian" } else { "disk" };
        let params = BTreeMap::from([("lens".to_string(), wedge::graph::ParamValue::Str(name.into()))]);
        let out = gpu.run_kernel(Arc::new(CameraProbe), &scene, w, h, 1, params, &BTreeMap::new()).unwrap();
        let (BufferData::Vec3(o), BufferData::Vec3(d), BufferData::Vec2(wt)) =
            (&out["origin"], &out["dir"], &out["weight"])
        else {
            panic!("formats")
        };
        let mut worst = 0f32;
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let lens = (Vec2::new((x % 8) as f32, (y % 8) as f32) + 0.5) / 8.0;
                let r = scene.camera.ray(Vec2::new(x as f32 + 0.25, y as f32 + 0.75), lens, w, h, shape);
                let coc = scene.camera.coc_pixels(0.5 + x as f32, h);
                for c in 0..3 {
                    worst = worst.max((o[i][c] - r.origin[c]).abs()).max((d[i][c] - r.dir[c]).abs());
                }
                worst = worst.max((wt[i][0] - r.weight).abs()).max((wt[i][1] - coc).abs() / coc.abs().max(1.0));
            }
        }
        println!("aperture {aperture} {name}: worst difference {worst:e}");
        assert!(worst <= 1e-5, "aperture {aperture} {name}: {worst}");
    }
}

#[test]
fn thin_lens_focuses_and_pinhole_ignores_the_lens() {
    let mut cam = builtin("grids").camera;
    let (w, h) = (64, 48);
    let pin = cam.ray(Vec2::new(20.5, 30.5), Vec2::new(0.1, 0.9), w, h, LensShape::Disk);
    assert_eq!(pin.origin, cam.position);
    assert_eq!((pin.weight, pin.lens), (1.0, Vec2::ZERO));
    assert_eq!(cam.coc_pixels(2.0, h), 0.0);
    cam.aperture_radius = 0.3;
    cam.focus_distance = 4.0;
    let forward = cam.basis().2;
    // Every lens sample's ray passes through the pinhole ray's point on the focal plane.
    let focal = pin.origin + pin.dir * (4.0 / pin.dir.dot(forward));
    for k in 0..16 {
        let u = Vec2::new((k % 4) as f32 + 0.5, (k / 4) as f32 + 0.5) / 4.0;
        let r = cam.ray(Vec2::new(20.5, 30.5), u, w, h, LensShape::Gaussian);
        assert!((r.origin - cam.position).length() <= 0.3 + 1e-6);
        let t = (focal - r.origin).dot(forward) / r.dir.dot(forward);
        assert!((r.origin + r.dir * t - focal).length() < 1e-5, "lens sample {k}");
        assert!((r.weight - (-0.5 * r.lens.length_squared()).exp()).abs() < 1e-7 && r.weight <= 1.0 && r.weight > 0.6);
    }
    // Eq. 5.2: zero on the focal plane, positive in front, negative behind; a·h/(2 f tan) at z = f/2.
    assert!(cam.coc_pixels(4.0, h).abs() < 1e-6);
    let tan_half = (cam.vfov_deg.to_radians() * 0.5).tan();
    let expect = 0.3 * h as f32 / (2.0 * 4.0 * tan_half);
    assert!((cam.coc_pixels(2.0, h) - expect).abs() < 1e-4 * expect);
    assert!(cam.coc_pixels(8.0, h) < 0.0);
}

// ---- paths.trace ----

use wedge::backends::kernels::direct::DirectLight;
use wedge::backends::kernels::paths::{PathRecord, PathsTrace};
use wedge::backends::kernels::primary::PrimaryGBuffer;
use wedge::backends::lone::LonePass;
use wedge::backends::parity::{compare, Tolerance};
use wedge::backends::{Job, KernelRegistry, RayCounts, Silent, Texel};
use wedge::graph::{BufferId, ParamValue, Pass, Stage};

/// Run one kernel alone with `params` and named inputs, on the CPU or (with `gpu`) the wgpu backend;
/// returns its outputs and the ray counters.
fn run_alone(
    kernel: Arc<dyn Kernel>,
    scene: &Scene,
    (w, h, seed): (u32, u32, u32),
    params: &[(&str, ParamValue)],
    inputs: &BTreeMap<&str, BufferData>,
    gpu: Option<&mut GpuBackend>,
) -> (BTreeMap<String, BufferData>, RayCounts) {
    let params = params.iter().map(|(k, v)| (k.to_string(), v.clone())).collect();
    let lone = LonePass::new(kernel, params, inputs).expect("inputs match the kernel's bindings");
    match gpu {
        Some(g) => lone.run_gpu(g, scene, w, h, seed).expect("gpu pass runs"),
        None => lone.run_cpu(scene, w, h, seed).expect("cpu pass runs"),
    }
}

/// `paths.trace` on the CPU with `params`, its record as `paths.resolve`'s input.
fn traced_record(
    scene: &Scene,
    size: (u32, u32, u32),
    params: &[(&str, ParamValue)],
) -> BTreeMap<&'static str, BufferData> {
    let (rec, _) = run_alone(Arc::new(PathsTrace), scene, size, params, &BTreeMap::new(), None);
    BTreeMap::from([("record", rec["record"].clone())])
}

fn trace_params(count: i64, jitter: bool, lens: &str) -> Vec<(&'static str, ParamValue)> {
    vec![
        ("count", ParamValue::Int(count)),
        ("jitter", ParamValue::Bool(jitter)),
        ("lens", ParamValue::Str(lens.into())),
        ("shadow_per_primary", ParamValue::Int(1)),
        ("indirect_per_primary", ParamValue::Int(1)),
        ("light", ParamValue::Int(0)),
        ("stream", ParamValue::Int(3)),
        ("brdf", ParamValue::Str("phong".into())),
        ("bounces", ParamValue::Int(1)),
        ("sampling", ParamValue::Str("stratified".into())),
    ]
}

fn set(params: &mut [(&'static str, ParamValue)], name: &str, v: ParamValue) {
    params.iter_mut().find(|(k, _)| *k == name).unwrap().1 = v;
}

fn records(b: &BufferData) -> &[PathRecord] {
    <PathRecord as Texel>::slice(b).expect("a PathRecord buffer")
}

/// Pixels whose records differ in any bit.
fn differing(a: &BufferData, b: &BufferData) -> usize {
    assert_eq!((a.len(), a.format()), (b.len(), b.format()));
    let stride = 4 * a.format().components();
    a.as_bytes().chunks(stride).zip(b.as_bytes().chunks(stride)).filter(|(x, y)| x != y).count()
}

fn defocused(name: &str, aperture: f32) -> Scene {
    let mut scene = builtin(name);
    scene.camera.aperture_radius = aperture;
    scene.camera.focus_distance = scene.camera.effective_focus_distance() * 0.8;
    scene
}

/// Share of pixels where some field of two record buffers differs beyond the sampling tolerance
/// (per component `|a − b| ≤ 1e-5·|a| + 1e-6`); fields that differ anywhere are printed.
fn share_differing(what: &str, c: &BufferData, g: &BufferData) -> f64 {
    let tol = Tolerance::for_class(KernelClass::Sampling);
    let pixels = c.len();
    let mut bad_pixels = vec![false; pixels];
    for f in wedge::backends::kernels::paths::PATH_RECORD.fields {
        let (a, b) = (c.field(f.name).unwrap(), g.field(f.name).unwrap());
        let (max_abs, _, over, boundary) = compare(&a, &b, tol);
        for (i, bad) in bad_pixels.iter_mut().enumerate() {
            *bad |= (0..a.format().components()).any(|k| {
                let (x, y) = (a.component(i, k), b.component(i, k));
                (x - y).abs() > tol.rel * x.abs() + tol.abs
            });
        }
        if over + boundary > 0 {
            println!("{what}: field {} differs in {over} (+{boundary} off by one) pixels, max abs {max_abs:e}", f.name);
        }
    }
    bad_pixels.iter().filter(|&&b| b).count() as f64 / pixels as f64
}

/// CPU vs GPU on built-in scenes, field by field, as the other sampling passes are compared: the
/// share of pixels over the per-component tolerance must stay small (grazing rays).
/// Through the pixel centre of a pinhole camera the camera ray cannot vary: both backends trace it
/// once per pixel and pass and count it once, also when the GPU splits the pass into chunks (40 paths
/// here, chunks of 16 on a software adapter), and the records still agree.
#[test]
fn a_fixed_camera_ray_is_traced_and_counted_once_per_pixel() {
    let Some(mut gpu) = gpu_or_skip("a_fixed_camera_ray_is_traced_and_counted_once_per_pixel") else { return };
    let size = (24u32, 18u32, 5u32);
    let scene = defocused("grids", 0.0);
    let p = trace_params(40, false, "disk");
    let (c, c_rays) = run_alone(Arc::new(PathsTrace), &scene, size, &p, &BTreeMap::new(), None);
    let (g, g_rays) = run_alone(Arc::new(PathsTrace), &scene, size, &p, &BTreeMap::new(), Some(&mut gpu));
    let pixels = u64::from(size.0 * size.1);
    assert_eq!(c_rays.primary_rays, pixels, "one camera ray per pixel on the CPU");
    assert_eq!(g_rays.primary_rays, pixels, "one camera ray per pixel on the GPU");
    assert!(records(&c["record"]).iter().all(|r| r.paths == 40), "every pixel still takes 40 paths");
    assert!(share_differing("grids", &c["record"], &g["record"]) <= 0.02);
}

#[test]
fn paths_trace_cpu_gpu_parity() {
    let Some(mut gpu) = gpu_or_skip("paths_trace_cpu_gpu_parity") else { return };
    let size = (40u32, 30u32, 9u32);
    for (scene_name, lens, sampling) in
        [("grids", "disk", "stratified"), ("cornell", "gaussian", "stratified"), ("curved", "disk", "independent")]
    {
        let scene = defocused(scene_name, 0.08);
        let mut p = trace_params(6, true, lens);
        set(&mut p, "sampling", ParamValue::Str(sampling.into()));
        set(&mut p, "shadow_per_primary", ParamValue::Int(2));
        let (c, c_rays) = run_alone(Arc::new(PathsTrace), &scene, size, &p, &BTreeMap::new(), None);
        let (g, g_rays) = run_alone(Arc::new(PathsTrace), &scene, size, &p, &BTreeMap::new(), Some(&mut gpu));
        let (c, g) = (&c["record"], &g["record"]);
        let share = share_differing(scene_name, c, g);
        println!("{scene_name} ({lens}): {:.2}% of pixels differ; rays cpu {c_rays:?} gpu {g_rays:?}", share * 100.0);
        assert!(share <= 0.02, "{scene_name}: {share}");
        let rel = |a: u64, b: u64| (a as f64 - b as f64).abs() / (a.max(1) as f64);
        assert_eq!(c_rays.primary_rays, g_rays.primary_rays);
        assert!(
            rel(c_rays.shadow_rays, g_rays.shadow_rays) < 0.01
                && rel(c_rays.secondary_rays, g_rays.secondary_rays) < 0.01
        );
        assert_eq!(g_rays.cut_loops, 0);
        if scene_name == "cornell" {
            let glossy: u64 = records(c).iter().map(|r| r.glossy_samples as u64).sum();
            assert!(glossy > 100, "the glossy component is exercised: {glossy} samples");
        }
    }
}

/// The same on the GL backend (few storage buffers per stage; naga's GLSL) and under WebGPU's
/// default limits (8 storage buffers: paths.resolve's 18 bindings run packed).
#[test]
fn paths_kernels_run_on_gl_and_webgpu_limits() {
    use wedge::backends::gpu::{Backends, LimitsChoice};
    use wedge::backends::kernels::paths::PathsResolve;
    let scene = defocused("cornell", 0.1);
    let size = (24u32, 18u32, 2u32);
    let p = trace_params(4, true, "disk");
    let (c, _) = run_alone(Arc::new(PathsTrace), &scene, size, &p, &BTreeMap::new(), None);
    let inputs = BTreeMap::from([("record", c["record"].clone())]);
    let (cr, _) = run_alone(Arc::new(PathsResolve), &scene, size, &[], &inputs, None);
    let devices =
        [("GL", Some(Backends::GL), LimitsChoice::Adapter), ("WebGPU limits", None, LimitsChoice::WebGpuDefault)];
    for (what, backends, limits) in devices {
        let mut gpu = match GpuBackend::open_on(backends, limits) {
            Ok(g) => g,
            Err(e) => {
                assert!(!std::env::var("CI").is_ok_and(|v| v == "true"), "CI=true and no {what} device: {e}");
                eprintln!("{what}: SKIPPED — no device: {e}");
                continue;
            }
        };
        let (g, _) = run_alone(Arc::new(PathsTrace), &scene, size, &p, &BTreeMap::new(), Some(&mut gpu));
        let share = share_differing(what, &c["record"], &g["record"]);
        let (gr, _) = run_alone(Arc::new(PathsResolve), &scene, size, &[], &inputs, Some(&mut gpu));
        println!(
            "{what} ({}): paths.trace records differing from the CPU's beyond round-off: {:.2}%",
            gpu.adapter_description(),
            share * 100.0
        );
        assert!(share <= 0.02, "{what}: {share}");
        for (name, a) in &cr {
            let (_, _, over, _) = compare(a, &gr[name], Tolerance::for_class(KernelClass::Compose));
            assert_eq!(over, 0, "{what}: paths.resolve `{name}`");
        }
    }
}

/// With a pinhole and one path through the pixel centre, the primary hits are primary.gbuffer's.
#[test]
fn pinhole_single_path_hits_equal_the_gbuffer() {
    let scene = builtin("cornell");
    let size = (32u32, 24u32, 5u32);
    let (rec, _) =
        run_alone(Arc::new(PathsTrace), &scene, size, &trace_params(1, false, "disk"), &BTreeMap::new(), None);
    let (gb, _) = run_alone(Arc::new(PrimaryGBuffer), &scene, size, &[], &BTreeMap::new(), None);
    let (BufferData::Vec4(pos), BufferData::Vec4(nrm), BufferData::Vec3(alb)) =
        (&gb["position"], &gb["normal"], &gb["albedo"])
    else {
        panic!("formats")
    };
    let mut hits = 0;
    for (i, r) in records(&rec["record"]).iter().enumerate() {
        assert_eq!(r.paths, 1);
        assert_eq!(r.hits == 1, pos[i][3] != 0.0, "pixel {i}: hit or miss differs");
        if r.hits == 1 {
            hits += 1;
            assert_eq!(r.position, [pos[i][0], pos[i][1], pos[i][2]], "pixel {i}");
            assert_eq!(r.normal, [nrm[i][0], nrm[i][1], nrm[i][2]], "pixel {i}");
            assert_eq!(r.object as f32, pos[i][3], "pixel {i}");
            assert_eq!(r.k_diffuse, alb[i], "pixel {i}");
            assert_eq!((r.weight, r.r_min, r.r_max), (1.0, 0.0, 0.0));
        }
    }
    assert!(hits > 500, "{hits}");
}

/// Many pinhole paths through the centre: the mean direct irradiance E is direct.light's estimate
/// with the centre-of-light form factor at the same point, within noise.
#[test]
fn mean_direct_matches_direct_light() {
    let scene = builtin("grids");
    let size = (32u32, 24u32, 11u32);
    let n = 256;
    let (rec, _) =
        run_alone(Arc::new(PathsTrace), &scene, size, &trace_params(n, false, "disk"), &BTreeMap::new(), None);
    let (gb, _) = run_alone(Arc::new(PrimaryGBuffer), &scene, size, &[], &BTreeMap::new(), None);
    let inputs = BTreeMap::from([("position", gb["position"].clone()), ("normal", gb["normal"].clone())]);
    let dl_params = [
        ("light", ParamValue::Int(0)),
        ("count", ParamValue::Int(n)),
        ("sampling", ParamValue::Str("stratified".into())),
        ("form_factor", ParamValue::Str("light_centre".into())),
        ("stream", ParamValue::Int(0)),
    ];
    let (dl, _) = run_alone(Arc::new(DirectLight), &scene, size, &dl_params, &inputs, None);
    let BufferData::Vec4(est) = &dl["estimate"] else { panic!("format") };
    let (mut sum_p, mut sum_d, mut sq, mut px) = (0f64, 0f64, 0f64, 0usize);
    for (i, r) in records(&rec["record"]).iter().enumerate() {
        if r.hits == 0 {
            continue;
        }
        let (_, k, e) = r.direct();
        let (a, b) = (e.x as f64, est[i][0] as f64);
        sum_p += a;
        sum_d += b;
        sq += (a - b).powi(2);
        px += 1;
        // k = k_d for this diffuse scene, and L = k·E per path with one point: L = k·E exactly.
        assert!((r.direct().0 - k * e).abs().max_element() <= 1e-5 * (1.0 + (k * e).max_element()));
    }
    let rel = (sum_p - sum_d).abs() / sum_d;
    let rms = (sq / px as f64).sqrt() / (sum_d / px as f64);
    println!("direct E: paths mean {:.5}, direct.light mean {:.5}, relative difference {rel:.2e}, per-pixel rms/mean {rms:.3}", sum_p / px as f64, sum_d / px as f64);
    assert!(rel < 0.01 && rms < 0.05, "{rel} {rms}");
}

/// Per-pass totals of `n` samples per path for every pixel: `shadow_total` = paths × (1 + i mod 3),
/// `diffuse_total` = paths × (1 + i mod 2).
fn per_path_totals(size: (u32, u32, u32), paths: u32) -> BTreeMap<&'static str, BufferData> {
    let pixels = size.0 * size.1;
    BTreeMap::from([
        ("shadow_total", BufferData::U32((0..pixels).map(|i| paths * (1 + i % 3)).collect())),
        ("diffuse_total", BufferData::U32((0..pixels).map(|i| paths * (1 + i % 2)).collect())),
    ])
}

/// 16 paths, then 16 more continuing the record, equal 32 in one pass bit for bit (CPU; and GPU,
/// also in chunks of 5 paths per dispatch). Counters and record counts agree.
#[test]
fn progressive_continuation_is_exact_and_counts_match() {
    let scene = defocused("cornell", 0.1);
    let size = (24u32, 18u32, 21u32);
    let mut p16 = trace_params(16, true, "disk");
    let shadow: Vec<u32> = (0..size.0 * size.1).map(|i| 1 + i % 3).collect();
    let indirect: Vec<u32> = (0..size.0 * size.1).map(|i| 1 + i % 2).collect();
    let (per, per32) = (per_path_totals(size, 16), per_path_totals(size, 32));
    let (first, r1) = run_alone(Arc::new(PathsTrace), &scene, size, &p16, &per, None);
    let mut cont = per.clone();
    cont.insert("previous", first["record"].clone());
    let (second, r2) = run_alone(Arc::new(PathsTrace), &scene, size, &p16, &cont, None);
    set(&mut p16, "count", ParamValue::Int(32));
    let (whole, rw) = run_alone(Arc::new(PathsTrace), &scene, size, &p16, &per32, None);
    assert_eq!(differing(&second["record"], &whole["record"]), 0, "16 + 16 continued differs from 32");
    let recs = records(&whole["record"]);
    let total = |f: fn(&PathRecord) -> u32| recs.iter().map(|r| f(r) as u64).sum::<u64>();
    let mut sum = r1;
    sum.add(&r2);
    assert_eq!(sum, rw, "counters of the two passes add up to the single pass");
    assert_eq!(rw.primary_rays, total(|r| r.paths));
    assert_eq!(rw.primary_rays, 32 * (size.0 * size.1) as u64);
    assert_eq!(rw.shadow_rays, total(|r| r.shadow) + total(|r| r.bounce_shadow));
    assert_eq!(rw.secondary_rays, total(|r| r.indirect_rays));
    let (s, q) = (&shadow, &indirect);
    for (i, r) in recs.iter().enumerate() {
        assert_eq!(r.shadow, r.hits * s[i], "pixel {i}: shadow rays per primary hit");
        assert_eq!(r.diffuse_samples, r.hits * q[i], "pixel {i}: diffuse samples per primary hit");
        assert!(r.indirect_rays <= r.diffuse_samples + r.glossy_samples);
        assert_eq!(r.non_finite, 0);
    }
    println!("rays for 32 paths: {rw:?}");
    let Some(mut gpu) = gpu_or_skip("progressive_continuation_is_exact_and_counts_match") else { return };
    set(&mut p16, "count", ParamValue::Int(16));
    let (g1, _) = run_alone(Arc::new(PathsTrace), &scene, size, &p16, &per, Some(&mut gpu));
    let mut gcont = per.clone();
    gcont.insert("previous", g1["record"].clone());
    let (g2, _) = run_alone(Arc::new(PathsTrace), &scene, size, &p16, &gcont, Some(&mut gpu));
    set(&mut p16, "count", ParamValue::Int(32));
    let (gw, _) = run_alone(Arc::new(PathsTrace), &scene, size, &p16, &per32, Some(&mut gpu));
    assert_eq!(differing(&g2["record"], &gw["record"]), 0, "GPU: 16 + 16 continued differs from 32");
    gpu.set_samples_per_dispatch(5);
    let (gc, gc_rays) = run_alone(Arc::new(PathsTrace), &scene, size, &p16, &per32, Some(&mut gpu));
    assert_eq!(differing(&gc["record"], &gw["record"]), 0, "GPU: chunks of 5 paths differ from the default");
    assert_eq!(gc_rays.primary_rays, rw.primary_rays);
    // The struct binding packed into one array<u32> with the others, and the image in bands of
    // 5 rows (records continue by absolute pixel id): the same bits.
    gpu.force_packed(true);
    let (gp, _) = run_alone(Arc::new(PathsTrace), &scene, size, &p16, &per32, Some(&mut gpu));
    assert_eq!(differing(&gp["record"], &gw["record"]), 0, "GPU: packed bindings differ from direct ones");
    gpu.force_packed(false);
    gpu.set_binding_limit(5 * size.0 as u64 * 4 * wedge::backends::kernels::paths::PATH_RECORD.words() as u64);
    let (gb, _) = run_alone(Arc::new(PathsTrace), &scene, size, &p16, &per32, Some(&mut gpu));
    assert_eq!(differing(&gb["record"], &gw["record"]), 0, "GPU: bands of 5 rows differ from one dispatch");
}

/// A pass total that does not divide by the paths is split as evenly as it can be (the first
/// `total mod paths` paths carry one more), a total of 0 traces none of that component, and a glossy
/// total apart from the diffuse one is honoured: exact counts on both backends, in GPU chunks too.
/// Through a fixed pinhole ray the record weighs samples, so the means do not depend on the split.
#[test]
fn uneven_totals_are_split_exactly_over_the_paths() {
    let scene = builtin("cornell");
    let size = (20u32, 15u32, 9u32);
    let pixels = size.0 * size.1;
    let params = trace_params(5, false, "disk");
    let totals = |k: u32| -> BTreeMap<&'static str, BufferData> {
        BTreeMap::from([
            ("shadow_total", BufferData::U32((0..pixels).map(|i| (i * k) % 13).collect())),
            ("diffuse_total", BufferData::U32((0..pixels).map(|i| 7 + i % 5).collect())),
            ("glossy_total", BufferData::U32((0..pixels).map(|i| i % 4).collect())),
        ])
    };
    let (out, rays) = run_alone(Arc::new(PathsTrace), &scene, size, &params, &totals(3), None);
    let recs = records(&out["record"]);
    let mut glossy_pixels = 0;
    for (i, r) in recs.iter().enumerate() {
        let i = i as u32;
        if r.hits == 0 {
            continue;
        }
        assert_eq!(r.paths, 5);
        assert_eq!(r.shadow, (i * 3) % 13, "pixel {i}: shadow rays");
        assert_eq!(r.diffuse_samples, 7 + i % 5, "pixel {i}: diffuse samples");
        if r.glossy_samples > 0 {
            glossy_pixels += 1;
            assert_eq!(r.glossy_samples, i % 4, "pixel {i}: glossy samples");
        }
        // Sample weights: each component's weight is its finite samples.
        assert_eq!(r.w_direct, r.shadow as f32);
        assert_eq!(r.w_diffuse, r.diffuse_samples as f32);
        assert_eq!(r.w_glossy, r.glossy_samples as f32);
    }
    assert!(glossy_pixels > 0, "cornell has glossy surfaces in view");
    // The same samples split over 1 path instead of 5: the same sums up to float regrouping.
    let one = trace_params(1, false, "disk");
    let (single, _) = run_alone(Arc::new(PathsTrace), &scene, size, &one, &totals(3), None);
    for (a, b) in recs.iter().zip(records(&single["record"])) {
        assert_eq!((a.shadow, a.diffuse_samples, a.glossy_samples), (b.shadow, b.diffuse_samples, b.glossy_samples));
        let (ea, eb) = (a.direct().2, b.direct().2);
        assert!((ea - eb).abs().max_element() <= 1e-5 * (1.0 + eb.max_element()), "{ea} vs {eb}");
    }
    println!("uneven totals: {rays:?}");
    let Some(mut gpu) = gpu_or_skip("uneven_totals_are_split_exactly_over_the_paths") else { return };
    let (g, grays) = run_alone(Arc::new(PathsTrace), &scene, size, &params, &totals(3), Some(&mut gpu));
    let counts = |r: &PathRecord| (r.paths, r.shadow, r.diffuse_samples, r.glossy_samples);
    let cpu_counts: Vec<_> = recs.iter().map(counts).collect();
    assert_eq!(records(&g["record"]).iter().map(counts).collect::<Vec<_>>(), cpu_counts, "GPU counts");
    assert_eq!(grays.shadow_rays, rays.shadow_rays);
    gpu.set_samples_per_dispatch(2);
    let (gc, _) = run_alone(Arc::new(PathsTrace), &scene, size, &params, &totals(3), Some(&mut gpu));
    assert_eq!(differing(&gc["record"], &g["record"]), 0, "GPU: chunks of 2 paths differ from one dispatch");
}

/// `paths.resolve` agrees on both backends to round-off, and for one pinhole path through the
/// centre its position and normal (with the footprint) are primary.gbuffer's.
#[test]
fn resolve_gives_means_in_gbuffer_conventions() {
    use wedge::backends::kernels::paths::PathsResolve;
    let scene = builtin("cornell");
    let size = (32u32, 24u32, 5u32);
    let inputs = traced_record(&scene, size, &trace_params(1, false, "disk"));
    let (res, _) = run_alone(Arc::new(PathsResolve), &scene, size, &[], &inputs, None);
    let (gb, _) = run_alone(Arc::new(PrimaryGBuffer), &scene, size, &[], &BTreeMap::new(), None);
    let (BufferData::Vec4(p), BufferData::Vec4(n)) = (&res["position"], &res["normal"]) else { panic!("formats") };
    let (BufferData::Vec4(gp), BufferData::Vec4(gn)) = (&gb["position"], &gb["normal"]) else { panic!("formats") };
    for i in 0..p.len() {
        assert_eq!(p[i], gp[i], "pixel {i}: position");
        for c in 0..4 {
            assert!(
                (n[i][c] - gn[i][c]).abs() <= 1e-5 * gn[i][c].abs().max(1.0),
                "pixel {i}: normal {:?} vs {:?}",
                n[i],
                gn[i]
            );
        }
    }
    let Some(mut gpu) = gpu_or_skip("resolve_gives_means_in_gbuffer_conventions") else { return };
    let scene = defocused("cornell", 0.1);
    let inputs = traced_record(&scene, size, &trace_params(8, true, "gaussian"));
    let (c, _) = run_alone(Arc::new(PathsResolve), &scene, size, &[], &inputs, None);
    let (g, _) = run_alone(Arc::new(PathsResolve), &scene, size, &[], &inputs, Some(&mut gpu));
    assert_eq!(c.len(), 30); // every output of paths.resolve, `direct`, `direct_unshadowed`, `diffuse`, `glossy` (the filters' Vec4), the velocities and the environment's included
    for (name, a) in &c {
        let (max_abs, max_rel, over, _) = compare(a, &g[name], Tolerance::for_class(KernelClass::Compose));
        println!("paths.resolve `{name}`: max abs {max_abs:e}, max rel {max_rel:e}, over {over}");
        assert_eq!(over, 0, "{name}");
    }
    // The radiance is the sum of the component means and the emission.
    let (BufferData::Vec3(rad), BufferData::Vec3(ld), BufferData::Vec3(lf), BufferData::Vec3(lg), BufferData::Vec3(em)) =
        (&c["radiance"], &c["l_direct"], &c["l_diffuse"], &c["l_glossy"], &c["emission"])
    else {
        panic!("formats")
    };
    for i in 0..rad.len() {
        for k in 0..3 {
            let sum = ld[i][k] + lf[i][k] + lg[i][k] + em[i][k];
            assert!((rad[i][k] - sum).abs() <= 1e-5 * sum.abs().max(1.0));
        }
    }
}

/// A pass binding `paths.trace`'s record to a buffer of another layout with the same struct name
/// is refused before anything runs, naming the field that differs.
#[test]
fn struct_layouts_are_checked_by_fields() {
    use wedge::graph::{Field, FieldType, StructLayout};
    static IMPOSTOR: StructLayout =
        StructLayout { name: "PathRecord", fields: &[Field::new("l_direct", FieldType::Vec4)] };
    let pass = Pass {
        writes: vec![("record".into(), BufferId(0))],
        ..Pass::new("paths", "test", "paths.trace", Stage::Sample)
    };
    let schedule = wedge::graph::Schedule {
        passes: vec![pass],
        buffers: vec![wedge::graph::BufferInfo::new("paths.record", Format::Struct(&IMPOSTOR))],
        lifetimes: vec![Some(wedge::graph::Lifetime { first: 0, last: 0 })],
        slots: vec![Some(0)],
        slot_formats: Vec::new(),
        slot_layers: Vec::new(),
        sink_inputs: Vec::new(),
        history: Vec::new(),
        culled: Vec::new(),
    };
    let mut registry = KernelRegistry::new();
    wedge::backends::register_shared_kernels(&mut registry);
    let e = registry.check_schedule(&schedule).unwrap_err().to_string();
    println!("{e}");
    assert!(
        e.contains("struct PathRecord (4 words)")
            && e.contains("field 0 is `l_direct: vec4<f32>` here but `l_direct: vec3<f32>` there"),
        "{e}"
    );
}

/// The progressive Sobol' sequences against independent sampling of the same dimensions (lens,
/// light, hemisphere): RMSE of 16-path pixel radiance against a 1024-path reference, on a
/// defocused Cornell box with its area light and glossy objects. Measured, and stratification must
/// win (it cannot lose on smooth integrands; the margin is what the thesis's 4×4 strata buy).
#[test]
fn stratified_paths_beat_independent_paths() {
    use wedge::backends::kernels::paths::PathRecord;
    let scene = defocused("cornell", 0.12);
    let size = (32u32, 24u32, 17u32);
    let radiance = |b: &BufferData| records(b).iter().map(PathRecord::radiance).collect::<Vec<_>>();
    let mut p = trace_params(1024, false, "disk");
    set(&mut p, "stream", ParamValue::Int(99));
    let (reference, _) = run_alone(Arc::new(PathsTrace), &scene, size, &p, &BTreeMap::new(), None);
    let reference = radiance(&reference["record"]);
    let mut rmse = BTreeMap::new();
    for sampling in ["stratified", "independent"] {
        let mut total = 0f64;
        // Average the squared error over 4 independent streams (seeds of the estimate).
        for stream in 0..4 {
            let mut p = trace_params(16, false, "disk");
            set(&mut p, "sampling", ParamValue::Str(sampling.into()));
            set(&mut p, "stream", ParamValue::Int(stream));
            let (out, _) = run_alone(Arc::new(PathsTrace), &scene, size, &p, &BTreeMap::new(), None);
            total += radiance(&out["record"])
                .iter()
                .zip(&reference)
                .map(|(a, b)| (*a - *b).length_squared() as f64)
                .sum::<f64>();
        }
        rmse.insert(sampling, (total / (4.0 * reference.len() as f64)).sqrt());
    }
    let ratio = rmse["independent"] / rmse["stratified"];
    println!(
        "16 paths/pixel: RMSE stratified {:.4}, independent {:.4}; MSE ratio {:.2} (rays to equal RMSE, at 1/N convergence)",
        rmse["stratified"],
        rmse["independent"],
        ratio * ratio
    );
    assert!(ratio > 1.1, "stratified {} vs independent {}", rmse["stratified"], rmse["independent"]);
}

/// The parity harness compares a struct output field by field (one row per field, `record.FIELD`),
/// on a two-pass job paths.trace → paths.resolve.
#[test]
fn parity_harness_compares_struct_fields() {
    use wedge::backends::kernels::paths::{PathsResolve, PATH_RECORD};
    use wedge::backends::parity::run_parity;
    let Some(mut gpu) = gpu_or_skip("parity_harness_compares_struct_fields") else { return };
    let scene = defocused("cornell", 0.1);
    let params = trace_params(4, true, "disk").into_iter().map(|(k, v)| (k.to_string(), v)).collect();
    let trace = Pass {
        writes: vec![("record".into(), BufferId(0))],
        params,
        random: true,
        ..Pass::new("paths", "test", "paths.trace", Stage::Sample)
    };
    let resolve = Pass {
        reads: vec![("record".into(), BufferId(0))],
        writes: vec![("radiance".into(), BufferId(1))],
        ..Pass::new("resolve", "test", "paths.resolve", Stage::Sample)
    };
    let schedule = wedge::graph::Schedule {
        passes: vec![trace, resolve],
        buffers: vec![
            wedge::graph::BufferInfo::new("paths.record", Format::Struct(&PATH_RECORD)),
            wedge::graph::BufferInfo::new("resolve.radiance", Format::Vec3),
        ],
        lifetimes: vec![
            Some(wedge::graph::Lifetime { first: 0, last: 1 }),
            Some(wedge::graph::Lifetime { first: 1, last: 1 }),
        ],
        slots: vec![Some(0), Some(1)],
        slot_formats: Vec::new(),
        slot_layers: Vec::new(),
        sink_inputs: Vec::new(),
        history: Vec::new(),
        culled: Vec::new(),
    };
    let mut registry = KernelRegistry::new();
    registry.register(Arc::new(PathsTrace)).register(Arc::new(PathsResolve));
    let job = Job {
        schedule: &schedule,
        scene: &scene,
        kernels: &registry,
        width: 24,
        height: 18,
        seed: 3,
        frame: 0,
        progress: &Silent,
        window: wedge::backends::Window::whole(24, 18),
    };
    let report = run_parity(&job, &mut gpu).unwrap();
    println!("{}", report.table());
    let rows: Vec<&str> = report.rows.iter().map(|r| r.binding.as_str()).collect();
    assert_eq!(rows.len(), PATH_RECORD.fields.len() + 1, "{rows:?}");
    assert!(
        rows.contains(&"record.l_direct") && rows.contains(&"record.non_finite") && rows.contains(&"radiance"),
        "{rows:?}"
    );
    assert!(report.ok());
}

/// `direct_unshadowed` (U, SoftShadows' ratio-estimator denominator) is `direct` (E) with every
/// shadow ray counted as unblocked: U ≥ E everywhere, equal bit for bit where no ray was blocked,
/// and larger where some were.
#[test]
fn unshadowed_direct_is_the_same_samples_without_visibility() {
    use wedge::backends::kernels::paths::PathsResolve;
    let scene = builtin("grids");
    let size = (48u32, 36u32, 5u32);
    let inputs = traced_record(&scene, size, &trace_params(4, true, "disk"));
    let (res, _) = run_alone(Arc::new(PathsResolve), &scene, size, &[], &inputs, None);
    let (BufferData::Vec4(e), BufferData::Vec4(u), BufferData::Vec4(occ)) =
        (&res["direct"], &res["direct_unshadowed"], &res["occlusion"])
    else {
        panic!("formats")
    };
    let (mut equal, mut shadowed) = (0, 0);
    for i in 0..e.len() {
        assert_eq!(e[i][3], u[i][3], "pixel {i}: the same samples");
        for c in 0..3 {
            assert!(e[i][c] <= u[i][c], "pixel {i}: E {:?} > U {:?}", e[i], u[i]);
        }
        if occ[i][3] == 0.0 {
            assert_eq!(e[i], u[i], "pixel {i}: nothing blocked");
            equal += 1;
        } else {
            assert!(e[i][0] < u[i][0], "pixel {i}: {} rays blocked but E = U", occ[i][3]);
            shadowed += 1;
        }
    }
    println!("{equal} pixels with E = U, {shadowed} with blocked rays and E < U");
    assert!(equal > 100 && shadowed > 100);
}

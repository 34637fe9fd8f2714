//! The Ch. 5 kernels one pass at a time: `defocus.rates`, `defocus.flags`, `defocus.compose`
//! (eq. 5.32), `neighbourhood.max3`, `neighbourhood.median3`, `filter.irradiance` (eq. 5.31) and
//! `filter.defocus` (eq. 5.33).
//!
//! - CPU-vs-GPU parity of every kernel on random inputs (the harness's tolerances: float outputs to
//!   round-off on every pixel, integer outputs exact), including non-finite inputs and unbound optional
//!   bindings. Without a wgpu adapter the GPU half prints why it was skipped — except under `CI=true`,
//!   where a missing adapter fails.
//! - Filter properties: a constant image is unchanged; in the consistent mode the filters converge to
//!   the identity as μ grows (the literal eq. 5.29 does not); the `w_j(i) < 0.01` rejection keeps a
//!   sharp region from bleeding into a blurry one; the 10° normal test; a NaN pixel is counted once
//!   and never spread.
//! - Weights and neighbourhood filters against values worked by hand.

mod common;
use common::gpu_or_skip;
use std::collections::BTreeMap;
use std::sync::Arc;

use wedge::backends::gpu::GpuBackend;
use wedge::backends::kernels::filter_window::{
    window_radius, Axis, ScreenRadius, FILTER_SHARPNESS, REJECT_EXPONENT, REJECT_RADIUS, REJECT_WEIGHT,
};
use wedge::backends::kernels::neighbourhood3::{max3, median3};
use wedge::backends::lone::LonePass;
use wedge::backends::parity::{compare, Tolerance};
use wedge::backends::{
    BackendError, Binding, BufferData, Kernel, KernelClass, KernelCtx, RayCounts, Uniforms, WgslSource,
};
use wedge::effects::defocus::kernels::filter::defocus_pixel;
use wedge::graph::Format;
use wedge::graph::ParamValue;
use wedge::scene::Scene;

type Params = BTreeMap<String, ParamValue>;
type Buffers = BTreeMap<&'static str, BufferData>;

/// The seed of every lone pass here (these kernels draw no random numbers).
const SEED: u32 = 7;

fn scene() -> Scene {
    wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).expect("builtin scene")
}

/// Run one kernel on the CPU backend: outputs by binding name and the counters.
fn run_cpu(
    scene: &Scene,
    name: &str,
    w: u32,
    h: u32,
    params: &Params,
    inputs: &Buffers,
) -> (BTreeMap<String, BufferData>, RayCounts) {
    run_cpu_with(kernel(name), scene, w, h, params, inputs)
}

fn run_cpu_with(
    k: Arc<dyn Kernel>,
    scene: &Scene,
    w: u32,
    h: u32,
    params: &Params,
    inputs: &Buffers,
) -> (BTreeMap<String, BufferData>, RayCounts) {
    LonePass::new(k, params.clone(), inputs).expect("inputs given").run_cpu(scene, w, h, SEED).expect("cpu pass runs")
}

/// Run one kernel on the wgpu backend.
fn run_gpu(
    gpu: &mut GpuBackend,
    scene: &Scene,
    name: &str,
    w: u32,
    h: u32,
    params: &Params,
    inputs: &Buffers,
) -> (BTreeMap<String, BufferData>, RayCounts) {
    run_gpu_with(gpu, kernel(name), scene, w, h, params, inputs)
}

fn run_gpu_with(
    gpu: &mut GpuBackend,
    k: Arc<dyn Kernel>,
    scene: &Scene,
    w: u32,
    h: u32,
    params: &Params,
    inputs: &Buffers,
) -> (BTreeMap<String, BufferData>, RayCounts) {
    LonePass::new(k, params.clone(), inputs)
        .expect("inputs given")
        .run_gpu(gpu, scene, w, h, SEED)
        .expect("gpu pass runs")
}

fn kernel(name: &str) -> Arc<dyn Kernel> {
    let (_, kernels) = wedge::effects::builtin();
    kernels.get(name).unwrap_or_else(|| panic!("kernel `{name}` is registered")).clone()
}

fn params(list: &[(&str, ParamValue)]) -> Params {
    list.iter().map(|(k, v)| (k.to_string(), v.clone())).collect()
}

fn float(v: f64) -> ParamValue {
    ParamValue::Float(v)
}

fn int(v: i64) -> ParamValue {
    ParamValue::Int(v)
}

/// splitmix64: deterministic random inputs.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, a: f32, b: f32) -> f32 {
        a + (b - a) * self.unit()
    }
    fn chance(&mut self, p: f32) -> bool {
        self.unit() < p
    }
}

fn f32s(v: Vec<f32>) -> BufferData {
    BufferData::F32(v)
}

fn vec4s(v: Vec<[f32; 4]>) -> BufferData {
    BufferData::Vec4(v)
}

fn vec3s(v: Vec<[f32; 3]>) -> BufferData {
    BufferData::Vec3(v)
}

fn vec3_of(b: &BufferData) -> &[[f32; 3]] {
    match b {
        BufferData::Vec3(v) => v,
        other => panic!("expected vec3, got {}", other.format()),
    }
}

fn vec4_of(b: &BufferData) -> &[[f32; 4]] {
    match b {
        BufferData::Vec4(v) => v,
        other => panic!("expected vec4, got {}", other.format()),
    }
}

fn f32_of(b: &BufferData) -> &[f32] {
    match b {
        BufferData::F32(v) => v,
        other => panic!("expected f32, got {}", other.format()),
    }
}

fn u32_of(b: &BufferData) -> &[u32] {
    match b {
        BufferData::U32(v) => v,
        other => panic!("expected u32, got {}", other.format()),
    }
}

/// Compare every output of one pass on both backends; returns the mismatches as text.
fn parity(
    gpu: &mut GpuBackend,
    scene: &Scene,
    name: &str,
    w: u32,
    h: u32,
    p: &Params,
    inputs: &Buffers,
) -> Vec<String> {
    parity_with(gpu, kernel(name), scene, w, h, p, inputs)
}

fn parity_with(
    gpu: &mut GpuBackend,
    k: Arc<dyn Kernel>,
    scene: &Scene,
    w: u32,
    h: u32,
    p: &Params,
    inputs: &Buffers,
) -> Vec<String> {
    let name = k.name();
    let (cpu_out, cpu_rays) = run_cpu_with(k.clone(), scene, w, h, p, inputs);
    let (gpu_out, gpu_rays) = run_gpu_with(gpu, k.clone(), scene, w, h, p, inputs);
    let class = k.class();
    let tol = Tolerance::for_class(class);
    let mut bad = Vec::new();
    assert_eq!(cpu_out.keys().collect::<Vec<_>>(), gpu_out.keys().collect::<Vec<_>>(), "{name}: same outputs");
    for (binding, c) in &cpu_out {
        let (max_abs, max_rel, over, boundary) = compare(c, &gpu_out[binding], tol);
        println!(
            "{name:<22} {binding:<20} max abs {max_abs:.3e} max rel {max_rel:.3e} over {over} boundary {boundary}"
        );
        if over > 0 || boundary > 0 {
            bad.push(format!(
                "{name}.{binding}: {over} pixels over tolerance, {boundary} off by one (max abs {max_abs:.3e})"
            ));
        }
    }
    if cpu_rays.non_finite_samples != gpu_rays.non_finite_samples {
        bad.push(format!(
            "{name}: non-finite counts differ: cpu {} gpu {}",
            cpu_rays.non_finite_samples, gpu_rays.non_finite_samples
        ));
    }
    bad
}

const W: u32 = 64;
const H: u32 = 48;
const N: usize = (W * H) as usize;

/// Lens, occlusion and reflector statistics as the path sampler leaves them, with misses, exact
/// focus and non-finite values mixed in.
fn random_stats(rng: &mut Rng) -> Buffers {
    let mut lens = Vec::with_capacity(N);
    let mut occ = Vec::with_capacity(N);
    let mut refl = Vec::with_capacity(N);
    let mut bandlimit = Vec::with_capacity(N);
    let (mut velocity, mut shadow_velocity) = (Vec::with_capacity(N), Vec::with_capacity(N));
    for i in 0..N {
        let r_min = if rng.chance(0.2) { 0.0 } else { rng.range(0.0, 12.0) };
        let r_max = r_min + if rng.chance(0.2) { 0.0 } else { rng.range(0.0, 30.0) };
        let hits = if rng.chance(0.1) { 0.0 } else { 16.0 };
        lens.push([r_min, r_max, rng.range(0.5, 20.0), hits]);
        let d1 = rng.range(1.0, 5.0);
        let d2_max = rng.range(0.1, d1);
        let d2_min = rng.range(0.05, d2_max);
        occ.push([d1, d2_min, d2_max, if rng.chance(0.5) { 1.0 } else { 0.0 }]);
        let z_min = rng.range(0.01, 2.0);
        // As indirect.sample's `depth`: z_min, z_max, samples that hit, samples.
        refl.push([
            z_min,
            z_min + rng.range(0.0, 5.0),
            if rng.chance(0.7) { rng.range(1.0, 16.0).floor() } else { 0.0 },
            16.0,
        ]);
        // The environment's Ch. 6 bandwidth (1/m), absent (0) at some pixels.
        bandlimit.push(if rng.chance(0.2) { 0.0 } else { rng.range(0.1, 60.0) });
        // Image velocities (mean, per-axis range), still at some pixels.
        let mut v = || {
            if rng.chance(0.3) {
                [0.0; 4]
            } else {
                [rng.range(-20.0, 20.0), rng.range(-5.0, 5.0), rng.range(0.0, 8.0), rng.range(0.0, 2.0)]
            }
        };
        velocity.push(v());
        shadow_velocity.push(v());
        if i == 17 {
            lens[i] = [f32::NAN, f32::NAN, 2.0, 16.0];
        }
        if i == 18 {
            lens[i] = [0.0, f32::INFINITY, 2.0, 16.0];
        }
    }
    BTreeMap::from([
        ("lens", vec4s(lens)),
        ("occlusion", vec4s(occ)),
        ("reflectors", vec4s(refl)),
        ("bandlimit", f32s(bandlimit)),
        ("velocity", vec4s(velocity)),
        ("shadow_velocity", vec4s(shadow_velocity)),
    ])
}

fn rate_params(mu: f64, mode: &str, max_primary: i64, max_per_primary: i64) -> Params {
    params(&[
        ("mu", float(mu)),
        ("mode", ParamValue::Str(mode.into())),
        ("omega_pix", float(0.5)),
        ("pixel_scale", float(0.0025)),
        ("light_half_width", float(0.25)),
        ("omega_v", float(2.8)),
        ("max_primary", int(max_primary)),
        ("max_per_primary", int(max_per_primary)),
        ("environment_per_primary", int(4)),
        // Every output is bound in a lone pass: the component ones for the direct component.
        ("component", ParamValue::Str("direct".into())),
    ])
}

/// `rate_params` for each component a rates pass sizes.
fn component_params(mu: f64, mode: &str, max_primary: i64, max_per_primary: i64) -> [Params; 3] {
    ["direct", "indirect", "environment"].map(|c| {
        let mut p = rate_params(mu, mode, max_primary, max_per_primary);
        p.insert("component".into(), ParamValue::Str(c.into()));
        p
    })
}

/// `stats` with a random first-pass factoring flag (`defocus.rates`' `flag`).
fn with_flag(mut stats: Buffers, rng: &mut Rng) -> Buffers {
    stats.insert("flag", BufferData::U32((0..N).map(|_| u32::from(rng.chance(0.5))).collect()));
    stats
}

#[test]
fn parity_defocus_rates_and_flags() {
    let Some(mut gpu) = gpu_or_skip("parity_defocus_rates_and_flags") else { return };
    let scene = scene();
    let mut rng = Rng(11);
    let stats = random_stats(&mut rng);
    let stats = with_flag(stats, &mut rng);
    let mut bad = Vec::new();
    for (mu, mode, cap_p, cap_s) in
        [(1.0, "literal", 64, 64), (2.5, "consistent", 4096, 4096), (0.3, "consistent", 16, 256)]
    {
        for p in component_params(mu, mode, cap_p, cap_s) {
            bad.extend(parity(&mut gpu, &scene, "defocus.rates", W, H, &p, &stats));
        }
    }
    // The screen filter's two scales: `screen_scale_factored` where the flag is set.
    let mut scaled = rate_params(1.0, "consistent", 64, 64);
    scaled.insert("screen_scale".into(), float(0.85));
    scaled.insert("screen_scale_factored".into(), float(0.7));
    bad.extend(parity(&mut gpu, &scene, "defocus.rates", W, H, &scaled, &stats));
    // A moving pixel's cap (`max_primary_moving`): the still cap 16 times 1 + |v| Ω per side, up to 256.
    let mut moving = rate_params(1.0, "consistent", 16, 64);
    moving.insert("max_primary_moving".into(), int(256));
    bad.extend(parity(&mut gpu, &scene, "defocus.rates", W, H, &moving, &stats));
    let (out, _) = run_cpu(&scene, "defocus.rates", W, H, &moving, &stats);
    let above = u32_of(&out["n_primary"]).iter().filter(|&&n| n > 16).count();
    assert!(above > 0 && above < N, "the moving cap binds on some pixels, the still one on others: {above} of {N}");
    // Only the lens statistics bound: no occluders or reflectors anywhere.
    let lens_only: Buffers = BTreeMap::from([("lens", stats["lens"].clone())]);
    bad.extend(parity(&mut gpu, &scene, "defocus.rates", W, H, &rate_params(1.5, "consistent", 64, 64), &lens_only));

    // Flags: L = k E plus noise around the 0.01 threshold, some NaN.
    let (mut l, mut k, mut e) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..N {
        let kk = [rng.unit(), rng.unit(), rng.unit()];
        let ee = [rng.range(0.0, 2.0), rng.range(0.0, 2.0), rng.range(0.0, 2.0)];
        let noise = rng.range(0.0, 0.02);
        let mut ll = [kk[0] * ee[0] + noise, kk[1] * ee[1], kk[2] * ee[2]];
        if i % 97 == 0 {
            ll[1] = f32::NAN;
        }
        l.push(ll);
        k.push(kk);
        e.push(ee);
    }
    let flags_in: Buffers = BTreeMap::from([("radiance", vec3s(l)), ("texture", vec3s(k)), ("irradiance", vec3s(e))]);
    bad.extend(parity(&mut gpu, &scene, "defocus.flags", W, H, &params(&[("threshold", float(0.01))]), &flags_in));
    let (out, _) = run_cpu(&scene, "defocus.flags", W, H, &params(&[("threshold", float(0.01))]), &flags_in);
    let ones = u32_of(&out["flag"]).iter().filter(|f| **f == 1).count();
    assert!(ones > N / 4 && ones < 3 * N / 4, "both sides of the threshold exercised: {ones} of {N}");
    assert_eq!(u32_of(&out["flag"])[0], 0, "NaN radiance is not separable");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// `defocus.rates`' eq. 5.33 width on the CPU: `screen_scale_factored` times the thesis's where the
/// flag is set, `screen_scale` times it elsewhere; without `screen_scale_factored`, `screen_scale`
/// everywhere.
#[test]
fn the_screen_filter_takes_the_factored_scale_where_the_flag_is_set() {
    let scene = scene();
    let mut rng = Rng(21);
    let stats = with_flag(random_stats(&mut rng), &mut rng);
    let omega = |extra: &[(&str, f64)]| {
        let mut p = rate_params(1.0, "consistent", 64, 64);
        for (n, v) in extra {
            p.insert((*n).into(), float(*v));
        }
        let (out, _) = run_cpu(&scene, "defocus.rates", W, H, &p, &stats);
        f32_of(&out["omega_defocus"]).to_vec()
    };
    let thesis = omega(&[]);
    let both = omega(&[("screen_scale", 0.85), ("screen_scale_factored", 0.7)]);
    let one = omega(&[("screen_scale", 0.85)]);
    let flag = u32_of(&stats["flag"]);
    let (mut set, mut clear) = (0, 0);
    for i in 0..N {
        if !thesis[i].is_finite() {
            continue;
        }
        let factor = if flag[i] != 0 { 0.7 } else { 0.85 };
        assert_eq!(both[i].to_bits(), (factor * thesis[i]).to_bits(), "pixel {i}");
        assert_eq!(one[i].to_bits(), (0.85 * thesis[i]).to_bits(), "pixel {i}");
        if flag[i] != 0 {
            set += 1;
        } else {
            clear += 1;
        }
    }
    assert!(set > N / 4 && clear > N / 4, "both kinds of pixel exercised: {set} set, {clear} clear");
}

/// `defocus.all_factored` on both backends: random flags, a previous result, emission that is 0,
/// -0, positive or NaN.
#[test]
fn parity_defocus_all_factored() {
    let Some(mut gpu) = gpu_or_skip("parity_defocus_all_factored") else { return };
    let scene = scene();
    let mut rng = Rng(22);
    let mut flags =
        || BufferData::U32((0..N).map(|_| u32::from(rng.chance(0.7)) * (1 + rng.next() % 3) as u32).collect());
    let (flag, previous) = (flags(), flags());
    let emission: Vec<[f32; 3]> = (0..N)
        .map(|i| match i % 5 {
            0 => [0.0, 0.0, 0.0],
            1 => [-0.0, 0.0, -0.0],
            2 => [0.0, 0.3, 0.0],
            3 => [f32::NAN, 0.0, 0.0],
            _ => [0.0; 3],
        })
        .collect();
    let mut bad = Vec::new();
    let first: Buffers = BTreeMap::from([("flag", flag.clone()), ("emission", vec3s(emission))]);
    let later: Buffers = BTreeMap::from([("flag", flag), ("previous", previous)]);
    for inputs in [&first, &later] {
        bad.extend(parity(&mut gpu, &scene, "defocus.all_factored", W, H, &Params::new(), inputs));
    }
    let (out, _) = run_cpu(&scene, "defocus.all_factored", W, H, &Params::new(), &first);
    let ones = u32_of(&out["out"]).iter().filter(|v| **v == 1).count();
    assert!(ones > N / 4 && ones < 3 * N / 4, "both results exercised: {ones} of {N}");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn parity_neighbourhood_max3_and_median3() {
    let Some(mut gpu) = gpu_or_skip("parity_neighbourhood_max3_and_median3") else { return };
    let scene = scene();
    let mut rng = Rng(12);
    let mut bad = Vec::new();
    for values in [
        (0..N).map(|_| (rng.next() % 2) as u32).collect::<Vec<_>>(),
        (0..N).map(|_| (rng.next() % 500) as u32).collect(),
    ] {
        let inputs: Buffers = BTreeMap::from([("value", BufferData::U32(values))]);
        for name in ["neighbourhood.max3", "neighbourhood.median3"] {
            bad.extend(parity(&mut gpu, &scene, name, W, H, &Params::new(), &inputs));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// A G-buffer of three surfaces: a plane facing the camera, a slanted plane (normal 30° off), and a
/// strip with no hit; lens-averaged positions in metres with ℓ_p = `ell` per pixel.
fn planes(ell: f32) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<f32>) {
    let (mut position, mut normal, mut length) = (Vec::new(), Vec::new(), Vec::new());
    let slant = 30f32.to_radians();
    for y in 0..H {
        for x in 0..W {
            let (px, py) = (x as f32 * ell, y as f32 * ell);
            if x < 24 {
                position.push([px, py, 2.0, 1.0]);
                normal.push([0.0, 0.0, 1.0, ell]);
            } else if x < 56 {
                position.push([px, py, 2.0 + (px - 24.0 * ell) * slant.tan(), 1.0]);
                normal.push([-slant.sin(), 0.0, slant.cos(), ell]);
            } else {
                position.push([0.0; 4]);
                normal.push([0.0; 4]);
            }
            length.push(ell);
        }
    }
    (position, normal, length)
}

fn random_widths(rng: &mut Rng) -> Vec<f32> {
    (0..N)
        .map(|i| match i % 50 {
            0 => 0.0,
            1 => f32::NAN,
            2 => 2.0,
            _ => {
                if rng.chance(0.3) {
                    0.5
                } else {
                    rng.range(0.02, 0.5)
                }
            }
        })
        .collect()
}

fn random_image(rng: &mut Rng, nan_every: usize) -> Vec<[f32; 3]> {
    (0..N)
        .map(|i| {
            if nan_every > 0 && i % nan_every == 5 {
                [f32::NAN, 0.0, 0.0]
            } else {
                [rng.unit(), rng.unit(), rng.unit()]
            }
        })
        .collect()
}

fn irradiance_params(max_radius: i64) -> Params {
    params(&[("max_radius", int(max_radius)), ("normal_cos", float(10f64.to_radians().cos()))])
}

#[test]
fn parity_irradiance_and_defocus_filters() {
    let Some(mut gpu) = gpu_or_skip("parity_irradiance_and_defocus_filters") else { return };
    let scene = scene();
    let mut rng = Rng(13);
    let (position, normal, length) = planes(0.01);
    let mut bad = Vec::new();
    for max_radius in [16, 5] {
        let value = random_image(&mut rng, 211);
        let omega = random_widths(&mut rng);
        let irr: Buffers = BTreeMap::from([
            ("value", vec3s(value.clone())),
            ("position", vec4s(position.clone())),
            ("normal", vec4s(normal.clone())),
            ("omega", f32s(omega.clone())),
            ("pixel_length", f32s(length.clone())),
        ]);
        let def: Buffers = BTreeMap::from([("value", vec3s(value)), ("omega", f32s(omega))]);
        for axis in [-1, 0, 1] {
            let mut p = irradiance_params(max_radius);
            p.insert("axis".into(), int(axis));
            bad.extend(parity(&mut gpu, &scene, "filter.irradiance", W, H, &p, &irr));
            let p = params(&[("max_radius", int(max_radius)), ("axis", int(axis))]);
            bad.extend(parity(&mut gpu, &scene, "filter.defocus", W, H, &p, &def));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The risk-based width's three passes (`effects/src/defocus/kernels/risk.rs`) on random images and
/// widths — a wide width that is wider, close or narrower, pass-through and NaN widths, NaN values;
/// noisy values on the right half, none on the left: the terms within float tolerance, the choices
/// and the selected image exact; both choices taken.
#[test]
fn parity_defocus_risk() {
    let Some(mut gpu) = gpu_or_skip("parity_defocus_risk") else { return };
    let scene = scene();
    let mut rng = Rng(31);
    let narrow = random_image(&mut rng, 0);
    let jitter = |rng: &mut Rng, v: &[f32; 3], a: f32| v.map(|c| c + a * (rng.unit() - 0.5));
    let wide: Vec<[f32; 3]> = narrow.iter().map(|v| jitter(&mut rng, v, 0.02)).collect();
    let value: Vec<[f32; 3]> = (0..N)
        .map(|i| {
            if i % 97 == 5 {
                [f32::NAN; 3]
            } else {
                jitter(&mut rng, &narrow[i], if i % W as usize >= W as usize / 2 { 1.0 } else { 0.0 })
            }
        })
        .collect();
    let omega = random_widths(&mut rng);
    let omega_wide: Vec<f32> = omega.iter().map(|w| w * rng.range(0.4, 1.1)).collect();
    let mut bad = Vec::new();
    let terms_in: Buffers = BTreeMap::from([
        ("value", vec3s(value)),
        ("narrow", vec3s(narrow.clone())),
        ("wide", vec3s(wide.clone())),
        ("omega", f32s(omega)),
        ("omega_wide", f32s(omega_wide)),
    ]);
    for max_radius in [16, 5] {
        let p = params(&[("max_radius", int(max_radius))]);
        bad.extend(parity(&mut gpu, &scene, "defocus.risk_terms", W, H, &p, &terms_in));
    }
    let p = params(&[("max_radius", int(16))]);
    let (terms, _) = run_cpu(&scene, "defocus.risk_terms", W, H, &p, &terms_in);
    let choice_in: Buffers = BTreeMap::from([("bias", terms["bias"].clone()), ("noise", terms["noise"].clone())]);
    bad.extend(parity(&mut gpu, &scene, "defocus.risk_choice", W, H, &Params::new(), &choice_in));
    let (choice, _) = run_cpu(&scene, "defocus.risk_choice", W, H, &Params::new(), &choice_in);
    let wide_taken = u32_of(&choice["choice"]).iter().filter(|c| **c == 1).count();
    assert!(wide_taken > N / 10 && wide_taken < 9 * N / 10, "both choices exercised: {wide_taken} of {N}");
    let select_in: Buffers =
        BTreeMap::from([("choice", choice["choice"].clone()), ("narrow", vec3s(narrow)), ("wide", vec3s(wide))]);
    bad.extend(parity(&mut gpu, &scene, "defocus.risk_select", W, H, &Params::new(), &select_in));
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Every kernel on random inputs, with the GPU binding its buffers packed (two storage buffers) and
/// split into bands of about 20 rows: the same results as the CPU (the kernels declare their reach:
/// rates and flags their own pixel, the 3×3 filters one row, the image filters `max_radius` rows).
#[test]
fn parity_packed_and_in_bands() {
    let Some(mut gpu) = gpu_or_skip("parity_packed_and_in_bands") else { return };
    gpu.force_packed(true);
    // The widest packed buffer: defocus.rates' outputs, at most 5 f32 + 2 u32 per pixel; filter.irradiance's
    // inputs, 14 floats per pixel.
    gpu.set_binding_limit(20 * W as u64 * 14 * 4);
    let scene = scene();
    let mut rng = Rng(14);
    let mut bad = Vec::new();
    let stats = with_flag(random_stats(&mut rng), &mut rng);
    for p in component_params(2.0, "consistent", 64, 256) {
        bad.extend(parity(&mut gpu, &scene, "defocus.rates", W, H, &p, &stats));
    }
    let counts: Buffers =
        BTreeMap::from([("value", BufferData::U32((0..N).map(|_| (rng.next() % 100) as u32).collect()))]);
    for name in ["neighbourhood.max3", "neighbourhood.median3"] {
        bad.extend(parity(&mut gpu, &scene, name, W, H, &Params::new(), &counts));
    }
    // The risk-based width's box of 7×7 terms (reach 3 rows).
    let mut terms = || f32s((0..N).map(|_| rng.range(0.0, 1.0)).collect());
    let terms: Buffers = BTreeMap::from([("bias", terms()), ("noise", terms())]);
    bad.extend(parity(&mut gpu, &scene, "defocus.risk_choice", W, H, &Params::new(), &terms));
    let value = random_image(&mut rng, 97);
    let omega = random_widths(&mut rng);
    let irr = irradiance_inputs(value.clone(), omega.clone());
    bad.extend(parity(&mut gpu, &scene, "filter.irradiance", W, H, &irradiance_params(4), &irr));
    let def = defocus_inputs(value, omega);
    bad.extend(parity(&mut gpu, &scene, "filter.defocus", W, H, &params(&[("max_radius", int(4))]), &def));
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

fn irradiance_inputs(value: Vec<[f32; 3]>, omega: Vec<f32>) -> Buffers {
    let (position, normal, length) = planes(0.01);
    BTreeMap::from([
        ("value", vec3s(value)),
        ("position", vec4s(position)),
        ("normal", vec4s(normal)),
        ("omega", f32s(omega)),
        ("pixel_length", f32s(length)),
    ])
}

fn defocus_inputs(value: Vec<[f32; 3]>, omega: Vec<f32>) -> Buffers {
    BTreeMap::from([("value", vec3s(value)), ("omega", f32s(omega))])
}

fn run_filter(name: &str, inputs: &Buffers) -> (Vec<[f32; 3]>, RayCounts) {
    let p = match name {
        "filter.irradiance" => irradiance_params(16),
        _ => params(&[("max_radius", int(16))]),
    };
    let (out, rays) = run_cpu(&scene(), name, W, H, &p, inputs);
    (vec3_of(&out["out"]).to_vec(), rays)
}

fn inputs_for(name: &str, value: Vec<[f32; 3]>, omega: Vec<f32>) -> Buffers {
    match name {
        "filter.irradiance" => irradiance_inputs(value, omega),
        _ => defocus_inputs(value, omega),
    }
}

const FILTERS: [&str; 2] = ["filter.irradiance", "filter.defocus"];

#[test]
fn constant_image_is_unchanged_by_both_filters() {
    let mut rng = Rng(21);
    let c = [0.3f32, 0.6, 0.9];
    for name in FILTERS {
        let value: Vec<[f32; 3]> = (0..N).map(|_| c).collect();
        let (out, rays) = run_filter(name, &inputs_for(name, value.clone(), random_widths(&mut rng)));
        for (i, o) in out.iter().enumerate() {
            for ch in 0..3 {
                assert!((o[ch] - c[ch]).abs() <= 1e-6, "{name} pixel {i}: {o:?}");
            }
        }
        assert_eq!(rays.non_finite_samples, 0);
    }
}

/// (rms, max) of |out − in| for a filter whose width comes from `defocus.rates` at μ.
fn filter_change_at(name: &str, mu: f64, mode: &str) -> (f64, f64) {
    let scene = scene();
    let mut rng = Rng(31);
    let stats = random_stats(&mut rng);
    let (rates, _) = run_cpu(&scene, "defocus.rates", W, H, &rate_params(mu, mode, 64, 64), &stats);
    let omega = match name {
        "filter.irradiance" => rates["omega"].clone(),
        _ => rates["omega_defocus"].clone(),
    };
    let BufferData::F32(omega) = omega else { panic!("f32 widths") };
    let value = random_image(&mut rng, 0);
    let (out, _) = run_filter(name, &inputs_for(name, value.clone(), omega));
    rms_and_max(&out, &value)
}

#[test]
fn consistent_mode_converges_to_the_identity_literal_mode_does_not() {
    // The rms change falls as μ grows (a single pixel's change need not: its neighbourhood's
    // rejections change with μ too) and is exactly 0 once every filter is below a pixel.
    for name in FILTERS {
        let changes: Vec<(f64, f64)> =
            [1.0, 4.0, 30.0, 1e3, 1e5].iter().map(|mu| filter_change_at(name, *mu, "consistent")).collect();
        println!("{name}: consistent (rms, max) |out − in| at μ = 1, 4, 30, 1e3, 1e5: {changes:?}");
        assert!(changes[0].0 > 0.05, "{name}: the filter blurs at μ = 1: {changes:?}");
        assert!(changes.windows(2).all(|w| w[1].0 <= w[0].0), "{name}: rms non-increasing in μ: {changes:?}");
        assert_eq!(changes[3], (0.0, 0.0), "{name}: a one-pixel filter at μ = 1e3");
        assert_eq!(changes[4], (0.0, 0.0), "{name}: and beyond");
        // Literal eq. 5.29: widths stop at Ω_pix^max = 0.5, whose neighbours keep weight e⁻⁴.
        let literal = filter_change_at(name, 1e3, "literal");
        println!("{name}: literal (rms, max) |out − in| at μ = 1000: {literal:?}");
        assert!(literal.1 > 0.01, "{name}: literal mode still filters at μ = 1000: {literal:?}");
    }
}

#[test]
fn rejection_keeps_sharp_regions_out_of_blurry_ones() {
    // Left half blurry (Ω = 0.05: σ = 3.5 px, reach 10.7 px) and black; right half sharp (Ω = 2) and
    // white. Pixel i in the blurry half next to the edge weighs its sharp neighbours by its own
    // Gaussian at ≈ 0.96, but i lies outside their filters (w_j(i) = e^{−64} < 0.01): rejected.
    let omega: Vec<f32> = (0..N).map(|i| if (i as u32 % W) < 32 { 0.05 } else { 2.0 }).collect();
    let value: Vec<[f32; 3]> =
        (0..N).map(|i| if (i as u32 % W) < 32 { [0.0, 0.0, 0.0] } else { [1.0, 1.0, 1.0] }).collect();
    let (out, _) = run_filter("filter.defocus", &defocus_inputs(value.clone(), omega));
    assert_eq!(out, value, "neither side bleeds into the other");
    // Without the rejection the blurry pixel next to the edge would be about half white.
    let own: f32 = (-FILTER_SHARPNESS * 1.0 * 0.05 * 0.05).exp();
    assert!(own > 0.9);
    // The irradiance filter on the camera-facing plane (x < 24): blurry left part, sharp right part.
    let omega: Vec<f32> = (0..N).map(|i| if (i as u32 % W) < 12 { 0.05 } else { 2.0 }).collect();
    let value: Vec<[f32; 3]> =
        (0..N).map(|i| if (i as u32 % W) < 12 { [0.0, 0.0, 0.0] } else { [1.0, 1.0, 1.0] }).collect();
    let (out, _) = run_filter("filter.irradiance", &irradiance_inputs(value.clone(), omega));
    assert_eq!(out, value);
    // Blurry pixels do mix among themselves: a gradient inside the blurry region is smoothed.
    let omega = vec![0.05f32; N];
    let value: Vec<[f32; 3]> = (0..N).map(|i| [((i as u32 % W) % 2) as f32, 0.0, 0.0]).collect();
    for name in FILTERS {
        let (out, _) = run_filter(name, &inputs_for(name, value.clone(), omega.clone()));
        let row = 20 * W as usize;
        assert!((out[row + 10][0] - 0.5).abs() < 0.05, "{name}: stripes average out: {:?}", out[row + 10]);
    }
}

#[test]
fn normal_test_separates_surfaces_more_than_ten_degrees_apart() {
    // planes(): x < 24 faces the camera, 24 ≤ x < 56 is tilted 30°. Values 0 and 1: no mixing across.
    let omega = vec![0.05f32; N];
    let value: Vec<[f32; 3]> =
        (0..N).map(|i| if (i as u32 % W) < 24 { [0.0, 0.0, 0.0] } else { [1.0, 1.0, 1.0] }).collect();
    let (out, _) = run_filter("filter.irradiance", &irradiance_inputs(value.clone(), omega.clone()));
    assert_eq!(out, value);
    // With a 40° tolerance the two planes mix at the seam.
    let s = scene();
    let p = params(&[("max_radius", int(16)), ("normal_cos", float(40f64.to_radians().cos()))]);
    let (mixed, _) = run_cpu(&s, "filter.irradiance", W, H, &p, &irradiance_inputs(value, omega));
    let seam = 20 * W as usize + 23;
    assert!(vec3_of(&mixed["out"])[seam][0] > 0.05, "{:?}", vec3_of(&mixed["out"])[seam]);
}

#[test]
fn nan_pixel_is_counted_once_and_not_spread() {
    let c = [0.25f32, 0.5, 0.75];
    for name in FILTERS {
        let mut value: Vec<[f32; 3]> = (0..N).map(|_| c).collect();
        let centre = 20 * W as usize + 10;
        value[centre] = [f32::NAN, 0.5, 0.75];
        // A wide filter: every neighbour of the NaN pixel reaches it.
        let (out, rays) = run_filter(name, &inputs_for(name, value.clone(), vec![0.05; N]));
        assert_eq!(rays.non_finite_samples, 1, "{name}");
        for (i, o) in out.iter().enumerate() {
            assert!((0..3).all(|ch| (o[ch] - c[ch]).abs() <= 1e-6), "{name} pixel {i}: {o:?}");
        }
        // A one-pixel filter at the NaN pixel: it keeps its value, its neighbours stay clean.
        let mut omega = vec![0.05f32; N];
        omega[centre] = 2.0;
        let (out, rays) = run_filter(name, &inputs_for(name, value.clone(), omega));
        assert_eq!(rays.non_finite_samples, 1);
        assert!(out[centre][0].is_nan());
        assert!(out.iter().enumerate().all(|(i, o)| i == centre || o[0] == c[0] || (o[0] - c[0]).abs() <= 1e-6));
    }
    // A non-finite lens-averaged position is never a neighbour either (its distances are NaN).
    let value: Vec<[f32; 3]> = (0..N).map(|_| c).collect();
    let mut inputs = irradiance_inputs(value, vec![0.05; N]);
    if let Some(BufferData::Vec4(p)) = inputs.get_mut("position") {
        p[20 * W as usize + 10] = [f32::NAN, 0.0, 2.0, 1.0];
    }
    let (out, _) = run_filter("filter.irradiance", &inputs);
    assert!(out.iter().all(|o| (0..3).all(|ch| (o[ch] - c[ch]).abs() <= 1e-6)));
    // The GPU counts it the same way.
    if let Some(mut gpu) = gpu_or_skip("nan_pixel_is_counted_once_and_not_spread") {
        let mut value: Vec<[f32; 3]> = (0..N).map(|_| c).collect();
        value[100] = [0.0, f32::INFINITY, 0.0];
        value[900] = [f32::NAN, 0.0, 0.0];
        for name in FILTERS {
            let p = match name {
                "filter.irradiance" => irradiance_params(16),
                _ => params(&[("max_radius", int(16))]),
            };
            let (_, rays) =
                run_gpu(&mut gpu, &scene(), name, W, H, &p, &inputs_for(name, value.clone(), vec![0.05; N]));
            assert_eq!(rays.non_finite_samples, 2, "{name}");
        }
    }
}

#[test]
fn defocus_weights_and_window_by_hand() {
    assert!((REJECT_EXPONENT - (1.0f64 / REJECT_WEIGHT as f64).ln() as f32).abs() < 1e-6);
    assert!((REJECT_RADIUS - (REJECT_EXPONENT / FILTER_SHARPNESS).sqrt()).abs() < 1e-6);
    // At Ω = Ω_pix^max = 0.5 the window is ceil(0.5365/0.5) = 2, but only distance-1 neighbours pass
    // (16·1·0.25 = 4 ≤ ln 100 < 16·2·0.25 = 8: the diagonal is out).
    assert_eq!(window_radius(0.5, 16), 2);
    assert_eq!(window_radius(0.05, 16), 11);
    assert_eq!(window_radius(0.0, 16), 16);
    assert_eq!(window_radius(f32::NAN, 16), 16);
    // 3×1 image, Ω = 0.5: the centre weighs 1, each neighbour e⁻⁴ (thesis Sec. 5.8).
    let value = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]];
    let e = (-4.0f32).exp();
    let out = defocus_pixel(1, 0, 3, 1, ScreenRadius::clamped(16), Axis::Both, &value, &[0.5; 3]);
    assert!((out[0] - (1.0 + 2.0 * e) / (1.0 + 2.0 * e)).abs() < 1e-6, "{out:?}");
    // A sharp left neighbour (Ω = 2: i outside its filter, e_j = 64 > ln 100) is rejected.
    let out = defocus_pixel(1, 0, 3, 1, ScreenRadius::clamped(16), Axis::Both, &value, &[2.0, 0.5, 0.5]);
    assert!((out[0] - (1.0 + 2.0 * e) / (1.0 + e)).abs() < 1e-6, "{out:?}");
    // Ω = 0.25 (r_min = 4): neighbours at distance 1 and 2 weigh e^{−1} and e^{−4}.
    let row: Vec<[f32; 3]> = (0..5).map(|x| [x as f32, 0.0, 0.0]).collect();
    let out = defocus_pixel(2, 0, 5, 1, ScreenRadius::clamped(16), Axis::Both, &row, &[0.25; 5]);
    let (e1, e4) = ((-1.0f32).exp(), (-4.0f32).exp());
    let expect = (0.0 * e4 + 1.0 * e1 + 2.0 + 3.0 * e1 + 4.0 * e4) / (1.0 + 2.0 * e1 + 2.0 * e4);
    assert!((out[0] - expect).abs() < 1e-6, "{out:?} vs {expect}");
}

#[test]
fn neighbourhood_filters_by_hand() {
    // 1 0 0 / 0 5 0 / 0 0 1
    let v = [1, 0, 0, 0, 5, 0, 0, 0, 1];
    assert_eq!(max3(&v, 3, 3, 0, 0), 5);
    assert_eq!(max3(&v, 3, 3, 2, 0), 5);
    assert_eq!(median3(&v, 3, 3, 1, 1), 0);
    // Corner (0, 0), edges clamped: (1 1 0)(1 1 0)(0 0 5) → sorted 0 0 0 0 1 1 1 1 5 → 1.
    assert_eq!(median3(&v, 3, 3, 0, 0), 1);
    // The median of 0/1 flags is the majority: a lone 1 disappears, a lone 0 is filled.
    let mut lone = vec![0u32; 25];
    lone[12] = 1;
    assert!((0..5).all(|y| (0..5).all(|x| median3(&lone, 5, 5, x, y) == 0)));
    let mut hole = vec![1u32; 25];
    hole[12] = 0;
    assert!((0..5).all(|y| (0..5).all(|x| median3(&hole, 5, 5, x, y) == 1)));
    // Through the kernels (CPU): the max spreads a count by one pixel.
    let mut counts = vec![1u32; N];
    counts[20 * W as usize + 10] = 64;
    let inputs: Buffers = BTreeMap::from([("value", BufferData::U32(counts))]);
    let (out, _) = run_cpu(&scene(), "neighbourhood.max3", W, H, &Params::new(), &inputs);
    let out = u32_of(&out["out"]);
    assert_eq!(out.iter().filter(|c| **c == 64).count(), 9);
    let (med, _) = run_cpu(&scene(), "neighbourhood.median3", W, H, &Params::new(), &inputs);
    assert!(u32_of(&med["out"]).iter().all(|c| *c == 1));
}

#[test]
fn rates_kernel_matches_the_formulas() {
    use wedge::effects::defocus::formulas::{pixel_rates, Mode, RateParams};
    use wedge::effects::defocus::kernels::{pixel_stats, sigma_px, OptionalStats};
    let scene = scene();
    let stats = with_flag(random_stats(&mut Rng(41)), &mut Rng(42));
    let outs = component_params(2.0, "consistent", 64, 256).map(|mut p| {
        p.insert("max_primary_moving".into(), int(128));
        run_cpu(&scene, "defocus.rates", W, H, &p, &stats).0
    });
    let [direct, indirect, environment] = outs;
    // Consistent mode scales the caps by max(μ, 1)² (kernels::scaled_cap): 64·4, 128·4, 256·4 — so
    // the moving pixels' counts, too, grow without bound as μ does.
    let k = RateParams {
        mu: 2.0,
        mode: Mode::Consistent,
        omega_pix: 0.5,
        pixel_scale: 0.0025,
        light_half_width: 0.25,
        omega_v: 2.8,
        max_primary: 256,
        max_primary_moving: 512,
        max_per_primary: 1024,
        max_shadow_per_primary: 1024,
        environment_per_primary: 4.0,
        width_pixel_limit: true,
    };
    let (lens, occ, refl) = (vec4_of(&stats["lens"]), vec4_of(&stats["occlusion"]), vec4_of(&stats["reflectors"]));
    let BufferData::F32(bandlimit) = &stats["bandlimit"] else { panic!("f32 bandwidths") };
    let (velocity, shadow_velocity) = (vec4_of(&stats["velocity"]), vec4_of(&stats["shadow_velocity"]));
    let flag = u32_of(&stats["flag"]);
    for i in 0..N {
        let o = OptionalStats {
            occlusion: Some(occ[i]),
            reflectors: Some(refl[i]),
            bandlimit: Some(bandlimit[i]),
            velocity: Some(velocity[i]),
            shadow_velocity: Some(shadow_velocity[i]),
        };
        let r = pixel_rates(&pixel_stats(lens[i], o), &k);
        let set = flag[i] != 0;
        let n = |out: &BTreeMap<String, BufferData>| u32_of(&out["n"])[i];
        assert_eq!(n(&environment), if set { r.n_environment_factored } else { r.n_environment_combined });
        assert_eq!(environment["omega"].component(i, 0), r.omega_environment);
        assert_eq!(u32_of(&direct["n_primary"])[i], r.n_primary);
        assert_eq!(n(&direct), if set { r.n_direct_factored } else { r.n_direct_combined }, "the flag picks");
        assert_eq!(n(&indirect), if set { r.n_indirect_factored } else { r.n_indirect_combined });
        assert_eq!(direct["omega"].component(i, 0), r.omega_direct);
        assert_eq!(indirect["sigma"].component(i, 0), sigma_px(r.omega_indirect));
    }
    // A component's outputs need the `component` parameter: an error naming it, not a panic.
    let mut p = rate_params(1.0, "literal", 64, 64);
    p.remove("component");
    let e = LonePass::new(kernel("defocus.rates"), p, &stats).unwrap().run_cpu(&scene, W, H, SEED).unwrap_err();
    assert!(e.to_string().contains("`component`"), "{e}");
    // Unknown modes are an error naming the choices, not a panic.
    let e = LonePass::new(kernel("defocus.rates"), rate_params(1.0, "clamped", 64, 64), &stats)
        .unwrap()
        .run_cpu(&scene, W, H, SEED)
        .unwrap_err();
    assert!(e.to_string().contains(r#"["literal", "consistent"]"#), "{e}");
    // So are non-positive or non-finite constants.
    for (name, v) in [("mu", 0.0), ("mu", f64::NAN), ("pixel_scale", -1.0), ("light_half_width", -0.1)] {
        let mut p = rate_params(1.0, "literal", 64, 64);
        p.insert(name.into(), float(v));
        let e = LonePass::new(kernel("defocus.rates"), p, &stats).unwrap().run_cpu(&scene, W, H, SEED).unwrap_err();
        assert!(e.to_string().contains(name) && e.to_string().contains("finite number"), "{e}");
    }
}

/// Run `name` as an X pass then a Y pass (the separable approximation).
fn run_separable(name: &str, inputs: &Buffers) -> Vec<[f32; 3]> {
    let scene = scene();
    let mut current = inputs.clone();
    for axis in [0, 1] {
        let mut p = match name {
            "filter.irradiance" => irradiance_params(16),
            _ => params(&[("max_radius", int(16))]),
        };
        p.insert("axis".into(), int(axis));
        let (out, _) = run_cpu(&scene, name, W, H, &p, &current);
        current.insert("value", out["out"].clone());
    }
    vec3_of(&current["value"]).to_vec()
}

fn rms_and_max(a: &[[f32; 3]], b: &[[f32; 3]]) -> (f64, f64) {
    let (mut s, mut m) = (0f64, 0f64);
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            let d = (x[c] - y[c]) as f64;
            s += d * d;
            m = m.max(d.abs());
        }
    }
    ((s / (3 * a.len()) as f64).sqrt(), m)
}

/// The separable X-then-Y version against the 2-D reference. With a constant width and no
/// rejections they differ only by the truncation (a square of side 2·0.5365/Ω instead of the disk:
/// the corners hold under 0.5% of the weight); with widths that vary and reject, by how the
/// rejection composes. Measured on a textured image (random values in [0, 1]).
#[test]
fn separable_passes_match_the_2d_filters() {
    let mut rng = Rng(51);
    let value = random_image(&mut rng, 0);
    for name in FILTERS {
        // Constant widths: r_min = 2, 4, 10 px.
        for omega in [0.5f32, 0.25, 0.1] {
            let inputs = inputs_for(name, value.clone(), vec![omega; N]);
            let (two_d, _) = run_filter(name, &inputs);
            let sep = run_separable(name, &inputs);
            let (rms, max) = rms_and_max(&two_d, &sep);
            println!("{name} Ω = {omega}: separable vs 2-D rms {rms:.2e} max {max:.2e}");
            assert!(rms < 5e-3 && max < 2e-2, "{name} Ω = {omega}: rms {rms} max {max}");
        }
        // A smooth focus ramp: in focus at the centre column, r_min growing to 12 px at both sides.
        let omega: Vec<f32> = (0..N)
            .map(|i| {
                let x = (i as u32 % W) as f32;
                let r_min = 12.0 * (x - W as f32 / 2.0).abs() / (W as f32 / 2.0);
                wedge::effects::defocus::formulas::omega_defocus(r_min, 0.5)
            })
            .collect();
        let inputs = inputs_for(name, value.clone(), omega);
        let (two_d, _) = run_filter(name, &inputs);
        let sep = run_separable(name, &inputs);
        let (rms, max) = rms_and_max(&two_d, &sep);
        let (change, _) = rms_and_max(&two_d, &value);
        println!("{name} focus ramp: separable vs 2-D rms {rms:.2e} max {max:.2e}; 2-D filter changes the image by rms {change:.2e}");
        assert!(rms < 0.05 * change, "{name} focus ramp: rms {rms} vs the filter's own change {change}");
        // Widths from defocus.rates on random lens statistics (focus and defocus mixed pixel by pixel,
        // the hardest case for the rejection): the difference stays a fraction of the filtering itself.
        let scene = scene();
        let stats = random_stats(&mut Rng(52));
        let (rates, _) = run_cpu(&scene, "defocus.rates", W, H, &rate_params(1.0, "literal", 64, 64), &stats);
        let BufferData::F32(omega) = rates["omega_defocus"].clone() else { panic!("f32") };
        let inputs = inputs_for(name, value.clone(), omega);
        let (two_d, _) = run_filter(name, &inputs);
        let sep = run_separable(name, &inputs);
        let (rms, max) = rms_and_max(&two_d, &sep);
        let (change, _) = rms_and_max(&two_d, &value);
        println!("{name} rates widths: separable vs 2-D rms {rms:.2e} max {max:.2e}; 2-D filter changes the image by rms {change:.2e}");
        assert!(rms < 0.3 * change, "{name}: rms {rms} vs the filter's own change {change}");
        // No bleeding across a sharp/blurry edge either.
        let omega: Vec<f32> = (0..N).map(|i| if (i as u32 % W) < 12 { 0.05 } else { 2.0 }).collect();
        let edge: Vec<[f32; 3]> =
            (0..N).map(|i| if (i as u32 % W) < 12 { [0.0, 0.0, 0.0] } else { [1.0, 1.0, 1.0] }).collect();
        assert_eq!(run_separable(name, &inputs_for(name, edge.clone(), omega)), edge, "{name}");
    }
}

/// The WGSL formula helpers no kernel of this crate calls but the path sampler may
/// (`defocus_circle_of_confusion`, `defocus_secondary_per_primary`), through a
/// probe kernel, against `formulas.rs`.
struct FormulaProbe;

impl Kernel for FormulaProbe {
    fn name(&self) -> &'static str {
        "test.defocus_formula_probe"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("lens", Format::Vec4),
            Binding::read("n_p", Format::U32),
            Binding::read("n", Format::U32),
            Binding::write("coc", Format::F32),
            Binding::write("per_primary", Format::U32),
        ]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        use wedge::effects::defocus::formulas::{secondary_per_primary, ThinLens};
        let lens = ctx.read::<[f32; 4]>("lens")?;
        let (n_p, n) = (ctx.read::<u32>("n_p")?, ctx.read::<u32>("n")?);
        let coc = lens
            .iter()
            .map(|l| {
                ThinLens { aperture_radius: l[0], focus_distance: l[1], pixel_scale: l[2] }.circle_of_confusion(l[3])
            })
            .collect();
        ctx.put("coc", coc)?;
        ctx.put("per_primary", n_p.iter().zip(n).map(|(a, b)| secondary_per_primary(*a, *b)).collect())
    }
    fn wgsl(&self) -> Option<WgslSource> {
        const SOURCE: &str = r#"
#include "common.wgsl"
#include "defocus_formulas.wgsl"
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let l = lens_at(i);
    coc_put(i, defocus_circle_of_confusion(l.x, l.y, l.z, l.w));
    per_primary_put(i, defocus_secondary_per_primary(n_p_at(i), n_at(i)));
}
"#;
        Some(
            WgslSource::new(SOURCE, |_| Ok(Uniforms::new()))
                .with_include("defocus_formulas.wgsl", include_str!("../shaders/defocus_formulas.wgsl"))
                .per_pixel(),
        )
    }
}

#[test]
fn parity_wgsl_formula_helpers() {
    let Some(mut gpu) = gpu_or_skip("parity_wgsl_formula_helpers") else { return };
    let mut rng = Rng(61);
    let lens: Vec<[f32; 4]> = (0..N)
        .map(|i| {
            let a = if i % 10 == 0 { 0.0 } else { rng.range(0.0, 0.2) };
            [a, rng.range(0.5, 10.0), rng.range(5e-4, 5e-3), rng.range(0.2, 30.0)]
        })
        .collect();
    let n_p: Vec<u32> = (0..N).map(|_| [0u32, 1, 4, 9, 16, 64][(rng.next() % 6) as usize]).collect();
    let n: Vec<u32> = (0..N).map(|_| (rng.next() % 2000) as u32).collect();
    let inputs: Buffers =
        BTreeMap::from([("lens", vec4s(lens)), ("n_p", BufferData::U32(n_p)), ("n", BufferData::U32(n))]);
    let bad = parity_with(&mut gpu, Arc::new(FormulaProbe), &scene(), W, H, &Params::new(), &inputs);
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The filters' noise reduction matches their weights: on a flat field with independent noise the
/// output's standard deviation is σ_in / sqrt(N_eff), with N_eff = (Σw)²/Σw² over the truncated
/// window (≈ π/(8Ω²) for the untruncated Gaussian exp(−16 d² Ω²), i.e. σ = 0.177/Ω px).
#[test]
fn noise_reduction_matches_the_weights() {
    let (w, h) = (128u32, 128u32);
    let n = (w * h) as usize;
    let scene = scene();
    let mut rng = Rng(71);
    let value: Vec<[f32; 3]> = (0..n).map(|_| [0.5 + rng.range(-0.2, 0.2), 0.5, 0.5]).collect();
    let sigma_in = 0.4 / 12f64.sqrt();
    let ell = 0.01f32;
    let position: Vec<[f32; 4]> =
        (0..n).map(|i| [(i as u32 % w) as f32 * ell, (i as u32 / w) as f32 * ell, 2.0, 1.0]).collect();
    let normal = vec![[0.0f32, 0.0, 1.0, ell]; n];
    for omega in [0.1f32, 0.2] {
        // N_eff over the window the kernels use (d² with 16 d² Ω² ≤ ln 100).
        let r = window_radius(omega, 16);
        let (mut s1, mut s2) = (0f64, 0f64);
        for dy in -r..=r {
            for dx in -r..=r {
                let e = FILTER_SHARPNESS * (dx * dx + dy * dy) as f32 * omega * omega;
                if e <= REJECT_EXPONENT {
                    let wt = (-e as f64).exp();
                    s1 += wt;
                    s2 += wt * wt;
                }
            }
        }
        let n_eff = s1 * s1 / s2;
        let untruncated = std::f64::consts::PI / (8.0 * (omega as f64).powi(2));
        assert!((n_eff / untruncated - 1.0).abs() < 0.1, "Ω = {omega}: N_eff {n_eff} vs π/(8Ω²) {untruncated}");
        let expect = sigma_in / n_eff.sqrt();
        let omegas = vec![omega; n];
        let irr: Buffers = BTreeMap::from([
            ("value", vec3s(value.clone())),
            ("position", vec4s(position.clone())),
            ("normal", vec4s(normal.clone())),
            ("omega", f32s(omegas.clone())),
            ("pixel_length", f32s(vec![ell; n])),
        ]);
        let def: Buffers = BTreeMap::from([("value", vec3s(value.clone())), ("omega", f32s(omegas))]);
        for (name, inputs, p) in [
            ("filter.irradiance", &irr, irradiance_params(16)),
            ("filter.defocus", &def, params(&[("max_radius", int(16))])),
        ] {
            let (out, _) = run_cpu(&scene, name, w, h, &p, inputs);
            let out = vec3_of(&out["out"]);
            // Interior pixels only (the window is whole there).
            let inner: Vec<f64> = (0..n)
                .filter(|i| {
                    let (x, y) = ((*i as u32 % w) as i32, (*i as u32 / w) as i32);
                    x >= r && y >= r && x < w as i32 - r && y < h as i32 - r
                })
                .map(|i| out[i][0] as f64)
                .collect();
            let mean = inner.iter().sum::<f64>() / inner.len() as f64;
            let std = (inner.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / inner.len() as f64).sqrt();
            println!("{name} Ω = {omega}: output std {std:.4}, predicted {expect:.4} (N_eff {n_eff:.1}, input std {sigma_in:.4})");
            assert!((std / expect - 1.0).abs() < 0.12, "{name} Ω = {omega}: std {std} vs {expect}");
            assert!((mean - 0.5).abs() < 0.01, "{name}: unbiased mean {mean}");
        }
    }
}

/// Eq. 5.32 chained over two components: parity on random inputs and flags, and the sum by hand.
#[test]
fn compose_chains_components_eq_5_32() {
    let scene = scene();
    let mut rng = Rng(81);
    let component = |rng: &mut Rng| -> Buffers {
        let v = |rng: &mut Rng| -> BufferData { vec3s((0..N).map(|_| [rng.unit(), rng.unit(), rng.unit()]).collect()) };
        BTreeMap::from([
            ("radiance", v(rng)),
            ("texture", v(rng)),
            ("irradiance", v(rng)),
            ("flag", BufferData::U32((0..N).map(|_| (rng.next() % 2) as u32).collect())),
        ])
    };
    let direct = component(&mut rng);
    let indirect = component(&mut rng);
    let (first, _) = run_cpu(&scene, "defocus.compose", W, H, &Params::new(), &direct);
    let mut second_in = indirect.clone();
    second_in.insert("previous", first["out"].clone());
    let (second, _) = run_cpu(&scene, "defocus.compose", W, H, &Params::new(), &second_in);
    let term = |c: &Buffers, i: usize| -> [f32; 3] {
        let (l, k, e) = (vec3_of(&c["radiance"])[i], vec3_of(&c["texture"])[i], vec3_of(&c["irradiance"])[i]);
        if u32_of(&c["flag"])[i] != 0 {
            [k[0] * e[0], k[1] * e[1], k[2] * e[2]]
        } else {
            [l[0], l[1], l[2]]
        }
    };
    for i in 0..N {
        let (a, b) = (term(&direct, i), term(&indirect, i));
        assert_eq!(vec3_of(&second["out"])[i], [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
    }
    if let Some(mut gpu) = gpu_or_skip("compose_chains_components_eq_5_32") {
        let mut bad = parity(&mut gpu, &scene, "defocus.compose", W, H, &Params::new(), &direct);
        bad.extend(parity(&mut gpu, &scene, "defocus.compose", W, H, &Params::new(), &second_in));
        assert!(bad.is_empty(), "{}", bad.join("\n"));
    }
}

/// The first pass of `paths.trace` (16 paths) resolved, on a builtin scene with the given lens.
fn first_pass(name: &str, aperture: f32, jitter: bool, (w, h): (u32, u32)) -> (Scene, BTreeMap<String, BufferData>) {
    use wedge::backends::kernels::paths::{PathsResolve, PathsTrace};
    let mut scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin(name.into())).expect("builtin scene");
    scene.camera.aperture_radius = aperture;
    let trace = params(&[
        ("count", int(16)),
        ("jitter", ParamValue::Bool(jitter)),
        ("lens", ParamValue::Str("disk".into())),
        ("shadow_per_primary", int(1)),
        ("indirect_per_primary", int(1)),
        ("light", int(0)),
        ("stream", int(3)),
        ("brdf", ParamValue::Str("phong".into())),
        ("bounces", int(1)),
        ("sampling", ParamValue::Str("stratified".into())),
    ]);
    let (rec, _) = run_cpu_with(Arc::new(PathsTrace), &scene, w, h, &trace, &Buffers::new());
    let (res, _) = run_cpu_with(
        Arc::new(PathsResolve),
        &scene,
        w,
        h,
        &Params::new(),
        &BTreeMap::from([("record", rec["record"].clone())]),
    );
    (scene, res)
}

fn direct_flags(scene: &Scene, res: &BTreeMap<String, BufferData>, (w, h): (u32, u32)) -> Vec<u32> {
    let inputs: Buffers = BTreeMap::from([
        ("radiance", res["l_direct"].clone()),
        ("texture", res["k_direct"].clone()),
        ("irradiance", res["e_direct"].clone()),
    ]);
    let (out, _) = run_cpu(scene, "defocus.flags", w, h, &params(&[("threshold", float(0.01))]), &inputs);
    u32_of(&out["flag"]).to_vec()
}

/// Issue 11 §3: with one primary point per pixel (pinhole, no jitter) `L`, `k` and `E` share the
/// centre-of-light form factor, so `k·E = L` and SepDir holds everywhere, textured or not; under
/// strong defocus the flags turn off where the lens footprint mixes texture and irradiance — at
/// defocused pixels of the textured board, far more than at pixels in focus.
#[test]
fn factoring_is_exact_at_a_single_primary_point_and_flagged_off_under_defocus() {
    let size = (96u32, 72u32);
    for name in ["curved", "chess"] {
        let (scene, res) = first_pass(name, 0.0, false, size);
        let flags = direct_flags(&scene, &res, size);
        let (l, k, e) = (vec3_of(&res["l_direct"]), vec3_of(&res["k_direct"]), vec3_of(&res["e_direct"]));
        let worst = (0..flags.len())
            .map(|i| (0..3).map(|c| (l[i][c] - k[i][c] * e[i][c]).abs()).fold(0f32, f32::max))
            .fold(0f32, f32::max);
        println!(
            "{name}, pinhole: SepDir at {} of {} pixels, max |L − kE| {worst:.2e}",
            flags.iter().sum::<u32>(),
            flags.len()
        );
        assert!(flags.iter().all(|f| *f == 1), "{name}: SepDir everywhere at a single primary point");
        assert!(worst < 1e-5, "{name}: k·E equals L ({worst})");
    }
    // chess with twice the recommended aperture (r up to ~4 px at this size), one image point per
    // pixel (the thesis's first pass: no pixel jitter, so only the lens spreads the hit points).
    let (scene, res) = first_pass("chess", 0.1, false, size);
    let flags = direct_flags(&scene, &res, size);
    let lens = vec4_of(&res["defocus"]);
    let off_share = |pick: &dyn Fn(f32) -> bool| {
        let idx: Vec<usize> = (0..flags.len()).filter(|i| lens[*i][3] > 0.0 && pick(lens[*i][1])).collect();
        (idx.iter().filter(|i| flags[**i] == 0).count() as f64 / idx.len().max(1) as f64, idx.len())
    };
    let (sharp, n_sharp) = off_share(&|r_max| r_max < 0.5);
    let (blurred, n_blurred) = off_share(&|r_max| r_max > 2.0);
    println!(
        "chess, aperture 0.1: SepDir off at {:.1}% of {n_sharp} sharp pixels, {:.1}% of {n_blurred} defocused pixels",
        sharp * 100.0,
        blurred * 100.0
    );
    assert!(n_sharp > 50 && n_blurred > 50, "both kinds of pixel present");
    assert!(blurred > 0.05 && blurred > 3.0 * sharp, "flags turn off under defocus: {blurred} vs {sharp}");
}

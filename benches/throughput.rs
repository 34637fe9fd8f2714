//! Ray-traversal throughput report (`cargo bench --bench throughput`): a Markdown table of primary,
//! shadow (any-hit) and closest-hit shadow rays per second on the built-in `grids` and `heavy` scenes,
//! at 1 and 2 rayon threads. Not a pass/fail test: it prints numbers for humans to compare.
//!
//! - primary: one camera ray through every pixel centre of a 640×480 image, `Scene::intersect`,
//!   repeated until ≥1 s has passed;
//! - shadow: from each primary hit (offset along the shading normal by 1e-4·extent, as
//!   `direct.light` does) toward 16 uniform points on light 0, `Scene::occluded`; samples behind the
//!   surface or the light are skipped like the kernel skips them;
//! - shadow closest: the same rays through `Scene::intersect` (the first pass needs occluder distances).
//!
//! - paths: the `indirect.sample` kernel itself (what `MonteCarlo` runs; `Indirect` runs `paths.trace`,
//!   whose hemisphere estimator is the same `trace_path`) on `cornell`
//!   with 1, 2 and 3 bounces: hemisphere/bounce rays plus next-event shadow rays per second, and
//!   paths per second (kernel time from the run's pass timings).
//!
//! Shadow rays are generated once up front so only traversal is timed. Each row also prints a
//! checksum (hit count and a hash of the hit triangles' input indices) so runs before and after a
//! traversal change can be compared for identical results.
//!
//! Environment: `WEDGE_BENCH_SCENES=grids,heavy` picks scenes, `WEDGE_BENCH_MIN_SECS=1` the minimum
//! timed duration per cell.

use std::time::{Duration, Instant};

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use wedge::backends::rng::PixelRng;
use wedge::backends::cpu::CpuBackend;
use wedge::backends::Silent;
use wedge::scene::{Scene, SceneSource};

const W: u32 = 640;
const H: u32 = 480;
const SHADOW_SAMPLES: u32 = 16;
const SEED: u32 = 0x5eed;
const CHUNK: usize = 1024;

struct Ray {
    o: Vec3,
    d: Vec3,
    tmax: f32,
}

fn machine_info() -> (usize, String) {
    let nproc = std::thread::available_parallelism().map_or(1, |n| n.get());
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into());
    (nproc, model)
}

fn primary_rays(scene: &Scene) -> Vec<Ray> {
    let mut rays = Vec::with_capacity((W * H) as usize);
    for y in 0..H {
        for x in 0..W {
            let (o, d) = scene
                .camera
                .generate_ray(x as f32 + 0.5, y as f32 + 0.5, W, H, Vec2::splat(0.5));
            rays.push(Ray { o, d, tmax: f32::INFINITY });
        }
    }
    rays
}

/// Shadow rays exactly as `backends::kernels::direct::light_sample` casts them.
fn shadow_rays(scene: &Scene, primary: &[Ray]) -> Vec<Ray> {
    let light = &scene.lights[0];
    let ln = light.normal();
    let eps = 1e-4 * scene.extent();
    let per_pixel: Vec<Vec<Ray>> = primary
        .par_iter()
        .enumerate()
        .map(|(pixel, r)| {
            let mut out = Vec::new();
            let Some(hit) = scene.intersect(r.o, r.d, 0.0, f32::INFINITY) else {
                return out;
            };
            let sp = scene.surface(&hit, r.o, r.d);
            let (x, n) = (sp.position, sp.shading_normal);
            let rng = PixelRng::new(SEED, pixel as u32, 0);
            for s in 0..SHADOW_SAMPLES {
                let y = light.sample_point(Vec2::from(rng.uniform2(s, 8)));
                let to = y - x;
                let dir = to.normalize();
                let cos_y = if light.two_sided { ln.dot(-dir).abs() } else { ln.dot(-dir) };
                if n.dot(dir) <= 0.0 || cos_y <= 0.0 {
                    continue;
                }
                let origin = x + n * eps;
                let seg = y - origin;
                let dist = seg.length();
                out.push(Ray { o: origin, d: seg / dist, tmax: dist * (1.0 - 1e-4) });
            }
            out
        })
        .collect();
    per_pixel.into_iter().flatten().collect()
}

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Closest,
    AnyHit,
}

/// (hits, order-independent hash of the hit triangles' input indices).
fn trace(scene: &Scene, rays: &[Ray], mode: Mode) -> (u64, u64) {
    rays.par_chunks(CHUNK)
        .map(|chunk| {
            let (mut hits, mut hash) = (0u64, 0u64);
            for r in chunk {
                match mode {
                    Mode::Closest => {
                        if let Some(h) = scene.intersect(r.o, r.d, 0.0, r.tmax) {
                            hits += 1;
                            let src = scene.triangles[h.triangle as usize].source as u64;
                            hash = hash.wrapping_add(src.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (src >> 3));
                        }
                    }
                    Mode::AnyHit => hits += scene.occluded(r.o, r.d, 0.0, r.tmax) as u64,
                }
            }
            (hits, hash)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1.wrapping_add(b.1)))
}

struct Cell {
    mrays: f64,
    passes: u32,
    check: (u64, u64),
}

fn measure(pool: &rayon::ThreadPool, scene: &Scene, rays: &[Ray], mode: Mode, min: Duration) -> Cell {
    pool.install(|| {
        let start = Instant::now();
        let mut passes = 0u32;
        let mut check = (0, 0);
        while passes == 0 || start.elapsed() < min {
            check = trace(scene, rays, mode);
            passes += 1;
        }
        let secs = start.elapsed().as_secs_f64();
        Cell { mrays: rays.len() as f64 * passes as f64 / secs / 1e6, passes, check }
    })
}

/// The bench's path pipeline on `cornell`: indirect light only, `spp` paths per pixel and component.
fn path_session(bounces: u32, size: (u32, u32), spp: u32) -> wedge::Session {
    let text = format!(
        r#"Pipeline(scene: "builtin:cornell", width: {}, height: {}, seed: 1, nodes: [
    (name: "primary", kind: "Primary"),
    (name: "mc", kind: "MonteCarlo", params: {{"spp": {spp}, "bounces": {bounces}, "direct": false, "light": -1}},
     inputs: {{"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo",
               "specular": "primary.specular"}}),
    (name: "out", kind: "Output", inputs: {{"color": "mc.radiance"}}),
])"#,
        size.0, size.1
    );
    let loaded = wedge::graph::parse_pipeline(std::path::Path::new("paths.ron"), &text).expect("bench pipeline parses");
    let (nodes, kernels) = wedge::effects::builtin();
    wedge::Session::build(loaded, &Default::default(), nodes, kernels).expect("bench session")
}

/// Multi-bounce path throughput of the `indirect.sample` kernel: (Mrays/s, Mpaths/s, rays per path).
fn paths(threads: usize, bounces: u32, size: (u32, u32), spp: u32, min: Duration) -> (f64, f64, f64) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    let run = |s: &wedge::Session| pool.install(|| s.run(&mut CpuBackend::new(), &Silent)).expect("bench run");
    // With one bounce every bounce ray starts a path: that run's count is the paths per run.
    let paths_per_run = run(&path_session(1, size, spp)).rays.secondary_rays;
    let session = path_session(bounces, size, spp);
    let (mut rays, mut runs, mut secs) = (0u64, 0u64, 0f64);
    while runs == 0 || secs < min.as_secs_f64() {
        let r = run(&session);
        secs += r.timings.iter().filter(|t| t.kernel == "indirect.sample").map(|t| t.seconds).sum::<f64>();
        rays += r.rays.secondary_rays + r.rays.shadow_rays;
        runs += 1;
    }
    let paths = (paths_per_run * runs).max(1) as f64;
    (rays as f64 / secs / 1e6, paths / secs / 1e6, rays as f64 / paths)
}

fn main() {
    // `cargo bench` passes `--bench`; accept and ignore libtest-style arguments.
    // `cargo test --all-targets` runs this binary without `--bench`: then only a quick smoke run
    // (grids, one pass per cell) so the test suite checks it works without paying for the numbers.
    let smoke = !std::env::args().any(|a| a == "--bench");
    let scenes: Vec<String> = std::env::var("WEDGE_BENCH_SCENES")
        .unwrap_or_else(|_| if smoke { "grids".into() } else { "grids,heavy".into() })
        .split(',')
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect();
    let min = Duration::from_secs_f64(
        std::env::var("WEDGE_BENCH_MIN_SECS").ok().and_then(|s| s.parse().ok()).unwrap_or(if smoke { 0.0 } else { 1.0 }),
    );
    let (nproc, model) = machine_info();
    println!("# wedge ray throughput\n");
    println!("- machine: {model}, nproc = {nproc}");
    println!("- image {W}×{H}, {SHADOW_SAMPLES} shadow rays per primary hit toward light 0, ≥{:.1} s per cell\n", min.as_secs_f64());

    let mut rows = Vec::new();
    for name in &scenes {
        let t = Instant::now();
        let scene = match wedge::scene::load(&SceneSource::Builtin(name.clone())) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("skipping {name}: {e}");
                continue;
            }
        };
        let load = t.elapsed();
        // Rebuild the BVH alone (input order recovered from `source`) to time just the builder.
        let n_input = scene.triangles.iter().map(|t| t.source as usize + 1).max().unwrap_or(0);
        let mut input = vec![[Vec3::ZERO; 3]; n_input];
        for t in &scene.triangles {
            input[t.source as usize] = t.vertices();
        }
        let t = Instant::now();
        let built = wedge::scene::bvh::build(&input);
        let build = t.elapsed();
        println!(
            "- `{name}`: {} input triangles, {} triangle references, {} BVH nodes (depth {}); load {:.0} ms, BVH build {:.0} ms",
            n_input,
            built.order.len(),
            built.nodes.len(),
            built.depth,
            load.as_secs_f64() * 1e3,
            build.as_secs_f64() * 1e3
        );
        drop(built);
        let primary = primary_rays(&scene);
        let shadow = shadow_rays(&scene, &primary);
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let p = measure(&pool, &scene, &primary, Mode::Closest, min);
            let s = measure(&pool, &scene, &shadow, Mode::AnyHit, min);
            let c = measure(&pool, &scene, &shadow, Mode::Closest, min);
            rows.push((name.clone(), threads, primary.len(), shadow.len(), p, s, c));
        }
    }
    // Multi-bounce paths (Indirect's sampler) on `cornell`.
    let (size, spp) = if smoke { ((32, 24), 1) } else { ((320, 240), 16) };
    let mut path_rows = Vec::new();
    for bounces in [1u32, 2, 3] {
        for threads in [1usize, 2] {
            path_rows.push((bounces, threads, paths(threads, bounces, size, spp, min)));
        }
    }
    println!();
    println!("| scene | threads | primary Mrays/s | shadow (any-hit) Mrays/s | shadow (closest) Mrays/s | rays (primary / shadow) | passes | checksum |");
    println!("|---|---:|---:|---:|---:|---:|---:|---|");
    for (name, threads, np, ns, p, s, c) in rows {
        println!(
            "| {name} | {threads} | {:.2} | {:.2} | {:.2} | {np} / {ns} | {}/{}/{} | p {}:{:x} s {} c {}:{:x} |",
            p.mrays, s.mrays, c.mrays, p.passes, s.passes, c.passes, p.check.0, p.check.1, s.check.0, c.check.0, c.check.1
        );
    }
    println!();
    println!("Paths on `cornell` ({}×{}, {spp} paths per pixel and component; `indirect.sample`, next-event estimation at every vertex):\n", size.0, size.1);
    println!("| bounces | threads | Mrays/s (bounce + shadow) | rays per path | Mpaths/s |");
    println!("|---:|---:|---:|---:|---:|");
    for (bounces, threads, (mrays, mpaths, per)) in path_rows {
        println!("| {bounces} | {threads} | {mrays:.2} | {per:.2} | {mpaths:.3} |");
    }
}

//! Ray-traversal throughput report (`cargo bench --bench throughput`): Markdown tables of primary,
//! shadow (any-hit), closest-hit shadow and diffuse-bounce rays per second on the built-in `grids`,
//! `heavy` and `spheres` (issue 12's 409,604-triangle scene) at 1 and 2 rayon threads, BVH build time
//! and memory per obvhs preset, and, when a Python with `embreex` is present, the same rays traced by
//! Embree on one thread. Not a pass/fail test: it prints numbers for humans to compare.
//!
//! - primary: one camera ray through every pixel centre of a 640×480 image, `Scene::intersect`,
//!   repeated until ≥1 s has passed;
//! - shadow: from each primary hit (offset along the shading normal by 1e-4·extent, as
//!   `direct.light` does) toward 16 uniform points on light 0, `Scene::occluded`; samples behind the
//!   surface or the light are skipped like the kernel skips them;
//! - shadow closest: the same rays through `Scene::intersect` (the first pass needs occluder distances).
//! - diffuse: from each primary hit (same offset origin), 4 cosine-weighted directions about the
//!   shading normal, `Scene::intersect` with tmax = ∞ — the incoherent bounce rays of a path tracer.
//!
//! - work: wide nodes and triangle packs tested per ray (`bvh::traverse_counted`), per ray kind — the
//!   first thing to look at when a ratio against Embree moves.
//! - build: `bvh::build` (what scenes use: `fast_build` with one triangle per leaf, SAH-optimal
//!   collapse), `bvh::build_with` for obvhs's `fastest_build`, `very_fast_build`, `fast_build`,
//!   `medium_build` and `slow_build` (spatial splits; their own 8-triangle leaves, SAH-optimal
//!   collapse), and `fast_build` with the greedy collapse used before, on each scene's triangles: build time (best of the runs in ≥1 s; obvhs's `parallel` feature uses every rayon
//!   thread), BVH memory (wide nodes + triangle packs) and total with the triangle records, and the
//!   primary- and diffuse-ray speed of that tree (one thread, `bvh::traverse_simd` with the CPU's best
//!   slab test over a `Bvh::pack` of it; medians of `WEDGE_BENCH_REPEATS` runs round-robin over the
//!   trees). A last row traces the scenes' tree with the portable slab test (two 4-lane groups per
//!   node instead of one AVX test): what a CPU without AVX gets, and the AVX path's share.
//!
//! - paths: the `indirect.sample` kernel itself (what `MonteCarlo` runs; `Indirect` runs `paths.trace`,
//!   whose hemisphere estimator is the same `trace_path`) on `cornell`
//!   with 1, 2 and 3 bounces: hemisphere/bounce rays plus next-event shadow rays per second, and
//!   paths per second (kernel time from the run's pass timings).
//!
//! - passes vs bare traversal (issue 38 §2): the `primary.gbuffer` pass and a `direct.light` pass
//!   (`MonteCarlo` with 16 independent samples toward light 0, no occlusion output: any-hit rays) run
//!   through one persistent `CpuBackend` on the same scene at the same 640×480, beside the bare rows'
//!   primary (closest) and shadow (any-hit) rates. A pass's rays are the bare set's (the pass draws its
//!   own light points, so its count of rays actually traced differs by noise); its time is the pass's
//!   own timing, the first frame (buffers allocated) apart from the median of the later frames (a
//!   persistent backend recycles them). Goal ≥ 0.8 of the bare rate.
//!
//! - Embree (issue 12's yardstick): each scene's triangles and rays are written to a temporary file
//!   (format in `benches/embree_compare.py`) and `embree_compare.py` traces them with Embree 4 through
//!   `embreex` (`rtcIntersect1`/`rtcOccluded1`, one thread), repeated for ≥1 s; the table sets its
//!   Mrays/s beside wedge's 1-thread figure, with both hit counts and the number of rays whose results
//!   agree (same triangle, or both miss), so the ratio is known to compare the same work. Skipped with
//!   one line when Python or `embreex` is missing, and in the smoke run.
//!
//! - motion (issue 13): on the built-in `motion`, rays per second through its moving instances (a static
//!   tree plus one tree per moving object, `Scene::at`) against the same scene frozen into one static
//!   tree (every object where it is at `t = 0`): primary rays (the camera's, 640×480) and shadow rays
//!   (16 toward light 0 from each primary hit of the frozen scene, any-hit), each traced at `t = 0`
//!   and at a random time per ray (the frozen scene ignores it). And how the linear loop over
//!   instances scales: primary rays on `spheres` with N of its 400 spheres moving (each its own
//!   instance, a 1 cm translation) at random times, against N = 0 (skipped in the smoke run).
//!
//! Shadow and bounce rays are generated once up front so only traversal is timed: the timed loop keeps
//! each hit as the tracer returns it (`Hit::triangle`, as Embree returns its `primID`). Each row also
//! prints a checksum, computed untimed (hit count and a hash of the hit triangles' input indices, the
//! same for any tree over the same triangles), so runs before and after a traversal change can be
//! compared for identical results.
//!
//! Environment: `WEDGE_BENCH_SCENES=grids,heavy,spheres` picks scenes, `WEDGE_BENCH_MIN_SECS=1` the
//! minimum timed duration per cell, `WEDGE_BENCH_PYTHON=python3` the interpreter for the Embree side,
//! `WEDGE_BENCH_MOTION=0` skips the motion tables, `WEDGE_BENCH_ONLY=passes` measures and prints only the
//! bare rows and the "passes vs bare traversal" table (a quick check of a kernel change),
//! `WEDGE_BENCH_REPEATS=3` how many times the Embree
//! comparison is run (each repetition re-measures wedge's 1-thread cells right before Embree traces
//! the same rays, so slow phases of a shared machine hit both sides; the table gives medians and the
//! ratio's range: one run's ratio moved by up to 45% here, DESIGN-NOTES "Re-measured against Embree").

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use wedge::backends::cpu::CpuBackend;
use wedge::backends::kernels::hemisphere::{cosine_hemisphere, Frame};
use wedge::backends::rng::PixelRng;
use wedge::backends::Silent;
use wedge::scene::bvh::Simd;
use wedge::scene::{RigidMotion, Scene, SceneObject, SceneSource};

const W: u32 = 640;
const H: u32 = 480;
const SHADOW_SAMPLES: u32 = 16;
const DIFFUSE_SAMPLES: u32 = 4;
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
            let (o, d) = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, W, H, Vec2::splat(0.5));
            rays.push(Ray { o, d, tmax: f32::INFINITY });
        }
    }
    rays
}

/// Each primary ray's hit point and shading normal (None for a miss): the start of shadow and bounce rays.
fn hit_points(scene: &Scene, primary: &[Ray]) -> Vec<Option<(Vec3, Vec3)>> {
    primary
        .par_iter()
        .map(|r| {
            let hit = scene.intersect(r.o, r.d, 0.0, f32::INFINITY)?;
            let sp = scene.surface(&hit, r.o, r.d);
            Some((sp.position, sp.shading_normal))
        })
        .collect()
}

/// Rays from every hit point, `make(pixel, x, n, out)` pushing that pixel's rays; pixel order is kept.
fn rays_from_hits(points: &[Option<(Vec3, Vec3)>], make: impl Fn(u32, Vec3, Vec3, &mut Vec<Ray>) + Sync) -> Vec<Ray> {
    let per_pixel: Vec<Vec<Ray>> = points
        .par_iter()
        .enumerate()
        .map(|(pixel, p)| {
            let mut out = Vec::new();
            if let Some((x, n)) = *p {
                make(pixel as u32, x, n, &mut out);
            }
            out
        })
        .collect();
    per_pixel.into_iter().flatten().collect()
}

/// Shadow rays exactly as `backends::kernels::direct::light_sample` casts them.
fn shadow_rays(scene: &Scene, points: &[Option<(Vec3, Vec3)>]) -> Vec<Ray> {
    let light = &scene.lights[0];
    let ln = light.normal();
    let eps = 1e-4 * scene.extent();
    rays_from_hits(points, |pixel, x, n, out| {
        let rng = PixelRng::new(SEED, pixel, 0);
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
    })
}

/// Diffuse-bounce rays: cosine-weighted about the shading normal from the same offset origin as the
/// shadow rays, unbounded. Stream 1 keeps them independent of the shadow rays' stream 0.
fn diffuse_rays(scene: &Scene, points: &[Option<(Vec3, Vec3)>]) -> Vec<Ray> {
    let eps = 1e-4 * scene.extent();
    rays_from_hits(points, |pixel, x, n, out| {
        let rng = PixelRng::new(SEED, pixel, 1);
        let frame = Frame::new(n);
        for s in 0..DIFFUSE_SAMPLES {
            let d = frame.to_world(cosine_hemisphere(Vec2::from(rng.uniform2(s, 0))));
            out.push(Ray { o: x + n * eps, d, tmax: f32::INFINITY });
        }
    })
}

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Closest,
    AnyHit,
}

/// One ray's result in `embree_compare.py`'s convention: closest hit → the input index (`source`) of
/// the hit triangle, any hit → 0 when occluded; −1 for a miss.
#[inline]
fn query(scene: &Scene, r: &Ray, mode: Mode) -> i32 {
    match mode {
        Mode::Closest => {
            scene.intersect(r.o, r.d, 0.0, r.tmax).map_or(-1, |h| scene.triangles[h.triangle as usize].source as i32)
        }
        Mode::AnyHit => -(!scene.occluded(r.o, r.d, 0.0, r.tmax) as i32),
    }
}

/// The timed loop: each ray's hit as the tracer returns it (`Hit::triangle`, the scene's own index,
/// as Embree returns its own `primID`), folded into a hash so no query is optimised away. Mapping a
/// hit to its input index (`query`) loads the hit's triangle record — a cache miss per hit on big
/// scenes that Embree's side does not pay — so it is left to the untimed [`checksum`].
fn trace(scene: &Scene, rays: &[Ray], mode: Mode) -> u64 {
    rays.par_chunks(CHUNK)
        .map(|chunk| {
            let mut hash = 0u64;
            for r in chunk {
                let q = match mode {
                    Mode::Closest => scene.intersect(r.o, r.d, 0.0, r.tmax).map_or(u64::MAX, |h| u64::from(h.triangle)),
                    Mode::AnyHit => scene.occluded(r.o, r.d, 0.0, r.tmax) as u64,
                };
                hash = hash.wrapping_add(q);
            }
            hash
        })
        .reduce(|| 0, u64::wrapping_add)
}

/// (hits, order-independent hash of the hit triangles' input indices; 0 for any-hit rays): the
/// table's checksum, the same for every tree over the same triangles.
fn checksum(scene: &Scene, rays: &[Ray], mode: Mode) -> (u64, u64) {
    results(scene, rays, mode).iter().filter(|&&q| q >= 0).fold((0, 0), |(hits, hash), &q| {
        let src = q as u64;
        (hits + 1, hash.wrapping_add(src.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (src >> 3)))
    })
}

/// Median of `v` (sorted in place; NaN last); NaN for an empty slice.
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
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
        while passes == 0 || start.elapsed() < min {
            std::hint::black_box(trace(scene, rays, mode));
            passes += 1;
        }
        let secs = start.elapsed().as_secs_f64();
        Cell { mrays: rays.len() as f64 * passes as f64 / secs / 1e6, passes, check: checksum(scene, rays, mode) }
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

/// `primary.gbuffer` and `direct.light` (`SHADOW_SAMPLES` independent samples toward light 0) on the
/// built-in `scene` at W×H: the passes whose rays the bare primary and shadow rows trace.
fn pass_session(scene: &str) -> wedge::Session {
    let text = format!(
        r#"Pipeline(scene: "builtin:{scene}", width: {W}, height: {H}, seed: 1, nodes: [
    (name: "primary", kind: "Primary"),
    (name: "mc", kind: "MonteCarlo", params: {{"spp": {SHADOW_SAMPLES}, "sampling": "independent", "light": 0}},
     inputs: {{"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo"}}),
    (name: "out", kind: "Output", inputs: {{"color": "mc.radiance"}}),
])"#
    );
    let loaded = wedge::graph::parse_pipeline(Path::new("passes.ron"), &text).expect("bench pipeline parses");
    let (nodes, kernels) = wedge::effects::builtin();
    wedge::Session::build(loaded, &Default::default(), nodes, kernels).expect("bench session")
}

/// Seconds of the passes of `kernels` on one persistent CPU backend with `threads` threads: the first
/// frame's, and the median over the later frames (at least one, then until `min` has passed).
struct PassTimes {
    first: [f64; 2],
    later: [f64; 2],
    frames: usize,
}

fn pass_times(session: &wedge::Session, threads: usize, kernels: [&str; 2], min: Duration) -> PassTimes {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    let mut backend = CpuBackend::new();
    let mut run = || {
        let r = pool.install(|| session.run(&mut backend, &Silent)).expect("bench run");
        kernels.map(|k| r.timings.iter().filter(|t| t.kernel == k).map(|t| t.seconds).sum::<f64>())
    };
    let first = run();
    let (start, mut later) = (Instant::now(), Vec::new());
    while later.is_empty() || start.elapsed() < min {
        later.push(run());
    }
    let frames = later.len() + 1;
    let column = |k: usize| median(&mut later.iter().map(|t| t[k]).collect::<Vec<_>>());
    PassTimes { first, later: [column(0), column(1)], frames }
}

/// One row of the build table.
struct BuildRow {
    builder: &'static str,
    best: Duration,
    runs: u32,
    nodes: usize,
    /// Wide nodes plus the triangle packs their leaves reference.
    node_bytes: usize,
    refs: usize,
    depth: usize,
    /// Closest-hit primary and diffuse-bounce rays per second through this tree, one thread: medians
    /// of `repeats` measurements interleaved over the builders (a single run moved by up to 45%).
    primary_mrays: f64,
    diffuse_mrays: f64,
}

/// Closest-hit rays per second through `bvh` with slab test `simd` on this thread, over ≥ `min`.
fn trace_rate(bvh: &wedge::scene::bvh::Bvh, simd: Simd, rays: &[Ray], min: Duration) -> f64 {
    let (start, mut passes) = (Instant::now(), 0u64);
    while passes == 0 || start.elapsed() < min {
        let hits = rays
            .iter()
            .filter(|r| wedge::scene::bvh::traverse_simd(bvh, simd, r.o, r.d, 0.0, r.tmax, false).is_some())
            .count();
        std::hint::black_box(hits);
        passes += 1;
    }
    (rays.len() as u64 * passes) as f64 / start.elapsed().as_secs_f64() / 1e6
}

/// Time `bvh::build` and obvhs presets on `input`: best of the runs in ≥ `min` (at least one), since
/// other work on the machine only ever makes a build slower; then trace `primary` and `diffuse` through
/// every tree, `repeats` times round-robin, so a slow moment of the machine hits all trees alike.
fn build_table(input: &[[Vec3; 3]], primary: &[Ray], diffuse: &[Ray], min: Duration, repeats: usize) -> Vec<BuildRow> {
    use obvhs::BvhBuildParams as P;
    use wedge::scene::bvh::build::{binary_obvhs, collapse_greedy};
    use wedge::scene::bvh::{build, build_with, Bvh, TriangleRecord};
    let best = Simd::best();
    let builders: [(&'static str, &dyn Fn() -> wedge::scene::bvh::BuiltBvh, Simd); 8] = [
        ("fast_build, greedy collapse (before)", &|| collapse_greedy(&binary_obvhs(input, P::fast_build())), best),
        ("fastest_build", &|| build_with(input, P::fastest_build()), best),
        ("very_fast_build", &|| build_with(input, P::very_fast_build()), best),
        ("fast_build", &|| build_with(input, P::fast_build()), best),
        ("medium_build", &|| build_with(input, P::medium_build()), best),
        ("slow_build (spatial splits)", &|| build_with(input, P::slow_build()), best),
        ("bvh::build (scenes)", &|| build(input), best),
        ("bvh::build (scenes), portable slab test", &|| build(input), Simd::Portable),
    ];
    let trees: Vec<(BuildRow, Bvh, Simd)> = builders
        .iter()
        .map(|&(builder, run, simd)| {
            let (start, mut runs, mut best) = (Instant::now(), 0, Duration::MAX);
            let mut built = None;
            while runs == 0 || start.elapsed() < min {
                let t = Instant::now();
                built = Some(run());
                best = best.min(t.elapsed());
                runs += 1;
            }
            let built = built.unwrap();
            // Trace this tree as a scene would (triangles in its order, leaves packed), one thread.
            let records: Vec<TriangleRecord> = built
                .order
                .iter()
                .map(|&i| {
                    let t = input[i as usize];
                    TriangleRecord::new(t[0], t[1], t[2], 0, i)
                })
                .collect();
            let (nodes, depth, refs) = (built.nodes.len(), built.depth, built.order.len());
            let bvh = Bvh::pack(built.nodes, &records);
            let row = BuildRow {
                builder,
                best,
                runs,
                nodes,
                node_bytes: bvh.bytes(),
                refs,
                depth,
                primary_mrays: 0.0,
                diffuse_mrays: 0.0,
            };
            (row, bvh, simd)
        })
        .collect();
    let mut rates = vec![(Vec::new(), Vec::new()); trees.len()];
    for _ in 0..repeats {
        for (k, (_, bvh, simd)) in trees.iter().enumerate() {
            rates[k].0.push(trace_rate(bvh, *simd, primary, min));
            rates[k].1.push(trace_rate(bvh, *simd, diffuse, min));
        }
    }
    trees
        .into_iter()
        .zip(rates)
        .map(|((row, _, _), (mut p, mut d))| BuildRow {
            primary_mrays: median(&mut p),
            diffuse_mrays: median(&mut d),
            ..row
        })
        .collect()
}

/// The interpreter for the Embree side, or why the comparison is skipped.
fn embree_python() -> Result<String, String> {
    let python = std::env::var("WEDGE_BENCH_PYTHON").unwrap_or_else(|_| "python3".into());
    match Command::new(&python).args(["-c", "import embreex"]).output() {
        Err(e) => Err(format!("cannot run `{python}`: {e}")),
        Ok(out) if !out.status.success() => {
            let err = String::from_utf8_lossy(&out.stderr);
            let last = err.lines().last().unwrap_or("no message").trim().to_string();
            Err(format!("`{python} -c 'import embreex'` failed: {last} (`pip install embreex` enables it)"))
        }
        Ok(_) => Ok(python),
    }
}

/// Traversal work per ray: (wide nodes, triangle packs) tested, averaged over `rays`.
fn traversal_work(scene: &Scene, rays: &[Ray], mode: Mode) -> (f64, f64) {
    use wedge::scene::bvh::traverse::{traverse_counted, TraversalStats};
    let mut stats = TraversalStats::default();
    for r in rays {
        traverse_counted(&scene.bvh, r.o, r.d, 0.0, r.tmax, mode == Mode::AnyHit, &mut stats);
    }
    let n = rays.len().max(1) as f64;
    (stats.nodes as f64 / n, stats.packs as f64 / n)
}

/// One ray set for the Embree side: rays plus wedge's per-ray result for each query run on them.
struct RaySet<'a> {
    name: &'static str,
    rays: &'a [Ray],
    queries: Vec<(Mode, Vec<i32>)>,
}

/// Write the file `benches/embree_compare.py` documents (little-endian, no padding).
fn write_rays(path: &Path, input: &[[Vec3; 3]], sets: &[RaySet]) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    let u32s = |w: &mut dyn Write, v: u32| w.write_all(&v.to_le_bytes());
    let f32s = |w: &mut dyn Write, vs: &[f32]| vs.iter().try_for_each(|v| w.write_all(&v.to_le_bytes()));
    w.write_all(b"WEDGERAY")?;
    u32s(&mut w, 1)?;
    u32s(&mut w, input.len() as u32)?;
    for t in input {
        for v in t {
            f32s(&mut w, &v.to_array())?;
        }
    }
    u32s(&mut w, sets.len() as u32)?;
    for set in sets {
        let mut name = [0u8; 16];
        name[..set.name.len()].copy_from_slice(set.name.as_bytes());
        w.write_all(&name)?;
        u32s(&mut w, set.rays.len() as u32)?;
        for r in set.rays {
            f32s(&mut w, &r.o.to_array())?;
        }
        for r in set.rays {
            f32s(&mut w, &r.d.to_array())?;
        }
        for r in set.rays {
            f32s(&mut w, &[r.tmax])?;
        }
        u32s(&mut w, set.queries.len() as u32)?;
        for (mode, results) in &set.queries {
            u32s(&mut w, (*mode == Mode::AnyHit) as u32)?;
            results.iter().try_for_each(|q| w.write_all(&q.to_le_bytes()))?;
        }
    }
    w.flush()
}

/// Trace `sets` with Embree through `embree_compare.py`; its parsed JSON output.
fn embree_compare(
    python: &str,
    scene: &str,
    input: &[[Vec3; 3]],
    sets: &[RaySet],
    min: Duration,
) -> Result<serde_json::Value, String> {
    let path: PathBuf = std::env::temp_dir().join(format!("wedge-embree-{}-{scene}.bin", std::process::id()));
    let written = write_rays(&path, input, sets).map_err(|e| format!("writing {}: {e}", path.display()));
    let out = written.and_then(|()| {
        Command::new(python)
            .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/benches/embree_compare.py"))
            .arg(&path)
            .arg(min.as_secs_f64().to_string())
            .output()
            .map_err(|e| format!("running {python}: {e}"))
    });
    let _ = std::fs::remove_file(&path);
    let out = out?;
    if !out.status.success() {
        return Err(format!("embree_compare.py failed: {}", String::from_utf8_lossy(&out.stderr).trim()));
    }
    serde_json::from_slice(&out.stdout).map_err(|e| format!("embree_compare.py printed no JSON: {e}"))
}

/// Per-ray results of `rays` under `mode` (for the Embree side's agreement count).
fn results(scene: &Scene, rays: &[Ray], mode: Mode) -> Vec<i32> {
    rays.par_iter().map(|r| query(scene, r, mode)).collect()
}

/// `scene`'s triangles in their input order (`source`) where they are at time `t`.
fn loose(scene: &Scene, t: f32) -> Vec<(Vec3, Vec3, Vec3, wedge::scene::TriangleShading)> {
    let mut order: Vec<usize> = (0..scene.triangles.len()).collect();
    order.sort_by_key(|&i| scene.triangles[i].source);
    order.dedup_by_key(|i| scene.triangles[*i].source);
    order
        .iter()
        .map(|&i| {
            let (r, s) = (&scene.triangles[i], scene.shading[i]);
            let v = match scene.instance_of(s.object) {
                Some(inst) => {
                    let xf = inst.prepared.at(t);
                    r.vertices().map(|p| xf.point(p))
                }
                None => r.vertices(),
            };
            (v[0], v[1], v[2], s)
        })
        .collect()
}

/// `scene` with every object where it is at time `t`, all at rest: the same triangles in one static
/// tree (what tracing would cost without motion support).
fn frozen(scene: &Scene, t: f32) -> Scene {
    let objects = scene.objects.iter().map(|o| SceneObject::named(o.name.clone())).collect();
    let name = format!("{} frozen", scene.name);
    Scene::from_objects(&name, loose(scene, t), scene.materials.clone(), scene.textures.clone(), scene.camera, objects)
        .expect("frozen scene")
}

/// `scene` (all at rest) with objects 1..=n each moving by its own 1 cm translation (n instances).
fn with_moving(scene: &Scene, n: usize) -> Scene {
    let objects = scene
        .objects
        .iter()
        .enumerate()
        .map(|(k, o)| SceneObject {
            motion: (1..=n)
                .contains(&k)
                .then(|| RigidMotion::translation(Vec3::ZERO, Vec3::new(0.01, 0.0, 0.01 * (k as f32 / n as f32)))),
            ..SceneObject::named(o.name.clone())
        })
        .collect();
    Scene::from_objects(
        &scene.name,
        loose(scene, 0.0),
        scene.materials.clone(),
        scene.textures.clone(),
        scene.camera,
        objects,
    )
    .expect("moving scene")
}

/// Per ray a time in [−1, 1) (stream 2 of the bench's per-pixel RNG, keyed by the ray's index).
fn ray_times(n: usize) -> Vec<f32> {
    (0..n).map(|i| -1.0 + 2.0 * PixelRng::new(SEED, i as u32, 2).uniform(0, 0)).collect()
}

/// Rays per second of `trace(ray index)` over `rays` (≥ `min`, at least one pass), and the hits.
fn measure_timed(
    pool: &rayon::ThreadPool,
    n: usize,
    min: Duration,
    trace: &(dyn Fn(usize) -> bool + Sync),
) -> (f64, u64) {
    pool.install(|| {
        let start = Instant::now();
        let (mut passes, mut hits) = (0u64, 0u64);
        while passes == 0 || start.elapsed() < min {
            hits = (0..n).into_par_iter().with_min_len(CHUNK).filter(|&i| trace(i)).count() as u64;
            passes += 1;
        }
        (n as f64 * passes as f64 / start.elapsed().as_secs_f64() / 1e6, hits)
    })
}

/// One row of the motion table: (rays, query, times, threads, Mrays/s with motion, frozen, hits each).
type MotionRow = (&'static str, &'static str, &'static str, usize, f64, f64, u64, u64);

/// The motion tables (see the module doc): `motion` vs frozen, and instance-count scaling on `spheres`.
fn motion_tables(min: Duration, smoke: bool) -> (Vec<MotionRow>, Vec<(usize, f64, u64)>, String) {
    let scene = wedge::scene::load(&SceneSource::Builtin("motion".into())).expect("motion scene");
    let still = frozen(&scene, 0.0);
    let info = format!(
        "`motion`: {} triangles, {} moving instances ({} of {} triangles move); frozen: one static tree",
        scene.triangle_count(),
        scene.instances.len(),
        scene.instances.iter().map(|i| i.count).sum::<u32>(),
        scene.triangle_count()
    );
    let primary = primary_rays(&still);
    let points = hit_points(&still, &primary);
    let shadow = shadow_rays(&still, &points);
    let mut rows = Vec::new();
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        for (name, rays, any) in [("primary", &primary, false), ("shadow", &shadow, true)] {
            let times = ray_times(rays.len());
            let query = |s: &Scene, i: usize, t: f32| {
                let (r, at) = (&rays[i], s.at(t));
                if any {
                    at.occluded(r.o, r.d, 0.0, r.tmax)
                } else {
                    at.intersect(r.o, r.d, 0.0, r.tmax).is_some()
                }
            };
            let q = if any { "any" } else { "closest" };
            let (m0, h0) = measure_timed(&pool, rays.len(), min, &|i| query(&scene, i, 0.0));
            let (f0, g0) = measure_timed(&pool, rays.len(), min, &|i| query(&still, i, 0.0));
            rows.push((name, q, "t = 0", threads, m0, f0, h0, g0));
            let (mt, ht) = measure_timed(&pool, rays.len(), min, &|i| query(&scene, i, times[i]));
            let (ft, gt) = measure_timed(&pool, rays.len(), min, &|i| query(&still, i, times[i]));
            rows.push((name, q, "random t", threads, mt, ft, ht, gt));
        }
    }
    let mut scaling = Vec::new();
    if !smoke {
        let spheres = wedge::scene::load(&SceneSource::Builtin("spheres".into())).expect("spheres scene");
        let primary = primary_rays(&spheres);
        let times = ray_times(primary.len());
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        for n in [0usize, 1, 10, 100, 400] {
            let s = with_moving(&spheres, n);
            assert_eq!(s.instances.len(), n);
            let (m, h) = measure_timed(&pool, primary.len(), min, &|i| {
                let r = &primary[i];
                s.at(times[i]).intersect(r.o, r.d, 0.0, r.tmax).is_some()
            });
            scaling.push((n, m, h));
        }
    }
    (rows, scaling, info)
}

/// What to measure: `--bench` and the `WEDGE_BENCH_*` variables (see the module doc).
struct Settings {
    /// No `--bench`: the test suite's quick run (grids, one pass per cell, no Embree).
    smoke: bool,
    scenes: Vec<String>,
    /// Minimum timed duration per cell.
    min: Duration,
    /// Repetitions of the Embree comparison and of the build table's traversal rates.
    repeats: usize,
    /// `WEDGE_BENCH_ONLY=passes`: the bare rows and the "passes vs bare traversal" table only.
    only_passes: bool,
}

impl Settings {
    /// Read the command line and the environment.
    fn from_env() -> Settings {
        // `cargo bench` passes `--bench`; accept and ignore libtest-style arguments.
        // `cargo test --all-targets` runs this binary without `--bench`: then only a quick smoke run
        // (grids, one pass per cell, no Embree) so the test suite checks it works without paying for the
        // numbers or needing Python.
        let smoke = !std::env::args().any(|a| a == "--bench");
        let scenes: Vec<String> = std::env::var("WEDGE_BENCH_SCENES")
            .unwrap_or_else(|_| if smoke { "grids".into() } else { "grids,heavy,spheres".into() })
            .split(',')
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty())
            .collect();
        let min = Duration::from_secs_f64(
            std::env::var("WEDGE_BENCH_MIN_SECS").ok().and_then(|s| s.parse().ok()).unwrap_or(if smoke {
                0.0
            } else {
                1.0
            }),
        );
        let repeats: usize = std::env::var("WEDGE_BENCH_REPEATS").ok().and_then(|s| s.parse().ok()).unwrap_or(3).max(1);
        let only_passes = std::env::var("WEDGE_BENCH_ONLY").as_deref() == Ok("passes");
        Settings { smoke, scenes, min, repeats, only_passes }
    }
}

/// The report's title and setup lines; returns the machine's thread count (the build table's heading)
/// and the interpreter for the Embree side, or why that comparison is skipped.
fn print_header(settings: &Settings) -> (usize, Result<String, String>) {
    let (nproc, model) = machine_info();
    println!("# wedge ray throughput\n");
    println!("- machine: {model}, nproc = {nproc}");

    println!(
        "- image {W}×{H}, {SHADOW_SAMPLES} shadow rays toward light 0 and {DIFFUSE_SAMPLES} diffuse-bounce rays per primary hit, ≥{:.1} s per cell",
        settings.min.as_secs_f64()
    );
    let python = if settings.smoke {
        Err("smoke run (no `--bench`)".to_string())
    } else if settings.only_passes {
        Err("WEDGE_BENCH_ONLY=passes".to_string())
    } else {
        embree_python()
    };
    match &python {
        Ok(p) => println!("- Embree side: `{p}` with embreex (benches/embree_compare.py)\n"),
        Err(why) => println!("- Embree comparison skipped: {why}\n"),
    }
    (nproc, python)
}

/// A loaded scene and the rays every table traces through it, generated once so only traversal is timed.
struct SceneRays {
    name: String,
    scene: Scene,
    /// The builder's input triangles, in their input order.
    input: Vec<[Vec3; 3]>,
    /// Bytes of one triangle record (the build table's total memory).
    record_bytes: usize,
    primary: Vec<Ray>,
    shadow: Vec<Ray>,
    diffuse: Vec<Ray>,
}

impl SceneRays {
    /// Load the built-in scene `name` (None, said on stderr, when it does not load), print its line of
    /// the report's header, and generate its primary, shadow and diffuse rays.
    fn load(name: &str) -> Option<SceneRays> {
        let t = Instant::now();
        let scene = match wedge::scene::load(&SceneSource::Builtin(name.to_string())) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("skipping {name}: {e}");
                return None;
            }
        };
        let load = t.elapsed();
        // The builder's input order recovered from `source`, to time just the builder (and to hand
        // Embree the same triangles in the same order, so its primID is wedge's `source`).
        let n_input = scene.triangles.iter().map(|t| t.source as usize + 1).max().unwrap_or(0);
        let mut input = vec![[Vec3::ZERO; 3]; n_input];
        for t in &scene.triangles {
            input[t.source as usize] = t.vertices();
        }
        println!(
            "- `{name}`: {n_input} input triangles, {} triangle references in the scene; load {:.0} ms",
            scene.triangles.len(),
            load.as_secs_f64() * 1e3
        );
        let record_bytes = std::mem::size_of_val(&scene.triangles[0]);
        let primary = primary_rays(&scene);
        let points = hit_points(&scene, &primary);
        let shadow = shadow_rays(&scene, &points);
        let diffuse = diffuse_rays(&scene, &points);
        Some(SceneRays { name: name.to_string(), scene, input, record_bytes, primary, shadow, diffuse })
    }

    /// The four (rays, query) kinds of the bare rows, the work table and the Embree comparison, in
    /// their column order: primary closest, shadow any-hit, shadow closest, diffuse closest.
    fn kinds(&self) -> [(&'static str, &'static str, &[Ray], Mode); 4] {
        [
            ("primary", "closest", &self.primary, Mode::Closest),
            ("shadow", "any", &self.shadow, Mode::AnyHit),
            ("shadow", "closest", &self.shadow, Mode::Closest),
            ("diffuse", "closest", &self.diffuse, Mode::Closest),
        ]
    }
}

/// A bare-traversal row: (scene, threads, ray counts (primary, shadow, diffuse), primary closest,
/// shadow any-hit, shadow closest, diffuse closest cells).
type BareRow = (String, usize, [usize; 3], Cell, Cell, Cell, Cell);
/// A "passes vs bare traversal" row: (scene, threads, ray counts (primary, shadow), pass times).
type PassRow = (String, usize, [usize; 2], PassTimes);
/// A traversal-work row: the scene and, per ray kind, (rays, query, (nodes, packs) per ray).
type WorkRow = (String, [(&'static str, &'static str, (f64, f64)); 4]);
/// One Embree repetition: its JSON output and wedge's 1-thread (rays, query, Mrays/s, hits) per kind.
type EmbreeRep = (serde_json::Value, [(&'static str, &'static str, f64, u64); 4]);

/// Everything measured on the scenes, one list per table, in scene order.
#[derive(Default)]
struct Measured {
    rows: Vec<BareRow>,
    builds: Vec<(String, usize, Vec<BuildRow>)>,
    embree: Vec<(String, Vec<EmbreeRep>)>,
    work: Vec<WorkRow>,
    passes: Vec<PassRow>,
}

impl Measured {
    /// Measure one scene for every table: build table, passes, bare cells, traversal work, Embree.
    fn scene(&mut self, s: &SceneRays, settings: &Settings, python: &Result<String, String>) {
        let (name, min) = (&s.name, settings.min);
        if !settings.only_passes {
            let table = build_table(&s.input, &s.primary, &s.diffuse, min, settings.repeats);
            self.builds.push((name.clone(), s.record_bytes, table));
        }
        let session = pass_session(name);
        // The smoke run checks the table works on one thread count: each run traces ~5 M rays.
        for &threads in if settings.smoke { &[2usize][..] } else { &[1, 2] } {
            let t = pass_times(&session, threads, ["primary.gbuffer", "direct.light"], min);
            self.passes.push((name.clone(), threads, [s.primary.len(), s.shadow.len()], t));
        }
        drop(session);
        let counts = [s.primary.len(), s.shadow.len(), s.diffuse.len()];
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let [p, sh, c, d] = s.kinds().map(|(.., rays, mode)| measure(&pool, &s.scene, rays, mode, min));
            self.rows.push((name.clone(), threads, counts, p, sh, c, d));
        }
        self.work
            .push((name.clone(), s.kinds().map(|(r, q, rays, mode)| (r, q, traversal_work(&s.scene, rays, mode)))));
        if let Ok(py) = python {
            let reps = embree_reps(py, s, settings);
            if !reps.is_empty() {
                self.embree.push((name.clone(), reps));
            }
        }
    }
}

/// Embree's side (issue 12): `repeats` interleaved repetitions of wedge's four 1-thread cells and then
/// Embree on the same rays; stops at the first failure (printed), so empty when none succeeded.
fn embree_reps(python: &str, s: &SceneRays, settings: &Settings) -> Vec<EmbreeRep> {
    let sets = [
        RaySet {
            name: "primary",
            rays: &s.primary,
            queries: vec![(Mode::Closest, results(&s.scene, &s.primary, Mode::Closest))],
        },
        RaySet {
            name: "shadow",
            rays: &s.shadow,
            queries: vec![
                (Mode::AnyHit, results(&s.scene, &s.shadow, Mode::AnyHit)),
                (Mode::Closest, results(&s.scene, &s.shadow, Mode::Closest)),
            ],
        },
        RaySet {
            name: "diffuse",
            rays: &s.diffuse,
            queries: vec![(Mode::Closest, results(&s.scene, &s.diffuse, Mode::Closest))],
        },
    ];
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let mut reps = Vec::new();
    for _ in 0..settings.repeats {
        let wedge_1t = s.kinds().map(|(r, q, rays, mode)| (r, q, measure(&pool, &s.scene, rays, mode, settings.min)));
        match embree_compare(python, &s.name, &s.input, &sets, settings.min) {
            Ok(json) => reps.push((json, wedge_1t.map(|(r, q, c)| (r, q, c.mrays, c.check.0)))),
            Err(e) => {
                println!("- `{}`: Embree comparison failed: {e}", s.name);
                break;
            }
        }
    }
    reps
}

/// Multi-bounce path throughput (`Indirect`'s sampler) on `cornell`: image size, paths per pixel, and
/// per bounce count and thread count (Mrays/s, Mpaths/s, rays per path).
struct PathRows {
    size: (u32, u32),
    spp: u32,
    rows: Vec<(u32, usize, (f64, f64, f64))>,
}

impl PathRows {
    /// 1, 2 and 3 bounces at 1 and 2 threads (a small image and one path per pixel in the smoke run).
    fn measure(settings: &Settings) -> PathRows {
        let (size, spp) = if settings.smoke { ((32, 24), 1) } else { ((320, 240), 16) };
        let mut rows = Vec::new();
        for bounces in [1u32, 2, 3] {
            for threads in [1usize, 2] {
                rows.push((bounces, threads, paths(threads, bounces, size, spp, settings.min)));
            }
        }
        PathRows { size, spp, rows }
    }

    /// The paths table.
    fn print(&self) {
        let (size, spp) = (self.size, self.spp);
        println!();
        println!("Paths on `cornell` ({}×{}, {spp} paths per pixel and component; `indirect.sample`, next-event estimation at every vertex):\n", size.0, size.1);
        println!("| bounces | threads | Mrays/s (bounce + shadow) | rays per path | Mpaths/s |");
        println!("|---:|---:|---:|---:|---:|");
        for (bounces, threads, (mrays, mpaths, per)) in &self.rows {
            println!("| {bounces} | {threads} | {mrays:.2} | {per:.2} | {mpaths:.3} |");
        }
    }
}

/// Setup and the report's header, every scene measured, motion and paths measured, then the tables.
fn main() {
    let settings = Settings::from_env();
    let (nproc, python) = print_header(&settings);
    let mut measured = Measured::default();
    for name in &settings.scenes {
        if let Some(scene) = SceneRays::load(name) {
            measured.scene(&scene, &settings, &python);
        }
    }
    if settings.only_passes {
        pass_table(&measured.passes, &measured.rows);
        return;
    }
    let motion = (std::env::var("WEDGE_BENCH_MOTION").as_deref() != Ok("0"))
        .then(|| motion_tables(settings.min, settings.smoke));
    let paths = PathRows::measure(&settings);
    bare_table(&measured.rows);
    pass_table(&measured.passes, &measured.rows);
    work_table(&measured.work);
    builds_table(&measured.builds, nproc, &settings);
    if !measured.embree.is_empty() {
        embree_table(&measured.embree, settings.repeats);
    }
    if let Some((rows, scaling, info)) = motion {
        motion_table(&rows, &info);
        if !scaling.is_empty() {
            scaling_table(&scaling);
        }
    }
    paths.print();
}

/// The main table: rays per second of each bare ray kind, its pass counts and checksums.
fn bare_table(rows: &[BareRow]) {
    println!();
    println!("| scene | threads | primary Mrays/s | shadow (any-hit) Mrays/s | shadow (closest) Mrays/s | diffuse Mrays/s | rays (primary / shadow / diffuse) | passes | checksum |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---|");
    for (name, threads, [np, ns, nd], p, s, c, d) in rows {
        println!(
            "| {name} | {threads} | {:.2} | {:.2} | {:.2} | {:.2} | {np} / {ns} / {nd} | {}/{}/{}/{} | p {}:{:x} s {} c {}:{:x} d {}:{:x} |",
            p.mrays,
            s.mrays,
            c.mrays,
            d.mrays,
            p.passes,
            s.passes,
            c.passes,
            d.passes,
            p.check.0,
            p.check.1,
            s.check.0,
            c.check.0,
            c.check.1,
            d.check.0,
            d.check.1
        );
    }
}

/// The "passes vs bare traversal" table: each pass's rays per second (first frame, later frames of a
/// persistent backend) beside the bare rate of the same rays at the same thread count.
fn pass_table(passes: &[PassRow], rows: &[BareRow]) {
    println!();
    println!("Passes vs bare traversal (one persistent `CpuBackend`; first frame apart from the median of the later ones; goal: later / bare ≥ 0.8):\n");
    println!("| scene | threads | pass | rays | bare Mrays/s | pass first frame Mrays/s | pass later frames Mrays/s | later / bare | frames |");
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|");
    for (name, threads, counts, t) in passes {
        let Some((.., p, s, _, _)) = rows.iter().find(|r| r.0 == *name && r.1 == *threads) else { continue };
        for (k, (pass, bare)) in
            [("primary.gbuffer (closest)", p), ("direct.light (any-hit)", s)].into_iter().enumerate()
        {
            let rate = |secs: f64| counts[k] as f64 / secs / 1e6;
            println!(
                "| {name} | {threads} | {pass} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {} |",
                counts[k],
                bare.mrays,
                rate(t.first[k]),
                rate(t.later[k]),
                rate(t.later[k]) / bare.mrays,
                t.frames
            );
        }
    }
}

/// Wide nodes and triangle packs tested per ray, per scene and ray kind.
fn work_table(work: &[WorkRow]) {
    println!();
    println!("Traversal work per ray (8-wide nodes whose boxes were tested, 4-triangle packs tested):\n");
    println!("| scene | rays | query | nodes / ray | packs / ray |");
    println!("|---|---|---|---:|---:|");
    for (name, kinds) in work {
        for (rays, query, (nodes, packs)) in kinds {
            println!("| {name} | {rays} | {query} | {nodes:.1} | {packs:.1} |");
        }
    }
}

/// The BVH build table: per scene and builder, build time, tree size and memory, and its trace rates.
fn builds_table(builds: &[(String, usize, Vec<BuildRow>)], nproc: usize, settings: &Settings) {
    let (min, repeats) = (settings.min, settings.repeats);
    println!();
    println!("BVH builds ({nproc} threads; best of the runs in ≥{:.1} s). Memory: BVH = wide nodes + triangle packs; total adds one triangle record per reference. Primary, diffuse: closest-hit Mrays/s through that tree, 1 thread, a tight loop without the main table's harness (medians of {repeats} measurements interleaved over the trees):\n", min.as_secs_f64());
    println!("| scene | builder | build ms | runs | nodes | depth | BVH MiB | references | total MiB | primary Mrays/s | diffuse Mrays/s |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (name, record_bytes, table) in builds {
        for b in table {
            let mib = |bytes: usize| bytes as f64 / (1 << 20) as f64;
            println!(
                "| {name} | {} | {:.1} | {} | {} | {} | {:.2} | {} | {:.2} | {:.2} | {:.2} |",
                b.builder,
                b.best.as_secs_f64() * 1e3,
                b.runs,
                b.nodes,
                b.depth,
                mib(b.node_bytes),
                b.refs,
                mib(b.node_bytes + b.refs * record_bytes),
                b.primary_mrays,
                b.diffuse_mrays
            );
        }
    }
}

/// The Embree table: medians over the repetitions of Embree's and wedge's 1-thread rates, the ratio's
/// range, hit counts and agreement; then each scene's Embree build line.
fn embree_table(embree: &[(String, Vec<EmbreeRep>)], repeats: usize) {
    println!();
    println!(
        "Against Embree 4 (embreex `rtcIntersect1`/`rtcOccluded1`, one thread; Embree's build uses every core); \
         medians of {repeats} interleaved repetitions, the ratio's range in brackets:\n"
    );
    println!("| scene | rays | query | Embree Mrays/s | wedge 1-thread Mrays/s | wedge/Embree (range) | hits Embree | hits wedge | rays agreeing | Embree CPU/wall |");
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for (name, reps) in embree {
        embree_rows(name, reps);
    }
    println!();
    for (name, reps) in embree {
        let json = &reps[0].0;
        println!(
            "- `{name}`: Embree build (rtcCommitScene, quality high, {} threads) {:.0} ms; embreex {}",
            json["embree"]["cpus"],
            json["build_seconds"].as_f64().unwrap_or(f64::NAN) * 1e3,
            json["embree"]["embreex"].as_str().unwrap_or("?")
        );
    }
}

/// One scene's rows of the Embree table, one per ray kind Embree reported in the first repetition.
fn embree_rows(name: &str, reps: &[EmbreeRep]) {
    let (first, wedge_first) = &reps[0];
    for (k, (set, q, _, hits)) in wedge_first.iter().enumerate() {
        let embree_result = |json: &serde_json::Value| {
            json["results"].as_array().into_iter().flatten().find(|r| r["set"] == *set && r["query"] == *q).cloned()
        };
        let Some(r) = embree_result(first) else {
            continue;
        };
        let mut e: Vec<f64> =
            reps.iter().map(|(j, _)| embree_result(j).and_then(|r| r["mrays"].as_f64()).unwrap_or(f64::NAN)).collect();
        let mut w: Vec<f64> = reps.iter().map(|(_, cells)| cells[k].2).collect();
        let mut ratio: Vec<f64> = w.iter().zip(&e).map(|(w, e)| w / e).collect();
        let (lo, hi) = ratio.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        println!(
            "| {name} | {set} | {q} | {:.2} | {:.2} | {:.2} ({lo:.2}–{hi:.2}) | {} | {hits} | {} / {} | {:.2} |",
            median(&mut e),
            median(&mut w),
            median(&mut ratio),
            r["hits"],
            r["agree"],
            r["rays"],
            r["cpu_per_wall"].as_f64().unwrap_or(f64::NAN)
        );
    }
}

/// The motion table: `motion` through its moving instances against the same scene frozen.
fn motion_table(rows: &[MotionRow], info: &str) {
    println!();
    println!("Motion: rays through moving instances (`Scene::at(t)`) vs the same scene frozen at t = 0 into one static tree — {info}:\n");
    println!("| rays | query | time | threads | motion Mrays/s | frozen Mrays/s | motion / frozen | hits (motion / frozen) |");
    println!("|---|---|---|---:|---:|---:|---:|---:|");
    for (rays, q, time, threads, m, f, hm, hf) in rows {
        println!("| {rays} | {q} | {time} | {threads} | {m:.2} | {f:.2} | {:.2} | {hm} / {hf} |", m / f);
    }
}

/// The instance-scaling table: primary rays on `spheres` with N moving instances against N = 0.
fn scaling_table(scaling: &[(usize, f64, u64)]) {
    println!();
    println!("Instances: primary rays on `spheres` (640×480, random time per ray, 1 thread) with N of its 400 spheres moving, each its own instance (the loop over instances is linear):\n");
    println!("| moving instances N | Mrays/s | vs N = 0 | hits |");
    println!("|---:|---:|---:|---:|");
    let base = scaling[0].1;
    for (n, m, h) in scaling {
        println!("| {n} | {m:.2} | {:.2} | {h} |", m / base);
    }
}

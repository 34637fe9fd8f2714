//! The `wedge` command line: render, reference, compare, bench, parity, graph, export-scene.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use wedge::backends::cpu::CpuBackend;
use wedge::graph::ParamValue;
use wedge::image::read_exr;
use wedge::outputs::summary;
use wedge::progress::Bars;
use wedge::session::{open_gpu, RunMode};
use wedge::{Overrides, Session, WedgeError};

#[derive(Parser)]
#[command(name = "wedge", version, about = "Sample-and-filter physically based rendering with axis-aligned filters")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Options every rendering command shares.
#[derive(Args, Clone)]
struct Common {
    /// Scene: a built-in name (`grids`, `curved`, `heavy`, `cornell`, `chess`, `spheres`, `motion`, `envmap`, `envmap_light`, `envmap_real`, `envmap_virtual`, `envmap_far`, and the suite's `suite_slats`, `suite_grate`, `suite_contact`, `suite_near_light`, `suite_textured`, `suite_glossy`, `suite_room`, the defocus suite's `dof_*`, the motion suite's `mo_*`), `builtin:NAME`, or a .gltf/.glb/.obj/.ron file.
    #[arg(long)]
    scene: Option<String>,
    /// Output directory.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Seed of the counter-based sampler (0..=4294967295).
    #[arg(long)]
    seed: Option<u32>,
    /// Image width in pixels (1..=16384; width × height at most 2^26).
    #[arg(long, value_parser = side_parser())]
    width: Option<u32>,
    /// Image height in pixels (1..=16384; width × height at most 2^26).
    #[arg(long, value_parser = side_parser())]
    height: Option<u32>,
    /// Worker threads (default: all cores; at most 4 × the cores). The image does not depend on it.
    #[arg(long, value_parser = parse_threads)]
    threads: Option<usize>,
    /// Refuse a run whose estimated peak memory exceeds SIZE (bytes, or K/M/G/T: 512M, 8G).
    /// Default: 3/4 of the memory available when the run starts.
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    memory_limit: Option<u64>,
    /// Set a node parameter: NODE.PARAM=VALUE (e.g. shadows.max_rays=200). Repeatable.
    #[arg(long = "set", value_name = "NODE.PARAM=VALUE")]
    set: Vec<String>,
    /// Where passes run: `cpu` (rayon) or `wgpu` (WGSL compute on a GPU, or Mesa's software Vulkan).
    #[arg(long, default_value = "cpu", value_parser = ["cpu", "wgpu"])]
    backend: String,
    /// Let the pipeline name files outside its own directory (its scene, environment map, real-layer
    /// maps) and the scene file read buffers, textures and meshes outside its own (symlinks are
    /// followed before the check). `--scene PATH` is never confined.
    #[arg(long = "allow-outside-dir", alias = "allow-outside-scene-dir")]
    allow_outside_dir: bool,
    /// With --backend wgpu: `adapter` (the device's own limits) or `webgpu` (wgpu's
    /// Limits::default(), 8 storage buffers per stage: checks that every kernel runs on any WebGPU
    /// device). Default: the WEDGE_WGPU_LIMITS environment variable, else `adapter`.
    #[arg(long, value_parser = ["adapter", "webgpu"])]
    gpu_limits: Option<String>,
}

#[derive(Subcommand)]
enum Command {
    /// Render a pipeline (default: pipelines/shadows.ron on the built-in `grids` scene).
    Render {
        pipeline: Option<PathBuf>,
        #[command(flatten)]
        common: Common,
        /// Scale every node's bandwidth parameter `mu` (a finite number > 0).
        #[arg(long, value_parser = parse_mu)]
        mu: Option<f64>,
        /// Render frames A to B (both included) of a sequence: the camera follows the pipeline's
        /// `camera_path`, each frame has its own noise, temporal filters see the frame before.
        /// Writes frame_NNNN.exr/png per frame, preview.gif, and the last frame's outputs.
        #[arg(long, value_name = "A..B", value_parser = parse_frames)]
        frames: Option<(u32, u32)>,
        /// Also write per-pixel surface data of the scene seen by the camera at the render's size,
        /// comma-separated: `position` (aov_position.exr, RGBA: world xyz, A = 1 where the ray through
        /// the pixel centre hits geometry, 0 where it misses), `normal` (aov_normal.exr: unit shading
        /// normal), `albedo` (aov_albedo.exr: diffuse k_d with textures) — the maps a mixed-reality
        /// real layer reads. With --frames: one per frame (aov_NAME_NNNN.exr, for `{frame:04}` in a
        /// mixed-reality pipeline's file names) and the last frame's unnumbered.
        #[arg(long, value_name = "NAMES", value_delimiter = ',', value_parser = wedge::aov::AOV_NAMES)]
        aov: Vec<String>,
        /// Progressive rendering: N frames (1..=1000000) with the camera held still, each adding its
        /// paths to what nodes accumulate over frames (PixelFilter, RadianceFilter); writes progressive_NNNN.exr/png
        /// after 1, 2, 4, 8, … frames and the last, each with that frame's full outputs (an
        /// interrupted render keeps the last complete snapshot), and prints the time per frame.
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=MAX_PROGRESSIVE), conflicts_with = "frames")]
        progressive: Option<u32>,
        /// Render only tile I (from 0) of N, with the apron the pipeline's passes need around it, into
        /// --out as tile_IIII_of_NNNN.exr for `wedge merge` (N tiles: a near-square grid).
        #[arg(long, value_name = "I/N", value_parser = wedge::tiles::parse_tile, conflicts_with_all = ["frames", "progressive", "aov"])]
        tile: Option<(u32, u32)>,
        /// With --tile: the grid, C columns by R rows (C × R = N).
        #[arg(long, value_name = "CxR", value_parser = wedge::tiles::parse_grid, requires = "tile")]
        tile_grid: Option<wedge::tiles::Grid>,
    },
    /// Assemble the tile files of `render --tile` in DIR into render.exr/.png (and unfiltered.exr/.png)
    /// in --out, after checking that they belong together and cover the image exactly.
    Merge {
        dir: PathBuf,
        #[arg(long, default_value = "out")]
        out: PathBuf,
    },
    /// Run a render on a cluster's scheduler as tiles and a merge (see `wedge farm slurm --help`).
    Farm {
        #[command(subcommand)]
        farm: Farm,
    },
    /// Plain Monte Carlo reference of the pipeline: its own graph with the filters bypassed, the
    /// per-pixel counts set to --spp and every sampling pass at --spp (`--set` applies as for render).
    Reference {
        pipeline: Option<PathBuf>,
        #[command(flatten)]
        common: Common,
        /// Samples per pixel (per light, per indirect component), 1..=1048576.
        #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=MAX_SPP))]
        spp: u32,
        /// `stratified` (default) or `independent`.
        #[arg(long, default_value = "stratified", value_parser = ["stratified", "independent"])]
        sampling: String,
    },
    /// Compare two EXR images: RMSE, relMSE, PSNR, SMAPE, and an error heatmap.
    Compare {
        test: PathBuf,
        reference: PathBuf,
        /// Where to write the error heatmap PNG.
        #[arg(long, default_value = "out/error.png")]
        heatmap: PathBuf,
    },
    /// Benchmark a pipeline: equal-error speedup vs Monte Carlo, convergence plots, report.md; on its
    /// own scene, on any scene (--scene) or over the built-in scene suite (--suite).
    Bench {
        pipeline: PathBuf,
        /// Small and fast (CI smoke test): 128x96, reference 512 spp, 2 mu values, 3 spp per baseline.
        #[arg(long)]
        quick: bool,
        /// Bench this scene instead of the pipeline's: a built-in name, `builtin:NAME`, or a
        /// .gltf/.glb/.obj/.ron file (as for `render`).
        #[arg(long, conflicts_with_all = ["suite", "suite_scenes"])]
        scene: Option<String>,
        /// Run the bench over the built-in scene suite a node of the pipeline names: the defocus suite
        /// (Defocus: dof_*, each scene's own lens set on the nodes that take a lens), the motion suite
        /// (Motion: mo_*), else the soft-shadow suite (issue 16: grids, suite_slats, suite_grate, suite_contact,
        /// suite_near_light, curved, suite_textured, suite_glossy, cornell, suite_room), each into OUT/SCENE/, and write OUT/suite.md (+ .csv, .json, suite_speedup.png): per scene
        /// rays/px, equal-RMSE speedups, bias/variance, filter overhead; the median and the worst.
        #[arg(long)]
        suite: bool,
        /// With --suite: only these built-ins, comma-separated (e.g. grids,suite_grate).
        #[arg(long, value_name = "NAMES", value_delimiter = ',', requires = "suite")]
        suite_scenes: Vec<String>,
        /// Measure another pipeline beside it (repeatable): on the bench's scene, size, seeds and
        /// reference, in the same tables and plots (e.g. pipelines/lightfield_indirect.ron beside
        /// pipelines/indirect.ron).
        #[arg(long, value_name = "PIPELINE", conflicts_with = "suite")]
        compare: Vec<PathBuf>,
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
        #[arg(long, value_parser = side_parser())]
        width: Option<u32>,
        #[arg(long, value_parser = side_parser())]
        height: Option<u32>,
        #[arg(long)]
        seed: Option<u32>,
        /// Reference samples per pixel, split over two seeds (default 4096; quick 512). Baselines
        /// run up to a quarter of it, so a larger reference brackets more of their curves.
        #[arg(long, value_parser = clap::value_parser!(u32).range(16..=1_048_576))]
        reference_spp: Option<u32>,
        /// As for `render` (the bench also keeps a few full-size images for its report).
        #[arg(long, value_name = "SIZE", value_parser = parse_size)]
        memory_limit: Option<u64>,
        /// Set a node parameter on every run and on the reference: NODE.PARAM=VALUE (repeatable;
        /// e.g. measure an option against the pipeline's default). Under --suite a scene's lens
        /// wins over a --set lens.
        #[arg(long = "set", value_name = "NODE.PARAM=VALUE")]
        set: Vec<String>,
    },
    /// Check the wgpu backend against the CPU backend pass by pass (each GPU pass runs on the CPU's
    /// inputs) and print max abs / max rel differences and pixels over tolerance; fails on a mismatch.
    Parity {
        pipeline: Option<PathBuf>,
        /// Scene override, as for `render`.
        #[arg(long)]
        scene: Option<String>,
        #[arg(long, default_value_t = 64, value_parser = side_parser())]
        width: u32,
        #[arg(long, default_value_t = 48, value_parser = side_parser())]
        height: u32,
        #[arg(long)]
        seed: Option<u32>,
        /// Set a node parameter: NODE.PARAM=VALUE. Repeatable.
        #[arg(long = "set", value_name = "NODE.PARAM=VALUE")]
        set: Vec<String>,
        /// As for `render`; parity holds CPU and GPU copies of the buffers.
        #[arg(long, value_name = "SIZE", value_parser = parse_size)]
        memory_limit: Option<u64>,
        /// As for `render`: `adapter` or `webgpu` (WebGPU's default limits).
        #[arg(long, value_parser = ["adapter", "webgpu"])]
        gpu_limits: Option<String>,
        /// Check frames A to B (both included) of a sequence, as `render --frames` renders them: each
        /// frame's passes with the previous frame's history (the CPU's) on both backends.
        #[arg(long, value_name = "A..B", value_parser = parse_frames)]
        frames: Option<(u32, u32)>,
    },
    /// Write the pipeline's scene, seen by its camera, for other renderers: scene.obj/.mtl, textures
    /// (EXR + PNG) and scene.json (camera with thin-lens conventions, exact materials, area lights).
    ExportScene {
        pipeline: Option<PathBuf>,
        /// Scene override, as for `render`.
        #[arg(long)]
        scene: Option<String>,
        #[arg(long, default_value = "out/scene")]
        out: PathBuf,
        /// Image size recorded in scene.json (default: the pipeline's).
        #[arg(long, value_parser = side_parser())]
        width: Option<u32>,
        #[arg(long, value_parser = side_parser())]
        height: Option<u32>,
        /// As for `render`.
        #[arg(long = "allow-outside-dir", alias = "allow-outside-scene-dir")]
        allow_outside_dir: bool,
    },
    /// Open a window showing the pipeline live (default: pipelines/shadows.ron): output picker with
    /// A/B split, parameter widgets from the node declarations, hot reload of the pipeline file,
    /// frame averaging while nothing changes, timings, orbit camera; F12 writes a screenshot
    /// (EXR + PNG as `render` writes them) into --out.
    #[cfg(feature = "view")]
    View {
        pipeline: Option<PathBuf>,
        #[command(flatten)]
        common: Common,
        /// Scale every node's bandwidth parameter `mu` (a finite number > 0); a slider in the window.
        #[arg(long, value_parser = parse_mu)]
        mu: Option<f64>,
        /// Run the steps of this RON script (parameter changes, outputs, camera moves, screenshots at
        /// given frames), then close the window and exit: for tests and demos.
        #[arg(long, value_name = "SCRIPT")]
        script: Option<PathBuf>,
    },
    /// Print a pipeline's schedule (passes, kernels, reads, writes, buffer lifetimes). Refusals that
    /// need no scene come first; then the scene is loaded as `render` loads it (no environment map
    /// read, no real layer captured), so the schedule is the one `render` runs.
    Graph {
        pipeline: Option<PathBuf>,
        /// Print Graphviz DOT instead of the table.
        #[arg(long)]
        dot: bool,
        /// Scene override, as for `render`.
        #[arg(long)]
        scene: Option<String>,
        /// As for `render`.
        #[arg(long = "allow-outside-dir", alias = "allow-outside-scene-dir")]
        allow_outside_dir: bool,
    },
}

#[derive(Subcommand)]
enum Farm {
    /// An sbatch job array, one task per tile (`render --tile $SLURM_ARRAY_TASK_ID/N`), and a merge
    /// job chained with --dependency=afterok, written to OUT/slurm/ and submitted with sbatch (or
    /// printed with --dry-run). Tiles go to OUT/tiles/, the merged images to OUT (--out).
    Slurm {
        pipeline: PathBuf,
        /// Number of tiles (array tasks), 1..=65536; a near-square grid.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(wedge::tiles::MAX_TILES)))]
        tiles: u32,
        #[command(flatten)]
        common: Common,
        /// Slurm partition of both jobs.
        #[arg(long)]
        partition: Option<String>,
        /// Slurm time limit of each task and of the merge (e.g. 01:00:00).
        #[arg(long)]
        time: Option<String>,
        /// Print the scripts and the sbatch commands instead of submitting.
        #[arg(long)]
        dry_run: bool,
    },
}

/// Largest `reference --spp` (the `MonteCarlo` node's `spp` limit, kept for references from the graph).
const MAX_SPP: i64 = 1 << 20;

/// `--width`/`--height`: clap checks the range and names the flag in its message.
fn side_parser() -> clap::builder::RangedI64ValueParser<u32> {
    clap::value_parser!(u32).range(1..=i64::from(wedge::graph::MAX_SIDE))
}

/// `--mu`: finite and > 0 (0 would be an infinitely wide filter, NaN no filter at all).
fn parse_mu(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(_) => Err("must be a finite number > 0 (e.g. 2.0)".into()),
        Err(e) => Err(format!("{e}; use a finite number > 0 (e.g. 2.0)")),
    }
}

/// `--threads`: 1 ..= 4 × the cores (more threads than that only cost memory and start-up time;
/// 100000 of them took minutes to spawn).
fn parse_threads(s: &str) -> Result<usize, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let cap = 4 * cores;
    match s.parse::<usize>() {
        Ok(n) if (1..=cap).contains(&n) => Ok(n),
        Ok(_) => Err(format!("must be in 1..={cap} (at most 4 × the {cores} core(s) of this machine)")),
        Err(e) => Err(format!("{e}; use a whole number in 1..={cap}")),
    }
}

fn parse_size(s: &str) -> Result<u64, String> {
    wedge::session::parse_size(s)
}

/// Refuse `session` in `mode` before anything large is allocated when it will not fit the budget.
fn check_memory(session: &Session, mode: RunMode, flag: Option<u64>) -> Result<(), WedgeError> {
    match wedge::session::memory_budget(flag) {
        Some((limit, source)) => session.memory_estimate(mode).check(limit, &source),
        None => Ok(()),
    }
}

fn overrides(c: &Common, mu: Option<f64>) -> Result<Overrides, WedgeError> {
    Ok(Overrides {
        scene: c.scene.clone(),
        width: c.width,
        height: c.height,
        seed: c.seed,
        mu,
        params: c.set.iter().map(|s| wedge::session::parse_set(s)).collect::<Result<_, _>>()?,
        allow_outside_dir: c.allow_outside_dir,
        without_real_layer: false,
        frame: None,
    })
}

/// `--threads N`: every rayon pool of the process runs N threads from here on — the global pool
/// (opening the session: the scene's BVH, a mixed-reality capture; the passes; the AOVs) and the
/// pools other crates build at rayon's default size, which reads `RAYON_NUM_THREADS` (the exr crate
/// compresses EXR blocks in a pool of its own). Called first in `main`: setting an environment
/// variable is only sound while no other thread may read the environment.
fn set_threads(threads: Option<usize>) -> Result<(), WedgeError> {
    let Some(n) = threads else { return Ok(()) };
    std::env::set_var("RAYON_NUM_THREADS", n.to_string());
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build_global()
        .map_err(|e| WedgeError::Usage(format!("--threads {n}: {e}")))
}

/// Flags that the chosen backend does not use: a warning, not a refusal ([`start_rendering_command`]).
fn warn_unused_flags(common: &Common) {
    if let (Some(limits), "cpu") = (&common.gpu_limits, common.backend.as_str()) {
        eprintln!(
            "warning: --gpu-limits {limits} has no effect with --backend cpu (device limits apply to the wgpu backend \
             only); add --backend wgpu to run under them"
        );
    }
}

/// The scene's warnings, its environment map (with the `B_e` the Environment node's filters use
/// unless its `b_e` is set), and a warning where nothing lights it.
fn scene_notes(session: &Session) {
    for w in &session.scene.warnings {
        eprintln!("warning: {w}");
    }
    for w in session.pipeline.light_warnings(Some(&wedge::session::scene_facts(&session.scene))) {
        eprintln!("warning: {w}");
    }
    if let Some(env) = &session.scene.environment {
        eprintln!(
            "environment: {} ({}x{}, scale {}, rotation {}°), B_e = {:.2} cycles/rad (99% of the spectrum's energy; \
             an Environment node's `b_e` overrides it)",
            env.name(),
            env.width(),
            env.height(),
            env.scale(),
            env.rotation_deg(),
            env.bandwidth()
        );
    }
    if session.scene.lights.is_empty() && session.scene.environment.is_none() {
        // Not an error: an AO pipeline needs no light. But direct and indirect light will be black.
        eprintln!(
            "warning: scene `{}` has no area light (no emissive triangles) and no environment map: light sampling adds \
             nothing, so only emission and ambient occlusion show; add an emissive material or use a scene with a light",
            session.scene.name
        );
    }
}

/// `--aov`'s maps for `scene` at the session's size (none when `names` is empty), and a line saying
/// what they took.
fn aov_images(scene: &wedge::scene::Scene, session: &Session, names: &[String]) -> Result<(Vec<wedge::outputs::ExtraExr>, String), WedgeError> {
    if names.is_empty() {
        return Ok((Vec::new(), String::new()));
    }
    let start = std::time::Instant::now();
    let aovs = wedge::aov::Aovs::render(scene, session.width, session.height)?;
    let images = aovs.images(names);
    let stems: Vec<&str> = images.iter().map(|e| e.stem.as_str()).collect();
    let line = format!("AOVs {} in {:.1} ms (primary.gbuffer on the CPU)\n", stems.join(", "), start.elapsed().as_secs_f64() * 1e3);
    Ok((images, line))
}

fn render(session: &Session, common: &Common, stem: &str, aov: &[String]) -> Result<String, WedgeError> {
    eprintln!(
        "{} on scene `{}` ({} triangles, {} lights), {}x{}, seed {}",
        session.pipeline.path.display(),
        session.scene.name,
        session.scene.triangle_count(),
        session.scene.lights.len(),
        session.width,
        session.height,
        session.seed
    );
    scene_notes(session);
    let mode = if common.backend == "wgpu" { RunMode::Gpu } else { RunMode::Cpu };
    check_memory(session, mode, common.memory_limit)?;
    let bars = Bars::default();
    let (run, note) = match common.backend.as_str() {
        "wgpu" => run_wgpu(session, &bars, common.gpu_limits.as_deref())?,
        _ => (session.run(&mut CpuBackend::new(), &bars)?, None),
    };
    let (extra, aov_line) = aov_images(&session.scene, session, aov)?;
    let written = wedge::outputs::write_run_with(&common.out, stem, &run, &extra, session.width, session.height)?;
    let mut text = summary(&run, session.width, session.height);
    text.push_str(&written.warnings());
    if let Some(note) = note {
        text.push_str(&note);
    }
    text.push_str(&aov_line);
    for f in &written.files {
        text.push_str(&format!("wrote {}\n", f.display()));
    }
    Ok(text)
}

/// `render --tile I/N`: one tile file into --out ([`wedge::tiles`]).
fn render_tile(session: &Session, common: &Common, (index, n): (u32, u32), grid: Option<wedge::tiles::Grid>) -> Result<String, WedgeError> {
    let grid = wedge::tiles::grid_of(n, grid, (session.width, session.height))?;
    scene_notes(session);
    let plan = wedge::tiles::plan(session, index, grid)?;
    // The memory of the tile with its apron, not of the whole image.
    let mode = if common.backend == "wgpu" { RunMode::Gpu } else { RunMode::Cpu };
    if let Some((limit, source)) = wedge::session::memory_budget(common.memory_limit) {
        session.memory_estimate_at(mode, (plan.grown.2, plan.grown.3)).check(limit, &source)?;
    }
    let bars = Bars::default();
    let tile = match common.backend.as_str() {
        "wgpu" => wedge::tiles::render_planned(session, &mut open_gpu(common.gpu_limits.as_deref())?, &bars, &plan)?,
        _ => wedge::tiles::render_planned(session, &mut CpuBackend::new(), &bars, &plan)?,
    };
    let path = wedge::tiles::write_tile(&common.out, &tile)?;
    let (h, r) = (&tile.header, tile.header.rect);
    Ok(format!(
        "tile {index}/{n} of a {}x{} grid: {}x{} at ({}, {}) of {}x{}, apron {} px\nwrote {}\n",
        h.grid.cols, h.grid.rows, r.w, r.h, r.x, r.y, h.full.0, h.full.1, h.apron, path.display()
    ))
}

/// The `render` flags of `c` that a farm task passes on (not --out: the farm places the tiles).
fn forwarded_args(c: &Common) -> Vec<String> {
    let mut a: Vec<String> = Vec::new();
    let values = [
        ("--scene", c.scene.clone()),
        ("--seed", c.seed.map(|v| v.to_string())),
        ("--width", c.width.map(|v| v.to_string())),
        ("--height", c.height.map(|v| v.to_string())),
        ("--threads", c.threads.map(|v| v.to_string())),
        ("--memory-limit", c.memory_limit.map(|v| v.to_string())),
        ("--backend", Some(c.backend.clone())),
        ("--gpu-limits", c.gpu_limits.clone()),
    ];
    for (flag, v) in values {
        if let Some(v) = v {
            a.extend([flag.to_string(), v]);
        }
    }
    for s in &c.set {
        a.extend(["--set".to_string(), s.clone()]);
    }
    if c.allow_outside_dir {
        a.push("--allow-outside-dir".into());
    }
    a
}

/// `wedge farm slurm`: refuse a pipeline that cannot be tiled before anything is submitted.
fn farm_slurm(pipeline: &Path, tiles: u32, common: &Common, partition: Option<String>, time: Option<String>, dry_run: bool) -> Result<String, WedgeError> {
    for (flag, v) in [("--partition", &partition), ("--time", &time)] {
        if let Some(v) = v {
            wedge::farm::check_sbatch_value(flag, v)?;
        }
    }
    let session = Session::open(Some(pipeline), &overrides(common, None)?)?;
    wedge::tiles::check(&session, wedge::tiles::Grid::near_square(tiles, (session.width, session.height)))?;
    let absolute = |p: &Path| std::path::absolute(p).map_err(|e| WedgeError::Usage(format!("{}: {e}", p.display())));
    let plan = wedge::farm::SlurmPlan {
        wedge: std::env::current_exe().map_err(|e| WedgeError::Usage(format!("cannot find the wedge executable: {e}")))?,
        pipeline: absolute(pipeline)?,
        tiles,
        out: absolute(&common.out)?,
        render_args: forwarded_args(common),
        partition,
        time,
    };
    if dry_run {
        return Ok(plan.dry_run());
    }
    plan.submit()
}

/// Most frames one `--frames` range may hold.
const MAX_FRAMES: u32 = 100_000;

/// `A..B` (both included, A ≤ B) or a single frame `A`.
fn parse_frames(s: &str) -> Result<(u32, u32), String> {
    let number = |t: &str| t.trim().parse::<u32>().map_err(|_| format!("`{t}` is not a frame number (0..=4294967295)"));
    let (a, b) = match s.split_once("..") {
        Some((a, b)) => (number(a)?, number(b.trim_start_matches('='))?),
        None => (number(s)?, number(s)?),
    };
    if a > b {
        return Err(format!("{a}..{b} ends before it starts; write the first frame first, e.g. 0..23"));
    }
    if b - a >= MAX_FRAMES {
        return Err(format!("{a}..{b} is {} frames, more than {MAX_FRAMES}; render it in parts", u64::from(b - a) + 1));
    }
    Ok((a, b))
}

/// The one backend a run of several frames (`--frames`, `--progressive`) keeps: announces the run
/// (`what`: which frames), prints the scene notes and checks the memory estimate first.
fn sequence_backend(session: &Session, common: &Common, what: &str) -> Result<Box<dyn wedge::backends::Backend + Send>, WedgeError> {
    eprintln!(
        "{} on scene `{}`, {}x{}, {what}, seed {} (+ frame)",
        session.pipeline.path.display(),
        session.scene.name,
        session.width,
        session.height,
        session.seed
    );
    scene_notes(session);
    let mode = if common.backend == "wgpu" { RunMode::Gpu } else { RunMode::Cpu };
    if let Some((limit, source)) = wedge::session::memory_budget(common.memory_limit) {
        session.sequence_memory_estimate(mode).check(limit, &source)?;
    }
    Ok(match common.backend.as_str() {
        "wgpu" => Box::new(open_gpu(common.gpu_limits.as_deref())?),
        _ => Box::new(CpuBackend::new()),
    })
}

/// `render --frames A..B`: every frame in order on one backend, each with the previous frame's
/// history. Each frame's image (and AOVs) is written as soon as it is rendered, into one
/// all-or-nothing set committed with the last frame's full outputs ([`wedge::outputs::SequenceWriter`]):
/// the memory held is one frame's, however many frames the range has.
fn render_frames(session: &mut Session, common: &Common, (first, last): (u32, u32), aov: &[String]) -> Result<String, WedgeError> {
    let mut backend = sequence_backend(session, common, &format!("frames {first}..{last}"))?;
    for w in session.pipeline.sequence_warnings(first, last) {
        eprintln!("warning: {w}");
    }
    let bars = Bars::default();
    let mut out = wedge::outputs::SequenceWriter::new(&common.out)?;
    let (mut previous, mut seconds) = (None, 0.0f64);
    let (mut last_aovs, mut aov_line) = (Vec::new(), String::new());
    for frame in first..=last {
        let run = session.run_frame(backend.as_mut(), &bars, frame, first, previous.as_ref())?;
        seconds += run.total_seconds();
        if let Some(b) = run.output("color") {
            out.frame(frame, &wedge::outputs::buffer_to_image(b, session.width, session.height))?;
        }
        previous = Some(run);
        // The AOVs of every frame's camera, `aov_NAME_NNNN.exr` beside `frame_NNNN.exr` (the inputs of
        // a mixed-reality sequence, `{frame:04}` in its file names); the last frame's also unnumbered,
        // like the full outputs.
        if !aov.is_empty() {
            let base = session.scene.camera;
            session.scene.camera = session.camera_at(frame);
            let aovs = aov_images(&session.scene, session, aov);
            session.scene.camera = base;
            let (maps, line) = aovs?;
            let numbered: Vec<_> = maps.iter().map(|m| wedge::outputs::ExtraExr { stem: format!("{}_{frame:04}", m.stem), ..m.clone() }).collect();
            out.extra(&numbered)?;
            if frame == last {
                (last_aovs, aov_line) = (maps, line);
            }
        }
    }
    let run = previous.expect("a frame range holds at least one frame");
    let written = out.finish("render", &run, &last_aovs, session.width, session.height)?;
    let n = last - first + 1;
    let mut text = summary(&run, session.width, session.height);
    text.push_str(&format!("{n} frames in {seconds:.2} s of passes: {:.2} frames per second ({})\n", f64::from(n) / seconds.max(1e-9), backend.name()));
    text.push_str(&aov_line);
    text.push_str(&written.warnings());
    for f in &written.files {
        text.push_str(&format!("wrote {}\n", f.display()));
    }
    Ok(text)
}

/// Most frames `render --progressive` takes.
const MAX_PROGRESSIVE: i64 = 1_000_000;

/// `render --progressive N`: frames 0..N−1 with a still camera, each continuing the previous frame's
/// history (`Session::run_progressive_frame`); after 1, 2, 4, 8, … frames and the last, one
/// all-or-nothing set of files: `progressive_NNNN.exr/png` (NNNN = frames so far) and that frame's
/// full outputs. Shows a bar over the frames and prints the time per frame and per pass class.
fn render_progressive(session: &Session, common: &Common, frames: u32, aov: &[String]) -> Result<String, WedgeError> {
    use wedge::backends::KernelClass;
    if session.schedule.history.is_empty() {
        return Err(WedgeError::Usage(format!(
            "--progressive: {} has no node that accumulates over frames, so every frame would be a new image, not a \
             better one; use a PixelFilter or RadianceFilter pipeline (e.g. pipelines/progressive_pixel.ron or \
             progressive_radiance.ron), or --frames for a sequence",
            session.pipeline.path.display()
        )));
    }
    let mut backend = sequence_backend(session, common, &format!("progressive: {frames} frames"))?;
    let (extra, aov_line) = aov_images(&session.scene, session, aov)?;
    // Which frames run a scheduled filter (a pass with the PixelFilter schedule's parameters).
    let schedule = session.schedule.passes.iter().find_map(|p| {
        match (p.params.get("first_filter"), p.params.get("filter_first_frame")) {
            (Some(ParamValue::Int(first)), Some(ParamValue::Bool(ff))) => Some((*first as u32, *ff)),
            _ => None,
        }
    });
    let filters = |frame: u32| schedule.is_some_and(|(first, ff)| wedge::backends::kernels::pixel_filter::is_filter_frame(frame, first, ff));
    let bar = indicatif::ProgressBar::new(u64::from(frames));
    bar.set_style(
        indicatif::ProgressStyle::with_template("{prefix:>12} [{bar:40}] {pos}/{len} frames {elapsed_precise} eta {eta} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix("progressive");
    let classes = [KernelClass::Sampling, KernelClass::Bandwidth, KernelClass::Filter, KernelClass::Compose];
    // One closure, so that the bar is cleared before an error returns.
    let looped = (|| -> Result<_, WedgeError> {
        let mut previous: Option<wedge::backends::RunResult> = None;
        let mut files: Vec<std::path::PathBuf> = Vec::new();
        let mut warnings = String::new();
        let (mut per_class, mut total, mut filter_frames, mut filter_seconds) = ([0.0f64; 4], 0.0f64, 0u32, 0.0f64);
        let mut frame_seconds: Vec<f64> = Vec::with_capacity(frames as usize);
        for frame in 0..frames {
            let run = session.run_progressive_frame(backend.as_mut(), &wedge::backends::Silent, frame, previous.as_ref())?;
            let seconds = run.total_seconds();
            total += seconds;
            frame_seconds.push(seconds);
            for (k, c) in classes.iter().enumerate() {
                per_class[k] += run.seconds(*c);
            }
            if filters(frame) {
                filter_frames += 1;
                filter_seconds += run.seconds(KernelClass::Filter);
            }
            let n = frame + 1;
            if n.is_power_of_two() || n == frames {
                if let Some(color) = run.output("color") {
                    let image = wedge::outputs::buffer_to_image(color, session.width, session.height);
                    let name = format!("progressive_{n:04}");
                    let written = wedge::outputs::write_snapshot(&common.out, "render", &run, (&name, &image), &extra, session.width, session.height)?;
                    if n == frames {
                        // The last set in full, after the earlier snapshots' own images.
                        files.extend(written.files.iter().cloned());
                        warnings = written.warnings();
                    } else {
                        files.extend(written.files.iter().filter(|f| f.file_name().is_some_and(|s| s.to_string_lossy().starts_with(&name))).cloned());
                    }
                }
            }
            bar.set_message(format!("{n} paths/px, {:.1} ms", seconds * 1e3));
            bar.inc(1);
            previous = Some(run);
        }
        Ok((previous, files, warnings, per_class, total, filter_frames, filter_seconds, frame_seconds))
    })();
    bar.finish_and_clear();
    let (last, files, warnings, per_class, total, filter_frames, filter_seconds, frame_seconds) = looped?;
    let run = last.expect("at least one frame");
    let n = f64::from(frames);
    let mut text = summary(&run, session.width, session.height);
    text.push_str(&format!(
        "progressive: {frames} frames in {total:.2} s of passes ({}): {:.2} ms per frame (first {:.2}, last {:.2}), {:.2} frames per second\n",
        backend.name(),
        total / n * 1e3,
        frame_seconds.first().copied().unwrap_or(0.0) * 1e3,
        frame_seconds.last().copied().unwrap_or(0.0) * 1e3,
        n / total.max(1e-9)
    ));
    let names = ["sampling", "bandwidth", "filter", "compose"];
    let parts: Vec<String> = names.iter().zip(per_class).map(|(name, s)| format!("{name} {:.2} ms ({:.1}%)", s / n * 1e3, 100.0 * s / total.max(1e-12))).collect();
    text.push_str(&format!("per frame by pass class: {}\n", parts.join(", ")));
    if schedule.is_some() {
        text.push_str(&format!(
            "filter frames: {filter_frames} of {frames}, {:.2} ms per filter frame's filter passes; filtering took {:.1}% of all pass time\n",
            if filter_frames > 0 { filter_seconds / f64::from(filter_frames) * 1e3 } else { 0.0 },
            100.0 * per_class[2] / total.max(1e-12)
        ));
    }
    text.push_str(&aov_line);
    text.push_str(&warnings);
    for f in &files {
        text.push_str(&format!("wrote {}\n", f.display()));
    }
    Ok(text)
}

fn run_wgpu(
    session: &Session,
    bars: &Bars,
    limits: Option<&str>,
) -> Result<(wedge::backends::RunResult, Option<String>), WedgeError> {
    let mut gpu = open_gpu(limits)?;
    eprintln!("wgpu adapter: {}", gpu.adapter_description());
    let run = session.run(&mut gpu, bars)?;
    let mut note = format!(
        "backend wgpu on {}; pass times are {}\n",
        gpu.adapter_description(),
        if gpu.has_timestamps() { "device timestamps (timestamp queries)" } else { "wall clock (no timestamp queries)" }
    );
    let split: Vec<String> = gpu.last_bands.iter().filter(|(_, n)| *n > 1).map(|(p, n)| format!("{p} ×{n}")).collect();
    if !split.is_empty() {
        note.push_str(&format!(
            "passes split into bands of rows (buffers over the device's storage-binding limit of {} bytes): {}\n",
            gpu.limits().max_storage_buffer_binding_size,
            split.join(", ")
        ));
    }
    let packed: Vec<&str> = gpu
        .last_plans
        .iter()
        .filter(|(_, plan)| *plan == wedge::backends::gpu::shaders::BindingPlan::Packed)
        .map(|(p, _)| p.as_str())
        .collect();
    if !packed.is_empty() {
        note.push_str(&format!(
            "passes bound packed (more buffers than the device's {} storage buffers per stage): {}\n",
            gpu.limits().max_storage_buffers_per_shader_stage,
            packed.join(", ")
        ));
    }
    if gpu.is_software() {
        note.push_str("note: this adapter is a CPU emulation (lavapipe/llvmpipe); its times say nothing about a GPU\n");
    }
    Ok((run, Some(note)))
}

/// `wedge parity`: every pass on both backends with the same inputs, at the first frame or, with
/// `frames`, at each frame of the sequence with the previous frame's history (the CPU's run of it).
fn parity(session: &mut Session, limits: Option<&str>, frames: Option<(u32, u32)>) -> Result<(String, bool), WedgeError> {
    let mut gpu = open_gpu(limits)?;
    let Some((first, last)) = frames else {
        let report = wedge::backends::parity::run_parity(&session.job(session.seed, 0, &wedge::backends::Silent), &mut gpu)?;
        return Ok((report.table(), report.ok()));
    };
    let (mut text, mut ok, mut previous) = (String::new(), true, None);
    for frame in first..=last {
        let report = session.parity_frame(&mut gpu, frame, first, previous.as_ref())?;
        text.push_str(&format!("frame {frame}\n{}", report.table()));
        ok &= report.ok();
        if frame < last {
            previous = Some(session.run_frame(&mut CpuBackend::new(), &wedge::backends::Silent, frame, first, previous.as_ref())?);
        }
    }
    Ok((text, ok))
}

fn compare(test: &Path, reference: &Path, heatmap: &Path) -> Result<String, WedgeError> {
    for input in [test, reference] {
        wedge::staging::refuse_input_as_output(heatmap, input)?;
    }
    let a = read_exr(test)?;
    let b = read_exr(reference)?;
    let m = wedge::metrics::compare(&a, &b)?;
    let mut text = format!(
        "RMSE    {:.6}\nrelMSE  {:.6}\nPSNR    {:.2} dB\nSMAPE   {:.6}\nmax abs {:.6}\n",
        m.rmse, m.rel_mse, m.psnr, m.smape, m.max_abs
    );
    if m.non_finite > 0 {
        text.push_str(&format!("warning: {} pixel(s) with non-finite values were excluded\n", m.non_finite));
    }
    let err = wedge::metrics::error_map(&a, &b);
    // One file: written under a unique temporary name and renamed into place (src/staging.rs).
    if let Some(dir) = heatmap.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|source| wedge::image::ImageError::Write { path: dir.to_path_buf(), source })?;
    }
    let spec = wedge::heatmap::HeatmapSpec {
        title: "relative squared error",
        unit: "",
        scale: wedge::heatmap::Scale::Log,
        range: None,
        arrows: None,
    };
    wedge::heatmap::write_heatmap_png(heatmap, a.width, a.height, &err, None, &spec)?;
    text.push_str(&format!("wrote {}\n", heatmap.display()));
    Ok(text)
}

/// `--suite-scenes`' names as scene specs (every one a built-in), or the whole suite of the
/// pipeline's family when empty (the defocus suite for a pipeline that takes a lens).
fn suite_scene_specs(pipeline: &Path, names: &[String]) -> Result<Vec<String>, WedgeError> {
    if names.is_empty() {
        return Ok(wedge::bench::suite::family_scenes(wedge::bench::suite::family_of(pipeline)?));
    }
    names
        .iter()
        .map(|n| {
            let name = n.trim().strip_prefix("builtin:").unwrap_or(n.trim());
            if wedge::scene::builtin_names().contains(&name) {
                Ok(format!("builtin:{name}"))
            } else {
                let suite: Vec<&str> = wedge::scene::builtin::SuiteFamily::ALL.iter().flat_map(|f| f.scenes()).map(|(s, _)| *s).collect();
                Err(WedgeError::Usage(format!(
                    "--suite-scenes: `{n}` is not a built-in scene; the suite's are {} (other built-ins: {})",
                    suite.join(", "),
                    wedge::scene::builtin_names().iter().filter(|b| !suite.contains(b)).copied().collect::<Vec<_>>().join(", ")
                )))
            }
        })
        .collect()
}

/// What `render` and `reference` do before anything else: refuse an `--out` that cannot be a
/// directory (before rendering, not after) and warn about flags the backend ignores.
///
/// `--gpu-limits` with `--backend cpu` is a warning rather than a refusal: the image does not
/// depend on it, and a script that passes the same flags to both backends keeps working, while
/// the line tells someone who forgot `--backend wgpu` that no limit was checked.
fn start_rendering_command(common: &Common) -> Result<(), WedgeError> {
    wedge::staging::check_output_dir(&common.out)?;
    warn_unused_flags(common);
    Ok(())
}

impl Command {
    /// `--threads`, for the commands that take it.
    fn threads(&self) -> Option<usize> {
        match self {
            Command::Render { common, .. } | Command::Reference { common, .. } => common.threads,
            #[cfg(feature = "view")]
            Command::View { common, .. } => common.threads,
            _ => None,
        }
    }
}

/// What a command prints on stdout (written once at the end, so a closed pipe is not a panic).
fn run(cli: Cli) -> Result<String, WedgeError> {
    match cli.command {
        Command::Render { pipeline, common, mu, frames, aov, progressive, tile, tile_grid } => {
            start_rendering_command(&common)?;
            // A sequence opens at its first frame (its camera, and a real layer read per frame).
            let ov = Overrides { frame: frames.map(|(first, _)| first), ..overrides(&common, mu)? };
            let mut session = Session::open(pipeline.as_deref(), &ov)?;
            match (frames, progressive, tile) {
                (_, _, Some(tile)) => render_tile(&session, &common, tile, tile_grid),
                (_, Some(n), None) => render_progressive(&session, &common, n, &aov),
                (Some(frames), None, None) => render_frames(&mut session, &common, frames, &aov),
                (None, None, None) => render(&session, &common, "render", &aov),
            }
        }
        Command::Reference { pipeline, common, spp, sampling } => {
            start_rendering_command(&common)?;
            let session = Session::reference(pipeline.as_deref(), spp, &sampling, &overrides(&common, None)?)?;
            render(&session, &common, "reference", &[])
        }
        Command::Compare { test, reference, heatmap } => compare(&test, &reference, &heatmap),
        Command::Merge { dir, out } => wedge::merge::merge(&dir, &out),
        Command::Farm { farm: Farm::Slurm { pipeline, tiles, common, partition, time, dry_run } } => {
            farm_slurm(&pipeline, tiles, &common, partition, time, dry_run)
        }
        #[cfg(feature = "view")]
        Command::View { pipeline, common, mu, script } => {
            start_rendering_command(&common)?;
            let opts = wedge::view::ViewOptions {
                pipeline,
                overrides: overrides(&common, mu)?,
                backend: common.backend.clone(),
                gpu_limits: common.gpu_limits.clone(),
                out: common.out.clone(),
                memory_limit: common.memory_limit,
                script,
            };
            wedge::view::run(opts)
        }
        Command::Parity { pipeline, scene, width, height, seed, set, memory_limit, gpu_limits, frames } => {
            let ov = Overrides {
                scene,
                width: Some(width),
                height: Some(height),
                seed,
                mu: None,
                params: set.iter().map(|s| wedge::session::parse_set(s)).collect::<Result<_, _>>()?,
                ..Overrides::default()
            };
            let mut session = Session::open(pipeline.as_deref(), &Overrides { frame: frames.map(|(first, _)| first), ..ov })?;
            check_memory(&session, RunMode::Parity, memory_limit)?;
            let (table, ok) = parity(&mut session, gpu_limits.as_deref(), frames)?;
            if ok {
                Ok(table)
            } else {
                Err(WedgeError::Usage(format!("{table}the wgpu backend disagrees with the CPU backend (see MISMATCH rows above)")))
            }
        }
        Command::Bench { pipeline, quick, scene, suite, suite_scenes, compare, out, width, height, seed, reference_spp, memory_limit, set } => {
            wedge::staging::check_output_dir(&out)?;
            let opts = wedge::bench::BenchOptions {
                quick,
                compare,
                scene,
                width,
                height,
                seed,
                reference_spp,
                memory_limit,
                params: set.iter().map(|s| wedge::session::parse_set(s)).collect::<Result<_, _>>()?,
                verbose: true,
                ..wedge::bench::BenchOptions::new(pipeline, out)
            };
            if suite {
                let scenes = suite_scene_specs(&opts.pipeline, &suite_scenes)?;
                let r = wedge::bench::suite::run_suite(&opts, &scenes)?;
                return Ok(format!("{}\n", wedge::bench::suite::summary(&r)));
            }
            let r = wedge::bench::run(&opts)?;
            Ok(format!("{}\n", wedge::bench::report::summary(&r)))
        }
        Command::ExportScene { pipeline, scene, out, width, height, allow_outside_dir } => {
            wedge::staging::check_output_dir(&out)?;
            let ov = Overrides { scene, width, height, allow_outside_dir, ..Overrides::default() };
            let s = wedge::export::open(pipeline.as_deref(), &ov)?;
            let exported = wedge::export::export_session(&s, &out)?;
            let mut text = format!(
                "exported scene `{}` ({} triangles, {} lights, {} textures), camera for {}x{}\n",
                s.scene.name,
                s.scene.triangle_count(),
                s.scene.lights.len(),
                s.scene.textures.len(),
                s.width,
                s.height
            );
            for f in exported.files {
                text.push_str(&format!("wrote {}\n", f.display()));
            }
            for lost in exported.not_exported {
                text.push_str(&format!("not exported: {lost}\n"));
            }
            Ok(text)
        }
        Command::Graph { pipeline, dot, scene, allow_outside_dir } => {
            let loaded = wedge::session::load_pipeline_or_default(pipeline.as_deref())?;
            let (nodes, kernels) = wedge::effects::builtin();
            let mut validated = wedge::graph::validate(&loaded, &nodes)?;
            let ov = Overrides { scene, allow_outside_dir, ..Default::default() };
            let facts = wedge::session::graph_scene_facts(&loaded, &validated, &ov)?;
            validated.update_factoring(Some(facts))?;
            let sched = wedge::graph::schedule(wedge::graph::expand(&validated)?)?;
            kernels.check_schedule(&sched)?;
            if dot {
                return Ok(sched.to_dot());
            }
            let mut text = sched.table() + &memory_line(&sched, loaded.pipeline.width, loaded.pipeline.height);
            text.push_str(&validated.light_summary());
            for w in validated.light_warnings(Some(&facts)) {
                text.push_str(&format!("warning: {w}\n"));
            }
            Ok(text)
        }
    }
}

/// `wedge graph`'s memory line: the schedule's buffers at the pipeline's size (the scene's own memory
/// is not counted).
fn memory_line(sched: &wedge::graph::Schedule, width: u32, height: u32) -> String {
    use wedge::session::format_bytes;
    let b = sched.buffer_bytes(width, height);
    format!(
        "memory at {width}x{height}: estimated peak {} of buffers on the CPU or wgpu backend (pool {} + one pass's \
         outputs {} + sink copies {}), {} for parity; the scene and output images come on top\n",
        format_bytes(sched.peak_bytes(width, height)),
        format_bytes(b.pool),
        format_bytes(b.pass_outputs),
        format_bytes(b.sinks),
        format_bytes(wedge::session::parity_buffer_bytes(&b))
    )
}

/// Write what a command prints. A reader that closed the pipe early (`wedge graph | head`) is not
/// an error; any other failure (`wedge graph > /dev/full`) is.
fn print_stdout(text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Before the signal thread starts (see `set_threads`).
    if let Err(e) = set_threads(cli.command.threads()) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    if let Err(e) = wedge::staging::install_signal_handler() {
        eprintln!("warning: cannot install the SIGINT/SIGTERM handler ({e}); an interrupted run may leave temporary files");
    }
    match run(cli) {
        Ok(text) => match print_stdout(&text) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: cannot write to standard output: {e}; check the disk or the file stdout goes to");
                ExitCode::FAILURE
            }
        },
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

//! The command line's flags and subcommands (clap derive), and the parsers that check their values
//! before anything runs: the one declaration of every flag `wedge` and a user's binary accept.

use std::path::PathBuf;

use crate::{Overrides, WedgeError};
use clap::{Args, Parser, Subcommand};

#[derive(Parser)]
#[command(name = "wedge", version, about = "Sample-and-filter physically based rendering with axis-aligned filters")]
pub(super) struct Cli {
    #[command(subcommand)]
    pub(super) command: Command,
}

/// Options every rendering command shares.
#[derive(Args, Clone)]
pub(super) struct Common {
    /// Scene: a built-in name (`grids`, `curved`, `heavy`, `cornell`, `chess`, `spheres`, `motion`, `envmap`, `envmap_light`, `envmap_real`, `envmap_virtual`, `envmap_far`, and the suite's `suite_slats`, `suite_grate`, `suite_contact`, `suite_near_light`, `suite_textured`, `suite_glossy`, `suite_room`, the defocus suite's `dof_*`, the motion suite's `mo_*`, the environment suite's `env_*`), `builtin:NAME`, or a .gltf/.glb/.obj/.ron file.
    #[arg(long)]
    pub(super) scene: Option<String>,
    /// Output directory.
    #[arg(long, default_value = "out")]
    pub(super) out: PathBuf,
    /// Seed of the counter-based sampler (0..=4294967295).
    #[arg(long)]
    pub(super) seed: Option<u32>,
    /// Image width in pixels (1..=16384; width × height at most 2^26).
    #[arg(long, value_parser = side_parser())]
    pub(super) width: Option<u32>,
    /// Image height in pixels (1..=16384; width × height at most 2^26).
    #[arg(long, value_parser = side_parser())]
    pub(super) height: Option<u32>,
    /// Worker threads (default: all cores; at most 4 × the cores). The image does not depend on it.
    #[arg(long, value_parser = parse_threads)]
    pub(super) threads: Option<usize>,
    /// Refuse a run whose estimated peak memory exceeds SIZE (bytes, or K/M/G/T: 512M, 8G).
    /// Default: 3/4 of the memory available when the run starts.
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    pub(super) memory_limit: Option<u64>,
    /// Set a node parameter: NODE.PARAM=VALUE (e.g. shadows.max_rays=200). Repeatable.
    #[arg(long = "set", value_name = "NODE.PARAM=VALUE")]
    pub(super) set: Vec<String>,
    /// Where passes run: `cpu` (rayon) or `wgpu` (WGSL compute on a GPU, or Mesa's software Vulkan).
    #[arg(long, default_value = "cpu", value_parser = ["cpu", "wgpu"])]
    pub(super) backend: String,
    /// Let the pipeline name files outside its own directory (its scene, environment map, real-layer
    /// maps) and the scene file read buffers, textures and meshes outside its own (symlinks are
    /// followed before the check). `--scene PATH` is never confined.
    #[arg(long = "allow-outside-dir", alias = "allow-outside-scene-dir")]
    pub(super) allow_outside_dir: bool,
    /// With --backend wgpu: `adapter` (the device's own limits) or `webgpu` (wgpu's
    /// Limits::default(), 8 storage buffers per stage: checks that every kernel runs on any WebGPU
    /// device). Default: the WEDGE_WGPU_LIMITS environment variable, else `adapter`.
    #[arg(long, value_parser = ["adapter", "webgpu"])]
    pub(super) gpu_limits: Option<String>,
    /// Progress lines on stderr, one per 10% of the task's work (its passes × pixels over every tile
    /// and frame it renders), for a farm's logs: `human` (`progress: 30% tile 2/4 frame 7 (pass
    /// NAME, 1.2 s)`), `json` (one object per line: task, percent, tile, frame, pass, elapsed_s) or
    /// `none`. They never change the image.
    #[arg(long, default_value = "human", value_parser = ["human", "json", "none"])]
    pub(super) progress: String,
}

#[derive(Subcommand)]
pub(super) enum Command {
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
        #[arg(long, value_name = "NAMES", value_delimiter = ',', value_parser = crate::aov::AOV_NAMES)]
        aov: Vec<String>,
        /// Progressive rendering: N frames (1..=1000000) with the camera held still, each adding its
        /// paths to what nodes accumulate over frames (PixelFilter, RadianceFilter); writes progressive_NNNN.exr/png
        /// after 1, 2, 4, 8, … frames and the last, each with that frame's full outputs (an
        /// interrupted render keeps the last complete snapshot), and prints the time per frame.
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=MAX_PROGRESSIVE), conflicts_with = "frames")]
        progressive: Option<u32>,
        /// Render only tile I (from 0) of N, with the apron the pipeline's passes need around it, into
        /// --out as tile_IIII_of_NNNN.exr for `wedge merge` (N tiles: a near-square grid).
        /// With --frames: tile I of each frame, into --out/frame_FFFF/ (pipelines without frame history).
        #[arg(long, value_name = "I/N", value_parser = crate::tiles::parse_tile, conflicts_with_all = ["progressive", "aov"])]
        tile: Option<(u32, u32)>,
        /// With --tile: the grid, C columns by R rows (C × R = N).
        #[arg(long, value_name = "CxR", value_parser = crate::tiles::parse_grid, requires = "tile")]
        tile_grid: Option<crate::tiles::Grid>,
        /// With --frames A..B: render only shard I (from 0) of N of the frames, each frame's file the
        /// bytes an unsharded --frames A..B writes for it; writes frame_NNNN.exr/png only (no
        /// preview.gif, no last-frame outputs), so shards can share --out.
        #[arg(long, value_name = "I/N", value_parser = crate::shard::parse_shard, requires = "frames")]
        shard: Option<(u32, u32)>,
        /// How --shard splits the frames: `stride` (frames A+I, A+I+N, …; refused for pipelines
        /// with frame history) or `chunks` (the I-th of N contiguous runs; with frame history, the
        /// shard first renders every frame from A up to its chunk to warm the history up, unwritten).
        #[arg(long, default_value = "stride", value_parser = ["stride", "chunks"], requires = "shard")]
        shard_mode: String,
        /// Render without the pipeline's filters at the same rays: every filter pass bypassed, the
        /// sampling and its adaptive counts as the pipeline makes them — the image each filter must
        /// improve on (its RMSE against `wedge reference`).
        #[arg(long)]
        unfiltered: bool,
    },
    /// Assemble the tile files of `render --tile` in DIR into render.exr/.png (and unfiltered.exr/.png)
    /// in --out, after checking that they belong together and cover the image exactly.
    Merge {
        dir: PathBuf,
        #[arg(long, default_value = "out")]
        out: PathBuf,
    },
    /// Run a render on a cluster's scheduler as tiles and a merge (see `wedge farm slurm --help`,
    /// `wedge farm k8s --help`).
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
        /// Run the bench over the first built-in scene suite that fits the pipeline (the one its
        /// factoring node names, then its other nodes', in file order, whose every scene it can
        /// render; checked before the first renders): the defocus suite
        /// (Defocus: dof_*, each scene's own lens set on the nodes that take a lens), the motion suite
        /// (Motion: mo_*), the environment suite (Environment: env_*, each lit by its own map), else the
        /// soft-shadow suite (issue 16: grids, suite_slats, suite_grate, suite_contact,
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
        /// The μ values of the pipeline's sweep, comma-separated (default 0.5,1,2,4; quick 1,2); the
        /// pipeline's own μ is added where it is not among them. Large μ at film sizes takes the
        /// most time (the counts grow as μ²).
        #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = parse_mu)]
        mu_values: Option<Vec<f64>>,
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
        /// An EXR of the same size (e.g. `wedge reference`'s render.exr): adds the `error` output,
        /// |image − reference| as a heatmap, and the RMSE and relMSE of the mean against it.
        #[arg(long, value_name = "REF.exr")]
        reference: Option<PathBuf>,
        /// Render the error view's reference in the background at N samples per pixel (the
        /// pipeline's `wedge reference` for the camera the window opens with); shown when done.
        #[arg(long, value_name = "N", conflicts_with = "reference")]
        reference_spp: Option<u32>,
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

impl Command {
    /// `--threads`, for the commands that take it.
    pub(super) fn threads(&self) -> Option<usize> {
        match self {
            Command::Render { common, .. } | Command::Reference { common, .. } => common.threads,
            #[cfg(feature = "view")]
            Command::View { common, .. } => common.threads,
            _ => None,
        }
    }
}

impl Common {
    /// `--progress`.
    pub(super) fn progress_format(&self) -> crate::progress::ProgressFormat {
        crate::progress::ProgressFormat::parse(&self.progress)
    }

    /// What the run's memory is estimated for: the backend `--backend` names.
    pub(super) fn run_mode(&self) -> crate::session::RunMode {
        if self.backend == "wgpu" {
            crate::session::RunMode::Gpu
        } else {
            crate::session::RunMode::Cpu
        }
    }
}

pub(super) fn overrides(c: &Common, mu: Option<f64>) -> Result<Overrides, WedgeError> {
    Ok(Overrides {
        scene: c.scene.clone(),
        width: c.width,
        height: c.height,
        seed: c.seed,
        mu,
        params: c.set.iter().map(|s| crate::session::parse_set(s)).collect::<Result<_, _>>()?,
        allow_outside_dir: c.allow_outside_dir,
        without_real_layer: false,
        frame: None,
        unfiltered: false,
        scene_camera: false,
    })
}

/// What a farm runs, for Slurm and Kubernetes alike: one task per tile (× frame).
#[derive(Args, Debug)]
pub(super) struct FarmTasks {
    pub pipeline: PathBuf,
    /// Number of tiles per frame, 1..=65536; a near-square grid.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(crate::tiles::MAX_TILES)))]
    pub tiles: u32,
    /// Frames A..B of a sequence: one task per tile × frame (task T renders frame A + T / tiles,
    /// tile T % tiles), merged per frame into OUT/frame_NNNN/.
    #[arg(long, value_name = "A..B", value_parser = parse_frames)]
    pub frames: Option<(u32, u32)>,
}

#[derive(Subcommand)]
pub(super) enum Farm {
    /// An sbatch job array, one task per tile (`render --tile $SLURM_ARRAY_TASK_ID/N`; with
    /// --frames one per tile × frame), and a merge job chained with --dependency=afterok, written to
    /// OUT/slurm/ and submitted with sbatch (or printed with --dry-run). Tiles go to OUT/tiles/, the
    /// merged images to OUT (--out; with --frames OUT/frame_NNNN/).
    Slurm {
        #[command(flatten)]
        tasks: FarmTasks,
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
    /// Kubernetes manifests into OUT/k8s/ (--out): tiles.yaml (a ConfigMap with the pipeline, a
    /// ReadWriteMany volume claim, an Indexed Job with one completion per tile, or per tile × frame,
    /// each pod rendering task JOB_COMPLETION_INDEX), merge.yaml (the merge Job, to apply once the
    /// tiles Job is complete: Kubernetes cannot chain Jobs) and submit.sh (the kubectl apply/wait
    /// commands in order). Talks to no cluster.
    K8s {
        #[command(flatten)]
        tasks: FarmTasks,
        #[command(flatten)]
        k8s: K8sArgs,
        #[command(flatten)]
        common: Common,
    },
}

/// What `wedge farm k8s` takes besides the render flags.
#[derive(Args)]
pub(super) struct K8sArgs {
    /// The container image the pods run; it must hold wedge (--wedge) and `/bin/sh`.
    #[arg(long)]
    pub(super) image: String,
    /// Prefix of the objects' names (a DNS-1123 label); default: wedge-PIPELINE.
    #[arg(long)]
    pub(super) name: Option<String>,
    /// The wedge executable inside the image.
    #[arg(long, default_value = "wedge")]
    pub(super) wedge: String,
    /// Pods running at once (default: every task).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub(super) parallelism: Option<u32>,
    /// Size of the ReadWriteMany volume claim for the tiles and the merged images.
    #[arg(long, default_value = "10Gi")]
    pub(super) storage: String,
    /// Storage class of the claim (one that offers ReadWriteMany, e.g. an NFS or CephFS class).
    #[arg(long)]
    pub(super) storage_class: Option<String>,
    /// Namespace of every object.
    #[arg(long)]
    pub(super) namespace: Option<String>,
}

/// Largest `reference --spp` (the `MonteCarlo` node's `spp` limit, kept for references from the graph).
pub(super) const MAX_SPP: i64 = 1 << 20;

/// `--width`/`--height`: clap checks the range and names the flag in its message.
pub(super) fn side_parser() -> clap::builder::RangedI64ValueParser<u32> {
    clap::value_parser!(u32).range(1..=i64::from(crate::graph::MAX_SIDE))
}

/// `--mu`: finite and > 0 (0 would be an infinitely wide filter, NaN no filter at all).
pub(super) fn parse_mu(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(_) => Err("must be a finite number > 0 (e.g. 2.0)".into()),
        Err(e) => Err(format!("{e}; use a finite number > 0 (e.g. 2.0)")),
    }
}

/// `--threads`: 1 ..= 4 × the cores (more threads than that only cost memory and start-up time;
/// 100000 of them took minutes to spawn).
pub(super) fn parse_threads(s: &str) -> Result<usize, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let cap = 4 * cores;
    match s.parse::<usize>() {
        Ok(n) if (1..=cap).contains(&n) => Ok(n),
        Ok(_) => Err(format!("must be in 1..={cap} (at most 4 × the {cores} core(s) of this machine)")),
        Err(e) => Err(format!("{e}; use a whole number in 1..={cap}")),
    }
}

pub(super) fn parse_size(s: &str) -> Result<u64, String> {
    crate::session::parse_size(s)
}

/// Most frames one `--frames` range may hold.
pub(super) const MAX_FRAMES: u32 = 100_000;

/// `A..B` (both included, A ≤ B) or a single frame `A`.
pub(super) fn parse_frames(s: &str) -> Result<(u32, u32), String> {
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

/// Most frames `render --progressive` takes.
pub(super) const MAX_PROGRESSIVE: i64 = 1_000_000;

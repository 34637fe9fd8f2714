//! The `wedge` command line: render, reference, compare, graph.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use wedge::backends::cpu::CpuBackend;
use wedge::graph::ParamValue;
use wedge::image::read_exr;
use wedge::outputs::{summary, write_run};
use wedge::progress::Bars;
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
    /// Scene: a built-in name (`grids`, `curved`, `heavy`), `builtin:NAME`, or a .gltf/.glb/.obj/.ron file.
    #[arg(long)]
    scene: Option<String>,
    /// Output directory.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Seed of the counter-based sampler.
    #[arg(long)]
    seed: Option<u32>,
    #[arg(long)]
    width: Option<u32>,
    #[arg(long)]
    height: Option<u32>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Set a node parameter: NODE.PARAM=VALUE (e.g. shadows.max_rays=200). Repeatable.
    #[arg(long = "set", value_name = "NODE.PARAM=VALUE")]
    set: Vec<String>,
}

#[derive(Subcommand)]
enum Command {
    /// Render a pipeline (default: pipelines/shadows.ron on the built-in `grids` scene).
    Render {
        pipeline: Option<PathBuf>,
        #[command(flatten)]
        common: Common,
        /// Scale every node's bandwidth parameter `mu`.
        #[arg(long)]
        mu: Option<f64>,
    },
    /// Plain Monte Carlo reference (no filtering) of the pipeline's scene and camera.
    Reference {
        pipeline: Option<PathBuf>,
        #[command(flatten)]
        common: Common,
        /// Light samples per pixel (per light).
        #[arg(long, default_value_t = 1024)]
        spp: u32,
        /// `stratified` (default) or `independent`.
        #[arg(long, default_value = "stratified")]
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
    /// Print a pipeline's schedule (passes, kernels, reads, writes, buffer lifetimes).
    Graph {
        pipeline: Option<PathBuf>,
        /// Print Graphviz DOT instead of the table.
        #[arg(long)]
        dot: bool,
    },
}

fn parse_set(s: &str) -> Result<(String, String, ParamValue), WedgeError> {
    let usage = || WedgeError::Usage(format!("--set {s:?}: expected NODE.PARAM=VALUE, e.g. shadows.mu=4"));
    let (lhs, value) = s.split_once('=').ok_or_else(usage)?;
    let (node, param) = lhs.split_once('.').ok_or_else(usage)?;
    let v = if let Ok(i) = value.parse::<i64>() {
        ParamValue::Int(i)
    } else if let Ok(f) = value.parse::<f64>() {
        ParamValue::Float(f)
    } else if let Ok(b) = value.parse::<bool>() {
        ParamValue::Bool(b)
    } else {
        ParamValue::Str(value.to_string())
    };
    Ok((node.to_string(), param.to_string(), v))
}

fn overrides(c: &Common, mu: Option<f64>) -> Result<Overrides, WedgeError> {
    Ok(Overrides {
        scene: c.scene.clone(),
        width: c.width,
        height: c.height,
        seed: c.seed,
        mu,
        params: c.set.iter().map(|s| parse_set(s)).collect::<Result<_, _>>()?,
    })
}

fn with_threads<T>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T, WedgeError>
where
    T: Send,
{
    match threads {
        None => Ok(f()),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n.max(1))
                .build()
                .map_err(|e| WedgeError::Usage(format!("--threads {n}: {e}")))?;
            Ok(pool.install(f))
        }
    }
}

fn render(session: &Session, common: &Common, stem: &str) -> Result<(), WedgeError> {
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
    let bars = Bars::default();
    let run = with_threads(common.threads, || session.run(&mut CpuBackend::new(), &bars))??;
    let files = write_run(&common.out, stem, &run, session.width, session.height)?;
    print!("{}", summary(&run, session.width, session.height));
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

fn compare(test: &Path, reference: &Path, heatmap: &Path) -> Result<(), WedgeError> {
    let a = read_exr(test)?;
    let b = read_exr(reference)?;
    let m = wedge::metrics::compare(&a, &b)?;
    println!("RMSE    {:.6}", m.rmse);
    println!("relMSE  {:.6}", m.rel_mse);
    println!("PSNR    {:.2} dB", m.psnr);
    println!("SMAPE   {:.6}", m.smape);
    println!("max abs {:.6}", m.max_abs);
    if m.non_finite > 0 {
        println!("warning: {} pixel(s) with non-finite values were excluded", m.non_finite);
    }
    let err = wedge::metrics::error_map(&a, &b);
    if let Some(dir) = heatmap.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|source| wedge::image::ImageError::Write { path: dir.to_path_buf(), source })?;
    }
    let spec = wedge::heatmap::HeatmapSpec {
        title: "relative squared error",
        unit: "",
        scale: wedge::heatmap::Scale::Log,
        range: None,
    };
    wedge::heatmap::write_heatmap_png(heatmap, a.width, a.height, &err, None, &spec)?;
    println!("wrote {}", heatmap.display());
    Ok(())
}

fn run(cli: Cli) -> Result<(), WedgeError> {
    match cli.command {
        Command::Render { pipeline, common, mu } => {
            let session = Session::open(pipeline.as_deref(), &overrides(&common, mu)?)?;
            render(&session, &common, "render")
        }
        Command::Reference { pipeline, common, spp, sampling } => {
            if !["stratified", "independent"].contains(&sampling.as_str()) {
                return Err(WedgeError::Usage(format!("--sampling {sampling}: use `stratified` or `independent`")));
            }
            let session = Session::reference(pipeline.as_deref(), spp, &sampling, &overrides(&common, None)?)?;
            render(&session, &common, "reference")
        }
        Command::Compare { test, reference, heatmap } => compare(&test, &reference, &heatmap),
        Command::Graph { pipeline, dot } => {
            let loaded = wedge::session::load_pipeline_or_default(pipeline.as_deref())?;
            let (nodes, _) = wedge::effects::builtin();
            let validated = wedge::graph::validate(&loaded, &nodes)?;
            let sched = wedge::graph::schedule(wedge::graph::expand(&validated)?)?;
            if dot {
                print!("{}", sched.to_dot());
            } else {
                print!("{}", sched.table());
            }
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

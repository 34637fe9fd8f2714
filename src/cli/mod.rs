//! The `wedge` command line as a library: every subcommand and flag of `wedge` (render, reference,
//! compare, bench, parity, view, export-scene, graph) over the node kinds and kernels it is given.
//! `wedge` itself is [`main`] with [`Registries::builtin`]; a user crate's binary is the same call
//! with its nodes added, and gets the whole CLI for them:
//!
//! ```no_run
//! fn main() -> std::process::ExitCode {
//!     wedge::cli::main(wedge::Registries::builtin() /* .with_node(MyNode).with_kernel(MyKernel) */)
//! }
//! ```
//!
//! `args` declares the flags, `render` runs the rendering commands; this file dispatches.

mod args;
mod farm;
mod render;

use std::path::Path;
use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches};

use crate::backends::cpu::CpuBackend;
use crate::image::read_exr;
use crate::session::{open_gpu, Registries, RunMode};
use crate::{Overrides, Session, WedgeError};
use args::{overrides, Cli, Command, Farm};
use render::{check_memory, render, render_frames, render_progressive, start_rendering_command};

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

/// `wedge parity`: every pass on both backends with the same inputs, at the first frame or, with
/// `frames`, at each frame of the sequence with the previous frame's history (the CPU's run of it).
fn parity(
    session: &mut Session,
    limits: Option<&str>,
    frames: Option<(u32, u32)>,
) -> Result<(String, bool), WedgeError> {
    let mut gpu = open_gpu(limits)?;
    let Some((first, last)) = frames else {
        let report = session.parity(&mut gpu)?;
        return Ok((report.table(), report.ok()));
    };
    let (mut text, mut ok, mut previous) = (String::new(), true, None);
    // One CPU backend for the sequence: its buffer pool persists across frames.
    let mut cpu = CpuBackend::new();
    for frame in first..=last {
        let report = session.parity_frame(&mut gpu, frame, first, previous.as_ref())?;
        text.push_str(&format!("frame {frame}\n{}", report.table()));
        ok &= report.ok();
        if frame < last {
            previous = Some(session.run_frame(&mut cpu, &crate::backends::Silent, frame, first, previous.as_ref())?);
        }
    }
    Ok((text, ok))
}

fn compare(test: &Path, reference: &Path, heatmap: &Path) -> Result<String, WedgeError> {
    for input in [test, reference] {
        crate::staging::refuse_input_as_output(heatmap, input)?;
    }
    let a = read_exr(test)?;
    let b = read_exr(reference)?;
    let m = crate::metrics::compare(&a, &b)?;
    let mut text = format!(
        "RMSE    {:.6}\nrelMSE  {:.6}\nPSNR    {:.2} dB\nSMAPE   {:.6}\nmax abs {:.6}\n",
        m.rmse, m.rel_mse, m.psnr, m.smape, m.max_abs
    );
    if m.non_finite > 0 {
        text.push_str(&format!("warning: {} pixel(s) with non-finite values were excluded\n", m.non_finite));
    }
    let err = crate::metrics::error_map(&a, &b);
    // One file: written under a unique temporary name and renamed into place (src/staging.rs).
    if let Some(dir) = heatmap.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|source| crate::image::ImageError::Write { path: dir.to_path_buf(), source })?;
    }
    let spec = crate::heatmap::HeatmapSpec {
        title: "relative squared error",
        unit: "",
        scale: crate::heatmap::Scale::Log,
        range: None,
        arrows: None,
    };
    crate::heatmap::write_heatmap_png(heatmap, a.width, a.height, &err, None, &spec)?;
    text.push_str(&format!("wrote {}\n", heatmap.display()));
    Ok(text)
}

/// `--suite-scenes`' names as scene specs (every one a built-in), or the whole suite that fits the
/// pipeline when empty ([`crate::bench::suite::suite_for`]).
fn suite_scene_specs(opts: &crate::bench::BenchOptions, names: &[String]) -> Result<Vec<String>, WedgeError> {
    if names.is_empty() {
        return Ok(crate::bench::suite::suite_for(opts)?.1);
    }
    names
        .iter()
        .map(|n| {
            let name = n.trim().strip_prefix("builtin:").unwrap_or(n.trim());
            if crate::scene::builtin_names().contains(&name) {
                Ok(format!("builtin:{name}"))
            } else {
                let suite: Vec<&str> =
                    crate::scene::builtin::SuiteFamily::ALL.iter().flat_map(|f| f.scenes()).map(|(s, _)| *s).collect();
                Err(WedgeError::Usage(format!(
                    "--suite-scenes: `{n}` is not a built-in scene; the suite's are {} (other built-ins: {})",
                    suite.join(", "),
                    crate::scene::builtin_names()
                        .iter()
                        .filter(|b| !suite.contains(b))
                        .copied()
                        .collect::<Vec<_>>()
                        .join(", ")
                )))
            }
        })
        .collect()
}

/// What a command prints on stdout (written once at the end, so a closed pipe is not a panic).
fn run(registries: &Registries, cli: Cli) -> Result<String, WedgeError> {
    match cli.command {
        Command::Render {
            pipeline,
            common,
            mu,
            frames,
            aov,
            progressive,
            tile,
            tile_grid,
            shard,
            shard_mode,
            unfiltered,
        } => {
            start_rendering_command(&common)?;
            // A sequence opens at its first frame (its camera, and a real layer read per frame); so
            // does every shard of it, whichever frames it renders.
            let ov = Overrides { frame: frames.map(|(first, _)| first), unfiltered, ..overrides(&common, mu)? };
            let mut session = Session::open_with(registries, pipeline.as_deref(), &ov)?;
            let plan = match frames {
                Some(range) => {
                    let shard = shard.map(|s| (s, crate::shard::ShardMode::parse(&shard_mode)));
                    let history = !session.schedule.history.is_empty();
                    Some(crate::shard::plan(range, shard, history, &session.pipeline.path.display().to_string())?)
                }
                None => None,
            };
            match (plan, progressive, tile) {
                (plan, _, Some(tile)) => farm::render_tile(&mut session, &common, tile, tile_grid, plan.as_ref()),
                (_, Some(n), None) => render_progressive(&session, &common, n, &aov),
                (Some(plan), None, None) => render_frames(&mut session, &common, &plan, shard.is_some(), &aov),
                (None, None, None) => render(&session, &common, "render", &aov),
            }
        }
        Command::Reference { pipeline, common, spp, sampling } => {
            start_rendering_command(&common)?;
            let session =
                Session::reference_with(registries, pipeline.as_deref(), spp, &sampling, &overrides(&common, None)?)?;
            render(&session, &common, "reference", &[])
        }
        Command::Compare { test, reference, heatmap } => compare(&test, &reference, &heatmap),
        Command::Merge { dir, out } => crate::merge::merge(&dir, &out),
        Command::Farm { farm: Farm::K8s { tasks, k8s, common } } => farm::farm_k8s(registries, &tasks, &k8s, &common),
        Command::Farm { farm: Farm::Slurm { tasks, common, partition, time, dry_run } } => farm::farm_slurm(
            registries,
            farm::SlurmRequest { tasks: &tasks, common: &common, partition, time, dry_run },
        ),
        #[cfg(feature = "view")]
        Command::View { pipeline, common, mu, script, reference, reference_spp } => {
            start_rendering_command(&common)?;
            let opts = crate::view::ViewOptions {
                pipeline,
                registries: registries.clone(),
                overrides: overrides(&common, mu)?,
                backend: common.backend.clone(),
                gpu_limits: common.gpu_limits.clone(),
                out: common.out.clone(),
                memory_limit: common.memory_limit,
                script,
                reference,
                reference_spp,
            };
            crate::view::run(opts)
        }
        Command::Parity { pipeline, scene, width, height, seed, set, memory_limit, gpu_limits, frames } => {
            let ov = Overrides {
                scene,
                width: Some(width),
                height: Some(height),
                seed,
                mu: None,
                params: set.iter().map(|s| crate::session::parse_set(s)).collect::<Result<_, _>>()?,
                ..Overrides::default()
            };
            let mut session = Session::open_with(
                registries,
                pipeline.as_deref(),
                &Overrides { frame: frames.map(|(first, _)| first), ..ov },
            )?;
            check_memory(&session, RunMode::Parity, memory_limit)?;
            let (table, ok) = parity(&mut session, gpu_limits.as_deref(), frames)?;
            if ok {
                Ok(table)
            } else {
                Err(WedgeError::Usage(format!(
                    "{table}the wgpu backend disagrees with the CPU backend (see MISMATCH rows above)"
                )))
            }
        }
        Command::Bench {
            pipeline,
            quick,
            scene,
            suite,
            suite_scenes,
            compare,
            out,
            width,
            height,
            seed,
            reference_spp,
            memory_limit,
            mu_values,
            set,
        } => {
            crate::staging::check_output_dir(&out)?;
            let opts = crate::bench::BenchOptions {
                quick,
                compare,
                scene,
                width,
                height,
                seed,
                reference_spp,
                memory_limit,
                mu_values,
                params: set.iter().map(|s| crate::session::parse_set(s)).collect::<Result<_, _>>()?,
                verbose: true,
                registries: registries.clone(),
                ..crate::bench::BenchOptions::new(pipeline, out)
            };
            if suite {
                let scenes = suite_scene_specs(&opts, &suite_scenes)?;
                let r = crate::bench::suite::run_suite(&opts, &scenes)?;
                return Ok(format!("{}\n", crate::bench::suite::summary(&r)));
            }
            let r = crate::bench::run(&opts)?;
            Ok(format!("{}\n", crate::bench::report::summary(&r)))
        }
        Command::ExportScene { pipeline, scene, out, width, height, allow_outside_dir } => {
            crate::staging::check_output_dir(&out)?;
            let ov = Overrides { scene, width, height, allow_outside_dir, ..Overrides::default() };
            let s = crate::export::open(registries, pipeline.as_deref(), &ov)?;
            let exported = crate::export::export_session(&s, &out)?;
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
            let loaded = crate::session::load_pipeline_or_default(pipeline.as_deref())?;
            let Registries { nodes, kernels } = registries;
            let mut validated = crate::graph::validate(&loaded, nodes)?;
            let ov = Overrides { scene, allow_outside_dir, ..Default::default() };
            let facts = crate::session::graph_scene_facts(&loaded, &validated, &ov)?;
            validated.update_factoring(Some(facts))?;
            let sched = crate::graph::schedule(crate::graph::expand(&validated)?)?;
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
fn memory_line(sched: &crate::graph::Schedule, width: u32, height: u32) -> String {
    use crate::session::format_bytes;
    let b = sched.buffer_bytes(width, height);
    format!(
        "memory at {width}x{height}: estimated peak {} of buffers on the CPU or wgpu backend (pool {} + one pass's \
         outputs {} + sink copies {}), {} for parity; the scene and output images come on top\n",
        format_bytes(sched.peak_bytes(width, height)),
        format_bytes(b.pool),
        format_bytes(b.pass_outputs),
        format_bytes(b.sinks),
        format_bytes(crate::session::parity_buffer_bytes(&b))
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

/// Run the command line of this process over `registries` and exit with its status: what `wedge`'s
/// `main` is, with the built-in registries. Usage and `--help` name the running binary.
pub fn main(registries: Registries) -> ExitCode {
    let cli = match parse_args() {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    // Before the signal thread starts (see `set_threads`).
    if let Err(e) = set_threads(cli.command.threads()) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    if let Err(e) = crate::staging::install_signal_handler() {
        eprintln!(
            "warning: cannot install the SIGINT/SIGTERM handler ({e}); an interrupted run may leave temporary files"
        );
    }
    match run(&registries, cli) {
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

/// The process's arguments as [`Cli`], with usage and help naming the binary that runs (`wedge`, or
/// a user's `wedge-fog`).
fn parse_args() -> Result<Cli, clap::Error> {
    let mut command = Cli::command();
    if let Some(name) =
        std::env::args_os().next().and_then(|a| Path::new(&a).file_name().map(|n| n.to_string_lossy().into_owned()))
    {
        command = command.bin_name(name);
    }
    Cli::from_arg_matches_mut(&mut command.get_matches())
}

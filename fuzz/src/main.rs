//! `wedge-fuzz TARGET [--seconds N] [--seed S] [--corpus DIR]... [--out DIR]`: fuzz one target
//! (or `all`, one after another) and print executions per second and the crashers found;
//! `wedge-fuzz TARGET --replay FILE...` runs saved inputs once each and prints their outcomes.
//! Exit status: 0 no crasher, 1 crashers found (or a replayed input panicked), 2 usage error,
//! 3 a hang and 4 a memory crasher (the process stops at the first of those; the input is saved).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use wedge_fuzz::{by_name, driver, Config, Outcome, TARGETS};

#[global_allocator]
static ALLOC: wedge_fuzz::alloc::CountingAlloc = wedge_fuzz::alloc::CountingAlloc;

#[derive(Parser)]
#[command(name = "wedge-fuzz", about = "Mutation fuzzing of wedge's input readers")]
struct Cli {
    /// pipeline, gltf, glb, obj, exr, camera_path, set, or all
    target: String,
    /// How long to fuzz each target
    #[arg(long, default_value_t = 60.0)]
    seconds: f64,
    /// Stop after this many executions per target (with --seed, a reproducible run)
    #[arg(long)]
    runs: Option<u64>,
    /// Seed of the mutation random number generator
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Extra seed inputs: every file in DIR (may be repeated)
    #[arg(long)]
    corpus: Vec<PathBuf>,
    /// Where crashers are saved (OUT/<target>/<kind>-<hash>.<ext> plus a .txt)
    #[arg(long, default_value = "fuzz-out")]
    out: PathBuf,
    /// Largest input the mutator produces, in bytes
    #[arg(long, default_value_t = 65536)]
    max_len: usize,
    /// One input running longer than this is a hang crasher
    #[arg(long, default_value_t = 5.0)]
    hang_seconds: f64,
    /// A live heap above this many MiB is a memory crasher
    #[arg(long, default_value_t = 2048)]
    memory_mib: usize,
    /// Threads for rayon inside the readers (the BVH build); 1 keeps runs reproducible
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Run these files once each instead of fuzzing
    #[arg(long, num_args = 1..)]
    replay: Vec<PathBuf>,
    /// Fuzz in this process: the first hang or memory crasher ends the run. By default the
    /// fuzzing runs in a child process that is restarted (with the next seed) after one.
    #[arg(long)]
    no_restart: bool,
    /// Skip inputs with this hash (hex, as in crasher file names); used between restarts
    #[arg(long, hide = true)]
    skip_hash: Vec<String>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let targets: Vec<_> = if cli.target == "all" {
        TARGETS.to_vec()
    } else {
        match by_name(&cli.target) {
            Some(t) => vec![t],
            None => {
                let names: Vec<&str> = TARGETS.iter().map(|t| t.name).collect();
                eprintln!("wedge-fuzz: unknown target `{}`; use one of: {}, all", cli.target, names.join(", "));
                return ExitCode::from(2);
            }
        }
    };
    if !(cli.seconds.is_finite() && cli.seconds >= 0.0) {
        eprintln!("wedge-fuzz: --seconds {} is not a duration; give seconds >= 0", cli.seconds);
        return ExitCode::from(2);
    }
    if !(cli.hang_seconds.is_finite() && cli.hang_seconds > 0.0) {
        eprintln!("wedge-fuzz: --hang-seconds {} must be > 0", cli.hang_seconds);
        return ExitCode::from(2);
    }
    if cli.threads == 0 || cli.threads > 1024 {
        eprintln!("wedge-fuzz: --threads {} must be in 1..=1024", cli.threads);
        return ExitCode::from(2);
    }
    // Ignore the error: a global pool may already exist (it cannot in this binary).
    let _ = rayon::ThreadPoolBuilder::new().num_threads(cli.threads).build_global();
    if !wedge_fuzz::alloc::installed() {
        eprintln!("wedge-fuzz: warning: the counting allocator is not installed; memory crashers are not detected");
    }

    if !cli.replay.is_empty() {
        let target = targets[0];
        let mut panicked = false;
        for f in &cli.replay {
            let data = match std::fs::read(f) {
                Ok(d) => d,
                Err(e) => {
                    eprintln!("wedge-fuzz: {}: cannot read: {e}", f.display());
                    return ExitCode::from(2);
                }
            };
            wedge_fuzz::alloc::arm(cli.memory_mib << 20);
            let start = std::time::Instant::now();
            let outcome = wedge_fuzz::run_one(target, &data);
            let ms = start.elapsed().as_secs_f64() * 1e3;
            match outcome {
                Outcome::Ok => println!("{}: ok ({ms:.1} ms)", f.display()),
                Outcome::Err(e) => println!("{}: error ({ms:.1} ms): {e}", f.display()),
                Outcome::Panic(p) => {
                    panicked = true;
                    println!("{}: PANIC ({ms:.1} ms): {p}", f.display())
                }
            }
        }
        return if panicked { ExitCode::from(1) } else { ExitCode::SUCCESS };
    }

    let mut found = false;
    for target in targets {
        let cfg = Config {
            seconds: cli.seconds,
            max_runs: cli.runs,
            seed: cli.seed,
            corpus: cli.corpus.clone(),
            out: cli.out.clone(),
            max_len: cli.max_len,
            hang_seconds: cli.hang_seconds,
            memory_mib: cli.memory_mib,
            skip: cli.skip_hash.iter().filter_map(|h| u64::from_str_radix(h, 16).ok()).collect(),
        };
        eprintln!(
            "wedge-fuzz: fuzzing `{}` for {} s (seed {}), crashers to {}",
            target.name,
            cli.seconds,
            cli.seed,
            cli.out.join(target.name).display()
        );
        if cli.no_restart {
            let report = driver::fuzz(target, &cfg);
            println!("{report}");
            println!("wedge-fuzz-stats {} {}", report.executions, report.seconds);
            found |= !report.crashers.is_empty();
        } else {
            match supervise(&cli, target.name) {
                Ok(crashers) => found |= crashers,
                Err(e) => {
                    eprintln!("wedge-fuzz: cannot run the fuzzing child process: {e}");
                    return ExitCode::from(2);
                }
            }
        }
    }
    if found {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// Fuzz `target` in child processes (`--no-restart`), starting a new one with the next seed and the
/// remaining time whenever one stops at a hang or memory crasher. Prints the children's reports
/// and a total; returns whether any crasher was found.
fn supervise(cli: &Cli, target: &str) -> std::io::Result<bool> {
    let exe = std::env::current_exe()?;
    let start = std::time::Instant::now();
    let (mut executions, mut segments) = (0u64, 0u64);
    let mut crashers: Vec<String> = Vec::new();
    let mut skip: Vec<String> = cli.skip_hash.clone();
    let mut abnormal = 0;
    loop {
        let remaining = cli.seconds - start.elapsed().as_secs_f64();
        let runs_left = cli.runs.map(|r| r.saturating_sub(executions));
        if (segments > 0 && remaining < 0.5) || runs_left == Some(0) {
            break;
        }
        let mut cmd = std::process::Command::new(&exe);
        cmd.arg(target)
            .arg("--no-restart")
            .args(["--seconds", &remaining.max(0.0).to_string()])
            .args(["--seed", &(cli.seed + segments * 7919).to_string()])
            .args(["--out", &cli.out.display().to_string()])
            .args(["--max-len", &cli.max_len.to_string()])
            .args(["--hang-seconds", &cli.hang_seconds.to_string()])
            .args(["--memory-mib", &cli.memory_mib.to_string()])
            .args(["--threads", &cli.threads.to_string()]);
        for c in &cli.corpus {
            cmd.arg("--corpus").arg(c);
        }
        for h in &skip {
            cmd.args(["--skip-hash", h]);
        }
        if let Some(r) = runs_left {
            cmd.args(["--runs", &r.to_string()]);
        }
        let output = cmd.stderr(std::process::Stdio::inherit()).output()?;
        segments += 1;
        for line in String::from_utf8_lossy(&output.stdout).lines() {
            if let Some(stats) = line.strip_prefix("wedge-fuzz-stats ") {
                executions += stats.split(' ').next().and_then(|n| n.parse::<u64>().ok()).unwrap_or(0);
            } else if let Some(c) = line.strip_prefix("wedge-fuzz-crasher ") {
                // `<kind> <dir>/<kind>-<hash>.<ext>`: skip that input from now on.
                if let Some(h) = c.rsplit('-').next().and_then(|s| s.split('.').next()) {
                    skip.push(h.to_string());
                }
                crashers.push(c.to_string());
            } else {
                if let Some(c) = line.strip_prefix("  panic") {
                    crashers.push(format!("panic{c}"));
                }
                println!("{line}");
            }
        }
        match output.status.code() {
            Some(0) | Some(1) => break,
            // A hang or memory crasher, saved by the child: go on with the next seed.
            Some(3) | Some(4) => continue,
            other => {
                abnormal += 1;
                if abnormal > 10 {
                    crashers.push("stopped after 10 abnormal child exits".into());
                    break;
                }
                crashers.push(format!(
                    "child process ended abnormally ({other:?}, e.g. a stack overflow); the input was not saved"
                ));
                continue;
            }
        }
    }
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{target}: total {executions} executions in {secs:.1} s = {:.0} exec/s over {segments} process(es); {} crasher(s){}",
        executions as f64 / secs.max(1e-9),
        crashers.len(),
        crashers.iter().map(|c| format!("\n  {c}")).collect::<String>()
    );
    Ok(!crashers.is_empty())
}

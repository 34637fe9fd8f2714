//! The fuzzing loop and crash handling.
//!
//! A run starts from the target's seeds ([`crate::seeds`]), the files of the `--corpus`
//! directories and the committed regression inputs, runs each once, then mutates random corpus
//! entries until the time (or execution count) is up. An input whose outcome is new (a different
//! error message, digits ignored) joins the corpus: on the stable toolchain there is no coverage
//! instrumentation, and distinct errors are a cheap proxy for distinct code paths.
//!
//! Crashers, each saved to `OUT/<target>/<kind>-<hash>.<ext>` with a `.txt` beside it:
//! - `panic`: the target panicked (caught with `catch_unwind`; the run goes on). One file per
//!   panic location; repeats are counted.
//! - `hang`: one input ran longer than `--hang-seconds`. A watchdog thread saves the input and
//!   exits the process with status 3 (a stuck thread cannot be stopped).
//! - `oom`: the live heap went over `--memory-mib` (see [`crate::alloc`]). The allocator's hook
//!   saves the input and exits with status 4, before the allocation is attempted.

use std::collections::{BTreeMap, HashSet};
use std::hash::{Hash, Hasher};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, Once};
use std::time::{Duration, Instant};

use crate::mutate::Mutator;
use crate::targets::Target;

/// Settings of one fuzzing run.
#[derive(Clone, Debug)]
pub struct Config {
    pub seconds: f64,
    /// Stop after this many executions (whichever of time and count comes first); for
    /// reproducible runs.
    pub max_runs: Option<u64>,
    pub seed: u64,
    /// Extra seed directories (files read in name order).
    pub corpus: Vec<PathBuf>,
    /// Where crashers go (`OUT/<target>/`).
    pub out: PathBuf,
    pub max_len: usize,
    pub hang_seconds: f64,
    pub memory_mib: usize,
    /// Hashes (as in crasher file names) of inputs not to run: hang and memory crashers found
    /// earlier, which would otherwise stop every restarted run at the same input.
    pub skip: HashSet<u64>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            seconds: 10.0,
            max_runs: None,
            seed: 1,
            corpus: Vec::new(),
            out: PathBuf::from("fuzz-out"),
            max_len: 64 * 1024,
            hang_seconds: 5.0,
            memory_mib: 2048,
            skip: HashSet::new(),
        }
    }
}

/// One saved crasher.
#[derive(Clone, Debug)]
pub struct Crasher {
    pub kind: &'static str,
    /// Panic message and location.
    pub message: String,
    pub file: PathBuf,
    /// How many inputs crashed at the same location.
    pub hits: u64,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct Report {
    pub target: &'static str,
    pub executions: u64,
    pub seconds: f64,
    pub corpus: usize,
    /// Distinct outcome features seen (message line shapes; the novelty signal).
    pub outcomes: usize,
    pub crashers: Vec<Crasher>,
    pub peak_heap_bytes: usize,
}

impl Report {
    pub fn execs_per_second(&self) -> f64 {
        self.executions as f64 / self.seconds.max(1e-9)
    }
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} executions in {:.1} s = {:.0} exec/s; corpus {}, {} outcome features, peak heap {} MiB; {} crasher(s)",
            self.target,
            self.executions,
            self.seconds,
            self.execs_per_second(),
            self.corpus,
            self.outcomes,
            self.peak_heap_bytes >> 20,
            self.crashers.len()
        )?;
        for c in &self.crashers {
            write!(f, "\n  {} x{}: {} -> {}", c.kind, c.hits, c.message, c.file.display())?;
        }
        Ok(())
    }
}

/// What the watchdog and the allocator hook need to save the input being run.
struct Current {
    target: Option<Target>,
    out: PathBuf,
    input: Vec<u8>,
}

static CURRENT: Mutex<Current> = Mutex::new(Current { target: None, out: PathBuf::new(), input: Vec::new() });
/// Milliseconds since [`epoch`] when the current execution started; 0 when idle.
static EXEC_START_MS: AtomicU64 = AtomicU64::new(0);
static HANG_LIMIT_MS: AtomicU64 = AtomicU64::new(5000);
/// The last panic's message and location, recorded by the hook while fuzzing.
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);
static FUZZING: AtomicBool = AtomicBool::new(false);
/// Executions in this process, and when fuzzing started (ms since [`epoch`]), for the statistics
/// line printed when the process ends at a hang or memory crasher.
static EXECUTIONS: AtomicU64 = AtomicU64::new(0);
static FUZZ_START_MS: AtomicU64 = AtomicU64::new(0);

fn epoch() -> Instant {
    static EPOCH: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

fn now_ms() -> u64 {
    epoch().elapsed().as_millis() as u64 + 1
}

/// Install the panic hook (silent while fuzzing), the watchdog and the allocator hook, once.
fn install() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        epoch();
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if FUZZING.load(Ordering::SeqCst) {
                let msg = match info.payload().downcast_ref::<&str>() {
                    Some(s) => s.to_string(),
                    None => info
                        .payload()
                        .downcast_ref::<String>()
                        .cloned()
                        .unwrap_or_else(|| "(non-string panic payload)".into()),
                };
                let at = info
                    .location()
                    .map(|l| format!("{}:{}:{}", l.file(), l.line(), l.column()))
                    .unwrap_or_else(|| "(unknown location)".into());
                *LAST_PANIC.lock().unwrap_or_else(|e| e.into_inner()) = Some(format!("{msg} at {at}"));
            } else {
                default(info);
            }
        }));
        std::thread::Builder::new()
            .name("wedge-fuzz-watchdog".into())
            .spawn(|| loop {
                std::thread::sleep(Duration::from_millis(100));
                let start = EXEC_START_MS.load(Ordering::SeqCst);
                let limit = HANG_LIMIT_MS.load(Ordering::SeqCst);
                if start != 0 && now_ms().saturating_sub(start) > limit {
                    save_current_and_exit(
                        "hang",
                        &format!("one input ran longer than {:.1} s", limit as f64 / 1000.0),
                        3,
                    );
                }
            })
            .expect("cannot start the watchdog thread");
        crate::alloc::set_hook(|live| {
            // The hook runs on the allocating thread, so its backtrace shows who asked.
            let trace = std::backtrace::Backtrace::force_capture();
            save_current_and_exit(
                "oom",
                &format!("the live heap would reach {} MiB, over the cap\nbacktrace:\n{trace}", live >> 20),
                4,
            )
        });
    });
}

/// A line on stderr that the test harness's output capture does not swallow (the process is about
/// to exit, and the captured output would be lost with it).
fn say(line: String) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// Save the input being run as a crasher of `kind` and end the process with `code`.
fn save_current_and_exit(kind: &'static str, message: &str, code: i32) -> ! {
    // The fuzzed thread never holds this lock while running an input.
    let current = CURRENT.lock().unwrap_or_else(|e| e.into_inner());
    if current.out.as_os_str().is_empty() {
        // `run_one` outside `fuzz` (replays, regression tests): the input is a file already.
        let name = current.target.map_or("?", |t| t.name);
        say(format!("wedge-fuzz: {name}: {kind} crasher: {}", message.lines().next().unwrap_or("")));
        std::process::exit(code);
    }
    if let Some(target) = current.target {
        match save(&current.out, target, kind, message, &current.input) {
            Ok(path) => {
                // For a supervising parent process (see main.rs), on stdout.
                println!("wedge-fuzz-crasher {kind} {}", path.display());
                let secs = now_ms().saturating_sub(FUZZ_START_MS.load(Ordering::SeqCst)) as f64 / 1e3;
                println!("wedge-fuzz-stats {} {secs}", EXECUTIONS.load(Ordering::SeqCst));
                say(format!(
                    "wedge-fuzz: {}: {kind} crasher ({}) saved to {}",
                    target.name,
                    message.lines().next().unwrap_or(""),
                    path.display()
                ))
            }
            Err(e) => say(format!("wedge-fuzz: {}: {kind} crasher ({message}); could not save it: {e}", target.name)),
        }
    }
    std::process::exit(code)
}

/// The hash that names an input's crasher file (`<kind>-<hash as 16 hex digits>.<ext>`).
pub fn hash(data: &[u8]) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    data.hash(&mut h);
    h.finish()
}

/// Write a crasher and its description; returns the input file's path.
fn save(out: &Path, target: Target, kind: &str, message: &str, input: &[u8]) -> std::io::Result<PathBuf> {
    let dir = out.join(target.name);
    std::fs::create_dir_all(&dir)?;
    let path = dir.join(format!("{kind}-{:016x}.{}", hash(input), target.ext));
    std::fs::write(&path, input)?;
    let mut txt = path.clone().into_os_string();
    txt.push(".txt");
    std::fs::write(
        txt,
        format!(
            "target: {}\nkind: {kind}\nmessage: {message}\nreplay: cargo run --release -p wedge-fuzz -- {} --replay {}\n",
            target.name,
            target.name,
            path.display()
        ),
    )?;
    Ok(path)
}

/// The result of running one input.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    Ok,
    /// The reader's error message.
    Err(String),
    /// The panic message and location.
    Panic(String),
}

/// Run one input under `catch_unwind` and the watchdog.
pub fn run_one(target: Target, input: &[u8]) -> Outcome {
    install();
    {
        let mut c = CURRENT.lock().unwrap_or_else(|e| e.into_inner());
        c.input.clear();
        c.input.extend_from_slice(input);
        c.target = Some(target);
    }
    FUZZING.store(true, Ordering::SeqCst);
    EXECUTIONS.fetch_add(1, Ordering::SeqCst);
    EXEC_START_MS.store(now_ms(), Ordering::SeqCst);
    let result = catch_unwind(AssertUnwindSafe(|| (target.run)(input)));
    EXEC_START_MS.store(0, Ordering::SeqCst);
    FUZZING.store(false, Ordering::SeqCst);
    match result {
        Ok(Ok(())) => Outcome::Ok,
        Ok(Err(e)) => Outcome::Err(e),
        Err(_) => Outcome::Panic(
            LAST_PANIC
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .take()
                .unwrap_or_else(|| "(panic message not recorded)".into()),
        ),
    }
}

/// The novelty features of an outcome: the *shape* of each line of the message: its lower-case
/// words before the first quote (`…`, "…"), so lines that differ only in the user's names or
/// values are one feature. An input is kept when it shows a
/// feature not seen before; taking lines one by one (not their combination) keeps reports with
/// several problems from making nearly every input "new" and filling the corpus with noise.
fn features(o: &Outcome) -> Vec<u64> {
    let text = match o {
        Outcome::Ok => return vec![0],
        Outcome::Err(e) | Outcome::Panic(e) => e,
    };
    let mut out = Vec::new();
    for line in text.lines().take(200) {
        // Up to the first quote: what follows may be the user's (mutated) text, and quotes inside
        // it need not pair up.
        let head = line.split(['`', '"']).next().unwrap_or("");
        let kept: String = head
            .split(|c: char| !c.is_ascii_lowercase())
            .filter(|w| w.len() >= 2)
            // Help lines end in lists of the user's names ("nodes in this pipeline: a, b"):
            // the first words say what the line is.
            .take(8)
            .collect::<Vec<_>>()
            .join(" ");
        out.push(hash(kept.as_bytes()));
    }
    out
}

/// Files in `dir` (not recursive), in name order; a missing directory is empty.
pub fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && p.extension().is_none_or(|e| e != "txt" && e != "md"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// The committed regression inputs of a target: `tests/data/bad/fuzz/<target>/`.
pub fn regression_dir(target: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/bad/fuzz").join(target)
}

/// Fuzz `target` as configured.
pub fn fuzz(target: Target, cfg: &Config) -> Report {
    install();
    crate::alloc::arm(cfg.memory_mib << 20);
    crate::alloc::reset_peak();
    HANG_LIMIT_MS.store((cfg.hang_seconds * 1000.0) as u64, Ordering::SeqCst);
    FUZZ_START_MS.store(now_ms(), Ordering::SeqCst);
    EXECUTIONS.store(0, Ordering::SeqCst);
    CURRENT.lock().unwrap_or_else(|e| e.into_inner()).out = cfg.out.clone();

    let mut corpus: Vec<Vec<u8>> = crate::seeds::seeds(target.name);
    let mut dirs = cfg.corpus.clone();
    dirs.push(regression_dir(target.name));
    for dir in &dirs {
        for f in files_in(dir) {
            if let Ok(bytes) = std::fs::read(&f) {
                corpus.push(bytes);
            }
        }
    }
    if corpus.is_empty() {
        corpus.push(Vec::new());
    }

    let start = Instant::now();
    let deadline = Duration::from_secs_f64(cfg.seconds);
    let mut mutator = Mutator::new(cfg.seed, target.name, target.text, cfg.max_len);
    let mut seen: HashSet<u64> = HashSet::new();
    // Panic location → crasher, so one bug is saved once however often it is hit.
    let mut crashers: BTreeMap<String, Crasher> = BTreeMap::new();
    let mut executions = 0u64;
    let initial = corpus.len();
    const MAX_CORPUS: usize = 4096;

    let mut handle = |input: &[u8], outcome: Outcome, crashers: &mut BTreeMap<String, Crasher>| {
        if let Outcome::Panic(msg) = &outcome {
            let location = msg.rsplit(" at ").next().unwrap_or(msg).to_string();
            crashers.entry(location).and_modify(|c| c.hits += 1).or_insert_with(|| Crasher {
                kind: "panic",
                message: msg.clone(),
                file: save(&cfg.out, target, "panic", msg, input)
                    .unwrap_or_else(|e| PathBuf::from(format!("(not saved: {e})"))),
                hits: 1,
            });
        }
        let mut new = false;
        for f in features(&outcome) {
            new |= seen.insert(f);
        }
        if new && std::env::var_os("WEDGE_FUZZ_DEBUG").is_some() {
            eprintln!("NEW {outcome:?}");
        }
        new
    };

    for input in corpus.clone() {
        if cfg.skip.contains(&hash(&input)) {
            continue;
        }
        let outcome = run_one(target, &input);
        executions += 1;
        handle(&input, outcome, &mut crashers);
    }
    while start.elapsed() < deadline && cfg.max_runs.is_none_or(|m| executions < m) {
        let parent = mutator.rng.usize(..corpus.len());
        let donor = mutator.rng.usize(..corpus.len());
        let input = mutator.mutate(&corpus[parent], &corpus[donor]);
        if cfg.skip.contains(&hash(&input)) {
            continue;
        }
        let outcome = run_one(target, &input);
        executions += 1;
        if handle(&input, outcome, &mut crashers) {
            if corpus.len() < MAX_CORPUS {
                corpus.push(input);
            } else {
                // Keep the seeds; replace a random later entry.
                let i = mutator.rng.usize(initial.min(MAX_CORPUS - 1)..MAX_CORPUS);
                corpus[i] = input;
            }
        }
    }
    crate::alloc::arm(0);
    Report {
        target: target.name,
        executions,
        seconds: start.elapsed().as_secs_f64(),
        corpus: corpus.len(),
        outcomes: seen.len(),
        crashers: crashers.into_values().collect(),
        peak_heap_bytes: crate::alloc::peak_bytes(),
    }
}

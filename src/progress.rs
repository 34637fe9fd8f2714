//! Progress bars for long passes and for compiling GPU kernels (indicatif): bars only on a
//! terminal; the compile phase also says what is happening in one line anywhere (a log, a farm job),
//! since on a CPU emulation with a cold shader cache it can take minutes.
//!
//! [`TaskProgress`]: one line per 10% of a render task's work on stderr (`--progress human|json|none`),
//! so that a farm's logs show where each task is. The work is counted, not timed: every pass of every
//! run the task makes (tiles × frames, warm-up frames included) weighted by the pixels that run
//! computes, so the lines a task prints depend only on its schedule and size; they never touch the
//! image.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use wedge_backends::Progress;

/// One bar per sampling pass, counting image rows, or for the kernels being compiled.
#[derive(Default)]
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
    /// While compiling: kernels announced so far and their number, for the lines written when
    /// stderr is not a terminal.
    compile: Mutex<(u64, u64)>,
}

impl Bars {
    /// Print `text` on stderr above the bar being drawn (if any), so the bar does not overwrite it.
    pub fn line(&self, text: &str) {
        match self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            Some(b) => b.suspend(|| eprintln!("{text}")),
            None => eprintln!("{text}"),
        }
    }

    fn set(&self, bar: Option<ProgressBar>) -> Option<ProgressBar> {
        std::mem::replace(&mut *self.bar.lock().unwrap_or_else(|e| e.into_inner()), bar)
    }
}

impl Progress for Bars {
    fn begin(&self, pass: &str, rows: u64) {
        let bar = ProgressBar::new(rows);
        bar.set_style(
            ProgressStyle::with_template("{prefix:>24} [{bar:40}] {pos}/{len} rows {elapsed_precise}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_prefix(pass.to_string());
        self.set(Some(bar));
    }
    fn advance(&self, rows: u64) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            b.inc(rows);
        }
    }
    fn end(&self) {
        if let Some(b) = self.set(None) {
            b.finish_and_clear();
        }
    }
    fn begin_compile(&self, kernels: u64, software: bool) {
        let why = if software {
            " on a CPU emulation of a GPU: the first run with an empty shader cache takes minutes, later runs read the cache"
        } else {
            ""
        };
        eprintln!("compiling {kernels} GPU kernel(s){why}");
        *self.compile.lock().unwrap_or_else(|e| e.into_inner()) = (0, kernels);
        let bar = ProgressBar::new(kernels);
        bar.set_style(
            ProgressStyle::with_template("{prefix:>24} [{bar:40}] {pos}/{len} kernels {elapsed_precise} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_prefix("compiling");
        self.set(Some(bar));
    }
    fn compiling(&self, kernel: &str) {
        let (done, total) = {
            let mut c = self.compile.lock().unwrap_or_else(|e| e.into_inner());
            c.0 += 1;
            *c
        };
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            b.set_message(format!("`{kernel}`"));
        }
        // The bar is hidden off a terminal: a line per kernel shows where a long compile is.
        if !std::io::stderr().is_terminal() {
            eprintln!("  compiling kernel {done}/{total}: `{kernel}`");
        }
    }
}

/// `--progress`: how a task reports its progress lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressFormat {
    /// `progress: 30% tile 2/4 frame 7 (pass sampler.adaptive)`.
    Human,
    /// One JSON object per line: `{"task":"render","percent":30,"tile":"2/4","frame":7,...}`.
    Json,
    /// No lines.
    None,
}

impl ProgressFormat {
    /// The flag's value (`human`, `json`, `none`; clap has checked it).
    pub fn parse(s: &str) -> ProgressFormat {
        match s {
            "json" => ProgressFormat::Json,
            "none" => ProgressFormat::None,
            _ => ProgressFormat::Human,
        }
    }
}

/// Where a task's runs are: the run now going (its tile, frame, and weight per pass) and the work
/// done so far.
#[derive(Default)]
struct TaskState {
    done: u64,
    /// Tenths of the work reported so far (0..=10).
    reported: u64,
    tile: Option<(u32, u32)>,
    frame: Option<u32>,
    /// Work one pass of the current run counts: the pixels it computes.
    weight: u64,
}

/// The progress of one render task over all its runs: forwards the passes' rows to the bars and
/// prints a line each time another tenth of the work is done (see the module doc).
pub struct TaskProgress<'a> {
    /// The per-pass bars it forwards to; none where the caller draws a bar of its own (the frames of
    /// `render --progressive`).
    bars: Option<&'a Bars>,
    format: ProgressFormat,
    /// What the task is: `render`, `tile`, `tiles`, `frames`, `shard`.
    task: &'static str,
    total: u64,
    start: Instant,
    state: Mutex<TaskState>,
}

impl<'a> TaskProgress<'a> {
    /// A task of `total` work units: the sum over its runs of passes × pixels ([`TaskProgress::work`]).
    pub fn new(bars: &'a Bars, format: ProgressFormat, task: &'static str, total: u64) -> TaskProgress<'a> {
        TaskProgress {
            bars: Some(bars),
            format,
            task,
            total: total.max(1),
            start: Instant::now(),
            state: Mutex::new(TaskState::default()),
        }
    }

    /// [`TaskProgress::new`] with no per-pass bars: only the lines.
    pub fn lines_only(format: ProgressFormat, task: &'static str, total: u64) -> TaskProgress<'static> {
        TaskProgress {
            bars: None,
            format,
            task,
            total: total.max(1),
            start: Instant::now(),
            state: Mutex::new(TaskState::default()),
        }
    }

    /// The work of one run of `passes` passes over `pixels` pixels.
    pub fn work(passes: usize, pixels: u64) -> u64 {
        (passes as u64).saturating_mul(pixels)
    }

    /// The next run: tile `tile` (index, count) and frame `frame` where the task has them, each of its
    /// passes computing `pixels` pixels.
    pub fn at(&self, tile: Option<(u32, u32)>, frame: Option<u32>, pixels: u64) {
        let mut s = self.lock();
        (s.tile, s.frame, s.weight) = (tile, frame, pixels);
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, TaskState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The line for `percent` after `pass`, in the task's format.
    fn render_line(&self, s: &TaskState, percent: u64, pass: &str) -> String {
        let elapsed = self.start.elapsed().as_secs_f64();
        match self.format {
            ProgressFormat::Json => serde_json::json!({
                "task": self.task,
                "percent": percent,
                "tile": s.tile.map(|(i, n)| format!("{i}/{n}")),
                "frame": s.frame,
                "pass": pass,
                "elapsed_s": (elapsed * 10.0).round() / 10.0,
            })
            .to_string(),
            _ => {
                // The task's kind only where no tile or frame says where it is (JSON always has it).
                let mut line = format!("progress: {percent}%");
                if s.tile.is_none() && s.frame.is_none() {
                    line.push_str(&format!(" {}", self.task));
                }
                if let Some((i, n)) = s.tile {
                    line.push_str(&format!(" tile {i}/{n}"));
                }
                if let Some(f) = s.frame {
                    line.push_str(&format!(" frame {f}"));
                }
                line.push_str(&format!(" (pass {pass}, {elapsed:.1} s)"));
                line
            }
        }
    }
}

impl Progress for TaskProgress<'_> {
    fn begin(&self, pass: &str, rows: u64) {
        if let Some(b) = self.bars {
            b.begin(pass, rows);
        }
    }
    fn advance(&self, rows: u64) {
        if let Some(b) = self.bars {
            b.advance(rows);
        }
    }
    fn end(&self) {
        if let Some(b) = self.bars {
            b.end();
        }
    }
    fn begin_compile(&self, kernels: u64, software: bool) {
        if let Some(b) = self.bars {
            b.begin_compile(kernels, software);
        }
    }
    fn compiling(&self, kernel: &str) {
        if let Some(b) = self.bars {
            b.compiling(kernel);
        }
    }
    fn pass_done(&self, pass: &str) {
        let mut s = self.lock();
        s.done = s.done.saturating_add(s.weight).min(self.total);
        // u128: passes × pixels × 10 of a large sequence can pass u64.
        let tenths = (u128::from(s.done) * 10 / u128::from(self.total)) as u64;
        if tenths > s.reported {
            s.reported = tenths;
            if self.format != ProgressFormat::None {
                let line = self.render_line(&s, tenths * 10, pass);
                match self.bars {
                    Some(b) => b.line(&line),
                    None => eprintln!("{line}"),
                }
            }
        }
    }
}

//! Progress bars for long passes and for compiling GPU kernels (indicatif): bars only on a
//! terminal; the compile phase also says what is happening in one line anywhere (a log, a farm job),
//! since on a CPU emulation with a cold shader cache it can take minutes.

use std::io::IsTerminal;
use std::sync::Mutex;

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

//! Progress bars for long passes (indicatif), shown only on a terminal.

use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressStyle};
use wedge_backends::Progress;

/// One bar per sampling pass, counting image rows.
#[derive(Default)]
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
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
        *self.bar.lock().unwrap_or_else(|e| e.into_inner()) = Some(bar);
    }
    fn advance(&self, rows: u64) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            b.inc(rows);
        }
    }
    fn end(&self) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
        }
    }
}

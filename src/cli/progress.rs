//! The terminal sink of the library's progress reports
//! ([`deformlab::solve::progress`]): one spinner line on stderr with the
//! current step, its count and the elapsed time; nothing when stderr is not
//! a terminal (logs stay clean).

use std::io::IsTerminal;
use std::sync::Arc;

use deformlab::solve::progress::{install, ProgressSink, SinkGuard};

struct Spinner(indicatif::ProgressBar);

impl ProgressSink for Spinner {
    fn update(&self, step: &str, done: usize, total: usize) {
        let msg = if total > 0 {
            format!("{step} {done}/{total}")
        } else {
            format!("{step} {done}")
        };
        self.0.set_message(msg);
    }
}

/// The installed spinner: cleared and uninstalled when dropped.
pub struct TerminalProgress {
    bar: indicatif::ProgressBar,
    _guard: SinkGuard,
}

impl Drop for TerminalProgress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}

/// Installs the spinner for the rest of the command when stderr is a
/// terminal; `None` otherwise.
pub fn on_terminal() -> Option<TerminalProgress> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new_spinner();
    if let Ok(style) = indicatif::ProgressStyle::with_template("{spinner} {wide_msg} [{elapsed}]") {
        bar.set_style(style);
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    let guard = install(Arc::new(Spinner(bar.clone())));
    Some(TerminalProgress { bar, _guard: guard })
}

//! The sinks of the library's progress reports
//! ([`deformlab::solve::progress`]) for the commands: on a terminal, one
//! spinner line on stderr with the current step, its count and the elapsed
//! time; in a log (stderr not a terminal), a line at least every 30 s with
//! the latest step ([`Heartbeat`]), so a long precomputation is never
//! silent.

use std::io::IsTerminal;
use std::sync::Arc;

use deformlab::solve::progress::{
    fit_to_width, install, step_message, terminal_columns, Heartbeat, ProgressSink, SinkGuard,
};

struct Spinner(indicatif::ProgressBar);

/// Columns of the spinner line besides the step: the spinner, spaces and
/// ` [1h 23m 45s]`.
const SPINNER_RESERVE: usize = 16;

impl ProgressSink for Spinner {
    fn update(&self, step: &str, done: usize, total: usize) {
        // Fitted here, at a word, with an ellipsis: indicatif would cut the
        // message at the terminal's edge mid-word.
        let width = terminal_columns().saturating_sub(SPINNER_RESERVE);
        self.0
            .set_message(fit_to_width(&step_message(step, done, total), width));
    }
}

/// The installed sink: cleared and uninstalled when dropped.
pub enum CommandProgress {
    Spinner {
        bar: indicatif::ProgressBar,
        _guard: SinkGuard,
    },
    /// Held for its lines (they stop when it is dropped).
    Log { _beat: Heartbeat },
}

impl Drop for CommandProgress {
    fn drop(&mut self) {
        if let CommandProgress::Spinner { bar, .. } = self {
            bar.finish_and_clear();
        }
    }
}

/// Installs the spinner (stderr is a terminal) or the heartbeat (a log)
/// for `command` until the value is dropped.
pub fn for_command(command: &str) -> CommandProgress {
    if !std::io::stderr().is_terminal() {
        return CommandProgress::Log {
            _beat: Heartbeat::start(command, String::new),
        };
    }
    let bar = indicatif::ProgressBar::new_spinner();
    if let Ok(style) = indicatif::ProgressStyle::with_template("{spinner} {wide_msg} [{elapsed}]") {
        bar.set_style(style);
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    let guard = install(Arc::new(Spinner(bar.clone())));
    CommandProgress::Spinner { bar, _guard: guard }
}

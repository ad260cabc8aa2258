//! Progress of long steps inside the library (bounded biharmonic weights,
//! key point selection, nonrigid ICP, the synthetic generator), reported to
//! one process-wide sink.
//!
//! The library never prints: a long step calls [`update`] with what it is
//! doing (`"key points: stage 1, 3 → 4 key points"`) and how far it is
//! (`done` of `total`, `total = 0` when unknown). Nothing happens unless a
//! front-end installed a [`ProgressSink`] ([`install`]); the CLI installs
//! one that draws on a terminal and stays quiet in logs. Updates are cheap
//! (a read lock and, with no sink, nothing else), so a step may report at
//! every iteration; the sink decides how often to draw.
//!
//! Reports never change results: they are one-way, and steps running in
//! parallel report through the same sink in whatever order they reach it.

use std::sync::{Arc, RwLock};

/// Where progress goes (a terminal bar, a test's recorder).
pub trait ProgressSink: Send + Sync {
    /// `step` is doing `done` of `total` units (`total = 0`: unknown).
    fn update(&self, step: &str, done: usize, total: usize);
}

static SINK: RwLock<Option<Arc<dyn ProgressSink>>> = RwLock::new(None);

/// Installs `sink` until the returned guard is dropped (the previous sink,
/// if any, is restored then).
pub fn install(sink: Arc<dyn ProgressSink>) -> SinkGuard {
    let mut s = SINK.write().unwrap_or_else(|e| e.into_inner());
    SinkGuard {
        previous: s.replace(sink),
    }
}

/// Restores the previous sink when dropped (see [`install`]).
pub struct SinkGuard {
    previous: Option<Arc<dyn ProgressSink>>,
}

impl Drop for SinkGuard {
    fn drop(&mut self) {
        let mut s = SINK.write().unwrap_or_else(|e| e.into_inner());
        *s = self.previous.take();
    }
}

/// Whether a sink is installed (to skip building a message nobody reads).
pub fn enabled() -> bool {
    SINK.read().map(|s| s.is_some()).unwrap_or(false)
}

/// Reports that `step` has done `done` of `total` units (`total = 0`:
/// unknown). A no-op without a sink.
pub fn update(step: &str, done: usize, total: usize) {
    let sink = match SINK.read() {
        Ok(s) => s.clone(),
        Err(_) => None,
    };
    if let Some(s) = sink {
        s.update(step, done, total);
    }
}

/// [`update`] with a message built only when a sink is installed.
pub fn update_with(step: impl FnOnce() -> String, done: usize, total: usize) {
    if enabled() {
        update(&step(), done, total);
    }
}

/// Default period of [`Heartbeat`] lines (seconds); the environment
/// variable `DEFORMLAB_HEARTBEAT_SECONDS` overrides it (tests use 1).
pub const HEARTBEAT_SECONDS: u64 = 30;

/// The heartbeat period: [`HEARTBEAT_SECONDS`], or a positive whole number
/// of seconds in `DEFORMLAB_HEARTBEAT_SECONDS`.
pub fn heartbeat_period() -> std::time::Duration {
    let s = std::env::var("DEFORMLAB_HEARTBEAT_SECONDS")
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .filter(|&s| s > 0)
        .unwrap_or(HEARTBEAT_SECONDS);
    std::time::Duration::from_secs(s)
}

struct Beat {
    label: String,
    start: std::time::Instant,
    period: std::time::Duration,
    /// The latest step reported, and when a line was last written.
    state: std::sync::Mutex<(Option<String>, std::time::Instant)>,
    stop: std::sync::Mutex<bool>,
    wake: std::sync::Condvar,
}

/// The text of a progress step: `step done/total`, or `step done` when the
/// total is unknown (0). Used by every sink (bar, spinner, heartbeat).
pub fn step_message(step: &str, done: usize, total: usize) -> String {
    if total > 0 {
        format!("{step} {done}/{total}")
    } else {
        format!("{step} {done}")
    }
}

/// Columns of a terminal line when none can be measured.
pub const DEFAULT_COLUMNS: usize = 80;

/// The width of the progress lines in columns: stderr's terminal width when
/// stderr is a terminal; else a positive whole number in the environment
/// variable `COLUMNS` when set; else [`DEFAULT_COLUMNS`].
pub fn terminal_columns() -> usize {
    let env = std::env::var("COLUMNS").ok();
    columns_from(
        console::Term::stderr()
            .size_checked()
            .map(|(_, c)| c as usize),
        env.as_deref(),
    )
}

/// [`terminal_columns`] from the measured terminal width and `COLUMNS`.
fn columns_from(terminal: Option<usize>, env: Option<&str>) -> usize {
    terminal
        .filter(|&c| c > 0)
        .or_else(|| {
            env.and_then(|v| v.trim().parse::<usize>().ok())
                .filter(|&c| c > 0)
        })
        .unwrap_or(DEFAULT_COLUMNS)
}

/// `text` fitted into `width` columns (as a terminal shows it, wide
/// characters counting two): unchanged if it fits; else cut after the last
/// whole word that leaves room for an ellipsis `…`, or mid-word when the
/// first word alone is too wide (or the last word break would drop more
/// than half the line).
pub fn fit_to_width(text: &str, width: usize) -> String {
    use console::measure_text_width as w;
    if w(text) <= width {
        return text.to_string();
    }
    if width == 0 {
        return String::new();
    }
    // The longest prefix of whole characters that leaves a column for `…`.
    let room = width - 1;
    let mut end = 0;
    for (i, ch) in text.char_indices() {
        let next = i + ch.len_utf8();
        if w(&text[..next]) > room {
            break;
        }
        end = next;
    }
    let cut = &text[..end];
    // Back to the last word break when the text is cut inside a word.
    let inside_word = text[end..]
        .chars()
        .next()
        .is_some_and(|c| !c.is_whitespace())
        && cut.chars().last().is_some_and(|c| !c.is_whitespace());
    let kept = match cut.rfind(char::is_whitespace) {
        Some(b) if inside_word && w(&cut[..b]) * 2 >= room => &cut[..b],
        _ => cut,
    };
    format!("{}…", kept.trim_end())
}

impl ProgressSink for Beat {
    fn update(&self, step: &str, done: usize, total: usize) {
        let msg = step_message(step, done, total);
        if let Ok(mut s) = self.state.lock() {
            s.0 = Some(msg);
        }
    }
}

/// Progress for logs (stderr not a terminal): while it lives, a line on
/// stderr at least every [`heartbeat_period`] — `label`, the elapsed time,
/// what `status` says and the latest step a long computation reported —
/// unless another line was written meanwhile ([`Heartbeat::wrote`]). It
/// is installed as the progress sink and uninstalled when dropped.
pub struct Heartbeat {
    beat: Arc<Beat>,
    thread: Option<std::thread::JoinHandle<()>>,
    _guard: SinkGuard,
}

impl Heartbeat {
    /// Starts the heartbeat; `status` is called from its thread at each
    /// line (e.g. `"3 of 40 rows done"`).
    pub fn start(label: &str, status: impl Fn() -> String + Send + 'static) -> Heartbeat {
        let now = std::time::Instant::now();
        let beat = Arc::new(Beat {
            label: label.to_string(),
            start: now,
            period: heartbeat_period(),
            state: std::sync::Mutex::new((None, now)),
            stop: std::sync::Mutex::new(false),
            wake: std::sync::Condvar::new(),
        });
        let guard = install(beat.clone());
        let b = beat.clone();
        let thread = std::thread::Builder::new()
            .name("deformlab-heartbeat".into())
            .spawn(move || {
                let mut stopped = b.stop.lock().unwrap_or_else(|e| e.into_inner());
                loop {
                    let due = b
                        .state
                        .lock()
                        .map(|s| s.1 + b.period)
                        .unwrap_or_else(|_| std::time::Instant::now() + b.period);
                    let wait = due.saturating_duration_since(std::time::Instant::now());
                    if !wait.is_zero() {
                        stopped = b
                            .wake
                            .wait_timeout(stopped, wait)
                            .unwrap_or_else(|e| e.into_inner())
                            .0;
                    }
                    if *stopped {
                        return;
                    }
                    let Ok(mut s) = b.state.lock() else { return };
                    if s.1 + b.period > std::time::Instant::now() {
                        continue;
                    }
                    let parts: Vec<String> = [status(), s.0.clone().unwrap_or_default()]
                        .into_iter()
                        .filter(|p| !p.is_empty())
                        .collect();
                    eprintln!(
                        "{}: still working after {:.0} s{}{}",
                        b.label,
                        b.start.elapsed().as_secs_f64(),
                        if parts.is_empty() { "" } else { "; " },
                        parts.join("; ")
                    );
                    s.1 = std::time::Instant::now();
                }
            })
            .ok();
        Heartbeat {
            beat,
            thread,
            _guard: guard,
        }
    }

    /// Another line was written now: the next heartbeat waits a full
    /// period from here.
    pub fn wrote(&self) {
        if let Ok(mut s) = self.beat.state.lock() {
            s.1 = std::time::Instant::now();
        }
    }
}

impl Drop for Heartbeat {
    fn drop(&mut self) {
        if let Ok(mut s) = self.beat.stop.lock() {
            *s = true;
        }
        self.beat.wake.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fitting_keeps_short_text_and_cuts_long_text_at_a_word() {
        assert_eq!(fit_to_width("key points 3/8", 80), "key points 3/8");
        assert_eq!(fit_to_width("abc", 3), "abc");
        let long = "key points: stage 1, 3 → 4 key points, candidate 17 of 24";
        let fit = fit_to_width(long, 30);
        assert_eq!(fit, "key points: stage 1, 3 → 4…");
        assert!(console::measure_text_width(&fit) <= 30);
        // A break at a space is kept whole ("stage 1," not "stage 1, 3").
        assert_eq!(fit_to_width("one two three", 9), "one two…");
        // One long word: cut inside it.
        assert_eq!(fit_to_width("abcdefghij", 5), "abcd…");
        // A break that would drop more than half the line: cut inside the word.
        assert_eq!(fit_to_width("a bcdefghijklmnop", 10), "a bcdefgh…");
        assert_eq!(fit_to_width("abc", 0), "");
        assert_eq!(fit_to_width("abc", 1), "…");
        // Wide characters count two columns.
        let wide = fit_to_width("漢字漢字漢字", 7);
        assert!(console::measure_text_width(&wide) <= 7, "{wide}");
    }

    #[test]
    fn columns_come_from_the_terminal_then_columns_then_80() {
        assert_eq!(columns_from(Some(132), Some("100")), 132);
        assert_eq!(columns_from(None, Some("100")), 100);
        assert_eq!(columns_from(None, Some(" 0")), DEFAULT_COLUMNS);
        assert_eq!(columns_from(None, Some("wide")), DEFAULT_COLUMNS);
        assert_eq!(columns_from(None, None), DEFAULT_COLUMNS);
    }
}

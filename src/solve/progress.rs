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

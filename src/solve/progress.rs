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

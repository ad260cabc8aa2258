//! Process-wide memos of deterministic results (key point selections and
//! fits, skeleton rigs): configs that repeat one expensive computation in
//! many rows compute it once. A memoised result equals a recomputed one.

use std::sync::Arc;

use crate::mesh::Mesh;
use crate::Result;

/// A hash of meshes' vertex coordinates and faces (memo keys).
pub(crate) fn meshes_hash<'m>(meshes: impl IntoIterator<Item = &'m Mesh>) -> u64 {
    let mut bytes: Vec<u8> = Vec::new();
    for m in meshes {
        for p in m.vertices() {
            for c in p.coords.iter() {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
        }
        for f in m.faces() {
            for &i in f {
                bytes.extend_from_slice(&(i as u64).to_le_bytes());
            }
        }
        bytes.push(0xff);
    }
    crate::data::fnv1a(&bytes)
}

/// A process-wide memo of deterministic results keyed by a hash of the
/// source meshes and a description of everything else they depend on.
///
/// Rows that need the same result at the same time (the cases of one
/// experiment, run in parallel) compute it **once**: the first caller
/// computes, later callers wait for it, and while they wait they run other
/// work of the rayon pool they are on (`rayon::yield_now`), which includes
/// the parallel parts of the computation they wait for (a key point
/// selection evaluates its candidates in parallel). Before, each caller
/// computed the result itself: on two threads, two cases of BDT Fig. 7
/// selected the same key points twice side by side and the experiment took
/// as long as on one thread. If the computation fails, every waiter
/// computes for itself (and gets the error itself).
pub(crate) struct Memo<T>(std::sync::OnceLock<std::sync::Mutex<MemoMap<T>>>);

std::thread_local! {
    /// Seconds this thread spent in [`Memo`] waits since the last
    /// [`take_waited`] (see there).
    static WAITED: std::cell::Cell<f64> = const { std::cell::Cell::new(0.0) };
}

/// Starts counting this thread's memo waits afresh and returns the count
/// so far; call it again with the returned value when the measured piece
/// of work ends, and it returns the seconds waited in between. Used by the
/// experiment runner to report a row's `seconds_total` without the time it
/// spent waiting for another row's shared result (and the other pool work
/// it ran meanwhile, which may be whole other rows: they nest, so each
/// saves and restores the count).
pub(crate) fn take_waited(restore: f64) -> f64 {
    WAITED.with(|w| w.replace(restore))
}

/// One entry of a [`Memo`]: filled once by the caller that computes it,
/// with the seconds that computation took.
struct Slot<T> {
    value: std::sync::OnceLock<(Arc<T>, f64)>,
    failed: std::sync::atomic::AtomicBool,
}

/// What [`Memo::get_or_costed`] returns.
pub(crate) struct Fetched<T> {
    pub(crate) value: Arc<T>,
    /// Seconds spent waiting for another caller's computation.
    pub(crate) waited: f64,
    /// Seconds of the computation that produced `value`: this caller's,
    /// or, when `reused`, the earlier caller's that filled the memo.
    pub(crate) computed: f64,
    /// Whether `value` was computed by an earlier caller (a memo hit).
    pub(crate) reused: bool,
}

impl<T> Fetched<T> {
    fn own(v: T, computed: f64, waited: f64) -> Self {
        Fetched {
            value: Arc::new(v),
            waited,
            computed,
            reused: false,
        }
    }
}

/// The map behind a [`Memo`].
type MemoMap<T> = std::collections::HashMap<(u64, String), Arc<Slot<T>>>;

impl<T> Memo<T> {
    pub(crate) const fn new() -> Self {
        Memo(std::sync::OnceLock::new())
    }

    pub(crate) fn get_or(
        &self,
        key: (u64, String),
        f: impl FnOnce() -> Result<T>,
    ) -> Result<Arc<T>> {
        Ok(self.get_or_timed(key, f)?.0)
    }

    /// [`Memo::get_or`] and the seconds this call spent waiting for another
    /// caller's computation (running other work of the pool meanwhile), so
    /// that callers can report their own time without it.
    pub(crate) fn get_or_timed(
        &self,
        key: (u64, String),
        f: impl FnOnce() -> Result<T>,
    ) -> Result<(Arc<T>, f64)> {
        let got = self.get_or_costed(key, f)?;
        Ok((got.value, got.waited))
    }

    /// [`Memo::get_or_timed`] with what the result cost: the seconds of
    /// the computation that produced it (this caller's, or the one whose
    /// result it reuses) and whether it was reused.
    pub(crate) fn get_or_costed(
        &self,
        key: (u64, String),
        f: impl FnOnce() -> Result<T>,
    ) -> Result<Fetched<T>> {
        use std::sync::atomic::Ordering;
        let computed = |f: &mut dyn FnMut() -> Result<T>| -> Result<(T, f64)> {
            let t = std::time::Instant::now();
            let v = f()?;
            Ok((v, t.elapsed().as_secs_f64()))
        };
        let mut f = Some(f);
        let mut run = || (f.take().expect("computed once"))();
        let memo = self.0.get_or_init(Default::default);
        let (slot, mine) = {
            let Ok(mut m) = memo.lock() else {
                let (v, secs) = computed(&mut run)?;
                return Ok(Fetched::own(v, secs, 0.0));
            };
            match m.get(&key) {
                Some(s) => (s.clone(), false),
                None => {
                    let s = Arc::new(Slot {
                        value: std::sync::OnceLock::new(),
                        failed: std::sync::atomic::AtomicBool::new(false),
                    });
                    m.insert(key.clone(), s.clone());
                    (s, true)
                }
            }
        };
        if mine {
            // Waiters must not wait forever if `f` panics: the slot counts
            // as failed unless a result was stored.
            struct Unwind<'s, T>(&'s Slot<T>);
            impl<T> Drop for Unwind<'_, T> {
                fn drop(&mut self) {
                    if self.0.value.get().is_none() {
                        self.0
                            .failed
                            .store(true, std::sync::atomic::Ordering::Release);
                    }
                }
            }
            let _guard = Unwind(&slot);
            return match computed(&mut run) {
                Ok((v, secs)) => {
                    let (v, secs) = slot.value.get_or_init(|| (Arc::new(v), secs)).clone();
                    Ok(Fetched {
                        value: v,
                        waited: 0.0,
                        computed: secs,
                        reused: false,
                    })
                }
                Err(e) => {
                    // Forget the entry (a later call tries again) and let
                    // the waiters compute for themselves.
                    if let Ok(mut m) = memo.lock() {
                        m.remove(&key);
                    }
                    slot.failed.store(true, Ordering::Release);
                    Err(e)
                }
            };
        }
        let start = std::time::Instant::now();
        let waited = || {
            let w = start.elapsed().as_secs_f64();
            WAITED.with(|c| c.set(c.get() + w));
            w
        };
        loop {
            if let Some((v, secs)) = slot.value.get() {
                return Ok(Fetched {
                    value: v.clone(),
                    waited: waited(),
                    computed: *secs,
                    reused: true,
                });
            }
            if slot.failed.load(Ordering::Acquire) {
                let w = waited();
                let (v, secs) = computed(&mut run)?;
                return Ok(Fetched::own(v, secs, w));
            }
            match rayon::yield_now() {
                Some(rayon::Yield::Executed) => {}
                _ => std::thread::sleep(std::time::Duration::from_millis(1)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// Concurrent callers of one key compute it once and get the same value;
    /// a failed computation is not memoised (the next caller computes).
    #[test]
    fn concurrent_callers_compute_once() {
        static MEMO: Memo<usize> = Memo::new();
        let calls = AtomicUsize::new(0);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let got: Vec<(usize, f64)> = pool.install(|| {
            (0..6)
                .into_par_iter()
                .map(|_| {
                    let saved = take_waited(0.0);
                    let v = *MEMO
                        .get_or((1, "k".into()), || {
                            calls.fetch_add(1, Ordering::SeqCst);
                            std::thread::sleep(std::time::Duration::from_millis(300));
                            Ok(42)
                        })
                        .unwrap();
                    (v, take_waited(saved))
                })
                .collect()
        });
        assert!(got.iter().all(|&(v, _)| v == 42));
        assert_eq!(calls.load(Ordering::SeqCst), 1);
        // The computing caller did not wait; the one on the other thread
        // waited for most of the 300 ms and said so.
        assert!(got.iter().any(|&(_, w)| w == 0.0));
        assert!(got.iter().any(|&(_, w)| w > 0.05), "{got:?}");

        let failed = MEMO.get_or((2, "k".into()), || Err(crate::Error::invalid("no")));
        assert!(failed.is_err());
        assert_eq!(*MEMO.get_or((2, "k".into()), || Ok(7)).unwrap(), 7);
    }
}

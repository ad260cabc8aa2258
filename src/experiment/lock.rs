//! One writer per results folder: advisory locks (`flock`, through `fs4`)
//! on files inside the experiment folder.
//!
//! ```text
//! DIR/.lock                    the folder: exclusive for `run` without --shard and for
//!                              `merge` (its output), shared for `run --shard` and `plot`
//! DIR/.lock.shard-I-of-N       exclusive for `run --shard I/N`: one process per shard
//! DIR/.lock.tables             exclusive while one process rebuilds the tables, the
//!                              manifest and the plots from the store
//! ```
//!
//! So a second `run` of a config on a folder in use waits (after printing
//! whom it waits for: the holder writes its pid, host and command into the
//! lock file) or, with `--no-wait`, stops with an error naming the holder.
//! Shards of one config run side by side in one folder: each owns its cases
//! (`index % N == I`), result files are written without overwriting, and the
//! tables are rebuilt by one process at a time from everything stored, so
//! the last shard to finish leaves complete tables. (Shards of *different*
//! counts overlap in cases: they stay correct, a case both own may be
//! computed twice, the second result being dropped.)
//!
//! Stale temporaries (left by a killed process) are removed by a process
//! that holds `.lock` exclusively, when no other process can be writing:
//! `run` without `--shard` always, a shard when it starts alone in the
//! folder. Lock files are never removed (removing a lock file races with
//! its next user); they are empty but for the last holder's description.
//! The kernel releases a lock when its process dies, however it dies.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use fs4::{FileExt, TryLockError};

use super::manifest::Shard;
use super::store::remove_stale_temporaries;
use crate::{Error, Result};

/// How long a lock that is taken is retried quietly before the wait is
/// announced (or, with no waiting, refused): a shard holds the folder alone
/// for a moment while it removes stale temporaries.
const GRACE: Duration = Duration::from_millis(500);

/// A lock file taken in one mode; released when dropped (or when the
/// process ends).
#[derive(Debug)]
struct Held {
    _file: File,
}

/// The locks a process holds on one experiment folder (see the module
/// documentation); released when dropped.
#[derive(Debug)]
pub struct FolderLock {
    dir: PathBuf,
    _held: Vec<Held>,
    /// Whether `.lock` was held exclusively at some point (stale
    /// temporaries were removed then).
    pub was_alone: bool,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    Exclusive,
    Shared,
}

/// `pid P on HOST: WHAT (since UNIX)`.
fn description(what: &str) -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "this host".into());
    let since = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    format!(
        "pid {} on {host}: deformlab {what} (since unix time {since})",
        std::process::id()
    )
}

/// The description written by the current (or last) holder of a lock file.
fn holder(file: &mut File) -> String {
    let mut s = String::new();
    let _ = file.seek(SeekFrom::Start(0));
    let _ = file.read_to_string(&mut s);
    let s = s.trim();
    if s.is_empty() {
        "another process (pid unknown)".into()
    } else {
        s.to_string()
    }
}

/// Opens (creating) a lock file of a results folder: a regular file,
/// never through a symbolic link ([`super::files::open_regular`]).
fn open(path: &Path) -> Result<File> {
    super::files::open_regular(path, true)
}

fn try_lock(f: &File, mode: Mode) -> std::result::Result<(), TryLockError> {
    match mode {
        Mode::Exclusive => FileExt::try_lock(f),
        Mode::Shared => FileExt::try_lock_shared(f),
    }
}

/// Writes this process's description into a lock file it holds.
fn sign(f: &mut File, what: &str) {
    let d = description(what);
    let _ = f.seek(SeekFrom::Start(0));
    let _ = f.write_all(format!("{d}\n").as_bytes());
    let _ = f.set_len(d.len() as u64 + 1);
}

/// Takes `path` in `mode`: at once, or after a quiet grace period, or
/// after announcing whom it waits for (`wait`), else an error naming the
/// holder. `dir` names the folder in messages.
fn acquire(path: &Path, mode: Mode, wait: bool, dir: &Path, what: &str) -> Result<File> {
    let mut f = open(path)?;
    let start = Instant::now();
    loop {
        match try_lock(&f, mode) {
            Ok(()) => break,
            Err(TryLockError::Error(e)) => return Err(Error::io(path, e)),
            Err(TryLockError::WouldBlock) if start.elapsed() < GRACE => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(TryLockError::WouldBlock) => {
                let who = holder(&mut f);
                if !wait {
                    return Err(Error::io(
                        dir,
                        std::io::Error::new(
                            std::io::ErrorKind::WouldBlock,
                            format!(
                                "in use by {who} (lock {}); --no-wait given, so not waiting \
                                 for it",
                                path.display()
                            ),
                        ),
                    ));
                }
                eprintln!(
                    "{}: in use by {who}; waiting for it to finish …",
                    dir.display()
                );
                let locked = match mode {
                    Mode::Exclusive => FileExt::lock(&f),
                    Mode::Shared => FileExt::lock_shared(&f),
                };
                locked.map_err(|e| Error::io(path, e))?;
                eprintln!("{}: free, going on", dir.display());
                break;
            }
        }
    }
    sign(&mut f, what);
    Ok(f)
}

impl FolderLock {
    /// The locks of `run` on the experiment folder `dir`: without a shard,
    /// `.lock` exclusively (stale temporaries are removed); with one,
    /// `.lock` shared (exclusively for a moment if the folder is free, to
    /// remove stale temporaries) and the shard's own lock. `wait = false`:
    /// an error naming the holder instead of waiting.
    pub fn for_run(dir: &Path, shard: Option<Shard>, wait: bool) -> Result<FolderLock> {
        let main = dir.join(".lock");
        let Some(s) = shard else {
            let f = acquire(&main, Mode::Exclusive, wait, dir, "run")?;
            remove_stale_temporaries(dir)?;
            return Ok(FolderLock {
                dir: dir.to_path_buf(),
                _held: vec![Held { _file: f }],
                was_alone: true,
            });
        };
        let what = format!("run --shard {}/{}", s.index, s.count);
        let mut f = open(&main)?;
        let was_alone = match FileExt::try_lock(&f) {
            Ok(()) => {
                remove_stale_temporaries(dir)?;
                // Converting to shared lets other shards in. The kernel may
                // release the exclusive lock first and grant it to a waiting
                // process: then wait for that one like any shard would.
                match FileExt::try_lock_shared(&f) {
                    Ok(()) => sign(&mut f, &what),
                    Err(TryLockError::WouldBlock) => {
                        drop(f);
                        f = acquire(&main, Mode::Shared, wait, dir, &what)?;
                    }
                    Err(TryLockError::Error(e)) => return Err(Error::io(&main, e)),
                }
                true
            }
            Err(TryLockError::WouldBlock) => {
                drop(f);
                f = acquire(&main, Mode::Shared, wait, dir, &what)?;
                false
            }
            Err(TryLockError::Error(e)) => return Err(Error::io(&main, e)),
        };
        let own = acquire(
            &dir.join(format!(".lock.shard-{}-of-{}", s.index, s.count)),
            Mode::Exclusive,
            wait,
            dir,
            &what,
        )?;
        Ok(FolderLock {
            dir: dir.to_path_buf(),
            _held: vec![Held { _file: f }, Held { _file: own }],
            was_alone,
        })
    }

    /// `.lock` exclusively (`merge` into `dir`; stale temporaries are
    /// removed), waiting for other users with a message.
    pub fn exclusive(dir: &Path, what: &str) -> Result<FolderLock> {
        Self::exclusive_or_stop(dir, what, true)
    }

    /// [`FolderLock::exclusive`]; `wait = false`: an error naming the
    /// holder instead of waiting (`run --force --no-wait` with a shard).
    pub fn exclusive_or_stop(dir: &Path, what: &str, wait: bool) -> Result<FolderLock> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let f = acquire(&dir.join(".lock"), Mode::Exclusive, wait, dir, what)?;
        remove_stale_temporaries(dir)?;
        Ok(FolderLock {
            dir: dir.to_path_buf(),
            _held: vec![Held { _file: f }],
            was_alone: true,
        })
    }

    /// `.lock` shared (`plot`: beside shards, not beside a whole run),
    /// waiting with a message.
    pub fn shared(dir: &Path, what: &str) -> Result<FolderLock> {
        let f = acquire(&dir.join(".lock"), Mode::Shared, true, dir, what)?;
        Ok(FolderLock {
            dir: dir.to_path_buf(),
            _held: vec![Held { _file: f }],
            was_alone: false,
        })
    }

    /// `.lock.tables` exclusively, for rebuilding the tables, the manifest
    /// and the plots from the store (waits quietly: others hold it
    /// briefly). Released when the returned guard is dropped.
    pub fn tables(&self) -> Result<impl Sized> {
        let path = self.dir.join(".lock.tables");
        let f = open(&path)?;
        FileExt::lock(&f).map_err(|e| Error::io(&path, e))?;
        Ok(Held { _file: f })
    }
}

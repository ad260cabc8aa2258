//! Temporary files of atomic writes, for every writer of the crate (meshes,
//! result files, tables, figures).
//!
//! A temporary lives next to its final file and is named
//! `.NAME.PID-TOKEN.N.tmp` (`.NAME.PID-TOKEN.N.tmp.EXT` where an encoder
//! picks the format from the extension): dot-prefixed, so listings of
//! results skip it; named by the process (its id and a random token drawn
//! once per process, so two hosts sharing a folder cannot pick the same
//! name) and a per-process counter. It is created with `create_new` (never
//! another process's file) and only its owner removes it: on success by the
//! rename, on failure right away. A process killed between the two leaves
//! it behind; [`is_temporary`] recognises it, so a later writer that knows
//! no other process writes in the folder (the results folder's exclusive
//! lock) can remove it.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use crate::{Error, Result};

/// `PID-TOKEN` of this process.
fn owner() -> &'static str {
    static OWNER: OnceLock<String> = OnceLock::new();
    OWNER.get_or_init(|| format!("{}-{:08x}", std::process::id(), rand::random::<u32>()))
}

/// A fresh temporary path next to `path` (see the module documentation);
/// `ext`: an extension to end with.
pub fn temp_path(path: &Path, ext: Option<&str>) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut tmp = format!(".{name}.{}.{n}.tmp", owner());
    if let Some(e) = ext {
        tmp.push('.');
        tmp.push_str(e);
    }
    path.with_file_name(tmp)
}

/// Whether a file name is a temporary of an atomic write, of any process:
/// `.….tmp` or `.….tmp.EXT`, and the `….tmp` that older versions left
/// without the leading dot (a mesh written by `write_ply` beside its final
/// name).
pub fn is_temporary(name: &str) -> bool {
    if name.ends_with(".tmp") {
        return true;
    }
    name.starts_with('.')
        && name.rsplit_once(".tmp.").is_some_and(|(_, ext)| {
            !ext.is_empty() && ext.chars().all(|c| c.is_ascii_alphanumeric())
        })
}

/// Whether a temporary was made by this process.
pub fn is_own_temporary(name: &str) -> bool {
    is_temporary(name) && name.contains(&format!(".{}.", owner()))
}

/// Creates a fresh temporary next to `path` and writes `bytes` to it
/// (`sync`: and flushes it to the disk). On failure (a full disk) the
/// temporary is removed and the error names `path`.
pub fn write_temp(path: &Path, bytes: &[u8], sync: bool) -> Result<PathBuf> {
    let tmp = temp_path(path, None);
    let written = (|| {
        let mut f = std::fs::File::create_new(&tmp)?;
        f.write_all(bytes)?;
        if sync {
            f.sync_all()?;
        }
        Ok(())
    })();
    match written {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(Error::io(path, e))
        }
    }
}

/// Moves a temporary onto `path` (replacing it), removing the temporary if
/// that fails.
pub fn commit(tmp: &Path, path: &Path) -> Result<()> {
    std::fs::rename(tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(tmp);
        Error::io(path, e)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_dot_prefixed_per_process_and_recognised() {
        let p = Path::new("dir/result_6.ply");
        let a = temp_path(p, None);
        let b = temp_path(p, Some("png"));
        let (na, nb) = (
            a.file_name().unwrap().to_str().unwrap(),
            b.file_name().unwrap().to_str().unwrap(),
        );
        assert!(
            na.starts_with(".result_6.ply.") && na.ends_with(".tmp"),
            "{na}"
        );
        assert!(nb.ends_with(".tmp.png"), "{nb}");
        assert_eq!(a.parent(), p.parent());
        assert_ne!(temp_path(p, None), a);
        for n in [na, nb] {
            assert!(is_temporary(n) && is_own_temporary(n), "{n}");
        }
        // Another process's, an older version's, and not temporaries.
        assert!(is_temporary(".x.json.12.0.tmp") && !is_own_temporary(".x.json.12.0.tmp"));
        assert!(is_temporary("result_6.ply.tmp"));
        assert!(is_temporary(".fig.png.1-ab.3.tmp.png"));
        for n in ["x.json", ".lock", "fig.tmp.png", ".a.tmp.b.c"] {
            assert!(!is_temporary(n), "{n}");
        }
    }

    #[test]
    fn a_failed_write_leaves_no_temporary() {
        let d = tempfile::tempdir().unwrap();
        // The final path is a folder: the rename fails.
        let p = d.path().join("sub");
        std::fs::create_dir(&p).unwrap();
        std::fs::write(p.join("x"), b"x").unwrap();
        let tmp = write_temp(&p, b"bytes", false).unwrap();
        assert!(commit(&tmp, &p).is_err());
        let left: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
        assert_eq!(left.len(), 1);
    }
}

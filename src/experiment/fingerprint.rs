//! Content fingerprints of the input meshes of an experiment: part of the
//! result store's key ([`super::store`]), so that changed data is noticed
//! and moved or respelled data is not.
//!
//! Each file of the dataset (every pose of every subject it serves) is
//! fingerprinted by its size and the XXH3-128 hash of its bytes, under its
//! identity in the dataset (`subject/pose`), not its path. The files' hashes
//! are cached in the results folder (`.fingerprints.json`, by canonical path,
//! size and modification time to the nanosecond), so a folder that resumes
//! reads no mesh twice to check its data.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::UNIX_EPOCH;

use serde::{Deserialize, Serialize};
use twox_hash::XxHash3_128;

use crate::data::DataRoot;
use crate::mesh::io::temp;
use crate::{Error, Result};

/// The cache file in a results folder.
pub const CACHE_FILE: &str = ".fingerprints.json";

/// One input file.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FilePrint {
    /// Its identity in the dataset: `subject/pose`.
    pub id: String,
    /// Where it was read (`@data/...` when under the data root).
    pub file: String,
    pub size: u64,
    /// XXH3-128 of the bytes, 32 hex digits.
    pub xxh3: String,
}

/// The fingerprint of every input file of a dataset.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DataPrint {
    /// XXH3-128 of the `id size xxh3` lines, in order: what the store key
    /// includes.
    pub hash: String,
    pub files: Vec<FilePrint>,
}

/// How the data of a stored result and of a run differ.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DataChanges {
    /// Same identity, other content: (then, now).
    pub changed: Vec<(FilePrint, FilePrint)>,
    pub added: Vec<FilePrint>,
    pub removed: Vec<FilePrint>,
}

impl DataChanges {
    pub fn is_empty(&self) -> bool {
        self.changed.is_empty() && self.added.is_empty() && self.removed.is_empty()
    }
}

impl std::fmt::Display for DataChanges {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        const SHOWN: usize = 10;
        let list = |v: Vec<String>| {
            let n = v.len();
            let mut s = v.into_iter().take(SHOWN).collect::<Vec<_>>().join(", ");
            if n > SHOWN {
                s.push_str(&format!(" and {} more", n - SHOWN));
            }
            s
        };
        let mut parts = Vec::new();
        if !self.changed.is_empty() {
            parts.push(format!(
                "{} file(s) changed: {}",
                self.changed.len(),
                list(
                    self.changed
                        .iter()
                        .map(|(then, now)| {
                            let size = if then.size == now.size {
                                "same size, other bytes".to_string()
                            } else {
                                format!("{} → {} bytes", then.size, now.size)
                            };
                            format!("{} ({}; {size})", now.file, now.id)
                        })
                        .collect()
                )
            ));
        }
        if !self.added.is_empty() {
            parts.push(format!(
                "{} file(s) added: {}",
                self.added.len(),
                list(
                    self.added
                        .iter()
                        .map(|p| format!("{} ({})", p.file, p.id))
                        .collect()
                )
            ));
        }
        if !self.removed.is_empty() {
            parts.push(format!(
                "{} file(s) gone: {}",
                self.removed.len(),
                list(
                    self.removed
                        .iter()
                        .map(|p| format!("{} ({})", p.file, p.id))
                        .collect()
                )
            ));
        }
        f.write_str(&parts.join("; "))
    }
}

impl DataPrint {
    /// What changed from `then` to `self`, file by file (by identity).
    pub fn changes_since(&self, then: &DataPrint) -> DataChanges {
        let old: BTreeMap<&str, &FilePrint> =
            then.files.iter().map(|p| (p.id.as_str(), p)).collect();
        let new: BTreeMap<&str, &FilePrint> =
            self.files.iter().map(|p| (p.id.as_str(), p)).collect();
        let mut c = DataChanges::default();
        for p in &self.files {
            match old.get(p.id.as_str()) {
                Some(o) if o.size == p.size && o.xxh3 == p.xxh3 => {}
                Some(o) => c.changed.push(((*o).clone(), p.clone())),
                None => c.added.push(p.clone()),
            }
        }
        for p in &then.files {
            if !new.contains_key(p.id.as_str()) {
                c.removed.push(p.clone());
            }
        }
        c
    }
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
struct CacheEntry {
    size: u64,
    mtime_s: u64,
    mtime_ns: u32,
    xxh3: String,
}

/// Hashes of files already read, by canonical path, size and modification
/// time (see the module documentation).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Cache {
    files: BTreeMap<String, CacheEntry>,
    #[serde(skip)]
    dirty: bool,
}

impl Cache {
    /// The cache of a results folder (empty if absent or unreadable: it
    /// only saves time).
    pub fn load(dir: &Path) -> Cache {
        super::files::read_regular(&dir.join(CACHE_FILE))
            .ok()
            .and_then(|s| serde_json::from_str(&s).ok())
            .unwrap_or_default()
    }

    /// Writes the cache into `dir` (atomically) if it learnt anything.
    pub fn save(&self, dir: &Path) -> Result<()> {
        if !self.dirty {
            return Ok(());
        }
        let path = dir.join(CACHE_FILE);
        let bytes = serde_json::to_vec_pretty(self)
            .map_err(|e| Error::invalid(format!("fingerprint cache to JSON: {e}")))?;
        let tmp = temp::write_temp(&path, &bytes, false)?;
        temp::commit(&tmp, &path)
    }

    /// The XXH3-128 of `path` (hex), from the cache when its size and
    /// modification time are the ones cached.
    fn hash(&mut self, path: &Path) -> Result<(u64, String)> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        let size = meta.len();
        let (mtime_s, mtime_ns) = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
            .map(|d| (d.as_secs(), d.subsec_nanos()))
            .unwrap_or((0, 0));
        let key = std::fs::canonicalize(path)
            .unwrap_or_else(|_| path.to_path_buf())
            .display()
            .to_string();
        if let Some(e) = self.files.get(&key) {
            if e.size == size && e.mtime_s == mtime_s && e.mtime_ns == mtime_ns && mtime_s > 0 {
                return Ok((size, e.xxh3.clone()));
            }
        }
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let xxh3 = format!("{:032x}", XxHash3_128::oneshot(&bytes));
        self.files.insert(
            key,
            CacheEntry {
                size: bytes.len() as u64,
                mtime_s,
                mtime_ns,
                xxh3: xxh3.clone(),
            },
        );
        self.dirty = true;
        Ok((bytes.len() as u64, xxh3))
    }
}

/// The fingerprint of `files` (`(id, path)`, in the dataset's order);
/// `None` for a dataset without files (the synthetic set, generated from
/// the config).
pub fn fingerprint(
    files: &[(String, PathBuf)],
    root: &DataRoot,
    cache: &mut Cache,
) -> Result<Option<DataPrint>> {
    if files.is_empty() {
        return Ok(None);
    }
    let mut prints = Vec::with_capacity(files.len());
    let mut all = String::new();
    for (id, path) in files {
        let (size, xxh3) = cache.hash(path)?;
        all.push_str(&format!("{id} {size} {xxh3}\n"));
        prints.push(FilePrint {
            id: id.clone(),
            file: root
                .spell(path)
                .unwrap_or_else(|| path.display().to_string()),
            size,
            xxh3,
        });
    }
    Ok(Some(DataPrint {
        hash: format!("{:032x}", XxHash3_128::oneshot(all.as_bytes())),
        files: prints,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_changed_byte_is_named_a_moved_file_is_not() {
        let d = tempfile::tempdir().unwrap();
        let a = d.path().join("a.ply");
        let b = d.path().join("b.ply");
        std::fs::write(&a, b"ply one").unwrap();
        std::fs::write(&b, b"ply two").unwrap();
        let root = DataRoot::at(d.path());
        let mut cache = Cache::default();
        let files = vec![
            ("0/0".to_string(), a.clone()),
            ("0/1".to_string(), b.clone()),
        ];
        let p1 = fingerprint(&files, &root, &mut cache).unwrap().unwrap();
        assert_eq!(p1.files[0].file, "@data/a.ply");
        cache.save(d.path()).unwrap();
        let mut cache = Cache::load(d.path());
        assert_eq!(cache.files.len(), 2);
        // Moved: same content elsewhere, same hash.
        let e = tempfile::tempdir().unwrap();
        std::fs::copy(&a, e.path().join("x.ply")).unwrap();
        std::fs::copy(&b, e.path().join("y.ply")).unwrap();
        let moved = vec![
            ("0/0".to_string(), e.path().join("x.ply")),
            ("0/1".to_string(), e.path().join("y.ply")),
        ];
        let p2 = fingerprint(&moved, &root, &mut cache).unwrap().unwrap();
        assert_eq!(p1.hash, p2.hash);
        assert!(p2.changes_since(&p1).is_empty());
        // One byte changed: that file is named.
        std::fs::write(e.path().join("y.ply"), b"ply twO").unwrap();
        let p3 = fingerprint(&moved, &root, &mut cache).unwrap().unwrap();
        assert_ne!(p1.hash, p3.hash);
        let c = p3.changes_since(&p1);
        assert_eq!(c.changed.len(), 1);
        let msg = c.to_string();
        assert!(
            msg.contains("y.ply") && msg.contains("0/1") && msg.contains("same size"),
            "{msg}"
        );
        assert!(fingerprint(&[], &root, &mut cache).unwrap().is_none());
    }
}

//! Dataset layouts, synthetic data and correspondence files.

pub mod correspondence;
pub mod folders;
pub(crate) mod memo;
pub mod partial;
pub mod root;
pub mod synthetic;

pub use correspondence::{
    read_cons, read_markers_yml, read_pairs, read_pairs_csv, MarkerFile, PairFormat, VertexPair,
};
pub use folders::{FaustEntry, FaustFolder, Manifest, ToscaEntry, ToscaFolder};
pub use root::DataRoot;
pub use synthetic::{write_faust_style, write_tosca_style, FaustStyle, SyntheticSet};

use std::path::PathBuf;

/// The development data folder: the data root of [`root`]
/// (`DEFORMLAB_DATA`, else the former `DEFORMLAB_SHARED_DATA`, else
/// `../shared/data` from the working directory, the repository root under
/// `cargo test`), if it exists. Tests that need real meshes call this and
/// skip, saying why, when it returns `None`.
pub fn shared_data_dir() -> Option<PathBuf> {
    let dir = DataRoot::from_env(None).dir;
    dir.is_dir().then_some(dir)
}

/// Like [`shared_data_dir`] joined with `sub`, printing why a test is skipped
/// when the folder is absent.
pub fn shared_data_or_skip(sub: &str, test: &str) -> Option<PathBuf> {
    let root = DataRoot::from_env(None);
    match shared_data_dir().map(|d| d.join(sub)) {
        Some(p) if p.exists() => Some(p),
        _ => {
            eprintln!(
                "SKIP {test}: {} not found (set {} to the data folder to run it)",
                root.dir.join(sub).display(),
                root::DATA_ROOT_ENV
            );
            None
        }
    }
}

/// FNV-1a 64-bit hash of `bytes` (stable across platforms and versions: the
/// config hash of a results folder and the per-case seeds use it).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf29ce484222325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x100000001b3);
    }
    h
}

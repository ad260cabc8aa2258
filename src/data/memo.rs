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
pub(crate) struct Memo<T>(std::sync::OnceLock<std::sync::Mutex<MemoMap<T>>>);

/// The map behind a [`Memo`].
type MemoMap<T> = std::collections::HashMap<(u64, String), Arc<T>>;

impl<T> Memo<T> {
    pub(crate) const fn new() -> Self {
        Memo(std::sync::OnceLock::new())
    }

    pub(crate) fn get_or(
        &self,
        key: (u64, String),
        f: impl FnOnce() -> Result<T>,
    ) -> Result<Arc<T>> {
        let memo = self.0.get_or_init(Default::default);
        if let Some(s) = memo.lock().ok().and_then(|m| m.get(&key).cloned()) {
            return Ok(s);
        }
        let v = Arc::new(f()?);
        if let Ok(mut m) = memo.lock() {
            m.insert(key, v.clone());
        }
        Ok(v)
    }
}

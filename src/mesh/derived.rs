//! Values derived from one mesh (its Laplacian, mass, adjacency, ...),
//! computed once per mesh and shared by its clones.
//!
//! A [`Mesh`](super::Mesh) is immutable, so whatever is computed from it
//! stays valid for as long as it lives. It carries two [`Derived`] stores:
//! one for values of its geometry (dropped by
//! [`with_vertices`](super::Mesh::with_vertices)) and one for values of its
//! connectivity alone (kept by `with_vertices`, which keeps the faces). The
//! operators themselves live in [`crate::ops`] ([`crate::ops::Operators`]);
//! this module only stores them, keyed by a type the operator chooses.

use std::any::{Any, TypeId};
use std::sync::{Arc, Mutex, OnceLock};

type Slot = Arc<OnceLock<Arc<dyn Any + Send + Sync>>>;

/// A key of a derived value: a type naming it, and the value's type.
pub trait Key: 'static {
    type Value: Send + Sync + 'static;
}

/// A store of values computed from a mesh, one per key type.
#[derive(Default)]
pub struct Derived {
    slots: Mutex<Vec<(TypeId, Slot)>>,
}

impl Derived {
    /// The value of key `K`, computed by `compute` on the first call (a
    /// caller that arrives while another computes it waits for that value).
    /// `compute` may ask for other keys, never for `K` itself.
    pub fn get<K: Key>(&self, compute: impl FnOnce() -> K::Value) -> Arc<K::Value> {
        let slot = {
            // A poisoned lock only means another thread panicked while
            // holding it: the list itself is always whole.
            let mut slots = self.slots.lock().unwrap_or_else(|e| e.into_inner());
            let key = TypeId::of::<K>();
            match slots.iter().find(|(k, _)| *k == key) {
                Some((_, s)) => s.clone(),
                None => {
                    let s = Slot::default();
                    slots.push((key, s.clone()));
                    s
                }
            }
        };
        let value = slot
            .get_or_init(|| Arc::new(compute()) as Arc<dyn Any + Send + Sync>)
            .clone();
        // The slot of `K` only ever holds a `K::Value` (stored just above).
        value
            .downcast::<K::Value>()
            .expect("the slot of a key holds that key's value type")
    }
}

impl std::fmt::Debug for Derived {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.slots.lock().map(|s| s.len()).unwrap_or(0);
        write!(f, "Derived({n} values)")
    }
}

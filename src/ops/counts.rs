//! How many times each per-mesh operator was computed in this process
//! (the measure of [`super::Operators`]' "once per mesh").

use std::sync::atomic::{AtomicUsize, Ordering};

/// How many times each operator was computed in this process.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Computations {
    pub laplacian: usize,
    pub mass: usize,
    pub edge_weights: usize,
    pub neighbours: usize,
    pub incident_faces: usize,
}

static COUNTS: [AtomicUsize; 5] = [
    AtomicUsize::new(0),
    AtomicUsize::new(0),
    AtomicUsize::new(0),
    AtomicUsize::new(0),
    AtomicUsize::new(0),
];

pub(crate) enum Counted {
    Laplacian = 0,
    Mass,
    EdgeWeights,
    Neighbours,
    IncidentFaces,
}

/// Counts one computation of `op` (called by the computing functions).
pub(crate) fn count(op: Counted) {
    COUNTS[op as usize].fetch_add(1, Ordering::Relaxed);
}

/// How many times each operator was computed in this process so far (by
/// [`Operators`] or the free functions): the measure of "once per mesh".
pub fn computations() -> Computations {
    let c = |i: usize| COUNTS[i].load(Ordering::Relaxed);
    Computations {
        laplacian: c(0),
        mass: c(1),
        edge_weights: c(2),
        neighbours: c(3),
        incident_faces: c(4),
    }
}

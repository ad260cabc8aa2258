//! Sparse linear algebra: the one sparse matrix type of the crate, sparse
//! symmetric factorisation, generalised eigenpairs.
//!
//! This layer knows nothing about meshes: it is the bottom of the stack, so
//! that mesh operators (`ops`, e.g. heat geodesics) can factorise matrices.
//! Matrices are assembled as [`SparseMatrix`] (nalgebra-sparse CSC) everywhere;
//! conversion to faer's own types happens only inside this module.

pub mod cholesky;
pub mod dense;
pub mod eigen;
pub mod elastic_net;
pub mod kmeans;
pub mod kmedoids;
pub mod progress;
pub mod qp;
pub use cholesky::{Inertia, SparseCholesky, SparseLdlt, SymbolicCholesky};
pub use eigen::{
    canonicalize_signs, generalized_eigen, mass_diagonal, EigenOptions, Eigenpairs, DENSE_MAX,
};

use std::sync::atomic::{AtomicUsize, Ordering};

/// Threads used by the sparse factorisations and solves of this module.
static THREADS: AtomicUsize = AtomicUsize::new(1);

/// Sets the number of threads used by factorisations, solves and eigen
/// solves in `solve` (process-wide). `1` (the default) is sequential; `k ≥ 2`
/// uses up to `k` threads of the global rayon pool; `0` means all threads of
/// that pool. Sequential is the default because on small machines faer's
/// parallel sparse solves were measured 4–10× slower. Results do not depend on
/// this setting beyond rounding.
pub fn set_threads(k: usize) {
    THREADS.store(k, Ordering::Relaxed);
}

/// Most worker threads a command starts (`run --threads`, `bench
/// --threads`): 4 × the available cores, at most [`THREAD_LIMIT`]. More
/// threads than that only cost memory and switching (results never
/// depend on the thread count).
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (4 * cores).clamp(1, THREAD_LIMIT)
}

/// The default worker count of `run`: the cores the process may use
/// (`std::thread::available_parallelism`, 1 when unknown), at most
/// [`THREAD_LIMIT`].
pub fn default_threads() -> usize {
    std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, THREAD_LIMIT)
}

/// Upper bound of [`max_threads`] whatever the machine.
pub const THREAD_LIMIT: usize = 256;

/// `k` capped to `1..=max_threads()`.
pub fn cap_threads(k: usize) -> usize {
    k.clamp(1, max_threads())
}

/// The current thread setting (see [`set_threads`]).
pub fn threads() -> usize {
    THREADS.load(Ordering::Relaxed)
}

/// faer's parallelism for the current thread setting.
pub(crate) fn parallelism() -> faer::Par {
    match threads() {
        1 => faer::Par::Seq,
        k => faer::Par::rayon(k),
    }
}

/// The crate's one sparse matrix type (compressed sparse column, f64).
pub type SparseMatrix = nalgebra_sparse::CscMatrix<f64>;

/// Builds a [`SparseMatrix`] from (row, column, value) triplets; duplicate
/// entries are summed.
pub fn sparse_from_triplets(
    nrows: usize,
    ncols: usize,
    triplets: impl IntoIterator<Item = (usize, usize, f64)>,
) -> SparseMatrix {
    let mut coo = nalgebra_sparse::CooMatrix::new(nrows, ncols);
    for (i, j, v) in triplets {
        coo.push(i, j, v);
    }
    SparseMatrix::from(&coo)
}

/// Diagonal sparse matrix.
pub fn sparse_diagonal(diag: &[f64]) -> SparseMatrix {
    sparse_from_triplets(
        diag.len(),
        diag.len(),
        diag.iter().enumerate().map(|(i, &v)| (i, i, v)),
    )
}

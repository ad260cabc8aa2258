//! Sparse linear algebra: the one sparse matrix type of the crate, sparse
//! symmetric factorisation, generalised eigenpairs.
//!
//! This layer knows nothing about meshes: it is the bottom of the stack, so
//! that mesh operators (`ops`, e.g. heat geodesics) can factorise matrices.
//! Matrices are assembled as [`SparseMatrix`] (nalgebra-sparse CSC) everywhere;
//! conversion to faer's own types happens only inside this module.

pub mod address;
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

/// Keeps freed memory in the process for reuse instead of returning it to
/// the kernel (process-wide; called first thing by the command line and the
/// Python binding). Returns whether the settings were applied (only on
/// glibc).
///
/// The solvers here allocate and free buffers of tens of megabytes at every
/// active-set iteration (factor values, scratch, reduced systems). glibc
/// serves blocks above its mmap threshold (at most 32 MB when it adapts)
/// with fresh `mmap`s and unmaps them on free, so each iteration paid for
/// page faults on zeroed pages again. Measured on FAUST `tr_reg_001`,
/// coupled weights with 6 handles (`deformlab weights --handles 6`, 75
/// support iterations, load 2.7, two runs each): 9.97 / 9.65 s wall of which
/// 2.39 / 2.36 s system time by default; 8.11 / 7.19 s wall and 0.14 /
/// 0.12 s system time with both thresholds at 1 GiB (same weights, bitwise:
/// only where memory comes from changes). Worker threads get one arena
/// shared with the main thread: per-thread arenas live in 64 MB heaps that
/// glibc maps and trims on their own, so blocks of the per-handle solves,
/// which run on rayon's workers, were still faulted in afresh (per-handle
/// weights, 4 handles, 27k vertices, 2 threads: 2.56 s system time of
/// 11.2 s wall; 0.16 s of 10.3 s with one arena). The hot loops do not
/// allocate, so the shared arena's lock is not contended. The cost is that
/// the resident size stays at its peak until the process ends.
pub fn keep_freed_memory() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        const LARGE: libc::c_int = 1 << 30;
        // SAFETY: mallopt only changes glibc's allocator parameters; both
        // are documented, and their values are in range.
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, LARGE) == 1
                && libc::mallopt(libc::M_TRIM_THRESHOLD, LARGE) == 1
                && libc::mallopt(libc::M_ARENA_MAX, 1) == 1
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        false
    }
}

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

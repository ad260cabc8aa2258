//! Sparse linear algebra: the one sparse matrix type of the crate, sparse
//! symmetric factorisation, generalised eigenpairs.
//!
//! This layer knows nothing about meshes: it is the bottom of the stack, so
//! that mesh operators (`ops`, e.g. heat geodesics) can factorise matrices.
//! Matrices are assembled as [`SparseMatrix`] (nalgebra-sparse CSC) everywhere;
//! conversion to faer's own types happens only inside this module.

pub mod cholesky;
pub use cholesky::SparseCholesky;

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

//! Sparse symmetric positive-definite factorisation (interface; the faer
//! implementation is being written).

use nalgebra::DMatrix;

use super::SparseMatrix;
use crate::{Error, Result};

/// Sparse Cholesky (LLᵀ) factorisation with a fill-reducing ordering, built
/// once and used for many solves.
pub struct SparseCholesky {
    n: usize,
}

impl SparseCholesky {
    /// Factorises a symmetric positive-definite matrix (both triangles
    /// stored). Errors if the matrix is not square or not positive definite.
    pub fn new(a: &SparseMatrix) -> Result<Self> {
        Err(Error::numerical(format!(
            "sparse Cholesky of {}x{} not implemented yet",
            a.nrows(),
            a.ncols()
        )))
    }

    /// Solves `A X = B` for every column of `B`.
    pub fn solve(&self, b: &DMatrix<f64>) -> DMatrix<f64> {
        assert_eq!(b.nrows(), self.n);
        b.clone()
    }

    /// Solves `A x = b` for one right-hand side.
    pub fn solve_vec(&self, b: &[f64]) -> Vec<f64> {
        b.to_vec()
    }
}

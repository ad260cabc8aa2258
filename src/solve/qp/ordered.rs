//! Sparse Cholesky of principal submatrices in a fixed elimination order.
//!
//! Active-set methods factorise a different principal submatrix `A_FF` at
//! every iteration. Computing a fresh fill-reducing ordering (AMD) each time
//! costs about as much as the numeric factorisation itself, and keeping the
//! full-size pattern with identity rows for the fixed variables wastes the
//! work of the eliminated part. Instead, [`Ordered`] computes one AMD ordering
//! of the whole matrix and stores `A`'s upper triangle permuted into it; the
//! submatrix of any subset `F` is then extracted in the *induced* order (a
//! filter over the stored columns, rows stay sorted, no sorting), and only the
//! cheap symbolic steps (elimination tree, column counts, supernodes) and the
//! numeric factorisation are redone. The induced ordering of a subset is not
//! an optimal ordering of `A_FF`, but it is close for the region-like subsets
//! of active-set methods (measured on FAUST `tr_reg_001`, 6880 free vertices:
//! a 50 % subset factorises in about a third of the full time).
//!
//! The factorisation is always supernodal (faer's automatic choice picked the
//! simplicial variant for the biharmonic form, measured twice as slow) and
//! sequential: callers parallelise over independent problems instead, which
//! keeps results independent of the thread count.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError;
use faer::sparse::linalg::cholesky as fch;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use crate::solve::SparseMatrix;
use crate::{Error, Result};

/// Upper triangle (diagonal included) of a symmetric matrix in compressed
/// sparse column form, row indices sorted within each column.
#[derive(Clone, Debug, Default)]
pub(crate) struct UpperCsc {
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub values: Vec<f64>,
}

impl UpperCsc {
    /// Empty matrix of dimension `n` to be filled column by column with
    /// [`UpperCsc::push`] and [`UpperCsc::end_column`].
    pub fn with_capacity(n: usize, nnz: usize) -> Self {
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        UpperCsc {
            n,
            col_ptr,
            row_idx: Vec::with_capacity(nnz),
            values: Vec::with_capacity(nnz),
        }
    }

    #[inline]
    pub fn push(&mut self, row: usize, value: f64) {
        self.row_idx.push(row);
        self.values.push(value);
    }

    #[inline]
    pub fn end_column(&mut self) {
        self.col_ptr.push(self.row_idx.len());
    }
}

/// Sparse LLᵀ of a matrix given in its elimination order (no permutation).
pub(crate) struct OrderedCholesky {
    symbolic: fch::SymbolicCholesky<usize>,
    values: Vec<f64>,
}

impl OrderedCholesky {
    /// Factorises the symmetric positive-definite matrix whose upper
    /// triangle is `m` (already in elimination order). Errors with the
    /// failing pivot if it is not (numerically) positive definite.
    pub fn factorize(m: &UpperCsc) -> Result<Self> {
        let n = m.n;
        if n == 0 || m.col_ptr.len() != n + 1 {
            return Err(Error::invalid(format!(
                "ordered Cholesky: malformed {n}×{n} matrix"
            )));
        }
        let sym_view = SymbolicSparseColMatRef::new_checked(n, n, &m.col_ptr, None, &m.row_idx);
        let symbolic = fch::factorize_symbolic_cholesky(
            sym_view,
            Side::Upper,
            fch::SymmetricOrdering::Identity,
            fch::CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
        )
        .map_err(|e| Error::numerical(format!("symbolic Cholesky failed: {e:?}")))?;
        let mut values = vec![0.0; symbolic.len_val()];
        let par = Par::Seq;
        let mut buf =
            MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
        let view = SparseColMatRef::new(sym_view, &m.values);
        symbolic
            .factorize_numeric_llt(
                &mut values,
                view,
                Side::Upper,
                Default::default(),
                par,
                MemStack::new(&mut buf),
                Default::default(),
            )
            .map_err(|e| match e {
                LltError::NonPositivePivot { index } => Error::numerical(format!(
                    "matrix of an active-set step is not positive definite (pivot {index} of \
                     {n}); the quadratic form must be positive definite on the free variables"
                )),
            })?;
        Ok(OrderedCholesky { symbolic, values })
    }

    /// Solves `A X = B` in place; `x` is column-major `n × ncols`.
    pub fn solve_in_place(&self, x: &mut [f64], ncols: usize) {
        let n = self.symbolic.nrows();
        debug_assert_eq!(x.len(), n * ncols);
        if ncols == 0 {
            return;
        }
        let par = Par::Seq;
        let mut buf = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(ncols, par));
        fch::LltRef::<usize, f64>::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, n, ncols),
            par,
            MemStack::new(&mut buf),
        );
    }
}

/// A symmetric matrix stored in one fixed fill-reducing order, from which
/// principal submatrices are factorised in the induced order.
#[derive(Clone, Debug)]
pub(crate) struct Ordered {
    /// `order[p]` = the variable eliminated at position `p`.
    pub order: Vec<usize>,
    /// Inverse of `order`.
    pub pos: Vec<usize>,
    /// Upper triangle of `P A Pᵀ`.
    pub upper: UpperCsc,
}

impl Ordered {
    /// AMD ordering of `a` (square, both triangles stored) and its permuted
    /// upper triangle.
    pub fn new(a: &SparseMatrix) -> Result<Self> {
        let n = a.nrows();
        if n == 0 || a.ncols() != n {
            return Err(Error::invalid(format!(
                "ordering needs a non-empty square matrix, got {}×{}",
                a.nrows(),
                a.ncols()
            )));
        }
        let sym_view =
            SymbolicSparseColMatRef::new_checked(n, n, a.col_offsets(), None, a.row_indices());
        let symbolic = fch::factorize_symbolic_cholesky(
            sym_view,
            Side::Lower,
            fch::SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| Error::numerical(format!("AMD ordering failed: {e:?}")))?;
        let order: Vec<usize> = match symbolic.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..n).collect(),
        };
        let mut pos = vec![0; n];
        for (p, &i) in order.iter().enumerate() {
            pos[i] = p;
        }
        // Permuted upper triangle: column p holds rows q ≤ p, sorted.
        let (off, rows, vals) = (a.col_offsets(), a.row_indices(), a.values());
        let mut upper = UpperCsc::with_capacity(n, vals.len() / 2 + n);
        let mut col: Vec<(usize, f64)> = Vec::new();
        for &j in &order {
            col.clear();
            let pj = pos[j];
            for p in off[j]..off[j + 1] {
                let q = pos[rows[p]];
                if q <= pj {
                    col.push((q, vals[p]));
                }
            }
            col.sort_unstable_by_key(|e| e.0);
            for &(q, v) in &col {
                upper.push(q, v);
            }
            upper.end_column();
        }
        Ok(Ordered { order, pos, upper })
    }

    /// Number of variables.
    pub fn n(&self) -> usize {
        self.order.len()
    }

    /// Factorises the principal submatrix of the variables with
    /// `keep[variable]` in the induced order; returns the kept variables in
    /// elimination order (the row order of the factor) and the factor, or
    /// `None` when no variable is kept.
    pub fn factorize_subset(&self, keep: &[bool]) -> Result<Option<(Vec<usize>, OrderedCholesky)>> {
        let n = self.n();
        let mut local = vec![usize::MAX; n];
        let mut vars = Vec::new();
        for (p, &i) in self.order.iter().enumerate() {
            if keep[i] {
                local[p] = vars.len();
                vars.push(i);
            }
        }
        if vars.is_empty() {
            return Ok(None);
        }
        let u = &self.upper;
        let mut m = UpperCsc::with_capacity(vars.len(), u.values.len());
        for &i in &vars {
            let p = self.pos[i];
            for e in u.col_ptr[p]..u.col_ptr[p + 1] {
                let r = local[u.row_idx[e]];
                if r != usize::MAX {
                    m.push(r, u.values[e]);
                }
            }
            m.end_column();
        }
        Ok(Some((vars, OrderedCholesky::factorize(&m)?)))
    }
}

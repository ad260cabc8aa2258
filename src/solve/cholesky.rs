//! Sparse symmetric factorisation: the crate's one wrapper around faer's
//! sparse Cholesky (LLᵀ) and its LDLᵀ variant, with a fill-reducing ordering
//! (approximate minimum degree).
//!
//! * [`SparseCholesky`] — LLᵀ of a symmetric positive-definite matrix.
//! * [`SparseLdlt`] — LDLᵀ without pivoting, for symmetric quasi-definite or
//!   shifted matrices; it also reports the inertia (counts of negative, zero
//!   and positive pivots), which by Sylvester's law of inertia counts the
//!   eigenvalues below a shift (used to verify eigen solves).
//! * [`SymbolicCholesky`] — the ordering and elimination structure of one
//!   sparsity pattern, reusable for many matrices with that pattern
//!   (e.g. `M + tL` for several `t`, or a re-weighted system).
//!
//! Inputs are checked: square, finite and symmetric (both triangles stored,
//! as assembled by [`super::sparse_from_triplets`]). Failures are
//! [`Error::InvalidInput`] for bad shapes/values and [`Error::Numerical`] when
//! the matrix is not positive definite, naming the failed pivot.
//!
//! Threads: see [`super::set_threads`]; the default is sequential.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::linalg::cholesky::llt::factor::LltError;
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky as fch;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Side};
use nalgebra::DMatrix;

use super::{parallelism, SparseMatrix};
use crate::{Error, Result};

/// A pivot whose magnitude is below `PIVOT_REL_TOL · max |A_ii|` is treated as
/// zero: the matrix is (numerically) singular. A singular positive
/// semi-definite matrix such as a closed mesh's Laplacian does not give an
/// exact zero pivot but one at rounding level (measured 2e-15 to 1.4e-14
/// relative on icospheres of 162 to 10 242 vertices), which would make solves
/// silently meaningless. Consequence for regularised systems: in `L + εM` the
/// last pivot is about `ε · area`, so choose `ε · area ≫ 1e-12 · max L_ii`.
pub const PIVOT_REL_TOL: f64 = 1e-12;

/// Relative tolerance of the symmetry check: `|A_ij − A_ji| ≤ SYMMETRY_REL_TOL ·
/// max |A|`.
pub const SYMMETRY_REL_TOL: f64 = 1e-10;

/// Checks that `a` is square, non-empty, finite and symmetric; returns
/// `max |A_ii|`.
fn check_symmetric(a: &SparseMatrix) -> Result<f64> {
    let n = a.nrows();
    if n != a.ncols() {
        return Err(Error::invalid(format!(
            "symmetric factorisation needs a square matrix, got {}x{}",
            a.nrows(),
            a.ncols()
        )));
    }
    if n == 0 {
        return Err(Error::invalid("symmetric factorisation of an empty matrix"));
    }
    let mut max_abs = 0.0f64;
    let mut max_diag = 0.0f64;
    for (i, j, &v) in a.triplet_iter() {
        if !v.is_finite() {
            return Err(Error::invalid(format!(
                "matrix entry ({i}, {j}) is not finite ({v})"
            )));
        }
        max_abs = max_abs.max(v.abs());
        if i == j {
            max_diag = max_diag.max(v.abs());
        }
    }
    let tol = SYMMETRY_REL_TOL * max_abs;
    for (i, j, &v) in a.triplet_iter() {
        if i < j {
            let t = a.get_entry(j, i).map(|e| e.into_value()).unwrap_or(0.0);
            if (v - t).abs() > tol {
                return Err(Error::invalid(format!(
                    "matrix is not symmetric: A({i}, {j}) = {v} but A({j}, {i}) = {t}"
                )));
            }
        } else if i > j && a.get_entry(j, i).is_none() && v.abs() > tol {
            return Err(Error::invalid(format!(
                "matrix is not symmetric: A({i}, {j}) = {v} but A({j}, {i}) is not stored"
            )));
        }
    }
    Ok(max_diag)
}

/// Checks an in-place solve buffer (column-major `n × ncols`); `Ok(false)`
/// when there is nothing to solve.
fn check_solve_buffer(n: usize, len: usize, ncols: usize) -> Result<bool> {
    if len != n * ncols {
        return Err(Error::invalid(format!(
            "solve buffer has {len} values, expected {n}×{ncols}"
        )));
    }
    Ok(ncols > 0)
}

fn faer_view(a: &SparseMatrix) -> SparseColMatRef<'_, usize, f64> {
    let sym = SymbolicSparseColMatRef::new_checked(
        a.nrows(),
        a.ncols(),
        a.col_offsets(),
        None,
        a.row_indices(),
    );
    SparseColMatRef::new(sym, a.values())
}

/// Ordering and elimination structure of one symmetric sparsity pattern.
/// Cheap to clone (shared). Build once with [`SymbolicCholesky::new`], then
/// factorise any matrix with exactly this pattern with
/// [`SymbolicCholesky::factorize`] / [`SymbolicCholesky::factorize_ldlt`].
#[derive(Clone)]
pub struct SymbolicCholesky {
    inner: Arc<Inner>,
}

struct Inner {
    symbolic: fch::SymbolicCholesky<usize>,
    col_offsets: Vec<usize>,
    row_indices: Vec<usize>,
}

impl std::fmt::Debug for SymbolicCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SymbolicCholesky")
            .field("n", &self.nrows())
            .field("factor_nnz", &self.factor_nnz())
            .finish()
    }
}

impl SymbolicCholesky {
    /// Computes the fill-reducing ordering (AMD) and the symbolic factor of
    /// the pattern of `a` (square, symmetric, finite).
    pub fn new(a: &SparseMatrix) -> Result<Self> {
        check_symmetric(a)?;
        Self::new_unchecked_values(a)
    }

    /// The analysis, with faer's automatic choice between the simplicial
    /// and the supernodal variant (by the flop count of the pattern): the
    /// simplicial one for the cotan Laplacian at 6.9k and 27k vertices
    /// (supernodal at 108k), where its solves are the faster ones (see
    /// [`crate::solve::eigen`]); the bounded-weight solvers, whose
    /// biharmonic forms factorise faster supernodally at every size, force
    /// that variant themselves (`solve::qp::ordered`).
    fn new_unchecked_values(a: &SparseMatrix) -> Result<Self> {
        let view = faer_view(a);
        let symbolic = fch::factorize_symbolic_cholesky(
            view.symbolic(),
            Side::Lower,
            fch::SymmetricOrdering::Amd,
            fch::CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::AUTO,
                ..Default::default()
            },
        )
        .map_err(|e| Error::numerical(format!("symbolic Cholesky analysis failed: {e:?}")))?;
        Ok(SymbolicCholesky {
            inner: Arc::new(Inner {
                symbolic,
                col_offsets: a.col_offsets().to_vec(),
                row_indices: a.row_indices().to_vec(),
            }),
        })
    }

    /// Matrix dimension.
    pub fn nrows(&self) -> usize {
        self.inner.symbolic.nrows()
    }

    /// Number of stored values of the factor (fill-in included).
    pub fn factor_nnz(&self) -> usize {
        self.inner.symbolic.len_val()
    }

    fn check_pattern(&self, a: &SparseMatrix) -> Result<()> {
        if a.nrows() != self.nrows()
            || a.ncols() != self.nrows()
            || a.col_offsets() != self.inner.col_offsets.as_slice()
            || a.row_indices() != self.inner.row_indices.as_slice()
        {
            return Err(Error::invalid(format!(
                "matrix ({}x{}, {} stored entries) does not have the sparsity pattern this \
                 symbolic factorisation was built for ({}x{}, {} entries)",
                a.nrows(),
                a.ncols(),
                a.nnz(),
                self.nrows(),
                self.nrows(),
                self.inner.row_indices.len()
            )));
        }
        Ok(())
    }

    /// Numeric LLᵀ factorisation of `a`, which must have this pattern and be
    /// symmetric positive definite.
    pub fn factorize(&self, a: &SparseMatrix) -> Result<SparseCholesky> {
        let max_diag = check_symmetric(a)?;
        self.check_pattern(a)?;
        let sym = &self.inner.symbolic;
        let par = parallelism();
        let mut values = vec![0.0f64; sym.len_val()];
        let mut buf =
            MemBuffer::new(sym.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
        let res = sym.factorize_numeric_llt(
            &mut values,
            faer_view(a),
            Side::Lower,
            LltRegularization::default(),
            par,
            MemStack::new(&mut buf),
            Default::default(),
        );
        match res {
            Ok(_) => {}
            Err(LltError::NonPositivePivot { index }) => {
                // faer 0.24 reports the simplicial failure 1-based and the
                // supernodal one 0-based; normalise to 0-based.
                let index = match sym.raw() {
                    fch::SymbolicCholeskyRaw::Simplicial(_) => index.saturating_sub(1),
                    fch::SymbolicCholeskyRaw::Supernodal(_) => index,
                }
                .min(sym.nrows() - 1);
                let original = self.original_index(index);
                return Err(Error::numerical(format!(
                    "matrix is not positive definite: Cholesky pivot {index} of {} (row/column \
                     {original} of the input) is not positive",
                    sym.nrows()
                )));
            }
        }
        let fac = SparseCholesky {
            symbolic: self.clone(),
            values,
        };
        // LLᵀ pivots are the squared diagonal of L.
        let tiny = PIVOT_REL_TOL * max_diag;
        let (k, d) = fac
            .factor_diagonal()
            .into_iter()
            .map(|l| l * l)
            .enumerate()
            .fold(
                (0, f64::INFINITY),
                |acc, (k, d)| if d < acc.1 { (k, d) } else { acc },
            );
        if d.is_nan() || d <= tiny {
            return Err(Error::numerical(format!(
                "matrix is numerically singular (not positive definite): Cholesky pivot {k} \
                 (row/column {} of the input) is {d:.3e}, below {PIVOT_REL_TOL:e} × max diagonal \
                 {max_diag:.3e}",
                self.original_index(k)
            )));
        }
        Ok(fac)
    }

    /// Numeric LDLᵀ factorisation of `a` (this pattern, symmetric, no
    /// pivoting beyond the fill-reducing ordering). Fails if a pivot is
    /// (numerically) zero. Stable for definite and quasi-definite matrices;
    /// for general indefinite matrices it may lose accuracy, so check
    /// residuals if you solve with it.
    pub fn factorize_ldlt(&self, a: &SparseMatrix) -> Result<SparseLdlt> {
        let max_diag = check_symmetric(a)?;
        self.check_pattern(a)?;
        let sym = &self.inner.symbolic;
        let par = parallelism();
        let mut values = vec![0.0f64; sym.len_val()];
        let mut buf =
            MemBuffer::new(sym.factorize_numeric_ldlt_scratch::<f64>(par, Default::default()));
        sym.factorize_numeric_ldlt(
            &mut values,
            faer_view(a),
            Side::Lower,
            LdltRegularization::default(),
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .map_err(|e| Error::numerical(format!("sparse LDLT failed: {e:?}")))?;
        let fac = SparseLdlt {
            symbolic: self.clone(),
            values,
        };
        let tiny = PIVOT_REL_TOL * max_diag;
        let d = fac.pivots();
        if let Some((k, &dk)) = d
            .iter()
            .enumerate()
            .find(|(_, x)| x.is_nan() || x.abs() <= tiny)
        {
            return Err(Error::numerical(format!(
                "matrix is numerically singular: LDLT pivot {k} (row/column {} of the input) is \
                 {dk:.3e}",
                self.original_index(k)
            )));
        }
        Ok(fac)
    }

    /// Input row/column of pivot `k` of the permuted factor.
    fn original_index(&self, k: usize) -> usize {
        match self.inner.symbolic.perm() {
            Some(p) => p.arrays().0.get(k).copied().unwrap_or(k),
            None => k,
        }
    }

    /// Diagonal of the stored factor (in pivot order): √d for LLᵀ, d for
    /// LDLᵀ.
    fn stored_diagonal(&self, values: &[f64]) -> Vec<f64> {
        match self.inner.symbolic.raw() {
            fch::SymbolicCholeskyRaw::Simplicial(s) => {
                let cp = s.col_ptr();
                (0..s.nrows()).map(|j| values[cp[j]]).collect()
            }
            fch::SymbolicCholeskyRaw::Supernodal(s) => {
                let lref = fch::supernodal::SupernodalLltRef::<usize, f64>::new(s, values);
                let mut d = Vec::with_capacity(s.nrows());
                for k in 0..s.n_supernodes() {
                    let val = lref.supernode(k).val();
                    for j in 0..val.ncols() {
                        d.push(val[(j, j)]);
                    }
                }
                d
            }
        }
    }

    fn solve_scratch(&self, ncols: usize) -> MemBuffer {
        MemBuffer::new(
            self.inner
                .symbolic
                .solve_in_place_scratch::<f64>(ncols, parallelism()),
        )
    }
}

fn check_rhs(n: usize, nrows: usize) -> Result<()> {
    if nrows != n {
        return Err(Error::invalid(format!(
            "right-hand side has {nrows} rows, the factorised matrix has {n}"
        )));
    }
    Ok(())
}

/// Sparse Cholesky (LLᵀ) factorisation with a fill-reducing ordering, built
/// once and used for many solves.
#[derive(Clone)]
pub struct SparseCholesky {
    symbolic: SymbolicCholesky,
    values: Vec<f64>,
}

impl std::fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseCholesky")
            .field("symbolic", &self.symbolic)
            .finish()
    }
}

impl SparseCholesky {
    /// Factorises a symmetric positive-definite matrix (both triangles
    /// stored). Errors if the matrix is not square, not finite, not
    /// symmetric, or not (numerically) positive definite — the message names
    /// the failed pivot.
    pub fn new(a: &SparseMatrix) -> Result<Self> {
        check_symmetric(a)?;
        SymbolicCholesky::new_unchecked_values(a)?.factorize(a)
    }

    /// The symbolic part, for factorising other matrices with the same
    /// pattern.
    pub fn symbolic(&self) -> &SymbolicCholesky {
        &self.symbolic
    }

    /// Matrix dimension.
    pub fn nrows(&self) -> usize {
        self.symbolic.nrows()
    }

    /// Diagonal of the Cholesky factor L (pivot order).
    pub fn factor_diagonal(&self) -> Vec<f64> {
        self.symbolic.stored_diagonal(&self.values)
    }

    /// Solves `A X = B` in place; `x` is column-major `n × ncols`.
    pub fn solve_in_place(&self, x: &mut [f64], ncols: usize) -> Result<()> {
        let n = self.nrows();
        if !check_solve_buffer(n, x.len(), ncols)? {
            return Ok(());
        }
        let mut buf = self.symbolic.solve_scratch(ncols);
        let llt = fch::LltRef::<usize, f64>::new(&self.symbolic.inner.symbolic, &self.values);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, n, ncols),
            parallelism(),
            MemStack::new(&mut buf),
        );
        Ok(())
    }

    /// Solves `A X = B` for every column of `B`; errors if `B` has the wrong
    /// number of rows.
    pub fn try_solve(&self, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        check_rhs(self.nrows(), b.nrows())?;
        let mut x = b.clone();
        let nc = x.ncols();
        self.solve_in_place(x.as_mut_slice(), nc)?;
        Ok(x)
    }

    /// Solves `A X = B` for every column of `B`.
    ///
    /// # Panics
    /// If `B` does not have as many rows as `A` (a programming error; use
    /// [`SparseCholesky::try_solve`] to get an error instead).
    pub fn solve(&self, b: &DMatrix<f64>) -> DMatrix<f64> {
        match self.try_solve(b) {
            Ok(x) => x,
            Err(e) => panic!("SparseCholesky::solve: {e}"),
        }
    }

    /// Solves `A x = b` for one right-hand side; errors on a length mismatch.
    pub fn try_solve_vec(&self, b: &[f64]) -> Result<Vec<f64>> {
        check_rhs(self.nrows(), b.len())?;
        let mut x = b.to_vec();
        self.solve_in_place(&mut x, 1)?;
        Ok(x)
    }

    /// Solves `A x = b` for one right-hand side.
    ///
    /// # Panics
    /// If `b.len()` differs from the dimension (see
    /// [`SparseCholesky::try_solve_vec`]).
    pub fn solve_vec(&self, b: &[f64]) -> Vec<f64> {
        match self.try_solve_vec(b) {
            Ok(x) => x,
            Err(e) => panic!("SparseCholesky::solve_vec: {e}"),
        }
    }
}

/// Sparse LDLᵀ factorisation (fill-reducing ordering, no numerical pivoting).
#[derive(Clone)]
pub struct SparseLdlt {
    symbolic: SymbolicCholesky,
    values: Vec<f64>,
}

impl std::fmt::Debug for SparseLdlt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLdlt")
            .field("symbolic", &self.symbolic)
            .finish()
    }
}

/// Counts of negative, zero and positive pivots of an LDLᵀ factorisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Inertia {
    pub negative: usize,
    pub zero: usize,
    pub positive: usize,
}

impl SparseLdlt {
    /// Factorises a symmetric matrix whose LDLᵀ exists without pivoting
    /// (definite, quasi-definite, or a shifted matrix away from its
    /// eigenvalues). See [`SymbolicCholesky::factorize_ldlt`].
    pub fn new(a: &SparseMatrix) -> Result<Self> {
        check_symmetric(a)?;
        SymbolicCholesky::new_unchecked_values(a)?.factorize_ldlt(a)
    }

    /// Matrix dimension.
    pub fn nrows(&self) -> usize {
        self.symbolic.nrows()
    }

    /// The pivots `D` (pivot order).
    pub fn pivots(&self) -> Vec<f64> {
        self.symbolic.stored_diagonal(&self.values)
    }

    /// Signs of the pivots. By Sylvester's law of inertia, for `A = K − σM`
    /// with `M` positive definite, `negative` is the number of generalised
    /// eigenvalues of `(K, M)` below `σ`.
    pub fn inertia(&self) -> Inertia {
        let mut out = Inertia {
            negative: 0,
            zero: 0,
            positive: 0,
        };
        for d in self.pivots() {
            if d < 0.0 {
                out.negative += 1;
            } else if d > 0.0 {
                out.positive += 1;
            } else {
                out.zero += 1;
            }
        }
        out
    }

    /// Solves `A X = B` in place; `x` is column-major `n × ncols`.
    pub fn solve_in_place(&self, x: &mut [f64], ncols: usize) -> Result<()> {
        let n = self.nrows();
        if !check_solve_buffer(n, x.len(), ncols)? {
            return Ok(());
        }
        let mut buf = self.symbolic.solve_scratch(ncols);
        let ldlt = fch::LdltRef::<usize, f64>::new(&self.symbolic.inner.symbolic, &self.values);
        ldlt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, n, ncols),
            parallelism(),
            MemStack::new(&mut buf),
        );
        Ok(())
    }

    /// Solves `A X = B` for every column of `B`.
    pub fn solve(&self, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        check_rhs(self.nrows(), b.nrows())?;
        let mut x = b.clone();
        let nc = x.ncols();
        self.solve_in_place(x.as_mut_slice(), nc)?;
        Ok(x)
    }

    /// Solves `A x = b`.
    pub fn solve_vec(&self, b: &[f64]) -> Result<Vec<f64>> {
        check_rhs(self.nrows(), b.len())?;
        let mut x = b.to_vec();
        self.solve_in_place(&mut x, 1)?;
        Ok(x)
    }
}

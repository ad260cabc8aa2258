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

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
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

    /// Empties the matrix and sets its dimension to `n`, keeping the
    /// allocations (for refilling with [`UpperCsc::push`]).
    pub fn reset(&mut self, n: usize) {
        self.n = n;
        self.col_ptr.clear();
        self.col_ptr.push(0);
        self.row_idx.clear();
        self.values.clear();
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

/// faer's scratch memory, kept between factorisations and solves and grown
/// only when a request exceeds it. A fresh buffer per call costs a fresh
/// zeroed allocation, which for a large factor means fresh pages faulted in
/// by the kernel at every iteration of an active-set method.
#[derive(Default)]
pub(crate) struct Scratch {
    buf: Option<MemBuffer>,
    req: Option<StackReq>,
}

impl Scratch {
    /// A stack of at least `req`.
    pub fn stack(&mut self, req: StackReq) -> &mut MemStack {
        let fits = self.req.is_some_and(|have| {
            have.size_bytes() >= req.size_bytes() && have.align_bytes() >= req.align_bytes()
        });
        if !fits {
            let grown = self.req.map_or(req, |have| have.or(req));
            self.buf = Some(MemBuffer::new(grown));
            self.req = Some(grown);
        }
        MemStack::new(self.buf.as_mut().expect("allocated above"))
    }
}

/// The buffers of a sequence of factorisations of changing matrices
/// ([`OrderedCholesky::factorize_with`]): the factor's values (faer
/// overwrites them, so stale values do no harm) and the scratch memory.
#[derive(Default)]
pub(crate) struct FactorBuffers {
    values: Vec<f64>,
    pub scratch: Scratch,
}

/// Supernodal symbolic analysis of an upper triangle already in its
/// elimination order (faer's automatic choice picked the simplicial variant
/// for the biharmonic form, measured twice as slow).
fn supernodal_symbolic(
    upper: SymbolicSparseColMatRef<'_, usize>,
) -> Result<fch::SymbolicCholesky<usize>> {
    fch::factorize_symbolic_cholesky(
        upper,
        Side::Upper,
        fch::SymmetricOrdering::Identity,
        fch::CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        },
    )
    .map_err(|e| Error::numerical(format!("symbolic Cholesky failed: {e:?}")))
}

/// The sequential numeric LLᵀ of `view` (the triangle `side`) into
/// `values`, with the error of a matrix that is not positive definite.
fn numeric_llt(
    symbolic: &fch::SymbolicCholesky<usize>,
    values: &mut [f64],
    view: SparseColMatRef<'_, usize, f64>,
    side: Side,
    stack: &mut MemStack,
) -> Result<()> {
    symbolic
        .factorize_numeric_llt(
            values,
            view,
            side,
            Default::default(),
            Par::Seq,
            stack,
            Default::default(),
        )
        .map(|_| ())
        .map_err(|e| match e {
            LltError::NonPositivePivot { index } => Error::numerical(format!(
                "matrix of an active-set step is not positive definite (pivot {index} of {}); \
                 the quadratic form must be positive definite on the free variables",
                symbolic.nrows()
            )),
        })
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
        Self::factorize_with(m, &mut FactorBuffers::default())
    }

    /// [`OrderedCholesky::factorize`] with the values and scratch of
    /// `bufs` (give the values back with [`OrderedCholesky::recycle`]).
    pub fn factorize_with(m: &UpperCsc, bufs: &mut FactorBuffers) -> Result<Self> {
        let n = m.n;
        if n == 0 || m.col_ptr.len() != n + 1 {
            return Err(Error::invalid(format!(
                "ordered Cholesky: malformed {n}×{n} matrix"
            )));
        }
        let sym_view = SymbolicSparseColMatRef::new_checked(n, n, &m.col_ptr, None, &m.row_idx);
        let symbolic = supernodal_symbolic(sym_view)?;
        let mut values = std::mem::take(&mut bufs.values);
        values.resize(symbolic.len_val(), 0.0);
        let stack = bufs
            .scratch
            .stack(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        let view = SparseColMatRef::new(sym_view, &m.values);
        numeric_llt(&symbolic, &mut values, view, Side::Upper, stack)?;
        Ok(OrderedCholesky { symbolic, values })
    }

    /// Hands the factor's values back to `bufs` for the next
    /// [`OrderedCholesky::factorize_with`].
    pub fn recycle(self, bufs: &mut FactorBuffers) {
        bufs.values = self.values;
    }

    /// Solves `A X = B` in place; `x` is column-major `n × ncols`.
    pub fn solve_in_place(&self, x: &mut [f64], ncols: usize) {
        self.solve_in_place_with(x, ncols, &mut Scratch::default());
    }

    /// [`OrderedCholesky::solve_in_place`] with kept scratch memory.
    pub fn solve_in_place_with(&self, x: &mut [f64], ncols: usize, scratch: &mut Scratch) {
        let n = self.symbolic.nrows();
        debug_assert_eq!(x.len(), n * ncols);
        if ncols == 0 {
            return;
        }
        let par = Par::Seq;
        let stack = scratch.stack(self.symbolic.solve_in_place_scratch::<f64>(ncols, par));
        fch::LltRef::<usize, f64>::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, n, ncols),
            par,
            stack,
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
    /// Lower triangle of `P A Pᵀ` (column p holds rows q ≥ p, sorted), the
    /// input faer's supernodal numeric factorisation takes without a
    /// transpose.
    lower: UpperCsc,
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
        let mut lower = UpperCsc::with_capacity(n, vals.len() / 2 + n);
        let mut col: Vec<(usize, f64)> = Vec::new();
        for &j in &order {
            col.clear();
            let pj = pos[j];
            for p in off[j]..off[j + 1] {
                col.push((pos[rows[p]], vals[p]));
            }
            col.sort_unstable_by_key(|e| e.0);
            for &(q, v) in &col {
                if q <= pj {
                    upper.push(q, v);
                }
                if q >= pj {
                    lower.push(q, v);
                }
            }
            upper.end_column();
            lower.end_column();
        }
        Ok(Ordered {
            order,
            pos,
            upper,
            lower,
        })
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

/// Factorises principal submatrices `A_FF` of an [`Ordered`] matrix for a
/// sequence of slowly changing sets `F` (the free sets of an active-set
/// method), reusing one symbolic analysis while it fits.
///
/// The symbolic analysis (elimination tree, column counts, supernodes) is
/// done for a *superset* `U ⊇ F`: `F` plus its neighbours in `A`'s pattern.
/// While later sets stay inside `U`, only the numeric factorisation is
/// redone, of the matrix that equals `A_FF` on `F` and the identity on
/// `U − F` (no entries between the two): its pattern is a subset of the
/// analysed one, and its factor is `A_FF`'s factor beside an identity block
/// (the identity columns receive no updates), so the solution on `F` is that
/// of `A_FF x = r` up to rounding. `U` is analysed again when a set leaves
/// it, or when it has shrunk so much that the identity part costs more than
/// the analysis saves. The active sets of the box QP grow by a few rings per
/// iteration; the neighbours of `F` cover several iterations.
///
/// Measured (`deformlab weights tr_reg_001.ply --handles 10 --mode
/// per-handle`, one thread, 351 iterations, three runs each, load 2.7–3):
/// 1.27 s without a margin (an analysis whenever `F` grows), 1.14 s with
/// the neighbours (109 analyses), 1.10 s with neighbours of neighbours
/// (within noise of one ring, at more memory: one ring is kept); the
/// previous fresh analysis per iteration 1.23 s. Weights within 5e-11.
#[derive(Default)]
pub(crate) struct SubsetFactorizer {
    /// Variable `i` is in the analysed set `U`.
    member: Vec<bool>,
    /// `U` in elimination order (the factor's row order).
    vars: Vec<usize>,
    /// Position `p` in the ordering → row of the factor (`usize::MAX` if
    /// the variable is not in `U`).
    local: Vec<usize>,
    /// Size of `U − F` right after the analysis.
    margin: usize,
    symbolic: Option<fch::SymbolicCholesky<usize>>,
    /// Lower triangle of the matrix factorised last (reused buffers).
    matrix: UpperCsc,
    /// The factor's values and faer's scratch.
    bufs: FactorBuffers,
    /// Symbolic analyses done.
    pub analyses: usize,
}

impl SubsetFactorizer {
    /// Analyses `U = keep ∪ neighbours(keep)`.
    fn analyse(&mut self, ordered: &Ordered, keep: &[bool]) -> Result<()> {
        let n = ordered.n();
        let u = &ordered.upper;
        self.member.clear();
        self.member.extend_from_slice(keep);
        // Neighbours in the pattern (both triangles: the upper triangle's
        // column p lists the earlier neighbours of order[p]).
        for p in 0..n {
            let i = ordered.order[p];
            for e in u.col_ptr[p]..u.col_ptr[p + 1] {
                let j = ordered.order[u.row_idx[e]];
                if keep[i] || keep[j] {
                    self.member[i] = true;
                    self.member[j] = true;
                }
            }
        }
        self.local.clear();
        self.local.resize(n, usize::MAX);
        self.vars.clear();
        for (p, &i) in ordered.order.iter().enumerate() {
            if self.member[i] {
                self.local[p] = self.vars.len();
                self.vars.push(i);
            }
        }
        let m = self.vars.len();
        self.margin = m - keep.iter().filter(|&&k| k).count();
        let mut pattern = UpperCsc::with_capacity(m, u.values.len());
        for &i in &self.vars {
            let p = ordered.pos[i];
            for e in u.col_ptr[p]..u.col_ptr[p + 1] {
                let r = self.local[u.row_idx[e]];
                if r != usize::MAX {
                    pattern.push(r, 0.0);
                }
            }
            pattern.end_column();
        }
        let sym_view =
            SymbolicSparseColMatRef::new_checked(m, m, &pattern.col_ptr, None, &pattern.row_idx);
        let symbolic = supernodal_symbolic(sym_view)?;
        self.bufs.values.resize(symbolic.len_val(), 0.0);
        self.symbolic = Some(symbolic);
        self.analyses += 1;
        Ok(())
    }

    /// Factorises `A_FF` for `F = {i : keep[i]}` (analysing again only when
    /// needed) and solves `A_FF x = rhs_F`, writing `x` into `out` at the
    /// variables of `F` (other entries of `out` are left alone). Returns
    /// `false` (and does nothing) when `F` is empty.
    pub fn solve(
        &mut self,
        ordered: &Ordered,
        keep: &[bool],
        rhs: &[f64],
        out: &mut [f64],
    ) -> Result<bool> {
        let kept = keep.iter().filter(|&&k| k).count();
        if kept == 0 {
            return Ok(false);
        }
        let fits = self.symbolic.is_some()
            && keep.iter().zip(&self.member).all(|(&k, &m)| !k || m)
            && self.vars.len() - kept <= 2 * self.margin.max(1);
        if !fits {
            self.analyse(ordered, keep)?;
        }
        let symbolic = self.symbolic.as_ref().expect("analysed above");
        let m = self.vars.len();
        // Lower triangle: A on F × F, identity on U − F.
        let l = &ordered.lower;
        let mat = &mut self.matrix;
        mat.n = m;
        mat.col_ptr.clear();
        mat.col_ptr.push(0);
        mat.row_idx.clear();
        mat.values.clear();
        for &i in &self.vars {
            let p = ordered.pos[i];
            if keep[i] {
                for e in l.col_ptr[p]..l.col_ptr[p + 1] {
                    let q = l.row_idx[e];
                    let r = self.local[q];
                    if r != usize::MAX && keep[ordered.order[q]] {
                        mat.push(r, l.values[e]);
                    }
                }
            } else {
                mat.push(self.local[p], 1.0);
            }
            mat.end_column();
        }
        let view = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(m, m, &mat.col_ptr, None, &mat.row_idx),
            &mat.values,
        );
        let par = Par::Seq;
        let stack = self.bufs.scratch.stack(
            symbolic
                .factorize_numeric_llt_scratch::<f64>(par, Default::default())
                .or(symbolic.solve_in_place_scratch::<f64>(1, par)),
        );
        numeric_llt(symbolic, &mut self.bufs.values, view, Side::Lower, stack)?;
        let mut y: Vec<f64> = self
            .vars
            .iter()
            .map(|&i| if keep[i] { rhs[i] } else { 0.0 })
            .collect();
        fch::LltRef::<usize, f64>::new(symbolic, &self.bufs.values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut y, m, 1),
            par,
            stack,
        );
        for (&i, &v) in self.vars.iter().zip(&y) {
            if keep[i] {
                out[i] = v;
            }
        }
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::sparse_from_triplets;

    /// Reusing one analysis over growing and shrinking subsets gives the
    /// fresh factorisation's solutions, and does reuse it.
    #[test]
    fn subset_factorizer_equals_fresh_factorisations() {
        // 2D grid Laplacian (5-point) + 0.05 I on 24 × 24 nodes.
        let w = 24;
        let n = w * w;
        let mut t = Vec::new();
        for y in 0..w {
            for x in 0..w {
                let i = y * w + x;
                t.push((i, i, 4.05));
                for (dx, dy) in [(1usize, 0usize), (0, 1)] {
                    if x + dx < w && y + dy < w {
                        let j = (y + dy) * w + x + dx;
                        t.push((i, j, -1.0));
                        t.push((j, i, -1.0));
                    }
                }
            }
        }
        let a = sparse_from_triplets(n, n, t);
        let ordered = Ordered::new(&a).unwrap();
        let rhs: Vec<f64> = (0..n)
            .map(|i| ((i * 37 % 101) as f64 - 50.0) / 7.0)
            .collect();
        let mut fac = SubsetFactorizer::default();
        let mut calls = 0;
        // Quarter discs around a corner: a disc, then three subsets of it
        // (every 17th / 19th / 23rd node removed: inside the analysed
        // neighbourhood, so no new analysis), then a larger disc (which
        // leaves it), its subsets, and shrinking discs (correctness only).
        let disc = |r: usize, skip: usize| -> Vec<bool> {
            (0..n)
                .map(|i| (i / w).pow(2) + (i % w).pow(2) <= r * r && (skip == 0 || i % skip != 0))
                .collect()
        };
        let mut sets = Vec::new();
        for r in [10, 14] {
            for skip in [0, 17, 19, 23] {
                sets.push(disc(r, skip));
            }
        }
        let reusing = sets.len();
        sets.extend((3..14).rev().map(|r| disc(r, 0)));
        for (call, keep) in sets.iter().enumerate() {
            let mut got = vec![f64::NAN; n];
            assert!(fac.solve(&ordered, keep, &rhs, &mut got).unwrap());
            calls += 1;
            let (vars, f) = ordered.factorize_subset(keep).unwrap().unwrap();
            let mut y: Vec<f64> = vars.iter().map(|&i| rhs[i]).collect();
            f.solve_in_place(&mut y, 1);
            let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (&i, &v) in vars.iter().zip(&y) {
                assert!(
                    (got[i] - v).abs() <= 1e-12 * scale,
                    "set {call}, variable {i}"
                );
            }
            for i in 0..n {
                assert_eq!(got[i].is_nan(), !keep[i], "only F is written");
            }
            if call + 1 == reusing {
                assert_eq!(
                    fac.analyses, 2,
                    "one analysis per disc, reused for its subsets"
                );
            }
        }
        assert!(fac.analyses < calls);
        assert!(!fac
            .solve(&ordered, &vec![false; n], &rhs, &mut vec![0.0; n])
            .unwrap());
    }
}

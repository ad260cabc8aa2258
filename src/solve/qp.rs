//! Small convex quadratic programs on top of sparse Cholesky factorisations.
//!
//! * [`BoxQp`] — `min ½ xᵀA x + bᵀx` subject to `lo ≤ x ≤ hi` (scalar bounds)
//!   for a sparse symmetric positive-definite `A`, by a primal–dual active-set
//!   method. Every iteration factorises the free block `A_FF` in the induced
//!   order of one AMD ordering of `A` computed once (module `ordered`), so no
//!   iteration pays for an ordering and the cost shrinks with the free set.
//!   `BoxQp` is `Sync`: many right-hand sides can be solved in parallel.
//! * [`RowAdmm`] — `min Σ_k ½ x_kᵀA x_k + b_kᵀx_k` over an `n × m`
//!   matrix `X` (columns `x_k`) whose every row lies on the probability simplex
//!   (`X_ik ≥ 0`, `Σ_k X_ik = 1`) or in a box, by ADMM with one factorisation
//!   of `A + ρD` shared by all columns and iterations.
//! * [`simplex_rows_qp`] — the same simplex-constrained problem solved
//!   exactly by an active-set method on the row supports.
//!
//! All are generic numerics (no meshes); bounded biharmonic weights
//! (`skin::bbw`) are their main user.

mod ordered;

use nalgebra::DMatrix;
use rayon::prelude::*;

use self::ordered::{FactorBuffers, Ordered, OrderedCholesky, SubsetFactorizer, UpperCsc};
use super::{SparseCholesky, SparseMatrix, SymbolicCholesky};
use crate::{Error, Result};

/// [`RowAdmm`] solves its right-hand sides in blocks of this many columns,
/// the blocks in parallel (multi-column solves are cheaper per column; the
/// fixed block size keeps results independent of the thread count).
pub const ADMM_COLUMN_BLOCK: usize = 4;

/// State of one variable in the active-set method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Bound {
    Free,
    Lower,
    Upper,
}

/// Result of [`BoxQp::solve`].
#[derive(Clone, Debug)]
pub struct BoxQpSolution {
    /// The last iterate clamped to the bounds (exactly within them).
    pub x: Vec<f64>,
    /// Global active-set iterations (each one numeric factorisation of the
    /// whole free block) used.
    pub iterations: usize,
    /// Iterations of local refinement (see [`BoxQp::with_local_hops`]), each
    /// a factorisation of the free block inside a small region.
    pub local_iterations: usize,
    /// Number of variables at a bound at the end.
    pub n_active: usize,
    /// Final active set: `true` for variables fixed at a bound (their values
    /// in `x` are exactly the bound; free variables may also sit at a bound
    /// after clamping).
    pub at_bound: Vec<bool>,
    /// Whether the active set settled within the iteration limit (if not,
    /// `x` is the clamped last iterate and [`BoxQpSolution::kkt_residual`]
    /// says how far from optimal it is).
    pub converged: bool,
    /// KKT residual of the returned `x`, in units of `x` (scale-free): the
    /// largest `|g_i| / A_ii` over variables strictly inside the bounds, and
    /// the largest wrong-signed `g_i / A_ii` over variables at a bound, with
    /// `g = A x + b`. It is how far variable `i` alone would move if it were
    /// re-optimised with the others fixed; 0 at the exact optimum.
    pub kkt_residual: f64,
}

/// Bound-constrained sparse QP `min ½ xᵀA x + bᵀx, lo ≤ x ≤ hi`, `A` symmetric
/// positive definite. Build once per matrix ([`BoxQp::new`] computes the
/// fill-reducing ordering), then [`BoxQp::solve`] for many `b` (from several
/// threads if wanted: every solve is sequential and independent).
///
/// Algorithm: the primal–dual active-set method (Hintermüller–Ito–Kunisch
/// 2003; libigl's `active_set` is the same iteration). Start from the active
/// set of a warm start `x0` (variables outside the bounds), then repeat: solve
/// the equality-constrained problem with the active variables fixed at their
/// bounds (one sparse Cholesky of the free block `A_FF`); fix *every* free
/// variable that violates a bound by more than `tol·(hi − lo)`; release *every*
/// active variable whose multiplier (the gradient `g = A x + b`) has the wrong
/// sign by more than `tol·(hi − lo)·A_ii` (releasing `x_i` alone would move it
/// by more than `tol·(hi − lo)`: a per-row, scale-free test); stop when the
/// set no longer changes. The result is clamped to the bounds (it moves by at
/// most `tol·(hi − lo)`), and its KKT residual is reported.
#[derive(Clone, Debug)]
pub struct BoxQp {
    a: SparseMatrix,
    diag: Vec<f64>,
    ordered: Ordered,
    local_hops: usize,
}

/// Iterations allowed to one local refinement of [`BoxQp::solve`] (see
/// [`BoxQp::with_local_hops`]); a refinement that has not settled by then
/// hands its current active set to the next global iteration.
const LOCAL_MAX_ITER: usize = 100;

/// Checks that `a` is square, finite, has a positive stored diagonal and is
/// symmetric (pattern and values, to `1e-12` relative); returns the diagonal.
fn check_spd_candidate(a: &SparseMatrix, what: &str) -> Result<Vec<f64>> {
    let n = a.nrows();
    if n == 0 || a.ncols() != n {
        return Err(Error::invalid(format!(
            "{what}: matrix must be square and non-empty, got {}×{}",
            a.nrows(),
            a.ncols()
        )));
    }
    let mut diag = vec![0.0; n];
    let mut max_abs = 0.0f64;
    for (i, j, &v) in a.triplet_iter() {
        if !v.is_finite() {
            return Err(Error::invalid(format!(
                "{what}: matrix entry ({i}, {j}) is not finite ({v})"
            )));
        }
        max_abs = max_abs.max(v.abs());
        if i == j {
            diag[i] = v;
        }
    }
    if let Some(i) = diag.iter().position(|&d| d <= 0.0) {
        return Err(Error::invalid(format!(
            "{what}: matrix needs a positive stored diagonal; A({i}, {i}) = {}",
            diag[i]
        )));
    }
    let t = a.transpose();
    let same_pattern = t.col_offsets() == a.col_offsets() && t.row_indices() == a.row_indices();
    let tol = 1e-12 * max_abs;
    if !same_pattern
        || t.values()
            .iter()
            .zip(a.values())
            .any(|(x, y)| (x - y).abs() > tol)
    {
        return Err(Error::invalid(format!(
            "{what}: matrix is not symmetric (both triangles must be stored, equal)"
        )));
    }
    Ok(diag)
}

impl BoxQp {
    /// Analyses `a` (square, symmetric with both triangles stored, every
    /// diagonal entry stored and positive): one AMD ordering.
    pub fn new(a: &SparseMatrix) -> Result<Self> {
        let diag = check_spd_candidate(a, "box QP")?;
        Ok(BoxQp {
            a: a.clone(),
            diag,
            ordered: Ordered::new(a)?,
            local_hops: 0,
        })
    }

    /// Enables local refinement with `hops` steps of `A`'s graph (0, the
    /// default of [`BoxQp::new`], turns it off).
    ///
    /// Why: a bound is released only where its multiplier `g_i = (A x + b)_i`
    /// has the wrong sign, and deep inside a region of active bounds `g_i`
    /// is exactly zero (every `A`-neighbour sits at the bound), so the free
    /// set can grow by only one step of `A`'s graph per iteration (for the
    /// bilaplacian of bounded biharmonic weights, two rings of the mesh).
    /// Where the optimum's free set reaches further, plain iterations creep
    /// ring by ring, each paying for a factorisation of the whole free block.
    ///
    /// What: after every global iteration that changed the active set, the
    /// same primal–dual iteration runs on the region `R` within `hops` steps
    /// of the changed variables, with every variable outside `R` frozen at
    /// its current value (a smaller QP with its own AMD ordering),
    /// until its active set settles (at most 100 iterations); its active set
    /// then seeds the next global iteration. Refinement is skipped when `R`
    /// holds more than half of the variables. Only the path changes: the
    /// method still stops only when a *global* iteration leaves the active
    /// set unchanged, with the same tolerance, so the result satisfies the
    /// same optimality test as without refinement.
    pub fn with_local_hops(mut self, hops: usize) -> Self {
        self.local_hops = hops;
        self
    }

    /// Dimension.
    pub fn n(&self) -> usize {
        self.a.nrows()
    }

    /// The matrix `A`.
    pub fn matrix(&self) -> &SparseMatrix {
        &self.a
    }

    /// Solves the unconstrained problems `A X = −B` for all columns of `b`
    /// (one factorisation), e.g. for a warm start.
    pub fn solve_unconstrained(&self, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        let n = self.n();
        if b.nrows() != n {
            return Err(Error::invalid(format!(
                "box QP of dimension {n} got a right-hand side with {} rows",
                b.nrows()
            )));
        }
        let m = b.ncols();
        let mut x = DMatrix::zeros(n, m);
        let Some((vars, fac)) = self.ordered.factorize_subset(&vec![true; n])? else {
            return Ok(x);
        };
        let mut y = vec![0.0; n * m];
        for k in 0..m {
            for (r, &i) in vars.iter().enumerate() {
                y[k * n + r] = -b[(i, k)];
            }
        }
        fac.solve_in_place(&mut y, m);
        for k in 0..m {
            for (r, &i) in vars.iter().enumerate() {
                x[(i, k)] = y[k * n + r];
            }
        }
        Ok(x)
    }

    /// `A x + b`.
    fn gradient(&self, x: &[f64], b: &[f64]) -> Vec<f64> {
        let mut g = b.to_vec();
        sym_matvec_add(&self.a, x, &mut g);
        g
    }

    /// KKT residual of a point within the bounds (see
    /// [`BoxQpSolution::kkt_residual`]).
    pub fn kkt_residual(&self, x: &[f64], b: &[f64], lo: f64, hi: f64) -> f64 {
        let g = self.gradient(x, b);
        let mut r = 0.0f64;
        for i in 0..x.len() {
            let s = g[i] / self.diag[i];
            let v = if x[i] <= lo {
                (-s).max(0.0)
            } else if x[i] >= hi {
                s.max(0.0)
            } else {
                s.abs()
            };
            r = r.max(v);
        }
        r
    }

    /// Solves the QP for linear term `b`. `x0` (optional warm start) only
    /// seeds the initial active set: variables of `x0` outside the bounds
    /// start fixed at the violated bound. Errors if the bounds are empty or
    /// not finite, or on length mismatches. If the active set has not settled
    /// after `max_iter` iterations the clamped last iterate is returned with
    /// `converged = false` and its KKT residual.
    pub fn solve(
        &self,
        b: &[f64],
        lo: f64,
        hi: f64,
        x0: Option<&[f64]>,
        max_iter: usize,
        tol: f64,
    ) -> Result<BoxQpSolution> {
        let n = self.n();
        if b.len() != n || x0.is_some_and(|x| x.len() != n) {
            return Err(Error::invalid(format!(
                "box QP of dimension {n} got b of length {} and x0 of length {:?}",
                b.len(),
                x0.map(|x| x.len())
            )));
        }
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(Error::invalid(format!(
                "box QP bounds must be finite with lo < hi, got [{lo}, {hi}]"
            )));
        }
        if !(tol >= 0.0 && tol.is_finite()) {
            return Err(Error::invalid(format!(
                "box QP tolerance must be finite and ≥ 0, got {tol}"
            )));
        }
        let feas_tol = tol * (hi - lo);
        let mut state: Vec<Bound> = match x0 {
            Some(x0) => x0
                .iter()
                .map(|&v| {
                    if v < lo {
                        Bound::Lower
                    } else if v > hi {
                        Bound::Upper
                    } else {
                        Bound::Free
                    }
                })
                .collect(),
            None => vec![Bound::Free; n],
        };
        let bounds = (lo, hi, feas_tol);
        let mut x = vec![0.0; n];
        let max_iter = max_iter.max(1);
        let mut converged = false;
        let mut iterations = 0;
        let mut local_iterations = 0;
        let mut factorizer = SubsetFactorizer::default();
        let mut changed = Vec::new();
        let mut region = vec![false; n];
        for it in 1..=max_iter {
            iterations = it;
            changed.clear();
            self.pdas_step(b, bounds, &mut state, &mut x, &mut factorizer, &mut changed)?;
            if changed.is_empty() {
                converged = true;
                break;
            }
            if self.local_hops > 0 && grow_region(&self.a, self.local_hops, &changed, &mut region) {
                local_iterations += self.refine_region(b, bounds, &mut state, &mut x, &region)?;
            }
        }
        for v in &mut x {
            *v = v.clamp(lo, hi);
        }
        let kkt_residual = self.kkt_residual(&x, b, lo, hi);
        Ok(BoxQpSolution {
            iterations,
            local_iterations,
            n_active: state.iter().filter(|&&s| s != Bound::Free).count(),
            at_bound: state.iter().map(|&s| s != Bound::Free).collect(),
            converged,
            kkt_residual,
            x,
        })
    }

    /// Local refinement: the QP restricted to `region` (its own AMD
    /// ordering: cheaper factorisations of a small region than the induced
    /// order of the global one, 27k key points 41–44 → 34 s), every other
    /// variable frozen at its value in `x`, solved by the same iteration
    /// from the current active set (at most [`LOCAL_MAX_ITER`] iterations);
    /// writes the region's values and active set back. Returns the
    /// iterations.
    fn refine_region(
        &self,
        b: &[f64],
        (lo, hi, feas_tol): (f64, f64, f64),
        state: &mut [Bound],
        x: &mut [f64],
        region: &[bool],
    ) -> Result<usize> {
        let n = self.n();
        let vars: Vec<usize> = (0..n).filter(|&i| region[i]).collect();
        let mut local = vec![usize::MAX; n];
        for (t, &i) in vars.iter().enumerate() {
            local[i] = t;
        }
        let (off, rows, vals) = (self.a.col_offsets(), self.a.row_indices(), self.a.values());
        let nr = vars.len();
        let mut col_offsets = Vec::with_capacity(nr + 1);
        let mut row_indices = Vec::new();
        let mut values = Vec::new();
        let mut bs = vec![0.0; nr];
        col_offsets.push(0);
        for (t, &j) in vars.iter().enumerate() {
            let mut r = b[j];
            for p in off[j]..off[j + 1] {
                let i = rows[p];
                if local[i] != usize::MAX {
                    row_indices.push(local[i]);
                    values.push(vals[p]);
                } else {
                    r += vals[p] * x[i];
                }
            }
            bs[t] = r;
            col_offsets.push(row_indices.len());
        }
        let asub = SparseMatrix::try_from_csc_data(nr, nr, col_offsets, row_indices, values)
            .map_err(|e| Error::numerical(format!("box QP: region matrix: {e:?}")))?;
        let sub = BoxQp {
            diag: vars.iter().map(|&i| self.diag[i]).collect(),
            ordered: Ordered::new(&asub)?,
            a: asub,
            local_hops: 0,
        };
        let x0: Vec<f64> = vars
            .iter()
            .map(|&i| match state[i] {
                Bound::Lower => lo - 1.0,
                Bound::Upper => hi + 1.0,
                Bound::Free => x[i].clamp(lo, hi),
            })
            .collect();
        let tol = if hi > lo { feas_tol / (hi - lo) } else { 0.0 };
        let s = sub.solve(&bs, lo, hi, Some(&x0), LOCAL_MAX_ITER, tol)?;
        for (t, &i) in vars.iter().enumerate() {
            x[i] = s.x[t];
            state[i] = if !s.at_bound[t] {
                Bound::Free
            } else if s.x[t] <= lo {
                Bound::Lower
            } else {
                Bound::Upper
            };
        }
        Ok(s.iterations)
    }

    /// One primal–dual active-set iteration: solves for the free block
    /// with the fixed variables at their bounds, then updates `state` (see
    /// [`BoxQp`]) and appends every variable whose state changed to
    /// `changed`.
    fn pdas_step(
        &self,
        b: &[f64],
        (lo, hi, feas_tol): (f64, f64, f64),
        state: &mut [Bound],
        x: &mut [f64],
        factorizer: &mut SubsetFactorizer,
        changed: &mut Vec<usize>,
    ) -> Result<()> {
        let n = self.n();
        let mut free = vec![false; n];
        for i in 0..n {
            match state[i] {
                Bound::Free => free[i] = true,
                Bound::Lower => x[i] = lo,
                Bound::Upper => x[i] = hi,
            }
        }
        // rhs_F = −b_F − A_F,fixed x_fixed, row i of A read as column i
        // (A is symmetric).
        let (off, rows, vals) = (self.a.col_offsets(), self.a.row_indices(), self.a.values());
        let mut rhs = vec![0.0; n];
        for i in 0..n {
            if !free[i] {
                continue;
            }
            let mut r = -b[i];
            for p in off[i]..off[i + 1] {
                let j = rows[p];
                if !free[j] {
                    r -= vals[p] * x[j];
                }
            }
            rhs[i] = r;
        }
        factorizer.solve(&self.ordered, &free, &rhs, x)?;
        for i in 0..n {
            if free[i] && !x[i].is_finite() {
                return Err(Error::numerical(
                    "box QP: the free-block solve produced non-finite values",
                ));
            }
        }
        for i in 0..n {
            let next = match state[i] {
                Bound::Free if x[i] < lo - feas_tol => Bound::Lower,
                Bound::Free if x[i] > hi + feas_tol => Bound::Upper,
                Bound::Free => Bound::Free,
                s => {
                    let mut g = b[i];
                    for p in off[i]..off[i + 1] {
                        g += vals[p] * x[rows[p]];
                    }
                    match s {
                        Bound::Lower if g < -feas_tol * self.diag[i] => Bound::Free,
                        Bound::Upper if g > feas_tol * self.diag[i] => Bound::Free,
                        s => s,
                    }
                }
            };
            if next != state[i] {
                state[i] = next;
                changed.push(i);
            }
        }
        Ok(())
    }
}

/// `y += A x` for a sparse `A` (CSC; symmetric or not, `A x` column by column).
pub fn sym_matvec_add(a: &SparseMatrix, x: &[f64], y: &mut [f64]) {
    let (offsets, rows, vals) = (a.col_offsets(), a.row_indices(), a.values());
    for (j, &xj) in x.iter().enumerate().take(a.ncols()) {
        if xj == 0.0 {
            continue;
        }
        for p in offsets[j]..offsets[j + 1] {
            y[rows[p]] += vals[p] * xj;
        }
    }
}

/// Euclidean projection of `v` onto the probability simplex
/// `{x : x ≥ 0, Σ x = 1}` (sort-based, O(m log m)); `v` is overwritten.
/// Non-finite input gives the uniform vector.
pub fn project_to_simplex(v: &mut [f64]) {
    let m = v.len();
    if m == 0 {
        return;
    }
    if v.iter().any(|x| !x.is_finite()) {
        v.fill(1.0 / m as f64);
        return;
    }
    let mut u = v.to_vec();
    u.sort_unstable_by(|a, b| b.total_cmp(a));
    let mut cum = 0.0;
    let mut theta = 0.0;
    for (k, &uk) in u.iter().enumerate() {
        cum += uk;
        let t = (cum - 1.0) / (k + 1) as f64;
        if uk - t > 0.0 {
            theta = t;
        } else {
            break;
        }
    }
    for x in v.iter_mut() {
        *x = (*x - theta).max(0.0);
    }
}

/// Options of [`RowAdmm::solve`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdmmOptions {
    /// Maximum ADMM iterations.
    pub max_iter: usize,
    /// Stop when the duality gap (objective at the feasible `Z` minus a
    /// Lagrange dual bound, see [`AdmmSolution::duality_gap`]) is at most
    /// this (absolute, in objective units); checked every `adapt_every`
    /// iterations (every 25 if that is 0). `0` disables the check (and the
    /// factorisation of `A` it needs): exactly `max_iter` iterations run.
    pub gap_tol: f64,
    /// Initial penalty relative to `ρ₀ = median_i(A_ii / D_i)`.
    pub rho_scale: f64,
    /// Re-balance `ρ` (one numeric refactorisation) when the primal and dual
    /// residuals differ by more than this factor; checked every
    /// `adapt_every` iterations. `0` disables adaptation.
    pub adapt_every: usize,
}

impl Default for AdmmOptions {
    fn default() -> Self {
        AdmmOptions {
            max_iter: 5000,
            gap_tol: 1e-8,
            rho_scale: 1e-3,
            adapt_every: 25,
        }
    }
}

/// Result of [`RowAdmm::solve`].
#[derive(Clone, Debug)]
pub struct AdmmSolution {
    /// The feasible iterate `Z` (every row exactly in the feasible set).
    pub x: DMatrix<f64>,
    /// The last point that was projected, `X + U` (entries beyond a bound
    /// mark the bounds ADMM considers active; used to warm-start an
    /// active-set method).
    pub pre_projection: DMatrix<f64>,
    /// Iterations used.
    pub iterations: usize,
    /// Numeric factorisations used (1 + number of ρ updates).
    pub factorizations: usize,
    /// Final `max |X − Z|`.
    pub primal_residual: f64,
    /// Final `ρ · max |Z − Z_prev|·D_i/A_ii` (dual residual, weight units).
    pub dual_residual: f64,
    /// Certified suboptimality of `Z`: objective at `Z` minus the Lagrange
    /// dual bound at the multiplier `ρDU` (≥ 0; the objective of `Z` exceeds
    /// the optimum by at most this).
    pub duality_gap: f64,
    /// Whether both residuals reached the tolerance.
    pub converged: bool,
}

/// `min Σ_k ½ x_kᵀA x_k + b_kᵀx_k` over `X` (n × m) with every row on the
/// probability simplex, `A` sparse symmetric positive definite, by ADMM with
/// the splitting `X = Z` in the `D`-weighted norm (`D` a positive diagonal):
///
/// ```text
/// X ← (A + ρD)⁻¹ (ρD(Z − U) − B)      one factorisation for all columns
/// Z ← rows of X + U projected onto the simplex
/// U ← U + X − Z
/// ```
///
/// Because `D` is diagonal, the `D`-weighted projection of a row is the
/// plain Euclidean one.
#[derive(Clone, Debug)]
pub struct RowAdmm {
    a: SparseMatrix,
    d: Vec<f64>,
    symbolic: SymbolicCholesky,
    rho0: f64,
    constraint: RowConstraint,
    diag_a: Vec<f64>,
}

/// Feasible set of each row of `X` in [`RowAdmm`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowConstraint {
    /// The probability simplex `x ≥ 0, Σ x = 1`.
    Simplex,
    /// The box `lo ≤ x ≤ hi` (entries independent: the columns are then
    /// separate bound-constrained QPs sharing one factorisation).
    Box(f64, f64),
}

impl RowConstraint {
    fn project(&self, row: &mut [f64]) {
        match *self {
            RowConstraint::Simplex => project_to_simplex(row),
            RowConstraint::Box(lo, hi) => {
                for v in row {
                    *v = v.clamp(lo, hi);
                }
            }
        }
    }

    /// Projects every row of `x`.
    pub fn project_rows(&self, x: &mut DMatrix<f64>) {
        let m = x.ncols();
        let mut row = vec![0.0; m];
        for i in 0..x.nrows() {
            for k in 0..m {
                row[k] = x[(i, k)];
            }
            self.project(&mut row);
            for k in 0..m {
                x[(i, k)] = row[k];
            }
        }
    }
}

impl RowAdmm {
    /// Analyses `a` (symmetric, every diagonal entry stored) with metric
    /// diagonal `d` (positive).
    pub fn new(a: &SparseMatrix, d: &[f64], constraint: RowConstraint) -> Result<Self> {
        if let RowConstraint::Box(lo, hi) = constraint {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(Error::invalid(format!(
                    "ADMM box bounds must be finite with lo < hi, got [{lo}, {hi}]"
                )));
            }
        }
        let n = a.nrows();
        if d.len() != n || d.iter().any(|&v| !(v > 0.0 && v.is_finite())) {
            return Err(Error::invalid(format!(
                "ADMM metric must be {n} positive finite values"
            )));
        }
        let symbolic = SymbolicCholesky::new(a)?;
        let mut diag_a = vec![0.0; n];
        for (i, j, &v) in a.triplet_iter() {
            if i == j {
                diag_a[i] = v;
            }
        }
        let mut ratio: Vec<f64> = diag_a.iter().zip(d).map(|(a, d)| a / d).collect();
        ratio.sort_unstable_by(f64::total_cmp);
        let rho0 = ratio[n / 2];
        if !(rho0.is_finite() && rho0 > 0.0) {
            return Err(Error::invalid(
                "ADMM matrix needs a positive stored diagonal",
            ));
        }
        Ok(RowAdmm {
            a: a.clone(),
            d: d.to_vec(),
            symbolic,
            rho0,
            constraint,
            diag_a,
        })
    }

    /// The symbolic factorisation of `A`'s pattern.
    pub fn symbolic(&self) -> &SymbolicCholesky {
        &self.symbolic
    }

    /// Objective `Σ_k ½ z_kᵀA z_k + b_kᵀz_k`.
    pub fn objective(&self, z: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
        let mut e = 0.0;
        for k in 0..z.ncols() {
            let zk: Vec<f64> = z.column(k).iter().copied().collect();
            let mut az = vec![0.0; zk.len()];
            sym_matvec_add(&self.a, &zk, &mut az);
            for i in 0..zk.len() {
                e += zk[i] * (0.5 * az[i] + b[(i, k)]);
            }
        }
        e
    }

    /// Lagrange dual function at multiplier `lambda` (for `X = Z`):
    /// `−½ Σ_k (b_k + λ_k)ᵀA⁻¹(b_k + λ_k) + Σ_i min_{z ∈ C} (−λ_iᵀz)`, a
    /// lower bound of the optimal objective.
    fn dual_bound(
        &self,
        fac_a: &SparseCholesky,
        lambda: &DMatrix<f64>,
        b: &DMatrix<f64>,
    ) -> Result<f64> {
        let r = b + lambda;
        let x = fac_a.try_solve(&r)?;
        let mut d = -0.5 * r.dot(&x);
        for i in 0..lambda.nrows() {
            match self.constraint {
                RowConstraint::Simplex => {
                    d -= lambda.row(i).max();
                }
                RowConstraint::Box(lo, hi) => {
                    for &l in lambda.row(i).iter() {
                        d += (-l * lo).min(-l * hi);
                    }
                }
            }
        }
        Ok(d)
    }

    fn factor(&self, rho: f64) -> Result<SparseCholesky> {
        let mut s = self.a.clone();
        let (offsets, rows) = (self.a.col_offsets().to_vec(), self.a.row_indices().to_vec());
        let vals = s.values_mut();
        for j in 0..self.d.len() {
            for p in offsets[j]..offsets[j + 1] {
                if rows[p] == j {
                    vals[p] += rho * self.d[j];
                }
            }
        }
        self.symbolic.factorize(&s)
    }

    /// Solves for linear terms `b` (n × m) from a starting point `x0` (n × m;
    /// projected onto the constraints first). Returns the feasible iterate
    /// even when `max_iter` is reached (see [`AdmmSolution::converged`]).
    pub fn solve(
        &self,
        b: &DMatrix<f64>,
        x0: &DMatrix<f64>,
        opts: &AdmmOptions,
    ) -> Result<AdmmSolution> {
        let n = self.d.len();
        let m = b.ncols();
        if b.nrows() != n || x0.shape() != (n, m) || m == 0 {
            return Err(Error::invalid(format!(
                "ADMM of dimension {n}: b is {}×{}, x0 is {}×{}",
                b.nrows(),
                b.ncols(),
                x0.nrows(),
                x0.ncols()
            )));
        }
        if !(opts.gap_tol >= 0.0 && opts.rho_scale > 0.0) {
            return Err(Error::invalid("ADMM needs gap_tol ≥ 0 and rho_scale > 0"));
        }
        let mut rho = self.rho0 * opts.rho_scale;
        let mut fac = self.factor(rho)?;
        let mut factorizations = 1;
        let mut z = x0.clone();
        self.constraint.project_rows(&mut z);
        let mut u = DMatrix::<f64>::zeros(n, m);
        let mut x = z.clone();
        let mut row = vec![0.0; m];
        let mut pre = DMatrix::<f64>::zeros(n, m);
        let (mut rp, mut rd) = (f64::INFINITY, f64::INFINITY);
        let mut last_gap = f64::INFINITY;
        // The dual bound needs A⁻¹; gap_tol = 0 runs max_iter iterations
        // without gap checks (e.g. as a warm start).
        let fac_a = if opts.gap_tol > 0.0 {
            factorizations += 1;
            Some(self.symbolic.factorize(&self.a)?)
        } else {
            None
        };
        for it in 1..=opts.max_iter.max(1) {
            // X-step.
            for k in 0..m {
                for i in 0..n {
                    x[(i, k)] = rho * self.d[i] * (z[(i, k)] - u[(i, k)]) - b[(i, k)];
                }
            }
            // Columns are independent: solved in fixed blocks of
            // ADMM_COLUMN_BLOCK columns, the blocks in parallel (the blocks
            // do not depend on the thread count, so neither does X).
            x.as_mut_slice()
                .par_chunks_mut(n * ADMM_COLUMN_BLOCK)
                .try_for_each(|cols| fac.solve_in_place(cols, cols.len() / n))?;
            // Z-step and U-step.
            rp = 0.0;
            rd = 0.0;
            for i in 0..n {
                for k in 0..m {
                    row[k] = x[(i, k)] + u[(i, k)];
                    pre[(i, k)] = row[k];
                }
                self.constraint.project(&mut row);
                for k in 0..m {
                    rd = rd.max((row[k] - z[(i, k)]).abs() * self.d[i] / self.diag_a[i]);
                    z[(i, k)] = row[k];
                    let r = x[(i, k)] - row[k];
                    rp = rp.max(r.abs());
                    u[(i, k)] += r;
                }
            }
            rd *= rho;
            let check = if opts.adapt_every == 0 {
                25
            } else {
                opts.adapt_every
            };
            if let Some(fac_a) = fac_a
                .as_ref()
                .filter(|_| it % check == 0 || it == opts.max_iter)
            {
                let primal = self.objective(&z, b);
                let mut lambda = u.clone();
                for i in 0..n {
                    let s = rho * self.d[i];
                    for k in 0..m {
                        lambda[(i, k)] *= s;
                    }
                }
                let gap = primal - self.dual_bound(fac_a, &lambda, b)?;
                if gap <= opts.gap_tol {
                    return Ok(AdmmSolution {
                        x: z,
                        pre_projection: pre,
                        iterations: it,
                        factorizations,
                        primal_residual: rp,
                        dual_residual: rd,
                        duality_gap: gap,
                        converged: true,
                    });
                }
                last_gap = gap;
            }
            if opts.adapt_every > 0 && it % opts.adapt_every == 0 {
                // Residual balancing: ρ up when primal lags, down when dual
                // lags; U is scaled so that the unscaled multiplier ρU stays.
                let factor = if rp > 10.0 * rd {
                    2.0
                } else if rd > 10.0 * rp {
                    0.5
                } else {
                    1.0
                };
                if factor != 1.0 {
                    rho *= factor;
                    u /= factor;
                    fac = self.factor(rho)?;
                    factorizations += 1;
                }
            }
        }
        Ok(AdmmSolution {
            x: z,
            pre_projection: pre,
            iterations: opts.max_iter.max(1),
            factorizations,
            primal_residual: rp,
            dual_residual: rd,
            duality_gap: last_gap,
            converged: false,
        })
    }
}

/// Result of [`simplex_rows_qp`].
#[derive(Clone, Debug)]
pub struct SimplexQpSolution {
    /// The minimiser (every row exactly on the simplex).
    pub x: DMatrix<f64>,
    /// Global support iterations (each a factorisation of the whole
    /// reduced system).
    pub iterations: usize,
    /// Iterations of local refinement (`local_hops`), each a factorisation
    /// of the reduced system of a small region of rows.
    pub local_iterations: usize,
    /// Size of the last reduced system.
    pub n_variables: usize,
    /// Whether the supports settled within the iteration limit (if not, `x`
    /// is the last iterate projected onto the simplex row by row).
    pub converged: bool,
    /// KKT residual of `x` in units of `x` (scale-free, per row `i`): with
    /// `G = A X + B` and `ν_i = G_ip` at the row's largest entry `p`, the
    /// largest `|G_ik − ν_i| / A_ii` over `k` with `X_ik > 0` and the largest
    /// `(ν_i − G_ik)⁺ / A_ii` over `k` with `X_ik = 0`; 0 at the optimum.
    pub kkt_residual: f64,
}

/// `G = A X + B`, column by column.
fn gradient_matrix(a: &SparseMatrix, x: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let n = x.nrows();
    let mut g = b.clone();
    g.as_mut_slice()
        .par_chunks_mut(n.max(1))
        .zip(x.as_slice().par_chunks(n.max(1)))
        .for_each(|(gk, xk)| sym_matvec_add(a, xk, gk));
    g
}

/// KKT residual of a row-stochastic `x` for the simplex-rows QP (see
/// [`SimplexQpSolution::kkt_residual`]).
pub fn simplex_rows_kkt_residual(a: &SparseMatrix, b: &DMatrix<f64>, x: &DMatrix<f64>) -> f64 {
    let g = gradient_matrix(a, x, b);
    let mut diag = vec![0.0; a.nrows()];
    for (i, j, &v) in a.triplet_iter() {
        if i == j {
            diag[i] = v;
        }
    }
    let m = x.ncols();
    let mut r = 0.0f64;
    for i in 0..x.nrows() {
        let p = (0..m)
            .max_by(|&p, &q| x[(i, p)].total_cmp(&x[(i, q)]).then(q.cmp(&p)))
            .unwrap_or(0);
        let nu = g[(i, p)];
        for k in 0..m {
            let d = (g[(i, k)] - nu) / diag[i];
            r = r.max(if x[(i, k)] > 0.0 {
                d.abs()
            } else {
                (-d).max(0.0)
            });
        }
    }
    r
}

/// Iterate of [`simplex_rows_qp`]: supports, pivots and the values.
struct SimplexState {
    /// `support[i*m + k]`: `k ∈ S_i`.
    support: Vec<bool>,
    pivot: Vec<usize>,
    x: DMatrix<f64>,
    /// Unknowns of row i: `var_start[i] .. var_start[i] + handles[i].len()`.
    handles: Vec<Vec<usize>>,
    var_start: Vec<usize>,
    /// The reduced matrix and its factor's buffers, kept between
    /// iterations (allocations of this size fault in fresh pages).
    matrix: UpperCsc,
    bufs: FactorBuffers,
}

/// Marks in `region` the variables (rows) within `hops` steps of `A`'s
/// graph of `seeds` (clearing it first); `false` if that is more than half
/// of all (local refinement would then cost about a global iteration).
fn grow_region(a: &SparseMatrix, hops: usize, seeds: &[usize], region: &mut [bool]) -> bool {
    let n = a.nrows();
    region.fill(false);
    let (off, rows) = (a.col_offsets(), a.row_indices());
    let mut count = 0;
    let mut front = Vec::with_capacity(seeds.len());
    for &i in seeds {
        if !region[i] {
            region[i] = true;
            count += 1;
            front.push(i);
        }
    }
    let mut next = Vec::new();
    for _ in 0..hops {
        next.clear();
        for &j in &front {
            for &i in &rows[off[j]..off[j + 1]] {
                if !region[i] {
                    region[i] = true;
                    count += 1;
                    next.push(i);
                }
            }
        }
        if 2 * count > n {
            return false;
        }
        std::mem::swap(&mut front, &mut next);
    }
    2 * count <= n
}

/// Row `i` of `G = A X + B` into `g` (`A` symmetric: row `i` read as
/// column `i`).
fn gradient_row(a: &SparseMatrix, b: &DMatrix<f64>, x: &DMatrix<f64>, i: usize, g: &mut [f64]) {
    let (off, rows, vals) = (a.col_offsets(), a.row_indices(), a.values());
    for (k, gk) in g.iter_mut().enumerate() {
        *gk = b[(i, k)];
    }
    for p in off[i]..off[i + 1] {
        let j = rows[p];
        for (k, gk) in g.iter_mut().enumerate() {
            *gk += vals[p] * x[(j, k)];
        }
    }
}

/// One support iteration of [`simplex_rows_qp`]: global (`region = None`)
/// or on the rows inside `region` with every other row frozen at its
/// current values. Solves the reduced system for the current supports,
/// updates the supports of the rows concerned and appends every row whose
/// support changed to `changed`. Returns the number of unknowns.
#[allow(clippy::too_many_arguments)]
fn simplex_step(
    a: &SparseMatrix,
    b: &DMatrix<f64>,
    ordered: &Ordered,
    diag: &[f64],
    tol: f64,
    st: &mut SimplexState,
    region: Option<&[bool]>,
    changed: &mut Vec<usize>,
) -> Result<usize> {
    let n = a.nrows();
    let m = b.ncols();
    let inside = |i: usize| region.is_none_or(|r| r[i]);
    let u = &ordered.upper;
    let SimplexState {
        support,
        pivot,
        x,
        handles,
        var_start,
        matrix: h,
        bufs,
    } = st;
    let mut nv = 0;
    for &i in &ordered.order {
        if !inside(i) {
            handles[i].clear();
            continue;
        }
        if pivot[i] == usize::MAX || !support[i * m + pivot[i]] {
            pivot[i] = (0..m)
                .filter(|&k| support[i * m + k])
                .max_by(|&p, &q| x[(i, p)].total_cmp(&x[(i, q)]).then(q.cmp(&p)))
                .unwrap_or(0);
        }
        let hs = &mut handles[i];
        hs.clear();
        hs.extend((0..m).filter(|&k| k != pivot[i] && support[i * m + k]));
        var_start[i] = nv;
        nv += hs.len();
    }
    // Rows inside: the pivot indicator C; outside: frozen values.
    for i in 0..n {
        if inside(i) {
            for k in 0..m {
                x[(i, k)] = 0.0;
            }
            x[(i, pivot[i])] = 1.0;
        }
    }
    if nv > 0 {
        // rhs = −(G0_ik − G0_ip) with G0 = A X + B at this X (rows inside
        // only; A symmetric, so row i is read as column i).
        let mut g0row = vec![0.0; m];
        let mut rhs = vec![0.0; nv];
        for i in 0..n {
            if handles[i].is_empty() {
                continue;
            }
            gradient_row(a, b, x, i, &mut g0row);
            for (t, &k) in handles[i].iter().enumerate() {
                rhs[var_start[i] + t] = -(g0row[k] - g0row[pivot[i]]);
            }
        }
        // Upper triangle, column (j, l): rows (i, k) for neighbours i
        // earlier in the order, and (j, k ≤ l).
        h.reset(nv);
        for (pj, &j) in ordered.order.iter().enumerate() {
            let pvj = pivot[j];
            for (tl, &l) in handles[j].iter().enumerate() {
                for e in u.col_ptr[pj]..u.col_ptr[pj + 1] {
                    let i = ordered.order[u.row_idx[e]];
                    let aij = u.values[e];
                    let pvi = pivot[i];
                    let hi_ = &handles[i];
                    let last = if i == j { tl + 1 } else { hi_.len() };
                    for (tk, &k) in hi_[..last].iter().enumerate() {
                        let c = (k == l) as i32 - (k == pvj) as i32 - (pvi == l) as i32
                            + (pvi == pvj) as i32;
                        if c != 0 {
                            h.push(var_start[i] + tk, aij * c as f64);
                        }
                    }
                }
                h.end_column();
            }
        }
        let fac = OrderedCholesky::factorize_with(h, bufs)?;
        fac.solve_in_place_with(&mut rhs, 1, &mut bufs.scratch);
        fac.recycle(bufs);
        if rhs.iter().any(|v| !v.is_finite()) {
            return Err(Error::numerical(
                "simplex-rows QP: the reduced solve produced non-finite values",
            ));
        }
        for i in 0..n {
            for (t, &k) in handles[i].iter().enumerate() {
                let v = rhs[var_start[i] + t];
                x[(i, k)] = v;
                x[(i, pivot[i])] -= v;
            }
        }
    }
    // Gradient and support update (rows inside).
    let mut g = vec![0.0; m];
    for i in 0..n {
        if !inside(i) {
            continue;
        }
        gradient_row(a, b, x, i, &mut g);
        let gp = g[pivot[i]];
        let mut row_changed = false;
        for k in 0..m {
            let s = &mut support[i * m + k];
            if *s && x[(i, k)] < -tol {
                *s = false;
                row_changed = true;
            } else if !*s && g[k] - gp < -tol * diag[i] {
                *s = true;
                row_changed = true;
            }
        }
        if !(0..m).any(|k| support[i * m + k]) {
            // Every support entry was negative (cannot happen for a row
            // summing to one); keep the largest.
            let k = (0..m)
                .max_by(|&p, &q| x[(i, p)].total_cmp(&x[(i, q)]).then(q.cmp(&p)))
                .unwrap_or(0);
            support[i * m + k] = true;
        }
        if row_changed {
            changed.push(i);
        }
    }
    Ok(nv)
}

/// `min Σ_k ½ x_kᵀA x_k + b_kᵀx_k` over `X` (n × m) with every row on the
/// probability simplex (`X ≥ 0`, rows sum to one), `A` sparse symmetric
/// positive definite, by a primal–dual active-set method on the row
/// supports `S_i = {k : X_ik > 0}`.
///
/// For fixed supports, each row's partition of unity is eliminated by
/// writing one support entry (the pivot `p(i)`: the row's largest entry when
/// it was chosen, kept while it stays in the support) as one
/// minus the others; the remaining `Σ_i (|S_i| − 1)` unknowns solve one
/// sparse SPD system `Eᵀ(I ⊗ A)E v = −Eᵀ(A C + B)`. Its unknowns are
/// numbered row by row in one AMD ordering of `A` computed once (so each
/// row's unknowns form a block and no iteration pays for an ordering), and
/// its upper triangle is assembled directly in that order. Then entries below
/// `−tol` leave their support, and a column `k ∉ S_i` joins it when its
/// multiplier `G_ik − G_ip(i)` (`G = A X + B`, the cost of moving weight from
/// the pivot to `k`) is below `−tol · A_ii`. When the supports no longer
/// change the KKT conditions hold to `tol` (per-row, scale-free) and the
/// result is the optimum; entries in `[−tol, 0)` are set to 0 and the row
/// rescaled. If `max_iter` is reached first, the last iterate is projected
/// onto the simplex row by row and returned with `converged = false`.
///
/// `x0` (n × m) seeds the supports (`x0_ik > 0`; the largest entry if none).
pub fn simplex_rows_qp(
    a: &SparseMatrix,
    b: &DMatrix<f64>,
    x0: &DMatrix<f64>,
    max_iter: usize,
    tol: f64,
    local_hops: usize,
) -> Result<SimplexQpSolution> {
    let n = a.nrows();
    let m = b.ncols();
    if a.ncols() != n || b.nrows() != n || x0.shape() != (n, m) || m == 0 {
        return Err(Error::invalid(format!(
            "simplex-rows QP: A is {}×{}, b is {}×{}, x0 is {}×{}",
            a.nrows(),
            a.ncols(),
            b.nrows(),
            b.ncols(),
            x0.nrows(),
            x0.ncols()
        )));
    }
    let diag = check_spd_candidate(a, "simplex-rows QP")?;
    let ordered = Ordered::new(a)?;
    // support[i*m + k]
    let mut support = vec![false; n * m];
    for i in 0..n {
        let mut any = false;
        for k in 0..m {
            if x0[(i, k)] > 0.0 {
                support[i * m + k] = true;
                any = true;
            }
        }
        if !any {
            let k = (0..m)
                .max_by(|&p, &q| x0[(i, p)].total_cmp(&x0[(i, q)]).then(q.cmp(&p)))
                .unwrap_or(0);
            support[i * m + k] = true;
        }
    }
    // Pivot of each row: its largest support entry (first x0, then the
    // last iterate); kept while it stays in the support.
    let mut st = SimplexState {
        support,
        pivot: vec![usize::MAX; n],
        x: x0.clone(),
        handles: vec![Vec::new(); n],
        var_start: vec![0usize; n],
        matrix: UpperCsc::default(),
        bufs: FactorBuffers::default(),
    };
    let mut nv = 0;
    let mut converged = false;
    let mut iterations = 0;
    let mut changed = Vec::new();
    let mut region = vec![false; n];
    let mut local_iterations = 0;
    for it in 1..=max_iter.max(1) {
        iterations = it;
        super::progress::update(
            "bounded biharmonic weights (partition of unity): support iteration",
            it,
            0,
        );
        changed.clear();
        nv = simplex_step(a, b, &ordered, &diag, tol, &mut st, None, &mut changed)?;
        if changed.is_empty() {
            converged = true;
            break;
        }
        if local_hops > 0 && grow_region(a, local_hops, &changed, &mut region) {
            for _ in 0..LOCAL_MAX_ITER {
                local_iterations += 1;
                changed.clear();
                simplex_step(
                    a,
                    b,
                    &ordered,
                    &diag,
                    tol,
                    &mut st,
                    Some(&region),
                    &mut changed,
                )?;
                if changed.is_empty() {
                    break;
                }
            }
        }
    }
    let mut x = st.x;
    let mut row = vec![0.0; m];
    for i in 0..n {
        if converged {
            let mut sum = 0.0;
            for k in 0..m {
                let v = x[(i, k)].max(0.0);
                x[(i, k)] = v;
                sum += v;
            }
            for k in 0..m {
                x[(i, k)] /= sum;
            }
        } else {
            for k in 0..m {
                row[k] = x[(i, k)];
            }
            project_to_simplex(&mut row);
            for k in 0..m {
                x[(i, k)] = row[k];
            }
        }
    }
    let kkt_residual = simplex_rows_kkt_residual(a, b, &x);
    Ok(SimplexQpSolution {
        x,
        iterations,
        local_iterations,
        n_variables: nv,
        converged,
        kkt_residual,
    })
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

    fn tridiag(n: usize) -> SparseMatrix {
        let mut t = Vec::new();
        for i in 0..n {
            t.push((i, i, 2.0));
            if i + 1 < n {
                t.push((i, i + 1, -1.0));
                t.push((i + 1, i, -1.0));
            }
        }
        sparse_from_triplets(n, n, t)
    }

    #[test]
    fn simplex_projection() {
        let mut v = [0.5, 0.5];
        project_to_simplex(&mut v);
        assert_eq!(v, [0.5, 0.5]);
        let mut v = [2.0, 0.0, -1.0];
        project_to_simplex(&mut v);
        assert_eq!(v, [1.0, 0.0, 0.0]);
        let mut v = [0.3, 0.3, 0.3];
        project_to_simplex(&mut v);
        assert!(v.iter().all(|&x| (x - 1.0 / 3.0).abs() < 1e-15));
    }

    #[test]
    fn box_qp_matches_clamped_1d_solution() {
        // min ½xᵀTx − 3·1ᵀx on [0, 1]: the unconstrained optimum exceeds 1 in
        // the middle.
        let n = 9;
        let qp = BoxQp::new(&tridiag(n)).unwrap();
        let b = vec![-3.0; n];
        let s = qp.solve(&b, 0.0, 1.0, None, 50, 1e-10).unwrap();
        assert!(s.x.iter().all(|&v| (0.0..=1.0).contains(&v)));
        // KKT: gradient ≥ 0 at lower, ≤ 0 at upper, 0 in between.
        let g = qp.gradient(&s.x, &b);
        for (&x, &gi) in s.x.iter().zip(&g) {
            if x <= 0.0 {
                assert!(gi >= -1e-9);
            } else if x >= 1.0 {
                assert!(gi <= 1e-9);
            } else {
                assert!(gi.abs() < 1e-9, "{x} {gi}");
            }
        }
    }
}

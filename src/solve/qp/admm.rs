//! [`RowAdmm`]: `min Σ_k ½ x_kᵀA x_k + b_kᵀx_k` with every row of `X` on the
//! probability simplex or in a box ([`RowConstraint`]), by ADMM with one
//! factorisation of `A + ρD` shared by all columns and iterations.

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::common::{project_to_simplex, sym_matvec_add};
use crate::solve::{SparseCholesky, SparseMatrix, SymbolicCholesky};
use crate::{Error, Result};

/// [`RowAdmm`] solves its right-hand sides in blocks of this many columns,
/// the blocks in parallel (multi-column solves are cheaper per column; the
/// fixed block size keeps results independent of the thread count).
pub const ADMM_COLUMN_BLOCK: usize = 4;

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

//! Smallest generalised eigenpairs of a symmetric pencil `(L, M)` with `L`
//! symmetric positive semi-definite and `M` diagonal positive: the
//! Laplace–Beltrami eigenproblem `L φ = λ M φ`.
//!
//! **Method.** Shift-invert *block* Krylov (block Lanczos with full
//! reorthogonalisation and thick restarts, written here) on the symmetric
//! operator `A = s · M^{½} (L + sM)^{-1} M^{½}`, whose largest eigenvalues
//! `s / (λ + s)` belong to the smallest `λ`; `L + sM` is factorised once with
//! [`SparseCholesky`](crate::solve::SparseCholesky) (faer's automatic choice
//! of the simplicial or supernodal variant) and applied to whole blocks.
//! Forcing the supernodal variant, as an earlier version did for its
//! dense-block solves, made the solves slower where the automatic choice is
//! simplicial (6-column solves, one thread: FAUST 6.9k 1.35 → 0.58 ms,
//! synthetic 27k 7.8 → 4.1 ms; at 108k both choices are supernodal). The
//! shift `−s` is negative because `L` is singular on closed meshes. The converged Ritz vectors
//! (`φ = M^{-½} u`) are then refined by a few steps of subspace iteration with
//! Rayleigh–Ritz on `(L, M)` themselves, which removes the rounding noise of
//! the Krylov basis (its operator-space residuals are floored at
//! `eps · cond(L + sM) / θ`).
//!
//! *Why not faer's `partial_self_adjoint_eigen`:* it is a single-vector
//! Lanczos (Krylov–Schur). A single start vector sees one direction of each
//! exactly repeated eigenvalue; further members appear only through rounding
//! noise. Measured here: with its default subspace it skipped cluster members
//! of the sphere spectrum (50k vertices) and returned duplicated vectors; with
//! `max_dim = 150`, asking for 50 pairs of a 2 562-vertex sphere, the inertia
//! check below still found a skipped eigenvalue. A random start *block* of `b`
//! vectors resolves multiplicities up to `b` by construction.
//!
//! **Verification (always).** Every result is checked:
//!
//! 1. residuals `‖Lφ − λMφ‖_{M⁻¹} / (max(λ, λ_scale) ‖φ‖_M) ≤ residual_tol`
//!    (a bound on the relative eigenvalue error);
//! 2. M-orthonormality `max |ΦᵀMΦ − I| ≤ orthonormality_tol` (duplicated
//!    vectors fail this);
//! 3. completeness by Sylvester's law of inertia: an LDLᵀ of `L − σM`, with
//!    `σ` just below the largest returned eigenvalue, must have exactly as many
//!    negative pivots as there are returned eigenvalues below `σ`. A skipped
//!    cluster member makes the count larger.
//!
//! The LDLᵀ reuses the symbolic analysis (ordering, elimination tree) of
//! `L + sM`, which has the same pattern.
//!
//! **Cost.** The dense work (Gram–Schmidt against the basis, Rayleigh–Ritz,
//! restarts, refinement) runs with faer's blocked products, QR and symmetric
//! eigensolver, sequentially, on `n × d` buffers allocated once per solve;
//! convergence is screened with the block-Lanczos residual estimate before
//! explicit residuals are formed (see `block_krylov`); between restarts the
//! Rayleigh–Ritz step that gives the estimate is skipped while the estimate,
//! extrapolated from its last two values, is still far from the tolerance.
//!
//! If a check fails the solve is repeated with a twice larger block and
//! subspace and another random start; after `max_attempts` it returns
//! [`Error::Numerical`] saying which check failed.
//!
//! Small problems (`n ≤ DENSE_MAX`, or a subspace as large as `n`) are solved
//! densely with nalgebra's symmetric eigensolver and verified the same way.
//!
//! **Signs.** Every returned eigenvector has a canonical sign that depends
//! only on the vector (and the masses), not on the random start, the block
//! size, the path (dense or Krylov) or rounding: see
//! [`canonicalize_signs`]. Within the eigenspace of a repeated eigenvalue the
//! returned basis is still arbitrary.
//!
//! Layout: this file holds the options, the result type and the driver
//! ([`generalized_eigen`], with the dense path); `krylov` the shift-invert
//! operator and the block Krylov iteration; `verify` the refinement and the
//! checks in the original pencil; `signs` the canonical signs
//! ([`canonicalize_signs`]); `kernels` the dense and sparse products on
//! column-major buffers.

mod kernels;
mod krylov;
mod signs;
mod verify;

use nalgebra::DMatrix;

use self::krylov::{block_krylov, ShiftInvert};
use self::verify::Context;
use crate::solve::{sparse_from_triplets, SparseMatrix, SymbolicCholesky};
use crate::{Error, Result};

pub use self::signs::canonicalize_signs;

/// Default block size. Smaller blocks need fewer solves in all (single-vector
/// Lanczos, ARPACK's, is the limit) but more, narrower steps; with
/// Rayleigh–Ritz skipped between restarts (`RR_SKIP_MARGIN`) the steps are
/// cheap. Measured when this default was chosen (before the refinement
/// reused the Krylov images; FAUST `tr_reg_001`, 6 890 vertices, 1 thread,
/// medians; max_dim, block → seconds): k = 20: (100, 8) 0.094, (60, 8) 0.100,
/// (60, 6) 0.073, (60, 4) 0.072; k = 100: (300, 25) 0.59, (250, 8) 0.44,
/// (300, 6) 0.45, (200, 6) 0.56. At 28k (TOSCA cat0) k = 20 / 100: 0.54 /
/// 2.77 s → 0.48 / 2.25 s; at 108k: 2.33 / 11.9 s → 2.08 / 9.5 s (old →
/// new defaults). 6 rather than 4 keeps clusters of up to 6 (the sphere's
/// l ≤ 2, tori, cylinders) on the first attempt.
const DEFAULT_BLOCK: usize = 6;

/// Problems up to this size are solved with a dense eigensolver.
pub const DENSE_MAX: usize = 400;

/// Settings of [`generalized_eigen`].
#[derive(Clone, Debug)]
pub struct EigenOptions {
    /// `s > 0` in the shift-invert operator `(L + sM)^{-1}`; `None` picks
    /// `0.2 · Σ L_ii / (n Σ M_ii)` (≈ 0.03 × the first non-zero eigenvalue
    /// on a sphere). Smaller shifts converge marginally faster but the
    /// accuracy floor of the solves grows like `1/s²`.
    pub shift: Option<f64>,
    /// Largest Krylov basis before a thick restart; `0` picks
    /// `max(60, 3k)` (see `DEFAULT_BLOCK` for the measurements).
    pub max_dim: usize,
    /// Block size `b` (number of random start vectors); eigenvalues of
    /// multiplicity up to `b` are resolved reliably. `0` picks
    /// `DEFAULT_BLOCK` = 6 (a cluster larger than `b` is caught by the
    /// inertia check and retried with `2b`).
    pub block_size: usize,
    /// Screening tolerance: once all Ritz pairs of the shift-invert operator
    /// have `‖A u − θ u‖ ≤ lanczos_tol · θ`, the true residuals of `(L, M)`
    /// are refined until below `residual_tol / 4`.
    pub lanczos_tol: f64,
    /// Maximum accepted relative residual (see module docs).
    pub residual_tol: f64,
    /// Maximum accepted `max |ΦᵀMΦ − I|`.
    pub orthonormality_tol: f64,
    /// Run the inertia (completeness) check.
    pub check_inertia: bool,
    /// Attempts (each doubles the subspace) before giving up.
    pub max_attempts: usize,
    /// Seed of the random Lanczos start vector.
    pub seed: u64,
}

impl Default for EigenOptions {
    fn default() -> Self {
        EigenOptions {
            shift: None,
            max_dim: 0,
            block_size: 0,
            lanczos_tol: 1e-7,
            residual_tol: 1e-6,
            orthonormality_tol: 1e-9,
            check_inertia: true,
            max_attempts: 3,
            seed: 0x5eed,
        }
    }
}

/// Eigenpairs sorted by ascending eigenvalue.
#[derive(Clone, Debug)]
pub struct Eigenpairs {
    /// Eigenvalues `λ_0 ≤ λ_1 ≤ …` (Rayleigh quotients).
    pub values: Vec<f64>,
    /// `n × k`, column `i` is `φ_i`, M-orthonormal (`ΦᵀMΦ = I`).
    pub vectors: DMatrix<f64>,
    /// Largest relative residual found by the verification.
    pub max_residual: f64,
    /// `max |ΦᵀMΦ − I|`.
    pub orthonormality_error: f64,
    /// Krylov subspace size of the accepted attempt (0 for the dense path).
    pub subspace_dim: usize,
    /// Attempts used.
    pub attempts: usize,
}

/// The diagonal of a sparse mass matrix; errors if it has off-diagonal
/// entries (only lumped masses are supported).
pub fn mass_diagonal(m: &SparseMatrix) -> Result<Vec<f64>> {
    if m.nrows() != m.ncols() {
        return Err(Error::invalid(format!(
            "mass matrix must be square, got {}x{}",
            m.nrows(),
            m.ncols()
        )));
    }
    let mut d = vec![0.0; m.nrows()];
    for (i, j, &v) in m.triplet_iter() {
        if i != j {
            if v != 0.0 {
                return Err(Error::invalid(format!(
                    "mass matrix has an off-diagonal entry ({i}, {j}); only diagonal (lumped) masses are supported"
                )));
            }
        } else {
            d[i] = v;
        }
    }
    Ok(d)
}

/// The `k` smallest eigenpairs of `L φ = λ M φ` (`L` symmetric positive
/// semi-definite, `M = diag(m)` positive), `1 ≤ k ≤ min(100, n)` is advised
/// (larger `k` works but costs a subspace of `3k` vectors). Verified as
/// described in the module docs; errors rather than returning unverified
/// pairs.
pub fn generalized_eigen(
    l: &SparseMatrix,
    m: &[f64],
    k: usize,
    opts: &EigenOptions,
) -> Result<Eigenpairs> {
    let n = l.nrows();
    if l.ncols() != n || m.len() != n {
        return Err(Error::invalid(format!(
            "eigenproblem needs a square L and one mass per row: L is {}x{}, mass has {} entries",
            l.nrows(),
            l.ncols(),
            m.len()
        )));
    }
    if k == 0 || k > n {
        return Err(Error::invalid(format!(
            "asked for {k} eigenpairs of a {n}x{n} problem"
        )));
    }
    if let Some(i) = m.iter().position(|&x| !(x.is_finite() && x > 0.0)) {
        return Err(Error::invalid(format!(
            "mass of row {i} is {} (must be positive and finite; unreferenced vertex?)",
            m[i]
        )));
    }
    let diag_l: Vec<f64> = (0..n)
        .map(|i| l.get_entry(i, i).map(|e| e.into_value()).unwrap_or(0.0))
        .collect();
    let lambda_scale = diag_l.iter().sum::<f64>() / (n as f64 * m.iter().sum::<f64>());
    if !(lambda_scale.is_finite() && lambda_scale > 0.0) {
        return Err(Error::invalid(
            "L has a non-positive or non-finite trace; expected a positive semi-definite Laplacian",
        ));
    }
    let shift = opts.shift.unwrap_or(0.2 * lambda_scale);
    if !(shift.is_finite() && shift > 0.0) {
        return Err(Error::invalid(format!(
            "shift must be positive, got {shift}"
        )));
    }
    let ctx = Context {
        l,
        m,
        lambda_scale,
        opts,
    };

    let base_dim = if opts.max_dim == 0 {
        (3 * k).max(60)
    } else {
        opts.max_dim.max(k + 1)
    };
    if n <= DENSE_MAX || base_dim >= n {
        let (values, vectors) = dense_eigen(l, m, k)?;
        return ctx.verify(values, vectors, 0, 1, None);
    }

    // K = L + sM, factorised once; its pattern also serves L − σM.
    // L − σM: L's own pattern with the masses added on its diagonal when
    // every diagonal entry is stored (Laplacians), else assembled.
    let diag_pos: Option<Vec<usize>> = (0..n)
        .map(|j| {
            let (off, rows) = (l.col_offsets(), l.row_indices());
            (off[j]..off[j + 1]).find(|&p| rows[p] == j)
        })
        .collect();
    let pencil = |sigma: f64| match &diag_pos {
        Some(pos) => {
            let mut p = l.clone();
            let vals = p.values_mut();
            for (i, &at) in pos.iter().enumerate() {
                vals[at] -= sigma * m[i];
            }
            p
        }
        None => sparse_from_triplets(
            n,
            n,
            l.triplet_iter()
                .map(|(i, j, &v)| (i, j, v))
                .chain(m.iter().enumerate().map(|(i, &mi)| (i, i, -sigma * mi))),
        ),
    };
    let k_mat = pencil(-shift);
    let symbolic = SymbolicCholesky::new(&k_mat)?;
    let chol = symbolic.factorize(&k_mat)?;
    let op = ShiftInvert {
        chol: &chol,
        sqrt_m: m.iter().map(|x| x.sqrt()).collect(),
        scale: shift,
    };

    let mut last_err = None;
    let mut dim = base_dim;
    let mut block = if opts.block_size == 0 {
        DEFAULT_BLOCK
    } else {
        opts.block_size
    };
    for attempt in 1..=opts.max_attempts.max(1) {
        let dim_now = dim.min(n - 1);
        let seed = opts.seed.wrapping_add(attempt as u64 - 1);
        let found = block_krylov(&op, k, block, dim_now, opts.lanczos_tol, seed)
            .and_then(|(basis, images, _)| ctx.refine(&op, basis, images, k));
        match found {
            Ok((values, vectors)) => {
                match ctx.verify(
                    values,
                    vectors,
                    dim_now,
                    attempt,
                    Some((&symbolic, &pencil)),
                ) {
                    Ok(p) => return Ok(p),
                    Err(e) => last_err = Some(e),
                }
            }
            Err(e) => last_err = Some(e),
        }
        dim *= 2;
        block *= 2;
    }
    Err(last_err.unwrap_or_else(|| Error::numerical("eigen solve failed")))
}

/// Dense path: eigen-decomposition of `M^{-½} L M^{-½}`.
fn dense_eigen(l: &SparseMatrix, m: &[f64], k: usize) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let n = l.nrows();
    let mut a = DMatrix::zeros(n, n);
    for (i, j, &v) in l.triplet_iter() {
        a[(i, j)] += v / (m[i] * m[j]).sqrt();
    }
    let a = (&a + a.transpose()) * 0.5;
    let eig = nalgebra::SymmetricEigen::new(a);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&x, &y| eig.eigenvalues[x].total_cmp(&eig.eigenvalues[y]));
    let values = order[..k].iter().map(|&i| eig.eigenvalues[i]).collect();
    let vectors = DMatrix::from_fn(n, k, |i, j| eig.eigenvectors[(i, order[j])] / m[i].sqrt());
    Ok((values, vectors))
}

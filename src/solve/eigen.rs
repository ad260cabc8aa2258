//! Smallest generalised eigenpairs of a symmetric pencil `(L, M)` with `L`
//! symmetric positive semi-definite and `M` diagonal positive: the
//! Laplace–Beltrami eigenproblem `L φ = λ M φ`.
//!
//! **Method.** Shift-invert *block* Krylov (block Lanczos with full
//! reorthogonalisation and thick restarts, written here) on the symmetric
//! operator `A = s · M^{½} (L + sM)^{-1} M^{½}`, whose largest eigenvalues
//! `s / (λ + s)` belong to the smallest `λ`; `L + sM` is factorised once with
//! [`SparseCholesky`] (faer's automatic choice of the simplicial or
//! supernodal variant) and applied to whole blocks. Forcing the supernodal
//! variant, as an earlier version did for its dense-block solves, made the
//! solves slower where the automatic choice is simplicial (6-column solves,
//! one thread: FAUST 6.9k 1.35 → 0.58 ms, synthetic 27k 7.8 → 4.1 ms; at
//! 108k both choices are supernodal). The shift `−s` is negative
//! because `L` is singular on closed meshes. The converged Ritz vectors
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

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};

use super::{sparse_from_triplets, SparseCholesky, SparseMatrix, SymbolicCholesky};
use crate::{Error, Result};

/// Maximum refinement steps after the block Krylov phase.
const REFINE_STEPS: usize = 6;

/// When the operator-space residual stops improving (it is floored by the
/// accuracy of the solves, about `eps · cond(K) / θ`) below this value, the
/// Krylov phase hands over to the refinement.
const STAGNATION_OK: f64 = 1e-4;

/// Between restarts, Rayleigh–Ritz runs only once the extrapolated residual
/// estimate is below this multiple of the screening tolerance.
const RR_SKIP_MARGIN: f64 = 30.0;

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

struct Context<'a> {
    l: &'a SparseMatrix,
    m: &'a [f64],
    lambda_scale: f64,
    opts: &'a EigenOptions,
}

impl Context<'_> {
    /// Subspace-iteration refinement in the original pencil: `Z = K⁻¹ M Φ`,
    /// M-orthonormalise, Rayleigh–Ritz with `L` and `M` themselves (not
    /// through the solves), until the `k` leading pairs have true residuals
    /// below `residual_tol / 4` (at most `REFINE_STEPS` steps). Each step
    /// damps the high-frequency rounding noise of the Krylov basis by
    /// `(λ + s)/(λ_max + s)`.
    fn refine(
        &self,
        op: &ShiftInvert<'_>,
        mut basis: DMatrix<f64>,
        mut images: Option<Vec<f64>>,
        k: usize,
    ) -> Result<(Vec<f64>, DMatrix<f64>)> {
        let (n, p) = basis.shape();
        let mut y = vec![0.0f64; n * p];
        let mut q = vec![0.0f64; n * p];
        let mut lz = vec![0.0f64; n * p];
        let mut lphi = vec![0.0f64; n * k];
        let mut h = Mat::<f64>::zeros(p, p);
        let mut last = f64::INFINITY;
        for step in 0..REFINE_STEPS {
            // Z = K⁻¹ M Φ via the symmetric operator: K⁻¹ M φ = M^{-½} A M^{½} φ / s.
            // In the first step `A M^{½} φ` are the Ritz vectors' images
            // that the Krylov phase already formed (no new solves).
            if let Some(au) = images.take().filter(|au| au.len() == n * p) {
                y.copy_from_slice(&au);
            } else {
                for (yc, bc) in y.chunks_exact_mut(n).zip(basis.as_slice().chunks_exact(n)) {
                    for ((yi, &bi), s) in yc.iter_mut().zip(bc).zip(&op.sqrt_m) {
                        *yi = bi * s;
                    }
                }
                op.apply_in_place(&mut y, p)?;
            }
            // M-orthonormal basis of Z: Euclidean QR of M^{½} Z = A y / s.
            thin_qr(fcols_mut(&mut y, n, 0, p), fcols_mut(&mut q, n, 0, p), None);
            for col in q.chunks_exact_mut(n) {
                for (zi, s) in col.iter_mut().zip(&op.sqrt_m) {
                    *zi /= s;
                }
            }
            // Rayleigh–Ritz with L and M = I on span(Z).
            sparse_times(self.l, &q, &mut lz, p);
            gemm(
                h.as_mut(),
                Accum::Replace,
                fcols(&q, n, 0, p).transpose(),
                fcols(&lz, n, 0, p),
                1.0,
            );
            for j in 0..p {
                for i in 0..j {
                    let s = 0.5 * (h[(i, j)] + h[(j, i)]);
                    h[(i, j)] = s;
                    h[(j, i)] = s;
                }
            }
            let (vals, vecs) = sym_eigen(h.as_ref())?;
            gemm(
                fview_mut(&mut basis),
                Accum::Replace,
                fcols(&q, n, 0, p),
                fview(&vecs),
                1.0,
            );
            let res = self.max_residual(&basis.as_slice()[..n * k], &mut lphi, k);
            if res <= 0.25 * self.opts.residual_tol {
                let values = vals[..k].to_vec();
                let lead = DMatrix::from_column_slice(n, k, &basis.as_slice()[..n * k]);
                return Ok((values, lead));
            }
            if res > 0.9 * last && step >= 2 {
                break;
            }
            last = last.min(res);
        }
        Err(Error::numerical(format!(
            "eigen refinement did not reach residual {:.1e} (best {last:.3e})",
            0.25 * self.opts.residual_tol
        )))
    }

    /// Largest relative residual over the `k` columns of the column-major
    /// `vectors` (`lphi`: `n × k` scratch for `L Φ`).
    fn max_residual(&self, vectors: &[f64], lphi: &mut [f64], k: usize) -> f64 {
        let n = self.m.len();
        sparse_times(self.l, vectors, lphi, k);
        (0..k)
            .map(|j| {
                let r = j * n..(j + 1) * n;
                self.residual(&vectors[r.clone()], &lphi[r]).1
            })
            .fold(0.0, f64::max)
    }

    /// (Rayleigh quotient, relative residual
    /// `‖Lφ − λMφ‖_{M⁻¹} / (max(|λ|, λ_scale) ‖φ‖_M)`) of `φ`, given `Lφ`.
    fn residual(&self, phi: &[f64], lphi: &[f64]) -> (f64, f64) {
        let m = self.m;
        let (mut num, mut p2) = (0.0, 0.0);
        for ((&x, &lx), &mi) in phi.iter().zip(lphi).zip(m) {
            num += x * lx;
            p2 += x * x * mi;
        }
        let lam = num / p2;
        let mut r2 = 0.0;
        for ((&x, &lx), &mi) in phi.iter().zip(lphi).zip(m) {
            let r = lx - lam * mi * x;
            r2 += r * r / mi;
        }
        let rel = r2.sqrt() / (lam.abs().max(self.lambda_scale) * p2.sqrt());
        (lam, if rel.is_nan() { f64::INFINITY } else { rel })
    }

    /// Rayleigh quotients, sorting, residual, orthonormality and inertia
    /// checks.
    fn verify(
        &self,
        _values: Vec<f64>,
        vectors: DMatrix<f64>,
        subspace_dim: usize,
        attempts: usize,
        inertia: Option<(&SymbolicCholesky, &dyn Fn(f64) -> SparseMatrix)>,
    ) -> Result<Eigenpairs> {
        let m = self.m;
        let (n, k) = vectors.shape();
        let mut lphi = vec![0.0f64; n * k];
        sparse_times(self.l, vectors.as_slice(), &mut lphi, k);
        let mut pairs: Vec<(f64, usize)> = (0..k)
            .map(|j| {
                let r = j * n..(j + 1) * n;
                (self.residual(&vectors.as_slice()[r.clone()], &lphi[r]).0, j)
            })
            .collect();
        if pairs.iter().any(|p| !p.0.is_finite()) {
            return Err(Error::numerical("eigen solve produced non-finite values"));
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let values: Vec<f64> = pairs.iter().map(|p| p.0).collect();
        let (mut vectors, lphi) = if pairs.iter().enumerate().all(|(j, p)| p.1 == j) {
            (vectors, lphi)
        } else {
            let v = DMatrix::from_fn(n, k, |i, j| vectors[(i, pairs[j].1)]);
            let lp = (0..k)
                .flat_map(|j| lphi[pairs[j].1 * n..(pairs[j].1 + 1) * n].iter().copied())
                .collect();
            (v, lp)
        };

        // Residuals in the M⁻¹ norm, relative to max(λ, λ_scale).
        let mut max_residual = 0.0f64;
        for (j, &lam) in values.iter().enumerate() {
            let r = j * n..(j + 1) * n;
            let rel = self.residual(&vectors.as_slice()[r.clone()], &lphi[r]).1;
            max_residual = max_residual.max(rel);
            if rel.is_nan() || rel > self.opts.residual_tol {
                return Err(Error::numerical(format!(
                    "eigenpair {j} (λ = {lam:.6e}) has relative residual {rel:.3e} > {:.1e} \
                     (subspace {subspace_dim})",
                    self.opts.residual_tol
                )));
            }
        }
        drop(lphi);
        // M-orthonormality.
        let mphi = DMatrix::from_fn(n, k, |i, j| m[i] * vectors[(i, j)]);
        let mut gram = DMatrix::<f64>::zeros(k, k);
        gemm(
            fview_mut(&mut gram),
            Accum::Replace,
            fview(&vectors).transpose(),
            fview(&mphi),
            1.0,
        );
        drop(mphi);
        let orthonormality_error = (gram - DMatrix::identity(k, k)).abs().max();
        if orthonormality_error.is_nan() || orthonormality_error > self.opts.orthonormality_tol {
            return Err(Error::numerical(format!(
                "eigenvectors are not M-orthonormal: max |ΦᵀMΦ − I| = {orthonormality_error:.3e} \
                 (duplicated vectors?) with subspace {subspace_dim}"
            )));
        }
        // Completeness (Sylvester inertia).
        if let (Some((symbolic, pencil)), true) = (inertia, self.opts.check_inertia) {
            let top = values[k - 1];
            let mut delta = 1e-6;
            let mut checked = false;
            while delta <= 1e-3 && !checked {
                let sigma = top - delta * top.abs().max(self.lambda_scale);
                let below = values.iter().filter(|&&v| v < sigma).count();
                match symbolic.factorize_ldlt(&pencil(sigma)) {
                    Ok(f) => {
                        let neg = f.inertia().negative;
                        if neg != below {
                            return Err(Error::numerical(format!(
                                "eigen solve missed eigenvalues: L − σM with σ = {sigma:.6e} has \
                                 {neg} eigenvalues below σ but {below} were found (skipped \
                                 members of a repeated eigenvalue?) with subspace {subspace_dim}"
                            )));
                        }
                        checked = true;
                    }
                    Err(_) => delta *= 10.0,
                }
            }
            if !checked {
                return Err(Error::numerical(
                    "could not verify eigen completeness: LDLT of the shifted pencil failed",
                ));
            }
        }
        canonicalize_signs(&mut vectors, m);
        Ok(Eigenpairs {
            values,
            vectors,
            max_residual,
            orthonormality_error,
            subspace_dim,
            attempts,
        })
    }
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

/// `A = s · M^{½} (L + sM)^{-1} M^{½}` (symmetric, norm ≤ 1).
struct ShiftInvert<'a> {
    chol: &'a SparseCholesky,
    sqrt_m: Vec<f64>,
    scale: f64,
}

impl std::fmt::Debug for ShiftInvert<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ShiftInvert(n = {})", self.sqrt_m.len())
    }
}

/// Block Krylov (block Lanczos with full reorthogonalisation and thick
/// restarts) for the `k` largest eigenpairs of the symmetric operator `op`,
/// mapped back to `(λ, φ)`.
///
/// The basis `V` (orthonormal, `n × d`) grows by blocks of `b` vectors, the
/// next block being the part of `A V_last` orthogonal to `V`; the projected
/// matrix `H = Vᵀ A V` is updated incrementally. When `d` would exceed
/// `max_dim`, the basis is compressed to its best Ritz vectors (`A V` is
/// compressed the same way, without new solves). A random start block of `b`
/// columns resolves eigenvalues of multiplicity up to `b` reliably — unlike a
/// single-vector Lanczos, which only finds further members of a repeated
/// eigenvalue through rounding noise.
///
/// *Convergence test.* The Ritz pairs `(θ, u = V y)` are accepted when their
/// explicit residuals `‖A u − θ u‖ ≤ tol θ`. Forming `u` and `A u` costs two
/// `n × d × k` products, so every step first screens with the block-Lanczos
/// estimate: the next block is orthonormalised before the Rayleigh–Ritz step,
/// `(I − V Vᵀ) A V_last = Q R`, and `‖A u − θ u‖ ≈ ‖R y_last‖` (`y_last`:
/// the rows of `y` of the last block; exact up to rounding and the
/// asymmetry of the computed solves). Explicit residuals are computed only
/// when the estimate says converged (or stagnated), and at restarts, where
/// the compressed basis gives them for free; only they decide.
///
/// Dense work runs on buffers allocated once, with faer's blocked products,
/// QR and symmetric eigensolver; the orthonormalisation of a block is block
/// classical Gram–Schmidt twice, Householder QR, once more and QR again.
///
/// Returns the best `k + b` Ritz vectors `φ = M^{-½} u`, their images `A u`
/// (column-major; the refinement's first step starts from them) and the
/// number of solves.
fn block_krylov(
    op: &ShiftInvert<'_>,
    k: usize,
    b: usize,
    max_dim: usize,
    screen_tol: f64,
    seed: u64,
) -> Result<(DMatrix<f64>, Option<Vec<f64>>, usize)> {
    let n = op.sqrt_m.len();
    let b = b.clamp(1, n);
    let max_dim = max_dim.clamp((k + 2 * b).min(n), n);
    let keep = (max_dim / 2).max(k + b).min(max_dim - b);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let start = DMatrix::<f64>::from_fn(n, b, |_, _| rng.random::<f64>() - 0.5);

    // V and W = A V, column-major n × max_dim.
    let mut v = vec![0.0f64; n * max_dim];
    let mut w = vec![0.0f64; n * max_dim];
    let mut h = Mat::<f64>::zeros(max_dim, max_dim);
    // Scratch: the block being orthonormalised, projection coefficients,
    // Ritz vectors and their images.
    let mut x = vec![0.0f64; n * b];
    let mut x2 = vec![0.0f64; n * b];
    let mut coef = Mat::<f64>::zeros(max_dim, b);
    let mut ritz_u: Vec<f64> = Vec::new();
    let mut ritz_au: Vec<f64> = Vec::new();

    let mut d = 0usize;
    // The next block: raw (to be orthonormalised against V[:, :d]) in `x`, or
    // already orthonormalised into V[:, d..d + nb] with its R factor.
    x[..n * b].copy_from_slice(start.as_slice());
    let mut x_cols = b;
    let mut prepared: Option<usize> = None;
    let max_steps = 200 + 20 * max_dim / b;
    let mut solves = 0usize;
    let mut best = f64::INFINITY;
    let mut since_best = 0usize;
    let mut explicit_mode = false;
    // Rayleigh–Ritz (a dense `d × d` eigensolve) is skipped between restarts
    // while the residual estimate, extrapolated geometrically from the last
    // two, is still far above `screen_tol`: with small blocks most steps
    // cannot have converged, and the eigensolves would dominate.
    let mut last_rr: Option<(usize, f64)> = None;
    let mut rate: Option<f64> = None;
    for step in 0..max_steps {
        let nb = match prepared.take() {
            Some(nb) => nb,
            None => {
                let nb = x_cols.min(max_dim - d);
                if nb == 0 {
                    break;
                }
                orthonormalise_into(
                    &mut v, &mut x, &mut x2, n, d, x_cols, nb, &mut coef, false, None,
                );
                nb
            }
        };
        // W[:, d..d+nb] = A V[:, d..d+nb].
        w[d * n..(d + nb) * n].copy_from_slice(&v[d * n..(d + nb) * n]);
        op.apply_in_place(&mut w[d * n..(d + nb) * n], nb)?;
        solves += nb;
        // C = V[:, :d+nb]ᵀ A q: the new columns of H (mirrored, the new
        // diagonal block symmetrised) and the first Gram–Schmidt pass of
        // the next block A q against V.
        let dn = d + nb;
        coef.resize_with(dn, nb, |_, _| 0.0);
        gemm(
            coef.as_mut(),
            Accum::Replace,
            fcols(&v, n, 0, dn).transpose(),
            fcols(&w, n, d, nb),
            1.0,
        );
        h.as_mut()
            .submatrix_mut(0, d, dn, nb)
            .copy_from(coef.as_ref());
        for j in d..dn {
            for i in 0..d {
                h[(j, i)] = h[(i, j)];
            }
            for i in d..j {
                let s = 0.5 * (h[(i, j)] + h[(j, i)]);
                h[(i, j)] = s;
                h[(j, i)] = s;
            }
        }
        d = dn;
        let restart = d + b > max_dim;
        // The next block, orthonormalised now (for the residual estimate),
        // except at a restart, which replaces it.
        let mut r_next = None;
        if !restart {
            x[..n * nb].copy_from_slice(&w[(d - nb) * n..d * n]);
            let nn = nb.min(max_dim - d);
            let mut r = DMatrix::zeros(0, 0);
            orthonormalise_into(
                &mut v,
                &mut x,
                &mut x2,
                n,
                d,
                nb,
                nn,
                &mut coef,
                true,
                Some(&mut r),
            );
            prepared = Some(nn);
            r_next = Some(r);
        }
        if d < k {
            continue;
        }
        if let (false, false, Some((s0, e0)), Some(q)) = (restart, explicit_mode, last_rr, rate) {
            let predicted = e0 * q.powi((step - s0) as i32);
            if predicted > RR_SKIP_MARGIN * screen_tol {
                continue;
            }
        }
        // Rayleigh–Ritz, Ritz values descending.
        let (vals, vecs) = sym_eigen(h.as_ref().submatrix(0, 0, d, d))?;
        let order: Vec<usize> = (0..d).rev().collect();
        let theta = |j: usize| vals[order[j]];
        let ycols = |c: usize| DMatrix::from_fn(d, c, |i, j| vecs[(i, order[j])]);
        let rel = |r: f64, th: f64| if th > 0.0 { r / th } else { f64::INFINITY };

        // Explicit residuals of the first `k` Ritz pairs from U = V Y and
        // A U = W Y (`c ≥ k` columns).
        let explicit = |u: &[f64], au: &[f64]| {
            (0..k)
                .map(|j| {
                    let th = theta(j);
                    let r2: f64 = u[j * n..(j + 1) * n]
                        .iter()
                        .zip(&au[j * n..(j + 1) * n])
                        .map(|(&a, &b)| (b - a * th).powi(2))
                        .sum();
                    rel(r2.sqrt(), th)
                })
                .fold(0.0f64, f64::max)
        };
        let ritz = |c: usize, u: &mut Vec<f64>, au: &mut Vec<f64>| {
            let y = ycols(c);
            u.resize(n * c, 0.0);
            au.resize(n * c, 0.0);
            gemm(
                fcols_mut(u, n, 0, c),
                Accum::Replace,
                fcols(&v, n, 0, d),
                fview(&y),
                1.0,
            );
            gemm(
                fcols_mut(au, n, 0, c),
                Accum::Replace,
                fcols(&w, n, 0, d),
                fview(&y),
                1.0,
            );
        };
        let mut have_ritz = 0usize;
        let worst = match &r_next {
            Some(r) => {
                let estimate = (0..k)
                    .map(|j| {
                        let o = order[j];
                        let mut s2 = 0.0;
                        for i in 0..r.nrows() {
                            let mut t = 0.0;
                            for l in i..r.ncols() {
                                t += r[(i, l)] * vecs[(d - nb + l, o)];
                            }
                            s2 += t * t;
                        }
                        rel(s2.sqrt(), theta(j))
                    })
                    .fold(0.0f64, f64::max);
                let might_stagnate = since_best + 1 > max_dim / b && estimate <= STAGNATION_OK;
                // Once screened in, explicit residuals every step: near the
                // accuracy floor of the solves the estimate (which does not
                // see it) keeps falling while the explicit residual stalls.
                explicit_mode |= estimate <= screen_tol || might_stagnate;
                if explicit_mode {
                    // The `k + b` vectors returned on success, so that
                    // they need not be formed again.
                    let c = (k + b).min(d);
                    ritz(c, &mut ritz_u, &mut ritz_au);
                    have_ritz = c;
                    explicit(&ritz_u, &ritz_au)
                } else {
                    estimate
                }
            }
            None => {
                ritz(keep, &mut ritz_u, &mut ritz_au);
                have_ritz = keep;
                explicit(&ritz_u, &ritz_au)
            }
        };
        // Converged in operator space (limited by the accuracy of the solves,
        // ~ eps·cond(K)/θ): return the best `k + b` Ritz vectors, φ = M^{-½}u;
        // the caller refines them in the original pencil.
        if let Some((s0, e0)) = last_rr {
            let q = (worst / e0).powf(1.0 / (step - s0) as f64);
            rate = (q.is_finite() && q < 1.0).then_some(q);
        }
        last_rr = Some((step, worst));
        if worst < 0.5 * best {
            best = worst;
            since_best = 0;
        } else {
            since_best += 1;
        }
        let stagnated = since_best > max_dim / b && worst <= STAGNATION_OK;
        if (worst <= screen_tol || stagnated) && have_ritz > 0 {
            let p = (k + b).min(d);
            if have_ritz < p {
                ritz(p, &mut ritz_u, &mut ritz_au);
            }
            let vectors = DMatrix::from_fn(n, p, |i, j| ritz_u[j * n + i] / op.sqrt_m[i]);
            ritz_au.truncate(n * p);
            return Ok((vectors, Some(ritz_au), solves));
        }
        if restart {
            // Thick restart: keep the best `keep` Ritz vectors (and their
            // images, no new solves). The next block is made of the residuals
            // `A u − θ u` of the first `b` unconverged wanted Ritz vectors
            // (then of the following ones), which carry the Krylov
            // continuation of the discarded basis.
            let res_norm = |j: usize| {
                let th = theta(j);
                ritz_u[j * n..(j + 1) * n]
                    .iter()
                    .zip(&ritz_au[j * n..(j + 1) * n])
                    .map(|(&a, &b)| (b - a * th).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            let mut cols: Vec<usize> = (0..keep)
                .filter(|&j| res_norm(j) > screen_tol * theta(j).abs())
                .take(b)
                .collect();
            let mut extra = 0;
            while cols.len() < b && extra < keep {
                if !cols.contains(&extra) {
                    cols.push(extra);
                }
                extra += 1;
            }
            for (c, &j) in cols.iter().enumerate() {
                let th = theta(j);
                for i in 0..n {
                    x[c * n + i] = ritz_au[j * n + i] - ritz_u[j * n + i] * th;
                }
            }
            x_cols = cols.len();
            v[..n * keep].copy_from_slice(&ritz_u[..n * keep]);
            w[..n * keep].copy_from_slice(&ritz_au[..n * keep]);
            h.fill(0.0);
            for j in 0..keep {
                h[(j, j)] = theta(j);
            }
            d = keep;
            prepared = None;
        }
    }
    Err(Error::numerical(format!(
        "block Krylov did not converge for {k} eigenpairs (block {b}, subspace {max_dim}, {solves} solves)"
    )))
}

/// Orthonormal basis of the part of the first `c` columns of `x` (scratch,
/// `n × c`, destroyed; `x2` likewise) orthogonal to the orthonormal columns
/// `V[:, :d]`, written to `V[:, d..d + nb]` (`nb ≤ c`): block classical
/// Gram–Schmidt with reorthogonalisation (BCGS2), each projection pass
/// followed by a Householder QR of the block; a further pass is made while a
/// pass shrinks some direction below half its length (Kahan–Parlett's
/// "twice is enough" test, at most two extra passes). With `first_done`,
/// `coef` already holds `V[:, :d]ᵀ x` (computed with `H`). With `r`, the
/// `c × c` factor with `(I − V Vᵀ) x ≈ Q R` (the product of the QR factors).
#[allow(clippy::too_many_arguments)]
fn orthonormalise_into(
    v: &mut [f64],
    x: &mut [f64],
    x2: &mut [f64],
    n: usize,
    d: usize,
    c: usize,
    nb: usize,
    coef: &mut Mat<f64>,
    first_done: bool,
    r: Option<&mut DMatrix<f64>>,
) {
    let (basis, rest) = v.split_at_mut(d * n);
    let basis = MatRef::from_column_major_slice(basis, n, d);
    let (mut src, mut dst) = (&mut x[..n * c], &mut x2[..n * c]);
    if first_done {
        if d > 0 {
            gemm(
                MatMut::from_column_major_slice_mut(src, n, c),
                Accum::Add,
                basis,
                coef.as_ref(),
                -1.0,
            );
        }
    } else {
        project_out(basis, MatMut::from_column_major_slice_mut(src, n, c), coef);
    }
    let mut r_acc = DMatrix::zeros(0, 0);
    thin_qr(
        MatMut::from_column_major_slice_mut(src, n, c),
        MatMut::from_column_major_slice_mut(dst, n, c),
        Some(&mut r_acc),
    );
    std::mem::swap(&mut src, &mut dst);
    let mut rp = DMatrix::zeros(0, 0);
    for _pass in 0..3 {
        project_out(basis, MatMut::from_column_major_slice_mut(src, n, c), coef);
        thin_qr(
            MatMut::from_column_major_slice_mut(src, n, c),
            MatMut::from_column_major_slice_mut(dst, n, c),
            Some(&mut rp),
        );
        std::mem::swap(&mut src, &mut dst);
        r_acc = &rp * &r_acc;
        if (0..c).all(|i| rp[(i, i)].abs() >= 0.5) {
            break;
        }
    }
    rest[..n * nb].copy_from_slice(&src[..n * nb]);
    if let Some(r) = r {
        *r = r_acc;
    }
}

impl ShiftInvert<'_> {
    /// `X ← A X` for the `ncols` columns of the column-major block `x`.
    fn apply_in_place(&self, x: &mut [f64], ncols: usize) -> Result<()> {
        let n = self.sqrt_m.len();
        for col in x[..n * ncols].chunks_exact_mut(n) {
            for (xi, s) in col.iter_mut().zip(&self.sqrt_m) {
                *xi *= s;
            }
        }
        self.chol.solve_in_place(&mut x[..n * ncols], ncols)?;
        for col in x[..n * ncols].chunks_exact_mut(n) {
            for (xi, s) in col.iter_mut().zip(&self.sqrt_m) {
                *xi *= self.scale * s;
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------
// Dense kernels on column-major buffers: faer's blocked (BLAS-3) products,
// QR and symmetric eigensolver, always sequential (`Par::Seq`) so that the
// results do not depend on the thread count, writing into caller-owned
// buffers so that the large `n × d` blocks are allocated once per solve.

/// The `n × c` column-major matrix stored in `buf[start·n .. (start + c)·n]`.
fn fcols(buf: &[f64], n: usize, start: usize, c: usize) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(&buf[start * n..(start + c) * n], n, c)
}

/// Mutable version of [`fcols`].
fn fcols_mut(buf: &mut [f64], n: usize, start: usize, c: usize) -> MatMut<'_, f64> {
    MatMut::from_column_major_slice_mut(&mut buf[start * n..(start + c) * n], n, c)
}

/// `dst = a · b` (`beta = Replace`) or `dst += a · b` (`Add`), times `alpha`.
fn gemm(dst: MatMut<'_, f64>, beta: Accum, a: MatRef<'_, f64>, b: MatRef<'_, f64>, alpha: f64) {
    faer::linalg::matmul::matmul(dst, beta, a, b, alpha, Par::Seq);
}

/// A faer view of a whole nalgebra matrix.
fn fview(m: &DMatrix<f64>) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(m.as_slice(), m.nrows(), m.ncols())
}

/// A mutable faer view of a whole nalgebra matrix.
fn fview_mut(m: &mut DMatrix<f64>) -> MatMut<'_, f64> {
    let (r, c) = m.shape();
    MatMut::from_column_major_slice_mut(m.as_mut_slice(), r, c)
}

/// Householder QR of the `n × c` matrix `a` (`n ≥ c`, overwritten by the
/// factorisation): writes the thin `Q` into `q` and, if asked, `R` (`c × c`,
/// upper triangular) into `r`.
fn thin_qr(mut a: MatMut<'_, f64>, mut q: MatMut<'_, f64>, r: Option<&mut DMatrix<f64>>) {
    use faer::linalg::{householder, qr::no_pivoting::factor};
    let (n, c) = (a.nrows(), a.ncols());
    if c == 0 {
        return;
    }
    let bs = factor::recommended_block_size::<f64>(n, c);
    let mut coeff = Mat::<f64>::zeros(bs, c);
    let req = StackReq::any_of(&[
        factor::qr_in_place_scratch::<f64>(n, c, bs, Par::Seq, Default::default()),
        householder::apply_block_householder_sequence_on_the_left_in_place_scratch::<f64>(n, bs, c),
    ]);
    let mut mem = MemBuffer::new(req);
    factor::qr_in_place(
        a.rb_mut(),
        coeff.as_mut(),
        Par::Seq,
        MemStack::new(&mut mem),
        Default::default(),
    );
    if let Some(r) = r {
        *r = DMatrix::from_fn(c, c, |i, j| if i <= j { a[(i, j)] } else { 0.0 });
    }
    q.fill(0.0);
    for j in 0..c {
        q[(j, j)] = 1.0;
    }
    householder::apply_block_householder_sequence_on_the_left_in_place_with_conj(
        a.rb(),
        coeff.as_ref(),
        Conj::No,
        q.rb_mut(),
        Par::Seq,
        MemStack::new(&mut mem),
    );
}

/// Eigen-decomposition of the symmetric `d × d` matrix `h` (lower triangle
/// read): (eigenvalues, eigenvectors), the eigenvalues ascending.
fn sym_eigen(h: MatRef<'_, f64>) -> Result<(Vec<f64>, DMatrix<f64>)> {
    use faer::linalg::evd;
    let d = h.nrows();
    let mut s = Mat::<f64>::zeros(d, 1);
    let mut u = DMatrix::<f64>::zeros(d, d);
    let mut mem = MemBuffer::new(evd::self_adjoint_evd_scratch::<f64>(
        d,
        evd::ComputeEigenvectors::Yes,
        Par::Seq,
        Default::default(),
    ));
    evd::self_adjoint_evd(
        h,
        s.as_mut().col_mut(0).as_diagonal_mut(),
        Some(fview_mut(&mut u)),
        Par::Seq,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .map_err(|e| Error::numerical(format!("dense symmetric eigensolver failed: {e:?}")))?;
    Ok(((0..d).map(|i| s[(i, 0)]).collect(), u))
}

/// `x ← (I − V Vᵀ) x` for the orthonormal columns `V` (`coef`: `d × c`
/// scratch).
fn project_out(v: MatRef<'_, f64>, mut x: MatMut<'_, f64>, coef: &mut Mat<f64>) {
    if v.ncols() == 0 {
        return;
    }
    coef.resize_with(v.ncols(), x.ncols(), |_, _| 0.0);
    gemm(coef.as_mut(), Accum::Replace, v.transpose(), x.rb(), 1.0);
    gemm(x.rb_mut(), Accum::Add, v, coef.as_ref(), -1.0);
}

/// Relative size below which `⟨φ, w⟩_M` is not trusted to fix the sign of
/// `φ` (see [`canonicalize_signs`]).
const SIGN_TAU: f64 = 1e-6;

/// Number of weight vectors tried by [`canonicalize_signs`] before the
/// largest-entry fallback.
const SIGN_WEIGHTS: u64 = 3;

/// Entry `i` of the `r`-th fixed sign weight vector: `1 + u − ½` with `u` in
/// `[0, 1)` from a SplitMix64 hash of `(r, i)`. Depends only on the index.
fn sign_weight(r: u64, i: usize) -> f64 {
    let mut z = (i as u64)
        .wrapping_add(r.wrapping_mul(0xD1B5_4A32_D192_ED03))
        .wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    0.5 + (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Gives every column `φ` of `vectors` its canonical sign (the rule that
/// [`generalized_eigen`] applies to its results), in place; `m` is the
/// diagonal mass.
///
/// **Rule.** `φ` is made to satisfy `⟨φ, w_r⟩_M = Σ m_i w_{r,i} φ_i > 0` for
/// the first of a few fixed weight vectors `w_0, w_1, w_2` whose product is
/// not negligible, `|⟨φ, w_r⟩_M| > τ ‖φ‖_M ‖w_r‖_M` with `τ = 1e-6`; if all
/// three are negligible (or for a vector that is zero there), its entry of
/// largest magnitude (lowest index on ties) is made positive. The weights
/// `w_{r,i} = 1 + (u_{r,i} − ½)`, `u` a fixed hash of `(r, i)` in `[0, 1)`,
/// depend only on the vertex index, so the sign depends only on the vector
/// (and the masses), not on the solver's random start, block size or
/// rounding.
///
/// **Why this rule.** Any sign rule is discontinuous somewhere; the question
/// is how likely a computed eigenvector lands there. "Largest entry
/// positive" fails on every symmetric mesh, where an odd eigenfunction has
/// two extreme entries of equal magnitude and opposite sign, so rounding
/// decides. Against a generic weight vector, the product of a unit vector is
/// of relative size `~ 1/√n` (`w` is not aligned with the mesh's
/// symmetries: the hash of the index knows nothing of the geometry), far
/// above the relative accuracy of the vectors (`≲ 1e-7`); the chance that
/// it falls below `τ` is about `τ √n`, and then a second, independent
/// weight decides. The constant part of `w` makes the constant eigenvector
/// of a closed (or Neumann) mesh positive; the other eigenvectors are
/// M-orthogonal to constants, so for them only the hashed part matters.
///
/// **Repeated eigenvalues.** For an eigenvalue of multiplicity `> 1` the
/// vectors inside its eigenspace are arbitrary (any M-orthonormal basis is
/// valid and the solver returns one that depends on its start); only the
/// sign of each returned vector is canonicalised, not the rotation.
///
/// Idempotent, and `φ` and `−φ` give bit-identical results (`⟨−φ, w⟩_M` is
/// computed as exactly `−⟨φ, w⟩_M`).
pub fn canonicalize_signs(vectors: &mut DMatrix<f64>, m: &[f64]) {
    let n = vectors.nrows();
    assert_eq!(m.len(), n, "one mass per row");
    // (M w_r, ‖w_r‖²_M), computed when first needed.
    let mut weights: Vec<(Vec<f64>, f64)> = Vec::new();
    for mut col in vectors.column_iter_mut() {
        let norm2: f64 = col.iter().zip(m).map(|(x, w)| w * x * x).sum();
        let mut sign = 0.0;
        for r in 0..SIGN_WEIGHTS {
            if weights.len() <= r as usize {
                let mw: Vec<f64> = (0..n).map(|i| m[i] * sign_weight(r, i)).collect();
                let w2 = (0..n).map(|i| mw[i] * sign_weight(r, i)).sum();
                weights.push((mw, w2));
            }
            let (mw, w2) = &weights[r as usize];
            let p: f64 = col.iter().zip(mw).map(|(x, w)| w * x).sum();
            if p.abs() > SIGN_TAU * (norm2 * w2).sqrt() {
                sign = p.signum();
                break;
            }
        }
        if sign == 0.0 {
            let mut best = (0.0f64, 0usize);
            for (i, x) in col.iter().enumerate() {
                if x.abs() > best.0 {
                    best = (x.abs(), i);
                }
            }
            sign = if col[best.1] < 0.0 { -1.0 } else { 1.0 };
        }
        if sign < 0.0 {
            col.neg_mut();
        }
    }
}

/// `out = L X` for the `c` columns of the column-major `x` (`L` sparse CSC,
/// `n × n`). Works on row-major copies of up to [`SPMM_CHUNK`] columns, so
/// that each stored entry of `L` updates a contiguous short row (the sums
/// are formed in the same order as column by column).
fn sparse_times(l: &SparseMatrix, x: &[f64], out: &mut [f64], c: usize) {
    let n = l.nrows();
    let (offsets, rows, vals) = (l.col_offsets(), l.row_indices(), l.values());
    let width = c.min(SPMM_CHUNK);
    let mut xt = vec![0.0f64; n * width];
    let mut ot = vec![0.0f64; n * width];
    for j0 in (0..c).step_by(SPMM_CHUNK) {
        let w = (c - j0).min(SPMM_CHUNK);
        for jj in 0..w {
            let col = &x[(j0 + jj) * n..(j0 + jj + 1) * n];
            for (i, &v) in col.iter().enumerate() {
                xt[i * w + jj] = v;
            }
        }
        ot[..n * w].fill(0.0);
        for col in 0..n {
            let xc = &xt[col * w..(col + 1) * w];
            for e in offsets[col]..offsets[col + 1] {
                let (r, v) = (rows[e], vals[e]);
                for (o, &xv) in ot[r * w..(r + 1) * w].iter_mut().zip(xc) {
                    *o += v * xv;
                }
            }
        }
        for jj in 0..w {
            let col = &mut out[(j0 + jj) * n..(j0 + jj + 1) * n];
            for (i, o) in col.iter_mut().enumerate() {
                *o = ot[i * w + jj];
            }
        }
    }
}

/// Columns per pass of [`sparse_times`].
const SPMM_CHUNK: usize = 16;

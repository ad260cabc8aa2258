//! Work in the original pencil `(L, M)`: the subspace-iteration refinement
//! of the Krylov vectors (Rayleigh–Ritz with `L` and `M` themselves), the
//! residuals, and the verification of every result (residuals,
//! M-orthonormality, completeness by Sylvester's law of inertia).

use faer::{Accum, Mat};
use nalgebra::DMatrix;

use super::kernels::{fcols, fcols_mut, fview, fview_mut, gemm, sparse_times, sym_eigen, thin_qr};
use super::krylov::ShiftInvert;
use super::signs::canonicalize_signs;
use super::{EigenOptions, Eigenpairs};
use crate::solve::{SparseMatrix, SymbolicCholesky};
use crate::{Error, Result};

/// Maximum refinement steps after the block Krylov phase.
const REFINE_STEPS: usize = 6;

pub(super) struct Context<'a> {
    pub(super) l: &'a SparseMatrix,
    pub(super) m: &'a [f64],
    pub(super) lambda_scale: f64,
    pub(super) opts: &'a EigenOptions,
}

impl Context<'_> {
    /// Subspace-iteration refinement in the original pencil: `Z = K⁻¹ M Φ`,
    /// M-orthonormalise, Rayleigh–Ritz with `L` and `M` themselves (not
    /// through the solves), until the `k` leading pairs have true residuals
    /// below `residual_tol / 4` (at most `REFINE_STEPS` steps). Each step
    /// damps the high-frequency rounding noise of the Krylov basis by
    /// `(λ + s)/(λ_max + s)`.
    pub(super) fn refine(
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
    pub(super) fn verify(
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

//! The shift-invert operator `A = s · M^{½} (L + sM)^{-1} M^{½}` and the
//! block Krylov iteration (block Lanczos with full reorthogonalisation and
//! thick restarts) for its largest eigenpairs.

use faer::{Accum, Mat, MatMut, MatRef};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};

use super::kernels::{fcols, fcols_mut, fview, gemm, project_out, sym_eigen, thin_qr};
use crate::solve::SparseCholesky;
use crate::{Error, Result};

/// When the operator-space residual stops improving (it is floored by the
/// accuracy of the solves, about `eps · cond(K) / θ`) below this value, the
/// Krylov phase hands over to the refinement.
const STAGNATION_OK: f64 = 1e-4;

/// Between restarts, Rayleigh–Ritz runs only once the extrapolated residual
/// estimate is below this multiple of the screening tolerance.
const RR_SKIP_MARGIN: f64 = 30.0;
/// `A = s · M^{½} (L + sM)^{-1} M^{½}` (symmetric, norm ≤ 1).
pub(super) struct ShiftInvert<'a> {
    pub(super) chol: &'a SparseCholesky,
    pub(super) sqrt_m: Vec<f64>,
    pub(super) scale: f64,
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
pub(super) fn block_krylov(
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
    pub(super) fn apply_in_place(&self, x: &mut [f64], ncols: usize) -> Result<()> {
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

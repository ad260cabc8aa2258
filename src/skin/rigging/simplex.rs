//! The per-vertex weight problem of step 3a: least squares over the
//! probability simplex ([`simplex_least_squares`]), solved exactly by a
//! primal active-set method on the Gram matrix.

use nalgebra::{DMatrix, DVector};

use crate::{Error, Result};

/// Relative ridge and multiplier tolerance of the simplex QP.
const QP_RIDGE: f64 = 1e-12;
const QP_TOL: f64 = 1e-11;

/// Exact minimiser of `‖A w − b‖²` over the probability simplex
/// (`w ≥ 0`, `Σ w = 1`), the per-vertex weight problem of step 3a.
///
/// Because `Σ w = 1`, `A w − b = D w` with `D = A − b 1ᵀ`, so this solves
/// `min wᵀ G w` on the simplex with `G = DᵀD` by a primal active-set method
/// started at the best vertex of the simplex: on the free set F solve the
/// equality-constrained problem (`(G_FF + δI) z = 1`, `y = z / 1ᵀz`), step
/// towards `y` until a weight hits 0 (then drop it from F), and when `y` is
/// feasible add the bound with the most negative multiplier
/// `λ_j = (G w)_j − wᵀ G w` (until all are ≥ −1e-11 · max G_jj). The relative
/// ridge `δ = 1e-12 · max G_jj` only makes `G_FF` invertible when two
/// columns coincide; `Σ w = 1` and `w ≥ 0` hold exactly (to rounding).
///
/// Errors on mismatched sizes, no columns, or non-finite entries.
pub fn simplex_least_squares(a: &DMatrix<f64>, b: &DVector<f64>) -> Result<DVector<f64>> {
    let k = a.ncols();
    if k == 0 {
        return Err(Error::invalid("simplex least squares with no columns"));
    }
    if a.nrows() != b.len() {
        return Err(Error::invalid(format!(
            "simplex least squares: A has {} rows, b has {}",
            a.nrows(),
            b.len()
        )));
    }
    if a.iter().chain(b.iter()).any(|x| !x.is_finite()) {
        return Err(Error::invalid("simplex least squares: non-finite entry"));
    }
    let mut d = a.clone();
    for mut col in d.column_iter_mut() {
        col -= b;
    }
    let gm = d.transpose() * &d;
    let g: Vec<f64> = (0..k * k).map(|x| gm[(x / k, x % k)]).collect();
    Ok(DVector::from_vec(simplex_gram(&g, k)))
}

/// [`simplex_least_squares`] on the Gram matrix `g` (k × k, row-major,
/// symmetric positive semi-definite).
pub(super) fn simplex_gram(g: &[f64], k: usize) -> Vec<f64> {
    let mut w = vec![0.0; k];
    if k == 0 {
        return w;
    }
    let diag = |j: usize| g[j * k + j];
    let start = (0..k)
        .min_by(|&a, &b| diag(a).total_cmp(&diag(b)))
        .unwrap_or(0);
    w[start] = 1.0;
    let scale = (0..k).map(diag).fold(0.0, f64::max);
    if !(scale > 0.0 && scale.is_finite()) {
        return w;
    }
    let ridge = QP_RIDGE * scale;
    let tol = QP_TOL * scale;
    let mut free = vec![false; k];
    free[start] = true;
    for _ in 0..(10 * k + 10) {
        let f: Vec<usize> = (0..k).filter(|&j| free[j]).collect();
        let Some(y) = equality_qp(g, k, &f, ridge) else {
            break;
        };
        let mut alpha = 1.0;
        let mut block = None;
        for (a, &j) in f.iter().enumerate() {
            if y[a] < 0.0 {
                let s = w[j] / (w[j] - y[a]);
                if s < alpha {
                    alpha = s;
                    block = Some(j);
                }
            }
        }
        for (a, &j) in f.iter().enumerate() {
            w[j] += alpha * (y[a] - w[j]);
        }
        if let Some(j) = block {
            w[j] = 0.0;
            free[j] = false;
            continue;
        }
        // Multipliers of the bounds not in F.
        let gw: Vec<f64> = (0..k)
            .map(|a| (0..k).map(|b| g[a * k + b] * w[b]).sum::<f64>() + ridge * w[a])
            .collect();
        let mu: f64 = (0..k).map(|a| w[a] * gw[a]).sum();
        let enter = (0..k)
            .filter(|&j| !free[j])
            .map(|j| (gw[j] - mu, j))
            .filter(|&(l, _)| l < -tol)
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        match enter {
            Some((_, j)) => free[j] = true,
            None => break,
        }
    }
    for x in &mut w {
        *x = x.max(0.0);
    }
    let s: f64 = w.iter().sum();
    if s > 0.0 {
        for x in &mut w {
            *x /= s;
        }
    }
    w
}

/// Minimiser of `yᵀ (G_FF + δI) y` subject to `Σ y = 1` (Cholesky of the
/// small dense block): `y = z / 1ᵀz` with `(G_FF + δI) z = 1`.
fn equality_qp(g: &[f64], k: usize, f: &[usize], ridge: f64) -> Option<Vec<f64>> {
    let m = f.len();
    let mut l = vec![0.0; m * m];
    for a in 0..m {
        for b in 0..=a {
            let mut s = g[f[a] * k + f[b]] + if a == b { ridge } else { 0.0 };
            for c in 0..b {
                s -= l[a * m + c] * l[b * m + c];
            }
            if a == b {
                if s.is_nan() || s <= 0.0 {
                    return None;
                }
                l[a * m + a] = s.sqrt();
            } else {
                l[a * m + b] = s / l[b * m + b];
            }
        }
    }
    let mut z = vec![1.0; m];
    for a in 0..m {
        for c in 0..a {
            z[a] -= l[a * m + c] * z[c];
        }
        z[a] /= l[a * m + a];
    }
    for a in (0..m).rev() {
        for c in a + 1..m {
            z[a] -= l[c * m + a] * z[c];
        }
        z[a] /= l[a * m + a];
    }
    let s: f64 = z.iter().sum();
    if !(s > 0.0 && s.is_finite()) {
        return None;
    }
    Some(z.into_iter().map(|x| x / s).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force over supports: the best feasible equality-constrained
    /// minimiser.
    fn brute(g: &[f64], k: usize) -> f64 {
        let mut best = f64::INFINITY;
        for mask in 1u32..(1 << k) {
            let f: Vec<usize> = (0..k).filter(|&j| mask & (1 << j) != 0).collect();
            if let Some(y) = equality_qp(g, k, &f, 0.0) {
                if y.iter().all(|&x| x >= -1e-12) {
                    let mut o = 0.0;
                    for (a, &ia) in f.iter().enumerate() {
                        for (b, &ib) in f.iter().enumerate() {
                            o += y[a] * y[b] * g[ia * k + ib];
                        }
                    }
                    best = best.min(o);
                }
            }
        }
        best
    }

    #[test]
    fn simplex_gram_matches_enumeration() {
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for k in 1..=6 {
            for _ in 0..50 {
                let rows = 6;
                let d: Vec<f64> = (0..rows * k).map(|_| rnd()).collect();
                let mut g = vec![0.0; k * k];
                for a in 0..k {
                    for b in 0..k {
                        g[a * k + b] = (0..rows).map(|r| d[r * k + a] * d[r * k + b]).sum();
                    }
                }
                let w = simplex_gram(&g, k);
                let mut o = 0.0;
                for a in 0..k {
                    for b in 0..k {
                        o += w[a] * w[b] * g[a * k + b];
                    }
                }
                assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                assert!(w.iter().all(|&x| x >= 0.0));
                let want = brute(&g, k);
                assert!(o <= want + 1e-9 * (1.0 + want), "k={k}: {o} vs {want}");
            }
        }
    }
}

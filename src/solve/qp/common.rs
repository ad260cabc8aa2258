//! Pieces shared by the QP solvers: the sparse matrix–vector product, the
//! Euclidean projection onto the probability simplex, the input check of
//! the active-set methods and the region growth of their local refinement.

use crate::solve::SparseMatrix;
use crate::{Error, Result};

/// Iterations allowed to one local refinement of [`BoxQp::solve`] (see
/// [`BoxQp::with_local_hops`]); a refinement that has not settled by then
/// hands its current active set to the next global iteration.
///
/// [`BoxQp::solve`]: super::BoxQp::solve
/// [`BoxQp::with_local_hops`]: super::BoxQp::with_local_hops
pub(super) const LOCAL_MAX_ITER: usize = 100;

/// Checks that `a` is square, finite, has a positive stored diagonal and is
/// symmetric (pattern and values, to `1e-12` relative); returns the diagonal.
pub(super) fn check_spd_candidate(a: &SparseMatrix, what: &str) -> Result<Vec<f64>> {
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

/// Marks in `region` the variables (rows) within `hops` steps of `A`'s
/// graph of `seeds` (clearing it first); `false` if that is more than half
/// of all (local refinement would then cost about a global iteration).
pub(super) fn grow_region(
    a: &SparseMatrix,
    hops: usize,
    seeds: &[usize],
    region: &mut [bool],
) -> bool {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}

//! Linear blend skinning (BDT Eq. 2) and its linear operator.
//!
//! `q_i = Σ_k W_ik T_k [p_i; 1]` with `T_k` a 3×4 affine transform. Written
//! per coordinate, the deformed positions (n × 3) are `Q = K · T` where
//! `K` (n × 4n_h) has `K_{i, 4k+j} = W_ik · [p_i; 1]_j` and the *stacked*
//! transforms `T` (4n_h × 3) hold `T_kᵀ` in rows `4k .. 4k+4`. This is the
//! 3n × 12n_h operator of the paper (Eq. 20's M) as `I₃ ⊗ K`, stored densely
//! because bounded biharmonic weights are dense.

use nalgebra::{DMatrix, Matrix3x4};

use crate::{Error, Point, Result};

/// A handle's affine transform `[A | t]` (3 × 4).
pub type Affine = Matrix3x4<f64>;

/// Applies linear blend skinning directly (no operator built).
/// `weights` is n × n_h; `transforms` has n_h entries.
pub fn lbs(rest: &[Point], weights: &DMatrix<f64>, transforms: &[Affine]) -> Result<Vec<Point>> {
    check_shapes(rest.len(), weights, transforms.len())?;
    Ok(rest
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let h = p.to_homogeneous();
            let mut q = nalgebra::Vector3::zeros();
            for (k, t) in transforms.iter().enumerate() {
                let w = weights[(i, k)];
                if w != 0.0 {
                    q += w * (t * h);
                }
            }
            Point::from(q)
        })
        .collect())
}

fn check_shapes(n: usize, weights: &DMatrix<f64>, n_transforms: usize) -> Result<()> {
    if weights.nrows() != n {
        return Err(Error::invalid(format!(
            "skinning weights have {} rows for {} vertices",
            weights.nrows(),
            n
        )));
    }
    if weights.ncols() != n_transforms {
        return Err(Error::invalid(format!(
            "skinning weights have {} columns for {} transforms",
            weights.ncols(),
            n_transforms
        )));
    }
    Ok(())
}

/// Stacks transforms into the 4n_h × 3 matrix `T` (rows `4k..4k+4` = `T_kᵀ`).
pub fn transforms_to_stacked(transforms: &[Affine]) -> DMatrix<f64> {
    let mut t = DMatrix::zeros(4 * transforms.len(), 3);
    for (k, a) in transforms.iter().enumerate() {
        for j in 0..4 {
            for d in 0..3 {
                t[(4 * k + j, d)] = a[(d, j)];
            }
        }
    }
    t
}

/// Inverse of [`transforms_to_stacked`].
pub fn transforms_from_stacked(t: &DMatrix<f64>) -> Result<Vec<Affine>> {
    if t.ncols() != 3 || t.nrows() % 4 != 0 {
        return Err(Error::invalid(format!(
            "stacked transforms must be 4n_h × 3, got {} × {}",
            t.nrows(),
            t.ncols()
        )));
    }
    Ok((0..t.nrows() / 4)
        .map(|k| Affine::from_fn(|d, j| t[(4 * k + j, d)]))
        .collect())
}

/// The LBS operator `K` (n × 4n_h) for fixed rest positions and weights.
#[derive(Clone, Debug)]
pub struct LbsMatrix {
    k: DMatrix<f64>,
}

impl LbsMatrix {
    /// Builds `K` from rest positions and n × n_h weights.
    pub fn new(rest: &[Point], weights: &DMatrix<f64>) -> Result<Self> {
        check_shapes(rest.len(), weights, weights.ncols())?;
        let (n, nh) = weights.shape();
        let k = DMatrix::from_fn(n, 4 * nh, |i, c| {
            let (h, j) = (c / 4, c % 4);
            let x = if j < 3 { rest[i][j] } else { 1.0 };
            weights[(i, h)] * x
        });
        Ok(LbsMatrix { k })
    }

    /// The dense operator `K` (n × 4n_h).
    pub fn matrix(&self) -> &DMatrix<f64> {
        &self.k
    }

    /// Number of handles.
    pub fn n_handles(&self) -> usize {
        self.k.ncols() / 4
    }

    /// Deformed positions (n × 3) `K · T` for stacked transforms `T`.
    pub fn apply_stacked(&self, t: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        if t.nrows() != self.k.ncols() || t.ncols() != 3 {
            return Err(Error::invalid(format!(
                "stacked transforms must be {} × 3, got {} × {}",
                self.k.ncols(),
                t.nrows(),
                t.ncols()
            )));
        }
        Ok(&self.k * t)
    }

    /// Deformed positions for per-handle transforms.
    pub fn apply(&self, transforms: &[Affine]) -> Result<Vec<Point>> {
        let q = self.apply_stacked(&transforms_to_stacked(transforms))?;
        Ok(points_from_matrix(&q))
    }
}

/// n × 3 matrix → points.
pub fn points_from_matrix(q: &DMatrix<f64>) -> Vec<Point> {
    (0..q.nrows())
        .map(|i| Point::new(q[(i, 0)], q[(i, 1)], q[(i, 2)]))
        .collect()
}

/// `Kᵀ` (4n_h × n) of the LBS operator built directly: column `i` holds
/// `W_ik [p_i; 1]` for every handle `k` (contiguous per vertex, the layout
/// the reduced ARAP precomputation works in). Errors on mismatched sizes.
pub fn lbs_operator_transposed(rest: &[Point], weights: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    check_shapes(rest.len(), weights, weights.ncols())?;
    let (n, nh) = weights.shape();
    let mut kt = DMatrix::zeros(4 * nh, n);
    for (i, col) in kt.as_mut_slice().chunks_exact_mut(4 * nh).enumerate() {
        let p = rest[i];
        for h in 0..nh {
            let w = weights[(i, h)];
            col[4 * h] = w * p.x;
            col[4 * h + 1] = w * p.y;
            col[4 * h + 2] = w * p.z;
            col[4 * h + 3] = w;
        }
    }
    Ok(kt)
}

/// Points → n × 3 matrix.
pub fn points_to_matrix(p: &[Point]) -> DMatrix<f64> {
    DMatrix::from_fn(p.len(), 3, |i, d| p[i][d])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::primitives::icosphere;

    #[test]
    fn operator_matches_direct_lbs() {
        let m = icosphere(1);
        let n = m.n_vertices();
        let w = DMatrix::from_fn(n, 3, |i, k| ((i * 7 + k * 3) % 5) as f64 + 0.5);
        let t: Vec<Affine> = (0..3)
            .map(|k| Affine::from_fn(|r, c| ((r + 2 * c + k) % 4) as f64 * 0.3 - 0.4))
            .collect();
        let a = lbs(m.vertices(), &w, &t).unwrap();
        let b = LbsMatrix::new(m.vertices(), &w).unwrap().apply(&t).unwrap();
        for (p, q) in a.iter().zip(&b) {
            assert!((p - q).norm() < 1e-12);
        }
        let back = transforms_from_stacked(&transforms_to_stacked(&t)).unwrap();
        assert_eq!(back, t);
    }
}

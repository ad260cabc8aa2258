//! The data every step reads ([`Problem`]: reference, aligned examples,
//! 1-ring graph, local non-rigidity) and the rigid fits: one rigid transform
//! ([`Rigid`]) and the blended Procrustes problem that fits it.

use nalgebra::Matrix3;
use rayon::prelude::*;

use super::V3;
use crate::ops::{polar_decomposition, Csr};
use crate::Result;

/// One rigid transform `x ↦ R x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Rigid {
    pub(super) r: Matrix3<f64>,
    pub(super) t: V3,
}

impl Rigid {
    pub(super) const IDENTITY: Rigid = Rigid {
        r: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        t: V3::new(0.0, 0.0, 0.0),
    };

    pub(super) fn apply(&self, p: &V3) -> V3 {
        self.r * p + self.t
    }
}

/// `argmin_{R ∈ SO(3), t} Σ_k ‖q_k − w_k (R p_k + t)‖²` over the items
/// `(p_k, q_k, w_k)` (see the module docs, step 3b; with `w = 1` plain
/// Kabsch). `None` when every weight is 0.
pub(super) fn blended_procrustes(items: &[(V3, V3, f64)]) -> Result<Option<Rigid>> {
    let sw2: f64 = items.iter().map(|(_, _, w)| w * w).sum();
    if sw2.is_nan() || sw2 <= 0.0 {
        return Ok(None);
    }
    let mut pbar = V3::zeros();
    let mut qbar = V3::zeros();
    for (p, q, w) in items {
        pbar += (w * w) * p;
        qbar += *w * q;
    }
    pbar /= sw2;
    qbar /= sw2;
    let mut m = Matrix3::zeros();
    for (p, q, w) in items {
        m += (*w * (q - *w * qbar)) * (p - pbar).transpose();
    }
    let r = polar_decomposition(&m)?.rotation;
    Ok(Some(Rigid {
        r,
        t: qbar - r * pbar,
    }))
}

/// The data every step reads: reference positions, aligned examples, the
/// 1-ring graph and the residual floor.
pub(super) struct Problem {
    pub(super) p: Vec<V3>,
    /// Aligned examples, `v[e][i]`.
    pub(super) v: Vec<Vec<V3>>,
    pub(super) nbr: std::sync::Arc<Csr>,
    /// Local non-rigidity of each vertex: mean residual of the best rigid
    /// fit of its closed 1-ring, summed over examples.
    pub(super) rho: Vec<f64>,
    pub(super) area: f64,
    /// Residuals (summed over examples) at or below this count as exact.
    pub(super) floor: f64,
}

impl Problem {
    pub(super) fn n(&self) -> usize {
        self.p.len()
    }

    pub(super) fn q(&self) -> usize {
        self.v.len()
    }

    /// `r_ib` for transforms `tr[e][b]`.
    pub(super) fn residual(&self, tr: &[Vec<Rigid>], i: usize, b: usize) -> f64 {
        let p = &self.p[i];
        tr.iter()
            .zip(&self.v)
            .map(|(t, v)| (t[b].apply(p) - v[i]).norm_squared())
            .sum()
    }

    /// rms in √area units of a total squared error.
    pub(super) fn rms(&self, e: f64) -> f64 {
        (e / (self.n() * self.q()) as f64).sqrt() / self.area.sqrt()
    }
}

/// Mean residual (summed over examples) of the best rigid fit of each
/// vertex's closed 1-ring.
pub(super) fn local_nonrigidity(p: &[V3], v: &[Vec<V3>], nbr: &Csr) -> Result<Vec<f64>> {
    (0..p.len())
        .into_par_iter()
        .map(|i| {
            let ring: Vec<usize> = std::iter::once(i)
                .chain(nbr.row(i).iter().copied())
                .collect();
            let mut total = 0.0;
            for ve in v {
                let items: Vec<(V3, V3, f64)> = ring.iter().map(|&j| (p[j], ve[j], 1.0)).collect();
                if let Some(t) = blended_procrustes(&items)? {
                    total += ring
                        .iter()
                        .map(|&j| (t.apply(&p[j]) - ve[j]).norm_squared())
                        .sum::<f64>();
                }
            }
            Ok(total / ring.len() as f64)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blended_procrustes_recovers_a_blend() {
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.5, 1.1).into_inner();
        let t = V3::new(0.5, -2.0, 1.0);
        let items: Vec<(V3, V3, f64)> = (0..20)
            .map(|k| {
                let p = V3::new((k as f64).sin(), (k as f64 * 0.7).cos(), k as f64 * 0.1);
                let w = 0.1 + 0.04 * k as f64;
                (p, w * (r * p + t), w)
            })
            .collect();
        let fit = blended_procrustes(&items).unwrap().unwrap();
        assert!((fit.r - r).norm() < 1e-10);
        assert!((fit.t - t).norm() < 1e-10);
    }
}

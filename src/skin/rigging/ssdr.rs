//! Step 3: the SSDR alternation ([`Soft`]) of per-vertex weights (step 3a,
//! [`vertex_weights`]) and Gauss–Seidel bone transforms (step 3b).

use rayon::prelude::*;

use super::clusters::Clusters;
use super::problem::{blended_procrustes, Problem, Rigid};
use super::simplex::simplex_gram;
use super::{CONVERGED, V3};
use crate::Result;

/// Soft state of the alternation (step 3).
#[derive(Clone)]
pub(super) struct Soft {
    /// Per vertex: `(bone, weight)`, sorted by bone, weights > 0.
    pub(super) w: Vec<Vec<(usize, f64)>>,
    /// `tr[e][b]`.
    pub(super) tr: Vec<Vec<Rigid>>,
    pub(super) bones: usize,
    /// Current E.
    pub(super) energy: f64,
    pub(super) iterations: usize,
}

impl Soft {
    pub(super) fn from_clusters(prob: &Problem, c: &Clusters) -> Self {
        let w = c.labels.iter().map(|&l| vec![(l, 1.0)]).collect();
        let mut s = Soft {
            w,
            tr: c.fits.clone(),
            bones: c.bones,
            energy: 0.0,
            iterations: 0,
        };
        s.energy = s.energies(prob).iter().sum();
        s
    }

    /// E of each example.
    fn energies(&self, prob: &Problem) -> Vec<f64> {
        prob.v
            .par_iter()
            .zip(&self.tr)
            .map(|(v, tr)| {
                (0..prob.n())
                    .map(|i| {
                        let x: V3 = self.w[i]
                            .iter()
                            .map(|&(b, w)| w * tr[b].apply(&prob.p[i]))
                            .sum();
                        (x - v[i]).norm_squared()
                    })
                    .sum()
            })
            .collect()
    }

    /// Up to `iters` alternations; stops early on convergence.
    pub(super) fn run(&mut self, prob: &Problem, k: usize, iters: usize) -> Result<()> {
        for _ in 0..iters {
            let before = self.energy;
            self.update_weights(prob, k);
            self.update_transforms(prob)?;
            self.iterations += 1;
            if before <= prob.floor * prob.n() as f64 || before - self.energy <= CONVERGED * before
            {
                break;
            }
        }
        Ok(())
    }

    /// Step 3a.
    fn update_weights(&mut self, prob: &Problem, k: usize) {
        let w = &self.w;
        let tr = &self.tr;
        // Dominant bones and the bones adjacent to each (sharing an edge).
        let dominant: Vec<usize> = w.iter().map(|row| dominant_bone(row)).collect();
        let mut adjacent = vec![Vec::new(); self.bones];
        for (i, row) in prob.nbr.rows().enumerate() {
            for &j in row {
                if dominant[i] != dominant[j] {
                    adjacent[dominant[i]].push(dominant[j]);
                }
            }
        }
        for a in &mut adjacent {
            a.sort_unstable();
            a.dedup();
        }
        let (dominant, adjacent) = (&dominant, &adjacent);
        let new: Vec<Vec<(usize, f64)>> = (0..prob.n())
            .into_par_iter()
            .map(|i| {
                let own = &w[i];
                let mut cands: Vec<usize> = own.iter().map(|&(b, _)| b).collect();
                for &j in prob.nbr.row(i) {
                    cands.extend(w[j].iter().map(|&(b, _)| b));
                }
                cands.extend(&adjacent[dominant[i]]);
                cands.sort_unstable();
                cands.dedup();
                if cands.len() == 1 {
                    return vec![(cands[0], 1.0)];
                }
                vertex_weights(prob, tr, i, own, cands, k)
            })
            .collect();
        self.w = new;
    }

    /// Step 3b.
    fn update_transforms(&mut self, prob: &Problem) -> Result<()> {
        let n = prob.n();
        let mut support: Vec<Vec<(usize, f64)>> = vec![Vec::new(); self.bones];
        for (i, row) in self.w.iter().enumerate() {
            for &(b, w) in row {
                support[b].push((i, w));
            }
        }
        let w = &self.w;
        let results: Vec<Result<(Vec<Rigid>, f64)>> = prob
            .v
            .par_iter()
            .zip(&self.tr)
            .map(|(v, tr)| {
                let mut tr = tr.clone();
                let mut recon: Vec<V3> = (0..n)
                    .map(|i| {
                        w[i].iter()
                            .map(|&(b, wb)| wb * tr[b].apply(&prob.p[i]))
                            .sum()
                    })
                    .collect();
                for (b, sup) in support.iter().enumerate() {
                    if sup.is_empty() {
                        continue;
                    }
                    let old = tr[b];
                    let items: Vec<(V3, V3, f64)> = sup
                        .iter()
                        .map(|&(i, wb)| {
                            let p = prob.p[i];
                            (p, v[i] - recon[i] + wb * old.apply(&p), wb)
                        })
                        .collect();
                    if let Some(t) = blended_procrustes(&items)? {
                        for &(i, wb) in sup {
                            let p = prob.p[i];
                            recon[i] += wb * (t.apply(&p) - old.apply(&p));
                        }
                        tr[b] = t;
                    }
                }
                let e: f64 = recon
                    .iter()
                    .zip(v)
                    .map(|(x, y)| (x - y).norm_squared())
                    .sum();
                Ok((tr, e))
            })
            .collect();
        let mut energy = 0.0;
        for (e, r) in results.into_iter().enumerate() {
            let (tr, x) = r?;
            self.tr[e] = tr;
            energy += x;
        }
        self.energy = energy;
        Ok(())
    }
}

/// Step 3a for vertex `i`: the best weights (≤ `k` bones) among the
/// candidate bones `cands` (sorted, containing the current support `own`).
fn vertex_weights(
    prob: &Problem,
    tr: &[Vec<Rigid>],
    i: usize,
    own: &[(usize, f64)],
    mut cands: Vec<usize>,
    k: usize,
) -> Vec<(usize, f64)> {
    let q = prob.q();
    let p = prob.p[i];
    // d_b = (R_b^e p_i + t_b^e − v_i^e)_e, flat: candidate a at a·q..(a+1)·q.
    let d_of = |b: usize| (0..q).map(move |e| tr[e][b].apply(&p) - prob.v[e][i]);
    let in_support = |b: usize| own.iter().any(|&(s, _)| s == b);
    let cap = (2 * k).max(own.len());
    if cands.len() > cap {
        // The current support first, then the smallest residuals.
        let mut keyed: Vec<(bool, f64, usize)> = cands
            .iter()
            .map(|&b| (!in_support(b), d_of(b).map(|x| x.norm_squared()).sum(), b))
            .collect();
        keyed.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2)));
        cands = keyed.into_iter().take(cap).map(|x| x.2).collect();
        cands.sort_unstable();
    }
    let c = cands.len();
    let d: Vec<V3> = cands.iter().flat_map(|&b| d_of(b)).collect();
    let dot = |a: usize, b: usize| -> f64 { (0..q).map(|e| d[a * q + e].dot(&d[b * q + e])).sum() };
    let mut g = vec![0.0; c * c];
    for a in 0..c {
        for b in a..c {
            let x = dot(a, b);
            g[a * c + b] = x;
            g[b * c + a] = x;
        }
    }
    let g = &g;
    let sub = |idx: &[usize]| -> Vec<f64> {
        idx.iter()
            .flat_map(|&a| idx.iter().map(move |&b| g[a * c + b]))
            .collect()
    };
    let objective = |idx: &[usize], x: &[f64]| -> f64 {
        let gs = sub(idx);
        let m = idx.len();
        (0..m)
            .map(|a| (0..m).map(|b| x[a] * x[b] * gs[a * m + b]).sum::<f64>())
            .sum()
    };
    let mut x = simplex_gram(g, c);
    let mut idx: Vec<usize> = (0..c).collect();
    if x.iter().filter(|&&v| v > 0.0).count() > k {
        let mut order: Vec<usize> = (0..c).collect();
        order.sort_by(|&a, &b| x[b].total_cmp(&x[a]).then(a.cmp(&b)));
        order.truncate(k);
        order.sort_unstable();
        x = simplex_gram(&sub(&order), order.len());
        idx = order;
        // Truncated: the QP on the current support (≤ K bones, all among
        // the candidates) bounds the result, so E cannot grow.
        let support: Vec<usize> = (0..c).filter(|&a| in_support(cands[a])).collect();
        let xs = simplex_gram(&sub(&support), support.len());
        if objective(&support, &xs) < objective(&idx, &x) {
            x = xs;
            idx = support;
        }
    }
    let sum: f64 = x.iter().filter(|&&v| v > 0.0).sum();
    idx.iter()
        .zip(&x)
        .filter(|(_, &v)| v > 0.0)
        .map(|(&a, &v)| (cands[a], v / sum))
        .collect()
}

/// The bone with the largest weight of a support (lower index on ties).
fn dominant_bone(row: &[(usize, f64)]) -> usize {
    let mut best = (f64::NEG_INFINITY, usize::MAX);
    for &(b, w) in row {
        if w > best.0 || (w == best.0 && b < best.1) {
            best = (w, b);
        }
    }
    best.1
}

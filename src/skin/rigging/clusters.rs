//! Step 1: hard rigid clustering ([`Clusters`]): one bone at the start,
//! bones added by splitting the worst one, boundary refinement, dropping of
//! tiny bones.

use rayon::prelude::*;

use super::problem::{blended_procrustes, Problem, Rigid};
use super::V3;
use crate::{Error, Result};

/// Refinement rounds after each split.
const REFINE_ROUNDS: usize = 6;
/// Old/new reassignment rounds inside a split bone.
const SPLIT_ROUNDS: usize = 4;
/// Vertices of a new bone's seed neighbourhood.
const SEED_SIZE: usize = 25;
/// A vertex changes bone only if its residual drops by this relative margin.
const HYSTERESIS: f64 = 1e-9;

/// Hard rigid clustering (step 1).
#[derive(Clone)]
pub(super) struct Clusters {
    pub(super) labels: Vec<usize>,
    pub(super) bones: usize,
    /// `fits[e][b]`.
    pub(super) fits: Vec<Vec<Rigid>>,
}

impl Clusters {
    pub(super) fn single(prob: &Problem) -> Result<Self> {
        let mut c = Clusters {
            labels: vec![0; prob.n()],
            bones: 1,
            fits: vec![vec![Rigid::IDENTITY]; prob.q()],
        };
        c.refit(prob, &[0])?;
        Ok(c)
    }

    fn members(&self) -> Vec<Vec<usize>> {
        let mut m = vec![Vec::new(); self.bones];
        for (i, &l) in self.labels.iter().enumerate() {
            m[l].push(i);
        }
        m
    }

    /// Refits the bones in `which` (Kabsch per example).
    fn refit(&mut self, prob: &Problem, which: &[usize]) -> Result<()> {
        let members = self.members();
        for &b in which {
            for (e, v) in prob.v.iter().enumerate() {
                let items: Vec<(V3, V3, f64)> =
                    members[b].iter().map(|&i| (prob.p[i], v[i], 1.0)).collect();
                if let Some(t) = blended_procrustes(&items)? {
                    self.fits[e][b] = t;
                }
            }
        }
        Ok(())
    }

    fn refit_all(&mut self, prob: &Problem) -> Result<()> {
        let all: Vec<usize> = (0..self.bones).collect();
        self.refit(prob, &all)
    }

    fn own_residuals(&self, prob: &Problem) -> Vec<f64> {
        (0..prob.n())
            .into_par_iter()
            .map(|i| prob.residual(&self.fits, i, self.labels[i]))
            .collect()
    }

    fn sizes(&self) -> Vec<usize> {
        let mut s = vec![0; self.bones];
        for &l in &self.labels {
            s[l] += 1;
        }
        s
    }

    /// Renumbers the bones that still have vertices to `0..B'` (in order),
    /// dropping the fits of the others.
    fn compact(&mut self) {
        let sizes = self.sizes();
        let mut map = vec![usize::MAX; self.bones];
        let mut next = 0;
        for b in 0..self.bones {
            if sizes[b] > 0 {
                map[b] = next;
                next += 1;
            }
        }
        for l in &mut self.labels {
            *l = map[*l];
        }
        for f in &mut self.fits {
            *f = (0..self.bones)
                .filter(|&b| map[b] != usize::MAX)
                .map(|b| f[b])
                .collect();
        }
        self.bones = next;
    }

    /// Whether `r_new` beats `r_old` by the hysteresis margin.
    fn better(prob: &Problem, r_new: f64, r_old: f64) -> bool {
        r_new < r_old - HYSTERESIS * r_old - prob.floor
    }

    /// Refinement rounds (module docs, step 1).
    fn refine(&mut self, prob: &Problem, min_size: usize) -> Result<()> {
        let n = prob.n();
        for _ in 0..REFINE_ROUNDS {
            let sizes = self.sizes();
            let labels = &self.labels;
            let fits = &self.fits;
            let proposals: Vec<usize> = (0..n)
                .into_par_iter()
                .map(|i| {
                    let own = labels[i];
                    let nb = prob.nbr.row(i);
                    if nb.iter().all(|&j| labels[j] == own) {
                        return own;
                    }
                    let mut cands: Vec<usize> = nb
                        .iter()
                        .map(|&j| labels[j])
                        .filter(|&l| l != own)
                        .collect();
                    cands.sort_unstable();
                    cands.dedup();
                    let isolated = sizes[own] > 1 && nb.iter().all(|&j| labels[j] != own);
                    let mut best = own;
                    let mut r_best = if isolated {
                        f64::INFINITY
                    } else {
                        prob.residual(fits, i, own)
                    };
                    for c in cands {
                        let r = prob.residual(fits, i, c);
                        if (best == own && Self::better(prob, r, r_best))
                            || (best != own && r < r_best)
                        {
                            best = c;
                            r_best = r;
                        }
                    }
                    best
                })
                .collect();
            let changed = proposals
                .iter()
                .zip(&self.labels)
                .filter(|(a, b)| a != b)
                .count();
            self.labels = proposals;
            let dropped = self.drop_tiny(prob, min_size);
            self.refit_all(prob)?;
            if changed * 1000 <= n && !dropped {
                break;
            }
        }
        Ok(())
    }

    /// Moves the vertices of bones smaller than `min_size` to the best bone
    /// among their neighbours' (or, failing that, all) surviving bones and
    /// compacts the numbering. Returns whether a bone was dropped.
    fn drop_tiny(&mut self, prob: &Problem, min_size: usize) -> bool {
        let sizes = self.sizes();
        let tiny: Vec<bool> = sizes.iter().map(|&s| s < min_size).collect();
        if !tiny.iter().any(|&t| t) {
            return false;
        }
        if tiny.iter().all(|&t| t) {
            // Cannot happen when min_size ≤ n / B; keep everything then.
            return false;
        }
        let survivors: Vec<usize> = (0..self.bones).filter(|&b| !tiny[b]).collect();
        let best_of = |i: usize, cands: &mut dyn Iterator<Item = usize>| {
            cands
                .map(|b| (prob.residual(&self.fits, i, b), b))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
                .map(|(_, b)| b)
        };
        let mut new = self.labels.clone();
        for (i, l) in new.iter_mut().enumerate() {
            if !tiny[*l] {
                continue;
            }
            let mut nb = prob
                .nbr
                .row(i)
                .iter()
                .map(|&j| self.labels[j])
                .filter(|&b| !tiny[b]);
            *l = best_of(i, &mut nb)
                .or_else(|| best_of(i, &mut survivors.iter().copied()))
                .unwrap_or(*l);
        }
        self.labels = new;
        self.compact();
        true
    }

    /// Splits the bone with the largest residual (module docs, step 1).
    /// Returns `false` when no bone can be split (too small, or every bone
    /// already exact).
    fn split_worst(&mut self, prob: &Problem, min_size: usize) -> Result<bool> {
        let res = self.own_residuals(prob);
        let sizes = self.sizes();
        let mut cost = vec![0.0; self.bones];
        for (i, &l) in self.labels.iter().enumerate() {
            cost[l] += res[i];
        }
        let worst = (0..self.bones)
            .filter(|&b| sizes[b] >= 2 * min_size.max(1))
            .filter(|&b| cost[b] > prob.floor * sizes[b] as f64)
            .max_by(|&a, &b| cost[a].total_cmp(&cost[b]).then(b.cmp(&a)));
        let Some(b) = worst else {
            return Ok(false);
        };
        let members: Vec<usize> = (0..prob.n()).filter(|&i| self.labels[i] == b).collect();
        let size = members.len();
        // The seed: the worst vertex among the locally more rigid half of
        // the bone (a blend region is not a bone).
        let mut rhos: Vec<f64> = members.iter().map(|&i| prob.rho[i]).collect();
        rhos.sort_by(f64::total_cmp);
        let median = rhos[rhos.len() / 2];
        let seed = members
            .iter()
            .copied()
            .filter(|&i| prob.rho[i] <= median)
            .max_by(|&i, &j| res[i].total_cmp(&res[j]).then(j.cmp(&i)))
            .ok_or_else(|| Error::numerical("split of an empty bone"))?;
        let m = SEED_SIZE.max(min_size).min(size - min_size.max(1));
        self.split_at(prob, b, seed, m, &members)?;
        Ok(true)
    }

    /// Splits bone `b` (vertices `members`) with a new bone seeded at the
    /// breadth-first neighbourhood (`m` vertices) of `seed`.
    fn split_at(
        &mut self,
        prob: &Problem,
        b: usize,
        seed: usize,
        m: usize,
        members: &[usize],
    ) -> Result<()> {
        let new = self.bones;
        self.bones += 1;
        for f in &mut self.fits {
            f.push(Rigid::IDENTITY);
        }
        let mut queue = std::collections::VecDeque::from([seed]);
        self.labels[seed] = new;
        let mut taken = 1;
        while let Some(i) = queue.pop_front() {
            if taken >= m {
                break;
            }
            for &j in prob.nbr.row(i) {
                if taken < m && self.labels[j] == b {
                    self.labels[j] = new;
                    taken += 1;
                    queue.push_back(j);
                }
            }
        }
        self.refit(prob, &[b, new])?;
        for _ in 0..SPLIT_ROUNDS {
            let proposals: Vec<usize> = members
                .par_iter()
                .map(|&i| {
                    let own = self.labels[i];
                    let other = if own == b { new } else { b };
                    let r_own = prob.residual(&self.fits, i, own);
                    let r_other = prob.residual(&self.fits, i, other);
                    if Self::better(prob, r_other, r_own) {
                        other
                    } else {
                        own
                    }
                })
                .collect();
            let mut changed = false;
            for (&i, &l) in members.iter().zip(&proposals) {
                changed |= self.labels[i] != l;
                self.labels[i] = l;
            }
            let sizes = self.sizes();
            if sizes[b] == 0 || sizes[new] == 0 {
                break;
            }
            self.refit(prob, &[b, new])?;
            if !changed {
                break;
            }
        }
        let sizes = self.sizes();
        if sizes[b] == 0 || sizes[new] == 0 {
            self.compact();
        }
        Ok(())
    }

    /// Splits and refines until there are `target` bones; returns whether
    /// the count grew.
    pub(super) fn grow_to(
        &mut self,
        prob: &Problem,
        target: usize,
        min_size: usize,
    ) -> Result<bool> {
        let start = self.bones;
        let mut attempts = 0;
        while self.bones < target && attempts < 2 * target + 4 {
            attempts += 1;
            if !self.split_worst(prob, min_size)? {
                break;
            }
            self.refine(prob, min_size)?;
        }
        Ok(self.bones > start)
    }
}

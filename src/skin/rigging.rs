//! Example-based skinning: bone weights and rigid bone transforms from a
//! reference mesh and deformed examples of it (the "skeleton" weights of
//! FBT Sec. 4.1/5, which takes them from Le & Deng 2014; the alternating
//! optimisation is Le & Deng 2012's SSDR, "Smooth skinning decomposition
//! with rigid bones").
//!
//! **Model.** Reference positions `p_i` (n vertices), examples `v_i^e`
//! (e = 1..q, same vertex order), B bones with one rigid transform
//! `(R_b^e, t_b^e)` (`R ∈ SO(3)`) per example, and per-vertex weights:
//!
//! ```text
//! v_i^e ≈ Σ_b w_ib (R_b^e p_i + t_b^e),   w_ib ≥ 0,  Σ_b w_ib = 1,  |{b : w_ib > 0}| ≤ K
//! E(w, R, t) = Σ_e Σ_i ‖Σ_b w_ib (R_b^e p_i + t_b^e) − v_i^e‖²
//! rms = √(E / (n q)) / √A          (A: area of the reference; "√area units")
//! ```
//!
//! **Steps** ([`example_skinning`]):
//!
//! 0. *Global alignment.* Each example is rigidly aligned onto the reference
//!    (Procrustes over all vertices, `v ↦ G_eᵀ(v − g_e)` with
//!    `(G_e, g_e) = argmin Σ_i ‖G p_i + g − v_i^e‖²`); everything below runs
//!    on the aligned examples and the transforms are mapped back at the end
//!    (`R ← G_e R`, `t ← G_e t + g_e`, exact because `Σ_b w_ib = 1`). This
//!    makes the weights independent of a rigid motion applied to every
//!    example.
//! 1. *Rigid clustering* (hard labels `l_i`, one rigid fit per cluster and
//!    example, `(R_b^e, t_b^e) = argmin Σ_{l_i = b} ‖R p_i + t − v_i^e‖²`,
//!    Kabsch with the proper-rotation fix). The vertex residual under bone b
//!    is `r_ib = Σ_e ‖R_b^e p_i + t_b^e − v_i^e‖²`. Bones are added one at a
//!    time, in the spirit of Le & Deng 2014's iterative clustering: starting
//!    from one bone, the bone with the largest residual `Σ_{l_i = b} r_ib`
//!    is split. The seed of the new bone is the vertex with the largest
//!    `r_ib` among the locally more rigid half of the bone — local
//!    non-rigidity `ρ_i` being the mean residual of the best rigid fit of
//!    the vertex's closed 1-ring over the examples — so that a new bone
//!    starts on a part that moves rigidly, not in a blend region. The new
//!    bone's transforms are fitted to the seed's breadth-first
//!    neighbourhood inside the bone (25 vertices); then the bone's vertices
//!    are reassigned between the old and the new bone by residual and both
//!    refitted, up to 4 rounds.
//!    *Refinement* (after every split): each vertex on a cluster boundary
//!    moves to the bone among its own and its 1-ring neighbours' bones with
//!    the smallest residual `r_ib` (only if smaller by a relative margin of
//!    1e-9, so exact ties keep their label); a vertex none of whose
//!    neighbours shares its label joins the best neighbouring bone (spatial
//!    coherence); bones with fewer than `min(4, n / B_max)` vertices are
//!    dropped; all bones are refitted. Restricting moves to neighbouring
//!    bones keeps the clusters spatially coherent and makes a round cost
//!    O(boundary · q) instead of O(n B q).
//! 2. *Bone count.* With `bones = Some(B)` the clusters are grown to B.
//!    Fewer than B bones are returned only when the examples have fewer
//!    distinct motions: every bone already reproduces its vertices exactly
//!    (residual ≤ 1e-20 · A · q per vertex), so no split can help; or a bone
//!    ends the alternation with no weight at all and is dropped. (A third,
//!    degenerate case: splits keep failing — the new bone loses all its
//!    vertices — until the budget of 2B + 4 attempts is spent.)
//!    With `bones = None`, after each split the SSDR alternation below is
//!    run for [`PROBE_ITERATIONS`] rounds from the clusters and its rms is
//!    recorded in [`Rig::bone_trace`]; growth stops at the first count whose
//!    rms is ≤ `tolerance`, or at `max_bones`, and that rig continues its
//!    alternation. The alternation never increases E, so the returned rms is
//!    ≤ the last trace entry.
//! 3. *Alternating optimisation (SSDR)*, from `w_i = e_{l_i}` and the
//!    cluster fits, `iterations` times or until E changes by less than
//!    [`CONVERGED`] relatively:
//!    - *(a) weights*, per vertex: the candidate bones are the vertex's
//!      current support, those of its 1-ring, and the bones adjacent to its
//!      dominant bone (dominant bones sharing a mesh edge) — at most `2K`
//!      of them, keeping the current support and then the smallest
//!      single-bone residuals. Supports thus stay local and spread by one
//!      ring per iteration; the adjacent bones let a blend start anywhere
//!      on a bone (TOSCA cat, 20 bones, 20 iterations: rms 0.00338 with
//!      them, 0.00404 without, for ~30% more time). With
//!      `d_b = (R_b^e p_i + t_b^e − v_i^e)_e ∈ R^{3q}` the vertex's term is
//!      `‖Σ_b w_b d_b‖²` (because `Σ w = 1`), so the weights solve
//!      `min wᵀ G w  s.t. w ≥ 0, 1ᵀw = 1` with `G_bc = d_b · d_c`, a tiny
//!      dense QP solved exactly by a primal active-set method
//!      ([`simplex_least_squares`]). If more than K weights are positive,
//!      the K largest are kept and the QP re-solved on them. The result is
//!      kept only if its objective is ≤ that of the QP on the current
//!      support, so the step never increases E.
//!    - *(b) transforms*, bone after bone (Gauss–Seidel), per example: with
//!      the other bones fixed, `q_i = v_i − Σ_{c≠b} w_ic (R_c p_i + t_c)`
//!      and `min_{R,t} Σ_i ‖q_i − w_ib (R p_i + t)‖²`, a weighted Procrustes
//!      problem (weights `w_ib²`, targets `q_i / w_ib`):
//!      `p̄ = Σ w² p / Σ w²`, `q̄ = Σ w q / Σ w²`,
//!      `M = Σ w (q − w q̄)(p − p̄)ᵀ`, `R = polar(M)` (det +1),
//!      `t = q̄ − R p̄` — SSDR's bone update, exact, so E does not increase.
//!
//! No spatial smoothing is applied to the weights: their locality comes from
//! the candidate rule of step 3a.
//!
//! **Determinism.** No random choice is made (ties go to the lower index).
//! Per-vertex work (reassignment, weights) runs in parallel but only reads
//! the previous state and is collected in vertex order; transforms are
//! solved per example in parallel, each example sequentially; sums are
//! reduced in a fixed order. Results do not depend on the thread count.
//!
//! **Units.** Every threshold is relative (to the reference area `A`, to a
//! residual, or to the QP's scale), so uniformly scaling the reference and
//! the examples leaves the weights unchanged.
//!
//! **Measured** (defaults; `cargo test --release --test rigging --
//! --ignored --nocapture`, 2 cores shared with other jobs, load 4–8):
//! TOSCA cat0 with cat1–8 as examples (27 894 vertices): 20 bones, rms
//! 0.0034, 5–7 s (a fixed count of 20: 1.3 s); FAUST subject 1 (tr_reg_012
//! with 017–019): 13 bones, rms 0.0039, 1 s; the synthetic creature class
//! (6 722 vertices, 10 poses): 12 bones, rms 0.0036, 0.7 s.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use rayon::prelude::*;

use crate::mesh::Mesh;
use crate::ops::{polar_decomposition, total_area, vertex_neighbours, Csr};
use crate::{Error, Result};

type V3 = Vector3<f64>;

/// SSDR alternations per candidate bone count when the count is automatic.
pub const PROBE_ITERATIONS: usize = 4;
/// Relative decrease of E below which the alternation stops.
pub const CONVERGED: f64 = 1e-5;
/// Refinement rounds after each split.
const REFINE_ROUNDS: usize = 6;
/// Old/new reassignment rounds inside a split bone.
const SPLIT_ROUNDS: usize = 4;
/// Vertices of a new bone's seed neighbourhood.
const SEED_SIZE: usize = 25;
/// Bones with fewer vertices are dropped (capped by `n / B_max`).
const MIN_BONE_VERTICES: usize = 4;
/// A vertex changes bone only if its residual drops by this relative margin.
const HYSTERESIS: f64 = 1e-9;
/// Residuals below `FLOOR · A · q` count as exact.
const FLOOR: f64 = 1e-20;
/// Relative ridge and multiplier tolerance of the simplex QP.
const QP_RIDGE: f64 = 1e-12;
const QP_TOL: f64 = 1e-11;

/// Options of [`example_skinning`]; [`Default`] holds the defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct RigOptions {
    /// Number of bones; `None`: grown until the rms is ≤ `tolerance` or the
    /// count reaches `max_bones`.
    pub bones: Option<usize>,
    /// Largest automatic bone count (capped by the vertex count).
    pub max_bones: usize,
    /// rms reconstruction error (√area units) at which the automatic bone
    /// count stops.
    pub tolerance: f64,
    /// K: most bones influencing one vertex.
    pub max_influences: usize,
    /// SSDR alternations (weights, then transforms) of the returned rig.
    pub iterations: usize,
}

impl Default for RigOptions {
    fn default() -> Self {
        RigOptions {
            bones: None,
            max_bones: 24,
            tolerance: 0.005,
            max_influences: 4,
            iterations: 20,
        }
    }
}

/// A skinning rig fitted to examples (see the module docs).
#[derive(Clone, Debug)]
pub struct Rig {
    /// n × B, entries ≥ 0, rows summing to 1, at most K nonzeros per row.
    pub weights: DMatrix<f64>,
    /// `transforms[e][b] = (R_b^e, t_b^e)`, `R` a proper rotation, in the
    /// frame of example e as given.
    pub transforms: Vec<Vec<(Matrix3<f64>, Vector3<f64>)>>,
    /// Dominant bone of each vertex (largest weight, lower index on ties).
    pub labels: Vec<usize>,
    /// rms reconstruction error over all examples, √area units.
    pub rms_error: f64,
    /// rms reconstruction error of each example, √area units.
    pub per_example_rms: Vec<f64>,
    /// SSDR alternations run for this rig.
    pub iterations: usize,
    /// `(bones, rms)` of each count tried when the count is automatic (the
    /// rms after [`PROBE_ITERATIONS`] alternations); one entry, the final
    /// one, for a fixed count.
    pub bone_trace: Vec<(usize, f64)>,
}

impl Rig {
    /// Number of bones B.
    pub fn bones(&self) -> usize {
        self.weights.ncols()
    }

    /// The rig's reconstruction of example `e`: `Σ_b w_ib (R_b^e p_i + t_b^e)`.
    pub fn pose(&self, reference: &Mesh, e: usize) -> Result<Vec<crate::Point>> {
        let tr = self.transforms.get(e).ok_or_else(|| {
            Error::invalid(format!(
                "example {e} not in the rig ({} examples)",
                self.transforms.len()
            ))
        })?;
        if reference.n_vertices() != self.weights.nrows() {
            return Err(Error::invalid(format!(
                "rig has {} vertices, the mesh {}",
                self.weights.nrows(),
                reference.n_vertices()
            )));
        }
        Ok(reference
            .vertices()
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let mut x = V3::zeros();
                for (b, (r, t)) in tr.iter().enumerate() {
                    let w = self.weights[(i, b)];
                    if w != 0.0 {
                        x += w * (r * p.coords + t);
                    }
                }
                crate::Point::from(x)
            })
            .collect())
    }
}

/// One rigid transform `x ↦ R x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rigid {
    r: Matrix3<f64>,
    t: V3,
}

impl Rigid {
    const IDENTITY: Rigid = Rigid {
        r: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        t: V3::new(0.0, 0.0, 0.0),
    };

    fn apply(&self, p: &V3) -> V3 {
        self.r * p + self.t
    }
}

/// `argmin_{R ∈ SO(3), t} Σ_k ‖q_k − w_k (R p_k + t)‖²` over the items
/// `(p_k, q_k, w_k)` (see the module docs, step 3b; with `w = 1` plain
/// Kabsch). `None` when every weight is 0.
fn blended_procrustes(items: &[(V3, V3, f64)]) -> Result<Option<Rigid>> {
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
struct Problem {
    p: Vec<V3>,
    /// Aligned examples, `v[e][i]`.
    v: Vec<Vec<V3>>,
    nbr: Csr,
    /// Local non-rigidity of each vertex: mean residual of the best rigid
    /// fit of its closed 1-ring, summed over examples.
    rho: Vec<f64>,
    area: f64,
    /// Residuals (summed over examples) at or below this count as exact.
    floor: f64,
}

impl Problem {
    fn n(&self) -> usize {
        self.p.len()
    }

    fn q(&self) -> usize {
        self.v.len()
    }

    /// `r_ib` for transforms `tr[e][b]`.
    fn residual(&self, tr: &[Vec<Rigid>], i: usize, b: usize) -> f64 {
        let p = &self.p[i];
        tr.iter()
            .zip(&self.v)
            .map(|(t, v)| (t[b].apply(p) - v[i]).norm_squared())
            .sum()
    }

    /// rms in √area units of a total squared error.
    fn rms(&self, e: f64) -> f64 {
        (e / (self.n() * self.q()) as f64).sqrt() / self.area.sqrt()
    }
}

/// Hard rigid clustering (step 1).
#[derive(Clone)]
struct Clusters {
    labels: Vec<usize>,
    bones: usize,
    /// `fits[e][b]`.
    fits: Vec<Vec<Rigid>>,
}

impl Clusters {
    fn single(prob: &Problem) -> Result<Self> {
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
    fn grow_to(&mut self, prob: &Problem, target: usize, min_size: usize) -> Result<bool> {
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

/// Soft state of the alternation (step 3).
#[derive(Clone)]
struct Soft {
    /// Per vertex: `(bone, weight)`, sorted by bone, weights > 0.
    w: Vec<Vec<(usize, f64)>>,
    /// `tr[e][b]`.
    tr: Vec<Vec<Rigid>>,
    bones: usize,
    /// Current E.
    energy: f64,
    iterations: usize,
}

impl Soft {
    fn from_clusters(prob: &Problem, c: &Clusters) -> Self {
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
    fn run(&mut self, prob: &Problem, k: usize, iters: usize) -> Result<()> {
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
fn simplex_gram(g: &[f64], k: usize) -> Vec<f64> {
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

/// Mean residual (summed over examples) of the best rigid fit of each
/// vertex's closed 1-ring.
fn local_nonrigidity(p: &[V3], v: &[Vec<V3>], nbr: &Csr) -> Result<Vec<f64>> {
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

/// Example-based skinning (see the module docs for the model and the steps).
///
/// `examples` are deformed poses of `reference` with the same vertex order
/// (their faces are not used). Errors (naming the problem) when there is no
/// example, a vertex count differs, a coordinate or the reference area is
/// not finite (or the area is 0), `bones` is 0 or exceeds the vertex count,
/// `max_bones` or `max_influences` is 0, or `tolerance` is negative or not
/// finite.
pub fn example_skinning(reference: &Mesh, examples: &[Mesh], opts: &RigOptions) -> Result<Rig> {
    let n = reference.n_vertices();
    if examples.is_empty() {
        return Err(Error::invalid(
            "example skinning needs at least one example pose",
        ));
    }
    for (e, m) in examples.iter().enumerate() {
        if m.n_vertices() != n {
            return Err(Error::invalid(format!(
                "example {e} has {} vertices, the reference {n}",
                m.n_vertices()
            )));
        }
    }
    for (name, m) in std::iter::once(("reference".to_string(), reference)).chain(
        examples
            .iter()
            .enumerate()
            .map(|(e, m)| (format!("example {e}"), m)),
    ) {
        if let Some(i) = m
            .vertices()
            .iter()
            .position(|p| p.iter().any(|x| !x.is_finite()))
        {
            return Err(Error::invalid(format!(
                "{name} has a non-finite coordinate at vertex {i}"
            )));
        }
    }
    if let Some(b) = opts.bones {
        if b == 0 || b > n {
            return Err(Error::invalid(format!(
                "cannot fit {b} bones to {n} vertices"
            )));
        }
    }
    if opts.max_bones == 0 {
        return Err(Error::invalid("max_bones must be at least 1"));
    }
    if opts.max_influences == 0 {
        return Err(Error::invalid(
            "max_influences must be at least 1 bone per vertex",
        ));
    }
    if !(opts.tolerance >= 0.0 && opts.tolerance.is_finite()) {
        return Err(Error::invalid(format!(
            "tolerance must be finite and ≥ 0, got {}",
            opts.tolerance
        )));
    }
    let area = total_area(reference);
    if !(area > 0.0 && area.is_finite()) {
        return Err(Error::invalid(format!(
            "the reference's area is {area}; example skinning measures errors in √area units"
        )));
    }
    let p: Vec<V3> = reference.vertices().iter().map(|x| x.coords).collect();
    // Step 0: align every example onto the reference.
    let mut align = Vec::with_capacity(examples.len());
    let mut v = Vec::with_capacity(examples.len());
    for m in examples {
        let items: Vec<(V3, V3, f64)> = p
            .iter()
            .zip(m.vertices())
            .map(|(a, b)| (*a, b.coords, 1.0))
            .collect();
        let g = blended_procrustes(&items)?.unwrap_or(Rigid::IDENTITY);
        v.push(
            m.vertices()
                .iter()
                .map(|x| g.r.transpose() * (x.coords - g.t))
                .collect::<Vec<V3>>(),
        );
        align.push(g);
    }
    let q = examples.len();
    let nbr = vertex_neighbours(reference);
    let rho = local_nonrigidity(&p, &v, &nbr)?;
    let prob = Problem {
        p,
        v,
        nbr,
        rho,
        area,
        floor: FLOOR * area * q as f64,
    };
    let k = opts.max_influences;
    let mut clusters = Clusters::single(&prob)?;
    let (soft, trace) = match opts.bones {
        Some(b) => {
            let min_size = MIN_BONE_VERTICES.min(n / b).max(1);
            clusters.grow_to(&prob, b, min_size)?;
            let mut soft = Soft::from_clusters(&prob, &clusters);
            soft.run(&prob, k, opts.iterations)?;
            let entry = (soft.bones, prob.rms(soft.energy));
            (soft, vec![entry])
        }
        None => {
            let max_bones = opts.max_bones.min(n);
            let min_size = MIN_BONE_VERTICES.min(n / max_bones).max(1);
            let probe = opts.iterations.min(PROBE_ITERATIONS);
            let mut trace = Vec::new();
            let mut soft = loop {
                let mut soft = Soft::from_clusters(&prob, &clusters);
                soft.run(&prob, k, probe)?;
                let rms = prob.rms(soft.energy);
                trace.push((soft.bones, rms));
                if rms <= opts.tolerance
                    || clusters.bones >= max_bones
                    || !clusters.grow_to(&prob, clusters.bones + 1, min_size)?
                {
                    break soft;
                }
            };
            let rest = opts.iterations - soft.iterations;
            soft.run(&prob, k, rest)?;
            (soft, trace)
        }
    };
    finish(reference, examples, &prob, &align, soft, trace)
}

/// Maps the transforms back to the examples' frames, drops bones without
/// weight and measures the errors against the examples as given.
fn finish(
    reference: &Mesh,
    examples: &[Mesh],
    prob: &Problem,
    align: &[Rigid],
    soft: Soft,
    trace: Vec<(usize, f64)>,
) -> Result<Rig> {
    let n = prob.n();
    let mut used = vec![false; soft.bones];
    for row in &soft.w {
        for &(b, _) in row {
            used[b] = true;
        }
    }
    let mut map = vec![usize::MAX; soft.bones];
    let mut bones = 0;
    for b in 0..soft.bones {
        if used[b] {
            map[b] = bones;
            bones += 1;
        }
    }
    let mut weights = DMatrix::zeros(n, bones);
    let mut labels = Vec::with_capacity(n);
    for (i, row) in soft.w.iter().enumerate() {
        let mut best = (f64::NEG_INFINITY, usize::MAX);
        for &(b, w) in row {
            weights[(i, map[b])] = w;
            if w > best.0 || (w == best.0 && map[b] < best.1) {
                best = (w, map[b]);
            }
        }
        labels.push(best.1);
    }
    let transforms: Vec<Vec<(Matrix3<f64>, Vector3<f64>)>> = soft
        .tr
        .iter()
        .zip(align)
        .map(|(tr, g)| {
            (0..soft.bones)
                .filter(|&b| used[b])
                .map(|b| (g.r * tr[b].r, g.r * tr[b].t + g.t))
                .collect()
        })
        .collect();
    let mut rig = Rig {
        weights,
        transforms,
        labels,
        rms_error: 0.0,
        per_example_rms: Vec::new(),
        iterations: soft.iterations,
        bone_trace: trace,
    };
    let mut total = 0.0;
    for (e, m) in examples.iter().enumerate() {
        let x = rig.pose(reference, e)?;
        let err: f64 = x
            .iter()
            .zip(m.vertices())
            .map(|(a, b)| (a - b).norm_squared())
            .sum();
        total += err;
        rig.per_example_rms
            .push((err / n as f64).sqrt() / prob.area.sqrt());
    }
    rig.rms_error = prob.rms(total);
    Ok(rig)
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

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
//!
//! **Code layout.** This file holds the options, the [`Rig`] and the driver
//! ([`example_skinning`]: checks, step 0, bone count, mapping back);
//! `problem` the shared data and the rigid fits, `clusters` step 1,
//! `ssdr` step 3, `simplex` the per-vertex weight QP
//! ([`simplex_least_squares`]).

mod clusters;
mod problem;
mod simplex;
mod ssdr;

use nalgebra::{DMatrix, Matrix3, Vector3};

use self::clusters::Clusters;
use self::problem::{blended_procrustes, local_nonrigidity, Problem, Rigid};
use self::ssdr::Soft;
use crate::mesh::Mesh;
use crate::ops::total_area;
use crate::ops::Operators;
use crate::{Error, Result};

pub use self::simplex::simplex_least_squares;

type V3 = Vector3<f64>;

/// SSDR alternations per candidate bone count when the count is automatic.
pub const PROBE_ITERATIONS: usize = 4;
/// Relative decrease of E below which the alternation stops.
pub const CONVERGED: f64 = 1e-5;
/// Bones with fewer vertices are dropped (capped by `n / B_max`).
const MIN_BONE_VERTICES: usize = 4;
/// Residuals below `FLOOR · A · q` count as exact.
const FLOOR: f64 = 1e-20;

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
    let nbr = reference.neighbours();
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

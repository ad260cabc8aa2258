//! Bounded biharmonic weights (BDT Eq. 1; Jacobson et al. 2011).
//!
//! For point handles `h_1..h_{n_h}` (mesh vertex indices) the weights
//! minimise the discrete biharmonic energy `Σ_k ½ w_kᵀ Q w_k` with
//! `Q = L M⁻¹ L` (positive semi-definite cotangent Laplacian `L`, Voronoi
//! mass `M`), subject to interpolation `w_k(h_j) = δ_jk`, bounds
//! `0 ≤ w ≤ 1` and partition of unity `Σ_k w_k = 1`.
//!
//! The handle rows are fixed, so every mode solves on the free vertices `f`
//! with `Q_ff` (positive definite as soon as every connected component holds
//! a handle) and linear term `B = Q_fh`:
//!
//! * [`WeightMode::Unbounded`] — equality constraints only:
//!   `W_f = −Q_ff⁻¹ Q_fh`, one factorisation, all handles as right-hand sides.
//!   Since `Q 1 = 0`, these sum to one exactly (up to rounding).
//! * [`WeightMode::PerHandle`] — each `w_k` separately with `0 ≤ w_k ≤ 1`
//!   (no partition of unity), then rows normalised to sum to one (the common
//!   practice, and what libigl's `bbw` + `normalize_row_sums` does). Solved by
//!   the primal–dual active-set method of [`crate::solve::qp::BoxQp`] (the
//!   iteration of libigl's `active_set`), started from the active set of the
//!   unbounded weights. Every iteration factorises only the free block
//!   `Q_FF`, in the order induced by one AMD ordering of `Q_ff` computed
//!   once per handle set (no ordering per iteration; the cost shrinks with
//!   the free set). The handles are solved in parallel on rayon's current
//!   pool, each solve sequential, so the weights do not depend on the thread
//!   count (bitwise; tested). An ADMM warm start of the active sets is
//!   optional ([`BbwOptions::admm`], off by default).
//!   [`Biharmonic::weights_from`] starts every handle that an earlier
//!   solve on a nearby handle set also had from where that solve's active
//!   set ended ([`ActiveSetStart`]); key point selection uses it for its
//!   exact trials, which differ from the current key points in one handle.
//!   Measured on the 27k-vertex synthetic subject (4 key points + one, 1
//!   thread): the shared handles took 8, 1, 1, 8 iterations instead of 239,
//!   67, 110, 252 (the new handle 84 either way), 3.9 s instead of 23.2 s;
//!   for a swapped handle the gain is smaller and can be negative for one
//!   handle (110, 376, 88, 91 instead of 267, 340, 179, 91). Same optimum
//!   to the tolerance (within 3e-7 there; tested).
//! * [`WeightMode::Coupled`] — the coupled problem of Eq. 1, all weights
//!   together, solved exactly by [`crate::solve::qp::simplex_rows_qp`]: a
//!   primal–dual active-set method on the row supports `S_i = {k : w_ik > 0}`;
//!   for fixed supports the partition of unity is eliminated row by row
//!   (one support entry = 1 − the others), leaving one sparse SPD system of
//!   `Σ_i (|S_i| − 1)` unknowns per iteration, assembled in one AMD ordering
//!   of `Q_ff`. Started from the normalised PerHandle weights moved by
//!   [`BbwOptions::coupled_admm_iter`] ADMM iterations on the coupled
//!   problem, with entries ≤ [`BbwOptions::coupled_support_threshold`]
//!   dropped (a support that is nearly right). Interpolation, bounds and
//!   partition of unity hold exactly; optimality to the KKT tolerance [`BbwOptions::coupled_tol`],
//!   or the support iteration stops once a global iteration moves no weight
//!   by more than [`BbwOptions::coupled_step_tol`].
//!
//! **What was chosen and why.** The measurements (7k vertices: a
//! generic interior-point solver 4–5 s per handle, one equality-only sparse
//! Cholesky solve 0.07 s) point to a bound-constrained method that reuses
//! factorisation work; an active set needs only sparse Cholesky solves and
//! ends at the exact active set, so it was chosen for both modes. Tried and
//! not chosen:
//!
//! * ADMM for Coupled (simplex projection, `D = M` or `D = diag Q_ff`,
//!   residual balancing): residuals fell below 1e-6 while the energy was
//!   still 20–40 % above that of the normalised PerHandle weights (a
//!   feasible point), and a certified duality gap stayed at ~40 % after
//!   4000 iterations: `Q = L M⁻¹ L` is too ill-conditioned for a
//!   first-order method. ADMM remains only as an optional warm start of
//!   PerHandle: 100 iterations cut the active-set iterations by about 30 %
//!   but cost about as much CPU time as they saved (an earlier A/B run, not
//!   re-measured), so it is off by default.
//! * Refactorising the full-size pattern with the active rows replaced by
//!   identity (one symbolic factorisation reused; the previous version
//!   here): every iteration then costs a full factorisation, while the free
//!   block in the induced order gets cheaper as the active set grows (a
//!   50 % subset factorised in about a third of the full time on FAUST, in
//!   an earlier micro-benchmark). Not A/B-tested under equal load: the
//!   previous version measured 0.9–1.4 s per handle wall in earlier runs.
//! * The multiplier test is per row, `|g_i| > tol·Q_ii` (scale-free): a
//!   global scale (`tol·max|b|`) stopped early with wrong active sets on
//!   FAUST because `Q_ii` varies over orders of magnitude with the triangle
//!   sizes. `tol = 1e-10` is the default (within 1e-6 of a tight solve;
//!   see [`BbwOptions::tol`]); 1e-6 moved the weights by 4e-3.
//!
//! **Measured** (`deformlab bench bbw`: FAUST `tr_reg_001`, 6890 vertices,
//! 10 FPS handles, release build, medians of 3 runs; the 1-thread Coupled
//! row is one run). The machine has 2 cores shared with other engineers'
//! compilations, so wall times are inflated and noisy: two runs of the
//! benchmark, at load averages 3.8 and 7.6 (the second while this crate
//! was compiling), gave
//!
//! | mode | wall s / handle, 1 thread | 2 threads | CPU s / handle | active-set iterations |
//! |---|---|---|---|---|
//! | Unbounded | 0.010 (0.047) | – | 0.007 | – (1 factorisation) |
//! | PerHandle | 0.54 (2.13) | 0.64 (1.60) | 0.34–0.36 | 14–38–69 per handle (min–median–max); 351 factorisations |
//! | Coupled | 2.16 (10.6) | 2.66 (10.2) | 0.55–1.8 | PerHandle's, then 33 support iterations (25 426 unknowns); 384 factorisations |
//!
//! (the run at load 3.8; in parentheses the run at load 7.6). Two threads
//! did not help on this loaded 2-core machine. The CPU time of Coupled is
//! not steady (5.5 s and 18 s for the same 1-thread solve in the two runs;
//! not understood), PerHandle's is (3.4–3.6 s in all four rows).
//!
//! KKT residuals: 1.4e-8 (PerHandle, before normalisation), 5.2e-8
//! (Coupled). For comparison, libigl 2.6.3's `igl.bbw` (Python wheel, its
//! defaults, no partition of unity, 1 thread) on the same mesh and handles:
//! 2.2 s per handle wall (median of 3, load 3.4), in a later run 3.2 s wall
//! and 1.55 s CPU per handle (load 8.1), 13–96 iterations per handle — so
//! PerHandle uses about 4× less CPU than libigl here; the 0.21 s per
//! handle for libigl was not reproduced under this load, and we do not claim
//! to beat it. PerHandle's weights before normalisation differ from
//! libigl's by at most 3.6e-6 (2.7e-7 with `tol = 1e-11`), and the summed
//! energies agree to 3e-9 relative (scratch comparison outside the
//! repository). With 6 FPS handles the normalised weights differed by
//! 3.4e-4 on FAUST at the former `tol = 1e-8` (`results/bench/`): the
//! per-vertex stopping test of [`BbwOptions::tol`] left bands with small
//! optimal weights at the bound. At today's 1e-10 they are within 9.1e-7
//! of a 1e-13 solve on FAUST and 5.3e-7 on TOSCA cat0, where libigl's are
//! 1.6e-3 from it (its KKT residual 2.8e-6; 2026-12-05). Coupled at
//! 2.2–2.7 s per handle (wall, load 3.8) is inside BDT's Table 1 range
//! (0.45–4.2 s per handle, smaller meshes), not under heavier load.

use std::time::Instant;

use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::mesh::Mesh;
use crate::ops::MassKind;
use crate::ops::Operators;

use crate::solve::qp::{
    project_to_simplex, simplex_rows_qp, AdmmOptions, AdmmSolution, BoxQp, BoxQpSolution, RowAdmm,
    RowConstraint, SimplexQpOptions,
};
use crate::solve::{progress, sparse_from_triplets, SparseCholesky, SparseMatrix};
use crate::{Error, Result};

/// Which weights to compute (see the module documentation).
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Default,
    serde::Deserialize,
    serde::Serialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
pub enum WeightMode {
    /// BDT Eq. 1: bounds and partition of unity enforced together (active
    /// set on the row supports, started from the PerHandle weights).
    Coupled,
    /// Bounds per handle (active set), then rows normalised to sum to one.
    /// The library's default ([`BbwOptions::default`]).
    #[default]
    #[value(
        help = "Bounds per handle (active set), then rows normalised to sum to one (the default)"
    )]
    PerHandle,
    /// Biharmonic weights with the interpolation constraints only (ablation);
    /// they sum to one but may leave [0, 1].
    #[value(skip)]
    #[serde(skip)]
    Unbounded,
}

/// Options of [`Biharmonic::weights`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BbwOptions {
    /// Which problem to solve. The one default of the library, `deformlab
    /// weights`, `deformlab keypoints` / `transfer` (`--weights`), the
    /// configs (`weights`) and Python (`dl.bbw`, `dl.transfer`):
    /// [`WeightMode::PerHandle`], chosen on the FAUST cross-subject
    /// benchmark (`experiments/real/bdt-faust.toml`, `coupled` row;
    /// `docs/bdt-defaults.md`) and on the synthetic Fig. 14 cases, where
    /// coupled weights transferred no better at several times the cost.
    pub mode: WeightMode,
    /// Active-set iterations allowed: per handle (PerHandle), and again for
    /// the coupled support iteration (Coupled). Not settling is an error
    /// unless [`BbwOptions::accept_unconverged`] is set. Without local
    /// refinement ([`BbwOptions::local_hops`] = 0) the supports grow by a
    /// few rings per iteration (`Q` couples two rings), so the count grows
    /// with resolution: a per-handle set needed 38 iterations at 6.9k
    /// vertices (FAUST), 207 at 27k (synthetic, resolution 3; the earlier
    /// default 200 failed there) and 429 at 108k; with it, 6 and 11 at 6.9k
    /// and 27k, and 95 at 108k (6 FPS handles, 2026-12-03). The default
    /// 1000 is a guard against cycling, not a budget: a converging solve
    /// stops earlier.
    pub max_iter: usize,
    /// Active-set tolerance of [`WeightMode::PerHandle`], in weight units:
    /// a bound may be violated by at most `tol` before the vertex is fixed,
    /// and a fixed vertex is released when its multiplier `g_i` would move
    /// it by more than `tol` on its own (`|g_i| > tol·Q_ii`, wrong sign).
    /// Results are clamped to the bounds. The test is per vertex and `Q` is
    /// ill-conditioned, so a band of vertices whose optimum is small but
    /// positive can stay at the bound although each multiplier passes the
    /// test: the weights' distance to a tight solve is far above `tol`.
    /// Measured 2026-12-05 (6 FPS handles, normalised weights, max |ΔW| to
    /// a 1e-13 solve whose KKT residual is 1e-13; CPU s on one thread;
    /// `igl.bbw` 4.8 s at 6.9k, 69.5 s at 28k):
    ///
    /// | tol | FAUST 6.9k: max \|ΔW\| | CPU s | TOSCA cat0 28k: max \|ΔW\| | CPU s |
    /// |---|---|---|---|---|
    /// | 1e-8 (the default until then) | 3.4e-4 | 0.31 | – | 6.2 |
    /// | 1e-9 | 3.7e-6 | 0.44 | 9.2e-6 | 9.2 |
    /// | **1e-10** | 9.1e-7 | 0.55 | 5.3e-7 | 11.6 |
    /// | 1e-13 | 0 | 0.72 | 0 | 24.3 |
    ///
    /// 1e-10, the default, stays within 1e-6 of the tight solve at 0.11×
    /// and 0.17× `igl.bbw`'s CPU time. (`igl.bbw` itself is 4.8e-7 from it
    /// at 6.9k but 1.6e-3 at 28k, KKT residual 2.8e-6: it stopped early.)
    /// 1e-6 moves weights by 4e-3.
    pub tol: f64,
    /// Active-set tolerance of [`WeightMode::Coupled`], in both of its
    /// stages (the per-handle warm start and the support iteration; the
    /// test of the latter is the same per-row test as `tol`'s). Kept at
    /// 1e-8: tightening it to 1e-10 doubles the coupled solve (FAUST 6.9k,
    /// 6 FPS handles: 4.6 → 9.5 s CPU, weights 8.2e-5 → 7.1e-7 from a
    /// 1e-13 solve), and Coupled is not the default mode.
    pub coupled_tol: f64,
    /// Step test of the coupled support iteration
    /// ([`crate::solve::qp::SimplexQpOptions::step_tol`]): it also stops
    /// when a global iteration moved no weight by more than this. 0 stops
    /// only when the supports no longer change.
    ///
    /// Why: on some meshes the iteration ends with many global iterations
    /// (each a factorisation of the whole reduced system) that join a few
    /// entries whose multipliers sit at the tolerance and move the weights
    /// by less than 1e-6, while the tolerance itself leaves the weights
    /// 1e-4 from the optimum. Measured 2026-12-06 (6 FPS handles, one
    /// thread; support iterations, CPU s of the whole solve, max |ΔW| to
    /// the solve without the test and to a 1e-13 solve; one run each
    /// beside another one-thread job):
    ///
    /// | mesh | 0 (before) | 1e-7 | **1e-6** | 1e-5 |
    /// |---|---|---|---|---|
    /// | FAUST 001 | 33, 4.97 s; 8.21e-5 from tight | 27, 4.38 s; 1.9e-7; 8.21e-5 | 19, 3.91 s; 1.5e-6; 8.22e-5 | 13, 2.84 s; 2.8e-5; 9.41e-5 |
    /// | FAUST 033 | 26, 3.62 s; 1.8e-6 | 26; 0 | 26; 0 | 26; 0 |
    /// | FAUST 050 | 18, 2.31 s; 1.24e-4 | 18; 0 | 18; 0 | 17; 2.8e-7 |
    /// | FAUST 075 | 14, 2.05 s; 3.3e-6 | 14; 0 | 13, 1.79 s; 2.7e-8; 3.3e-6 | 8, 1.45 s; 8.7e-6; 1.2e-5 |
    /// | synthetic 27k | 10, 17.7 s | – | 10; 0 | – |
    /// | TOSCA cat0 28k | 33, 57.5 s; 5.6e-4 | – | 33; 0 | – |
    ///
    /// 1e-6, the default, moves no weight by more than 1.5e-6 and none
    /// further from the optimum by more than 1e-7; 1e-5 moved them by
    /// 2.8e-5. Elsewhere the last iterations move the weights by more, and
    /// the test does not fire.
    pub coupled_step_tol: f64,
    /// Coupled: ADMM iterations on BDT Eq. 1 itself (rows on the simplex,
    /// one factorisation of `Q_ff + ρ diag Q_ff`, all handles at once)
    /// between the per-handle stage and the support iteration; the support
    /// iteration then starts from the supports of the ADMM iterate (entries
    /// at or below [`BbwOptions::coupled_support_threshold`] dropped). 0
    /// starts it from the normalised per-handle weights, as before
    /// 2026-12-06. Only the start changes; the stopping tests are the same.
    ///
    /// Why: the normalised per-handle weights are the coupled optimum's
    /// supports shrunk or shifted by up to a few rings along every support
    /// boundary, and the support iteration moves a boundary by about one
    /// step of `Q`'s graph per global iteration. A few ADMM iterations (each
    /// a pair of triangular solves) move the supports most of the way at
    /// FAUST size. Measured 2026-12-06 (`deformlab weights MESH --handles 6
    /// --weights coupled`, one thread pinned, CPU s of the whole solve, one
    /// run each beside a one-thread job on the other core):
    ///
    /// | mesh | 0 (before) | 10 | **20** | 50 | 100 |
    /// |---|---|---|---|---|---|
    /// | FAUST 001 | 3.44 (19 support it.) | – | 1.79 (12) | 1.90 (12) | 1.66 (10) |
    /// | FAUST 010 | 2.00 | 2.01 | 2.02 | – | – |
    /// | FAUST 013 | 4.61 | 4.28 | 4.06 | – | – |
    /// | FAUST 033 | 3.62 (26) | – | 3.42 (24) | 3.75 (23) | 3.56 (23) |
    /// | FAUST 036 | 1.56 | 1.37 | 1.44 | – | – |
    /// | FAUST 050 | 2.34 (18) | – | 0.83 (5) | 0.91 (5) | 1.00 (5) |
    /// | FAUST 057 | 3.15 | 3.10 | 3.24 | – | – |
    /// | FAUST 075 | 1.88 (13) | – | 1.53 (10) | 1.68 (10) | 1.87 (10) |
    /// | FAUST 092 | 3.84 | 3.09 | 2.81 | – | – |
    /// | FAUST 097 | 2.74 | 2.77 | 2.64 | – | – |
    /// | TOSCA cat0 (28k) | 62.6 (33) | – | 65.9 (36) | 66.9 (36) | 68.7 (37) with 200, 64.6 (35) with 600 |
    /// | cat0, side by side (two pairs, cores swapped) | 66.6, 63.2 (33) | – | 73.4, 70.3 (36) | – | – |
    /// | synthetic 27k | 39.3 | – | 40.7 | – | – |
    /// | synthetic creature 0 (27k) | 37.6 | – | 38.3 | – | – |
    ///
    /// 20, the default: FAUST total 29.2 → 23.2 s (geometric mean of the
    /// ratios 0.78), the 27k–28k meshes 2–11 % slower (cat0 side by side:
    /// +11 %; more ADMM iterations do not help there: their supports grow
    /// by a third during the support iteration, further than ADMM moves
    /// them); over all 13 meshes the geometric mean ratio is 0.84. The
    /// project's real benchmarks are FAUST-sized, hence 20; on meshes of
    /// 27k vertices and more, 0 is about 10 % faster. The weights stay
    /// within the coupled tolerance's own gap: on FAUST 001 8.1e-5 from the start without
    /// ADMM and 1.6e-5 from a 1e-13 solve (the start without ADMM: 8.2e-5).
    pub coupled_admm_iter: usize,
    /// Optional ADMM warm start (box constraints, all handles at once, one
    /// factorisation) for the initial active sets of the per-handle solves:
    /// `admm.max_iter` iterations are run (`gap_tol = 0`). The default 0
    /// starts from the unbounded weights (as libigl does): 100 ADMM
    /// iterations cut the active-set iterations by 30 % on FAUST but cost
    /// about as much CPU time as they saved (see the module documentation).
    pub admm: AdmmOptions,
    /// When an active set has not settled after `max_iter` iterations,
    /// return the clamped last iterate (its KKT residual is in
    /// [`BbwReport::kkt_residual`], [`BbwReport::converged`] is false)
    /// instead of an error. Off by default.
    pub accept_unconverged: bool,
    /// Coupled: the support active set starts from the normalised PerHandle
    /// weights with entries at or below this dropped (each row keeps its
    /// largest entry). Only the starting supports change, not the solution.
    /// Measured on FAUST `tr_reg_001` (support iterations for 10 / 4 FPS
    /// handles): 0 → 49 / 22, 1e-4 → 33 / 32, 1e-3 → 31 / 47.
    pub coupled_support_threshold: f64,
    /// Local refinement of the active-set iterations (PerHandle, and the
    /// support iteration of Coupled): after every iteration, the same
    /// iteration is repeated on the vertices within this many steps of
    /// `Q`'s graph (two mesh rings each) of the changed ones, the rest
    /// frozen, before the next iteration over the whole mesh (see
    /// [`crate::solve::qp::BoxQp::with_local_hops`]). 0 turns it off. Only
    /// the path to the optimum changes, not the optimality test. Measured
    /// on one thread (6 FPS handles, PerHandle active-set iterations
    /// summed over handles): FAUST 6.9k 132 → 38 with 2 and 27 with 4;
    /// synthetic 27k 282 → 66 with 2 and 42 with 4 (13.4 → 3.1 s).
    pub local_hops: usize,
    /// [`BbwOptions::local_hops`] for the support iteration of Coupled
    /// (its regions hold several unknowns per vertex, so a local iteration
    /// costs more there and fewer steps pay off). Measured on FAUST, 6 FPS
    /// handles, one thread: support iterations 75 → 33 / 21 / 12 with 1 /
    /// 2 / 4, whole solve about 10 s → 6–7 / 7.4 / 10.7 s.
    pub coupled_local_hops: usize,
    /// The per-handle solves that start from the unbounded weights (every
    /// one but those an [`ActiveSetStart`] seeds) start with the vertices
    /// below 0 but within this many steps of `Q`'s graph (two mesh rings
    /// each) of a vertex inside `[0, 1]` free instead of fixed at 0. The
    /// unbounded weights undershoot 0 well inside the optimum's support,
    /// and an active set releases such vertices only a few rings per
    /// iteration (fixing is immediate: every violator at once), so a start
    /// with too few fixed costs less than one with too many. Only the
    /// start changes (weights within 7e-11 at 108k). Numeric
    /// factorisations, 6 FPS handles, `tol` 1e-10 (2026-12-05; CPU s of
    /// one thread beside, on a machine running a suite):
    ///
    /// | hops | FAUST 001 (6.9k) | FAUST 033 (6.9k) | TOSCA cat0 (28k) | synthetic 27k | synthetic 108k | sum |
    /// |---|---|---|---|---|---|---|
    /// | 0 (before) | 489 | 660 | 2299 (13.9 s) | 399 | 3452 (54.0 s) | 7299 |
    /// | 2 | 390 | 559 | 2379 | – | – | – |
    /// | 4 | 461 | 482 | 2145 | 213 | 2980 (44.3 s) | 6281 |
    /// | **8** | 453 | 518 | 1754 (9.6 s) | 350 | 2464 (39.3 s) | **5539** |
    /// | 16 | – | – | – | 369 | – | – |
    ///
    /// Releasing the neighbours of every released vertex at *every*
    /// iteration instead cycled (27k: over 2 minutes against 2.6 s).
    pub start_release_hops: usize,
}

impl Default for BbwOptions {
    fn default() -> Self {
        BbwOptions {
            mode: WeightMode::default(),
            max_iter: 1000,
            tol: 1e-10,
            coupled_tol: 1e-8,
            coupled_step_tol: 1e-6,
            admm: AdmmOptions {
                max_iter: 0,
                gap_tol: 0.0,
                rho_scale: 1e-2,
                adapt_every: 25,
            },
            accept_unconverged: false,
            coupled_support_threshold: 1e-4,
            coupled_admm_iter: 20,
            local_hops: 4,
            coupled_local_hops: 1,
            start_release_hops: 8,
        }
    }
}

impl BbwOptions {
    /// The active-set tolerance that [`BbwOptions::mode`] uses:
    /// [`BbwOptions::coupled_tol`] for Coupled, [`BbwOptions::tol`]
    /// otherwise.
    pub fn mode_tol(&self) -> f64 {
        match self.mode {
            WeightMode::Coupled => self.coupled_tol,
            _ => self.tol,
        }
    }

    /// Sets the tolerance [`BbwOptions::mode_tol`] reads.
    pub fn set_mode_tol(&mut self, tol: f64) {
        match self.mode {
            WeightMode::Coupled => self.coupled_tol = tol,
            _ => self.tol = tol,
        }
    }

    /// Defaults with `mode`.
    pub fn with_mode(mode: WeightMode) -> Self {
        BbwOptions {
            mode,
            ..Default::default()
        }
    }
}

/// Weights and solver statistics from [`Biharmonic::weights_with_report`].
#[derive(Clone, Debug)]
pub struct BbwReport {
    /// n × n_h weights.
    pub weights: DMatrix<f64>,
    /// Numeric factorisations done.
    pub factorizations: usize,
    /// Global active-set iterations (each over the whole mesh): summed over
    /// handles (PerHandle); that plus the coupled support iterations
    /// (Coupled); 0 for Unbounded.
    pub iterations: usize,
    /// Iterations of local refinement ([`BbwOptions::local_hops`]), each a
    /// factorisation on a small region, summed over all solves (not in
    /// `iterations`).
    pub local_iterations: usize,
    /// Coupled: support iterations of the coupled solve alone.
    pub coupled_iterations: usize,
    /// Coupled: unknowns of the last reduced coupled system.
    pub coupled_unknowns: usize,
    /// Coupled: whether the support iteration stopped on its step test
    /// ([`BbwOptions::coupled_step_tol`]) rather than on unchanged supports.
    pub coupled_stopped_on_step: bool,
    /// Active-set iterations of each per-handle solve (PerHandle and the
    /// warm start of Coupled), in handle order.
    pub handle_iterations: Vec<usize>,
    /// KKT residual of the returned solution in weight units (see
    /// [`crate::solve::qp::BoxQpSolution::kkt_residual`]): PerHandle, the
    /// largest over the per-handle box problems (before normalisation);
    /// Coupled, that of the coupled problem. 0 for Unbounded.
    pub kkt_residual: f64,
    /// Whether every active set settled within `max_iter` (always true
    /// unless [`BbwOptions::accept_unconverged`] is set).
    pub converged: bool,
    /// PerHandle and Coupled: the per-handle box-constrained weights before
    /// row normalisation (n × n_h; each column solves its own QP exactly).
    pub unnormalized: Option<DMatrix<f64>>,
    /// Wall time (s) of the phases: unbounded solve and ADMM warm start,
    /// per-handle active sets, coupled support active set.
    pub seconds: [f64; 3],
}

/// Handle-independent precomputation for biharmonic weights on one mesh:
/// `L`, `M`, `Q = L M⁻¹ L` and the connected components of `L`'s graph.
/// Build once, then call [`Biharmonic::weights`] for many handle sets.
#[derive(Clone, Debug)]
pub struct Biharmonic {
    q: SparseMatrix,
    mass: Vec<f64>,
    component: Vec<usize>,
    n_components: usize,
}

impl Biharmonic {
    /// The connected components of the mesh's Laplacian graph.
    pub fn n_components(&self) -> usize {
        self.n_components
    }

    /// Builds `L`, `M` (Voronoi) and `Q = L M⁻¹ L`. Errors if a vertex has
    /// zero mass (an isolated vertex, or one only in degenerate faces): `M⁻¹`
    /// and hence the biharmonic system would be singular there.
    pub fn new(mesh: &Mesh) -> Result<Self> {
        let n = mesh.n_vertices();
        let l = mesh.laplacian();
        let mass = mesh.mass(MassKind::Voronoi);
        if let Some(i) = mass.iter().position(|&m| !(m > 0.0 && m.is_finite())) {
            return Err(Error::invalid(format!(
                "biharmonic weights: vertex {i} has zero Voronoi area (isolated vertex or only in \
                 degenerate faces), so Q = L M⁻¹ L is singular there; remove unreferenced \
                 vertices first"
            )));
        }
        // Q_ij = Σ_k L_ki L_kj / m_k, pushed symmetrically so Q is exactly
        // symmetric.
        let (off, rows, vals) = (l.col_offsets(), l.row_indices(), l.values());
        let mut trip = Vec::new();
        for k in 0..n {
            let col = off[k]..off[k + 1];
            for p in col.clone() {
                for r in col.clone() {
                    trip.push((rows[p], rows[r], vals[p] * vals[r] / mass[k]));
                }
            }
        }
        let q = sparse_from_triplets(n, n, trip);
        // Components of L's graph (non-zero off-diagonal entries).
        let mut parent: Vec<usize> = (0..n).collect();
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for (i, j, &v) in l.triplet_iter() {
            if i < j && v != 0.0 {
                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
        let mut label = vec![usize::MAX; n];
        let mut component = vec![0; n];
        let mut n_components = 0;
        for (i, c) in component.iter_mut().enumerate() {
            let r = find(&mut parent, i);
            if label[r] == usize::MAX {
                label[r] = n_components;
                n_components += 1;
            }
            *c = label[r];
        }
        Ok(Biharmonic {
            q,
            mass: mass.to_vec(),
            component,
            n_components,
        })
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.mass.len()
    }

    /// The quadratic form `Q = L M⁻¹ L` (n × n).
    pub fn quadratic_form(&self) -> &SparseMatrix {
        &self.q
    }

    /// The Voronoi mass diagonal `M`.
    pub fn mass(&self) -> &[f64] {
        &self.mass
    }

    /// `Σ_k ½ w_kᵀ Q w_k` for n × n_h weights (the objective of Eq. 1).
    pub fn energy(&self, w: &DMatrix<f64>) -> Result<f64> {
        if w.nrows() != self.n_vertices() {
            return Err(Error::invalid(format!(
                "weights have {} rows for {} vertices",
                w.nrows(),
                self.n_vertices()
            )));
        }
        let (off, rows, vals) = (self.q.col_offsets(), self.q.row_indices(), self.q.values());
        let mut e = 0.0;
        for k in 0..w.ncols() {
            let c = w.column(k);
            for j in 0..self.n_vertices() {
                let mut s = 0.0;
                for p in off[j]..off[j + 1] {
                    s += vals[p] * c[rows[p]];
                }
                e += 0.5 * s * c[j];
            }
        }
        Ok(e)
    }

    /// Checks the handle list; returns the free vertices and, for every
    /// vertex, its free index (or `usize::MAX` for a handle).
    fn split(&self, handles: &[usize]) -> Result<(Vec<usize>, Vec<usize>)> {
        let n = self.n_vertices();
        if handles.is_empty() {
            return Err(Error::invalid(
                "biharmonic weights need at least one handle",
            ));
        }
        let mut slot = vec![usize::MAX; n];
        for (k, &h) in handles.iter().enumerate() {
            if h >= n {
                return Err(Error::invalid(format!(
                    "handle {k} is vertex {h}, but the mesh has {n} vertices"
                )));
            }
            if slot[h] != usize::MAX {
                return Err(Error::invalid(format!(
                    "handles {} and {k} are the same vertex {h}; handles must be distinct",
                    slot[h]
                )));
            }
            slot[h] = k;
        }
        let mut covered = vec![false; self.n_components];
        for &h in handles {
            covered[self.component[h]] = true;
        }
        if let Some(c) = covered.iter().position(|&c| !c) {
            let v = self.component.iter().position(|&x| x == c).unwrap_or(0);
            return Err(Error::invalid(format!(
                "biharmonic weights: the connected component containing vertex {v} has no \
                 handle ({} components in all), so the system is singular there (weights are \
                 undetermined); put at least one handle in every component",
                self.n_components
            )));
        }
        let mut free_index = vec![usize::MAX; n];
        let mut free = Vec::with_capacity(n - handles.len());
        for i in 0..n {
            if slot[i] == usize::MAX {
                free_index[i] = free.len();
                free.push(i);
            }
        }
        Ok((free, free_index))
    }

    /// n × n_h weights for the handle vertices `handles` (distinct, in
    /// range, at least one per connected component); column `k` belongs to
    /// `handles[k]`.
    ///
    /// Algorithms, tolerances and measured figures: see the module
    /// documentation.
    pub fn weights(&self, handles: &[usize], opts: &BbwOptions) -> Result<DMatrix<f64>> {
        Ok(self.weights_with_report(handles, opts)?.weights)
    }

    /// [`Biharmonic::weights`] with solver statistics.
    pub fn weights_with_report(&self, handles: &[usize], opts: &BbwOptions) -> Result<BbwReport> {
        self.weights_from(handles, opts, None)
    }

    /// [`Biharmonic::weights_with_report`] with the per-handle active sets
    /// (PerHandle, and the PerHandle stage of Coupled) started from an
    /// earlier solve on a nearby handle set (see [`ActiveSetStart`]). The
    /// problem solved is the same; only the starting active sets, and
    /// so the number of iterations, change.
    pub fn weights_from(
        &self,
        handles: &[usize],
        opts: &BbwOptions,
        start: Option<&ActiveSetStart>,
    ) -> Result<BbwReport> {
        let n = self.n_vertices();
        let nh = handles.len();
        let (free, free_index) = self.split(handles)?;
        let nf = free.len();
        let mut w = DMatrix::<f64>::zeros(n, nh);
        for (k, &h) in handles.iter().enumerate() {
            w[(h, k)] = 1.0;
        }
        let mut report = BbwReport {
            weights: DMatrix::zeros(0, 0),
            factorizations: 0,
            iterations: 0,
            handle_iterations: Vec::new(),
            local_iterations: 0,
            coupled_iterations: 0,
            coupled_unknowns: 0,
            coupled_stopped_on_step: false,
            kkt_residual: 0.0,
            converged: true,
            unnormalized: None,
            seconds: [0.0; 3],
        };
        if nf == 0 {
            report.weights = w;
            return Ok(report);
        }
        // Q_ff and B = Q_fh (dense n_f × n_h).
        let mut handle_col = vec![usize::MAX; n];
        for (k, &h) in handles.iter().enumerate() {
            handle_col[h] = k;
        }
        let (off, rows, vals) = (self.q.col_offsets(), self.q.row_indices(), self.q.values());
        let mut trip = Vec::with_capacity(vals.len());
        let mut b = DMatrix::<f64>::zeros(nf, nh);
        for j in 0..n {
            for p in off[j]..off[j + 1] {
                let i = rows[p];
                let fi = free_index[i];
                if fi == usize::MAX {
                    continue;
                }
                if free_index[j] != usize::MAX {
                    trip.push((fi, free_index[j], vals[p]));
                } else {
                    b[(fi, handle_col[j])] += vals[p];
                }
            }
        }
        let qff = sparse_from_triplets(nf, nf, trip);
        let starts = match opts.mode {
            WeightMode::Unbounded => Vec::new(),
            _ => start_columns(start, handles, &free, n)?,
        };
        let wf: DMatrix<f64> = match opts.mode {
            WeightMode::Unbounded => {
                let fac = SparseCholesky::new(&qff)?;
                report.factorizations = 1;
                fac.try_solve(&(-&b))?
            }
            WeightMode::PerHandle => {
                let (raw, unbounded) =
                    per_handle_raw(&qff, &b, opts, opts.mode_tol(), &starts, &mut report)?;
                let wf = normalise_rows(&raw, &unbounded);
                report.unnormalized = Some(raw);
                wf
            }
            WeightMode::Coupled => {
                let (raw, unbounded) =
                    per_handle_raw(&qff, &b, opts, opts.mode_tol(), &starts, &mut report)?;
                let mut x0 = normalise_rows(&raw, &unbounded);
                report.unnormalized = Some(raw);
                let clock = Instant::now();
                if opts.coupled_admm_iter > 0 {
                    let (c, k) = (RowConstraint::Simplex, opts.coupled_admm_iter);
                    x0 = admm_iterate(&qff, &b, &x0, c, k, opts, &mut report)?.x;
                }
                drop_small_entries(&mut x0, opts.coupled_support_threshold);
                let s = simplex_rows_qp(
                    &qff,
                    &b,
                    &x0,
                    &SimplexQpOptions {
                        max_iter: opts.max_iter,
                        tol: opts.mode_tol(),
                        local_hops: opts.coupled_local_hops,
                        step_tol: opts.coupled_step_tol,
                    },
                )?;
                report.seconds[2] = clock.elapsed().as_secs_f64();
                if !s.converged && !opts.accept_unconverged {
                    return Err(Error::numerical(format!(
                        "bounded biharmonic weights (coupled): the supports did not settle \
                         within {} iterations (KKT residual {:.2e}); raise max_iter or set \
                         accept_unconverged",
                        opts.max_iter, s.kkt_residual
                    )));
                }
                report.converged &= s.converged;
                report.kkt_residual = s.kkt_residual;
                report.factorizations += s.iterations;
                report.iterations += s.iterations;
                report.coupled_iterations = s.iterations;
                report.local_iterations += s.local_iterations;
                report.factorizations += s.local_iterations;
                report.coupled_unknowns = s.n_variables;
                report.coupled_stopped_on_step = s.stopped_on_step;
                s.x
            }
        };
        let scatter_into = |w: &mut DMatrix<f64>, wf: &DMatrix<f64>| {
            for (fi, &i) in free.iter().enumerate() {
                for k in 0..nh {
                    w[(i, k)] = wf[(fi, k)];
                }
            }
        };
        if let Some(raw) = report.unnormalized.take() {
            let mut full = w.clone();
            scatter_into(&mut full, &raw);
            report.unnormalized = Some(full);
        }
        scatter_into(&mut w, &wf);
        report.weights = w;
        Ok(report)
    }
}

/// Per-handle bound-constrained weights on the free vertices (unnormalised
/// columns), see [`WeightMode::PerHandle`]. Handles are solved in parallel
/// (rayon's current pool); each solve is sequential and independent, so the
/// result does not depend on the number of threads.
fn per_handle_raw(
    qff: &SparseMatrix,
    b: &DMatrix<f64>,
    opts: &BbwOptions,
    tol: f64,
    starts: &[Option<Vec<f64>>],
    report: &mut BbwReport,
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let (nf, nh) = b.shape();
    let clock = Instant::now();
    let qp = BoxQp::new(qff)?.with_local_hops(opts.local_hops);
    let unbounded = qp.solve_unconstrained(b)?;
    report.factorizations = 1;
    // Optional warm start: ADMM iterations on all handles at once
    // (box constraints, one factorisation of Q_ff + ρ diag Q_ff).
    let mut warm = if opts.admm.max_iter > 0 {
        let box01 = RowConstraint::Box(0.0, 1.0);
        admm_iterate(qff, b, &unbounded, box01, opts.admm.max_iter, opts, report)?.pre_projection
    } else {
        unbounded.clone()
    };
    if opts.start_release_hops > 0 {
        release_near_free(qff, &mut warm, opts.start_release_hops);
    }
    report.seconds[0] = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let step = format!("bounded biharmonic weights: {nh} handles on {nf} free vertices, handle");
    progress::update(&step, 0, nh);
    // Solves started from an earlier active set ([`ActiveSetStart`]) take a
    // few iterations, the others (key point selection's new handle) many:
    // the latter are started first, so that the short ones fill the other
    // threads instead of waiting behind them (one task per handle). Each
    // solve is independent, so the order changes no result.
    let mut order: Vec<usize> = (0..nh).collect();
    order.sort_by_key(|&k| matches!(starts.get(k), Some(Some(_))));
    let mut solutions: Vec<(usize, Result<BoxQpSolution>)> = order
        .into_par_iter()
        .with_max_len(1)
        .map(|k| {
            let bk: Vec<f64> = b.column(k).iter().copied().collect();
            let from_warm: Vec<f64>;
            let x0: &[f64] = match starts.get(k) {
                Some(Some(x0)) => x0,
                _ => {
                    from_warm = warm.column(k).iter().copied().collect();
                    &from_warm
                }
            };
            let s = qp.solve(&bk, 0.0, 1.0, Some(x0), opts.max_iter, tol);
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress::update(&step, d, nh);
            (k, s)
        })
        .collect();
    solutions.sort_by_key(|&(k, _)| k);
    let mut wf = DMatrix::zeros(nf, nh);
    for (k, s) in solutions {
        let s = s?;
        if !s.converged && !opts.accept_unconverged {
            return Err(Error::numerical(format!(
                "bounded biharmonic weights: the active set of handle {k} did not settle within \
                 {} iterations (KKT residual {:.2e}); raise max_iter or set accept_unconverged",
                opts.max_iter, s.kkt_residual
            )));
        }
        report.factorizations += s.iterations + s.local_iterations;
        report.iterations += s.iterations;
        report.local_iterations += s.local_iterations;
        report.handle_iterations.push(s.iterations);
        report.kkt_residual = report.kkt_residual.max(s.kkt_residual);
        report.converged &= s.converged;
        wf.column_mut(k).copy_from_slice(&s.x);
    }
    report.seconds[1] = clock.elapsed().as_secs_f64();
    Ok((wf, unbounded))
}

/// `max_iter` ADMM iterations (`D = diag Q_ff`, `gap_tol = 0`, the other
/// settings from [`BbwOptions::admm`]) on the rows of `x0` under
/// `constraint`, counting the factorisations in `report`: the warm starts
/// of the per-handle active sets and of the coupled support iteration.
fn admm_iterate(
    qff: &SparseMatrix,
    b: &DMatrix<f64>,
    x0: &DMatrix<f64>,
    constraint: RowConstraint,
    max_iter: usize,
    opts: &BbwOptions,
    report: &mut BbwReport,
) -> Result<AdmmSolution> {
    let admm = RowAdmm::new(qff, &diagonal(qff), constraint)?;
    let aopts = AdmmOptions {
        max_iter,
        gap_tol: 0.0,
        ..opts.admm
    };
    let s = admm.solve(b, x0, &aopts)?;
    report.factorizations += s.factorizations;
    Ok(s)
}

/// Moves every vertex of a warm start column that is below the lower
/// bound 0 but within `hops` steps of `qff`'s graph of a vertex inside
/// `[0, 1]` to 0, so that its solve starts with it free (see
/// [`BbwOptions::start_release_hops`]).
fn release_near_free(qff: &SparseMatrix, warm: &mut DMatrix<f64>, hops: usize) {
    let (off, rows) = (qff.col_offsets(), qff.row_indices());
    let nf = warm.nrows();
    let mut seen = vec![false; nf];
    let (mut front, mut next) = (Vec::new(), Vec::new());
    for mut col in warm.column_iter_mut() {
        seen.fill(false);
        front.clear();
        for i in 0..nf {
            if (0.0..=1.0).contains(&col[i]) {
                seen[i] = true;
                front.push(i);
            }
        }
        for _ in 0..hops {
            next.clear();
            for &j in &front {
                for &i in &rows[off[j]..off[j + 1]] {
                    if !seen[i] {
                        seen[i] = true;
                        next.push(i);
                        if col[i] < 0.0 {
                            col[i] = 0.0;
                        }
                    }
                }
            }
            std::mem::swap(&mut front, &mut next);
        }
    }
}

/// The per-handle box-constrained weights of an earlier solve (before row
/// normalisation: [`BbwReport::unnormalized`]) on the handle set `handles`,
/// used by [`Biharmonic::weights_from`] to start the active set of every
/// handle that both sets share from where it ended: vertices where the
/// earlier weight sat at a bound start fixed at that bound. For a handle
/// set that differs in one handle (key point selection's trials) the
/// active sets change only near the changed handles, so the solves settle
/// in fewer iterations; handles not in `handles` start from the unbounded
/// weights as usual.
#[derive(Clone, Copy, Debug)]
pub struct ActiveSetStart<'a> {
    /// Handle vertices of the earlier solve (column `j` of `unnormalized`
    /// belongs to `handles[j]`).
    pub handles: &'a [usize],
    /// n × `handles.len()` per-handle weights, in `[0, 1]`.
    pub unnormalized: &'a DMatrix<f64>,
}

/// Starting points (on the free vertices) of the per-handle solves of
/// `handles` from `start`: `None` for a handle `start` does not have.
fn start_columns(
    start: Option<&ActiveSetStart>,
    handles: &[usize],
    free: &[usize],
    n: usize,
) -> Result<Vec<Option<Vec<f64>>>> {
    let Some(start) = start else {
        return Ok(vec![None; handles.len()]);
    };
    if start.unnormalized.shape() != (n, start.handles.len()) {
        return Err(Error::invalid(format!(
            "bounded biharmonic weights: the active-set start is {}×{}, expected {n}×{} (one \
             column per handle of the earlier solve)",
            start.unnormalized.nrows(),
            start.unnormalized.ncols(),
            start.handles.len()
        )));
    }
    Ok(handles
        .iter()
        .map(|h| {
            let j = start.handles.iter().position(|g| g == h)?;
            let col = start.unnormalized.column(j);
            Some(
                free.iter()
                    .map(|&i| {
                        // Outside the bounds: starts fixed there.
                        let v = col[i];
                        if v <= 0.0 {
                            -1.0
                        } else if v >= 1.0 {
                            2.0
                        } else {
                            v
                        }
                    })
                    .collect(),
            )
        })
        .collect())
}

/// Rows of the per-handle weights normalised to sum to one; a row that is
/// all zero (possible in principle) falls back to the simplex projection of
/// the unbounded row.
fn normalise_rows(raw: &DMatrix<f64>, unbounded: &DMatrix<f64>) -> DMatrix<f64> {
    let (nf, nh) = raw.shape();
    let mut wf = raw.clone();
    let mut row = vec![0.0; nh];
    for i in 0..nf {
        let s: f64 = wf.row(i).sum();
        if s > 1e-12 {
            for k in 0..nh {
                wf[(i, k)] /= s;
            }
        } else {
            for k in 0..nh {
                row[k] = unbounded[(i, k)];
            }
            project_to_simplex(&mut row);
            for k in 0..nh {
                wf[(i, k)] = row[k];
            }
        }
    }
    wf
}

/// Sets entries `≤ theta` to zero, except each row's largest entry (so
/// every row keeps a non-empty support).
fn drop_small_entries(x: &mut DMatrix<f64>, theta: f64) {
    let m = x.ncols();
    for i in 0..x.nrows() {
        let keep = (0..m)
            .max_by(|&p, &q| x[(i, p)].total_cmp(&x[(i, q)]).then(q.cmp(&p)))
            .unwrap_or(0);
        for k in 0..m {
            if k != keep && x[(i, k)] <= theta {
                x[(i, k)] = 0.0;
            }
        }
    }
}

/// Stored diagonal of a square sparse matrix.
fn diagonal(a: &SparseMatrix) -> Vec<f64> {
    let mut d = vec![0.0; a.nrows()];
    for (i, j, &v) in a.triplet_iter() {
        if i == j {
            d[i] = v;
        }
    }
    d
}

/// Convenience: [`Biharmonic::new`] then [`Biharmonic::weights`].
pub fn bounded_biharmonic_weights(
    mesh: &Mesh,
    handles: &[usize],
    opts: &BbwOptions,
) -> Result<DMatrix<f64>> {
    Biharmonic::new(mesh)?.weights(handles, opts)
}

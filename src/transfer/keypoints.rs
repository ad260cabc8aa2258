//! Automatic key point selection (BDT Sec. 3.5, Algorithm 1, Eq. 22–23).
//!
//! # Procedure
//!
//! 1. The source `A` and the deformed sources `A′_1..A′_m` are scaled into
//!    the unit sphere with **one** similarity `S` (union of all meshes,
//!    [`crate::ops::normalize_to_unit_sphere`]); errors are in those units.
//! 2. `n_c` candidates `C` by farthest point sampling on `S(A)` (seeded
//!    first vertex, geodesic by default).
//! 3. `D_S(A)` for a trial set of handles `S ⊂ C`: skinning weights of `S`
//!    on `A`, rotation groups (k-means on `W′ = [W, logr~, s~]` of all
//!    deformed sources, BDT Eq. 15, `n_groups = |S|`, seeded), reduced ARAP
//!    with E_diff ([`ReducedArap`]), solved towards every `A′_j`.
//! 4. Error (BDT Eq. 22): by default the mean per-vertex Euclidean distance
//!    `Ê = 1/(m n) Σ_j Σ_i ‖D_S(A)_i − A′_{j,i}‖` ([`ErrorNorm::MeanDistance`]).
//!    Eq. 22 read literally, `1/(m n) Σ_j ‖D_S(A) − A′_j‖_F`
//!    ([`ErrorNorm::Paper`]), is `RMS/√n` per source: on a mesh with
//!    thousands of vertices it is tiny and `ε = 0.03` is met by a single key
//!    point, against the paper's own statement that its normalisation makes
//!    one threshold fit a wide range of meshes. [`ErrorNorm::Rms`]
//!    (root-mean-square distance) is the third choice.
//! 5. Stage 1: `S = {c_1}`, then repeatedly add the candidate of `C − S`
//!    minimising `Ê` until `Ê < ε` or `|S| = max_keypoints`. Stage 2: for
//!    each key point in turn try every replacement from `C − S`, take the
//!    best only if it *strictly* lowers `Ê` (so the error never increases);
//!    repeat passes until one changes nothing (or `max_swap_passes`).
//!
//! Candidate evaluations of one step run in parallel (rayon), are collected
//! in candidate order and reduced by argmin with the lowest index on ties,
//! so the result does not depend on the number of threads. A trial whose
//! solver fails numerically (e.g. ADMM not converging) counts as `+∞`
//! ([`KeypointSelection::failed_evaluations`]); invalid input is an error.
//!
//! # Modes
//!
//! * [`SelectionMode::Exact`] — the paper: weights recomputed by
//!   [`Biharmonic::weights`] (bounded, [`KeypointOptions::weights`]) for every
//!   trial set, k-means on all vertices ([`GROUP_KMEANS`]).
//! * [`SelectionMode::Fast`] — the same method, reached faster: candidates
//!   are *screened* with cheap weights and groups, then the best few of
//!   every greedy step are *ranked* by the exact evaluation (the one of
//!   exact mode, bounded biharmonic weights with
//!   [`KeypointOptions::weights`]), and every decision is taken on the
//!   exact error. See [`FastOptions`]:
//!   - **Screening weights (Green's functions).** The unbounded biharmonic
//!     weights of any handle set satisfy `Q w_k = Σ_{s∈S} μ_ks e_s` (Lagrange
//!     multipliers at the handles), so with particular solutions `g_c` of
//!     `Q g_c = e_c − a` (`a` = normalised mass, `1ᵀa = 1`; consistent
//!     because `1ᵀQ = 0`) of every candidate, `w_k = Σ_s μ_ks g_s + c_k 1`
//!     with the small dense saddle system `[G_SS 1; 1ᵀ 0] [μ_k; c_k] =
//!     [e_k; 0]`. One sparse factorisation of `Q` with one grounded vertex
//!     and `n_c` solves are done once; a trial set then costs O(n |S|²).
//!     These are *exactly* the unbounded biharmonic weights (up to
//!     rounding; tested against [`crate::skin::bbw::WeightMode::Unbounded`]).
//!   - **Screening bounds.** [`FastBounds::ClampNormalize`] clamps them to
//!     `[0, 1]` and renormalises each row to sum to one. These are *not*
//!     bounded biharmonic weights (measured against Eq. 1: mean per-vertex
//!     total variation 0.15–0.19 with 3 handles), which is why they only
//!     screen and never decide.
//!   - **Screening groups / ARAP.** k-means on a fixed seeded subsample of
//!     vertices ([`FastOptions::kmeans_sample`], fewer iterations), then
//!     every vertex joins its nearest centre; at most
//!     [`FastOptions::arap_max_iter`] local/global iterations.
//!   - **Ranking.** At every greedy step (the first set, every stage-1
//!     addition and every stage-2 replacement attempt) all trial sets are
//!     scored cheaply, the best [`FastOptions::verify_top`] (≥ 1) of them are
//!     re-evaluated exactly, and the step takes the one with the lowest
//!     exact error; the ε test of stage 1 and the "strictly lower" test of
//!     stage 2 compare exact errors. Fast mode therefore differs from exact
//!     mode only in *which* trial sets get an exact evaluation: with
//!     `verify_top ≥ n_c` it is exact mode.
//!
//! In both modes the final set is fitted exactly (the fit of
//! [`fit_keypoints`], which does not depend on the mode), and the reported
//! error, trace errors and transforms are those of the exact evaluation.

use std::time::Instant;

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use std::sync::Arc;

use crate::arap::{ArapMesh, ArapOptions, ReducedArap};
use crate::mesh::Mesh;
use crate::ops::{
    farthest_point_sampling, farthest_point_sampling_in, normalize_to_unit_sphere, FpsMetric,
    NormalizeReference, Similarity,
};
use crate::skin::bbw::{ActiveSetStart, BbwOptions, Biharmonic};
use crate::skin::groups::{group_features, GROUP_KMEANS};
use crate::skin::{Affine, GroupFeatures};
use crate::solve::kmeans::{kmeans_with, KMeansOptions};
use crate::solve::{progress, sparse_from_triplets, SparseCholesky};
use crate::{Error, Point, Result};

/// Exact (paper) or fast (cheap screening, exact ranking) selection. Both
/// fit the final key points with bounded biharmonic weights and report the
/// exact error. The one default of the library, the CLI (`--mode`) and the
/// configs (`mode`) is [`KeypointOptions::default`]'s: `fast` (an exact
/// selection on a 6.9k-vertex mesh takes about an hour of CPU).
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
pub enum SelectionMode {
    /// Every candidate is scored with the full fit: bounded biharmonic
    /// weights recomputed for every trial set (Algorithm 1 as written).
    Exact,
    /// Candidates screened with Green's-function weights and subsampled
    /// k-means; the best [`FastOptions::verify_top`] of every step ranked by
    /// the exact evaluation (see the module docs).
    #[default]
    #[value(
        help = "Candidates screened with Green's-function weights and subsampled k-means; the \
                best few of every step (verify_top) ranked by the exact evaluation"
    )]
    Fast,
}

/// How the per-source residual is summarised (all in unit-sphere units).
///
/// The default is [`ErrorNorm::MeanDistance`]: BDT says its normalisation
/// "makes the same error threshold applicable to a wide range" of meshes
/// and plots the error as a Euclidean distance (Fig. 6), which holds for the
/// mean per-vertex distance but not for Eq. 22 read literally (a Frobenius
/// norm over `n` vertices divided by `n` shrinks like `1/√n`, so `ε = 0.03`
/// is met by one key point on any dense mesh). The literal form is kept as
/// [`ErrorNorm::Paper`].
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
pub enum ErrorNorm {
    /// `1/(m n) Σ_j Σ_i ‖D_S(A)_i − A′_{j,i}‖` (mean per-vertex Euclidean
    /// distance, averaged over the sources; the same measure as the transfer
    /// error).
    #[default]
    #[serde(rename = "mean")]
    #[value(name = "mean")]
    MeanDistance,
    /// BDT Eq. 22 literally: `1/(m n) Σ_j ‖D_S(A) − A′_j‖_F`.
    Paper,
    /// `1/m Σ_j ‖D_S(A) − A′_j‖_F / √n` (root-mean-square vertex distance,
    /// averaged over the sources).
    Rms,
}

/// How fast mode makes its unbounded screening weights admissible (they
/// only screen candidates; decisions and the final fit use bounded
/// biharmonic weights).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FastBounds {
    /// Clamp to `[0, 1]`, renormalise rows to sum to one.
    #[default]
    ClampNormalize,
    /// Keep the unbounded biharmonic weights (they sum to one).
    Unbounded,
}

/// Settings of [`SelectionMode::Fast`].
#[derive(Clone, Debug, PartialEq)]
pub struct FastOptions {
    /// Bounds on the Green's-function screening weights.
    pub bounds: FastBounds,
    /// Vertices (seeded subsample) that k-means clusters; all vertices are
    /// then assigned to the nearest centre. 0 or ≥ n: all vertices.
    pub kmeans_sample: usize,
    /// k-means settings on the subsample.
    pub kmeans: KMeansOptions,
    /// Cap on the local/global iterations of a trial's ARAP solve.
    pub arap_max_iter: usize,
    /// Re-evaluate this many best-screened trial sets of every greedy step
    /// exactly (bounded biharmonic weights) and decide by the exact error.
    /// At least 1 (fast mode ranks by the exact error; 0 is rejected).
    /// Default: see [`FastOptions::default`].
    pub verify_top: usize,
}

/// Default [`FastOptions::verify_top`], chosen by `deformlab bench
/// fast-exact` (fast against exact mode at n_c = 10, where exact mode is
/// affordable at FAUST size; both scored by the bounded-weight fit of their
/// final key points; table in `docs/bdt-defaults.md`): with 1, FAUST
/// 010 → 017 lands 3.6 % above exact mode (another sixth key point that
/// the swaps, verifying only the best-screened replacement, did not undo);
/// with 2, every row (synthetic resolutions 1 and 2, m = 1 and 3; ten
/// FAUST source/pose pairs over subjects 1, 3, 5, 7, 9 and poses 7, 8, 9)
/// is within 2 % of exact mode. 2 costs about 1.5× the CPU time of 1.
pub const DEFAULT_VERIFY_TOP: usize = 2;

impl Default for FastOptions {
    fn default() -> Self {
        FastOptions {
            bounds: FastBounds::ClampNormalize,
            kmeans_sample: 1000,
            kmeans: KMeansOptions {
                max_iter: 50,
                n_init: 1,
            },
            arap_max_iter: 30,
            verify_top: DEFAULT_VERIFY_TOP,
        }
    }
}

/// Options of [`select_keypoints`] and [`fit_keypoints`].
#[derive(Clone, Debug, PartialEq)]
pub struct KeypointOptions {
    /// Number of FPS candidates n_c (paper: 100).
    pub n_candidates: usize,
    /// Seed of every random choice (FPS start, k-means, subsamples).
    pub seed: u64,
    /// Stage-1 threshold ε on the error (paper: 0.03, unit-sphere units).
    pub epsilon: f64,
    /// Upper bound on the number of key points.
    pub max_keypoints: usize,
    /// Exact or fast evaluation.
    pub mode: SelectionMode,
    /// Metric of the candidate FPS.
    pub fps: FpsMetric,
    /// Bounded biharmonic weights of every fit `D_S(A)` (the trial sets of
    /// both modes, fast mode's verified trials and the final fit whose
    /// transforms `T_k` are transferred) and, through
    /// [`crate::transfer::target::TargetWeights::Bounded`], of the target
    /// `B`. Default: [`WeightMode::PerHandle`](crate::skin::bbw::WeightMode::PerHandle) — each weight function
    /// solved with its bounds, rows normalised to sum to one afterwards (the
    /// practice of Jacobson et al. 2011, BDT's ref. [5], and of libigl's
    /// `bbw`, whose per-handle weights ours match to 9.1e-7 with 6 FPS
    /// handles on FAUST at the default tolerance, see [`BbwOptions::tol`]): bounds,
    /// interpolation and partition of unity hold, but the weights are not
    /// the minimiser of BDT Eq. 1. [`WeightMode::Coupled`](crate::skin::bbw::WeightMode::Coupled) solves Eq. 1 as
    /// written (config key `weights = "coupled"`, CLI `--weights coupled`).
    /// Measured: the two weights differ little (`tests/weights_modes.rs`:
    /// mean per-vertex total variation 0.003–0.012, fit errors of the same
    /// key points within 2.6 %), coupled costs 2.9–16× more on FAUST
    /// (1.3 / 5.6 s against 0.44 / 0.35 s for 4 / 6 FPS handles, one thread,
    /// `deformlab weights`, 2026-12-03), and on
    /// the synthetic Fig. 14 cases the coupled pipeline (selection, fit and
    /// target) transferred worse (mean error 0.0297 against 0.0267 √area;
    /// `automatic-coupled` in `experiments/fig14.toml`). Ranking with one and
    /// fitting with the other was worse than either (0.0305), so one option
    /// sets both.
    pub weights: BbwOptions,
    /// Rotation-group features (paper: `W′`, Eq. 15).
    pub groups: GroupFeatures,
    /// Number of rotation groups; `None`: `|S|` (paper).
    pub n_groups: Option<usize>,
    /// Reduced ARAP options (paper: λ = 0.5 with E_diff).
    pub arap: ArapOptions,
    /// Maximum number of stage-2 passes.
    pub max_swap_passes: usize,
    /// Error summary (mean per-vertex distance by default).
    pub error_norm: ErrorNorm,
    /// Fast-mode settings.
    pub fast: FastOptions,
    /// Vertices allowed as candidates (e.g. the source vertices of a
    /// correspondence file, so that every key point has a known target);
    /// empty: all vertices. The FPS runs inside the pool (distances over the
    /// whole mesh); `n_candidates` is capped at the pool size.
    pub candidate_pool: Vec<usize>,
}

impl Default for KeypointOptions {
    fn default() -> Self {
        KeypointOptions {
            n_candidates: 100,
            seed: 0,
            epsilon: 0.03,
            max_keypoints: 30,
            mode: SelectionMode::Fast,
            fps: FpsMetric::Geodesic,
            weights: BbwOptions::default(),
            groups: GroupFeatures::AUGMENTED,
            n_groups: None,
            arap: ArapOptions::default(),
            max_swap_passes: usize::MAX,
            error_norm: ErrorNorm::MeanDistance,
            fast: FastOptions::default(),
            candidate_pool: Vec::new(),
        }
    }
}

/// One step of the selection.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceStep {
    /// 1: addition (stage 1, the first entry is `S = {c_1}`), 2: one
    /// replacement attempt of stage 2 (the set is unchanged when no
    /// candidate was strictly better).
    pub stage: u8,
    /// The key point set after the step.
    pub keypoints: Vec<usize>,
    /// Its error (as compared during the selection).
    pub error: f64,
}

/// Result of [`select_keypoints`].
#[derive(Clone, Debug)]
pub struct KeypointSelection {
    /// Selected key points (vertex ids on A).
    pub keypoints: Vec<usize>,
    /// The FPS candidates (vertex ids on A).
    pub candidates: Vec<usize>,
    /// `[deformed source][key point]` affine transforms, in A's original
    /// coordinate frame.
    pub transforms: Vec<Vec<Affine>>,
    /// Error of the final fit (unit-sphere units, [`KeypointOptions::error_norm`]).
    pub error: f64,
    /// Error after every step.
    pub trace: Vec<TraceStep>,
    /// The unit-sphere similarity used.
    pub normalization: Similarity,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Trial sets evaluated (one evaluation = all m sources; the final
    /// fit included).
    pub evaluations: usize,
    /// Of these, exact evaluations (bounded biharmonic weights; all of them
    /// in exact mode, the ranked ones and the final fit in fast mode).
    pub exact_evaluations: usize,
    /// Trial sets met again and answered from the memo (not evaluated).
    pub repeated_trials: usize,
    /// Trials whose solver failed numerically (counted as `+∞`).
    pub failed_evaluations: usize,
}

/// Result of [`fit_keypoints`].
#[derive(Clone, Debug)]
pub struct KeypointFit {
    /// `[deformed source][key point]` transforms in A's original frame.
    pub transforms: Vec<Vec<Affine>>,
    /// `[deformed source]` deformed A (`D_S(A)`), original frame.
    pub positions: Vec<Vec<Point>>,
    /// Error (unit-sphere units, [`KeypointOptions::error_norm`]).
    pub error: f64,
    /// n × |S| skinning weights.
    pub weights: DMatrix<f64>,
    /// Rotation group of every vertex.
    pub groups: Vec<usize>,
}

/// Automatic key point selection (BDT Algorithm 1); see the module docs.
///
/// Errors if `deformed` is empty, a deformed mesh has another vertex count
/// or other faces than `source`, the source has several connected
/// components, `n_candidates` is 0 or exceeds the vertex
/// count, `max_keypoints` is 0, `epsilon` is not finite and ≥ 0, or the
/// options are otherwise invalid.
pub fn select_keypoints(
    source: &Mesh,
    deformed: &[Mesh],
    opts: &KeypointOptions,
) -> Result<KeypointSelection> {
    let start = Instant::now();
    check_inputs(source, deformed, opts)?;
    let parts = source.component_count();
    if parts > 1 {
        return Err(Error::invalid(format!(
            "the source mesh has {parts} connected components (separate parts, or an unwelded \
             triangle soup: one per face); key point selection needs one connected surface \
             (weld duplicate vertices, or keep one part)"
        )));
    }
    let n = source.n_vertices();
    if opts.n_candidates == 0 || opts.n_candidates > n {
        return Err(Error::invalid(format!(
            "n_candidates = {} must be in 1..={n} (the vertex count)",
            opts.n_candidates
        )));
    }
    if !(opts.epsilon.is_finite() && opts.epsilon >= 0.0) {
        return Err(Error::invalid(format!(
            "epsilon must be finite and ≥ 0, got {}",
            opts.epsilon
        )));
    }
    let ctx = Context::new(source, deformed, opts)?;
    let candidates = if opts.candidate_pool.is_empty() {
        farthest_point_sampling(&ctx.rest, opts.n_candidates, opts.fps, opts.seed)?
    } else {
        let k = opts.n_candidates.min(opts.candidate_pool.len());
        farthest_point_sampling_in(&ctx.rest, &opts.candidate_pool, k, opts.fps, opts.seed)?
    };
    let fast = match opts.mode {
        SelectionMode::Fast => Some(GreenBasis::new(&ctx.bih, &candidates)?),
        SelectionMode::Exact => None,
    };
    let mut sel = Selector {
        ctx: &ctx,
        fast: fast.as_ref(),
        evaluations: 0,
        cached: 0,
        failed: 0,
        memo: Default::default(),
        base: None,
        fresh: Default::default(),
        exact: 0,
        step: "key points: stage 1, 1 key point".to_string(),
    };
    let max_k = opts.max_keypoints.min(candidates.len());

    // Stage 1.
    let mut set = vec![candidates[0]];
    let mut error = sel.best_of(&[set.clone()])?.1;
    sel.rebase(&set);
    let mut trace = vec![TraceStep {
        stage: 1,
        keypoints: set.clone(),
        error,
    }];
    // `error` is never NaN (failed trials count as +∞).
    while error >= opts.epsilon && set.len() < max_k {
        sel.step = format!(
            "key points: stage 1, {} → {} key points (error {error:.4}, ε {})",
            set.len(),
            set.len() + 1,
            opts.epsilon
        );
        let trials: Vec<Vec<usize>> = candidates
            .iter()
            .filter(|c| !set.contains(c))
            .map(|&c| {
                let mut s = set.clone();
                s.push(c);
                s
            })
            .collect();
        let (best, e) = sel.best_of(&trials)?;
        if !e.is_finite() {
            return Err(Error::numerical(format!(
                "key point selection: every trial set of size {} failed",
                set.len() + 1
            )));
        }
        set = trials[best].clone();
        error = e;
        sel.rebase(&set);
        trace.push(TraceStep {
            stage: 1,
            keypoints: set.clone(),
            error,
        });
    }

    // Stage 2.
    for pass in 0..opts.max_swap_passes {
        let mut changed = false;
        for t in 0..set.len() {
            sel.step = format!(
                "key points: stage 2, pass {}, replacing key point {} of {} (error {error:.4})",
                pass + 1,
                t + 1,
                set.len()
            );
            let trials: Vec<Vec<usize>> = candidates
                .iter()
                .filter(|c| !set.contains(c))
                .map(|&c| {
                    let mut s = set.clone();
                    s[t] = c;
                    s
                })
                .collect();
            if !trials.is_empty() {
                let (best, e) = sel.best_of(&trials)?;
                if e < error {
                    set = trials[best].clone();
                    error = e;
                    changed = true;
                }
                sel.rebase(&set);
            }
            trace.push(TraceStep {
                stage: 2,
                keypoints: set.clone(),
                error,
            });
        }
        if !changed {
            break;
        }
    }

    // The final fit is the exact one in both modes (fast mode differs only
    // in which trial sets were evaluated exactly). Its bounded weights start
    // from the active sets this selection ended with for the same set, so
    // the solves confirm them in about one iteration instead of starting
    // over (synthetic 27k: 2.97 → 0.36 s); the weights equal those of a
    // start from scratch ([`fit_keypoints`]) to the active-set tolerance.
    let own = sel
        .base
        .as_ref()
        .filter(|(h, _)| *h == set)
        .map(|(h, w)| ActiveSetStart {
            handles: h,
            unnormalized: w,
        });
    let fit = ctx.fit(&set, own.as_ref())?;
    let (evaluations, failed_evaluations) = (sel.evaluations + 1, sel.failed);
    let repeated_trials = sel.cached;
    Ok(KeypointSelection {
        keypoints: set,
        candidates,
        transforms: fit.transforms,
        error: fit.error,
        trace,
        normalization: ctx.sim,
        seconds: start.elapsed().as_secs_f64(),
        evaluations,
        exact_evaluations: sel.exact + 1,
        repeated_trials,
        failed_evaluations,
    })
}

/// `D_S`: deforms A towards every A′ with the given key points as handles
/// (bounded biharmonic weights with [`KeypointOptions::weights`], rotation
/// groups, reduced ARAP with E_diff). The fit is the same in both modes
/// ([`KeypointOptions::mode`] only changes how a selection screens
/// candidates). For random/user key point baselines and ablations.
///
/// Errors as [`select_keypoints`] (except the candidate count), and if
/// `keypoints` is empty, out of range or has duplicates.
pub fn fit_keypoints(
    source: &Mesh,
    deformed: &[Mesh],
    keypoints: &[usize],
    opts: &KeypointOptions,
) -> Result<KeypointFit> {
    check_inputs(source, deformed, opts)?;
    let n = source.n_vertices();
    if keypoints.is_empty() {
        return Err(Error::invalid("fit_keypoints needs at least one key point"));
    }
    for (k, &v) in keypoints.iter().enumerate() {
        if v >= n {
            return Err(Error::invalid(format!(
                "key point {k} is vertex {v}, but the mesh has {n} vertices"
            )));
        }
        if keypoints[..k].contains(&v) {
            return Err(Error::invalid(format!(
                "key point {k} (vertex {v}) is repeated"
            )));
        }
    }
    let ctx = Context::new(source, deformed, opts)?;
    // Both modes fit with bounded biharmonic weights (fast mode only screens
    // candidates cheaply during a selection).
    ctx.fit(keypoints, None)
}

fn check_inputs(source: &Mesh, deformed: &[Mesh], opts: &KeypointOptions) -> Result<()> {
    if deformed.is_empty() {
        return Err(Error::invalid(
            "key point selection needs at least one deformed source mesh",
        ));
    }
    let n = source.n_vertices();
    for (j, d) in deformed.iter().enumerate() {
        if d.n_vertices() != n {
            return Err(Error::invalid(format!(
                "deformed source {j} has {} vertices, the source has {n}",
                d.n_vertices()
            )));
        }
        if d.faces() != source.faces() {
            return Err(Error::invalid(format!(
                "deformed source {j} does not share the source's faces"
            )));
        }
    }
    if opts.max_keypoints == 0 {
        return Err(Error::invalid("max_keypoints must be at least 1"));
    }
    if opts.n_groups == Some(0) {
        return Err(Error::invalid("n_groups must be at least 1"));
    }
    if opts.mode == SelectionMode::Fast && opts.fast.verify_top == 0 {
        return Err(Error::invalid(
            "fast mode needs verify_top ≥ 1 (it ranks the best-screened trial sets by the \
             exact error)",
        ));
    }
    if !(opts.arap.lambda.is_finite() && opts.arap.lambda >= 0.0) {
        return Err(Error::invalid(format!(
            "ARAP weight lambda must be finite and ≥ 0, got {}",
            opts.arap.lambda
        )));
    }
    Ok(())
}

/// Everything shared by all trials: normalised meshes, biharmonic
/// precomputation, deformation features, k-means subsample.
struct Context<'a> {
    opts: &'a KeypointOptions,
    sim: Similarity,
    rest: Mesh,
    /// Mesh-only ARAP precomputation shared by all trials.
    arap_mesh: Arc<ArapMesh>,
    targets: Vec<Vec<Point>>,
    bih: Biharmonic,
    /// `[γ logr~, γ s~]` (n × 12m) or empty for [`GroupFeatures::Weights`].
    features: DMatrix<f64>,
    /// Whether `W` is part of the k-means features.
    use_w: bool,
    /// Fast-mode k-means subsample (sorted vertex ids).
    sample: Vec<usize>,
}

/// One evaluated trial set.
struct Eval {
    error: f64,
    weights: DMatrix<f64>,
    /// Exact evaluations with bounded weights: the per-handle weights
    /// before row normalisation (the next trials' active-set start).
    unnormalized: Option<DMatrix<f64>>,
    groups: Vec<usize>,
    stacked: Vec<DMatrix<f64>>,
    positions: Vec<Vec<Point>>,
}

impl<'a> Context<'a> {
    fn new(source: &Mesh, deformed: &[Mesh], opts: &'a KeypointOptions) -> Result<Self> {
        let mut all = Vec::with_capacity(deformed.len() + 1);
        all.push(source.clone());
        all.extend_from_slice(deformed);
        let (sim, mut normed) = normalize_to_unit_sphere(&all, NormalizeReference::Union)?;
        let rest = normed.remove(0);
        let n = rest.n_vertices();
        let empty = DMatrix::zeros(n, 0);
        let features = group_features(&rest, &normed, &empty, opts.groups)?;
        let use_w = !matches!(opts.groups, GroupFeatures::RotationScale { .. });
        let bih = Biharmonic::new(&rest)?;
        let sample = match opts.mode {
            SelectionMode::Fast if opts.fast.kmeans_sample > 0 && opts.fast.kmeans_sample < n => {
                seeded_subsample(n, opts.fast.kmeans_sample, opts.seed)
            }
            _ => Vec::new(),
        };
        Ok(Context {
            opts,
            sim,
            arap_mesh: Arc::new(ArapMesh::new(&rest)),
            rest,
            targets: normed.into_iter().map(|m| m.vertices().to_vec()).collect(),
            bih,
            features,
            use_w,
            sample,
        })
    }

    fn n(&self) -> usize {
        self.rest.n_vertices()
    }

    /// Skinning weights of a trial set, and (bounded weights) the
    /// per-handle weights before normalisation. `start`: active sets of an
    /// earlier exact evaluation to start the bounded solves from.
    fn weights(
        &self,
        set: &[usize],
        fast: Option<&GreenBasis>,
        start: Option<&ActiveSetStart>,
    ) -> Result<(DMatrix<f64>, Option<DMatrix<f64>>)> {
        match fast {
            Some(g) => Ok((g.weights(set, self.opts.fast.bounds)?, None)),
            None => {
                let r = self.bih.weights_from(set, &self.opts.weights, start)?;
                Ok((r.weights, r.unnormalized))
            }
        }
    }

    /// Rotation groups for weights `w`.
    fn groups(&self, w: &DMatrix<f64>, fast: bool) -> Result<Vec<usize>> {
        let n = self.n();
        let k = self.opts.n_groups.unwrap_or(w.ncols()).min(n);
        let wc = if self.use_w { w.ncols() } else { 0 };
        let d = wc + self.features.ncols();
        let row = |i: usize, c: usize| {
            if c < wc {
                w[(i, c)]
            } else {
                self.features[(i, c - wc)]
            }
        };
        if d == 0 {
            return Err(Error::invalid("rotation groups have no features"));
        }
        let x = DMatrix::from_fn(n, d, row);
        if fast && !self.sample.is_empty() && k <= self.sample.len() {
            let km = kmeans_with(
                &x.select_rows(&self.sample),
                k,
                self.opts.seed,
                &self.opts.fast.kmeans,
            )?;
            Ok(nearest_centers(&x, &km.centers))
        } else {
            Ok(kmeans_with(&x, k, self.opts.seed, &GROUP_KMEANS)?.labels)
        }
    }

    /// `D_S(A)` towards every target and its error. `fast` selects the fast
    /// weights/groups/ARAP settings; `keep` keeps transforms and positions.
    fn evaluate(
        &self,
        set: &[usize],
        fast: Option<&GreenBasis>,
        keep: bool,
        start: Option<&ActiveSetStart>,
    ) -> Result<Eval> {
        let (w, unnormalized) = self.weights(set, fast, start)?;
        let groups = self.groups(&w, fast.is_some())?;
        let mut arap_opts = self.opts.arap.clone();
        if !arap_opts.use_ediff {
            // FAST ablation (E_diff off): the key points are the handles whose
            // target positions constrain the ARAP solve.
            arap_opts.handles = set.to_vec();
        }
        if fast.is_some() {
            arap_opts.max_iter = arap_opts.max_iter.min(self.opts.fast.arap_max_iter.max(1));
        }
        let arap = ReducedArap::with_mesh(&self.arap_mesh, &w, &groups, arap_opts)?;
        let n = self.n() as f64;
        let m = self.targets.len() as f64;
        let mut sum = 0.0;
        let mut stacked = Vec::new();
        let mut positions = Vec::new();
        let mean_distance = self.opts.error_norm == ErrorNorm::MeanDistance;
        for target in &self.targets {
            let sol = arap.solve(target, None)?;
            let d = sol.positions.iter().zip(target).map(|(p, q)| {
                let sq = (p - q).norm_squared();
                if mean_distance {
                    sq.sqrt()
                } else {
                    sq
                }
            });
            let total: f64 = d.sum();
            sum += if mean_distance { total } else { total.sqrt() };
            if keep {
                stacked.push(sol.stacked);
                positions.push(sol.positions);
            }
        }
        let error = match self.opts.error_norm {
            ErrorNorm::MeanDistance | ErrorNorm::Paper => sum / (m * n),
            ErrorNorm::Rms => sum / (m * n.sqrt()),
        };
        if !error.is_finite() {
            return Err(Error::numerical(format!(
                "key point error is {error} for {set:?}"
            )));
        }
        Ok(Eval {
            error,
            weights: w,
            unnormalized,
            groups,
            stacked,
            positions,
        })
    }

    /// The final (exact, bounded-weight) fit of a set, converted back to the
    /// original frame; `start` as in [`Context::weights`].
    fn fit(&self, set: &[usize], start: Option<&ActiveSetStart>) -> Result<KeypointFit> {
        let e = self.evaluate(set, None, true, start)?;
        let transforms = e
            .stacked
            .iter()
            .map(|t| {
                crate::skin::transforms_from_stacked(t)
                    .map(|ts| ts.iter().map(|a| to_original_frame(a, &self.sim)).collect())
            })
            .collect::<Result<Vec<Vec<Affine>>>>()?;
        let positions = e
            .positions
            .iter()
            .map(|ps| ps.iter().map(|p| self.sim.invert(p)).collect())
            .collect();
        Ok(KeypointFit {
            transforms,
            positions,
            error: e.error,
            weights: e.weights,
            groups: e.groups,
        })
    }
}

/// `T_orig = S⁻¹ ∘ T ∘ S` for `S(x) = (x − c) s`: `A` unchanged,
/// `t_orig = c − A c + t / s`. Valid for LBS because the weights sum to one.
pub fn to_original_frame(t: &Affine, sim: &Similarity) -> Affine {
    let a = t.fixed_view::<3, 3>(0, 0).into_owned();
    let tr = t.column(3).into_owned();
    let c = sim.center.coords;
    let t_orig = c - a * c + tr / sim.scale;
    let mut out = *t;
    out.set_column(3, &t_orig);
    out
}

/// Index of the nearest centre (rows of `centers`) of every row of `x`,
/// lowest index on ties, from `‖c‖² − 2 x·c` (one dense product).
fn nearest_centers(x: &DMatrix<f64>, centers: &DMatrix<f64>) -> Vec<usize> {
    let xc = x * centers.transpose();
    let c2: Vec<f64> = centers.row_iter().map(|c| c.norm_squared()).collect();
    (0..x.nrows())
        .map(|i| {
            let mut best = (0, f64::INFINITY);
            for (g, &cg) in c2.iter().enumerate() {
                let s = cg - 2.0 * xc[(i, g)];
                if s < best.1 {
                    best = (g, s);
                }
            }
            best.0
        })
        .collect()
}

/// `k` distinct indices of `0..n`, seeded (partial Fisher–Yates), sorted.
fn seeded_subsample(n: usize, k: usize, seed: u64) -> Vec<usize> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6b65_7970_6f69_6e74);
    let mut idx: Vec<usize> = (0..n).collect();
    for i in 0..k.min(n) {
        let j = rng.random_range(i..n);
        idx.swap(i, j);
    }
    idx.truncate(k.min(n));
    idx.sort_unstable();
    idx
}

/// Evaluates trial sets in parallel and reduces deterministically.
///
/// Errors are memoised by the *ordered* trial set (and the mode), so a
/// repeated trial (stage 2 revisiting a position whose set has not changed
/// since, or the last stage-1 step's sets met again as replacements of the
/// last key point) returns the value computed first without being
/// recomputed.
///
/// Exact evaluations start the per-handle active sets of the bounded
/// weights from those of the current key point set ([`ActiveSetStart`]):
/// a trial differs from it in one handle, so the shared handles' active
/// sets change only near it. The weights are the same to the active-set
/// tolerance (measured: within 3e-7 on the 27k-vertex synthetic subject),
/// not bitwise; the start is the same for every trial of a step, so the
/// result does not depend on the thread count. The final fit starts from
/// the selected set's own active sets (the same as [`fit_keypoints`] of the
/// selected set, which starts from scratch, to the active-set tolerance).
struct Selector<'c, 'a> {
    ctx: &'c Context<'a>,
    fast: Option<&'c GreenBasis>,
    evaluations: usize,
    cached: usize,
    failed: usize,
    memo: std::collections::HashMap<(bool, Vec<usize>), f64>,
    /// The current key point set and its per-handle weights before
    /// normalisation: the active-set start of exact evaluations.
    base: Option<(Vec<usize>, DMatrix<f64>)>,
    /// Per-handle weights of the best exact evaluation computed since the
    /// last [`Selector::rebase`].
    fresh: Option<(Vec<usize>, DMatrix<f64>)>,
    /// Exact evaluations (a subset of `evaluations`).
    exact: usize,
    /// What the current greedy step is (progress reports only).
    step: String,
}

impl Selector<'_, '_> {
    /// Errors of the trials (in order; numerical failures → +∞).
    fn errors(&mut self, trials: &[Vec<usize>], fast: Option<&GreenBasis>) -> Result<Vec<f64>> {
        let ctx = self.ctx;
        let is_fast = fast.is_some();
        let todo: Vec<&Vec<usize>> = trials
            .iter()
            .filter(|s| !self.memo.contains_key(&(is_fast, s.to_vec())))
            .collect();
        let total = todo.len();
        let done = std::sync::atomic::AtomicUsize::new(0);
        let step = format!(
            "{}: {} trial",
            self.step,
            if is_fast { "screening" } else { "exact" }
        );
        progress::update(&step, 0, total);
        let start = self.base.as_ref().map(|(h, w)| ActiveSetStart {
            handles: h,
            unnormalized: w,
        });
        // Only the best computed trial (lowest error, then lowest index) can
        // become the next key point set: only its per-handle weights are
        // kept, as the trials finish (exact mode computes ~n_c of them).
        let best: std::sync::Mutex<Option<(f64, usize, DMatrix<f64>)>> = Default::default();
        let results: Vec<Result<f64>> = todo
            .par_iter()
            .enumerate()
            .map(|(i, s)| {
                let r = ctx.evaluate(s, fast, false, start.as_ref()).map(|e| {
                    if let Some(raw) = e.unnormalized {
                        let mut b = best.lock().unwrap_or_else(|p| p.into_inner());
                        if b.as_ref()
                            .is_none_or(|(be, bi, _)| (e.error, i) < (*be, *bi))
                        {
                            *b = Some((e.error, i, raw));
                        }
                    }
                    e.error
                });
                let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                progress::update(&step, d, total);
                r
            })
            .collect();
        if let Some((_, i, raw)) = best.into_inner().unwrap_or_else(|p| p.into_inner()) {
            self.fresh = Some((todo[i].clone(), raw));
        }
        self.evaluations += todo.len();
        if !is_fast {
            self.exact += todo.len();
        }
        self.cached += trials.len() - todo.len();
        for (s, r) in todo.into_iter().zip(results) {
            let e = match r {
                Ok(e) => e,
                Err(Error::Numerical(_)) => {
                    self.failed += 1;
                    f64::INFINITY
                }
                Err(e) => return Err(e),
            };
            self.memo.insert((is_fast, s.clone()), e);
        }
        Ok(trials
            .iter()
            .map(|s| self.memo[&(is_fast, s.clone())])
            .collect())
    }

    /// Makes `set` (the current key points, just evaluated or unchanged)
    /// the active-set start of the next exact evaluations, if its weights
    /// were computed since the last call; forgets the other trial's.
    fn rebase(&mut self, set: &[usize]) {
        if let Some((s, raw)) = self.fresh.take() {
            if s == set {
                self.base = Some((s, raw));
            }
        }
    }

    /// Index and exact error of the best trial (lowest index on ties). Fast
    /// mode screens all trials cheaply and evaluates the best `verify_top`
    /// of them exactly.
    fn best_of(&mut self, trials: &[Vec<usize>]) -> Result<(usize, f64)> {
        let Some(fast) = self.fast else {
            let errs = self.errors(trials, None)?;
            let k = argmin(&errs);
            return Ok((k, errs[k]));
        };
        let verify = self.ctx.opts.fast.verify_top.max(1);
        let order: Vec<usize> = if verify >= trials.len() {
            (0..trials.len()).collect()
        } else {
            let errs = self.errors(trials, Some(fast))?;
            let mut order: Vec<usize> = (0..trials.len()).collect();
            order.sort_by(|&a, &b| errs[a].total_cmp(&errs[b]).then(a.cmp(&b)));
            order.truncate(verify);
            order.sort_unstable();
            order
        };
        let subset: Vec<Vec<usize>> = order.iter().map(|&i| trials[i].clone()).collect();
        let exact = self.errors(&subset, None)?;
        let k = argmin(&exact);
        Ok((order[k], exact[k]))
    }
}

/// Index of the smallest value, lowest index on ties (NaN never wins).
fn argmin(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in v.iter().enumerate() {
        if x < v[best] || (v[best].is_nan() && !x.is_nan()) {
            best = i;
        }
    }
    best
}

/// Biharmonic Green's functions of a fixed vertex set (fast mode).
#[derive(Clone, Debug)]
pub struct GreenBasis {
    /// Column of each vertex in `g` (`usize::MAX`: not in the basis).
    col: Vec<usize>,
    /// n × |basis|: `Q g_c = e_c − a` with `g_c(ground) = 0`.
    g: DMatrix<f64>,
}

impl GreenBasis {
    /// One factorisation of `Q` with vertex 0 grounded, `vertices.len()`
    /// solves. Errors if the mesh is not connected (the grounded system is
    /// then singular) or a vertex is out of range.
    pub fn new(bih: &Biharmonic, vertices: &[usize]) -> Result<Self> {
        let n = bih.n_vertices();
        let mut col = vec![usize::MAX; n];
        for (k, &v) in vertices.iter().enumerate() {
            if v >= n {
                return Err(Error::invalid(format!(
                    "basis vertex {v} out of range ({n} vertices)"
                )));
            }
            col[v] = k;
        }
        if n < 2 {
            return Err(Error::invalid("Green's functions need at least 2 vertices"));
        }
        let q = bih.quadratic_form();
        let ground = 0;
        let trip = q
            .triplet_iter()
            .filter(|&(i, j, _)| i != ground && j != ground)
            .map(|(i, j, &v)| (i - 1, j - 1, v));
        let qr = sparse_from_triplets(n - 1, n - 1, trip);
        let fac = SparseCholesky::new(&qr).map_err(|e| {
            let why = match bih.n_components() {
                1 => "nearly degenerate or folded triangles make it so (is the mesh flattened \
                      or crushed somewhere?)"
                    .to_string(),
                k => format!("the mesh has {k} separate components; it must be connected"),
            };
            Error::numerical(format!(
                "fast key point mode: the grounded biharmonic system is singular: {why}: {e}"
            ))
        })?;
        let mass = bih.mass();
        let total: f64 = mass.iter().sum();
        let mut rhs = DMatrix::zeros(n - 1, vertices.len());
        for (k, &v) in vertices.iter().enumerate() {
            for i in 1..n {
                rhs[(i - 1, k)] = -mass[i] / total;
            }
            if v != ground {
                rhs[(v - 1, k)] += 1.0;
            }
        }
        let sol = fac.try_solve(&rhs)?;
        let mut g = DMatrix::zeros(n, vertices.len());
        g.rows_mut(1, n - 1).copy_from(&sol);
        Ok(GreenBasis { col, g })
    }

    /// Unbounded biharmonic weights of `set` (all in the basis), then
    /// `bounds`.
    pub fn weights(&self, set: &[usize], bounds: FastBounds) -> Result<DMatrix<f64>> {
        let k = set.len();
        let n = self.g.nrows();
        let mut cols = Vec::with_capacity(k);
        for &s in set {
            match self.col.get(s) {
                Some(&c) if c != usize::MAX => cols.push(c),
                _ => {
                    return Err(Error::invalid(format!(
                        "vertex {s} is not in the Green's function basis"
                    )))
                }
            }
        }
        let gs = self.g.select_columns(&cols);
        let mut a = DMatrix::zeros(k + 1, k + 1);
        for i in 0..k {
            for j in 0..k {
                a[(i, j)] = gs[(set[i], j)];
            }
            a[(i, k)] = 1.0;
            a[(k, i)] = 1.0;
        }
        let mut b = DMatrix::zeros(k + 1, k);
        for i in 0..k {
            b[(i, i)] = 1.0;
        }
        let x = a.lu().solve(&b).ok_or_else(|| {
            Error::numerical(format!(
                "fast weights: singular Green's function system for {set:?}"
            ))
        })?;
        let mu = x.rows(0, k);
        let mut w = &gs * mu;
        for j in 0..k {
            let c = x[(k, j)];
            for i in 0..n {
                w[(i, j)] += c;
            }
        }
        for (j, &s) in set.iter().enumerate() {
            for c in 0..k {
                w[(s, c)] = if c == j { 1.0 } else { 0.0 };
            }
        }
        if bounds == FastBounds::ClampNormalize {
            for i in 0..n {
                let mut sum = 0.0;
                for j in 0..k {
                    let v = w[(i, j)].clamp(0.0, 1.0);
                    w[(i, j)] = v;
                    sum += v;
                }
                if sum > 0.0 {
                    for j in 0..k {
                        w[(i, j)] /= sum;
                    }
                } else {
                    for j in 0..k {
                        w[(i, j)] = 1.0 / k as f64;
                    }
                }
            }
        }
        if w.iter().any(|x| !x.is_finite()) {
            return Err(Error::numerical("fast weights are not finite"));
        }
        Ok(w)
    }
}

//! Nonrigid ICP with blended transformations (FBT Sec. 5, "Nonrigid ICP";
//! after Allen et al. 2003, Amberg et al. 2007, Li et al. 2008).
//!
//! Each iteration:
//!
//! 1. **Correspondences** ([`Matcher`], shared with the baselines' ICP
//!    loops). The deformed template `D T` (its vertex normals from the
//!    reference faces) is sampled at `samples` vertices (farthest point
//!    sampling on the reference, fixed across iterations). For each sample
//!    the `neighbours` nearest target vertices are found with a
//!    [`PointIndex`](super::spatial::PointIndex) built once on the target;
//!    the nearest one whose normal makes an angle below
//!    `max_normal_angle_deg` with the sample's normal is its match.
//! 2. **Rejection.** Pairs farther than `max_distance · √A` (A = template
//!    area), pairs without a compatible normal, and — for partial targets —
//!    pairs whose target vertex lies on the target's boundary (a template
//!    vertex in a missing region snaps to the hole's rim) are dropped.
//! 3. **Constraint update.** `H` = the feature rows (weight
//!    `feature_weight`) plus one vertex row per accepted pair (target
//!    position as `Y`); the correspondence rows share the total weight
//!    `correspondence_weight` (row and target scaled by √weight). Measured
//!    on the synthetic class (β_lc = 1000, 8 features × 10 circles, 600
//!    samples): a total of 1–4 feature rows works best; per-row weights as
//!    large as a feature row's overfit the closest-point noise.
//! 4. **Solve** ([`minimal_step`], also the solve of the automatic
//!    correspondence's nonrigid ICP in `transfer::auto`). A new
//!    [`FbtSystem`] for this `H` (X and Γ factorised, of cost
//!    O(h b² + b³)) and `inner_iterations` of the minimal energy E_mn
//!    warm-started from the previous transformations.
//!
//! Only a subset of points needs matching because the deformation lives in
//! the dictionary's span (the paper's remark). The result keeps the mean
//! distance of the accepted pairs per iteration.

use std::sync::Arc;

use nalgebra::DMatrix;

use super::matcher::Matcher;
use super::model::FbtModel;
use super::solver::{ConstraintRows, FbtParams, FbtSystem, IterOptions, MinimalSolution};
use crate::mesh::Mesh;
use crate::{Error, Point, Result};

pub use super::matcher::NicpOptions;

/// Result of [`nicp`].
#[derive(Clone, Debug)]
pub struct NicpResult {
    /// Final transformations (model's dictionary).
    pub t: DMatrix<f64>,
    /// Final deformed template (the completed shape).
    pub positions: Vec<Point>,
    /// Example ℓ* of the last E_mn solve.
    pub example: usize,
    /// Global scale of the last solve.
    pub alpha: f64,
    /// Accepted pairs per iteration.
    pub accepted: Vec<usize>,
    /// Mean distance of the accepted pairs per iteration (before that
    /// iteration's solve).
    pub mean_distance: Vec<f64>,
}

/// Nonrigid ICP of the model's template to `target` (possibly partial),
/// from transformations `t0` (e.g. the feature-point registration), keeping
/// the feature constraints `features = (H rows, Y)`.
pub fn nicp(
    model: &Arc<FbtModel>,
    params: &FbtParams,
    features: (&ConstraintRows, &DMatrix<f64>),
    target: &Mesh,
    t0: &DMatrix<f64>,
    alpha0: f64,
    opts: &NicpOptions,
) -> Result<NicpResult> {
    let (feature_rows, feature_y) = features;
    if feature_y.nrows() != feature_rows.len() || feature_y.ncols() != 3 {
        return Err(Error::invalid(format!(
            "feature targets must be {} × 3",
            feature_rows.len()
        )));
    }
    if target.n_vertices() == 0 {
        return Err(Error::invalid("NICP target has no vertices"));
    }
    if !(opts.max_distance > 0.0 && opts.feature_weight >= 0.0 && opts.correspondence_weight > 0.0)
    {
        return Err(Error::invalid(
            "NICP needs max_distance > 0, feature_weight ≥ 0, correspondence_weight > 0",
        ));
    }
    let graph = model.graph();
    let reference = graph.reference();
    let matcher = Matcher::new(reference, graph.area(), target, opts)?;
    let fw = opts.feature_weight.sqrt();

    let mut t = t0.clone();
    let mut alpha = alpha0;
    let mut example = 0;
    let mut accepted = Vec::new();
    let mut mean_distance = Vec::new();
    for it in 0..opts.iterations {
        crate::solve::progress::update("nonrigid ICP (FBT): iteration", it, opts.iterations);
        let p = model.positions(&t)?;
        let matches = matcher.matches(&p)?;
        let mut rows: ConstraintRows = feature_rows
            .iter()
            .map(|r| r.iter().map(|&(i, w)| (i, w * fw)).collect())
            .collect();
        let mut ys: Vec<[f64; 3]> = (0..feature_rows.len())
            .map(|r| {
                [
                    feature_y[(r, 0)] * fw,
                    feature_y[(r, 1)] * fw,
                    feature_y[(r, 2)] * fw,
                ]
            })
            .collect();
        let count = matches.pairs.len();
        let cw = (opts.correspondence_weight / count.max(1) as f64).sqrt();
        for &(i, j) in &matches.pairs {
            rows.push(vec![(i, cw)]);
            let tp = target.vertices()[j];
            ys.push([tp.x * cw, tp.y * cw, tp.z * cw]);
        }
        accepted.push(count);
        mean_distance.push(matches.mean_distance);
        let y = DMatrix::from_fn(ys.len(), 3, |r, c| ys[r][c]);
        let sol = minimal_step(model, params, rows, &y, &t, alpha, opts.inner_iterations)?;
        t = sol.t().clone();
        alpha = sol.alpha();
        example = sol.best;
    }
    let positions = model.positions(&t)?;
    Ok(NicpResult {
        t,
        positions,
        example,
        alpha,
        accepted,
        mean_distance,
    })
}

/// The solve of one nonrigid ICP iteration: a new [`FbtSystem`] for the
/// constraint rows `rows` (targets `y`) and `inner_iterations` (at least
/// one) local / scale / global iterations of the minimal energy E_mn
/// (FBT Eq. 12) warm-started from the transformations `t` and scale `alpha`.
pub fn minimal_step(
    model: &Arc<FbtModel>,
    params: &FbtParams,
    rows: ConstraintRows,
    y: &DMatrix<f64>,
    t: &DMatrix<f64>,
    alpha: f64,
    inner_iterations: usize,
) -> Result<MinimalSolution> {
    let sys = FbtSystem::new(model.clone(), rows, *params)?;
    sys.solve_minimal(
        y,
        t,
        Some(alpha),
        &IterOptions {
            max_iter: inner_iterations.max(1),
            rel_tol: 1e-8,
        },
    )
}

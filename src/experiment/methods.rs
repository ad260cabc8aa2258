//! Running one method on one case: key points (automatic, random or
//! extremities), fit on the source, transfer to the target, metrics against
//! the ground truth; or rotation-group clustering of the source.
//!
//! Measured quantities (columns of `cases.csv`, see [`super::store`]):
//!
//! * `err_*_unit` / `err_*_area`: per-vertex Euclidean distance between each
//!   transferred mesh `B′_j` and the ground truth, pooled over all vertices
//!   of all poses of the case (mean, RMS, max), in unit-sphere units of the
//!   target reference `B` and in √area(B) units ([`crate::eval`]); after a
//!   rigid Procrustes alignment of each `B′_j` onto its truth when
//!   `[metrics] procrustes = true` (column `procrustes`).
//! * `fit_error_unit`: the same mean distance between `D_S(A)` (the fit on
//!   the source) and `A′_j`, in unit-sphere units of `A`.
//! * `selection_error`: the selection's own error (its `error_norm`).
//! * `arap_energy` / `arap_energy_truth`: relative ARAP energy of `B′_j`
//!   (resp. the ground truth) against `B`, mean over poses.
//! * `distortion_area` / `distortion_edge`: area-weighted mean `|log|` face
//!   area ratio and RMS log edge length ratio of `B′_j` against `B`; curve
//!   `distortion_area`: fraction of faces with `|log(A′/A)| ≤` bound.
//! * clustering: `ari`, `purity` against the dataset's true labels (synthetic
//!   set), `rigidity_unit` (RMS residual of the best rigid motion of each
//!   cluster onto every deformed pose, unit-sphere units of `A`).
//! * target key points (issue 8): `target_correspondence` (`identity`:
//!   target vertex = source vertex, or `auto`: registration of A onto B,
//!   [`crate::transfer::auto`]), `target_noise` (geodesic noise radius,
//!   √area(B) units, [`crate::transfer::perturb_keypoints`] seeded with
//!   `target_noise_seed`), `target_keypoints` (the target vertices used),
//!   `target_keypoint_error_area` (mean edge-path distance on B between the
//!   used and the true target key points, √area(B) units; only when B
//!   shares A's faces, where the truth is the source index),
//!   `registration_residual_area` (symmetric mean closest-point distance of
//!   the registered A to B), `target_frame` (`source`: A and B in one frame,
//!   transforms applied as fitted; `registration`: the frames differ and the
//!   transforms are re-expressed in B's frame by the coarse alignment,
//!   [`crate::transfer::auto`]) and `seconds_correspondence`.
//! * timings: `seconds_selection`, `seconds_fit`, `seconds_weights` (target
//!   weights), `seconds_weights_per_handle` (BDT Table 1 "SWT/h"),
//!   `seconds_lbs` and `seconds_lbs_per_pose` (Table 1 "LBS time"),
//!   `seconds_refine`, `seconds_metrics`, `seconds_total`.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::cases::Case;
use super::config::{
    ExamplesSpec, Method, MetricsSpec, NamedMethod, PoolSpec, StrategySpec,
    TargetCorrespondenceSpec,
};
use super::dataset::Collection;
use super::store::{num, secs, CaseResult, Curve};
use crate::eval::{
    aligned_vertex_errors, arap_energy, cluster_rigidity_rms, cumulative_curve, curve_grid,
    distortion, error_stats, face_log_area_ratios, vertex_errors, ErrorScale,
};
use crate::mesh::io::write_ply;
use crate::mesh::Mesh;
use crate::ops::geodesic::EdgeGraph;
use crate::ops::{
    farthest_point_sampling, farthest_point_sampling_from, total_area, vertex_neighbours, FpsMetric,
};
use crate::skin::bbw::{BbwOptions, Biharmonic, WeightMode};
use crate::skin::rotation_groups;
use crate::transfer::{
    auto_correspondence, fit_keypoints, perturb_keypoints, select_keypoints, transfer_detailed,
    AutoCorrespondence, AutoOptions, SelectionMode,
};
use crate::{Error, Result};

/// Where a render case's meshes go (`None`: not a render case).
pub struct RenderOut<'a> {
    pub dir: &'a Path,
    /// Deformed poses saved (the first ones of the case).
    pub poses: usize,
}

/// The meshes of a case.
pub struct CaseMeshes {
    pub a: Arc<Mesh>,
    pub a_def: Vec<Arc<Mesh>>,
    pub b: Arc<Mesh>,
    pub truth: Vec<Option<Arc<Mesh>>>,
}

impl CaseMeshes {
    pub fn load(col: &Collection, case: &Case) -> Result<Self> {
        let a = col.mesh(&case.source, &case.reference)?;
        let a_def = case
            .poses
            .iter()
            .map(|p| col.mesh(&case.source, p))
            .collect::<Result<Vec<_>>>()?;
        let b = col.mesh(&case.target, &case.reference)?;
        let truth = case
            .poses
            .iter()
            .zip(&case.truth)
            .map(|(p, &has)| {
                if has {
                    col.mesh(&case.target, p).map(Some)
                } else {
                    Ok(None)
                }
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(CaseMeshes { a, a_def, b, truth })
    }
}

/// Runs `m` on `case`; an `Err` is a failure of the method on this case
/// (recorded as the row's status by the caller).
pub fn run_method(
    col: &Collection,
    case: &Case,
    m: &NamedMethod,
    metrics: &MetricsSpec,
    render: Option<&RenderOut>,
    out: &mut CaseResult,
) -> Result<()> {
    let t_total = Instant::now();
    if let Method::Fbt { spec, seed, .. } = &m.method {
        let render = render.map(|r| (r, m.name.as_str()));
        super::fbt::run(col, case, spec, *seed, metrics, render, out)?;
        out.set("seconds_total", secs(t_total.elapsed().as_secs_f64()));
        return Ok(());
    }
    let cm = CaseMeshes::load(col, case)?;
    out.set("n_vertices", cm.a.n_vertices().to_string());
    match &m.method {
        Method::Clustering { .. } => clustering(col, &cm, m, render, out)?,
        Method::Sumner { .. } | Method::SumnerOracle { .. } | Method::Cage { .. } => {
            super::baselines::run(&cm, case, m, metrics, render, out)?
        }
        _ => bdt(&cm, case, m, metrics, render, out)?,
    }
    out.set("seconds_total", secs(t_total.elapsed().as_secs_f64()));
    Ok(())
}

pub(super) fn owned(v: &[Arc<Mesh>]) -> Vec<Mesh> {
    v.iter().map(|m| (**m).clone()).collect()
}

pub(super) fn save_mesh(path: &Path, mesh: &Mesh) -> Result<()> {
    if path.exists() {
        return Ok(());
    }
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
    }
    write_ply(path, mesh)
}

fn bdt(
    cm: &CaseMeshes,
    case: &Case,
    m: &NamedMethod,
    metrics: &MetricsSpec,
    render: Option<&RenderOut>,
    out: &mut CaseResult,
) -> Result<()> {
    let p = m.method.pipeline();
    let kopts = &p.keypoints;
    let a = &*cm.a;
    let a_def = owned(&cm.a_def);
    let b = &*cm.b;
    // Key points.
    let t = Instant::now();
    let keypoints: Vec<usize> = match &m.method {
        Method::Bdt { .. } => auto_keypoints(a, &a_def, p, out)?,
        Method::BdtRandom {
            count, seed, pool, ..
        } => random_keypoints(a, *count, *seed, *pool, kopts.n_candidates, kopts.fps)?,
        Method::BdtExtremity {
            count,
            strategy,
            jitter,
            seed,
            ..
        } => extremity_keypoints(a, *count, *strategy, *jitter, *seed)?,
        _ => unreachable!("handled by the caller"),
    };
    out.set("seconds_selection", secs(t.elapsed().as_secs_f64()));
    record_keypoints(&keypoints, out);

    // Fit on the source (all deformed poses).
    let t = Instant::now();
    let fit = fit_keypoints(a, &a_def, &keypoints, kopts)?;
    out.set("seconds_fit", secs(t.elapsed().as_secs_f64()));
    let sa = ErrorScale::of_reference(a)?;
    let mut fit_err = 0.0;
    for (pos, d) in fit.positions.iter().zip(&a_def) {
        fit_err += error_stats(&vertex_errors(pos, d.vertices())?)?.mean * sa.unit_sphere;
    }
    out.set("fit_error_unit", num(fit_err / a_def.len() as f64));

    // Target key points and transfer.
    let (target_kp, auto) = target_keypoints(
        cm,
        &keypoints,
        p,
        render.map(|r| r.dir.join(&m.name)).as_deref(),
        out,
    )?;
    // A rotated onto B by the registration: transforms in B's frame.
    let (a_t, transforms) = match &auto {
        Some(r) => (
            r.source_in_target_frame(a)?,
            r.target_frame_transforms(&fit.transforms),
        ),
        None => (a.clone(), fit.transforms.clone()),
    };
    if let Some(r) = &auto {
        out.set(
            "target_frame",
            if r.frames_differ() {
                "registration"
            } else {
                "source"
            }
            .to_string(),
        );
    }
    let tr = transfer_detailed(&a_t, &keypoints, &transforms, b, &target_kp, &p.transfer)?;
    out.set("seconds_weights", secs(tr.seconds_weights));
    out.set(
        "seconds_weights_per_handle",
        secs(tr.seconds_weights / keypoints.len() as f64),
    );
    out.set("seconds_lbs", secs(tr.seconds_lbs));
    out.set(
        "seconds_lbs_per_pose",
        secs(tr.seconds_lbs / tr.meshes.len().max(1) as f64),
    );
    out.set("seconds_refine", secs(tr.seconds_refine));

    // Metrics.
    measure(b, &tr.meshes, &cm.truth, metrics, out)?;

    if let Some(r) = render {
        let dir = r.dir.join(&m.name);
        for (j, pose) in case.poses.iter().enumerate().take(r.poses) {
            save_mesh(&dir.join(format!("result_{pose}.ply")), &tr.meshes[j])?;
            let fitted = a.with_vertices(fit.positions[j].clone())?;
            save_mesh(&dir.join(format!("fit_{pose}.ply")), &fitted)?;
        }
    }
    Ok(())
}

/// What a selection contributes to a row.
#[derive(Clone)]
struct SelectionSummary {
    keypoints: Vec<usize>,
    error: f64,
    evaluations: usize,
    trace: Vec<crate::transfer::TraceStep>,
}

/// Selections already made in this process, keyed by a hash of the source
/// meshes and the options: configs that repeat one selection in many rows
/// (e.g. `auto-noise.toml`: one per noise level and seed) select once. The
/// selection is deterministic, so a memoised row equals a recomputed one
/// (`seconds_selection` aside: near zero for a memo hit).
fn memo_select(
    a: &Mesh,
    a_def: &[Mesh],
    kopts: &crate::transfer::KeypointOptions,
) -> Result<SelectionSummary> {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    static MEMO: OnceLock<Mutex<HashMap<(u64, String), SelectionSummary>>> = OnceLock::new();
    let mut bytes: Vec<u8> = Vec::new();
    for m in std::iter::once(a).chain(a_def) {
        for p in m.vertices() {
            for c in p.coords.iter() {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
        }
        for f in m.faces() {
            for &i in f {
                bytes.extend_from_slice(&(i as u64).to_le_bytes());
            }
        }
        bytes.push(0xff);
    }
    let key = (super::config::fnv1a(&bytes), format!("{kopts:?}"));
    let memo = MEMO.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(s) = memo.lock().ok().and_then(|m| m.get(&key).cloned()) {
        return Ok(s);
    }
    let sel = select_keypoints(a, a_def, kopts)?;
    let s = SelectionSummary {
        keypoints: sel.keypoints,
        error: sel.error,
        evaluations: sel.evaluations,
        trace: sel.trace,
    };
    if let Ok(mut m) = memo.lock() {
        m.insert(key, s.clone());
    }
    Ok(s)
}

/// The automatic key points of BDT (Algorithm 1 with the pipeline's
/// options, from its first `selection_poses` poses); records the selection
/// columns and its trace curve.
pub(super) fn auto_keypoints(
    a: &Mesh,
    a_def: &[Mesh],
    p: &super::config::Pipeline,
    out: &mut CaseResult,
) -> Result<Vec<usize>> {
    let kopts = &p.keypoints;
    let k = p.selection_poses.unwrap_or(a_def.len()).min(a_def.len());
    out.set("n_selection_poses", k.to_string());
    let sel = memo_select(a, &a_def[..k], kopts)?;
    out.set("selection_error", num(sel.error));
    out.set("selection_evaluations", sel.evaluations.to_string());
    let trace: Vec<(f64, f64)> = sel
        .trace
        .iter()
        .filter(|s| s.stage == 1)
        .map(|s| (s.keypoints.len() as f64, s.error))
        .collect();
    let (x, y): (Vec<f64>, Vec<f64>) = trace.into_iter().unzip();
    out.curves.push(Curve::new("selection_trace", &x, &y));
    Ok(sel.keypoints)
}

/// The target vertices of the source key points `keypoints` on the case's
/// `B` (see the module documentation: identity or automatic, then the
/// optional geodesic noise); records the `target_*` columns. With
/// `render_dir`, an automatic registration saves `registered.ply` (A
/// registered onto B) there. Also returns the registration (automatic only).
pub(super) fn target_keypoints(
    cm: &CaseMeshes,
    keypoints: &[usize],
    p: &super::config::Pipeline,
    render_dir: Option<&Path>,
    out: &mut CaseResult,
) -> Result<(Vec<usize>, Option<AutoCorrespondence>)> {
    let (a, b) = (&*cm.a, &*cm.b);
    let spec = p.target;
    let t = Instant::now();
    let mut auto = None;
    let mut target: Vec<usize> = match spec.correspondence {
        TargetCorrespondenceSpec::Identity => {
            if b.n_vertices() != a.n_vertices() {
                return Err(Error::invalid(format!(
                    "source has {} vertices, target {}: target_correspondence = \"identity\" \
                     (the default) needs one connectivity; use target_correspondence = \"auto\"",
                    a.n_vertices(),
                    b.n_vertices()
                )));
            }
            out.set("target_correspondence", "identity".to_string());
            keypoints.to_vec()
        }
        TargetCorrespondenceSpec::Auto => {
            let r = auto_correspondence(
                a,
                keypoints,
                b,
                &AutoOptions {
                    seed: p.keypoints.seed,
                    ..AutoOptions::default()
                },
            )?;
            out.set("target_correspondence", "auto".to_string());
            out.set("registration_residual_area", num(r.residual));
            if let Some(dir) = render_dir {
                save_mesh(&dir.join("registered.ply"), &r.registered)?;
            }
            let kp = r.target_keypoints.clone();
            auto = Some(r);
            kp
        }
    };
    if spec.noise > 0.0 {
        let radius = spec.noise * total_area(b).sqrt();
        target = perturb_keypoints(b, &target, radius, spec.noise_seed)?;
    }
    out.set("target_noise", num(spec.noise));
    out.set("seconds_correspondence", secs(t.elapsed().as_secs_f64()));
    out.set(
        "target_keypoints",
        target
            .iter()
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(";"),
    );
    if a.faces() == b.faces() {
        let graph = EdgeGraph::new(b);
        let s = total_area(b).sqrt();
        let mut sum = 0.0;
        for (&k, &t) in keypoints.iter().zip(&target) {
            sum += graph.distances(&[k])?[t] / s;
        }
        out.set(
            "target_keypoint_error_area",
            num(sum / keypoints.len().max(1) as f64),
        );
    }
    Ok((target, auto))
}

/// Records `n_keypoints` and `keypoints`.
pub(super) fn record_keypoints(keypoints: &[usize], out: &mut CaseResult) {
    out.set("n_keypoints", keypoints.len().to_string());
    out.set(
        "keypoints",
        keypoints
            .iter()
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(";"),
    );
}

/// Metrics of the transferred meshes `results` (one per pose) of the target
/// reference `b` against the ground truths (see the module documentation).
pub(super) fn measure(
    b: &Mesh,
    results: &[Mesh],
    truth: &[Option<Arc<Mesh>>],
    metrics: &MetricsSpec,
    out: &mut CaseResult,
) -> Result<()> {
    let t = Instant::now();
    let sb = ErrorScale::of_reference(b)?;
    let procrustes = metrics.procrustes();
    out.set("procrustes", procrustes.to_string());
    let mut pooled: Vec<f64> = Vec::new();
    let (mut e_arap, mut e_arap_truth, mut d_area, mut d_edge) = (0.0, 0.0, 0.0, 0.0);
    let mut n_truth = 0;
    let mut log_area: Vec<f64> = Vec::new();
    for (res, truth) in results.iter().zip(truth) {
        e_arap += arap_energy(b, res.vertices())?.1;
        log_area.extend(face_log_area_ratios(b, res.vertices())?);
        let d = distortion(b, res.vertices())?;
        d_area += d.area_log_mean_abs;
        d_edge += d.edge_log_rms;
        if let Some(truth) = truth {
            let e = if procrustes {
                aligned_vertex_errors(res.vertices(), truth.vertices())?
            } else {
                vertex_errors(res.vertices(), truth.vertices())?
            };
            pooled.extend(e);
            e_arap_truth += arap_energy(b, truth.vertices())?.1;
            n_truth += 1;
        }
    }
    let np = results.len().max(1) as f64;
    out.set("arap_energy", num(e_arap / np));
    out.set("distortion_area", num(d_area / np));
    out.set("distortion_edge", num(d_edge / np));
    // Distortion curve: fraction of faces whose |log area ratio| to B is
    // within a bound (grid 0..1, i.e. area ratios within [1/e, e]).
    let grid = curve_grid(1.0, metrics.curve_points())?;
    out.curves.push(Curve::new(
        "distortion_area",
        &grid,
        &cumulative_curve(&log_area, &grid),
    ));
    if n_truth > 0 {
        out.set("arap_energy_truth", num(e_arap_truth / n_truth as f64));
        let s = error_stats(&pooled)?;
        let su = s.scaled(sb.unit_sphere);
        let sq = s.scaled(sb.sqrt_area);
        out.set("err_mean_unit", num(su.mean));
        out.set("err_rms_unit", num(su.rms));
        out.set("err_max_unit", num(su.max));
        out.set("err_mean_area", num(sq.mean));
        out.set("err_rms_area", num(sq.rms));
        out.set("err_max_area", num(sq.max));
        let grid = curve_grid(metrics.curve_max(), metrics.curve_points())?;
        let unit: Vec<f64> = pooled.iter().map(|e| e * sb.unit_sphere).collect();
        out.curves.push(Curve::new(
            "cumulative_unit",
            &grid,
            &cumulative_curve(&unit, &grid),
        ));
        let grid = curve_grid(metrics.curve_max_area(), metrics.curve_points())?;
        let area: Vec<f64> = pooled.iter().map(|e| e * sb.sqrt_area).collect();
        out.curves.push(Curve::new(
            "cumulative_area",
            &grid,
            &cumulative_curve(&area, &grid),
        ));
    }
    out.set("seconds_metrics", secs(t.elapsed().as_secs_f64()));
    Ok(())
}

/// `count` random key points: among the FPS candidates (`n_candidates`,
/// seeded with `seed`) or among all vertices, drawn with `ChaCha8(seed)`.
pub fn random_keypoints(
    a: &Mesh,
    count: usize,
    seed: u64,
    pool: PoolSpec,
    n_candidates: usize,
    fps: FpsMetric,
) -> Result<Vec<usize>> {
    let pool: Vec<usize> = match pool {
        PoolSpec::Candidates => {
            farthest_point_sampling(a, n_candidates.min(a.n_vertices()), fps, seed)?
        }
        PoolSpec::Vertices => (0..a.n_vertices()).collect(),
    };
    if count > pool.len() {
        return Err(Error::invalid(format!(
            "cannot pick {count} random key points from a pool of {}",
            pool.len()
        )));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    Ok(rand::seq::index::sample(&mut rng, pool.len(), count)
        .into_iter()
        .map(|i| pool[i])
        .collect())
}

/// The vertex nearest the vertex centroid (lowest index on ties).
fn centroid_vertex(a: &Mesh) -> usize {
    let v = a.vertices();
    let c = v.iter().fold(crate::Vec3::zeros(), |s, p| s + p.coords) / v.len() as f64;
    let mut best = (0, f64::INFINITY);
    for (i, p) in v.iter().enumerate() {
        let d = (p.coords - c).norm_squared();
        if d < best.1 {
            best = (i, d);
        }
    }
    best.0
}

/// Key points a user would pick at the shape's extremities (see
/// [`StrategySpec`]); with `jitter > 0` each is replaced by a random vertex
/// (`ChaCha8(seed)`) within geodesic distance `jitter · √area` of it,
/// distinct from the others (a less precise user).
pub fn extremity_keypoints(
    a: &Mesh,
    count: usize,
    strategy: StrategySpec,
    jitter: f64,
    seed: u64,
) -> Result<Vec<usize>> {
    let n = a.n_vertices();
    if count >= n {
        return Err(Error::invalid(format!(
            "cannot pick {count} extremities on {n} vertices"
        )));
    }
    let c = centroid_vertex(a);
    let graph = EdgeGraph::new(a);
    let sqrt_area = total_area(a).sqrt();
    let mut picks: Vec<usize> = match strategy {
        StrategySpec::CentroidFps => {
            let mut f = farthest_point_sampling_from(a, count + 1, FpsMetric::Geodesic, c)?;
            f.remove(0);
            f
        }
        StrategySpec::Eccentricity => {
            let d = graph.distances(&[c])?;
            let nb = vertex_neighbours(a);
            let mut maxima: Vec<usize> = (0..n)
                .filter(|&i| {
                    d[i].is_finite() && d[i] > 0.0 && nb.row(i).iter().all(|&j| d[i] >= d[j])
                })
                .collect();
            maxima.sort_by(|&i, &j| d[j].total_cmp(&d[i]).then(i.cmp(&j)));
            let sep = 0.15 * sqrt_area;
            let mut md = vec![f64::INFINITY; n];
            let mut out = Vec::new();
            for i in maxima {
                if out.len() == count {
                    break;
                }
                if md[i] >= sep {
                    out.push(i);
                    graph.relax_from(i, &mut md)?;
                }
            }
            // Fill up by farthest points from the picks so far.
            while out.len() < count {
                let mut best = (usize::MAX, -1.0);
                for (i, &x) in md.iter().enumerate() {
                    if x.is_finite() && x > best.1 && !out.contains(&i) {
                        best = (i, x);
                    }
                }
                if best.0 == usize::MAX {
                    return Err(Error::invalid("no vertex left to pick"));
                }
                out.push(best.0);
                graph.relax_from(best.0, &mut md)?;
            }
            out
        }
    };
    if jitter > 0.0 {
        // The same seeded geodesic draw as the target key point noise.
        picks = crate::transfer::perturb_keypoints(a, &picks, jitter * sqrt_area, seed)?;
    }
    Ok(picks)
}

fn clustering(
    col: &Collection,
    cm: &CaseMeshes,
    m: &NamedMethod,
    render: Option<&RenderOut>,
    out: &mut CaseResult,
) -> Result<()> {
    let Method::Clustering {
        pipeline,
        handles,
        features,
        examples,
        n_clusters,
        seed,
    } = &m.method
    else {
        return Err(Error::invalid("not a clustering method"));
    };
    let a = &*cm.a;
    let all = owned(&cm.a_def);
    let ex: &[Mesh] = match examples {
        ExamplesSpec::One => &all[..1],
        ExamplesSpec::All => &all,
    };
    out.set("n_selection_poses", ex.len().to_string());
    let t = Instant::now();
    let hs = farthest_point_sampling(
        a,
        (*handles).min(a.n_vertices()),
        FpsMetric::Geodesic,
        *seed,
    )?;
    let bih = Biharmonic::new(a)?;
    let w: DMatrix<f64> = match pipeline.keypoints.mode {
        SelectionMode::Exact => bih.weights(&hs, &pipeline.keypoints.weights)?,
        SelectionMode::Fast => {
            // Unbounded biharmonic weights, clamped to [0, 1] and renormalised.
            let mut w = bih.weights(&hs, &BbwOptions::with_mode(WeightMode::Unbounded))?;
            for mut row in w.row_iter_mut() {
                row.iter_mut().for_each(|x| *x = x.clamp(0.0, 1.0));
                let s: f64 = row.iter().sum();
                if s > 0.0 {
                    row /= s;
                }
            }
            w
        }
    };
    out.set("seconds_weights", secs(t.elapsed().as_secs_f64()));
    out.set(
        "seconds_weights_per_handle",
        secs(t.elapsed().as_secs_f64() / hs.len() as f64),
    );
    let truth = col.labels.as_ref().filter(|l| l.len() == a.n_vertices());
    let k = n_clusters
        .or_else(|| {
            truth.map(|l| {
                let mut u = l.clone();
                u.sort_unstable();
                u.dedup();
                u.len()
            })
        })
        .unwrap_or(hs.len());
    let t = Instant::now();
    let labels = rotation_groups(a, ex, &w, *features, Some(k), *seed)?;
    out.set("seconds_fit", secs(t.elapsed().as_secs_f64()));
    out.set("n_clusters", k.to_string());
    out.set("n_keypoints", hs.len().to_string());
    out.set(
        "keypoints",
        hs.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(";"),
    );
    if let Some(l) = truth {
        out.set("ari", num(crate::eval::adjusted_rand_index(&labels, l)?));
        out.set("purity", num(crate::skin::groups::purity(&labels, l)?));
    }
    let sa = ErrorScale::of_reference(a)?;
    let def: Vec<Vec<crate::Point>> = all.iter().map(|d| d.vertices().to_vec()).collect();
    out.set(
        "rigidity_unit",
        num(cluster_rigidity_rms(a.vertices(), &def, &labels)? * sa.unit_sphere),
    );
    if let Some(r) = render {
        let path = r.dir.join(&m.name).join("clusters.csv");
        let mut s = String::from("vertex,cluster\n");
        for (i, l) in labels.iter().enumerate() {
            s.push_str(&format!("{i},{l}\n"));
        }
        if !path.exists() {
            super::store::write_file(&path, s.as_bytes(), false)?;
        }
    }
    Ok(())
}

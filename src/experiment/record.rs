//! Running one method ([`crate::methods`]) on one case and recording what
//! it computed: the only code (with [`super::fbt`] for the FBT rows) that
//! knows the `cases.csv` column names.
//!
//! Measured quantities (columns of `cases.csv`, see [`super::store`]):
//!
//! * `err_*_unit` / `err_*_area`: per-vertex Euclidean distance between each
//!   transferred mesh `B′_j` and the ground truth, pooled over all vertices
//!   of all poses of the case (mean, RMS, max), in unit-sphere units of the
//!   target reference `B` and in √area(B) units ([`crate::eval`]); after a
//!   rigid Procrustes alignment of each `B′_j` onto its truth when
//!   `[metrics] procrustes = true` (column `procrustes`).
//! * `err_*_unit_rigid` / `err_*_area_rigid` (always, whatever
//!   `[metrics] procrustes` says): the same statistics after the best
//!   **rigid** alignment (rotation + translation, no scaling, no reflection;
//!   [`crate::eval::aligned_vertex_errors`], Kabsch) of each `B′_j` onto its
//!   truth; curve `cumulative_area_rigid` (grid of `cumulative_area`). With
//!   `procrustes = true` they equal the `err_*` columns.
//! * `within_002_area` / `within_005_area`: fraction of the pooled vertices
//!   whose raw (unaligned, whatever `procrustes` says) error is `≤ 0.02` /
//!   `≤ 0.05` √area(B); `within_002_area_rigid` / `within_005_area_rigid`:
//!   the same after the rigid alignment.
//! * `edge_strain_p99`: 99th percentile ([`crate::eval::percentile`], linear
//!   interpolation) of the edge strains `|ℓ′/ℓ − 1|` over every edge of `B`
//!   and every pose (`ℓ` edge length on `B`, `ℓ′` on `B′_j`,
//!   [`crate::eval::edge_strains`]); needs no truth, so every transfer row
//!   has it (`identity`: 0). `edge_strain_p99_source`: the same statistic
//!   of the source's own deformation (`A′_j` against `A`), the strain a
//!   transfer that reproduces the source's deformation carries (FAUST
//!   registrations in other poses reach 0.6–0.9 there: stretched armpits
//!   and crotch); `edge_strain_p99_fit`: of the method's own fit on the
//!   source (`D_S(A)` against `A`, BDT rows): strain the transfer inherits
//!   from too few key points rather than adds; `edge_strain_p99_truth`: of
//!   the ground truths against `B` (poses with a truth).
//! * `fit_error_unit`: the same mean distance between `D_S(A)` (the fit on
//!   the source) and `A′_j`, in unit-sphere units of `A`.
//! * `selection_error`: the selection's own error (its `error_norm`);
//!   `epsilon` and `n_candidates`: the selection's threshold ε and FPS
//!   candidates (automatic selections only; what a sweep of them varies).
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
//!   `seconds_refine`, `seconds_metrics`, `seconds_total`. Rows that share
//!   a memoised selection or fit and run at the same time compute it once;
//!   the others wait, and their `seconds_selection`, `seconds_fit` and
//!   `seconds_total` leave the wait out (wall time of the row's own work).
//!   A selection or fit reused from the memo (made by an earlier row of
//!   the process) takes a few milliseconds: `seconds_selection_computed`
//!   and `seconds_fit_computed` hold what it cost when it was made (equal
//!   to `seconds_selection` / `seconds_fit` in the row that made it), the
//!   real cost a timing table reports.

use std::sync::Arc;
use std::time::Instant;

use super::cases::Case;
use super::config::{Method, MetricsSpec, NamedMethod};
use super::dataset::Collection;
use super::store::{num, secs, CaseResult, Curve, RenderOut};
use crate::eval::{
    aligned_vertex_errors, arap_energy, cluster_rigidity_rms, cumulative_curve, curve_grid,
    distortion, edge_strains, error_stats, face_log_area_ratios, fraction_within, percentile,
    vertex_errors, ErrorScale,
};
use crate::mesh::Mesh;
use crate::methods::{
    Clustering, PickedKeypoints, TargetCorrespondence, TargetFound, TransferCase, TransferMethod,
    TransferOutcome,
};
use crate::ops::geodesic::EdgeGraph;
use crate::ops::total_area;
use crate::transfer::KeypointOptions;
use crate::Result;

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

    /// Errors, naming the file, when a mesh of the case spans a range whose
    /// squared lengths overflow or underflow `f64`
    /// ([`crate::mesh::check_extent`]): measured anyway, its lengths and
    /// areas would be infinite or zero.
    pub fn check_sizes(&self, col: &Collection, case: &Case) -> Result<()> {
        let (s, t, r) = (&case.source, &case.target, &case.reference);
        let mut meshes = vec![(s, r, &self.a), (t, r, &self.b)];
        for (p, m) in case.poses.iter().zip(&self.a_def) {
            meshes.push((s, p, m));
        }
        for (p, m) in case.poses.iter().zip(&self.truth) {
            if let Some(m) = m {
                meshes.push((t, p, m));
            }
        }
        for (subject, pose, m) in meshes {
            crate::mesh::check_extent(crate::mesh::half_diagonal(m.vertices())).map_err(|e| {
                crate::Error::invalid(format!(
                    "{} (subject {subject}, pose {pose}): {e}",
                    col.file_label(subject, pose)
                ))
            })?;
        }
        Ok(())
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
    let outer_waits = crate::data::memo::take_waited(0.0);
    let result = (|| -> Result<()> {
        match &m.method {
            Method::Fbt(f) => {
                let render = render.map(|r| (r, m.name.as_str()));
                super::fbt::run(col, case, f, metrics, render, out)?;
            }
            Method::Transfer(t) => {
                let cm = CaseMeshes::load(col, case)?;
                cm.check_sizes(col, case)?;
                out.set("n_vertices", cm.a.n_vertices().to_string());
                if !matches!(t, TransferMethod::Identity | TransferMethod::SumnerOracle) {
                    connected_source(col, case, &cm.a)?;
                }
                transfer(&cm, case, t, &m.name, metrics, render, out)?;
            }
            Method::Clustering(c) => {
                let cm = CaseMeshes::load(col, case)?;
                cm.check_sizes(col, case)?;
                out.set("n_vertices", cm.a.n_vertices().to_string());
                connected_source(col, case, &cm.a)?;
                clustering(col, &cm, c, &m.name, render, out)?;
            }
        }
        Ok(())
    })();
    let waited = crate::data::memo::take_waited(outer_waits);
    result?;
    // Without the time spent waiting for another row's shared result (a key
    // point selection or fit computed once for several rows).
    out.set(
        "seconds_total",
        secs((t_total.elapsed().as_secs_f64() - waited).max(0.0)),
    );
    Ok(())
}

/// Errors, naming the source's file and its component count, when the
/// source of a method that places handles on it (bounded biharmonic
/// weights, key point selection) is not one connected surface.
fn connected_source(col: &Collection, case: &Case, a: &Mesh) -> Result<()> {
    let parts = a.component_count();
    if parts > 1 {
        return Err(crate::Error::invalid(format!(
            "{} (subject {}, pose {}) has {parts} connected components (separate parts, or an \
             unwelded triangle soup: one per face); key points and their weights need one \
             connected source surface",
            col.file_label(&case.source, &case.reference),
            case.source,
            case.reference
        )));
    }
    Ok(())
}

/// The meshes behind `Arc`s, owned.
pub fn owned(v: &[Arc<Mesh>]) -> Vec<Mesh> {
    v.iter().map(|m| (**m).clone()).collect()
}

fn transfer(
    cm: &CaseMeshes,
    case: &Case,
    method: &TransferMethod,
    name: &str,
    metrics: &MetricsSpec,
    render: Option<&RenderOut>,
    out: &mut CaseResult,
) -> Result<()> {
    let a = &*cm.a;
    let a_def = owned(&cm.a_def);
    let b = &*cm.b;
    let o = method.run(&TransferCase {
        a,
        a_def: &a_def,
        b,
    })?;
    if let Some(p) = &o.keypoints {
        record_keypoints(p, out);
        if let (Some(_), Some(k)) = (&p.selection, selection_options(method)) {
            out.set("epsilon", num(k.epsilon));
            out.set("n_candidates", k.n_candidates.to_string());
        }
    }
    if let (Some(found), Some(p)) = (&o.target, &o.keypoints) {
        record_target(a, b, &p.keypoints, found, method, out)?;
    }
    record_timings(&o, out);
    if let Some(fit) = &o.fit {
        let sa = ErrorScale::of_reference(a)?;
        let mut fit_err = 0.0;
        let mut fit_strains = Vec::new();
        for (pos, d) in fit.positions.iter().zip(&a_def) {
            fit_err += error_stats(&vertex_errors(pos, d.vertices())?)?.mean * sa.unit_sphere;
            fit_strains.extend(edge_strains(a, pos)?);
        }
        out.set("fit_error_unit", num(fit_err / a_def.len() as f64));
        record_strain_p99("edge_strain_p99_fit", &fit_strains, out)?;
    }
    if let Some(errs) = &o.cage_fit_errors {
        let sa = ErrorScale::of_reference(a)?;
        let s: f64 = errs.iter().map(|e| e * sa.unit_sphere).sum();
        out.set("fit_error_unit", num(s / errs.len().max(1) as f64));
    }
    if let Some(d) = o.frames_differ {
        out.set(
            "target_frame",
            if d { "registration" } else { "source" }.to_string(),
        );
    }

    let mut source_strains = Vec::new();
    for d in &a_def {
        source_strains.extend(edge_strains(a, d.vertices())?);
    }
    record_strain_p99("edge_strain_p99_source", &source_strains, out)?;
    measure(b, &o.meshes, &cm.truth, metrics, out)?;

    if let Some(r) = render {
        let out = r.method(name);
        if let Some(reg) = o.target.as_ref().and_then(|f| f.auto.as_ref()) {
            out.save("registered", &reg.registered, None)?;
        }
        let sb = ErrorScale::of_reference(b)?;
        let sa = ErrorScale::of_reference(a)?;
        for (j, pose) in case.poses.iter().enumerate().take(r.poses) {
            // The errors behind `err_*_unit` (aligned when `procrustes`).
            let error = match &cm.truth[j] {
                Some(t) => Some(result_errors(&o.meshes[j], t, metrics.procrustes(), &sb)?),
                None => None,
            };
            out.save(&format!("result_{pose}"), &o.meshes[j], error.as_deref())?;
            if let Some(fit) = &o.fit {
                let fitted = a.with_vertices(fit.positions[j].clone())?;
                // The errors behind `fit_error_unit`.
                let e: Vec<f64> = vertex_errors(&fit.positions[j], a_def[j].vertices())?
                    .into_iter()
                    .map(|e| e * sa.unit_sphere)
                    .collect();
                out.save(&format!("fit_{pose}"), &fitted, Some(&e))?;
            }
        }
    }
    Ok(())
}

/// Per-vertex distance of a transferred mesh to its ground truth in
/// unit-sphere units of B (`sb`), after the best rigid alignment when
/// `procrustes`: the values the `err_*_unit` columns summarise, stored with
/// the result mesh.
fn result_errors(
    result: &Mesh,
    truth: &Mesh,
    procrustes: bool,
    sb: &ErrorScale,
) -> Result<Vec<f64>> {
    let e = if procrustes {
        aligned_vertex_errors(result.vertices(), truth.vertices())?
    } else {
        vertex_errors(result.vertices(), truth.vertices())?
    };
    Ok(e.into_iter().map(|x| x * sb.unit_sphere).collect())
}

/// `seconds_*` of a transfer.
fn record_timings(o: &TransferOutcome, out: &mut CaseResult) {
    let t = &o.timings;
    let n_kp = o.keypoints.as_ref().map_or(0, |p| p.keypoints.len());
    let set = |out: &mut CaseResult, k: &str, v: Option<f64>| {
        if let Some(v) = v {
            out.set(k, secs(v));
        }
    };
    set(out, "seconds_fit", t.fit);
    set(out, "seconds_fit_computed", t.fit_computed);
    set(out, "seconds_weights", t.weights);
    set(
        out,
        "seconds_weights_per_handle",
        t.weights.map(|w| w / n_kp.max(1) as f64),
    );
    set(out, "seconds_lbs", t.lbs);
    set(
        out,
        "seconds_lbs_per_pose",
        t.lbs.map(|l| l / o.meshes.len().max(1) as f64),
    );
    set(out, "seconds_refine", t.refine);
    set(out, "seconds_precompute", t.precompute);
    set(out, "seconds_factorise", t.factorise);
    set(out, "seconds_solve", t.solve);
}

/// The key point selection options of a method that selects key points.
fn selection_options(m: &TransferMethod) -> Option<&KeypointOptions> {
    m.keypoint_inputs().map(|(_, _, o)| o)
}

/// `n_keypoints`, `keypoints`, `seconds_selection` and, for an automatic
/// selection, `n_selection_poses`, `selection_error`,
/// `selection_evaluations` and the `selection_trace` curve.
fn record_keypoints(p: &PickedKeypoints, out: &mut CaseResult) {
    out.set("seconds_selection", secs(p.seconds));
    out.set("seconds_selection_computed", secs(p.seconds_computed));
    if let Some((sel, k)) = &p.selection {
        out.set("n_selection_poses", k.to_string());
        out.set("selection_error", num(sel.error));
        out.set("selection_evaluations", sel.evaluations.to_string());
        let (x, y): (Vec<f64>, Vec<f64>) = sel
            .trace
            .iter()
            .filter(|s| s.stage == 1)
            .map(|s| (s.keypoints.len() as f64, s.error))
            .unzip();
        out.curves.push(Curve::new("selection_trace", &x, &y));
    }
    out.set("n_keypoints", p.keypoints.len().to_string());
    out.set("keypoints", join(&p.keypoints));
}

fn join(v: &[usize]) -> String {
    v.iter()
        .map(|k| k.to_string())
        .collect::<Vec<_>>()
        .join(";")
}

/// The `target_*` columns (see the module documentation).
fn record_target(
    a: &Mesh,
    b: &Mesh,
    keypoints: &[usize],
    found: &TargetFound,
    method: &TransferMethod,
    out: &mut CaseResult,
) -> Result<()> {
    let Some((_, target, _)) = method.keypoint_inputs() else {
        return Ok(());
    };
    let name = match &target.correspondence {
        TargetCorrespondence::Identity => "identity",
        TargetCorrespondence::Auto => "auto",
        TargetCorrespondence::List(_) => "list",
        TargetCorrespondence::Markers { .. } => "markers",
    };
    out.set("target_correspondence", name.to_string());
    if let Some(r) = &found.auto {
        out.set("registration_residual_area", num(r.residual));
    }
    out.set("target_noise", num(target.noise));
    out.set("seconds_correspondence", secs(found.seconds));
    out.set("target_keypoints", join(&found.keypoints));
    if a.faces() == b.faces() {
        let graph = EdgeGraph::new(b);
        let s = total_area(b).sqrt();
        let mut sum = 0.0;
        for (&k, &t) in keypoints.iter().zip(&found.keypoints) {
            sum += graph.distances(&[k])?[t] / s;
        }
        out.set(
            "target_keypoint_error_area",
            num(sum / keypoints.len().max(1) as f64),
        );
    }
    Ok(())
}

/// Bounds of the `within_*` columns, in √area(B) units, with their column
/// suffixes.
const WITHIN_BOUNDS: [(f64, &str); 2] = [(0.02, "002"), (0.05, "005")];

/// Percentile of the per-edge strains reported as `edge_strain_p99*`.
const EDGE_STRAIN_PERCENTILE: f64 = 99.0;

/// Sets `column` to the [`EDGE_STRAIN_PERCENTILE`] of pooled edge strains
/// (left empty when there are none).
fn record_strain_p99(column: &str, strains: &[f64], out: &mut CaseResult) -> Result<()> {
    if !strains.is_empty() {
        out.set(column, num(percentile(strains, EDGE_STRAIN_PERCENTILE)?));
    }
    Ok(())
}

/// `err_{mean,rms,max}_{unit,area}{suffix}` of the pooled vertex errors.
fn record_errors(
    errors: &[f64],
    sb: &ErrorScale,
    suffix: &str,
    out: &mut CaseResult,
) -> Result<()> {
    let s = error_stats(errors)?;
    for (unit, st) in [
        ("unit", s.scaled(sb.unit_sphere)),
        ("area", s.scaled(sb.sqrt_area)),
    ] {
        out.set(&format!("err_mean_{unit}{suffix}"), num(st.mean));
        out.set(&format!("err_rms_{unit}{suffix}"), num(st.rms));
        out.set(&format!("err_max_{unit}{suffix}"), num(st.max));
    }
    Ok(())
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
    // Raw and rigidly aligned errors, pooled over the poses with a truth;
    // the `err_*` columns use the one `[metrics] procrustes` chooses.
    let mut raw: Vec<f64> = Vec::new();
    let mut rigid: Vec<f64> = Vec::new();
    let mut strains: Vec<f64> = Vec::new();
    let mut truth_strains: Vec<f64> = Vec::new();
    let (mut e_arap, mut e_arap_truth, mut d_area, mut d_edge) = (0.0, 0.0, 0.0, 0.0);
    let mut n_truth = 0;
    let mut log_area: Vec<f64> = Vec::new();
    for (res, truth) in results.iter().zip(truth) {
        e_arap += arap_energy(b, res.vertices())?.1;
        log_area.extend(face_log_area_ratios(b, res.vertices())?);
        strains.extend(edge_strains(b, res.vertices())?);
        let d = distortion(b, res.vertices())?;
        d_area += d.area_log_mean_abs;
        d_edge += d.edge_log_rms;
        if let Some(truth) = truth {
            raw.extend(vertex_errors(res.vertices(), truth.vertices())?);
            rigid.extend(aligned_vertex_errors(res.vertices(), truth.vertices())?);
            e_arap_truth += arap_energy(b, truth.vertices())?.1;
            truth_strains.extend(edge_strains(b, truth.vertices())?);
            n_truth += 1;
        }
    }
    let np = results.len().max(1) as f64;
    out.set("arap_energy", num(e_arap / np));
    out.set("distortion_area", num(d_area / np));
    out.set("distortion_edge", num(d_edge / np));
    record_strain_p99("edge_strain_p99", &strains, out)?;
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
        record_strain_p99("edge_strain_p99_truth", &truth_strains, out)?;
        let pooled = if procrustes { &rigid } else { &raw };
        record_errors(pooled, &sb, "", out)?;
        record_errors(&rigid, &sb, "_rigid", out)?;
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
        let raw_area: Vec<f64> = raw.iter().map(|e| e * sb.sqrt_area).collect();
        let rigid_area: Vec<f64> = rigid.iter().map(|e| e * sb.sqrt_area).collect();
        for (bound, suffix) in WITHIN_BOUNDS {
            out.set(
                &format!("within_{suffix}_area"),
                num(fraction_within(&raw_area, bound)),
            );
            out.set(
                &format!("within_{suffix}_area_rigid"),
                num(fraction_within(&rigid_area, bound)),
            );
        }
        out.curves.push(Curve::new(
            "cumulative_area_rigid",
            &grid,
            &cumulative_curve(&rigid_area, &grid),
        ));
    }
    out.set("seconds_metrics", secs(t.elapsed().as_secs_f64()));
    Ok(())
}

fn clustering(
    col: &Collection,
    cm: &CaseMeshes,
    c: &Clustering,
    name: &str,
    render: Option<&RenderOut>,
    out: &mut CaseResult,
) -> Result<()> {
    let a = &*cm.a;
    let all = owned(&cm.a_def);
    let truth = col.labels.as_ref().filter(|l| l.len() == a.n_vertices());
    let n_true = truth.map(|l| {
        let mut u = l.clone();
        u.sort_unstable();
        u.dedup();
        u.len()
    });
    let o = c.run(a, &all, n_true)?;
    out.set("n_selection_poses", o.n_examples.to_string());
    out.set("seconds_weights", secs(o.seconds_weights));
    out.set(
        "seconds_weights_per_handle",
        secs(o.seconds_weights / o.handles.len() as f64),
    );
    out.set("seconds_fit", secs(o.seconds_clustering));
    out.set("n_clusters", o.n_clusters.to_string());
    out.set("n_keypoints", o.handles.len().to_string());
    out.set("keypoints", join(&o.handles));
    if let Some(l) = truth {
        out.set("ari", num(crate::eval::adjusted_rand_index(&o.labels, l)?));
        out.set("purity", num(crate::skin::groups::purity(&o.labels, l)?));
    }
    let sa = ErrorScale::of_reference(a)?;
    let def: Vec<Vec<crate::Point>> = all.iter().map(|d| d.vertices().to_vec()).collect();
    out.set(
        "rigidity_unit",
        num(cluster_rigidity_rms(a.vertices(), &def, &o.labels)? * sa.unit_sphere),
    );
    if let Some(r) = render {
        let path = r.dir.join(name).join("clusters.csv");
        let mut s = String::from("vertex,cluster\n");
        for (i, l) in o.labels.iter().enumerate() {
            s.push_str(&format!("{i},{l}\n"));
        }
        if !path.exists() {
            super::store::write_file(&path, s.as_bytes(), false)?;
        }
    }
    Ok(())
}

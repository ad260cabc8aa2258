//! Baseline methods run on a case ([`crate::baselines`]), measured exactly
//! like the BDT rows ([`super::methods::measure`]: same `cases.csv` columns,
//! curves and renders).
//!
//! * `kind = "sumner"`: Sumner & Popović deformation transfer in the "few
//!   correspondences" setting of the BDT paper. The key points are the
//!   automatic BDT selection of the case, run with the method's key point
//!   options (the same options and seed give the same key points as a `bdt`
//!   row of the config); as in BDT, target key point `i` is source key point
//!   `i` (the harness requires shared connectivity). The pairs are the
//!   markers of Sumner's correspondence step
//!   ([`crate::baselines::correspond`], default options), whose triangle
//!   pairs drive [`DeformationTransfer`]; each deformed source is then
//!   transferred.
//! * `kind = "sumner_oracle"`: the identity triangle correspondence (full
//!   correspondence; an error when the meshes' faces differ).
//! * `kind = "cage"`: [`CageTransfer`] with the same key points as markers.
//!
//! **Translation.** Deformation transfer determines the result only up to a
//! translation (the solve pins one vertex at its rest position). Every
//! result is translated so that the centroid of the target marker vertices
//! moves by the same vector as the centroid of the source marker vertices
//! in the pose (the oracle: all vertices). This uses only source data.
//!
//! Columns: `seconds_selection` (key points), `seconds_precompute`
//! (correspondence step; cages and coordinates), `seconds_factorise` (the
//! deformation transfer matrix), `seconds_solve` (all poses; for `cage`
//! rows the cage fits, cage transfers and reconstructions); `fit_error_unit` is the cage
//! fit residual `‖Φ_s C_s′ − A′‖` (mean, unit-sphere units of `A`) for
//! `cage` rows.

use std::time::Instant;

use super::cases::Case;
use super::config::{Method, MetricsSpec, NamedMethod};
use super::methods::{
    auto_keypoints, measure, owned, record_keypoints, save_mesh, target_keypoints, CaseMeshes,
    RenderOut,
};
use super::store::{num, secs, CaseResult};
use crate::baselines::{
    CageOptions, CageTransfer, CorrespondenceOptions, DeformationTransfer, SumnerTransferOptions,
    TriangleCorrespondence,
};
use crate::eval::ErrorScale;
use crate::mesh::Mesh;
use crate::{Error, Result, Vec3};

/// Translates `result` so that the centroid of its vertices `targets`
/// moves by the displacement of the centroid of `sources` from
/// `source_rest` to `source_pose` (relative to `target_rest`).
pub fn match_translation(
    result: &Mesh,
    target_rest: &Mesh,
    source_rest: &Mesh,
    source_pose: &Mesh,
    pairs: &[(usize, usize)],
) -> Result<Mesh> {
    if pairs.is_empty() {
        return Err(Error::invalid("translation from an empty marker list"));
    }
    let (rv, tv) = (result.vertices(), target_rest.vertices());
    let (sr, sp) = (source_rest.vertices(), source_pose.vertices());
    let mut shift = Vec3::zeros();
    for &(s, t) in pairs {
        shift += (sp[s] - sr[s]) - (rv[t] - tv[t]);
    }
    shift /= pairs.len() as f64;
    result.map_vertices(|p| p + shift)
}

/// Runs a baseline method on a case (see the module documentation).
pub fn run(
    cm: &CaseMeshes,
    case: &Case,
    m: &NamedMethod,
    metrics: &MetricsSpec,
    render: Option<&RenderOut>,
    out: &mut CaseResult,
) -> Result<()> {
    let a = &*cm.a;
    let b = &*cm.b;
    let a_def = owned(&cm.a_def);
    let p = m.method.pipeline();
    let oracle = matches!(m.method, Method::SumnerOracle { .. });
    // Markers.
    let markers: Vec<(usize, usize)> = if oracle {
        if a.faces() != b.faces() {
            return Err(Error::invalid(format!(
                "sumner_oracle needs shared connectivity: source has {} vertices / {} faces, \
                 target {} / {} (or different faces)",
                a.n_vertices(),
                a.n_faces(),
                b.n_vertices(),
                b.n_faces()
            )));
        }
        (0..a.n_vertices()).map(|i| (i, i)).collect()
    } else {
        let t = Instant::now();
        let kp = auto_keypoints(a, &a_def, p, out)?;
        out.set("seconds_selection", secs(t.elapsed().as_secs_f64()));
        record_keypoints(&kp, out);
        // Target key points: identity / automatic, optional noise (issue 8).
        let dir = render.map(|r| r.dir.join(&m.name));
        let (tk, auto) = target_keypoints(cm, &kp, p, dir.as_deref(), out)?;
        if auto.as_ref().is_some_and(|r| r.frames_differ()) {
            return Err(Error::invalid(
                "the registration rotated the source onto the target: the baselines assume \
                 one frame (only bdt re-expresses its transforms in the target's frame)",
            ));
        }
        kp.iter().copied().zip(tk).collect()
    };

    let t_solve;
    let results: Vec<Mesh> = match &m.method {
        Method::Sumner { .. } | Method::SumnerOracle { .. } => {
            let t = Instant::now();
            let corr = if oracle {
                TriangleCorrespondence::identity(a.n_faces())
            } else {
                crate::baselines::correspond(a, b, &markers, &CorrespondenceOptions::default())?
                    .triangles
            };
            out.set("seconds_precompute", secs(t.elapsed().as_secs_f64()));
            let dt = DeformationTransfer::new(a, b, &corr, &SumnerTransferOptions::default())?;
            out.set("seconds_factorise", secs(dt.factor_seconds()));
            t_solve = Instant::now();
            a_def
                .iter()
                .map(|pose| match_translation(&dt.transfer(pose)?, b, a, pose, &markers))
                .collect::<Result<Vec<_>>>()?
        }
        Method::Cage { .. } => {
            let t = Instant::now();
            let ct = CageTransfer::new(a, b, &markers, &CageOptions::default())?;
            out.set("seconds_precompute", secs(t.elapsed().as_secs_f64()));
            t_solve = Instant::now();
            let sa = ErrorScale::of_reference(a)?;
            let mut fit_err = 0.0;
            let mut res = Vec::with_capacity(a_def.len());
            for pose in &a_def {
                let r = ct.transfer(pose)?;
                fit_err += r.fit_error * sa.unit_sphere;
                res.push(r.mesh);
            }
            out.set("fit_error_unit", num(fit_err / a_def.len().max(1) as f64));
            res
        }
        _ => return Err(Error::invalid("not a baseline method")),
    };
    out.set("seconds_solve", secs(t_solve.elapsed().as_secs_f64()));

    measure(b, &results, &cm.truth, metrics, out)?;

    if let Some(r) = render {
        let dir = r.dir.join(&m.name);
        for (j, pose) in case.poses.iter().enumerate().take(r.poses) {
            save_mesh(&dir.join(format!("result_{pose}.ply")), &results[j])?;
        }
    }
    Ok(())
}

use crate::register::metrics::median;

/// Timing of the baselines on the cases of `experiments/fig14.toml` (the
/// config is compiled in): per case, the automatic key points of its
/// `automatic` method (not timed), then Sumner DT with those markers
/// (correspondence step, factorisation, per-pose solve), the oracle
/// (factorisation, per-pose solve) and cage DT (cages + coordinates +
/// factorisations, per-pose transfer). A Markdown table of medians over
/// cases × runs (3 runs, 1 when `quick`; per-pose times over all poses).
pub fn bench_fig14(quick: bool) -> Result<String> {
    use std::fmt::Write as _;
    let text = include_str!("../../experiments/fig14.toml");
    let cfg = super::config::parse_config(text, std::path::Path::new("experiments/fig14.toml"))?;
    let col = super::Collection::open(&cfg)?;
    let cases = super::generate_cases(&cfg, &col)?;
    let auto = cfg
        .methods
        .iter()
        .find(|m| matches!(m.method, Method::Bdt { .. }))
        .ok_or_else(|| Error::invalid("fig14.toml has no bdt method"))?;
    let reps = if quick { 1 } else { 3 };
    let names = [
        "sumner: correspondence",
        "sumner: factorise",
        "sumner: solve per pose",
        "oracle: factorise",
        "oracle: solve per pose",
        "cage: cages, coordinates, factorisations",
        "cage: transfer per pose",
    ];
    let mut t: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut nv = 0;
    for case in &cases {
        let cm = CaseMeshes::load(&col, case)?;
        let (a, b) = (&*cm.a, &*cm.b);
        nv = a.n_vertices();
        let a_def = owned(&cm.a_def);
        let mut scratch = CaseResult::default();
        let kp = auto_keypoints(a, &a_def, auto.method.pipeline(), &mut scratch)?;
        let markers: Vec<(usize, usize)> = kp.iter().map(|&k| (k, k)).collect();
        for _ in 0..reps {
            let s = Instant::now();
            let corr =
                crate::baselines::correspond(a, b, &markers, &CorrespondenceOptions::default())?;
            t[0].push(s.elapsed().as_secs_f64());
            let s = Instant::now();
            let dt =
                DeformationTransfer::new(a, b, &corr.triangles, &SumnerTransferOptions::default())?;
            t[1].push(s.elapsed().as_secs_f64());
            for pose in &a_def {
                let s = Instant::now();
                dt.transfer(pose)?;
                t[2].push(s.elapsed().as_secs_f64());
            }
            let s = Instant::now();
            let dt = DeformationTransfer::new(
                a,
                b,
                &TriangleCorrespondence::identity(a.n_faces()),
                &SumnerTransferOptions::default(),
            )?;
            t[3].push(s.elapsed().as_secs_f64());
            for pose in &a_def {
                let s = Instant::now();
                dt.transfer(pose)?;
                t[4].push(s.elapsed().as_secs_f64());
            }
            let s = Instant::now();
            let ct = CageTransfer::new(a, b, &markers, &CageOptions::default())?;
            t[5].push(s.elapsed().as_secs_f64());
            for pose in &a_def {
                let s = Instant::now();
                ct.transfer(pose)?;
                t[6].push(s.elapsed().as_secs_f64());
            }
        }
    }
    let mut out = String::new();
    let _ = writeln!(
        out,
        "fig14 synthetic cases: {} case(s), {nv} vertices, key points of its `{}` method; \
         medians over cases × {reps} run(s); {} solver thread(s)\n",
        cases.len(),
        auto.name,
        crate::solve::threads()
    );
    let _ = writeln!(out, "| step | median (ms) |");
    let _ = writeln!(out, "|---|---|");
    for (n, v) in names.iter().zip(t) {
        let _ = writeln!(out, "| {n} | {:.2} |", 1e3 * median(v));
    }
    Ok(out)
}

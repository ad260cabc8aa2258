//! Timing of Sumner & Popović deformation transfer: the correspondence
//! step, the factorisation and one per-pose solve, medians over runs; and
//! ([`bench_registration`]) of the FBT Fig. 7 registration baselines, Der
//! et al. and Amberg NICP, on the synthetic and the TOSCA cat completion
//! cases.
//!
//! Reads `../shared/data/sumner/cat-lion` (cat reference → lion reference
//! with its 55 markers, the nine cat poses); when absent, the synthetic
//! case of the tests (subject 1 → a remesh of subject 0 at resolution 2,
//! 24 farthest-point markers) and says so. This module does file I/O and is
//! not used by the algorithms.

use std::fmt::Write as _;
use std::time::Instant;

use crate::baselines::sumner::{DeformationTransfer, SumnerTransferOptions};
use crate::baselines::sumner_correspondence::{correspond, CorrespondenceOptions};
use crate::data::read_markers_yml;
use crate::data::synthetic::FaustStyle;
use crate::mesh::io::read_mesh;
use crate::ops::{farthest_point_sampling, FpsMetric};
use crate::{Error, Mesh, Result};

use crate::register::metrics::median;

struct Case {
    name: String,
    source: Mesh,
    target: Mesh,
    markers: Vec<(usize, usize)>,
    poses: Vec<Mesh>,
}

fn case(out: &mut String) -> Result<Case> {
    if let Some(dir) = crate::data::shared_data_dir().map(|d| d.join("sumner/cat-lion")) {
        if dir.is_dir() {
            let _ = writeln!(out, "data: {}", dir.display());
            let mf = read_markers_yml(&dir.join("markers-cat-lion.yml"), 0)?;
            let poses = (1..=9)
                .map(|p| read_mesh(&dir.join(format!("cat-{p:02}.obj"))))
                .collect::<Result<Vec<_>>>()?;
            return Ok(Case {
                name: "cat → lion".into(),
                source: read_mesh(&dir.join("cat-reference.obj"))?,
                target: read_mesh(&dir.join("lion-reference.obj"))?,
                markers: mf.pairs.iter().map(|p| (p.source, p.target)).collect(),
                poses,
            });
        }
    }
    let _ = writeln!(
        out,
        "data: ../shared/data/sumner/cat-lion not found; using synthetic subject 1 → remeshed \
         subject 0 (resolution 2)"
    );
    let set = FaustStyle {
        subjects: 2,
        poses: 4,
        resolution: 2,
        ..Default::default()
    }
    .generate()?;
    let remeshed = set.remesh(0.7)?;
    let picks = farthest_point_sampling(&remeshed.mesh, 24, FpsMetric::Euclidean, 7)?;
    let markers = picks
        .iter()
        .map(|&j| {
            let sp = remeshed.map[j];
            let k = (0..3)
                .max_by(|&a, &b| sp.bary[a].total_cmp(&sp.bary[b]))
                .unwrap_or(0);
            (set.faces()[sp.face][k], j)
        })
        .collect();
    Ok(Case {
        name: "synthetic → remesh".into(),
        source: set.rest[1].clone(),
        target: remeshed.mesh,
        markers,
        poses: set.meshes[1].clone(),
    })
}

/// Runs the benchmark and returns a Markdown report: medians over 3 runs
/// (1 when `quick`) of the correspondence step, of the factorisation and
/// of one pose's solve (the median over all poses and runs).
pub fn bench(quick: bool) -> Result<String> {
    let mut out = String::new();
    let reps = if quick { 1 } else { 3 };
    let c = case(&mut out)?;
    let opts = CorrespondenceOptions::default();
    let (mut t_corr, mut t_fact, mut t_solve) = (Vec::new(), Vec::new(), Vec::new());
    let mut pairs = 0;
    for _ in 0..reps {
        let t = Instant::now();
        let res = correspond(&c.source, &c.target, &c.markers, &opts)?;
        t_corr.push(t.elapsed().as_secs_f64());
        pairs = res.triangles.pairs().len();
        let t = Instant::now();
        let dt = DeformationTransfer::new(
            &c.source,
            &c.target,
            &res.triangles,
            &SumnerTransferOptions::default(),
        )?;
        t_fact.push(t.elapsed().as_secs_f64());
        for pose in &c.poses {
            let t = Instant::now();
            dt.transfer(pose)?;
            t_solve.push(t.elapsed().as_secs_f64());
        }
    }
    if t_solve.is_empty() {
        return Err(Error::invalid("Sumner bench: no poses"));
    }
    let _ = writeln!(
        out,
        "medians of {reps} run(s); {} thread(s) for faer\n",
        crate::solve::threads()
    );
    let _ = writeln!(
        out,
        "| case | source v/f | target v/f | markers | pairs | correspondence (s) | factorise (ms) | solve per pose (ms) |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    let _ = writeln!(
        out,
        "| {} | {}/{} | {}/{} | {} | {} | {:.2} | {:.1} | {:.2} |",
        c.name,
        c.source.n_vertices(),
        c.source.n_faces(),
        c.target.n_vertices(),
        c.target.n_faces(),
        c.markers.len(),
        pairs,
        median(t_corr),
        1e3 * median(t_fact),
        1e3 * median(t_solve)
    );
    Ok(out)
}

/// One registration case of [`bench_registration`].
struct RegCase {
    name: String,
    examples: Vec<Mesh>,
    target: Mesh,
}

fn registration_cases(out: &mut String) -> Result<Vec<RegCase>> {
    let class = crate::register::synthetic_class(1, 0)?;
    let mut cases = vec![RegCase {
        name: "synthetic class (Fig. 7 config, pose 5)".into(),
        examples: class[..4].to_vec(),
        target: class[5].clone(),
    }];
    match crate::data::shared_data_dir().map(|d| d.join("tosca")) {
        Some(d) if d.is_dir() => {
            let folder = crate::data::ToscaFolder::open(&d)?;
            match folder.classes.get("cat") {
                Some(entries) if entries.len() >= 5 => {
                    let meshes: Vec<Mesh> =
                        entries.iter().map(|e| e.load()).collect::<Result<_>>()?;
                    let (_, meshes) = crate::mesh::set::adopt_consistent_faces(&meshes)?;
                    cases.push(RegCase {
                        name: "TOSCA cat (examples 0–3, last pose partial)".into(),
                        examples: meshes[..4].to_vec(),
                        target: meshes[meshes.len() - 1].clone(),
                    });
                }
                _ => {
                    let _ = writeln!(
                        out,
                        "TOSCA cat: fewer than 5 cat meshes in {}; skipped",
                        d.display()
                    );
                }
            }
        }
        _ => {
            let _ = writeln!(
                out,
                "TOSCA cat: ../shared/data/tosca not found; only the synthetic case"
            );
        }
    }
    Ok(cases)
}

/// Median times of the registration baselines of FBT Fig. 7 (Der et al.
/// and Amberg NICP) on the completion case: the synthetic class (q = 4,
/// target pose 5) and, when `../shared/data/tosca` is present, the cat
/// (examples cat0–3, the last cat partial). Partial target, 8 features × 10
/// circles and options exactly as the `completion` task (the FBT rotation
/// clusters of the default configuration). Medians of 3 runs (1 when
/// `quick`).
pub fn bench_registration(quick: bool) -> Result<String> {
    use crate::methods::completion::{
        CompletionProblem, CompletionSolver, FbtOptions, FeatureOptions,
    };
    use crate::register::metrics;
    let mut out = String::new();
    let reps = if quick { 1 } else { 3 };
    let cases = registration_cases(&mut out)?;
    let opts = FbtOptions::default();
    let _ = writeln!(
        out,
        "medians of {reps} run(s); {} thread(s) for faer; the completion task's solvers \
         (methods::completion, FbtOptions::default(): NICP {} iterations for Der, Amberg's own schedule)\n",
        crate::solve::threads(),
        opts.nicp_iterations
    );
    let _ = writeln!(
        out,
        "| case | n | r | Der precompute (ms) | Der feature registration (ms) | Der NICP (s) | Der mean dist. | Amberg NICP (s) | Amberg mean dist. |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
    for c in &cases {
        let problem =
            CompletionProblem::new(&c.examples, &c.target, &FeatureOptions::default(), 0)?;
        let der = CompletionSolver::der(&opts, 0);
        let amberg = CompletionSolver::amberg(&opts, 0);
        let (mut t_pre, mut t_reg, mut t_nicp, mut t_amb) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut d_der, mut d_amb) = (f64::NAN, f64::NAN);
        let mut r = 0;
        for _ in 0..reps {
            let o = der.solve(&problem)?;
            t_pre.push(o.seconds_precompute.unwrap_or(f64::NAN));
            t_reg.push(o.seconds_solve.unwrap_or(f64::NAN));
            t_nicp.push(o.seconds_nicp.unwrap_or(f64::NAN));
            r = o.n_clusters.unwrap_or(0);
            d_der = metrics::mean(&problem.distortion(&o.positions)?);
            let o = amberg.solve(&problem)?;
            t_amb.push(o.seconds_nicp.unwrap_or(f64::NAN));
            d_amb = metrics::mean(&problem.distortion(&o.positions)?);
        }
        let _ = writeln!(
            out,
            "| {} | {} | {r} | {:.1} | {:.1} | {:.2} | {:.4} | {:.2} | {:.4} |",
            c.name,
            problem.reference().n_vertices(),
            1e3 * median(t_pre),
            1e3 * median(t_reg),
            median(t_nicp),
            d_der,
            median(t_amb),
            d_amb
        );
    }
    Ok(out)
}

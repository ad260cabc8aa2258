//! Timing of Sumner & Popović deformation transfer: the correspondence
//! step, the factorisation and one per-pose solve, medians over runs.
//!
//! Reads `../shared/data/sumner/cat-lion` (cat reference → lion reference
//! with its 55 markers, the nine cat poses); when absent, the synthetic
//! case of the tests (subject 1 → a remesh of subject 0 at resolution 2,
//! 24 farthest-point markers) and says so. This module does file I/O and is
//! not used by the algorithms.

use std::fmt::Write as _;
use std::time::Instant;

use super::sumner::{DeformationTransfer, SumnerTransferOptions};
use super::sumner_correspondence::{correspond, CorrespondenceOptions};
use crate::data::read_markers_yml;
use crate::data::synthetic::FaustStyle;
use crate::mesh::io::read_mesh;
use crate::ops::{farthest_point_sampling, FpsMetric};
use crate::{Error, Mesh, Result};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    v[v.len() / 2]
}

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

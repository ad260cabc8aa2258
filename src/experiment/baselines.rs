//! Timing of the Sumner and cage baselines on the Fig. 14 cases.

use std::time::Instant;

use super::config::Method;
use super::record::{owned, CaseMeshes};
use crate::baselines::{
    CageOptions, CageTransfer, CorrespondenceOptions, DeformationTransfer, SumnerTransferOptions,
    TriangleCorrespondence,
};
use crate::methods::{KeypointSource, TransferMethod};
use crate::register::metrics::median;
use crate::{Error, Result};

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
    let (auto, keypoints, options) = cfg
        .methods
        .iter()
        .find_map(|m| {
            if let Method::Transfer(TransferMethod::Bdt {
                keypoints: k @ KeypointSource::Automatic { .. },
                options,
                ..
            }) = &m.method
            {
                Some((m, k, &options.keypoints))
            } else {
                None
            }
        })
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
        let kp = keypoints.pick(a, &a_def, options)?.keypoints;
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

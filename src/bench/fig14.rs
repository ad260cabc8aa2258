//! Timing of the baselines on the cases of `experiments/fig14.toml` (the
//! config is compiled in), through the same method values as the harness
//! ([`TransferMethod::run`]): per case, the automatic key points of its
//! `automatic` method (selected once, not timed), then Sumner DT with those
//! markers (correspondence step, factorisation, all poses), the oracle
//! (factorisation, all poses) and cage DT (cages + coordinates +
//! factorisations, all poses). A Markdown table of medians over cases ×
//! runs (3 runs, 1 when `quick`; per-pose times are a run's total over its
//! poses).

use std::fmt::Write as _;
use std::path::Path;

use crate::experiment::parse_config;
use crate::experiment::record::{owned, CaseMeshes};
use crate::experiment::{generate_cases, Collection, Method};
use crate::methods::{
    cage_markers, sumner_markers, KeypointSource, MarkerBaseline, TargetPoints, TransferCase,
    TransferMethod,
};
use crate::register::metrics::median;
use crate::{Error, Result};

/// The table (see the module documentation).
pub fn run(quick: bool) -> Result<String> {
    let text = include_str!("../../experiments/fig14.toml");
    let cfg = parse_config(text, Path::new("experiments/fig14.toml"))?;
    let col = Collection::open(&cfg)?;
    let cases = generate_cases(&cfg, &col)?;
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
        let tc = TransferCase {
            a,
            a_def: &a_def,
            b,
        };
        let per_pose = |s: Option<f64>| s.unwrap_or(f64::NAN) / a_def.len().max(1) as f64;
        let kp = keypoints.pick(a, &a_def, options)?.keypoints;
        let given = KeypointSource::Given(kp);
        let sumner = TransferMethod::Markers {
            baseline: MarkerBaseline {
                name: "sumner",
                run: sumner_markers,
            },
            keypoints: given.clone(),
            target: TargetPoints::default(),
            options: options.clone(),
        };
        let cage = TransferMethod::Markers {
            baseline: MarkerBaseline {
                name: "cage",
                run: cage_markers,
            },
            keypoints: given,
            target: TargetPoints::default(),
            options: options.clone(),
        };
        for _ in 0..reps {
            let s = sumner.run(&tc)?.timings;
            t[0].push(s.precompute.unwrap_or(f64::NAN));
            t[1].push(s.factorise.unwrap_or(f64::NAN));
            t[2].push(per_pose(s.solve));
            let o = TransferMethod::SumnerOracle.run(&tc)?.timings;
            t[3].push(o.factorise.unwrap_or(f64::NAN));
            t[4].push(per_pose(o.solve));
            let c = cage.run(&tc)?.timings;
            t[5].push(c.precompute.unwrap_or(f64::NAN));
            t[6].push(per_pose(c.solve));
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

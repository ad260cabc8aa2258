//! Timing of automatic key point selection (BDT Sec. 3.5, Table 1 column
//! "Key Point Selection").
//!
//! `run(quick)` reads FAUST `tr_reg_001.ply` (A) and the other poses of the
//! same subject present in the shared data folder (`tr_reg_003`, `007` in
//! the sample: so m = 1 uses 003 and the multi-source case uses m = 2, the
//! number available), or, when absent, a synthetic FAUST-style subject and
//! says so. It reports
//!
//! * full selections in fast mode (n_c = 100, or 30 when `quick`) for m = 1
//!   and m = all, with the paper's ε = 0.03 and with ε = 0 capped at
//!   `max_keypoints` (the paper's normalisation reaches 0.03 at once on a
//!   6890-vertex mesh, see [`crate::transfer::keypoints`]);
//! * median times of single trial evaluations (weights + groups + ARAP for
//!   all sources) in exact and fast mode at several set sizes, and from them
//!   an extrapolated exact-mode selection time for the trial count of the
//!   corresponding fast run.
//!
//! This module does file I/O (it reads meshes) and is not used by the
//! algorithms.

use std::fmt::Write as _;
use std::time::Instant;

use crate::data::synthetic::FaustStyle;
use crate::mesh::io::read_mesh;
use crate::ops::{farthest_point_sampling, FpsMetric};
use crate::transfer::keypoints::{fit_keypoints, select_keypoints, KeypointOptions, SelectionMode};
use crate::{Mesh, Result};

/// Appends a line to the table and echoes it to stderr (progress).
macro_rules! emit {
    ($out:expr, $($arg:tt)*) => {{
        let line = format!($($arg)*);
        eprintln!("{line}");
        let _ = writeln!($out, "{line}");
    }};
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Source and deformed sources (FAUST sample or synthetic fallback).
fn bench_meshes(out: &mut String) -> Result<(Mesh, Vec<Mesh>)> {
    let dir = crate::data::shared_data_dir().map(|d| d.join("faust"));
    if let Some(dir) = dir {
        let a = dir.join("tr_reg_001.ply");
        if a.exists() {
            let source = read_mesh(&a)?;
            let mut deformed = Vec::new();
            let mut names = Vec::new();
            for pose in 2..10 {
                let p = dir.join(format!("tr_reg_00{pose}.ply"));
                if p.exists() {
                    deformed.push(read_mesh(&p)?);
                    names.push(format!("tr_reg_00{pose}"));
                }
            }
            if !deformed.is_empty() {
                emit!(
                    out,
                    "mesh: {} ({} vertices); deformed sources of the same subject: {}",
                    a.display(),
                    source.n_vertices(),
                    names.join(", ")
                );
                return Ok((source, deformed));
            }
        }
    }
    let set = FaustStyle {
        subjects: 1,
        poses: 4,
        resolution: 2,
        ..Default::default()
    }
    .generate()?;
    let source = set.meshes[0][0].clone();
    let deformed = set.meshes[0][1..].to_vec();
    emit!(
        out,
        "mesh: FAUST sample not found; synthetic FAUST-style subject 0 ({} vertices), poses 1..=3",
        source.n_vertices()
    );
    Ok((source, deformed))
}

/// Runs the benchmark and returns the printed table.
pub fn run(quick: bool) -> Result<String> {
    let mut out = String::new();
    let (source, deformed) = bench_meshes(&mut out)?;
    let n_c = if quick { 30 } else { 100 };
    let max_k = if quick { 6 } else { 12 };
    let reps = if quick { 2 } else { 3 };
    let threads = rayon::current_num_threads();
    emit!(
        out,
        "n_c = {n_c}, rayon threads = {threads}; selections are single runs, trial times medians of {reps}\n"
    );
    emit!(
        out,
        "| mode | m | ε | max k | key points | stage-1 / stage-2 steps | trials | final Ê | time (s) |"
    );
    emit!(out, "|---|---|---|---|---|---|---|---|---|");
    let ms: Vec<usize> = if deformed.len() > 1 {
        vec![1, deformed.len()]
    } else {
        vec![1]
    };
    let mut fast_trials = Vec::new();
    for &m in &ms {
        for (eps, cap) in [(0.03, 30), (0.0, max_k)] {
            let opts = KeypointOptions {
                n_candidates: n_c,
                epsilon: eps,
                max_keypoints: cap,
                mode: SelectionMode::Fast,
                ..Default::default()
            };
            let t = Instant::now();
            let sel = select_keypoints(&source, &deformed[..m], &opts)?;
            let secs = t.elapsed().as_secs_f64();
            let s1 = sel.trace.iter().filter(|s| s.stage == 1).count();
            let s2 = sel.trace.len() - s1;
            emit!(
                out,
                "| fast | {m} | {eps} | {cap} | {} | {s1} / {s2} | {} | {:.3e} | {secs:.1} |",
                sel.keypoints.len(),
                sel.evaluations,
                sel.error
            );
            if eps == 0.0 {
                fast_trials.push((m, sel.evaluations, sel.keypoints.len()));
            }
        }
    }

    // Per-trial timings.
    emit!(out, "\n| mode | m | |S| | trial time (s, median) |");
    emit!(out, "|---|---|---|---|");
    let cands = farthest_point_sampling(&source, n_c, FpsMetric::Geodesic, 0)?;
    let sizes: Vec<usize> = [2, max_k / 2, max_k]
        .into_iter()
        .filter(|&k| k >= 1)
        .collect();
    let mut exact_at = Vec::new();
    for &m in &ms {
        for mode in [SelectionMode::Fast, SelectionMode::Exact] {
            for &k in &sizes {
                let opts = KeypointOptions {
                    mode,
                    ..Default::default()
                };
                let set = &cands[..k];
                let mut times = Vec::new();
                for _ in 0..reps {
                    let t = Instant::now();
                    // fit_keypoints includes the per-run precomputation
                    // (normalisation, Q, features; fast: k Green's
                    // functions), which a selection does once.
                    fit_keypoints(&source, &deformed[..m], set, &opts)?;
                    times.push(t.elapsed().as_secs_f64());
                }
                let med = median(times);
                let name = match mode {
                    SelectionMode::Fast => "fast",
                    SelectionMode::Exact => "exact",
                };
                emit!(out, "| {name} (fit incl. setup) | {m} | {k} | {med:.3} |");
                if mode == SelectionMode::Exact {
                    exact_at.push((m, k, med));
                }
            }
        }
    }
    emit!(
        out,
        "\nExact-mode extrapolation (trials of the ε = 0 fast run × mean exact trial time over the sizes above, / {threads} threads):"
    );
    for (m, trials, _) in &fast_trials {
        let ts: Vec<f64> = exact_at
            .iter()
            .filter(|(mm, _, _)| mm == m)
            .map(|e| e.2)
            .collect();
        let mean = ts.iter().sum::<f64>() / ts.len().max(1) as f64;
        let est = *trials as f64 * mean / threads as f64;
        emit!(
            out,
            "- m = {m}: {trials} trials × {mean:.2} s / {threads} ≈ {:.0} s ({:.2} h)",
            est,
            est / 3600.0
        );
    }
    Ok(out)
}

//! Timing of automatic key point selection (BDT Sec. 3.5; Table 1, column
//! "Key Point Selection").
//!
//! `run(quick, full_exact)` reads FAUST `tr_reg_001.ply` (A) and as deformed
//! sources `tr_reg_003` (m = 1), then `tr_reg_003, 007, 012` (m = 3; the
//! sample holds only two more poses of subject 0, so the third source is
//! `tr_reg_012`, another subject in another pose — same connectivity, a
//! shape-and-pose change, which is what the timing needs). Without the
//! shared data it uses a synthetic FAUST-style subject and says so. It
//! reports
//!
//! * full selections in fast mode (n_c = 100, 30 when `quick`) with the
//!   defaults (ε = 0.03 on the mean per-vertex distance, at most 30 key
//!   points), medians of 3 runs (1 when `quick`);
//! * median times of single exact-mode trials (bounded biharmonic weights of
//!   the set, rotation groups, reduced ARAP towards all sources) at three
//!   set sizes, and from them an **extrapolated** exact selection time: the
//!   trial-size profile of the fast run (stage 1: `n_c − s + 1` trials of
//!   size `s`; the remaining evaluations at the final size) times the
//!   interpolated exact trial time, divided by the thread count;
//! * with `full_exact`, the exact selection itself, measured (hours at
//!   6890 vertices).
//!
//! This module does file I/O (it reads meshes) and is not used by the
//! algorithms.

use std::fmt::Write as _;
use std::time::Instant;

use crate::data::synthetic::FaustStyle;
use crate::mesh::io::read_mesh;
use crate::ops::{farthest_point_sampling, FpsMetric};
use crate::transfer::keypoints::{
    fit_keypoints, select_keypoints, KeypointOptions, KeypointSelection, SelectionMode,
};
use crate::{Mesh, Result};

use super::time;

/// Appends a line to the table and echoes it to stderr (progress).
macro_rules! emit {
    ($out:expr, $($arg:tt)*) => {{
        let line = format!($($arg)*);
        eprintln!("{line}");
        let _ = writeln!($out, "{line}");
    }};
}

/// Source and up to three deformed sources (FAUST sample or synthetic).
fn bench_meshes(out: &mut String) -> Result<(Mesh, Vec<Mesh>)> {
    if let Some(dir) = crate::data::shared_data_dir().map(|d| d.join("faust")) {
        let names = ["tr_reg_003", "tr_reg_007", "tr_reg_012"];
        let a = dir.join("tr_reg_001.ply");
        let paths: Vec<_> = names.iter().map(|n| dir.join(format!("{n}.ply"))).collect();
        if a.exists() && paths.iter().all(|p| p.exists()) {
            let source = read_mesh(&a)?;
            let deformed = paths.iter().map(|p| read_mesh(p)).collect::<Result<_>>()?;
            emit!(
                out,
                "mesh: {} ({} vertices); deformed sources: {} (m = 1: the first; m = 3: all, the \
                 third is subject 1)",
                a.display(),
                source.n_vertices(),
                names.join(", ")
            );
            return Ok((source, deformed));
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

/// Trial-set sizes of a selection, `(size, count)`: stage 1 evaluates
/// `n_c − s + 1` sets of size `s` for `s ≥ 2` (one for `s = 1`); every
/// other evaluation (stage 2, the final fit) has the final size.
fn trial_profile(sel: &KeypointSelection) -> Vec<(usize, usize)> {
    let n_c = sel.candidates.len();
    let s1 = sel.trace.iter().filter(|s| s.stage == 1).count();
    let mut prof = vec![(1, 1)];
    let mut used = 1;
    for s in 2..=s1 {
        prof.push((s, n_c + 1 - s));
        used += n_c + 1 - s;
    }
    let k = sel.keypoints.len();
    prof.push((k, sel.evaluations.saturating_sub(used)));
    prof
}

/// Piecewise-linear interpolation (constant extrapolation) of `(x, y)`.
fn interpolate(points: &[(usize, f64)], x: usize) -> f64 {
    let x = x as f64;
    let (first, last) = (points[0], points[points.len() - 1]);
    if x <= first.0 as f64 {
        return first.1 * x / first.0 as f64;
    }
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        if x <= b.0 as f64 {
            let t = (x - a.0 as f64) / (b.0 - a.0) as f64;
            return a.1 + t * (b.1 - a.1);
        }
    }
    last.1 * x / last.0 as f64
}

/// Runs the benchmark and returns the printed table.
pub fn run(quick: bool, full_exact: bool) -> Result<String> {
    let mut out = String::new();
    let (source, deformed) = bench_meshes(&mut out)?;
    let n_c = if quick { 30 } else { 100 };
    let reps = if quick { 1 } else { 3 };
    let threads = rayon::current_num_threads();
    let ms: Vec<usize> = if deformed.len() >= 3 {
        vec![1, 3]
    } else {
        vec![1]
    };
    emit!(
        out,
        "n_c = {n_c}, rayon threads = {threads}, defaults otherwise (ε = 0.03 on the mean \
         per-vertex distance, unit-sphere units; at most 30 key points)\n"
    );
    emit!(
        out,
        "| mode | m | key points | stage-1 / stage-2 steps | trials evaluated (repeated) | final Ê | time (s), median of {reps} |"
    );
    emit!(out, "|---|---|---|---|---|---|---|");
    let mut fast_runs = Vec::new();
    for &m in &ms {
        let opts = KeypointOptions {
            n_candidates: n_c,
            mode: SelectionMode::Fast,
            ..Default::default()
        };
        let (t_sel, sel) = time(reps, || select_keypoints(&source, &deformed[..m], &opts))?;
        let s1 = sel.trace.iter().filter(|s| s.stage == 1).count();
        emit!(
            out,
            "| fast | {m} | {} | {s1} / {} | {} ({}) | {:.4} | {:.1} |",
            sel.keypoints.len(),
            sel.trace.len() - s1,
            sel.evaluations,
            sel.repeated_trials,
            sel.error,
            t_sel
        );
        fast_runs.push((m, sel));
    }

    // Exact-mode trials.
    let max_k = fast_runs
        .iter()
        .map(|(_, s)| s.keypoints.len())
        .max()
        .unwrap_or(4)
        .max(2);
    let sizes = [1, max_k.div_ceil(2), max_k];
    let trial_reps = if quick { 1 } else { 3 };
    emit!(
        out,
        "\n| exact trial | m | |S| | time (s), median of {trial_reps} |"
    );
    emit!(out, "|---|---|---|---|");
    let cands = farthest_point_sampling(&source, n_c, FpsMetric::Geodesic, 0)?;
    let mut exact_at: Vec<(usize, Vec<(usize, f64)>)> = Vec::new();
    for &m in &ms {
        let mut pts = Vec::new();
        for &k in &sizes {
            let opts = KeypointOptions {
                mode: SelectionMode::Exact,
                ..Default::default()
            };
            // Includes the per-run setup (normalisation, features,
            // biharmonic operator) that a selection does once: an upper
            // bound on the per-trial cost.
            let (med, _) = time(trial_reps, || {
                fit_keypoints(&source, &deformed[..m], &cands[..k], &opts)
            })?;
            emit!(out, "| exact | {m} | {k} | {med:.3} |");
            pts.push((k, med));
        }
        exact_at.push((m, pts));
    }
    emit!(
        out,
        "\nExact selection, extrapolated (the fast run's trial sizes × the interpolated exact trial \
         time / {threads} threads):"
    );
    for (m, sel) in &fast_runs {
        let Some((_, pts)) = exact_at.iter().find(|(mm, _)| mm == m) else {
            continue;
        };
        let est: f64 = trial_profile(sel)
            .iter()
            .map(|&(k, count)| count as f64 * interpolate(pts, k))
            .sum::<f64>()
            / threads as f64;
        emit!(
            out,
            "- m = {m}: {} trials → ≈ {est:.0} s ({:.2} h)",
            sel.evaluations,
            est / 3600.0
        );
    }
    paper_sized(&mut out, quick)?;
    if full_exact {
        emit!(
            out,
            "\n| mode | m | key points | trials | final Ê | time (s), measured |"
        );
        emit!(out, "|---|---|---|---|---|---|");
        for &m in &ms {
            let opts = KeypointOptions {
                n_candidates: n_c,
                mode: SelectionMode::Exact,
                ..Default::default()
            };
            let t = Instant::now();
            let sel = select_keypoints(&source, &deformed[..m], &opts)?;
            emit!(
                out,
                "| exact | {m} | {:?} | {} | {:.4} | {:.0} |",
                sel.keypoints,
                sel.evaluations,
                sel.error,
                t.elapsed().as_secs_f64()
            );
        }
    }
    Ok(out)
}

/// Exact and fast selections, both measured, on a synthetic subject of
/// about 1.7k vertices (the paper's Table 1 meshes have 1–3k vertices):
/// time, key points, and the error of each mode's key points under the
/// exact (bounded-weight) fit.
fn paper_sized(out: &mut String, quick: bool) -> Result<()> {
    let set = FaustStyle {
        subjects: 1,
        poses: 4,
        resolution: 1,
        ..Default::default()
    }
    .generate()?;
    let source = set.meshes[0][0].clone();
    let deformed = set.meshes[0][1..].to_vec();
    let n_c = if quick { 20 } else { 100 };
    emit!(
        out,
        "\nPaper-sized mesh: synthetic subject 0 ({} vertices), poses 1..=3, n_c = {n_c}; both modes \
         measured; Ê(exact fit) = the error of the mode's key points under the exact fit\n",
        source.n_vertices()
    );
    emit!(
        out,
        "| mode | m | key points | trials | Ê (own fit) | Ê (exact fit) | time (s) |"
    );
    emit!(out, "|---|---|---|---|---|---|---|");
    let ms: &[usize] = if quick { &[1] } else { &[1, 3] };
    for &m in ms {
        let exact_opts = KeypointOptions {
            n_candidates: n_c,
            mode: SelectionMode::Exact,
            ..Default::default()
        };
        for mode in [SelectionMode::Fast, SelectionMode::Exact] {
            let opts = KeypointOptions {
                mode,
                ..exact_opts.clone()
            };
            let t = Instant::now();
            let sel = select_keypoints(&source, &deformed[..m], &opts)?;
            let secs = t.elapsed().as_secs_f64();
            let exact_err = match mode {
                SelectionMode::Exact => sel.error,
                SelectionMode::Fast => {
                    fit_keypoints(&source, &deformed[..m], &sel.keypoints, &exact_opts)?.error
                }
            };
            let mut kp = sel.keypoints.clone();
            kp.sort_unstable();
            emit!(
                out,
                "| {} | {m} | {kp:?} | {} | {:.4} | {exact_err:.4} | {secs:.1} |",
                match mode {
                    SelectionMode::Fast => "fast",
                    SelectionMode::Exact => "exact",
                },
                sel.evaluations,
                sel.error
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation() {
        let pts = [(2, 1.0), (6, 3.0), (12, 9.0)];
        assert_eq!(interpolate(&pts, 2), 1.0);
        assert_eq!(interpolate(&pts, 4), 2.0);
        assert_eq!(interpolate(&pts, 9), 6.0);
        assert_eq!(interpolate(&pts, 1), 0.5);
        assert_eq!(interpolate(&pts, 24), 18.0);
    }
}

//! Timing of automatic key point selection (BDT Sec. 3.5; Table 1, column
//! "Key Point Selection").
//!
//! `run(quick, full_exact)` measures fast and exact selections side by side
//! (see [`run`]): on a synthetic FAUST-style subject
//! ([`crate::data::synthetic::FaustStyle`], resolutions 1 and 2, poses 1..=3
//! deformed) and on FAUST `tr_reg_001.ply` (A) with deformed sources
//! `tr_reg_003` (m = 1), then `tr_reg_003, 007, 012` (m = 3; the sample
//! holds only two more poses of subject 0, so the third source is
//! `tr_reg_012`, another subject in another pose — same connectivity).
//! Both modes are scored by the same measure, the bounded-biharmonic fit
//! of their final key points; with `full_exact` exact mode runs at
//! `n_c = 100` (hours at FAUST size).
//!
//! This module does file I/O (it reads meshes) and is not used by the
//! algorithms.

use std::fmt::Write as _;

use crate::data::synthetic::FaustStyle;
use crate::mesh::io::read_mesh;
use crate::transfer::keypoints::{fit_keypoints, select_keypoints, KeypointOptions, SelectionMode};
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

/// 1-minute load average from `/proc/loadavg` (`NaN` where unavailable).
fn load_average() -> f64 {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|t| t.split_whitespace().next().and_then(|x| x.parse().ok()))
        .unwrap_or(f64::NAN)
}

/// One mesh family of the comparison: source and deformed sources.
#[derive(Clone)]
struct Family {
    name: String,
    source: Mesh,
    deformed: Vec<Mesh>,
}

/// One row of the comparison: mode, `n_c`, `verify_top` (fast), repetitions.
#[derive(Clone, Copy)]
struct Row {
    mode: SelectionMode,
    n_c: usize,
    verify_top: usize,
    reps: usize,
}

/// Runs the rows of one family and `m`, printing key points, the BBW fit
/// error of the final key points (the same measure for both modes: the fit
/// with exact mode's weights, [`fit_keypoints`] with
/// `SelectionMode::Exact`), its gap to the exact selection at the same
/// `n_c`, wall time (median of the repetitions) and the load average.
fn compare(out: &mut String, fam: &Family, m: usize, rows: &[Row]) -> Result<()> {
    let deformed = &fam.deformed[..m];
    // Exact rows first, so that fast rows can be compared with them.
    let mut exact_err: Vec<(usize, f64)> = Vec::new();
    let mut ordered: Vec<Row> = rows
        .iter()
        .filter(|r| r.mode == SelectionMode::Exact)
        .copied()
        .collect();
    ordered.extend(rows.iter().filter(|r| r.mode == SelectionMode::Fast));
    for r in ordered {
        let mut opts = KeypointOptions {
            n_candidates: r.n_c,
            mode: r.mode,
            ..Default::default()
        };
        opts.fast.verify_top = r.verify_top;
        let exact_opts = KeypointOptions {
            mode: SelectionMode::Exact,
            ..opts.clone()
        };
        let load = load_average();
        let (secs, sel) = time(r.reps, || select_keypoints(&fam.source, deformed, &opts))?;
        let fit = fit_keypoints(&fam.source, deformed, &sel.keypoints, &exact_opts)?;
        let (mode, vt) = match r.mode {
            SelectionMode::Exact => {
                exact_err.push((r.n_c, fit.error));
                ("exact", "–".to_string())
            }
            SelectionMode::Fast => ("fast", r.verify_top.to_string()),
        };
        let gap = exact_err
            .iter()
            .find(|(n, _)| *n == r.n_c)
            .map(|(_, e)| format!("{:+.2} %", 100.0 * (fit.error - e) / e))
            .unwrap_or_else(|| "–".to_string());
        let mut kp = sel.keypoints.clone();
        kp.sort_unstable();
        emit!(
            out,
            "| {} | {} | {m} | {} | {mode} | {vt} | {kp:?} | {:.5} | {gap} | {} / {} | {secs:.1} ({}) | {load:.1} |",
            fam.name,
            fam.source.n_vertices(),
            r.n_c,
            fit.error,
            sel.exact_evaluations,
            sel.evaluations,
            r.reps
        );
    }
    Ok(())
}

/// The synthetic FAUST-style subject 0 at `resolution`, poses 1..=3.
fn synthetic(resolution: u32) -> Result<Family> {
    let set = FaustStyle {
        subjects: 1,
        poses: 4,
        resolution,
        ..Default::default()
    }
    .generate()?;
    Ok(Family {
        name: format!("synthetic r{resolution}"),
        source: set.meshes[0][0].clone(),
        deformed: set.meshes[0][1..].to_vec(),
    })
}

/// Runs the benchmark and returns the printed table.
///
/// Fast vs exact selection, both measured, at the same `n_c`: on the
/// synthetic subject at resolution 1 (m = 1 and 3) and 2 (m = 1), and on
/// FAUST (m = 1 and 3). Exact selections at `n_c = 100` take hours at FAUST
/// size, so without `full_exact` exact mode (and fast mode beside it) runs
/// at a smaller `n_c` (30 synthetic, 20 FAUST; `quick`: 20 / 10); fast
/// mode is also timed at `n_c = 100` (median of 3 runs, 1 when `quick`),
/// the setting of the 10 s target.
pub fn run(quick: bool, full_exact: bool) -> Result<String> {
    let mut out = String::new();
    let threads = rayon::current_num_threads();
    let (n_syn, n_faust) = match (quick, full_exact) {
        (_, true) => (100, 100),
        (true, false) => (20, 10),
        (false, false) => (30, 20),
    };
    let reps = if quick { 1 } else { 3 };
    emit!(
        out,
        "Fast vs exact key point selection. Defaults otherwise (ε = 0.03 on the mean per-vertex \
         distance, unit-sphere units; at most 30 key points; weights {:?}); rayon threads = \
         {threads}. Ê = the BBW fit error of the final key points (fit_keypoints in exact mode, \
         the same measure for both modes); gap = relative to exact mode at the same n_c; \
         evaluations = exact / all trial sets evaluated (final fit included); load = 1-minute \
         load average when the row started.\n",
        KeypointOptions::default().weights.mode
    );
    emit!(
        out,
        "| mesh | n | m | n_c | mode | verify_top | key points | Ê (BBW fit) | gap | evaluations | time (s) (reps) | load |"
    );
    emit!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    let vt = crate::transfer::keypoints::DEFAULT_VERIFY_TOP;
    let pair = |n_c: usize, vts: &[usize]| {
        let mut rows = vec![Row {
            mode: SelectionMode::Exact,
            n_c,
            verify_top: 0,
            reps: 1,
        }];
        // Fast rows at the paper's n_c are the timed setting (median of
        // `reps`); the others are single runs beside their exact row.
        rows.extend(vts.iter().map(|&v| Row {
            mode: SelectionMode::Fast,
            n_c,
            verify_top: v,
            reps: if n_c == 100 { reps } else { 1 },
        }));
        rows
    };
    let fast100 = Row {
        mode: SelectionMode::Fast,
        n_c: 100,
        verify_top: vt,
        reps,
    };
    let sweep: Vec<usize> = if quick { vec![vt] } else { vec![1, 3, 6] };
    let one = [vt];
    let syn1 = synthetic(1)?;
    for m in [1, 3] {
        let mut rows = pair(n_syn, if m == 1 { &sweep } else { &one });
        if n_syn != 100 && !quick {
            rows.push(fast100);
        }
        compare(&mut out, &syn1, m, &rows)?;
    }
    if !quick {
        let syn2 = synthetic(2)?;
        compare(&mut out, &syn2, 1, &pair(n_syn, &[vt]))?;
    }
    match faust_family(&mut out)? {
        Some(fam) => {
            for m in [1, 3] {
                let mut rows = pair(n_faust, if m == 1 { &sweep } else { &one });
                if n_faust != 100 && (m == 1 || !quick) {
                    rows.push(fast100);
                }
                compare(&mut out, &fam, m, &rows)?;
            }
        }
        None => emit!(out, "(FAUST sample not found: FAUST rows skipped)"),
    }
    Ok(out)
}

/// FAUST `tr_reg_001` with `tr_reg_003, 007, 012` (see the module docs).
fn faust_family(out: &mut String) -> Result<Option<Family>> {
    let Some(dir) = crate::data::shared_data_dir().map(|d| d.join("faust")) else {
        return Ok(None);
    };
    let names = ["tr_reg_003", "tr_reg_007", "tr_reg_012"];
    let a = dir.join("tr_reg_001.ply");
    let paths: Vec<_> = names.iter().map(|n| dir.join(format!("{n}.ply"))).collect();
    if !(a.exists() && paths.iter().all(|p| p.exists())) {
        return Ok(None);
    }
    let source = read_mesh(&a)?;
    let deformed = paths.iter().map(|p| read_mesh(p)).collect::<Result<_>>()?;
    emit!(
        out,
        "\nFAUST: A = tr_reg_001; deformed sources {} (m = 1: the first; m = 3: all, the third \
         is subject 1)",
        names.join(", ")
    );
    Ok(Some(Family {
        name: "FAUST".to_string(),
        source,
        deformed,
    }))
}

/// The `verify_top` values [`run_fast_exact`] measures.
pub const VERIFY_TOP_SWEEP: [usize; 5] = [1, 2, 3, 5, 10];

/// Runs the fast-vs-exact table at `n_c = 10`, where exact mode is
/// affordable at FAUST size, and returns it.
///
/// Families: the synthetic subject 0 at resolution 1 (m = 1 and 3) and 2
/// (m = 1), and ten FAUST source/pose pairs across the five complete
/// subjects (A = subject s in pose 0, A′ = the same subject in one of the
/// large-motion poses 7, 8, 9: 1 → 7, 3 → 8, 5 → 9, 7 → 7, 9 → 8, then
/// 1 → 9, 3 → 7, 5 → 8, 7 → 9, 9 → 7), skipped when the data are absent. Every fast row (each `verify_top` of
/// [`VERIFY_TOP_SWEEP`]) is scored by the bounded-biharmonic fit of its
/// final key points against exact mode's at the same `n_c`; CPU seconds
/// (all threads) and wall seconds of one run each. `quick`: the synthetic
/// rows and two FAUST pairs.
pub fn run_fast_exact(quick: bool) -> Result<String> {
    let mut out = String::new();
    let n_c = 10;
    emit!(
        out,
        "Fast vs exact key point selection at n_c = {n_c}, defaults otherwise (weights {:?}). \
         Ê = the BBW fit error of the final key points (the same measure for both modes); gap = \
         relative to exact mode; CPU = user + sys of all threads (s), wall (s), one run each; \
         load = 1-minute load average when the row started.\n",
        KeypointOptions::default().weights.mode
    );
    emit!(
        out,
        "| mesh | n | m | mode | verify_top | key points | Ê (BBW fit) | gap | evaluations | CPU (s) | wall (s) | load |"
    );
    emit!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut gaps: Vec<(usize, f64)> = Vec::new();
    let mut families: Vec<(Family, usize)> = Vec::new();
    let syn1 = synthetic(1)?;
    families.push((syn1.clone(), 1));
    families.push((syn1, 3));
    if !quick {
        families.push((synthetic(2)?, 1));
    }
    let pairs: &[(usize, usize)] = if quick {
        &[(1, 7), (3, 8)]
    } else {
        &[
            (1, 7),
            (3, 8),
            (5, 9),
            (7, 7),
            (9, 8),
            (1, 9),
            (3, 7),
            (5, 8),
            (7, 9),
            (9, 7),
        ]
    };
    let dir = crate::data::shared_data_dir().map(|d| d.join("faust"));
    let mut faust_found = 0;
    for &(s, p) in pairs {
        let Some(dir) = &dir else { break };
        let a = dir.join(format!("tr_reg_{:03}.ply", 10 * s));
        let a1 = dir.join(format!("tr_reg_{:03}.ply", 10 * s + p));
        if !(a.exists() && a1.exists()) {
            continue;
        }
        faust_found += 1;
        families.push((
            Family {
                name: format!("FAUST {:03}→{:03}", 10 * s, 10 * s + p),
                source: read_mesh(&a)?,
                deformed: vec![read_mesh(&a1)?],
            },
            1,
        ));
    }
    if faust_found == 0 {
        emit!(
            out,
            "(FAUST subjects 1, 3, 5, 7, 9 not found: FAUST rows skipped)"
        );
    }
    for (fam, m) in &families {
        let deformed = &fam.deformed[..*m];
        let mut exact_err = f64::NAN;
        let mut rows = vec![(SelectionMode::Exact, 0)];
        rows.extend(VERIFY_TOP_SWEEP.iter().map(|&v| (SelectionMode::Fast, v)));
        for (mode, vt) in rows {
            let mut opts = KeypointOptions {
                n_candidates: n_c,
                mode,
                ..Default::default()
            };
            opts.fast.verify_top = vt.max(1);
            let exact_opts = KeypointOptions {
                mode: SelectionMode::Exact,
                ..opts.clone()
            };
            let load = load_average();
            let (wall, cpu, sel) =
                super::time_cpu(1, || select_keypoints(&fam.source, deformed, &opts))?;
            let fit = fit_keypoints(&fam.source, deformed, &sel.keypoints, &exact_opts)?;
            let (name, vts, gap) = if mode == SelectionMode::Exact {
                exact_err = fit.error;
                ("exact", "–".to_string(), "–".to_string())
            } else {
                let g = 100.0 * (fit.error - exact_err) / exact_err;
                gaps.push((vt, g));
                ("fast", vt.to_string(), format!("{g:+.2} %"))
            };
            let mut kp = sel.keypoints.clone();
            kp.sort_unstable();
            emit!(
                out,
                "| {} | {} | {m} | {name} | {vts} | {kp:?} | {:.5} | {gap} | {} / {} | {cpu:.1} | {wall:.1} | {load:.1} |",
                fam.name,
                fam.source.n_vertices(),
                fit.error,
                sel.exact_evaluations,
                sel.evaluations,
            );
        }
    }
    emit!(
        out,
        "\n| verify_top | rows | worst gap | mean gap | rows within 2 % |\n|---|---|---|---|---|"
    );
    for v in VERIFY_TOP_SWEEP {
        let g: Vec<f64> = gaps.iter().filter(|(x, _)| *x == v).map(|p| p.1).collect();
        let worst = g.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mean = g.iter().sum::<f64>() / g.len().max(1) as f64;
        let within = g.iter().filter(|x| **x <= 2.0).count();
        emit!(
            out,
            "| {v} | {} | {worst:+.2} % | {mean:+.2} % | {within} / {} |",
            g.len(),
            g.len()
        );
    }
    Ok(out)
}

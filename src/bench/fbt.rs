//! Timing of FBT (the paper's Table 1: precomputation, one iteration and a
//! full solve per class) and of NICP on a partial cat.
//!
//! `run(quick)` reads every class of the TOSCA folder `../shared/data/tosca`
//! (or, when absent, uses the synthetic TOSCA-style class at resolution 2
//! and says so), and without `quick` adds the synthetic class at
//! resolution 4 (107.5k vertices, q = 9: twice the paper's largest class,
//! the man). Per class: the last mesh is the target, the first
//! `q = min(paper's q, count − 1)` meshes are the examples (face lists
//! unified by [`adopt_consistent_faces`]); the default [`FbtConfig`]
//! (init LBO m = 4, main LBO m = 10 reduced by k-medoids to half its example
//! atoms, rich example-based skeleton dictionary, r = 20 clusters from the
//! skeleton weights) and 8 feature points × 10 geodesic circles. Reported
//! medians over repetitions: precomputation (pipeline build, then the
//! factorisation for the constraints with the reduced form of the E_ℓ
//! iterations, [`crate::register::FbtSystem::prepare`]), one
//! local/scale/global iteration of E_total in the main dictionary and of
//! E_mn in the rich one (all q examples; one call, its set-up included),
//! and the full default schedule after precomputation (init, 5 E_total,
//! 5 E_mn, change, 5 E_mn, and the final positions `D T`, shown separately:
//! row-sparse for the skeleton dictionary, a few bones per vertex). Then
//! NICP (defaults) on a partial cat (or the synthetic class): time and
//! mean / max relative distortion before and after. A second table gives,
//! for the timings judged against the paper (one iteration of each kind, the
//! full solve), the CPU time (user + sys of the timed call, all threads of
//! the process) beside the wall time, median (min–max) over the
//! repetitions. Progress goes to stderr, a line per class and stage, as
//! the benchmark runs (the table is returned at the end).
//! This module does file I/O (it reads meshes) and is not used by the
//! algorithms.

use std::fmt::Write as _;

use crate::data::partial::feature_points;
use crate::data::ToscaFolder;
use crate::mesh::set::adopt_consistent_faces;
use crate::methods::completion::{CompletionProblem, CompletionSolver, FbtOptions, FeatureOptions};
use crate::register::{
    build, circle_radii, feature_circle_constraints, metrics, synthetic_class, FbtConfig,
    FbtParams, IterOptions, Schedule,
};
use crate::{Mesh, Result};

use super::{load_average, time, time_runs, Runs};

/// A progress line on stderr (the table itself is returned at the end).
macro_rules! progress {
    ($($arg:tt)*) => {{
        eprintln!("fbt: {}", format!($($arg)*));
    }};
}

/// The paper's q per class (Table 1).
fn paper_q(class: &str) -> usize {
    match class {
        "woman" | "centaur" => 5,
        "wolf" => 2,
        "dog" | "horse" => 4,
        // The synthetic class at resolution 4 (107.5k vertices) stands in
        // for the paper's largest class, the man (52.6k, q = 9).
        "man" | "synthetic-r4" => 9,
        "cat" => 6,
        "hand" => 7,
        _ => 4,
    }
}

fn classes(out: &mut String, quick: bool) -> Result<Vec<(String, Vec<Mesh>)>> {
    let dir = crate::data::shared_data_dir().map(|d| d.join("tosca"));
    match dir {
        Some(d) if d.is_dir() => {
            let folder = ToscaFolder::open(&d)?;
            let _ = writeln!(out, "data: {}", d.display());
            let mut v = Vec::new();
            for (name, entries) in &folder.classes {
                if quick && name != "wolf" && name != "cat" {
                    continue;
                }
                let meshes: Vec<Mesh> = entries.iter().map(|e| e.load()).collect::<Result<_>>()?;
                if meshes.len() < 2 {
                    continue;
                }
                let (_, meshes) = adopt_consistent_faces(&meshes)?;
                v.push((name.clone(), meshes));
            }
            if !quick {
                // The shared classes stop at 27.9k vertices; the paper's go
                // to 52.6k (man). The synthetic class at resolution 4 is
                // twice that.
                v.push(("synthetic-r4".to_string(), synthetic_class(4, 0)?));
            }
            Ok(v)
        }
        _ => {
            let _ = writeln!(
                out,
                "data: ../shared/data/tosca not found; using the synthetic TOSCA-style class (resolution 2)"
            );
            Ok(vec![("synthetic".to_string(), synthetic_class(2, 0)?)])
        }
    }
}

/// Runs the benchmark and returns the report (Markdown). `quick`: only wolf
/// and cat (when present) and 3 repetitions instead of 7.
pub fn run(quick: bool) -> Result<String> {
    let mut out = String::new();
    let reps = if quick { 3 } else { 7 };
    let cfg = FbtConfig::default();
    let params = FbtParams::default();
    let schedule = Schedule::default();
    progress!(
        "reading the classes ({}; load average {})",
        if quick { "quick: wolf and cat" } else { "all" },
        load_average()
    );
    let sets = classes(&mut out, quick)?;
    progress!(
        "{} class(es): {}; {reps} runs per timing",
        sets.len(),
        sets.iter()
            .map(|(n, m)| format!("{n} ({} meshes)", m.len()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        out,
        "config: default FbtConfig (stages LBO m = 4 / LBO m = 10 reduced ½ / example-based skeleton, r = {} clusters from the skeleton weights), β_lc = {}, β_sm = {}, schedule {}+{}+{} iterations; medians of {reps} runs; {} thread(s) for faer. 'factorise H' includes the reduced form of the E_ℓ iterations (FbtSystem::prepare); '1 iter' is one call with one iteration (its per-call set-up included).\n",
        cfg.clusters,
        params.beta_lc,
        params.beta_sm,
        schedule.average_iters,
        schedule.minimal_iters,
        schedule.rich_iters,
        crate::solve::threads()
    );
    let _ = writeln!(
        out,
        "| class | n | f | r | b (init/main/rich) | q | build (s) | factorise H (ms) | 1 iter E_total main (ms) | 1 iter E_mn rich (ms) | full solve (ms) | of which D T (ms) | iterations | mean dist. (%) |"
    );
    let _ = writeln!(
        out,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    let mut nicp_case: Option<(String, Vec<Mesh>)> = None;
    // Per class: (name, n, 1 iter E_total main, 1 iter E_mn rich, full solve).
    let mut cpu_rows: Vec<(String, usize, Runs, Runs, Runs)> = Vec::new();
    for (name, meshes) in &sets {
        let q = paper_q(name).min(meshes.len() - 1);
        let examples = &meshes[..q];
        let target = &meshes[meshes.len() - 1];
        progress!(
            "{name} (n = {}, q = {q}): build (load average {})",
            target.n_vertices(),
            load_average()
        );
        let (t_build, setup) = time(if quick { 1 } else { 3 }, || build(examples, &cfg))?;
        progress!("{name}: build {t_build:.2} s; factorise H ({reps} runs)");
        let area = setup.graph.area();
        let feats = feature_points(target, 8, 0)?;
        let radii = circle_radii(10, 0.15 * area.sqrt());
        let pairs: Vec<(usize, usize)> = feats.iter().map(|&f| (f, f)).collect();
        let (rows, y) = feature_circle_constraints(&examples[0], target, &pairs, &radii)?;
        let (t_fact, sys) = time(reps, || setup.pipeline.systems(&rows, &params))?;
        progress!(
            "{name}: factorise H {:.1} ms; 1 iteration E_total main ({reps} runs)",
            1e3 * t_fact
        );
        let t0 = sys.initial(&y, schedule.init)?;
        let one = IterOptions {
            max_iter: 1,
            rel_tol: 0.0,
        };
        let (r_it, _) = time_runs(reps, || sys.main.solve_average(&y, &t0, &one))?;
        let t_it = metrics::median(r_it.wall.clone());
        progress!(
            "{name}: 1 iter E_total main CPU {} ms, wall {} ms; 1 iteration E_mn rich",
            r_it.cpu_cell(1e3, 2),
            r_it.wall_cell(1e3, 2)
        );
        let last = sys.last();
        let t_rich = crate::skin::dictionary::DictionaryChange::new(
            setup.pipeline.main().dictionary(),
            last.model().dictionary(),
        )?
        .apply(&t0)?;
        let (r_it_mn, _) = time_runs(reps, || last.solve_minimal(&y, &t_rich, None, &one))?;
        let t_it_mn = metrics::median(r_it_mn.wall.clone());
        progress!(
            "{name}: 1 iter E_mn rich CPU {} ms, wall {} ms; full solve",
            r_it_mn.cpu_cell(1e3, 2),
            r_it_mn.wall_cell(1e3, 2)
        );
        let (r_full, reg) = time_runs(reps, || sys.solve(&y, &schedule))?;
        let t_full = metrics::median(r_full.wall.clone());
        progress!(
            "{name}: full solve CPU {} ms, wall {} ms",
            r_full.cpu_cell(1e3, 1),
            r_full.wall_cell(1e3, 1)
        );
        let (t_pos, _) = time(reps, || last.positions(&reg.t))?;
        let d = metrics::relative_distortion(&reg.positions, target.vertices(), area)?;
        let (bi, bm, br) = setup.sizes;
        let _ = writeln!(
            out,
            "| {name} | {} | {} | {} | {}/{bm}/{} | {q} | {t_build:.2} | {:.1} | {:.2} | {:.2} | {:.1} | {:.1} | {} | {:.2} |",
            target.n_vertices(),
            target.n_faces(),
            setup.pipeline.main().n_clusters(),
            bi.map_or("-".into(), |b| b.to_string()),
            br.map_or("-".into(), |b| b.to_string()),
            1e3 * t_fact,
            1e3 * t_it,
            1e3 * t_it_mn,
            1e3 * t_full,
            1e3 * t_pos,
            reg.iterations,
            100.0 * metrics::mean(&d),
        );
        cpu_rows.push((name.clone(), target.n_vertices(), r_it, r_it_mn, r_full));
        if name == "cat" || (nicp_case.is_none() && name == "synthetic") {
            nicp_case = Some((name.clone(), meshes.clone()));
        }
    }
    let _ = writeln!(
        out,
        "\nCPU time (user + sys of the timed call, all threads of the process) beside wall time, median (min–max) of {reps} runs:\n"
    );
    let _ = writeln!(
        out,
        "| class | n | 1 iter E_total main CPU (ms) | 1 iter E_total main wall (ms) | 1 iter E_mn rich CPU (ms) | 1 iter E_mn rich wall (ms) | full solve CPU (ms) | full solve wall (ms) |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for (name, n, it, it_mn, full) in &cpu_rows {
        let _ = writeln!(
            out,
            "| {name} | {n} | {} | {} | {} | {} | {} | {} |",
            it.cpu_cell(1e3, 2),
            it.wall_cell(1e3, 2),
            it_mn.cpu_cell(1e3, 2),
            it_mn.wall_cell(1e3, 2),
            full.cpu_cell(1e3, 1),
            full.wall_cell(1e3, 1)
        );
    }
    let _ = writeln!(
        out,
        "\nPaper (Table 1, MATLAB + C++, 3 GHz i7): 0.7–1.9 ms per iteration, 10–25 ms per full solve."
    );
    if let Some((name, meshes)) = nicp_case {
        progress!("NICP on a partial {name} (load average {})", load_average());
        let q = paper_q(&name).min(meshes.len() - 1);
        let examples = &meshes[..q];
        let target = &meshes[meshes.len() - 1];
        // The completion task's problem and FBT solver (methods::completion).
        let problem = CompletionProblem::new(examples, target, &FeatureOptions::default(), 1)?;
        let fopts = FbtOptions {
            q,
            ..FbtOptions::default()
        };
        let solver = CompletionSolver::fbt(&fopts, 0);
        let (mut t_init, mut t_nicp, mut solved) = (Vec::new(), Vec::new(), None);
        for _ in 0..if quick { 1 } else { 3 } {
            let o = solver.solve(&problem)?;
            t_init.push(o.seconds_precompute.unwrap_or(0.0) + o.seconds_solve.unwrap_or(0.0));
            t_nicp.push(o.seconds_nicp.unwrap_or(f64::NAN));
            solved = Some(o);
        }
        let o = solved.ok_or_else(|| crate::Error::invalid("no completion run"))?;
        let (t_init, t_nicp) = (metrics::median(t_init), metrics::median(t_nicp));
        let partial = problem.partial();
        let opts = fopts.nicp_options(0);
        let init = o.init_positions.clone().unwrap_or_default();
        let area = problem.area();
        let before = metrics::relative_distortion(&init, target.vertices(), area)?;
        let after = metrics::relative_distortion(&o.positions, target.vertices(), area)?;
        progress!("NICP: feature points {t_init:.3} s, + NICP {t_nicp:.3} s");
        let _ = writeln!(
            out,
            "\nNICP on a partial {name} (target {} of {} vertices kept, {:.0} % of the area, {} parts; q = {q}; {} iterations, {} samples):\n",
            partial.mesh.n_vertices(),
            target.n_vertices(),
            100.0 * partial.area_fraction,
            partial.n_components,
            opts.iterations,
            opts.samples
        );
        let _ = writeln!(out, "| stage | time (s) | mean dist. (%) | max dist. (%) |");
        let _ = writeln!(out, "|---|---|---|---|");
        let _ = writeln!(
            out,
            "| feature points (precompute + factorise + schedule) | {t_init:.3} | {:.2} | {:.2} |",
            100.0 * metrics::mean(&before),
            100.0 * metrics::max(&before)
        );
        let _ = writeln!(
            out,
            "| + NICP | {t_nicp:.3} | {:.2} | {:.2} |",
            100.0 * metrics::mean(&after),
            100.0 * metrics::max(&after)
        );
    }
    Ok(out)
}

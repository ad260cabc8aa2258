//! FBT experiments (paper 001, Sec. 5) as harness methods: `kind = "fbt"`
//! with a `[methods.fbt]` table choosing the task and its options.
//!
//! ```toml
//! [[methods]]
//! name = "q4"
//! kind = "fbt"
//! fbt = { task = "completion", q = 4 }
//! ```
//!
//! **Cases.** An FBT case uses the harness's ordinary case list with
//! `include_self = true` and `per_pose = true`: the case's subject is the
//! shape class (synthetic subject, TOSCA class), `reference_pose` is the
//! reference example and the case's single pose is the target. The other
//! `q − 1` examples are drawn from the class's remaining shapes (never the
//! target) by a permutation seeded with the method seed and the case id, so
//! the example sets of methods that differ only in `q` are nested (the
//! q = 2 examples are among the q = 4 ones). Shapes of one class must share
//! their connectivity (the dataset serves every shape of a class with the
//! class's consistently wound face list, see [`super::dataset`]); the truth
//! correspondence is vertex `i` ↔ vertex `i`.
//!
//! **Tasks** (columns of `cases.csv`, curves of `curves.csv`):
//!
//! | task | paper | what is measured |
//! |---|---|---|
//! | `timing` | Table 1 | n, f, r, b, q; precomputation, one E_total iteration in each stage's dictionary (`seconds_iteration_init` / `_main` / `_rich`), full schedule (medians of `repeats`) |
//! | `projection` | Table 2 | max / mean relative distortion of the closest shape the dictionary spans (`dictionary` = `lbo`, `skeleton`, `one_example`, also the `dictionary_kind` column; size via `m`) |
//! | `scale` | Figs. 4–5 | target scaled by `scale` about its centroid, `vertices` vertex-position constraints: recovered α, distortion to the scaled truth |
//! | `completion` | Figs. 6–8 | partial target (`data::partial`), `features` feature points × `circles` geodesic circles, schedule, then NICP: distortion before / after NICP, distortion curve (`cumulative_area`), correspondence curves (`correspondence_euclidean_area`, the paper's; `correspondence_geodesic_area`, Kim et al.'s) |
//! | `permutation` | Fig. 3 | the first `group` features are ambiguous: the assignment with minimal E_mn among all `group!` is kept; `perm_correct` is 1 when it is the true one |
//! | `interpolation` | Fig. 3 | two targets registered, blended at s = ½ (rotations slerped per example): ARAP energy of the blend vs the linear blend; endpoint reproduction (when both chose the same example ℓ*) |
//!
//! Relative distortion is the paper's: per vertex `‖p − p_true‖ / √area`
//! with the area of the reference example. The skeleton dictionary (the
//! `projection` task's `dictionary = "skeleton"` and the skeleton
//! pipelines' last stage or clusters) uses the bone weights of
//! example-based skinning ([`crate::skin::rigging`]) learnt from the q
//! examples (`rig = "examples"`, the default; q = 1 then has no rig) or from
//! `rig_poses` other shapes of the class, never the target (`rig =
//! "class"`, the same rig for every q). `completion` also flags gross
//! failures (`failed_parts`, `gross_failure`: parts whose mean or worst
//! distortion exceeds 0.2 √area; `worst_part_mean`, `worst_part_max`; parts
//! = the dataset's true segmentation, else the bones of a rig learnt from
//! four other shapes of the class: one measuring device for every method
//! and q). Unreferenced vertices and tiny loose parts are dropped for every
//! task (`dropped_vertices`).

use std::time::Instant;

use nalgebra::Vector3;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::cases::Case;
use super::config::{FbtSpec, FbtTask, MetricsSpec};
use super::dataset::Collection;
use super::store::{num, secs, CaseResult, Curve, MeshOut, RenderOut};
use crate::data::fnv1a;
use crate::data::partial::feature_points;
use crate::eval::{
    aligned_vertex_errors, arap_energy, cumulative_curve, curve_grid, error_stats,
    geodesic_error_curve, vertex_errors, ErrorScale,
};
use crate::mesh::compact::{SolvablePart, DEFAULT_MIN_PART_FRACTION};
use crate::mesh::set::ConnectivityReport;
use crate::mesh::Mesh;
use crate::methods::completion::{CompletionProblem, CompletionSolver, FbtOptions, FeatureOptions};
use crate::methods::completion::{DictionaryKind, RigSource, SolverKind};
use crate::register::{
    apply_rows, best_permutation, build_with_rig, feature_row_groups, interpolate, metrics,
    skeleton_rig, skeleton_weights, vertex_rows, IterOptions, Schedule,
};
use crate::skin::dictionary::{Dictionary, SkinningWeights};
use crate::skin::lbo::lbo_basis;
use crate::skin::lbs::points_from_matrix;
use crate::solve::EigenOptions;
use crate::{Error, Point, Result};

fn task_name(t: FbtTask) -> &'static str {
    match t {
        FbtTask::Timing => "timing",
        FbtTask::Projection => "projection",
        FbtTask::Scale => "scale",
        FbtTask::Completion => "completion",
        FbtTask::Permutation => "permutation",
        FbtTask::Interpolation => "interpolation",
    }
}

/// The meshes of one FBT case: examples (reference first), the target and
/// the remaining shapes of the class in draw order.
struct FbtCase {
    examples: Vec<Mesh>,
    target: Mesh,
    rest: Vec<Mesh>,
    example_ids: Vec<String>,
    rest_ids: Vec<String>,
    /// Vertices dropped for the solve (unreferenced, tiny loose parts);
    /// every mesh above is the kept part.
    part: SolvablePart,
}

fn load_case(col: &Collection, case: &Case, q: usize, seed: u64) -> Result<FbtCase> {
    let subject = col
        .subject(&case.source)
        .ok_or_else(|| Error::invalid(format!("subject {} not in the dataset", case.source)))?;
    let target_id = case
        .poses
        .first()
        .ok_or_else(|| Error::invalid("an FBT case needs a target pose"))?;
    if case.target != case.source {
        return Err(Error::invalid(format!(
            "FBT cases register shapes of one class: set [cases] include_self = true and \
             targets = [] (case {} has source {} and target {})",
            case.id, case.source, case.target
        )));
    }
    let mut pool: Vec<String> = subject
        .poses
        .iter()
        .chain(&subject.extra)
        .map(|p| p.id.clone())
        .filter(|p| p != target_id && *p != case.reference)
        .collect();
    if pool.len() + 1 < q {
        return Err(Error::invalid(format!(
            "q = {q} examples need {} shapes of class {} besides the reference and the target; \
             it has {}",
            q - 1,
            case.source,
            pool.len()
        )));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ fnv1a(case.id.as_bytes()));
    pool.shuffle(&mut rng);
    let mut ids = vec![case.reference.clone()];
    ids.extend(pool.iter().take(q - 1).cloned());
    let rest_ids: Vec<String> = pool[q - 1..].to_vec();
    let mut all: Vec<Mesh> = Vec::new();
    for id in ids.iter().chain([target_id]).chain(&rest_ids) {
        let m = col.mesh(&case.source, id)?;
        // Lengths and areas of a mesh beyond f64's range: say so, naming it.
        crate::mesh::check_extent(crate::mesh::half_diagonal(m.vertices())).map_err(|e| {
            Error::invalid(format!(
                "{} (class {}, shape {id}): {e}",
                col.file_label(&case.source, id),
                case.source
            ))
        })?;
        all.push((*m).clone());
    }
    if all.iter().any(|m| m.faces() != all[0].faces()) {
        return Err(Error::invalid(format!(
            "FBT needs one face list per class; the shapes of class {} differ \
             beyond winding:\n{}",
            case.source,
            ConnectivityReport::of(&all)
        )));
    }
    // Unreferenced vertices and tiny loose parts carry no area: drop them
    // (the same vertices from every shape: one face list) and say so.
    let part = SolvablePart::of(&all[0], DEFAULT_MIN_PART_FRACTION)?;
    if !part.is_whole() {
        all = all
            .iter()
            .map(|m| part.restrict(m))
            .collect::<Result<Vec<Mesh>>>()?;
    }
    let rest = all.split_off(q + 1);
    let target = all.pop().ok_or_else(|| Error::invalid("no target"))?;
    Ok(FbtCase {
        examples: all,
        target,
        rest,
        example_ids: ids,
        rest_ids,
        part,
    })
}

/// The shapes the skeleton weights are learnt from: the q − 1 examples
/// besides the reference (`rig = "examples"`), or the first `rig_poses`
/// shapes of the class in draw order besides the reference and the target
/// (`rig = "class"`: the examples of every q come first, so the rig is the
/// same for every q).
fn rig_shapes(fc: &FbtCase, o: &FbtOptions) -> Vec<Mesh> {
    match o.rig {
        RigSource::Examples => fc.examples[1..].to_vec(),
        RigSource::Class => class_shapes(fc, o.rig_poses),
    }
}

/// The first `n` shapes of the class in draw order besides the reference
/// and the target (independent of q: the draws are nested).
fn class_shapes(fc: &FbtCase, n: usize) -> Vec<Mesh> {
    fc.examples[1..]
        .iter()
        .chain(&fc.rest)
        .take(n)
        .cloned()
        .collect()
}

/// Shapes of the class the measurement's parts are learnt from (when the
/// dataset has no true segmentation): the same for every method and q.
const PART_RIG_SHAPES: usize = 4;

/// The parts of the class that a gross failure misplaces: the dataset's
/// true segmentation when it has one (synthetic set), else the bones of
/// the example-based skinning of the rig shapes (never the target),
/// vertex → dominant bone.
fn class_parts(col: &Collection, fc: &FbtCase) -> Result<Vec<usize>> {
    if let Some(labels) = &col.labels {
        if labels.len() == fc.part.new_index.len() {
            return Ok(fc.part.kept.iter().map(|&i| labels[i]).collect());
        }
    }
    let rig = class_shapes(fc, PART_RIG_SHAPES);
    if rig.is_empty() {
        return Err(Error::invalid(
            "the class's parts are learnt from its other shapes: the class has none besides \
             the reference and the target",
        ));
    }
    // The library's rig options (not the method's `bones`): one measuring
    // device for every method.
    Ok(skeleton_rig(
        &fc.examples[0],
        &rig,
        &crate::skin::rigging::RigOptions::default(),
    )?
    .labels
    .clone())
}

/// Runs an FBT method on a case, filling `out` (see the module docs).
pub fn run(
    col: &Collection,
    case: &Case,
    spec: &FbtSpec,
    seed: u64,
    metrics_spec: &MetricsSpec,
    render: Option<(&RenderOut, &str)>,
    out: &mut CaseResult,
) -> Result<()> {
    let o = spec.resolve();
    let q = o.q;
    let fc = load_case(col, case, q, seed)?;
    out.set("q", q.to_string());
    out.set("fbt_task", task_name(spec.task));
    out.set("examples", fc.example_ids.join(";"));
    out.set("n_vertices", fc.target.n_vertices().to_string());
    out.set("n_faces", fc.target.n_faces().to_string());
    out.set("dropped_vertices", fc.part.dropped().to_string());
    if !fc.part.is_whole() {
        out.set("dropped_note", fc.part.describe());
    }
    let m = o.m;
    let solver = spec.solver.unwrap_or_default();
    if spec.solves_with_pipeline() {
        // The solving pipeline (Der et al. uses its rotation clusters).
        out.set("pipeline", o.pipeline.name());
    }
    out.set(
        "dictionary",
        match spec.dictionary.unwrap_or_default() {
            _ if spec.task != FbtTask::Projection => o.config(seed).describe(),
            DictionaryKind::Lbo => format!("LBO m = {m}"),
            DictionaryKind::Skeleton => match o.bones {
                Some(b) => format!("skeleton, {b} bones"),
                None => "skeleton, bones chosen by the data".to_string(),
            },
            DictionaryKind::OneExample => format!("one example, size of LBO m = {m}"),
        },
    );
    let render_dir = render.map(|(r, name)| r.method(name));
    let pose = case.poses[0].clone();
    match spec.task {
        FbtTask::Projection => projection(&fc, spec, &o, out),
        FbtTask::Timing => timing(&fc, &o, seed, out),
        FbtTask::Scale => scale(&fc, &o, seed, out, render_dir.as_ref(), &pose),
        FbtTask::Completion => completion(
            &fc,
            &class_parts(col, &fc)?,
            &o,
            solver,
            seed,
            case,
            metrics_spec,
            out,
            render_dir.as_ref(),
            &pose,
        ),
        FbtTask::Permutation => permutation(&fc, &o, seed, out),
        FbtTask::Interpolation => interpolation(&fc, &o, seed, out, render_dir.as_ref(), &pose),
    }
}

fn set_distortion(out: &mut CaseResult, d: &[f64], suffix: &str) {
    out.set(
        &format!("rel_distortion_mean{suffix}"),
        num(metrics::mean(d)),
    );
    out.set(
        &format!("rel_distortion_median{suffix}"),
        num(metrics::median(d.to_vec())),
    );
    out.set(&format!("rel_distortion_max{suffix}"), num(metrics::max(d)));
}

/// Beside the raw distortion of a registration: its distortion after the
/// best rigid motion onto the truth (`rel_distortion_*_aligned`: how much of
/// the error is pose, not placement), and the trivial floor, the template
/// left undeformed (`floor_distortion_mean`, raw and `_aligned`). All in
/// √area units, `area` being the one of the raw distortion. Returns the
/// aligned distortion per vertex.
fn set_aligned_and_floor(
    out: &mut CaseResult,
    positions: &[Point],
    template: &[Point],
    truth: &[Point],
    area: f64,
) -> Result<Vec<f64>> {
    let s = area.sqrt();
    let rel = |e: Vec<f64>| -> Vec<f64> { e.into_iter().map(|x| x / s).collect() };
    let aligned = rel(aligned_vertex_errors(positions, truth)?);
    set_distortion(out, &aligned, "_aligned");
    let floor = metrics::relative_distortion(template, truth, area)?;
    out.set("floor_distortion_mean", num(metrics::mean(&floor)));
    let floor_aligned = rel(aligned_vertex_errors(template, truth)?);
    out.set(
        "floor_distortion_mean_aligned",
        num(metrics::mean(&floor_aligned)),
    );
    Ok(aligned)
}

/// Table 2: the closest shape in the dictionary's span.
fn projection(fc: &FbtCase, spec: &FbtSpec, o: &FbtOptions, out: &mut CaseResult) -> Result<()> {
    let t = Instant::now();
    let reference = &fc.examples[0];
    let m = o.m;
    out.set(
        "dictionary_kind",
        match spec.dictionary.unwrap_or_default() {
            DictionaryKind::Lbo => "lbo",
            DictionaryKind::Skeleton => "skeleton",
            DictionaryKind::OneExample => "one_example",
        },
    );
    let dict = match spec.dictionary.unwrap_or_default() {
        DictionaryKind::Lbo => {
            let basis = lbo_basis(reference, m, &EigenOptions::default())?;
            Dictionary::from_meshes(&fc.examples, &SkinningWeights::lbo(&basis))?
        }
        DictionaryKind::OneExample => {
            let m1 = (((1.0 + 3.0 * fc.examples.len() as f64) * m as f64) / 4.0).round() as usize;
            let basis = lbo_basis(reference, m1, &EigenOptions::default())?;
            Dictionary::from_meshes(&fc.examples[..1], &SkinningWeights::lbo(&basis))?
        }
        DictionaryKind::Skeleton => {
            let rig = rig_shapes(fc, o);
            let want = match o.rig {
                RigSource::Examples => 1,
                RigSource::Class => o.rig_poses,
            };
            if rig.len() < want {
                return Err(Error::invalid(format!(
                    "skeleton weights need {want} rig shape(s) besides the reference and the \
                     target (rig = \"{}\"); the case has {}",
                    o.rig.name(),
                    rig.len()
                )));
            }
            let (w, r) = skeleton_weights(reference, &rig, &o.rig_options())?;
            out.set("n_bones", r.bones().to_string());
            out.set("rig_rms", num(r.rms_error));
            Dictionary::from_meshes(&fc.examples, &w)?
        }
    };
    out.set("dict_size", dict.size().to_string());
    let coef = dict.project(fc.target.vertices())?;
    let p = points_from_matrix(&dict.apply(&coef)?);
    let area = crate::ops::total_area(reference);
    let d = metrics::relative_distortion(&p, fc.target.vertices(), area)?;
    set_distortion(out, &d, "");
    out.set("seconds_precompute", secs(t.elapsed().as_secs_f64()));
    Ok(())
}

/// Table 1 timings (medians of `repeats`): precomputation, one
/// local/scale/global iteration of E_total in the dictionary of each stage
/// of the pipeline (`seconds_iteration_init` / `_main` / `_rich`, the same
/// energy, so the columns differ by the dictionary size b; a stage the
/// pipeline lacks has no column), and the full default schedule after
/// precomputation (`seconds_solve`).
fn timing(fc: &FbtCase, o: &FbtOptions, seed: u64, out: &mut CaseResult) -> Result<()> {
    let reps = o.repeats;
    let params = o.params();
    let schedule = Schedule::default();
    let t = Instant::now();
    let setup = build_with_rig(&fc.examples, &rig_shapes(fc, o), &o.config(seed))?;
    let t_build = t.elapsed().as_secs_f64();
    let area = setup.graph.area();
    let feats = feature_points(&fc.target, o.features.features, seed)?;
    let pairs: Vec<(usize, usize)> = feats.iter().map(|&f| (f, f)).collect();
    let (rows, y) = o
        .features
        .constraints(&fc.examples[0], &fc.target, &pairs, area)?;
    let t = Instant::now();
    let sys = setup.pipeline.systems(&rows, &params)?;
    let t_fact = t.elapsed().as_secs_f64();
    // Each stage's system with a start in its own dictionary: the main
    // stage from the schedule's initial transformations (steps 1–2), the
    // others from their linear initial solve (Eq. 22); one iteration costs
    // the same from any start.
    let mut stages = vec![("main", &sys.main, sys.initial(&y, schedule.init)?)];
    for (name, s) in [("init", sys.init.as_ref()), ("rich", sys.rich.as_ref())] {
        if let Some(s) = s {
            stages.push((name, s, s.initial(&y)?));
        }
    }
    let one = IterOptions {
        max_iter: 1,
        rel_tol: 0.0,
    };
    let mut it: Vec<Vec<f64>> = vec![Vec::new(); stages.len()];
    let mut full = Vec::new();
    let mut reg = None;
    for _ in 0..reps {
        for ((_, s, t0), times) in stages.iter().zip(&mut it) {
            let t = Instant::now();
            s.solve_average(&y, t0, &one)?;
            times.push(t.elapsed().as_secs_f64());
        }
        let t = Instant::now();
        reg = Some(sys.solve(&y, &schedule)?);
        full.push(t.elapsed().as_secs_f64());
    }
    let reg = reg.ok_or_else(|| Error::invalid("no repetitions"))?;
    let (bi, bm, br) = setup.sizes;
    out.set("dict_size", bm.to_string());
    out.set(
        "dict_sizes",
        format!(
            "{}/{bm}/{}",
            bi.map_or("-".into(), |b| b.to_string()),
            br.map_or("-".into(), |b| b.to_string())
        ),
    );
    out.set("n_clusters", setup.pipeline.main().n_clusters().to_string());
    out.set("n_constraints", rows.len().to_string());
    out.set("seconds_precompute", secs(t_build + t_fact));
    out.set("seconds_factorise", secs(t_fact));
    for ((name, ..), times) in stages.iter().zip(it) {
        out.set(
            &format!("seconds_iteration_{name}"),
            secs(metrics::median(times)),
        );
    }
    out.set("seconds_solve", secs(metrics::median(full)));
    out.set("iterations", reg.iterations.to_string());
    let d = metrics::relative_distortion(&reg.positions, fc.target.vertices(), area)?;
    set_distortion(out, &d, "");
    Ok(())
}

fn scaled(points: &[Point], s: f64) -> Vec<Point> {
    let c = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / points.len() as f64;
    points
        .iter()
        .map(|p| Point::from(c + s * (p.coords - c)))
        .collect()
}

/// Figs. 4–5: vertex-position constraints on a scaled target.
fn scale(
    fc: &FbtCase,
    o: &FbtOptions,
    seed: u64,
    out: &mut CaseResult,
    render: Option<&MeshOut>,
    pose: &str,
) -> Result<()> {
    let s = o.scale;
    let params = o.params();
    let t = Instant::now();
    let setup = build_with_rig(&fc.examples, &rig_shapes(fc, o), &o.config(seed))?;
    out.set("seconds_precompute", secs(t.elapsed().as_secs_f64()));
    let target = fc.target.with_vertices(scaled(fc.target.vertices(), s))?;
    let verts = feature_points(&fc.examples[0], o.vertices, seed)?;
    let rows = vertex_rows(&verts);
    let y = apply_rows(&rows, target.vertices())?;
    let t = Instant::now();
    let sys = setup.pipeline.systems(&rows, &params)?;
    let reg = sys.solve(&y, &Schedule::default())?;
    out.set("seconds_solve", secs(t.elapsed().as_secs_f64()));
    out.set("n_constraints", rows.len().to_string());
    out.set("dict_size", setup.sizes.1.to_string());
    out.set("alpha", num(reg.alpha));
    out.set("alpha_true", num(s));
    out.set("alpha_error", num((reg.alpha - s).abs() / s));
    // The unscaled target's own α (≠ 1 when it is not an isometry of the
    // examples): α is linear in the target's scale, so α / α₁ isolates the
    // applied scale.
    let y1 = apply_rows(&rows, fc.target.vertices())?;
    let alpha1 = sys.solve(&y1, &Schedule::default())?.alpha;
    out.set("alpha_unscaled", num(alpha1));
    out.set("alpha_ratio_error", num((reg.alpha / alpha1 - s).abs() / s));
    // The α the energy assigns to the true scaled target (optimal cluster
    // rotations and scale for the truth, same example ℓ*): the estimator's
    // own value, against which the solver's α is judged.
    let clusters = setup.pipeline.main().clusters();
    let (oracle, _) = setup
        .graph
        .best_scale(reg.example, target.vertices(), clusters)?;
    out.set("alpha_oracle", num(oracle));
    // The same with one rotation per vertex (its 1-ring: the finest
    // clusters, classic ARAP): how far the true target is from a scaled
    // isometry of example ℓ*, which no clustering can remove; the cluster
    // oracle falls below it by the within-cluster bending.
    let per_vertex: Vec<usize> = (0..target.n_vertices()).collect();
    let (vertex_oracle, _) = setup
        .graph
        .best_scale(reg.example, target.vertices(), &per_vertex)?;
    out.set("alpha_vertex_oracle", num(vertex_oracle));
    out.set(
        "alpha_oracle_error",
        num((reg.alpha - oracle).abs() / oracle),
    );
    let area = setup.graph.area() * s * s;
    let d = metrics::relative_distortion(&reg.positions, target.vertices(), area)?;
    set_distortion(out, &d, "");
    set_aligned_and_floor(
        out,
        &reg.positions,
        fc.examples[0].vertices(),
        target.vertices(),
        area,
    )?;
    if let Some(dir) = render {
        // Per vertex: the relative distortion (√area units) behind
        // `rel_distortion_*`.
        dir.save(
            &format!("result_{pose}"),
            &fc.examples[0].with_vertices(reg.positions)?,
            Some(&d),
        )?;
        dir.save(&format!("scaled_target_{pose}"), &target, None)?;
    }
    Ok(())
}

/// Figs. 6–8: partial target, feature registration, NICP — with FBT's
/// blended transformations, Der et al.'s reduced model, or Amberg et al.'s
/// optimal-step NICP as the deformation model (`solver`); the partial
/// target, the features and the measurements are the same for all three
/// (one [`CompletionProblem`] per case).
#[allow(clippy::too_many_arguments)]
fn completion(
    fc: &FbtCase,
    parts: &[usize],
    o: &FbtOptions,
    solver: SolverKind,
    seed: u64,
    case: &Case,
    metrics_spec: &MetricsSpec,
    out: &mut CaseResult,
    render: Option<&MeshOut>,
    pose: &str,
) -> Result<()> {
    // Partial target: depends on the case only (same for every method).
    let problem = CompletionProblem::new(
        &fc.examples,
        &fc.target,
        &o.features,
        fnv1a(case.id.as_bytes()),
    )?
    .with_rig_shapes(rig_shapes(fc, o));
    out.set("partial_area", num(problem.partial().area_fraction));
    out.set("n_constraints", problem.rows().len().to_string());
    let solver = CompletionSolver::new(solver, o, seed);
    let r = solver.solve(&problem)?;
    let optional = [
        ("seconds_precompute", r.seconds_precompute.map(secs)),
        ("seconds_solve", r.seconds_solve.map(secs)),
        ("seconds_nicp", r.seconds_nicp.map(secs)),
        ("alpha", r.alpha.map(num)),
        ("dict_size", r.dict_size.map(|b| b.to_string())),
        ("n_clusters", r.n_clusters.map(|c| c.to_string())),
        ("iterations", r.iterations.map(|i| i.to_string())),
        ("dictionary", r.dictionary.clone()),
        ("partial_residual", r.partial_residual.map(num)),
        ("attempts", r.attempts.map(|a| a.to_string())),
        ("attempt", r.attempt.map(str::to_string)),
    ];
    for (column, value) in optional {
        if let Some(v) = value {
            out.set(column, v);
        }
    }
    if let Some(init) = &r.init_positions {
        set_distortion(out, &problem.distortion(init)?, "_init");
    }
    let positions = &r.positions;
    let d = problem.distortion(positions)?;
    set_distortion(out, &d, "");
    let d_rigid = set_aligned_and_floor(
        out,
        positions,
        problem.reference().vertices(),
        problem.target().vertices(),
        problem.area(),
    )?;
    // Gross failures: a part (limb, torso) off by more than
    // GROSS_FAILURE_DISTORTION √area on average or at its worst.
    let per_part = metrics::part_errors(&d, parts)?;
    let failed = per_part
        .iter()
        .filter(|p| p.failed(metrics::GROSS_FAILURE_DISTORTION))
        .count();
    out.set("failed_parts", failed.to_string());
    out.set("gross_failure", if failed > 0 { "1" } else { "0" });
    out.set(
        "worst_part_mean",
        num(per_part.iter().map(|p| p.mean).fold(0.0, f64::max)),
    );
    out.set(
        "worst_part_max",
        num(per_part.iter().map(|p| p.worst).fold(0.0, f64::max)),
    );
    // Curves. Distortion: share of template points within a relative
    // distance (√area units) of their true position; also in unit-sphere
    // units for the harness's cumulative plot.
    let grid = curve_grid(metrics_spec.curve_max_area(), metrics_spec.curve_points())?;
    out.curves.push(Curve::new(
        "cumulative_area",
        &grid,
        &cumulative_curve(&d, &grid),
    ));
    out.curves.push(Curve::new(
        "cumulative_area_rigid",
        &grid,
        &cumulative_curve(&d_rigid, &grid),
    ));
    let sc = ErrorScale::of_reference(&fc.target)?;
    let raw = vertex_errors(positions, fc.target.vertices())?;
    let st = error_stats(&raw)?;
    out.set("err_mean_unit", num(st.mean * sc.unit_sphere));
    out.set("err_mean_area", num(st.mean * sc.sqrt_area));
    let unit: Vec<f64> = raw.iter().map(|e| e * sc.unit_sphere).collect();
    let ugrid = curve_grid(metrics_spec.curve_max(), metrics_spec.curve_points())?;
    out.curves.push(Curve::new(
        "cumulative_unit",
        &ugrid,
        &cumulative_curve(&unit, &ugrid),
    ));
    // Correspondences: a partial-target point is matched to the nearest
    // vertex of the registered template; the error is the distance on the
    // full target between that vertex and the point's true vertex, over
    // √area(target): Euclidean as in the paper's Fig. 7 (right), geodesic
    // as in Kim et al. (`corr_error_mean` = the geodesic one, kept for the
    // configs that name it).
    let (predicted, truth) = problem.correspondences(positions, o.queries)?;
    let (ce, curve) = geodesic_error_curve(&fc.target, &predicted, &truth, &grid)?;
    out.set("corr_error_mean", num(metrics::mean(&ce)));
    out.set("corr_error_mean_geodesic", num(metrics::mean(&ce)));
    out.curves
        .push(Curve::new("correspondence_geodesic_area", &grid, &curve));
    let (ce, curve) = crate::eval::euclidean_error_curve(&fc.target, &predicted, &truth, &grid)?;
    out.set("corr_error_mean_euclidean", num(metrics::mean(&ce)));
    // The floor: the same queries matched to the undeformed template.
    let (floor_predicted, _) =
        problem.correspondences(problem.reference().vertices(), o.queries)?;
    let (fce, _) = crate::eval::euclidean_error_curve(&fc.target, &floor_predicted, &truth, &grid)?;
    out.set("floor_corr_error_mean_euclidean", num(metrics::mean(&fce)));
    out.curves
        .push(Curve::new("correspondence_euclidean_area", &grid, &curve));
    if let Some(dir) = render {
        // Per vertex: the relative distortion (√area units) behind
        // `rel_distortion_*`.
        dir.save(
            &format!("result_{pose}"),
            &problem.reference().with_vertices(r.positions.clone())?,
            Some(&d),
        )?;
        dir.save(&format!("partial_{pose}"), &problem.partial().mesh, None)?;
    }
    Ok(())
}

/// Fig. 3: automatic correspondence within an ambiguous feature group.
fn permutation(fc: &FbtCase, o: &FbtOptions, seed: u64, out: &mut CaseResult) -> Result<()> {
    let params = o.params();
    let setup = build_with_rig(&fc.examples, &rig_shapes(fc, o), &o.config(seed))?;
    let area = setup.graph.area();
    let k = o.group;
    let circles = FeatureOptions {
        radius: o.full_target_radius,
        ..o.features
    };
    let feats = feature_points(&fc.examples[0], circles.features, seed)?;
    let pairs: Vec<(usize, usize)> = feats.iter().map(|&f| (f, f)).collect();
    let (rows, y) = circles.constraints(&fc.examples[0], &fc.target, &pairs, area)?;
    let group = feature_row_groups(k, circles.circles);
    let t = Instant::now();
    let sys = setup.pipeline.systems(&rows, &params)?;
    let search = best_permutation(&sys, &y, &group, &Schedule::default())?;
    out.set("seconds_solve", secs(t.elapsed().as_secs_f64()));
    let identity: Vec<usize> = (0..k).collect();
    let e_true = search
        .energies
        .iter()
        .find(|(p, _)| *p == identity)
        .map(|e| e.1)
        .ok_or_else(|| Error::invalid("identity assignment missing"))?;
    let rank = search.energies.iter().filter(|e| e.1 < e_true).count();
    out.set(
        "perm_correct",
        if search.best == identity { "1" } else { "0" },
    );
    out.set("perm_rank", rank.to_string());
    out.set("perm_count", search.energies.len().to_string());
    let d =
        metrics::relative_distortion(&search.registration.positions, fc.target.vertices(), area)?;
    set_distortion(out, &d, "");
    set_aligned_and_floor(
        out,
        &search.registration.positions,
        fc.examples[0].vertices(),
        fc.target.vertices(),
        area,
    )?;
    Ok(())
}

/// Fig. 3: interpolation between two registrations.
fn interpolation(
    fc: &FbtCase,
    o: &FbtOptions,
    seed: u64,
    out: &mut CaseResult,
    render: Option<&MeshOut>,
    pose: &str,
) -> Result<()> {
    let other = fc.rest.first().ok_or_else(|| {
        Error::invalid("interpolation needs a second target: one more shape in the class")
    })?;
    out.set(
        "examples",
        format!("{};to {}", fc.example_ids.join(";"), fc.rest_ids[0]),
    );
    let params = o.params();
    let setup = build_with_rig(&fc.examples, &rig_shapes(fc, o), &o.config(seed))?;
    let area = setup.graph.area();
    let circles = FeatureOptions {
        radius: o.full_target_radius,
        ..o.features
    };
    let feats = feature_points(&fc.examples[0], circles.features, seed)?;
    let pairs: Vec<(usize, usize)> = feats.iter().map(|&f| (f, f)).collect();
    let (rows, ya) = circles.constraints(&fc.examples[0], &fc.target, &pairs, area)?;
    let (_, yb) = circles.constraints(&fc.examples[0], other, &pairs, area)?;
    let sys = setup.pipeline.systems(&rows, &params)?;
    let a = sys.solve(&ya, &Schedule::default())?;
    let b = sys.solve(&yb, &Schedule::default())?;
    let last = sys.last();
    let at =
        |s: f64| -> Result<Vec<Point>> { last.positions(&interpolate(last, &a, &b, &ya, &yb, s)?) };
    let p0 = at(0.0)?;
    let p1 = at(1.0)?;
    let end = metrics::max(&metrics::relative_distortion(&p0, &a.positions, area)?).max(
        metrics::max(&metrics::relative_distortion(&p1, &b.positions, area)?),
    );
    // The endpoints are the registrations exactly when both chose the same
    // example ℓ* (otherwise the blend is an average-energy global step).
    if a.example == b.example {
        out.set("interp_endpoint_error", num(end));
    }
    let reference = &fc.examples[0];
    let mut ours = Vec::new();
    let mut linear = Vec::new();
    let ss = [0.0, 0.25, 0.5, 0.75, 1.0];
    let mut mid = Vec::new();
    for &s in &ss {
        let p = at(s)?;
        let l: Vec<Point> = a
            .positions
            .iter()
            .zip(&b.positions)
            .map(|(x, y)| Point::from(x.coords * (1.0 - s) + y.coords * s))
            .collect();
        ours.push(arap_energy(reference, &p)?.1);
        linear.push(arap_energy(reference, &l)?.1);
        if s == 0.5 {
            mid = p;
        }
    }
    out.set("arap_energy", num(ours[2]));
    out.set("arap_energy_linear", num(linear[2]));
    out.curves
        .push(Curve::new("interpolation_arap", &ss, &ours));
    out.curves
        .push(Curve::new("interpolation_arap_linear", &ss, &linear));
    if let Some(dir) = render {
        dir.save(
            &format!("result_{pose}"),
            &reference.with_vertices(mid)?,
            None,
        )?;
    }
    Ok(())
}

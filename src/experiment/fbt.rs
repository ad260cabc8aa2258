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

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::cases::Case;
use super::config::{FbtTask, MetricsSpec};
use super::dataset::Collection;
use super::store::{num, secs, CaseResult, Curve, MeshOut, RenderOut};
use crate::data::fnv1a;
use crate::eval::{
    aligned_vertex_errors, cumulative_curve, curve_grid, error_stats, geodesic_error_curve,
    vertex_errors, ErrorScale,
};
use crate::mesh::compact::{SolvablePart, DEFAULT_MIN_PART_FRACTION};
use crate::mesh::set::ConnectivityReport;
use crate::mesh::Mesh;
use crate::methods::completion::{CompletionProblem, CompletionSolver};
use crate::methods::fbt::{self as task, ClassShapes, FbtMethod};
use crate::register::{metrics, skeleton_rig};
use crate::{Error, Point, Result};

/// The meshes of one FBT case ([`ClassShapes`]) and where they came from.
struct FbtCase {
    shapes: ClassShapes,
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
        shapes: ClassShapes {
            examples: all,
            target,
            rest,
        },
        example_ids: ids,
        rest_ids,
        part,
    })
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
    let rig = fc.shapes.class_shapes(PART_RIG_SHAPES);
    if rig.is_empty() {
        return Err(Error::invalid(
            "the class's parts are learnt from its other shapes: the class has none besides \
             the reference and the target",
        ));
    }
    // The library's rig options (not the method's `bones`): one measuring
    // device for every method.
    Ok(skeleton_rig(
        fc.shapes.reference(),
        &rig,
        &crate::skin::rigging::RigOptions::default(),
    )?
    .labels
    .clone())
}

/// Runs an FBT method on a case, filling `out` (see the module docs): the
/// task is the library's ([`crate::methods::fbt`]); this records it.
pub fn run(
    col: &Collection,
    case: &Case,
    f: &FbtMethod,
    metrics_spec: &MetricsSpec,
    render: Option<(&RenderOut, &str)>,
    out: &mut CaseResult,
) -> Result<()> {
    let (o, seed) = (&f.options, f.seed);
    let fc = load_case(col, case, o.q, seed)?;
    let shapes = &fc.shapes;
    out.set("q", o.q.to_string());
    out.set("fbt_task", f.task.name());
    out.set("examples", fc.example_ids.join(";"));
    out.set("n_vertices", shapes.target.n_vertices().to_string());
    out.set("n_faces", shapes.target.n_faces().to_string());
    out.set("dropped_vertices", fc.part.dropped().to_string());
    if !fc.part.is_whole() {
        out.set("dropped_note", fc.part.describe());
    }
    if f.solves_with_pipeline() {
        // The solving pipeline (Der et al. uses its rotation clusters).
        out.set("pipeline", o.pipeline.name());
    }
    out.set("dictionary", f.dictionary_label());
    let render_dir = render.map(|(r, name)| r.method(name));
    let render_dir = render_dir.as_ref();
    let pose = case.poses[0].as_str();
    let truth = shapes.target.vertices();
    let template = shapes.reference().vertices();
    match f.task {
        FbtTask::Projection => {
            out.set("dictionary_kind", f.dictionary.name());
            let r = task::projection(shapes, f.dictionary, o)?;
            if let Some((bones, rms)) = r.rig {
                out.set("n_bones", bones.to_string());
                out.set("rig_rms", num(rms));
            }
            out.set("dict_size", r.dict_size.to_string());
            let d = metrics::relative_distortion(&r.positions, truth, r.area)?;
            set_distortion(out, &d, "");
            out.set("seconds_precompute", secs(r.seconds));
        }
        FbtTask::Timing => {
            let r = task::timing(shapes, o, seed)?;
            let (bi, bm, br) = r.sizes;
            out.set("dict_size", bm.to_string());
            let opt = |b: Option<usize>| b.map_or("-".into(), |b| b.to_string());
            out.set("dict_sizes", format!("{}/{bm}/{}", opt(bi), opt(br)));
            out.set("n_clusters", r.n_clusters.to_string());
            out.set("n_constraints", r.n_constraints.to_string());
            out.set(
                "seconds_precompute",
                secs(r.seconds_build + r.seconds_factorise),
            );
            out.set("seconds_factorise", secs(r.seconds_factorise));
            for (name, t) in &r.seconds_iteration {
                out.set(&format!("seconds_iteration_{name}"), secs(*t));
            }
            out.set("seconds_solve", secs(r.seconds_solve));
            out.set("iterations", r.iterations.to_string());
            let d = metrics::relative_distortion(&r.positions, truth, r.area)?;
            set_distortion(out, &d, "");
        }
        FbtTask::Scale => {
            let r = task::scale(shapes, o, seed)?;
            let s = o.scale;
            out.set("seconds_precompute", secs(r.seconds_precompute));
            out.set("seconds_solve", secs(r.seconds_solve));
            out.set("n_constraints", r.n_constraints.to_string());
            out.set("dict_size", r.dict_size.to_string());
            out.set("alpha", num(r.alpha));
            out.set("alpha_true", num(s));
            out.set("alpha_error", num((r.alpha - s).abs() / s));
            out.set("alpha_unscaled", num(r.alpha_unscaled));
            out.set(
                "alpha_ratio_error",
                num((r.alpha / r.alpha_unscaled - s).abs() / s),
            );
            out.set("alpha_oracle", num(r.alpha_oracle));
            out.set("alpha_vertex_oracle", num(r.alpha_vertex_oracle));
            out.set(
                "alpha_oracle_error",
                num((r.alpha - r.alpha_oracle).abs() / r.alpha_oracle),
            );
            let scaled = r.scaled_target.vertices();
            let d = metrics::relative_distortion(&r.positions, scaled, r.area)?;
            set_distortion(out, &d, "");
            set_aligned_and_floor(out, &r.positions, template, scaled, r.area)?;
            if let Some(dir) = render_dir {
                // Per vertex: the relative distortion (√area units) behind
                // `rel_distortion_*`.
                dir.save(
                    &format!("result_{pose}"),
                    &shapes.reference().with_vertices(r.positions)?,
                    Some(&d),
                )?;
                dir.save(&format!("scaled_target_{pose}"), &r.scaled_target, None)?;
            }
        }
        FbtTask::Completion => completion(
            &fc,
            &class_parts(col, &fc)?,
            f,
            case,
            metrics_spec,
            out,
            render_dir,
            pose,
        )?,
        FbtTask::Permutation => {
            let r = task::permutation(shapes, o, seed)?;
            out.set("seconds_solve", secs(r.seconds_solve));
            out.set("perm_correct", if r.correct { "1" } else { "0" });
            out.set("perm_rank", r.rank.to_string());
            out.set("perm_count", r.count.to_string());
            let d = metrics::relative_distortion(&r.positions, truth, r.area)?;
            set_distortion(out, &d, "");
            set_aligned_and_floor(out, &r.positions, template, truth, r.area)?;
        }
        FbtTask::Interpolation => {
            let second = shapes.rest.first().ok_or_else(|| {
                Error::invalid("interpolation needs a second target: one more shape in the class")
            })?;
            out.set(
                "examples",
                format!("{};to {}", fc.example_ids.join(";"), fc.rest_ids[0]),
            );
            let r = task::interpolation(shapes, second, o, seed)?;
            if let Some(e) = r.endpoint_error {
                out.set("interp_endpoint_error", num(e));
            }
            out.set("arap_energy", num(r.arap[2]));
            out.set("arap_energy_linear", num(r.arap_linear[2]));
            out.curves
                .push(Curve::new("interpolation_arap", &r.s, &r.arap));
            out.curves.push(Curve::new(
                "interpolation_arap_linear",
                &r.s,
                &r.arap_linear,
            ));
            if let Some(dir) = render_dir {
                dir.save(
                    &format!("result_{pose}"),
                    &shapes.reference().with_vertices(r.middle)?,
                    None,
                )?;
            }
        }
    }
    Ok(())
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

/// Figs. 6–8: partial target, feature registration, NICP — with FBT's
/// blended transformations, Der et al.'s reduced model, or Amberg et al.'s
/// optimal-step NICP as the deformation model (`solver`); the partial
/// target, the features and the measurements are the same for all three
/// (one [`CompletionProblem`] per case).
#[allow(clippy::too_many_arguments)]
fn completion(
    fc: &FbtCase,
    parts: &[usize],
    f: &FbtMethod,
    case: &Case,
    metrics_spec: &MetricsSpec,
    out: &mut CaseResult,
    render: Option<&MeshOut>,
    pose: &str,
) -> Result<()> {
    // Partial target: depends on the case only (same for every method).
    let (shapes, o) = (&fc.shapes, &f.options);
    let problem = CompletionProblem::new(
        &shapes.examples,
        &shapes.target,
        &o.features,
        fnv1a(case.id.as_bytes()),
    )?
    .with_rig_shapes(shapes.rig_shapes(o));
    out.set("partial_area", num(problem.partial().area_fraction));
    out.set("n_constraints", problem.rows().len().to_string());
    let solver = CompletionSolver::new(f.solver, o, f.seed);
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
    let sc = ErrorScale::of_reference(&fc.shapes.target)?;
    let raw = vertex_errors(positions, fc.shapes.target.vertices())?;
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
    let (ce, curve) = geodesic_error_curve(&fc.shapes.target, &predicted, &truth, &grid)?;
    out.set("corr_error_mean", num(metrics::mean(&ce)));
    out.set("corr_error_mean_geodesic", num(metrics::mean(&ce)));
    out.curves
        .push(Curve::new("correspondence_geodesic_area", &grid, &curve));
    let (ce, curve) =
        crate::eval::euclidean_error_curve(&fc.shapes.target, &predicted, &truth, &grid)?;
    out.set("corr_error_mean_euclidean", num(metrics::mean(&ce)));
    // The floor: the same queries matched to the undeformed template.
    let (floor_predicted, _) =
        problem.correspondences(problem.reference().vertices(), o.queries)?;
    let (fce, _) =
        crate::eval::euclidean_error_curve(&fc.shapes.target, &floor_predicted, &truth, &grid)?;
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

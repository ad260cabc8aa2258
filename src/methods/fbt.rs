//! The FBT tasks (paper 001, Sec. 5) as library values.
//!
//! An [`FbtMethod`] is one `kind = "fbt"` method resolved once from its
//! [`FbtSpec`]: the task, the typed [`FbtOptions`], the projection's
//! dictionary and the completion's deformation model. Each task runs on
//! [`ClassShapes`] (the examples with the reference first, the target, the
//! class's other shapes in draw order) and returns its outcome as plain
//! values; the harness ([`crate::experiment`]) only loads the shapes from a
//! dataset, measures the outcome against the truth and records it. Shape
//! completion is [`super::completion`]'s [`CompletionProblem`] /
//! [`super::completion::CompletionSolver`].
//!
//! [`FbtRegistrar`] is the registration every solving task (and the Python
//! binding's `FbtModel.register`) goes through: the examples' pipeline,
//! built once, then the paper's schedule on each set of constraints.
//!
//! [`CompletionProblem`]: super::completion::CompletionProblem

use std::time::Instant;

use nalgebra::{DMatrix, Vector3};

use super::completion::{DictionaryKind, FbtOptions, FeatureOptions, RigSource, SolverKind};
use super::spec::{FbtSpec, FbtTask};
use crate::data::partial::feature_points;
use crate::eval::arap_energy;
use crate::mesh::Mesh;
use crate::register::{
    apply_rows, best_permutation, build_with_rig, feature_row_groups, interpolate, metrics,
    skeleton_weights, vertex_rows, ConstraintRows, FbtParams, FbtSetup, IterOptions, Registration,
    Schedule,
};
use crate::skin::dictionary::{Dictionary, SkinningWeights};
use crate::skin::lbo::lbo_basis;
use crate::skin::lbs::points_from_matrix;
use crate::solve::EigenOptions;
use crate::{Error, Point, Result};

/// A resolved `kind = "fbt"` method: its task and every option typed, with
/// the defaults of [`FbtOptions::default`] filled in once.
#[derive(Clone, Debug, PartialEq)]
pub struct FbtMethod {
    /// The configured table (what the records and fingerprints show).
    pub spec: FbtSpec,
    pub task: FbtTask,
    pub options: FbtOptions,
    /// The `projection` task's dictionary.
    pub dictionary: DictionaryKind,
    /// The `completion` task's deformation model.
    pub solver: SolverKind,
    pub seed: u64,
}

impl FbtMethod {
    /// Checks `spec` (errors are `(key, message)` relative to the method's
    /// `fbt` table) and resolves it.
    pub fn new(spec: FbtSpec, seed: u64) -> std::result::Result<Self, (String, String)> {
        spec.check()?;
        Ok(FbtMethod {
            task: spec.task,
            options: spec.resolve(),
            dictionary: spec.dictionary.unwrap_or_default(),
            solver: spec.solver.unwrap_or_default(),
            seed,
            spec,
        })
    }

    /// Whether the method solves with an FBT pipeline (FBT itself, or Der
    /// et al. on its rotation clusters; not the projection task).
    pub fn solves_with_pipeline(&self) -> bool {
        self.spec.solves_with_pipeline()
    }

    /// Whether the method learns skeleton weights (the projection's
    /// skeleton dictionary, or a solving pipeline with a skeleton stage).
    pub fn uses_skeleton(&self) -> bool {
        if self.task == FbtTask::Projection {
            self.dictionary == DictionaryKind::Skeleton
        } else {
            self.solves_with_pipeline() && self.options.pipeline.uses_skeleton()
        }
    }

    /// Whether the task places feature points on the target.
    pub fn uses_features(&self) -> bool {
        matches!(
            self.task,
            FbtTask::Timing | FbtTask::Completion | FbtTask::Permutation | FbtTask::Interpolation
        )
    }

    /// The dictionary, as the `dictionary` column reads it.
    pub fn dictionary_label(&self) -> String {
        let m = self.options.m;
        match self.dictionary {
            _ if self.task != FbtTask::Projection => self.options.config(self.seed).describe(),
            DictionaryKind::Lbo => format!("LBO m = {m}"),
            DictionaryKind::Skeleton => match self.options.bones {
                Some(b) => format!("skeleton, {b} bones"),
                None => "skeleton, bones chosen by the data".to_string(),
            },
            DictionaryKind::OneExample => format!("one example, size of LBO m = {m}"),
        }
    }
}

impl FbtTask {
    /// The task's name (`task = "..."`, the `fbt_task` column).
    pub fn name(self) -> &'static str {
        match self {
            FbtTask::Timing => "timing",
            FbtTask::Projection => "projection",
            FbtTask::Scale => "scale",
            FbtTask::Completion => "completion",
            FbtTask::Permutation => "permutation",
            FbtTask::Interpolation => "interpolation",
        }
    }
}

impl DictionaryKind {
    /// The dictionary's name (`dictionary = "..."`).
    pub fn name(self) -> &'static str {
        match self {
            DictionaryKind::Lbo => "lbo",
            DictionaryKind::Skeleton => "skeleton",
            DictionaryKind::OneExample => "one_example",
        }
    }
}

/// The shapes of one class an FBT task runs on: the q examples (reference
/// first), the target, and the class's remaining shapes in draw order.
/// Every shape has the reference's connectivity (vertex `i` ↔ vertex `i`).
#[derive(Clone, Debug)]
pub struct ClassShapes {
    pub examples: Vec<Mesh>,
    pub target: Mesh,
    pub rest: Vec<Mesh>,
}

impl ClassShapes {
    /// The reference example.
    pub fn reference(&self) -> &Mesh {
        &self.examples[0]
    }

    /// The shapes the skeleton weights are learnt from: the q − 1 examples
    /// besides the reference (`rig = "examples"`), or the first `rig_poses`
    /// shapes of the class in draw order besides the reference and the
    /// target (`rig = "class"`: the examples of every q come first, so the
    /// rig is the same for every q).
    pub fn rig_shapes(&self, o: &FbtOptions) -> Vec<Mesh> {
        match o.rig {
            RigSource::Examples => self.examples[1..].to_vec(),
            RigSource::Class => self.class_shapes(o.rig_poses),
        }
    }

    /// The first `n` shapes of the class in draw order besides the
    /// reference and the target (independent of q: the draws are nested).
    pub fn class_shapes(&self, n: usize) -> Vec<Mesh> {
        self.examples[1..]
            .iter()
            .chain(&self.rest)
            .take(n)
            .cloned()
            .collect()
    }
}

/// The examples' registration pipeline, built once; every solving task and
/// the binding's `FbtModel.register` register through it with the paper's
/// schedule.
pub struct FbtRegistrar {
    setup: FbtSetup,
    params: FbtParams,
    reference: Mesh,
    seed: u64,
}

impl FbtRegistrar {
    /// Builds the pipeline of `o` from the examples (reference first) and
    /// the shapes the skeleton weights are learnt from.
    pub fn build(examples: &[Mesh], rig: &[Mesh], o: &FbtOptions, seed: u64) -> Result<Self> {
        let reference = examples
            .first()
            .ok_or_else(|| Error::invalid("FBT needs at least one example"))?
            .clone();
        Ok(FbtRegistrar {
            setup: build_with_rig(examples, rig, &o.config(seed))?,
            params: o.params(),
            reference,
            seed,
        })
    }

    /// The built pipeline (dictionaries, clusters, ARAP graph).
    pub fn setup(&self) -> &FbtSetup {
        &self.setup
    }

    /// Area of the reference example (the √area unit of distortions).
    pub fn area(&self) -> f64 {
        self.setup.graph.area()
    }

    /// Registration to linear constraints `H` (rows) with targets `Y`.
    pub fn register(&self, rows: &ConstraintRows, y: &DMatrix<f64>) -> Result<Registration> {
        let sys = self.setup.pipeline.systems(rows, &self.params)?;
        sys.solve(y, &Schedule::default())
    }

    /// Registration to vertex-position constraints (`H = e_i`).
    pub fn register_vertices(&self, vertices: &[usize], targets: &[Point]) -> Result<Registration> {
        if vertices.is_empty() || vertices.len() != targets.len() {
            return Err(Error::invalid(format!(
                "constraints: {} vertices and {} target positions; expected as many, at least one",
                vertices.len(),
                targets.len()
            )));
        }
        let y = DMatrix::from_fn(targets.len(), 3, |r, c| targets[r][c]);
        self.register(&vertex_rows(vertices), &y)
    }

    /// Feature-circle constraints between the reference and a full target:
    /// `features.features` feature points placed on the reference (seeded),
    /// matched to the same vertex of `target`.
    pub fn feature_constraints(
        &self,
        features: &FeatureOptions,
        target: &Mesh,
    ) -> Result<(ConstraintRows, DMatrix<f64>)> {
        let feats = feature_points(&self.reference, features.features, self.seed)?;
        let pairs: Vec<(usize, usize)> = feats.iter().map(|&f| (f, f)).collect();
        features.constraints(&self.reference, target, &pairs, self.area())
    }
}

/// Table 2: the closest shape the dictionary spans.
#[derive(Clone, Debug)]
pub struct ProjectionOutcome {
    pub dict_size: usize,
    /// Bones and RMS fit error of the skeleton weights (skeleton only).
    pub rig: Option<(usize, f64)>,
    pub positions: Vec<Point>,
    /// Area of the reference.
    pub area: f64,
    pub seconds: f64,
}

/// Table 2: projects the target onto the span of `dictionary` built from
/// the examples.
pub fn projection(
    shapes: &ClassShapes,
    dictionary: DictionaryKind,
    o: &FbtOptions,
) -> Result<ProjectionOutcome> {
    let t = Instant::now();
    let reference = shapes.reference();
    let m = o.m;
    let mut rig_fit = None;
    let dict = match dictionary {
        DictionaryKind::Lbo => {
            let basis = lbo_basis(reference, m, &EigenOptions::default())?;
            Dictionary::from_meshes(&shapes.examples, &SkinningWeights::lbo(&basis))?
        }
        DictionaryKind::OneExample => {
            // The atom count of the q-example LBO dictionary: (1 + 3q)·m = 4·m′.
            let q = shapes.examples.len() as f64;
            let m1 = (((1.0 + 3.0 * q) * m as f64) / 4.0).round() as usize;
            let basis = lbo_basis(reference, m1, &EigenOptions::default())?;
            Dictionary::from_meshes(&shapes.examples[..1], &SkinningWeights::lbo(&basis))?
        }
        DictionaryKind::Skeleton => {
            let rig = shapes.rig_shapes(o);
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
            rig_fit = Some((r.bones(), r.rms_error));
            Dictionary::from_meshes(&shapes.examples, &w)?
        }
    };
    let coef = dict.project(shapes.target.vertices())?;
    Ok(ProjectionOutcome {
        dict_size: dict.size(),
        rig: rig_fit,
        positions: points_from_matrix(&dict.apply(&coef)?),
        area: crate::ops::total_area(reference),
        seconds: t.elapsed().as_secs_f64(),
    })
}

/// Table 1: the cost of the pipeline's parts (medians of `repeats`).
#[derive(Clone, Debug)]
pub struct TimingOutcome {
    /// Dictionary sizes b of (init, main, rich).
    pub sizes: (Option<usize>, usize, Option<usize>),
    pub n_clusters: usize,
    pub n_constraints: usize,
    pub seconds_build: f64,
    pub seconds_factorise: f64,
    /// One E_total iteration in each stage's dictionary (`main`, then
    /// `init` and `rich` when the pipeline has them).
    pub seconds_iteration: Vec<(&'static str, f64)>,
    /// The full default schedule after precomputation.
    pub seconds_solve: f64,
    pub iterations: usize,
    pub positions: Vec<Point>,
    pub area: f64,
}

/// Table 1 timings: precomputation, one local/scale/global iteration of
/// E_total in the dictionary of each stage (the same energy, so they
/// differ by the dictionary size b), and the full default schedule, on the
/// feature-circle constraints to the target.
pub fn timing(shapes: &ClassShapes, o: &FbtOptions, seed: u64) -> Result<TimingOutcome> {
    let schedule = Schedule::default();
    let t = Instant::now();
    let reg = FbtRegistrar::build(&shapes.examples, &shapes.rig_shapes(o), o, seed)?;
    let seconds_build = t.elapsed().as_secs_f64();
    // The features of the timing are placed on the target (as the paper's
    // partial targets), matched to the same vertex of the reference.
    let feats = feature_points(&shapes.target, o.features.features, seed)?;
    let pairs: Vec<(usize, usize)> = feats.iter().map(|&f| (f, f)).collect();
    let (rows, y) =
        o.features
            .constraints(shapes.reference(), &shapes.target, &pairs, reg.area())?;
    let t = Instant::now();
    let sys = reg.setup.pipeline.systems(&rows, &reg.params)?;
    let seconds_factorise = t.elapsed().as_secs_f64();
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
    let mut last = None;
    for _ in 0..o.repeats {
        for ((_, s, t0), times) in stages.iter().zip(&mut it) {
            let t = Instant::now();
            s.solve_average(&y, t0, &one)?;
            times.push(t.elapsed().as_secs_f64());
        }
        let t = Instant::now();
        last = Some(sys.solve(&y, &schedule)?);
        full.push(t.elapsed().as_secs_f64());
    }
    let last = last.ok_or_else(|| Error::invalid("no repetitions"))?;
    Ok(TimingOutcome {
        sizes: reg.setup.sizes,
        n_clusters: reg.setup.pipeline.main().n_clusters(),
        n_constraints: rows.len(),
        seconds_build,
        seconds_factorise,
        seconds_iteration: stages
            .iter()
            .zip(it)
            .map(|((name, ..), times)| (*name, metrics::median(times)))
            .collect(),
        seconds_solve: metrics::median(full),
        iterations: last.iterations,
        positions: last.positions,
        area: reg.area(),
    })
}

/// Figs. 4–5: registration of a scaled target and its global scale α.
#[derive(Clone, Debug)]
pub struct ScaleOutcome {
    /// The target scaled by `scale` about its centroid (the truth).
    pub scaled_target: Mesh,
    pub seconds_precompute: f64,
    pub seconds_solve: f64,
    pub n_constraints: usize,
    pub dict_size: usize,
    pub positions: Vec<Point>,
    /// The recovered α.
    pub alpha: f64,
    /// α of the unscaled target (≠ 1 when it is not an isometry of the
    /// examples): α / α₁ isolates the applied scale.
    pub alpha_unscaled: f64,
    /// The α the energy assigns to the true scaled target (optimal cluster
    /// rotations and scale, same example ℓ*): the estimator's own value.
    pub alpha_oracle: f64,
    /// The same with one rotation per vertex (classic ARAP): how far the
    /// truth is from a scaled isometry of ℓ*.
    pub alpha_vertex_oracle: f64,
    /// Area of the scaled truth.
    pub area: f64,
}

fn scaled(points: &[Point], s: f64) -> Vec<Point> {
    let c = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / points.len() as f64;
    points
        .iter()
        .map(|p| Point::from(c + s * (p.coords - c)))
        .collect()
}

/// Figs. 4–5: `vertices` vertex-position constraints on the target scaled
/// by `scale` about its centroid.
pub fn scale(shapes: &ClassShapes, o: &FbtOptions, seed: u64) -> Result<ScaleOutcome> {
    let s = o.scale;
    let t = Instant::now();
    let reg = FbtRegistrar::build(&shapes.examples, &shapes.rig_shapes(o), o, seed)?;
    let seconds_precompute = t.elapsed().as_secs_f64();
    let target = shapes
        .target
        .with_vertices(scaled(shapes.target.vertices(), s))?;
    let verts = feature_points(shapes.reference(), o.vertices, seed)?;
    let rows = vertex_rows(&verts);
    let t = Instant::now();
    let sys = reg.setup.pipeline.systems(&rows, &reg.params)?;
    let fit = sys.solve(&apply_rows(&rows, target.vertices())?, &Schedule::default())?;
    let seconds_solve = t.elapsed().as_secs_f64();
    let alpha_unscaled = sys
        .solve(
            &apply_rows(&rows, shapes.target.vertices())?,
            &Schedule::default(),
        )?
        .alpha;
    let graph = &reg.setup.graph;
    let clusters = reg.setup.pipeline.main().clusters();
    let (alpha_oracle, _) = graph.best_scale(fit.example, target.vertices(), clusters)?;
    let per_vertex: Vec<usize> = (0..target.n_vertices()).collect();
    let (alpha_vertex_oracle, _) = graph.best_scale(fit.example, target.vertices(), &per_vertex)?;
    Ok(ScaleOutcome {
        seconds_precompute,
        seconds_solve,
        n_constraints: rows.len(),
        dict_size: reg.setup.sizes.1,
        alpha: fit.alpha,
        alpha_unscaled,
        alpha_oracle,
        alpha_vertex_oracle,
        positions: fit.positions,
        area: reg.area() * s * s,
        scaled_target: target,
    })
}

/// Fig. 3: automatic correspondence within an ambiguous feature group.
#[derive(Clone, Debug)]
pub struct PermutationOutcome {
    pub seconds_solve: f64,
    /// Whether the minimal-energy assignment is the true one.
    pub correct: bool,
    /// Assignments with a lower energy than the true one.
    pub rank: usize,
    /// Assignments tried (`group!`).
    pub count: usize,
    pub positions: Vec<Point>,
    pub area: f64,
}

/// Fig. 3: the first `group` features are ambiguous; the assignment with
/// minimal E_mn among all `group!` is kept.
pub fn permutation(shapes: &ClassShapes, o: &FbtOptions, seed: u64) -> Result<PermutationOutcome> {
    let reg = FbtRegistrar::build(&shapes.examples, &shapes.rig_shapes(o), o, seed)?;
    let k = o.group;
    let circles = o.full_target_features();
    let (rows, y) = reg.feature_constraints(&circles, &shapes.target)?;
    let group = feature_row_groups(k, circles.circles);
    let t = Instant::now();
    let sys = reg.setup.pipeline.systems(&rows, &reg.params)?;
    let search = best_permutation(&sys, &y, &group, &Schedule::default())?;
    let seconds_solve = t.elapsed().as_secs_f64();
    let identity: Vec<usize> = (0..k).collect();
    let e_true = search
        .energies
        .iter()
        .find(|(p, _)| *p == identity)
        .map(|e| e.1)
        .ok_or_else(|| Error::invalid("identity assignment missing"))?;
    Ok(PermutationOutcome {
        seconds_solve,
        correct: search.best == identity,
        rank: search.energies.iter().filter(|e| e.1 < e_true).count(),
        count: search.energies.len(),
        positions: search.registration.positions,
        area: reg.area(),
    })
}

/// Fig. 3: the blend of two registrations.
#[derive(Clone, Debug)]
pub struct InterpolationOutcome {
    /// Largest distortion of the blend's endpoints from the registrations
    /// (√area units); only when both chose the same example ℓ* (otherwise
    /// the blend is an average-energy global step).
    pub endpoint_error: Option<f64>,
    /// Blend parameters s.
    pub s: Vec<f64>,
    /// ARAP energy of the blend at each s, and of the linear blend.
    pub arap: Vec<f64>,
    pub arap_linear: Vec<f64>,
    /// The blend at s = ½.
    pub middle: Vec<Point>,
}

/// Fig. 3: registers the target and `second`, blends at s ∈ {0, ¼, ½, ¾,
/// 1} (rotations slerped per example), against the linear blend.
pub fn interpolation(
    shapes: &ClassShapes,
    second: &Mesh,
    o: &FbtOptions,
    seed: u64,
) -> Result<InterpolationOutcome> {
    let reg = FbtRegistrar::build(&shapes.examples, &shapes.rig_shapes(o), o, seed)?;
    let area = reg.area();
    let circles = o.full_target_features();
    let (rows, ya) = reg.feature_constraints(&circles, &shapes.target)?;
    let (_, yb) = reg.feature_constraints(&circles, second)?;
    let sys = reg.setup.pipeline.systems(&rows, &reg.params)?;
    let a = sys.solve(&ya, &Schedule::default())?;
    let b = sys.solve(&yb, &Schedule::default())?;
    let last = sys.last();
    let at =
        |s: f64| -> Result<Vec<Point>> { last.positions(&interpolate(last, &a, &b, &ya, &yb, s)?) };
    let endpoint_error = if a.example == b.example {
        let e0 = metrics::relative_distortion(&at(0.0)?, &a.positions, area)?;
        let e1 = metrics::relative_distortion(&at(1.0)?, &b.positions, area)?;
        Some(metrics::max(&e0).max(metrics::max(&e1)))
    } else {
        None
    };
    let reference = shapes.reference();
    let ss = vec![0.0, 0.25, 0.5, 0.75, 1.0];
    let (mut arap, mut arap_linear, mut middle) = (Vec::new(), Vec::new(), Vec::new());
    for &s in &ss {
        let p = at(s)?;
        let l: Vec<Point> = a
            .positions
            .iter()
            .zip(&b.positions)
            .map(|(x, y)| Point::from(x.coords * (1.0 - s) + y.coords * s))
            .collect();
        arap.push(arap_energy(reference, &p)?.1);
        arap_linear.push(arap_energy(reference, &l)?.1);
        if s == 0.5 {
            middle = p;
        }
    }
    Ok(InterpolationOutcome {
        endpoint_error,
        s: ss,
        arap,
        arap_linear,
        middle,
    })
}

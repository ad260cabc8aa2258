//! Shape completion and partial registration (FBT Figs. 6–8): one
//! `CompletionProblem`, solved by FBT, Der et al. or Amberg et al.
//!
//! A [`CompletionProblem`] is built once from the examples (reference
//! first), the full target and the feature options: feature points on the
//! target, the partial target that keeps them ([`make_partial`]), the
//! geodesic-circle constraints between the reference and the partial target
//! (`H` rows and `Y`) and the √area unit of every measure. Every
//! [`CompletionSolver`] solves that same problem and returns a
//! [`CompletionOutcome`]: the completed shape and what was measured on the
//! way, as plain values.
//!
//! [`FbtOptions`] holds the options of the FBT experiments (paper 001,
//! Sec. 5) and their defaults, once.

use std::time::Instant;

use nalgebra::DMatrix;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::baselines::{amberg_nicp, AmbergOptions, DerModel, DerOptions};
use crate::data::partial::{feature_points, make_partial, PartialOptions, PartialShape};
use crate::mesh::Mesh;
use crate::ops::Operators;
use crate::register::{
    apply_rows, build_with_rig, circle_radii, feature_circle_constraints, metrics, nicp,
    ClusterSource, ConstraintRows, DictionaryExamples, FbtConfig, FbtParams, InitMethod,
    NicpOptions, ScaleMode, Schedule, StageConfig, WeightChoice,
};
use crate::skin::rigging::RigOptions;
use crate::{Error, Point, Result};

/// Feature points and their geodesic circles (FBT Sec. 5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureOptions {
    /// Feature points.
    pub features: usize,
    /// Geodesic circles per feature.
    pub circles: usize,
    /// Largest circle radius relative to √area.
    pub radius: f64,
}

impl Default for FeatureOptions {
    fn default() -> Self {
        FeatureOptions {
            features: 8,
            circles: 10,
            radius: 0.15,
        }
    }
}

impl FeatureOptions {
    /// Feature-circle constraints between `reference` (vertex `f`) and
    /// `target` (vertex `g`) for the pairs `(f, g)`; `area` is the area of
    /// which √area scales the radii.
    pub fn constraints(
        &self,
        reference: &Mesh,
        target: &Mesh,
        pairs: &[(usize, usize)],
        area: f64,
    ) -> Result<(ConstraintRows, DMatrix<f64>)> {
        let radii = circle_radii(self.circles, self.radius * area.sqrt());
        feature_circle_constraints(reference, target, pairs, &radii)
    }
}

/// The options of the FBT experiments, every default in one place (the
/// harness's `[methods.fbt]` table resolves to this).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FbtOptions {
    /// Number of example shapes.
    pub q: usize,
    /// LBO eigenfunctions of the main stage (and of the `projection`
    /// dictionary).
    pub m: usize,
    /// Bones of the skeleton weights (`None`: chosen by the data, see
    /// [`crate::skin::rigging::RigOptions`]).
    pub bones: Option<usize>,
    /// Where the skeleton weights are learnt from (see [`RigSource`]).
    pub rig: RigSource,
    /// With `rig = RigSource::Class`: how many shapes of the class besides
    /// the reference and the target (the same for every q).
    pub rig_poses: usize,
    /// Stages and clusters (see [`PipelineKind`]; the configs' and
    /// Python's unset `pipeline` is [`PipelineKind::default_for`] the rig).
    pub pipeline: PipelineKind,
    /// Rotation clusters r.
    pub clusters: usize,
    /// Scale applied to the target (`scale` task).
    pub scale: f64,
    /// Fixed global scale α (Fig. 8 C); `None`: α is optimised.
    pub alpha: Option<f64>,
    /// Examples of the dictionary atoms: all q (the paper) or the reference
    /// only with the atom count of the example-based dictionary (Fig. 8 A).
    pub dictionary_examples: DictionaryExamples,
    /// Examples of the ARAP energy: all q (the paper) or the reference only
    /// (Fig. 8 B).
    pub arap_examples: DictionaryExamples,
    /// Feature points and circles of the `completion` and `timing` tasks.
    pub features: FeatureOptions,
    /// Largest circle radius (relative to √area) of the tasks whose target
    /// is a full shape (`permutation`, `interpolation`).
    pub full_target_radius: f64,
    /// Vertex-position constraints of the `scale` task.
    pub vertices: usize,
    /// Run NICP after the feature registration (`completion`).
    pub nicp: bool,
    /// NICP iterations.
    pub nicp_iterations: usize,
    /// Size of the ambiguous feature group (`permutation`).
    pub group: usize,
    /// Timing repetitions (`timing`).
    pub repeats: usize,
    /// Correspondence queries per case (Kim et al. curve).
    pub queries: usize,
    /// Remedies against gross failures of FBT's completion.
    pub restarts: RestartOptions,
}

impl Default for FbtOptions {
    fn default() -> Self {
        let config = FbtConfig::default();
        let (q, rig_poses) = (4, 4);
        FbtOptions {
            q,
            m: 10,
            bones: config.rig.bones,
            rig: RigSource::default(),
            rig_poses,
            pipeline: PipelineKind::default_for(RigSource::default().shape_count(q, rig_poses)),
            clusters: config.clusters,
            scale: 1.5,
            alpha: None,
            dictionary_examples: DictionaryExamples::All,
            arap_examples: DictionaryExamples::All,
            features: FeatureOptions::default(),
            full_target_radius: 0.1,
            vertices: 20,
            nicp: true,
            nicp_iterations: 10,
            group: 4,
            repeats: 5,
            queries: 300,
            restarts: RestartOptions::default(),
        }
    }
}

impl FbtOptions {
    /// The energy parameters (α fixed when `alpha` is set).
    pub fn params(&self) -> FbtParams {
        let mut p = FbtParams::default();
        if let Some(a) = self.alpha {
            p.scale = ScaleMode::Fixed(a);
        }
        p
    }

    /// The example-based skinning of the skeleton weights (`bones`, the
    /// library's defaults otherwise).
    pub fn rig_options(&self) -> RigOptions {
        RigOptions {
            bones: self.bones,
            ..RigOptions::default()
        }
    }

    /// The pipeline configuration of the solving tasks.
    pub fn config(&self, seed: u64) -> FbtConfig {
        let base = self.pipeline.config();
        let mut c = FbtConfig {
            seed,
            rig: self.rig_options(),
            ..base
        };
        c.main.weights = WeightChoice::Lbo { m: self.m };
        c.clusters = self.clusters;
        match self.dictionary_examples {
            DictionaryExamples::All => {}
            DictionaryExamples::First => {
                // Every stage from the reference only, with the atom count
                // of the example-based stage: (1 + 3q)·m = 4·m′.
                let q = self.q as f64;
                let one = |s: &StageConfig| -> StageConfig {
                    let m = match s.weights {
                        WeightChoice::Lbo { m } => m,
                        // The skeleton stage becomes the LBO-only
                        // pipeline's rich stage (m = 15).
                        WeightChoice::Skeleton => 15,
                        WeightChoice::Biharmonic { .. } => 10,
                    };
                    StageConfig {
                        weights: WeightChoice::Lbo {
                            m: (((1.0 + 3.0 * q) * m as f64) / 4.0).round() as usize,
                        },
                        examples: DictionaryExamples::First,
                        reduce: s.reduce,
                    }
                };
                c.init = c.init.as_ref().map(one);
                c.main = one(&c.main);
                c.rich = c.rich.as_ref().map(one);
            }
        }
        c.arap_examples = self.arap_examples;
        c
    }

    /// The feature circles of the tasks with a full target (`permutation`,
    /// `interpolation`): radius `full_target_radius`.
    pub fn full_target_features(&self) -> FeatureOptions {
        FeatureOptions {
            radius: self.full_target_radius,
            ..self.features
        }
    }

    /// NICP options (`nicp_iterations`, sample placement seeded by `seed`).
    pub fn nicp_options(&self, seed: u64) -> NicpOptions {
        NicpOptions {
            iterations: self.nicp_iterations,
            seed,
            ..NicpOptions::default()
        }
    }
}

/// One shape completion problem: a partial target with feature points, the
/// feature-circle constraints to the reference example, and the truth.
#[derive(Clone, Debug)]
pub struct CompletionProblem {
    examples: Vec<Mesh>,
    /// Shapes the skeleton weights are learnt from (default: the examples
    /// but the reference).
    rig: Vec<Mesh>,
    target: Mesh,
    features: Vec<usize>,
    partial: PartialShape,
    rows: ConstraintRows,
    y: DMatrix<f64>,
    area: f64,
    seed: u64,
}

/// The reference (first example) of a completion problem and its (Voronoi)
/// area, whose square root is the unit of every measure, as FBT's
/// `ArapGraph::area`.
fn reference_and_area(examples: &[Mesh]) -> Result<(&Mesh, f64)> {
    let reference = examples
        .first()
        .ok_or_else(|| Error::invalid("a completion problem needs an example"))?;
    Ok((reference, reference.mass_area()))
}

impl CompletionProblem {
    /// The completion of the full `target` (its vertices in correspondence
    /// with the examples': truth vertex `i` ↔ vertex `i`) from `examples`
    /// (reference first): `features.features` farthest-point feature points
    /// of the target (seed `seed`), a partial target keeping them
    /// ([`make_partial`] with default options and seed `seed`), and
    /// `features.circles` geodesic circles per feature up to
    /// `features.radius · √area`, where the area is the reference's
    /// (Voronoi) area — the unit of every measure.
    pub fn new(
        examples: &[Mesh],
        target: &Mesh,
        features: &FeatureOptions,
        seed: u64,
    ) -> Result<Self> {
        let (reference, area) = reference_and_area(examples)?;
        let feats = feature_points(target, features.features, seed)?;
        let partial = make_partial(
            target,
            &feats,
            &PartialOptions {
                seed,
                ..Default::default()
            },
        )?;
        let pairs: Vec<(usize, usize)> = feats
            .iter()
            .zip(&partial.features)
            .map(|(&f, &g)| (f, g))
            .collect();
        let (rows, y) = features.constraints(reference, &partial.mesh, &pairs, area)?;
        Ok(CompletionProblem {
            examples: examples.to_vec(),
            rig: examples[1..].to_vec(),
            target: target.clone(),
            features: feats,
            partial,
            rows,
            y,
            area,
            seed,
        })
    }

    /// The completion of a given partial target (any connectivity, no
    /// ground truth) from `examples` (reference first), with the feature
    /// pairs `(reference vertex, partial-target vertex)` and
    /// `features.circles` geodesic circles per pair up to
    /// `features.radius · √area` (`features.features` is not used: the pairs
    /// are given). Every [`CompletionSolver`] solves it as it solves
    /// [`CompletionProblem::new`]'s. Without a truth, [`Self::target`] is
    /// the partial target itself (its `vertex_map` the identity), so
    /// [`Self::distortion`] and [`Self::correspondences`] measure nothing
    /// meaningful: use the completed positions directly (the Python
    /// binding's `complete`).
    pub fn from_partial(
        examples: &[Mesh],
        partial: &Mesh,
        pairs: &[(usize, usize)],
        features: &FeatureOptions,
        seed: u64,
    ) -> Result<Self> {
        let (reference, area) = reference_and_area(examples)?;
        if pairs.is_empty() {
            return Err(Error::invalid(
                "a completion problem needs at least one feature pair",
            ));
        }
        for (k, &(f, g)) in pairs.iter().enumerate() {
            if f >= reference.n_vertices() || g >= partial.n_vertices() {
                return Err(Error::invalid(format!(
                    "feature pair {k} ({f}, {g}) out of range: the reference has {} vertices, \
                     the partial target {}",
                    reference.n_vertices(),
                    partial.n_vertices()
                )));
            }
        }
        let (rows, y) = features.constraints(reference, partial, pairs, area)?;
        let g: Vec<usize> = pairs.iter().map(|p| p.1).collect();
        let shape = PartialShape {
            mesh: partial.clone(),
            vertex_map: (0..partial.n_vertices()).collect(),
            features: g.clone(),
            features_full: g,
            area_fraction: 1.0,
            n_components: partial.component_count(),
            removals: 0,
        };
        Ok(CompletionProblem {
            examples: examples.to_vec(),
            rig: examples[1..].to_vec(),
            target: partial.clone(),
            features: pairs.iter().map(|p| p.1).collect(),
            partial: shape,
            rows,
            y,
            area,
            seed,
        })
    }

    /// The examples (reference first).
    pub fn examples(&self) -> &[Mesh] {
        &self.examples
    }

    /// The problem with the skeleton weights learnt from `rig` (other poses
    /// of the class, never the target; see [`crate::register::build_with_rig`]).
    pub fn with_rig_shapes(mut self, rig: Vec<Mesh>) -> Self {
        self.rig = rig;
        self
    }

    /// The shapes the skeleton weights are learnt from.
    pub fn rig_shapes(&self) -> &[Mesh] {
        &self.rig
    }

    /// The reference example (the template that is deformed).
    pub fn reference(&self) -> &Mesh {
        &self.examples[0]
    }

    /// The full target (the truth).
    pub fn target(&self) -> &Mesh {
        &self.target
    }

    /// The feature points (vertices of the full target).
    pub fn features(&self) -> &[usize] {
        &self.features
    }

    /// The partial target and its map to the full one.
    pub fn partial(&self) -> &PartialShape {
        &self.partial
    }

    /// The constraint rows `H` (reference vertices).
    pub fn rows(&self) -> &ConstraintRows {
        &self.rows
    }

    /// The constraint targets `Y` (h × 3, on the partial target).
    pub fn y(&self) -> &DMatrix<f64> {
        &self.y
    }

    /// `(H rows, Y)`.
    pub fn constraints(&self) -> (&ConstraintRows, &DMatrix<f64>) {
        (&self.rows, &self.y)
    }

    /// The reference's (Voronoi) area; √area is the unit of every measure.
    pub fn area(&self) -> f64 {
        self.area
    }

    /// The seed of the features, the partial target and the queries.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Relative distortion `‖p_i − p_true,i‖ / √area` per template vertex.
    pub fn distortion(&self, positions: &[Point]) -> Result<Vec<f64>> {
        metrics::relative_distortion(positions, self.target.vertices(), self.area)
    }

    /// Correspondences (Kim et al.): `queries` partial-target vertices
    /// (at most all; drawn with the problem's seed, in index order) are
    /// matched to the nearest vertex of the registered template `positions`.
    /// Returns `(predicted, truth)` vertices of the full target.
    pub fn correspondences(
        &self,
        positions: &[Point],
        queries: usize,
    ) -> Result<(Vec<usize>, Vec<usize>)> {
        let mesh = &self.partial.mesh;
        let nq = queries.min(mesh.n_vertices());
        let mut idx: Vec<usize> = (0..mesh.n_vertices()).collect();
        idx.shuffle(&mut ChaCha8Rng::seed_from_u64(self.seed));
        idx.truncate(nq);
        idx.sort_unstable();
        let points: Vec<Point> = idx.iter().map(|&i| mesh.vertices()[i]).collect();
        let predicted: Vec<usize> = metrics::nearest_points(&points, positions)?
            .into_iter()
            .map(|(v, _)| v)
            .collect();
        let truth: Vec<usize> = idx.iter().map(|&i| self.partial.vertex_map[i]).collect();
        Ok((predicted, truth))
    }
}

/// FBT's completion: feature registration with blended transformations
/// (the paper's schedule), then FBT's NICP.
#[derive(Clone, Debug)]
pub struct FbtCompletion {
    pub config: FbtConfig,
    pub params: FbtParams,
    pub schedule: Schedule,
    /// NICP after the feature registration (`None`: none).
    pub nicp: Option<NicpOptions>,
    /// Remedies tried when the first attempt looks like a gross failure.
    pub restarts: RestartOptions,
}

/// Remedies against gross failures of FBT's completion (a limb or the torso
/// misplaced). The first attempt is the paper's procedure. When its
/// *partial residual* — the mean distance from the partial target's
/// vertices to the nearest vertex of the completed shape, over √area, a
/// measure that needs no ground truth — exceeds `suspicious_residual`, the
/// alternatives are solved too and the attempt with the lowest partial
/// residual is kept:
///
/// 1. `aligned`: the partial target (and the constraint targets) rigidly
///    pre-aligned onto the reference by the feature constraints
///    (Kabsch on `Y` against `H V_ref`), solved there, the result mapped
///    back;
/// 2. `linear`: the initial transformations from Eq. 22 (least squares)
///    instead of the elastic net (Eq. 23);
/// 3. `aligned_linear`: both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestartOptions {
    /// Partial residual (√area units) above which the alternatives run;
    /// `0` always runs them, `f64::INFINITY` never.
    pub suspicious_residual: f64,
}

/// Default [`RestartOptions::suspicious_residual`] (√area units).
pub const DEFAULT_SUSPICIOUS_RESIDUAL: f64 = 0.02;

impl Default for RestartOptions {
    fn default() -> Self {
        RestartOptions {
            suspicious_residual: DEFAULT_SUSPICIOUS_RESIDUAL,
        }
    }
}

/// One FBT completion attempt (see [`RestartOptions`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Attempt {
    Paper,
    Aligned,
    Linear,
    AlignedLinear,
}

impl Attempt {
    const ALL: [Attempt; 4] = [
        Attempt::Paper,
        Attempt::Aligned,
        Attempt::Linear,
        Attempt::AlignedLinear,
    ];

    fn name(self) -> &'static str {
        match self {
            Attempt::Paper => "paper",
            Attempt::Aligned => "aligned",
            Attempt::Linear => "linear",
            Attempt::AlignedLinear => "aligned_linear",
        }
    }

    fn aligned(self) -> bool {
        matches!(self, Attempt::Aligned | Attempt::AlignedLinear)
    }

    fn linear(self) -> bool {
        matches!(self, Attempt::Linear | Attempt::AlignedLinear)
    }
}

/// Mean distance from `partial`'s vertices to the nearest of `positions`,
/// over √area (no ground truth needed).
pub fn partial_residual(partial: &Mesh, positions: &[Point], area: f64) -> Result<f64> {
    let near = metrics::nearest_points(partial.vertices(), positions)?;
    Ok(near.iter().map(|p| p.1).sum::<f64>() / near.len().max(1) as f64 / area.sqrt())
}

/// Der et al.'s reduced model on the FBT rotation clusters, in the same
/// procedure (feature registration, then NICP).
#[derive(Clone, Debug)]
pub struct DerCompletion {
    /// The FBT configuration whose rotation clusters Der et al. use.
    pub config: FbtConfig,
    pub options: DerOptions,
    pub nicp: Option<NicpOptions>,
}

/// The deformation model of a completion (FBT Fig. 7 baselines).
#[derive(Clone, Debug)]
pub enum CompletionSolver {
    /// Fast blended transformations (the paper).
    Fbt(FbtCompletion),
    /// Der, Sumner & Popović 2006 ([`crate::baselines::der`]).
    Der(DerCompletion),
    /// Amberg et al. 2007 optimal-step nonrigid ICP
    /// ([`crate::baselines::amberg`]) with the feature circles as landmarks.
    Amberg(AmbergOptions),
    /// The trivial floor: the template (reference example) left undeformed.
    Template,
}

/// What a [`CompletionSolver`] returns: the completed shape and the
/// quantities measured on the way (`None`: not applicable to the solver).
#[derive(Clone, Debug, PartialEq)]
pub struct CompletionOutcome {
    /// The deformed reference (the completed shape).
    pub positions: Vec<Point>,
    /// The feature registration before NICP.
    pub init_positions: Option<Vec<Point>>,
    /// Global scale α (after NICP when it ran).
    pub alpha: Option<f64>,
    /// Main dictionary size b.
    pub dict_size: Option<usize>,
    /// Rotation clusters.
    pub n_clusters: Option<usize>,
    /// Solver iterations.
    pub iterations: Option<usize>,
    /// A description of the deformation model when it is not FBT's
    /// dictionary.
    pub dictionary: Option<String>,
    /// Precomputation (s).
    pub seconds_precompute: Option<f64>,
    /// Feature registration (s).
    pub seconds_solve: Option<f64>,
    /// Nonrigid ICP (s).
    pub seconds_nicp: Option<f64>,
    /// Mean distance from the partial target to the result (√area units,
    /// [`partial_residual`]).
    pub partial_residual: Option<f64>,
    /// Attempts solved (FBT: 1 unless the first looked like a failure).
    pub attempts: Option<usize>,
    /// The attempt kept (see [`RestartOptions`]).
    pub attempt: Option<&'static str>,
}

impl CompletionOutcome {
    fn new(positions: Vec<Point>) -> Self {
        CompletionOutcome {
            positions,
            init_positions: None,
            alpha: None,
            dict_size: None,
            n_clusters: None,
            iterations: None,
            dictionary: None,
            seconds_precompute: None,
            seconds_solve: None,
            seconds_nicp: None,
            partial_residual: None,
            attempts: None,
            attempt: None,
        }
    }
}

impl CompletionSolver {
    /// FBT with the options' configuration, parameters and NICP (`seed`:
    /// clustering and NICP samples).
    pub fn fbt(opts: &FbtOptions, seed: u64) -> Self {
        CompletionSolver::Fbt(FbtCompletion {
            config: opts.config(seed),
            params: opts.params(),
            schedule: Schedule::default(),
            nicp: opts.nicp.then(|| opts.nicp_options(seed)),
            restarts: opts.restarts,
        })
    }

    /// Der et al. on the clusters of [`CompletionSolver::fbt`]'s
    /// configuration, with FBT's constraint weight β_lc.
    pub fn der(opts: &FbtOptions, seed: u64) -> Self {
        CompletionSolver::Der(DerCompletion {
            config: opts.config(seed),
            options: DerOptions {
                beta: opts.params().beta_lc,
                ..DerOptions::default()
            },
            nicp: opts.nicp.then(|| opts.nicp_options(seed)),
        })
    }

    /// Amberg et al. matching every template vertex, with the options'
    /// NICP rules.
    pub fn amberg(opts: &FbtOptions, seed: u64) -> Self {
        CompletionSolver::Amberg(AmbergOptions {
            icp: NicpOptions {
                samples: 0,
                ..opts.nicp_options(seed)
            },
            ..AmbergOptions::default()
        })
    }

    /// Solves `problem`.
    pub fn solve(&self, problem: &CompletionProblem) -> Result<CompletionOutcome> {
        let examples = problem.examples();
        let (rows, y) = (problem.rows(), problem.y());
        match self {
            CompletionSolver::Fbt(s) => {
                let t = Instant::now();
                let setup = build_with_rig(examples, problem.rig_shapes(), &s.config)?;
                let seconds_precompute = t.elapsed().as_secs_f64();
                let t = Instant::now();
                let sys = setup.pipeline.systems(rows, &s.params)?;
                let seconds_factorise = t.elapsed().as_secs_f64();
                let mut best: Option<FbtAttempt> = None;
                let mut attempts = 0;
                for a in Attempt::ALL {
                    if let Some(b) = &best {
                        if b.residual <= s.restarts.suspicious_residual {
                            break;
                        }
                    }
                    let r = s.attempt(a, &setup, &sys, problem)?;
                    attempts += 1;
                    if best.as_ref().is_none_or(|b| r.residual < b.residual) {
                        best = Some(r);
                    }
                }
                let b = best.ok_or_else(|| Error::invalid("no completion attempt ran"))?;
                Ok(CompletionOutcome {
                    init_positions: Some(b.init_positions),
                    alpha: Some(b.alpha),
                    dict_size: Some(setup.sizes.1),
                    n_clusters: Some(setup.pipeline.main().n_clusters()),
                    seconds_precompute: Some(seconds_precompute),
                    seconds_solve: Some(seconds_factorise + b.seconds_solve),
                    seconds_nicp: b.seconds_nicp,
                    partial_residual: Some(b.residual),
                    attempts: Some(attempts),
                    attempt: Some(b.attempt.name()),
                    ..CompletionOutcome::new(b.positions)
                })
            }
            CompletionSolver::Der(s) => {
                // The same rotation clusters as FBT: those of the FBT setup
                // of this configuration (not timed: it is FBT's).
                let setup = build_with_rig(examples, problem.rig_shapes(), &s.config)?;
                let t = Instant::now();
                let model = DerModel::new(examples, &setup.clusters)?;
                let seconds_precompute = t.elapsed().as_secs_f64();
                let dictionary = format!(
                    "Der et al. (weights of {} examples, {} clusters)",
                    model.n_examples(),
                    model.n_clusters()
                );
                let t = Instant::now();
                let prob = model.problem(rows, y, s.options.beta)?;
                let reg = model.register(&prob, &s.options)?;
                let seconds_solve = t.elapsed().as_secs_f64();
                let (positions, seconds_nicp) = match &s.nicp {
                    Some(icp) => {
                        let t = Instant::now();
                        let res = model.nicp(
                            (rows, y),
                            &problem.partial().mesh,
                            &reg.state,
                            icp,
                            &s.options,
                        )?;
                        (res.positions, Some(t.elapsed().as_secs_f64()))
                    }
                    None => (reg.positions.clone(), None),
                };
                Ok(CompletionOutcome {
                    init_positions: Some(reg.positions),
                    n_clusters: Some(model.n_clusters()),
                    iterations: Some(reg.iterations),
                    dictionary: Some(dictionary),
                    seconds_precompute: Some(seconds_precompute),
                    seconds_solve: Some(seconds_solve),
                    seconds_nicp,
                    ..CompletionOutcome::new(positions)
                })
            }
            CompletionSolver::Amberg(opts) => {
                let dictionary = format!(
                    "Amberg NICP (reference only, {} stiffness steps)",
                    opts.stiffness.len()
                );
                let t = Instant::now();
                let res = amberg_nicp(
                    problem.reference(),
                    &problem.partial().mesh,
                    (rows, y),
                    opts,
                )?;
                let seconds_nicp = t.elapsed().as_secs_f64();
                Ok(CompletionOutcome {
                    iterations: Some(res.steps.iter().map(|s| s.1).sum()),
                    dictionary: Some(dictionary),
                    seconds_nicp: Some(seconds_nicp),
                    ..CompletionOutcome::new(res.positions)
                })
            }
            CompletionSolver::Template => Ok(CompletionOutcome {
                dictionary: Some("template left undeformed (floor)".to_string()),
                ..CompletionOutcome::new(problem.reference().vertices().to_vec())
            }),
        }
    }
}

/// What one FBT completion attempt gave.
struct FbtAttempt {
    attempt: Attempt,
    positions: Vec<Point>,
    init_positions: Vec<Point>,
    alpha: f64,
    residual: f64,
    seconds_solve: f64,
    seconds_nicp: Option<f64>,
}

impl FbtCompletion {
    /// Feature registration and NICP of `problem` as attempt `a` (see
    /// [`RestartOptions`]); positions in the partial target's frame.
    fn attempt(
        &self,
        a: Attempt,
        setup: &crate::register::FbtSetup,
        sys: &crate::register::PipelineSystems,
        problem: &CompletionProblem,
    ) -> Result<FbtAttempt> {
        let (rows, y0) = problem.constraints();
        let partial0 = &problem.partial().mesh;
        // Rigid pre-alignment of the target onto the reference by the
        // constraints: Y's rows against H V_ref.
        let motion = if a.aligned() {
            let at_ref = apply_rows(rows, problem.reference().vertices())?;
            let pts = |m: &DMatrix<f64>| -> Vec<Point> {
                (0..m.nrows())
                    .map(|r| Point::new(m[(r, 0)], m[(r, 1)], m[(r, 2)]))
                    .collect()
            };
            Some(crate::eval::procrustes(&pts(y0), &pts(&at_ref))?)
        } else {
            None
        };
        let (y, partial) = match &motion {
            Some(m) => {
                // Rows of H are weighted averages (weights summing to one),
                // so a rigid motion of the target moves Y the same way.
                let y = DMatrix::from_fn(y0.nrows(), 3, |r, c| {
                    m.apply(&Point::new(y0[(r, 0)], y0[(r, 1)], y0[(r, 2)]))[c]
                });
                (y, partial0.map_vertices(|p| m.apply(p))?)
            }
            None => (y0.clone(), partial0.clone()),
        };
        let schedule = if a.linear() {
            Schedule {
                init: InitMethod::Linear,
                ..self.schedule
            }
        } else {
            self.schedule
        };
        let t = Instant::now();
        let reg = sys.solve(&y, &schedule)?;
        let seconds_solve = t.elapsed().as_secs_f64();
        let mut alpha = reg.alpha;
        let (positions, seconds_nicp) = match &self.nicp {
            Some(icp) => {
                let t = Instant::now();
                let res = nicp(
                    setup.pipeline.last(),
                    &self.params,
                    (rows, &y),
                    &partial,
                    &reg.t,
                    reg.alpha,
                    icp,
                )?;
                alpha = res.alpha;
                (res.positions, Some(t.elapsed().as_secs_f64()))
            }
            None => (reg.positions.clone(), None),
        };
        let back = |p: Vec<Point>| -> Vec<Point> {
            match &motion {
                Some(m) => {
                    let rt = m.rotation.transpose();
                    p.iter()
                        .map(|q| Point::from(rt * (q.coords - m.translation)))
                        .collect()
                }
                None => p,
            }
        };
        let positions = back(positions);
        let residual = partial_residual(partial0, &positions, problem.area())?;
        Ok(FbtAttempt {
            attempt: a,
            positions,
            init_positions: back(reg.positions),
            alpha,
            residual,
            seconds_solve,
            seconds_nicp,
        })
    }
}

/// Dictionary of the `projection` task and of the main stage.
#[derive(Clone, Copy, Debug, Default, serde::Deserialize, serde::Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum DictionaryKind {
    /// Example-based LBO dictionary (the paper's main choice).
    #[default]
    Lbo,
    /// Example-based skeleton dictionary (bone weights of example-based
    /// skinning, [`crate::skin::rigging`]).
    Skeleton,
    /// LBO atoms of the reference example only, with as many atoms as the
    /// example-based LBO dictionary of the same q and m (Table 2, Fig. 8 A).
    OneExample,
}

/// Where the skeleton weights (example-based skinning of the reference)
/// are learnt from.
#[derive(Clone, Copy, Debug, Default, serde::Deserialize, serde::Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RigSource {
    /// The q examples only (the reference against the q − 1 others): what
    /// the method is given. At q = 1 there is no pose to learn bones from,
    /// so a pipeline that uses the skeleton refuses q = 1.
    #[default]
    Examples,
    /// The examples and further shapes of the class (never the target):
    /// the first `rig_poses` shapes besides the reference in draw order,
    /// the same rig for every q. More data than the q examples: an
    /// explicit option, not the paper's setting.
    Class,
}

impl RigSource {
    /// The name in configs.
    pub fn name(self) -> &'static str {
        match self {
            RigSource::Examples => "examples",
            RigSource::Class => "class",
        }
    }

    /// How many shapes besides the reference the rig is learnt from with
    /// `q` examples and `rig_poses` class shapes (at most: a small class
    /// may have fewer).
    pub fn shape_count(self, q: usize, rig_poses: usize) -> usize {
        match self {
            RigSource::Examples => q.saturating_sub(1),
            RigSource::Class => rig_poses,
        }
    }
}

/// Shapes besides the reference a rig must be learnt from before the
/// default pipeline uses its clusters ([`PipelineKind::default_for`]).
pub const MIN_RIG_SHAPES: usize = 3;

/// The solving pipeline of the FBT tasks. The default is chosen per case
/// by [`PipelineKind::default_for`]: the skeleton clusters
/// ([`PipelineKind::SkeletonClusters`], the default value) when the rig has
/// [`MIN_RIG_SHAPES`] shapes, else LBO only.
#[derive(Clone, Copy, Debug, Default, serde::Deserialize, serde::Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PipelineKind {
    /// The paper's articulated-shape pipeline: last stage the example-based
    /// skeleton dictionary, rotation clusters from the skeleton weights
    /// (k-means of them, `clusters` = r; [`FbtConfig::default`]).
    Skeleton,
    /// LBO only: last stage LBO m = 15, clusters from the main LBO weights
    /// ([`FbtConfig::lbo_only`]).
    Lbo,
    /// Ablation: the skeleton dictionary as the last stage, the rotation
    /// clusters of the LBO-only pipeline (k-means of the main LBO weights).
    SkeletonDictionary,
    /// The LBO-only pipeline's stages with the paper's rotation clusters
    /// (k-means of the skeleton weights): the skeleton weights where they
    /// help. The default with a rig of [`MIN_RIG_SHAPES`] shapes.
    #[default]
    SkeletonClusters,
}

impl PipelineKind {
    /// Every pipeline, in the order of the docs.
    pub const ALL: [PipelineKind; 4] = [
        PipelineKind::Skeleton,
        PipelineKind::Lbo,
        PipelineKind::SkeletonDictionary,
        PipelineKind::SkeletonClusters,
    ];

    /// The name in configs and tables.
    pub fn name(self) -> &'static str {
        match self {
            PipelineKind::Skeleton => "skeleton",
            PipelineKind::Lbo => "lbo",
            PipelineKind::SkeletonDictionary => "skeleton_dictionary",
            PipelineKind::SkeletonClusters => "skeleton_clusters",
        }
    }

    /// The pipeline of this kind (before the options' m, r, rig and seed).
    pub fn config(self) -> FbtConfig {
        match self {
            PipelineKind::Skeleton => FbtConfig::default(),
            PipelineKind::Lbo => FbtConfig::lbo_only(),
            PipelineKind::SkeletonDictionary => FbtConfig {
                cluster_source: ClusterSource::MainWeights,
                ..FbtConfig::default()
            },
            PipelineKind::SkeletonClusters => FbtConfig {
                cluster_source: ClusterSource::SkeletonWeights,
                ..FbtConfig::lbo_only()
            },
        }
    }

    /// The default pipeline for a rig learnt from `rig_shapes` shapes
    /// besides the reference: [`PipelineKind::default`] (the skeleton
    /// clusters over the LBO stages) when there are at least
    /// [`MIN_RIG_SHAPES`], else the LBO-only pipeline. Chosen by the FBT
    /// benchmark (docs/fbt-benchmark.md): a rig learnt from one other shape
    /// (q = 2) makes clusters that complete worse than the LBO ones on the
    /// synthetic class, the cat and the centaur; from three or more (q ≥ 4)
    /// the skeleton clusters complete better on every class. Cases record
    /// the pipeline that ran in their `pipeline` column.
    pub fn default_for(rig_shapes: usize) -> Self {
        let d = PipelineKind::default();
        if d.uses_skeleton() && rig_shapes < MIN_RIG_SHAPES {
            PipelineKind::Lbo
        } else {
            d
        }
    }

    /// The pipeline named `name` (see [`Self::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Whether the pipeline needs a rig (skeleton weights).
    pub fn uses_skeleton(self) -> bool {
        self.config().uses_skeleton()
    }
}

/// Which examples the ARAP energy compares against.
#[derive(Clone, Copy, Debug, Default, serde::Deserialize, serde::Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CompareWith {
    /// All q examples (the paper).
    #[default]
    All,
    /// Only the reference example (Fig. 8 B).
    First,
}

/// The deformation model of the `completion` task (FBT Fig. 7 baselines).
#[derive(Clone, Copy, Debug, Default, serde::Deserialize, serde::Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SolverKind {
    /// Fast blended transformations (the paper).
    #[default]
    Fbt,
    /// Der, Sumner & Popović 2006 on the FBT rotation clusters
    /// ([`crate::baselines::der`]), in the same completion procedure.
    Der,
    /// Amberg et al. 2007 optimal-step nonrigid ICP
    /// ([`crate::baselines::amberg`]) with the feature circles as landmarks.
    Amberg,
    /// The template (reference example) left undeformed: the floor every
    /// completion result must beat.
    Template,
}

impl SolverKind {
    /// The name in configs.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Fbt => "fbt",
            SolverKind::Der => "der",
            SolverKind::Amberg => "amberg",
            SolverKind::Template => "template",
        }
    }
}

impl CompletionSolver {
    /// The solver of `kind` with the options `opts` (and `seed`).
    pub fn new(kind: SolverKind, opts: &FbtOptions, seed: u64) -> Self {
        match kind {
            SolverKind::Fbt => CompletionSolver::fbt(opts, seed),
            SolverKind::Der => CompletionSolver::der(opts, seed),
            SolverKind::Amberg => CompletionSolver::amberg(opts, seed),
            SolverKind::Template => CompletionSolver::Template,
        }
    }
}

//! The schema of a configured method: the keys of a `[[methods]]` entry
//! (and of `[defaults]`), each with its range, shared by the experiment
//! configs, `deformlab transfer --method` and the Python binding. Which
//! keys a kind uses, and how an entry becomes a library value, is the
//! registry ([`super::registry`]).

use serde::{Deserialize, Serialize};

use crate::methods::completion::{
    CompareWith, DictionaryKind, FbtOptions, FeatureOptions, PipelineKind, RestartOptions,
    RigSource, SolverKind,
};
use crate::methods::{Examples, Pool, Strategy, TargetCorrespondence};
use crate::ops::FpsMetric;
use crate::range::{Int, NonNegative, OpenUnitInterval, Real, ScaleFactor, UnitInterval};
use crate::register::DictionaryExamples;
use crate::skin::bbw::WeightMode;
use crate::skin::FeatureKind;
use crate::transfer::{ErrorNorm, FrameAlign, SelectionMode, TargetWeights, TransferFrame};

/// Method kinds.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MethodKind {
    /// BDT with automatically selected key points (Algorithm 1).
    #[default]
    Bdt,
    /// BDT with random key points (simulated user).
    BdtRandom,
    /// BDT with key points at geodesic extremities (simulated user).
    BdtExtremity,
    /// Rotation-group clustering only (BDT Fig. 4), scored against labels.
    Clustering,
    /// FBT registration experiments ([`super::fbt`]).
    Fbt,
    /// Sumner & Popović deformation transfer with the automatic BDT key
    /// points as correspondence markers ([`super::baselines`]).
    Sumner,
    /// Sumner & Popović deformation transfer with the identity triangle
    /// correspondence (shared connectivity only).
    SumnerOracle,
    /// Cage-based spatial deformation transfer with the automatic BDT key
    /// points as markers ([`crate::baselines::cage`]).
    Cage,
    /// The target left unchanged (`B′ = B`): the floor of every transfer
    /// evaluation.
    Identity,
}

/// Range of `n_candidates` (and `--candidates` of `keypoints` / `transfer`);
/// at most the source's vertex count, checked once the dataset is open.
pub type NCandidates = Int<1, 100_000>;
/// Range of `max_keypoints` (and `--max-keypoints`).
pub type MaxKeypoints = Int<1, 1000>;
/// Range of `epsilon` (and `--epsilon`), unit-sphere units.
pub type Epsilon = Real<NonNegative>;

macro_rules! pipeline_struct {
    ($(#[$m:meta])* pub struct $name:ident { $($(#[$fm:meta])* pub $f:ident : $t:ty,)* }) => {
        $(#[$m])*
        #[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            $($(#[$fm])* pub $f: $t,)*
            /// FPS candidates n_c (default 100).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "NCandidates::de")]
            pub n_candidates: Option<usize>,
            /// Seed of FPS, k-means, random picks (default: the config seed).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub seed: Option<u64>,
            /// Stage-1 threshold ε (default 0.03).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Epsilon::de")]
            pub epsilon: Option<f64>,
            /// `mean` (default: the mean per-vertex distance), `paper` (Eq. 22
            /// literally) or `rms` ([`ErrorNorm`]).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub error_norm: Option<ErrorNorm>,
            /// Upper bound on the key points (default 30).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "MaxKeypoints::de")]
            pub max_keypoints: Option<usize>,
            /// `fast` (default) or `exact` ([`SelectionMode`]).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub mode: Option<SelectionMode>,
            /// `geodesic` (default) or `euclidean`.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub fps: Option<FpsMetric>,
            /// Rotation-group features (default `augmented`).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub groups: Option<FeatureKind>,
            /// γ_logr (default 1).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Real::<NonNegative>::de")]
            pub gamma_logr: Option<f64>,
            /// γ_s (default 0.1).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Real::<NonNegative>::de")]
            pub gamma_s: Option<f64>,
            /// Rotation groups (default: the number of key points).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Int::<1, 10_000>::de")]
            pub n_groups: Option<usize>,
            /// E_diff data term (default true; false: handle constraints).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub use_ediff: Option<bool>,
            /// ARAP weight λ (default 0.5) of every ARAP solve of the method: the
            /// selection, the fit on A and the refinement on B (`refine = true`;
            /// there the key points are held with weight μ = 1e5, so λ only sets
            /// how soft they are and moves B′ little).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Real::<NonNegative>::de")]
            pub lambda: Option<f64>,
            /// Stage-2 passes at most (default: until a pass changes nothing, Algorithm 1).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Int::<0, 1000>::de")]
            pub max_swap_passes: Option<usize>,
            /// Fast mode: k-means subsample (default 1000).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Int::<1, 10_000_000>::de")]
            pub kmeans_sample: Option<usize>,
            /// Fast mode: ARAP iterations per trial (default 30).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Int::<1, 10_000>::de")]
            pub arap_max_iter: Option<usize>,
            /// Select key points from the first m deformed poses only (the
            /// transforms are then fitted on all of them). Default: all.
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Int::<1, 1000>::de")]
            pub selection_poses: Option<usize>,
            /// `unit_sphere` (the library's default, `BdtOptions::default`),
            /// `raw` (alias `direct`) or `handle_relative`.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub frame: Option<TransferFrame>,
            /// Rotation of B onto A in the unit-sphere frame: `none` (the
            /// library's default, `BdtOptions::default`), `keypoints` or
            /// `dense` ([`FrameAlign`]).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub align: Option<FrameAlign>,
            /// ARAP refinement on the target (default false).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub refine: Option<bool>,
            /// Target weights: `auto` (default), `bounded`, `fast`.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub target_weights: Option<TargetWeights>,
            /// Bounded biharmonic weights of the fits on A and of the target:
            /// `per_handle` (default; rows normalised) or `coupled` (BDT
            /// Eq. 1 as written).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub weights: Option<WeightMode>,
            /// Target key points: `identity` (default; shared connectivity,
            /// target vertex = source vertex) or `auto` (registration of A
            /// onto B, [`crate::transfer::auto`]; any connectivity).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub target_correspondence: Option<TargetCorrespondence>,
            /// Geodesic noise on the target key points: each moves to a random
            /// vertex within this edge-path radius, √area(B) units (default 0).
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Real::<UnitInterval>::de")]
            pub target_noise: Option<f64>,
            /// Seed of the target noise (default 0; independent of `seed`, so
            /// the key points on A stay the same across noise seeds).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub target_noise_seed: Option<u64>,
        }
    };
}

pipeline_struct! {
    /// `[defaults]`: pipeline options shared by every method (each method
    /// may override any of them).
    pub struct PipelineSpec {}
}

pipeline_struct! {
    /// One `[[methods]]` entry: a name, a kind, the kind's own parameters
    /// and any pipeline option. Keys that do not apply to the kind are
    /// rejected when the config is resolved.
    pub struct MethodEntry {
        /// Unique name (letters, digits, `-`, `_`, `.`): a column value and a folder name.
        pub name: String,
        /// What the method does.
        pub kind: MethodKind,
        /// Plot group (default: the name): plots aggregate methods of a group.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub group: Option<String>,
        /// Display name in legends and tables (spaces allowed; default: the
        /// group name). Output only: not part of the config hash. A group
        /// is shown by the first `label` among its methods.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub label: Option<String>,
        /// Key points (random, extremity).
        #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Int::<1, 1000>::de")]
        pub count: Option<usize>,
        /// Random pool (default `candidates`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub pool: Option<Pool>,
        /// Extremity strategy (default `centroid_fps`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub strategy: Option<Strategy>,
        /// Extremity jitter radius in √area units (default 0: exact picks).
        #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Real::<UnitInterval>::de")]
        pub jitter: Option<f64>,
        /// Clustering: FPS handles whose weights form W (default 12).
        #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Int::<1, 1000>::de")]
        pub handles: Option<usize>,
        /// Clustering features.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub features: Option<FeatureKind>,
        /// Clustering: `one` or `all` (default) deformed examples.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub examples: Option<Examples>,
        /// Clustering: clusters (default: the number of true labels, else `handles`).
        #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Int::<1, 1000>::de")]
        pub n_clusters: Option<usize>,
        /// `kind = "fbt"`: the task and its options ([`FbtSpec`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub fbt: Option<FbtSpec>,
    }
}

/// What an FBT method measures (see the module docs).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FbtTask {
    Timing,
    Projection,
    Scale,
    Completion,
    Permutation,
    Interpolation,
}

/// `[methods.fbt]` / `fbt = { .. }` of a `kind = "fbt"` method.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FbtSpec {
    pub task: FbtTask,
    /// Number of example shapes (default 4).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 100>::de"
    )]
    pub q: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dictionary: Option<DictionaryKind>,
    /// LBO eigenfunctions (projection: of the dictionary, default 10;
    /// otherwise of the main stage, default that of `FbtConfig`).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 200>::de"
    )]
    pub m: Option<usize>,
    /// Bones of the skeleton weights (default: chosen by the data).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 100>::de"
    )]
    pub bones: Option<usize>,
    /// Where the skeleton weights are learnt from: `"examples"` (the q
    /// examples, default) or `"class"` (`rig_poses` shapes of the class
    /// besides the reference and the target).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig: Option<RigSource>,
    /// With `rig = "class"`: shapes besides the reference and the target
    /// the skeleton weights are learnt from (default 4).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 100>::de"
    )]
    pub rig_poses: Option<usize>,
    /// Solving pipeline: `"skeleton"` (the paper's for articulated shapes,
    /// default) or `"lbo"` (LBO only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pipeline: Option<PipelineKind>,
    /// Rotation clusters r (default 20).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 1000>::de"
    )]
    pub clusters: Option<usize>,
    /// Scale applied to the target (`scale` task, default 1.5).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<ScaleFactor>::de"
    )]
    pub scale: Option<f64>,
    /// Fixed global scale α (Fig. 8 C); default: α is optimised.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<ScaleFactor>::de"
    )]
    pub alpha: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compare: Option<CompareWith>,
    /// Feature points (default 8).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 100>::de"
    )]
    pub features: Option<usize>,
    /// Geodesic circles per feature (default 10).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 100>::de"
    )]
    pub circles: Option<usize>,
    /// Largest circle radius relative to √area (default 0.15; 0.1 for
    /// `permutation` and `interpolation`).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<OpenUnitInterval>::de"
    )]
    pub radius: Option<f64>,
    /// Vertex-position constraints of the `scale` task (default 20).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 10_000>::de"
    )]
    pub vertices: Option<usize>,
    /// Run NICP after the feature registration (`completion`, default true).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nicp: Option<bool>,
    /// NICP iterations (default 10).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 100>::de"
    )]
    pub nicp_iterations: Option<usize>,
    /// Size of the ambiguous feature group (`permutation`, default 4; at
    /// most 6: 720 assignments are tried).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 6>::de"
    )]
    pub group: Option<usize>,
    /// Timing repetitions (`timing`, default 5).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 100>::de"
    )]
    pub repeats: Option<usize>,
    /// Correspondence queries per case (Kim et al. curve, default 300).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 10_000>::de"
    )]
    pub queries: Option<usize>,
    /// FBT completion: retry a suspicious first attempt with the remedies
    /// of [`crate::methods::completion::RestartOptions`] (default true).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub restarts: Option<bool>,
    /// Deformation model of the `completion` task: `"fbt"` (default),
    /// `"der"`, `"amberg"`, or `"template"` (the template left undeformed:
    /// the floor).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver: Option<SolverKind>,
}

impl FbtSpec {
    pub fn q(&self) -> usize {
        self.resolve().q
    }

    /// The typed options: every unset field takes its default from
    /// [`FbtOptions::default`] (the task-independent defaults; the full
    /// target tasks' circle radius is `full_target_radius`).
    pub fn resolve(&self) -> FbtOptions {
        let d = FbtOptions::default();
        FbtOptions {
            q: self.q.unwrap_or(d.q),
            m: self.m.unwrap_or(d.m),
            bones: self.bones.or(d.bones),
            rig: self.rig.unwrap_or(d.rig),
            rig_poses: self.rig_poses.unwrap_or(d.rig_poses),
            pipeline: self.pipeline.unwrap_or_else(|| {
                PipelineKind::default_for(
                    self.rig
                        .unwrap_or(d.rig)
                        .shape_count(self.q.unwrap_or(d.q), self.rig_poses.unwrap_or(d.rig_poses)),
                )
            }),
            clusters: self.clusters.unwrap_or(d.clusters),
            scale: self.scale.unwrap_or(d.scale),
            alpha: self.alpha.or(d.alpha),
            dictionary_examples: match self.dictionary.unwrap_or_default() {
                DictionaryKind::Lbo | DictionaryKind::Skeleton => d.dictionary_examples,
                DictionaryKind::OneExample => DictionaryExamples::First,
            },
            arap_examples: match self.compare.unwrap_or_default() {
                CompareWith::All => d.arap_examples,
                CompareWith::First => DictionaryExamples::First,
            },
            features: FeatureOptions {
                features: self.features.unwrap_or(d.features.features),
                circles: self.circles.unwrap_or(d.features.circles),
                radius: self.radius.unwrap_or(d.features.radius),
            },
            full_target_radius: self.radius.unwrap_or(d.full_target_radius),
            vertices: self.vertices.unwrap_or(d.vertices),
            nicp: self.nicp.unwrap_or(d.nicp),
            nicp_iterations: self.nicp_iterations.unwrap_or(d.nicp_iterations),
            group: self.group.unwrap_or(d.group),
            repeats: self.repeats.unwrap_or(d.repeats),
            queries: self.queries.unwrap_or(d.queries),
            restarts: match self.restarts {
                Some(false) => RestartOptions {
                    suspicious_residual: f64::INFINITY,
                },
                _ => d.restarts,
            },
        }
    }

    /// Whether the method solves with an FBT pipeline (FBT itself, or Der
    /// et al. on its rotation clusters; not the projection task).
    pub fn solves_with_pipeline(&self) -> bool {
        self.task != FbtTask::Projection
            && matches!(
                self.solver.unwrap_or_default(),
                SolverKind::Fbt | SolverKind::Der
            )
    }

    /// Checks the options; errors are `(key, message)` relative to the
    /// method's `fbt` table.
    pub fn check(&self) -> std::result::Result<(), (String, String)> {
        // Each key's own range is checked while reading (see its definition).
        let e = |k: &str, m: &str| Err((k.to_string(), m.to_string()));
        if let Some(g) = self.group {
            if g > self.resolve().features.features {
                return e("group", "expected at most `features` features");
            }
        }
        if self.task == FbtTask::Projection
            && self.dictionary == Some(DictionaryKind::Skeleton)
            && self.m.is_some()
        {
            return e(
                "m",
                "does not apply to the skeleton dictionary (use `bones`)",
            );
        }
        let o = self.resolve();
        let skeleton = if self.task == FbtTask::Projection {
            self.dictionary == Some(DictionaryKind::Skeleton)
        } else {
            self.solves_with_pipeline() && o.pipeline.uses_skeleton()
        };
        if !skeleton && (self.bones.is_some() || self.rig.is_some() || self.rig_poses.is_some()) {
            let key = if self.bones.is_some() {
                "bones"
            } else if self.rig.is_some() {
                "rig"
            } else {
                "rig_poses"
            };
            return e(
                key,
                &format!(
                    "bones / rig / rig_poses configure the skeleton; {} has none",
                    if self.task == FbtTask::Projection {
                        "this dictionary".to_string()
                    } else {
                        format!("pipeline = \"{}\"", o.pipeline.name())
                    }
                ),
            );
        }
        if self.rig_poses.is_some() && o.rig != RigSource::Class {
            return e(
                "rig_poses",
                "counts the class shapes of rig = \"class\"; with rig = \"examples\" the \
                 bones are learnt from the q examples",
            );
        }
        if skeleton && o.rig == RigSource::Examples && o.q < 2 {
            return e(
                "q",
                "q = 1 leaves no example besides the reference to learn the skeleton's bones \
                 from (rig = \"examples\"); use rig = \"class\" or pipeline = \"lbo\"",
            );
        }
        if self.task == FbtTask::Projection && self.pipeline.is_some() {
            return e(
                "pipeline",
                "the projection task has no solving pipeline (use `dictionary`)",
            );
        }
        match self.solver.unwrap_or_default() {
            SolverKind::Fbt => {}
            other @ (SolverKind::Der | SolverKind::Amberg | SolverKind::Template) => {
                if self.task != FbtTask::Completion {
                    return e(
                        "solver",
                        &format!(
                            "solver = \"{}\" applies to task = \"completion\" only",
                            other.name()
                        ),
                    );
                }
                if self.dictionary.is_some() || self.m.is_some() || self.alpha.is_some() {
                    return e(
                        "solver",
                        &format!(
                            "dictionary / m / alpha are FBT options; solver = \"{}\" has none",
                            other.name()
                        ),
                    );
                }
                if other == SolverKind::Template
                    && (self.nicp.is_some() || self.nicp_iterations.is_some())
                {
                    return e(
                        "nicp",
                        "solver = \"template\" leaves the template undeformed: \
                         nicp / nicp_iterations do not apply",
                    );
                }
                if other != SolverKind::Der {
                    if self.nicp == Some(false) || self.nicp_iterations.is_some() {
                        return e(
                            "nicp",
                            "solver = \"amberg\" is a nonrigid ICP with its own stiffness \
                             schedule: nicp / nicp_iterations do not apply",
                        );
                    }
                    if self.pipeline.is_some()
                        || self.bones.is_some()
                        || self.rig.is_some()
                        || self.rig_poses.is_some()
                        || self.restarts.is_some()
                    {
                        return e(
                            "pipeline",
                            &format!(
                                "pipeline / bones / rig / rig_poses / restarts configure FBT's \
                                 solve; solver = \"{}\" has none",
                                other.name()
                            ),
                        );
                    }
                    if self.clusters.is_some() || self.compare.is_some() {
                        return e(
                            "clusters",
                            &format!(
                                "solver = \"{}\" uses no rotation clusters or examples",
                                other.name()
                            ),
                        );
                    }
                }
            }
        }
        if self.task != FbtTask::Projection && self.dictionary == Some(DictionaryKind::Skeleton) {
            return e(
                "dictionary",
                "the skeleton dictionary is available for task = \"projection\" only",
            );
        }
        Ok(())
    }
}

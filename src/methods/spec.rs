//! The FBT options of a `kind = "fbt"` method entry (`fbt = { ... }`), and
//! the ranges of the selection options that the command line shares. The
//! entry schema itself and the kinds are the registry's
//! ([`super::registry`]).

use serde::{Deserialize, Serialize};

use crate::methods::completion::{
    CompareWith, DictionaryKind, FbtOptions, FeatureOptions, PipelineKind, RestartOptions,
    RigSource, SolverKind,
};
use crate::range::{Int, NonNegative, OpenUnitInterval, Real, ScaleFactor};
use crate::register::DictionaryExamples;

/// Range of `n_candidates` (and `--candidates` of `keypoints` / `transfer`);
/// at most the source's vertex count, checked once the dataset is open.
pub type NCandidates = Int<1, 100_000>;
/// Range of `max_keypoints` (and `--max-keypoints`).
pub type MaxKeypoints = Int<1, 1000>;
/// Range of `epsilon` (and `--epsilon`), unit-sphere units.
pub type Epsilon = Real<NonNegative>;
/// Active-set tolerance of bounded biharmonic weights (`deformlab weights
/// --tol`, `--coupled-tol`; Python `bbw(tol=…)`).
pub type BbwTolerance = Real<crate::range::ActiveSetTol>;
/// Step test of the coupled weights (`deformlab weights --coupled-step-tol`).
pub type BbwStepTolerance = Real<crate::range::StepTol>;

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

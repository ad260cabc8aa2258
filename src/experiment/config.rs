//! Experiment config schema (TOML, serde, unknown keys rejected everywhere).
//!
//! ```toml
//! name = "fig14"                # folder name under the results root
//! description = "..."           # free text (not part of the config hash)
//! seed = 0                      # random case draws; default seed of every method
//!
//! [dataset]
//! strict = false                # refuse meshes with result-changing defects (not hashed)
//! repair = false                # drop duplicate / zero-area faces, fix winding at load
//!
//! [dataset.synthetic]           # or [dataset.faust] path = "..."
//! subjects = 3                  #    [dataset.tosca] path = "...", class = "cactus"
//! poses = 4                     #    [dataset.manifest] path = ".../manifest.toml"
//! resolution = 1                # (paths: `@data/...` under the data root,
//!                               #  others relative to this config file)
//!
//! [cases]                       # source subject → target subjects × poses
//! sources = [0]                 # default: every subject
//! targets = [1, 2]              # default: every other subject
//! include_self = false          # also target = source (B = A, truth = A′)
//! reference_pose = 0            # A and B; default: first pose both subjects have
//! poses = [1, 2, 3]             # A′; default: every other pose of the source
//! max_poses = 3                 # keep the first m of them
//! per_pose = false              # one case per pose (m = 1) instead of all at once
//! require_truth = true          # drop poses whose ground truth is missing
//! repeat = 5                    # copies of every case (fresh FBT draws per copy)
//! random = 4                    # N random draws (seeded) instead of the product
//! max_cases = 10
//!
//! [defaults]                    # pipeline options shared by every method
//! mode = "fast"
//! n_candidates = 24
//!
//! [[methods]]
//! name = "auto"
//! kind = "bdt"                  # bdt | bdt_random | bdt_extremity | clustering
//! label = "BDT (automatic)"     # legend / table name (output only, not hashed)
//! max_keypoints = 8             # any pipeline option overrides [defaults]
//!
//! [[methods]]
//! name = "random-0"
//! kind = "bdt_random"
//! group = "random"              # plots aggregate methods of one group
//! count = 6
//! seed = 0
//!
//! [metrics]
//! procrustes = false            # rigid alignment before measuring
//! curve_max = 0.2               # cumulative curve grid, unit-sphere units
//!
//! [sweep]                       # method variants (super::sweep)
//! defaults.epsilon = [0.01, 0.02]
//!
//! [outputs]                     # output-only: not part of the config hash
//! render_cases = 1
//! title = false                 # no plot titles (or a text: the title prefix)
//! subtitle = false              # no provenance line under the titles
//! formats = ["png", "pdf"]      # charts and renders (default: charts png, svg, pdf; renders png)
//! up = "z"                      # render up axis (default: "z" for [dataset.tosca], else "y")
//! max_per_row = 6               # render panels per row (0: one row)
//! mesh_format = "obj"           # meshes/ as OBJ (default "ply", with a per-vertex `error`)
//! [[outputs.plots]]
//! kind = "cumulative"
//! title = true                  # this plot keeps its title; `subtitle`, `formats` likewise
//! [[outputs.plots]]               # one figure, one panel per curve, shared legend
//! kind = "curve_panels"
//! curves = ["cumulative_area", "correspondence_euclidean_area"]
//! [[outputs.plots]]               # rows × columns of metric means (figure + CSV + Markdown + LaTeX)
//! kind = "pivot"
//! rows = "q"
//! columns = "dictionary_kind"
//! metric = "rel_distortion_max"
//! scale = 100                   # percent
//! digits = 2
//! lead = ["dict_size"]          # per-row columns before the pivoted ones
//! lead_from = "lbo"             # ... taken from the `lbo` results only
//! labels = { lbo = "LBO" }      # display names of values, columns, curves
//! ```
//!
//! Errors name the file, the key (e.g. `methods[1].n_candidates`), the line
//! and what was expected. Every numeric key has a valid range, written on
//! its definition below (`deserialize_with = "Int::<1, 1000>::de"`, see
//! [`super::range`]) and listed in `experiments/README.md`; values that
//! depend on the data are checked once the dataset is open
//! ([`super::feasible`]). Sumner–Popović and cage baselines (issue 6) will be
//! further `kind`s of [`MethodEntry`] / variants of [`Method`].

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::range::{
    Degrees, Int, NonNegative, OpenUnitInterval, Positive, Real, RemeshRatio, ScaleFactor, Spread,
    UnitInterval,
};
use crate::data::synthetic::{pose::N_POSES, MAX_RESOLUTION, MAX_SUBJECTS};
use crate::data::DataRoot;
use crate::mesh::repair::DefectPolicy;
use crate::methods::completion::{
    CompareWith, DictionaryKind, FbtOptions, FeatureOptions, PipelineKind, RestartOptions,
    RigSource, SolverKind,
};
use crate::methods::{
    BdtOptions, Clustering, Examples, KeypointSource, Pool, Strategy, TargetCorrespondence,
    TargetPoints, TransferMethod,
};
use crate::ops::FpsMetric;
use crate::register::DictionaryExamples;
use crate::skin::bbw::{BbwOptions, WeightMode};
use crate::skin::{FeatureKind, GroupFeatures};
use crate::transfer::{
    ErrorNorm, FastOptions, FrameAlign, KeypointOptions, SelectionMode, TargetWeights,
    TransferFrame,
};
use crate::{Error, Result};

/// A parsed experiment config.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Experiment name: the results folder (letters, digits, `-`, `_`, `.`).
    pub name: String,
    /// Free text (not hashed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Seed of random case draws and default seed of every method.
    #[serde(default)]
    pub seed: u64,
    /// Where the meshes come from (synthetic by default).
    #[serde(default)]
    pub dataset: DatasetSpec,
    /// Case generator.
    #[serde(default)]
    pub cases: CaseSpec,
    /// Pipeline options shared by every method.
    #[serde(default)]
    pub defaults: PipelineSpec,
    /// The methods, run on every case in this order.
    pub methods: Vec<MethodEntry>,
    /// Metric settings.
    #[serde(default)]
    pub metrics: MetricsSpec,
    /// Output-only settings (not hashed).
    #[serde(default)]
    pub outputs: OutputSpec,
    /// `[sweep]` / `[[sweep]]`: method variants, expanded when the config
    /// is loaded ([`super::sweep`]); the expanded config has none.
    #[serde(default, skip_serializing)]
    pub sweep: Option<toml::Value>,
}

/// A subject or pose label: a number (`3`) or a name (`"rest"`).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(untagged)]
pub enum Label {
    Index(u64),
    Name(String),
}

impl std::fmt::Display for Label {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Label::Index(i) => write!(f, "{i}"),
            Label::Name(s) => f.write_str(s),
        }
    }
}

/// `[dataset]`: exactly one of the tables, or none (synthetic defaults).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DatasetSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub synthetic: Option<SyntheticSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faust: Option<FolderSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tosca: Option<ToscaSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub manifest: Option<FolderSpec>,
    /// Refuse a mesh with a defect that changes results (duplicate or
    /// zero-area faces, non-manifold edges or vertices, inconsistent
    /// winding, several components, unreferenced vertices) instead of
    /// warning ([`DefectPolicy::strict`]; `run --strict` sets it). Not part
    /// of the config hash: it changes no result.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strict: Option<bool>,
    /// Repair meshes at load: drop duplicate and zero-area faces, wind each
    /// component consistently ([`DefectPolicy::repair`]; `run --repair`
    /// sets it). Part of the config hash.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub repair: Option<bool>,
}

impl DatasetSpec {
    /// The defect policy: the keys given, else [`DefectPolicy::default`].
    pub fn policy(&self) -> DefectPolicy {
        let d = DefectPolicy::default();
        DefectPolicy {
            strict: self.strict.unwrap_or(d.strict),
            repair: self.repair.unwrap_or(d.repair),
        }
    }
}

/// Range of `dataset.synthetic.subjects` (and `deformlab gen --subjects`).
pub type Subjects = Int<1, { MAX_SUBJECTS as u64 }>;
/// Range of `dataset.synthetic.poses` (and `deformlab gen --poses`).
pub type SyntheticPoses = Int<1, { N_POSES as u64 }>;
/// Range of `dataset.synthetic.resolution` (and `deformlab gen --resolution`).
pub type Resolution = Int<1, { MAX_RESOLUTION as u64 }>;

/// `[dataset.synthetic]`: [`crate::data::synthetic::FaustStyle`] parameters
/// (defaults: those of `FaustStyle::default()`).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SyntheticSpec {
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Subjects::de"
    )]
    pub subjects: Option<usize>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "SyntheticPoses::de"
    )]
    pub poses: Option<usize>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Resolution::de_u32"
    )]
    pub resolution: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tail: Option<bool>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<Spread>::de"
    )]
    pub spread: Option<f64>,
    /// Also serve a remesh of subject 0 (about `remesh · n` vertices, other
    /// connectivity, [`crate::data::synthetic::remesh`]) as the subject
    /// `"remesh"`, in every pose of subject 0 (exact: its vertices lie on
    /// subject 0's surface), for cross-topology transfer with ground truth.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<RemeshRatio>::de"
    )]
    pub remesh: Option<f64>,
}

impl SyntheticSpec {
    /// The generator configuration.
    pub fn faust_style(&self) -> crate::data::FaustStyle {
        let d = crate::data::FaustStyle::default();
        crate::data::FaustStyle {
            subjects: self.subjects.unwrap_or(d.subjects),
            poses: self.poses.unwrap_or(d.poses),
            resolution: self.resolution.unwrap_or(d.resolution),
            seed: self.seed.unwrap_or(d.seed),
            tail: self.tail.unwrap_or(d.tail),
            spread: self.spread.unwrap_or(d.spread),
        }
    }
}

/// `[dataset.faust]` / `[dataset.manifest]`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FolderSpec {
    /// Folder (FAUST) or manifest file, relative to the config file.
    pub path: PathBuf,
}

/// `[dataset.tosca]`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ToscaSpec {
    /// Folder, relative to the config file.
    pub path: PathBuf,
    /// Classes used as subjects (default: all; shapes of different classes
    /// do not share connectivity, so transfer needs `include_self`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub classes: Option<Vec<String>>,
}

/// `[cases]`: see the module documentation.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sources: Option<Vec<Label>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub targets: Option<Vec<Label>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub include_self: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_pose: Option<Label>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poses: Option<Vec<Label>>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 1_000_000>::de"
    )]
    pub max_poses: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub per_pose: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub require_truth: Option<bool>,
    /// Copies of every generated case (ids suffixed `-x0`, `-x1`, …) before
    /// `random` draws from them: methods that seed their random choices with
    /// the case id (FBT's partial shapes, feature points and example draws)
    /// get a fresh draw per copy. Default 1.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 1000>::de"
    )]
    pub repeat: Option<usize>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 1_000_000>::de"
    )]
    pub random: Option<usize>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 1_000_000>::de"
    )]
    pub max_cases: Option<usize>,
}

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

macro_rules! merge_pipeline {
    ($a:expr, $b:expr; $($f:ident),*) => {
        PipelineSpec { $($f: $a.$f.clone().or_else(|| $b.$f.clone()),)* }
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

/// `[metrics]`.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MetricsSpec {
    /// Rigid (Procrustes) alignment of each result onto its ground truth
    /// before measuring (default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub procrustes: Option<bool>,
    /// Upper end of the cumulative curve grid in unit-sphere units (default 0.2).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<Positive>::de"
    )]
    pub curve_max: Option<f64>,
    /// Upper end of the √area curve grid (default 0.15).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<Positive>::de"
    )]
    pub curve_max_area: Option<f64>,
    /// Grid points (default 41).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<2, 10_000>::de"
    )]
    pub curve_points: Option<usize>,
}

impl MetricsSpec {
    pub fn procrustes(&self) -> bool {
        self.procrustes.unwrap_or(false)
    }
    pub fn curve_max(&self) -> f64 {
        self.curve_max.unwrap_or(0.2)
    }
    pub fn curve_max_area(&self) -> f64 {
        self.curve_max_area.unwrap_or(0.15)
    }
    pub fn curve_points(&self) -> usize {
        self.curve_points.unwrap_or(41)
    }
}

/// `[outputs]` (not part of the config hash).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Titles of the plots: a text (the title prefix), `true` (default: the
    /// experiment name as prefix) or `false` (no titles; a plot's own
    /// `title` still wins).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub title: Option<TitleSpec>,
    /// The provenance line under each title (data set, cases; default
    /// true); `false` leaves it out (a plot's own `subtitle` still wins).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub subtitle: Option<bool>,
    /// Files of every chart and render: some of `"png"`, `"svg"`, `"pdf"`
    /// (default: charts PNG + SVG + PDF, renders PNG;
    /// [`crate::plot::Formats::CHARTS`], [`crate::plot::Formats::RENDERS`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formats: Option<Vec<FileFormat>>,
    /// Cases (first in case order) whose meshes are saved for renders (default 1).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<0, 10_000>::de"
    )]
    pub render_cases: Option<usize>,
    /// Deformed poses saved per render case (default 2).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<0, 1000>::de"
    )]
    pub render_poses: Option<usize>,
    /// Render camera `[yaw, pitch]` in degrees (default: the data set's,
    /// [`DatasetSpec::default_camera`]).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<Degrees>::de_pair"
    )]
    pub camera: Option<[f64; 2]>,
    /// The model axis drawn pointing up in renders: `"y"` or `"z"`
    /// (default: the data set's, [`DatasetSpec::default_camera`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<UpAxis>,
    /// Render panels per row at most; more wrap onto further rows (0: one
    /// row; default [`crate::plot::DEFAULT_MAX_PER_ROW`]).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<0, 1000>::de"
    )]
    pub max_per_row: Option<usize>,
    /// Format of the saved meshes (`meshes/`): `"ply"` (default; result
    /// meshes carry a per-vertex `error` property) or `"obj"` (the errors
    /// in a companion `<name>.error.txt`, one number per vertex).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh_format: Option<MeshFormat>,
    /// Plots made by `run` and `plot`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plots: Vec<PlotSpec>,
}

impl OutputSpec {
    pub fn render_cases(&self) -> usize {
        self.render_cases.unwrap_or(1)
    }
    pub fn render_poses(&self) -> usize {
        self.render_poses.unwrap_or(2)
    }
    pub fn mesh_format(&self) -> MeshFormat {
        self.mesh_format.unwrap_or_default()
    }
    /// Panels per row of the renders (0: no limit).
    pub fn max_per_row(&self) -> usize {
        self.max_per_row
            .unwrap_or(crate::plot::RenderOptions::default().max_per_row)
    }

    /// The files of a chart made by `plot`: its own `formats`, else
    /// `[outputs] formats`, else [`crate::plot::Formats::CHARTS`].
    pub fn chart_formats(&self, plot: &PlotSpec) -> crate::plot::Formats {
        formats_of(plot.formats.as_ref().or(self.formats.as_ref()))
            .unwrap_or(crate::plot::Formats::CHARTS)
    }

    /// The files of a render made by `plot`: its own `formats`, else
    /// `[outputs] formats`, else [`crate::plot::Formats::RENDERS`].
    pub fn render_formats(&self, plot: &PlotSpec) -> crate::plot::Formats {
        formats_of(plot.formats.as_ref().or(self.formats.as_ref()))
            .unwrap_or(crate::plot::Formats::RENDERS)
    }

    /// The render camera for `dataset`: [`DatasetSpec::default_camera`]
    /// with `camera` and `up` applied.
    pub fn camera(&self, dataset: &DatasetSpec) -> crate::plot::Camera {
        let d = dataset.default_camera();
        let (yaw_deg, pitch_deg) = match self.camera {
            Some([yaw, pitch]) => (yaw, pitch),
            None => (d.yaw_deg, d.pitch_deg),
        };
        crate::plot::Camera {
            yaw_deg,
            pitch_deg,
            up: match self.up {
                Some(UpAxis::Y) => crate::plot::Up::Y,
                Some(UpAxis::Z) => crate::plot::Up::Z,
                None => d.up,
            },
        }
    }
}

fn formats_of(v: Option<&Vec<FileFormat>>) -> Option<crate::plot::Formats> {
    let names: Vec<&str> = v?.iter().map(|f| f.name()).collect();
    crate::plot::Formats::from_names(&names).ok()
}

impl DatasetSpec {
    /// The render camera of the data set when `[outputs]` sets none:
    /// TOSCA-style folders (`[dataset.tosca]`: TOSCA, the cactus) are
    /// z-up, seen three-quarters from the front right and above
    /// ([`crate::plot::Camera::TOSCA`]); every other data set is y-up,
    /// seen from the front ([`crate::plot::Camera::FRONT`]).
    pub fn default_camera(&self) -> crate::plot::Camera {
        if self.tosca.is_some() {
            crate::plot::Camera::TOSCA
        } else {
            crate::plot::Camera::FRONT
        }
    }
}

/// A title setting: a text, or whether the default title is drawn.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(untagged, expecting = "a title (text), true or false")]
pub enum TitleSpec {
    Show(bool),
    Text(String),
}

/// A file format of the charts and renders.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FileFormat {
    Png,
    Svg,
    Pdf,
}

impl FileFormat {
    pub fn name(self) -> &'static str {
        match self {
            FileFormat::Png => "png",
            FileFormat::Svg => "svg",
            FileFormat::Pdf => "pdf",
        }
    }
}

/// The model axis drawn pointing up (`[outputs] up`).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum UpAxis {
    Y,
    Z,
}

/// Format of the meshes saved under `meshes/` (`[outputs] mesh_format`).
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MeshFormat {
    /// Binary PLY; result meshes with a float `error` property per vertex.
    #[default]
    Ply,
    /// Wavefront OBJ; the errors in a companion `<name>.error.txt`.
    Obj,
}

impl MeshFormat {
    /// The mesh file format.
    pub fn format(self) -> crate::mesh::io::Format {
        match self {
            MeshFormat::Ply => crate::mesh::io::Format::Ply,
            MeshFormat::Obj => crate::mesh::io::Format::Obj,
        }
    }
}

/// Plot kinds (see [`crate::experiment::plots`]).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PlotKind {
    /// Cumulative error curves, one line per method group (BDT Fig. 14).
    Cumulative,
    /// Grouped bars of `metrics` (mean ± std over cases) per method group.
    Bars,
    /// Selection error vs number of key points (BDT Fig. 6).
    Trace,
    /// `metrics` vs the column `x` (mean per method), e.g. BDT Fig. 9.
    Line,
    /// Timing bars (log scale) and a Markdown table (BDT Table 1).
    Timing,
    /// Mesh panels: source, deformed source, target, results with key points.
    Panels,
    /// Mesh panels coloured by cluster (BDT Fig. 4).
    Clusters,
    /// Markdown + CSV + LaTeX (booktabs) table of group means (`metrics`;
    /// rows also split by the `x` column when set).
    Table,
    /// One figure of line-chart panels, one per curve of curves.csv
    /// (`curves`), mean curve per method group, shared legend (FBT Fig. 7).
    CurvePanels,
    /// A pivot table (figure, CSV, Markdown, LaTeX): one row per value of the
    /// cases.csv column `rows`, one column per value of `columns`, cells the
    /// mean of `metric` over the results with both values (× `scale`,
    /// `digits` decimals); `lead` columns first (FBT Table 2).
    Pivot,
}

/// One `[[outputs.plots]]` entry.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    pub kind: PlotKind,
    /// File stem under plots/ (default: the kind's name).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Title: a text, `false` (none) or `true` (the default title, from
    /// the kind and the experiment, even when `[outputs] title = false`).
    /// Default: as `[outputs] title` says.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub title: Option<TitleSpec>,
    /// The provenance line under the title (default: `[outputs] subtitle`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub subtitle: Option<bool>,
    /// Files written (default: `[outputs] formats`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formats: Option<Vec<FileFormat>>,
    /// cases.csv columns plotted (bars, line).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub metrics: Vec<String>,
    /// Only these methods (default: all), e.g. one selection trace.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub methods: Vec<String>,
    /// cases.csv column on the x axis (line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<String>,
    /// Panels: `results` (default: B′ per method) or `fits` (D_S(A) per method).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub show: Option<String>,
    /// Logarithmic y axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub log_y: Option<bool>,
    /// Line plots: one series per value of this cases.csv column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by: Option<String>,
    /// Bars and line plots: the y axis label, with units (default: from
    /// the metrics).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y_label: Option<String>,
    /// Curve panels: the curves.csv curves drawn, one panel each, in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub curves: Vec<String>,
    /// Pivot: the cases.csv column whose values make the rows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rows: Option<String>,
    /// Pivot: the cases.csv column whose values make the columns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub columns: Option<String>,
    /// Pivot: the cases.csv column averaged in the cells.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub metric: Option<String>,
    /// Pivot: factor applied to the cell means (e.g. 100 for percent;
    /// default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    /// Pivot: decimals shown in the PNG and Markdown (default 3; the CSV
    /// keeps 10 significant digits).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<0, 10>::de"
    )]
    pub digits: Option<usize>,
    /// Pivot: cases.csv columns shown per row before the pivoted columns
    /// (mean over the row's results, not scaled), e.g. the dictionary size.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lead: Vec<String>,
    /// Pivot: take the `lead` columns only from the results whose `columns`
    /// value is this one (default: all of the row's results).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lead_from: Option<String>,
    /// Display names, overriding the methods' `label`s: of method groups
    /// (legends, categories, table rows, panel captions), of metric columns
    /// (table headers), of column values (pivot, `by` series) and of curves
    /// (curve panels).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub labels: BTreeMap<String, String>,
}

impl PlotSpec {
    /// A plot of `kind` over `metrics`, every other key at its default.
    pub fn new(kind: PlotKind, metrics: &[&str]) -> Self {
        PlotSpec {
            kind,
            file: None,
            title: None,
            subtitle: None,
            formats: None,
            metrics: metrics.iter().map(|s| s.to_string()).collect(),
            methods: Vec::new(),
            x: None,
            show: None,
            log_y: None,
            by: None,
            y_label: None,
            curves: Vec::new(),
            rows: None,
            columns: None,
            metric: None,
            scale: None,
            digits: None,
            lead: Vec::new(),
            lead_from: None,
            labels: BTreeMap::new(),
        }
    }
}

/// A resolved method: a library value ([`crate::methods`]).
// One value per configured method, built once per run: the size of the
// largest variant (the BDT options) costs nothing, and boxing it would make
// every match on a method's options go through a `Box`.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Method {
    /// A transfer to a target, measured against its ground truth (BDT,
    /// its simulated users, the Sumner and cage baselines, `identity`).
    Transfer(TransferMethod),
    /// Rotation-group clustering of the source (no transfer).
    Clustering(Clustering),
    /// FBT ([`super::fbt`]).
    Fbt { spec: FbtSpec, seed: u64 },
}

impl Method {
    /// Short kind name (as in the config).
    pub fn kind_name(&self) -> &'static str {
        match self {
            Method::Transfer(t) => t.kind_name(),
            Method::Clustering(_) => "clustering",
            Method::Fbt { .. } => "fbt",
        }
    }

    /// Whether the method transfers to a target (and is measured against a
    /// ground truth).
    pub fn transfers(&self) -> bool {
        match self {
            Method::Transfer(_) => true,
            Method::Clustering(_) | Method::Fbt { .. } => false,
        }
    }
}

/// A named resolved method.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedMethod {
    pub name: String,
    pub group: String,
    pub method: Method,
}

/// A config loaded from a file: the parsed values, where it came from, and
/// the resolved methods.
#[derive(Clone, Debug)]
pub struct LoadedConfig {
    pub config: Config,
    /// The config file.
    pub path: PathBuf,
    /// Its folder: relative dataset paths are resolved against it.
    pub base_dir: PathBuf,
    /// The data root: `@data/...` dataset paths are resolved against it.
    pub data_root: DataRoot,
    pub methods: Vec<NamedMethod>,
    /// Command-line overrides applied (`--set KEY=VALUE`, as given).
    pub overrides: Vec<String>,
    /// The sweep expanded into methods, if any ([`super::sweep`]): its
    /// axes and the methods each template became, for the manifest.
    pub sweep: Option<serde_json::Value>,
}

/// Columns of cases.csv that plots may name (see [`crate::experiment::store`]).
pub use super::store::CASE_COLUMNS;

pub(super) fn valid_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 100
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.'))
        && !s.starts_with('.')
}

/// A display name: 1 to 200 characters, no control characters.
fn valid_label(s: &str) -> bool {
    !s.trim().is_empty() && s.chars().count() <= 200 && !s.chars().any(char::is_control)
}

/// A `formats` list: not empty, no format twice.
fn check_formats(c: &LoadedConfig, key: &str, f: &[FileFormat]) -> Result<()> {
    if f.is_empty() {
        return Err(bad(
            &c.path,
            key,
            "expected at least one of \"png\", \"svg\", \"pdf\"",
        ));
    }
    if let Some(d) = f.iter().enumerate().find(|(i, x)| f[..*i].contains(x)) {
        return Err(bad(
            &c.path,
            key,
            format!("{:?} is listed twice", d.1.name()),
        ));
    }
    Ok(())
}

/// The key path (`methods[1].n_candidates`) and line of a byte offset in a
/// TOML text, reconstructed from the table headers above it and the key on
/// its line.
fn key_at(text: &str, offset: usize) -> (String, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_no = text[..offset].matches('\n').count() + 1;
    let mut table = String::new();
    let mut arrays: BTreeMap<String, usize> = BTreeMap::new();
    let mut array_paths: BTreeMap<String, String> = BTreeMap::new();
    for line in text[..line_start].lines() {
        let t = line.trim();
        if let Some(inner) = t.strip_prefix("[[").and_then(|r| r.split("]]").next()) {
            let name = inner.trim().to_string();
            let c = arrays.entry(name.clone()).or_insert(0);
            let path = format!("{}[{}]", expand(&name, &array_paths), *c);
            *c += 1;
            array_paths.insert(name, path.clone());
            table = path;
        } else if let Some(inner) = t.strip_prefix('[').and_then(|r| r.split(']').next()) {
            table = expand(inner.trim(), &array_paths);
        }
    }
    let line_end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = &text[line_start..line_end];
    let before = &text[line_start..offset];
    let word = |s: &str| -> Option<String> {
        let w: String = s
            .trim_start()
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == '-')
            .collect();
        (!w.is_empty()).then_some(w)
    };
    let key = if line.trim_start().starts_with('[') {
        None
    } else if before.trim().is_empty() {
        word(&text[offset..line_end])
    } else {
        // The last `key =` before the offset on this line (inline tables too).
        let mut found = None;
        let mut inline_path: Vec<String> = Vec::new();
        for (i, ch) in before.char_indices() {
            if ch == '=' {
                let head = before[..i].trim_end();
                let start = head
                    .rfind(|c: char| {
                        !(c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.')
                    })
                    .map_or(0, |p| {
                        p + head[p..].chars().next().map_or(1, char::len_utf8)
                    });
                let k = head[start..].to_string();
                if !k.is_empty() {
                    found = Some(k);
                }
            } else if ch == '{' {
                if let Some(k) = found.take() {
                    inline_path.push(k);
                }
            } else if ch == '}' {
                inline_path.pop();
            }
        }
        found.map(|k| {
            if inline_path.is_empty() {
                k
            } else {
                format!("{}.{k}", inline_path.join("."))
            }
        })
    };
    let path = match (table.is_empty(), key) {
        (_, None) => table,
        (true, Some(k)) => k,
        (false, Some(k)) => format!("{table}.{k}"),
    };
    (path, line_no)
}

/// `methods.x` → `methods[2].x` when `methods` is an array of tables.
fn expand(name: &str, arrays: &BTreeMap<String, String>) -> String {
    let mut best: Option<(&String, &String)> = None;
    for (k, v) in arrays {
        if name.starts_with(&format!("{k}.")) && best.is_none_or(|(b, _)| k.len() > b.len()) {
            best = Some((k, v));
        }
    }
    match best {
        Some((k, v)) => format!("{v}{}", &name[k.len()..]),
        None => name.to_string(),
    }
}

/// Parses a config text and resolves its methods (no dataset or output
/// checks), with the data root `root`.
pub(super) fn parse_unchecked_in(text: &str, path: &Path, root: &DataRoot) -> Result<LoadedConfig> {
    let config: Config = toml::from_str(text).map_err(|e| {
        let msg = e.message().trim().to_string();
        match e.span() {
            Some(span) => {
                let (key, line) = key_at(text, span.start);
                let location = if key.is_empty() {
                    format!("line {line}")
                } else {
                    format!("key `{key}` (line {line})")
                };
                Error::parse(path, location, msg)
            }
            None => Error::parse(path, "config", msg),
        }
    })?;
    let base_dir = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let methods = resolve(&config, path)?;
    let loaded = LoadedConfig {
        config,
        path: path.to_path_buf(),
        base_dir,
        data_root: root.clone(),
        methods,
        overrides: Vec::new(),
        sweep: None,
    };
    Ok(loaded)
}

fn bad(path: &Path, key: impl Into<String>, msg: impl Into<String>) -> Error {
    Error::parse(path, format!("key `{}`", key.into()), msg)
}

impl LoadedConfig {
    /// A dataset path of the config resolved: `@data/...` against the data
    /// root, other relative paths against the config's folder.
    pub fn resolve_path(&self, p: &Path) -> PathBuf {
        self.data_root.resolve(p, &self.base_dir)
    }

    /// Errors (naming the key and the path) if a dataset path of the
    /// config does not exist.
    pub fn check_paths(&self) -> Result<()> {
        let c = self;
        let d = &c.config.dataset;
        let check = |key: &str, p: &Path, want_dir: bool| -> Result<()> {
            let full = c.resolve_path(p);
            let ok = if want_dir {
                full.is_dir()
            } else {
                full.is_file()
            };
            let what = if want_dir { "folder" } else { "file" };
            if ok {
                Ok(())
            } else if full.exists() {
                // A file for a folder; a FIFO or a device for a file (which
                // would block or never end).
                let found = match crate::mesh::io::check_regular_file(&full) {
                    Ok(_) => "is a file".to_string(),
                    Err(Error::Parse { message, .. }) => message,
                    Err(e) => e.to_string(),
                };
                Err(bad(
                    &c.path,
                    key,
                    format!("expected a {what}, but {} {found}", full.display()),
                ))
            } else if DataRoot::names(p) {
                Err(bad(
                    &c.path,
                    key,
                    format!(
                        "expected an existing {what}, but {} ({}) does not exist: {}",
                        full.display(),
                        p.display(),
                        c.data_root.describe()
                    ),
                ))
            } else {
                Err(bad(
                    &c.path,
                    key,
                    format!(
                        "expected an existing {what} (relative paths are relative to the config \
                         file; `@data/...` to the data root), but {} does not exist",
                        full.display()
                    ),
                ))
            }
        };
        if let Some(f) = &d.faust {
            check("dataset.faust.path", &f.path, true)?;
        }
        if let Some(f) = &d.tosca {
            check("dataset.tosca.path", &f.path, true)?;
        }
        if let Some(f) = &d.manifest {
            check("dataset.manifest.path", &f.path, false)?;
        }
        Ok(())
    }
}

pub(super) fn check_dataset(c: &LoadedConfig) -> Result<()> {
    let d = &c.config.dataset;
    let n = [
        d.synthetic.is_some(),
        d.faust.is_some(),
        d.tosca.is_some(),
        d.manifest.is_some(),
    ]
    .iter()
    .filter(|x| **x)
    .count();
    if n > 1 {
        return Err(bad(
            &c.path,
            "dataset",
            "expected exactly one of [dataset.synthetic], [dataset.faust], [dataset.tosca], \
             [dataset.manifest]",
        ));
    }
    Ok(())
}

pub(super) fn check_outputs(c: &LoadedConfig) -> Result<()> {
    if let Some(f) = &c.config.outputs.formats {
        check_formats(c, "outputs.formats", f)?;
    }
    if let Some(TitleSpec::Text(t)) = &c.config.outputs.title {
        if !valid_label(t) {
            return Err(bad(
                &c.path,
                "outputs.title",
                "expected a title of 1 to 200 characters without control characters, or false",
            ));
        }
    }
    for (i, m) in c.config.methods.iter().enumerate() {
        if let Some(l) = &m.label {
            if !valid_label(l) {
                return Err(bad(
                    &c.path,
                    format!("methods[{i}].label"),
                    "expected a display name of 1 to 200 characters without control characters",
                ));
            }
        }
    }
    for (i, p) in c.config.outputs.plots.iter().enumerate() {
        let columns = p.metrics.iter().chain(p.x.iter()).chain(p.by.iter());
        let pivot = p
            .rows
            .iter()
            .chain(p.columns.iter())
            .chain(p.metric.iter())
            .chain(p.lead.iter());
        for m in columns.chain(pivot) {
            if !CASE_COLUMNS.contains(&m.as_str()) {
                return Err(bad(
                    &c.path,
                    format!("outputs.plots[{i}]"),
                    format!(
                        "{m:?} is not a cases.csv column; expected one of {}",
                        CASE_COLUMNS.join(", ")
                    ),
                ));
            }
        }
        for m in &p.methods {
            if !c.methods.iter().any(|x| x.name == *m) {
                return Err(bad(
                    &c.path,
                    format!("outputs.plots[{i}].methods"),
                    format!("{m:?} is not the name of a [[methods]] entry"),
                ));
            }
        }
        if let Some(f) = &p.file {
            if !valid_name(f) {
                return Err(bad(
                    &c.path,
                    format!("outputs.plots[{i}].file"),
                    "expected a plain file stem (letters, digits, - _ .)",
                ));
            }
        }
        check_plot_kind(c, i, p)?;
        if let Some(s) = &p.show {
            if s != "results" && s != "fits" {
                return Err(bad(
                    &c.path,
                    format!("outputs.plots[{i}].show"),
                    format!("expected \"results\" or \"fits\", got {s:?}"),
                ));
            }
        }
    }
    Ok(())
}

/// The keys a plot kind needs, and keys that belong to other kinds.
fn check_plot_kind(c: &LoadedConfig, i: usize, p: &PlotSpec) -> Result<()> {
    let key = |k: &str| format!("outputs.plots[{i}].{k}");
    let pivot = p.kind == PlotKind::Pivot;
    if p.kind == PlotKind::CurvePanels {
        if p.curves.is_empty() {
            return Err(bad(
                &c.path,
                key("curves"),
                "curve panels need `curves`: curves.csv curve names, one panel each",
            ));
        }
        if let Some(k) = p.curves.iter().find(|k| !valid_name(k)) {
            return Err(bad(
                &c.path,
                key("curves"),
                format!("{k:?} is not a curve name"),
            ));
        }
    } else if !p.curves.is_empty() {
        return Err(bad(
            &c.path,
            key("curves"),
            "only `kind = \"curve_panels\"` takes `curves`",
        ));
    }
    for (k, set) in [
        ("rows", p.rows.is_some()),
        ("columns", p.columns.is_some()),
        ("metric", p.metric.is_some()),
    ] {
        if pivot && !set {
            return Err(bad(
                &c.path,
                key(k),
                "pivot tables need `rows`, `columns` and `metric` (cases.csv columns)",
            ));
        }
        if !pivot && set {
            return Err(bad(
                &c.path,
                key(k),
                "only `kind = \"pivot\"` takes this key",
            ));
        }
    }
    let pivot_only = [
        ("scale", p.scale.is_some()),
        ("digits", p.digits.is_some()),
        ("lead", !p.lead.is_empty()),
        ("lead_from", p.lead_from.is_some()),
    ];
    if let Some((k, _)) = pivot_only.iter().find(|(_, set)| *set && !pivot) {
        return Err(bad(
            &c.path,
            key(k),
            "only `kind = \"pivot\"` takes this key",
        ));
    }
    if let Some(s) = p.scale {
        if !(s.is_finite() && s != 0.0) {
            return Err(bad(
                &c.path,
                key("scale"),
                format!("expected a finite non-zero factor, got {s}"),
            ));
        }
    }
    if let Some((k, _)) = p.labels.iter().find(|(_, v)| !valid_label(v)) {
        return Err(bad(
            &c.path,
            key(&format!("labels.{k}")),
            "expected a display name of 1 to 200 characters without control characters",
        ));
    }
    if let Some(f) = &p.formats {
        check_formats(c, &key("formats"), f)?;
    }
    Ok(())
}

fn resolve(config: &Config, path: &Path) -> Result<Vec<NamedMethod>> {
    if !valid_name(&config.name) {
        return Err(bad(
            path,
            "name",
            format!(
                "expected a folder name of letters, digits, '-', '_' or '.', got {:?}",
                config.name
            ),
        ));
    }
    if config.methods.is_empty() {
        return Err(bad(
            path,
            "methods",
            "expected at least one [[methods]] entry",
        ));
    }
    let mut out: Vec<NamedMethod> = Vec::new();
    for (i, m) in config.methods.iter().enumerate() {
        let key = |k: &str| format!("methods[{i}].{k}");
        if !valid_name(&m.name) {
            return Err(bad(
                path,
                key("name"),
                format!(
                    "expected letters, digits, '-', '_' or '.', got {:?}",
                    m.name
                ),
            ));
        }
        if out.iter().any(|o| o.name == m.name) {
            return Err(bad(
                path,
                key("name"),
                format!("{:?} is used twice", m.name),
            ));
        }
        let not_for = |field: &str, set: bool| -> Result<()> {
            if set {
                Err(bad(
                    path,
                    key(field),
                    format!("does not apply to kind = {:?}", kind_str(m.kind)),
                ))
            } else {
                Ok(())
            }
        };
        // Simulated users (random, extremity): how many key points they pick.
        let keypoint_count = || -> Result<usize> {
            m.count
                .ok_or_else(|| bad(path, key("count"), "expected the number of key points"))
        };
        let pipe = merge_pipeline!(m, config.defaults;
            n_candidates, seed, epsilon, error_norm, max_keypoints, mode, fps, groups,
            gamma_logr, gamma_s, n_groups, use_ediff, lambda, max_swap_passes, kmeans_sample,
            arap_max_iter, selection_poses, frame, align, refine, target_weights, weights,
            target_correspondence, target_noise, target_noise_seed);
        let bdt = bdt_options(&pipe, config.seed);
        bdt.align
            .check_frame(bdt.frame)
            .map_err(|e| bad(path, key("align"), e.to_string()))?;
        let target = target_points(&pipe, &bdt);
        let seed = pipe.seed.unwrap_or(config.seed);
        if m.kind != MethodKind::Fbt {
            not_for("fbt", m.fbt.is_some())?;
        }
        let no_target_keys = || -> Result<()> {
            not_for(
                "target_correspondence",
                pipe.target_correspondence.is_some(),
            )?;
            not_for("target_noise", pipe.target_noise.is_some())?;
            not_for("target_noise_seed", pipe.target_noise_seed.is_some())
        };
        // Keys of the simulated users and of clustering, which the FBT and
        // baseline kinds do not take.
        let no_bdt_user_keys = || -> Result<()> {
            not_for("count", m.count.is_some())?;
            not_for("pool", m.pool.is_some())?;
            not_for("strategy", m.strategy.is_some())?;
            not_for("jitter", m.jitter.is_some())?;
            not_for("handles", m.handles.is_some())?;
            not_for("features", m.features.is_some())?;
            not_for("examples", m.examples.is_some())?;
            not_for("n_clusters", m.n_clusters.is_some())
        };
        // Keys of BDT's transfer stage (how the transforms act on B), which
        // the baselines that take BDT's key points as markers do not use.
        let no_transfer_stage_keys = || -> Result<()> {
            not_for("frame", m.frame.is_some())?;
            not_for("align", m.align.is_some())?;
            not_for("refine", m.refine.is_some())?;
            not_for("target_weights", m.target_weights.is_some())
        };
        // Every key of the BDT pipeline (selection, fit, transfer), for the
        // kinds that select no key points. Set in [defaults] they are shared
        // with the other methods and do not apply; set on the entry itself
        // they are an error.
        let no_pipeline_keys = || -> Result<()> {
            no_transfer_stage_keys()?;
            for (field, set) in [
                ("n_candidates", m.n_candidates.is_some()),
                ("epsilon", m.epsilon.is_some()),
                ("error_norm", m.error_norm.is_some()),
                ("max_keypoints", m.max_keypoints.is_some()),
                ("mode", m.mode.is_some()),
                ("fps", m.fps.is_some()),
                ("groups", m.groups.is_some()),
                ("gamma_logr", m.gamma_logr.is_some()),
                ("gamma_s", m.gamma_s.is_some()),
                ("n_groups", m.n_groups.is_some()),
                ("use_ediff", m.use_ediff.is_some()),
                ("lambda", m.lambda.is_some()),
                ("max_swap_passes", m.max_swap_passes.is_some()),
                ("kmeans_sample", m.kmeans_sample.is_some()),
                ("arap_max_iter", m.arap_max_iter.is_some()),
                ("selection_poses", m.selection_poses.is_some()),
                ("weights", m.weights.is_some()),
            ] {
                not_for(field, set)?;
            }
            Ok(())
        };
        let automatic = KeypointSource::Automatic {
            selection_poses: pipe.selection_poses,
        };
        let method = match m.kind {
            MethodKind::Fbt => {
                no_bdt_user_keys()?;
                no_target_keys()?;
                let spec = m.fbt.clone().ok_or_else(|| {
                    bad(
                        path,
                        key("fbt"),
                        "expected an fbt table, e.g. fbt = { task = \"completion\", q = 4 }",
                    )
                })?;
                spec.check()
                    .map_err(|(k, msg)| bad(path, key(&format!("fbt.{k}")), msg))?;
                Method::Fbt { spec, seed }
            }
            MethodKind::Identity => {
                // Pipeline keys inherited from [defaults] do not apply and
                // are ignored; set on the entry itself they are an error.
                no_bdt_user_keys()?;
                no_pipeline_keys()?;
                not_for("target_correspondence", m.target_correspondence.is_some())?;
                not_for("target_noise", m.target_noise.is_some())?;
                not_for("target_noise_seed", m.target_noise_seed.is_some())?;
                Method::Transfer(TransferMethod::Identity)
            }
            MethodKind::SumnerOracle => {
                no_bdt_user_keys()?;
                no_target_keys()?;
                no_pipeline_keys()?;
                Method::Transfer(TransferMethod::SumnerOracle)
            }
            MethodKind::Sumner => {
                no_bdt_user_keys()?;
                no_transfer_stage_keys()?;
                Method::Transfer(TransferMethod::Sumner {
                    keypoints: automatic,
                    target,
                    options: bdt.keypoints,
                })
            }
            MethodKind::Cage => {
                no_bdt_user_keys()?;
                no_transfer_stage_keys()?;
                Method::Transfer(TransferMethod::Cage {
                    keypoints: automatic,
                    target,
                    options: bdt.keypoints,
                })
            }
            MethodKind::Bdt => {
                no_bdt_user_keys()?;
                Method::Transfer(TransferMethod::Bdt {
                    keypoints: automatic,
                    target,
                    options: bdt,
                })
            }
            MethodKind::BdtRandom => {
                not_for("strategy", m.strategy.is_some())?;
                not_for("jitter", m.jitter.is_some())?;
                not_for("handles", m.handles.is_some())?;
                not_for("features", m.features.is_some())?;
                not_for("examples", m.examples.is_some())?;
                not_for("n_clusters", m.n_clusters.is_some())?;
                not_for("selection_poses", pipe.selection_poses.is_some())?;
                let count = keypoint_count()?;
                Method::Transfer(TransferMethod::Bdt {
                    keypoints: KeypointSource::Random {
                        count,
                        seed,
                        pool: m.pool.unwrap_or_default(),
                    },
                    target,
                    options: bdt,
                })
            }
            MethodKind::BdtExtremity => {
                not_for("pool", m.pool.is_some())?;
                not_for("handles", m.handles.is_some())?;
                not_for("features", m.features.is_some())?;
                not_for("examples", m.examples.is_some())?;
                not_for("n_clusters", m.n_clusters.is_some())?;
                not_for("selection_poses", pipe.selection_poses.is_some())?;
                let count = keypoint_count()?;
                let jitter = m.jitter.unwrap_or(0.0);
                Method::Transfer(TransferMethod::Bdt {
                    keypoints: KeypointSource::Extremity {
                        count,
                        strategy: m.strategy.unwrap_or_default(),
                        jitter,
                        seed,
                    },
                    target,
                    options: bdt,
                })
            }
            MethodKind::Clustering => {
                not_for("count", m.count.is_some())?;
                not_for("pool", m.pool.is_some())?;
                not_for("strategy", m.strategy.is_some())?;
                not_for("jitter", m.jitter.is_some())?;
                no_target_keys()?;
                let d = Clustering::default();
                let handles = m.handles.unwrap_or(d.handles);
                Method::Clustering(Clustering {
                    handles,
                    features: features(m.features, &pipe),
                    examples: m.examples.unwrap_or(d.examples),
                    n_clusters: m.n_clusters,
                    seed,
                    mode: bdt.keypoints.mode,
                    weights: bdt.keypoints.weights,
                })
            }
        };
        out.push(NamedMethod {
            name: m.name.clone(),
            group: m.group.clone().unwrap_or_else(|| m.name.clone()),
            method,
        });
    }
    Ok(out)
}

fn kind_str(k: MethodKind) -> &'static str {
    match k {
        MethodKind::Bdt => "bdt",
        MethodKind::BdtRandom => "bdt_random",
        MethodKind::BdtExtremity => "bdt_extremity",
        MethodKind::Clustering => "clustering",
        MethodKind::Fbt => "fbt",
        MethodKind::Sumner => "sumner",
        MethodKind::SumnerOracle => "sumner_oracle",
        MethodKind::Cage => "cage",
        MethodKind::Identity => "identity",
    }
}

/// Group features: `kind` (default: the library's, [`GroupFeatures::default`])
/// with the pipeline's γ (default: the paper's).
fn features(kind: Option<FeatureKind>, p: &PipelineSpec) -> GroupFeatures {
    GroupFeatures::new(
        kind.unwrap_or_default(),
        p.gamma_logr.unwrap_or(GroupFeatures::GAMMA_LOGR),
        p.gamma_s.unwrap_or(GroupFeatures::GAMMA_S),
    )
}

/// The BDT options of a method: every key not set falls back to
/// [`BdtOptions::default`] (the CLI's defaults too), the seed to the
/// config's.
/// (Ranges are checked while reading, see the keys' definitions.)
fn bdt_options(p: &PipelineSpec, seed: u64) -> BdtOptions {
    let d = BdtOptions::default();
    let dk = &d.keypoints;
    let mut arap = dk.arap.clone();
    arap.lambda = p.lambda.unwrap_or(arap.lambda);
    arap.use_ediff = p.use_ediff.unwrap_or(arap.use_ediff);
    let fast = FastOptions {
        kmeans_sample: p.kmeans_sample.unwrap_or(dk.fast.kmeans_sample),
        arap_max_iter: p.arap_max_iter.unwrap_or(dk.fast.arap_max_iter),
        ..dk.fast.clone()
    };
    let groups = match p.groups {
        Some(kind) => features(Some(kind), p),
        None => match dk.groups {
            // The library default with this pipeline's γ.
            GroupFeatures::Weights => GroupFeatures::Weights,
            GroupFeatures::RotationScale { .. } => features(Some(FeatureKind::RotationScale), p),
            GroupFeatures::Augmented { .. } => features(Some(FeatureKind::Augmented), p),
        },
    };
    let keypoints = KeypointOptions {
        n_candidates: p.n_candidates.unwrap_or(dk.n_candidates),
        seed: p.seed.unwrap_or(seed),
        epsilon: p.epsilon.unwrap_or(dk.epsilon),
        max_keypoints: p.max_keypoints.unwrap_or(dk.max_keypoints),
        mode: p.mode.unwrap_or(dk.mode),
        fps: p.fps.unwrap_or(dk.fps),
        groups,
        n_groups: p.n_groups.or(dk.n_groups),
        arap,
        max_swap_passes: p.max_swap_passes.unwrap_or(dk.max_swap_passes),
        error_norm: p.error_norm.unwrap_or(dk.error_norm),
        fast,
        weights: match p.weights {
            Some(mode) => BbwOptions { mode, ..dk.weights },
            None => dk.weights,
        },
        ..dk.clone()
    };
    BdtOptions {
        keypoints,
        frame: p.frame.unwrap_or(d.frame),
        align: p.align.unwrap_or(d.align),
        target_weights: p.target_weights.unwrap_or(d.target_weights),
        refine: p.refine.unwrap_or(d.refine),
    }
}

/// The target key point options of a method (defaults:
/// [`TargetPoints::default`]; the automatic correspondence is seeded with
/// the selection seed).
fn target_points(p: &PipelineSpec, bdt: &BdtOptions) -> TargetPoints {
    let d = TargetPoints::default();
    TargetPoints {
        correspondence: p.target_correspondence.clone().unwrap_or(d.correspondence),
        landmarks: d.landmarks,
        seed: bdt.keypoints.seed,
        noise: p.target_noise.unwrap_or(d.noise),
        noise_seed: p.target_noise_seed.unwrap_or(d.noise_seed),
    }
}

impl Config {
    /// The config without its output-only fields (`description`,
    /// `outputs`, the methods' `label`s): what the stored results depend
    /// on.
    pub fn hashed_part(&self) -> Config {
        let d = DefectPolicy::default();
        Config {
            description: None,
            outputs: OutputSpec::default(),
            dataset: DatasetSpec {
                strict: None,
                // The default stated or left out: the same results.
                repair: self.dataset.repair.filter(|&r| r != d.repair),
                ..self.dataset.clone()
            },
            methods: self
                .methods
                .iter()
                .map(|m| MethodEntry {
                    label: None,
                    ..m.clone()
                })
                .collect(),
            ..self.clone()
        }
    }

    /// [`Config::hashed_part`] without where the data live (dataset paths
    /// emptied): what the result store's key is made of, with the content
    /// of the data ([`super::fingerprint`]), so that moving the data or
    /// spelling their path otherwise keeps the results.
    pub fn key_part(&self) -> Config {
        let mut c = self.hashed_part();
        if let Some(f) = &mut c.dataset.faust {
            f.path = PathBuf::new();
        }
        if let Some(f) = &mut c.dataset.tosca {
            f.path = PathBuf::new();
        }
        if let Some(f) = &mut c.dataset.manifest {
            f.path = PathBuf::new();
        }
        c
    }

    /// FNV-1a 64 of the canonical JSON of [`Config::hashed_part`], as 16 hex digits.
    pub fn hash(&self) -> String {
        let json = serde_json::to_string(&self.hashed_part()).unwrap_or_default();
        format!("{:016x}", crate::data::fnv1a(json.as_bytes()))
    }
}

pub use crate::data::fnv1a;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_paths_from_offsets() {
        let text = "name = \"x\"\n[dataset.faust]\npath = 3\n[[methods]]\nname = \"a\"\n\
                    [[methods]]\nname = \"b\"\nn_candidates = \"many\"\n[methods.extra]\nfoo = 1\n";
        let off = text.find("3\n").unwrap();
        assert_eq!(key_at(text, off), ("dataset.faust.path".to_string(), 3));
        let off = text.find("\"many\"").unwrap();
        assert_eq!(key_at(text, off).0, "methods[1].n_candidates");
        let off = text.find("foo").unwrap();
        assert_eq!(key_at(text, off).0, "methods[1].extra.foo");
        let t2 = "[[methods]]\nbdt = { a = 1, b = \"x\" }\n";
        let off = t2.find("\"x\"").unwrap();
        assert_eq!(key_at(t2, off).0, "methods[0].bdt.b");
    }

    #[test]
    fn hash_ignores_outputs_only() {
        let p = Path::new("x.toml");
        let a = parse_unchecked_in(
            "name = \"a\"\n[[methods]]\nname = \"m\"\nkind = \"bdt\"\n",
            p,
            &DataRoot::default(),
        )
        .unwrap();
        let b = parse_unchecked_in(
            "name = \"a\"\ndescription = \"d\"\n[[methods]]\nname = \"m\"\nkind = \"bdt\"\n\
             [outputs]\nrender_cases = 3\n",
            p,
            &DataRoot::default(),
        )
        .unwrap();
        let c = parse_unchecked_in(
            "name = \"a\"\n[[methods]]\nname = \"m\"\nkind = \"bdt\"\nn_candidates = 5\n",
            p,
            &DataRoot::default(),
        )
        .unwrap();
        assert_eq!(a.config.hash(), b.config.hash());
        assert_ne!(a.config.hash(), c.config.hash());
    }
}

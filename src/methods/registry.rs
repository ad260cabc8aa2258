//! The registry of method kinds: every kind a config's `kind = "..."`,
//! `deformlab transfer --method` and the Python binding's `method=` can
//! name, with the keys it uses, and one function that turns a method entry
//! ([`MethodEntry`]: the same schema for all three front-ends) into a
//! library value ([`Method`]).
//!
//! A key set on an entry that its kind does not use is an error naming the
//! key and the kind ([`resolve_entry`]); the same key in a config's
//! `[defaults]` is shared by every method and ignored by the kinds that do
//! not use it. `deformlab methods` prints this table (and
//! `docs/methods.md` is generated from it).
//!
//! # How to add a method kind
//!
//! 1. This file: a variant in `method_kinds!` below (the `kind` name is
//!    its snake_case spelling) and its row in [`MethodKind::info`] (the
//!    compiler points at the match): name, family, one-line summary, the
//!    keys it uses and its constructor, a closure over [`Resolving`].
//! 2. The method: for a baseline that takes BDT's key point pairs as
//!    markers, one function of type [`MarkerFn`] in
//!    `src/methods/transfer.rs`, named in the row by
//!    `|r| Ok(r.markers(my_markers))`. (A method with its own kind of
//!    input is a [`TransferMethod`] variant; the compiler lists its arms.)
//!    A new option key is a field of [`MethodEntry`] below (with its
//!    range) and a name in the key lists of the kinds that use it.
//! 3. A `[[methods]]` entry with the new `kind` in a config.
//!
//! The harness, the CLI (`deformlab transfer --method`), Python
//! (`transfer(method=...)`), `deformlab methods` and `docs/methods.md`
//! read the registry; nothing else changes.

use serde::{Deserialize, Serialize};

use super::clustering::{Clustering, Examples};
use super::external::{callable, ExternalCommand, ExternalRunner, DEFAULT_TIMEOUT};
use super::fbt::FbtMethod;
use super::keypoints::{KeypointSource, Pool, Strategy};
use super::spec::{Epsilon, FbtSpec, MaxKeypoints, NCandidates};
use super::target::{TargetCorrespondence, TargetPoints};
use super::transfer::{cage_markers, rigid_markers, sumner_markers, MarkerBaseline, MarkerFn};
use super::transfer::{BdtOptions, TransferMethod};
use crate::ops::FpsMetric;
use crate::range::{Int, NonNegative, Positive, Real, UnitInterval, Weight};
use crate::skin::bbw::BbwOptions;
use crate::skin::bbw::WeightMode;
use crate::skin::{FeatureKind, GroupFeatures};
use crate::transfer::{ErrorNorm, FrameAlign, SelectionMode, TargetWeights, TransferFrame};
use crate::transfer::{FastOptions, KeypointOptions};

macro_rules! method_kinds {
    ($($(#[$m:meta])* $v:ident,)*) => {
        /// Method kinds: a config's `kind = "..."`, `deformlab transfer
        /// --method`, the binding's `method=`. Each has its row in
        /// [`MethodKind::info`].
        #[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
        #[serde(rename_all = "snake_case")]
        pub enum MethodKind {
            $($(#[$m])* $v,)*
        }

        impl MethodKind {
            /// Every kind, in declaration order (the reference's order).
            pub const ALL: &'static [MethodKind] = &[$(MethodKind::$v),*];
        }
    };
}

method_kinds! {
    /// BDT with automatically selected key points (Algorithm 1).
    #[default]
    Bdt,
    /// BDT with random key points (simulated user).
    BdtRandom,
    /// BDT with key points at geodesic extremities (simulated user).
    BdtExtremity,
    /// Sumner & Popović deformation transfer with BDT's key points as
    /// correspondence markers ([`crate::baselines::sumner`]).
    Sumner,
    /// Sumner & Popović deformation transfer with the identity triangle
    /// correspondence (shared connectivity only).
    SumnerOracle,
    /// Cage-based spatial deformation transfer with BDT's key points as
    /// markers ([`crate::baselines::cage`]).
    Cage,
    /// The target left unchanged (`B′ = B`): the floor of every transfer
    /// evaluation.
    Identity,
    /// B moved by the best rigid motion of A → A′ at the key points.
    Rigid,
    /// A command the user gives, run per case ([`crate::methods::external`]).
    External,
    /// A function a host program registered (e.g. Python's
    /// `run(config, methods={...})`; [`crate::methods::external`]).
    Callable,
    /// Rotation-group clustering only (BDT Fig. 4), scored against labels.
    Clustering,
    /// FBT: one of its tasks ([`crate::experiment::fbt`]).
    Fbt,
}

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
            #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Real::<Weight>::de")]
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
        /// `kind = "external"`: the command run per case (placeholders
        /// `{source}`, `{poses}`, `{target}`, `{markers}`, `{out}`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub command: Option<String>,
        /// `kind = "external"`: seconds before the command is killed (default 600).
        #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "Real::<Positive>::de")]
        pub timeout: Option<f64>,
        /// `kind = "callable"`: the registered function's name.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub function: Option<String>,
        /// `kind = "callable"`: pass BDT's key point pairs (default false).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub markers: Option<bool>,
        /// `kind = "fbt"`: the task and its options ([`FbtSpec`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub fbt: Option<FbtSpec>,
    }
}

/// An entry's pipeline keys over the `[defaults]` ones.
macro_rules! merge_pipeline {
    ($a:expr, $b:expr; $($f:ident),*) => {
        PipelineSpec { $($f: $a.$f.clone().or_else(|| $b.$f.clone()),)* }
    };
}

/// What a method kind produces, and so how it is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// Transfers A → A′ to B; measured against B′'s ground truth.
    Transfer,
    /// Rotation-group clustering of the source; scored against labels.
    Clustering,
    /// FBT's tasks (registration, completion, ...).
    Fbt,
}

impl Family {
    /// The family's name (in the reference and the binding's `method_kinds`).
    pub fn name(self) -> &'static str {
        match self {
            Family::Transfer => "transfer",
            Family::Clustering => "clustering",
            Family::Fbt => "fbt",
        }
    }
}

/// How an entry becomes a library value: the kind's constructor, given
/// the entry's keys resolved over the defaults ([`Resolving`]).
pub type Build = fn(&Resolving) -> std::result::Result<Method, (String, String)>;

/// One kind of the registry.
#[derive(Clone, Copy, Debug)]
pub struct KindInfo {
    /// The config's `kind` (and `--method`, Python's `method=`).
    pub name: &'static str,
    pub family: Family,
    /// One line for the reference.
    pub summary: &'static str,
    /// The entry keys the kind uses (besides `name`, `kind`, `group`,
    /// `label`), in groups.
    pub keys: &'static [&'static [&'static str]],
    /// The kind's constructor.
    pub build: Build,
}

impl KindInfo {
    /// Whether the kind uses entry key `key`.
    pub fn uses(&self, key: &str) -> bool {
        COMMON_KEYS.contains(&key) || self.keys.iter().any(|g| g.contains(&key))
    }

    /// Every key the kind uses, in the table's order.
    pub fn key_list(&self) -> Vec<&'static str> {
        self.keys.iter().flat_map(|g| g.iter().copied()).collect()
    }
}

/// Keys of every entry.
pub const COMMON_KEYS: &[&str] = &["name", "kind", "group", "label"];

/// Key point selection and the fit on A (Algorithm 1, Eq. 2–5).
const SELECTION: &[&str] = &[
    "n_candidates",
    "seed",
    "epsilon",
    "error_norm",
    "max_keypoints",
    "mode",
    "fps",
    "groups",
    "gamma_logr",
    "gamma_s",
    "n_groups",
    "use_ediff",
    "lambda",
    "max_swap_passes",
    "kmeans_sample",
    "arap_max_iter",
    "weights",
];
/// Algorithm 1 on the first m poses only (the automatic selection).
const SELECTION_POSES: &[&str] = &["selection_poses"];
/// BDT's transfer stage: how the transforms act on B.
const TRANSFER_STAGE: &[&str] = &["frame", "align", "refine", "target_weights"];
/// How the target key points are found.
const TARGET: &[&str] = &["target_correspondence", "target_noise", "target_noise_seed"];

impl MethodKind {
    /// The kind's row of the registry: name, family, summary, the keys it
    /// uses and its constructor.
    pub fn info(self) -> KindInfo {
        let row = |name, family, summary, keys, build| KindInfo {
            name,
            family,
            summary,
            keys,
            build,
        };
        match self {
            MethodKind::Bdt => row(
                "bdt",
                Family::Transfer,
                "BDT: automatic key points (Algorithm 1), transforms fitted on A′, LBS on B",
                &[SELECTION, SELECTION_POSES, TRANSFER_STAGE, TARGET],
                |r| r.bdt(r.automatic()),
            ),
            MethodKind::BdtRandom => row(
                "bdt_random",
                Family::Transfer,
                "BDT with `count` random key points (a simulated user)",
                &[&["count", "pool"], SELECTION, TRANSFER_STAGE, TARGET],
                |r| {
                    r.bdt(KeypointSource::Random {
                        count: r.count()?,
                        seed: r.seed,
                        pool: r.entry.pool.unwrap_or_default(),
                    })
                },
            ),
            MethodKind::BdtExtremity => row(
                "bdt_extremity",
                Family::Transfer,
                "BDT with `count` key points at geodesic extremities (a simulated user)",
                &[
                    &["count", "strategy", "jitter"],
                    SELECTION,
                    TRANSFER_STAGE,
                    TARGET,
                ],
                |r| {
                    r.bdt(KeypointSource::Extremity {
                        count: r.count()?,
                        strategy: r.entry.strategy.unwrap_or_default(),
                        jitter: r.entry.jitter.unwrap_or(0.0),
                        seed: r.seed,
                    })
                },
            ),
            MethodKind::Sumner => row(
                "sumner",
                Family::Transfer,
                "Sumner & Popović deformation transfer, BDT's key point pairs as markers",
                &[SELECTION, SELECTION_POSES, TARGET],
                |r| Ok(r.markers(sumner_markers)),
            ),
            MethodKind::SumnerOracle => row(
                "sumner_oracle",
                Family::Transfer,
                "Sumner & Popović with the identity triangle correspondence (full \
                 correspondence: the oracle; shared connectivity only)",
                &[],
                |_| Ok(Method::Transfer(TransferMethod::SumnerOracle)),
            ),
            MethodKind::Cage => row(
                "cage",
                Family::Transfer,
                "cage-based deformation transfer, BDT's key point pairs as markers",
                &[SELECTION, SELECTION_POSES, TARGET],
                |r| Ok(r.markers(cage_markers)),
            ),
            MethodKind::Identity => row(
                "identity",
                Family::Transfer,
                "B left unchanged (B′ = B): the floor of every transfer evaluation",
                &[],
                |_| Ok(Method::Transfer(TransferMethod::Identity)),
            ),
            MethodKind::Rigid => row(
                "rigid",
                Family::Transfer,
                "B moved rigidly: the best rigid motion of A → A′ at BDT's key points (a \
                 baseline that ignores articulation)",
                &[SELECTION, SELECTION_POSES, TARGET],
                |r| Ok(r.markers(rigid_markers)),
            ),
            MethodKind::External => row(
                "external",
                Family::Transfer,
                "your method: a `command` run per case on the case's files (A, A′, B, \
                 optionally BDT's key point pairs), its results read back and evaluated like \
                 every method (docs/own-method.md)",
                &[&["command", "timeout"], SELECTION, SELECTION_POSES, TARGET],
                |r| r.external(),
            ),
            MethodKind::Callable => row(
                "callable",
                Family::Transfer,
                "your method as a function of the host program (Python: \
                 `deformlab.run(config, methods={\"name\": fn})`), named by `function`; \
                 `markers = true` passes BDT's key point pairs",
                &[&["function", "markers"], SELECTION, SELECTION_POSES, TARGET],
                |r| r.callable(),
            ),
            MethodKind::Clustering => row(
                "clustering",
                Family::Clustering,
                "rotation-group clustering of the source (BDT Fig. 4), scored against labels",
                &[
                    &["handles", "features", "examples", "n_clusters"],
                    &["seed", "gamma_logr", "gamma_s", "mode", "weights"],
                ],
                |r| {
                    let d = Clustering::default();
                    let m = r.entry;
                    Ok(Method::Clustering(Clustering {
                        handles: m.handles.unwrap_or(d.handles),
                        features: features(m.features, &r.pipe),
                        examples: m.examples.unwrap_or(d.examples),
                        n_clusters: m.n_clusters,
                        seed: r.seed,
                        mode: r.bdt.keypoints.mode,
                        weights: r.bdt.keypoints.weights,
                    }))
                },
            ),
            MethodKind::Fbt => row(
                "fbt",
                Family::Fbt,
                "FBT: a task (`fbt = { task = ... }`: registration, completion, ...) and its \
                 options",
                &[&["fbt", "seed"]],
                |r| {
                    let spec = r.entry.fbt.clone().ok_or_else(|| {
                        (
                            "fbt".to_string(),
                            "expected an fbt table, e.g. fbt = { task = \"completion\", q = 4 }"
                                .to_string(),
                        )
                    })?;
                    let fbt = FbtMethod::new(spec, r.seed)
                        .map_err(|(k, msg)| (format!("fbt.{k}"), msg))?;
                    Ok(Method::Fbt(fbt))
                },
            ),
        }
    }

    /// The kind's name (`kind = "..."`).
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// The kind named `name`.
    pub fn from_name(name: &str) -> Option<MethodKind> {
        MethodKind::ALL.iter().copied().find(|k| k.name() == name)
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
    /// An FBT task ([`super::fbt`]), resolved once.
    Fbt(FbtMethod),
}

impl Method {
    /// Short kind name (as in the config).
    pub fn kind_name(&self) -> &'static str {
        match self {
            Method::Transfer(t) => t.kind_name(),
            Method::Clustering(_) => "clustering",
            Method::Fbt(_) => "fbt",
        }
    }

    /// Whether the method transfers to a target (and is measured against a
    /// ground truth).
    pub fn transfers(&self) -> bool {
        match self {
            Method::Transfer(_) => true,
            Method::Clustering(_) | Method::Fbt(_) => false,
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

/// An entry of kind `kind` from keys and values (the CLI's `--opt`, the
/// binding's keyword options): each key is read alone first, so that a
/// value out of range or of the wrong type names its key. Errors are
/// `(key, message)`; the key is empty for an unknown kind.
pub fn entry_from_table(
    kind: &str,
    table: &toml::Table,
) -> std::result::Result<MethodEntry, (String, String)> {
    if MethodKind::from_name(kind).is_none() {
        return Err((
            String::new(),
            format!(
                "unknown method kind {kind:?}; expected one of {}",
                MethodKind::ALL
                    .iter()
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    let with = |pairs: &mut dyn Iterator<Item = (&String, &toml::Value)>| {
        let mut t = toml::Table::new();
        t.insert("name".into(), "method".into());
        t.insert("kind".into(), kind.into());
        for (k, v) in pairs {
            t.insert(k.clone(), v.clone());
        }
        toml::Value::Table(t).try_into::<MethodEntry>()
    };
    for (k, v) in table {
        if COMMON_KEYS.contains(&k.as_str()) {
            return Err((k.clone(), "is not an option of the method".to_string()));
        }
        with(&mut std::iter::once((k, v)))
            .map_err(|e| (k.clone(), e.message().trim().to_string()))?;
    }
    with(&mut table.iter()).map_err(|e| (String::new(), e.message().trim().to_string()))
}

/// A transfer method from its kind and options, resolved as a config entry
/// with no `[defaults]` and the library's default seed: what `deformlab
/// transfer --method KIND --opt KEY=VALUE` and the binding's
/// `transfer(method=KIND, **options)` run. Errors are `(key, message)`, the
/// key empty when the kind itself is wrong.
pub fn transfer_method(
    kind: &str,
    table: &toml::Table,
) -> std::result::Result<TransferMethod, (String, String)> {
    let entry = entry_from_table(kind, table)?;
    match resolve_entry(
        &entry,
        &PipelineSpec::default(),
        KeypointOptions::default().seed,
    )? {
        Method::Transfer(m) => Ok(m),
        Method::Clustering(_) | Method::Fbt(_) => {
            Err((String::new(), format!("{kind:?} is not a transfer method")))
        }
    }
}

/// The entry keys set on `m` (besides `name`, `kind`, `group`, `label`),
/// in the schema's order: read from the entry's serialisation, so that a
/// new field of [`MethodEntry`] is checked without listing it here.
pub fn keys_set(m: &MethodEntry) -> Vec<String> {
    match serde_json::to_value(m) {
        Ok(serde_json::Value::Object(map)) => map
            .keys()
            .filter(|k| !COMMON_KEYS.contains(&k.as_str()))
            .cloned()
            .collect(),
        _ => Vec::new(),
    }
}

/// Refuses the first key set on `m` that its kind does not use:
/// `(key, message)`.
pub fn check_keys(m: &MethodEntry) -> std::result::Result<(), (String, String)> {
    let info = m.kind.info();
    for k in keys_set(m) {
        if !info.uses(&k) {
            let uses = info.key_list();
            return Err((
                k,
                format!(
                    "does not apply to kind = \"{}\" (it uses {})",
                    info.name,
                    if uses.is_empty() {
                        "no keys besides name, group and label".to_string()
                    } else {
                        uses.join(", ")
                    }
                ),
            ));
        }
    }
    Ok(())
}

/// An entry being resolved: its keys over the defaults, in the library's
/// types. A kind's constructor ([`KindInfo::build`]) reads it.
pub struct Resolving<'a> {
    /// The entry as written.
    pub entry: &'a MethodEntry,
    /// Its pipeline keys over `[defaults]`.
    pub pipe: PipelineSpec,
    /// BDT's options from them (selection, fit, transfer stage).
    pub bdt: BdtOptions,
    /// The method's seed (`seed`, else the config's).
    pub seed: u64,
    /// The target key points (correspondence, noise).
    pub target: TargetPoints,
}

impl Resolving<'_> {
    /// Algorithm 1's key points (on the first `selection_poses` poses).
    pub fn automatic(&self) -> KeypointSource {
        KeypointSource::Automatic {
            selection_poses: self.pipe.selection_poses,
        }
    }

    /// `count` (the simulated users' number of key points).
    pub fn count(&self) -> std::result::Result<usize, (String, String)> {
        self.entry.count.ok_or_else(|| {
            (
                "count".to_string(),
                "expected the number of key points".to_string(),
            )
        })
    }

    /// BDT with key points from `keypoints`.
    pub fn bdt(&self, keypoints: KeypointSource) -> std::result::Result<Method, (String, String)> {
        self.bdt
            .align
            .check_frame(self.bdt.frame)
            .map_err(|e| ("align".to_string(), e.to_string()))?;
        Ok(Method::Transfer(TransferMethod::Bdt {
            keypoints,
            target: self.target.clone(),
            options: self.bdt.clone(),
        }))
    }

    /// An external method: `command` (and `timeout`); BDT's key point
    /// options only when the command names `{markers}`.
    pub fn external(&self) -> std::result::Result<Method, (String, String)> {
        let m = self.entry;
        let text = m.command.as_deref().ok_or_else(|| {
            (
                "command".to_string(),
                "expected the command to run per case, e.g. \
                 \"python3 mine.py --source {source} --target {target} --out {out} {poses}\""
                    .to_string(),
            )
        })?;
        let timeout = m.timeout.unwrap_or(DEFAULT_TIMEOUT);
        let command =
            ExternalCommand::new(text, timeout).map_err(|e| ("command".to_string(), e))?;
        let keypoints = self.marker_source(
            command.uses_markers(),
            &["command", "timeout"],
            "this command does not take (it names no {markers})",
        )?;
        Ok(Method::Transfer(TransferMethod::External {
            runner: ExternalRunner::Command(command),
            keypoints,
            target: self.target.clone(),
            options: self.bdt.keypoints.clone(),
        }))
    }

    /// A function registered by the host program (`function`, `markers`).
    pub fn callable(&self) -> std::result::Result<Method, (String, String)> {
        let m = self.entry;
        let name = m.function.as_deref().ok_or_else(|| {
            (
                "function".to_string(),
                "expected the name of a registered function, e.g. function = \"mine\" with \
                 deformlab.run(config, methods={\"mine\": fn})"
                    .to_string(),
            )
        })?;
        let f = callable(name).map_err(|e| ("function".to_string(), e))?;
        let keypoints = self.marker_source(
            m.markers.unwrap_or(false),
            &["function", "markers"],
            "this function does not take (markers = false)",
        )?;
        Ok(Method::Transfer(TransferMethod::External {
            runner: ExternalRunner::Function(f),
            keypoints,
            target: self.target.clone(),
            options: self.bdt.keypoints.clone(),
        }))
    }

    /// Automatic key points when an external method takes marker pairs;
    /// else none, and a selection key set on the entry is an error.
    fn marker_source(
        &self,
        takes_markers: bool,
        own: &[&str],
        why: &str,
    ) -> std::result::Result<Option<KeypointSource>, (String, String)> {
        if takes_markers {
            return Ok(Some(self.automatic()));
        }
        match keys_set(self.entry)
            .into_iter()
            .find(|k| !own.contains(&k.as_str()))
        {
            Some(k) => Err((k, format!("configures the key point pairs, which {why}"))),
            None => Ok(None),
        }
    }

    /// A baseline that takes BDT's automatic key point pairs as markers
    /// and transfers with `run`, named by the entry's kind.
    pub fn markers(&self, run: MarkerFn) -> Method {
        Method::Transfer(TransferMethod::Markers {
            baseline: MarkerBaseline {
                name: self.entry.kind.name(),
                run,
            },
            keypoints: self.automatic(),
            target: self.target.clone(),
            options: self.bdt.keypoints.clone(),
        })
    }
}

/// The library value of entry `m`: its keys over `defaults` (a config's
/// `[defaults]`; keys there that the kind does not use are ignored), the
/// seed over `seed`. Errors are `(key, message)`, the key relative to the
/// entry (`count`, `fbt.q`).
pub fn resolve_entry(
    m: &MethodEntry,
    defaults: &PipelineSpec,
    seed: u64,
) -> std::result::Result<Method, (String, String)> {
    check_keys(m)?;
    let pipe = merge_pipeline!(m, defaults;
        n_candidates, seed, epsilon, error_norm, max_keypoints, mode, fps, groups,
        gamma_logr, gamma_s, n_groups, use_ediff, lambda, max_swap_passes, kmeans_sample,
        arap_max_iter, selection_poses, frame, align, refine, target_weights, weights,
        target_correspondence, target_noise, target_noise_seed);
    let bdt = bdt_options(&pipe, seed);
    let target = target_points(&pipe, &bdt);
    let r = Resolving {
        entry: m,
        seed: pipe.seed.unwrap_or(seed),
        pipe,
        bdt,
        target,
    };
    (m.kind.info().build)(&r)
}

/// Group features: `kind` (default: the library's, [`GroupFeatures::default`])
/// with the pipeline's γ (default: the paper's).
pub fn features(kind: Option<FeatureKind>, p: &PipelineSpec) -> GroupFeatures {
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
pub fn bdt_options(p: &PipelineSpec, seed: u64) -> BdtOptions {
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
pub fn target_points(p: &PipelineSpec, bdt: &BdtOptions) -> TargetPoints {
    let d = TargetPoints::default();
    TargetPoints {
        correspondence: p.target_correspondence.clone().unwrap_or(d.correspondence),
        landmarks: d.landmarks,
        seed: bdt.keypoints.seed,
        noise: p.target_noise.unwrap_or(d.noise),
        noise_seed: p.target_noise_seed.unwrap_or(d.noise_seed),
    }
}

/// The reference of the registry (Markdown): every kind, what it is, its
/// family and the entry keys it uses. `deformlab methods` prints it and
/// `docs/methods.md` is this text (a test holds them equal).
pub fn reference_markdown() -> String {
    let mut s = String::from(
        "# Method kinds\n\n\
         Generated by `deformlab methods` from the registry \
         (`src/methods/registry.rs`); do not edit by hand.\n\n\
         A method is a `[[methods]]` entry of a config (`kind = \"...\"`), \
         `deformlab transfer --method KIND --opt KEY=VALUE`, or \
         `deformlab.transfer(..., method=\"KIND\", KEY=VALUE)` in Python: one \
         schema, one resolution. Every entry takes `name`, `kind`, `group` and \
         `label`; a key the kind does not use is refused, naming the key and \
         the kind (in a config's `[defaults]` it is shared by every method and \
         ignored where unused). The ranges of the keys are in \
         `experiments/README.md`.\n\n\
         | kind | family | what it is |\n|---|---|---|\n",
    );
    for k in MethodKind::ALL {
        let i = k.info();
        s.push_str(&format!(
            "| `{}` | {} | {} |\n",
            i.name,
            i.family.name(),
            i.summary
        ));
    }
    s.push_str("\n## Keys per kind\n");
    for k in MethodKind::ALL {
        let i = k.info();
        let keys = i.key_list();
        s.push_str(&format!(
            "\n### `{}`\n\n{}\n",
            i.name,
            if keys.is_empty() {
                "No keys besides `name`, `kind`, `group`, `label`.".to_string()
            } else {
                keys.iter()
                    .map(|k| format!("`{k}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        ));
    }
    s
}

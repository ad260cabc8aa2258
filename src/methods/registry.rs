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
//! 1. `src/methods/registry.rs`: a [`MethodKind`] variant, its row in
//!    [`MethodKind::info`] (name, family, summary, keys) and its arm in
//!    [`resolve_entry`] (the compiler points at both: the matches are
//!    exhaustive).
//! 2. The method itself: for a transfer method, a [`TransferMethod`]
//!    variant with its arms in `src/methods/transfer.rs` (`run`,
//!    `kind_name`, `markers`; again pointed at by the compiler). A new
//!    option key is a field of [`MethodEntry`] in `src/methods/spec.rs`
//!    (with its range) and a name in the kind's key list.
//! 3. A `[[methods]]` entry with the new `kind` in a config.
//!
//! The harness, the CLI and Python need no change: they resolve entries
//! here and run [`TransferMethod::run`].

use serde::Serialize;

use super::spec::{FbtSpec, MethodEntry, PipelineSpec};
use crate::methods::{BdtOptions, Clustering, KeypointSource, TargetPoints, TransferMethod};
use crate::skin::bbw::BbwOptions;
use crate::skin::{FeatureKind, GroupFeatures};
use crate::transfer::{FastOptions, KeypointOptions};

pub use super::spec::MethodKind;

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
    /// Every kind, in the reference's order.
    pub const ALL: [MethodKind; 9] = [
        MethodKind::Bdt,
        MethodKind::BdtRandom,
        MethodKind::BdtExtremity,
        MethodKind::Sumner,
        MethodKind::SumnerOracle,
        MethodKind::Cage,
        MethodKind::Identity,
        MethodKind::Clustering,
        MethodKind::Fbt,
    ];

    /// The kind's row of the registry.
    pub fn info(self) -> KindInfo {
        let (name, family, summary, keys): (_, _, _, &'static [&'static [&'static str]]) =
            match self {
                MethodKind::Bdt => (
                    "bdt",
                    Family::Transfer,
                    "BDT: automatic key points (Algorithm 1), transforms fitted on A′, LBS on B",
                    &[SELECTION, SELECTION_POSES, TRANSFER_STAGE, TARGET],
                ),
                MethodKind::BdtRandom => (
                    "bdt_random",
                    Family::Transfer,
                    "BDT with `count` random key points (a simulated user)",
                    &[&["count", "pool"], SELECTION, TRANSFER_STAGE, TARGET],
                ),
                MethodKind::BdtExtremity => (
                    "bdt_extremity",
                    Family::Transfer,
                    "BDT with `count` key points at geodesic extremities (a simulated user)",
                    &[
                        &["count", "strategy", "jitter"],
                        SELECTION,
                        TRANSFER_STAGE,
                        TARGET,
                    ],
                ),
                MethodKind::Sumner => (
                    "sumner",
                    Family::Transfer,
                    "Sumner & Popović deformation transfer, BDT's key point pairs as markers",
                    &[SELECTION, SELECTION_POSES, TARGET],
                ),
                MethodKind::SumnerOracle => (
                    "sumner_oracle",
                    Family::Transfer,
                    "Sumner & Popović with the identity triangle correspondence (full \
                     correspondence: the oracle; shared connectivity only)",
                    &[],
                ),
                MethodKind::Cage => (
                    "cage",
                    Family::Transfer,
                    "cage-based deformation transfer, BDT's key point pairs as markers",
                    &[SELECTION, SELECTION_POSES, TARGET],
                ),
                MethodKind::Identity => (
                    "identity",
                    Family::Transfer,
                    "B left unchanged (B′ = B): the floor of every transfer evaluation",
                    &[],
                ),
                MethodKind::Clustering => (
                    "clustering",
                    Family::Clustering,
                    "rotation-group clustering of the source (BDT Fig. 4), scored against labels",
                    &[
                        &["handles", "features", "examples", "n_clusters"],
                        &["seed", "gamma_logr", "gamma_s", "mode", "weights"],
                    ],
                ),
                MethodKind::Fbt => (
                    "fbt",
                    Family::Fbt,
                    "FBT: a task (`fbt = { task = ... }`: registration, completion, ...) and its \
                     options",
                    &[&["fbt", "seed"]],
                ),
            };
        KindInfo {
            name,
            family,
            summary,
            keys,
        }
    }

    /// The kind's name (`kind = "..."`).
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// The kind named `name`.
    pub fn from_name(name: &str) -> Option<MethodKind> {
        MethodKind::ALL.into_iter().find(|k| k.name() == name)
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
    /// FBT (its tasks run by [`crate::experiment::fbt`]).
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
    let seed = pipe.seed.unwrap_or(seed);
    let keypoint_count = || {
        m.count.ok_or_else(|| {
            (
                "count".to_string(),
                "expected the number of key points".to_string(),
            )
        })
    };
    let transfer_stage = |bdt: &BdtOptions| {
        bdt.align
            .check_frame(bdt.frame)
            .map_err(|e| ("align".to_string(), e.to_string()))
    };
    let target = target_points(&pipe, &bdt);
    let automatic = KeypointSource::Automatic {
        selection_poses: pipe.selection_poses,
    };
    Ok(match m.kind {
        MethodKind::Fbt => {
            let spec = m.fbt.clone().ok_or_else(|| {
                (
                    "fbt".to_string(),
                    "expected an fbt table, e.g. fbt = { task = \"completion\", q = 4 }"
                        .to_string(),
                )
            })?;
            spec.check().map_err(|(k, msg)| (format!("fbt.{k}"), msg))?;
            Method::Fbt { spec, seed }
        }
        MethodKind::Identity => Method::Transfer(TransferMethod::Identity),
        MethodKind::SumnerOracle => Method::Transfer(TransferMethod::SumnerOracle),
        MethodKind::Sumner => Method::Transfer(TransferMethod::Sumner {
            keypoints: automatic,
            target,
            options: bdt.keypoints,
        }),
        MethodKind::Cage => Method::Transfer(TransferMethod::Cage {
            keypoints: automatic,
            target,
            options: bdt.keypoints,
        }),
        MethodKind::Bdt => {
            transfer_stage(&bdt)?;
            Method::Transfer(TransferMethod::Bdt {
                keypoints: automatic,
                target,
                options: bdt,
            })
        }
        MethodKind::BdtRandom => {
            transfer_stage(&bdt)?;
            Method::Transfer(TransferMethod::Bdt {
                keypoints: KeypointSource::Random {
                    count: keypoint_count()?,
                    seed,
                    pool: m.pool.unwrap_or_default(),
                },
                target,
                options: bdt,
            })
        }
        MethodKind::BdtExtremity => {
            transfer_stage(&bdt)?;
            Method::Transfer(TransferMethod::Bdt {
                keypoints: KeypointSource::Extremity {
                    count: keypoint_count()?,
                    strategy: m.strategy.unwrap_or_default(),
                    jitter: m.jitter.unwrap_or(0.0),
                    seed,
                },
                target,
                options: bdt,
            })
        }
        MethodKind::Clustering => {
            let d = Clustering::default();
            Method::Clustering(Clustering {
                handles: m.handles.unwrap_or(d.handles),
                features: features(m.features, &pipe),
                examples: m.examples.unwrap_or(d.examples),
                n_clusters: m.n_clusters,
                seed,
                mode: bdt.keypoints.mode,
                weights: bdt.keypoints.weights,
            })
        }
    })
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

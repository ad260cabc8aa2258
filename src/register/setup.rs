//! One-call construction of an FBT pipeline from q example meshes, with
//! every choice a field of [`FbtConfig`] (DESIGN rule 5: a method is a
//! value; ablations change one field), and the synthetic TOSCA-style class
//! used by tests and as the experiments' default data.
//!
//! The paper's variants as configurations:
//!
//! | variant | change from [`FbtConfig::default`] |
//! |---|---|
//! | LBO only (non-articulated shapes; the named `lbo` variant) | [`FbtConfig::lbo_only`]: rich stage LBO m = 15, clusters from the main LBO weights |
//! | example-based LBO dictionary (Table 2) | `main = StageConfig::lbo(m)` |
//! | example-based skeleton dictionary (Table 2) | `weights: WeightChoice::Skeleton` |
//! | one example, same atom count (Table 2, Fig. 8 A) | `examples: DictionaryExamples::First`, LBO m' = (1+3q)m/4 |
//! | compare to one reference shape (Fig. 8 B) | `arap_examples: DictionaryExamples::First` |
//! | α = 1 (Fig. 8 C) | `FbtParams { scale: ScaleMode::Fixed(1.0), .. }` |
//! | skeleton clusters (Sec. 5, the default) | `cluster_source: ClusterSource::RichWeights` with a skeleton rich stage |
//! | one cluster per bone | `cluster_source: ClusterSource::Skeleton` |
//!
//! **Default: the paper's articulated-shape pipeline.** Initialisation in
//! LBO m = 4, main stage LBO m = 10 (k-medoids halves its example atoms),
//! last stage the example-based *skeleton* dictionary, and r = 20 rotation
//! clusters by k-means on the skeleton weights: "these skeleton weights
//! are also used to define the rotation clusters" (Sec. 5). k-means on the
//! weights gives blend regions (joints) clusters of their own; one cluster
//! per dominant bone (`ClusterSource::Skeleton`) biased α on the synthetic
//! class (unscaled target 0.985 against 0.990; cat 0.967 either way). The skeleton weights come from
//! example-based skinning ([`crate::skin::rigging`]) of the reference
//! against *rig shapes*: other poses of the class, never the target
//! ([`build_with_rig`]; [`build`] rigs from the examples themselves).

use std::sync::Arc;
use std::time::Instant;

use super::model::{ArapGraph, FbtModel};
use super::pipeline::FbtPipeline;
use crate::data::memo::{meshes_hash, Memo};
use crate::data::synthetic::FaustStyle;
use crate::mesh::Mesh;
use crate::skin::dictionary::WeightKind;
use crate::skin::dictionary::{Dictionary, SkinningWeights};
use crate::skin::lbo::{lbo_basis, LboBasis};
use crate::skin::rigging::{example_skinning, Rig, RigOptions};
use crate::solve::EigenOptions;
use crate::{Error, Result};

/// Weighting functions of a dictionary stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WeightChoice {
    /// First `m` LBO eigenfunctions of the reference example.
    Lbo { m: usize },
    /// The paper's skeleton weights: bone weights of example-based skinning
    /// of the rig shapes ([`SkinningWeights::skeleton`], options
    /// [`FbtConfig::rig`]).
    Skeleton,
    /// Bounded biharmonic weights of farthest-point handles
    /// ([`SkinningWeights::biharmonic`]; not the paper's, an ablation).
    Biharmonic { handles: usize },
}

/// Which examples the dictionary atoms come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DictionaryExamples {
    /// All q examples (the paper's example-based dictionary).
    All,
    /// Only the first example (Table 2 "one example", Fig. 8 A); the ARAP
    /// energy still compares against all examples.
    First,
}

/// A dictionary stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StageConfig {
    pub weights: WeightChoice,
    pub examples: DictionaryExamples,
    /// Keep this fraction of the example atoms by k-medoids (Sec. 4.4);
    /// `None`: no reduction.
    pub reduce: Option<f64>,
}

impl StageConfig {
    /// LBO with `m` eigenfunctions, all examples, no reduction.
    pub fn lbo(m: usize) -> Self {
        StageConfig {
            weights: WeightChoice::Lbo { m },
            examples: DictionaryExamples::All,
            reduce: None,
        }
    }
}

/// Where the rotation clusters come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClusterSource {
    /// k-means (r clusters) on the main stage's weights.
    MainWeights,
    /// k-means (r clusters) on the rich stage's weights.
    RichWeights,
    /// The skeleton's bones: each vertex in the cluster of its dominant bone
    /// (r = the number of bones; `clusters` is not used).
    Skeleton,
    /// k-means (r clusters) on the skeleton weights, whichever stages use
    /// them: the paper's clusters without its skeleton dictionary (the
    /// harness's default pipeline once the rig has enough shapes).
    SkeletonWeights,
}

/// Everything needed to build an [`FbtPipeline`].
#[derive(Clone, Debug)]
pub struct FbtConfig {
    /// Small dictionary for the initialisation (`None`: initialise in the
    /// main dictionary).
    pub init: Option<StageConfig>,
    pub main: StageConfig,
    /// Richer dictionary for the last stage.
    pub rich: Option<StageConfig>,
    /// Examples the ARAP energy compares against: `All` (the paper), or
    /// `First` only (Fig. 8 B, "comparing the deformed shape to only one
    /// reference shape"); the dictionaries are unaffected.
    pub arap_examples: DictionaryExamples,
    /// Number of rotation clusters r.
    pub clusters: usize,
    pub cluster_source: ClusterSource,
    /// Example-based skinning of the skeleton weights.
    pub rig: RigOptions,
    /// Seed of k-means and k-medoids.
    pub seed: u64,
    /// Eigensolver settings.
    pub eigen: EigenOptions,
}

impl Default for FbtConfig {
    /// The paper's pipeline for articulated shapes (see the module docs).
    fn default() -> Self {
        FbtConfig {
            init: Some(StageConfig::lbo(4)),
            main: StageConfig {
                reduce: Some(0.5),
                ..StageConfig::lbo(10)
            },
            rich: Some(StageConfig {
                weights: WeightChoice::Skeleton,
                examples: DictionaryExamples::All,
                reduce: None,
            }),
            arap_examples: DictionaryExamples::All,
            clusters: 20,
            cluster_source: ClusterSource::RichWeights,
            rig: RigOptions::default(),
            seed: 0,
            eigen: EigenOptions::default(),
        }
    }
}

impl FbtConfig {
    /// The LBO-only variant (non-articulated shapes, Sec. 5: "for
    /// non-articulated objects, we increase the number of eigenfunctions"):
    /// rich stage LBO m = 15, r = `clusters` k-means clusters of the main
    /// stage's LBO weights. Needs no rig shapes.
    pub fn lbo_only() -> Self {
        FbtConfig {
            rich: Some(StageConfig::lbo(15)),
            cluster_source: ClusterSource::MainWeights,
            ..FbtConfig::default()
        }
    }

    /// The stages in one line, e.g. `LBO m = 4 → LBO m = 10 (reduced) →
    /// skeleton (bones by the data)`; `(reference only)` marks a stage of
    /// Fig. 8 A's one-example dictionary.
    pub fn describe(&self) -> String {
        let stage = |s: &StageConfig| -> String {
            let mut d = match s.weights {
                WeightChoice::Lbo { m } => format!("LBO m = {m}"),
                WeightChoice::Skeleton => match self.rig.bones {
                    Some(b) => format!("skeleton, {b} bones"),
                    None => "skeleton, bones by the data".to_string(),
                },
                WeightChoice::Biharmonic { handles } => format!("BBW {handles} handles"),
            };
            if s.reduce.is_some() {
                d.push_str(" (reduced)");
            }
            if s.examples == DictionaryExamples::First {
                d.push_str(" (reference only)");
            }
            d
        };
        self.init
            .iter()
            .chain([&self.main])
            .chain(self.rich.iter())
            .map(stage)
            .collect::<Vec<_>>()
            .join(" → ")
    }

    /// Whether any stage or the clusters use the skeleton weights.
    pub fn uses_skeleton(&self) -> bool {
        matches!(
            self.cluster_source,
            ClusterSource::Skeleton | ClusterSource::SkeletonWeights
        ) || self
            .init
            .iter()
            .chain([&self.main])
            .chain(self.rich.iter())
            .any(|s| s.weights == WeightChoice::Skeleton)
    }
}

/// The built pipeline and what went into it.
#[derive(Clone, Debug)]
pub struct FbtSetup {
    pub graph: Arc<ArapGraph>,
    pub pipeline: FbtPipeline,
    /// LBO basis of the reference (as many eigenfunctions as any stage uses;
    /// `None` if no stage uses LBO).
    pub lbo: Option<LboBasis>,
    pub clusters: Vec<usize>,
    /// The skeleton rig, when a stage or the clusters use it.
    pub rig: Option<Arc<Rig>>,
    /// Dictionary sizes b of (init, main, rich).
    pub sizes: (Option<usize>, usize, Option<usize>),
    /// Wall time of the whole precomputation (s).
    pub seconds: f64,
}

fn stage_weights(
    choice: WeightChoice,
    examples: &[Mesh],
    lbo: Option<&LboBasis>,
    skeleton: Option<&SkinningWeights>,
    seed: u64,
) -> Result<SkinningWeights> {
    let reference = &examples[0];
    match choice {
        WeightChoice::Lbo { m } => {
            let b = lbo.ok_or_else(|| Error::invalid("LBO basis missing"))?;
            Ok(SkinningWeights::lbo(&b.truncated(m)?))
        }
        WeightChoice::Skeleton => skeleton
            .cloned()
            .ok_or_else(|| Error::invalid("skeleton weights missing")),
        WeightChoice::Biharmonic { handles } => {
            SkinningWeights::biharmonic(reference, handles, seed)
        }
    }
}

fn stage_dictionary(
    cfg: &StageConfig,
    examples: &[Mesh],
    weights: &SkinningWeights,
    seed: u64,
) -> Result<Dictionary> {
    let ex = match cfg.examples {
        DictionaryExamples::All => examples,
        DictionaryExamples::First => &examples[..1],
    };
    let d = Dictionary::from_meshes(ex, weights)?;
    match cfg.reduce {
        None => Ok(d),
        Some(f) => {
            if !(f > 0.0 && f <= 1.0) {
                return Err(Error::invalid(format!(
                    "dictionary reduction fraction must be in (0, 1], got {f}"
                )));
            }
            let n_ex = d.size() - d.n_weights();
            let k = ((f * n_ex as f64).round() as usize).clamp(1, n_ex);
            Ok(d.reduce(k, seed)?.0)
        }
    }
}

/// Builds the pipeline for `examples` (q ≥ 1 meshes with one face list;
/// the first is the reference); the skeleton weights, if used, are learnt
/// from the examples other than the reference (see [`build_with_rig`]).
pub fn build(examples: &[Mesh], cfg: &FbtConfig) -> Result<FbtSetup> {
    let rig_shapes = examples.get(1..).unwrap_or(&[]);
    build_with_rig(examples, rig_shapes, cfg)
}

/// [`build`] with the skeleton weights learnt from `rig_shapes` (poses of
/// the reference's class, same connectivity, never the target): the same
/// skeleton for every q. Errors when the configuration uses the skeleton
/// and `rig_shapes` is empty (q = 1 without other poses: use
/// [`FbtConfig::lbo_only`]).
pub fn build_with_rig(examples: &[Mesh], rig_shapes: &[Mesh], cfg: &FbtConfig) -> Result<FbtSetup> {
    let start = Instant::now();
    if examples.is_empty() {
        return Err(Error::invalid("FBT needs at least one example"));
    }
    let graph = Arc::new(ArapGraph::new(match cfg.arap_examples {
        DictionaryExamples::All => examples,
        DictionaryExamples::First => &examples[..1],
    })?);
    let stages: Vec<&StageConfig> = cfg
        .init
        .iter()
        .chain([&cfg.main])
        .chain(cfg.rich.iter())
        .collect();
    let m_lbo = stages
        .iter()
        .filter_map(|s| match s.weights {
            WeightChoice::Lbo { m } => Some(m),
            WeightChoice::Skeleton | WeightChoice::Biharmonic { .. } => None,
        })
        .max();
    let lbo = m_lbo
        .map(|m| lbo_basis(&examples[0], m, &cfg.eigen))
        .transpose()?;
    let (skeleton, rig) = if cfg.uses_skeleton() {
        if rig_shapes.is_empty() {
            return Err(Error::invalid(
                "the skeleton dictionary learns its bones from other poses of the class: none \
                 was given (q = 1 without rig shapes); give rig shapes or use the LBO-only \
                 pipeline",
            ));
        }
        let (w, r) = skeleton_weights(&examples[0], rig_shapes, &cfg.rig)?;
        (Some(w), Some(r))
    } else {
        (None, None)
    };
    let sw = |s: &StageConfig| {
        stage_weights(
            s.weights,
            examples,
            lbo.as_ref(),
            skeleton.as_ref(),
            cfg.seed,
        )
    };
    let w_init = cfg.init.as_ref().map(sw).transpose()?;
    let w_main = sw(&cfg.main)?;
    let w_rich = cfg.rich.as_ref().map(sw).transpose()?;
    let clusters = match cfg.cluster_source {
        ClusterSource::MainWeights => w_main.rotation_clusters(cfg.clusters, cfg.seed)?,
        ClusterSource::RichWeights => w_rich
            .as_ref()
            .ok_or_else(|| Error::invalid("cluster source RichWeights without a rich stage"))?
            .rotation_clusters(cfg.clusters, cfg.seed)?,
        ClusterSource::SkeletonWeights => skeleton
            .as_ref()
            .ok_or_else(|| Error::invalid("skeleton weight clusters without a rig"))?
            .rotation_clusters(cfg.clusters, cfg.seed)?,
        ClusterSource::Skeleton => {
            let r = rig
                .as_ref()
                .ok_or_else(|| Error::invalid("skeleton clusters without a rig"))?;
            compact_labels(&r.labels)
        }
    };
    let model = |s: &StageConfig, w: &SkinningWeights| -> Result<Arc<FbtModel>> {
        let d = stage_dictionary(s, examples, w, cfg.seed)?;
        Ok(Arc::new(FbtModel::new(graph.clone(), d, clusters.clone())?))
    };
    let init = match (&cfg.init, &w_init) {
        (Some(s), Some(w)) => Some(model(s, w)?),
        _ => None,
    };
    let main = model(&cfg.main, &w_main)?;
    let rich = match (&cfg.rich, &w_rich) {
        (Some(s), Some(w)) => Some(model(s, w)?),
        _ => None,
    };
    let sizes = (
        init.as_ref().map(|m| m.size()),
        main.size(),
        rich.as_ref().map(|m| m.size()),
    );
    let pipeline = FbtPipeline::new(init, main, rich)?;
    Ok(FbtSetup {
        graph,
        pipeline,
        lbo,
        clusters,
        rig,
        sizes,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The example-based skinning of `reference` against `rig_shapes`
/// ([`example_skinning`]), memoised in the process: every method of a case
/// (each q, each solver) learns the same rig from the same shapes.
pub fn skeleton_rig(reference: &Mesh, rig_shapes: &[Mesh], opts: &RigOptions) -> Result<Arc<Rig>> {
    static MEMO: Memo<Rig> = Memo::new();
    let key = (
        meshes_hash(std::iter::once(reference).chain(rig_shapes)),
        format!("{opts:?}"),
    );
    MEMO.get_or(key, || example_skinning(reference, rig_shapes, opts))
}

/// The skeleton weights of `reference` learnt from `rig_shapes`
/// ([`skeleton_rig`], memoised) with the rig they come from.
pub fn skeleton_weights(
    reference: &Mesh,
    rig_shapes: &[Mesh],
    opts: &RigOptions,
) -> Result<(SkinningWeights, Arc<Rig>)> {
    let r = skeleton_rig(reference, rig_shapes, opts)?;
    let w = SkinningWeights::custom(reference, r.weights.clone(), WeightKind::Skeleton)?;
    Ok((w, r))
}

/// Labels renumbered `0..k` in order of first appearance (bones that lost
/// every vertex as a dominant bone leave no empty cluster).
fn compact_labels(labels: &[usize]) -> Vec<usize> {
    let mut map = std::collections::HashMap::new();
    labels
        .iter()
        .map(|&l| {
            let k = map.len();
            *map.entry(l).or_insert(k)
        })
        .collect()
}

/// The synthetic TOSCA-style class: subject 0 of a one-subject synthetic
/// set, its rest (T-)pose followed by the 10 poses of the pose table — the
/// meshes `deformlab gen` writes to `tosca/creature0..10` — at Catmull–Clark
/// `resolution` (1: 1.5k–1.7k vertices; 2: ~6.7k).
pub fn synthetic_class(resolution: u32, seed: u64) -> Result<Vec<Mesh>> {
    let set = FaustStyle {
        subjects: 1,
        poses: 10,
        seed,
        resolution,
        tail: true,
        spread: 0.15,
    }
    .generate()?;
    let mut out = vec![set.rest[0].clone()];
    out.extend(set.meshes[0].iter().cloned());
    Ok(out)
}

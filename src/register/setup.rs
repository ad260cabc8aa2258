//! One-call construction of an FBT pipeline from q example meshes, with
//! every choice a field of [`FbtConfig`] (DESIGN rule 5: a method is a
//! value; ablations change one field), and the synthetic TOSCA-style class
//! used by tests and as the experiments' default data.
//!
//! The paper's variants as configurations:
//!
//! | variant | change from [`FbtConfig::default`] |
//! |---|---|
//! | example-based LBO dictionary (Table 2) | `main = StageConfig::lbo(m)` |
//! | example-based skeleton dictionary (Table 2) | `weights: WeightChoice::Segments { .. }` (or `Biharmonic`) |
//! | one example, same atom count (Table 2, Fig. 8 A) | `examples: DictionaryExamples::First`, LBO m' = (1+3q)m/4 |
//! | compare to one reference shape (Fig. 8 B) | `arap_examples: DictionaryExamples::First` |
//! | α = 1 (Fig. 8 C) | `FbtParams { scale: ScaleMode::Fixed(1.0), .. }` |
//! | skeleton clusters (Sec. 5) | `cluster_source: ClusterSource::Segments { .. }` |

use std::sync::Arc;
use std::time::Instant;

use super::model::{ArapGraph, FbtModel};
use super::pipeline::FbtPipeline;
use crate::data::synthetic::FaustStyle;
use crate::mesh::Mesh;
use crate::skin::dictionary::{Dictionary, SkinningWeights};
use crate::skin::lbo::{lbo_basis, LboBasis};
use crate::solve::EigenOptions;
use crate::{Error, Result};

/// Weighting functions of a dictionary stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WeightChoice {
    /// First `m` LBO eigenfunctions of the reference example.
    Lbo { m: usize },
    /// Skeleton substitute: smoothed rotation segments of the examples
    /// ([`SkinningWeights::segments`]).
    Segments { segments: usize, width: f64 },
    /// Skeleton substitute: bounded biharmonic weights of farthest-point
    /// handles ([`SkinningWeights::biharmonic`]).
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
    /// k-means on the main stage's weights.
    MainWeights,
    /// k-means on the rich stage's weights (the paper: skeleton weights).
    RichWeights,
    /// k-means on smoothed rotation segments with this many segments.
    Segments { segments: usize, width: f64 },
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
    /// Seed of k-means, k-medoids and segments.
    pub seed: u64,
    /// Eigensolver settings.
    pub eigen: EigenOptions,
}

impl Default for FbtConfig {
    fn default() -> Self {
        FbtConfig {
            init: Some(StageConfig::lbo(4)),
            main: StageConfig {
                reduce: Some(0.5),
                ..StageConfig::lbo(10)
            },
            rich: Some(StageConfig::lbo(15)),
            arap_examples: DictionaryExamples::All,
            clusters: 20,
            cluster_source: ClusterSource::MainWeights,
            seed: 0,
            eigen: EigenOptions::default(),
        }
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
    /// Dictionary sizes b of (init, main, rich).
    pub sizes: (Option<usize>, usize, Option<usize>),
    /// Wall time of the whole precomputation (s).
    pub seconds: f64,
}

fn stage_weights(
    choice: WeightChoice,
    examples: &[Mesh],
    lbo: Option<&LboBasis>,
    seed: u64,
) -> Result<SkinningWeights> {
    let reference = &examples[0];
    match choice {
        WeightChoice::Lbo { m } => {
            let b = lbo.ok_or_else(|| Error::invalid("LBO basis missing"))?;
            Ok(SkinningWeights::lbo(&b.truncated(m)?))
        }
        WeightChoice::Segments { segments, width } => {
            if examples.len() < 2 {
                return Err(Error::invalid(
                    "segment (skeleton) weights need at least two examples: \
                     the rotations between them define the segments",
                ));
            }
            SkinningWeights::segments(reference, &examples[1..], segments, width, seed)
        }
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
/// the first is the reference).
pub fn build(examples: &[Mesh], cfg: &FbtConfig) -> Result<FbtSetup> {
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
            WeightChoice::Segments { .. } | WeightChoice::Biharmonic { .. } => None,
        })
        .max();
    let lbo = m_lbo
        .map(|m| lbo_basis(&examples[0], m, &cfg.eigen))
        .transpose()?;
    let w_init = cfg
        .init
        .map(|s| stage_weights(s.weights, examples, lbo.as_ref(), cfg.seed))
        .transpose()?;
    let w_main = stage_weights(cfg.main.weights, examples, lbo.as_ref(), cfg.seed)?;
    let w_rich = cfg
        .rich
        .map(|s| stage_weights(s.weights, examples, lbo.as_ref(), cfg.seed))
        .transpose()?;
    let clusters = match cfg.cluster_source {
        ClusterSource::MainWeights => w_main.rotation_clusters(cfg.clusters, cfg.seed)?,
        ClusterSource::RichWeights => w_rich
            .as_ref()
            .ok_or_else(|| Error::invalid("cluster source RichWeights without a rich stage"))?
            .rotation_clusters(cfg.clusters, cfg.seed)?,
        ClusterSource::Segments { segments, width } => stage_weights(
            WeightChoice::Segments { segments, width },
            examples,
            None,
            cfg.seed,
        )?
        .rotation_clusters(cfg.clusters, cfg.seed)?,
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
        sizes,
        seconds: start.elapsed().as_secs_f64(),
    })
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

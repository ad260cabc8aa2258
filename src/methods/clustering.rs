//! Rotation-group clustering of a source (BDT Fig. 4) as a value.

use std::time::Instant;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::mesh::Mesh;
use crate::ops::{farthest_point_sampling, FpsMetric};
use crate::skin::bbw::{BbwOptions, Biharmonic, WeightMode};
use crate::skin::{rotation_groups, GroupFeatures};
use crate::transfer::SelectionMode;
use crate::Result;

/// Which deformed examples the clustering features use.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Examples {
    /// The first deformed pose only.
    One,
    /// Every deformed pose.
    #[default]
    All,
}

/// Clusters the vertices of A into rotation groups (BDT Sec. 3.3, Eq. 15)
/// from the weights of `handles` geodesic FPS handles.
#[derive(Clone, Debug, PartialEq)]
pub struct Clustering {
    /// FPS handles whose weights form `W`.
    pub handles: usize,
    /// Clustering features.
    pub features: GroupFeatures,
    /// Which deformed poses give the rotation features.
    pub examples: Examples,
    /// Clusters (`None`: the number of true labels when known, else `handles`).
    pub n_clusters: Option<usize>,
    /// Seed of the FPS and the k-means.
    pub seed: u64,
    /// `fast`: clamped, renormalised unbounded biharmonic weights; `exact`:
    /// bounded biharmonic weights with `weights`.
    pub mode: SelectionMode,
    pub weights: BbwOptions,
}

impl Default for Clustering {
    fn default() -> Self {
        let k = crate::transfer::KeypointOptions::default();
        Clustering {
            handles: 12,
            features: GroupFeatures::default(),
            examples: Examples::default(),
            n_clusters: None,
            seed: k.seed,
            mode: k.mode,
            weights: k.weights,
        }
    }
}

/// What [`Clustering::run`] found.
#[derive(Clone, Debug)]
pub struct ClusteringOutcome {
    /// The FPS handles.
    pub handles: Vec<usize>,
    /// Cluster of every vertex of A.
    pub labels: Vec<usize>,
    /// Number of clusters asked for.
    pub n_clusters: usize,
    /// Deformed poses used.
    pub n_examples: usize,
    pub seconds_weights: f64,
    pub seconds_clustering: f64,
}

impl Clustering {
    /// Clusters `a` with its deformed poses `a_def`; `n_true_labels`: the
    /// number of distinct true labels when known (the default cluster count).
    pub fn run(
        &self,
        a: &Mesh,
        a_def: &[Mesh],
        n_true_labels: Option<usize>,
    ) -> Result<ClusteringOutcome> {
        let ex: &[Mesh] = match self.examples {
            Examples::One => &a_def[..a_def.len().min(1)],
            Examples::All => a_def,
        };
        let t = Instant::now();
        let hs = farthest_point_sampling(
            a,
            self.handles.min(a.n_vertices()),
            FpsMetric::Geodesic,
            self.seed,
        )?;
        let bih = Biharmonic::new(a)?;
        let w: DMatrix<f64> = match self.mode {
            SelectionMode::Exact => bih.weights(&hs, &self.weights)?,
            SelectionMode::Fast => {
                // Unbounded biharmonic weights, clamped to [0, 1] and renormalised.
                let mut w = bih.weights(&hs, &BbwOptions::with_mode(WeightMode::Unbounded))?;
                for mut row in w.row_iter_mut() {
                    row.iter_mut().for_each(|x| *x = x.clamp(0.0, 1.0));
                    let s: f64 = row.iter().sum();
                    if s > 0.0 {
                        row /= s;
                    }
                }
                w
            }
        };
        let seconds_weights = t.elapsed().as_secs_f64();
        let k = self.n_clusters.or(n_true_labels).unwrap_or(hs.len());
        let t = Instant::now();
        let labels = rotation_groups(a, ex, &w, self.features, Some(k), self.seed)?;
        Ok(ClusteringOutcome {
            handles: hs,
            labels,
            n_clusters: k,
            n_examples: ex.len(),
            seconds_weights,
            seconds_clustering: t.elapsed().as_secs_f64(),
        })
    }
}

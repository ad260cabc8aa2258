//! Rotation groups: k-means clustering of skinning weights and deformation
//! features (BDT Sec. 3.3, Eq. 6–15).
//!
//! The groups are the regions `G_g` of the clustered ARAP energy (BDT Eq. 3):
//! one label per vertex, clustered from one of
//!
//! - the skinning weights `W` (n × n_h) alone (FAST, BDT Fig. 4b);
//! - the deformation features `[γ_logr/√m · logr~, γ_s/√m · s~]` alone (BDT
//!   Fig. 4c);
//! - the augmented matrix `W′ = [W, γ_logr/√m · logr~, γ_s/√m · s~]` (BDT
//!   Eq. 15, Fig. 4d–e),
//!
//! where `logr~` (n × 3m) and `s~` (n × 9m) concatenate the per-vertex
//! rotation logs and scale/shear vectors of the m deformed sources
//! ([`crate::ops::deformation_features`], Eq. 12–14).

use nalgebra::DMatrix;

use crate::mesh::Mesh;
use crate::ops::deformation_features;
use crate::solve::kmeans::{kmeans_with, KMeansOptions};
use crate::{Error, Result};

/// Which features the rotation groups are clustered on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GroupFeatures {
    /// Skinning weights `W` only.
    Weights,
    /// `[γ_logr/√m · logr~, γ_s/√m · s~]` only (no `W`).
    RotationScale { gamma_logr: f64, gamma_s: f64 },
    /// `W′ = [W, γ_logr/√m · logr~, γ_s/√m · s~]` (BDT Eq. 15).
    Augmented { gamma_logr: f64, gamma_s: f64 },
}

impl GroupFeatures {
    /// The paper's defaults `γ_logr = 1`, `γ_s = 0.1` for `W′`.
    pub const AUGMENTED: GroupFeatures = GroupFeatures::Augmented {
        gamma_logr: GroupFeatures::GAMMA_LOGR,
        gamma_s: GroupFeatures::GAMMA_S,
    };
    /// The paper's defaults for the features without `W`.
    pub const ROTATION_SCALE: GroupFeatures = GroupFeatures::RotationScale {
        gamma_logr: GroupFeatures::GAMMA_LOGR,
        gamma_s: GroupFeatures::GAMMA_S,
    };
}

/// Which features, without their weights γ (the config key `groups` /
/// `features`). [`GroupFeatures::new`] adds the γ.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Default,
    serde::Deserialize,
    serde::Serialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
pub enum FeatureKind {
    /// `W` only.
    Weights,
    /// `[logr, s]` only.
    RotationScale,
    /// `W′ = [W, logr, s]` (BDT Eq. 15).
    #[default]
    Augmented,
}

impl GroupFeatures {
    /// The paper's `γ_logr`.
    pub const GAMMA_LOGR: f64 = 1.0;
    /// The paper's `γ_s`.
    pub const GAMMA_S: f64 = 0.1;

    /// Features of `kind` with the weights `γ_logr`, `γ_s` (ignored for
    /// [`FeatureKind::Weights`]).
    pub fn new(kind: FeatureKind, gamma_logr: f64, gamma_s: f64) -> GroupFeatures {
        match kind {
            FeatureKind::Weights => GroupFeatures::Weights,
            FeatureKind::RotationScale => GroupFeatures::RotationScale {
                gamma_logr,
                gamma_s,
            },
            FeatureKind::Augmented => GroupFeatures::Augmented {
                gamma_logr,
                gamma_s,
            },
        }
    }
}

impl Default for GroupFeatures {
    fn default() -> Self {
        GroupFeatures::AUGMENTED
    }
}

/// k-means settings used by [`rotation_groups`].
pub const GROUP_KMEANS: KMeansOptions = KMeansOptions {
    max_iter: 300,
    n_init: 4,
};

/// The feature matrix (n rows) that [`rotation_groups`] clusters.
///
/// `deformed` are the m deformed copies of `rest` (same faces); they are not
/// used (and may be empty) for [`GroupFeatures::Weights`]. Errors on
/// mismatched counts, non-finite weights or gammas, or no deformed mesh when
/// features need one.
pub fn group_features(
    rest: &Mesh,
    deformed: &[Mesh],
    weights: &DMatrix<f64>,
    features: GroupFeatures,
) -> Result<DMatrix<f64>> {
    let n = rest.n_vertices();
    if weights.nrows() != n {
        return Err(Error::invalid(format!(
            "skinning weights have {} rows for {n} vertices",
            weights.nrows()
        )));
    }
    let (use_w, gammas) = match features {
        GroupFeatures::Weights => return Ok(weights.clone()),
        GroupFeatures::RotationScale {
            gamma_logr,
            gamma_s,
        } => (false, (gamma_logr, gamma_s)),
        GroupFeatures::Augmented {
            gamma_logr,
            gamma_s,
        } => (true, (gamma_logr, gamma_s)),
    };
    let (gamma_logr, gamma_s) = gammas;
    if !(gamma_logr.is_finite() && gamma_s.is_finite()) {
        return Err(Error::invalid(format!(
            "feature weights must be finite, got γ_logr = {gamma_logr}, γ_s = {gamma_s}"
        )));
    }
    let m = deformed.len();
    if m == 0 {
        return Err(Error::invalid(
            "rotation/scale group features need at least one deformed mesh",
        ));
    }
    let w_cols = if use_w { weights.ncols() } else { 0 };
    let mut out = DMatrix::zeros(n, w_cols + 12 * m);
    if use_w {
        out.columns_mut(0, w_cols).copy_from(weights);
    }
    let (cr, cs) = (gamma_logr / (m as f64).sqrt(), gamma_s / (m as f64).sqrt());
    for (j, d) in deformed.iter().enumerate() {
        let f = deformation_features(rest, d)
            .map_err(|e| Error::invalid(format!("deformed mesh {j}: {e}")))?;
        out.columns_mut(w_cols + 3 * j, 3)
            .copy_from(&(f.log_rotation * cr));
        out.columns_mut(w_cols + 3 * m + 9 * j, 9)
            .copy_from(&(f.scale_shear * cs));
    }
    Ok(out)
}

/// Rotation groups (BDT Sec. 3.3): k-means (k-means++ from `seed`,
/// [`GROUP_KMEANS`]) on the rows of [`group_features`]. `n_groups` defaults
/// to n_h (the number of weight columns), as in the paper. Returns a group
/// label in `0..n_groups` per vertex.
///
/// Errors as [`group_features`], and if `n_groups` is 0 or exceeds the
/// number of vertices.
pub fn rotation_groups(
    rest: &Mesh,
    deformed: &[Mesh],
    weights: &DMatrix<f64>,
    features: GroupFeatures,
    n_groups: Option<usize>,
    seed: u64,
) -> Result<Vec<usize>> {
    let k = n_groups.unwrap_or(weights.ncols());
    let x = group_features(rest, deformed, weights, features)?;
    Ok(kmeans_with(&x, k, seed, &GROUP_KMEANS)?.labels)
}

/// Purity of a clustering against reference labels: the fraction of items
/// whose cluster's most frequent reference label equals their own (1 for a
/// refinement of the reference). Errors if the lengths differ or are 0.
pub fn purity(labels: &[usize], reference: &[usize]) -> Result<f64> {
    if labels.len() != reference.len() || labels.is_empty() {
        return Err(Error::invalid(format!(
            "purity of {} labels against {} reference labels",
            labels.len(),
            reference.len()
        )));
    }
    let mut pairs: Vec<(usize, usize)> = labels
        .iter()
        .copied()
        .zip(reference.iter().copied())
        .collect();
    pairs.sort_unstable();
    let mut agree = 0usize;
    let mut i = 0;
    while i < pairs.len() {
        let cluster = pairs[i].0;
        let mut best = 0usize;
        while i < pairs.len() && pairs[i].0 == cluster {
            let r = pairs[i].1;
            let mut count = 0;
            while i < pairs.len() && pairs[i] == (cluster, r) {
                count += 1;
                i += 1;
            }
            best = best.max(count);
        }
        agree += best;
    }
    Ok(agree as f64 / labels.len() as f64)
}

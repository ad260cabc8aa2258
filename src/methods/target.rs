//! The target vertices of the source key points: the same vertex (shared
//! connectivity), a given list, a marker file, or the automatic
//! correspondence (registration of A onto B), then optional geodesic noise.

use std::collections::BTreeMap;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::mesh::Mesh;
use crate::ops::total_area;
use crate::transfer::{auto_correspondence, perturb_keypoints, AutoCorrespondence, AutoOptions};
use crate::{Error, Result};

/// How the target key points are found.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum TargetCorrespondence {
    /// Target vertex = source vertex (shared connectivity; config
    /// `identity`, CLI `--same-connectivity`).
    #[default]
    Identity,
    /// Registration of A onto B ([`crate::transfer::auto_correspondence`];
    /// any connectivity; config `auto`, CLI `--auto-correspondence`).
    Auto,
    /// The target vertices in key point order (CLI `--target-keypoints`,
    /// or the `target` column of a key point file).
    #[serde(skip)]
    List(Vec<usize>),
    /// Source vertex → target vertex markers read from `file` (CLI
    /// `--correspondence`); every key point must be a source vertex of it.
    #[serde(skip)]
    Markers {
        file: String,
        map: BTreeMap<usize, usize>,
    },
}

/// The target key point options of a method.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TargetPoints {
    pub correspondence: TargetCorrespondence,
    /// Landmark pairs `(vertex of A, vertex of B)` guiding the automatic
    /// correspondence.
    pub landmarks: Vec<(usize, usize)>,
    /// Seed of the automatic correspondence (FPS, k-means).
    pub seed: u64,
    /// Geodesic noise radius in √area(B) units (0: none).
    pub noise: f64,
    /// Seed of the noise.
    pub noise_seed: u64,
}

/// What [`TargetPoints::find`] found.
#[derive(Clone, Debug)]
pub struct TargetFound {
    /// Target vertex of each key point (after the noise).
    pub keypoints: Vec<usize>,
    /// The registration (automatic correspondence only).
    pub auto: Option<AutoCorrespondence>,
    pub seconds: f64,
}

impl TargetPoints {
    /// The target vertices on `b` of the key points `keypoints` of `a`.
    pub fn find(&self, a: &Mesh, b: &Mesh, keypoints: &[usize]) -> Result<TargetFound> {
        let t = Instant::now();
        let mut auto = None;
        let mut target: Vec<usize> = match &self.correspondence {
            TargetCorrespondence::Identity => {
                if b.n_vertices() != a.n_vertices() {
                    return Err(Error::invalid(format!(
                        "source has {} vertices, target {}: the identity correspondence \
                         (target_correspondence = \"identity\", the default; CLI \
                         --same-connectivity) needs one connectivity; use the automatic one \
                         (target_correspondence = \"auto\"; --auto-correspondence)",
                        a.n_vertices(),
                        b.n_vertices()
                    )));
                }
                keypoints.to_vec()
            }
            TargetCorrespondence::Auto => {
                let r = auto_correspondence(
                    a,
                    keypoints,
                    b,
                    &AutoOptions {
                        seed: self.seed,
                        landmarks: self.landmarks.clone(),
                        ..AutoOptions::default()
                    },
                )?;
                let kp = r.target_keypoints.clone();
                auto = Some(r);
                kp
            }
            TargetCorrespondence::List(v) => {
                if v.len() != keypoints.len() {
                    return Err(Error::invalid(format!(
                        "{} target vertices were given but there are {} key points {:?}; \
                         fix the source key points (a key point file) to match",
                        v.len(),
                        keypoints.len(),
                        keypoints
                    )));
                }
                v.clone()
            }
            TargetCorrespondence::Markers { file, map } => keypoints
                .iter()
                .map(|s| {
                    map.get(s).copied().ok_or_else(|| {
                        Error::parse(
                            file,
                            "markers",
                            format!(
                                "key point (source vertex {s}) is not a source vertex of the file"
                            ),
                        )
                    })
                })
                .collect::<Result<_>>()?,
        };
        if let Some(&bad) = target.iter().find(|&&v| v >= b.n_vertices()) {
            return Err(Error::invalid(format!(
                "target key point {bad} out of range for the target ({} vertices)",
                b.n_vertices()
            )));
        }
        if self.noise > 0.0 {
            let radius = self.noise * total_area(b).sqrt();
            target = perturb_keypoints(b, &target, radius, self.noise_seed)?;
        }
        Ok(TargetFound {
            keypoints: target,
            auto,
            seconds: t.elapsed().as_secs_f64(),
        })
    }
}

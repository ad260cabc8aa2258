//! The correspondence step of every nonrigid ICP loop of the registration
//! methods: FBT's [`nicp`](mod@super::nicp) (steps 1–2 there) and the Der et al. and
//! Amberg et al. baselines (which use it from above: `register` imports no
//! baseline), with the options of [`NicpOptions`]. For each sampled
//! template vertex, the `neighbours` nearest target vertices (a
//! [`PointIndex`] on the target, built once) are examined and the nearest
//! one whose normal makes an angle below `max_normal_angle_deg` with the
//! deformed template's vertex normal is its match; pairs farther than
//! `max_distance · √A` (A = template area), pairs without a compatible
//! normal and — for partial targets — pairs whose target vertex lies on the
//! target's boundary are rejected.

use super::spatial::PointIndex;
use crate::mesh::Mesh;
use crate::ops::{boundary_vertices, farthest_point_sampling, vertex_normals, FpsMetric};
use crate::{Error, Point, Result, Vec3};

/// Closest compatible points on a fixed target.
pub struct Matcher {
    reference: Mesh,
    samples: Vec<usize>,
    target: Vec<Point>,
    normals: Vec<Vec3>,
    boundary: Vec<bool>,
    index: PointIndex,
    dmax: f64,
    cos_max: f64,
    neighbours: usize,
}

/// The accepted pairs of one correspondence step.
#[derive(Clone, Debug, Default)]
pub struct Matches {
    /// `(template vertex, target vertex)`.
    pub pairs: Vec<(usize, usize)>,
    /// Mean distance of the accepted pairs (NaN when none).
    pub mean_distance: f64,
}

impl Matcher {
    /// A matcher of template `reference` (whose faces define the deformed
    /// template's normals; `area` its area) against `target`. `samples` of
    /// the options: 0 or ≥ n matches every template vertex, otherwise the
    /// farthest-point samples of the reference (seed `seed` of the options),
    /// as in FBT's NICP.
    pub fn new(reference: &Mesh, area: f64, target: &Mesh, opts: &NicpOptions) -> Result<Self> {
        if target.n_vertices() == 0 {
            return Err(Error::invalid("ICP target has no vertices"));
        }
        if !(opts.max_distance > 0.0 && area > 0.0) {
            return Err(Error::invalid(
                "ICP needs max_distance > 0 and a template of positive area",
            ));
        }
        let n = reference.n_vertices();
        let samples: Vec<usize> = if opts.samples == 0 || opts.samples >= n {
            (0..n).collect()
        } else {
            farthest_point_sampling(reference, opts.samples, FpsMetric::Euclidean, opts.seed)?
        };
        let index = PointIndex::new(target.vertices())?;
        let boundary = if opts.reject_boundary {
            boundary_vertices(target)
        } else {
            vec![false; target.n_vertices()]
        };
        Ok(Matcher {
            reference: reference.clone(),
            samples,
            target: target.vertices().to_vec(),
            normals: vertex_normals(target),
            boundary,
            index,
            dmax: opts.max_distance * area.sqrt(),
            cos_max: opts.max_normal_angle_deg.to_radians().cos(),
            neighbours: opts.neighbours.max(1),
        })
    }

    /// The template vertices that are matched.
    pub fn samples(&self) -> &[usize] {
        &self.samples
    }

    /// Target vertex positions.
    pub fn target(&self) -> &[Point] {
        &self.target
    }

    /// Matches the deformed template `p` (reference connectivity).
    pub fn matches(&self, p: &[Point]) -> Result<Matches> {
        let deformed = self.reference.with_vertices(p.to_vec())?;
        let normals = vertex_normals(&deformed);
        let mut pairs = Vec::new();
        let mut dsum = 0.0;
        for &i in &self.samples {
            let hits = self.index.nearest_n(&p[i], self.neighbours);
            let Some(h) = hits
                .iter()
                .find(|h| self.normals[h.index].dot(&normals[i]) >= self.cos_max)
            else {
                continue;
            };
            let j = h.index;
            let d = h.distance();
            if d > self.dmax || self.boundary[j] {
                continue;
            }
            pairs.push((i, j));
            dsum += d;
        }
        let mean_distance = if pairs.is_empty() {
            f64::NAN
        } else {
            dsum / pairs.len() as f64
        };
        Ok(Matches {
            pairs,
            mean_distance,
        })
    }
}

/// Options of the nonrigid ICP ([`super::nicp::nicp`]) and of its matcher.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NicpOptions {
    /// ICP iterations.
    pub iterations: usize,
    /// Template vertices matched per iteration (0: all).
    pub samples: usize,
    /// Rejection distance, relative to √(template area).
    pub max_distance: f64,
    /// Rejection angle between normals (degrees).
    pub max_normal_angle_deg: f64,
    /// Nearest target vertices examined per sample.
    pub neighbours: usize,
    /// Drop pairs whose target vertex is on a boundary edge.
    pub reject_boundary: bool,
    /// Weight of the feature rows.
    pub feature_weight: f64,
    /// Total weight of the correspondence rows, in units of one feature
    /// row at weight 1: each of the `a` accepted pairs gets weight
    /// `correspondence_weight / a`, so the balance does not depend on
    /// `samples`.
    pub correspondence_weight: f64,
    /// E_mn local/scale/global iterations per ICP iteration.
    pub inner_iterations: usize,
    /// Seed of the sample placement.
    pub seed: u64,
}

impl Default for NicpOptions {
    fn default() -> Self {
        NicpOptions {
            iterations: 10,
            samples: 1000,
            max_distance: 0.05,
            max_normal_angle_deg: 60.0,
            neighbours: 8,
            reject_boundary: true,
            feature_weight: 1.0,
            correspondence_weight: 2.0,
            inner_iterations: 5,
            seed: 0,
        }
    }
}

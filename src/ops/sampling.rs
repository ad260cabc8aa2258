//! Farthest point sampling of mesh vertices.
//!
//! After the first vertex, each new sample is the vertex whose distance to
//! the nearest sample so far is largest (max–min), ties broken by the lowest
//! vertex index, so results are deterministic. Already chosen vertices are
//! never chosen again, so the samples are distinct even when vertices
//! coincide. With the geodesic metric, vertices in a component not yet
//! reached by any sample are at infinite distance and so are picked first
//! (lowest index first).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::mesh::Mesh;
use crate::ops::geodesic::EdgeGraph;
use crate::{Error, Result};

/// Distance used by farthest point sampling.
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
pub enum FpsMetric {
    /// Straight-line distance between vertex positions.
    #[default]
    Euclidean,
    /// Dijkstra distance along mesh edges ([`crate::ops::geodesic`]).
    Geodesic,
}

/// The vertex a seeded sampling starts from: uniform over the vertices,
/// drawn with `ChaCha8Rng::seed_from_u64(seed)`.
pub fn seeded_first_vertex(mesh: &Mesh, seed: u64) -> usize {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.random_range(0..mesh.n_vertices())
}

/// `k` vertices by farthest point sampling, starting at
/// [`seeded_first_vertex`]`(mesh, seed)`. Errors if `k` exceeds the number of
/// vertices.
pub fn farthest_point_sampling(
    mesh: &Mesh,
    k: usize,
    metric: FpsMetric,
    seed: u64,
) -> Result<Vec<usize>> {
    farthest_point_sampling_from(mesh, k, metric, seeded_first_vertex(mesh, seed))
}

/// `k` vertices by farthest point sampling starting at vertex `first` (the
/// first element of the result when `k > 0`). Errors if `first` is out of
/// range or `k` exceeds the number of vertices.
pub fn farthest_point_sampling_from(
    mesh: &Mesh,
    k: usize,
    metric: FpsMetric,
    first: usize,
) -> Result<Vec<usize>> {
    let n = mesh.n_vertices();
    if first >= n {
        return Err(Error::invalid(format!(
            "first sample {first} out of range ({n} vertices)"
        )));
    }
    if k > n {
        return Err(Error::invalid(format!(
            "cannot sample {k} distinct vertices from {n}"
        )));
    }
    farthest_point_sampling_masked(mesh, k, metric, first, None)
}

/// Farthest point sampling among the vertices of `pool` only (distances
/// still over the whole mesh): the first sample is `pool[i]` with `i`
/// seeded, then repeatedly the pool vertex farthest from the samples.
/// For restricting candidates to vertices with a known correspondence.
/// Errors on an empty pool, a vertex out of range, a repeated vertex, or
/// `k > pool.len()`.
pub fn farthest_point_sampling_in(
    mesh: &Mesh,
    pool: &[usize],
    k: usize,
    metric: FpsMetric,
    seed: u64,
) -> Result<Vec<usize>> {
    let n = mesh.n_vertices();
    if pool.is_empty() {
        return Err(Error::invalid("the candidate pool is empty"));
    }
    let mut allowed = vec![false; n];
    for &v in pool {
        if v >= n {
            return Err(Error::invalid(format!(
                "candidate pool vertex {v} out of range ({n} vertices)"
            )));
        }
        if allowed[v] {
            return Err(Error::invalid(format!(
                "candidate pool vertex {v} is repeated"
            )));
        }
        allowed[v] = true;
    }
    if k > pool.len() {
        return Err(Error::invalid(format!(
            "cannot sample {k} distinct vertices from a pool of {}",
            pool.len()
        )));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let first = pool[rng.random_range(0..pool.len())];
    farthest_point_sampling_masked(mesh, k, metric, first, Some(&allowed))
}

fn farthest_point_sampling_masked(
    mesh: &Mesh,
    k: usize,
    metric: FpsMetric,
    first: usize,
    allowed: Option<&[bool]>,
) -> Result<Vec<usize>> {
    let n = mesh.n_vertices();
    let graph = match metric {
        FpsMetric::Geodesic => Some(EdgeGraph::new(mesh)),
        FpsMetric::Euclidean => None,
    };
    let v = mesh.vertices();
    let mut min_dist = vec![f64::INFINITY; n];
    let mut chosen = vec![false; n];
    if let Some(a) = allowed {
        for (c, &ok) in chosen.iter_mut().zip(a) {
            *c = !ok;
        }
    }
    let mut out = Vec::with_capacity(k);
    let mut next = first;
    while out.len() < k {
        out.push(next);
        chosen[next] = true;
        match &graph {
            Some(g) => g.relax_from(next, &mut min_dist)?,
            None => {
                for (d, p) in min_dist.iter_mut().zip(v) {
                    *d = d.min((p - v[next]).norm());
                }
            }
        }
        // Strictly greater keeps the lowest index on ties.
        let mut best: Option<(usize, f64)> = None;
        for (i, &d) in min_dist.iter().enumerate() {
            if !chosen[i] && best.is_none_or(|(_, bd)| d > bd) {
                best = Some((i, d));
            }
        }
        match best {
            Some((i, _)) => next = i,
            None => break,
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::primitives::{grid, icosphere};

    #[test]
    fn grid_corners_first() {
        // From corner 0 of the unit square, the farthest vertex is the
        // opposite corner, then the remaining two corners (lowest index
        // first on the tie).
        let g = grid(4, 4);
        let s = farthest_point_sampling_from(&g, 4, FpsMetric::Euclidean, 0).unwrap();
        assert_eq!(s, vec![0, 24, 4, 20]);
        let s = farthest_point_sampling_from(&g, 2, FpsMetric::Geodesic, 0).unwrap();
        assert_eq!(s, vec![0, 24]);
    }

    #[test]
    fn pool_restricts_samples() {
        let g = grid(4, 4);
        let pool = [6, 7, 8, 12, 24, 0];
        let s = farthest_point_sampling_in(&g, &pool, 3, FpsMetric::Euclidean, 3).unwrap();
        assert!(s.iter().all(|v| pool.contains(v)));
        // After the first, the farthest pool vertices; the whole pool when k = |pool|.
        let all = farthest_point_sampling_in(&g, &pool, 6, FpsMetric::Geodesic, 3).unwrap();
        let mut sorted = all.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, vec![0, 6, 7, 8, 12, 24]);
        assert!(farthest_point_sampling_in(&g, &pool, 7, FpsMetric::Euclidean, 3).is_err());
        assert!(farthest_point_sampling_in(&g, &[], 1, FpsMetric::Euclidean, 3).is_err());
        assert!(farthest_point_sampling_in(&g, &[3, 3], 1, FpsMetric::Euclidean, 3).is_err());
        assert!(farthest_point_sampling_in(&g, &[99], 1, FpsMetric::Euclidean, 3).is_err());
        // From corner 0 the farthest of {0, 12, 24} is 24.
        let s = farthest_point_sampling_masked(
            &g,
            2,
            FpsMetric::Euclidean,
            0,
            Some(&{
                let mut a = vec![false; 25];
                for v in [0, 12, 24] {
                    a[v] = true;
                }
                a
            }),
        )
        .unwrap();
        assert_eq!(s, vec![0, 24]);
    }

    #[test]
    fn sphere_antipode() {
        let m = icosphere(2);
        let s = farthest_point_sampling_from(&m, 2, FpsMetric::Euclidean, 7).unwrap();
        let (a, b) = (m.vertices()[s[0]], m.vertices()[s[1]]);
        assert!((a.coords + b.coords).norm() < 1e-12);
    }

    #[test]
    fn seeded_is_deterministic_and_checks_input() {
        let m = icosphere(1);
        let a = farthest_point_sampling(&m, 10, FpsMetric::Geodesic, 42).unwrap();
        let b = farthest_point_sampling(&m, 10, FpsMetric::Geodesic, 42).unwrap();
        assert_eq!(a, b);
        assert_eq!(a[0], seeded_first_vertex(&m, 42));
        let all = farthest_point_sampling(&m, m.n_vertices(), FpsMetric::Euclidean, 1).unwrap();
        let mut sorted = all.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), m.n_vertices());
        assert!(farthest_point_sampling(&m, m.n_vertices() + 1, FpsMetric::Euclidean, 0).is_err());
        assert!(farthest_point_sampling_from(&m, 1, FpsMetric::Euclidean, 99).is_err());
        assert!(farthest_point_sampling_from(&m, 0, FpsMetric::Euclidean, 0)
            .unwrap()
            .is_empty());
    }
}

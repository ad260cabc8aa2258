//! The crate's one nearest-neighbour index over 3-D points: a thin wrapper
//! around a `kiddo` immutable kd-tree, built once on a fixed point set and
//! queried many times (closest points of the nonrigid ICP loops, key point
//! snapping, correspondence queries, symmetric distances).
//!
//! Every kd-tree user goes through [`PointIndex`], so the tie-breaking of
//! equidistant points is the same everywhere (that of `kiddo`).

use std::num::NonZero;

use kiddo::{ImmutableKdTree, SquaredEuclidean};

use crate::{Error, Point, Result};

/// Nearest-neighbour index of a fixed set of points.
pub struct PointIndex {
    tree: ImmutableKdTree<f64, 3>,
}

/// One hit of [`PointIndex::nearest_n`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    /// Index of the point in the indexed set.
    pub index: usize,
    /// Squared Euclidean distance to the query.
    pub distance_squared: f64,
}

impl Neighbour {
    /// Euclidean distance to the query (rounding noise below 0 clamped).
    pub fn distance(&self) -> f64 {
        self.distance_squared.max(0.0).sqrt()
    }
}

impl PointIndex {
    /// Indexes `points` (their order defines the returned indices).
    pub fn new(points: &[Point]) -> Result<Self> {
        let pts: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
        let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&pts)
            .map_err(|e| Error::numerical(format!("kd-tree construction failed: {e:?}")))?;
        Ok(PointIndex { tree })
    }

    /// The nearest indexed point to `p` and its distance.
    pub fn nearest(&self, p: &Point) -> (usize, f64) {
        let r = self
            .tree
            .query(&[p.x, p.y, p.z])
            .nearest_one::<SquaredEuclidean<f64>>()
            .execute();
        (r.item as usize, r.distance.max(0.0).sqrt())
    }

    /// The `k` nearest indexed points to `p` (at least one), nearest first.
    pub fn nearest_n(&self, p: &Point, k: usize) -> Vec<Neighbour> {
        let k = NonZero::new(k.max(1)).unwrap_or(NonZero::<usize>::MIN);
        self.tree
            .query(&[p.x, p.y, p.z])
            .nearest_n::<SquaredEuclidean<f64>>(k)
            .execute()
            .iter()
            .map(|h| Neighbour {
                index: h.item as usize,
                distance_squared: h.distance,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_matches_brute_force() {
        // Points on a skewed grid (distinct distances to the queries).
        let pts: Vec<Point> = (0..60)
            .map(|i| {
                let f = i as f64;
                Point::new((f * 0.37).sin(), (f * 0.71).cos(), f * 0.013)
            })
            .collect();
        let index = PointIndex::new(&pts).unwrap();
        for q in [
            Point::new(0.1, 0.2, 0.3),
            Point::new(-0.9, 0.4, 0.0),
            pts[17],
        ] {
            let mut brute: Vec<(f64, usize)> = pts
                .iter()
                .enumerate()
                .map(|(i, p)| ((p - q).norm_squared(), i))
                .collect();
            brute.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (i, d) = index.nearest(&q);
            assert_eq!(i, brute[0].1);
            assert!((d - brute[0].0.sqrt()).abs() < 1e-12);
            let hits = index.nearest_n(&q, 5);
            assert_eq!(hits.len(), 5);
            for (h, b) in hits.iter().zip(&brute) {
                assert_eq!(h.index, b.1);
                assert!((h.distance() - b.0.sqrt()).abs() < 1e-12);
            }
            // k = 0 is one neighbour.
            assert_eq!(index.nearest_n(&q, 0).len(), 1);
        }
    }
}

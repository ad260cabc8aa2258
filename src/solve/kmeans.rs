//! Seeded k-means (Lloyd iterations, k-means++ initialisation) over the rows
//! of a dense matrix.
//!
//! **Determinism.** Every random choice comes from a `ChaCha8Rng` seeded by
//! the caller; restart `r` uses a generator derived from `(seed, r)`. The
//! implementation is sequential, so results are independent of the thread
//! count. Ties are broken towards the lower index (nearest centre, best
//! restart).
//!
//! **Empty clusters.** After an update step, a cluster that lost all its
//! points is re-seeded at the point currently farthest from its own centre
//! (lowest index on ties; a point is used at most once per step). That point
//! then sits at distance 0 from its new centre, so the next assignment cannot
//! increase the inertia: the inertia recorded after each assignment step is
//! non-increasing ([`KMeans::inertia_trace`]).

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::{Error, Result};

/// Options of [`kmeans_with`].
#[derive(Clone, Debug, PartialEq)]
pub struct KMeansOptions {
    /// Maximum number of Lloyd iterations per restart (assignment + update).
    pub max_iter: usize,
    /// Number of k-means++ restarts; the run with the smallest inertia wins
    /// (the earliest on ties).
    pub n_init: usize,
}

impl Default for KMeansOptions {
    fn default() -> Self {
        KMeansOptions {
            max_iter: 300,
            n_init: 1,
        }
    }
}

/// Result of k-means.
#[derive(Clone, Debug, PartialEq)]
pub struct KMeans {
    /// Cluster of each row, in `0..k`.
    pub labels: Vec<usize>,
    /// k × d cluster centres (the mean of each cluster's rows).
    pub centers: DMatrix<f64>,
    /// Sum of squared distances of the rows to their centres.
    pub inertia: f64,
    /// Inertia after each assignment step of the winning restart
    /// (non-increasing; the last entry equals `inertia`).
    pub inertia_trace: Vec<f64>,
    /// Lloyd iterations of the winning restart.
    pub iterations: usize,
}

/// k-means with one restart (see [`kmeans_with`]).
pub fn kmeans(data: &DMatrix<f64>, k: usize, seed: u64, max_iter: usize) -> Result<KMeans> {
    kmeans_with(
        data,
        k,
        seed,
        &KMeansOptions {
            max_iter,
            n_init: 1,
        },
    )
}

/// k-means over the rows of `data` (n × d) into `k` clusters: k-means++
/// initialisation from `seed`, then Lloyd iterations until the labels stop
/// changing or `max_iter` is reached; `opts.n_init` restarts.
///
/// Errors if `k = 0`, `k > n`, `n_init = 0` or `data` has a non-finite entry.
pub fn kmeans_with(
    data: &DMatrix<f64>,
    k: usize,
    seed: u64,
    opts: &KMeansOptions,
) -> Result<KMeans> {
    let n = data.nrows();
    if k == 0 {
        return Err(Error::invalid("k-means needs k ≥ 1 clusters"));
    }
    if k > n {
        return Err(Error::invalid(format!(
            "k-means asked for {k} clusters of {n} points"
        )));
    }
    if opts.n_init == 0 {
        return Err(Error::invalid("k-means needs n_init ≥ 1"));
    }
    if let Some(pos) = data.iter().position(|x| !x.is_finite()) {
        return Err(Error::invalid(format!(
            "k-means data has a non-finite entry at row {}, column {}",
            pos % n,
            pos / n
        )));
    }
    // Row-major copy: rows are contiguous, which the distance loops want.
    let d = data.ncols();
    let rows: Vec<f64> = (0..n)
        .flat_map(|i| (0..d).map(move |j| (i, j)))
        .map(|(i, j)| data[(i, j)])
        .collect();
    let pts = Points { rows, d };
    let mut best: Option<KMeans> = None;
    for r in 0..opts.n_init {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(r as u64);
        let run = lloyd(&pts, n, k, &mut rng, opts.max_iter);
        if best.as_ref().is_none_or(|b| run.inertia < b.inertia) {
            best = Some(run);
        }
    }
    best.ok_or_else(|| Error::numerical("k-means produced no run"))
}

struct Points {
    rows: Vec<f64>,
    d: usize,
}

impl Points {
    fn row(&self, i: usize) -> &[f64] {
        &self.rows[i * self.d..(i + 1) * self.d]
    }
}

fn dist2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// k-means++ seeding: first centre uniform, then each next one with
/// probability proportional to the squared distance to the nearest chosen
/// centre (uniform over all points if every distance is 0).
fn kmeans_pp(pts: &Points, n: usize, k: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let d = pts.d;
    let mut centers = Vec::with_capacity(k * d);
    let first = rng.random_range(0..n);
    centers.extend_from_slice(pts.row(first));
    let mut nearest: Vec<f64> = (0..n).map(|i| dist2(pts.row(i), pts.row(first))).collect();
    for _ in 1..k {
        let total: f64 = nearest.iter().sum();
        let pick = if total > 0.0 {
            let target = rng.random::<f64>() * total;
            let mut acc = 0.0;
            let mut chosen = None;
            for (i, &x) in nearest.iter().enumerate() {
                acc += x;
                if x > 0.0 && acc > target {
                    chosen = Some(i);
                    break;
                }
            }
            // Rounding can leave `acc` just below `target`: take the last
            // point with positive weight.
            chosen.unwrap_or_else(|| nearest.iter().rposition(|&x| x > 0.0).unwrap_or(0))
        } else {
            rng.random_range(0..n)
        };
        centers.extend_from_slice(pts.row(pick));
        let c = &centers[centers.len() - d..];
        for (i, x) in nearest.iter_mut().enumerate() {
            *x = x.min(dist2(pts.row(i), c));
        }
    }
    centers
}

/// Assigns each point to its nearest centre (lowest index on ties); returns
/// the squared distances.
fn assign(pts: &Points, n: usize, k: usize, centers: &[f64], labels: &mut [usize]) -> Vec<f64> {
    let d = pts.d;
    (0..n)
        .map(|i| {
            let p = pts.row(i);
            let mut best = (f64::INFINITY, 0);
            for c in 0..k {
                let dd = dist2(p, &centers[c * d..(c + 1) * d]);
                if dd < best.0 {
                    best = (dd, c);
                }
            }
            labels[i] = best.1;
            best.0
        })
        .collect()
}

fn lloyd(pts: &Points, n: usize, k: usize, rng: &mut ChaCha8Rng, max_iter: usize) -> KMeans {
    let d = pts.d;
    let mut centers = kmeans_pp(pts, n, k, rng);
    let mut labels = vec![usize::MAX; n];
    let mut dist = assign(pts, n, k, &centers, &mut labels);
    let mut trace = vec![dist.iter().sum::<f64>()];
    let mut iterations = 0;
    for _ in 0..max_iter {
        iterations += 1;
        // Update step: means, in index order.
        let mut sums = vec![0.0; k * d];
        let mut counts = vec![0usize; k];
        for (i, &c) in labels.iter().enumerate() {
            counts[c] += 1;
            for (s, x) in sums[c * d..(c + 1) * d].iter_mut().zip(pts.row(i)) {
                *s += x;
            }
        }
        let mut used = vec![false; n];
        for c in 0..k {
            if counts[c] > 0 {
                let inv = 1.0 / counts[c] as f64;
                for (dst, s) in centers[c * d..(c + 1) * d]
                    .iter_mut()
                    .zip(&sums[c * d..(c + 1) * d])
                {
                    *dst = s * inv;
                }
            } else {
                // Re-seed at the farthest point not yet used (lowest index on
                // ties); the distances are those to the old centres.
                let mut far = (f64::NEG_INFINITY, None);
                for (i, &x) in dist.iter().enumerate() {
                    if !used[i] && x > far.0 {
                        far = (x, Some(i));
                    }
                }
                if let Some(i) = far.1 {
                    used[i] = true;
                    centers[c * d..(c + 1) * d].copy_from_slice(pts.row(i));
                }
            }
        }
        let old = labels.clone();
        dist = assign(pts, n, k, &centers, &mut labels);
        trace.push(dist.iter().sum());
        if labels == old {
            break;
        }
    }
    let inertia = dist.iter().sum();
    KMeans {
        labels,
        centers: DMatrix::from_fn(k, d, |c, j| centers[c * d + j]),
        inertia,
        inertia_trace: trace,
        iterations,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_input() {
        let x = DMatrix::from_fn(5, 2, |i, j| (i + j) as f64);
        assert!(kmeans(&x, 0, 1, 10).is_err());
        assert!(kmeans(&x, 6, 1, 10).is_err());
        let mut y = x.clone();
        y[(3, 1)] = f64::NAN;
        assert!(kmeans(&y, 2, 1, 10).is_err());
        assert!(kmeans(&x, 5, 1, 10).is_ok());
    }

    #[test]
    fn duplicates_fill_all_clusters() {
        // Three distinct points, many copies: k = 3 must find them.
        let x = DMatrix::from_fn(30, 1, |i, _| (i % 3) as f64);
        let r = kmeans(&x, 3, 7, 50).unwrap();
        assert!(r.inertia < 1e-20);
        let r = kmeans(&x, 5, 7, 50).unwrap();
        assert!(r.inertia < 1e-20);
    }
}

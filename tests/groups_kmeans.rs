//! Property tests for seeded k-means (`deformlab::solve::kmeans`):
//! determinism, recovery of well-separated blobs, non-increasing inertia.
//! `cargo test --release --test groups_kmeans`.

use deformlab::solve::kmeans::{kmeans, kmeans_with, KMeansOptions};
use nalgebra::DMatrix;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `k` blobs of `per` points in `d` dimensions: centres 10 apart along
/// distinct directions, noise of radius `r`. Returns data and true labels.
fn blobs(k: usize, per: usize, d: usize, r: f64, seed: u64) -> (DMatrix<f64>, Vec<usize>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let centres: Vec<Vec<f64>> = (0..k)
        .map(|c| {
            (0..d)
                .map(|j| {
                    if j == c % d {
                        10.0 * (1 + c / d) as f64
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    // Interleave the blobs so that labels are not sorted by index.
    let n = k * per;
    let truth: Vec<usize> = (0..n).map(|i| i % k).collect();
    let x = DMatrix::from_fn(n, d, |i, j| centres[truth[i]][j]);
    let noise = DMatrix::from_fn(n, d, |_, _| rng.random_range(-r..r));
    (x + noise, truth)
}

/// Same partition up to renaming of the clusters.
fn same_partition(a: &[usize], b: &[usize]) -> bool {
    let mut map = std::collections::HashMap::new();
    let mut inv = std::collections::HashMap::new();
    a.iter()
        .zip(b)
        .all(|(x, y)| *map.entry(*x).or_insert(*y) == *y && *inv.entry(*y).or_insert(*x) == *x)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn deterministic_for_a_seed(n in 5usize..60, d in 1usize..5, k in 1usize..5, seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x = DMatrix::from_fn(n, d, |_, _| rng.random_range(-1.0..1.0));
        let k = k.min(n);
        let opts = KMeansOptions { max_iter: 100, n_init: 3 };
        let a = kmeans_with(&x, k, seed, &opts).unwrap();
        let b = kmeans_with(&x, k, seed, &opts).unwrap();
        prop_assert_eq!(&a, &b);
        prop_assert!(a.labels.iter().all(|&l| l < k));
        prop_assert_eq!(a.centers.shape(), (k, d));
    }

    #[test]
    fn well_separated_blobs_are_recovered(k in 1usize..6, per in 3usize..20, d in 2usize..4, seed in any::<u64>()) {
        let (x, truth) = blobs(k, per, d, 1.0, seed);
        let opts = KMeansOptions { max_iter: 100, n_init: 5 };
        let r = kmeans_with(&x, k, seed, &opts).unwrap();
        prop_assert!(same_partition(&r.labels, &truth), "labels {:?}", r.labels);
    }

    #[test]
    fn inertia_never_increases(n in 5usize..80, d in 1usize..4, k in 1usize..8, seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x = DMatrix::from_fn(n, d, |_, _| rng.random_range(-1.0..1.0));
        let k = k.min(n);
        let r = kmeans(&x, k, seed, 100).unwrap();
        let tr = &r.inertia_trace;
        for w in tr.windows(2) {
            prop_assert!(w[1] <= w[0] * (1.0 + 1e-12) + 1e-300, "{:?}", tr);
        }
        prop_assert!((tr.last().unwrap() - r.inertia).abs() <= 1e-12 * r.inertia.max(1e-300));
        // Inertia equals the distances to the reported centres.
        let direct: f64 = (0..n).map(|i| (x.row(i) - r.centers.row(r.labels[i])).norm_squared()).sum();
        prop_assert!((direct - r.inertia).abs() <= 1e-9 * direct.max(1e-12));
    }
}

#[test]
fn more_restarts_never_worse() {
    let (x, _) = blobs(6, 15, 3, 6.0, 3);
    let one = kmeans_with(
        &x,
        6,
        11,
        &KMeansOptions {
            max_iter: 100,
            n_init: 1,
        },
    )
    .unwrap();
    let many = kmeans_with(
        &x,
        6,
        11,
        &KMeansOptions {
            max_iter: 100,
            n_init: 8,
        },
    )
    .unwrap();
    assert!(many.inertia <= one.inertia);
}

#[test]
fn bad_input_is_an_error() {
    let x = DMatrix::from_fn(4, 2, |i, j| (i * j) as f64);
    assert!(kmeans(&x, 0, 0, 10).is_err());
    assert!(kmeans(&x, 5, 0, 10).is_err());
    assert!(kmeans(&DMatrix::zeros(0, 2), 1, 0, 10).is_err());
    let mut y = x.clone();
    y[(1, 1)] = f64::NAN;
    assert!(kmeans(&y, 2, 0, 10).is_err());
    assert!(kmeans_with(
        &x,
        2,
        0,
        &KMeansOptions {
            max_iter: 10,
            n_init: 0
        }
    )
    .is_err());
}

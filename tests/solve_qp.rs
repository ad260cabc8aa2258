//! Box- and simplex-constrained QPs (`solve::qp`): optimality checked by
//! independent dense KKT computations, for tiny problems by brute-force
//! enumeration of the active sets, and against the independent ADMM solver
//! (its certified duality gap).
//! `cargo test --release --test solve_qp`

use deformlab::solve::qp::{
    simplex_rows_qp, AdmmOptions, BoxQp, RowAdmm, RowConstraint, SimplexQpOptions,
};
use deformlab::solve::{sparse_from_triplets, SparseMatrix};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random sparse SPD matrix `Mᵀ M + δ I` with a banded random `M` (a few
/// entries per row, so the pattern is sparse but irregular), as both a
/// sparse matrix (both triangles) and a dense copy.
fn random_spd(n: usize, seed: u64) -> (SparseMatrix, DMatrix<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut m = DMatrix::<f64>::zeros(n, n);
    for i in 0..n {
        m[(i, i)] = rng.random_range(0.5..2.0);
        for _ in 0..2 {
            let j = (i + rng.random_range(1..4)) % n;
            m[(i, j)] += rng.random_range(-1.0..1.0);
        }
    }
    let mut a = m.transpose() * &m;
    for i in 0..n {
        a[(i, i)] += 0.05;
    }
    let mut trip = Vec::new();
    for j in 0..n {
        for i in 0..n {
            if a[(i, j)] != 0.0 {
                trip.push((i, j, a[(i, j)]));
            }
        }
    }
    (sparse_from_triplets(n, n, trip), a)
}

fn random_vec(n: usize, scale: f64, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xabcdef);
    (0..n)
        .map(|_| scale * rng.random_range(-1.0..1.0))
        .collect()
}

/// Largest violation of the box-QP KKT conditions at `x`, computed densely:
/// `g = A x + b` must vanish where `lo < x < hi`, be ≥ 0 at `lo`, ≤ 0 at
/// `hi`; `x` must lie in the box. Relative to `A_ii` (weight units).
fn box_kkt(a: &DMatrix<f64>, b: &[f64], x: &[f64], lo: f64, hi: f64) -> f64 {
    let xv = DVector::from_column_slice(x);
    let g = a * xv + DVector::from_column_slice(b);
    let mut r = 0.0f64;
    for i in 0..x.len() {
        assert!(x[i] >= lo && x[i] <= hi, "x[{i}] = {} outside box", x[i]);
        let s = g[i] / a[(i, i)];
        r = r.max(if x[i] == lo {
            (-s).max(0.0)
        } else if x[i] == hi {
            s.max(0.0)
        } else {
            s.abs()
        });
    }
    r
}

/// Exact minimiser by enumerating all 3ⁿ assignments (free / lower /
/// upper) and keeping the KKT point.
fn brute_force_box(a: &DMatrix<f64>, b: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    let n = b.len();
    let mut best: Option<(f64, Vec<f64>)> = None;
    for code in 0..3usize.pow(n as u32) {
        let mut c = code;
        let state: Vec<usize> = (0..n)
            .map(|_| {
                let s = c % 3;
                c /= 3;
                s
            })
            .collect();
        let mut x = vec![0.0; n];
        let free: Vec<usize> = (0..n).filter(|&i| state[i] == 0).collect();
        for i in 0..n {
            x[i] = match state[i] {
                1 => lo,
                2 => hi,
                _ => 0.0,
            };
        }
        if !free.is_empty() {
            let k = free.len();
            let mut aff = DMatrix::<f64>::zeros(k, k);
            let mut rhs = DVector::<f64>::zeros(k);
            for (r, &i) in free.iter().enumerate() {
                rhs[r] = -b[i];
                for j in 0..n {
                    if state[j] != 0 {
                        rhs[r] -= a[(i, j)] * x[j];
                    }
                }
                for (s, &j) in free.iter().enumerate() {
                    aff[(r, s)] = a[(i, j)];
                }
            }
            let y = aff.cholesky().unwrap().solve(&rhs);
            for (r, &i) in free.iter().enumerate() {
                x[i] = y[r];
            }
        }
        if x.iter().any(|&v| v < lo - 1e-12 || v > hi + 1e-12) {
            continue;
        }
        let xv = DVector::from_column_slice(&x);
        let f = 0.5 * xv.dot(&(a * &xv)) + xv.dot(&DVector::from_column_slice(b));
        if best.as_ref().is_none_or(|(bf, _)| f < *bf) {
            best = Some((f, x));
        }
    }
    best.unwrap().1
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Converged box-QP solutions satisfy the KKT conditions (checked
    /// densely) and are reported as converged with a small residual.
    #[test]
    fn box_qp_satisfies_kkt(n in 2usize..60, seed in any::<u64>(), scale in 0.1f64..20.0,
                            warm in any::<bool>(), hops in 0usize..4) {
        let (a, ad) = random_spd(n, seed);
        let b = random_vec(n, scale, seed);
        let qp = BoxQp::new(&a).unwrap().with_local_hops(hops);
        let x0 = random_vec(n, 2.0, seed ^ 1);
        let s = qp.solve(&b, -0.5, 1.0, if warm { Some(&x0) } else { None }, 200, 1e-10).unwrap();
        prop_assert!(s.converged);
        let r = box_kkt(&ad, &b, &s.x, -0.5, 1.0);
        prop_assert!(r < 1e-8, "KKT residual {r}");
        prop_assert!((s.kkt_residual - r).abs() < 1e-9, "reported {} vs {r}", s.kkt_residual);
    }

    /// Tiny problems: identical to brute-force enumeration of active sets.
    #[test]
    fn box_qp_matches_enumeration(n in 1usize..=6, seed in any::<u64>(), scale in 0.5f64..10.0) {
        let (a, ad) = random_spd(n, seed);
        let b = random_vec(n, scale, seed);
        let qp = BoxQp::new(&a).unwrap();
        let s = qp.solve(&b, 0.0, 1.0, None, 100, 1e-12).unwrap();
        let x = brute_force_box(&ad, &b, 0.0, 1.0);
        for (i, (a, b)) in s.x.iter().zip(&x).enumerate() {
            prop_assert!((a - b).abs() < 1e-9, "x[{i}]: {a} vs {b}");
        }
    }

    /// Simplex-constrained rows: every row on the simplex, and the KKT
    /// conditions (equal gradients on the support, no cheaper column off it)
    /// checked densely.
    #[test]
    fn simplex_rows_satisfy_kkt(n in 2usize..40, m in 1usize..6, seed in any::<u64>(),
                                scale in 0.1f64..10.0, hops in 0usize..3) {
        let (a, ad) = random_spd(n, seed);
        let b = DMatrix::from_column_slice(n, m, &random_vec(n * m, scale, seed));
        let x0 = DMatrix::from_element(n, m, 1.0 / m as f64);
        let opts = SimplexQpOptions { local_hops: hops, ..SimplexQpOptions::new(200, 1e-10) };
        let s = simplex_rows_qp(&a, &b, &x0, &opts).unwrap();
        prop_assert!(s.converged);
        let g = &ad * &s.x + &b;
        let mut worst = 0.0f64;
        for i in 0..n {
            let row_sum: f64 = s.x.row(i).sum();
            prop_assert!((row_sum - 1.0).abs() < 1e-12);
            prop_assert!(s.x.row(i).iter().all(|&v| v >= 0.0));
            let p = (0..m).max_by(|&p, &q| s.x[(i, p)].total_cmp(&s.x[(i, q)])).unwrap();
            for k in 0..m {
                let d = (g[(i, k)] - g[(i, p)]) / ad[(i, i)];
                worst = worst.max(if s.x[(i, k)] > 0.0 { d.abs() } else { (-d).max(0.0) });
            }
        }
        prop_assert!(worst < 1e-8, "KKT residual {worst}");
        prop_assert!((s.kkt_residual - worst).abs() < 1e-9);
        prop_assert!(!s.stopped_on_step, "no step test was asked for");
    }

    /// The step test (`step_tol > 0`): the result stays on the simplex row
    /// by row; a stop on the step test follows a global iteration that moved
    /// no entry by more than `step_tol`; any other stop is the KKT one.
    #[test]
    fn simplex_step_test_keeps_rows_feasible(n in 2usize..40, m in 2usize..6,
                                             seed in any::<u64>(), scale in 0.1f64..10.0,
                                             log_step in -9.0f64..-2.0) {
        let (a, _) = random_spd(n, seed);
        let b = DMatrix::from_column_slice(n, m, &random_vec(n * m, scale, seed ^ 1));
        let x0 = DMatrix::from_element(n, m, 1.0 / m as f64);
        let step_tol = 10f64.powf(log_step);
        let opts = SimplexQpOptions { step_tol, ..SimplexQpOptions::new(200, 1e-10) };
        let s = simplex_rows_qp(&a, &b, &x0, &opts).unwrap();
        prop_assert!(s.converged);
        for i in 0..n {
            prop_assert!((s.x.row(i).sum() - 1.0).abs() < 1e-12);
            prop_assert!(s.x.row(i).iter().all(|&v| v >= 0.0));
        }
        if s.stopped_on_step {
            prop_assert!(s.last_step <= step_tol, "{} > {step_tol}", s.last_step);
            prop_assert!(s.iterations >= 2);
        } else {
            prop_assert!(s.kkt_residual < 1e-8, "KKT residual {}", s.kkt_residual);
        }
    }
}

#[test]
fn box_qp_cap_is_reported_not_silent() {
    // A 1-D chain pulled up strongly: the unconstrained optimum leaves the
    // box over a wide range, so one iteration from a cold start is not
    // enough.
    let n = 40;
    let mut t = Vec::new();
    for i in 0..n {
        t.push((i, i, 2.0));
        if i + 1 < n {
            t.push((i, i + 1, -1.0));
            t.push((i + 1, i, -1.0));
        }
    }
    let a = sparse_from_triplets(n, n, t);
    let b: Vec<f64> = (0..n)
        .map(|i| if i % 7 == 0 { -5.0 } else { 0.3 })
        .collect();
    let qp = BoxQp::new(&a).unwrap();
    let full = qp.solve(&b, 0.0, 1.0, None, 100, 1e-12).unwrap();
    assert!(full.converged && full.iterations > 1 && full.kkt_residual < 1e-10);
    let capped = qp.solve(&b, 0.0, 1.0, None, 1, 1e-12).unwrap();
    assert!(!capped.converged);
    assert_eq!(capped.iterations, 1);
    assert!(capped.kkt_residual > 1e-3, "{}", capped.kkt_residual);
    assert!(capped.x.iter().all(|&v| (0.0..=1.0).contains(&v)));
}

#[test]
fn box_qp_rejects_bad_input() {
    let (a, _) = random_spd(5, 3);
    let qp = BoxQp::new(&a).unwrap();
    assert!(qp.solve(&[0.0; 4], 0.0, 1.0, None, 10, 1e-9).is_err());
    assert!(qp.solve(&[0.0; 5], 1.0, 1.0, None, 10, 1e-9).is_err());
    assert!(qp
        .solve(&[0.0; 5], 0.0, f64::INFINITY, None, 10, 1e-9)
        .is_err());
    assert!(qp
        .solve(&[0.0; 5], 0.0, 1.0, Some(&[0.0; 3]), 10, 1e-9)
        .is_err());
    // Not symmetric, and a non-positive diagonal.
    let ns = sparse_from_triplets(2, 2, vec![(0, 0, 1.0), (1, 1, 1.0), (0, 1, 0.5)]);
    let e = BoxQp::new(&ns).unwrap_err();
    assert!(e.to_string().contains("symmetric"), "{e}");
    let nd = sparse_from_triplets(2, 2, vec![(0, 0, 1.0), (1, 1, 0.0)]);
    assert!(BoxQp::new(&nd).is_err());
    // Indefinite on the free block: an error naming positive definiteness,
    // not a panic.
    let indef = sparse_from_triplets(
        2,
        2,
        vec![(0, 0, 1.0), (1, 1, 1.0), (0, 1, 2.0), (1, 0, 2.0)],
    );
    let qp = BoxQp::new(&indef).unwrap();
    let e = qp
        .solve(&[0.0, 0.0], -1.0, 1.0, None, 10, 1e-9)
        .unwrap_err();
    assert!(e.to_string().contains("positive definite"), "{e}");
}

#[test]
fn box_qp_same_result_in_parallel() {
    // Solving many right-hand sides from a 2-thread pool gives bitwise the
    // results of sequential solves.
    let (a, _) = random_spd(80, 11);
    let qp = BoxQp::new(&a).unwrap();
    let bs: Vec<Vec<f64>> = (0..8).map(|k| random_vec(80, 5.0, k)).collect();
    let seq: Vec<Vec<f64>> = bs
        .iter()
        .map(|b| qp.solve(b, 0.0, 1.0, None, 200, 1e-10).unwrap().x)
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let par: Vec<Vec<f64>> = pool.install(|| {
        use rayon::prelude::*;
        bs.par_iter()
            .map(|b| qp.solve(b, 0.0, 1.0, None, 200, 1e-10).unwrap().x)
            .collect()
    });
    assert_eq!(seq, par);
}

/// `Σ_k ½ x_kᵀA x_k + b_kᵀx_k`, densely.
fn dense_objective(a: &DMatrix<f64>, b: &DMatrix<f64>, x: &DMatrix<f64>) -> f64 {
    (0..x.ncols())
        .map(|k| {
            let xk = x.column(k);
            0.5 * xk.dot(&(a * xk)) + b.column(k).dot(&xk)
        })
        .sum()
}

#[test]
fn active_set_agrees_with_admm() {
    // Two independent solvers of the same problems: the exact active-set
    // methods and first-order ADMM with a certified duality gap. The
    // active-set optimum can be no worse than ADMM's feasible point, and no
    // better than ADMM's dual bound; by strong convexity (λ_min(A) ≥ 0.05,
    // the δ of `random_spd`) the two points are then within
    // √(2·gap/λ_min) of each other.
    let (n, m) = (30, 3);
    for seed in 0..4u64 {
        let (a, ad) = random_spd(n, seed);
        let b = DMatrix::from_column_slice(n, m, &random_vec(n * m, 3.0, seed));
        let x0 = DMatrix::from_element(n, m, 1.0 / m as f64);
        let opts = AdmmOptions {
            max_iter: 20_000,
            gap_tol: 1e-11,
            rho_scale: 1.0,
            adapt_every: 25,
        };
        let ones = vec![1.0; n];
        for constraint in [RowConstraint::Box(0.0, 1.0), RowConstraint::Simplex] {
            let admm = RowAdmm::new(&a, &ones, constraint).unwrap();
            let z = admm.solve(&b, &x0, &opts).unwrap();
            assert!(
                z.converged,
                "seed {seed} {constraint:?}: gap {}",
                z.duality_gap
            );
            let x = match constraint {
                RowConstraint::Box(lo, hi) => {
                    let qp = BoxQp::new(&a).unwrap();
                    let mut x = DMatrix::zeros(n, m);
                    for k in 0..m {
                        let bk: Vec<f64> = b.column(k).iter().copied().collect();
                        let s = qp.solve(&bk, lo, hi, None, 200, 1e-12).unwrap();
                        assert!(s.converged);
                        x.column_mut(k).copy_from_slice(&s.x);
                    }
                    x
                }
                RowConstraint::Simplex => {
                    let s =
                        simplex_rows_qp(&a, &b, &x0, &SimplexQpOptions::new(200, 1e-12)).unwrap();
                    assert!(s.converged);
                    s.x
                }
            };
            let (fa, fz) = (dense_objective(&ad, &b, &x), dense_objective(&ad, &b, &z.x));
            assert!(
                fa <= fz + 1e-10,
                "seed {seed} {constraint:?}: {fa} > ADMM {fz}"
            );
            assert!(
                fz - fa <= z.duality_gap + 1e-10,
                "seed {seed} {constraint:?}: below ADMM's dual bound ({fz} − {fa} > {})",
                z.duality_gap
            );
            let bound = (2.0 * (z.duality_gap.max(0.0) + 1e-10) / 0.05).sqrt();
            let diff = (&x - &z.x).abs().max();
            assert!(
                diff <= bound,
                "seed {seed} {constraint:?}: |x − z| = {diff} > {bound}"
            );
            assert!(diff < 1e-3, "seed {seed} {constraint:?}: |x − z| = {diff}");
        }
    }
}

/// The allocator settings of `solve::keep_freed_memory` (called by the CLI
/// and the binding) are accepted by glibc: a rejected value (e.g. a
/// threshold above what `mallopt` allows) returns false.
#[test]
fn allocator_settings_apply_on_glibc() {
    let applied = deformlab::solve::keep_freed_memory();
    assert_eq!(
        applied,
        cfg!(all(target_os = "linux", target_env = "gnu")),
        "keep_freed_memory applied: {applied}"
    );
}

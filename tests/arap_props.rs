//! Property tests for the reduced ARAP solver (`deformlab::arap`): energy
//! sign, rigid invariance, monotone local/global iterations, reduced
//! bookkeeping against the direct full-mesh energy, in both the E_diff mode
//! and the FAST ablation (handle constraints).
//! `cargo test --release --test arap_props`.

use deformlab::arap::{ArapOptions, ReducedArap};
use deformlab::mesh::primitives::{icosphere, torus};
use deformlab::ops::rotation::rotation_exp_axis_angle;
use deformlab::skin::transforms_to_stacked;
use deformlab::skin::Affine;
use deformlab::{Mesh, Point, Vec3};
use nalgebra::DMatrix;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A perturbed closed mesh (icosphere or torus), built deterministically.
fn mesh(kind: u8, noise: f64, seed: u64) -> Mesh {
    let base = if kind == 0 {
        icosphere(2)
    } else {
        torus(1.0, 0.4, 16, 8)
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let v: Vec<Point> = base
        .vertices()
        .iter()
        .map(|p| {
            let d = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            p + noise * d
        })
        .collect();
    base.with_vertices(v).unwrap()
}

/// Normalised Gaussian weights of `nh` handle vertices spread over the
/// index range, and the handle indices.
fn weights(m: &Mesh, nh: usize) -> (DMatrix<f64>, Vec<usize>) {
    let n = m.n_vertices();
    let handles: Vec<usize> = (0..nh).map(|k| k * n / nh).collect();
    let v = m.vertices();
    let mut w = DMatrix::from_fn(n, nh, |i, k| {
        let d2 = (v[i] - v[handles[k]]).norm_squared();
        (-d2 / 0.3).exp() + 1e-6
    });
    for i in 0..n {
        let s: f64 = w.row(i).sum();
        w.row_mut(i).scale_mut(1.0 / s);
    }
    (w, handles)
}

/// Groups: the handle of largest weight.
fn argmax_groups(w: &DMatrix<f64>) -> Vec<usize> {
    (0..w.nrows())
        .map(|i| w.row(i).transpose().argmax().0)
        .collect()
}

fn rigid(m: &Mesh, axis_angle: Vec3, t: Vec3) -> Vec<Point> {
    let r = rotation_exp_axis_angle(&axis_angle);
    m.vertices()
        .iter()
        .map(|p| Point::from(r * p.coords + t))
        .collect()
}

/// A non-rigid target: a smooth bend-and-stretch of the mesh plus noise.
fn nonrigid(m: &Mesh, amount: f64, seed: u64) -> Vec<Point> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    m.vertices()
        .iter()
        .map(|p| {
            let r = rotation_exp_axis_angle(&Vec3::new(0.0, amount * p.z, 0.0));
            let q = r * p.coords;
            let n = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            Point::from(Vec3::new(q.x * (1.0 + 0.3 * amount), q.y, q.z) + 0.02 * n)
        })
        .collect()
}

fn scale_of(m: &Mesh, target: &[Point]) -> f64 {
    m.vertices()
        .iter()
        .chain(target)
        .map(|p| p.coords.norm_squared())
        .sum()
}

fn random_stacked(nh: usize, amount: f64, seed: u64) -> DMatrix<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let t: Vec<Affine> = (0..nh)
        .map(|_| Affine::identity() + Affine::from_fn(|_, _| amount * rng.random_range(-1.0..1.0)))
        .collect();
    transforms_to_stacked(&t)
}

fn opts(use_ediff: bool, handles: &[usize]) -> ArapOptions {
    ArapOptions {
        use_ediff,
        handles: handles.to_vec(),
        max_iter: 50,
        ..ArapOptions::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// E ≥ 0 for arbitrary transforms, and the reduced bookkeeping (trace[0]
    /// is the energy of `init`, the last entry that of the solution) equals
    /// the direct full-mesh evaluation.
    #[test]
    fn energy_nonnegative_and_bookkeeping_matches(
        kind in 0u8..2, noise in 0.0..0.05f64, nh in 2usize..7, amount in 0.0..0.5f64,
        seed in 0u64..1000, ediff in any::<bool>(),
    ) {
        let m = mesh(kind, noise, seed);
        let (w, handles) = weights(&m, nh);
        let g = argmax_groups(&w);
        let arap = ReducedArap::new(&m, &w, &g, opts(ediff, &handles)).unwrap();
        let target = nonrigid(&m, amount, seed + 1);
        let scale = scale_of(&m, &target);
        let init = random_stacked(nh, amount, seed + 2);
        let e_init = arap.energy(&init, &target).unwrap();
        prop_assert!(e_init >= 0.0);
        let sol = arap.solve(&target, Some(&init)).unwrap();
        let tol = 1e-10 * scale;
        prop_assert!((sol.energy_trace[0] - e_init).abs() <= tol,
            "init: reduced {} direct {}", sol.energy_trace[0], e_init);
        let e_sol = arap.energy(&sol.stacked, &target).unwrap();
        prop_assert!(e_sol >= 0.0);
        let last = *sol.energy_trace.last().unwrap();
        prop_assert!((last - e_sol).abs() <= tol, "final: reduced {} direct {}", last, e_sol);
    }

    /// The local/global iteration never increases E.
    #[test]
    fn iterations_never_increase_energy(
        kind in 0u8..2, noise in 0.0..0.05f64, nh in 2usize..7, amount in 0.0..0.8f64,
        seed in 0u64..1000, ediff in any::<bool>(), with_init in any::<bool>(),
    ) {
        let m = mesh(kind, noise, seed);
        let (w, handles) = weights(&m, nh);
        let g = argmax_groups(&w);
        let arap = ReducedArap::new(&m, &w, &g, opts(ediff, &handles)).unwrap();
        let target = nonrigid(&m, amount, seed + 1);
        let init = random_stacked(nh, 0.3, seed + 2);
        let sol = arap.solve(&target, with_init.then_some(&init)).unwrap();
        let tr = &sol.energy_trace;
        let slack = 1e-12 * tr[0].abs().max(scale_of(&m, &target));
        for k in 1..tr.len() {
            prop_assert!(tr[k] <= tr[k - 1] + slack, "step {}: {} > {}", k, tr[k], tr[k - 1]);
        }
    }

    /// A rigid motion of the whole mesh: the solution reaches E ≈ 0 and
    /// reproduces the target (E_diff mode, no init).
    #[test]
    fn rigid_motion_is_reproduced(
        kind in 0u8..2, noise in 0.0..0.05f64, nh in 1usize..7, seed in 0u64..1000,
        ax in -2.0..2.0f64, ay in -2.0..2.0f64, az in -2.0..2.0f64,
        tx in -3.0..3.0f64, ty in -3.0..3.0f64, tz in -3.0..3.0f64,
    ) {
        let m = mesh(kind, noise, seed);
        let (w, handles) = weights(&m, nh);
        let g = argmax_groups(&w);
        let arap = ReducedArap::new(&m, &w, &g, opts(true, &handles)).unwrap();
        let target = rigid(&m, Vec3::new(ax, ay, az), Vec3::new(tx, ty, tz));
        let scale = scale_of(&m, &target);
        let sol = arap.solve(&target, None).unwrap();
        let e = arap.energy(&sol.stacked, &target).unwrap();
        prop_assert!(e <= 1e-10 * scale, "E = {} (scale {})", e, scale);
        prop_assert!(*sol.energy_trace.last().unwrap() <= 1e-10 * scale);
        for (q, t) in sol.positions.iter().zip(&target) {
            prop_assert!((q - t).norm() <= 1e-7 * scale.sqrt());
        }
    }
}

/// FAST ablation: handles moved by one rigid motion are reproduced (the
/// whole mesh follows rigidly), and the handles meet their targets.
#[test]
fn fast_rigid_handles_move_the_mesh_rigidly() {
    let m = mesh(0, 0.02, 5);
    let (w, handles) = weights(&m, 5);
    let g = argmax_groups(&w);
    let o = ArapOptions {
        max_iter: 500,
        rel_tol: 1e-14,
        ..opts(false, &handles)
    };
    let arap = ReducedArap::new(&m, &w, &g, o).unwrap();
    let target = rigid(&m, Vec3::new(0.3, -0.5, 0.2), Vec3::new(1.0, 2.0, -0.5));
    let sol = arap.solve(&target, None).unwrap();
    let err = sol
        .positions
        .iter()
        .zip(&target)
        .map(|(q, t)| (q - t).norm())
        .fold(0.0, f64::max);
    eprintln!(
        "iters {} trace first {:?} last {:?}",
        sol.iterations,
        &sol.energy_trace[..3],
        sol.energy_trace.last()
    );
    assert!(err < 1e-4, "max position error {err}");
    for &h in &handles {
        assert!((sol.positions[h] - target[h]).norm() < 1e-4);
    }
}

/// Mismatched sizes and non-finite input are errors, not panics.
#[test]
fn bad_input_is_an_error() {
    let m = mesh(0, 0.01, 1);
    let n = m.n_vertices();
    let (w, handles) = weights(&m, 3);
    let g = argmax_groups(&w);
    assert!(ReducedArap::new(&m, &w, &g[1..], ArapOptions::default()).is_err());
    let mut huge = g.clone();
    huge[0] = usize::MAX;
    assert!(ReducedArap::new(&m, &w, &huge, ArapOptions::default()).is_err());
    assert!(ReducedArap::new(
        &m,
        &w.rows(0, n - 1).into_owned(),
        &g,
        ArapOptions::default()
    )
    .is_err());
    let mut bad = w.clone();
    bad[(3, 1)] = f64::NAN;
    assert!(ReducedArap::new(&m, &bad, &g, ArapOptions::default()).is_err());
    assert!(ReducedArap::new(
        &m,
        &w,
        &g,
        ArapOptions {
            handles: vec![0, n],
            ..opts(false, &[])
        }
    )
    .is_err());
    assert!(ReducedArap::new(
        &m,
        &w,
        &g,
        ArapOptions {
            lambda: -1.0,
            ..ArapOptions::default()
        }
    )
    .is_err());
    let arap = ReducedArap::new(&m, &w, &g, opts(true, &handles)).unwrap();
    let target = m.vertices().to_vec();
    assert!(arap.solve(&target[1..], None).is_err());
    let mut nan_target = target.clone();
    nan_target[2].x = f64::INFINITY;
    assert!(arap.solve(&nan_target, None).is_err());
    assert!(arap.solve(&target, Some(&DMatrix::zeros(5, 3))).is_err());
    assert!(arap.energy(&DMatrix::zeros(12, 2), &target).is_err());
    // A planar mesh makes the system singular: an error, not a panic.
    let flat = deformlab::mesh::primitives::grid(4, 4);
    let (wf, _) = weights(&flat, 2);
    let gf = argmax_groups(&wf);
    assert!(ReducedArap::new(&flat, &wf, &gf, ArapOptions::default()).is_err());
}

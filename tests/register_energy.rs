//! FBT energies and their local / scale / global optimisation on the
//! low-resolution synthetic TOSCA-style class (1 682 vertices).

use std::sync::{Arc, OnceLock};

use deformlab::data::partial::feature_points;
use deformlab::ops::{farthest_point_sampling, FpsMetric};
use deformlab::register::*;
use deformlab::{Mesh, Point};
use nalgebra::{DMatrix, Rotation3, Vector3};
use proptest::prelude::*;

struct Fixture {
    meshes: Vec<Mesh>,
    examples: Vec<Mesh>,
    setup: FbtSetup,
}

/// Examples: poses 1–4 of the class; the others are held out.
fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let meshes = synthetic_class(1, 0).unwrap();
        let examples = meshes[1..5].to_vec();
        // The LBO-only pipeline: these tests check the energies and the
        // solver, whose behaviour with the skeleton pipeline is measured by
        // the Figs. 4-5 configs (the skeleton learnt from these three
        // examples is coarse: on pose 7 its solver α is 1.024 against the
        // energy's 0.977 for the truth).
        let setup = build(&examples, &FbtConfig::lbo_only()).unwrap();
        Fixture {
            meshes,
            examples,
            setup,
        }
    })
}

fn feature_constraints(target: &Mesh, seed: u64) -> (ConstraintRows, DMatrix<f64>) {
    let f = fixture();
    let feats = feature_points(target, 8, seed).unwrap();
    let radii = circle_radii(10, 0.15 * f.setup.graph.area().sqrt());
    let pairs: Vec<(usize, usize)> = feats.iter().map(|&v| (v, v)).collect();
    feature_circle_constraints(&f.examples[0], target, &pairs, &radii).unwrap()
}

fn similarity(
    points: &[Point],
    scale: f64,
    axis: Vector3<f64>,
    angle: f64,
    shift: Vector3<f64>,
) -> Vec<Point> {
    let c = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / points.len() as f64;
    let r = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
    points
        .iter()
        .map(|p| Point::from(c + shift + scale * (r * (p.coords - c))))
        .collect()
}

#[test]
fn reduced_energy_matches_vertex_by_vertex_energy() {
    let f = fixture();
    let (rows, y) = feature_constraints(&f.meshes[8], 3);
    let params = FbtParams {
        beta_sm: 1e-2,
        ..FbtParams::default()
    };
    let sys = FbtSystem::new(f.setup.pipeline.main().clone(), rows, params).unwrap();
    let t = sys.initial(&y).unwrap();
    for l in 0..4 {
        let rots = sys.local_step(l, &t).unwrap();
        for alpha in [1.0, 1.3] {
            let a = sys.energy_example(l, &y, &t, &rots, alpha).unwrap();
            let b = sys.energy_example_full(l, &y, &t, &rots, alpha).unwrap();
            assert!(
                (a - b).abs() <= 1e-9 * b.abs(),
                "example {l}: reduced {a} vs full {b}"
            );
        }
    }
    // E_total is the mean of the ARAP terms plus the shared terms.
    let rots: Vec<_> = (0..4).map(|l| sys.local_step(l, &t).unwrap()).collect();
    let avg = sys.energy_average(&y, &t, &rots, 1.1).unwrap();
    let per: f64 = (0..4)
        .map(|l| sys.energy_example_full(l, &y, &t, &rots[l], 1.1).unwrap())
        .sum::<f64>()
        / 4.0;
    assert!((avg - per).abs() <= 1e-9 * per, "{avg} vs {per}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, .. ProptestConfig::default() })]

    /// The energy recorded after every local, scale and global step never
    /// increases (E_total and every E_ℓ of E_mn), for random targets,
    /// feature points and weights.
    #[test]
    fn energy_never_increases(
        pose in 5usize..11,
        seed in 0u64..1000,
        beta_lc in 1.0f64..1000.0,
        beta_sm in 0.0f64..0.05,
        fixed in proptest::bool::ANY,
    ) {
        let f = fixture();
        let (rows, y) = feature_constraints(&f.meshes[pose], seed);
        let params = FbtParams {
            beta_lc,
            beta_sm,
            scale: if fixed { ScaleMode::Fixed(1.0) } else { ScaleMode::Estimate },
            ..FbtParams::default()
        };
        let sys = FbtSystem::new(f.setup.pipeline.main().clone(), rows, params).unwrap();
        let t0 = sys.initial(&y).unwrap();
        let opts = IterOptions { max_iter: 8, rel_tol: 0.0 };
        let av = sys.solve_average(&y, &t0, &opts).unwrap();
        let e = av.trace.energies();
        let scale = e[0].abs().max(1e-300);
        prop_assert!(av.trace.max_increase() <= 1e-9 * scale, "E_total rose by {} ({:?})", av.trace.max_increase(), e);
        let mn = sys.solve_minimal(&y, &av.t, Some(av.alpha), &opts).unwrap();
        for s in &mn.per_example {
            let sc = s.trace.steps[0].2.abs().max(1e-300);
            prop_assert!(s.trace.max_increase() <= 1e-9 * sc, "E_l rose by {}", s.trace.max_increase());
        }
        let m = mn.min_trace();
        prop_assert!(m.windows(2).all(|w| w[1] <= w[0] + 1e-9 * m[0].abs()));
    }
}

#[test]
fn constraints_from_a_pose_in_the_span_are_reproduced() {
    let f = fixture();
    // Unreduced dictionary: it contains every example's atoms, so any
    // similarity transform of an example is exactly D T for some T.
    let cfg = FbtConfig {
        init: None,
        main: StageConfig::lbo(6),
        rich: None,
        ..FbtConfig::lbo_only()
    };
    let setup = build(&f.examples, &cfg).unwrap();
    let reference = &f.examples[0];
    let vertices = farthest_point_sampling(reference, 12, FpsMetric::Euclidean, 5).unwrap();
    let rows = vertex_rows(&vertices);
    let params = FbtParams::default();
    let sys = FbtSystem::new(setup.pipeline.main().clone(), rows.clone(), params).unwrap();
    for (l, scale, angle) in [(2usize, 1.0, 0.4), (1, 1.2, -1.0)] {
        let pose = similarity(
            f.examples[l].vertices(),
            scale,
            Vector3::new(0.3, 1.0, 0.2),
            angle,
            Vector3::new(0.1, -0.2, 0.3),
        );
        let y = apply_rows(&rows, &pose).unwrap();
        let t0 = sys.initial(&y).unwrap();
        let av = sys
            .solve_average(
                &y,
                &t0,
                &IterOptions {
                    max_iter: 10,
                    rel_tol: 0.0,
                },
            )
            .unwrap();
        let mn = sys
            .solve_minimal(
                &y,
                &av.t,
                Some(av.alpha),
                &IterOptions {
                    max_iter: 400,
                    rel_tol: 1e-14,
                },
            )
            .unwrap();
        let p = sys.positions(mn.t()).unwrap();
        let got = apply_rows(&rows, &p).unwrap();
        let centred = {
            let mut c = y.clone();
            let mean = y.row_mean();
            for mut r in c.row_iter_mut() {
                r -= &mean;
            }
            c
        };
        let rel = (&got - &y).norm() / centred.norm();
        eprintln!(
            "example {l} scale {scale}: chose {}, alpha {:.6}, iterations {}, relative constraint error {rel:.2e}",
            mn.best,
            mn.alpha(),
            mn.per_example[mn.best].iterations
        );
        assert_eq!(mn.best, l);
        assert!(rel < 1e-6, "relative constraint error {rel:e}");
        // The whole shape is reproduced, not only the constraints.
        let d =
            metrics::relative_distortion(&p, &pose, setup.graph.area() * scale * scale).unwrap();
        assert!(
            metrics::max(&d) < 1e-5,
            "max distortion {}",
            metrics::max(&d)
        );
    }
}

/// Targets: held-out poses 6 and 8 (table rows; meshes 7, 9) and example
/// poses 2, 3, scaled by 1.5 / 0.7 about their centroid; 20 vertex
/// constraints (geodesic farthest points). The held-out poses have their own
/// slight non-isometry (muscle bulge), so their α is off by up to ≈ 2 %;
/// the ratio to the α of the unscaled target is within 0.5 %.
#[test]
fn scale_is_recovered() {
    let f = fixture();
    let params = FbtParams::default();
    for (pose, scale) in [(7usize, 1.5), (9, 0.7), (2, 1.5), (3, 0.7)] {
        let target = f.meshes[pose].with_vertices(similarity(
            f.meshes[pose].vertices(),
            scale,
            Vector3::y(),
            0.0,
            Vector3::zeros(),
        ));
        let target = target.unwrap();
        let feats = farthest_point_sampling(&f.examples[0], 20, FpsMetric::Geodesic, 1).unwrap();
        let rows = vertex_rows(&feats);
        let y = apply_rows(&rows, target.vertices()).unwrap();
        let sys = f.setup.pipeline.systems(&rows, &params).unwrap();
        let reg = sys.solve(&y, &Schedule::default()).unwrap();
        let err = (reg.alpha - scale).abs() / scale;
        eprintln!(
            "pose {pose} scale {scale}: alpha {:.4} ({:.2} %)",
            reg.alpha,
            100.0 * err
        );
        // α is linear in the target's scale: compare with the unscaled target.
        let y1 = apply_rows(&rows, f.meshes[pose].vertices()).unwrap();
        let alpha1 = sys.solve(&y1, &Schedule::default()).unwrap().alpha;
        let ratio = reg.alpha / alpha1;
        eprintln!("   unscaled target: alpha {alpha1:.4}; ratio {ratio:.5}");
        assert!((ratio - scale).abs() / scale < 0.005, "ratio {ratio}");
        assert!(err < 0.02, "alpha {} for scale {scale}", reg.alpha);
    }
}

#[test]
fn removing_constraints_by_downdate_matches_a_new_factorisation() {
    let f = fixture();
    let (rows, y) = feature_constraints(&f.meshes[6], 11);
    let params = FbtParams::default();
    let model = f.setup.pipeline.main().clone();
    let mut sys = FbtSystem::new(model.clone(), rows.clone(), params).unwrap();
    let removed: Vec<usize> = (10..30).chain(55..60).collect();
    sys.set_available(&removed, false).unwrap();
    let kept: Vec<usize> = (0..rows.len()).filter(|r| !removed.contains(r)).collect();
    let fresh = FbtSystem::new(
        model.clone(),
        kept.iter().map(|&r| rows[r].clone()).collect(),
        params,
    )
    .unwrap();
    let y_kept = y.select_rows(&kept);
    // The downdated factor solves the explicitly downdated Γ.
    let rhs = DMatrix::from_fn(model_size(&sys), 3, |i, j| ((i * 5 + j) % 7) as f64 - 3.0);
    let direct = sys.gamma().clone().cholesky().unwrap().solve(&rhs);
    let rel = (sys.solve_gamma(&rhs) - &direct).norm() / direct.norm();
    assert!(
        rel < 1e-8,
        "downdated factor vs factor of the downdated matrix: {rel:e}"
    );
    // And the downdated system solves like a new system without the rows.
    let ti = sys.initial(&y).unwrap();
    let tf = fresh.initial(&y_kept).unwrap();
    let rel = (&ti - &tf).norm() / tf.norm();
    assert!(rel < 1e-7, "Eq. 22 after downdate vs new system: {rel:e}");
    let a = sys
        .solve_average(
            &y,
            &ti,
            &IterOptions {
                max_iter: 1,
                rel_tol: 0.0,
            },
        )
        .unwrap();
    let b = fresh
        .solve_average(
            &y_kept,
            &tf,
            &IterOptions {
                max_iter: 1,
                rel_tol: 0.0,
            },
        )
        .unwrap();
    let rel = (&a.t - &b.t).norm() / b.t.norm();
    assert!(
        rel < 1e-7,
        "one iteration after downdate vs new system: {rel:e}"
    );
    // Restoring the rows gives back the original system.
    sys.set_available(&removed, true).unwrap();
    let orig = FbtSystem::new(model, rows, params).unwrap();
    let rhs = DMatrix::from_fn(model_size(&orig), 3, |i, j| {
        ((i * 7 + j * 3) % 11) as f64 - 5.0
    });
    let rel =
        (sys.solve_gamma(&rhs) - orig.solve_gamma(&rhs)).norm() / orig.solve_gamma(&rhs).norm();
    assert!(rel < 1e-8, "restored vs original: {rel:e}");
}

fn model_size(s: &FbtSystem) -> usize {
    s.model().size()
}

#[test]
fn interpolation_reproduces_its_endpoints() {
    let f = fixture();
    let (rows, ya) = feature_constraints(&f.meshes[6], 4);
    let pairs = rows.clone();
    let yb = apply_rows(&pairs, f.meshes[8].vertices()).unwrap();
    let sys = f
        .setup
        .pipeline
        .systems(&rows, &FbtParams::default())
        .unwrap();
    let schedule = Schedule::default();
    let a = sys.solve(&ya, &schedule).unwrap();
    let b = sys.solve(&yb, &schedule).unwrap();
    let last = sys.last();
    for (s, reg) in [(0.0, &a), (1.0, &b)] {
        let t = interpolate(last, &a, &b, &ya, &yb, s).unwrap();
        if a.example == b.example {
            // The shapes: the coefficients T of a redundant dictionary are
            // determined only to about cond(Γ)·ε, and the endpoint's T comes
            // from the reduced iteration (FbtSystem::prepare).
            let d = last.model().dictionary();
            let (p, q) = (d.apply(&t).unwrap(), d.apply(&reg.t).unwrap());
            let rel = (&p - &q).norm() / q.norm();
            assert!(rel < 1e-9, "s = {s}: {rel:e}");
        }
    }
    // Midway frames stay between the two shapes (per vertex, up to a margin).
    let t = interpolate(last, &a, &b, &ya, &yb, 0.5).unwrap();
    let p = last.positions(&t).unwrap();
    let mid: Vec<Point> = a
        .positions
        .iter()
        .zip(&b.positions)
        .map(|(x, y)| Point::from((x.coords + y.coords) / 2.0))
        .collect();
    let gap =
        metrics::relative_distortion(&a.positions, &b.positions, f.setup.graph.area()).unwrap();
    let dev = metrics::relative_distortion(&p, &mid, f.setup.graph.area()).unwrap();
    eprintln!(
        "endpoint gap mean {:.4}, midway deviation from the average shape {:.4}",
        metrics::mean(&gap),
        metrics::mean(&dev)
    );
    assert!(metrics::mean(&dev) < 0.5 * metrics::mean(&gap));
    let _ = Arc::strong_count(last.model());
}

#[test]
fn sparse_initialisation_is_sparse_and_reduces_to_eq_22() {
    let f = fixture();
    let (rows, y) = feature_constraints(&f.meshes[9], 2);
    let params = FbtParams::default();
    let systems = f.setup.pipeline.systems(&rows, &params).unwrap();
    // The small initialisation dictionary (LBO m = 4), as in the schedule.
    let sys = systems.init.as_ref().unwrap();
    let lam = sys.model().dictionary().smoothness().clone();
    // Eq. 20 (without the 1e-10 ridge).
    let e20 = |t: &DMatrix<f64>| {
        let hp = apply_rows(sys.rows(), &sys.positions(t).unwrap()).unwrap();
        0.5 * params.beta_lc * (hp - &y).norm_squared() + 0.5 * params.beta_sm * t.dot(&(&lam * t))
    };
    let dense = sys.initial(&y).unwrap();
    let opts = deformlab::solve::elastic_net::CoordinateDescentOptions::default();
    // β_sp = 0: Eq. 23 is Eq. 22 (coordinate descent reaches its minimum).
    let (t0, _) = sys.sparse_initial(&y, 0.0, &opts).unwrap();
    let (a, b) = (e20(&t0), e20(&dense));
    eprintln!("β_sp = 0: Eq. 20 energy {a:.6e} (coordinate descent) vs {b:.6e} (Eq. 22)");
    assert!((a - b).abs() <= 1e-6 * b, "{a} vs {b}");
    // β_sp > 0: many exact zeros, and a larger Eq. 20 energy (it trades
    // Eq. 20 for the L1 term).
    let (ts, ok) = sys.sparse_initial(&y, 0.05, &opts).unwrap();
    assert!(ok);
    let zeros = ts.iter().filter(|v| **v == 0.0).count();
    eprintln!(
        "β_sp = 0.05 max: {zeros} of {} coefficients are zero, Eq. 20 energy {:.6e}",
        ts.len(),
        e20(&ts)
    );
    assert!(zeros > ts.len() / 4);
    assert!(e20(&ts) > b);
    assert_eq!(dense.iter().filter(|v| **v == 0.0).count(), 0);
}

/// `ArapGraph::best_scale`: exact on scaled, rotated copies of an example
/// (S_k is then `s·R·(symmetric PSD)`, so the polar factor is R and α = s),
/// below 1 for an unscaled pose outside the examples (bent regions), and
/// the solver's α follows it: the low α of an unscaled non-example target
/// is the estimator's definition, not a solver error.
#[test]
fn alpha_matches_the_energys_own_scale_of_the_truth() {
    let f = fixture();
    let clusters = f.setup.pipeline.main().clusters();
    for (l, s, angle) in [(0usize, 1.5, 0.0), (2, 0.7, 0.9), (3, 1.0, -2.0)] {
        let p = similarity(
            f.setup.graph.example(l),
            s,
            Vector3::new(0.3, 1.0, -0.2),
            angle,
            Vector3::new(0.1, 0.0, 2.0),
        );
        let (alpha, rots) = f.setup.graph.best_scale(l, &p, clusters).unwrap();
        assert!(
            (alpha - s).abs() < 1e-10,
            "example {l}: α {alpha} for scale {s}"
        );
        let r = Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(0.3, 1.0, -0.2)),
            angle,
        );
        for rot in &rots {
            assert!((rot - r.matrix()).norm() < 1e-8);
        }
        let e = f.setup.graph.energy(l, &p, clusters, &rots, alpha).unwrap();
        assert!(
            e < 1e-16 * f.setup.graph.rest_terms()[l].max(1.0),
            "energy {e}"
        );
    }
    let params = FbtParams::default();
    let feats = farthest_point_sampling(&f.examples[0], 20, FpsMetric::Geodesic, 1).unwrap();
    let rows = vertex_rows(&feats);
    let sys = f.setup.pipeline.systems(&rows, &params).unwrap();
    for pose in [7usize, 9] {
        let truth = f.meshes[pose].vertices();
        let reg = sys
            .solve(&apply_rows(&rows, truth).unwrap(), &Schedule::default())
            .unwrap();
        let (oracle, _) = f
            .setup
            .graph
            .best_scale(reg.example, truth, clusters)
            .unwrap();
        eprintln!(
            "pose {pose}: solver α {:.4}, energy's α of the truth {oracle:.4}",
            reg.alpha
        );
        assert!(
            oracle < 0.999,
            "a bent pose should have α < 1, got {oracle}"
        );
        assert!(
            (reg.alpha - oracle).abs() / oracle < 0.01,
            "solver α {} vs the truth's {oracle}",
            reg.alpha
        );
    }
}

/// Largest entry of `|a − b|` relative to the largest entry of `|a|`.
fn rel_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    assert_eq!(a.shape(), b.shape());
    (a - b).amax() / a.amax().max(f64::MIN_POSITIVE)
}

/// The prepared (reduced, O(r²) per iteration) E_ℓ iterations against the
/// direct ones (a Γ solve per iteration) on the same system: the same
/// iterates, traces, scales, energies and example choice up to rounding.
fn check_prepared_equals_direct(sys: &FbtSystem, y: &DMatrix<f64>, t0: &DMatrix<f64>, tag: &str) {
    assert!(!sys.is_prepared());
    let mut prepared = sys.clone();
    prepared.prepare();
    assert!(prepared.is_prepared());
    let opts = IterOptions {
        max_iter: 12,
        rel_tol: 0.0,
    };
    let a = sys.solve_minimal(y, t0, Some(0.9), &opts).unwrap();
    let b = prepared.solve_minimal(y, t0, Some(0.9), &opts).unwrap();
    assert_eq!(a.best, b.best, "{tag}: example choice");
    for (l, (ea, eb)) in a.per_example.iter().zip(&b.per_example).enumerate() {
        assert_eq!(ea.iterations, eb.iterations, "{tag} ℓ = {l}: iterations");
        // The shapes D T agree to rounding; the coefficients T themselves
        // only to about cond(Γ)·ε (redundant dictionaries make Γ nearly
        // singular: measured 4e-8 on the rich stage with the same R and α,
        // where the shapes differ by 8e-11). Over 12 unstopped iterations
        // the rounding grows: shapes up to 1.2e-9 (pose 9, seed 609).
        let (pa, pb) = (
            sys.model().dictionary().apply(&ea.t).unwrap(),
            sys.model().dictionary().apply(&eb.t).unwrap(),
        );
        let dp = rel_diff(&pa, &pb);
        assert!(dp < 1e-7, "{tag} ℓ = {l}: D T differs by {dp:e} (relative)");
        let dt = rel_diff(&ea.t, &eb.t);
        assert!(dt < 1e-5, "{tag} ℓ = {l}: T differs by {dt:e} (relative)");
        assert!(
            (ea.alpha - eb.alpha).abs() < 1e-8,
            "{tag} ℓ = {l}: α {} vs {}",
            ea.alpha,
            eb.alpha
        );
        let (ta, tb) = (ea.trace.energies(), eb.trace.energies());
        assert_eq!(ta.len(), tb.len(), "{tag} ℓ = {l}: trace lengths");
        // Both routes form the energy as a difference of terms of the size
        // of β‖Y‖² (far larger than the energy near convergence), so they
        // agree to the rounding of those terms: measured up to 1.4e-8 of
        // the energy after 9 iterations (pose 9, seed 85, kept in
        // register_energy.proptest-regressions).
        let scale = ta.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        for (k, (x, z)) in ta.iter().zip(&tb).enumerate() {
            assert!(
                (x - z).abs() <= 1e-7 * scale,
                "{tag} ℓ = {l}, step {k}: energy {x} vs {z}"
            );
        }
        for (ra, rb) in ea.rotations.iter().zip(&eb.rotations) {
            assert!((ra - rb).amax() < 1e-6, "{tag} ℓ = {l}: rotations differ");
        }
    }
    // One example alone takes the same route.
    let sa = sys.solve_example(1, y, t0, None, &opts).unwrap();
    let sb = prepared.solve_example(1, y, t0, None, &opts).unwrap();
    let d = sys.model().dictionary();
    let dp = rel_diff(&d.apply(&sa.t).unwrap(), &d.apply(&sb.t).unwrap());
    assert!(dp < 1e-7, "{tag}: solve_example D T differs by {dp:e}");
    assert!((sa.energy - sb.energy).abs() <= 1e-7 * sa.energy.abs().max(1e-300));
    // Marking rows unavailable changes Γ: the reduced form is dropped.
    let mut changed = prepared.clone();
    changed.set_available(&[0], false).unwrap();
    assert!(
        !changed.is_prepared(),
        "{tag}: stale reduced form kept after a downdate"
    );
}

#[test]
fn prepared_iterations_equal_the_direct_ones() {
    let f = fixture();
    let params = FbtParams::default();
    for (pose, seed) in [(5usize, 0u64), (8, 3)] {
        let (rows, y) = feature_constraints(&f.meshes[pose], seed);
        for (stage, model) in [
            ("main", f.setup.pipeline.main()),
            ("last", f.setup.pipeline.last()),
        ] {
            let sys = FbtSystem::new(model.clone(), rows.clone(), params).unwrap();
            let t0 = sys.initial(&y).unwrap();
            check_prepared_equals_direct(&sys, &y, &t0, &format!("pose {pose}, {stage}"));
        }
    }
    // Fixed α (Fig. 8 C's ablation) and the skeleton pipeline's last stage.
    let skeleton = build(&f.examples, &FbtConfig::default()).unwrap();
    let (rows, y) = feature_constraints(&f.meshes[6], 1);
    let fixed = FbtParams {
        scale: ScaleMode::Fixed(1.0),
        ..FbtParams::default()
    };
    for (tag, p) in [("skeleton", params), ("skeleton, α = 1", fixed)] {
        let sys = FbtSystem::new(skeleton.pipeline.last().clone(), rows.clone(), p).unwrap();
        let t0 = sys.initial(&y).unwrap();
        check_prepared_equals_direct(&sys, &y, &t0, tag);
    }
}

/// The row-sparse product of a skeleton dictionary (a few bones per
/// vertex) against the dense `D T`.
#[test]
fn sparse_positions_equal_the_dense_product() {
    let f = fixture();
    let skeleton = build(&f.examples, &FbtConfig::default()).unwrap();
    assert!(skeleton.pipeline.last().has_sparse_rows());
    assert!(!f.setup.pipeline.main().has_sparse_rows());
    for model in [skeleton.pipeline.last(), f.setup.pipeline.main()] {
        let d = model.dictionary();
        let t = DMatrix::from_fn(d.size(), 3, |i, c| {
            ((i * 7 + c * 3) % 11) as f64 / 11.0 - 0.4
        });
        let dense = d.apply(&t).unwrap();
        let p = model.positions(&t).unwrap();
        let scale = dense.amax();
        for (i, q) in p.iter().enumerate() {
            for c in 0..3 {
                assert!(
                    (q[c] - dense[(i, c)]).abs() <= 1e-12 * scale,
                    "vertex {i}: {} vs {}",
                    q[c],
                    dense[(i, c)]
                );
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, ..ProptestConfig::default() })]

    /// The prepared iterations equal the direct ones for any feature
    /// points, held-out pose and starting scale.
    #[test]
    fn prepared_equals_direct_for_any_constraints(pose in 5usize..10, seed in 0u64..1000) {
        let f = fixture();
        let (rows, y) = feature_constraints(&f.meshes[pose], seed);
        let sys = FbtSystem::new(f.setup.pipeline.last().clone(), rows, FbtParams::default()).unwrap();
        let t0 = sys.initial(&y).unwrap();
        check_prepared_equals_direct(&sys, &y, &t0, &format!("pose {pose}, seed {seed}"));
    }
}

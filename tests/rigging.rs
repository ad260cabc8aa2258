//! Example-based skinning (`skin::rigging`): ground-truth recovery from
//! synthetic linear blend skinning, weight and transform properties,
//! invariances, the per-vertex simplex least-squares solver, errors, and
//! (ignored) figures on the real TOSCA / FAUST meshes.
//! `cargo test --release --test rigging` (`-- --ignored --nocapture` for the
//! real-data figures).

use std::time::Instant;

use deformlab::data::synthetic::body::BONE_PARENT;
use deformlab::data::synthetic::FaustStyle;
use deformlab::data::{shared_data_or_skip, FaustFolder, ToscaFolder};
use deformlab::ops::vertex_neighbours;
use deformlab::register::synthetic_class;
use deformlab::skin::dictionary::{SkinningWeights, WeightKind};
use deformlab::skin::groups::purity;
use deformlab::skin::rigging::{example_skinning, simplex_least_squares, Rig, RigOptions};
use deformlab::{Mesh, Point};
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Unit, Vector3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random rotation of angle ≤ `max_angle` and a translation of size ≤ `shift`.
fn random_rigid(rng: &mut ChaCha8Rng, max_angle: f64, shift: f64) -> (Matrix3<f64>, Vector3<f64>) {
    let axis = Unit::new_normalize(Vector3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0) + 1e-3,
    ));
    let r = Rotation3::from_axis_angle(&axis, rng.random_range(-max_angle..max_angle)).into_inner();
    let t = Vector3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    ) * shift;
    (r, t)
}

/// Linear blend skinning of `rest` with weights `w` (n × B) and one rigid
/// transform per bone.
fn blend(rest: &Mesh, w: &DMatrix<f64>, tr: &[(Matrix3<f64>, Vector3<f64>)]) -> Mesh {
    let v = rest
        .vertices()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let x: Vector3<f64> = tr
                .iter()
                .enumerate()
                .map(|(b, (r, t))| w[(i, b)] * (r * p.coords + t))
                .sum();
            Point::from(x)
        })
        .collect();
    rest.with_vertices(v).unwrap()
}

/// The synthetic creature at resolution 1 (rest pose), its true bone labels
/// and smooth weights.
fn creature() -> (Mesh, Vec<usize>, DMatrix<f64>) {
    let set = FaustStyle {
        subjects: 1,
        poses: 1,
        seed: 3,
        resolution: 1,
        tail: true,
        spread: 0.1,
    }
    .generate()
    .unwrap();
    let n = set.n_vertices();
    let b = set.bone_names.len();
    let w = DMatrix::from_fn(n, b, |i, j| set.weights[i][j]);
    (set.rest[0].clone(), set.labels.clone(), w)
}

fn one_hot(labels: &[usize], b: usize) -> DMatrix<f64> {
    DMatrix::from_fn(labels.len(), b, |i, j| f64::from(u8::from(labels[i] == j)))
}

/// `q` examples of `rest` skinned with `w` and random bone transforms.
fn skinned_examples(rest: &Mesh, w: &DMatrix<f64>, q: usize, seed: u64) -> Vec<Mesh> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..q)
        .map(|_| {
            let tr: Vec<_> = (0..w.ncols())
                .map(|_| random_rigid(&mut rng, 0.9, 0.3))
                .collect();
            blend(rest, w, &tr)
        })
        .collect()
}

/// Asserts the rig's structural properties.
#[track_caller]
fn check_rig(rig: &Rig, n: usize, q: usize, k: usize) {
    let b = rig.bones();
    assert_eq!(rig.weights.nrows(), n);
    assert!(b >= 1);
    assert_eq!(rig.labels.len(), n);
    assert_eq!(rig.transforms.len(), q);
    assert_eq!(rig.per_example_rms.len(), q);
    for i in 0..n {
        let row = rig.weights.row(i);
        assert!(
            row.iter().all(|&x| x >= 0.0),
            "row {i} has a negative weight"
        );
        let s: f64 = row.sum();
        assert!((s - 1.0).abs() < 1e-9, "row {i} sums to {s}");
        let nnz = row.iter().filter(|&&x| x > 0.0).count();
        assert!(nnz <= k, "row {i} has {nnz} > {k} influences");
        let l = rig.labels[i];
        assert!(
            row.iter().all(|&x| x <= row[l]),
            "label of {i} is not dominant"
        );
    }
    for (j, col) in rig.weights.column_iter().enumerate() {
        assert!(col.iter().any(|&x| x > 0.0), "bone {j} has no weight");
    }
    for tr in &rig.transforms {
        assert_eq!(tr.len(), b);
        for (r, t) in tr {
            assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-9);
            assert!((r.determinant() - 1.0).abs() < 1e-9);
            assert!(t.iter().all(|x| x.is_finite()));
        }
    }
    let total: f64 = rig.per_example_rms.iter().map(|x| x * x).sum::<f64>() / q as f64;
    assert!((total.sqrt() - rig.rms_error).abs() <= 1e-9 * (1.0 + rig.rms_error));
    assert!(rig.rms_error.is_finite());
}

/// Asserts that two labellings are the same partition (a bijection).
#[track_caller]
fn same_partition(a: &[usize], b: &[usize]) {
    let p1 = purity(a, b).unwrap();
    let p2 = purity(b, a).unwrap();
    assert!(p1 == 1.0 && p2 == 1.0, "purity {p1} / {p2}");
}

#[test]
fn piecewise_rigid_creature_is_recovered_exactly() {
    let (rest, truth, _) = creature();
    let nb = 1 + truth.iter().max().unwrap();
    let ex = skinned_examples(&rest, &one_hot(&truth, nb), 5, 7);
    let n = rest.n_vertices();
    for bones in [None, Some(nb)] {
        let opts = RigOptions {
            bones,
            tolerance: 1e-6,
            ..RigOptions::default()
        };
        let t = Instant::now();
        let rig = example_skinning(&rest, &ex, &opts).unwrap();
        eprintln!(
            "bones {bones:?}: {} bones, rms {:.2e}, {} iterations, {:.2} s, trace {:?}",
            rig.bones(),
            rig.rms_error,
            rig.iterations,
            t.elapsed().as_secs_f64(),
            rig.bone_trace
        );
        check_rig(&rig, n, ex.len(), opts.max_influences);
        assert_eq!(rig.bones(), nb);
        assert!(rig.rms_error < 1e-9, "rms {}", rig.rms_error);
        same_partition(&rig.labels, &truth);
        // Piecewise rigid: every vertex follows one bone.
        for (i, row) in rig.weights.row_iter().enumerate() {
            assert!(row.max() > 1.0 - 1e-9, "vertex {i} blends bones");
        }
    }
}

/// Articulated bone transforms of the creature: each bone rotates by a
/// random angle ≤ `max_angle` about its joint with its parent (the centroid
/// of the rest vertices on their shared boundary), composed down the
/// hierarchy from a random rigid motion of the root.
fn articulated(
    rest: &Mesh,
    labels: &[usize],
    rng: &mut ChaCha8Rng,
    max_angle: f64,
) -> Vec<(Matrix3<f64>, Vector3<f64>)> {
    let nb = BONE_PARENT.len();
    let v = rest.vertices();
    let nbr = vertex_neighbours(rest);
    let mut out: Vec<(Matrix3<f64>, Vector3<f64>)> = Vec::with_capacity(nb);
    for (b, &parent) in BONE_PARENT.iter().enumerate() {
        if parent == usize::MAX {
            out.push(random_rigid(rng, 3.0, 1.0));
            continue;
        }
        let joint: Vec<Vector3<f64>> = (0..v.len())
            .filter(|&i| labels[i] == b && nbr.row(i).iter().any(|&j| labels[j] == parent))
            .map(|i| v[i].coords)
            .collect();
        assert!(!joint.is_empty(), "bone {b} does not touch its parent");
        let c = joint.iter().sum::<Vector3<f64>>() / joint.len() as f64;
        let (r, _) = random_rigid(rng, max_angle, 0.0);
        let (rp, tp) = out[parent];
        out.push((rp * r, rp * (c - r * c) + tp));
    }
    out
}

#[test]
fn smooth_blend_skinning_is_reproduced() {
    let (rest, truth, w) = creature();
    let nb = w.ncols();
    assert_eq!(nb, BONE_PARENT.len());
    // Keep the 4 largest true weights per vertex so K = 4 can represent it.
    let mut w4 = w.clone();
    for mut row in w4.row_iter_mut() {
        let mut idx: Vec<usize> = (0..nb).collect();
        idx.sort_by(|&a, &b| row[b].total_cmp(&row[a]));
        for &j in &idx[4..] {
            row[j] = 0.0;
        }
        let s = row.sum();
        row /= s;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let ex: Vec<Mesh> = (0..8)
        .map(|_| blend(&rest, &w4, &articulated(&rest, &truth, &mut rng, 0.8)))
        .collect();
    let opts = RigOptions {
        bones: Some(nb),
        iterations: 40,
        ..RigOptions::default()
    };
    let t = Instant::now();
    let rig = example_skinning(&rest, &ex, &opts).unwrap();
    let one = example_skinning(
        &rest,
        &ex,
        &RigOptions {
            bones: Some(1),
            ..opts.clone()
        },
    )
    .unwrap();
    eprintln!(
        "articulated smooth LBS: {} bones, rms {:.2e} (one bone {:.2e}), {} iterations, {:.2} s, purity {:.3}",
        rig.bones(),
        rig.rms_error,
        one.rms_error,
        rig.iterations,
        t.elapsed().as_secs_f64(),
        purity(&rig.labels, &truth).unwrap()
    );
    check_rig(&rig, rest.n_vertices(), ex.len(), 4);
    assert_eq!(rig.bones(), nb);
    assert!(rig.rms_error < 1e-3, "rms {}", rig.rms_error);
    assert!(purity(&rig.labels, &truth).unwrap() > 0.9);
}

#[test]
fn synthetic_class_rig_properties_and_dictionary_weights() {
    let class = synthetic_class(1, 0).unwrap();
    let (rest, ex) = (&class[0], &class[1..]);
    let opts = RigOptions {
        max_influences: 3,
        ..RigOptions::default()
    };
    let t = Instant::now();
    let (sw, rig) = SkinningWeights::skeleton(rest, ex, &opts).unwrap();
    eprintln!(
        "synthetic class: {} bones, rms {:.4}, {} iterations, {:.2} s, trace {:?}",
        rig.bones(),
        rig.rms_error,
        rig.iterations,
        t.elapsed().as_secs_f64(),
        rig.bone_trace
    );
    check_rig(&rig, rest.n_vertices(), ex.len(), 3);
    assert_eq!(sw.kind, WeightKind::Skeleton);
    assert_eq!(sw.weights, rig.weights);
    assert_eq!(sw.smoothness.shape(), (rig.bones(), rig.bones()));
    // The automatic count stops at the tolerance or at max_bones.
    let &(last_b, last_rms) = rig.bone_trace.last().unwrap();
    assert_eq!(last_b, rig.bones());
    assert!(last_rms <= opts.tolerance || last_b == opts.max_bones);
    assert!(rig.rms_error <= last_rms * (1.0 + 1e-12));
    // The reconstruction is much better than the best single rigid motion.
    let one = example_skinning(
        rest,
        ex,
        &RigOptions {
            bones: Some(1),
            ..RigOptions::default()
        },
    )
    .unwrap();
    assert_eq!(one.bones(), 1);
    assert!(
        rig.rms_error < 0.2 * one.rms_error,
        "{} vs {}",
        rig.rms_error,
        one.rms_error
    );
}

#[test]
fn rigid_examples_need_one_bone() {
    let class = synthetic_class(1, 0).unwrap();
    let rest = &class[0];
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let ex: Vec<Mesh> = (0..4)
        .map(|_| {
            let (r, t) = random_rigid(&mut rng, 3.0, 2.0);
            rest.map_vertices(|p| Point::from(r * p.coords + t))
                .unwrap()
        })
        .collect();
    let rig = example_skinning(rest, &ex, &RigOptions::default()).unwrap();
    check_rig(&rig, rest.n_vertices(), ex.len(), 4);
    assert_eq!(rig.bones(), 1);
    assert_eq!(rig.bone_trace.len(), 1);
    assert!(rig.rms_error < 1e-12, "rms {}", rig.rms_error);
    // A fixed count on rigid data: no distinct motion to split off.
    let fixed = example_skinning(
        rest,
        &ex,
        &RigOptions {
            bones: Some(5),
            ..RigOptions::default()
        },
    )
    .unwrap();
    assert_eq!(fixed.bones(), 1);
}

#[test]
fn rigid_motion_and_scaling_of_the_examples() {
    let class = synthetic_class(1, 0).unwrap();
    let (rest, ex) = (&class[0], &class[1..6]);
    let opts = RigOptions {
        bones: Some(8),
        ..RigOptions::default()
    };
    let base = example_skinning(rest, ex, &opts).unwrap();
    // One rigid motion applied to every example.
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let (g, c) = random_rigid(&mut rng, 2.5, 3.0);
    let moved: Vec<Mesh> = ex
        .iter()
        .map(|m| m.map_vertices(|p| Point::from(g * p.coords + c)).unwrap())
        .collect();
    let rig = example_skinning(rest, &moved, &opts).unwrap();
    assert_eq!(rig.bones(), base.bones());
    let dw = (&rig.weights - &base.weights).amax();
    assert!(dw < 1e-6, "weights moved by {dw}");
    assert_eq!(rig.labels, base.labels);
    for (a, b) in rig.transforms.iter().zip(&base.transforms) {
        for ((r1, t1), (r0, t0)) in a.iter().zip(b) {
            assert!((r1 - g * r0).norm() < 1e-6);
            assert!((t1 - (g * t0 + c)).norm() < 1e-6);
        }
    }
    assert!((rig.rms_error - base.rms_error).abs() < 1e-9);
    // Uniform scaling of the reference and the examples.
    let s = 37.5;
    let scale = |m: &Mesh| m.map_vertices(|p| Point::from(p.coords * s)).unwrap();
    let scaled: Vec<Mesh> = ex.iter().map(scale).collect();
    let rig = example_skinning(&scale(rest), &scaled, &opts).unwrap();
    let dw = (&rig.weights - &base.weights).amax();
    assert!(dw < 1e-6, "weights moved by {dw}");
    assert!((rig.rms_error - base.rms_error).abs() < 1e-9 * (1.0 + base.rms_error));
    for (a, b) in rig.transforms.iter().zip(&base.transforms) {
        for ((r1, t1), (r0, t0)) in a.iter().zip(b) {
            assert!((r1 - r0).norm() < 1e-6);
            assert!((t1 - s * t0).norm() < 1e-6 * s);
        }
    }
    // The automatic count too.
    let auto = example_skinning(rest, ex, &RigOptions::default()).unwrap();
    let auto_moved = example_skinning(rest, &moved, &RigOptions::default()).unwrap();
    assert_eq!(auto.bone_trace.len(), auto_moved.bone_trace.len());
    assert!((&auto.weights - &auto_moved.weights).amax() < 1e-6);
}

#[test]
fn fixed_count_is_exact_and_threads_do_not_matter() {
    let class = synthetic_class(1, 0).unwrap();
    let (rest, ex) = (&class[0], &class[1..]);
    for b in [2, 5, 17] {
        let opts = RigOptions {
            bones: Some(b),
            max_influences: 2,
            ..RigOptions::default()
        };
        let rig = example_skinning(rest, ex, &opts).unwrap();
        check_rig(&rig, rest.n_vertices(), ex.len(), 2);
        assert_eq!(rig.bones(), b);
        assert_eq!(rig.bone_trace, vec![(b, rig.bone_trace[0].1)]);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| example_skinning(rest, ex, &opts).unwrap());
        assert_eq!(one.weights, rig.weights);
        assert_eq!(one.rms_error, rig.rms_error);
    }
}

#[test]
fn bad_inputs_are_errors() {
    let class = synthetic_class(1, 0).unwrap();
    let (rest, ex) = (&class[0], &class[1..3]);
    let n = rest.n_vertices();
    let d = RigOptions::default();
    let err = |r: deformlab::Result<Rig>, what: &str| {
        let e = r.expect_err(what);
        assert!(
            matches!(e, deformlab::Error::InvalidInput(_)),
            "{what}: {e}"
        );
        // Messages are the sentence, without the kind as a prefix.
        let e = e.to_string();
        assert!(!e.starts_with("invalid input"), "{what}: {e}");
        e
    };
    let e = err(example_skinning(rest, &[], &d), "no examples");
    assert!(e.contains("example"), "{e}");
    let small = deformlab::mesh::primitives::icosphere(1);
    let e = err(
        example_skinning(rest, &[ex[0].clone(), small], &d),
        "vertex count",
    );
    assert!(e.contains("example 1"), "{e}");
    for b in [0, n + 1] {
        let o = RigOptions {
            bones: Some(b),
            ..d.clone()
        };
        let e = err(example_skinning(rest, ex, &o), "bones");
        assert!(e.contains("bones"), "{e}");
    }
    let o = RigOptions {
        max_influences: 0,
        ..d.clone()
    };
    assert!(err(example_skinning(rest, ex, &o), "K").contains("max_influences"));
    let o = RigOptions {
        max_bones: 0,
        ..d.clone()
    };
    assert!(err(example_skinning(rest, ex, &o), "max_bones").contains("max_bones"));
    for tol in [-1.0, f64::NAN, f64::INFINITY] {
        let o = RigOptions {
            tolerance: tol,
            ..d.clone()
        };
        assert!(err(example_skinning(rest, ex, &o), "tolerance").contains("tolerance"));
    }
    // Meshes cannot hold non-finite coordinates; huge ones overflow the area.
    let huge = rest
        .map_vertices(|p| Point::from(p.coords * 1e300))
        .unwrap();
    let e = err(
        example_skinning(&huge, std::slice::from_ref(&huge), &d),
        "overflow",
    );
    assert!(e.contains("area"), "{e}");
    // Degenerate: a flat, zero-area reference.
    let flat = rest.map_vertices(|_| Point::origin()).unwrap();
    assert!(example_skinning(&flat, ex, &d).is_err());
    // The simplex solver.
    assert!(simplex_least_squares(&DMatrix::zeros(3, 0), &DVector::zeros(3)).is_err());
    assert!(simplex_least_squares(&DMatrix::zeros(3, 2), &DVector::zeros(4)).is_err());
    let mut a = DMatrix::zeros(3, 2);
    a[(0, 0)] = f64::NAN;
    assert!(simplex_least_squares(&a, &DVector::zeros(3)).is_err());
}

/// `‖A w − b‖²`.
fn objective(a: &DMatrix<f64>, b: &DVector<f64>, w: &DVector<f64>) -> f64 {
    (a * w - b).norm_squared()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// The simplex least-squares solution is feasible, satisfies the KKT
    /// conditions, and no random feasible point does better.
    #[test]
    fn simplex_least_squares_is_optimal(k in 1usize..9, rows in 1usize..25, seed in any::<u64>(),
                                        scale in 1e-3f64..1e3, dup in any::<bool>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut a = DMatrix::from_fn(rows, k, |_, _| rng.random_range(-1.0..1.0) * scale);
        if dup && k > 1 {
            // Two identical columns (two bones with the same motion).
            let c = a.column(0).into_owned();
            a.set_column(k - 1, &c);
        }
        let b = DVector::from_fn(rows, |_, _| rng.random_range(-1.0..1.0) * scale);
        let w = simplex_least_squares(&a, &b).unwrap();
        prop_assert!(w.iter().all(|&x| x >= 0.0));
        prop_assert!((w.sum() - 1.0).abs() < 1e-12);
        let f = objective(&a, &b, &w);
        let unit = scale * scale * rows as f64;
        // KKT: g = ∇f = 2 Aᵀ(Aw − b); g_j = ν on the support, g_j ≥ ν off it.
        let g = 2.0 * a.transpose() * (&a * &w - &b);
        let nu = w.dot(&g);
        for j in 0..k {
            if w[j] > 1e-9 {
                prop_assert!((g[j] - nu).abs() < 1e-6 * unit, "stationarity at {j}: {} vs {nu}", g[j]);
            } else {
                prop_assert!(g[j] - nu > -1e-6 * unit, "multiplier at {j}: {}", g[j] - nu);
            }
        }
        // Random feasible points (Dirichlet-like, vertices, edge midpoints).
        for t in 0..200 {
            let mut x = DVector::from_fn(k, |_, _| -rng.random_range(1e-12f64..1.0).ln());
            if t % 4 == 0 {
                let j = rng.random_range(0..k);
                x = DVector::zeros(k);
                x[j] = 1.0;
                let j2 = rng.random_range(0..k);
                x[j2] += 1.0;
            }
            x /= x.sum();
            prop_assert!(objective(&a, &b, &x) >= f - 1e-9 * unit,
                "feasible point beats the solver: {} < {f}", objective(&a, &b, &x));
        }
    }
}

// ---------------------------------------------------------------------------
// Real data (ignored; prints the figures).

fn load_avg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

fn report(name: &str, rest: &Mesh, ex: &[Mesh], opts: &RigOptions) -> Rig {
    let t = Instant::now();
    let rig = example_skinning(rest, ex, opts).unwrap();
    let secs = t.elapsed().as_secs_f64();
    println!(
        "{name}: n = {}, q = {}, bones = {} (trace {:?}), rms = {:.5} √A (per example {:?}), \
         {} iterations, {secs:.2} s, load {}",
        rest.n_vertices(),
        ex.len(),
        rig.bones(),
        rig.bone_trace
            .iter()
            .map(|(b, r)| format!("{b}:{r:.4}"))
            .collect::<Vec<_>>(),
        rig.rms_error,
        rig.per_example_rms
            .iter()
            .map(|x| format!("{x:.4}"))
            .collect::<Vec<_>>(),
        rig.iterations,
        load_avg()
    );
    check_rig(&rig, rest.n_vertices(), ex.len(), opts.max_influences);
    rig
}

#[test]
#[ignore = "real data; prints figures (cargo test --release --test rigging -- --ignored --nocapture)"]
fn real_data_figures() {
    let opts = RigOptions::default();
    println!("options: {opts:?}");
    let class = synthetic_class(2, 0).unwrap();
    report("synthetic class (res 2)", &class[0], &class[1..], &opts);
    if let Some(dir) = shared_data_or_skip("tosca", "real_data_figures") {
        let folder = ToscaFolder::open(&dir).unwrap();
        let cats = folder.class("cat").unwrap();
        let rest = cats[0].load().unwrap();
        let ex: Vec<Mesh> = cats[1..9].iter().map(|e| e.load().unwrap()).collect();
        report("TOSCA cat0 ← cat1..8", &rest, &ex, &opts);
        report("TOSCA cat0 ← cat1..4", &rest, &ex[..4], &opts);
    }
    if let Some(dir) = shared_data_or_skip("faust", "real_data_figures") {
        let folder = FaustFolder::open(&dir).unwrap();
        let subject: Vec<Mesh> = folder
            .entries
            .iter()
            .filter(|e| e.id / 10 == 1)
            .map(|e| e.load().unwrap())
            .collect();
        report(
            "FAUST subject 1 (012 ← 017 018 019)",
            &subject[0],
            &subject[1..],
            &opts,
        );
    }
}

//! Der, Sumner & Popović 2006 reduced-model IK (`baselines::der`): the
//! blend returns an example's gradients for its one-hot weights, the
//! reduced energy equals the energy evaluated vertex by vertex, Gauss–Newton
//! reproduces an example that the model spans exactly, and the completion
//! loop on a partial target lowers the distortion of the template.

use deformlab::baselines::{DerModel, DerOptions, DerState};
use deformlab::mesh::Mesh;
use deformlab::methods::completion::{CompletionProblem, FeatureOptions};
use deformlab::ops::rotation::rotation_exp_axis_angle;
use deformlab::ops::{farthest_point_sampling, FpsMetric};
use deformlab::register::{apply_rows, metrics, synthetic_class, vertex_rows, NicpOptions};
use deformlab::{Mat3, Point, Vec3};
use nalgebra::DVector;

/// Euclidean Voronoi clusters of `r` farthest-point seeds (a stand-in for
/// the FBT clusters that needs no eigensolve).
fn clusters(mesh: &Mesh, r: usize) -> Vec<usize> {
    let seeds = farthest_point_sampling(mesh, r, FpsMetric::Euclidean, 3).unwrap();
    let v = mesh.vertices();
    v.iter()
        .map(|p| {
            (0..seeds.len())
                .min_by(|&a, &b| {
                    (p - v[seeds[a]])
                        .norm()
                        .total_cmp(&(p - v[seeds[b]]).norm())
                })
                .unwrap()
        })
        .collect()
}

fn bbox_diag(m: &Mesh) -> f64 {
    let v = m.vertices();
    let (mut lo, mut hi) = (v[0].coords, v[0].coords);
    for p in v {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    (hi - lo).norm()
}

/// Reference, a similarity of it (rotation, scale 1.3, translation) and a
/// genuinely different pose of the synthetic class.
fn examples() -> Vec<Mesh> {
    let class = synthetic_class(1, 0).unwrap();
    let r = rotation_exp_axis_angle(&Vec3::new(0.2, -0.5, 0.3));
    let t = Vec3::new(0.3, -0.1, 0.2);
    let sim = class[0]
        .map_vertices(|p| Point::from(r * p.coords * 1.3 + t))
        .unwrap();
    vec![class[0].clone(), sim, class[3].clone()]
}

#[test]
fn one_hot_weights_return_the_example_gradients() {
    let ex = examples();
    let cl = clusters(&ex[0], 12);
    let model = DerModel::new(&ex, &cl).unwrap();
    assert_eq!(model.n_clusters(), 12);
    let rot = rotation_exp_axis_angle(&Vec3::new(0.0, 0.4, -0.1));
    for l in 0..ex.len() {
        let mut st = DerState::example(ex.len(), l);
        let t = model.blend(&st).unwrap();
        st.rotation = rot;
        let tr = model.blend(&st).unwrap();
        for k in 0..model.n_clusters() {
            let g = model.example_gradient(l, k).unwrap();
            assert!((t[k] - g).abs().max() < 1e-9, "example {l} cluster {k}");
            assert!((tr[k] - rot * g).abs().max() < 1e-9);
        }
    }
    // The similarity example's gradients are its matrix in every cluster
    // (an independent value: 1.3 R).
    let r = rotation_exp_axis_angle(&Vec3::new(0.2, -0.5, 0.3));
    for k in 0..model.n_clusters() {
        let g = model.example_gradient(1, k).unwrap();
        assert!((g - r * 1.3).abs().max() < 1e-9, "cluster {k}: {g}");
    }
    // The reference's own gradients are the identity.
    for k in 0..model.n_clusters() {
        assert!(
            (model.example_gradient(0, k).unwrap() - Mat3::identity())
                .abs()
                .max()
                < 1e-9
        );
    }
}

#[test]
fn reduced_energy_equals_the_full_energy() {
    let ex = examples();
    let cl = clusters(&ex[0], 10);
    let model = DerModel::new(&ex, &cl).unwrap();
    // Mixed rows: single vertices and weighted averages.
    let verts = farthest_point_sampling(&ex[2], 15, FpsMetric::Euclidean, 1).unwrap();
    let mut rows = vertex_rows(&verts);
    rows.push(vec![(5, 0.25), (40, 0.5), (90, 0.25)]);
    rows.push(vec![(7, 0.5), (300, 0.5)]);
    let y = apply_rows(&rows, ex[2].vertices()).unwrap();
    let prob = model.problem(&rows, &y, 1000.0).unwrap();
    let st = DerState {
        weights: DVector::from_vec(vec![0.3, 0.2, 0.6]),
        rotation: rotation_exp_axis_angle(&Vec3::new(0.1, 0.2, -0.3)),
    };
    let ts = model.blend(&st).unwrap();
    let x = model.positions(&prob, &ts);
    let reduced = model.energy(&prob, &st).unwrap();
    let full = model.energy_full(&prob, &x, &ts).unwrap();
    assert!(
        (reduced - full).abs() <= 1e-7 * full.abs().max(1e-9),
        "{reduced} vs {full}"
    );
    // x minimises the energy over positions: perturbing it raises it.
    let mut xp = x.clone();
    xp[17] += Vec3::new(1e-3, 0.0, 0.0);
    assert!(model.energy_full(&prob, &xp, &ts).unwrap() > full);
}

#[test]
fn gauss_newton_reproduces_a_spanned_example_from_the_reference() {
    let ex = examples();
    let cl = clusters(&ex[0], 12);
    let model = DerModel::new(&ex, &cl).unwrap();
    let verts = farthest_point_sampling(&ex[1], 20, FpsMetric::Euclidean, 2).unwrap();
    let rows = vertex_rows(&verts);
    let y = apply_rows(&rows, ex[1].vertices()).unwrap();
    let prob = model.problem(&rows, &y, 1000.0).unwrap();
    // From the reference pose (not the example's start): Gauss–Newton must
    // find the weights and rotation of the similarity.
    let sol = model
        .solve(
            &prob,
            &DerState::example(3, 0),
            &DerOptions {
                max_iter: 100,
                ..DerOptions::default()
            },
        )
        .unwrap();
    for w in sol.trace.windows(2) {
        assert!(w[1] <= w[0], "energy increased: {:?}", sol.trace);
    }
    let diag = bbox_diag(&ex[1]);
    let err = sol
        .positions
        .iter()
        .zip(ex[1].vertices())
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(err < 1e-6 * diag, "max error {err} (diag {diag})");
    // Multi-start registration too.
    let reg = model.register(&prob, &DerOptions::default()).unwrap();
    let err = reg
        .positions
        .iter()
        .zip(ex[1].vertices())
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(err < 1e-6 * diag, "register: max error {err}");
}

#[test]
fn completion_on_a_partial_target_reduces_distortion() {
    let class = synthetic_class(1, 0).unwrap();
    let ex = vec![class[0].clone(), class[2].clone(), class[5].clone()];
    let target = &class[7];
    let cl = clusters(&ex[0], 16);
    let model = DerModel::new(&ex, &cl).unwrap();
    let problem = CompletionProblem::new(&ex, target, &FeatureOptions::default(), 11).unwrap();
    let (a, partial, (rows, y)) = (problem.area(), problem.partial(), problem.constraints());
    let opts = DerOptions::default();
    let prob = model.problem(rows, y, opts.beta).unwrap();
    let reg = model.register(&prob, &opts).unwrap();
    let res = model
        .nicp(
            (rows, y),
            &partial.mesh,
            &reg.state,
            &NicpOptions {
                iterations: 3,
                ..NicpOptions::default()
            },
            &opts,
        )
        .unwrap();
    let tv = target.vertices();
    let d0 = metrics::mean(&metrics::relative_distortion(ex[0].vertices(), tv, a).unwrap());
    let d1 = metrics::mean(&metrics::relative_distortion(&res.positions, tv, a).unwrap());
    assert_eq!(res.accepted.len(), 3);
    assert!(res.accepted.iter().all(|&c| c > 100), "{:?}", res.accepted);
    assert!(d1 < 0.5 * d0, "template {d0}, Der completion {d1}");
}

#[test]
fn bad_inputs_are_errors() {
    let ex = examples();
    let cl = clusters(&ex[0], 5);
    assert!(DerModel::new(&ex, &cl[1..]).is_err());
    assert!(DerModel::new(&[], &cl).is_err());
    let model = DerModel::new(&ex, &cl).unwrap();
    let rows = vertex_rows(&[0, 1, 2]);
    let y = apply_rows(&rows, ex[1].vertices()).unwrap();
    assert!(model
        .problem(&rows, &y.rows(0, 2).into_owned(), 1.0)
        .is_err());
    assert!(model
        .problem(&vertex_rows(&[1_000_000]), &y.rows(0, 1).into_owned(), 1.0)
        .is_err());
    assert!(model.problem(&rows, &y, -1.0).is_err());
    let prob = model.problem(&rows, &y, 1.0).unwrap();
    assert!(model.energy(&prob, &DerState::example(2, 0)).is_err());
}

//! Amberg et al. 2007 optimal-step nonrigid ICP (`baselines::amberg`):
//! exact recovery of a target that is an affine / rigid image of the
//! template, no motion for an identical target, and a partial target
//! registered closer than the undeformed template.

use deformlab::baselines::{amberg_nicp, AmbergOptions};
use deformlab::mesh::primitives::torus;
use deformlab::mesh::Mesh;
use deformlab::methods::completion::{CompletionProblem, FeatureOptions};
use deformlab::ops::rotation::rotation_exp_axis_angle;
use deformlab::ops::{farthest_point_sampling, FpsMetric};
use deformlab::register::{apply_rows, metrics, synthetic_class, vertex_rows, NicpOptions};
use deformlab::{Mat3, Point, Vec3};
use nalgebra::DMatrix;

fn bbox_diag(m: &Mesh) -> f64 {
    let v = m.vertices();
    let (mut lo, mut hi) = (v[0].coords, v[0].coords);
    for p in v {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    (hi - lo).norm()
}

fn max_err(a: &[Point], b: &[Point]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max)
}

/// A torus bent out of symmetry (so closest points are informative).
fn template() -> Mesh {
    torus(1.0, 0.35, 24, 12)
        .map_vertices(|p| Point::new(p.x * 1.2, p.y + 0.2 * p.x * p.x, p.z + 0.1 * p.x))
        .unwrap()
}

fn landmarks(t: &Mesh, target: &Mesh) -> (Vec<Vec<(usize, f64)>>, DMatrix<f64>) {
    let v = farthest_point_sampling(t, 8, FpsMetric::Euclidean, 4).unwrap();
    let rows = vertex_rows(&v);
    let y = apply_rows(&rows, target.vertices()).unwrap();
    (rows, y)
}

fn transformed(t: &Mesh, a: &Mat3, b: Vec3) -> Mesh {
    t.map_vertices(|p| Point::from(a * p.coords + b)).unwrap()
}

#[test]
fn recovers_an_affine_and_a_rigid_image_of_the_template() {
    let t = template();
    let r = rotation_exp_axis_angle(&Vec3::new(0.15, -0.1, 0.2));
    let affine = r * Mat3::new(1.1, 0.05, 0.0, 0.0, 0.95, 0.03, 0.02, 0.0, 1.05);
    for (name, a) in [("rigid", r), ("affine", affine)] {
        let target = transformed(&t, &a, Vec3::new(0.1, -0.05, 0.08));
        let (rows, y) = landmarks(&t, &target);
        let res = amberg_nicp(
            &t,
            &target,
            (&rows, &y),
            &AmbergOptions {
                icp: NicpOptions {
                    samples: 0,
                    max_distance: 0.5,
                    ..NicpOptions::default()
                },
                ..AmbergOptions::default()
            },
        )
        .unwrap();
        let err = max_err(&res.positions, target.vertices());
        let diag = bbox_diag(&target);
        assert!(err < 1e-3 * diag, "{name}: max error {err}, diag {diag}");
        // The undeformed template was far off: the test is not vacuous.
        assert!(max_err(t.vertices(), target.vertices()) > 0.05 * diag);
        assert_eq!(res.steps.len(), 10);
        // Every vertex ends matched to its own image.
        assert_eq!(*res.accepted.last().unwrap(), t.n_vertices());
    }
}

#[test]
fn identical_template_and_target_stay_put() {
    let t = template();
    let (rows, y) = landmarks(&t, &t);
    let res = amberg_nicp(&t, &t, (&rows, &y), &AmbergOptions::default()).unwrap();
    let err = max_err(&res.positions, t.vertices());
    assert!(err < 1e-6 * bbox_diag(&t), "moved by {err}");
    // Converged at once at every stiffness: the transforms are the identity.
    assert!(res.steps.iter().all(|s| s.1 <= 2), "{:?}", res.steps);
}

#[test]
fn partial_target_is_registered_closer_than_the_template() {
    let class = synthetic_class(1, 0).unwrap();
    let (reference, target) = (&class[0], &class[4]);
    let problem = CompletionProblem::new(
        std::slice::from_ref(reference),
        target,
        &FeatureOptions::default(),
        21,
    )
    .unwrap();
    let (area, partial, (rows, y)) = (problem.area(), problem.partial(), problem.constraints());
    let opts = AmbergOptions {
        stiffness: vec![100.0, 20.0, 5.0, 1.0],
        max_inner: 3,
        ..AmbergOptions::default()
    };
    let res = amberg_nicp(reference, &partial.mesh, (rows, y), &opts).unwrap();
    let tv = target.vertices();
    let d0 = metrics::mean(&metrics::relative_distortion(reference.vertices(), tv, area).unwrap());
    let d1 = metrics::mean(&metrics::relative_distortion(&res.positions, tv, area).unwrap());
    assert!(d1 < 0.7 * d0, "template {d0}, Amberg {d1}");
    // Boundary rejection: no template vertex is matched to the rim.
    assert!(res.accepted.iter().all(|&a| a < reference.n_vertices()));
}

#[test]
fn bad_inputs_are_errors() {
    let t = template();
    let (rows, y) = landmarks(&t, &t);
    let bad = |o: AmbergOptions| amberg_nicp(&t, &t, (&rows, &y), &o).is_err();
    assert!(bad(AmbergOptions {
        stiffness: vec![],
        ..AmbergOptions::default()
    }));
    assert!(bad(AmbergOptions {
        stiffness: vec![10.0, -1.0],
        ..AmbergOptions::default()
    }));
    assert!(bad(AmbergOptions {
        gamma: 0.0,
        ..AmbergOptions::default()
    }));
    let far = vertex_rows(&[t.n_vertices()]);
    assert!(amberg_nicp(
        &t,
        &t,
        (&far, &y.rows(0, 1).into_owned()),
        &AmbergOptions::default()
    )
    .is_err());
    assert!(amberg_nicp(
        &t,
        &t,
        (&rows, &y.rows(0, 2).into_owned()),
        &AmbergOptions::default()
    )
    .is_err());
}

//! The default transfer frame (`unit_sphere`, BDT Sec. 3.5–3.6) is
//! equivariant: moving, rotating and uniformly scaling the target B moves,
//! rotates and scales B′ the same way (to 1e-6 of B's bounding radius); the
//! raw-coordinates ablation is not.

use std::sync::OnceLock;

use deformlab::data::synthetic::FaustStyle;
use deformlab::mesh::Mesh;
use deformlab::ops::sampling::{farthest_point_sampling, FpsMetric};
use deformlab::transfer::{
    fit_keypoints, transfer, KeypointOptions, TargetWeights, TransferFrame, TransferOptions,
};
use deformlab::{skin::Affine, Point};
use nalgebra::{Rotation3, Vector3};
use proptest::prelude::*;

struct Setup {
    a: Mesh,
    b: Mesh,
    kp: Vec<usize>,
    transforms: Vec<Vec<Affine>>,
}

/// Subject 0 → subject 1 of a small synthetic set, 6 FPS key points and the
/// transforms fitted on two poses of subject 0.
fn setup() -> &'static Setup {
    static S: OnceLock<Setup> = OnceLock::new();
    S.get_or_init(|| {
        let set = FaustStyle {
            subjects: 2,
            poses: 3,
            resolution: 1,
            ..FaustStyle::default()
        }
        .generate()
        .unwrap();
        let a = set.meshes[0][0].clone();
        let a_def = vec![set.meshes[0][1].clone(), set.meshes[0][2].clone()];
        let b = set.meshes[1][0].clone();
        let kp = farthest_point_sampling(&a, 6, FpsMetric::Geodesic, 0).unwrap();
        let fit = fit_keypoints(&a, &a_def, &kp, &KeypointOptions::default()).unwrap();
        Setup {
            a,
            b,
            kp,
            transforms: fit.transforms,
        }
    })
}

fn opts(frame: TransferFrame) -> TransferOptions {
    TransferOptions {
        frame,
        weight_kind: TargetWeights::Fast,
        ..TransferOptions::default()
    }
}

fn radius(m: &Mesh) -> f64 {
    let v = m.vertices();
    let c = v.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / v.len() as f64;
    v.iter().map(|p| (p.coords - c).norm()).fold(0.0, f64::max)
}

/// `max_i ‖Q(B′)_i − (B′ of Q(B))_i‖ / radius(Q(B))` for the similarity Q.
fn equivariance_gap(frame: TransferFrame, q: &dyn Fn(&Point) -> Point) -> f64 {
    let s = setup();
    let qb = s.b.map_vertices(q).unwrap();
    let o = opts(frame);
    let plain = transfer(&s.a, &s.kp, &s.transforms, &s.b, &s.kp, &o).unwrap();
    let moved = transfer(&s.a, &s.kp, &s.transforms, &qb, &s.kp, &o).unwrap();
    let mut gap = 0.0f64;
    for (p, m) in plain.iter().zip(&moved) {
        for (x, y) in p.vertices().iter().zip(m.vertices()) {
            gap = gap.max((q(x) - y).norm());
        }
    }
    gap / radius(&qb)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    #[test]
    fn unit_sphere_frame_is_equivariant_under_similarities(
        axis in (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64),
        angle in -3.1..3.1f64,
        shift in (-5.0..5.0f64, -5.0..5.0f64, -5.0..5.0f64),
        log_scale in -1.5..1.5f64,
    ) {
        let axis = Vector3::new(axis.0, axis.1, axis.2);
        prop_assume!(axis.norm() > 0.1);
        let r = Rotation3::new(axis.normalize() * angle);
        let t = Vector3::new(shift.0, shift.1, shift.2);
        let sc = log_scale.exp();
        let q = move |p: &Point| Point::from(sc * (r * p.coords) + t);
        let gap = equivariance_gap(TransferFrame::UnitSphere, &q);
        prop_assert!(gap < 1e-6, "gap {gap}");
    }
}

/// The raw frame is not equivariant (so the test above can fail): a
/// rotated and shifted B gives a B′ that is not the rotated, shifted B′.
#[test]
fn raw_frame_is_not_equivariant() {
    let r = Rotation3::new(Vector3::new(0.0, 0.7, 0.0));
    let t = Vector3::new(0.5, 0.0, -0.3);
    let q = move |p: &Point| Point::from(r * p.coords + t);
    let raw = equivariance_gap(TransferFrame::Raw, &q);
    let unit = equivariance_gap(TransferFrame::UnitSphere, &q);
    assert!(raw > 1e-2, "raw gap {raw}");
    assert!(unit < 1e-6, "unit-sphere gap {unit}");
}

/// With A = B and the source key points on both, the unit-sphere frame is
/// the identity map, so it reproduces the raw transfer exactly.
#[test]
fn unit_sphere_frame_equals_raw_when_b_is_a() {
    let s = setup();
    let u = transfer(
        &s.a,
        &s.kp,
        &s.transforms,
        &s.a,
        &s.kp,
        &opts(TransferFrame::UnitSphere),
    )
    .unwrap();
    let r = transfer(
        &s.a,
        &s.kp,
        &s.transforms,
        &s.a,
        &s.kp,
        &opts(TransferFrame::Raw),
    )
    .unwrap();
    for (x, y) in u.iter().zip(&r) {
        for (p, q) in x.vertices().iter().zip(y.vertices()) {
            assert!((p - q).norm() < 1e-9 * radius(&s.a));
        }
    }
}

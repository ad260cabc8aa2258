//! Transfer to a target (BDT Sec. 3.6) with hand-made transforms: frames,
//! invariances, refinement and input errors. Independent of key point
//! selection.

use deformlab::data::synthetic::FaustStyle;
use deformlab::ops::sampling::{farthest_point_sampling, FpsMetric};
use deformlab::skin::bbw::{BbwOptions, WeightMode};
use deformlab::skin::Affine;
use deformlab::transfer::{
    handle_relative, transfer, transfer_detailed, TransferFrame, TransferOptions,
};
use deformlab::{Error, Mesh, Point, Vec3};
use nalgebra::{Rotation3, Vector3};

fn small_set() -> Vec<Vec<Mesh>> {
    FaustStyle {
        subjects: 2,
        poses: 2,
        resolution: 1,
        ..Default::default()
    }
    .generate()
    .unwrap()
    .meshes
}

fn opts(frame: TransferFrame) -> TransferOptions {
    TransferOptions {
        frame,
        weights: BbwOptions::with_mode(WeightMode::PerHandle),
        ..TransferOptions::default()
    }
}

/// A few smooth-ish affine transforms (rotations about varying axes plus
/// translations), deterministic.
fn some_transforms(n: usize, phase: f64) -> Vec<Affine> {
    (0..n)
        .map(|k| {
            let a = 0.1 * (k as f64 + phase);
            let r = Rotation3::from_axis_angle(
                &nalgebra::Unit::new_normalize(Vector3::new(a.cos(), a.sin(), 0.3)),
                0.2 + 0.05 * k as f64,
            );
            let mut t = Affine::zeros();
            t.fixed_view_mut::<3, 3>(0, 0).copy_from(r.matrix());
            t.set_column(3, &Vector3::new(0.01 * k as f64, -0.02, 0.03 * phase));
            t
        })
        .collect()
}

fn max_dist(a: &Mesh, b: &Mesh) -> f64 {
    a.vertices()
        .iter()
        .zip(b.vertices())
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max)
}

#[test]
fn identity_transforms_leave_the_target_unchanged_and_frames_agree_on_b_equal_a() {
    let set = small_set();
    let a = &set[0][0];
    let b = &set[1][0];
    let kp = farthest_point_sampling(a, 8, FpsMetric::Euclidean, 3).unwrap();
    let id = vec![vec![Affine::identity(); kp.len()]];
    let out = transfer(a, &kp, &id, b, &kp, &opts(TransferFrame::Raw)).unwrap();
    let d = max_dist(&out[0], b);
    eprintln!("identity transforms: max displacement of B = {d:.3e}");
    assert!(d < 1e-9, "{d}");

    // B = A: handle-relative equals direct.
    let ts = vec![
        some_transforms(kp.len(), 0.0),
        some_transforms(kp.len(), 1.0),
    ];
    let d1 = transfer(a, &kp, &ts, a, &kp, &opts(TransferFrame::Raw)).unwrap();
    let d2 = transfer(a, &kp, &ts, a, &kp, &opts(TransferFrame::HandleRelative)).unwrap();
    for (x, y) in d1.iter().zip(&d2) {
        let d = max_dist(x, y);
        eprintln!("B = A: max |direct − handle-relative| = {d:.3e}");
        assert!(d < 1e-9, "{d}");
    }
}

#[test]
fn handle_relative_moves_with_a_translated_target() {
    let set = small_set();
    let a = &set[0][0];
    let shift = Vec3::new(0.7, -0.3, 1.1);
    let b = a.map_vertices(|p| p + shift).unwrap();
    let kp = farthest_point_sampling(a, 6, FpsMetric::Euclidean, 1).unwrap();
    let ts = vec![some_transforms(kp.len(), 2.0)];
    let on_a = transfer(a, &kp, &ts, a, &kp, &opts(TransferFrame::HandleRelative)).unwrap();
    let on_b = transfer(a, &kp, &ts, &b, &kp, &opts(TransferFrame::HandleRelative)).unwrap();
    let moved = on_a[0].map_vertices(|p| p + shift).unwrap();
    let d = max_dist(&moved, &on_b[0]);
    eprintln!("translated target, handle-relative: max deviation {d:.3e}");
    assert!(d < 1e-9, "{d}");
    // The handle displacement is the source's.
    let t = &ts[0][0];
    let (pa, pb) = (a.vertices()[kp[0]], b.vertices()[kp[0]]);
    let tb = handle_relative(t, &pa, &pb);
    let lhs = tb * pb.to_homogeneous();
    let rhs = pb.coords + (t * pa.to_homogeneous() - pa.coords);
    assert!((lhs - rhs).norm() < 1e-12);
}

#[test]
fn refinement_keeps_key_points_and_is_rigid_for_a_rigid_motion() {
    let set = small_set();
    let a = &set[0][0];
    let b = &set[1][0];
    let kp = farthest_point_sampling(a, 8, FpsMetric::Euclidean, 5).unwrap();
    // One rigid motion for every handle: the refined result must stay that
    // rigid motion of B (ARAP energy zero, handle constraints met).
    let rigid = some_transforms(1, 0.5)[0];
    let ts = vec![vec![rigid; kp.len()]];
    let o = TransferOptions {
        refine: true,
        ..opts(TransferFrame::Raw)
    };
    let res = transfer_detailed(a, &kp, &ts, b, &kp, &o).unwrap();
    let expect: Vec<Point> = b
        .vertices()
        .iter()
        .map(|p| Point::from(rigid * p.to_homogeneous()))
        .collect();
    let d = res.meshes[0]
        .vertices()
        .iter()
        .zip(&expect)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    eprintln!(
        "rigid motion, refined: max deviation {d:.3e} (weights {:.2} s, refine {:.2} s)",
        res.seconds_weights, res.seconds_refine
    );
    assert!(d < 1e-4, "{d}");

    // Non-rigid transforms: refined key points stay near the transferred ones.
    let ts = vec![some_transforms(kp.len(), 3.0)];
    let res = transfer_detailed(a, &kp, &ts, b, &kp, &o).unwrap();
    let worst = kp
        .iter()
        .map(|&v| (res.meshes[0].vertices()[v] - res.lbs[0].vertices()[v]).norm())
        .fold(0.0, f64::max);
    eprintln!("refined key points moved by at most {worst:.3e}");
    assert!(worst < 1e-2, "{worst}");
    assert_eq!(res.groups.len(), b.n_vertices());
}

#[test]
fn bad_inputs_are_errors() {
    let set = small_set();
    let a = &set[0][0];
    let b = &set[1][0];
    let kp = vec![1, 50, 300];
    let ts = vec![some_transforms(3, 0.0)];
    let o = opts(TransferFrame::Raw);
    let msg = |r: deformlab::Result<Vec<Mesh>>| match r {
        Err(Error::InvalidInput(m)) => m,
        other => panic!("expected an invalid-input error, got {other:?}"),
    };
    let m = msg(transfer(a, &kp, &ts, b, &[1, 50], &o));
    assert!(m.contains("3 source key points but 2 target"), "{m}");
    let m = msg(transfer(a, &kp, &ts, b, &[1, 50, b.n_vertices()], &o));
    assert!(m.contains("out") || m.contains("vertices"), "{m}");
    let m = msg(transfer(a, &kp, &ts, b, &[1, 50, 1], &o));
    assert!(m.contains("same vertex 1"), "{m}");
    let m = msg(transfer(a, &kp, &[some_transforms(2, 0.0)], b, &kp, &o));
    assert!(m.contains("2 transforms for 3 key points"), "{m}");
    let mut bad = some_transforms(3, 0.0);
    bad[1][(0, 3)] = f64::NAN;
    let m = msg(transfer(a, &kp, &[bad], b, &kp, &o));
    assert!(m.contains("not finite"), "{m}");
    let m = msg(transfer(a, &kp, &[], b, &kp, &o));
    assert!(m.contains("no deformations"), "{m}");
}

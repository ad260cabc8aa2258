//! Which motions of the target B the transfer frames are equivariant under
//! (moving B moves B′ the same way, to 1e-6 of B's bounding radius), held
//! for every key point count: 1, 2, 3 and 6.
//!
//! * `unit_sphere` with `align = none` (the default, the paper): translations
//!   and uniform scalings of B, for any count; not rotations.
//! * `unit_sphere` with `align = keypoints`: every similarity, with ≥ 3
//!   non-collinear key point pairs; fewer pairs are refused.
//! * `unit_sphere` with `align = dense` (shared connectivity): every
//!   similarity, for any count.
//! * `handle_relative`: translations of B, for any count.
//! * `raw`: none of these.

use std::sync::OnceLock;

use deformlab::data::synthetic::FaustStyle;
use deformlab::mesh::Mesh;
use deformlab::ops::sampling::{farthest_point_sampling, FpsMetric};
use deformlab::transfer::{
    fit_keypoints, transfer, FrameAlign, FrameMap, KeypointOptions, TargetWeights, TransferFrame,
    TransferOptions,
};
use deformlab::{skin::Affine, Point};
use nalgebra::{Rotation3, Vector3};
use proptest::prelude::*;

/// The key point counts every property is held for.
const COUNTS: [usize; 4] = [1, 2, 3, 6];

struct Fit {
    kp: Vec<usize>,
    transforms: Vec<Vec<Affine>>,
}

struct Setup {
    a: Mesh,
    b: Mesh,
    /// One fit per entry of [`COUNTS`].
    fits: Vec<Fit>,
}

/// Subject 0 → subject 1 of a small synthetic set (shared connectivity),
/// for each count the first `k` FPS key points and the transforms fitted
/// on two poses of subject 0.
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
        let fits = COUNTS
            .iter()
            .map(|&k| {
                let kp = farthest_point_sampling(&a, k, FpsMetric::Geodesic, 0).unwrap();
                let fit = fit_keypoints(&a, &a_def, &kp, &KeypointOptions::default()).unwrap();
                Fit {
                    kp,
                    transforms: fit.transforms,
                }
            })
            .collect();
        Setup { a, b, fits }
    })
}

fn opts(frame: TransferFrame, align: FrameAlign) -> TransferOptions {
    TransferOptions {
        frame,
        align,
        weight_kind: TargetWeights::Fast,
        ..TransferOptions::default()
    }
}

fn radius(m: &Mesh) -> f64 {
    let v = m.vertices();
    let c = v.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / v.len() as f64;
    v.iter().map(|p| (p.coords - c).norm()).fold(0.0, f64::max)
}

/// `max_i ‖Q(B′)_i − (B′ of Q(B))_i‖ / radius(Q(B))` for the motion Q, with
/// the fit of `COUNTS[which]`.
fn gap(which: usize, frame: TransferFrame, align: FrameAlign, q: &dyn Fn(&Point) -> Point) -> f64 {
    let s = setup();
    let f = &s.fits[which];
    let qb = s.b.map_vertices(q).unwrap();
    let o = opts(frame, align);
    let plain = transfer(&s.a, &f.kp, &f.transforms, &s.b, &f.kp, &o).unwrap();
    let moved = transfer(&s.a, &f.kp, &f.transforms, &qb, &f.kp, &o).unwrap();
    let mut g = 0.0f64;
    for (p, m) in plain.iter().zip(&moved) {
        for (x, y) in p.vertices().iter().zip(m.vertices()) {
            g = g.max((q(x) - y).norm());
        }
    }
    g / radius(&qb)
}

fn similarity(
    axis: (f64, f64, f64),
    angle: f64,
    shift: (f64, f64, f64),
    log_scale: f64,
) -> impl Fn(&Point) -> Point {
    let axis = Vector3::new(axis.0, axis.1, axis.2);
    let r = if axis.norm() > 0.1 {
        Rotation3::new(axis.normalize() * angle)
    } else {
        Rotation3::new(Vector3::new(0.0, angle, 0.0))
    };
    let t = Vector3::new(shift.0, shift.1, shift.2);
    let sc = log_scale.exp();
    move |p: &Point| Point::from(sc * (r * p.coords) + t)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 8, ..ProptestConfig::default() })]

    /// The default: translations and uniform scalings, every count.
    #[test]
    fn default_frame_is_equivariant_under_translation_and_scaling(
        shift in (-5.0..5.0f64, -5.0..5.0f64, -5.0..5.0f64),
        log_scale in -1.5..1.5f64,
    ) {
        let q = similarity((0.0, 1.0, 0.0), 0.0, shift, log_scale);
        for (i, k) in COUNTS.iter().enumerate() {
            let g = gap(i, TransferFrame::UnitSphere, FrameAlign::None, &q);
            prop_assert!(g < 1e-6, "{k} key points: gap {g}");
        }
    }

    /// `align = dense`: every similarity, every count.
    #[test]
    fn dense_alignment_is_equivariant_under_similarities(
        axis in (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64),
        angle in -3.1..3.1f64,
        shift in (-5.0..5.0f64, -5.0..5.0f64, -5.0..5.0f64),
        log_scale in -1.5..1.5f64,
    ) {
        let q = similarity(axis, angle, shift, log_scale);
        for (i, k) in COUNTS.iter().enumerate() {
            let g = gap(i, TransferFrame::UnitSphere, FrameAlign::Dense, &q);
            prop_assert!(g < 1e-6, "{k} key points: gap {g}");
        }
    }

    /// `align = keypoints`: every similarity with 3 and 6 key points.
    #[test]
    fn keypoint_alignment_is_equivariant_under_similarities(
        axis in (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64),
        angle in -3.1..3.1f64,
        shift in (-5.0..5.0f64, -5.0..5.0f64, -5.0..5.0f64),
        log_scale in -1.5..1.5f64,
    ) {
        let q = similarity(axis, angle, shift, log_scale);
        for (i, k) in COUNTS.iter().enumerate().filter(|(_, &k)| k >= 3) {
            let g = gap(i, TransferFrame::UnitSphere, FrameAlign::Keypoints, &q);
            prop_assert!(g < 1e-6, "{k} key points: gap {g}");
        }
    }

    /// `handle_relative`: translations, every count.
    #[test]
    fn handle_relative_frame_is_equivariant_under_translation(
        shift in (-5.0..5.0f64, -5.0..5.0f64, -5.0..5.0f64),
    ) {
        let q = similarity((0.0, 1.0, 0.0), 0.0, shift, 0.0);
        for (i, k) in COUNTS.iter().enumerate() {
            let g = gap(i, TransferFrame::HandleRelative, FrameAlign::None, &q);
            prop_assert!(g < 1e-6, "{k} key points: gap {g}");
        }
    }
}

/// The properties above can fail: the default does not follow a rotation
/// of B (for any count, 2 key points included), and the raw frame follows
/// neither a rotation nor a shift.
#[test]
fn default_frame_does_not_follow_rotations_and_raw_frame_nothing() {
    let rot = similarity((0.0, 1.0, 0.0), 0.7, (0.0, 0.0, 0.0), 0.0);
    let shift = similarity((0.0, 1.0, 0.0), 0.0, (0.5, 0.0, -0.3), 0.0);
    for (i, k) in COUNTS.iter().enumerate() {
        let g = gap(i, TransferFrame::UnitSphere, FrameAlign::None, &rot);
        assert!(g > 1e-2, "{k} key points: default gap under a rotation {g}");
        let g = gap(i, TransferFrame::Raw, FrameAlign::None, &shift);
        assert!(g > 1e-2, "{k} key points: raw gap under a shift {g}");
    }
}

/// `align = keypoints` refuses 1 and 2 key points (the rotation is
/// undetermined) and collinear ones; `align` with another frame is refused.
#[test]
fn keypoint_alignment_refuses_ill_posed_pairs() {
    let s = setup();
    for (i, k) in COUNTS.iter().enumerate().filter(|(_, &k)| k < 3) {
        let f = &s.fits[i];
        let o = opts(TransferFrame::UnitSphere, FrameAlign::Keypoints);
        let e = transfer(&s.a, &f.kp, &f.transforms, &s.b, &f.kp, &o).unwrap_err();
        assert!(e.to_string().contains("at least 3"), "{k}: {e}");
        assert!(!e.to_string().contains("  "), "a run of spaces in: {e}");
    }
    // Three key points on one line (two of them coincide): the rotation
    // about that line is undetermined.
    let kp = [s.fits[3].kp[0], s.fits[3].kp[0], s.fits[3].kp[1]];
    let e = FrameMap::unit_sphere(&s.a, &kp, &s.b, &kp, FrameAlign::Keypoints).unwrap_err();
    assert!(e.to_string().contains("nearly on a line"), "{e}");
    assert!(!e.to_string().contains("  "), "a run of spaces in: {e}");
    // `dense` needs the identity correspondence.
    let other: Vec<usize> = kp.iter().map(|&k| k + 1).collect();
    let e = FrameMap::unit_sphere(&s.a, &kp, &s.b, &other, FrameAlign::Dense).unwrap_err();
    assert!(e.to_string().contains("dense correspondence"), "{e}");
    assert!(!e.to_string().contains("  "), "a run of spaces in: {e}");
    // The same three key points are fine without the rotation step.
    FrameMap::unit_sphere(&s.a, &kp, &s.b, &kp, FrameAlign::None).unwrap();
    let f = &s.fits[3];
    let o = opts(TransferFrame::HandleRelative, FrameAlign::Keypoints);
    let e = transfer(&s.a, &f.kp, &f.transforms, &s.b, &f.kp, &o).unwrap_err();
    assert!(e.to_string().contains("unit-sphere"), "{e}");
}

/// With A = B and the source key points on both, the unit-sphere frame is
/// the identity map, so it reproduces the raw transfer exactly (with and
/// without a rotation step).
#[test]
fn unit_sphere_frame_equals_raw_when_b_is_a() {
    let s = setup();
    let f = &s.fits[3];
    let r = transfer(
        &s.a,
        &f.kp,
        &f.transforms,
        &s.a,
        &f.kp,
        &opts(TransferFrame::Raw, FrameAlign::None),
    )
    .unwrap();
    for align in [FrameAlign::None, FrameAlign::Keypoints, FrameAlign::Dense] {
        let u = transfer(
            &s.a,
            &f.kp,
            &f.transforms,
            &s.a,
            &f.kp,
            &opts(TransferFrame::UnitSphere, align),
        )
        .unwrap();
        for (x, y) in u.iter().zip(&r) {
            for (p, q) in x.vertices().iter().zip(y.vertices()) {
                assert!((p - q).norm() < 1e-9 * radius(&s.a), "{align:?}");
            }
        }
    }
}

//! Rotation groups (`deformlab::skin::groups`, BDT Sec. 3.3) on a tube bent
//! at a joint: clustering on the augmented `W′` (Eq. 15) separates the two
//! rigid parts better than clustering on `W` alone.
//! `cargo test --release --test groups_bend`.

use deformlab::mesh::Face;
use deformlab::ops::rotation::rotation_exp_axis_angle;
use deformlab::skin::groups::{group_features, purity, rotation_groups, GroupFeatures};
use deformlab::{Mesh, Point, Vec3};
use nalgebra::DMatrix;

/// Open tube of radius 0.3 along z ∈ [0, 2], `nz` rings of `nt` vertices.
fn tube(nz: usize, nt: usize) -> Mesh {
    let mut v = Vec::new();
    for i in 0..nz {
        let z = 2.0 * i as f64 / (nz - 1) as f64;
        for j in 0..nt {
            let a = 2.0 * std::f64::consts::PI * (j as f64 + 0.5 * (i % 2) as f64) / nt as f64;
            v.push(Point::new(0.3 * a.cos(), 0.3 * a.sin(), z));
        }
    }
    let idx = |i: usize, j: usize| i * nt + j % nt;
    let mut f: Vec<Face> = Vec::new();
    for i in 0..nz - 1 {
        for j in 0..nt {
            f.push([idx(i, j), idx(i, j + 1), idx(i + 1, j)]);
            f.push([idx(i, j + 1), idx(i + 1, j + 1), idx(i + 1, j)]);
        }
    }
    Mesh::new(v, f).unwrap()
}

/// The top half (z > 1) rotated by `angle` about the x axis through (0,0,1).
fn bend(m: &Mesh, angle: f64) -> Mesh {
    let r = rotation_exp_axis_angle(&Vec3::new(angle, 0.0, 0.0));
    let c = Vec3::new(0.0, 0.0, 1.0);
    m.map_vertices(|p| {
        if p.z > 1.0 + 1e-9 {
            Point::from(r * (p.coords - c) + c)
        } else {
            *p
        }
    })
    .unwrap()
}

/// Normalised Gaussian weights of handles at heights `hz` on the axis.
fn weights(m: &Mesh, hz: &[f64], sigma: f64) -> DMatrix<f64> {
    let mut w = DMatrix::from_fn(m.n_vertices(), hz.len(), |i, k| {
        let d = m.vertices()[i].z - hz[k];
        (-d * d / (sigma * sigma)).exp() + 1e-9
    });
    for i in 0..w.nrows() {
        let s: f64 = w.row(i).sum();
        w.row_mut(i).scale_mut(1.0 / s);
    }
    w
}

fn parts(m: &Mesh) -> Vec<usize> {
    m.vertices()
        .iter()
        .map(|p| usize::from(p.z > 1.0 + 1e-9))
        .collect()
}

#[test]
fn augmented_weights_separate_rigid_parts_better() {
    let m = tube(41, 16);
    let truth = parts(&m);
    let bent = vec![bend(&m, 1.2)];
    // Handles placed unevenly: W alone has no reason to split at the joint.
    let w = weights(&m, &[0.1, 0.35, 0.6, 1.9], 0.4);
    for seed in 0..4 {
        let gw = rotation_groups(&m, &bent, &w, GroupFeatures::Weights, Some(2), seed).unwrap();
        let ga = rotation_groups(&m, &bent, &w, GroupFeatures::AUGMENTED, Some(2), seed).unwrap();
        let (pw, pa) = (purity(&gw, &truth).unwrap(), purity(&ga, &truth).unwrap());
        assert!(pa >= 0.97, "seed {seed}: W′ purity {pa}");
        assert!(
            pa > pw + 0.05,
            "seed {seed}: W′ purity {pa} vs W purity {pw}"
        );
    }
    // More groups than parts: W′ groups should still not straddle the joint
    // much (each group is almost entirely in one part).
    let ga = rotation_groups(&m, &bent, &w, GroupFeatures::AUGMENTED, None, 1).unwrap();
    let gw = rotation_groups(&m, &bent, &w, GroupFeatures::Weights, None, 1).unwrap();
    let (pw, pa) = (purity(&gw, &truth).unwrap(), purity(&ga, &truth).unwrap());
    assert!(pa >= 0.97 && pa >= pw, "3 groups: W′ {pa}, W {pw}");
}

#[test]
fn feature_matrix_layout_and_scaling() {
    let m = tube(11, 8);
    let w = weights(&m, &[0.3, 1.5], 0.5);
    let d = vec![bend(&m, 0.5), bend(&m, -0.4), m.clone()];
    let x = group_features(
        &m,
        &d,
        &w,
        GroupFeatures::Augmented {
            gamma_logr: 2.0,
            gamma_s: 0.5,
        },
    )
    .unwrap();
    assert_eq!(x.shape(), (m.n_vertices(), 2 + 12 * 3));
    assert_eq!(x.columns(0, 2), w.columns(0, 2));
    let f = deformlab::ops::deformation_features(&m, &d[1]).unwrap();
    let c = 2.0 / 3f64.sqrt();
    assert!((x.columns(2 + 3, 3) - f.log_rotation * c).norm() < 1e-12);
    let c = 0.5 / 3f64.sqrt();
    assert!((x.columns(2 + 9 + 9, 9) - f.scale_shear * c).norm() < 1e-12);
    let y = group_features(&m, &d, &w, GroupFeatures::ROTATION_SCALE).unwrap();
    assert_eq!(y.ncols(), 36);
    assert_eq!(
        group_features(&m, &[], &w, GroupFeatures::Weights).unwrap(),
        w
    );
}

#[test]
fn bad_input_is_an_error() {
    let m = tube(11, 8);
    let w = weights(&m, &[0.3, 1.5], 0.5);
    let d = vec![bend(&m, 0.5)];
    // No deformed mesh for features that need one.
    assert!(rotation_groups(&m, &[], &w, GroupFeatures::AUGMENTED, None, 0).is_err());
    // Wrong weight rows; wrong vertex count in a deformed mesh.
    let short = w.rows(0, 10).into_owned();
    assert!(rotation_groups(&m, &d, &short, GroupFeatures::Weights, None, 0).is_err());
    let other = tube(12, 8);
    assert!(rotation_groups(&m, &[other], &w, GroupFeatures::AUGMENTED, None, 0).is_err());
    // k = 0 and k > n.
    assert!(rotation_groups(&m, &d, &w, GroupFeatures::Weights, Some(0), 0).is_err());
    assert!(rotation_groups(&m, &d, &w, GroupFeatures::Weights, Some(10_000), 0).is_err());
    let nan = GroupFeatures::Augmented {
        gamma_logr: f64::NAN,
        gamma_s: 0.1,
    };
    assert!(rotation_groups(&m, &d, &w, nan, None, 0).is_err());
    assert!(purity(&[0, 1], &[0]).is_err());
}

#[test]
fn deterministic_for_a_seed() {
    let m = tube(21, 12);
    let w = weights(&m, &[0.2, 1.0, 1.8], 0.4);
    let d = vec![bend(&m, 0.9)];
    let a = rotation_groups(&m, &d, &w, GroupFeatures::AUGMENTED, Some(4), 9).unwrap();
    let b = rotation_groups(&m, &d, &w, GroupFeatures::AUGMENTED, Some(4), 9).unwrap();
    assert_eq!(a, b);
    assert!(a.iter().all(|&g| g < 4));
}

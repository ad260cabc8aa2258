//! Automatic target correspondence (issue 8, `deformlab::transfer::auto`):
//! on two synthetic subjects with shared connectivity the true target key
//! point of source vertex `k` is vertex `k`, so the automatic result can be
//! checked by the geodesic distance between the found and the true vertex —
//! also after B is turned upside down and rotated. And the CLI flag end to
//! end.

mod common;

use common::{deformlab, stdout_ok};
use deformlab::data::synthetic::FaustStyle;
use deformlab::mesh::io::{read_mesh, write_ply};
use deformlab::mesh::Mesh;
use deformlab::ops::geodesic::EdgeGraph;
use deformlab::ops::{farthest_point_sampling, total_area, FpsMetric};
use deformlab::transfer::{auto_correspondence, coarse_align, perturb_keypoints, AutoOptions};
use deformlab::{Mat3, Point, Vec3};
use nalgebra::Rotation3;

/// Two subjects of the synthetic set in their first pose (1.5k vertices).
fn pair() -> (Mesh, Mesh) {
    let set = FaustStyle {
        subjects: 2,
        poses: 1,
        resolution: 1,
        seed: 5,
        tail: true,
        spread: 0.15,
    }
    .generate()
    .unwrap();
    (set.meshes[0][0].clone(), set.meshes[1][0].clone())
}

/// Geodesic (edge-path) distance on `b` between the found and the true
/// target key points, in √area(B) units.
fn errors(b: &Mesh, found: &[usize], truth: &[usize]) -> Vec<f64> {
    let g = EdgeGraph::new(b);
    let s = total_area(b).sqrt();
    found
        .iter()
        .zip(truth)
        .map(|(&f, &t)| g.distances(&[t]).unwrap()[f] / s)
        .collect()
}

/// Tolerance on the geodesic error of each key point, in √area(B) units.
/// The two subjects differ in limb lengths and girths (spread 0.15), so the
/// registration cannot be exact; 0.05 √area is about a quarter of a hand's
/// length on this creature (its mean edge length is ≈ 0.02 √area): a key
/// point within it stays on the same limb end. A wrong coarse alignment
/// (e.g. upside down or front/back swapped) gives errors of 0.3–1 √area.
const TOL: f64 = 0.05;

#[test]
fn recovers_true_keypoints_on_shared_connectivity() {
    let (a, b) = pair();
    let kp = farthest_point_sampling(&a, 8, FpsMetric::Geodesic, 1).unwrap();
    let opts = AutoOptions::default();
    let r = auto_correspondence(&a, &kp, &b, &opts).unwrap();
    let e = errors(&b, &r.target_keypoints, &kp);
    println!(
        "upright: errors {e:.4?} (√area), coarse residual {:.4}, residual {:.4}, {:.2} s",
        r.coarse.residual, r.residual, r.seconds
    );
    assert!(
        e.iter().all(|&x| x <= TOL),
        "key point errors {e:?} exceed {TOL}"
    );
    // The nonrigid stage must improve on the rigid alignment.
    assert!(
        r.residual < r.coarse.residual,
        "{} ≥ {}",
        r.residual,
        r.coarse.residual
    );
    assert_eq!(r.target_keypoints.len(), kp.len());

    // B turned upside down (180° about x: a proper rotation), rotated about
    // an oblique axis, scaled and moved: the same vertices must be found.
    let rot: Mat3 = *(Rotation3::from_axis_angle(&Vec3::x_axis(), std::f64::consts::PI)
        * Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vec3::new(0.3, 1.0, -0.5)),
            1.1,
        ))
    .matrix();
    let moved = b
        .map_vertices(|p| Point::from(2.5 * (rot * p.coords) + Vec3::new(3.0, -1.0, 7.0)))
        .unwrap();
    let r2 = auto_correspondence(&a, &kp, &moved, &opts).unwrap();
    let e2 = errors(&moved, &r2.target_keypoints, &kp);
    println!(
        "rotated + flipped: errors {e2:.4?} (√area), coarse residual {:.4}, residual {:.4}",
        r2.coarse.residual, r2.residual
    );
    assert!(
        e2.iter().all(|&x| x <= TOL),
        "after rotation + flip: key point errors {e2:?} exceed {TOL}"
    );
}

#[test]
fn perturbation_stays_within_the_radius_and_is_seeded() {
    let (_, b) = pair();
    let kp = farthest_point_sampling(&b, 6, FpsMetric::Geodesic, 2).unwrap();
    let s = total_area(&b).sqrt();
    let radius = 0.04 * s;
    let p1 = perturb_keypoints(&b, &kp, radius, 9).unwrap();
    let p2 = perturb_keypoints(&b, &kp, radius, 9).unwrap();
    let p3 = perturb_keypoints(&b, &kp, radius, 10).unwrap();
    assert_eq!(p1, p2);
    assert_ne!(p1, p3);
    let e = errors(&b, &p1, &kp);
    assert!(e.iter().all(|&x| x <= 0.04 + 1e-12), "{e:?}");
    assert!(e.iter().any(|&x| x > 0.0));
    assert_eq!(perturb_keypoints(&b, &kp, 0.0, 9).unwrap(), kp);
    assert!(perturb_keypoints(&b, &kp, -1.0, 9).is_err());
    assert!(perturb_keypoints(&b, &[b.n_vertices()], 0.1, 9).is_err());
}

#[test]
fn cli_auto_correspondence_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let set = FaustStyle {
        subjects: 2,
        poses: 2,
        resolution: 1,
        seed: 5,
        tail: true,
        spread: 0.15,
    }
    .generate()
    .unwrap();
    let p = |n: &str| dir.path().join(n);
    write_ply(&p("a.ply"), &set.meshes[0][0]).unwrap();
    write_ply(&p("a1.ply"), &set.meshes[0][1]).unwrap();
    // The target with its vertices in reverse order: another vertex
    // numbering, so the same index would be wrong.
    let b = &set.meshes[1][0];
    let n = b.n_vertices();
    let rev: Vec<Point> = (0..n).map(|i| b.vertices()[n - 1 - i]).collect();
    let faces: Vec<[usize; 3]> = b
        .faces()
        .iter()
        .map(|f| [n - 1 - f[0], n - 1 - f[1], n - 1 - f[2]])
        .collect();
    write_ply(&p("b.ply"), &Mesh::new(rev, faces).unwrap()).unwrap();
    let out = deformlab()
        .args(["transfer", "--source"])
        .arg(p("a.ply"))
        .arg("--deformed")
        .arg(p("a1.ply"))
        .arg("--target")
        .arg(p("b.ply"))
        .args([
            "--auto-correspondence",
            "--candidates",
            "12",
            "--max-keypoints",
            "4",
            "--error-norm",
            "rms",
            "--out",
        ])
        .arg(p("out"))
        .output()
        .unwrap();
    let text = stdout_ok(&out);
    assert!(text.contains("automatic correspondence"), "{text}");
    let result = read_mesh(&p("out").join("a1_to_b.ply")).unwrap();
    assert_eq!(result.n_vertices(), n);
    let reg = read_mesh(&p("out").join("registered_source.ply")).unwrap();
    assert_eq!(reg.n_vertices(), set.meshes[0][0].n_vertices());
    // keypoints.csv: source vertex k must map to the reversed index n-1-k
    // (within the tolerance of the library test).
    let csv = std::fs::read_to_string(p("out").join("keypoints.csv")).unwrap();
    let g = EdgeGraph::new(b);
    let s = total_area(b).sqrt();
    let mut rows = 0;
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (src, tgt): (usize, usize) = (f[0].parse().unwrap(), f[1].parse().unwrap());
        let d = g.distances(&[src]).unwrap()[n - 1 - tgt] / s;
        assert!(d <= TOL, "key point {src} → {tgt}: {d} √area");
        rows += 1;
    }
    assert!(rows >= 2, "{csv}");
    let log = std::fs::read_to_string(p("out").join("log.json")).unwrap();
    assert!(log.contains("residual_sqrt_area"), "{log}");
    // A second run refuses to overwrite.
    let again = deformlab()
        .args(["transfer", "--source"])
        .arg(p("a.ply"))
        .arg("--deformed")
        .arg(p("a1.ply"))
        .arg("--target")
        .arg(p("b.ply"))
        .args(["--auto-correspondence", "--out"])
        .arg(p("out"))
        .output()
        .unwrap();
    assert!(!again.status.success());
}

#[test]
fn config_keys_are_validated_and_named() {
    use deformlab::experiment::{parse_config, Method};
    use deformlab::methods::{TargetCorrespondence, TransferMethod};
    let p = std::path::Path::new("auto.toml");
    let ok = parse_config(
        "name = \"a\"\n[[methods]]\nname = \"m\"\nkind = \"sumner\"\n\
         target_correspondence = \"auto\"\ntarget_noise = 0.02\ntarget_noise_seed = 3\n",
        p,
    )
    .unwrap();
    let Method::Transfer(TransferMethod::Markers { target: t, .. }) = &ok.methods[0].method else {
        panic!("{:?}", ok.methods[0].method)
    };
    assert_eq!(t.correspondence, TargetCorrespondence::Auto);
    assert_eq!((t.noise, t.noise_seed), (0.02, 3));
    let e = parse_config(
        "name = \"a\"\n[[methods]]\nname = \"m\"\nkind = \"clustering\"\n\
         target_correspondence = \"auto\"\n",
        p,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("methods[0].target_correspondence"), "{e}");
    let e = parse_config(
        "name = \"a\"\n[[methods]]\nname = \"m\"\nkind = \"bdt\"\ntarget_noise = 2.0\n",
        p,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("target_noise"), "{e}");
    let e = parse_config(
        "name = \"a\"\n[dataset.synthetic]\nremesh = 5.0\n[[methods]]\nname = \"m\"\nkind = \"bdt\"\n",
        p,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("dataset.synthetic.remesh"), "{e}");
}

/// Landmarks join the coarse alignment: three or more add the landmark fit
/// as a 25th candidate, the chosen motion carries each landmark close to its
/// partner, and on a pair the principal axes already solve it agrees with
/// the alignment found without landmarks.
#[test]
fn landmarks_join_the_coarse_alignment() {
    let (a, b) = pair();
    let rot: Mat3 = *Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vec3::new(0.3, 1.0, -0.5)),
        2.0,
    )
    .matrix();
    let moved = b
        .map_vertices(|p| Point::from(1.7 * (rot * p.coords) + Vec3::new(-2.0, 0.5, 4.0)))
        .unwrap();
    let lm: Vec<(usize, usize)> = farthest_point_sampling(&a, 4, FpsMetric::Geodesic, 3)
        .unwrap()
        .into_iter()
        .map(|i| (i, i))
        .collect();
    let plain = coarse_align(&a, &moved, &AutoOptions::default()).unwrap();
    let with = coarse_align(
        &a,
        &moved,
        &AutoOptions {
            landmarks: lm.clone(),
            ..AutoOptions::default()
        },
    )
    .unwrap();
    assert_eq!(plain.candidate_scores.len(), 24);
    assert_eq!(with.candidate_scores.len(), 25);
    let s = total_area(&moved).sqrt();
    let d: Vec<f64> = lm
        .iter()
        .map(|&(i, j)| (with.motion.apply(&a.vertices()[i]) - moved.vertices()[j]).norm() / s)
        .collect();
    let angle = {
        let r = with.motion.rotation * plain.motion.rotation.transpose();
        ((r.trace() - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    };
    println!(
        "landmark distances {d:.4?} (√area), chosen candidate {}, rotation vs no landmarks {angle:.2}°",
        with.chosen
    );
    // A and B are different subjects (limb lengths differ), so a rigid fit
    // leaves limb tips apart; a wrong rotation leaves them 0.3–1 √area apart.
    assert!(d.iter().all(|&x| x < 0.2), "landmarks left at {d:?}");
    assert!(angle < 10.0, "landmarks turned the alignment by {angle}°");

    // Landmarks out of range are an error naming them.
    let e = coarse_align(
        &a,
        &moved,
        &AutoOptions {
            landmarks: vec![(0, moved.n_vertices())],
            ..AutoOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("landmark (0, "), "{e}");
}

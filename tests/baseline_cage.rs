//! Cage-based spatial deformation transfer (issue 6, item 2):
//! mean-value coordinates, cage fits, self-transfer.

use deformlab::baselines::cage::{
    apply_coordinates, build_cage, coordinate_matrix, mean_value_coordinates, principal_axes,
    CageFit, CageOptions, CageTransfer,
};
use deformlab::data::synthetic::FaustStyle;
use deformlab::ops::{farthest_point_sampling, FpsMetric};
use deformlab::{Mat3, Point, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_points(n: usize, seed: u64) -> Vec<Point> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            Point::new(
                rng.random_range(-2.0..2.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-0.5..0.5),
            )
        })
        .collect()
}

#[test]
fn mvc_reproduce_linear_functions_inside_the_cage() {
    let pts = random_points(200, 1);
    let axes = principal_axes(&pts).unwrap();
    assert!((axes.transpose() * axes - Mat3::identity()).norm() < 1e-12);
    assert!((axes.determinant() - 1.0).abs() < 1e-12);
    let cage = build_cage(&pts, &axes, &CageOptions::default()).unwrap();
    let cv = cage.vertices();
    // Interior points (the samples themselves, strictly inside the
    // enlarged box), a cage vertex and a point on a cage face.
    let f = cage.faces()[7];
    let on_face = Point::from((cv[f[0]].coords + cv[f[1]].coords * 2.0 + cv[f[2]].coords) / 4.0);
    let mut queries: Vec<Point> = pts[..60].to_vec();
    queries.push(cv[5]);
    queries.push(on_face);
    for x in &queries {
        let w = mean_value_coordinates(&cage, x).unwrap();
        let s: f64 = w.iter().sum();
        assert!((s - 1.0).abs() < 1e-10, "Σφ = {s}");
        let r = w
            .iter()
            .zip(cv)
            .fold(Vec3::zeros(), |a, (wi, c)| a + c.coords * *wi);
        assert!(
            (r - x.coords).norm() < 1e-9,
            "Σφc − x = {}",
            (r - x.coords).norm()
        );
        // Strictly inside a convex cage, MVC are positive.
        if pts.contains(x) {
            assert!(
                w.iter().all(|&v| v > -1e-12),
                "negative MVC inside a convex cage"
            );
        }
    }
    // Linear precision for an arbitrary affine map of the cage.
    let m = Mat3::new(1.0, 0.3, -0.2, 0.1, 0.8, 0.4, -0.5, 0.2, 1.3);
    let t = Vec3::new(0.4, -1.0, 2.0);
    let phi = coordinate_matrix(&cage, &pts).unwrap();
    let moved: Vec<Point> = cv.iter().map(|c| Point::from(m * c.coords + t)).collect();
    let def = apply_coordinates(&phi, &moved);
    for (p, q) in pts.iter().zip(&def) {
        assert!((Point::from(m * p.coords + t) - q).norm() < 1e-9);
    }
}

#[test]
fn identity_cage_deformation_leaves_the_mesh_unchanged() {
    let set = FaustStyle {
        subjects: 1,
        poses: 1,
        resolution: 1,
        ..Default::default()
    }
    .generate()
    .unwrap();
    let rest = &set.rest[0];
    let axes = principal_axes(rest.vertices()).unwrap();
    let cage = build_cage(rest.vertices(), &axes, &CageOptions::default()).unwrap();
    let fit = CageFit::new(rest, cage.clone(), 0.01).unwrap();
    let def = fit.deform(cage.vertices()).unwrap();
    let worst = def
        .iter()
        .zip(rest.vertices())
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "identity cage moved a vertex by {worst}");
    // Fitting the rest pose returns the rest cage (both energy terms vanish).
    let c = fit.fit(rest.vertices()).unwrap();
    let worst = c
        .iter()
        .zip(cage.vertices())
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(
        worst < 1e-6,
        "fit of the rest pose moved a cage vertex by {worst}"
    );
    // Bad input: wrong sizes are errors, not panics.
    assert!(fit.fit(&rest.vertices()[1..]).is_err());
    assert!(fit.deform(&cage.vertices()[1..]).is_err());
    assert!(build_cage(
        rest.vertices(),
        &axes,
        &CageOptions {
            subdivisions: 0,
            ..Default::default()
        }
    )
    .is_err());
}

#[test]
fn self_transfer_reproduces_the_cage_fit() {
    let set = FaustStyle {
        subjects: 1,
        poses: 4,
        resolution: 1,
        ..Default::default()
    }
    .generate()
    .unwrap();
    let rest = &set.rest[0];
    let diag = {
        let v = rest.vertices();
        let (mut lo, mut hi) = (v[0].coords, v[0].coords);
        for p in v {
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
        (hi - lo).norm()
    };
    let kp = farthest_point_sampling(rest, 6, FpsMetric::Geodesic, 0).unwrap();
    let markers: Vec<(usize, usize)> = kp.iter().map(|&k| (k, k)).collect();
    let ct = CageTransfer::new(rest, rest, &markers, &CageOptions::default()).unwrap();
    let mut err_sum = 0.0;
    let mut n = 0;
    for pose in &set.meshes[0] {
        let r = ct.transfer(pose).unwrap();
        // With source = target the cage transfer is exact: the result is the
        // fitted source shape Φ C′ up to one translation.
        let fitted = ct.source().deform(&r.source_cage).unwrap();
        let d0 = r.mesh.vertices()[0] - fitted[0];
        for (p, q) in r.mesh.vertices().iter().zip(&fitted) {
            assert!(((p - q) - d0).norm() < 1e-7 * diag);
        }
        let e = r
            .mesh
            .vertices()
            .iter()
            .zip(pose.vertices())
            .map(|(a, b)| (a - b).norm())
            .sum::<f64>()
            / pose.n_vertices() as f64;
        eprintln!(
            "self-transfer: mean error {:.4} diag (cage fit residual {:.4} diag)",
            e / diag,
            r.fit_error / diag
        );
        assert!(e <= r.fit_error + d0.norm() + 1e-12);
        err_sum += e / diag;
        n += 1;
    }
    let mean = err_sum / n as f64;
    eprintln!("self-transfer mean error over {n} poses: {mean:.4} of the bbox diagonal");
    // Box cage (98 vertices) on articulated poses: measured ≈ 0.01 diag.
    assert!(mean < 0.02, "self-transfer mean error {mean} diag");
    // Fewer than one marker: a clear error.
    assert!(CageTransfer::new(rest, rest, &[], &CageOptions::default()).is_err());
    assert!(CageTransfer::new(rest, rest, &[(0, 1 << 30)], &CageOptions::default()).is_err());
}

//! Acceptance: Laplace–Beltrami spectrum of the unit sphere. On a level-5
//! icosphere (10 242 vertices) the first 16 eigenvalues of `L φ = λ M φ`
//! (cotangent L, Voronoi mass) must be l(l+1) = 0, 2×3, 6×5, 12×7 within 1 %
//! and the eigenvectors M-orthonormal to 1e-8.

use deformlab::mesh::primitives::icosphere;
use deformlab::ops::{cotan_laplacian, mass_matrix, MassKind};
use deformlab::solve::{generalized_eigen, EigenOptions};

#[test]
fn sphere_spectrum_level5() {
    let mesh = icosphere(5);
    assert_eq!(mesh.n_vertices(), 10_242);
    let l = cotan_laplacian(&mesh);
    let m = mass_matrix(&mesh, MassKind::Voronoi);
    let t = std::time::Instant::now();
    let eig = generalized_eigen(&l, &m, 16, &EigenOptions::default()).expect("eigen solve");
    eprintln!(
        "16 eigenpairs in {:.2} s, subspace {}, attempts {}, max residual {:.2e}, orth {:.2e}",
        t.elapsed().as_secs_f64(),
        eig.subspace_dim,
        eig.attempts,
        eig.max_residual,
        eig.orthonormality_error
    );
    let expected: Vec<f64> = (0..4u32)
        .flat_map(|l| std::iter::repeat_n((l * (l + 1)) as f64, (2 * l + 1) as usize))
        .collect();
    assert_eq!(expected.len(), 16);
    eprintln!("eigenvalues: {:?}", eig.values);
    assert!(eig.values[0].abs() < 1e-8, "λ0 = {}", eig.values[0]);
    for (i, (&got, &want)) in eig.values.iter().zip(&expected).enumerate().skip(1) {
        let rel = (got - want).abs() / want;
        assert!(
            rel < 0.01,
            "λ{i} = {got}, expected {want} (rel. error {rel:.4})"
        );
    }
    // M-orthonormality, computed here independently of the solver's check.
    let n = mesh.n_vertices();
    for a in 0..16 {
        for b in a..16 {
            let g: f64 = (0..n)
                .map(|i| eig.vectors[(i, a)] * m[i] * eig.vectors[(i, b)])
                .sum();
            let want = if a == b { 1.0 } else { 0.0 };
            assert!((g - want).abs() < 1e-8, "<φ{a}, φ{b}>_M = {g}");
        }
    }
    // The constant function is the λ = 0 eigenvector.
    let c0 = eig.vectors[(0, 0)];
    assert!((0..n).all(|i| (eig.vectors[(i, 0)] - c0).abs() < 1e-6 * c0.abs()));
}

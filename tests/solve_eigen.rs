//! Generalised eigenpairs: sparse block-Krylov path against the dense path,
//! verification output, bad inputs.

use deformlab::mesh::primitives::{grid, torus};
use deformlab::ops::{cotan_laplacian, mass_matrix, MassKind};
use deformlab::solve::{generalized_eigen, mass_diagonal, sparse_diagonal, EigenOptions};
use deformlab::Error;
use nalgebra::DMatrix;

/// Dense reference: eigenvalues of M^{-½} L M^{-½}, ascending.
fn dense_values(l: &deformlab::solve::SparseMatrix, m: &[f64]) -> Vec<f64> {
    let n = l.nrows();
    let mut a = DMatrix::<f64>::zeros(n, n);
    for (i, j, &v) in l.triplet_iter() {
        a[(i, j)] += v / (m[i] * m[j]).sqrt();
    }
    let mut v: Vec<f64> = nalgebra::SymmetricEigen::new(a)
        .eigenvalues
        .iter()
        .copied()
        .collect();
    v.sort_by(f64::total_cmp);
    v
}

#[test]
fn torus_krylov_matches_dense() {
    // 30 × 20 = 600 vertices: above the dense cut-off, so the block Krylov
    // path runs. The torus has many exactly double eigenvalues.
    let mesh = torus(1.0, 0.3, 30, 20);
    let l = cotan_laplacian(&mesh);
    let m = mass_matrix(&mesh, MassKind::Voronoi);
    let k = 30;
    let eig = generalized_eigen(&l, &m, k, &EigenOptions::default()).unwrap();
    assert!(eig.subspace_dim > 0, "expected the sparse path");
    let reference = dense_values(&l, &m);
    for (i, (&got, &want)) in eig.values.iter().zip(&reference).enumerate() {
        let tol = 1e-8 * want.abs().max(1.0);
        assert!((got - want).abs() < tol, "λ{i}: {got} vs dense {want}");
    }
    assert!(eig.values.windows(2).all(|w| w[0] <= w[1]));
    assert!(eig.orthonormality_error < 1e-10);
    assert!(eig.max_residual < 1e-6);
    // Each vector satisfies L φ ≈ λ M φ.
    let lphi = &l * &eig.vectors;
    for j in 0..k {
        let r: f64 = (0..m.len())
            .map(|i| (lphi[(i, j)] - eig.values[j] * m[i] * eig.vectors[(i, j)]).powi(2) / m[i])
            .sum::<f64>()
            .sqrt();
        assert!(r < 1e-5 * eig.values[j].max(1.0), "pair {j}: residual {r}");
    }
}

#[test]
fn small_problem_uses_dense_path_and_is_verified() {
    let mesh = grid(8, 8);
    let l = cotan_laplacian(&mesh);
    let m = mass_matrix(&mesh, MassKind::Barycentric);
    let eig = generalized_eigen(&l, &m, 10, &EigenOptions::default()).unwrap();
    assert_eq!(eig.subspace_dim, 0);
    let reference = dense_values(&l, &m);
    for (&got, &want) in eig.values.iter().zip(&reference) {
        assert!((got - want).abs() < 1e-9 * want.max(1.0));
    }
    // Neumann square: λ0 = 0 with a constant eigenvector.
    assert!(eig.values[0].abs() < 1e-10);
    // A sparse diagonal mass gives the same diagonal.
    assert_eq!(mass_diagonal(&sparse_diagonal(&m)).unwrap(), m);
}

#[test]
fn bad_inputs_are_errors() {
    let mesh = grid(3, 3);
    let l = cotan_laplacian(&mesh);
    let mut m = mass_matrix(&mesh, MassKind::Voronoi);
    let opts = EigenOptions::default();
    assert!(matches!(
        generalized_eigen(&l, &m, 0, &opts),
        Err(Error::InvalidInput(_))
    ));
    assert!(matches!(
        generalized_eigen(&l, &m, 17, &opts),
        Err(Error::InvalidInput(_))
    ));
    assert!(matches!(
        generalized_eigen(&l, &m[1..], 2, &opts),
        Err(Error::InvalidInput(_))
    ));
    m[3] = 0.0;
    let e = generalized_eigen(&l, &m, 2, &opts).unwrap_err();
    assert!(e.to_string().contains("mass of row 3"), "{e}");
    // Non-diagonal sparse mass is refused.
    assert!(mass_diagonal(&l).is_err());
}

//! Generalised eigenpairs: sparse block-Krylov path against the dense path,
//! verification output, bad inputs, canonical eigenvector signs.

use deformlab::mesh::primitives::{grid, icosphere, torus};
use deformlab::mesh::Mesh;
use deformlab::ops::{cotan_laplacian, mass_matrix, MassKind};
use deformlab::solve::{
    canonicalize_signs, generalized_eigen, mass_diagonal, sparse_diagonal, EigenOptions, DENSE_MAX,
};
use deformlab::{Error, Point};
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

/// Eigenvalue clusters larger than the block: the sphere's l = 4 cluster has
/// 9 members, more than the default block (6) and far more than a block of
/// 2. Whether the Krylov phase finds every member (rounding seeds the
/// missing directions) or the inertia check catches a skipped one and the
/// solve is repeated with a larger block, all 25 eigenvalues must equal the
/// dense ones, each cluster complete.
#[test]
fn clusters_larger_than_the_block_are_complete() {
    let mesh = icosphere(3);
    assert!(mesh.n_vertices() > DENSE_MAX);
    let l = cotan_laplacian(&mesh);
    let m = mass_matrix(&mesh, MassKind::Voronoi);
    let reference = dense_values(&l, &m);
    let k = 25;
    for block_size in [0, 2] {
        let opts = EigenOptions {
            block_size,
            ..EigenOptions::default()
        };
        let eig = generalized_eigen(&l, &m, k, &opts).unwrap();
        assert!(eig.subspace_dim > 0, "expected the sparse path");
        for (i, (&got, &want)) in eig.values.iter().zip(&reference).enumerate() {
            assert!(
                (got - want).abs() < 1e-8 * want.abs().max(1.0),
                "block {block_size}, λ{i}: {got} vs dense {want} (attempts {})",
                eig.attempts
            );
        }
        assert!(eig.orthonormality_error < 1e-9);
        eprintln!(
            "block {block_size}: attempts {}, subspace {}",
            eig.attempts, eig.subspace_dim
        );
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

/// A 24 × 19 grid (500 vertices, above the dense cut-off) stretched and bent
/// into an asymmetric surface: no symmetry, so its eigenvalues are simple.
fn asymmetric_sheet() -> Mesh {
    let g = grid(24, 19);
    let vertices = g
        .vertices()
        .iter()
        .map(|p| {
            let (x, y) = (1.3 * p.x, p.y);
            Point::new(x, y, 0.15 * x * x * y + 0.1 * y * y * y - 0.05 * x)
        })
        .collect();
    Mesh::new(vertices, g.faces().to_vec()).unwrap()
}

#[test]
fn eigenvectors_do_not_depend_on_seed_block_or_path() {
    let mesh = asymmetric_sheet();
    assert!(mesh.n_vertices() > DENSE_MAX);
    let l = cotan_laplacian(&mesh);
    let m = mass_matrix(&mesh, MassKind::Voronoi);
    let k = 12;
    let runs = [
        EigenOptions::default(),
        EigenOptions {
            seed: 12345,
            block_size: 5,
            ..EigenOptions::default()
        },
        EigenOptions {
            seed: 777,
            block_size: 11,
            max_dim: 60,
            ..EigenOptions::default()
        },
        // A subspace as large as the problem: the dense path.
        EigenOptions {
            max_dim: mesh.n_vertices(),
            ..EigenOptions::default()
        },
    ];
    let results: Vec<_> = runs
        .iter()
        .map(|o| generalized_eigen(&l, &m, k, o).unwrap())
        .collect();
    assert!(results[0].subspace_dim > 0 && results[2].subspace_dim > 0);
    assert_eq!(results[3].subspace_dim, 0, "expected the dense path");
    let reference = dense_values(&l, &m);
    // Simple eigenvalues (relative gaps well above the accuracy).
    for i in 1..k {
        let gap = (reference[i + 1] - reference[i]).min(reference[i] - reference[i - 1]);
        assert!(gap > 1e-3 * reference[i], "λ{i} is not simple: gap {gap}");
    }
    let base = &results[0];
    for (r, other) in results.iter().enumerate().skip(1) {
        let mut worst = 0.0f64;
        for j in 0..k {
            // Not up to sign: the vectors themselves agree.
            let d: f64 = (0..m.len())
                .map(|i| m[i] * (base.vectors[(i, j)] - other.vectors[(i, j)]).powi(2))
                .sum::<f64>()
                .sqrt();
            worst = worst.max(d);
        }
        eprintln!("run {r}: max ‖φ − φ'‖_M = {worst:.3e}");
        assert!(worst < 1e-6, "run {r}: max ‖φ − φ'‖_M = {worst:.3e}");
    }
    // The constant eigenvector (λ₀ = 0) is positive.
    assert!(base.vectors.column(0).iter().all(|&x| x > 0.0));
}

#[test]
fn canonical_sign_is_idempotent_and_sign_blind() {
    let mesh = asymmetric_sheet();
    let l = cotan_laplacian(&mesh);
    let m = mass_matrix(&mesh, MassKind::Voronoi);
    let eig = generalized_eigen(&l, &m, 8, &EigenOptions::default()).unwrap();
    let n = m.len();
    // Solver output is already canonical: canonicalising again changes nothing.
    let mut again = eig.vectors.clone();
    canonicalize_signs(&mut again, &m);
    assert!(
        again == eig.vectors,
        "canonicalising twice changed the vectors"
    );
    // Flipping any subset of columns gives back exactly the canonical vectors.
    let mut flipped = eig.vectors.clone();
    for j in (0..8).step_by(2) {
        flipped.column_mut(j).neg_mut();
    }
    canonicalize_signs(&mut flipped, &m);
    assert!(flipped == eig.vectors, "flipped columns did not come back");
    // Vectors built to defeat a "largest entry is positive" rule: two entries
    // of equal magnitude and opposite sign, and antisymmetric profiles.
    let mut x = DMatrix::<f64>::from_fn(n, 3, |i, j| match j {
        0 => (i as f64 * 0.37).sin(),
        1 => {
            if i == 3 {
                1.0
            } else if i == n - 4 {
                -1.0
            } else {
                0.0
            }
        }
        _ => i as f64 - (n as f64 - 1.0) / 2.0,
    });
    canonicalize_signs(&mut x, &m);
    let mut y = -x.clone();
    canonicalize_signs(&mut y, &m);
    assert!(x == y, "φ and −φ canonicalise differently");
    let mut z = x.clone();
    canonicalize_signs(&mut z, &m);
    assert!(x == z, "not idempotent");
    // A small perturbation does not change the chosen signs.
    let mut p = DMatrix::<f64>::from_fn(n, 3, |i, j| {
        x[(i, j)] * (1.0 + 1e-9 * ((i + j) as f64).cos())
    });
    canonicalize_signs(&mut p, &m);
    for j in 0..3 {
        assert!(p.column(j).dot(&x.column(j)) > 0.0, "column {j} flipped");
    }
}

//! Sparse Cholesky / LDLT: agreement with dense nalgebra Cholesky, residuals,
//! errors on bad input, symbolic reuse, inertia.

use deformlab::mesh::primitives::icosphere;
use deformlab::ops::{cotan_laplacian, mass_matrix, MassKind};
use deformlab::solve::{
    set_threads, sparse_diagonal, sparse_from_triplets, SparseCholesky, SparseLdlt, SparseMatrix,
    SymbolicCholesky,
};
use deformlab::Error;
use nalgebra::DMatrix;
use proptest::prelude::*;

fn to_dense(a: &SparseMatrix) -> DMatrix<f64> {
    let mut d = DMatrix::zeros(a.nrows(), a.ncols());
    for (i, j, &v) in a.triplet_iter() {
        d[(i, j)] += v;
    }
    d
}

fn add(a: &SparseMatrix, b: &SparseMatrix, s: f64) -> SparseMatrix {
    sparse_from_triplets(
        a.nrows(),
        a.ncols(),
        a.triplet_iter()
            .map(|(i, j, &v)| (i, j, v))
            .chain(b.triplet_iter().map(|(i, j, &v)| (i, j, s * v))),
    )
}

/// Sparse SPD matrix A = B Bᵀ + shift·I with B sparse (entries given).
fn spd_from(n: usize, entries: &[(usize, usize, f64)], shift: f64) -> SparseMatrix {
    let b = sparse_from_triplets(n, n, entries.iter().map(|&(i, j, v)| (i % n, j % n, v)));
    let bd = to_dense(&b);
    let a = &bd * bd.transpose() + DMatrix::identity(n, n) * shift;
    sparse_from_triplets(
        n,
        n,
        (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .filter(|&(i, j)| a[(i, j)] != 0.0)
            .map(|(i, j)| (i, j, a[(i, j)])),
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn matches_dense_cholesky(
        n in 1usize..40,
        entries in prop::collection::vec((0usize..40, 0usize..40, -2.0f64..2.0), 0..120),
        shift in 0.05f64..2.0,
        rhs in prop::collection::vec(-1.0f64..1.0, 120),
    ) {
        let a = spd_from(n, &entries, shift);
        let dense = to_dense(&a);
        let b = DMatrix::from_fn(n, 3, |i, j| rhs[(i * 3 + j) % rhs.len()]);
        let chol = SparseCholesky::new(&a).expect("SPD matrix must factorise");
        let x = chol.solve(&b);
        let x_dense = dense.clone().cholesky().expect("dense Cholesky").solve(&b);
        let scale = x_dense.abs().max().max(1.0);
        prop_assert!((&x - &x_dense).abs().max() < 1e-9 * scale,
            "sparse vs dense differ by {}", (&x - &x_dense).abs().max());
        let r = &dense * &x - &b;
        prop_assert!(r.abs().max() < 1e-10 * (dense.abs().max() * scale + 1.0));
        // LDLT agrees and reports all pivots positive.
        let ldlt = SparseLdlt::new(&a).unwrap();
        let y = ldlt.solve(&b).unwrap();
        prop_assert!((&y - &x_dense).abs().max() < 1e-9 * scale);
        prop_assert_eq!(ldlt.inertia().positive, n);
    }
}

#[test]
fn mesh_system_residual_and_solve_vec() {
    let mesh = icosphere(4);
    let n = mesh.n_vertices();
    let l = cotan_laplacian(&mesh);
    let m = mass_matrix(&mesh, MassKind::Voronoi);
    let a = add(&l, &sparse_diagonal(&m), 1e-3);
    let chol = SparseCholesky::new(&a).unwrap();
    let b: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 101) as f64 / 50.0 - 1.0)
        .collect();
    let x = chol.solve_vec(&b);
    let ax = &a * &nalgebra::DVector::from_vec(x.clone());
    let rel = (ax - nalgebra::DVector::from_vec(b.clone())).norm()
        / nalgebra::DVector::from_vec(b.clone()).norm();
    assert!(rel < 1e-10, "relative residual {rel}");
    // Multi-column solve equals column-wise solves.
    let bm = DMatrix::from_fn(n, 2, |i, j| b[i] * (j as f64 + 1.0));
    let xm = chol.solve(&bm);
    for i in 0..n {
        assert!((xm[(i, 1)] - 2.0 * x[i]).abs() < 1e-9 * (1.0 + x[i].abs()));
    }
    // Two threads give the same answer up to rounding.
    set_threads(2);
    let x2 = SparseCholesky::new(&a).unwrap().solve_vec(&b);
    set_threads(1);
    let diff = x
        .iter()
        .zip(&x2)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    assert!(diff < 1e-9, "threaded result differs by {diff}");
}

#[test]
fn symbolic_reuse_for_same_pattern() {
    let mesh = icosphere(2);
    let l = cotan_laplacian(&mesh);
    let m = sparse_diagonal(&mass_matrix(&mesh, MassKind::Voronoi));
    let a1 = add(&l, &m, 1.0);
    let a2 = add(&l, &m, 0.01);
    let sym = SymbolicCholesky::new(&a1).unwrap();
    for a in [&a1, &a2] {
        let x = sym.factorize(a).unwrap().solve_vec(&vec![1.0; a.nrows()]);
        let y = SparseCholesky::new(a)
            .unwrap()
            .solve_vec(&vec![1.0; a.nrows()]);
        let d = x
            .iter()
            .zip(&y)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        assert!(d < 1e-10);
    }
    // A matrix with another pattern is refused.
    let err = sym.factorize(&m).unwrap_err();
    assert!(matches!(err, Error::InvalidInput(_)), "{err}");
}

#[test]
fn bad_inputs_are_errors() {
    // Not square.
    let rect = sparse_from_triplets(2, 3, [(0, 0, 1.0)]);
    assert!(matches!(
        SparseCholesky::new(&rect),
        Err(Error::InvalidInput(_))
    ));
    // NaN entry.
    let nan = sparse_from_triplets(2, 2, [(0, 0, 1.0), (1, 1, f64::NAN)]);
    let e = SparseCholesky::new(&nan).unwrap_err();
    assert!(matches!(e, Error::InvalidInput(_)) && e.to_string().contains("not finite"));
    // Not symmetric.
    let asym = sparse_from_triplets(2, 2, [(0, 0, 2.0), (1, 1, 2.0), (0, 1, 1.0)]);
    assert!(matches!(
        SparseCholesky::new(&asym),
        Err(Error::InvalidInput(_))
    ));
    // Indefinite: diag(1, -1) — names the pivot of input row 1.
    let indef = sparse_diagonal(&[1.0, -1.0]);
    let e = SparseCholesky::new(&indef).unwrap_err();
    assert!(matches!(e, Error::Numerical(_)), "{e}");
    assert!(e.to_string().contains("not positive definite"), "{e}");
    assert!(e.to_string().contains("row/column 1"), "{e}");
    // Large indefinite mesh system L − 10·M (supernodal path).
    let mesh = icosphere(4);
    let l = cotan_laplacian(&mesh);
    let m = sparse_diagonal(&mass_matrix(&mesh, MassKind::Voronoi));
    let e = SparseCholesky::new(&add(&l, &m, -10.0)).unwrap_err();
    assert!(e.to_string().contains("not positive definite"), "{e}");
    // ... whose LDLT inertia counts the 16 eigenvalues 0, 2, 6, 6.. below 10:
    // l(l+1) < 10 for l = 0, 1, 2 → 1 + 3 + 5 = 9.
    let inertia = SparseLdlt::new(&add(&l, &m, -10.0)).unwrap().inertia();
    assert_eq!(inertia.negative, 9, "{inertia:?}");
    // Singular PSD (closed-mesh Laplacian): refused, not garbage.
    let l = cotan_laplacian(&icosphere(3));
    let e = SparseCholesky::new(&l).unwrap_err();
    assert!(matches!(e, Error::Numerical(_)), "{e}");
    // Wrong right-hand side length.
    let chol = SparseCholesky::new(&sparse_diagonal(&[2.0, 4.0])).unwrap();
    assert!(chol.try_solve_vec(&[1.0]).is_err());
    let x = chol.solve_vec(&[2.0, 4.0]);
    assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 1.0).abs() < 1e-15);
    // Empty.
    assert!(SparseCholesky::new(&sparse_from_triplets(0, 0, [])).is_err());
}

#[test]
fn ldlt_inertia_counts_eigenvalues_below_shift() {
    // diag(1..=10) − 4.5·I has 4 negative pivots.
    let d: Vec<f64> = (1..=10).map(|k| k as f64 - 4.5).collect();
    let mut t: Vec<(usize, usize, f64)> = d.iter().enumerate().map(|(i, &v)| (i, i, v)).collect();
    // Rotate a little so the matrix is not diagonal: symmetric coupling 0.01.
    for i in 0..9 {
        t.push((i, i + 1, 0.01));
        t.push((i + 1, i, 0.01));
    }
    let a = sparse_from_triplets(10, 10, t);
    let f = SparseLdlt::new(&a).unwrap();
    let inertia = f.inertia();
    assert_eq!((inertia.negative, inertia.positive), (4, 6));
}

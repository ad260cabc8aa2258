//! LBO weights, example-based dictionaries, k-medoids reduction and the
//! change of dictionaries (FBT Sec. 4.1, 4.4).

use deformlab::mesh::primitives::icosphere;
use deformlab::register::synthetic_class;
use deformlab::skin::dictionary::{
    laplacian_energy_matrix, Atom, Dictionary, DictionaryChange, SkinningWeights, WeightKind,
};
use deformlab::skin::lbo::lbo_basis;
use deformlab::skin::lbs::points_to_matrix;
use deformlab::solve::EigenOptions;
use nalgebra::DMatrix;

#[test]
fn lbo_eigenvectors_are_mass_orthonormal_and_match_their_laplacian_energy() {
    let sphere = icosphere(3);
    let b = lbo_basis(&sphere, 16, &EigenOptions::default()).unwrap();
    // WᵀMW/A = I, recomputed from the stored weights.
    let defect = b.orthonormality_defect();
    assert!(defect < 1e-9, "orthonormality defect {defect:e}");
    // w_0 is the constant 1 (area normalisation, positive sign).
    let c = b.weights.column(0);
    assert!(
        c.iter().all(|v| (v - 1.0).abs() < 1e-6),
        "w_0 not constant 1"
    );
    // Sphere spectrum of the unit-area surface: μ = A λ with λ = l(l+1)/R²
    // for R² = A/4π: μ_l = 4π l(l+1) (to discretisation accuracy: 3 % at
    // 642 vertices).
    for (k, l) in [(1, 1.0), (3, 1.0), (4, 2.0), (8, 2.0), (9, 3.0), (15, 3.0)] {
        let expect = 4.0 * std::f64::consts::PI * l * (l + 1.0);
        assert!(
            (b.values[k] / expect - 1.0).abs() < 0.03,
            "μ_{k} = {} vs {expect}",
            b.values[k]
        );
    }
    // Q_w = A WᵀLM⁻¹LW computed from the mesh equals diag(μ²) (Eq. 6).
    let q = laplacian_energy_matrix(&sphere, &b.weights).unwrap();
    let d = b.smoothness();
    let scale = d.max();
    assert!(
        (&q - &d).abs().max() < 1e-5 * scale,
        "{}",
        (&q - &d).abs().max() / scale
    );
    // The same holds on a creature mesh.
    let creature = &synthetic_class(1, 0).unwrap()[0];
    let b = lbo_basis(creature, 10, &EigenOptions::default()).unwrap();
    assert!(b.orthonormality_defect() < 1e-9);
    let q = laplacian_energy_matrix(creature, &b.weights).unwrap();
    assert!((&q - b.smoothness()).abs().max() < 1e-5 * b.smoothness().max());
}

#[test]
fn dictionary_atoms_reduction_and_change_of_dictionaries() {
    let meshes = synthetic_class(1, 0).unwrap();
    let examples = &meshes[1..4];
    let basis = lbo_basis(&examples[0], 6, &EigenOptions::default()).unwrap();
    let w = SkinningWeights::lbo(&basis);
    assert_eq!(w.kind, WeightKind::Lbo);
    let d = Dictionary::from_meshes(examples, &w).unwrap();
    let (n, m, q) = (examples[0].n_vertices(), 6, 3);
    assert_eq!(d.size(), (1 + 3 * q) * m);
    // Atom (ℓ, j, k) = w_j · (V_ℓ)_k.
    for (c, a) in d.info().iter().enumerate() {
        let i = (c * 37) % n;
        let expect = match *a {
            Atom::Translation { weight } => w.weights[(i, weight)],
            Atom::Example {
                example,
                weight,
                coord,
            } => w.weights[(i, weight)] * examples[example].vertices()[i][coord],
        };
        assert!((d.atoms()[(i, c)] - expect).abs() < 1e-12);
    }
    // Every example is in the span: M̂_0 = I on its block (w_0 ≡ 1).
    for (l, e) in examples.iter().enumerate() {
        let mut t = DMatrix::zeros(d.size(), 3);
        for k in 0..3 {
            t[(m + 3 * m * l + k, k)] = 1.0;
        }
        let v = d.apply(&t).unwrap();
        let err = (&v - points_to_matrix(e.vertices())).abs().max();
        assert!(err < 1e-6, "example {l}: {err:e}");
        // and least-squares projection finds it.
        let tp = d.project(e.vertices()).unwrap();
        let err = (d.apply(&tp).unwrap() - points_to_matrix(e.vertices()))
            .abs()
            .max();
        // (the 1e-10 relative ridge of the redundant normal equations costs ~1e-6)
        assert!(err < 1e-5, "projection of example {l}: {err:e}");
    }
    // Λ: block structure (zero across streams), diag(μ²) on streams.
    let lam = d.smoothness();
    assert_eq!(lam[(0, m)], 0.0);
    assert!((lam[(2, 2)] - basis.values[2].powi(2)).abs() < 1e-9 * lam[(2, 2)]);
    // k-medoids keeps translation atoms and original example atoms.
    let k = (d.size() - m) / 2;
    let (r, km) = d.reduce(k, 3).unwrap();
    assert_eq!(r.size(), m + k);
    assert!(km.loss <= km.build_loss + 1e-12);
    assert_eq!(
        r.info()
            .iter()
            .filter(|a| matches!(a, Atom::Translation { .. }))
            .count(),
        m
    );
    for (c, a) in r.info().iter().enumerate() {
        let orig = d.info().iter().position(|b| b == a).unwrap();
        assert_eq!(r.atoms().column(c), d.atoms().column(orig));
    }
    // Eq. 24: the reduced dictionary's span is inside the full one, so the
    // change reduced → full represents a shape exactly …
    let t_red = DMatrix::from_fn(r.size(), 3, |i, j| ((i * 3 + j * 5) % 7) as f64 * 0.01);
    let shape = r.apply(&t_red).unwrap();
    let up = DictionaryChange::new(&r, &d).unwrap();
    let back = d.apply(&up.apply(&t_red).unwrap()).unwrap();
    let rel = (&back - &shape).norm() / shape.norm();
    assert!(rel < 1e-6, "reduced → full: {rel:e}");
    // … and full → reduced is the least-squares projection: its residual
    // is orthogonal to the reduced atoms.
    let t_full = DMatrix::from_fn(d.size(), 3, |i, j| ((i * 7 + j) % 5) as f64 * 0.01);
    let s = d.apply(&t_full).unwrap();
    let down = DictionaryChange::new(&d, &r).unwrap();
    let resid = r.apply(&down.apply(&t_full).unwrap()).unwrap() - &s;
    let g = r.atoms().transpose() * resid;
    assert!(
        g.abs().max() < 1e-6 * (r.atoms().norm() * s.norm()),
        "{}",
        g.abs().max()
    );
}

#[test]
fn skeleton_weights_are_a_smooth_partition_of_unity() {
    let meshes = synthetic_class(1, 0).unwrap();
    let opts = deformlab::skin::rigging::RigOptions {
        bones: Some(12),
        ..Default::default()
    };
    let (w, rig) = SkinningWeights::skeleton(&meshes[0], &meshes[1..6], &opts).unwrap();
    assert_eq!(rig.bones(), 12);
    assert_eq!(w.weights.ncols(), 12);
    for row in w.weights.row_iter() {
        assert!((row.sum() - 1.0).abs() < 1e-9);
        assert!(row.iter().all(|&x| (0.0..=1.0 + 1e-12).contains(&x)));
    }
    // Smoothness matrix is symmetric positive semi-definite and constant
    // functions (Σ_j w_j = 1) have zero Laplacian energy.
    let q = &w.smoothness;
    assert!((q - q.transpose()).abs().max() < 1e-9 * q.abs().max());
    let ones = DMatrix::from_element(12, 1, 1.0);
    let e = (ones.transpose() * q * &ones)[(0, 0)];
    assert!(e.abs() < 1e-8 * q.trace(), "energy of the constant {e}");
    let clusters = w.rotation_clusters(8, 1).unwrap();
    assert_eq!(clusters.iter().max(), Some(&7));
}

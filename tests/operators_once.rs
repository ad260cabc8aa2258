//! The per-mesh operators (cotangent Laplacian, mass, edge weights,
//! adjacency) are computed once per mesh ([`Operators`]): the memoised
//! values equal fresh computations, clones share them, a deformed copy
//! recomputes its geometry but not its connectivity, and one case of an
//! FBT completion and of a BDT transfer computes each operator at most once
//! per mesh it uses. The counters are process-wide, so everything runs in
//! one test, in order.

mod common;

use common::{quiet_run, tiny_bdt, tiny_fbt_completion, write};
use deformlab::experiment::run_configs;
use deformlab::mesh::primitives::icosphere;
use deformlab::ops::{
    computations, cotan_laplacian, mass_matrix, vertex_neighbours, Computations, MassKind,
    Operators,
};

fn run_one(toml: &str) -> Computations {
    let t = tempfile::tempdir().unwrap();
    let cfg = write(t.path(), "c.toml", toml);
    let opts = quiet_run(t.path().join("results"), 1);
    let before = computations();
    let s = run_configs(std::slice::from_ref(&cfg), &opts).unwrap();
    assert_eq!(s[0].failed, 0);
    let after = computations();
    Computations {
        laplacian: after.laplacian - before.laplacian,
        mass: after.mass - before.mass,
        edge_weights: after.edge_weights - before.edge_weights,
        neighbours: after.neighbours - before.neighbours,
        incident_faces: after.incident_faces - before.incident_faces,
    }
}

#[test]
fn operators_are_computed_once_per_mesh() {
    let s = icosphere(2);
    let c0 = computations();
    let l = s.laplacian();
    assert_eq!(*l, cotan_laplacian(&s));
    assert_eq!(
        *s.mass(MassKind::Voronoi),
        mass_matrix(&s, MassKind::Voronoi)
    );
    assert_eq!(*s.neighbours(), vertex_neighbours(&s));
    let c1 = computations();
    // Asking again, from the mesh or a clone: nothing is computed.
    let clone = s.clone();
    for m in [&s, &clone] {
        assert_eq!(*m.laplacian(), *l);
        m.mass(MassKind::Voronoi);
        m.neighbours();
    }
    assert_eq!(computations(), c1);
    assert!(c1.laplacian > c0.laplacian);
    // A deformed copy: a new Laplacian, the same 1-ring.
    let moved = s.map_vertices(|p| p * 2.0).unwrap();
    let l2 = moved.laplacian();
    moved.neighbours();
    let c2 = computations();
    assert_eq!(c2.laplacian, c1.laplacian + 1);
    assert_eq!(c2.neighbours, c1.neighbours);
    // Cotangents do not change under a uniform scaling: nor does L.
    assert!((&*l2 - &*l).triplet_iter().all(|(_, _, v)| v.abs() < 1e-12));

    // One case each, one thread. Each operator once per mesh it is needed
    // on: FBT completion: the Laplacian of the reference (its LBO basis),
    // the mass of the reference and of the partial target, their 1-rings.
    // BDT: the Laplacian, mass and edge weights of the normalised source
    // (shared by the key point selection and the fit, which normalise it
    // by the same similarity) and of the normalised target. Before the
    // operators were kept with the mesh the same cases computed FBT
    // (laplacian, mass, edge weights, 1-rings) = (2, 7, 3, 30) and BDT
    // (3, 3, 9, 4).
    let fbt = run_one(&tiny_fbt_completion("fbt-once", 4, "[3]"));
    let bdt = run_one(&tiny_bdt("bdt-once", "[1]", false));
    eprintln!("FBT completion case: {fbt:?}\nBDT transfer case: {bdt:?}");
    let most = |laplacian, mass, edge_weights, neighbours| Computations {
        laplacian,
        mass,
        edge_weights,
        neighbours,
        incident_faces: 0,
    };
    let within = |c: Computations, m: Computations| {
        c.laplacian <= m.laplacian
            && c.mass <= m.mass
            && c.edge_weights <= m.edge_weights
            && c.neighbours <= m.neighbours
            && c.incident_faces <= m.incident_faces
    };
    assert!(within(fbt, most(1, 2, 1, 2)), "FBT: {fbt:?}");
    assert!(within(bdt, most(2, 2, 2, 2)), "BDT: {bdt:?}");
    assert!(fbt.laplacian >= 1 && bdt.laplacian >= 2, "{fbt:?} {bdt:?}");
}

//! Mesh sets: shared connectivity, per-face winding differences, adopting
//! one consistently wound face list.

use deformlab::data::shared_data_or_skip;
use deformlab::mesh::io::read_mesh;
use deformlab::mesh::primitives::{icosphere, torus};
use deformlab::mesh::set::{adopt_consistent_faces, compare_faces, ConnectivityReport, FaceMatch};
use deformlab::mesh::validate::DefectReport;
use deformlab::mesh::Mesh;

fn reversed(m: &Mesh, which: impl Fn(usize) -> bool) -> Mesh {
    let faces = m
        .faces()
        .iter()
        .enumerate()
        .map(|(i, &[a, b, c])| if which(i) { [a, c, b] } else { [a, b, c] })
        .collect();
    m.with_faces(faces).unwrap()
}

#[test]
fn face_comparison() {
    assert_eq!(compare_faces([1, 2, 3], [1, 2, 3]), FaceMatch::Same);
    assert_eq!(compare_faces([2, 3, 1], [1, 2, 3]), FaceMatch::Same);
    assert_eq!(compare_faces([3, 2, 1], [1, 2, 3]), FaceMatch::Reversed);
    assert_eq!(compare_faces([1, 3, 2], [1, 2, 3]), FaceMatch::Reversed);
    assert_eq!(compare_faces([1, 2, 4], [1, 2, 3]), FaceMatch::Different);
}

#[test]
fn shared_connectivity_with_reversed_faces() {
    let a = icosphere(2);
    let b = a.map_vertices(|p| p * 2.0).unwrap();
    let c = reversed(&a.map_vertices(|p| p * 0.5).unwrap(), |i| i % 10 == 3);
    let set = [a.clone(), b, c];
    let r = ConnectivityReport::of(&set);
    assert!(r.shared() && !r.identical(), "{r}");
    assert_eq!(r.meshes[1].reversed_faces.count, 0);
    assert_eq!(r.meshes[2].reversed_faces.count, a.n_faces() / 10);
    assert_eq!(r.meshes[2].reversed_faces.first[..3], [3, 13, 23]);
    assert_eq!(r.meshes[2].same_faces, a.n_faces() - a.n_faces() / 10);
    let s = r.to_string();
    assert!(
        s.contains("winding differs") && s.contains("first reversed faces [3, 13, 23"),
        "{s}"
    );

    // Adopt: the first mesh is consistent, so its faces win.
    let (k, adopted) = adopt_consistent_faces(&set).unwrap();
    assert_eq!(k, 0);
    assert!(ConnectivityReport::of(&adopted).identical());
    assert_eq!(adopted[2].vertices(), set[2].vertices());
    assert!(DefectReport::of_mesh(&adopted[2]).is_clean());

    // With the inconsistent mesh first, the next consistent one is adopted.
    let set = [set[2].clone(), set[0].clone()];
    let (k, adopted) = adopt_consistent_faces(&set).unwrap();
    assert_eq!(k, 1);
    assert_eq!(adopted[0].faces(), set[1].faces());
}

#[test]
fn different_connectivity_is_reported() {
    let a = icosphere(1);
    let t = torus(1.0, 0.3, 6, 7);
    // Same vertex count (42), different triples.
    assert_eq!(a.n_vertices(), t.n_vertices());
    let b = icosphere(2);
    let mut faces = a.faces().to_vec();
    faces.swap(0, 5);
    let shuffled = a.with_faces(faces).unwrap();
    let set = [a.clone(), t, b, shuffled];
    let r = ConnectivityReport::of(&set);
    assert!(!r.shared());
    assert!(r.meshes[1].different_faces.count > 0);
    assert!(r.meshes[2].n_vertices != r.meshes[0].n_vertices);
    assert_eq!(r.meshes[3].different_faces.count, 2);
    assert_eq!(r.meshes[3].different_faces.first, vec![0, 5]);
    let s = r.to_string();
    assert!(
        s.contains("NOT shared") && s.contains("vertex count differs from 42"),
        "{s}"
    );
    let e = adopt_consistent_faces(&set).unwrap_err().to_string();
    assert!(e.contains("do not share connectivity"), "{e}");
    assert!(adopt_consistent_faces(&[]).is_err());

    // No consistently wound member.
    let bad = reversed(&a, |i| i == 0);
    let e = adopt_consistent_faces(&[bad.clone(), bad])
        .unwrap_err()
        .to_string();
    assert!(e.contains("consistently wound"), "{e}");
}

#[test]
fn tosca_centaur3_reverses_376_faces() {
    let Some(dir) = shared_data_or_skip("tosca", "tosca_centaur3_reverses_376_faces") else {
        return;
    };
    let names = ["centaur0", "centaur1", "centaur2", "centaur3", "centaur5"];
    let set: Vec<Mesh> = names
        .iter()
        .map(|n| read_mesh(&dir.join(format!("{n}.off"))).unwrap())
        .collect();
    let r = ConnectivityReport::of(&set);
    println!("{r}");
    assert!(r.shared());
    for (i, m) in r.meshes.iter().enumerate() {
        let want = if names[i] == "centaur3" { 376 } else { 0 };
        assert_eq!(m.reversed_faces.count, want, "{}", names[i]);
        assert_eq!(m.different_faces.count, 0);
    }
    // Within centaur3, the reversed patch is found as the fewest flips.
    let d = DefectReport::of_mesh(&set[3]);
    assert_eq!(d.components[0].faces_to_flip, Some(376));
    let (k, adopted) = adopt_consistent_faces(&set).unwrap();
    assert_eq!(k, 0);
    assert!(ConnectivityReport::of(&adopted).identical());
    assert!(DefectReport::of_mesh(&adopted[3]).is_clean());
}

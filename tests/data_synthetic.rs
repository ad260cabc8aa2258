//! Synthetic FAUST-style generator: mesh validity, shared connectivity,
//! subject and pose differences, determinism, labels, remesh map.

use std::collections::HashSet;
use std::path::Path;
use std::time::Instant;

use deformlab::data::synthetic::{self, body, FaustStyle};
use deformlab::mesh::Mesh;
use deformlab::ops::face_areas;

fn small(seed: u64) -> FaustStyle {
    FaustStyle {
        subjects: 2,
        poses: 3,
        seed,
        ..FaustStyle::default()
    }
}

/// Every directed edge once and its reverse present: closed, manifold,
/// consistently oriented. Also Euler characteristic 2 (genus 0).
fn assert_closed_oriented(m: &Mesh, what: &str) {
    let mut directed = HashSet::new();
    for f in m.faces() {
        assert!(
            f[0] != f[1] && f[1] != f[2] && f[0] != f[2],
            "{what}: repeated index"
        );
        for k in 0..3 {
            assert!(
                directed.insert((f[k], f[(k + 1) % 3])),
                "{what}: directed edge twice"
            );
        }
    }
    for &(a, b) in &directed {
        assert!(directed.contains(&(b, a)), "{what}: boundary edge {a}-{b}");
    }
    let (v, e, f) = (
        m.n_vertices() as i64,
        directed.len() as i64 / 2,
        m.n_faces() as i64,
    );
    assert_eq!(v - e + f, 2, "{what}: Euler characteristic");
}

fn min_area_ratio(m: &Mesh) -> f64 {
    let a = face_areas(m);
    let mean = a.iter().sum::<f64>() / a.len() as f64;
    a.iter().cloned().fold(f64::INFINITY, f64::min) / mean
}

/// Smallest cosine between the normals of two faces sharing an edge (−1 for
/// a fold-over).
fn min_dihedral_cos(m: &Mesh) -> f64 {
    let v = m.vertices();
    let n: Vec<_> = m
        .faces()
        .iter()
        .map(|f| (v[f[1]] - v[f[0]]).cross(&(v[f[2]] - v[f[0]])).normalize())
        .collect();
    let mut by_edge = std::collections::HashMap::new();
    for (fi, f) in m.faces().iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            by_edge
                .entry((a.min(b), a.max(b)))
                .or_insert_with(Vec::new)
                .push(fi);
        }
    }
    by_edge
        .values()
        .map(|fs| n[fs[0]].dot(&n[fs[1]]))
        .fold(1.0, f64::min)
}

#[test]
fn meshes_are_closed_manifold_well_shaped_and_share_faces() {
    let set = small(3).generate().unwrap();
    let n = set.n_vertices();
    assert!((4000..=8000).contains(&n), "vertex count {n}");
    assert_closed_oriented(&set.rest[0], "rest 0");
    for (s, poses) in set.meshes.iter().enumerate() {
        for (p, m) in poses.iter().enumerate() {
            assert_eq!(m.faces(), set.faces(), "subject {s} pose {p}: faces differ");
            let r = min_area_ratio(m);
            assert!(r > 0.02, "subject {s} pose {p}: min/mean face area {r}");
            let c = min_dihedral_cos(m);
            assert!(
                c > -0.5,
                "subject {s} pose {p}: fold-over, min dihedral cos {c}"
            );
        }
    }
    // Outward orientation: positive signed volume.
    let v = set.rest[0].vertices();
    let vol: f64 = set
        .faces()
        .iter()
        .map(|f| v[f[0]].coords.dot(&v[f[1]].coords.cross(&v[f[2]].coords)) / 6.0)
        .sum();
    assert!(vol > 0.0, "inward-facing mesh, volume {vol}");
}

#[test]
fn all_table_poses_stay_valid() {
    let set = FaustStyle {
        subjects: 1,
        poses: 1,
        seed: 5,
        ..FaustStyle::default()
    }
    .generate()
    .unwrap();
    for p in 0..synthetic::pose::N_POSES {
        let m = set.posed(0, p).unwrap();
        let r = min_area_ratio(&m);
        let c = min_dihedral_cos(&m);
        assert!(
            r > 0.02 && c > -0.5,
            "pose {p}: area ratio {r}, dihedral cos {c}"
        );
    }
    assert!(set.posed(1, 0).is_err());
    assert!(set.posed(0, synthetic::pose::N_POSES).is_err());
}

#[test]
fn subjects_differ_and_poses_differ_from_rest() {
    let set = small(3).generate().unwrap();
    let (a, b) = (&set.proportions[0], &set.proportions[1]);
    let ratio = |p: &body::Proportions| {
        (p.upper_arm_length + p.forearm_length) / (p.thigh_length + p.shin_length)
    };
    assert!(
        (ratio(a) - ratio(b)).abs() > 1e-3,
        "arm/leg ratio {} vs {}",
        ratio(a),
        ratio(b)
    );
    let rms = |x: &Mesh, y: &Mesh| {
        (x.vertices()
            .iter()
            .zip(y.vertices())
            .map(|(p, q)| (p - q).norm_squared())
            .sum::<f64>()
            / x.n_vertices() as f64)
            .sqrt()
    };
    // Same pose, different subjects: different shapes.
    for p in 0..3 {
        assert!(rms(&set.meshes[0][p], &set.meshes[1][p]) > 0.01);
    }
    // Every pose differs from the rest pose (> 5 cm RMS).
    for s in 0..2 {
        for p in 0..3 {
            let d = rms(&set.meshes[s][p], &set.rest[s]);
            assert!(d > 0.05, "subject {s} pose {p} rms from rest {d}");
        }
    }
    // Measured limb lengths on the mesh follow the proportions: the left
    // forearm+hand bone has different length across subjects.
    let len = |s: usize| {
        let v = set.rest[s].vertices();
        let xs = v.iter().map(|p| p.x).fold(f64::MIN, f64::max);
        let ys = v.iter().map(|p| p.y).fold(f64::MIN, f64::max);
        (xs, ys)
    };
    assert_ne!(len(0), len(1));
}

#[test]
fn labels_cover_all_bones_and_weights_sum_to_one() {
    let set = small(1).generate().unwrap();
    assert_eq!(set.labels.len(), set.n_vertices());
    let used: HashSet<usize> = set.labels.iter().copied().collect();
    assert_eq!(used.len(), set.bone_names.len(), "bones used: {used:?}");
    for w in &set.weights {
        let s: f64 = w.iter().sum();
        assert!((s - 1.0).abs() < 1e-9 && w.iter().all(|&x| x >= -1e-12));
    }
    let no_tail = FaustStyle {
        tail: false,
        ..small(1)
    }
    .generate()
    .unwrap();
    assert_eq!(no_tail.bone_names.len(), 11);
    let used: HashSet<usize> = no_tail.labels.iter().copied().collect();
    assert_eq!(used.len(), 11);
    assert!(no_tail.n_vertices() >= 4000 && no_tail.n_vertices() < set.n_vertices());
    assert_closed_oriented(&no_tail.rest[0], "no tail");
}

fn read_all(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().display().to_string();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn same_seed_gives_identical_files_other_seed_differs() {
    let (t1, t2, t3) = (
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
    );
    synthetic::write_all(t1.path(), &small(42)).unwrap();
    synthetic::write_all(t2.path(), &small(42)).unwrap();
    synthetic::write_all(t3.path(), &small(43)).unwrap();
    let (a, b, c) = (
        read_all(t1.path()),
        read_all(t2.path()),
        read_all(t3.path()),
    );
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.0, y.0);
        assert!(
            x.1 == y.1,
            "{} differs between runs with the same seed",
            x.0
        );
    }
    let names: Vec<&str> = a.iter().map(|x| x.0.as_str()).collect();
    for want in [
        "faust/tr_reg_000.ply",
        "faust/tr_reg_012.ply",
        "faust/labels.csv",
        "faust/synthetic.json",
        "faust/rest/subject_01.ply",
        "tosca/creature0.off",
        "tosca/creature4.ply",
        "tosca/creature10.off",
        "remesh/map.csv",
        "remesh/remesh_rest.ply",
        "remesh/remesh_002.ply",
    ] {
        assert!(names.contains(&want), "{want} missing from {names:?}");
    }
    let get = |v: &[(String, Vec<u8>)], n: &str| v.iter().find(|x| x.0 == n).unwrap().1.clone();
    assert_ne!(
        get(&a, "faust/tr_reg_011.ply"),
        get(&c, "faust/tr_reg_011.ply")
    );
    // Subject proportions are in the metadata and differ with the seed.
    let meta = |v: &[(String, Vec<u8>)]| -> serde_json::Value {
        serde_json::from_slice(&get(v, "faust/synthetic.json")).unwrap()
    };
    let (ma, mc) = (meta(&a), meta(&c));
    assert_eq!(ma["n_vertices"], 6722);
    assert_eq!(ma["files"].as_array().unwrap().len(), 6);
    assert_ne!(ma["proportions"], mc["proportions"]);
}

#[test]
fn remesh_map_reconstructs_vertices() {
    let set = small(2).generate().unwrap();
    let rm = set.remesh(0.8).unwrap();
    let n = rm.mesh.n_vertices();
    assert!(n != set.n_vertices() && n > 4000, "remesh has {n} vertices");
    assert_closed_oriented(&rm.mesh, "remesh");
    assert!(
        min_area_ratio(&rm.mesh) > 0.01,
        "remesh min area ratio {}",
        min_area_ratio(&rm.mesh)
    );
    // Written and read back, the map reconstructs the remesh to 1e-9 by
    // barycentric interpolation on the original rest mesh…
    let dir = tempfile::tempdir().unwrap();
    synthetic::write_remeshed(dir.path(), &set, &rm).unwrap();
    let map = synthetic::read_remesh_map(&dir.path().join("map.csv")).unwrap();
    assert_eq!(map.len(), n);
    let mut max_err: f64 = 0.0;
    for (sp, p) in map.iter().zip(rm.mesh.vertices()) {
        let q = sp.eval(&set.rest[0]).unwrap();
        max_err = max_err.max((q - p).norm());
        assert!((sp.bary.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
    assert!(max_err < 1e-9, "max reconstruction error {max_err}");
    // …and transfers the poses: posed remesh vertices lie on the posed
    // original, and the remesh is not just the original vertex subset.
    let posed = rm.transfer(&set.meshes[0][1]).unwrap();
    assert_eq!(posed.faces(), rm.mesh.faces());
    let on_vertex = map.iter().filter(|s| s.bary.contains(&1.0)).count();
    assert!(
        on_vertex < n / 2,
        "{on_vertex} of {n} remesh vertices are original vertices"
    );
}

/// Writes the default set to `DEFORMLAB_GEN_OUT` (or a temp dir) and prints
/// the time: `cargo test --release --test data_synthetic -- --ignored --nocapture`.
#[test]
#[ignore]
fn gen_timing() {
    let out = std::env::var_os("DEFORMLAB_GEN_OUT")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("deformlab_gen"));
    let t = Instant::now();
    let set = FaustStyle::default().generate().unwrap();
    let t_gen = t.elapsed();
    let t = Instant::now();
    let s = synthetic::write_all(&out, &FaustStyle::default()).unwrap();
    println!(
        "generate (in memory) {:.3}s; write_all (generate + remesh + write) {:.3}s; {} meshes x {} v / {} f; remesh {} v / {} f; out {}",
        t_gen.as_secs_f64(),
        t.elapsed().as_secs_f64(),
        s.n_meshes,
        s.n_vertices,
        s.n_faces,
        s.remesh_vertices,
        s.remesh_faces,
        out.display()
    );
    assert_eq!(set.n_vertices(), s.n_vertices);
}

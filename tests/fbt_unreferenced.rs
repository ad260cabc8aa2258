//! A TOSCA-style class whose meshes carry unreferenced vertices and a tiny
//! disconnected part registers: the solve drops them (the same vertices in
//! every shape) and `cases.csv` says how many.

mod common;

use common::{csv_rows as rows, write};
use deformlab::experiment::{run_configs, RunOptions};
use deformlab::mesh::io::write_off;
use deformlab::{Mesh, Point};

/// `m` with `extra` unreferenced vertices and a small tetrahedron appended.
fn with_debris(m: &Mesh, extra: usize) -> Mesh {
    let mut v = m.vertices().to_vec();
    let mut f = m.faces().to_vec();
    for k in 0..extra {
        let s = k as f64 * 0.01;
        v.push(Point::new(s, -s, 2.0 * s));
    }
    let b = v.len();
    let c = Point::new(5.0, 5.0, 5.0);
    for d in [
        [0.0, 0.0, 0.0],
        [0.01, 0.0, 0.0],
        [0.0, 0.01, 0.0],
        [0.0, 0.0, 0.01],
    ] {
        v.push(Point::new(c.x + d[0], c.y + d[1], c.z + d[2]));
    }
    f.extend([
        [b, b + 2, b + 1],
        [b, b + 1, b + 3],
        [b, b + 3, b + 2],
        [b + 1, b + 2, b + 3],
    ]);
    Mesh::new(v, f).unwrap()
}

#[test]
fn a_class_with_unreferenced_vertices_and_loose_parts_completes() {
    let t = tempfile::tempdir().unwrap();
    let dir = t.path().join("tosca");
    std::fs::create_dir_all(&dir).unwrap();
    let class = deformlab::register::synthetic_class(1, 0).unwrap();
    for (i, m) in class.iter().take(7).enumerate() {
        write_off(&dir.join(format!("beast{i}.off")), &with_debris(m, 50)).unwrap();
    }
    let cfg = write(
        t.path(),
        "debris.toml",
        r#"
name = "debris"
seed = 0
[dataset.tosca]
path = "tosca"
[cases]
targets = []
include_self = true
per_pose = true
reference_pose = 0
poses = [5]
[[methods]]
name = "completion"
kind = "fbt"
fbt = { task = "completion", q = 2, nicp_iterations = 2, queries = 50 }
[[methods]]
name = "projection"
kind = "fbt"
fbt = { task = "projection", q = 2 }
"#,
    );
    let out = t.path().join("results");
    let opts = RunOptions {
        out: out.clone(),
        threads: 1,
        shard: None,
        plots: false,
        progress: false,
        max_new: None,
        wait: true,
        defects: Default::default(),
        load: Default::default(),
        force: false,
        retry_failed: false,
    };
    let s = run_configs(std::slice::from_ref(&cfg), &opts).unwrap();
    assert_eq!(s[0].failed, 0, "a method failed on the class with debris");
    for r in rows(&out.join("debris").join("cases.csv")) {
        assert_eq!(r["status"], "ok");
        assert_eq!(r["dropped_vertices"], "54", "{}", r["method"]);
        assert!(r["dropped_note"].contains("50 unreferenced"));
        assert_eq!(r["n_vertices"], class[0].n_vertices().to_string());
        let d: f64 = r["rel_distortion_mean"].parse().unwrap();
        assert!(d.is_finite() && d < 0.05, "{}: {d}", r["method"]);
    }
}

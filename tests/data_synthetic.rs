//! Synthetic FAUST-style generator: mesh validity, shared connectivity,
//! subject and pose differences, determinism, labels, remesh map.

use std::collections::{HashMap, HashSet};
use std::time::Instant;

use deformlab::data::synthetic::{self, FaustStyle, SyntheticSet};
use deformlab::mesh::Mesh;

fn small() -> FaustStyle {
    FaustStyle {
        subjects: 2,
        poses: 3,
        seed: 11,
        ..FaustStyle::default()
    }
}

/// Writes the default set to `DEFORMLAB_GEN_OUT` (or a temp dir) and prints
/// the time: `cargo test --test data_synthetic -- --ignored --nocapture`.
#[test]
#[ignore]
fn gen_timing() {
    let out = std::env::var_os("DEFORMLAB_GEN_OUT")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("deformlab_gen"));
    let t = Instant::now();
    let set = FaustStyle::default().generate().unwrap();
    let t_gen = t.elapsed();
    let s = synthetic::write_all(&out, &FaustStyle::default()).unwrap();
    println!(
        "generate (in memory) {:.3}s; write_all {:.3}s; {} meshes x {} v / {} f; remesh {} v / {} f; out {}",
        t_gen.as_secs_f64(),
        t.elapsed().as_secs_f64() - t_gen.as_secs_f64(),
        s.n_meshes,
        s.n_vertices,
        s.n_faces,
        s.remesh_vertices,
        s.remesh_faces,
        out.display()
    );
    assert_eq!(set.n_vertices(), s.n_vertices);
}

//! Consistent winding at load (issue 16): the dataset serves every mesh of a
//! subject with the subject's consistently wound face list, for every method
//! kind, and reports each repair (warning line + manifest.json).

mod common;

use std::path::Path;

use common::{csv_rows, ok, tmp, write};
use deformlab::data::shared_data_or_skip;
use deformlab::data::synthetic::FaustStyle;
use deformlab::experiment::{load_config, Collection};
use deformlab::mesh::io::write_ply;
use deformlab::mesh::Mesh;

/// Faces reversed in the planted mesh: every 7th.
fn reverse_some(m: &Mesh) -> (Mesh, usize) {
    let mut n = 0;
    let faces = m
        .faces()
        .iter()
        .enumerate()
        .map(|(i, &[a, b, c])| {
            if i % 7 == 0 {
                n += 1;
                [a, c, b]
            } else {
                [a, b, c]
            }
        })
        .collect();
    (m.with_faces(faces).unwrap(), n)
}

const BDT: &str = r#"
name = "winding"
seed = 1

[dataset.faust]
path = "faust"

[cases]
sources = [0]
targets = [1]

[defaults]
mode = "fast"
n_candidates = 8
error_norm = "rms"
epsilon = 0.0
max_keypoints = 4
max_swap_passes = 0

[[methods]]
name = "automatic"
kind = "bdt"

[[methods]]
name = "identity"
kind = "identity"
"#;

/// A FAUST-style folder of 2 subjects × 3 poses whose subject 0 pose 0 (the
/// reference `A` of the cases) has some faces reversed; returns the number
/// reversed.
fn planted_folder(dir: &Path) -> usize {
    let set = FaustStyle {
        subjects: 2,
        poses: 3,
        resolution: 1,
        ..Default::default()
    }
    .generate()
    .unwrap();
    let faust = dir.join("faust");
    std::fs::create_dir_all(&faust).unwrap();
    let mut flipped = 0;
    for (s, poses) in set.meshes.iter().enumerate() {
        for (p, m) in poses.iter().enumerate() {
            let path = faust.join(format!("tr_reg_{:03}.ply", 10 * s + p));
            if (s, p) == (0, 0) {
                let (bad, n) = reverse_some(m);
                flipped = n;
                write_ply(&path, &bad).unwrap();
            } else {
                write_ply(&path, m).unwrap();
            }
        }
    }
    flipped
}

#[test]
fn a_mesh_with_reversed_faces_loads_repaired_and_bdt_runs() {
    let d = tmp();
    let flipped = planted_folder(d.path());
    assert!(flipped > 10);
    let cfg = write(d.path(), "winding.toml", BDT);

    // Library: served with the subject's consistent face list.
    let l = load_config(&cfg).unwrap();
    let col = Collection::open(&l).unwrap();
    let a0 = col.mesh("0", "0").unwrap();
    let a1 = col.mesh("0", "1").unwrap();
    let a2 = col.mesh("0", "2").unwrap();
    assert_eq!(a0.faces(), a1.faces());
    assert_eq!(a0.faces(), a2.faces());
    // Subject 1 had nothing to repair and shares the synthetic faces.
    assert_eq!(col.mesh("1", "0").unwrap().faces(), a1.faces());
    let r = col.repairs();
    assert_eq!(r.len(), 1, "{r:?}");
    assert_eq!(r[0].file, "tr_reg_000.ply");
    assert_eq!(r[0].from_pose, "1");
    assert_eq!(r[0].flipped, flipped);
    assert_eq!(r[0].faces, a0.n_faces());

    // A BDT run on the folder: succeeds, warns once, records the repair.
    let out_dir = d.path().join("out");
    let o = ok(&[
        "run".as_ref(),
        cfg.as_os_str(),
        "--out".as_ref(),
        out_dir.as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    let warn: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("warning: tr_reg_000.ply"))
        .collect();
    assert_eq!(warn.len(), 1, "{err}");
    assert!(warn[0].contains(&format!("{flipped} of")), "{}", warn[0]);
    let run_dir = out_dir.join("winding");
    let rows = csv_rows(&run_dir.join("cases.csv"));
    assert_eq!(rows.len(), 2);
    assert!(rows.iter().all(|r| r["status"] == "ok"), "{rows:?}");
    let manifest = std::fs::read_to_string(run_dir.join("manifest.json")).unwrap();
    assert!(
        manifest.contains("tr_reg_000.ply") && manifest.contains("flipped at load"),
        "{manifest}"
    );
}

#[test]
fn bdt_runs_on_tosca_centaurs_including_centaur3() {
    let Some(tosca) = shared_data_or_skip("tosca", "bdt_runs_on_tosca_centaurs_including_centaur3")
    else {
        return;
    };
    if !tosca.join("centaur3.off").exists() {
        eprintln!("SKIP bdt_runs_on_tosca_centaurs_including_centaur3: no centaur3.off");
        return;
    }
    // The config lives in a temporary folder: name the data absolutely.
    let tosca = std::fs::canonicalize(&tosca).unwrap();
    let d = tmp();
    let text = format!(
        r#"
name = "centaur"
seed = 1

[dataset.tosca]
path = "{}"
classes = ["centaur"]

[cases]
targets = []
include_self = true
reference_pose = 0
poses = [1, 3]

[defaults]
mode = "fast"
n_candidates = 8
error_norm = "rms"
epsilon = 0.0
max_keypoints = 4
max_swap_passes = 0

[[methods]]
name = "automatic"
kind = "bdt"
"#,
        tosca.display()
    );
    let cfg = write(d.path(), "centaur.toml", text);
    let out_dir = d.path().join("out");
    let o = ok(&[
        "run".as_ref(),
        cfg.as_os_str(),
        "--out".as_ref(),
        out_dir.as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.lines()
            .any(|l| l.starts_with("warning: centaur3.off: 376 of")),
        "{err}"
    );
    let rows = csv_rows(&out_dir.join("centaur").join("cases.csv"));
    assert!(!rows.is_empty());
    for r in &rows {
        assert_eq!(r["status"], "ok", "{r:?}");
        assert!(!r["err_mean_area"].is_empty() && !r["edge_strain_p99"].is_empty());
    }
}

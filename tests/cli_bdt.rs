//! End-to-end runs of `deformlab gen → keypoints → transfer` on a tiny
//! synthetic set, and bad input.

mod common;

use std::path::Path;

use common::{deformlab, stdout_ok as ok};
use deformlab::mesh::io::read_mesh;

fn gen(dir: &Path) -> std::path::PathBuf {
    let out = deformlab()
        .args([
            "gen",
            "--subjects",
            "2",
            "--poses",
            "3",
            "--resolution",
            "1",
            "--seed",
            "3",
            "--out",
        ])
        .arg(dir)
        .output()
        .unwrap();
    ok(&out);
    dir.join("faust")
}

#[test]
fn gen_keypoints_transfer_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let f = gen(dir.path());
    let sel = [
        "--candidates",
        "12",
        "--error-norm",
        "rms",
        "--max-keypoints",
        "6",
    ];

    // keypoints
    let kp_dir = dir.path().join("kp");
    let out = deformlab()
        .arg("keypoints")
        .arg("--source")
        .arg(f.join("tr_reg_000.ply"))
        .arg("--deformed")
        .arg(f.join("tr_reg_001.ply"))
        .arg(f.join("tr_reg_002.ply"))
        .args(sel)
        .arg("--out")
        .arg(&kp_dir)
        .output()
        .unwrap();
    let text = ok(&out);
    assert!(
        text.contains("key points") && text.contains("error trace"),
        "{text}"
    );
    let csv = std::fs::read_to_string(kp_dir.join("keypoints.csv")).unwrap();
    assert!(csv.starts_with("source,ax,ay,az\n"), "{csv}");
    let log: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(kp_dir.join("log.json")).unwrap()).unwrap();
    assert!(log["selection"]["trace"].as_array().unwrap().len() >= 2);

    // transfer, selecting again, shared connectivity, refined
    let t_dir = dir.path().join("t");
    // (Selection flags only when key points are selected: with
    // --keypoints they would have no effect, which is an error.)
    let transfer_with = |sel: &[&str], extra: &[&str], out_dir: &Path| {
        deformlab()
            .arg("transfer")
            .arg("--source")
            .arg(f.join("tr_reg_000.ply"))
            .arg("--deformed")
            .arg(f.join("tr_reg_001.ply"))
            .arg(f.join("tr_reg_002.ply"))
            .arg("--target")
            .arg(f.join("tr_reg_010.ply"))
            .args(sel)
            .args(extra)
            .arg("--out")
            .arg(out_dir)
            .output()
            .unwrap()
    };
    let transfer = |extra: &[&str], out_dir: &Path| transfer_with(&sel, extra, out_dir);
    ok(&transfer(&["--same-connectivity", "--refine"], &t_dir));
    let target = read_mesh(&f.join("tr_reg_010.ply")).unwrap();
    for name in [
        "tr_reg_001_to_tr_reg_010.ply",
        "tr_reg_002_to_tr_reg_010.ply",
    ] {
        let m = read_mesh(&t_dir.join(name)).unwrap();
        assert_eq!(m.n_vertices(), target.n_vertices());
        assert_eq!(m.faces(), target.faces());
    }
    let csv = std::fs::read_to_string(t_dir.join("keypoints.csv")).unwrap();
    assert!(
        csv.starts_with("source,target,ax,ay,az,bx,by,bz\n"),
        "{csv}"
    );
    let log: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(t_dir.join("log.json")).unwrap()).unwrap();
    assert!(log["seconds"]["total"].as_f64().unwrap() > 0.0);

    // A second run into the same folder refuses; --force overwrites.
    let out = transfer(&["--same-connectivity"], &t_dir);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--force"));
    ok(&transfer(&["--same-connectivity", "--force"], &t_dir));

    // Reuse the key point file (its target column maps the key points).
    let r_dir = dir.path().join("reuse");
    let kp_file = t_dir.join("keypoints.csv");
    let out = transfer_with(
        &[],
        &[
            "--keypoints",
            kp_file.to_str().unwrap(),
            "--frame",
            "handle-relative",
        ],
        &r_dir,
    );
    ok(&out);
    assert!(r_dir.join("tr_reg_002_to_tr_reg_010.ply").is_file());

    // Correspondence markers: candidates (hence key points) are marker vertices.
    let markers = dir.path().join("markers.csv");
    let pairs: String = (0..target.n_vertices())
        .step_by(97)
        .map(|v| format!("{v},{v}\n"))
        .collect();
    std::fs::write(&markers, format!("source,target\n{pairs}")).unwrap();
    let c_dir = dir.path().join("corr");
    ok(&transfer(
        &["--correspondence", markers.to_str().unwrap()],
        &c_dir,
    ));
    let csv = std::fs::read_to_string(c_dir.join("keypoints.csv")).unwrap();
    for line in csv.lines().skip(1) {
        let v: usize = line.split(',').next().unwrap().parse().unwrap();
        assert_eq!(v % 97, 0, "{line} is not a marker");
    }
}

#[test]
fn bad_input_fails_with_a_message_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let f = gen(dir.path());
    let base = |target: &Path, extra: &[&str]| {
        let out = deformlab()
            .arg("transfer")
            .arg("--source")
            .arg(f.join("tr_reg_000.ply"))
            .arg("--deformed")
            .arg(f.join("tr_reg_001.ply"))
            .arg("--target")
            .arg(target)
            // (--candidates would have no effect with --keypoints: an error.)
            .args(if extra.contains(&"--keypoints") {
                &[][..]
            } else {
                &["--candidates", "8"][..]
            })
            .args(extra)
            .arg("--out")
            .arg(dir.path().join("out"))
            .output()
            .unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    // Missing target file.
    let err = base(&f.join("missing.ply"), &["--same-connectivity"]);
    assert!(err.contains("missing.ply"), "{err}");
    // Missing deformed file.
    let out = deformlab()
        .args(["keypoints", "--source"])
        .arg(f.join("tr_reg_000.ply"))
        .arg("--deformed")
        .arg(f.join("nope.ply"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.ply"));
    // Different vertex count with --same-connectivity.
    let err = base(
        &dir.path().join("remesh/remesh_rest.ply"),
        &["--same-connectivity"],
    );
    assert!(
        err.contains("remesh_rest.ply") && err.contains("vertices"),
        "{err}"
    );
    // Mismatched counts: key point file vs explicit target list.
    let kp = dir.path().join("kp.csv");
    std::fs::write(&kp, "source\n1\n50\n300\n").unwrap();
    let err = base(
        &f.join("tr_reg_010.ply"),
        &[
            "--keypoints",
            kp.to_str().unwrap(),
            "--target-keypoints",
            "1,50",
        ],
    );
    assert!(
        err.contains("kp.csv") && err.contains("3 key points"),
        "{err}"
    );
    // Out-of-range target key point.
    let err = base(
        &f.join("tr_reg_010.ply"),
        &[
            "--keypoints",
            kp.to_str().unwrap(),
            "--target-keypoints",
            "1,50,999999",
        ],
    );
    assert!(err.contains("999999"), "{err}");
    // Missing correspondence file.
    let err = base(
        &f.join("tr_reg_010.ply"),
        &["--correspondence", "/nonexistent/markers.csv"],
    );
    assert!(err.contains("markers.csv"), "{err}");
}

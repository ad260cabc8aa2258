//! End-to-end runs of the `deformlab` binary.

mod common;

use common::deformlab;

#[test]
fn gen_then_inspect_reports_zero_defects() {
    let dir = tempfile::tempdir().unwrap();
    let out = deformlab()
        .args([
            "gen",
            "--subjects",
            "2",
            "--poses",
            "3",
            "--seed",
            "5",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let faust = dir.path().join("faust");
    assert!(faust.join("tr_reg_000.ply").is_file());
    assert!(faust.join("tr_reg_012.ply").is_file());
    assert!(faust.join("labels.csv").is_file());
    assert!(dir.path().join("remesh/map.csv").is_file());

    let out = deformlab()
        .args(["inspect", "--brief"])
        .arg(&faust)
        .arg(dir.path().join("tosca"))
        .arg(dir.path().join("remesh"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains(", 0 with defects"), "{text}");
    assert!(text.contains("0 unreadable"), "{text}");
    assert!(text.contains("identical connectivity"), "{text}");

    // A second gen into the same folder refuses to overwrite.
    let out = deformlab()
        .args(["gen", "--subjects", "2", "--poses", "3", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--force"));
}

#[test]
fn inspect_names_bad_and_missing_files() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken.off");
    std::fs::write(&bad, "OFF\n3 1 0\n0 0 0\n1 0 0\n").unwrap();
    let out = deformlab().arg("inspect").arg(&bad).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(
        text.contains("broken.off") && text.contains("UNREADABLE"),
        "{text}"
    );

    let missing = dir.path().join("nope.ply");
    let out = deformlab().arg("inspect").arg(&missing).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.ply"));
    // A loop of symbolic links is named as such (before: "no such file").
    #[cfg(unix)]
    {
        let (a, b) = (dir.path().join("loop-a.ply"), dir.path().join("loop-b.ply"));
        std::os::unix::fs::symlink(&b, &a).unwrap();
        std::os::unix::fs::symlink(&a, &b).unwrap();
        let out = deformlab().arg("inspect").arg(&a).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(
            err.contains("loop-a.ply")
                && err.contains("symbolic links")
                && !err.contains("no such"),
            "{err}"
        );
    }
}

#[test]
fn inspect_real_tosca_and_camel_when_present() {
    let Some(data) = deformlab::data::shared_data_or_skip("tosca", "inspect_real_tosca_and_camel")
    else {
        return;
    };
    let camel = data.join("../sumner/horse-camel/camel_ref.obj");
    let out = deformlab()
        .arg("inspect")
        .arg(data.join("centaur0.off"))
        .arg(data.join("centaur3.off"))
        .arg(&camel)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("376"), "centaur3's reversed faces: {text}");
    assert!(
        text.contains("non-manifold edges                   26"),
        "{text}"
    );
}

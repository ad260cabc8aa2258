//! Messages that name the real problem (issue 40, class "messages that
//! mislead"): each case below was refused before, but in words that sent
//! the user after something else.

mod common;

use std::path::Path;

use common::{cli_err, run, tmp, write};
use deformlab::mesh::io::write_ply;
use deformlab::mesh::primitives::icosphere;
use deformlab::Mesh;

/// A closed surface with every vertex in one plane (a dropped or
/// overwritten coordinate) is refused at load as flattened, by every
/// command; before, key point selection blamed connectivity ("is the mesh
/// connected?"), `weights` an active set that did not settle, and
/// `inspect` called it clean.
#[test]
fn flattened_mesh_is_named_at_load() {
    let dir = tmp();
    let sphere = icosphere(3);
    let flat = sphere
        .map_vertices(|p| deformlab::Point::new(p.x, p.y, 0.0))
        .unwrap();
    let wide = sphere
        .map_vertices(|p| deformlab::Point::new(1.2 * p.x, p.y, 0.0))
        .unwrap();
    let a = dir.path().join("flat.ply");
    let b = dir.path().join("wide.ply");
    write_ply(&a, &flat).unwrap();
    write_ply(&b, &wide).unwrap();
    for args in [
        vec!["weights".into(), a.display().to_string()],
        vec![
            "keypoints".into(),
            "--source".into(),
            a.display().to_string(),
            "--deformed".into(),
            b.display().to_string(),
        ],
    ] {
        let err = cli_err(&args, &["flat.ply", "flattened", "one plane"]);
        assert!(!err.contains("connected"), "{err}");
    }
    let o = run(&["inspect".to_string(), a.display().to_string()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(!o.status.success() && text.contains("flattened"), "{text}");
    // A flat open surface (a disk) is a legitimate mesh.
    let disk = disk();
    let d = dir.path().join("disk.ply");
    write_ply(&d, &disk).unwrap();
    let o = run(&["inspect".to_string(), d.display().to_string()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stdout));
}

/// A flat open surface of two triangles (a disk: one boundary loop).
fn disk() -> Mesh {
    Mesh::new(
        vec![
            deformlab::Point::new(0.0, 0.0, 0.0),
            deformlab::Point::new(1.0, 0.0, 0.0),
            deformlab::Point::new(0.0, 1.0, 0.0),
            deformlab::Point::new(-1.0, 0.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
    .unwrap()
}

fn ascii_ply(props: &[&str], rows: &[String]) -> String {
    let mut s = format!("ply\nformat ascii 1.0\nelement vertex {}\n", rows.len());
    for p in props {
        s.push_str(&format!("property float {p}\n"));
    }
    s.push_str("element face 2\nproperty list uchar int vertex_indices\nend_header\n");
    for r in rows {
        s.push_str(r);
        s.push('\n');
    }
    s.push_str("3 0 1 2\n3 0 2 3\n");
    s
}

/// A property declared twice is refused naming both header lines (the
/// header parser kept one, so a second `z` overwrote the first and
/// flattened the mesh); a `nan` in an ASCII PLY names the line, the vertex
/// and the value instead of quoting the parser's grammar.
#[test]
fn ply_header_and_values_are_named() {
    let dir = tmp();
    let rows: Vec<String> = ["0 0 0 1", "1 0 0 2", "0 1 0 3", "1 1 1 4"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let dup = write(
        dir.path(),
        "dup.ply",
        ascii_ply(&["x", "y", "z", "z"], &rows),
    );
    let err = cli_err(&["weights", dup.to_str().unwrap()], &["dup.ply"]);
    assert!(
        err.contains("property 'z' of element 'vertex' is declared twice (lines 6 and 7)"),
        "{err}"
    );
    let mut rows3: Vec<String> = ["0 0 0", "1 0 0", "0 1 nan", "1 1 1"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let nan = write(dir.path(), "nan.ply", ascii_ply(&["x", "y", "z"], &rows3));
    let err = cli_err(&["weights", nan.to_str().unwrap()], &["nan.ply"]);
    assert!(
        err.contains("element 'vertex' item 2 (line 12): 'nan' is not a finite number"),
        "{err}"
    );
    assert!(!err.contains("expected one of"), "{err}");
    rows3[1] = "1 zero 0".into();
    let word = write(dir.path(), "word.ply", ascii_ply(&["x", "y", "z"], &rows3));
    let o = run(&["inspect", word.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        !o.status.success()
            && text.contains("element 'vertex' item 1 (line 11): 'zero' is not a number"),
        "{text}"
    );
}

/// A negative number after an option is that option's value, refused by
/// its range check; clap's default called it an unexpected argument and
/// suggested `-- -1`, which would make it a positional argument (a config
/// path for `run`).
#[test]
fn negative_numbers_after_a_flag_are_values() {
    let err = cli_err(
        &[
            "keypoints",
            "--source",
            "a.ply",
            "--deformed",
            "b.ply",
            "--epsilon",
            "-1",
        ],
        &["--epsilon", "-1 is out of range"],
    );
    assert!(!err.contains("-- -1"), "{err}");
    let err = cli_err(
        &["run", "x.toml", "--threads", "-2"],
        &["--threads", "-2 is out of range"],
    );
    assert!(!err.contains("-- -2"), "{err}");
}

/// `transfer --out` naming an existing file, and `weights --out` naming a
/// folder or a file in a missing folder, are refused before anything is
/// computed (before, after the whole computation, in the system's words).
#[test]
fn output_paths_are_checked_before_computing() {
    let dir = tmp();
    let sphere = icosphere(2);
    let a = dir.path().join("a.ply");
    let a1 = dir.path().join("a1.ply");
    write_ply(&a, &sphere).unwrap();
    write_ply(
        &a1,
        &sphere
            .map_vertices(|p| deformlab::Point::new(1.3 * p.x, p.y, p.z))
            .unwrap(),
    )
    .unwrap();
    let file = write(dir.path(), "taken", "x");
    let o = run(&[
        "transfer",
        "--source",
        a.to_str().unwrap(),
        "--deformed",
        a1.to_str().unwrap(),
        "--target",
        a.to_str().unwrap(),
        "--same-connectivity",
        "--out",
        file.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("a file of that name exists"),
        "{err}"
    );
    // Nothing was computed: the selection prints its key points first.
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    cli_err(
        &[
            "weights",
            a.to_str().unwrap(),
            "--out",
            dir.path().to_str().unwrap(),
        ],
        &["is a folder"],
    );
    let missing = dir.path().join("no/such/W.csv");
    cli_err(
        &[
            "weights",
            a.to_str().unwrap(),
            "--out",
            missing.to_str().unwrap(),
        ],
        &["does not exist"],
    );
}

/// A dataset path or manifest entry behind a loop of symbolic links gets
/// the system's reason, not "does not exist".
#[test]
fn link_loops_are_not_called_missing() {
    let dir = tmp();
    let d = dir.path();
    std::os::unix::fs::symlink(d.join("l2"), d.join("l1")).unwrap();
    std::os::unix::fs::symlink(d.join("l1"), d.join("l2")).unwrap();
    std::os::unix::fs::symlink(d.join("m2.ply"), d.join("m1.ply")).unwrap();
    std::os::unix::fs::symlink(d.join("m1.ply"), d.join("m2.ply")).unwrap();
    let config = write(
        d,
        "c.toml",
        "name = \"c\"\n[dataset.faust]\npath = \"l1\"\n[[methods]]\nname = \"x\"\nkind = \"identity\"\n",
    );
    let out = d.join("out");
    let err = cli_err(
        &[
            "run",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["dataset.faust.path", "symbolic links"],
    );
    assert!(!err.contains("does not exist"), "{err}");
    let manifest = write(d, "set.toml", "[[mesh]]\nfile = \"m1.ply\"\n");
    let err = deformlab::data::folders::Manifest::open(Path::new(&manifest))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("mesh[0].file") && err.contains("symbolic links"),
        "{err}"
    );
}

/// An open surface is valid input: `inspect` reports its boundary as a
/// boundary, not as a defect, and counts the file among those without
/// defects (before: "has defects", and "1 with defects").
#[test]
fn open_surfaces_are_not_defective() {
    let dir = tmp();
    let disk = disk();
    let d = dir.path().join("disk.ply");
    write_ply(&d, &disk).unwrap();
    let o = run(&["inspect".to_string(), d.display().to_string()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}");
    assert!(text.contains("; clean open surface"), "{text}");
    assert!(
        text.contains("boundary (not a defect): 4 edges in 1 loop"),
        "{text}"
    );
    assert!(
        text.contains("1 without any defect, 0 with defects"),
        "{text}"
    );
    let o = run(&["inspect", "--brief", d.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains(": clean open surface\n"), "{text}");
}

/// Errors are the sentence, without the error kind as a prefix
/// (`error: invalid input: …`).
#[test]
fn messages_carry_no_internal_prefix() {
    let err = cli_err(
        &["weights", "no-such-mesh.obj", "--handles", "0"],
        &["error: "],
    );
    for prefix in ["error: invalid input", "error: numerical failure"] {
        assert!(!err.contains(prefix), "{err}");
    }
    let dir = tmp();
    let a = dir.path().join("a.ply");
    write_ply(&a, &icosphere(1)).unwrap();
    let err = cli_err(
        &["weights", a.to_str().unwrap(), "--handles", "1000"],
        &["--handles 1000"],
    );
    assert!(err.starts_with("error: --handles"), "{err}");
}

/// A mesh of another shape under a `tr_reg_XXX.ply` name is named when the
/// folder is opened (from the PLY headers), not inside its first case after
/// the key point selection.
#[test]
fn a_foreign_mesh_in_a_faust_folder_is_named_at_load() {
    let dir = tmp();
    let data = dir.path().join("faust");
    common::synthetic_faust(&data, 2, 2);
    write_ply(&data.join("tr_reg_011.ply"), &icosphere(2)).unwrap();
    let config = write(
        dir.path(),
        "c.toml",
        format!(
            "name = \"c\"\n[dataset.faust]\npath = \"{}\"\n[[methods]]\nname = \"b\"\nkind = \"bdt\"\n",
            data.display()
        ),
    );
    let out = dir.path().join("out");
    let err = cli_err(
        &[
            "run",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &[
            "tr_reg_011.ply (162 vertices, 320 faces)",
            "have 1682 vertices",
            "one template",
        ],
    );
    assert!(!err.contains("key point"), "{err}");
    assert!(!out.join("c/cases").exists(), "a case ran");
}

/// One name per concept: the weight problem is `--weights` in `weights` as
/// in `transfer` and the configs (`--mode` is the candidate scoring of
/// `keypoints` and `transfer`); the former `--mode` of `weights` still works.
#[test]
fn weights_takes_the_weight_problem_as_weights() {
    let dir = tmp();
    let a = dir.path().join("a.ply");
    write_ply(&a, &icosphere(2)).unwrap();
    let base = ["weights", a.to_str().unwrap(), "--handles", "3"];
    let new = run(&[&base[..], &["--weights", "coupled"]].concat());
    let old = run(&[&base[..], &["--mode", "coupled"]].concat());
    assert!(
        new.status.success(),
        "{}",
        String::from_utf8_lossy(&new.stderr)
    );
    let text = String::from_utf8_lossy(&new.stdout);
    assert!(text.contains("Coupled"), "{text}");
    assert!(old.status.success());
    let help = run(&["weights", "--help"]);
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(
        help.contains("--weights <WEIGHTS>") && !help.contains("--mode"),
        "{help}"
    );
}

//! Dataset folder loaders and manifests, on generated temporary folders.

use std::fs;

use deformlab::data::correspondence::PairFormat;
use deformlab::data::folders::{FaustFolder, Label, Manifest, ToscaFolder};
use deformlab::data::synthetic::{self, FaustStyle};
use deformlab::Error;

fn small() -> FaustStyle {
    FaustStyle {
        subjects: 2,
        poses: 3,
        seed: 9,
        ..FaustStyle::default()
    }
}

/// Loading needs the mesh readers (another module); skip that part while
/// they are not implemented.
#[test]
fn faust_folder_on_generated_set() {
    let dir = tempfile::tempdir().unwrap();
    let set = small().generate().unwrap();
    synthetic::write_faust_style(dir.path(), &set).unwrap();
    fs::write(dir.path().join("tr_reg_abc.ply"), b"not a mesh").unwrap();
    fs::write(dir.path().join("notes.txt"), b"ignored").unwrap();
    let f = FaustFolder::open(dir.path()).unwrap();
    let ids: Vec<usize> = f.entries.iter().map(|e| e.id).collect();
    assert_eq!(ids, vec![0, 1, 2, 10, 11, 12]);
    assert_eq!(f.subjects(), vec![0, 1]);
    let e = f.get(1, 2).unwrap();
    assert_eq!((e.id, e.subject, e.pose), (12, 1, 2));
    assert!(e.path.ends_with("tr_reg_012.ply"));
    let pairs = f.same_pose_pairs();
    assert_eq!(pairs.len(), 3);
    assert!(pairs
        .iter()
        .all(|(a, b)| a.pose == b.pose && a.subject == 0 && b.subject == 1));
    let m = e.load().unwrap();
    assert_eq!(m.faces(), set.faces());
    assert_eq!(m.vertices(), set.meshes[1][2].vertices());
}

#[test]
fn faust_folder_errors() {
    let dir = tempfile::tempdir().unwrap();
    let err = FaustFolder::open(dir.path()).unwrap_err();
    assert!(err.to_string().contains("no tr_reg_XXX.ply"), "{err}");
    let err = FaustFolder::open(&dir.path().join("missing")).unwrap_err();
    assert!(matches!(err, Error::Io { .. }), "{err}");
    fs::write(dir.path().join("tr_reg_007.ply"), b"").unwrap();
    fs::write(dir.path().join("tr_reg_07.ply"), b"").unwrap();
    let err = FaustFolder::open(dir.path()).unwrap_err();
    assert!(err.to_string().contains("id 7 also used"), "{err}");
}

#[test]
fn tosca_folder_on_generated_class() {
    let dir = tempfile::tempdir().unwrap();
    let set = FaustStyle {
        subjects: 1,
        poses: 1,
        ..small()
    }
    .generate()
    .unwrap();
    let names = synthetic::write_tosca_style(dir.path(), &set, "creature", 0).unwrap();
    assert_eq!(names.len(), 11);
    // A second class as a .vert + .tri pair, and noise.
    fs::write(dir.path().join("wolf2.vert"), b"0 0 0\n").unwrap();
    fs::write(dir.path().join("wolf2.tri"), b"1 1 1\n").unwrap();
    fs::write(dir.path().join("readme.off"), b"").unwrap();
    let t = ToscaFolder::open(dir.path()).unwrap();
    assert_eq!(
        t.classes.keys().collect::<Vec<_>>(),
        vec!["creature", "wolf"]
    );
    let c = t.class("creature").unwrap();
    assert_eq!(
        c.iter().map(|e| e.index).collect::<Vec<_>>(),
        (0..=10).collect::<Vec<_>>()
    );
    assert!(c[4].path.extension().unwrap() == "ply" && c[3].path.extension().unwrap() == "off");
    assert!(t.class("wolf").unwrap()[0].path.ends_with("wolf2.vert"));
    let rest = c[0].load().unwrap();
    assert_eq!(rest.faces(), set.faces());
    assert_eq!(
        rest.vertices(),
        set.rest[0].vertices(),
        "OFF round trip is exact"
    );
    let p3 = c[4].load().unwrap();
    assert_eq!(p3.vertices(), set.posed(0, 3).unwrap().vertices());
    // Errors: missing .tri, duplicate class index.
    fs::remove_file(dir.path().join("wolf2.tri")).unwrap();
    let err = ToscaFolder::open(dir.path()).unwrap_err();
    assert!(err.to_string().contains("wolf2.tri is missing"), "{err}");
    fs::remove_file(dir.path().join("wolf2.vert")).unwrap();
    fs::write(dir.path().join("creature4.off"), b"").unwrap();
    let err = ToscaFolder::open(dir.path()).unwrap_err();
    assert!(
        err.to_string().contains("creature4 is also stored"),
        "{err}"
    );
}

fn manifest_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for f in ["a.ply", "b.off"] {
        fs::write(dir.path().join(f), b"").unwrap();
    }
    fs::write(dir.path().join("ab.csv"), b"source,target\n0,1\n2,3\n").unwrap();
    fs::write(dir.path().join("ab.cons"), b"1\n5, 6\n").unwrap();
    dir
}

#[test]
fn manifest_reads_meshes_and_correspondences() {
    let dir = manifest_dir();
    let m = dir.path().join("manifest.toml");
    fs::write(
        &m,
        r#"
name = "tiny"
[[mesh]]
file = "a.ply"
subject = 0
pose = "walk"
[[mesh]]
file = "b.off"
class = "cat"
[[correspondence]]
file = "ab.csv"
source = "a.ply"
target = "b.off"
[[correspondence]]
file = "ab.cons"
source = "b.off"
target = "a.ply"
base = 1
"#,
    )
    .unwrap();
    let man = Manifest::open(&m).unwrap();
    assert_eq!(man.name.as_deref(), Some("tiny"));
    assert_eq!(man.meshes.len(), 2);
    assert_eq!(man.meshes[0].subject, Some(Label::Index(0)));
    assert_eq!(man.meshes[0].pose, Some(Label::Name("walk".into())));
    assert_eq!(man.meshes[1].class.as_deref(), Some("cat"));
    let c = &man.correspondences;
    assert_eq!(
        (c[0].source, c[0].target, c[0].file.format),
        (0, 1, PairFormat::Csv)
    );
    assert_eq!(
        (c[1].source, c[1].target, c[1].file.format, c[1].file.base),
        (1, 0, PairFormat::Cons, 1)
    );
    let p0: Vec<(usize, usize)> = c[0]
        .read()
        .unwrap()
        .iter()
        .map(|p| (p.source, p.target))
        .collect();
    assert_eq!(p0, vec![(0, 1), (2, 3)]);
    let p1 = c[1].read().unwrap();
    assert_eq!((p1[0].source, p1[0].target), (4, 5));
}

#[test]
fn manifest_errors_name_file_and_key() {
    let dir = manifest_dir();
    let m = dir.path().join("manifest.toml");
    let check = |text: &str, want: &[&str]| {
        fs::write(&m, text).unwrap();
        let err = Manifest::open(&m).unwrap_err().to_string();
        assert!(err.contains("manifest.toml"), "{err}");
        for w in want {
            assert!(err.contains(w), "{err:?} should contain {w:?}");
        }
    };
    check(
        "[[mesh]]\nfile = \"a.ply\"\nsubjct = 1\n",
        &["subjct", "line 3"],
    );
    check("colour = 1\n", &["colour"]);
    check(
        "[[mesh]]\nfile = \"missing.ply\"\n",
        &["mesh[0].file", "does not exist"],
    );
    check(
        "[[mesh]]\nfile = \"a.ply\"\n[[correspondence]]\nfile = \"ab.csv\"\nsource = \"a.ply\"\ntarget = \"c.ply\"\n",
        &["correspondence[0].target", "c.ply"],
    );
    check(
        "[[mesh]]\nfile = \"a.ply\"\n[[correspondence]]\nfile = \"ab.csv\"\nsource = \"a.ply\"\ntarget = \"a.ply\"\nbase = 2\n",
        &["correspondence[0].base"],
    );
    check(
        "[[mesh]]\nfile = \"a.ply\"\n[[mesh]]\nfile = \"a.ply\"\n",
        &["mesh[1].file", "twice"],
    );
}

//! Correspondence parsers on small hand-written files and (when present)
//! the real Sumner & Popović files.

use std::fs;

use deformlab::data::correspondence::*;
use deformlab::data::shared_data_or_skip;

fn pairs(v: &[VertexPair]) -> Vec<(usize, usize)> {
    v.iter().map(|p| (p.source, p.target)).collect()
}

#[test]
fn csv_pairs_with_and_without_header() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.csv");
    fs::write(&a, "src,dst\n1,2\n# comment\n\n3, 4\n5\t6\n").unwrap();
    assert_eq!(
        pairs(&read_pairs_csv(&a, 0).unwrap()),
        vec![(1, 2), (3, 4), (5, 6)]
    );
    assert_eq!(
        pairs(&read_pairs_csv(&a, 1).unwrap()),
        vec![(0, 1), (2, 3), (4, 5)]
    );
    let b = dir.path().join("b.csv");
    fs::write(&b, "1,2\n3,4\n").unwrap();
    assert_eq!(pairs(&read_pairs_csv(&b, 0).unwrap()), vec![(1, 2), (3, 4)]);
    // Errors name the file and the line.
    fs::write(&b, "1,2\nx,4\n").unwrap();
    let e = read_pairs_csv(&b, 0).unwrap_err().to_string();
    assert!(e.contains("b.csv") && e.contains("line 2"), "{e}");
    fs::write(&b, "1,2,3\n").unwrap();
    assert!(read_pairs_csv(&b, 0)
        .unwrap_err()
        .to_string()
        .contains("line 1"));
    fs::write(&b, "0,2\n").unwrap();
    let e = read_pairs_csv(&b, 1).unwrap_err().to_string();
    assert!(e.contains("below the index base"), "{e}");
    assert!(read_pairs_csv(&b, 2).is_err());
    assert!(read_pairs_csv(&dir.path().join("missing.csv"), 0).is_err());
    check_pairs(&b, &read_pairs_csv(&b, 0).unwrap(), 1, 3).unwrap();
    assert!(check_pairs(&b, &read_pairs_csv(&b, 0).unwrap(), 1, 2).is_err());
}

#[test]
fn cons_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("x.cons");
    fs::write(&p, "3\n750, 3386\n524, 3737\n1409, 3060\n").unwrap();
    assert_eq!(
        pairs(&read_cons(&p, 0).unwrap()),
        vec![(750, 3386), (524, 3737), (1409, 3060)]
    );
    fs::write(&p, "4\n1, 2\n").unwrap();
    let e = read_cons(&p, 0).unwrap_err().to_string();
    assert!(e.contains("header says 4 pairs"), "{e}");
    fs::write(&p, "1\n1 2\n").unwrap();
    assert!(read_cons(&p, 0).unwrap_err().to_string().contains("line 2"));
    fs::write(&p, "").unwrap();
    assert!(read_cons(&p, 0).is_err());
}

#[test]
fn markers_yml_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("markers-a-b.yml");
    fs::write(
        &p,
        "source:\n  reference: a/ref.obj\n  poses:\n    - a/p1.obj\n    - a/p2.obj\n\ntarget:\n  reference: b/ref.obj\n  # comment\n  poses:\n    - b/p1.obj\n\nmarkers:\n  - \"10:20\"  #left paw\n  - \"30:40\"\n  - 5:6\n",
    )
    .unwrap();
    let m = read_markers_yml(&p, 0).unwrap();
    assert_eq!(m.source_reference.as_deref(), Some("a/ref.obj"));
    assert_eq!(m.source_poses, vec!["a/p1.obj", "a/p2.obj"]);
    assert_eq!(m.target_reference.as_deref(), Some("b/ref.obj"));
    assert_eq!(m.target_poses, vec!["b/p1.obj"]);
    assert_eq!(pairs(&m.pairs), vec![(10, 20), (30, 40), (5, 6)]);
    assert_eq!(m.pairs[0].comment.as_deref(), Some("left paw"));
    assert_eq!(m.pairs[1].comment, None);
    let m1 = read_markers_yml(&p, 1).unwrap();
    assert_eq!(pairs(&m1.pairs)[0], (9, 19));
    fs::write(&p, "markers:\n  - \"10-20\"\n").unwrap();
    let e = read_markers_yml(&p, 0).unwrap_err().to_string();
    assert!(e.contains("line 2") && e.contains("markers-a-b.yml"), "{e}");
    fs::write(&p, "source:\n  reference: x\n").unwrap();
    assert!(read_markers_yml(&p, 0)
        .unwrap_err()
        .to_string()
        .contains("no `markers:`"));
    assert_eq!(PairFormat::from_path(&p), PairFormat::MarkersYml);
    assert_eq!(PairFormat::MarkersYml.default_base(), 0);
}

#[test]
fn real_sumner_files() {
    let Some(dir) = shared_data_or_skip("sumner", "real_sumner_files") else {
        return;
    };
    let cl =
        read_markers_yml(&dir.join("cat-lion/markers-cat-lion.yml"), MARKERS_YML_BASE).unwrap();
    assert_eq!(cl.pairs.len(), 55);
    assert_eq!(
        cl.source_reference.as_deref(),
        Some("cat-poses/cat-reference.obj")
    );
    assert_eq!(cl.source_poses.len(), 9);
    assert_eq!((cl.pairs[0].source, cl.pairs[0].target), (2653, 1316));
    assert_eq!(
        cl.pairs[0].comment.as_deref(),
        Some("left front paw left side")
    );
    // cat 7207 vertices, lion 5000.
    check_pairs(
        &dir.join("cat-lion/markers-cat-lion.yml"),
        &cl.pairs,
        7207,
        5000,
    )
    .unwrap();
    let hc = read_markers_yml(
        &dir.join("horse-camel/markers-horse-camel.yml"),
        MARKERS_YML_BASE,
    )
    .unwrap();
    assert_eq!(hc.pairs.len(), 124);
    let cons = read_cons(&dir.join("horse-camel/horse_camel.cons"), CONS_BASE).unwrap();
    assert_eq!(cons.len(), 107);
    assert_eq!((cons[0].source, cons[0].target), (750, 3386));
    // Every .cons pair is also a marker pair.
    let all: std::collections::HashSet<(usize, usize)> = pairs(&hc.pairs).into_iter().collect();
    assert!(pairs(&cons).iter().all(|p| all.contains(p)));
    check_pairs(
        &dir.join("horse-camel/horse_camel.cons"),
        &cons,
        8431,
        21887,
    )
    .unwrap();
}

//! Data roots (issue 20, point 2): configs and dataset manifests name their
//! data `@data/...`, found under `run --data-root DIR`, `DEFORMLAB_DATA`, or
//! the default; an absent folder is one error naming the key, the path
//! tried and how to set the root; moved data keep their results.

mod common;

use std::path::Path;

use common::{copy_dir, deformlab, tmp, write};
use deformlab::data::synthetic::{self, FaustStyle};

/// A FAUST-style folder `root/faust` (2 subjects × 3 poses, resolution 1).
fn faust_root(root: &Path) {
    let set = FaustStyle {
        subjects: 2,
        poses: 3,
        resolution: 1,
        ..FaustStyle::default()
    }
    .generate()
    .unwrap();
    std::fs::create_dir_all(root.join("faust")).unwrap();
    synthetic::write_faust_style(&root.join("faust"), &set).unwrap();
}

/// A config on `@data/faust` with one cheap method (the identity floor).
const CONFIG: &str = r#"
name = "rooted"
[dataset.faust]
path = "@data/faust"
[cases]
sources = [0]
targets = [1]
[[methods]]
name = "identity"
kind = "identity"
[outputs]
render_cases = 0
"#;

fn run_in(cwd: &Path, args: &[&str], env: Option<(&str, &Path)>) -> std::process::Output {
    let mut c = deformlab();
    c.current_dir(cwd)
        .args(args)
        .env_remove("DEFORMLAB_DATA")
        .env_remove("DEFORMLAB_SHARED_DATA");
    if let Some((k, v)) = env {
        c.env(k, v);
    }
    c.output().unwrap()
}

fn text(o: &std::process::Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn data_paths_resolve_through_flag_env_and_default() {
    let t = tmp();
    let data = t.path().join("somewhere/data");
    faust_root(&data);
    let cfg_dir = t.path().join("checkout/experiments");
    let cfg = write(&cfg_dir, "rooted.toml", CONFIG);
    let out = t.path().join("out");
    let (cfg, out_s) = (cfg.to_str().unwrap(), out.to_str().unwrap());

    // --data-root.
    let o = run_in(
        t.path(),
        &[
            "run",
            cfg,
            "--out",
            out_s,
            "--data-root",
            data.to_str().unwrap(),
        ],
        None,
    );
    let (so, se) = text(&o);
    assert!(o.status.success(), "{so}\n{se}");
    assert!(so.contains("rooted: 1 computed"), "{so}");
    let stored = std::fs::read_to_string(out.join("rooted/config.json")).unwrap();
    assert!(stored.contains("\"@data/faust\""), "{stored}");
    assert!(stored.contains("\"xxh3\""), "{stored}");
    let manifest = std::fs::read_to_string(out.join("rooted/manifest.json")).unwrap();
    assert!(manifest.contains("\"data_root\""), "{manifest}");

    // DEFORMLAB_DATA: the same data, the same results.
    let o = run_in(
        t.path(),
        &["run", cfg, "--out", out_s],
        Some(("DEFORMLAB_DATA", &data)),
    );
    let (so, se) = text(&o);
    assert!(so.contains("rooted: 0 computed, 1 resumed"), "{so}\n{se}");

    // The former variable name still works.
    let o = run_in(
        t.path(),
        &["run", cfg, "--out", out_s],
        Some(("DEFORMLAB_SHARED_DATA", &data)),
    );
    assert!(text(&o).0.contains("0 computed"), "{:?}", text(&o));

    // The default: ../shared/data from the working directory.
    let shared = t.path().join("shared/data");
    copy_dir(&data, &shared);
    let o = run_in(
        &t.path().join("checkout"),
        &["run", cfg, "--out", out_s],
        None,
    );
    let (so, se) = text(&o);
    assert!(
        so.contains("rooted: 0 computed"),
        "moved data keep their results: {so}\n{se}"
    );

    // Moved elsewhere and reached through a symbolic link: still the same.
    let moved = t.path().join("moved");
    std::fs::rename(&data, &moved).unwrap();
    let link = t.path().join("link");
    std::os::unix::fs::symlink(&moved, &link).unwrap();
    let o = run_in(
        t.path(),
        &[
            "run",
            cfg,
            "--out",
            out_s,
            "--data-root",
            link.to_str().unwrap(),
        ],
        None,
    );
    assert!(text(&o).0.contains("rooted: 0 computed"), "{:?}", text(&o));
}

#[test]
fn an_absent_data_folder_is_one_error_naming_key_path_and_root() {
    let t = tmp();
    let cfg = write(t.path(), "rooted.toml", CONFIG);
    let out = t.path().join("out");
    let missing = t.path().join("no-data");
    for (args, env, source) in [
        (
            vec!["--data-root", missing.to_str().unwrap()],
            None,
            "from --data-root",
        ),
        (
            vec![],
            Some(("DEFORMLAB_DATA", missing.as_path())),
            "DEFORMLAB_DATA",
        ),
        (vec![], None, "the default"),
    ] {
        let mut a = vec!["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()];
        a.extend(args);
        let o = run_in(t.path(), &a, env);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(!err.contains("panicked"), "{err}");
        for needle in [
            "rooted.toml",
            "dataset.faust.path",
            "faust",
            "does not exist",
            "--data-root",
            "DEFORMLAB_DATA",
            source,
        ] {
            assert!(err.contains(needle), "{needle:?} not in: {err}");
        }
        assert_eq!(err.lines().count(), 1, "one error: {err}");
        assert!(!out.exists(), "nothing written");
    }
}

#[test]
fn manifest_files_under_the_data_root() {
    let t = tmp();
    let data = t.path().join("data");
    faust_root(&data);
    let cfg_dir = t.path().join("cfg");
    write(
        &cfg_dir,
        "set.toml",
        "[[mesh]]\nfile = \"@data/faust/tr_reg_000.ply\"\nsubject = 0\npose = 0\n\
         [[mesh]]\nfile = \"@data/faust/tr_reg_001.ply\"\nsubject = 0\npose = 1\n\
         [[mesh]]\nfile = \"@data/faust/tr_reg_010.ply\"\nsubject = 1\npose = 0\n",
    );
    let cfg = write(
        &cfg_dir,
        "m.toml",
        "name = \"m\"\n[dataset.manifest]\npath = \"set.toml\"\n[cases]\nsources = [0]\n\
         targets = [1]\nrequire_truth = false\n[[methods]]\nname = \"identity\"\n\
         kind = \"identity\"\n[outputs]\nrender_cases = 0\n",
    );
    let out = t.path().join("out");
    let o = run_in(
        t.path(),
        &[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--data-root",
            data.to_str().unwrap(),
        ],
        None,
    );
    let (so, se) = text(&o);
    assert!(o.status.success(), "{so}\n{se}");
    let o = run_in(
        t.path(),
        &["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()],
        Some(("DEFORMLAB_DATA", &t.path().join("elsewhere"))),
    );
    let (_, err) = text(&o);
    assert!(
        err.contains("set.toml")
            && err.contains("mesh[0].file")
            && err.contains("elsewhere")
            && err.contains("DEFORMLAB_DATA"),
        "{err}"
    );
}

/// The shipped real configs run from any checkout given the data root
/// (here: loaded and fingerprinted, no case computed).
#[test]
fn shipped_real_configs_find_their_data_through_the_root() {
    let Some(data) = deformlab::data::shared_data_or_skip(
        "faust",
        "shipped_real_configs_find_their_data_through_the_root",
    ) else {
        return;
    };
    let root = std::fs::canonicalize(data.parent().unwrap()).unwrap();
    let t = tmp();
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/real/fig14-faust.toml");
    let o = deformlab()
        .current_dir(t.path())
        .env("DEFORMLAB_RUN_MAX_NEW", "0")
        .args([
            "run",
            cfg.to_str().unwrap(),
            "--out",
            t.path().join("out").to_str().unwrap(),
            "--data-root",
            root.to_str().unwrap(),
            "--no-plots",
        ])
        .output()
        .unwrap();
    let (so, se) = text(&o);
    assert!(o.status.success(), "{so}\n{se}");
    assert!(so.contains("fig14-faust: 0 computed"), "{so}");
}

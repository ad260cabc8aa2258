//! The result store keyed by what determines a result (issue 20, point 3):
//! changed meshes are refused naming the file, `--force` starts afresh
//! keeping the old results aside, `--retry-failed` computes failed results
//! again, a config that fails validation leaves nothing behind, added
//! methods and folders from before data fingerprints resume.

mod common;

use std::path::Path;

use common::{copy_dir, csv_rows, run, tmp, write};
use deformlab::data::synthetic::{self, FaustStyle};

fn faust(dir: &Path) {
    let set = FaustStyle {
        subjects: 2,
        poses: 3,
        resolution: 1,
        ..FaustStyle::default()
    }
    .generate()
    .unwrap();
    std::fs::create_dir_all(dir).unwrap();
    synthetic::write_faust_style(dir, &set).unwrap();
}

const CONFIG: &str = r#"
name = "keyed"
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

struct Setup {
    _t: tempfile::TempDir,
    data: std::path::PathBuf,
    cfg: std::path::PathBuf,
    out: std::path::PathBuf,
}

fn setup(config: &str) -> Setup {
    let t = tmp();
    let data = t.path().join("data");
    faust(&data.join("faust"));
    let cfg = write(t.path(), "keyed.toml", config);
    let out = t.path().join("out");
    Setup {
        data,
        cfg,
        out,
        _t: t,
    }
}

impl Setup {
    fn run(&self, extra: &[&str]) -> (bool, String, String) {
        let mut a = vec![
            "run",
            self.cfg.to_str().unwrap(),
            "--out",
            self.out.to_str().unwrap(),
            "--data-root",
            self.data.to_str().unwrap(),
            "--no-plots",
        ];
        a.extend(extra);
        let o = run(&a);
        let (so, se) = (
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        );
        assert!(!se.contains("panicked"), "{se}");
        (o.status.success(), so, se)
    }
}

/// Flips the lowest bit of the first byte after a PLY header (the first
/// vertex's x in a binary file, a digit in an ASCII one): same size, other
/// content, still a valid mesh.
fn edit_one_byte(p: &Path) {
    let mut b = std::fs::read(p).unwrap();
    let end = b"end_header\n";
    let i = b.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    b[i] ^= 1;
    std::fs::write(p, b).unwrap();
}

#[test]
fn changed_data_is_refused_naming_the_file_and_force_starts_afresh() {
    let s = setup(CONFIG);
    let (ok, so, se) = s.run(&[]);
    assert!(ok && so.contains("keyed: 1 computed"), "{so}\n{se}");
    let dir = s.out.join("keyed");
    let cached = std::fs::read_to_string(dir.join(".fingerprints.json")).unwrap();
    assert!(cached.contains("tr_reg_001.ply"), "{cached}");

    edit_one_byte(&s.data.join("faust/tr_reg_001.ply"));
    let (ok, so, se) = s.run(&[]);
    assert!(!ok, "{so}");
    for needle in [
        "other data",
        "tr_reg_001.ply",
        "0/1",
        "1 file(s) changed",
        "--force",
    ] {
        assert!(se.contains(needle), "{needle:?} not in {se}");
    }
    assert!(
        !se.contains("tr_reg_000.ply"),
        "only the changed file: {se}"
    );
    // The stored result is untouched.
    assert_eq!(csv_rows(&dir.join("cases.csv")).len(), 1);

    let (ok, so, se) = s.run(&["--force"]);
    assert!(
        ok && so.contains("keyed: 1 computed, 0 resumed"),
        "{so}\n{se}"
    );
    let kept: Vec<_> = std::fs::read_dir(s.out.as_path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("keyed.superseded-"))
        .collect();
    assert_eq!(kept.len(), 1, "{kept:?}");
    let old = s.out.join(&kept[0]);
    assert!(
        old.join("cases").is_dir() && old.join("config.json").is_file(),
        "the old results are kept"
    );
    assert!(se.contains(&kept[0]), "{se}");
    // And the new folder resumes.
    let (ok, so, _) = s.run(&[]);
    assert!(ok && so.contains("keyed: 0 computed, 1 resumed"), "{so}");
}

#[test]
fn another_config_is_refused_naming_the_key() {
    let s = setup(CONFIG);
    assert!(s.run(&[]).0);
    let (ok, _, se) = s.run(&["--set", "cases.require_truth=false"]);
    assert!(!ok);
    assert!(
        se.contains("another configuration") && se.contains("cases.require_truth"),
        "{se}"
    );
}

#[test]
fn retry_failed_computes_failed_results_again_keeping_them() {
    let s = setup(CONFIG);
    assert!(s.run(&[]).0);
    // Turn the stored result into a failure, as a crashed method leaves it.
    let dir = s.out.join("keyed");
    let file = std::fs::read_dir(dir.join("cases"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path()
        .join("identity.json");
    let text = std::fs::read_to_string(&file).unwrap();
    let failed = text.replace("\"status\":\"ok\"", "\"status\":\"failed: out of memory\"");
    assert_ne!(text, failed);
    std::fs::write(&file, &failed).unwrap();

    let (ok, so, _) = s.run(&[]);
    assert!(!ok, "a stored failure makes the exit status 1");
    assert!(
        so.contains("0 computed, 1 resumed, 1 failed") && so.contains("--retry-failed"),
        "{so}"
    );
    let (ok, so, se) = s.run(&["--retry-failed"]);
    assert!(ok, "{so}\n{se}");
    assert!(
        so.contains("keyed: 1 computed, 0 resumed, 0 failed"),
        "{so}"
    );
    assert!(se.contains("moved to") || so.contains("1 computed"), "{se}");
    let kept = dir
        .join("failed")
        .join(file.parent().unwrap().file_name().unwrap())
        .join("identity.json");
    assert_eq!(std::fs::read_to_string(kept).unwrap(), failed);
    assert_eq!(csv_rows(&dir.join("cases.csv"))[0]["status"], "ok");
}

#[test]
fn a_config_that_fails_validation_leaves_nothing_behind() {
    // Refused against the data: an unknown subject, more FPS candidates
    // than vertices; in strict mode a mesh with duplicate faces.
    for (config, needle) in [
        (
            CONFIG.replace("sources = [0]", "sources = [7]"),
            "cases.sources",
        ),
        (
            CONFIG.replace(
                "kind = \"identity\"",
                "kind = \"bdt\"\nn_candidates = 99999",
            ),
            "n_candidates",
        ),
    ] {
        let s = setup(&config);
        let (ok, _, se) = s.run(&[]);
        assert!(!ok && se.contains(needle), "{se}");
        assert!(!s.out.exists(), "{} exists after: {se}", s.out.display());
    }
    let s = setup(CONFIG);
    let mesh = s.data.join("faust/tr_reg_010.ply");
    let m = deformlab::mesh::io::read_mesh(&mesh).unwrap();
    let mut faces = m.faces().to_vec();
    faces.push(faces[0]);
    let dup = deformlab::mesh::Mesh::new(m.vertices().to_vec(), faces).unwrap();
    deformlab::mesh::io::write_ply(&mesh, &dup).unwrap();
    let (ok, _, se) = s.run(&["--strict"]);
    assert!(
        !ok && se.contains("tr_reg_010.ply") && se.contains("duplicate"),
        "{se}"
    );
    assert!(!s.out.exists(), "strict refusal leaves nothing: {se}");
}

#[test]
fn added_methods_and_folders_from_before_fingerprints_resume() {
    let s = setup(CONFIG);
    assert!(s.run(&[]).0);
    let dir = s.out.join("keyed");
    // A folder written before data fingerprints: no `data`, another hash.
    let p = dir.join("config.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    let o = v.as_object_mut().unwrap();
    o.remove("data");
    o.insert("hash".into(), "0123456789abcdef".into());
    o["config"]["dataset"]["faust"]["path"] = "../../../shared/data/faust".into();
    std::fs::write(&p, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
    let (ok, so, se) = s.run(&[]);
    assert!(ok && so.contains("0 computed, 1 resumed"), "{so}\n{se}");
    assert!(se.contains("adopted"), "{se}");
    let now = std::fs::read_to_string(&p).unwrap();
    assert!(
        now.contains("\"adopted_from\": \"0123456789abcdef\"") && now.contains("xxh3"),
        "{now}"
    );

    // A method added to the config: the stored results are kept.
    std::fs::write(
        &s.cfg,
        CONFIG.replace(
            "[outputs]",
            "[[methods]]\nname = \"oracle\"\nkind = \"sumner_oracle\"\n[outputs]",
        ),
    )
    .unwrap();
    let (ok, so, se) = s.run(&[]);
    assert!(ok && so.contains("1 computed, 1 resumed"), "{so}\n{se}");
    assert!(se.contains("adds method(s) oracle"), "{se}");
}

/// On the real FAUST sample: a copy of the data with one byte of one mesh
/// edited is refused, naming that file.
#[test]
fn real_data_edited_one_byte_is_refused() {
    let Some(faust) =
        deformlab::data::shared_data_or_skip("faust", "real_data_edited_one_byte_is_refused")
    else {
        return;
    };
    let s = setup(&CONFIG.replace("targets = [1]", "targets = [0]\ninclude_self = true"));
    std::fs::remove_dir_all(s.data.join("faust")).unwrap();
    copy_dir(&faust, &s.data.join("faust"));
    let (ok, so, se) = s.run(&[]);
    assert!(ok && so.contains("1 computed"), "{so}\n{se}");
    edit_one_byte(&s.data.join("faust/tr_reg_003.ply"));
    let (ok, _, se) = s.run(&[]);
    assert!(!ok);
    assert!(
        se.contains("@data/faust/tr_reg_003.ply") && se.contains("1 file(s) changed"),
        "{se}"
    );
}

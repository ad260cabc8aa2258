//! The baselines as harness methods (issue 6): a tiny Fig. 14-like config
//! with BDT, Sumner DT with the BDT key points, the Sumner oracle and cage DT.

mod common;

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use common::{csv_rows as rows, run as deformlab, write};

const CONFIG: &str = r#"
name = "tiny14"
seed = 5

[dataset.synthetic]
subjects = 2
poses = 3
resolution = 1

[cases]
sources = [0]

[defaults]
mode = "fast"
n_candidates = 12
error_norm = "rms"
epsilon = 0.0
max_keypoints = 4
max_swap_passes = 0

[[methods]]
name = "auto"
kind = "bdt"

[[methods]]
name = "sumner"
kind = "sumner"

[[methods]]
name = "oracle"
kind = "sumner_oracle"

[[methods]]
name = "cage"
kind = "cage"

[outputs]
render_poses = 1

[[outputs.plots]]
kind = "cumulative"
"#;

#[test]
fn sumner_oracle_and_cage_rows_share_bdt_keypoints_and_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "tiny14.toml", CONFIG);
    let out = dir.path().join("out");
    let o = deformlab(&[
        "run",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "2",
    ]);
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let res = out.join("tiny14");
    let rs = rows(&res.join("cases.csv"));
    assert_eq!(rs.len(), 4, "one case × 4 methods");
    let by: HashMap<&str, &BTreeMap<String, String>> =
        rs.iter().map(|r| (r["method"].as_str(), r)).collect();
    let err = |m: &str| -> f64 { by[m]["err_mean_unit"].parse().unwrap() };
    for m in ["auto", "sumner", "oracle", "cage"] {
        assert_eq!(by[m]["status"], "ok", "{m}: {:?}", by[m]["status"]);
        let e = err(m);
        assert!(
            e.is_finite() && e > 0.0 && e < 0.5,
            "{m}: err_mean_unit {e}"
        );
    }
    assert_eq!(by["sumner"]["kind"], "sumner");
    assert_eq!(by["oracle"]["kind"], "sumner_oracle");
    // Same sparse key points as the automatic BDT row.
    assert!(!by["auto"]["keypoints"].is_empty());
    assert_eq!(by["sumner"]["keypoints"], by["auto"]["keypoints"]);
    assert_eq!(by["cage"]["keypoints"], by["auto"]["keypoints"]);
    // Full correspondence beats a handful of markers.
    assert!(
        err("oracle") < err("sumner"),
        "oracle {} vs markers {}",
        err("oracle"),
        err("sumner")
    );
    let fit: f64 = by["cage"]["fit_error_unit"].parse().unwrap();
    assert!(fit > 0.0 && fit < err("cage") + 0.05);
    eprintln!(
        "tiny14 err_mean_unit: auto {:.4}, sumner {:.4}, oracle {:.4}, cage {:.4} (cage fit {fit:.4})",
        err("auto"),
        err("sumner"),
        err("oracle"),
        err("cage")
    );
    // Curves and renders like the BDT rows.
    let curves = std::fs::read_to_string(res.join("curves.csv")).unwrap();
    for m in ["sumner", "oracle", "cage"] {
        assert!(
            curves
                .lines()
                .any(|l| l.contains(m) && l.contains("cumulative_unit")),
            "no cumulative curve for {m}"
        );
    }
    assert!(res.join("plots").join("cumulative.png").exists());
    let meshes: Vec<_> = walk(&res.join("meshes"));
    for m in ["sumner", "oracle", "cage"] {
        assert!(
            meshes.iter().any(|p| p.contains(&format!("/{m}/result_"))),
            "no render mesh for {m}: {meshes:?}"
        );
    }
}

fn walk(d: &Path) -> Vec<String> {
    let mut out = Vec::new();
    if let Ok(rd) = std::fs::read_dir(d) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(walk(&p));
            } else {
                out.push(p.to_string_lossy().into_owned());
            }
        }
    }
    out
}

#[test]
fn baseline_kinds_reject_fields_of_other_kinds() {
    let dir = tempfile::tempdir().unwrap();
    let text = CONFIG.replace("kind = \"cage\"", "kind = \"cage\"\ncount = 3");
    let cfg = write(dir.path(), "bad.toml", text);
    let out = dir.path().join("out");
    let o = deformlab(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    let msg = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        msg.contains("methods[3].count") && msg.contains("cage"),
        "message: {msg}"
    );
}

//! Running a config again writes the same bytes: every output outside the
//! volatile `timings/` folder (tables, manifest, config, figures in PNG,
//! SVG and PDF, saved meshes) is identical between two runs, on one and on
//! two threads. Before, the tables carried timing columns, the manifest
//! the invocations (start, wall time, revision), and the PDFs came out with
//! their fonts and resources in hash-map order.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::{ok, tiny_bdt, tmp, write};

/// Every file under `dir` (relative path → bytes), without the result
/// store's own files (`cases/`, locks, fingerprint cache) and the volatile
/// `timings/`.
fn outputs(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(base: &Path, d: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(base).unwrap().to_string_lossy().into_owned();
            let top = rel.split('/').next().unwrap_or("");
            if matches!(top, "cases" | "timings" | ".fingerprints.json") || top.starts_with(".lock")
            {
                continue;
            }
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

#[test]
fn a_second_run_writes_the_same_bytes_outside_timings() {
    let t = tmp();
    let mut config = tiny_bdt("repro", "[1, 2]", true);
    config.push_str(
        "[outputs]\nrender_cases = 1\nrender_poses = 1\n\
         [[outputs.plots]]\nkind = \"bars\"\nmetrics = [\"err_mean_unit\"]\n\
         [[outputs.plots]]\nkind = \"cumulative\"\n\
         [[outputs.plots]]\nkind = \"table\"\nmetrics = [\"err_mean_unit\", \"seconds_total\"]\n\
         [[outputs.plots]]\nkind = \"panels\"\n",
    );
    let cfg = write(t.path(), "repro.toml", config);
    let mut runs = Vec::new();
    for (root, threads) in [("a", "1"), ("b", "2")] {
        let out = t.path().join(root);
        ok(&[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--threads",
            threads,
            "--quiet",
        ]);
        runs.push(outputs(&out.join("repro")));
    }
    let (a, b) = (&runs[0], &runs[1]);
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the two runs wrote different files"
    );
    for kind in [".pdf", ".svg", ".png", ".csv", ".ply", "manifest.json"] {
        assert!(a.keys().any(|k| k.ends_with(kind)), "no {kind} output");
    }
    for (k, v) in a {
        assert!(b[k] == *v, "{k} differs between two runs");
    }
    // The timings are there, apart, and the table that shows one is a
    // volatile figure.
    let dir = t.path().join("a/repro");
    for f in [
        "timings/cases.csv",
        "timings/summary.csv",
        "timings/runs.json",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    assert!(dir.join("timings/plots/table.md").is_file());
    assert!(!a.contains_key("plots/table.md"));
    let header = String::from_utf8_lossy(&a["cases.csv"])
        .lines()
        .next()
        .unwrap()
        .to_string();
    assert!(!header.contains("seconds_"), "{header}");
}

//! End-to-end runs of the experiment harness with the built binary on a
//! tiny synthetic suite (2 cases × 3 methods, 1.7k vertices):
//! an interrupted (SIGKILL) and resumed run, thread counts, shards + merge,
//! a changed config, and the plot calls.

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use common::{cases_without_timing, copy_dir, deformlab, ok, run, write};

const CONFIG: &str = r#"
name = "tiny"
seed = 3

[dataset.synthetic]
subjects = 3
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
name = "random"
kind = "bdt_random"
count = 4

[[methods]]
name = "extremity"
kind = "bdt_extremity"
count = 4
jitter = 0.02

[[methods]]
name = "groups"
kind = "clustering"

[outputs]
render_poses = 1
"#;

const N_RESULTS: usize = 2 * 4;

/// Writes the config `dir/tiny.toml`.
fn write_config(dir: &Path, text: &str) -> PathBuf {
    write(dir, "tiny.toml", text)
}

fn count_results(dir: &Path) -> usize {
    let Ok(rd) = std::fs::read_dir(dir.join("cases")) else {
        return 0;
    };
    rd.filter_map(|e| e.ok())
        .map(|e| {
            std::fs::read_dir(e.path())
                .map(|r| {
                    r.filter_map(|x| x.ok())
                        .filter(|x| {
                            let n = x.file_name().to_string_lossy().into_owned();
                            n.ends_with(".json") && !n.starts_with('.')
                        })
                        .count()
                })
                .unwrap_or(0)
        })
        .sum()
}

/// The uninterrupted reference run (2 threads), shared by the tests.
fn reference() -> &'static (tempfile::TempDir, PathBuf) {
    static REF: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    REF.get_or_init(|| {
        let t = tempfile::tempdir().unwrap();
        let cfg = write_config(t.path(), CONFIG);
        let out = t.path().join("out");
        ok(&[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--threads",
            "2",
            "--no-plots",
        ]);
        let dir = out.join("tiny");
        assert_eq!(count_results(&dir), N_RESULTS);
        (t, dir)
    })
}

#[test]
fn reference_run_has_a_row_per_case_and_method_and_all_outputs() {
    let (_, dir) = reference();
    let rows = cases_without_timing(dir);
    assert_eq!(rows.lines().count(), 1 + N_RESULTS, "{rows}");
    assert!(rows.lines().skip(1).all(|l| l.contains(",ok,")), "{rows}");
    for f in [
        "manifest.json",
        "cases.csv",
        "curves.csv",
        "summary.csv",
        "config.json",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["seed"], 3);
    assert_eq!(m["n_cases"], 2);
    assert_eq!(m["crate_version"], env!("CARGO_PKG_VERSION"));
    assert!(m.get("git_revision").is_none() && m.get("invocations").is_none());
    let log = common::runs(dir);
    assert!(log["invocations"][0]["git_revision"].is_string());
    assert_eq!(log["invocations"][0]["threads"], 2);
    let curves = std::fs::read_to_string(dir.join("curves.csv")).unwrap();
    assert!(curves.starts_with("case,case_id,method,curve,x,y"));
    assert!(curves.contains("cumulative_unit") && curves.contains("selection_trace"));
    // Render meshes of the first case only.
    let meshes: Vec<_> = std::fs::read_dir(dir.join("meshes")).unwrap().collect();
    assert_eq!(meshes.len(), 1);
}

#[test]
fn sigkill_mid_run_then_resume_gives_the_same_cases_csv() {
    let (_, ref_dir) = reference();
    let t = tempfile::tempdir().unwrap();
    let cfg = write_config(t.path(), CONFIG);
    let out = t.path().join("out");
    let dir = out.join("tiny");
    let args = [
        "run",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
        "--no-plots",
    ];
    let mut child = deformlab()
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while count_results(&dir) < 2 {
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "no result stored"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let stored = count_results(&dir);
    assert!(
        stored < N_RESULTS,
        "the run finished before it could be killed ({stored} results)"
    );
    // Every stored result is complete JSON (no partial file under its name).
    for e in std::fs::read_dir(dir.join("cases")).unwrap() {
        for f in std::fs::read_dir(e.unwrap().path()).unwrap() {
            let p = f.unwrap().path();
            if p.extension().is_some_and(|x| x == "json") {
                let v: serde_json::Value =
                    serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
                assert!(v["cells"]["status"].is_string());
            }
        }
    }
    let before: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir.join("cases"))
        .unwrap()
        .flat_map(|e| std::fs::read_dir(e.unwrap().path()).unwrap())
        .map(|f| f.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .map(|p| (p.clone(), std::fs::read(&p).unwrap()))
        .collect();
    // Resume.
    let o = run(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains(&format!("{} resumed", before.len())),
        "{text}"
    );
    assert_eq!(count_results(&dir), N_RESULTS);
    // Finished results were not rewritten.
    for (p, bytes) in before {
        assert_eq!(std::fs::read(&p).unwrap(), bytes, "{} changed", p.display());
    }
    assert_eq!(cases_without_timing(&dir), cases_without_timing(ref_dir));
    assert_eq!(
        std::fs::read(dir.join("curves.csv")).unwrap(),
        std::fs::read(ref_dir.join("curves.csv")).unwrap()
    );
    // The killed invocation never reached its manifest; the resumed one
    // records what it reused.
    let m = common::runs(&dir);
    assert_eq!(m["invocations"].as_array().unwrap().len(), 1);
    assert_eq!(m["invocations"][0]["computed"], N_RESULTS - stored);
}

#[test]
fn one_and_two_threads_give_identical_results() {
    let (_, ref_dir) = reference();
    let t = tempfile::tempdir().unwrap();
    let cfg = write_config(t.path(), CONFIG);
    let out = t.path().join("out");
    run_without_plots(&[&cfg], &out, 1);
    assert_same_results(&out.join("tiny"), ref_dir);
}

/// `deformlab run CONFIGS --out OUT --threads N --no-plots` (must succeed).
fn run_without_plots(configs: &[&Path], out: &Path, threads: usize) -> std::process::Output {
    let mut args: Vec<String> = vec!["run".into()];
    args.extend(configs.iter().map(|c| c.display().to_string()));
    args.extend([
        "--out".into(),
        out.display().to_string(),
        "--threads".into(),
        threads.to_string(),
        "--no-plots".into(),
    ]);
    ok(&args)
}

/// The same `cases.csv` (apart from timing) and `curves.csv`.
fn assert_same_results(dir: &Path, ref_dir: &Path) {
    assert_eq!(cases_without_timing(dir), cases_without_timing(ref_dir));
    assert_eq!(
        std::fs::read(dir.join("curves.csv")).unwrap(),
        std::fs::read(ref_dir.join("curves.csv")).unwrap()
    );
}

#[test]
fn configs_run_side_by_side_give_the_results_of_separate_runs() {
    // The configs of one run share the pool and run side by side: each
    // folder holds what a run of its config alone gives, and the summary
    // lines come in config order.
    let (_, ref_dir) = reference();
    let t = tempfile::tempdir().unwrap();
    let other = write(
        t.path(),
        "other.toml",
        CONFIG
            .replace("name = \"tiny\"", "name = \"other\"")
            .replace("seed = 3", "seed = 4"),
    );
    let cfg = write_config(t.path(), CONFIG);
    let out = t.path().join("out");
    let o = run_without_plots(&[&other, &cfg], &out, 2);
    assert_same_results(&out.join("tiny"), ref_dir);
    assert_eq!(count_results(&out.join("other")), N_RESULTS);
    assert_ne!(
        cases_without_timing(&out.join("other")),
        cases_without_timing(ref_dir),
        "the seed should change the second config's results"
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    let (a, b) = (stdout.find("other:"), stdout.find("tiny:"));
    assert!(
        a.is_some() && b.is_some() && a < b,
        "summaries not in config order:\n{stdout}"
    );
}

#[test]
fn two_shards_merged_equal_the_unsharded_run() {
    let (_, ref_dir) = reference();
    let t = tempfile::tempdir().unwrap();
    let cfg = write_config(t.path(), CONFIG);
    let mut dirs = Vec::new();
    for i in 0..2 {
        let out = t.path().join(format!("shard{i}"));
        ok(&[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--threads",
            "2",
            "--shard",
            &format!("{i}/2"),
            "--no-plots",
        ]);
        let d = out.join("tiny");
        assert_eq!(count_results(&d), N_RESULTS / 2, "shard {i}");
        dirs.push(d);
    }
    let merged = t.path().join("merged");
    ok(&[
        "merge",
        dirs[0].to_str().unwrap(),
        dirs[1].to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
        "--no-plots",
    ]);
    assert_eq!(cases_without_timing(&merged), cases_without_timing(ref_dir));
    assert_eq!(
        std::fs::read(merged.join("curves.csv")).unwrap(),
        std::fs::read(ref_dir.join("curves.csv")).unwrap()
    );
    // Render meshes came along from the shard that ran case 0.
    assert!(merged.join("meshes").read_dir().unwrap().count() == 1);
    // Merging again changes nothing; merging another config is refused.
    ok(&[
        "merge",
        dirs[0].to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
        "--no-plots",
    ]);
    assert_eq!(cases_without_timing(&merged), cases_without_timing(ref_dir));
    let other = t.path().join("other");
    let cfg2 = write_config(&other, &CONFIG.replace("seed = 3", "seed = 4"));
    let out2 = other.join("out");
    ok(&[
        "run",
        cfg2.to_str().unwrap(),
        "--out",
        out2.to_str().unwrap(),
        "--shard",
        "0/2",
        "--no-plots",
    ]);
    let o = run(&[
        "merge",
        dirs[1].to_str().unwrap(),
        out2.join("tiny").to_str().unwrap(),
        "--out",
        t.path().join("bad").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("different configs"), "{err}");
}

#[test]
fn a_changed_config_is_refused_for_an_existing_folder() {
    let t = tempfile::tempdir().unwrap();
    let small = CONFIG.replace("subjects = 3", "subjects = 2");
    let cfg = write_config(t.path(), &small);
    let out = t.path().join("out");
    let args = |c: &Path| {
        vec![
            "run".to_string(),
            c.to_str().unwrap().to_string(),
            "--out".into(),
            out.to_str().unwrap().to_string(),
            "--no-plots".into(),
        ]
    };
    let a = args(&cfg);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    ok(&a);
    let before = cases_without_timing(&out.join("tiny"));
    // Output-only changes are accepted (nothing recomputed) ...
    write_config(
        t.path(),
        &small.replace("render_poses = 1", "render_poses = 2"),
    );
    let o = run(&a);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 computed"));
    // ... a change of a method parameter is not.
    write_config(
        t.path(),
        &small.replace(
            "count = 4\n\n[[methods]]\nname = \"extremity\"",
            "count = 3\n\n[[methods]]\nname = \"extremity\"",
        ),
    );
    let o = run(&a);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("another configuration") && err.contains("methods[1].count"),
        "{err}"
    );
    assert_eq!(cases_without_timing(&out.join("tiny")), before);
}

#[test]
fn plot_command_calls_every_configured_plot() {
    let (_, ref_dir) = reference();
    // Work on a copy: plots/ is written into the folder.
    let t = tempfile::tempdir().unwrap();
    let dir = t.path().join("tiny");
    copy_dir(ref_dir, &dir);
    let o = run(&["plot", dir.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    // Default plots for transfer + clustering methods: each either exists
    // or is reported by name (the plot module may not be merged yet).
    for stem in [
        "cumulative",
        "bars_err_mean_unit",
        "panels_s0-t1-r0_1",
        "bars_ari_purity",
        "clusters_s0-t1-r0",
    ] {
        // The stub in src/plot names the stem it was asked to write; an
        // error of the harness before the call would not.
        let png = dir.join("plots").join(format!("{stem}.png"));
        let called = format!("{}: ", dir.join("plots").join(stem).display());
        assert!(
            png.is_file() || err.contains(&called),
            "plot {stem}: neither written nor handed to src/plot:\n{err}"
        );
    }
    assert!(!err.contains("panicked"), "{err}");
}

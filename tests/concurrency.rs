//! One writer per results folder (issue 18): two `deformlab run` processes
//! started together on one `--out` folder both succeed, compute every case
//! × method once between them and leave the tables of a single run; a
//! second run waits for the holder (naming its pid) or, with `--no-wait`,
//! stops with an error naming it; shards of one config run side by side in
//! one folder; stale temporaries are removed only by a process that has the
//! folder to itself.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Output, Stdio};
use std::time::{Duration, Instant};

use common::{csv_without_timing, deformlab, ok, tmp, write};
use deformlab::experiment::{FolderLock, Shard};

const NAME: &str = "concurrent";

/// 4 cases (subject 0 → 1, 2; one pose each) × 2 methods. Sized so that one
/// run lasts long enough (about 1.7 s) for the other, started just after it,
/// to find the folder held: with 10 candidates and 3 key points a run took
/// 0.5 s and on an idle machine the second often found everything already
/// stored (2 failures in 6 tries).
const CONFIG: &str = r#"
name = "concurrent"
seed = 3

[dataset.synthetic]
subjects = 3
poses = 3
resolution = 1

[cases]
sources = [0]
per_pose = true

[defaults]
mode = "fast"
n_candidates = 40
error_norm = "rms"
epsilon = 0.0
max_keypoints = 6
max_swap_passes = 0

[[methods]]
name = "auto"
kind = "bdt"

[[methods]]
name = "identity"
kind = "identity"
"#;

const N_RESULTS: usize = 8;

fn args(cfg: &Path, out: &Path, extra: &[&str]) -> Vec<String> {
    let mut a = vec![
        "run".to_string(),
        cfg.display().to_string(),
        "--out".into(),
        out.display().to_string(),
        "--threads".into(),
        "1".into(),
        "--no-plots".into(),
    ];
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

fn spawn(args: &[String]) -> Child {
    deformlab()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn deformlab")
}

/// Waits for a child, failing after `limit` (a hang is a failure).
fn finish(mut child: Child, limit: Duration) -> Output {
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            child.kill().unwrap();
            panic!("deformlab run did not finish within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// `computed` of the summary line `NAME: X computed, Y resumed, …`.
fn computed(stdout: &str) -> usize {
    let line = stdout
        .lines()
        .find(|l| l.starts_with(&format!("{NAME}: ")))
        .unwrap_or_else(|| panic!("no summary line in {stdout}"));
    line[NAME.len() + 2..]
        .split(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"))
}

/// Every file under `dir/cases/`: (result files, temporaries).
fn stored(dir: &Path) -> (Vec<PathBuf>, Vec<PathBuf>) {
    let (mut results, mut temps) = (Vec::new(), Vec::new());
    for case in std::fs::read_dir(dir.join("cases")).unwrap() {
        for f in std::fs::read_dir(case.unwrap().path()).unwrap() {
            let p = f.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            if name.starts_with('.') {
                temps.push(p);
            } else {
                results.push(p);
            }
        }
    }
    results.sort();
    (results, temps)
}

fn assert_tables_equal(dir: &Path, reference: &Path) {
    for t in ["cases.csv", "curves.csv", "summary.csv"] {
        assert_eq!(
            csv_without_timing(&dir.join(t)),
            csv_without_timing(&reference.join(t)),
            "{t} differs from a single run's"
        );
    }
}

fn manifest(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap()
}

/// A single uninterrupted run into `root/reference`; its experiment folder.
fn reference(root: &Path, cfg: &Path) -> PathBuf {
    let out = root.join("reference");
    ok(&args(cfg, &out, &[]));
    out.join(NAME)
}

const LIMIT: Duration = Duration::from_secs(600);

#[test]
fn two_runs_started_together_compute_each_case_once() {
    let d = tmp();
    let cfg = write(d.path(), "c.toml", CONFIG);
    let reference = reference(d.path(), &cfg);
    let out = d.path().join("both");
    let a = args(&cfg, &out, &[]);
    let (first, second) = (spawn(&a), spawn(&a));
    let pids = [first.id(), second.id()];
    let outs = [finish(first, LIMIT), finish(second, LIMIT)];
    for o in &outs {
        assert!(
            o.status.success(),
            "{}\n{}",
            text(&o.stdout),
            text(&o.stderr)
        );
    }
    // One computed everything, the other waited (naming the first) and
    // found everything stored.
    let done: Vec<usize> = outs.iter().map(|o| computed(&text(&o.stdout))).collect();
    assert_eq!(done.iter().sum::<usize>(), N_RESULTS, "{done:?}");
    let waiter = done
        .iter()
        .position(|&n| n == 0)
        .expect("one run computed nothing");
    let err = text(&outs[waiter].stderr);
    assert!(
        err.contains(&format!("in use by pid {} on ", pids[1 - waiter]))
            && err.contains("waiting for it to finish"),
        "{err}"
    );
    assert!(!text(&outs[1 - waiter].stderr).contains("waiting"));
    let dir = out.join(NAME);
    let (results, temps) = stored(&dir);
    assert_eq!(results.len(), N_RESULTS, "{results:?}");
    assert!(temps.is_empty(), "{temps:?}");
    assert_tables_equal(&dir, &reference);
    let m = manifest(&dir);
    let log = common::runs(&dir);
    let inv = log["invocations"].as_array().unwrap();
    assert_eq!(inv.len(), 2);
    let total: u64 = inv.iter().map(|i| i["computed"].as_u64().unwrap()).sum();
    assert_eq!(total as usize, N_RESULTS);
    assert_eq!(m["results_stored"], N_RESULTS);
}

#[test]
fn a_second_run_waits_for_the_holder_or_names_it() {
    let d = tmp();
    let cfg = write(d.path(), "c.toml", CONFIG);
    let out = d.path().join("out");
    let dir = out.join(NAME);
    std::fs::create_dir_all(&dir).unwrap();
    // This test process holds the folder, as a running `run` would.
    let held = FolderLock::for_run(&dir, None, false).unwrap();
    let me = std::process::id();
    let o = deformlab()
        .args(args(&cfg, &out, &["--no-wait"]))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains(&format!("in use by pid {me} on "))
            && err.contains("deformlab run")
            && err.contains("--no-wait"),
        "{err}"
    );
    assert!(!dir.join("cases").exists(), "nothing computed");
    // A shard waits too (the folder is held whole).
    let o = deformlab()
        .args(args(&cfg, &out, &["--no-wait", "--shard", "0/2"]))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    // Without --no-wait: it waits, says for whom, and runs once released.
    let child = spawn(&args(&cfg, &out, &[]));
    std::thread::sleep(Duration::from_millis(1500));
    assert!(!dir.join("cases").exists(), "ran while the folder was held");
    drop(held);
    let o = finish(child, LIMIT);
    let err = text(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(&format!("in use by pid {me} on ")) && err.contains("waiting"),
        "{err}"
    );
    assert_eq!(computed(&text(&o.stdout)), N_RESULTS);
}

#[test]
fn shards_of_one_config_run_side_by_side_in_one_folder() {
    let d = tmp();
    let cfg = write(d.path(), "c.toml", CONFIG);
    let reference = reference(d.path(), &cfg);
    let out = d.path().join("shards");
    let children = [
        spawn(&args(&cfg, &out, &["--shard", "0/2"])),
        spawn(&args(&cfg, &out, &["--shard", "1/2"])),
    ];
    let outs: Vec<Output> = children.into_iter().map(|c| finish(c, LIMIT)).collect();
    let mut total = 0;
    for o in &outs {
        let err = text(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert!(
            !err.contains("waiting"),
            "shards waited for each other: {err}"
        );
        total += computed(&text(&o.stdout));
    }
    assert_eq!(total, N_RESULTS);
    let dir = out.join(NAME);
    let (results, temps) = stored(&dir);
    assert_eq!(results.len(), N_RESULTS);
    assert!(temps.is_empty(), "{temps:?}");
    // The shard that finished last rebuilt the tables from everything.
    assert_tables_equal(&dir, &reference);
    let m = manifest(&dir);
    assert_eq!(m["shards"].as_array().map(|s| s.len()), Some(2), "{m}");
    // The same shard twice at once: the second waits for the first.
    let again = [
        spawn(&args(&cfg, &out, &["--shard", "1/2"])),
        spawn(&args(&cfg, &out, &["--shard", "1/2", "--no-wait"])),
    ];
    for o in again.into_iter().map(|c| finish(c, LIMIT)) {
        let err = text(&o.stderr);
        // Either it found the shard free (the other had finished) or it
        // was refused naming the holder.
        assert!(
            o.status.success() || (err.contains("in use by pid") && err.contains("shard-1-of-2")),
            "{err}"
        );
    }
}

#[test]
fn stale_temporaries_are_removed_only_by_a_lone_writer() {
    let d = tmp();
    let cfg = write(d.path(), "c.toml", CONFIG);
    let out = d.path().join("out");
    let dir = out.join(NAME);
    std::fs::create_dir_all(dir.join("cases/s0-t1-p1")).unwrap();
    std::fs::create_dir_all(dir.join("meshes/s0-t1-p1")).unwrap();
    // A live shard (this process) holds the folder shared.
    let shard = FolderLock::for_run(&dir, Some(Shard { index: 1, count: 2 }), true).unwrap();
    let planted = [
        dir.join("cases/s0-t1-p1/.auto.json.4242-0badcafe.0.tmp"),
        dir.join("meshes/s0-t1-p1/result_6.ply.tmp"),
        dir.join("meshes/s0-t1-p1/.result_6.ply.4242-0badcafe.1.tmp"),
        dir.join(".cases.csv.4242-0badcafe.2.tmp"),
    ];
    for p in &planted {
        std::fs::write(p, b"partial").unwrap();
    }
    // Another shard beside it: may not touch them (they could be the live
    // shard's).
    let o = deformlab()
        .args(args(&cfg, &out, &["--shard", "0/2"]))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    for p in &planted {
        assert!(p.exists(), "{} removed beside a live writer", p.display());
    }
    drop(shard);
    // Alone in the folder: they are removed.
    let o = deformlab().args(args(&cfg, &out, &[])).output().unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    for p in &planted {
        assert!(!p.exists(), "{} left behind", p.display());
    }
    let (results, temps) = stored(&dir);
    assert_eq!(results.len(), N_RESULTS);
    assert!(temps.is_empty(), "{temps:?}");
}

//! Scaffolding shared by the integration tests (`mod common;` in each test
//! file): the built `deformlab` binary (also with a time limit, and as a
//! clear failure: no panic, key phrases in stderr), temporary folders,
//! small files and configs, result CSVs without their timing columns,
//! folder copies.
//!
//! Real data: `deformlab::data::shared_data_or_skip` (the
//! `DEFORMLAB_SHARED_DATA` or `../shared/data` folder, or `None` after
//! printing `SKIP <test>: ...`).
//!
//! Each test binary compiles its own copy of this module and uses only part
//! of it, hence the `dead_code` allowance.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::ffi::OsStr;
use std::fmt::Debug;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// The `deformlab` binary built for these tests.
pub const BIN: &str = env!("CARGO_BIN_EXE_deformlab");

/// The binary as a command, without a `DEFORMLAB_RUN_MAX_NEW` inherited
/// from the environment (it would stop `run` early).
pub fn deformlab() -> Command {
    let mut c = Command::new(BIN);
    c.env_remove("DEFORMLAB_RUN_MAX_NEW");
    c
}

/// Runs the binary with `args` to the end and returns its output.
pub fn run<S: AsRef<OsStr>>(args: &[S]) -> Output {
    deformlab().args(args).output().expect("spawn deformlab")
}

/// Runs the binary with `args` and a time limit: a child still running
/// after `limit` is killed and the test fails naming the arguments (a
/// hang). Stdin is closed, so nothing waits for input.
#[track_caller]
pub fn run_limited<S: AsRef<OsStr> + Debug>(args: &[S], limit: Duration) -> Output {
    use std::io::Read;
    use std::process::Stdio;
    let mut child = deformlab()
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn deformlab");
    // Drain both pipes meanwhile, so a chatty child never blocks on them.
    let drain = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut buf);
            }
            buf
        })
    };
    let out = drain(
        child
            .stdout
            .take()
            .map(|p| Box::new(p) as Box<dyn Read + Send>),
    );
    let err = drain(
        child
            .stderr
            .take()
            .map(|p| Box::new(p) as Box<dyn Read + Send>),
    );
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for deformlab") {
            break status;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("deformlab {args:?} still running after {limit:?}: killed (a hang)");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Output {
        status,
        stdout: out.join().unwrap_or_default(),
        stderr: err.join().unwrap_or_default(),
    }
}

/// The time limit of [`cli_err`]: every hostile input must be refused well
/// within it.
pub const LIMIT: Duration = Duration::from_secs(60);

/// Runs the CLI (within [`LIMIT`]) expecting a clear failure: exit code ≠ 0,
/// not a panic (exit code 101 and "panicked" are refused), stderr
/// mentioning every needle. Returns stderr.
#[track_caller]
pub fn cli_err<S: AsRef<OsStr> + Debug>(args: &[S], needles: &[&str]) -> String {
    let o = run_limited(args, LIMIT);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "deformlab {args:?} succeeded: {err}");
    assert_ne!(
        o.status.code(),
        Some(101),
        "deformlab {args:?} panicked: {err}"
    );
    assert!(
        !err.contains("panicked"),
        "deformlab {args:?} panicked: {err}"
    );
    for n in needles {
        assert!(
            err.contains(n),
            "stderr of {args:?} does not mention {n:?}: {err}"
        );
    }
    err
}

/// Like [`run`], asserting success (the failure message shows the arguments,
/// stdout and stderr).
#[track_caller]
pub fn ok<S: AsRef<OsStr> + Debug>(args: &[S]) -> Output {
    let o = run(args);
    assert!(
        o.status.success(),
        "deformlab {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// Asserts that a finished run succeeded (the failure message shows stdout
/// and stderr) and returns its stdout.
#[track_caller]
pub fn stdout_ok(out: &Output) -> String {
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// `dir/timings/runs.json` of a results folder: the invocations (start,
/// wall time, threads, revision, computed, reused) and seconds per method.
pub fn runs(dir: &Path) -> serde_json::Value {
    let p = dir.join("timings/runs.json");
    serde_json::from_str(
        &std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())),
    )
    .unwrap()
}

/// Writes a synthetic FAUST-style folder (`tr_reg_XXX.ply`, resolution 1,
/// 1682 vertices) of `subjects` × `poses` meshes into `dir`.
pub fn synthetic_faust(dir: &Path, subjects: usize, poses: usize) {
    use deformlab::data::synthetic::{write_faust_style, FaustStyle};
    let set = FaustStyle {
        subjects,
        poses,
        resolution: 1,
        ..FaustStyle::default()
    }
    .generate()
    .unwrap();
    write_faust_style(dir, &set).unwrap();
}

/// A fresh temporary folder, removed when dropped.
pub fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().expect("temp dir")
}

/// Writes `dir/name` (creating `dir` if needed) and returns its path: mesh
/// files, tiny configs, correspondence files.
pub fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Copies the folder `from` to `to`, recursively.
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

/// The rows of a CSV file as maps column name → cell. A `cases.csv` holds
/// only the columns with a value in some row: every other column of
/// `deformlab::experiment::CASE_COLUMNS` is added as an empty cell, as the
/// readers of the project treat it.
pub fn csv_rows(path: &Path) -> Vec<BTreeMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let head = r.headers().unwrap().clone();
    let cases = path.file_name().is_some_and(|n| n == "cases.csv");
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            let mut row: BTreeMap<String, String> = head
                .iter()
                .zip(rec.iter())
                .map(|(h, c)| (h.to_string(), c.to_string()))
                .collect();
            if cases {
                for c in deformlab::experiment::CASE_COLUMNS {
                    row.entry(c.to_string()).or_default();
                }
            }
            row
        })
        .collect()
}

/// A CSV (header first) with the columns named `seconds_*` removed, and the
/// rows whose `metric` column (summary.csv) names a `seconds_*` column.
pub fn csv_without_timing(path: &Path) -> Vec<Vec<String>> {
    without_timing(path, true).0
}

/// `dir/cases.csv` as text, byte for byte: it holds no timing column
/// (`seconds_*`); they are in `dir/timings/cases.csv`, which must have some.
pub fn cases_without_timing(dir: &Path) -> String {
    let (_, dropped) = without_timing(&dir.join("cases.csv"), false);
    assert_eq!(dropped, 0, "cases.csv holds timing columns");
    let (_, timings) = without_timing(&dir.join("timings/cases.csv"), false);
    assert!(timings > 0, "timing columns expected in timings/cases.csv");
    std::fs::read_to_string(dir.join("cases.csv")).unwrap()
}

/// The rows of a CSV (header first) without its `seconds_*` columns (and,
/// with `timing_metrics`, without the rows whose `metric` is a `seconds_*`
/// column), and the number of columns removed.
fn without_timing(path: &Path, timing_metrics: bool) -> (Vec<Vec<String>>, usize) {
    let mut rdr = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| !header[i].starts_with("seconds_"))
        .collect();
    let metric = header
        .iter()
        .position(|h| h == "metric")
        .filter(|_| timing_metrics);
    let mut rows = vec![keep.iter().map(|&i| header[i].clone()).collect::<Vec<_>>()];
    for rec in rdr.records() {
        let rec = rec.unwrap();
        if metric.is_some_and(|m| rec[m].starts_with("seconds_")) {
            continue;
        }
        rows.push(keep.iter().map(|&i| rec[i].to_string()).collect());
    }
    (rows, header.len() - keep.len())
}

/// Options of a library `run_configs` call: `threads` workers into `out`,
/// plots and progress off, waiting for a busy folder.
pub fn quiet_run(out: PathBuf, threads: usize) -> deformlab::experiment::RunOptions {
    deformlab::experiment::RunOptions {
        out,
        threads,
        shard: None,
        plots: false,
        progress: false,
        max_new: None,
        wait: true,
        defects: Default::default(),
        load: Default::default(),
        force: false,
        retry_failed: false,
    }
}

/// A small FBT completion config on the synthetic set (one class, six
/// shapes; q examples, targets `poses`, e.g. `"[3]"`).
pub fn tiny_fbt_completion(name: &str, q: usize, poses: &str) -> String {
    format!(
        r#"
name = "{name}"
seed = 0
[dataset.synthetic]
subjects = 1
poses = 6
resolution = 1
[cases]
targets = []
include_self = true
per_pose = true
reference_pose = "rest"
poses = {poses}
[[methods]]
name = "completion"
kind = "fbt"
fbt = {{ task = "completion", q = {q}, nicp_iterations = 2, queries = 50 }}
"#
    )
}

/// A small BDT transfer config on the synthetic set (subject 0 → 1, the
/// poses `poses` in one case; fast selection from 40 candidates), with the
/// `identity` floor when `floor`.
/// Writes `text` as `dir/<name>.toml` and runs it into `dir/out`; returns
/// its results folder `dir/out/<name>` (`name` is the config's name).
#[track_caller]
pub fn run_config(dir: &Path, name: &str, text: &str) -> PathBuf {
    let cfg = write(dir, &format!("{name}.toml"), text);
    let out = dir.join("out");
    ok(&[
        "run",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    out.join(name)
}

pub fn tiny_bdt(name: &str, poses: &str, floor: bool) -> String {
    let identity = if floor {
        "[[methods]]\nname = \"identity\"\nkind = \"identity\"\n"
    } else {
        ""
    };
    format!(
        r#"
name = "{name}"
seed = 0
[dataset.synthetic]
subjects = 2
poses = 3
resolution = 1
[cases]
sources = [0]
targets = [1]
poses = {poses}
[defaults]
mode = "fast"
n_candidates = 40
[[methods]]
name = "bdt"
kind = "bdt"
{identity}"#
    )
}

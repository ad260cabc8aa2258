//! A results folder nobody can subvert (issue 40, first class): a symbolic
//! link or a FIFO planted where a lock file goes is refused with an error
//! naming it; the run neither writes through the link (an unrelated file
//! stays intact, a dangling link creates nothing) nor blocks on the FIFO.

#![cfg(unix)]

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_deformlab");

fn config(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("tiny.toml");
    std::fs::write(
        &p,
        "name = \"tiny\"\n[dataset.synthetic]\nsubjects = 2\nposes = 2\nresolution = 1\n\
         [cases]\nsources = [0]\n[[methods]]\nname = \"id\"\nkind = \"identity\"\n",
    )
    .unwrap();
    p
}

/// Runs the config into `out` with a time limit; (success, stderr).
fn run(cfg: &Path, out: &Path) -> (bool, String) {
    let mut child = Command::new(BIN)
        .args(["run", cfg.to_str().unwrap(), "--no-plots", "--out"])
        .arg(out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            use std::io::Read;
            child
                .stderr
                .take()
                .unwrap()
                .read_to_string(&mut err)
                .unwrap();
            return (status.success(), err);
        }
        if start.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("the run blocked (a FIFO or a link in the results folder)");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_link_planted_as_the_lock_is_refused_and_not_followed() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path());
    let out = t.path().join("out");
    let folder = out.join("tiny");
    std::fs::create_dir_all(&folder).unwrap();
    let victim = t.path().join("victim.txt");
    std::fs::write(&victim, "precious").unwrap();
    std::os::unix::fs::symlink(&victim, folder.join(".lock")).unwrap();
    let (ok, err) = run(&cfg, &out);
    assert!(!ok, "the run went through a planted link");
    assert!(
        err.contains(".lock") && err.contains("symbolic link"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious");

    // A dangling link: nothing is created where it points.
    std::fs::remove_file(folder.join(".lock")).unwrap();
    let elsewhere = t.path().join("elsewhere");
    std::os::unix::fs::symlink(&elsewhere, folder.join(".lock")).unwrap();
    let (ok, err) = run(&cfg, &out);
    assert!(!ok && err.contains("symbolic link"), "{err}");
    assert!(!elsewhere.exists(), "the run created the link's target");

    // Removed, the run goes through.
    std::fs::remove_file(folder.join(".lock")).unwrap();
    let (ok, err) = run(&cfg, &out);
    assert!(ok, "{err}");
}

#[test]
fn a_fifo_planted_as_the_lock_is_refused_without_blocking() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path());
    let out = t.path().join("out");
    let folder = out.join("tiny");
    std::fs::create_dir_all(&folder).unwrap();
    let fifo = folder.join(".lock");
    let made = Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("SKIP: mkfifo is not available here");
        return;
    }
    let (ok, err) = run(&cfg, &out);
    assert!(
        !ok && err.contains(".lock") && err.contains("not a regular file"),
        "{err}"
    );
}

/// A FIFO made at `p` (false when `mkfifo` is missing: the test skips).
fn mkfifo(p: &Path) -> bool {
    let made = Command::new("mkfifo").arg(p).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("SKIP: mkfifo is not available here");
        return false;
    }
    true
}

#[test]
fn fifos_where_the_store_reads_are_refused_without_blocking() {
    // Before: a FIFO at manifest.json, config.json or a case result made
    // the run wait forever on its first read.
    for file in ["manifest.json", "config.json", "cases/s0-t1-r0/id.json"] {
        let t = tempfile::tempdir().unwrap();
        let cfg = config(t.path());
        let out = t.path().join("out");
        let (ok, err) = run(&cfg, &out);
        assert!(ok, "{err}");
        let p = out.join("tiny").join(file);
        std::fs::remove_file(&p).unwrap();
        if !mkfifo(&p) {
            return;
        }
        let (ok, err) = run(&cfg, &out);
        assert!(!ok, "{file}: {err}");
        assert!(
            err.contains(file.rsplit('/').next().unwrap()) && err.contains("not a regular file"),
            "{file}: {err}"
        );
    }
}

#[test]
fn a_link_planted_as_a_result_is_refused_and_not_read() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path());
    let out = t.path().join("out");
    let (ok, err) = run(&cfg, &out);
    assert!(ok, "{err}");
    let p = out.join("tiny/cases/s0-t1-r0/id.json");
    let elsewhere = t.path().join("elsewhere.json");
    std::fs::rename(&p, &elsewhere).unwrap();
    std::os::unix::fs::symlink(&elsewhere, &p).unwrap();
    let (ok, err) = run(&cfg, &out);
    assert!(
        !ok && err.contains("id.json") && err.contains("symbolic link"),
        "{err}"
    );
}

#[test]
fn stray_copies_are_not_counted_and_corrupt_results_are_recomputed() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path());
    let out = t.path().join("out");
    let (ok, err) = run(&cfg, &out);
    assert!(ok, "{err}");
    let folder = out.join("tiny");
    let rows = |f: &Path| {
        std::fs::read_to_string(f.join("cases.csv"))
            .unwrap()
            .lines()
            .count()
            - 1
    };
    let n = rows(&folder);
    // A copy of a result under another name: not a second row (before:
    // the summary counted it).
    let case = folder.join("cases/s0-t1-r0");
    std::fs::copy(case.join("id.json"), case.join("id (copy).json")).unwrap();
    let (ok, err) = run(&cfg, &out);
    assert!(ok, "{err}");
    assert_eq!(rows(&folder), n, "{err}");
    assert!(
        err.contains("id (copy).json") && err.contains("not counted"),
        "{err}"
    );
    // A truncated result: moved aside with a warning and computed again
    // (before: the whole run stopped on it).
    let r = case.join("id.json");
    let text = std::fs::read_to_string(&r).unwrap();
    std::fs::write(&r, &text[..text.len() / 2]).unwrap();
    let (ok, err) = run(&cfg, &out);
    assert!(ok, "{err}");
    assert!(
        err.contains("not a result") && err.contains("computed again"),
        "{err}"
    );
    assert_eq!(rows(&folder), n, "{err}");
    assert!(folder.join("corrupt/s0-t1-r0/id.json").is_file());
    // Recomputed: the same numbers, timings aside.
    let strip = |t: &str| -> String {
        t.split(',')
            .filter(|c| !c.contains("seconds_"))
            .collect::<Vec<_>>()
            .join(",")
    };
    assert_eq!(strip(&std::fs::read_to_string(&r).unwrap()), strip(&text));
}

#[test]
fn a_write_failure_in_the_results_folder_is_not_a_method_failure() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path());
    let out = t.path().join("out");
    // Where the method's render meshes go, a file: writing them fails (as
    // on a full disk). Before, the row was stored as the method's failure
    // and a plain re-run kept it.
    let blocked = out.join("tiny/meshes/s0-t1-r0/id");
    std::fs::create_dir_all(blocked.parent().unwrap()).unwrap();
    std::fs::write(&blocked, b"not a folder").unwrap();
    let (ok, err) = run(&cfg, &out);
    assert!(!ok && err.contains("meshes/s0-t1-r0/id"), "{err}");
    assert!(!out.join("tiny/cases/s0-t1-r0/id.json").exists(), "{err}");
    // The cause removed, a plain re-run computes the row.
    std::fs::remove_file(&blocked).unwrap();
    let (ok, err) = run(&cfg, &out);
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(out.join("tiny/cases/s0-t1-r0/id.json")).unwrap();
    assert!(text.contains("\"status\":\"ok\""), "{text}");
}

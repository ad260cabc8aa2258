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

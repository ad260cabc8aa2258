//! Runs under an address-space limit (`ulimit -v`, as batch schedulers set
//! it). faer's dense kernels reserve a buffer of 2 × L3 per thread on its
//! first product ([`deformlab::solve::address`]): mostly untouched, so a
//! run that needs ~33 MB resident aborted (SIGABRT, "memory allocation of
//! … bytes failed") once a few workers had reserved theirs. Now a run uses
//! as many workers as fit, saying so, or stops at once naming the limit.
#![cfg(target_os = "linux")]

mod common;

use std::process::Command;

use common::{tiny_bdt, tiny_fbt_completion, write};
use deformlab::solve::address::dense_buffer_per_thread;

/// `deformlab run` of both configs with `threads` under `ulimit -v kib`.
fn run_limited(kib: u64, threads: usize) -> (std::process::Output, tempfile::TempDir) {
    let t = tempfile::tempdir().unwrap();
    let f = write(
        t.path(),
        "fbt.toml",
        tiny_fbt_completion("fbt-limit", 3, "[2, 3, 4]"),
    );
    let b = write(t.path(), "bdt.toml", tiny_bdt("bdt-limit", "[1, 2]", true));
    let out = t.path().join("results");
    let script = format!(
        "ulimit -v {kib} && exec \"$0\" run \"$1\" \"$2\" --out \"$3\" --threads {threads}"
    );
    let o = Command::new("sh")
        .arg("-c")
        .arg(script)
        .arg(env!("CARGO_BIN_EXE_deformlab"))
        .arg(&f)
        .arg(&b)
        .arg(&out)
        .output()
        .expect("spawn sh");
    (o, t)
}

fn rows(dir: &std::path::Path) -> usize {
    std::fs::read_to_string(dir.join("cases.csv"))
        .map(|s| s.lines().count().saturating_sub(1))
        .unwrap_or(0)
}

#[test]
fn runs_fit_their_workers_in_an_address_space_limit() {
    // The acceptance limit (1.5 GiB) with two workers: both experiments
    // complete.
    let (o, t) = run_limited(1_572_864, 2);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "1.5 GiB, 2 threads: {err}");
    let res = t.path().join("results");
    assert_eq!(rows(&res.join("fbt-limit")), 3, "{err}");
    assert_eq!(rows(&res.join("bdt-limit")), 2, "{err}");

    // Room for about two workers but eight asked: before, the third
    // worker's first dense product aborted the run; now it runs with the
    // workers that fit and says so.
    let buffer = dense_buffer_per_thread() >> 10;
    let kib = 160 * 1024 + buffer + 2 * (buffer + 16 * 1024) + 8 * 1024;
    let (o, t) = run_limited(kib, 8);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{kib} KiB, 8 threads: {err}");
    assert!(
        err.contains("ulimit -v") && err.contains("of the 8 threads"),
        "{err}"
    );
    let res = t.path().join("results");
    assert_eq!(rows(&res.join("bdt-limit")), 2, "{err}");

    // No room for a worker: a clear error at once, naming the limit.
    let (o, _t) = run_limited(96 * 1024, 2);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("address-space limit (ulimit -v) of 96 MiB") && !err.contains("allocation"),
        "{err}"
    );
}

/// The commands outside `run` use the global thread pool (key point
/// candidates, transfers): with room for about two threads and eight asked
/// (`RAYON_NUM_THREADS`), `keypoints` and `transfer` aborted in a thread's
/// first dense product ("memory allocation of … bytes failed"); now they
/// run with the threads that fit and say so.
#[test]
fn commands_fit_the_global_pool_in_an_address_space_limit() {
    let t = tempfile::tempdir().unwrap();
    common::synthetic_faust(t.path(), 1, 3);
    let mesh = |i: usize| t.path().join(format!("tr_reg_00{i}.ply"));
    let buffer = dense_buffer_per_thread() >> 10;
    let kib = 160 * 1024 + buffer + 2 * (buffer + 16 * 1024) + 8 * 1024;
    let limited = |args: &[&std::ffi::OsStr]| {
        Command::new("sh")
            .arg("-c")
            .arg(format!("ulimit -v {kib} && exec \"$@\""))
            .arg("sh")
            .arg(env!("CARGO_BIN_EXE_deformlab"))
            .args(args)
            .env("RAYON_NUM_THREADS", "8")
            .output()
            .expect("spawn sh")
    };
    let (a, a1, a2) = (mesh(0), mesh(1), mesh(2));
    let out = t.path().join("out");
    for args in [
        vec![
            "keypoints".as_ref(),
            "--source".as_ref(),
            a.as_os_str(),
            "--deformed".as_ref(),
            a1.as_os_str(),
            a2.as_os_str(),
            "--max-keypoints".as_ref(),
            "3".as_ref(),
        ],
        vec![
            "transfer".as_ref(),
            "--source".as_ref(),
            a.as_os_str(),
            "--deformed".as_ref(),
            a1.as_os_str(),
            "--target".as_ref(),
            a2.as_os_str(),
            "--same-connectivity".as_ref(),
            "--max-keypoints".as_ref(),
            "3".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
    ] {
        let o = limited(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{kib} KiB, {:?}: {err}", args[0]);
        assert!(
            err.contains("ulimit -v") && err.contains("of the 8 threads"),
            "{err}"
        );
    }
    assert!(out.join("tr_reg_001_to_tr_reg_002.ply").is_file());
}

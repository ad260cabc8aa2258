//! Every expansion is bounded and counted before any work: a sweep's
//! methods, `repeat` × cases, and key point files — each refused at once
//! with the count and the limit (before, three sweep axes of 100 values and
//! a 1,001-row key point file ran silently for minutes).

mod common;

use std::time::Duration;

use common::{cli_err, run_limited, tmp, write};
use deformlab::mesh::io::write_ply;
use deformlab::mesh::primitives::icosphere;

/// The command is refused within `secs` seconds, its stderr containing
/// every needle.
fn refused_quickly(args: &[&str], secs: u64, needles: &[&str]) {
    let o = run_limited(args, Duration::from_secs(secs));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for n in needles {
        assert!(err.contains(n), "missing {n:?} in: {err}");
    }
}

#[test]
fn a_sweep_of_a_million_methods_is_refused_at_once() {
    let d = tmp();
    let values: Vec<String> = (0..100)
        .map(|i| format!("{}", 0.001 * (i + 1) as f64))
        .collect();
    let list = values.join(", ");
    let ints = (1..=100)
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    let cfg = write(
        d.path(),
        "sweep.toml",
        format!(
            r#"name = "huge"
[dataset.synthetic]
subjects = 2
poses = 2
resolution = 1
[cases]
sources = [0]
[[methods]]
name = "bdt"
kind = "bdt"
[sweep]
"methods.bdt.epsilon" = [{list}]
"methods.bdt.lambda" = [{list}]
"methods.bdt.n_candidates" = [{ints}]
"#
        ),
    );
    let out = d.path().join("out");
    refused_quickly(
        &["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()],
        30,
        &["makes 1000000 methods", "at most 1000"],
    );
    assert!(!out.join("huge").exists());
}

#[test]
fn repeat_beyond_a_million_cases_is_refused_at_once() {
    let d = tmp();
    let cfg = write(
        d.path(),
        "repeat.toml",
        r#"name = "many"
[dataset.synthetic]
subjects = 12
poses = 10
resolution = 1
[cases]
per_pose = true
repeat = 1000
[[methods]]
name = "identity"
kind = "identity"
"#,
    );
    let out = d.path().join("out");
    refused_quickly(
        &["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()],
        60,
        &["repeat = 1000", "at most 1000000"],
    );
}

#[test]
fn a_key_point_file_beyond_the_limit_is_refused_at_once() {
    let d = tmp();
    let m = icosphere(4); // 2562 vertices: every row a valid vertex
    let pa = d.path().join("a.ply");
    write_ply(&pa, &m).unwrap();
    let rows: Vec<String> = (0..1001).map(|i| i.to_string()).collect();
    let kp = write(d.path(), "kp.csv", format!("source\n{}\n", rows.join("\n")));
    let out = d.path().join("out");
    cli_err(
        &[
            "transfer",
            "--source",
            pa.to_str().unwrap(),
            "--deformed",
            pa.to_str().unwrap(),
            "--target",
            pa.to_str().unwrap(),
            "--same-connectivity",
            "--keypoints",
            kp.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["kp.csv", "more than 1000 key points", "1001 key point rows"],
    );
}

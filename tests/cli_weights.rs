//! `deformlab weights`: the CLI's bounded biharmonic weights equal the
//! library's (same defaults), satisfy Eq. 1's constraints, and bad input is
//! a clear error.

mod common;

use common::deformlab;
use deformlab::mesh::io::write_ply as write_mesh;
use deformlab::mesh::primitives::icosphere;
use deformlab::skin::bbw::{BbwOptions, Biharmonic, WeightMode};

fn read_csv(path: &std::path::Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

#[test]
fn cli_weights_equal_the_library_and_meet_eq1() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = icosphere(3);
    let path = dir.path().join("sphere.ply");
    write_mesh(&path, &mesh).unwrap();
    let handles = [0usize, 200, 400, 600];
    let csv = dir.path().join("w.csv");
    // `deformlab weights sphere.ply --handle-vertices … [extra] --out csv`;
    // its stdout, after checking it succeeded.
    let run = |extra: &[&str], csv: &std::path::Path| -> String {
        let out = deformlab()
            .arg("weights")
            .arg(&path)
            .args(["--handle-vertices", "0,200,400,600"])
            .args(extra)
            .arg("--out")
            .arg(csv)
            .output()
            .unwrap();
        common::stdout_ok(&out)
    };
    let stdout = run(&[], &csv);
    assert!(stdout.contains("mode: PerHandle"), "{stdout}");
    assert!(stdout.contains("converged true"), "{stdout}");
    let w = read_csv(&csv);
    assert_eq!(w.len(), mesh.n_vertices());
    // The library with its defaults (the CLI passes no option).
    let lib = Biharmonic::new(&mesh)
        .unwrap()
        .weights(&handles, &BbwOptions::default())
        .unwrap();
    // One weight-mode default: the weights command, key point selection
    // and transfer (and so the configs) share it.
    assert_eq!(BbwOptions::default().mode, WeightMode::PerHandle);
    assert_eq!(
        deformlab::transfer::KeypointOptions::default().weights,
        BbwOptions::default()
    );
    assert_eq!(
        deformlab::transfer::TransferOptions::default().weights,
        BbwOptions::default()
    );
    let mut max_diff: f64 = 0.0;
    for (i, row) in w.iter().enumerate() {
        assert_eq!(row.len(), handles.len());
        let sum: f64 = row.iter().sum();
        assert!((sum - 1.0).abs() < 1e-12, "row {i} sums to {sum}");
        assert!(
            row.iter().all(|&x| (0.0..=1.0).contains(&x)),
            "row {i}: {row:?}"
        );
        for (k, &x) in row.iter().enumerate() {
            max_diff = max_diff.max((x - lib[(i, k)]).abs());
        }
    }
    assert!(
        max_diff < 1e-15,
        "CLI and library weights differ by {max_diff}"
    );
    for (k, &h) in handles.iter().enumerate() {
        for (c, &x) in w[h].iter().enumerate() {
            assert_eq!(x, if c == k { 1.0 } else { 0.0 }, "handle {h}");
        }
    }
    // Bounded weights are local: on a sphere with 4 spread handles, some
    // weights are exactly zero (an unbounded solution would be negative).
    assert!(w.iter().flatten().any(|&x| x == 0.0));

    // Local refinement off: the library's weights with local_hops = 0 (to
    // the last bit), no local iteration reported, and weights within the
    // active-set tolerance of the default (refined) ones.
    let off_csv = dir.path().join("w_off.csv");
    let stdout = run(
        &["--local-hops", "0", "--coupled-local-hops", "0"],
        &off_csv,
    );
    assert!(
        stdout.contains("local refinement iterations: 0 (regions within 0 / 0 steps"),
        "{stdout}"
    );
    let off = read_csv(&off_csv);
    let lib_off = Biharmonic::new(&mesh)
        .unwrap()
        .weights(
            &handles,
            &BbwOptions {
                local_hops: 0,
                coupled_local_hops: 0,
                ..BbwOptions::default()
            },
        )
        .unwrap();
    let (mut to_lib, mut to_refined) = (0.0f64, 0.0f64);
    for (i, row) in off.iter().enumerate() {
        for (k, &x) in row.iter().enumerate() {
            to_lib = to_lib.max((x - lib_off[(i, k)]).abs());
            to_refined = to_refined.max((x - w[i][k]).abs());
        }
    }
    assert!(
        to_lib < 1e-15,
        "CLI and library differ by {to_lib} without refinement"
    );
    assert!(
        to_refined < 1e-5,
        "refinement moved the weights by {to_refined}"
    );

    // The same file again: refused without --force.
    let out = deformlab()
        .arg("weights")
        .arg(&path)
        .args(["--handles", "3", "--out"])
        .arg(&csv)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--force"));
}

#[test]
fn cli_weights_refuses_bad_handles_and_paths() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sphere.ply");
    write_mesh(&path, &icosphere(2)).unwrap();
    let out = deformlab()
        .arg("weights")
        .arg(&path)
        .args(["--handle-vertices", "0,99999"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("vertex 99999 out of range"), "{err}");
    assert!(err.contains("sphere.ply"), "{err}");
    let out = deformlab()
        .arg("weights")
        .arg(&path)
        .args(["--handles", "0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--handles"));
    let out = deformlab()
        .arg("weights")
        .arg(dir.path().join("missing.ply"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.ply"));
}

/// Output piped into a reader that has gone (`deformlab weights … | head
/// -1`) ends the process quietly, not with a panic in `println!`; the same
/// run into an open pipe succeeds (so the check can fail).
#[test]
fn closed_stdout_pipe_is_not_a_panic() {
    use std::process::Stdio;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sphere.ply");
    write_mesh(&path, &icosphere(2)).unwrap();
    let run = |close: bool| {
        let mut child = deformlab()
            .arg("weights")
            .arg(&path)
            .args(["--handle-vertices", "0,20,40"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        if close {
            drop(child.stdout.take());
        }
        child.wait_with_output().unwrap()
    };
    let open = run(false);
    assert!(open.status.success());
    assert!(String::from_utf8_lossy(&open.stdout).contains("handles: 3"));
    let closed = run(true);
    let stderr = String::from_utf8_lossy(&closed.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

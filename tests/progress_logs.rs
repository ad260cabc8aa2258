//! Progress in logs (stderr not a terminal): a long row or a long step is
//! never silent — a "still working" line at least every heartbeat period
//! (30 s; 1 s here through `DEFORMLAB_HEARTBEAT_SECONDS`) — and the ETA of
//! the row lines is the mean pace of the rows done (`?` before the first).

mod common;

use common::{deformlab, write};

#[test]
fn a_long_row_prints_heartbeats_and_a_sane_eta() {
    let t = tempfile::tempdir().unwrap();
    let cfg = write(
        t.path(),
        "slow.toml",
        r#"name = "slow"
[dataset.synthetic]
subjects = 2
poses = 2
resolution = 1
[cases]
sources = [0]
[[methods]]
name = "identity"
kind = "identity"
[[methods]]
name = "slow"
kind = "external"
command = "sh -c 'sleep 4' sh {out}"  # no result: the row fails after 4 s
"#,
    );
    let o = deformlab()
        .env("DEFORMLAB_HEARTBEAT_SECONDS", "1")
        .args(["run", cfg.to_str().unwrap(), "--threads", "1", "--out"])
        .arg(t.path().join("results"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    // The slow method writes no result (its row fails; the run ends).
    assert!(o.status.code().is_some(), "{err}");
    assert!(err.contains("slow [2/2]"), "{err}");
    // The 4 s row: heartbeats while it runs, naming the rows done.
    let beats: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("slow: still working after"))
        .collect();
    assert!(beats.len() >= 2, "{err}");
    assert!(beats.iter().all(|l| l.contains("rows done")), "{err}");
    // Row lines: an ETA in seconds, minutes or hours, never years.
    for l in err.lines().filter(|l| l.starts_with("slow [")) {
        let eta = l.rsplit("ETA ").next().unwrap().trim_end_matches(')');
        assert!(
            eta == "?" || eta.ends_with(" s") || eta.ends_with(" min") || eta.ends_with(" h"),
            "{l}"
        );
    }
}

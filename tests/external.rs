//! External methods (`kind = "external"`): a command run per case, its
//! meshes read back and evaluated like a built-in method's; a command that
//! fails, hangs past its timeout or writes a wrong vertex count fails that
//! case only, with a clear message, and the other cases still run.

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_deformlab");

fn rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let h = r.headers().unwrap().clone();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            h.iter()
                .zip(rec.iter())
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect()
        })
        .collect()
}

fn have_python3() -> bool {
    Command::new("python3")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The example config (experiments/examples/own-method.toml): the example
/// script runs, appears in cases.csv, summary.csv and the plots, and scores
/// between the oracle and the floor as a translation should.
#[test]
fn the_example_external_method_is_evaluated_like_a_builtin_one() {
    if !have_python3() {
        eprintln!("SKIP: no python3 on this machine (the example method is a Python script)");
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let t = tempfile::tempdir().unwrap();
    let o = Command::new(BIN)
        .current_dir(root)
        .args(["run", "experiments/examples/own-method.toml", "--out"])
        .arg(t.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let dir = t.path().join("own-method");
    let cases = rows(&dir.join("cases.csv"));
    let mine: Vec<_> = cases
        .iter()
        .filter(|r| r["method"] == "translate")
        .collect();
    assert_eq!(mine.len(), 2, "one row per case");
    for r in &mine {
        assert_eq!(r["status"], "ok", "{r:?}");
        assert!(
            !r["keypoints"].is_empty(),
            "the markers it was given are recorded"
        );
    }
    let mean = |method: &str, metric: &str| -> f64 {
        rows(&dir.join("summary.csv"))
            .iter()
            .find(|r| r["method"] == method && r["metric"] == metric)
            .unwrap_or_else(|| panic!("{method} {metric} not in summary.csv"))["mean"]
            .parse()
            .unwrap()
    };
    let (mine, floor, oracle) = (
        mean("translate", "err_mean_area"),
        mean("identity", "err_mean_area"),
        mean("sumner-oracle", "err_mean_area"),
    );
    eprintln!("external translate {mine:.4}, identity {floor:.4}, oracle {oracle:.4} (sqrt-area)");
    assert!(mine.is_finite() && oracle < mine, "{oracle} < {mine}");
    // A translation is a rigid motion: after the best rigid alignment it
    // scores what the floor scores.
    let (mine_r, floor_r) = (
        mean("translate", "err_mean_area_rigid"),
        mean("identity", "err_mean_area_rigid"),
    );
    assert!(
        (mine_r - floor_r).abs() < 1e-6 * floor_r.max(1.0),
        "{mine_r} vs {floor_r}"
    );
    let curves = std::fs::read_to_string(dir.join("curves.csv")).unwrap();
    assert!(curves.contains(",translate,cumulative_area,"));
    assert!(dir.join("plots/cumulative_area.png").is_file());
    assert!(dir.join("meshes/s0-t1-r0/translate/result_1.ply").is_file());
}

#[test]
fn failing_hanging_and_wrong_commands_fail_their_case_only() {
    let t = tempfile::tempdir().unwrap();
    let cfg = t.path().join("bad.toml");
    std::fs::write(
        &cfg,
        r#"name = "bad"
[dataset.synthetic]
subjects = 2
poses = 2
resolution = 1
[cases]
sources = [0]
[[methods]]
name = "fails"
kind = "external"
command = "sh -c 'echo the method broke >&2; exit 3' sh {out}"
[[methods]]
name = "hangs"
kind = "external"
command = "sh -c 'sleep 30' sh {out}"
timeout = 1
[[methods]]
name = "wrong-count"
kind = "external"
command = "sh -c 'printf \"v 0 0 0\\nv 1 0 0\\n\" > $1/result_1.obj' sh {out}"
[[methods]]
name = "missing"
kind = "external"
command = "sh -c 'true' sh {out}"
[[methods]]
name = "no-program"
kind = "external"
command = "no-such-program-here {out}"
[[methods]]
name = "identity"
kind = "identity"
"#,
    )
    .unwrap();
    let start = std::time::Instant::now();
    let o = Command::new(BIN)
        .args(["run", cfg.to_str().unwrap(), "--no-plots", "--out"])
        .arg(t.path().join("out"))
        .output()
        .unwrap();
    // Failed cases make the run's exit code non-zero but every case ran.
    let secs = start.elapsed().as_secs_f64();
    assert!(
        secs < 25.0,
        "the hanging command was not killed ({secs:.0} s)"
    );
    let cases = rows(&t.path().join("out/bad/cases.csv"));
    let status = |m: &str| -> String {
        cases
            .iter()
            .find(|r| r["method"] == m)
            .unwrap_or_else(|| panic!("no row for {m}: {}", String::from_utf8_lossy(&o.stderr)))
            ["status"]
            .clone()
    };
    assert_eq!(status("identity"), "ok");
    let expect = [
        ("fails", "the method broke"),
        ("fails", "exit status: 3"),
        ("hangs", "timeout of 1 s"),
        ("wrong-count", "has 2 vertices"),
        ("missing", "wrote no result_1"),
        ("no-program", "cannot start"),
    ];
    for (m, text) in expect {
        let s = status(m);
        assert!(s.starts_with("failed") && s.contains(text), "{m}: {s}");
    }
}

#[test]
fn external_configs_are_checked_at_load() {
    let t = tempfile::tempdir().unwrap();
    let load = |entry: &str| -> String {
        let p = t.path().join("c.toml");
        std::fs::write(
            &p,
            format!(
                "name = \"c\"\n[dataset.synthetic]\nsubjects = 2\n[[methods]]\nname = \"m\"\n\
                 kind = \"external\"\n{entry}\n"
            ),
        )
        .unwrap();
        match deformlab::experiment::load_config_schema(&p) {
            Ok(_) => "ok".into(),
            Err(e) => e.to_string(),
        }
    };
    assert_eq!(load("command = \"mine {source} {out}\""), "ok");
    assert!(load("").contains("methods[0].command"), "{}", load(""));
    assert!(load("command = \"mine {source}\"").contains("{out}"));
    assert!(load("command = \"mine {sauce} {out}\"").contains("unknown placeholder"));
    assert!(load("command = \"mine 'x {out}\"").contains("unbalanced"));
    assert!(load("command = \"mine {out}\"\ntimeout = 0").contains("timeout"));
    // Key point options apply only when the command takes the markers.
    let e = load("command = \"mine {out}\"\nepsilon = 0.01");
    assert!(
        e.contains("methods[0].epsilon") && e.contains("{markers}"),
        "{e}"
    );
    assert_eq!(
        load("command = \"mine {markers} {out}\"\nepsilon = 0.01"),
        "ok"
    );
    // Keys of other kinds are refused naming the kind.
    let e = load("command = \"mine {out}\"\ncount = 3");
    assert!(e.contains("does not apply to kind = \"external\""), "{e}");
}

/// A function registered by the host program (`kind = "callable"`): run by
/// the harness like every method, its results in cases.csv and
/// summary.csv; an error it returns fails its case only; an unregistered
/// name is refused at load.
#[test]
fn registered_functions_run_as_methods() {
    use deformlab::experiment::{run_configs, LoadOptions, RunOptions};
    use deformlab::methods::external::{register_callable, unregister_callable};
    use std::sync::Arc;
    // B moved by the mean displacement of the key points (as the example
    // script does), and a function that always fails.
    register_callable(
        "test-shift",
        Arc::new(|i| {
            let m = i.markers.expect("markers = true");
            let mut out = Vec::new();
            for pose in i.a_def {
                let mut d = nalgebra::Vector3::zeros();
                for &(s, _) in m {
                    d += pose.vertices()[s] - i.a.vertices()[s];
                }
                d /= m.len() as f64;
                out.push(i.b.vertices().iter().map(|p| p + d).collect());
            }
            Ok(out)
        }),
    );
    register_callable(
        "test-broken",
        Arc::new(|_| Err(deformlab::Error::invalid("my bug"))),
    );
    let t = tempfile::tempdir().unwrap();
    let cfg = t.path().join("fn.toml");
    std::fs::write(
        &cfg,
        "name = \"fn\"\n[dataset.synthetic]\nsubjects = 2\nposes = 2\nresolution = 1\n\
         [cases]\nsources = [0]\n\
         [[methods]]\nname = \"shift\"\nkind = \"callable\"\nfunction = \"test-shift\"\nmarkers = true\n\
         [[methods]]\nname = \"broken\"\nkind = \"callable\"\nfunction = \"test-broken\"\n\
         [[methods]]\nname = \"identity\"\nkind = \"identity\"\n",
    )
    .unwrap();
    let opts = RunOptions {
        out: t.path().join("out"),
        threads: 2,
        shard: None,
        plots: false,
        progress: false,
        max_new: None,
        wait: true,
        defects: Default::default(),
        load: LoadOptions::default(),
        force: false,
        retry_failed: false,
    };
    let s = run_configs(std::slice::from_ref(&cfg), &opts).unwrap();
    assert_eq!(s[0].failed, 1, "the broken function's case");
    let cases = rows(&t.path().join("out/fn/cases.csv"));
    let row = |m: &str| cases.iter().find(|r| r["method"] == m).unwrap().clone();
    assert_eq!(row("shift")["status"], "ok");
    assert_eq!(row("shift")["kind"], "callable");
    assert!(!row("shift")["keypoints"].is_empty());
    let b = row("broken")["status"].clone();
    assert!(b.contains("test-broken") && b.contains("my bug"), "{b}");
    // A translation: after the best rigid alignment, the floor's error.
    let (a, f) = (
        row("shift")["err_mean_area_rigid"].parse::<f64>().unwrap(),
        row("identity")["err_mean_area_rigid"]
            .parse::<f64>()
            .unwrap(),
    );
    assert!((a - f).abs() < 1e-6, "{a} vs {f}");
    unregister_callable("test-shift");
    // Unregistered: refused at load, naming the key and the function.
    let e = deformlab::experiment::load_config(&cfg)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("methods[0].function") && e.contains("test-shift"),
        "{e}"
    );
    unregister_callable("test-broken");
}

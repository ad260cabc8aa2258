//! Overrides and sweeps (issue 20, point 4): `--set KEY=VALUE`, `[sweep]`
//! and `--sweep KEY=V1,V2,...` expand methods into named variants; the
//! override is recorded in the manifest and part of the store key; unknown
//! keys and bad values get the file's errors, naming the key.

mod common;

use std::path::Path;

use common::{cli_err, csv_rows, run, tmp, write};
use deformlab::experiment::{parse_config_with, LoadOptions, Method};
use deformlab::methods::TransferMethod;

const TINY: &str = r#"
name = "tiny"
[dataset.synthetic]
subjects = 2
poses = 3
resolution = 1
[cases]
sources = [0]
targets = [1]
[defaults]
mode = "fast"
n_candidates = 12
[[methods]]
name = "auto"
kind = "bdt"
[[methods]]
name = "tight"
kind = "bdt"
epsilon = 0.01
[[methods]]
name = "identity"
kind = "identity"
[[outputs.plots]]
kind = "bars"
methods = ["auto", "identity"]
metrics = ["err_mean_area"]
"#;

fn load(
    text: &str,
    set: &[&str],
    sweep: &[&str],
) -> deformlab::Result<deformlab::experiment::LoadedConfig> {
    parse_config_with(
        text,
        Path::new("tiny.toml"),
        &LoadOptions {
            data_root: None,
            set: set.iter().map(|s| s.to_string()).collect(),
            sweep: sweep.iter().map(|s| s.to_string()).collect(),
        },
    )
}

fn epsilon(m: &Method) -> f64 {
    match m {
        Method::Transfer(TransferMethod::Bdt { options, .. }) => options.keypoints.epsilon,
        m => panic!("{m:?}"),
    }
}

#[test]
fn set_overrides_keys_with_methods_by_name() {
    let l = load(
        TINY,
        &[
            "defaults.epsilon=0.02",
            "methods.auto.n_candidates=8",
            "methods[1].max_keypoints=5",
        ],
        &[],
    )
    .unwrap();
    assert_eq!(epsilon(&l.methods[0].method), 0.02);
    assert_eq!(epsilon(&l.methods[1].method), 0.01, "its own key wins");
    match &l.methods[0].method {
        Method::Transfer(TransferMethod::Bdt { options, .. }) => {
            assert_eq!(options.keypoints.n_candidates, 8)
        }
        m => panic!("{m:?}"),
    }
    assert_eq!(l.config.methods[1].max_keypoints, Some(5));
    assert_eq!(l.overrides.len(), 3);
}

#[test]
fn bad_overrides_name_the_key() {
    let e = |set: &str| load(TINY, &[set], &[]).unwrap_err().to_string();
    let m = e("defaults.epsilonn=0.02");
    assert!(
        m.contains("tiny.toml")
            && m.contains("--set defaults.epsilonn=0.02")
            && m.contains("unknown field `epsilonn`"),
        "{m}"
    );
    let m = e("methods.autoo.epsilon=0.02");
    assert!(
        m.contains("\"autoo\"") && m.contains("auto, tight, identity"),
        "{m}"
    );
    let m = e("methods.auto.epsilon=-1");
    assert!(m.contains("epsilon") && m.contains("out of range"), "{m}");
    let m = e("defaults.mode=quick");
    assert!(m.contains("defaults.mode") && m.contains("`fast`"), "{m}");
    let m = e("methods.identity.count=3");
    assert!(m.contains("count") && m.contains("does not apply"), "{m}");
    let m = e("cases.repeat=0");
    assert!(
        m.contains("cases.repeat") && m.contains("out of range"),
        "{m}"
    );
    let m = e("epsilon");
    assert!(m.contains("KEY=VALUE"), "{m}");
    let m = load(TINY, &[], &["cases.repeat=1,2"])
        .unwrap_err()
        .to_string();
    assert!(m.contains("only method keys can be swept"), "{m}");
    let m = load(TINY, &[], &["defaults.epsilon=0.01,abc"])
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("defaults.epsilon") && m.contains("\"abc\""),
        "{m}"
    );
}

#[test]
fn sweeps_expand_methods_into_named_variants() {
    let l = load(TINY, &[], &["defaults.epsilon=0.01,0.02,0.03,0.05"]).unwrap();
    let names: Vec<&str> = l.methods.iter().map(|m| m.name.as_str()).collect();
    // `tight` sets epsilon itself and `identity` takes none: not expanded.
    assert_eq!(
        names,
        [
            "auto-eps0.01",
            "auto-eps0.02",
            "auto-eps0.03",
            "auto-eps0.05",
            "tight",
            "identity"
        ]
    );
    assert_eq!(epsilon(&l.methods[3].method), 0.05);
    assert_eq!(l.methods[1].group, "auto-eps0.02");
    // The plot that named `auto` names its variants; a line plot of the
    // error against the new `epsilon` column is added.
    let plots = &l.config.outputs.plots;
    assert_eq!(plots[0].methods.len(), 5);
    let line = plots
        .iter()
        .find(|p| p.x.as_deref() == Some("epsilon"))
        .unwrap();
    assert_eq!(line.metrics, ["err_mean_area"]);
    let sweep = l.sweep.as_ref().unwrap();
    assert_eq!(sweep["methods"]["auto"].as_array().unwrap().len(), 4);
    assert_eq!(sweep["axes"][0]["from"], "--sweep");

    // In the file: grids (union), names, seeds as replicates, a method
    // addressed by name, the product with --sweep.
    let text = format!(
        "{TINY}\n[[sweep]]\nmethods.auto.n_candidates = {{ values = [8, 12], names = [\"nc8\", \"nc12\"] }}\n\
         [[sweep]]\nmethods.auto.n_candidates = {{ values = [16], names = [\"nc16\"] }}\n\
         methods.auto.seed = [1, 2]\n"
    );
    let l = load(&text, &[], &["methods.tight.max_keypoints=4"]).unwrap();
    let names: Vec<(&str, &str)> = l
        .methods
        .iter()
        .map(|m| (m.name.as_str(), m.group.as_str()))
        .collect();
    assert_eq!(
        names,
        [
            ("auto-nc8", "auto-nc8"),
            ("auto-nc12", "auto-nc12"),
            ("auto-nc16-seed1", "auto-nc16"),
            ("auto-nc16-seed2", "auto-nc16"),
            ("tight-max_keypoints4", "tight-max_keypoints4"),
            ("identity", "identity"),
        ]
    );
    let bad =
        format!("{TINY}\n[sweep]\ndefaults.epsilon = {{ values = [0.1], names = [\"a b\"] }}\n");
    let m = load(&bad, &[], &[]).unwrap_err().to_string();
    assert!(m.contains("defaults.epsilon") && m.contains("names"), "{m}");
    let bad = format!("{TINY}\n[sweep]\ndefaults.epsilon = {{ values = [0.1], label = \"x\" }}\n");
    let m = load(&bad, &[], &[]).unwrap_err().to_string();
    assert!(m.contains("sweep.defaults.epsilon.label"), "{m}");
}

/// A labelled method's sweep variants get labels of their own (label and
/// swept value), so a table or legend does not show two rows "BDT (ours)";
/// seed replicates share their group's label.
#[test]
fn sweep_variants_have_distinct_labels() {
    let text = TINY.replace(
        "name = \"auto\"\nkind = \"bdt\"",
        "name = \"auto\"\nkind = \"bdt\"\nlabel = \"BDT (ours)\"",
    );
    let text = format!("{text}\n[sweep]\nmethods.auto.seed = [1, 2]\n");
    let l = load(&text, &[], &["methods.auto.epsilon=0.01,0.02"]).unwrap();
    let labels: Vec<(String, Option<String>)> = l
        .config
        .methods
        .iter()
        .map(|m| (m.name.clone(), m.label.clone()))
        .collect();
    let of = |n: &str| labels.iter().find(|(m, _)| m == n).unwrap().1.clone();
    assert_eq!(
        of("auto-seed1-eps0.01").as_deref(),
        Some("BDT (ours) (epsilon = 0.01)")
    );
    assert_eq!(
        of("auto-seed2-eps0.01").as_deref(),
        Some("BDT (ours) (epsilon = 0.01)")
    );
    assert_eq!(
        of("auto-seed1-eps0.02").as_deref(),
        Some("BDT (ours) (epsilon = 0.02)")
    );
    assert_eq!(of("tight"), None);
}

/// `auto-noise.toml` is a sweep that gives the 33 methods of the committed
/// results, with their names, groups and store key.
#[test]
fn auto_noise_sweep_keeps_the_committed_results() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let l = deformlab::experiment::load_config(&root.join("experiments/auto-noise.toml")).unwrap();
    let stored: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root.join("results/auto-noise/config.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        serde_json::to_value(l.config.hashed_part()).unwrap(),
        stored["config"]
    );
    assert_eq!(l.config.hash(), stored["hash"].as_str().unwrap());
    assert_eq!(l.methods.len(), 33);
    assert_eq!(l.methods[1].name, "bdt-r1-s0");
    assert_eq!(l.methods[1].group, "bdt-r1");
    // And a run finds every stored result's key there (no case computed).
    let t = tmp();
    let dir = t.path().join("auto-noise");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(
        root.join("results/auto-noise/config.json"),
        dir.join("config.json"),
    )
    .unwrap();
    let o = common::deformlab()
        .env("DEFORMLAB_RUN_MAX_NEW", "0")
        .args([
            "run",
            root.join("experiments/auto-noise.toml").to_str().unwrap(),
            "--out",
            t.path().to_str().unwrap(),
            "--no-plots",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && !err.contains("bound"), "{err}");
}

/// One command: a sweep over ε gives four methods and a line plot of the
/// error against ε; the overrides and the sweep are in the manifest and
/// in the store key.
#[test]
fn epsilon_sweep_from_one_command() {
    let t = tmp();
    let cfg = write(
        t.path(),
        "tiny.toml",
        TINY.replace(
            "[[methods]]\nname = \"tight\"\nkind = \"bdt\"\nepsilon = 0.01\n",
            "",
        ),
    );
    let out = t.path().join("out");
    let args = |extra: &[&str]| {
        let mut a = vec![
            "run".to_string(),
            cfg.display().to_string(),
            "--out".into(),
            out.display().to_string(),
        ];
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let o = run(&args(&[
        "--sweep",
        "defaults.epsilon=0.01,0.02,0.03,0.05",
        "--set",
        "name=eps-sweep",
    ]));
    let so = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{so}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(so.contains("eps-sweep: 5 computed"), "{so}");
    let dir = out.join("eps-sweep");
    let rows = csv_rows(&dir.join("cases.csv"));
    let eps: Vec<&str> = rows.iter().map(|r| r["epsilon"].as_str()).collect();
    assert_eq!(eps, ["0.01", "0.02", "0.03", "0.05", ""]);
    assert!(dir.join("plots/line_epsilon.png").is_file());
    assert!(dir.join("plots/line_epsilon.svg").is_file());
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["overrides"][0], "name=eps-sweep");
    assert_eq!(m["sweep"]["axes"][0]["key"], "defaults.epsilon");
    assert_eq!(m["methods"].as_array().unwrap().len(), 5);

    // Part of the key: the same folder with another override is refused,
    // naming the key; the same command resumes.
    cli_err(
        &args(&[
            "--sweep",
            "defaults.epsilon=0.01,0.02,0.03,0.05",
            "--set",
            "name=eps-sweep",
            "--set",
            "defaults.n_candidates=10",
        ]),
        &["another configuration", "defaults.n_candidates"],
    );
    let o = run(&args(&[
        "--sweep",
        "defaults.epsilon=0.01,0.02,0.03,0.05",
        "--set",
        "name=eps-sweep",
    ]));
    assert!(String::from_utf8_lossy(&o.stdout).contains("eps-sweep: 0 computed, 5 resumed"));
    // A bad key on the command line: one error naming it, nothing written.
    let before = std::fs::read_dir(&out).unwrap().count();
    cli_err(
        &args(&["--set", "methods.auto.epsilonn=1"]),
        &[
            "tiny.toml",
            "--set methods.auto.epsilonn=1",
            "unknown field `epsilonn`",
        ],
    );
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), before);
}

#[test]
fn every_override_applies_as_written_or_is_refused() {
    let d = tmp();
    let cfg = write(d.path(), "tiny.toml", TINY);
    let out = d.path().join("out");
    let c = cfg.to_str().unwrap();
    let o = out.to_str().unwrap();
    // A table for an existing table would replace it whole (`mode` and
    // `n_candidates` of the file silently back to their defaults).
    cli_err(
        &["run", c, "--out", o, "--set", "defaults={epsilon=0.02}"],
        &[
            "--set defaults={epsilon=0.02}",
            "one by one",
            "defaults.KEY=VALUE",
        ],
    );
    // A key both set and swept: the set value would be dropped.
    cli_err(
        &[
            "run",
            c,
            "--out",
            o,
            "--set",
            "methods.auto.epsilon=0.02",
            "--sweep",
            "methods.auto.epsilon=0.01,0.03",
        ],
        &["methods.auto.epsilon", "also swept", "--sweep"],
    );
    assert!(!out.join("tiny").exists());
}

#[test]
fn values_that_would_fail_later_are_refused_at_load() {
    let d = tmp();
    let out = d.path().join("out");
    let o = out.to_str().unwrap();
    // A third camera value was dropped.
    let cfg = write(
        d.path(),
        "cam.toml",
        format!("{TINY}\n[outputs]\ncamera = [10, 20, 30]\n").replace(
            "[[outputs.plots]]\nkind = \"bars\"\nmethods = [\"auto\", \"identity\"]\nmetrics = [\"err_mean_area\"]\n",
            "",
        ),
    );
    cli_err(
        &["run", cfg.to_str().unwrap(), "--out", o],
        &["camera", "expected two numbers, got 3"],
    );
    // λ = 1e308 passed its range and failed in every case.
    let cfg = write(
        d.path(),
        "lambda.toml",
        TINY.replace("epsilon = 0.01", "epsilon = 0.01\nlambda = 1e308"),
    );
    cli_err(
        &["run", cfg.to_str().unwrap(), "--out", o],
        &["lambda", "out of range", "1000000"],
    );
    // rig_poses beyond the class's shapes, for a solving task (before:
    // only the projection's skeleton dictionary was checked).
    let cfg = write(
        d.path(),
        "rig.toml",
        r#"name = "rig"
[dataset.synthetic]
subjects = 1
poses = 5
resolution = 1
[cases]
targets = []
include_self = true
per_pose = true
reference_pose = "rest"
poses = [2]
[[methods]]
name = "completion"
kind = "fbt"
fbt = { task = "completion", q = 2, rig = "class", rig_poses = 20, pipeline = "skeleton" }
"#,
    );
    cli_err(
        &["run", cfg.to_str().unwrap(), "--out", o],
        &["rig_poses", "expected 1..="],
    );
    assert!(!out.join("rig").exists());
}

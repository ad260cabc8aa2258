//! The README is the newcomer's entry point: its two commands must be there,
//! every image it shows must exist, and it must not have been mangled by an
//! editing script (a bad replace once inserted a block between every
//! character: 279k lines).

use std::path::Path;

#[test]
fn readme_names_the_two_commands_and_its_images_exist() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let lines = text.lines().count();
    assert!(lines < 1500, "README.md has {lines} lines: mangled?");
    assert!(
        text.starts_with("# deformlab"),
        "README.md must start with its title"
    );
    assert!(
        text.contains("cargo test --release"),
        "test command missing"
    );
    assert!(text.contains("deformlab run experiments/*.toml") || text.contains("run experiments/"));
    let mut images = 0;
    for part in text.split("](").skip(1) {
        let target = part.split(')').next().unwrap_or("");
        if target.ends_with(".png") && !target.starts_with("http") {
            images += 1;
            assert!(
                root.join(target).is_file(),
                "README shows missing image {target}"
            );
        }
    }
    assert!(images > 0, "no images found in README.md");
    let headers = text.matches("\n| | |\n").count();
    assert!(headers <= 1, "the results table appears {headers} times");
}

/// The README's suite facts are those of the committed default suite: the
/// experiment count is the number of default configs (each with its
/// results folder), and the measured wall time is the manifests' (the sum
/// over experiments of the invocations that computed something, within
/// 25 %). Regenerating `results/` without updating the README fails here.
#[test]
fn readme_suite_figures_match_the_committed_results() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("README.md")).unwrap();
    let configs: Vec<String> = std::fs::read_dir(root.join("experiments"))
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            (p.extension().is_some_and(|x| x == "toml"))
                .then(|| p.file_stem().unwrap().to_string_lossy().into_owned())
        })
        .collect();
    let stated = format!("The suite ({} experiments)", configs.len());
    assert!(
        text.contains(&stated),
        "README must say \"{stated}\" (experiments/*.toml holds {})",
        configs.len()
    );
    let mut total = 0.0;
    for c in &configs {
        let toml_text =
            std::fs::read_to_string(root.join("experiments").join(format!("{c}.toml"))).unwrap();
        let name = toml_text
            .lines()
            .find_map(|l| l.strip_prefix("name = \""))
            .and_then(|l| l.split('"').next())
            .unwrap_or_else(|| panic!("{c}.toml has no name"));
        let manifest = root.join("results").join(name).join("manifest.json");
        let m: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&manifest).unwrap_or_else(|e| {
                panic!("{}: {e} (results not regenerated?)", manifest.display())
            }))
            .unwrap();
        let invocations = m["invocations"].as_array().expect("invocations");
        total += invocations
            .iter()
            .filter(|i| i["computed"].as_u64().unwrap_or(0) > 0)
            .map(|i| i["wall_seconds"].as_f64().unwrap_or(0.0))
            .sum::<f64>();
    }
    let measured = text
        .split("(measured:")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|s| s.parse::<f64>().ok())
        .expect("README states the suite's measured wall time as \"(measured: N s\"");
    assert!(
        (measured - total).abs() <= 0.25 * total,
        "README says the suite took {measured} s; the committed manifests sum to {total:.0} s"
    );
}

/// Every `deformlab <command>` the README's command table names exists
/// (its `--help` exits 0), and every `experiments/…toml` it names is there.
#[test]
fn readme_commands_and_configs_exist() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("README.md")).unwrap();
    let mut commands = std::collections::BTreeSet::new();
    for line in text.lines().filter(|l| l.starts_with("| `deformlab ")) {
        let cmd = line["| `deformlab ".len()..]
            .split(|c: char| !c.is_ascii_lowercase())
            .next()
            .unwrap()
            .to_string();
        commands.insert(cmd);
    }
    assert!(commands.len() >= 5, "command table not found: {commands:?}");
    for c in &commands {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_deformlab"))
            .args([c.as_str(), "--help"])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "README names `deformlab {c}`, which does not exist"
        );
    }
    for part in text.split("experiments/").skip(1) {
        let name: String = part
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '/' | '.'))
            .collect();
        if let Some(stem) = name.strip_suffix(".toml") {
            if !stem.contains('*') {
                assert!(
                    root.join("experiments").join(&name).is_file(),
                    "README names experiments/{name}, which does not exist"
                );
            }
        }
    }
}

/// The README's test command is `scripts/test.sh`, which runs the Rust
/// tests and then the Python tests; CI (`.ci/run`) runs exactly it.
#[test]
fn readme_test_command_covers_rust_and_python_and_ci_runs_it() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("README.md")).unwrap();
    let block = text
        .split("```sh")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .expect("the README's first shell block (the two commands)");
    assert!(
        block.lines().any(|l| l.trim() == "scripts/test.sh"),
        "the README's test command must be scripts/test.sh"
    );
    let script = std::fs::read_to_string(root.join("scripts/test.sh")).unwrap();
    let rust = script
        .find("cargo test --locked --release")
        .expect("scripts/test.sh runs cargo test --release");
    let python = script
        .find("-m pytest")
        .expect("scripts/test.sh runs pytest");
    assert!(rust < python, "the Rust tests run first");
    assert!(
        script.contains("maturin"),
        "the module is built with maturin"
    );
    let ci = std::fs::read_to_string(root.join(".ci/run")).unwrap();
    assert!(
        ci.lines()
            .any(|l| l.contains("scripts/test.sh") && !l.trim_start().starts_with('#')),
        ".ci/run must run the README's test command, scripts/test.sh"
    );
    assert!(
        !ci.contains("cargo test --locked --release 2>&1"),
        ".ci/run must not run the Rust tests apart from the README's command"
    );
    assert!(
        ci.contains("--manifest-path python/Cargo.toml"),
        ".ci/run checks the Python crate's formatting and lints"
    );
}

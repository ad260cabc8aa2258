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
        text.contains("cargo test --profile release"),
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
/// results folder), and the measured wall time is the manifests' (from the
/// first start to the last end of the invocations that computed something,
/// within 25 %). Regenerating `results/` without updating the README fails here.
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
    // The run's span: from the first experiment's start to the last one's
    // end over the invocations that computed something (experiments of
    // one run overlap, so their wall times are not summed).
    let (mut first, mut last) = (f64::INFINITY, f64::NEG_INFINITY);
    for c in &configs {
        let toml_text =
            std::fs::read_to_string(root.join("experiments").join(format!("{c}.toml"))).unwrap();
        let name = toml_text
            .lines()
            .find_map(|l| l.strip_prefix("name = \""))
            .and_then(|l| l.split('"').next())
            .unwrap_or_else(|| panic!("{c}.toml has no name"));
        // The timings are volatile (results/*/timings/, not committed); the
        // docs quote the snapshot scripts/snapshot_timings.sh takes.
        let manifest = root.join("docs/timings").join(name).join("runs.json");
        let m: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(&manifest)
                .unwrap_or_else(|e| panic!("{}: {e} (timings not snapshot?)", manifest.display())),
        )
        .unwrap();
        let invocations = m["invocations"].as_array().expect("invocations");
        for i in invocations
            .iter()
            .filter(|i| i["computed"].as_u64().unwrap_or(0) > 0)
        {
            let start = i["started_unix"].as_f64().expect("started_unix");
            first = first.min(start);
            last = last.max(start + i["wall_seconds"].as_f64().expect("wall_seconds"));
        }
    }
    let total = last - first;
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

/// `results/<experiment>/summary.csv` as (method, metric) → (mean, median).
fn summary(experiment: &str) -> std::collections::HashMap<(String, String), (f64, f64)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("results").join(experiment).join("summary.csv");
    let mut text =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    // Timing rows: the committed snapshot of the volatile timings/summary.csv.
    let timings = root
        .join("docs/timings")
        .join(experiment)
        .join("summary.csv");
    if let Ok(t) = std::fs::read_to_string(&timings) {
        text.extend(t.lines().skip(1).map(|l| format!("{l}\n")));
    }
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (method, metric, mean, median) = (col("method"), col("metric"), col("mean"), col("median"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let num = |i: usize| f[i].parse::<f64>().unwrap_or(f64::NAN);
            (
                (f[method].to_string(), f[metric].to_string()),
                (num(mean), num(median)),
            )
        })
        .collect()
}

/// The results page (`docs/results.md`, linked from the README) with
/// every run of whitespace (line breaks, indentation) as one space, so that
/// a sentence can be looked up across its line wraps.
fn readme_flat() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("docs/results.md")).unwrap();
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn assert_states(readme: &str, expected: &str) {
    let expected = expected.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        readme.contains(&expected),
        "docs/results.md does not state the committed results: expected the text\n  {expected}\n\
         (numbers from results/*/summary.csv; regenerate the README's figures)"
    );
}

/// The headline numbers the README quotes from the default suite are those
/// of the committed `results/` (formatted as the README prints them):
/// regenerating the results without updating these sentences fails here.
/// The FAUST benchmark's table is checked against its committed tables
/// (`results/real/bdt-faust`); other numbers measured on real data or by
/// benchmarks are not in the default suite and are not checked.
#[test]
fn readme_result_numbers_match_the_committed_results() {
    let readme = readme_flat();
    let mean = |s: &std::collections::HashMap<(String, String), (f64, f64)>, m: &str, k: &str| {
        s.get(&(m.to_string(), k.to_string()))
            .unwrap_or_else(|| panic!("summary has no {m} / {k}"))
            .0
    };

    let s = summary("fig7");
    assert_states(
        &readme,
        &format!(
            "BDT Fig. 7: fit error (unit sphere) {:.4} without E_diff, {:.4} with it",
            mean(&s, "without-E_diff", "fit_error_unit"),
            mean(&s, "with-E_diff", "fit_error_unit")
        ),
    );

    let s = summary("fig6");
    let sel: Vec<String> = [2, 4, 6, 8, 10]
        .iter()
        .map(|k| format!("{:.3}", mean(&s, &format!("k{k}"), "selection_error")))
        .collect();
    assert_states(
        &readme,
        &format!(
            "BDT Fig. 6: selection error {} with 2 / 4 / 6 / 8 / 10 key points",
            sel.join(" / ")
        ),
    );

    // BDT Fig. 14 table.
    let s = summary("fig14");
    for (label, m, kp) in [
        ("automatic (BDT, unit-sphere frame)", "automatic", true),
        (
            "automatic, handle-relative frame",
            "auto-handle-relative",
            true,
        ),
        ("automatic, raw frame (ablation)", "auto-raw-frame", true),
        (
            "automatic, Eq. 1 coupled weights (ablation)",
            "automatic-coupled",
            true,
        ),
        ("random user", "random-user", true),
        ("extremity user", "extremity-user", true),
        ("Sumner DT, same markers", "sumner-markers", true),
        (
            "Sumner DT oracle (full correspondence)",
            "sumner-oracle",
            false,
        ),
        ("cage DT, same markers", "cage", true),
        ("identity (B unchanged)", "identity", false),
    ] {
        let strain = mean(&s, m, "edge_strain_p99");
        let strain = if strain == 0.0 {
            "0".to_string()
        } else {
            format!("{strain:.2}")
        };
        let kps = if kp {
            format!("{}", mean(&s, m, "n_keypoints"))
        } else {
            "–".to_string()
        };
        assert_states(
            &readme,
            &format!(
                "| {label} | {:.4} | {:.4} | {:.3} | {strain} | {kps} |",
                mean(&s, m, "err_mean_area"),
                mean(&s, m, "err_mean_area_rigid"),
                mean(&s, m, "within_005_area"),
            ),
        );
    }

    // The FAUST benchmark (committed tables of experiments/real/bdt-faust.toml).
    let s = summary("real/bdt-faust");
    for (label, m) in [
        ("BDT, the default", "default"),
        ("BDT, ε = 0.015", "eps-0.015"),
        ("BDT, B rotated onto A by its key points", "align-keypoints"),
        ("BDT, handle-relative frame", "handle-relative"),
        ("BDT, raw frame", "raw-frame"),
        ("BDT, Eq. 1 coupled weights", "coupled"),
        ("Sumner DT, the default's markers", "sumner-markers"),
        ("Sumner DT oracle (full correspondence)", "sumner-oracle"),
        ("cage DT, the default's markers", "cage"),
        ("identity (B unchanged), the floor", "identity"),
    ] {
        assert_states(
            &readme,
            &format!(
                "| {label} | {:.4} | {:.4} | {:.3} |",
                mean(&s, m, "err_mean_area"),
                mean(&s, m, "err_mean_area_rigid"),
                mean(&s, m, "within_005_area"),
            ),
        );
    }

    // FBT Table 2, paper layout (synthetic).
    let s = summary("fbt-table2");
    let col = |prefix: &str| {
        [1, 2, 4, 8]
            .iter()
            .map(|q| {
                format!(
                    "{:.2}",
                    100.0 * mean(&s, &format!("{prefix}-q{q}"), "rel_distortion_max")
                )
            })
            .collect::<Vec<_>>()
            .join(" / ")
    };
    assert_states(
        &readme,
        &format!(
            "LBO m = 10 {}, skeleton {}, one example {};",
            col("lbo10"),
            col("skel"),
            col("one")
        ),
    );

    // FBT Fig. 7.
    let s = summary("fbt-fig7");
    let row = |prefix: &str, metric: &str| {
        [1, 2, 4, 8]
            .iter()
            .map(|q| format!("{:.4}", mean(&s, &format!("{prefix}q{q}"), metric)))
            .collect::<Vec<_>>()
            .join(" / ")
    };
    assert_states(
        &readme,
        &format!(
            "default {}, LBO only {} (correspondence error, Euclidean, {} and {})",
            row("", "rel_distortion_mean"),
            row("lbo-", "rel_distortion_mean"),
            row("", "corr_error_mean_euclidean"),
            row("lbo-", "corr_error_mean_euclidean"),
        ),
    );
    assert_states(
        &readme,
        &format!(
            "scores {:.3} ({:.3} after its best rigid alignment onto the truth) and a \
             correspondence error of {:.3}",
            mean(&s, "q1", "floor_distortion_mean"),
            mean(&s, "q1", "floor_distortion_mean_aligned"),
            mean(&s, "q1", "floor_corr_error_mean_euclidean"),
        ),
    );
    assert_states(
        &readme,
        &format!(
            "(q = 8: {:.4} against {:.4} raw;",
            mean(&s, "q8", "rel_distortion_mean_aligned"),
            mean(&s, "q8", "rel_distortion_mean"),
        ),
    );
    let failures = |prefix: &str| {
        [1, 2, 4, 8]
            .iter()
            .map(|q| {
                let m = format!("{prefix}q{q}");
                let n = s[&(m.clone(), "gross_failure".to_string())];
                format!("{}", (n.0 * 50.0).round())
            })
            .collect::<Vec<_>>()
            .join(" / ")
    };
    assert_states(
        &readme,
        &format!(
            "synthetic default {} of 50, LBO only {};",
            failures(""),
            failures("lbo-")
        ),
    );

    // The FBT benchmark on real data (committed tables of
    // experiments/real/fbt-bench-*.toml): the default is LBO only at q = 1,
    // 2 and the skeleton clusters at q = 4, 8.
    let bench = |name: &str, intro: &str, skeleton: &str, amberg: &str| {
        let s = summary(name);
        let d = |m: &str| format!("{:.4}", mean(&s, m, "rel_distortion_mean"));
        let joined = |ms: &[&str]| ms.iter().map(|m| d(m)).collect::<Vec<_>>().join(" / ");
        assert_states(
            &readme,
            &format!(
                "{intro} default {}, {skeleton} — / {}, Der et al. {}, {amberg} {}, floor {}.",
                joined(&[
                    "lbo-q1",
                    "lbo-q2",
                    "skeleton-clusters-q4",
                    "skeleton-clusters-q8"
                ]),
                joined(&["skeleton-q2", "skeleton-q4", "skeleton-q8"]),
                joined(&["der-q1", "der-q2", "der-q4", "der-q8"]),
                d("amberg"),
                d("template"),
            ),
        );
    };
    bench(
        "real/fbt-bench-faust",
        "FAUST, 45 cases:",
        "the paper's skeleton pipeline",
        "Amberg NICP",
    );
    bench(
        "real/fbt-bench-tosca-cat",
        "TOSCA cat, 10 cases:",
        "skeleton",
        "Amberg",
    );

    let s = summary("fbt-fig7-baselines");
    assert_states(
        &readme,
        &format!(
            "FBT {:.4}, Der et al. {:.4} (on the same clusters), Amberg optimal-step \
             NICP {:.4}",
            mean(&s, "FBT", "rel_distortion_mean"),
            mean(&s, "Der-et-al", "rel_distortion_mean"),
            mean(&s, "Amberg-NICP", "rel_distortion_mean"),
        ),
    );

    let s = summary("fbt-fig4-5");
    assert_states(
        &readme,
        &format!(
            "α = {:.3} / {:.3} for targets scaled by 1.5 / 0.7 and {:.3} for the unscaled \
             target (synthetic)",
            mean(&s, "scale-1.5", "alpha"),
            mean(&s, "scale-0.7", "alpha"),
            mean(&s, "scale-1.5", "alpha_unscaled"),
        ),
    );

    // FBT Table 1 timings (medians, ms).
    let s = summary("fbt-table1");
    let ms = |m: &str, k: &str| 1000.0 * s[&(m.to_string(), k.to_string())].1;
    let it = |q: &str| {
        ["init", "main", "rich"]
            .iter()
            .map(|st| format!("{:.2}", ms(q, &format!("seconds_iteration_{st}"))))
            .collect::<Vec<_>>()
            .join(" / ")
    };
    assert_states(
        &readme,
        &format!(
            "one E_total iteration costs {} ms (q = 4) and {} ms (q = 8) in the init / main / \
             rich dictionary, the full schedule {:.1} / {:.1} ms",
            it("q4"),
            it("q8"),
            ms("q4", "seconds_solve"),
            ms("q8", "seconds_solve"),
        ),
    );

    let s = summary("auto-synthetic");
    assert_states(
        &readme,
        &format!(
            "BDT {:.4} with automatic target points and {:.4} with the true ones (Sumner DT \
             {:.4} vs {:.4}; {:.4} vs {:.4} after rigid alignment)",
            mean(&s, "bdt-auto-targets", "err_mean_area"),
            mean(&s, "bdt-true-targets", "err_mean_area"),
            mean(&s, "sumner-auto-targets", "err_mean_area"),
            mean(&s, "sumner-true-targets", "err_mean_area"),
            mean(&s, "sumner-auto-targets", "err_mean_area_rigid"),
            mean(&s, "sumner-true-targets", "err_mean_area_rigid"),
        ),
    );
    let s = summary("auto-noise");
    assert_states(
        &readme,
        &format!(
            "BDT {:.4} → {:.4} and Sumner DT {:.4} → {:.4} as the radius goes from 0 to 5 % √area",
            mean(&s, "bdt-r0-s0", "err_mean_area_rigid"),
            mean(&s, "bdt-r5-s0", "err_mean_area_rigid"),
            mean(&s, "sumner-r0-s0", "err_mean_area_rigid"),
            mean(&s, "sumner-r5-s0", "err_mean_area_rigid"),
        ),
    );
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
        .find("cargo test --locked --profile release")
        .expect("scripts/test.sh runs cargo test --profile release");
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

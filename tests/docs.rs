//! The manual holds together: the README is short and links every page of
//! `docs/`; every relative link of the README and of `docs/` resolves;
//! the reference pages are checked against the code they describe (every
//! config in the experiments table, every `cases.csv` column in the data
//! dictionary, the method registry as `deformlab methods` prints it).

use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The Markdown pages of `docs/`.
fn pages() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    v.sort();
    v
}

/// The link targets `](target)` of a Markdown text.
fn links(text: &str) -> Vec<String> {
    text.split("](")
        .skip(1)
        .filter_map(|r| r.split(')').next())
        .map(str::to_string)
        .collect()
}

#[test]
fn readme_is_short_and_links_every_page() {
    let readme = read(&root().join("README.md"));
    let n = readme.lines().count();
    assert!(n <= 250, "README.md has {n} lines (at most 250)");
    let targets = links(&readme);
    for p in pages() {
        let rel = format!("docs/{}", p.file_name().unwrap().to_string_lossy());
        assert!(targets.contains(&rel), "README.md does not link {rel}");
    }
}

#[test]
fn relative_links_resolve() {
    let mut files = vec![
        root().join("README.md"),
        root().join("experiments/README.md"),
    ];
    files.extend(pages());
    let mut broken = Vec::new();
    for f in &files {
        let dir = f.parent().unwrap();
        for t in links(&read(f)) {
            let t = t.split('#').next().unwrap_or("").trim();
            if t.is_empty() || t.contains("://") || t.starts_with("mailto:") {
                continue;
            }
            if !dir.join(t).exists() {
                broken.push(format!("{}: {t}", f.display()));
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn every_config_is_in_the_experiments_table() {
    let table = read(&root().join("docs/experiments.md"));
    let mut missing = Vec::new();
    let mut stack = vec![root().join("experiments")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "toml") {
                let rel = p
                    .strip_prefix(root())
                    .unwrap()
                    .to_string_lossy()
                    .into_owned();
                // Dataset manifests are data descriptions, not experiments.
                if rel.contains("/manifests/") {
                    continue;
                }
                if !table.contains(&format!("(../{rel})")) {
                    missing.push(rel);
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "docs/experiments.md does not list: {missing:?}"
    );
}

#[test]
fn every_case_column_is_in_the_data_dictionary() {
    let dict = read(&root().join("docs/outputs.md"));
    let missing: Vec<&str> = deformlab::experiment::CASE_COLUMNS
        .iter()
        .copied()
        .filter(|c| !dict.contains(&format!("`{c}`")))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/outputs.md does not describe the cases.csv columns {missing:?}"
    );
}

#[test]
fn the_methods_page_is_the_registry() {
    let page = read(&root().join("docs/methods.md"));
    assert_eq!(
        page,
        deformlab::methods::registry::reference_markdown(),
        "docs/methods.md differs from `deformlab methods`: regenerate it with \
         `deformlab methods > docs/methods.md`"
    );
}

/// `--help` is plain text: no rustdoc link syntax (``[`FastOptions::verify_top`]``)
/// leaks from the library's doc comments into any command's help.
#[test]
fn help_texts_have_no_rustdoc_syntax() {
    for c in [
        "gen",
        "inspect",
        "bench",
        "keypoints",
        "transfer",
        "weights",
        "run",
        "merge",
        "plot",
        "methods",
    ] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_deformlab"))
            .args([c, "--help"])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "deformlab {c} --help failed");
        for bad in ["[`", "`]", "crate::"] {
            assert!(
                !text.contains(bad),
                "deformlab {c} --help shows rustdoc syntax {bad:?}:\n{}",
                text.lines()
                    .filter(|l| l.contains(bad))
                    .collect::<Vec<_>>()
                    .join("\n")
            );
        }
    }
}

/// The keys a config table accepts, as the parser lists them when it meets
/// an unknown one (`expected one of `a`, `b``), so this list is the code's.
fn accepted(text: &str) -> Vec<String> {
    let e = match deformlab::experiment::parse_config(text, Path::new("probe.toml")) {
        Ok(_) => panic!("the probe was accepted:\n{text}"),
        Err(e) => e.to_string(),
    };
    let list = e
        .split("expected one of ")
        .nth(1)
        .or_else(|| e.split("expected ").nth(1))
        .unwrap_or_else(|| panic!("no key list in {e}"));
    list.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// Every key of every config table and every plot kind is described in the
/// configuration reference (`experiments/README.md`), in backticks: the
/// keys come from the parser itself.
#[test]
fn every_config_key_and_plot_kind_is_in_the_reference() {
    let reference = read(&root().join("experiments/README.md"));
    let methods = read(&root().join("docs/methods.md"));
    let method = "[[methods]]\nname = \"m\"\nkind = \"bdt\"\n";
    let probes: Vec<(&str, &str, String)> = vec![
        ("top level", "", format!("zzz = 1\n{method}")),
        (
            "[dataset]",
            "dataset.",
            format!("[dataset]\nzzz = 1\n{method}"),
        ),
        (
            "[dataset.synthetic]",
            "dataset.synthetic.",
            format!("[dataset.synthetic]\nzzz = 1\n{method}"),
        ),
        (
            "[dataset.faust]",
            "dataset.faust.",
            format!("[dataset.faust]\nzzz = 1\n{method}"),
        ),
        (
            "[dataset.tosca]",
            "dataset.tosca.",
            format!("[dataset.tosca]\nzzz = 1\n{method}"),
        ),
        (
            "[dataset.manifest]",
            "dataset.manifest.",
            format!("[dataset.manifest]\nzzz = 1\n{method}"),
        ),
        ("[cases]", "cases.", format!("[cases]\nzzz = 1\n{method}")),
        (
            "[defaults]",
            "defaults.",
            format!("[defaults]\nzzz = 1\n{method}"),
        ),
        (
            "[metrics]",
            "metrics.",
            format!("[metrics]\nzzz = 1\n{method}"),
        ),
        (
            "[outputs]",
            "outputs.",
            format!("[outputs]\nzzz = 1\n{method}"),
        ),
        ("[[methods]]", "methods.", format!("{method}zzz = 1\n")),
        (
            "[methods.fbt]",
            "methods.fbt.",
            format!("{method}[methods.fbt]\nzzz = 1\n"),
        ),
        (
            "[[outputs.plots]]",
            "outputs.plots.",
            format!("{method}[[outputs.plots]]\nkind = \"bars\"\nzzz = 1\n"),
        ),
        (
            "plot kinds",
            "",
            format!("{method}[[outputs.plots]]\nkind = \"zzz\"\n"),
        ),
        (
            "method kinds",
            "",
            "[[methods]]\nname = \"m\"\nkind = \"zzz\"\n".to_string(),
        ),
    ];
    let mut missing = Vec::new();
    for (table, prefix, text) in &probes {
        let keys = accepted(text);
        assert!(!keys.is_empty(), "{table}: no keys found");
        for k in keys {
            // Named in backticks, or set in an example (`k = …` in a
            // TOML block), or a table header (`[k]`, `[a.k]`).
            let named = reference.contains(&format!("`{k}`"))
                || reference.contains(&format!("`{prefix}{k}`"))
                || reference.contains(&format!("`{k} ="))
                || reference.lines().any(|l| {
                    let t = l.trim_start_matches(['#', ' ']);
                    t.starts_with(&format!("{k} = "))
                        || t.contains(&format!("[{k}]"))
                        || t.contains(&format!(".{k}]"))
                        || t.contains(&format!("[{k}."))
                });
            // Method kinds are the registry's page (generated, checked above).
            let named = named || (*table == "method kinds" && methods.contains(&format!("`{k}`")));
            // A method may set any pipeline key of [defaults] for itself.
            let named = named
                || (*table == "[[methods]]" && reference.contains(&format!("`defaults.{k}`")));
            if !named {
                missing.push(format!("{table} {k}"));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "experiments/README.md does not describe: {missing:?}"
    );
}

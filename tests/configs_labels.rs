//! Every shipped experiment config (`experiments/*.toml` and its
//! subfolders `real/`, `large/`, `bench/`, `examples/`) names each method
//! for readers: read with the library's own config parser, every method
//! has a `label`, and two method groups of one config never share one (the
//! methods of one group share their group's label: plots show a group by
//! the first label among its methods). Without a label a legend falls back
//! to the method key (`auto-handle-relative`, `sumner-markers`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use deformlab::experiment::load_config_schema;

/// The shipped experiment configs: `experiments/*.toml` and the `.toml`
/// files one folder down (dataset manifests live two folders down, in
/// `experiments/real/manifests/`, and are not experiments).
fn shipped_configs() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments");
    let mut out = Vec::new();
    let tomls = |dir: &Path| -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_file() && p.extension().is_some_and(|x| x == "toml"))
            .collect();
        v.sort();
        v
    };
    out.extend(tomls(&root));
    for sub in ["real", "large", "bench", "examples"] {
        out.extend(tomls(&root.join(sub)));
    }
    out
}

#[test]
fn every_shipped_method_has_a_label_of_its_own() {
    let configs = shipped_configs();
    assert!(configs.len() >= 40, "{} configs found", configs.len());
    let mut problems = Vec::new();
    for path in &configs {
        let loaded = load_config_schema(path)
            .unwrap_or_else(|e| panic!("{}: does not parse: {e}", path.display()));
        // label → the group that uses it
        let mut owner: BTreeMap<&str, String> = BTreeMap::new();
        for m in &loaded.config.methods {
            let group = m.group.clone().unwrap_or_else(|| m.name.clone());
            let Some(label) = m.label.as_deref() else {
                problems.push(format!(
                    "{}: method {} has no label",
                    path.display(),
                    m.name
                ));
                continue;
            };
            if label.trim().is_empty() {
                problems.push(format!(
                    "{}: method {} has an empty label",
                    path.display(),
                    m.name
                ));
            }
            match owner.get(label) {
                Some(g) if *g != group => problems.push(format!(
                    "{}: label {label:?} names both group {g} and method {} (group {group})",
                    path.display(),
                    m.name
                )),
                Some(_) => {}
                None => {
                    owner.insert(label, group);
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

//! The import structure of `src/` (DESIGN.md, "Layers"): no import loop
//! between files, and top-level modules import only the layers below them.
//! Read from the source text: every `crate::…` and `super::…` path in code
//! (comments skipped) is resolved to the deepest module file it names.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

type Module = Vec<String>;

fn modules(root: &Path) -> BTreeMap<Module, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(root).unwrap().with_extension("");
                let mut parts: Module = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if parts.last().is_some_and(|l| l == "mod") {
                    parts.pop();
                }
                if parts == ["lib"] || parts == ["main"] {
                    continue;
                }
                let code: String = std::fs::read_to_string(&p)
                    .unwrap()
                    .lines()
                    .filter(|l| !l.trim_start().starts_with("//"))
                    .map(|l| l.split("//").next().unwrap_or(""))
                    .collect::<Vec<_>>()
                    .join("\n");
                out.insert(parts, code);
            }
        }
    }
    out
}

fn is_ident(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .next()
            .is_some_and(|c| c.is_ascii_lowercase() || c == '_')
        && s.chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

/// The paths after each occurrence of `prefix` (`crate::` or `super::`),
/// with `{a, b::c}` groups expanded one level.
fn paths_after(code: &str, prefix: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for (i, _) in code.match_indices(prefix) {
        let before = code[..i].chars().last();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        let rest = &code[i + prefix.len()..];
        let seg = |s: &str| -> Vec<String> {
            s.split("::")
                .map(str::trim)
                .take_while(|x| is_ident(x))
                .map(str::to_string)
                .collect()
        };
        if let Some(inner) = rest.strip_prefix('{') {
            let inner = &inner[..inner.find('}').unwrap_or(inner.len())];
            out.extend(inner.split(',').map(seg));
        } else {
            let end = rest
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(rest.len());
            out.push(seg(&rest[..end]));
        }
    }
    out
}

fn edges(mods: &BTreeMap<Module, String>) -> BTreeMap<Module, BTreeSet<Module>> {
    let resolve = |path: &[String]| -> Option<Module> {
        (1..=path.len())
            .rev()
            .map(|k| path[..k].to_vec())
            .find(|m| mods.contains_key(m))
    };
    let mut out: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (m, code) in mods {
        let e = out.entry(m.clone()).or_default();
        let mut targets: Vec<Module> = paths_after(code, "crate::")
            .into_iter()
            .filter_map(|p| resolve(&p))
            .collect();
        let parent: Module = m[..m.len().saturating_sub(1)].to_vec();
        for p in paths_after(code, "super::") {
            let full: Module = parent.iter().cloned().chain(p).collect();
            targets.extend(resolve(&full));
        }
        for t in targets {
            // A module's own ancestors (its `mod.rs` re-exports) are not imports.
            if t != *m && !m.starts_with(&t) {
                e.insert(t);
            }
        }
    }
    out
}

/// Strongly connected components with more than one module.
fn loops(g: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    let nodes: Vec<&Module> = g.keys().collect();
    let reach = |from: &Module| -> BTreeSet<Module> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.clone()];
        while let Some(v) = stack.pop() {
            for w in g.get(&v).into_iter().flatten() {
                if seen.insert(w.clone()) {
                    stack.push(w.clone());
                }
            }
        }
        seen
    };
    let r: BTreeMap<&Module, BTreeSet<Module>> = nodes.iter().map(|v| (*v, reach(v))).collect();
    let mut done = BTreeSet::new();
    let mut out = Vec::new();
    for v in &nodes {
        if done.contains(*v) {
            continue;
        }
        let comp: Vec<Module> = nodes
            .iter()
            .filter(|w| r[*v].contains(**w) && r[**w].contains(*v))
            .map(|w| (*w).clone())
            .collect();
        for c in &comp {
            done.insert(c.clone());
        }
        if comp.len() > 1 {
            out.push(comp);
        }
    }
    out
}

fn src() -> BTreeMap<Module, String> {
    modules(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"))
}

#[test]
fn no_import_loop_between_files() {
    let g = edges(&src());
    let l = loops(&g);
    let show: Vec<String> = l
        .iter()
        .map(|c| {
            c.iter()
                .map(|m| m.join("::"))
                .collect::<Vec<_>>()
                .join(" ↔ ")
        })
        .collect();
    assert!(l.is_empty(), "import loops: {show:#?}");
}

#[test]
fn top_level_modules_import_only_lower_layers() {
    // DESIGN.md: imports point downward only. Rank = layer (higher may
    // import lower; equal ranks may not import each other).
    let rank: BTreeMap<&str, u32> = [
        ("cli", 8),
        ("bench", 7),
        ("experiment", 6),
        ("methods", 5),
        ("transfer", 4),
        ("baselines", 4),
        ("arap", 3),
        ("register", 3),
        // Metrics and plots sit low: the algorithms report residuals with them.
        ("eval", 2),
        ("plot", 3),
        // Option ranges (serde): above the data's limits they name.
        ("range", 3),
        ("skin", 2),
        ("data", 2),
        ("ops", 1),
        ("solve", 0),
        ("mesh", 0),
        ("error", 0),
    ]
    .into_iter()
    .collect();
    let g = edges(&src());
    let mut bad = Vec::new();
    for (m, ts) in &g {
        for t in ts {
            let (a, b) = (m[0].as_str(), t[0].as_str());
            if a == b {
                continue;
            }
            let (Some(&ra), Some(&rb)) = (rank.get(a), rank.get(b)) else {
                bad.push(format!(
                    "{} → {} (module without a layer)",
                    m.join("::"),
                    t.join("::")
                ));
                continue;
            };
            if ra <= rb {
                bad.push(format!("{} → {}", m.join("::"), t.join("::")));
            }
        }
    }
    assert!(bad.is_empty(), "upward or sideways imports: {bad:#?}");
}

/// The checker finds a loop where there is one (so the tests above can fail).
#[test]
fn the_checker_sees_a_planted_loop() {
    let mut m = BTreeMap::new();
    m.insert(vec!["a".to_string()], "use crate::b::X;".to_string());
    m.insert(
        vec!["b".to_string()],
        "fn f() { crate::c::g() }".to_string(),
    );
    m.insert(vec!["c".to_string()], "use crate::{a::Y, b};".to_string());
    m.insert(vec!["d".to_string()], "use crate::a;".to_string());
    let l = loops(&edges(&m));
    assert_eq!(l.len(), 1);
    assert_eq!(l[0].len(), 3);
}

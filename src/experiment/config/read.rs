//! Reading a config: TOML text to [`Config`], parse errors named by key
//! path and line, and the methods resolved through the registry
//! ([`crate::methods::registry`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::{bad, valid_name, Config, LoadedConfig, NamedMethod};
use crate::data::DataRoot;
use crate::methods::registry::resolve_entry;
use crate::{Error, Result};

/// The key path (`methods[1].n_candidates`) and line of a byte offset in a
/// TOML text, reconstructed from the table headers above it and the key on
/// its line.
pub(super) fn key_at(text: &str, offset: usize) -> (String, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_no = text[..offset].matches('\n').count() + 1;
    let mut table = String::new();
    let mut arrays: BTreeMap<String, usize> = BTreeMap::new();
    let mut array_paths: BTreeMap<String, String> = BTreeMap::new();
    for line in text[..line_start].lines() {
        let t = line.trim();
        if let Some(inner) = t.strip_prefix("[[").and_then(|r| r.split("]]").next()) {
            let name = inner.trim().to_string();
            let c = arrays.entry(name.clone()).or_insert(0);
            let path = format!("{}[{}]", expand(&name, &array_paths), *c);
            *c += 1;
            array_paths.insert(name, path.clone());
            table = path;
        } else if let Some(inner) = t.strip_prefix('[').and_then(|r| r.split(']').next()) {
            table = expand(inner.trim(), &array_paths);
        }
    }
    let line_end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = &text[line_start..line_end];
    let before = &text[line_start..offset];
    let word = |s: &str| -> Option<String> {
        let w: String = s
            .trim_start()
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == '-')
            .collect();
        (!w.is_empty()).then_some(w)
    };
    let key = if line.trim_start().starts_with('[') {
        None
    } else if before.trim().is_empty() {
        word(&text[offset..line_end])
    } else {
        // The last `key =` before the offset on this line (inline tables too).
        let mut found = None;
        let mut inline_path: Vec<String> = Vec::new();
        for (i, ch) in before.char_indices() {
            if ch == '=' {
                let head = before[..i].trim_end();
                let start = head
                    .rfind(|c: char| {
                        !(c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.')
                    })
                    .map_or(0, |p| {
                        p + head[p..].chars().next().map_or(1, char::len_utf8)
                    });
                let k = head[start..].to_string();
                if !k.is_empty() {
                    found = Some(k);
                }
            } else if ch == '{' {
                if let Some(k) = found.take() {
                    inline_path.push(k);
                }
            } else if ch == '}' {
                inline_path.pop();
            }
        }
        found.map(|k| {
            if inline_path.is_empty() {
                k
            } else {
                format!("{}.{k}", inline_path.join("."))
            }
        })
    };
    let path = match (table.is_empty(), key) {
        (_, None) => table,
        (true, Some(k)) => k,
        (false, Some(k)) => format!("{table}.{k}"),
    };
    (path, line_no)
}

/// `methods.x` → `methods[2].x` when `methods` is an array of tables.
fn expand(name: &str, arrays: &BTreeMap<String, String>) -> String {
    let mut best: Option<(&String, &String)> = None;
    for (k, v) in arrays {
        if name.starts_with(&format!("{k}.")) && best.is_none_or(|(b, _)| k.len() > b.len()) {
            best = Some((k, v));
        }
    }
    match best {
        Some((k, v)) => format!("{v}{}", &name[k.len()..]),
        None => name.to_string(),
    }
}

/// Parses a config text and resolves its methods (no dataset or output
/// checks), with the data root `root`.
pub(crate) fn parse_unchecked_in(text: &str, path: &Path, root: &DataRoot) -> Result<LoadedConfig> {
    let config: Config = toml::from_str(text).map_err(|e| {
        let msg = e.message().trim().to_string();
        match e.span() {
            Some(span) => {
                let (key, line) = key_at(text, span.start);
                let location = if key.is_empty() {
                    format!("line {line}")
                } else {
                    format!("key `{key}` (line {line})")
                };
                Error::parse(path, location, msg)
            }
            None => Error::parse(path, "config", msg),
        }
    })?;
    let base_dir = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let methods = resolve(&config, path)?;
    let loaded = LoadedConfig {
        config,
        path: path.to_path_buf(),
        base_dir,
        data_root: root.clone(),
        methods,
        overrides: Vec::new(),
        sweep: None,
    };
    Ok(loaded)
}

fn resolve(config: &Config, path: &Path) -> Result<Vec<NamedMethod>> {
    if !valid_name(&config.name) {
        return Err(bad(
            path,
            "name",
            format!(
                "expected a folder name of letters, digits, '-', '_' or '.', got {:?}",
                config.name
            ),
        ));
    }
    if config.methods.is_empty() {
        return Err(bad(
            path,
            "methods",
            "expected at least one [[methods]] entry",
        ));
    }
    let mut out: Vec<NamedMethod> = Vec::new();
    for (i, m) in config.methods.iter().enumerate() {
        let key = |k: &str| format!("methods[{i}].{k}");
        if !valid_name(&m.name) {
            return Err(bad(
                path,
                key("name"),
                format!(
                    "expected letters, digits, '-', '_' or '.', got {:?}",
                    m.name
                ),
            ));
        }
        if out.iter().any(|o| o.name == m.name) {
            return Err(bad(
                path,
                key("name"),
                format!("{:?} is used twice", m.name),
            ));
        }
        let method = resolve_entry(m, &config.defaults, config.seed)
            .map_err(|(k, msg)| bad(path, key(&k), msg))?;
        out.push(NamedMethod {
            name: m.name.clone(),
            group: m.group.clone().unwrap_or_else(|| m.name.clone()),
            method,
        });
    }
    Ok(out)
}

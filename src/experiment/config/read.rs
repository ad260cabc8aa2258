//! Reading a config: TOML text to [`Config`], parse errors named by key
//! path and line, and the methods resolved through the registry
//! ([`crate::methods::registry`]).

use std::path::{Path, PathBuf};

use super::{bad, valid_name, Config, LoadedConfig, NamedMethod};
use crate::data::DataRoot;
use crate::methods::registry::resolve_entry;
use crate::{Error, Result};

/// The key path (`methods[1].n_candidates`) and line of a byte offset in a
/// TOML text, found in the document's parse tree (with its spans): the
/// innermost key, value or array element whose span holds the offset, else
/// the table whose header is the last before it (a `[[methods]]` header
/// names `methods[i]`, a value spread over lines names its key). A document
/// that does not parse cleanly (a duplicate key) is read as far as it goes.
pub(super) fn key_at(text: &str, offset: usize) -> (String, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let line_no = text[..offset].matches('\n').count() + 1;
    let (doc, _) = toml::de::DeTable::parse_recoverable(text);
    let mut spans = Vec::new();
    collect_spans(doc.get_ref(), "", text, &mut spans);
    // The innermost span holding the offset (ties: the later-collected,
    // deeper one).
    let inner = spans
        .iter()
        .filter(|s| s.range.contains(&offset))
        .min_by_key(|s| s.range.len());
    let path = match inner {
        Some(s) => s.path.clone(),
        None => spans
            .iter()
            .filter(|s| s.header && s.range.start <= offset)
            .max_by_key(|s| s.range.start)
            .map(|s| s.path.clone())
            .unwrap_or_default(),
    };
    (path, line_no)
}

/// A span of a config text and the key path it belongs to; `header`: the
/// span is a `[table]` or `[[array]]` header.
struct KeySpan {
    range: std::ops::Range<usize>,
    path: String,
    header: bool,
}

fn collect_spans(table: &toml::de::DeTable<'_>, prefix: &str, text: &str, out: &mut Vec<KeySpan>) {
    use toml::de::DeValue;
    let join = |k: &str| {
        if prefix.is_empty() {
            k.to_string()
        } else {
            format!("{prefix}.{k}")
        }
    };
    let is_header =
        |r: &std::ops::Range<usize>| text.get(r.clone()).is_some_and(|t| t.starts_with('['));
    for (k, v) in table.iter() {
        let path = join(k.get_ref());
        out.push(KeySpan {
            range: k.span(),
            path: path.clone(),
            header: false,
        });
        let vr = v.span();
        match v.get_ref() {
            DeValue::Table(t) => {
                out.push(KeySpan {
                    header: is_header(&vr),
                    range: vr,
                    path: path.clone(),
                });
                collect_spans(t, &path, text, out);
            }
            DeValue::Array(a) => {
                let header = a.iter().any(|e| is_header(&e.span()));
                if !header {
                    out.push(KeySpan {
                        range: vr,
                        path: path.clone(),
                        header: false,
                    });
                }
                for (i, e) in a.iter().enumerate() {
                    let p = format!("{path}[{i}]");
                    let er = e.span();
                    out.push(KeySpan {
                        header: is_header(&er),
                        range: er,
                        path: p.clone(),
                    });
                    if let DeValue::Table(t) = e.get_ref() {
                        collect_spans(t, &p, text, out);
                    }
                }
            }
            _ => out.push(KeySpan {
                range: vr,
                path,
                header: false,
            }),
        }
    }
}

/// Parses a config text and resolves its methods (no dataset or output
/// checks), with the data root `root`.
pub(crate) fn parse_unchecked_in(text: &str, path: &Path, root: &DataRoot) -> Result<LoadedConfig> {
    let config: Config = toml::from_str(text).map_err(|e| {
        let msg = e.message().trim().to_string();
        match e.span() {
            Some(span) => {
                let (mut key, line) = key_at(text, span.start);
                // An unknown key of an inline table is reported at the table.
                if let Some(field) = msg
                    .strip_prefix("unknown field `")
                    .and_then(|r| r.split('`').next())
                {
                    let last = key.rsplit('.').next().unwrap_or("");
                    if last != field {
                        key = if key.is_empty() {
                            field.to_string()
                        } else {
                            format!("{key}.{field}")
                        };
                    }
                }
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

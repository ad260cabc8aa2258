//! Command-line overrides and sweeps of a config.
//!
//! **Overrides** (`deformlab run cfg.toml --set KEY=VALUE`): `KEY` is the
//! key's path as in the error messages of the file — `defaults.epsilon`,
//! `cases.repeat`, `dataset.synthetic.subjects`, `name` — with methods
//! addressed by name (`methods.auto.n_candidates`, `methods.q4.fbt.q`) or
//! by position (`methods[0].epsilon`); `VALUE` is a TOML value (`0.02`,
//! `true`, `[1, 2]`, `"fast"`; a bare word is a string). Each override is
//! applied to the file's TOML in order, then read exactly as the file is:
//! an unknown key or a bad value is the file's error, naming the override.
//!
//! **Sweeps** expand methods into variants. In the file:
//!
//! ```toml
//! [sweep]                                   # one grid: the product of its keys
//! defaults.epsilon = [0.01, 0.02, 0.03, 0.05]
//! methods.auto.n_candidates = { values = [50, 100], names = ["nc50", "nc100"] }
//!
//! [[sweep]]                                 # or several grids, their union
//! defaults.target_noise = { values = [0], names = ["r0"] }
//! ```
//!
//! or on the command line, `--sweep defaults.epsilon=0.01,0.02,0.03,0.05`
//! (an axis added to every grid of the file's sweep, or the one grid).
//! A `defaults.KEY` axis expands every method whose resolved options it
//! changes (not one that sets KEY itself, nor the `identity` floor); a
//! `methods.NAME.KEY` axis expands that method. Each method is replaced, in
//! place, by its variants, grid by grid, axis values in the product's order
//! (first axis outermost); a variant is the method with KEY set on it, named
//! `NAME-PART-PART…` with one part per axis: the axis's `names`, else the
//! key's short name and the value (`auto-eps0.02`; `eps` for `epsilon`, the
//! key itself otherwise; a string value is its own part). Its plot `group`
//! is the method's group (else its name) with the parts of the axes that
//! have `group = true` — the default, except for seeds (`seed`,
//! `*_seed`), whose variants are replicates averaged in one group. A
//! method's `label` becomes the variant's label with those parts
//! (`BDT (ours) (epsilon = 0.02)`), so legends and tables tell the variants
//! apart. A
//! plot's `methods` list naming an expanded method names its variants. A
//! swept key with a `cases.csv` column (`epsilon`, `n_candidates`, `q`,
//! `target_noise`, …) gets a line plot of the error against that column
//! (`plots/line_<column>`) unless a plot has it as `x` already.
//!
//! The expanded config is what is run, stored (its hash is the results
//! folder's key) and recorded in `manifest.json`, with the overrides
//! (`overrides`) and the sweep (`sweep`: its axes and each method's variants).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use toml::{Table, Value};

use super::config::{
    parse_unchecked_in, valid_name, FbtTask, LoadedConfig, Method, PlotKind, PlotSpec, CASE_COLUMNS,
};
use crate::{Error, Result};

/// One axis of a sweep grid.
#[derive(Clone, Debug)]
struct Axis {
    /// The key as written (`defaults.epsilon`, `methods.auto.fbt.q`).
    key: String,
    target: Target,
    values: Vec<Value>,
    names: Option<Vec<String>>,
    /// `group` as given (default: [`Axis::groups`]).
    group: Option<bool>,
    /// `config` or `--sweep`.
    from: &'static str,
}

#[derive(Clone, Debug, PartialEq)]
enum Target {
    /// `defaults.KEY`: every method it changes.
    Defaults(String),
    /// `methods.NAME.KEY`.
    Method(String, String),
}

impl Target {
    /// The key inside a method entry.
    fn rel(&self) -> &str {
        match self {
            Target::Defaults(k) | Target::Method(_, k) => k,
        }
    }
}

impl Axis {
    /// Whether the variants of different values go to different plot
    /// groups: as given, else for every key but seeds.
    fn groups(&self) -> bool {
        self.group.unwrap_or(!is_seed(self.target.rel()))
    }

    /// The name part of value `j`.
    fn part(&self, j: usize) -> String {
        if let Some(n) = &self.names {
            return n[j].clone();
        }
        let last = self.target.rel().rsplit('.').next().unwrap_or_default();
        let short = match last {
            "epsilon" => "eps",
            other => other,
        };
        match &self.values[j] {
            Value::Integer(i) => format!("{short}{i}"),
            Value::Float(f) => format!("{short}{f}"),
            Value::Boolean(b) => format!("{short}-{b}"),
            Value::String(s) => s.clone(),
            other => format!("{short}{other}"),
        }
    }
}

impl Axis {
    /// The part of a variant's display label for value `j`: the axis's
    /// `names`, else `key = value` (`epsilon = 0.02`), a string value
    /// itself.
    fn label_part(&self, j: usize) -> String {
        if let Some(n) = &self.names {
            return n[j].clone();
        }
        let last = self.target.rel().rsplit('.').next().unwrap_or_default();
        match &self.values[j] {
            Value::String(s) => s.clone(),
            v => format!("{last} = {v}"),
        }
    }
}

/// Whether a key's variants are replicates by default (`group = false`).
fn is_seed(rel: &str) -> bool {
    let last = rel.rsplit('.').next().unwrap_or_default();
    last == "seed" || last.ends_with("_seed")
}

/// A command-line value: a TOML value, else the text as a string.
fn parse_value(raw: &str) -> Value {
    let t = raw.trim();
    if !t.contains('\n') {
        if let Ok(mut table) = toml::from_str::<Table>(&format!("v = {t}")) {
            if let Some(v) = table.remove("v") {
                return v;
            }
        }
    }
    Value::String(t.to_string())
}

fn show(v: &Value) -> String {
    v.to_string()
}

/// The position of the array element (a table) that `rest` names: `[i]…`,
/// or the longest `name` of an element that `rest` is or starts with
/// (followed by `.`). Returns the index and what follows.
fn element<'a>(array: &[Value], rest: &'a str) -> std::result::Result<(usize, &'a str), String> {
    if let Some(r) = rest.strip_prefix('[') {
        let (i, after) = r
            .split_once(']')
            .ok_or_else(|| format!("expected `[index]`, got {rest:?}"))?;
        let i: usize = i
            .trim()
            .parse()
            .map_err(|_| format!("expected `[index]`, got {rest:?}"))?;
        if i >= array.len() {
            return Err(format!(
                "index {i} is out of range: there are {} entries",
                array.len()
            ));
        }
        return Ok((i, after.strip_prefix('.').unwrap_or(after)));
    }
    let mut best: Option<(usize, usize)> = None;
    for (i, v) in array.iter().enumerate() {
        let Some(name) = v.get("name").and_then(Value::as_str) else {
            continue;
        };
        let fits = rest == name
            || rest
                .strip_prefix(name)
                .is_some_and(|after| after.starts_with('.'));
        if fits && best.is_none_or(|(_, l)| name.len() > l) {
            best = Some((i, name.len()));
        }
    }
    match best {
        Some((i, l)) => Ok((i, rest[l..].strip_prefix('.').unwrap_or(""))),
        None => {
            let names: Vec<&str> = array
                .iter()
                .filter_map(|v| v.get("name").and_then(Value::as_str))
                .collect();
            let want = rest.split('.').next().unwrap_or(rest);
            Err(if names.is_empty() {
                format!("no entry is named {want:?} (address entries by position, e.g. `[0]`)")
            } else {
                format!("no entry is named {want:?}; names: {}", names.join(", "))
            })
        }
    }
}

/// Sets `key` (a dotted path; arrays of tables addressed by `name` or
/// `[index]`) in `t` to `v`, creating missing tables on the way.
fn set_path(t: &mut Table, key: &str, v: Value) -> std::result::Result<(), String> {
    let (head, rest) = match key.find(['.', '[']) {
        Some(i) => (&key[..i], &key[i..]),
        None => (key, ""),
    };
    if head.is_empty()
        || !head
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(format!("{key:?} is not a key path"));
    }
    if rest.is_empty() {
        t.insert(head.to_string(), v);
        return Ok(());
    }
    let rest = rest.strip_prefix('.').unwrap_or(rest);
    let slot = t
        .entry(head.to_string())
        .or_insert_with(|| Value::Table(Table::new()));
    match slot {
        Value::Table(inner) => set_path(inner, rest, v),
        Value::Array(array) => {
            let (i, after) = element(array, rest).map_err(|e| format!("`{head}`: {e}"))?;
            if after.is_empty() {
                return Err(format!(
                    "`{head}` entries are tables: name a key inside one"
                ));
            }
            match &mut array[i] {
                Value::Table(inner) => set_path(inner, after, v),
                _ => Err(format!("`{head}[{i}]` is not a table")),
            }
        }
        _ => Err(format!("`{head}` is a value, not a table")),
    }
}

/// `KEY=VALUE` split at the first `=`.
fn assignment<'a>(s: &'a str, flag: &str, form: &str) -> Result<(&'a str, &'a str)> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| Error::invalid(format!("{flag} expects {form}, got {s:?}")))?;
    let k = k.trim();
    if k.is_empty() {
        return Err(Error::invalid(format!("{flag} expects {form}, got {s:?}")));
    }
    Ok((k, v))
}

/// A parse error of a regenerated config, attributed to `what` (an
/// override or a sweep value) instead of a line of a text the user never
/// saw.
fn attribute(e: Error, path: &Path, what: &str) -> Error {
    match e {
        Error::Parse {
            location, message, ..
        } => {
            let loc = match location.find(" (line ") {
                Some(i) => location[..i].to_string(),
                None if location.starts_with("line ") => String::new(),
                None => location,
            };
            let message = if loc.is_empty() || loc == "config" {
                message
            } else {
                format!("{loc}: {message}")
            };
            Error::parse(path, what, message)
        }
        other => other,
    }
}

/// Reads a config from its (modified) TOML table, as the file would be read.
fn reparse(t: &Table, l: &LoadedConfig) -> Result<LoadedConfig> {
    let text = toml::to_string(t).map_err(|e| Error::invalid(format!("config to TOML: {e}")))?;
    parse_unchecked_in(&text, &l.path, &l.data_root)
}

/// The axes of one grid of the file's `[sweep]` (nested tables of dotted
/// keys flattened; a leaf is a list of values or `{ values, names, group }`).
fn flatten(t: &Table, prefix: &str, out: &mut Vec<(String, Value)>) {
    for (k, v) in t {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Value::Table(x) if !x.contains_key("values") => flatten(x, &key, out),
            other => out.push((key, other.clone())),
        }
    }
}

/// An axis read from the file (`where_` names it in errors: `sweep.KEY`).
fn file_axis(path: &Path, where_: &str, key: String, v: &Value) -> Result<Axis> {
    let bad = |k: &str, m: String| Error::parse(path, format!("key `{k}`"), m);
    let (values, names, group) = match v {
        Value::Array(a) => (a.clone(), None, None),
        Value::Table(t) => {
            for k in t.keys() {
                if !matches!(k.as_str(), "values" | "names" | "group") {
                    return Err(bad(
                        &format!("{where_}.{k}"),
                        "unknown field; expected `values`, `names` or `group`".into(),
                    ));
                }
            }
            let values = match t.get("values") {
                Some(Value::Array(a)) => a.clone(),
                _ => {
                    return Err(bad(
                        &format!("{where_}.values"),
                        "expected a list of values".into(),
                    ))
                }
            };
            let names = match t.get("names") {
                None => None,
                Some(Value::Array(a)) => {
                    let n: Option<Vec<String>> =
                        a.iter().map(|x| x.as_str().map(str::to_string)).collect();
                    match n {
                        Some(n) if n.len() == values.len() => Some(n),
                        _ => {
                            return Err(bad(
                                &format!("{where_}.names"),
                                format!(
                                    "expected one name (a string) per value: {} values",
                                    values.len()
                                ),
                            ))
                        }
                    }
                }
                Some(_) => {
                    return Err(bad(
                        &format!("{where_}.names"),
                        "expected a list of names".into(),
                    ))
                }
            };
            let group = match t.get("group") {
                None => None,
                Some(Value::Boolean(b)) => Some(*b),
                Some(_) => {
                    return Err(bad(
                        &format!("{where_}.group"),
                        "expected true or false".into(),
                    ))
                }
            };
            (values, names, group)
        }
        _ => {
            return Err(bad(
                where_,
                "expected a list of values, or a table { values = [...], names = [...], \
                 group = true }"
                    .into(),
            ))
        }
    };
    if values.is_empty() {
        return Err(bad(where_, "expected at least one value".into()));
    }
    Ok(Axis {
        key,
        target: Target::Defaults(String::new()),
        values,
        names,
        group,
        from: "config",
    })
}

/// The grids of the file's `sweep` value.
fn file_grids(path: &Path, v: &Value) -> Result<Vec<Vec<Axis>>> {
    let grid = |t: &Table, where_: &str| -> Result<Vec<Axis>> {
        let mut leaves = Vec::new();
        flatten(t, "", &mut leaves);
        if leaves.is_empty() {
            return Err(Error::parse(
                path,
                format!("key `{where_}`"),
                "expected at least one swept key, e.g. defaults.epsilon = [0.01, 0.02]",
            ));
        }
        leaves
            .into_iter()
            .map(|(k, v)| file_axis(path, &format!("{where_}.{k}"), k, &v))
            .collect()
    };
    match v {
        Value::Table(t) => Ok(vec![grid(t, "sweep")?]),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .map(|(i, g)| match g {
                Value::Table(t) => grid(t, &format!("sweep[{i}]")),
                _ => Err(Error::parse(
                    path,
                    format!("key `sweep[{i}]`"),
                    "expected a table of swept keys",
                )),
            })
            .collect(),
        _ => Err(Error::parse(
            path,
            "key `sweep`",
            "expected a table of swept keys ([sweep]) or a list of them ([[sweep]])",
        )),
    }
}

/// `--sweep KEY=V1,V2,...`.
fn cli_axis(s: &str) -> Result<Axis> {
    let form = "KEY=V1,V2,... (e.g. defaults.epsilon=0.01,0.02)";
    let (k, vs) = assignment(s, "--sweep", form)?;
    let values: Vec<Value> = vs
        .split(',')
        .filter(|v| !v.trim().is_empty())
        .map(parse_value)
        .collect();
    if values.is_empty() {
        return Err(Error::invalid(format!(
            "--sweep {s}: expected at least one value ({form})"
        )));
    }
    Ok(Axis {
        key: k.to_string(),
        target: Target::Defaults(String::new()),
        values,
        names: None,
        group: None,
        from: "--sweep",
    })
}

/// Applies the overrides and expands the sweep of a config (see the module
/// documentation). `base` is the file as read, `text` its TOML.
pub fn vary(
    base: LoadedConfig,
    text: &str,
    set: &[String],
    sweep: &[String],
) -> Result<LoadedConfig> {
    if set.is_empty() && sweep.is_empty() && base.config.sweep.is_none() {
        return Ok(base);
    }
    let path = base.path.clone();
    let mut table: Table =
        toml::from_str(text).map_err(|e| Error::parse(&path, "config", e.message().to_string()))?;
    let mut current = base;
    for s in set {
        let what = format!("--set {s}");
        let (k, v) = assignment(s, "--set", "KEY=VALUE (e.g. defaults.epsilon=0.02)")?;
        if k == "sweep" || k.starts_with("sweep.") {
            return Err(Error::parse(
                &path,
                what,
                "the sweep is not set with --set; use --sweep KEY=V1,V2,...",
            ));
        }
        let value = parse_value(v);
        // A table given for an existing table would replace it whole: the
        // file's other keys there would silently fall back to defaults.
        if value.is_table() && is_table_at(&table, k) {
            return Err(Error::parse(
                &path,
                what,
                format!(
                    "`{k}` is a table of the config; a table value would replace all of it                      (its other keys reverting to their defaults): set its keys one by one,                      e.g. --set {k}.KEY=VALUE"
                ),
            ));
        }
        set_path(&mut table, k, value).map_err(|m| Error::parse(&path, &what, m))?;
        let t = strip_sweep(&table);
        current = reparse(&t, &current).map_err(|e| attribute(e, &path, &what))?;
    }
    let mut grids = match table.get("sweep") {
        Some(v) => file_grids(&path, v)?,
        None => Vec::new(),
    };
    let cli: Vec<Axis> = sweep.iter().map(|s| cli_axis(s)).collect::<Result<_>>()?;
    if grids.is_empty() && !cli.is_empty() {
        grids.push(Vec::new());
    }
    for g in &mut grids {
        g.extend(cli.iter().cloned());
    }
    // A key both set and swept: the sweep's values would replace the set
    // one in every variant.
    for s in set {
        let (k, _) = assignment(s, "--set", "KEY=VALUE")?;
        if let Some(a) = grids.iter().flatten().find(|a| a.key == k) {
            return Err(Error::parse(
                &path,
                format!("--set {s}"),
                format!(
                    "`{k}` is also swept ({}): its values would replace the set one; drop                      one of the two",
                    if a.from == "config" { "[sweep]" } else { "--sweep" }
                ),
            ));
        }
    }
    table.remove("sweep");
    let mut out = if grids.is_empty() {
        current
    } else {
        expand(&mut table, &mut grids, &current)?
    };
    out.overrides = set.to_vec();
    Ok(out)
}

/// Whether the dotted `key` (no array addressing) names a table in `t`.
fn is_table_at(t: &Table, key: &str) -> bool {
    let mut cur = t;
    let mut parts = key.split('.').peekable();
    while let Some(p) = parts.next() {
        match cur.get(p) {
            Some(Value::Table(inner)) if parts.peek().is_none() => return !inner.is_empty(),
            Some(Value::Table(inner)) => cur = inner,
            _ => return false,
        }
    }
    false
}

fn strip_sweep(t: &Table) -> Table {
    let mut t = t.clone();
    t.remove("sweep");
    t
}

/// The methods array of a config table (entries as tables).
fn methods_of(t: &Table) -> Vec<Table> {
    t.get("methods")
        .and_then(Value::as_array)
        .map(|a| a.iter().filter_map(|v| v.as_table().cloned()).collect())
        .unwrap_or_default()
}

/// Most methods a sweep may make (all grids, all swept methods).
pub const MAX_METHODS: usize = 1000;

fn expand(table: &mut Table, grids: &mut [Vec<Axis>], base: &LoadedConfig) -> Result<LoadedConfig> {
    let path = base.path.clone();
    let methods = methods_of(table);
    let method_values: Vec<Value> = methods.iter().cloned().map(Value::Table).collect();
    // Targets, checked against the methods and within each grid.
    for (gi, g) in grids.iter_mut().enumerate() {
        let mut seen = BTreeSet::new();
        for a in g.iter_mut() {
            let where_ = format!("sweep `{}`", a.key);
            if !seen.insert(a.key.clone()) {
                return Err(Error::parse(
                    &path,
                    where_,
                    format!("swept twice in grid {gi}"),
                ));
            }
            a.target = if let Some(rel) = a.key.strip_prefix("defaults.") {
                Target::Defaults(rel.to_string())
            } else if let Some(rest) = a
                .key
                .strip_prefix("methods.")
                .or_else(|| a.key.strip_prefix("methods").filter(|r| r.starts_with('[')))
            {
                let (i, rel) = element(&method_values, rest)
                    .map_err(|m| Error::parse(&path, &where_, format!("`methods`: {m}")))?;
                let name = methods[i]
                    .get("name")
                    .and_then(Value::as_str)
                    .unwrap_or_default()
                    .to_string();
                Target::Method(name, rel.to_string())
            } else {
                return Err(Error::parse(
                    &path,
                    where_,
                    "only method keys can be swept: `defaults.KEY` (every method it changes) \
                     or `methods.NAME.KEY`; set other keys with --set",
                ));
            };
            let rel = a.target.rel();
            if rel.is_empty() || rel == "name" || rel == "group" {
                return Err(Error::parse(
                    &path,
                    where_,
                    "expected a method option (e.g. epsilon, fbt.q), not a method's name or group",
                ));
            }
        }
    }
    // Every value read as the file would be, and which methods each key
    // changes.
    let mut dependents: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut values_of: BTreeMap<String, (Target, Vec<Value>)> = BTreeMap::new();
    for a in grids.iter().flatten() {
        let e = values_of
            .entry(a.key.clone())
            .or_insert_with(|| (a.target.clone(), Vec::new()));
        for v in &a.values {
            if !e.1.contains(v) {
                e.1.push(v.clone());
            }
        }
    }
    for (key, (target, values)) in &values_of {
        let mut resolved = Vec::new();
        for v in values {
            let mut t = table.clone();
            let k = match target {
                Target::Defaults(rel) => format!("defaults.{rel}"),
                Target::Method(name, rel) => {
                    let i = methods
                        .iter()
                        .position(|m| m.get("name").and_then(Value::as_str) == Some(name))
                        .unwrap_or_default();
                    format!("methods[{i}].{rel}")
                }
            };
            let what = format!("sweep `{key}` value {}", show(v));
            set_path(&mut t, &k, v.clone()).map_err(|m| Error::parse(&path, &what, m))?;
            resolved.push(reparse(&t, base).map_err(|e| attribute(e, &path, &what))?);
        }
        let set = dependents.entry(key.clone()).or_default();
        match target {
            Target::Method(name, _) => {
                set.insert(name.clone());
            }
            Target::Defaults(_) => {
                if resolved.len() == 1 {
                    resolved.push(base.clone());
                }
                for (i, m) in base.methods.iter().enumerate() {
                    let first = &resolved[0].methods[i].method;
                    if resolved.iter().any(|r| r.methods[i].method != *first) {
                        set.insert(m.name.clone());
                    }
                }
            }
        }
    }
    // The variants are counted before they are made.
    let mut count: usize = 0;
    for m in &methods {
        let name = m.get("name").and_then(Value::as_str).unwrap_or_default();
        for g in grids.iter() {
            let n = g
                .iter()
                .filter(|a| dependents.get(&a.key).is_some_and(|d| d.contains(name)))
                .fold(1usize, |n, a| n.saturating_mul(a.values.len()));
            count = count.saturating_add(n);
        }
    }
    if count > MAX_METHODS {
        return Err(Error::parse(
            &path,
            "key `sweep`",
            format!(
                "the sweep makes {count} methods (the product of its axes' values, for each                  method it varies); at most {MAX_METHODS}: sweep fewer values or split the                  sweep over several configs"
            ),
        ));
    }
    // The variants, method by method, grid by grid.
    let mut expanded: Vec<Value> = Vec::new();
    let mut variants_of: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut all_names: BTreeSet<String> = BTreeSet::new();
    for m in &methods {
        let name = m
            .get("name")
            .and_then(Value::as_str)
            .unwrap_or_default()
            .to_string();
        let mut variants: Vec<(String, Table)> = Vec::new();
        for g in grids.iter() {
            let axes: Vec<&Axis> = g
                .iter()
                .filter(|a| dependents.get(&a.key).is_some_and(|d| d.contains(&name)))
                .collect();
            if axes.is_empty() {
                variants.push((name.clone(), m.clone()));
                continue;
            }
            let total: usize = axes.iter().map(|a| a.values.len()).product();
            for mut k in 0..total {
                // Mixed radix, first axis outermost.
                let mut idx = vec![0; axes.len()];
                for (slot, a) in idx.iter_mut().zip(&axes).rev() {
                    *slot = k % a.values.len();
                    k /= a.values.len();
                }
                let mut x = m.clone();
                let mut parts = Vec::new();
                let mut group_parts = Vec::new();
                let mut label_parts = Vec::new();
                for (a, &j) in axes.iter().zip(&idx) {
                    let what = format!("sweep `{}` value {}", a.key, show(&a.values[j]));
                    set_path(&mut x, a.target.rel(), a.values[j].clone())
                        .map_err(|e| Error::parse(&path, &what, e))?;
                    let p = a.part(j);
                    if a.groups() {
                        group_parts.push(p.clone());
                        label_parts.push(a.label_part(j));
                    }
                    parts.push(p);
                }
                let vname = format!("{name}-{}", parts.join("-"));
                if !valid_name(&vname) {
                    return Err(Error::parse(
                        &path,
                        format!("sweep `{}`", axes[0].key),
                        format!(
                            "the variant name {vname:?} is not a valid method name (letters, \
                             digits, '-', '_', '.'); give the axis `names`"
                        ),
                    ));
                }
                let base_group = m
                    .get("group")
                    .and_then(Value::as_str)
                    .unwrap_or(&name)
                    .to_string();
                let group = if group_parts.is_empty() {
                    base_group
                } else {
                    format!("{base_group}-{}", group_parts.join("-"))
                };
                x.insert("name".into(), Value::String(vname.clone()));
                // A labelled method's variants are told apart in legends and
                // tables: `BDT (ours) (epsilon = 0.02)`; replicates (seed
                // axes) share their group and keep its label.
                if let Some(label) = m.get("label").and_then(Value::as_str) {
                    if !label_parts.is_empty() {
                        x.insert(
                            "label".into(),
                            Value::String(format!("{label} ({})", label_parts.join(", "))),
                        );
                    }
                }
                if group == vname {
                    x.remove("group");
                } else {
                    x.insert("group".into(), Value::String(group));
                }
                variants.push((vname, x));
            }
        }
        let mut kept: Vec<(String, Table)> = Vec::new();
        for (n, t) in variants {
            match kept.iter().find(|(k, _)| *k == n) {
                Some((_, same)) if *same == t => {}
                Some(_) => {
                    return Err(Error::parse(
                        &path,
                        "sweep",
                        format!(
                            "two different variants of method {name:?} are named {n:?}; give \
                             the axes `names` that tell them apart"
                        ),
                    ))
                }
                None => kept.push((n, t)),
            }
        }
        let is_expanded = !(kept.len() == 1 && kept[0].0 == name);
        for (n, t) in kept {
            if !all_names.insert(n.clone()) {
                return Err(Error::parse(
                    &path,
                    "sweep",
                    format!(
                        "the method name {n:?} is made twice (by the sweep or a [[methods]] entry)"
                    ),
                ));
            }
            if is_expanded {
                variants_of.entry(name.clone()).or_default().push(n);
            }
            expanded.push(Value::Table(t));
        }
    }
    table.insert("methods".into(), Value::Array(expanded));
    // Plots naming an expanded method name its variants.
    if let Some(Value::Table(outputs)) = table.get_mut("outputs") {
        if let Some(Value::Array(plots)) = outputs.get_mut("plots") {
            for p in plots.iter_mut() {
                if let Some(Value::Array(ms)) = p.get_mut("methods") {
                    let mut new = Vec::new();
                    for m in ms.iter() {
                        match m.as_str().and_then(|s| variants_of.get(s)) {
                            Some(vs) => new.extend(vs.iter().cloned().map(Value::String)),
                            None => new.push(m.clone()),
                        }
                    }
                    *ms = new;
                }
            }
        }
    }
    let mut out = reparse(table, base).map_err(|e| attribute(e, &path, "sweep"))?;
    add_sweep_plots(&mut out, grids, &variants_of, &dependents);
    out.sweep = Some(serde_json::json!({
        "axes": grids.iter().enumerate().flat_map(|(g, axes)| axes.iter().map(move |a| {
            serde_json::json!({
                "grid": g,
                "key": a.key,
                "values": a.values.iter().map(|v| serde_json::to_value(v).unwrap_or_default()).collect::<Vec<_>>(),
                "names": (0..a.values.len()).map(|j| a.part(j)).collect::<Vec<_>>(),
                "group": a.groups(),
                "from": a.from,
            })
        })).collect::<Vec<_>>(),
        "methods": variants_of,
    }));
    Ok(out)
}

/// A line plot of the error against each swept key that has a `cases.csv`
/// column, per expanded method, unless a plot has that column as `x`.
fn add_sweep_plots(
    l: &mut LoadedConfig,
    grids: &[Vec<Axis>],
    variants_of: &BTreeMap<String, Vec<String>>,
    dependents: &BTreeMap<String, BTreeSet<String>>,
) {
    let mut columns: Vec<(String, String)> = Vec::new();
    for a in grids.iter().flatten() {
        let col = a
            .target
            .rel()
            .rsplit('.')
            .next()
            .unwrap_or_default()
            .to_string();
        if CASE_COLUMNS.contains(&col.as_str()) && !columns.iter().any(|(k, _)| *k == a.key) {
            columns.push((a.key.clone(), col));
        }
    }
    if columns.is_empty() {
        return;
    }
    let existing: BTreeSet<String> = l
        .config
        .outputs
        .plots
        .iter()
        .filter_map(|p| p.x.clone())
        .collect();
    let mut add = Vec::new();
    for (key, col) in &columns {
        if existing.contains(col) {
            continue;
        }
        // The methods whose variants differ in this column.
        let templates: Vec<(&String, &Vec<String>)> = variants_of
            .iter()
            .filter(|(t, _)| dependents.get(key).is_some_and(|d| d.contains(*t)))
            .collect();
        let several = templates.len() > 1;
        for (t, vs) in templates {
            let Some(first) = l.methods.iter().find(|m| vs.contains(&m.name)) else {
                continue;
            };
            let metric = match &first.method {
                Method::Transfer(_) => "err_mean_area",
                Method::Fbt(f) if f.task == FbtTask::Completion => "rel_distortion_mean",
                Method::Fbt(f) if f.task == FbtTask::Scale => "alpha_error",
                Method::Clustering(_) => "ari",
                Method::Fbt(_) => continue,
            };
            add.push(PlotSpec {
                file: several.then(|| format!("line_{col}_{t}")),
                methods: vs.clone(),
                x: Some(col.clone()),
                ..PlotSpec::new(PlotKind::Line, &[metric])
            });
        }
    }
    if add.is_empty() {
        return;
    }
    if l.config.outputs.plots.is_empty() {
        l.config.outputs.plots = super::plots::default_plots(&l.config);
    }
    l.config.outputs.plots.extend(add);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_path_addresses_methods_by_name_and_position() {
        let mut t: Table = toml::from_str(
            "[[methods]]\nname = \"a.b\"\nkind = \"bdt\"\n[[methods]]\nname = \"a\"\n",
        )
        .unwrap();
        set_path(&mut t, "methods.a.b.epsilon", Value::Float(0.5)).unwrap();
        set_path(&mut t, "methods.a.fbt.q", Value::Integer(2)).unwrap();
        set_path(&mut t, "methods[1].seed", Value::Integer(3)).unwrap();
        set_path(&mut t, "defaults.mode", Value::String("exact".into())).unwrap();
        let m = t["methods"].as_array().unwrap();
        assert_eq!(m[0]["epsilon"].as_float(), Some(0.5));
        assert_eq!(m[1]["fbt"]["q"].as_integer(), Some(2));
        assert_eq!(m[1]["seed"].as_integer(), Some(3));
        assert_eq!(t["defaults"]["mode"].as_str(), Some("exact"));
        let e = set_path(&mut t, "methods.c.epsilon", Value::Integer(1)).unwrap_err();
        assert!(e.contains("\"c\"") && e.contains("a.b, a"), "{e}");
        assert!(set_path(&mut t, "methods[7].x", Value::Integer(1)).is_err());
    }

    #[test]
    fn command_line_values_are_toml_or_strings() {
        assert_eq!(parse_value("0.02"), Value::Float(0.02));
        assert_eq!(parse_value("50"), Value::Integer(50));
        assert_eq!(parse_value("fast"), Value::String("fast".into()));
        assert_eq!(parse_value("\"fast\""), Value::String("fast".into()));
        assert_eq!(parse_value("true"), Value::Boolean(true));
    }
}

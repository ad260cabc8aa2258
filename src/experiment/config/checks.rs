//! Checks of a loaded config that need more than one key: names and
//! labels, dataset paths, output formats and plot kinds against the
//! methods and columns.

use std::path::Path;

use super::*;
use crate::{Error, Result};

/// A display name: 1 to 200 characters, no control characters.
fn valid_label(s: &str) -> bool {
    !s.trim().is_empty() && s.chars().count() <= 200 && !s.chars().any(char::is_control)
}

/// A `formats` list: not empty, no format twice.
fn check_formats(c: &LoadedConfig, key: &str, f: &[FileFormat]) -> Result<()> {
    if f.is_empty() {
        return Err(bad(
            &c.path,
            key,
            "expected at least one of \"png\", \"svg\", \"pdf\"",
        ));
    }
    if let Some(d) = f.iter().enumerate().find(|(i, x)| f[..*i].contains(x)) {
        return Err(bad(
            &c.path,
            key,
            format!("{:?} is listed twice", d.1.name()),
        ));
    }
    Ok(())
}

impl LoadedConfig {
    /// A dataset path of the config resolved: `@data/...` against the data
    /// root, other relative paths against the config's folder.
    pub fn resolve_path(&self, p: &Path) -> PathBuf {
        self.data_root.resolve(p, &self.base_dir)
    }

    /// Errors (naming the key and the path) if a dataset path of the
    /// config does not exist.
    pub fn check_paths(&self) -> Result<()> {
        let c = self;
        let d = &c.config.dataset;
        let check = |key: &str, p: &Path, want_dir: bool| -> Result<()> {
            let full = c.resolve_path(p);
            let ok = if want_dir {
                full.is_dir()
            } else {
                full.is_file()
            };
            let what = if want_dir { "folder" } else { "file" };
            let problem = crate::mesh::io::path_problem(&full);
            if ok {
                Ok(())
            } else if let Some(why) = problem.filter(|w| w != "does not exist") {
                // A loop of symbolic links, no permission: the system's reason.
                Err(bad(
                    &c.path,
                    key,
                    format!("expected a {what}, but {} {why}", full.display()),
                ))
            } else if full.exists() {
                // A file for a folder; a FIFO or a device for a file (which
                // would block or never end).
                let found = match crate::mesh::io::check_regular_file(&full) {
                    Ok(_) => "is a file".to_string(),
                    Err(Error::Parse { message, .. }) => message,
                    Err(e) => e.to_string(),
                };
                Err(bad(
                    &c.path,
                    key,
                    format!("expected a {what}, but {} {found}", full.display()),
                ))
            } else if DataRoot::names(p) {
                Err(bad(
                    &c.path,
                    key,
                    format!(
                        "expected an existing {what}, but {} ({}) does not exist: {}",
                        full.display(),
                        p.display(),
                        c.data_root.describe()
                    ),
                ))
            } else {
                Err(bad(
                    &c.path,
                    key,
                    format!(
                        "expected an existing {what} (relative paths are relative to the config \
                         file; `@data/...` to the data root), but {} does not exist",
                        full.display()
                    ),
                ))
            }
        };
        if let Some(f) = &d.faust {
            check("dataset.faust.path", &f.path, true)?;
        }
        if let Some(f) = &d.tosca {
            check("dataset.tosca.path", &f.path, true)?;
        }
        if let Some(f) = &d.manifest {
            check("dataset.manifest.path", &f.path, false)?;
        }
        Ok(())
    }
}

pub(crate) fn check_dataset(c: &LoadedConfig) -> Result<()> {
    let d = &c.config.dataset;
    let n = [
        d.synthetic.is_some(),
        d.faust.is_some(),
        d.tosca.is_some(),
        d.manifest.is_some(),
    ]
    .iter()
    .filter(|x| **x)
    .count();
    if n > 1 {
        return Err(bad(
            &c.path,
            "dataset",
            "expected exactly one of [dataset.synthetic], [dataset.faust], [dataset.tosca], \
             [dataset.manifest]",
        ));
    }
    Ok(())
}

pub(crate) fn check_outputs(c: &LoadedConfig) -> Result<()> {
    if let Some(f) = &c.config.outputs.formats {
        check_formats(c, "outputs.formats", f)?;
    }
    if let Some(TitleSpec::Text(t)) = &c.config.outputs.title {
        if !valid_label(t) {
            return Err(bad(
                &c.path,
                "outputs.title",
                "expected a title of 1 to 200 characters without control characters, or false",
            ));
        }
    }
    for (i, m) in c.config.methods.iter().enumerate() {
        if let Some(l) = &m.label {
            if !valid_label(l) {
                return Err(bad(
                    &c.path,
                    format!("methods[{i}].label"),
                    "expected a display name of 1 to 200 characters without control characters",
                ));
            }
        }
    }
    for (i, p) in c.config.outputs.plots.iter().enumerate() {
        let columns = p.metrics.iter().chain(p.x.iter()).chain(p.by.iter());
        let pivot = p
            .rows
            .iter()
            .chain(p.columns.iter())
            .chain(p.metric.iter())
            .chain(p.lead.iter());
        for m in columns.chain(pivot) {
            if !CASE_COLUMNS.contains(&m.as_str()) {
                return Err(bad(
                    &c.path,
                    format!("outputs.plots[{i}]"),
                    format!(
                        "{m:?} is not a cases.csv column; expected one of {}",
                        CASE_COLUMNS.join(", ")
                    ),
                ));
            }
        }
        for m in &p.methods {
            if !c.methods.iter().any(|x| x.name == *m) {
                return Err(bad(
                    &c.path,
                    format!("outputs.plots[{i}].methods"),
                    format!("{m:?} is not the name of a [[methods]] entry"),
                ));
            }
        }
        if let Some(f) = &p.file {
            if !valid_name(f) {
                return Err(bad(
                    &c.path,
                    format!("outputs.plots[{i}].file"),
                    "expected a plain file stem (letters, digits, - _ .)",
                ));
            }
        }
        check_plot_kind(c, i, p)?;
        if let Some(s) = &p.show {
            if s != "results" && s != "fits" {
                return Err(bad(
                    &c.path,
                    format!("outputs.plots[{i}].show"),
                    format!("expected \"results\" or \"fits\", got {s:?}"),
                ));
            }
        }
    }
    Ok(())
}

/// The keys a plot kind needs, and keys that belong to other kinds.
fn check_plot_kind(c: &LoadedConfig, i: usize, p: &PlotSpec) -> Result<()> {
    let key = |k: &str| format!("outputs.plots[{i}].{k}");
    let pivot = p.kind == PlotKind::Pivot;
    if p.kind == PlotKind::CurvePanels {
        if p.curves.is_empty() {
            return Err(bad(
                &c.path,
                key("curves"),
                "curve panels need `curves`: curves.csv curve names, one panel each",
            ));
        }
        if let Some(k) = p.curves.iter().find(|k| !valid_name(k)) {
            return Err(bad(
                &c.path,
                key("curves"),
                format!("{k:?} is not a curve name"),
            ));
        }
    } else if !p.curves.is_empty() {
        return Err(bad(
            &c.path,
            key("curves"),
            "only `kind = \"curve_panels\"` takes `curves`",
        ));
    }
    for (k, set) in [
        ("rows", p.rows.is_some()),
        ("columns", p.columns.is_some()),
        ("metric", p.metric.is_some()),
    ] {
        if pivot && !set {
            return Err(bad(
                &c.path,
                key(k),
                "pivot tables need `rows`, `columns` and `metric` (cases.csv columns)",
            ));
        }
        if !pivot && set {
            return Err(bad(
                &c.path,
                key(k),
                "only `kind = \"pivot\"` takes this key",
            ));
        }
    }
    let pivot_only = [
        ("scale", p.scale.is_some()),
        ("digits", p.digits.is_some()),
        ("lead", !p.lead.is_empty()),
        ("lead_from", p.lead_from.is_some()),
    ];
    if let Some((k, _)) = pivot_only.iter().find(|(_, set)| *set && !pivot) {
        return Err(bad(
            &c.path,
            key(k),
            "only `kind = \"pivot\"` takes this key",
        ));
    }
    if let Some(s) = p.scale {
        if !(s.is_finite() && s != 0.0) {
            return Err(bad(
                &c.path,
                key("scale"),
                format!("expected a finite non-zero factor, got {s}"),
            ));
        }
    }
    if let Some((k, _)) = p.labels.iter().find(|(_, v)| !valid_label(v)) {
        return Err(bad(
            &c.path,
            key(&format!("labels.{k}")),
            "expected a display name of 1 to 200 characters without control characters",
        ));
    }
    if let Some(f) = &p.formats {
        check_formats(c, &key("formats"), f)?;
    }
    Ok(())
}

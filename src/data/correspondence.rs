//! Correspondence files: vertex pairs between a source and a target mesh.
//!
//! Every parser takes the file's **index base** (0 or 1) and returns 0-based
//! pairs. Defaults per format, verified on the Sumner & Popović 2004 data in
//! `shared/data/sumner` by loading the reference OBJ meshes and comparing the
//! marker positions in normalised bounding boxes:
//!
//! - `markers-*.yml` ([`read_markers_yml`]): **0-based** ([`MARKERS_YML_BASE`]).
//!   For cat→lion (55 markers) the mean normalised-bbox distance between
//!   paired vertices is 0.089 with base 0 against 0.136 with base 1, and the
//!   correlation of pairwise marker distances (cat vs lion) is 0.987 against
//!   0.956; scanning index shifts −3…+3 puts the minimum / maximum exactly at
//!   0. Named markers agree with base 0: "left front paw" lands on the
//!   front-left paw of both (cat (0.06, 0.03, 0.79), lion (0.07, 0.01, 0.83)),
//!   and "neck" on the neck ((0.53, 0.87, 0.86) vs (0.50, 0.96, 0.84); with
//!   base 1 the lion vertex is at (0.33, 0.84, 0.86)). Horse→camel (124
//!   markers): distance 0.139 vs 0.294, correlation 0.973 vs 0.904.
//! - `horse_camel.cons` ([`read_cons`]): **0-based** ([`CONS_BASE`]); its 107
//!   pairs are a subset of the 124 pairs of `markers-horse-camel.yml`, and
//!   the shift scan again peaks at 0 (distance 0.138 vs 0.288 for base 1).
//!   The OBJ files themselves are 1-based for faces, as OBJ always is; the
//!   marker files index the vertex list from 0.
//! - plain CSV pairs ([`read_pairs_csv`]): no convention exists; default 0
//!   ([`CSV_BASE`]).

use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// Verified index base of Sumner `markers-*.yml` files.
pub const MARKERS_YML_BASE: usize = 0;
/// Verified index base of Sumner `.cons` files.
pub const CONS_BASE: usize = 0;
/// Default index base of plain CSV pair files.
pub const CSV_BASE: usize = 0;

/// One vertex correspondence (0-based), with the file's comment if any.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VertexPair {
    pub source: usize,
    pub target: usize,
    pub comment: Option<String>,
}

/// Contents of a Sumner-style `markers-*.yml` file.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MarkerFile {
    pub source_reference: Option<String>,
    pub source_poses: Vec<String>,
    pub target_reference: Option<String>,
    pub target_poses: Vec<String>,
    pub pairs: Vec<VertexPair>,
}

/// Checks that every pair indexes meshes of `n_source` and `n_target`
/// vertices; the error names `path` and the offending pair.
pub fn check_pairs(
    path: &Path,
    pairs: &[VertexPair],
    n_source: usize,
    n_target: usize,
) -> Result<()> {
    for (k, p) in pairs.iter().enumerate() {
        if p.source >= n_source || p.target >= n_target {
            return Err(Error::parse(
                path,
                format!("pair {k}"),
                format!(
                    "pair ({}, {}) out of range for meshes of {n_source} and {n_target} vertices",
                    p.source, p.target
                ),
            ));
        }
    }
    Ok(())
}

/// The pairs as a map source vertex → target vertex, and the source
/// vertices in the order they first appear. A pair given twice is kept
/// once; a source vertex matched to two different targets is a
/// contradiction: an error naming `path`, the pair and both targets (the
/// same rule for marker files and landmarks).
pub fn pair_map(
    path: &Path,
    pairs: &[VertexPair],
) -> Result<(std::collections::BTreeMap<usize, usize>, Vec<usize>)> {
    let mut map = std::collections::BTreeMap::new();
    let mut sources = Vec::new();
    for (k, p) in pairs.iter().enumerate() {
        match map.get(&p.source) {
            Some(&t) if t != p.target => {
                return Err(Error::parse(
                    path,
                    format!("pair {k}"),
                    format!(
                        "source vertex {} is matched to both {t} and {}",
                        p.source, p.target
                    ),
                ));
            }
            Some(_) => {}
            None => {
                map.insert(p.source, p.target);
                sources.push(p.source);
            }
        }
    }
    Ok((map, sources))
}

fn check_base(path: &Path, base: usize) -> Result<()> {
    if base > 1 {
        return Err(Error::invalid(format!(
            "{}: index base must be 0 or 1, got {base}",
            path.display()
        )));
    }
    Ok(())
}

fn read_text(path: &Path) -> Result<String> {
    crate::mesh::io::read_input_text(path)
}

fn parse_index(path: &Path, line: usize, s: &str, base: usize) -> Result<usize> {
    let s = s.trim();
    let v: usize = s.parse().map_err(|_| {
        Error::parse(
            path,
            format!("line {line}"),
            format!("{s:?} is not a vertex index"),
        )
    })?;
    v.checked_sub(base).ok_or_else(|| {
        Error::parse(
            path,
            format!("line {line}"),
            format!("index {v} is below the index base {base}"),
        )
    })
}

/// Plain CSV of vertex pairs: one `source,target` per line (commas,
/// semicolons, tabs or spaces), optional header line (any line whose first
/// field is not a number, only as the first non-empty line), `#` comments and
/// blank lines ignored.
pub fn read_pairs_csv(path: &Path, base: usize) -> Result<Vec<VertexPair>> {
    check_base(path, base)?;
    let text = read_text(path)?;
    let mut out = Vec::new();
    let mut seen_data = false;
    let mut seen_header = false;
    for (ln, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let fields: Vec<&str> = line
            .split([',', ';', '\t', ' '])
            .map(str::trim)
            .filter(|f| !f.is_empty())
            .collect();
        if !seen_data && !seen_header && fields.first().is_some_and(|f| f.parse::<usize>().is_err())
        {
            seen_header = true;
            continue;
        }
        if fields.len() != 2 {
            return Err(Error::parse(
                path,
                format!("line {}", ln + 1),
                format!("expected two vertex indices, found {} fields", fields.len()),
            ));
        }
        seen_data = true;
        out.push(VertexPair {
            source: parse_index(path, ln + 1, fields[0], base)?,
            target: parse_index(path, ln + 1, fields[1], base)?,
            comment: None,
        });
    }
    Ok(out)
}

/// Sumner `.cons` file: first line the pair count, then `source, target`
/// per line. The count must match.
pub fn read_cons(path: &Path, base: usize) -> Result<Vec<VertexPair>> {
    check_base(path, base)?;
    let text = read_text(path)?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, first) = lines
        .next()
        .ok_or_else(|| Error::parse(path, "line 1", "empty file (expected a pair count)"))?;
    let count: usize = first.trim().parse().map_err(|_| {
        Error::parse(
            path,
            "line 1",
            format!("{:?} is not a pair count", first.trim()),
        )
    })?;
    let mut out = Vec::with_capacity(count.min(1 << 20));
    for (ln, line) in lines {
        let (a, b) = line.split_once(',').ok_or_else(|| {
            Error::parse(
                path,
                format!("line {}", ln + 1),
                "expected \"source, target\"",
            )
        })?;
        out.push(VertexPair {
            source: parse_index(path, ln + 1, a, base)?,
            target: parse_index(path, ln + 1, b, base)?,
            comment: None,
        });
    }
    if out.len() != count {
        return Err(Error::parse(
            path,
            "line 1",
            format!("header says {count} pairs, the file has {}", out.len()),
        ));
    }
    Ok(out)
}

/// Sumner-style `markers-*.yml`: sections `source:` and `target:` (each with
/// `reference:` and a `poses:` list) and `markers:`, a list of `"s:t"`
/// strings with optional `# comment`. Only this subset of YAML is read;
/// other top-level keys are ignored.
pub fn read_markers_yml(path: &Path, base: usize) -> Result<MarkerFile> {
    check_base(path, base)?;
    let text = read_text(path)?;
    let mut out = MarkerFile::default();
    #[derive(PartialEq)]
    enum Section {
        None,
        Source,
        Target,
        Markers,
        Other,
    }
    let mut section = Section::None;
    let mut in_poses = false;
    let mut saw_markers = false;
    for (ln, raw) in text.lines().enumerate() {
        let loc = || format!("line {}", ln + 1);
        let (body, comment) = match raw.find('#') {
            Some(i) => (&raw[..i], Some(raw[i + 1..].trim().to_string())),
            None => (raw, None),
        };
        if body.trim().is_empty() {
            continue;
        }
        let indented = body.starts_with(' ') || body.starts_with('\t');
        let t = body.trim();
        if !indented {
            let key = t.strip_suffix(':').unwrap_or(t);
            section = match key {
                "source" => Section::Source,
                "target" => Section::Target,
                "markers" => {
                    saw_markers = true;
                    Section::Markers
                }
                _ => Section::Other,
            };
            in_poses = false;
            continue;
        }
        let unquote = |s: &str| s.trim().trim_matches('"').trim_matches('\'').to_string();
        match section {
            Section::Markers => {
                let item = t.strip_prefix('-').ok_or_else(|| {
                    Error::parse(
                        path,
                        loc(),
                        "expected a list item \"- \\\"source:target\\\"\"",
                    )
                })?;
                let item = unquote(item);
                let (a, b) = item.split_once(':').ok_or_else(|| {
                    Error::parse(
                        path,
                        loc(),
                        format!("marker {item:?} is not \"source:target\""),
                    )
                })?;
                out.pairs.push(VertexPair {
                    source: parse_index(path, ln + 1, a, base)?,
                    target: parse_index(path, ln + 1, b, base)?,
                    comment: comment.filter(|c| !c.is_empty()),
                });
            }
            Section::Source | Section::Target => {
                let (reference, poses) = if section == Section::Source {
                    (&mut out.source_reference, &mut out.source_poses)
                } else {
                    (&mut out.target_reference, &mut out.target_poses)
                };
                if let Some(item) = t.strip_prefix('-') {
                    if in_poses {
                        poses.push(unquote(item));
                    }
                } else if let Some((k, v)) = t.split_once(':') {
                    match k.trim() {
                        "reference" => *reference = Some(unquote(v)),
                        "poses" => in_poses = true,
                        _ => in_poses = false,
                    }
                }
            }
            Section::None => {
                return Err(Error::parse(
                    path,
                    loc(),
                    "indented line before any section",
                ));
            }
            Section::Other => {}
        }
    }
    if !saw_markers {
        return Err(Error::parse(path, "file", "no `markers:` section"));
    }
    Ok(out)
}

/// Correspondence file formats.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize, clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
pub enum PairFormat {
    Csv,
    MarkersYml,
    Cons,
}

impl PairFormat {
    /// Guesses the format from the file name (`.yml`/`.yaml` → markers,
    /// `.cons` → cons, otherwise CSV).
    pub fn from_path(path: &Path) -> Self {
        match path.extension().and_then(|e| e.to_str()) {
            Some("yml" | "yaml") => PairFormat::MarkersYml,
            Some("cons") => PairFormat::Cons,
            _ => PairFormat::Csv,
        }
    }

    /// The verified / default index base of the format.
    pub fn default_base(self) -> usize {
        match self {
            PairFormat::Csv => CSV_BASE,
            PairFormat::MarkersYml => MARKERS_YML_BASE,
            PairFormat::Cons => CONS_BASE,
        }
    }
}

/// Reads a correspondence file of any format (base `None`: the format's
/// default).
pub fn read_pairs(path: &Path, format: PairFormat, base: Option<usize>) -> Result<Vec<VertexPair>> {
    let base = base.unwrap_or(format.default_base());
    match format {
        PairFormat::Csv => read_pairs_csv(path, base),
        PairFormat::Cons => read_cons(path, base),
        PairFormat::MarkersYml => Ok(read_markers_yml(path, base)?.pairs),
    }
}

/// A correspondence file path with its format (used by dataset manifests).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PairFile {
    pub path: PathBuf,
    pub format: PairFormat,
    pub base: usize,
}

impl PairFile {
    /// Reads the pairs.
    pub fn read(&self) -> Result<Vec<VertexPair>> {
        read_pairs(&self.path, self.format, Some(self.base))
    }
}

//! Dataset folder layouts: FAUST-style, TOSCA-style and a generic folder
//! described by a TOML manifest. Folders are scanned eagerly (names, labels,
//! paths); meshes are read lazily with [`read_mesh`] by the entries' `load`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::correspondence::{PairFile, PairFormat, VertexPair};
use super::root::DataRoot;
use crate::mesh::io::{check_regular_file, read_input_text, read_mesh};
use crate::mesh::Mesh;
use crate::{Error, Result};

/// The entries of `dir` (files, folders, anything), sorted by name. A
/// caller that takes an entry as a mesh checks it with
/// [`check_regular_file`], so a folder, a FIFO or a device named like a
/// mesh is an error naming it rather than skipped or read forever.
fn list_dir(dir: &Path) -> Result<Vec<(String, PathBuf)>> {
    let rd = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut out = Vec::new();
    for e in rd {
        let e = e.map_err(|e| Error::io(dir, e))?;
        let path = e.path();
        if let Some(name) = path.file_name().and_then(|n| n.to_str()) {
            out.push((name.to_string(), path));
        }
    }
    out.sort();
    Ok(out)
}

/// One mesh of a FAUST-style folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FaustEntry {
    /// The number in `tr_reg_XXX.ply`.
    pub id: usize,
    /// `id / 10`.
    pub subject: usize,
    /// `id % 10`.
    pub pose: usize,
    pub path: PathBuf,
}

impl FaustEntry {
    /// Reads and validates the mesh.
    pub fn load(&self) -> Result<Mesh> {
        read_mesh(&self.path)
    }
}

/// A FAUST-style folder: `tr_reg_XXX.ply`, id = 10·subject + pose, shared
/// connectivity (checked by whoever loads the meshes, not here). Other
/// files are ignored.
#[derive(Clone, Debug)]
pub struct FaustFolder {
    pub dir: PathBuf,
    /// Sorted by id.
    pub entries: Vec<FaustEntry>,
}

/// The vertex and face counts a PLY header announces (`None` when the
/// header cannot be read: the mesh reader reports that file itself).
fn ply_counts(path: &Path) -> Option<(usize, usize)> {
    use std::io::Read;
    let mut head = vec![0u8; 1 << 14];
    let mut f = std::fs::File::open(path).ok()?;
    let n = f.read(&mut head).ok()?;
    let text = String::from_utf8_lossy(&head[..n]);
    let (mut v, mut fc) = (None, None);
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["element", "vertex", k] => v = k.parse().ok(),
            ["element", "face", k] => fc = k.parse().ok(),
            ["end_header"] => break,
            _ => {}
        }
    }
    Some((v?, fc?))
}

impl FaustFolder {
    /// Checks that the folder holds registrations of one template, as a
    /// FAUST-style folder must: every mesh announces the vertex count most
    /// of them have (read from the PLY headers, so it costs no mesh load).
    /// A mesh of another shape saved under a `tr_reg_XXX.ply` name is named
    /// here, when the folder is opened, instead of failing inside its first
    /// case. Face counts are not compared: a registration with defects (a
    /// duplicate face) is the defect policy's to warn about or repair.
    pub fn check_one_connectivity(&self) -> Result<()> {
        let counts: Vec<(&FaustEntry, (usize, usize))> = self
            .entries
            .iter()
            .filter_map(|e| Some((e, ply_counts(&e.path)?)))
            .collect();
        let mut tally: BTreeMap<usize, usize> = BTreeMap::new();
        for (_, c) in &counts {
            *tally.entry(c.0).or_default() += 1;
        }
        let Some((&common, &n_common)) = tally
            .iter()
            .max_by_key(|(v, n)| (**n, std::cmp::Reverse(**v)))
        else {
            return Ok(());
        };
        let odd: Vec<String> = counts
            .iter()
            .filter(|(_, c)| c.0 != common)
            .map(|(e, (v, f))| {
                format!(
                    "{} ({v} vertices, {f} faces)",
                    e.path.file_name().unwrap_or_default().to_string_lossy()
                )
            })
            .collect();
        if odd.is_empty() {
            return Ok(());
        }
        let first = counts
            .iter()
            .find(|(_, c)| c.0 != common)
            .map(|(e, _)| e.path.clone());
        Err(Error::parse(
            first.unwrap_or_default(),
            "mesh",
            format!(
                "a FAUST-style folder holds registrations of one template, and {} of its {} \
                 meshes have {} vertices, but {}: another shape under a tr_reg_XXX.ply name?",
                n_common,
                counts.len(),
                common,
                odd.join(", ")
            ),
        ))
    }

    /// Scans `dir`. Errors if it cannot be read or holds no `tr_reg_*.ply`.
    pub fn open(dir: &Path) -> Result<Self> {
        let mut entries = Vec::new();
        for (name, path) in list_dir(dir)? {
            let Some(num) = name
                .strip_prefix("tr_reg_")
                .and_then(|s| s.strip_suffix(".ply"))
            else {
                continue;
            };
            if num.is_empty() || !num.bytes().all(|b| b.is_ascii_digit()) {
                continue;
            }
            let id: usize = num.parse().map_err(|_| {
                Error::parse(&path, "file name", format!("id {num:?} is too large"))
            })?;
            check_regular_file(&path)?;
            entries.push(FaustEntry {
                id,
                subject: id / 10,
                pose: id % 10,
                path,
            });
        }
        entries.sort_by_key(|e| e.id);
        if let Some(w) = entries.windows(2).find(|w| w[0].id == w[1].id) {
            return Err(Error::parse(
                &w[1].path,
                "file name",
                format!("id {} also used by {}", w[1].id, w[0].path.display()),
            ));
        }
        if entries.is_empty() {
            return Err(Error::parse(dir, "folder", "no tr_reg_XXX.ply files"));
        }
        Ok(FaustFolder {
            dir: dir.to_path_buf(),
            entries,
        })
    }

    /// The entry of `subject`, `pose`, if present.
    pub fn get(&self, subject: usize, pose: usize) -> Option<&FaustEntry> {
        self.entries
            .iter()
            .find(|e| e.subject == subject && e.pose == pose)
    }

    /// Distinct subjects, sorted.
    pub fn subjects(&self) -> Vec<usize> {
        let mut s: Vec<usize> = self.entries.iter().map(|e| e.subject).collect();
        s.dedup();
        s
    }

    /// Pairs (a, b) of entries with the same pose and different subjects,
    /// a.subject < b.subject, sorted by (pose, a, b): the cross-subject
    /// transfer cases with ground truth.
    pub fn same_pose_pairs(&self) -> Vec<(&FaustEntry, &FaustEntry)> {
        let mut out = Vec::new();
        for a in &self.entries {
            for b in &self.entries {
                if a.pose == b.pose && a.subject < b.subject {
                    out.push((a, b));
                }
            }
        }
        out.sort_by_key(|(a, b)| (a.pose, a.subject, b.subject));
        out
    }
}

/// One mesh of a TOSCA-style folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ToscaEntry {
    pub class: String,
    pub index: usize,
    /// The `.off` / `.ply` file, or the `.vert` file of a `.vert` + `.tri`
    /// pair (which [`read_mesh`] reads together).
    pub path: PathBuf,
}

impl ToscaEntry {
    /// Reads and validates the mesh.
    pub fn load(&self) -> Result<Mesh> {
        read_mesh(&self.path)
    }
}

/// A TOSCA-style folder: `<class><k>.{off,ply}` or `<class><k>.vert` +
/// `<class><k>.tri`; grouped by class, each class sorted by k. Files whose
/// stem is not letters (or `_`) followed by digits are ignored.
#[derive(Clone, Debug)]
pub struct ToscaFolder {
    pub dir: PathBuf,
    pub classes: BTreeMap<String, Vec<ToscaEntry>>,
}

fn split_class(stem: &str) -> Option<(&str, usize)> {
    let digits = stem.len() - stem.bytes().rev().take_while(u8::is_ascii_digit).count();
    let (class, num) = stem.split_at(digits);
    if class.is_empty()
        || num.is_empty()
        || !class.bytes().all(|b| b.is_ascii_alphabetic() || b == b'_')
    {
        return None;
    }
    Some((class, num.parse().ok()?))
}

impl ToscaFolder {
    /// Scans `dir`. Errors on a `.vert` without its `.tri` (or the reverse),
    /// on two files for the same `<class><k>`, and when nothing is found.
    pub fn open(dir: &Path) -> Result<Self> {
        let files = list_dir(dir)?;
        let names: std::collections::HashSet<&str> =
            files.iter().map(|(n, _)| n.as_str()).collect();
        let mut classes: BTreeMap<String, Vec<ToscaEntry>> = BTreeMap::new();
        for (name, path) in &files {
            let Some((stem, ext)) = name.rsplit_once('.') else {
                continue;
            };
            let ext = ext.to_ascii_lowercase();
            if !matches!(ext.as_str(), "off" | "ply" | "vert" | "tri") {
                continue;
            }
            let Some((class, index)) = split_class(stem) else {
                continue;
            };
            check_regular_file(path)?;
            match ext.as_str() {
                "vert" if !names.contains(format!("{stem}.tri").as_str()) => {
                    return Err(Error::parse(
                        path,
                        "file name",
                        format!("{stem}.tri is missing"),
                    ));
                }
                "tri" if !names.contains(format!("{stem}.vert").as_str()) => {
                    return Err(Error::parse(
                        path,
                        "file name",
                        format!("{stem}.vert is missing"),
                    ));
                }
                "tri" => continue,
                _ => {}
            }
            let list = classes.entry(class.to_string()).or_default();
            if let Some(prev) = list.iter().find(|e| e.index == index) {
                return Err(Error::parse(
                    path,
                    "file name",
                    format!("{class}{index} is also stored as {}", prev.path.display()),
                ));
            }
            list.push(ToscaEntry {
                class: class.to_string(),
                index,
                path: path.clone(),
            });
        }
        for list in classes.values_mut() {
            list.sort_by_key(|e| e.index);
        }
        if classes.is_empty() {
            return Err(Error::parse(
                dir,
                "folder",
                "no <class><k>.{off,ply,vert+tri} files",
            ));
        }
        Ok(ToscaFolder {
            dir: dir.to_path_buf(),
            classes,
        })
    }

    /// Entries of one class, sorted by index.
    pub fn class(&self, name: &str) -> Option<&[ToscaEntry]> {
        self.classes.get(name).map(Vec::as_slice)
    }
}

/// A subject or pose label: a number or a name.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(untagged)]
pub enum Label {
    Index(u64),
    Name(String),
}

impl std::fmt::Display for Label {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Label::Index(i) => write!(f, "{i}"),
            Label::Name(s) => f.write_str(s),
        }
    }
}

/// `[[mesh]]` table of a manifest.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshSpec {
    file: String,
    subject: Option<Label>,
    pose: Option<Label>,
    class: Option<String>,
}

/// `[[correspondence]]` table of a manifest.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CorrSpec {
    file: String,
    source: String,
    target: String,
    format: Option<PairFormat>,
    base: Option<usize>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestSpec {
    name: Option<String>,
    #[serde(default)]
    mesh: Vec<MeshSpec>,
    #[serde(default)]
    correspondence: Vec<CorrSpec>,
}

/// One mesh listed in a manifest.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ManifestMesh {
    /// The file name as written in the manifest.
    pub file: String,
    pub path: PathBuf,
    pub subject: Option<Label>,
    pub pose: Option<Label>,
    pub class: Option<String>,
}

impl ManifestMesh {
    /// Reads and validates the mesh.
    pub fn load(&self) -> Result<Mesh> {
        read_mesh(&self.path)
    }
}

/// One correspondence file listed in a manifest; `source` and `target` are
/// indices into [`Manifest::meshes`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ManifestCorrespondence {
    pub file: PairFile,
    pub source: usize,
    pub target: usize,
}

impl ManifestCorrespondence {
    /// Reads the pairs (0-based).
    pub fn read(&self) -> Result<Vec<VertexPair>> {
        self.file.read()
    }
}

/// A generic dataset folder described by `manifest.toml` (or any TOML file):
///
/// ```toml
/// name = "my set"                      # optional
///
/// [[mesh]]
/// file = "a.ply"                       # relative to the manifest (`@data/...`: the data root)
/// subject = 0                          # optional, number or name
/// pose = "walk"                        # optional, number or name
/// class = "cat"                        # optional
///
/// [[correspondence]]
/// file = "a_b.csv"
/// source = "a.ply"                     # a `file` of a [[mesh]]
/// target = "b.ply"
/// format = "csv"                       # optional: csv | markers_yml | cons (default: by extension)
/// base = 0                             # optional: index base (default: the format's)
/// ```
///
/// Unknown keys are errors naming the manifest file, the line and the key.
#[derive(Clone, Debug)]
pub struct Manifest {
    pub path: PathBuf,
    pub name: Option<String>,
    pub meshes: Vec<ManifestMesh>,
    pub correspondences: Vec<ManifestCorrespondence>,
}

impl Manifest {
    /// Reads and checks a manifest: keys, referenced files exist, mesh files
    /// unique, correspondences name listed meshes, bases are 0 or 1. Files
    /// named `@data/...` are found under the data root of the environment
    /// ([`DataRoot::from_env`]).
    pub fn open(path: &Path) -> Result<Self> {
        Self::open_in(path, &DataRoot::from_env(None))
    }

    /// [`Manifest::open`] with the data root `root` for `@data/...` files.
    pub fn open_in(path: &Path, root: &DataRoot) -> Result<Self> {
        let text = read_input_text(path)?;
        let spec: ManifestSpec = toml::from_str(&text).map_err(|e| {
            let location = match e.span() {
                Some(span) => {
                    let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
                    format!("line {line}")
                }
                None => "manifest".to_string(),
            };
            Error::parse(path, location, e.message().to_string())
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut meshes: Vec<ManifestMesh> = Vec::new();
        for (i, m) in spec.mesh.into_iter().enumerate() {
            let p = root.resolve(Path::new(&m.file), dir);
            if let Some(why) = crate::mesh::io::path_problem(&p) {
                let hint = if why == "does not exist" {
                    root.hint(Path::new(&m.file))
                } else {
                    String::new()
                };
                return Err(Error::parse(
                    path,
                    format!("mesh[{i}].file"),
                    format!("{} {why}{hint}", p.display()),
                ));
            }
            check_regular_file(&p)?;
            if meshes.iter().any(|o| o.file == m.file) {
                return Err(Error::parse(
                    path,
                    format!("mesh[{i}].file"),
                    format!("{} is listed twice", m.file),
                ));
            }
            meshes.push(ManifestMesh {
                file: m.file,
                path: p,
                subject: m.subject,
                pose: m.pose,
                class: m.class,
            });
        }
        let mut correspondences = Vec::new();
        for (i, c) in spec.correspondence.into_iter().enumerate() {
            let find = |key: &str, f: &str| {
                meshes.iter().position(|m| m.file == f).ok_or_else(|| {
                    Error::parse(
                        path,
                        format!("correspondence[{i}].{key}"),
                        format!("{f:?} is not the file of any [[mesh]]"),
                    )
                })
            };
            let source = find("source", &c.source)?;
            let target = find("target", &c.target)?;
            let p = root.resolve(Path::new(&c.file), dir);
            if let Some(why) = crate::mesh::io::path_problem(&p) {
                let hint = if why == "does not exist" {
                    root.hint(Path::new(&c.file))
                } else {
                    String::new()
                };
                return Err(Error::parse(
                    path,
                    format!("correspondence[{i}].file"),
                    format!("{} {why}{hint}", p.display()),
                ));
            }
            check_regular_file(&p)?;
            let format = c.format.unwrap_or_else(|| PairFormat::from_path(&p));
            let base = c.base.unwrap_or(format.default_base());
            if base > 1 {
                return Err(Error::parse(
                    path,
                    format!("correspondence[{i}].base"),
                    format!("index base must be 0 or 1, got {base}"),
                ));
            }
            correspondences.push(ManifestCorrespondence {
                file: PairFile {
                    path: p,
                    format,
                    base,
                },
                source,
                target,
            });
        }
        Ok(Manifest {
            path: path.to_path_buf(),
            name: spec.name,
            meshes,
            correspondences,
        })
    }
}

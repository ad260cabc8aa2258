//! The meshes of an experiment, grouped by subject and pose, whatever the
//! source (synthetic set in memory, FAUST-style folder, TOSCA-style folder,
//! manifest). Meshes in files are read on first use and kept.
//!
//! Identifiers are strings: FAUST and synthetic subjects and poses are their
//! numbers (`tr_reg_XXX`: subject `XXX / 10`, pose `XXX % 10`); TOSCA-style
//! subjects are the class names and poses the shape numbers (`cactus12`:
//! subject `cactus`, pose `12`); manifest subjects are the `subject` label
//! (else the `class`, else the file name) and poses the `pose` label (else
//! the file name).
//!
//! **Synthetic convention.** The synthetic set is served exactly like a
//! FAUST folder: subject `s`, pose `p` is `set.meshes[s][p]`, so a case's
//! `A` is the source subject's pose 0 (a relaxed A-pose), as with FAUST
//! registrations. The true unposed T-poses (`set.rest`) are available as
//! the extra pose `rest` (e.g. `reference_pose = "rest"`); "every pose"
//! lists never include it. The true bone of every vertex (`set.labels`) is
//! the dataset's segmentation ([`Collection::labels`]).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use super::config::LoadedConfig;
use crate::data::folders::{FaustFolder, Label, Manifest, ToscaFolder};
use crate::mesh::io::read_mesh;
use crate::mesh::Mesh;
use crate::{Error, Result};

/// The last component of a path (for captions: no local directories).
fn folder_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

/// One mesh of the collection.
#[derive(Debug)]
pub struct PoseEntry {
    pub id: String,
    path: Option<PathBuf>,
    mesh: Mutex<Option<Arc<Mesh>>>,
}

impl PoseEntry {
    fn memory(id: String, mesh: Mesh) -> Self {
        PoseEntry {
            id,
            path: None,
            mesh: Mutex::new(Some(Arc::new(mesh))),
        }
    }

    fn file(id: String, path: PathBuf) -> Self {
        PoseEntry {
            id,
            path: Some(path),
            mesh: Mutex::new(None),
        }
    }

    /// The mesh (read from its file on first use).
    pub fn mesh(&self) -> Result<Arc<Mesh>> {
        let mut slot = self
            .mesh
            .lock()
            .map_err(|_| Error::invalid("mesh cache poisoned by a failed thread"))?;
        if let Some(m) = slot.as_ref() {
            return Ok(m.clone());
        }
        let path = self
            .path
            .as_ref()
            .ok_or_else(|| Error::invalid(format!("pose {} has no mesh", self.id)))?;
        let m = Arc::new(read_mesh(path)?);
        *slot = Some(m.clone());
        Ok(m)
    }

    /// The file the mesh comes from (`None`: generated in memory).
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }
}

/// One subject and its poses (in the dataset's order).
#[derive(Debug)]
pub struct Subject {
    pub id: String,
    pub poses: Vec<PoseEntry>,
    /// Poses reachable by name only (the synthetic `rest`).
    pub extra: Vec<PoseEntry>,
}

impl Subject {
    /// The pose `id` (listed or extra).
    pub fn pose(&self, id: &str) -> Option<&PoseEntry> {
        self.poses.iter().chain(&self.extra).find(|p| p.id == id)
    }

    /// Whether the subject has pose `id`.
    pub fn has(&self, id: &str) -> bool {
        self.pose(id).is_some()
    }
}

/// The meshes of an experiment.
#[derive(Debug)]
pub struct Collection {
    /// `synthetic`, `faust`, `tosca` or `manifest`.
    pub kind: &'static str,
    /// One line for captions (e.g. "synthetic FAUST-style set, 3 subjects × 4 poses, 1 710 vertices").
    pub description: String,
    pub subjects: Vec<Subject>,
    /// True segmentation label of every vertex (synthetic set only).
    pub labels: Option<Vec<usize>>,
}

impl Collection {
    /// Opens the dataset of a config (generates the synthetic set).
    pub fn open(cfg: &LoadedConfig) -> Result<Self> {
        let d = &cfg.config.dataset;
        let base = &cfg.base_dir;
        if let Some(f) = &d.faust {
            return Self::faust(&base.join(&f.path));
        }
        if let Some(t) = &d.tosca {
            return Self::tosca(&base.join(&t.path), t.classes.as_deref());
        }
        if let Some(m) = &d.manifest {
            return Self::manifest(&base.join(&m.path));
        }
        let synth = d.synthetic.clone().unwrap_or_default();
        let spec = synth.faust_style();
        let set = spec.generate()?;
        let n = set.n_vertices();
        let mut subjects: Vec<Subject> = set
            .meshes
            .iter()
            .zip(&set.rest)
            .enumerate()
            .map(|(s, (poses, rest))| Subject {
                id: s.to_string(),
                poses: poses
                    .iter()
                    .enumerate()
                    .map(|(p, m)| PoseEntry::memory(p.to_string(), m.clone()))
                    .collect(),
                extra: vec![PoseEntry::memory("rest".to_string(), rest.clone())],
            })
            .collect();
        // The remeshed subject 0 (issue 8: cross-topology transfer).
        let mut remesh_note = String::new();
        if let Some(keep) = synth.remesh {
            let r = set.remesh(keep)?;
            let mut poses = Vec::new();
            for (p, m) in set.meshes[0].iter().enumerate() {
                poses.push(PoseEntry::memory(p.to_string(), r.transfer(m)?));
            }
            remesh_note = format!(
                " + subject \"remesh\" (subject 0 remeshed, {} vertices)",
                r.mesh.n_vertices()
            );
            subjects.push(Subject {
                id: "remesh".to_string(),
                poses,
                extra: vec![PoseEntry::memory(
                    "rest".to_string(),
                    r.transfer(&set.rest[0])?,
                )],
            });
        }
        Ok(Collection {
            kind: "synthetic",
            description: format!(
                "synthetic FAUST-style set (seed {}), {} subject{} × {} poses, {n} vertices{remesh_note}",
                spec.seed,
                spec.subjects,
                if spec.subjects == 1 { "" } else { "s" },
                spec.poses
            ),
            subjects,
            labels: Some(set.labels.clone()),
        })
    }

    fn faust(dir: &Path) -> Result<Self> {
        let f = FaustFolder::open(dir)?;
        let mut subjects: Vec<Subject> = Vec::new();
        for e in &f.entries {
            let sid = e.subject.to_string();
            if subjects.last().is_none_or(|s| s.id != sid) {
                subjects.push(Subject {
                    id: sid,
                    poses: Vec::new(),
                    extra: Vec::new(),
                });
            }
            if let Some(s) = subjects.last_mut() {
                s.poses
                    .push(PoseEntry::file(e.pose.to_string(), e.path.clone()));
            }
        }
        Ok(Collection {
            kind: "faust",
            description: format!(
                "FAUST-style folder {} ({} meshes, {} subjects)",
                folder_name(dir),
                f.entries.len(),
                subjects.len()
            ),
            subjects,
            labels: None,
        })
    }

    fn tosca(dir: &Path, classes: Option<&[String]>) -> Result<Self> {
        let f = ToscaFolder::open(dir)?;
        let mut subjects = Vec::new();
        if let Some(cs) = classes {
            for c in cs {
                if f.class(c).is_none() {
                    return Err(Error::parse(
                        dir,
                        "dataset.tosca.classes",
                        format!(
                            "class {c:?} not found; classes: {}",
                            f.classes.keys().cloned().collect::<Vec<_>>().join(", ")
                        ),
                    ));
                }
            }
        }
        for (class, entries) in &f.classes {
            if classes.is_some_and(|cs| !cs.contains(class)) {
                continue;
            }
            subjects.push(Subject {
                id: class.clone(),
                poses: entries
                    .iter()
                    .map(|e| PoseEntry::file(e.index.to_string(), e.path.clone()))
                    .collect(),
                extra: Vec::new(),
            });
        }
        let n: usize = subjects.iter().map(|s| s.poses.len()).sum();
        Ok(Collection {
            kind: "tosca",
            description: format!(
                "TOSCA-style folder {} ({} meshes: {})",
                folder_name(dir),
                n,
                subjects
                    .iter()
                    .map(|s| s.id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            subjects,
            labels: None,
        })
    }

    fn manifest(path: &Path) -> Result<Self> {
        let m = Manifest::open(path)?;
        let mut subjects: Vec<Subject> = Vec::new();
        for mesh in &m.meshes {
            let sid = mesh
                .subject
                .as_ref()
                .map(Label::to_string)
                .or_else(|| mesh.class.clone())
                .unwrap_or_else(|| mesh.file.clone());
            let pid = mesh
                .pose
                .as_ref()
                .map(Label::to_string)
                .unwrap_or_else(|| mesh.file.clone());
            let idx = match subjects.iter().position(|s| s.id == sid) {
                Some(i) => i,
                None => {
                    subjects.push(Subject {
                        id: sid.clone(),
                        poses: Vec::new(),
                        extra: Vec::new(),
                    });
                    subjects.len() - 1
                }
            };
            if subjects[idx].has(&pid) {
                return Err(Error::parse(
                    path,
                    format!("mesh {}", mesh.file),
                    format!("subject {sid:?} has pose {pid:?} twice"),
                ));
            }
            subjects[idx]
                .poses
                .push(PoseEntry::file(pid, mesh.path.clone()));
        }
        Ok(Collection {
            kind: "manifest",
            description: format!(
                "manifest {} ({} meshes, {} subjects)",
                folder_name(path),
                m.meshes.len(),
                subjects.len()
            ),
            subjects,
            labels: None,
        })
    }

    /// The subject `id`.
    pub fn subject(&self, id: &str) -> Option<&Subject> {
        self.subjects.iter().find(|s| s.id == id)
    }

    /// The mesh of subject `s` in pose `p`.
    pub fn mesh(&self, s: &str, p: &str) -> Result<Arc<Mesh>> {
        self.subject(s)
            .and_then(|sub| sub.pose(p))
            .ok_or_else(|| Error::invalid(format!("subject {s} has no pose {p}")))?
            .mesh()
    }
}

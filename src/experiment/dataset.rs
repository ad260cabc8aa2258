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
//!
//! **Consistent winding.** Every mesh is served with its subject's
//! consistently wound face list when it has the same vertex triples in
//! another winding (TOSCA `centaur3` reverses 376 faces of the centaur
//! class): the subject's face list is that of its first pose (listed order,
//! then the extra poses) whose winding is consistent (no edge used twice in
//! one direction, [`DefectReport`]), and a mesh whose faces are those
//! triples with some of them reversed gets that face list (same vertices).
//! This happens once, where meshes are served, for every method kind. Each
//! repair is printed as a warning naming the file and the number of flipped
//! faces, and kept in [`Collection::repairs`] (the runner records them in
//! `manifest.json`). Meshes with other triples (another connectivity) and
//! subjects without a consistently wound pose are served unchanged.
//!
//! **Defects that change results.** Every served mesh is then checked under
//! the config's [`DefectPolicy`] (`[dataset] strict`, `repair`): with the
//! repair on, duplicate and zero-area faces are dropped and each component
//! wound consistently ([`FaceRepair`]; planned once per subject on its first
//! pose and shared by every pose with the same face list, so the poses keep
//! one connectivity); each defect kind left is printed as one warning line
//! naming the file (`warning: tr_reg_000.ply: 2 duplicate faces (first: 5
//! 9)`), each repair as `repaired: FILE: …`, and both are kept in
//! [`Collection::checks`] (the runner records them in `manifest.json`). In
//! strict mode a defect left is an error naming the file.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use super::config::LoadedConfig;
use crate::data::folders::{FaustFolder, Label, Manifest, ToscaFolder};
use crate::data::DataRoot;
use crate::mesh::io::read_mesh;
use crate::mesh::repair::{DefectPolicy, FaceRepair};
use crate::mesh::set::{compare_faces, FaceMatch};
use crate::mesh::validate::{Defect, DefectReport};
use crate::mesh::{Face, Mesh};
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
    /// The mesh as generated (in-memory datasets).
    memory: Option<Arc<Mesh>>,
    /// The mesh as served (read, winding repaired, checked), once it was
    /// asked for.
    mesh: Mutex<Option<Arc<Mesh>>>,
    /// The mesh as read, kept between a look at it (the subject's face
    /// list, its repair) and its serving, so that the file is read once.
    read: Mutex<Option<Arc<Mesh>>>,
}

impl PoseEntry {
    fn memory(id: String, mesh: Mesh) -> Self {
        PoseEntry {
            id,
            path: None,
            memory: Some(Arc::new(mesh)),
            mesh: Mutex::new(None),
            read: Mutex::new(None),
        }
    }

    fn file(id: String, path: PathBuf) -> Self {
        PoseEntry {
            id,
            path: Some(path),
            memory: None,
            mesh: Mutex::new(None),
            read: Mutex::new(None),
        }
    }

    /// The mesh as stored (generated, or read from its file), no repair.
    /// `keep`: keep it for the next call (see [`PoseEntry::read`]); else a
    /// kept copy is handed over and forgotten.
    fn raw(&self, keep: bool) -> Result<Arc<Mesh>> {
        if let Some(m) = &self.memory {
            return Ok(m.clone());
        }
        let mut read = self
            .read
            .lock()
            .map_err(|_| Error::invalid("mesh cache poisoned by a failed thread"))?;
        if let Some(m) = read.as_ref() {
            let m = m.clone();
            if !keep {
                *read = None;
            }
            return Ok(m);
        }
        let path = self
            .path
            .as_ref()
            .ok_or_else(|| Error::invalid(format!("pose {} has no mesh", self.id)))?;
        let m = Arc::new(read_mesh(path)?);
        if keep {
            *read = Some(m.clone());
        }
        Ok(m)
    }

    /// The path named in errors: the file, or `subject/pose` in memory.
    fn error_path(&self, subject: &str) -> PathBuf {
        self.path
            .clone()
            .unwrap_or_else(|| PathBuf::from(format!("{subject}/{}", self.id)))
    }

    fn lock(&self) -> Result<std::sync::MutexGuard<'_, Option<Arc<Mesh>>>> {
        self.mesh
            .lock()
            .map_err(|_| Error::invalid("mesh cache poisoned by a failed thread"))
    }

    /// The file the mesh comes from (`None`: generated in memory).
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// The file name, or `subject/pose` for a mesh generated in memory.
    fn label(&self, subject: &str) -> String {
        match &self.path {
            Some(p) => folder_name(p),
            None => format!("{subject}/{}", self.id),
        }
    }
}

/// A mesh served with its subject's consistently wound face list (see the
/// module documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WindingRepair {
    pub subject: String,
    pub pose: String,
    /// File name of the repaired mesh (`subject/pose` in memory).
    pub file: String,
    /// The pose whose face list was adopted, and its file name.
    pub from_pose: String,
    pub from_file: String,
    /// Faces whose winding was reversed against the adopted face list.
    pub flipped: usize,
    pub faces: usize,
}

impl std::fmt::Display for WindingRepair {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} of {} faces wound against subject {}'s consistent face list (from {}); \
             flipped at load",
            self.file, self.flipped, self.faces, self.subject, self.from_file
        )
    }
}

/// The consistently wound face list of a subject.
#[derive(Debug)]
struct SubjectFaces {
    pose: String,
    file: String,
    n_vertices: usize,
    faces: Vec<Face>,
}

/// One subject and its poses (in the dataset's order).
#[derive(Debug)]
pub struct Subject {
    pub id: String,
    pub poses: Vec<PoseEntry>,
    /// Poses reachable by name only (the synthetic `rest`).
    pub extra: Vec<PoseEntry>,
    /// The subject's consistently wound face list (found on first use).
    faces: OnceLock<Option<SubjectFaces>>,
    repairs: Mutex<Vec<WindingRepair>>,
    /// What to do with result-changing defects (the collection's).
    policy: DefectPolicy,
    /// With the repair on: the face list of the subject's first pose (as
    /// wound by the step above) and its repair, shared by every pose with
    /// that face list.
    face_repair: OnceLock<Option<(Vec<Face>, FaceRepair)>>,
    checks: Mutex<Vec<MeshCheck>>,
}

impl Subject {
    fn new(id: String, poses: Vec<PoseEntry>, extra: Vec<PoseEntry>) -> Self {
        Subject {
            id,
            poses,
            extra,
            faces: OnceLock::new(),
            repairs: Mutex::new(Vec::new()),
            policy: DefectPolicy::default(),
            face_repair: OnceLock::new(),
            checks: Mutex::new(Vec::new()),
        }
    }

    /// The pose `id` (listed or extra).
    pub fn pose(&self, id: &str) -> Option<&PoseEntry> {
        self.poses.iter().chain(&self.extra).find(|p| p.id == id)
    }

    /// Whether the subject has pose `id`.
    pub fn has(&self, id: &str) -> bool {
        self.pose(id).is_some()
    }

    /// The first consistently wound pose's face list. Poses that fail to
    /// load are skipped here (they fail when asked for); a consistent pose
    /// is kept as served (its faces are the subject's).
    fn consistent_faces(&self) -> Option<&SubjectFaces> {
        self.faces
            .get_or_init(|| {
                for e in self.poses.iter().chain(&self.extra) {
                    let Ok(m) = e.raw(true) else { continue };
                    if DefectReport::of_mesh(&m).inconsistent_edges.is_empty() {
                        return Some(SubjectFaces {
                            pose: e.id.clone(),
                            file: e.label(&self.id),
                            n_vertices: m.n_vertices(),
                            faces: m.faces().to_vec(),
                        });
                    }
                }
                None
            })
            .as_ref()
    }

    /// Pose `e` read (kept for its serving when `keep`) and wound with the
    /// subject's consistent face list when it differs from it only by the
    /// winding of some faces (the repair, if any, is returned, not logged).
    fn wound(&self, e: &PoseEntry, keep: bool) -> Result<(Arc<Mesh>, Option<WindingRepair>)> {
        let m = e.raw(keep)?;
        let Some(f) = self.consistent_faces() else {
            return Ok((m, None));
        };
        let Some(flipped) = reversed_faces(&m, f) else {
            return Ok((m, None));
        };
        let r = WindingRepair {
            subject: self.id.clone(),
            pose: e.id.clone(),
            file: e.label(&self.id),
            from_pose: f.pose.clone(),
            from_file: f.file.clone(),
            flipped,
            faces: f.faces.len(),
        };
        Ok((Arc::new(m.with_faces(f.faces.clone())?), Some(r)))
    }

    /// With the repair on, the subject's shared face repair: planned on its
    /// first pose that loads (listed order, then the extra poses).
    fn face_repair(&self) -> Option<(&[Face], &FaceRepair)> {
        if !self.policy.repair {
            return None;
        }
        self.face_repair
            .get_or_init(|| {
                for e in self.poses.iter().chain(&self.extra) {
                    if let Ok((m, _)) = self.wound(e, true) {
                        return Some((m.faces().to_vec(), FaceRepair::plan(&m)));
                    }
                }
                None
            })
            .as_ref()
            .map(|(f, r)| (f.as_slice(), r))
    }

    /// The mesh of pose `p`: with the subject's consistent face list when it
    /// differs from it only by the winding of some faces, then repaired and
    /// checked under the collection's [`DefectPolicy`] (warnings printed and
    /// logged; a defect in strict mode is an error naming the file).
    pub fn mesh(&self, p: &str) -> Result<Arc<Mesh>> {
        let e = self
            .pose(p)
            .ok_or_else(|| Error::invalid(format!("subject {} has no pose {p}", self.id)))?;
        if let Some(m) = e.lock()?.as_ref() {
            return Ok(m.clone());
        }
        // Found before locking the entry: finding them reads poses.
        self.consistent_faces();
        let shared = self.face_repair();
        let mut slot = e.lock()?;
        if let Some(m) = slot.as_ref() {
            return Ok(m.clone());
        }
        let (m, winding) = self.wound(e, false)?;
        let file = e.label(&self.id);
        let checked =
            self.policy
                .apply(Arc::unwrap_or_clone(m), &e.error_path(&self.id), shared)?;
        if let Some(r) = winding {
            eprintln!("warning: {r}");
            self.repairs
                .lock()
                .map_err(|_| Error::invalid("repair log poisoned by a failed thread"))?
                .push(r);
        }
        if let Some(r) = &checked.repair {
            eprintln!("repaired: {file}: {r}");
        }
        for d in &checked.defects {
            eprintln!("warning: {file}: {d}");
        }
        if checked.repair.is_some() || !checked.defects.is_empty() {
            self.checks
                .lock()
                .map_err(|_| Error::invalid("defect log poisoned by a failed thread"))?
                .push(MeshCheck {
                    subject: self.id.clone(),
                    pose: e.id.clone(),
                    file,
                    repair: checked.repair.as_ref().map(|r| r.to_string()),
                    defects: checked.defects.clone(),
                });
        }
        let m = Arc::new(checked.mesh);
        *slot = Some(m.clone());
        Ok(m)
    }
}

/// The result-changing defects left in a served mesh and the repair made
/// (see [`DefectPolicy`]); only meshes with one or the other are logged.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshCheck {
    pub subject: String,
    pub pose: String,
    /// File name (`subject/pose` in memory).
    pub file: String,
    /// What the repair did (`None`: repair off or nothing to repair).
    pub repair: Option<String>,
    pub defects: Vec<Defect>,
}

/// The number of faces of `m` that are faces of `f` in the opposite winding,
/// when `m` has `f`'s vertex triples face by face and at least one is
/// reversed; `None` otherwise (nothing to repair, or another connectivity).
fn reversed_faces(m: &Mesh, f: &SubjectFaces) -> Option<usize> {
    if m.faces() == f.faces.as_slice()
        || m.n_vertices() != f.n_vertices
        || m.n_faces() != f.faces.len()
    {
        return None;
    }
    let mut flipped = 0;
    for (&a, &b) in m.faces().iter().zip(&f.faces) {
        match compare_faces(a, b) {
            FaceMatch::Same => {}
            FaceMatch::Reversed => flipped += 1,
            FaceMatch::Different => return None,
        }
    }
    (flipped > 0).then_some(flipped)
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
    /// Opens the dataset of a config (generates the synthetic set), with
    /// the config's [`DefectPolicy`] (`[dataset] strict`, `repair`).
    pub fn open(cfg: &LoadedConfig) -> Result<Self> {
        Ok(Self::open_unchecked(cfg)?.with_policy(cfg.config.dataset.policy()))
    }

    /// Sets the policy applied to every mesh served from now on.
    pub fn with_policy(mut self, policy: DefectPolicy) -> Self {
        for s in &mut self.subjects {
            s.policy = policy;
        }
        self
    }

    fn open_unchecked(cfg: &LoadedConfig) -> Result<Self> {
        let d = &cfg.config.dataset;
        if let Some(f) = &d.faust {
            return Self::faust(&cfg.resolve_path(&f.path));
        }
        if let Some(t) = &d.tosca {
            return Self::tosca(&cfg.resolve_path(&t.path), t.classes.as_deref());
        }
        if let Some(m) = &d.manifest {
            return Self::manifest(&cfg.resolve_path(&m.path), &cfg.data_root);
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
            .map(|(s, (poses, rest))| {
                Subject::new(
                    s.to_string(),
                    poses
                        .iter()
                        .enumerate()
                        .map(|(p, m)| PoseEntry::memory(p.to_string(), m.clone()))
                        .collect(),
                    vec![PoseEntry::memory("rest".to_string(), rest.clone())],
                )
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
            subjects.push(Subject::new(
                "remesh".to_string(),
                poses,
                vec![PoseEntry::memory(
                    "rest".to_string(),
                    r.transfer(&set.rest[0])?,
                )],
            ));
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
        f.check_one_connectivity()?;
        let mut subjects: Vec<Subject> = Vec::new();
        for e in &f.entries {
            let sid = e.subject.to_string();
            if subjects.last().is_none_or(|s| s.id != sid) {
                subjects.push(Subject::new(sid, Vec::new(), Vec::new()));
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
            subjects.push(Subject::new(
                class.clone(),
                entries
                    .iter()
                    .map(|e| PoseEntry::file(e.index.to_string(), e.path.clone()))
                    .collect(),
                Vec::new(),
            ));
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

    fn manifest(path: &Path, root: &DataRoot) -> Result<Self> {
        let m = Manifest::open_in(path, root)?;
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
                    subjects.push(Subject::new(sid.clone(), Vec::new(), Vec::new()));
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

    /// Every file the dataset serves, as `(subject/pose, path)` in the
    /// dataset's order (none for a dataset generated in memory): the input
    /// files the result store fingerprints ([`super::fingerprint`]).
    pub fn input_files(&self) -> Vec<(String, PathBuf)> {
        self.subjects
            .iter()
            .flat_map(|s| {
                s.poses
                    .iter()
                    .chain(&s.extra)
                    .filter_map(move |e| Some((format!("{}/{}", s.id, e.id), e.path.clone()?)))
            })
            .collect()
    }

    /// The subject `id`.
    pub fn subject(&self, id: &str) -> Option<&Subject> {
        self.subjects.iter().find(|s| s.id == id)
    }

    /// The mesh of subject `s` in pose `p`, winding repaired (see the
    /// module documentation).
    pub fn mesh(&self, s: &str, p: &str) -> Result<Arc<Mesh>> {
        self.subject(s)
            .ok_or_else(|| Error::invalid(format!("subject {s} has no pose {p}")))?
            .mesh(p)
    }

    /// The file name of subject `s` in pose `p` (`s/p` for a mesh generated
    /// in memory), for messages.
    pub fn file_label(&self, s: &str, p: &str) -> String {
        self.subject(s)
            .and_then(|x| x.pose(p).map(|e| e.label(s)))
            .unwrap_or_else(|| format!("{s}/{p}"))
    }

    /// The meshes served so far with a result-changing defect or a repair
    /// ([`MeshCheck`]), subject by subject, in pose order.
    pub fn checks(&self) -> Vec<MeshCheck> {
        let mut out = Vec::new();
        for s in &self.subjects {
            let mut r = s.checks.lock().map(|r| r.clone()).unwrap_or_default();
            let order = |p: &str| s.poses.iter().chain(&s.extra).position(|e| e.id == p);
            r.sort_by_key(|x| order(&x.pose));
            out.extend(r);
        }
        out
    }

    /// The winding repairs made so far, subject by subject, in pose order.
    pub fn repairs(&self) -> Vec<WindingRepair> {
        let mut out = Vec::new();
        for s in &self.subjects {
            let mut r = s.repairs.lock().map(|r| r.clone()).unwrap_or_default();
            let order = |p: &str| s.poses.iter().chain(&s.extra).position(|e| e.id == p);
            r.sort_by_key(|x| order(&x.pose));
            out.extend(r);
        }
        out
    }
}

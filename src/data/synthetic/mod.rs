//! Synthetic FAUST-style and TOSCA-style data with exact ground truth.
//!
//! **Creature.** A box-modelled quad cage (torso lattice; neck + head with a
//! snout; two arms with elbows and flat hands; two legs with knees and
//! forward-pointing feet; optional two-bone tail) smoothed by Catmull–Clark
//! subdivision (2 levels by default: 6 722 vertices with the tail, 6 146
//! without) and split into triangles along the shorter diagonal of each
//! quad on the mean subject. The cage connectivity never depends on the
//! proportions, so **every subject and pose shares one connectivity** and
//! vertex `i` corresponds to vertex `i` on every mesh. The mesh is closed,
//! genus 0, consistently wound (outward normals).
//!
//! **Subjects** differ in torso width/height, arm and leg length (and the
//! forearm/shin ratio), girth, head size and tail length, each factor drawn
//! uniformly in ±`spread` from the seed ([`body::Proportions::random`]).
//!
//! **Poses** come from one fixed table of joint angles ([`pose::pose_table`])
//! shared by all subjects, posed by dual-quaternion skinning with smooth
//! subdivided weights plus a nonlinear, angle-dependent muscle bulge (see
//! [`pose`]). The true bone of every vertex (largest weight) is in
//! [`SyntheticSet::labels`].
//!
//! Writers: [`write_faust_style`], [`write_tosca_style`], [`write_remeshed`],
//! or [`write_all`] for the standard layout.

pub mod body;
pub mod pose;
pub mod remesh;
pub mod subdiv;

use std::path::Path;

use serde::Serialize;

use crate::mesh::io::{write_atomic, write_ply};
use crate::mesh::{Face, Mesh};
use crate::{Error, Point, Result, Vec3};
use body::{Proportions, Skeleton, Weights, BONE_NAMES, BONE_PARENT, N_BONES};
pub use remesh::{Remeshed, SurfacePoint};

/// Most subjects of a set ([`FaustStyle::subjects`]).
pub const MAX_SUBJECTS: usize = 99;
/// Most Catmull–Clark levels ([`FaustStyle::resolution`]).
pub const MAX_RESOLUTION: u32 = 5;
/// Largest relative spread of the proportion factors ([`FaustStyle::spread`]).
pub const MAX_SPREAD: f64 = 0.4;

/// Configuration of a synthetic FAUST-style set.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FaustStyle {
    /// Number of subjects (1..=[`MAX_SUBJECTS`]).
    pub subjects: usize,
    /// Poses per subject (1..=[`pose::N_POSES`]): the first `poses` rows of the pose table.
    pub poses: usize,
    /// Seed of every random choice (subject proportions, remesh).
    pub seed: u64,
    /// Catmull–Clark levels (1..=[`MAX_RESOLUTION`]): each level has about 4× the vertices of
    /// the one before (1: ~1.7k, 2: ~6.7k, 3: ~27k, 4: ~108k, 5: ~430k).
    /// 4 and 5 are for the large-mesh runs (`experiments/large/`).
    pub resolution: u32,
    /// Whether the creature has a tail (two extra bones).
    pub tail: bool,
    /// Relative spread of the subject proportion factors (0..=[`MAX_SPREAD`]).
    pub spread: f64,
}

impl Default for FaustStyle {
    fn default() -> Self {
        FaustStyle {
            subjects: 6,
            poses: 8,
            seed: 0,
            resolution: 2,
            tail: true,
            spread: 0.15,
        }
    }
}

/// Rest-pose data of one subject needed to pose it.
#[derive(Clone, Debug)]
struct Rig {
    skeleton: Skeleton,
    rest: Vec<Point>,
    normals: Vec<Vec3>,
}

/// A generated set: `meshes[s][p]` is subject `s` in pose `p`; all meshes
/// share [`SyntheticSet::faces`].
#[derive(Clone, Debug)]
pub struct SyntheticSet {
    pub config: FaustStyle,
    pub proportions: Vec<Proportions>,
    /// Unposed (T-pose) mesh of every subject.
    pub rest: Vec<Mesh>,
    pub meshes: Vec<Vec<Mesh>>,
    /// Bone index (into [`SyntheticSet::bone_names`]) of every vertex.
    pub labels: Vec<usize>,
    /// Smooth skinning weights of every vertex (as used for posing).
    pub weights: Vec<Weights>,
    /// Names of the bones in use (13 with a tail, 11 without).
    pub bone_names: Vec<&'static str>,
    rigs: Vec<Rig>,
}

impl FaustStyle {
    fn check(&self) -> Result<()> {
        if !(1..=MAX_SUBJECTS).contains(&self.subjects) {
            return Err(Error::invalid(format!(
                "subjects = {} not in 1..={MAX_SUBJECTS}",
                self.subjects
            )));
        }
        if !(1..=pose::N_POSES).contains(&self.poses) {
            return Err(Error::invalid(format!(
                "poses = {} not in 1..={}",
                self.poses,
                pose::N_POSES
            )));
        }
        if !(1..=MAX_RESOLUTION).contains(&self.resolution) {
            return Err(Error::invalid(format!(
                "resolution = {} not in 1..={MAX_RESOLUTION}",
                self.resolution
            )));
        }
        if !(0.0..=MAX_SPREAD).contains(&self.spread) {
            return Err(Error::invalid(format!(
                "spread = {} not in [0, {MAX_SPREAD}]",
                self.spread
            )));
        }
        Ok(())
    }

    /// Generates the set in memory.
    pub fn generate(&self) -> Result<SyntheticSet> {
        self.check()?;
        let (_, mean_cage) = body::build(&Proportions::mean(), self.tail);
        let (stencil, quads) =
            subdiv::subdivide(mean_cage.vertices.len(), &mean_cage.quads, self.resolution);
        let weights: Vec<Weights> = stencil
            .apply(
                &mean_cage
                    .weights
                    .iter()
                    .map(|&w| subdiv::WeightVec(w))
                    .collect::<Vec<_>>(),
            )
            .into_iter()
            .map(|w| w.0)
            .collect();
        crate::solve::progress::update("synthetic set: smoothing skinning weights", 0, 0);
        let weights = smooth_weights(&quads, weights, WEIGHT_SMOOTHING << (self.resolution - 1));
        let labels: Vec<usize> = weights
            .iter()
            .map(|w| {
                (0..N_BONES)
                    .max_by(|&i, &j| w[i].total_cmp(&w[j]))
                    .unwrap_or(0)
            })
            .collect();
        // Triangulate along the shorter diagonal of the mean subject.
        let mean_fine = stencil.apply(&mean_cage.vertices);
        let faces: Vec<Face> = quads
            .iter()
            .flat_map(|&[a, b, c, d]| {
                let ac = (mean_fine[a] - mean_fine[c]).norm_squared();
                let bd = (mean_fine[b] - mean_fine[d]).norm_squared();
                if ac <= bd {
                    [[a, b, c], [a, c, d]]
                } else {
                    [[a, b, d], [b, c, d]]
                }
            })
            .collect();
        let table = pose::pose_table();
        let mut set = SyntheticSet {
            config: self.clone(),
            proportions: Vec::new(),
            rest: Vec::new(),
            meshes: Vec::new(),
            labels,
            weights,
            bone_names: BONE_NAMES[..if self.tail { N_BONES } else { N_BONES - 2 }].to_vec(),
            rigs: Vec::new(),
        };
        for s in 0..self.subjects {
            crate::solve::progress::update("synthetic set: posing subject", s, self.subjects);
            let prop = Proportions::random(self.seed, s, self.spread);
            let (skeleton, cage) = body::build(&prop, self.tail);
            let rest: Vec<Point> = stencil
                .apply(&cage.vertices)
                .into_iter()
                .map(Point::from)
                .collect();
            let rest_mesh = Mesh::new(rest.clone(), faces.clone())?;
            let normals = vertex_normals(&rest_mesh);
            let rig = Rig {
                skeleton,
                rest,
                normals,
            };
            let posed = table[..self.poses]
                .iter()
                .map(|p| rest_mesh.with_vertices(set.pose_rig(&rig, p)))
                .collect::<Result<Vec<_>>>()?;
            set.proportions.push(prop);
            set.rest.push(rest_mesh);
            set.meshes.push(posed);
            set.rigs.push(rig);
        }
        Ok(set)
    }
}

/// Uniform smoothing rounds of the subdivided weights at resolution 1
/// (doubled per extra level, so the blend width in metres stays the same).
const WEIGHT_SMOOTHING: usize = 8;

/// `rounds` Jacobi rounds of `w ← ½ w + ½ mean(neighbours)` on the quad
/// mesh's edge graph: widens every joint's blend region. Partition of unity
/// is kept.
fn smooth_weights(quads: &[[usize; 4]], mut w: Vec<Weights>, rounds: usize) -> Vec<Weights> {
    let mut nb: Vec<Vec<usize>> = vec![Vec::new(); w.len()];
    for q in quads {
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            if !nb[a].contains(&b) {
                nb[a].push(b);
                nb[b].push(a);
            }
        }
    }
    for _ in 0..rounds {
        w = (0..w.len())
            .map(|i| {
                let mut acc = [0.0; N_BONES];
                for &j in &nb[i] {
                    for (a, x) in acc.iter_mut().zip(&w[j]) {
                        *a += x;
                    }
                }
                let k = nb[i].len().max(1) as f64;
                let mut out = w[i];
                for (o, a) in out.iter_mut().zip(acc) {
                    *o = 0.5 * *o + 0.5 * a / k;
                }
                out
            })
            .collect();
    }
    w
}

/// Area-weighted vertex normals (unit; zero for isolated vertices).
fn vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    let v = mesh.vertices();
    let mut n = vec![Vec3::zeros(); v.len()];
    for f in mesh.faces() {
        let fn_ = (v[f[1]] - v[f[0]]).cross(&(v[f[2]] - v[f[0]]));
        for &i in f {
            n[i] += fn_;
        }
    }
    n.iter()
        .map(|x| x.try_normalize(1e-300).unwrap_or_else(Vec3::zeros))
        .collect()
}

impl SyntheticSet {
    fn pose_rig(&self, rig: &Rig, p: &pose::Pose) -> Vec<Point> {
        pose::pose_vertices(&rig.skeleton, &rig.rest, &rig.normals, &self.weights, p)
    }

    /// The shared faces.
    pub fn faces(&self) -> &[Face] {
        self.rest[0].faces()
    }

    /// Number of vertices of every mesh.
    pub fn n_vertices(&self) -> usize {
        self.rest[0].n_vertices()
    }

    /// FAUST-style id of subject `s`, pose `p`: `10·s + p`.
    pub fn id(subject: usize, pose: usize) -> usize {
        10 * subject + pose
    }

    /// Subject `subject` in row `pose` of the full pose table (any of the
    /// [`pose::N_POSES`] poses, not only the first `config.poses`).
    pub fn posed(&self, subject: usize, pose: usize) -> Result<Mesh> {
        let rig = self.rigs.get(subject).ok_or_else(|| {
            Error::invalid(format!(
                "subject {subject} not in the set ({} subjects)",
                self.rigs.len()
            ))
        })?;
        let table = pose::pose_table();
        let p = table.get(pose).ok_or_else(|| {
            Error::invalid(format!(
                "pose {pose} not in the table ({} poses)",
                pose::N_POSES
            ))
        })?;
        self.rest[subject].with_vertices(self.pose_rig(rig, p))
    }

    /// A remesh of subject 0's rest mesh with about `keep · n` vertices and
    /// its barycentric map onto the shared connectivity (pose-independent:
    /// apply it to any pose of subject 0 with [`Remeshed::transfer`]).
    pub fn remesh(&self, keep: f64) -> Result<Remeshed> {
        remesh::remesh(&self.rest[0], keep, self.config.seed ^ 0x05EE_D0F4_E3E5)
    }
}

#[derive(Serialize)]
struct BoneMeta {
    index: usize,
    name: &'static str,
    parent: Option<usize>,
}

#[derive(Serialize)]
struct FileMeta {
    file: String,
    id: usize,
    subject: usize,
    pose: usize,
    pose_name: &'static str,
}

#[derive(Serialize)]
struct Metadata<'a> {
    generator: &'static str,
    config: &'a FaustStyle,
    n_vertices: usize,
    n_faces: usize,
    bones: Vec<BoneMeta>,
    labels_file: &'static str,
    rest_files: Vec<String>,
    files: Vec<FileMeta>,
    proportions: &'a [Proportions],
}

fn ensure_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

fn labels_csv(set: &SyntheticSet) -> String {
    let mut s = String::from("vertex,bone,bone_name\n");
    for (i, &b) in set.labels.iter().enumerate() {
        s.push_str(&format!("{i},{b},{}\n", BONE_NAMES[b]));
    }
    s
}

/// Writes the FAUST-style folder: `tr_reg_XXX.ply` (id = 10·subject + pose),
/// `rest/subject_SS.ply` (unposed meshes), `labels.csv` (vertex, bone,
/// bone_name) and `synthetic.json` (config, bones, files, proportions).
/// Byte-identical for equal sets.
pub fn write_faust_style(dir: &Path, set: &SyntheticSet) -> Result<()> {
    ensure_dir(dir)?;
    ensure_dir(&dir.join("rest"))?;
    let mut files = Vec::new();
    for (s, poses) in set.meshes.iter().enumerate() {
        for (p, mesh) in poses.iter().enumerate() {
            let id = SyntheticSet::id(s, p);
            crate::solve::progress::update(
                "synthetic set: writing FAUST-style meshes",
                id,
                set.meshes.len() * poses.len(),
            );
            let file = format!("tr_reg_{id:03}.ply");
            write_ply(&dir.join(&file), mesh)?;
            files.push(FileMeta {
                file,
                id,
                subject: s,
                pose: p,
                pose_name: pose::POSE_NAMES[p],
            });
        }
    }
    let mut rest_files = Vec::new();
    for (s, mesh) in set.rest.iter().enumerate() {
        let file = format!("rest/subject_{s:02}.ply");
        write_ply(&dir.join(&file), mesh)?;
        rest_files.push(file);
    }
    write_atomic(&dir.join("labels.csv"), labels_csv(set).as_bytes())?;
    let meta = Metadata {
        generator: "deformlab synthetic FAUST-style creature v1",
        config: &set.config,
        n_vertices: set.n_vertices(),
        n_faces: set.faces().len(),
        bones: set
            .bone_names
            .iter()
            .enumerate()
            .map(|(index, &name)| BoneMeta {
                index,
                name,
                parent: (BONE_PARENT[index] != usize::MAX).then_some(BONE_PARENT[index]),
            })
            .collect(),
        labels_file: "labels.csv",
        rest_files,
        files,
        proportions: &set.proportions,
    };
    let json = serde_json::to_string_pretty(&meta)
        .map_err(|e| Error::invalid(format!("metadata serialisation failed: {e}")))?;
    write_atomic(&dir.join("synthetic.json"), json.as_bytes())
}

/// Writes a TOSCA-style class folder for subject `subject`: `<class>0` is
/// the rest (T-)pose and `<class>k` (k = 1..=10) pose k-1 of the full table.
/// Files are OFF, except every file with `k % 5 == 4` which is binary PLY
/// (so loaders meet both formats). Also writes `labels.csv`.
pub fn write_tosca_style(
    dir: &Path,
    set: &SyntheticSet,
    class: &str,
    subject: usize,
) -> Result<Vec<String>> {
    if class.is_empty() || class.chars().any(|c| !c.is_ascii_alphabetic()) {
        return Err(Error::invalid(format!(
            "TOSCA class name {class:?} must be non-empty ASCII letters"
        )));
    }
    ensure_dir(dir)?;
    let mut names = Vec::new();
    for k in 0..=pose::N_POSES {
        let mesh = if k == 0 {
            set.rest
                .get(subject)
                .cloned()
                .ok_or_else(|| Error::invalid(format!("subject {subject} not in the set")))?
        } else {
            set.posed(subject, k - 1)?
        };
        let name = if k % 5 == 4 {
            let n = format!("{class}{k}.ply");
            write_ply(&dir.join(&n), &mesh)?;
            n
        } else {
            let n = format!("{class}{k}.off");
            crate::mesh::io::write_off(&dir.join(&n), &mesh)?;
            n
        };
        names.push(name);
    }
    write_atomic(&dir.join("labels.csv"), labels_csv(set).as_bytes())?;
    Ok(names)
}

/// Writes the remesh of subject 0: `remesh_rest.ply`, `remesh_XXX.ply` for
/// every pose of subject 0 (XXX = the FAUST id), and `map.csv` with header
/// `vertex,face,b0,b1,b2`: remesh vertex `vertex` is
/// `b0·v[f0] + b1·v[f1] + b2·v[f2]` for face `face` of the shared
/// connectivity (valid in every pose of subject 0).
pub fn write_remeshed(dir: &Path, set: &SyntheticSet, remeshed: &Remeshed) -> Result<()> {
    ensure_dir(dir)?;
    write_ply(&dir.join("remesh_rest.ply"), &remeshed.mesh)?;
    for (p, mesh) in set.meshes[0].iter().enumerate() {
        let posed = remeshed.transfer(mesh)?;
        write_ply(
            &dir.join(format!("remesh_{:03}.ply", SyntheticSet::id(0, p))),
            &posed,
        )?;
    }
    let mut s = String::from("vertex,face,b0,b1,b2\n");
    for (i, sp) in remeshed.map.iter().enumerate() {
        s.push_str(&format!(
            "{i},{},{:?},{:?},{:?}\n",
            sp.face, sp.bary[0], sp.bary[1], sp.bary[2]
        ));
    }
    write_atomic(&dir.join("map.csv"), s.as_bytes())
}

/// Reads a `map.csv` written by [`write_remeshed`] (header required).
pub fn read_remesh_map(path: &Path) -> Result<Vec<SurfacePoint>> {
    let text = crate::mesh::io::read_input_text(path)?;
    let mut out = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        if ln == 0 {
            if line.trim() != "vertex,face,b0,b1,b2" {
                return Err(Error::parse(
                    path,
                    "line 1",
                    "expected header vertex,face,b0,b1,b2",
                ));
            }
            continue;
        }
        if line.trim().is_empty() {
            continue;
        }
        let bad = |m: &str| Error::parse(path, format!("line {}", ln + 1), m.to_string());
        let cols: Vec<&str> = line.split(',').map(str::trim).collect();
        if cols.len() != 5 {
            return Err(bad("expected 5 columns"));
        }
        let v: usize = cols[0]
            .parse()
            .map_err(|_| bad("vertex is not an integer"))?;
        if v != out.len() {
            return Err(bad("vertices must be listed in order 0, 1, 2, …"));
        }
        let face: usize = cols[1].parse().map_err(|_| bad("face is not an integer"))?;
        let mut bary = [0.0; 3];
        for k in 0..3 {
            bary[k] = cols[2 + k]
                .parse()
                .map_err(|_| bad("barycentric coordinate is not a number"))?;
        }
        out.push(SurfacePoint { face, bary });
    }
    Ok(out)
}

/// What [`write_all`] wrote.
#[derive(Clone, Debug)]
pub struct GenSummary {
    pub n_vertices: usize,
    pub n_faces: usize,
    pub n_meshes: usize,
    pub remesh_vertices: usize,
    pub remesh_faces: usize,
}

/// The standard layout under `dir`: `faust/` ([`write_faust_style`]),
/// `tosca/` (class `creature`, subject 0, [`write_tosca_style`]) and
/// `remesh/` (subject 0 remeshed to ~0.8 n vertices, [`write_remeshed`]).
pub fn write_all(dir: &Path, config: &FaustStyle) -> Result<GenSummary> {
    let set = config.generate()?;
    write_faust_style(&dir.join("faust"), &set)?;
    write_tosca_style(&dir.join("tosca"), &set, "creature", 0)?;
    let rm = set.remesh(0.8)?;
    write_remeshed(&dir.join("remesh"), &set, &rm)?;
    Ok(GenSummary {
        n_vertices: set.n_vertices(),
        n_faces: set.faces().len(),
        n_meshes: config.subjects * config.poses,
        remesh_vertices: rm.mesh.n_vertices(),
        remesh_faces: rm.mesh.n_faces(),
    })
}

//! The standard, safe repairs of a face list, and the policy the commands
//! that compute on meshes (`run`, `transfer`, `keypoints`) apply to
//! result-changing defects ([`DefectKind`]).
//!
//! [`FaceRepair::plan`] changes faces only, never vertices (vertex `i` stays
//! vertex `i`, so correspondences and shared connectivity survive):
//!
//! - faces with a repeated vertex and zero-area faces (the test of
//!   [`super::validate::is_zero_area`]) are dropped;
//! - of faces with the same three vertices (in any order), the first is kept
//!   and the later ones are dropped;
//! - every *patch* (faces connected through edges that exactly two faces
//!   share) that can be wound consistently is: the faces wound against the
//!   patch's majority are reversed (on a tie, the winding of the patch's
//!   first face is kept). A patch that cannot (a Möbius band) is left as it
//!   is and counted in [`FaceRepair::unoriented`].
//!
//! Not repaired (reported by [`DefectPolicy::apply`] after the repair):
//! non-manifold edges and vertices, several components, unreferenced
//! vertices (removing one would renumber the others), and vertices that only
//! dropped faces used (they become unreferenced).

use std::fmt;
use std::path::Path;

use super::validate::{is_zero_area, Defect, DefectReport};
use super::{Face, Mesh};
use crate::{Error, Result};

/// The repaired face list of a mesh and what changed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FaceRepair {
    pub faces: Vec<Face>,
    /// Later copies of a vertex triple, dropped.
    pub duplicate: usize,
    /// Zero-area faces and faces with a repeated vertex, dropped.
    pub degenerate: usize,
    /// Faces whose winding was reversed.
    pub flipped: usize,
    /// Patches that cannot be wound consistently (left as they were).
    pub unoriented: usize,
}

impl FaceRepair {
    /// The repair of `mesh`'s faces (see the module documentation).
    pub fn plan(mesh: &Mesh) -> FaceRepair {
        let v = mesh.vertices();
        let faces = mesh.faces();
        let mut degenerate = 0;
        let mut kept: Vec<usize> = Vec::with_capacity(faces.len());
        for (fi, f) in faces.iter().enumerate() {
            let [a, b, c] = *f;
            if a == b || b == c || c == a || is_zero_area(v, f) {
                degenerate += 1;
            } else {
                kept.push(fi);
            }
        }
        // Duplicates: the first face of each vertex triple stays.
        let mut keyed: Vec<([usize; 3], usize)> = kept
            .iter()
            .map(|&fi| {
                let mut k = faces[fi];
                k.sort_unstable();
                (k, fi)
            })
            .collect();
        keyed.sort_unstable();
        let mut drop = vec![false; faces.len()];
        for w in keyed.windows(2) {
            if w[0].0 == w[1].0 {
                drop[w[1].1] = true;
            }
        }
        let before = kept.len();
        kept.retain(|&fi| !drop[fi]);
        let duplicate = before - kept.len();
        let mut out: Vec<Face> = kept.iter().map(|&fi| faces[fi]).collect();
        let (flipped, unoriented) = orient_patches(&mut out);
        FaceRepair {
            faces: out,
            duplicate,
            degenerate,
            flipped,
            unoriented,
        }
    }

    /// Whether the repair changes the face list.
    pub fn changed(&self) -> bool {
        self.duplicate + self.degenerate + self.flipped > 0
    }
}

impl fmt::Display for FaceRepair {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if self.duplicate > 0 {
            parts.push(format!("dropped {} duplicate faces", self.duplicate));
        }
        if self.degenerate > 0 {
            parts.push(format!(
                "dropped {} zero-area or repeated-vertex faces",
                self.degenerate
            ));
        }
        if self.flipped > 0 {
            parts.push(format!(
                "reversed the winding of {} faces (one winding per component)",
                self.flipped
            ));
        }
        if self.unoriented > 0 {
            parts.push(format!(
                "left {} non-orientable patch(es) as they were",
                self.unoriented
            ));
        }
        if parts.is_empty() {
            parts.push("nothing to repair".into());
        }
        f.write_str(&parts.join(", "))
    }
}

/// Reverses the faces wound against their patch's majority; returns the
/// number reversed and the number of patches that cannot be oriented.
fn orient_patches(faces: &mut [Face]) -> (usize, usize) {
    let nf = faces.len();
    // Half-edges grouped by undirected edge: (lo, hi, forward, face).
    let mut half: Vec<(usize, usize, bool, usize)> = Vec::with_capacity(3 * nf);
    for (fi, f) in faces.iter().enumerate() {
        let [a, b, c] = *f;
        for (u, v) in [(a, b), (b, c), (c, a)] {
            half.push((u.min(v), u.max(v), u < v, fi));
        }
    }
    half.sort_unstable();
    // Neighbours across edges shared by exactly two faces: (face, same direction).
    let mut adj: Vec<Vec<(usize, bool)>> = vec![Vec::new(); nf];
    let mut s = 0;
    while s < half.len() {
        let mut e = s;
        while e < half.len() && half[e].0 == half[s].0 && half[e].1 == half[s].1 {
            e += 1;
        }
        if e - s == 2 {
            let (f, g) = (half[s].3, half[s + 1].3);
            let same = half[s].2 == half[s + 1].2;
            adj[f].push((g, same));
            adj[g].push((f, same));
        }
        s = e;
    }
    let mut flip: Vec<Option<bool>> = vec![None; nf];
    let (mut flipped, mut unoriented) = (0, 0);
    let mut patch = Vec::new();
    let mut stack = Vec::new();
    for seed in 0..nf {
        if flip[seed].is_some() {
            continue;
        }
        flip[seed] = Some(false);
        stack.push(seed);
        patch.clear();
        let mut conflict = false;
        while let Some(f) = stack.pop() {
            patch.push(f);
            let ff = flip[f].unwrap_or(false);
            for &(g, same) in &adj[f] {
                let want = ff ^ same;
                match flip[g] {
                    None => {
                        flip[g] = Some(want);
                        stack.push(g);
                    }
                    Some(x) if x != want => conflict = true,
                    _ => {}
                }
            }
        }
        if conflict {
            unoriented += 1;
            continue;
        }
        let against = patch.iter().filter(|&&f| flip[f] == Some(true)).count();
        // Reverse the minority: the faces marked `true` unless they are more.
        let reverse = 2 * against <= patch.len();
        for &f in &patch {
            if flip[f] == Some(reverse) {
                faces[f].swap(1, 2);
                flipped += 1;
            }
        }
    }
    (flipped, unoriented)
}

/// What the commands that compute on meshes do with result-changing
/// defects. The default (both off) warns and computes on the mesh as it
/// is; the CLI flags `--strict` / `--repair` and the config keys `[dataset]
/// strict` / `repair` fall back to it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DefectPolicy {
    /// Refuse a mesh that has a result-changing defect (after the repair,
    /// when it is on).
    pub strict: bool,
    /// Apply [`FaceRepair`] before checking.
    pub repair: bool,
}

/// A mesh after [`DefectPolicy::apply`].
#[derive(Clone, Debug)]
pub struct Checked {
    pub mesh: Mesh,
    /// The repair made (`None`: repair off, or nothing to repair).
    pub repair: Option<FaceRepair>,
    /// The result-changing defects left (one entry per kind).
    pub defects: Vec<Defect>,
}

impl DefectPolicy {
    /// Repairs `mesh` if asked, then lists its result-changing defects;
    /// in strict mode a defect left is an error naming `file` and every
    /// kind found.
    ///
    /// `shared`: the original face list and the repair of another mesh
    /// (poses of one subject): when `mesh` has exactly that face list it
    /// gets that repair, so every pose keeps one connectivity (zero-area
    /// faces are then judged on the other mesh's geometry).
    pub fn apply(
        &self,
        mesh: Mesh,
        file: &Path,
        shared: Option<(&[Face], &FaceRepair)>,
    ) -> Result<Checked> {
        let mut mesh = mesh;
        let mut repair = None;
        if self.repair {
            let plan = match shared {
                Some((faces, plan)) if mesh.faces() == faces => plan.clone(),
                _ => FaceRepair::plan(&mesh),
            };
            if plan.changed() {
                if plan.faces.is_empty() {
                    return Err(Error::parse(
                        file,
                        "mesh",
                        format!("the repair drops every face ({plan})"),
                    ));
                }
                mesh = mesh.with_faces(plan.faces.clone())?;
                repair = Some(plan);
            }
        }
        let report = DefectReport::of_mesh(&mesh);
        if let Some(why) = super::validate::flattened(&mesh, &report) {
            return Err(Error::parse(file, "mesh", why));
        }
        let defects = report.result_defects();
        if self.strict && !defects.is_empty() {
            return Err(Error::parse(
                file,
                "mesh",
                format!(
                    "{}; strict mode refuses meshes with defects that change results \
                     (the repair option drops duplicate and zero-area faces and winds each \
                     component consistently{})",
                    defects
                        .iter()
                        .map(|d| d.to_string())
                        .collect::<Vec<_>>()
                        .join("; "),
                    if self.repair { "; it is on" } else { "" }
                ),
            ));
        }
        Ok(Checked {
            mesh,
            repair,
            defects,
        })
    }
}

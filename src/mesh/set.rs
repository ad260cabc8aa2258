//! Mesh sets: shared connectivity detection and consistent winding.
//!
//! Datasets such as FAUST or TOSCA store one mesh per pose, all meant to use
//! the same connectivity. [`ConnectivityReport::of`] checks that claim face by
//! face against the first mesh: same vertex count, same face count, and face
//! `i` of every mesh uses the same vertex triple as face `i` of the first mesh
//! (as a cyclic rotation, or reversed: the winding may differ per face).
//! [`adopt_consistent_faces`] then gives every mesh of the set one face list:
//! the first one in the set that is consistently wound.

use std::fmt;

use super::validate::{DefectReport, Offenders, LIST_CAP};
use super::{Face, Mesh};
use crate::{Error, Result};

/// How one face compares to the reference face.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaceMatch {
    /// Same triple, same cyclic order.
    Same,
    /// Same triple, opposite winding.
    Reversed,
    /// A different vertex set.
    Different,
}

/// Compares two faces up to rotation.
pub fn compare_faces(a: Face, b: Face) -> FaceMatch {
    let rotations = [b, [b[1], b[2], b[0]], [b[2], b[0], b[1]]];
    if rotations.contains(&a) {
        return FaceMatch::Same;
    }
    let r = [b[0], b[2], b[1]];
    let reversed = [r, [r[1], r[2], r[0]], [r[2], r[0], r[1]]];
    if reversed.contains(&a) {
        FaceMatch::Reversed
    } else {
        FaceMatch::Different
    }
}

/// One mesh of a set compared to the first mesh.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshComparison {
    pub n_vertices: usize,
    pub n_faces: usize,
    /// Faces `i < min(n_faces, reference n_faces)` with the same triple in the
    /// same winding.
    pub same_faces: usize,
    /// Faces with the same triple in the opposite winding.
    pub reversed_faces: Offenders<usize>,
    /// Faces with a different vertex set.
    pub different_faces: Offenders<usize>,
}

impl MeshComparison {
    /// Same vertex and face counts and the same triples face by face
    /// (winding aside).
    pub fn shares_connectivity(&self, reference: &MeshComparison) -> bool {
        self.n_vertices == reference.n_vertices
            && self.n_faces == reference.n_faces
            && self.different_faces.is_empty()
    }
}

/// Whether meshes share connectivity with the first one, mesh by mesh.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConnectivityReport {
    /// One entry per mesh, the first being the reference (compared to itself).
    pub meshes: Vec<MeshComparison>,
}

impl ConnectivityReport {
    /// Compares every mesh with `meshes[0]`.
    pub fn of(meshes: &[Mesh]) -> ConnectivityReport {
        let Some(reference) = meshes.first() else {
            return ConnectivityReport { meshes: Vec::new() };
        };
        let rf = reference.faces();
        let meshes = meshes
            .iter()
            .map(|m| {
                let mut c = MeshComparison {
                    n_vertices: m.n_vertices(),
                    n_faces: m.n_faces(),
                    same_faces: 0,
                    reversed_faces: Offenders::default(),
                    different_faces: Offenders::default(),
                };
                for (i, (&a, &b)) in m.faces().iter().zip(rf).enumerate() {
                    match compare_faces(a, b) {
                        FaceMatch::Same => c.same_faces += 1,
                        FaceMatch::Reversed => push(&mut c.reversed_faces, i),
                        FaceMatch::Different => push(&mut c.different_faces, i),
                    }
                }
                c
            })
            .collect();
        ConnectivityReport { meshes }
    }

    /// Every mesh shares the first mesh's connectivity (winding aside).
    pub fn shared(&self) -> bool {
        match self.meshes.first() {
            Some(r) => self.meshes.iter().all(|m| m.shares_connectivity(r)),
            None => true,
        }
    }

    /// Every mesh uses exactly the first mesh's face list.
    pub fn identical(&self) -> bool {
        self.shared() && self.meshes.iter().all(|m| m.reversed_faces.is_empty())
    }
}

fn push(o: &mut Offenders<usize>, i: usize) {
    o.count += 1;
    if o.first.len() < LIST_CAP {
        o.first.push(i);
    }
}

impl fmt::Display for ConnectivityReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Some(r) = self.meshes.first() else {
            return writeln!(f, "empty mesh set");
        };
        writeln!(
            f,
            "{} meshes; {}",
            self.meshes.len(),
            if self.identical() {
                "identical connectivity"
            } else if self.shared() {
                "shared connectivity (vertex triples), winding differs on some faces"
            } else {
                "connectivity NOT shared"
            }
        )?;
        writeln!(
            f,
            "  {:>4} {:>9} {:>9} {:>9} {:>9} {:>9}  note",
            "mesh", "vertices", "faces", "same", "reversed", "different"
        )?;
        for (i, m) in self.meshes.iter().enumerate() {
            let mut notes = Vec::new();
            if m.n_vertices != r.n_vertices {
                notes.push(format!("vertex count differs from {}", r.n_vertices));
            }
            if m.n_faces != r.n_faces {
                notes.push(format!("face count differs from {}", r.n_faces));
            }
            if !m.different_faces.is_empty() {
                notes.push(format!(
                    "first different faces {:?}",
                    m.different_faces.first
                ));
            }
            if !m.reversed_faces.is_empty() {
                notes.push(format!("first reversed faces {:?}", m.reversed_faces.first));
            }
            writeln!(
                f,
                "  {:>4} {:>9} {:>9} {:>9} {:>9} {:>9}  {}",
                i,
                m.n_vertices,
                m.n_faces,
                m.same_faces,
                m.reversed_faces.count,
                m.different_faces.count,
                notes.join("; ")
            )?;
        }
        Ok(())
    }
}

/// Gives every mesh of a set the face list of the first mesh whose winding
/// is consistent (no edge used twice in the same direction, see
/// [`DefectReport`]). Returns the index of that mesh and the new meshes
/// (same vertices, that face list).
///
/// Errors when the set is empty, does not share connectivity (the message
/// holds the [`ConnectivityReport`]), or no mesh is consistently wound.
pub fn adopt_consistent_faces(meshes: &[Mesh]) -> Result<(usize, Vec<Mesh>)> {
    if meshes.is_empty() {
        return Err(Error::invalid("empty mesh set"));
    }
    let report = ConnectivityReport::of(meshes);
    if !report.shared() {
        return Err(Error::invalid(format!(
            "the meshes do not share connectivity:\n{report}"
        )));
    }
    // Meshes with the same face list need checking only once.
    let mut checked: Vec<&[Face]> = Vec::new();
    for (i, m) in meshes.iter().enumerate() {
        if checked.contains(&m.faces()) {
            continue;
        }
        checked.push(m.faces());
        if DefectReport::of_mesh(m).inconsistent_edges.is_empty() {
            let faces = m.faces().to_vec();
            let out = meshes
                .iter()
                .map(|n| n.with_faces(faces.clone()))
                .collect::<Result<Vec<_>>>()?;
            return Ok((i, out));
        }
    }
    Err(Error::invalid(
        "no mesh of the set has a consistently wound face list",
    ))
}

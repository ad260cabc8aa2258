//! The triangle mesh type, its file formats and its validation.
//!
//! Readers produce a [`RawMesh`] (whatever the file said, defects included) so
//! that [`validate::DefectReport`] can describe a broken file; [`Mesh::new`]
//! turns raw data into a [`Mesh`] whose invariants every algorithm relies on:
//! every face index is in range and every coordinate is finite.

pub mod compact;
pub mod io;
pub mod primitives;
pub mod repair;
pub mod set;
pub mod validate;

use crate::{Error, Point, Result};

/// A triangle, as three vertex indices (counter-clockwise seen from outside).
pub type Face = [usize; 3];

/// Vertices and faces exactly as read from a file, not yet checked.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawMesh {
    pub vertices: Vec<Point>,
    pub faces: Vec<Face>,
}

/// A triangle mesh with checked invariants: face indices are in range and all
/// coordinates are finite. Defects that algorithms can live with (boundaries,
/// non-manifold edges, degenerate faces) are allowed and reported by
/// [`validate::DefectReport`].
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    vertices: Vec<Point>,
    faces: Vec<Face>,
}

impl Mesh {
    /// Builds a mesh, checking that every face index is in range and every
    /// coordinate is finite, and that there is at least one face.
    pub fn new(vertices: Vec<Point>, faces: Vec<Face>) -> Result<Self> {
        if faces.is_empty() {
            return Err(Error::invalid("mesh has no faces"));
        }
        check_finite(&vertices)?;
        let n = vertices.len();
        for (fi, f) in faces.iter().enumerate() {
            if let Some(&bad) = f.iter().find(|&&v| v >= n) {
                return Err(Error::invalid(format!(
                    "face {fi} uses vertex {bad}, but the mesh has {n} vertices"
                )));
            }
        }
        Ok(Mesh { vertices, faces })
    }

    /// Vertex positions.
    pub fn vertices(&self) -> &[Point] {
        &self.vertices
    }

    /// Faces.
    pub fn faces(&self) -> &[Face] {
        &self.faces
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.vertices.len()
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// The same connectivity with new vertex positions (a deformed copy).
    /// Errors if the count differs or a coordinate is not finite.
    pub fn with_vertices(&self, vertices: Vec<Point>) -> Result<Self> {
        if vertices.len() != self.vertices.len() {
            return Err(Error::invalid(format!(
                "deformed copy has {} vertices, the mesh has {}",
                vertices.len(),
                self.vertices.len()
            )));
        }
        check_finite(&vertices)?;
        Ok(Mesh {
            vertices,
            faces: self.faces.clone(),
        })
    }

    /// The same vertices with another face list (e.g. a consistently wound
    /// one adopted from a set). Indices are checked.
    pub fn with_faces(&self, faces: Vec<Face>) -> Result<Self> {
        Mesh::new(self.vertices.clone(), faces)
    }

    /// Moves the parts out.
    pub fn into_parts(self) -> (Vec<Point>, Vec<Face>) {
        (self.vertices, self.faces)
    }

    /// Applies `f` to every vertex position.
    pub fn map_vertices(&self, f: impl Fn(&Point) -> Point) -> Result<Self> {
        self.with_vertices(self.vertices.iter().map(f).collect())
    }
}

impl TryFrom<RawMesh> for Mesh {
    type Error = Error;
    fn try_from(raw: RawMesh) -> Result<Self> {
        Mesh::new(raw.vertices, raw.faces)
    }
}

impl From<Mesh> for RawMesh {
    fn from(m: Mesh) -> Self {
        RawMesh {
            vertices: m.vertices,
            faces: m.faces,
        }
    }
}

fn check_finite(vertices: &[Point]) -> Result<()> {
    if let Some(i) = vertices
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
    {
        return Err(Error::invalid(format!(
            "vertex {i} has a non-finite coordinate ({}, {}, {})",
            vertices[i].x, vertices[i].y, vertices[i].z
        )));
    }
    Ok(())
}

//! The triangle mesh type, its file formats and its validation.
//!
//! Readers produce a [`RawMesh`] (whatever the file said, defects included) so
//! that [`validate::DefectReport`] can describe a broken file; [`Mesh::new`]
//! turns raw data into a [`Mesh`] whose invariants every algorithm relies on:
//! every face index is in range and every coordinate is finite.

pub mod compact;
pub mod derived;
pub mod io;
pub mod primitives;
pub mod repair;
pub mod set;
pub mod validate;

use std::sync::Arc;

use crate::{Error, Point, Result};
use derived::Derived;

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
///
/// Values computed from a mesh (Laplacian, mass, adjacency: see
/// [`crate::ops::Operators`]) are kept with it and shared by its clones
/// ([`derived`]): a mesh never changes, so they stay valid.
#[derive(Clone)]
pub struct Mesh {
    vertices: Vec<Point>,
    faces: Vec<Face>,
    /// Values of the geometry (vertices and faces).
    geometry: Arc<Derived>,
    /// Values of the connectivity alone (kept by `with_vertices`).
    topology: Arc<Derived>,
}

impl PartialEq for Mesh {
    fn eq(&self, other: &Self) -> bool {
        self.vertices == other.vertices && self.faces == other.faces
    }
}

impl std::fmt::Debug for Mesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mesh")
            .field("vertices", &self.vertices)
            .field("faces", &self.faces)
            .finish()
    }
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
        Ok(Mesh {
            vertices,
            faces,
            geometry: Arc::default(),
            topology: Arc::default(),
        })
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
            geometry: Arc::default(),
            topology: self.topology.clone(),
        })
    }

    /// The same vertices with another face list (e.g. a consistently wound
    /// one adopted from a set). Indices are checked.
    pub fn with_faces(&self, faces: Vec<Face>) -> Result<Self> {
        Mesh::new(self.vertices.clone(), faces)
    }

    /// Values computed from the vertices and faces ([`derived`]).
    pub fn geometry_values(&self) -> &Derived {
        &self.geometry
    }

    /// Values computed from the faces alone, shared with every
    /// [`with_vertices`](Mesh::with_vertices) copy ([`derived`]).
    pub fn topology_values(&self) -> &Derived {
        &self.topology
    }

    /// Moves the parts out.
    pub fn into_parts(self) -> (Vec<Point>, Vec<Face>) {
        (self.vertices, self.faces)
    }

    /// Connected components of the surface: groups of faces joined through
    /// shared vertices (vertices in no face are not counted). An unwelded
    /// triangle soup has one per face.
    pub fn component_count(&self) -> usize {
        let n = self.vertices.len();
        let mut parent: Vec<usize> = (0..n).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for f in &self.faces {
            for k in 1..3 {
                let (a, b) = (root(&mut parent, f[0]), root(&mut parent, f[k]));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
        let mut seen = vec![false; n];
        let mut count = 0;
        for f in &self.faces {
            let r = root(&mut parent, f[0]);
            if !seen[r] {
                seen[r] = true;
                count += 1;
            }
        }
        count
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

/// The distances from their centre that a mesh's vertices may span: the
/// squared lengths, areas and cotangent weights of a mesh larger than
/// `1e50` overflow `f64` (about 1.8e308) and those of a mesh smaller than
/// `1e-50` underflow to zero, so such a mesh is refused with what happened
/// ([`check_extent`]) rather than computed into "coincident vertices" or
/// NaN.
pub const EXTENT_RANGE: (f64, f64) = (1e-50, 1e50);

/// The Euclidean norm of `v`, computed without overflow or underflow of
/// the squares (a vector of 1e200s has norm 1.7e200, not infinity).
pub fn stable_norm(v: &crate::Vec3) -> f64 {
    let m = v.amax();
    if m == 0.0 || !m.is_finite() {
        return m;
    }
    m * (v / m).norm()
}

/// Half the diagonal of the bounding box of `points` (0 for no points),
/// without overflow of the differences or squares.
pub fn half_diagonal(points: &[Point]) -> f64 {
    let Some(first) = points.first() else {
        return 0.0;
    };
    let (mut lo, mut hi) = (first.coords, first.coords);
    for p in points {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    stable_norm(&(hi * 0.5 - lo * 0.5))
}

/// The problem (overflow or underflow, as a message) when `extent`, the
/// largest distance of a mesh's vertices from their centre, is positive
/// and outside [`EXTENT_RANGE`]. An extent of 0 (every vertex at one
/// point) is not judged here.
pub fn check_extent(extent: f64) -> std::result::Result<(), String> {
    let (lo, hi) = EXTENT_RANGE;
    if !(extent.is_finite() && extent <= hi) {
        return Err(format!(
            "the vertices lie up to {extent:e} from their centre: beyond {hi:e}, squared \
             lengths and areas overflow f64 (numeric overflow); rescale the mesh"
        ));
    }
    if extent > 0.0 && extent < lo {
        return Err(format!(
            "the vertices lie at most {extent:e} from their centre: below {lo:e}, squared \
             lengths and areas underflow f64 to zero (numeric underflow); rescale the mesh"
        ));
    }
    Ok(())
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

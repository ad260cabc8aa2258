//! The per-mesh operators, computed once per mesh: [`Operators`].
//!
//! `mesh.laplacian()` computes the cotangent Laplacian on its first call
//! and returns the same matrix (shared) on every later call, from any clone
//! of the mesh; likewise the lumped mass, the cotangent edge weights, the
//! 1-ring and the vertex → face lists (these two are shared with every
//! deformed copy, `with_vertices`, which keeps the faces). The free
//! functions ([`cotan_laplacian`], [`mass_matrix`], ...) compute afresh
//! each time; [`computations`] counts how often each one ran
//! ([`super::counts`]).

use std::sync::Arc;

pub use super::counts::{computations, Computations};

use super::adjacency::{vertex_faces, vertex_neighbours, Csr};
use super::laplacian::{cotan_laplacian_from, cotan_weights, mass_matrix, MassKind};
use crate::mesh::derived::Key;
use crate::mesh::Mesh;
use crate::solve::SparseMatrix;

/// The operators of a mesh, each computed once per mesh (see the module
/// docs).
pub trait Operators {
    /// Cotangent Laplacian ([`super::cotan_laplacian`]).
    fn laplacian(&self) -> Arc<SparseMatrix>;
    /// Lumped mass diagonal ([`super::mass_matrix`]).
    fn mass(&self, kind: MassKind) -> Arc<Vec<f64>>;
    /// Total of the Voronoi mass: the area of the non-degenerate faces.
    fn mass_area(&self) -> f64;
    /// Cotangent weight per undirected edge ([`super::cotan_weights`]).
    fn edge_weights(&self) -> Arc<Vec<((usize, usize), f64)>>;
    /// 1-ring of every vertex ([`super::vertex_neighbours`]).
    fn neighbours(&self) -> Arc<Csr>;
    /// Faces incident to every vertex ([`super::vertex_faces`]).
    fn incident_faces(&self) -> Arc<Csr>;
}

struct LaplacianKey;
impl Key for LaplacianKey {
    type Value = SparseMatrix;
}
struct VoronoiMassKey;
impl Key for VoronoiMassKey {
    type Value = Vec<f64>;
}
struct BarycentricMassKey;
impl Key for BarycentricMassKey {
    type Value = Vec<f64>;
}
struct EdgeWeightsKey;
impl Key for EdgeWeightsKey {
    type Value = Vec<((usize, usize), f64)>;
}
struct NeighboursKey;
impl Key for NeighboursKey {
    type Value = Csr;
}
struct IncidentFacesKey;
impl Key for IncidentFacesKey {
    type Value = Csr;
}

impl Operators for Mesh {
    fn laplacian(&self) -> Arc<SparseMatrix> {
        self.geometry_values()
            .get::<LaplacianKey>(|| cotan_laplacian_from(self.n_vertices(), &self.edge_weights()))
    }

    fn mass(&self, kind: MassKind) -> Arc<Vec<f64>> {
        let compute = || mass_matrix(self, kind);
        match kind {
            MassKind::Voronoi => self.geometry_values().get::<VoronoiMassKey>(compute),
            MassKind::Barycentric => self.geometry_values().get::<BarycentricMassKey>(compute),
        }
    }

    fn mass_area(&self) -> f64 {
        self.mass(MassKind::Voronoi).iter().sum()
    }

    fn edge_weights(&self) -> Arc<Vec<((usize, usize), f64)>> {
        self.geometry_values()
            .get::<EdgeWeightsKey>(|| cotan_weights(self))
    }

    fn neighbours(&self) -> Arc<Csr> {
        self.topology_values()
            .get::<NeighboursKey>(|| vertex_neighbours(self))
    }

    fn incident_faces(&self) -> Arc<Csr> {
        self.topology_values()
            .get::<IncidentFacesKey>(|| vertex_faces(self))
    }
}

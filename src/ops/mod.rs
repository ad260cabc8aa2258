//! Discrete operators on one triangle mesh.
//!
//! Conventions: the Laplacian is the positive semi-definite cotangent
//! stiffness matrix `L` (off-diagonal `-½(cot α + cot β)`, zero row sums), so
//! the Laplace–Beltrami eigenproblem is `L φ = λ M φ` with `λ ≥ 0`.
//!
//! Contents: Laplacian and mass ([`laplacian`]; computed once per mesh
//! through [`Operators`]), edges and areas
//! ([`topology`]), adjacency and boundaries ([`adjacency`]), normals
//! ([`normals`]), polar decomposition and rotation log/exp ([`rotation`]),
//! per-vertex deformation gradients and BDT rotation/scale features
//! ([`gradient`]), Dijkstra geodesics ([`geodesic`]), farthest point
//! sampling ([`sampling`]), heat-method geodesics ([`heat`]) and unit-sphere
//! normalisation ([`normalize`]).

pub mod adjacency;
pub mod counts;
pub mod geodesic;
pub mod gradient;
pub mod heat;
pub mod laplacian;
pub mod normalize;
pub mod normals;
pub mod operators;
pub mod rotation;
pub mod sampling;
pub mod topology;

pub use adjacency::{
    boundary_edges, boundary_vertices, edge_faces, is_closed, vertex_faces, vertex_neighbours, Csr,
    EdgeFaces,
};
pub use geodesic::{dijkstra_distances, EdgeGraph};
pub use gradient::{deformation_features, deformation_gradients, DeformationFeatures};
pub use laplacian::{cotan_laplacian, cotan_weights, mass_matrix, MassKind};
pub use normalize::{
    normalize_to_unit_sphere, unit_sphere_transform, NormalizeReference, Similarity,
};
pub use normals::{face_normals, vertex_area_normals, vertex_normals};
pub use operators::{computations, Computations, Operators};
pub use rotation::{polar_decomposition, rotation_exp, rotation_log, scale_shear_vector, Polar};
pub use sampling::{
    farthest_point_sampling, farthest_point_sampling_from, farthest_point_sampling_in, FpsMetric,
};
pub use topology::{closest_point_on_triangle, edges, face_areas, total_area};

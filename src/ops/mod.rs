//! Discrete operators on one triangle mesh.
//!
//! Conventions: the Laplacian is the positive semi-definite cotangent
//! stiffness matrix `L` (off-diagonal `-½(cot α + cot β)`, zero row sums), so
//! the Laplace–Beltrami eigenproblem is `L φ = λ M φ` with `λ ≥ 0`.

pub mod heat;
pub mod laplacian;
pub mod topology;

pub use laplacian::{cotan_laplacian, cotan_weights, mass_matrix, MassKind};
pub use topology::{edges, face_areas, total_area};

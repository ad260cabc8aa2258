//! deformlab: a research harness for mesh deformation transfer and partial
//! shape registration.
//!
//! Layers (imports point downward only; see `DESIGN.md` of the project):
//!
//! ```text
//! data/ mesh/   Mesh type, I/O, validation | dataset layouts, synthetic generator
//! ops/          discrete operators on one mesh
//! solve/        sparse factorisations, eigenpairs
//! ```
//!
//! Algorithms never touch files: only `mesh::io` and `data` do I/O.
//!
//! ```
//! use deformlab::mesh::primitives::icosphere;
//! use deformlab::ops::{cotan_laplacian, mass_matrix, total_area, MassKind};
//!
//! let sphere = icosphere(3);
//! let l = cotan_laplacian(&sphere);
//! // Zero row sums: constants are in the kernel of the Laplacian.
//! let mut rows = vec![0.0; sphere.n_vertices()];
//! for (i, _, x) in l.triplet_iter() {
//!     rows[i] += x;
//! }
//! assert!(rows.iter().all(|r| r.abs() < 1e-10));
//! // The lumped mass sums to the surface area (a bit below 4π: the mesh is
//! // inscribed in the unit sphere).
//! let area: f64 = mass_matrix(&sphere, MassKind::Voronoi).iter().sum();
//! assert!((area - total_area(&sphere)).abs() < 1e-10);
//! assert!(area < 4.0 * std::f64::consts::PI && area > 0.99 * 4.0 * std::f64::consts::PI);
//! ```

pub mod arap;
pub mod baselines;
pub mod bench;
pub mod data;
pub mod error;
pub mod eval;
pub mod experiment;
pub mod mesh;
pub mod methods;
pub mod ops;
pub mod plot;
pub mod range;
pub mod register;
pub mod skin;
pub mod solve;
pub mod transfer;

pub use error::{Error, Result};
pub use mesh::Mesh;

/// Vertex positions: one type across the crate.
pub type Point = nalgebra::Point3<f64>;
/// 3-vectors (displacements, normals).
pub type Vec3 = nalgebra::Vector3<f64>;
/// 3×3 matrices (deformation gradients, rotations).
pub type Mat3 = nalgebra::Matrix3<f64>;

/// The crate version (`deformlab --version`, `deformlab.__version__`).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

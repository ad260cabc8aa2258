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

pub mod arap;
pub mod bench_bdt;
pub mod bench_skin;
pub mod data;
pub mod error;
pub mod mesh;
pub mod ops;
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

//! Baseline methods the papers compare against (issue 6).
//!
//! - [`sumner`]: Sumner & Popović 2004, "Deformation transfer for triangle
//!   meshes" — per-triangle deformation gradients, the transfer solve and
//!   (in [`sumner_correspondence`]) their triangle correspondence step;
//!   timing in [`bench`] (also as `sumner::bench`).

pub mod bench;
pub mod sumner;
pub mod sumner_correspondence;

pub use sumner::{
    deformation_gradients, triangle_frame, DeformationTransfer, SumnerTransferOptions,
    TriangleCorrespondence,
};
pub use sumner_correspondence::{
    correspond, match_triangles, CorrespondenceOptions, CorrespondenceResult,
};

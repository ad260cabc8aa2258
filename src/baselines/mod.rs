//! Baseline methods the papers compare against (issue 6).
//!
//! - [`sumner`]: Sumner & Popović 2004, "Deformation transfer for triangle
//!   meshes" — per-triangle deformation gradients, the transfer solve and
//!   (in [`sumner_correspondence`]) their triangle correspondence step;
//!   timing in [`bench`] (also as `sumner::bench`).
//! - [`cage`]: Ben-Chen, Weber & Gotsman 2009, "Spatial deformation
//!   transfer" — automatic box cages, mean-value coordinates, cage fits and
//!   cage-to-cage deformation transfer (simplifications in its docs).

pub mod bench;
pub mod cage;
pub mod sumner;
pub mod sumner_correspondence;

pub use cage::{
    build_cage, mean_value_coordinates, CageFit, CageOptions, CageTransfer, CageTransferred,
};
pub use sumner::{
    deformation_gradients, triangle_frame, DeformationTransfer, SumnerTransferOptions,
    TriangleCorrespondence,
};
pub use sumner_correspondence::{
    correspond, match_triangles, CorrespondenceOptions, CorrespondenceResult,
};

//! Baseline methods the papers compare against (issue 6).
//!
//! - [`sumner`]: Sumner & Popović 2004, "Deformation transfer for triangle
//!   meshes" — per-triangle deformation gradients, the transfer solve and
//!   (in [`sumner_correspondence`]) their triangle correspondence step;
//!   timing in `crate::bench::baselines`.
//! - [`cage`]: Ben-Chen, Weber & Gotsman 2009, "Spatial deformation
//!   transfer" — automatic box cages, mean-value coordinates, cage fits and
//!   cage-to-cage deformation transfer (simplifications in its docs).
//! - [`der`]: Der, Sumner & Popović 2006, "Inverse kinematics for reduced
//!   deformable models" — example-based deformation gradients on the FBT
//!   rotation clusters, Gauss–Newton on the blend weights, plugged into
//!   FBT's shape completion (simplifications in its docs).
//! - [`amberg`]: Amberg, Romdhani & Vetter 2007, "Optimal step nonrigid ICP
//!   algorithms for surface registration" — per-vertex affine transforms,
//!   stiffness schedule, landmarks, rejected closest points.
//!
//! Der and Amberg share the correspondence step of FBT's NICP,
//! [`crate::register::Matcher`].

pub mod amberg;
pub mod cage;
pub mod der;
pub mod sumner;
pub mod sumner_correspondence;

pub use amberg::{amberg_nicp, AmbergOptions, AmbergResult};
pub use cage::{
    build_cage, mean_value_coordinates, CageFit, CageOptions, CageTransfer, CageTransferred,
};
pub use der::{DerModel, DerNicpResult, DerOptions, DerProblem, DerSolution, DerState};
pub use sumner::{
    deformation_gradients, triangle_frame, DeformationTransfer, SumnerTransferOptions,
    TriangleCorrespondence,
};
pub use sumner_correspondence::{
    correspond, match_triangles, CorrespondenceOptions, CorrespondenceResult,
};

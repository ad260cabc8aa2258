//! Skinning: weights (bounded biharmonic, later Laplace–Beltrami), linear
//! blend skinning, rotation groups.

pub mod bbw;
pub mod dictionary;
pub mod groups;
pub mod lbo;
pub mod lbs;
pub mod rigging;

pub use groups::{rotation_groups, FeatureKind, GroupFeatures};
pub use lbs::{lbs, transforms_from_stacked, transforms_to_stacked, Affine, LbsMatrix};

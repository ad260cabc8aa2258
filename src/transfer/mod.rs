//! BDT pipeline: key point selection (Algorithm 1) and deformation transfer
//! (Sec. 3.6).

pub mod keypoints;

pub use keypoints::{
    fit_keypoints, select_keypoints, ErrorNorm, FastBounds, FastOptions, KeypointFit,
    KeypointOptions, KeypointSelection, SelectionMode, TraceStep,
};

//! BDT pipeline: key point selection (Algorithm 1) and deformation transfer
//! (Sec. 3.6), and the automatic target correspondence of issue 8 ([`auto`]).

pub mod auto;
pub mod keypoints;
pub mod target;

pub use auto::{
    auto_correspondence, coarse_align, perturb_keypoints, AutoCorrespondence, AutoOptions,
    CoarseAlignment, IcpStage, SimilarityMotion,
};
pub use keypoints::{
    fit_keypoints, select_keypoints, ErrorNorm, FastBounds, FastOptions, KeypointFit,
    KeypointOptions, KeypointSelection, SelectionMode, TraceStep,
};
pub use target::{
    handle_relative, mean_vertex_error, transfer, transfer_detailed, FrameAlign, FrameMap,
    TargetWeights, TransferFrame, TransferOptions, TransferResult,
};

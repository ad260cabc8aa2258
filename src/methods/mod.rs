//! Every method as a value with one entry point, used identically by the
//! CLI (`deformlab transfer`, `keypoints`), the experiment harness
//! (`deformlab run`) and the benchmarks (`deformlab bench`):
//!
//! * [`KeypointSource`]: where the key points on the source come from
//!   (Algorithm 1, a random or extremity simulated user, a given list);
//! * [`TargetPoints`]: their target vertices (same index, a list, a marker
//!   file, the automatic correspondence), with optional noise;
//! * [`TransferMethod`]: BDT ([`BdtOptions`]), Sumner–Popović with markers,
//!   the Sumner oracle, cage DT, and `identity` (B unchanged: the floor of
//!   every transfer evaluation); [`TransferMethod::run`];
//! * [`Clustering`]: rotation-group clustering (BDT Fig. 4);
//! * [`completion`]: shape completion / partial registration (FBT).
//!
//! Every options struct has one [`Default`], which the CLI flags and the
//! config keys fall back to; the enums are closed and every `match` over
//! them is exhaustive, so a new variant makes the compiler list each place
//! it must be handled.
//!
//! # How to add a method
//!
//! A transfer method (the `identity` floor was added this way, touching
//! three files):
//!
//! 1. `src/methods/transfer.rs`: a variant of [`TransferMethod`] with its
//!    parameters, its arm in [`TransferMethod::run`] (return the meshes and
//!    whatever it measured in a [`TransferOutcome`]) and in `kind_name`.
//! 2. `src/experiment/config.rs`: a `MethodKind` variant (the config's
//!    `kind = "..."`) and its arm in `resolve` (which keys it takes).
//! 3. Configs: a `[[methods]]` entry with the new `kind` in `experiments/`.
//!
//! The harness records every [`TransferOutcome`] the same way (metrics
//! against the ground truth, timings, renders), so nothing else changes. A
//! registration solver is a variant of the completion solver enum in
//! [`completion`], likewise.

pub mod clustering;
pub mod completion;
pub mod keypoints;
pub mod registry;
pub mod spec;
pub mod target;
pub mod transfer;

pub use clustering::{Clustering, ClusteringOutcome, Examples};
pub use keypoints::{
    extremity_keypoints, random_keypoints, KeypointSource, PickedKeypoints, Pool, Strategy,
};
pub use registry::{resolve_entry, Family, KindInfo, Method, MethodKind, NamedMethod};
pub use spec::{FbtSpec, FbtTask, MethodEntry, PipelineSpec};
pub use target::{TargetCorrespondence, TargetFound, TargetPoints};
pub use transfer::{
    match_translation, BdtOptions, TransferCase, TransferMethod, TransferOutcome, TransferTimings,
};

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
//! * [`fbt`]: the FBT tasks ([`FbtMethod`], one resolved `kind = "fbt"`
//!   method; [`fbt::FbtRegistrar`], the registration they share);
//!   [`completion`]: shape completion / partial registration (FBT).
//!
//! Every options struct has one [`Default`], which the CLI flags and the
//! config keys fall back to; the enums are closed and every `match` over
//! them is exhaustive, so a new variant makes the compiler list each place
//! it must be handled.
//!
//! # How to add a method
//!
//! See [`registry`]: a kind is a variant of [`MethodKind`] and its row in
//! [`MethodKind::info`] (name, family, summary, the keys it uses, its
//! constructor). A transfer baseline that takes BDT's key point pairs as
//! markers is one function of type [`MarkerFn`] (in `transfer.rs`) named
//! by its row: `|r| Ok(r.markers(my_markers))`. The CLI (`deformlab
//! transfer --method`), the configs and Python (`transfer(method=...)`)
//! read the registry; the harness records every [`TransferOutcome`] alike.

pub mod clustering;
pub mod completion;
pub mod external;
pub mod fbt;
pub mod keypoints;
pub mod registry;
pub mod spec;
pub mod target;
pub mod transfer;

pub use clustering::{Clustering, ClusteringOutcome, Examples};
pub use fbt::{ClassShapes, FbtMethod, FbtRegistrar};
pub use keypoints::{
    extremity_keypoints, random_keypoints, KeypointSource, PickedKeypoints, Pool, Strategy,
};
pub use registry::{
    entry_from_table, resolve_entry, transfer_method, Family, KindInfo, Method, MethodEntry,
    MethodKind, NamedMethod, PipelineSpec,
};
pub use spec::{FbtSpec, FbtTask};
pub use target::{TargetCorrespondence, TargetFound, TargetPoints};
pub use transfer::{
    cage_markers, match_translation, rigid_markers, sumner_markers, BdtOptions, MarkerBaseline,
    MarkerFn, TransferCase, TransferMethod, TransferOutcome, TransferTimings,
};

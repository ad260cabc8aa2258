//! FBT: fast blended transformations for partial shape registration
//! (Shtern, Sela & Kimmel; `papers/001_*.txt`), built on the example-based
//! dictionaries of [`crate::skin::dictionary`].
//!
//! Precompute / solve split (DESIGN rule 2):
//!
//! | object | built once per | holds |
//! |---|---|---|
//! | [`model::ArapGraph`] | mesh set (q examples) | cotangent spokes, example positions, `tr(V_ℓᵀLV_ℓ)` |
//! | [`model::FbtModel`] | (mesh set, dictionary, rotation clusters) | `L̃ = DᵀLD`, `K̃_ℓ = K_ℓD`, `Λ` |
//! | [`pipeline::FbtPipeline`] | (mesh set, init / main / rich dictionaries) | stage models, Eq. 24 matrices |
//! | [`solver::FbtSystem`], [`pipeline::PipelineSystems`] | constraint matrix `H` | `X = HD`, Cholesky of `Γ` (Eq. 18) and of Eq. 22's matrix |
//! | `solve*` calls | target `Y` | local / scale / global iterations, O(q r b) each |
//!
//! Contents: energies and their optimisation ([`solver`]), the paper's
//! schedule ([`pipeline`]), constraints including the geodesic-circle
//! feature constraints ([`constraints`]), nonrigid ICP ([`nicp`](mod@nicp)) and its
//! closest-point matcher ([`matcher`], shared with the baselines), the
//! crate's nearest-neighbour index ([`spatial`]), automatic feature
//! correspondence and shape interpolation ([`correspondence`]), error
//! measures ([`metrics`]).

pub mod constraints;
pub mod correspondence;
pub mod matcher;
pub mod metrics;
pub mod model;
pub mod nicp;
pub mod pipeline;
pub mod setup;
pub mod solver;
pub mod spatial;

pub use constraints::{
    apply_rows, circle_radii, feature_circle_constraints, feature_row_groups, geodesic_circle_rows,
    vertex_rows,
};
pub use correspondence::{best_permutation, interpolate, permutations, PermutationSearch};
pub use matcher::{Matcher, Matches};
pub use model::{ArapGraph, FbtModel};
pub use nicp::{minimal_step, nicp, NicpOptions, NicpResult};
pub use pipeline::{FbtPipeline, InitMethod, PipelineSystems, Registration, Schedule};
pub use setup::{
    build, build_with_rig, skeleton_rig, skeleton_weights, synthetic_class, ClusterSource,
    DictionaryExamples, FbtConfig, FbtSetup, StageConfig, WeightChoice,
};
pub use solver::{
    AverageSolution, ConstraintRows, ExampleSolution, FbtParams, FbtSystem, IterOptions,
    MinimalSolution, ScaleMode, Step, Trace,
};
pub use spatial::{Neighbour, PointIndex};

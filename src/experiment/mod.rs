//! Experiment harness: TOML configs ([`config`]), datasets and cases
//! ([`dataset`], [`cases`]), the methods of [`crate::methods`] run on
//! cases and recorded ([`record`]; FBT registration experiments in
//! [`fbt`]), the
//! resumable result store ([`store`]), the checks of the config against the
//! data before a run ([`feasible`]), valid ranges of numeric keys
//! ([`range`]), the suite runner with sharding and
//! merging ([`runner`]) and the plots regenerated from stored results
//! ([`plots`]). This layer (with `data`, `mesh::io` and `plot`) is the only
//! one that touches files.
//!
//! Results folder layout: see [`store`].

pub mod cases;
pub mod config;
pub mod dataset;
pub mod fbt;
pub mod feasible;
pub mod manifest;
pub mod plots;
pub mod range;
pub mod record;
pub mod runner;
pub mod store;

pub use cases::{generate_cases, Case};
pub use config::{load_config, parse_config, Config, LoadedConfig, Method, NamedMethod};
pub use dataset::Collection;
pub use manifest::{read_manifest, Manifest, Shard};
pub use plots::{make_plots, make_plots_with};
pub use runner::{merge, run_configs, RunOptions, RunSummary};
pub use store::{CaseResult, Store, CASE_COLUMNS};

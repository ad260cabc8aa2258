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
pub mod files;
pub mod fingerprint;
pub mod load;
pub mod lock;
pub mod manifest;
pub mod plots;
pub mod report;
pub use crate::range;
pub mod record;
pub mod runner;
pub mod store;
pub mod sweep;

pub use cases::{generate_cases, Case};
pub use config::{Config, LoadedConfig, Method, NamedMethod};
pub use dataset::Collection;
pub use load::{
    load_config, load_config_schema, load_config_with, parse_config, parse_config_schema,
    parse_config_with, LoadOptions,
};
pub use lock::FolderLock;
pub use manifest::{read_manifest, Manifest, Shard};
pub use plots::{make_plots, make_plots_with};
pub use report::{build_report, write_report, Report, ReportOptions};
pub use runner::{merge, run_configs, RunOptions, RunSummary};
pub use store::{CaseResult, Store, CASE_COLUMNS};

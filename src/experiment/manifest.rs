//! `manifest.json` of a results folder: the config, its hash, the cases,
//! the shards, the mesh defects; and `timings/runs.json`, the volatile
//! record of every invocation of `run` on the folder.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::cases::Case;
use super::store::write_file;
use crate::{Error, Result};

/// A deterministic slice of the cases: those with `index % count == index_of_shard`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// Parses `i/N` (0 ≤ i < N).
    pub fn parse(s: &str) -> Result<Shard> {
        let bad = || Error::invalid(format!("--shard expects i/N with 0 ≤ i < N, got {s:?}"));
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }

    pub fn contains(&self, case: usize) -> bool {
        case % self.count == self.index
    }
}

/// One invocation of `run` on a folder, as recorded in
/// `timings/runs.json` ([`RunLog`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Invocation {
    pub started_unix: u64,
    pub wall_seconds: f64,
    pub threads: usize,
    pub shard: Option<Shard>,
    pub crate_version: String,
    pub git_revision: String,
    /// Case × method results computed by this invocation.
    pub computed: usize,
    /// Results found already stored (resumed).
    pub reused: usize,
}

/// `timings/runs.json`: the volatile record of a results folder (see
/// [`super::store::TIMINGS_DIR`]): every invocation of `run` (or `merge`)
/// on it and the seconds per method over the stored results.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RunLog {
    /// Sum of `seconds_total` per method over the stored results.
    pub method_seconds: Vec<(String, f64)>,
    pub invocations: Vec<Invocation>,
}

/// Reads `timings/runs.json` of a results folder: `None` when there is
/// none or it does not parse (it is replaced), an error for a link or a
/// special file in its place.
pub fn read_run_log(dir: &Path) -> Result<Option<RunLog>> {
    let path = dir.join(super::store::TIMINGS_DIR).join("runs.json");
    match std::fs::symlink_metadata(&path) {
        Err(_) => Ok(None),
        Ok(_) => Ok(serde_json::from_str(&super::files::read_regular(&path)?).ok()),
    }
}

/// Writes `timings/runs.json` (atomically).
pub fn write_run_log(dir: &Path, log: &RunLog) -> Result<()> {
    let bytes = serde_json::to_vec_pretty(log)
        .map_err(|e| Error::invalid(format!("run log to JSON: {e}")))?;
    let timings = super::store::own_subdir(dir, super::store::TIMINGS_DIR)?;
    write_file(&timings.join("runs.json"), &bytes, true)?;
    Ok(())
}

/// One kind of result-changing defect in one mesh file, as recorded in
/// manifest.json (`kind`: [`crate::mesh::validate::DefectKind::name`]).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct DefectNote {
    pub subject: String,
    pub pose: String,
    pub file: String,
    pub kind: String,
    pub count: usize,
    /// The warning printed, e.g. `2 duplicate faces (first: 5 9)`.
    pub detail: String,
}

impl DefectNote {
    /// One note per defect kind of each check.
    pub fn of(checks: &[super::dataset::MeshCheck]) -> Vec<DefectNote> {
        checks
            .iter()
            .flat_map(|c| {
                c.defects.iter().map(|d| DefectNote {
                    subject: c.subject.clone(),
                    pose: c.pose.clone(),
                    file: c.file.clone(),
                    kind: d.kind.name().to_string(),
                    count: d.count,
                    detail: d.to_string(),
                })
            })
            .collect()
    }
}

/// `manifest.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Manifest {
    pub name: String,
    pub config_file: String,
    /// The store key of the folder (`config.json`'s `hash`: the config
    /// and, for data read from files, their content fingerprint).
    pub config_hash: String,
    /// `--set KEY=VALUE` overrides applied to the config file, in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub overrides: Vec<String>,
    /// The sweep expanded into methods: its axes (key, values, name parts,
    /// grid, whether from the file or `--sweep`) and each swept method's
    /// variants ([`super::sweep`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<serde_json::Value>,
    /// The data root of the last run, when the data are files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data_root: Option<String>,
    /// The fingerprint of the input files (`config.json`'s `data.hash`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data_hash: Option<String>,
    /// The full config as run (overrides applied, sweep expanded, output
    /// settings included).
    pub config: serde_json::Value,
    pub seed: u64,
    pub crate_version: String,
    pub dataset: String,
    pub n_cases: usize,
    pub cases: Vec<Case>,
    pub methods: Vec<String>,
    /// Shards whose cases this folder holds (`None`: all cases).
    pub shards: Option<Vec<Shard>>,
    pub results_stored: usize,
    pub results_failed: usize,
    /// Meshes the dataset repaired at load, one line each, over every
    /// invocation (sorted): windings adopted from the subject
    /// ([`super::dataset::WindingRepair`]) and, with `[dataset] repair`,
    /// dropped faces and reversed windings (`FILE: repaired: …`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub repairs: Vec<String>,
    /// Result-changing defects of the meshes served (after any repair), one
    /// entry per file and kind, over every invocation (sorted).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub mesh_defects: Vec<DefectNote>,
}

/// Writes manifest.json (atomically).
pub fn write_manifest(dir: &Path, m: &Manifest) -> Result<()> {
    let bytes = serde_json::to_vec_pretty(m)
        .map_err(|e| Error::invalid(format!("manifest to JSON: {e}")))?;
    write_file(&dir.join("manifest.json"), &bytes, true)?;
    Ok(())
}

/// Reads manifest.json of a results folder.
pub fn read_manifest(dir: &Path) -> Result<Manifest> {
    let path = dir.join("manifest.json");
    let text = super::files::read_regular(&path)?;
    serde_json::from_str(&text).map_err(|e| Error::parse(&path, "JSON", e.to_string()))
}

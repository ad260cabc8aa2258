//! The result store of one experiment folder.
//!
//! ```text
//! DIR/config.json          the store key (`hash`): the config as run and the input
//!                          files' fingerprint (`data`); written first (see [`StoredConfig`])
//! DIR/.fingerprints.json   cached hashes of the input files ([`super::fingerprint`])
//! DIR/failed/<case>/<method>.json  failed results moved aside by `--retry-failed`
//! DIR/cases/<case>/<method>.json   one finished case × method (atomic, never overwritten)
//! DIR/meshes/<case>/...    meshes saved for renders: source, deformed, target, truth, and
//!                          the results of the first method of each group ([outputs] render_*)
//! DIR/manifest.json        config, seed, crate version, cases, methods, shards, counts
//! DIR/cases.csv            one row per case × method, rebuilt from cases/ in case order;
//!                          the columns of CASE_COLUMNS that hold a value in some row,
//!                          timings aside
//! DIR/curves.csv           case,method,curve,x,y (long format)
//! DIR/summary.csv          method,group,metric,n,mean,std,min,median,max (timings aside)
//! DIR/plots/               PNG + SVG + PDF charts, PNG renders; tables as CSV, Markdown, LaTeX
//! DIR/timings/             the volatile files (TIMINGS_DIR): cases.csv and summary.csv of
//!                          the seconds_* columns, runs.json (every invocation: start, wall
//!                          time, threads, revision), plots/ (figures showing timings)
//! ```
//!
//! Everything outside `timings/` is byte-identical when a config is run
//! again (on any thread count, resumed or sharded and merged).
//!
//! **Atomicity.** A result file is written to a unique temporary name in the
//! same folder and then hard-linked to its final name, which fails if the
//! name exists: a finished result is never overwritten, and a process
//! killed at any moment leaves either no file or a complete one (its
//! temporary files, dot-prefixed and named by the process, are removed by
//! the next run that holds the folder alone; [`remove_stale_temporaries`]). Tables are rebuilt from the result
//! files only, so a resumed, a sharded+merged and an uninterrupted run give
//! the same `cases.csv` (timing columns aside).
//!
//! **Numbers** are stored as text at the moment they are computed (10
//! significant digits, shortest form), so rebuilding a table is pure text.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::fingerprint::DataPrint;
use crate::mesh::io::temp;
use crate::{Error, Result};

/// The columns that identify a row (the first of [`CASE_COLUMNS`]): a
/// failed row keeps only these.
pub const ID_COLUMNS: &[&str] = &[
    "case",
    "case_id",
    "source",
    "target",
    "reference_pose",
    "poses",
    "method",
    "group",
    "kind",
];

/// Columns of `cases.csv`, in order. Columns whose name starts with
/// `seconds_` are timings (the only columns that differ between two runs of
/// one config).
pub const CASE_COLUMNS: &[&str] = &[
    // ID_COLUMNS first (a test holds them equal)
    "case",
    "case_id",
    "source",
    "target",
    "reference_pose",
    "poses",
    "method",
    "group",
    "kind",
    "status",
    "n_vertices",
    "n_keypoints",
    "keypoints",
    "n_selection_poses",
    "selection_error",
    "selection_evaluations",
    "epsilon",
    "n_candidates",
    "fit_error_unit",
    "procrustes",
    "err_mean_unit",
    "err_rms_unit",
    "err_max_unit",
    "err_mean_area",
    "err_rms_area",
    "err_max_area",
    "err_mean_unit_rigid",
    "err_rms_unit_rigid",
    "err_max_unit_rigid",
    "err_mean_area_rigid",
    "err_rms_area_rigid",
    "err_max_area_rigid",
    "within_002_area",
    "within_005_area",
    "within_002_area_rigid",
    "within_005_area_rigid",
    "edge_strain_p99",
    "edge_strain_p99_source",
    "edge_strain_p99_fit",
    "edge_strain_p99_truth",
    "arap_energy",
    "arap_energy_truth",
    "distortion_area",
    "distortion_edge",
    "n_clusters",
    "ari",
    "purity",
    "rigidity_unit",
    "fbt_task",
    "q",
    "examples",
    "pipeline",
    "dictionary",
    "dictionary_kind",
    "dict_size",
    "dict_sizes",
    "n_bones",
    "rig_rms",
    "n_faces",
    "dropped_vertices",
    "dropped_note",
    "n_constraints",
    "iterations",
    "partial_area",
    "alpha",
    "alpha_true",
    "alpha_error",
    "alpha_unscaled",
    "alpha_oracle",
    "alpha_oracle_error",
    "alpha_vertex_oracle",
    "alpha_ratio_error",
    "rel_distortion_mean",
    "rel_distortion_median",
    "rel_distortion_max",
    "rel_distortion_mean_init",
    "rel_distortion_median_init",
    "rel_distortion_max_init",
    "rel_distortion_mean_aligned",
    "rel_distortion_median_aligned",
    "rel_distortion_max_aligned",
    "floor_distortion_mean",
    "floor_distortion_mean_aligned",
    "failed_parts",
    "gross_failure",
    "worst_part_mean",
    "worst_part_max",
    "partial_residual",
    "attempts",
    "attempt",
    "corr_error_mean",
    "corr_error_mean_geodesic",
    "corr_error_mean_euclidean",
    "floor_corr_error_mean_euclidean",
    "perm_correct",
    "perm_rank",
    "perm_count",
    "interp_endpoint_error",
    "arap_energy_linear",
    "target_correspondence",
    "target_noise",
    "target_keypoints",
    "target_keypoint_error_area",
    "registration_residual_area",
    "target_frame",
    "seconds_selection",
    "seconds_selection_computed",
    "seconds_fit",
    "seconds_fit_computed",
    "seconds_weights",
    "seconds_weights_per_handle",
    "seconds_lbs",
    "seconds_lbs_per_pose",
    "seconds_refine",
    "seconds_metrics",
    "seconds_precompute",
    "seconds_factorise",
    "seconds_iteration_init",
    "seconds_iteration_main",
    "seconds_iteration_rich",
    "seconds_solve",
    "seconds_nicp",
    "seconds_correspondence",
    "seconds_total",
];

/// Whether a column is a timing column.
pub fn is_timing(column: &str) -> bool {
    column.starts_with("seconds_")
}

/// A number as stored: 10 significant digits, shortest form; empty for
/// non-finite values.
pub fn num(x: f64) -> String {
    if !x.is_finite() {
        return String::new();
    }
    let r: f64 = format!("{x:.9e}").parse().unwrap_or(x);
    format!("{r}")
}

/// A timing in seconds (microsecond resolution).
pub fn secs(x: f64) -> String {
    format!("{x:.6}")
}

/// One curve of a case × method (`x`, `y` stored as text).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    pub name: String,
    pub x: Vec<String>,
    pub y: Vec<String>,
}

impl Curve {
    pub fn new(name: &str, x: &[f64], y: &[f64]) -> Self {
        Curve {
            name: name.to_string(),
            x: x.iter().map(|v| num(*v)).collect(),
            y: y.iter().map(|v| num(*v)).collect(),
        }
    }
}

/// A finished case × method.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CaseResult {
    pub case: usize,
    pub case_id: String,
    pub method: String,
    /// Column → cell (columns of [`CASE_COLUMNS`]; missing = empty).
    pub cells: BTreeMap<String, String>,
    pub curves: Vec<Curve>,
}

impl CaseResult {
    /// Sets a cell.
    pub fn set(&mut self, column: &str, value: impl Into<String>) {
        debug_assert!(CASE_COLUMNS.contains(&column), "unknown column {column}");
        self.cells.insert(column.to_string(), value.into());
    }

    /// The CSV row in [`CASE_COLUMNS`] order.
    pub fn row(&self) -> Vec<String> {
        CASE_COLUMNS
            .iter()
            .map(|c| self.cells.get(*c).cloned().unwrap_or_default())
            .collect()
    }
}

/// Where a render case's meshes go (`None`: not a render case).
pub struct RenderOut<'a> {
    pub dir: &'a Path,
    /// Deformed poses saved (the first ones of the case).
    pub poses: usize,
    /// File format of the meshes ([`crate::mesh::io::Format::Ply`] or
    /// [`crate::mesh::io::Format::Obj`]).
    pub format: crate::mesh::io::Format,
}

impl RenderOut<'_> {
    /// The folder of method `name`'s meshes.
    pub fn method(&self, name: &str) -> MeshOut {
        MeshOut {
            dir: self.dir.join(name),
            format: self.format,
        }
    }
}

/// A folder of saved meshes and their format.
#[derive(Clone, Debug)]
pub struct MeshOut {
    pub dir: PathBuf,
    pub format: crate::mesh::io::Format,
}

impl MeshOut {
    /// Saves `dir/<stem>.ply` (or `.obj`) unless it exists (a stored
    /// result is never overwritten). `error`, one value per vertex (the
    /// distance to the true position), goes into the PLY as the float
    /// vertex property `error`, or beside an OBJ into `<stem>.error.txt`
    /// (one number per line, in vertex order, nothing else).
    pub fn save(&self, stem: &str, mesh: &crate::mesh::Mesh, error: Option<&[f64]>) -> Result<()> {
        use crate::mesh::io::Format;
        let obj = self.format == Format::Obj;
        let path = self
            .dir
            .join(format!("{stem}.{}", if obj { "obj" } else { "ply" }));
        if path.exists() {
            return Ok(());
        }
        std::fs::create_dir_all(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
        match (obj, error) {
            (false, None) => crate::mesh::io::write_ply(&path, mesh),
            (false, Some(e)) => crate::mesh::io::write_ply_with(&path, mesh, &[("error", e)]),
            (true, e) => {
                if let Some(e) = e {
                    let text: String = e.iter().map(|v| num(*v) + "\n").collect();
                    let side = self.dir.join(format!("{stem}.error.txt"));
                    write_file(&side, text.as_bytes(), true)?;
                }
                crate::mesh::io::write_obj(&path, mesh)
            }
        }
    }

    /// The saved mesh `dir/<stem>.ply`, else `dir/<stem>.obj` (`None`:
    /// neither exists).
    pub fn find(dir: &Path, stem: &str) -> Option<PathBuf> {
        ["ply", "obj"]
            .iter()
            .map(|e| dir.join(format!("{stem}.{e}")))
            .find(|p| p.is_file())
    }
}

/// Saves a render mesh (PLY) unless `path` exists (a stored result is never
/// overwritten).
pub fn save_mesh(path: &Path, mesh: &crate::mesh::Mesh) -> Result<()> {
    if path.exists() {
        return Ok(());
    }
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
    }
    crate::mesh::io::write_ply(path, mesh)
}

/// Writes `bytes` to a temporary file of this process
/// ([`crate::mesh::io::temp`]), syncs it and moves it to `path`.
/// `clobber = false`: fails with `Ok(false)` (file left alone) if `path`
/// exists. Returns whether the file was written. The temporary is removed
/// in every case.
pub fn write_file(path: &Path, bytes: &[u8], clobber: bool) -> Result<bool> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    let tmp = temp::write_temp(path, bytes, true)?;
    if clobber {
        temp::commit(&tmp, path)?;
        return Ok(true);
    }
    let linked = std::fs::hard_link(&tmp, path);
    let _ = std::fs::remove_file(&tmp);
    match linked {
        Ok(()) => Ok(true),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(false),
        Err(e) => Err(Error::io(path, e)),
    }
}

/// Removes the temporaries under `dir` (recursively) that other processes
/// left behind ([`temp::is_temporary`]; this process's own are kept).
/// Call it only while no other process writes under `dir` (the folder's
/// exclusive lock, [`super::lock`]): a temporary of a live writer would be
/// pulled from under it.
pub fn remove_stale_temporaries(dir: &Path) -> Result<usize> {
    let mut n = 0;
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Ok(0);
    };
    for e in rd {
        let e = e.map_err(|e| Error::io(dir, e))?;
        let p = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        let is_dir = e.file_type().map(|t| t.is_dir()).unwrap_or(false);
        if is_dir {
            n += remove_stale_temporaries(&p)?;
        } else if temp::is_temporary(&name) && !temp::is_own_temporary(&name) {
            match std::fs::remove_file(&p) {
                Ok(()) => n += 1,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(Error::io(&p, e)),
            }
        }
    }
    Ok(n)
}

/// The store of one experiment folder.
#[derive(Clone, Debug)]
pub struct Store {
    pub dir: PathBuf,
}

/// Content of `DIR/config.json`: what the stored results belong to. `hash`
/// is the store key: the config's [`crate::experiment::Config::key_part`]
/// (overrides and sweeps applied, dataset paths left out) and, for data
/// read from files, the content fingerprint of every input file (`data`).
/// Folders written before fingerprints have no `data`; `adopted_from` is
/// their former key when a run adopted one ([`Store::bind`]).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct StoredConfig {
    pub hash: String,
    pub config: serde_json::Value,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data: Option<DataPrint>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adopted_from: Option<String>,
}

/// The store key of a config (its [`crate::experiment::Config::key_part`]
/// as JSON, fields in the struct's order) and its data's fingerprint: FNV-1a 64, 16 hex digits. Without
/// data files it is the hash of the config alone, as folders written
/// before data fingerprints have it.
pub fn store_key(key_config_json: &str, data: Option<&DataPrint>) -> String {
    let mut text = key_config_json.to_string();
    if let Some(d) = data {
        text.push_str("\ndata ");
        text.push_str(&d.hash);
    }
    format!("{:016x}", crate::data::fnv1a(text.as_bytes()))
}

/// `config` (JSON) without the dataset paths: where the data live is not
/// part of what a result depends on (its content is, see `data`).
pub fn without_data_paths(config: &serde_json::Value) -> serde_json::Value {
    let mut c = config.clone();
    if let Some(d) = c.get_mut("dataset").and_then(|d| d.as_object_mut()) {
        for (_, spec) in d.iter_mut() {
            if let Some(o) = spec.as_object_mut() {
                o.remove("path");
            }
        }
    }
    c
}

/// How [`Store::bind`] found the folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Bound {
    /// No `config.json` yet: written.
    Fresh,
    /// The same key.
    Same,
    /// A folder from before data fingerprints, same config: adopted, the
    /// current data recorded.
    Adopted { files: usize },
    /// Another key but no stored result: rebound to this config.
    Rebound,
    /// The same config with these methods added: the stored results are
    /// kept (a method's results do not depend on the other methods).
    Extended(Vec<String>),
    /// Another key, `--force`: its content moved to this folder.
    Superseded(PathBuf),
}

/// Options of [`Store::bind`].
#[derive(Clone, Copy, Debug, Default)]
pub struct BindOptions {
    /// Move the results of another key aside and start afresh (`--force`).
    pub force: bool,
    /// The caller holds the folder alone (exclusive lock): needed to
    /// rebind an empty folder or to move results aside.
    pub alone: bool,
}

impl Store {
    pub fn new(dir: &Path) -> Self {
        Store {
            dir: dir.to_path_buf(),
        }
    }

    pub fn result_path(&self, case_id: &str, method: &str) -> PathBuf {
        self.dir
            .join("cases")
            .join(case_id)
            .join(format!("{method}.json"))
    }

    pub fn mesh_dir(&self, case_id: &str) -> PathBuf {
        self.dir.join("meshes").join(case_id)
    }

    pub fn config_path(&self) -> PathBuf {
        self.dir.join("config.json")
    }

    /// Binds the folder to a config: writes `config.json` if absent, else
    /// checks that it holds the same key. A folder written before data
    /// fingerprints (no `data`) whose config is this one, dataset paths
    /// aside, is adopted: the current data are recorded. Otherwise another
    /// key is refused with an error naming the keys and the data files
    /// that differ, unless nothing is stored yet or `force` (see
    /// [`BindOptions`]; `force` moves the folder's content to
    /// `DIR.superseded-<old key>` first: no result is lost).
    pub fn bind(&self, stored: &StoredConfig, o: BindOptions) -> Result<Bound> {
        let path = self.config_path();
        let bytes = serde_json::to_vec_pretty(stored)
            .map_err(|e| Error::invalid(format!("config to JSON: {e}")))?;
        if write_file(&path, &bytes, false)? {
            return Ok(Bound::Fresh);
        }
        let old = self.read_config()?;
        if old.hash == stored.hash {
            return Ok(Bound::Same);
        }
        let same_config = without_data_paths(&old.config) == without_data_paths(&stored.config);
        if same_config && old.data.is_none() && old.adopted_from.is_none() {
            if let Some(d) = &stored.data {
                let adopted = StoredConfig {
                    adopted_from: Some(old.hash.clone()),
                    ..stored.clone()
                };
                let bytes = serde_json::to_vec_pretty(&adopted)
                    .map_err(|e| Error::invalid(format!("config to JSON: {e}")))?;
                write_file(&path, &bytes, true)?;
                return Ok(Bound::Adopted {
                    files: d.files.len(),
                });
            }
        }
        if let Some(added) = added_methods(&old.config, &stored.config) {
            if old.data == stored.data {
                let extended = StoredConfig {
                    adopted_from: Some(old.hash.clone()),
                    ..stored.clone()
                };
                let bytes = serde_json::to_vec_pretty(&extended)
                    .map_err(|e| Error::invalid(format!("config to JSON: {e}")))?;
                write_file(&path, &bytes, true)?;
                return Ok(Bound::Extended(added));
            }
        }
        if o.alone && !self.has_results() {
            write_file(&path, &bytes, true)?;
            return Ok(Bound::Rebound);
        }
        if o.force {
            if !o.alone {
                return Err(Error::invalid(format!(
                    "{}: --force needs the folder to itself",
                    self.dir.display()
                )));
            }
            let to = self.supersede(&old.hash)?;
            write_file(&path, &bytes, false)?;
            return Ok(Bound::Superseded(to));
        }
        let mut what = Vec::new();
        if !same_config {
            let mut diffs = Vec::new();
            json_diff(
                "",
                &without_data_paths(&old.config),
                &without_data_paths(&stored.config),
                &mut diffs,
            );
            what.push(format!(
                "another configuration (differing keys: {})",
                if diffs.is_empty() {
                    "none found".to_string()
                } else {
                    diffs.join(", ")
                }
            ));
        }
        match (&old.data, &stored.data) {
            (Some(then), Some(now)) if then.hash != now.hash => {
                what.push(format!("other data ({})", now.changes_since(then)));
            }
            (Some(_), None) => what.push("data read from files, now none".into()),
            _ => {}
        }
        if what.is_empty() {
            what.push("another configuration".into());
        }
        Err(Error::invalid(format!(
            "{} holds results of {} (store key {} there, {} now). Run with --force to move \
             them to {} and start this folder afresh, or use another --out folder",
            self.dir.display(),
            what.join(" and of "),
            old.hash,
            stored.hash,
            self.superseded_path(&old.hash).display()
        )))
    }

    /// Where [`Store::bind`] with `force` moves the results of key `hash`:
    /// `DIR.superseded-<hash>` (`-2`, `-3`, … if taken).
    fn superseded_path(&self, hash: &str) -> PathBuf {
        let name = self
            .dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "results".into());
        let base = self.dir.with_file_name(format!("{name}.superseded-{hash}"));
        let mut p = base.clone();
        let mut k = 2;
        while p.exists() {
            p = PathBuf::from(format!("{}-{k}", base.display()));
            k += 1;
        }
        p
    }

    /// Moves the folder's content (but its lock files and the fingerprint
    /// cache) to [`Store::superseded_path`]. Call only while holding the
    /// folder alone.
    fn supersede(&self, hash: &str) -> Result<PathBuf> {
        let to = self.superseded_path(hash);
        std::fs::create_dir_all(&to).map_err(|e| Error::io(&to, e))?;
        let rd = std::fs::read_dir(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
        for e in rd {
            let e = e.map_err(|e| Error::io(&self.dir, e))?;
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with(".lock") || name == super::fingerprint::CACHE_FILE {
                continue;
            }
            let dest = to.join(&name);
            std::fs::rename(e.path(), &dest).map_err(|err| Error::io(e.path(), err))?;
        }
        Ok(to)
    }

    /// Whether any case × method result is stored.
    pub fn has_results(&self) -> bool {
        let Ok(rd) = std::fs::read_dir(self.dir.join("cases")) else {
            return false;
        };
        rd.filter_map(|e| e.ok()).any(|d| {
            std::fs::read_dir(d.path()).is_ok_and(|mut f| {
                f.any(|x| {
                    x.is_ok_and(|x| {
                        let n = x.file_name().to_string_lossy().into_owned();
                        n.ends_with(".json") && !n.starts_with('.')
                    })
                })
            })
        })
    }

    /// Moves a stored failed result (status other than `ok`) of `case_id` ×
    /// `method` to `DIR/failed/<case>/<method>.json` (`.2.json`, … if
    /// taken), so that the next run computes it again; returns whether
    /// there was one. Nothing is deleted.
    pub fn retire_failed(&self, case_id: &str, method: &str) -> Result<bool> {
        let path = self.result_path(case_id, method);
        if !path.is_file() {
            return Ok(false);
        }
        let r = self.get(case_id, method)?;
        if r.cells.get("status").is_none_or(|s| s == "ok") {
            return Ok(false);
        }
        let dir = self.dir.join("failed").join(case_id);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let mut dest = dir.join(format!("{method}.json"));
        let mut k = 2;
        while dest.exists() {
            dest = dir.join(format!("{method}.{k}.json"));
            k += 1;
        }
        std::fs::rename(&path, &dest).map_err(|e| Error::io(&path, e))?;
        Ok(true)
    }

    pub fn read_config(&self) -> Result<StoredConfig> {
        let path = self.config_path();
        let text = super::files::read_regular(&path)?;
        serde_json::from_str(&text).map_err(|e| Error::parse(&path, "JSON", e.to_string()))
    }

    /// Moves a file of `cases/` to `DIR/<aside>/<case>/<file>` (never
    /// overwriting: `-2`, `-3`, … on a clash) and returns where.
    fn set_aside(&self, f: &Path, aside: &str) -> Result<PathBuf> {
        let case = f
            .parent()
            .and_then(Path::file_name)
            .map(|n| n.to_os_string())
            .unwrap_or_default();
        let dir = self.dir.join(aside).join(case);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let name = f
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        let mut dest = dir.join(&name);
        let mut k = 2;
        while std::fs::symlink_metadata(&dest).is_ok() {
            dest = dir.join(format!("{name}-{k}"));
            k += 1;
        }
        std::fs::rename(f, &dest).map_err(|e| Error::io(f, e))?;
        Ok(dest)
    }

    /// Whether the result of `case_id` × `method` is stored.
    pub fn has(&self, case_id: &str, method: &str) -> bool {
        self.result_path(case_id, method).is_file()
    }

    /// Stores a result (never overwriting one). Returns false if it existed.
    pub fn put(&self, r: &CaseResult) -> Result<bool> {
        let bytes =
            serde_json::to_vec(r).map_err(|e| Error::invalid(format!("result to JSON: {e}")))?;
        write_file(&self.result_path(&r.case_id, &r.method), &bytes, false)
    }

    pub fn get(&self, case_id: &str, method: &str) -> Result<CaseResult> {
        let path = self.result_path(case_id, method);
        let text = super::files::read_regular(&path)?;
        serde_json::from_str(&text).map_err(|e| Error::parse(&path, "JSON", e.to_string()))
    }

    /// Every stored result, sorted by (case index, method order).
    pub fn all(&self, method_order: &[String]) -> Result<Vec<CaseResult>> {
        let mut out = Vec::new();
        let root = self.dir.join("cases");
        let Ok(rd) = std::fs::read_dir(&root) else {
            return Ok(out);
        };
        // Real folders only (a link planted in `cases/` is not followed).
        let mut dirs: Vec<PathBuf> = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| std::fs::symlink_metadata(p).is_ok_and(|m| m.is_dir()))
            .collect();
        dirs.sort();
        for d in dirs {
            let rd = std::fs::read_dir(&d).map_err(|e| Error::io(&d, e))?;
            let mut files: Vec<PathBuf> = rd
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.extension().is_some_and(|x| x == "json")
                        && !p
                            .file_name()
                            .is_some_and(|n| n.to_string_lossy().starts_with('.'))
                })
                .collect();
            files.sort();
            for f in files {
                let text = super::files::read_regular(&f)?;
                let r: CaseResult = match serde_json::from_str(&text) {
                    Ok(r) => r,
                    Err(e) => {
                        // Truncated or corrupt (a crash of another tool, a
                        // full disk): moved aside and computed again.
                        let to = self.set_aside(&f, "corrupt")?;
                        eprintln!(
                            "warning: {}: not a result ({e}); moved to {} and computed again",
                            f.display(),
                            to.display()
                        );
                        continue;
                    }
                };
                // Only the file a result is stored as counts (a copy under
                // another name would be a second row).
                if self.result_path(&r.case_id, &r.method) != f {
                    eprintln!(
                        "warning: {}: a result of case {} × method {} under another name                          (not {}); not counted",
                        f.display(),
                        r.case_id,
                        r.method,
                        self.result_path(&r.case_id, &r.method).display()
                    );
                    continue;
                }
                out.push(r);
            }
        }
        let pos = |m: &str| {
            method_order
                .iter()
                .position(|x| x == m)
                .unwrap_or(usize::MAX)
        };
        out.sort_by(|a, b| {
            (a.case, pos(&a.method), &a.method).cmp(&(b.case, pos(&b.method), &b.method))
        });
        Ok(out)
    }

    /// Rebuilds cases.csv, curves.csv and summary.csv from the stored
    /// results, and their timings (the only values that differ between two
    /// runs of one config) apart: timings/cases.csv and timings/summary.csv
    /// ([`TIMINGS_DIR`]).
    pub fn write_tables(&self, results: &[CaseResult]) -> Result<()> {
        write_file(&self.dir.join("cases.csv"), &cases_csv(results)?, true)?;
        write_file(&self.dir.join("curves.csv"), &curves_csv(results)?, true)?;
        write_file(&self.dir.join("summary.csv"), &summary_csv(results)?, true)?;
        let timings = own_subdir(&self.dir, TIMINGS_DIR)?;
        write_file(&timings.join("cases.csv"), &timings_csv(results)?, true)?;
        write_file(
            &timings.join("summary.csv"),
            &timings_summary_csv(results)?,
            true,
        )?;
        Ok(())
    }
}

/// The names of the methods `new` adds to `old` when that is their only
/// difference: every method of `old` is in `new`, unchanged and in the same
/// order, and every other key is the same.
fn added_methods(old: &serde_json::Value, new: &serde_json::Value) -> Option<Vec<String>> {
    let methods = |v: &serde_json::Value| v.get("methods").and_then(|m| m.as_array()).cloned();
    let (a, b) = (methods(old)?, methods(new)?);
    let rest = |v: &serde_json::Value| {
        let mut v = without_data_paths(v);
        if let Some(o) = v.as_object_mut() {
            o.remove("methods");
        }
        v
    };
    if a.len() >= b.len() || rest(old) != rest(new) {
        return None;
    }
    let mut i = 0;
    let mut added = Vec::new();
    for m in &b {
        if i < a.len() && a[i] == *m {
            i += 1;
        } else {
            added.push(m.get("name")?.as_str()?.to_string());
        }
    }
    (i == a.len()).then_some(added)
}

/// The name of every element of an array of named objects.
fn names_of(v: &[serde_json::Value]) -> Option<Vec<&str>> {
    v.iter().map(|x| x.get("name")?.as_str()).collect()
}

pub(crate) fn json_diff(
    prefix: &str,
    a: &serde_json::Value,
    b: &serde_json::Value,
    out: &mut Vec<String>,
) {
    use serde_json::Value;
    if let (Value::Array(x), Value::Array(y)) = (a, b) {
        if let (Some(nx), Some(ny)) = (names_of(x), names_of(y)) {
            if nx != ny {
                // Named entries (methods): by name.
                for (n, u) in nx.iter().zip(x) {
                    match ny.iter().position(|m| m == n) {
                        Some(j) => json_diff(&format!("{prefix}.{n}"), u, &y[j], out),
                        None => out.push(format!("{prefix}.{n} (only there)")),
                    }
                }
                for n in ny.iter().filter(|n| !nx.contains(n)) {
                    out.push(format!("{prefix}.{n} (only now)"));
                }
                return;
            }
        }
    }
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => json_diff(&p, u, v, out),
                    _ => out.push(p),
                }
            }
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                json_diff(&format!("{prefix}[{i}]"), u, v, out);
            }
        }
        _ if a != b => out.push(if prefix.is_empty() {
            "(root)".to_string()
        } else {
            prefix.to_string()
        }),
        _ => {}
    }
}

fn csv_err(e: impl std::fmt::Display) -> Error {
    Error::invalid(format!("CSV: {e}"))
}

fn finish(w: csv::Writer<Vec<u8>>) -> Result<Vec<u8>> {
    w.into_inner().map_err(csv_err)
}

/// The columns of `cases.csv` for `results`: those of [`CASE_COLUMNS`]
/// (in its order) that hold a value in at least one result; all of them
/// when there is no result.
pub fn case_columns(results: &[CaseResult]) -> Vec<&'static str> {
    if results.is_empty() {
        return CASE_COLUMNS.to_vec();
    }
    CASE_COLUMNS
        .iter()
        .copied()
        .filter(|c| {
            results
                .iter()
                .any(|r| r.cells.get(*c).is_some_and(|v| !v.is_empty()))
        })
        .collect()
}

/// `cases.csv` bytes: one row per result, the columns of [`case_columns`]
/// (no column is empty in every row). Readers find columns by name: an
/// absent column is an empty cell in every row, so tables of older runs
/// (every column) and of runs with other methods read alike.
pub fn cases_csv(results: &[CaseResult]) -> Result<Vec<u8>> {
    let columns: Vec<&str> = case_columns(results)
        .into_iter()
        .filter(|c| !is_timing(c))
        .collect();
    table_csv(results, &columns)
}

/// `timings/cases.csv` bytes: the [`ID_COLUMNS`] and the timing columns
/// ([`is_timing`]) of [`case_columns`], one row per result.
pub fn timings_csv(results: &[CaseResult]) -> Result<Vec<u8>> {
    let columns: Vec<&str> = case_columns(results)
        .into_iter()
        .filter(|c| ID_COLUMNS.contains(c) || is_timing(c))
        .collect();
    table_csv(results, &columns)
}

/// The folder of a results folder that holds its volatile files: timings
/// per case and summarised, the log of invocations (when, how long, which
/// revision) and the figures that show timings. Everything else a run
/// writes is the same, byte for byte, when the run is repeated.
pub const TIMINGS_DIR: &str = "timings";

/// `dir/name`, made if missing; a symbolic link or a file there is
/// refused (a link planted in a results folder would send the tables
/// elsewhere).
pub fn own_subdir(dir: &Path, name: &str) -> Result<PathBuf> {
    let sub = dir.join(name);
    match std::fs::symlink_metadata(&sub) {
        Ok(m) if m.is_dir() => Ok(sub),
        Ok(_) => Err(Error::parse(
            &sub,
            "results folder",
            "is not a folder (a file or a symbolic link); the run writes its own folder here \
             and follows no link",
        )),
        Err(_) => {
            std::fs::create_dir_all(&sub).map_err(|e| Error::io(&sub, e))?;
            Ok(sub)
        }
    }
}

fn table_csv(results: &[CaseResult], columns: &[&str]) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(columns).map_err(csv_err)?;
    for r in results {
        w.write_record(
            columns
                .iter()
                .map(|c| r.cells.get(*c).map_or("", String::as_str)),
        )
        .map_err(csv_err)?;
    }
    finish(w)
}

/// `curves.csv` bytes: `case,case_id,method,curve,x,y`.
pub fn curves_csv(results: &[CaseResult]) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(["case", "case_id", "method", "curve", "x", "y"])
        .map_err(csv_err)?;
    for r in results {
        for c in &r.curves {
            for (x, y) in c.x.iter().zip(&c.y) {
                w.write_record([
                    r.case.to_string().as_str(),
                    &r.case_id,
                    &r.method,
                    &c.name,
                    x,
                    y,
                ])
                .map_err(csv_err)?;
            }
        }
    }
    finish(w)
}

/// Numeric columns summarised in summary.csv.
pub fn summary_columns() -> impl Iterator<Item = &'static str> {
    CASE_COLUMNS.iter().copied().filter(|c| {
        !matches!(
            *c,
            "case"
                | "case_id"
                | "source"
                | "target"
                | "reference_pose"
                | "poses"
                | "method"
                | "group"
                | "kind"
                | "status"
                | "keypoints"
                | "procrustes"
        )
    })
}

/// Mean, std (population), min, median, max of values (in order).
pub fn describe(v: &[f64]) -> (f64, f64, f64, f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let k = s.len();
    let median = if k % 2 == 1 {
        s[k / 2]
    } else {
        0.5 * (s[k / 2 - 1] + s[k / 2])
    };
    (mean, var.sqrt(), s[0], median, s[k - 1])
}

/// `summary.csv` bytes: per method (in order of first appearance) and numeric
/// column, statistics over the cases where the cell is a number.
pub fn summary_csv(results: &[CaseResult]) -> Result<Vec<u8>> {
    summary_of(results, |c| !is_timing(c))
}

/// `timings/summary.csv` bytes: [`summary_csv`] of the timing columns.
pub fn timings_summary_csv(results: &[CaseResult]) -> Result<Vec<u8>> {
    summary_of(results, is_timing)
}

fn summary_of(results: &[CaseResult], keep: impl Fn(&str) -> bool) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "method", "group", "metric", "n", "n_failed", "mean", "std", "min", "median", "max",
    ])
    .map_err(csv_err)?;
    let mut methods: Vec<(String, String)> = Vec::new();
    for r in results {
        let g = r.cells.get("group").cloned().unwrap_or_default();
        if !methods.iter().any(|(m, _)| *m == r.method) {
            methods.push((r.method.clone(), g));
        }
    }
    for (m, g) in &methods {
        let rows: Vec<&CaseResult> = results.iter().filter(|r| r.method == *m).collect();
        let failed = rows
            .iter()
            .filter(|r| r.cells.get("status").is_some_and(|s| s != "ok"))
            .count();
        for col in summary_columns().filter(|c| keep(c)) {
            let v: Vec<f64> = rows
                .iter()
                .filter_map(|r| r.cells.get(col).and_then(|s| s.parse::<f64>().ok()))
                .filter(|x| x.is_finite())
                .collect();
            if v.is_empty() {
                continue;
            }
            let (mean, std, min, median, max) = describe(&v);
            let cell = |x: f64| {
                if is_timing(col) {
                    secs(x)
                } else {
                    num(x)
                }
            };
            w.write_record([
                m.as_str(),
                g.as_str(),
                col,
                &v.len().to_string(),
                &failed.to_string(),
                &cell(mean),
                &cell(std),
                &cell(min),
                &cell(median),
                &cell(max),
            ])
            .map_err(csv_err)?;
        }
    }
    finish(w)
}

/// The git revision of the checkout at or above `start`, read from `.git`
/// without running git (handles worktrees, packed refs); "unknown" if none.
pub fn git_revision(start: &Path) -> String {
    fn read(p: &Path) -> Option<String> {
        std::fs::read_to_string(p)
            .ok()
            .map(|s| s.trim().to_string())
    }
    let mut dir = Some(start);
    while let Some(d) = dir {
        let dotgit = d.join(".git");
        let git_dir = if dotgit.is_dir() {
            Some(dotgit)
        } else if dotgit.is_file() {
            read(&dotgit)
                .and_then(|s| s.strip_prefix("gitdir:").map(|x| x.trim().to_string()))
                .map(|g| {
                    let p = PathBuf::from(g);
                    if p.is_absolute() {
                        p
                    } else {
                        d.join(p)
                    }
                })
        } else {
            None
        };
        if let Some(g) = git_dir {
            let common = read(&g.join("commondir"))
                .map(|c| {
                    let p = PathBuf::from(c);
                    if p.is_absolute() {
                        p
                    } else {
                        g.join(p)
                    }
                })
                .unwrap_or_else(|| g.clone());
            let Some(head) = read(&g.join("HEAD")) else {
                return "unknown".into();
            };
            let Some(r) = head.strip_prefix("ref:").map(str::trim) else {
                return head;
            };
            for base in [&g, &common] {
                if let Some(h) = read(&base.join(r)) {
                    return h;
                }
            }
            if let Some(packed) = read(&common.join("packed-refs")) {
                for line in packed.lines() {
                    if let Some((h, name)) = line.split_once(' ') {
                        if name == r {
                            return h.to_string();
                        }
                    }
                }
            }
            return "unknown".into();
        }
        dir = d.parent();
    }
    "unknown".into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_id_columns_come_first() {
        assert_eq!(&CASE_COLUMNS[..ID_COLUMNS.len()], ID_COLUMNS);
    }

    #[test]
    fn numbers_are_stable_text() {
        assert_eq!(num(0.1 + 0.2), "0.3");
        assert_eq!(num(1.0), "1");
        assert_eq!(num(f64::NAN), "");
        assert_eq!(num(0.07389238479234), "0.07389238479");
    }

    #[test]
    fn no_clobber_writes() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a/b.json");
        assert!(write_file(&p, b"one", false).unwrap());
        assert!(!write_file(&p, b"two", false).unwrap());
        assert_eq!(std::fs::read(&p).unwrap(), b"one");
        assert!(write_file(&p, b"three", true).unwrap());
        assert_eq!(std::fs::read(&p).unwrap(), b"three");
        // No temporaries left behind.
        assert_eq!(remove_stale_temporaries(d.path()).unwrap(), 0);
        assert_eq!(std::fs::read_dir(d.path().join("a")).unwrap().count(), 1);
    }

    #[test]
    fn only_other_processes_temporaries_are_removed() {
        let d = tempfile::tempdir().unwrap();
        let sub = d.path().join("cases/c0");
        std::fs::create_dir_all(&sub).unwrap();
        let own = temp::temp_path(&sub.join("m.json"), None);
        for p in [
            own.clone(),
            sub.join(".m.json.4242-0badcafe.0.tmp"),
            d.path().join("meshes_result_6.ply.tmp"),
            d.path().join(".fig.png.1-ab.0.tmp.png"),
            sub.join("m.json"),
            d.path().join(".lock"),
        ] {
            std::fs::write(&p, b"x").unwrap();
        }
        assert_eq!(remove_stale_temporaries(d.path()).unwrap(), 3);
        assert!(own.exists() && sub.join("m.json").exists() && d.path().join(".lock").exists());
    }

    #[test]
    fn git_revision_of_this_checkout_is_a_hash_or_unknown() {
        let r = git_revision(Path::new(env!("CARGO_MANIFEST_DIR")));
        assert!(
            r == "unknown" || (r.len() == 40 && r.bytes().all(|b| b.is_ascii_hexdigit())),
            "{r}"
        );
    }
}

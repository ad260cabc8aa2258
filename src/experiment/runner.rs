//! The suite runner: `deformlab run CONFIG... [--out ROOT] [--threads K]
//! [--shard i/N]`.
//!
//! For every config: open the dataset, generate the cases, bind the folder
//! `ROOT/<name>` to the config hash ([`Store::bind`]), save the render
//! meshes, then run every unfinished case × method of this shard on a local
//! rayon pool of K threads (nested parallelism of key point selection runs
//! on the same pool). Each finished case × method is stored at once
//! (atomically); tables are rebuilt from the store at the end, in case
//! order, so results do not depend on K or on interruptions. A failing
//! method on a case is a result too (status `failed: …`).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use rayon::prelude::*;

use super::cases::{generate_cases, Case};
use super::config::{load_config, LoadedConfig, NamedMethod};
use super::dataset::Collection;
use super::manifest::{read_manifest, write_manifest, Invocation, Manifest, Shard};
use super::record::run_method;
use super::store::{secs, CaseResult, MeshOut, RenderOut, Store, StoredConfig};
use crate::{Error, Result};

/// Options of [`run_configs`].
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Results root: experiment `name` goes to `out/name`.
    pub out: PathBuf,
    /// Threads of the local pool (≥ 1; capped to
    /// [`crate::solve::max_threads`]).
    pub threads: usize,
    pub shard: Option<Shard>,
    /// Make the plots at the end (failures are warnings).
    pub plots: bool,
    /// Progress bar / log lines on stderr.
    pub progress: bool,
    /// Stop after this many newly finished case × method results (tests).
    pub max_new: Option<usize>,
}

/// What a run of one config did.
#[derive(Clone, Debug)]
pub struct RunSummary {
    pub name: String,
    pub dir: PathBuf,
    pub computed: usize,
    pub reused: usize,
    pub failed: usize,
    pub wall_seconds: f64,
    pub complete: bool,
}

fn unix_now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// Runs every config in turn (see the module documentation).
pub fn run_configs(configs: &[PathBuf], opts: &RunOptions) -> Result<Vec<RunSummary>> {
    let loaded = configs
        .iter()
        .map(|c| load_config(c))
        .collect::<Result<Vec<_>>>()?;
    let mut names = std::collections::HashSet::new();
    for l in &loaded {
        if !names.insert(l.config.name.clone()) {
            return Err(Error::parse(
                &l.path,
                "key `name`",
                format!(
                    "another config of this run is also named {:?}",
                    l.config.name
                ),
            ));
        }
    }
    let mut out = Vec::new();
    for l in &loaded {
        out.push(run_one(l, opts)?);
    }
    Ok(out)
}

/// Saves the meshes a render needs: A, A′ (first poses), B, truths, labels.
fn save_render_base(col: &Collection, case: &Case, out: &MeshOut, poses: usize) -> Result<()> {
    let dir = &out.dir;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let save = |stem: String, s: &str, p: &str| -> Result<()> {
        if MeshOut::find(dir, &stem).is_some() {
            return Ok(());
        }
        out.save(&stem, &*col.mesh(s, p)?, None)
    };
    save("source".into(), &case.source, &case.reference)?;
    save("target".into(), &case.target, &case.reference)?;
    for (p, &has) in case.poses.iter().zip(&case.truth).take(poses) {
        save(format!("deformed_{p}"), &case.source, p)?;
        if has {
            save(format!("truth_{p}"), &case.target, p)?;
        }
    }
    if let Some(labels) = &col.labels {
        let path = dir.join("labels.csv");
        if !path.exists() {
            let mut s = String::from("vertex,label\n");
            for (i, l) in labels.iter().enumerate() {
                s.push_str(&format!("{i},{l}\n"));
            }
            super::store::write_file(&path, s.as_bytes(), false)?;
        }
    }
    Ok(())
}

enum Progress {
    Bar(indicatif::ProgressBar),
    Log { total: usize, start: Instant },
    Quiet,
}

impl Progress {
    fn new(total: usize, name: &str, enabled: bool) -> Self {
        if !enabled {
            return Progress::Quiet;
        }
        if std::io::stderr().is_terminal() {
            let bar = indicatif::ProgressBar::new(total as u64);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{prefix} [{bar:30}] {pos}/{len} {wide_msg} elapsed {elapsed} ETA {eta}",
            ) {
                bar.set_style(style.progress_chars("=> "));
            }
            bar.set_prefix(name.to_string());
            Progress::Bar(bar)
        } else {
            Progress::Log {
                total,
                start: Instant::now(),
            }
        }
    }

    fn tick(&self, done: usize, line: &str) {
        match self {
            Progress::Bar(b) => {
                b.set_message(line.to_string());
                b.set_position(done as u64);
            }
            Progress::Log { total, start } => {
                let el = start.elapsed().as_secs_f64();
                let eta = if done > 0 {
                    el / done as f64 * (total - done) as f64
                } else {
                    0.0
                };
                eprintln!("[{done}/{total}] {line} (elapsed {el:.1} s, ETA {eta:.0} s)");
            }
            Progress::Quiet => {}
        }
    }

    fn finish(&self) {
        if let Progress::Bar(b) = self {
            let (n, el) = (b.position(), b.elapsed().as_secs_f64());
            b.finish_and_clear();
            eprintln!("{}: {n} case × method results in {el:.1} s", b.prefix());
        }
    }
}

fn run_one(l: &LoadedConfig, opts: &RunOptions) -> Result<RunSummary> {
    let t0 = Instant::now();
    let started = unix_now();
    let name = &l.config.name;
    let dir = opts.out.join(name);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let store = Store::new(&dir);
    super::store::remove_temporaries(&dir)?;
    let hash = l.config.hash();
    let stored = StoredConfig {
        hash: hash.clone(),
        config: serde_json::to_value(l.config.hashed_part())
            .map_err(|e| Error::invalid(format!("config to JSON: {e}")))?,
    };
    store.bind(&stored)?;

    let col = Collection::open(l)?;
    let cases = generate_cases(l, &col)?;
    let mine: Vec<&Case> = cases
        .iter()
        .filter(|c| opts.shard.is_none_or(|s| s.contains(c.index)))
        .collect();
    // Values the data make impossible: one error before any case runs.
    super::feasible::check_against_data(l, &col, &mine)?;
    let render_cases = l.config.outputs.render_cases();
    let render_poses = l.config.outputs.render_poses();
    let mesh_format = l.config.outputs.mesh_format().format();
    for c in mine.iter().filter(|c| c.index < render_cases) {
        let out = MeshOut {
            dir: store.mesh_dir(&c.id),
            format: mesh_format,
        };
        save_render_base(&col, c, &out, render_poses)?;
    }

    let mut work: Vec<(&Case, &NamedMethod)> = Vec::new();
    let mut reused = 0;
    for c in &mine {
        for m in &l.methods {
            if store.has(&c.id, &m.name) {
                reused += 1;
            } else {
                work.push((c, m));
            }
        }
    }
    if let Some(k) = opts.max_new {
        work.truncate(k);
    }
    if opts.progress {
        eprintln!(
            "{name}: {} cases ({} in this shard) × {} methods; {} stored, {} to run on {} thread(s) → {}",
            cases.len(),
            mine.len(),
            l.methods.len(),
            reused,
            work.len(),
            opts.threads,
            dir.display()
        );
    }
    let progress = Progress::new(work.len(), name, opts.progress);
    let done = AtomicUsize::new(0);
    let first_error: Mutex<Option<Error>> = Mutex::new(None);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(crate::solve::cap_threads(opts.threads))
        .build()
        .map_err(|e| Error::invalid(format!("thread pool: {e}")))?;
    let metrics = &l.config.metrics;
    pool.install(|| {
        work.par_iter().for_each(|(case, m)| {
            if first_error.lock().map(|e| e.is_some()).unwrap_or(true) {
                return;
            }
            let t = Instant::now();
            let mut r = CaseResult {
                case: case.index,
                case_id: case.id.clone(),
                method: m.name.clone(),
                ..Default::default()
            };
            r.set("case", case.index.to_string());
            r.set("case_id", case.id.clone());
            r.set("source", case.source.clone());
            r.set("target", case.target.clone());
            r.set("reference_pose", case.reference.clone());
            r.set("poses", case.poses.join(";"));
            r.set("method", m.name.clone());
            r.set("group", m.group.clone());
            r.set("kind", m.method.kind_name());
            let mdir = store.mesh_dir(&case.id);
            // Renders show one method per group: save only its meshes.
            let first_of_group = l
                .methods
                .iter()
                .find(|x| x.group == m.group)
                .is_some_and(|x| x.name == m.name);
            let render = (case.index < render_cases && first_of_group).then(|| RenderOut {
                dir: &mdir,
                poses: render_poses,
                format: mesh_format,
            });
            let status = match run_method(&col, case, m, metrics, render.as_ref(), &mut r) {
                Ok(()) => "ok".to_string(),
                Err(e) => {
                    // Keep the identification cells, drop partial numbers.
                    let keep = [
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
                    r.cells.retain(|k, _| keep.contains(&k.as_str()));
                    r.curves.clear();
                    r.set("seconds_total", secs(t.elapsed().as_secs_f64()));
                    format!("failed: {e}").replace(['\n', '\r'], " ")
                }
            };
            r.set("status", status.clone());
            if let Err(e) = store.put(&r) {
                if let Ok(mut slot) = first_error.lock() {
                    slot.get_or_insert(e);
                }
                return;
            }
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress.tick(
                k,
                &format!(
                    "case {} {} × {}: {} ({:.2} s)",
                    case.index,
                    case.id,
                    m.name,
                    if status == "ok" { "ok" } else { &status },
                    t.elapsed().as_secs_f64()
                ),
            );
        });
    });
    progress.finish();
    if let Some(e) = first_error.into_inner().ok().flatten() {
        return Err(e);
    }
    let computed = done.load(Ordering::Relaxed);

    let order: Vec<String> = l.methods.iter().map(|m| m.name.clone()).collect();
    let results = store.all(&order)?;
    store.write_tables(&results)?;
    let failed = results
        .iter()
        .filter(|r| r.cells.get("status").is_some_and(|s| s != "ok"))
        .count();
    let expected: usize = mine.len() * l.methods.len();
    let have_mine = results
        .iter()
        .filter(|r| opts.shard.is_none_or(|s| s.contains(r.case)))
        .count();
    let complete = have_mine >= expected;

    let git = super::store::git_revision(&std::env::current_dir().unwrap_or_default());
    let prev: Option<Manifest> = std::fs::read_to_string(dir.join("manifest.json"))
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok());
    let mut invocations = prev
        .as_ref()
        .map(|p| p.invocations.clone())
        .unwrap_or_default();
    invocations.push(Invocation {
        started_unix: started,
        wall_seconds: t0.elapsed().as_secs_f64(),
        threads: opts.threads,
        shard: opts.shard,
        crate_version: env!("CARGO_PKG_VERSION").to_string(),
        git_revision: git.clone(),
        computed,
        reused,
        repairs: col.repairs().iter().map(|r| r.to_string()).collect(),
    });
    let shards = match opts.shard {
        None => None,
        Some(s) => {
            let mut v = prev.and_then(|p| p.shards).unwrap_or_default();
            if !v.contains(&s) {
                v.push(s);
            }
            Some(v)
        }
    };
    let manifest = Manifest {
        name: name.clone(),
        config_file: l.path.display().to_string(),
        config_hash: hash,
        config: serde_json::to_value(&l.config)
            .map_err(|e| Error::invalid(format!("config to JSON: {e}")))?,
        seed: l.config.seed,
        crate_version: env!("CARGO_PKG_VERSION").to_string(),
        git_revision: git,
        dataset: col.description.clone(),
        n_cases: cases.len(),
        cases: cases.clone(),
        methods: order.clone(),
        shards,
        results_stored: results.len(),
        results_failed: failed,
        method_seconds: method_seconds(&results, &order),
        invocations,
    };
    write_manifest(&dir, &manifest)?;
    if opts.plots && complete {
        for w in super::plots::make_plots(&dir)? {
            eprintln!("warning: {w}");
        }
    }
    let summary = RunSummary {
        name: name.clone(),
        dir,
        computed,
        reused,
        failed,
        wall_seconds: t0.elapsed().as_secs_f64(),
        complete,
    };
    Ok(summary)
}

/// Sum of `seconds_total` per method.
pub fn method_seconds(results: &[CaseResult], order: &[String]) -> Vec<(String, f64)> {
    order
        .iter()
        .map(|m| {
            let s: f64 = results
                .iter()
                .filter(|r| r.method == *m)
                .filter_map(|r| r.cells.get("seconds_total")?.parse::<f64>().ok())
                .sum();
            (m.clone(), s)
        })
        .collect()
}

/// `deformlab merge DIR... --out DIR`: copies the stored results and render
/// meshes of shard folders of one config into `out` (never overwriting a
/// stored result; a result stored in two inputs must be identical apart
/// from timing cells), then rebuilds the tables, the manifest and the plots.
/// Errors if the folders hold different configs.
pub fn merge(inputs: &[PathBuf], out: &Path, plots: bool) -> Result<RunSummary> {
    let t0 = Instant::now();
    if inputs.is_empty() {
        return Err(Error::invalid("merge needs at least one results folder"));
    }
    let manifests = inputs
        .iter()
        .map(|d| read_manifest(d))
        .collect::<Result<Vec<_>>>()?;
    let first = &manifests[0];
    for (d, m) in inputs.iter().zip(&manifests).skip(1) {
        if m.config_hash != first.config_hash {
            return Err(Error::invalid(format!(
                "{} holds config hash {} but {} holds {}: cannot merge results of different configs",
                d.display(),
                m.config_hash,
                inputs[0].display(),
                first.config_hash
            )));
        }
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let store = Store::new(out);
    let stored = Store::new(&inputs[0]).read_config()?;
    store.bind(&stored)?;
    let mut reused = 0;
    let mut computed = 0;
    for d in inputs {
        let src = Store::new(d);
        for r in src.all(&first.methods)? {
            if store.has(&r.case_id, &r.method) {
                let have = store.get(&r.case_id, &r.method)?;
                if strip_timing(&have) != strip_timing(&r) {
                    return Err(Error::invalid(format!(
                        "case {} × {}: {} and {} hold different results",
                        r.case_id,
                        r.method,
                        out.display(),
                        d.display()
                    )));
                }
                reused += 1;
            } else {
                store.put(&r)?;
                computed += 1;
            }
        }
        copy_tree(&d.join("meshes"), &out.join("meshes"))?;
    }
    let results = store.all(&first.methods)?;
    store.write_tables(&results)?;
    let failed = results
        .iter()
        .filter(|r| r.cells.get("status").is_some_and(|s| s != "ok"))
        .count();
    let mut invocations: Vec<Invocation> = Vec::new();
    for m in &manifests {
        invocations.extend(m.invocations.iter().cloned());
    }
    let manifest = Manifest {
        shards: None,
        results_stored: results.len(),
        results_failed: failed,
        method_seconds: method_seconds(&results, &first.methods),
        invocations,
        ..first.clone()
    };
    write_manifest(out, &manifest)?;
    let complete = results.len() >= first.n_cases * first.methods.len();
    if plots && complete {
        for w in super::plots::make_plots(out)? {
            eprintln!("warning: {w}");
        }
    }
    Ok(RunSummary {
        name: first.name.clone(),
        dir: out.to_path_buf(),
        computed,
        reused,
        failed,
        wall_seconds: t0.elapsed().as_secs_f64(),
        complete,
    })
}

fn strip_timing(r: &CaseResult) -> CaseResult {
    let mut r = r.clone();
    r.cells.retain(|k, _| !super::store::is_timing(k));
    r
}

/// Copies files of `from` into `to` recursively, keeping existing files.
fn copy_tree(from: &Path, to: &Path) -> Result<()> {
    let Ok(rd) = std::fs::read_dir(from) else {
        return Ok(());
    };
    std::fs::create_dir_all(to).map_err(|e| Error::io(to, e))?;
    for e in rd {
        let e = e.map_err(|e| Error::io(from, e))?;
        let p = e.path();
        let q = to.join(e.file_name());
        if p.is_dir() {
            copy_tree(&p, &q)?;
        } else if !q.exists() && !e.file_name().to_string_lossy().ends_with(".tmp") {
            let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
            super::store::write_file(&q, &bytes, false)?;
        }
    }
    Ok(())
}

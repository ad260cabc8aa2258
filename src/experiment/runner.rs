//! The suite runner: `deformlab run CONFIG... [--out ROOT] [--threads K]
//! [--shard i/N]`.
//!
//! For every config: open the dataset, generate the cases, bind the folder
//! `ROOT/<name>` to the config hash ([`Store::bind`]), save the render
//! meshes, then run every unfinished case × method of this shard. All
//! configs of a run share one rayon pool of K threads and run side by side
//! on it (the rows of every config, and the nested parallelism of key point
//! selection, are tasks of the same pool): a thread that finds no more rows
//! of one experiment, or waits on a sequential step of one, works on
//! another's, so no thread idles while any row is left (measured on the
//! default suite, 2 threads: see `results/bench/README.md`). An
//! experiment's wall time therefore includes time it shared the threads
//! with the others. Each finished case × method is stored at once
//! (atomically); tables are rebuilt from the store at the end, in case
//! order, so results do not depend on K or on interruptions. A failing
//! method on a case is a result too (status `failed: …`).
//!
//! One writer per folder ([`super::lock`]): a run holds the experiment
//! folder exclusively (shards: shared, and their own shard exclusively), so
//! a second run of the config waits for the first (or, with `--no-wait`,
//! stops with an error naming it) and then finds every result stored.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use rayon::prelude::*;

use super::cases::{generate_cases, Case};
use super::config::{LoadedConfig, NamedMethod};
use super::dataset::Collection;
use super::fingerprint::{fingerprint, Cache};
use super::load::{load_config_with, LoadOptions};
use super::lock::FolderLock;
use super::manifest::{read_manifest, write_manifest, DefectNote, Invocation, Manifest, Shard};
use super::record::run_method;
use super::store::{
    secs, store_key, BindOptions, Bound, CaseResult, MeshOut, RenderOut, Store, StoredConfig,
    ID_COLUMNS,
};
use crate::mesh::io::temp;
use crate::mesh::repair::DefectPolicy;
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
    /// Wait for another process that uses an experiment folder (after a
    /// message naming it); `false`: an error naming it (`--no-wait`).
    pub wait: bool,
    /// Command-line `--strict` / `--repair`: each one that is on overrides
    /// the configs' `[dataset] strict` / `repair` (and, for `repair`, the
    /// config hash, as the key would).
    pub defects: DefectPolicy,
    /// How the configs are read: data root, `--set`, `--sweep`.
    pub load: LoadOptions,
    /// `--force`: a folder holding results of another key (config or data)
    /// is moved aside ([`Store::bind`]) instead of refused.
    pub force: bool,
    /// `--retry-failed`: stored failed results of this run's cases are
    /// moved to `failed/` and computed again.
    pub retry_failed: bool,
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

/// Runs every config, side by side on one pool (see the module
/// documentation). Summaries come in config order; on errors, the first
/// (in config order) is returned after every config has run or stopped.
pub fn run_configs(configs: &[PathBuf], opts: &RunOptions) -> Result<Vec<RunSummary>> {
    let mut loaded = configs
        .iter()
        .map(|c| load_config_with(c, &opts.load))
        .collect::<Result<Vec<_>>>()?;
    for l in &mut loaded {
        if opts.defects.strict {
            l.config.dataset.strict = Some(true);
        }
        if opts.defects.repair {
            l.config.dataset.repair = Some(true);
        }
    }
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
    // Under an address-space limit: as many workers as fit (or stop now,
    // naming the limit) rather than an abort in a worker's first product.
    let (threads, warning) =
        crate::solve::address::fit_threads(crate::solve::cap_threads(opts.threads))?;
    if let Some(w) = warning {
        eprintln!("warning: {w}");
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::invalid(format!("thread pool: {e}")))?;
    let bars = Bars::new(opts.progress);
    let done: Vec<Result<RunSummary>> = pool.install(|| {
        loaded
            .par_iter()
            .with_max_len(1)
            .map(|l| run_one(l, opts, &bars))
            .collect()
    });
    done.into_iter().collect()
}

/// The progress display of a run: one bar per running experiment on a
/// terminal (long steps inside a row write into the bar of the experiment
/// whose row the thread is running), log lines otherwise, or nothing.
struct Bars {
    multi: Option<indicatif::MultiProgress>,
    enabled: bool,
    _sink: Option<crate::solve::progress::SinkGuard>,
}

thread_local! {
    /// The bar of the experiment whose row this thread is running.
    static ROW_BAR: std::cell::RefCell<Option<indicatif::ProgressBar>> =
        const { std::cell::RefCell::new(None) };
}

impl Bars {
    /// Prints a line on stderr above the bars (plainly without bars).
    fn say(&self, line: &str) {
        match &self.multi {
            Some(m) => m.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }

    fn new(enabled: bool) -> Self {
        if enabled && std::io::stderr().is_terminal() {
            let sink = crate::solve::progress::install(std::sync::Arc::new(StepSink));
            Bars {
                multi: Some(indicatif::MultiProgress::new()),
                enabled,
                _sink: Some(sink),
            }
        } else {
            Bars {
                multi: None,
                enabled,
                _sink: None,
            }
        }
    }
}

/// Runs `f` with `bar` as this thread's row bar (restored after: a thread
/// waiting inside one row may run a row of another experiment).
fn with_row_bar<T>(bar: Option<&indicatif::ProgressBar>, f: impl FnOnce() -> T) -> T {
    let previous = ROW_BAR.with(|b| b.replace(bar.cloned()));
    let out = f();
    ROW_BAR.with(|b| *b.borrow_mut() = previous);
    out
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

/// Serves every mesh that the cases with work left use, before any case
/// runs, so that the defect warnings come first and, in strict mode, a
/// refused mesh (or one that cannot be read) stops the run with one error
/// naming the file instead of failing case after case. Without strict mode
/// a mesh that cannot be read is left to the cases that use it (each fails
/// with the error, as a result).
fn serve_case_meshes(col: &Collection, cases: &[&Case], strict: bool) -> Result<()> {
    let mut seen = std::collections::BTreeSet::new();
    for c in cases {
        let mut want = vec![(&c.source, &c.reference), (&c.target, &c.reference)];
        for (p, &has) in c.poses.iter().zip(&c.truth) {
            want.push((&c.source, p));
            if has {
                want.push((&c.target, p));
            }
        }
        for (s, p) in want {
            if !seen.insert((s.clone(), p.clone())) {
                continue;
            }
            if let Err(e) = col.mesh(s, p) {
                if strict {
                    return Err(e);
                }
            }
        }
    }
    Ok(())
}

enum Progress {
    /// The case bar; long steps inside a case write their progress into its
    /// message ([`crate::solve::progress`], through [`StepSink`]).
    Bar {
        bar: indicatif::ProgressBar,
    },
    Log {
        name: String,
        total: usize,
        start: Instant,
        /// Rows done (read by the heartbeat's lines).
        done: std::sync::Arc<AtomicUsize>,
        /// A line at least every 30 s between rows (long rows, long steps).
        beat: crate::solve::progress::Heartbeat,
    },
    Quiet,
}

/// The time left after `done` of `total` rows in `elapsed` seconds, at the
/// mean pace of the rows so far: `?` before the first row, then seconds,
/// minutes or hours.
fn rows_eta(elapsed: f64, done: usize, total: usize) -> String {
    if done == 0 || !elapsed.is_finite() || elapsed < 0.0 {
        return "?".to_string();
    }
    let left = total.saturating_sub(done) as f64 * elapsed / done as f64;
    if left < 120.0 {
        format!("{left:.0} s")
    } else if left < 7200.0 {
        format!("{:.0} min", left / 60.0)
    } else {
        format!("{:.1} h", left / 3600.0)
    }
}

/// Long steps' progress shown in the message of the bar of the row the
/// reporting thread runs (a step's parallel parts run by a thread outside
/// any row are not shown).
struct StepSink;

impl crate::solve::progress::ProgressSink for StepSink {
    fn update(&self, step: &str, done: usize, total: usize) {
        ROW_BAR.with(|b| {
            if let Some(bar) = &*b.borrow() {
                // The row bar's other parts: the prefix, `[bar:30]`,
                // `pos/len` and ` elapsed 1h 23m 45s ETA 123 min`.
                let digits = bar.length().unwrap_or(0).max(1).ilog10() as usize + 1;
                let reserve = bar.prefix().chars().count() + 33 + 2 * digits + 1 + 34;
                let width = crate::solve::progress::terminal_columns().saturating_sub(reserve);
                bar.set_message(crate::solve::progress::fit_to_width(
                    &crate::solve::progress::step_message(step, done, total),
                    width,
                ));
            }
        });
    }
}

impl Progress {
    fn new(total: usize, name: &str, bars: &Bars) -> Self {
        if !bars.enabled {
            return Progress::Quiet;
        }
        if let Some(multi) = &bars.multi {
            let bar = multi.add(indicatif::ProgressBar::new(total as u64));
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{prefix} [{bar:30}] {pos}/{len} {wide_msg} elapsed {elapsed} ETA {rows_eta}",
            ) {
                // The ETA from the rows done so far (indicatif's own
                // estimate extrapolated the rate of a bar that had not
                // moved: 584942417355y on a long first row).
                let style = style.with_key(
                    "rows_eta",
                    |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                        let eta = rows_eta(
                            s.elapsed().as_secs_f64(),
                            s.pos() as usize,
                            s.len().unwrap_or(0) as usize,
                        );
                        let _ = w.write_str(&eta);
                    },
                );
                bar.set_style(style.progress_chars("=> "));
            }
            bar.set_prefix(name.to_string());
            Progress::Bar { bar }
        } else {
            let done = std::sync::Arc::new(AtomicUsize::new(0));
            let d = done.clone();
            let beat = crate::solve::progress::Heartbeat::start(name, move || {
                format!("{} of {total} rows done", d.load(Ordering::Relaxed))
            });
            Progress::Log {
                name: name.to_string(),
                total,
                start: Instant::now(),
                done,
                beat,
            }
        }
    }

    fn bar(&self) -> Option<&indicatif::ProgressBar> {
        match self {
            Progress::Bar { bar } => Some(bar),
            _ => None,
        }
    }

    fn tick(&self, done: usize, line: &str) {
        match self {
            Progress::Bar { bar: b, .. } => {
                b.set_message(line.to_string());
                b.set_position(done as u64);
            }
            Progress::Log {
                name,
                total,
                start,
                done: rows,
                beat,
            } => {
                rows.store(done, Ordering::Relaxed);
                let el = start.elapsed().as_secs_f64();
                let eta = rows_eta(el, done, *total);
                eprintln!("{name} [{done}/{total}] {line} (elapsed {el:.1} s, ETA {eta})");
                beat.wrote();
            }
            Progress::Quiet => {}
        }
    }

    fn finish(&self, bars: &Bars) {
        if let Progress::Bar { bar: b, .. } = self {
            let (n, el) = (b.position(), b.elapsed().as_secs_f64());
            b.finish_and_clear();
            if let Some(m) = &bars.multi {
                m.remove(b);
            }
            bars.say(&format!(
                "{}: {n} case × method results in {el:.1} s",
                b.prefix()
            ));
        }
    }
}

/// What `config.json` of a run of `l` holds: the key config (JSON), its
/// dataset paths spelled through the data root for the reader, and the
/// data fingerprint.
fn stored_config(l: &LoadedConfig, col: &Collection, dir: &Path) -> Result<(StoredConfig, Cache)> {
    let json = |c: &super::config::Config| {
        serde_json::to_value(c).map_err(|e| Error::invalid(format!("config to JSON: {e}")))
    };
    let key_json = serde_json::to_string(&l.config.key_part())
        .map_err(|e| Error::invalid(format!("config to JSON: {e}")))?;
    let mut cache = Cache::load(dir);
    let data = fingerprint(&col.input_files(), &l.data_root, &mut cache)?;
    let mut shown = l.config.hashed_part();
    let spell = |p: &mut PathBuf| {
        let full = l.resolve_path(p);
        if let Some(s) = l.data_root.spell(&full) {
            *p = PathBuf::from(s);
        } else if let Ok(c) = std::fs::canonicalize(&full) {
            *p = c;
        }
    };
    if let Some(f) = &mut shown.dataset.faust {
        spell(&mut f.path);
    }
    if let Some(f) = &mut shown.dataset.tosca {
        spell(&mut f.path);
    }
    if let Some(f) = &mut shown.dataset.manifest {
        spell(&mut f.path);
    }
    Ok((
        StoredConfig {
            hash: store_key(&key_json, data.as_ref()),
            config: json(&shown)?,
            data,
            adopted_from: None,
        },
        cache,
    ))
}

fn run_one(l: &LoadedConfig, opts: &RunOptions, bars: &Bars) -> Result<RunSummary> {
    let t0 = Instant::now();
    let started = unix_now();
    let name = &l.config.name;
    let dir = opts.out.join(name);
    let store = Store::new(&dir);

    // Everything that can refuse the config is checked before the folder
    // is made: a config that fails leaves nothing behind.
    let col = Collection::open(l)?;
    let cases = generate_cases(l, &col)?;
    super::cases::check_rows(l, cases.len())?;
    let mine: Vec<&Case> = cases
        .iter()
        .filter(|c| opts.shard.is_none_or(|s| s.contains(c.index)))
        .collect();
    let strict = l.config.dataset.policy().strict;
    let new_folder = !store.config_path().exists();
    if new_folder {
        // A new folder (every case to compute): values the data make
        // impossible and, in strict mode, refused meshes stop the run
        // before the folder exists.
        super::feasible::check_against_data(l, &col, &mine)?;
        serve_case_meshes(&col, &mine, strict)?;
    }
    let (stored, cache) = stored_config(l, &col, &dir)?;

    if opts.force && opts.shard.is_some() {
        // Moving another key's results aside needs the folder alone.
        let _alone = FolderLock::exclusive_or_stop(&dir, "run --force", opts.wait)?;
        report_bound(
            &dir,
            store.bind(
                &stored,
                BindOptions {
                    force: true,
                    alone: true,
                },
            )?,
        );
    }
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let lock = FolderLock::for_run(&dir, opts.shard, opts.wait)?;
    let bound = store.bind(
        &stored,
        BindOptions {
            force: opts.force,
            alone: opts.shard.is_none(),
        },
    )?;
    report_bound(&dir, bound);
    cache.save(&dir)?;

    let (work, reused) = plan_work(l, opts, &store, &dir, &mine)?;
    let mut pending: Vec<&Case> = work.iter().map(|(c, _)| *c).collect();
    pending.dedup_by_key(|c| c.index);
    // Values the data make impossible: one error before any case runs (a
    // resumed run with nothing to compute loads no mesh).
    if !pending.is_empty() && !new_folder {
        super::feasible::check_against_data(l, &col, &pending)?;
    }
    serve_case_meshes(&col, &pending, strict)?;

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
    if opts.progress {
        bars.say(&format!(
            "{name}: {} cases ({} in this shard) × {} methods; {} stored, {} to run on {} thread(s) → {}",
            cases.len(),
            mine.len(),
            l.methods.len(),
            reused,
            work.len(),
            opts.threads,
            dir.display()
        ));
    }
    let progress = Progress::new(work.len(), name, bars);
    let done = AtomicUsize::new(0);
    let dropped = AtomicUsize::new(0);
    let first_error: Mutex<Option<Error>> = Mutex::new(None);
    let row_bar = progress.bar();
    work.par_iter().with_max_len(1).for_each(|(case, m)| {
        if first_error.lock().map(|e| e.is_some()).unwrap_or(true) {
            return;
        }
        let t = Instant::now();
        let r = match with_row_bar(row_bar, || row(l, &col, &store, case, m)) {
            Ok(r) => r,
            // The results folder could not be written (disk full, ...):
            // not the method's failure. The run stops; a re-run computes it.
            Err(e) => {
                if let Ok(mut slot) = first_error.lock() {
                    slot.get_or_insert(e);
                }
                return;
            }
        };
        let status = r.cells.get("status").cloned().unwrap_or_default();
        match store.put(&r) {
            Ok(true) => {}
            // Stored meanwhile by a run of an overlapping shard: its
            // result stays, this one is dropped.
            Ok(false) => {
                dropped.fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => {
                if let Ok(mut slot) = first_error.lock() {
                    slot.get_or_insert(e);
                }
                return;
            }
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
    progress.finish(bars);
    if let Some(e) = first_error.into_inner().ok().flatten() {
        return Err(e);
    }
    let computed = done.load(Ordering::Relaxed) - dropped.load(Ordering::Relaxed);
    let reused = reused + dropped.load(Ordering::Relaxed);

    // One process at a time rebuilds the tables, the manifest and the
    // plots from everything stored (shards of one folder finish in any
    // order; the last leaves complete tables).
    let _tables = lock.tables()?;
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

    record_run(
        l,
        opts,
        &dir,
        &col,
        &cases,
        &stored,
        &Finished {
            results: &results,
            order: &order,
            failed,
            computed,
            reused,
            started,
            wall_seconds: t0.elapsed().as_secs_f64(),
        },
    )?;
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

/// The rows this invocation computes (every (case, method) of `mine`
/// without a stored result, failed ones retired first with
/// `--retry-failed`, at most `--max-new`) and the count of stored ones.
fn plan_work<'c>(
    l: &'c LoadedConfig,
    opts: &RunOptions,
    store: &Store,
    dir: &Path,
    mine: &[&'c Case],
) -> Result<(Vec<(&'c Case, &'c NamedMethod)>, usize)> {
    let name = &l.config.name;
    // Reading every stored result moves corrupt ones aside (computed again
    // below) and refuses links or special files in their place.
    store.all(&[])?;
    let mut retried = 0;
    if opts.retry_failed {
        for c in mine {
            for m in &l.methods {
                if store.retire_failed(&c.id, &m.name)? {
                    retried += 1;
                }
            }
        }
        if retried > 0 && opts.progress {
            eprintln!(
                "{name}: {retried} failed result(s) moved to {} to be computed again",
                dir.join("failed").display()
            );
        }
    }
    let mut work: Vec<(&Case, &NamedMethod)> = Vec::new();
    let mut reused = 0;
    for c in mine {
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
    Ok((work, reused))
}

/// What one invocation of a run did (for its manifest).
struct Finished<'a> {
    results: &'a [CaseResult],
    order: &'a [String],
    failed: usize,
    computed: usize,
    reused: usize,
    started: u64,
    wall_seconds: f64,
}

/// Writes the folder's manifest: the config, the data, the cases, what is
/// stored, and this invocation appended to the earlier ones.
fn record_run(
    l: &LoadedConfig,
    opts: &RunOptions,
    dir: &Path,
    col: &Collection,
    cases: &[Case],
    stored: &StoredConfig,
    f: &Finished,
) -> Result<()> {
    let name = &l.config.name;
    let git = super::store::git_revision(&std::env::current_dir().unwrap_or_default());
    // The earlier record (a manifest that does not parse is replaced; a
    // link or a special file in its place is refused).
    let manifest_path = dir.join("manifest.json");
    let prev: Option<Manifest> = match std::fs::symlink_metadata(&manifest_path) {
        Err(_) => None,
        Ok(_) => serde_json::from_str(&super::files::read_regular(&manifest_path)?).ok(),
    };
    let mut log = super::manifest::read_run_log(dir)?.unwrap_or_default();
    log.invocations.push(Invocation {
        started_unix: f.started,
        wall_seconds: f.wall_seconds,
        threads: opts.threads,
        shard: opts.shard,
        crate_version: env!("CARGO_PKG_VERSION").to_string(),
        git_revision: git,
        computed: f.computed,
        reused: f.reused,
    });
    log.method_seconds = method_seconds(f.results, f.order);
    let mut repairs: Vec<String> = col
        .repairs()
        .iter()
        .map(|r| r.to_string())
        .chain(
            col.checks()
                .iter()
                .filter_map(|c| Some(format!("{}: repaired: {}", c.file, c.repair.as_ref()?))),
        )
        .collect();
    let mut mesh_defects = DefectNote::of(&col.checks());
    if let Some(p) = &prev {
        repairs.extend(p.repairs.iter().cloned());
        mesh_defects.extend(p.mesh_defects.iter().cloned());
    }
    repairs.sort();
    repairs.dedup();
    mesh_defects.sort();
    mesh_defects.dedup();
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
        config_hash: stored.hash.clone(),
        overrides: l.overrides.clone(),
        sweep: l.sweep.clone(),
        data_root: stored
            .data
            .as_ref()
            .map(|_| l.data_root.dir.display().to_string()),
        data_hash: stored.data.as_ref().map(|d| d.hash.clone()),
        config: serde_json::to_value(&l.config)
            .map_err(|e| Error::invalid(format!("config to JSON: {e}")))?,
        seed: l.config.seed,
        crate_version: env!("CARGO_PKG_VERSION").to_string(),
        dataset: col.description.clone(),
        n_cases: cases.len(),
        cases: cases.to_vec(),
        methods: f.order.to_vec(),
        shards,
        results_stored: f.results.len(),
        results_failed: f.failed,
        repairs,
        mesh_defects,
    };
    write_manifest(dir, &manifest)?;
    super::manifest::write_run_log(dir, &log)
}

/// Runs method `m` on `case` and returns its row: the identification
/// cells, what the method measured, and `status` (`ok`, or `failed: …`
/// with the method's numbers dropped). An error writing into the results
/// folder, or a full disk, is the run's error, not the method's (see
/// [`run_error`]).
fn row(
    l: &LoadedConfig,
    col: &Collection,
    store: &Store,
    case: &Case,
    m: &NamedMethod,
) -> Result<CaseResult> {
    let render_cases = l.config.outputs.render_cases();
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
        poses: l.config.outputs.render_poses(),
        format: l.config.outputs.mesh_format().format(),
    });
    let status = match run_method(col, case, m, &l.config.metrics, render.as_ref(), &mut r) {
        Ok(()) => "ok".to_string(),
        Err(e) if run_error(&e, &store.dir) => return Err(e),
        Err(e) => {
            // Keep the identification cells, drop partial numbers.
            r.cells.retain(|k, _| ID_COLUMNS.contains(&k.as_str()));
            r.curves.clear();
            r.set("seconds_total", secs(t.elapsed().as_secs_f64()));
            format!("failed: {e}").replace(['\n', '\r'], " ")
        }
    };
    r.set("status", status);
    Ok(r)
}

/// Whether `e` is the run's failure rather than the method's: the results
/// folder (`dir`) could not be written, or a disk is full. Stored as a
/// failed result it would stay failed on a plain re-run.
fn run_error(e: &Error, dir: &Path) -> bool {
    match e {
        Error::Io { path, source } => {
            let full = matches!(
                source.kind(),
                std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded
            );
            full || path.starts_with(dir)
        }
        _ => false,
    }
}

/// Says what [`Store::bind`] did, when it did more than check the key.
fn report_bound(dir: &Path, b: Bound) {
    match b {
        Bound::Fresh | Bound::Same => {}
        Bound::Adopted { files } => eprintln!(
            "{}: results from before data fingerprints, same config: adopted, the current data \
             ({files} files) recorded in config.json",
            dir.display()
        ),
        Bound::Extended(added) => eprintln!(
            "{}: the config adds method(s) {}; the stored results are kept",
            dir.display(),
            added.join(", ")
        ),
        Bound::Rebound => eprintln!(
            "{}: held no result of its former config; bound to this one",
            dir.display()
        ),
        Bound::Superseded(to) => eprintln!(
            "{}: results of another config or data moved to {} (--force); starting afresh",
            dir.display(),
            to.display()
        ),
    }
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
    let _lock = FolderLock::exclusive(out, "merge")?;
    let store = Store::new(out);
    let stored = Store::new(&inputs[0]).read_config()?;
    store.bind(&stored, BindOptions::default())?;
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
    let mut log = super::manifest::RunLog {
        method_seconds: method_seconds(&results, &first.methods),
        invocations: Vec::new(),
    };
    let mut repairs: Vec<String> = Vec::new();
    let mut mesh_defects: Vec<DefectNote> = Vec::new();
    for (m, d) in manifests.iter().zip(inputs) {
        if let Some(l) = super::manifest::read_run_log(d)? {
            log.invocations.extend(l.invocations);
        }
        repairs.extend(m.repairs.iter().cloned());
        mesh_defects.extend(m.mesh_defects.iter().cloned());
    }
    repairs.sort();
    repairs.dedup();
    mesh_defects.sort();
    mesh_defects.dedup();
    let manifest = Manifest {
        shards: None,
        results_stored: results.len(),
        results_failed: failed,
        repairs,
        mesh_defects,
        ..first.clone()
    };
    write_manifest(out, &manifest)?;
    super::manifest::write_run_log(out, &log)?;
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
        } else if !q.exists() && !temp::is_temporary(&e.file_name().to_string_lossy()) {
            let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
            super::store::write_file(&q, &bytes, false)?;
        }
    }
    Ok(())
}

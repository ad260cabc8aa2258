//! `deformlab run CONFIG... [--out ROOT] [--threads K] [--shard i/N]`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Args;

use deformlab::experiment::{run_configs, LoadOptions, RunOptions, Shard};
use deformlab::mesh::repair::DefectPolicy;
use deformlab::Result;

/// Arguments of `deformlab run`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  \
    deformlab run experiments/*.toml                 # the default suite → results/<name>/\n  \
    deformlab run experiments/fig14.toml --threads 2\n  \
    deformlab run experiments/fig6.toml --out /tmp/r --shard 0/4   # one slice of the cases\n  \
    deformlab run experiments/real/fig14-faust.toml --data-root /data/deformlab\n  \
    deformlab run experiments/fig7.toml --set defaults.epsilon=0.02 --set name=fig7-eps\n  \
    deformlab run experiments/fig7.toml --sweep defaults.epsilon=0.01,0.02 --set name=eps\n\n\
    Results: ROOT/<name>/{manifest.json, cases.csv, curves.csv, summary.csv, plots/, meshes/,\n\
    cases/ (one file per finished case × method)}. Re-running continues an interrupted run\n\
    (finished results are kept, never overwritten); a folder is keyed by the config (with\n\
    --set/--sweep applied) and the content of the input meshes: another config or changed\n\
    meshes are refused, naming the keys or files (--force moves the old results aside).\n\
    Dataset paths `@data/...` are relative to the data root (--data-root, DEFORMLAB_DATA,\n\
    else ../shared/data); other relative paths to the config file.\n\
    One process writes an experiment folder at a time: a second run of a config waits for the\n\
    first (it prints the holder's pid) or, with --no-wait, stops; shards of one config\n\
    (--shard i/N, same N) can run side by side in one folder.\n\
    Mesh defects that change results are printed as one warning per file and kind and recorded\n\
    in manifest.json; --strict refuses such meshes, --repair fixes the standard ones.")]
pub struct RunArgs {
    /// Experiment configs (TOML), run side by side on one pool of worker
    /// threads.
    #[arg(required = true)]
    pub configs: Vec<PathBuf>,
    /// Results root: experiment `name` is written to ROOT/name.
    #[arg(long, default_value = "results")]
    pub out: PathBuf,
    /// Worker threads (cases × methods and key point candidates run on them);
    /// results do not depend on it. Default: the available cores. Capped to
    /// 4 × the available cores (at most 256).
    #[arg(long, default_value_t = deformlab::solve::default_threads(), value_parser = super::Threads::parse)]
    pub threads: usize,
    /// Run only the cases with index % N == i (join with `deformlab merge`).
    #[arg(long, value_name = "i/N")]
    pub shard: Option<String>,
    /// Do not make the plots at the end.
    #[arg(long)]
    pub no_plots: bool,
    /// No progress output.
    #[arg(long)]
    pub quiet: bool,
    /// If another process uses an experiment folder (a run of the same
    /// config, or a shard of it), stop with an error naming it instead of
    /// waiting for it.
    #[arg(long)]
    pub no_wait: bool,
    /// Refuse meshes with defects that change results (duplicate or
    /// zero-area faces, non-manifold edges or vertices, inconsistent winding,
    /// several components, unreferenced vertices) instead of warning; the
    /// same as `[dataset] strict = true` in every config.
    #[arg(long)]
    pub strict: bool,
    /// Repair meshes at load: drop duplicate and zero-area faces, wind each
    /// component consistently (each repair is printed and recorded); the
    /// same as `[dataset] repair = true` in every config (part of the
    /// config hash).
    #[arg(long)]
    pub repair: bool,
    /// The data root: dataset paths written `@data/...` in the configs (and
    /// in dataset manifests) are found under DIR. Default: the environment
    /// variable DEFORMLAB_DATA, else ../shared/data from the working
    /// directory.
    #[arg(long, value_name = "DIR")]
    pub data_root: Option<PathBuf>,
    /// Override a config key, as if the file said so (repeatable): e.g.
    /// `defaults.epsilon=0.02`, `methods.auto.n_candidates=50` (methods by
    /// name), `cases.repeat=3`, `name=eps-test`. Part of the results
    /// folder's key; recorded in manifest.json.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Sweep a method key over values (repeatable; the product of several):
    /// each method it changes becomes one method per value, named e.g.
    /// `auto-eps0.02`. `defaults.KEY` changes every method that uses it,
    /// `methods.NAME.KEY` one method. Added to the config's own [sweep].
    #[arg(long, value_name = "KEY=V1,V2,...")]
    pub sweep: Vec<String>,
    /// A results folder holding results of another config or other data
    /// (changed meshes) is refused; with --force its content is moved to
    /// ROOT/<name>.superseded-<key> and the folder starts afresh.
    #[arg(long)]
    pub force: bool,
    /// Compute again the case × method results stored as failed (the
    /// failed results are moved to ROOT/<name>/failed/).
    #[arg(long)]
    pub retry_failed: bool,
}

pub fn run(a: RunArgs) -> Result<ExitCode> {
    let t = Instant::now();
    let shard = a.shard.as_deref().map(Shard::parse).transpose()?;
    let opts = RunOptions {
        out: a.out,
        threads: super::threads(a.threads),
        shard,
        plots: !a.no_plots,
        progress: !a.quiet,
        max_new: std::env::var("DEFORMLAB_RUN_MAX_NEW")
            .ok()
            .and_then(|s| s.parse().ok()),
        wait: !a.no_wait,
        defects: DefectPolicy {
            strict: a.strict,
            repair: a.repair,
        },
        load: LoadOptions {
            data_root: a.data_root,
            set: a.set,
            sweep: a.sweep,
        },
        force: a.force,
        retry_failed: a.retry_failed,
    };
    let summaries = run_configs(&a.configs, &opts)?;
    let mut failed = 0;
    for s in &summaries {
        println!(
            "{}: {} computed, {} resumed, {} failed{}, {:.1} s{} → {}",
            s.name,
            s.computed,
            s.reused,
            s.failed,
            if s.failed > 0 {
                " (kept; --retry-failed computes them again)"
            } else {
                ""
            },
            s.wall_seconds,
            if s.complete { "" } else { " (incomplete)" },
            s.dir.display()
        );
        failed += s.failed;
    }
    println!(
        "{} experiment(s), total wall time {:.1} s",
        summaries.len(),
        t.elapsed().as_secs_f64()
    );
    Ok(if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

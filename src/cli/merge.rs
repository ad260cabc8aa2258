//! `deformlab merge DIR... --out DIR`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use deformlab::Result;

/// Arguments of `deformlab merge`.
#[derive(Args, Debug)]
#[command(after_help = "Example:\n  \
    deformlab run exp.toml --out shards/0 --shard 0/2\n  \
    deformlab run exp.toml --out shards/1 --shard 1/2\n  \
    deformlab merge shards/0/NAME shards/1/NAME --out results/NAME\n\n\
    The folders must hold results of one config (same config hash); results present in\n\
    OUT are kept, a conflicting result is an error.")]
pub struct MergeArgs {
    /// Experiment folders written by `deformlab run --shard`.
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// The merged experiment folder itself (`ROOT/NAME`: one level below
    /// the `--out ROOT` of `run`, which holds one folder per experiment).
    #[arg(long)]
    pub out: PathBuf,
    /// Do not make the plots.
    #[arg(long)]
    pub no_plots: bool,
}

pub fn run(a: MergeArgs) -> Result<ExitCode> {
    let s = deformlab::experiment::merge(&a.dirs, &a.out, !a.no_plots)?;
    println!(
        "{}: {} results copied, {} already present, {} failed{} → {}",
        s.name,
        s.computed,
        s.reused,
        s.failed,
        if s.complete {
            ""
        } else {
            " (incomplete: some cases missing)"
        },
        s.dir.display()
    );
    Ok(ExitCode::SUCCESS)
}

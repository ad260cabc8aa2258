//! Command definitions (clap) and their dispatch.

mod bench;
mod gen;
mod inspect;
mod keypoints;
mod merge;
mod plot;
mod progress;
mod report;
mod run;
mod transfer;
mod weights;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use deformlab::experiment::config::{Resolution, Subjects, SyntheticPoses};
use deformlab::experiment::range::Int;
use deformlab::Result;

/// Range of `--threads` (`run`, `bench`): any count ≥ 1 is accepted and
/// capped to [`deformlab::solve::max_threads`] by [`threads`].
type Threads = Int<1, 1_000_000_000>;

/// `--threads k` capped to [`deformlab::solve::max_threads`] (4 × the
/// available cores, at most 256), with a warning when it is.
pub fn threads(k: usize) -> usize {
    let capped = deformlab::solve::cap_threads(k);
    if capped < k {
        eprintln!(
            "warning: --threads {k} capped to {capped} (at most 4 × the available cores, and \
             at most {})",
            deformlab::solve::THREAD_LIMIT
        );
    }
    capped
}

/// deformlab: mesh deformation transfer (BDT) and partial shape registration
/// (FBT), reproduced and measured.
#[derive(Parser, Debug)]
#[command(name = "deformlab", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

impl Cli {
    /// Parses `args` (the program name first). Every subcommand takes a
    /// negative number after an option as its value, so `--epsilon -1`
    /// reaches the option's range check; clap's default calls it an
    /// unexpected argument and suggests `-- -1`, which would turn the
    /// number into a positional argument (a config path for `run`).
    pub fn parse_from_args<I, T>(args: I) -> Self
    where
        I: IntoIterator<Item = T>,
        T: Into<std::ffi::OsString> + Clone,
    {
        let command = <Self as clap::CommandFactory>::command()
            .mut_subcommands(|c| c.allow_negative_numbers(true));
        let matches = command.get_matches_from(args);
        <Self as clap::FromArgMatches>::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
    }
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Write the synthetic data set: a FAUST-style folder (S subjects × P
    /// poses of an articulated creature, one connectivity, exact ground
    /// truth, bone labels), a TOSCA-style class and a remeshed subject.
    #[command(after_help = "Examples:\n  \
        deformlab gen --out data/synthetic\n  \
        deformlab gen --out /tmp/small --subjects 2 --poses 4 --seed 7\n\n\
        Layout: OUT/faust/tr_reg_XXX.ply (XXX = 10·subject + pose), OUT/faust/labels.csv,\n\
        OUT/faust/synthetic.json, OUT/faust/rest/, OUT/tosca/creatureK.{off,ply},\n\
        OUT/remesh/remesh_*.ply + map.csv (face, barycentrics on subject 0).")]
    Gen {
        /// Output folder (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Seed of every random choice (subject proportions, remesh).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Number of subjects, 1..=99.
        #[arg(long, default_value_t = 6, value_parser = Subjects::parse)]
        subjects: usize,
        /// Poses per subject, 1..=10.
        #[arg(long, default_value_t = 8, value_parser = SyntheticPoses::parse)]
        poses: usize,
        /// Catmull–Clark levels of the template, 1..=5 (2: ~6.7k vertices, 3: ~27k,
        /// 5: ~430k for large-mesh runs).
        #[arg(long, default_value_t = 2, value_parser = Resolution::parse_u32)]
        resolution: u32,
        /// Creature without a tail.
        #[arg(long)]
        no_tail: bool,
        /// Overwrite an existing generated set in OUT.
        #[arg(long)]
        force: bool,
    },
    /// Print median timings (Markdown tables): numerical kernels, bounded
    /// biharmonic weights, key point selection.
    #[command(
        after_help = "Groups: ops (cotan Laplacian + mass), cholesky (factorise + 3 solves of L+εM),\n\
        biharmonic (the same for L M⁻¹ L + εM), eigen (20 LBO eigenpairs), nalgebra\n\
        (nalgebra-sparse's Cholesky, for comparison) — sizes 7.2k, 50k, 200k vertices;\n\
        bbw (weights for 10 handles on FAUST tr_reg_001, all modes, and LBS of 12 handles);\n\
        keypoints (fast vs exact key point selection, m = 1 and 3, by the bounded-weight fit\n\
        error; exact at a smaller n_c unless --exact-full: hours at n_c = 100);\n\
        baselines (Sumner DT on cat → lion: correspondence, factorisation, per-pose solve;\n\
        Sumner, oracle and cage DT on the synthetic Fig. 14 cases).\n\
        bbw and keypoints read the data root (DEFORMLAB_DATA, else ../shared/data) and fall back to\n\
        synthetic meshes.\n\n\
        Examples:\n  \
        deformlab bench --quick\n  \
        deformlab bench cholesky eigen\n  \
        deformlab bench keypoints\n  \
        deformlab bench --threads 2 biharmonic"
    )]
    Bench {
        /// Benchmark groups to run (all when none is given).
        groups: Vec<String>,
        /// Only the smallest size, fewer repetitions.
        #[arg(long)]
        quick: bool,
        /// Solver threads (1 = sequential, the default; measured faster on 2 cores);
        /// capped to 4 × the available cores (at most 256).
        #[arg(long, default_value_t = 1, value_parser = Threads::parse)]
        threads: usize,
        /// keypoints: also run the exact-mode selections (hours at 6890 vertices).
        #[arg(long)]
        exact_full: bool,
    },
    /// Load meshes, print a defect table per file and a set summary.
    #[command(after_help = "Examples:\n  \
        deformlab inspect data/synthetic/faust/*.ply\n  \
        deformlab inspect ../shared/data/tosca/*.off ../shared/data/sumner/horse-camel/*.obj\n  \
        deformlab inspect --brief ~/FAUST/training/registrations")]
    Inspect {
        /// Mesh files (.ply, .off, .obj, .vert/.tri) or folders holding them.
        #[arg(required = true)]
        paths: Vec<PathBuf>,
        /// One line per file instead of a full table.
        #[arg(long)]
        brief: bool,
    },
    /// Select key points on a source mesh from its deformed poses (BDT
    /// Algorithm 1); print them with the error trace and the time.
    Keypoints(keypoints::KeypointsArgs),
    /// Select (or reuse) key points on the source, fit their transforms and
    /// transfer every deformed pose to a target mesh (BDT Sec. 3.6).
    Transfer(Box<transfer::TransferArgs>),
    /// Bounded biharmonic weights (BDT Eq. 1) of one mesh for given or
    /// sampled handles, with time, active-set iterations and KKT residual.
    Weights(weights::WeightsArgs),
    /// Run experiment configs (TOML): cases × methods, resumable, sharded;
    /// writes manifest.json, cases.csv, curves.csv, summary.csv and plots.
    Run(run::RunArgs),
    /// Join the folders of sharded runs of one config.
    Merge(merge::MergeArgs),
    /// Regenerate the plots of results folders from their CSVs and meshes
    /// (with --config, as a config file's [outputs] now say).
    Plot(plot::PlotArgs),
    /// Write one self-contained HTML report of results folders: summary
    /// tables with their floor, figures, per-case tables, meshes in 3D.
    Report(report::ReportArgs),
    /// Print the registry of method kinds and the keys each uses (Markdown;
    /// docs/methods.md is this output).
    Methods,
}

/// Under an address-space limit (`ulimit -v`), the global thread pool
/// (key point candidates, transfers, plots, bench stages) gets as many of
/// its threads (`RAYON_NUM_THREADS`, else the available cores) as fit, with
/// a warning, or the command stops at once naming the limit
/// ([`deformlab::solve::address::fit_threads`]); each thread's first dense
/// product reserves a buffer that would otherwise abort the process.
/// Without a limit nothing changes. `run` sizes its own pool the same way.
fn fit_global_pool() -> Result<()> {
    use deformlab::solve::address::{address_space_limit, fit_threads};
    if address_space_limit().is_none() {
        return Ok(());
    }
    let want = std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let (n, warning) = fit_threads(want)?;
    if let Some(w) = warning {
        eprintln!("warning: {w}");
    }
    // Fails only when the pool already exists (it does not at start-up).
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build_global();
    Ok(())
}

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<ExitCode> {
    if !matches!(cli.command, Command::Run(_)) {
        fit_global_pool()?;
    }
    match cli.command {
        Command::Gen {
            out,
            seed,
            subjects,
            poses,
            resolution,
            no_tail,
            force,
        } => gen::run(gen::GenArgs {
            out: &out,
            seed,
            subjects,
            poses,
            resolution,
            no_tail,
            force,
        }),
        Command::Inspect { paths, brief } => inspect::run(&paths, brief),
        Command::Bench {
            groups,
            quick,
            threads,
            exact_full,
        } => bench::run(&groups, quick, self::threads(threads), exact_full),
        Command::Keypoints(a) => keypoints::run(a),
        Command::Transfer(a) => transfer::run(*a),
        Command::Weights(a) => weights::run(a),
        Command::Run(a) => run::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Plot(a) => plot::run(a),
        Command::Report(a) => report::run(a),
        Command::Methods => {
            print!("{}", deformlab::methods::registry::reference_markdown());
            Ok(ExitCode::SUCCESS)
        }
    }
}

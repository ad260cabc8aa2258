//! Command definitions (clap) and their dispatch.

mod inspect;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use deformlab::Result;

/// deformlab: mesh deformation transfer (BDT) and partial shape registration
/// (FBT), reproduced and measured.
#[derive(Parser, Debug)]
#[command(name = "deformlab", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
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
}

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Inspect { paths, brief } => inspect::run(&paths, brief),
    }
}

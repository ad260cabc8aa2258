//! `deformlab plot RESULTS_DIR...`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use deformlab::Result;

/// Arguments of `deformlab plot`.
#[derive(Args, Debug)]
#[command(
    after_help = "Example:\n  deformlab plot results/fig14 results/fig6\n\n\
    Reads manifest.json (the config and its [[outputs.plots]]), cases.csv, curves.csv and\n\
    meshes/ and writes plots/*.png and *.svg. Plots that cannot be made are reported."
)]
pub struct PlotArgs {
    /// Experiment results folders.
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
}

pub fn run(a: PlotArgs) -> Result<ExitCode> {
    let mut warnings = 0;
    for d in &a.dirs {
        // Not while a whole run writes the folder (beside shards: yes).
        let _lock = deformlab::experiment::FolderLock::shared(d, "plot")?;
        let w = deformlab::experiment::make_plots(d)?;
        for x in &w {
            eprintln!("warning: {x}");
        }
        warnings += w.len();
        println!(
            "{}: plots written to {} ({} warning(s))",
            d.display(),
            d.join("plots").display(),
            w.len()
        );
    }
    Ok(if warnings > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

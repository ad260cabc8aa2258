//! `deformlab plot [RESULTS_DIR...] [--config TOML [--out ROOT]]`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use deformlab::experiment::load_config_schema;
use deformlab::{Error, Result};

/// Arguments of `deformlab plot`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  \
    deformlab plot results/fig14 results/fig6\n  \
    deformlab plot --config experiments/fig14.toml          # results/fig14, plots as the TOML says\n  \
    deformlab plot /tmp/o/fig14 --config experiments/fig14.toml\n\n\
    Reads manifest.json (the config and its [[outputs.plots]]), cases.csv, curves.csv and\n\
    meshes/ and writes plots/ (PNG, SVG and PDF charts, PNG renders unless [outputs] formats\n\
    says otherwise; Markdown, CSV and LaTeX tables). With --config the output settings\n\
    ([outputs], the methods' labels) come from that file instead of the manifest, so edits\n\
    to them apply without recomputing; any other difference from the folder's config is an\n\
    error. Plots that cannot be made are reported.")]
pub struct PlotArgs {
    /// Experiment results folders (with --config: at most one; default
    /// ROOT/<name of the config>).
    #[arg(required_unless_present = "config")]
    pub dirs: Vec<PathBuf>,
    /// Take the output settings from this config file (TOML).
    #[arg(long, value_name = "TOML")]
    pub config: Option<PathBuf>,
    /// With --config and no folder: the results root, as for `run`.
    #[arg(long, default_value = "results", value_name = "ROOT")]
    pub out: PathBuf,
}

pub fn run(a: PlotArgs) -> Result<ExitCode> {
    let config = a.config.as_deref().map(load_config_schema).transpose()?;
    let dirs = match (&config, a.dirs.len()) {
        (Some(c), 0) => vec![a.out.join(&c.config.name)],
        (Some(_), 1) | (None, _) => a.dirs.clone(),
        (Some(c), n) => {
            return Err(Error::invalid(format!(
                "--config {} describes one experiment, but {n} folders are given",
                c.path.display()
            )))
        }
    };
    let mut warnings = 0;
    for d in &dirs {
        // Not while a whole run writes the folder (beside shards: yes).
        let _lock = deformlab::experiment::FolderLock::shared(d, "plot")?;
        let w = deformlab::experiment::make_plots_with(d, config.as_ref())?;
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

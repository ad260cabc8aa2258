//! `deformlab report RESULTS_ROOT [--out FILE]`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use deformlab::experiment::report::{DEFAULT_MAX_CASE_ROWS, DEFAULT_MAX_MESHES};
use deformlab::experiment::{write_report, ReportOptions};
use deformlab::Result;

/// Arguments of `deformlab report`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  \
    deformlab report results                  # results/report.html: every experiment\n  \
    deformlab report results/fig14 --out fig14.html\n\n\
    One self-contained HTML file (no network needed to view it): an index of the\n\
    experiments; per experiment the summary table with its floor shaded, every PNG\n\
    figure of plots/, a sortable per-case table, and the saved result meshes of its\n\
    first rendered case in a 3D viewer coloured by per-vertex error. The same folders\n\
    give the same bytes (no date or timing in the page). Meshes are read from\n\
    meshes/, which `deformlab run` writes and git does not keep.")]
pub struct ReportArgs {
    /// A results root (its folders with a manifest.json) or one results folder.
    pub root: PathBuf,
    /// The HTML file to write (default: ROOT/report.html); an existing file is replaced.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Result meshes in each experiment's viewer (0: none).
    #[arg(long, default_value_t = DEFAULT_MAX_MESHES, value_name = "N")]
    pub max_meshes: usize,
    /// Rows of each experiment's per-case table (the rest are in its cases.csv).
    #[arg(long, default_value_t = DEFAULT_MAX_CASE_ROWS, value_name = "N")]
    pub max_case_rows: usize,
}

pub fn run(a: ReportArgs) -> Result<ExitCode> {
    let out = a.out.clone().unwrap_or_else(|| a.root.join("report.html"));
    let r = write_report(
        &a.root,
        &out,
        &ReportOptions {
            max_meshes: a.max_meshes,
            max_case_rows: a.max_case_rows,
        },
    )?;
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    println!(
        "{}: {} experiment(s), {} figure(s), {} mesh(es); {:.1} MB ({} warning(s))",
        out.display(),
        r.experiments.len(),
        r.figures,
        r.meshes,
        r.html.len() as f64 / 1e6,
        r.warnings.len()
    );
    Ok(if r.warnings.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

//! `deformlab bench`: the groups of [`deformlab::bench`], printed to stdout.

use std::process::ExitCode;

use deformlab::bench::BenchOptions;
use deformlab::Result;

pub fn run(groups: &[String], quick: bool, threads: usize, exact_full: bool) -> Result<ExitCode> {
    deformlab::bench::check_groups(groups)?;
    if exact_full && !groups.is_empty() && !groups.iter().any(|g| g == "keypoints") {
        return Err(deformlab::Error::invalid(
            "--exact-full has no effect without the keypoints group (it adds exact-mode \
             selections to it); add keypoints to the groups or drop --exact-full",
        ));
    }
    let (threads, warning) = deformlab::solve::address::fit_threads(threads)?;
    if let Some(w) = warning {
        eprintln!("warning: {w}");
    }
    deformlab::solve::set_threads(threads);
    eprintln!(
        "benchmarking {} ({} mode, {} solver thread(s)); this takes {}",
        if groups.is_empty() {
            "all groups".to_string()
        } else {
            groups.join(", ")
        },
        if quick { "quick" } else { "full" },
        threads,
        if quick {
            "a minute or two"
        } else {
            "tens of minutes"
        }
    );
    let opts = BenchOptions { quick, exact_full };
    deformlab::bench::run(groups, &opts, &mut std::io::stdout())?;
    Ok(ExitCode::SUCCESS)
}

//! `deformlab bench`: median timings of the numerical kernels.

use std::process::ExitCode;

use deformlab::Result;

pub fn run(groups: &[String], quick: bool, threads: usize) -> Result<ExitCode> {
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
        if quick { "seconds" } else { "several minutes" }
    );
    let table = deformlab::bench::run(groups, quick)?;
    print!("{table}");
    Ok(ExitCode::SUCCESS)
}

//! `deformlab bench`: median timings of the numerical kernels, of bounded
//! biharmonic weights, of key point selection, of FBT registration and of
//! the baselines (Sumner DT, cage DT, Der et al., Amberg NICP).

use std::process::ExitCode;

use deformlab::{Error, Result};

/// Groups beyond the kernel groups of [`deformlab::bench::GROUPS`].
const METHOD_GROUPS: [&str; 4] = ["bbw", "keypoints", "fbt", "baselines"];

pub fn run(groups: &[String], quick: bool, threads: usize, exact_full: bool) -> Result<ExitCode> {
    for g in groups {
        if !deformlab::bench::GROUPS.contains(&g.as_str()) && !METHOD_GROUPS.contains(&g.as_str()) {
            return Err(Error::invalid(format!(
                "unknown benchmark group {g:?} (known: {}, {})",
                deformlab::bench::GROUPS.join(", "),
                METHOD_GROUPS.join(", ")
            )));
        }
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
    let want = |g: &str| groups.is_empty() || groups.iter().any(|w| w == g);
    let kernels: Vec<String> = groups
        .iter()
        .filter(|g| !METHOD_GROUPS.contains(&g.as_str()))
        .cloned()
        .collect();
    if groups.is_empty() || !kernels.is_empty() {
        print!("{}", deformlab::bench::run(&kernels, quick)?);
    }
    if want("bbw") {
        println!("\n## Bounded biharmonic weights and LBS\n");
        print!("{}", deformlab::bench_skin::run(quick)?);
    }
    if want("keypoints") {
        println!("\n## Key point selection\n");
        print!("{}", deformlab::bench_bdt::run(quick, exact_full)?);
    }
    if want("fbt") {
        println!("\n## FBT registration (Table 1, NICP on a partial cat)\n");
        print!("{}", deformlab::bench_fbt::run(quick)?);
    }
    if want("baselines") {
        println!("\n## Baselines: Sumner & Popović deformation transfer (cat → lion)\n");
        print!("{}", deformlab::baselines::bench::bench(quick)?);
        println!("\n## Baselines on the synthetic Fig. 14 cases\n");
        print!("{}", deformlab::experiment::baselines::bench_fig14(quick)?);
        println!("\n## Baselines on the FBT Fig. 7 completion case (Der et al., Amberg NICP)\n");
        print!(
            "{}",
            deformlab::baselines::bench::bench_registration(quick)?
        );
    }
    Ok(ExitCode::SUCCESS)
}

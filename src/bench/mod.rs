//! `deformlab bench`: median timings of the numerical kernels, of bounded
//! biharmonic weights, of key point selection, of FBT registration and of
//! the baselines (Sumner DT, cage DT, Der et al., Amberg NICP).
//!
//! One module per group of timings, each a plain function that returns its
//! printed table; [`run`] picks them by group name and writes them in order:
//!
//! * [`kernels`] — the groups of [`kernels::GROUPS`] (`ops`, `cholesky`,
//!   `biharmonic`, `eigen`, `nalgebra`);
//! * [`skin`] — `bbw` (bounded biharmonic weights and LBS);
//! * [`bdt`] — `keypoints` (key point selection) and `fast-exact` (fast
//!   vs exact selection at n_c = 10, the `verify_top` sweep);
//! * [`fbt`] — `fbt` (FBT Table 1 and NICP on a partial cat);
//! * [`baselines`] — `baselines` (Sumner DT, then the Fig. 14 cases, then
//!   Der et al. and Amberg NICP on the Fig. 7 completion case).
//!
//! The benchmarks do file I/O (they read the shared data folder) and are not
//! used by the algorithms.

use std::io::Write;
use std::time::Instant;

use crate::register::metrics::median;
use crate::{Error, Result};

pub mod baselines;
pub mod bdt;
pub mod fbt;
pub mod fig14;
pub mod kernels;
pub mod skin;

/// Groups beyond the kernel groups of [`kernels::GROUPS`].
pub const METHOD_GROUPS: [&str; 5] = ["bbw", "keypoints", "fast-exact", "fbt", "baselines"];

/// What [`run`] measures besides the group names.
#[derive(Clone, Copy, Debug, Default)]
pub struct BenchOptions {
    /// Smaller sizes and fewer repetitions (minutes instead of tens of
    /// minutes).
    pub quick: bool,
    /// `keypoints`: also measure the exact selection itself (hours).
    pub exact_full: bool,
}

/// Checks that every name is a known group (kernel or method group).
pub fn check_groups(groups: &[String]) -> Result<()> {
    for g in groups {
        if !kernels::GROUPS.contains(&g.as_str()) && !METHOD_GROUPS.contains(&g.as_str()) {
            return Err(Error::invalid(format!(
                "unknown benchmark group {g:?} (known: {}, {})",
                kernels::GROUPS.join(", "),
                METHOD_GROUPS.join(", ")
            )));
        }
    }
    Ok(())
}

/// Runs the named groups (all when `groups` is empty) and writes each table
/// to `out` as soon as it is measured. Timings use the current
/// [`crate::solve::set_threads`] setting.
pub fn run(groups: &[String], opts: &BenchOptions, out: &mut dyn Write) -> Result<()> {
    check_groups(groups)?;
    let quick = opts.quick;
    let want = |g: &str| groups.is_empty() || groups.iter().any(|w| w == g);
    let mut put = |text: &str| -> Result<()> {
        out.write_all(text.as_bytes())
            .and_then(|()| out.flush())
            .map_err(|e| Error::io("<benchmark output>", e))
    };
    let kernel_groups: Vec<String> = groups
        .iter()
        .filter(|g| !METHOD_GROUPS.contains(&g.as_str()))
        .cloned()
        .collect();
    if groups.is_empty() || !kernel_groups.is_empty() {
        put(&kernels::run(&kernel_groups, quick)?)?;
    }
    // Each heading is written before its group runs (the slow groups report
    // progress on stderr meanwhile).
    if want("bbw") {
        put("\n## Bounded biharmonic weights and LBS\n\n")?;
        put(&skin::run(quick)?)?;
    }
    if want("keypoints") {
        put("\n## Key point selection\n\n")?;
        put(&bdt::run(quick, opts.exact_full)?)?;
    }
    if want("fast-exact") {
        put("\n## Fast vs exact key point selection (n_c = 10)\n\n")?;
        put(&bdt::run_fast_exact(quick)?)?;
    }
    if want("fbt") {
        put("\n## FBT registration (Table 1, NICP on a partial cat)\n\n")?;
        put(&fbt::run(quick)?)?;
    }
    if want("baselines") {
        put("\n## Baselines: Sumner & Popović deformation transfer (cat → lion)\n\n")?;
        put(&baselines::bench(quick)?)?;
        put("\n## Baselines on the synthetic Fig. 14 cases\n\n")?;
        put(&fig14::run(quick)?)?;
        put("\n## Baselines on the FBT Fig. 7 completion case (Der et al., Amberg NICP)\n\n")?;
        put(&baselines::bench_registration(quick)?)?;
    }
    Ok(())
}

/// Median wall time (s) of `reps` runs of `f` (at least one) and the result
/// of the last run. Each run's result is dropped, untimed, before the next
/// run starts, so at most one is alive at a time.
pub(crate) fn time<T>(reps: usize, mut f: impl FnMut() -> Result<T>) -> Result<(f64, T)> {
    let mut times = Vec::with_capacity(reps.max(1));
    let mut last = None;
    for _ in 0..reps.max(1) {
        drop(last.take());
        let t = Instant::now();
        let r = f()?;
        times.push(t.elapsed().as_secs_f64());
        last = Some(r);
    }
    let last = last.ok_or_else(|| Error::invalid("no repetitions"))?;
    Ok((median(times), last))
}

/// Like [`time`], also returning the median CPU time (all threads of the
/// process, from [`cpu_seconds`]; `NaN` if unavailable) of the runs.
pub(crate) fn time_cpu<T>(reps: usize, mut f: impl FnMut() -> Result<T>) -> Result<(f64, f64, T)> {
    let mut cpu = Vec::with_capacity(reps.max(1));
    let (wall, last) = time(reps, || {
        let c0 = cpu_seconds();
        let r = f()?;
        cpu.push(match (c0, cpu_seconds()) {
            (Some(a), Some(b)) => b - a,
            _ => f64::NAN,
        });
        Ok(r)
    })?;
    Ok((wall, median(cpu), last))
}

/// Wall and CPU times (s) of each of the repetitions of [`time_runs`].
#[derive(Clone, Debug, Default)]
pub(crate) struct Runs {
    /// Wall time of each run.
    pub wall: Vec<f64>,
    /// CPU time (user + sys, all threads of the process, from
    /// [`cpu_seconds`]; `NaN` if unavailable) of each run.
    pub cpu: Vec<f64>,
}

impl Runs {
    /// `"median (min–max)"` of `v` scaled by `scale` with `prec` decimals
    /// (just the median for a single run).
    fn cell(v: &[f64], scale: f64, prec: usize) -> String {
        let med = scale * median(v.to_vec());
        if v.len() < 2 {
            return format!("{med:.prec$}");
        }
        let lo = scale * v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = scale * v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        format!("{med:.prec$} ({lo:.prec$}–{hi:.prec$})")
    }

    /// The CPU cell: median (min–max) × `scale`.
    pub fn cpu_cell(&self, scale: f64, prec: usize) -> String {
        Self::cell(&self.cpu, scale, prec)
    }

    /// The wall cell: median (min–max) × `scale`.
    pub fn wall_cell(&self, scale: f64, prec: usize) -> String {
        Self::cell(&self.wall, scale, prec)
    }
}

/// Like [`time_cpu`], returning every run's wall and CPU time instead of
/// their medians.
pub(crate) fn time_runs<T>(reps: usize, mut f: impl FnMut() -> Result<T>) -> Result<(Runs, T)> {
    let mut runs = Runs::default();
    let mut last = None;
    for _ in 0..reps.max(1) {
        drop(last.take());
        let (t, c0) = (Instant::now(), cpu_seconds());
        let r = f()?;
        runs.wall.push(t.elapsed().as_secs_f64());
        runs.cpu.push(match (c0, cpu_seconds()) {
            (Some(a), Some(b)) => b - a,
            _ => f64::NAN,
        });
        last = Some(r);
    }
    let last = last.ok_or_else(|| Error::invalid("no repetitions"))?;
    Ok((runs, last))
}

/// CPU time (s, user + sys) used so far by this process, all its threads
/// (`clock_gettime(CLOCK_PROCESS_CPUTIME_ID)`, to the nanosecond, the
/// running threads included); `None` where unavailable.
#[cfg(unix)]
pub fn cpu_seconds() -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec for the call.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) } == 0;
    ok.then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

/// CPU time of this process: not available off Unix.
#[cfg(not(unix))]
pub fn cpu_seconds() -> Option<f64> {
    None
}

/// The 1-minute load average from `/proc/loadavg` (as printed by `uptime`),
/// `"n/a"` where unavailable: timings are wall-clock on a shared machine.
pub(crate) fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "n/a".into())
}

/// A rayon pool of `threads` threads (time a parallel stage at a fixed
/// thread count with `pool.install(..)`).
pub(crate) fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::numerical(format!("cannot build a {threads}-thread pool: {e}")))
}

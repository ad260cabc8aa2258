//! Worker threads within an address-space limit (`ulimit -v`, as batch
//! schedulers set it).
//!
//! The dense kernels faer uses on x86-64 (`private-gemm-x86`) reserve, on
//! the first dense product of each thread, a buffer of **2 × the machine's
//! L3 cache** (the crate's figure: the L3 size of `/sys` over the CPUs
//! sharing it, times the CPUs sharing an L1, times the physical cores,
//! `num_cpus::get_physical`). The
//! buffer is mostly never touched, so it costs no resident memory, but it
//! counts against an address-space limit: on a host with 15 physical cores
//! and 32 MiB of L3 it is 960 MiB per thread, and a run that peaks at 33 MB
//! resident aborted under `ulimit -v` 1.5 GiB with two threads.
//!
//! [`fit_threads`] estimates that reservation the same way and, under a
//! limit, runs with as many workers as fit (results do not depend on the
//! thread count), saying so, or stops at once naming the limit.

use crate::{Error, Result};

/// Address space a worker thread may reserve besides the dense-kernel
/// buffer: its stack and the allocations of one case (a margin).
const PER_THREAD_MARGIN: u64 = 16 << 20;
/// Room kept for the process besides the workers (memoised meshes and
/// results, the main thread's own dense-kernel buffer).
const PROCESS_MARGIN: u64 = 128 << 20;

/// The dense-kernel buffer one thread reserves (bytes): 2 × the L3 size as
/// `private-gemm-x86` computes it; 0 off x86-64 Linux (other kernels).
pub fn dense_buffer_per_thread() -> u64 {
    #[cfg(all(target_arch = "x86_64", target_os = "linux"))]
    {
        let (l3, l1_shared) = linux_caches();
        2 * l3 * l1_shared * num_cpus::get_physical() as u64
    }
    #[cfg(not(all(target_arch = "x86_64", target_os = "linux")))]
    {
        0
    }
}

/// (L3 bytes per CPU sharing it, CPUs sharing an L1 data cache) from `/sys`, as the dense
/// kernels read them; (0, 1) where unknown.
#[cfg(all(target_arch = "x86_64", target_os = "linux"))]
fn linux_caches() -> (u64, u64) {
    let dir = std::path::Path::new("/sys/devices/system/cpu/cpu0/cache");
    let read = |p: std::path::PathBuf| std::fs::read_to_string(p).ok();
    let (mut l3, mut l1_shared) = (0u64, 1u64);
    let Ok(entries) = std::fs::read_dir(dir) else {
        return (l3, l1_shared);
    };
    for e in entries.flatten() {
        let p = e.path();
        let kind = read(p.join("type")).unwrap_or_default();
        if !matches!(kind.trim(), "Data" | "Unified") {
            continue;
        }
        let level = read(p.join("level")).and_then(|s| s.trim().parse::<u32>().ok());
        match level {
            Some(3) => {
                // Per CPU sharing it (the kernels multiply back by the
                // physical cores).
                let shared = read(p.join("shared_cpu_list"))
                    .map_or(1, |l| cpu_count(l.trim()))
                    .max(1);
                l3 = read(p.join("size"))
                    .and_then(|s| size_bytes(s.trim()))
                    .unwrap_or(0)
                    / shared
            }
            Some(1) => {
                if let Some(list) = read(p.join("shared_cpu_list")) {
                    l1_shared = cpu_count(list.trim()).max(1);
                }
            }
            _ => {}
        }
    }
    (l3, l1_shared)
}

/// `32768K`, `32M`, `1G` or a byte count.
#[cfg_attr(
    not(all(target_arch = "x86_64", target_os = "linux")),
    allow(dead_code)
)]
fn size_bytes(s: &str) -> Option<u64> {
    let (num, unit) = match s.chars().last()? {
        'K' => (&s[..s.len() - 1], 1 << 10),
        'M' => (&s[..s.len() - 1], 1 << 20),
        'G' => (&s[..s.len() - 1], 1 << 30),
        _ => (s, 1),
    };
    num.parse::<u64>().ok().map(|n| n * unit)
}

/// CPUs in a list such as `0-3,8,10-11`.
#[cfg_attr(
    not(all(target_arch = "x86_64", target_os = "linux")),
    allow(dead_code)
)]
fn cpu_count(list: &str) -> u64 {
    list.split(',')
        .filter_map(|item| match item.split_once('-') {
            Some((a, b)) => Some(b.parse::<u64>().ok()? + 1 - a.parse::<u64>().ok()?),
            None => item.parse::<u64>().ok().map(|_| 1),
        })
        .sum()
}

/// The process's address-space limit (`RLIMIT_AS`), `None` when unlimited.
pub fn address_space_limit() -> Option<u64> {
    #[cfg(unix)]
    {
        let mut r = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit writes the struct it is given; nothing else.
        let ok = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut r) } == 0;
        // rlim_t is u64 on Linux but not on every Unix.
        #[allow(clippy::unnecessary_cast)]
        let cur = r.rlim_cur as u64;
        (ok && r.rlim_cur != libc::RLIM_INFINITY).then_some(cur)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// Address space the process uses now (`VmSize`), 0 where unknown.
fn address_space_in_use() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("VmSize:"))?;
            let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(kb << 10)
        })
        .unwrap_or(0)
}

/// How many of `requested` workers fit in the address-space limit:
/// `Ok((requested, None))` without a limit or when they fit; `Ok((k,
/// Some(warning)))` with fewer; an error naming the limit when not even one
/// fits.
pub fn fit_threads(requested: usize) -> Result<(usize, Option<String>)> {
    let Some(limit) = address_space_limit() else {
        return Ok((requested, None));
    };
    let buffer = dense_buffer_per_thread();
    let per_thread = buffer + PER_THREAD_MARGIN;
    let used = address_space_in_use() + PROCESS_MARGIN + buffer;
    let mib = |b: u64| b >> 20;
    let room = limit.saturating_sub(used);
    let fit = (room / per_thread) as usize;
    if fit == 0 {
        return Err(Error::invalid(format!(
            "the address-space limit (ulimit -v) of {} MiB leaves no room for a worker: the \
             process uses {} MiB and each worker reserves about {} MiB ({} MiB for faer's dense \
             kernels, 2 × the L3 cache as they count it); raise the limit to at least {} MiB",
            mib(limit),
            mib(used),
            mib(per_thread),
            mib(buffer),
            mib(used + per_thread)
        )));
    }
    if fit >= requested {
        return Ok((requested, None));
    }
    Ok((
        fit,
        Some(format!(
            "the address-space limit (ulimit -v) of {} MiB fits {fit} of the {requested} \
             threads asked (each reserves about {} MiB, {} MiB of it for faer's dense kernels): \
             running with {fit}; the results do not depend on the thread count",
            mib(limit),
            mib(per_thread),
            mib(buffer)
        )),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_and_cpu_lists_parse_as_sysfs_writes_them() {
        assert_eq!(size_bytes("32768K"), Some(32 << 20));
        assert_eq!(size_bytes("32M"), Some(32 << 20));
        assert_eq!(size_bytes("1G"), Some(1 << 30));
        assert_eq!(size_bytes("4096"), Some(4096));
        assert_eq!(size_bytes("x"), None);
        assert_eq!(cpu_count("0-3,8,10-11"), 7);
        assert_eq!(cpu_count("0"), 1);
    }
}

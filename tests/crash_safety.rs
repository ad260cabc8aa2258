//! Crash safety of `deformlab run`: a small suite (a BDT and an FBT config,
//! 4 cases × 2 methods each, synthetic data) is killed with SIGKILL at 20
//! random (seeded) moments and restarted each time, then run to the end.
//! Checked after every kill: every stored result is complete JSON and no
//! result stored before was lost or rewritten. At the end: every case ×
//! method is stored exactly once, each stored result equals the one of an
//! uninterrupted run (timing cells aside), and cases.csv, curves.csv and
//! summary.csv equal the uninterrupted run's apart from the `seconds_*`
//! columns (rows of `seconds_*` metrics in summary.csv).

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::{Duration, Instant};

use common::{csv_without_timing, deformlab, ok, write};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const BDT: &str = r#"
name = "crash-bdt"
seed = 5

[dataset.synthetic]
subjects = 3
poses = 3
resolution = 1

[cases]
sources = [0]
per_pose = true

[defaults]
mode = "fast"
n_candidates = 10
error_norm = "rms"
epsilon = 0.0
max_keypoints = 3
max_swap_passes = 0

[[methods]]
name = "auto"
kind = "bdt"

[[methods]]
name = "random"
kind = "bdt_random"
count = 4

[outputs]
render_poses = 1
"#;

const FBT: &str = r#"
name = "crash-fbt"
seed = 7

[dataset.synthetic]
subjects = 1
poses = 4
tail = true
spread = 0.15
resolution = 1

[cases]
targets = []
include_self = true
per_pose = true
reference_pose = "rest"

[[methods]]
name = "q2"
kind = "fbt"
fbt = { task = "completion", q = 2, nicp = false }

[[methods]]
name = "q2-nicp"
kind = "fbt"
fbt = { task = "completion", q = 2 }

[outputs]
render_cases = 1
render_poses = 1
"#;

const EXPERIMENTS: [&str; 2] = ["crash-bdt", "crash-fbt"];
/// Case × method results per experiment.
const N_RESULTS: usize = 4 * 2;
const KILLS: usize = 20;

fn write_configs(dir: &Path) -> Vec<PathBuf> {
    [("bdt.toml", BDT), ("fbt.toml", FBT)]
        .iter()
        .map(|(name, text)| write(dir, name, text))
        .collect()
}

fn run_args(configs: &[PathBuf], out: &Path) -> Vec<String> {
    let mut a = vec!["run".to_string()];
    a.extend(configs.iter().map(|c| c.display().to_string()));
    for s in ["--out", &out.display().to_string(), "--threads", "2"] {
        a.push(s.to_string());
    }
    a.push("--no-plots".into());
    a.push("--quiet".into());
    a
}

/// Every file under `dir/cases/` (relative path → bytes), temporaries
/// included (they start with '.').
fn case_files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let Ok(rd) = std::fs::read_dir(dir.join("cases")) else {
        return out;
    };
    for e in rd {
        let case = e.unwrap().path();
        for f in std::fs::read_dir(&case).unwrap() {
            let p = f.unwrap().path();
            let rel = p.strip_prefix(dir).unwrap().display().to_string();
            // A file can vanish between listing and reading only if it is a
            // temporary; those are not results.
            if let Ok(bytes) = std::fs::read(&p) {
                out.insert(rel, bytes);
            }
        }
    }
    out
}

fn is_result(rel: &str) -> bool {
    let name = rel.rsplit('/').next().unwrap();
    name.ends_with(".json") && !name.starts_with('.')
}

/// A stored result parsed, with the timing cells removed.
fn result_without_timing(rel: &str, bytes: &[u8]) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(bytes)
        .unwrap_or_else(|e| panic!("{rel} is not complete JSON ({e}): {bytes:?}"));
    let cells = v["cells"]
        .as_object_mut()
        .unwrap_or_else(|| panic!("{rel} has no cells"));
    assert!(cells.get("status").is_some_and(|s| s.is_string()), "{rel}");
    cells.retain(|k, _| !k.starts_with("seconds_"));
    v
}

#[test]
fn sigkill_at_20_random_moments_loses_nothing() {
    let t0 = Instant::now();
    let tmp = tempfile::tempdir().unwrap();
    let configs = write_configs(&tmp.path().join("configs"));

    // Uninterrupted reference run; its duration scales the kill moments.
    let ref_out = tmp.path().join("reference");
    let start = Instant::now();
    ok(&run_args(&configs, &ref_out));
    let t_ref = start.elapsed();
    let reference: Vec<BTreeMap<String, Vec<u8>>> = EXPERIMENTS
        .iter()
        .map(|e| case_files(&ref_out.join(e)))
        .collect();
    for (e, files) in EXPERIMENTS.iter().zip(&reference) {
        assert_eq!(files.len(), N_RESULTS, "{e}: {:?}", files.keys());
    }

    // A resumed run of a finished suite (start-up, tables, manifest).
    let start = Instant::now();
    ok(&run_args(&configs, &ref_out));
    let t_noop = start.elapsed().as_secs_f64();

    // Killed runs: each is killed at a moment drawn uniformly from
    // [0, t_noop + t_ref × (0.25 + 0.6 × share of results still missing))
    // after its start, so the kills fall at start-up (dataset, config
    // binding, render meshes), in the middle of cases and between stored
    // results. The 0.25 t_ref floor covers a restart's fixed cost (the
    // datasets are generated again before the first missing case; the
    // resume of a finished suite, t_noop, skips that): without it, on an
    // idle machine (t_ref 1.4 s) every kill of one run fell before the
    // 11th result and the run made no progress.
    //
    // When a killed run has nevertheless stored everything (fast machines),
    // its folder is checked complete and the next kills start a new round
    // in a fresh folder, so that no kill is spent on a finished suite.
    let mut round = 0;
    let mut out = tmp.path().join("killed-0");
    let mut args = run_args(&configs, &out);
    let mut rng = ChaCha8Rng::seed_from_u64(20);
    let mut seen: Vec<BTreeMap<String, Vec<u8>>> = vec![BTreeMap::new(); EXPERIMENTS.len()];
    let mut interrupted = 0;
    let mut progress = Vec::new();
    let mut in_round = 0;
    let mut stalled = 0u32;
    let total = (EXPERIMENTS.len() * N_RESULTS) as f64;
    // The run's duration as the kills see it: the reference run's, lowered
    // whenever a killed run had already finished (the reference may have
    // been slowed by other load on the machine; then most kills would land
    // after a finished run).
    let mut t_run = t_ref.as_secs_f64();
    // Up to 3 × KILLS attempts, until KILLS of them interrupted a running
    // process (a kill that finds the run finished does not count).
    let mut attempts = 0;
    for kill in 0..3 * KILLS {
        if interrupted >= KILLS {
            break;
        }
        attempts += 1;
        let missing = 1.0 - in_round as f64 / total;
        // After kills that stored nothing new, the window widens (× 1.5 per
        // such kill, at most to the whole run): the next result may need
        // more than the floor when it is one of the longer cases (seen on
        // an idle machine with t_ref 1.6 s: 20 kills all stopped at 13 of
        // 16 results, the window being 0.58 s).
        let widen = 1.5f64.powi(stalled.min(8) as i32);
        let window = t_noop + (t_run * (0.25 + 0.6 * missing) * widen).min(t_ref.as_secs_f64());
        let delay = Duration::from_secs_f64(rng.random::<f64>() * window);
        let mut child = deformlab()
            .args(&args)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn deformlab");
        std::thread::sleep(delay);
        if child.try_wait().unwrap().is_none() {
            interrupted += 1;
        } else {
            // This kill's window would have ended at `delay` with this
            // t_run; never below a tenth of the reference.
            let fit = (delay.as_secs_f64() - t_noop).max(0.0) / (0.25 + 0.6 * missing);
            t_run = t_run.min(fit).max(0.1 * t_ref.as_secs_f64());
        }
        child.kill().unwrap(); // SIGKILL on Unix; Ok if it already exited
        let status = child.wait().unwrap();
        assert!(
            status.code().is_none_or(|c| c == 0),
            "kill {kill}: run failed on its own with {status}"
        );
        let mut stored = 0;
        for (k, e) in EXPERIMENTS.iter().enumerate() {
            let now = case_files(&out.join(e));
            // Nothing stored before was lost or rewritten.
            for (rel, bytes) in &seen[k] {
                assert_eq!(
                    now.get(rel),
                    Some(bytes),
                    "kill {kill}: {e}/{rel} was lost or rewritten"
                );
            }
            // Every result is complete and equals the uninterrupted run's.
            for (rel, bytes) in now.iter().filter(|(r, _)| is_result(r)) {
                let want = reference[k]
                    .get(rel)
                    .unwrap_or_else(|| panic!("kill {kill}: {e}/{rel} not in the reference"));
                assert_eq!(
                    result_without_timing(rel, bytes),
                    result_without_timing(rel, want),
                    "kill {kill}: {e}/{rel} differs from the uninterrupted run"
                );
                stored += 1;
            }
            seen[k] = now.into_iter().filter(|(r, _)| is_result(r)).collect();
        }
        progress.push(stored);
        stalled = if stored > in_round { 0 } else { stalled + 1 };
        in_round = stored;
        if stored == EXPERIMENTS.len() * N_RESULTS {
            for (k, e) in EXPERIMENTS.iter().enumerate() {
                assert_eq!(
                    case_files(&out.join(e)).keys().collect::<Vec<_>>(),
                    reference[k].keys().collect::<Vec<_>>(),
                    "round {round}: {e}: stored files differ from the uninterrupted run's"
                );
            }
            round += 1;
            out = tmp.path().join(format!("killed-{round}"));
            args = run_args(&configs, &out);
            seen = vec![BTreeMap::new(); EXPERIMENTS.len()];
            in_round = 0;
        }
    }
    eprintln!(
        "reference run {:.1} s, resumed finished run {t_noop:.1} s; {interrupted} of {attempts} \
         kills interrupted a running process; results stored after each kill: {progress:?} \
         ({round} round(s) completed under kills)",
        t_ref.as_secs_f64()
    );
    assert!(
        interrupted >= KILLS / 2,
        "only {interrupted} of {attempts} kills hit a running process"
    );
    assert!(
        round > 0 || progress.first() < progress.last(),
        "no progress across restarts: {progress:?}"
    );

    // Final, uninterrupted resume.
    ok(&args);
    for (k, e) in EXPERIMENTS.iter().enumerate() {
        let dir = out.join(e);
        let files = case_files(&dir);
        // Exactly one file per case × method, no temporaries left.
        assert_eq!(
            files.keys().collect::<Vec<_>>(),
            reference[k].keys().collect::<Vec<_>>(),
            "{e}: stored files differ from the uninterrupted run's"
        );
        for (rel, bytes) in &files {
            assert_eq!(
                result_without_timing(rel, bytes),
                result_without_timing(rel, &reference[k][rel]),
                "{e}/{rel}"
            );
        }
        for (rel, bytes) in &seen[k] {
            assert_eq!(
                files.get(rel),
                Some(bytes),
                "{e}/{rel} rewritten by the last run"
            );
        }
        let ref_dir = ref_out.join(e);
        for table in ["cases.csv", "summary.csv", "curves.csv"] {
            let got = csv_without_timing(&dir.join(table));
            let want = csv_without_timing(&ref_dir.join(table));
            assert_eq!(got, want, "{e}/{table} differs from the uninterrupted run");
        }
        // No (case, method) row twice in cases.csv, and one per result.
        let rows = csv_without_timing(&dir.join("cases.csv"));
        let (c, m) = (
            rows[0].iter().position(|h| h == "case_id").unwrap(),
            rows[0].iter().position(|h| h == "method").unwrap(),
        );
        let mut keys: Vec<(String, String)> = rows[1..]
            .iter()
            .map(|r| (r[c].clone(), r[m].clone()))
            .collect();
        keys.sort();
        keys.dedup();
        assert_eq!(keys.len(), N_RESULTS, "{e}: duplicated or missing rows");
        assert_eq!(rows.len(), 1 + N_RESULTS);
        assert!(rows[1..].iter().all(|r| r.contains(&"ok".to_string())));
        // The manifest is complete JSON and counts every result.
        let m: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap())
                .unwrap();
        assert_eq!(m["results_stored"], N_RESULTS, "{e}");
    }
    eprintln!("crash safety test: {:.1} s", t0.elapsed().as_secs_f64());
}

//! Case generation (BDT Sec. 4 semantics for FAUST-style data).
//!
//! A case is one transfer problem: `A` = the source subject in the
//! reference pose, `A′` = the source subject in the deformed poses, `B` = the
//! target subject in the reference pose, ground truth `B′` = the target
//! subject in the same deformed poses. With shared connectivity the target
//! key points are the source key points (vertex `i` ↔ vertex `i`).
//!
//! Generation (`[cases]`, see [`super::config`]): for every source subject
//! (default all), for every target subject (default all others, plus the
//! source itself with `include_self`), the reference pose is the configured
//! one or the first pose of the source that the target also has and that
//! leaves the source another pose; the deformed poses are the configured
//! ones (or every other pose of the source), restricted to those whose
//! ground truth exists (`require_truth`, default) and cut to `max_poses`.
//! `per_pose` makes one case per deformed pose. `repeat = k` makes k copies
//! of every case (ids suffixed `-x0` … `-x{k-1}`; methods seeded by the case
//! id — the FBT tasks — draw their partial shapes, feature points and
//! examples anew per copy). `random = N` keeps N of the
//! generated cases drawn without replacement with the config seed
//! (ChaCha8), in generation order; `max_cases` cuts the list. Cases are
//! numbered in that final order; shard `i/N` runs the cases with
//! `index % N == i`.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::config::{CaseSpec, Label, LoadedConfig};
use super::dataset::Collection;
use crate::{Error, Result};

/// One transfer problem.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Case {
    /// Position in the case list.
    pub index: usize,
    /// File-name-safe identifier, unique within the experiment.
    pub id: String,
    pub source: String,
    pub target: String,
    pub reference: String,
    /// Deformed poses (A′ and the ground truth).
    pub poses: Vec<String>,
    /// Whether the target has each pose (ground truth available).
    pub truth: Vec<bool>,
}

impl Case {
    /// Whether the target is the source subject itself.
    pub fn is_self(&self) -> bool {
        self.source == self.target
    }
}

fn safe(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

fn pick_subjects(
    col: &Collection,
    labels: &Option<Vec<Label>>,
    key: &str,
    cfg: &LoadedConfig,
) -> Result<Option<Vec<String>>> {
    let Some(list) = labels else {
        return Ok(None);
    };
    let mut out = Vec::new();
    for l in list {
        let id = l.to_string();
        if col.subject(&id).is_none() {
            return Err(Error::parse(
                &cfg.path,
                format!("key `cases.{key}`"),
                format!(
                    "subject {id:?} is not in the dataset; subjects: {}",
                    col.subjects
                        .iter()
                        .map(|s| s.id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        out.push(id);
    }
    Ok(Some(out))
}

/// The cases of a config over its dataset. Errors (naming the config file
/// and key) on unknown subjects and when no case can be formed.
/// Most cases one config may make (after `repeat`; before `random` and
/// `max_cases` take fewer).
pub const MAX_CASES: usize = 1_000_000;

/// Most rows (cases × methods) one run of a config may compute, checked
/// before anything runs ([`check_rows`]).
pub const MAX_ROWS: usize = 1_000_000;

/// Refuses a config whose cases × methods exceed [`MAX_ROWS`].
pub fn check_rows(cfg: &LoadedConfig, cases: usize) -> Result<()> {
    let rows = cases.saturating_mul(cfg.methods.len());
    if rows > MAX_ROWS {
        return Err(Error::parse(
            &cfg.path,
            "key `cases`",
            format!(
                "{cases} cases × {} methods make {rows} results to compute; at most {MAX_ROWS}                  per config (take fewer cases with `random` or `max_cases`, or split the run                  with --shard)",
                cfg.methods.len()
            ),
        ));
    }
    Ok(())
}

pub fn generate_cases(cfg: &LoadedConfig, col: &Collection) -> Result<Vec<Case>> {
    let spec: &CaseSpec = &cfg.config.cases;
    let sources = pick_subjects(col, &spec.sources, "sources", cfg)?
        .unwrap_or_else(|| col.subjects.iter().map(|s| s.id.clone()).collect());
    let targets = pick_subjects(col, &spec.targets, "targets", cfg)?;
    let include_self = spec.include_self.unwrap_or(false);
    let require_truth = spec.require_truth.unwrap_or(true);
    let per_pose = spec.per_pose.unwrap_or(false);
    let reference = spec.reference_pose.as_ref().map(Label::to_string);
    let wanted_poses: Option<Vec<String>> = spec
        .poses
        .as_ref()
        .map(|v| v.iter().map(Label::to_string).collect());
    let mut cases: Vec<Case> = Vec::new();
    for s in &sources {
        let Some(src) = col.subject(s) else { continue };
        let mut ts: Vec<String> = match &targets {
            Some(t) => t.iter().filter(|t| *t != s).cloned().collect(),
            None => col
                .subjects
                .iter()
                .map(|x| x.id.clone())
                .filter(|t| t != s)
                .collect(),
        };
        if include_self {
            ts.push(s.clone());
        }
        for t in &ts {
            let Some(tgt) = col.subject(t) else { continue };
            let reference = match &reference {
                Some(r) => {
                    if !src.has(r) || !tgt.has(r) {
                        continue;
                    }
                    r.clone()
                }
                None => {
                    let found = src
                        .poses
                        .iter()
                        .find(|p| tgt.has(&p.id) && src.poses.len() > 1)
                        .map(|p| p.id.clone());
                    match found {
                        Some(r) => r,
                        None => continue,
                    }
                }
            };
            let mut poses: Vec<String> = match &wanted_poses {
                Some(w) => w
                    .iter()
                    .filter(|p| src.has(p) && **p != reference)
                    .cloned()
                    .collect(),
                None => src
                    .poses
                    .iter()
                    .map(|p| p.id.clone())
                    .filter(|p| *p != reference)
                    .collect(),
            };
            if require_truth {
                poses.retain(|p| tgt.has(p));
            }
            if let Some(m) = spec.max_poses {
                poses.truncate(m);
            }
            if poses.is_empty() {
                continue;
            }
            let truth: Vec<bool> = poses.iter().map(|p| tgt.has(p)).collect();
            let base = format!("s{}-t{}-r{}", safe(s), safe(t), safe(&reference));
            if per_pose {
                for (p, has) in poses.iter().zip(&truth) {
                    cases.push(Case {
                        index: 0,
                        id: format!("{base}-p{}", safe(p)),
                        source: s.clone(),
                        target: t.clone(),
                        reference: reference.clone(),
                        poses: vec![p.clone()],
                        truth: vec![*has],
                    });
                }
            } else {
                cases.push(Case {
                    index: 0,
                    id: base,
                    source: s.clone(),
                    target: t.clone(),
                    reference: reference.clone(),
                    poses,
                    truth,
                });
            }
        }
    }
    // (`repeat` is in its range, checked while reading the config.) The
    // copies are counted before they are made.
    if let Some(k) = spec.repeat.filter(|&k| k > 1) {
        let n = cases.len().saturating_mul(k);
        if n > MAX_CASES {
            return Err(Error::parse(
                &cfg.path,
                "key `cases.repeat`",
                format!(
                    "{} cases × repeat = {k} make {n} cases; at most {MAX_CASES} (use                      `random` or `max_cases` to take fewer, or shard the run)",
                    cases.len()
                ),
            ));
        }
        cases = cases
            .iter()
            .flat_map(|c| {
                (0..k).map(move |j| Case {
                    id: format!("{}-x{j}", c.id),
                    ..c.clone()
                })
            })
            .collect();
    }
    if let Some(n) = spec.random {
        if n < cases.len() {
            let mut rng = ChaCha8Rng::seed_from_u64(cfg.config.seed);
            let mut keep = rand::seq::index::sample(&mut rng, cases.len(), n).into_vec();
            keep.sort_unstable();
            cases = keep.into_iter().map(|i| cases[i].clone()).collect();
        }
    }
    if let Some(n) = spec.max_cases {
        cases.truncate(n);
    }
    if cases.is_empty() {
        return Err(Error::parse(
            &cfg.path,
            "key `cases`",
            format!(
                "no case can be formed from {} (a case needs a source with a reference pose \
                 and another pose, and a target with the reference pose{})",
                col.description,
                if require_truth {
                    " and the deformed poses; set require_truth = false to run without ground truth"
                } else {
                    ""
                }
            ),
        ));
    }
    let mut seen = std::collections::HashSet::new();
    for (i, c) in cases.iter_mut().enumerate() {
        c.index = i;
        if !seen.insert(c.id.clone()) {
            c.id = format!("{}-{i}", c.id);
            seen.insert(c.id.clone());
        }
    }
    Ok(cases)
}

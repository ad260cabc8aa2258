//! Config values that the data make impossible, checked once the dataset
//! is open and the cases are generated, before any case runs: one error
//! naming the config file and the key, instead of one failed case per case.
//!
//! | key | needs |
//! |---|---|
//! | `n_candidates` (automatic key points) | at most the source's vertex count |
//! | `selection_poses` | at most the deformed poses of every case |
//! | `n_groups` | at most the source's vertex count |
//! | `count` (`bdt_random`) | at most the pool: `min(n_candidates, vertices)` or the vertices |
//! | `count` (`bdt_extremity`) | fewer than the source's vertices |
//! | `handles`, `n_clusters` (`clustering`) | at most the source's vertex count |
//! | FBT: every case | the target is the source subject (`include_self`) |
//! | `fbt.q` | at most the class's shapes besides the target (one more for `interpolation`) |
//! | `fbt.features`, `fbt.vertices` | at most the class's vertex count |
//! | `fbt.rig_poses` (skeleton projection) | at most the class's shapes besides reference and target |
//!
//! Meshes that cannot be read are skipped here: their cases fail with the
//! reader's error.

use std::collections::HashMap;

use super::cases::Case;
use super::config::{FbtTask, LoadedConfig, Method};
use super::dataset::Collection;
use crate::methods::completion::RigSource;
use crate::methods::{KeypointSource, Pool};
use crate::{Error, Result};

/// How a key of method `i` is named in messages: where it is set (the
/// method entry, else `[defaults]`), or the default it takes.
fn key_name(l: &LoadedConfig, i: usize, k: &str, default: impl std::fmt::Display) -> String {
    let set_in = |v: serde_json::Result<serde_json::Value>| {
        v.ok()
            .and_then(|v| v.as_object().map(|o| o.contains_key(k)))
            .unwrap_or(false)
    };
    if set_in(serde_json::to_value(&l.config.methods[i])) {
        format!("methods[{i}].{k}")
    } else if set_in(serde_json::to_value(&l.config.defaults)) {
        format!("defaults.{k}")
    } else {
        format!("methods[{i}].{k} (default {default})")
    }
}

/// How an FBT key of method `i` is named: `methods[i].fbt.k`, with the
/// default when it is not set.
fn fbt_key(l: &LoadedConfig, i: usize, k: &str, default: impl std::fmt::Display) -> String {
    let set = l.config.methods[i]
        .fbt
        .as_ref()
        .and_then(|f| serde_json::to_value(f).ok())
        .and_then(|v| v.as_object().map(|o| o.contains_key(k)))
        .unwrap_or(false);
    if set {
        format!("methods[{i}].fbt.{k}")
    } else {
        format!("methods[{i}].fbt.{k} (default {default})")
    }
}

/// The vertex count of subject `s` in pose `p` (`None`: unreadable).
struct Sizes<'a> {
    col: &'a Collection,
    known: HashMap<(String, String), Option<usize>>,
}

impl Sizes<'_> {
    fn of(&mut self, s: &str, p: &str) -> Option<usize> {
        *self
            .known
            .entry((s.to_string(), p.to_string()))
            .or_insert_with(|| self.col.mesh(s, p).ok().map(|m| m.n_vertices()))
    }
}

/// Checks the config's values against the dataset and `cases` (see the
/// module documentation).
pub fn check_against_data(l: &LoadedConfig, col: &Collection, cases: &[&Case]) -> Result<()> {
    let mut sizes = Sizes {
        col,
        known: HashMap::new(),
    };
    for (i, m) in l.methods.iter().enumerate() {
        let bad = |key: String, msg: String| Error::parse(&l.path, format!("key `{key}`"), msg);
        for case in cases {
            let Some(n) = sizes.of(&case.source, &case.reference) else {
                continue;
            };
            let what = format!(
                "the source of case {} (subject {}, pose {}) has {n} vertices",
                case.id, case.source, case.reference
            );
            match &m.method {
                Method::Transfer(t) => {
                    let Some((source, _, opts)) = t.keypoint_inputs() else {
                        continue;
                    };
                    match source {
                        KeypointSource::Automatic { selection_poses } => {
                            if opts.n_candidates > n {
                                return Err(bad(
                                    key_name(l, i, "n_candidates", opts.n_candidates),
                                    format!(
                                        "{} candidates asked, but {what}; \
                                         expected 1..={n} for this dataset",
                                        opts.n_candidates
                                    ),
                                ));
                            }
                            if let Some(k) = selection_poses {
                                if *k > case.poses.len() {
                                    return Err(bad(
                                        key_name(l, i, "selection_poses", "all"),
                                        format!(
                                            "{k} selection poses asked, but case {} has {} \
                                             deformed pose(s) ({}); expected 1..={} for these \
                                             cases",
                                            case.id,
                                            case.poses.len(),
                                            case.poses.join(", "),
                                            cases.iter().map(|c| c.poses.len()).min().unwrap_or(0)
                                        ),
                                    ));
                                }
                            }
                            if let Some(g) = opts.n_groups.filter(|&g| g > n) {
                                return Err(bad(
                                    key_name(l, i, "n_groups", "the key point count"),
                                    format!(
                                        "{g} rotation groups asked, but {what}; expected 1..={n} for this dataset"
                                    ),
                                ));
                            }
                        }
                        KeypointSource::Random { count, pool, .. } => {
                            let (size, from) = match pool {
                                Pool::Candidates => (
                                    opts.n_candidates.min(n),
                                    format!("{} FPS candidates", opts.n_candidates.min(n)),
                                ),
                                Pool::Vertices => (n, format!("{n} vertices")),
                            };
                            if *count > size {
                                return Err(bad(
                                    key_name(l, i, "count", count),
                                    format!(
                                        "{count} random key points asked from a pool of {from} \
                                         ({what}); expected 1..={size} for this dataset"
                                    ),
                                ));
                            }
                        }
                        KeypointSource::Extremity { count, .. } => {
                            if *count >= n {
                                return Err(bad(
                                    key_name(l, i, "count", count),
                                    format!(
                                        "{count} extremities asked, but {what}; expected \
                                         1..={} for this dataset",
                                        n.saturating_sub(1)
                                    ),
                                ));
                            }
                        }
                        KeypointSource::Given(_) => {}
                    }
                }
                Method::Clustering(c) => {
                    if c.handles > n {
                        return Err(bad(
                            key_name(l, i, "handles", c.handles),
                            format!(
                                "{} handles asked, but {what}; expected 1..={n} for this dataset",
                                c.handles
                            ),
                        ));
                    }
                    if let Some(k) = c.n_clusters.filter(|&k| k > n) {
                        return Err(bad(
                            key_name(l, i, "n_clusters", k),
                            format!(
                                "{k} clusters asked, but {what}; expected 1..={n} for this dataset"
                            ),
                        ));
                    }
                }
                Method::Fbt(f) => {
                    if case.target != case.source {
                        return Err(Error::parse(
                            &l.path,
                            "key `cases`",
                            format!(
                                "method {} (kind = \"fbt\") registers shapes of one class, but \
                                 case {} has source {} and target {}: set include_self = true \
                                 and targets = []",
                                m.name, case.id, case.source, case.target
                            ),
                        ));
                    }
                    let o = &f.options;
                    let Some(subject) = col.subject(&case.source) else {
                        continue;
                    };
                    let target = case.poses.first().map(String::as_str).unwrap_or("");
                    let others = subject
                        .poses
                        .iter()
                        .chain(&subject.extra)
                        .filter(|p| p.id != target && p.id != case.reference)
                        .count();
                    let interpolation = f.task == FbtTask::Interpolation;
                    let most = if interpolation { others } else { others + 1 };
                    if o.q > most {
                        return Err(bad(
                            fbt_key(l, i, "q", o.q),
                            format!(
                                "q = {} examples need {} shapes of class {} besides the \
                                 reference and the target{}; it has {others} (case {}); \
                                 expected 1..={most} for this dataset",
                                o.q,
                                o.q - 1 + usize::from(interpolation),
                                case.source,
                                if interpolation {
                                    " and the second interpolation target"
                                } else {
                                    ""
                                },
                                case.id
                            ),
                        ));
                    }
                    if f.uses_features() && o.features.features > n {
                        return Err(bad(
                            fbt_key(l, i, "features", o.features.features),
                            format!(
                                "{} feature points asked, but {what}; expected 1..={n} for \
                                 this dataset",
                                o.features.features
                            ),
                        ));
                    }
                    if f.task == FbtTask::Scale && o.vertices > n {
                        return Err(bad(
                            fbt_key(l, i, "vertices", o.vertices),
                            format!(
                                "{} vertex constraints asked, but {what}; expected 1..={n} for \
                                 this dataset",
                                o.vertices
                            ),
                        ));
                    }
                    if f.uses_skeleton() && o.rig == RigSource::Class && o.rig_poses > others {
                        return Err(bad(
                            fbt_key(l, i, "rig_poses", o.rig_poses),
                            format!(
                                "the skeleton weights are learnt from {} shapes of class {} \
                                 besides the reference and the target; it has {others} (case \
                                 {}); expected 1..={others} for this dataset",
                                o.rig_poses, case.source, case.id
                            ),
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

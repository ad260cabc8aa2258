//! Where the key points on the source come from: Algorithm 1, a simulated
//! user (random or at the extremities), or a given list.

use std::sync::Arc;
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::data::memo::{meshes_hash, Fetched, Memo};
use crate::mesh::Mesh;
use crate::ops::geodesic::EdgeGraph;
use crate::ops::Operators;
use crate::ops::{farthest_point_sampling, farthest_point_sampling_from, total_area, FpsMetric};
use crate::transfer::{
    fit_keypoints, perturb_keypoints, select_keypoints, KeypointFit, KeypointOptions,
    KeypointSelection,
};
use crate::{Error, Result};

/// Pool of a random simulated user.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Pool {
    /// Among the FPS candidates (`n_candidates`, the method's seed).
    #[default]
    Candidates,
    /// Among all vertices.
    Vertices,
}

/// How a simulated user picks extremities.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Strategy {
    /// Geodesic FPS started at the vertex nearest the centroid (the start
    /// itself dropped): the farthest points first.
    #[default]
    CentroidFps,
    /// Local maxima of the geodesic distance from the centroid vertex, by
    /// decreasing distance, then FPS to fill up.
    Eccentricity,
}

/// A source of key points on the source mesh A. Every variant is a value;
/// [`KeypointSource::pick`] is the one entry point.
#[derive(Clone, Debug, PartialEq)]
pub enum KeypointSource {
    /// BDT Algorithm 1 ([`select_keypoints`]) with the method's
    /// [`KeypointOptions`], on the first `selection_poses` deformed poses
    /// (`None`: all). Restricting `KeypointOptions::candidate_pool` to the
    /// source vertices of a correspondence file makes every key point one
    /// with a known target (`deformlab transfer --correspondence`).
    Automatic { selection_poses: Option<usize> },
    /// `count` random vertices drawn with `ChaCha8(seed)` from `pool`.
    Random { count: usize, seed: u64, pool: Pool },
    /// `count` geodesic extremities, each moved to a random vertex within
    /// `jitter · √area` (edge-path distance) with `seed` when `jitter > 0`.
    Extremity {
        count: usize,
        strategy: Strategy,
        jitter: f64,
        seed: u64,
    },
    /// A given list (e.g. a key point file).
    Given(Vec<usize>),
}

/// What [`KeypointSource::pick`] found.
#[derive(Clone, Debug)]
pub struct PickedKeypoints {
    pub keypoints: Vec<usize>,
    /// The selection (automatic only) and the number of poses it used.
    pub selection: Option<(Arc<KeypointSelection>, usize)>,
    /// Wall-clock seconds of the pick (near zero for a memoised selection;
    /// time spent waiting for a selection another case was computing is
    /// not counted).
    pub seconds: f64,
    /// What the key points cost: `seconds`, except for a selection reused
    /// from the memo (selected earlier in this process for the same source
    /// and options), where it is the seconds of the selection that filled
    /// the memo.
    pub seconds_computed: f64,
}

impl KeypointSource {
    /// Key points on `a` (with deformed poses `a_def`; `opts`: the
    /// selection options, also the candidate count and FPS metric of the
    /// random pool).
    pub fn pick(
        &self,
        a: &Mesh,
        a_def: &[Mesh],
        opts: &KeypointOptions,
    ) -> Result<PickedKeypoints> {
        let t = Instant::now();
        let mut waited = 0.0;
        let mut reused_cost = None;
        let (keypoints, selection) = match self {
            KeypointSource::Automatic { selection_poses } => {
                let k = selection_poses.unwrap_or(a_def.len()).min(a_def.len());
                let got = memo_select(a, &a_def[..k], opts)?;
                waited = got.waited;
                if got.reused {
                    reused_cost = Some(got.computed);
                }
                let sel = got.value;
                (sel.keypoints.clone(), Some((sel, k)))
            }
            KeypointSource::Random { count, seed, pool } => (
                random_keypoints(a, *count, *seed, *pool, opts.n_candidates, opts.fps)?,
                None,
            ),
            KeypointSource::Extremity {
                count,
                strategy,
                jitter,
                seed,
            } => (
                extremity_keypoints(a, *count, *strategy, *jitter, *seed)?,
                None,
            ),
            KeypointSource::Given(v) => {
                if let Some(&bad) = v.iter().find(|&&k| k >= a.n_vertices()) {
                    return Err(Error::invalid(format!(
                        "key point {bad} out of range for the source ({} vertices)",
                        a.n_vertices()
                    )));
                }
                (v.clone(), None)
            }
        };
        let seconds = (t.elapsed().as_secs_f64() - waited).max(0.0);
        Ok(PickedKeypoints {
            keypoints,
            selection,
            seconds,
            seconds_computed: reused_cost.unwrap_or(seconds),
        })
    }
}

/// Selections already made in this process, keyed by a hash of the source
/// meshes and the options: configs that repeat one selection in many rows
/// (e.g. `auto-noise.toml`: one per noise level and seed) select once. The
/// selection is deterministic, so a memoised result equals a recomputed one.
/// Also returns the seconds spent waiting for another caller's selection
/// and what the selection cost when it was made.
fn memo_select(
    a: &Mesh,
    a_def: &[Mesh],
    opts: &KeypointOptions,
) -> Result<Fetched<KeypointSelection>> {
    static MEMO: Memo<KeypointSelection> = Memo::new();
    let key = (
        meshes_hash(std::iter::once(a).chain(a_def)),
        format!("{opts:?}"),
    );
    MEMO.get_or_costed(key, || select_keypoints(a, a_def, opts))
}

/// [`fit_keypoints`], memoised like [`memo_select`]: rows that fit the same
/// key points on the same source (the frame variants of one selection, the
/// noise levels of `auto-noise.toml`) fit once; the fit is deterministic.
/// Their `seconds_fit` is then near zero.
pub fn memo_fit(
    a: &Mesh,
    a_def: &[Mesh],
    keypoints: &[usize],
    opts: &KeypointOptions,
) -> Result<Arc<KeypointFit>> {
    Ok(memo_fit_timed(a, a_def, keypoints, opts)?.0)
}

/// [`memo_fit`] and the seconds spent waiting for another caller's fit.
pub fn memo_fit_timed(
    a: &Mesh,
    a_def: &[Mesh],
    keypoints: &[usize],
    opts: &KeypointOptions,
) -> Result<(Arc<KeypointFit>, f64)> {
    let (fit, waited, _) = memo_fit_costed(a, a_def, keypoints, opts)?;
    Ok((fit, waited))
}

/// [`memo_fit_timed`] and what the fit cost: `None` when this call
/// computed it, else the seconds of the fit that filled the memo.
pub fn memo_fit_costed(
    a: &Mesh,
    a_def: &[Mesh],
    keypoints: &[usize],
    opts: &KeypointOptions,
) -> Result<(Arc<KeypointFit>, f64, Option<f64>)> {
    static MEMO: Memo<KeypointFit> = Memo::new();
    let key = (
        meshes_hash(std::iter::once(a).chain(a_def)),
        format!("{keypoints:?} {opts:?}"),
    );
    let got = MEMO.get_or_costed(key, || fit_keypoints(a, a_def, keypoints, opts))?;
    Ok((got.value, got.waited, got.reused.then_some(got.computed)))
}

/// `count` random key points: among the FPS candidates (`n_candidates`,
/// seeded with `seed`) or among all vertices, drawn with `ChaCha8(seed)`.
pub fn random_keypoints(
    a: &Mesh,
    count: usize,
    seed: u64,
    pool: Pool,
    n_candidates: usize,
    fps: FpsMetric,
) -> Result<Vec<usize>> {
    let pool: Vec<usize> = match pool {
        Pool::Candidates => {
            farthest_point_sampling(a, n_candidates.min(a.n_vertices()), fps, seed)?
        }
        Pool::Vertices => (0..a.n_vertices()).collect(),
    };
    if count > pool.len() {
        return Err(Error::invalid(format!(
            "cannot pick {count} random key points from a pool of {}",
            pool.len()
        )));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    Ok(rand::seq::index::sample(&mut rng, pool.len(), count)
        .into_iter()
        .map(|i| pool[i])
        .collect())
}

/// The vertex nearest the vertex centroid (lowest index on ties).
fn centroid_vertex(a: &Mesh) -> usize {
    let v = a.vertices();
    let c = v.iter().fold(crate::Vec3::zeros(), |s, p| s + p.coords) / v.len() as f64;
    let mut best = (0, f64::INFINITY);
    for (i, p) in v.iter().enumerate() {
        let d = (p.coords - c).norm_squared();
        if d < best.1 {
            best = (i, d);
        }
    }
    best.0
}

/// Key points a user would pick at the shape's extremities (see
/// [`Strategy`]); with `jitter > 0` each is replaced by a random vertex
/// (`ChaCha8(seed)`) within geodesic distance `jitter · √area` of it,
/// distinct from the others (a less precise user).
pub fn extremity_keypoints(
    a: &Mesh,
    count: usize,
    strategy: Strategy,
    jitter: f64,
    seed: u64,
) -> Result<Vec<usize>> {
    let n = a.n_vertices();
    if count >= n {
        return Err(Error::invalid(format!(
            "cannot pick {count} extremities on {n} vertices"
        )));
    }
    let c = centroid_vertex(a);
    let graph = EdgeGraph::new(a);
    let sqrt_area = total_area(a).sqrt();
    let mut picks: Vec<usize> = match strategy {
        Strategy::CentroidFps => {
            let mut f = farthest_point_sampling_from(a, count + 1, FpsMetric::Geodesic, c)?;
            f.remove(0);
            f
        }
        Strategy::Eccentricity => {
            let d = graph.distances(&[c])?;
            let nb = a.neighbours();
            let mut maxima: Vec<usize> = (0..n)
                .filter(|&i| {
                    d[i].is_finite() && d[i] > 0.0 && nb.row(i).iter().all(|&j| d[i] >= d[j])
                })
                .collect();
            maxima.sort_by(|&i, &j| d[j].total_cmp(&d[i]).then(i.cmp(&j)));
            let sep = 0.15 * sqrt_area;
            let mut md = vec![f64::INFINITY; n];
            let mut out = Vec::new();
            for i in maxima {
                if out.len() == count {
                    break;
                }
                if md[i] >= sep {
                    out.push(i);
                    graph.relax_from(i, &mut md)?;
                }
            }
            // Fill up by farthest points from the picks so far.
            while out.len() < count {
                let mut best = (usize::MAX, -1.0);
                for (i, &x) in md.iter().enumerate() {
                    if x.is_finite() && x > best.1 && !out.contains(&i) {
                        best = (i, x);
                    }
                }
                if best.0 == usize::MAX {
                    return Err(Error::invalid("no vertex left to pick"));
                }
                out.push(best.0);
                graph.relax_from(best.0, &mut md)?;
            }
            out
        }
    };
    if jitter > 0.0 {
        // The same seeded geodesic draw as the target key point noise.
        picks = perturb_keypoints(a, &picks, jitter * sqrt_area, seed)?;
    }
    Ok(picks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::synthetic::FaustStyle;

    #[test]
    fn memoised_fit_is_the_fit_and_is_computed_once() {
        let set = FaustStyle {
            subjects: 1,
            poses: 2,
            ..Default::default()
        }
        .generate()
        .unwrap();
        let (a, d) = (&set.meshes[0][0], &set.meshes[0][1..]);
        let opts = KeypointOptions::default();
        let kp = [3, 400, 900];
        let first = memo_fit(a, d, &kp, &opts).unwrap();
        let again = memo_fit(a, d, &kp, &opts).unwrap();
        assert!(Arc::ptr_eq(&first, &again));
        let direct = fit_keypoints(a, d, &kp, &opts).unwrap();
        assert_eq!(first.transforms, direct.transforms);
        assert_eq!(first.error, direct.error);
        // Other key points or options are other entries.
        let other = memo_fit(a, d, &[3, 400, 901], &opts).unwrap();
        assert!(!Arc::ptr_eq(&first, &other));
        let opts2 = KeypointOptions {
            seed: 1,
            ..opts.clone()
        };
        assert!(!Arc::ptr_eq(&first, &memo_fit(a, d, &kp, &opts2).unwrap()));
    }
}

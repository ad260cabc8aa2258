//! Error measures of FBT Sec. 5: relative distortion (Euclidean distance to
//! the true shape divided by √area, Table 2 and Fig. 7 left) and
//! correspondence error (Fig. 7 right, protocol of Kim et al. 2011 with
//! Euclidean distances), and cumulative curves of either.

use super::spatial::PointIndex;
use crate::{Error, Point, Result};

/// `‖a_i − b_i‖ / √area` per vertex.
pub fn relative_distortion(a: &[Point], b: &[Point], area: f64) -> Result<Vec<f64>> {
    if a.len() != b.len() {
        return Err(Error::invalid(format!(
            "distortion of {} against {} points",
            a.len(),
            b.len()
        )));
    }
    if !(area.is_finite() && area > 0.0) {
        return Err(Error::invalid(format!("area must be positive, got {area}")));
    }
    let s = area.sqrt();
    Ok(a.iter().zip(b).map(|(p, q)| (p - q).norm() / s).collect())
}

/// Mean of a slice (NaN when empty).
pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Median of a sample (the upper one for an even count; NaN when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_unstable_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Maximum of a slice (−∞ when empty).
pub fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

/// Fraction of `errors` ≤ each threshold (a cumulative curve).
pub fn cumulative_curve(errors: &[f64], thresholds: &[f64]) -> Vec<f64> {
    let mut s: Vec<f64> = errors.to_vec();
    s.sort_by(f64::total_cmp);
    thresholds
        .iter()
        .map(|&t| {
            let k = s.partition_point(|&e| e <= t);
            k as f64 / s.len().max(1) as f64
        })
        .collect()
}

/// For each query point, the index of the nearest point of `to` and the
/// distance (kd-tree).
pub fn nearest_points(from: &[Point], to: &[Point]) -> Result<Vec<(usize, f64)>> {
    if to.is_empty() {
        return Err(Error::invalid("nearest point search in an empty set"));
    }
    let index = PointIndex::new(to)?;
    Ok(from.iter().map(|p| index.nearest(p)).collect())
}

/// Correspondence errors (Fig. 7 right): a partial-target vertex `i`
/// (truly vertex `truth[i]` of the full shape) was matched to template
/// vertex `predicted[i]`; with shared connectivity that vertex's true
/// position is `full[predicted[i]]`. Error = `‖full[predicted[i]] −
/// full[truth[i]]‖ / √area`.
pub fn correspondence_errors(
    predicted: &[usize],
    truth: &[usize],
    full: &[Point],
    area: f64,
) -> Result<Vec<f64>> {
    if predicted.len() != truth.len() {
        return Err(Error::invalid("predicted and true maps differ in length"));
    }
    let s = area.sqrt();
    predicted
        .iter()
        .zip(truth)
        .map(|(&p, &t)| match (full.get(p), full.get(t)) {
            (Some(a), Some(b)) => Ok((a - b).norm() / s),
            _ => Err(Error::invalid(format!(
                "correspondence ({p}, {t}) out of range ({} vertices)",
                full.len()
            ))),
        })
        .collect()
}

/// A part (limb, torso, …) whose mean or worst relative distortion exceeds
/// this is misplaced: a gross failure of a completion (√area units).
pub const GROSS_FAILURE_DISTORTION: f64 = 0.2;

/// The error of one part: its mean and its worst (largest) relative
/// distortion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartError {
    pub part: usize,
    pub mean: f64,
    pub worst: f64,
}

impl PartError {
    /// Whether the part is off by more than `threshold` on average or at
    /// its worst.
    pub fn failed(&self, threshold: f64) -> bool {
        self.mean > threshold || self.worst > threshold
    }
}

/// Mean and worst relative distortion of every part: `labels[i]` is vertex
/// `i`'s part (`0..`); parts without a vertex are skipped. In part order.
pub fn part_errors(distortion: &[f64], labels: &[usize]) -> Result<Vec<PartError>> {
    if distortion.len() != labels.len() {
        return Err(Error::invalid(format!(
            "{} distortions for {} part labels",
            distortion.len(),
            labels.len()
        )));
    }
    let k = labels.iter().max().map_or(0, |m| m + 1);
    let mut sum = vec![0.0; k];
    let mut worst = vec![f64::NEG_INFINITY; k];
    let mut count = vec![0usize; k];
    for (&d, &l) in distortion.iter().zip(labels) {
        sum[l] += d;
        worst[l] = worst[l].max(d);
        count[l] += 1;
    }
    Ok((0..k)
        .filter(|&p| count[p] > 0)
        .map(|p| PartError {
            part: p,
            mean: sum[p] / count[p] as f64,
            worst: worst[p],
        })
        .collect())
}

/// Parts off by more than `threshold` on average or at their worst (see
/// [`GROSS_FAILURE_DISTORTION`]).
pub fn failed_parts(
    distortion: &[f64],
    labels: &[usize],
    threshold: f64,
) -> Result<Vec<PartError>> {
    Ok(part_errors(distortion, labels)?
        .into_iter()
        .filter(|p| p.failed(threshold))
        .collect())
}

#[cfg(test)]
mod part_tests {
    use super::*;

    #[test]
    fn part_means_worsts_and_failures() {
        let d = [0.1, 0.3, 0.5, 0.0, 0.0, 0.05, 0.25];
        let l = [0, 0, 1, 3, 3, 4, 4];
        let p = part_errors(&d, &l).unwrap();
        assert_eq!(p.len(), 4);
        assert!((p[0].mean - 0.2).abs() < 1e-15 && p[0].worst == 0.3);
        assert_eq!((p[1].part, p[1].mean, p[1].worst), (1, 0.5, 0.5));
        assert_eq!((p[2].part, p[2].mean, p[2].worst), (3, 0.0, 0.0));
        // Part 4: mean 0.15 under the threshold, worst 0.25 over it.
        assert!((p[3].mean - 0.15).abs() < 1e-15 && p[3].worst == 0.25);
        let f: Vec<usize> = failed_parts(&d, &l, GROSS_FAILURE_DISTORTION)
            .unwrap()
            .iter()
            .map(|p| p.part)
            .collect();
        // Part 0 fails by its worst (0.3), part 1 by both, part 4 by its worst.
        assert_eq!(f, vec![0, 1, 4]);
        assert!(part_errors(&d, &l[..2]).is_err());
    }
}

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

//! Evaluation metrics: per-vertex errors against a ground truth, summary
//! statistics, cumulative error curves (BDT Fig. 14), geodesic
//! correspondence error curves (Kim et al. 2011 protocol), the ARAP energy of
//! a result against its rest shape, distortion statistics (per-edge strain,
//! percentiles, fractions within a bound) and clustering scores.
//!
//! # Units
//!
//! Raw distances are in the meshes' own units. [`ErrorScale::of_reference`]
//! converts them with factors taken from **one reference mesh** (the
//! experiment harness passes the target reference `B`, the same for every
//! pose of a case, so errors of different poses are comparable):
//!
//! * **unit-sphere units**: `1 / r`, with `r` the radius of the
//!   [`crate::ops::normalize`] similarity of `B` (bounding-box centre, largest
//!   distance of a vertex to it): `B` scaled by it fits the unit sphere, as
//!   BDT scales its data;
//! * **√area units**: `1 / √area(B)` (the normalisation of geodesic
//!   correspondence errors, Kim et al. 2011).
//!
//! Pure functions of plain values: no I/O.

use nalgebra::Matrix3;

use crate::mesh::Mesh;
use crate::ops::geodesic::EdgeGraph;
use crate::ops::normalize::{unit_sphere_transform, NormalizeReference};
use crate::ops::Operators;
use crate::ops::{face_areas, polar_decomposition, total_area};
use crate::{Error, Mat3, Point, Result, Vec3};

/// Factors that turn raw distances into normalised units (see the module
/// documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorScale {
    /// Multiply a raw distance by this to get unit-sphere units.
    pub unit_sphere: f64,
    /// Multiply a raw distance by this to get √area units.
    pub sqrt_area: f64,
}

impl ErrorScale {
    /// Scales of `reference` (e.g. the target `B`). Errors if its vertices
    /// all coincide or its area is zero.
    pub fn of_reference(reference: &Mesh) -> Result<Self> {
        let sim =
            unit_sphere_transform(std::slice::from_ref(reference), NormalizeReference::Union)?;
        let area = total_area(reference);
        if !(area > 0.0 && area.is_finite()) {
            return Err(Error::invalid(format!(
                "reference mesh has area {area}: cannot normalise errors by √area"
            )));
        }
        Ok(ErrorScale {
            unit_sphere: sim.scale,
            sqrt_area: 1.0 / area.sqrt(),
        })
    }
}

/// Per-vertex Euclidean distances `‖r_i − t_i‖`. Errors on lists of
/// different length, empty lists or non-finite coordinates.
pub fn vertex_errors(result: &[Point], truth: &[Point]) -> Result<Vec<f64>> {
    if result.len() != truth.len() || result.is_empty() {
        return Err(Error::invalid(format!(
            "cannot compare {} result vertices with {} ground-truth vertices",
            result.len(),
            truth.len()
        )));
    }
    let e: Vec<f64> = result
        .iter()
        .zip(truth)
        .map(|(r, t)| (r - t).norm())
        .collect();
    if let Some(i) = e.iter().position(|x| !x.is_finite()) {
        return Err(Error::invalid(format!(
            "vertex {i}: error is not finite (non-finite coordinates)"
        )));
    }
    Ok(e)
}

/// A proper rigid motion `x ↦ R x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidMotion {
    /// Rotation (orthonormal, determinant +1).
    pub rotation: Mat3,
    /// Translation.
    pub translation: Vec3,
}

impl RigidMotion {
    /// Applies the motion to a point.
    pub fn apply(&self, p: &Point) -> Point {
        Point::from(self.rotation * p.coords + self.translation)
    }
}

/// The rigid motion (no scaling, no reflection) that best maps `moving` onto
/// `fixed` in the least-squares sense (Kabsch): `argmin Σ ‖R m_i + t − f_i‖²`.
/// Errors on mismatched or empty lists and non-finite input.
pub fn procrustes(moving: &[Point], fixed: &[Point]) -> Result<RigidMotion> {
    if moving.len() != fixed.len() || moving.is_empty() {
        return Err(Error::invalid(format!(
            "Procrustes alignment of {} onto {} points",
            moving.len(),
            fixed.len()
        )));
    }
    let n = moving.len() as f64;
    let cm = moving.iter().fold(Vec3::zeros(), |a, p| a + p.coords) / n;
    let cf = fixed.iter().fold(Vec3::zeros(), |a, p| a + p.coords) / n;
    // M = Σ (f − c_f)(m − c_m)ᵀ; the best rotation maximises tr(Rᵀ M).
    let mut m = Matrix3::zeros();
    for (p, q) in moving.iter().zip(fixed) {
        m += (q.coords - cf) * (p.coords - cm).transpose();
    }
    let rotation = polar_decomposition(&m)?.rotation;
    Ok(RigidMotion {
        rotation,
        translation: cf - rotation * cm,
    })
}

/// [`vertex_errors`] after rigidly aligning `result` onto `truth`
/// ([`procrustes`]): the best **rigid** motion (rotation + translation; no
/// scaling, no reflection), not a similarity.
pub fn aligned_vertex_errors(result: &[Point], truth: &[Point]) -> Result<Vec<f64>> {
    let t = procrustes(result, truth)?;
    let moved: Vec<Point> = result.iter().map(|p| t.apply(p)).collect();
    vertex_errors(&moved, truth)
}

/// Mean, root-mean-square and maximum of a list of errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorStats {
    pub mean: f64,
    pub rms: f64,
    pub max: f64,
}

impl ErrorStats {
    /// The statistics multiplied by a unit factor.
    pub fn scaled(&self, factor: f64) -> ErrorStats {
        ErrorStats {
            mean: self.mean * factor,
            rms: self.rms * factor,
            max: self.max * factor,
        }
    }
}

/// Statistics of `errors` (summed in index order). Errors on an empty list
/// or a non-finite value.
pub fn error_stats(errors: &[f64]) -> Result<ErrorStats> {
    if errors.is_empty() {
        return Err(Error::invalid("no errors to summarise"));
    }
    if let Some(i) = errors.iter().position(|e| !e.is_finite()) {
        return Err(Error::invalid(format!("error {i} is {}", errors[i])));
    }
    let n = errors.len() as f64;
    let sum: f64 = errors.iter().sum();
    let sq: f64 = errors.iter().map(|e| e * e).sum();
    Ok(ErrorStats {
        mean: sum / n,
        rms: (sq / n).sqrt(),
        max: errors.iter().cloned().fold(0.0, f64::max),
    })
}

/// `points` equally spaced bounds from 0 to `max` (both included). Errors if
/// `points < 2` or `max` is not finite and positive.
pub fn curve_grid(max: f64, points: usize) -> Result<Vec<f64>> {
    if points < 2 || !(max.is_finite() && max > 0.0) {
        return Err(Error::invalid(format!(
            "an error curve grid needs at least 2 points and a positive finite maximum, \
             got {points} points up to {max}"
        )));
    }
    let step = max / (points - 1) as f64;
    Ok((0..points)
        .map(|k| {
            if k + 1 == points {
                max
            } else {
                k as f64 * step
            }
        })
        .collect())
}

/// Cumulative error curve (BDT Fig. 14): for every bound `b` of `bounds`, the
/// fraction of `errors` that are `≤ b`. Empty `errors` give an all-zero curve.
pub fn cumulative_curve(errors: &[f64], bounds: &[f64]) -> Vec<f64> {
    if errors.is_empty() {
        return vec![0.0; bounds.len()];
    }
    let mut sorted: Vec<f64> = errors.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len() as f64;
    bounds
        .iter()
        .map(|&b| sorted.partition_point(|&e| e <= b) as f64 / n)
        .collect()
}

/// Fraction of `errors` that are `≤ bound` (0 for an empty list): one point
/// of [`cumulative_curve`], e.g. the share of vertices within 0.02 √area.
pub fn fraction_within(errors: &[f64], bound: f64) -> f64 {
    if errors.is_empty() {
        return 0.0;
    }
    errors.iter().filter(|&&e| e <= bound).count() as f64 / errors.len() as f64
}

/// The `p`-th percentile (`0 ≤ p ≤ 100`) of `values`, by linear
/// interpolation between the order statistics (the "linear" rule of NumPy
/// and R type 7): rank `h = (n − 1) p / 100`, value `x_⌊h⌋ + (h − ⌊h⌋)
/// (x_⌊h⌋+1 − x_⌊h⌋)` of the sorted values. `p = 0` is the minimum, `p = 100`
/// the maximum. Errors on an empty list, a non-finite value or `p` outside
/// `[0, 100]`.
pub fn percentile(values: &[f64], p: f64) -> Result<f64> {
    if values.is_empty() {
        return Err(Error::invalid("percentile of an empty list"));
    }
    if !(0.0..=100.0).contains(&p) {
        return Err(Error::invalid(format!("percentile {p} outside [0, 100]")));
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(format!(
            "percentile: value {i} is {}",
            values[i]
        )));
    }
    let mut s = values.to_vec();
    s.sort_by(f64::total_cmp);
    let h = (s.len() - 1) as f64 * p / 100.0;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(s.len() - 1);
    Ok(s[lo] + (h - lo as f64) * (s[hi] - s[lo]))
}

/// Per-edge strain `|ℓ′_e / ℓ_e − 1|` of `deformed` against `rest` (same
/// faces), one value per undirected edge of `rest` in
/// [`crate::ops::edges`] order; edges of zero length in `rest` are left out.
/// 0 for a rigid motion, `|s − 1|` for a uniform scaling by `s`. Errors on a
/// vertex count mismatch or a non-finite deformed edge length.
pub fn edge_strains(rest: &Mesh, deformed: &[Point]) -> Result<Vec<f64>> {
    if deformed.len() != rest.n_vertices() {
        return Err(Error::invalid(format!(
            "edge strain of {} vertices against a rest shape with {}",
            deformed.len(),
            rest.n_vertices()
        )));
    }
    let p = rest.vertices();
    let mut out = Vec::new();
    for (i, j) in crate::ops::edges(rest) {
        let l0 = (p[j] - p[i]).norm();
        if l0 <= 0.0 {
            continue;
        }
        let l1 = (deformed[j] - deformed[i]).norm();
        if !l1.is_finite() {
            return Err(Error::invalid(format!(
                "edge strain: edge ({i}, {j}) has a non-finite deformed length"
            )));
        }
        out.push((l1 / l0 - 1.0).abs());
    }
    Ok(out)
}

/// Checks a list of correspondences on `mesh` (equal lengths, vertices in
/// range, positive area); returns the mesh's area.
fn check_correspondences(mesh: &Mesh, predicted: &[usize], truth: &[usize]) -> Result<f64> {
    if predicted.len() != truth.len() {
        return Err(Error::invalid(format!(
            "{} predicted but {} true correspondences",
            predicted.len(),
            truth.len()
        )));
    }
    let n = mesh.n_vertices();
    if let Some(&v) = predicted.iter().chain(truth).find(|&&v| v >= n) {
        return Err(Error::invalid(format!(
            "correspondence vertex {v} out of range ({n} vertices)"
        )));
    }
    let area = total_area(mesh);
    if area.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(Error::invalid("mesh has zero area"));
    }
    Ok(area)
}

/// Euclidean correspondence errors `‖v[predicted] − v[truth]‖ / √area` on
/// `mesh` (FBT Fig. 7 right as the paper measures it; the unit of
/// [`geodesic_error_curve`], which they never exceed: an edge path is at
/// least as long as the straight segment) and their cumulative curve on
/// `bounds`. Errors as [`geodesic_error_curve`].
pub fn euclidean_error_curve(
    mesh: &Mesh,
    predicted: &[usize],
    truth: &[usize],
    bounds: &[f64],
) -> Result<(Vec<f64>, Vec<f64>)> {
    let area = check_correspondences(mesh, predicted, truth)?;
    let v = mesh.vertices();
    let errors: Vec<f64> = predicted
        .iter()
        .zip(truth)
        .map(|(&p, &t)| (v[p] - v[t]).norm() / area.sqrt())
        .collect();
    let curve = cumulative_curve(&errors, bounds);
    Ok((errors, curve))
}

/// Geodesic correspondence errors (Kim et al. 2011 protocol): for each query
/// `k`, the edge-graph (Dijkstra) distance on `mesh` between the predicted
/// vertex `predicted[k]` and the true vertex `truth[k]`, divided by
/// `√area(mesh)`. (Edge paths overestimate the true geodesic distance by a
/// few percent on regular meshes.) Returns the errors and their cumulative
/// curve on `bounds`. Errors on mismatched lists or out-of-range vertices.
pub fn geodesic_error_curve(
    mesh: &Mesh,
    predicted: &[usize],
    truth: &[usize],
    bounds: &[f64],
) -> Result<(Vec<f64>, Vec<f64>)> {
    let area = check_correspondences(mesh, predicted, truth)?;
    let graph = EdgeGraph::new(mesh);
    let mut order: Vec<usize> = (0..truth.len()).collect();
    order.sort_by_key(|&k| truth[k]);
    let mut errors = vec![0.0; truth.len()];
    let mut i = 0;
    while i < order.len() {
        let t = truth[order[i]];
        let d = graph.distances(&[t])?;
        while i < order.len() && truth[order[i]] == t {
            let k = order[i];
            errors[k] = d[predicted[k]] / area.sqrt();
            i += 1;
        }
    }
    let curve = cumulative_curve(&errors, bounds);
    Ok((errors, curve))
}

/// The ARAP energy of `deformed` against the rest shape `rest` (Sorkine &
/// Alexa 2007, one-ring cells): `Σ_i Σ_{j∈N(i)} w_ij ‖(p′_j − p′_i) −
/// R_i (p_j − p_i)‖²` with the best rotation `R_i` of every cell and the
/// cotangent weights `w_ij` of `rest` clamped at 0 (so the energy is ≥ 0 and
/// the rotations are its minimisers). Returns `(energy, relative)` where
/// `relative = energy / Σ_i Σ_j w_ij ‖p_j − p_i‖²` is dimensionless: 0 for a
/// rigid motion, `(s − 1)²` for a uniform scaling by `s` on a mesh whose
/// cells are not sheared. Errors on a vertex count mismatch.
pub fn arap_energy(rest: &Mesh, deformed: &[Point]) -> Result<(f64, f64)> {
    let n = rest.n_vertices();
    if deformed.len() != n {
        return Err(Error::invalid(format!(
            "ARAP energy of {} vertices against a rest shape with {n}",
            deformed.len()
        )));
    }
    let p = rest.vertices();
    // One weight per undirected edge (the faces' contributions summed).
    let merged = rest.edge_weights();
    let mut cov = vec![Matrix3::<f64>::zeros(); n];
    for &((i, j), w) in merged.iter() {
        let w = w.max(0.0);
        let e = p[j] - p[i];
        let e2 = deformed[j] - deformed[i];
        // M_i = Σ w e′ eᵀ (same for the reversed edge at j: signs cancel).
        let m = w * e2 * e.transpose();
        cov[i] += m;
        cov[j] += m;
    }
    let rot = cov
        .iter()
        .map(|m| polar_decomposition(m).map(|p| p.rotation))
        .collect::<Result<Vec<Mat3>>>()?;
    let (mut energy, mut norm) = (0.0, 0.0);
    for &((i, j), w) in merged.iter() {
        let w = w.max(0.0);
        let e = p[j] - p[i];
        let e2 = deformed[j] - deformed[i];
        energy += w * ((e2 - rot[i] * e).norm_squared() + (e2 - rot[j] * e).norm_squared());
        norm += 2.0 * w * e.norm_squared();
    }
    if !energy.is_finite() {
        return Err(Error::invalid("ARAP energy is not finite"));
    }
    let relative = if norm > 0.0 { energy / norm } else { 0.0 };
    Ok((energy, relative))
}

/// Per-face `|log(A′_f / A_f)|` of `deformed` against `rest` (same faces),
/// for distortion curves ([`cumulative_curve`] of these values); faces
/// degenerate in either shape are left out. Errors on a vertex count
/// mismatch.
pub fn face_log_area_ratios(rest: &Mesh, deformed: &[Point]) -> Result<Vec<f64>> {
    if deformed.len() != rest.n_vertices() {
        return Err(Error::invalid(format!(
            "area ratios of {} vertices against a rest shape with {}",
            deformed.len(),
            rest.n_vertices()
        )));
    }
    let d = deformed;
    Ok(rest
        .faces()
        .iter()
        .zip(face_areas(rest))
        .filter_map(|(&[i, j, k], a)| {
            let a1 = 0.5 * (d[j] - d[i]).cross(&(d[k] - d[i])).norm();
            (a > 0.0 && a1 > 0.0 && a1.is_finite()).then(|| (a1 / a).ln().abs())
        })
        .collect())
}

/// Distortion of `deformed` relative to `rest` (same faces): statistics of
/// the per-face log area ratios `log(A′_f / A_f)` and per-edge log length
/// ratios `log(ℓ′_e / ℓ_e)`. Faces or edges that are degenerate in either
/// shape are skipped and counted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Distortion {
    /// Area-weighted mean of `|log(A′/A)|` (0: every face keeps its area).
    pub area_log_mean_abs: f64,
    /// Largest `|log(A′/A)|`.
    pub area_log_max_abs: f64,
    /// Root mean square of `log(ℓ′/ℓ)` over edges.
    pub edge_log_rms: f64,
    /// Largest `|log(ℓ′/ℓ)|`.
    pub edge_log_max_abs: f64,
    /// Faces and edges skipped as degenerate.
    pub skipped: usize,
}

/// See [`Distortion`]. Errors on a vertex count mismatch or when every face
/// is degenerate.
pub fn distortion(rest: &Mesh, deformed: &[Point]) -> Result<Distortion> {
    if deformed.len() != rest.n_vertices() {
        return Err(Error::invalid(format!(
            "distortion of {} vertices against a rest shape with {}",
            deformed.len(),
            rest.n_vertices()
        )));
    }
    let a0 = face_areas(rest);
    let d = deformed;
    let mut skipped = 0;
    let (mut wsum, mut asum, mut amax) = (0.0, 0.0, 0.0f64);
    for (f, &a) in rest.faces().iter().zip(&a0) {
        let [i, j, k] = *f;
        let a1 = 0.5 * (d[j] - d[i]).cross(&(d[k] - d[i])).norm();
        if !(a > 0.0 && a1 > 0.0 && a1.is_finite()) {
            skipped += 1;
            continue;
        }
        let l = (a1 / a).ln().abs();
        wsum += a;
        asum += a * l;
        amax = amax.max(l);
    }
    if wsum <= 0.0 {
        return Err(Error::invalid("distortion: every face is degenerate"));
    }
    let p = rest.vertices();
    let (mut esq, mut emax, mut ecount) = (0.0, 0.0f64, 0usize);
    for (i, j) in crate::ops::edges(rest) {
        let l0 = (p[j] - p[i]).norm();
        let l1 = (d[j] - d[i]).norm();
        if !(l0 > 0.0 && l1 > 0.0 && l1.is_finite()) {
            skipped += 1;
            continue;
        }
        let l = (l1 / l0).ln();
        esq += l * l;
        emax = emax.max(l.abs());
        ecount += 1;
    }
    Ok(Distortion {
        area_log_mean_abs: asum / wsum,
        area_log_max_abs: amax,
        edge_log_rms: if ecount > 0 {
            (esq / ecount as f64).sqrt()
        } else {
            0.0
        },
        edge_log_max_abs: emax,
        skipped,
    })
}

/// Adjusted Rand index of two labelings of the same items (Hubert & Arabie
/// 1985): 1 for identical partitions (up to renaming), about 0 for
/// independent ones. Two trivial partitions (one cluster each, or all
/// singletons each) score 1. Errors if the lengths differ or are 0.
pub fn adjusted_rand_index(a: &[usize], b: &[usize]) -> Result<f64> {
    if a.len() != b.len() || a.is_empty() {
        return Err(Error::invalid(format!(
            "adjusted Rand index of {} against {} labels",
            a.len(),
            b.len()
        )));
    }
    use std::collections::HashMap;
    let c2 = |x: usize| (x as f64) * (x as f64 - 1.0) / 2.0;
    let mut pairs: HashMap<(usize, usize), usize> = HashMap::new();
    let mut ra: HashMap<usize, usize> = HashMap::new();
    let mut rb: HashMap<usize, usize> = HashMap::new();
    for (&x, &y) in a.iter().zip(b) {
        *pairs.entry((x, y)).or_default() += 1;
        *ra.entry(x).or_default() += 1;
        *rb.entry(y).or_default() += 1;
    }
    // Sums of integers: exact in f64 for any realistic size, order-free.
    let index: f64 = pairs.values().map(|&v| c2(v)).sum();
    let sa: f64 = ra.values().map(|&v| c2(v)).sum();
    let sb: f64 = rb.values().map(|&v| c2(v)).sum();
    let expected = sa * sb / c2(a.len()).max(f64::MIN_POSITIVE);
    let max = 0.5 * (sa + sb);
    if (max - expected).abs() < 1e-12 {
        return Ok(1.0);
    }
    Ok((index - expected) / (max - expected))
}

/// Root-mean-square residual of the best rigid motion per cluster: for every
/// cluster `g` and deformed shape `d`, the rest vertices of `g` are aligned
/// rigidly ([`procrustes`]) onto their positions in `d`; returns the RMS of
/// all residuals (vertex-weighted, over all shapes), in the units of the
/// input. 0 when every cluster moves rigidly: a label-free score of rotation
/// groups. Errors on mismatched sizes.
pub fn cluster_rigidity_rms(
    rest: &[Point],
    deformed: &[Vec<Point>],
    labels: &[usize],
) -> Result<f64> {
    if labels.len() != rest.len() || deformed.iter().any(|d| d.len() != rest.len()) {
        return Err(Error::invalid(
            "cluster rigidity: labels and shapes must all have one entry per vertex",
        ));
    }
    if deformed.is_empty() || rest.is_empty() {
        return Err(Error::invalid(
            "cluster rigidity needs at least one deformed shape",
        ));
    }
    let k = labels.iter().max().map_or(0, |m| m + 1);
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); k];
    for (i, &g) in labels.iter().enumerate() {
        members[g].push(i);
    }
    let mut sq = 0.0;
    for d in deformed {
        for m in members.iter().filter(|m| !m.is_empty()) {
            let a: Vec<Point> = m.iter().map(|&i| rest[i]).collect();
            let b: Vec<Point> = m.iter().map(|&i| d[i]).collect();
            let t = procrustes(&a, &b)?;
            sq += a
                .iter()
                .zip(&b)
                .map(|(p, q)| (t.apply(p) - q).norm_squared())
                .sum::<f64>();
        }
    }
    Ok((sq / (rest.len() * deformed.len()) as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::primitives::icosphere;
    use crate::ops::rotation_exp;

    fn rigid(p: &[Point]) -> Vec<Point> {
        let r = rotation_exp(&Vec3::new(0.3, -0.7, 0.2));
        let t = Vec3::new(1.5, -2.0, 0.25);
        p.iter().map(|x| Point::from(r * x.coords + t)).collect()
    }

    #[test]
    fn rigid_motion_has_zero_error_after_procrustes_only() {
        let s = icosphere(2);
        let moved = rigid(s.vertices());
        let raw = error_stats(&vertex_errors(&moved, s.vertices()).unwrap()).unwrap();
        assert!(raw.mean > 0.5, "raw error {raw:?}");
        let al = error_stats(&aligned_vertex_errors(&moved, s.vertices()).unwrap()).unwrap();
        assert!(al.max < 1e-12, "aligned {al:?}");
    }

    #[test]
    fn procrustes_never_reflects() {
        let s = icosphere(1);
        let mirrored: Vec<Point> = s
            .vertices()
            .iter()
            .map(|p| Point::new(-p.x, p.y, p.z))
            .collect();
        let t = procrustes(s.vertices(), &mirrored).unwrap();
        assert!((t.rotation.determinant() - 1.0).abs() < 1e-12);
        // A mirror image cannot be reached rigidly: residual stays > 0.
        let e = error_stats(&aligned_vertex_errors(s.vertices(), &mirrored).unwrap()).unwrap();
        assert!(e.mean > 0.1);
    }

    #[test]
    fn stats_of_known_values() {
        let s = error_stats(&[3.0, 4.0]).unwrap();
        assert_eq!(s.mean, 3.5);
        assert!((s.rms - 12.5f64.sqrt()).abs() < 1e-15);
        assert_eq!(s.max, 4.0);
        assert!(error_stats(&[]).is_err());
        assert!(error_stats(&[1.0, f64::NAN]).is_err());
    }

    #[test]
    fn curve_endpoints_are_zero_and_one() {
        let s = icosphere(1);
        let d: Vec<Point> = s
            .vertices()
            .iter()
            .enumerate()
            .map(|(i, p)| p + Vec3::new(0.01 * (1 + i % 7) as f64, 0.0, 0.0))
            .collect();
        let e = vertex_errors(&d, s.vertices()).unwrap();
        let max = e.iter().cloned().fold(0.0, f64::max);
        let grid = curve_grid(max, 21).unwrap();
        let c = cumulative_curve(&e, &grid);
        assert_eq!(c[0], 0.0);
        assert_eq!(*c.last().unwrap(), 1.0);
        assert!(c.windows(2).all(|w| w[0] <= w[1]), "monotone");
    }

    #[test]
    fn constant_offset_gives_a_step() {
        let s = icosphere(1);
        let off = 0.05;
        let d: Vec<Point> = s
            .vertices()
            .iter()
            .map(|p| p + Vec3::new(0.0, off, 0.0))
            .collect();
        let e = vertex_errors(&d, s.vertices()).unwrap();
        let grid = curve_grid(0.1, 11).unwrap(); // 0, 0.01, ..., 0.1
        let c = cumulative_curve(&e, &grid);
        for (b, f) in grid.iter().zip(&c) {
            let expect = if *b < off - 1e-9 {
                0.0
            } else if *b > off + 1e-9 {
                1.0
            } else {
                *f // at the step itself rounding decides
            };
            assert_eq!(*f, expect, "bound {b}");
        }
        assert_eq!(c[4], 0.0);
        assert_eq!(c[6], 1.0);
    }

    #[test]
    fn unit_scales_of_a_sphere() {
        let s = icosphere(3);
        let sc = ErrorScale::of_reference(&s).unwrap();
        // Inscribed in the unit sphere: radius 1 (vertices on it).
        assert!((sc.unit_sphere - 1.0).abs() < 1e-9, "{sc:?}");
        let area = total_area(&s);
        assert!((sc.sqrt_area - 1.0 / area.sqrt()).abs() < 1e-15);
        assert!(area < 4.0 * std::f64::consts::PI);
    }

    #[test]
    fn arap_energy_of_rigid_motion_and_scaling() {
        let s = icosphere(2);
        let (e, rel) = arap_energy(&s, &rigid(s.vertices())).unwrap();
        assert!(e.abs() < 1e-20 && rel.abs() < 1e-20, "{e} {rel}");
        let k = 1.3;
        let scaled: Vec<Point> = s
            .vertices()
            .iter()
            .map(|p| Point::from(p.coords * k))
            .collect();
        let (_, rel) = arap_energy(&s, &scaled).unwrap();
        assert!((rel - (k - 1.0f64).powi(2)).abs() < 1e-12, "{rel}");
        // A non-uniform stretch costs more than zero.
        let stretched: Vec<Point> = s
            .vertices()
            .iter()
            .map(|p| Point::new(1.5 * p.x, p.y, p.z))
            .collect();
        assert!(arap_energy(&s, &stretched).unwrap().1 > 1e-3);
        assert!(arap_energy(&s, &stretched[1..]).is_err());
    }

    #[test]
    fn distortion_of_scaling() {
        let s = icosphere(2);
        let k = 2.0f64;
        let scaled: Vec<Point> = s
            .vertices()
            .iter()
            .map(|p| Point::from(p.coords * k))
            .collect();
        let d = distortion(&s, &scaled).unwrap();
        assert!((d.area_log_mean_abs - 2.0 * k.ln()).abs() < 1e-12);
        assert!((d.area_log_max_abs - 2.0 * k.ln()).abs() < 1e-12);
        assert!((d.edge_log_rms - k.ln()).abs() < 1e-12);
        let r = face_log_area_ratios(&s, &scaled).unwrap();
        assert_eq!(r.len(), s.n_faces());
        assert!(r.iter().all(|x| (x - 2.0 * k.ln()).abs() < 1e-12));
        let r = distortion(&s, &rigid(s.vertices())).unwrap();
        assert!(r.area_log_max_abs < 1e-12 && r.edge_log_max_abs < 1e-12);
    }

    #[test]
    fn edge_strain_of_scaling_and_rigid_motion() {
        let s = icosphere(2);
        let n_edges = crate::ops::edges(&s).len();
        for k in [0.5f64, 1.25, 2.0] {
            let scaled: Vec<Point> = s
                .vertices()
                .iter()
                .map(|p| Point::from(p.coords * k))
                .collect();
            let e = edge_strains(&s, &scaled).unwrap();
            assert_eq!(e.len(), n_edges);
            assert!(e.iter().all(|x| (x - (k - 1.0).abs()).abs() < 1e-12), "{k}");
            let p99 = percentile(&e, 99.0).unwrap();
            assert!((p99 - (k - 1.0).abs()).abs() < 1e-12);
        }
        let e = edge_strains(&s, &rigid(s.vertices())).unwrap();
        assert!(e.iter().all(|&x| x < 1e-12));
        assert!(percentile(&e, 99.0).unwrap() < 1e-12);
        assert!(edge_strains(&s, &s.vertices()[1..]).is_err());
    }

    #[test]
    fn percentile_and_fractions_of_known_values() {
        let v = [4.0, 1.0, 3.0, 2.0, 5.0];
        assert_eq!(percentile(&v, 0.0).unwrap(), 1.0);
        assert_eq!(percentile(&v, 100.0).unwrap(), 5.0);
        assert_eq!(percentile(&v, 50.0).unwrap(), 3.0);
        // h = 4 · 0.99 = 3.96: 4 + 0.96 · (5 − 4).
        assert!((percentile(&v, 99.0).unwrap() - 4.96).abs() < 1e-12);
        assert_eq!(percentile(&[7.0], 99.0).unwrap(), 7.0);
        assert!(percentile(&[], 50.0).is_err());
        assert!(percentile(&v, 101.0).is_err());
        assert!(percentile(&[1.0, f64::NAN], 50.0).is_err());
        let e = [0.0, 0.01, 0.02, 0.03, 0.05, 0.06, 0.1, 0.2];
        assert_eq!(fraction_within(&e, 0.02), 3.0 / 8.0);
        assert_eq!(fraction_within(&e, 0.05), 5.0 / 8.0);
        assert_eq!(fraction_within(&[], 0.05), 0.0);
        // One point of the cumulative curve.
        let c = cumulative_curve(&e, &[0.02, 0.05]);
        assert_eq!(
            c,
            vec![fraction_within(&e, 0.02), fraction_within(&e, 0.05)]
        );
    }

    #[test]
    fn adjusted_rand_index_values() {
        // Identical up to renaming.
        assert_eq!(
            adjusted_rand_index(&[0, 0, 1, 1], &[5, 5, 2, 2]).unwrap(),
            1.0
        );
        // Hand-computed: a = [0,0,0,1,1,1], b = [0,0,1,1,2,2]:
        // index = 1 + 1 = 2 (pairs (0,0)x2, (0,1), (1,1), (1,2)x2);
        // Σ C(a) = 3 + 3 = 6; Σ C(b) = 1 + 1 + 1 = 3; C(6,2) = 15;
        // expected = 6·3/15 = 1.2; max = 4.5; ARI = 0.8 / 3.3.
        let ari = adjusted_rand_index(&[0, 0, 0, 1, 1, 1], &[0, 0, 1, 1, 2, 2]).unwrap();
        assert!((ari - 0.8 / 3.3).abs() < 1e-12, "{ari}");
        assert!(adjusted_rand_index(&[0], &[0, 1]).is_err());
    }

    #[test]
    fn geodesic_errors_are_zero_on_the_truth_and_scaled_by_area() {
        let s = icosphere(2);
        let truth: Vec<usize> = (0..s.n_vertices()).collect();
        let grid = curve_grid(0.5, 6).unwrap();
        let (e, c) = geodesic_error_curve(&s, &truth, &truth, &grid).unwrap();
        assert!(e.iter().all(|&x| x == 0.0));
        assert!(c.iter().all(|&x| x == 1.0));
        // Neighbour predictions: error = edge length / √area.
        let n = s.faces()[0];
        let (e, _) = geodesic_error_curve(&s, &[n[1]], &[n[0]], &grid).unwrap();
        let len = (s.vertices()[n[1]] - s.vertices()[n[0]]).norm();
        assert!((e[0] - len / total_area(&s).sqrt()).abs() < 1e-12);
        assert!(geodesic_error_curve(&s, &[0], &[s.n_vertices()], &grid).is_err());
    }

    #[test]
    fn rigid_clusters_have_zero_rigidity_residual() {
        let s = icosphere(2);
        let labels: Vec<usize> = s
            .vertices()
            .iter()
            .map(|p| usize::from(p.x > 0.0))
            .collect();
        // Move each half by its own rigid motion.
        let moved: Vec<Point> = s
            .vertices()
            .iter()
            .zip(&labels)
            .map(|(p, &g)| {
                if g == 0 {
                    *p
                } else {
                    rigid(std::slice::from_ref(p))[0]
                }
            })
            .collect();
        let r = cluster_rigidity_rms(s.vertices(), std::slice::from_ref(&moved), &labels).unwrap();
        assert!(r < 1e-12, "{r}");
        let one = vec![0; labels.len()];
        assert!(cluster_rigidity_rms(s.vertices(), &[moved], &one).unwrap() > 0.1);
    }
}

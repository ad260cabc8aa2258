//! The triangle correspondence step of Sumner & Popović 2004 (paper Sec. 5).
//!
//! # Deforming the source onto the target
//!
//! The source reference is deformed towards the target reference by
//! minimising, over the source vertices **and** one fourth vertex per
//! triangle (the transformations `T_i = Ṽ_i V_i⁻¹` of paper Sec. 3),
//!
//! ```text
//! w_S E_S + w_I E_I + w_C E_C,   subject to  x_m = target position of marker m
//! E_S = Σ_i Σ_{j ∈ adj(i)} ‖T_i − T_j‖²_F     (edge-adjacent triangles, each pair once)
//! E_I = Σ_i ‖T_i − I‖²_F
//! E_C = Σ_v ‖x_v − c_v‖² / ℓ²                  (c_v: closest valid point)
//! ```
//!
//! Markers are hard constraints (their vertices are eliminated). Each entry
//! of `T_i` is linear in the four corners, with the same coefficients for
//! the x, y and z coordinates, so one sparse normal matrix serves all three.
//! The paper's schedule: first `w_C = 0`, then `w_C` growing from 1 to 5000
//! in four steps (here geometrically: 1, 17.1, 292, 5000), `w_S = 1`,
//! `w_I = 0.001`; the closest valid points are recomputed before every solve
//! ([`CorrespondenceOptions::iterations_per_stage`] solves per value).
//!
//! **Closest valid point.** For a source vertex at `p` with vertex normal
//! `n` (of the current deformed source), the closest point on the target
//! surface among the triangles incident to the `neighbours` nearest target
//! vertices (kd-tree) whose face normal makes an angle below 90° with `n`
//! ([`CorrespondenceOptions::max_normal_angle_deg`]); if none, the vertex has
//! no `E_C` term in that solve. Restricting the search to the triangles
//! around the nearest vertices is an approximation of the exact closest
//! point on the whole surface.
//!
//! **Length unit.** `E_S` and `E_I` are dimensionless but `E_C` is a squared
//! length, so the paper's weights depend on the units of its meshes (their
//! bounding-box diagonals are 1.1–1.4). Here distances in `E_C` are divided
//! by `ℓ` = [`CorrespondenceOptions::length_scale`], by default the target's
//! bounding-box diagonal, which keeps Sumner's data within a factor 2 of the
//! paper's weighting and makes the step invariant to scaling both meshes.
//!
//! A vanishing Tikhonov term `ε ‖x − x_ref‖²` (`ε` = 1e-9 × the mean diagonal
//! of the matrix) keeps parts without markers well-posed in the first stage
//! (the paper does not need it because its meshes are connected).
//!
//! # Matching triangles
//!
//! After deformation ([`match_triangles`]): every source triangle is paired
//! with the target triangle of nearest centroid among those whose normal is
//! within the angle of its own and whose centroid lies within
//! `match_distance · ℓ`, and every target triangle likewise with the
//! nearest source triangle. The union is a many-to-many list
//! ([`TriangleCorrespondence`]).

use std::time::Instant;

use nalgebra::DMatrix;

use super::sumner::{
    face_adjacency, inverse_frames, DeformationTransfer, SumnerTransferOptions,
    TriangleCorrespondence,
};
use crate::mesh::Mesh;
use crate::ops::closest_point_on_triangle;
use crate::ops::Operators;
use crate::ops::{face_normals, vertex_normals};
use crate::register::PointIndex;
use crate::solve::{sparse_from_triplets, SparseCholesky};
use crate::{Error, Mat3, Point, Result, Vec3};

/// Options of [`correspond`] (defaults: the paper's weights).
#[derive(Clone, Debug, PartialEq)]
pub struct CorrespondenceOptions {
    /// Weight of the smoothness term `E_S`.
    pub w_smooth: f64,
    /// Weight of the identity term `E_I`.
    pub w_identity: f64,
    /// `w_C` of the stages after the first (`w_C = 0`) one.
    pub w_closest: Vec<f64>,
    /// Solves per `w_C` value (closest points recomputed before each).
    pub iterations_per_stage: usize,
    /// Normals of matched points / triangles must differ by less than this.
    pub max_normal_angle_deg: f64,
    /// Nearest target vertices (or centroids) examined per query.
    pub neighbours: usize,
    /// Length unit of `E_C` and of `match_distance`; `None` = the target's
    /// bounding-box diagonal.
    pub length_scale: Option<f64>,
    /// Centroid distance threshold of the triangle matching, in `ℓ`.
    pub match_distance: f64,
}

impl Default for CorrespondenceOptions {
    fn default() -> Self {
        let r = 5000f64.powf(1.0 / 3.0);
        CorrespondenceOptions {
            w_smooth: 1.0,
            w_identity: 0.001,
            w_closest: vec![1.0, r, r * r, 5000.0],
            iterations_per_stage: 1,
            max_normal_angle_deg: 90.0,
            neighbours: 16,
            length_scale: None,
            match_distance: 0.05,
        }
    }
}

/// One solve of the deformation.
#[derive(Clone, Debug, PartialEq)]
pub struct StageStats {
    /// `w_C` of this solve.
    pub w_closest: f64,
    /// Source vertices with a valid closest point (0 in the first stage).
    pub valid_points: usize,
    /// Mean distance to those points before the solve, in `ℓ`.
    pub mean_distance: f64,
    /// Seconds for closest points, assembly, factorisation and solve.
    pub seconds: f64,
}

/// Result of [`correspond`].
#[derive(Clone, Debug)]
pub struct CorrespondenceResult {
    /// The source reference deformed onto the target.
    pub deformed_source: Mesh,
    /// The triangle pairs.
    pub triangles: TriangleCorrespondence,
    /// One entry per solve.
    pub stages: Vec<StageStats>,
    /// Length unit `ℓ` used.
    pub length_scale: f64,
    /// Seconds for the deformation (all stages).
    pub deform_seconds: f64,
    /// Seconds for the triangle matching.
    pub match_seconds: f64,
}

fn bbox_diagonal(mesh: &Mesh) -> f64 {
    let v = mesh.vertices();
    let mut lo = v[0].coords;
    let mut hi = v[0].coords;
    for p in v {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    (hi - lo).norm()
}

fn check_options(o: &CorrespondenceOptions) -> Result<()> {
    let bad = |what: &str, v: f64| {
        Err(Error::invalid(format!(
            "correspondence option {what} = {v} must be finite and ≥ 0"
        )))
    };
    for (what, v) in [
        ("w_smooth", o.w_smooth),
        ("w_identity", o.w_identity),
        ("match_distance", o.match_distance),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return bad(what, v);
        }
    }
    if let Some(&w) = o.w_closest.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
        return bad("w_closest", w);
    }
    if o.w_smooth + o.w_identity <= 0.0 {
        return Err(Error::invalid(
            "correspondence options: w_smooth + w_identity must be > 0",
        ));
    }
    if !(o.max_normal_angle_deg > 0.0 && o.max_normal_angle_deg <= 180.0) {
        return Err(Error::invalid(format!(
            "correspondence option max_normal_angle_deg = {} not in (0, 180]",
            o.max_normal_angle_deg
        )));
    }
    if let Some(l) = o.length_scale {
        if !(l.is_finite() && l > 0.0) {
            return Err(Error::invalid(format!(
                "correspondence option length_scale = {l} must be finite and > 0"
            )));
        }
    }
    Ok(())
}

/// Checks marker pairs `(source vertex, target vertex)` against the meshes.
pub fn check_markers(markers: &[(usize, usize)], n_source: usize, n_target: usize) -> Result<()> {
    for (k, &(s, t)) in markers.iter().enumerate() {
        if s >= n_source || t >= n_target {
            return Err(Error::invalid(format!(
                "marker {k} ({s}, {t}) out of range: source has {n_source} vertices, \
                 target has {n_target}"
            )));
        }
    }
    let mut sorted: Vec<(usize, usize)> = markers.to_vec();
    sorted.sort_unstable();
    for w in sorted.windows(2) {
        if w[0].0 == w[1].0 && w[0].1 != w[1].1 {
            return Err(Error::invalid(format!(
                "source vertex {} is a marker for two target vertices ({} and {})",
                w[0].0, w[0].1, w[1].1
            )));
        }
    }
    Ok(())
}

/// Closest-valid-point search on a fixed target.
struct ClosestValid<'a> {
    target: &'a Mesh,
    tree: PointIndex,
    vf: std::sync::Arc<crate::ops::adjacency::Csr>,
    normals: Vec<Vec3>,
    k: usize,
    cos_max: f64,
}

impl<'a> ClosestValid<'a> {
    fn new(target: &'a Mesh, neighbours: usize, cos_max: f64) -> Result<Self> {
        Ok(ClosestValid {
            target,
            tree: PointIndex::new(target.vertices())?,
            vf: target.incident_faces(),
            normals: face_normals(target),
            k: neighbours,
            cos_max,
        })
    }

    fn query(&self, p: &Point, n: &Vec3) -> Option<Point> {
        let hits = self.tree.nearest_n(p, self.k);
        let tv = self.target.vertices();
        let tf = self.target.faces();
        let mut best: Option<(f64, Point)> = None;
        for h in hits {
            for &f in self.vf.row(h.index) {
                let nf = &self.normals[f];
                if nf.norm_squared() == 0.0 || nf.dot(n) <= self.cos_max {
                    continue;
                }
                let [a, b, c] = tf[f];
                let q = closest_point_on_triangle(p, &tv[a], &tv[b], &tv[c]);
                let d = (q - p).norm_squared();
                if best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, q));
                }
            }
        }
        best.map(|(_, q)| q)
    }
}

/// A linear row over the unknowns: `Σ coef · x_var` for each coordinate.
struct Row {
    terms: Vec<(usize, f64)>,
    target: [f64; 3],
    weight: f64,
}

/// Deforms `source` onto `target` with the marker pairs `(source vertex,
/// target vertex)` and matches triangles (see the module documentation).
pub fn correspond(
    source: &Mesh,
    target: &Mesh,
    markers: &[(usize, usize)],
    opts: &CorrespondenceOptions,
) -> Result<CorrespondenceResult> {
    check_options(opts)?;
    check_markers(markers, source.n_vertices(), target.n_vertices())?;
    let t_start = Instant::now();
    let ell = opts.length_scale.unwrap_or_else(|| bbox_diagonal(target));
    if !(ell.is_finite() && ell > 0.0) {
        return Err(Error::invalid(format!(
            "target bounding-box diagonal {ell} cannot serve as length unit"
        )));
    }
    let n = source.n_vertices();
    let faces = source.faces();
    let inv = inverse_frames(source);
    let valid: Vec<bool> = inv.iter().map(Option::is_some).collect();
    // Variable numbering: vertices, then one fourth vertex per valid face.
    let mut v4 = vec![usize::MAX; faces.len()];
    let mut nvar = n;
    for (f, ok) in valid.iter().enumerate() {
        if *ok {
            v4[f] = nvar;
            nvar += 1;
        }
    }
    // Reference positions of all variables.
    let sv = source.vertices();
    let mut x0: Vec<Point> = sv.to_vec();
    for (f, fc) in faces.iter().enumerate() {
        if valid[f] {
            let (a, b, c) = (sv[fc[0]], sv[fc[1]], sv[fc[2]]);
            let cr = (b - a).cross(&(c - a));
            x0.push(a + cr / cr.norm().sqrt());
        }
    }
    // Coefficients: entry (k, c) of T_f = Σ_j x_j[k] coef_j[c].
    let coefs = |f: usize| -> [(usize, Vec3); 4] {
        let w: Mat3 = inv[f].unwrap_or_else(Mat3::zeros);
        let (w1, w2, w3): (Vec3, Vec3, Vec3) = (
            w.row(0).transpose(),
            w.row(1).transpose(),
            w.row(2).transpose(),
        );
        let fc = faces[f];
        [
            (fc[0], -w1 - w2 - w3),
            (fc[1], w1),
            (fc[2], w2),
            (v4[f], w3),
        ]
    };
    // Fixed variables: markers (at target positions).
    let tv = target.vertices();
    let mut fixed: Vec<Option<Point>> = vec![None; nvar];
    for &(s, t) in markers {
        fixed[s] = Some(tv[t]);
    }
    let mut free = vec![usize::MAX; nvar];
    let mut nfree = 0;
    for i in 0..nvar {
        if fixed[i].is_none() {
            free[i] = nfree;
            nfree += 1;
        }
    }
    if nfree == 0 {
        return Err(Error::invalid(
            "every source vertex is a marker: nothing to solve",
        ));
    }
    // Rows of E_I and E_S.
    let mut rows: Vec<Row> = Vec::new();
    if opts.w_identity > 0.0 {
        for f in (0..faces.len()).filter(|&f| valid[f]) {
            let cf = coefs(f);
            for c in 0..3 {
                let mut target = [0.0; 3];
                target[c] = 1.0;
                rows.push(Row {
                    terms: cf.iter().map(|(v, a)| (*v, a[c])).collect(),
                    target,
                    weight: opts.w_identity,
                });
            }
        }
    }
    if opts.w_smooth > 0.0 {
        let adj = face_adjacency(faces, &valid);
        for (f, nb) in adj.iter().enumerate() {
            for &g in nb.iter().filter(|&&g| g > f) {
                let (cf, cg) = (coefs(f), coefs(g));
                for c in 0..3 {
                    let mut terms: Vec<(usize, f64)> = cf.iter().map(|(v, a)| (*v, a[c])).collect();
                    terms.extend(cg.iter().map(|(v, a)| (*v, -a[c])));
                    rows.push(Row {
                        terms,
                        target: [0.0; 3],
                        weight: opts.w_smooth,
                    });
                }
            }
        }
    }
    // Normal equations of the fixed part.
    let mut trip: Vec<(usize, usize, f64)> = Vec::new();
    let mut rhs0 = DMatrix::<f64>::zeros(nfree, 3);
    let mut diag = vec![0.0; nfree];
    for r in &rows {
        let mut t = r.target;
        for &(v, a) in &r.terms {
            if let Some(p) = fixed[v] {
                for k in 0..3 {
                    t[k] -= a * p[k];
                }
            }
        }
        for &(va, a) in &r.terms {
            let ia = free[va];
            if ia == usize::MAX {
                continue;
            }
            for k in 0..3 {
                rhs0[(ia, k)] += r.weight * a * t[k];
            }
            for &(vb, b) in &r.terms {
                let ib = free[vb];
                if ib != usize::MAX {
                    trip.push((ia, ib, r.weight * a * b));
                    if ia == ib {
                        diag[ia] += r.weight * a * b;
                    }
                }
            }
        }
    }
    drop(rows);
    let eps = 1e-9 * diag.iter().sum::<f64>() / nfree as f64;
    let eps = if eps > 0.0 { eps } else { 1e-12 };
    for i in 0..nvar {
        let fi = free[i];
        if fi != usize::MAX {
            trip.push((fi, fi, eps));
            for k in 0..3 {
                rhs0[(fi, k)] += eps * x0[i][k];
            }
        }
    }
    let cos_max = opts.max_normal_angle_deg.to_radians().cos();
    let search = ClosestValid::new(target, opts.neighbours, cos_max)?;

    let mut x = x0.clone();
    for (i, p) in fixed.iter().enumerate() {
        if let Some(p) = p {
            x[i] = *p;
        }
    }
    let mut schedule = vec![0.0];
    for &w in &opts.w_closest {
        for _ in 0..opts.iterations_per_stage.max(1) {
            schedule.push(w);
        }
    }
    let mut stages = Vec::with_capacity(schedule.len());
    let w_scale = 1.0 / (ell * ell);
    for &wc in &schedule {
        let t0 = Instant::now();
        let mut t = trip.clone();
        let mut rhs = rhs0.clone();
        let (mut count, mut dsum) = (0usize, 0.0);
        if wc > 0.0 {
            let deformed = source.with_vertices(x[..n].to_vec())?;
            let normals = vertex_normals(&deformed);
            let cps: Vec<Option<Point>> =
                (0..n).map(|i| search.query(&x[i], &normals[i])).collect();
            let w = wc * w_scale;
            for (i, cp) in cps.iter().enumerate() {
                let Some(c) = cp else { continue };
                count += 1;
                dsum += (c - x[i]).norm() / ell;
                let fi = free[i];
                if fi == usize::MAX {
                    continue;
                }
                t.push((fi, fi, w));
                for k in 0..3 {
                    rhs[(fi, k)] += w * c[k];
                }
            }
        }
        let m = sparse_from_triplets(nfree, nfree, t);
        let chol = SparseCholesky::new(&m).map_err(|e| {
            Error::numerical(format!(
                "correspondence step (w_C = {wc}, {nfree} unknowns): {e}"
            ))
        })?;
        let sol = chol.try_solve(&rhs)?;
        for i in 0..nvar {
            let fi = free[i];
            if fi != usize::MAX {
                x[i] = Point::new(sol[(fi, 0)], sol[(fi, 1)], sol[(fi, 2)]);
            }
        }
        stages.push(StageStats {
            w_closest: wc,
            valid_points: count,
            mean_distance: if count > 0 { dsum / count as f64 } else { 0.0 },
            seconds: t0.elapsed().as_secs_f64(),
        });
    }
    let deformed_source = source
        .with_vertices(x[..n].to_vec())
        .map_err(|e| Error::numerical(format!("correspondence step produced a bad mesh: {e}")))?;
    let deform_seconds = t_start.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let triangles = match_triangles(
        &deformed_source,
        target,
        opts.match_distance * ell,
        opts.max_normal_angle_deg,
        opts.neighbours,
    )?;
    Ok(CorrespondenceResult {
        deformed_source,
        triangles,
        stages,
        length_scale: ell,
        deform_seconds,
        match_seconds: t1.elapsed().as_secs_f64(),
    })
}

fn centroids(mesh: &Mesh) -> Vec<Point> {
    let v = mesh.vertices();
    mesh.faces()
        .iter()
        .map(|f| Point::from((v[f[0]].coords + v[f[1]].coords + v[f[2]].coords) / 3.0))
        .collect()
}

/// Pairs every triangle of `a` with the triangle of `b` of nearest centroid
/// among the `neighbours` nearest whose normal is within `max_angle_deg` and
/// whose centroid is within `max_distance` (absolute units).
fn one_way(
    a: &Mesh,
    b: &Mesh,
    max_distance: f64,
    cos_max: f64,
    neighbours: usize,
) -> Result<Vec<(usize, usize)>> {
    let (ca, cb) = (centroids(a), centroids(b));
    let (na, nb) = (face_normals(a), face_normals(b));
    let tree = PointIndex::new(&cb)?;
    let d2max = max_distance * max_distance;
    let mut out = Vec::new();
    for (i, p) in ca.iter().enumerate() {
        if na[i].norm_squared() == 0.0 {
            continue;
        }
        let hits = tree.nearest_n(p, neighbours);
        if let Some(h) = hits.iter().find(|h| {
            let j = h.index;
            h.distance_squared <= d2max && nb[j].norm_squared() > 0.0 && nb[j].dot(&na[i]) > cos_max
        }) {
            out.push((i, h.index));
        }
    }
    Ok(out)
}

/// Triangle pairs between a source deformed onto the target and the target:
/// nearest compatible centroid in both directions (see the module
/// documentation); `max_distance` is absolute.
pub fn match_triangles(
    deformed_source: &Mesh,
    target: &Mesh,
    max_distance: f64,
    max_normal_angle_deg: f64,
    neighbours: usize,
) -> Result<TriangleCorrespondence> {
    let cos_max = max_normal_angle_deg.to_radians().cos();
    let mut pairs = one_way(deformed_source, target, max_distance, cos_max, neighbours)?;
    pairs.extend(
        one_way(target, deformed_source, max_distance, cos_max, neighbours)?
            .into_iter()
            .map(|(t, s)| (s, t)),
    );
    TriangleCorrespondence::new(pairs, deformed_source.n_faces(), target.n_faces())
}

/// The full Sumner–Popović pipeline (in this module, beside the
/// correspondence step it runs first, so that `sumner` does not import it).
impl DeformationTransfer {
    /// The full pipeline for meshes with different connectivity: the
    /// correspondence step ([`correspond`]) with the marker pairs `(source
    /// vertex, target vertex)`, then [`DeformationTransfer::new`] on its
    /// triangle pairs.
    pub fn from_markers(
        source_reference: &Mesh,
        target_reference: &Mesh,
        markers: &[(usize, usize)],
        correspondence: &CorrespondenceOptions,
        opts: &SumnerTransferOptions,
    ) -> Result<(Self, CorrespondenceResult)> {
        let res = correspond(source_reference, target_reference, markers, correspondence)?;
        let dt = Self::new(source_reference, target_reference, &res.triangles, opts)?;
        Ok((dt, res))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = (
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0, 0.0),
            Point::new(0.0, 1.0, 0.0),
        );
        let cases = [
            (Point::new(0.2, 0.2, 1.0), Point::new(0.2, 0.2, 0.0)),
            (Point::new(-1.0, -1.0, 0.0), a),
            (Point::new(2.0, -0.5, 0.0), b),
            (Point::new(0.5, -1.0, 3.0), Point::new(0.5, 0.0, 0.0)),
            (Point::new(1.0, 1.0, 0.0), Point::new(0.5, 0.5, 0.0)),
            (Point::new(-1.0, 0.5, 0.0), Point::new(0.0, 0.5, 0.0)),
        ];
        for (p, want) in cases {
            let got = closest_point_on_triangle(&p, &a, &b, &c);
            assert!((got - want).norm() < 1e-12, "{p} → {got}, want {want}");
        }
    }
}

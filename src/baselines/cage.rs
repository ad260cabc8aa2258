//! Cage-based spatial deformation transfer, after Ben-Chen, Weber & Gotsman
//! 2009, "Spatial deformation transfer" (SCA 2009).
//!
//! # What the paper does
//!
//! Each shape is enclosed in a coarse cage; the shape's vertices are
//! expressed in cage coordinates (the paper uses Green coordinates and
//! mean-value coordinates); for every source pose a cage deformation is
//! fitted so that the cage-coordinate reconstruction matches the pose (a
//! least-squares fit with a smoothness term on the cage); the cage
//! deformations are transferred to the target's cage with Sumner-style
//! deformation transfer of per-cage-face deformation gradients through a
//! correspondence between the cages built from user markers; the target
//! follows its deformed cage through its own coordinates.
//!
//! # What is implemented here, and every simplification
//!
//! * **Automatic cage** ([`build_cage`]): *not* a shape-following offset
//!   surface but an **oriented bounding box**, enlarged by `margin` times
//!   the bounding-box diagonal on every side, whose six faces are split into
//!   `subdivisions × subdivisions` quads (two triangles each): `6k² + 2`
//!   cage vertices. The source box's axes are the principal axes of the
//!   source reference vertices (right-handed, by decreasing variance); the
//!   target box uses the **same axes rotated by the best rigid rotation of
//!   the source markers onto the target markers** (Kabsch; the source axes
//!   unchanged with fewer than 3 markers), with its own extents. Both cages
//!   therefore share one connectivity and cage vertex `j` of the source
//!   corresponds to cage vertex `j` of the target: this replaces the
//!   paper's marker-driven cage correspondence step (the markers only orient
//!   the target box). A box cage is far coarser than the paper's cages: it
//!   cannot separate limbs, so articulated poses are fitted poorly; this is
//!   the main weakness of this baseline and is measured by the fit error.
//! * **Coordinates**: mean-value coordinates only (Ju, Schaefer & Warren
//!   2005, triangle-mesh version, [`mean_value_coordinates`]); no Green
//!   coordinates (which the paper prefers for their shape preservation).
//! * **Cage fit** ([`CageFit`]): `min_C ‖Φ C − V‖² + λ' ‖L (C − C₀)‖²` with
//!   `Φ` the coordinates of the shape's reference vertices, `L` the uniform
//!   graph Laplacian of the cage, `C₀` the rest cage and
//!   `λ' = smoothness · tr(ΦᵀΦ) / tr(LᵀL)` (scale free). One dense Cholesky
//!   factorisation per shape; each pose costs a back-substitution.
//! * **Transfer** ([`CageTransfer`]): Sumner & Popović deformation transfer
//!   ([`super::DeformationTransfer`], per-face gradients with the fourth
//!   vertex) from the source cage to the target cage with the identity face
//!   correspondence (same connectivity by construction). The target result
//!   is `Φ_t C_t′`.
//! * **Translation**: deformation transfer fixes shapes up to a translation;
//!   the result is translated so that the centroid of the target marker
//!   vertices moves by the same vector as the centroid of the source marker
//!   vertices in the pose (the paper does not discuss this; it is the same
//!   convention as the harness's Sumner rows).
//! * Not implemented: the paper's interactive cage editing, per-part cages,
//!   the Green-coordinate variant and its normal terms.

use nalgebra::{DMatrix, SymmetricEigen};

use super::sumner::{DeformationTransfer, SumnerTransferOptions, TriangleCorrespondence};
use crate::eval::procrustes;
use crate::mesh::{Face, Mesh};
use crate::{Error, Mat3, Point, Result, Vec3};

/// Options of the cage baseline.
#[derive(Clone, Debug, PartialEq)]
pub struct CageOptions {
    /// Quads per box edge (`k`; the cage has `6k² + 2` vertices).
    pub subdivisions: usize,
    /// Enlargement of the box on every side, in bounding-box diagonals.
    pub margin: f64,
    /// Weight of the cage Laplacian regulariser (relative, see the module
    /// documentation).
    pub smoothness: f64,
}

impl Default for CageOptions {
    fn default() -> Self {
        CageOptions {
            subdivisions: 4,
            margin: 0.05,
            smoothness: 0.01,
        }
    }
}

impl CageOptions {
    fn check(&self) -> Result<()> {
        if self.subdivisions == 0 || self.subdivisions > 64 {
            return Err(Error::invalid(format!(
                "cage subdivisions = {} must be in 1..=64",
                self.subdivisions
            )));
        }
        if !(self.margin.is_finite() && self.margin > 0.0) {
            return Err(Error::invalid(format!(
                "cage margin = {} must be finite and > 0",
                self.margin
            )));
        }
        if !(self.smoothness.is_finite() && self.smoothness >= 0.0) {
            return Err(Error::invalid(format!(
                "cage smoothness = {} must be finite and ≥ 0",
                self.smoothness
            )));
        }
        Ok(())
    }
}

/// Principal axes of a point set as the columns of a rotation (decreasing
/// variance, determinant +1).
pub fn principal_axes(points: &[Point]) -> Result<Mat3> {
    if points.is_empty() {
        return Err(Error::invalid("principal axes of an empty point set"));
    }
    let n = points.len() as f64;
    let c = points.iter().fold(Vec3::zeros(), |s, p| s + p.coords) / n;
    let mut cov = Mat3::zeros();
    for p in points {
        let d = p.coords - c;
        cov += d * d.transpose();
    }
    if !cov.iter().all(|x| x.is_finite()) {
        return Err(Error::invalid("non-finite vertex coordinates"));
    }
    let eig = SymmetricEigen::new(cov);
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&a, &b| {
        eig.eigenvalues[b]
            .total_cmp(&eig.eigenvalues[a])
            .then(a.cmp(&b))
    });
    let mut r = Mat3::zeros();
    for (k, &i) in idx.iter().enumerate() {
        let mut v: Vec3 = eig.eigenvectors.column(i).into_owned();
        // Deterministic sign: largest component positive.
        let (mut big, mut bi) = (0.0, 0);
        for (j, x) in v.iter().enumerate() {
            if x.abs() > big {
                big = x.abs();
                bi = j;
            }
        }
        if v[bi] < 0.0 {
            v = -v;
        }
        r.set_column(k, &v);
    }
    if r.determinant() < 0.0 {
        let c2: Vec3 = -r.column(2).into_owned();
        r.set_column(2, &c2);
    }
    Ok(r)
}

/// The box cage of `points` along the orthonormal `axes` (columns),
/// enlarged by `margin` bounding-box diagonals on every side, each face split
/// into `subdivisions²` quads (outward-oriented triangles).
pub fn build_cage(points: &[Point], axes: &Mat3, opts: &CageOptions) -> Result<Mesh> {
    opts.check()?;
    if points.is_empty() {
        return Err(Error::invalid("cage of an empty point set"));
    }
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    let (mut blo, mut bhi) = (lo, hi);
    for p in points {
        let q = axes.transpose() * p.coords;
        lo = lo.inf(&q);
        hi = hi.sup(&q);
        blo = blo.inf(&p.coords);
        bhi = bhi.sup(&p.coords);
    }
    let diag = (bhi - blo).norm();
    if !(diag.is_finite() && diag > 0.0) {
        return Err(Error::invalid(
            "cage of a degenerate point set (zero or non-finite extent)",
        ));
    }
    let pad = opts.margin * diag;
    lo -= Vec3::repeat(pad);
    hi += Vec3::repeat(pad);
    let k = opts.subdivisions;
    let mut index = std::collections::HashMap::new();
    let mut verts: Vec<Point> = Vec::new();
    let mut id = |l: [usize; 3], verts: &mut Vec<Point>| -> usize {
        *index.entry(l).or_insert_with(|| {
            let mut q = Vec3::zeros();
            for d in 0..3 {
                q[d] = lo[d] + (hi[d] - lo[d]) * l[d] as f64 / k as f64;
            }
            verts.push(Point::from(axes * q));
            verts.len() - 1
        })
    };
    let mut faces: Vec<Face> = Vec::new();
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for s in [0, k] {
            for u in 0..k {
                for v in 0..k {
                    let lat = |du: usize, dv: usize| {
                        let mut l = [0; 3];
                        l[a] = s;
                        l[b] = u + du;
                        l[c] = v + dv;
                        l
                    };
                    let q = [
                        id(lat(0, 0), &mut verts),
                        id(lat(1, 0), &mut verts),
                        id(lat(1, 1), &mut verts),
                        id(lat(0, 1), &mut verts),
                    ];
                    // e_b × e_c = e_a: counter-clockwise in (b, c) faces +a.
                    if s == k {
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    } else {
                        faces.push([q[0], q[2], q[1]]);
                        faces.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    Mesh::new(verts, faces)
}

/// Mean-value coordinates (Ju, Schaefer & Warren 2005) of `x` with respect
/// to the closed, consistently oriented triangle cage `cage`: weights `φ_j`
/// with `Σ φ_j = 1` and `Σ φ_j c_j = x` (linear precision). Points on the
/// cage get their barycentric coordinates on the face they lie on.
pub fn mean_value_coordinates(cage: &Mesh, x: &Point) -> Result<Vec<f64>> {
    const EPS: f64 = 1e-12;
    let cv = cage.vertices();
    let m = cv.len();
    let mut w = vec![0.0; m];
    let mut d = vec![0.0; m];
    let mut u = vec![Vec3::zeros(); m];
    for j in 0..m {
        let r = cv[j] - x;
        d[j] = r.norm();
        if d[j] < EPS {
            w[j] = 1.0;
            return Ok(w);
        }
        u[j] = r / d[j];
    }
    for f in cage.faces() {
        let l = |i: usize, j: usize| (u[f[i]] - u[f[j]]).norm();
        let th = [
            2.0 * (l(1, 2) / 2.0).min(1.0).asin(),
            2.0 * (l(2, 0) / 2.0).min(1.0).asin(),
            2.0 * (l(0, 1) / 2.0).min(1.0).asin(),
        ];
        let h = (th[0] + th[1] + th[2]) / 2.0;
        if std::f64::consts::PI - h < 1e-9 {
            // x lies on the face: 2D barycentric coordinates.
            let mut out = vec![0.0; m];
            let mut s = 0.0;
            for i in 0..3 {
                let v = th[i].sin() * d[f[(i + 2) % 3]] * d[f[(i + 1) % 3]];
                out[f[i]] += v;
                s += v;
            }
            if s > 0.0 {
                out.iter_mut().for_each(|v| *v /= s);
                return Ok(out);
            }
            continue;
        }
        let det = Mat3::from_columns(&[u[f[0]], u[f[1]], u[f[2]]]).determinant();
        let sign = if det < 0.0 { -1.0 } else { 1.0 };
        let mut c = [0.0; 3];
        let mut s = [0.0; 3];
        let mut skip = false;
        for i in 0..3 {
            let (ip, im) = ((i + 1) % 3, (i + 2) % 3);
            let den = th[ip].sin() * th[im].sin();
            if den.abs() < EPS {
                skip = true;
                break;
            }
            c[i] = (2.0 * h.sin() * (h - th[i]).sin() / den - 1.0).clamp(-1.0, 1.0);
            s[i] = sign * (1.0 - c[i] * c[i]).max(0.0).sqrt();
            if s[i].abs() <= 1e-10 {
                skip = true;
                break;
            }
        }
        if skip {
            // x on the face's plane, outside it: no contribution.
            continue;
        }
        for i in 0..3 {
            let (ip, im) = ((i + 1) % 3, (i + 2) % 3);
            w[f[i]] += (th[i] - c[ip] * th[im] - c[im] * th[ip]) / (d[f[i]] * th[ip].sin() * s[im]);
        }
    }
    let total: f64 = w.iter().sum();
    if !(total.is_finite() && total.abs() > EPS) {
        return Err(Error::numerical(format!(
            "mean-value coordinates of ({:.4}, {:.4}, {:.4}): weights sum to {total}",
            x.x, x.y, x.z
        )));
    }
    w.iter_mut().for_each(|v| *v /= total);
    Ok(w)
}

/// Coordinates of every point (rows) w.r.t. the cage vertices (columns).
pub fn coordinate_matrix(cage: &Mesh, points: &[Point]) -> Result<DMatrix<f64>> {
    let mut phi = DMatrix::zeros(points.len(), cage.n_vertices());
    for (i, p) in points.iter().enumerate() {
        let w = mean_value_coordinates(cage, p)?;
        for (j, x) in w.into_iter().enumerate() {
            phi[(i, j)] = x;
        }
    }
    Ok(phi)
}

/// `Φ · C` as points.
pub fn apply_coordinates(phi: &DMatrix<f64>, cage: &[Point]) -> Vec<Point> {
    let c = DMatrix::from_fn(cage.len(), 3, |i, k| cage[i][k]);
    let v = phi * c;
    (0..v.nrows())
        .map(|i| Point::new(v[(i, 0)], v[(i, 1)], v[(i, 2)]))
        .collect()
}

/// A shape in its cage with the factorised least-squares cage fit.
#[derive(Clone, Debug)]
pub struct CageFit {
    cage: Mesh,
    phi: DMatrix<f64>,
    chol: nalgebra::Cholesky<f64, nalgebra::Dyn>,
    /// `λ' LᵀL C₀`.
    reg_rhs: DMatrix<f64>,
}

impl CageFit {
    /// Coordinates of `reference` in `cage` and the fit's factorisation.
    pub fn new(reference: &Mesh, cage: Mesh, smoothness: f64) -> Result<Self> {
        let phi = coordinate_matrix(&cage, reference.vertices())?;
        let m = cage.n_vertices();
        let mut lap = DMatrix::<f64>::zeros(m, m);
        let mut nb: Vec<Vec<usize>> = vec![Vec::new(); m];
        for f in cage.faces() {
            for i in 0..3 {
                let (a, b) = (f[i], f[(i + 1) % 3]);
                if !nb[a].contains(&b) {
                    nb[a].push(b);
                    nb[b].push(a);
                }
            }
        }
        for (i, n) in nb.iter().enumerate() {
            lap[(i, i)] = 1.0;
            for &j in n {
                lap[(i, j)] = -1.0 / n.len() as f64;
            }
        }
        let ltl = lap.transpose() * &lap;
        let ptp = phi.transpose() * &phi;
        let lam = smoothness * ptp.trace() / ltl.trace().max(f64::MIN_POSITIVE);
        let c0 = DMatrix::from_fn(m, 3, |i, k| cage.vertices()[i][k]);
        let reg_rhs = &ltl * c0 * lam;
        let mut normal = ptp + ltl * lam;
        // A tiny ridge keeps the system definite when smoothness = 0 and a
        // cage vertex has (numerically) no influence.
        let ridge = 1e-12 * normal.trace() / m as f64;
        for i in 0..m {
            normal[(i, i)] += ridge;
        }
        let chol = nalgebra::Cholesky::new(normal)
            .ok_or_else(|| Error::numerical("cage fit normal matrix is not positive definite"))?;
        Ok(CageFit {
            cage,
            phi,
            chol,
            reg_rhs,
        })
    }

    /// The rest cage.
    pub fn cage(&self) -> &Mesh {
        &self.cage
    }

    /// Mean-value coordinates of the reference vertices (rows).
    pub fn coordinates(&self) -> &DMatrix<f64> {
        &self.phi
    }

    /// The cage fitted to `pose` (positions of the reference's vertices).
    pub fn fit(&self, pose: &[Point]) -> Result<Vec<Point>> {
        if pose.len() != self.phi.nrows() {
            return Err(Error::invalid(format!(
                "cage fit: pose has {} vertices, the reference {}",
                pose.len(),
                self.phi.nrows()
            )));
        }
        let v = DMatrix::from_fn(pose.len(), 3, |i, k| pose[i][k]);
        let rhs = self.phi.transpose() * v + &self.reg_rhs;
        let c = self.chol.solve(&rhs);
        Ok((0..c.nrows())
            .map(|i| Point::new(c[(i, 0)], c[(i, 1)], c[(i, 2)]))
            .collect())
    }

    /// The shape deformed by the cage positions `cage` (`Φ C`).
    pub fn deform(&self, cage: &[Point]) -> Result<Vec<Point>> {
        if cage.len() != self.phi.ncols() {
            return Err(Error::invalid(format!(
                "cage deformation: {} cage positions for {} cage vertices",
                cage.len(),
                self.phi.ncols()
            )));
        }
        Ok(apply_coordinates(&self.phi, cage))
    }
}

/// One transferred pose with its intermediate cages.
#[derive(Clone, Debug)]
pub struct CageTransferred {
    pub mesh: Mesh,
    /// The source cage fitted to the pose.
    pub source_cage: Vec<Point>,
    /// Mean distance between the fitted source shape `Φ_s C_s′` and the pose.
    pub fit_error: f64,
}

/// Cage-based spatial deformation transfer from a source reference to a
/// target reference (see the module documentation).
#[derive(Debug)]
pub struct CageTransfer {
    source: CageFit,
    target: CageFit,
    dt: DeformationTransfer,
    markers: Vec<(usize, usize)>,
    source_reference: Mesh,
    target_reference: Mesh,
}

impl CageTransfer {
    /// Builds both cages (the target's oriented by the markers), their
    /// coordinates, the source fit and the cage-to-cage deformation
    /// transfer. `markers` are `(source vertex, target vertex)` pairs; at
    /// least one is needed (translation).
    pub fn new(
        source_reference: &Mesh,
        target_reference: &Mesh,
        markers: &[(usize, usize)],
        opts: &CageOptions,
    ) -> Result<Self> {
        opts.check()?;
        let (ns, nt) = (source_reference.n_vertices(), target_reference.n_vertices());
        if markers.is_empty() {
            return Err(Error::invalid("cage transfer needs at least one marker"));
        }
        if let Some(&(s, t)) = markers.iter().find(|&&(s, t)| s >= ns || t >= nt) {
            return Err(Error::invalid(format!(
                "marker ({s}, {t}) out of range (source has {ns} vertices, target {nt})"
            )));
        }
        let axes = principal_axes(source_reference.vertices())?;
        let taxes = if markers.len() >= 3 {
            let sp: Vec<Point> = markers
                .iter()
                .map(|&(s, _)| source_reference.vertices()[s])
                .collect();
            let tp: Vec<Point> = markers
                .iter()
                .map(|&(_, t)| target_reference.vertices()[t])
                .collect();
            procrustes(&sp, &tp)?.rotation * axes
        } else {
            axes
        };
        let scage = build_cage(source_reference.vertices(), &axes, opts)?;
        let tcage = build_cage(target_reference.vertices(), &taxes, opts)?;
        let source = CageFit::new(source_reference, scage, opts.smoothness)?;
        let target = CageFit::new(target_reference, tcage, opts.smoothness)?;
        let dt = DeformationTransfer::new(
            source.cage(),
            target.cage(),
            &TriangleCorrespondence::identity(source.cage().n_faces()),
            &SumnerTransferOptions::default(),
        )?;
        Ok(CageTransfer {
            source,
            target,
            dt,
            markers: markers.to_vec(),
            source_reference: source_reference.clone(),
            target_reference: target_reference.clone(),
        })
    }

    /// The source shape's cage fit.
    pub fn source(&self) -> &CageFit {
        &self.source
    }

    /// The target shape's cage and coordinates.
    pub fn target(&self) -> &CageFit {
        &self.target
    }

    /// Transfers one source pose (same connectivity as the source reference).
    pub fn transfer(&self, pose: &Mesh) -> Result<CageTransferred> {
        if pose.n_vertices() != self.source_reference.n_vertices() {
            return Err(Error::invalid(format!(
                "source pose has {} vertices, the source reference {}",
                pose.n_vertices(),
                self.source_reference.n_vertices()
            )));
        }
        let sc = self.source.fit(pose.vertices())?;
        let fitted = self.source.deform(&sc)?;
        let fit_error = fitted
            .iter()
            .zip(pose.vertices())
            .map(|(a, b)| (a - b).norm())
            .sum::<f64>()
            / fitted.len().max(1) as f64;
        let tc = self
            .dt
            .transfer(&self.source.cage().with_vertices(sc.clone())?)?;
        let mut v = self.target.deform(tc.vertices())?;
        // Translation: target marker centroid moves like the source one.
        let k = self.markers.len() as f64;
        let (sv, sr) = (pose.vertices(), self.source_reference.vertices());
        let tr = self.target_reference.vertices();
        let mut want = Vec3::zeros();
        let mut have = Vec3::zeros();
        for &(s, t) in &self.markers {
            want += (sv[s] - sr[s]) + tr[t].coords;
            have += v[t].coords;
        }
        let shift = (want - have) / k;
        v.iter_mut().for_each(|p| *p += shift);
        Ok(CageTransferred {
            mesh: self.target_reference.with_vertices(v)?,
            source_cage: sc,
            fit_error,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cage_counts_and_closed() {
        let pts = vec![
            Point::new(0.0, 0.0, 0.0),
            Point::new(2.0, 1.0, 0.5),
            Point::new(1.0, -1.0, 0.2),
            Point::new(0.3, 0.2, 1.0),
        ];
        let ax = principal_axes(&pts).unwrap();
        let c = build_cage(&pts, &ax, &CageOptions::default()).unwrap();
        assert_eq!(c.n_vertices(), 6 * 16 + 2);
        assert_eq!(c.n_faces(), 6 * 16 * 2);
        // Closed: every edge in exactly two faces, opposite directions.
        let mut e = std::collections::HashMap::new();
        for f in c.faces() {
            for i in 0..3 {
                *e.entry((f[i], f[(i + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &e {
            assert_eq!(n, 1);
            assert_eq!(e.get(&(b, a)), Some(&1));
        }
    }
}

//! Cotangent Laplacian and mass matrices.
//!
//! **Obtuse and near-degenerate triangles.** The cotangent matrix is the
//! stiffness matrix of linear finite elements, assembled exactly: an obtuse
//! angle gives a negative cotangent and so a positive off-diagonal entry. The
//! matrix stays symmetric positive semi-definite with zero row sums (each
//! element's contribution is), but it is then not an M-matrix (no discrete
//! maximum principle). A triangle whose doubled area is below
//! `DEGENERATE_REL · (longest edge)²` contributes nothing: this is the limit of
//! a vanishing element and keeps needles from injecting cotangents of 1e10 and
//! more. Such faces are reported by the defect report.

use crate::mesh::Mesh;
use crate::solve::{sparse_from_triplets, SparseMatrix};

/// Faces with `2·area < DEGENERATE_REL · longest_edge²` are skipped by the
/// operators in this module.
pub const DEGENERATE_REL: f64 = 1e-10;

/// Which lumped mass matrix to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MassKind {
    /// Mixed Voronoi areas (Meyer et al. 2003): Voronoi cells for
    /// non-obtuse triangles, area/2 to the obtuse corner and area/4 to the
    /// others for obtuse ones.
    #[default]
    Voronoi,
    /// One third of each adjacent triangle's area.
    Barycentric,
}

/// Per-face corner cotangents: `cot[f][k]` is the cotangent of the angle at
/// corner `k` of face `f` (opposite the edge between the other two corners),
/// or `None` for a face skipped as degenerate.
fn corner_cotangents(mesh: &Mesh) -> Vec<Option<[f64; 3]>> {
    let v = mesh.vertices();
    mesh.faces()
        .iter()
        .map(|f| {
            let p = [v[f[0]], v[f[1]], v[f[2]]];
            let cross2 = (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
            let longest = (0..3)
                .map(|k| (p[(k + 1) % 3] - p[k]).norm_squared())
                .fold(0.0, f64::max);
            // Written so that a NaN area also counts as degenerate.
            let keep = cross2 >= DEGENERATE_REL * longest && longest != 0.0;
            if !keep {
                return None;
            }
            let mut c = [0.0; 3];
            for (k, ck) in c.iter_mut().enumerate() {
                let a = p[(k + 1) % 3] - p[k];
                let b = p[(k + 2) % 3] - p[k];
                *ck = a.dot(&b) / cross2;
            }
            Some(c)
        })
        .collect()
}

/// Symmetric cotangent edge weights `w_ij = ½ (cot α_ij + cot β_ij)` for each
/// undirected edge `(i, j)`, `i < j` (one term for boundary edges). Sorted by
/// edge. These are the `w̃_ij` of ARAP (BDT Eq. 3).
pub fn cotan_weights(mesh: &Mesh) -> Vec<((usize, usize), f64)> {
    let mut w: Vec<((usize, usize), f64)> = Vec::with_capacity(mesh.n_faces() * 3);
    for (f, cot) in mesh.faces().iter().zip(corner_cotangents(mesh)) {
        let Some(cot) = cot else { continue };
        for k in 0..3 {
            let (i, j) = (f[(k + 1) % 3], f[(k + 2) % 3]);
            w.push(((i.min(j), i.max(j)), 0.5 * cot[k]));
        }
    }
    w.sort_unstable_by_key(|e| e.0);
    let mut out: Vec<((usize, usize), f64)> = Vec::with_capacity(w.len() / 2 + 1);
    for (e, x) in w {
        match out.last_mut() {
            Some((le, lx)) if *le == e => *lx += x,
            _ => out.push((e, x)),
        }
    }
    out
}

/// Positive semi-definite cotangent Laplacian `L` (n × n): `L_ij = -w_ij`,
/// `L_ii = Σ_j w_ij`. Symmetric with zero row sums.
pub fn cotan_laplacian(mesh: &Mesh) -> SparseMatrix {
    let n = mesh.n_vertices();
    let w = cotan_weights(mesh);
    let mut trip = Vec::with_capacity(4 * w.len());
    for &((i, j), x) in &w {
        trip.push((i, j, -x));
        trip.push((j, i, -x));
        trip.push((i, i, x));
        trip.push((j, j, x));
    }
    sparse_from_triplets(n, n, trip)
}

/// Lumped (diagonal) mass matrix as its diagonal. Sums to the total area of
/// the non-degenerate faces.
pub fn mass_matrix(mesh: &Mesh, kind: MassKind) -> Vec<f64> {
    let v = mesh.vertices();
    let mut m = vec![0.0; mesh.n_vertices()];
    for (f, cot) in mesh.faces().iter().zip(corner_cotangents(mesh)) {
        let Some(cot) = cot else { continue };
        let p = [v[f[0]], v[f[1]], v[f[2]]];
        let area = 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
        match kind {
            MassKind::Barycentric => {
                for &i in f {
                    m[i] += area / 3.0;
                }
            }
            MassKind::Voronoi => {
                if let Some(obtuse) = (0..3).find(|&k| cot[k] < 0.0) {
                    for k in 0..3 {
                        m[f[k]] += if k == obtuse { area / 2.0 } else { area / 4.0 };
                    }
                } else {
                    for (k, &cot_k) in cot.iter().enumerate() {
                        // Edge opposite corner k joins k+1 and k+2; each end
                        // gets |e|² cot_k / 8.
                        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
                        let e2 = (p[b] - p[a]).norm_squared();
                        m[f[a]] += e2 * cot_k / 8.0;
                        m[f[b]] += e2 * cot_k / 8.0;
                    }
                }
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::primitives::{grid, icosphere};

    #[test]
    fn grid_laplacian_rows_sum_to_zero_and_mass_sums_to_area() {
        let g = grid(4, 3);
        let l = cotan_laplacian(&g);
        let mut rows = vec![0.0; g.n_vertices()];
        for (i, _, x) in l.triplet_iter() {
            rows[i] += x;
        }
        assert!(rows.iter().all(|r| r.abs() < 1e-12));
        for kind in [MassKind::Voronoi, MassKind::Barycentric] {
            let total: f64 = mass_matrix(&g, kind).iter().sum();
            assert!((total - 1.0).abs() < 1e-12, "{kind:?} {total}");
        }
    }

    #[test]
    fn sphere_mass_close_to_4pi() {
        let s = icosphere(4);
        let total: f64 = mass_matrix(&s, MassKind::Voronoi).iter().sum();
        let area = crate::ops::total_area(&s);
        assert!((total - area).abs() < 1e-10, "{total} vs {area}");
        // The inscribed polyhedron is slightly smaller than the sphere.
        assert!(
            (total / (4.0 * std::f64::consts::PI) - 1.0).abs() < 2e-3,
            "{total}"
        );
    }

    #[test]
    fn degenerate_face_is_skipped() {
        use crate::Point;
        let m = Mesh::new(
            vec![
                Point::new(0.0, 0.0, 0.0),
                Point::new(1.0, 0.0, 0.0),
                Point::new(2.0, 0.0, 0.0),
                Point::new(0.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 1, 3]],
        )
        .unwrap();
        let l = cotan_laplacian(&m);
        assert!(l.triplet_iter().all(|(_, _, x)| x.is_finite()));
        let total: f64 = mass_matrix(&m, MassKind::Voronoi).iter().sum();
        assert!((total - 0.5).abs() < 1e-12);
    }
}

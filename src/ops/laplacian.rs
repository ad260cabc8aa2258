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

use super::counts::{count, Counted};
use crate::mesh::Mesh;
use crate::solve::SparseMatrix;

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
            if cross2.is_nan() || cross2 < DEGENERATE_REL * longest || longest == 0.0 {
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
///
/// The half-edge terms are bucketed by their smaller vertex (a counting
/// sort), and each bucket (a vertex's few larger neighbours) is sorted by
/// the other vertex, then equal edges are summed.
pub fn cotan_weights(mesh: &Mesh) -> Vec<((usize, usize), f64)> {
    count(Counted::EdgeWeights);
    let n = mesh.n_vertices();
    let cots = corner_cotangents(mesh);
    let half_edges = || {
        mesh.faces()
            .iter()
            .zip(&cots)
            .filter_map(|(f, cot)| cot.map(|c| (f, c)))
            .flat_map(|(f, c)| {
                (0..3).map(move |k| {
                    let (i, j) = (f[(k + 1) % 3], f[(k + 2) % 3]);
                    (i.min(j), i.max(j), 0.5 * c[k])
                })
            })
    };
    let mut start = vec![0usize; n + 1];
    for (i, _, _) in half_edges() {
        start[i + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut bucket = vec![(0usize, 0.0f64); start[n]];
    for (i, j, x) in half_edges() {
        bucket[next[i]] = (j, x);
        next[i] += 1;
    }
    let mut out: Vec<((usize, usize), f64)> = Vec::with_capacity(start[n] / 2 + 1);
    for i in 0..n {
        let b = &mut bucket[start[i]..start[i + 1]];
        b.sort_unstable_by_key(|e| e.0);
        for &(j, x) in b.iter() {
            match out.last_mut() {
                Some((le, lx)) if *le == (i, j) => *lx += x,
                _ => out.push(((i, j), x)),
            }
        }
    }
    out
}

/// Positive semi-definite cotangent Laplacian `L` (n × n): `L_ij = -w_ij`,
/// `L_ii = Σ_j w_ij`. Symmetric with zero row sums.
///
/// Assembled straight into compressed columns from the sorted edge weights
/// (no triplets): column `c` holds its neighbours below `c`, the diagonal,
/// then its neighbours above, each run already sorted because the edges
/// are; the diagonal sums the weights in edge order. A vertex without an
/// edge (isolated, or only in skipped faces) has an empty column.
pub fn cotan_laplacian(mesh: &Mesh) -> SparseMatrix {
    cotan_laplacian_from(mesh.n_vertices(), &cotan_weights(mesh))
}

/// The Laplacian of [`cotan_laplacian`] from the sorted edge weights of
/// [`cotan_weights`] on `n` vertices.
pub(super) fn cotan_laplacian_from(n: usize, w: &[((usize, usize), f64)]) -> SparseMatrix {
    count(Counted::Laplacian);
    // below[c]: neighbours i < c (edges (i, c)); above[c]: neighbours > c.
    let mut below = vec![0usize; n];
    let mut above = vec![0usize; n];
    for &((i, j), _) in w {
        above[i] += 1;
        below[j] += 1;
    }
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0usize);
    let has_diag = |c: usize| below[c] + above[c] > 0;
    for c in 0..n {
        offsets.push(offsets[c] + below[c] + usize::from(has_diag(c)) + above[c]);
    }
    let nnz = offsets[n];
    let mut rows = vec![0usize; nnz];
    let mut vals = vec![0.0f64; nnz];
    // Cursors: the next lower slot and the next upper slot of each column.
    let mut lower: Vec<usize> = offsets[..n].to_vec();
    let mut upper: Vec<usize> = (0..n)
        .map(|c| offsets[c] + below[c] + usize::from(has_diag(c)))
        .collect();
    let mut diag = vec![0.0f64; n];
    for &((i, j), x) in w {
        // Column j, row i (i < j): a lower entry; column i, row j: upper.
        rows[lower[j]] = i;
        vals[lower[j]] = -x;
        lower[j] += 1;
        rows[upper[i]] = j;
        vals[upper[i]] = -x;
        upper[i] += 1;
        diag[i] += x;
        diag[j] += x;
    }
    for c in (0..n).filter(|&c| has_diag(c)) {
        let d = offsets[c] + below[c];
        rows[d] = c;
        vals[d] = diag[c];
    }
    SparseMatrix::try_from_csc_data(n, n, offsets, rows, vals)
        .expect("the cotangent Laplacian's columns are sorted and in range by construction")
}

/// Lumped (diagonal) mass matrix as its diagonal. Sums to the total area of
/// the non-degenerate faces.
pub fn mass_matrix(mesh: &Mesh, kind: MassKind) -> Vec<f64> {
    count(Counted::Mass);
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
                    for (k, &fk) in f.iter().enumerate() {
                        m[fk] += if k == obtuse { area / 2.0 } else { area / 4.0 };
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
    use crate::solve::sparse_from_triplets;

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
        // Vertex 2 lies only in the skipped face: an empty column.
        assert_eq!(l.col(2).nnz(), 0);
        assert_eq!(l, triplet_laplacian(&m));
    }

    /// The Laplacian assembled from triplets by nalgebra-sparse (duplicates
    /// summed in insertion order): the reference for the direct assembly.
    fn triplet_laplacian(mesh: &Mesh) -> SparseMatrix {
        let w = cotan_weights(mesh);
        let mut trip = Vec::new();
        for &((i, j), x) in &w {
            trip.push((i, j, -x));
            trip.push((j, i, -x));
            trip.push((i, i, x));
            trip.push((j, j, x));
        }
        sparse_from_triplets(mesh.n_vertices(), mesh.n_vertices(), trip)
    }

    #[test]
    fn bucketed_edge_weights_equal_a_plain_sort() {
        for m in [grid(6, 4), icosphere(2)] {
            let mut w: Vec<((usize, usize), f64)> = Vec::new();
            for (f, cot) in m.faces().iter().zip(corner_cotangents(&m)) {
                let c = cot.unwrap();
                for k in 0..3 {
                    let (i, j) = (f[(k + 1) % 3], f[(k + 2) % 3]);
                    w.push(((i.min(j), i.max(j)), 0.5 * c[k]));
                }
            }
            w.sort_by_key(|e| e.0);
            let mut reference: Vec<((usize, usize), f64)> = Vec::new();
            for (e, x) in w {
                match reference.last_mut() {
                    Some((le, lx)) if *le == e => *lx += x,
                    _ => reference.push((e, x)),
                }
            }
            assert_eq!(cotan_weights(&m), reference);
        }
    }

    #[test]
    fn direct_assembly_equals_triplet_assembly_bitwise() {
        use crate::Point;
        let mut jittered = icosphere(3);
        let v: Vec<Point> = jittered
            .vertices()
            .iter()
            .enumerate()
            .map(|(i, p)| p * (1.0 + 0.1 * ((i * 7919 % 97) as f64 / 97.0 - 0.5)))
            .collect();
        jittered = Mesh::new(v, jittered.faces().to_vec()).unwrap();
        for m in [grid(7, 5), icosphere(2), jittered] {
            let l = cotan_laplacian(&m);
            let r = triplet_laplacian(&m);
            assert_eq!(l.col_offsets(), r.col_offsets());
            assert_eq!(l.row_indices(), r.row_indices());
            let (a, b) = (l.values(), r.values());
            assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()));
        }
    }
}

//! Face and vertex normals.
//!
//! **Orientation.** A face `[a, b, c]` has normal direction
//! `(p_b − p_a) × (p_c − p_a)` (counter-clockwise seen from outside gives an
//! outward normal).
//!
//! **Vertex weighting.** Vertex normals are *area weighted*: the normalised
//! sum of the incident faces' unnormalised normals `(p_b − p_a) × (p_c − p_a)
//! = 2 A_f n_f`. Large faces count more than small ones, the result does not
//! depend on how a face is triangulated into slivers only through its area,
//! and it needs no angle computations. (Angle weighting, Thürmer–Wüthrich, is
//! more robust to irregular valence; it is not used here.)

use crate::mesh::Mesh;
use crate::ops::laplacian::DEGENERATE_REL;
use crate::Vec3;

/// Unit normal of every face; the zero vector for a degenerate face
/// (`2·area < DEGENERATE_REL · longest_edge²`, the threshold the Laplacian
/// uses to skip faces).
pub fn face_normals(mesh: &Mesh) -> Vec<Vec3> {
    let v = mesh.vertices();
    mesh.faces()
        .iter()
        .map(|&[a, b, c]| {
            let (e0, e1, e2) = (v[b] - v[a], v[c] - v[b], v[a] - v[c]);
            let n = e0.cross(&(v[c] - v[a]));
            let longest = e0
                .norm_squared()
                .max(e1.norm_squared())
                .max(e2.norm_squared());
            let len = n.norm();
            if longest > 0.0 && len >= DEGENERATE_REL * longest {
                n / len
            } else {
                Vec3::zeros()
            }
        })
        .collect()
}

/// Area-weighted vertex normal *sums*, not normalised: `Σ_f A_f n_f` over the
/// faces incident to each vertex. Its length is the area of the 1-ring when
/// the 1-ring is flat, and it scales with the square of a uniform scaling.
pub fn vertex_area_normals(mesh: &Mesh) -> Vec<Vec3> {
    let v = mesh.vertices();
    let mut out = vec![Vec3::zeros(); mesh.n_vertices()];
    for &[a, b, c] in mesh.faces() {
        let n = 0.5 * (v[b] - v[a]).cross(&(v[c] - v[a]));
        out[a] += n;
        if b != a {
            out[b] += n;
        }
        if c != a && c != b {
            out[c] += n;
        }
    }
    out
}

/// Unit area-weighted vertex normals (see the module documentation). The
/// zero vector for a vertex without faces or whose face normals cancel.
pub fn vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    vertex_area_normals(mesh)
        .into_iter()
        .map(|n| {
            let len = n.norm();
            if len > 0.0 && len.is_finite() {
                n / len
            } else {
                Vec3::zeros()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::primitives::{grid, icosphere};
    use crate::Point;

    #[test]
    fn sphere_normals_point_outward() {
        let s = icosphere(3);
        for (p, n) in s.vertices().iter().zip(vertex_normals(&s)) {
            assert!((n.norm() - 1.0).abs() < 1e-12);
            // By symmetry of the subdivided icosahedron, close to radial.
            assert!(n.dot(&p.coords) > 0.999, "{n:?} at {p:?}");
        }
        for (f, n) in s.faces().iter().zip(face_normals(&s)) {
            let c = (s.vertices()[f[0]].coords + s.vertices()[f[1]].coords) / 2.0;
            assert!(n.dot(&c) > 0.9);
        }
    }

    #[test]
    fn grid_normals_are_z_and_sums_are_areas() {
        let g = grid(3, 2);
        assert!(vertex_normals(&g)
            .iter()
            .all(|n| (n - Vec3::z()).norm() < 1e-12));
        let sums: f64 = vertex_area_normals(&g).iter().map(|n| n.z).sum();
        // Each face is counted at its three corners.
        assert!((sums - 3.0).abs() < 1e-12);
    }

    #[test]
    fn area_weighting() {
        // Two faces at a shared vertex 0: a big one in the xy plane and a
        // small one in the xz plane; the normal leans towards +z by the
        // ratio of areas.
        let v = vec![
            Point::new(0.0, 0.0, 0.0),
            Point::new(2.0, 0.0, 0.0),
            Point::new(0.0, 2.0, 0.0),
            Point::new(0.0, 0.0, 1.0),
            Point::new(-1.0, 0.0, 0.0),
        ];
        let m = Mesh::new(v, vec![[0, 1, 2], [0, 3, 4]]).unwrap();
        let n = vertex_normals(&m)[0];
        // Areas 2 and 0.5, normals +z and (0,0,1)×(-1,0,0) = -y.
        let expect = Vec3::new(0.0, -0.5, 2.0).normalize();
        assert!((n - expect).norm() < 1e-12, "{n:?}");
    }

    #[test]
    fn degenerate_face_has_zero_normal() {
        let v = vec![
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0, 0.0),
            Point::new(2.0, 0.0, 0.0),
        ];
        let m = Mesh::new(v, vec![[0, 1, 2]]).unwrap();
        assert_eq!(face_normals(&m)[0], Vec3::zeros());
        assert_eq!(vertex_normals(&m)[1], Vec3::zeros());
    }
}

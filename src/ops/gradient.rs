//! Per-vertex deformation gradients between a mesh and a deformed copy, and
//! the rotation / scale-shear features of BDT Sec. 3.3 (Eq. 6–13).
//!
//! # The fit (BDT Eq. 6, made well-posed)
//!
//! For vertex `i` with 1-ring `N_i`, rest edges `e^p_ij = p_i − p_j` and
//! deformed edges `e^q_ij = q_i − q_j`, the paper fits
//! `D_i = argmin Σ_j w̃_ij ‖e^q_ij − D_i e^p_ij‖²` with cotangent weights.
//! Two things make that ill-posed on real meshes, and this module changes
//! the energy as follows:
//!
//! 1. **Non-positive weights.** `w_ij = ½(cot α + cot β)` is ≤ 0 when the
//!    angles opposite the edge are obtuse enough (and 0 for an edge whose
//!    faces are all degenerate). A negative weight *rewards* residual and can
//!    make the normal matrix indefinite. Weights are clamped:
//!    `w̃_ij = max(w_ij, CLAMP_REL · w̄_i)` where `w̄_i` is the mean of `|w_ij|`
//!    over the 1-ring (uniform weights `1` if that mean is 0). Clamping rather
//!    than `|w|` keeps an edge opposite a very obtuse angle (large negative
//!    cotangent) from dominating the fit.
//! 2. **Rank deficiency.** All edges of a 1-ring lie close to the tangent
//!    plane, so `A = Σ w̃ e^p e^pᵀ` is rank 2 for a flat 1-ring and badly
//!    conditioned for a nearly flat one: `D_i` is undetermined along the
//!    normal. A normal term is added, as for the fourth vertex of Sumner &
//!    Popović's deformation transfer:
//!    `λ_i ‖ν^q_i − D_i ν^p_i‖²` with `ν = N / √‖N‖`, where `N` is the
//!    area-weighted vertex normal sum `Σ_f A_f n_f`
//!    ([`crate::ops::vertex_area_normals`]) of the respective mesh. `‖ν‖` is
//!    `√(1-ring area)`, an edge-length-like scale, and under a similarity
//!    `q = s R p + t` one gets `ν^q = s R ν^p` exactly, so a similarity is
//!    recovered exactly (`D_i = s R`) at every vertex. The weight
//!    `λ_i = w̄_i` (mean clamped edge weight) makes the normal count like one
//!    average edge.
//!
//! The minimiser is `D_i = B A⁻¹` with `A = Σ w̃ e^p e^pᵀ + λ ν^p ν^pᵀ`,
//! `B = Σ w̃ e^q e^pᵀ + λ ν^q ν^pᵀ`. If `A` is still singular (a vertex with
//! no faces, or a 1-ring collapsed to a line/point) the pseudo-inverse is
//! used with eigenvalues below `1e-12 · λ_max(A)` dropped, and `D_i` maps
//! the unconstrained directions to themselves: `D_i = B A⁺ + (I − A A⁺)`.
//! A vertex with no faces thus gets `D_i = I`.

use nalgebra::DMatrix;

use crate::mesh::Mesh;
use crate::ops::normals::vertex_area_normals;
use crate::ops::rotation::{polar_decomposition, rotation_log, scale_shear_vector};
use crate::ops::Operators;
use crate::{Error, Mat3, Result, Vec3};

/// Weights below `CLAMP_REL` times the mean absolute 1-ring weight are
/// raised to it (see the module documentation).
pub const CLAMP_REL: f64 = 0.05;

/// Per-vertex rotation log and scale/shear of a deformed copy (BDT
/// Eq. 12–13).
#[derive(Clone, Debug, PartialEq)]
pub struct DeformationFeatures {
    /// `logr`, n × 3: row `i` is `u_i` (BDT Eq. 10), the log of the rotation
    /// `U_i` of the polar decomposition `D_i = U_i N_i` in the basis of Eq. 9.
    pub log_rotation: DMatrix<f64>,
    /// `s`, n × 9: row `i` is `s_i` (BDT Eq. 11), `N_i` in row-major order.
    pub scale_shear: DMatrix<f64>,
}

fn check_pair(rest: &Mesh, deformed: &Mesh) -> Result<()> {
    if rest.n_vertices() != deformed.n_vertices() {
        return Err(Error::invalid(format!(
            "deformed mesh has {} vertices, the rest mesh has {}",
            deformed.n_vertices(),
            rest.n_vertices()
        )));
    }
    if rest.faces() != deformed.faces() {
        return Err(Error::invalid(
            "deformed mesh has different faces from the rest mesh; \
             deformation gradients need shared connectivity",
        ));
    }
    Ok(())
}

/// Per-vertex deformation gradient `D_i` taking `rest` to `deformed` (BDT
/// Eq. 6 with clamped cotangent weights and a normal term; see the module
/// documentation). The two meshes must share their faces.
pub fn deformation_gradients(rest: &Mesh, deformed: &Mesh) -> Result<Vec<Mat3>> {
    check_pair(rest, deformed)?;
    let p = rest.vertices();
    let q = deformed.vertices();
    let weights = rest.edge_weights();
    let nb = rest.neighbours();
    let np = vertex_area_normals(rest);
    let nq = vertex_area_normals(deformed);
    let weight = |i: usize, j: usize| -> f64 {
        weights
            .binary_search_by_key(&(i.min(j), i.max(j)), |e| e.0)
            .map(|k| weights[k].1)
            .unwrap_or(0.0)
    };
    let scaled = |n: &Vec3| -> Vec3 {
        let len = n.norm();
        if len > 0.0 {
            n / len.sqrt()
        } else {
            Vec3::zeros()
        }
    };
    let mut out = Vec::with_capacity(p.len());
    let mut w_ring: Vec<f64> = Vec::new();
    for i in 0..p.len() {
        let ring = nb.row(i);
        w_ring.clear();
        w_ring.extend(ring.iter().map(|&j| weight(i, j)));
        let mean_abs = if ring.is_empty() {
            0.0
        } else {
            w_ring.iter().map(|w| w.abs()).sum::<f64>() / ring.len() as f64
        };
        if mean_abs > 0.0 && mean_abs.is_finite() {
            let floor = CLAMP_REL * mean_abs;
            for w in w_ring.iter_mut() {
                *w = w.max(floor);
            }
        } else {
            w_ring.iter_mut().for_each(|w| *w = 1.0);
        }
        let mut a = Mat3::zeros();
        let mut b = Mat3::zeros();
        for (&j, &w) in ring.iter().zip(&w_ring) {
            let ep = p[i] - p[j];
            let eq = q[i] - q[j];
            a += w * ep * ep.transpose();
            b += w * eq * ep.transpose();
        }
        if !ring.is_empty() {
            let lambda = w_ring.iter().sum::<f64>() / ring.len() as f64;
            let (vp, vq) = (scaled(&np[i]), scaled(&nq[i]));
            a += lambda * vp * vp.transpose();
            b += lambda * vq * vp.transpose();
        }
        out.push(solve_fit(&a, &b, i)?);
    }
    Ok(out)
}

/// `B A⁺ + (I − A A⁺)` for symmetric PSD `A` (see the module documentation).
fn solve_fit(a: &Mat3, b: &Mat3, vertex: usize) -> Result<Mat3> {
    if let Some(inv) = a.try_inverse() {
        // Fast path for a well-conditioned A; the check keeps near-singular
        // systems on the eigen path.
        let cond_ok = a.norm() * inv.norm() < 1e10;
        if cond_ok && inv.iter().all(|x| x.is_finite()) {
            return Ok(b * inv);
        }
    }
    let eig = a.symmetric_eigen();
    let max = eig.eigenvalues.iter().fold(0.0f64, |m, &x| m.max(x));
    if !max.is_finite() {
        return Err(Error::numerical(format!(
            "deformation gradient at vertex {vertex}: non-finite normal matrix"
        )));
    }
    let tol = 1e-12 * max;
    let mut pinv = Mat3::zeros();
    let mut proj = Mat3::zeros();
    for k in 0..3 {
        let l = eig.eigenvalues[k];
        if max > 0.0 && l > tol {
            let v: Vec3 = eig.eigenvectors.column(k).into();
            let vvt = v * v.transpose();
            pinv += vvt / l;
            proj += vvt;
        }
    }
    Ok(b * pinv + (Mat3::identity() - proj))
}

/// Rotation log `logr` (n × 3) and scale/shear `s` (n × 9) of a deformed copy
/// (BDT Eq. 12–13): deformation gradients ([`deformation_gradients`]),
/// polar decomposition `D_i = U_i N_i` with a proper rotation
/// ([`polar_decomposition`]), `u_i = log U_i` in the basis of Eq. 9
/// ([`rotation_log`]), `s_i` = `N_i` row-major.
pub fn deformation_features(rest: &Mesh, deformed: &Mesh) -> Result<DeformationFeatures> {
    let grads = deformation_gradients(rest, deformed)?;
    let n = grads.len();
    let mut log_rotation = DMatrix::zeros(n, 3);
    let mut scale_shear = DMatrix::zeros(n, 9);
    for (i, d) in grads.iter().enumerate() {
        let polar =
            polar_decomposition(d).map_err(|e| Error::numerical(format!("vertex {i}: {e}")))?;
        let u = rotation_log(&polar.rotation);
        for k in 0..3 {
            log_rotation[(i, k)] = u[k];
        }
        for (k, x) in scale_shear_vector(&polar.stretch).into_iter().enumerate() {
            scale_shear[(i, k)] = x;
        }
    }
    Ok(DeformationFeatures {
        log_rotation,
        scale_shear,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::primitives::{grid, icosphere};
    use crate::ops::rotation::rotation_exp_axis_angle;
    use crate::Point;

    #[test]
    fn similarity_is_recovered() {
        let s = icosphere(2);
        let r = rotation_exp_axis_angle(&Vec3::new(0.2, 0.9, -0.4));
        let t = Vec3::new(1.0, -2.0, 0.5);
        let d = s
            .map_vertices(|p| Point::from(2.5 * (r * p.coords) + t))
            .unwrap();
        for g in deformation_gradients(&s, &d).unwrap() {
            assert!((g - 2.5 * r).norm() < 1e-10, "{g:?}");
        }
        let f = deformation_features(&s, &d).unwrap();
        let u = rotation_log(&r);
        for i in 0..s.n_vertices() {
            assert!((f.log_rotation.row(i).transpose() - u).norm() < 1e-10);
            for k in 0..9 {
                let expect = if k % 4 == 0 { 2.5 } else { 0.0 };
                assert!((f.scale_shear[(i, k)] - expect).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn flat_grid_linear_map_with_normal_stretch() {
        // An in-plane linear map A on a flat grid: the normal term makes the
        // normal direction map to ν^q = √det(A₂) ẑ.
        let g = grid(4, 4);
        let a2 = nalgebra::Matrix2::new(1.5, 0.3, -0.2, 0.8);
        let d = g
            .map_vertices(|p| {
                let x = a2 * nalgebra::Vector2::new(p.x, p.y);
                Point::new(x.x, x.y, 0.0)
            })
            .unwrap();
        let det = a2.determinant();
        let expect = Mat3::new(
            a2[(0, 0)],
            a2[(0, 1)],
            0.0,
            a2[(1, 0)],
            a2[(1, 1)],
            0.0,
            0.0,
            0.0,
            det.sqrt(),
        );
        for g in deformation_gradients(&g, &d).unwrap() {
            assert!((g - expect).norm() < 1e-10, "{g:?}");
        }
    }

    #[test]
    fn isolated_vertex_and_bad_input() {
        let v = vec![
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0, 0.0),
            Point::new(0.0, 1.0, 0.0),
            Point::new(3.0, 3.0, 3.0),
        ];
        let m = Mesh::new(v, vec![[0, 1, 2]]).unwrap();
        let grads = deformation_gradients(&m, &m).unwrap();
        assert!(grads.iter().all(|g| (g - Mat3::identity()).norm() < 1e-12));
        let other = icosphere(1);
        assert!(deformation_gradients(&m, &other).is_err());
        let reordered = m.with_faces(vec![[0, 2, 1]]).unwrap();
        assert!(deformation_features(&m, &reordered).is_err());
    }
}

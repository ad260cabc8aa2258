//! Polar decomposition, rotation logarithm / exponential in the basis of
//! BDT Eq. 9, and the scale/shear 9-vector of BDT Eq. 11.
//!
//! **Basis (BDT Eq. 8–9).** A skew-symmetric matrix is written
//! `Ū = u₁ e₁ + u₂ e₂ + u₃ e₃` with
//!
//! ```text
//!      [ 0  1  0]        [ 0  0  1]        [0  0  0]
//! e₁ = [-1  0  0]   e₂ = [ 0  0  0]   e₃ = [0  0  1]
//!      [ 0  0  0]        [-1  0  0]        [0 -1  0]
//! ```
//!
//! i.e. `u = (Ū₀₁, Ū₀₂, Ū₁₂)`. With the usual axis–angle vector `ω = θ a`
//! (`Ū = [ω]×`, `[ω]× x = ω × x`) this is `u = (−ω_z, ω_y, −ω_x)`, so
//! `‖u‖ = θ`. The basis is orthogonal, so Euclidean distances between
//! `u` vectors equal (up to the factor √2) Frobenius distances between the
//! logarithms, which is what clustering on `logr` relies on.

use nalgebra::Matrix3;

use crate::{Error, Mat3, Result, Vec3};

/// Polar decomposition `D = U N` (BDT Eq. 7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Polar {
    /// Proper rotation: orthonormal with determinant +1.
    pub rotation: Mat3,
    /// Symmetric scale/shear factor. Positive semi-definite when
    /// `det D ≥ 0`; when `det D < 0` its eigenvalue of smallest magnitude is
    /// negative (the reflection is put there, see [`polar_decomposition`]).
    pub stretch: Mat3,
}

/// Polar decomposition `D = U N` with `U` a proper rotation and `N`
/// symmetric, via the SVD `D = W Σ Vᵀ`: `U = W Vᵀ`, `N = V Σ Vᵀ`.
///
/// **Reflections.** If `det(W Vᵀ) < 0` (i.e. `det D < 0`, or `det D = 0`
/// with an unlucky SVD sign) the sign of the singular vector pair of the
/// *smallest* singular value is flipped: `U = W diag(1,1,−1) Vᵀ`,
/// `N = V diag(σ₁,σ₂,−σ₃) Vᵀ`. This is the rotation closest to `D` in the
/// Frobenius norm (the Kabsch/Umeyama choice), and `U N = D` still holds
/// exactly. A singular `D` gets some valid rotation (not unique).
///
/// Errors if `D` has a non-finite entry or the SVD does not converge.
pub fn polar_decomposition(d: &Mat3) -> Result<Polar> {
    if d.iter().any(|x| !x.is_finite()) {
        return Err(Error::invalid(format!(
            "polar decomposition of a non-finite matrix {d:?}"
        )));
    }
    let svd = d
        .try_svd(true, true, f64::EPSILON, 1000)
        .ok_or_else(|| Error::numerical("3×3 SVD did not converge"))?;
    let (Some(mut w), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(Error::numerical("3×3 SVD returned no singular vectors"));
    };
    let mut sigma = svd.singular_values;
    if (w * v_t).determinant() < 0.0 {
        // Singular values are sorted in decreasing order: flip the last.
        let k = sigma.imin();
        w.column_mut(k).neg_mut();
        sigma[k] = -sigma[k];
    }
    let rotation = w * v_t;
    let stretch = v_t.transpose() * Matrix3::from_diagonal(&sigma) * v_t;
    // Symmetrise away rounding.
    let stretch = 0.5 * (stretch + stretch.transpose());
    Ok(Polar { rotation, stretch })
}

/// Skew-symmetric matrix `u₁ e₁ + u₂ e₂ + u₃ e₃` (BDT Eq. 8–9).
pub fn skew_from_paper_basis(u: &Vec3) -> Mat3 {
    Mat3::new(0.0, u[0], u[1], -u[0], 0.0, u[2], -u[1], -u[2], 0.0)
}

/// Coordinates `(u₁, u₂, u₃)` of the skew-symmetric part of `m` in the basis
/// of BDT Eq. 9 (exact inverse of [`skew_from_paper_basis`] on
/// skew-symmetric matrices).
pub fn paper_basis_from_skew(m: &Mat3) -> Vec3 {
    Vec3::new(
        0.5 * (m[(0, 1)] - m[(1, 0)]),
        0.5 * (m[(0, 2)] - m[(2, 0)]),
        0.5 * (m[(1, 2)] - m[(2, 1)]),
    )
}

/// Axis–angle vector `ω = θ a` → paper-basis coordinates `u = (−ω_z, ω_y, −ω_x)`.
pub fn axis_angle_to_paper(omega: &Vec3) -> Vec3 {
    Vec3::new(-omega.z, omega.y, -omega.x)
}

/// Paper-basis coordinates `u` → axis–angle vector `ω = (−u₃, u₂, −u₁)`.
pub fn paper_to_axis_angle(u: &Vec3) -> Vec3 {
    Vec3::new(-u[2], u[1], -u[0])
}

/// Axis–angle vector `ω = θ a` of a rotation matrix, with `θ ∈ [0, π]`.
///
/// Accurate over the whole range: `θ = atan2(‖vee(R − Rᵀ)‖/2, (tr R − 1)/2)`;
/// for `θ ≤ 2π/3` the axis is `vee(R − Rᵀ)/(2 sin θ)` (with `θ/sin θ`
/// replaced by its series near 0), for larger angles — where `sin θ` loses
/// precision — it is the dominant column of the symmetric part
/// `(R + Rᵀ)/2 − cos θ I = (1 − cos θ) a aᵀ`, its sign taken from the
/// skew part. At exactly `θ = π` either sign is returned (both are valid).
///
/// `r` is assumed to be a rotation (e.g. from [`polar_decomposition`]);
/// for a slightly non-orthogonal input the result is that of a nearby
/// rotation.
pub fn rotation_log_axis_angle(r: &Mat3) -> Vec3 {
    // vee of the skew part: sin θ · a.
    let s_vec = Vec3::new(
        0.5 * (r[(2, 1)] - r[(1, 2)]),
        0.5 * (r[(0, 2)] - r[(2, 0)]),
        0.5 * (r[(1, 0)] - r[(0, 1)]),
    );
    let s = s_vec.norm();
    let c = ((r.trace() - 1.0) * 0.5).clamp(-1.0, 1.0);
    let theta = s.atan2(c);
    if c > -0.5 {
        let factor = if s < 1e-8 {
            1.0 + s * s / 6.0
        } else {
            theta / s
        };
        return s_vec * factor;
    }
    let b = 0.5 * (r + r.transpose()) - Mat3::identity() * c;
    let k = b.diagonal().imax();
    let col: Vec3 = b.column(k).into();
    let len = col.norm();
    if len == 0.0 {
        // Unreachable for a rotation (b has trace 1 − c ≥ 1.5); keep total.
        return s_vec;
    }
    let mut a = col / len;
    if a.dot(&s_vec) < 0.0 {
        a = -a;
    }
    a * theta
}

/// Rotation matrix of an axis–angle vector `ω` (Rodrigues), with the
/// coefficients `sin θ/θ` and `(1 − cos θ)/θ²` taken from their series for
/// small `θ`.
pub fn rotation_exp_axis_angle(omega: &Vec3) -> Mat3 {
    let t2 = omega.norm_squared();
    let theta = t2.sqrt();
    let (a, b) = if theta < 1e-4 {
        (1.0 - t2 / 6.0, 0.5 - t2 / 24.0)
    } else {
        (theta.sin() / theta, (1.0 - theta.cos()) / t2)
    };
    let k = omega.cross_matrix();
    Mat3::identity() + k * a + k * k * b
}

/// Logarithm of a rotation as the 3-vector `u_i` of BDT Eq. 8–10 (paper
/// basis, `‖u‖ = θ ∈ [0, π]`). See [`rotation_log_axis_angle`] for accuracy.
pub fn rotation_log(r: &Mat3) -> Vec3 {
    axis_angle_to_paper(&rotation_log_axis_angle(r))
}

/// Inverse of [`rotation_log`]: `exp(u₁ e₁ + u₂ e₂ + u₃ e₃)`.
pub fn rotation_exp(u: &Vec3) -> Mat3 {
    rotation_exp_axis_angle(&paper_to_axis_angle(u))
}

/// Scale/shear 9-vector `s_i = (n⁽¹⁾, …, n⁽⁹⁾)` of BDT Eq. 11: the entries of
/// `N` in row-major order (`N` is symmetric, so column-major is the same).
pub fn scale_shear_vector(n: &Mat3) -> [f64; 9] {
    let mut s = [0.0; 9];
    for r in 0..3 {
        for c in 0..3 {
            s[3 * r + c] = n[(r, c)];
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn close(a: &Mat3, b: &Mat3, tol: f64) -> bool {
        (a - b).norm() <= tol
    }

    #[test]
    fn basis_matches_eq9() {
        let e1 = skew_from_paper_basis(&Vec3::new(1.0, 0.0, 0.0));
        let e2 = skew_from_paper_basis(&Vec3::new(0.0, 1.0, 0.0));
        let e3 = skew_from_paper_basis(&Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(e1, Mat3::new(0., 1., 0., -1., 0., 0., 0., 0., 0.));
        assert_eq!(e2, Mat3::new(0., 0., 1., 0., 0., 0., -1., 0., 0.));
        assert_eq!(e3, Mat3::new(0., 0., 0., 0., 0., 1., 0., -1., 0.));
        let u = Vec3::new(0.3, -0.2, 0.7);
        assert_eq!(paper_basis_from_skew(&skew_from_paper_basis(&u)), u);
        // Same skew matrix as the cross-product matrix of ω.
        let w = paper_to_axis_angle(&u);
        assert!(close(&w.cross_matrix(), &skew_from_paper_basis(&u), 0.0));
    }

    #[test]
    fn known_rotation_about_z() {
        // 90° about +z: x → y.
        let r = Mat3::new(0., -1., 0., 1., 0., 0., 0., 0., 1.);
        let w = rotation_log_axis_angle(&r);
        assert!((w - Vec3::new(0.0, 0.0, PI / 2.0)).norm() < 1e-15);
        assert!((rotation_log(&r) - Vec3::new(-PI / 2.0, 0.0, 0.0)).norm() < 1e-15);
        assert!(close(&rotation_exp(&rotation_log(&r)), &r, 1e-15));
        assert_eq!(rotation_log(&Mat3::identity()), Vec3::zeros());
    }

    #[test]
    fn log_near_zero_and_pi() {
        let axis = Vec3::new(1.0, -2.0, 0.5).normalize();
        for theta in [
            0.0,
            1e-12,
            1e-7,
            1e-3,
            0.5,
            2.0,
            2.0 * PI / 3.0,
            PI - 1e-3,
            PI - 1e-7,
            PI - 1e-12,
            PI,
        ] {
            let r = rotation_exp_axis_angle(&(axis * theta));
            assert!((r.determinant() - 1.0).abs() < 1e-14);
            let w = rotation_log_axis_angle(&r);
            let err = if theta > PI - 1e-6 {
                // ±π a are the same rotation.
                (w - axis * theta).norm().min((w + axis * theta).norm())
            } else {
                (w - axis * theta).norm()
            };
            assert!(err < 1e-9 * theta.max(1.0), "θ = {theta}: {w:?}, err {err}");
            assert!(close(&rotation_exp_axis_angle(&w), &r, 1e-14));
        }
    }

    #[test]
    fn polar_of_rotation_times_spd() {
        let r = rotation_exp_axis_angle(&Vec3::new(0.3, -1.1, 0.4));
        let n = Mat3::new(2.0, 0.3, 0.1, 0.3, 1.0, -0.2, 0.1, -0.2, 0.5);
        let p = polar_decomposition(&(r * n)).unwrap();
        assert!(close(&p.rotation, &r, 1e-12));
        assert!(close(&p.stretch, &n, 1e-12));
    }

    #[test]
    fn polar_with_reflection() {
        let d = Mat3::from_diagonal(&Vec3::new(3.0, 2.0, -1.0));
        let p = polar_decomposition(&d).unwrap();
        assert!((p.rotation.determinant() - 1.0).abs() < 1e-12);
        assert!(close(&(p.rotation * p.stretch), &d, 1e-12));
        assert!(close(&p.rotation, &Mat3::identity(), 1e-12));
        assert!(polar_decomposition(&Mat3::zeros()).is_ok());
        let mut bad = Mat3::identity();
        bad[(1, 2)] = f64::NAN;
        assert!(polar_decomposition(&bad).is_err());
    }

    #[test]
    fn scale_shear_is_row_major() {
        let n = Mat3::new(1., 2., 3., 2., 4., 5., 3., 5., 6.);
        assert_eq!(scale_shear_vector(&n), [1., 2., 3., 2., 4., 5., 3., 5., 6.]);
    }
}

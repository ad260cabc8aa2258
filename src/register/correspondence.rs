//! Automatic feature point correspondence and shape interpolation (FBT
//! Sec. 5, Fig. 3).
//!
//! **Correspondence.** Within an ambiguous group of features (e.g. the four
//! feet of a quadruped: 4! = 24 assignments) every permissible assignment
//! of the given target points to the template's features is solved with
//! the full schedule and the one with the smallest minimal ARAP energy E_mn
//! (Eq. 12) is kept. Only `Y` changes between assignments — `H` (and so
//! every Cholesky factor) is shared, which is why this is cheap.
//!
//! **Interpolation.** Two deformations solved from two constraint sets
//! give rotations per example and cluster and scales α. For `s ∈ [0, 1]`
//! the rotations are interpolated by quaternion slerp, α and the
//! constraint targets linearly, and one additional global step produces
//! the transformations (the paper: "we are able to interpolate between these
//! rotations. To produce the new transformations, we apply one additional
//! global-step"). When both solutions selected the same example ℓ* the
//! global step of E_ℓ* is used, otherwise that of E_total over all
//! examples.

use nalgebra::{DMatrix, Rotation3, UnitQuaternion};

use super::pipeline::{PipelineSystems, Registration, Schedule};
use super::solver::FbtSystem;
use crate::{Error, Mat3, Result};

/// Result of [`best_permutation`].
#[derive(Clone, Debug)]
pub struct PermutationSearch {
    /// The chosen assignment: template feature `g` of the group takes the
    /// target rows of feature `best[g]`.
    pub best: Vec<usize>,
    /// Every assignment tried with its final E_mn, in lexicographic order.
    pub energies: Vec<(Vec<usize>, f64)>,
    /// The registration of the chosen assignment.
    pub registration: Registration,
}

/// All permutations of `0..k` in lexicographic order.
pub fn permutations(k: usize) -> Vec<Vec<usize>> {
    let mut out = Vec::new();
    let mut p: Vec<usize> = (0..k).collect();
    loop {
        out.push(p.clone());
        // next lexicographic permutation
        let Some(i) = (1..k).rev().find(|&i| p[i - 1] < p[i]) else {
            return out;
        };
        let j = (i..k).rev().find(|&j| p[j] > p[i - 1]).unwrap_or(i);
        p.swap(i - 1, j);
        p[i..].reverse();
    }
}

/// `y` with the rows of group member `g` replaced by those of `perm[g]`.
pub fn permute_targets(
    y: &DMatrix<f64>,
    group: &[Vec<usize>],
    perm: &[usize],
) -> Result<DMatrix<f64>> {
    if perm.len() != group.len() {
        return Err(Error::invalid("permutation and group differ in length"));
    }
    let mut out = y.clone();
    for (g, &p) in perm.iter().enumerate() {
        let (dst, src) = (
            &group[g],
            group
                .get(p)
                .ok_or_else(|| Error::invalid(format!("permutation entry {p} out of range")))?,
        );
        if dst.len() != src.len() {
            return Err(Error::invalid(
                "features of an ambiguous group must have equally many rows",
            ));
        }
        for (&d, &s) in dst.iter().zip(src) {
            if d >= y.nrows() || s >= y.nrows() {
                return Err(Error::invalid(format!("row {d} or {s} out of range")));
            }
            out.row_mut(d).copy_from(&y.row(s));
        }
    }
    Ok(out)
}

/// Tries every assignment within `group` (each entry: the constraint rows
/// of one feature) and returns the one with minimal E_mn (lowest
/// lexicographic rank on ties). At most 8 features (40 320 assignments).
pub fn best_permutation(
    systems: &PipelineSystems,
    y: &DMatrix<f64>,
    group: &[Vec<usize>],
    schedule: &Schedule,
) -> Result<PermutationSearch> {
    if group.is_empty() || group.len() > 8 {
        return Err(Error::invalid(format!(
            "an ambiguous group needs 1..=8 features, got {}",
            group.len()
        )));
    }
    let mut energies = Vec::new();
    let mut best: Option<(f64, Vec<usize>, Registration)> = None;
    for perm in permutations(group.len()) {
        let yp = permute_targets(y, group, &perm)?;
        let reg = systems.solve(&yp, schedule)?;
        energies.push((perm.clone(), reg.energy));
        if best.as_ref().is_none_or(|b| reg.energy < b.0) {
            best = Some((reg.energy, perm, reg));
        }
    }
    let (_, best, registration) =
        best.ok_or_else(|| Error::numerical("no assignment could be evaluated"))?;
    Ok(PermutationSearch {
        best,
        energies,
        registration,
    })
}

/// Rotation slerp `R_a → R_b` at `s`.
pub fn slerp(a: &Mat3, b: &Mat3, s: f64) -> Mat3 {
    let qa = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*a));
    let qb = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*b));
    // Shortest arc; antipodal pairs fall back to nlerp's choice.
    let q = qa
        .try_slerp(&qb, s, 1e-12)
        .unwrap_or_else(|| qa.nlerp(&qb, s));
    *q.to_rotation_matrix().matrix()
}

/// Interpolated transformations between two registrations of the same
/// system (their `minimal` solutions are required: they carry the
/// rotations of every example) with targets `y_a`, `y_b`, at `s ∈ [0, 1]`
/// (see the module docs).
pub fn interpolate(
    system: &FbtSystem,
    a: &Registration,
    b: &Registration,
    y_a: &DMatrix<f64>,
    y_b: &DMatrix<f64>,
    s: f64,
) -> Result<DMatrix<f64>> {
    let (Some(ma), Some(mb)) = (&a.minimal, &b.minimal) else {
        return Err(Error::invalid(
            "interpolation needs registrations with a minimal-energy stage",
        ));
    };
    if !(0.0..=1.0).contains(&s) {
        return Err(Error::invalid(format!(
            "interpolation parameter {s} not in [0, 1]"
        )));
    }
    let q = system.model().n_examples();
    if ma.per_example.len() != q || mb.per_example.len() != q {
        return Err(Error::invalid("registrations belong to another system"));
    }
    let y = y_a * (1.0 - s) + y_b * s;
    let rots: Vec<Vec<Mat3>> = (0..q)
        .map(|l| {
            ma.per_example[l]
                .rotations
                .iter()
                .zip(&mb.per_example[l].rotations)
                .map(|(ra, rb)| slerp(ra, rb, s))
                .collect()
        })
        .collect();
    if ma.best == mb.best {
        let l = ma.best;
        let alpha = (1.0 - s) * ma.per_example[l].alpha + s * mb.per_example[l].alpha;
        system.global_step_example(l, &y, &rots[l], alpha)
    } else {
        let alpha = (1.0 - s) * a.alpha + s * b.alpha;
        system.global_step_average(&y, &rots, alpha)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permutations_are_lexicographic_and_complete() {
        let p = permutations(4);
        assert_eq!(p.len(), 24);
        assert_eq!(p[0], vec![0, 1, 2, 3]);
        assert_eq!(p[23], vec![3, 2, 1, 0]);
        for w in p.windows(2) {
            assert!(w[0] < w[1]);
        }
        assert_eq!(permutations(1), vec![vec![0]]);
    }

    #[test]
    fn slerp_endpoints_and_midpoint() {
        let a = Mat3::identity();
        let b = *Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), 1.0).matrix();
        assert!((slerp(&a, &b, 0.0) - a).abs().max() < 1e-12);
        assert!((slerp(&a, &b, 1.0) - b).abs().max() < 1e-12);
        let m = *Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), 0.5).matrix();
        assert!((slerp(&a, &b, 0.5) - m).abs().max() < 1e-12);
    }
}

//! Canonical signs of eigenvectors ([`canonicalize_signs`]): fixed hashed
//! weight vectors decide the sign of each vector, independently of the
//! solver's start, block size or rounding.

use nalgebra::DMatrix;

/// Relative size below which `⟨φ, w⟩_M` is not trusted to fix the sign of
/// `φ` (see [`canonicalize_signs`]).
const SIGN_TAU: f64 = 1e-6;

/// Number of weight vectors tried by [`canonicalize_signs`] before the
/// largest-entry fallback.
const SIGN_WEIGHTS: u64 = 3;

/// Entry `i` of the `r`-th fixed sign weight vector: `1 + u − ½` with `u` in
/// `[0, 1)` from a SplitMix64 hash of `(r, i)`. Depends only on the index.
fn sign_weight(r: u64, i: usize) -> f64 {
    let mut z = (i as u64)
        .wrapping_add(r.wrapping_mul(0xD1B5_4A32_D192_ED03))
        .wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    0.5 + (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Gives every column `φ` of `vectors` its canonical sign (the rule that
/// [`generalized_eigen`](super::generalized_eigen) applies to its results),
/// in place; `m` is the diagonal mass.
///
/// **Rule.** `φ` is made to satisfy `⟨φ, w_r⟩_M = Σ m_i w_{r,i} φ_i > 0` for
/// the first of a few fixed weight vectors `w_0, w_1, w_2` whose product is
/// not negligible, `|⟨φ, w_r⟩_M| > τ ‖φ‖_M ‖w_r‖_M` with `τ = 1e-6`; if all
/// three are negligible (or for a vector that is zero there), its entry of
/// largest magnitude (lowest index on ties) is made positive. The weights
/// `w_{r,i} = 1 + (u_{r,i} − ½)`, `u` a fixed hash of `(r, i)` in `[0, 1)`,
/// depend only on the vertex index, so the sign depends only on the vector
/// (and the masses), not on the solver's random start, block size or
/// rounding.
///
/// **Why this rule.** Any sign rule is discontinuous somewhere; the question
/// is how likely a computed eigenvector lands there. "Largest entry
/// positive" fails on every symmetric mesh, where an odd eigenfunction has
/// two extreme entries of equal magnitude and opposite sign, so rounding
/// decides. Against a generic weight vector, the product of a unit vector is
/// of relative size `~ 1/√n` (`w` is not aligned with the mesh's
/// symmetries: the hash of the index knows nothing of the geometry), far
/// above the relative accuracy of the vectors (`≲ 1e-7`); the chance that
/// it falls below `τ` is about `τ √n`, and then a second, independent
/// weight decides. The constant part of `w` makes the constant eigenvector
/// of a closed (or Neumann) mesh positive; the other eigenvectors are
/// M-orthogonal to constants, so for them only the hashed part matters.
///
/// **Repeated eigenvalues.** For an eigenvalue of multiplicity `> 1` the
/// vectors inside its eigenspace are arbitrary (any M-orthonormal basis is
/// valid and the solver returns one that depends on its start); only the
/// sign of each returned vector is canonicalised, not the rotation.
///
/// Idempotent, and `φ` and `−φ` give bit-identical results (`⟨−φ, w⟩_M` is
/// computed as exactly `−⟨φ, w⟩_M`).
pub fn canonicalize_signs(vectors: &mut DMatrix<f64>, m: &[f64]) {
    let n = vectors.nrows();
    assert_eq!(m.len(), n, "one mass per row");
    // (M w_r, ‖w_r‖²_M), computed when first needed.
    let mut weights: Vec<(Vec<f64>, f64)> = Vec::new();
    for mut col in vectors.column_iter_mut() {
        let norm2: f64 = col.iter().zip(m).map(|(x, w)| w * x * x).sum();
        let mut sign = 0.0;
        for r in 0..SIGN_WEIGHTS {
            if weights.len() <= r as usize {
                let mw: Vec<f64> = (0..n).map(|i| m[i] * sign_weight(r, i)).collect();
                let w2 = (0..n).map(|i| mw[i] * sign_weight(r, i)).sum();
                weights.push((mw, w2));
            }
            let (mw, w2) = &weights[r as usize];
            let p: f64 = col.iter().zip(mw).map(|(x, w)| w * x).sum();
            if p.abs() > SIGN_TAU * (norm2 * w2).sqrt() {
                sign = p.signum();
                break;
            }
        }
        if sign == 0.0 {
            let mut best = (0.0f64, 0usize);
            for (i, x) in col.iter().enumerate() {
                if x.abs() > best.0 {
                    best = (x.abs(), i);
                }
            }
            sign = if col[best.1] < 0.0 { -1.0 } else { 1.0 };
        }
        if sign < 0.0 {
            col.neg_mut();
        }
    }
}

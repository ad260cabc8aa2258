//! L1-penalised quadratic minimisation by cyclic coordinate descent: the
//! elastic net (Zou & Hastie 2005) in its Gram form, used for FBT's sparse
//! initial transformations (FBT Eq. 23).
//!
//! Each column `x` of the unknown is solved independently:
//!
//! ```text
//! min_x  ½ xᵀ Q x − cᵀ x + l1 ‖x‖₁
//! ```
//!
//! with `Q` symmetric positive semi-definite with a positive diagonal. For
//! least squares with a ridge, `Q = β XᵀX + B`, `c = β Xᵀ y`, which is
//! `½β‖Xx − y‖² + ½ xᵀBx + l1‖x‖₁` up to a constant (the elastic net when
//! `B` is a multiple of the identity). Coordinate `a` is updated by the exact
//! one-dimensional minimiser
//!
//! ```text
//! x_a ← S(c_a − Σ_{a'≠a} Q_{aa'} x_{a'}, l1) / Q_aa,   S(z, t) = sign(z)·max(|z| − t, 0),
//! ```
//!
//! keeping the gradient `g = Qx − c` up to date (O(b) per update). Each
//! update cannot increase the objective. Sweeps go over the coordinates in
//! index order (deterministic, no random choice).
//!
//! **Active-set refinement.** Plain coordinate descent crawls on the
//! ill-conditioned Gram matrices of redundant dictionaries (measured: after
//! 2000 sweeps still 14× above the minimum). Every [`REFINE_EVERY`] sweeps
//! the support `A` and signs `s` of the iterate are frozen and the smooth
//! problem on that face is solved exactly, `Q_AA z = c_A − l1 s` (Cholesky);
//! `z` replaces the iterate when the true objective (with `|z|`) does not
//! increase, so the objective stays non-increasing; with consistent signs
//! `z` is the exact minimiser on that face, and further sweeps fix the
//! support otherwise. The solve
//! stops when the optimality (KKT) conditions hold to `tol · max|c|`:
//! `|g_a| ≤ l1` where `x_a = 0`, `g_a = −l1·sign(x_a)` elsewhere.

use nalgebra::DMatrix;

use crate::{Error, Result};

/// Sweeps between active-set refinements.
pub const REFINE_EVERY: usize = 5;

/// Options of [`quadratic_l1`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoordinateDescentOptions {
    /// Maximum sweeps over all coordinates.
    pub max_sweeps: usize,
    /// Relative KKT tolerance (times `max|c|`).
    pub tol: f64,
}

impl Default for CoordinateDescentOptions {
    fn default() -> Self {
        CoordinateDescentOptions {
            max_sweeps: 2000,
            tol: 1e-9,
        }
    }
}

/// Result of [`quadratic_l1`].
#[derive(Clone, Debug)]
pub struct L1Solution {
    /// b × k minimisers (one column per column of `c`).
    pub x: DMatrix<f64>,
    /// Sweeps used by the slowest column.
    pub sweeps: usize,
    /// Whether every column met the tolerance.
    pub converged: bool,
}

/// Minimises `½ xᵀQx − cᵀx + l1‖x‖₁` for every column of `c` (see the
/// module documentation), starting from zero. Errors when shapes disagree,
/// `l1 < 0`, an entry is not finite or a diagonal entry of `Q` is not
/// positive.
pub fn quadratic_l1(
    q: &DMatrix<f64>,
    c: &DMatrix<f64>,
    l1: f64,
    opts: &CoordinateDescentOptions,
) -> Result<L1Solution> {
    let b = q.nrows();
    if q.ncols() != b || c.nrows() != b {
        return Err(Error::invalid(format!(
            "coordinate descent: Q is {}x{}, c has {} rows",
            q.nrows(),
            q.ncols(),
            c.nrows()
        )));
    }
    if !(l1.is_finite() && l1 >= 0.0) {
        return Err(Error::invalid(format!(
            "L1 weight must be finite and ≥ 0, got {l1}"
        )));
    }
    if q.iter().chain(c.iter()).any(|x| !x.is_finite()) {
        return Err(Error::invalid("coordinate descent input is not finite"));
    }
    if let Some(a) = (0..b).find(|&a| q[(a, a)] <= 0.0) {
        return Err(Error::invalid(format!(
            "coordinate descent needs a positive diagonal; Q[{a},{a}] = {}",
            q[(a, a)]
        )));
    }
    let k = c.ncols();
    let mut x = DMatrix::zeros(b, k);
    let mut max_sweeps_used = 0;
    let mut converged = true;
    for col in 0..k {
        let mut xc = vec![0.0; b];
        // g = Q x − c with x = 0.
        let mut g: Vec<f64> = (0..b).map(|a| -c[(a, col)]).collect();
        let cmax = (0..b).fold(0.0_f64, |m, a| m.max(c[(a, col)].abs()));
        let ktol = opts.tol * cmax.max(f64::MIN_POSITIVE);
        let mut done = kkt_ok(&xc, &g, l1, ktol);
        let mut sweeps = 0;
        while !done && sweeps < opts.max_sweeps {
            sweeps += 1;
            for a in 0..b {
                let qaa = q[(a, a)];
                // c_a − Σ_{a'≠a} Q x = −(g_a − Q_aa x_a)
                let z = -(g[a] - qaa * xc[a]);
                let new = soft(z, l1) / qaa;
                let delta = new - xc[a];
                if delta != 0.0 {
                    for (gi, qi) in g.iter_mut().zip(q.column(a).iter()) {
                        *gi += qi * delta;
                    }
                    xc[a] = new;
                }
            }
            if sweeps % REFINE_EVERY == 0 {
                refine(q, c, col, l1, &mut xc, &mut g);
            }
            done = kkt_ok(&xc, &g, l1, ktol);
        }
        converged &= done;
        max_sweeps_used = max_sweeps_used.max(sweeps);
        for a in 0..b {
            x[(a, col)] = xc[a];
        }
    }
    Ok(L1Solution {
        x,
        sweeps: max_sweeps_used,
        converged,
    })
}

/// Objective `½ xᵀQx − cᵀx + l1‖x‖₁` summed over columns.
pub fn quadratic_l1_objective(
    q: &DMatrix<f64>,
    c: &DMatrix<f64>,
    l1: f64,
    x: &DMatrix<f64>,
) -> f64 {
    let qx = q * x;
    0.5 * x.dot(&qx) - c.dot(x) + l1 * x.iter().map(|v| v.abs()).sum::<f64>()
}

/// The smallest `l1` for which the solution is zero: `max |c|`.
pub fn l1_max(c: &DMatrix<f64>) -> f64 {
    c.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// KKT conditions of `½xᵀQx − cᵀx + l1‖x‖₁` at `x` with gradient `g`.
fn kkt_ok(x: &[f64], g: &[f64], l1: f64, tol: f64) -> bool {
    x.iter().zip(g).all(|(&xa, &ga)| {
        if xa == 0.0 {
            ga.abs() <= l1 + tol
        } else {
            (ga + l1 * xa.signum()).abs() <= tol
        }
    })
}

/// One active-set step (see the module docs); updates `x` and `g = Qx − c`
/// when accepted.
fn refine(q: &DMatrix<f64>, c: &DMatrix<f64>, col: usize, l1: f64, x: &mut [f64], g: &mut [f64]) {
    let act: Vec<usize> = (0..x.len()).filter(|&a| x[a] != 0.0).collect();
    if act.is_empty() {
        return;
    }
    let k = act.len();
    let qa = DMatrix::from_fn(k, k, |i, j| q[(act[i], act[j])]);
    let rhs = nalgebra::DVector::from_fn(k, |i, _| c[(act[i], col)] - l1 * x[act[i]].signum());
    let Some(chol) = qa.cholesky() else {
        return;
    };
    let z = chol.solve(&rhs);
    let mut xn = vec![0.0; x.len()];
    for (i, &a) in act.iter().enumerate() {
        xn[a] = z[i];
    }
    let obj = |v: &[f64]| -> f64 {
        let mut f = 0.0;
        for (a, &va) in v.iter().enumerate() {
            if va == 0.0 {
                continue;
            }
            let qv: f64 = v.iter().enumerate().map(|(b, &vb)| q[(a, b)] * vb).sum();
            f += 0.5 * va * qv - c[(a, col)] * va + l1 * va.abs();
        }
        f
    };
    if obj(&xn) <= obj(x) {
        for (a, ga) in g.iter_mut().enumerate() {
            *ga = (0..x.len()).map(|b| q[(a, b)] * xn[b]).sum::<f64>() - c[(a, col)];
        }
        x.copy_from_slice(&xn);
    }
}

fn soft(z: f64, t: f64) -> f64 {
    if z > t {
        z - t
    } else if z < -t {
        z + t
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_problem(seed: u64, b: usize, h: usize) -> (DMatrix<f64>, DMatrix<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x = DMatrix::from_fn(h, b, |_, _| rng.random::<f64>() - 0.5);
        let y = DMatrix::from_fn(h, 2, |_, _| rng.random::<f64>() - 0.5);
        let mut q = x.transpose() * &x;
        for a in 0..b {
            q[(a, a)] += 1e-3;
        }
        (q, x.transpose() * y)
    }

    #[test]
    fn zero_penalty_is_the_linear_solve() {
        let (q, c) = random_problem(1, 6, 20);
        let s = quadratic_l1(&q, &c, 0.0, &CoordinateDescentOptions::default()).unwrap();
        let direct = q.clone().cholesky().unwrap().solve(&c);
        assert!(s.converged);
        assert!(
            (&s.x - &direct).abs().max() < 1e-7,
            "{}",
            (&s.x - direct).abs().max()
        );
    }

    #[test]
    fn kkt_conditions_hold_and_penalty_sparsifies() {
        let (q, c) = random_problem(2, 12, 8);
        let l1 = 0.3 * l1_max(&c);
        let s = quadratic_l1(&q, &c, l1, &CoordinateDescentOptions::default()).unwrap();
        let g = &q * &s.x - &c;
        let mut zeros = 0;
        for (gi, xi) in g.iter().zip(s.x.iter()) {
            if *xi == 0.0 {
                zeros += 1;
                assert!(gi.abs() <= l1 * (1.0 + 1e-6), "{gi} > {l1}");
            } else {
                assert!((gi + l1 * xi.signum()).abs() < 1e-6 * l1.max(1.0));
            }
        }
        assert!(zeros > 0);
        // Above l1_max the solution vanishes.
        let s0 = quadratic_l1(&q, &c, 1.01 * l1_max(&c), &Default::default()).unwrap();
        assert!(s0.x.iter().all(|&v| v == 0.0));
        // Objective below that of the zero vector and of small perturbations.
        let f = quadratic_l1_objective(&q, &c, l1, &s.x);
        assert!(f < 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..20 {
            let p = DMatrix::from_fn(12, 2, |_, _| 1e-3 * (rng.random::<f64>() - 0.5));
            assert!(quadratic_l1_objective(&q, &c, l1, &(&s.x + p)) >= f - 1e-12);
        }
    }

    #[test]
    fn ill_conditioned_gram_matrix_converges() {
        // Nearly collinear columns (condition number ~1e8): plain coordinate
        // descent crawls here; with the active-set refinement and l1 = 0 the
        // KKT conditions hold after a few dozen sweeps and the result is the
        // direct solve.
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (h, b) = (30, 10);
        let base = DMatrix::from_fn(h, 1, |_, _| rng.random::<f64>() - 0.5);
        let x = DMatrix::from_fn(h, b, |i, j| {
            base[(i, 0)] * (1.0 + 0.1 * j as f64) + 1e-3 * (rng.random::<f64>() - 0.5)
        });
        let q = x.transpose() * &x;
        let c = x.transpose() * DMatrix::from_fn(h, 1, |_, _| rng.random::<f64>() - 0.5);
        let opts = CoordinateDescentOptions::default();
        let s = quadratic_l1(&q, &c, 0.0, &opts).unwrap();
        assert!(s.converged && s.sweeps <= 50, "{} sweeps", s.sweeps);
        let direct = q.clone().cholesky().unwrap().solve(&c);
        let f_cd = quadratic_l1_objective(&q, &c, 0.0, &s.x);
        let f_direct = quadratic_l1_objective(&q, &c, 0.0, &direct);
        assert!(
            (f_cd - f_direct).abs() <= 1e-9 * f_direct.abs(),
            "{f_cd} vs {f_direct}"
        );
        // With a penalty the support has to be found by the sweeps; the KKT
        // conditions still hold well within the sweep limit.
        let l1 = 0.1 * l1_max(&c);
        let s = quadratic_l1(&q, &c, l1, &opts).unwrap();
        assert!(s.converged && s.sweeps <= 500, "{} sweeps", s.sweeps);
        let g = &q * &s.x - &c;
        for (gi, xi) in g.iter().zip(s.x.iter()) {
            if *xi == 0.0 {
                assert!(gi.abs() <= l1 * (1.0 + 1e-6), "{gi} > {l1}");
            } else {
                assert!((gi + l1 * xi.signum()).abs() <= 1e-6 * l1, "{gi}");
            }
        }
        assert!(s.x.iter().any(|&v| v == 0.0));
    }

    #[test]
    fn rejects_bad_input() {
        let q = DMatrix::<f64>::zeros(2, 2);
        let c = DMatrix::<f64>::zeros(2, 1);
        assert!(quadratic_l1(&q, &c, 0.0, &Default::default()).is_err());
        let q = DMatrix::<f64>::identity(2, 2);
        assert!(quadratic_l1(&q, &c, -1.0, &Default::default()).is_err());
        assert!(quadratic_l1(&q, &DMatrix::zeros(3, 1), 0.0, &Default::default()).is_err());
    }
}

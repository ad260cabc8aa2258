//! [`simplex_rows_qp`]: the simplex-rows QP solved exactly by an active-set
//! method on the row supports (with optional local refinement), and its KKT
//! residual.

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::common::{
    check_spd_candidate, grow_region, project_to_simplex, sym_matvec_add, LOCAL_MAX_ITER,
};
use super::ordered::{FactorBuffers, Ordered, OrderedCholesky, UpperCsc};
use crate::solve::SparseMatrix;
use crate::{Error, Result};

/// Options of [`simplex_rows_qp`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimplexQpOptions {
    /// Global support iterations allowed.
    pub max_iter: usize,
    /// Support test tolerance, per row and scale-free (see
    /// [`simplex_rows_qp`]).
    pub tol: f64,
    /// Local refinement: steps of `A`'s graph around the changed rows (0 =
    /// off; see [`simplex_rows_qp`]).
    pub local_hops: usize,
    /// Step test: the iteration also stops when a global iteration moved no
    /// entry of `X` by more than this from the previous global iteration's
    /// solution (0 = off: stop only when the supports no longer change).
    /// The supports then still change, but only where the multipliers sit
    /// at the tolerance, and by less than `step_tol` in every entry.
    pub step_tol: f64,
}

impl SimplexQpOptions {
    /// `max_iter` and `tol`, no local refinement, no step test: the support
    /// iteration stops only when the supports no longer change.
    pub fn new(max_iter: usize, tol: f64) -> Self {
        SimplexQpOptions {
            max_iter,
            tol,
            local_hops: 0,
            step_tol: 0.0,
        }
    }
}

/// Result of [`simplex_rows_qp`].
#[derive(Clone, Debug)]
pub struct SimplexQpSolution {
    /// The minimiser (every row exactly on the simplex).
    pub x: DMatrix<f64>,
    /// Global support iterations (each a factorisation of the whole
    /// reduced system).
    pub iterations: usize,
    /// Iterations of local refinement (`local_hops`), each a factorisation
    /// of the reduced system of a small region of rows.
    pub local_iterations: usize,
    /// Size of the last reduced system.
    pub n_variables: usize,
    /// Whether the iteration stopped within the iteration limit, by either
    /// test (if not, `x` is the last iterate projected onto the simplex row
    /// by row).
    pub converged: bool,
    /// Whether it stopped on the step test ([`SimplexQpOptions::step_tol`])
    /// rather than on unchanged supports.
    pub stopped_on_step: bool,
    /// Largest change of an entry of `X` between the last two global
    /// iterations (infinite after a single one).
    pub last_step: f64,
    /// KKT residual of `x` in units of `x` (scale-free, per row `i`): with
    /// `G = A X + B` and `ν_i = G_ip` at the row's largest entry `p`, the
    /// largest `|G_ik − ν_i| / A_ii` over `k` with `X_ik > 0` and the largest
    /// `(ν_i − G_ik)⁺ / A_ii` over `k` with `X_ik = 0`; 0 at the optimum.
    pub kkt_residual: f64,
}

/// `G = A X + B`, column by column.
fn gradient_matrix(a: &SparseMatrix, x: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let n = x.nrows();
    let mut g = b.clone();
    g.as_mut_slice()
        .par_chunks_mut(n.max(1))
        .zip(x.as_slice().par_chunks(n.max(1)))
        .for_each(|(gk, xk)| sym_matvec_add(a, xk, gk));
    g
}

/// KKT residual of a row-stochastic `x` for the simplex-rows QP (see
/// [`SimplexQpSolution::kkt_residual`]).
pub fn simplex_rows_kkt_residual(a: &SparseMatrix, b: &DMatrix<f64>, x: &DMatrix<f64>) -> f64 {
    let g = gradient_matrix(a, x, b);
    let mut diag = vec![0.0; a.nrows()];
    for (i, j, &v) in a.triplet_iter() {
        if i == j {
            diag[i] = v;
        }
    }
    let m = x.ncols();
    let mut r = 0.0f64;
    for i in 0..x.nrows() {
        let p = (0..m)
            .max_by(|&p, &q| x[(i, p)].total_cmp(&x[(i, q)]).then(q.cmp(&p)))
            .unwrap_or(0);
        let nu = g[(i, p)];
        for k in 0..m {
            let d = (g[(i, k)] - nu) / diag[i];
            r = r.max(if x[(i, k)] > 0.0 {
                d.abs()
            } else {
                (-d).max(0.0)
            });
        }
    }
    r
}

/// Iterate of [`simplex_rows_qp`]: supports, pivots and the values.
struct SimplexState {
    /// `support[i*m + k]`: `k ∈ S_i`.
    support: Vec<bool>,
    pivot: Vec<usize>,
    x: DMatrix<f64>,
    /// Unknowns of row i: `var_start[i] .. var_start[i] + handles[i].len()`.
    handles: Vec<Vec<usize>>,
    var_start: Vec<usize>,
    /// The reduced matrix and its factor's buffers, kept between
    /// iterations (allocations of this size fault in fresh pages).
    matrix: UpperCsc,
    bufs: FactorBuffers,
}

/// Row `i` of `G = A X + B` into `g` (`A` symmetric: row `i` read as
/// column `i`).
fn gradient_row(a: &SparseMatrix, b: &DMatrix<f64>, x: &DMatrix<f64>, i: usize, g: &mut [f64]) {
    let (off, rows, vals) = (a.col_offsets(), a.row_indices(), a.values());
    for (k, gk) in g.iter_mut().enumerate() {
        *gk = b[(i, k)];
    }
    for p in off[i]..off[i + 1] {
        let j = rows[p];
        for (k, gk) in g.iter_mut().enumerate() {
            *gk += vals[p] * x[(j, k)];
        }
    }
}

/// One support iteration of [`simplex_rows_qp`]: global (`region = None`)
/// or on the rows inside `region` with every other row frozen at its
/// current values. Solves the reduced system for the current supports,
/// updates the supports of the rows concerned and appends every row whose
/// support changed to `changed`. Returns the number of unknowns.
#[allow(clippy::too_many_arguments)]
fn simplex_step(
    a: &SparseMatrix,
    b: &DMatrix<f64>,
    ordered: &Ordered,
    diag: &[f64],
    tol: f64,
    st: &mut SimplexState,
    region: Option<&[bool]>,
    changed: &mut Vec<usize>,
) -> Result<usize> {
    let n = a.nrows();
    let m = b.ncols();
    let inside = |i: usize| region.is_none_or(|r| r[i]);
    let u = &ordered.upper;
    let SimplexState {
        support,
        pivot,
        x,
        handles,
        var_start,
        matrix: h,
        bufs,
    } = st;
    let mut nv = 0;
    for &i in &ordered.order {
        if !inside(i) {
            handles[i].clear();
            continue;
        }
        if pivot[i] == usize::MAX || !support[i * m + pivot[i]] {
            pivot[i] = (0..m)
                .filter(|&k| support[i * m + k])
                .max_by(|&p, &q| x[(i, p)].total_cmp(&x[(i, q)]).then(q.cmp(&p)))
                .unwrap_or(0);
        }
        let hs = &mut handles[i];
        hs.clear();
        hs.extend((0..m).filter(|&k| k != pivot[i] && support[i * m + k]));
        var_start[i] = nv;
        nv += hs.len();
    }
    // Rows inside: the pivot indicator C; outside: frozen values.
    for i in 0..n {
        if inside(i) {
            for k in 0..m {
                x[(i, k)] = 0.0;
            }
            x[(i, pivot[i])] = 1.0;
        }
    }
    if nv > 0 {
        // rhs = −(G0_ik − G0_ip) with G0 = A X + B at this X (rows inside
        // only; A symmetric, so row i is read as column i).
        let mut g0row = vec![0.0; m];
        let mut rhs = vec![0.0; nv];
        for i in 0..n {
            if handles[i].is_empty() {
                continue;
            }
            gradient_row(a, b, x, i, &mut g0row);
            for (t, &k) in handles[i].iter().enumerate() {
                rhs[var_start[i] + t] = -(g0row[k] - g0row[pivot[i]]);
            }
        }
        // Upper triangle, column (j, l): rows (i, k) for neighbours i
        // earlier in the order, and (j, k ≤ l).
        h.reset(nv);
        for (pj, &j) in ordered.order.iter().enumerate() {
            let pvj = pivot[j];
            for (tl, &l) in handles[j].iter().enumerate() {
                for e in u.col_ptr[pj]..u.col_ptr[pj + 1] {
                    let i = ordered.order[u.row_idx[e]];
                    let aij = u.values[e];
                    let pvi = pivot[i];
                    let hi_ = &handles[i];
                    let last = if i == j { tl + 1 } else { hi_.len() };
                    for (tk, &k) in hi_[..last].iter().enumerate() {
                        let c = (k == l) as i32 - (k == pvj) as i32 - (pvi == l) as i32
                            + (pvi == pvj) as i32;
                        if c != 0 {
                            h.push(var_start[i] + tk, aij * c as f64);
                        }
                    }
                }
                h.end_column();
            }
        }
        let fac = OrderedCholesky::factorize_with(h, bufs)?;
        fac.solve_in_place_with(&mut rhs, 1, &mut bufs.scratch);
        fac.recycle(bufs);
        if rhs.iter().any(|v| !v.is_finite()) {
            return Err(Error::numerical(
                "simplex-rows QP: the reduced solve produced non-finite values",
            ));
        }
        for i in 0..n {
            for (t, &k) in handles[i].iter().enumerate() {
                let v = rhs[var_start[i] + t];
                x[(i, k)] = v;
                x[(i, pivot[i])] -= v;
            }
        }
    }
    // Gradient and support update (rows inside).
    let mut g = vec![0.0; m];
    for i in 0..n {
        if !inside(i) {
            continue;
        }
        gradient_row(a, b, x, i, &mut g);
        let gp = g[pivot[i]];
        let mut row_changed = false;
        for k in 0..m {
            let s = &mut support[i * m + k];
            if *s && x[(i, k)] < -tol {
                *s = false;
                row_changed = true;
            } else if !*s && g[k] - gp < -tol * diag[i] {
                *s = true;
                row_changed = true;
            }
        }
        if !(0..m).any(|k| support[i * m + k]) {
            // Every support entry was negative (cannot happen for a row
            // summing to one); keep the largest.
            let k = (0..m)
                .max_by(|&p, &q| x[(i, p)].total_cmp(&x[(i, q)]).then(q.cmp(&p)))
                .unwrap_or(0);
            support[i * m + k] = true;
        }
        if row_changed {
            changed.push(i);
        }
    }
    Ok(nv)
}

/// `min Σ_k ½ x_kᵀA x_k + b_kᵀx_k` over `X` (n × m) with every row on the
/// probability simplex (`X ≥ 0`, rows sum to one), `A` sparse symmetric
/// positive definite, by a primal–dual active-set method on the row
/// supports `S_i = {k : X_ik > 0}`.
///
/// For fixed supports, each row's partition of unity is eliminated by
/// writing one support entry (the pivot `p(i)`: the row's largest entry when
/// it was chosen, kept while it stays in the support) as one
/// minus the others; the remaining `Σ_i (|S_i| − 1)` unknowns solve one
/// sparse SPD system `Eᵀ(I ⊗ A)E v = −Eᵀ(A C + B)`. Its unknowns are
/// numbered row by row in one AMD ordering of `A` computed once (so each
/// row's unknowns form a block and no iteration pays for an ordering), and
/// its upper triangle is assembled directly in that order. Then entries below
/// `−tol` leave their support, and a column `k ∉ S_i` joins it when its
/// multiplier `G_ik − G_ip(i)` (`G = A X + B`, the cost of moving weight from
/// the pivot to `k`) is below `−tol · A_ii`. When the supports no longer
/// change the KKT conditions hold to `tol` (per-row, scale-free) and the
/// result is the optimum; entries in `[−tol, 0)` are set to 0 and the row
/// rescaled. With [`SimplexQpOptions::step_tol`] > 0 it also stops when a
/// global iteration moved no entry by more than `step_tol` (the last
/// solve's negative entries are then set to 0 and the row rescaled the same
/// way). If `max_iter` is reached first, the last
/// iterate is projected onto the simplex row by row and returned with
/// `converged = false`.
///
/// With `local_hops > 0`, every global iteration that changed a support is
/// followed by local iterations on the rows within `local_hops` steps of
/// `A`'s graph of the changed rows (the others frozen) until their supports
/// settle; only the path changes, the stopping tests are the global ones.
///
/// `x0` (n × m) seeds the supports (`x0_ik > 0`; the largest entry if none).
pub fn simplex_rows_qp(
    a: &SparseMatrix,
    b: &DMatrix<f64>,
    x0: &DMatrix<f64>,
    opts: &SimplexQpOptions,
) -> Result<SimplexQpSolution> {
    let SimplexQpOptions {
        max_iter,
        tol,
        local_hops,
        step_tol,
    } = *opts;
    let n = a.nrows();
    let m = b.ncols();
    if a.ncols() != n || b.nrows() != n || x0.shape() != (n, m) || m == 0 {
        return Err(Error::invalid(format!(
            "simplex-rows QP: A is {}×{}, b is {}×{}, x0 is {}×{}",
            a.nrows(),
            a.ncols(),
            b.nrows(),
            b.ncols(),
            x0.nrows(),
            x0.ncols()
        )));
    }
    let diag = check_spd_candidate(a, "simplex-rows QP")?;
    let ordered = Ordered::new(a)?;
    // support[i*m + k]
    let mut support = vec![false; n * m];
    for i in 0..n {
        let mut any = false;
        for k in 0..m {
            if x0[(i, k)] > 0.0 {
                support[i * m + k] = true;
                any = true;
            }
        }
        if !any {
            let k = (0..m)
                .max_by(|&p, &q| x0[(i, p)].total_cmp(&x0[(i, q)]).then(q.cmp(&p)))
                .unwrap_or(0);
            support[i * m + k] = true;
        }
    }
    // Pivot of each row: its largest support entry (first x0, then the
    // last iterate); kept while it stays in the support.
    let mut st = SimplexState {
        support,
        pivot: vec![usize::MAX; n],
        x: x0.clone(),
        handles: vec![Vec::new(); n],
        var_start: vec![0usize; n],
        matrix: UpperCsc::default(),
        bufs: FactorBuffers::default(),
    };
    let mut nv = 0;
    let mut converged = false;
    let mut iterations = 0;
    let mut changed = Vec::new();
    let mut region = vec![false; n];
    let mut local_iterations = 0;
    let mut stopped_on_step = false;
    let mut last_step = f64::INFINITY;
    // The previous global iteration's solution (for the step test).
    let mut previous: Option<DMatrix<f64>> = None;
    for it in 1..=max_iter.max(1) {
        iterations = it;
        crate::solve::progress::update(
            "bounded biharmonic weights (partition of unity): support iteration",
            it,
            0,
        );
        changed.clear();
        nv = simplex_step(a, b, &ordered, &diag, tol, &mut st, None, &mut changed)?;
        if changed.is_empty() {
            converged = true;
            break;
        }
        if step_tol > 0.0 {
            if let Some(prev) = &previous {
                last_step =
                    st.x.iter()
                        .zip(prev.iter())
                        .fold(0.0f64, |s, (a, b)| s.max((a - b).abs()));
                if last_step <= step_tol {
                    converged = true;
                    stopped_on_step = true;
                    break;
                }
            }
            match &mut previous {
                Some(prev) => prev.copy_from(&st.x),
                None => previous = Some(st.x.clone()),
            }
        }
        if local_hops > 0 && grow_region(a, local_hops, &changed, &mut region) {
            for _ in 0..LOCAL_MAX_ITER {
                local_iterations += 1;
                changed.clear();
                simplex_step(
                    a,
                    b,
                    &ordered,
                    &diag,
                    tol,
                    &mut st,
                    Some(&region),
                    &mut changed,
                )?;
                if changed.is_empty() {
                    break;
                }
            }
        }
    }
    let mut x = st.x;
    let mut row = vec![0.0; m];
    for i in 0..n {
        if converged {
            let mut sum = 0.0;
            for k in 0..m {
                let v = x[(i, k)].max(0.0);
                x[(i, k)] = v;
                sum += v;
            }
            for k in 0..m {
                x[(i, k)] /= sum;
            }
        } else {
            for k in 0..m {
                row[k] = x[(i, k)];
            }
            project_to_simplex(&mut row);
            for k in 0..m {
                x[(i, k)] = row[k];
            }
        }
    }
    let kkt_residual = simplex_rows_kkt_residual(a, b, &x);
    Ok(SimplexQpSolution {
        x,
        iterations,
        local_iterations,
        n_variables: nv,
        converged,
        stopped_on_step,
        last_step,
        kkt_residual,
    })
}

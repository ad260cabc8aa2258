//! Amberg, Romdhani & Vetter 2007, "Optimal step nonrigid ICP algorithms
//! for surface registration", as a registration baseline for the partial
//! experiments (FBT Fig. 7).
//!
//! Every template vertex i has an affine transform `X_i` (4 × 3; the
//! deformed vertex is `[v_iᵀ 1] X_i`). With `X` (4n × 3) stacking them,
//!
//! ```text
//! E(X) = E_d + α E_s + β E_l
//! E_d  = Σ_i w_i ‖[v_iᵀ 1] X_i − u_i‖²                 (data: closest points u_i)
//! E_s  = ‖(M ⊗ G) X‖²_F,  G = diag(1, 1, 1, γ)          (stiffness)
//! E_l  = Σ_r ‖Σ_i h_ri [v_iᵀ 1] X_i − y_r‖²             (landmarks)
//! ```
//!
//! with M the node–arc incidence matrix of the template's edges (one row
//! per undirected edge, +1 / −1 at its ends) and `w_i ∈ {0, 1}`: 0 when the
//! closest point is rejected — farther than `max_distance · √A`, normals
//! more than `max_normal_angle_deg` apart, or on the boundary of a partial
//! target (the rules and options of FBT's NICP, [`crate::register::Matcher`]).
//! The landmarks are constraint rows (`h_r` weighted vertex averages, e.g.
//! the feature circles of the completion experiment, targets `y_r`).
//!
//! **Optimal step.** For each stiffness α of a decreasing schedule
//! (default 10 values, geometric from 100 to 1): repeat — find the closest
//! points of the current deformed template, solve the quadratic E for X
//! exactly — until `‖X^j − X^{j−1}‖_F / √n < tol` or `max_inner`
//! iterations. The normal equations
//! `(α (MᵀM ⊗ G²) + DᵀWD + β (HD)ᵀ(HD)) X = DᵀWU + β (HD)ᵀY` are sparse
//! except for the landmark part (a circle averages many vertices), which
//! is applied by the Woodbury identity around the sparse part; that is
//! factorised by the crate's sparse Cholesky (the symbolic analysis once,
//! the pattern does not change).
//!
//! **Units.** The template is centred at its centroid and scaled to a unit
//! bounding-box diagonal before solving (targets and landmarks alike), so
//! that γ = 1 and the α schedule mean the same on every data set; results
//! are mapped back. A landmark row has weight
//! `β = landmark_weight · n / h` (n vertices, h rows), so
//! `landmark_weight = 1` balances all landmarks against a fully matched
//! data term. The default 10 was the best of {0.1, 1, 10} on one synthetic
//! partial case (pose 2 of the synthetic class, 80 feature-circle rows:
//! mean relative distortion 0.050 / 0.045 / 0.040; the α schedules
//! 1000→1, 100→0.1 and 10→0.1 were no better than 100→1).
//!
//! **Simplifications against the paper.** A ridge `ε ‖X − X_I‖²`
//! (ε = 1e-8, X_I the identity transforms) keeps the system definite while
//! few points are matched; the inner loop is capped at `max_inner`
//! iterations; the landmark weight is fixed (the paper also keeps β fixed
//! within a schedule; it lowers it only for noisy landmarks); the closest
//! points are target vertices (not points on triangles), as in FBT's NICP.

use nalgebra::DMatrix;

use crate::mesh::Mesh;
use crate::ops::edges;
use crate::ops::Operators;
use crate::register::{ConstraintRows, Matcher, NicpOptions};
use crate::solve::{sparse_from_triplets, SymbolicCholesky};
use crate::{Error, Point, Result, Vec3};

/// Options of [`amberg_nicp`].
#[derive(Clone, Debug, PartialEq)]
pub struct AmbergOptions {
    /// Stiffness schedule α (decreasing).
    pub stiffness: Vec<f64>,
    /// Weight γ of the translation part in the stiffness term.
    pub gamma: f64,
    /// Landmark weight relative to the data term (see the module docs).
    pub landmark_weight: f64,
    /// Inner iterations per stiffness at most.
    pub max_inner: usize,
    /// Convergence threshold of the inner loop (`‖ΔX‖_F / √n`, normalised
    /// units).
    pub tol: f64,
    /// Correspondence rules (`samples`, `max_distance`,
    /// `max_normal_angle_deg`, `neighbours`, `reject_boundary`; the other
    /// fields are not used). `samples = 0`: every template vertex.
    pub icp: NicpOptions,
}

impl Default for AmbergOptions {
    fn default() -> Self {
        AmbergOptions {
            stiffness: (0..10)
                .map(|k| 100.0 * 0.01f64.powf(k as f64 / 9.0))
                .collect(),
            gamma: 1.0,
            landmark_weight: 10.0,
            max_inner: 5,
            tol: 1e-4,
            icp: NicpOptions {
                samples: 0,
                ..NicpOptions::default()
            },
        }
    }
}

/// Result of [`amberg_nicp`].
#[derive(Clone, Debug)]
pub struct AmbergResult {
    /// Deformed template vertices.
    pub positions: Vec<Point>,
    /// Per-vertex affine transforms (4n × 3, normalised frame).
    pub transforms: DMatrix<f64>,
    /// `(α, inner iterations run)` per stiffness.
    pub steps: Vec<(f64, usize)>,
    /// Accepted closest points per inner iteration.
    pub accepted: Vec<usize>,
    /// Mean distance of the accepted pairs per inner iteration.
    pub mean_distance: Vec<f64>,
}

/// Registers `template` to `target` (possibly partial) with landmark rows
/// `landmarks = (H over template vertices, Y)` (see the module docs).
pub fn amberg_nicp(
    template: &Mesh,
    target: &Mesh,
    landmarks: (&ConstraintRows, &DMatrix<f64>),
    opts: &AmbergOptions,
) -> Result<AmbergResult> {
    let (hrows, hy) = landmarks;
    let n = template.n_vertices();
    if n == 0 {
        return Err(Error::invalid("Amberg NICP: empty template"));
    }
    if hy.nrows() != hrows.len() || hy.ncols() != 3 {
        return Err(Error::invalid(format!(
            "landmark targets must be {} × 3, got {} × {}",
            hrows.len(),
            hy.nrows(),
            hy.ncols()
        )));
    }
    if opts.stiffness.is_empty() || opts.stiffness.iter().any(|a| !(a.is_finite() && *a > 0.0)) {
        return Err(Error::invalid(
            "Amberg NICP: the stiffness schedule needs positive values",
        ));
    }
    let ok = |v: f64, positive: bool| v.is_finite() && (v > 0.0 || (!positive && v == 0.0));
    if !(ok(opts.gamma, true) && ok(opts.landmark_weight, false) && ok(opts.tol, false)) {
        return Err(Error::invalid(
            "Amberg NICP: gamma > 0, landmark_weight ≥ 0 and tol ≥ 0 required",
        ));
    }
    for (r, row) in hrows.iter().enumerate() {
        for &(i, w) in row {
            if i >= n || !w.is_finite() {
                return Err(Error::invalid(format!(
                    "landmark row {r}: entry ({i}, {w}) invalid for {n} vertices"
                )));
            }
        }
    }
    if hy.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid("landmark targets are not finite"));
    }
    // Normalised frame.
    let v = template.vertices();
    let c = v.iter().fold(Vec3::zeros(), |a, p| a + p.coords) / n as f64;
    let (mut lo, mut hi) = (v[0].coords, v[0].coords);
    for p in v {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let s = (hi - lo).norm();
    if !s.is_finite() || s <= 0.0 {
        return Err(Error::invalid("Amberg NICP: degenerate template"));
    }
    let d: Vec<[f64; 4]> = v
        .iter()
        .map(|p| {
            let q = (p.coords - c) / s;
            [q.x, q.y, q.z, 1.0]
        })
        .collect();
    let matcher = Matcher::new(template, template.mass_area(), target, &opts.icp)?;
    let edge_list = edges(template);
    let g2 = [1.0, 1.0, 1.0, opts.gamma * opts.gamma];
    const EPS: f64 = 1e-8;
    let dim = 4 * n;
    // Landmarks: single-vertex rows go into the sparse diagonal blocks
    // (`lw`), the others into V (4n × h_dense) for the Woodbury identity;
    // `lrhs` = β (HD)ᵀ Y of all rows.
    let h = hrows.len();
    let beta = if h > 0 {
        opts.landmark_weight * n as f64 / h as f64
    } else {
        0.0
    };
    let sb = beta.sqrt();
    let dense: Vec<usize> = (0..h).filter(|&r| hrows[r].len() != 1).collect();
    let hd = dense.len();
    let mut lw = vec![0.0; n];
    let mut vmat = DMatrix::<f64>::zeros(dim, hd);
    let mut lrhs = DMatrix::<f64>::zeros(dim, 3);
    for (r, row) in hrows.iter().enumerate() {
        let wsum: f64 = row.iter().map(|e| e.1).sum();
        let yr = (Vec3::new(hy[(r, 0)], hy[(r, 1)], hy[(r, 2)]) - c * wsum) / s;
        for &(i, w) in row {
            for a in 0..4 {
                for k in 0..3 {
                    lrhs[(4 * i + a, k)] += beta * w * d[i][a] * yr[k];
                }
            }
        }
        if let [(i, w)] = row.as_slice() {
            lw[*i] += beta * w * w;
        }
    }
    for (col, &r) in dense.iter().enumerate() {
        for &(i, w) in &hrows[r] {
            for a in 0..4 {
                vmat[(4 * i + a, col)] += sb * w * d[i][a];
            }
        }
    }
    let assemble = |alpha: f64, w: &[f64]| {
        let mut t = Vec::with_capacity(8 * edge_list.len() + 16 * n);
        for &(i, j) in &edge_list {
            for (a, g) in g2.iter().enumerate() {
                let x = alpha * g;
                t.push((4 * i + a, 4 * i + a, x));
                t.push((4 * j + a, 4 * j + a, x));
                t.push((4 * i + a, 4 * j + a, -x));
                t.push((4 * j + a, 4 * i + a, -x));
            }
        }
        for i in 0..n {
            for a in 0..4 {
                for b in 0..4 {
                    let mut x = (w[i] + lw[i]) * d[i][a] * d[i][b];
                    if a == b {
                        x += EPS;
                    }
                    t.push((4 * i + a, 4 * i + b, x));
                }
            }
        }
        sparse_from_triplets(dim, dim, t)
    };
    let mut symbolic: Option<SymbolicCholesky> = None;
    let mut x = DMatrix::zeros(dim, 3);
    for i in 0..n {
        for k in 0..3 {
            x[(4 * i + k, k)] = 1.0;
        }
    }
    let x_id = x.clone();
    let positions_of = |x: &DMatrix<f64>| -> Vec<Point> {
        (0..n)
            .map(|i| {
                let mut q = Vec3::zeros();
                for k in 0..3 {
                    q[k] = (0..4).map(|a| d[i][a] * x[(4 * i + a, k)]).sum();
                }
                Point::from(q * s + c)
            })
            .collect()
    };
    let mut steps = Vec::new();
    let mut accepted = Vec::new();
    let mut mean_distance = Vec::new();
    let sqrt_n = (n as f64).sqrt();
    for (step, &alpha) in opts.stiffness.iter().enumerate() {
        crate::solve::progress::update_with(
            || format!("Amberg nonrigid ICP: stiffness {alpha:.3e}, step"),
            step,
            opts.stiffness.len(),
        );
        let mut inner = 0;
        for _ in 0..opts.max_inner.max(1) {
            inner += 1;
            let p = positions_of(&x);
            let m = matcher.matches(&p)?;
            accepted.push(m.pairs.len());
            mean_distance.push(m.mean_distance);
            let mut w = vec![0.0; n];
            let mut rhs = DMatrix::zeros(dim, 3 + hd);
            for &(i, j) in &m.pairs {
                w[i] = 1.0;
                let u = (matcher.target()[j].coords - c) / s;
                for a in 0..4 {
                    for k in 0..3 {
                        rhs[(4 * i + a, k)] += d[i][a] * u[k];
                    }
                }
            }
            for r in 0..dim {
                for k in 0..3 {
                    rhs[(r, k)] += lrhs[(r, k)] + EPS * x_id[(r, k)];
                }
            }
            rhs.columns_mut(3, hd).copy_from(&vmat);
            let a = assemble(alpha, &w);
            let sym = match &symbolic {
                Some(sy) => sy.clone(),
                None => {
                    let sy = SymbolicCholesky::new(&a)?;
                    symbolic = Some(sy.clone());
                    sy
                }
            };
            let chol = sym.factorize(&a)?;
            let z = chol.try_solve(&rhs)?;
            let zb = z.columns(0, 3).into_owned();
            let x_new = if hd > 0 {
                let wv = z.columns(3, hd).into_owned();
                let mut cap = vmat.transpose() * &wv;
                for k in 0..hd {
                    cap[(k, k)] += 1.0;
                }
                let corr = cap
                    .cholesky()
                    .ok_or_else(|| Error::numerical("Amberg NICP: landmark system not definite"))?
                    .solve(&(vmat.transpose() * &zb));
                zb - wv * corr
            } else {
                zb
            };
            let change = (&x_new - &x).norm() / sqrt_n;
            x = x_new;
            if change < opts.tol {
                break;
            }
        }
        steps.push((alpha, inner));
    }
    Ok(AmbergResult {
        positions: positions_of(&x),
        transforms: x,
        steps,
        accepted,
        mean_distance,
    })
}

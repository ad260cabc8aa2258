//! Der, Sumner & Popović 2006, "Inverse kinematics for reduced deformable
//! models", as the deformation model of FBT's shape completion procedure
//! (the comparison of FBT Fig. 7: "plugging in the deformation method
//! proposed by Der et al. into our shape completion procedure, using the
//! same skeleton structure … a modified version of the deformation gradient
//! model that supports soft constraints").
//!
//! **Reduced model.** The vertices are grouped into the rotation clusters
//! of the FBT setup of the case (labels `0..r`, the "same skeleton
//! structure"); every vertex of cluster k shares one deformation gradient
//! `T_k` (3 × 3) — cluster k is the proxy of its vertices, so the model has
//! r proxies. The spokes `i → j` (j a 1-ring neighbour of i, clamped
//! cotangent weights `c_ij` of the reference example, each undirected edge
//! once from each end, as in [`crate::register::model`]) of the vertices of
//! cluster k are its "triangles".
//!
//! **Examples.** For example ℓ and cluster k the example deformation
//! gradient is the least-squares affine map of the cluster's reference
//! spokes to the example's, `T_{ℓk} = argmin Σ c ‖e^ℓ_ij − T e⁰_ij‖²`,
//! with one normal pseudo-spoke per vertex (the vertex normal times the mean
//! length of its spokes in that shape, weight `Σ_j c_ij`) so that flat
//! clusters are determined (the role of Sumner's fourth vertex; a
//! similarity of the reference gives its own matrix exactly). Polar decomposition
//! `T_{ℓk} = R_{ℓk} S_{ℓk}`; the feature vector of example ℓ is
//! `(log R_{ℓk}, S_{ℓk})_k`.
//!
//! **Nonlinear blend** (Sumner et al. 2005, used by Der et al.) with weights
//! `w ∈ ℝ^q` (the unknowns) and a global rotation `R_g`:
//!
//! ```text
//! T_k(w, R_g) = R_g · exp(Σ_ℓ w_ℓ log R_{ℓk}) · Σ_ℓ w_ℓ S_{ℓk}
//! ```
//!
//! **Positions from the cluster transforms** (the Poisson step) with soft
//! constraints `H x ≈ Y` (rows of [`ConstraintRows`]):
//!
//! ```text
//! E(x, w, R_g) = ½ Σ_i Σ_{j∈N(i)} c_ij ‖(x_i − x_j) − T_{k(i)} e⁰_ij‖² + ½ β ‖H x − Y‖²
//! ```
//!
//! is quadratic in x for fixed transforms: `A x = K₀ᵀ F + β HᵀY` with
//! `A = L + β HᵀH` (L the spoke Laplacian), `F` (3r × 3) stacking `T_kᵀ`,
//! so `x = P F + z` with `P = A⁻¹K₀ᵀ` (n × 3r), `z = A⁻¹βHᵀY`. Eliminating
//! x gives the **reduced energy** `E(F) = ½ tr(FᵀMF) − tr(FᵀN) + c₀` with
//! `M = C − K₀P` (3r × 3r, C the block diagonal of `Σ c e⁰e⁰ᵀ` per cluster)
//! and `N = K₀ z`: every Gauss–Newton iteration on (w, R_g) costs O(r² q),
//! independent of n (Der et al.'s point: the cost of IK depends on the
//! proxies, not the mesh). `HᵀH` of the feature-circle rows is dense (a
//! circle averages hundreds of vertices), so `A⁻¹` is applied by the
//! Woodbury identity around a sparse base (`L`, the single-vertex rows on
//! the diagonal, one pinned vertex that is subtracted again) factorised by
//! the crate's sparse Cholesky.
//!
//! **Solver.** Levenberg–Marquardt-damped Gauss–Newton on `θ = (w, ω)`
//! (ω the increment of R_g, `R_g ← exp(ω) R_g`), with the exact Jacobian of
//! the blend (the right Jacobian of the rotation exponential), the
//! Gauss–Newton Hessian `tr(J_pᵀ M J_q)` and only energy-decreasing steps.
//! [`DerModel::register`] starts from every example (`w = e_ℓ`, `R_g` the
//! Kabsch rotation of the constrained example points onto `Y`) and keeps
//! the lowest energy, like FBT's E_mn; [`DerModel::nicp`] then runs the same
//! nonrigid ICP loop as FBT ([`crate::register::Matcher`], same
//! [`NicpOptions`]), warm-started.
//!
//! **Simplifications and changes against the paper** (Der et al. 2006):
//!
//! - The reduced model is not their skinning-based reduction (mean-shift
//!   clustering of skinning weights fitted to the examples, James & Twigg
//!   2005, with control transforms recovered from deformation gradients in
//!   closed form); it is the FBT rotation clusters with one deformation
//!   gradient per cluster and the vertex positions from a Poisson-like
//!   least-squares solve. One cluster is one proxy (their proxy vertices
//!   group vertices of equal deformation gradient, which is what a cluster
//!   is here). The Poisson residual is measured on spokes (edge vectors),
//!   not per triangle.
//! - Constraints are soft (`β ‖Hx − Y‖²`, the FBT paper's modification),
//!   not hard; they may be any weighted vertex averages (the feature
//!   circles), not only vertex positions.
//! - A global rotation `R_g` is an unknown besides the blend weights (the
//!   examples' span contains no rigid rotation of the whole shape; without
//!   it a target rotated away from the examples could not be reached; a
//!   target's translation is absorbed by the Poisson solve). Set
//!   [`DerOptions::global_rotation`] = false for the weights alone.
//! - Gauss–Newton is damped (Levenberg–Marquardt) and multi-started from
//!   every example; the paper uses Gauss–Newton from the previous frame's
//!   weights (interactive IK).
//! - The example gradients are cluster-wise least-squares fits with normal
//!   pseudo-spokes, not per-triangle gradients with a fourth vertex.

use nalgebra::{DMatrix, DVector};

use crate::mesh::Mesh;
use crate::ops::rotation::{rotation_exp_axis_angle, rotation_log_axis_angle};
use crate::ops::Operators;
use crate::ops::{polar_decomposition, vertex_normals};
use crate::register::{ConstraintRows, Matcher, NicpOptions};
use crate::solve::{sparse_from_triplets, SymbolicCholesky};
use crate::{Error, Mat3, Point, Result, Vec3};

/// Options of the Gauss–Newton solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DerOptions {
    /// Maximum Gauss–Newton iterations per solve.
    pub max_iter: usize,
    /// Stop when an iteration lowers the energy by at most `rel_tol · E`.
    pub rel_tol: f64,
    /// Optimise a global rotation besides the blend weights.
    pub global_rotation: bool,
    /// Weight β of the constraints (FBT's β_lc; the Poisson energy has the
    /// units of FBT's ARAP energy, so the same value balances the same way).
    pub beta: f64,
}

impl Default for DerOptions {
    fn default() -> Self {
        DerOptions {
            max_iter: 30,
            rel_tol: 1e-9,
            global_rotation: true,
            beta: 1000.0,
        }
    }
}

/// Blend weights and global rotation.
#[derive(Clone, Debug, PartialEq)]
pub struct DerState {
    /// `w ∈ ℝ^q`.
    pub weights: DVector<f64>,
    /// `R_g`.
    pub rotation: Mat3,
}

impl DerState {
    /// Weight 1 on example `l`, identity rotation.
    pub fn example(q: usize, l: usize) -> Self {
        let mut w = DVector::zeros(q);
        if l < q {
            w[l] = 1.0;
        }
        DerState {
            weights: w,
            rotation: Mat3::identity(),
        }
    }
}

/// A solve's result.
#[derive(Clone, Debug)]
pub struct DerSolution {
    pub state: DerState,
    /// Vertex positions `x = P F + z`.
    pub positions: Vec<Point>,
    /// Final energy E (Poisson + constraints).
    pub energy: f64,
    /// Gauss–Newton iterations run.
    pub iterations: usize,
    /// Energy after every accepted iteration (starting value first).
    pub trace: Vec<f64>,
}

/// Result of [`DerModel::nicp`].
#[derive(Clone, Debug)]
pub struct DerNicpResult {
    pub state: DerState,
    pub positions: Vec<Point>,
    /// Accepted pairs per ICP iteration.
    pub accepted: Vec<usize>,
    /// Mean distance of the accepted pairs per iteration (before its solve).
    pub mean_distance: Vec<f64>,
}

/// The precomputation per (examples, clusters).
#[derive(Clone, Debug)]
pub struct DerModel {
    reference: Mesh,
    examples: Vec<Vec<Point>>,
    clusters: Vec<usize>,
    r: usize,
    area: f64,
    /// Spoke Laplacian triplets (both triangles).
    lap: Vec<(usize, usize, f64)>,
    /// Spokes `(i, j, c_ij)`.
    spokes: Vec<(usize, usize, f64)>,
    lap_diag_mean: f64,
    /// `K₀ᵀ` (n × 3r).
    k0t: DMatrix<f64>,
    /// `C_k = Σ c e⁰e⁰ᵀ` per cluster.
    c: Vec<Mat3>,
    /// `log R_{ℓk}` (axis–angle) and `S_{ℓk}`, `[ℓ][k]`.
    logs: Vec<Vec<Vec3>>,
    stretch: Vec<Vec<Mat3>>,
    /// Example gradients `T_{ℓk}`.
    gradients: Vec<Vec<Mat3>>,
    symbolic: SymbolicCholesky,
}

fn kabsch(src: &[Vec3], dst: &[Vec3], w: &[f64]) -> Mat3 {
    let tw: f64 = w.iter().sum();
    if src.is_empty() || tw <= 0.0 {
        return Mat3::identity();
    }
    let cs = src
        .iter()
        .zip(w)
        .fold(Vec3::zeros(), |a, (p, &x)| a + p * x)
        / tw;
    let cd = dst
        .iter()
        .zip(w)
        .fold(Vec3::zeros(), |a, (p, &x)| a + p * x)
        / tw;
    let mut s = Mat3::zeros();
    for ((p, q), &x) in src.iter().zip(dst).zip(w) {
        s += (q - cd) * (p - cs).transpose() * x;
    }
    match polar_decomposition(&s) {
        Ok(p) => p.rotation,
        Err(_) => Mat3::identity(),
    }
}

/// Right Jacobian of the rotation exponential at `phi`:
/// `exp(φ + t δ) = exp(φ) exp(t [J_r(φ) δ]×) + O(t²)`.
fn right_jacobian(phi: &Vec3) -> Mat3 {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let k = phi.cross_matrix();
    let (a, b) = if t < 1e-4 {
        (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
    } else {
        ((1.0 - t.cos()) / t2, (t - t.sin()) / (t2 * t))
    };
    Mat3::identity() - k * a + k * k * b
}

impl DerModel {
    /// Precomputes the model from q ≥ 1 examples with one face list (the
    /// first is the reference and the template) and one cluster label per
    /// vertex (e.g. [`crate::register::FbtSetup::clusters`]).
    pub fn new(examples: &[Mesh], clusters: &[usize]) -> Result<Self> {
        let Some(reference) = examples.first() else {
            return Err(Error::invalid("Der et al. needs at least one example mesh"));
        };
        let n = reference.n_vertices();
        for (l, e) in examples.iter().enumerate().skip(1) {
            if e.faces() != reference.faces() {
                return Err(Error::invalid(format!(
                    "example {l} does not share the face list of example 0"
                )));
            }
        }
        if clusters.len() != n {
            return Err(Error::invalid(format!(
                "{} cluster labels for {n} vertices",
                clusters.len()
            )));
        }
        let r = clusters.iter().max().map_or(0, |m| m + 1);
        // Spokes (i → j) of clamped cotangent weights.
        let mut nb: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for &((i, j), w) in reference.edge_weights().iter() {
            if w > 0.0 {
                nb[i].push((j, w));
                nb[j].push((i, w));
            }
        }
        let v0 = reference.vertices();
        let mut lap = Vec::new();
        let mut spokes = Vec::new();
        let mut diag = vec![0.0; n];
        let mut k0t = DMatrix::zeros(n, 3 * r);
        let mut c = vec![Mat3::zeros(); r];
        for i in 0..n {
            let k = clusters[i];
            for &(j, w) in &nb[i] {
                let e = v0[i] - v0[j];
                spokes.push((i, j, w));
                lap.push((i, j, -w));
                lap.push((j, i, -w));
                diag[i] += w;
                diag[j] += w;
                for a in 0..3 {
                    k0t[(i, 3 * k + a)] += w * e[a];
                    k0t[(j, 3 * k + a)] -= w * e[a];
                }
                c[k] += e * e.transpose() * w;
            }
        }
        for (i, &d) in diag.iter().enumerate() {
            lap.push((i, i, d));
        }
        let lap_diag_mean = diag.iter().sum::<f64>() / n.max(1) as f64;
        if !lap_diag_mean.is_finite() || lap_diag_mean <= 0.0 {
            return Err(Error::invalid(
                "the reference has no edge of positive cotangent weight",
            ));
        }
        // Example gradients with normal pseudo-spokes.
        let n0 = vertex_normals(reference);
        let mut logs = Vec::new();
        let mut stretch = Vec::new();
        let mut gradients = Vec::new();
        for ex in examples {
            let vl = ex.vertices();
            let nl = vertex_normals(ex);
            let mut num = vec![Mat3::zeros(); r];
            let mut den = vec![Mat3::zeros(); r];
            for i in 0..n {
                let k = clusters[i];
                let mut wsum = 0.0;
                let (mut len0, mut lenl) = (0.0, 0.0);
                for &(j, w) in &nb[i] {
                    let e0 = v0[i] - v0[j];
                    let el = vl[i] - vl[j];
                    num[k] += el * e0.transpose() * w;
                    den[k] += e0 * e0.transpose() * w;
                    wsum += w;
                    len0 += e0.norm();
                    lenl += el.norm();
                }
                if !nb[i].is_empty() {
                    let m = nb[i].len() as f64;
                    let (a, b) = (n0[i] * (len0 / m), nl[i] * (lenl / m));
                    num[k] += b * a.transpose() * wsum;
                    den[k] += a * a.transpose() * wsum;
                }
            }
            let mut lg = Vec::with_capacity(r);
            let mut st = Vec::with_capacity(r);
            let mut gr = Vec::with_capacity(r);
            for k in 0..r {
                let t = match den[k].try_inverse() {
                    Some(inv) if den[k].norm() > 0.0 => num[k] * inv,
                    _ => Mat3::identity(),
                };
                let p = polar_decomposition(&t)?;
                lg.push(rotation_log_axis_angle(&p.rotation));
                st.push(p.stretch);
                gr.push(t);
            }
            logs.push(lg);
            stretch.push(st);
            gradients.push(gr);
        }
        // Pattern of the base matrix: the Laplacian (its diagonal holds the
        // single-vertex rows and the pin).
        let symbolic = SymbolicCholesky::new(&sparse_from_triplets(n, n, lap.iter().copied()))?;
        Ok(DerModel {
            reference: reference.clone(),
            examples: examples.iter().map(|m| m.vertices().to_vec()).collect(),
            clusters: clusters.to_vec(),
            r,
            area: reference.mass_area(),
            lap,
            spokes,
            lap_diag_mean,
            k0t,
            c,
            logs,
            stretch,
            gradients,
            symbolic,
        })
    }

    /// Number of examples q.
    pub fn n_examples(&self) -> usize {
        self.examples.len()
    }

    /// Number of clusters (proxies) r.
    pub fn n_clusters(&self) -> usize {
        self.r
    }

    /// Cluster label of every vertex.
    pub fn clusters(&self) -> &[usize] {
        &self.clusters
    }

    /// The reference (template).
    pub fn reference(&self) -> &Mesh {
        &self.reference
    }

    /// Surface area of the reference.
    pub fn area(&self) -> f64 {
        self.area
    }

    /// The fitted gradient `T_{ℓk}` of example ℓ, cluster k.
    pub fn example_gradient(&self, l: usize, k: usize) -> Option<Mat3> {
        self.gradients.get(l).and_then(|g| g.get(k)).copied()
    }

    /// The blended cluster gradients `T_k(w, R_g)`.
    pub fn blend(&self, state: &DerState) -> Result<Vec<Mat3>> {
        Ok(self.blend_jacobian(state, false)?.0)
    }

    fn check_state(&self, state: &DerState) -> Result<()> {
        if state.weights.len() != self.n_examples() {
            return Err(Error::invalid(format!(
                "{} blend weights for {} examples",
                state.weights.len(),
                self.n_examples()
            )));
        }
        if state.weights.iter().any(|w| !w.is_finite())
            || state.rotation.iter().any(|v| !v.is_finite())
        {
            return Err(Error::invalid("blend weights or rotation not finite"));
        }
        Ok(())
    }

    /// `T_k` and, when `jac`, `∂T_k/∂θ_p` for `θ = (w_0..w_{q−1}, ω_x, ω_y, ω_z)`.
    #[allow(clippy::type_complexity)]
    fn blend_jacobian(&self, state: &DerState, jac: bool) -> Result<(Vec<Mat3>, Vec<Vec<Mat3>>)> {
        self.check_state(state)?;
        let q = self.n_examples();
        let w = &state.weights;
        let rg = state.rotation;
        let mut ts = Vec::with_capacity(self.r);
        let mut js = Vec::new();
        for k in 0..self.r {
            let mut phi = Vec3::zeros();
            let mut s = Mat3::zeros();
            for l in 0..q {
                phi += self.logs[l][k] * w[l];
                s += self.stretch[l][k] * w[l];
            }
            let e = rotation_exp_axis_angle(&phi);
            let t = rg * e * s;
            ts.push(t);
            if jac {
                let jr = right_jacobian(&phi);
                let mut d = Vec::with_capacity(q + 3);
                for l in 0..q {
                    let dphi = (jr * self.logs[l][k]).cross_matrix();
                    d.push(rg * e * (dphi * s + self.stretch[l][k]));
                }
                for a in 0..3 {
                    let mut u = Vec3::zeros();
                    u[a] = 1.0;
                    d.push(u.cross_matrix() * t);
                }
                js.push(d);
            }
        }
        Ok((ts, js))
    }

    /// Precomputes the reduced energy for constraint rows `rows` with
    /// targets `y` (h × 3) and weight `beta`.
    pub fn problem(
        &self,
        rows: &ConstraintRows,
        y: &DMatrix<f64>,
        beta: f64,
    ) -> Result<DerProblem> {
        let n = self.reference.n_vertices();
        if y.nrows() != rows.len() || y.ncols() != 3 {
            return Err(Error::invalid(format!(
                "constraint targets must be {} × 3, got {} × {}",
                rows.len(),
                y.nrows(),
                y.ncols()
            )));
        }
        if !(beta.is_finite() && beta > 0.0) {
            return Err(Error::invalid(format!("beta must be positive, got {beta}")));
        }
        if y.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("constraint targets are not finite"));
        }
        for (ri, row) in rows.iter().enumerate() {
            for &(i, w) in row {
                if i >= n || !w.is_finite() {
                    return Err(Error::invalid(format!(
                        "constraint row {ri}: entry ({i}, {w}) invalid for {n} vertices"
                    )));
                }
            }
        }
        // Base: Laplacian + single-vertex rows + pin; dense rows by Woodbury.
        let mut trip = self.lap.clone();
        let mut g = DMatrix::zeros(n, 3);
        let mut dense: Vec<usize> = Vec::new();
        for (ri, row) in rows.iter().enumerate() {
            if let [(i, w)] = row.as_slice() {
                trip.push((*i, *i, beta * w * w));
                for c in 0..3 {
                    g[(*i, c)] += beta * w * y[(ri, c)];
                }
            } else {
                dense.push(ri);
                for &(i, w) in row {
                    for c in 0..3 {
                        g[(i, c)] += beta * w * y[(ri, c)];
                    }
                }
            }
        }
        let pin = self.lap_diag_mean;
        trip.push((0, 0, pin));
        let base = sparse_from_triplets(n, n, trip);
        let chol = self.symbolic.factorize(&base)?;
        let hv = dense.len() + 1;
        let sb = beta.sqrt();
        let mut v = DMatrix::zeros(n, hv);
        for (col, &ri) in dense.iter().enumerate() {
            for &(i, w) in &rows[ri] {
                v[(i, col)] += sb * w;
            }
        }
        v[(0, hv - 1)] = pin.sqrt();
        let r3 = 3 * self.r;
        let mut rhs = DMatrix::zeros(n, r3 + 3 + hv);
        rhs.columns_mut(0, r3).copy_from(&self.k0t);
        rhs.columns_mut(r3, 3).copy_from(&g);
        rhs.columns_mut(r3 + 3, hv).copy_from(&v);
        let z_all = chol.try_solve(&rhs)?;
        let wv = z_all.columns(r3 + 3, hv).into_owned();
        let mut cap = v.transpose() * &wv;
        for a in 0..hv {
            cap[(a, a)] += if a + 1 == hv { -1.0 } else { 1.0 };
        }
        let lu = cap.lu();
        let zb = z_all.columns(0, r3 + 3).into_owned();
        let corr = lu.solve(&(v.transpose() * &zb)).ok_or_else(|| {
            Error::numerical(
                "the constraints do not determine the shape (Poisson system singular: \
                     they must fix the translation)",
            )
        })?;
        let sol = zb - &wv * corr;
        let p = sol.columns(0, r3).into_owned();
        let z = sol.columns(r3, 3).into_owned();
        let mut m = -(self.k0t.transpose() * &p);
        for k in 0..self.r {
            for a in 0..3 {
                for b in 0..3 {
                    m[(3 * k + a, 3 * k + b)] += self.c[k][(a, b)];
                }
            }
        }
        let m = 0.5 * (&m + m.transpose());
        let nn = self.k0t.transpose() * &z;
        let yy: f64 = rows
            .iter()
            .enumerate()
            .map(|(ri, _)| (0..3).map(|c| y[(ri, c)].powi(2)).sum::<f64>())
            .sum();
        let c0 = 0.5 * (beta * yy - g.dot(&z));
        Ok(DerProblem {
            p,
            z,
            m,
            n: nn,
            c0,
            rows: rows.clone(),
            y: y.clone(),
            beta,
        })
    }

    /// `F` (3r × 3) stacking `T_kᵀ`.
    fn stack(&self, ts: &[Mat3]) -> DMatrix<f64> {
        let mut f = DMatrix::zeros(3 * self.r, 3);
        for (k, t) in ts.iter().enumerate() {
            for a in 0..3 {
                for b in 0..3 {
                    f[(3 * k + a, b)] = t[(b, a)];
                }
            }
        }
        f
    }

    /// Positions `x = P F + z` for cluster gradients `ts`.
    pub fn positions(&self, prob: &DerProblem, ts: &[Mat3]) -> Vec<Point> {
        let x = &prob.p * self.stack(ts) + &prob.z;
        (0..x.nrows())
            .map(|i| Point::new(x[(i, 0)], x[(i, 1)], x[(i, 2)]))
            .collect()
    }

    /// The reduced energy `E(F)` at a state.
    pub fn energy(&self, prob: &DerProblem, state: &DerState) -> Result<f64> {
        let f = self.stack(&self.blend(state)?);
        Ok(prob.energy_f(&f))
    }

    /// The energy evaluated in the full space from positions `x` and cluster
    /// gradients `ts` (spoke by spoke; an independent check of the reduced
    /// form, equal to it at `x = P F + z`).
    pub fn energy_full(&self, prob: &DerProblem, x: &[Point], ts: &[Mat3]) -> Result<f64> {
        let n = self.reference.n_vertices();
        if x.len() != n || ts.len() != self.r {
            return Err(Error::invalid("energy_full: wrong sizes"));
        }
        let v0 = self.reference.vertices();
        let mut e = 0.0;
        for &(i, j, w) in &self.spokes {
            let d = (x[i] - x[j]) - ts[self.clusters[i]] * (v0[i] - v0[j]);
            e += w * d.norm_squared();
        }
        let mut lc = 0.0;
        for (ri, row) in prob.rows.iter().enumerate() {
            let mut hp = Vec3::zeros();
            for &(i, w) in row {
                hp += x[i].coords * w;
            }
            for c in 0..3 {
                lc += (hp[c] - prob.y[(ri, c)]).powi(2);
            }
        }
        Ok(0.5 * e + 0.5 * prob.beta * lc)
    }

    /// Gauss–Newton from `start` (see the module docs).
    pub fn solve(
        &self,
        prob: &DerProblem,
        start: &DerState,
        opts: &DerOptions,
    ) -> Result<DerSolution> {
        let q = self.n_examples();
        let np = if opts.global_rotation { q + 3 } else { q };
        let mut state = start.clone();
        let mut e = self.energy(prob, &state)?;
        let mut trace = vec![e];
        let mut lambda = 1e-4;
        let mut iterations = 0;
        for _ in 0..opts.max_iter {
            iterations += 1;
            let (ts, js) = self.blend_jacobian(&state, true)?;
            let f = self.stack(&ts);
            let grad_f = &prob.m * &f - &prob.n;
            // J_p stacked as 3r × 3 each.
            let jp: Vec<DMatrix<f64>> = (0..np)
                .map(|p| {
                    let d: Vec<Mat3> = js.iter().map(|jk| jk[p]).collect();
                    self.stack(&d)
                })
                .collect();
            let mj: Vec<DMatrix<f64>> = jp.iter().map(|j| &prob.m * j).collect();
            let mut h = DMatrix::zeros(np, np);
            let mut g = DVector::zeros(np);
            for a in 0..np {
                g[a] = jp[a].dot(&grad_f);
                for b in a..np {
                    let v = jp[a].dot(&mj[b]);
                    h[(a, b)] = v;
                    h[(b, a)] = v;
                }
            }
            let hmax = h.diagonal().max().max(1e-300);
            let mut accepted = false;
            for _ in 0..30 {
                let mut hd = h.clone();
                for a in 0..np {
                    hd[(a, a)] += lambda * h[(a, a)].max(1e-12 * hmax) + 1e-14 * hmax;
                }
                let Some(delta) = hd.cholesky().map(|c| c.solve(&(-&g))) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut cand = state.clone();
                for l in 0..q {
                    cand.weights[l] += delta[l];
                }
                if opts.global_rotation {
                    let om = Vec3::new(delta[q], delta[q + 1], delta[q + 2]);
                    cand.rotation = rotation_exp_axis_angle(&om) * state.rotation;
                }
                let ec = self.energy(prob, &cand)?;
                if ec.is_finite() && ec < e {
                    state = cand;
                    let dec = e - ec;
                    e = ec;
                    trace.push(e);
                    lambda = (lambda / 3.0).max(1e-12);
                    accepted = dec > opts.rel_tol * e.abs();
                    break;
                }
                lambda *= 4.0;
            }
            if !accepted {
                break;
            }
        }
        let ts = self.blend(&state)?;
        Ok(DerSolution {
            positions: self.positions(prob, &ts),
            state,
            energy: e,
            iterations,
            trace,
        })
    }

    /// Start of example `l`: `w = e_l`, `R_g` the weighted Kabsch rotation of
    /// the example's constrained points `H V_l` onto `Y`.
    pub fn start(&self, prob: &DerProblem, l: usize) -> Result<DerState> {
        let ex = self
            .examples
            .get(l)
            .ok_or_else(|| Error::invalid(format!("example {l} out of range")))?;
        let mut src = Vec::new();
        let mut dst = Vec::new();
        let mut wt = Vec::new();
        for (ri, row) in prob.rows.iter().enumerate() {
            let s: f64 = row.iter().map(|e| e.1).sum();
            if s.abs() < 1e-12 {
                continue;
            }
            let mut hp = Vec3::zeros();
            for &(i, w) in row {
                hp += ex[i].coords * w;
            }
            src.push(hp / s);
            dst.push(Vec3::new(prob.y[(ri, 0)], prob.y[(ri, 1)], prob.y[(ri, 2)]) / s);
            wt.push(s * s);
        }
        let mut st = DerState::example(self.n_examples(), l);
        st.rotation = kabsch(&src, &dst, &wt);
        Ok(st)
    }

    /// Registration to the constraints alone: Gauss–Newton from every
    /// example's start, the lowest energy kept (lowest index on ties).
    pub fn register(&self, prob: &DerProblem, opts: &DerOptions) -> Result<DerSolution> {
        let mut best: Option<DerSolution> = None;
        for l in 0..self.n_examples() {
            let mut st = self.start(prob, l)?;
            if !opts.global_rotation {
                st.rotation = Mat3::identity();
            }
            let s = self.solve(prob, &st, opts)?;
            if best.as_ref().is_none_or(|b| s.energy < b.energy) {
                best = Some(s);
            }
        }
        best.ok_or_else(|| Error::invalid("no example"))
    }

    /// FBT's nonrigid ICP loop with this model: per iteration the
    /// correspondences of [`Matcher`] (same options as FBT), `H` = feature
    /// rows (weight `feature_weight`) + one row per accepted pair (total
    /// weight `correspondence_weight`), then Gauss–Newton warm-started
    /// (`max_iter` of `opts` per iteration).
    pub fn nicp(
        &self,
        features: (&ConstraintRows, &DMatrix<f64>),
        target: &Mesh,
        start: &DerState,
        icp: &NicpOptions,
        opts: &DerOptions,
    ) -> Result<DerNicpResult> {
        let (frows, fy) = features;
        if fy.nrows() != frows.len() || fy.ncols() != 3 {
            return Err(Error::invalid(format!(
                "feature targets must be {} × 3",
                frows.len()
            )));
        }
        if !(icp.feature_weight >= 0.0 && icp.correspondence_weight > 0.0) {
            return Err(Error::invalid(
                "NICP needs feature_weight ≥ 0 and correspondence_weight > 0",
            ));
        }
        let matcher = Matcher::new(&self.reference, self.area, target, icp)?;
        let fw = icp.feature_weight.sqrt();
        let mut state = start.clone();
        let mut accepted = Vec::new();
        let mut mean_distance = Vec::new();
        // Positions of the start under the feature constraints.
        let prob0 = self.problem(&scale_rows(frows, fw), &(fy * fw), opts.beta)?;
        let mut positions = self.positions(&prob0, &self.blend(&state)?);
        for _ in 0..icp.iterations {
            let m = matcher.matches(&positions)?;
            let mut rows = scale_rows(frows, fw);
            let mut ys: Vec<[f64; 3]> = (0..frows.len())
                .map(|r| [fy[(r, 0)] * fw, fy[(r, 1)] * fw, fy[(r, 2)] * fw])
                .collect();
            let cw = (icp.correspondence_weight / m.pairs.len().max(1) as f64).sqrt();
            for &(i, j) in &m.pairs {
                rows.push(vec![(i, cw)]);
                let t = matcher.target()[j];
                ys.push([t.x * cw, t.y * cw, t.z * cw]);
            }
            accepted.push(m.pairs.len());
            mean_distance.push(m.mean_distance);
            let y = DMatrix::from_fn(ys.len(), 3, |r, c| ys[r][c]);
            let prob = self.problem(&rows, &y, opts.beta)?;
            let sol = self.solve(&prob, &state, opts)?;
            state = sol.state;
            positions = sol.positions;
        }
        Ok(DerNicpResult {
            state,
            positions,
            accepted,
            mean_distance,
        })
    }
}

fn scale_rows(rows: &ConstraintRows, s: f64) -> ConstraintRows {
    rows.iter()
        .map(|r| r.iter().map(|&(i, w)| (i, w * s)).collect())
        .collect()
}

/// The reduced energy of one constraint set (see the module docs).
#[derive(Clone, Debug)]
pub struct DerProblem {
    p: DMatrix<f64>,
    z: DMatrix<f64>,
    m: DMatrix<f64>,
    n: DMatrix<f64>,
    c0: f64,
    rows: ConstraintRows,
    y: DMatrix<f64>,
    beta: f64,
}

impl DerProblem {
    /// `½ tr(FᵀMF) − tr(FᵀN) + c₀`.
    pub fn energy_f(&self, f: &DMatrix<f64>) -> f64 {
        0.5 * f.dot(&(&self.m * f)) - f.dot(&self.n) + self.c0
    }

    /// The constraint rows.
    pub fn rows(&self) -> &ConstraintRows {
        &self.rows
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn right_jacobian_matches_finite_differences() {
        let phi = Vec3::new(0.4, -0.7, 0.3);
        let delta = Vec3::new(0.2, 0.1, -0.5);
        let h = 1e-6;
        let e0 = rotation_exp_axis_angle(&phi);
        let fd = (rotation_exp_axis_angle(&(phi + delta * h))
            - rotation_exp_axis_angle(&(phi - delta * h)))
            / (2.0 * h);
        let an = e0 * (right_jacobian(&phi) * delta).cross_matrix();
        assert!((fd - an).abs().max() < 1e-8, "{fd} vs {an}");
        // Small angle branch.
        let phi = Vec3::new(1e-6, 0.0, 2e-6);
        let e0 = rotation_exp_axis_angle(&phi);
        let fd = (rotation_exp_axis_angle(&(phi + delta * h))
            - rotation_exp_axis_angle(&(phi - delta * h)))
            / (2.0 * h);
        let an = e0 * (right_jacobian(&phi) * delta).cross_matrix();
        assert!((fd - an).abs().max() < 1e-7);
    }

    #[test]
    fn kabsch_recovers_a_rotation() {
        let r = rotation_exp_axis_angle(&Vec3::new(0.3, 1.1, -0.4));
        let src: Vec<Vec3> = (0..6)
            .map(|i| Vec3::new(i as f64, (i * i) as f64 * 0.3, (i % 3) as f64))
            .collect();
        let dst: Vec<Vec3> = src
            .iter()
            .map(|p| r * p + Vec3::new(1.0, 2.0, 3.0))
            .collect();
        let k = kabsch(&src, &dst, &[1.0; 6]);
        assert!((k - r).abs().max() < 1e-10);
    }
}

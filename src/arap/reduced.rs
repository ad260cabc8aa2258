//! The precomputed reduced ARAP solver (see the module documentation of
//! [`crate::arap`] for the energy and the conventions).

use std::sync::Arc;

use nalgebra::{Cholesky, DMatrix, Dyn};

use crate::mesh::Mesh;
use crate::ops::polar_decomposition;
use crate::ops::Operators;
use crate::skin::lbs::lbs_operator_transposed;
use crate::skin::lbs::{points_from_matrix, points_to_matrix};
use crate::skin::{transforms_from_stacked, Affine};
use crate::solve::dense::{mul_tr, tr_mul};
use crate::{Error, Mat3, Point, Result};

/// Below this fraction of the problem's energy scale the energy counts as
/// zero for the stopping test (rounding level of the reduced bookkeeping).
const ZERO_ENERGY_REL: f64 = 1e-14;

/// Options of [`ReducedArap`].
#[derive(Clone, Debug, PartialEq)]
pub struct ArapOptions {
    /// Weight λ of the ARAP term (BDT Eq. 5; the paper uses 0.5).
    pub lambda: f64,
    /// `true`: data term E_diff (BDT Eq. 4). `false`: the FAST ablation, soft
    /// handle position constraints instead.
    pub use_ediff: bool,
    /// Maximum number of local/global iterations per solve (at least one is
    /// always done).
    pub max_iter: usize,
    /// Stop when the energy decreases by at most `rel_tol` times its value.
    pub rel_tol: f64,
    /// Weight μ of the handle constraints `μ Σ_h ‖q_h − x_h‖²` (only when
    /// `use_ediff` is false).
    pub handle_weight: f64,
    /// Handle vertex of each weight column (only when `use_ediff` is false).
    /// Empty: the vertex with the largest weight in each column (lowest index
    /// on ties), which is the handle itself for interpolating weights such as
    /// bounded biharmonic weights.
    pub handles: Vec<usize>,
}

impl Default for ArapOptions {
    fn default() -> Self {
        ArapOptions {
            lambda: 0.5,
            use_ediff: true,
            max_iter: 100,
            rel_tol: 1e-8,
            handle_weight: 1e5,
            handles: Vec::new(),
        }
    }
}

/// Result of [`ReducedArap::solve`].
#[derive(Clone, Debug)]
pub struct ArapSolution {
    /// Per-handle affine transforms `T_k`.
    pub transforms: Vec<Affine>,
    /// The same, stacked (4n_h × 3, see [`crate::skin::transforms_to_stacked`]).
    pub stacked: DMatrix<f64>,
    /// Deformed positions `Q = K T`.
    pub positions: Vec<Point>,
    /// Group rotations `R_g` fitted to the final `T`.
    pub rotations: Vec<Mat3>,
    /// `E(T) = min_R E(T, R)` after each iteration (preceded by the energy
    /// of `init` when one was given). Non-increasing up to rounding.
    pub energy_trace: Vec<f64>,
    /// Local/global iterations performed.
    pub iterations: usize,
}

/// The mesh-only part of the reduced ARAP precomputation: rest positions,
/// clamped cotangent edge weights `w̃` and the 1-ring lists of `L̃`. Build
/// it once per mesh and share it ([`ReducedArap::with_mesh`]) when many
/// (weights, groups) are tried on one mesh, as key point selection does.
#[derive(Clone, Debug)]
pub struct ArapMesh {
    rest: Vec<Point>,
    /// Undirected edges `(i, j, w̃)` with `w̃ > 0`.
    edges: Vec<(usize, usize, f64)>,
    /// CSR 1-rings of `L̃`: neighbours of `i` are
    /// `ring[ring_start[i]..ring_start[i + 1]]` with weights `ring_w`.
    ring_start: Vec<usize>,
    ring: Vec<usize>,
    ring_w: Vec<f64>,
    /// `w̃_ij (p_i − p_j)` of each ring entry `j` of `i`.
    ring_we: Vec<[f64; 3]>,
    /// `L̃_ii = Σ_j w̃_ij`.
    diag: Vec<f64>,
    /// `tr(Pᵀ L̃ P)`: the constant of E_arap.
    rest_term: f64,
}

impl ArapMesh {
    /// Clamped cotangent weights and 1-rings of `mesh`. O(n).
    pub fn new(mesh: &Mesh) -> Self {
        let n = mesh.n_vertices();
        let rest = mesh.vertices().to_vec();
        let edges: Vec<(usize, usize, f64)> = mesh
            .edge_weights()
            .iter()
            .filter(|&&(_, w)| w > 0.0)
            .map(|&((i, j), w)| (i, j, w))
            .collect();
        let mut count = vec![0usize; n + 1];
        let mut diag = vec![0.0; n];
        let mut rest_term = 0.0;
        for &(i, j, w) in &edges {
            count[i + 1] += 1;
            count[j + 1] += 1;
            diag[i] += w;
            diag[j] += w;
            rest_term += w * (rest[i] - rest[j]).norm_squared();
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let ring_start = count.clone();
        let mut fill = count;
        let mut ring = vec![0; 2 * edges.len()];
        let mut ring_w = vec![0.0; 2 * edges.len()];
        let mut ring_we = vec![[0.0; 3]; 2 * edges.len()];
        for &(i, j, w) in &edges {
            for (a, b) in [(i, j), (j, i)] {
                let e = (rest[a] - rest[b]) * w;
                ring[fill[a]] = b;
                ring_w[fill[a]] = w;
                ring_we[fill[a]] = [e.x, e.y, e.z];
                fill[a] += 1;
            }
        }
        ArapMesh {
            rest,
            edges,
            ring_start,
            ring,
            ring_w,
            ring_we,
            diag,
            rest_term,
        }
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.rest.len()
    }

    /// `(α L̃ X + β X)ᵀ` for `xt = Xᵀ` (columns = vertices, contiguous).
    fn apply_laplacian_t(&self, xt: &DMatrix<f64>, alpha: f64, beta: f64) -> DMatrix<f64> {
        let (c, n) = xt.shape();
        let mut yt = DMatrix::zeros(c, n);
        if c == 0 {
            return yt;
        }
        let x = xt.as_slice();
        for (i, yi) in yt.as_mut_slice().chunks_exact_mut(c).enumerate() {
            let s = beta + alpha * self.diag[i];
            for (y, v) in yi.iter_mut().zip(&x[i * c..(i + 1) * c]) {
                *y = s * v;
            }
            for r in self.ring_start[i]..self.ring_start[i + 1] {
                let f = alpha * self.ring_w[r];
                let j = self.ring[r];
                for (y, v) in yi.iter_mut().zip(&x[j * c..(j + 1) * c]) {
                    *y -= f * v;
                }
            }
        }
        yt
    }

    /// `(C K)ᵀ` (cols × 3|G|) for `kt = Kᵀ`: column `3g + a` sums
    /// `w̃ (p_i − p_j)_a (K_i − K_j)` over the spokes `i → j` of the
    /// vertices `i` of group `g`. Gathered per vertex `v`: `K_v` enters
    /// group `g` with coefficient `[g = g(v)] Σ_j w̃_vj (p_v − p_j) +
    /// Σ_{i ∈ N(v), g(i) = g} w̃_vi (p_v − p_i)` (its own spokes, and the
    /// spokes of its neighbours that end at `v`), so the cost is one axpy of
    /// `K_v` per (vertex, group touching its 1-ring, axis): about 3n.
    fn covariance_operator_t(
        &self,
        groups: &[usize],
        n_groups: usize,
        kt: &DMatrix<f64>,
    ) -> DMatrix<f64> {
        let c = kt.nrows();
        let mut ckt = DMatrix::zeros(c, 3 * n_groups);
        if c == 0 || n_groups == 0 {
            return ckt;
        }
        let x = kt.as_slice();
        let out = ckt.as_mut_slice();
        let mut coef: Vec<(usize, [f64; 3])> = Vec::new();
        for (v, kv) in x.chunks_exact(c).enumerate() {
            coef.clear();
            let ring = self.ring_start[v]..self.ring_start[v + 1];
            let mut own = [0.0; 3];
            for we in &self.ring_we[ring.clone()] {
                for a in 0..3 {
                    own[a] += we[a];
                }
            }
            coef.push((groups[v], own));
            for r in ring {
                let g = groups[self.ring[r]];
                let we = self.ring_we[r];
                match coef.iter_mut().find(|(h, _)| *h == g) {
                    Some((_, cf)) => {
                        for a in 0..3 {
                            cf[a] += we[a];
                        }
                    }
                    None => coef.push((g, we)),
                }
            }
            for &(g, cf) in &coef {
                for (a, &f) in cf.iter().enumerate() {
                    let col = 3 * g + a;
                    for (o, k) in out[col * c..(col + 1) * c].iter_mut().zip(kv) {
                        *o += f * k;
                    }
                }
            }
        }
        ckt
    }

    /// Group covariances `S = C Q` (3|G| × 3) of positions `q`.
    fn covariances(&self, groups: &[usize], n_groups: usize, q: &[Point]) -> DMatrix<f64> {
        let p = &self.rest;
        let mut s = DMatrix::zeros(3 * n_groups, 3);
        for &(i, j, w) in &self.edges {
            let m = w * (p[i] - p[j]) * (q[i] - q[j]).transpose();
            for g in [groups[i], groups[j]] {
                for a in 0..3 {
                    for b in 0..3 {
                        s[(3 * g + a, b)] += m[(a, b)];
                    }
                }
            }
        }
        s
    }
}

/// Reduced ARAP with E_diff (or handle constraints), precomputed for one
/// (mesh, weights, groups) and solved for many targets.
#[derive(Clone, Debug)]
pub struct ReducedArap {
    opts: ArapOptions,
    mesh: Arc<ArapMesh>,
    groups: Vec<usize>,
    n_groups: usize,
    /// `Kᵀ` (4n_h × n) of the LBS operator `K` ([`crate::skin::LbsMatrix`]).
    kt: DMatrix<f64>,
    /// `C K` (3|G| × 4n_h): `S = (CK) T`.
    ck: DMatrix<f64>,
    /// `λ Kᵀ L̃ K` (handle constraints) or empty (E_diff: see `a`).
    arap_quad: DMatrix<f64>,
    /// `A = λ Kᵀ L̃ K + Kᵀ K` (or `+ μ K_hᵀ K_h`).
    a: DMatrix<f64>,
    /// Rows of `K` at the handles (handle constraints) or empty (E_diff).
    kh: DMatrix<f64>,
    /// Cholesky factor of `A`.
    chol: Cholesky<f64, Dyn>,
    /// `A⁻¹ (CK)ᵀ` (4n_h × 3|G|).
    h: DMatrix<f64>,
    /// Handle vertices (FAST mode only).
    handles: Vec<usize>,
}

impl ReducedArap {
    /// Precomputes everything that depends on (mesh, weights, groups):
    /// clamped cotangent weights, `K`, `CK`, the system matrix `A` and its
    /// Cholesky factor, `A⁻¹ (CK)ᵀ`.
    ///
    /// `weights` is n × n_h (rows = vertices); `groups` gives a group label
    /// per vertex (the number of groups is the largest label + 1; empty
    /// groups are allowed). Errors on mismatched sizes, non-finite weights,
    /// bad options, bad handle indices, or a system matrix that is not
    /// positive definite (e.g. a planar mesh, whose `K` has a zero column
    /// for the z coordinate of every handle).
    pub fn new(
        mesh: &Mesh,
        weights: &DMatrix<f64>,
        groups: &[usize],
        opts: ArapOptions,
    ) -> Result<Self> {
        Self::with_mesh(&Arc::new(ArapMesh::new(mesh)), weights, groups, opts)
    }

    /// [`ReducedArap::new`] with the mesh-only part precomputed. Cost:
    /// O(n · n_h²) (two dense products of n × 4n_h matrices) plus
    /// O(edges · n_h) for `CK`.
    pub fn with_mesh(
        mesh: &Arc<ArapMesh>,
        weights: &DMatrix<f64>,
        groups: &[usize],
        opts: ArapOptions,
    ) -> Result<Self> {
        let n = mesh.n_vertices();
        check_options(&opts)?;
        if weights.nrows() != n {
            return Err(Error::invalid(format!(
                "skinning weights have {} rows for {n} vertices",
                weights.nrows()
            )));
        }
        if weights.ncols() == 0 {
            return Err(Error::invalid("skinning weights have no columns"));
        }
        if weights.iter().any(|x| !x.is_finite()) {
            return Err(Error::invalid("skinning weights have a non-finite entry"));
        }
        if groups.len() != n {
            return Err(Error::invalid(format!(
                "{} group labels for {n} vertices",
                groups.len()
            )));
        }
        let max_label = groups.iter().copied().max().unwrap_or(0);
        if max_label >= n {
            return Err(Error::invalid(format!(
                "group label {max_label} is out of range for {n} vertices"
            )));
        }
        let n_groups = if n == 0 { 0 } else { max_label + 1 };
        let nh = weights.ncols();
        let rest = &mesh.rest;
        let kt = lbs_operator_transposed(rest, weights)?;
        let ckt = mesh.covariance_operator_t(groups, n_groups, &kt);
        let sym = |m: DMatrix<f64>| (&m + m.transpose()) * 0.5;
        let (handles, kh, arap_quad, a) = if opts.use_ediff {
            // A = Kᵀ (λ L̃ K + K) in one product.
            let mt = mesh.apply_laplacian_t(&kt, opts.lambda, 1.0);
            let a = sym(mul_tr(&kt, &mt));
            (Vec::new(), DMatrix::zeros(0, 0), DMatrix::zeros(0, 0), a)
        } else {
            let handles = resolve_handles(weights, &opts.handles)?;
            let kh = kt.select_columns(&handles).transpose();
            let mt = mesh.apply_laplacian_t(&kt, opts.lambda, 0.0);
            let arap_quad = sym(mul_tr(&kt, &mt));
            let a = &arap_quad + kh.tr_mul(&kh) * opts.handle_weight;
            (handles, kh, arap_quad, a)
        };
        let chol = Cholesky::new(a.clone()).ok_or_else(|| {
            Error::numerical(format!(
                "the reduced ARAP system ({0} × {0}) is not positive definite: the skinning \
                 subspace has dependent columns (e.g. a planar mesh or duplicate weight \
                 columns){1}",
                4 * nh,
                if opts.use_ediff {
                    ""
                } else {
                    ", or the handle constraints do not pin every handle's transform"
                }
            ))
        })?;
        let h = chol.solve(&ckt);
        let ck = ckt.transpose();
        Ok(ReducedArap {
            opts,
            mesh: Arc::clone(mesh),
            groups: groups.to_vec(),
            n_groups,
            kt,
            ck,
            arap_quad,
            a,
            kh,
            chol,
            h,
            handles,
        })
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.mesh.rest.len()
    }

    /// Number of handles n_h.
    pub fn n_handles(&self) -> usize {
        self.kt.nrows() / 4
    }

    /// Number of rotation groups |G|.
    pub fn n_groups(&self) -> usize {
        self.n_groups
    }

    /// The options.
    pub fn options(&self) -> &ArapOptions {
        &self.opts
    }

    /// Handle vertices used by the constraints (empty with E_diff).
    pub fn handles(&self) -> &[usize] {
        &self.handles
    }

    /// `Kᵀ` (4n_h × n), the transposed LBS operator of the weights.
    pub fn lbs_transposed(&self) -> &DMatrix<f64> {
        &self.kt
    }

    /// The data term for a target (E_diff: O(n · n_h); handles: O(n_h²)).
    fn data_term(&self, target: &[Point]) -> Result<DataTerm> {
        check_points(target, self.mesh.rest.len(), "target")?;
        let lambda_rest = self.opts.lambda * self.mesh.rest_term;
        if self.opts.use_ediff {
            let qp = points_to_matrix(target);
            let d0 = qp.norm_squared();
            Ok(DataTerm {
                rhs: &self.kt * &qp,
                d0,
                xh: DMatrix::zeros(0, 0),
                scale: d0 + lambda_rest,
            })
        } else {
            let xh = DMatrix::from_fn(self.handles.len(), 3, |r, d| target[self.handles[r]][d]);
            Ok(DataTerm {
                rhs: self.kh.tr_mul(&xh) * self.opts.handle_weight,
                d0: 0.0,
                scale: xh.norm_squared() + lambda_rest,
                xh,
            })
        }
    }

    /// Optimal rotations for covariances `S` (3|G| × 3).
    fn fit_rotations(&self, s: &DMatrix<f64>) -> Result<Vec<Mat3>> {
        (0..self.n_groups)
            .map(|g| {
                let sg = Mat3::from_fn(|a, b| s[(3 * g + a, b)]);
                best_rotation(&sg)
            })
            .collect()
    }

    /// Stacks `R_gᵀ` into 3|G| × 3.
    fn stack_rotations(&self, rots: &[Mat3]) -> DMatrix<f64> {
        DMatrix::from_fn(3 * self.n_groups, 3, |r, c| rots[r / 3][(c, r % 3)])
    }

    /// Reduced energy `E(T, R)` from 4n_h-sized quantities. The handle
    /// term is evaluated as a residual (`μ ‖K_h T − X_h‖²`, no
    /// cancellation); E_diff as `tr(Tᵀ KᵀK T) − 2⟨KᵀQ′, T⟩ + ‖Q′‖²`, exact up
    /// to rounding relative to `‖Q′‖²`.
    fn reduced_energy(
        &self,
        t: &DMatrix<f64>,
        s: &DMatrix<f64>,
        rots: &[Mat3],
        data: &DataTerm,
    ) -> f64 {
        let tr_rs: f64 = rots
            .iter()
            .enumerate()
            .map(|(g, r)| {
                let sg = Mat3::from_fn(|a, b| s[(3 * g + a, b)]);
                (r * sg).trace()
            })
            .sum();
        let rot_term = self.opts.lambda * (self.mesh.rest_term - tr_rs);
        if self.opts.use_ediff {
            // tᵀ (λ KᵀL̃K + KᵀK) t − 2⟨KᵀQ′, T⟩ + ‖Q′‖² + λ (tr(PᵀL̃P) − tr(R S)).
            (&self.a * t).dot(t) - 2.0 * data.rhs.dot(t) + data.d0 + rot_term
        } else {
            (&self.arap_quad * t).dot(t)
                + rot_term
                + self.opts.handle_weight * (&self.kh * t - &data.xh).norm_squared()
        }
    }

    /// Local/global iterations for one target (A′ positions, one per
    /// vertex), from `init` stacked transforms (4n_h × 3) if given, else from
    /// the group rotations fitted to the target itself (E_diff) or identity
    /// rotations (handle constraints). Errors on mismatched sizes or
    /// non-finite input.
    pub fn solve(&self, target: &[Point], init: Option<&DMatrix<f64>>) -> Result<ArapSolution> {
        let data = self.data_term(target)?;
        let t0 = self.chol.solve(&data.rhs);
        let half_lambda = 0.5 * self.opts.lambda;
        let scale = data.scale;
        let mut trace = Vec::with_capacity(self.opts.max_iter + 1);

        let mut rots = match init {
            Some(t) => {
                self.check_stacked(t)?;
                let s = &self.ck * t;
                let rots = self.fit_rotations(&s)?;
                trace.push(self.reduced_energy(t, &s, &rots, &data));
                rots
            }
            None if self.opts.use_ediff => {
                let s = self.mesh.covariances(&self.groups, self.n_groups, target);
                self.fit_rotations(&s)?
            }
            None => vec![Mat3::identity(); self.n_groups],
        };

        let mut t = t0.clone();
        let mut iterations = 0;
        for _ in 0..self.opts.max_iter.max(1) {
            iterations += 1;
            // Global step: T = A⁻¹ (b₀ + (λ/2) (CK)ᵀ R̂).
            t = &t0 + &self.h * self.stack_rotations(&rots) * half_lambda;
            // Local step.
            let s = &self.ck * &t;
            rots = self.fit_rotations(&s)?;
            let e = self.reduced_energy(&t, &s, &rots, &data);
            if !e.is_finite() {
                return Err(Error::numerical(format!(
                    "reduced ARAP energy became {e} at iteration {iterations}"
                )));
            }
            let prev = trace.last().copied();
            trace.push(e);
            if let Some(prev) = prev {
                let floor = ZERO_ENERGY_REL * scale;
                if prev - e <= self.opts.rel_tol * prev.abs().max(floor) {
                    break;
                }
            }
            if e.abs() <= ZERO_ENERGY_REL * scale {
                break;
            }
        }
        let positions = points_from_matrix(&tr_mul(&self.kt, &t));
        Ok(ArapSolution {
            transforms: transforms_from_stacked(&t)?,
            stacked: t,
            positions,
            rotations: rots,
            energy_trace: trace,
            iterations,
        })
    }

    fn check_stacked(&self, t: &DMatrix<f64>) -> Result<()> {
        let rows = 4 * self.n_handles();
        if t.nrows() != rows || t.ncols() != 3 {
            return Err(Error::invalid(format!(
                "stacked transforms must be {rows} × 3, got {} × {}",
                t.nrows(),
                t.ncols()
            )));
        }
        if t.iter().any(|x| !x.is_finite()) {
            return Err(Error::invalid("stacked transforms have a non-finite entry"));
        }
        Ok(())
    }

    /// `E(T) = min_R E(T, R)` evaluated directly on the full mesh: positions
    /// `Q = K T`, per-group covariances and rotations from the edges, the sum
    /// of the spoke terms and the data term. Independent of the reduced
    /// matrices (for tests and diagnostics); O(n · n_h).
    pub fn energy(&self, t_stacked: &DMatrix<f64>, target: &[Point]) -> Result<f64> {
        self.check_stacked(t_stacked)?;
        check_points(target, self.mesh.rest.len(), "target")?;
        let q = points_from_matrix(&tr_mul(&self.kt, t_stacked));
        let p = &self.mesh.rest;
        let mut s = vec![Mat3::zeros(); self.n_groups];
        for &(i, j, w) in &self.mesh.edges {
            let m = w * (p[i] - p[j]) * (q[i] - q[j]).transpose();
            s[self.groups[i]] += m;
            s[self.groups[j]] += m;
        }
        let rots: Vec<Mat3> = s.iter().map(best_rotation).collect::<Result<_>>()?;
        let mut arap = 0.0;
        for &(i, j, w) in &self.mesh.edges {
            let (ep, eq) = (p[i] - p[j], q[i] - q[j]);
            let ri = (eq - rots[self.groups[i]] * ep).norm_squared();
            let rj = (eq - rots[self.groups[j]] * ep).norm_squared();
            arap += 0.5 * w * (ri + rj);
        }
        let data = if self.opts.use_ediff {
            q.iter()
                .zip(target)
                .map(|(a, b)| (a - b).norm_squared())
                .sum::<f64>()
        } else {
            self.opts.handle_weight
                * self
                    .handles
                    .iter()
                    .map(|&h| (q[h] - target[h]).norm_squared())
                    .sum::<f64>()
        };
        Ok(self.opts.lambda * arap + data)
    }
}

/// Per-target data: right-hand side `b₀` (4n_h × 3), `‖Q′‖²` (E_diff), the
/// handle targets `X_h` (handle constraints) and the energy scale used by
/// the stopping test.
struct DataTerm {
    rhs: DMatrix<f64>,
    d0: f64,
    xh: DMatrix<f64>,
    scale: f64,
}

/// `argmax_{R ∈ SO(3)} tr(R S)`: the polar rotation of `Sᵀ` (Kabsch, with
/// the reflection moved to the smallest singular value).
fn best_rotation(s: &Mat3) -> Result<Mat3> {
    Ok(polar_decomposition(&s.transpose())?.rotation)
}

fn check_options(o: &ArapOptions) -> Result<()> {
    if !(o.lambda.is_finite() && o.lambda >= 0.0) {
        return Err(Error::invalid(format!(
            "ARAP weight lambda must be finite and ≥ 0, got {}",
            o.lambda
        )));
    }
    if !(o.rel_tol.is_finite() && o.rel_tol >= 0.0) {
        return Err(Error::invalid(format!(
            "rel_tol must be finite and ≥ 0, got {}",
            o.rel_tol
        )));
    }
    let weight_ok = o.handle_weight.is_finite() && o.handle_weight > 0.0;
    if !o.use_ediff && !weight_ok {
        return Err(Error::invalid(format!(
            "handle_weight must be finite and > 0, got {}",
            o.handle_weight
        )));
    }
    Ok(())
}

fn check_points(p: &[Point], n: usize, what: &str) -> Result<()> {
    if p.len() != n {
        return Err(Error::invalid(format!(
            "{what} has {} points for {n} vertices",
            p.len()
        )));
    }
    if let Some(i) = p
        .iter()
        .position(|x| !x.coords.iter().all(|c| c.is_finite()))
    {
        return Err(Error::invalid(format!(
            "{what} point {i} has a non-finite coordinate"
        )));
    }
    Ok(())
}

/// Handle vertices: the given ones (one per weight column, in range) or the
/// argmax of each column.
fn resolve_handles(weights: &DMatrix<f64>, given: &[usize]) -> Result<Vec<usize>> {
    let (n, nh) = weights.shape();
    if given.is_empty() {
        return Ok((0..nh)
            .map(|k| {
                let col = weights.column(k);
                let mut best = 0;
                for i in 1..n {
                    if col[i] > col[best] {
                        best = i;
                    }
                }
                best
            })
            .collect());
    }
    if given.len() != nh {
        return Err(Error::invalid(format!(
            "{} handle vertices for {nh} weight columns",
            given.len()
        )));
    }
    if let Some(&h) = given.iter().find(|&&h| h >= n) {
        return Err(Error::invalid(format!(
            "handle vertex {h} is out of range for {n} vertices"
        )));
    }
    Ok(given.to_vec())
}

//! The precomputed reduced ARAP solver (see the module documentation of
//! [`crate::arap`] for the energy and the conventions).

use nalgebra::{Cholesky, DMatrix, Dyn};

use crate::mesh::Mesh;
use crate::ops::{cotan_weights, polar_decomposition};
use crate::skin::lbs::{points_from_matrix, points_to_matrix};
use crate::skin::{transforms_from_stacked, Affine, LbsMatrix};
use crate::solve::{sparse_from_triplets, SparseMatrix};
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

/// Reduced ARAP with E_diff (or handle constraints), precomputed for one
/// (mesh, weights, groups) and solved for many targets.
#[derive(Clone, Debug)]
pub struct ReducedArap {
    opts: ArapOptions,
    rest: Vec<Point>,
    groups: Vec<usize>,
    n_groups: usize,
    /// Undirected edges with clamped cotangent weights `w̃ > 0`.
    edges: Vec<(usize, usize, f64)>,
    lbs: LbsMatrix,
    /// Sparse C (3|G| × n): `S = C Q`.
    cov: SparseMatrix,
    /// `C K` (3|G| × 4n_h).
    ck: DMatrix<f64>,
    /// `λ Kᵀ L̃ K` (4n_h × 4n_h).
    arap_quad: DMatrix<f64>,
    /// `Kᵀ K` (E_diff) or empty (handle constraints).
    ktk: DMatrix<f64>,
    /// Rows of `K` at the handles (handle constraints) or empty (E_diff).
    kh: DMatrix<f64>,
    /// Cholesky factor of `A = λ Kᵀ L̃ K + Kᵀ K` (or `+ μ K_hᵀ K_h`).
    chol: Cholesky<f64, Dyn>,
    /// `A⁻¹ (CK)ᵀ` (4n_h × 3|G|).
    h: DMatrix<f64>,
    /// `tr(Pᵀ L̃ P)`: the constant of E_arap.
    rest_term: f64,
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
        let rest = mesh.vertices().to_vec();
        let lbs = LbsMatrix::new(&rest, weights)?;
        let k = lbs.matrix();

        let edges: Vec<(usize, usize, f64)> = cotan_weights(mesh)
            .into_iter()
            .filter(|&(_, w)| w > 0.0)
            .map(|((i, j), w)| (i, j, w))
            .collect();

        // Clamped Laplacian, C and tr(Pᵀ L̃ P).
        let mut lap = Vec::with_capacity(4 * edges.len());
        let mut cov = Vec::with_capacity(12 * edges.len());
        let mut rest_term = 0.0;
        for &(i, j, w) in &edges {
            lap.extend_from_slice(&[(i, j, -w), (j, i, -w), (i, i, w), (j, j, w)]);
            let e = rest[i] - rest[j];
            rest_term += w * e.norm_squared();
            // Spoke i→j in group g(i) and spoke j→i in group g(j) both add
            // w e^p_ij (δ_i − δ_j)ᵀ to their group's rows of C.
            for g in [groups[i], groups[j]] {
                for a in 0..3 {
                    cov.push((3 * g + a, i, w * e[a]));
                    cov.push((3 * g + a, j, -w * e[a]));
                }
            }
        }
        let lap = sparse_from_triplets(n, n, lap);
        let cov = sparse_from_triplets(3 * n_groups, n, cov);
        let ck: DMatrix<f64> = &cov * k;

        let lk: DMatrix<f64> = &lap * k;
        let arap_quad = k.tr_mul(&lk) * opts.lambda;
        let arap_quad = (&arap_quad + arap_quad.transpose()) * 0.5;
        let (handles, ktk, kh, data_quad) = if opts.use_ediff {
            let ktk = k.tr_mul(k);
            (Vec::new(), ktk.clone(), DMatrix::zeros(0, 0), ktk)
        } else {
            let handles = resolve_handles(weights, &opts.handles)?;
            let kh = k.select_rows(&handles);
            let d = kh.tr_mul(&kh) * opts.handle_weight;
            (handles, DMatrix::zeros(0, 0), kh, d)
        };
        let a = &arap_quad + data_quad;
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
        let h = chol.solve(&ck.transpose());
        Ok(ReducedArap {
            opts,
            rest,
            groups: groups.to_vec(),
            n_groups,
            edges,
            lbs,
            cov,
            ck,
            arap_quad,
            ktk,
            kh,
            chol,
            h,
            rest_term,
            handles,
        })
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.rest.len()
    }

    /// Number of handles n_h.
    pub fn n_handles(&self) -> usize {
        self.lbs.n_handles()
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

    /// The LBS operator `K`.
    pub fn lbs(&self) -> &LbsMatrix {
        &self.lbs
    }

    /// The data term for a target (E_diff: O(n · n_h); handles: O(n_h²)).
    fn data_term(&self, target: &[Point]) -> Result<DataTerm> {
        check_points(target, self.rest.len(), "target")?;
        let lambda_rest = self.opts.lambda * self.rest_term;
        if self.opts.use_ediff {
            let qp = points_to_matrix(target);
            let d0 = qp.norm_squared();
            Ok(DataTerm {
                rhs: self.lbs.matrix().tr_mul(&qp),
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
        let arap = (&self.arap_quad * t).dot(t) + self.opts.lambda * (self.rest_term - tr_rs);
        let fit = if self.opts.use_ediff {
            (&self.ktk * t).dot(t) - 2.0 * data.rhs.dot(t) + data.d0
        } else {
            self.opts.handle_weight * (&self.kh * t - &data.xh).norm_squared()
        };
        arap + fit
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
                let s: DMatrix<f64> = &self.cov * points_to_matrix(target);
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
        let positions = points_from_matrix(&self.lbs.apply_stacked(&t)?);
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
        check_points(target, self.rest.len(), "target")?;
        let q = points_from_matrix(&self.lbs.apply_stacked(t_stacked)?);
        let p = &self.rest;
        let mut s = vec![Mat3::zeros(); self.n_groups];
        for &(i, j, w) in &self.edges {
            let m = w * (p[i] - p[j]) * (q[i] - q[j]).transpose();
            s[self.groups[i]] += m;
            s[self.groups[j]] += m;
        }
        let rots: Vec<Mat3> = s.iter().map(best_rotation).collect::<Result<_>>()?;
        let mut arap = 0.0;
        for &(i, j, w) in &self.edges {
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

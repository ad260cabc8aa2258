//! FBT's constrained energies and their local / scale / global optimisation
//! (FBT Sec. 4.2–4.4) for one constraint matrix `H`.
//!
//! With `X = H D` (h × b) and targets `Y` (h × 3):
//!
//! ```text
//! E_lc = ½ ‖X T − Y‖²                                   (Eq. 5)
//! E_sm = ½ tr(Tᵀ Λ T)                                    (Eq. 6)
//! E_av = (1/q) Σ_ℓ E_sc(V_ℓ, Ṽ),  E_total = E_av + β_lc E_lc + β_sm E_sm   (Eq. 9–11)
//! E_ℓ  = E_sc(V_ℓ, Ṽ) + β_lc E_lc + β_sm E_sm,  E_mn = min_ℓ E_ℓ            (Eq. 12–14)
//! ```
//!
//! **Steps.** *Local:* `R_{ℓ,k}` maximises `tr(R S_{ℓ,k})`, `S_ℓ = K̃_ℓ T`,
//! by SVD (the rotation of the polar decomposition of `S_{ℓ,k}ᵀ`). *Scale*
//! (Eq. 16): `α = Σ_ℓ tr(R_ℓ K̃_ℓ T) / Σ_ℓ tr(V_ℓᵀ L V_ℓ)` — the exact
//! minimiser of Eq. 11 over α (the paper prints the average of per-example
//! ratios, which equals this when the examples have equal `tr(VᵀLV)`, as
//! isometric poses nearly do); for E_ℓ, `α_ℓ = tr(R_ℓ K̃_ℓ T_ℓ) /
//! tr(V_ℓᵀ L V_ℓ)`. *Global* (Eq. 18–19): `T = Γ⁻¹ (β_lc XᵀY + (α/q) Σ_ℓ
//! K̃_ℓᵀ R_ℓᵀ)` with `Γ = L̃ + β_lc XᵀX + β_sm Λ` factorised once by
//! Cholesky; for E_ℓ, `T_ℓ = Γ⁻¹(β_lc XᵀY + α_ℓ K̃_ℓᵀ R_ℓᵀ)`. Each step
//! minimises the energy exactly over its own variables, so the energy never
//! increases ([`Trace`] records it after every step).
//!
//! **Regularisation.** `Γ` is singular for redundant dictionaries (e.g. the
//! constant weight's translation atom is invisible to ARAP and to Λ), so a
//! tiny ridge `ε‖T‖²/2` with `ε = ridge · tr(L̃)/b` is part of the energy
//! (default `ridge = 1e-10`; it depends on the model only, not on `H`);
//! reported energies include it.
//!
//! **Units.** `β_lc` weighs squared lengths against the ARAP energy (also a
//! squared length), so it is scale-free; `β_sm` likewise (see
//! [`crate::skin::dictionary`] for Λ's units).
//!
//! **Initialisation.** Eq. 22: `T = (β_lc XᵀX + β_sm Λ + εI)⁻¹ β_lc XᵀY`;
//! Eq. 23 adds `β_sp ‖T‖₁`, solved by coordinate descent
//! ([`crate::solve::elastic_net`]) with `β_sp = sparsity · max|β_lc XᵀY|`.
//!
//! **Unavailable constraints (Sec. 4.4).** [`FbtSystem::set_available`]
//! removes (or restores) rows of `X` by rank-one downdates (updates) of the
//! Cholesky factors of `Γ` and of the initialisation matrix — O(b²) per row
//! instead of a new O(b³) factorisation. `Y` keeps all h rows; rows marked
//! unavailable are ignored.

use std::sync::Arc;

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use super::model::FbtModel;
use crate::ops::polar_decomposition;
use crate::solve::dense::tr_mul;
use crate::solve::elastic_net::{l1_max, quadratic_l1, CoordinateDescentOptions};
use crate::{Error, Mat3, Point, Result};

/// How the global scale α is handled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScaleMode {
    /// Scale step of Eq. 16 (starting from 1).
    Estimate,
    /// α fixed (Fig. 8 C uses 1).
    Fixed(f64),
}

/// Weights of the energy terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FbtParams {
    /// β_lc of Eq. 10.
    pub beta_lc: f64,
    /// β_sm of Eq. 10.
    pub beta_sm: f64,
    /// Global scale handling.
    pub scale: ScaleMode,
    /// Relative ridge (see the module docs).
    pub ridge: f64,
}

impl Default for FbtParams {
    fn default() -> Self {
        FbtParams {
            beta_lc: 1000.0,
            beta_sm: 1e-4,
            scale: ScaleMode::Estimate,
            ridge: 1e-10,
        }
    }
}

/// Sparse rows of the constraint matrix `H` (h × n): row `r` is the list of
/// `(vertex, coefficient)`; a vertex position constraint is `[(i, 1.0)]`, a
/// weighted average `[(i, w_i), …]` with `Σ w_i = 1`.
pub type ConstraintRows = Vec<Vec<(usize, f64)>>;

/// One step of the optimisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    Local,
    Scale,
    Global,
}

/// Energy after every step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    /// `(iteration, step, energy)`.
    pub steps: Vec<(usize, Step, f64)>,
}

impl Trace {
    /// The energies in order.
    pub fn energies(&self) -> Vec<f64> {
        self.steps.iter().map(|s| s.2).collect()
    }

    /// Largest increase between consecutive recorded energies (≤ 0 when
    /// monotone).
    pub fn max_increase(&self) -> f64 {
        self.steps
            .windows(2)
            .map(|w| w[1].2 - w[0].2)
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

/// Iteration control of a local/scale/global loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterOptions {
    /// Maximum local/scale/global iterations.
    pub max_iter: usize,
    /// Stop when an iteration decreases the energy by at most
    /// `rel_tol · energy`.
    pub rel_tol: f64,
}

impl Default for IterOptions {
    fn default() -> Self {
        IterOptions {
            max_iter: 20,
            rel_tol: 1e-6,
        }
    }
}

/// Result of [`FbtSystem::solve_average`] (E_total, Eq. 10–11).
#[derive(Clone, Debug)]
pub struct AverageSolution {
    /// T (b × 3).
    pub t: DMatrix<f64>,
    /// `R_ℓ` per example, one rotation per cluster.
    pub rotations: Vec<Vec<Mat3>>,
    /// Global scale α.
    pub alpha: f64,
    /// Final energy.
    pub energy: f64,
    pub trace: Trace,
    pub iterations: usize,
}

/// The solution of one example's energy E_ℓ (Eq. 13–14).
#[derive(Clone, Debug)]
pub struct ExampleSolution {
    pub t: DMatrix<f64>,
    pub rotations: Vec<Mat3>,
    pub alpha: f64,
    pub energy: f64,
    pub trace: Trace,
    pub iterations: usize,
}

/// Result of [`FbtSystem::solve_minimal`] (E_mn, Eq. 12).
#[derive(Clone, Debug)]
pub struct MinimalSolution {
    /// One solution per example.
    pub per_example: Vec<ExampleSolution>,
    /// ℓ* = argmin_ℓ E_ℓ (lowest index on ties).
    pub best: usize,
}

impl MinimalSolution {
    /// `E_mn = min_ℓ E_ℓ`.
    pub fn energy(&self) -> f64 {
        self.per_example[self.best].energy
    }

    /// `T_ℓ*`.
    pub fn t(&self) -> &DMatrix<f64> {
        &self.per_example[self.best].t
    }

    /// `α_ℓ*`.
    pub fn alpha(&self) -> f64 {
        self.per_example[self.best].alpha
    }

    /// `min_ℓ E_ℓ` after every recorded step (all examples run the same
    /// number of steps until they stop; a stopped example keeps its last
    /// energy). Non-increasing when every E_ℓ trace is.
    pub fn min_trace(&self) -> Vec<f64> {
        let len = self
            .per_example
            .iter()
            .map(|s| s.trace.steps.len())
            .max()
            .unwrap_or(0);
        (0..len)
            .map(|k| {
                self.per_example
                    .iter()
                    .filter_map(|s| s.trace.steps.get(k).or(s.trace.steps.last()).map(|x| x.2))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect()
    }
}

/// FBT precomputed for one constraint matrix `H`: `X = HD`, the Cholesky
/// factors of `Γ` and of the initialisation matrix. Solve many `Y`.
#[derive(Clone, Debug)]
pub struct FbtSystem {
    model: Arc<FbtModel>,
    params: FbtParams,
    rows: ConstraintRows,
    available: Vec<bool>,
    x: DMatrix<f64>,
    gamma: DMatrix<f64>,
    gamma_chol: Cholesky<f64, Dyn>,
    init: DMatrix<f64>,
    init_chol: Cholesky<f64, Dyn>,
    ridge_eps: f64,
    /// The reduced form of E_ℓ's iterations, once [`FbtSystem::prepare`]d
    /// (dropped when rows change availability).
    reduced: Option<Arc<Reduced>>,
}

/// What makes an E_ℓ iteration independent of the dictionary size b (see
/// [`FbtSystem::prepare`]): with `Γ = L Lᵀ`, per example ℓ
/// `Z_ℓ = L⁻¹ K̃_ℓᵀ` (b × 3r) and `G_ℓ = Z_ℓᵀ Z_ℓ = K̃_ℓ Γ⁻¹ K̃_ℓᵀ` (3r × 3r).
#[derive(Clone, Debug)]
struct Reduced {
    z: Vec<DMatrix<f64>>,
    g: Vec<DMatrix<f64>>,
}

impl FbtSystem {
    /// Builds `X = HD` and factorises `Γ` and `β_lc XᵀX + β_sm Λ + εI`.
    /// Errors on bad rows (vertex out of range, non-finite coefficient),
    /// negative weights, or a failed factorisation.
    pub fn new(model: Arc<FbtModel>, rows: ConstraintRows, params: FbtParams) -> Result<Self> {
        let n = model.dictionary().n_vertices();
        for (r, row) in rows.iter().enumerate() {
            for &(i, w) in row {
                if i >= n || !w.is_finite() {
                    return Err(Error::invalid(format!(
                        "constraint row {r}: entry ({i}, {w}) invalid for {n} vertices"
                    )));
                }
            }
        }
        for (name, v) in [
            ("beta_lc", params.beta_lc),
            ("beta_sm", params.beta_sm),
            ("ridge", params.ridge),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(format!(
                    "{name} must be finite and ≥ 0, got {v}"
                )));
            }
        }
        if let ScaleMode::Fixed(a) = params.scale {
            if !a.is_finite() {
                return Err(Error::invalid(format!(
                    "fixed scale must be finite, got {a}"
                )));
            }
        }
        let d = model.dictionary().atoms();
        let b = d.ncols();
        let h = rows.len();
        // X = H D, column by column (columns of D are contiguous).
        let mut x = DMatrix::zeros(h, b);
        for c in 0..b {
            let col = d.column(c);
            let col = col.as_slice();
            for (r, row) in rows.iter().enumerate() {
                x[(r, c)] = row.iter().map(|&(i, w)| w * col[i]).sum();
            }
        }
        let xtx = crate::solve::dense::tr_mul(&x, &x);
        let lam = model.dictionary().smoothness();
        let mut gamma = model.laplacian_form() + &xtx * params.beta_lc + lam * params.beta_sm;
        let mut init = &xtx * params.beta_lc + lam * params.beta_sm;
        // ε from the model only, so that it does not depend on H (a system
        // with rows removed by downdates equals one built without them).
        let ridge_eps = params.ridge * model.laplacian_form().trace() / b.max(1) as f64;
        add_ridge(&mut gamma, ridge_eps);
        add_ridge(&mut init, ridge_eps);
        let gamma_chol = gamma.clone().cholesky().ok_or_else(|| {
            Error::numerical("Γ = L̃ + β_lc XᵀX + β_sm Λ is not positive definite")
        })?;
        let init_chol = init.clone().cholesky().ok_or_else(|| {
            Error::numerical("β_lc XᵀX + β_sm Λ + εI is not positive definite (Eq. 22)")
        })?;
        Ok(FbtSystem {
            model,
            params,
            available: vec![true; h],
            rows,
            x,
            gamma,
            gamma_chol,
            init,
            init_chol,
            ridge_eps,
            reduced: None,
        })
    }

    /// Precomputes the reduced form of the E_ℓ iterations (cost
    /// O(q r b²), about that of a few direct iterations), after which every
    /// local / scale / global iteration of [`Self::solve_example`] and
    /// [`Self::solve_minimal`] costs O(r²) instead of O(b²): the same
    /// iterates, energies and result up to rounding.
    ///
    /// The global step's `T = Γ⁻¹(β XᵀY + α K̃ᵀR̂) = T₀ + α Γ⁻¹K̃ᵀR̂` (`R̂`
    /// the 3r × 3 stack of the `R_kᵀ`) is never formed inside the loop: the
    /// local step needs only `S = K̃ T = S₀ + α G R̂` (`S₀ = K̃ T₀ = Zᵀu`,
    /// `u = L⁻¹ β XᵀY`), and the energy's quadratic part
    /// `tr(TᵀΓT) − 2 tr(Tᵀ β XᵀY) = α² ⟨R̂, G R̂⟩ − ‖u‖²` (using `ΓT₀ = β XᵀY`
    /// and `Γ Γ⁻¹K̃ᵀ = K̃ᵀ`). The final `T = L⁻ᵀ(u + α Z R̂)` is formed once.
    /// The same precomputation as the BDT reduced ARAP solver's
    /// ([`crate::arap`]), applied to FBT's Eq. 19.
    pub fn prepare(&mut self) {
        let q = self.model.n_examples();
        let lfac = self.gamma_chol.l_dirty();
        let z: Vec<DMatrix<f64>> = (0..q)
            .map(|l| {
                let mut z = self.model.covariance_form_t(l).clone();
                triangular_solve_in_place(lfac, &mut z, false);
                z
            })
            .collect();
        let g = z.iter().map(|z| tr_mul(z, z)).collect();
        self.reduced = Some(Arc::new(Reduced { z, g }));
    }

    /// Whether [`Self::prepare`] has been done (and is still valid).
    pub fn is_prepared(&self) -> bool {
        self.reduced.is_some()
    }

    /// The model.
    pub fn model(&self) -> &Arc<FbtModel> {
        &self.model
    }

    /// The parameters.
    pub fn params(&self) -> &FbtParams {
        &self.params
    }

    /// The constraint rows `H`.
    pub fn rows(&self) -> &ConstraintRows {
        &self.rows
    }

    /// Number of constraint rows h (available or not).
    pub fn n_rows(&self) -> usize {
        self.rows.len()
    }

    /// Which rows are in use.
    pub fn available(&self) -> &[bool] {
        &self.available
    }

    /// Marks rows unavailable (`available = false`) or available again by
    /// rank-one downdates / updates of both Cholesky factors (Sec. 4.4).
    /// Rows already in the requested state are left alone. Errors on a row
    /// out of range, or if a downdate would lose positive definiteness (then
    /// the factors are rebuilt from scratch to stay consistent).
    pub fn set_available(&mut self, rows: &[usize], available: bool) -> Result<()> {
        if let Some(&r) = rows.iter().find(|&&r| r >= self.rows.len()) {
            return Err(Error::invalid(format!(
                "constraint row {r} out of range ({} rows)",
                self.rows.len()
            )));
        }
        let sigma = if available { 1.0 } else { -1.0 };
        let s = self.params.beta_lc.sqrt();
        for &r in rows {
            if self.available[r] == available {
                continue;
            }
            self.available[r] = available;
            self.reduced = None;
            let xr: DVector<f64> = self.x.row(r).transpose() * s;
            self.gamma_chol.rank_one_update(&xr, sigma);
            self.init_chol.rank_one_update(&xr, sigma);
            let outer = &xr * xr.transpose() * sigma;
            self.gamma += &outer;
            self.init += &outer;
        }
        let bad = |c: &Cholesky<f64, Dyn>| {
            c.l_dirty()
                .diagonal()
                .iter()
                .any(|v| !(v.is_finite() && *v > 0.0))
        };
        if bad(&self.gamma_chol) || bad(&self.init_chol) {
            self.gamma_chol = self
                .gamma
                .clone()
                .cholesky()
                .ok_or_else(|| Error::numerical("Γ lost positive definiteness"))?;
            self.init_chol = self.init.clone().cholesky().ok_or_else(|| {
                Error::numerical("initialisation matrix lost positive definiteness")
            })?;
        }
        Ok(())
    }

    /// `Γ` with the rows currently available (including the ridge).
    pub fn gamma(&self) -> &DMatrix<f64> {
        &self.gamma
    }

    /// Solves `Γ Z = B` with the (possibly up/downdated) factor.
    pub fn solve_gamma(&self, b: &DMatrix<f64>) -> DMatrix<f64> {
        self.gamma_chol.solve(b)
    }

    fn check_y(&self, y: &DMatrix<f64>) -> Result<()> {
        if y.nrows() != self.rows.len() || y.ncols() != 3 {
            return Err(Error::invalid(format!(
                "constraint targets must be {} × 3, got {} × {}",
                self.rows.len(),
                y.nrows(),
                y.ncols()
            )));
        }
        if y.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("constraint targets are not finite"));
        }
        // Without any target point the solve is undetermined (the scale
        // collapses to 0 and every vertex to one point): refuse it.
        if !self.available.iter().any(|&a| a) {
            return Err(Error::invalid(format!(
                "no constraint rows available ({} rows, all unavailable or none given): the \
                 target has no points to register to (an empty partial shape?)",
                self.rows.len()
            )));
        }
        Ok(())
    }

    fn check_t(&self, t: &DMatrix<f64>) -> Result<()> {
        let b = self.model.size();
        if t.nrows() != b || t.ncols() != 3 {
            return Err(Error::invalid(format!(
                "transformations must be {b} × 3, got {} × {}",
                t.nrows(),
                t.ncols()
            )));
        }
        Ok(())
    }

    /// `Y` with unavailable rows zeroed.
    fn masked(&self, y: &DMatrix<f64>) -> DMatrix<f64> {
        let mut m = y.clone();
        for (r, &a) in self.available.iter().enumerate() {
            if !a {
                m.row_mut(r).fill(0.0);
            }
        }
        m
    }

    /// `β_lc Xᵀ Y` over the available rows, and `β_lc ‖Y‖²`.
    fn constraint_terms(&self, y: &DMatrix<f64>) -> (DMatrix<f64>, f64) {
        let ym = self.masked(y);
        (
            crate::solve::dense::tr_mul(&self.x, &ym) * self.params.beta_lc,
            self.params.beta_lc * ym.norm_squared(),
        )
    }

    /// Deformed positions `D T`.
    pub fn positions(&self, t: &DMatrix<f64>) -> Result<Vec<Point>> {
        self.model.positions(t)
    }

    /// Initial transformations of Eq. 22.
    pub fn initial(&self, y: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        self.check_y(y)?;
        let (xty, _) = self.constraint_terms(y);
        Ok(self.init_chol.solve(&xty))
    }

    /// Sparse initial transformations of Eq. 23 (`β_sp = sparsity ·
    /// max|β_lc XᵀY|`; `sparsity` in [0, 1), 0 gives Eq. 22). Also returns
    /// whether coordinate descent converged.
    pub fn sparse_initial(
        &self,
        y: &DMatrix<f64>,
        sparsity: f64,
        opts: &CoordinateDescentOptions,
    ) -> Result<(DMatrix<f64>, bool)> {
        self.check_y(y)?;
        if !(0.0..1.0).contains(&sparsity) {
            return Err(Error::invalid(format!(
                "sparsity must be in [0, 1), got {sparsity}"
            )));
        }
        let (xty, _) = self.constraint_terms(y);
        let l1 = sparsity * l1_max(&xty);
        let s = quadratic_l1(&self.init, &xty, l1, opts)?;
        Ok((s.x, s.converged))
    }

    /// Local step for example ℓ: one rotation per cluster maximising
    /// `tr(R_k S_k)`, `S = K̃_ℓ T`.
    pub fn local_step(&self, l: usize, t: &DMatrix<f64>) -> Result<Vec<Mat3>> {
        rotations_of(&(self.model.covariance_form(l) * t))
    }

    /// `tr(R_ℓ K̃_ℓ T)` = ⟨R̂, K̃_ℓ T⟩.
    fn rotation_trace(&self, l: usize, rots: &[Mat3], t: &DMatrix<f64>) -> f64 {
        stacked_transposes(rots).dot(&(self.model.covariance_form(l) * t))
    }

    /// `K̃_ℓᵀ R_ℓᵀ` (b × 3).
    fn rotation_rhs(&self, l: usize, rots: &[Mat3]) -> DMatrix<f64> {
        self.model.covariance_form_t(l) * stacked_transposes(rots)
    }

    /// ½[tr(TᵀΓT) − 2 tr(Tᵀ B)] + const, B = β XᵀY + rotation part.
    fn quadratic(&self, t: &DMatrix<f64>, b: &DMatrix<f64>, constant: f64) -> f64 {
        let gt = &self.gamma * t;
        0.5 * (t.dot(&gt) - 2.0 * t.dot(b) + constant)
    }

    /// `E_ℓ(T, R_ℓ, α)` of Eq. 13–14 (reduced form, ridge included).
    pub fn energy_example(
        &self,
        l: usize,
        y: &DMatrix<f64>,
        t: &DMatrix<f64>,
        rots: &[Mat3],
        alpha: f64,
    ) -> Result<f64> {
        self.check_y(y)?;
        self.check_t(t)?;
        let (xty, yy) = self.constraint_terms(y);
        let c = self.model.graph().rest_terms()[l];
        let rt = self.rotation_trace(l, rots, t);
        let gt = &self.gamma * t;
        Ok(0.5 * (t.dot(&gt) - 2.0 * t.dot(&xty) - 2.0 * alpha * rt + yy + alpha * alpha * c))
    }

    /// `E_total(T, R, α)` of Eq. 10–11 (reduced form, ridge included).
    pub fn energy_average(
        &self,
        y: &DMatrix<f64>,
        t: &DMatrix<f64>,
        rots: &[Vec<Mat3>],
        alpha: f64,
    ) -> Result<f64> {
        self.check_y(y)?;
        self.check_t(t)?;
        let q = self.model.n_examples() as f64;
        let (xty, yy) = self.constraint_terms(y);
        let rest = self.model.graph().rest_terms();
        let mut rt = 0.0;
        let mut cc = 0.0;
        for (l, r) in rots.iter().enumerate() {
            rt += self.rotation_trace(l, r, t);
            cc += rest[l];
        }
        let gt = &self.gamma * t;
        Ok(0.5
            * (t.dot(&gt) - 2.0 * t.dot(&xty) - 2.0 * alpha * rt / q + yy + alpha * alpha * cc / q))
    }

    /// `E_ℓ` evaluated in the full space (vertex by vertex ARAP, `HDT − Y`,
    /// `tr(TᵀΛT)`, ridge): an independent check of [`Self::energy_example`].
    pub fn energy_example_full(
        &self,
        l: usize,
        y: &DMatrix<f64>,
        t: &DMatrix<f64>,
        rots: &[Mat3],
        alpha: f64,
    ) -> Result<f64> {
        self.check_y(y)?;
        self.check_t(t)?;
        let p = self.positions(t)?;
        let arap = self
            .model
            .graph()
            .energy(l, &p, self.model.clusters(), rots, alpha)?;
        let mut lc = 0.0;
        for (r, row) in self.rows.iter().enumerate() {
            if !self.available[r] {
                continue;
            }
            let mut hp = nalgebra::Vector3::zeros();
            for &(i, w) in row {
                hp += p[i].coords * w;
            }
            for c in 0..3 {
                lc += (hp[c] - y[(r, c)]).powi(2);
            }
        }
        let lam = self.model.dictionary().smoothness();
        let sm = t.dot(&(lam * t));
        Ok(arap
            + 0.5 * self.params.beta_lc * lc
            + 0.5 * self.params.beta_sm * sm
            + 0.5 * self.ridge_eps * t.norm_squared())
    }

    fn initial_alpha(&self) -> f64 {
        match self.params.scale {
            ScaleMode::Estimate => 1.0,
            ScaleMode::Fixed(a) => a,
        }
    }

    /// Minimises E_total (Eq. 10, average ARAP energy) from `t0` by
    /// local / scale / global iterations.
    pub fn solve_average(
        &self,
        y: &DMatrix<f64>,
        t0: &DMatrix<f64>,
        opts: &IterOptions,
    ) -> Result<AverageSolution> {
        self.check_y(y)?;
        self.check_t(t0)?;
        let q = self.model.n_examples();
        let qf = q as f64;
        let (xty, yy) = self.constraint_terms(y);
        let rest = self.model.graph().rest_terms();
        let csum: f64 = rest.iter().sum();
        let mut t = t0.clone();
        let mut alpha = self.initial_alpha();
        let mut rots: Vec<Vec<Mat3>> = Vec::new();
        let mut trace = Trace::default();
        let mut prev = f64::INFINITY;
        let mut iterations = 0;
        let energy = |t: &DMatrix<f64>, rt: f64, alpha: f64| {
            self.quadratic(
                t,
                &xty,
                yy - 2.0 * alpha * rt / qf + alpha * alpha * csum / qf,
            )
        };
        for it in 0..opts.max_iter.max(1) {
            iterations = it + 1;
            rots = (0..q)
                .map(|l| self.local_step(l, &t))
                .collect::<Result<_>>()?;
            let rt: f64 = (0..q).map(|l| self.rotation_trace(l, &rots[l], &t)).sum();
            trace.steps.push((it, Step::Local, energy(&t, rt, alpha)));
            if self.params.scale == ScaleMode::Estimate && csum > 0.0 {
                alpha = (rt / csum).max(0.0);
                trace.steps.push((it, Step::Scale, energy(&t, rt, alpha)));
            }
            let mut b = xty.clone();
            for (l, r) in rots.iter().enumerate() {
                b += self.rotation_rhs(l, r) * (alpha / qf);
            }
            t = self.gamma_chol.solve(&b);
            let rt: f64 = (0..q).map(|l| self.rotation_trace(l, &rots[l], &t)).sum();
            let e = energy(&t, rt, alpha);
            trace.steps.push((it, Step::Global, e));
            if prev - e <= opts.rel_tol * e.abs() {
                break;
            }
            prev = e;
        }
        let energy = trace.steps.last().map_or(f64::NAN, |s| s.2);
        Ok(AverageSolution {
            t,
            rotations: rots,
            alpha,
            energy,
            trace,
            iterations,
        })
    }

    /// Minimises E_ℓ (Eq. 13) for one example ℓ from `t0` (in O(r²) per
    /// iteration once [`Self::prepare`]d).
    pub fn solve_example(
        &self,
        l: usize,
        y: &DMatrix<f64>,
        t0: &DMatrix<f64>,
        alpha0: Option<f64>,
        opts: &IterOptions,
    ) -> Result<ExampleSolution> {
        self.check_y(y)?;
        self.check_t(t0)?;
        self.check_example(l)?;
        let terms = self.example_terms(y, t0);
        let (mut sol, pending) = self.example_from(l, &terms, t0, alpha0, opts)?;
        if let Some(mut v) = pending {
            triangular_solve_in_place(self.gamma_chol.l_dirty(), &mut v, true);
            sol.t = v;
        }
        Ok(sol)
    }

    fn check_example(&self, l: usize) -> Result<()> {
        if l >= self.model.n_examples() {
            return Err(Error::invalid(format!(
                "example {l} out of range ({} examples)",
                self.model.n_examples()
            )));
        }
        Ok(())
    }

    /// The quantities of `Y` and of the start `t0` shared by every
    /// example's solve.
    fn example_terms(&self, y: &DMatrix<f64>, t0: &DMatrix<f64>) -> ExampleTerms {
        let (xty, yy) = self.constraint_terms(y);
        let u = self.reduced.as_ref().map(|_| {
            let mut u = xty.clone();
            triangular_solve_in_place(self.gamma_chol.l_dirty(), &mut u, false);
            u
        });
        let quad0 = t0.dot(&(&self.gamma * t0)) - 2.0 * t0.dot(&xty);
        ExampleTerms { xty, yy, u, quad0 }
    }

    /// E_ℓ's iterations from `t0`. On the reduced path the returned
    /// solution's `t` is empty and the second value holds `Lᵀ T` (the caller
    /// solves with `Lᵀ`, for several examples at once).
    fn example_from(
        &self,
        l: usize,
        terms: &ExampleTerms,
        t0: &DMatrix<f64>,
        alpha0: Option<f64>,
        opts: &IterOptions,
    ) -> Result<(ExampleSolution, Option<DMatrix<f64>>)> {
        let (xty, yy) = (&terms.xty, terms.yy);
        let c = self.model.graph().rest_terms()[l];
        let kt = self.model.covariance_form(l);
        let mut alpha = match self.params.scale {
            ScaleMode::Estimate => alpha0.unwrap_or(1.0),
            ScaleMode::Fixed(a) => a,
        };
        // On the reduced path: the precomputation, u = L⁻¹ β XᵀY, S₀ = Zᵀu
        // and ‖u‖².
        let reduced = self
            .reduced
            .as_deref()
            .zip(terms.u.as_ref())
            .map(|(red, u)| (red, u, tr_mul(&red.z[l], u), u.norm_squared()));
        // The state: S = K̃_ℓ T and the quadratic part of the energy at T,
        // quad = tr(TᵀΓT) − 2 tr(Tᵀ β XᵀY); T itself only on the direct path.
        let mut t = if reduced.is_some() {
            DMatrix::zeros(0, 3)
        } else {
            t0.clone()
        };
        let mut s = kt * t0;
        let mut quad = terms.quad0;
        let energy = |quad: f64, rt: f64, alpha: f64| {
            0.5 * (quad - 2.0 * alpha * rt + yy + alpha * alpha * c)
        };
        let mut rots = Vec::new();
        let mut rhat = DMatrix::zeros(0, 3);
        let mut trace = Trace::default();
        let mut prev = f64::INFINITY;
        let mut iterations = 0;
        for it in 0..opts.max_iter.max(1) {
            iterations = it + 1;
            rots = rotations_of(&s)?;
            rhat = stacked_transposes(&rots);
            let rt = rhat.dot(&s);
            trace.steps.push((it, Step::Local, energy(quad, rt, alpha)));
            if self.params.scale == ScaleMode::Estimate && c > 0.0 {
                alpha = (rt / c).max(0.0);
                trace.steps.push((it, Step::Scale, energy(quad, rt, alpha)));
            }
            match &reduced {
                Some((red, _, s0, e0)) => {
                    let gr = &red.g[l] * &rhat;
                    s = s0 + &gr * alpha;
                    quad = alpha * alpha * rhat.dot(&gr) - e0;
                }
                None => {
                    let b = xty + self.model.covariance_form_t(l) * &rhat * alpha;
                    t = self.gamma_chol.solve(&b);
                    s = kt * &t;
                    quad = t.dot(&(&self.gamma * &t)) - 2.0 * t.dot(xty);
                }
            }
            let e = energy(quad, rhat.dot(&s), alpha);
            trace.steps.push((it, Step::Global, e));
            if prev - e <= opts.rel_tol * e.abs() {
                break;
            }
            prev = e;
        }
        // The last global step's T = L⁻ᵀ(u + α Z R̂), still to be solved.
        let pending = reduced.map(|(red, u, _, _)| u + &red.z[l] * &rhat * alpha);
        let energy = trace.steps.last().map_or(f64::NAN, |s| s.2);
        Ok((
            ExampleSolution {
                t,
                rotations: rots,
                alpha,
                energy,
                trace,
                iterations,
            },
            pending,
        ))
    }

    /// Minimises E_mn (Eq. 12): every E_ℓ from `t0` (or from `starts[ℓ]`),
    /// then ℓ* = argmin.
    pub fn solve_minimal(
        &self,
        y: &DMatrix<f64>,
        t0: &DMatrix<f64>,
        alpha0: Option<f64>,
        opts: &IterOptions,
    ) -> Result<MinimalSolution> {
        self.check_y(y)?;
        self.check_t(t0)?;
        let terms = self.example_terms(y, t0);
        let solved: Vec<(ExampleSolution, Option<DMatrix<f64>>)> = (0..self.model.n_examples())
            .map(|l| self.example_from(l, &terms, t0, alpha0, opts))
            .collect::<Result<_>>()?;
        let (mut per_example, pending): (Vec<ExampleSolution>, Vec<Option<DMatrix<f64>>>) =
            solved.into_iter().unzip();
        // The reduced path (every example or none): the T of every example
        // by one triangular solve.
        let pending: Vec<DMatrix<f64>> = pending.into_iter().flatten().collect();
        if !pending.is_empty() {
            let mut all = DMatrix::zeros(self.model.size(), 3 * pending.len());
            for (l, v) in pending.iter().enumerate() {
                all.columns_mut(3 * l, 3).copy_from(v);
            }
            triangular_solve_in_place(self.gamma_chol.l_dirty(), &mut all, true);
            for (l, sol) in per_example.iter_mut().enumerate() {
                sol.t = all.columns(3 * l, 3).into_owned();
            }
        }
        let best = argmin(per_example.iter().map(|s| s.energy));
        Ok(MinimalSolution { per_example, best })
    }

    /// One global step of E_total for given rotations and α (used by shape
    /// interpolation): `T = Γ⁻¹(β XᵀY + (α/q) Σ_ℓ K̃_ℓᵀR_ℓᵀ)`.
    pub fn global_step_average(
        &self,
        y: &DMatrix<f64>,
        rots: &[Vec<Mat3>],
        alpha: f64,
    ) -> Result<DMatrix<f64>> {
        self.check_y(y)?;
        if rots.len() != self.model.n_examples() {
            return Err(Error::invalid(format!(
                "{} rotation sets for {} examples",
                rots.len(),
                self.model.n_examples()
            )));
        }
        let (mut b, _) = self.constraint_terms(y);
        let qf = rots.len() as f64;
        for (l, r) in rots.iter().enumerate() {
            b += self.rotation_rhs(l, r) * (alpha / qf);
        }
        Ok(self.gamma_chol.solve(&b))
    }

    /// One global step of E_ℓ: `T_ℓ = Γ⁻¹(β XᵀY + α K̃_ℓᵀR_ℓᵀ)`.
    pub fn global_step_example(
        &self,
        l: usize,
        y: &DMatrix<f64>,
        rots: &[Mat3],
        alpha: f64,
    ) -> Result<DMatrix<f64>> {
        self.check_y(y)?;
        let (b, _) = self.constraint_terms(y);
        Ok(self
            .gamma_chol
            .solve(&(b + self.rotation_rhs(l, rots) * alpha)))
    }
}

/// What [`FbtSystem::example_from`] needs of the targets `Y`: `β XᵀY`,
/// `β‖Y‖²` and, on the reduced path, `u = L⁻¹ β XᵀY`.
struct ExampleTerms {
    xty: DMatrix<f64>,
    yy: f64,
    u: Option<DMatrix<f64>>,
    /// `tr(t0ᵀΓt0) − 2 tr(t0ᵀ β XᵀY)`.
    quad0: f64,
}

/// One rotation per cluster block `S_k` (rows `3k..3k+3`) of `s` (3r × 3),
/// maximising `tr(R_k S_k)`: the rotation of the polar decomposition of
/// `S_kᵀ` (the identity for an all-zero block).
fn rotations_of(s: &DMatrix<f64>) -> Result<Vec<Mat3>> {
    (0..s.nrows() / 3)
        .map(|k| {
            let sk = Mat3::from_fn(|a, c| s[(3 * k + a, c)]);
            if sk.iter().all(|v| *v == 0.0) {
                return Ok(Mat3::identity());
            }
            Ok(polar_decomposition(&sk.transpose())?.rotation)
        })
        .collect()
}

/// `R̂`: the 3r × 3 stack of the `R_kᵀ` (so that `tr(R̂ᵀ S) = Σ_k tr(R_k S_k)`).
fn stacked_transposes(rots: &[Mat3]) -> DMatrix<f64> {
    let mut rs = DMatrix::zeros(3 * rots.len(), 3);
    for (k, rot) in rots.iter().enumerate() {
        for a in 0..3 {
            for c in 0..3 {
                rs[(3 * k + a, c)] = rot[(c, a)];
            }
        }
    }
    rs
}

/// Solves `L X = B` (or `Lᵀ X = B` when `transpose`) in place for
/// lower-triangular `L` (only its lower triangle is read) and column-major
/// `B` (faer's blocked kernel, sequential).
fn triangular_solve_in_place(l: &DMatrix<f64>, b: &mut DMatrix<f64>, transpose: bool) {
    use faer::linalg::triangular_solve as ts;
    let n = l.nrows();
    let k = b.ncols();
    if n == 0 || k == 0 {
        return;
    }
    let lv = faer::MatRef::from_column_major_slice(l.as_slice(), n, n);
    let bv = faer::MatMut::from_column_major_slice_mut(b.as_mut_slice(), n, k);
    if transpose {
        ts::solve_upper_triangular_in_place(lv.transpose(), bv, faer::Par::Seq);
    } else {
        ts::solve_lower_triangular_in_place(lv, bv, faer::Par::Seq);
    }
}

fn add_ridge(a: &mut DMatrix<f64>, eps: f64) {
    for i in 0..a.nrows() {
        a[(i, i)] += eps;
    }
}

pub(crate) fn argmin(it: impl Iterator<Item = f64>) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (i, v) in it.enumerate() {
        if v < best.0 {
            best = (v, i);
        }
    }
    best.1
}

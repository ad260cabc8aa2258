//! Small convex quadratic programs on top of sparse Cholesky factorisations.
//!
//! * [`BoxQp`] — `min ½ xᵀA x + bᵀx` subject to `lo ≤ x ≤ hi` (scalar bounds)
//!   for a sparse symmetric positive-definite `A`, by a primal–dual active-set
//!   method. Every iteration factorises the free block `A_FF` in the induced
//!   order of one AMD ordering of `A` computed once (module `ordered`), so no
//!   iteration pays for an ordering and the cost shrinks with the free set.
//!   `BoxQp` is `Sync`: many right-hand sides can be solved in parallel.
//! * [`RowAdmm`] — `min Σ_k ½ x_kᵀA x_k + b_kᵀx_k` over an `n × m`
//!   matrix `X` (columns `x_k`) whose every row lies on the probability simplex
//!   (`X_ik ≥ 0`, `Σ_k X_ik = 1`) or in a box, by ADMM with one factorisation
//!   of `A + ρD` shared by all columns and iterations.
//! * [`simplex_rows_qp`] — the same simplex-constrained problem solved
//!   exactly by an active-set method on the row supports.
//!
//! All are generic numerics (no meshes); bounded biharmonic weights
//! (`skin::bbw`) are their main user.
//!
//! Layout: `box_qp` (the bound-constrained QP and its active-set method),
//! `admm` (the row-constrained ADMM), `simplex` (the exact active-set
//! method for simplex rows), `common` (matrix–vector product, simplex
//! projection and the checks and region growth the active-set methods
//! share) and `ordered` (subset factorisations in one fixed ordering).

mod admm;
mod box_qp;
mod common;
mod ordered;
mod simplex;

pub use admm::{AdmmOptions, AdmmSolution, RowAdmm, RowConstraint, ADMM_COLUMN_BLOCK};
pub use box_qp::{BoxQp, BoxQpSolution};
pub use common::{project_to_simplex, sym_matvec_add};
pub use simplex::{
    simplex_rows_kkt_residual, simplex_rows_qp, SimplexQpOptions, SimplexQpSolution,
};

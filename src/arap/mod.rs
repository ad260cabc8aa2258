//! Reduced (skinning-subspace) as-rigid-as-possible deformation with the
//! E_diff data term, solved local/global (BDT Eq. 3–5, 16–21), and its
//! E_diff-off ablation (Fast Automatic Skinning Transformations, Jacobson et
//! al. 2012: ARAP in the skinning subspace with handle position
//! constraints).
//!
//! # Energy
//!
//! The deformed positions are `Q = K T` (linear blend skinning, BDT Eq. 2;
//! `K` n × 4n_h from [`crate::skin::LbsMatrix`], `T` the 4n_h × 3 stacked
//! transforms). With one rotation `R_g` per group,
//!
//! ```text
//! E_arap(T, R) = ½ Σ_i Σ_{j ∈ N(i)} w̃_ij ‖(q_i − q_j) − R_{g(i)} (p_i − p_j)‖²      (BDT Eq. 3)
//! E_diff(T)    = Σ_i ‖q_i − q′_i‖²                                                    (BDT Eq. 4)
//! E            = λ E_arap + E_diff                                                    (BDT Eq. 5)
//! ```
//!
//! and the reported energy of a `T` is `E(T) = min_R E(T, R)`.
//!
//! **Edges → groups (the "spokes" convention of FAST / libigl `arap_dof`).**
//! Every vertex `i` owns its spokes `(i, j)`, `j` in its 1-ring, and they use
//! the rotation of `i`'s group. An undirected edge inside a group therefore
//! counts twice with the same rotation (hence the `½`, which makes `E_arap`
//! equal to the paper's sum over undirected edges in that case), and an edge
//! between two groups is split half/half between them. This needs no
//! arbitrary tie-break (such as "the group of the lower index"), is symmetric
//! in `i` and `j`, and gives the clean quadratic part `tr(Qᵀ L̃ Q)` with the
//! (clamped) cotangent Laplacian `L̃`.
//!
//! **Negative cotangents.** `w̃_ij = max(w_ij, 0)` with `w_ij = ½(cot α +
//! cot β)` from [`crate::ops::cotan_weights`]: an edge opposite two obtuse
//! angles whose cotangents sum below zero is dropped from the energy. Every
//! term is then a non-negative weight times a squared norm, so `E ≥ 0`
//! exactly, and `L̃` (built from the same clamped weights, so that the
//! reduced bookkeeping equals the direct evaluation) is positive
//! semi-definite. A rigid motion of the whole mesh still has `E_arap = 0`
//! for any non-negative weights.
//!
//! **Local step (BDT Eq. 21).** `S_g = Σ_{i ∈ g} Σ_{j ∈ N(i)} w̃_ij e^p_ij
//! e^qᵀ_ij` and `R_g = argmax tr(R S_g)` over SO(3): with `S_g = U Σ Vᵀ`,
//! `R_g = V Uᵀ`, and if `det < 0` the sign of the singular vector pair of
//! the smallest singular value is flipped (`R_g = V diag(1, 1, −1) Uᵀ`, the
//! Kabsch fix; the paper's "negate R" would give det −1 again in 3-D). This
//! is the polar rotation of `S_gᵀ` ([`crate::ops::polar_decomposition`]).
//!
//! **Global step (BDT Eq. 16–20).** For fixed rotations `E` is quadratic in
//! `T`: `E = tr(Tᵀ A T) − 2⟨b₀ + (λ/2) (CK)ᵀ R̂, T⟩ + const` with
//! `A = λ Kᵀ L̃ K + Kᵀ K` (4n_h × 4n_h, shared by the three coordinates),
//! `b₀ = Kᵀ Q′`, `R̂` the 3|G| × 3 stack of the `R_gᵀ`, and `C` (3|G| × n,
//! sparse) the map with `S = C Q`. So the same 3|G| × 4n_h matrix `CK` maps
//! `T` to the covariances (`S = (CK) T`) and, transposed, the rotations to the
//! right-hand side. [`ReducedArap::new`] factorises `A` once (dense Cholesky)
//! and stores `CK` and `H = A⁻¹ (CK)ᵀ`; a solve computes `T₀ = A⁻¹ b₀` once
//! (the only O(n) work besides the final positions), after which an
//! iteration is `T = T₀ + (λ/2) H R̂`, `S = (CK) T`, |G| 3×3 SVDs and the
//! energy from 4n_h-sized quantities: O(n_h · |G|), independent of n.
//!
//! **Precomputation cost.** The mesh-only part (clamped weights, 1-rings of
//! `L̃`) is an [`ArapMesh`], built once per mesh and shared by every
//! [`ReducedArap::with_mesh`] (key point selection builds thousands of
//! solvers on one mesh). Per (weights, groups) the work is `Kᵀ` built
//! directly (4n_h × n, one contiguous column per vertex), `(λ L̃ + I) K`
//! from the 1-rings, `A` as one blocked dense product, and `CK` gathered per
//! vertex (about 3n axpys of length 4n_h); no sparse matrix is assembled.
//! On the 6890-vertex FAUST mesh with 12 handles this went from ~45 ms to
//! ~6 ms of CPU per trial set (see `bench::bdt`).
//!
//! **E_diff off (FAST ablation).** ARAP alone is invariant to rigid motions,
//! so the data term is replaced by soft handle position constraints
//! `μ Σ_h ‖q_h − x_h‖²` (handle vertices `h`, positions `x_h` read from the
//! target; `μ` = [`ArapOptions::handle_weight`], default 1e5): the same
//! code path with `Kᵀ K` replaced by `μ K_hᵀ K_h` and `b₀ = μ K_hᵀ X_h`. Soft
//! rather than exact (Lagrange multipliers) keeps the system a positive
//! definite matrix with one Cholesky; with `μ = 1e5` the handles are met to
//! about `1e-5` of the ARAP residual forces.

mod reduced;

pub use reduced::{ArapMesh, ArapOptions, ArapSolution, ReducedArap};

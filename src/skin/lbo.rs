//! Laplace–Beltrami eigenfunctions as skinning weights (FBT Sec. 4.1,
//! "example-based LBO dictionary").
//!
//! The first `m` eigenpairs of `L φ = λ M φ` (cotangent `L`, Voronoi mass
//! `M`) come from [`crate::solve::generalized_eigen`], which verifies
//! residuals, M-orthonormality and completeness. They are stored
//! **area-normalised**: with `A` the surface area,
//!
//! ```text
//! w_j = √A · φ_j        (so w_0 ≡ 1 on a connected mesh, and Wᵀ (M/A) W = I)
//! μ_j = A · λ_j         (eigenvalues of the unit-area surface)
//! ```
//!
//! which is exactly the eigen-basis of the same surface scaled to unit area.
//! Weights, eigenvalues and hence FBT's smoothness term (Eq. 6,
//! `Λ = diag(μ_j²)`) are then independent of the units of the mesh.
//!
//! **Signs.** Eigenvectors are defined up to sign; the columns keep the
//! canonical sign given by the eigensolver
//! ([`crate::solve::canonicalize_signs`]: `⟨φ, w⟩_M > 0` for a fixed generic
//! weight `w`), which depends only on the vector, not on the solver's start
//! vector, block size or rounding — unlike "largest entry positive", which
//! rounding decides on symmetric meshes. (For a repeated eigenvalue the basis
//! of its eigenspace is arbitrary anyway.)

use nalgebra::DMatrix;

use crate::mesh::Mesh;
use crate::ops::MassKind;
use crate::ops::Operators;
use crate::solve::{generalized_eigen, EigenOptions};
use crate::{Error, Result};

/// The first `m` area-normalised Laplace–Beltrami eigenfunctions of a mesh.
#[derive(Clone, Debug)]
pub struct LboBasis {
    /// n × m, column `j` is `w_j = √A φ_j` (see the module docs).
    pub weights: DMatrix<f64>,
    /// `μ_j = A λ_j`, ascending.
    pub values: Vec<f64>,
    /// The lumped Voronoi mass `M` (diagonal) used.
    pub mass: Vec<f64>,
    /// Surface area `A = Σ M_ii`.
    pub area: f64,
    /// `max |ΦᵀMΦ − I|` reported by the verified eigensolver.
    pub orthonormality_error: f64,
    /// Largest relative residual reported by the eigensolver.
    pub max_residual: f64,
}

/// The first `m` eigenfunctions of `mesh` (see the module docs). Errors if
/// `m` is 0 or exceeds the number of vertices, if a vertex has no mass, or
/// if the eigensolver cannot verify its result.
pub fn lbo_basis(mesh: &Mesh, m: usize, opts: &EigenOptions) -> Result<LboBasis> {
    let n = mesh.n_vertices();
    if m == 0 || m > n {
        return Err(Error::invalid(format!(
            "asked for {m} Laplace–Beltrami eigenfunctions of a mesh with {n} vertices"
        )));
    }
    let l = mesh.laplacian();
    let mass = mesh.mass(MassKind::Voronoi);
    if let Some(i) = mass.iter().position(|&x| !(x > 0.0 && x.is_finite())) {
        return Err(Error::invalid(format!(
            "vertex {i} has mass {} (isolated or only in degenerate faces); \
             the Laplace–Beltrami eigenproblem needs positive masses",
            mass[i]
        )));
    }
    let area: f64 = mass.iter().sum();
    let eig = generalized_eigen(&l, &mass, m, opts)?;
    let s = area.sqrt();
    let weights = eig.vectors * s;
    Ok(LboBasis {
        weights,
        values: eig.values.iter().map(|l| l * area).collect(),
        mass: mass.to_vec(),
        area,
        orthonormality_error: eig.orthonormality_error,
        max_residual: eig.max_residual,
    })
}

impl LboBasis {
    /// Number of eigenfunctions.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Whether the basis is empty (never, for a basis built by [`lbo_basis`]).
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The first `m` eigenfunctions (`m ≤ len`).
    pub fn truncated(&self, m: usize) -> Result<LboBasis> {
        if m == 0 || m > self.len() {
            return Err(Error::invalid(format!(
                "cannot keep {m} of {} eigenfunctions",
                self.len()
            )));
        }
        Ok(LboBasis {
            weights: self.weights.columns(0, m).into_owned(),
            values: self.values[..m].to_vec(),
            mass: self.mass.clone(),
            area: self.area,
            orthonormality_error: self.orthonormality_error,
            max_residual: self.max_residual,
        })
    }

    /// `max |Wᵀ (M/A) W − I|`, recomputed from the stored weights.
    pub fn orthonormality_defect(&self) -> f64 {
        let m = self.len();
        let mut g = DMatrix::zeros(m, m);
        for a in 0..m {
            for b in a..m {
                let v: f64 = (0..self.weights.nrows())
                    .map(|i| self.weights[(i, a)] * self.weights[(i, b)] * self.mass[i])
                    .sum::<f64>()
                    / self.area;
                g[(a, b)] = v;
                g[(b, a)] = v;
            }
        }
        (g - DMatrix::identity(m, m)).abs().max()
    }

    /// The smoothness matrix of FBT Eq. 6 for these weights:
    /// `diag(μ_j²)` (m × m), the Laplacian energy `∫(Δf)²` of
    /// `f = Σ a_j w_j` on the unit-area surface is `aᵀ diag(μ²) a`.
    pub fn smoothness(&self) -> DMatrix<f64> {
        DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            self.len(),
            self.values.iter().map(|v| v * v),
        ))
    }
}

//! FBT's example-based dictionary (Sec. 4.1), its k-medoids reduction and
//! the change of dictionaries (Sec. 4.4, Eq. 24), and the weighting
//! functions it is built from.
//!
//! **Dictionary.** From q example poses `V_1..V_q` (n × 3, shared
//! connectivity) and m weighting functions `w_j` (n × m matrix `W`):
//!
//! ```text
//! D = (D̄, D̂_1, …, D̂_q)  ∈ R^{n × (1+3q)m}
//! D̄   = W                              (translation atoms, column j = w_j)
//! D̂_ℓ = [w_1 ∘ V_ℓ, …, w_m ∘ V_ℓ]        (column 3j + k = w_j · (V_ℓ)_{:,k})
//! ```
//!
//! so that `Ṽ = D T` with `T = (T̄ᵀ, T̂_1ᵀ, …, T̂_qᵀ)ᵀ` reproduces Eq. 3–4:
//! rows `3j..3j+3` of `T̂_ℓ` hold `M̂_jᵀ` of example ℓ and row `j` of `T̄` the
//! summed translations `Σ_ℓ M̄_j^ℓ`.
//!
//! **Smoothness (Eq. 6).** The influence of `v^ℓ_{i,k}` on `ṽ_{i,k̃}` is
//! `Σ_j w_j(v_i) a_j` with `a_j = T[(ℓ, j, k), k̃]`; its Laplacian energy
//! `½∫(Δ ·)²` summed over all streams `(ℓ, k)` and output coordinates is
//! `½ tr(Tᵀ Λ T)` with `Λ[a, a'] = Q_w[j(a), j(a')]` when atoms `a, a'`
//! belong to the same stream, 0 otherwise; translation atoms form one more
//! stream. `Q_w = A · Wᵀ L M⁻¹ L W` is the Laplacian energy of the weights on
//! the unit-area surface ([`laplacian_energy_matrix`]); for area-normalised
//! LBO eigenfunctions it is `diag(μ_j²)` (μ = A·λ), i.e. Eq. 6's `Λ`
//! ("squares of the eigenvalues") on a unit-area shape. For other weights
//! the same formula gives the "more involved" expression the paper mentions.
//! *Units:* for the example atoms (`w_j · v`, a length) the stream block is
//! multiplied by `A`, so that every term of `tr(TᵀΛT)` is a squared length
//! like the ARAP and constraint energies — identical to the paper's Λ when
//! the shapes have unit area, and scale-invariant otherwise.
//!
//! **Weighting functions** ([`SkinningWeights`]):
//! - LBO eigenfunctions ([`crate::skin::lbo`]), the paper's main choice;
//! - "skeleton" weights. The paper's come from an example-based rigging
//!   package (Le & Deng 2014); [`SkinningWeights::skeleton`] builds them by
//!   example-based skinning ([`crate::skin::rigging`]: rigid bones fitted
//!   to the examples, SSDR weights) — the FBT pipeline's last stage and
//!   clusters by default ([`crate::register::FbtConfig`]). The earlier
//!   segment stand-in (heat-smoothed k-means segments of rotation
//!   features) is removed; [`SkinningWeights::biharmonic`] (bounded
//!   biharmonic weights of farthest-point handles) remains as an ablation.
//!
//! **Reduction (Sec. 4.4).** The example atoms are clustered by k-medoids
//! ([`crate::solve::kmedoids`]) on Euclidean distances between atom columns;
//! the reduced dictionary keeps the medoid atoms (original atoms, not
//! averages) and every translation atom.
//!
//! **Change of dictionaries (Eq. 24).** `T_2 = (D_2ᵀ D_2)⁻¹ D_2ᵀ D_1 T_1`,
//! the least-squares representation in `D_2` of the shape `D_1 T_1`. (The
//! paper prints `D_1ᵀ T_1`, which does not type-check; `D_2ᵀ D_1 T_1` is the
//! least-squares solution it describes.) A relative ridge keeps the normal
//! equations solvable for redundant dictionaries.

use nalgebra::DMatrix;

use crate::mesh::Mesh;
use crate::ops::MassKind;
use crate::ops::Operators;
use crate::skin::bbw::{BbwOptions, Biharmonic, WeightMode};
use crate::skin::lbo::LboBasis;
use crate::skin::rigging::{example_skinning, Rig, RigOptions};
use crate::solve::dense::tr_mul;
use crate::solve::kmeans::kmeans_with;
use crate::solve::kmedoids::{column_distances, kmedoids, KMedoids};
use crate::{Error, Point, Result};

/// Relative ridge of the normal equations of [`Dictionary::project`] and
/// [`DictionaryChange`] (times the mean diagonal of `DᵀD`).
pub const PROJECTION_RIDGE: f64 = 1e-10;

/// Which weighting functions a [`SkinningWeights`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeightKind {
    /// Laplace–Beltrami eigenfunctions ("example-based LBO dictionary").
    Lbo,
    /// Biharmonic weights of farthest-point handles (an ablation).
    Biharmonic,
    /// Bone weights of example-based skinning ([`crate::skin::rigging`]),
    /// the paper's "skeleton" weights.
    Skeleton,
    /// Anything else given by the caller.
    Custom,
}

/// Weighting functions `W` (n × m) with their smoothness matrix
/// `Q_w = A · Wᵀ L M⁻¹ L W` (m × m, see the module docs).
#[derive(Clone, Debug)]
pub struct SkinningWeights {
    /// n × m.
    pub weights: DMatrix<f64>,
    /// m × m Laplacian energy of the weights on the unit-area surface.
    pub smoothness: DMatrix<f64>,
    /// Surface area `A` of the mesh the weights were built on.
    pub area: f64,
    /// Which construction.
    pub kind: WeightKind,
}

/// `A · Wᵀ L M⁻¹ L W` (Voronoi `M`): the Laplacian energy `∫(Δf)²` of
/// `f = W a` on `mesh` scaled to unit area is `aᵀ Q a`. Errors on a
/// row-count mismatch or a vertex without mass.
pub fn laplacian_energy_matrix(mesh: &Mesh, weights: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = mesh.n_vertices();
    if weights.nrows() != n {
        return Err(Error::invalid(format!(
            "weights have {} rows for {n} vertices",
            weights.nrows()
        )));
    }
    let mass = mesh.mass(MassKind::Voronoi);
    if let Some(i) = mass.iter().position(|&x| !(x > 0.0 && x.is_finite())) {
        return Err(Error::invalid(format!(
            "vertex {i} has no mass; the Laplacian energy needs M⁻¹"
        )));
    }
    let area: f64 = mass.iter().sum();
    let l = mesh.laplacian();
    let mut lw = &*l * weights;
    for (i, mut row) in lw.row_iter_mut().enumerate() {
        row /= mass[i].sqrt();
    }
    let q = tr_mul(&lw, &lw) * area;
    Ok(0.5 * (&q + q.transpose()))
}

impl SkinningWeights {
    /// Area-normalised LBO eigenfunctions with `Q_w = diag(μ²)` (Eq. 6).
    pub fn lbo(basis: &LboBasis) -> Self {
        SkinningWeights {
            weights: basis.weights.clone(),
            smoothness: basis.smoothness(),
            area: basis.area,
            kind: WeightKind::Lbo,
        }
    }

    /// Caller-given weights on `mesh`; `Q_w` from [`laplacian_energy_matrix`].
    pub fn custom(mesh: &Mesh, weights: DMatrix<f64>, kind: WeightKind) -> Result<Self> {
        if weights.iter().any(|x| !x.is_finite()) {
            return Err(Error::invalid("skinning weights have a non-finite entry"));
        }
        let smoothness = laplacian_energy_matrix(mesh, &weights)?;
        let area = mesh.mass_area();
        Ok(SkinningWeights {
            weights,
            smoothness,
            area,
            kind,
        })
    }

    /// The paper's "skeleton" weights: the bone weights of example-based
    /// skinning of `examples` against `reference`
    /// ([`crate::skin::rigging::example_skinning`]), with the rig they come
    /// from (its dominant-bone labels can serve as rotation clusters, FBT
    /// Sec. 5). Errors as `example_skinning` and [`SkinningWeights::custom`].
    pub fn skeleton(reference: &Mesh, examples: &[Mesh], opts: &RigOptions) -> Result<(Self, Rig)> {
        let rig = example_skinning(reference, examples, opts)?;
        let w = Self::custom(reference, rig.weights.clone(), WeightKind::Skeleton)?;
        Ok((w, rig))
    }

    /// "Skeleton" weights from bounded biharmonic weights (per-handle
    /// bounds, rows normalised; [`WeightMode::PerHandle`]) of `n_handles`
    /// handles placed by Euclidean farthest point sampling from `seed`.
    pub fn biharmonic(mesh: &Mesh, n_handles: usize, seed: u64) -> Result<Self> {
        let handles = crate::ops::farthest_point_sampling(
            mesh,
            n_handles,
            crate::ops::FpsMetric::Euclidean,
            seed,
        )?;
        let w = Biharmonic::new(mesh)?
            .weights(&handles, &BbwOptions::with_mode(WeightMode::PerHandle))?;
        Self::custom(mesh, w, WeightKind::Biharmonic)
    }

    /// Number of weighting functions m.
    pub fn len(&self) -> usize {
        self.weights.ncols()
    }

    /// Whether there are no weighting functions.
    pub fn is_empty(&self) -> bool {
        self.weights.ncols() == 0
    }

    /// The first `m` weighting functions (for LBO: the lowest frequencies).
    pub fn truncated(&self, m: usize) -> Result<Self> {
        if m == 0 || m > self.len() {
            return Err(Error::invalid(format!(
                "cannot keep {m} of {} weighting functions",
                self.len()
            )));
        }
        Ok(SkinningWeights {
            weights: self.weights.columns(0, m).into_owned(),
            smoothness: self.smoothness.view((0, 0), (m, m)).into_owned(),
            area: self.area,
            kind: self.kind,
        })
    }

    /// Rotation clusters from the weights (FBT Sec. 5: "these skeleton
    /// weights are also used to define the rotation clusters"): seeded
    /// k-means on the rows of `W` into `r` clusters. For LBO weights this is
    /// spectral clustering (the constant `w_0` does not matter).
    pub fn rotation_clusters(&self, r: usize, seed: u64) -> Result<Vec<usize>> {
        if r == 0 || r > self.weights.nrows() {
            return Err(Error::invalid(format!(
                "cannot make {r} rotation clusters of {} vertices",
                self.weights.nrows()
            )));
        }
        Ok(kmeans_with(&self.weights, r, seed, &crate::skin::groups::GROUP_KMEANS)?.labels)
    }
}

/// What one dictionary atom (column of `D`) is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Atom {
    /// Column of `D̄`: weighting function `weight`.
    Translation { weight: usize },
    /// Column of `D̂_example`: `w_weight · (V_example)_{:, coord}`.
    Example {
        example: usize,
        weight: usize,
        coord: usize,
    },
}

impl Atom {
    /// The weighting function of the atom.
    pub fn weight(&self) -> usize {
        match *self {
            Atom::Translation { weight } | Atom::Example { weight, .. } => weight,
        }
    }

    /// The smoothness stream: translation atoms share stream 0, example
    /// atoms of (example ℓ, coordinate k) stream `1 + 3ℓ + k`.
    fn stream(&self) -> usize {
        match *self {
            Atom::Translation { .. } => 0,
            Atom::Example { example, coord, .. } => 1 + 3 * example + coord,
        }
    }
}

/// An example-based dictionary `D` (n × b) with its atoms' provenance and
/// the smoothness matrix `Λ` (b × b) of Eq. 6 (see the module docs).
#[derive(Clone, Debug)]
pub struct Dictionary {
    atoms: DMatrix<f64>,
    info: Vec<Atom>,
    smoothness: DMatrix<f64>,
    n_examples: usize,
    n_weights: usize,
}

impl Dictionary {
    /// `D = (D̄, D̂_1 … D̂_q)` of size `(1 + 3q) m` from the examples
    /// (positions; all with n vertices) and the weights (Sec. 4.1).
    pub fn example_based(examples: &[&[Point]], weights: &SkinningWeights) -> Result<Self> {
        let (n, m) = weights.weights.shape();
        if examples.is_empty() {
            return Err(Error::invalid("a dictionary needs at least one example"));
        }
        for (l, e) in examples.iter().enumerate() {
            if e.len() != n {
                return Err(Error::invalid(format!(
                    "example {l} has {} vertices, the weights {n}",
                    e.len()
                )));
            }
        }
        let q = examples.len();
        let b = (1 + 3 * q) * m;
        let w = &weights.weights;
        let mut atoms = DMatrix::zeros(n, b);
        let mut info = Vec::with_capacity(b);
        for j in 0..m {
            atoms.column_mut(j).copy_from(&w.column(j));
            info.push(Atom::Translation { weight: j });
        }
        for (l, e) in examples.iter().enumerate() {
            for j in 0..m {
                for k in 0..3 {
                    let c = m + 3 * m * l + 3 * j + k;
                    for i in 0..n {
                        atoms[(i, c)] = w[(i, j)] * e[i][k];
                    }
                    info.push(Atom::Example {
                        example: l,
                        weight: j,
                        coord: k,
                    });
                }
            }
        }
        let smoothness = smoothness_matrix(&info, &weights.smoothness, weights.area);
        Ok(Dictionary {
            atoms,
            info,
            smoothness,
            n_examples: q,
            n_weights: m,
        })
    }

    /// The same from meshes.
    pub fn from_meshes(examples: &[Mesh], weights: &SkinningWeights) -> Result<Self> {
        let v: Vec<&[Point]> = examples.iter().map(|m| m.vertices()).collect();
        Self::example_based(&v, weights)
    }

    /// `D` (n × b).
    pub fn atoms(&self) -> &DMatrix<f64> {
        &self.atoms
    }

    /// Provenance of every atom.
    pub fn info(&self) -> &[Atom] {
        &self.info
    }

    /// `Λ` (b × b) of Eq. 6.
    pub fn smoothness(&self) -> &DMatrix<f64> {
        &self.smoothness
    }

    /// Dictionary size b.
    pub fn size(&self) -> usize {
        self.atoms.ncols()
    }

    /// Number of vertices n.
    pub fn n_vertices(&self) -> usize {
        self.atoms.nrows()
    }

    /// Number of examples q the dictionary was built from.
    pub fn n_examples(&self) -> usize {
        self.n_examples
    }

    /// Number of weighting functions m.
    pub fn n_weights(&self) -> usize {
        self.n_weights
    }

    /// The sub-dictionary of the given atoms (in that order); `Λ` is the
    /// corresponding sub-matrix.
    pub fn select(&self, cols: &[usize]) -> Result<Dictionary> {
        let b = self.size();
        if let Some(&c) = cols.iter().find(|&&c| c >= b) {
            return Err(Error::invalid(format!("atom {c} out of range ({b} atoms)")));
        }
        if cols.is_empty() {
            return Err(Error::invalid("cannot select an empty dictionary"));
        }
        Ok(Dictionary {
            atoms: self.atoms.select_columns(cols),
            info: cols.iter().map(|&c| self.info[c]).collect(),
            smoothness: DMatrix::from_fn(cols.len(), cols.len(), |a, c| {
                self.smoothness[(cols[a], cols[c])]
            }),
            n_examples: self.n_examples,
            n_weights: self.n_weights,
        })
    }

    /// k-medoids reduction (Sec. 4.4) to `k` example atoms plus all
    /// translation atoms: the example atoms are clustered on the Euclidean
    /// distances between their columns and the medoids kept (atoms sorted
    /// by their original index). Returns the reduced dictionary and the
    /// clustering. Errors if `k` is 0 or exceeds the number of example atoms.
    pub fn reduce(&self, k: usize, seed: u64) -> Result<(Dictionary, KMedoids)> {
        let ex: Vec<usize> = (0..self.size())
            .filter(|&c| matches!(self.info[c], Atom::Example { .. }))
            .collect();
        if k == 0 || k > ex.len() {
            return Err(Error::invalid(format!(
                "cannot reduce {} example atoms to {k}",
                ex.len()
            )));
        }
        let dist = column_distances(&self.atoms.select_columns(&ex));
        let km = kmedoids(&dist, k, seed, 100 * ex.len())?;
        let mut keep: Vec<usize> = (0..self.size())
            .filter(|&c| matches!(self.info[c], Atom::Translation { .. }))
            .collect();
        keep.extend(km.medoids.iter().map(|&i| ex[i]));
        keep.sort_unstable();
        Ok((self.select(&keep)?, km))
    }

    /// Deformed positions `Ṽ = D T` (n × 3) for `T` (b × 3).
    pub fn apply(&self, t: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        if t.nrows() != self.size() || t.ncols() != 3 {
            return Err(Error::invalid(format!(
                "transformations must be {} × 3, got {} × {}",
                self.size(),
                t.nrows(),
                t.ncols()
            )));
        }
        Ok(&self.atoms * t)
    }

    /// Least-squares coefficients `T = argmin ‖D T − V‖²` (relative ridge
    /// [`PROJECTION_RIDGE`]) of positions `v` (n points): the closest shape
    /// the dictionary spans "in the L2 sense" (Table 2).
    pub fn project(&self, v: &[Point]) -> Result<DMatrix<f64>> {
        if v.len() != self.n_vertices() {
            return Err(Error::invalid(format!(
                "{} points for a dictionary of {} vertices",
                v.len(),
                self.n_vertices()
            )));
        }
        let vm = crate::skin::lbs::points_to_matrix(v);
        let g = ridged_gram(&self.atoms);
        let rhs = tr_mul(&self.atoms, &vm);
        let chol = g
            .cholesky()
            .ok_or_else(|| Error::numerical("DᵀD + εI is not positive definite"))?;
        Ok(chol.solve(&rhs))
    }
}

fn ridged_gram(d: &DMatrix<f64>) -> DMatrix<f64> {
    let mut g = tr_mul(d, d);
    let b = g.nrows();
    let eps = PROJECTION_RIDGE * (0..b).map(|i| g[(i, i)]).sum::<f64>() / b.max(1) as f64;
    for i in 0..b {
        g[(i, i)] += eps.max(f64::MIN_POSITIVE);
    }
    g
}

fn smoothness_matrix(info: &[Atom], qw: &DMatrix<f64>, area: f64) -> DMatrix<f64> {
    let b = info.len();
    DMatrix::from_fn(b, b, |a, c| {
        let (sa, sc) = (info[a].stream(), info[c].stream());
        if sa != sc {
            return 0.0;
        }
        let v = qw[(info[a].weight(), info[c].weight())];
        if sa == 0 {
            v
        } else {
            area * v
        }
    })
}

/// The change of dictionaries of Eq. 24, precomputed: `P = (D_2ᵀD_2 +
/// εI)⁻¹ D_2ᵀ D_1` (b_2 × b_1), so `T_2 = P T_1`.
#[derive(Clone, Debug)]
pub struct DictionaryChange {
    p: DMatrix<f64>,
}

impl DictionaryChange {
    /// Precomputes `P` for `from` (D_1) → `to` (D_2); both must have the same
    /// number of vertices.
    pub fn new(from: &Dictionary, to: &Dictionary) -> Result<Self> {
        if from.n_vertices() != to.n_vertices() {
            return Err(Error::invalid(format!(
                "dictionaries over {} and {} vertices",
                from.n_vertices(),
                to.n_vertices()
            )));
        }
        let g = ridged_gram(&to.atoms);
        let rhs = tr_mul(&to.atoms, &from.atoms);
        let chol = g
            .cholesky()
            .ok_or_else(|| Error::numerical("D_2ᵀD_2 + εI is not positive definite"))?;
        Ok(DictionaryChange {
            p: chol.solve(&rhs),
        })
    }

    /// `T_2 = P T_1`.
    pub fn apply(&self, t1: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        if t1.nrows() != self.p.ncols() {
            return Err(Error::invalid(format!(
                "transformations have {} rows, the source dictionary {} atoms",
                t1.nrows(),
                self.p.ncols()
            )));
        }
        Ok(&self.p * t1)
    }

    /// `P` (b_2 × b_1).
    pub fn matrix(&self) -> &DMatrix<f64> {
        &self.p
    }
}

//! The precomputation of FBT's energies for one mesh set and one dictionary
//! (FBT Sec. 3.2 and 4.2): everything that does not depend on the
//! constraints.
//!
//! **ARAP in matrix form.** Rotation clusters `𝓔_k` are sets of vertices;
//! the edges of cluster k are the *spokes* `i → j` (j a 1-ring neighbour of
//! i) of its vertices, so every undirected edge appears twice, once in the
//! cluster of each endpoint. With `c_ij` the cotangent weights of the
//! reference (first) example, clamped at 0 (negative weights would make the
//! energy indefinite; BDT's ARAP does the same), the energy relative to
//! example ℓ with global scale α (Eq. 7) is
//!
//! ```text
//! E_sc(V_ℓ, Ṽ) = ½ Σ_i Σ_{j∈N(i)} c_ij ‖(ṽ_i − ṽ_j) − α R_{k(i)} (v^ℓ_i − v^ℓ_j)‖²
//! 2E_sc       = tr(Tᵀ L̃ T) − 2α tr(R_ℓ K̃_ℓ T) + α² tr(V_ℓᵀ L V_ℓ)        (Eq. 8)
//! ```
//!
//! with `L` = twice the (clamped) cotangent Laplacian (each edge counted
//! from both ends), `K_ℓ` (3r × n) stacking `S_k = Σ_{i∈𝓔_k, j} c_ij
//! (v^ℓ_i − v^ℓ_j)(ṽ_i − ṽ_j)ᵀ = K_{ℓ,k} Ṽ`, `L̃ = Dᵀ L D` (b × b) and
//! `K̃_ℓ = K_ℓ D` (3r × b) (Eq. 2). [`FbtModel`] stores `L̃`, every `K̃_ℓ`
//! and `tr(V_ℓᵀ L V_ℓ)`; an iteration then costs O(q r b) and never touches
//! the n vertices. [`ArapGraph::energy`] evaluates the same energy vertex
//! by vertex, as an independent check of the reduced form.

use std::sync::Arc;

use nalgebra::DMatrix;

use crate::mesh::Mesh;
use crate::ops::Operators;
use crate::skin::dictionary::Dictionary;
use crate::solve::dense::tr_mul;
use crate::{Error, Mat3, Point, Result};

/// The mesh-set part of the precomputation: shared connectivity, clamped
/// cotangent spokes of the reference example, and the example positions.
/// Build once per mesh set and share between dictionaries.
#[derive(Clone, Debug)]
pub struct ArapGraph {
    reference: Mesh,
    examples: Vec<Vec<Point>>,
    /// CSR spokes: neighbours of i are `ring[ring_start[i]..ring_start[i+1]]`.
    ring_start: Vec<usize>,
    ring: Vec<usize>,
    ring_w: Vec<f64>,
    rest_terms: Vec<f64>,
    area: f64,
}

impl ArapGraph {
    /// From q ≥ 1 example meshes with identical face lists (use
    /// [`crate::mesh::set::adopt_consistent_faces`] first for TOSCA-style
    /// classes). The first example is the reference for the cotangent
    /// weights and the area.
    pub fn new(examples: &[Mesh]) -> Result<Self> {
        let Some(reference) = examples.first() else {
            return Err(Error::invalid("FBT needs at least one example mesh"));
        };
        for (l, e) in examples.iter().enumerate().skip(1) {
            if e.faces() != reference.faces() || e.n_vertices() != reference.n_vertices() {
                return Err(Error::invalid(format!(
                    "example {l} does not share the face list of example 0 \
                     (FBT needs one connectivity; see mesh::set::adopt_consistent_faces)"
                )));
            }
        }
        let n = reference.n_vertices();
        let edges: Vec<(usize, usize, f64)> = reference
            .edge_weights()
            .iter()
            .filter(|&&(_, w)| w > 0.0)
            .map(|&((i, j), w)| (i, j, w))
            .collect();
        let mut count = vec![0usize; n + 1];
        for &(i, j, _) in &edges {
            count[i + 1] += 1;
            count[j + 1] += 1;
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let ring_start = count.clone();
        let mut fill = count;
        let mut ring = vec![0; 2 * edges.len()];
        let mut ring_w = vec![0.0; 2 * edges.len()];
        for &(i, j, w) in &edges {
            for (a, b) in [(i, j), (j, i)] {
                ring[fill[a]] = b;
                ring_w[fill[a]] = w;
                fill[a] += 1;
            }
        }
        let examples: Vec<Vec<Point>> = examples.iter().map(|m| m.vertices().to_vec()).collect();
        let mut g = ArapGraph {
            reference: reference.clone(),
            examples,
            ring_start,
            ring,
            ring_w,
            rest_terms: Vec::new(),
            area: reference.mass_area(),
        };
        g.rest_terms = (0..g.examples.len())
            .map(|l| {
                let v = &g.examples[l];
                let mut s = 0.0;
                for i in 0..n {
                    for r in g.ring_start[i]..g.ring_start[i + 1] {
                        s += g.ring_w[r] * (v[i] - v[g.ring[r]]).norm_squared();
                    }
                }
                s
            })
            .collect();
        Ok(g)
    }

    /// Number of vertices n.
    pub fn n_vertices(&self) -> usize {
        self.reference.n_vertices()
    }

    /// Number of examples q.
    pub fn n_examples(&self) -> usize {
        self.examples.len()
    }

    /// The reference (first) example.
    pub fn reference(&self) -> &Mesh {
        &self.reference
    }

    /// Positions of example ℓ.
    pub fn example(&self, l: usize) -> &[Point] {
        &self.examples[l]
    }

    /// Surface area of the reference.
    pub fn area(&self) -> f64 {
        self.area
    }

    /// `tr(V_ℓᵀ L V_ℓ) = Σ_i Σ_j c_ij ‖v^ℓ_i − v^ℓ_j‖²` of every example.
    pub fn rest_terms(&self) -> &[f64] {
        &self.rest_terms
    }

    /// `E_sc(V_ℓ, Ṽ)` (Eq. 7) evaluated vertex by vertex: positions `p`
    /// (n points), per-vertex cluster labels, one rotation per cluster and
    /// the scale α.
    pub fn energy(
        &self,
        l: usize,
        p: &[Point],
        clusters: &[usize],
        rotations: &[Mat3],
        alpha: f64,
    ) -> Result<f64> {
        let n = self.n_vertices();
        if l >= self.n_examples() || p.len() != n || clusters.len() != n {
            return Err(Error::invalid(format!(
                "energy of example {l} with {} points and {} labels (n = {n}, q = {})",
                p.len(),
                clusters.len(),
                self.n_examples()
            )));
        }
        let v = &self.examples[l];
        let mut e = 0.0;
        for i in 0..n {
            let rot = rotations.get(clusters[i]).ok_or_else(|| {
                Error::invalid(format!("no rotation for cluster {}", clusters[i]))
            })?;
            for r in self.ring_start[i]..self.ring_start[i + 1] {
                let j = self.ring[r];
                let d = (p[i] - p[j]) - alpha * rot * (v[i] - v[j]);
                e += self.ring_w[r] * d.norm_squared();
            }
        }
        Ok(0.5 * e)
    }

    /// The scale α and per-cluster rotations that minimise `E_sc(V_ℓ, p)`
    /// (Eq. 7) for given positions `p`: `R_k` = polar factor of the
    /// cluster's edge covariance `Σ c_ij (p_i − p_j)(v_i − v_j)ᵀ`, then
    /// `α = Σ_k tr(R_kᵀ S_k) / Σ c_ij ‖v_i − v_j‖²` (the scale step of
    /// Eq. 16 with the rotations of the local step). Applied to a ground
    /// truth it gives the α the energy itself assigns to that shape — below
    /// 1 for a non-rigid pose even without any scaling, because an edge of a
    /// bent region is not a rotated copy of its rest edge under its
    /// cluster's single rotation (`tr(Rᵀ S) < ‖S‖` there).
    pub fn best_scale(
        &self,
        l: usize,
        p: &[Point],
        clusters: &[usize],
    ) -> Result<(f64, Vec<Mat3>)> {
        let n = self.n_vertices();
        if l >= self.n_examples() || p.len() != n || clusters.len() != n {
            return Err(Error::invalid(format!(
                "best scale of example {l} with {} points and {} labels (n = {n}, q = {})",
                p.len(),
                clusters.len(),
                self.n_examples()
            )));
        }
        let k = clusters.iter().max().map_or(0, |m| m + 1);
        let v = &self.examples[l];
        let mut cov = vec![Mat3::zeros(); k];
        for i in 0..n {
            for r in self.ring_start[i]..self.ring_start[i + 1] {
                let j = self.ring[r];
                cov[clusters[i]] += self.ring_w[r] * (p[i] - p[j]) * (v[i] - v[j]).transpose();
            }
        }
        let mut rots = Vec::with_capacity(k);
        let mut tr = 0.0;
        for s in &cov {
            let r = if s.iter().all(|x| *x == 0.0) {
                Mat3::identity()
            } else {
                crate::ops::polar_decomposition(s)?.rotation
            };
            tr += (r.transpose() * s).trace();
            rots.push(r);
        }
        Ok(((tr / self.rest_terms[l]).max(0.0), rots))
    }

    /// `L̃ = Dᵀ L D` (b × b) for a dictionary `d` (n × b).
    fn laplacian_form(&self, d: &DMatrix<f64>) -> DMatrix<f64> {
        let n = self.n_vertices();
        let b = d.ncols();
        // (L D) row by row through the transposed layout (contiguous rows).
        let dt = d.transpose();
        let mut ldt = DMatrix::zeros(b, n);
        {
            let x = dt.as_slice();
            let out = ldt.as_mut_slice();
            for i in 0..n {
                let (oi, rest) = (i * b, &x[i * b..(i + 1) * b]);
                for r in self.ring_start[i]..self.ring_start[i + 1] {
                    let j = self.ring[r];
                    let w = self.ring_w[r];
                    let xj = &x[j * b..(j + 1) * b];
                    // L = 2 L_cot: (L D)_i = 2 Σ_j c_ij (D_i − D_j).
                    for k in 0..b {
                        out[oi + k] += 2.0 * w * (rest[k] - xj[k]);
                    }
                }
            }
        }
        let ld = ldt.transpose();
        let g = tr_mul(d, &ld);
        0.5 * (&g + g.transpose())
    }

    /// `K̃_ℓ = K_ℓ D` (3r × b): row `3k + a` is
    /// `Σ_{i∈𝓔_k} Σ_j c_ij (v^ℓ_i − v^ℓ_j)_a (D_i − D_j)`, gathered per
    /// vertex (each row of `D` is added once per cluster touching its
    /// 1-ring, O(n b)).
    fn covariance_form(
        &self,
        l: usize,
        clusters: &[usize],
        r: usize,
        dt: &DMatrix<f64>,
    ) -> DMatrix<f64> {
        let n = self.n_vertices();
        let b = dt.nrows();
        let v = &self.examples[l];
        let mut kt = DMatrix::zeros(b, 3 * r);
        let x = dt.as_slice();
        let out = kt.as_mut_slice();
        let mut coef: Vec<(usize, [f64; 3])> = Vec::new();
        for u in 0..n {
            coef.clear();
            let mut own = [0.0; 3];
            for rr in self.ring_start[u]..self.ring_start[u + 1] {
                let j = self.ring[rr];
                let e = (v[u] - v[j]) * self.ring_w[rr];
                for a in 0..3 {
                    own[a] += e[a];
                }
                // Spoke j → u of cluster k(j) contributes −c (v_j − v_u) D_u.
                let g = clusters[j];
                match coef.iter_mut().find(|(h, _)| *h == g) {
                    Some((_, cf)) => {
                        for a in 0..3 {
                            cf[a] += e[a];
                        }
                    }
                    None => coef.push((g, [e[0], e[1], e[2]])),
                }
            }
            let g = clusters[u];
            match coef.iter_mut().find(|(h, _)| *h == g) {
                Some((_, cf)) => {
                    for a in 0..3 {
                        cf[a] += own[a];
                    }
                }
                None => coef.push((g, own)),
            }
            let du = &x[u * b..(u + 1) * b];
            for &(g, cf) in &coef {
                for (a, &f) in cf.iter().enumerate() {
                    if f == 0.0 {
                        continue;
                    }
                    let col = 3 * g + a;
                    for (o, d) in out[col * b..(col + 1) * b].iter_mut().zip(du) {
                        *o += f * d;
                    }
                }
            }
        }
        kt.transpose()
    }
}

/// Everything of FBT that depends on (mesh set, dictionary, rotation
/// clusters) but not on the constraints: `L̃`, `K̃_ℓ`, `tr(V_ℓᵀLV_ℓ)`, `Λ`.
#[derive(Clone, Debug)]
pub struct FbtModel {
    graph: Arc<ArapGraph>,
    dict: Dictionary,
    clusters: Vec<usize>,
    n_clusters: usize,
    lt: DMatrix<f64>,
    kt: Vec<DMatrix<f64>>,
    kt_t: Vec<DMatrix<f64>>,
    /// The nonzero entries of `D` row by row, when `D` is sparse enough for
    /// that to be the faster product (skeleton weights: at most a few bones
    /// per vertex, so most atoms vanish at a vertex); `None` for dense
    /// dictionaries (LBO eigenfunctions).
    rows: Option<RowSparse>,
}

/// A matrix stored by rows, nonzero entries only (compressed sparse rows).
#[derive(Clone, Debug)]
struct RowSparse {
    ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<f64>,
}

/// `D` is kept by rows as well when at most this fraction of its entries
/// is nonzero (the row product then reads and multiplies less than the
/// dense blocked product; measured on the TOSCA cat's skeleton dictionary,
/// 22 % nonzero: 12.6 ms dense against about 2 ms).
const ROW_SPARSE_MAX_DENSITY: f64 = 0.4;

impl RowSparse {
    /// The nonzeros of `d` by rows, or `None` when more than
    /// [`ROW_SPARSE_MAX_DENSITY`] of its entries are nonzero.
    fn of(d: &DMatrix<f64>) -> Option<RowSparse> {
        let (n, b) = d.shape();
        if n == 0 || b == 0 || b > u32::MAX as usize {
            return None;
        }
        let mut counts = vec![0usize; n + 1];
        for c in 0..b {
            for (i, v) in d.column(c).iter().enumerate() {
                if *v != 0.0 {
                    counts[i + 1] += 1;
                }
            }
        }
        for i in 0..n {
            counts[i + 1] += counts[i];
        }
        let nnz = counts[n];
        if nnz as f64 > ROW_SPARSE_MAX_DENSITY * (n * b) as f64 {
            return None;
        }
        let ptr = counts.clone();
        let mut next = counts;
        let mut col = vec![0u32; nnz];
        let mut val = vec![0.0; nnz];
        // Column-major traversal fills each row in increasing column order.
        for c in 0..b {
            for (i, v) in d.column(c).iter().enumerate() {
                if *v != 0.0 {
                    col[next[i]] = c as u32;
                    val[next[i]] = *v;
                    next[i] += 1;
                }
            }
        }
        Some(RowSparse { ptr, col, val })
    }

    /// `D T` as points, `T` b × 3.
    fn times(&self, t: &DMatrix<f64>) -> Vec<Point> {
        let b = t.nrows();
        // T by rows (b × 3 contiguous) for the gathers.
        let tr: Vec<[f64; 3]> = (0..b).map(|a| [t[(a, 0)], t[(a, 1)], t[(a, 2)]]).collect();
        (0..self.ptr.len() - 1)
            .map(|i| {
                let mut p = [0.0; 3];
                for e in self.ptr[i]..self.ptr[i + 1] {
                    let w = self.val[e];
                    let r = &tr[self.col[e] as usize];
                    p[0] += w * r[0];
                    p[1] += w * r[1];
                    p[2] += w * r[2];
                }
                Point::new(p[0], p[1], p[2])
            })
            .collect()
    }
}

impl FbtModel {
    /// Precomputes the reduced ARAP matrices. `clusters` holds one label per
    /// vertex in `0..r` (every label used at most; unused labels get the
    /// identity rotation). Errors on size mismatches.
    pub fn new(graph: Arc<ArapGraph>, dict: Dictionary, clusters: Vec<usize>) -> Result<Self> {
        let n = graph.n_vertices();
        if dict.n_vertices() != n || clusters.len() != n {
            return Err(Error::invalid(format!(
                "dictionary over {} vertices and {} cluster labels for a mesh set of {n} vertices",
                dict.n_vertices(),
                clusters.len()
            )));
        }
        let r = clusters.iter().max().map_or(0, |m| m + 1);
        let lt = graph.laplacian_form(dict.atoms());
        let dt = dict.atoms().transpose();
        let kt: Vec<DMatrix<f64>> = (0..graph.n_examples())
            .map(|l| graph.covariance_form(l, &clusters, r, &dt))
            .collect();
        let kt_t = kt.iter().map(|k| k.transpose()).collect();
        let rows = RowSparse::of(dict.atoms());
        Ok(FbtModel {
            graph,
            dict,
            clusters,
            n_clusters: r,
            lt,
            kt,
            kt_t,
            rows,
        })
    }

    /// The mesh-set precomputation.
    pub fn graph(&self) -> &Arc<ArapGraph> {
        &self.graph
    }

    /// The dictionary.
    pub fn dictionary(&self) -> &Dictionary {
        &self.dict
    }

    /// Rotation cluster of every vertex.
    pub fn clusters(&self) -> &[usize] {
        &self.clusters
    }

    /// Number of rotation clusters r.
    pub fn n_clusters(&self) -> usize {
        self.n_clusters
    }

    /// Number of examples q.
    pub fn n_examples(&self) -> usize {
        self.graph.n_examples()
    }

    /// Dictionary size b.
    pub fn size(&self) -> usize {
        self.dict.size()
    }

    /// `L̃ = DᵀLD` (b × b).
    pub fn laplacian_form(&self) -> &DMatrix<f64> {
        &self.lt
    }

    /// `K̃_ℓ` (3r × b).
    pub fn covariance_form(&self, l: usize) -> &DMatrix<f64> {
        &self.kt[l]
    }

    pub(crate) fn covariance_form_t(&self, l: usize) -> &DMatrix<f64> {
        &self.kt_t[l]
    }

    /// Whether [`Self::positions`] uses the row-sparse product (a dictionary
    /// of skeleton weights) rather than the dense one.
    pub fn has_sparse_rows(&self) -> bool {
        self.rows.is_some()
    }

    /// Deformed positions `D T` as points: the blocked dense product, or the
    /// row-sparse one when `D` is mostly zeros (skeleton weights).
    pub fn positions(&self, t: &DMatrix<f64>) -> Result<Vec<Point>> {
        if t.nrows() != self.size() || t.ncols() != 3 {
            return Err(Error::invalid(format!(
                "transformations must be {} × 3, got {} × {}",
                self.size(),
                t.nrows(),
                t.ncols()
            )));
        }
        if let Some(rows) = &self.rows {
            return Ok(rows.times(t));
        }
        Ok(crate::skin::lbs::points_from_matrix(&gemm(
            self.dict.atoms(),
            t,
        )))
    }
}

/// `A B` (column-major) through matrixmultiply's blocked kernel:
/// deterministic, single-threaded; several times faster than the generic
/// product for tall `A`.
pub(crate) fn gemm(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    assert_eq!(a.ncols(), b.nrows(), "gemm: inner dimensions differ");
    let (m, k) = a.shape();
    let n = b.ncols();
    let mut c = DMatrix::zeros(m, n);
    if m == 0 || n == 0 || k == 0 {
        return c;
    }
    let (mi, ki) = (m as isize, k as isize);
    // SAFETY: the pointers address m·k, k·n and m·n initialised f64s with
    // the column-major strides given; `c` does not alias `a` or `b`.
    unsafe {
        matrixmultiply::dgemm(
            m,
            k,
            n,
            1.0,
            a.as_ptr(),
            1,
            mi,
            b.as_ptr(),
            1,
            ki,
            0.0,
            c.as_mut_ptr(),
            1,
            mi,
        );
    }
    c
}

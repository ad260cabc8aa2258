//! Sumner & Popović 2004, "Deformation transfer for triangle meshes":
//! per-triangle deformation gradients and the transfer solve.
//!
//! # Deformation gradients (paper Sec. 3)
//!
//! Each triangle `(v1, v2, v3)` gets a fourth vertex
//! `v4 = v1 + (v2 − v1) × (v3 − v1) / √‖(v2 − v1) × (v3 − v1)‖` (paper Eq. 1)
//! and the frame `V = [v2 − v1, v3 − v1, v4 − v1]` ([`triangle_frame`]). The
//! deformation gradient between a reference and a deformed copy is
//! `S = Ṽ V⁻¹` (Eq. 3–4, [`deformation_gradients`]). A reference triangle
//! whose doubled area is below [`DEGENERATE_REL`] times its longest squared
//! edge has no invertible frame: [`deformation_gradients`] returns an error
//! naming it; [`DeformationTransfer`] instead **skips** such triangles (on
//! either mesh) and counts them ([`DeformationTransfer::skipped`]). A
//! *deformed* triangle that collapsed is fine: its fourth-vertex offset is
//! the zero vector, giving a finite (singular) `S`.
//!
//! # The transfer solve (paper Sec. 4, vertex formulation)
//!
//! The paper minimises `Σ_(s,t) ‖S_s − T_t‖²_F` over the matched triangle
//! pairs `(s, t)`, where `T_t = Ṽ_t V_t⁻¹` depends linearly on the unknown
//! target vertices *and* on one unknown fourth vertex per target triangle.
//! The fourth vertices are eliminated here in closed form. Write the rows of
//! `V_t⁻¹` as `w1, w2, w3`: `w1, w2` are orthogonal to the reference normal
//! `n_t` and `w3 ∥ n_t`, so `T_t = e1 w1ᵀ + e2 w2ᵀ + (ṽ4 − ṽ1) w3ᵀ`. The free
//! `ṽ4` only reaches the `n_t` column; minimising over it leaves
//! `‖(S̄_t − T_t) P_t‖²_F` with `P_t = I − n_t n_tᵀ`, weighted by the number
//! `k_t` of pairs of `t` (`S̄_t` = mean of their `S_s`; the sum of `k_t`
//! squared distances equals `k_t` times the distance to the mean plus a
//! constant). So row `k` of `T_t P_t` is `Σ_j x_j[k] g_j` with the hat-function
//! gradients `g_2 = w1`, `g_3 = w2`, `g_1 = −w1 − w2` of the reference
//! triangle, and each coordinate solves the same normal equations
//! `Σ_t k_t G_tᵀ G_t x = Σ_t k_t G_tᵀ (S̄_t P_t)ᵀ` — exactly the paper's
//! minimiser over the vertices (the equivalence Botsch et al. 2006 point
//! out), with a matrix of `n` rather than `n + m` unknowns.
//!
//! The matrix is factorised once per (target, correspondence) by
//! [`DeformationTransfer::new`]; every pose costs three back-substitutions.
//!
//! **Anchors.** The energy fixes positions only up to a translation per
//! connected component: the vertices in [`SumnerTransferOptions::anchors`] are
//! pinned (eliminated), and every component (over non-degenerate triangles)
//! without an anchor gets its lowest-index vertex pinned too; a vertex in no
//! non-degenerate triangle is its own component and is pinned. Pins sit at
//! their target reference positions ([`DeformationTransfer::transfer`]) or
//! at given positions ([`DeformationTransfer::transfer_with`]).
//! [`SumnerTransferOptions::soft`] vertices add `w ‖x_i − p_i‖²` with `w =
//! soft_weight` times the mean diagonal of the matrix (scale free).
//!
//! **Unmatched target triangles** (no pair, e.g. with a partial
//! correspondence) would leave vertices undetermined. The paper does not
//! say what it does with them; here each one takes the target gradient of
//! the nearest matched triangle (breadth first over edge-adjacent
//! triangles, seeded by the matched faces in index order) with weight 1,
//! and a component
//! without any matched triangle keeps its reference shape (`S = I`).

use std::collections::{HashMap, HashSet, VecDeque};
use std::time::Instant;

use nalgebra::DMatrix;

use crate::mesh::{Face, Mesh};
use crate::solve::{sparse_from_triplets, SparseCholesky};
use crate::{Error, Mat3, Point, Result, Vec3};

pub use crate::ops::laplacian::DEGENERATE_REL;

/// The frame `V = [v2 − v1, v3 − v1, v4 − v1]` of a triangle with the
/// normal-offset fourth vertex (paper Eq. 1), or `None` if the triangle is
/// degenerate (`‖(v2 − v1) × (v3 − v1)‖ < DEGENERATE_REL · longest edge²`).
pub fn triangle_frame(v1: &Point, v2: &Point, v3: &Point) -> Option<Mat3> {
    let (e1, e2) = (v2 - v1, v3 - v1);
    let c = e1.cross(&e2);
    let longest = e1
        .norm_squared()
        .max(e2.norm_squared())
        .max((v3 - v2).norm_squared());
    let len = c.norm();
    if longest.is_nan() || longest <= 0.0 || len < DEGENERATE_REL * longest {
        return None;
    }
    Some(Mat3::from_columns(&[e1, e2, c / len.sqrt()]))
}

/// The frame of a deformed triangle: like [`triangle_frame`], but a
/// collapsed triangle gets a zero fourth-vertex offset instead of `None`.
fn deformed_frame(v1: &Point, v2: &Point, v3: &Point) -> Mat3 {
    let (e1, e2) = (v2 - v1, v3 - v1);
    let c = e1.cross(&e2);
    let len = c.norm();
    let off = if len > 0.0 {
        c / len.sqrt()
    } else {
        Vec3::zeros()
    };
    Mat3::from_columns(&[e1, e2, off])
}

fn face_points(v: &[Point], f: &Face) -> (Point, Point, Point) {
    (v[f[0]], v[f[1]], v[f[2]])
}

/// Inverse reference frames `V⁻¹` of every face, `None` for degenerate ones.
pub(crate) fn inverse_frames(mesh: &Mesh) -> Vec<Option<Mat3>> {
    let v = mesh.vertices();
    mesh.faces()
        .iter()
        .map(|f| {
            let (a, b, c) = face_points(v, f);
            triangle_frame(&a, &b, &c)
                .and_then(|m| m.try_inverse())
                .filter(|m| m.iter().all(|x| x.is_finite()))
        })
        .collect()
}

fn check_same_connectivity(reference: &Mesh, deformed: &Mesh, what: &str) -> Result<()> {
    if reference.n_vertices() != deformed.n_vertices() {
        return Err(Error::invalid(format!(
            "{what}: deformed mesh has {} vertices, the reference has {}",
            deformed.n_vertices(),
            reference.n_vertices()
        )));
    }
    if reference.faces() != deformed.faces() {
        return Err(Error::invalid(format!(
            "{what}: deformed mesh has different faces from the reference \
             ({} vs {} faces); deformation gradients need shared connectivity",
            deformed.n_faces(),
            reference.n_faces()
        )));
    }
    Ok(())
}

/// Per-triangle deformation gradients `S = Ṽ V⁻¹` from `reference` to
/// `deformed` (same faces). Errors on a degenerate reference triangle.
pub fn deformation_gradients(reference: &Mesh, deformed: &Mesh) -> Result<Vec<Mat3>> {
    check_same_connectivity(reference, deformed, "deformation gradients")?;
    let inv = inverse_frames(reference);
    let q = deformed.vertices();
    reference
        .faces()
        .iter()
        .zip(&inv)
        .enumerate()
        .map(|(fi, (f, vinv))| {
            let vinv = vinv.ok_or_else(|| {
                Error::numerical(format!(
                    "deformation gradients: reference face {fi} {f:?} is degenerate \
                     (zero area), its frame has no inverse"
                ))
            })?;
            let (a, b, c) = face_points(q, f);
            Ok(deformed_frame(&a, &b, &c) * vinv)
        })
        .collect()
}

/// Gradients for the faces with an inverse frame (`None` elsewhere).
fn gradients_where(inv: &[Option<Mat3>], deformed: &Mesh) -> Vec<Option<Mat3>> {
    let q = deformed.vertices();
    deformed
        .faces()
        .iter()
        .zip(inv)
        .map(|(f, vinv)| {
            vinv.map(|vi| {
                let (a, b, c) = face_points(q, f);
                deformed_frame(&a, &b, &c) * vi
            })
        })
        .collect()
}

/// Edge-adjacent faces (faces sharing an undirected edge; all pairs at a
/// non-manifold edge), restricted to faces with `valid[f]`.
pub(crate) fn face_adjacency(faces: &[Face], valid: &[bool]) -> Vec<Vec<usize>> {
    let mut by_edge: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for (fi, f) in faces.iter().enumerate() {
        if !valid[fi] {
            continue;
        }
        for (i, j) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
            if i != j {
                by_edge.entry((i.min(j), i.max(j))).or_default().push(fi);
            }
        }
    }
    let mut adj = vec![Vec::new(); faces.len()];
    for fs in by_edge.values() {
        for (a, &fa) in fs.iter().enumerate() {
            for &fb in &fs[a + 1..] {
                if fa != fb {
                    adj[fa].push(fb);
                    adj[fb].push(fa);
                }
            }
        }
    }
    for row in adj.iter_mut() {
        row.sort_unstable();
        row.dedup();
    }
    adj
}

/// Connected components of the vertices over the `valid` faces: component
/// id per vertex (a vertex in no valid face is its own component).
pub(crate) fn vertex_components(n: usize, faces: &[Face], valid: &[bool]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for (f, _) in faces.iter().zip(valid).filter(|(_, &v)| v) {
        for k in 1..3 {
            let (a, b) = (find(&mut parent, f[0]), find(&mut parent, f[k]));
            if a != b {
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    (0..n).map(|i| find(&mut parent, i)).collect()
}

/// A many-to-many list of (source face, target face) pairs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TriangleCorrespondence {
    pairs: Vec<(usize, usize)>,
    n_source: usize,
    n_target: usize,
}

impl TriangleCorrespondence {
    /// Face `i` ↔ face `i` (shared connectivity).
    pub fn identity(n_faces: usize) -> Self {
        TriangleCorrespondence {
            pairs: (0..n_faces).map(|i| (i, i)).collect(),
            n_source: n_faces,
            n_target: n_faces,
        }
    }

    /// Checked pairs (sorted, duplicates removed) between meshes of
    /// `n_source` and `n_target` faces.
    pub fn new(mut pairs: Vec<(usize, usize)>, n_source: usize, n_target: usize) -> Result<Self> {
        if let Some(&(s, t)) = pairs.iter().find(|&&(s, t)| s >= n_source || t >= n_target) {
            return Err(Error::invalid(format!(
                "triangle pair ({s}, {t}) out of range for meshes of {n_source} and \
                 {n_target} faces"
            )));
        }
        pairs.sort_unstable();
        pairs.dedup();
        Ok(TriangleCorrespondence {
            pairs,
            n_source,
            n_target,
        })
    }

    /// The (source face, target face) pairs, sorted.
    pub fn pairs(&self) -> &[(usize, usize)] {
        &self.pairs
    }

    /// Number of source faces.
    pub fn n_source(&self) -> usize {
        self.n_source
    }

    /// Number of target faces.
    pub fn n_target(&self) -> usize {
        self.n_target
    }

    /// Fraction of source faces in at least one pair.
    pub fn source_coverage(&self) -> f64 {
        let mut seen = vec![false; self.n_source];
        self.pairs.iter().for_each(|&(s, _)| seen[s] = true);
        seen.iter().filter(|&&b| b).count() as f64 / self.n_source.max(1) as f64
    }

    /// Fraction of target faces in at least one pair.
    pub fn target_coverage(&self) -> f64 {
        let mut seen = vec![false; self.n_target];
        self.pairs.iter().for_each(|&(_, t)| seen[t] = true);
        seen.iter().filter(|&&b| b).count() as f64 / self.n_target.max(1) as f64
    }
}

/// Options of [`DeformationTransfer`].
#[derive(Clone, Debug, PartialEq)]
pub struct SumnerTransferOptions {
    /// Target vertices pinned (hard); components without one get their
    /// lowest-index vertex pinned automatically.
    pub anchors: Vec<usize>,
    /// Target vertices softly constrained to given positions.
    pub soft: Vec<usize>,
    /// Weight of a soft constraint relative to the mean diagonal of the
    /// normal matrix.
    pub soft_weight: f64,
}

impl Default for SumnerTransferOptions {
    fn default() -> Self {
        SumnerTransferOptions {
            anchors: Vec::new(),
            soft: Vec::new(),
            soft_weight: 1.0,
        }
    }
}

/// Where the target gradient of one target face comes from.
#[derive(Clone, Debug)]
enum FaceSource {
    /// Mean of these source faces' gradients (weight = count, or 1 when
    /// borrowed from the nearest matched face).
    Sources { faces: Vec<usize>, weight: f64 },
    /// `S = I`, weight 1 (component without any match).
    Identity,
    /// Degenerate target face: no term.
    Skip,
}

/// Precomputed per-face data of the target.
#[derive(Clone, Debug)]
struct TargetFace {
    verts: [usize; 3],
    /// Hat-function gradients of the three corners (reference triangle).
    grads: [Vec3; 3],
    /// Projector onto the reference tangent plane.
    proj: Mat3,
}

/// Counts of what [`DeformationTransfer::new`] skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Skipped {
    /// Degenerate source reference faces.
    pub source_faces: usize,
    /// Degenerate target reference faces.
    pub target_faces: usize,
    /// Pairs dropped because one of their faces is degenerate.
    pub pairs: usize,
    /// Target faces with no pair that borrowed a neighbour's gradient.
    pub filled: usize,
    /// Target faces set to `S = I` (component without any match).
    pub identity: usize,
}

/// The factorised transfer of one (source reference, target reference,
/// triangle correspondence): apply it to any number of source poses.
#[derive(Debug)]
pub struct DeformationTransfer {
    source_reference: Mesh,
    source_inv: Vec<Option<Mat3>>,
    target_reference: Mesh,
    target_faces: Vec<Option<TargetFace>>,
    face_source: Vec<FaceSource>,
    /// Free index of every target vertex (`None` = pinned).
    free: Vec<Option<usize>>,
    /// Pinned vertices: user anchors first (in the given order), then the
    /// automatic ones.
    pinned: Vec<usize>,
    n_user_anchors: usize,
    soft: Vec<usize>,
    soft_weight: f64,
    chol: SparseCholesky,
    skipped: Skipped,
    factor_seconds: f64,
}

impl DeformationTransfer {
    /// Precomputes and factorises the transfer from `source_reference` to
    /// `target_reference` through `correspondence`.
    pub fn new(
        source_reference: &Mesh,
        target_reference: &Mesh,
        correspondence: &TriangleCorrespondence,
        opts: &SumnerTransferOptions,
    ) -> Result<Self> {
        let t0 = Instant::now();
        let (ns, nt) = (source_reference.n_faces(), target_reference.n_faces());
        if correspondence.n_source() != ns || correspondence.n_target() != nt {
            return Err(Error::invalid(format!(
                "triangle correspondence is for {} source and {} target faces, the meshes \
                 have {ns} and {nt}",
                correspondence.n_source(),
                correspondence.n_target()
            )));
        }
        let n = target_reference.n_vertices();
        for (what, list) in [("anchor", &opts.anchors), ("soft constraint", &opts.soft)] {
            if let Some(&bad) = list.iter().find(|&&i| i >= n) {
                return Err(Error::invalid(format!(
                    "{what} vertex {bad} out of range (target has {n} vertices)"
                )));
            }
        }
        if !(opts.soft_weight.is_finite() && opts.soft_weight >= 0.0) {
            return Err(Error::invalid(format!(
                "soft_weight = {} must be finite and ≥ 0",
                opts.soft_weight
            )));
        }
        let source_inv = inverse_frames(source_reference);
        let target_inv = inverse_frames(target_reference);
        let mut skipped = Skipped {
            source_faces: source_inv.iter().filter(|x| x.is_none()).count(),
            target_faces: target_inv.iter().filter(|x| x.is_none()).count(),
            ..Skipped::default()
        };
        let tv = target_reference.vertices();
        let target_faces: Vec<Option<TargetFace>> = target_reference
            .faces()
            .iter()
            .zip(&target_inv)
            .map(|(f, inv)| {
                inv.map(|w| {
                    let w1: Vec3 = w.row(0).transpose();
                    let w2: Vec3 = w.row(1).transpose();
                    let nrm = (tv[f[1]] - tv[f[0]])
                        .cross(&(tv[f[2]] - tv[f[0]]))
                        .normalize();
                    TargetFace {
                        verts: *f,
                        grads: [-w1 - w2, w1, w2],
                        proj: Mat3::identity() - nrm * nrm.transpose(),
                    }
                })
            })
            .collect();
        // Sources of every target face.
        let mut sources: Vec<Vec<usize>> = vec![Vec::new(); nt];
        for &(s, t) in correspondence.pairs() {
            if source_inv[s].is_none() || target_faces[t].is_none() {
                skipped.pairs += 1;
            } else {
                sources[t].push(s);
            }
        }
        let valid: Vec<bool> = target_faces.iter().map(Option::is_some).collect();
        let face_source = fill_unmatched(&sources, &valid, target_reference.faces(), &mut skipped);
        // Pins.
        let comp = vertex_components(n, target_reference.faces(), &valid);
        let mut pinned: Vec<usize> = Vec::new();
        let mut is_pinned = vec![false; n];
        let mut comp_has_pin: HashSet<usize> = HashSet::new();
        for &a in &opts.anchors {
            if !is_pinned[a] {
                is_pinned[a] = true;
                pinned.push(a);
            }
            comp_has_pin.insert(comp[a]);
        }
        let n_user_anchors = pinned.len();
        for i in 0..n {
            if comp_has_pin.insert(comp[i]) {
                is_pinned[i] = true;
                pinned.push(i);
            }
        }
        let mut free = vec![None; n];
        let mut nf = 0;
        for i in 0..n {
            if !is_pinned[i] {
                free[i] = Some(nf);
                nf += 1;
            }
        }
        let mut dt = DeformationTransfer {
            source_reference: source_reference.clone(),
            source_inv,
            target_reference: target_reference.clone(),
            target_faces,
            face_source,
            free,
            pinned,
            n_user_anchors,
            soft: opts.soft.clone(),
            soft_weight: 0.0,
            chol: SparseCholesky::new(&sparse_from_triplets(1, 1, [(0, 0, 1.0)]))?,
            skipped,
            factor_seconds: 0.0,
        };
        if nf == 0 {
            dt.factor_seconds = t0.elapsed().as_secs_f64();
            return Ok(dt);
        }
        // Normal matrix over the free vertices.
        let mut trip: Vec<(usize, usize, f64)> = Vec::new();
        let mut diag_sum = vec![0.0; nf];
        for (tf, fs) in dt.target_faces.iter().zip(&dt.face_source) {
            let (Some(tf), Some(w)) = (tf, fs.weight()) else {
                continue;
            };
            for a in 0..3 {
                let Some(ia) = dt.free[tf.verts[a]] else {
                    continue;
                };
                for b in 0..3 {
                    if let Some(ib) = dt.free[tf.verts[b]] {
                        let v = w * tf.grads[a].dot(&tf.grads[b]);
                        trip.push((ia, ib, v));
                        if ia == ib {
                            diag_sum[ia] += v;
                        }
                    }
                }
            }
        }
        let mean_diag = diag_sum.iter().sum::<f64>() / nf as f64;
        dt.soft_weight = opts.soft_weight * mean_diag;
        for &s in &dt.soft {
            if let Some(i) = dt.free[s] {
                trip.push((i, i, dt.soft_weight));
            }
        }
        let m = sparse_from_triplets(nf, nf, trip);
        dt.chol = SparseCholesky::new(&m).map_err(|e| {
            Error::numerical(format!(
                "deformation transfer normal matrix ({nf} free vertices): {e}"
            ))
        })?;
        dt.factor_seconds = t0.elapsed().as_secs_f64();
        Ok(dt)
    }

    /// What was skipped or filled in (see the module documentation).
    pub fn skipped(&self) -> Skipped {
        self.skipped
    }

    /// Seconds spent in [`DeformationTransfer::new`] (assembly and
    /// factorisation).
    pub fn factor_seconds(&self) -> f64 {
        self.factor_seconds
    }

    /// All pinned target vertices: the user anchors (deduplicated, in the
    /// given order), then one automatic pin per unanchored component.
    pub fn pinned(&self) -> &[usize] {
        &self.pinned
    }

    /// The target reference mesh.
    pub fn target_reference(&self) -> &Mesh {
        &self.target_reference
    }

    /// Transfers `source_pose` (same connectivity as the source reference)
    /// with every pin at its target reference position and soft constraints
    /// at their reference positions.
    pub fn transfer(&self, source_pose: &Mesh) -> Result<Mesh> {
        let tv = self.target_reference.vertices();
        let anchors: Vec<Point> = self.pinned[..self.n_user_anchors]
            .iter()
            .map(|&i| tv[i])
            .collect();
        let soft: Vec<Point> = self.soft.iter().map(|&i| tv[i]).collect();
        self.transfer_with(source_pose, &anchors, &soft)
    }

    /// Transfers `source_pose` with the user anchors at `anchor_positions`
    /// (one per distinct anchor, in order) and the soft vertices pulled to
    /// `soft_positions`; automatic pins stay at their reference positions.
    pub fn transfer_with(
        &self,
        source_pose: &Mesh,
        anchor_positions: &[Point],
        soft_positions: &[Point],
    ) -> Result<Mesh> {
        check_same_connectivity(&self.source_reference, source_pose, "source pose")?;
        if anchor_positions.len() != self.n_user_anchors {
            return Err(Error::invalid(format!(
                "{} anchor positions given for {} anchors",
                anchor_positions.len(),
                self.n_user_anchors
            )));
        }
        if soft_positions.len() != self.soft.len() {
            return Err(Error::invalid(format!(
                "{} soft positions given for {} soft constraints",
                soft_positions.len(),
                self.soft.len()
            )));
        }
        let tv = self.target_reference.vertices();
        let n = tv.len();
        let mut x: Vec<Point> = tv.to_vec();
        for (k, &i) in self.pinned.iter().enumerate() {
            if k < self.n_user_anchors {
                x[i] = anchor_positions[k];
            }
        }
        let grads = gradients_where(&self.source_inv, source_pose);
        let nf = n - self.pinned.len();
        if nf == 0 {
            return self.target_reference.with_vertices(x);
        }
        let mut rhs = DMatrix::<f64>::zeros(nf, 3);
        for (tf, fs) in self.target_faces.iter().zip(&self.face_source) {
            let (Some(tf), Some(w)) = (tf, fs.weight()) else {
                continue;
            };
            let s = match fs {
                FaceSource::Sources { faces, .. } => {
                    let mut acc = Mat3::zeros();
                    for &f in faces {
                        // Pairs with degenerate faces were dropped in `new`.
                        acc += grads[f].unwrap_or_else(Mat3::identity);
                    }
                    acc / faces.len() as f64
                }
                _ => Mat3::identity(),
            };
            // Rows of the desired gradient, minus the pinned corners.
            let g = s * tf.proj;
            for k in 0..3 {
                let mut d: Vec3 = g.row(k).transpose();
                for b in 0..3 {
                    let vb = tf.verts[b];
                    if self.free[vb].is_none() {
                        d -= tf.grads[b] * x[vb][k];
                    }
                }
                for a in 0..3 {
                    if let Some(ia) = self.free[tf.verts[a]] {
                        rhs[(ia, k)] += w * tf.grads[a].dot(&d);
                    }
                }
            }
        }
        for (&s, p) in self.soft.iter().zip(soft_positions) {
            if let Some(i) = self.free[s] {
                for k in 0..3 {
                    rhs[(i, k)] += self.soft_weight * p[k];
                }
            }
        }
        let sol = self.chol.try_solve(&rhs)?;
        for (xi, fi) in x.iter_mut().zip(&self.free) {
            if let Some(fi) = *fi {
                *xi = Point::new(sol[(fi, 0)], sol[(fi, 1)], sol[(fi, 2)]);
            }
        }
        self.target_reference
            .with_vertices(x)
            .map_err(|e| Error::numerical(format!("deformation transfer produced a bad mesh: {e}")))
    }
}

impl FaceSource {
    fn weight(&self) -> Option<f64> {
        match self {
            FaceSource::Sources { weight, .. } => Some(*weight),
            FaceSource::Identity => Some(1.0),
            FaceSource::Skip => None,
        }
    }
}

/// Target faces with sources keep them (weight = count); unmatched valid
/// faces borrow the sources of the nearest matched face (BFS over edge
/// adjacency, weight 1); components without matches get `S = I`.
fn fill_unmatched(
    sources: &[Vec<usize>],
    valid: &[bool],
    faces: &[Face],
    skipped: &mut Skipped,
) -> Vec<FaceSource> {
    let nt = sources.len();
    let adj = face_adjacency(faces, valid);
    let mut owner: Vec<Option<usize>> = (0..nt)
        .map(|t| (valid[t] && !sources[t].is_empty()).then_some(t))
        .collect();
    let mut queue: VecDeque<usize> = (0..nt).filter(|&t| owner[t].is_some()).collect();
    while let Some(t) = queue.pop_front() {
        for &u in &adj[t] {
            if owner[u].is_none() {
                owner[u] = owner[t];
                queue.push_back(u);
            }
        }
    }
    (0..nt)
        .map(|t| {
            if !valid[t] {
                FaceSource::Skip
            } else if !sources[t].is_empty() {
                FaceSource::Sources {
                    faces: sources[t].clone(),
                    weight: sources[t].len() as f64,
                }
            } else if let Some(o) = owner[t] {
                skipped.filled += 1;
                FaceSource::Sources {
                    faces: sources[o].clone(),
                    weight: 1.0,
                }
            } else {
                skipped.identity += 1;
                FaceSource::Identity
            }
        })
        .collect()
}

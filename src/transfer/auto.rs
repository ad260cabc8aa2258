//! Automatic target correspondence for deformation transfer (issue 8): the
//! target key points `b_k` that BDT asks the user to click are found by
//! registering the source reference `A` onto the target reference `B`.
//! `A` and `B` may have different connectivity. No I/O.
//!
//! 1. **Coarse alignment** ([`coarse_align`]). Both shapes are centred
//!    (Voronoi-area-weighted centroid) and `A` is scaled by
//!    `√(area(B)/area(A))`. Candidate rotations are `R = E_B P E_Aᵀ` with
//!    `E_·` the principal axes (area-weighted covariance) and `P` every
//!    signed permutation matrix for which `det R = +1` (24 candidates: the
//!    sign flips of the axes, and their permutations in case two principal
//!    extents are close, which happens between poses). Reflections are
//!    never tried: a mirrored registration swaps left and right, which no
//!    distance can detect on a bilaterally symmetric shape. Each candidate
//!    is refined by a few iterations of symmetric rigid ICP (closest-point
//!    pairs in both directions, Kabsch) and scored by the symmetric mean
//!    closest-point distance; the best one is refined further. With
//!    landmarks ([`AutoOptions::landmarks`]) the score adds their mean
//!    distance, and three or more landmarks add one candidate: the rigid
//!    fit of the landmark pairs.
//! 2. **Nonrigid registration** ([`auto_correspondence`]). The aligned `A`
//!    is the only example of an FBT model ([`crate::register`]): LBO
//!    weighting functions of `A` (no examples of `B`'s class are needed),
//!    rotation clusters from k-means on the weights, ARAP against `A`
//!    itself, global scale α estimated. Nonrigid ICP then alternates
//!    closest-point pairs and E_mn solves warm-started from the previous
//!    transformations. Unlike [`crate::register::nicp`] (template → target
//!    pairs only, for partial targets) the pairs go both ways — every
//!    sampled template vertex to its closest compatible target vertex and
//!    every sampled target vertex to its closest compatible deformed
//!    template vertex — because `B` is complete and a one-way ICP leaves a
//!    limb of `B` that no template vertex reaches unmatched. Pairs farther
//!    than `max_distance · √area(B)` or with normals more than
//!    `max_normal_angle_deg` apart are rejected; the stages anneal from far
//!    and soft to near and stiff ([`IcpStage`]). Optional landmarks (pairs
//!    `(a, b)`) add one constraint row each.
//! 3. **Key point mapping.** Each key point `a_k` of the registered `A` is
//!    projected to the closest point of `B`'s surface (exact point–triangle
//!    distance over the faces around the nearest vertices) and snapped to
//!    the nearest corner of that triangle. Two key points that land on one
//!    vertex would make BDT's handles coincide; the later one then takes
//!    the nearest unused vertex.
//!
//! Normals: if `A` and `B` have opposite orientation (signed volumes of
//! opposite sign) `B`'s normals are flipped for the compatibility test.
//!
//! **Frames.** BDT's `Direct` frame applies the transforms fitted on `A`
//! to `B` as they are, which is right when both live in one frame (FAUST
//! registrations, the synthetic set). When the coarse alignment had to
//! rotate `A` by more than [`FRAME_ROTATION_DEG`], scale it by more than
//! 1.5× (or less than 1/1.5) or move its centroid by more than 0.5 √area(B)
//! ([`AutoCorrespondence::frames_differ`]) they do not, and
//! [`AutoCorrespondence::target_frame_transforms`] re-expresses each
//! transform in `B`'s frame, `T′ = M T M⁻¹` with `M` the coarse similarity
//! ([`conjugate`]); the source reference goes with them
//! ([`AutoCorrespondence::source_in_target_frame`], for the key point
//! positions of the handle-relative frame).
//!
//! [`perturb_keypoints`] is the noise model of the robustness experiment: a
//! seeded random vertex within a geodesic (edge-path) radius.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, SymmetricEigen};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::eval::procrustes;
use crate::mesh::Mesh;
use crate::ops::closest_point_on_triangle;
use crate::ops::geodesic::EdgeGraph;
use crate::ops::Operators;
use crate::ops::{farthest_point_sampling, vertex_normals, FpsMetric, MassKind};
use crate::register::model::FbtModel;
use crate::register::nicp::minimal_step;
use crate::register::setup::{build, ClusterSource, DictionaryExamples, FbtConfig, StageConfig};
use crate::register::solver::{ConstraintRows, FbtParams};
use crate::register::spatial::PointIndex;
use crate::skin::Affine;
use crate::solve::EigenOptions;
use crate::{Error, Mat3, Point, Result, Vec3};

/// Coarse rotations above this angle (degrees) mean that `A` and `B` are
/// not in one frame ([`AutoCorrespondence::target_frame_transforms`]).
pub const FRAME_ROTATION_DEG: f64 = 30.0;

/// One annealing stage of the nonrigid ICP.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcpStage {
    /// ICP iterations of the stage.
    pub iterations: usize,
    /// Rejection distance in √area(B) units.
    pub max_distance: f64,
    /// Total weight of the correspondence rows (in units of one constraint
    /// row of weight 1, shared by all accepted pairs).
    pub correspondence_weight: f64,
}

/// Options of [`auto_correspondence`].
#[derive(Clone, Debug)]
pub struct AutoOptions {
    /// Points sampled (FPS, each mesh) for the coarse alignment.
    pub coarse_samples: usize,
    /// Rigid ICP iterations per coarse candidate.
    pub candidate_iterations: usize,
    /// Rigid ICP iterations of the chosen candidate.
    pub rigid_iterations: usize,
    /// LBO eigenfunctions of the registration dictionary.
    pub lbo: usize,
    /// Rotation clusters of the ARAP energy.
    pub clusters: usize,
    /// FBT energy weights (β_lc, β_sm, scale).
    pub params: FbtParams,
    /// Annealing schedule of the nonrigid ICP (empty: coarse alignment only).
    pub stages: Vec<IcpStage>,
    /// Sampled vertices per direction per ICP iteration.
    pub samples: usize,
    /// Largest angle between the normals of a pair (degrees).
    pub max_normal_angle_deg: f64,
    /// Nearest vertices examined per sample for a compatible normal.
    pub neighbours: usize,
    /// E_mn iterations per ICP iteration.
    pub inner_iterations: usize,
    /// Optional landmark pairs `(vertex of A, vertex of B)`.
    pub landmarks: Vec<(usize, usize)>,
    /// Weight of each landmark row.
    pub landmark_weight: f64,
    /// Seed of FPS and k-means.
    pub seed: u64,
    /// Eigensolver of the LBO basis.
    pub eigen: EigenOptions,
}

impl Default for AutoOptions {
    fn default() -> Self {
        AutoOptions {
            coarse_samples: 600,
            candidate_iterations: 8,
            rigid_iterations: 30,
            lbo: 20,
            clusters: 30,
            params: FbtParams::default(),
            stages: vec![
                IcpStage {
                    iterations: 6,
                    max_distance: 0.3,
                    correspondence_weight: 1.0,
                },
                IcpStage {
                    iterations: 6,
                    max_distance: 0.15,
                    correspondence_weight: 4.0,
                },
                IcpStage {
                    iterations: 6,
                    max_distance: 0.08,
                    correspondence_weight: 16.0,
                },
            ],
            samples: 800,
            max_normal_angle_deg: 60.0,
            neighbours: 8,
            inner_iterations: 3,
            landmarks: Vec::new(),
            landmark_weight: 1.0,
            seed: 0,
            eigen: EigenOptions::default(),
        }
    }
}

/// A similarity `x ↦ s R x + t` (R a rotation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimilarityMotion {
    pub scale: f64,
    pub rotation: Mat3,
    pub translation: Vec3,
}

impl SimilarityMotion {
    /// Applies the motion to a point.
    pub fn apply(&self, p: &Point) -> Point {
        Point::from(self.scale * (self.rotation * p.coords) + self.translation)
    }

    /// Rotation angle of the motion (degrees).
    pub fn angle_deg(&self) -> f64 {
        ((self.rotation.trace() - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    }

    /// The inverse motion applied to a point.
    pub fn invert(&self, p: &Point) -> Point {
        Point::from(self.rotation.transpose() * (p.coords - self.translation) / self.scale)
    }
}

/// Result of [`coarse_align`].
#[derive(Clone, Debug)]
pub struct CoarseAlignment {
    /// Maps `A` into `B`'s frame.
    pub motion: SimilarityMotion,
    /// Symmetric mean closest-point distance after the alignment, in
    /// √area(B) units.
    pub residual: f64,
    /// Score of every candidate (same units, plus the mean landmark
    /// distance when landmarks are given), in enumeration order: the 24
    /// principal-axes rotations, then the landmark fit (≥ 3 landmarks).
    pub candidate_scores: Vec<f64>,
    /// Index of the chosen candidate.
    pub chosen: usize,
    /// Area-weighted centroid of `A` (A's frame).
    pub source_centroid: Point,
    /// √area(B).
    pub target_sqrt_area: f64,
}

/// Result of [`auto_correspondence`].
#[derive(Clone, Debug)]
pub struct AutoCorrespondence {
    /// Target vertex of each source key point (same order).
    pub target_keypoints: Vec<usize>,
    /// The closest surface points of `B` before snapping.
    pub surface_points: Vec<Point>,
    /// `A` registered onto `B` (A's connectivity, B's frame).
    pub registered: Mesh,
    /// The coarse alignment.
    pub coarse: CoarseAlignment,
    /// Symmetric mean closest-point distance (vertex to nearest vertex,
    /// both ways) between the registered `A` and `B`, in √area(B) units.
    pub residual: f64,
    /// Mean distance of the accepted pairs per ICP iteration (√area(B)).
    pub residual_trace: Vec<f64>,
    /// Global scale α of the final solve.
    pub alpha: f64,
    pub seconds_coarse: f64,
    pub seconds_registration: f64,
    pub seconds: f64,
}

/// `M T M⁻¹` for an affine `T = [L | t]` and a similarity `M = [sR | m]`:
/// `L′ = R L Rᵀ`, `t′ = sR t + m − L′ m`.
pub fn conjugate(t: &Affine, m: &SimilarityMotion) -> Affine {
    let l = t.fixed_view::<3, 3>(0, 0).into_owned();
    let tr = t.column(3).into_owned();
    let l2 = m.rotation * l * m.rotation.transpose();
    let t2 = m.scale * (m.rotation * tr) + m.translation - l2 * m.translation;
    let mut out = Affine::zeros();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&l2);
    out.column_mut(3).copy_from(&t2);
    out
}

impl AutoCorrespondence {
    /// Whether `A` and `B` are in different frames: the coarse alignment
    /// rotated `A` by more than [`FRAME_ROTATION_DEG`], scaled it by more
    /// than 1.5× either way or moved its centroid by more than 0.5 √area(B).
    pub fn frames_differ(&self) -> bool {
        let c = &self.coarse;
        let shift = (c.motion.apply(&c.source_centroid) - c.source_centroid).norm();
        c.motion.angle_deg() > FRAME_ROTATION_DEG
            || c.motion.scale.ln().abs() > 1.5f64.ln()
            || shift > 0.5 * c.target_sqrt_area
    }

    /// The source reference `a` in `B`'s frame (the coarse similarity
    /// applied) when the frames differ, else `a` itself: the source mesh to
    /// pass to [`crate::transfer::transfer`] with
    /// [`Self::target_frame_transforms`].
    pub fn source_in_target_frame(&self, a: &Mesh) -> Result<Mesh> {
        if self.frames_differ() {
            a.map_vertices(|p| self.coarse.motion.apply(p))
        } else {
            Ok(a.clone())
        }
    }

    /// The per-pose, per-key-point transforms fitted on `A`, re-expressed in
    /// `B`'s frame by the coarse similarity when the frames differ
    /// ([`Self::frames_differ`]); unchanged otherwise.
    pub fn target_frame_transforms(&self, transforms: &[Vec<Affine>]) -> Vec<Vec<Affine>> {
        if !self.frames_differ() {
            return transforms.to_vec();
        }
        transforms
            .iter()
            .map(|ts| {
                ts.iter()
                    .map(|t| conjugate(t, &self.coarse.motion))
                    .collect()
            })
            .collect()
    }
}

/// Voronoi-area-weighted centroid, covariance and total area.
fn moments(mesh: &Mesh) -> Result<(Point, Mat3, f64)> {
    let m = mesh.mass(MassKind::Voronoi);
    let area: f64 = m.iter().sum();
    if !(area.is_finite() && area > 0.0) {
        return Err(Error::invalid(format!(
            "mesh of {} vertices has no positive area",
            mesh.n_vertices()
        )));
    }
    let v = mesh.vertices();
    let c = v
        .iter()
        .zip(m.iter())
        .fold(Vec3::zeros(), |s, (p, w)| s + p.coords * *w)
        / area;
    let mut cov = Mat3::zeros();
    for (p, w) in v.iter().zip(m.iter()) {
        let d = p.coords - c;
        cov += d * d.transpose() * (*w / area);
    }
    Ok((Point::from(c), cov, area))
}

/// Principal axes as columns, by decreasing extent.
fn principal_axes(cov: &Mat3) -> Mat3 {
    let e = SymmetricEigen::new(*cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| e.eigenvalues[j].total_cmp(&e.eigenvalues[i]));
    Mat3::from_columns(&[
        e.eigenvectors.column(order[0]).into_owned(),
        e.eigenvectors.column(order[1]).into_owned(),
        e.eigenvectors.column(order[2]).into_owned(),
    ])
}

/// Signed permutation matrices (48).
fn signed_permutations() -> Vec<Mat3> {
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut out = Vec::new();
    for p in perms {
        for s in 0..8u32 {
            let mut m = Mat3::zeros();
            for (r, &c) in p.iter().enumerate() {
                m[(r, c)] = if s & (1 << r) != 0 { -1.0 } else { 1.0 };
            }
            out.push(m);
        }
    }
    out
}

/// Samples of a mesh for ICP: FPS (Euclidean) with `k` points, or all.
fn samples(mesh: &Mesh, k: usize, seed: u64) -> Result<Vec<usize>> {
    if k == 0 || k >= mesh.n_vertices() {
        Ok((0..mesh.n_vertices()).collect())
    } else {
        farthest_point_sampling(mesh, k, FpsMetric::Euclidean, seed)
    }
}

struct RigidProblem<'a> {
    a: &'a Mesh,
    b: &'a Mesh,
    tree_a: PointIndex,
    tree_b: PointIndex,
    sa: Vec<usize>,
    sb: Vec<usize>,
    sqrt_area_b: f64,
}

impl RigidProblem<'_> {
    /// Symmetric mean closest-point distance (√area(B) units) of `A` under
    /// `m` to `B`.
    fn score(&self, m: &SimilarityMotion) -> f64 {
        let (av, bv) = (self.a.vertices(), self.b.vertices());
        let mut s = 0.0;
        for &i in &self.sa {
            s += self.tree_b.nearest(&m.apply(&av[i])).1;
        }
        for &j in &self.sb {
            // Distance in A's frame, scaled back to B's.
            s += self.tree_a.nearest(&m.invert(&bv[j])).1 * m.scale;
        }
        s / (self.sa.len() + self.sb.len()) as f64 / self.sqrt_area_b
    }

    /// Symmetric rigid ICP (scale fixed).
    fn refine(&self, mut m: SimilarityMotion, iterations: usize) -> Result<SimilarityMotion> {
        let (av, bv) = (self.a.vertices(), self.b.vertices());
        for _ in 0..iterations {
            let mut moving = Vec::with_capacity(self.sa.len() + self.sb.len());
            let mut fixed = Vec::with_capacity(moving.capacity());
            for &i in &self.sa {
                let p = m.apply(&av[i]);
                let (j, _) = self.tree_b.nearest(&p);
                moving.push(p);
                fixed.push(bv[j]);
            }
            for &j in &self.sb {
                let (i, _) = self.tree_a.nearest(&m.invert(&bv[j]));
                moving.push(m.apply(&av[i]));
                fixed.push(bv[j]);
            }
            let r = procrustes(&moving, &fixed)?;
            m = SimilarityMotion {
                scale: m.scale,
                rotation: r.rotation * m.rotation,
                translation: r.rotation * m.translation + r.translation,
            };
        }
        Ok(m)
    }
}

/// Coarse similarity alignment of `a` onto `b` (see the module docs).
pub fn coarse_align(a: &Mesh, b: &Mesh, opts: &AutoOptions) -> Result<CoarseAlignment> {
    check_landmarks(a, b, &opts.landmarks)?;
    let (ca, cov_a, area_a) = moments(a)?;
    let (cb, cov_b, area_b) = moments(b)?;
    let scale = (area_b / area_a).sqrt();
    let (ea, eb) = (principal_axes(&cov_a), principal_axes(&cov_b));
    let prob = RigidProblem {
        a,
        b,
        tree_a: PointIndex::new(a.vertices())?,
        tree_b: PointIndex::new(b.vertices())?,
        sa: samples(a, opts.coarse_samples, opts.seed)?,
        sb: samples(b, opts.coarse_samples, opts.seed)?,
        sqrt_area_b: area_b.sqrt(),
    };
    // Landmarks (when given) join the score: mean landmark distance in
    // √area(B) units. Between very different shapes or poses the symmetric
    // distance alone can prefer a wrong rotation; a few landmarks rule such
    // candidates out.
    let (av, bv) = (a.vertices(), b.vertices());
    let landmark_distance = |m: &SimilarityMotion| -> f64 {
        if opts.landmarks.is_empty() {
            return 0.0;
        }
        opts.landmarks
            .iter()
            .map(|&(i, j)| (m.apply(&av[i]) - bv[j]).norm())
            .sum::<f64>()
            / opts.landmarks.len() as f64
            / prob.sqrt_area_b
    };
    let mut starts: Vec<SimilarityMotion> = signed_permutations()
        .into_iter()
        .map(|p| eb * p * ea.transpose())
        .filter(|r| r.determinant() > 0.0)
        .map(|rotation| SimilarityMotion {
            scale,
            rotation,
            translation: cb.coords - scale * (rotation * ca.coords),
        })
        .collect();
    // With three or more landmarks, one more candidate: the rotation and
    // translation that best fit the landmark pairs (scale from the areas).
    if opts.landmarks.len() >= 3 {
        let moving: Vec<Point> = opts
            .landmarks
            .iter()
            .map(|&(i, _)| Point::from(scale * av[i].coords))
            .collect();
        let fixed: Vec<Point> = opts.landmarks.iter().map(|&(_, j)| bv[j]).collect();
        let r = procrustes(&moving, &fixed)?;
        starts.push(SimilarityMotion {
            scale,
            rotation: r.rotation,
            translation: r.translation,
        });
    }
    let mut scores = Vec::new();
    let mut best: Option<(f64, usize, SimilarityMotion)> = None;
    for m in starts {
        let m = prob.refine(m, opts.candidate_iterations)?;
        let s = prob.score(&m) + landmark_distance(&m);
        scores.push(s);
        if best.as_ref().is_none_or(|b| s < b.0) {
            best = Some((s, scores.len() - 1, m));
        }
    }
    let (_, chosen, m) = best.ok_or_else(|| Error::numerical("no coarse alignment candidate"))?;
    let m = prob.refine(m, opts.rigid_iterations)?;
    let residual = prob.score(&m);
    if !residual.is_finite() {
        return Err(Error::numerical(
            "coarse alignment produced non-finite values",
        ));
    }
    Ok(CoarseAlignment {
        motion: m,
        residual,
        candidate_scores: scores,
        chosen,
        source_centroid: ca,
        target_sqrt_area: area_b.sqrt(),
    })
}

/// Six times the signed volume (orientation of a closed surface).
fn signed_volume(mesh: &Mesh) -> f64 {
    let v = mesh.vertices();
    mesh.faces()
        .iter()
        .map(|f| v[f[0]].coords.dot(&v[f[1]].coords.cross(&v[f[2]].coords)))
        .sum()
}

/// For each query point: the closest point on `mesh`'s surface (over the
/// faces around its `k` nearest vertices) and the triangle corner nearest
/// to it. Later queries that would reuse a vertex take the nearest unused
/// vertex instead (distinct results).
pub fn project_to_vertices(
    mesh: &Mesh,
    queries: &[Point],
    k: usize,
) -> Result<(Vec<usize>, Vec<Point>)> {
    if queries.len() > mesh.n_vertices() {
        return Err(Error::invalid(format!(
            "{} points cannot map to distinct vertices of a {}-vertex mesh",
            queries.len(),
            mesh.n_vertices()
        )));
    }
    let tree = PointIndex::new(mesh.vertices())?;
    let vf = mesh.incident_faces();
    let (v, f) = (mesh.vertices(), mesh.faces());
    let mut used: Vec<usize> = Vec::new();
    let mut surface = Vec::new();
    for q in queries {
        let hits = tree.nearest_n(q, k);
        let mut best: Option<(f64, Point, usize)> = None;
        for h in &hits {
            for &fi in vf.row(h.index) {
                let t = f[fi];
                let c = closest_point_on_triangle(q, &v[t[0]], &v[t[1]], &v[t[2]]);
                let d = (c - q).norm_squared();
                if best.as_ref().is_none_or(|b| d < b.0) {
                    best = Some((d, c, fi));
                }
            }
        }
        let (sp, mut cands): (Point, Vec<usize>) = match best {
            Some((_, c, fi)) => (c, f[fi].to_vec()),
            None => (*q, Vec::new()),
        };
        cands.sort_by(|&i, &j| {
            (v[i] - sp)
                .norm_squared()
                .total_cmp(&(v[j] - sp).norm_squared())
        });
        let pick = match cands.iter().find(|c| !used.contains(c)) {
            Some(&c) => c,
            None => {
                // All corners taken: the nearest unused vertex to the surface point.
                let mut n = (k.max(1) + used.len()).min(mesh.n_vertices());
                loop {
                    let hits = tree.nearest_n(&sp, n);
                    if let Some(h) = hits.iter().find(|h| !used.contains(&h.index)) {
                        break h.index;
                    }
                    if n >= mesh.n_vertices() {
                        return Err(Error::invalid("no unused vertex left for a key point"));
                    }
                    n = (2 * n).min(mesh.n_vertices());
                }
            }
        };
        used.push(pick);
        surface.push(sp);
    }
    Ok((used, surface))
}

/// Symmetric mean vertex-to-nearest-vertex distance between two point sets.
fn symmetric_distance(p: &[Point], q: &[Point]) -> Result<f64> {
    let tp = PointIndex::new(p)?;
    let tq = PointIndex::new(q)?;
    let s1: f64 = p.iter().map(|x| tq.nearest(x).1).sum();
    let s2: f64 = q.iter().map(|x| tp.nearest(x).1).sum();
    Ok((s1 + s2) / (p.len() + q.len()) as f64)
}

fn check_landmarks(a: &Mesh, b: &Mesh, landmarks: &[(usize, usize)]) -> Result<()> {
    match landmarks
        .iter()
        .find(|&&(i, j)| i >= a.n_vertices() || j >= b.n_vertices())
    {
        Some(&(i, j)) => Err(Error::invalid(format!(
            "landmark ({i}, {j}) out of range ({} / {} vertices)",
            a.n_vertices(),
            b.n_vertices()
        ))),
        None => Ok(()),
    }
}

fn check_options(a: &Mesh, b: &Mesh, keypoints: &[usize], opts: &AutoOptions) -> Result<()> {
    if a.n_vertices() < 4 || b.n_vertices() < 4 {
        return Err(Error::invalid(
            "automatic correspondence needs meshes with at least 4 vertices",
        ));
    }
    for &k in keypoints {
        if k >= a.n_vertices() {
            return Err(Error::invalid(format!(
                "key point {k} out of range (source has {} vertices)",
                a.n_vertices()
            )));
        }
    }
    check_landmarks(a, b, &opts.landmarks)?;
    if opts.lbo < 1 || opts.clusters < 1 {
        return Err(Error::invalid(
            "automatic correspondence needs lbo ≥ 1 and clusters ≥ 1",
        ));
    }
    for s in &opts.stages {
        if !(s.max_distance > 0.0 && s.correspondence_weight > 0.0) {
            return Err(Error::invalid(
                "ICP stages need max_distance > 0 and correspondence_weight > 0",
            ));
        }
    }
    if !(opts.landmark_weight >= 0.0 && opts.landmark_weight.is_finite()) {
        return Err(Error::invalid("landmark_weight must be finite and ≥ 0"));
    }
    Ok(())
}

/// Finds the vertices of `b` that correspond to the key points
/// `keypoints` of `a` (see the module documentation).
pub fn auto_correspondence(
    a: &Mesh,
    keypoints: &[usize],
    b: &Mesh,
    opts: &AutoOptions,
) -> Result<AutoCorrespondence> {
    let start = Instant::now();
    check_options(a, b, keypoints, opts)?;
    let coarse = coarse_align(a, b, opts)?;
    let seconds_coarse = start.elapsed().as_secs_f64();
    let t_reg = Instant::now();
    let aligned = a.map_vertices(|p| coarse.motion.apply(p))?;
    let sqrt_area_b = moments(b)?.2.sqrt();

    let (positions, alpha, trace) = if opts.stages.is_empty() {
        (aligned.vertices().to_vec(), 1.0, Vec::new())
    } else {
        register(&aligned, b, sqrt_area_b, opts)?
    };
    let registered = a.with_vertices(positions)?;
    let residual = symmetric_distance(registered.vertices(), b.vertices())? / sqrt_area_b;
    let queries: Vec<Point> = keypoints
        .iter()
        .map(|&k| registered.vertices()[k])
        .collect();
    let (target_keypoints, surface_points) = project_to_vertices(b, &queries, 8)?;
    Ok(AutoCorrespondence {
        target_keypoints,
        surface_points,
        registered,
        coarse,
        residual,
        residual_trace: trace,
        alpha,
        seconds_coarse,
        seconds_registration: t_reg.elapsed().as_secs_f64(),
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The nonrigid ICP of the aligned template onto `b`: positions, α and the
/// mean accepted pair distance per iteration (√area(B) units).
fn register(
    aligned: &Mesh,
    b: &Mesh,
    sqrt_area_b: f64,
    opts: &AutoOptions,
) -> Result<(Vec<Point>, f64, Vec<f64>)> {
    let n = aligned.n_vertices();
    let cfg = FbtConfig {
        init: None,
        main: StageConfig::lbo(opts.lbo.min(n - 1)),
        rich: None,
        arap_examples: DictionaryExamples::All,
        clusters: opts.clusters.min(n),
        cluster_source: ClusterSource::MainWeights,
        rig: Default::default(),
        seed: opts.seed,
        eigen: opts.eigen.clone(),
    };
    let setup = build(std::slice::from_ref(aligned), &cfg)?;
    let model: Arc<FbtModel> = setup.pipeline.main().clone();
    let mut t = model.dictionary().project(aligned.vertices())?;
    let mut alpha = 1.0;

    let bv = b.vertices();
    let tree_b = PointIndex::new(bv)?;
    let mut nb = vertex_normals(b);
    if signed_volume(aligned).signum() != signed_volume(b).signum() {
        nb.iter_mut().for_each(|x| *x = -*x);
    }
    let sa = samples(aligned, opts.samples, opts.seed)?;
    let sb = samples(b, opts.samples, opts.seed)?;
    let cos_max = opts.max_normal_angle_deg.to_radians().cos();
    let lw = opts.landmark_weight.sqrt();
    let mut trace = Vec::new();
    for stage in &opts.stages {
        let dmax = stage.max_distance * sqrt_area_b;
        for _ in 0..stage.iterations {
            let p = model.positions(&t)?;
            let deformed = aligned.with_vertices(p.clone())?;
            let np = vertex_normals(&deformed);
            let tree_p = PointIndex::new(&p)?;
            let mut pairs: Vec<(usize, Point, f64)> = Vec::new();
            for &i in &sa {
                let hits = tree_b.nearest_n(&p[i], opts.neighbours);
                if let Some(h) = hits.iter().find(|h| nb[h.index].dot(&np[i]) >= cos_max) {
                    let d = h.distance();
                    if d <= dmax {
                        pairs.push((i, bv[h.index], d));
                    }
                }
            }
            for &j in &sb {
                let q = bv[j];
                let hits = tree_p.nearest_n(&q, opts.neighbours);
                if let Some(h) = hits.iter().find(|h| np[h.index].dot(&nb[j]) >= cos_max) {
                    let d = h.distance();
                    if d <= dmax {
                        pairs.push((h.index, q, d));
                    }
                }
            }
            if pairs.is_empty() && opts.landmarks.is_empty() {
                return Err(Error::numerical(format!(
                    "nonrigid ICP found no compatible closest-point pair within {} √area \
                     (coarse alignment failed?)",
                    stage.max_distance
                )));
            }
            trace.push(
                pairs.iter().map(|x| x.2).sum::<f64>() / pairs.len().max(1) as f64 / sqrt_area_b,
            );
            let cw = (stage.correspondence_weight / pairs.len().max(1) as f64).sqrt();
            let mut rows: ConstraintRows = Vec::with_capacity(pairs.len() + opts.landmarks.len());
            let mut ys: Vec<[f64; 3]> = Vec::with_capacity(rows.capacity());
            for &(i, j) in &opts.landmarks {
                rows.push(vec![(i, lw)]);
                ys.push([bv[j].x * lw, bv[j].y * lw, bv[j].z * lw]);
            }
            for (i, q, _) in &pairs {
                rows.push(vec![(*i, cw)]);
                ys.push([q.x * cw, q.y * cw, q.z * cw]);
            }
            let y = DMatrix::from_fn(ys.len(), 3, |r, c| ys[r][c]);
            let sol = minimal_step(
                &model,
                &opts.params,
                rows,
                &y,
                &t,
                alpha,
                opts.inner_iterations,
            )?;
            t = sol.t().clone();
            alpha = sol.alpha();
        }
    }
    let p = model.positions(&t)?;
    if p.iter().any(|x| !x.coords.iter().all(|c| c.is_finite())) {
        return Err(Error::numerical("nonrigid registration diverged"));
    }
    Ok((p, alpha, trace))
}

/// Moves each vertex of `points` on `mesh` to a random vertex within
/// edge-path (Dijkstra) distance `radius` of it, drawn with `ChaCha8(seed)`,
/// distinct from the vertices already chosen (the point itself if no other
/// vertex qualifies). `radius = 0` returns `points`.
pub fn perturb_keypoints(
    mesh: &Mesh,
    points: &[usize],
    radius: f64,
    seed: u64,
) -> Result<Vec<usize>> {
    if !(radius.is_finite() && radius >= 0.0) {
        return Err(Error::invalid(format!(
            "noise radius must be finite and ≥ 0, got {radius}"
        )));
    }
    let n = mesh.n_vertices();
    if let Some(&p) = points.iter().find(|&&p| p >= n) {
        return Err(Error::invalid(format!(
            "key point {p} out of range ({n} vertices)"
        )));
    }
    if radius == 0.0 {
        return Ok(points.to_vec());
    }
    let graph = EdgeGraph::new(mesh);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut chosen: Vec<usize> = Vec::with_capacity(points.len());
    for &p in points {
        let d = graph.distances(&[p])?;
        let near: Vec<usize> = (0..n)
            .filter(|&i| d[i] <= radius && !chosen.contains(&i))
            .collect();
        let pick = if near.is_empty() {
            p
        } else {
            near[rng.random_range(0..near.len())]
        };
        chosen.push(pick);
    }
    Ok(chosen)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_regions() {
        let a = Point::new(0.0, 0.0, 0.0);
        let b = Point::new(1.0, 0.0, 0.0);
        let c = Point::new(0.0, 1.0, 0.0);
        let cp = |p: Point| closest_point_on_triangle(&p, &a, &b, &c);
        assert!((cp(Point::new(0.2, 0.2, 1.0)) - Point::new(0.2, 0.2, 0.0)).norm() < 1e-12);
        assert!((cp(Point::new(-1.0, -1.0, 0.0)) - a).norm() < 1e-12);
        assert!((cp(Point::new(2.0, -0.1, 0.0)) - b).norm() < 1e-12);
        assert!((cp(Point::new(0.5, -1.0, 0.3)) - Point::new(0.5, 0.0, 0.0)).norm() < 1e-12);
        assert!((cp(Point::new(1.0, 1.0, 0.0)) - Point::new(0.5, 0.5, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn conjugation_matches_a_change_of_frame() {
        let t = Affine::from_fn(|r, c| {
            0.1 * (r as f64 + 1.0) * (c as f64 - 1.5) + if r == c { 1.0 } else { 0.0 }
        });
        let rot = *nalgebra::Rotation3::from_axis_angle(&Vec3::y_axis(), 2.0).matrix();
        let m = SimilarityMotion {
            scale: 1.7,
            rotation: rot,
            translation: Vec3::new(0.3, -2.0, 1.0),
        };
        let c = conjugate(&t, &m);
        let apply = |a: &Affine, p: &Point| {
            Point::from(a.fixed_view::<3, 3>(0, 0) * p.coords + a.column(3))
        };
        let p = Point::new(0.2, 0.5, -1.3);
        // M T M⁻¹ p computed step by step.
        let direct = m.apply(&apply(&t, &m.invert(&p)));
        assert!((apply(&c, &p) - direct).norm() < 1e-12);
        assert!((m.angle_deg() - 2.0f64.to_degrees()).abs() < 1e-9);
    }

    #[test]
    fn signed_permutations_give_24_rotations() {
        let n = signed_permutations()
            .iter()
            .filter(|p| p.determinant() > 0.0)
            .count();
        assert_eq!(n, 24);
    }
}

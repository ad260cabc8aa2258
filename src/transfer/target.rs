//! Deformation transfer to a target mesh (BDT Sec. 3.6).
//!
//! Input: the source reference `A` with key points `a_k` (vertex indices
//! `source_keypoints`), the per-key-point affine transforms `T_k` fitted for
//! every deformed source `A′_j` (key point selection / fitting, in `A`'s own
//! coordinates), and the target reference `B` with the matched vertices
//! `b_k` (`target_keypoints[k]` corresponds to `source_keypoints[k]`).
//!
//! Output: one deformed target `B′_j` per deformed source:
//!
//! 1. **Weights.** Bounded biharmonic weights `W_B` (n_B × n_k) on `B` with
//!    the target key points as point handles (column `k` ↔ `b_k`), computed
//!    once for all `j` ([`TransferOptions::weights`]): the weights the
//!    transforms were fitted with on `A` in either selection mode. As an
//!    ablation ([`TargetWeights::Fast`]), the clamped, renormalised
//!    unbounded biharmonic weights that fast mode screens candidates with
//!    ([`crate::transfer::keypoints::GreenBasis`]).
//! 2. **Transforms on B** ([`TransferFrame`]):
//!    * [`TransferFrame::UnitSphere`] (default) — the paper's setting: the
//!      models "scaled consistently to fit into a unit sphere" (Sec. 3.5)
//!      and the `T_k` applied directly there (Sec. 3.6). A and B are each
//!      normalised (centroid, largest radius) and the result is mapped back
//!      into B's frame ([`FrameMap`]): `T_k^B = M⁻¹ T_k M`. By default B is
//!      not rotated ([`FrameAlign::None`], the paper), which makes B′
//!      equivariant under translations and uniform scalings of `B`, for
//!      any number of key points, but not under its rotations. As options,
//!      [`FrameAlign::Keypoints`] rotates B onto A by Kabsch on the key
//!      point pairs (≥ 3, not collinear) and [`FrameAlign::Dense`] on every
//!      vertex pair (shared connectivity); both make B′ equivariant under
//!      rotations of B too.
//!    * [`TransferFrame::Raw`] (ablation) — `T_k` applied as is in B's own
//!      coordinates. Right only when `A` and `B` already share a frame;
//!      FAUST subjects stand 0.35–0.38 apart, and a raw transfer across
//!      them stretches limbs.
//!    * [`TransferFrame::HandleRelative`] — `T_k^B = [L_k | t′_k]` with the
//!      linear part `L_k` of `T_k` and `t′_k` chosen so that the handle moves
//!      by the same displacement as on the source:
//!      `T_k^B b_k = b_k + (T_k a_k − a_k)`, i.e.
//!      `t′_k = b_k + T_k a_k − a_k − L_k b_k`. Invariant to a translation of
//!      `B` relative to `A` (B′ moves with B); equals `Direct` when
//!      `b_k = a_k`.
//! 3. **LBS** (BDT Eq. 2): `b′_i = Σ_k W_B,ik T_k^B [b_i; 1]`.
//! 4. **Optional ARAP refinement** ([`TransferOptions::refine`]). The
//!    transforms fitted on `A` carry `A`'s local shape in their linear parts;
//!    on a differently proportioned `B` the blend can shear. The refinement
//!    re-solves the transforms on `B` with the reduced ARAP solver of
//!    [`crate::arap`] in its handle-constrained (FAST) mode:
//!    `min_T λ E_arap(T) + μ Σ_k ‖q_{b_k} − x_k‖²` with the handle targets
//!    `x_k` = the LBS positions of step 3 at the target key points (for
//!    interpolating weights `x_k = T_k^B b_k`), rotation groups from k-means
//!    on `W_B` (n_k groups, [`TransferOptions::groups`],
//!    [`TransferOptions::seed`]), and local/global iterations initialised
//!    from `T^B` (so the first local step starts from the transferred
//!    rotations). Only the key point *positions* are kept from the transfer;
//!    the rest of `B′` follows `B`'s own rest shape as rigidly as possible.
//!    When [`TransferOptions::arap`]`.use_ediff` is `true` instead, the data
//!    term pulls every vertex towards its LBS position (E_diff with
//!    `q′ = ` LBS result): a milder, smoothing refinement.
//!
//!    Measured (tests/transfer_synthetic.rs, 1.7k vertices, 4 automatic key
//!    points, mean vertex error in B's unit sphere): LBS 0.0739,
//!    handle-constrained refinement 0.181 (worse: with so few handles the
//!    position constraints leave limb rotations about a single handle free,
//!    and ARAP towards B's T-pose undoes them), E_diff-to-LBS refinement
//!    0.0738. Refinement is therefore off by default.
//!
//! Errors (never panics): key point count mismatch between source, target
//! and transforms; out-of-range or duplicate key points; non-finite
//! transforms; and whatever the weight / ARAP solvers report.

use std::time::Instant;

use nalgebra::DMatrix;

use crate::arap::{ArapOptions, ReducedArap};
use crate::mesh::Mesh;
use crate::skin::bbw::{BbwOptions, Biharmonic};
use crate::skin::{rotation_groups, transforms_to_stacked, Affine, GroupFeatures, LbsMatrix};
use crate::transfer::keypoints::{FastBounds, GreenBasis};
use crate::{Error, Point, Result};

/// How the source transforms are placed on the target (see the module
/// documentation). Configs write `handle_relative`, the CLI `handle-relative`.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Deserialize,
    serde::Serialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
pub enum TransferFrame {
    /// A and B share one frame (BDT Sec. 3.5–3.6: models "scaled
    /// consistently to fit into a unit sphere"): each is normalised into the
    /// unit sphere (centroid, largest distance from it), the transforms act
    /// there and the result is mapped back into B's frame. B is not rotated
    /// unless the rotation step (`align`) asks for it. B′ follows
    /// translations and uniform scalings of B for any number of key points;
    /// rotations of B only with `align = keypoints` or `align = dense`
    #[default]
    UnitSphere,
    /// Ablation: `T_k` applied to `B` in B's own coordinates, as fitted in
    /// A's (right only when A and B already share a frame).
    #[serde(alias = "direct")]
    #[value(alias = "direct")]
    Raw,
    /// Same linear part, same handle displacement: `T_k^B b_k = b_k + T_k a_k − a_k`.
    HandleRelative,
}

impl TransferFrame {
    /// Name used on the command line and in logs.
    pub fn name(self) -> &'static str {
        match self {
            TransferFrame::UnitSphere => "unit-sphere",
            TransferFrame::Raw => "raw",
            TransferFrame::HandleRelative => "handle-relative",
        }
    }
}

/// Whether (and from what) the unit-sphere frame rotates B onto A before
/// the transforms act ([`TransferFrame::UnitSphere`] only). The paper only
/// scales A and B "consistently to fit into a unit sphere" (Sec. 3.5); a
/// rotation is this library's addition, off by default. Configs and Python
/// write `none`, `keypoints`, `dense`; so does the CLI (`--align`).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Deserialize,
    serde::Serialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
pub enum FrameAlign {
    /// No rotation (the paper): B is centred and scaled only, so B′ follows
    /// translations and uniform scalings of B but not its rotations.
    #[default]
    None,
    /// Rotation of B onto A by least squares (Kabsch) on the normalised key
    /// point pairs. Refused with fewer than 3 pairs or when the key points
    /// of A or B are nearly collinear (the rotation about their line is then
    /// undetermined). On differently proportioned bodies a handful of pairs
    /// can give a wrong rotation: on the FAUST benchmark
    /// (`experiments/real/bdt-faust.toml`, 3-6 key points) 0.7-12.7 degrees
    /// (median 3.4) where all vertices give 1.0-4.3; issue 37 measured
    /// 42-59 degrees with 3-4 key points on other FAUST cases.
    Keypoints,
    /// Rotation of B onto A by least squares on every vertex pair: needs a
    /// dense correspondence, i.e. A and B share connectivity (equal vertex
    /// counts and target key points equal to the source key points).
    Dense,
}

impl FrameAlign {
    /// Name used on the command line, in configs and logs.
    pub fn name(self) -> &'static str {
        match self {
            FrameAlign::None => "none",
            FrameAlign::Keypoints => "keypoints",
            FrameAlign::Dense => "dense",
        }
    }

    /// A rotation step exists only in the unit-sphere frame: any other
    /// `align` with another frame is an error (checked by
    /// [`transfer_detailed`] and, naming the key, by the configs).
    pub fn check_frame(self, frame: TransferFrame) -> Result<()> {
        if self != FrameAlign::None && frame != TransferFrame::UnitSphere {
            return Err(Error::invalid(format!(
                "align = {} rotates B in the unit-sphere frame; the {} frame has no such step \
                 (use frame = unit_sphere, or align = none)",
                self.name(),
                frame.name()
            )));
        }
        Ok(())
    }
}

/// Smallest ratio of the second to the first singular value of the centred
/// key points that [`FrameAlign::Keypoints`] accepts (below it the points
/// lie nearly on a line and the rotation about it is ill-determined).
pub const MIN_KEYPOINT_SPREAD: f64 = 0.05;

/// The similarity `y ↦ scale · R y + translation` that takes B into A's
/// frame for [`TransferFrame::UnitSphere`]: `N_A⁻¹ ∘ (rotation) ∘ N_B`, with
/// `N_X(x) = (x − c_X) / r_X` (`c_X` the vertex centroid, `r_X` the largest
/// distance of a vertex from it) and the rotation chosen by [`FrameAlign`]:
/// none (identity), the least-squares rigid motion (Kabsch) of the
/// normalised target key points onto the normalised source key points, or
/// of every normalised target vertex onto its source vertex. Transforms act
/// on B as `T_k^B = M⁻¹ ∘ T_k ∘ M`; since LBS weights sum to one, this is
/// the same as deforming `M(B)` with the `T_k` and mapping the result back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameMap {
    pub scale: f64,
    pub rotation: nalgebra::Matrix3<f64>,
    pub translation: nalgebra::Vector3<f64>,
}

/// Centroid and largest distance from it.
fn centre_radius(mesh: &Mesh) -> Result<(nalgebra::Vector3<f64>, f64)> {
    let v = mesh.vertices();
    let c = v
        .iter()
        .fold(nalgebra::Vector3::zeros(), |s, p| s + p.coords)
        / v.len().max(1) as f64;
    let r = v
        .iter()
        .map(|p| crate::mesh::stable_norm(&(p.coords - c)))
        .fold(0.0f64, f64::max);
    crate::mesh::check_extent(r)
        .map_err(|e| Error::invalid(format!("cannot normalise into the unit sphere: {e}")))?;
    if !(r > 0.0 && r.is_finite()) {
        return Err(Error::invalid(
            "cannot normalise into the unit sphere: the vertices coincide or are not finite",
        ));
    }
    Ok((c, r))
}

/// Second over first singular value of the centred points (0 for a single
/// point or coincident points).
fn spread_ratio(points: &[Point]) -> f64 {
    let n = points.len().max(1) as f64;
    let c = points
        .iter()
        .fold(nalgebra::Vector3::zeros(), |s, p| s + p.coords)
        / n;
    let mut cov = nalgebra::Matrix3::zeros();
    for p in points {
        let d = p.coords - c;
        cov += d * d.transpose();
    }
    // Singular values of the centred point matrix = square roots of the
    // covariance's eigenvalues.
    let mut ev: Vec<f64> = cov
        .symmetric_eigenvalues()
        .iter()
        .map(|x| x.max(0.0).sqrt())
        .collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    if ev[0] > 0.0 {
        ev[1] / ev[0]
    } else {
        0.0
    }
}

impl FrameMap {
    /// The map of B into A's frame (see the type documentation). Errors
    /// when `align` cannot be honoured (too few or collinear key point
    /// pairs for [`FrameAlign::Keypoints`]; no shared connectivity for
    /// [`FrameAlign::Dense`]).
    pub fn unit_sphere(
        source: &Mesh,
        source_keypoints: &[usize],
        target: &Mesh,
        target_keypoints: &[usize],
        align: FrameAlign,
    ) -> Result<FrameMap> {
        let (ca, ra) = centre_radius(source)?;
        let (cb, rb) = centre_radius(target)?;
        // The vertices `idx` of `m` in its unit-sphere frame.
        fn norm(
            m: &Mesh,
            idx: impl Iterator<Item = usize>,
            c: nalgebra::Vector3<f64>,
            r: f64,
        ) -> Vec<Point> {
            idx.map(|k| Point::from((m.vertices()[k].coords - c) / r))
                .collect()
        }
        let pairs = match align {
            FrameAlign::None => None,
            FrameAlign::Keypoints => {
                let k = source_keypoints.len();
                if k < 3 {
                    return Err(Error::invalid(format!(
                        "align = keypoints needs at least 3 key point pairs to determine a \
                         rotation, got {k}; use align = none (the default) or dense"
                    )));
                }
                let na = norm(source, source_keypoints.iter().copied(), ca, ra);
                let nb = norm(target, target_keypoints.iter().copied(), cb, rb);
                for (name, pts) in [("source", &na), ("target", &nb)] {
                    let q = spread_ratio(pts);
                    if q < MIN_KEYPOINT_SPREAD {
                        return Err(Error::invalid(format!(
                            "align = keypoints: the {k} {name} key points lie nearly on a line \
                             (spread ratio {q:.3} < {MIN_KEYPOINT_SPREAD}), so the rotation \
                             about it is undetermined; use align = none (the default) or dense"
                        )));
                    }
                }
                Some((nb, na))
            }
            FrameAlign::Dense => {
                if source.n_vertices() != target.n_vertices()
                    || source_keypoints != target_keypoints
                {
                    return Err(Error::invalid(format!(
                        "align = dense needs a dense correspondence: A and B sharing \
                         connectivity (the identity target correspondence), but A has {} \
                         vertices and B {}{}; use align = none (the default) or keypoints",
                        source.n_vertices(),
                        target.n_vertices(),
                        if source_keypoints != target_keypoints {
                            " and the target key points are not the source's"
                        } else {
                            ""
                        }
                    )));
                }
                let n = source.n_vertices();
                Some((norm(target, 0..n, cb, rb), norm(source, 0..n, ca, ra)))
            }
        };
        let (rotation, t) = match pairs {
            Some((nb, na)) => {
                let m = crate::eval::procrustes(&nb, &na)?;
                (m.rotation, m.translation)
            }
            None => (nalgebra::Matrix3::identity(), nalgebra::Vector3::zeros()),
        };
        let scale = ra / rb;
        Ok(FrameMap {
            scale,
            rotation,
            translation: ca + ra * t - scale * (rotation * cb),
        })
    }

    /// `M⁻¹ ∘ T ∘ M` for an affine `T = [L | u]`: linear part `Rᵀ L R`,
    /// translation `Rᵀ (L τ + u − τ) / s`.
    pub fn conjugate(&self, t: &Affine) -> Affine {
        let l = t.fixed_view::<3, 3>(0, 0).into_owned();
        let u = t.column(3).into_owned();
        let rt = self.rotation.transpose();
        let lin = rt * l * self.rotation;
        let shift = rt * (l * self.translation + u - self.translation) / self.scale;
        let mut out = *t;
        out.fixed_view_mut::<3, 3>(0, 0).copy_from(&lin);
        out.set_column(3, &shift);
        out
    }
}

/// Which skinning weights are computed on the target.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Default,
    serde::Deserialize,
    serde::Serialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
pub enum TargetWeights {
    /// The weights the transforms were fitted with on the source: bounded
    /// biharmonic weights in both selection modes ([`TargetWeights::resolve`]).
    #[default]
    #[value(
        help = "The weights the transforms were fitted with on the source: bounded biharmonic \
                weights in both selection modes"
    )]
    Auto,
    /// Bounded biharmonic weights with [`TransferOptions::weights`] (BDT Eq. 1).
    #[value(help = "Bounded biharmonic weights of the --weights problem (BDT Eq. 1)")]
    Bounded,
    /// Unbounded biharmonic weights made admissible by
    /// [`TransferOptions::fast_bounds`] (the weights of
    /// [`crate::transfer::SelectionMode::Fast`]).
    #[value(
        help = "Unbounded biharmonic weights made admissible (by default clamped to [0, 1] and \
                renormalised; the screening weights of fast selection)"
    )]
    Fast,
}

impl TargetWeights {
    /// `Auto` made concrete for transforms fitted in `mode`: bounded
    /// biharmonic weights in both modes, because both fit the key points'
    /// transforms on `A` with bounded weights
    /// ([`crate::transfer::keypoints::fit_keypoints`]; fast mode only
    /// screens candidates with the cheap weights), so `B` is skinned the way
    /// `A` was when the transforms were fitted.
    pub fn resolve(self, mode: crate::transfer::SelectionMode) -> TargetWeights {
        use crate::transfer::SelectionMode;
        match self {
            TargetWeights::Auto => match mode {
                SelectionMode::Exact | SelectionMode::Fast => TargetWeights::Bounded,
            },
            TargetWeights::Bounded => TargetWeights::Bounded,
            TargetWeights::Fast => TargetWeights::Fast,
        }
    }
}

/// Options of [`transfer`].
#[derive(Clone, Debug, PartialEq)]
pub struct TransferOptions {
    /// Where the transforms act on `B`.
    pub frame: TransferFrame,
    /// Rotation of B onto A in the unit-sphere frame (none by default);
    /// must be `None` for the other frames.
    pub align: FrameAlign,
    /// Bounded biharmonic weights on `B` (use the same options as the key
    /// point fitting on `A` so that `A → A` reproduces the fit exactly).
    pub weights: BbwOptions,
    /// Bounded (default) or fast-mode weights on `B`; `Auto` must be
    /// resolved first ([`TargetWeights::resolve`]).
    pub weight_kind: TargetWeights,
    /// Bounds of fast-mode weights on `B`.
    pub fast_bounds: FastBounds,
    /// Run the ARAP refinement on `B` after LBS.
    pub refine: bool,
    /// Refinement solver options. `use_ediff: false` (default): handle
    /// constraints at the transferred key point positions (`handles` is
    /// overwritten with the target key points' weight columns). `true`:
    /// E_diff towards the LBS result.
    pub arap: ArapOptions,
    /// Features of the refinement's rotation groups (clustered on `W_B`;
    /// rotation features use the LBS results as the deformed examples).
    pub groups: GroupFeatures,
    /// Number of rotation groups (`None`: the number of key points).
    pub n_groups: Option<usize>,
    /// Seed of the k-means of the rotation groups.
    pub seed: u64,
}

impl Default for TransferOptions {
    fn default() -> Self {
        TransferOptions {
            frame: TransferFrame::UnitSphere,
            align: FrameAlign::None,
            weights: BbwOptions::default(),
            weight_kind: TargetWeights::Bounded,
            fast_bounds: FastBounds::ClampNormalize,
            refine: false,
            arap: ArapOptions {
                use_ediff: false,
                ..ArapOptions::default()
            },
            groups: GroupFeatures::Weights,
            n_groups: None,
            seed: 0,
        }
    }
}

/// Everything [`transfer_detailed`] computes.
#[derive(Clone, Debug)]
pub struct TransferResult {
    /// One deformed target `B′_j` per deformed source (after refinement when
    /// it was asked for).
    pub meshes: Vec<Mesh>,
    /// The LBS results before refinement (equal to `meshes` without it).
    pub lbs: Vec<Mesh>,
    /// Transforms acting on `B` (`[deformed source][key point]`), before
    /// refinement.
    pub transforms: Vec<Vec<Affine>>,
    /// Refined transforms (empty without refinement).
    pub refined_transforms: Vec<Vec<Affine>>,
    /// `W_B` (n_B × n_k).
    pub weights: DMatrix<f64>,
    /// Rotation groups of the refinement (empty without refinement).
    pub groups: Vec<usize>,
    /// Wall-clock seconds: weights, LBS, refinement.
    pub seconds_weights: f64,
    pub seconds_lbs: f64,
    pub seconds_refine: f64,
}

/// Transfers every deformation (`transforms[j]`, one `Affine` per key point)
/// from `source` to `target`; one deformed target per entry of `transforms`.
/// See the module documentation for the method and the errors.
pub fn transfer(
    source: &Mesh,
    source_keypoints: &[usize],
    transforms: &[Vec<Affine>],
    target: &Mesh,
    target_keypoints: &[usize],
    opts: &TransferOptions,
) -> Result<Vec<Mesh>> {
    Ok(transfer_detailed(
        source,
        source_keypoints,
        transforms,
        target,
        target_keypoints,
        opts,
    )?
    .meshes)
}

/// [`transfer`] with intermediate results and timings.
pub fn transfer_detailed(
    source: &Mesh,
    source_keypoints: &[usize],
    transforms: &[Vec<Affine>],
    target: &Mesh,
    target_keypoints: &[usize],
    opts: &TransferOptions,
) -> Result<TransferResult> {
    check_inputs(
        source,
        source_keypoints,
        transforms,
        target,
        target_keypoints,
    )?;
    opts.align.check_frame(opts.frame)?;

    let t = Instant::now();
    let bih = Biharmonic::new(target)?;
    let weights = match opts.weight_kind {
        TargetWeights::Bounded => bih.weights(target_keypoints, &opts.weights)?,
        TargetWeights::Fast => {
            GreenBasis::new(&bih, target_keypoints)?.weights(target_keypoints, opts.fast_bounds)?
        }
        TargetWeights::Auto => {
            return Err(Error::invalid(
                "target weights `auto` follow the selection mode of the fit: resolve them \
                 with TargetWeights::resolve before the transfer",
            ))
        }
    };
    if weights.iter().any(|w| !w.is_finite()) {
        return Err(Error::numerical("target skinning weights are not finite"));
    }
    let seconds_weights = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let on_target: Vec<Vec<Affine>> = match opts.frame {
        TransferFrame::UnitSphere => {
            let m = FrameMap::unit_sphere(
                source,
                source_keypoints,
                target,
                target_keypoints,
                opts.align,
            )?;
            transforms
                .iter()
                .map(|tj| tj.iter().map(|t| m.conjugate(t)).collect())
                .collect()
        }
        TransferFrame::Raw => transforms.to_vec(),
        TransferFrame::HandleRelative => transforms
            .iter()
            .map(|tj| handle_relative_all(source, source_keypoints, tj, target, target_keypoints))
            .collect(),
    };
    let k = LbsMatrix::new(target.vertices(), &weights)?;
    let lbs = on_target
        .iter()
        .enumerate()
        .map(|(j, tj)| {
            let q = k.apply(tj)?;
            target
                .with_vertices(q)
                .map_err(|e| Error::numerical(format!("transferred mesh {j} is not valid: {e}")))
        })
        .collect::<Result<Vec<Mesh>>>()?;
    let seconds_lbs = t.elapsed().as_secs_f64();

    if !opts.refine {
        return Ok(TransferResult {
            meshes: lbs.clone(),
            lbs,
            transforms: on_target,
            refined_transforms: Vec::new(),
            weights,
            groups: Vec::new(),
            seconds_weights,
            seconds_lbs,
            seconds_refine: 0.0,
        });
    }

    let t = Instant::now();
    let groups = rotation_groups(
        target,
        &lbs,
        &weights,
        opts.groups,
        opts.n_groups,
        opts.seed,
    )?;
    let mut arap_opts = opts.arap.clone();
    if !arap_opts.use_ediff {
        arap_opts.handles = target_keypoints.to_vec();
    }
    let solver = ReducedArap::new(target, &weights, &groups, arap_opts)?;
    let mut meshes = Vec::with_capacity(lbs.len());
    let mut refined_transforms = Vec::with_capacity(lbs.len());
    for (j, (tj, bj)) in on_target.iter().zip(&lbs).enumerate() {
        let init = transforms_to_stacked(tj);
        let sol = solver.solve(bj.vertices(), Some(&init))?;
        let m = target.with_vertices(sol.positions).map_err(|e| {
            Error::numerical(format!("refined transferred mesh {j} is not valid: {e}"))
        })?;
        meshes.push(m);
        refined_transforms.push(sol.transforms);
    }
    Ok(TransferResult {
        meshes,
        lbs,
        transforms: on_target,
        refined_transforms,
        weights,
        groups,
        seconds_weights,
        seconds_lbs,
        seconds_refine: t.elapsed().as_secs_f64(),
    })
}

/// The transforms of one deformed source as they act on the target.
/// [`handle_relative`] for every key point.
fn handle_relative_all(
    source: &Mesh,
    source_keypoints: &[usize],
    transforms: &[Affine],
    target: &Mesh,
    target_keypoints: &[usize],
) -> Vec<Affine> {
    transforms
        .iter()
        .enumerate()
        .map(|(k, tk)| {
            let a = source.vertices()[source_keypoints[k]];
            let b = target.vertices()[target_keypoints[k]];
            handle_relative(tk, &a, &b)
        })
        .collect()
}

/// `[L | t′]` with `t′ = b + T a − a − L b`, so that `T^B b = b + (T a − a)`.
pub fn handle_relative(t: &Affine, a: &Point, b: &Point) -> Affine {
    let lin = t.fixed_view::<3, 3>(0, 0).into_owned();
    let moved = t * a.to_homogeneous();
    let shift = b.coords + (moved - a.coords) - lin * b.coords;
    let mut out = *t;
    out.set_column(3, &shift);
    out
}

fn check_keypoints(name: &str, keypoints: &[usize], n: usize) -> Result<()> {
    if keypoints.is_empty() {
        return Err(Error::invalid(format!("no {name} key points")));
    }
    let mut seen = std::collections::HashMap::with_capacity(keypoints.len());
    for (k, &v) in keypoints.iter().enumerate() {
        if v >= n {
            return Err(Error::invalid(format!(
                "{name} key point {k} is vertex {v}, but the {name} mesh has {n} vertices"
            )));
        }
        if let Some(first) = seen.insert(v, k) {
            return Err(Error::invalid(format!(
                "{name} key points {first} and {k} are the same vertex {v}"
            )));
        }
    }
    Ok(())
}

fn check_inputs(
    source: &Mesh,
    source_keypoints: &[usize],
    transforms: &[Vec<Affine>],
    target: &Mesh,
    target_keypoints: &[usize],
) -> Result<()> {
    if source_keypoints.len() != target_keypoints.len() {
        return Err(Error::invalid(format!(
            "{} source key points but {} target key points",
            source_keypoints.len(),
            target_keypoints.len()
        )));
    }
    check_keypoints("source", source_keypoints, source.n_vertices())?;
    check_keypoints("target", target_keypoints, target.n_vertices())?;
    if transforms.is_empty() {
        return Err(Error::invalid("no deformations to transfer"));
    }
    for (j, tj) in transforms.iter().enumerate() {
        if tj.len() != source_keypoints.len() {
            return Err(Error::invalid(format!(
                "deformation {j} has {} transforms for {} key points",
                tj.len(),
                source_keypoints.len()
            )));
        }
        if let Some(k) = tj.iter().position(|t| t.iter().any(|x| !x.is_finite())) {
            return Err(Error::invalid(format!(
                "deformation {j}: transform of key point {k} is not finite"
            )));
        }
    }
    Ok(())
}

/// Mean per-vertex Euclidean distance between two vertex lists of equal
/// length, after applying one similarity `norm` to both (pass the identity
/// similarity for raw units). Errors on mismatched or empty lists.
pub fn mean_vertex_error(
    a: &[Point],
    b: &[Point],
    norm: &crate::ops::normalize::Similarity,
) -> Result<f64> {
    if a.len() != b.len() || a.is_empty() {
        return Err(Error::invalid(format!(
            "cannot compare {} and {} vertices",
            a.len(),
            b.len()
        )));
    }
    let s: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| (norm.apply(p) - norm.apply(q)).norm())
        .sum();
    Ok(s / a.len() as f64)
}

//! Deformation transfer methods as values: BDT and its baselines, and the
//! trivial floor `identity`. [`TransferMethod::run`] is the one entry point
//! of the CLI (`deformlab transfer`), the harness (`deformlab run`) and
//! the benchmarks.

use std::time::Instant;

use super::external::ExternalRunner;
use super::keypoints::{memo_fit_costed, KeypointSource, PickedKeypoints};
use super::target::{TargetFound, TargetPoints};
use crate::arap::ArapOptions;
use crate::baselines::{
    correspond, CageOptions, CageTransfer, CorrespondenceOptions, DeformationTransfer,
    SumnerTransferOptions, TriangleCorrespondence,
};
use crate::mesh::Mesh;
use crate::transfer::{
    transfer_detailed, FrameAlign, KeypointFit, KeypointOptions, TargetWeights, TransferFrame,
    TransferOptions,
};
use crate::{Error, Result, Vec3};

/// The options of BDT transfer: the selection and fit on A, and how the
/// transforms act on B. Its [`Default`] is the one default of the CLI, the
/// configs and the benchmarks.
#[derive(Clone, Debug, PartialEq)]
pub struct BdtOptions {
    /// Key point selection and fit on the source (Algorithm 1, Eq. 2–5).
    pub keypoints: KeypointOptions,
    /// Where the transforms act on B.
    pub frame: TransferFrame,
    /// Rotation of B onto A in the unit-sphere frame (none: the paper).
    pub align: FrameAlign,
    /// Weights computed on B (`auto`: those of the fit on A).
    pub target_weights: TargetWeights,
    /// ARAP refinement on B after LBS (not in the paper).
    pub refine: bool,
}

/// Written out (not derived) so that a new field needs a stated default,
/// not a silent zero.
impl Default for BdtOptions {
    fn default() -> Self {
        BdtOptions {
            keypoints: KeypointOptions::default(),
            frame: TransferFrame::UnitSphere,
            align: FrameAlign::None,
            target_weights: TargetWeights::Auto,
            refine: false,
        }
    }
}

impl BdtOptions {
    /// The options of [`transfer_detailed`]: B is skinned with the weight
    /// options of the fit on A (so that A → A reproduces the fit).
    pub fn transfer_options(&self) -> TransferOptions {
        let d = TransferOptions::default();
        TransferOptions {
            frame: self.frame,
            align: self.align,
            weights: self.keypoints.weights,
            weight_kind: self.target_weights.resolve(self.keypoints.mode),
            fast_bounds: self.keypoints.fast.bounds,
            refine: self.refine,
            seed: self.keypoints.seed,
            // The refinement on B takes the ARAP weight λ of the fit on A
            // (its handle targets and E_diff switch are its own).
            arap: ArapOptions {
                lambda: self.keypoints.arap.lambda,
                ..d.arap
            },
            ..d
        }
    }
}

/// A transfer method. Closed: a new variant makes the compiler point at
/// every `match` that must handle it (no wildcard arms).
#[derive(Clone, Debug, PartialEq)]
pub enum TransferMethod {
    /// The target left unchanged: `B′_j = B` (every evaluation's floor).
    Identity,
    /// BDT: key points on A, their transforms fitted on the deformed A′,
    /// target key points, weights on B, LBS (optionally ARAP-refined).
    Bdt {
        keypoints: KeypointSource,
        target: TargetPoints,
        options: BdtOptions,
    },
    /// A baseline that takes the key point pairs as markers: Sumner &
    /// Popović ([`sumner_markers`]), cage DT ([`cage_markers`]), or any
    /// [`MarkerFn`] a new kind registers.
    Markers {
        baseline: MarkerBaseline,
        keypoints: KeypointSource,
        target: TargetPoints,
        options: KeypointOptions,
    },
    /// Sumner & Popović with the identity triangle correspondence (shared
    /// connectivity only): the full-correspondence oracle.
    SumnerOracle,
    /// A command the user gives, or a function a host program registered
    /// ([`ExternalRunner`]), with BDT's key point pairs when it takes them
    /// (`keypoints` then set).
    External {
        runner: ExternalRunner,
        keypoints: Option<KeypointSource>,
        target: TargetPoints,
        options: KeypointOptions,
    },
}

/// A transfer from marker pairs `(source vertex, target vertex)`: every
/// pose `a_def[j]` of `a` transferred to `b`.
pub type MarkerFn =
    fn(a: &Mesh, a_def: &[Mesh], b: &Mesh, markers: &[(usize, usize)]) -> Result<TransferOutcome>;

/// A marker baseline: its kind's name and its transfer.
#[derive(Clone, Copy)]
pub struct MarkerBaseline {
    /// The kind's name (`sumner`, `cage`, ...).
    pub name: &'static str,
    pub run: MarkerFn,
}

impl std::fmt::Debug for MarkerBaseline {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "MarkerBaseline({})", self.name)
    }
}

/// Two baselines are the same kind when their names are (a kind has one
/// transfer function).
impl PartialEq for MarkerBaseline {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

/// The meshes of one transfer: source `a`, its deformed poses `a_def`,
/// target `b`.
#[derive(Clone, Copy, Debug)]
pub struct TransferCase<'a> {
    pub a: &'a Mesh,
    pub a_def: &'a [Mesh],
    pub b: &'a Mesh,
}

/// Wall-clock seconds of the stages a method has (`None`: not run).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TransferTimings {
    /// Fit of the key point transforms on A (BDT).
    pub fit: Option<f64>,
    /// What the fit cost: `fit`, except for a fit reused from the memo
    /// (made earlier in this process for the same source, key points and
    /// options), where it is the seconds of the fit that filled the memo.
    pub fit_computed: Option<f64>,
    /// Weights on B (BDT).
    pub weights: Option<f64>,
    /// LBS of all poses (BDT).
    pub lbs: Option<f64>,
    /// ARAP refinement (BDT).
    pub refine: Option<f64>,
    /// Correspondence step (Sumner), cages and coordinates (cage).
    pub precompute: Option<f64>,
    /// Deformation transfer matrix (Sumner).
    pub factorise: Option<f64>,
    /// All poses (Sumner, cage).
    pub solve: Option<f64>,
}

/// Everything a transfer computed.
#[derive(Clone, Debug)]
pub struct TransferOutcome {
    /// `B′_j`, one per deformed source.
    pub meshes: Vec<Mesh>,
    /// Key points on A (not for `identity` and the oracle).
    pub keypoints: Option<PickedKeypoints>,
    /// Their target vertices.
    pub target: Option<TargetFound>,
    /// The BDT fit on A (`D_S(A)` per pose, transforms, error).
    pub fit: Option<KeypointFit>,
    /// Cage rows: the cage fit residual `‖Φ_s C_s′ − A′‖` per pose (A's units).
    pub cage_fit_errors: Option<Vec<f64>>,
    /// BDT with an automatic correspondence: whether the transforms were
    /// re-expressed in B's frame (the registration rotated A onto B).
    pub frames_differ: Option<bool>,
    pub timings: TransferTimings,
}

impl TransferOutcome {
    /// The meshes of a transfer, nothing else measured yet.
    pub fn new(meshes: Vec<Mesh>) -> Self {
        TransferOutcome {
            meshes,
            keypoints: None,
            target: None,
            fit: None,
            cage_fit_errors: None,
            frames_differ: None,
            timings: TransferTimings::default(),
        }
    }
}

impl TransferMethod {
    /// Short kind name (as in the configs' `kind`).
    pub fn kind_name(&self) -> &'static str {
        match self {
            TransferMethod::Identity => "identity",
            TransferMethod::Bdt { keypoints, .. } => match keypoints {
                KeypointSource::Automatic { .. } | KeypointSource::Given(_) => "bdt",
                KeypointSource::Random { .. } => "bdt_random",
                KeypointSource::Extremity { .. } => "bdt_extremity",
            },
            TransferMethod::Markers { baseline, .. } => baseline.name,
            TransferMethod::SumnerOracle => "sumner_oracle",
            TransferMethod::External { runner, .. } => runner.kind_name(),
        }
    }

    /// The key point inputs of a method that takes key points (BDT and its
    /// simulated users, Sumner, cage): where they come from, their target
    /// points and the selection options; `None` for the kinds that take
    /// none (`identity`, `sumner_oracle`). The CLI and the binding set the
    /// inputs they read from files here.
    pub fn keypoint_inputs_mut(
        &mut self,
    ) -> Option<(&mut KeypointSource, &mut TargetPoints, &mut KeypointOptions)> {
        match self {
            TransferMethod::Identity
            | TransferMethod::SumnerOracle
            | TransferMethod::External {
                keypoints: None, ..
            } => None,
            TransferMethod::Bdt {
                keypoints,
                target,
                options,
            } => Some((keypoints, target, &mut options.keypoints)),
            TransferMethod::Markers {
                keypoints,
                target,
                options,
                ..
            }
            | TransferMethod::External {
                keypoints: Some(keypoints),
                target,
                options,
                ..
            } => Some((keypoints, target, options)),
        }
    }

    /// [`Self::keypoint_inputs_mut`], read only: what the harness records
    /// and checks of a method that takes key points.
    pub fn keypoint_inputs(&self) -> Option<(&KeypointSource, &TargetPoints, &KeypointOptions)> {
        match self {
            TransferMethod::Identity
            | TransferMethod::SumnerOracle
            | TransferMethod::External {
                keypoints: None, ..
            } => None,
            TransferMethod::Bdt {
                keypoints,
                target,
                options,
            } => Some((keypoints, target, &options.keypoints)),
            TransferMethod::Markers {
                keypoints,
                target,
                options,
                ..
            }
            | TransferMethod::External {
                keypoints: Some(keypoints),
                target,
                options,
                ..
            } => Some((keypoints, target, options)),
        }
    }

    /// Transfers every deformation `a → a_def[j]` to `b`.
    pub fn run(&self, case: &TransferCase) -> Result<TransferOutcome> {
        let TransferCase { a, a_def, b } = *case;
        match self {
            TransferMethod::Identity => Ok(TransferOutcome::new(vec![b.clone(); a_def.len()])),
            TransferMethod::Bdt {
                keypoints,
                target,
                options,
            } => {
                let picked = keypoints.pick(a, a_def, &options.keypoints)?;
                let t = Instant::now();
                let (fit, waited, reused_cost) =
                    memo_fit_costed(a, a_def, &picked.keypoints, &options.keypoints)?;
                let fit = (*fit).clone();
                let seconds_fit = (t.elapsed().as_secs_f64() - waited).max(0.0);
                let found = target.find(a, b, &picked.keypoints)?;
                // When the registration of A onto B (automatic target
                // correspondence) rotated A, the transforms are re-expressed
                // in B's frame, whatever the frame: the registration is a
                // dense correspondence, a better guide to the rotation than
                // a handful of key point pairs.
                let registration_frame = found.auto.as_ref();
                let (a_t, transforms) = match registration_frame {
                    Some(r) => (
                        r.source_in_target_frame(a)?,
                        r.target_frame_transforms(&fit.transforms),
                    ),
                    None => (a.clone(), fit.transforms.clone()),
                };
                let tr = transfer_detailed(
                    &a_t,
                    &picked.keypoints,
                    &transforms,
                    b,
                    &found.keypoints,
                    &options.transfer_options(),
                )?;
                let mut out = TransferOutcome::new(tr.meshes);
                out.frames_differ = registration_frame.map(|r| r.frames_differ());
                out.timings = TransferTimings {
                    fit: Some(seconds_fit),
                    fit_computed: Some(reused_cost.unwrap_or(seconds_fit)),
                    weights: Some(tr.seconds_weights),
                    lbs: Some(tr.seconds_lbs),
                    refine: Some(tr.seconds_refine),
                    ..TransferTimings::default()
                };
                out.keypoints = Some(picked);
                out.target = Some(found);
                out.fit = Some(fit);
                Ok(out)
            }
            TransferMethod::Markers {
                baseline,
                keypoints,
                target,
                options,
            } => {
                let picked = keypoints.pick(a, a_def, options)?;
                let found = target.find(a, b, &picked.keypoints)?;
                if found.auto.as_ref().is_some_and(|r| r.frames_differ()) {
                    return Err(Error::invalid(
                        "the registration rotated the source onto the target: the baselines \
                         assume one frame (only bdt re-expresses its transforms in the \
                         target's frame)",
                    ));
                }
                let markers: Vec<(usize, usize)> = picked
                    .keypoints
                    .iter()
                    .copied()
                    .zip(found.keypoints.iter().copied())
                    .collect();
                let mut out = (baseline.run)(a, a_def, b, &markers)?;
                out.keypoints = Some(picked);
                out.target = Some(found);
                Ok(out)
            }
            TransferMethod::External {
                runner,
                keypoints,
                target,
                options,
            } => {
                let (mut picked, mut found) = (None, None);
                if let Some(source) = keypoints {
                    let p = source.pick(a, a_def, options)?;
                    found = Some(target.find(a, b, &p.keypoints)?);
                    picked = Some(p);
                }
                let markers: Option<Vec<(usize, usize)>> = match (&picked, &found) {
                    (Some(p), Some(f)) => Some(
                        p.keypoints
                            .iter()
                            .copied()
                            .zip(f.keypoints.iter().copied())
                            .collect(),
                    ),
                    _ => None,
                };
                let t = Instant::now();
                let meshes = runner.run(a, a_def, b, markers.as_deref())?;
                let mut out = TransferOutcome::new(meshes);
                out.timings.solve = Some(t.elapsed().as_secs_f64());
                out.keypoints = picked;
                out.target = found;
                Ok(out)
            }
            TransferMethod::SumnerOracle => {
                if a.faces() != b.faces() {
                    return Err(Error::invalid(format!(
                        "sumner_oracle needs shared connectivity: source has {} vertices / {} \
                         faces, target {} / {} (or different faces)",
                        a.n_vertices(),
                        a.n_faces(),
                        b.n_vertices(),
                        b.n_faces()
                    )));
                }
                let markers: Vec<(usize, usize)> = (0..a.n_vertices()).map(|i| (i, i)).collect();
                sumner(a, a_def, b, &markers, true)
            }
        }
    }
}

/// Sumner DT of every pose; `oracle`: the identity triangle correspondence,
/// else the correspondence step from `markers`.
fn sumner(
    a: &Mesh,
    a_def: &[Mesh],
    b: &Mesh,
    markers: &[(usize, usize)],
    oracle: bool,
) -> Result<TransferOutcome> {
    let t = Instant::now();
    let corr = if oracle {
        TriangleCorrespondence::identity(a.n_faces())
    } else {
        correspond(a, b, markers, &CorrespondenceOptions::default())?.triangles
    };
    let precompute = t.elapsed().as_secs_f64();
    let dt = DeformationTransfer::new(a, b, &corr, &SumnerTransferOptions::default())?;
    let t = Instant::now();
    let meshes = a_def
        .iter()
        .map(|pose| match_translation(&dt.transfer(pose)?, b, a, pose, markers))
        .collect::<Result<Vec<_>>>()?;
    let mut out = TransferOutcome::new(meshes);
    out.timings = TransferTimings {
        precompute: Some(precompute),
        factorise: Some(dt.factor_seconds()),
        solve: Some(t.elapsed().as_secs_f64()),
        ..TransferTimings::default()
    };
    Ok(out)
}

/// Sumner & Popović DT of every pose, the triangle correspondence from
/// `markers` (the `sumner` kind).
pub fn sumner_markers(
    a: &Mesh,
    a_def: &[Mesh],
    b: &Mesh,
    markers: &[(usize, usize)],
) -> Result<TransferOutcome> {
    sumner(a, a_def, b, markers, false)
}

/// Cage DT of every pose with `markers` (the `cage` kind).
pub fn cage_markers(
    a: &Mesh,
    a_def: &[Mesh],
    b: &Mesh,
    markers: &[(usize, usize)],
) -> Result<TransferOutcome> {
    let t = Instant::now();
    let ct = CageTransfer::new(a, b, markers, &CageOptions::default())?;
    let precompute = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut meshes = Vec::with_capacity(a_def.len());
    let mut fit = Vec::with_capacity(a_def.len());
    for pose in a_def {
        let r = ct.transfer(pose)?;
        fit.push(r.fit_error);
        meshes.push(r.mesh);
    }
    let mut out = TransferOutcome::new(meshes);
    out.cage_fit_errors = Some(fit);
    out.timings = TransferTimings {
        precompute: Some(precompute),
        solve: Some(t.elapsed().as_secs_f64()),
        ..TransferTimings::default()
    };
    Ok(out)
}

/// B moved by the best rigid motion of A → A′ at the marker sources (the
/// `rigid` kind): the rotation by Kabsch ([`crate::eval::procrustes`])
/// about B's marker centroid, the translation that of A's marker centroid.
pub fn rigid_markers(
    a: &Mesh,
    a_def: &[Mesh],
    b: &Mesh,
    markers: &[(usize, usize)],
) -> Result<TransferOutcome> {
    let t = Instant::now();
    let centroid = |m: &Mesh, idx: &mut dyn Iterator<Item = usize>| {
        let pts: Vec<_> = idx.map(|i| m.vertices()[i]).collect();
        let c = pts.iter().fold(Vec3::zeros(), |s, p| s + p.coords) / pts.len().max(1) as f64;
        (pts, c)
    };
    let (src, c_a) = centroid(a, &mut markers.iter().map(|m| m.0));
    let (_, c_b) = centroid(b, &mut markers.iter().map(|m| m.1));
    let meshes = a_def
        .iter()
        .map(|pose| {
            let (moved, c_p) = centroid(pose, &mut markers.iter().map(|m| m.0));
            let rot = crate::eval::procrustes(&src, &moved)?.rotation;
            b.map_vertices(|p| (rot * (p.coords - c_b) + c_b + (c_p - c_a)).into())
        })
        .collect::<Result<Vec<_>>>()?;
    let mut out = TransferOutcome::new(meshes);
    out.timings.solve = Some(t.elapsed().as_secs_f64());
    Ok(out)
}

/// Translates `result` so that the centroid of its vertices `targets`
/// moves by the displacement of the centroid of `sources` from
/// `source_rest` to `source_pose` (relative to `target_rest`).
///
/// Deformation transfer determines its result only up to a translation
/// (the solve pins one vertex at its rest position); this uses only source
/// data (the oracle: all vertices).
pub fn match_translation(
    result: &Mesh,
    target_rest: &Mesh,
    source_rest: &Mesh,
    source_pose: &Mesh,
    pairs: &[(usize, usize)],
) -> Result<Mesh> {
    if pairs.is_empty() {
        return Err(Error::invalid("translation from an empty marker list"));
    }
    let (rv, tv) = (result.vertices(), target_rest.vertices());
    let (sr, sp) = (source_rest.vertices(), source_pose.vertices());
    let mut shift = Vec3::zeros();
    for &(s, t) in pairs {
        shift += (sp[s] - sr[s]) - (rv[t] - tv[t]);
    }
    shift /= pairs.len() as f64;
    result.map_vertices(|p| p + shift)
}

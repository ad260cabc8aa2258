//! Deformation transfer on the synthetic FAUST-style set (BDT Sec. 4's FAUST
//! evaluation in miniature): subject 0's T-pose is A, its poses are A′,
//! subject 1's T-pose is B (shared connectivity: target key point = source
//! key point), subject 1's poses are the ground truth.
//!
//! Error: mean per-vertex Euclidean distance to the true pose, averaged over
//! the poses, in unit-sphere units of ONE similarity computed from B.
//!
//! Key points are selected in fast mode with the RMS error norm (with the
//! paper's norm `ε = 0.03` is met by one key point on 1.7k vertices) and
//! `n_c = 24`; B is skinned with the same (fast-mode) weights the
//! transforms were fitted with.
//!
//! Run: `cargo test --release --test transfer_synthetic -- --nocapture`.

use deformlab::arap::{ArapOptions, ReducedArap};
use deformlab::data::synthetic::FaustStyle;
use deformlab::ops::normalize::{unit_sphere_transform, NormalizeReference, Similarity};
use deformlab::skin::Affine;
use deformlab::transfer::{
    fit_keypoints, mean_vertex_error, select_keypoints, transfer, ErrorNorm, KeypointFit,
    KeypointOptions, SelectionMode, TargetWeights, TransferFrame, TransferOptions,
};
use deformlab::Mesh;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

struct Case {
    a: Mesh,
    a_posed: Vec<Mesh>,
    b: Mesh,
    truth: Vec<Mesh>,
    norm: Similarity,
}

fn case() -> Case {
    let set = FaustStyle {
        subjects: 2,
        poses: 4,
        resolution: 1,
        ..Default::default()
    }
    .generate()
    .unwrap();
    let b = set.rest[1].clone();
    let norm = unit_sphere_transform(std::slice::from_ref(&b), NormalizeReference::Union).unwrap();
    Case {
        a: set.rest[0].clone(),
        a_posed: set.meshes[0].clone(),
        b,
        truth: set.meshes[1].clone(),
        norm,
    }
}

fn kp_options() -> KeypointOptions {
    KeypointOptions {
        n_candidates: 24,
        seed: 1,
        max_keypoints: 12,
        mode: SelectionMode::Fast,
        error_norm: ErrorNorm::Rms,
        ..KeypointOptions::default()
    }
}

fn transfer_options(kp: &KeypointOptions) -> TransferOptions {
    TransferOptions {
        frame: TransferFrame::Raw,
        weights: kp.weights,
        weight_kind: TargetWeights::Auto.resolve(kp.mode),
        fast_bounds: kp.fast.bounds,
        ..TransferOptions::default()
    }
}

/// Transfers with shared connectivity and returns the mean error over poses.
fn transfer_error(
    c: &Case,
    keypoints: &[usize],
    transforms: &[Vec<Affine>],
    o: &TransferOptions,
) -> f64 {
    let out = transfer(&c.a, keypoints, transforms, &c.b, keypoints, o).unwrap();
    let errs: Vec<f64> = out
        .iter()
        .zip(&c.truth)
        .map(|(m, t)| mean_vertex_error(m.vertices(), t.vertices(), &c.norm).unwrap())
        .collect();
    errs.iter().sum::<f64>() / errs.len() as f64
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[test]
fn automatic_key_points_beat_random_candidates() {
    let c = case();
    let opts = kp_options();
    let sel = select_keypoints(&c.a, &c.a_posed, &opts).unwrap();
    let to = transfer_options(&opts);
    let auto = transfer_error(&c, &sel.keypoints, &sel.transforms, &to);
    let nk = sel.keypoints.len();

    let mut random = Vec::new();
    for seed in 0..10u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let kp: Vec<usize> = rand::seq::index::sample(&mut rng, sel.candidates.len(), nk)
            .into_iter()
            .map(|i| sel.candidates[i])
            .collect();
        let fit = fit_keypoints(&c.a, &c.a_posed, &kp, &opts).unwrap();
        let e = transfer_error(&c, &kp, &fit.transforms, &to);
        eprintln!(
            "  random seed {seed}: fit error {:.5}, transfer error {e:.5}",
            fit.error
        );
        random.push(e);
    }
    let med = median(random.clone());
    let refined = transfer_error(
        &c,
        &sel.keypoints,
        &sel.transforms,
        &TransferOptions {
            refine: true,
            ..to.clone()
        },
    );
    let mut smooth = TransferOptions {
        refine: true,
        ..to.clone()
    };
    smooth.arap.use_ediff = true;
    let refined_ediff = transfer_error(&c, &sel.keypoints, &sel.transforms, &smooth);
    eprintln!(
        "auto: {nk} key points {:?}, selection error {:.5} ({:.2} s); transfer error {auto:.5} \
         (refined: handle-constrained {refined:.5}, E_diff to LBS {refined_ediff:.5}); random ({nk} of the {} candidates, 10 seeds): median {med:.5}, \
         min {:.5}, max {:.5}",
        sel.keypoints,
        sel.error,
        sel.seconds,
        sel.candidates.len(),
        random.iter().cloned().fold(f64::INFINITY, f64::min),
        random.iter().cloned().fold(0.0, f64::max),
    );
    assert!(auto < med, "auto {auto} vs random median {med}");
}

/// The E_diff-off ablation of the fit (FAST: ARAP in the skinning subspace
/// with handle position constraints at the key points' positions on A′),
/// built from the public solver with the fit's own weights and groups:
/// `fit_keypoints` always enables E_diff (it overrides
/// `opts.arap.use_ediff`), so the ablation is done here.
fn fit_without_ediff(c: &Case, keypoints: &[usize], fit: &KeypointFit) -> Vec<Vec<Affine>> {
    let arap = ReducedArap::new(
        &c.a,
        &fit.weights,
        &fit.groups,
        ArapOptions {
            use_ediff: false,
            handles: keypoints.to_vec(),
            ..ArapOptions::default()
        },
    )
    .unwrap();
    c.a_posed
        .iter()
        .map(|t| arap.solve(t.vertices(), None).unwrap().transforms)
        .collect()
}

#[test]
fn ediff_fitting_transfers_better_than_handle_constraints() {
    let c = case();
    let opts = kp_options();
    let sel = select_keypoints(&c.a, &c.a_posed, &opts).unwrap();
    let to = transfer_options(&opts);
    let with = fit_keypoints(&c.a, &c.a_posed, &sel.keypoints, &opts).unwrap();
    let without = fit_without_ediff(&c, &sel.keypoints, &with);
    // Fit error of the ablation on A (mean vertex distance, B's units).
    let fit_err = |ts: &[Vec<Affine>]| {
        let out = transfer(&c.a, &sel.keypoints, ts, &c.a, &sel.keypoints, &to).unwrap();
        out.iter()
            .zip(&c.a_posed)
            .map(|(m, t)| mean_vertex_error(m.vertices(), t.vertices(), &c.norm).unwrap())
            .sum::<f64>()
            / out.len() as f64
    };
    let e_with = transfer_error(&c, &sel.keypoints, &with.transforms, &to);
    let e_without = transfer_error(&c, &sel.keypoints, &without, &to);
    eprintln!(
        "{} key points {:?}: E_diff on: mean fit error on A {:.5}, transfer error {e_with:.5}; \
         E_diff off (handle constraints): mean fit error on A {:.5}, transfer error {e_without:.5}",
        sel.keypoints.len(),
        sel.keypoints,
        fit_err(&with.transforms),
        fit_err(&without),
    );
    assert!(e_with < e_without, "{e_with} vs {e_without}");
}

#[test]
fn transferring_to_the_source_reproduces_the_fit() {
    let c = case();
    let opts = kp_options();
    let sel = select_keypoints(&c.a, &c.a_posed, &opts).unwrap();
    let fit = fit_keypoints(&c.a, &c.a_posed, &sel.keypoints, &opts).unwrap();
    let to = transfer_options(&opts);
    let self_norm =
        unit_sphere_transform(std::slice::from_ref(&c.a), NormalizeReference::Union).unwrap();
    for frame in [TransferFrame::Raw, TransferFrame::HandleRelative] {
        let o = TransferOptions {
            frame,
            ..to.clone()
        };
        let out = transfer(
            &c.a,
            &sel.keypoints,
            &fit.transforms,
            &c.a,
            &sel.keypoints,
            &o,
        )
        .unwrap();
        for (j, m) in out.iter().enumerate() {
            let vs_fit = m
                .vertices()
                .iter()
                .zip(&fit.positions[j])
                .map(|(p, q)| (self_norm.apply(p) - self_norm.apply(q)).norm())
                .fold(0.0, f64::max);
            let vs_posed =
                mean_vertex_error(m.vertices(), c.a_posed[j].vertices(), &self_norm).unwrap();
            let fit_vs_posed =
                mean_vertex_error(&fit.positions[j], c.a_posed[j].vertices(), &self_norm).unwrap();
            eprintln!(
                "A→A {} pose {j}: max |transfer − fit| {vs_fit:.2e}, mean error to A′ {vs_posed:.5} \
                 (fit's own {fit_vs_posed:.5})",
                frame.name()
            );
            assert!(vs_fit < 1e-6, "{vs_fit}");
            assert!((vs_posed - fit_vs_posed).abs() < 1e-6);
        }
    }
}

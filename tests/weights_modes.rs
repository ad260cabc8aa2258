//! The two bounded-weight problems of the key point pipeline agree closely:
//! per-handle bounded weights with rows normalised (the default of
//! `KeypointOptions::weights`, the practice of BDT's ref. [5]) and the
//! coupled problem of BDT Eq. 1 (`weights = "coupled"`). The documented
//! bounds (mean per-vertex total variation, fit error of the
//! same key points) are checked here on the synthetic subject and, when
//! present, on FAUST.

use deformlab::data::shared_data_or_skip;
use deformlab::data::synthetic::FaustStyle;
use deformlab::mesh::io::read_mesh;
use deformlab::skin::bbw::{BbwOptions, Biharmonic, WeightMode};
use deformlab::transfer::keypoints::{fit_keypoints, KeypointOptions};
use deformlab::Mesh;

/// Mean per-vertex total variation `½ Σ_k |w_ik − v_ik|` and the largest
/// entry difference.
fn differences(a: &nalgebra::DMatrix<f64>, b: &nalgebra::DMatrix<f64>) -> (f64, f64) {
    let mut tv = 0.0;
    let mut max: f64 = 0.0;
    for i in 0..a.nrows() {
        let mut s = 0.0;
        for k in 0..a.ncols() {
            let d = (a[(i, k)] - b[(i, k)]).abs();
            max = max.max(d);
            s += d;
        }
        tv += 0.5 * s;
    }
    (tv / a.nrows() as f64, max)
}

fn check(name: &str, a: &Mesh, deformed: &[Mesh], handles: &[usize]) {
    let bh = Biharmonic::new(a).unwrap();
    let per = bh
        .weights(handles, &BbwOptions::with_mode(WeightMode::PerHandle))
        .unwrap();
    let coupled = bh
        .weights(handles, &BbwOptions::with_mode(WeightMode::Coupled))
        .unwrap();
    let (tv, max) = differences(&per, &coupled);
    // Eq. 1's optimum has at most the energy of the feasible normalised
    // per-handle weights.
    let (ep, ec) = (bh.energy(&per).unwrap(), bh.energy(&coupled).unwrap());
    assert!(
        ec <= ep * (1.0 + 1e-9),
        "{name}: coupled {ec} > per-handle {ep}"
    );
    let fit = |mode| {
        let o = KeypointOptions {
            weights: BbwOptions::with_mode(mode),
            ..Default::default()
        };
        fit_keypoints(a, deformed, handles, &o).unwrap().error
    };
    let (fp, fc) = (fit(WeightMode::PerHandle), fit(WeightMode::Coupled));
    let rel = (fp - fc).abs() / fc;
    eprintln!(
        "{name}: {} handles, mean TV {tv:.4}, max |Δw| {max:.3}, energy {ep:.4} vs {ec:.4}, \
         fit error {fp:.5} (per-handle) vs {fc:.5} (coupled), {:.2} %",
        handles.len(),
        100.0 * rel
    );
    assert!(tv < 0.02, "{name}: mean total variation {tv}");
    assert!(max < 0.1, "{name}: max weight difference {max}");
    assert!(
        rel < 0.04,
        "{name}: fit errors differ by {:.2} %",
        100.0 * rel
    );
    assert!(tv > 0.0, "{name}: the two problems gave identical weights");
}

#[test]
fn per_handle_and_coupled_weights_agree_on_the_synthetic_subject() {
    let set = FaustStyle {
        subjects: 1,
        poses: 3,
        ..Default::default()
    }
    .generate()
    .unwrap();
    let a = &set.meshes[0][0];
    let n = a.n_vertices();
    check(
        "synthetic",
        a,
        &set.meshes[0][1..],
        &[n / 7, 2 * n / 5, 3 * n / 5, 6 * n / 7],
    );
}

#[test]
fn per_handle_and_coupled_weights_agree_on_faust() {
    let Some(dir) = shared_data_or_skip("faust", "per_handle_and_coupled_weights_agree_on_faust")
    else {
        return;
    };
    let a = read_mesh(&dir.join("tr_reg_001.ply")).unwrap();
    let d: Vec<Mesh> = ["tr_reg_003", "tr_reg_007"]
        .iter()
        .map(|n| read_mesh(&dir.join(format!("{n}.ply"))).unwrap())
        .collect();
    // Key points chosen by the fast selection at n_c = 100 (m = 1) and by
    // both modes at n_c = 10 (m = 3): see `deformlab bench keypoints`.
    check("FAUST 4", &a, &d[..1], &[729, 1678, 4193, 5118]);
    check("FAUST 5", &a, &d, &[414, 1720, 2832, 4741, 6695]);
}

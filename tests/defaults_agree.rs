//! One default per option: a config without the option, `deformlab
//! transfer` without the flag and the library's `Default` select the same
//! key points and give the same transfer (error norm, selection mode,
//! transfer frame, target weights, and every other option left out).

use std::path::Path;
use std::process::Command;

use deformlab::data::synthetic::FaustStyle;
use deformlab::data::write_faust_style;
use deformlab::experiment::{parse_config, Method};
use deformlab::mesh::io::read_mesh;
use deformlab::methods::{BdtOptions, KeypointSource, TargetPoints, TransferCase, TransferMethod};
use deformlab::transfer::{
    ErrorNorm, KeypointOptions, SelectionMode, TargetWeights, TransferFrame,
};

const BIN: &str = env!("CARGO_BIN_EXE_deformlab");

fn max_vertex_difference(a: &deformlab::Mesh, b: &deformlab::Mesh) -> f64 {
    assert_eq!(a.n_vertices(), b.n_vertices());
    a.vertices()
        .iter()
        .zip(b.vertices())
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max)
}

#[test]
fn config_cli_and_library_defaults_agree() {
    let t = tempfile::tempdir().unwrap();
    let data = t.path().join("faust");
    let set = small_set();
    write_faust_style(&data, &set).unwrap();
    let (a_path, a1_path, b_path) = (
        data.join("tr_reg_000.ply"),
        data.join("tr_reg_001.ply"),
        data.join("tr_reg_010.ply"),
    );

    // The library: BdtOptions::default() and the identity target points.
    let (a, a1, b) = (
        read_mesh(&a_path).unwrap(),
        read_mesh(&a1_path).unwrap(),
        read_mesh(&b_path).unwrap(),
    );
    let d = BdtOptions::default();
    let lib = TransferMethod::Bdt {
        keypoints: KeypointSource::Automatic {
            selection_poses: None,
        },
        target: TargetPoints::default(),
        options: d.clone(),
    }
    .run(&TransferCase {
        a: &a,
        a_def: std::slice::from_ref(&a1),
        b: &b,
    })
    .unwrap();
    let lib_kp = lib.keypoints.as_ref().unwrap().keypoints.clone();
    assert!(lib_kp.len() > 1, "{lib_kp:?}");

    // A config with none of the options resolves to the library default.
    let text = format!(
        "name = \"defaults\"\n[dataset.faust]\npath = {:?}\n[cases]\nsources = [0]\n\
         targets = [1]\nreference_pose = 0\nposes = [1]\n[[methods]]\nname = \"bdt\"\n\
         kind = \"bdt\"\n[outputs]\nrender_cases = 1\nrender_poses = 1\n",
        data.display().to_string()
    );
    let cfg_path = t.path().join("defaults.toml");
    std::fs::write(&cfg_path, &text).unwrap();
    let cfg = parse_config(&text, &cfg_path).unwrap();
    match &cfg.methods[0].method {
        Method::Transfer(TransferMethod::Bdt {
            keypoints: KeypointSource::Automatic { selection_poses },
            target,
            options,
        }) => {
            assert_eq!(*options, d);
            assert_eq!(*target, TargetPoints::default());
            assert_eq!(*selection_poses, None);
        }
        m => panic!("{m:?}"),
    }

    // The run of that config.
    let out = t.path().join("results");
    let o = Command::new(BIN)
        .args([
            "run",
            cfg_path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut rdr = csv::Reader::from_path(out.join("defaults/cases.csv")).unwrap();
    let headers = rdr.headers().unwrap().clone();
    let row = rdr.records().next().unwrap().unwrap();
    let col = |name: &str| {
        row.get(headers.iter().position(|h| h == name).unwrap())
            .unwrap()
    };
    assert_eq!(col("status"), "ok");
    let cfg_kp: Vec<usize> = col("keypoints")
        .split(';')
        .map(|k| k.parse().unwrap())
        .collect();
    let cfg_b = read_mesh(&out.join("defaults/meshes/s0-t1-r0/bdt/result_1.ply")).unwrap();

    // The CLI without any option flag.
    let cli_out = t.path().join("cli");
    let o = Command::new(BIN)
        .args(["transfer", "--source"])
        .arg(&a_path)
        .arg("--deformed")
        .arg(&a1_path)
        .arg("--target")
        .arg(&b_path)
        .args(["--same-connectivity", "--out"])
        .arg(&cli_out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let log: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cli_out.join("log.json")).unwrap()).unwrap();
    let k = KeypointOptions::default();
    let settings = &log["settings"];
    assert_eq!(settings["mode"], serde_json::to_value(k.mode).unwrap());
    assert_eq!(settings["candidates"], k.n_candidates);
    assert_eq!(settings["epsilon"], k.epsilon);
    assert_eq!(log["frame"], d.frame.name());
    assert_eq!(
        log["target_weights"],
        serde_json::to_value(d.transfer_options().weight_kind).unwrap()
    );
    let cli_kp: Vec<usize> = serde_json::from_value(log["source_keypoints"].clone()).unwrap();
    let cli_b = read_mesh(&cli_out.join("tr_reg_001_to_tr_reg_010.ply")).unwrap();

    // Same key points, same B′.
    assert_eq!(cfg_kp, lib_kp);
    assert_eq!(cli_kp, lib_kp);
    let scale = deformlab::eval::ErrorScale::of_reference(&b)
        .unwrap()
        .unit_sphere;
    assert!(max_vertex_difference(&cfg_b, &lib.meshes[0]) * scale < 1e-9);
    assert!(max_vertex_difference(&cli_b, &lib.meshes[0]) * scale < 1e-9);

    // And the defaults are the documented ones.
    assert_eq!(k.mode, SelectionMode::Fast);
    assert_eq!(k.error_norm, ErrorNorm::MeanDistance);
    assert_eq!(d.frame, TransferFrame::UnitSphere);
    assert_eq!(d.target_weights, TargetWeights::Auto);
}

/// Two subjects × two poses of the synthetic set at resolution 1.
fn small_set() -> deformlab::data::synthetic::SyntheticSet {
    FaustStyle {
        subjects: 2,
        poses: 2,
        resolution: 1,
        ..FaustStyle::default()
    }
    .generate()
    .unwrap()
}

/// A changed default would show: the same case with the other value of
/// each option gives other key points or another B′ (so the test above
/// can fail).
#[test]
fn each_option_changes_the_result() {
    let set = small_set();
    let (a, a1, b) = (&set.meshes[0][0], &set.meshes[0][1], &set.meshes[1][0]);
    let run = |options: BdtOptions| {
        TransferMethod::Bdt {
            keypoints: KeypointSource::Automatic {
                selection_poses: None,
            },
            target: TargetPoints::default(),
            options,
        }
        .run(&TransferCase {
            a,
            a_def: std::slice::from_ref(a1),
            b,
        })
        .unwrap()
    };
    let d = BdtOptions::default();
    let base = run(d.clone());
    let kp =
        |o: &deformlab::methods::TransferOutcome| o.keypoints.as_ref().unwrap().keypoints.clone();
    let moved = |o: &deformlab::methods::TransferOutcome| {
        max_vertex_difference(&o.meshes[0], &base.meshes[0])
    };
    let mut paper = d.clone();
    paper.keypoints.error_norm = ErrorNorm::Paper;
    assert_ne!(kp(&run(paper)), kp(&base), "error norm");
    let mut hr = d.clone();
    hr.frame = TransferFrame::HandleRelative;
    assert!(moved(&run(hr)) > 1e-6, "frame");
    // `auto` resolves to bounded weights in both selection modes, so the
    // other value is the fast screening weights.
    let mut screening = d.clone();
    screening.target_weights = TargetWeights::Fast;
    assert!(moved(&run(screening)) > 1e-6, "target weights");
    let _ = Path::new(".");
}

/// `--help` prints the library's defaults, not a copy that can drift (the
/// weights' `--max-iter` help said 200 after the library moved to 1000).
#[test]
fn help_prints_the_library_defaults() {
    use clap::ValueEnum;
    let help = |cmd: &str| {
        let out = Command::new(BIN).args([cmd, "--help"]).output().unwrap();
        assert!(out.status.success(), "{cmd} --help failed");
        // clap wraps long lines; compare with whitespace collapsed.
        String::from_utf8(out.stdout)
            .unwrap()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ")
    };
    fn name<T: ValueEnum>(v: &T) -> String {
        v.to_possible_value().unwrap().get_name().to_string()
    }
    let k = KeypointOptions::default();
    let b = deformlab::skin::bbw::BbwOptions::default();
    let keypoints = help("keypoints");
    for want in [
        k.n_candidates.to_string(),
        k.seed.to_string(),
        k.epsilon.to_string(),
        k.max_keypoints.to_string(),
        name(&k.mode),
        name(&k.error_norm),
        name(&k.weights.mode),
    ] {
        let s = format!("[default: the library's, {want}]");
        assert!(
            keypoints.contains(&s),
            "keypoints --help lacks {s}:\n{keypoints}"
        );
    }
    let weights = help("weights");
    for want in [b.max_iter.to_string(), name(&b.mode)] {
        let s = format!("[default: the library's, {want}]");
        assert!(weights.contains(&s), "weights --help lacks {s}:\n{weights}");
    }
    assert!(!weights.contains("library's, 200]"), "{weights}");
    // Each local refinement and tolerance option's own help names its own
    // default.
    for (flag, want) in [
        ("--local-hops", b.local_hops.to_string()),
        ("--coupled-local-hops", b.coupled_local_hops.to_string()),
        ("--tol", format!("{:e}", b.tol)),
        ("--coupled-tol", format!("{:e}", b.coupled_tol)),
        ("--coupled-step-tol", format!("{:e}", b.coupled_step_tol)),
        ("--coupled-admm-iter", b.coupled_admm_iter.to_string()),
    ] {
        let at = weights
            .find(&format!("{flag} <"))
            .unwrap_or_else(|| panic!("weights --help lacks {flag}:\n{weights}"));
        let rest = &weights[at + flag.len()..];
        let own = &rest[..rest.find("\n      --").unwrap_or(rest.len())];
        let s = format!("[default: the library's, {want}]");
        assert!(own.contains(&s), "{flag}'s help lacks {s}:\n{own}");
    }
    // transfer: the selection options as keypoints, and where the
    // transforms act on B (its help said "direct" while the default is the
    // unit sphere).
    let d = BdtOptions::default();
    let transfer = help("transfer");
    for want in [
        name(&d.frame),
        name(&d.target_weights),
        k.n_candidates.to_string(),
        name(&k.weights.mode),
    ] {
        let s = format!("[default: the library's, {want}]");
        assert!(
            transfer.contains(&s),
            "transfer --help lacks {s}:\n{transfer}"
        );
    }
    assert!(!transfer.contains("[default: direct]"), "{transfer}");
}

/// `lambda` (the configs' key, `BdtOptions::keypoints.arap.lambda`) reaches
/// the ARAP refinement on B, not only the selection and the fit on A: the
/// transfer options carry it, and with the same transforms and weights a
/// different λ gives the same LBS result but another refined B′.
#[test]
fn lambda_reaches_the_refinement_on_b() {
    use deformlab::ops::sampling::{farthest_point_sampling, FpsMetric};
    use deformlab::transfer::{fit_keypoints, transfer_detailed};
    let set = small_set();
    let (a, a1, b) = (&set.meshes[0][0], &set.meshes[0][1], &set.meshes[1][0]);
    let kp = farthest_point_sampling(a, 5, FpsMetric::Geodesic, 0).unwrap();
    let fit = fit_keypoints(
        a,
        std::slice::from_ref(a1),
        &kp,
        &KeypointOptions::default(),
    )
    .unwrap();
    let run = |lambda: f64| {
        let mut o = BdtOptions {
            refine: true,
            ..BdtOptions::default()
        };
        o.keypoints.arap.lambda = lambda;
        let t = o.transfer_options();
        assert_eq!(t.arap.lambda, lambda);
        assert!(t.refine);
        transfer_detailed(a, &kp, &fit.transforms, b, &kp, &t).unwrap()
    };
    let (lo, hi) = (run(0.05), run(5.0));
    assert!(max_vertex_difference(&lo.lbs[0], &hi.lbs[0]) < 1e-12);
    // The refinement holds the key points with μ = 1e5 (handle-constrained
    // ARAP), so λ only sets how soft they are: a small but nonzero effect
    // (identical options would give bitwise equal meshes).
    let moved = max_vertex_difference(&lo.meshes[0], &hi.meshes[0]);
    assert!(moved > 1e-8, "λ did not change the refined B′ ({moved})");
}

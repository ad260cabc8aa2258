//! The registry of method kinds (`methods::registry`): one table read by
//! the configs, `deformlab transfer --method` and the library; a key that a
//! kind does not use is refused naming both; every transfer kind gives the
//! same result from a config, the CLI and the library; `docs/methods.md` is
//! the registry's reference.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use deformlab::data::synthetic::FaustStyle;
use deformlab::data::write_faust_style;
use deformlab::experiment::parse_config;
use deformlab::mesh::io::read_mesh;
use deformlab::methods::registry::{reference_markdown, Family, COMMON_KEYS};
use deformlab::methods::{
    entry_from_table, resolve_entry, Method, MethodKind, PipelineSpec, TransferCase,
};

const BIN: &str = env!("CARGO_BIN_EXE_deformlab");

#[test]
fn docs_methods_md_is_the_registry() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/methods.md");
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(
        text,
        reference_markdown(),
        "docs/methods.md is stale: run `deformlab methods > docs/methods.md`"
    );
    // And the command prints it.
    let o = Command::new(BIN).arg("methods").output().unwrap();
    assert!(o.status.success());
    assert_eq!(String::from_utf8(o.stdout).unwrap(), text);
}

/// A valid value of every entry key (a new key without one fails here:
/// add it, and to the kinds that use it).
fn sample(key: &str) -> &'static str {
    match key {
        "count" | "handles" | "n_clusters" | "n_candidates" | "max_keypoints" | "n_groups"
        | "max_swap_passes" | "kmeans_sample" | "arap_max_iter" | "selection_poses" => "3",
        "seed" | "target_noise_seed" => "7",
        "epsilon" | "gamma_logr" | "gamma_s" | "lambda" | "jitter" | "target_noise" => "0.1",
        "pool" => "\"vertices\"",
        "strategy" => "\"centroid_fps\"",
        "features" | "groups" => "\"augmented\"",
        "examples" => "\"one\"",
        "fbt" => "{ task = \"completion\", q = 2 }",
        "error_norm" => "\"rms\"",
        "mode" => "\"exact\"",
        "fps" => "\"euclidean\"",
        "use_ediff" | "refine" => "true",
        "frame" => "\"raw\"",
        "align" => "\"none\"",
        "target_weights" => "\"fast\"",
        "weights" => "\"coupled\"",
        "target_correspondence" => "\"auto\"",
        "command" => "\"mine {markers} {out}\"",
        "function" => "\"registry-test\"",
        "markers" => "true",
        "timeout" => "5",
        other => panic!("no sample value for key {other:?}: add one"),
    }
}

/// Every key of the schema (from the unknown-field message of serde).
fn schema_keys() -> Vec<String> {
    let e = toml::from_str::<deformlab::methods::MethodEntry>(
        "name = \"x\"\nkind = \"bdt\"\nno_such_key = 1\n",
    )
    .unwrap_err()
    .to_string();
    let list = e.split("expected one of").nth(1).unwrap();
    list.split(',')
        .map(|s| s.trim().trim_matches('`').to_string())
        .filter(|s| !s.is_empty() && !COMMON_KEYS.contains(&s.as_str()))
        .collect()
}

#[test]
fn every_kind_refuses_every_key_it_does_not_use() {
    deformlab::methods::external::register_callable(
        "registry-test",
        std::sync::Arc::new(|i| Ok(vec![i.b.vertices().to_vec(); i.a_def.len()])),
    );
    let keys = schema_keys();
    assert!(keys.len() > 30, "{keys:?}");
    let mut used_somewhere: BTreeMap<String, bool> = BTreeMap::new();
    for &kind in MethodKind::ALL {
        let info = kind.info();
        for key in &keys {
            let text = format!(
                "name = \"m\"\nkind = \"{}\"\n{key} = {}\n{}",
                info.name,
                sample(key),
                if matches!(kind, MethodKind::BdtRandom | MethodKind::BdtExtremity)
                    && key != "count"
                {
                    "count = 4\n"
                } else if kind == MethodKind::Fbt && key != "fbt" {
                    "fbt = { task = \"completion\" }\n"
                } else if kind == MethodKind::Callable && key == "markers" {
                    "function = \"registry-test\"\n"
                } else if kind == MethodKind::Callable && key != "function" {
                    "function = \"registry-test\"\nmarkers = true\n"
                } else if kind == MethodKind::External && key != "command" {
                    "command = \"mine {markers} {out}\"\n"
                } else {
                    ""
                }
            );
            let entry: deformlab::methods::MethodEntry = toml::from_str(&text).unwrap();
            let r = resolve_entry(&entry, &PipelineSpec::default(), 0);
            if info.uses(key) {
                *used_somewhere.entry(key.clone()).or_default() = true;
                // Accepted (the value may still be refused for another reason
                // that names another key, e.g. align against frame).
                if let Err((k, msg)) = &r {
                    assert_ne!(k, key, "{} refuses its own key {key}: {msg}", info.name);
                }
            } else {
                used_somewhere.entry(key.clone()).or_default();
                let (k, msg) = r.err().unwrap_or_else(|| {
                    panic!("{} accepted {key}, which it does not use", info.name)
                });
                assert_eq!(&k, key);
                assert!(
                    msg.contains(&format!("does not apply to kind = \"{}\"", info.name)),
                    "{msg}"
                );
            }
        }
    }
    let unused: Vec<_> = used_somewhere.iter().filter(|(_, u)| !**u).collect();
    assert!(unused.is_empty(), "keys no kind uses: {unused:?}");
}

#[test]
fn kind_names_round_trip_and_config_names_agree() {
    for &kind in MethodKind::ALL {
        assert_eq!(MethodKind::from_name(kind.name()), Some(kind));
        // The config's spelling of the kind is the registry's.
        let v: toml::Value = toml::Value::try_from(kind).unwrap();
        assert_eq!(v.as_str(), Some(kind.name()));
    }
    assert_eq!(MethodKind::from_name("nope"), None);
}

/// Every transfer kind of the registry, from a config run, from `deformlab
/// transfer --method` and from the library: the same B′.
#[test]
fn every_transfer_kind_runs_alike_from_config_cli_and_library() {
    let t = tempfile::tempdir().unwrap();
    let data = t.path().join("faust");
    let set = FaustStyle {
        subjects: 2,
        poses: 2,
        resolution: 1,
        ..FaustStyle::default()
    }
    .generate()
    .unwrap();
    write_faust_style(&data, &set).unwrap();
    let (a_path, a1_path, b_path) = (
        data.join("tr_reg_000.ply"),
        data.join("tr_reg_001.ply"),
        data.join("tr_reg_010.ply"),
    );
    let (a, a1, b) = (
        read_mesh(&a_path).unwrap(),
        read_mesh(&a1_path).unwrap(),
        read_mesh(&b_path).unwrap(),
    );
    // Options per kind (the keys each takes), as config / --opt text.
    let options = |kind: MethodKind| -> Vec<(&'static str, &'static str)> {
        match kind {
            MethodKind::Bdt | MethodKind::Sumner | MethodKind::Cage => {
                vec![("n_candidates", "24"), ("max_keypoints", "6")]
            }
            MethodKind::BdtRandom => vec![("count", "5"), ("seed", "3")],
            MethodKind::BdtExtremity => vec![("count", "5"), ("strategy", "\"centroid_fps\"")],
            MethodKind::External => vec![(
                "command",
                "\"python3 scripts/examples/translate_method.py --source {source} --target \
                 {target} --markers {markers} --out {out} {poses}\"",
            )],
            // Every other kind (a new one too) with its defaults.
            _ => vec![],
        }
    };
    let python = Command::new("python3")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !python {
        eprintln!("SKIP (kind external only): no python3 for the example method");
    }
    let kinds: Vec<MethodKind> = MethodKind::ALL
        .iter()
        .copied()
        .filter(|k| k.info().family == Family::Transfer)
        .filter(|&k| python || k != MethodKind::External)
        // Functions are registered by a host program (Python's run), not
        // by the CLI: tests/external.rs runs them.
        .filter(|&k| k != MethodKind::Callable)
        .collect();
    assert!(kinds.len() >= 8, "{kinds:?}");
    let mut text = format!(
        "name = \"kinds\"\n[dataset.faust]\npath = {:?}\n[cases]\nsources = [0]\n\
         targets = [1]\nreference_pose = 0\nposes = [1]\n",
        data.display().to_string()
    );
    for &k in &kinds {
        text.push_str(&format!(
            "[[methods]]\nname = \"{0}\"\nkind = \"{0}\"\n",
            k.name()
        ));
        for (key, v) in options(k) {
            text.push_str(&format!("{key} = {v}\n"));
        }
    }
    text.push_str("[outputs]\nrender_cases = 1\nrender_poses = 1\n");
    let cfg_path = t.path().join("kinds.toml");
    std::fs::write(&cfg_path, &text).unwrap();
    let cfg = parse_config(&text, &cfg_path).unwrap();
    let out = t.path().join("results");
    let o = Command::new(BIN)
        .args([
            "run",
            cfg_path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--no-plots"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let scale = deformlab::eval::ErrorScale::of_reference(&b)
        .unwrap()
        .unit_sphere;
    let diff = |p: &deformlab::Mesh, q: &deformlab::Mesh| {
        assert_eq!(p.n_vertices(), q.n_vertices());
        p.vertices()
            .iter()
            .zip(q.vertices())
            .map(|(x, y)| (x - y).norm())
            .fold(0.0, f64::max)
            * scale
    };
    for (i, &k) in kinds.iter().enumerate() {
        // The library: the entry resolved through the registry, run.
        let mut table = toml::Table::new();
        for (key, v) in options(k) {
            let one: toml::Table = toml::from_str(&format!("v = {v}")).unwrap();
            table.insert(key.to_string(), one["v"].clone());
        }
        let entry = entry_from_table(k.name(), &table).unwrap();
        let Method::Transfer(m) = resolve_entry(&entry, &PipelineSpec::default(), 0).unwrap()
        else {
            panic!("{} is not a transfer method", k.name())
        };
        // The config resolved to the same value.
        match &cfg.methods[i].method {
            Method::Transfer(c) => assert_eq!(c, &m, "{}", k.name()),
            other => panic!("{other:?}"),
        }
        let lib = m
            .run(&TransferCase {
                a: &a,
                a_def: std::slice::from_ref(&a1),
                b: &b,
            })
            .unwrap();
        // The config run.
        let cfg_b =
            read_mesh(&out.join(format!("kinds/meshes/s0-t1-r0/{}/result_1.ply", k.name())))
                .unwrap();
        // The CLI.
        let cli_out = t.path().join(format!("cli-{}", k.name()));
        let mut cmd = Command::new(BIN);
        cmd.args(["transfer", "--source"])
            .arg(&a_path)
            .arg("--deformed")
            .arg(&a1_path)
            .arg("--target")
            .arg(&b_path)
            .args(["--method", k.name(), "--out"])
            .arg(&cli_out);
        if k.info().uses("target_correspondence") {
            cmd.arg("--same-connectivity");
        }
        for (key, v) in options(k) {
            cmd.args(["--opt", &format!("{key}={}", v.trim_matches('"'))]);
        }
        let o = cmd.output().unwrap();
        assert!(
            o.status.success(),
            "{}: {}",
            k.name(),
            String::from_utf8_lossy(&o.stderr)
        );
        let cli_b = read_mesh(&cli_out.join("tr_reg_001_to_tr_reg_010.ply")).unwrap();
        let (d_cfg, d_cli) = (diff(&cfg_b, &lib.meshes[0]), diff(&cli_b, &lib.meshes[0]));
        assert!(
            d_cfg < 1e-9 && d_cli < 1e-9,
            "{}: config {d_cfg:e}, CLI {d_cli:e} from the library",
            k.name()
        );
        // Not a vacuous comparison: the methods differ from the floor.
        if k != MethodKind::Identity {
            assert!(
                diff(&lib.meshes[0], &b) > 1e-3,
                "{} left B unchanged",
                k.name()
            );
        }
    }
}

/// The `rigid` kind (the registry's trial kind) reproduces a rigid motion of
/// the source exactly when B = A, and leaves B in place when A′ = A.
#[test]
fn rigid_kind_reproduces_a_rigid_motion() {
    use deformlab::methods::rigid_markers;
    let set = FaustStyle {
        subjects: 1,
        poses: 2,
        resolution: 1,
        ..FaustStyle::default()
    }
    .generate()
    .unwrap();
    let a = &set.meshes[0][0];
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    let moved = a
        .map_vertices(|p| {
            deformlab::Point::new(c * p.x - s * p.z + 0.2, p.y - 0.1, s * p.x + c * p.z + 0.05)
        })
        .unwrap();
    let markers: Vec<(usize, usize)> = [3, 70, 250, 600, 900].iter().map(|&i| (i, i)).collect();
    let out = rigid_markers(a, std::slice::from_ref(&moved), a, &markers).unwrap();
    let err = out.meshes[0]
        .vertices()
        .iter()
        .zip(moved.vertices())
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    assert!(err < 1e-9, "{err}");
    let same = rigid_markers(a, std::slice::from_ref(a), a, &markers).unwrap();
    let err = same.meshes[0]
        .vertices()
        .iter()
        .zip(a.vertices())
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    assert!(err < 1e-9, "{err}");
}

//! Config errors name the file, the key and what was expected.

mod common;

use std::path::Path;

use common::{run, write};
use deformlab::experiment::{load_config, parse_config, Method};
use deformlab::methods::{KeypointSource, TransferMethod};

const GOOD: &str = r#"
name = "ok"
[dataset.synthetic]
subjects = 2
poses = 3
resolution = 1
[defaults]
mode = "fast"
n_candidates = 12
[[methods]]
name = "auto"
kind = "bdt"
[[methods]]
name = "random"
kind = "bdt_random"
count = 4
seed = 9
"#;

fn error_of(text: &str) -> String {
    match parse_config(text, Path::new("dir/exp.toml")) {
        Ok(_) => panic!("config accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn good_config_resolves_methods_and_defaults() {
    let c = parse_config(GOOD, Path::new("exp.toml")).unwrap();
    assert_eq!(c.methods.len(), 2);
    match &c.methods[1].method {
        Method::Transfer(TransferMethod::Bdt {
            keypoints: KeypointSource::Random { count, seed, .. },
            options,
            ..
        }) => {
            assert_eq!((*count, *seed), (4, 9));
            assert_eq!(options.keypoints.n_candidates, 12);
            assert_eq!(options.keypoints.seed, 9);
        }
        m => panic!("{m:?}"),
    }
    match &c.methods[0].method {
        Method::Transfer(TransferMethod::Bdt { options, .. }) => {
            assert_eq!(options.keypoints.n_candidates, 12);
            assert_eq!(options.keypoints.seed, 0);
        }
        m => panic!("{m:?}"),
    }
}

#[test]
fn unknown_key_is_named_with_file_and_line() {
    let e = error_of(&GOOD.replace("count = 4", "count = 4\ncolour = \"red\""));
    assert!(e.contains("dir/exp.toml"), "{e}");
    assert!(e.contains("methods[1].colour"), "{e}");
    assert!(e.contains("unknown field `colour`"), "{e}");
    assert!(e.contains("line 17"), "{e}");
    let e = error_of(&GOOD.replace("[defaults]", "[defaults]\nn_candidate = 3"));
    assert!(
        e.contains("defaults.n_candidate") && e.contains("expected one of"),
        "{e}"
    );
    let e = error_of(&format!("{GOOD}\n[metrics]\nprocrustes = true\nbins = 3\n"));
    assert!(e.contains("metrics.bins"), "{e}");
}

#[test]
fn wrong_type_names_the_key_and_the_expected_type() {
    let e = error_of(&GOOD.replace("n_candidates = 12", "n_candidates = \"many\""));
    assert!(e.contains("dir/exp.toml"), "{e}");
    assert!(e.contains("defaults.n_candidates"), "{e}");
    assert!(
        e.contains("invalid type: string \"many\", expected an integer in 1..=100000"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("mode = \"fast\"", "mode = \"quick\""));
    assert!(
        e.contains("defaults.mode") && e.contains("`exact`") && e.contains("`fast`"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("kind = \"bdt_random\"", "kind = \"der_ik\""));
    assert!(
        e.contains("methods[1].kind") && e.contains("bdt_extremity"),
        "{e}"
    );
}

/// Errors the former line-based key finder named wrongly: a missing field
/// of the second `[[methods]]` (named the table above it), a quoted key
/// (named the table), a value spread over lines (named the table, or an
/// array element as a key `3`), a redefined table (named the table above
/// it) and an unknown key of an inline table (named its first key).
#[test]
fn errors_name_the_key_from_the_parse_tree() {
    let cases: [(String, &str, &str); 6] = [
        (
            GOOD.replace("kind = \"bdt_random\"\n", ""),
            "key `methods[1]` (line 13)",
            "missing field `kind`",
        ),
        (
            GOOD.replace("count = 4", "\"count\" = \"four\""),
            "key `methods[1].count`",
            "invalid type",
        ),
        (
            GOOD.replace(
                "resolution = 1",
                "resolution = 1\nposes_list = [\n  1,\n  \"x\"\n]",
            )
            .replace("poses_list", "subjects_x"),
            "key `dataset.synthetic.subjects_x`",
            "unknown field",
        ),
        (
            format!("{GOOD}[outputs]\ncamera = [1,\n  \"a\"]\n"),
            "key `outputs.camera[1]` (line 20)",
            "invalid type: string \"a\"",
        ),
        (
            format!("{GOOD}[dataset.synthetic]\nsubjects = 3\n"),
            "key `dataset.synthetic` (line 18)",
            "duplicate key",
        ),
        (
            GOOD.replace(
                "count = 4",
                "count = 4\nfbt = { task = \"projection\", colour = 1 }",
            ),
            "key `methods[1].fbt.colour`",
            "unknown field `colour`",
        ),
    ];
    for (text, key, what) in cases {
        let e = error_of(&text);
        assert!(
            e.contains(key) && e.contains(what),
            "want {key}: {what}\ngot {e}"
        );
    }
}

#[test]
fn missing_dataset_path_is_named() {
    let t = tempfile::tempdir().unwrap();
    let text = GOOD.replace(
        "[dataset.synthetic]\nsubjects = 2\nposes = 3\nresolution = 1",
        "[dataset.faust]\npath = \"no/such/folder\"",
    );
    let p = write(t.path(), "exp.toml", &text);
    let e = load_config(&p).unwrap_err().to_string();
    assert!(e.contains(&p.display().to_string()), "{e}");
    assert!(
        e.contains("dataset.faust.path") && e.contains("does not exist"),
        "{e}"
    );
    assert!(e.contains("no/such/folder"), "{e}");
    // Same through the command line, exit code 2, nothing written.
    let out = t.path().join("out");
    let o = run(&["run", p.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("dataset.faust.path") && err.contains("exp.toml"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn semantic_errors_name_the_key() {
    let e = error_of(&GOOD.replace("count = 4", "count = 4\nstrategy = \"eccentricity\""));
    assert!(
        e.contains("methods[1].strategy") && e.contains("does not apply"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("count = 4\n", ""));
    assert!(
        e.contains("methods[1].count") && e.contains("expected the number"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("name = \"random\"", "name = \"auto\""));
    assert!(e.contains("methods[1].name") && e.contains("twice"), "{e}");
    let e = error_of(&GOOD.replace("name = \"ok\"", "name = \"../up\""));
    assert!(e.contains("key `name`"), "{e}");
    let e = error_of(&GOOD.replace("resolution = 1", "resolution = 7"));
    assert!(e.contains("dataset.synthetic.resolution"), "{e}");
    let e = error_of(&format!("{GOOD}\n[dataset.faust]\npath = \".\"\n"));
    assert!(e.contains("exactly one"), "{e}");
    let e = error_of(&format!(
        "{GOOD}\n[[outputs.plots]]\nkind = \"bars\"\nmetrics = [\"err_mean\"]\n"
    ));
    assert!(
        e.contains("outputs.plots[0]") && e.contains("err_mean_unit"),
        "{e}"
    );
}

#[test]
fn unknown_subject_in_cases_is_named() {
    let t = tempfile::tempdir().unwrap();
    let p = write(
        t.path(),
        "exp.toml",
        GOOD.replace("[defaults]", "[cases]\nsources = [7]\n[defaults]"),
    );
    let out = t.path().join("out");
    let o = run(&["run", p.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("cases.sources") && err.contains("\"7\""),
        "{err}"
    );
}

#[test]
fn every_shipped_config_parses() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments");
    let mut n = 0;
    for sub in [dir.clone(), dir.join("real")] {
        for e in std::fs::read_dir(&sub).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                match load_config(&p) {
                    Ok(_) => n += 1,
                    // Real-data variants need ../shared/data.
                    Err(e) if sub.ends_with("real") && e.to_string().contains("does not exist") => {
                        eprintln!("SKIP {}: {e}", p.display())
                    }
                    Err(e) => panic!("{}: {e}", p.display()),
                }
            }
        }
    }
    assert!(n >= 8, "{n} configs");
    // (with the FBT configs fbt-*.toml: 7 synthetic + 7 real variants)
}

#[test]
fn every_shipped_config_loads() {
    // The configs of experiments/, experiments/real/, experiments/large/,
    // experiments/bench/ and experiments/examples/:
    // schema and values always; the dataset paths of the real variants
    // (under ../shared/data) only where that folder is present, else SKIP.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments");
    let mut n = 0;
    for dir in [
        root.clone(),
        root.join("real"),
        root.join("large"),
        root.join("bench"),
        root.join("examples"),
    ] {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            if p.extension().is_some_and(|e| e == "toml") {
                let c = deformlab::experiment::load_config_schema(&p)
                    .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
                match c.check_paths() {
                    Ok(()) => {}
                    Err(e) if dir.ends_with("real") && e.to_string().contains("does not exist") => {
                        eprintln!("SKIP data paths of {}: {e}", p.display())
                    }
                    Err(e) => panic!("{}: {e}", p.display()),
                }
                n += 1;
            }
        }
    }
    // 16 BDT configs + 14 FBT configs (fbt-*.toml and real/fbt-*-tosca.toml).
    assert!(n >= 30, "only {n} configs found");
}

/// `[cases] repeat = k` makes k copies of every case with distinct ids (so
/// id-seeded methods draw anew), before `random` draws from them; 0 is an
/// error naming the key and its range.
#[test]
fn repeat_copies_every_case_before_random() {
    use deformlab::experiment::{generate_cases, Collection};
    let with = |extra: &str| {
        let text = format!(
            "name = \"rep\"\n[dataset.synthetic]\nsubjects = 2\nposes = 3\nresolution = 1\n\
             [cases]\nsources = [0]\nper_pose = true\n{extra}\n\
             [[methods]]\nname = \"auto\"\nkind = \"bdt\"\n"
        );
        let cfg = parse_config(&text, Path::new("rep.toml")).unwrap();
        let col = Collection::open(&cfg).unwrap();
        generate_cases(&cfg, &col)
    };
    let base = with("").unwrap();
    let rep = with("repeat = 3").unwrap();
    assert_eq!(rep.len(), 3 * base.len());
    for (i, c) in rep.iter().enumerate() {
        let b = &base[i / 3];
        assert_eq!(c.id, format!("{}-x{}", b.id, i % 3));
        assert_eq!(
            (&c.source, &c.target, &c.poses),
            (&b.source, &b.target, &b.poses)
        );
        assert_eq!(c.index, i);
    }
    let drawn = with("repeat = 3\nrandom = 4").unwrap();
    assert_eq!(drawn.len(), 4);
    assert!(drawn.iter().all(|c| rep.iter().any(|r| r.id == c.id)));
    // Out of range: refused while reading the config, naming the key, the
    // value and the range.
    let e = parse_config(
        "name = \"rep\"\n[cases]\nrepeat = 0\n[[methods]]\nname = \"a\"\nkind = \"bdt\"\n",
        Path::new("rep.toml"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("rep.toml") && e.contains("cases.repeat") && e.contains("0 is out of range"),
        "{e}"
    );
    assert!(e.contains("1..=1000"), "{e}");
}

#[test]
fn weights_key_chooses_the_bounded_weight_problem() {
    use deformlab::skin::bbw::WeightMode;
    let mode_of =
        |text: &str, i: usize| match &parse_config(text, Path::new("exp.toml")).unwrap().methods[i]
            .method
        {
            Method::Transfer(TransferMethod::Bdt { options, .. }) => (
                options.keypoints.weights.mode,
                options.transfer_options().weights.mode,
            ),
            m => panic!("{m:?}"),
        };
    // Default: per-handle bounds, rows normalised, on A and on B.
    assert_eq!(
        mode_of(GOOD, 0),
        (WeightMode::PerHandle, WeightMode::PerHandle)
    );
    let coupled = GOOD.replace(
        "kind = \"bdt\"\n",
        "kind = \"bdt\"\nweights = \"coupled\"\n",
    );
    assert_eq!(
        mode_of(&coupled, 0),
        (WeightMode::Coupled, WeightMode::Coupled)
    );
    assert_eq!(
        mode_of(&coupled, 1),
        (WeightMode::PerHandle, WeightMode::PerHandle)
    );
    let e = error_of(&GOOD.replace("kind = \"bdt\"\n", "kind = \"bdt\"\nweights = \"exact\"\n"));
    assert!(e.contains("weights") && e.contains("coupled"), "{e}");
}

/// A key that a method kind does not use is refused on the entry, naming the
/// key and the kind: BDT's transfer-stage keys on the baselines that take its
/// key points as markers, and every pipeline key on the kinds that select no
/// key points. The same keys in [defaults] (shared by every method) are fine.
#[test]
fn keys_a_kind_does_not_use_are_refused() {
    for (kind, key) in [
        ("sumner", "frame = \"raw\""),
        ("sumner", "refine = true"),
        ("cage", "align = \"keypoints\""),
        ("cage", "target_weights = \"fast\""),
        ("identity", "lambda = 0.3"),
        ("identity", "epsilon = 0.01"),
        ("sumner_oracle", "weights = \"coupled\""),
        ("sumner_oracle", "frame = \"raw\""),
    ] {
        let text = format!("{GOOD}[[methods]]\nname = \"extra\"\nkind = \"{kind}\"\n{key}\n");
        let e = error_of(&text);
        let field = key.split(' ').next().unwrap();
        assert!(
            e.contains(&format!("methods[2].{field}"))
                && e.contains(&format!("does not apply to kind = \"{kind}\"")),
            "{kind} with {key}: {e}"
        );
    }
    // The keys a kind uses are accepted: the baselines' selection keys, and
    // any pipeline key in [defaults].
    let ok = format!(
        "{}[[methods]]\nname = \"s\"\nkind = \"sumner\"\nepsilon = 0.02\nlambda = 0.3\n\
         [[methods]]\nname = \"id\"\nkind = \"identity\"\n",
        GOOD.replace(
            "n_candidates = 12",
            "n_candidates = 12\nframe = \"raw\"\nlambda = 0.4"
        )
    );
    parse_config(&ok, Path::new("dir/exp.toml")).unwrap();
}

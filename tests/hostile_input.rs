//! Hostile input (issue 18): inputs that crashed, hung or were silently
//! accepted, each run through the built binary under a time limit
//! ([`common::cli_err`]: killed and failed after 60 s), asserting the exit
//! status, that nothing panicked, and the key phrase of the error. Every
//! input is generated here (small meshes, configs, FIFOs, links); nothing
//! large is committed.
//!
//! | # | input | before | now |
//! |---|---|---|---|
//! | 1 | `repeat = 1000000000`, `repeat = 2^64 − 1`, `curve_points = 1000000000`, `circles = 100000`, `nicp_iterations = 1000000000`, `curve_points = 0 / 1`, a NaN camera | abort, panic, unbounded runs, late failure | error naming the key, the value and the range |
//! | 2 | a value just outside every range of `experiments/README.md` | — | the same error (the table and the code agree) |
//! | 3 | `n_candidates`, `selection_poses`, FBT `q` and `features` beyond the data | a failed case per case, or capped silently | one error naming the key, before any case runs |
//! | 4 | `--threads 100000`, `--threads 0`, `--candidates` out of range or above the vertices, `--epsilon nan`, `gen --resolution 9` | 100000 OS threads, ... | capped with a warning / an error naming the flag |
//! | 5 | a FIFO, a link to `/dev/zero`, a folder as a mesh (`inspect`, `keypoints`, `transfer`, `run`) | hang, memory exhaustion, silently skipped | error naming the path and what it is |
//! | 6 | a UTF-8 BOM (OFF, OBJ, PLY); meshes scaled by 1e200 / 1e-200; two parts, a triangle soup | refused / vertex 0 lost; "coincide"; "singular" without the file | read; "overflow" / "underflow"; the component count and the file |
//! | 7 | contradictory `--landmarks`; options without effect | used as given; ignored | refused, naming the file / both options |

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{cli_err, run_limited, tmp, write, LIMIT};
use deformlab::mesh::io::write_ply;
use deformlab::mesh::primitives::icosphere;
use deformlab::{Mesh, Point};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A small sphere bent about z (a deformed pose with the same faces).
fn bent(m: &Mesh, k: f64) -> Mesh {
    m.map_vertices(|q| {
        let a = k * q.z.max(0.0);
        Point::new(
            q.x * a.cos() - q.y * a.sin(),
            q.x * a.sin() + q.y * a.cos(),
            q.z,
        )
    })
    .unwrap()
}

fn ply(dir: &Path, name: &str, m: &Mesh) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let p = dir.join(name);
    write_ply(&p, m).unwrap();
    p
}

/// `run CONFIG --out DIR/out --no-plots --quiet` expecting a clear error.
#[track_caller]
fn run_err(dir: &Path, config: &str, needles: &[&str]) -> String {
    let cfg = write(dir, "hostile.toml", config);
    let out = dir.join("out");
    cli_err(
        &["run", s(&cfg), "--out", s(&out), "--no-plots", "--quiet"],
        needles,
    )
}

/// Whether a results folder holds no stored case × method result.
fn no_results(out: &Path, name: &str) -> bool {
    let cases = out.join(name).join("cases");
    !cases.exists() || std::fs::read_dir(&cases).unwrap().next().is_none()
}

const METHOD: &str = "[[methods]]\nname = \"m\"\nkind = \"bdt\"\n";

// ---------------------------------------------------------------------------
// 1. Config numbers that crashed or ran without bound.

#[test]
fn h01_config_numbers_out_of_range_are_errors_at_load() {
    let d = tmp();
    let cases: [(&str, &str, &[&str]); 9] = [
        (
            "[cases]\nrepeat = 1000000000\n",
            METHOD,
            &["cases.repeat", "1000000000 is out of range", "1..=1000"],
        ),
        (
            "[cases]\nrepeat = 18446744073709551615\n",
            METHOD,
            &["cases.repeat", "18446744073709551615", "1..=1000"],
        ),
        (
            "[metrics]\ncurve_points = 1000000000\n",
            METHOD,
            &["metrics.curve_points", "1000000000", "2..=10000"],
        ),
        (
            "[metrics]\ncurve_points = 1\n",
            METHOD,
            &["metrics.curve_points", "1 is out of range", "2..=10000"],
        ),
        (
            "[metrics]\ncurve_points = 0\n",
            METHOD,
            &["metrics.curve_points", "0 is out of range"],
        ),
        (
            "",
            "[[methods]]\nname = \"f\"\nkind = \"fbt\"\n\
             fbt = { task = \"completion\", circles = 100000 }\n",
            &["methods[0].fbt.circles", "100000", "1..=100"],
        ),
        (
            "",
            "[[methods]]\nname = \"f\"\nkind = \"fbt\"\n\
             fbt = { task = \"completion\", nicp_iterations = 1000000000 }\n",
            &["methods[0].fbt.nicp_iterations", "1..=100"],
        ),
        (
            "[outputs]\ncamera = [nan, 0]\n",
            METHOD,
            &["outputs.camera", "NaN is out of range", "[-360, 360]"],
        ),
        (
            "[defaults]\nepsilon = -inf\n",
            METHOD,
            &["defaults.epsilon", "-inf is out of range", "[0, ∞)"],
        ),
    ];
    for (tables, methods, needles) in cases {
        let text = format!("name = \"h1\"\n{methods}{tables}");
        let err = run_err(d.path(), &text, needles);
        assert!(
            err.contains("hostile.toml") && err.contains("line"),
            "{err}"
        );
        // Refused at load: no results folder at all (a NaN camera used to
        // compute everything and fail writing manifest.json).
        assert!(!d.path().join("out").join("h1").exists(), "{err}");
    }
}

// 2. Every range documented in experiments/README.md is the one enforced.

/// `(key, range)` of the rows of the README's "Valid ranges" table.
fn documented_ranges() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("experiments/README.md")).unwrap();
    let start = text.find("| key | range |").expect("valid ranges table");
    text[start..]
        .lines()
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            (cells[1].trim_matches('`').to_string(), cells[2].to_string())
        })
        .collect()
}

/// A config setting `key` (a README key path) to `value`.
fn config_with(key: &str, value: &str) -> String {
    let (section, k) = key.rsplit_once('.').unwrap_or(("", key));
    let method = "[[methods]]\nname = \"m\"\nkind = \"bdt\"\n";
    let v = if k == "camera" {
        format!("[{value}, 0]")
    } else {
        value.to_string()
    };
    match section {
        "" => format!("name = \"r\"\n{k} = {v}\n{method}"),
        "methods" => format!("name = \"r\"\n{method}{k} = {v}\n"),
        "methods.fbt" => format!(
            "name = \"r\"\n[[methods]]\nname = \"f\"\nkind = \"fbt\"\n\
             fbt = {{ task = \"completion\", {k} = {v} }}\n"
        ),
        "outputs.plots" => format!(
            "name = \"r\"\n{method}[[outputs.plots]]\nkind = \"pivot\"\nrows = \"q\"\n\
             columns = \"q\"\nmetric = \"q\"\n{k} = {v}\n"
        ),
        table => format!("name = \"r\"\n{method}[{table}]\n{k} = {v}\n"),
    }
}

/// Values just outside a documented range, with a phrase the error must
/// contain (besides the key).
fn outside(range: &str) -> Vec<(String, String)> {
    if let Some((lo, hi)) = range.split_once("..=") {
        let (lo, hi): (i64, u64) = (lo.parse().unwrap(), hi.parse().unwrap());
        let mut v = vec![(
            (hi + 1).to_string(),
            format!("{} is out of range; expected an integer in {range}", hi + 1),
        )];
        if lo > 0 {
            v.push((
                (lo - 1).to_string(),
                format!("expected an integer in {range}"),
            ));
        }
        return v;
    }
    if range.starts_with('[') || range.starts_with('(') {
        let r = range.split(" (").next().unwrap();
        let lo: f64 = r[1..].split(',').next().unwrap().trim().parse().unwrap();
        let below = if range.starts_with('(') { lo } else { lo - 1.0 };
        return vec![
            (
                format!("{below:?}"),
                format!("expected a finite number in {r}"),
            ),
            (
                "nan".into(),
                format!("NaN is out of range; expected a finite number in {r}"),
            ),
        ];
    }
    if range.starts_with("any 64-bit") {
        return vec![("-1".into(), "u64".into())];
    }
    if range.starts_with("finite, ≠ 0") {
        return vec![("0".into(), "non-zero".into())];
    }
    panic!("unknown range {range:?}: teach this test how to leave it");
}

#[test]
fn h02_every_documented_range_is_enforced() {
    let rows = documented_ranges();
    assert!(rows.len() >= 50, "{} rows", rows.len());
    let d = tmp();
    for (key, range) in rows {
        let leaf = key.rsplit('.').next().unwrap().to_string();
        for (value, phrase) in outside(&range) {
            let text = config_with(&key, &value);
            let err = run_err(d.path(), &text, &[&leaf, &phrase]);
            assert!(err.contains("hostile.toml"), "{key} = {value}: {err}");
        }
    }
}

// 3. Values the data make impossible: one error before any case runs.

const SYNTH: &str = "[dataset.synthetic]\nsubjects = 2\nposes = 3\nresolution = 1\n";

#[test]
fn h03_values_the_data_make_impossible_are_one_error_before_any_case() {
    let d = tmp();
    let out = d.path().join("out");
    let checks: [(String, &[&str]); 3] = [
        (
            format!("name = \"h3\"\n{SYNTH}[defaults]\nn_candidates = 5000\n{METHOD}"),
            &["defaults.n_candidates", "5000 candidates asked", "vertices"],
        ),
        (
            // 3 poses: the reference and 2 deformed poses per case (this
            // was capped to 2 silently).
            format!("name = \"h3\"\n{SYNTH}{METHOD}selection_poses = 3\n"),
            &["methods[0].selection_poses", "2 deformed pose(s)", "1..=2"],
        ),
        (
            // One subject: 3 poses and `rest`; a case has the reference,
            // the target and 2 more shapes.
            "name = \"h3\"\n[dataset.synthetic]\nsubjects = 1\nposes = 3\nresolution = 1\n\
             [cases]\ninclude_self = true\ntargets = []\nper_pose = true\n\
             [[methods]]\nname = \"f\"\nkind = \"fbt\"\nfbt = { task = \"completion\", q = 20 }\n"
                .to_string(),
            &["methods[0].fbt.q", "q = 20", "expected 1..=3"],
        ),
    ];
    for (text, needles) in checks {
        let err = run_err(d.path(), &text, needles);
        assert!(err.contains("hostile.toml"), "{err}");
        assert!(no_results(&out, "h3"), "a case ran: {err}");
        let _ = std::fs::remove_dir_all(&out);
    }
    // FBT feature points beyond the vertices of a tiny class (a manifest
    // of six 42-vertex spheres).
    let ball = icosphere(1);
    let mut manifest = String::new();
    for k in 0..6 {
        ply(
            &d.path().join("balls"),
            &format!("b{k}.ply"),
            &bent(&ball, 0.1 * k as f64),
        );
        manifest += &format!("[[mesh]]\nfile = \"b{k}.ply\"\nsubject = \"ball\"\npose = {k}\n");
    }
    write(&d.path().join("balls"), "manifest.toml", manifest);
    let text = "name = \"h3b\"\n[dataset.manifest]\npath = \"balls/manifest.toml\"\n\
                [cases]\ninclude_self = true\ntargets = []\nper_pose = true\n\
                [[methods]]\nname = \"f\"\nkind = \"fbt\"\n\
                fbt = { task = \"completion\", features = 60 }\n";
    run_err(
        d.path(),
        text,
        &[
            "methods[0].fbt.features",
            "60 feature points",
            "42 vertices",
        ],
    );
    assert!(no_results(&out, "h3b"));
}

// 4. Command-line numbers.

#[test]
fn h04_command_line_numbers() {
    let d = tmp();
    // --threads 100000 is capped (a full tiny run, results stored).
    let cfg = write(
        d.path(),
        "t.toml",
        format!(
            "name = \"threads\"\n{SYNTH}[cases]\nmax_cases = 1\n[outputs]\nrender_cases = 0\n\
             [[methods]]\nname = \"identity\"\nkind = \"identity\"\n"
        ),
    );
    let out = d.path().join("out");
    let o = run_limited(
        &[
            "run",
            s(&cfg),
            "--out",
            s(&out),
            "--threads",
            "100000",
            "--no-plots",
            "--quiet",
        ],
        LIMIT,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("--threads 100000 capped to"), "{err}");
    let log = common::runs(&out.join("threads"));
    let used = log["invocations"][0]["threads"].as_u64().unwrap() as usize;
    assert!(
        (1..=deformlab::solve::max_threads().min(256)).contains(&used),
        "{used}"
    );
    cli_err(
        &["run", s(&cfg), "--out", s(&out), "--threads", "0"],
        &["--threads", "0 is out of range"],
    );
    cli_err(
        &["bench", "--threads=-2", "ops"],
        &["--threads", "-2 is out of range"],
    );
    // Selection numbers: the flag, the value and the range.
    let a = ply(d.path(), "a.ply", &icosphere(2));
    let a1 = ply(d.path(), "a1.ply", &bent(&icosphere(2), 0.5));
    let kp = |extra: &[&str], needles: &[&str]| {
        let mut args = vec!["keypoints", "--source", s(&a), "--deformed", s(&a1)];
        args.extend_from_slice(extra);
        cli_err(&args, needles);
    };
    kp(
        &["--candidates", "1000000"],
        &["--candidates", "1000000 is out of range", "1..=100000"],
    );
    kp(
        &["--candidates", "5000"],
        &["--candidates 5000", "exceeds the 162 vertices", "a.ply"],
    );
    kp(&["--epsilon", "nan"], &["--epsilon", "NaN is out of range"]);
    kp(
        &["--max-keypoints", "0"],
        &["--max-keypoints", "0 is out of range", "1..=1000"],
    );
    cli_err(
        &["gen", "--out", s(&d.path().join("g")), "--resolution", "9"],
        &["--resolution", "9 is out of range", "1..=5"],
    );
    cli_err(
        &["gen", "--out", s(&d.path().join("g")), "--subjects", "0"],
        &["--subjects", "0 is out of range", "1..=99"],
    );
}

// 5. Mesh paths must be regular files.

/// Makes a FIFO at `path` (`mkfifo`); false when the system has none.
fn fifo(path: &Path) -> bool {
    Command::new("mkfifo")
        .arg(path)
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn h05_fifos_devices_and_folders_are_not_meshes() {
    let d = tmp();
    let m = icosphere(2);
    let a = ply(d.path(), "a.ply", &m);
    let a1 = ply(d.path(), "a1.ply", &bent(&m, 0.5));
    let zero = d.path().join("zero.ply");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let folder = d.path().join("folder.ply");
    std::fs::create_dir_all(&folder).unwrap();
    let pipe = d.path().join("pipe.ply");
    let have_fifo = fifo(&pipe);
    if !have_fifo {
        println!("SKIP h05 FIFO cases: mkfifo failed");
    }
    let mut bad: Vec<(&Path, &str)> =
        vec![(&zero, "is a character device"), (&folder, "is a folder")];
    if have_fifo {
        bad.push((&pipe, "is a FIFO"));
    }
    let out = d.path().join("out");
    for (p, what) in bad {
        let name = p.file_name().unwrap().to_str().unwrap();
        cli_err(
            &["keypoints", "--source", s(p), "--deformed", s(&a1)],
            &[name, what],
        );
        cli_err(
            &["keypoints", "--source", s(&a), "--deformed", s(p)],
            &[name, what],
        );
        cli_err(
            &[
                "transfer",
                "--source",
                s(&a),
                "--deformed",
                s(&a1),
                "--target",
                s(p),
                "--same-connectivity",
                "--out",
                s(&out),
            ],
            &[name, what],
        );
        if p != folder.as_path() {
            // `inspect` lists a folder's meshes; other paths are read.
            let o = run_limited(&["inspect", s(p)], LIMIT);
            let text = String::from_utf8_lossy(&o.stdout);
            assert_eq!(o.status.code(), Some(1), "{text}");
            assert!(text.contains("UNREADABLE") && text.contains(what), "{text}");
        }
    }
    // `inspect` of a folder lists such entries as unreadable (it skipped
    // them).
    let o = run_limited(&["inspect", "--brief", s(d.path())], LIMIT);
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(text.contains("folder.ply: UNREADABLE"), "{text}");
    assert!(
        !have_fifo || text.contains("pipe.ply: UNREADABLE"),
        "{text}"
    );
    // `run` over a FAUST-style folder holding a FIFO or a folder named like
    // a mesh: an error naming it (it was skipped silently).
    for (entry, what) in [("fifo", "is a FIFO"), ("dir", "is a folder")] {
        if entry == "fifo" && !have_fifo {
            continue;
        }
        let faust = d.path().join(format!("faust-{entry}"));
        ply(&faust, "tr_reg_000.ply", &m);
        ply(&faust, "tr_reg_001.ply", &bent(&m, 0.5));
        let odd = faust.join("tr_reg_002.ply");
        if entry == "fifo" {
            assert!(fifo(&odd));
        } else {
            std::fs::create_dir_all(&odd).unwrap();
        }
        let text = format!(
            "name = \"h5-{entry}\"\n[dataset.faust]\npath = \"faust-{entry}\"\n\
             [cases]\ninclude_self = true\nrequire_truth = false\n{METHOD}"
        );
        run_err(d.path(), &text, &["tr_reg_002.ply", what]);
    }
}

// 6. Readers: BOM, numeric range, disconnected meshes.

/// Two spheres of 42 vertices side by side: one mesh of two parts.
fn two_spheres() -> Mesh {
    let one = icosphere(1);
    let k = one.n_vertices();
    let mut v = one.vertices().to_vec();
    v.extend(
        one.vertices()
            .iter()
            .map(|q| Point::new(q.x + 3.0, q.y, q.z)),
    );
    let mut f = one.faces().to_vec();
    f.extend(one.faces().iter().map(|t| [t[0] + k, t[1] + k, t[2] + k]));
    Mesh::new(v, f).unwrap()
}

const TET_OFF: &str =
    "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
const TET_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

#[test]
fn h06_bom_numeric_range_and_disconnected_meshes() {
    let d = tmp();
    // A UTF-8 BOM is skipped: the tetrahedron reads whole (OBJ used to lose
    // vertex 0, OFF to refuse the keyword).
    let mut plybytes = b"\xEF\xBB\xBF".to_vec();
    let t = ply(
        d.path(),
        "t.ply",
        &deformlab::mesh::io::read_mesh(&write(d.path(), "t.off", TET_OFF)).unwrap(),
    );
    plybytes.extend(std::fs::read(&t).unwrap());
    let files = [
        write(d.path(), "bom.off", format!("\u{feff}{TET_OFF}")),
        write(d.path(), "bom.obj", format!("\u{feff}{TET_OBJ}")),
        write(d.path(), "bom.ply", &plybytes),
    ];
    for f in &files {
        let o = run_limited(&["inspect", "--brief", s(f)], LIMIT);
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{text}");
        assert!(
            text.contains("4 v, 4 f") && text.contains("clean"),
            "{text}"
        );
    }
    // Coordinates whose squares overflow / underflow: said so, with the file.
    let m = icosphere(2);
    for (scale, word) in [(1e200, "numeric overflow"), (1e-200, "numeric underflow")] {
        let big = m.map_vertices(|p| Point::from(p.coords * scale)).unwrap();
        let a = ply(d.path(), "scaled.ply", &big);
        let a1 = ply(d.path(), "scaled1.ply", &bent(&big, 0.5));
        let err = cli_err(
            &["keypoints", "--source", s(&a), "--deformed", s(&a1)],
            &["scaled.ply", word],
        );
        assert!(!err.contains("coincide"), "{err}");
    }
    // Through `run`: the failed case names the file and the overflow (the
    // identity floor failed on "a non-finite deformed length").
    let big = m.map_vertices(|p| Point::from(p.coords * 1e200)).unwrap();
    let dir = d.path().join("big");
    ply(&dir, "big0.ply", &big);
    ply(&dir, "big1.ply", &bent(&big, 0.5));
    write(
        &dir,
        "manifest.toml",
        "[[mesh]]\nfile = \"big0.ply\"\nsubject = \"s\"\npose = 0\n\
         [[mesh]]\nfile = \"big1.ply\"\nsubject = \"s\"\npose = 1\n",
    );
    let cfg = write(
        d.path(),
        "big.toml",
        "name = \"big\"\n[dataset.manifest]\npath = \"big/manifest.toml\"\n\
         [cases]\ninclude_self = true\n[[methods]]\nname = \"identity\"\nkind = \"identity\"\n\
         [outputs]\nrender_cases = 0\n",
    );
    let out = d.path().join("out");
    let o = run_limited(
        &["run", s(&cfg), "--out", s(&out), "--no-plots", "--quiet"],
        LIMIT,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let table = std::fs::read_to_string(out.join("big/cases.csv")).unwrap();
    assert!(
        table.contains("big0.ply") && table.contains("numeric overflow"),
        "{table}"
    );
    // Two parts and an unwelded triangle soup: the component count and the
    // file, not "singular (is the mesh connected?)".
    let one = icosphere(1);
    let two = two_spheres();
    let soup = {
        let mut v = Vec::new();
        let mut f = Vec::new();
        for t in one.faces() {
            f.push([v.len(), v.len() + 1, v.len() + 2]);
            v.extend(t.iter().map(|&i| one.vertices()[i]));
        }
        Mesh::new(v, f).unwrap()
    };
    let parts = [
        (two.clone(), "2 connected components"),
        (soup, "80 connected components"),
    ];
    for (mesh, phrase) in parts {
        let a = ply(d.path(), "parts.ply", &mesh);
        let a1 = ply(d.path(), "parts1.ply", &bent(&mesh, 0.3));
        cli_err(
            &[
                "keypoints",
                "--source",
                s(&a),
                "--deformed",
                s(&a1),
                "--candidates",
                "8",
            ],
            &["parts.ply", phrase],
        );
    }
    // Through `run`: the failed case names the source file.
    let dir = d.path().join("two");
    ply(&dir, "tr_reg_000.ply", &two);
    ply(&dir, "tr_reg_001.ply", &bent(&two, 0.3));
    let cfg = write(
        d.path(),
        "two.toml",
        format!(
            "name = \"two\"\n[dataset.faust]\npath = \"two\"\n[cases]\ninclude_self = true\n\
             [defaults]\nn_candidates = 8\n{METHOD}[outputs]\nrender_cases = 0\n"
        ),
    );
    let out = d.path().join("out");
    let o = run_limited(
        &["run", s(&cfg), "--out", s(&out), "--no-plots", "--quiet"],
        LIMIT,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let table = std::fs::read_to_string(out.join("two/cases.csv")).unwrap();
    assert!(
        table.contains("tr_reg_000.ply") && table.contains("2 connected components"),
        "{table}"
    );
}

// 7. Landmarks and options without effect.

#[test]
fn h07_contradictory_landmarks_and_options_without_effect() {
    let d = tmp();
    let m = icosphere(2);
    let a = ply(d.path(), "a.ply", &m);
    let a1 = ply(d.path(), "a1.ply", &bent(&m, 0.5));
    let out = d.path().join("out");
    let lm = write(d.path(), "lm.csv", "source,target\n0,1\n5,7\n0,2\n");
    let kpf = write(d.path(), "kp.csv", "source\n3\n17\n");
    let base = ["--source", s(&a), "--deformed", s(&a1), "--target", s(&a)];
    let transfer = |extra: &[&str], needles: &[&str]| {
        let mut args = vec!["transfer"];
        args.extend_from_slice(&base);
        args.extend_from_slice(&["--out", s(&out)]);
        args.extend_from_slice(extra);
        cli_err(&args, needles);
    };
    // The same source vertex mapped to two targets, as a marker file's
    // conflict is refused.
    transfer(
        &["--auto-correspondence", "--landmarks", s(&lm)],
        &[
            "lm.csv",
            "pair 2",
            "source vertex 0 is matched to both 1 and 2",
        ],
    );
    transfer(
        &["--correspondence", s(&lm)],
        &["lm.csv", "source vertex 0 is matched to both 1 and 2"],
    );
    // Options that do nothing without another name both.
    transfer(
        &["--same-connectivity", "--landmarks", s(&lm)],
        &["--landmarks has no effect without --auto-correspondence"],
    );
    transfer(
        &["--same-connectivity", "--format", "csv"],
        &["--format has no effect without --correspondence"],
    );
    transfer(
        &["--same-connectivity", "--base", "1"],
        &["--base has no effect without --correspondence"],
    );
    transfer(
        &[
            "--same-connectivity",
            "--keypoints",
            s(&kpf),
            "--candidates",
            "8",
        ],
        &["--candidates has no effect with --keypoints"],
    );
    cli_err(
        &[
            "keypoints",
            "--source",
            s(&a),
            "--deformed",
            s(&a1),
            "--force",
        ],
        &["--force has no effect without --out"],
    );
    cli_err(
        &["bench", "--exact-full", "ops"],
        &["--exact-full has no effect without the keypoints group"],
    );
    assert!(!out.exists(), "an output was written");
}

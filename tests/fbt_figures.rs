//! The FBT figure outputs: pivot tables (Table 2 layout) checked against
//! means computed here from a hand-written cases.csv, curve panels (Fig. 7)
//! and the Euclidean correspondence error against the geodesic one.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::{csv_rows, write};
use deformlab::eval::euclidean_error_curve;
use deformlab::eval::{curve_grid, geodesic_error_curve};
use deformlab::experiment::{make_plots, parse_config, Manifest};
use deformlab::mesh::primitives::{icosphere, torus};

/// A config whose methods name the rows of the hand-written tables.
const CONFIG: &str = r#"
name = "figs"

[[methods]]
name = "lbo5-q1"
kind = "fbt"
fbt = { task = "projection", q = 1, m = 5 }
[[methods]]
name = "lbo10-q1"
kind = "fbt"
fbt = { task = "projection", q = 1, m = 10 }
[[methods]]
name = "lbo10-q2"
kind = "fbt"
fbt = { task = "projection", q = 2, m = 10 }
[[methods]]
name = "skel-q1"
kind = "fbt"
fbt = { task = "projection", q = 1, dictionary = "skeleton", rig = "class" }
[[methods]]
name = "skel-q2"
kind = "fbt"
fbt = { task = "projection", q = 2, dictionary = "skeleton", rig = "class" }

[[outputs.plots]]
kind = "pivot"
file = "paper"
rows = "q"
columns = "dictionary_kind"
metric = "rel_distortion_max"
scale = 100
digits = 2
lead = ["dict_size"]
lead_from = "lbo"
methods = ["lbo10-q1", "lbo10-q2", "skel-q1", "skel-q2"]
labels = { lbo = "LBO", dict_size = "dict. size" }

[[outputs.plots]]
kind = "pivot"
file = "mixed"
rows = "q"
columns = "dictionary_kind"
metric = "rel_distortion_max"

[[outputs.plots]]
kind = "curve_panels"
file = "fig7"
curves = ["cumulative_area", "correspondence_euclidean_area", "correspondence_geodesic_area"]

[[outputs.plots]]
kind = "cumulative"
file = "curves"
"#;

/// (method, q, kind, dict_size) of the hand-written results.
const METHODS: [(&str, u32, &str, u32); 5] = [
    ("lbo5-q1", 1, "lbo", 20),
    ("lbo10-q1", 1, "lbo", 40),
    ("lbo10-q2", 2, "lbo", 70),
    ("skel-q1", 1, "skeleton", 48),
    ("skel-q2", 2, "skeleton", 84),
];

/// Writes manifest.json, cases.csv (3 cases × 5 methods, one failed row
/// whose number must not count) and curves.csv (the geodesic curve under
/// its old name `correspondence_area`) into `dir`.
fn results_folder(dir: &Path) {
    let loaded = parse_config(CONFIG, Path::new("figs.toml")).unwrap();
    let manifest = Manifest {
        name: "figs".into(),
        config_file: "figs.toml".into(),
        config_hash: "0".into(),
        overrides: Vec::new(),
        sweep: None,
        data_root: None,
        data_hash: None,
        config: serde_json::to_value(&loaded.config).unwrap(),
        seed: 0,
        crate_version: "test".into(),
        dataset: "hand-written".into(),
        n_cases: 3,
        cases: Vec::new(),
        methods: METHODS.iter().map(|m| m.0.to_string()).collect(),
        shards: None,
        results_stored: 15,
        results_failed: 1,
        repairs: Vec::new(),
        mesh_defects: Vec::new(),
    };
    write(
        dir,
        "manifest.json",
        serde_json::to_vec_pretty(&manifest).unwrap(),
    );
    let mut cases = String::from(
        "case,case_id,method,group,kind,status,q,dictionary_kind,dict_size,rel_distortion_max\n",
    );
    let mut curves = String::from("case,case_id,method,curve,x,y\n");
    for c in 0..3u32 {
        for (k, (m, q, kind, size)) in METHODS.iter().enumerate() {
            // Distinct, irregular values per (case, method).
            let v = 0.001 * (1.0 + k as f64)
                + 0.00037 * (c * c) as f64
                + 0.0001 * (k as f64) * f64::from(c);
            let status = if c == 2 && *m == "skel-q2" {
                "failed: test"
            } else {
                "ok"
            };
            cases.push_str(&format!(
                "{c},case{c},{m},{m},fbt,{status},{q},{kind},{size},{v}\n"
            ));
            for curve in [
                "cumulative_unit",
                "cumulative_area",
                "correspondence_euclidean_area",
                "correspondence_area",
            ] {
                for (i, x) in [0.0, 0.05, 0.1].iter().enumerate() {
                    let y = (0.3 * i as f64 + 0.1 * (k % 2) as f64).min(1.0);
                    curves.push_str(&format!("{c},case{c},{m},{curve},{x},{y}\n"));
                }
            }
        }
    }
    write(dir, "cases.csv", cases);
    write(dir, "curves.csv", curves);
}

#[test]
fn pivot_cells_are_the_means_of_cases_csv() {
    let t = tempfile::tempdir().unwrap();
    let dir = t.path();
    results_folder(dir);
    let warnings = make_plots(dir).unwrap();
    // The unrestricted pivot mixes lbo5 and lbo10 in the `lbo` cells: an
    // error naming both, not a silent average.
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("mixes") && warnings[0].contains("lbo5-q1"),
        "{}",
        warnings[0]
    );
    assert!(!dir.join("plots/mixed.csv").exists());

    // Independent means from cases.csv: rows with status ok of the listed
    // methods, grouped by (q, dictionary_kind), × 100.
    let cases = csv_rows(&dir.join("cases.csv"));
    let listed = ["lbo10-q1", "lbo10-q2", "skel-q1", "skel-q2"];
    let mut sums: BTreeMap<(String, String), (f64, usize)> = BTreeMap::new();
    let mut sizes: BTreeMap<String, (f64, usize)> = BTreeMap::new();
    for r in &cases {
        if r["status"] != "ok" || !listed.contains(&r["method"].as_str()) {
            continue;
        }
        let v: f64 = r["rel_distortion_max"].parse().unwrap();
        let e = sums
            .entry((r["q"].clone(), r["dictionary_kind"].clone()))
            .or_default();
        e.0 += v;
        e.1 += 1;
        if r["dictionary_kind"] == "lbo" {
            let e = sizes.entry(r["q"].clone()).or_default();
            e.0 += r["dict_size"].parse::<f64>().unwrap();
            e.1 += 1;
        }
    }
    assert_eq!(
        sums[&("2".into(), "skeleton".into())].1,
        2,
        "failed row left out"
    );
    let table = csv_rows(&dir.join("plots/paper.csv"));
    assert_eq!(table.len(), 2);
    let mut checked = 0;
    for (i, row) in table.iter().enumerate() {
        let q = (i + 1).to_string();
        assert_eq!(row["q"], q, "rows sorted by q");
        let (s, n) = sizes[&q];
        assert_eq!(row["dict_size"].parse::<f64>().unwrap(), s / n as f64);
        for kind in ["lbo", "skeleton"] {
            let (s, n) = sums[&(q.clone(), kind.to_string())];
            let want = 100.0 * s / n as f64;
            let got: f64 = row[kind].parse().unwrap();
            assert!(
                (got - want).abs() <= 1e-8 * want.abs(),
                "q = {q}, {kind}: {got} vs {want}"
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 4);
    // Markdown: labels, 2 decimals; the PNG exists.
    let md = std::fs::read_to_string(dir.join("plots/paper.md")).unwrap();
    assert!(
        md.starts_with("| q | dict. size | LBO | skeleton |"),
        "{md}"
    );
    let (s, n) = sums[&("1".into(), "lbo".into())];
    assert!(
        md.contains(&format!("| 1 | 40 | {:.2} |", 100.0 * s / n as f64)),
        "{md}"
    );
    assert!(dir.join("plots/paper.png").is_file());
}

#[test]
fn curve_panels_draw_one_figure_and_old_curve_names_still_plot() {
    let t = tempfile::tempdir().unwrap();
    let dir = t.path();
    results_folder(dir);
    make_plots(dir).unwrap();
    // Three panels side by side in one PNG, each of the default chart
    // size (inches at the default dpi), the shared legend below.
    let png = image_size(&dir.join("plots/fig7.png"));
    let style = deformlab::plot::ChartStyle::PAPER;
    let (w, h) = (style.width_in * style.dpi, style.height_in * style.dpi);
    assert!((png.0 as f64 - 3.0 * w).abs() <= 3.0, "{png:?}");
    assert!(png.1 as f64 > h && (png.1 as f64) < 2.0 * h, "{png:?}");
    assert!(dir.join("plots/fig7.svg").is_file());
    // The geodesic curve stored as `correspondence_area` (older runs) is
    // drawn as `correspondence_geodesic_area`.
    for f in [
        "curves_correspondence.png",
        "curves_correspondence_euclidean.png",
    ] {
        assert!(dir.join("plots").join(f).is_file(), "missing {f}");
    }
}

/// Width and height of a PNG from its IHDR chunk.
fn image_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[1..4], b"PNG");
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

#[test]
fn plot_keys_of_other_kinds_are_rejected() {
    let p = Path::new("x.toml");
    let base = "name = \"x\"\n[[methods]]\nname = \"a\"\nkind = \"identity\"\n[[outputs.plots]]\n";
    let err = |s: &str| {
        parse_config(&format!("{base}{s}"), p)
            .unwrap_err()
            .to_string()
    };
    let e = err("kind = \"pivot\"\nrows = \"q\"\ncolumns = \"dictionary_kind\"\n");
    assert!(e.contains("outputs.plots[0].metric"), "{e}");
    let e = err("kind = \"pivot\"\nrows = \"q\"\ncolumns = \"nope\"\nmetric = \"q\"\n");
    assert!(e.contains("\"nope\" is not a cases.csv column"), "{e}");
    let e = err("kind = \"curve_panels\"\n");
    assert!(e.contains("outputs.plots[0].curves"), "{e}");
    let e = err("kind = \"table\"\nmetrics = [\"q\"]\nscale = 100\n");
    assert!(e.contains("outputs.plots[0].scale"), "{e}");
    let e = err("kind = \"bars\"\nmetrics = [\"q\"]\ncurves = [\"cumulative_area\"]\n");
    assert!(e.contains("outputs.plots[0].curves"), "{e}");
}

#[test]
fn euclidean_correspondence_error_is_at_most_the_geodesic_one() {
    let grid = curve_grid(0.5, 11).unwrap();
    for mesh in [icosphere(2), torus(1.0, 0.3, 24, 12)] {
        let n = mesh.n_vertices();
        // Pseudo-random pairs (LCG), some equal.
        let mut s: u64 = 12345;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) as usize % n
        };
        let predicted: Vec<usize> = (0..200).map(|_| next()).collect();
        let mut truth: Vec<usize> = (0..200).map(|_| next()).collect();
        truth[..10].copy_from_slice(&predicted[..10]);
        let (geo, geo_curve) = geodesic_error_curve(&mesh, &predicted, &truth, &grid).unwrap();
        let (euc, euc_curve) = euclidean_error_curve(&mesh, &predicted, &truth, &grid).unwrap();
        let mut strictly = 0;
        for k in 0..predicted.len() {
            assert!(
                euc[k] <= geo[k] + 1e-12,
                "pair {k}: {} > {}",
                euc[k],
                geo[k]
            );
            assert!(euc[k] >= 0.0);
            if predicted[k] == truth[k] {
                assert_eq!(euc[k], 0.0);
            } else {
                assert!(euc[k] > 0.0);
                strictly += usize::from(euc[k] < geo[k] - 1e-9);
            }
        }
        // On curved surfaces most paths are longer than the chord.
        assert!(strictly > 100, "{strictly}");
        // Hence at every bound at least as many Euclidean errors are within.
        for (e, g) in euc_curve.iter().zip(&geo_curve) {
            assert!(e >= g, "{euc_curve:?} vs {geo_curve:?}");
        }
        // Predicted == truth: all errors 0, every bound holds them all.
        let (zero, curve) = euclidean_error_curve(&mesh, &truth, &truth, &grid).unwrap();
        assert!(zero.iter().all(|&e| e == 0.0));
        assert!(curve.iter().all(|&c| c == 1.0), "{curve:?}");
        // Bad input names the problem.
        let e = euclidean_error_curve(&mesh, &truth[..3], &truth, &grid).unwrap_err();
        assert!(e.to_string().contains("3 predicted"), "{e}");
        let e = euclidean_error_curve(&mesh, &[n], &[0], &grid).unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
    }
}

//! Paper-ready outputs of the harness (issue 20, points 5 and 7), on a tiny
//! synthetic run (one case, three methods): a PDF beside every chart,
//! `title` / `subtitle` switches (off by default), method labels in legends and tables, the
//! up axis, `plot --config`, wrapping render grids, renders as PDF, LaTeX
//! tables, a tidy `cases.csv` (and older wide ones still read), result
//! meshes with their per-vertex `error`, and OBJ output on request.

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{copy_dir, csv_rows, ok, run, write};
use deformlab::eval::{vertex_errors, ErrorScale};
use deformlab::experiment::parse_config_schema;
use deformlab::experiment::{make_plots, CASE_COLUMNS};
use deformlab::mesh::io::{read_mesh, read_ply_vertex_scalar};
use deformlab::plot::{Camera, Up};

const CONFIG: &str = r#"
name = "paper"
seed = 1

[dataset.synthetic]
subjects = 2
poses = 2
resolution = 1

[cases]
sources = [0]
targets = [1]

[defaults]
mode = "fast"
n_candidates = 12
error_norm = "rms"
epsilon = 0.0
max_keypoints = 4
max_swap_passes = 0

[[methods]]
name = "auto_bdt"
kind = "bdt"
label = "BDT (automatic)"

[[methods]]
name = "extremity_user"
kind = "bdt_extremity"
count = 4

[[methods]]
name = "identity"
kind = "identity"

[outputs]
render_poses = 1

[[outputs.plots]]
kind = "cumulative"

[[outputs.plots]]
kind = "bars"
metrics = ["err_mean_unit", "err_rms_unit"]

[[outputs.plots]]
kind = "panels"

[[outputs.plots]]
kind = "table"
metrics = ["err_mean_unit", "within_005_area"]
"#;

/// The default title prefix (the experiment name) and the start of the
/// provenance line of every plot.
const TITLE: &str = "paper: cumulative error to ground truth";
const CAPTION: &str = "synthetic FAUST-style set";

/// Runs `text` (written as `dir/paper.toml`) into `dir/out/paper`.
fn run_config(dir: &Path, text: &str) -> PathBuf {
    common::run_config(dir, "paper", text)
}

/// The run with the default outputs, shared by the tests (read only).
fn reference() -> &'static Path {
    static REF: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &REF.get_or_init(|| {
        let t = tempfile::tempdir().unwrap();
        let dir = run_config(t.path(), CONFIG);
        (t, dir)
    })
    .1
}

/// A copy of the reference run to re-plot.
fn copy_of_reference(t: &Path) -> PathBuf {
    let dir = t.join("copy");
    copy_dir(reference(), &dir);
    dir
}

/// `deformlab plot DIR --config (CONFIG with `outputs` appended)`.
fn replot(dir: &Path, outputs: &str) -> std::process::Output {
    let cfg = write(
        dir.parent().unwrap(),
        "edited.toml",
        format!("{CONFIG}{outputs}"),
    );
    run(&[
        "plot",
        dir.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
    ])
}

/// The texts of an SVG's `<text>` elements.
fn svg_texts(path: &Path) -> Vec<String> {
    let svg = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    svg.split("<text")
        .skip(1)
        .map(|t| {
            let inner = &t[t.find('>').unwrap() + 1..];
            inner[..inner.find("</text>").unwrap()].trim().to_string()
        })
        .collect()
}

fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{}", path.display());
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

/// A PDF file with one page and the bundled font.
fn assert_pdf(path: &Path) {
    let b = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(b.starts_with(b"%PDF-"), "{}: not a PDF", path.display());
    let t = String::from_utf8_lossy(&b);
    assert!(
        t.contains("/Type /Pages"),
        "{}: no page tree",
        path.display()
    );
    assert!(t.contains("/Count 1"), "{}: not one page", path.display());
    assert!(t.contains("DejaVuSans"), "{}: no font", path.display());
}

/// Files of `dir/plots` with extension `ext`.
fn plots_with(dir: &Path, ext: &str) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir.join("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(&format!(".{ext}")))
        .collect();
    v.sort();
    v
}

#[test]
fn every_chart_has_a_pdf_and_renders_are_png() {
    let dir = reference();
    let pngs = plots_with(dir, "png");
    let charts: Vec<&String> = pngs.iter().filter(|p| !p.starts_with("panels")).collect();
    assert!(charts.len() >= 4, "{pngs:?}");
    for png in charts {
        let stem = png.trim_end_matches(".png");
        assert!(
            dir.join(format!("plots/{stem}.svg")).is_file(),
            "{stem}.svg"
        );
        assert_pdf(&dir.join(format!("plots/{stem}.pdf")));
    }
    // Renders: PNG only by default.
    let panels: Vec<&String> = pngs.iter().filter(|p| p.starts_with("panels")).collect();
    assert_eq!(panels.len(), 1, "{pngs:?}");
    assert!(plots_with(dir, "pdf")
        .iter()
        .all(|p| !p.starts_with("panels")));
    // No temporary file left behind.
    let dot: Vec<String> = std::fs::read_dir(dir.join("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(dot.is_empty(), "{dot:?}");
}

#[test]
fn method_labels_name_legends_categories_and_table_rows() {
    let dir = reference();
    let legend = svg_texts(&dir.join("plots/cumulative.svg"));
    assert!(legend.iter().any(|t| t == "BDT (automatic)"), "{legend:?}");
    assert!(!legend.iter().any(|t| t == "auto_bdt"), "{legend:?}");
    // Without a label, the identifier; the identity floor keeps its entry.
    assert!(legend.iter().any(|t| t == "extremity_user"), "{legend:?}");
    assert!(legend.iter().any(|t| t == "identity (B unchanged)"));
    // Bar categories wrap on the one-column default chart: "BDT" over
    // "(automatic)".
    let bars = svg_texts(&dir.join("plots/bars_err_mean_unit_err_rms_unit.svg"));
    assert!(bars.join(" ").contains("BDT (automatic)"), "{bars:?}");
    let md = std::fs::read_to_string(dir.join("plots/table.md")).unwrap();
    assert!(md.contains("| BDT (automatic) |"), "{md}");
    // The CSV keeps the identifiers (data, not display).
    let csv = std::fs::read_to_string(dir.join("plots/table.csv")).unwrap();
    assert!(csv.contains("\nauto_bdt,"), "{csv}");
    // A plot's `labels` wins over the method's label.
    let t = tempfile::tempdir().unwrap();
    let copy = copy_of_reference(t.path());
    let o = replot(
        &copy,
        "\n[[outputs.plots]]\nkind = \"cumulative\"\nfile = \"relabelled\"\n\
         labels = { auto_bdt = \"Ours\" }\n",
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let legend = svg_texts(&copy.join("plots/relabelled.svg"));
    assert!(legend.iter().any(|t| t == "Ours"), "{legend:?}");
    assert!(!legend.iter().any(|t| t == "BDT (automatic)"), "{legend:?}");
}

#[test]
fn labels_are_not_part_of_the_results_key() {
    // Relabelling a method neither changes the config hash nor needs a
    // recomputation: `run` resumes every result.
    let t = tempfile::tempdir().unwrap();
    let first = run_config(t.path(), CONFIG);
    let relabelled = CONFIG.replace("BDT (automatic)", "BDT, relabelled");
    let cfg = write(t.path(), "paper.toml", &relabelled);
    let o = ok(&[
        "run",
        cfg.to_str().unwrap(),
        "--out",
        first.parent().unwrap().to_str().unwrap(),
        "--quiet",
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("0 computed, 3 resumed"), "{out}");
    let legend = svg_texts(&first.join("plots/cumulative.svg"));
    assert!(legend.iter().any(|t| t == "BDT, relabelled"), "{legend:?}");
}

#[test]
fn titles_are_off_by_default_and_can_be_switched_on() {
    // By default a figure has no title and no provenance line (a paper
    // gives it a caption).
    let dir = reference();
    let texts = svg_texts(&dir.join("plots/cumulative.svg"));
    assert!(!texts.iter().any(|t| t == TITLE), "{texts:?}");
    assert!(!texts.iter().any(|t| t.starts_with(CAPTION)), "{texts:?}");
    assert!(texts.iter().any(|t| t == "BDT (automatic)"), "legend kept");

    let t = tempfile::tempdir().unwrap();
    let copy = copy_of_reference(t.path());
    // `[outputs] title = true, subtitle = true`, but the bars plot has
    // neither (`title = false`, `subtitle = false`).
    let edited = CONFIG
        .replace(
            "[outputs]\nrender_poses = 1\n",
            "[outputs]\nrender_poses = 1\ntitle = true\nsubtitle = true\n",
        )
        .replace(
            "metrics = [\"err_mean_unit\", \"err_rms_unit\"]\n",
            "metrics = [\"err_mean_unit\", \"err_rms_unit\"]\ntitle = false\nsubtitle = false\n",
        );
    let cfg = write(t.path(), "edited.toml", &edited);
    ok(&[
        "plot",
        copy.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
    ]);
    let texts = svg_texts(&copy.join("plots/cumulative.svg"));
    assert!(texts.iter().any(|t| t == TITLE), "{texts:?}");
    assert!(texts.iter().any(|t| t.starts_with(CAPTION)), "{texts:?}");
    assert!(texts.iter().any(|t| t == "BDT (automatic)"), "legend kept");
    let bars = svg_texts(&copy.join("plots/bars_err_mean_unit_err_rms_unit.svg"));
    assert!(
        !bars
            .iter()
            .any(|t| t == "paper: err_mean_unit, err_rms_unit"),
        "{bars:?}"
    );
    assert!(!bars.iter().any(|t| t.starts_with(CAPTION)), "{bars:?}");
    // A plot's own `title = true` draws its title with `[outputs]` silent.
    let one = CONFIG.replace(
        "metrics = [\"err_mean_unit\", \"err_rms_unit\"]\n",
        "metrics = [\"err_mean_unit\", \"err_rms_unit\"]\ntitle = true\n",
    );
    let cfg = write(t.path(), "one.toml", &one);
    ok(&[
        "plot",
        copy.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
    ]);
    let bars = svg_texts(&copy.join("plots/bars_err_mean_unit_err_rms_unit.svg"));
    assert!(
        bars.iter()
            .any(|t| t == "paper: err_mean_unit, err_rms_unit"),
        "{bars:?}"
    );
    assert!(!bars.iter().any(|t| t.starts_with(CAPTION)), "{bars:?}");
    let texts = svg_texts(&copy.join("plots/cumulative.svg"));
    assert!(!texts.iter().any(|t| t == TITLE), "{texts:?}");
    // The chart is taller where the header was: the PNG is the same size,
    // the PDF converts.
    assert_pdf(&copy.join("plots/cumulative.pdf"));
    // A plot's own title text names it in its data files but is drawn only
    // when titles are on.
    let named = CONFIG.replace(
        "kind = \"cumulative\"\n",
        "kind = \"cumulative\"\ntitle = \"A named cumulative plot\"\n",
    );
    assert_ne!(named, CONFIG);
    for (config, drawn) in [
        (named.clone(), false),
        (
            named.replace("[outputs]\n", "[outputs]\ntitle = true\n"),
            true,
        ),
    ] {
        let cfg = write(t.path(), "named.toml", &config);
        ok(&[
            "plot",
            copy.to_str().unwrap(),
            "--config",
            cfg.to_str().unwrap(),
        ]);
        for svg in ["cumulative.svg", "cumulative_area.svg"] {
            let texts = svg_texts(&copy.join("plots").join(svg));
            assert_eq!(
                texts
                    .iter()
                    .any(|t| t.starts_with("A named cumulative plot")),
                drawn,
                "{svg}: {texts:?}"
            );
        }
    }
    // A title text must be a title.
    let bad = CONFIG.replace("[outputs]\n", "[outputs]\ntitle = 3\n");
    let cfg = write(t.path(), "bad.toml", &bad);
    let o = run(&[
        "plot",
        copy.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        e.contains("outputs.title") && e.contains("true or false"),
        "{e}"
    );
}

#[test]
fn plot_config_applies_edited_outputs_and_refuses_other_results() {
    let t = tempfile::tempdir().unwrap();
    let copy = copy_of_reference(t.path());
    let o = replot(
        &copy,
        "\n[[outputs.plots]]\nkind = \"bars\"\nfile = \"edited\"\nmetrics = [\"err_max_unit\"]\n\
         formats = [\"pdf\"]\n",
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_pdf(&copy.join("plots/edited.pdf"));
    assert!(
        !copy.join("plots/edited.png").exists(),
        "formats = [\"pdf\"]"
    );
    // Without --config: the manifest's outputs (no such plot).
    std::fs::remove_file(copy.join("plots/edited.pdf")).unwrap();
    ok(&["plot", copy.to_str().unwrap()]);
    assert!(!copy.join("plots/edited.pdf").exists());
    // A config of other results (another seed, another method count) is
    // refused, naming the keys.
    let other = CONFIG
        .replace("seed = 1\n", "seed = 2\n")
        .replace("count = 4\n", "count = 5\n");
    let cfg = write(t.path(), "other.toml", &other);
    let o = run(&[
        "plot",
        copy.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(e.contains("seed") && e.contains("methods[1].count"), "{e}");
    // With --config and no folder: ROOT/<name>.
    let cfg = write(t.path(), "same.toml", CONFIG);
    let root = t.path().join("root");
    copy_dir(&copy, &root.join("paper"));
    ok(&[
        "plot",
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
    ]);
}

#[test]
fn up_axis_is_accepted_and_turns_the_render() {
    let t = tempfile::tempdir().unwrap();
    let copy = copy_of_reference(t.path());
    let panels = plots_with(&copy, "png")
        .into_iter()
        .find(|p| p.starts_with("panels"))
        .unwrap();
    let before = std::fs::read(copy.join("plots").join(&panels)).unwrap();
    let o = replot(&copy, "").status;
    assert!(o.success());
    let same = std::fs::read(copy.join("plots").join(&panels)).unwrap();
    assert_eq!(
        before, same,
        "re-plotting unchanged outputs changed the render"
    );
    let edited = CONFIG.replace("[outputs]\n", "[outputs]\nup = \"z\"\n");
    let cfg = write(t.path(), "z.toml", &edited);
    ok(&[
        "plot",
        copy.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
    ]);
    let after = std::fs::read(copy.join("plots").join(&panels)).unwrap();
    assert_ne!(before, after, "up = \"z\" did not change the render");
    // Only y and z.
    let bad = CONFIG.replace("[outputs]\n", "[outputs]\nup = \"x\"\n");
    let e = parse_config_schema(&bad, Path::new("x.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("outputs.up") && e.contains("`y`"), "{e}");
}

#[test]
fn tosca_style_data_default_to_z_up() {
    let with = |dataset: &str, outputs: &str| {
        let text = format!(
            "name = \"t\"\n{dataset}\n[cases]\ninclude_self = true\n[[methods]]\nname = \"m\"\n\
             kind = \"identity\"\n[outputs]\n{outputs}\n"
        );
        let l = parse_config_schema(&text, Path::new("t.toml")).unwrap();
        l.config.outputs.camera(&l.config.dataset)
    };
    let tosca = "[dataset.tosca]\npath = \"nowhere\"";
    assert_eq!(with(tosca, ""), Camera::TOSCA);
    assert_eq!(with(tosca, "").up, Up::Z);
    assert_eq!(with(tosca, "up = \"y\"").up, Up::Y);
    let c = with(tosca, "camera = [90, 10]");
    assert_eq!((c.yaw_deg, c.pitch_deg, c.up), (90.0, 10.0, Up::Z));
    assert_eq!(with("", ""), Camera::FRONT);
    assert_eq!(with("", "up = \"z\"").up, Up::Z);
}

#[test]
fn render_grids_wrap_and_renders_can_be_pdf() {
    let t = tempfile::tempdir().unwrap();
    let copy = copy_of_reference(t.path());
    let panels = plots_with(&copy, "png")
        .into_iter()
        .find(|p| p.starts_with("panels"))
        .unwrap();
    let stem = panels.trim_end_matches(".png").to_string();
    // Seven panels (source, deformed source, target, truth, three
    // results): two rows by default (at most 6 a row).
    let (w1, h1) = png_size(&copy.join("plots").join(&panels));
    let edited = CONFIG.replace(
        "[outputs]\n",
        "[outputs]\nmax_per_row = 2\nformats = [\"png\", \"pdf\"]\n",
    );
    let cfg = write(t.path(), "wrap.toml", &edited);
    ok(&[
        "plot",
        copy.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
    ]);
    let (w2, h2) = png_size(&copy.join("plots").join(&panels));
    // 260 px panels: two a row plus the colour bar, four rows.
    assert!(w2 <= 2 * 260 + 200, "{w2}×{h2} (was {w1}×{h1})");
    assert!((6 * 260..7 * 260).contains(&w1), "{w1}×{h1}");
    assert!((2 * 360..3 * 360).contains(&h1), "{w1}×{h1}");
    assert!(h2 >= 4 * 360, "{w2}×{h2}");
    // The render as PDF too, and the charts as PNG + PDF only.
    assert_pdf(&copy.join(format!("plots/{stem}.pdf")));
    assert!(!copy.join(format!("plots/{stem}.svg")).exists());
    assert_pdf(&copy.join("plots/cumulative.pdf"));
    let bad = CONFIG.replace("[outputs]\n", "[outputs]\nformats = [\"png\", \"png\"]\n");
    let e = parse_config_schema(&bad, Path::new("x.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("outputs.formats") && e.contains("twice"), "{e}");
    let bad = CONFIG.replace("[outputs]\n", "[outputs]\nformats = [\"jpeg\"]\n");
    let e = parse_config_schema(&bad, Path::new("x.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("outputs.formats"), "{e}");
}

#[test]
fn table_tex_is_booktabs_and_escaped() {
    let dir = reference();
    let tex = std::fs::read_to_string(dir.join("plots/table.tex")).unwrap();
    for rule in [
        "\\toprule",
        "\\midrule",
        "\\bottomrule",
        "\\begin{tabular}{lrr}",
    ] {
        assert!(tex.contains(rule), "no {rule}: {tex}");
    }
    assert!(tex.contains("extremity\\_user &"), "{tex}");
    assert!(tex.contains("BDT (automatic) &"), "{tex}");
    assert!(
        !tex.contains("extremity_user"),
        "unescaped underscore: {tex}"
    );
    // The numbers of the Markdown table.
    let md = std::fs::read_to_string(dir.join("plots/table.md")).unwrap();
    let md_row = md
        .lines()
        .find(|l| l.starts_with("| extremity_user |"))
        .unwrap();
    let tex_row = tex
        .lines()
        .find(|l| l.starts_with("extremity\\_user &"))
        .unwrap();
    let cells = |l: &str, sep: char, skip: usize| -> Vec<String> {
        l.split(sep)
            .skip(skip)
            .map(|c| c.trim().trim_end_matches("\\\\").trim().to_string())
            .filter(|c| !c.is_empty())
            .collect()
    };
    assert_eq!(cells(md_row, '|', 2), cells(tex_row, '&', 1));
    // Compiles in a minimal document where a TeX engine is installed.
    let Some(pdflatex) = which("pdflatex") else {
        println!("SKIP table_tex compile: no pdflatex on PATH");
        return;
    };
    let t = tempfile::tempdir().unwrap();
    std::fs::copy(dir.join("plots/table.tex"), t.path().join("table.tex")).unwrap();
    write(
        t.path(),
        "doc.tex",
        "\\documentclass{article}\n\\usepackage{booktabs}\n\\begin{document}\n\
         \\begin{table}\\centering\\input{table.tex}\\caption{Means.}\\end{table}\n\
         \\end{document}\n",
    );
    let o = std::process::Command::new(pdflatex)
        .args(["-interaction=nonstopmode", "-halt-on-error", "doc.tex"])
        .current_dir(t.path())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "pdflatex failed:\n{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(t.path().join("doc.pdf").is_file());
}

fn which(program: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(program))
            .find(|p| p.is_file())
    })
}

#[test]
fn cases_csv_has_no_empty_column_and_older_tables_still_plot() {
    let dir = reference();
    let mut r = csv::Reader::from_path(dir.join("cases.csv")).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    assert_eq!(rows.len(), 3);
    for (i, h) in header.iter().enumerate() {
        assert!(
            rows.iter().any(|r| !r[i].is_empty()),
            "column {h} is empty in every row"
        );
    }
    // A subset of CASE_COLUMNS, in its order, well short of all of them.
    let pos: Vec<usize> = header
        .iter()
        .map(|h| CASE_COLUMNS.iter().position(|c| c == h).unwrap())
        .collect();
    assert!(pos.windows(2).all(|w| w[0] < w[1]), "{header:?}");
    assert!(
        header.len() < CASE_COLUMNS.len() / 2 + 10,
        "{}",
        header.len()
    );
    for c in ["ari", "fbt_task", "alpha"] {
        assert!(!header.iter().any(|h| h == c), "{c} has no value here");
    }

    // An older table with every column (empty cells) plots alike.
    let t = tempfile::tempdir().unwrap();
    let copy = copy_of_reference(t.path());
    let tidy = csv_rows(&dir.join("cases.csv"));
    let mut w = csv::Writer::from_path(copy.join("cases.csv")).unwrap();
    w.write_record(CASE_COLUMNS).unwrap();
    for row in &tidy {
        w.write_record(CASE_COLUMNS.iter().map(|c| row[*c].as_str()))
            .unwrap();
    }
    w.flush().unwrap();
    drop(w);
    std::fs::remove_dir_all(copy.join("plots")).unwrap();
    let warnings = make_plots(&copy).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(plots_with(&copy, "png"), plots_with(dir, "png"));
    assert_eq!(
        std::fs::read_to_string(copy.join("plots/table.md")).unwrap(),
        std::fs::read_to_string(dir.join("plots/table.md")).unwrap()
    );
    // A narrower one (a plotted metric absent): absent cells are empty, the
    // table shows a dash, nothing fails.
    let keep: Vec<&String> = header.iter().filter(|h| *h != "within_005_area").collect();
    let mut w = csv::Writer::from_path(copy.join("cases.csv")).unwrap();
    w.write_record(&keep).unwrap();
    for row in &tidy {
        w.write_record(keep.iter().map(|c| row[c.as_str()].as_str()))
            .unwrap();
    }
    w.flush().unwrap();
    drop(w);
    let warnings = make_plots(&copy).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let md = std::fs::read_to_string(copy.join("plots/table.md")).unwrap();
    assert!(
        md.contains("| BDT (automatic) | ") && md.contains(" – |"),
        "{md}"
    );
}

/// Per-vertex distances of `result` to `truth` in unit-sphere units of
/// `reference`.
fn errors(result: &Path, truth: &Path, reference: &Path) -> Vec<f64> {
    let (r, t, b) = (
        read_mesh(result).unwrap(),
        read_mesh(truth).unwrap(),
        read_mesh(reference).unwrap(),
    );
    let s = ErrorScale::of_reference(&b).unwrap().unit_sphere;
    vertex_errors(r.vertices(), t.vertices())
        .unwrap()
        .into_iter()
        .map(|e| e * s)
        .collect()
}

#[test]
fn result_plys_carry_the_per_vertex_error() {
    let dir = reference();
    let case = csv_rows(&dir.join("cases.csv"))[0]["case_id"].clone();
    let m = dir.join("meshes").join(&case);
    let rows = csv_rows(&dir.join("cases.csv"));
    for method in ["auto_bdt", "extremity_user", "identity"] {
        let result = m.join(method).join("result_1.ply");
        // The project's reader still reads the file.
        let mesh = read_mesh(&result).unwrap();
        let stored = read_ply_vertex_scalar(&result, "error")
            .unwrap()
            .unwrap_or_else(|| panic!("{method}: no error property"));
        assert_eq!(stored.len(), mesh.n_vertices());
        let want = errors(&result, &m.join("truth_1.ply"), &m.join("target.ply"));
        for (i, (a, b)) in stored.iter().zip(&want).enumerate() {
            assert!(
                (a - b).abs() <= 1e-6 * b.abs().max(1e-3),
                "{method} vertex {i}: stored {a}, computed {b}"
            );
        }
        // One pose: the mean is the row's err_mean_unit.
        let row = rows.iter().find(|r| r["method"] == method).unwrap();
        let mean = stored.iter().sum::<f64>() / stored.len() as f64;
        let col: f64 = row["err_mean_unit"].parse().unwrap();
        assert!(
            (mean - col).abs() <= 1e-6 * col.max(1e-9),
            "{mean} vs {col}"
        );
    }
    // The fit on the source: its error to A′ in unit-sphere units of A.
    let fit = m.join("auto_bdt/fit_1.ply");
    let stored = read_ply_vertex_scalar(&fit, "error").unwrap().unwrap();
    let want = errors(&fit, &m.join("deformed_1.ply"), &m.join("source.ply"));
    assert!(stored
        .iter()
        .zip(&want)
        .all(|(a, b)| (a - b).abs() <= 1e-6 * b.abs().max(1e-3)));
    // Meshes without a known error have no such property.
    assert_eq!(
        read_ply_vertex_scalar(&m.join("target.ply"), "error").unwrap(),
        None
    );
}

#[test]
fn meshes_as_obj_on_request() {
    let t = tempfile::tempdir().unwrap();
    let text = CONFIG.replace("[outputs]\n", "[outputs]\nmesh_format = \"obj\"\n");
    let dir = run_config(t.path(), &text);
    let case = csv_rows(&dir.join("cases.csv"))[0]["case_id"].clone();
    let m = dir.join("meshes").join(&case);
    for f in ["source.obj", "target.obj", "deformed_1.obj", "truth_1.obj"] {
        assert!(m.join(f).is_file(), "{f}");
    }
    assert!(!m.join("source.ply").exists());
    let result = m.join("auto_bdt/result_1.obj");
    let mesh = read_mesh(&result).unwrap();
    let side = std::fs::read_to_string(m.join("auto_bdt/result_1.error.txt")).unwrap();
    let values: Vec<f64> = side.lines().map(|l| l.parse().unwrap()).collect();
    assert_eq!(values.len(), mesh.n_vertices());
    let want = errors(&result, &m.join("truth_1.obj"), &m.join("target.obj"));
    for (a, b) in values.iter().zip(&want) {
        assert!((a - b).abs() <= 1e-9 * b.abs().max(1e-3), "{a} vs {b}");
    }
    // The same errors as the PLY run's (f32 there).
    let ply = read_ply_vertex_scalar(
        &reference()
            .join("meshes")
            .join(&case)
            .join("auto_bdt/result_1.ply"),
        "error",
    )
    .unwrap()
    .unwrap();
    assert!(ply
        .iter()
        .zip(&values)
        .all(|(a, b)| (a - b).abs() <= 1e-6 * b.abs().max(1e-3)));
    // The renders read the OBJ meshes.
    assert!(plots_with(&dir, "png")
        .iter()
        .any(|p| p.starts_with("panels")));
}

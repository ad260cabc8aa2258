//! `deformlab report`: one self-contained HTML page over a results root (or
//! one results folder). An index of the experiments; per experiment its
//! summary table with the floor marked, every figure of `plots/`, a sortable
//! per-case table, and the saved result meshes in a 3D viewer, coloured by
//! their per-vertex error on one scale.
//!
//! Nothing is fetched when the page is opened: figures and meshes are
//! inlined (base64), and the viewer is the page's own script (`report.js`:
//! WebGL, with a 2D canvas fallback where WebGL is unavailable). The page
//! holds no timing, date or revision, so the same folders give the same
//! bytes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::config::Config;
use super::manifest::{read_manifest, Manifest};
use super::plots::{column_label, floor_of, labels_of, read_csv, Row};
use super::store::MeshOut;
use crate::mesh::io::{read_input_text, read_mesh, read_ply_vertex_scalar, Format};
use crate::mesh::Mesh;
use crate::plot::output::{base64, write_bytes_atomic};
use crate::plot::RenderOptions;
use crate::{Error, Result};

const SCRIPT: &str = include_str!("report.js");
const STYLE: &str = include_str!("report.css");

/// Result meshes in the viewer of one experiment, by default.
pub const DEFAULT_MAX_MESHES: usize = 16;
/// Rows of the per-case table of one experiment, by default (the rest are
/// in its `cases.csv`).
pub const DEFAULT_MAX_CASE_ROWS: usize = 2000;

/// Options of a report.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReportOptions {
    /// Result meshes in each experiment's viewer.
    pub max_meshes: usize,
    /// Rows of each experiment's per-case table.
    pub max_case_rows: usize,
}

impl Default for ReportOptions {
    fn default() -> Self {
        ReportOptions {
            max_meshes: DEFAULT_MAX_MESHES,
            max_case_rows: DEFAULT_MAX_CASE_ROWS,
        }
    }
}

/// A report: the page and what it holds.
#[derive(Clone, Debug)]
pub struct Report {
    pub html: String,
    /// The experiments, in page order.
    pub experiments: Vec<String>,
    /// Figures and meshes inlined.
    pub figures: usize,
    pub meshes: usize,
    /// Experiments or parts that could not be read (the page says so too).
    pub warnings: Vec<String>,
}

/// The metrics shown first (summary and case tables), in this order, where
/// an experiment has them; every other metric is under "all metrics".
const HEADLINE: &[&str] = &[
    "err_mean_unit",
    "err_mean_unit_rigid",
    "err_mean_area",
    "err_mean_area_rigid",
    "within_005_area",
    "fit_error_unit",
    "selection_error",
    "rel_distortion_mean",
    "rel_distortion_mean_aligned",
    "floor_distortion_mean",
    "floor_distortion_mean_aligned",
    "corr_error_mean",
    "floor_corr_error_mean_euclidean",
    "gross_failure",
    "ari",
    "purity",
    "rigidity_unit",
    "alpha_error",
    "perm_correct",
    "interp_endpoint_error",
];

/// The results folders of `root`: `root` itself when it holds a
/// `manifest.json`, else its sub-folders that do, by name. Symbolic links
/// are not followed (each is a warning).
pub fn experiment_dirs(root: &Path) -> Result<(Vec<PathBuf>, Vec<String>)> {
    let meta = std::fs::metadata(root).map_err(|e| Error::io(root, e))?;
    if !meta.is_dir() {
        return Err(Error::invalid(format!(
            "{}: not a folder (give a results root, such as results/, or one results folder)",
            root.display()
        )));
    }
    if root.join("manifest.json").is_file() {
        return Ok((vec![root.to_path_buf()], Vec::new()));
    }
    let mut dirs = Vec::new();
    let mut warnings = Vec::new();
    let entries = std::fs::read_dir(root).map_err(|e| Error::io(root, e))?;
    for e in entries {
        let e = e.map_err(|e| Error::io(root, e))?;
        let path = e.path();
        let kind = e.file_type().map_err(|err| Error::io(&path, err))?;
        if kind.is_symlink() {
            if path.join("manifest.json").exists() {
                warnings.push(format!(
                    "{}: skipped: a symbolic link (the report reads results folders only)",
                    path.display()
                ));
            }
            continue;
        }
        if kind.is_dir() && path.join("manifest.json").is_file() {
            dirs.push(path);
        }
    }
    dirs.sort();
    if dirs.is_empty() {
        return Err(Error::invalid(format!(
            "{}: no results folders in it (folders with a manifest.json, as `deformlab run` writes)",
            root.display()
        )));
    }
    Ok((dirs, warnings))
}

/// Writes the report of `root` to `out` (atomically; an existing regular
/// file is replaced, anything else at `out` is refused).
pub fn write_report(root: &Path, out: &Path, o: &ReportOptions) -> Result<Report> {
    if let Ok(m) = std::fs::symlink_metadata(out) {
        if !m.file_type().is_file() {
            return Err(Error::invalid(format!(
                "{}: exists and is not a regular file (a report replaces only a file)",
                out.display()
            )));
        }
    }
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        if !parent.is_dir() {
            return Err(Error::invalid(format!(
                "{}: the folder {} does not exist",
                out.display(),
                parent.display()
            )));
        }
    }
    let report = build_report(root, o)?;
    write_bytes_atomic(out, report.html.as_bytes())?;
    Ok(report)
}

/// The report of `root` (see the module documentation).
pub fn build_report(root: &Path, o: &ReportOptions) -> Result<Report> {
    let (dirs, mut warnings) = experiment_dirs(root)?;
    let mut sections = Vec::new();
    for (i, dir) in dirs.iter().enumerate() {
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| dir.display().to_string());
        match Experiment::read(dir, &name, i, o) {
            Ok((e, w)) => {
                warnings.extend(w);
                sections.push(Ok(e));
            }
            Err(e) => {
                warnings.push(format!("{}: not in the report: {e}", dir.display()));
                sections.push(Err((name, e.to_string())));
            }
        }
    }
    let mut html = String::new();
    html.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    html.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    let _ = writeln!(
        html,
        "<title>deformlab report: {}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>",
        esc(&root.display().to_string())
    );
    let _ = writeln!(
        html,
        "<header><h1>deformlab report</h1><p class=\"meta\">{} experiment(s) in <code>{}</code>; \
         made by deformlab {}. Figures and meshes are inlined: this file is the whole report.</p></header>",
        dirs.len(),
        esc(&root.display().to_string()),
        env!("CARGO_PKG_VERSION")
    );
    html.push_str(&index(&sections));
    let (mut figures, mut meshes) = (0, 0);
    for s in &sections {
        match s {
            Ok(e) => {
                figures += e.figures.len();
                meshes += e.viewer.as_ref().map_or(0, |v| v.meshes.len());
                html.push_str(&e.section());
            }
            Err((name, msg)) => {
                let _ = writeln!(
                    html,
                    "<section class=\"experiment\" id=\"{}\"><h2>{}</h2><p class=\"error\">Could not be read: {}</p></section>",
                    anchor(name),
                    esc(name),
                    esc(msg)
                );
            }
        }
    }
    html.push_str("<script>\n");
    html.push_str(SCRIPT);
    html.push_str("</script>\n</body>\n</html>\n");
    Ok(Report {
        html,
        experiments: sections
            .iter()
            .map(|s| match s {
                Ok(e) => e.name.clone(),
                Err((n, _)) => n.clone(),
            })
            .collect(),
        figures,
        meshes,
        warnings,
    })
}

type Section = std::result::Result<Experiment, (String, String)>;

fn index(sections: &[Section]) -> String {
    let mut h = String::from(
        "<nav><h2>Experiments</h2>\n<table class=\"index sortable\"><thead><tr><th>experiment</th>\
         <th>description</th><th>dataset</th><th>cases</th><th>methods</th><th>failed</th>\
         <th>figures</th><th>meshes</th></tr></thead><tbody>\n",
    );
    for s in sections {
        match s {
            Ok(e) => {
                let _ = writeln!(
                    h,
                    "<tr><td><a href=\"#{}\">{}</a></td><td>{}</td><td>{}</td><td data-v=\"{}\">{}</td>\
                     <td data-v=\"{}\">{}</td><td data-v=\"{}\">{}</td><td data-v=\"{}\">{}</td><td data-v=\"{}\">{}</td></tr>",
                    anchor(&e.name),
                    esc(&e.name),
                    esc(e.description.as_deref().unwrap_or("")),
                    esc(&e.manifest.dataset),
                    e.manifest.n_cases,
                    e.manifest.n_cases,
                    e.manifest.methods.len(),
                    e.manifest.methods.len(),
                    e.manifest.results_failed,
                    e.manifest.results_failed,
                    e.figures.len(),
                    e.figures.len(),
                    e.viewer.as_ref().map_or(0, |v| v.meshes.len()),
                    e.viewer.as_ref().map_or(0, |v| v.meshes.len()),
                );
            }
            Err((name, _)) => {
                let _ = writeln!(
                    h,
                    "<tr><td><a href=\"#{}\">{}</a></td><td class=\"error\" colspan=\"7\">could not be read</td></tr>",
                    anchor(name),
                    esc(name)
                );
            }
        }
    }
    h.push_str("</tbody></table></nav>\n");
    h
}

/// One method's line of the summary table.
struct MethodLine {
    name: String,
    label: String,
    kind: String,
    floor: bool,
    rows: usize,
    failed: usize,
}

/// The saved meshes of one case and pose, for the viewer.
struct Viewer {
    case_id: String,
    pose: String,
    quantity: String,
    /// The top of the colour scale: the 98th percentile of the errors of
    /// the methods shown (the floor excluded when there are others).
    hi: f64,
    meshes: Vec<ViewMesh>,
}

struct ViewMesh {
    label: String,
    mesh: Mesh,
    error: Option<Vec<f64>>,
    /// The floor's result: its errors do not set the colour scale.
    floor: bool,
}

struct Experiment {
    name: String,
    index: usize,
    description: Option<String>,
    manifest: Manifest,
    floor_label: Option<&'static str>,
    methods: Vec<MethodLine>,
    /// summary.csv rows.
    summary: Vec<Row>,
    cases: Vec<Row>,
    headline: Vec<String>,
    others: Vec<String>,
    figures: Vec<(String, Vec<u8>)>,
    viewer: Option<Viewer>,
    max_case_rows: usize,
}

impl Experiment {
    fn read(
        dir: &Path,
        name: &str,
        index: usize,
        o: &ReportOptions,
    ) -> Result<(Experiment, Vec<String>)> {
        let mut warnings = Vec::new();
        let manifest = read_manifest(dir)?;
        let config: Option<Config> = match serde_json::from_value(manifest.config.clone()) {
            Ok(c) => Some(c),
            Err(e) => {
                warnings.push(format!(
                    "{}: its manifest's config is of another version ({e}): methods are shown by name",
                    dir.display()
                ));
                None
            }
        };
        let summary = read_csv(&dir.join("summary.csv"))?;
        let cases = read_csv(&dir.join("cases.csv"))?;
        let (_, method_labels) = config.as_ref().map(labels_of).unwrap_or_default();
        let floor = config.as_ref().and_then(floor_of);
        let floor_group = floor.as_ref().map(|(g, _)| g.clone());
        let group_of = |m: &str| -> String {
            config
                .as_ref()
                .and_then(|c| c.methods.iter().find(|x| x.name == m))
                .and_then(|x| x.group.clone())
                .unwrap_or_else(|| m.to_string())
        };
        let methods: Vec<MethodLine> = manifest
            .methods
            .iter()
            .map(|m| {
                let mine: Vec<&Row> = cases
                    .iter()
                    .filter(|r| r.get("method").map(String::as_str) == Some(m))
                    .collect();
                MethodLine {
                    name: m.clone(),
                    label: method_labels.get(m).cloned().unwrap_or_else(|| m.clone()),
                    kind: mine
                        .first()
                        .and_then(|r| r.get("kind"))
                        .cloned()
                        .unwrap_or_default(),
                    floor: floor_group.as_deref() == Some(group_of(m).as_str()),
                    rows: mine.len(),
                    failed: mine
                        .iter()
                        .filter(|r| r.get("status").map(String::as_str) != Some("ok"))
                        .count(),
                }
            })
            .collect();
        // Metrics with a value for some method, headline ones first.
        let mut present: Vec<String> = Vec::new();
        for r in &summary {
            if let (Some(m), Some(v)) = (r.get("metric"), r.get("mean")) {
                if v.parse::<f64>().is_ok_and(f64::is_finite)
                    && !m.starts_with("seconds_")
                    && !present.contains(m)
                {
                    present.push(m.clone());
                }
            }
        }
        let headline: Vec<String> = HEADLINE
            .iter()
            .filter(|h| present.iter().any(|p| p == *h))
            .map(|h| h.to_string())
            .collect();
        let mut others: Vec<String> = present
            .into_iter()
            .filter(|p| !headline.contains(p))
            .collect();
        others.sort();
        let figures = figures(dir)?;
        let viewer = match viewer(dir, &manifest, &methods, &cases, o.max_meshes) {
            Ok(v) => v,
            Err(e) => {
                warnings.push(format!("{}: meshes not shown: {e}", dir.display()));
                None
            }
        };
        Ok((
            Experiment {
                name: name.to_string(),
                index,
                description: config.as_ref().and_then(|c| c.description.clone()),
                manifest,
                floor_label: floor.map(|(_, l)| l),
                methods,
                summary,
                cases,
                headline,
                others,
                figures,
                viewer,
                max_case_rows: o.max_case_rows,
            },
            warnings,
        ))
    }

    fn summary_row(&self, method: &str, metric: &str) -> Option<&Row> {
        self.summary.iter().find(|r| {
            r.get("method").map(String::as_str) == Some(method)
                && r.get("metric").map(String::as_str) == Some(metric)
        })
    }

    fn section(&self) -> String {
        let m = &self.manifest;
        let mut h = String::new();
        let _ = writeln!(
            h,
            "<section class=\"experiment\" id=\"{}\">\n<h2>{}</h2>",
            anchor(&self.name),
            esc(&self.name)
        );
        if let Some(d) = &self.description {
            let _ = writeln!(h, "<p class=\"desc\">{}</p>", esc(d));
        }
        let _ = writeln!(
            h,
            "<p class=\"meta\">{}; {} case(s), {} method(s); {} result(s) stored, {} failed; config <code>{}</code>, seed {}.</p>",
            esc(&m.dataset),
            m.n_cases,
            m.methods.len(),
            m.results_stored,
            m.results_failed,
            esc(&m.config_file),
            m.seed
        );
        h.push_str(
            "<div class=\"top\">\n<div class=\"summary\">\n<h3>Summary: mean over cases</h3>\n",
        );
        h.push_str(&self.summary_table(&self.headline, "summary"));
        match self.floor_label {
            Some(l) => {
                let _ = writeln!(
                    h,
                    "<p class=\"note\">Shaded: the floor, {} — a method that does not beat it has not done anything useful. \
                     Hover a cell for the median, range and count. Click a heading to sort.</p>",
                    esc(l)
                );
            }
            None => h.push_str(
                "<p class=\"note\">This experiment runs no floor method (B unchanged, or the template undeformed); \
                 columns named floor_… give the floor per case where the task records it. Click a heading to sort.</p>\n",
            ),
        }
        if !self.others.is_empty() {
            let _ = writeln!(
                h,
                "<details><summary>All metrics ({})</summary>",
                self.others.len() + self.headline.len()
            );
            let all: Vec<String> = self.headline.iter().chain(&self.others).cloned().collect();
            h.push_str(&self.summary_table(&all, "summary all"));
            h.push_str("</details>\n");
        }
        h.push_str("</div>\n");
        h.push_str(&self.viewer_html());
        h.push_str("</div>\n");
        if !self.figures.is_empty() {
            h.push_str("<h3>Figures</h3>\n<div class=\"figures\">\n");
            for (file, bytes) in &self.figures {
                let _ = writeln!(
                    h,
                    "<figure><img alt=\"{}\" loading=\"lazy\" src=\"data:image/png;base64,{}\"><figcaption>plots/{}</figcaption></figure>",
                    esc(file),
                    base64(bytes),
                    esc(file)
                );
            }
            h.push_str("</div>\n");
        }
        h.push_str(&self.case_table());
        h.push_str("</section>\n");
        h
    }

    fn summary_table(&self, metrics: &[String], class: &str) -> String {
        let mut h = format!(
            "<table class=\"{class} sortable\"><thead><tr><th>method</th><th>kind</th><th title=\"results stored (case × pose rows)\">rows</th><th>failed</th>"
        );
        for c in metrics {
            let _ = write!(h, "<th title=\"{}\">{}</th>", esc(&column_label(c)), esc(c));
        }
        h.push_str("</tr></thead><tbody>\n");
        for ml in &self.methods {
            let _ = write!(
                h,
                "<tr{}><td title=\"{}\">{}{}</td><td>{}</td><td data-v=\"{}\">{}</td><td data-v=\"{}\">{}</td>",
                if ml.floor { " class=\"floor\"" } else { "" },
                esc(&ml.name),
                esc(&ml.label),
                if ml.floor {
                    " <span class=\"tag\">floor</span>"
                } else {
                    ""
                },
                esc(&ml.kind),
                ml.rows,
                ml.rows,
                ml.failed,
                ml.failed
            );
            for c in metrics {
                match self.summary_row(&ml.name, c) {
                    Some(r) => {
                        let mean = r.get("mean").map(String::as_str).unwrap_or("");
                        let get = |k: &str| r.get(k).map(String::as_str).unwrap_or("");
                        let _ = write!(
                            h,
                            "<td data-v=\"{}\" title=\"median {}, min {}, max {}, n {}, failed {}\">{}</td>",
                            esc(mean),
                            show_str(get("median")),
                            show_str(get("min")),
                            show_str(get("max")),
                            esc(get("n")),
                            esc(get("n_failed")),
                            show_str(mean)
                        );
                    }
                    None => h.push_str("<td data-v=\"\"></td>"),
                }
            }
            h.push_str("</tr>\n");
        }
        h.push_str("</tbody></table>\n");
        h
    }

    fn case_table(&self) -> String {
        let mut cols: Vec<&str> = vec!["case_id", "method", "status"];
        let has = |c: &str| self.cases.first().is_some_and(|r| r.contains_key(c));
        for c in ["pose", "target_noise", "q"] {
            if has(c) {
                cols.push(c);
            }
        }
        for c in &self.headline {
            if has(c) {
                cols.push(c);
            }
        }
        let mut h = format!(
            "<h3>Cases</h3>\n<p class=\"note\">{} row(s){}; every column is in <code>cases.csv</code> \
             (docs/outputs.md says what each means). Click a heading to sort.</p>\n",
            self.cases.len(),
            if self.cases.len() > self.max_case_rows {
                format!(", the first {} shown", self.max_case_rows)
            } else {
                String::new()
            }
        );
        h.push_str("<div class=\"scroll\"><table class=\"cases sortable\"><thead><tr>");
        for c in &cols {
            let _ = write!(h, "<th title=\"{}\">{}</th>", esc(&column_label(c)), esc(c));
        }
        h.push_str("</tr></thead><tbody>\n");
        for r in self.cases.iter().take(self.max_case_rows) {
            let method = r.get("method").map(String::as_str).unwrap_or("");
            let floor = self.methods.iter().any(|m| m.name == method && m.floor);
            let status = r.get("status").map(String::as_str).unwrap_or("");
            let class = match (floor, status == "ok") {
                (_, false) => " class=\"failed\"",
                (true, true) => " class=\"floor\"",
                _ => "",
            };
            let _ = write!(h, "<tr{class}>");
            for c in &cols {
                let v = r.get(*c).map(String::as_str).unwrap_or("");
                if *c == "method" {
                    let label = self
                        .methods
                        .iter()
                        .find(|m| m.name == method)
                        .map_or(method, |m| m.label.as_str());
                    let _ = write!(h, "<td title=\"{}\">{}</td>", esc(method), esc(label));
                } else if v.parse::<f64>().is_ok() {
                    let _ = write!(h, "<td data-v=\"{}\">{}</td>", esc(v), show_str(v));
                } else if *c == "status" && status != "ok" {
                    let err = r.get("error").map(String::as_str).unwrap_or("");
                    let _ = write!(h, "<td title=\"{}\">{}</td>", esc(err), esc(v));
                } else {
                    let _ = write!(h, "<td>{}</td>", esc(v));
                }
            }
            h.push_str("</tr>\n");
        }
        h.push_str("</tbody></table></div>\n");
        h
    }

    fn viewer_html(&self) -> String {
        let Some(v) = &self.viewer else {
            return "<div class=\"viewer none\"><h3>Result meshes</h3><p class=\"note\">No result meshes in \
                    <code>meshes/</code>. They are not committed with shipped results: <code>deformlab run</code> \
                    writes them for the first <code>[outputs] render_cases</code> cases.</p></div>\n"
                .to_string();
        };
        let id = format!("view-{}", self.index);
        let mut h = String::from("<div class=\"viewer\">\n<h3>Result meshes</h3>\n");
        let _ = writeln!(
            h,
            "<p class=\"meta\">Case <code>{}</code>, pose {}. Colour: {}, from 0 to {}, the 98th percentile of the methods' results (the floor excluded; larger values get the top colour; grey: no error recorded).</p>",
            esc(&v.case_id),
            esc(&v.pose),
            esc(&v.quantity),
            show(v.hi)
        );
        let _ = write!(
            h,
            "<select class=\"mesh-pick\" data-canvas=\"{id}\" aria-label=\"mesh shown\">"
        );
        for (i, m) in v.meshes.iter().enumerate() {
            let stats = match &m.error {
                Some(e) if !e.is_empty() => format!(
                    " (mean {}, max {})",
                    show(e.iter().sum::<f64>() / e.len() as f64),
                    show(e.iter().copied().fold(0.0, f64::max))
                ),
                _ => String::new(),
            };
            let _ = write!(
                h,
                "<option value=\"{i}\"{}>{}{}</option>",
                if i == first_with_error(v) {
                    " selected"
                } else {
                    ""
                },
                esc(&m.label),
                esc(&stats)
            );
        }
        h.push_str("</select>\n");
        let _ = writeln!(
            h,
            "<canvas id=\"{id}\" class=\"mesh\" width=\"520\" height=\"520\" data-meshes=\"{id}-data\"></canvas>"
        );
        let map = RenderOptions::default().colormap;
        let stops: Vec<String> = (0..=10)
            .map(|k| {
                let [r, g, b] = map.color(k as f64 / 10.0);
                format!("rgb({r},{g},{b}) {}%", k * 10)
            })
            .collect();
        let _ = writeln!(
            h,
            "<div class=\"colorbar\" style=\"background: linear-gradient(to right, {})\"></div>\
             <div class=\"cbl\"><span>0</span><span>{}</span></div>\
             <p class=\"hint\">Drag to turn, wheel to zoom, double-click to reset.</p>",
            stops.join(", "),
            show(v.hi)
        );
        let meshes: Vec<serde_json::Value> = v
            .meshes
            .iter()
            .map(|m| {
                let mut pos = Vec::with_capacity(m.mesh.n_vertices() * 12);
                for p in m.mesh.vertices() {
                    for k in 0..3 {
                        pos.extend_from_slice(&(p[k] as f32).to_le_bytes());
                    }
                }
                let mut tri = Vec::with_capacity(m.mesh.faces().len() * 12);
                for f in m.mesh.faces() {
                    for &i in f {
                        tri.extend_from_slice(&(i as u32).to_le_bytes());
                    }
                }
                let rgb: Vec<u8> = match &m.error {
                    Some(e) => e
                        .iter()
                        .flat_map(|x| map.color(if x.is_finite() { x / v.hi } else { 0.0 }))
                        .collect(),
                    None => [200u8, 200, 200].repeat(m.mesh.n_vertices()),
                };
                serde_json::json!({
                    "label": m.label,
                    "pos": base64(&pos),
                    "tri": base64(&tri),
                    "rgb": base64(&rgb),
                })
            })
            .collect();
        let data = serde_json::json!({ "meshes": meshes, "first": first_with_error(v) });
        let _ = writeln!(
            h,
            "<script type=\"application/json\" id=\"{id}-data\">{}</script>\n</div>",
            data.to_string().replace("</", "<\\/")
        );
        h
    }
}

/// The viewer's first mesh: the first method's result that carries an
/// error (the floor's only when no other has one).
fn first_with_error(v: &Viewer) -> usize {
    v.meshes
        .iter()
        .position(|m| m.error.is_some() && !m.floor)
        .or_else(|| v.meshes.iter().position(|m| m.error.is_some()))
        .unwrap_or(0)
}

/// The PNG figures of `dir/plots/`, by file name (regular files only).
fn figures(dir: &Path) -> Result<Vec<(String, Vec<u8>)>> {
    let plots = dir.join("plots");
    let Ok(entries) = std::fs::read_dir(&plots) else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    for e in entries {
        let e = e.map_err(|e| Error::io(&plots, e))?;
        let name = e.file_name().to_string_lossy().into_owned();
        let regular = e.file_type().is_ok_and(|t| t.is_file());
        if regular && name.ends_with(".png") {
            let bytes = std::fs::read(e.path()).map_err(|err| Error::io(e.path(), err))?;
            out.push((name, bytes));
        }
    }
    out.sort();
    Ok(out)
}

/// The meshes of the first case with saved results: the target, the truth
/// of the first pose that has results, the floor's result, then each other
/// method's result (fits where no method saved a result), at most `max` in
/// all.
fn viewer(
    dir: &Path,
    manifest: &Manifest,
    methods: &[MethodLine],
    cases: &[Row],
    max: usize,
) -> Result<Option<Viewer>> {
    if max == 0 {
        return Ok(None);
    }
    for case in &manifest.cases {
        let mdir = dir.join("meshes").join(&case.id);
        if !mdir.is_dir() {
            continue;
        }
        for pose in &case.poses {
            let mut stem = "result";
            let mut saved: Vec<(&MethodLine, PathBuf)> = methods
                .iter()
                .filter_map(|m| {
                    MeshOut::find(&mdir.join(&m.name), &format!("result_{pose}")).map(|p| (m, p))
                })
                .collect();
            if saved.is_empty() {
                stem = "fit";
                saved = methods
                    .iter()
                    .filter_map(|m| {
                        MeshOut::find(&mdir.join(&m.name), &format!("fit_{pose}")).map(|p| (m, p))
                    })
                    .collect();
            }
            if saved.is_empty() {
                continue;
            }
            let mut meshes = Vec::new();
            let plain = |label: String, file: &str| -> Result<Option<ViewMesh>> {
                MeshOut::find(&mdir, file)
                    .map(|p| {
                        Ok(ViewMesh {
                            label,
                            mesh: read_mesh(&p)?,
                            error: None,
                            floor: false,
                        })
                    })
                    .transpose()
            };
            let fbt = saved
                .iter()
                .all(|(m, _)| m.kind == "fbt" || m.kind.is_empty());
            if stem == "fit" {
                meshes.extend(plain("A (source)".into(), "source")?);
                meshes.extend(plain(
                    format!("A′ (pose {pose})"),
                    &format!("deformed_{pose}"),
                )?);
            } else if fbt {
                meshes.extend(plain("template (reference shape)".into(), "source")?);
                meshes.extend(plain(
                    format!("full target, ground truth (pose {pose})"),
                    &format!("truth_{pose}"),
                )?);
            } else {
                meshes.extend(plain("B (target, undeformed)".into(), "target")?);
                meshes.extend(plain(
                    format!("B′ ground truth (pose {pose})"),
                    &format!("truth_{pose}"),
                )?);
            }
            // The floor first, so that a cut keeps it.
            saved.sort_by_key(|(m, _)| !m.floor);
            for (m, path) in saved {
                let mesh = read_mesh(&path)?;
                let error = read_error(&path)?;
                if let Some(e) = &error {
                    if e.len() != mesh.n_vertices() {
                        return Err(Error::invalid(format!(
                            "{}: {} error values for {} vertices",
                            path.display(),
                            e.len(),
                            mesh.n_vertices()
                        )));
                    }
                }
                meshes.push(ViewMesh {
                    label: if m.floor {
                        format!("{} (floor)", m.label)
                    } else {
                        m.label.clone()
                    },
                    mesh,
                    error,
                    floor: m.floor,
                });
            }
            meshes.truncate(max);
            // The scale of the methods' errors: the floor's, far larger,
            // would leave every method at the bottom of the colour map.
            let scaled = |m: &&ViewMesh| m.error.is_some() && !m.floor;
            let basis: Vec<&ViewMesh> = if meshes.iter().any(|m| scaled(&m)) {
                meshes.iter().filter(scaled).collect()
            } else {
                meshes.iter().collect()
            };
            let mut all: Vec<f64> = basis
                .iter()
                .filter_map(|m| m.error.as_ref())
                .flatten()
                .copied()
                .filter(|x| x.is_finite())
                .collect();
            all.sort_by(f64::total_cmp);
            let hi = all
                .get(((all.len() as f64) * 0.98) as usize)
                .or(all.last())
                .copied()
                .unwrap_or(0.0)
                .max(1e-6);
            let kind = cases
                .iter()
                .find(|r| r.get("case_id") == Some(&case.id))
                .and_then(|r| r.get("kind"))
                .map(String::as_str)
                .unwrap_or("");
            let quantity = match (stem, kind) {
                ("fit", _) => "distance to A′ (unit-sphere units of A)",
                (_, "fbt") => "relative distortion (√area units)",
                _ => "distance to the ground truth (unit-sphere units of B)",
            };
            return Ok(Some(Viewer {
                case_id: case.id.clone(),
                pose: pose.clone(),
                quantity: quantity.to_string(),
                hi,
                meshes,
            }));
        }
    }
    Ok(None)
}

/// The per-vertex error saved with a result mesh: the PLY property
/// `error`, or `<stem>.error.txt` beside an OBJ; `None` when there is none.
fn read_error(path: &Path) -> Result<Option<Vec<f64>>> {
    if Format::of_path(path) != Some(Format::Obj) {
        return read_ply_vertex_scalar(path, "error");
    }
    let side = path.with_extension("error.txt");
    if !side.is_file() {
        return Ok(None);
    }
    let text = read_input_text(&side)?;
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            l.trim()
                .parse::<f64>()
                .map_err(|e| Error::parse(&side, format!("line {}", i + 1), format!("'{l}': {e}")))
        })
        .collect::<Result<Vec<f64>>>()
        .map(Some)
}

/// HTML text and attribute escaping.
fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            _ => o.push(c),
        }
    }
    o
}

/// An element id for an experiment name (names are file-name safe).
fn anchor(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect();
    format!("exp-{s}")
}

/// A number for a table cell: four significant digits, scientific notation
/// outside [1e-3, 1e5).
fn show(x: f64) -> String {
    if !x.is_finite() {
        return if x.is_nan() {
            "NaN".into()
        } else {
            x.to_string()
        };
    }
    let a = x.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{x:.3e}")
    } else {
        let d = (3 - a.log10().floor() as i32).max(0) as usize;
        format!("{x:.d$}")
    }
}

/// [`show`] of a CSV cell (text that is not a number is kept, escaped).
fn show_str(s: &str) -> String {
    match s.parse::<f64>() {
        Ok(x) => show(x),
        Err(_) => esc(s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_four_significant_digits() {
        assert_eq!(show(0.0), "0");
        assert_eq!(show(0.012346), "0.01235");
        assert_eq!(show(1.5), "1.500");
        assert_eq!(show(1234.4), "1234");
        assert_eq!(show(123456.0), "1.235e5");
        assert_eq!(show(0.0001234), "1.234e-4");
        assert_eq!(show(-0.5), "-0.5000");
        assert_eq!(show(f64::NAN), "NaN");
        assert_eq!(show_str("x<y"), "x&lt;y");
    }

    #[test]
    fn text_is_escaped_for_html() {
        assert_eq!(
            esc("<b a=\"1\">'&'</b>"),
            "&lt;b a=&quot;1&quot;&gt;&#39;&amp;&#39;&lt;/b&gt;"
        );
        assert_eq!(anchor("fig 7/x"), "exp-fig-7-x");
    }
}

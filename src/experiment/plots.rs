//! `deformlab plot RESULTS_DIR`: every plot of an experiment regenerated from
//! its `manifest.json` (the config, with its `[[outputs.plots]]`),
//! `cases.csv`, `curves.csv` and the saved meshes alone, drawn by
//! [`crate::plot`]. A plot that cannot be made is a warning, not an error.
//!
//! Methods are aggregated by their `group` (default: the method name), in
//! config order. Without `[[outputs.plots]]` the defaults are: cumulative
//! error curves and error bars when a method transfers, cluster scores when
//! one clusters, and mesh panels.
//!
//! **Cumulative plots** (`kind = "cumulative"`) write one file per curve
//! present in `curves.csv`: `<file>.png` (errors in unit-sphere units),
//! `<file>_area.png` (√area(B) units), `<file>_area_rigid.png` (√area(B)
//! units after the best rigid alignment of each result onto its truth, curve
//! `cumulative_area_rigid`), `<file>_distortion.png` and
//! `<file>_correspondence.png` (`<file>` defaults to `cumulative`). The
//! group of the first `kind = "identity"` method (the target left unchanged)
//! is always drawn, even when the spec's `methods` list leaves it out, as a
//! dashed grey line labelled "identity (B unchanged)": the floor every
//! method must beat (for FBT completion, the first `solver = "template"`
//! method, labelled "template (undeformed)"). `_correspondence.png` is the geodesic correspondence
//! curve (`correspondence_geodesic_area`, Kim et al.; results of older
//! runs call it `correspondence_area`), `_correspondence_euclidean.png` the
//! Euclidean one (`correspondence_euclidean_area`, FBT Fig. 7 right).
//!
//! **Curve panels** (`kind = "curve_panels"`, `curves = [...]`): one figure,
//! one titled panel per named curve of `curves.csv` (mean curve per method
//! group; the identity floor as above), one legend below shared by every
//! panel; `labels` renames panels (by curve name) and legend entries (by
//! method group).
//!
//! **Pivot tables** (`kind = "pivot"`, `rows`, `columns`, `metric`, optional
//! `scale`, `digits`, `lead`, `lead_from`, `labels`): the mean of `metric`
//! over the results with each (row value, column value) pair, as a figure,
//! CSV (scaled means, 10 significant digits), Markdown and LaTeX.
//!
//! **Output settings** (`[outputs]`, per plot where noted): `title` /
//! `subtitle` (on, off, or a text), `formats` (charts PNG + SVG + PDF,
//! renders PNG by default), `up` and `camera` of renders (default per data
//! set, [`super::config::DatasetSpec::default_camera`]), `max_per_row`;
//! method groups are shown by their methods' `label`, a plot's `labels` map
//! overriding it. [`make_plots_with`] takes these from a config file rather
//! than the manifest.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::config::{Config, LoadedConfig, PlotKind, PlotSpec, TitleSpec};
use super::manifest::read_manifest;
use super::store::{describe, MeshOut};
use crate::eval::{vertex_errors, ErrorScale};
use crate::mesh::io::read_mesh;
use crate::mesh::Mesh;
use crate::plot::{
    save_bar_chart_as, save_figure_as, save_line_chart_as, save_line_panels_as, save_table_as,
    BarChart, Coloring, Figure, LineChart, LinePanels, Panel, RenderOptions, Series, Table,
};
use crate::{Error, Result};

type Row = BTreeMap<String, String>;

/// (group, mesh, per-vertex error, key points) of one result panel.
type ResultPanel = (String, Mesh, Vec<f64>, Vec<(usize, usize)>);

fn read_csv(path: &Path) -> Result<Vec<Row>> {
    let mut r =
        csv::Reader::from_path(path).map_err(|e| Error::parse(path, "CSV", e.to_string()))?;
    let headers = r
        .headers()
        .map_err(|e| Error::parse(path, "header", e.to_string()))?
        .clone();
    let mut out = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| Error::parse(path, format!("row {}", i + 2), e.to_string()))?;
        out.push(
            headers
                .iter()
                .zip(rec.iter())
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect(),
        );
    }
    Ok(out)
}

fn f(row: &Row, col: &str) -> Option<f64> {
    row.get(col)
        .and_then(|s| s.parse::<f64>().ok())
        .filter(|x| x.is_finite())
}

/// Readable axis label of a cases.csv column.
pub fn column_label(c: &str) -> String {
    match c {
        "err_mean_unit" => "mean error to ground truth (unit-sphere units)".into(),
        "err_rms_unit" => "RMS error to ground truth (unit-sphere units)".into(),
        "err_max_unit" => "max error to ground truth (unit-sphere units)".into(),
        "err_mean_area" => "mean error to ground truth (√area units)".into(),
        "err_rms_area" => "RMS error to ground truth (√area units)".into(),
        "err_max_area" => "max error to ground truth (√area units)".into(),
        "fit_error_unit" => "mean fit error on the source (unit-sphere units)".into(),
        "selection_error" => "key point selection error Ê".into(),
        "n_keypoints" => "number of key points".into(),
        "n_selection_poses" => "deformed examples used for selection (m)".into(),
        "arap_energy" => "relative ARAP energy of B′ vs B".into(),
        "ari" => "adjusted Rand index vs true bones".into(),
        "purity" => "purity vs true bones".into(),
        "rigidity_unit" => "per-cluster rigid-fit RMS residual (unit-sphere units)".into(),
        "q" => "number of example shapes q".into(),
        "rel_distortion_mean" => "mean relative distortion (√area units)".into(),
        "rel_distortion_max" => "max relative distortion (√area units)".into(),
        "rel_distortion_mean_init" => "mean relative distortion before NICP (√area units)".into(),
        "rel_distortion_median" => "median relative distortion (√area units)".into(),
        "rel_distortion_median_init" => {
            "median relative distortion before NICP (√area units)".into()
        }
        "corr_error_mean" | "corr_error_mean_geodesic" => {
            "mean geodesic correspondence error (√area units)".into()
        }
        "corr_error_mean_euclidean" => "mean Euclidean correspondence error (√area units)".into(),
        "rel_distortion_mean_aligned" => {
            "mean relative distortion after best rigid alignment (√area units)".into()
        }
        "rel_distortion_max_aligned" => {
            "max relative distortion after best rigid alignment (√area units)".into()
        }
        "floor_distortion_mean" => "floor: template undeformed, mean distortion".into(),
        "floor_distortion_mean_aligned" => {
            "floor: template undeformed, rigidly aligned, mean distortion".into()
        }
        "floor_corr_error_mean_euclidean" => {
            "floor: template undeformed, mean Euclidean correspondence error".into()
        }
        "seconds_iteration_init" => "one E_total iteration, init dictionary (s)".into(),
        "seconds_iteration_main" => "one E_total iteration, main dictionary (s)".into(),
        "seconds_iteration_rich" => "one E_total iteration, rich dictionary (s)".into(),
        "seconds_solve" => "full solve after precomputation (s)".into(),
        "alpha" => "recovered global scale α".into(),
        "alpha_true" => "applied scale".into(),
        "alpha_error" => "|α − scale| / scale".into(),
        "alpha_unscaled" => "α of the unscaled target".into(),
        "alpha_oracle" => "α of the true target (energy's own)".into(),
        "alpha_vertex_oracle" => "α of the true target, one rotation per vertex".into(),
        "alpha_oracle_error" => "|α − α of the true target| / α of the true target".into(),
        "alpha_ratio_error" => "|α / α(unscaled) − scale| / scale".into(),
        "perm_correct" => "share of trials with the true assignment".into(),
        "dict_size" => "dictionary size b".into(),
        "arap_energy_linear" => "relative ARAP energy of the linear blend".into(),
        "target_noise" => "target key point noise radius r (√area units)".into(),
        "target_keypoint_error_area" => "target key point error (geodesic, √area units)".into(),
        "registration_residual_area" => "registration residual (√area units)".into(),
        c if c.starts_with("seconds_") => {
            format!("{} (s)", c.trim_start_matches("seconds_").replace('_', " "))
        }
        c => c.replace('_', " "),
    }
}

/// The display name of a cases.csv column in a plot: its `labels` entry,
/// else [`column_label`].
fn metric_label(spec: &PlotSpec, c: &str) -> String {
    spec.labels
        .get(c)
        .cloned()
        .unwrap_or_else(|| column_label(c))
}

struct Ctx {
    dir: PathBuf,
    config: Config,
    /// Prefix of the default titles.
    title: String,
    /// Whether plots without a `title` of their own have one.
    titles: bool,
    /// Whether plots without a `subtitle` of their own have one.
    subtitles: bool,
    /// The provenance line (data set, cases).
    caption: String,
    /// Display names of the method groups (the methods' `label`s).
    group_labels: BTreeMap<String, String>,
    /// Display names of the methods (`label`, else their group's).
    method_labels: BTreeMap<String, String>,
    rows: Vec<Row>,
    curves: Vec<Row>,
    /// Groups in config order, with their methods.
    groups: Vec<(String, Vec<String>)>,
    /// The group of the first `kind = "identity"` method (B left unchanged):
    /// the floor of every transfer evaluation.
    identity_group: Option<String>,
    /// Legend entry of the floor.
    floor_label: &'static str,
    warnings: Vec<String>,
}

impl Ctx {
    fn rows_of_group(&self, g: &str) -> Vec<&Row> {
        self.rows
            .iter()
            .filter(|r| r.get("group").map(String::as_str) == Some(g))
            .filter(|r| r.get("status").map(String::as_str) == Some("ok"))
            .collect()
    }

    fn stem(&self, spec: &PlotSpec, default: &str) -> PathBuf {
        self.dir
            .join("plots")
            .join(spec.file.clone().unwrap_or_else(|| default.to_string()))
    }

    /// The title of a plot: `default()` unless the plot's `title` or
    /// `[outputs] title` says otherwise ("" for none).
    fn title(&self, spec: &PlotSpec, default: impl FnOnce() -> String) -> String {
        match &spec.title {
            Some(TitleSpec::Text(t)) => t.clone(),
            Some(TitleSpec::Show(false)) => String::new(),
            Some(TitleSpec::Show(true)) => default(),
            None if self.titles => default(),
            None => String::new(),
        }
    }

    /// The title text of a data file (Markdown, LaTeX comment): the plot's
    /// own title, else `default()`, whether or not figures show titles.
    fn title_text(&self, spec: &PlotSpec, default: impl FnOnce() -> String) -> String {
        match &spec.title {
            Some(TitleSpec::Text(t)) => t.clone(),
            _ => default(),
        }
    }

    /// The subtitle of a plot: `text` unless the plot's `subtitle` or
    /// `[outputs] subtitle` is false.
    fn subtitle(&self, spec: &PlotSpec, text: String) -> Option<String> {
        spec.subtitle.unwrap_or(self.subtitles).then_some(text)
    }

    /// The display name of a method group: the plot's `labels`, else the
    /// group's method `label`, else `fallback` (the group name, or the
    /// floor's legend entry).
    fn group_label(&self, spec: &PlotSpec, group: &str, fallback: &str) -> String {
        spec.labels
            .get(group)
            .or_else(|| self.group_labels.get(group))
            .cloned()
            .unwrap_or_else(|| fallback.to_string())
    }

    /// The display name of a method: the plot's `labels` (by method, then
    /// by group), else the method's (or its group's) `label`, else its name.
    fn method_label(&self, spec: &PlotSpec, method: &str) -> String {
        if let Some(l) = spec.labels.get(method) {
            return l.clone();
        }
        let group = self
            .groups
            .iter()
            .find(|(_, ms)| ms.iter().any(|m| m == method))
            .map(|(g, _)| g.as_str());
        group
            .and_then(|g| spec.labels.get(g))
            .or_else(|| self.method_labels.get(method))
            .cloned()
            .unwrap_or_else(|| method.to_string())
    }

    /// The render options of the figures (panels per row).
    fn render_options(&self) -> RenderOptions {
        RenderOptions {
            max_per_row: self.config.outputs.max_per_row(),
            ..RenderOptions::default()
        }
    }

    fn warn(&mut self, what: &str, r: Result<()>) {
        if let Err(e) = r {
            self.warnings
                .push(format!("{}: plot {what}: {e}", self.dir.display()));
        }
    }
}

/// Makes every plot of the results folder `dir`; returns the warnings
/// (plots that could not be made). Errors only if the folder's manifest or
/// tables cannot be read.
pub fn make_plots(dir: &Path) -> Result<Vec<String>> {
    make_plots_with(dir, None)
}

/// [`make_plots`], with the output settings (`[outputs]`, `description`,
/// the methods' `label`s) of `config` instead of those recorded in the
/// folder's manifest: edits to a config's plots apply without recomputing.
/// Errors, naming the keys, when `config` differs from the folder's in
/// anything else (it would describe other results).
pub fn make_plots_with(dir: &Path, config: Option<&LoadedConfig>) -> Result<Vec<String>> {
    let manifest = read_manifest(dir)?;
    let recorded: Config = serde_json::from_value(manifest.config.clone())
        .map_err(|e| Error::parse(dir.join("manifest.json"), "config", e.to_string()))?;
    let config = match config {
        None => recorded,
        Some(l) => {
            let (a, b) = (recorded.hashed_part(), l.config.hashed_part());
            if a != b {
                let (ja, jb) = (
                    serde_json::to_value(&a).unwrap_or_default(),
                    serde_json::to_value(&b).unwrap_or_default(),
                );
                let mut keys = Vec::new();
                super::store::json_diff("", &ja, &jb, &mut keys);
                return Err(Error::invalid(format!(
                    "{}: its results are not those of {}: they differ in {} (only \
                     [outputs], description and the methods' labels may change)",
                    dir.display(),
                    l.path.display(),
                    if keys.is_empty() {
                        "the config".to_string()
                    } else {
                        keys.join(", ")
                    }
                )));
            }
            l.config.clone()
        }
    };
    let rows = read_csv(&dir.join("cases.csv"))?;
    let curves = read_csv(&dir.join("curves.csv"))?;
    let mut groups: Vec<(String, Vec<String>)> = Vec::new();
    for m in &config.methods {
        let g = m.group.clone().unwrap_or_else(|| m.name.clone());
        match groups.iter_mut().find(|(x, _)| *x == g) {
            Some((_, v)) => v.push(m.name.clone()),
            None => groups.push((g, vec![m.name.clone()])),
        }
    }
    // The floor: B left unchanged (transfer) or the template left
    // undeformed (completion), whichever the config has first.
    let floor = config.methods.iter().find_map(|m| {
        let label = if m.kind == super::config::MethodKind::Identity {
            IDENTITY_LABEL
        } else if m
            .fbt
            .as_ref()
            .is_some_and(|f| f.solver == Some(crate::methods::completion::SolverKind::Template))
        {
            TEMPLATE_LABEL
        } else {
            return None;
        };
        Some((m.group.clone().unwrap_or_else(|| m.name.clone()), label))
    });
    let (identity_group, floor_label) = match floor {
        Some((g, l)) => (Some(g), l),
        None => (None, IDENTITY_LABEL),
    };
    let n_cases = rows
        .iter()
        .filter_map(|r| r.get("case"))
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let title = match &config.outputs.title {
        Some(TitleSpec::Text(t)) => t.clone(),
        _ => config.name.clone(),
    };
    let titles = config.outputs.title != Some(TitleSpec::Show(false));
    let subtitles = config.outputs.subtitle.unwrap_or(true);
    let caption = format!("{}; {} case(s)", manifest.dataset, n_cases);
    let mut group_labels: BTreeMap<String, String> = BTreeMap::new();
    let mut method_labels: BTreeMap<String, String> = BTreeMap::new();
    for m in &config.methods {
        let g = m.group.clone().unwrap_or_else(|| m.name.clone());
        if let Some(l) = &m.label {
            group_labels.entry(g).or_insert_with(|| l.clone());
            method_labels.insert(m.name.clone(), l.clone());
        }
    }
    for m in &config.methods {
        let g = m.group.clone().unwrap_or_else(|| m.name.clone());
        if let Some(l) = group_labels.get(&g) {
            method_labels
                .entry(m.name.clone())
                .or_insert_with(|| l.clone());
        }
    }
    std::fs::create_dir_all(dir.join("plots")).map_err(|e| Error::io(dir.join("plots"), e))?;
    let mut ctx = Ctx {
        dir: dir.to_path_buf(),
        config,
        title,
        titles,
        subtitles,
        caption,
        group_labels,
        method_labels,
        rows,
        curves,
        groups,
        identity_group,
        floor_label,
        warnings: Vec::new(),
    };
    let mut specs = ctx.config.outputs.plots.clone();
    if specs.is_empty() {
        specs = default_plots(&ctx.config);
    }
    let all_groups = ctx.groups.clone();
    for spec in &specs {
        ctx.groups = all_groups
            .iter()
            .filter_map(|(g, ms)| {
                let keep: Vec<String> = ms
                    .iter()
                    .filter(|m| spec.methods.is_empty() || spec.methods.contains(m))
                    .cloned()
                    .collect();
                (!keep.is_empty()).then(|| (g.clone(), keep))
            })
            .collect();
        // Cumulative curves always show the identity floor, even when the
        // spec lists its methods without it.
        if spec.kind == PlotKind::Cumulative || spec.kind == PlotKind::CurvePanels {
            if let Some(ig) = &ctx.identity_group {
                if !ctx.groups.iter().any(|(g, _)| g == ig) {
                    if let Some(e) = all_groups.iter().find(|(g, _)| g == ig) {
                        ctx.groups.push(e.clone());
                    }
                }
            }
        }
        let r = match spec.kind {
            PlotKind::Cumulative => cumulative(&ctx, spec),
            PlotKind::Bars => bars(&ctx, spec),
            PlotKind::Trace => trace(&ctx, spec),
            PlotKind::Line => line(&ctx, spec),
            PlotKind::Timing => timing(&ctx, spec),
            PlotKind::Panels => panels(&ctx, spec),
            PlotKind::Clusters => clusters(&ctx, spec),
            PlotKind::Table => table(&ctx, spec),
            PlotKind::CurvePanels => curve_panels(&ctx, spec),
            PlotKind::Pivot => pivot(&ctx, spec),
        };
        ctx.warn(&format!("{:?}", spec.kind).to_lowercase(), r);
    }
    Ok(ctx.warnings)
}

pub(super) fn default_plots(c: &Config) -> Vec<PlotSpec> {
    use super::config::MethodKind;
    let spec = |kind, metrics: &[&str]| PlotSpec::new(kind, metrics);
    let mut v = Vec::new();
    if c.methods.iter().any(|m| m.kind == MethodKind::Fbt) {
        v.push(spec(PlotKind::Cumulative, &[]));
        v.push(spec(PlotKind::Bars, &["rel_distortion_mean"]));
    }
    if c.methods
        .iter()
        .any(|m| m.kind != MethodKind::Clustering && m.kind != MethodKind::Fbt)
    {
        v.push(spec(PlotKind::Cumulative, &[]));
        v.push(spec(PlotKind::Bars, &["err_mean_unit"]));
        v.push(spec(PlotKind::Panels, &[]));
    }
    if c.methods.iter().any(|m| m.kind == MethodKind::Clustering) {
        v.push(spec(PlotKind::Bars, &["ari", "purity"]));
        v.push(spec(PlotKind::Clusters, &[]));
    }
    v
}

/// Legend entry of the identity floor in cumulative plots.
const IDENTITY_LABEL: &str = "identity (B unchanged)";
/// Legend entry of the completion floor (`solver = "template"`).
const TEMPLATE_LABEL: &str = "template (undeformed)";

/// Cumulative curves of every method group (see the module documentation):
/// `cumulative` (unit-sphere units), `cumulative_area` (√area units),
/// `cumulative_area_rigid` (√area units, after the best rigid alignment of
/// each result onto its truth), `cumulative_distortion` and
/// `cumulative_correspondence`, each written when some result has its curve.
/// The identity group is drawn as a dashed grey floor.
fn cumulative(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    for (curve, x_label, y_label, suffix) in [
        (
            "cumulative_unit",
            "error bound (unit-sphere units of B)",
            "vertices within the bound (%)",
            "",
        ),
        (
            "cumulative_area",
            "error bound (√area(B) units)",
            "vertices within the bound (%)",
            "_area",
        ),
        (
            "cumulative_area_rigid",
            "error bound after best rigid alignment (√area(B) units)",
            "vertices within the bound (%)",
            "_area_rigid",
        ),
        (
            "distortion_area",
            "bound on |log(face area / area on B)|",
            "faces within the bound (%)",
            "_distortion",
        ),
        (
            "correspondence_geodesic_area",
            "geodesic error bound (√area units)",
            "correspondences within the bound (%)",
            "_correspondence",
        ),
        (
            "correspondence_euclidean_area",
            "Euclidean error bound (√area units)",
            "correspondences within the bound (%)",
            "_correspondence_euclidean",
        ),
    ] {
        let MeanCurves {
            mut series,
            floor,
            cases: curve_cases,
        } = mean_curves(ctx, spec, curve);
        for sr in &mut series {
            sr.y.iter_mut().for_each(|y| *y *= 100.0);
        }
        if series.is_empty() {
            if curve == "cumulative_unit" {
                return Err(Error::invalid(format!("no {curve} curves in curves.csv")));
            }
            continue;
        }
        let title = match (&spec.title, suffix) {
            (Some(TitleSpec::Text(t)), "") => t.clone(),
            (Some(TitleSpec::Text(t)), _) => format!("{t} ({})", suffix.trim_start_matches('_')),
            _ => ctx.title(spec, || match suffix {
                "_distortion" => format!("{}: cumulative area distortion", ctx.title),
                "_correspondence" => {
                    format!("{}: geodesic correspondence error (Kim et al.)", ctx.title)
                }
                "_correspondence_euclidean" => {
                    format!("{}: Euclidean correspondence error", ctx.title)
                }
                _ => format!("{}: cumulative error to ground truth", ctx.title),
            }),
        };
        let chart = LineChart {
            title,
            caption: ctx.subtitle(
                spec,
                format!(
                    "{}; mean curve over the {} case(s) with {}",
                    ctx.caption,
                    curve_cases.len(),
                    if suffix == "_distortion" || suffix.starts_with("_correspondence") {
                        "results"
                    } else {
                        "ground truth"
                    }
                ),
            ),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series,
            x_range: None,
            y_range: Some((0.0, 100.0)),
            log_y: false,
            markers: false,
            floor,
        };
        let stem = ctx.stem(spec, "cumulative");
        let stem = stem.with_file_name(format!(
            "{}{suffix}",
            stem.file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        ));
        save_line_chart_as(&chart, &stem, ctx.config.outputs.chart_formats(spec))?;
    }
    Ok(())
}

/// Mean curves of the shown method groups (see [`mean_curves`]).
struct MeanCurves {
    /// One series per group with the curve, y as stored (a fraction for
    /// cumulative curves).
    series: Vec<Series>,
    /// Index of the identity group's series, labelled with the floor label.
    floor: Option<usize>,
    /// Case ids with the curve.
    cases: std::collections::BTreeSet<String>,
}

/// Whether a curves.csv row's curve is `wanted` (results written before the
/// geodesic correspondence curve was named `correspondence_geodesic_area`
/// call it `correspondence_area`).
fn is_curve(r: &Row, wanted: &str) -> bool {
    match r.get("curve").map(String::as_str) {
        Some(c) if c == wanted => true,
        Some("correspondence_area") => wanted == "correspondence_geodesic_area",
        _ => false,
    }
}

/// The mean over the case × method curves `curve` of each shown group, in
/// group order, sorted by x; labelled with the groups' display names.
fn mean_curves(ctx: &Ctx, spec: &PlotSpec, curve: &str) -> MeanCurves {
    let mut series = Vec::new();
    let mut floor = None;
    let mut cases = std::collections::BTreeSet::new();
    for (g, methods) in &ctx.groups {
        let mut acc: BTreeMap<String, (f64, f64, usize)> = BTreeMap::new();
        for r in &ctx.curves {
            if !is_curve(r, curve) || !methods.iter().any(|m| Some(m) == r.get("method")) {
                continue;
            }
            if let Some(c) = r.get("case_id") {
                cases.insert(c.clone());
            }
            let (Some(x), Some(y)) = (f(r, "x"), f(r, "y")) else {
                continue;
            };
            let e = acc.entry(r["x"].clone()).or_insert((x, 0.0, 0));
            e.1 += y;
            e.2 += 1;
        }
        if acc.is_empty() {
            continue;
        }
        let mut pts: Vec<(f64, f64)> = acc.values().map(|&(x, s, n)| (x, s / n as f64)).collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let is_floor = ctx.identity_group.as_ref() == Some(g);
        if is_floor {
            floor = Some(series.len());
        }
        series.push(Series {
            label: ctx.group_label(spec, g, if is_floor { ctx.floor_label } else { g }),
            x: pts.iter().map(|p| p.0).collect(),
            y: pts.iter().map(|p| p.1).collect(),
        });
    }
    MeanCurves {
        series,
        floor,
        cases,
    }
}

/// Panel title, x label, y label of a curves.csv curve, and whether it is
/// cumulative (a share, drawn in percent).
fn curve_info(curve: &str) -> (String, String, String, bool) {
    let share = |t: &str, x: &str, y: &str| (t.to_string(), x.to_string(), y.to_string(), true);
    match curve {
        "cumulative_unit" => share(
            "Distance to the true position",
            "distance bound (unit-sphere units)",
            "points within the bound (%)",
        ),
        "cumulative_area" => share(
            "Distortion",
            "relative distance to the true position (√area units)",
            "points within the distance (%)",
        ),
        "cumulative_area_rigid" => share(
            "Distortion after rigid alignment",
            "relative distance to the true position (√area units)",
            "points within the distance (%)",
        ),
        "distortion_area" => share(
            "Area distortion",
            "bound on |log(face area / area on B)|",
            "faces within the bound (%)",
        ),
        "correspondence_euclidean_area" => share(
            "Correspondence (Euclidean)",
            "Euclidean distance to the true point (√area units)",
            "correspondences within the distance (%)",
        ),
        "correspondence_geodesic_area" | "correspondence_area" => share(
            "Correspondence (geodesic)",
            "geodesic distance to the true point (√area units)",
            "correspondences within the distance (%)",
        ),
        c => (c.replace('_', " "), "x".into(), "y".into(), false),
    }
}

/// One figure with a panel per curve of `spec.curves` (mean curve per
/// method group, shared legend); curves absent from curves.csv are left
/// out with a warning.
fn curve_panels(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let mut panels = Vec::new();
    let mut missing = Vec::new();
    let mut cases = std::collections::BTreeSet::new();
    for curve in &spec.curves {
        let mc = mean_curves(ctx, spec, curve);
        if mc.series.is_empty() {
            missing.push(curve.as_str());
            continue;
        }
        cases.extend(mc.cases);
        let (title, x_label, y_label, share) = curve_info(curve);
        let mut series = mc.series;
        for sr in &mut series {
            if share {
                sr.y.iter_mut().for_each(|y| *y *= 100.0);
            }
        }
        panels.push(LineChart {
            title: spec.labels.get(curve).cloned().unwrap_or(title),
            caption: None,
            x_label,
            y_label,
            series,
            y_range: share.then_some((0.0, 100.0)),
            floor: mc.floor,
            ..Default::default()
        });
    }
    let n_cases = ctx
        .rows
        .iter()
        .filter_map(|r| r.get("case_id"))
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    if panels.is_empty() {
        return Err(Error::invalid(format!(
            "none of the curves {} in curves.csv",
            spec.curves.join(", ")
        )));
    }
    let names: Vec<&str> = panels.iter().map(|p| p.title.as_str()).collect();
    let fig = LinePanels {
        title: ctx.title(spec, || format!("{}: {}", ctx.title, names.join(", "))),
        caption: ctx.subtitle(
            spec,
            format!(
                "{}; mean curve per method over {}",
                ctx.caption,
                if cases.len() == n_cases {
                    "the cases".to_string()
                } else {
                    format!("the {} case(s) with results", cases.len())
                }
            ),
        ),
        panels,
    };
    save_line_panels_as(
        &fig,
        &ctx.stem(spec, "curve_panels"),
        ctx.config.outputs.chart_formats(spec),
    )?;
    if !missing.is_empty() {
        return Err(Error::invalid(format!(
            "no {} curves in curves.csv; drawn without them",
            missing.join(", ")
        )));
    }
    Ok(())
}

/// A pivot table (see [`PlotKind::Pivot`]): `<file>.png` / `.svg` / `.csv`
/// / `.md`. Rows are sorted numerically when every row value is a number,
/// otherwise kept in order of appearance (method groups in config order,
/// then cases); columns in order of appearance. A cell mixing the results
/// of two method groups is an error (restrict `methods`).
fn pivot(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let need = |k: &Option<String>, name: &str| {
        k.clone()
            .ok_or_else(|| Error::invalid(format!("pivot tables need `{name}`")))
    };
    let (rk, ck, metric) = (
        need(&spec.rows, "rows")?,
        need(&spec.columns, "columns")?,
        need(&spec.metric, "metric")?,
    );
    let scale = spec.scale.unwrap_or(1.0);
    let digits = spec.digits.unwrap_or(3);
    let mut row_keys: Vec<String> = Vec::new();
    let mut col_keys: Vec<String> = Vec::new();
    // (row, column) → (values, groups); (row, lead column) → values.
    type Cell = (Vec<f64>, Vec<String>);
    let mut cells: BTreeMap<(String, String), Cell> = BTreeMap::new();
    let mut leads: BTreeMap<(String, String), Vec<f64>> = BTreeMap::new();
    for (g, methods) in &ctx.groups {
        for r in ctx.rows_of_group(g) {
            if !r.get("method").is_some_and(|m| methods.contains(m)) {
                continue;
            }
            let (Some(rv), Some(cv)) = (r.get(&rk), r.get(&ck)) else {
                continue;
            };
            if rv.is_empty() || cv.is_empty() {
                continue;
            }
            if !row_keys.contains(rv) {
                row_keys.push(rv.clone());
            }
            if !col_keys.contains(cv) {
                col_keys.push(cv.clone());
            }
            if let Some(x) = f(r, &metric) {
                let cell = cells.entry((rv.clone(), cv.clone())).or_default();
                cell.0.push(x);
                if !cell.1.contains(g) {
                    cell.1.push(g.clone());
                }
            }
            if spec.lead_from.as_ref().is_none_or(|v| v == cv) {
                for l in &spec.lead {
                    if let Some(x) = f(r, l) {
                        leads.entry((rv.clone(), l.clone())).or_default().push(x);
                    }
                }
            }
        }
    }
    if cells.is_empty() {
        return Err(Error::invalid(format!(
            "no finished results with {rk}, {ck} and {metric}"
        )));
    }
    if let Some(((rv, cv), (_, gs))) = cells.iter().find(|(_, c)| c.1.len() > 1) {
        return Err(Error::invalid(format!(
            "cell ({rk} = {rv}, {ck} = {cv}) mixes the method groups {}; \
             list the methods of one per cell in `methods`",
            gs.join(", ")
        )));
    }
    let numbers: Option<Vec<f64>> = row_keys.iter().map(|k| k.parse::<f64>().ok()).collect();
    if let Some(nums) = numbers {
        let mut order: Vec<usize> = (0..row_keys.len()).collect();
        order.sort_by(|&a, &b| nums[a].total_cmp(&nums[b]));
        row_keys = order.into_iter().map(|i| row_keys[i].clone()).collect();
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let label = |k: &str, default: String| spec.labels.get(k).cloned().unwrap_or(default);
    let header: Vec<String> = std::iter::once(label(&rk, rk.clone()))
        .chain(spec.lead.iter().map(|l| label(l, l.clone())))
        .chain(col_keys.iter().map(|c| label(c, c.replace('_', " "))))
        .collect();
    let mut csv_out = csv::Writer::from_writer(Vec::new());
    let csv_err = |e: csv::Error| Error::invalid(format!("pivot CSV: {e}"));
    let csv_head: Vec<&String> = std::iter::once(&rk)
        .chain(spec.lead.iter())
        .chain(col_keys.iter())
        .collect();
    csv_out.write_record(&csv_head).map_err(csv_err)?;
    let mut shown: Vec<Vec<String>> = Vec::new();
    let mut counts: Vec<usize> = Vec::new();
    for rv in &row_keys {
        let shown_rv = match rk.as_str() {
            "group" => ctx.group_label(spec, rv, rv),
            "method" => ctx.method_label(spec, rv),
            _ => label(rv, rv.clone()),
        };
        let mut line = vec![shown_rv];
        let mut rec = vec![rv.clone()];
        for l in &spec.lead {
            match leads.get(&(rv.clone(), l.clone())) {
                Some(v) => {
                    let x = mean(v);
                    line.push(if x.fract() == 0.0 {
                        format!("{x:.0}")
                    } else {
                        format!("{x:.1}")
                    });
                    rec.push(super::store::num(x));
                }
                None => {
                    line.push("–".into());
                    rec.push(String::new());
                }
            }
        }
        for cv in &col_keys {
            match cells.get(&(rv.clone(), cv.clone())) {
                Some((v, _)) => {
                    let x = mean(v) * scale;
                    counts.push(v.len());
                    line.push(format!("{x:.digits$}"));
                    rec.push(super::store::num(x));
                }
                None => {
                    line.push("–".into());
                    rec.push(String::new());
                }
            }
        }
        csv_out.write_record(&rec).map_err(csv_err)?;
        shown.push(line);
    }
    let what = if scale == 1.0 {
        metric.clone()
    } else {
        format!("{metric} × {scale}")
    };
    let n_note = match (counts.iter().min(), counts.iter().max()) {
        (Some(a), Some(b)) if a == b => format!("{a} result(s) per cell"),
        (Some(a), Some(b)) => format!("{a} to {b} results per cell"),
        _ => String::new(),
    };
    let caption = format!(
        "{}; cells: mean of {what} over cases, {n_note}",
        ctx.caption
    );
    let default_title = || format!("{}: {metric} by {rk} and {ck}", ctx.title);
    let md_title = ctx.title_text(spec, default_title);
    let title = ctx.title(spec, default_title);
    let mut md = format!(
        "| {} |\n|{}\n",
        header.join(" | "),
        "---|".repeat(header.len())
    );
    for line in &shown {
        md.push_str(&format!("| {} |\n", line.join(" | ")));
    }
    let lead_note = match (&spec.lead_from, spec.lead.is_empty()) {
        (Some(v), false) => format!(" {} from the {ck} = {v} results.", spec.lead.join(", ")),
        _ => String::new(),
    };
    md.push_str(&format!("\n{md_title}. {caption}.{lead_note}\n"));
    let stem = ctx.stem(spec, "pivot");
    super::store::write_file(&stem.with_extension("md"), md.as_bytes(), true)?;
    let tex = latex_table(
        &header,
        &shown,
        &format!("{md_title}. {caption}.{lead_note}"),
    );
    super::store::write_file(&stem.with_extension("tex"), tex.as_bytes(), true)?;
    let bytes = csv_out
        .into_inner()
        .map_err(|e| Error::invalid(format!("pivot CSV: {e}")))?;
    super::store::write_file(&stem.with_extension("csv"), &bytes, true)?;
    save_table_as(
        &Table {
            title,
            caption: ctx.subtitle(spec, caption),
            columns: header,
            rows: shown,
        },
        &stem,
        ctx.config.outputs.chart_formats(spec),
    )
}

fn group_stats(ctx: &Ctx, g: &str, col: &str) -> Option<(f64, f64)> {
    let v: Vec<f64> = ctx
        .rows_of_group(g)
        .iter()
        .filter_map(|r| f(r, col))
        .collect();
    if v.is_empty() {
        return None;
    }
    let (mean, std, ..) = describe(&v);
    Some((mean, std))
}

fn bars(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    if spec.metrics.is_empty() {
        return Err(Error::invalid("bars need `metrics`"));
    }
    let groups: Vec<&String> = ctx
        .groups
        .iter()
        .map(|(g, _)| g)
        .filter(|g| {
            spec.metrics
                .iter()
                .any(|m| group_stats(ctx, g, m).is_some())
        })
        .collect();
    if groups.is_empty() {
        return Err(Error::invalid(format!(
            "no numbers for {} in cases.csv",
            spec.metrics.join(", ")
        )));
    }
    let mut series = Vec::new();
    let mut errors = Vec::new();
    for m in &spec.metrics {
        let st: Vec<(f64, f64)> = groups
            .iter()
            .map(|g| group_stats(ctx, g, m).unwrap_or((0.0, 0.0)))
            .collect();
        series.push((metric_label(spec, m), st.iter().map(|s| s.0).collect()));
        errors.push(st.iter().map(|s| s.1).collect());
    }
    let y_label = if let Some(l) = &spec.y_label {
        l.clone()
    } else if spec.metrics.len() == 1 {
        metric_label(spec, &spec.metrics[0])
    } else if spec.metrics.iter().all(|m| m.ends_with("_unit")) {
        "error (unit-sphere units)".into()
    } else if spec
        .metrics
        .iter()
        .all(|m| column_label(m).contains("(√area units)"))
    {
        "error (√area units)".into()
    } else if spec.metrics.iter().all(|m| m == "ari" || m == "purity") {
        "score (1 = true segmentation)".into()
    } else {
        "value".into()
    };
    // A 0/1 column's mean is a share of the cases: no ±std whiskers (they
    // would reach below 0 and above 1).
    let shares = spec
        .metrics
        .iter()
        .all(|m| SHARE_METRICS.contains(&m.as_str()));
    let chart = BarChart {
        title: ctx.title(spec, || {
            format!("{}: {}", ctx.title, spec.metrics.join(", "))
        }),
        caption: ctx.subtitle(
            spec,
            if shares {
                format!("{}; bars: share of the cases", ctx.caption)
            } else {
                format!("{}; bars: mean over cases, whiskers: ±1 std", ctx.caption)
            },
        ),
        y_label,
        categories: groups.iter().map(|g| ctx.group_label(spec, g, g)).collect(),
        series,
        errors: (!shares).then_some(errors),
        log_y: spec.log_y.unwrap_or(false),
    };
    let default = format!("bars_{}", spec.metrics.join("_"));
    save_bar_chart_as(
        &chart,
        &ctx.stem(spec, &default),
        ctx.config.outputs.chart_formats(spec),
    )
}

/// Columns that are 0 or 1 per case: their mean is a share.
const SHARE_METRICS: [&str; 2] = ["gross_failure", "perm_correct"];

fn trace(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let mut series: Vec<Series> = Vec::new();
    let mut counts: Vec<usize> = Vec::new();
    let mut keys: Vec<(String, String)> = Vec::new();
    for r in &ctx.curves {
        if r.get("curve").map(String::as_str) != Some("selection_trace") {
            continue;
        }
        let k = (r["method"].clone(), r["case_id"].clone());
        let shown = ctx.groups.iter().any(|(_, ms)| ms.contains(&k.0));
        if shown && !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (m, c) in &keys {
        let pts: Vec<(f64, f64)> = ctx
            .curves
            .iter()
            .filter(|r| {
                r.get("curve").map(String::as_str) == Some("selection_trace")
                    && r["method"] == *m
                    && r["case_id"] == *c
            })
            .filter_map(|r| Some((f(r, "x")?, f(r, "y")?)))
            .collect();
        let n_methods: usize = ctx.groups.iter().map(|(_, ms)| ms.len()).sum();
        let label = if n_methods > 1 {
            format!("{}, {c}", ctx.method_label(spec, m))
        } else {
            c.clone()
        };
        let (x, y): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
        // Cases with the same source and A′ have the same trace: draw it once.
        match series.iter().position(|s| s.x == x && s.y == y) {
            Some(i) => counts[i] += 1,
            None => {
                series.push(Series { label, x, y });
                counts.push(1);
            }
        }
    }
    for (s, n) in series.iter_mut().zip(&counts) {
        if *n > 1 {
            s.label = format!("{} (same for {n} cases)", s.label);
        }
    }
    if series.is_empty() {
        return Err(Error::invalid("no selection traces in curves.csv"));
    }
    let norm = ctx
        .config
        .defaults
        .error_norm
        .map(|n| format!("{n:?}").to_lowercase())
        .unwrap_or_else(|| "paper".into());
    let chart = LineChart {
        title: ctx.title(spec, || {
            format!("{}: selection error vs number of key points", ctx.title)
        }),
        caption: ctx.subtitle(
            spec,
            format!("{}; stage 1 of Algorithm 1, one line per case", ctx.caption),
        ),
        x_label: "number of key points".into(),
        y_label: format!("deformation error Ê ({norm} norm, unit-sphere units)"),
        series,
        log_y: spec.log_y.unwrap_or(false),
        markers: true,
        floor: None,
        ..Default::default()
    };
    save_line_chart_as(
        &chart,
        &ctx.stem(spec, "trace"),
        ctx.config.outputs.chart_formats(spec),
    )
}

fn line(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let x = spec
        .x
        .clone()
        .ok_or_else(|| Error::invalid("line plots need `x`"))?;
    if spec.metrics.is_empty() {
        return Err(Error::invalid("line plots need `metrics`"));
    }
    // `by`: one series per value of that column (e.g. the dictionary), in
    // order of first appearance among the groups.
    let by_value = |g: &str| -> String {
        spec.by
            .as_ref()
            .and_then(|b| ctx.rows_of_group(g).first().and_then(|r| r.get(b).cloned()))
            .unwrap_or_default()
    };
    let mut values: Vec<String> = Vec::new();
    for (g, _) in &ctx.groups {
        let v = by_value(g);
        if !values.contains(&v) {
            values.push(v);
        }
    }
    let mut series = Vec::new();
    for m in &spec.metrics {
        for v in &values {
            let mut pts: Vec<(f64, f64)> = ctx
                .groups
                .iter()
                .filter(|(g, _)| by_value(g) == *v)
                .filter_map(|(g, _)| Some((group_stats(ctx, g, &x)?.0, group_stats(ctx, g, m)?.0)))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            if !pts.is_empty() {
                let value = spec
                    .labels
                    .get(v)
                    .cloned()
                    .unwrap_or_else(|| v.replace('_', " "));
                let label = match (spec.metrics.len(), v.is_empty()) {
                    (_, true) => metric_label(spec, m),
                    (1, false) => value,
                    _ => format!("{} ({value})", metric_label(spec, m)),
                };
                series.push(Series {
                    label,
                    x: pts.iter().map(|p| p.0).collect(),
                    y: pts.iter().map(|p| p.1).collect(),
                });
            }
        }
    }
    if series.is_empty() {
        return Err(Error::invalid("no numbers to plot"));
    }
    let y_label = if let Some(l) = &spec.y_label {
        l.clone()
    } else if spec.metrics.len() == 1 {
        metric_label(spec, &spec.metrics[0])
    } else if spec
        .metrics
        .iter()
        .all(|m| column_label(m).contains("(√area units)"))
    {
        "error (√area units)".into()
    } else {
        "error (unit-sphere units)".into()
    };
    let chart = LineChart {
        title: ctx.title(spec, || {
            format!("{}: {} vs {}", ctx.title, spec.metrics.join(", "), x)
        }),
        caption: ctx.subtitle(spec, format!("{}; mean over cases per method", ctx.caption)),
        x_label: metric_label(spec, &x),
        y_label,
        series,
        log_y: spec.log_y.unwrap_or(false),
        markers: true,
        floor: None,
        ..Default::default()
    };
    save_line_chart_as(
        &chart,
        &ctx.stem(spec, &format!("line_{x}")),
        ctx.config.outputs.chart_formats(spec),
    )
}

fn timing(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let cols = [
        ("seconds_selection", "key point selection (s)"),
        ("seconds_fit", "fit on A (s)"),
        (
            "seconds_weights_per_handle",
            "target weights per handle, SWT/h (s)",
        ),
        ("seconds_lbs_per_pose", "LBS per pose (s)"),
    ];
    let groups: Vec<&String> = ctx
        .groups
        .iter()
        .map(|(g, _)| g)
        // Methods with none of the timed stages (the `identity` floor) have
        // nothing to show on these axes.
        .filter(|g| {
            group_stats(ctx, g, "seconds_total").is_some()
                && cols.iter().any(|(c, _)| group_stats(ctx, g, c).is_some())
        })
        .collect();
    if groups.is_empty() {
        return Err(Error::invalid("no timings in cases.csv"));
    }
    let mut md = String::from(
        "| method | vertices | key points | key point selection (s) | fit (s) | SWT/h (s) | LBS per pose (ms) | total (s) |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for g in &groups {
        let s = |c: &str| group_stats(ctx, g, c).map(|x| x.0);
        let fmt = |x: Option<f64>, k: f64, d: usize| {
            x.map_or("–".to_string(), |v| format!("{:.*}", d, v * k))
        };
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            ctx.group_label(spec, g, g),
            fmt(s("n_vertices"), 1.0, 0),
            fmt(s("n_keypoints"), 1.0, 1),
            fmt(s("seconds_selection"), 1.0, 3),
            fmt(s("seconds_fit"), 1.0, 3),
            fmt(s("seconds_weights_per_handle"), 1.0, 4),
            fmt(s("seconds_lbs_per_pose"), 1000.0, 3),
            fmt(s("seconds_total"), 1.0, 2),
        ));
    }
    md.push_str(&format!("\nMeans over cases. {}\n", ctx.caption));
    let stem = ctx.stem(spec, "timing");
    super::store::write_file(&stem.with_extension("md"), md.as_bytes(), true)?;
    let mut series = Vec::new();
    for (c, label) in cols {
        let v: Vec<f64> = groups
            .iter()
            .map(|g| group_stats(ctx, g, c).map_or(0.0, |s| s.0.max(1e-6)))
            .collect();
        if v.iter().any(|x| *x > 1e-6) {
            series.push((label.to_string(), v));
        }
    }
    let chart = BarChart {
        title: ctx.title(spec, || format!("{}: running times", ctx.title)),
        caption: ctx.subtitle(spec, format!("{}; mean over cases", ctx.caption)),
        y_label: "time (s, log scale)".into(),
        categories: groups.iter().map(|g| ctx.group_label(spec, g, g)).collect(),
        series,
        errors: None,
        log_y: true,
    };
    save_bar_chart_as(&chart, &stem, ctx.config.outputs.chart_formats(spec))
}

/// A Markdown + CSV + LaTeX table of group means: one row per group (and
/// per value of the `x` column when set, e.g. the class), one column per
/// metric.
fn table(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    if spec.metrics.is_empty() {
        return Err(Error::invalid("tables need `metrics`"));
    }
    let mut keys: Vec<(String, String)> = Vec::new();
    for (g, _) in &ctx.groups {
        for r in ctx.rows_of_group(g) {
            let v = spec
                .x
                .as_ref()
                .and_then(|x| r.get(x).cloned())
                .unwrap_or_default();
            if !keys.contains(&(g.clone(), v.clone())) {
                keys.push((g.clone(), v));
            }
        }
    }
    if keys.is_empty() {
        return Err(Error::invalid("no finished results for the table"));
    }
    let head_x = spec.x.clone().map(|x| vec![x]).unwrap_or_default();
    let header: Vec<String> = ["method".to_string()]
        .into_iter()
        .chain(
            head_x
                .iter()
                .map(|x| spec.labels.get(x).unwrap_or(x).clone()),
        )
        .chain(spec.metrics.iter().map(|m| metric_label(spec, m)))
        .collect();
    let mut csv_out = csv::Writer::from_writer(Vec::new());
    let csv_head: Vec<String> = ["method".to_string()]
        .into_iter()
        .chain(head_x.iter().cloned())
        .chain(spec.metrics.iter().cloned())
        .chain(["n".to_string()])
        .collect();
    csv_out
        .write_record(&csv_head)
        .map_err(|e| Error::invalid(format!("table CSV: {e}")))?;
    let mut shown: Vec<Vec<String>> = Vec::new();
    for (g, v) in &keys {
        let rows: Vec<&Row> = ctx
            .rows_of_group(g)
            .into_iter()
            .filter(|r| {
                spec.x
                    .as_ref()
                    .is_none_or(|x| r.get(x).map(String::as_str) == Some(v.as_str()))
            })
            .collect();
        let cells: Vec<String> = spec
            .metrics
            .iter()
            .map(|m| {
                let vals: Vec<f64> = rows.iter().filter_map(|r| f(r, m)).collect();
                if vals.is_empty() {
                    String::new()
                } else {
                    let mean = vals.iter().sum::<f64>() / vals.len() as f64;
                    format!("{mean:.4e}")
                }
            })
            .collect();
        let mut line: Vec<String> = vec![ctx.group_label(spec, g, g)];
        if spec.x.is_some() {
            line.push(v.clone());
        }
        line.extend(
            cells
                .iter()
                .map(|c| c.parse::<f64>().map_or("–".to_string(), super::store::num)),
        );
        shown.push(line);
        let mut rec: Vec<String> = vec![g.clone()];
        if spec.x.is_some() {
            rec.push(v.clone());
        }
        rec.extend(cells);
        rec.push(rows.len().to_string());
        csv_out
            .write_record(&rec)
            .map_err(|e| Error::invalid(format!("table CSV: {e}")))?;
    }
    let note = format!(
        "{}; means over cases.",
        ctx.title_text(spec, || ctx.caption.clone())
    );
    let mut md = format!(
        "| {} |\n|{}\n",
        header.join(" | "),
        "---|".repeat(header.len())
    );
    for line in &shown {
        md.push_str(&format!("| {} |\n", line.join(" | ")));
    }
    md.push_str(&format!("\n{note}\n"));
    let stem = ctx.stem(spec, "table");
    super::store::write_file(&stem.with_extension("md"), md.as_bytes(), true)?;
    let tex = latex_table(&header, &shown, &note);
    super::store::write_file(&stem.with_extension("tex"), tex.as_bytes(), true)?;
    let bytes = csv_out
        .into_inner()
        .map_err(|e| Error::invalid(format!("table CSV: {e}")))?;
    super::store::write_file(&stem.with_extension("csv"), &bytes, true)?;
    Ok(())
}

/// A LaTeX `tabular` with booktabs rules (`\toprule`, `\midrule`,
/// `\bottomrule`; needs `\usepackage{booktabs}`) of a header and rows of
/// cells as the Markdown table shows them: columns of numbers (and dashes
/// for missing ones) right-aligned, the others left-aligned, every cell
/// escaped ([`latex_escape`]); `note` (title and caption) as a comment
/// above it, for the document's own `\caption`.
fn latex_table(header: &[String], rows: &[Vec<String>], note: &str) -> String {
    let numeric = |c: &str| {
        let t = c.trim();
        matches!(t, "" | "–" | "-") || t.replace('−', "-").parse::<f64>().is_ok()
    };
    let spec: String = (0..header.len())
        .map(|i| {
            if rows.iter().all(|r| r.get(i).is_some_and(|c| numeric(c))) {
                'r'
            } else {
                'l'
            }
        })
        .collect();
    let line = |cells: &[String]| {
        let c: Vec<String> = cells.iter().map(|c| latex_escape(c)).collect();
        format!("{} \\\\\n", c.join(" & "))
    };
    let mut out = String::new();
    for l in note.lines() {
        out.push_str(&format!("% {l}\n"));
    }
    out.push_str(&format!("\\begin{{tabular}}{{{spec}}}\n\\toprule\n"));
    out.push_str(&line(header));
    out.push_str("\\midrule\n");
    for r in rows {
        out.push_str(&line(r));
    }
    out.push_str("\\bottomrule\n\\end{tabular}\n");
    out
}

/// `text` for LaTeX: the ten special characters escaped, the dashes and
/// the mathematical symbols of the labels (√, ′, −, ×, ±, Greek letters,
/// …) as LaTeX commands; other characters are kept (UTF-8 input).
pub fn latex_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 8);
    for ch in text.chars() {
        let s: &str = match ch {
            '\\' => "\\textbackslash{}",
            '&' => "\\&",
            '%' => "\\%",
            '$' => "\\$",
            '#' => "\\#",
            '_' => "\\_",
            '{' => "\\{",
            '}' => "\\}",
            '~' => "\\textasciitilde{}",
            '^' => "\\textasciicircum{}",
            '<' => "\\textless{}",
            '>' => "\\textgreater{}",
            '|' => "\\textbar{}",
            '–' => "--",
            '—' => "---",
            '−' => "\\ensuremath{-}",
            '×' => "\\ensuremath{\\times}",
            '±' => "\\ensuremath{\\pm}",
            '·' => "\\ensuremath{\\cdot}",
            '√' => "\\ensuremath{\\surd}",
            '′' => "\\ensuremath{'}",
            '→' => "\\ensuremath{\\to}",
            '≤' => "\\ensuremath{\\le}",
            '≥' => "\\ensuremath{\\ge}",
            'α' => "\\ensuremath{\\alpha}",
            'β' => "\\ensuremath{\\beta}",
            'γ' => "\\ensuremath{\\gamma}",
            'ε' => "\\ensuremath{\\varepsilon}",
            'λ' => "\\ensuremath{\\lambda}",
            'σ' => "\\ensuremath{\\sigma}",
            'Ê' => "\\^{E}",
            _ => {
                out.push(ch);
                continue;
            }
        };
        out.push_str(s);
    }
    out
}

fn keypoints_of(row: &Row) -> Vec<(usize, usize)> {
    keypoint_column(row, "keypoints")
}

/// The key points on the target: `target_keypoints` when recorded (automatic
/// or noisy target points), else the source indices.
fn target_keypoints_of(row: &Row) -> Vec<(usize, usize)> {
    match row.get("target_keypoints") {
        Some(s) if !s.is_empty() => keypoint_column(row, "target_keypoints"),
        _ => keypoints_of(row),
    }
}

fn keypoint_column(row: &Row, column: &str) -> Vec<(usize, usize)> {
    row.get(column)
        .map(|s| {
            s.split(';')
                .filter_map(|x| x.parse::<usize>().ok())
                .enumerate()
                .map(|(k, v)| (v, k))
                .collect()
        })
        .unwrap_or_default()
}

/// Case ids (in case order) whose meshes were saved.
fn render_cases(ctx: &Ctx) -> Vec<String> {
    let mut ids: Vec<(usize, String)> = Vec::new();
    for r in &ctx.rows {
        let (Some(c), Some(id)) = (r.get("case").and_then(|c| c.parse().ok()), r.get("case_id"))
        else {
            continue;
        };
        if !ids.iter().any(|(_, x)| x == id) && ctx.dir.join("meshes").join(id).is_dir() {
            ids.push((c, id.clone()));
        }
    }
    ids.sort();
    ids.into_iter().map(|x| x.1).collect()
}

fn panels(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let fits = spec.show.as_deref() == Some("fits");
    let ids = render_cases(ctx);
    if ids.is_empty() {
        return Err(Error::invalid("no saved meshes (meshes/<case>/)"));
    }
    for id in &ids {
        let mdir = ctx.dir.join("meshes").join(id);
        let rows: Vec<&Row> = ctx
            .rows
            .iter()
            .filter(|r| {
                r.get("case_id") == Some(id) && r.get("status").map(String::as_str) == Some("ok")
            })
            .collect();
        let Some(first) = rows.first() else { continue };
        let poses: Vec<String> = first
            .get("poses")
            .map(|p| p.split(';').map(String::from).collect())
            .unwrap_or_default();
        let source = read_mesh(&saved(&mdir, "source")?)?;
        let target = read_mesh(&saved(&mdir, "target")?)?;
        // One representative method per group (the first with saved meshes).
        let mut shown: Vec<(&String, &Row)> = Vec::new();
        for (g, methods) in &ctx.groups {
            if let Some(r) = methods
                .iter()
                .find_map(|m| rows.iter().find(|r| r.get("method") == Some(m)))
            {
                if r.get("kind").map(String::as_str) != Some("clustering") {
                    shown.push((g, r));
                }
            }
        }
        if shown.is_empty() {
            continue;
        }
        for pose in &poses {
            let Some(deformed_path) = MeshOut::find(&mdir, &format!("deformed_{pose}")) else {
                continue;
            };
            let deformed = read_mesh(&deformed_path)?;
            let reference: Option<Mesh> = if fits {
                Some(deformed.clone())
            } else {
                MeshOut::find(&mdir, &format!("truth_{pose}"))
                    .map(|p| read_mesh(&p))
                    .transpose()?
            };
            let scale = ErrorScale::of_reference(if fits { &source } else { &target })?.unit_sphere;
            let kp0 = keypoints_of(shown[0].1);
            // FBT registration (shape completion): the template, the partial
            // target it is registered to, the full target, then the results.
            let registration = !fits
                && shown
                    .iter()
                    .all(|(_, r)| r.get("kind").map(String::as_str) == Some("fbt"));
            let mut ps = if registration {
                let partial = shown.iter().find_map(|(_, r)| {
                    MeshOut::find(&mdir.join(&r["method"]), &format!("partial_{pose}"))
                });
                let (label, mesh) = match partial {
                    Some(p) => (format!("partial target (pose {pose})"), read_mesh(&p)?),
                    None => (format!("target (pose {pose})"), deformed.clone()),
                };
                let mut ps = vec![
                    Panel {
                        label: "template (reference shape)".into(),
                        mesh: source.clone(),
                        coloring: Coloring::Plain,
                        keypoints: kp0,
                    },
                    Panel {
                        label,
                        mesh,
                        coloring: Coloring::Plain,
                        keypoints: Vec::new(),
                    },
                ];
                if let Some(t) = &reference {
                    ps.push(Panel {
                        label: "full target (ground truth)".into(),
                        mesh: t.clone(),
                        coloring: Coloring::Plain,
                        keypoints: Vec::new(),
                    });
                }
                ps
            } else {
                header_panels(
                    &source,
                    &target,
                    &deformed,
                    reference.as_ref(),
                    pose,
                    fits,
                    (kp0, target_keypoints_of(shown[0].1)),
                )
            };
            let mut results: Vec<ResultPanel> = Vec::new();
            let mut registered: Vec<Panel> = Vec::new();
            for (g, r) in &shown {
                let m = &r["method"];
                let file = if fits { "fit" } else { "result" };
                let Some(p) = MeshOut::find(&mdir.join(m), &format!("{file}_{pose}")) else {
                    continue;
                };
                let reg = MeshOut::find(&mdir.join(m), "registered");
                if let (false, true, Some(reg)) = (fits, registered.is_empty(), reg) {
                    // Automatic target correspondence: A registered onto B.
                    registered.push(Panel {
                        label: format!("A→B, {}", ctx.group_label(spec, g, g)),
                        mesh: read_mesh(&reg)?,
                        coloring: Coloring::Plain,
                        keypoints: keypoints_of(r),
                    });
                }
                let mesh = read_mesh(&p)?;
                let err = match &reference {
                    Some(t) => vertex_errors(mesh.vertices(), t.vertices())?
                        .into_iter()
                        .map(|e| e * scale)
                        .collect(),
                    None => Vec::new(),
                };
                let kp = if fits {
                    keypoints_of(r)
                } else {
                    target_keypoints_of(r)
                };
                results.push((ctx.group_label(spec, g, g), mesh, err, kp));
            }
            if results.is_empty() {
                continue;
            }
            ps.extend(registered);
            let mut all: Vec<f64> = results.iter().flat_map(|r| r.2.iter().copied()).collect();
            all.sort_by(f64::total_cmp);
            let hi = all
                .get(((all.len() as f64) * 0.98) as usize)
                .copied()
                .unwrap_or(0.0)
                .max(1e-6);
            for (g, mesh, err, kp) in results {
                let coloring = if err.is_empty() {
                    Coloring::Plain
                } else {
                    Coloring::Scalar {
                        values: err,
                        lo: 0.0,
                        hi,
                        label: if fits {
                            "error to A′ (unit-sphere units of A)".into()
                        } else if registration {
                            "distance to the true position (unit-sphere units)".into()
                        } else {
                            "error to ground truth (unit-sphere units of B)".into()
                        },
                    }
                };
                ps.push(Panel {
                    label: g,
                    mesh,
                    coloring,
                    keypoints: kp,
                });
            }
            let fig = Figure {
                title: ctx.title(spec, || {
                    if fits {
                        format!(
                            "{}: deformed source per method (case {id}, pose {pose})",
                            ctx.title
                        )
                    } else if registration {
                        format!(
                            "{}: registration results (case {id}, pose {pose})",
                            ctx.title
                        )
                    } else {
                        format!("{}: transfer results (case {id}, pose {pose})", ctx.title)
                    }
                }),
                caption: ctx.subtitle(
                    spec,
                    if registration {
                        format!(
                            "{}; right: the template registered by each method",
                            ctx.caption
                        )
                    } else {
                        format!(
                            "{}; {}; spheres: key points (on A: those of {}); colour: \
                             per-vertex error",
                            ctx.caption,
                            if fits {
                                "right: the deformed source D_S(A) of each method"
                            } else {
                                "right: the transferred B′ of each method"
                            },
                            ctx.group_label(spec, shown[0].0, shown[0].0)
                        )
                    },
                ),
                panels: ps,
                camera: ctx.config.outputs.camera(&ctx.config.dataset),
                panel_size: (260, 360),
            };
            let default = if fits { "fits" } else { "panels" };
            let stem = ctx.stem(spec, default);
            let stem = stem.with_file_name(format!(
                "{}_{id}_{pose}",
                stem.file_name()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            ));
            save_figure_as(
                &fig,
                &ctx.render_options(),
                &stem,
                ctx.config.outputs.render_formats(spec),
            )?;
        }
    }
    Ok(())
}

/// The saved mesh `dir/<stem>.ply` (or `.obj`); an error naming the
/// folder when neither exists.
fn saved(dir: &Path, stem: &str) -> Result<PathBuf> {
    MeshOut::find(dir, stem).ok_or_else(|| {
        Error::invalid(format!(
            "{}: no saved mesh {stem}.ply or {stem}.obj",
            dir.display()
        ))
    })
}

/// Key points of a panel: (vertex, key point index).
type Keypoints = Vec<(usize, usize)>;

/// The left panels of a BDT figure: source (with key points), deformed
/// source, and for transfers the target (with its key points: the source's,
/// or the recorded target key points) and the ground truth.
fn header_panels(
    source: &Mesh,
    target: &Mesh,
    deformed: &Mesh,
    reference: Option<&Mesh>,
    pose: &str,
    fits: bool,
    (kp0, kp_b): (Keypoints, Keypoints),
) -> Vec<Panel> {
    let mut ps = vec![
        Panel {
            label: "source A".into(),
            mesh: source.clone(),
            coloring: Coloring::Plain,
            keypoints: kp0,
        },
        Panel {
            label: format!("deformed source A′ (pose {pose})"),
            mesh: deformed.clone(),
            coloring: Coloring::Plain,
            keypoints: Vec::new(),
        },
    ];
    if !fits {
        ps.push(Panel {
            label: "target B".into(),
            mesh: target.clone(),
            coloring: Coloring::Plain,
            keypoints: kp_b
                .into_iter()
                .filter(|&(v, _)| v < target.n_vertices())
                .collect(),
        });
        if let Some(t) = reference {
            ps.push(Panel {
                label: "ground truth B′".into(),
                mesh: t.clone(),
                coloring: Coloring::Plain,
                keypoints: Vec::new(),
            });
        }
    }
    ps
}

/// Spreads label ids over [0, 1] so that neighbouring ids get distinct colours.
fn label_value(l: usize) -> f64 {
    (l as f64 * 0.618_033_988_75).fract()
}

fn read_labels(path: &Path) -> Result<Vec<usize>> {
    read_csv(path)?
        .iter()
        .enumerate()
        .map(|(i, r)| {
            r.get("cluster")
                .or_else(|| r.get("label"))
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| Error::parse(path, format!("row {}", i + 2), "expected a label"))
        })
        .collect()
}

fn clusters(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let ids = render_cases(ctx);
    let mut made = 0;
    for id in &ids {
        let mdir = ctx.dir.join("meshes").join(id);
        let source = read_mesh(&saved(&mdir, "source")?)?;
        let mut ps = Vec::new();
        let lp = mdir.join("labels.csv");
        if lp.exists() {
            let l = read_labels(&lp)?;
            ps.push(Panel {
                label: "true bones".into(),
                mesh: source.clone(),
                coloring: Coloring::Scalar {
                    values: l.iter().map(|&x| label_value(x)).collect(),
                    lo: 0.0,
                    hi: 1.0,
                    label: "segment (colours are arbitrary)".into(),
                },
                keypoints: Vec::new(),
            });
        }
        for (g, methods) in &ctx.groups {
            let Some(m) = methods
                .iter()
                .find(|m| mdir.join(m.as_str()).join("clusters.csv").exists())
            else {
                continue;
            };
            let l = read_labels(&mdir.join(m.as_str()).join("clusters.csv"))?;
            let row = ctx
                .rows
                .iter()
                .find(|r| r.get("case_id") == Some(id) && r.get("method") == Some(m));
            let score = row
                .and_then(|r| f(r, "ari"))
                .map(|a| format!(" (ARI {a:.2})"))
                .unwrap_or_default();
            ps.push(Panel {
                label: format!("{}{score}", ctx.group_label(spec, g, g)),
                mesh: source.clone(),
                coloring: Coloring::Scalar {
                    values: l.iter().map(|&x| label_value(x)).collect(),
                    lo: 0.0,
                    hi: 1.0,
                    label: "segment (colours are arbitrary)".into(),
                },
                keypoints: Vec::new(),
            });
        }
        if ps.len() < 2 {
            continue;
        }
        let fig = Figure {
            title: ctx.title(spec, || {
                format!("{}: rotation groups (case {id})", ctx.title)
            }),
            caption: ctx.subtitle(spec, ctx.caption.clone()),
            panels: ps,
            camera: ctx.config.outputs.camera(&ctx.config.dataset),
            panel_size: (260, 360),
        };
        let stem = ctx.stem(spec, "clusters");
        let stem = stem.with_file_name(format!(
            "{}_{id}",
            stem.file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        ));
        save_figure_as(
            &fig,
            &ctx.render_options(),
            &stem,
            ctx.config.outputs.render_formats(spec),
        )?;
        made += 1;
    }
    if made == 0 {
        return Err(Error::invalid(
            "no saved cluster labels (meshes/<case>/<method>/clusters.csv)",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latex_cells_are_escaped() {
        assert_eq!(
            latex_escape("a_b & 50% #1 {x} $y ~^\\"),
            "a\\_b \\& 50\\% \\#1 \\{x\\} \\$y \\textasciitilde{}\\textasciicircum{}\\textbackslash{}"
        );
        assert_eq!(
            latex_escape("error (√area units) – |α − 1|"),
            "error (\\ensuremath{\\surd}area units) -- \\textbar{}\\ensuremath{\\alpha} \\ensuremath{-} 1\\textbar{}"
        );
    }

    #[test]
    fn latex_tables_align_numbers_right() {
        let header = vec!["method".to_string(), "q".into(), "error".into()];
        let rows = vec![
            vec!["auto_x".to_string(), "1".into(), "0.5".into()],
            vec!["b".to_string(), "2".into(), "–".into()],
        ];
        let t = latex_table(&header, &rows, "note\nsecond line");
        assert!(t.starts_with("% note\n% second line\n\\begin{tabular}{lrr}\n\\toprule\n"));
        assert!(t.contains("method & q & error \\\\\n\\midrule\n"), "{t}");
        assert!(t.contains("auto\\_x & 1 & 0.5 \\\\\nb & 2 & -- \\\\\n\\bottomrule\n"));
        assert!(t.ends_with("\\end{tabular}\n"));
    }
}

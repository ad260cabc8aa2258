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
//! `subtitle` (off by default, [`super::config::DEFAULT_TITLES`]; `true`
//! draws them, a title text names the plot), `chart_width_in`,
//! `chart_height_in`, `font_pt`, `dpi` (the charts' [`crate::plot::ChartStyle`],
//! default [`crate::plot::ChartStyle::PAPER`]), `formats` (charts PNG + SVG + PDF,
//! renders PNG by default), `up` and `camera` of renders (default per data
//! set, [`super::config::DatasetSpec::default_camera`]), `max_per_row`;
//! method groups are shown by their methods' `label`, a plot's `labels` map
//! overriding it. [`make_plots_with`] takes these from a config file rather
//! than the manifest.
//!
//! Code layout: this file reads the results and dispatches each plot
//! ([`make_plots_with`]); `curves` draws the cumulative curves and curve
//! panels, `metric_charts` the bar, trace, line and timing charts, `tables`
//! the pivot and group-mean tables (figure, CSV, Markdown, LaTeX), `renders`
//! the mesh panels and cluster renders.

mod curves;
mod metric_charts;
mod renders;
mod tables;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use self::curves::{cumulative, curve_panels};
use self::metric_charts::{bars, line, timing, trace};
use self::renders::{clusters, panels};
use self::tables::{pivot, table};
use super::config::{Config, LoadedConfig, PlotKind, PlotSpec, TitleSpec};
use super::manifest::read_manifest;
use super::store::{own_subdir, TIMINGS_DIR};
use crate::plot::RenderOptions;
use crate::{Error, Result};

pub use self::tables::latex_escape;

pub(crate) type Row = BTreeMap<String, String>;

pub(crate) fn read_csv(path: &Path) -> Result<Vec<Row>> {
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

/// The rows of `cases.csv` with the timing cells of `timings/cases.csv`
/// (matched by case and method) added; rows stay as they are when there is
/// no timings file (a folder of an older run keeps its timings in
/// `cases.csv`).
fn with_timings(mut rows: Vec<Row>, dir: &Path) -> Result<Vec<Row>> {
    let path = dir.join(TIMINGS_DIR).join("cases.csv");
    if std::fs::symlink_metadata(&path).is_err() {
        return Ok(rows);
    }
    let key = |r: &Row| {
        (
            r.get("case_id").cloned().unwrap_or_default(),
            r.get("method").cloned().unwrap_or_default(),
        )
    };
    let timings: std::collections::BTreeMap<(String, String), Row> =
        read_csv(&path)?.into_iter().map(|r| (key(&r), r)).collect();
    for r in &mut rows {
        if let Some(t) = timings.get(&key(r)) {
            for (k, v) in t {
                if crate::experiment::store::is_timing(k) {
                    r.insert(k.clone(), v.clone());
                }
            }
        }
    }
    Ok(rows)
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
        "err_mean_area_rigid" => "mean error after the best rigid alignment (√area units)".into(),
        "err_rms_area_rigid" => "RMS error after the best rigid alignment (√area units)".into(),
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

    /// The output path (without extension) of a figure: `plots/NAME`, or
    /// `timings/plots/NAME` for a figure that shows timings (volatile,
    /// [`PlotSpec::shows_timing`]).
    fn stem(&self, spec: &PlotSpec, default: &str) -> PathBuf {
        let dir = if spec.shows_timing() {
            self.dir.join(TIMINGS_DIR).join("plots")
        } else {
            self.dir.join("plots")
        };
        dir.join(spec.file.clone().unwrap_or_else(|| default.to_string()))
    }

    /// The title drawn on a figure ("" for none): the plot's `title = true`
    /// draws `default()`, `false` nothing; a text, or no `title`, draws
    /// (the text, else `default()`) when `[outputs]` turns titles on.
    fn title(&self, spec: &PlotSpec, default: impl FnOnce() -> String) -> String {
        match &spec.title {
            Some(TitleSpec::Text(t)) if self.titles => t.clone(),
            Some(TitleSpec::Text(_)) => String::new(),
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
    let rows = with_timings(read_csv(&dir.join("cases.csv"))?, dir)?;
    let curves = read_csv(&dir.join("curves.csv"))?;
    let mut groups: Vec<(String, Vec<String>)> = Vec::new();
    for m in &config.methods {
        let g = m.group.clone().unwrap_or_else(|| m.name.clone());
        match groups.iter_mut().find(|(x, _)| *x == g) {
            Some((_, v)) => v.push(m.name.clone()),
            None => groups.push((g, vec![m.name.clone()])),
        }
    }
    let (identity_group, floor_label) = match floor_of(&config) {
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
    let titles = config.outputs.titles();
    let subtitles = config.outputs.subtitles();
    let caption = format!("{}; {} case(s)", manifest.dataset, n_cases);
    let (group_labels, method_labels) = labels_of(&config);
    own_subdir(dir, "plots")?;
    // The figures: the config's, else the defaults for its methods.
    let specs = if config.outputs.plots.is_empty() {
        default_plots(&config)
    } else {
        config.outputs.plots.clone()
    };
    if specs.iter().any(PlotSpec::shows_timing) {
        own_subdir(&own_subdir(dir, TIMINGS_DIR)?, "plots")?;
    }
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

/// The floor of an experiment: the group of its first method that leaves B
/// unchanged (transfer) or the template undeformed (completion), and that
/// floor's legend entry; `None` when it has no such method.
pub(crate) fn floor_of(config: &Config) -> Option<(String, &'static str)> {
    config.methods.iter().find_map(|m| {
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
    })
}

/// The legend labels of a config: by group (the first `label` in the
/// group) and by method (its own `label`, else its group's). Methods and
/// groups without one are absent (the name is shown).
pub(crate) fn labels_of(config: &Config) -> (BTreeMap<String, String>, BTreeMap<String, String>) {
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
    (group_labels, method_labels)
}

/// Legend entry of the identity floor in cumulative plots.
const IDENTITY_LABEL: &str = "identity (B unchanged)";
/// Legend entry of the completion floor (`solver = "template"`).
const TEMPLATE_LABEL: &str = "template (undeformed)";

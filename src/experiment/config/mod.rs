//! Experiment config schema (TOML, serde, unknown keys rejected everywhere).
//!
//! ```toml
//! name = "fig14"                # folder name under the results root
//! description = "..."           # free text (not part of the config hash)
//! seed = 0                      # random case draws; default seed of every method
//!
//! [dataset]
//! strict = false                # refuse meshes with result-changing defects (not hashed)
//! repair = false                # drop duplicate / zero-area faces, fix winding at load
//!
//! [dataset.synthetic]           # or [dataset.faust] path = "..."
//! subjects = 3                  #    [dataset.tosca] path = "...", class = "cactus"
//! poses = 4                     #    [dataset.manifest] path = ".../manifest.toml"
//! resolution = 1                # (paths: `@data/...` under the data root,
//!                               #  others relative to this config file)
//!
//! [cases]                       # source subject → target subjects × poses
//! sources = [0]                 # default: every subject
//! targets = [1, 2]              # default: every other subject
//! include_self = false          # also target = source (B = A, truth = A′)
//! reference_pose = 0            # A and B; default: first pose both subjects have
//! poses = [1, 2, 3]             # A′; default: every other pose of the source
//! max_poses = 3                 # keep the first m of them
//! per_pose = false              # one case per pose (m = 1) instead of all at once
//! require_truth = true          # drop poses whose ground truth is missing
//! repeat = 5                    # copies of every case (fresh FBT draws per copy)
//! random = 4                    # N random draws (seeded) instead of the product
//! max_cases = 10
//!
//! [defaults]                    # pipeline options shared by every method
//! mode = "fast"
//! n_candidates = 24
//!
//! [[methods]]
//! name = "auto"
//! kind = "bdt"                  # bdt | bdt_random | bdt_extremity | clustering
//! label = "BDT (automatic)"     # legend / table name (output only, not hashed)
//! max_keypoints = 8             # any pipeline option overrides [defaults]
//!
//! [[methods]]
//! name = "random-0"
//! kind = "bdt_random"
//! group = "random"              # plots aggregate methods of one group
//! count = 6
//! seed = 0
//!
//! [metrics]
//! procrustes = false            # rigid alignment before measuring
//! curve_max = 0.2               # cumulative curve grid, unit-sphere units
//!
//! [sweep]                       # method variants (super::sweep)
//! defaults.epsilon = [0.01, 0.02]
//!
//! [outputs]                     # output-only: not part of the config hash
//! render_cases = 1
//! title = true                  # plot titles (default false; a text: the title prefix)
//! subtitle = true               # provenance line under the titles (default false)
//! formats = ["png", "pdf"]      # charts and renders (default: charts png, svg, pdf; renders png)
//! up = "z"                      # render up axis (default: "z" for [dataset.tosca], else "y")
//! max_per_row = 6               # render panels per row (0: one row)
//! mesh_format = "obj"           # meshes/ as OBJ (default "ply", with a per-vertex `error`)
//! [[outputs.plots]]
//! kind = "cumulative"
//! title = true                  # this plot keeps its title; `subtitle`, `formats` likewise
//! [[outputs.plots]]               # one figure, one panel per curve, shared legend
//! kind = "curve_panels"
//! curves = ["cumulative_area", "correspondence_euclidean_area"]
//! [[outputs.plots]]               # rows × columns of metric means (figure + CSV + Markdown + LaTeX)
//! kind = "pivot"
//! rows = "q"
//! columns = "dictionary_kind"
//! metric = "rel_distortion_max"
//! scale = 100                   # percent
//! digits = 2
//! lead = ["dict_size"]          # per-row columns before the pivoted ones
//! lead_from = "lbo"             # ... taken from the `lbo` results only
//! labels = { lbo = "LBO" }      # display names of values, columns, curves
//! ```
//!
//! Errors name the file, the key (e.g. `methods[1].n_candidates`), the line
//! and what was expected. Every numeric key has a valid range, written on
//! its definition below (`deserialize_with = "Int::<1, 1000>::de"`, see
//! [`super::range`]) and listed in `experiments/README.md`; values that
//! depend on the data are checked once the dataset is open
//! ([`super::feasible`]). Sumner–Popović and cage baselines (issue 6) will be
//! further `kind`s of [`MethodEntry`] / variants of [`Method`].

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::data::synthetic::{pose::N_POSES, MAX_RESOLUTION, MAX_SUBJECTS};
use crate::data::DataRoot;
use crate::mesh::repair::DefectPolicy;
mod checks;
mod read;

pub use crate::methods::registry::{Method, NamedMethod};
pub use crate::methods::registry::{MethodEntry, MethodKind, PipelineSpec};
pub use crate::methods::spec::{Epsilon, FbtSpec, FbtTask, MaxKeypoints, NCandidates};
use crate::range::{
    ChartInches, Degrees, Dpi, FontPoints, Int, Positive, Real, RemeshRatio, Spread,
};
pub(crate) use checks::{check_dataset, check_outputs};
pub(crate) use read::parse_unchecked_in;

/// A parsed experiment config.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Experiment name: the results folder (letters, digits, `-`, `_`, `.`).
    pub name: String,
    /// Free text (not hashed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Seed of random case draws and default seed of every method.
    #[serde(default)]
    pub seed: u64,
    /// Where the meshes come from (synthetic by default).
    #[serde(default)]
    pub dataset: DatasetSpec,
    /// Case generator.
    #[serde(default)]
    pub cases: CaseSpec,
    /// Pipeline options shared by every method.
    #[serde(default)]
    pub defaults: PipelineSpec,
    /// The methods, run on every case in this order.
    pub methods: Vec<MethodEntry>,
    /// Metric settings.
    #[serde(default)]
    pub metrics: MetricsSpec,
    /// Output-only settings (not hashed).
    #[serde(default)]
    pub outputs: OutputSpec,
    /// `[sweep]` / `[[sweep]]`: method variants, expanded when the config
    /// is loaded ([`super::sweep`]); the expanded config has none.
    #[serde(default, skip_serializing)]
    pub sweep: Option<toml::Value>,
}

/// A subject or pose label: a number (`3`) or a name (`"rest"`).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(untagged)]
pub enum Label {
    Index(u64),
    Name(String),
}

impl std::fmt::Display for Label {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Label::Index(i) => write!(f, "{i}"),
            Label::Name(s) => f.write_str(s),
        }
    }
}

/// `[dataset]`: exactly one of the tables, or none (synthetic defaults).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DatasetSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub synthetic: Option<SyntheticSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faust: Option<FolderSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tosca: Option<ToscaSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub manifest: Option<FolderSpec>,
    /// Refuse a mesh with a defect that changes results (duplicate or
    /// zero-area faces, non-manifold edges or vertices, inconsistent
    /// winding, several components, unreferenced vertices) instead of
    /// warning ([`DefectPolicy::strict`]; `run --strict` sets it). Not part
    /// of the config hash: it changes no result.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strict: Option<bool>,
    /// Repair meshes at load: drop duplicate and zero-area faces, wind each
    /// component consistently ([`DefectPolicy::repair`]; `run --repair`
    /// sets it). Part of the config hash.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub repair: Option<bool>,
}

impl DatasetSpec {
    /// The defect policy: the keys given, else [`DefectPolicy::default`].
    pub fn policy(&self) -> DefectPolicy {
        let d = DefectPolicy::default();
        DefectPolicy {
            strict: self.strict.unwrap_or(d.strict),
            repair: self.repair.unwrap_or(d.repair),
        }
    }
}

/// Range of `dataset.synthetic.subjects` (and `deformlab gen --subjects`).
pub type Subjects = Int<1, { MAX_SUBJECTS as u64 }>;
/// Range of `dataset.synthetic.poses` (and `deformlab gen --poses`).
pub type SyntheticPoses = Int<1, { N_POSES as u64 }>;
/// Range of `dataset.synthetic.resolution` (and `deformlab gen --resolution`).
pub type Resolution = Int<1, { MAX_RESOLUTION as u64 }>;

/// `[dataset.synthetic]`: [`crate::data::synthetic::FaustStyle`] parameters
/// (defaults: those of `FaustStyle::default()`).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SyntheticSpec {
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Subjects::de"
    )]
    pub subjects: Option<usize>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "SyntheticPoses::de"
    )]
    pub poses: Option<usize>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Resolution::de_u32"
    )]
    pub resolution: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tail: Option<bool>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<Spread>::de"
    )]
    pub spread: Option<f64>,
    /// Also serve a remesh of subject 0 (about `remesh · n` vertices, other
    /// connectivity, [`crate::data::synthetic::remesh`]) as the subject
    /// `"remesh"`, in every pose of subject 0 (exact: its vertices lie on
    /// subject 0's surface), for cross-topology transfer with ground truth.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<RemeshRatio>::de"
    )]
    pub remesh: Option<f64>,
}

impl SyntheticSpec {
    /// The generator configuration.
    pub fn faust_style(&self) -> crate::data::FaustStyle {
        let d = crate::data::FaustStyle::default();
        crate::data::FaustStyle {
            subjects: self.subjects.unwrap_or(d.subjects),
            poses: self.poses.unwrap_or(d.poses),
            resolution: self.resolution.unwrap_or(d.resolution),
            seed: self.seed.unwrap_or(d.seed),
            tail: self.tail.unwrap_or(d.tail),
            spread: self.spread.unwrap_or(d.spread),
        }
    }
}

/// `[dataset.faust]` / `[dataset.manifest]`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FolderSpec {
    /// Folder (FAUST) or manifest file, relative to the config file.
    pub path: PathBuf,
}

/// `[dataset.tosca]`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ToscaSpec {
    /// Folder, relative to the config file.
    pub path: PathBuf,
    /// Classes used as subjects (default: all; shapes of different classes
    /// do not share connectivity, so transfer needs `include_self`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub classes: Option<Vec<String>>,
}

/// `[cases]`: see the module documentation.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sources: Option<Vec<Label>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub targets: Option<Vec<Label>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub include_self: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_pose: Option<Label>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poses: Option<Vec<Label>>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 1_000_000>::de"
    )]
    pub max_poses: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub per_pose: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub require_truth: Option<bool>,
    /// Copies of every generated case (ids suffixed `-x0`, `-x1`, …) before
    /// `random` draws from them: methods that seed their random choices with
    /// the case id (FBT's partial shapes, feature points and example draws)
    /// get a fresh draw per copy. Default 1.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 1000>::de"
    )]
    pub repeat: Option<usize>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 1_000_000>::de"
    )]
    pub random: Option<usize>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<1, 1_000_000>::de"
    )]
    pub max_cases: Option<usize>,
}

/// `[metrics]`.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MetricsSpec {
    /// Rigid (Procrustes) alignment of each result onto its ground truth
    /// before measuring (default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub procrustes: Option<bool>,
    /// Upper end of the cumulative curve grid in unit-sphere units (default 0.2).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<Positive>::de"
    )]
    pub curve_max: Option<f64>,
    /// Upper end of the √area curve grid (default 0.15).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<Positive>::de"
    )]
    pub curve_max_area: Option<f64>,
    /// Grid points (default 41).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<2, 10_000>::de"
    )]
    pub curve_points: Option<usize>,
}

impl MetricsSpec {
    pub fn procrustes(&self) -> bool {
        self.procrustes.unwrap_or(false)
    }
    pub fn curve_max(&self) -> f64 {
        self.curve_max.unwrap_or(0.2)
    }
    pub fn curve_max_area(&self) -> f64 {
        self.curve_max_area.unwrap_or(0.15)
    }
    pub fn curve_points(&self) -> usize {
        self.curve_points.unwrap_or(41)
    }
}

/// `[outputs]` (not part of the config hash).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Titles of the figures: `true` draws them ("<name>: ..."), `false`
    /// (the default, [`DEFAULT_TITLES`]: a paper's figure has its caption)
    /// does not; a text is the prefix of the default titles instead of the
    /// experiment name (used by the Markdown and LaTeX tables, and by the
    /// figures when a plot's `title = true`). A plot's own `title` wins.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub title: Option<TitleSpec>,
    /// The provenance line (data set, cases) under each figure's title:
    /// `true` draws it, `false` (the default, [`DEFAULT_SUBTITLES`]) does
    /// not. A plot's own `subtitle` wins.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub subtitle: Option<bool>,
    /// Files of every chart and render: some of `"png"`, `"svg"`, `"pdf"`
    /// (default: charts PNG + SVG + PDF, renders PNG;
    /// [`crate::plot::Formats::CHARTS`], [`crate::plot::Formats::RENDERS`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formats: Option<Vec<FileFormat>>,
    /// Width of a chart (line, bar; one panel of `curve_panels`), inches
    /// (default [`crate::plot::DEFAULT_CHART_WIDTH_IN`]: one column).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<ChartInches>::de"
    )]
    pub chart_width_in: Option<f64>,
    /// Height of a chart, inches (default
    /// [`crate::plot::DEFAULT_CHART_HEIGHT_IN`]).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<ChartInches>::de"
    )]
    pub chart_height_in: Option<f64>,
    /// Text of charts and table figures (tick labels, legends, table
    /// cells), points (default [`crate::plot::DEFAULT_FONT_PT`]).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<FontPoints>::de"
    )]
    pub font_pt: Option<f64>,
    /// Pixels per inch of the charts' and table figures' PNGs (default
    /// [`crate::plot::DEFAULT_DPI`]).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<Dpi>::de"
    )]
    pub dpi: Option<f64>,
    /// Cases (first in case order) whose meshes are saved for renders (default 1).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<0, 10_000>::de"
    )]
    pub render_cases: Option<usize>,
    /// Deformed poses saved per render case (default 2).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<0, 1000>::de"
    )]
    pub render_poses: Option<usize>,
    /// Render camera `[yaw, pitch]` in degrees (default: the data set's,
    /// [`DatasetSpec::default_camera`]).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Real::<Degrees>::de_pair"
    )]
    pub camera: Option<[f64; 2]>,
    /// The model axis drawn pointing up in renders: `"y"` or `"z"`
    /// (default: the data set's, [`DatasetSpec::default_camera`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<UpAxis>,
    /// Render panels per row at most; more wrap onto further rows (0: one
    /// row; default [`crate::plot::DEFAULT_MAX_PER_ROW`]).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<0, 1000>::de"
    )]
    pub max_per_row: Option<usize>,
    /// Format of the saved meshes (`meshes/`): `"ply"` (default; result
    /// meshes carry a per-vertex `error` property) or `"obj"` (the errors
    /// in a companion `<name>.error.txt`, one number per vertex).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh_format: Option<MeshFormat>,
    /// Plots made by `run` and `plot`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plots: Vec<PlotSpec>,
}

/// Whether figures draw their titles when `[outputs] title` is absent or a
/// text: no (`title = true` turns them on).
pub const DEFAULT_TITLES: bool = false;
/// Whether figures draw the provenance line when `[outputs] subtitle` is
/// absent: no (`subtitle = true` turns it on).
pub const DEFAULT_SUBTITLES: bool = false;

impl OutputSpec {
    /// Whether figures without a `title` of their own draw a title:
    /// `[outputs] title = true` or `false`, else [`DEFAULT_TITLES`] (a
    /// text only names the titles).
    pub fn titles(&self) -> bool {
        match &self.title {
            Some(TitleSpec::Show(b)) => *b,
            _ => DEFAULT_TITLES,
        }
    }

    /// Whether figures without a `subtitle` of their own draw the
    /// provenance line: `[outputs] subtitle`, else [`DEFAULT_SUBTITLES`].
    pub fn subtitles(&self) -> bool {
        self.subtitle.unwrap_or(DEFAULT_SUBTITLES)
    }

    /// The size, text and resolution of the charts and table figures:
    /// `chart_width_in`, `chart_height_in`, `font_pt`, `dpi`, each
    /// defaulting to [`crate::plot::ChartStyle::PAPER`]'s.
    pub fn chart_style(&self) -> crate::plot::ChartStyle {
        let d = crate::plot::ChartStyle::PAPER;
        crate::plot::ChartStyle {
            width_in: self.chart_width_in.unwrap_or(d.width_in),
            height_in: self.chart_height_in.unwrap_or(d.height_in),
            font_pt: self.font_pt.unwrap_or(d.font_pt),
            dpi: self.dpi.unwrap_or(d.dpi),
        }
    }

    pub fn render_cases(&self) -> usize {
        self.render_cases.unwrap_or(1)
    }
    pub fn render_poses(&self) -> usize {
        self.render_poses.unwrap_or(2)
    }
    pub fn mesh_format(&self) -> MeshFormat {
        self.mesh_format.unwrap_or_default()
    }
    /// Panels per row of the renders (0: no limit).
    pub fn max_per_row(&self) -> usize {
        self.max_per_row
            .unwrap_or(crate::plot::RenderOptions::default().max_per_row)
    }

    /// The files of a chart made by `plot`: its own `formats`, else
    /// `[outputs] formats`, else [`crate::plot::Formats::CHARTS`].
    pub fn chart_formats(&self, plot: &PlotSpec) -> crate::plot::Formats {
        formats_of(plot.formats.as_ref().or(self.formats.as_ref()))
            .unwrap_or(crate::plot::Formats::CHARTS)
    }

    /// The files of a render made by `plot`: its own `formats`, else
    /// `[outputs] formats`, else [`crate::plot::Formats::RENDERS`].
    pub fn render_formats(&self, plot: &PlotSpec) -> crate::plot::Formats {
        formats_of(plot.formats.as_ref().or(self.formats.as_ref()))
            .unwrap_or(crate::plot::Formats::RENDERS)
    }

    /// The render camera for `dataset`: [`DatasetSpec::default_camera`]
    /// with `camera` and `up` applied.
    pub fn camera(&self, dataset: &DatasetSpec) -> crate::plot::Camera {
        let d = dataset.default_camera();
        let (yaw_deg, pitch_deg) = match self.camera {
            Some([yaw, pitch]) => (yaw, pitch),
            None => (d.yaw_deg, d.pitch_deg),
        };
        crate::plot::Camera {
            yaw_deg,
            pitch_deg,
            up: match self.up {
                Some(UpAxis::Y) => crate::plot::Up::Y,
                Some(UpAxis::Z) => crate::plot::Up::Z,
                None => d.up,
            },
        }
    }
}

fn formats_of(v: Option<&Vec<FileFormat>>) -> Option<crate::plot::Formats> {
    let names: Vec<&str> = v?.iter().map(|f| f.name()).collect();
    crate::plot::Formats::from_names(&names).ok()
}

impl DatasetSpec {
    /// The render camera of the data set when `[outputs]` sets none:
    /// TOSCA-style folders (`[dataset.tosca]`: TOSCA, the cactus) are
    /// z-up, seen three-quarters from the front right and above
    /// ([`crate::plot::Camera::TOSCA`]); every other data set is y-up,
    /// seen from the front ([`crate::plot::Camera::FRONT`]).
    pub fn default_camera(&self) -> crate::plot::Camera {
        if self.tosca.is_some() {
            crate::plot::Camera::TOSCA
        } else {
            crate::plot::Camera::FRONT
        }
    }
}

/// A title setting: a text, or whether the default title is drawn.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(untagged, expecting = "a title (text), true or false")]
pub enum TitleSpec {
    Show(bool),
    Text(String),
}

/// A file format of the charts and renders.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FileFormat {
    Png,
    Svg,
    Pdf,
}

impl FileFormat {
    pub fn name(self) -> &'static str {
        match self {
            FileFormat::Png => "png",
            FileFormat::Svg => "svg",
            FileFormat::Pdf => "pdf",
        }
    }
}

/// The model axis drawn pointing up (`[outputs] up`).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum UpAxis {
    Y,
    Z,
}

/// Format of the meshes saved under `meshes/` (`[outputs] mesh_format`).
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MeshFormat {
    /// Binary PLY; result meshes with a float `error` property per vertex.
    #[default]
    Ply,
    /// Wavefront OBJ; the errors in a companion `<name>.error.txt`.
    Obj,
}

impl MeshFormat {
    /// The mesh file format.
    pub fn format(self) -> crate::mesh::io::Format {
        match self {
            MeshFormat::Ply => crate::mesh::io::Format::Ply,
            MeshFormat::Obj => crate::mesh::io::Format::Obj,
        }
    }
}

/// Plot kinds (see [`crate::experiment::plots`]).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PlotKind {
    /// Cumulative error curves, one line per method group (BDT Fig. 14).
    Cumulative,
    /// Grouped bars of `metrics` (mean ± std over cases) per method group.
    Bars,
    /// Selection error vs number of key points (BDT Fig. 6).
    Trace,
    /// `metrics` vs the column `x` (mean per method), e.g. BDT Fig. 9.
    Line,
    /// Timing bars (log scale) and a Markdown table (BDT Table 1).
    Timing,
    /// Mesh panels: source, deformed source, target, results with key points.
    Panels,
    /// Mesh panels coloured by cluster (BDT Fig. 4).
    Clusters,
    /// Markdown + CSV + LaTeX (booktabs) table of group means (`metrics`;
    /// rows also split by the `x` column when set).
    Table,
    /// One figure of line-chart panels, one per curve of curves.csv
    /// (`curves`), mean curve per method group, shared legend (FBT Fig. 7).
    CurvePanels,
    /// A pivot table (figure, CSV, Markdown, LaTeX): one row per value of the
    /// cases.csv column `rows`, one column per value of `columns`, cells the
    /// mean of `metric` over the results with both values (× `scale`,
    /// `digits` decimals); `lead` columns first (FBT Table 2).
    Pivot,
}

/// One `[[outputs.plots]]` entry.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    pub kind: PlotKind,
    /// File stem under plots/ (default: the kind's name).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Title: `true` (drawn: the default title, from the kind and the
    /// experiment, even when `[outputs]` has no titles), `false` (none) or
    /// a text (this plot's title: in its Markdown and LaTeX files, and on
    /// the figure when `[outputs] title = true`). Default: as `[outputs]
    /// title` says.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub title: Option<TitleSpec>,
    /// The provenance line under the title (default: `[outputs] subtitle`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub subtitle: Option<bool>,
    /// Files written (default: `[outputs] formats`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formats: Option<Vec<FileFormat>>,
    /// cases.csv columns plotted (bars, line).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub metrics: Vec<String>,
    /// Only these methods (default: all), e.g. one selection trace.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub methods: Vec<String>,
    /// cases.csv column on the x axis (line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<String>,
    /// Panels: `results` (default: B′ per method) or `fits` (D_S(A) per method).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub show: Option<String>,
    /// Logarithmic y axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub log_y: Option<bool>,
    /// Line plots: one series per value of this cases.csv column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by: Option<String>,
    /// Bars and line plots: the y axis label, with units (default: from
    /// the metrics).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y_label: Option<String>,
    /// Curve panels: the curves.csv curves drawn, one panel each, in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub curves: Vec<String>,
    /// Pivot: the cases.csv column whose values make the rows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rows: Option<String>,
    /// Pivot: the cases.csv column whose values make the columns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub columns: Option<String>,
    /// Pivot: the cases.csv column averaged in the cells.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub metric: Option<String>,
    /// Pivot: factor applied to the cell means (e.g. 100 for percent;
    /// default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    /// Pivot: decimals shown in the PNG and Markdown (default 3; the CSV
    /// keeps 10 significant digits).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "Int::<0, 10>::de"
    )]
    pub digits: Option<usize>,
    /// Pivot: cases.csv columns shown per row before the pivoted columns
    /// (mean over the row's results, not scaled), e.g. the dictionary size.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lead: Vec<String>,
    /// Pivot: take the `lead` columns only from the results whose `columns`
    /// value is this one (default: all of the row's results).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lead_from: Option<String>,
    /// Display names, overriding the methods' `label`s: of method groups
    /// (legends, categories, table rows, panel captions), of metric columns
    /// (table headers), of column values (pivot, `by` series) and of curves
    /// (curve panels).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub labels: BTreeMap<String, String>,
}

impl PlotSpec {
    /// Whether the figure shows timings (a `timing` chart, or a timing
    /// column among its metrics): such a figure differs between two runs of
    /// one config, so it is written with the volatile files
    /// (`timings/plots/`, [`crate::experiment::store::TIMINGS_DIR`]).
    pub fn shows_timing(&self) -> bool {
        use crate::experiment::store::is_timing;
        self.kind == PlotKind::Timing
            || self.metrics.iter().any(|m| is_timing(m))
            || self.metric.as_deref().is_some_and(is_timing)
            || self.lead.iter().any(|m| is_timing(m))
    }

    /// A plot of `kind` over `metrics`, every other key at its default.
    pub fn new(kind: PlotKind, metrics: &[&str]) -> Self {
        PlotSpec {
            kind,
            file: None,
            title: None,
            subtitle: None,
            formats: None,
            metrics: metrics.iter().map(|s| s.to_string()).collect(),
            methods: Vec::new(),
            x: None,
            show: None,
            log_y: None,
            by: None,
            y_label: None,
            curves: Vec::new(),
            rows: None,
            columns: None,
            metric: None,
            scale: None,
            digits: None,
            lead: Vec::new(),
            lead_from: None,
            labels: BTreeMap::new(),
        }
    }
}

/// A config loaded from a file: the parsed values, where it came from, and
/// the resolved methods.
#[derive(Clone, Debug)]
pub struct LoadedConfig {
    pub config: Config,
    /// The config file.
    pub path: PathBuf,
    /// Its folder: relative dataset paths are resolved against it.
    pub base_dir: PathBuf,
    /// The data root: `@data/...` dataset paths are resolved against it.
    pub data_root: DataRoot,
    pub methods: Vec<NamedMethod>,
    /// Command-line overrides applied (`--set KEY=VALUE`, as given).
    pub overrides: Vec<String>,
    /// The sweep expanded into methods, if any ([`super::sweep`]): its
    /// axes and the methods each template became, for the manifest.
    pub sweep: Option<serde_json::Value>,
}

/// A folder name: letters, digits, `-`, `_`, `.`; not starting with `.`.
pub(crate) fn valid_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 100
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.'))
        && !s.starts_with('.')
}

/// A config error at key path `key`.
fn bad(path: &std::path::Path, key: impl Into<String>, msg: impl Into<String>) -> crate::Error {
    crate::Error::parse(path, format!("key `{}`", key.into()), msg)
}

/// Columns of cases.csv that plots may name (see [`crate::experiment::store`]).
pub use super::store::CASE_COLUMNS;

impl Config {
    /// The config without its output-only fields (`description`,
    /// `outputs`, the methods' `label`s): what the stored results depend
    /// on.
    pub fn hashed_part(&self) -> Config {
        let d = DefectPolicy::default();
        Config {
            description: None,
            outputs: OutputSpec::default(),
            dataset: DatasetSpec {
                strict: None,
                // The default stated or left out: the same results.
                repair: self.dataset.repair.filter(|&r| r != d.repair),
                ..self.dataset.clone()
            },
            methods: self
                .methods
                .iter()
                .map(|m| MethodEntry {
                    label: None,
                    ..m.clone()
                })
                .collect(),
            ..self.clone()
        }
    }

    /// [`Config::hashed_part`] without where the data live (dataset paths
    /// emptied): what the result store's key is made of, with the content
    /// of the data ([`super::fingerprint`]), so that moving the data or
    /// spelling their path otherwise keeps the results.
    pub fn key_part(&self) -> Config {
        let mut c = self.hashed_part();
        if let Some(f) = &mut c.dataset.faust {
            f.path = PathBuf::new();
        }
        if let Some(f) = &mut c.dataset.tosca {
            f.path = PathBuf::new();
        }
        if let Some(f) = &mut c.dataset.manifest {
            f.path = PathBuf::new();
        }
        c
    }

    /// FNV-1a 64 of the canonical JSON of [`Config::hashed_part`], as 16 hex digits.
    pub fn hash(&self) -> String {
        let json = serde_json::to_string(&self.hashed_part()).unwrap_or_default();
        format!("{:016x}", crate::data::fnv1a(json.as_bytes()))
    }
}

pub use crate::data::fnv1a;

#[cfg(test)]
mod tests {
    use super::read::key_at;
    use super::*;
    use std::path::Path;

    #[test]
    fn key_paths_from_offsets() {
        let text = "name = \"x\"\n[dataset.faust]\npath = 3\n[[methods]]\nname = \"a\"\n\
                    [[methods]]\nname = \"b\"\nn_candidates = \"many\"\n[methods.extra]\nfoo = 1\n";
        let off = text.find("3\n").unwrap();
        assert_eq!(key_at(text, off), ("dataset.faust.path".to_string(), 3));
        let off = text.find("\"many\"").unwrap();
        assert_eq!(key_at(text, off).0, "methods[1].n_candidates");
        let off = text.find("foo").unwrap();
        assert_eq!(key_at(text, off).0, "methods[1].extra.foo");
        let t2 = "[[methods]]\nbdt = { a = 1, b = \"x\" }\n";
        let off = t2.find("\"x\"").unwrap();
        assert_eq!(key_at(t2, off).0, "methods[0].bdt.b");
    }

    #[test]
    fn hash_ignores_outputs_only() {
        let p = Path::new("x.toml");
        let a = parse_unchecked_in(
            "name = \"a\"\n[[methods]]\nname = \"m\"\nkind = \"bdt\"\n",
            p,
            &DataRoot::default(),
        )
        .unwrap();
        let b = parse_unchecked_in(
            "name = \"a\"\ndescription = \"d\"\n[[methods]]\nname = \"m\"\nkind = \"bdt\"\n\
             [outputs]\nrender_cases = 3\n",
            p,
            &DataRoot::default(),
        )
        .unwrap();
        let c = parse_unchecked_in(
            "name = \"a\"\n[[methods]]\nname = \"m\"\nkind = \"bdt\"\nn_candidates = 5\n",
            p,
            &DataRoot::default(),
        )
        .unwrap();
        assert_eq!(a.config.hash(), b.config.hash());
        assert_ne!(a.config.hash(), c.config.hash());
    }
}

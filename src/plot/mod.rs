//! Paper-style figures: line charts (cumulative error curves, error vs
//! number of key points), grouped bar charts (ablations, timings) and mesh
//! renders (figure panels of shaded meshes with error colour maps and key
//! points). PNG and SVG via plotters with a bundled font (no system
//! libraries), PDF converted from the SVG ([`pdf`]). This is one of the
//! layers that does file I/O.
//!
//! - [`save_line_chart`], [`save_bar_chart`]: 1200 × 800 PNG (2×
//!   supersampled), SVG and PDF, written atomically; see [`charts`] for
//!   layout. The `_as` variants ([`save_line_chart_as`], …) write the
//!   [`Formats`] asked for; the `_styled` ones ([`save_line_chart_styled`],
//!   …) also take a [`ChartStyle`]: size in inches, text in points, PNG
//!   resolution ([`ChartStyle::PAPER`]: 3.3 × 2.5 in, 8 pt, 300 dpi, the
//!   experiments' default).
//! - [`save_line_panels`]: several line charts side by side in one figure
//!   with a shared legend ([`LinePanels`]).
//! - [`save_table`]: a table (timings) as PNG, SVG and PDF sized to its
//!   content.
//! - [`save_figure`] ([`save_figure_with`] for [`RenderOptions`],
//!   [`save_figure_as`] for the [`Formats`]): rows of software-rendered mesh
//!   panels ([`render`]) with key points and colour bars, PNG; SVG and PDF
//!   with the mesh raster under vector text ([`figure_svg`]). [`Camera`] has recommended constants per data set
//!   ([`Camera::FAUST`], [`Camera::SYNTHETIC`], [`Camera::TOSCA`],
//!   [`Camera::CACTUS`], [`Camera::SUMNER`], [`Camera::ARMADILLO`]).
//! - In memory, without files: [`line_chart_image`], [`bar_chart_image`],
//!   [`line_panels_image`],
//!   [`render_figure`], [`render_mesh`] (with a [`View`]).
//! - [`colormap`] / [`ColorMap`], [`keypoint_color`], [`series_style`]: the
//!   colours used, for matching them elsewhere.
//! - [`demo()`]: writes sample figures (the test `plot_samples`, ignored by
//!   default, calls it).
//!
//! The font is DejaVu Sans, compiled in from the `dejavu` crate and
//! registered with plotters' ab_glyph renderer ([`font`]); no fontconfig or
//! FreeType is involved.

pub mod axis;
pub mod charts;
pub mod demo;
pub mod figure;
pub mod font;
pub mod output;
pub mod pdf;
pub mod render;
pub mod style;

use std::path::Path;

use crate::{Mesh, Result};

pub use charts::{
    ChartStyle, CHART_SIZE, DEFAULT_CHART_HEIGHT_IN, DEFAULT_CHART_WIDTH_IN, DEFAULT_DPI,
    DEFAULT_FONT_PT,
};

/// Size of one panel of [`save_line_panels`] (pixels, [`ChartStyle::pixels`]).
pub const PANEL_SIZE: (u32, u32) = (760, 640);

/// The PNG rendering of a line chart ([`CHART_SIZE`]) without writing it.
pub fn line_chart_image(chart: &LineChart) -> Result<Image> {
    charts::line_chart_image(chart, &ChartStyle::SCREEN)
}

/// The PNG rendering of a bar chart ([`CHART_SIZE`]) without writing it.
pub fn bar_chart_image(chart: &BarChart) -> Result<Image> {
    charts::bar_chart_image(chart, &ChartStyle::SCREEN)
}

/// The PNG rendering of a [`LinePanels`] figure ([`PANEL_SIZE`] a panel)
/// without writing it.
pub fn line_panels_image(figure: &LinePanels) -> Result<Image> {
    charts::line_panels_image(figure, &ChartStyle::pixels(PANEL_SIZE.0, PANEL_SIZE.1))
}
pub use demo::demo;
pub use figure::{
    figure_svg, render_figure, save_figure_as, save_figure_with, DEFAULT_PANEL_SIZE,
    VECTOR_RASTER_SCALE,
};
pub use output::{Formats, Image};
pub use pdf::svg_to_pdf;
pub use render::{render_mesh, RenderOptions, Shading, View, DEFAULT_MAX_PER_ROW};
pub use style::{colormap, keypoint_color, series_style, ColorMap, SeriesStyle, FLOOR_STYLE};

/// One line of a [`LineChart`].
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub label: String,
    /// Abscissae (same length as `y`).
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
}

/// A line chart: cumulative error curves, error vs number of key points.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct LineChart {
    /// Title drawn above the plot.
    pub title: String,
    /// Optional caption line drawn below the title (e.g. data set, cases).
    pub caption: Option<String>,
    /// x axis label including units, e.g. "error bound (unit-sphere units)".
    pub x_label: String,
    /// y axis label including units.
    pub y_label: String,
    /// The lines, one legend entry each.
    pub series: Vec<Series>,
    /// Fixed x range; `None`: fitted to the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None`: fitted to the data.
    pub y_range: Option<(f64, f64)>,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Draw a marker at every point (e.g. error vs key points).
    pub markers: bool,
    /// Index of a series drawn as a reference floor (e.g. the `identity`
    /// method of a transfer evaluation): dashed grey, without markers,
    /// beneath the other series, which keep the styles they would have
    /// without it ([`FLOOR_STYLE`]).
    pub floor: Option<usize>,
}

/// Line charts side by side in one figure (e.g. FBT Fig. 7: distortion
/// and correspondence curves), each panel titled by its chart's `title`
/// (the charts' captions are not drawn), with one legend below the panels
/// shared by all: series with the same label are drawn alike in every
/// panel, and a label that is some panel's `floor` is drawn as the floor in
/// all of them.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct LinePanels {
    /// Title drawn above the panels.
    pub title: String,
    /// Optional caption line.
    pub caption: Option<String>,
    /// The panels, left to right.
    pub panels: Vec<LineChart>,
}

/// Writes `stem.png`, `stem.svg` and `stem.pdf` (atomically): 760 × 640
/// pixels per panel plus the header and the legend. Errors as
/// [`save_line_chart`] does, naming the panel's series, and on a figure
/// without panels.
pub fn save_line_panels(figure: &LinePanels, stem: &Path) -> Result<()> {
    save_line_panels_as(figure, stem, Formats::CHARTS)
}

/// [`save_line_panels`] in the chosen formats.
pub fn save_line_panels_as(figure: &LinePanels, stem: &Path, formats: Formats) -> Result<()> {
    let style = ChartStyle::pixels(PANEL_SIZE.0, PANEL_SIZE.1);
    charts::save_line_panels(figure, stem, formats, &style)
}

/// [`save_line_panels_as`] with each panel of the size of `style` (its
/// text size, its resolution).
pub fn save_line_panels_styled(
    figure: &LinePanels,
    stem: &Path,
    formats: Formats,
    style: &ChartStyle,
) -> Result<()> {
    charts::save_line_panels(figure, stem, formats, style)
}

/// A grouped bar chart: one group per category, one bar per series.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct BarChart {
    /// Title drawn above the plot.
    pub title: String,
    /// Optional caption line.
    pub caption: Option<String>,
    /// y axis label including units.
    pub y_label: String,
    /// Category names along x (e.g. poses, data sets).
    pub categories: Vec<String>,
    /// `(legend label, value per category)`.
    pub series: Vec<(String, Vec<f64>)>,
    /// Optional error bar half-widths, same shape as `series` values.
    pub errors: Option<Vec<Vec<f64>>>,
    /// Logarithmic y axis (timings).
    pub log_y: bool,
}

/// Writes `stem.png`, `stem.svg` and `stem.pdf` ([`Formats::CHARTS`];
/// each atomically: dot-prefixed temporary file + rename). Errors on empty
/// or non-finite data (naming the series) and on I/O. Parent directories
/// are created.
pub fn save_line_chart(chart: &LineChart, stem: &Path) -> Result<()> {
    save_line_chart_as(chart, stem, Formats::CHARTS)
}

/// [`save_line_chart`] in the chosen formats.
pub fn save_line_chart_as(chart: &LineChart, stem: &Path, formats: Formats) -> Result<()> {
    charts::save_line_chart(chart, stem, formats, &ChartStyle::SCREEN)
}

/// [`save_line_chart_as`] at the physical size, text size and resolution
/// of `style` (e.g. [`ChartStyle::PAPER`]).
pub fn save_line_chart_styled(
    chart: &LineChart,
    stem: &Path,
    formats: Formats,
    style: &ChartStyle,
) -> Result<()> {
    charts::save_line_chart(chart, stem, formats, style)
}

/// Writes `stem.png`, `stem.svg` and `stem.pdf` (atomically).
/// Errors on empty charts, values that do not match the categories, and
/// non-finite (or, with `log_y`, non-positive) values, naming the series.
pub fn save_bar_chart(chart: &BarChart, stem: &Path) -> Result<()> {
    save_bar_chart_as(chart, stem, Formats::CHARTS)
}

/// [`save_bar_chart`] in the chosen formats.
pub fn save_bar_chart_as(chart: &BarChart, stem: &Path, formats: Formats) -> Result<()> {
    charts::save_bar_chart(chart, stem, formats, &ChartStyle::SCREEN)
}

/// [`save_bar_chart_as`] in `style` (see [`save_line_chart_styled`]).
pub fn save_bar_chart_styled(
    chart: &BarChart,
    stem: &Path,
    formats: Formats,
    style: &ChartStyle,
) -> Result<()> {
    charts::save_bar_chart(chart, stem, formats, style)
}

/// A table drawn as a figure (timings, ablation numbers): a header row in
/// bold, booktabs-style rules, numeric columns right-aligned.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Table {
    /// Title drawn above the table.
    pub title: String,
    /// Optional caption line.
    pub caption: Option<String>,
    /// Column headers.
    pub columns: Vec<String>,
    /// Cells, one row per entry, each with one cell per column.
    pub rows: Vec<Vec<String>>,
}

/// Writes `stem.png`, `stem.svg` and `stem.pdf` (atomically), sized to the
/// content. Errors on a table without columns or rows and on ragged rows.
pub fn save_table(table: &Table, stem: &Path) -> Result<()> {
    save_table_as(table, stem, Formats::CHARTS)
}

/// [`save_table`] in the chosen formats.
pub fn save_table_as(table: &Table, stem: &Path, formats: Formats) -> Result<()> {
    charts::save_table(table, stem, formats, &ChartStyle::SCREEN)
}

/// [`save_table_as`] with the text size and resolution of `style` (the
/// size follows the content).
pub fn save_table_styled(
    table: &Table,
    stem: &Path,
    formats: Formats,
    style: &ChartStyle,
) -> Result<()> {
    charts::save_table(table, stem, formats, style)
}

/// Viewing direction of a render (orthographic camera looking at the
/// bounding box centre, y up before rotation).
///
/// The model is first turned so that its `up` axis points up (+y), then
/// rotated by `yaw_deg` about the vertical and by `pitch_deg` about the
/// horizontal screen axis; the viewer looks along −z. Yaw 0 pitch 0 views
/// the model from its +z side (for `up = Z`, from its −y side). Positive
/// yaw turns the model counter-clockwise seen from above; positive pitch
/// shows it from above. See the per-dataset constants ([`Camera::FAUST`],
/// [`Camera::TOSCA`], …).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Rotation about the vertical axis, degrees.
    pub yaw_deg: f64,
    /// Rotation about the horizontal axis, degrees.
    pub pitch_deg: f64,
    /// Which model axis is "up" (added field; default [`Up::Y`]).
    pub up: Up,
}

/// The model axis drawn pointing up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Up {
    /// +y is up (FAUST, the synthetic set, Sumner's meshes, Armadillo).
    #[default]
    Y,
    /// +z is up (TOSCA, the cactus).
    Z,
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            yaw_deg: 0.0,
            pitch_deg: 0.0,
            up: Up::Y,
        }
    }
}

/// Per-vertex colouring of a rendered mesh.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum Coloring {
    /// Uniform grey shading.
    #[default]
    Plain,
    /// Scalar per vertex (e.g. error) mapped through the colour map onto
    /// `[lo, hi]`; a colour bar with `label` is drawn.
    Scalar {
        /// One value per vertex.
        values: Vec<f64>,
        /// Range of the colour map (shared across panels for comparison).
        lo: f64,
        /// Upper end of the range.
        hi: f64,
        /// Colour bar label with units.
        label: String,
    },
}

/// One panel of a figure: a mesh, its colouring and its key points.
#[derive(Clone, Debug)]
pub struct Panel {
    /// Caption under the panel (e.g. "source A", "B′ (BDT)").
    pub label: String,
    /// The mesh (drawn in its own coordinates, scaled to fit the panel).
    pub mesh: Mesh,
    /// Vertex colouring.
    pub coloring: Coloring,
    /// Key points: `(vertex, index)`; the same index gets the same colour
    /// in every panel (corresponding points).
    pub keypoints: Vec<(usize, usize)>,
}

/// Panels side by side (BDT Figs. 3, 5, 8, 10–13), in rows of at most
/// [`RenderOptions::max_per_row`].
#[derive(Clone, Debug, Default)]
pub struct Figure {
    /// Title above the panels.
    pub title: String,
    /// Optional caption line.
    pub caption: Option<String>,
    /// The panels, left to right.
    pub panels: Vec<Panel>,
    /// Camera shared by all panels.
    pub camera: Camera,
    /// Pixel size of one panel (width, height).
    pub panel_size: (u32, u32),
}

/// Renders the figure to `stem.png` (atomically; [`save_figure_as`] for
/// SVG and PDF too). Errors on an empty figure, a colouring or key point
/// that does not fit its mesh, and I/O. `panel_size` `(0, 0)` (the
/// `Default`) means [`DEFAULT_PANEL_SIZE`]. Uses [`RenderOptions::default`]
/// (at most [`DEFAULT_MAX_PER_ROW`] panels a row).
pub fn save_figure(figure: &Figure, stem: &Path) -> Result<()> {
    save_figure_with(figure, &RenderOptions::default(), stem)
}

impl Camera {
    /// Straight-on view (yaw 0, pitch 0, y up): the default.
    pub const FRONT: Camera = Camera {
        yaw_deg: 0.0,
        pitch_deg: 0.0,
        up: Up::Y,
    };
    /// FAUST registrations (y up, facing +z): front view, slightly from
    /// above.
    pub const FAUST: Camera = Camera {
        yaw_deg: 0.0,
        pitch_deg: 8.0,
        up: Up::Y,
    };
    /// The synthetic FAUST-style set (y up, facing +z, left at +x): front
    /// view, slightly from above.
    pub const SYNTHETIC: Camera = Camera {
        yaw_deg: 0.0,
        pitch_deg: 8.0,
        up: Up::Y,
    };
    /// TOSCA (z up, facing −y; yaw 0 shows the face): three-quarter view
    /// from the front right and above, head to the right.
    pub const TOSCA: Camera = Camera {
        yaw_deg: 50.0,
        pitch_deg: 15.0,
        up: Up::Z,
    };
    /// The cactus benchmark (z up): the arms to the left and right (yaw 0
    /// would look along the arms), slightly from above.
    pub const CACTUS: Camera = Camera {
        yaw_deg: 90.0,
        pitch_deg: 10.0,
        up: Up::Z,
    };
    /// Sumner & Popović's cat, lion, horse and camel (y up, facing +z):
    /// three-quarter view from the front right and above, head to the right.
    pub const SUMNER: Camera = Camera {
        yaw_deg: 50.0,
        pitch_deg: 15.0,
        up: Up::Y,
    };
    /// The Stanford Armadillo (y up, facing −z): front view.
    pub const ARMADILLO: Camera = Camera {
        yaw_deg: 180.0,
        pitch_deg: 5.0,
        up: Up::Y,
    };
}

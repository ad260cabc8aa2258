//! Paper-style figures: line charts (cumulative error curves, error vs
//! number of key points), grouped bar charts (ablations, timings) and mesh
//! renders (figure panels of shaded meshes with error colour maps and key
//! points). PNG and SVG via plotters with a bundled font (no system
//! libraries). This is one of the layers that does file I/O.
//!
//! Skeleton: the types are the agreed interface; the bodies are being
//! written (see the plot issue work in progress).

use std::path::Path;

use crate::{Error, Mesh, Result};

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

/// Writes `stem.png` and `stem.svg` (atomically: temporary file + rename).
/// Errors on empty or non-finite data (naming the series) and on I/O.
pub fn save_line_chart(chart: &LineChart, stem: &Path) -> Result<()> {
    let _ = chart;
    Err(Error::invalid(format!(
        "{}: line charts are not implemented yet",
        stem.display()
    )))
}

/// Writes `stem.png` and `stem.svg` (atomically).
pub fn save_bar_chart(chart: &BarChart, stem: &Path) -> Result<()> {
    let _ = chart;
    Err(Error::invalid(format!(
        "{}: bar charts are not implemented yet",
        stem.display()
    )))
}

/// Viewing direction of a render (orthographic camera looking at the
/// bounding box centre, y up before rotation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Rotation about the vertical axis, degrees.
    pub yaw_deg: f64,
    /// Rotation about the horizontal axis, degrees.
    pub pitch_deg: f64,
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            yaw_deg: 0.0,
            pitch_deg: 0.0,
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

/// A row of panels side by side (BDT Figs. 3, 5, 8, 10–13).
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

/// Renders the figure to `stem.png` (atomically). Errors on an empty
/// figure, a colouring or key point that does not fit its mesh, and I/O.
pub fn save_figure(figure: &Figure, stem: &Path) -> Result<()> {
    let _ = figure;
    Err(Error::invalid(format!(
        "{}: mesh renders are not implemented yet",
        stem.display()
    )))
}

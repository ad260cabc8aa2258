//! Line charts, grouped bar charts and tables drawn with plotters on any
//! backend: a 2× supersampled bitmap (downsampled to the PNG, which
//! anti-aliases lines) and SVG (converted to the PDF, [`super::pdf`]).
//!
//! Layout (at the 1200 × 800 reference size; everything scales with the
//! supersampling factor): title 30 px bold, caption 20 px, axis labels 22 px,
//! tick labels and legend 19 px. The legend goes into the first corner of
//! the plot area (top right, bottom right, top left, bottom left) that no
//! line, marker or bar touches; if every corner is taken it goes to the
//! right of the plot, outside it.
//!
//! Code layout: `line` (line charts), `panels` (line charts side by side
//! with a shared legend), `bar` (grouped bar charts), `table` (tables);
//! `layout` holds what they share (sizes, header, axis ticks, legend
//! placement, markers, word wrap) and `backend` draws a chart on the
//! supersampled bitmap and the SVG backend and writes the files.

mod backend;
mod bar;
mod layout;
mod line;
mod panels;
mod table;

use plotters::prelude::*;

pub use self::bar::{bar_chart_image, save_bar_chart};
pub(crate) use self::layout::wrap;
pub use self::line::{line_chart_image, save_line_chart};
pub use self::panels::{line_panels_image, save_line_panels};
pub use self::table::save_table;

/// Pixel size of charts (PNG and SVG).
pub const CHART_SIZE: (u32, u32) = (1200, 800);
/// Supersampling factor of the PNG (rendered at this multiple, then box
/// filtered down).
const SUPERSAMPLE: u32 = 2;

type DResult<T> = std::result::Result<T, String>;

fn de<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

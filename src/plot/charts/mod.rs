//! Line charts, grouped bar charts and tables drawn with plotters on any
//! backend: a 2× supersampled bitmap (downsampled to the PNG, which
//! anti-aliases lines) and SVG (converted to the PDF, [`super::pdf`]).
//!
//! Layout (in reference pixels, 1200 × 800 for [`ChartStyle::SCREEN`];
//! everything scales with the [`ChartStyle`] and the supersampling factor):
//! title 30 px bold, caption 20 px, axis labels 22 px, tick labels and
//! legend 19 px (= [`ChartStyle::font_pt`]). The legend goes into the first corner of
//! the plot area (top right, bottom right, top left, bottom left) that no
//! line, marker or bar touches; if every corner is taken it goes to the
//! right of the plot, outside it, or below the plot in rows when it would
//! take more than 40% of the width there (narrow paper charts).
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

/// Pixel size of the charts of [`ChartStyle::SCREEN`] (PNG and SVG), the
/// style of `save_line_chart`, `save_bar_chart`, `line_chart_image`, ….
pub const CHART_SIZE: (u32, u32) = (1200, 800);

/// Size of the tick labels and legend text in the layout's reference
/// pixels; the other sizes of the layout are relative to it.
const REFERENCE_TEXT: f64 = 19.0;

/// Default [`ChartStyle::width_in`]: one column of a two-column paper.
pub const DEFAULT_CHART_WIDTH_IN: f64 = 3.3;
/// Default [`ChartStyle::height_in`].
pub const DEFAULT_CHART_HEIGHT_IN: f64 = 2.5;
/// Default [`ChartStyle::font_pt`]: a paper's figure text.
pub const DEFAULT_FONT_PT: f64 = 8.0;
/// Default [`ChartStyle::dpi`]: print resolution.
pub const DEFAULT_DPI: f64 = 300.0;

/// The physical size of a chart and its text: the layout is drawn so that
/// the tick labels and legend are `font_pt` points tall in a figure
/// `width_in` × `height_in` inches (axis labels are 22/19 of `font_pt`,
/// titles 30/19, the provenance line 20/19); the PNG has `dpi` pixels per
/// inch (recorded in the file), the SVG and PDF are that many inches wide
/// and tall. A figure of line-chart panels is `width_in` wide per panel;
/// a table is sized to its content, in `font_pt` text. Placed at its
/// natural size in a one-column paper (3.3 in), [`ChartStyle::PAPER`]
/// shows 8 pt text.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChartStyle {
    /// Width of a chart (of one panel of a panels figure), inches.
    pub width_in: f64,
    /// Height of a chart's plot, legend and axes, inches (a title and a
    /// shared legend of panels add to it).
    pub height_in: f64,
    /// Size of the tick labels and legend text, points.
    pub font_pt: f64,
    /// Pixels per inch of the PNG.
    pub dpi: f64,
}

impl Default for ChartStyle {
    fn default() -> Self {
        ChartStyle::PAPER
    }
}

impl ChartStyle {
    /// The defaults of `[outputs]`: 3.3 × 2.5 in, 8 pt text, 300 dpi.
    pub const PAPER: ChartStyle = ChartStyle {
        width_in: DEFAULT_CHART_WIDTH_IN,
        height_in: DEFAULT_CHART_HEIGHT_IN,
        font_pt: DEFAULT_FONT_PT,
        dpi: DEFAULT_DPI,
    };
    /// The screen layout of the library's `save_*_chart` functions:
    /// [`CHART_SIZE`] pixels at 96 dpi, 19-pixel text.
    pub const SCREEN: ChartStyle = ChartStyle::pixels(CHART_SIZE.0, CHART_SIZE.1);

    /// A `width` × `height` pixel chart at 96 dpi with 19-pixel text (the
    /// reference layout at scale 1).
    pub const fn pixels(width: u32, height: u32) -> ChartStyle {
        ChartStyle {
            width_in: width as f64 / 96.0,
            height_in: height as f64 / 96.0,
            font_pt: REFERENCE_TEXT * 72.0 / 96.0,
            dpi: 96.0,
        }
    }

    /// Reference pixels per point.
    fn reference_per_pt(&self) -> f64 {
        REFERENCE_TEXT / self.font_pt
    }

    /// The chart's size in reference pixels (whole).
    pub(crate) fn reference_size(&self) -> (u32, u32) {
        let k = 72.0 * self.reference_per_pt();
        (
            (self.width_in * k).round().max(1.0) as u32,
            (self.height_in * k).round().max(1.0) as u32,
        )
    }

    /// PNG pixels per reference pixel.
    pub(crate) fn png_per_reference(&self) -> f64 {
        self.dpi / (72.0 * self.reference_per_pt())
    }

    /// Inches of `reference` pixels.
    pub(crate) fn inches(&self, reference: f64) -> f64 {
        reference / (72.0 * self.reference_per_pt())
    }

    /// Errors unless every field is finite and positive.
    pub fn check(&self) -> std::result::Result<(), String> {
        for (name, v) in [
            ("width_in", self.width_in),
            ("height_in", self.height_in),
            ("font_pt", self.font_pt),
            ("dpi", self.dpi),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!(
                    "chart style: {name} = {v} must be finite and positive"
                ));
            }
        }
        Ok(())
    }
}
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The screen style is the reference layout at scale 1 (the library's
    /// 1200 × 800 charts); the paper style puts 8 pt text in 3.3 in.
    #[test]
    fn chart_styles_scale_the_reference_layout() {
        let s = ChartStyle::SCREEN;
        assert_eq!(s.reference_size(), CHART_SIZE);
        assert!((s.png_per_reference() - 1.0).abs() < 1e-12);
        let p = ChartStyle::default();
        assert_eq!(p, ChartStyle::PAPER);
        let (w, h) = p.reference_size();
        // 19 reference pixels of tick text are 8 pt: 3.3 in = 237.6 pt.
        assert_eq!((w, h), (564, 428));
        let png_w = w as f64 * p.png_per_reference();
        assert!((png_w - 3.3 * 300.0).abs() < 1.0, "{png_w}");
        assert!((p.inches(w as f64) - 3.3).abs() < 0.01);
        // Tick text in the PNG: 8 pt at 300 dpi.
        let tick_px = 19.0 * p.png_per_reference();
        assert!((tick_px - 8.0 / 72.0 * 300.0).abs() < 1e-9, "{tick_px}");
        assert!(ChartStyle { dpi: 0.0, ..p }.check().is_err());
        assert!(ChartStyle {
            font_pt: f64::NAN,
            ..p
        }
        .check()
        .is_err());
    }
}

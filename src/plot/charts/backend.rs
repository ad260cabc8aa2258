//! One chart drawing routine on both backends ([`ChartDraw`]): the 2×
//! supersampled bitmap (with automatic legend placement, box-filtered down
//! to the PNG) and the SVG (converted to the PDF), and the writing of the
//! files asked for.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::layout::{LegendPos, Metrics};
use super::{DResult, SUPERSAMPLE};
use crate::plot::font::{ensure_font, GlyphBackend};
use crate::plot::output::{with_suffix, write_bytes_atomic, write_png_atomic, Formats, Image};
use crate::plot::pdf::svg_to_pdf;
use crate::{Error, Result};

/// One chart drawing routine on both backends.
pub(super) trait ChartDraw {
    fn draw_bitmap(
        &self,
        root: &DrawingArea<GlyphBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>>;
    fn draw_svg(
        &self,
        root: &DrawingArea<SVGBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>>;
}

/// Draws `chart` on a supersampled bitmap with automatic legend placement
/// (redrawn with the legend outside if no corner is free) and box-filters
/// it down to `size`. `name` is the file named in errors.
pub(super) fn bitmap<C: ChartDraw>(
    chart: &C,
    size: (u32, u32),
    name: &str,
) -> Result<(Image, Option<LegendPos>)> {
    ensure_font()?;
    let fail = |msg: String| Error::invalid(format!("{name}: drawing failed: {msg}"));
    let (w, h) = (size.0 * SUPERSAMPLE, size.1 * SUPERSAMPLE);
    let m = Metrics {
        s: SUPERSAMPLE as f64,
    };
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let mut placement = {
        let root = GlyphBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let r = chart.draw_bitmap(&root, None, m).map_err(fail)?;
        root.present().map_err(|e| fail(e.to_string()))?;
        r
    };
    if placement.is_none() {
        let root = GlyphBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        placement = chart
            .draw_bitmap(&root, Some(LegendPos::Outside), m)
            .map_err(fail)?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    let big = Image {
        width: w,
        height: h,
        rgb: buf,
    };
    Ok((big.downsample(SUPERSAMPLE), placement))
}

/// Every rendering in memory first (the bitmap always: it places the
/// legend), then the files `formats` asks for, each atomically.
pub(super) fn render_chart<C: ChartDraw>(
    chart: &C,
    stem: &Path,
    size: (u32, u32),
    formats: Formats,
) -> Result<()> {
    if formats.is_empty() {
        return Err(Error::invalid(format!(
            "{}: no output format chosen",
            stem.display()
        )));
    }
    let png = with_suffix(stem, "png")?;
    let svg = with_suffix(stem, "svg")?;
    let pdf = with_suffix(stem, "pdf")?;
    let (image, placement) = bitmap(chart, size, &png.display().to_string())?;
    let mut text = String::new();
    if formats.svg || formats.pdf {
        let fail =
            |msg: String| Error::invalid(format!("{}: drawing failed: {msg}", svg.display()));
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        chart
            .draw_svg(&root, placement, Metrics { s: 1.0 })
            .map_err(fail)?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    let pdf_bytes = if formats.pdf {
        Some(svg_to_pdf(&text, &pdf.display().to_string())?)
    } else {
        None
    };
    if formats.png {
        write_png_atomic(&png, &image)?;
    }
    if formats.svg {
        write_bytes_atomic(&svg, text.as_bytes())?;
    }
    if let Some(bytes) = pdf_bytes {
        write_bytes_atomic(&pdf, &bytes)?;
    }
    Ok(())
}

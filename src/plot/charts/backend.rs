//! One chart drawing routine on both backends ([`ChartDraw`]): the 2×
//! supersampled bitmap (with automatic legend placement, box-filtered down
//! to the PNG) and the SVG (converted to the PDF), and the writing of the
//! files asked for.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::layout::{LegendPos, Metrics};
use super::{ChartStyle, DResult, SUPERSAMPLE};
use crate::plot::font::{ensure_font, GlyphBackend};
use crate::plot::output::{encode_png_dpi, with_suffix, write_bytes_atomic, Formats, Image};
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

/// Largest side of a chart's PNG, pixels.
const MAX_PNG_SIDE: u32 = 10_000;

/// The PNG size of a chart of `reference` size (reference pixels) in
/// `style`; errors (naming `name`) beyond [`MAX_PNG_SIDE`].
fn png_size(reference: (u32, u32), style: &ChartStyle, name: &str) -> Result<(u32, u32)> {
    style
        .check()
        .map_err(|e| Error::invalid(format!("{name}: {e}")))?;
    let k = style.png_per_reference();
    let (w, h) = (
        (reference.0 as f64 * k).round().max(1.0),
        (reference.1 as f64 * k).round().max(1.0),
    );
    if w > MAX_PNG_SIDE as f64 || h > MAX_PNG_SIDE as f64 {
        return Err(Error::invalid(format!(
            "{name}: the PNG would be {w}×{h} pixels (at most {MAX_PNG_SIDE} a side); \
             lower the dpi or the size"
        )));
    }
    Ok((w as u32, h as u32))
}

/// Draws `chart` (laid out on `reference` pixels) on a supersampled bitmap
/// with automatic legend placement (redrawn with the legend outside if no
/// corner is free) and box-filters it down to the PNG size of `style`.
/// `name` is the file named in errors.
pub(super) fn bitmap<C: ChartDraw>(
    chart: &C,
    reference: (u32, u32),
    style: &ChartStyle,
    name: &str,
) -> Result<(Image, Option<LegendPos>)> {
    ensure_font()?;
    let fail = |msg: String| Error::invalid(format!("{name}: drawing failed: {msg}"));
    let size = png_size(reference, style, name)?;
    let (w, h) = (size.0 * SUPERSAMPLE, size.1 * SUPERSAMPLE);
    let m = Metrics {
        s: SUPERSAMPLE as f64 * size.0 as f64 / reference.0 as f64,
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

/// `svg` with its size given in points (the drawing keeps its reference
/// pixels as the view box), so the SVG and the PDF converted from it have
/// the physical size of `style` (points rather than inches: a size in
/// whole CSS pixels stays whole, 800 px = 600 pt).
fn physical_svg(svg: &str, reference: (u32, u32), style: &ChartStyle) -> String {
    let old = format!("<svg width=\"{}\" height=\"{}\"", reference.0, reference.1);
    let pt = |px: u32| {
        let v = (style.inches(px as f64) * 72.0 * 1000.0).round() / 1000.0;
        format!("{v}pt")
    };
    let new = format!(
        "<svg width=\"{}\" height=\"{}\"",
        pt(reference.0),
        pt(reference.1)
    );
    svg.replacen(&old, &new, 1)
}

/// Every rendering in memory first (the bitmap always: it places the
/// legend), then the files `formats` asks for, each atomically: the chart
/// laid out on `reference` pixels, at the physical size of `style`.
pub(super) fn render_chart<C: ChartDraw>(
    chart: &C,
    stem: &Path,
    reference: (u32, u32),
    style: &ChartStyle,
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
    let (image, placement) = bitmap(chart, reference, style, &png.display().to_string())?;
    let mut text = String::new();
    if formats.svg || formats.pdf {
        let fail =
            |msg: String| Error::invalid(format!("{}: drawing failed: {msg}", svg.display()));
        {
            let root = SVGBackend::with_string(&mut text, reference).into_drawing_area();
            chart
                .draw_svg(&root, placement, Metrics { s: 1.0 })
                .map_err(fail)?;
            root.present().map_err(|e| fail(e.to_string()))?;
        }
        text = physical_svg(&text, reference, style);
    }
    let pdf_bytes = if formats.pdf {
        Some(svg_to_pdf(&text, &pdf.display().to_string())?)
    } else {
        None
    };
    if formats.png {
        write_bytes_atomic(&png, &encode_png_dpi(&image, Some(style.dpi))?)?;
    }
    if formats.svg {
        write_bytes_atomic(&svg, text.as_bytes())?;
    }
    if let Some(bytes) = pdf_bytes {
        write_bytes_atomic(&pdf, &bytes)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_size_is_written_in_inches() {
        let svg = "<svg width=\"564\" height=\"428\" viewBox=\"0 0 564 428\" xmlns=\"x\">\n</svg>";
        let out = physical_svg(svg, (564, 428), &ChartStyle::PAPER);
        assert!(
            out.starts_with(
                "<svg width=\"237.474pt\" height=\"180.211pt\" viewBox=\"0 0 564 428\""
            ),
            "{out}"
        );
        let screen = svg.replace("564", "1200").replace("428", "800");
        let out = physical_svg(&screen, (1200, 800), &ChartStyle::SCREEN);
        assert!(
            out.starts_with("<svg width=\"900pt\" height=\"600pt\""),
            "{out}"
        );
    }
}

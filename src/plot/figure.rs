//! Figure composition: panels side by side (wrapping onto further rows
//! after [`RenderOptions::max_per_row`] panels), a title and caption on top
//! (the caption word-wrapped to the panels' width),
//! labels under the panels, and one colour bar per distinct scalar range on
//! the right. The mesh raster comes from [`super::render`]; all text, the
//! colour bars' frames and ticks are drawn by plotters with the bundled font
//! on top of it: into the raster for the PNG, as vector elements over the
//! embedded raster (at [`VECTOR_RASTER_SCALE`] times the resolution) for the
//! SVG, which the PDF is converted from.

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontTransform;

use super::axis::{format_tick, Axis};
use super::charts::wrap;
use super::font::{self, ensure_font, GlyphBackend};
use super::output::{
    base64, encode_png, with_suffix, write_bytes_atomic, write_png_atomic, Formats, Image,
};
use super::pdf::svg_to_pdf;
use super::render::{check_panel, render_mesh, RenderOptions, View};
use super::{Coloring, Figure};
use crate::{Error, Result};

/// Panel size used when a figure leaves `panel_size` at `(0, 0)`.
pub const DEFAULT_PANEL_SIZE: (u32, u32) = (480, 640);
/// Smallest accepted panel side, in pixels.
const MIN_PANEL: u32 = 64;
/// Largest accepted panel side, in pixels.
const MAX_PANEL: u32 = 2048;

const TITLE_PX: f64 = 28.0;
const CAPTION_PX: f64 = 20.0;
const LABEL_PX: f64 = 22.0;
const TICK_PX: f64 = 18.0;
const BAR_LABEL_PX: f64 = 20.0;
/// Resolution of the mesh raster embedded in an SVG (and so a PDF) figure,
/// relative to the PNG's: sharper when the vector figure is enlarged.
pub const VECTOR_RASTER_SCALE: u32 = 2;

/// One colour bar: range and label.
#[derive(Clone, Debug, PartialEq)]
struct Bar {
    lo: f64,
    hi: f64,
    label: String,
}

/// Pixel layout of a figure.
#[derive(Clone, Debug)]
struct Layout {
    panel: (u32, u32),
    /// Panels per row.
    cols: u32,
    /// Left edge of the first panel (non-zero when the title is wider than
    /// the panels and colour bars).
    x0: u32,
    header: u32,
    /// The caption, word-wrapped to the figure's width.
    caption: Vec<String>,
    /// Height below each row of panels (their labels).
    footer: u32,
    bars: Vec<(Bar, u32, u32)>, // (bar, x of its column, column width)
    /// Top and bottom (exclusive) of the colour bars.
    bar_span: (u32, u32),
    width: u32,
    height: u32,
}

impl Layout {
    /// Top left corner of panel `i`.
    fn panel_origin(&self, i: usize) -> (u32, u32) {
        let (c, r) = (i as u32 % self.cols, i as u32 / self.cols);
        (
            self.x0 + c * self.panel.0,
            self.header + r * (self.panel.1 + self.footer),
        )
    }
}

/// Line height of the panel labels.
const LABEL_LINE_PX: u32 = 26;

/// A panel's label as lines that fit its width (a label that fits stays one
/// line; at most three, the last cut with an ellipsis); none for an empty
/// label.
fn panel_label_lines(label: &str, panel_width: u32) -> Vec<String> {
    if label.is_empty() {
        return Vec::new();
    }
    let width = panel_width.saturating_sub(8).max(40) as f64;
    let mut lines = super::charts::wrap(label, LABEL_PX, width);
    if lines.len() > 3 {
        lines.truncate(3);
        lines[2].push('…');
    }
    lines
}

fn text_width(text: &str, size: f64) -> u32 {
    font::text_size(text, size, false).0
}

const BAR_TICKS: usize = 6;

fn bar_ticks(b: &Bar) -> (Vec<f64>, f64) {
    Axis::linear(b.lo, b.hi).major_ticks(BAR_TICKS)
}

/// Width of a colour bar column: gap, bar, ticks, tick labels, rotated
/// label.
fn bar_column_width(b: &Bar) -> u32 {
    let (ticks, step) = bar_ticks(b);
    let tw = ticks
        .iter()
        .map(|&t| text_width(&format_tick(t, step), TICK_PX))
        .max()
        .unwrap_or(0);
    let label_h = if b.label.is_empty() { 0 } else { 34 };
    20 + 24 + 8 + tw + 10 + label_h + 14
}

fn layout(fig: &Figure, opts: &RenderOptions) -> Result<Layout> {
    let panel = if fig.panel_size.0 == 0 || fig.panel_size.1 == 0 {
        DEFAULT_PANEL_SIZE
    } else {
        fig.panel_size
    };
    let n = fig.panels.len() as u32;
    let cols = match opts.max_per_row {
        0 => n,
        k => n.min(k as u32),
    }
    .max(1);
    let rows = n.div_ceil(cols).max(1);
    // Labels wider than a panel wrap onto more lines (at most three).
    let label_lines = fig
        .panels
        .iter()
        .map(|p| panel_label_lines(&p.label, fig.panel_size.0).len() as u32)
        .max()
        .unwrap_or(0);
    let footer = if label_lines > 0 {
        22 + LABEL_LINE_PX * label_lines
    } else {
        12
    };
    let mut bars: Vec<Bar> = Vec::new();
    for p in &fig.panels {
        if let Coloring::Scalar { lo, hi, label, .. } = &p.coloring {
            let b = Bar {
                lo: *lo,
                hi: *hi,
                label: label.clone(),
            };
            if !bars.contains(&b) {
                bars.push(b);
            }
        }
    }
    let content: u32 = cols * panel.0 + bars.iter().map(bar_column_width).sum::<u32>();
    let title_w = font::text_size(&fig.title, TITLE_PX, true).0;
    // The caption wraps to the panels' (or the title's) width.
    let caption: Vec<String> = match fig.caption.as_deref().filter(|c| !c.is_empty()) {
        Some(c) => wrap(
            c,
            CAPTION_PX,
            content.max(title_w + 40).saturating_sub(40) as f64,
        ),
        None => Vec::new(),
    };
    let caption_w = caption
        .iter()
        .map(|l| font::text_size(l, CAPTION_PX, false).0)
        .max()
        .unwrap_or(0);
    let need = title_w.max(caption_w) + 40;
    let mut header = 12u32;
    if !fig.title.is_empty() {
        header += 40;
    }
    header += 30 * caption.len() as u32 + 4;
    let x0 = need.saturating_sub(content) / 2;
    let mut x = x0 + cols * panel.0;
    let mut cols_of_bars = Vec::new();
    for b in bars {
        let w = bar_column_width(&b);
        cols_of_bars.push((b, x, w));
        x += w;
    }
    // The bars: three quarters of a panel high, centred on the grid.
    let grid_h = rows * panel.1 + (rows - 1) * footer;
    let bar_h = panel.1 - 2 * (panel.1 / 8);
    let bar_top = header + (grid_h - bar_h) / 2;
    Ok(Layout {
        panel,
        cols,
        x0,
        header,
        caption,
        footer,
        width: x.max(need),
        height: header + rows * (panel.1 + footer),
        bars: cols_of_bars,
        bar_span: (bar_top, bar_top + bar_h),
    })
}

/// Validates a figure (non-empty, sizes, every panel against its mesh);
/// `name` is the output file named in errors.
fn check(fig: &Figure, name: &str) -> Result<()> {
    if fig.panels.is_empty() {
        return Err(Error::invalid(format!(
            "{name}: figure \"{}\" has no panels",
            fig.title
        )));
    }
    let (w, h) = fig.panel_size;
    let ok = |v: u32| (MIN_PANEL..=MAX_PANEL).contains(&v);
    if (w, h) != (0, 0) && !(ok(w) && ok(h)) {
        return Err(Error::invalid(format!(
            "{name}: panel size {w}×{h} outside {MIN_PANEL}..={MAX_PANEL} pixels per side \
             ((0, 0) picks the default {}×{})",
            DEFAULT_PANEL_SIZE.0, DEFAULT_PANEL_SIZE.1
        )));
    }
    for (i, p) in fig.panels.iter().enumerate() {
        check_panel(p, &format!("{name}: panel {i} (\"{}\")", p.label))?;
    }
    if !(fig.camera.yaw_deg.is_finite() && fig.camera.pitch_deg.is_finite()) {
        return Err(Error::invalid(format!(
            "{name}: camera angles must be finite (yaw {}, pitch {})",
            fig.camera.yaw_deg, fig.camera.pitch_deg
        )));
    }
    Ok(())
}

/// The pixels of a figure without its text and rules: the panels' meshes
/// and the colour bars' gradients, at `k` times the layout's resolution.
fn compose(fig: &Figure, opts: &RenderOptions, lay: &Layout, k: u32, name: &str) -> Result<Image> {
    let (pw, ph) = (lay.panel.0 * k, lay.panel.1 * k);
    let mut img = Image::new(lay.width * k, lay.height * k, [255, 255, 255]);
    let common = if opts.shared_scale {
        fig.panels
            .iter()
            .map(|p| View::fit(&p.mesh, fig.camera, pw, ph, opts.margin).scale)
            .fold(f64::INFINITY, f64::min)
    } else {
        f64::INFINITY
    };
    for (i, p) in fig.panels.iter().enumerate() {
        let view = View::fit_at_most(&p.mesh, fig.camera, pw, ph, opts.margin, common);
        let raster = render_mesh(p, &view, pw, ph, opts)
            .map_err(|e| Error::invalid(format!("{name}: panel {i}: {e}")))?;
        let (x, y) = lay.panel_origin(i);
        img.blit(&raster, x * k, y * k);
    }
    let (top, bottom) = (lay.bar_span.0 * k, lay.bar_span.1 * k);
    for (_, x, _) in &lay.bars {
        let x0 = (x + 20) * k;
        for y in top..bottom {
            let t = (bottom - 1 - y) as f64 / (bottom - 1 - top).max(1) as f64;
            let c = opts.colormap.color(t);
            for xx in x0..x0 + 24 * k {
                img.set(xx, y, c);
            }
        }
    }
    Ok(img)
}

/// The title, caption, panel labels and the colour bars' frames, ticks and
/// labels, on any backend (layout pixels).
fn draw_overlay<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    fig: &Figure,
    lay: &Layout,
) -> std::result::Result<(), String> {
    let de = |e: plotters::drawing::DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let w = lay.width;
    let mut y = 12;
    if !fig.title.is_empty() {
        root.draw_text(
            &fig.title,
            &font::bold(TITLE_PX, BLACK).pos(Pos::new(HPos::Center, VPos::Top)),
            (w as i32 / 2, y),
        )
        .map_err(de)?;
        y += 40;
    }
    for line in &lay.caption {
        root.draw_text(
            line,
            &font::text(CAPTION_PX, RGBColor(70, 70, 70)).pos(Pos::new(HPos::Center, VPos::Top)),
            (w as i32 / 2, y),
        )
        .map_err(de)?;
        y += 30;
    }
    let (pw, ph) = lay.panel;
    for (i, p) in fig.panels.iter().enumerate() {
        if p.label.is_empty() {
            continue;
        }
        let (x, y) = lay.panel_origin(i);
        for (k, line) in panel_label_lines(&p.label, pw).iter().enumerate() {
            root.draw_text(
                line,
                &font::text(LABEL_PX, BLACK).pos(Pos::new(HPos::Center, VPos::Top)),
                (
                    (x + pw / 2) as i32,
                    (y + ph + 12 + LABEL_LINE_PX * k as u32) as i32,
                ),
            )
            .map_err(de)?;
        }
    }
    for (b, x, cw) in &lay.bars {
        let x0 = (x + 20) as i32;
        let (t0, t1) = (lay.bar_span.0 as i32, lay.bar_span.1 as i32 - 1);
        root.draw(&Rectangle::new(
            [(x0 - 1, t0 - 1), (x0 + 24, t1 + 1)],
            BLACK.stroke_width(1),
        ))
        .map_err(de)?;
        let (ticks, step) = bar_ticks(b);
        for t in ticks {
            let f = (t - b.lo) / (b.hi - b.lo);
            let ty = (t1 as f64 - f * (t1 - t0) as f64).round() as i32;
            root.draw(&PathElement::new(
                vec![(x0 + 24, ty), (x0 + 30, ty)],
                BLACK.stroke_width(1),
            ))
            .map_err(de)?;
            root.draw_text(
                &format_tick(t, step),
                &font::text(TICK_PX, BLACK).pos(Pos::new(HPos::Left, VPos::Center)),
                (x0 + 33, ty),
            )
            .map_err(de)?;
        }
        if !b.label.is_empty() {
            let lx = (x + cw - 14 - 17) as i32;
            root.draw_text(
                &b.label,
                &font::text(BAR_LABEL_PX, BLACK)
                    .pos(Pos::new(HPos::Center, VPos::Center))
                    .transform(FontTransform::Rotate270),
                (lx, (t0 + t1) / 2),
            )
            .map_err(de)?;
        }
    }
    root.present().map_err(de)?;
    Ok(())
}

/// Renders a whole figure into an image (what [`super::save_figure`]
/// writes). `name` is used in error messages.
pub fn render_figure(fig: &Figure, opts: &RenderOptions, name: &str) -> Result<Image> {
    check(fig, name)?;
    ensure_font()?;
    let lay = layout(fig, opts)?;
    let mut img = compose(fig, opts, &lay, 1, name)?;
    let (w, h) = (img.width, img.height);
    {
        let root = GlyphBackend::with_buffer(&mut img.rgb, (w, h)).into_drawing_area();
        draw_overlay(&root, fig, &lay)
            .map_err(|e| Error::invalid(format!("{name}: drawing text failed: {e}")))?;
    }
    Ok(img)
}

/// The SVG of a figure: the mesh raster ([`VECTOR_RASTER_SCALE`] times the
/// PNG's resolution) embedded as a PNG image, the text and rules as vector
/// elements over it. `name` is used in error messages.
pub fn figure_svg(fig: &Figure, opts: &RenderOptions, name: &str) -> Result<String> {
    check(fig, name)?;
    ensure_font()?;
    let lay = layout(fig, opts)?;
    let raster = compose(fig, opts, &lay, VECTOR_RASTER_SCALE, name)?;
    let png = encode_png(&raster)?;
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (lay.width, lay.height)).into_drawing_area();
        draw_overlay(&root, fig, &lay)
            .map_err(|e| Error::invalid(format!("{name}: drawing text failed: {e}")))?;
    }
    // The raster goes first, under everything else: right after the root
    // element's start tag.
    let at = text
        .find("<svg")
        .and_then(|i| text[i..].find('>').map(|j| i + j + 1))
        .ok_or_else(|| Error::invalid(format!("{name}: the SVG backend wrote no <svg> element")))?;
    let image = format!(
        "\n<image x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" preserveAspectRatio=\"none\" \
         href=\"data:image/png;base64,{}\"/>",
        lay.width,
        lay.height,
        base64(&png)
    );
    text.insert_str(at, &image);
    Ok(text)
}

/// See [`super::save_figure`]: the PNG only ([`Formats::RENDERS`]).
pub fn save_figure_with(fig: &Figure, opts: &RenderOptions, stem: &Path) -> Result<()> {
    save_figure_as(fig, opts, stem, Formats::RENDERS)
}

/// Renders the figure to the chosen files: `stem.png` ([`render_figure`]),
/// `stem.svg` ([`figure_svg`]), `stem.pdf` (from the SVG), each
/// atomically, none before all are drawn. Errors as [`super::save_figure`].
pub fn save_figure_as(
    fig: &Figure,
    opts: &RenderOptions,
    stem: &Path,
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
    let name = if formats.png {
        png.display().to_string()
    } else {
        formats.describe(stem)
    };
    let img = if formats.png {
        Some(render_figure(fig, opts, &name)?)
    } else {
        None
    };
    let text = if formats.svg || formats.pdf {
        Some(figure_svg(fig, opts, &name)?)
    } else {
        None
    };
    let pdf_bytes = match (&text, formats.pdf) {
        (Some(t), true) => Some(svg_to_pdf(t, &pdf.display().to_string())?),
        _ => None,
    };
    if let Some(img) = img {
        write_png_atomic(&png, &img)?;
    }
    if let (Some(t), true) = (&text, formats.svg) {
        write_bytes_atomic(&svg, t.as_bytes())?;
    }
    if let Some(b) = pdf_bytes {
        write_bytes_atomic(&pdf, &b)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panel_labels_wrap_to_the_panel_width() {
        assert!(panel_label_lines("", 260).is_empty());
        assert_eq!(panel_label_lines("target B", 260), ["target B"]);
        let long = "Sumner & Popović, oracle correspondence";
        let lines = panel_label_lines(long, 260);
        assert!(lines.len() >= 2, "{lines:?}");
        assert_eq!(lines.join(" "), long);
        for l in &lines {
            assert!(
                text_width(l, LABEL_PX) <= 252,
                "{l:?} is wider than the panel"
            );
        }
        let very = "word ".repeat(60);
        let cut = panel_label_lines(very.trim(), 260);
        assert_eq!(cut.len(), 3);
        assert!(cut[2].ends_with('…'));
    }
}

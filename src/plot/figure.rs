//! Figure composition: panels side by side, a title and caption on top,
//! labels under the panels, and one colour bar per distinct scalar range on
//! the right. The mesh raster comes from [`super::render`]; all text is drawn
//! by plotters with the bundled font on top of it.

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontTransform;

use super::axis::{format_tick, Axis};
use super::font::{self, ensure_font, GlyphBackend};
use super::output::{with_suffix, write_png_atomic, Image};
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
    /// Left edge of the first panel (non-zero when the title is wider than
    /// the panels and colour bars).
    x0: u32,
    header: u32,
    bars: Vec<(Bar, u32, u32)>, // (bar, x of its column, column width)
    width: u32,
    height: u32,
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

fn layout(fig: &Figure) -> Result<Layout> {
    let panel = if fig.panel_size.0 == 0 || fig.panel_size.1 == 0 {
        DEFAULT_PANEL_SIZE
    } else {
        fig.panel_size
    };
    let n = fig.panels.len() as u32;
    let mut header = 12u32;
    if !fig.title.is_empty() {
        header += 40;
    }
    if fig.caption.as_deref().is_some_and(|c| !c.is_empty()) {
        header += 30;
    }
    header += 4;
    let footer = if fig.panels.iter().any(|p| !p.label.is_empty()) {
        48
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
    let content: u32 = n * panel.0 + bars.iter().map(bar_column_width).sum::<u32>();
    let title_w = font::text_size(&fig.title, TITLE_PX, true).0;
    let caption_w = fig
        .caption
        .as_deref()
        .map_or(0, |c| font::text_size(c, CAPTION_PX, false).0);
    let need = title_w.max(caption_w) + 40;
    let x0 = need.saturating_sub(content) / 2;
    let mut x = x0 + n * panel.0;
    let mut cols = Vec::new();
    for b in bars {
        let w = bar_column_width(&b);
        cols.push((b, x, w));
        x += w;
    }
    Ok(Layout {
        panel,
        x0,
        header,
        width: x.max(need),
        height: header + panel.1 + footer,
        bars: cols,
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

/// Renders a whole figure into an image (what [`super::save_figure`]
/// writes). `name` is used in error messages.
pub fn render_figure(fig: &Figure, opts: &RenderOptions, name: &str) -> Result<Image> {
    check(fig, name)?;
    ensure_font()?;
    let lay = layout(fig)?;
    let (pw, ph) = lay.panel;
    let mut img = Image::new(lay.width, lay.height, [255, 255, 255]);
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
        img.blit(&raster, lay.x0 + i as u32 * pw, lay.header);
    }
    // Colour bar gradients (pixels), then all text with plotters.
    let bar_top = lay.header + ph / 8;
    let bar_bottom = lay.header + ph - ph / 8;
    for (_, x, _) in &lay.bars {
        let x0 = x + 20;
        for y in bar_top..bar_bottom {
            let t = (bar_bottom - 1 - y) as f64 / (bar_bottom - 1 - bar_top).max(1) as f64;
            let c = opts.colormap.color(t);
            for xx in x0..x0 + 24 {
                img.set(xx, y, c);
            }
        }
    }
    let draw = |img: &mut Image| -> std::result::Result<(), String> {
        let (w, h) = (img.width, img.height);
        let root = GlyphBackend::with_buffer(&mut img.rgb, (w, h)).into_drawing_area();
        let de = |e: plotters::drawing::DrawingAreaErrorKind<_>| e.to_string();
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
        if let Some(c) = fig.caption.as_deref().filter(|c| !c.is_empty()) {
            root.draw_text(
                c,
                &font::text(CAPTION_PX, RGBColor(70, 70, 70))
                    .pos(Pos::new(HPos::Center, VPos::Top)),
                (w as i32 / 2, y),
            )
            .map_err(de)?;
        }
        for (i, p) in fig.panels.iter().enumerate() {
            if p.label.is_empty() {
                continue;
            }
            let cx = lay.x0 + i as u32 * pw + pw / 2;
            root.draw_text(
                &p.label,
                &font::text(LABEL_PX, BLACK).pos(Pos::new(HPos::Center, VPos::Top)),
                (cx as i32, (lay.header + ph + 12) as i32),
            )
            .map_err(de)?;
        }
        for (b, x, cw) in &lay.bars {
            let x0 = (x + 20) as i32;
            let (t0, t1) = (bar_top as i32, bar_bottom as i32 - 1);
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
    };
    draw(&mut img).map_err(|e| Error::invalid(format!("{name}: drawing text failed: {e}")))?;
    Ok(img)
}

/// See [`super::save_figure`].
pub fn save_figure_with(fig: &Figure, opts: &RenderOptions, stem: &Path) -> Result<()> {
    let png = with_suffix(stem, "png")?;
    let img = render_figure(fig, opts, &png.display().to_string())?;
    write_png_atomic(&png, &img)
}

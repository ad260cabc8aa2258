//! What every chart kind shares: sizes at the reference scale
//! ([`Metrics`]), the header, the legend (size, placement in a free corner
//! of the plot or outside it, drawing), polylines and markers in pixels,
//! word wrap, and the axes' tick labels (log ranges, tick formatting, the
//! room the y labels need).

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{de, rgb, DResult};
use crate::plot::axis::{format_log_tick, format_tick, log_axis_is_scientific, Axis, Scale};
use crate::plot::font;
use crate::plot::style::{Marker, SeriesStyle};

/// Size of the legend and tick text at the reference scale.
const LEGEND_TEXT: f64 = 19.0;

/// Which corner of the plot area holds the legend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Corner {
    TopRight,
    BottomRight,
    TopLeft,
    BottomLeft,
}

const CORNERS: [Corner; 4] = [
    Corner::TopRight,
    Corner::BottomRight,
    Corner::TopLeft,
    Corner::BottomLeft,
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum LegendPos {
    Inside(Corner),
    /// Right of the plot.
    Outside,
    /// Below the plot, entries in rows.
    Below,
}

/// Share of a chart's width a legend right of the plot may take; a wider
/// one goes below the plot.
const OUTSIDE_SHARE: f64 = 0.4;
/// Charts narrower than this (reference pixels; a one-column chart is
/// 564) put a legend that fits no corner below the plot, never beside it.
const NARROW: f64 = 800.0;

/// Whether a legend `lw` reference pixels wide that fits no corner goes
/// below the plot of a chart `width` reference pixels wide (else beside).
fn goes_below(lw: f64, width: f64) -> bool {
    width < NARROW || lw + 24.0 > OUTSIDE_SHARE * width
}

/// Where a legend that fits in no corner goes (`Outside` asked): right of
/// the plot, or below it ([`goes_below`]; `width` in pixels).
pub(super) fn outside_or_below(
    legend: Option<LegendPos>,
    lsize: (f64, f64),
    width: f64,
    m: Metrics,
) -> Option<LegendPos> {
    match legend {
        Some(LegendPos::Outside) if goes_below(lsize.0 / m.s, width / m.s) => {
            Some(LegendPos::Below)
        }
        l => l,
    }
}

/// A legend below the plot: the entries (indices) of each row and its
/// rectangle.
pub(super) type BelowLegend = (Vec<Vec<usize>>, Rect);

/// Room for the legend in `body`: the legend's place (`Outside` turns
/// `Below` when it does not fit, [`outside_or_below`]), the plot area, the
/// x of a legend right of the plot, and a legend below it.
pub(super) fn room_for_legend<DB: DrawingBackend>(
    body: &DrawingArea<DB, Shift>,
    legend: Option<LegendPos>,
    lsize: (f64, f64),
    entries: &[LegendEntry],
    m: Metrics,
) -> (
    Option<LegendPos>,
    DrawingArea<DB, Shift>,
    Option<f64>,
    Option<BelowLegend>,
) {
    let (bw, bh) = body.dim_in_pixel();
    let legend = outside_or_below(legend, lsize, bw as f64, m);
    let mut below = None;
    let (plot_area, legend_x) = match legend {
        Some(LegendPos::Outside) => {
            let lw = (lsize.0 + m.px(24.0)) as u32;
            let (a, _) = body.split_horizontally(bw.saturating_sub(lw));
            (a, Some(bw.saturating_sub(lw) as f64 + m.px(8.0)))
        }
        Some(LegendPos::Below) => {
            let labels: Vec<&str> = entries.iter().map(|e| e.label).collect();
            let rows = below_rows(&labels, bw as f64 / m.s - 20.0);
            let lh = m.px(below_height(rows.len())).round() as u32;
            let (a, b) = body.split_vertically(bh.saturating_sub(lh));
            let (xr, yr) = b.get_pixel_range();
            let area = (
                xr.start as f64,
                yr.start as f64,
                xr.end as f64,
                yr.end as f64,
            );
            below = Some((rows, area));
            (a, None)
        }
        _ => (body.clone(), None),
    };
    (legend, plot_area, legend_x, below)
}

/// Gap between legend entries of a row below the plot.
const ROW_GAP: f64 = 20.0;

/// Width (reference pixels) of a legend entry in a row below the plot.
fn below_entry_width(label: &str) -> f64 {
    48.0 + 12.0 + ROW_GAP + font::text_size(label, LEGEND_TEXT, false).0 as f64
}

/// A legend below the plot: the entries (indices) of each row, filled left
/// to right within `width` reference pixels.
pub(super) fn below_rows(labels: &[&str], width: f64) -> Vec<Vec<usize>> {
    pack_rows(labels.iter().map(|l| below_entry_width(l)), width)
}

/// Items of the given widths, in order, into rows no wider than `width`
/// (an item wider than that gets a row of its own): the indices per row.
pub(super) fn pack_rows(widths: impl IntoIterator<Item = f64>, width: f64) -> Vec<Vec<usize>> {
    let mut rows: Vec<Vec<usize>> = Vec::new();
    let mut used = 0.0;
    for (i, w) in widths.into_iter().enumerate() {
        match rows.last_mut() {
            Some(r) if used + w <= width => {
                r.push(i);
                used += w;
            }
            _ => {
                rows.push(vec![i]);
                used = w;
            }
        }
    }
    rows
}

/// Height (reference pixels) of a legend of `rows` rows below the plot.
pub(super) fn below_height(rows: usize) -> f64 {
    8.0 + 10.0 + 30.0 * rows as f64 + 6.0 + 8.0
}

/// Height (reference pixels) of the header [`draw_header`] draws.
pub(super) fn header_height(title: &str, caption: Option<&str>) -> f64 {
    let mut h = 14.0 + 6.0;
    if !title.is_empty() {
        h += 40.0;
    }
    if caption.is_some_and(|c| !c.is_empty()) {
        h += 30.0;
    }
    h
}

/// The extra height (reference pixels) a chart of `size` (reference
/// pixels) with a header of `header` needs for its legend of `labels`
/// below the plot, when that legend fits in no corner of the plot and
/// beside it would take more than [`OUTSIDE_SHARE`] of the width or the
/// chart is narrow ([`goes_below`]); `None` when the legend goes inside or
/// beside the plot. The figure grows by it: the plot keeps its size.
pub(super) fn legend_below(labels: &[&str], size: (u32, u32), header: f64) -> Option<f64> {
    let tw = labels
        .iter()
        .map(|l| font::text_size(l, LEGEND_TEXT, false).0 as f64)
        .fold(0.0, f64::max);
    let (lw, lh) = (
        14.0 + 48.0 + 12.0 + 14.0 + tw,
        10.0 + 30.0 * labels.len() as f64 + 6.0,
    );
    let (w, h) = (size.0 as f64, size.1 as f64);
    // The plot, roughly: the y labels and margins take ~150 px, the x
    // labels and margins ~110 px.
    let (pw, ph) = (w - 150.0, h - header - 110.0);
    let cornerless = lw > 0.6 * pw || lh > 0.8 * ph;
    if cornerless && goes_below(lw, w) {
        Some(below_height(below_rows(labels, w - 20.0).len()))
    } else {
        None
    }
}

/// Draws a legend of `rows` (see [`below_rows`]) centred in `area`
/// (pixels: x0, y0, x1, y1), in a light box.
pub(super) fn draw_legend_below<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    rows: &[Vec<usize>],
    area: Rect,
    m: Metrics,
) -> DResult<()> {
    let widths: Vec<f64> = entries
        .iter()
        .map(|e| m.px(below_entry_width(e.label)))
        .collect();
    let row_w = |r: &[usize]| r.iter().map(|&i| widths[i]).sum::<f64>() - m.px(ROW_GAP);
    let box_w = rows.iter().map(|r| row_w(r)).fold(0.0, f64::max) + m.px(28.0);
    let cx = (area.0 + area.2) / 2.0;
    let y0 = area.1 + m.px(8.0);
    let r = [
        ((cx - box_w / 2.0) as i32, y0 as i32),
        (
            (cx + box_w / 2.0) as i32,
            (y0 + m.px(10.0 + 30.0 * rows.len() as f64 + 6.0)) as i32,
        ),
    ];
    root.draw(&Rectangle::new(r, WHITE.mix(0.92).filled()))
        .map_err(de)?;
    root.draw(&Rectangle::new(
        r,
        RGBColor(150, 150, 150).stroke_width(m.pu(1.0).max(1)),
    ))
    .map_err(de)?;
    for (ri, row) in rows.iter().enumerate() {
        let cy = y0 + m.px(10.0 + 15.0 + 30.0 * ri as f64);
        let mut x = cx - row_w(row) / 2.0;
        for &i in row {
            draw_entry(root, &entries[i], x, cy, m)?;
            x += widths[i];
        }
    }
    Ok(())
}

/// What a legend entry shows next to its label.
#[derive(Clone, Copy, Debug)]
pub(super) enum Swatch {
    Line { markers: bool },
    Bar,
}

pub(super) struct LegendEntry<'a> {
    pub(super) label: &'a str,
    pub(super) style: SeriesStyle,
    pub(super) swatch: Swatch,
}

/// Pixel rectangle `(x0, y0, x1, y1)`.
pub(super) type Rect = (f64, f64, f64, f64);

/// Sizes at one scale factor.
#[derive(Clone, Copy)]
pub(super) struct Metrics {
    pub(super) s: f64,
}

impl Metrics {
    pub(super) fn px(&self, v: f64) -> f64 {
        v * self.s
    }
    pub(super) fn pi(&self, v: f64) -> i32 {
        (v * self.s).round() as i32
    }
    pub(super) fn pu(&self, v: f64) -> u32 {
        (v * self.s).round().max(0.0) as u32
    }
    pub(super) fn title(&self) -> TextStyle<'static> {
        font::bold(self.px(30.0), BLACK)
    }
    pub(super) fn caption(&self) -> TextStyle<'static> {
        font::text(self.px(20.0), RGBColor(70, 70, 70))
    }
    pub(super) fn tick(&self) -> TextStyle<'static> {
        font::text(self.px(19.0), BLACK)
    }
    /// The axis label style for labels `texts[i]` at most `rooms[i]`
    /// pixels long: [`Self::desc`], or smaller (down to the tick size) when
    /// one would be longer (one size for both axes).
    pub(super) fn desc_fitting(&self, texts: &[(&str, f64)]) -> TextStyle<'static> {
        let full = self.px(22.0);
        let mut size = full;
        for &(text, room) in texts {
            let w = font::text_size(text, full, false).0 as f64;
            if w > room && w > 0.0 {
                size = size.min((full * room / w).max(self.px(LEGEND_TEXT)));
            }
        }
        font::text(size, BLACK)
    }
    pub(super) fn desc(&self) -> TextStyle<'static> {
        font::text(self.px(22.0), BLACK)
    }
    pub(super) fn legend(&self) -> TextStyle<'static> {
        font::text(self.px(19.0), BLACK)
    }
}

/// Draws the title and caption centred at the top; returns the height used.
pub(super) fn draw_header<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    caption: Option<&str>,
    m: Metrics,
) -> DResult<i32> {
    let (w, _) = root.dim_in_pixel();
    let cx = w as i32 / 2;
    let mut y = m.pi(14.0);
    if !title.is_empty() {
        root.draw_text(
            title,
            &m.title().pos(Pos::new(HPos::Center, VPos::Top)),
            (cx, y),
        )
        .map_err(de)?;
        y += m.pi(40.0);
    }
    if let Some(c) = caption.filter(|c| !c.is_empty()) {
        root.draw_text(
            c,
            &m.caption().pos(Pos::new(HPos::Center, VPos::Top)),
            (cx, y),
        )
        .map_err(de)?;
        y += m.pi(30.0);
    }
    Ok(y + m.pi(6.0))
}

pub(super) fn legend_size<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    m: Metrics,
) -> DResult<(f64, f64)> {
    let mut tw = 0u32;
    for e in entries {
        let (w, _) = root.estimate_text_size(e.label, &m.legend()).map_err(de)?;
        tw = tw.max(w);
    }
    let w = m.px(14.0 + 48.0 + 12.0 + 14.0) + tw as f64;
    let h = m.px(10.0 + 30.0 * entries.len() as f64 + 6.0);
    Ok((w, h))
}

/// Draws the legend where asked, or in the first plot corner free of
/// `obstacles`; returns where it went (`None`: nowhere free).
#[allow(clippy::too_many_arguments)]
pub(super) fn place_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    legend: Option<LegendPos>,
    plot: Rect,
    lsize: (f64, f64),
    obstacles: &[Rect],
    legend_x: Option<f64>,
    m: Metrics,
) -> DResult<Option<LegendPos>> {
    let chosen = match legend {
        Some(l) => Some(l),
        None => free_corner(plot, lsize, obstacles, m).map(LegendPos::Inside),
    };
    match chosen {
        Some(LegendPos::Inside(corner)) => {
            draw_legend(root, entries, corner_rect(plot, lsize, corner, m), m)?;
        }
        // Drawn by the chart (`draw_legend_below`).
        Some(LegendPos::Below) => {}
        Some(LegendPos::Outside) => {
            let x0 = legend_x.unwrap_or(plot.2 + m.px(8.0));
            draw_legend(
                root,
                entries,
                (x0, plot.1, x0 + lsize.0, plot.1 + lsize.1),
                m,
            )?;
        }
        None => {}
    }
    Ok(chosen)
}

fn draw_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    (x0, y0, x1, y1): Rect,
    m: Metrics,
) -> DResult<()> {
    let r = [(x0 as i32, y0 as i32), (x1 as i32, y1 as i32)];
    root.draw(&Rectangle::new(r, WHITE.mix(0.92).filled()))
        .map_err(de)?;
    root.draw(&Rectangle::new(
        r,
        RGBColor(150, 150, 150).stroke_width(m.pu(1.0).max(1)),
    ))
    .map_err(de)?;
    for (i, e) in entries.iter().enumerate() {
        let cy = y0 + m.px(10.0 + 15.0 + 30.0 * i as f64);
        draw_entry(root, e, x0 + m.px(14.0), cy, m)?;
    }
    Ok(())
}

/// One legend entry: its swatch from `sx0` and its label, centred on `cy`.
fn draw_entry<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    e: &LegendEntry,
    sx0: f64,
    cy: f64,
    m: Metrics,
) -> DResult<()> {
    let sx1 = sx0 + m.px(48.0);
    let color = rgb(e.style.color);
    match e.swatch {
        Swatch::Line { markers } => {
            let pts = vec![(sx0 as i32, cy as i32), (sx1 as i32, cy as i32)];
            draw_polyline_px(root, &pts, e.style, m)?;
            if markers {
                draw_marker(root, ((sx0 + sx1) / 2.0, cy), e.style, m)?;
            }
        }
        Swatch::Bar => {
            let b = [
                ((sx0 + m.px(8.0)) as i32, (cy - m.px(9.0)) as i32),
                ((sx1 - m.px(8.0)) as i32, (cy + m.px(9.0)) as i32),
            ];
            root.draw(&Rectangle::new(b, color.filled())).map_err(de)?;
            root.draw(&Rectangle::new(b, BLACK.stroke_width(m.pu(1.0).max(1))))
                .map_err(de)?;
        }
    }
    root.draw_text(
        e.label,
        &m.legend().pos(Pos::new(HPos::Left, VPos::Center)),
        ((sx1 + m.px(12.0)) as i32, cy as i32),
    )
    .map_err(de)?;
    Ok(())
}

/// A polyline in pixel coordinates, solid or dashed per `style`.
pub(super) fn draw_polyline_px<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    pts: &[(i32, i32)],
    style: SeriesStyle,
    m: Metrics,
) -> DResult<()> {
    let shape = rgb(style.color).stroke_width(m.pu(3.0).max(1));
    match style.dash {
        None => root
            .draw(&PathElement::new(pts.to_vec(), shape))
            .map_err(de),
        Some((dash, gap)) => root
            .draw(&DashedPathElement::new(
                pts.iter().copied(),
                m.pu(dash).max(1),
                m.pu(gap).max(1),
                shape,
            ))
            .map_err(de),
    }
}

/// A marker centred at pixel `c`.
pub(super) fn draw_marker<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    c: (f64, f64),
    style: SeriesStyle,
    m: Metrics,
) -> DResult<()> {
    let color = rgb(style.color);
    let r = m.px(6.0);
    let (x, y) = c;
    let p = |dx: f64, dy: f64| ((x + dx).round() as i32, (y + dy).round() as i32);
    let fill = color.filled();
    let edge = WHITE.stroke_width(m.pu(1.0).max(1));
    match style.marker {
        Marker::Circle => {
            root.draw(&Circle::new(p(0.0, 0.0), r.round() as i32, fill))
                .map_err(de)?;
            root.draw(&Circle::new(p(0.0, 0.0), r.round() as i32, edge))
                .map_err(de)
        }
        Marker::Square => {
            let q = r * 0.85;
            root.draw(&Rectangle::new([p(-q, -q), p(q, q)], fill))
                .map_err(de)?;
            root.draw(&Rectangle::new([p(-q, -q), p(q, q)], edge))
                .map_err(de)
        }
        Marker::TriangleUp | Marker::TriangleDown | Marker::Diamond => {
            let k = r * 1.15;
            let pts = match style.marker {
                Marker::TriangleUp => vec![p(0.0, -k), p(k, 0.7 * k), p(-k, 0.7 * k)],
                Marker::TriangleDown => vec![p(0.0, k), p(k, -0.7 * k), p(-k, -0.7 * k)],
                _ => vec![p(0.0, -k), p(k, 0.0), p(0.0, k), p(-k, 0.0)],
            };
            root.draw(&Polygon::new(pts.clone(), fill)).map_err(de)?;
            let mut closed = pts;
            closed.push(closed[0]);
            root.draw(&PathElement::new(closed, edge)).map_err(de)
        }
        Marker::Cross => {
            let k = r;
            let st = color.stroke_width(m.pu(3.0).max(1));
            root.draw(&PathElement::new(vec![p(-k, -k), p(k, k)], st))
                .map_err(de)?;
            root.draw(&PathElement::new(vec![p(-k, k), p(k, -k)], st))
                .map_err(de)
        }
    }
}

/// Linear map of an axis onto a pixel interval `[p0, p1]`.
pub(super) fn to_px(axis: &Axis, v: f64, p0: f64, p1: f64) -> f64 {
    p0 + axis.fraction(v) * (p1 - p0)
}

/// The legend rectangle at `corner` of the plot rectangle.
fn corner_rect(plot: Rect, size: (f64, f64), corner: Corner, m: Metrics) -> Rect {
    let inset = m.px(12.0);
    let (w, h) = size;
    let (x0, x1) = match corner {
        Corner::TopLeft | Corner::BottomLeft => (plot.0 + inset, plot.0 + inset + w),
        _ => (plot.2 - inset - w, plot.2 - inset),
    };
    let (y0, y1) = match corner {
        Corner::TopLeft | Corner::TopRight => (plot.1 + inset, plot.1 + inset + h),
        _ => (plot.3 - inset - h, plot.3 - inset),
    };
    (x0, y0, x1, y1)
}

fn rects_overlap(a: Rect, b: Rect) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// The first legend corner whose (padded) rectangle meets no obstacle.
fn free_corner(plot: Rect, size: (f64, f64), obstacles: &[Rect], m: Metrics) -> Option<Corner> {
    if size.0 > (plot.2 - plot.0) * 0.6 || size.1 > (plot.3 - plot.1) * 0.8 {
        return None;
    }
    let pad = m.px(6.0);
    CORNERS.iter().copied().find(|&c| {
        let r = corner_rect(plot, size, c, m);
        let r = (r.0 - pad, r.1 - pad, r.2 + pad, r.3 + pad);
        !obstacles.iter().any(|&o| rects_overlap(r, o))
    })
}

/// Greedy word wrap of `text` into lines at most `width` pixels wide at
/// `size` (a single word wider than that stays on its own line).
pub(crate) fn wrap(text: &str, size: f64, width: f64) -> Vec<String> {
    // Pieces and the separator before each: words split at spaces, and
    // words too wide for a line also after their hyphens and underscores
    // ("auto-handle-relative" → "auto-", "handle-", "relative").
    let mut pieces: Vec<(&str, &str)> = Vec::new();
    for word in text.split_whitespace() {
        let mut sep = " ";
        if font::text_size(word, size, false).0 as f64 <= width {
            pieces.push((sep, word));
            continue;
        }
        let mut start = 0;
        for (i, ch) in word.char_indices() {
            if ch == '-' || ch == '_' {
                let end = i + ch.len_utf8();
                pieces.push((sep, &word[start..end]));
                sep = "";
                start = end;
            }
        }
        if start < word.len() {
            pieces.push((sep, &word[start..]));
        }
    }
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    for (sep, piece) in pieces {
        let trial = if cur.is_empty() {
            piece.to_string()
        } else {
            format!("{cur}{sep}{piece}")
        };
        if cur.is_empty() || font::text_size(&trial, size, false).0 as f64 <= width {
            cur = trial;
        } else {
            lines.push(std::mem::replace(&mut cur, piece.to_string()));
        }
    }
    if !cur.is_empty() || lines.is_empty() {
        lines.push(cur);
    }
    lines
}

/// Width (reference pixels) of one more line of a wrapped y axis label.
const Y_LINE: f64 = 27.0;

/// The y axis label as lines: one (drawn by the mesh, shrunk to fit by
/// [`Metrics::desc_fitting`]) when at the tick size it fits along the
/// `room` pixels of the axis, else word wrapped into up to three lines
/// ([`draw_y_lines`]).
pub(super) fn y_desc_lines(text: &str, room: f64, m: Metrics) -> Vec<String> {
    if font::text_size(text, m.px(LEGEND_TEXT), false).0 as f64 <= room {
        return vec![text.to_string()];
    }
    let mut lines = wrap(text, 22.0, room / m.s);
    if lines.len() > 3 {
        let rest = lines.split_off(2).join(" ");
        lines.push(rest);
    }
    lines
}

/// Extra width (pixels) of the y label area for `lines` of y label.
pub(super) fn y_lines_extra(lines: &[String], m: Metrics) -> u32 {
    m.pu(Y_LINE * lines.len().saturating_sub(1) as f64)
}

/// Draws a wrapped y axis label (more than one line) turned a quarter,
/// centred on the plot's height, its first line leftmost at `x0`.
pub(super) fn draw_y_lines<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lines: &[String],
    x0: f64,
    plot: Rect,
    m: Metrics,
) -> DResult<()> {
    let style = m
        .desc()
        .transform(FontTransform::Rotate270)
        .pos(Pos::new(HPos::Center, VPos::Center));
    let cy = (plot.1 + plot.3) / 2.0;
    for (k, line) in lines.iter().enumerate() {
        let x = x0 + m.px(4.0 + 13.0 + Y_LINE * k as f64);
        root.draw_text(line, &style, (x.round() as i32, cy.round() as i32))
            .map_err(de)?;
    }
    Ok(())
}

/// Log range covering `[lo, hi]` (both > 0), widened to whole decades.
pub(super) fn log_range(lo: f64, hi: f64) -> (f64, f64) {
    let a = 10f64.powf((lo.log10() + 1e-9).floor());
    let mut b = 10f64.powf((hi.log10() - 1e-9).ceil());
    if b <= a {
        b = a * 10.0;
    }
    (a, b)
}

pub(super) fn tick_formatter(axis: Axis, max_ticks: usize) -> impl Fn(&f64) -> String {
    let (_, step) = axis.major_ticks(max_ticks);
    let sci = log_axis_is_scientific(axis.lo, axis.hi);
    move |v: &f64| match axis.scale {
        Scale::Log => format_log_tick(*v, sci),
        _ => format_tick(*v, step),
    }
}

pub(super) const X_TICKS: usize = 10;

/// Most x ticks on a plot `width` pixels wide: [`X_TICKS`], fewer on a
/// narrow plot (one per 70 reference pixels, at least 4), so that tick
/// labels do not touch.
pub(super) fn x_ticks(width: f64, m: Metrics) -> usize {
    ((width / m.s / 70.0).floor() as usize).clamp(4, X_TICKS)
}
pub(super) const Y_TICKS: usize = 8;

/// Width needed left of the plot for the y tick labels and the y label.
pub(super) fn y_label_area<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    y: &Axis,
    m: Metrics,
) -> DResult<u32> {
    let fmt = tick_formatter(*y, Y_TICKS);
    let mut w = 0u32;
    for t in y.major_ticks(Y_TICKS).0 {
        let (tw, _) = root.estimate_text_size(&fmt(&t), &m.tick()).map_err(de)?;
        w = w.max(tw);
    }
    Ok(w + m.pu(6.0 + 10.0 + 22.0 + 22.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    const M: Metrics = Metrics { s: 1.0 };

    #[test]
    fn long_names_wrap_at_spaces_then_hyphens() {
        let w = font::text_size("handle-", 22.0, false).0 as f64 + 4.0;
        let lines = wrap("auto-handle-relative", 22.0, w);
        assert_eq!(lines.join(""), "auto-handle-relative");
        assert!(lines.len() >= 2, "{lines:?}");
        for l in &lines {
            assert!(font::text_size(l, 22.0, false).0 as f64 <= w, "{l} in {w}");
        }
        assert_eq!(wrap("mean error", 22.0, 1000.0), vec!["mean error"]);
        assert_eq!(wrap("a b", 22.0, 1.0), vec!["a", "b"]);
    }
    const PLOT: Rect = (100.0, 100.0, 1100.0, 700.0);
    const SIZE: (f64, f64) = (200.0, 100.0);

    #[test]
    fn legend_avoids_data() {
        assert_eq!(free_corner(PLOT, SIZE, &[], M), Some(Corner::TopRight));
        // Data in the top right corner: the legend moves to the bottom right.
        let tr = (1000.0, 120.0, 1010.0, 130.0);
        assert_eq!(free_corner(PLOT, SIZE, &[tr], M), Some(Corner::BottomRight));
        let br = (1000.0, 650.0, 1010.0, 660.0);
        let tl = (150.0, 150.0, 160.0, 160.0);
        assert_eq!(free_corner(PLOT, SIZE, &[tr, br], M), Some(Corner::TopLeft));
        let bl = (150.0, 650.0, 160.0, 660.0);
        assert_eq!(
            free_corner(PLOT, SIZE, &[tr, br, tl], M),
            Some(Corner::BottomLeft)
        );
        assert_eq!(free_corner(PLOT, SIZE, &[tr, br, tl, bl], M), None);
        // The chosen rectangle really is clear of the obstacles.
        let r = corner_rect(PLOT, SIZE, Corner::BottomRight, M);
        assert!(!rects_overlap(r, tr));
        // A legend too large for the plot goes outside.
        assert_eq!(free_corner(PLOT, (900.0, 100.0), &[], M), None);
    }
}

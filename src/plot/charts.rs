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

use std::path::Path;

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axis::{format_log_tick, format_tick, log_axis_is_scientific, Axis, Scale};
use super::font::{self, ensure_font, GlyphBackend};
use super::output::{with_suffix, write_bytes_atomic, write_png_atomic, Formats, Image};
use super::pdf::svg_to_pdf;
use super::style::{series_style, Marker, SeriesStyle, FLOOR_STYLE, MAX_PLAIN_SERIES};
use super::{BarChart, LineChart};
use crate::{Error, Result};

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

/// Which corner of the plot area holds the legend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Corner {
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
enum LegendPos {
    Inside(Corner),
    Outside,
}

/// What a legend entry shows next to its label.
#[derive(Clone, Copy, Debug)]
enum Swatch {
    Line { markers: bool },
    Bar,
}

struct LegendEntry<'a> {
    label: &'a str,
    style: SeriesStyle,
    swatch: Swatch,
}

/// Pixel rectangle `(x0, y0, x1, y1)`.
type Rect = (f64, f64, f64, f64);

/// Sizes at one scale factor.
#[derive(Clone, Copy)]
struct Metrics {
    s: f64,
}

impl Metrics {
    fn px(&self, v: f64) -> f64 {
        v * self.s
    }
    fn pi(&self, v: f64) -> i32 {
        (v * self.s).round() as i32
    }
    fn pu(&self, v: f64) -> u32 {
        (v * self.s).round().max(0.0) as u32
    }
    fn title(&self) -> TextStyle<'static> {
        font::bold(self.px(30.0), BLACK)
    }
    fn caption(&self) -> TextStyle<'static> {
        font::text(self.px(20.0), RGBColor(70, 70, 70))
    }
    fn tick(&self) -> TextStyle<'static> {
        font::text(self.px(19.0), BLACK)
    }
    fn desc(&self) -> TextStyle<'static> {
        font::text(self.px(22.0), BLACK)
    }
    fn legend(&self) -> TextStyle<'static> {
        font::text(self.px(19.0), BLACK)
    }
}

/// Draws the title and caption centred at the top; returns the height used.
fn draw_header<DB: DrawingBackend>(
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

fn legend_size<DB: DrawingBackend>(
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
fn place_legend<DB: DrawingBackend>(
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
        let sx0 = x0 + m.px(14.0);
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
    }
    Ok(())
}

/// A polyline in pixel coordinates, solid or dashed per `style`.
fn draw_polyline_px<DB: DrawingBackend>(
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
fn draw_marker<DB: DrawingBackend>(
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
fn to_px(axis: &Axis, v: f64, p0: f64, p1: f64) -> f64 {
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

// ---------------------------------------------------------------- line chart

/// A validated line chart: axes and per-series point lists.
pub(crate) struct PreparedLine {
    x: Axis,
    y: Axis,
}

fn finite_range(name: &str, r: (f64, f64), log: bool, what: &str) -> Result<()> {
    if !(r.0.is_finite() && r.1.is_finite() && r.0 < r.1) {
        return Err(Error::invalid(format!(
            "{name}: {what} range ({}, {}) must be finite with lo < hi",
            r.0, r.1
        )));
    }
    if log && r.0 <= 0.0 {
        return Err(Error::invalid(format!(
            "{name}: {what} range ({}, {}) must be positive on a log axis",
            r.0, r.1
        )));
    }
    Ok(())
}

/// Data range padded for display: `pad` of the span on each side; a zero
/// span is widened.
fn padded(lo: f64, hi: f64, pad: f64) -> (f64, f64) {
    if hi > lo {
        let p = (hi - lo) * pad;
        (lo - p, hi + p)
    } else {
        let p = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        (lo - p, hi + p)
    }
}

/// Log range covering `[lo, hi]` (both > 0), widened to whole decades.
fn log_range(lo: f64, hi: f64) -> (f64, f64) {
    let a = 10f64.powf((lo.log10() + 1e-9).floor());
    let mut b = 10f64.powf((hi.log10() - 1e-9).ceil());
    if b <= a {
        b = a * 10.0;
    }
    (a, b)
}

pub(crate) fn prepare_line(c: &LineChart, name: &str) -> Result<PreparedLine> {
    if c.series.is_empty() {
        return Err(Error::invalid(format!(
            "{name}: line chart \"{}\" has no series",
            c.title
        )));
    }
    let (mut xlo, mut xhi, mut ylo, mut yhi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for s in &c.series {
        if s.x.len() != s.y.len() {
            return Err(Error::invalid(format!(
                "{name}: series \"{}\" has {} x values but {} y values",
                s.label,
                s.x.len(),
                s.y.len()
            )));
        }
        if s.x.is_empty() {
            return Err(Error::invalid(format!(
                "{name}: series \"{}\" has no points",
                s.label
            )));
        }
        for (i, (&x, &y)) in s.x.iter().zip(&s.y).enumerate() {
            if !x.is_finite() || !y.is_finite() {
                return Err(Error::invalid(format!(
                    "{name}: series \"{}\" point {i} is not finite (x = {x}, y = {y})",
                    s.label
                )));
            }
            if c.log_y && y <= 0.0 {
                return Err(Error::invalid(format!(
                    "{name}: series \"{}\" point {i} has y = {y}, not positive on a log y axis",
                    s.label
                )));
            }
            xlo = xlo.min(x);
            xhi = xhi.max(x);
            ylo = ylo.min(y);
            yhi = yhi.max(y);
        }
    }
    let x = match c.x_range {
        Some(r) => {
            finite_range(name, r, false, "x")?;
            Axis::linear(r.0, r.1)
        }
        None => {
            let (a, b) = padded(xlo, xhi, if c.markers { 0.03 } else { 0.0 });
            let counts = c
                .series
                .iter()
                .flat_map(|s| s.x.iter())
                .all(|x| x.fract() == 0.0);
            if counts && xhi - xlo >= 1.0 {
                Axis::integer(a, b)
            } else {
                Axis::linear(a, b)
            }
        }
    };
    let y = match c.y_range {
        Some(r) => {
            finite_range(name, r, c.log_y, "y")?;
            if c.log_y {
                Axis::log(r.0, r.1)
            } else {
                Axis::linear(r.0, r.1)
            }
        }
        None if c.log_y => {
            let (a, b) = log_range(ylo, yhi);
            Axis::log(a, b)
        }
        None => {
            let (a, b) = padded(ylo, yhi, 0.04);
            let counts = c
                .series
                .iter()
                .flat_map(|s| s.y.iter())
                .all(|y| y.fract() == 0.0);
            if counts && yhi - ylo >= 1.0 {
                // Counts: start at zero so that ratios read off the axis.
                let a = if ylo >= 0.0 { 0.0 } else { a };
                Axis::integer(a, b)
            } else {
                Axis::linear(a, b)
            }
        }
    };
    Ok(PreparedLine { x, y })
}

/// Clips the polyline `pts` (data coordinates) to the axes' box, in axis
/// space (so log axes clip correctly); returns the visible pieces.
fn clip_polyline(pts: &[(f64, f64)], x: &Axis, y: &Axis) -> Vec<Vec<(f64, f64)>> {
    let (ax0, ax1) = (x.forward(x.lo), x.forward(x.hi));
    let (ay0, ay1) = (y.forward(y.lo), y.forward(y.hi));
    let f: Vec<(f64, f64)> = pts
        .iter()
        .map(|&(a, b)| (x.forward(a), y.forward(b)))
        .collect();
    let back = |(u, v): (f64, f64)| (x.backward(u), y.backward(v));
    let inside = |(u, v): (f64, f64)| {
        let eu = (ax1 - ax0) * 1e-9;
        let ev = (ay1 - ay0) * 1e-9;
        u >= ax0 - eu && u <= ax1 + eu && v >= ay0 - ev && v <= ay1 + ev
    };
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    if f.len() == 1 {
        if inside(f[0]) {
            out.push(vec![pts[0]]);
        }
        return out;
    }
    for w in f.windows(2) {
        let (p, q) = (w[0], w[1]);
        // Liang–Barsky.
        let (dx, dy) = (q.0 - p.0, q.1 - p.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let mut visible = true;
        for (pk, qk) in [
            (-dx, p.0 - ax0),
            (dx, ax1 - p.0),
            (-dy, p.1 - ay0),
            (dy, ay1 - p.1),
        ] {
            if pk == 0.0 {
                if qk < 0.0 {
                    visible = false;
                    break;
                }
            } else {
                let r = qk / pk;
                if pk < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        if !visible || t0 > t1 {
            if cur.len() > 1 {
                out.push(std::mem::take(&mut cur));
            }
            cur.clear();
            continue;
        }
        let a = (p.0 + t0 * dx, p.1 + t0 * dy);
        let b = (p.0 + t1 * dx, p.1 + t1 * dy);
        if cur.is_empty() || t0 > 0.0 {
            if cur.len() > 1 {
                out.push(std::mem::take(&mut cur));
            }
            cur.clear();
            cur.push(back(a));
        }
        cur.push(back(b));
        if t1 < 1.0 {
            out.push(std::mem::take(&mut cur));
        }
    }
    if cur.len() > 1 {
        out.push(cur);
    }
    out
}

fn tick_formatter(axis: Axis, max_ticks: usize) -> impl Fn(&f64) -> String {
    let (_, step) = axis.major_ticks(max_ticks);
    let sci = log_axis_is_scientific(axis.lo, axis.hi);
    move |v: &f64| match axis.scale {
        Scale::Log => format_log_tick(*v, sci),
        _ => format_tick(*v, step),
    }
}

const X_TICKS: usize = 10;
const Y_TICKS: usize = 8;

/// Width needed left of the plot for the y tick labels and the y label.
fn y_label_area<DB: DrawingBackend>(
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

fn draw_line_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    c: &LineChart,
    p: &PreparedLine,
    legend: Option<LegendPos>,
    m: Metrics,
) -> DResult<Option<LegendPos>> {
    root.fill(&WHITE).map_err(de)?;
    let header = draw_header(root, &c.title, c.caption.as_deref(), m)?;
    let (_, body) = root.split_vertically(header);
    let floor = c.floor.filter(|&k| k < c.series.len());
    let n = c.series.len() - usize::from(floor.is_some());
    let force_markers = n > MAX_PLAIN_SERIES;
    // The floor series is styled apart; the others as if it were absent.
    let style_of = |i: usize| match floor {
        Some(k) if k == i => FLOOR_STYLE,
        Some(k) if i > k => series_style(i - 1, n),
        _ => series_style(i, n),
    };
    let entries: Vec<LegendEntry> = c
        .series
        .iter()
        .enumerate()
        .map(|(i, s)| LegendEntry {
            label: &s.label,
            style: style_of(i),
            swatch: Swatch::Line {
                markers: Some(i) != floor && (c.markers || force_markers),
            },
        })
        .collect();
    let lsize = legend_size(root, &entries, m)?;
    let (plot_area, legend_x) = if legend == Some(LegendPos::Outside) {
        let (bw, _) = body.dim_in_pixel();
        let lw = (lsize.0 + m.px(24.0)) as u32;
        let (a, _) = body.split_horizontally(bw.saturating_sub(lw));
        (a, Some(bw.saturating_sub(lw) as f64 + m.px(8.0)))
    } else {
        (body.clone(), None)
    };
    let (plot, obstacles) = draw_line_body(
        root,
        &plot_area,
        c,
        p,
        &style_of,
        c.markers || force_markers,
        floor,
        m,
    )?;
    place_legend(root, &entries, legend, plot, lsize, &obstacles, legend_x, m)
}

/// Axes, grid and series of the line chart `c` in `area` (drawn through
/// `root`, in its pixel coordinates): series `i` in `style_of(i)`, the
/// `floor` series first and without markers, markers on the others when
/// `markers` (and on single points). Returns the plot rectangle and the
/// rectangles the data covers (obstacles for the legend).
#[allow(clippy::too_many_arguments)]
fn draw_line_body<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    area: &DrawingArea<DB, Shift>,
    c: &LineChart,
    p: &PreparedLine,
    style_of: &dyn Fn(usize) -> SeriesStyle,
    markers: bool,
    floor: Option<usize>,
    m: Metrics,
) -> DResult<(Rect, Vec<Rect>)> {
    let yarea = y_label_area(root, &p.y, m)?;
    let mut chart = ChartBuilder::on(area)
        .margin_top(m.pu(8.0))
        .margin_right(m.pu(36.0))
        .margin_bottom(m.pu(12.0))
        .margin_left(m.pu(10.0))
        .x_label_area_size(m.pu(78.0))
        .y_label_area_size(yarea)
        .build_cartesian_2d(p.x, p.y)
        .map_err(de)?;
    let fx = tick_formatter(p.x, X_TICKS);
    let fy = tick_formatter(p.y, Y_TICKS);
    chart
        .configure_mesh()
        .x_desc(c.x_label.as_str())
        .y_desc(c.y_label.as_str())
        .x_labels(X_TICKS)
        .y_labels(Y_TICKS)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .label_style(m.tick())
        .axis_desc_style(m.desc())
        .bold_line_style(BLACK.mix(0.16).stroke_width(m.pu(1.0).max(1)))
        .light_line_style(BLACK.mix(0.06).stroke_width(m.pu(1.0).max(1)))
        .axis_style(BLACK.stroke_width(m.pu(1.5).max(1)))
        .set_all_tick_mark_size(m.pu(6.0))
        .x_label_offset(0)
        .draw()
        .map_err(de)?;

    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let plot: Rect = (
        xr.start as f64,
        yr.start as f64,
        xr.end as f64,
        yr.end as f64,
    );
    let map = |(a, b): (f64, f64)| {
        (
            to_px(&p.x, a, plot.0, plot.2 - 1.0),
            to_px(&p.y, b, plot.3 - 1.0, plot.1),
        )
    };
    let mut obstacles: Vec<Rect> = Vec::new();
    let mr = m.px(7.0);
    // The floor first: beneath the other series.
    let order: Vec<usize> = floor
        .into_iter()
        .chain((0..c.series.len()).filter(|&i| Some(i) != floor))
        .collect();
    for i in order {
        let s = &c.series[i];
        let style = style_of(i);
        let pts: Vec<(f64, f64)> = s.x.iter().copied().zip(s.y.iter().copied()).collect();
        for piece in clip_polyline(&pts, &p.x, &p.y) {
            let px: Vec<(f64, f64)> = piece.iter().map(|&q| map(q)).collect();
            let pi: Vec<(i32, i32)> = px
                .iter()
                .map(|&(a, b)| (a.round() as i32, b.round() as i32))
                .collect();
            if pi.len() > 1 {
                draw_polyline_px(root, &pi, style, m)?;
            }
            // Obstacles: the line sampled every few pixels.
            let lw = m.px(2.5);
            for w in px.windows(2) {
                let (a, b) = (w[0], w[1]);
                let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
                let k = (len / m.px(3.0)).ceil().max(1.0) as usize;
                for j in 0..=k {
                    let t = j as f64 / k as f64;
                    let q = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                    obstacles.push((q.0 - lw, q.1 - lw, q.0 + lw, q.1 + lw));
                }
            }
            if px.len() == 1 {
                let q = px[0];
                obstacles.push((q.0 - mr, q.1 - mr, q.0 + mr, q.1 + mr));
            }
        }
        if Some(i) != floor && (markers || s.x.len() == 1) {
            for q in &pts {
                let fx = p.x.fraction(q.0);
                let fy = p.y.fraction(q.1);
                if (-1e-9..=1.0 + 1e-9).contains(&fx) && (-1e-9..=1.0 + 1e-9).contains(&fy) {
                    let c = map(*q);
                    draw_marker(root, c, style, m)?;
                    obstacles.push((c.0 - mr, c.1 - mr, c.0 + mr, c.1 + mr));
                }
            }
        }
    }
    Ok((plot, obstacles))
}

/// One chart drawing routine on both backends.
trait ChartDraw {
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
fn bitmap<C: ChartDraw>(
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
fn render_chart<C: ChartDraw>(
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

/// The PNG rendering of a line chart ([`CHART_SIZE`]) without writing it.
pub fn line_chart_image(chart: &LineChart) -> Result<Image> {
    let prepared = prepare_line(chart, "line chart")?;
    Ok(bitmap(&LineJob { chart, prepared }, CHART_SIZE, "line chart")?.0)
}

/// The PNG rendering of a bar chart ([`CHART_SIZE`]) without writing it.
pub fn bar_chart_image(chart: &BarChart) -> Result<Image> {
    let prepared = prepare_bar(chart, "bar chart")?;
    Ok(bitmap(&BarJob { chart, prepared }, CHART_SIZE, "bar chart")?.0)
}

struct LineJob<'a> {
    chart: &'a LineChart,
    prepared: PreparedLine,
}

impl ChartDraw for LineJob<'_> {
    fn draw_bitmap(
        &self,
        root: &DrawingArea<GlyphBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_line_chart(root, self.chart, &self.prepared, legend, m)
    }
    fn draw_svg(
        &self,
        root: &DrawingArea<SVGBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_line_chart(root, self.chart, &self.prepared, legend, m)
    }
}

/// See [`super::save_line_chart_as`].
pub fn save_line_chart(chart: &LineChart, stem: &Path, formats: Formats) -> Result<()> {
    let prepared = prepare_line(chart, &formats.describe(stem))?;
    render_chart(&LineJob { chart, prepared }, stem, CHART_SIZE, formats)
}

// --------------------------------------------------------------- line panels

/// Size of one panel of [`super::LinePanels`] at the reference scale.
const PANEL_SIZE: (f64, f64) = (760.0, 640.0);
/// Height of a panel title line.
const PANEL_TITLE: f64 = 40.0;
/// Height of one row of the shared legend.
const LEGEND_ROW: f64 = 32.0;
/// Width of a legend entry besides its text: swatch, gaps.
const LEGEND_ENTRY: f64 = 48.0 + 12.0 + 30.0;

/// The series of all panels, each label once (first appearance), with its
/// style: the same label is drawn alike in every panel; a label that is
/// the floor of some panel is the floor everywhere.
struct SharedStyles {
    labels: Vec<String>,
    styles: Vec<SeriesStyle>,
    floor: Vec<bool>,
    markers: bool,
}

fn shared_styles(f: &super::LinePanels) -> SharedStyles {
    let mut labels: Vec<String> = Vec::new();
    let mut floor: Vec<bool> = Vec::new();
    for c in &f.panels {
        for (i, s) in c.series.iter().enumerate() {
            let is_floor = c.floor == Some(i);
            match labels.iter().position(|l| *l == s.label) {
                Some(k) => floor[k] |= is_floor,
                None => {
                    labels.push(s.label.clone());
                    floor.push(is_floor);
                }
            }
        }
    }
    let n = floor.iter().filter(|x| !**x).count();
    let mut k = 0;
    let styles = floor
        .iter()
        .map(|&fl| {
            if fl {
                FLOOR_STYLE
            } else {
                k += 1;
                series_style(k - 1, n)
            }
        })
        .collect();
    SharedStyles {
        labels,
        styles,
        floor,
        markers: n > MAX_PLAIN_SERIES || f.panels.iter().any(|c| c.markers),
    }
}

/// The shared legend's rows (entry indices) within `width` reference pixels.
fn legend_rows(labels: &[String], width: f64) -> Vec<Vec<usize>> {
    let mut rows: Vec<Vec<usize>> = Vec::new();
    let mut used = 0.0;
    for (i, l) in labels.iter().enumerate() {
        let w = LEGEND_ENTRY + font::text_size(l, 19.0, false).0 as f64;
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

struct PanelsJob<'a> {
    fig: &'a super::LinePanels,
    prepared: Vec<PreparedLine>,
    shared: SharedStyles,
    rows: Vec<Vec<usize>>,
}

fn draw_line_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    job: &PanelsJob,
    m: Metrics,
) -> DResult<Option<LegendPos>> {
    let f = job.fig;
    root.fill(&WHITE).map_err(de)?;
    let header = draw_header(root, &f.title, f.caption.as_deref(), m)?;
    let (_, body) = root.split_vertically(header);
    let (_, bh) = body.dim_in_pixel();
    let legend_h = m.px(LEGEND_ROW * job.rows.len() as f64 + 16.0);
    let (panels_area, legend_area) = body.split_vertically(bh.saturating_sub(legend_h as u32));
    let (pw, _) = panels_area.dim_in_pixel();
    let n = f.panels.len() as u32;
    let cell = pw / n.max(1);
    let style_of_label = |label: &str| {
        job.shared
            .labels
            .iter()
            .position(|l| l == label)
            .map_or(FLOOR_STYLE, |k| job.shared.styles[k])
    };
    for (k, (c, p)) in f.panels.iter().zip(&job.prepared).enumerate() {
        let x0 = cell * k as u32;
        let (_, right) = panels_area.split_horizontally(x0);
        let (area, _) = right.split_horizontally(cell);
        let (aw, _) = area.dim_in_pixel();
        area.draw_text(
            &c.title,
            &font::bold(m.px(24.0), BLACK).pos(Pos::new(HPos::Center, VPos::Top)),
            (aw as i32 / 2, m.pi(6.0)),
        )
        .map_err(de)?;
        let (_, chart_area) = area.split_vertically(m.pu(PANEL_TITLE));
        let floor = c.series.iter().position(|s| {
            job.shared
                .labels
                .iter()
                .position(|l| *l == s.label)
                .is_some_and(|i| job.shared.floor[i])
        });
        let style_of = |i: usize| style_of_label(&c.series[i].label);
        draw_line_body(
            root,
            &chart_area,
            c,
            p,
            &style_of,
            job.shared.markers,
            floor,
            m,
        )?;
    }
    // The shared legend: centred rows below the panels, in a light box.
    let entries: Vec<LegendEntry> = job
        .shared
        .labels
        .iter()
        .enumerate()
        .map(|(i, l)| LegendEntry {
            label: l,
            style: job.shared.styles[i],
            swatch: Swatch::Line {
                markers: !job.shared.floor[i] && job.shared.markers,
            },
        })
        .collect();
    let (lw, _) = legend_area.dim_in_pixel();
    let (lx, ly) = (
        legend_area.get_pixel_range().0.start as f64,
        legend_area.get_pixel_range().1.start as f64,
    );
    let widths: Vec<f64> = entries
        .iter()
        .map(|e| {
            let (tw, _) = font::text_size(e.label, m.px(19.0), false);
            m.px(LEGEND_ENTRY) + tw as f64
        })
        .collect();
    let row_w = |r: &[usize]| r.iter().map(|&i| widths[i]).sum::<f64>();
    let box_w = job.rows.iter().map(|r| row_w(r)).fold(0.0, f64::max) + m.px(10.0);
    let bx0 = lx + (lw as f64 - box_w) / 2.0;
    let r = [
        (bx0 as i32, (ly + m.px(4.0)) as i32),
        ((bx0 + box_w) as i32, (ly + legend_h - m.px(6.0)) as i32),
    ];
    root.draw(&Rectangle::new(r, WHITE.mix(0.92).filled()))
        .map_err(de)?;
    root.draw(&Rectangle::new(
        r,
        RGBColor(150, 150, 150).stroke_width(m.pu(1.0).max(1)),
    ))
    .map_err(de)?;
    for (ri, row) in job.rows.iter().enumerate() {
        let cy = ly + m.px(4.0 + 4.0 + LEGEND_ROW * (ri as f64 + 0.5));
        let mut x = lx + (lw as f64 - row_w(row)) / 2.0 + m.px(14.0);
        for &i in row {
            let e = &entries[i];
            let sx1 = x + m.px(48.0);
            let pts = vec![(x as i32, cy as i32), (sx1 as i32, cy as i32)];
            draw_polyline_px(root, &pts, e.style, m)?;
            if let Swatch::Line { markers: true } = e.swatch {
                draw_marker(root, ((x + sx1) / 2.0, cy), e.style, m)?;
            }
            root.draw_text(
                e.label,
                &m.legend().pos(Pos::new(HPos::Left, VPos::Center)),
                ((sx1 + m.px(12.0)) as i32, cy as i32),
            )
            .map_err(de)?;
            x += widths[i];
        }
    }
    Ok(Some(LegendPos::Outside))
}

impl ChartDraw for PanelsJob<'_> {
    fn draw_bitmap(
        &self,
        root: &DrawingArea<GlyphBackend, Shift>,
        _: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_line_panels(root, self, m)
    }
    fn draw_svg(
        &self,
        root: &DrawingArea<SVGBackend, Shift>,
        _: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_line_panels(root, self, m)
    }
}

/// Validates the panels and lays the figure out: the job and its size.
fn prepare_panels<'a>(f: &'a super::LinePanels, name: &str) -> Result<(PanelsJob<'a>, (u32, u32))> {
    if f.panels.is_empty() {
        return Err(Error::invalid(format!(
            "{name}: figure \"{}\" has no panels",
            f.title
        )));
    }
    let prepared = f
        .panels
        .iter()
        .map(|c| prepare_line(c, name))
        .collect::<Result<Vec<_>>>()?;
    let shared = shared_styles(f);
    let title_w = font::text_size(&f.title, 30.0, true).0 as f64;
    let cap_w = f
        .caption
        .as_deref()
        .map_or(0.0, |c| font::text_size(c, 20.0, false).0 as f64);
    let width = (PANEL_SIZE.0 * f.panels.len() as f64)
        .max(title_w + 60.0)
        .max(cap_w + 60.0);
    let rows = legend_rows(&shared.labels, width - 60.0);
    let mut header = 14.0 + 6.0;
    if !f.title.is_empty() {
        header += 40.0;
    }
    if f.caption.as_deref().is_some_and(|c| !c.is_empty()) {
        header += 30.0;
    }
    let height = header + PANEL_SIZE.1 + LEGEND_ROW * rows.len() as f64 + 16.0;
    let size = (width.ceil() as u32, height.ceil() as u32);
    if size.0 > 8000 || size.1 > 8000 {
        return Err(Error::invalid(format!(
            "{name}: figure would be {}×{} pixels; split it",
            size.0, size.1
        )));
    }
    Ok((
        PanelsJob {
            fig: f,
            prepared,
            shared,
            rows,
        },
        size,
    ))
}

/// See [`super::save_line_panels_as`].
pub fn save_line_panels(f: &super::LinePanels, stem: &Path, formats: Formats) -> Result<()> {
    let (job, size) = prepare_panels(f, &formats.describe(stem))?;
    render_chart(&job, stem, size, formats)
}

/// The PNG rendering of a [`super::LinePanels`] figure without writing it.
pub fn line_panels_image(f: &super::LinePanels) -> Result<Image> {
    let (job, size) = prepare_panels(f, "line panels")?;
    Ok(bitmap(&job, size, "line panels")?.0)
}

// ----------------------------------------------------------------- bar chart

pub(crate) struct PreparedBar {
    y: Axis,
}

pub(crate) fn prepare_bar(c: &BarChart, name: &str) -> Result<PreparedBar> {
    if c.categories.is_empty() {
        return Err(Error::invalid(format!(
            "{name}: bar chart \"{}\" has no categories",
            c.title
        )));
    }
    if c.series.is_empty() {
        return Err(Error::invalid(format!(
            "{name}: bar chart \"{}\" has no series",
            c.title
        )));
    }
    let nc = c.categories.len();
    if let Some(errs) = &c.errors {
        if errs.len() != c.series.len() {
            return Err(Error::invalid(format!(
                "{name}: {} error bar rows for {} series",
                errs.len(),
                c.series.len()
            )));
        }
    }
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for (si, (label, values)) in c.series.iter().enumerate() {
        if values.len() != nc {
            return Err(Error::invalid(format!(
                "{name}: series \"{label}\" has {} values for {nc} categories",
                values.len()
            )));
        }
        let errs = c.errors.as_ref().map(|e| &e[si]);
        if let Some(e) = errs {
            if e.len() != nc {
                return Err(Error::invalid(format!(
                    "{name}: series \"{label}\" has {} error bars for {nc} categories",
                    e.len()
                )));
            }
        }
        for (i, &v) in values.iter().enumerate() {
            let cat = &c.categories[i];
            if !v.is_finite() {
                return Err(Error::invalid(format!(
                    "{name}: series \"{label}\" value for \"{cat}\" is not finite ({v})"
                )));
            }
            if c.log_y && v <= 0.0 {
                return Err(Error::invalid(format!(
                    "{name}: series \"{label}\" value for \"{cat}\" is {v}, not positive on a log y axis"
                )));
            }
            let e = errs.map_or(0.0, |e| e[i]);
            if !e.is_finite() || e < 0.0 {
                return Err(Error::invalid(format!(
                    "{name}: series \"{label}\" error bar for \"{cat}\" is {e}; must be finite and ≥ 0"
                )));
            }
            // On a log axis an error bar reaching zero or below is cut at
            // the axis bottom, so only positive lower ends set the range.
            let low = if c.log_y && v - e <= 0.0 { v } else { v - e };
            lo = lo.min(low);
            hi = hi.max(v + e);
        }
    }
    let y = if c.log_y {
        let (a, b) = log_range(lo, hi);
        Axis::log(a, b)
    } else {
        let (a, b) = (lo.min(0.0), hi.max(0.0));
        let span = if b > a { b - a } else { 1.0 };
        let a = if a < 0.0 { a - 0.05 * span } else { 0.0 };
        let b = if hi > 0.0 { b + 0.08 * span } else { b };
        Axis::linear(a, b)
    };
    Ok(PreparedBar { y })
}

fn draw_bar_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    c: &BarChart,
    p: &PreparedBar,
    legend: Option<LegendPos>,
    m: Metrics,
) -> DResult<Option<LegendPos>> {
    root.fill(&WHITE).map_err(de)?;
    let header = draw_header(root, &c.title, c.caption.as_deref(), m)?;
    let (_, body) = root.split_vertically(header);
    let ns = c.series.len();
    let nc = c.categories.len();
    let entries: Vec<LegendEntry> = c
        .series
        .iter()
        .enumerate()
        .map(|(i, (label, _))| LegendEntry {
            label,
            style: series_style(i, ns.min(MAX_PLAIN_SERIES)),
            swatch: Swatch::Bar,
        })
        .collect();
    let lsize = legend_size(root, &entries, m)?;
    let (plot_area, legend_x) = if legend == Some(LegendPos::Outside) {
        let (bw, _) = body.dim_in_pixel();
        let lw = (lsize.0 + m.px(24.0)) as u32;
        let (a, _) = body.split_horizontally(bw.saturating_sub(lw));
        (a, Some(bw.saturating_sub(lw) as f64 + m.px(8.0)))
    } else {
        (body.clone(), None)
    };
    let x = Axis::category(nc);
    let yarea = y_label_area(root, &p.y, m)?;
    let mut chart = ChartBuilder::on(&plot_area)
        .margin_top(m.pu(8.0))
        .margin_right(m.pu(24.0))
        .margin_bottom(m.pu(12.0))
        .margin_left(m.pu(10.0))
        .x_label_area_size(m.px(22.0 + 30.0 * category_lines(c) as f64) as u32)
        .y_label_area_size(yarea)
        .build_cartesian_2d(x, p.y)
        .map_err(de)?;
    // Category names are drawn below the axis by `draw_categories` (word
    // wrapped to the category width); the mesh only draws the ticks.
    let fx = |_: &f64| String::new();
    let fy = tick_formatter(p.y, Y_TICKS);
    chart
        .configure_mesh()
        .y_desc(c.y_label.as_str())
        .x_labels(nc)
        .y_labels(Y_TICKS)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .label_style(m.tick())
        .x_label_style(m.desc())
        .axis_desc_style(m.desc())
        .disable_x_mesh()
        .bold_line_style(BLACK.mix(0.16).stroke_width(m.pu(1.0).max(1)))
        .light_line_style(BLACK.mix(0.06).stroke_width(m.pu(1.0).max(1)))
        .axis_style(BLACK.stroke_width(m.pu(1.5).max(1)))
        .set_all_tick_mark_size(m.pu(6.0))
        .draw()
        .map_err(de)?;
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let plot: Rect = (
        xr.start as f64,
        yr.start as f64,
        xr.end as f64,
        yr.end as f64,
    );
    let px = |v: f64| to_px(&x, v, plot.0, plot.2 - 1.0);
    let py = |v: f64| {
        let v = v.clamp(p.y.lo, p.y.hi);
        to_px(&p.y, v, plot.3 - 1.0, plot.1)
    };
    draw_categories(root, c, plot, m)?;
    let base = match p.y.scale {
        Scale::Log => p.y.lo,
        _ => 0.0f64.clamp(p.y.lo, p.y.hi),
    };
    let group = 0.8;
    let bw = group / ns as f64;
    let gap = bw * 0.08;
    let mut obstacles: Vec<Rect> = Vec::new();
    for (si, (_, values)) in c.series.iter().enumerate() {
        let style = series_style(si, ns.min(MAX_PLAIN_SERIES));
        let color = rgb(style.color);
        for (ci, &v) in values.iter().enumerate() {
            let x0 = ci as f64 - group / 2.0 + si as f64 * bw + gap;
            let x1 = x0 + bw - 2.0 * gap;
            let (a, b) = (px(x0), px(x1));
            let (t, u) = (py(v), py(base));
            let r = [
                (a.round() as i32, t.min(u).round() as i32),
                (b.round() as i32, t.max(u).round() as i32),
            ];
            root.draw(&Rectangle::new(r, color.filled())).map_err(de)?;
            root.draw(&Rectangle::new(
                r,
                BLACK.mix(0.7).stroke_width(m.pu(1.0).max(1)),
            ))
            .map_err(de)?;
            obstacles.push((a, t.min(u), b, t.max(u)));
            if let Some(errs) = &c.errors {
                let e = errs[si][ci];
                if e > 0.0 {
                    let lo = if p.y.scale == Scale::Log && v - e <= 0.0 {
                        p.y.lo
                    } else {
                        v - e
                    };
                    let (ylo, yhi) = (py(lo), py(v + e));
                    let cx = (a + b) / 2.0;
                    let cap = ((b - a) * 0.25).max(m.px(3.0));
                    let st = BLACK.stroke_width(m.pu(2.0).max(1));
                    let seg = |p0: (f64, f64), p1: (f64, f64)| {
                        PathElement::new(
                            vec![
                                (p0.0.round() as i32, p0.1.round() as i32),
                                (p1.0.round() as i32, p1.1.round() as i32),
                            ],
                            st,
                        )
                    };
                    root.draw(&seg((cx, ylo), (cx, yhi))).map_err(de)?;
                    root.draw(&seg((cx - cap, ylo), (cx + cap, ylo)))
                        .map_err(de)?;
                    root.draw(&seg((cx - cap, yhi), (cx + cap, yhi)))
                        .map_err(de)?;
                    obstacles.push((cx - cap, yhi, cx + cap, ylo));
                }
            }
        }
    }
    place_legend(root, &entries, legend, plot, lsize, &obstacles, legend_x, m)
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

/// Category label font size and the width available to one label, at the
/// reference size.
const CATEGORY_PX: f64 = 22.0;

fn category_width(c: &BarChart) -> f64 {
    // The plot is roughly 1000 px wide at the reference size.
    0.92 * 1000.0 / c.categories.len().max(1) as f64
}

/// Lines the longest wrapped category name needs (at most 3).
fn category_lines(c: &BarChart) -> usize {
    c.categories
        .iter()
        .map(|t| wrap(t, CATEGORY_PX, category_width(c)).len())
        .max()
        .unwrap_or(1)
        .clamp(1, 3)
}

fn draw_categories<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    c: &BarChart,
    plot: Rect,
    m: Metrics,
) -> DResult<()> {
    let x = Axis::category(c.categories.len());
    let style = m.desc().pos(Pos::new(HPos::Center, VPos::Top));
    let width = category_width(c);
    for (i, name) in c.categories.iter().enumerate() {
        let cx = to_px(&x, i as f64, plot.0, plot.2 - 1.0);
        for (k, line) in wrap(name, CATEGORY_PX, width).iter().take(3).enumerate() {
            let y = plot.3 + m.px(12.0 + 28.0 * k as f64);
            root.draw_text(line, &style, (cx.round() as i32, y.round() as i32))
                .map_err(de)?;
        }
    }
    Ok(())
}

struct BarJob<'a> {
    chart: &'a BarChart,
    prepared: PreparedBar,
}

impl ChartDraw for BarJob<'_> {
    fn draw_bitmap(
        &self,
        root: &DrawingArea<GlyphBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_bar_chart(root, self.chart, &self.prepared, legend, m)
    }
    fn draw_svg(
        &self,
        root: &DrawingArea<SVGBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_bar_chart(root, self.chart, &self.prepared, legend, m)
    }
}

/// See [`super::save_bar_chart_as`].
pub fn save_bar_chart(chart: &BarChart, stem: &Path, formats: Formats) -> Result<()> {
    let prepared = prepare_bar(chart, &formats.describe(stem))?;
    render_chart(&BarJob { chart, prepared }, stem, CHART_SIZE, formats)
}

// --------------------------------------------------------------------- table

/// See [`super::Table`]: column widths, row height, whether a column is
/// numeric (right-aligned).
struct TableJob<'a> {
    table: &'a super::Table,
    widths: Vec<f64>,
    numeric: Vec<bool>,
}

const TABLE_FONT: f64 = 20.0;
const TABLE_ROW: f64 = 36.0;
const TABLE_PAD: f64 = 18.0;
const TABLE_MARGIN: f64 = 30.0;

fn is_numeric(cell: &str) -> bool {
    let t = cell.trim();
    let head = t.split(['±', ' ']).next().unwrap_or("");
    !head.is_empty() && head.replace('−', "-").parse::<f64>().is_ok()
}

fn draw_table<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    job: &TableJob,
    m: Metrics,
) -> DResult<Option<LegendPos>> {
    let t = job.table;
    root.fill(&WHITE).map_err(de)?;
    let header = draw_header(root, &t.title, t.caption.as_deref(), m)?;
    let total: f64 = job.widths.iter().sum();
    let (w, _) = root.dim_in_pixel();
    let x0 = (w as f64 - m.px(total)) / 2.0;
    let y0 = header as f64 + m.px(8.0);
    let rule = |y: f64, width: f64| -> DResult<()> {
        root.draw(&Rectangle::new(
            [
                (x0.round() as i32, y.round() as i32),
                (
                    (x0 + m.px(total)).round() as i32,
                    (y + m.px(width)).round() as i32,
                ),
            ],
            BLACK.filled(),
        ))
        .map_err(de)
    };
    rule(y0, 2.0)?;
    let row_y = |r: usize| y0 + m.px(4.0 + TABLE_ROW * r as f64 + TABLE_ROW / 2.0);
    let cells = std::iter::once(&t.columns).chain(t.rows.iter());
    for (r, row) in cells.enumerate() {
        let mut x = x0;
        for (c, cell) in row.iter().enumerate() {
            let cw = m.px(job.widths[c]);
            let style = if r == 0 {
                font::bold(m.px(TABLE_FONT), BLACK)
            } else {
                font::text(m.px(TABLE_FONT), BLACK)
            };
            let (anchor, tx) = if job.numeric[c] {
                (HPos::Right, x + cw - m.px(TABLE_PAD))
            } else {
                (HPos::Left, x + m.px(TABLE_PAD))
            };
            root.draw_text(
                cell,
                &style.pos(Pos::new(anchor, VPos::Center)),
                (tx.round() as i32, row_y(r).round() as i32),
            )
            .map_err(de)?;
            x += cw;
        }
        if r == 0 {
            rule(y0 + m.px(4.0 + TABLE_ROW), 1.0)?;
        }
    }
    rule(
        y0 + m.px(4.0 + TABLE_ROW * (t.rows.len() + 1) as f64 + 4.0),
        2.0,
    )?;
    Ok(Some(LegendPos::Outside))
}

impl ChartDraw for TableJob<'_> {
    fn draw_bitmap(
        &self,
        root: &DrawingArea<GlyphBackend, Shift>,
        _: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_table(root, self, m)
    }
    fn draw_svg(
        &self,
        root: &DrawingArea<SVGBackend, Shift>,
        _: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_table(root, self, m)
    }
}

/// See [`super::save_table_as`].
pub fn save_table(table: &super::Table, stem: &Path, formats: Formats) -> Result<()> {
    let name = formats.describe(stem);
    let nc = table.columns.len();
    if nc == 0 {
        return Err(Error::invalid(format!(
            "{name}: table \"{}\" has no columns",
            table.title
        )));
    }
    if table.rows.is_empty() {
        return Err(Error::invalid(format!(
            "{name}: table \"{}\" has no rows",
            table.title
        )));
    }
    for (i, r) in table.rows.iter().enumerate() {
        if r.len() != nc {
            return Err(Error::invalid(format!(
                "{name}: table row {i} has {} cells for {nc} columns",
                r.len()
            )));
        }
    }
    let mut widths = Vec::with_capacity(nc);
    let mut numeric = Vec::with_capacity(nc);
    for c in 0..nc {
        let mut w = font::text_size(&table.columns[c], TABLE_FONT, true).0;
        for r in &table.rows {
            w = w.max(font::text_size(&r[c], TABLE_FONT, false).0);
        }
        widths.push(w as f64 + 2.0 * TABLE_PAD);
        numeric.push(table.rows.iter().all(|r| is_numeric(&r[c])));
    }
    let total: f64 = widths.iter().sum();
    let title_w = font::text_size(&table.title, 30.0, true).0 as f64;
    let cap_w = table
        .caption
        .as_deref()
        .map_or(0.0, |c| font::text_size(c, 20.0, false).0 as f64);
    let width = (total.max(title_w).max(cap_w) + 2.0 * TABLE_MARGIN).ceil() as u32;
    let mut header = 14.0 + 6.0;
    if !table.title.is_empty() {
        header += 40.0;
    }
    if table.caption.as_deref().is_some_and(|c| !c.is_empty()) {
        header += 30.0;
    }
    let height = (header + 8.0 + TABLE_ROW * (table.rows.len() + 1) as f64 + 12.0 + TABLE_MARGIN)
        .ceil() as u32;
    if width > 8000 || height > 8000 {
        return Err(Error::invalid(format!(
            "{name}: table would be {width}×{height} pixels; split it"
        )));
    }
    render_chart(
        &TableJob {
            table,
            widths,
            numeric,
        },
        stem,
        (width, height),
        formats,
    )
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

    #[test]
    fn clipping_keeps_the_inside_part() {
        let x = Axis::linear(0.0, 1.0);
        let y = Axis::linear(0.0, 1.0);
        // Leaves through the top at x = 0.1 and comes back at x = 0.9.
        let pts = [(0.0, 0.0), (0.5, 5.0), (1.0, 0.0)];
        let pieces = clip_polyline(&pts, &x, &y);
        assert_eq!(pieces.len(), 2);
        assert!((pieces[0][1].0 - 0.1).abs() < 1e-12 && (pieces[0][1].1 - 1.0).abs() < 1e-12);
        assert!((pieces[1][0].0 - 0.9).abs() < 1e-12);
        // Entirely outside: nothing.
        assert!(clip_polyline(&[(0.0, 2.0), (1.0, 3.0)], &x, &y).is_empty());
        // Log axis clipping happens in log space: (1, 1e-3)–(2, 1e1) crosses
        // y = 1 halfway in log10 y.
        let ly = Axis::log(1e-3, 1.0);
        let lx = Axis::linear(1.0, 2.0);
        let p = clip_polyline(&[(1.0, 1e-3), (2.0, 10.0)], &lx, &ly);
        assert_eq!(p.len(), 1);
        assert!((p[0][1].0 - 1.75).abs() < 1e-9, "{:?}", p);
    }
}

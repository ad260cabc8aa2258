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
    Outside,
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

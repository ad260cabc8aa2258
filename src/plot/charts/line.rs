//! Line charts ([`crate::plot::LineChart`]): validation and axis ranges,
//! clipping to the plot, drawing, and the PNG/SVG/PDF entry points.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::backend::{bitmap, render_chart, ChartDraw};
use super::layout::{
    draw_header, draw_legend_below, draw_marker, draw_polyline_px, draw_y_lines, header_height,
    legend_below, legend_size, log_range, place_legend, room_for_legend, tick_formatter, to_px,
    x_ticks, y_desc_lines, y_label_area, y_lines_extra, LegendEntry, LegendPos, Metrics, Rect,
    Swatch, Y_TICKS,
};
use super::{de, ChartStyle, DResult};
use crate::plot::axis::Axis;
use crate::plot::font::GlyphBackend;
use crate::plot::output::{Formats, Image};
use crate::plot::style::{series_style, SeriesStyle, FLOOR_STYLE, MAX_PLAIN_SERIES};
use crate::plot::LineChart;
use crate::{Error, Result};

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
    let (legend, plot_area, legend_x, below) = room_for_legend(&body, legend, lsize, &entries, m);
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
    if let Some((rows, area)) = below {
        draw_legend_below(root, &entries, &rows, area, m)?;
        return Ok(legend);
    }
    place_legend(root, &entries, legend, plot, lsize, &obstacles, legend_x, m)
}

/// Axes, grid and series of the line chart `c` in `area` (drawn through
/// `root`, in its pixel coordinates): series `i` in `style_of(i)`, the
/// `floor` series first and without markers, markers on the others when
/// `markers` (and on single points). Returns the plot rectangle and the
/// rectangles the data covers (obstacles for the legend).
#[allow(clippy::too_many_arguments)]
pub(super) fn draw_line_body<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    area: &DrawingArea<DB, Shift>,
    c: &LineChart,
    p: &PreparedLine,
    style_of: &dyn Fn(usize) -> SeriesStyle,
    markers: bool,
    floor: Option<usize>,
    m: Metrics,
) -> DResult<(Rect, Vec<Rect>)> {
    let (aw, ah) = area.dim_in_pixel();
    let yroom = ah as f64 - m.px(8.0 + 12.0 + 78.0);
    let ylines = y_desc_lines(&c.y_label, yroom, m);
    let yarea = y_label_area(root, &p.y, m)? + y_lines_extra(&ylines, m);
    let mut fits = vec![(c.x_label.as_str(), aw as f64 - yarea as f64 - m.px(46.0))];
    if ylines.len() == 1 {
        fits.push((c.y_label.as_str(), yroom));
    }
    let desc = m.desc_fitting(&fits);
    let mut chart = ChartBuilder::on(area)
        .margin_top(m.pu(8.0))
        .margin_right(m.pu(36.0))
        .margin_bottom(m.pu(12.0))
        .margin_left(m.pu(10.0))
        .x_label_area_size(m.pu(78.0))
        .y_label_area_size(yarea)
        .build_cartesian_2d(p.x, p.y)
        .map_err(de)?;
    let nx = x_ticks(aw as f64 - yarea as f64 - m.px(46.0), m);
    let fx = tick_formatter(p.x, nx);
    let fy = tick_formatter(p.y, Y_TICKS);
    let mut mesh = chart.configure_mesh();
    if ylines.len() == 1 {
        mesh.y_desc(c.y_label.as_str());
    }
    mesh.x_desc(c.x_label.as_str())
        .x_labels(nx)
        .y_labels(Y_TICKS)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .label_style(m.tick())
        .axis_desc_style(desc)
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
    if ylines.len() > 1 {
        let x0 = area.get_pixel_range().0.start as f64 + m.px(10.0);
        draw_y_lines(root, &ylines, x0, plot, m)?;
    }
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

/// The PNG rendering of a line chart in `style` without writing it.
pub fn line_chart_image(chart: &LineChart, style: &ChartStyle) -> Result<Image> {
    let prepared = prepare_line(chart, "line chart")?;
    let (job, size) = LineJob::new(chart, prepared, style);
    Ok(bitmap(&job, size, style, "line chart")?.0)
}

struct LineJob<'a> {
    chart: &'a LineChart,
    prepared: PreparedLine,
    /// The legend goes below the plot (the figure grew for it).
    below: bool,
}

impl<'a> LineJob<'a> {
    /// The job and the figure's size (reference pixels): the chart size of
    /// `style`, taller by a legend below the plot when it needs one.
    fn new(chart: &'a LineChart, prepared: PreparedLine, style: &ChartStyle) -> (Self, (u32, u32)) {
        let size = style.reference_size();
        let labels: Vec<&str> = chart.series.iter().map(|s| s.label.as_str()).collect();
        let header = header_height(&chart.title, chart.caption.as_deref());
        let extra = legend_below(&labels, size, header);
        let job = LineJob {
            chart,
            prepared,
            below: extra.is_some(),
        };
        (job, (size.0, size.1 + extra.unwrap_or(0.0).ceil() as u32))
    }

    fn legend(&self, asked: Option<LegendPos>) -> Option<LegendPos> {
        if self.below {
            Some(LegendPos::Below)
        } else {
            asked
        }
    }
}

impl ChartDraw for LineJob<'_> {
    fn draw_bitmap(
        &self,
        root: &DrawingArea<GlyphBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_line_chart(root, self.chart, &self.prepared, self.legend(legend), m)
    }
    fn draw_svg(
        &self,
        root: &DrawingArea<SVGBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_line_chart(root, self.chart, &self.prepared, self.legend(legend), m)
    }
}

/// See [`crate::plot::save_line_chart_styled`].
pub fn save_line_chart(
    chart: &LineChart,
    stem: &Path,
    formats: Formats,
    style: &ChartStyle,
) -> Result<()> {
    let prepared = prepare_line(chart, &formats.describe(stem))?;
    let (job, size) = LineJob::new(chart, prepared, style);
    render_chart(&job, stem, size, style, formats)
}

#[cfg(test)]
mod tests {
    use super::*;

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

//! Grouped bar charts ([`crate::plot::BarChart`]): validation, bars with
//! error bars, wrapped category labels, and the PNG/SVG/PDF entry points.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::backend::{bitmap, render_chart, ChartDraw};
use super::layout::{
    draw_header, draw_legend_below, draw_y_lines, header_height, legend_below, legend_size,
    log_range, place_legend, room_for_legend, tick_formatter, to_px, wrap, y_desc_lines,
    y_label_area, y_lines_extra, LegendEntry, LegendPos, Metrics, Rect, Swatch, Y_TICKS,
};
use super::{de, rgb, ChartStyle, DResult};
use crate::plot::axis::{Axis, Scale};
use crate::plot::font::{self, GlyphBackend};
use crate::plot::output::{Formats, Image};
use crate::plot::style::{series_style, MAX_PLAIN_SERIES};
use crate::plot::BarChart;
use crate::{Error, Result};

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
    job: &BarJob,
    legend: Option<LegendPos>,
    m: Metrics,
) -> DResult<Option<LegendPos>> {
    let (c, p) = (job.chart, &job.prepared);
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
    let (legend, plot_area, legend_x, below) = room_for_legend(&body, legend, lsize, &entries, m);
    let x = Axis::category(nc);
    let (_, ah) = plot_area.dim_in_pixel();
    let yroom = ah as f64 - m.px(8.0 + 12.0 + job.categories.area());
    let ylines = y_desc_lines(&c.y_label, yroom, m);
    let yarea = y_label_area(root, &p.y, m)? + y_lines_extra(&ylines, m);
    let mut chart = ChartBuilder::on(&plot_area)
        .margin_top(m.pu(8.0))
        .margin_right(m.pu(24.0))
        .margin_bottom(m.pu(12.0))
        .margin_left(m.pu(10.0))
        .x_label_area_size(m.px(job.categories.area()) as u32)
        .y_label_area_size(yarea)
        .build_cartesian_2d(x, p.y)
        .map_err(de)?;
    // Category names are drawn below the axis by `draw_categories` (word
    // wrapped to the category width); the mesh only draws the ticks.
    let fx = |_: &f64| String::new();
    let fy = tick_formatter(p.y, Y_TICKS);
    let desc = if ylines.len() == 1 {
        m.desc_fitting(&[(&c.y_label, yroom)])
    } else {
        m.desc()
    };
    let mut mesh = chart.configure_mesh();
    if ylines.len() == 1 {
        mesh.y_desc(c.y_label.as_str());
    }
    mesh.x_labels(nc)
        .y_labels(Y_TICKS)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .label_style(m.tick())
        .x_label_style(m.desc())
        .axis_desc_style(desc)
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
    if ylines.len() > 1 {
        let x0 = plot_area.get_pixel_range().0.start as f64 + m.px(10.0);
        draw_y_lines(root, &ylines, x0, plot, m)?;
    }
    let px = |v: f64| to_px(&x, v, plot.0, plot.2 - 1.0);
    let py = |v: f64| {
        let v = v.clamp(p.y.lo, p.y.hi);
        to_px(&p.y, v, plot.3 - 1.0, plot.1)
    };
    draw_categories(root, c, job.categories, plot, m)?;
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
    if let Some((rows, area)) = below {
        draw_legend_below(root, &entries, &rows, area, m)?;
        return Ok(legend);
    }
    place_legend(root, &entries, legend, plot, lsize, &obstacles, legend_x, m)
}

/// The PNG rendering of a bar chart in `style` without writing it.
pub fn bar_chart_image(chart: &BarChart, style: &ChartStyle) -> Result<Image> {
    let prepared = prepare_bar(chart, "bar chart")?;
    let (job, size) = BarJob::new(chart, prepared, style);
    Ok(bitmap(&job, size, style, "bar chart")?.0)
}

/// Category label font size and the width available to one label, at the
/// reference size.
const CATEGORY_PX: f64 = 22.0;

/// The width (reference pixels) of one category's label on a chart
/// `width` reference pixels wide (the plot: about `width` − 200).
fn category_width(c: &BarChart, width: f64) -> f64 {
    0.92 * (width - 200.0).max(100.0) / c.categories.len().max(1) as f64
}

/// How the category names are drawn below the axis.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Categories {
    /// Word wrapped to the category width, this many lines (1 to 3).
    Wrapped { lines: usize, width: f64 },
    /// Turned a quarter (reading upwards), one line each, the longest this
    /// many reference pixels: when wrapped names would not fit (many
    /// categories on a narrow chart).
    Vertical(f64),
}

impl Categories {
    /// Categories of `c` on a chart `width` reference pixels wide.
    fn of(c: &BarChart, width: f64) -> Categories {
        let cw = category_width(c, width);
        let mut lines = 1;
        let mut fits = true;
        for t in &c.categories {
            let w = wrap(t, CATEGORY_PX, cw);
            lines = lines.max(w.len());
            fits &= w.len() <= 3
                && w.iter()
                    .all(|l| font::text_size(l, CATEGORY_PX, false).0 as f64 <= cw);
        }
        if fits {
            Categories::Wrapped { lines, width: cw }
        } else {
            let longest = c
                .categories
                .iter()
                .map(|t| font::text_size(t, CATEGORY_PX, false).0 as f64)
                .fold(0.0, f64::max);
            Categories::Vertical(longest)
        }
    }

    /// Height (reference pixels) below the plot for the names.
    fn area(self) -> f64 {
        match self {
            Categories::Wrapped { lines, .. } => 22.0 + 30.0 * lines as f64,
            Categories::Vertical(h) => 24.0 + h,
        }
    }

    /// How much more room than one line of names they take (the figure
    /// grows by it when they turn).
    fn extra(self) -> f64 {
        match self {
            Categories::Wrapped { .. } => 0.0,
            Categories::Vertical(_) => (self.area() - 52.0).max(0.0),
        }
    }
}

fn draw_categories<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    c: &BarChart,
    layout: Categories,
    plot: Rect,
    m: Metrics,
) -> DResult<()> {
    let x = Axis::category(c.categories.len());
    let width = match layout {
        Categories::Wrapped { width, .. } => width,
        Categories::Vertical(_) => {
            let style = m
                .desc()
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Right, VPos::Center));
            for (i, name) in c.categories.iter().enumerate() {
                let cx = to_px(&x, i as f64, plot.0, plot.2 - 1.0);
                let y = plot.3 + m.px(12.0);
                root.draw_text(name, &style, (cx.round() as i32, y.round() as i32))
                    .map_err(de)?;
            }
            return Ok(());
        }
    };
    let style = m.desc().pos(Pos::new(HPos::Center, VPos::Top));
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
    categories: Categories,
    /// The legend goes below the plot (the figure grew for it).
    below: bool,
}

impl<'a> BarJob<'a> {
    /// The job and the figure's size (reference pixels): the chart size of
    /// `style`, taller by turned category names and a legend below the
    /// plot when it needs them.
    fn new(chart: &'a BarChart, prepared: PreparedBar, style: &ChartStyle) -> (Self, (u32, u32)) {
        let size = style.reference_size();
        let categories = Categories::of(chart, size.0 as f64);
        let labels: Vec<&str> = chart.series.iter().map(|(l, _)| l.as_str()).collect();
        let header = header_height(&chart.title, chart.caption.as_deref());
        let legend = legend_below(&labels, size, header);
        let extra = categories.extra() + legend.unwrap_or(0.0);
        let job = BarJob {
            chart,
            prepared,
            categories,
            below: legend.is_some(),
        };
        (job, (size.0, size.1 + extra.ceil() as u32))
    }

    fn legend(&self, asked: Option<LegendPos>) -> Option<LegendPos> {
        if self.below {
            Some(LegendPos::Below)
        } else {
            asked
        }
    }
}

impl ChartDraw for BarJob<'_> {
    fn draw_bitmap(
        &self,
        root: &DrawingArea<GlyphBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_bar_chart(root, self, self.legend(legend), m)
    }
    fn draw_svg(
        &self,
        root: &DrawingArea<SVGBackend, Shift>,
        legend: Option<LegendPos>,
        m: Metrics,
    ) -> DResult<Option<LegendPos>> {
        draw_bar_chart(root, self, self.legend(legend), m)
    }
}

/// See [`crate::plot::save_bar_chart_styled`].
pub fn save_bar_chart(
    chart: &BarChart,
    stem: &Path,
    formats: Formats,
    style: &ChartStyle,
) -> Result<()> {
    let prepared = prepare_bar(chart, &formats.describe(stem))?;
    let (job, size) = BarJob::new(chart, prepared, style);
    render_chart(&job, stem, size, style, formats)
}

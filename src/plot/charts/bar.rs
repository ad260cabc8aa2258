//! Grouped bar charts ([`crate::plot::BarChart`]): validation, bars with
//! error bars, wrapped category labels, and the PNG/SVG/PDF entry points.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::backend::{bitmap, render_chart, ChartDraw};
use super::layout::{
    draw_header, legend_size, log_range, place_legend, tick_formatter, to_px, wrap, y_label_area,
    LegendEntry, LegendPos, Metrics, Rect, Swatch, Y_TICKS,
};
use super::{de, rgb, DResult, CHART_SIZE};
use crate::plot::axis::{Axis, Scale};
use crate::plot::font::GlyphBackend;
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

/// The PNG rendering of a bar chart ([`CHART_SIZE`]) without writing it.
pub fn bar_chart_image(chart: &BarChart) -> Result<Image> {
    let prepared = prepare_bar(chart, "bar chart")?;
    Ok(bitmap(&BarJob { chart, prepared }, CHART_SIZE, "bar chart")?.0)
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

/// See [`crate::plot::save_bar_chart_as`].
pub fn save_bar_chart(chart: &BarChart, stem: &Path, formats: Formats) -> Result<()> {
    let prepared = prepare_bar(chart, &formats.describe(stem))?;
    render_chart(&BarJob { chart, prepared }, stem, CHART_SIZE, formats)
}

//! Line charts side by side in one figure with one shared legend
//! ([`crate::plot::LinePanels`]).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::backend::{bitmap, render_chart, ChartDraw};
use super::layout::{
    draw_header, draw_marker, draw_polyline_px, LegendEntry, LegendPos, Metrics, Swatch,
};
use super::line::{draw_line_body, prepare_line, PreparedLine};
use super::{de, ChartStyle, DResult};
use crate::plot::font::{self, GlyphBackend};
use crate::plot::output::{Formats, Image};
use crate::plot::style::{series_style, SeriesStyle, FLOOR_STYLE, MAX_PLAIN_SERIES};
use crate::{Error, Result};

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

fn shared_styles(f: &crate::plot::LinePanels) -> SharedStyles {
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
    super::layout::pack_rows(
        labels
            .iter()
            .map(|l| LEGEND_ENTRY + font::text_size(l, 19.0, false).0 as f64),
        width,
    )
}

struct PanelsJob<'a> {
    fig: &'a crate::plot::LinePanels,
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
fn prepare_panels<'a>(
    f: &'a crate::plot::LinePanels,
    name: &str,
    style: &ChartStyle,
) -> Result<(PanelsJob<'a>, (u32, u32))> {
    // One panel: the chart size of `style`, in reference pixels.
    let (pw, ph) = style.reference_size();
    let panel = (pw as f64, ph as f64);
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
    let width = (panel.0 * f.panels.len() as f64)
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
    let height = header + panel.1 + LEGEND_ROW * rows.len() as f64 + 16.0;
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

/// See [`crate::plot::save_line_panels_styled`]: each panel has the size
/// of `style`.
pub fn save_line_panels(
    f: &crate::plot::LinePanels,
    stem: &Path,
    formats: Formats,
    style: &ChartStyle,
) -> Result<()> {
    let (job, size) = prepare_panels(f, &formats.describe(stem), style)?;
    render_chart(&job, stem, size, style, formats)
}

/// The PNG rendering of a [`crate::plot::LinePanels`] figure without
/// writing it, each panel of the size of `style`.
pub fn line_panels_image(f: &crate::plot::LinePanels, style: &ChartStyle) -> Result<Image> {
    let (job, size) = prepare_panels(f, "line panels", style)?;
    Ok(bitmap(&job, size, style, "line panels")?.0)
}

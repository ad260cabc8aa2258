//! Tables drawn as figures ([`crate::plot::Table`]): booktabs-style rules,
//! bold header, numeric columns right-aligned, sized to the content.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::backend::{render_chart, ChartDraw};
use super::layout::{draw_header, LegendPos, Metrics};
use super::{de, ChartStyle, DResult};
use crate::plot::font::{self, GlyphBackend};
use crate::plot::output::Formats;
use crate::{Error, Result};

/// See [`crate::plot::Table`]: column widths, row height, whether a column is
/// numeric (right-aligned).
struct TableJob<'a> {
    table: &'a crate::plot::Table,
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

/// See [`crate::plot::save_table_styled`]: sized to the content, with the
/// text size and resolution of `style`.
pub fn save_table(
    table: &crate::plot::Table,
    stem: &Path,
    formats: Formats,
    style: &ChartStyle,
) -> Result<()> {
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
        style,
        formats,
    )
}

//! Tables: pivot tables (mean of a metric per row and column value) and
//! tables of group means, each as a figure, CSV, Markdown and LaTeX; the
//! LaTeX writing and escaping.

use std::collections::BTreeMap;

use super::{f, metric_label, Ctx, Row};
use crate::experiment::config::PlotSpec;
use crate::plot::{save_table_styled, Table};
use crate::{Error, Result};

/// A pivot table (see [`PlotKind::Pivot`]): `<file>.png` / `.svg` / `.csv`
/// / `.md`. Rows are sorted numerically when every row value is a number,
/// otherwise kept in order of appearance (method groups in config order,
/// then cases); columns in order of appearance. A cell mixing the results
/// of two method groups is an error (restrict `methods`).
///
/// [`PlotKind::Pivot`]: crate::experiment::config::PlotKind::Pivot
pub(super) fn pivot(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let need = |k: &Option<String>, name: &str| {
        k.clone()
            .ok_or_else(|| Error::invalid(format!("pivot tables need `{name}`")))
    };
    let (rk, ck, metric) = (
        need(&spec.rows, "rows")?,
        need(&spec.columns, "columns")?,
        need(&spec.metric, "metric")?,
    );
    let scale = spec.scale.unwrap_or(1.0);
    let digits = spec.digits.unwrap_or(3);
    let mut row_keys: Vec<String> = Vec::new();
    let mut col_keys: Vec<String> = Vec::new();
    // (row, column) → (values, groups); (row, lead column) → values.
    type Cell = (Vec<f64>, Vec<String>);
    let mut cells: BTreeMap<(String, String), Cell> = BTreeMap::new();
    let mut leads: BTreeMap<(String, String), Vec<f64>> = BTreeMap::new();
    for (g, methods) in &ctx.groups {
        for r in ctx.rows_of_group(g) {
            if !r.get("method").is_some_and(|m| methods.contains(m)) {
                continue;
            }
            let (Some(rv), Some(cv)) = (r.get(&rk), r.get(&ck)) else {
                continue;
            };
            if rv.is_empty() || cv.is_empty() {
                continue;
            }
            if !row_keys.contains(rv) {
                row_keys.push(rv.clone());
            }
            if !col_keys.contains(cv) {
                col_keys.push(cv.clone());
            }
            if let Some(x) = f(r, &metric) {
                let cell = cells.entry((rv.clone(), cv.clone())).or_default();
                cell.0.push(x);
                if !cell.1.contains(g) {
                    cell.1.push(g.clone());
                }
            }
            if spec.lead_from.as_ref().is_none_or(|v| v == cv) {
                for l in &spec.lead {
                    if let Some(x) = f(r, l) {
                        leads.entry((rv.clone(), l.clone())).or_default().push(x);
                    }
                }
            }
        }
    }
    if cells.is_empty() {
        return Err(Error::invalid(format!(
            "no finished results with {rk}, {ck} and {metric}"
        )));
    }
    if let Some(((rv, cv), (_, gs))) = cells.iter().find(|(_, c)| c.1.len() > 1) {
        return Err(Error::invalid(format!(
            "cell ({rk} = {rv}, {ck} = {cv}) mixes the method groups {}; \
             list the methods of one per cell in `methods`",
            gs.join(", ")
        )));
    }
    let numbers: Option<Vec<f64>> = row_keys.iter().map(|k| k.parse::<f64>().ok()).collect();
    if let Some(nums) = numbers {
        let mut order: Vec<usize> = (0..row_keys.len()).collect();
        order.sort_by(|&a, &b| nums[a].total_cmp(&nums[b]));
        row_keys = order.into_iter().map(|i| row_keys[i].clone()).collect();
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let label = |k: &str, default: String| spec.labels.get(k).cloned().unwrap_or(default);
    let header: Vec<String> = std::iter::once(label(&rk, rk.clone()))
        .chain(spec.lead.iter().map(|l| label(l, l.clone())))
        .chain(col_keys.iter().map(|c| label(c, c.replace('_', " "))))
        .collect();
    let mut csv_out = csv::Writer::from_writer(Vec::new());
    let csv_err = |e: csv::Error| Error::invalid(format!("pivot CSV: {e}"));
    let csv_head: Vec<&String> = std::iter::once(&rk)
        .chain(spec.lead.iter())
        .chain(col_keys.iter())
        .collect();
    csv_out.write_record(&csv_head).map_err(csv_err)?;
    let mut shown: Vec<Vec<String>> = Vec::new();
    let mut counts: Vec<usize> = Vec::new();
    for rv in &row_keys {
        let shown_rv = match rk.as_str() {
            "group" => ctx.group_label(spec, rv, rv),
            "method" => ctx.method_label(spec, rv),
            _ => label(rv, rv.clone()),
        };
        let mut line = vec![shown_rv];
        let mut rec = vec![rv.clone()];
        for l in &spec.lead {
            match leads.get(&(rv.clone(), l.clone())) {
                Some(v) => {
                    let x = mean(v);
                    line.push(if x.fract() == 0.0 {
                        format!("{x:.0}")
                    } else {
                        format!("{x:.1}")
                    });
                    rec.push(crate::experiment::store::num(x));
                }
                None => {
                    line.push("–".into());
                    rec.push(String::new());
                }
            }
        }
        for cv in &col_keys {
            match cells.get(&(rv.clone(), cv.clone())) {
                Some((v, _)) => {
                    let x = mean(v) * scale;
                    counts.push(v.len());
                    line.push(format!("{x:.digits$}"));
                    rec.push(crate::experiment::store::num(x));
                }
                None => {
                    line.push("–".into());
                    rec.push(String::new());
                }
            }
        }
        csv_out.write_record(&rec).map_err(csv_err)?;
        shown.push(line);
    }
    let what = if scale == 1.0 {
        metric.clone()
    } else {
        format!("{metric} × {scale}")
    };
    let n_note = match (counts.iter().min(), counts.iter().max()) {
        (Some(a), Some(b)) if a == b => format!("{a} result(s) per cell"),
        (Some(a), Some(b)) => format!("{a} to {b} results per cell"),
        _ => String::new(),
    };
    let caption = format!(
        "{}; cells: mean of {what} over cases, {n_note}",
        ctx.caption
    );
    let default_title = || format!("{}: {metric} by {rk} and {ck}", ctx.title);
    let md_title = ctx.title_text(spec, default_title);
    let title = ctx.title(spec, default_title);
    let mut md = format!(
        "| {} |\n|{}\n",
        header.join(" | "),
        "---|".repeat(header.len())
    );
    for line in &shown {
        md.push_str(&format!("| {} |\n", line.join(" | ")));
    }
    let lead_note = match (&spec.lead_from, spec.lead.is_empty()) {
        (Some(v), false) => format!(" {} from the {ck} = {v} results.", spec.lead.join(", ")),
        _ => String::new(),
    };
    md.push_str(&format!("\n{md_title}. {caption}.{lead_note}\n"));
    let stem = ctx.stem(spec, "pivot");
    crate::experiment::store::write_file(&stem.with_extension("md"), md.as_bytes(), true)?;
    let tex = latex_table(
        &header,
        &shown,
        &format!("{md_title}. {caption}.{lead_note}"),
    );
    crate::experiment::store::write_file(&stem.with_extension("tex"), tex.as_bytes(), true)?;
    let bytes = csv_out
        .into_inner()
        .map_err(|e| Error::invalid(format!("pivot CSV: {e}")))?;
    crate::experiment::store::write_file(&stem.with_extension("csv"), &bytes, true)?;
    save_table_styled(
        &Table {
            title,
            caption: ctx.subtitle(spec, caption),
            columns: header,
            rows: shown,
        },
        &stem,
        ctx.config.outputs.chart_formats(spec),
        &ctx.config.outputs.chart_style(),
    )
}

/// A Markdown + CSV + LaTeX table of group means: one row per group (and
/// per value of the `x` column when set, e.g. the class), one column per
/// metric.
pub(super) fn table(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    if spec.metrics.is_empty() {
        return Err(Error::invalid("tables need `metrics`"));
    }
    let mut keys: Vec<(String, String)> = Vec::new();
    for (g, _) in &ctx.groups {
        for r in ctx.rows_of_group(g) {
            let v = spec
                .x
                .as_ref()
                .and_then(|x| r.get(x).cloned())
                .unwrap_or_default();
            if !keys.contains(&(g.clone(), v.clone())) {
                keys.push((g.clone(), v));
            }
        }
    }
    if keys.is_empty() {
        return Err(Error::invalid("no finished results for the table"));
    }
    let head_x = spec.x.clone().map(|x| vec![x]).unwrap_or_default();
    let header: Vec<String> = ["method".to_string()]
        .into_iter()
        .chain(
            head_x
                .iter()
                .map(|x| spec.labels.get(x).unwrap_or(x).clone()),
        )
        .chain(spec.metrics.iter().map(|m| metric_label(spec, m)))
        .collect();
    let mut csv_out = csv::Writer::from_writer(Vec::new());
    let csv_head: Vec<String> = ["method".to_string()]
        .into_iter()
        .chain(head_x.iter().cloned())
        .chain(spec.metrics.iter().cloned())
        .chain(["n".to_string()])
        .collect();
    csv_out
        .write_record(&csv_head)
        .map_err(|e| Error::invalid(format!("table CSV: {e}")))?;
    let mut shown: Vec<Vec<String>> = Vec::new();
    for (g, v) in &keys {
        let rows: Vec<&Row> = ctx
            .rows_of_group(g)
            .into_iter()
            .filter(|r| {
                spec.x
                    .as_ref()
                    .is_none_or(|x| r.get(x).map(String::as_str) == Some(v.as_str()))
            })
            .collect();
        let cells: Vec<String> = spec
            .metrics
            .iter()
            .map(|m| {
                let vals: Vec<f64> = rows.iter().filter_map(|r| f(r, m)).collect();
                if vals.is_empty() {
                    String::new()
                } else {
                    let mean = vals.iter().sum::<f64>() / vals.len() as f64;
                    format!("{mean:.4e}")
                }
            })
            .collect();
        let mut line: Vec<String> = vec![ctx.group_label(spec, g, g)];
        if spec.x.is_some() {
            line.push(v.clone());
        }
        line.extend(cells.iter().map(|c| {
            c.parse::<f64>()
                .map_or("–".to_string(), crate::experiment::store::num)
        }));
        shown.push(line);
        let mut rec: Vec<String> = vec![g.clone()];
        if spec.x.is_some() {
            rec.push(v.clone());
        }
        rec.extend(cells);
        rec.push(rows.len().to_string());
        csv_out
            .write_record(&rec)
            .map_err(|e| Error::invalid(format!("table CSV: {e}")))?;
    }
    let note = format!(
        "{}; means over cases.",
        ctx.title_text(spec, || ctx.caption.clone())
    );
    let mut md = format!(
        "| {} |\n|{}\n",
        header.join(" | "),
        "---|".repeat(header.len())
    );
    for line in &shown {
        md.push_str(&format!("| {} |\n", line.join(" | ")));
    }
    md.push_str(&format!("\n{note}\n"));
    let stem = ctx.stem(spec, "table");
    crate::experiment::store::write_file(&stem.with_extension("md"), md.as_bytes(), true)?;
    let tex = latex_table(&header, &shown, &note);
    crate::experiment::store::write_file(&stem.with_extension("tex"), tex.as_bytes(), true)?;
    let bytes = csv_out
        .into_inner()
        .map_err(|e| Error::invalid(format!("table CSV: {e}")))?;
    crate::experiment::store::write_file(&stem.with_extension("csv"), &bytes, true)?;
    Ok(())
}

/// A LaTeX `tabular` with booktabs rules (`\toprule`, `\midrule`,
/// `\bottomrule`; needs `\usepackage{booktabs}`) of a header and rows of
/// cells as the Markdown table shows them: columns of numbers (and dashes
/// for missing ones) right-aligned, the others left-aligned, every cell
/// escaped ([`latex_escape`]); `note` (title and caption) as a comment
/// above it, for the document's own `\caption`.
fn latex_table(header: &[String], rows: &[Vec<String>], note: &str) -> String {
    let numeric = |c: &str| {
        let t = c.trim();
        matches!(t, "" | "–" | "-") || t.replace('−', "-").parse::<f64>().is_ok()
    };
    let spec: String = (0..header.len())
        .map(|i| {
            if rows.iter().all(|r| r.get(i).is_some_and(|c| numeric(c))) {
                'r'
            } else {
                'l'
            }
        })
        .collect();
    let line = |cells: &[String]| {
        let c: Vec<String> = cells.iter().map(|c| latex_escape(c)).collect();
        format!("{} \\\\\n", c.join(" & "))
    };
    let mut out = String::new();
    for l in note.lines() {
        out.push_str(&format!("% {l}\n"));
    }
    out.push_str(&format!("\\begin{{tabular}}{{{spec}}}\n\\toprule\n"));
    out.push_str(&line(header));
    out.push_str("\\midrule\n");
    for r in rows {
        out.push_str(&line(r));
    }
    out.push_str("\\bottomrule\n\\end{tabular}\n");
    out
}

/// `text` for LaTeX: the ten special characters escaped, the dashes and
/// the mathematical symbols of the labels (√, ′, −, ×, ±, Greek letters,
/// …) as LaTeX commands; other characters are kept (UTF-8 input).
pub fn latex_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 8);
    for ch in text.chars() {
        let s: &str = match ch {
            '\\' => "\\textbackslash{}",
            '&' => "\\&",
            '%' => "\\%",
            '$' => "\\$",
            '#' => "\\#",
            '_' => "\\_",
            '{' => "\\{",
            '}' => "\\}",
            '~' => "\\textasciitilde{}",
            '^' => "\\textasciicircum{}",
            '<' => "\\textless{}",
            '>' => "\\textgreater{}",
            '|' => "\\textbar{}",
            '–' => "--",
            '—' => "---",
            '−' => "\\ensuremath{-}",
            '×' => "\\ensuremath{\\times}",
            '±' => "\\ensuremath{\\pm}",
            '·' => "\\ensuremath{\\cdot}",
            '√' => "\\ensuremath{\\surd}",
            '′' => "\\ensuremath{'}",
            '→' => "\\ensuremath{\\to}",
            '≤' => "\\ensuremath{\\le}",
            '≥' => "\\ensuremath{\\ge}",
            'α' => "\\ensuremath{\\alpha}",
            'β' => "\\ensuremath{\\beta}",
            'γ' => "\\ensuremath{\\gamma}",
            'ε' => "\\ensuremath{\\varepsilon}",
            'λ' => "\\ensuremath{\\lambda}",
            'σ' => "\\ensuremath{\\sigma}",
            'Ê' => "\\^{E}",
            _ => {
                out.push(ch);
                continue;
            }
        };
        out.push_str(s);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latex_cells_are_escaped() {
        assert_eq!(
            latex_escape("a_b & 50% #1 {x} $y ~^\\"),
            "a\\_b \\& 50\\% \\#1 \\{x\\} \\$y \\textasciitilde{}\\textasciicircum{}\\textbackslash{}"
        );
        assert_eq!(
            latex_escape("error (√area units) – |α − 1|"),
            "error (\\ensuremath{\\surd}area units) -- \\textbar{}\\ensuremath{\\alpha} \\ensuremath{-} 1\\textbar{}"
        );
    }

    #[test]
    fn latex_tables_align_numbers_right() {
        let header = vec!["method".to_string(), "q".into(), "error".into()];
        let rows = vec![
            vec!["auto_x".to_string(), "1".into(), "0.5".into()],
            vec!["b".to_string(), "2".into(), "–".into()],
        ];
        let t = latex_table(&header, &rows, "note\nsecond line");
        assert!(t.starts_with("% note\n% second line\n\\begin{tabular}{lrr}\n\\toprule\n"));
        assert!(t.contains("method & q & error \\\\\n\\midrule\n"), "{t}");
        assert!(t.contains("auto\\_x & 1 & 0.5 \\\\\nb & 2 & -- \\\\\n\\bottomrule\n"));
        assert!(t.ends_with("\\end{tabular}\n"));
    }
}

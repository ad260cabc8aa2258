//! Charts of per-result metrics by method group: error bars, traces over a
//! parameter, lines of a metric against a column, timings.

use super::{column_label, f, metric_label, Ctx};
use crate::experiment::config::PlotSpec;
use crate::experiment::store::describe;
use crate::plot::{save_bar_chart_styled, save_line_chart_styled, BarChart, LineChart, Series};
use crate::{Error, Result};

fn group_stats(ctx: &Ctx, g: &str, col: &str) -> Option<(f64, f64)> {
    let v: Vec<f64> = ctx
        .rows_of_group(g)
        .iter()
        .filter_map(|r| f(r, col))
        .collect();
    if v.is_empty() {
        return None;
    }
    let (mean, std, ..) = describe(&v);
    Some((mean, std))
}

/// [`group_stats`] of a timing column, each row's memo-aware cost where it
/// has one: `seconds_selection` and `seconds_fit` of a row that reused a
/// memoised selection or fit are a few milliseconds, and their
/// `_computed` twins hold what the reused result cost when it was made
/// (rows recorded before those columns existed keep their own times).
fn cost_stats(ctx: &Ctx, g: &str, col: &str) -> Option<(f64, f64)> {
    let computed = format!("{col}_computed");
    let v: Vec<f64> = ctx
        .rows_of_group(g)
        .iter()
        .filter_map(|r| f(r, &computed).or_else(|| f(r, col)))
        .collect();
    if v.is_empty() {
        return None;
    }
    let (mean, std, ..) = describe(&v);
    Some((mean, std))
}

pub(super) fn bars(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    if spec.metrics.is_empty() {
        return Err(Error::invalid("bars need `metrics`"));
    }
    let groups: Vec<&String> = ctx
        .groups
        .iter()
        .map(|(g, _)| g)
        .filter(|g| {
            spec.metrics
                .iter()
                .any(|m| group_stats(ctx, g, m).is_some())
        })
        .collect();
    if groups.is_empty() {
        return Err(Error::invalid(format!(
            "no numbers for {} in cases.csv",
            spec.metrics.join(", ")
        )));
    }
    let mut series = Vec::new();
    let mut errors = Vec::new();
    for m in &spec.metrics {
        let st: Vec<(f64, f64)> = groups
            .iter()
            .map(|g| group_stats(ctx, g, m).unwrap_or((0.0, 0.0)))
            .collect();
        series.push((metric_label(spec, m), st.iter().map(|s| s.0).collect()));
        errors.push(st.iter().map(|s| s.1).collect());
    }
    let y_label = if let Some(l) = &spec.y_label {
        l.clone()
    } else if spec.metrics.len() == 1 {
        metric_label(spec, &spec.metrics[0])
    } else if spec.metrics.iter().all(|m| m.ends_with("_unit")) {
        "error (unit-sphere units)".into()
    } else if spec
        .metrics
        .iter()
        .all(|m| column_label(m).contains("(√area units)"))
    {
        "error (√area units)".into()
    } else if spec.metrics.iter().all(|m| m == "ari" || m == "purity") {
        "score (1 = true segmentation)".into()
    } else {
        "value".into()
    };
    // A 0/1 column's mean is a share of the cases: no ±std whiskers (they
    // would reach below 0 and above 1).
    let shares = spec
        .metrics
        .iter()
        .all(|m| SHARE_METRICS.contains(&m.as_str()));
    let chart = BarChart {
        title: ctx.title(spec, || {
            format!("{}: {}", ctx.title, spec.metrics.join(", "))
        }),
        caption: ctx.subtitle(
            spec,
            if shares {
                format!("{}; bars: share of the cases", ctx.caption)
            } else {
                format!("{}; bars: mean over cases, whiskers: ±1 std", ctx.caption)
            },
        ),
        y_label,
        categories: groups.iter().map(|g| ctx.group_label(spec, g, g)).collect(),
        series,
        errors: (!shares).then_some(errors),
        log_y: spec.log_y.unwrap_or(false),
    };
    let default = format!("bars_{}", spec.metrics.join("_"));
    save_bar_chart_styled(
        &chart,
        &ctx.stem(spec, &default),
        ctx.config.outputs.chart_formats(spec),
        &ctx.config.outputs.chart_style(),
    )
}

/// Columns that are 0 or 1 per case: their mean is a share.
const SHARE_METRICS: [&str; 2] = ["gross_failure", "perm_correct"];

pub(super) fn trace(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let mut series: Vec<Series> = Vec::new();
    let mut counts: Vec<usize> = Vec::new();
    let mut keys: Vec<(String, String)> = Vec::new();
    for r in &ctx.curves {
        if r.get("curve").map(String::as_str) != Some("selection_trace") {
            continue;
        }
        let k = (r["method"].clone(), r["case_id"].clone());
        let shown = ctx.groups.iter().any(|(_, ms)| ms.contains(&k.0));
        if shown && !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (m, c) in &keys {
        let pts: Vec<(f64, f64)> = ctx
            .curves
            .iter()
            .filter(|r| {
                r.get("curve").map(String::as_str) == Some("selection_trace")
                    && r["method"] == *m
                    && r["case_id"] == *c
            })
            .filter_map(|r| Some((f(r, "x")?, f(r, "y")?)))
            .collect();
        let n_methods: usize = ctx.groups.iter().map(|(_, ms)| ms.len()).sum();
        let label = if n_methods > 1 {
            format!("{}, {c}", ctx.method_label(spec, m))
        } else {
            c.clone()
        };
        let (x, y): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
        // Cases with the same source and A′ have the same trace: draw it once.
        match series.iter().position(|s| s.x == x && s.y == y) {
            Some(i) => counts[i] += 1,
            None => {
                series.push(Series { label, x, y });
                counts.push(1);
            }
        }
    }
    for (s, n) in series.iter_mut().zip(&counts) {
        if *n > 1 {
            s.label = format!("{} (same for {n} cases)", s.label);
        }
    }
    if series.is_empty() {
        return Err(Error::invalid("no selection traces in curves.csv"));
    }
    let norm = ctx
        .config
        .defaults
        .error_norm
        .map(|n| format!("{n:?}").to_lowercase())
        .unwrap_or_else(|| "paper".into());
    let chart = LineChart {
        title: ctx.title(spec, || {
            format!("{}: selection error vs number of key points", ctx.title)
        }),
        caption: ctx.subtitle(
            spec,
            format!("{}; stage 1 of Algorithm 1, one line per case", ctx.caption),
        ),
        x_label: "number of key points".into(),
        y_label: format!("deformation error Ê ({norm} norm, unit-sphere units)"),
        series,
        log_y: spec.log_y.unwrap_or(false),
        markers: true,
        floor: None,
        ..Default::default()
    };
    save_line_chart_styled(
        &chart,
        &ctx.stem(spec, "trace"),
        ctx.config.outputs.chart_formats(spec),
        &ctx.config.outputs.chart_style(),
    )
}

pub(super) fn line(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let x = spec
        .x
        .clone()
        .ok_or_else(|| Error::invalid("line plots need `x`"))?;
    if spec.metrics.is_empty() {
        return Err(Error::invalid("line plots need `metrics`"));
    }
    // `by`: one series per value of that column (e.g. the dictionary), in
    // order of first appearance among the groups.
    let by_value = |g: &str| -> String {
        spec.by
            .as_ref()
            .and_then(|b| ctx.rows_of_group(g).first().and_then(|r| r.get(b).cloned()))
            .unwrap_or_default()
    };
    let mut values: Vec<String> = Vec::new();
    for (g, _) in &ctx.groups {
        let v = by_value(g);
        if !values.contains(&v) {
            values.push(v);
        }
    }
    let mut series = Vec::new();
    for m in &spec.metrics {
        for v in &values {
            let mut pts: Vec<(f64, f64)> = ctx
                .groups
                .iter()
                .filter(|(g, _)| by_value(g) == *v)
                .filter_map(|(g, _)| Some((group_stats(ctx, g, &x)?.0, group_stats(ctx, g, m)?.0)))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            if !pts.is_empty() {
                let value = spec
                    .labels
                    .get(v)
                    .cloned()
                    .unwrap_or_else(|| v.replace('_', " "));
                let label = match (spec.metrics.len(), v.is_empty()) {
                    (_, true) => metric_label(spec, m),
                    (1, false) => value,
                    _ => format!("{} ({value})", metric_label(spec, m)),
                };
                series.push(Series {
                    label,
                    x: pts.iter().map(|p| p.0).collect(),
                    y: pts.iter().map(|p| p.1).collect(),
                });
            }
        }
    }
    if series.is_empty() {
        return Err(Error::invalid("no numbers to plot"));
    }
    let y_label = if let Some(l) = &spec.y_label {
        l.clone()
    } else if spec.metrics.len() == 1 {
        metric_label(spec, &spec.metrics[0])
    } else if spec
        .metrics
        .iter()
        .all(|m| column_label(m).contains("(√area units)"))
    {
        "error (√area units)".into()
    } else {
        "error (unit-sphere units)".into()
    };
    let chart = LineChart {
        title: ctx.title(spec, || {
            format!("{}: {} vs {}", ctx.title, spec.metrics.join(", "), x)
        }),
        caption: ctx.subtitle(spec, format!("{}; mean over cases per method", ctx.caption)),
        x_label: metric_label(spec, &x),
        y_label,
        series,
        log_y: spec.log_y.unwrap_or(false),
        markers: true,
        floor: None,
        ..Default::default()
    };
    save_line_chart_styled(
        &chart,
        &ctx.stem(spec, &format!("line_{x}")),
        ctx.config.outputs.chart_formats(spec),
        &ctx.config.outputs.chart_style(),
    )
}

pub(super) fn timing(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let cols = [
        ("seconds_selection", "key point selection (s)"),
        ("seconds_fit", "fit on A (s)"),
        (
            "seconds_weights_per_handle",
            "target weights per handle, SWT/h (s)",
        ),
        ("seconds_lbs_per_pose", "LBS per pose (s)"),
    ];
    let groups: Vec<&String> = ctx
        .groups
        .iter()
        .map(|(g, _)| g)
        // Methods with none of the timed stages (the `identity` floor) have
        // nothing to show on these axes.
        .filter(|g| {
            group_stats(ctx, g, "seconds_total").is_some()
                && cols.iter().any(|(c, _)| cost_stats(ctx, g, c).is_some())
        })
        .collect();
    if groups.is_empty() {
        return Err(Error::invalid("no timings in cases.csv"));
    }
    let mut md = String::from(
        "| method | vertices | key points | key point selection (s) | fit (s) | SWT/h (s) | LBS per pose (ms) | total (s) |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for g in &groups {
        let s = |c: &str| cost_stats(ctx, g, c).map(|x| x.0);
        let fmt = |x: Option<f64>, k: f64, d: usize| {
            x.map_or("–".to_string(), |v| format!("{:.*}", d, v * k))
        };
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            ctx.group_label(spec, g, g),
            fmt(s("n_vertices"), 1.0, 0),
            fmt(s("n_keypoints"), 1.0, 1),
            fmt(s("seconds_selection"), 1.0, 3),
            fmt(s("seconds_fit"), 1.0, 3),
            fmt(s("seconds_weights_per_handle"), 1.0, 4),
            fmt(s("seconds_lbs_per_pose"), 1000.0, 3),
            fmt(s("seconds_total"), 1.0, 2),
        ));
    }
    md.push_str(&format!(
        "\nMeans over cases. A key point selection or fit made once and reused by \
         later rows counts what it cost when made (`seconds_selection_computed`, \
         `seconds_fit_computed`). {}\n",
        ctx.caption
    ));
    let stem = ctx.stem(spec, "timing");
    crate::experiment::store::write_file(&stem.with_extension("md"), md.as_bytes(), true)?;
    let mut series = Vec::new();
    for (c, label) in cols {
        let v: Vec<f64> = groups
            .iter()
            .map(|g| cost_stats(ctx, g, c).map_or(0.0, |s| s.0.max(1e-6)))
            .collect();
        if v.iter().any(|x| *x > 1e-6) {
            series.push((label.to_string(), v));
        }
    }
    let chart = BarChart {
        title: ctx.title(spec, || format!("{}: running times", ctx.title)),
        caption: ctx.subtitle(spec, format!("{}; mean over cases", ctx.caption)),
        y_label: "time (s, log scale)".into(),
        categories: groups.iter().map(|g| ctx.group_label(spec, g, g)).collect(),
        series,
        errors: None,
        log_y: true,
    };
    save_bar_chart_styled(
        &chart,
        &stem,
        ctx.config.outputs.chart_formats(spec),
        &ctx.config.outputs.chart_style(),
    )
}

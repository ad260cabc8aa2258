//! Cumulative error curves (one chart per curve of `curves.csv`, the
//! identity floor dashed) and curve panels (several curves side by side
//! with one shared legend).

use std::collections::BTreeMap;

use super::{f, Ctx, Row};
use crate::experiment::config::{PlotSpec, TitleSpec};
use crate::plot::{save_line_chart_styled, save_line_panels_styled, LineChart, LinePanels, Series};
use crate::{Error, Result};

/// Cumulative curves of every method group (see the module documentation):
/// `cumulative` (unit-sphere units), `cumulative_area` (√area units),
/// `cumulative_area_rigid` (√area units, after the best rigid alignment of
/// each result onto its truth), `cumulative_distortion` and
/// `cumulative_correspondence`, each written when some result has its curve.
/// The identity group is drawn as a dashed grey floor.
pub(super) fn cumulative(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    for (curve, x_label, y_label, suffix) in [
        (
            "cumulative_unit",
            "error bound (unit-sphere units of B)",
            "vertices within the bound (%)",
            "",
        ),
        (
            "cumulative_area",
            "error bound (√area(B) units)",
            "vertices within the bound (%)",
            "_area",
        ),
        (
            "cumulative_area_rigid",
            "error bound after best rigid alignment (√area(B) units)",
            "vertices within the bound (%)",
            "_area_rigid",
        ),
        (
            "distortion_area",
            "bound on |log(face area / area on B)|",
            "faces within the bound (%)",
            "_distortion",
        ),
        (
            "correspondence_geodesic_area",
            "geodesic error bound (√area units)",
            "correspondences within the bound (%)",
            "_correspondence",
        ),
        (
            "correspondence_euclidean_area",
            "Euclidean error bound (√area units)",
            "correspondences within the bound (%)",
            "_correspondence_euclidean",
        ),
    ] {
        let MeanCurves {
            mut series,
            floor,
            cases: curve_cases,
        } = mean_curves(ctx, spec, curve);
        for sr in &mut series {
            sr.y.iter_mut().for_each(|y| *y *= 100.0);
        }
        if series.is_empty() {
            if curve == "cumulative_unit" {
                return Err(Error::invalid(format!("no {curve} curves in curves.csv")));
            }
            continue;
        }
        let title = match (&spec.title, suffix) {
            (Some(TitleSpec::Text(_)), _) if !ctx.titles => String::new(),
            (Some(TitleSpec::Text(t)), "") => t.clone(),
            (Some(TitleSpec::Text(t)), _) => format!("{t} ({})", suffix.trim_start_matches('_')),
            _ => ctx.title(spec, || match suffix {
                "_distortion" => format!("{}: cumulative area distortion", ctx.title),
                "_correspondence" => {
                    format!("{}: geodesic correspondence error (Kim et al.)", ctx.title)
                }
                "_correspondence_euclidean" => {
                    format!("{}: Euclidean correspondence error", ctx.title)
                }
                _ => format!("{}: cumulative error to ground truth", ctx.title),
            }),
        };
        let chart = LineChart {
            title,
            caption: ctx.subtitle(
                spec,
                format!(
                    "{}; mean curve over the {} case(s) with {}",
                    ctx.caption,
                    curve_cases.len(),
                    if suffix == "_distortion" || suffix.starts_with("_correspondence") {
                        "results"
                    } else {
                        "ground truth"
                    }
                ),
            ),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series,
            x_range: None,
            y_range: Some((0.0, 100.0)),
            log_y: false,
            markers: false,
            floor,
        };
        let stem = ctx.stem(spec, "cumulative");
        let stem = stem.with_file_name(format!(
            "{}{suffix}",
            stem.file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        ));
        save_line_chart_styled(
            &chart,
            &stem,
            ctx.config.outputs.chart_formats(spec),
            &ctx.config.outputs.chart_style(),
        )?;
    }
    Ok(())
}

/// Mean curves of the shown method groups (see [`mean_curves`]).
struct MeanCurves {
    /// One series per group with the curve, y as stored (a fraction for
    /// cumulative curves).
    series: Vec<Series>,
    /// Index of the identity group's series, labelled with the floor label.
    floor: Option<usize>,
    /// Case ids with the curve.
    cases: std::collections::BTreeSet<String>,
}

/// Whether a curves.csv row's curve is `wanted` (results written before the
/// geodesic correspondence curve was named `correspondence_geodesic_area`
/// call it `correspondence_area`).
fn is_curve(r: &Row, wanted: &str) -> bool {
    match r.get("curve").map(String::as_str) {
        Some(c) if c == wanted => true,
        Some("correspondence_area") => wanted == "correspondence_geodesic_area",
        _ => false,
    }
}

/// The mean over the case × method curves `curve` of each shown group, in
/// group order, sorted by x; labelled with the groups' display names.
fn mean_curves(ctx: &Ctx, spec: &PlotSpec, curve: &str) -> MeanCurves {
    let mut series = Vec::new();
    let mut floor = None;
    let mut cases = std::collections::BTreeSet::new();
    for (g, methods) in &ctx.groups {
        let mut acc: BTreeMap<String, (f64, f64, usize)> = BTreeMap::new();
        for r in &ctx.curves {
            if !is_curve(r, curve) || !methods.iter().any(|m| Some(m) == r.get("method")) {
                continue;
            }
            if let Some(c) = r.get("case_id") {
                cases.insert(c.clone());
            }
            let (Some(x), Some(y)) = (f(r, "x"), f(r, "y")) else {
                continue;
            };
            let e = acc.entry(r["x"].clone()).or_insert((x, 0.0, 0));
            e.1 += y;
            e.2 += 1;
        }
        if acc.is_empty() {
            continue;
        }
        let mut pts: Vec<(f64, f64)> = acc.values().map(|&(x, s, n)| (x, s / n as f64)).collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let is_floor = ctx.identity_group.as_ref() == Some(g);
        if is_floor {
            floor = Some(series.len());
        }
        series.push(Series {
            label: ctx.group_label(spec, g, if is_floor { ctx.floor_label } else { g }),
            x: pts.iter().map(|p| p.0).collect(),
            y: pts.iter().map(|p| p.1).collect(),
        });
    }
    MeanCurves {
        series,
        floor,
        cases,
    }
}

/// Panel title, x label, y label of a curves.csv curve, and whether it is
/// cumulative (a share, drawn in percent).
fn curve_info(curve: &str) -> (String, String, String, bool) {
    let share = |t: &str, x: &str, y: &str| (t.to_string(), x.to_string(), y.to_string(), true);
    match curve {
        "cumulative_unit" => share(
            "Distance to the true position",
            "distance bound (unit-sphere units)",
            "points within the bound (%)",
        ),
        "cumulative_area" => share(
            "Distortion",
            "relative distance to the true position (√area units)",
            "points within the distance (%)",
        ),
        "cumulative_area_rigid" => share(
            "Distortion after rigid alignment",
            "relative distance to the true position (√area units)",
            "points within the distance (%)",
        ),
        "distortion_area" => share(
            "Area distortion",
            "bound on |log(face area / area on B)|",
            "faces within the bound (%)",
        ),
        "correspondence_euclidean_area" => share(
            "Correspondence (Euclidean)",
            "Euclidean distance to the true point (√area units)",
            "correspondences within the distance (%)",
        ),
        "correspondence_geodesic_area" | "correspondence_area" => share(
            "Correspondence (geodesic)",
            "geodesic distance to the true point (√area units)",
            "correspondences within the distance (%)",
        ),
        c => (c.replace('_', " "), "x".into(), "y".into(), false),
    }
}

/// One figure with a panel per curve of `spec.curves` (mean curve per
/// method group, shared legend); curves absent from curves.csv are left
/// out with a warning.
pub(super) fn curve_panels(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let mut panels = Vec::new();
    let mut missing = Vec::new();
    let mut cases = std::collections::BTreeSet::new();
    for curve in &spec.curves {
        let mc = mean_curves(ctx, spec, curve);
        if mc.series.is_empty() {
            missing.push(curve.as_str());
            continue;
        }
        cases.extend(mc.cases);
        let (title, x_label, y_label, share) = curve_info(curve);
        let mut series = mc.series;
        for sr in &mut series {
            if share {
                sr.y.iter_mut().for_each(|y| *y *= 100.0);
            }
        }
        panels.push(LineChart {
            title: spec.labels.get(curve).cloned().unwrap_or(title),
            caption: None,
            x_label,
            y_label,
            series,
            y_range: share.then_some((0.0, 100.0)),
            floor: mc.floor,
            ..Default::default()
        });
    }
    let n_cases = ctx
        .rows
        .iter()
        .filter_map(|r| r.get("case_id"))
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    if panels.is_empty() {
        return Err(Error::invalid(format!(
            "none of the curves {} in curves.csv",
            spec.curves.join(", ")
        )));
    }
    let names: Vec<&str> = panels.iter().map(|p| p.title.as_str()).collect();
    let fig = LinePanels {
        title: ctx.title(spec, || format!("{}: {}", ctx.title, names.join(", "))),
        caption: ctx.subtitle(
            spec,
            format!(
                "{}; mean curve per method over {}",
                ctx.caption,
                if cases.len() == n_cases {
                    "the cases".to_string()
                } else {
                    format!("the {} case(s) with results", cases.len())
                }
            ),
        ),
        panels,
    };
    save_line_panels_styled(
        &fig,
        &ctx.stem(spec, "curve_panels"),
        ctx.config.outputs.chart_formats(spec),
        &ctx.config.outputs.chart_style(),
    )?;
    if !missing.is_empty() {
        return Err(Error::invalid(format!(
            "no {} curves in curves.csv; drawn without them",
            missing.join(", ")
        )));
    }
    Ok(())
}

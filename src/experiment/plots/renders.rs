//! Mesh renders: panels of results (source, target, results coloured by
//! their per-vertex error, with key points) and cluster renders (vertex
//! labels), read from the saved meshes.

use std::path::{Path, PathBuf};

use super::{f, read_csv, Ctx, Row};
use crate::eval::{vertex_errors, ErrorScale};
use crate::experiment::config::PlotSpec;
use crate::experiment::store::MeshOut;
use crate::mesh::io::read_mesh;
use crate::mesh::Mesh;
use crate::plot::{save_figure_as, Coloring, Figure, Panel};
use crate::{Error, Result};

/// (group, mesh, per-vertex error, key points) of one result panel.
type ResultPanel = (String, Mesh, Vec<f64>, Vec<(usize, usize)>);

fn keypoints_of(row: &Row) -> Vec<(usize, usize)> {
    keypoint_column(row, "keypoints")
}

/// The key points on the target: `target_keypoints` when recorded (automatic
/// or noisy target points), else the source indices.
fn target_keypoints_of(row: &Row) -> Vec<(usize, usize)> {
    match row.get("target_keypoints") {
        Some(s) if !s.is_empty() => keypoint_column(row, "target_keypoints"),
        _ => keypoints_of(row),
    }
}

fn keypoint_column(row: &Row, column: &str) -> Vec<(usize, usize)> {
    row.get(column)
        .map(|s| {
            s.split(';')
                .filter_map(|x| x.parse::<usize>().ok())
                .enumerate()
                .map(|(k, v)| (v, k))
                .collect()
        })
        .unwrap_or_default()
}

/// Case ids (in case order) whose meshes were saved.
fn render_cases(ctx: &Ctx) -> Vec<String> {
    let mut ids: Vec<(usize, String)> = Vec::new();
    for r in &ctx.rows {
        let (Some(c), Some(id)) = (r.get("case").and_then(|c| c.parse().ok()), r.get("case_id"))
        else {
            continue;
        };
        if !ids.iter().any(|(_, x)| x == id) && ctx.dir.join("meshes").join(id).is_dir() {
            ids.push((c, id.clone()));
        }
    }
    ids.sort();
    ids.into_iter().map(|x| x.1).collect()
}

pub(super) fn panels(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let fits = spec.show.as_deref() == Some("fits");
    let ids = render_cases(ctx);
    if ids.is_empty() {
        return Err(Error::invalid("no saved meshes (meshes/<case>/)"));
    }
    for id in &ids {
        let mdir = ctx.dir.join("meshes").join(id);
        let rows: Vec<&Row> = ctx
            .rows
            .iter()
            .filter(|r| {
                r.get("case_id") == Some(id) && r.get("status").map(String::as_str) == Some("ok")
            })
            .collect();
        let Some(first) = rows.first() else { continue };
        let poses: Vec<String> = first
            .get("poses")
            .map(|p| p.split(';').map(String::from).collect())
            .unwrap_or_default();
        let source = read_mesh(&saved(&mdir, "source")?)?;
        let target = read_mesh(&saved(&mdir, "target")?)?;
        // One representative method per group (the first with saved meshes).
        let mut shown: Vec<(&String, &Row)> = Vec::new();
        for (g, methods) in &ctx.groups {
            if let Some(r) = methods
                .iter()
                .find_map(|m| rows.iter().find(|r| r.get("method") == Some(m)))
            {
                if r.get("kind").map(String::as_str) != Some("clustering") {
                    shown.push((g, r));
                }
            }
        }
        if shown.is_empty() {
            continue;
        }
        for pose in &poses {
            let Some(deformed_path) = MeshOut::find(&mdir, &format!("deformed_{pose}")) else {
                continue;
            };
            let deformed = read_mesh(&deformed_path)?;
            let reference: Option<Mesh> = if fits {
                Some(deformed.clone())
            } else {
                MeshOut::find(&mdir, &format!("truth_{pose}"))
                    .map(|p| read_mesh(&p))
                    .transpose()?
            };
            let scale = ErrorScale::of_reference(if fits { &source } else { &target })?.unit_sphere;
            let kp0 = keypoints_of(shown[0].1);
            // FBT registration (shape completion): the template, the partial
            // target it is registered to, the full target, then the results.
            let registration = !fits
                && shown
                    .iter()
                    .all(|(_, r)| r.get("kind").map(String::as_str) == Some("fbt"));
            let mut ps = if registration {
                let partial = shown.iter().find_map(|(_, r)| {
                    MeshOut::find(&mdir.join(&r["method"]), &format!("partial_{pose}"))
                });
                let (label, mesh) = match partial {
                    Some(p) => (format!("partial target (pose {pose})"), read_mesh(&p)?),
                    None => (format!("target (pose {pose})"), deformed.clone()),
                };
                let mut ps = vec![
                    Panel {
                        label: "template (reference shape)".into(),
                        mesh: source.clone(),
                        coloring: Coloring::Plain,
                        keypoints: kp0,
                    },
                    Panel {
                        label,
                        mesh,
                        coloring: Coloring::Plain,
                        keypoints: Vec::new(),
                    },
                ];
                if let Some(t) = &reference {
                    ps.push(Panel {
                        label: "full target (ground truth)".into(),
                        mesh: t.clone(),
                        coloring: Coloring::Plain,
                        keypoints: Vec::new(),
                    });
                }
                ps
            } else {
                header_panels(
                    &source,
                    &target,
                    &deformed,
                    reference.as_ref(),
                    pose,
                    fits,
                    (kp0, target_keypoints_of(shown[0].1)),
                )
            };
            let mut results: Vec<ResultPanel> = Vec::new();
            let mut registered: Vec<Panel> = Vec::new();
            for (g, r) in &shown {
                let m = &r["method"];
                let file = if fits { "fit" } else { "result" };
                let Some(p) = MeshOut::find(&mdir.join(m), &format!("{file}_{pose}")) else {
                    continue;
                };
                let reg = MeshOut::find(&mdir.join(m), "registered");
                if let (false, true, Some(reg)) = (fits, registered.is_empty(), reg) {
                    // Automatic target correspondence: A registered onto B.
                    registered.push(Panel {
                        label: format!("A→B, {}", ctx.group_label(spec, g, g)),
                        mesh: read_mesh(&reg)?,
                        coloring: Coloring::Plain,
                        keypoints: keypoints_of(r),
                    });
                }
                let mesh = read_mesh(&p)?;
                let err = match &reference {
                    Some(t) => vertex_errors(mesh.vertices(), t.vertices())?
                        .into_iter()
                        .map(|e| e * scale)
                        .collect(),
                    None => Vec::new(),
                };
                let kp = if fits {
                    keypoints_of(r)
                } else {
                    target_keypoints_of(r)
                };
                results.push((ctx.group_label(spec, g, g), mesh, err, kp));
            }
            if results.is_empty() {
                continue;
            }
            ps.extend(registered);
            let mut all: Vec<f64> = results.iter().flat_map(|r| r.2.iter().copied()).collect();
            all.sort_by(f64::total_cmp);
            let hi = all
                .get(((all.len() as f64) * 0.98) as usize)
                .copied()
                .unwrap_or(0.0)
                .max(1e-6);
            for (g, mesh, err, kp) in results {
                let coloring = if err.is_empty() {
                    Coloring::Plain
                } else {
                    Coloring::Scalar {
                        values: err,
                        lo: 0.0,
                        hi,
                        label: if fits {
                            "error to A′ (unit-sphere units of A)".into()
                        } else if registration {
                            "distance to the true position (unit-sphere units)".into()
                        } else {
                            "error to ground truth (unit-sphere units of B)".into()
                        },
                    }
                };
                ps.push(Panel {
                    label: g,
                    mesh,
                    coloring,
                    keypoints: kp,
                });
            }
            let fig = Figure {
                title: ctx.title(spec, || {
                    if fits {
                        format!(
                            "{}: deformed source per method (case {id}, pose {pose})",
                            ctx.title
                        )
                    } else if registration {
                        format!(
                            "{}: registration results (case {id}, pose {pose})",
                            ctx.title
                        )
                    } else {
                        format!("{}: transfer results (case {id}, pose {pose})", ctx.title)
                    }
                }),
                caption: ctx.subtitle(
                    spec,
                    if registration {
                        format!(
                            "{}; right: the template registered by each method",
                            ctx.caption
                        )
                    } else {
                        format!(
                            "{}; {}; spheres: key points (on A: those of {}); colour: \
                             per-vertex error",
                            ctx.caption,
                            if fits {
                                "right: the deformed source D_S(A) of each method"
                            } else {
                                "right: the transferred B′ of each method"
                            },
                            ctx.group_label(spec, shown[0].0, shown[0].0)
                        )
                    },
                ),
                panels: ps,
                camera: ctx.config.outputs.camera(&ctx.config.dataset),
                panel_size: (260, 360),
            };
            let default = if fits { "fits" } else { "panels" };
            let stem = ctx.stem(spec, default);
            let stem = stem.with_file_name(format!(
                "{}_{id}_{pose}",
                stem.file_name()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            ));
            save_figure_as(
                &fig,
                &ctx.render_options(),
                &stem,
                ctx.config.outputs.render_formats(spec),
            )?;
        }
    }
    Ok(())
}

/// The saved mesh `dir/<stem>.ply` (or `.obj`); an error naming the
/// folder when neither exists.
fn saved(dir: &Path, stem: &str) -> Result<PathBuf> {
    MeshOut::find(dir, stem).ok_or_else(|| {
        Error::invalid(format!(
            "{}: no saved mesh {stem}.ply or {stem}.obj",
            dir.display()
        ))
    })
}

/// Key points of a panel: (vertex, key point index).
type Keypoints = Vec<(usize, usize)>;

/// The left panels of a BDT figure: source (with key points), deformed
/// source, and for transfers the target (with its key points: the source's,
/// or the recorded target key points) and the ground truth.
fn header_panels(
    source: &Mesh,
    target: &Mesh,
    deformed: &Mesh,
    reference: Option<&Mesh>,
    pose: &str,
    fits: bool,
    (kp0, kp_b): (Keypoints, Keypoints),
) -> Vec<Panel> {
    let mut ps = vec![
        Panel {
            label: "source A".into(),
            mesh: source.clone(),
            coloring: Coloring::Plain,
            keypoints: kp0,
        },
        Panel {
            label: format!("deformed source A′ (pose {pose})"),
            mesh: deformed.clone(),
            coloring: Coloring::Plain,
            keypoints: Vec::new(),
        },
    ];
    if !fits {
        ps.push(Panel {
            label: "target B".into(),
            mesh: target.clone(),
            coloring: Coloring::Plain,
            keypoints: kp_b
                .into_iter()
                .filter(|&(v, _)| v < target.n_vertices())
                .collect(),
        });
        if let Some(t) = reference {
            ps.push(Panel {
                label: "ground truth B′".into(),
                mesh: t.clone(),
                coloring: Coloring::Plain,
                keypoints: Vec::new(),
            });
        }
    }
    ps
}

/// Spreads label ids over [0, 1] so that neighbouring ids get distinct colours.
fn label_value(l: usize) -> f64 {
    (l as f64 * 0.618_033_988_75).fract()
}

fn read_labels(path: &Path) -> Result<Vec<usize>> {
    read_csv(path)?
        .iter()
        .enumerate()
        .map(|(i, r)| {
            r.get("cluster")
                .or_else(|| r.get("label"))
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| Error::parse(path, format!("row {}", i + 2), "expected a label"))
        })
        .collect()
}

pub(super) fn clusters(ctx: &Ctx, spec: &PlotSpec) -> Result<()> {
    let ids = render_cases(ctx);
    let mut made = 0;
    for id in &ids {
        let mdir = ctx.dir.join("meshes").join(id);
        let source = read_mesh(&saved(&mdir, "source")?)?;
        let mut ps = Vec::new();
        let lp = mdir.join("labels.csv");
        if lp.exists() {
            let l = read_labels(&lp)?;
            ps.push(Panel {
                label: "true bones".into(),
                mesh: source.clone(),
                coloring: Coloring::Scalar {
                    values: l.iter().map(|&x| label_value(x)).collect(),
                    lo: 0.0,
                    hi: 1.0,
                    label: "segment (colours are arbitrary)".into(),
                },
                keypoints: Vec::new(),
            });
        }
        for (g, methods) in &ctx.groups {
            let Some(m) = methods
                .iter()
                .find(|m| mdir.join(m.as_str()).join("clusters.csv").exists())
            else {
                continue;
            };
            let l = read_labels(&mdir.join(m.as_str()).join("clusters.csv"))?;
            let row = ctx
                .rows
                .iter()
                .find(|r| r.get("case_id") == Some(id) && r.get("method") == Some(m));
            let score = row
                .and_then(|r| f(r, "ari"))
                .map(|a| format!(" (ARI {a:.2})"))
                .unwrap_or_default();
            ps.push(Panel {
                label: format!("{}{score}", ctx.group_label(spec, g, g)),
                mesh: source.clone(),
                coloring: Coloring::Scalar {
                    values: l.iter().map(|&x| label_value(x)).collect(),
                    lo: 0.0,
                    hi: 1.0,
                    label: "segment (colours are arbitrary)".into(),
                },
                keypoints: Vec::new(),
            });
        }
        if ps.len() < 2 {
            continue;
        }
        let fig = Figure {
            title: ctx.title(spec, || {
                format!("{}: rotation groups (case {id})", ctx.title)
            }),
            caption: ctx.subtitle(spec, ctx.caption.clone()),
            panels: ps,
            camera: ctx.config.outputs.camera(&ctx.config.dataset),
            panel_size: (260, 360),
        };
        let stem = ctx.stem(spec, "clusters");
        let stem = stem.with_file_name(format!(
            "{}_{id}",
            stem.file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        ));
        save_figure_as(
            &fig,
            &ctx.render_options(),
            &stem,
            ctx.config.outputs.render_formats(spec),
        )?;
        made += 1;
    }
    if made == 0 {
        return Err(Error::invalid(
            "no saved cluster labels (meshes/<case>/<method>/clusters.csv)",
        ));
    }
    Ok(())
}

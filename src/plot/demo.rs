//! Sample figures for eyeballing the plotting layer: a line chart, a bar
//! chart and mesh figures from the synthetic FAUST-style set (and from
//! FAUST itself when `../shared/data/faust` is present).

use std::path::{Path, PathBuf};

use super::{
    save_bar_chart, save_figure, save_figure_as, save_figure_with, save_line_chart, save_table,
    BarChart, Camera, ColorMap, Coloring, Figure, Formats, LineChart, Panel, RenderOptions, Series,
    Table,
};
use crate::data::synthetic::FaustStyle;
use crate::ops::{farthest_point_sampling, FpsMetric};
use crate::{Mesh, Result};

/// Writes the sample figures into `dir` and returns the files written.
pub fn demo(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let mut push = |stem: PathBuf, exts: &[&str]| {
        for e in exts {
            out.push(PathBuf::from(format!("{}.{e}", stem.display())));
        }
    };

    // Cumulative error curves of three methods.
    let bounds: Vec<f64> = (0..=60).map(|i| i as f64 * 0.001).collect();
    let curve = |scale: f64| -> Vec<f64> {
        bounds
            .iter()
            .map(|&b| 1.0 - (-(b / scale).powf(1.6)).exp())
            .collect()
    };
    let line = LineChart {
        title: "Cumulative error".into(),
        caption: Some("synthetic FAUST-style set, 5 subjects × 8 poses (sample data)".into()),
        x_label: "error bound (unit-sphere units)".into(),
        y_label: "fraction of vertices within bound".into(),
        series: vec![
            Series {
                label: "BDT (ours)".into(),
                x: bounds.clone(),
                y: curve(0.008),
            },
            Series {
                label: "Deformation transfer".into(),
                x: bounds.clone(),
                y: curve(0.015),
            },
            Series {
                label: "LBS baseline".into(),
                x: bounds.clone(),
                y: curve(0.025),
            },
        ],
        y_range: Some((0.0, 1.0)),
        ..Default::default()
    };
    let stem = dir.join("line_cumulative");
    save_line_chart(&line, &stem)?;
    push(stem, &["png", "svg", "pdf"]);

    // Error vs number of key points (log y, markers).
    let ks: Vec<f64> = [5, 10, 15, 20, 30, 40, 60]
        .iter()
        .map(|&k| k as f64)
        .collect();
    let err = |a: f64, p: f64| ks.iter().map(|k| a * k.powf(-p)).collect::<Vec<f64>>();
    let keyed = LineChart {
        title: "Error vs number of key points".into(),
        caption: None,
        x_label: "key points".into(),
        y_label: "mean error (unit-sphere units)".into(),
        series: vec![
            Series {
                label: "automatic".into(),
                x: ks.clone(),
                y: err(0.2, 1.2),
            },
            Series {
                label: "random (mean of 10 seeds)".into(),
                x: ks.clone(),
                y: err(0.3, 0.9),
            },
            Series {
                label: "extremities".into(),
                x: ks.clone(),
                y: err(0.25, 1.0),
            },
        ],
        log_y: true,
        markers: true,
        floor: None,
        ..Default::default()
    };
    let stem = dir.join("line_keypoints");
    save_line_chart(&keyed, &stem)?;
    push(stem, &["png", "svg", "pdf"]);

    // Ablation bars with error bars.
    let bars = BarChart {
        title: "E_diff ablation".into(),
        caption: Some("mean ± std over 10 seeds (sample data)".into()),
        y_label: "mean error (unit-sphere units)".into(),
        categories: vec![
            "walk".into(),
            "squat".into(),
            "reach".into(),
            "kneel".into(),
        ],
        series: vec![
            ("with E_diff".into(), vec![0.011, 0.016, 0.013, 0.021]),
            ("without E_diff".into(), vec![0.017, 0.027, 0.019, 0.034]),
        ],
        errors: Some(vec![
            vec![0.002, 0.003, 0.002, 0.004],
            vec![0.003, 0.005, 0.003, 0.006],
        ]),
        log_y: false,
    };
    let stem = dir.join("bar_ablation");
    save_bar_chart(&bars, &stem)?;
    push(stem, &["png", "svg", "pdf"]);

    // Timings on a log axis.
    let timing = BarChart {
        title: "Timings".into(),
        caption: Some("per mesh, 2 cores (sample data)".into()),
        y_label: "time (s)".into(),
        categories: vec![
            "FAUST (6890 vertices)".into(),
            "TOSCA cat (27894 vertices)".into(),
            "TOSCA centaur (15768 vertices)".into(),
            "cactus (5261 vertices)".into(),
        ],
        series: vec![
            ("key point selection".into(), vec![0.8, 3.5, 2.0, 0.6]),
            ("weights / handle".into(), vec![0.05, 0.21, 0.12, 0.04]),
            ("LBS".into(), vec![0.0009, 0.004, 0.002, 0.0007]),
        ],
        errors: None,
        log_y: true,
    };
    let stem = dir.join("bar_timings_log");
    save_bar_chart(&timing, &stem)?;
    push(stem, &["png", "svg", "pdf"]);

    // The same numbers as a table.
    let table = Table {
        title: "Table 1: timings".into(),
        caption: Some("seconds per mesh (sample data)".into()),
        columns: vec![
            "data set".into(),
            "vertices".into(),
            "key points (s)".into(),
            "weights / handle (s)".into(),
            "LBS (ms)".into(),
        ],
        rows: vec![
            vec![
                "FAUST".into(),
                "6890".into(),
                "0.80".into(),
                "0.050".into(),
                "0.9".into(),
            ],
            vec![
                "TOSCA cat".into(),
                "27894".into(),
                "3.50".into(),
                "0.210".into(),
                "4.0".into(),
            ],
            vec![
                "cactus".into(),
                "5261".into(),
                "0.60".into(),
                "0.040".into(),
                "0.7".into(),
            ],
        ],
    };
    let stem = dir.join("table_timings");
    save_table(&table, &stem)?;
    push(stem, &["png", "svg", "pdf"]);

    // Eight series: colours plus dash patterns and markers.
    let many = LineChart {
        title: "Eight methods".into(),
        caption: Some("more than six series get dash patterns and markers".into()),
        x_label: "error bound (unit-sphere units)".into(),
        y_label: "fraction of vertices".into(),
        series: (0..8)
            .map(|i| Series {
                label: format!("method {}", i + 1),
                x: bounds.iter().step_by(5).copied().collect(),
                y: curve(0.006 + 0.003 * i as f64)
                    .into_iter()
                    .step_by(5)
                    .collect(),
            })
            .collect(),
        y_range: Some((0.0, 1.0)),
        ..Default::default()
    };
    let stem = dir.join("line_eight");
    save_line_chart(&many, &stem)?;
    push(stem, &["png", "svg", "pdf"]);

    // Synthetic mesh figure: three poses, error w.r.t. pose 0, 5 key points.
    let set = FaustStyle {
        subjects: 1,
        poses: 3,
        resolution: 1,
        ..Default::default()
    }
    .generate()?;
    let rest = &set.meshes[0][0];
    let keys = farthest_point_sampling(rest, 5, FpsMetric::Euclidean, 0)?;
    let fields: Vec<Vec<f64>> = (0..3)
        .map(|p| {
            set.meshes[0][p]
                .vertices()
                .iter()
                .zip(rest.vertices())
                .map(|(a, b)| (a - b).norm())
                .collect()
        })
        .collect();
    let hi = fields
        .iter()
        .flat_map(|f| f.iter().copied())
        .fold(0.0f64, f64::max)
        .max(1e-9);
    let panels: Vec<Panel> = (0..3)
        .map(|p| Panel {
            label: if p == 0 {
                "rest pose A".to_string()
            } else {
                format!("pose A′{p}")
            },
            mesh: set.meshes[0][p].clone(),
            coloring: Coloring::Scalar {
                values: fields[p].clone(),
                lo: 0.0,
                hi,
                label: "displacement (model units)".into(),
            },
            keypoints: keys.iter().enumerate().map(|(i, &v)| (v, i)).collect(),
        })
        .collect();
    let mut fig = Figure {
        title: "Synthetic FAUST-style subject".into(),
        caption: Some("colour: displacement from pose 0; spheres: 5 FPS key points".into()),
        panels,
        camera: Camera::SYNTHETIC,
        panel_size: (420, 620),
    };
    let stem = dir.join("figure_synthetic");
    save_figure_as(&fig, &RenderOptions::default(), &stem, Formats::CHARTS)?;
    push(stem, &["png", "svg", "pdf"]);
    // The same with the light-to-dark red map and one scale for all panels.
    fig.caption = Some("ColorMap::Reds, shared_scale: colour = displacement from pose 0".into());
    let opts = RenderOptions {
        colormap: ColorMap::Reds,
        shared_scale: true,
        ..Default::default()
    };
    let stem = dir.join("figure_synthetic_reds");
    save_figure_with(&fig, &opts, &stem)?;
    push(stem, &["png"]);

    // FAUST scan, if the shared data is present.
    if let Some(faust) = crate::data::shared_data_or_skip("faust", "plot::demo") {
        let path = faust.join("tr_reg_001.ply");
        if path.exists() {
            let mesh: Mesh = crate::mesh::io::read_mesh(&path)?;
            let keys = farthest_point_sampling(&mesh, 8, FpsMetric::Euclidean, 0)?;
            let kp: Vec<(usize, usize)> = keys.iter().enumerate().map(|(i, &v)| (v, i)).collect();
            let height: Vec<f64> = mesh.vertices().iter().map(|p| p.y).collect();
            let (lo, hi) = height
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
            let panels = vec![
                Panel {
                    label: "front (Camera::FAUST)".into(),
                    mesh: mesh.clone(),
                    coloring: Coloring::Plain,
                    keypoints: kp.clone(),
                },
                Panel {
                    label: "height".into(),
                    mesh: mesh.clone(),
                    coloring: Coloring::Scalar {
                        values: height,
                        lo,
                        hi,
                        label: "height y (m)".into(),
                    },
                    keypoints: kp,
                },
            ];
            let fig = Figure {
                title: "FAUST tr_reg_001".into(),
                caption: Some("8 FPS key points".into()),
                panels,
                camera: Camera::FAUST,
                panel_size: (420, 620),
            };
            let stem = dir.join("figure_faust");
            save_figure(&fig, &stem)?;
            push(stem, &["png"]);
        }
    }
    // The other shared data sets with their recommended cameras.
    let sets: [(&str, &str, &[&str], Camera); 3] = [
        (
            "tosca",
            "TOSCA (Camera::TOSCA)",
            &["cat0.off", "centaur0.off", "wolf0.off"],
            Camera::TOSCA,
        ),
        (
            "cactus",
            "Cactus (Camera::CACTUS)",
            &["cactus0.ply", "cactus5.ply", "cactus10.ply"],
            Camera::CACTUS,
        ),
        (
            "sumner/cat-lion",
            "Sumner cat and lion (Camera::SUMNER)",
            &["cat-reference.obj", "cat-03.obj", "lion-reference.obj"],
            Camera::SUMNER,
        ),
    ];
    for (sub, title, files, camera) in sets {
        let Some(folder) = crate::data::shared_data_or_skip(sub, "plot::demo") else {
            continue;
        };
        let mut panels = Vec::new();
        for f in files {
            let path = folder.join(f);
            if !path.exists() {
                continue;
            }
            let mesh = crate::mesh::io::read_mesh(&path)?;
            let keys = farthest_point_sampling(&mesh, 6, FpsMetric::Euclidean, 0)?;
            panels.push(Panel {
                label: f.to_string(),
                keypoints: keys.iter().enumerate().map(|(i, &v)| (v, i)).collect(),
                mesh,
                coloring: Coloring::Plain,
            });
        }
        if panels.is_empty() {
            continue;
        }
        let fig = Figure {
            title: title.into(),
            caption: Some("6 FPS key points each".into()),
            panels,
            camera,
            panel_size: (420, 420),
        };
        let stem = dir.join(format!("figure_{}", sub.replace('/', "_")));
        save_figure(&fig, &stem)?;
        push(stem, &["png"]);
    }
    Ok(out)
}

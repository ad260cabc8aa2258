//! Line charts, bar charts and tables: files written atomically as valid
//! PNG / SVG / PDF carrying the titles and legend labels; bad input is an
//! error naming the file and the series, never a panic or a partial file.

use std::path::{Path, PathBuf};

use deformlab::plot::{
    bar_chart_image, line_chart_image, save_bar_chart, save_line_chart, save_line_chart_as,
    save_table, series_style, BarChart, Formats, LineChart, Series, Table, CHART_SIZE,
};

/// Width and height from a PNG's IHDR chunk, after checking the signature.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(bytes.len() > 33, "{}: too short for a PNG", path.display());
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{}: not a PNG",
        path.display()
    );
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    (be(16), be(20))
}

fn svg_text(path: &Path) -> String {
    let s = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(s.contains("<svg"), "{}: no <svg> element", path.display());
    assert!(
        s.trim_end().ends_with("</svg>"),
        "{}: unterminated",
        path.display()
    );
    s
}

/// Checks a PDF file: the header, one page of `size` pixels at 96 per inch
/// and the bundled font embedded; returns its bytes as (lossy) text.
fn pdf_check(path: &Path, size: (u32, u32)) -> String {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(bytes.starts_with(b"%PDF-"), "{}: not a PDF", path.display());
    let text = String::from_utf8_lossy(&bytes).into_owned();
    assert_eq!(
        text.matches("/Type /Page\n").count()
            + text.matches("/Type /Page\r").count()
            + text.matches("/Type /Page ").count()
            + text.matches("/Type /Page/").count()
            + text.matches("/Type /Page>").count(),
        1,
        "{}: expected one page",
        path.display()
    );
    let pt = |px: u32| {
        let v = px as f64 * 0.75;
        if v.fract() == 0.0 {
            format!("{v:.0}")
        } else {
            format!("{v}")
        }
    };
    let media = format!("/MediaBox [0 0 {} {}]", pt(size.0), pt(size.1));
    assert!(text.contains(&media), "{}: no {media}", path.display());
    assert!(
        text.contains("DejaVuSans"),
        "{}: font not embedded",
        path.display()
    );
    text
}

/// Files in `dir` (names only, sorted).
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

fn three_series() -> LineChart {
    let x: Vec<f64> = (0..=20).map(|i| i as f64 * 0.005).collect();
    let s = |label: &str, k: f64| Series {
        label: label.into(),
        x: x.clone(),
        y: x.iter().map(|&b| 1.0 - (-b / k).exp()).collect(),
    };
    LineChart {
        title: "Cumulative error".into(),
        caption: Some("three methods".into()),
        x_label: "error bound (unit-sphere units)".into(),
        y_label: "fraction of vertices".into(),
        series: vec![s("alpha", 0.01), s("beta", 0.02), s("gamma", 0.04)],
        y_range: Some((0.0, 1.0)),
        ..Default::default()
    }
}

#[test]
fn line_chart_writes_png_and_svg() {
    let dir = tempfile::tempdir().unwrap();
    // Parent directories are created; a dot in the stem is kept.
    let stem = dir.path().join("plots/sub/fig14.v2");
    save_line_chart(&three_series(), &stem).unwrap();
    let sub = dir.path().join("plots/sub");
    let all = vec!["fig14.v2.pdf", "fig14.v2.png", "fig14.v2.svg"];
    assert_eq!(listing(&sub), all);
    assert_eq!(png_size(&sub.join("fig14.v2.png")), CHART_SIZE);
    pdf_check(&sub.join("fig14.v2.pdf"), CHART_SIZE);
    let svg = svg_text(&sub.join("fig14.v2.svg"));
    for text in [
        "Cumulative error",
        "three methods",
        "alpha",
        "beta",
        "gamma",
        "error bound (unit-sphere units)",
        "fraction of vertices",
    ] {
        assert!(svg.contains(text), "SVG lacks {text:?}");
    }
    // Overwriting (regenerating) leaves no temporary files behind.
    save_line_chart(&three_series(), &stem).unwrap();
    assert_eq!(listing(&sub), all);
}

#[test]
fn formats_choose_the_files() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("only");
    let pdf = Formats::from_names(&["pdf"]).unwrap();
    save_line_chart_as(&three_series(), &stem, pdf).unwrap();
    assert_eq!(listing(dir.path()), vec!["only.pdf"]);
    pdf_check(&dir.path().join("only.pdf"), CHART_SIZE);
    let both = Formats::from_names(&["png", "svg"]).unwrap();
    save_line_chart_as(&three_series(), &stem, both).unwrap();
    assert_eq!(
        listing(dir.path()),
        vec!["only.pdf", "only.png", "only.svg"]
    );
    assert!(Formats::from_names(&["jpeg"])
        .unwrap_err()
        .contains("\"jpeg\""));
    assert!(Formats::from_names::<&str>(&[]).is_err());
}

#[test]
fn a_chart_without_title_and_caption_has_no_header_text() {
    let dir = tempfile::tempdir().unwrap();
    let mut chart = three_series();
    chart.title.clear();
    chart.caption = None;
    let stem = dir.path().join("bare");
    save_line_chart(&chart, &stem).unwrap();
    let svg = svg_text(&dir.path().join("bare.svg"));
    assert!(!svg.contains("Cumulative error") && !svg.contains("three methods"));
    assert!(svg.contains("alpha") && svg.contains("fraction of vertices"));
    // The black title text is gone from the top centre of the image.
    let black_in_header = |img: &deformlab::plot::Image| {
        let mut n = 0;
        for y in 10..44 {
            for x in img.width * 2 / 5..img.width * 3 / 5 {
                n += usize::from(img.pixel(x, y).unwrap().iter().all(|&c| c < 60));
            }
        }
        n
    };
    assert!(black_in_header(&line_chart_image(&three_series()).unwrap()) > 100);
    assert_eq!(black_in_header(&line_chart_image(&chart).unwrap()), 0);
}

#[test]
fn log_chart_with_markers_and_many_series() {
    let dir = tempfile::tempdir().unwrap();
    let ks = vec![5.0, 10.0, 20.0, 40.0];
    let series: Vec<Series> = (0..9)
        .map(|i| Series {
            label: format!("method {i}"),
            x: ks.clone(),
            y: ks.iter().map(|k| (i + 1) as f64 * 1e-3 / k).collect(),
        })
        .collect();
    let chart = LineChart {
        title: "Error vs key points".into(),
        x_label: "key points".into(),
        y_label: "mean error".into(),
        series,
        log_y: true,
        markers: true,
        floor: None,
        ..Default::default()
    };
    let stem = dir.path().join("keys");
    save_line_chart(&chart, &stem).unwrap();
    assert_eq!(png_size(&dir.path().join("keys.png")), CHART_SIZE);
    let svg = svg_text(&dir.path().join("keys.svg"));
    for i in 0..9 {
        assert!(svg.contains(&format!("method {i}")));
    }
    // More than six series: (colour, dash) pairs differ.
    let a = series_style(0, 9);
    let g = series_style(8, 9);
    assert!((a.color, a.dash) != (g.color, g.dash));
}

fn has_color_near(img: &deformlab::plot::Image, rows: std::ops::Range<u32>, c: [u8; 3]) -> usize {
    let mut n = 0;
    for y in rows {
        for x in 0..img.width {
            let p = img.pixel(x, y).unwrap();
            let d: i32 = (0..3).map(|k| (p[k] as i32 - c[k] as i32).abs()).sum();
            if d < 30 {
                n += 1;
            }
        }
    }
    n
}

#[test]
fn lines_are_drawn_and_clipped_to_fixed_ranges() {
    // A horizontal line at y = 0.5 across the plot, and a steep line that
    // leaves the fixed y range through the top at x = 0.1.
    let chart = LineChart {
        title: "T".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        series: vec![
            Series {
                label: "flat".into(),
                x: vec![0.0, 1.0],
                y: vec![0.5, 0.5],
            },
            Series {
                label: "steep".into(),
                x: vec![0.0, 1.0],
                y: vec![0.0, 10.0],
            },
        ],
        x_range: Some((0.0, 1.0)),
        y_range: Some((0.0, 1.0)),
        ..Default::default()
    };
    let img = line_chart_image(&chart).unwrap();
    assert_eq!((img.width, img.height), CHART_SIZE);
    let flat = series_style(0, 2).color;
    let steep = series_style(1, 2).color;
    // Some row holds a long run of the flat line's colour (the plot is
    // ~1000 px wide).
    let best_row = (0..img.height)
        .map(|y| has_color_near(&img, y..y + 1, flat))
        .max()
        .unwrap();
    assert!(best_row > 800, "longest flat-line row: {best_row} px");
    // The steep line is visible, but nothing of it reaches the title band
    // (it would without clipping: unclipped it ends 9 plot heights above).
    assert!(has_color_near(&img, 0..img.height, steep) > 100);
    assert_eq!(has_color_near(&img, 0..60, steep), 0);
}

#[test]
fn bar_chart_with_error_bars_and_log_axis() {
    let dir = tempfile::tempdir().unwrap();
    let chart = BarChart {
        title: "Ablation".into(),
        caption: Some("mean ± std".into()),
        y_label: "error (unit-sphere units)".into(),
        categories: vec!["walk".into(), "squat".into(), "reach".into()],
        series: vec![
            ("with E_diff".into(), vec![0.01, 0.02, 0.015]),
            ("without".into(), vec![0.02, 0.03, 0.025]),
        ],
        errors: Some(vec![vec![0.002, 0.003, 0.001], vec![0.004, 0.002, 0.003]]),
        log_y: false,
    };
    let stem = dir.path().join("bars");
    save_bar_chart(&chart, &stem).unwrap();
    assert_eq!(png_size(&dir.path().join("bars.png")), CHART_SIZE);
    let svg = svg_text(&dir.path().join("bars.svg"));
    for t in [
        "Ablation",
        "with E_diff",
        "without",
        "walk",
        "squat",
        "reach",
    ] {
        assert!(svg.contains(t), "SVG lacks {t:?}");
    }
    // Bars are filled with the series colours.
    let img = bar_chart_image(&chart).unwrap();
    let c0 = series_style(0, 2).color;
    assert!(has_color_near(&img, 0..img.height, c0) > 2000);

    let log = BarChart {
        log_y: true,
        errors: None,
        series: vec![("time".into(), vec![0.001, 0.5, 20.0])],
        ..chart
    };
    save_bar_chart(&log, &dir.path().join("log")).unwrap();
    assert_eq!(png_size(&dir.path().join("log.png")), CHART_SIZE);
}

#[test]
fn table_figure() {
    let dir = tempfile::tempdir().unwrap();
    let t = Table {
        title: "Table 1".into(),
        caption: Some("seconds".into()),
        columns: vec!["data set".into(), "time (s)".into()],
        rows: vec![
            vec!["FAUST".into(), "0.80".into()],
            vec!["cactus".into(), "0.61".into()],
        ],
    };
    save_table(&t, &dir.path().join("t1")).unwrap();
    let (w, h) = png_size(&dir.path().join("t1.png"));
    assert!(w > 200 && h > 150, "{w}×{h}");
    let svg = svg_text(&dir.path().join("t1.svg"));
    for s in ["Table 1", "data set", "FAUST", "0.61"] {
        assert!(svg.contains(s), "SVG lacks {s:?}");
    }
    let ragged = Table {
        rows: vec![vec!["x".into()]],
        ..t
    };
    let e = save_table(&ragged, &dir.path().join("t2")).unwrap_err();
    assert!(e.to_string().contains("row 0"), "{e}");
}

/// Runs `f` expecting an error whose message contains every `needle`, and
/// checks no file was left in the directory.
fn expect_err(f: impl FnOnce(&Path) -> deformlab::Result<()>, needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let stem: PathBuf = dir.path().join("out");
    let err = f(&stem).expect_err("should fail").to_string();
    for n in needles {
        assert!(err.contains(n), "error {err:?} lacks {n:?}");
    }
    assert!(
        listing(dir.path()).is_empty(),
        "files left: {:?}",
        listing(dir.path())
    );
}

#[test]
fn line_chart_errors() {
    let base = three_series();
    let mut empty = base.clone();
    empty.series.clear();
    expect_err(|s| save_line_chart(&empty, s), &["out", "no series"]);

    let mut no_points = base.clone();
    no_points.series[1].x.clear();
    no_points.series[1].y.clear();
    expect_err(
        |s| save_line_chart(&no_points, s),
        &["out", "beta", "no points"],
    );

    let mut mismatch = base.clone();
    mismatch.series[2].y.pop();
    expect_err(
        |s| save_line_chart(&mismatch, s),
        &["out", "gamma", "21 x values but 20 y values"],
    );

    let mut nan = base.clone();
    nan.series[0].y[3] = f64::NAN;
    expect_err(
        |s| save_line_chart(&nan, s),
        &["alpha", "point 3", "not finite"],
    );

    let mut inf = base.clone();
    inf.series[1].x[0] = f64::INFINITY;
    expect_err(|s| save_line_chart(&inf, s), &["beta", "point 0"]);

    let mut log0 = base.clone();
    log0.log_y = true;
    log0.y_range = None;
    expect_err(|s| save_line_chart(&log0, s), &["alpha", "not positive"]);

    let mut bad_range = base.clone();
    bad_range.x_range = Some((1.0, 1.0));
    expect_err(|s| save_line_chart(&bad_range, s), &["x range"]);

    let mut bad_log_range = base;
    bad_log_range.series.iter_mut().for_each(|s| {
        s.y.iter_mut().for_each(|v| *v += 1.0);
    });
    bad_log_range.log_y = true;
    bad_log_range.y_range = Some((0.0, 2.0));
    expect_err(
        |s| save_line_chart(&bad_log_range, s),
        &["y range", "positive"],
    );
}

#[test]
fn bar_chart_errors() {
    let base = BarChart {
        title: "B".into(),
        y_label: "v".into(),
        categories: vec!["a".into(), "b".into()],
        series: vec![("s1".into(), vec![1.0, 2.0]), ("s2".into(), vec![1.5, 2.5])],
        ..Default::default()
    };
    let mut no_cat = base.clone();
    no_cat.categories.clear();
    expect_err(|s| save_bar_chart(&no_cat, s), &["no categories"]);

    let mut no_series = base.clone();
    no_series.series.clear();
    expect_err(|s| save_bar_chart(&no_series, s), &["no series"]);

    let mut short = base.clone();
    short.series[1].1.pop();
    expect_err(
        |s| save_bar_chart(&short, s),
        &["s2", "1 values for 2 categories"],
    );

    let mut nan = base.clone();
    nan.series[0].1[1] = f64::NAN;
    expect_err(|s| save_bar_chart(&nan, s), &["s1", "\"b\"", "not finite"]);

    let mut errs = base.clone();
    errs.errors = Some(vec![vec![0.1, 0.1]]);
    expect_err(
        |s| save_bar_chart(&errs, s),
        &["1 error bar rows for 2 series"],
    );

    let mut neg = base.clone();
    neg.errors = Some(vec![vec![0.1, -0.1], vec![0.1, 0.1]]);
    expect_err(|s| save_bar_chart(&neg, s), &["s1", "error bar"]);

    let mut log = base;
    log.series[1].1[0] = 0.0;
    log.log_y = true;
    expect_err(|s| save_bar_chart(&log, s), &["s2", "not positive"]);
}

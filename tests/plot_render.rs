//! The software mesh renderer: silhouette area against π r², depth test
//! (occlusion independent of face order), key point colours at their
//! projected pixels and hidden key points, camera conventions, the colour
//! map, figure output and error cases.

use std::path::Path;

use deformlab::mesh::primitives::{grid, icosphere};
use deformlab::plot::{
    colormap, figure_svg, keypoint_color, render_figure, render_mesh, save_figure, save_figure_as,
    Camera, ColorMap, Coloring, Figure, Formats, Image, Panel, RenderOptions, Up, View,
    DEFAULT_MAX_PER_ROW,
};
use deformlab::{Mesh, Point};

const WHITE: [u8; 3] = [255, 255, 255];

fn panel(mesh: Mesh) -> Panel {
    Panel {
        label: String::new(),
        mesh,
        coloring: Coloring::Plain,
        keypoints: Vec::new(),
    }
}

fn exact() -> RenderOptions {
    RenderOptions {
        supersample: 1,
        ..Default::default()
    }
}

fn covered(img: &Image) -> usize {
    img.rgb.chunks(3).filter(|p| p != &WHITE).count()
}

fn at(img: &Image, x: f64, y: f64) -> [u8; 3] {
    img.pixel(x.floor() as u32, y.floor() as u32)
        .expect("inside the image")
}

/// Colour up to brightness: `c / (r + g + b)`.
fn chroma(c: [u8; 3]) -> [f64; 3] {
    let s = (c[0] as f64 + c[1] as f64 + c[2] as f64).max(1.0);
    [c[0] as f64 / s, c[1] as f64 / s, c[2] as f64 / s]
}

fn chroma_dist(a: [u8; 3], b: [u8; 3]) -> f64 {
    let (a, b) = (chroma(a), chroma(b));
    (0..3).map(|k| (a[k] - b[k]).abs()).sum()
}

#[test]
fn sphere_silhouette_area_is_pi_r_squared() {
    let sphere = icosphere(4);
    for camera in [
        Camera::default(),
        Camera {
            yaw_deg: 37.0,
            pitch_deg: -50.0,
            up: Up::Y,
        },
        Camera {
            yaw_deg: 10.0,
            pitch_deg: 20.0,
            up: Up::Z,
        },
    ] {
        let view = View::fit(&sphere, camera, 300, 300, 0.1);
        let img = render_mesh(&panel(sphere.clone()), &view, 300, 300, &exact()).unwrap();
        let r = view.scale; // unit sphere
        let expected = std::f64::consts::PI * r * r;
        let ratio = covered(&img) as f64 / expected;
        // The inscribed polyhedron covers slightly less than the disc.
        assert!(
            (0.975..=1.005).contains(&ratio),
            "{camera:?}: {} px vs π r² = {expected:.0} (r = {r:.1} px), ratio {ratio:.4}",
            covered(&img)
        );
        // Centred with the margin: r ≈ 0.4 · 300.
        assert!((r - 120.0).abs() < 3.0, "r = {r}");
    }
}

/// Two unit squares facing +z, the front one at z = +0.5 coloured 1 (yellow
/// end of the colour map), the back one at z = −0.5 shifted by 0.5 in x and
/// coloured 0 (purple end); `front_first` orders the faces.
fn two_squares(front_first: bool) -> Panel {
    let mut v = Vec::new();
    for (dx, z) in [(0.0, 0.5), (0.5, -0.5)] {
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            v.push(Point::new(x + dx, y, z));
        }
    }
    let front = [[0, 1, 2], [0, 2, 3]];
    let back = [[4, 5, 6], [4, 6, 7]];
    let faces: Vec<[usize; 3]> = if front_first {
        front.iter().chain(back.iter()).copied().collect()
    } else {
        back.iter().chain(front.iter()).copied().collect()
    };
    Panel {
        label: String::new(),
        mesh: Mesh::new(v, faces).unwrap(),
        coloring: Coloring::Scalar {
            values: vec![1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            lo: 0.0,
            hi: 1.0,
            label: "v".into(),
        },
        keypoints: Vec::new(),
    }
}

fn is_yellow(c: [u8; 3]) -> bool {
    c[1] > 100 && c[0] > 100 && c[2] < 60
}

fn is_purple(c: [u8; 3]) -> bool {
    c[1] < 20 && c[2] > c[1] + 15
}

#[test]
fn depth_test_not_face_order_decides_visibility() {
    for front_first in [true, false] {
        let p = two_squares(front_first);
        // From the front (+z): the overlap shows the front square.
        let view = View::fit(&p.mesh, Camera::default(), 240, 160, 0.05);
        let img = render_mesh(&p, &view, 240, 160, &exact()).unwrap();
        let (x, y, _) = view.project(&Point::new(0.75, 0.5, 0.0));
        assert!(is_yellow(at(&img, x, y)), "{:?}", at(&img, x, y));
        // The back square is visible where nothing covers it.
        let (x, y, _) = view.project(&Point::new(1.25, 0.5, -0.5));
        assert!(is_purple(at(&img, x, y)), "{:?}", at(&img, x, y));
        // From behind (yaw 180) the other square is in front in the
        // overlap; both are seen from their back sides (two-sided shading).
        let back = Camera {
            yaw_deg: 180.0,
            ..Camera::default()
        };
        let view = View::fit(&p.mesh, back, 240, 160, 0.05);
        let img = render_mesh(&p, &view, 240, 160, &exact()).unwrap();
        let (x, y, _) = view.project(&Point::new(0.75, 0.5, 0.0));
        assert!(is_purple(at(&img, x, y)), "{:?}", at(&img, x, y));
        let (x, y, _) = view.project(&Point::new(0.25, 0.5, 0.5));
        assert!(is_yellow(at(&img, x, y)), "{:?}", at(&img, x, y));
    }
}

#[test]
fn keypoint_colour_appears_at_its_projection_in_every_view() {
    let g = grid(10, 10);
    let centre = 5 * 11 + 5;
    let opts = RenderOptions {
        keypoint_radius: 0.05,
        ..exact()
    };
    for (idx, yaw) in [(3usize, 0.0), (3, 35.0), (7, -20.0), (15, 10.0)] {
        let camera = Camera {
            yaw_deg: yaw,
            pitch_deg: 15.0,
            up: Up::Y,
        };
        let p = Panel {
            keypoints: vec![(centre, idx)],
            ..panel(g.clone())
        };
        let view = View::fit(&p.mesh, camera, 200, 200, 0.1);
        let img = render_mesh(&p, &view, 200, 200, &opts).unwrap();
        let (cx, cy, _) = view.project(&g.vertices()[centre]);
        // Radius 10 px; sample below right of the centre, away from the
        // highlight and the rim.
        let c = at(&img, cx + 4.0, cy + 4.0);
        let want = keypoint_color(idx);
        assert!(
            chroma_dist(c, want) < 0.06,
            "key point {idx}, yaw {yaw}: pixel {c:?} vs colour {want:?}"
        );
        // Far from the key point: the grey surface.
        let (sx, sy, _) = view.project(&g.vertices()[11 + 1]);
        let s = at(&img, sx, sy);
        assert!(chroma_dist(s, [200, 200, 206]) < 0.03, "surface {s:?}");
    }
}

#[test]
fn hidden_keypoints_are_not_drawn_as_visible() {
    let sphere = icosphere(3);
    let v = sphere.vertices();
    let back = (0..v.len())
        .min_by(|&a, &b| v[a].z.total_cmp(&v[b].z))
        .unwrap();
    let front = (0..v.len())
        .max_by(|&a, &b| v[a].z.total_cmp(&v[b].z))
        .unwrap();
    let view = View::fit(&sphere, Camera::default(), 200, 200, 0.1);
    let plain = render_mesh(&panel(sphere.clone()), &view, 200, 200, &exact()).unwrap();
    let with = |kps: Vec<(usize, usize)>, alpha: f64| {
        let opts = RenderOptions {
            hidden_keypoint_alpha: alpha,
            keypoint_radius: 0.04,
            ..exact()
        };
        let p = Panel {
            keypoints: kps,
            ..panel(sphere.clone())
        };
        render_mesh(&p, &view, 200, 200, &opts).unwrap()
    };
    // Fully suppressed: the image is exactly the one without key points.
    assert_eq!(with(vec![(back, 0)], 0.0), plain);
    // Dimmed: present, but the pixel stays much closer to the surface than
    // to the key point colour.
    let dim = with(vec![(back, 0)], 0.3);
    let (x, y, _) = view.project(&v[back]);
    let (d, s) = (at(&dim, x + 2.0, y + 2.0), at(&plain, x + 2.0, y + 2.0));
    assert_ne!(d, s);
    let red = keypoint_color(0);
    let l1 =
        |a: [u8; 3], b: [u8; 3]| -> i32 { (0..3).map(|k| (a[k] as i32 - b[k] as i32).abs()).sum() };
    assert!(l1(d, s) < l1(d, red), "dimmed {d:?}, surface {s:?}");
    // The front vertex's key point is drawn at full colour.
    let vis = with(vec![(front, 0)], 0.3);
    let (x, y, _) = view.project(&v[front]);
    assert!(chroma_dist(at(&vis, x + 2.0, y + 2.0), red) < 0.06);
}

#[test]
fn camera_conventions() {
    let sphere = icosphere(1);
    let c = Point::new(0.0, 0.0, 0.0);
    let px = Point::new(1.0, 0.0, 0.0);
    let py = Point::new(0.0, 1.0, 0.0);
    let pz = Point::new(0.0, 0.0, 1.0);
    let v = View::fit(&sphere, Camera::default(), 100, 100, 0.0);
    let (c0, x0, y0, z0) = (
        v.project(&c),
        v.project(&px),
        v.project(&py),
        v.project(&pz),
    );
    assert!(x0.0 > c0.0 + 40.0, "+x is to the right");
    assert!(y0.1 < c0.1 - 40.0, "+y is up (smaller row)");
    assert!(z0.2 > c0.2 + 0.9, "+z is towards the viewer");
    // Yaw 90: the model's front (+z) turns to the viewer's right.
    let v = View::fit(
        &sphere,
        Camera {
            yaw_deg: 90.0,
            ..Camera::default()
        },
        100,
        100,
        0.0,
    );
    assert!(v.project(&pz).0 > v.project(&c).0 + 40.0);
    // Pitch 30: the top comes towards the viewer (seen from above).
    let v = View::fit(
        &sphere,
        Camera {
            pitch_deg: 30.0,
            ..Camera::default()
        },
        100,
        100,
        0.0,
    );
    assert!(v.project(&py).2 > v.project(&c).2 + 0.4);
    // z up: +z is drawn up.
    let v = View::fit(
        &sphere,
        Camera {
            up: Up::Z,
            ..Camera::default()
        },
        100,
        100,
        0.0,
    );
    assert!(v.project(&pz).1 < v.project(&c).1 - 40.0);
}

#[test]
fn colour_map_endpoints_and_monotone_lightness() {
    assert_eq!(colormap(0.0), [68, 1, 84]);
    assert_eq!(colormap(1.0), [253, 231, 37]);
    assert_eq!(colormap(-3.0), colormap(0.0));
    assert_eq!(colormap(7.0), colormap(1.0));
    assert_eq!(colormap(f64::NAN), colormap(0.0));
    // Perceptual: relative luminance strictly increases along the map.
    let lum = |c: [u8; 3]| {
        let lin = |u: u8| {
            let s = u as f64 / 255.0;
            if s <= 0.04045 {
                s / 12.92
            } else {
                ((s + 0.055) / 1.055).powf(2.4)
            }
        };
        0.2126 * lin(c[0]) + 0.7152 * lin(c[1]) + 0.0722 * lin(c[2])
    };
    let mut prev = -1.0;
    for i in 0..=200 {
        let l = lum(colormap(i as f64 / 200.0));
        assert!(
            l > prev,
            "luminance not increasing at t = {}",
            i as f64 / 200.0
        );
        prev = l;
    }
    // The Reds map runs from near white to dark red, darkening throughout.
    assert_eq!(ColorMap::Reds.color(0.0), [255, 245, 240]);
    assert_eq!(ColorMap::Reds.color(1.0), [103, 0, 13]);
    let mut prev = 2.0;
    for i in 0..=200 {
        let l = lum(ColorMap::Reds.color(i as f64 / 200.0));
        assert!(l < prev, "Reds lightness not decreasing at {i}");
        prev = l;
    }
    assert_eq!(ColorMap::Viridis.color(0.3), colormap(0.3));
    // Key point colours are fixed per index and differ within the palette.
    assert_eq!(keypoint_color(4), keypoint_color(4));
    for i in 0..12 {
        for j in 0..i {
            assert_ne!(keypoint_color(i), keypoint_color(j));
        }
    }
}

fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n");
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

fn synthetic_figure() -> Figure {
    let set = deformlab::data::synthetic::FaustStyle {
        subjects: 1,
        poses: 3,
        resolution: 1,
        ..Default::default()
    }
    .generate()
    .unwrap();
    let rest = &set.meshes[0][0];
    let n = rest.n_vertices();
    let keys: Vec<(usize, usize)> = (0..5).map(|i| (i * n / 5, i)).collect();
    let panels = (0..3)
        .map(|p| {
            let m = &set.meshes[0][p];
            let values: Vec<f64> = m
                .vertices()
                .iter()
                .zip(rest.vertices())
                .map(|(a, b)| (a - b).norm())
                .collect();
            Panel {
                label: format!("pose {p}"),
                mesh: m.clone(),
                coloring: Coloring::Scalar {
                    values,
                    lo: 0.0,
                    hi: 0.5,
                    label: "displacement".into(),
                },
                keypoints: keys.clone(),
            }
        })
        .collect();
    Figure {
        title: "Synthetic".into(),
        caption: Some("three poses".into()),
        panels,
        camera: Camera::SYNTHETIC,
        panel_size: (200, 300),
    }
}

#[test]
fn figure_png_has_panels_and_colour_bar() {
    let fig = synthetic_figure();
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("figs/pose");
    save_figure(&fig, &stem).unwrap();
    let png = dir.path().join("figs/pose.png");
    let img = render_figure(&fig, &RenderOptions::default(), "test").unwrap();
    assert_eq!(png_size(&png), (img.width, img.height));
    assert!(
        img.width > 3 * 200 && img.height > 300,
        "{}×{}",
        img.width,
        img.height
    );
    // The colour bar right of the panels holds both ends of the map.
    let near = |a: [u8; 3], b: [u8; 3]| (0..3).all(|k| (a[k] as i32 - b[k] as i32).abs() <= 3);
    let mut ends = (false, false);
    for y in 0..img.height {
        for x in 600..img.width {
            let p = img.pixel(x, y).unwrap();
            ends.0 |= near(p, colormap(0.0));
            ends.1 |= near(p, colormap(1.0));
        }
    }
    assert!(ends.0 && ends.1, "colour bar ends missing: {ends:?}");
    // Every panel shows a body: many non-white pixels in each column.
    for i in 0..3 {
        let mut n = 0;
        for y in 0..img.height {
            for x in i * 200..(i + 1) * 200 {
                if img.pixel(x, y).unwrap() != WHITE {
                    n += 1;
                }
            }
        }
        assert!(n > 5000, "panel {i}: {n} drawn pixels");
    }
    // Default panel size when left at (0, 0).
    let mut d = fig.clone();
    d.panel_size = (0, 0);
    d.panels.truncate(1);
    let img = render_figure(&d, &RenderOptions::default(), "test").unwrap();
    assert!(img.width > deformlab::plot::DEFAULT_PANEL_SIZE.0);
}

fn expect_figure_err(fig: &Figure, needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let err = save_figure(fig, &dir.path().join("f")).expect_err("should fail");
    let msg = err.to_string();
    for n in needles {
        assert!(msg.contains(n), "error {msg:?} lacks {n:?}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn figure_errors() {
    let base = Figure {
        title: "t".into(),
        panels: vec![Panel {
            label: "p".into(),
            ..panel(grid(2, 2))
        }],
        panel_size: (100, 100),
        ..Default::default()
    };
    expect_figure_err(
        &Figure {
            panels: vec![],
            ..base.clone()
        },
        &["f.png", "no panels"],
    );
    let mut kp = base.clone();
    kp.panels[0].keypoints = vec![(3, 0), (9, 1)];
    expect_figure_err(&kp, &["f.png", "key point 1", "vertex 9", "9 vertices"]);
    let scalar = |values: Vec<f64>, lo: f64, hi: f64| {
        let mut f = base.clone();
        f.panels[0].coloring = Coloring::Scalar {
            values,
            lo,
            hi,
            label: "e".into(),
        };
        f
    };
    expect_figure_err(
        &scalar(vec![0.0; 8], 0.0, 1.0),
        &["panel 0", "8 values", "9 vertices"],
    );
    let mut nan = vec![0.0; 9];
    nan[4] = f64::NAN;
    expect_figure_err(&scalar(nan, 0.0, 1.0), &["vertex 4", "not finite"]);
    expect_figure_err(&scalar(vec![0.0; 9], 1.0, 1.0), &["colour range"]);
    expect_figure_err(
        &Figure {
            panel_size: (10, 300),
            ..base.clone()
        },
        &["panel size"],
    );
    expect_figure_err(
        &Figure {
            camera: Camera {
                yaw_deg: f64::NAN,
                ..Camera::default()
            },
            ..base
        },
        &["camera"],
    );
}

#[test]
fn faust_renders_upright_and_facing_the_camera() {
    let Some(dir) = deformlab::data::shared_data_or_skip("faust", "faust_renders_upright") else {
        return;
    };
    let mesh = deformlab::mesh::io::read_mesh(&dir.join("tr_reg_001.ply")).unwrap();
    let view = View::fit(&mesh, Camera::FAUST, 300, 450, 0.05);
    let img = render_mesh(&panel(mesh.clone()), &view, 300, 450, &exact()).unwrap();
    // Standing: the drawn silhouette is much taller than wide.
    let (mut x0, mut x1, mut y0, mut y1) = (u32::MAX, 0, u32::MAX, 0);
    for y in 0..img.height {
        for x in 0..img.width {
            if img.pixel(x, y).unwrap() != WHITE {
                x0 = x0.min(x);
                x1 = x1.max(x);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
    }
    let (w, h) = ((x1 - x0) as f64, (y1 - y0) as f64);
    assert!(h > 1.6 * w, "silhouette {w}×{h}");
    // The head (highest vertex) is drawn at the top.
    let v = mesh.vertices();
    let top = (0..v.len())
        .max_by(|&a, &b| v[a].y.total_cmp(&v[b].y))
        .unwrap();
    assert!(view.project(&v[top]).1 < y0 as f64 + 0.05 * h);
    // Facing the viewer: the feet reach further forward (towards the
    // viewer) of the shins than backwards (toes versus heels).
    let ymin = v.iter().map(|p| p.y).fold(f64::MAX, f64::min);
    let depth = |lo: f64, hi: f64| -> Vec<f64> {
        v.iter()
            .filter(|p| p.y >= ymin + lo && p.y < ymin + hi)
            .map(|p| view.project(p).2)
            .collect()
    };
    let shin = depth(0.12, 0.16);
    let shin = shin.iter().sum::<f64>() / shin.len() as f64;
    let feet = depth(0.0, 0.05);
    let fwd = feet.iter().fold(f64::MIN, |a, &b| a.max(b)) - shin;
    let bwd = shin - feet.iter().fold(f64::MAX, |a, &b| a.min(b));
    assert!(
        fwd > 1.5 * bwd,
        "toes {fwd:.3} m forward vs heels {bwd:.3} m back of the shins"
    );
}

#[test]
fn shared_scale_keeps_relative_sizes() {
    let small = icosphere(3);
    let big = small
        .map_vertices(|p| Point::from(p.coords * 2.0 + nalgebra::Vector3::new(5.0, 0.0, 0.0)))
        .unwrap();
    let fig = Figure {
        panels: vec![panel(small), panel(big)],
        panel_size: (200, 200),
        ..Default::default()
    };
    let areas = |shared: bool| -> (usize, usize) {
        let opts = RenderOptions {
            shared_scale: shared,
            ..exact()
        };
        let img = render_figure(&fig, &opts, "test").unwrap();
        let count = |x0: u32| {
            let mut n = 0;
            for y in 0..img.height {
                for x in x0..x0 + 200 {
                    if img.pixel(x, y).unwrap() != WHITE {
                        n += 1;
                    }
                }
            }
            n
        };
        (count(0), count(200))
    };
    // Each fitted on its own: equal discs.
    let (a, b) = areas(false);
    assert!((a as f64 / b as f64 - 1.0).abs() < 0.02, "{a} vs {b}");
    // One scale: the sphere of twice the radius covers four times the area.
    let (a, b) = areas(true);
    assert!((b as f64 / a as f64 - 4.0).abs() < 0.15, "{a} vs {b}");
}

/// `n` labelled sphere panels of 100 × 120 pixels.
fn spheres(n: usize) -> Figure {
    Figure {
        title: "wrapped".into(),
        panels: (0..n)
            .map(|i| Panel {
                label: format!("p{i}"),
                ..panel(icosphere(2))
            })
            .collect(),
        panel_size: (100, 120),
        ..Default::default()
    }
}

/// Rows of panels: the vertical runs of image rows with drawn pixels in
/// the first panel's column (below the header).
fn panel_rows(img: &Image, header: u32) -> usize {
    let mut runs = 0;
    let mut inside = false;
    for y in header..img.height {
        let drawn = (0..100).any(|x| img.pixel(x, y).unwrap() != WHITE);
        if drawn && !inside {
            runs += 1;
        }
        inside = drawn;
    }
    runs
}

#[test]
fn render_grids_wrap_after_max_per_row_panels() {
    // Twelve panels: the default wraps them into two rows of six.
    let fig = spheres(12);
    let one_row = RenderOptions {
        max_per_row: 0,
        ..exact()
    };
    let wide = render_figure(&fig, &one_row, "test").unwrap();
    let wrapped = render_figure(&fig, &exact(), "test").unwrap();
    assert_eq!(DEFAULT_MAX_PER_ROW, 6);
    assert!(wide.width >= 1200, "{}", wide.width);
    assert!(
        wrapped.width <= 6 * 100 + 40,
        "{}×{}",
        wrapped.width,
        wrapped.height
    );
    assert!(wrapped.height > wide.height + 120);
    // Five a row: three rows (5 + 5 + 2), the labels of the last row below
    // its panels; the last row's third slot is empty.
    let five = RenderOptions {
        max_per_row: 5,
        ..exact()
    };
    let img = render_figure(&fig, &five, "test").unwrap();
    assert!(img.width <= 5 * 100 + 40, "{}", img.width);
    // Panels, then their labels: two runs per row in the first column.
    assert_eq!(panel_rows(&img, 60), 6);
    let last_row_top = img.height - (120 + 48) + 10;
    let drawn = |x0: u32| {
        (last_row_top..last_row_top + 100)
            .flat_map(|y| (x0..x0 + 100).map(move |x| (x, y)))
            .filter(|&(x, y)| img.pixel(x, y).unwrap() != WHITE)
            .count()
    };
    assert!(drawn(100) > 1000, "second panel of the last row missing");
    assert_eq!(drawn(200), 0, "a third panel in the last row");
}

#[test]
fn figures_as_svg_and_pdf() {
    let fig = synthetic_figure();
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("fig");
    let all = Formats::from_names(&["png", "svg", "pdf"]).unwrap();
    save_figure_as(&fig, &RenderOptions::default(), &stem, all).unwrap();
    let png = render_figure(&fig, &RenderOptions::default(), "test").unwrap();
    let svg = std::fs::read_to_string(dir.path().join("fig.svg")).unwrap();
    // The raster under vector text: the labels are SVG text elements.
    assert!(svg.contains("data:image/png;base64,"));
    let texts: Vec<String> = svg
        .split("<text")
        .skip(1)
        .map(|t| {
            let inner = &t[t.find('>').unwrap() + 1..];
            inner[..inner.find("</text>").unwrap()].trim().to_string()
        })
        .collect();
    for t in ["Synthetic", "three poses", "pose 2", "displacement"] {
        assert!(
            texts.iter().any(|x| x == t),
            "no text element {t:?}: {texts:?}"
        );
    }
    assert!(svg.contains(&format!(
        "width=\"{}\" height=\"{}\"",
        png.width, png.height
    )));
    let pdf = std::fs::read(dir.path().join("fig.pdf")).unwrap();
    assert!(pdf.starts_with(b"%PDF-"));
    let text = String::from_utf8_lossy(&pdf);
    assert!(text.contains("/Subtype /Image"), "no raster in the PDF");
    assert!(text.contains("DejaVuSans"), "no embedded font");
    // No title, no caption: neither text remains.
    let bare = Figure {
        title: String::new(),
        caption: None,
        ..fig.clone()
    };
    let svg = figure_svg(&bare, &RenderOptions::default(), "test").unwrap();
    assert!(!svg.contains("Synthetic") && !svg.contains("three poses"));
    assert!(svg.contains("pose 2"));
    // PNG only by default.
    let only = dir.path().join("only");
    save_figure(&fig, &only).unwrap();
    assert!(dir.path().join("only.png").is_file());
    assert!(!dir.path().join("only.svg").exists() && !dir.path().join("only.pdf").exists());
}

//! `deformlab report`: one self-contained HTML page of results folders.
//! Checked as a file (everything inlined, nothing fetched, text escaped,
//! the same bytes twice, every figure and case row in it, bad input refused
//! by name) and in a real headless Chromium (the page loads with no error,
//! its viewer draws the meshes, and a screenshot shows the table and a
//! coloured mesh).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{cli_err, csv_rows, ok, run, tiny_bdt, tmp};

/// A small BDT experiment with its floor, figures and saved meshes, run
/// into `root`; returns its results folder.
fn experiment(root: &Path) -> PathBuf {
    let mut config = format!(
        "description = \"a <b>bold</b> & 'quoted' description\"\n{}",
        tiny_bdt("rep", "[1, 2]", true)
    );
    config.push_str(
        "label = \"identity (B unchanged)\"\n\
         [outputs]\nrender_cases = 1\nrender_poses = 1\n\
         [[outputs.plots]]\nkind = \"bars\"\nmetrics = [\"err_mean_unit\"]\n\
         [[outputs.plots]]\nkind = \"cumulative\"\n\
         [[outputs.plots]]\nkind = \"panels\"\n",
    );
    common::run_config(root, "rep", &config)
}

/// `deformlab report root --out out`, expected to write the page and exit
/// with 1 (warnings); returns its stderr.
fn report_with_warnings(root: &Path, out: &Path) -> String {
    let o = run(&[
        "report",
        root.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(out.is_file(), "no page written: {err}");
    err
}

fn report(root: &Path, out: &Path) -> String {
    ok(&[
        "report",
        root.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    std::fs::read_to_string(out).unwrap()
}

#[test]
fn a_report_is_one_page_with_everything_inlined_and_the_same_bytes_twice() {
    let t = tmp();
    let dir = experiment(t.path());
    let root = dir.parent().unwrap();
    let a = report(root, &t.path().join("a.html"));
    let b = report(root, &t.path().join("b.html"));
    assert!(a == b, "two reports of the same folders differ");

    // Nothing is fetched: no external script, style, image or frame.
    for needle in ["src=\"http", "href=\"http", "<link", "@import", "url(http"] {
        assert!(!a.contains(needle), "the page loads {needle}…");
    }
    // The description is text, not markup.
    assert!(a.contains("a &lt;b&gt;bold&lt;/b&gt; &amp; &#39;quoted&#39; description"));
    assert!(!a.contains("<b>bold</b>"));

    // The index links the experiment; its summary table marks the floor.
    assert!(a.contains("<a href=\"#exp-rep\">rep</a>"));
    assert!(a.contains("<section class=\"experiment\" id=\"exp-rep\">"));
    assert!(a.contains("<tr class=\"floor\"><td title=\"identity\">identity (B unchanged) <span class=\"tag\">floor</span>"));
    for metric in ["err_mean_unit", "err_mean_unit_rigid", "err_mean_area"] {
        assert!(a.contains(&format!(">{metric}</th>")), "no {metric} column");
    }

    // Every PNG figure of plots/ is inlined, once.
    let pngs = std::fs::read_dir(dir.join("plots"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".png")
        })
        .count();
    assert!(pngs >= 3, "the run made {pngs} PNG figures");
    assert_eq!(a.matches("<figure><img").count(), pngs);
    assert_eq!(a.matches("src=\"data:image/png;base64,").count(), pngs);

    // Every case row is in the sortable case table.
    let rows = csv_rows(&dir.join("cases.csv"));
    let table = &a[a.find("<table class=\"cases sortable\">").unwrap()..];
    let table = &table[..table.find("</table>").unwrap()];
    assert_eq!(table.matches("<tr").count(), rows.len() + 1);

    // The meshes of the first case: B, the truth, then each method's result.
    assert!(a.contains("<canvas id=\"view-0\" class=\"mesh\""));
    let data = &a[a.find("id=\"view-0-data\">").unwrap() + 17..];
    let data: serde_json::Value =
        serde_json::from_str(&data[..data.find("</script>").unwrap()]).unwrap();
    let labels: Vec<&str> = data["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["label"].as_str().unwrap())
        .collect();
    assert_eq!(
        labels,
        [
            "B (target, undeformed)",
            "B′ ground truth (pose 1)",
            "identity (B unchanged) (floor)",
            "bdt"
        ]
    );
    // Positions, triangles and colours decode to the mesh's sizes.
    use base64::Engine;
    let b64 = |v: &serde_json::Value| {
        base64::engine::general_purpose::STANDARD
            .decode(v.as_str().unwrap())
            .unwrap()
    };
    let m = &data["meshes"][3];
    let (pos, tri, rgb) = (b64(&m["pos"]), b64(&m["tri"]), b64(&m["rgb"]));
    let n = pos.len() / 12;
    assert!(n > 100);
    assert_eq!(rgb.len(), 3 * n);
    assert_eq!(tri.len() % 12, 0);
    assert!(tri
        .chunks(4)
        .all(|c| (u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as usize) < n));
    // The first mesh shown is the first method's result (not the floor's).
    assert_eq!(data["first"], 3);
}

#[test]
fn bad_roots_and_outputs_are_refused_by_name() {
    let t = tmp();
    let missing = t.path().join("nowhere");
    cli_err(&["report", missing.to_str().unwrap()], &["nowhere"]);
    let empty = t.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    cli_err(
        &["report", empty.to_str().unwrap()],
        &["empty", "no results folders"],
    );
    let dir = experiment(t.path());
    let root = dir.parent().unwrap();
    // --out naming a folder, or a file in a folder that does not exist.
    cli_err(
        &[
            "report",
            root.to_str().unwrap(),
            "--out",
            root.to_str().unwrap(),
        ],
        &["not a regular file"],
    );
    let deep = t.path().join("no/such/dir/r.html");
    cli_err(
        &[
            "report",
            root.to_str().unwrap(),
            "--out",
            deep.to_str().unwrap(),
        ],
        &["does not exist"],
    );
    // A results folder linked into the root is skipped with a warning (exit
    // 1), and the report of the rest is still written.
    #[cfg(unix)]
    {
        let other = t.path().join("other");
        std::fs::create_dir(&other).unwrap();
        std::os::unix::fs::symlink(&dir, other.join("linked")).unwrap();
        common::copy_dir(&dir, &other.join("real"));
        let out = t.path().join("o.html");
        let err = report_with_warnings(&other, &out);
        assert!(
            err.contains("linked") && err.contains("symbolic link"),
            "{err}"
        );
        let html = std::fs::read_to_string(&out).unwrap();
        assert!(html.contains("id=\"exp-real\"") && !html.contains("id=\"exp-linked\""));
    }
    // A malformed cases.csv: that experiment is reported as unreadable, by
    // name, the page is still written, and the command exits 1.
    let broken = t.path().join("broken");
    common::copy_dir(&dir, &broken.join("bad"));
    std::fs::write(broken.join("bad/cases.csv"), "case,method\n1,2,3\n").unwrap();
    let out = t.path().join("b.html");
    let err = report_with_warnings(&broken, &out);
    assert!(err.contains("cases.csv"), "{err}");
    assert!(std::fs::read_to_string(&out)
        .unwrap()
        .contains("Could not be read"));
}

/// Chromium: `DEFORMLAB_CHROMIUM`, else the system's. `None` outside CI
/// when there is none (the test then says it skips); in CI (`CI` set) its
/// absence fails the test, since `.ci/run` installs it.
fn chromium() -> Option<PathBuf> {
    let candidates = std::env::var_os("DEFORMLAB_CHROMIUM")
        .map(PathBuf::from)
        .into_iter()
        .chain(
            ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
                .iter()
                .map(PathBuf::from),
        );
    for c in candidates {
        if c.is_file() {
            return Some(c);
        }
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but no Chromium was found (.ci/run installs Debian's chromium; \
         or set DEFORMLAB_CHROMIUM)"
    );
    None
}

fn headless(chromium: &Path, profile: &Path, extra: &[&str], page: &Path) -> std::process::Output {
    let url = format!("file://{}", page.display());
    Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--enable-unsafe-swiftshader",
            "--use-angle=swiftshader",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=15000",
            "--window-size=1400,1300",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(url)
        .output()
        .expect("start chromium")
}

#[test]
fn the_report_opens_in_headless_chromium_with_no_error_and_shows_table_and_mesh() {
    let Some(chromium) = chromium() else {
        eprintln!("SKIP: no Chromium (/usr/bin/chromium; set DEFORMLAB_CHROMIUM)");
        return;
    };
    let t = tmp();
    let dir = experiment(t.path());
    // One results folder: its summary and viewer are at the top of the page.
    let page = t.path().join("report.html");
    report(&dir, &page);

    // The DOM after the scripts ran: no error, the viewer drew a mesh.
    let o = headless(&chromium, &t.path().join("p1"), &["--dump-dom"], &page);
    let dom = String::from_utf8_lossy(&o.stdout);
    let log = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "chromium failed: {log}");
    assert!(
        dom.contains("data-ready=\"1\""),
        "the page's script did not finish: {log}"
    );
    assert!(
        !dom.contains("data-errors="),
        "the page raised errors: {log}"
    );
    assert!(
        dom.contains("data-viewers-drawn=\"1\""),
        "no viewer drew: {log}"
    );
    let mode = if dom.contains("data-drawn=\"webgl\"") {
        "webgl"
    } else {
        assert!(
            dom.contains("data-drawn=\"2d\""),
            "the canvas was not drawn"
        );
        "2d"
    };
    // Console errors and uncaught exceptions are logged on stderr.
    for line in log.lines() {
        let l = line.to_ascii_lowercase();
        assert!(
            !(l.contains("error:console") || (l.contains(":console") && l.contains("uncaught"))),
            "console error: {line}"
        );
    }

    // A screenshot: the summary table and a mesh coloured by its error.
    let shot = t.path().join("shot.png");
    let o = headless(
        &chromium,
        &t.path().join("p2"),
        &[&format!("--screenshot={}", shot.display())],
        &page,
    );
    assert!(
        o.status.success() && shot.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&shot).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let pixels: Vec<&[u8]> = buf[..info.buffer_size()].chunks(channels).collect();
    // The viridis colours of the mesh are saturated; the tables are grey,
    // black and pale blue.
    let saturated = pixels
        .iter()
        .filter(|p| {
            let (hi, lo) = (p[..3].iter().max().unwrap(), p[..3].iter().min().unwrap());
            hi - lo > 60
        })
        .count();
    // Dark text of the tables.
    let dark = pixels
        .iter()
        .filter(|p| p[..3].iter().all(|&c| c < 90))
        .count();
    if let Ok(keep) = std::env::var("DEFORMLAB_KEEP_SCREENSHOT") {
        std::fs::copy(&shot, keep).unwrap();
    }
    eprintln!(
        "report screenshot ({mode}): {}×{}, {saturated} saturated (mesh) pixels, {dark} dark (text) pixels",
        info.width, info.height
    );
    assert!(
        saturated > 8000,
        "no coloured mesh in the screenshot ({saturated} pixels)"
    );
    assert!(
        dark > 3000,
        "no table text in the screenshot ({dark} pixels)"
    );
}

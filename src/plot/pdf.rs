//! PDF output: every PDF is converted from the figure's SVG by `usvg` +
//! `svg2pdf` (pure Rust), with the bundled DejaVu Sans as the only font
//! (the SVGs name the family `sans-serif`), so the text stays text
//! (embedded, subset, selectable) and no system font is consulted.
//!
//! One SVG pixel is one CSS pixel (1/96 in): a 1200 × 800 chart is a
//! 900 × 600 pt page (12.5 × 8.3 in), to be scaled in the document.

use std::sync::{Arc, OnceLock};

use crate::{Error, Result};

/// The family name of the bundled font in the font database.
const DEJAVU: &str = "DejaVu Sans";

/// A font database holding only the bundled DejaVu Sans (regular, bold),
/// which also serves every generic family.
fn fonts() -> Arc<usvg::fontdb::Database> {
    static DB: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_data(dejavu::sans::regular().to_vec());
        db.load_font_data(dejavu::sans::bold().to_vec());
        db.set_sans_serif_family(DEJAVU);
        db.set_serif_family(DEJAVU);
        db.set_monospace_family(DEJAVU);
        db.set_cursive_family(DEJAVU);
        db.set_fantasy_family(DEJAVU);
        Arc::new(db)
    })
    .clone()
}

/// The PDF (one page, the SVG's size at 96 px per inch) of an SVG
/// document; `name` names the output in errors.
pub fn svg_to_pdf(svg: &str, name: &str) -> Result<Vec<u8>> {
    let opts = usvg::Options {
        font_family: DEJAVU.to_string(),
        fontdb: fonts(),
        ..Default::default()
    };
    let tree = usvg::Tree::from_str(svg, &opts)
        .map_err(|e| Error::invalid(format!("{name}: the SVG did not parse for PDF: {e}")))?;
    let pdf = svg2pdf::to_pdf(
        &tree,
        svg2pdf::ConversionOptions::default(),
        svg2pdf::PageOptions { dpi: 96.0 },
    )
    .map_err(|e| Error::invalid(format!("{name}: PDF conversion failed: {e}")))?;
    canonical(&pdf).map_err(|why| {
        Error::invalid(format!(
            "{name}: the PDF written by svg2pdf has an unexpected structure ({why})"
        ))
    })
}

/// The same PDF with its objects in a canonical order, so one figure gives
/// one byte sequence. `svg2pdf` keeps resources and fonts in hash maps: a
/// resource dictionary lists its entries, and the objects of each font are
/// numbered and written, in an order that changes from process to process.
/// Here every run of `/Name N 0 R` lines of one dictionary is sorted, the
/// objects are renumbered in the order they are reached from the trailer
/// (breadth first, references in text order) and written in that order,
/// and the cross-reference table is rebuilt. Stream data is copied as is.
///
/// It reads the layout `pdf-writer` writes: a classic cross-reference
/// table of one section, `N 0 obj` … `endobj` objects, dictionaries one
/// entry per line; anything else is an error (the caller names the file).
fn canonical(pdf: &[u8]) -> std::result::Result<Vec<u8>, String> {
    let find = |hay: &[u8], needle: &[u8], from: usize| -> Option<usize> {
        hay.get(from..)?
            .windows(needle.len())
            .position(|w| w == needle)
            .map(|i| i + from)
    };
    let tail_from = pdf.len().saturating_sub(64);
    let sx_at = find(pdf, b"startxref", tail_from).ok_or("no startxref")?;
    let sx: usize = std::str::from_utf8(&pdf[sx_at + 9..])
        .ok()
        .and_then(|t| t.split_whitespace().next()?.parse().ok())
        .ok_or("unreadable startxref")?;
    let xref = pdf.get(sx..sx_at).ok_or("startxref out of range")?;
    let xref = std::str::from_utf8(xref).map_err(|_| "binary cross-reference table")?;
    let mut lines = xref.lines();
    if lines.next().map(str::trim) != Some("xref") {
        return Err("no xref table at startxref".into());
    }
    let (first, count) = lines
        .next()
        .and_then(|l| {
            let mut w = l.split_whitespace();
            Some((
                w.next()?.parse::<usize>().ok()?,
                w.next()?.parse::<usize>().ok()?,
            ))
        })
        .ok_or("unreadable xref section header")?;
    let mut offsets: Vec<(usize, usize)> = Vec::new(); // (offset, number)
    for i in 0..count {
        let l = lines.next().ok_or("short xref table")?;
        let w: Vec<&str> = l.split_whitespace().collect();
        if w.len() == 3 && w[2] == "n" {
            let off = w[0].parse().map_err(|_| "unreadable xref entry")?;
            offsets.push((off, first + i));
        }
    }
    if lines.next().map(str::trim) != Some("trailer") {
        return Err("one xref section expected".into());
    }
    let trailer: Vec<u8> = lines.collect::<Vec<_>>().join("\n").into_bytes();
    offsets.sort_unstable();
    let head_end = offsets.first().map_or(sx, |&(o, _)| o);
    // Each object: its dictionary text (canonical) and its stream bytes.
    let mut objects: std::collections::BTreeMap<usize, (Vec<u8>, &[u8])> = Default::default();
    for (k, &(off, num)) in offsets.iter().enumerate() {
        let end = offsets.get(k + 1).map_or(sx, |&(o, _)| o);
        let bytes = pdf.get(off..end).ok_or("object out of range")?;
        let (text, stream) = match find(bytes, b">>\nstream\n", 0) {
            Some(i) => bytes.split_at(i + 3),
            None => (bytes, &[][..]),
        };
        objects.insert(num, (sort_reference_runs(text), stream));
    }
    // New numbers: breadth first from the trailer's references.
    let mut order: Vec<usize> = Vec::new();
    let mut new_num: std::collections::BTreeMap<usize, usize> = Default::default();
    let mut queue: std::collections::VecDeque<usize> = references(&trailer).into();
    while let Some(n) = queue.pop_front() {
        if new_num.contains_key(&n) || !objects.contains_key(&n) {
            continue;
        }
        new_num.insert(n, order.len() + 1);
        order.push(n);
        // Skip the object's own `N 0 obj` line.
        let text = &objects[&n].0;
        let body = text
            .iter()
            .position(|&c| c == b'\n')
            .map_or(&text[..], |i| &text[i..]);
        queue.extend(references(body));
    }
    for &n in objects.keys() {
        if let std::collections::btree_map::Entry::Vacant(e) = new_num.entry(n) {
            e.insert(order.len() + 1);
            order.push(n);
        }
    }
    let mut out = pdf[..head_end].to_vec();
    let mut xref_entries = Vec::with_capacity(order.len());
    for n in &order {
        let (text, stream) = &objects[n];
        xref_entries.push(out.len());
        let body = text
            .iter()
            .position(|&c| c == b'\n')
            .map_or(&text[..], |i| &text[i..]);
        out.extend_from_slice(format!("{} 0 obj", new_num[n]).as_bytes());
        out.extend(renumber(body, &new_num));
        out.extend_from_slice(stream);
    }
    let start = out.len();
    out.extend_from_slice(
        format!("xref\n0 {}\n0000000000 65535 f\r\n", order.len() + 1).as_bytes(),
    );
    for off in xref_entries {
        out.extend_from_slice(format!("{off:010} 00000 n\r\n").as_bytes());
    }
    out.extend_from_slice(b"trailer\n");
    let trailer = renumber(&trailer, &new_num);
    let trailer = String::from_utf8_lossy(&trailer).into_owned();
    out.extend_from_slice(trailer.trim_end().as_bytes());
    out.push(b'\n');
    out.extend_from_slice(format!("startxref\n{start}\n%%EOF").as_bytes());
    Ok(out)
}

/// Whether a line is one `/Name N 0 R` dictionary entry.
fn is_reference_entry(line: &[u8]) -> bool {
    let t = line.trim_ascii();
    let Some(rest) = t.strip_prefix(b"/") else {
        return false;
    };
    let parts: Vec<&[u8]> = rest.split(|&c| c == b' ').collect();
    parts.len() == 4
        && !parts[0].is_empty()
        && parts[1].iter().all(u8::is_ascii_digit)
        && !parts[1].is_empty()
        && parts[2] == b"0"
        && parts[3] == b"R"
}

/// Sorts every run of consecutive `/Name N 0 R` lines of equal indentation
/// (the entries of one dictionary; their order has no meaning).
fn sort_reference_runs(text: &[u8]) -> Vec<u8> {
    let lines: Vec<&[u8]> = text.split(|&c| c == b'\n').collect();
    let indent = |l: &[u8]| l.iter().take_while(|&&c| c == b' ').count();
    let mut out: Vec<&[u8]> = Vec::with_capacity(lines.len());
    let mut i = 0;
    while i < lines.len() {
        if is_reference_entry(lines[i]) {
            let mut j = i + 1;
            while j < lines.len()
                && is_reference_entry(lines[j])
                && indent(lines[j]) == indent(lines[i])
            {
                j += 1;
            }
            let mut run = lines[i..j].to_vec();
            run.sort_unstable();
            out.extend(run);
            i = j;
        } else {
            out.push(lines[i]);
            i += 1;
        }
    }
    out.join(&b'\n')
}

/// The object numbers of the `N 0 R` references in a text, in order.
fn references(text: &[u8]) -> Vec<usize> {
    let mut out = Vec::new();
    scan_references(text, |n| {
        out.push(n);
        None
    });
    out
}

/// The text with every `N 0 R` reference renumbered.
fn renumber(text: &[u8], map: &std::collections::BTreeMap<usize, usize>) -> Vec<u8> {
    scan_references(text, |n| map.get(&n).copied())
}

/// Walks the `N 0 R` references of `text`, calling `f` on each number;
/// returns the text with each reference whose `f` gave a number replaced.
fn scan_references(text: &[u8], mut f: impl FnMut(usize) -> Option<usize>) -> Vec<u8> {
    let mut out = Vec::with_capacity(text.len());
    let mut i = 0;
    while i < text.len() {
        let starts = text[i].is_ascii_digit() && (i == 0 || !text[i - 1].is_ascii_alphanumeric());
        if starts {
            let j = i + text[i..].iter().take_while(|c| c.is_ascii_digit()).count();
            if text[j..].starts_with(b" 0 R")
                && text.get(j + 4).is_none_or(|c| !c.is_ascii_alphanumeric())
            {
                let n: Option<usize> = std::str::from_utf8(&text[i..j])
                    .ok()
                    .and_then(|s| s.parse().ok());
                match n.and_then(&mut f) {
                    Some(m) => out.extend_from_slice(m.to_string().as_bytes()),
                    None => out.extend_from_slice(&text[i..j]),
                }
                out.extend_from_slice(b" 0 R");
                i = j + 4;
                continue;
            }
            out.extend_from_slice(&text[i..j]);
            i = j;
            continue;
        }
        out.push(text[i]);
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_converts_with_the_bundled_font() {
        let svg = r#"<svg width="200" height="100" viewBox="0 0 200 100" xmlns="http://www.w3.org/2000/svg">
<rect x="0" y="0" width="200" height="100" fill="white"/>
<text x="10" y="50" font-family="sans-serif" font-size="20">B′ √area</text>
<text x="10" y="80" font-family="sans-serif" font-weight="bold" font-size="16">bold</text>
</svg>"#;
        let pdf = svg_to_pdf(svg, "t.pdf").unwrap();
        assert!(pdf.starts_with(b"%PDF-"));
        let text = String::from_utf8_lossy(&pdf);
        assert!(text.contains("/Type /Page"), "no page");
        assert!(text.contains("DejaVu"), "font not embedded");
        // 200 × 100 px at 96 px per inch: 150 × 75 pt.
        assert!(text.contains("/MediaBox [0 0 150 75]"), "{text:.400}");
    }

    /// svg2pdf writes fonts and resource entries in hash-map order, which
    /// changes from process to process (the thread's hash keys are drawn
    /// once): converted in fresh threads, one SVG gives one PDF; and the
    /// canonical form is a PDF whose cross-reference offsets point at its
    /// objects.
    #[test]
    fn one_svg_gives_one_pdf() {
        let mut svg = String::from(
            r#"<svg width="300" height="200" viewBox="0 0 300 200" xmlns="http://www.w3.org/2000/svg">"#,
        );
        for i in 0..12 {
            svg.push_str(&format!(
                r#"<rect x="{}" y="10" width="20" height="20" fill="rgb({},0,0)" fill-opacity="0.{}"/>"#,
                20 * i,
                20 * i,
                i % 9 + 1
            ));
        }
        svg.push_str(
            r#"<text x="10" y="80" font-family="sans-serif" font-size="20">regular</text>"#,
        );
        svg.push_str(r#"<text x="10" y="120" font-family="sans-serif" font-weight="bold" font-size="16">bold</text></svg>"#);
        let pdfs: Vec<Vec<u8>> = (0..6)
            .map(|_| {
                let s = svg.clone();
                std::thread::spawn(move || svg_to_pdf(&s, "t.pdf").unwrap())
                    .join()
                    .unwrap()
            })
            .collect();
        assert!(pdfs.iter().all(|p| *p == pdfs[0]));
        assert!(
            pdfs[0].ends_with(b">>\nstartxref\n") || {
                let t = String::from_utf8_lossy(&pdfs[0]);
                t.contains(">>\nstartxref\n") && t.ends_with("%%EOF")
            }
        );
        // Every xref offset points at `N 0 obj` with its own number.
        let p = &pdfs[0];
        let text = String::from_utf8_lossy(p);
        let sx: usize = text
            .rsplit("startxref")
            .next()
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let table = &text[sx..];
        for (k, line) in table
            .lines()
            .skip(3)
            .take_while(|l| l.ends_with(" n"))
            .enumerate()
        {
            let off: usize = line[..10].parse().unwrap();
            let head = format!("{} 0 obj", k + 1);
            assert!(
                p[off..].starts_with(head.as_bytes()),
                "object {} at {off}",
                k + 1
            );
        }
    }
}

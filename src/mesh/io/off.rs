//! OFF reader and writer (Geomview Object File Format, text variant).
//!
//! Accepted: an `OFF`, `COFF`, `NOFF`, `CNOFF` or `STOFF`-style first keyword
//! (only the first three numbers of a vertex line are used, so colours,
//! normals and texture coordinates are ignored), the counts either on the
//! keyword line or on the next line, `#` comments anywhere, faces as
//! `n i1 … in [colour…]` with `n ≥ 3` (polygons are fan-triangulated), zero-based
//! indices. Rejected with an error: binary OFF, `4OFF` / `nOFF` (other
//! dimensions), and files whose data disagree with the counts.

use std::fmt::Write as _;
use std::path::Path;

use super::text::{capped, content_lines, fan, line_loc, parse_count, parse_point, read_text};
use crate::mesh::{Mesh, RawMesh};
use crate::{Error, Result};

pub(super) fn read_off(path: &Path) -> Result<RawMesh> {
    parse_off(path, &read_text(path)?)
}

/// Parses the text of an OFF file; `path` only names it in messages.
pub(super) fn parse_off(path: &Path, text: &str) -> Result<RawMesh> {
    let mut lines = content_lines(text);
    let (kline, first) = lines
        .next()
        .ok_or_else(|| Error::parse(path, "header", "empty file: expected 'OFF'"))?;
    let mut toks = first.split_ascii_whitespace();
    let keyword = toks.next().unwrap_or("");
    let upper = keyword.to_ascii_uppercase();
    let known = upper
        .strip_suffix("OFF")
        .is_some_and(|p| p.chars().all(|c| matches!(c, 'C' | 'N' | 'S' | 'T')));
    if !known {
        return Err(Error::parse(
            path,
            line_loc(kline),
            format!("expected the keyword 'OFF' (or COFF/NOFF), found '{keyword}'"),
        ));
    }
    if toks
        .clone()
        .next()
        .is_some_and(|t| t.eq_ignore_ascii_case("BINARY"))
    {
        return Err(Error::parse(
            path,
            line_loc(kline),
            "binary OFF is not supported",
        ));
    }
    // Counts: on the keyword line, or on the next content line.
    let rest: Vec<&str> = toks.collect();
    let (cline, counts) = if rest.is_empty() {
        let (l, s) = lines.next().ok_or_else(|| {
            Error::parse(
                path,
                "header",
                "file ends before the vertex and face counts",
            )
        })?;
        (l, s.split_ascii_whitespace().collect::<Vec<_>>())
    } else {
        (kline, rest)
    };
    if counts.len() < 2 {
        return Err(Error::parse(
            path,
            line_loc(cline),
            "expected 'vertices faces [edges]' counts",
        ));
    }
    let nv = parse_count(path, cline, counts[0], "vertex count")?;
    let nf = parse_count(path, cline, counts[1], "face count")?;

    let mut vertices = Vec::with_capacity(capped(nv));
    for i in 0..nv {
        let (l, s) = lines.next().ok_or_else(|| {
            Error::parse(
                path,
                format!("vertex {i}"),
                format!("file ends after {i} of the {nv} vertices announced in the header"),
            )
        })?;
        vertices.push(parse_point(
            path,
            l,
            s.split_ascii_whitespace(),
            &format!("vertex {i}"),
        )?);
    }
    let mut faces = Vec::with_capacity(capped(nf));
    let mut polygon = Vec::new();
    for i in 0..nf {
        let (l, s) = lines.next().ok_or_else(|| {
            Error::parse(
                path,
                format!("face {i}"),
                format!("file ends after {i} of the {nf} faces announced in the header"),
            )
        })?;
        let mut toks = s.split_ascii_whitespace();
        let n = parse_count(
            path,
            l,
            toks.next().unwrap_or(""),
            &format!("face {i} size"),
        )?;
        if n < 3 {
            return Err(Error::parse(
                path,
                line_loc(l),
                format!("face {i} has {n} corners; at least 3 are needed"),
            ));
        }
        polygon.clear();
        for k in 0..n {
            let tok = toks.next().ok_or_else(|| {
                Error::parse(
                    path,
                    line_loc(l),
                    format!("face {i} announces {n} corners but lists {k}"),
                )
            })?;
            polygon.push(parse_count(path, l, tok, &format!("face {i} index"))?);
        }
        // Anything after the indices is a per-face colour: ignored.
        fan(&polygon, &mut faces);
    }
    if let Some((l, _)) = lines.next() {
        return Err(Error::parse(
            path,
            line_loc(l),
            format!(
                "unexpected data after the {nv} vertices and {nf} faces announced in the header"
            ),
        ));
    }
    Ok(RawMesh { vertices, faces })
}

/// Writes `mesh` as ASCII OFF (`OFF`, counts line, `x y z` lines, `3 a b c`
/// lines). Coordinates use Rust's shortest round-trip formatting, so reading
/// the file back gives the same `f64` values.
pub(super) fn off_bytes(mesh: &Mesh) -> Vec<u8> {
    let mut s = String::with_capacity(40 * mesh.n_vertices() + 20 * mesh.n_faces() + 32);
    // Writing to a String cannot fail; the results are ignored on purpose.
    let _ = writeln!(s, "OFF\n{} {} 0", mesh.n_vertices(), mesh.n_faces());
    for p in mesh.vertices() {
        let _ = writeln!(s, "{:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for f in mesh.faces() {
        let _ = writeln!(s, "3 {} {} {}", f[0], f[1], f[2]);
    }
    s.into_bytes()
}

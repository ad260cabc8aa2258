//! TOSCA `.vert` + `.tri` text pairs.
//!
//! `name.vert` holds one vertex per line (three numbers), `name.tri` one
//! triangle per line as three **one-based** vertex indices (the TOSCA
//! high-resolution release was written from MATLAB). The sample data of this
//! project (`shared/data/tosca`) ships only `.off` files, so the index base
//! could not be checked against a real pair; an index 0 is therefore reported
//! as an error naming the line rather than silently shifted.

use std::path::{Path, PathBuf};

use super::text::{content_lines, line_loc, parse_count, parse_point, read_text};
use crate::mesh::RawMesh;
use crate::{Error, Result};

/// The `.vert` and `.tri` paths for either member of a pair.
fn pair(path: &Path) -> (PathBuf, PathBuf) {
    (path.with_extension("vert"), path.with_extension("tri"))
}

pub(super) fn read_vert_tri(path: &Path) -> Result<RawMesh> {
    let (vert, tri) = pair(path);
    for (p, other) in [(&vert, &tri), (&tri, &vert)] {
        if let Some(why) = super::path_problem(p) {
            let why = if why == "does not exist" {
                "is missing".to_string()
            } else {
                why
            };
            return Err(Error::parse(
                other,
                "file",
                format!(
                    "the matching file {} of this TOSCA .vert/.tri pair {why}",
                    p.display()
                ),
            ));
        }
    }
    parse_vert_tri(&vert, &read_text(&vert)?, &tri, &read_text(&tri)?)
}

/// Parses the texts of a `.vert` and a `.tri` file; the paths only name them
/// in messages.
pub(super) fn parse_vert_tri(
    vert: &Path,
    vert_text: &str,
    tri: &Path,
    tri_text: &str,
) -> Result<RawMesh> {
    let mut vertices = Vec::new();
    for (l, s) in content_lines(vert_text) {
        let mut toks = s.split_ascii_whitespace();
        let what = format!("vertex {}", vertices.len());
        vertices.push(parse_point(vert, l, toks.by_ref(), &what)?);
        if toks.next().is_some() {
            return Err(Error::parse(
                vert,
                line_loc(l),
                format!("{what}: more than 3 numbers on the line"),
            ));
        }
    }
    let mut faces = Vec::new();
    for (l, s) in content_lines(tri_text) {
        let what = format!("face {}", faces.len());
        let toks: Vec<&str> = s.split_ascii_whitespace().collect();
        if toks.len() != 3 {
            return Err(Error::parse(
                tri,
                line_loc(l),
                format!("{what}: expected 3 vertex indices, found {}", toks.len()),
            ));
        }
        let mut f = [0usize; 3];
        for (slot, tok) in f.iter_mut().zip(&toks) {
            // MATLAB writes integers as e.g. "12" but sometimes "12.0000".
            let idx = match parse_count(tri, l, tok, &what) {
                Ok(i) => i,
                Err(e) => match tok.parse::<f64>() {
                    Ok(x) if x.fract() == 0.0 && (0.0..1e15).contains(&x) => x as usize,
                    _ => return Err(e),
                },
            };
            if idx == 0 {
                return Err(Error::parse(
                    tri,
                    line_loc(l),
                    format!("{what}: index 0, but .tri indices are one-based"),
                ));
            }
            *slot = idx - 1;
        }
        faces.push(f);
    }
    Ok(RawMesh { vertices, faces })
}

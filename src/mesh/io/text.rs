//! Helpers shared by the line-oriented text readers (OFF, OBJ, TOSCA).

use std::path::Path;

use crate::mesh::Face;
use crate::{Error, Point, Result};

/// Reads a whole text file (a regular file, see
/// [`super::read_input_file`]). Bytes that are not UTF-8 become U+FFFD, so
/// they surface as a parse error on the line where they occur rather than
/// as a whole-file failure.
pub(super) fn read_text(path: &Path) -> Result<String> {
    let bytes = super::read_input_file(path)?;
    Ok(decode_text(&bytes))
}

/// The UTF-8 byte-order mark some editors write at the start of a file.
const BOM: &[u8] = b"\xEF\xBB\xBF";

/// `bytes` without a leading UTF-8 byte-order mark.
pub(super) fn strip_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(BOM).unwrap_or(bytes)
}

/// The text of a file's bytes without a leading byte-order mark, invalid
/// UTF-8 replaced by U+FFFD (see [`read_text`]).
pub(super) fn decode_text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(strip_bom(bytes)).into_owned()
}

/// Non-empty lines with `#` comments removed, with their one-based line
/// numbers.
pub(super) fn content_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().filter_map(|(i, l)| {
        let l = match l.find('#') {
            Some(k) => &l[..k],
            None => l,
        };
        let l = l.trim();
        (!l.is_empty()).then_some((i + 1, l))
    })
}

/// `line N` as an error location.
pub(super) fn line_loc(line: usize) -> String {
    format!("line {line}")
}

/// Parses a coordinate token; `nan` and `inf` are accepted (the defect report
/// and [`crate::Mesh::new`] deal with them), anything else that is not a
/// number is an error.
pub(super) fn parse_coord(path: &Path, line: usize, tok: &str, what: &str) -> Result<f64> {
    tok.parse::<f64>().map_err(|_| {
        Error::parse(
            path,
            line_loc(line),
            format!("{what}: '{tok}' is not a number"),
        )
    })
}

/// Parses three coordinates from the first three tokens; extra tokens are
/// ignored (colours, normals, w).
pub(super) fn parse_point<'a>(
    path: &Path,
    line: usize,
    mut toks: impl Iterator<Item = &'a str>,
    what: &str,
) -> Result<Point> {
    let mut c = [0.0; 3];
    for (k, slot) in c.iter_mut().enumerate() {
        let tok = toks.next().ok_or_else(|| {
            Error::parse(
                path,
                line_loc(line),
                format!("{what}: expected 3 coordinates, found {k}"),
            )
        })?;
        *slot = parse_coord(path, line, tok, what)?;
    }
    Ok(Point::new(c[0], c[1], c[2]))
}

/// Parses a non-negative integer token.
pub(super) fn parse_count(path: &Path, line: usize, tok: &str, what: &str) -> Result<usize> {
    tok.parse::<usize>().map_err(|_| {
        Error::parse(
            path,
            line_loc(line),
            format!("{what}: '{tok}' is not a non-negative integer"),
        )
    })
}

/// Appends the fan triangulation `(p0, p_k, p_{k+1})` of a polygon. The
/// caller guarantees at least three corners.
pub(super) fn fan(polygon: &[usize], faces: &mut Vec<Face>) {
    for k in 1..polygon.len().saturating_sub(1) {
        faces.push([polygon[0], polygon[k], polygon[k + 1]]);
    }
}

/// Capacity to reserve for a count announced by a file header: never more
/// than a modest bound, so a header that lies (4e9 vertices) cannot make us
/// allocate before the data proves it exists.
pub(super) fn capped(count: usize) -> usize {
    count.min(1 << 16)
}

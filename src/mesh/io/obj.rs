//! Wavefront OBJ reader and writer.
//!
//! Read: `v x y z [w | r g b]` (extra numbers ignored), `f` with corners
//! written `a`, `a/b`, `a//c` or `a/b/c` (only the vertex index `a` is used),
//! one-based or negative (relative: `-1` is the last vertex defined so far)
//! indices, polygons fan-triangulated, `#` comments. Every other statement
//! (`vn`, `vt`, `g`, `o`, `s`, `usemtl`, `mtllib`, `l`, `p`, …) is ignored.
//! A positive index beyond the vertex list is kept (the defect report names
//! it); an index 0 or a relative index before the first vertex is an error.

use std::fmt::Write as _;
use std::path::Path;

use super::text::{content_lines, fan, line_loc, parse_point, read_text};
use super::write_atomic;
use crate::mesh::{Mesh, RawMesh};
use crate::{Error, Result};

pub(super) fn read_obj(path: &Path) -> Result<RawMesh> {
    parse_obj(path, &read_text(path)?)
}

/// Parses the text of an OBJ file; `path` only names it in messages.
pub(super) fn parse_obj(path: &Path, text: &str) -> Result<RawMesh> {
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    let mut polygon = Vec::new();
    for (l, s) in content_lines(text) {
        let mut toks = s.split_ascii_whitespace();
        match toks.next() {
            Some("v") => vertices.push(parse_point(path, l, toks, "vertex")?),
            Some("f") => {
                polygon.clear();
                for tok in toks {
                    let first = tok.split('/').next().unwrap_or("");
                    let idx: i64 = first.parse().map_err(|_| {
                        Error::parse(
                            path,
                            line_loc(l),
                            format!("face corner '{tok}' does not start with an integer index"),
                        )
                    })?;
                    let resolved = if idx > 0 {
                        usize::try_from(idx - 1).ok()
                    } else if idx < 0 {
                        usize::try_from(vertices.len() as i64 + idx).ok()
                    } else {
                        None
                    };
                    let resolved = resolved.ok_or_else(|| {
                        Error::parse(
                            path,
                            line_loc(l),
                            format!(
                                "face index {idx} does not name a vertex ({} defined so far; \
                                 OBJ indices start at 1, negative ones count back)",
                                vertices.len()
                            ),
                        )
                    })?;
                    polygon.push(resolved);
                }
                if polygon.len() < 3 {
                    return Err(Error::parse(
                        path,
                        line_loc(l),
                        format!("face has {} corners; at least 3 are needed", polygon.len()),
                    ));
                }
                fan(&polygon, &mut faces);
            }
            _ => {}
        }
    }
    Ok(RawMesh { vertices, faces })
}

/// OBJ text for `mesh`: `v` lines with shortest round-trip decimal
/// representation, then one-based `f` lines.
pub(super) fn obj_text(mesh: &Mesh) -> String {
    let mut s = String::with_capacity(40 * mesh.n_vertices() + 24 * mesh.n_faces() + 64);
    s.push_str("# written by deformlab\n");
    for p in mesh.vertices() {
        let _ = writeln!(s, "v {:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for f in mesh.faces() {
        let _ = writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    s
}

pub(super) fn write_obj(path: &Path, mesh: &Mesh) -> Result<()> {
    write_atomic(path, obj_text(mesh).as_bytes())
}

//! Mesh file formats: PLY (ascii, binary little/big endian), OFF, OBJ, TOSCA
//! `.vert` + `.tri` pairs; writers for binary PLY and OBJ.
//!
//! Readers return a [`RawMesh`] so that defects can be reported;
//! [`read_mesh`] also validates into a [`Mesh`]. Every error names the file.

//!
//! | format | read | write | notes |
//! |---|---|---|---|
//! | `.ply` | ascii, binary LE/BE (via `ply-rs-bw`) | binary LE, f64 (+ float per-vertex scalars, [`write_ply_with`]) | any scalar types, extra properties skipped ([`read_ply_vertex_scalar`] reads one) |
//! | `.off` | text (OFF/COFF/NOFF) | — | zero-based indices |
//! | `.obj` | `v` and `f` | yes | one-based or negative indices |
//! | `.vert`+`.tri` | TOSCA text pair | — | one-based `.tri` indices |
//!
//! Polygons are fan-triangulated on reading. Counts announced by headers are
//! never trusted for allocation. Indices beyond the vertex list are kept in the
//! [`RawMesh`] (so [`super::validate::DefectReport`] can describe them) and
//! rejected by [`read_mesh`]; anything that cannot be represented (negative or
//! zero OBJ index, non-number token, data that disagree with header counts)
//! is an [`Error::Parse`] naming the file and the line or element.
//!
//! Only regular files (or symbolic links to them) are read, up to the size
//! they have when opened ([`read_input_file`]): a FIFO, a device such as
//! `/dev/zero` or a folder given as a mesh is an error naming the path, not
//! a read that blocks or never ends.

mod obj;
mod off;
mod ply;
pub mod temp;
mod text;
mod tosca;

use std::io::Write;
use std::path::Path;

use super::{Mesh, RawMesh};
use crate::{Error, Result};

/// Mesh file formats known to [`read_raw`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Ply,
    Off,
    Obj,
    /// TOSCA `.vert` + `.tri` pair.
    VertTri,
}

impl Format {
    /// The format named by the extension of `path` (case-insensitive).
    pub fn of_path(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "ply" => Format::Ply,
            "off" => Format::Off,
            "obj" => Format::Obj,
            "vert" | "tri" => Format::VertTri,
            _ => return None,
        })
    }
}

/// What kind of file system object `path` is, when it is not a regular
/// file (after following symbolic links); `None` for a regular file.
fn not_regular(meta: &std::fs::Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        return None;
    }
    if t.is_dir() {
        return Some("a folder");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if t.is_char_device() {
            return Some("a character device");
        }
        if t.is_block_device() {
            return Some("a block device");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a regular file")
}

/// Errors (naming the path) unless `path` is a regular file or a symbolic
/// link to one: a FIFO would block a reader forever, a device (e.g.
/// `/dev/zero`) never ends, a folder has no content. Returns the file's
/// size.
pub fn check_regular_file(path: &Path) -> Result<u64> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    match not_regular(&meta) {
        None => Ok(meta.len()),
        Some(kind) => Err(Error::parse(
            path,
            "file",
            format!(
                "is {kind}, not a regular file; only regular files (or links to them) are read"
            ),
        )),
    }
}

/// Why an input path cannot be used, in the system's words: `None` when
/// it can be looked up; "does not exist" when nothing is there; else the
/// system's reason (a loop of symbolic links, no permission to search a
/// folder on the way), which a plain existence test would also call
/// missing.
pub fn path_problem(path: &Path) -> Option<String> {
    match std::fs::metadata(path) {
        Ok(_) => None,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Some("does not exist".to_string()),
        Err(e) => Some(format!("cannot be opened: {e}")),
    }
}

/// The bytes of an input file: a regular file (or a link to one, see
/// [`check_regular_file`]), read up to the size it had when opened (a file
/// that grows meanwhile is not followed).
pub fn read_input_file(path: &Path) -> Result<Vec<u8>> {
    use std::io::Read;
    let len = check_regular_file(path)?;
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    // The object opened may differ from the one checked (a race): check it.
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if let Some(kind) = not_regular(&meta) {
        return Err(Error::parse(
            path,
            "file",
            format!("is {kind}, not a regular file"),
        ));
    }
    let len = len.min(meta.len());
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0).min(1 << 30));
    file.take(len)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    Ok(bytes)
}

/// The text of an input file ([`read_input_file`]) as UTF-8, without a
/// leading byte-order mark; invalid UTF-8 is an error naming the path and
/// the byte offset.
pub fn read_input_text(path: &Path) -> Result<String> {
    let bytes = read_input_file(path)?;
    let bytes = text::strip_bom(&bytes);
    std::str::from_utf8(bytes).map(str::to_string).map_err(|e| {
        Error::parse(
            path,
            format!("byte {}", e.valid_up_to()),
            "not valid UTF-8 text",
        )
    })
}

/// Reads any supported format, chosen by extension (`.ply`, `.off`, `.obj`,
/// `.vert` or `.tri` for a TOSCA pair; either member of a pair names it).
pub fn read_raw(path: &Path) -> Result<RawMesh> {
    match Format::of_path(path) {
        Some(Format::Ply) => ply::read_ply(path),
        Some(Format::Off) => off::read_off(path),
        Some(Format::Obj) => obj::read_obj(path),
        Some(Format::VertTri) => tosca::read_vert_tri(path),
        None => Err(Error::parse(
            path,
            "file name",
            "unknown mesh format (expected extension .ply, .off, .obj, .vert or .tri)",
        )),
    }
}

/// Parses the bytes of a single-file mesh (`Ply`, `Off` or `Obj`) without
/// touching the file system; `name` only names the input in messages. A
/// TOSCA pair needs two files: use [`parse_vert_tri`].
pub fn parse_raw(format: Format, bytes: &[u8], name: &Path) -> Result<RawMesh> {
    match format {
        Format::Ply => ply::parse_ply(name, text::strip_bom(bytes)),
        Format::Off => off::parse_off(name, &text::decode_text(bytes)),
        Format::Obj => obj::parse_obj(name, &text::decode_text(bytes)),
        Format::VertTri => Err(Error::invalid(format!(
            "{}: a TOSCA .vert/.tri pair is two files; parse it with parse_vert_tri",
            name.display()
        ))),
    }
}

/// Parses the bytes of a TOSCA `.vert` file and its `.tri` file (named
/// `name.vert` and `name.tri` in messages) without touching the file system.
pub fn parse_vert_tri(vert: &[u8], tri: &[u8], name: &Path) -> Result<RawMesh> {
    tosca::parse_vert_tri(
        &name.with_extension("vert"),
        &text::decode_text(vert),
        &name.with_extension("tri"),
        &text::decode_text(tri),
    )
}

/// Reads and validates a mesh (indices in range, finite coordinates); errors
/// name the file. (Any finite size is read, so files round-trip exactly;
/// the algorithms refuse meshes outside [`super::EXTENT_RANGE`].)
pub fn read_mesh(path: &Path) -> Result<Mesh> {
    let raw = read_raw(path)?;
    Mesh::try_from(raw).map_err(|e| match e {
        Error::InvalidInput(msg) => Error::parse(path, "mesh", msg),
        other => other,
    })
}

/// Writes a binary little-endian PLY (float64 vertices, uchar/int32 faces).
/// Writes to a temporary file beside `path` and renames it, so a reader never
/// sees a half-written mesh.
pub fn write_ply(path: &Path, mesh: &Mesh) -> Result<()> {
    write_ply_with(path, mesh, &[])
}

/// [`write_ply`] with per-vertex scalar properties after `x y z`, each
/// `(name, one value per vertex)`, stored as `float` (32-bit): e.g. an
/// `error` that MeshLab, Polyscope or trimesh can colour by. Errors if a
/// list's length is not the vertex count or a name is not a plain
/// identifier (or is `x`, `y`, `z`). [`read_mesh`] skips such properties;
/// [`read_ply_vertex_scalar`] reads one back.
pub fn write_ply_with(path: &Path, mesh: &Mesh, scalars: &[(&str, &[f64])]) -> Result<()> {
    let n = mesh.n_vertices();
    for (name, values) in scalars {
        let plain = !name.is_empty()
            && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
            && !matches!(*name, "x" | "y" | "z");
        if !plain {
            return Err(Error::invalid(format!(
                "{}: {name:?} is not a usable PLY property name",
                path.display()
            )));
        }
        if values.len() != n {
            return Err(Error::invalid(format!(
                "{}: property {name} has {} values for {n} vertices",
                path.display(),
                values.len()
            )));
        }
    }
    let mut buf: Vec<u8> =
        Vec::with_capacity((24 + 4 * scalars.len()) * n + 13 * mesh.n_faces() + 256);
    write!(
        buf,
        "ply\nformat binary_little_endian 1.0\ncomment written by deformlab\n\
         element vertex {n}\nproperty double x\nproperty double y\nproperty double z\n"
    )
    .expect("writing to a Vec cannot fail");
    for (name, _) in scalars {
        writeln!(buf, "property float {name}").expect("writing to a Vec cannot fail");
    }
    write!(
        buf,
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.n_faces()
    )
    .expect("writing to a Vec cannot fail");
    for (i, p) in mesh.vertices().iter().enumerate() {
        for c in [p.x, p.y, p.z] {
            buf.extend_from_slice(&c.to_le_bytes());
        }
        for (_, values) in scalars {
            buf.extend_from_slice(&(values[i] as f32).to_le_bytes());
        }
    }
    for f in mesh.faces() {
        buf.push(3);
        for &i in f {
            let i = i32::try_from(i)
                .map_err(|_| Error::invalid(format!("vertex index {i} too large for PLY")))?;
            buf.extend_from_slice(&i.to_le_bytes());
        }
    }
    write_atomic(path, &buf)
}

/// The per-vertex scalar property `name` of a PLY file (any encoding and
/// scalar type, as `f64`), or `None` when its vertex element has no such
/// property. Errors as [`read_mesh`] does on a malformed file.
pub fn read_ply_vertex_scalar(path: &Path, name: &str) -> Result<Option<Vec<f64>>> {
    let bytes = read_input_file(path)?;
    ply::parse_vertex_scalar(path, text::strip_bom(&bytes), name)
}

/// Writes a Wavefront OBJ (`v` and one-based `f` lines, coordinates in the
/// shortest decimal form that reads back to the same `f64`), atomically like
/// [`write_ply`].
pub fn write_obj(path: &Path, mesh: &Mesh) -> Result<()> {
    obj::write_obj(path, mesh)
}

/// Writes ASCII OFF (exact `f64` round trip), atomically.
pub fn write_off(path: &Path, mesh: &Mesh) -> Result<()> {
    write_atomic(path, &off::off_bytes(mesh))
}

/// Writes `bytes` to `path` through a temporary file of this process
/// ([`temp`]: dot-prefixed, removed if the write fails) and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = temp::write_temp(path, bytes, false)?;
    temp::commit(&tmp, path)
}

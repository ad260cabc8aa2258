//! A minimal OFF writer (ASCII, triangles), for TOSCA-style synthetic data.
//! Reading OFF is `mesh::io`'s job.

use std::fmt::Write as _;
use std::path::Path;

use crate::mesh::io::write_atomic;
use crate::mesh::Mesh;
use crate::Result;

/// Writes `mesh` as ASCII OFF (`OFF`, counts line, `x y z` lines, `3 a b c`
/// lines). Coordinates use Rust's shortest round-trip formatting, so reading
/// the file back gives the same `f64` values. Atomic (temporary file +
/// rename).
pub fn write_off(path: &Path, mesh: &Mesh) -> Result<()> {
    let mut s = String::with_capacity(40 * mesh.n_vertices() + 20 * mesh.n_faces() + 32);
    // Writing to a String cannot fail; the results are ignored on purpose.
    let _ = writeln!(s, "OFF\n{} {} 0", mesh.n_vertices(), mesh.n_faces());
    for p in mesh.vertices() {
        let _ = writeln!(s, "{:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for f in mesh.faces() {
        let _ = writeln!(s, "3 {} {} {}", f[0], f[1], f[2]);
    }
    write_atomic(path, s.as_bytes())
}

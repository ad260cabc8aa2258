//! Edges, adjacency and areas.

use crate::mesh::Mesh;
use crate::Point;

/// Unique undirected edges `(i, j)` with `i < j`, sorted.
pub fn edges(mesh: &Mesh) -> Vec<(usize, usize)> {
    let mut e: Vec<(usize, usize)> = mesh
        .faces()
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .map(|(i, j)| (i.min(j), i.max(j)))
        .collect();
    e.sort_unstable();
    e.dedup();
    e
}

/// Area of every face.
pub fn face_areas(mesh: &Mesh) -> Vec<f64> {
    let v = mesh.vertices();
    mesh.faces()
        .iter()
        .map(|&[a, b, c]| 0.5 * (v[b] - v[a]).cross(&(v[c] - v[a])).norm())
        .collect()
}

/// Total surface area.
pub fn total_area(mesh: &Mesh) -> f64 {
    face_areas(mesh).iter().sum()
}

/// Closest point to `p` on triangle `(a, b, c)` (Voronoi regions of the
/// triangle: corners, edges, interior).
pub fn closest_point_on_triangle(p: &Point, a: &Point, b: &Point, c: &Point) -> Point {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return b + (c - b) * w;
    }
    let denom = va + vb + vc;
    if denom.abs() < f64::MIN_POSITIVE {
        return *a;
    }
    a + ab * (vb / denom) + ac * (vc / denom)
}

//! Edges, adjacency and areas.

use crate::mesh::Mesh;

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

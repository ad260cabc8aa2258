//! Vertex and edge adjacency in compressed-row form, and boundary detection.
//!
//! All lists are sorted and free of duplicates, so results do not depend on
//! face order beyond the face indices themselves. A face with a repeated
//! vertex (e.g. `[a, a, b]`) contributes no self-loop `(a, a)`; its other edge
//! is kept.

use super::counts::{count, Counted};
use crate::mesh::Mesh;

/// A list of sorted index lists in compressed-row (CSR-like) form: row `i`
/// is `indices[offsets[i]..offsets[i + 1]]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Csr {
    offsets: Vec<usize>,
    indices: Vec<usize>,
}

impl Csr {
    /// Builds rows from `(row, index)` pairs; each row is sorted and
    /// deduplicated. Pairs with `row >= n_rows` are ignored.
    fn from_pairs(n_rows: usize, mut pairs: Vec<(usize, usize)>) -> Self {
        pairs.retain(|&(r, _)| r < n_rows);
        pairs.sort_unstable();
        pairs.dedup();
        let mut offsets = vec![0usize; n_rows + 1];
        for &(r, _) in &pairs {
            offsets[r + 1] += 1;
        }
        for r in 0..n_rows {
            offsets[r + 1] += offsets[r];
        }
        let indices = pairs.into_iter().map(|(_, c)| c).collect();
        Csr { offsets, indices }
    }

    /// Number of rows.
    pub fn n_rows(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Total number of stored indices.
    pub fn nnz(&self) -> usize {
        self.indices.len()
    }

    /// Row `i` (sorted, no duplicates), or `None` if `i` is out of range.
    pub fn get(&self, i: usize) -> Option<&[usize]> {
        let (&a, &b) = (self.offsets.get(i)?, self.offsets.get(i + 1)?);
        Some(&self.indices[a..b])
    }

    /// Row `i`. Panics if `i >= n_rows()`, like slice indexing; use
    /// [`Csr::get`] for a checked lookup.
    pub fn row(&self, i: usize) -> &[usize] {
        &self.indices[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Row start offsets (`n_rows() + 1` entries, starting at 0).
    pub fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// All indices, row after row.
    pub fn indices(&self) -> &[usize] {
        &self.indices
    }

    /// Iterator over the rows.
    pub fn rows(&self) -> impl ExactSizeIterator<Item = &[usize]> + '_ {
        self.offsets.windows(2).map(|w| &self.indices[w[0]..w[1]])
    }
}

/// Vertex → neighbouring vertices (the 1-ring), sorted, one row per vertex.
/// Vertices not used by any face have an empty row.
pub fn vertex_neighbours(mesh: &Mesh) -> Csr {
    count(Counted::Neighbours);
    let mut pairs = Vec::with_capacity(mesh.n_faces() * 6);
    for &[a, b, c] in mesh.faces() {
        for (i, j) in [(a, b), (b, c), (c, a)] {
            if i != j {
                pairs.push((i, j));
                pairs.push((j, i));
            }
        }
    }
    Csr::from_pairs(mesh.n_vertices(), pairs)
}

/// Vertex → incident faces (face indices, sorted), one row per vertex.
pub fn vertex_faces(mesh: &Mesh) -> Csr {
    count(Counted::IncidentFaces);
    let pairs = mesh
        .faces()
        .iter()
        .enumerate()
        .flat_map(|(fi, f)| f.iter().map(move |&v| (v, fi)))
        .collect();
    Csr::from_pairs(mesh.n_vertices(), pairs)
}

/// Undirected edges with the faces that contain them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EdgeFaces {
    /// Unique edges `(i, j)`, `i < j`, sorted (the same list as
    /// [`crate::ops::edges`] minus self-loops of faces with a repeated vertex).
    pub edges: Vec<(usize, usize)>,
    /// Row `e` lists the faces containing `edges[e]`: one for a boundary edge,
    /// two for an interior manifold edge, more for a non-manifold edge.
    pub faces: Csr,
}

impl EdgeFaces {
    /// Index of the edge between `i` and `j` (either order), if present.
    pub fn edge_index(&self, i: usize, j: usize) -> Option<usize> {
        self.edges.binary_search(&(i.min(j), i.max(j))).ok()
    }

    /// Edges with exactly one incident face, sorted.
    pub fn boundary_edges(&self) -> Vec<(usize, usize)> {
        self.edges_with(|k| k == 1)
    }

    /// Edges with three or more incident faces, sorted.
    pub fn non_manifold_edges(&self) -> Vec<(usize, usize)> {
        self.edges_with(|k| k > 2)
    }

    fn edges_with(&self, keep: impl Fn(usize) -> bool) -> Vec<(usize, usize)> {
        self.edges
            .iter()
            .zip(self.faces.rows())
            .filter(|(_, f)| keep(f.len()))
            .map(|(&e, _)| e)
            .collect()
    }
}

/// Edge → faces adjacency.
pub fn edge_faces(mesh: &Mesh) -> EdgeFaces {
    let mut ef: Vec<((usize, usize), usize)> = Vec::with_capacity(mesh.n_faces() * 3);
    for (fi, &[a, b, c]) in mesh.faces().iter().enumerate() {
        for (i, j) in [(a, b), (b, c), (c, a)] {
            if i != j {
                ef.push(((i.min(j), i.max(j)), fi));
            }
        }
    }
    ef.sort_unstable();
    ef.dedup();
    let mut edges: Vec<(usize, usize)> = ef.iter().map(|&(e, _)| e).collect();
    edges.dedup();
    let mut pairs = Vec::with_capacity(ef.len());
    let mut k = 0usize;
    for (idx, &(e, f)) in ef.iter().enumerate() {
        if idx > 0 && ef[idx - 1].0 != e {
            k += 1;
        }
        pairs.push((k, f));
    }
    let faces = Csr::from_pairs(edges.len(), pairs);
    EdgeFaces { edges, faces }
}

/// Unique edges with exactly one incident face, sorted.
pub fn boundary_edges(mesh: &Mesh) -> Vec<(usize, usize)> {
    edge_faces(mesh).boundary_edges()
}

/// `true` for every vertex on a boundary edge.
pub fn boundary_vertices(mesh: &Mesh) -> Vec<bool> {
    let mut on = vec![false; mesh.n_vertices()];
    for (i, j) in boundary_edges(mesh) {
        on[i] = true;
        on[j] = true;
    }
    on
}

/// `true` if every edge has exactly two incident faces (closed and
/// edge-manifold).
pub fn is_closed(mesh: &Mesh) -> bool {
    edge_faces(mesh).faces.rows().all(|f| f.len() == 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::primitives::{grid, icosphere, torus};
    use crate::Point;

    #[test]
    fn icosahedron_adjacency() {
        let m = icosphere(0);
        let nb = vertex_neighbours(&m);
        assert_eq!(nb.n_rows(), 12);
        assert!(nb
            .rows()
            .all(|r| r.len() == 5 && r.windows(2).all(|w| w[0] < w[1])));
        let vf = vertex_faces(&m);
        assert!(vf.rows().all(|r| r.len() == 5));
        let ef = edge_faces(&m);
        assert_eq!(ef.edges.len(), 30);
        assert!(ef.faces.rows().all(|r| r.len() == 2));
        assert!(is_closed(&m));
        assert!(boundary_vertices(&m).iter().all(|&b| !b));
        assert_eq!(ef.edge_index(5, 0), ef.edge_index(0, 5));
        assert!(ef.edge_index(0, 3).is_none());
    }

    #[test]
    fn grid_boundary() {
        let (nx, ny) = (4, 3);
        let g = grid(nx, ny);
        let be = boundary_edges(&g);
        assert_eq!(be.len(), 2 * (nx + ny));
        let bv = boundary_vertices(&g);
        assert_eq!(bv.iter().filter(|&&b| b).count(), 2 * (nx + ny));
        // Interior vertex (1, 1) is not on the boundary.
        assert!(!bv[nx + 2]);
        assert!(!is_closed(&g));
        assert!(edge_faces(&g).non_manifold_edges().is_empty());
        assert!(is_closed(&torus(2.0, 0.5, 8, 6)));
    }

    #[test]
    fn non_manifold_and_repeated_vertex() {
        let v = vec![
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0, 0.0),
            Point::new(0.0, 1.0, 0.0),
            Point::new(0.0, -1.0, 0.0),
            Point::new(0.0, 0.0, 1.0),
            Point::new(5.0, 5.0, 5.0),
        ];
        let m = Mesh::new(v, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4], [2, 2, 4]]).unwrap();
        let ef = edge_faces(&m);
        assert_eq!(ef.non_manifold_edges(), vec![(0, 1)]);
        assert!(ef.edges.iter().all(|&(i, j)| i < j));
        let nb = vertex_neighbours(&m);
        assert_eq!(nb.row(2), &[0, 1, 4]);
        assert!(nb.row(5).is_empty());
        assert_eq!(vertex_faces(&m).row(2), &[0, 3]);
        assert!(nb.get(6).is_none());
    }
}

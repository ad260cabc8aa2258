//! The solvable part of a mesh: unreferenced vertices and tiny disconnected
//! parts dropped, with the map back to the original indices.
//!
//! Methods that need every vertex to carry area (mass matrices, Laplace–
//! Beltrami eigenfunctions, geodesic circles) fail on a vertex no face uses
//! ("vertex … has mass 0"), and a small loose part (a stray triangle, an
//! eyeball, a scanning artefact) gives the Laplacian an extra null vector
//! and breaks geodesic farthest-point sampling. [`SolvablePart::of`] keeps
//! the vertices of every face-connected part whose area is at least
//! `min_part_fraction` of the largest part's; [`SolvablePart::restrict`]
//! applies the same selection to another mesh of the same connectivity (a
//! pose of the class), and [`SolvablePart::expand`] maps per-vertex results
//! back to the original numbering (dropped vertices get a fill value).

use crate::mesh::{Face, Mesh};
use crate::{Error, Point, Result};

/// Default [`SolvablePart::of`] threshold: parts below 1 % of the largest
/// part's area are dropped.
pub const DEFAULT_MIN_PART_FRACTION: f64 = 0.01;

/// The kept vertices of a mesh and its compacted copy.
#[derive(Clone, Debug)]
pub struct SolvablePart {
    /// Original index of every kept vertex (increasing).
    pub kept: Vec<usize>,
    /// New index of every original vertex (`usize::MAX`: dropped).
    pub new_index: Vec<usize>,
    /// The faces of the kept part, in new indices.
    pub faces: Vec<Face>,
    /// Vertices no face references.
    pub unreferenced: usize,
    /// Vertices of dropped small parts.
    pub small_part_vertices: usize,
    /// Number of dropped small parts.
    pub small_parts: usize,
}

impl SolvablePart {
    /// The solvable part of `mesh` (see the module docs). Errors if the
    /// mesh has no face of positive area.
    pub fn of(mesh: &Mesh, min_part_fraction: f64) -> Result<Self> {
        if !(0.0..=1.0).contains(&min_part_fraction) {
            return Err(Error::invalid(format!(
                "the smallest kept part must be a fraction in [0, 1] of the largest, got \
                 {min_part_fraction}"
            )));
        }
        let n = mesh.n_vertices();
        let faces = mesh.faces();
        let mut parent: Vec<usize> = (0..n).collect();
        fn find(p: &mut [usize], mut x: usize) -> usize {
            while p[x] != x {
                p[x] = p[p[x]];
                x = p[x];
            }
            x
        }
        let mut referenced = vec![false; n];
        for f in faces {
            for &v in f {
                referenced[v] = true;
            }
            for (x, y) in [(f[0], f[1]), (f[1], f[2])] {
                let (rx, ry) = (find(&mut parent, x), find(&mut parent, y));
                if rx != ry {
                    parent[rx.max(ry)] = rx.min(ry);
                }
            }
        }
        let v = mesh.vertices();
        let mut part_area = vec![0.0; n];
        for f in faces {
            let a = 0.5 * (v[f[1]] - v[f[0]]).cross(&(v[f[2]] - v[f[0]])).norm();
            let r = find(&mut parent, f[0]);
            part_area[r] += a;
        }
        let largest = part_area.iter().cloned().fold(0.0, f64::max);
        if !(largest > 0.0 && largest.is_finite()) {
            return Err(Error::invalid(
                "the mesh has no face of positive finite area",
            ));
        }
        let mut keep = vec![false; n];
        let mut small_roots = std::collections::BTreeSet::new();
        let mut small_part_vertices = 0;
        for i in 0..n {
            if !referenced[i] {
                continue;
            }
            let r = find(&mut parent, i);
            if part_area[r] >= min_part_fraction * largest {
                keep[i] = true;
            } else {
                small_roots.insert(r);
                small_part_vertices += 1;
            }
        }
        let kept: Vec<usize> = (0..n).filter(|&i| keep[i]).collect();
        let mut new_index = vec![usize::MAX; n];
        for (k, &i) in kept.iter().enumerate() {
            new_index[i] = k;
        }
        let faces = faces
            .iter()
            .filter(|f| keep[f[0]])
            .map(|f| [new_index[f[0]], new_index[f[1]], new_index[f[2]]])
            .collect();
        Ok(SolvablePart {
            kept,
            new_index,
            faces,
            unreferenced: referenced.iter().filter(|r| !**r).count(),
            small_part_vertices,
            small_parts: small_roots.len(),
        })
    }

    /// Whether nothing was dropped.
    pub fn is_whole(&self) -> bool {
        self.kept.len() == self.new_index.len()
    }

    /// Number of dropped vertices.
    pub fn dropped(&self) -> usize {
        self.new_index.len() - self.kept.len()
    }

    /// `mesh` (same vertex count and faces as the mesh this part was made
    /// of) restricted to the kept part.
    pub fn restrict(&self, mesh: &Mesh) -> Result<Mesh> {
        if mesh.n_vertices() != self.new_index.len() {
            return Err(Error::invalid(format!(
                "a mesh of {} vertices cannot be restricted to a part of a {}-vertex mesh",
                mesh.n_vertices(),
                self.new_index.len()
            )));
        }
        let v = mesh.vertices();
        Mesh::new(
            self.kept.iter().map(|&i| v[i]).collect(),
            self.faces.clone(),
        )
    }

    /// Per-vertex values of the kept part in the original numbering;
    /// dropped vertices get `fill`.
    pub fn expand<T: Clone>(&self, values: &[T], fill: T) -> Result<Vec<T>> {
        if values.len() != self.kept.len() {
            return Err(Error::invalid(format!(
                "{} values for a part of {} vertices",
                values.len(),
                self.kept.len()
            )));
        }
        let mut out = vec![fill; self.new_index.len()];
        for (k, &i) in self.kept.iter().enumerate() {
            out[i] = values[k].clone();
        }
        Ok(out)
    }

    /// A one-line description of what was dropped (empty when nothing).
    pub fn describe(&self) -> String {
        if self.is_whole() {
            return String::new();
        }
        format!(
            "{} unreferenced vertices and {} vertices in {} small disconnected parts dropped \
             for the solve",
            self.unreferenced, self.small_part_vertices, self.small_parts
        )
    }
}

/// Positions of a kept part mapped back to the original numbering, dropped
/// vertices left where `original` has them.
pub fn expand_positions(
    part: &SolvablePart,
    positions: &[Point],
    original: &Mesh,
) -> Result<Vec<Point>> {
    let mut out = part.expand(positions, Point::origin())?;
    for (i, p) in out.iter_mut().enumerate() {
        if part.new_index[i] == usize::MAX {
            *p = original.vertices()[i];
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square_with_extras() -> Mesh {
        // Two triangles (unit square, area 1), one unreferenced vertex, and
        // a tiny triangle far away (area 5e-5).
        let v = vec![
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0, 0.0),
            Point::new(1.0, 1.0, 0.0),
            Point::new(0.0, 1.0, 0.0),
            Point::new(9.0, 9.0, 9.0),
            Point::new(5.0, 0.0, 0.0),
            Point::new(5.01, 0.0, 0.0),
            Point::new(5.0, 0.01, 0.0),
        ];
        Mesh::new(v, vec![[0, 1, 2], [0, 2, 3], [5, 6, 7]]).unwrap()
    }

    #[test]
    fn drops_unreferenced_vertices_and_tiny_parts_and_maps_back() {
        let m = square_with_extras();
        let p = SolvablePart::of(&m, DEFAULT_MIN_PART_FRACTION).unwrap();
        assert_eq!(p.kept, vec![0, 1, 2, 3]);
        assert_eq!(p.unreferenced, 1);
        assert_eq!(p.small_parts, 1);
        assert_eq!(p.small_part_vertices, 3);
        assert_eq!(p.dropped(), 4);
        let r = p.restrict(&m).unwrap();
        assert_eq!(r.n_vertices(), 4);
        assert_eq!(r.faces(), &[[0, 1, 2], [0, 2, 3]]);
        let back = p.expand(&[1, 2, 3, 4], 0).unwrap();
        assert_eq!(back, vec![1, 2, 3, 4, 0, 0, 0, 0]);
        let moved: Vec<Point> = r
            .vertices()
            .iter()
            .map(|q| q + nalgebra::Vector3::z())
            .collect();
        let full = expand_positions(&p, &moved, &m).unwrap();
        assert_eq!(full[2], Point::new(1.0, 1.0, 1.0));
        assert_eq!(full[4], m.vertices()[4]);
        assert!(!p.describe().is_empty());
        // Threshold 0 keeps the tiny part (not the unreferenced vertex).
        let all = SolvablePart::of(&m, 0.0).unwrap();
        assert_eq!(all.kept, vec![0, 1, 2, 3, 5, 6, 7]);
    }

    #[test]
    fn a_clean_mesh_is_whole_and_bad_input_errors() {
        let m = square_with_extras();
        let clean = Mesh::new(m.vertices()[..4].to_vec(), vec![[0, 1, 2], [0, 2, 3]]).unwrap();
        let p = SolvablePart::of(&clean, DEFAULT_MIN_PART_FRACTION).unwrap();
        assert!(p.is_whole());
        assert!(p.describe().is_empty());
        assert!(SolvablePart::of(&clean, 1.5).is_err());
        assert!(p.restrict(&m).is_err());
        assert!(p.expand(&[1.0], 0.0).is_err());
    }
}
